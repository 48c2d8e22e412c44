// Component "terrain_map": camera frames + wheel odometry (+ IMU heading) -> DriveMapper ->
// corrected odometry (channel `odom`, DDS `odom`, `odom/wheel`) and the world-frame map (DDS
// `terrain/world_map`). Everything is allocated in configure(); step() reuses it.
#include "regolith/mapping/component.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "regolith/common/camera.hpp"
#include "regolith/core/frame_order.hpp"
#include "regolith/dds/participant.hpp"
#include "regolith/dds/sample.hpp"
#include "regolith/dds/topics.hpp"
#include "regolith/hal/camera.hpp"
#include "regolith/hal/imu.hpp"
#include "regolith/hal/wheel_encoders.hpp"
#include "regolith/mapping/config.hpp"
#include "regolith/mapping/wheel_odometry.hpp"
#include "regolith/runtime/application.hpp"

namespace regolith::mapping {
namespace {

using OdometryMsg = msgs::nav_msgs::Odometry;
using TfMsg = msgs::tf2_msgs::TFMessage;
using GridMapMsg = msgs::grid_map_msgs::GridMap;
using RocksMsg = msgs::vision_msgs::Detection3DArray;
constexpr double kUnobserved = 1e6;  // variance of what a planar odometry does not estimate (z, roll, pitch)
constexpr const char* kOdomTopic = "odom";
constexpr const char* kWheelOdomTopic = "odom/wheel";
constexpr const char* kMapTopic = "terrain/world_map";
constexpr const char* kRocksTopic = "terrain/world_rocks";
constexpr std::size_t kIdCapacity = 32;  // characters of a Detection3D's id and class_id
// Rocks per terrain/world_rocks sample: the strongest this many of the map's (reserved at configure).
constexpr std::uint32_t kMaxPublishedRocks = 256;
constexpr const char* kTfTopic = "/tf";
// Cells per side of the live map window. The algorithm takes up to 4096 (offline `regolith map`);
// on the rover the map is kept twice at configure (warm-up and the mapper, ~130 B per cell each)
// and published whole: 1024 cells per side is ~130 MB of map and 4 MB per published layer.
constexpr int kMaxLiveMapCellsPerSide = 1024;

// The key of this component's YAML that sets a DriveMapperParams field (FieldError owner + field).
std::string key_of(const FieldError& e) {
  if (e.owner() == "mapping.map") return "map_" + e.field();
  if (e.owner() == "mapping.wheel") return "wheel_" + e.field();
  return e.field();
}

// Row-major WorldMap layer (row 0 = smallest y, column 0 = smallest x) -> grid_map's column-major
// buffer (index 0 = the +x/+y corner, Eigen rows along -x): exactly the reversed row-major order.
void export_reversed(const cv::Mat& layer, float* out, std::size_t n) {
  const std::size_t total = layer.total();
  if (n < total || !layer.isContinuous()) return;
  const float* src = layer.ptr<float>();
  for (std::size_t k = 0; k < total; ++k) out[total - 1 - k] = src[k];
}

void set_pose(OdometryMsg& m, TimeNs stamp, const Pose2& p, const Cov3& c) {
  dds::set_stamp(m.header.stamp, stamp);
  m.pose.pose.position.x = p.x;
  m.pose.pose.position.y = p.y;
  m.pose.pose.position.z = 0.0;
  m.pose.pose.orientation.x = 0.0;
  m.pose.pose.orientation.y = 0.0;
  m.pose.pose.orientation.z = std::sin(0.5 * p.yaw);
  m.pose.pose.orientation.w = std::cos(0.5 * p.yaw);
  // 6x6 row-major over (x, y, z, roll, pitch, yaw): the planar block from the 3x3 (x, y, yaw).
  double* cv = m.pose.covariance;
  for (int k = 0; k < 36; ++k) cv[k] = 0.0;
  const int idx[3] = {0, 1, 5};
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) cv[idx[a] * 6 + idx[b]] = c(a, b);
  cv[2 * 6 + 2] = cv[3 * 6 + 3] = cv[4 * 6 + 4] = kUnobserved;
}

void set_twist(OdometryMsg& m, const Pose2& step, double dt, const Cov3& step_cov) {
  double* cv = m.twist.covariance;
  for (int k = 0; k < 36; ++k) cv[k] = 0.0;
  if (!(dt > 0.0) || !step.finite()) {
    m.twist.twist.linear = {0.0, 0.0, 0.0};
    m.twist.twist.angular = {0.0, 0.0, 0.0};
    for (int k = 0; k < 6; ++k) cv[k * 6 + k] = kUnobserved;
    return;
  }
  m.twist.twist.linear = {step.x / dt, step.y / dt, 0.0};
  m.twist.twist.angular = {0.0, 0.0, step.yaw / dt};
  const int idx[3] = {0, 1, 5};
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) cv[idx[a] * 6 + idx[b]] = step_cov(a, b) / (dt * dt);
  cv[2 * 6 + 2] = cv[3 * 6 + 3] = cv[4 * 6 + 4] = kUnobserved;
}

