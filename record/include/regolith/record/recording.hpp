#pragma once
// What a `regolith run --record` file holds for tools that read it without replaying it: the
// deployment it ran (its YAML attachment) and single camera frames of the HAL recording
// (`regolith assess REC.mcap --frame N`). Errors are InputError naming the file, the channel and
// the frame.
#include <cstddef>
#include <filesystem>
#include <string>

#include <opencv2/core/mat.hpp>

#include "regolith/core/time.hpp"

namespace regolith::record {

/// The deployment recorded in `file`: its YAML attachment's text, and a name for messages (the
/// attachment's name beside the file). Empty text when the file carries none.
struct RecordedDeployment {
  std::string text;
  std::string name;
};
RecordedDeployment recorded_deployment(const std::filesystem::path& file);
class McapReader;
/// The same from a reader already open on `file` (a tool that also reads its messages opens it once).
RecordedDeployment recorded_deployment(McapReader& reader, const std::filesystem::path& file);

/// The latest device-sample stamp (process clock of the recording) among the readable HAL
/// messages of `reader`'s file (`/hal/...` channels; each message starts with a std_msgs/Header);
/// -1 when it has none. How long a recording lasted that was cut off before its end record
/// (`regolith_hal_end`) was written: a power loss, a full disk.
TimeNs last_hal_stamp(McapReader& reader);

struct RecordedFrame {
  std::string device;  ///< camera device id
  std::size_t index = 0;
  std::size_t count = 0;          ///< frames of that camera in the file
  std::uint32_t sequence = 0;     ///< the camera's frame sequence number
  TimeNs stamp = 0;               ///< capture time (process clock of the recording)
  cv::Mat image;                  ///< CV_8UC1 or CV_8UC3
  RecordedDeployment deployment;  ///< the deployment the recording ran (read from the same file)
};
/// Frame `index` (0 = first, in file order) of camera `device` (/hal/cameras/<device>/image); an
/// empty `device` picks the only camera recorded. InputError when the file has no such camera
/// (listing the ones it has), more than one and none chosen, or fewer frames.
RecordedFrame recorded_camera_frame(const std::filesystem::path& file, const std::string& device, std::size_t index);

}  // namespace regolith::record
