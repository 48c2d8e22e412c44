#pragma once
// Recorded drives on disk (the layout of the development set's `traverse/` scenes) and the files
// `regolith map` writes.
//
// Input directory:
//   input.json  camera {fx, fy, cx, cy, width, height, mount_height_m, pitch_deg, mount_x_m,
//               mount_y_m [, mount_yaw_deg, roll_deg]}, sun {azimuth_deg (from +y clockwise),
//               elevation_deg}, wheel {radius_m}
//   frames.csv  frame,file,t_s,odom_x_m,odom_y_m,odom_yaw_rad (wheel odometry, world frame)
//   frames/     the images (8-bit grey)
// Output directory: map.json, elevation.tiff, hazard.tiff (float32, NaN unknown, row 0 = smallest
// y), rocks.csv, odometry.csv (corrected poses; wheel_* columns beside them), overview.png.
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "regolith/direct_depth/direct_depth.hpp"
#include "regolith/mapping/drive_mapper.hpp"

namespace regolith::mapping {

struct DriveFrame {
  int index = 0;
  std::filesystem::path file;  ///< absolute (resolved against the drive directory)
  double t_s = 0.0;
  Pose2 odometry;  ///< wheel odometry (world)
  int line = 0;    ///< line in frames.csv
};

struct RecordedDrive {
  std::filesystem::path dir;
  direct_depth::CameraModel camera;
  CameraMount mount;
  double sun_azimuth_deg = 0.0;  ///< from +y (north) clockwise towards +x (east)
  double sun_elevation_deg = 0.0;
  double wheel_radius_m = 0.0;
  std::vector<DriveFrame> frames;
  /// Unit vector towards the sun in the world frame (x east, y north, z up).
  cv::Vec3d sun_world() const;
};

/// Reads input.json and frames.csv. A missing or bad field is an InputError naming the file and
/// the field; a bad frames.csv row names its line.
RecordedDrive read_drive(const std::filesystem::path& dir);

/// Writes `drive`'s description as `file` (input.json: camera, mount, sun, wheel), the inverse of
/// read_drive: a drive assembled elsewhere (e.g. from a HAL recording) becomes a drive directory
/// that `regolith map DIR` reads. InputError naming the file when it cannot be written.
void write_drive_description(const RecordedDrive& drive, const std::filesystem::path& file);

struct DriveMapSummary {
  DriveCounters counters;
  long skipped = 0;                  ///< frames not used (unreadable, wrong size, out of order)
  std::vector<std::string> notes;    ///< one line per skipped frame / odometry jump / vision loss
  std::vector<FrameReport> reports;  ///< per used frame
  std::vector<int> frame_index;      ///< frames.csv `frame` of each report
  std::vector<MapRock> rocks;
  double path_length_m = 0.0;  ///< of the corrected poses
  std::vector<std::filesystem::path> written;
};

/// Runs a DriveMapper over the drive and writes the outputs into `out` (created). Frames that
/// cannot be used are skipped with a note naming them; nothing already written is lost.
/// `progress` (optional) is called after each frame.
DriveMapSummary map_drive(const RecordedDrive& drive, const DriveMapperParams& params, const std::filesystem::path& out,
                          const std::function<void(const DriveFrame&, const FrameReport&)>& progress = {});

/// overview.png of a finished map: hillshade, hazard in red, the corrected path (green) and the
/// wheel path (blue), north up, 1 m scale bar.
cv::Mat render_overview(const WorldMap& map, const std::vector<Pose2>& corrected, const std::vector<Pose2>& wheel,
                        const std::vector<MapRock>& rocks);

}  // namespace regolith::mapping