class TerrainMapComponent final : public runtime::Component {
 public:
  void configure(Params& p, runtime::Context& ctx) override {
    // ---- devices and geometry (rover description) ----
    cam_ = &ctx.camera(p, "camera");
    const hal::CameraFormat fmt = cam_->format();
    const RoverCamera& rc = ctx.rover_camera(p, "camera");
    const direct_depth::CameraModel model = common::camera_model_for_frames(rc, fmt.width, fmt.height, p, "camera");
    const CameraMount mount{rc.mount.x_m, rc.mount.y_m, rc.mount.yaw_rad};
    const Sun& sun = ctx.sun(p, "terrain_map (shadow heights)");
    const Vec3 s = sun.local_level();  // the odometry frame is the local-level frame at start
    const cv::Vec3d sun_world(s.x, s.y, s.z);

    enc_ = &ctx.encoders(p, "encoders");
    std::vector<OdometryWheel> wheels;
    for (const Wheel& w : ctx.rover().wheels) {
      if (w.encoders != enc_->id()) continue;
      const auto& names = enc_->wheel_names();
      const auto it = std::find(names.begin(), names.end(), w.name);
      if (it == names.end())
        p.fail("encoders", "rover.wheels." + w.name + " names encoder device '" + enc_->id() +
                               "', which does not report a wheel of that name");
      wheel_index_.push_back(static_cast<std::size_t>(it - names.begin()));
      wheels.push_back({w.y_m, w.radius_m});
    }
    if (wheels.empty())
      p.fail("encoders", "no rover.wheels entry is reported by encoder device '" + enc_->id() +
                             "' (rover.wheels[].encoders): the odometry needs the wheels' positions and radii");
    const OdometrySettings odometry = read_odometry_settings(p, ctx.rover());
    if (odometry.imu_heading) {
      imu_ = ctx.attitude_imu();
      if (imu_ == nullptr) p.fail("heading_source", "`imu`: the rover's IMU (rover.imu) is not open");
    }

    // ---- the mapper (DriveMapperParams read by name, shared with `regolith map --set`) ----
    DriveMapperParams defaults;
    defaults.parallax_spacing_m = 0.15;  // a parallax search per 15 cm of baseline: the component's time budget
    DriveMapperParams mp = read_drive_mapper_params(p, defaults);
    const double window_m = std::max(mp.map.length_x_m, mp.map.length_y_m);
    const double cells_per_side = window_m / mp.map.resolution_m;
    if (cells_per_side > kMaxLiveMapCellsPerSide) {
      p.fail("map_resolution_m",
             "map_length_m " + number_text(window_m) + " m at " + number_text(mp.map.resolution_m) + " m per cell is " +
                 number_text(std::ceil(cells_per_side)) + " cells per side; the live map takes at most " +
                 std::to_string(kMaxLiveMapCellsPerSide) + " (a coarser resolution or a shorter window)");
    }
    map_every_ = p.get<int>(
        "map_publish_every", 2,
        {.min = 1, .max = 10000, .doc = "frames between map updates (derived layers, cells known, DDS map)"});
    std::vector<std::string> all_layers = WorldMap::layer_names();
    const std::vector<std::string> want = p.get<std::vector<std::string>>(
        "layers", {"elevation", "elevation_variance", "hazard", "confidence", "observed_count", "traversability"},
        {.choices = all_layers, .doc = "layers of the published grid map (NaN = never seen)"});
    frame_id_ = p.get<std::string>("frame_id", "odom", {.doc = "header.frame_id of odom and the map (REP-105 odom)"});
    child_frame_id_ = p.get<std::string>("child_frame_id", ctx.rover().base_frame,
                                         {.doc = "child_frame_id of odom (default rover.base_frame)"});
    const TimeNs timeout = read_input_timeout(p, fmt.rate_hz);
    if (frame_id_.size() > 31 || child_frame_id_.size() > 31)
      p.fail("frame_id", "frame names are limited to 31 characters");
    try {
      mp.validate();
      // Warm-up on a textured frame pair (sizes OpenCV's and the process's lazily made state); the
      // mapper that runs is made afterwards and starts clean.
      cv::Mat a(fmt.height, fmt.width, CV_8U), b;
      cv::randu(a, 40, 200);
      cv::GaussianBlur(a, a, cv::Size(5, 5), 1.5);
      cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, 0, 0, 1, -2);
      cv::warpAffine(a, b, shift, a.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
      {
        DriveMapper warm(model, mount, sun_world, mp, {0.0, 0.0});
        warm.add_frame(a, Pose2{});
        warm.add_frame(b, Pose2{0.02, 0.0, 0.0});
        warm.map().finish();
      }
      mapper_ = std::make_unique<DriveMapper>(model, mount, sun_world, mp, cv::Point2d(0.0, 0.0));
      mapper_->map().finish();
    } catch (const FieldError& e) {
      p.fail(key_of(e), e.problem());
    }
    wheel_noise_ = mp.wheel;
    try {
      odo_.emplace(wheels, odometry.step, mp.wheel.max_speed_mps);
    } catch (const FieldError& e) {
      p.fail("encoders", std::string("rover.wheels reported by '") + enc_->id() + "': " + e.problem());
    }
    gray_.create(fmt.height, fmt.width, CV_8U);
    rocks_.reserve(mapper_->map().max_rock_candidates());
    for (const auto& name : want) layers_.push_back(&mapper_->map().layer(name));

    // ---- outputs ----
    state_ = &ctx.produce<TerrainMapState>(kOdometryChannel, 4);
    input_ = &watch_input("camera", timeout);
    order_ = FrameOrder(timeout);
    if (dds::Participant* part = ctx.dds()) {
      for (const char* topic : {kOdomTopic, kWheelOdomTopic, kMapTopic, kRocksTopic, kTfTopic})
        if (dds::find_topic(topic) == nullptr)
          p.fail({}, std::string("DDS topic ") + topic + " is unknown to this build");
      const std::string frame = frame_id_, child = child_frame_id_;
      auto odom_reserve = [frame, child](OdometryMsg& m) {
        dds::reserve(m, 32);
        dds::copy_string(m.header.frame_id, 32, frame);
        dds::copy_string(m.child_frame_id, 32, child);
      };
      odom_msg_ = part->make_outbox<OdometryMsg>(kOdomTopic, dds::find_topic(kOdomTopic)->writer_qos(),
                                                 dds::OutboxOptions{dds::OutboxMode::kFifo, 8}, odom_reserve);
      // odom -> base_link on /tf (REP-105), one transform per mapped frame.
      tf_msg_ = part->make_outbox<TfMsg>(kTfTopic, dds::find_topic(kTfTopic)->writer_qos(),
                                         dds::OutboxOptions{dds::OutboxMode::kFifo, 8}, [frame, child](TfMsg& m) {
                                           dds::reserve(m, 1, 32);
                                           dds::set_length(m.transforms, 1);
                                           dds::copy_string(m.transforms._buffer[0].header.frame_id, 32, frame);
                                           dds::copy_string(m.transforms._buffer[0].child_frame_id, 32, child);
                                         });
      wheel_msg_ = part->make_outbox<OdometryMsg>(kWheelOdomTopic, dds::find_topic(kWheelOdomTopic)->writer_qos(),
                                                  dds::OutboxOptions{dds::OutboxMode::kFifo, 8}, odom_reserve);
      const WorldMap& map = mapper_->map();
      const auto nx = static_cast<std::uint32_t>(map.cols()), ny = static_cast<std::uint32_t>(map.rows());
      const double res = map.resolution();
      map_msg_ = part->make_outbox<GridMapMsg>(kMapTopic, dds::find_topic(kMapTopic)->writer_qos(),
                                               dds::OutboxOptions{dds::OutboxMode::kLatest, 3},
                                               [nx, ny, res, frame, want](GridMapMsg& m) {
                                                 const auto nl = static_cast<std::uint32_t>(want.size());
                                                 dds::reserve(m, dds::GridMapCapacity{nl, 1, nx, ny, 32, 32});
                                                 dds::copy_string(m.header.frame_id, 32, frame);
                                                 dds::set_length(m.layers, nl);
                                                 dds::set_length(m.data, nl);
                                                 for (std::uint32_t k = 0; k < nl; ++k)
                                                   dds::copy_string(m.layers._buffer[k], 32, want[k]);
                                                 dds::set_length(m.basic_layers, 1);
                                                 dds::copy_string(m.basic_layers._buffer[0], 32, "elevation");
                                                 m.info.resolution = res;
                                                 m.info.length_x = nx * res;
                                                 m.info.length_y = ny * res;
                                               });
      // The map's rocks in the odom frame, as vision_msgs/Detection3DArray (latched like the map).
      rocks_msg_ = part->make_outbox<RocksMsg>(
          kRocksTopic, dds::find_topic(kRocksTopic)->writer_qos(), dds::OutboxOptions{dds::OutboxMode::kLatest, 3},
          [frame](RocksMsg& m) {
            dds::reserve(m, dds::Detection3DArrayCapacity{kMaxPublishedRocks, 1, kIdCapacity, 32});
            dds::copy_string(m.header.frame_id, 32, frame);
            for (std::uint32_t k = 0; k < kMaxPublishedRocks; ++k) {
              auto& d = m.detections._buffer[k];
              dds::copy_string(d.header.frame_id, 32, frame);
              dds::copy_string(d.results._buffer[0].hypothesis.class_id, kIdCapacity, "rock");
            }
          });
    }
  }

