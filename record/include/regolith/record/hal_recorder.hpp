#pragma once
// HalRecorder: records what the devices of a deployment delivered, so `regolith replay` can feed
// the same inputs to the same code (record/README.md "HAL recording"). Devices are wrapped at
// configure time (wrap()); the wrappers forward every call to the device and note, without
// allocating, locking or blocking:
//   cameras   every new frame a component leases (pixels copied into a slot of a ring made at
//             configure time);
//   encoders  every angle_at() answer (wheel, time, angle or "none");
//   IMUs      every attitude_at() answer.
// A writer thread of its own drains the rings into a record::MessageSink (the MCAP file of
// `regolith run --record`) and polls each encoder and IMU for every sample it delivered
// (samples_since). A full ring drops the item and counts it (real time) or, in lossless mode
// (simulated time, where determinism matters and wall time does not), waits for the writer.
//
// Topics (ros2msg schemas, cdr): /hal/cameras/<id>/image (sensor_msgs/Image, MCAP sequence =
// frame sequence; corrupt frames on /hal/cameras/<id>/image_corrupt), /hal/encoders/<id>/samples
// and /hal/encoders/<id>/queries (sensor_msgs/JointState, one wheel per message; a failed query
// has position NaN), /hal/encoders/<id>/can and /can_fd (every raw frame of a backend that reads a
// CAN bus, WheelEncoders::can_frames: can_msgs/Frame, ros2_socketcan_msgs/FdFrame; MCAP sequence =
// the frame's number, a gap = frames the backend's history no longer held, counted as dropped),
// /hal/imus/<id>/samples (sensor_msgs/Imu), /hal/imus/<id>/attitude (each
// sample's roll, pitch, yaw exactly, as geometry_msgs/Vector3Stamped x, y, z in rad) and
// /hal/imus/<id>/queries (the same type; NaN = the query failed). Header stamps are the
// process clock (TimeNs); MCAP log times are ROS time: process clock + the offset measured at
// start() or, under simulated time, HalRecorderOptions::sim_ros_offset (the time line of the DDS
// samples beside them, whose log time is then their simulated source time), kept in the
// `regolith_hal` metadata record with the time origin. A query's message is logged when the
// component asked, its header stamp is the time it asked about. stop() adds `regolith_hal_end`
// (time_end_ns: the clock at the end), so a replay knows how long the recording runs.
// Target regolith::hal_record (hal + record + ros2msg).
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "regolith/core/time.hpp"
#include "regolith/hal/device.hpp"
#include "regolith/record/sink.hpp"

namespace regolith::record {

struct HalRecorderOptions {
  std::size_t frames_per_camera = 4;      ///< ring slots per camera (each one frame of its geometry)
  std::size_t queries_per_device = 4096;  ///< ring slots per encoder set / IMU for query answers
  TimeNs poll_period = 5 * kNsPerMs;      ///< writer thread wake-up (wall time)
  /// A full ring makes the device call wait for the writer instead of dropping (simulated time).
  bool lossless = false;
  /// Under simulated time: ROS time - simulated time (runtime::AppOptions::sim_ros_offset; 0 but
  /// for a replay, which keeps its recording's).
  TimeNs sim_ros_offset = 0;
};

class HalRecorder {
 public:
  struct DeviceCount {
    std::string id;
    std::string kind;            ///< camera / encoders / imu
    std::uint64_t recorded = 0;  ///< messages written (frames, samples + queries)
    std::uint64_t dropped = 0;   ///< items lost because a ring was full
  };

  explicit HalRecorder(HalRecorderOptions options = {});
  ~HalRecorder();
  HalRecorder(const HalRecorder&) = delete;
  HalRecorder& operator=(const HalRecorder&) = delete;

  /// The device wrapped so that what it delivers is recorded (cameras, encoders and IMUs; other
  /// kinds are returned as they are): at configure time (runtime::AppOptions::wrap_device), before
  /// start(). Until start() and after stop() the wrapper only forwards (one atomic load per call;
  /// the frame slots are allocated by start()). The recorder must outlive the wrapper's use.
  std::unique_ptr<hal::Device> wrap(std::unique_ptr<hal::Device> device);

  /// Adds the channels and the `regolith_hal` metadata (time origin = `clock` now, ROS time offset)
  /// to `sink` and starts the writer thread. Call just before the devices start. `sink` and `clock`
  /// (the deployment's, simulated under --sim-time) must outlive stop().
  void start(MessageSink& sink, Clock& clock);
  /// Drains the rings, polls the devices a last time and joins the thread (idempotent). Call after
  /// the devices stopped and before the sink closes.
  void stop();

  std::vector<DeviceCount> counts() const;
  std::uint64_t dropped() const;

  struct Tap;  // one wrapped device's recording state (hal_recorder.cpp)

 private:
  void loop();
  void drain_all();

  MessageSink* sink_ = nullptr;
  Clock* clock_ = nullptr;
  HalRecorderOptions opts_;
  std::vector<std::shared_ptr<Tap>> taps_;
  TimeNs ros_offset_ = 0;
  std::vector<std::uint8_t> buffer_;  // encoded message (writer thread, then stop())
  struct WheelSample {
    TimeNs stamp;
    std::uint32_t wheel;
    double angle;
  };
  std::vector<WheelSample> wheel_samples_;  // one pass's samples of an encoder set, merged by stamp
  std::atomic<bool> stop_{false};
  std::mutex wake_mutex_;
  std::condition_variable wake_;  // stop() wakes the writer at once
  std::thread thread_;
  bool stopped_ = false;
};

/// Topic names of the HAL recording.
std::string hal_camera_topic(const std::string& id, bool corrupt = false);
/// Raw CAN frames of encoder set `id` (can_msgs/Frame; `fd`: the CAN FD ones, ros2_socketcan_msgs/FdFrame).
std::string hal_can_topic(const std::string& id, bool fd = false);
std::string hal_samples_topic(const std::string& kind, const std::string& id);  ///< kind: encoders / imus
std::string hal_queries_topic(const std::string& kind, const std::string& id);

}  // namespace regolith::record
