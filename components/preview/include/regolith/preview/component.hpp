#pragma once
// Component wrapper "camera_preview": what a camera saw with what the rover made of it drawn on top,
// JPEG-encoded for people watching (the live page, Foxglove's Image panel, ros2 bag):
//   * source `rocks`:   the front camera's grey frame (channel terrain/dtm) with the rock boxes of
//                       the same frame (channel terrain/rocks) -> DDS preview/rocks/compressed;
//   * source `sinkage`: the hub camera's frame (the camera device) with the wheel_sinkage result of
//                       the same frame (channel terrain/wheel_sinkage: leg template, interface
//                       line, sinkage) -> DDS preview/sinkage/compressed.
// Both as sensor_msgs/CompressedImage (format "jpeg"), stamped with the frame's capture time, and on
// the channel preview/<source> (PreviewImage) for in-process observers. step() only copies the
// frame into a slot sized at configure time; scaling, drawing and JPEG run on the component's own
// non-real-time thread. Parameters and numbers: components/preview/README.md.
#include <cstdint>
#include <vector>

#include "regolith/core/time.hpp"

namespace regolith::preview {

/// One encoded preview, on channel "preview/<source>".
struct PreviewImage {
  TimeNs stamp = 0;                ///< capture time of the camera frame (ns, process clock)
  std::uint64_t sequence = 0;      ///< camera frame sequence number
  int width = 0, height = 0;       ///< px, of the encoded image
  std::vector<std::uint8_t> jpeg;  ///< capacity reserved at configure time; size() = bytes
};

/// Registers component type "camera_preview" (idempotent).
void register_component();

}  // namespace regolith::preview