  void activate() override { new_frame_.reset(); }

  void step(const runtime::CycleInfo& c) override {
    hal::FrameLease lease;
    if (!cam_->latest(c.now, lease)) return;
    if (!new_frame_(lease.generation())) return;
    const hal::Frame& fr = *lease;
    if (!in_order(fr.capture_time)) return;
    input_updated(*input_, c.now);
    const bool odometry_ok = advance_odometry(fr.capture_time);
    if (!odometry_ok) ++odometry_unavailable_;
    const cv::Size size(gray_.cols, gray_.rows);
    if (fr.corrupt || fr.image.empty() || fr.image.size() != size ||
        (fr.image.type() != CV_8UC1 && fr.image.type() != CV_8UC3)) {
      ++rejected_;
      count_error();
      set_status(fr.corrupt ? "corrupt frame skipped" : "frame size/type differs from the camera calibration");
      return;
    }
    const cv::Mat* gray = &fr.image;
    if (fr.image.type() == CV_8UC3) {
      cv::cvtColor(fr.image, gray_, cv::COLOR_BGR2GRAY);  // into the pre-sized buffer
      gray = &gray_;
    }
    constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
    const Pose2 wheel = odometry_ok ? odo_->pose() : Pose2{kNaN, kNaN, kNaN};
    const FrameReport* r = nullptr;
    try {
      r = &mapper_->add_frame(*gray, wheel, to_seconds(fr.capture_time));
    } catch (...) {  // inputs are checked above; never let anything leave step()
      ++rejected_;
      count_error();
      set_status("the mapper rejected a frame");
      return;
    }
    if (++since_map_ >= map_every_) {
      since_map_ = 0;
      update_map(fr.capture_time);
    }
    publish(*r, fr);
    if (!odometry_ok)
      set_status("no wheel angles at the frame's capture time: vision only");
    else if (r->vo == VoStatus::kUncertain)
      set_status(
          "visual odometry too uncertain against the keyframe: wheel odometry carries this frame, which "
          "becomes the keyframe");
    else if (r->vo != VoStatus::kOk && r->vo != VoStatus::kNoKeyframe)
      set_status("visual odometry lost: wheel odometry carries the pose");
    else
      set_status("ok");
  }

  void diagnostics(std::vector<std::pair<std::string, std::string>>& kv) const override {
    const auto l = state_ != nullptr ? state_->acquire() : decltype(state_->acquire()){};
    if (!l) return;
    kv.emplace_back("frames_mapped", std::to_string(l->counters.frames));
    kv.emplace_back("vo_ok", std::to_string(l->counters.vo_ok));
    kv.emplace_back("vo_failed", std::to_string(l->counters.vo_failed));
    kv.emplace_back("vo_uncertain", std::to_string(l->counters.vo_uncertain));
    kv.emplace_back("keyframes", std::to_string(l->counters.keyframes));
    kv.emplace_back("odometry_jumps", std::to_string(l->counters.odometry_jumps));
    // Counted per frame received, mapped or not: read live, not from the last mapped frame's state.
    kv.emplace_back("frames_rejected", std::to_string(rejected_.load(std::memory_order_relaxed)));
    kv.emplace_back("odometry_unavailable", std::to_string(odometry_unavailable_.load(std::memory_order_relaxed)));
    kv.emplace_back("odometry_reanchored", std::to_string(l->odometry_reanchored));
    kv.emplace_back("frames_out_of_order", std::to_string(order_.out_of_order()));
    kv.emplace_back("clock_steps", std::to_string(order_.clock_steps()));
    kv.emplace_back("cells_known", std::to_string(l->cells_known));
    kv.emplace_back("rocks", std::to_string(l->rocks));
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.3f %.3f %.2f", l->pose.x, l->pose.y, l->pose.yaw * 57.29577951308232);
    kv.emplace_back("pose_x_y_yawdeg", buf);
  }

  std::string result() const override {
    const auto l = state_ != nullptr ? state_->acquire() : decltype(state_->acquire()){};
    if (!l) return {};
    char buf[256];
    const double dw = std::hypot(l->pose.x - l->wheel_pose.x, l->pose.y - l->wheel_pose.y);
    std::snprintf(buf, sizeof buf,
                  "map %ld frames (VO %ld ok / %ld failed, %ld keyframes), %ld cells known, %ld rocks, pose %.2f %.2f "
                  "m %.1f deg (wheels %.1f cm away)%s%s",
                  l->counters.frames, l->counters.vo_ok, l->counters.vo_failed, l->counters.keyframes, l->cells_known,
                  l->rocks, l->pose.x, l->pose.y, l->pose.yaw * 57.29577951308232, 100.0 * dw,
                  rejected_.load(std::memory_order_relaxed) > 0 ? ", frames rejected" : "",
                  order_.out_of_order() + order_.clock_steps() > 0 ? ", camera clock stepped back" : "");
    return buf;
  }

 private:
  // FrameOrder: a frame stamped at or before the last one taken (mapped, or rejected below) is
  // skipped; a step back past the input timeout maps on from the new time base.
  bool in_order(TimeNs stamp) {
    switch (order_.admit(stamp)) {
      case FrameOrder::Verdict::kNext: return true;
      case FrameOrder::Verdict::kOutOfOrder:
        set_status("frame stamped at or before the last one taken (the camera clock stepped back): skipped");
        return false;
      case FrameOrder::Verdict::kClockStep: odo_->clock_stepped_back(); return true;
    }
    return false;
  }

  // Wheel (+ IMU heading) odometry up to `t` (SteppedOdometry: sub-steps of odometry_step_s). False
  // when the encoders (or the IMU) have nothing at `t`; the pose then stays where the last good
  // reading left it.
  bool advance_odometry(TimeNs t) {
    return odo_->advance_to(t, [this](TimeNs tk, std::span<double> angles, double& yaw) {
      for (std::size_t i = 0; i < wheel_index_.size(); ++i)
        if (!enc_->angle_at(wheel_index_[i], tk, angles[i])) return false;
      yaw = std::numeric_limits<double>::quiet_NaN();
      if (imu_ != nullptr) {
        Attitude a;
        if (!imu_->attitude_at(tk, a)) return false;
        yaw = a.yaw_rad;
      }
      return true;
    });
  }

  void update_map(TimeNs /*stamp*/) {
    WorldMap& map = mapper_->map();
    map.finish();
    const cv::Mat& el = map.layer("elevation");
    long known = 0;
    for (int i = 0; i < el.rows; ++i) {
      const float* row = el.ptr<float>(i);
      for (int j = 0; j < el.cols; ++j) known += std::isfinite(row[j]) ? 1 : 0;
    }
    cells_known_ = known;
    rocks_known_ = static_cast<long>(map.rocks(rocks_));
    ++map_updates_;
    map_due_ = true;
  }

  void publish(const FrameReport& r, const hal::Frame& fr) {
    const double dt = have_prev_ ? to_seconds(fr.capture_time - prev_stamp_) : 0.0;
    const Pose2 step = have_prev_ ? between(prev_pose_, r.pose) : Pose2{};
    const Pose2 wstep =
        have_prev_ && r.wheel_pose.finite() && prev_wheel_.finite() ? between(prev_wheel_, r.wheel_pose) : Pose2{};
    if (TerrainMapState* s = state_->begin_write()) {
      s->stamp = fr.capture_time;
      s->sequence = fr.sequence;
      s->pose = r.pose;
      s->covariance = r.covariance;
      s->wheel_pose = r.wheel_pose;
      s->vo = r.vo;
      s->keyframe = r.keyframe;
      s->vo_inliers = r.vo_inliers;
      s->counters = mapper_->counters();
      s->frames_rejected = rejected_;
      s->odometry_unavailable = odometry_unavailable_;
      s->odometry_reanchored = odo_->reanchored();
      s->frames_out_of_order = order_.out_of_order();
      s->clock_steps = order_.clock_steps();
      s->cells_known = cells_known_;
      s->rocks = rocks_known_;
      s->map_updates = map_updates_;
      s->distance_m = odo_->distance();
      state_->commit();
    }
    if (odom_msg_) {
      if (OdometryMsg* m = odom_msg_->begin()) {
        set_pose(*m, fr.capture_time, r.pose, r.covariance);
        set_twist(*m, step, dt, wheel_noise_.covariance(step));
        odom_msg_->commit();
      }
    }
    if (tf_msg_) {
      if (TfMsg* m = tf_msg_->begin()) {
        auto& t = m->transforms._buffer[0];
        dds::set_stamp(t.header.stamp, fr.capture_time);
        t.transform.translation.x = r.pose.x;
        t.transform.translation.y = r.pose.y;
        t.transform.translation.z = 0.0;
        t.transform.rotation.x = 0.0;
        t.transform.rotation.y = 0.0;
        t.transform.rotation.z = std::sin(0.5 * r.pose.yaw);
        t.transform.rotation.w = std::cos(0.5 * r.pose.yaw);
        tf_msg_->commit();
      }
    }
    if (wheel_msg_ && r.wheel_pose.finite()) {
      if (OdometryMsg* m = wheel_msg_->begin()) {
        // Wheel odometry alone: its covariance grows with the wheel model along the path.
        if (have_prev_) wheel_cov_ = compose_covariance(prev_wheel_, wheel_cov_, wstep, wheel_noise_.covariance(wstep));
        set_pose(*m, fr.capture_time, r.wheel_pose, wheel_cov_);
        set_twist(*m, wstep, dt, wheel_noise_.covariance(wstep));
        wheel_msg_->commit();
      }
    }
    if (map_msg_ && map_due_) {
      if (GridMapMsg* m = map_msg_->begin()) {
        const WorldMap& map = mapper_->map();
        dds::set_stamp(m->header.stamp, fr.capture_time);
        m->info.pose.position.x = map.origin_x() + 0.5 * (map.cols() - 1) * map.resolution();
        m->info.pose.position.y = map.origin_y() + 0.5 * (map.rows() - 1) * map.resolution();
        for (std::size_t k = 0; k < layers_.size(); ++k) {
          auto& seq = m->data._buffer[k].data;
          export_reversed(*layers_[k], seq._buffer, seq._length);
        }
        map_msg_->commit();
      }
      if (rocks_msg_) publish_rocks(fr.capture_time);
      map_due_ = false;
    }
    prev_pose_ = r.pose;
    if (r.wheel_pose.finite()) prev_wheel_ = r.wheel_pose;
    prev_stamp_ = fr.capture_time;
    have_prev_ = true;
  }

  // terrain/world_rocks: the map's rocks, strongest first. Each: its track number as id, one
  // hypothesis "rock" with its score and pose (the centre at half its height above the map's
  // ground there, or above z = 0 where the map has no elevation; x / y covariance MapRock's: the
  // triangulation plus the errors a track's frames share; z variance (height / 2)^2, orientation
  // not estimated), and a box of its width x width x height.
  void publish_rocks(TimeNs stamp) {
    RocksMsg* m = rocks_msg_->begin();
    if (m == nullptr) return;
    const WorldMap& map = mapper_->map();
    const std::size_t n = std::min<std::size_t>(rocks_.size(), kMaxPublishedRocks);
    const cv::Mat& el = map.layer("elevation");
    dds::set_stamp(m->header.stamp, stamp);
    dds::set_length(m->detections, static_cast<std::uint32_t>(n));
    for (std::size_t k = 0; k < n; ++k) {
      const MapRock& r = rocks_[k];
      auto& d = m->detections._buffer[k];
      d.header.stamp = m->header.stamp;
      const int j = static_cast<int>(std::lround((r.x_m - map.origin_x()) / map.resolution()));
      const int i = static_cast<int>(std::lround((r.y_m - map.origin_y()) / map.resolution()));
      const float g = (i >= 0 && j >= 0 && i < el.rows && j < el.cols) ? el.at<float>(i, j) : 0.0f;
      auto& h = d.results._buffer[0];
      h.hypothesis.score = r.score;
      auto& pose = h.pose.pose;
      pose.position.x = r.x_m;
      pose.position.y = r.y_m;
      pose.position.z = (std::isfinite(g) ? g : 0.0) + 0.5 * r.height_m;
      double* cv = h.pose.covariance;
      std::fill(cv, cv + 36, 0.0);
      cv[0] = r.cov_xx;
      cv[1] = cv[6] = r.cov_xy;
      cv[7] = r.cov_yy;
      cv[14] = 0.25 * r.height_m * r.height_m;
      cv[21] = cv[28] = cv[35] = kUnobserved;
      d.bbox.center = pose;
      d.bbox.size.x = d.bbox.size.y = r.width_m;
      d.bbox.size.z = r.height_m;
      // The same rock keeps its id across messages while its track lives ("" for a relief rock).
      if (r.id > 0)
        dds::format_int(d.id, kIdCapacity, r.id);
      else
        dds::copy_string(d.id, kIdCapacity, "");
    }
    rocks_msg_->commit();
  }

  hal::Camera* cam_ = nullptr;
  hal::WheelEncoders* enc_ = nullptr;
  const hal::Imu* imu_ = nullptr;
  std::vector<std::size_t> wheel_index_;  // rover wheel k -> encoder wheel index
  std::optional<SteppedOdometry> odo_;
  std::unique_ptr<DriveMapper> mapper_;
  WheelNoise wheel_noise_;
  cv::Mat gray_;
  std::vector<const cv::Mat*> layers_;
  int map_every_ = 2, since_map_ = 0;
  bool map_due_ = false;
  long cells_known_ = 0, map_updates_ = 0, rocks_known_ = 0;
  // Per frame received, mapped or not, for diagnostics() / result() on other threads.
  std::atomic<long> rejected_{0}, odometry_unavailable_{0};
  FrameOrder order_;  // its step-back limit is the input timeout
  bool have_prev_ = false;
  Pose2 prev_pose_, prev_wheel_;
  Cov3 wheel_cov_ = Cov3::Zero();
  TimeNs prev_stamp_ = 0;
  std::string frame_id_, child_frame_id_;
  LatestPool<TerrainMapState>* state_ = nullptr;
  std::shared_ptr<dds::Outbox<OdometryMsg>> odom_msg_, wheel_msg_;
  std::shared_ptr<dds::Outbox<TfMsg>> tf_msg_;
  std::shared_ptr<dds::Outbox<GridMapMsg>> map_msg_;
  std::shared_ptr<dds::Outbox<RocksMsg>> rocks_msg_;
  std::vector<MapRock> rocks_;  // the map's rocks at the last map update (capacity reserved at configure)
  runtime::InputWatch* input_ = nullptr;
  NewValue new_frame_;
};

}  // namespace

void register_component() {
  runtime::ComponentRegistry::instance().add(
      "terrain_map",
      "camera + wheel encoders (+ IMU heading) -> visual/wheel odometry and a world-frame terrain map "
      "(odom, odom/wheel, terrain/world_map, terrain/world_rocks)",
      [] { return std::make_unique<TerrainMapComponent>(); });
}

}  // namespace regolith::mapping
