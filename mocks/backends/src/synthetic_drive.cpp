// Camera, encoders and IMU "synthetic_drive": a rover driving a scripted path (straight or a
// constant-curvature arc, then standing still) over a generated terrain tile with rocks, craters
// and cast shadows from the deployment sun (regolith::terrain_scene::DrivePath / make_drive_tile).
// The camera renders each frame from the body pose at its capture time through the device's
// rover.cameras mount; the encoders report the wheel rotations of that path (rover.wheels that
// name the encoder device, skid-steer kinematics, optional slip); the IMU the path's heading and
// yaw rate. Give the three devices the same mapping (a YAML anchor): every backend reads every key.
//
// Rendering never happens on the real-time path: `prerender_frames` frames are rendered at
// configure (in parallel), the rest by a background thread started at configure; latest() serves
// the newest frame that is both due and rendered (a frame rendered late is served with its own
// capture time, like a camera with latency).
#include "regolith/mocks/synthetic_drive.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <thread>

#include <opencv2/imgproc.hpp>

#include "backends_internal.hpp"
#include "common.hpp"
#include "regolith/hal/imu.hpp"

namespace regolith::mocks {
namespace detail {
namespace {

namespace ts = regolith::terrain_scene;

struct DriveSpec {
  hal::CameraFormat fmt;
  int frames = 0;
  int prerender = 0;
  int render_threads = 2;
  ts::DrivePath path;
  ts::DriveTileParams tile;
  ts::RenderOptions render;
  double sample_rate_hz = 100.0;
  TimeNs max_extrapolation = 0;
  double slip_left = 0.0, slip_right = 0.0;
  double imu_rate_hz = 100.0;
  double gravity_mps2 = 1.62;
  const RoverCamera* camera = nullptr;  ///< rover.cameras.<id> (camera device only)
  const Sun* sun = nullptr;
};

// Every backend reads every key, so one mapping serves the camera, the encoders and the IMU.
DriveSpec read_spec(Params& p, const hal::DeviceContext& ctx) {
  DriveSpec s;
  const SceneDescription desc = scene_description(p, ctx, {}, {});
  s.camera = desc.camera;
  s.sun = desc.sun;
  s.fmt.rate_hz = p.get<double>(
      "rate_hz", 2.0, {.unit = "Hz", .min = 0.0, .max = 1000.0, .min_exclusive = true, .doc = "camera frame rate"});
  s.fmt.format = hal::pixel_format_from_string(
      p.get<std::string>("format", "mono8", {.choices = {"mono8", "bgr8"}, .doc = "camera pixel format"}));
  // The image size is the calibration's for the camera device; the other devices of the pair
  // have no calibration of their own (any size is accepted and ignored).
  const cv::Size size = scene_image_size(p, desc, {320, 240});
  s.fmt.width = size.width;
  s.fmt.height = size.height;
  ts::DrivePath& path = s.path;
  path.start_x_m = p.get<double>("start_x_m", 0.0, {.unit = "m", .doc = "start position in the scene (world x)"});
  path.start_y_m = p.get<double>("start_y_m", 0.0, {.unit = "m", .doc = "start position in the scene (world y)"});
  path.start_yaw_rad = p.get<double>("start_yaw_rad", 0.0,
                                     {.unit = "rad", .min = -7.0, .max = 7.0, .doc = "start heading in the scene"});
  path.speed_m_s = p.get<double>("speed_m_s", 0.1, {.unit = "m/s", .min = 0.0, .max = 2.0, .doc = "driving speed"});
  path.turn_radius_m =
      p.get<double>("turn_radius_m", 8.0,
                    {.unit = "m", .min = -1000.0, .max = 1000.0, .doc = "arc radius, > 0 turns left, 0 = straight"});
  path.duration_s =
      p.get<double>("duration_s", 40.0,
                    {.unit = "s", .min = 0.0, .max = 3600.0, .doc = "driving time; afterwards the rover stands still"});
  s.frames = static_cast<int>(std::floor(path.duration_s * s.fmt.rate_hz + 1e-9)) + 1;
  if (s.frames > 5000)
    p.fail("duration_s", "duration_s x rate_hz gives " + std::to_string(s.frames) + " frames (at most 5000)");
  s.prerender =
      p.get<int>("prerender_frames", 8,
                 {.min = 1, .max = 5000, .doc = "frames rendered at configure; the rest on a background thread"});
  s.render_threads = p.get<int>("render_threads", 2, {.min = 1, .max = 64, .doc = "threads rendering at configure"});
  ts::DriveTileParams& t = s.tile;
  t.seed = static_cast<std::uint64_t>(p.get<std::int64_t>("seed", 1, {.min = 0, .doc = "terrain seed"}));
  t.resolution_m =
      p.get<double>("resolution_m", 0.02, {.unit = "m", .min = 0.005, .max = 0.2, .doc = "height-field cell"});
  t.fractal_rms_m =
      p.get<double>("fractal_rms_m", 0.005, {.unit = "m", .min = 0.0, .max = 0.5, .doc = "RMS of the fractal terrain"});
  t.rocks_per_m2 =
      p.get<double>("rocks_per_m2", 0.15, {.unit = "1/m^2", .min = 0.0, .max = 10.0, .doc = "rock density"});
  t.rock_radius_max_m =
      p.get<double>("rock_radius_max_m", 0.18,
                    {.unit = "m", .min = 0.06, .max = 2.0, .doc = "largest rock half-axis (smallest 0.05 m)"});
  t.craters = p.get<int>("craters", 2, {.min = 0, .max = 50, .doc = "number of craters"});
  t.margin_m = p.get<double>("margin_m", 6.0,
                             {.unit = "m", .min = 1.0, .max = 50.0, .doc = "terrain beyond the path's bounding box"});
  t.keep_clear_m = p.get<double>(
      "keep_clear_m", 0.6, {.unit = "m", .min = 0.0, .max = 10.0, .doc = "no rock or crater this close to the path"});
  s.render.albedo = p.get<double>("albedo", 0.8, {.min = 0.0, .max = 1.0, .doc = "Lambertian albedo"});
  s.render.noise_sigma =
      p.get<double>("noise_sigma", 0.005, {.min = 0.0, .max = 1.0, .doc = "Gaussian image noise (0..1)"});
  s.render.cast_shadows = p.get<bool>("cast_shadows", true, {.doc = "cast shadows from the sun"});
  s.sample_rate_hz = read_sample_rate(p, "encoder report rate");
  s.max_extrapolation = read_max_extrapolation(p);
  s.slip_left = p.get<double>("slip_left", 0.0,
                              {.min = -0.5, .max = 0.5, .doc = "left wheels turn (1 + slip) x the distance they roll"});
  s.slip_right = p.get<double>("slip_right", 0.0, {.min = -0.5, .max = 0.5, .doc = "same for the right wheels"});
  s.imu_rate_hz =
      p.get<double>("imu_rate_hz", 100.0,
                    {.unit = "Hz", .min = 0.0, .max = 10000.0, .min_exclusive = true, .doc = "IMU sample rate"});
  s.gravity_mps2 = ctx.rover != nullptr && ctx.rover->gravity_mps2 > 0.0 ? ctx.rover->gravity_mps2 : 1.62;
  try {
    path.validate();
  } catch (const std::invalid_argument& e) {
    p.fail({}, e.what());
  }
  return s;
}

// ---- camera -----------------------------------------------------------------------------------

class DriveCamera final : public hal::Camera, public DriveTruth {
 public:
  DriveCamera(const hal::DeviceContext& ctx, DriveSpec spec, Params& p)
      : id_(ctx.id),
        index_(ctx.index),
        clock_(clock_of(ctx)),
        spec_(std::move(spec)),
        grid_(spec_.fmt.rate_hz),
        outlet_(spec_.fmt) {
    images_.resize(static_cast<std::size_t>(spec_.frames));
    if (!ctx.open_devices) {  // `config check`: parameters validated, nothing rendered
      for (auto& m : images_)
        m = cv::Mat(spec_.fmt.height, spec_.fmt.width, hal::cv_type(spec_.fmt.format), cv::Scalar::all(0));
      rendered_ = spec_.frames;
      return;
    }
    // The camera: rover.cameras.<id> (without it: 77 deg field of view, 0.5 m high, 0.35 rad down).
    cam_.width = spec_.fmt.width;
    cam_.height = spec_.fmt.height;
    cam_.fx = cam_.fy = 0.5 * spec_.fmt.width / std::tan(0.5 * 1.349);
    cam_.cx = 0.5 * (spec_.fmt.width - 1);
    cam_.cy = 0.5 * (spec_.fmt.height - 1);
    mount_ = Pose{.z_m = 0.5, .pitch_rad = 0.35};
    if (spec_.camera != nullptr) {
      const CameraInfo& ci = spec_.camera->info;
      cam_.fx = ci.fx(), cam_.fy = ci.fy(), cam_.cx = ci.cx(), cam_.cy = ci.cy();
      mount_ = spec_.camera->mount;
    }
    cam_.height_m = mount_.z_m;
    cam_.pitch_rad = mount_.pitch_rad;
    cam_.roll_rad = mount_.roll_rad;
    // The sun: the deployment's, given in the local-level frame at start (= the start pose's frame).
    sun_.azimuth_rad = 0.8;
    sun_.elevation_rad = 0.6;
    if (spec_.sun != nullptr) {
      const Vec3 v = spec_.sun->local_level();
      sun_.azimuth_rad = azimuth_ccw(v) + spec_.path.start_yaw_rad;
      sun_.elevation_rad = elevation(v);
    }
    try {
      cam_.validate();
      terrain_ = std::make_unique<ts::Terrain>(ts::make_drive_tile(spec_.path, spec_.tile));
      // The camera must stay over the tile (its reach is the margin).
      const int first = std::min(spec_.prerender, spec_.frames);
      std::vector<std::thread> pool;
      std::atomic<int> next{0};
      std::exception_ptr error;
      std::atomic<bool> failed{false};
      auto work = [&] {
        for (int k = next++; k < first; k = next++) {
          try {
            images_[static_cast<std::size_t>(k)] = render(k);
          } catch (...) {
            if (!failed.exchange(true)) error = std::current_exception();
          }
        }
      };
      for (int i = 1; i < spec_.render_threads; ++i) pool.emplace_back(work);
      work();
      for (auto& th : pool) th.join();
      if (error) std::rethrow_exception(error);
      rendered_ = first;
    } catch (const std::invalid_argument& e) {
      p.fail({}, std::string("invalid drive scene: ") + e.what());
    }
    if (rendered_.load() < spec_.frames) worker_ = std::thread([this] { render_rest(); });
  }
  ~DriveCamera() override {
    quit_ = true;
    if (worker_.joinable()) worker_.join();
  }

  // hal::Camera
  const std::string& id() const override { return id_; }
  hal::CameraFormat format() const override { return spec_.fmt; }
  void start() override {
    outlet_.reset();
    run_.begin(clock_->now());
  }
  void stop() override { run_.end(clock_->now()); }
  bool ready_for(TimeNs t) const override {
    if (!run_.running()) return true;
    std::int64_t k = grid_.index(t - run_.start());
    if (k < 0) return true;
    k = std::min<std::int64_t>(k, spec_.frames - 1);
    return rendered_.load(std::memory_order_acquire) > k;  // frames [0, rendered_) exist
  }
  bool latest(TimeNs now, hal::FrameLease& out) override {
    out.reset();
    if (!run_.running()) return false;
    const TimeNs start = run_.start();
    std::int64_t k = grid_.index(now - start);
    if (k < 0) return false;
    k = std::min<std::int64_t>(k, spec_.frames - 1);  // after the drive the last view stays
    const std::int64_t ready = rendered_.load(std::memory_order_acquire) - 1;
    if (k > ready) {
      k = ready;  // rendering is behind: the newest rendered frame (late, with its own capture time)
      late_.fetch_add(1, std::memory_order_relaxed);
    }
    return outlet_.serve(k, out, [&](hal::Frame& f) {
      images_[static_cast<std::size_t>(k)].copyTo(f.image);  // same geometry: no allocation
      f.capture_time = start + grid_.offset(k);
      f.sequence = static_cast<std::uint64_t>(k);
      f.camera_index = index_;
      f.corrupt = false;
    });
  }
  hal::CameraStats stats() const override {
    hal::CameraStats s;
    outlet_.fill_stats(s);
    s.state = run_.state();
    return s;
  }

  // DriveTruth
  const ts::DrivePath& drive_path() const override { return spec_.path; }
  const ts::Terrain* drive_terrain() const override { return terrain_.get(); }
  TimeNs drive_start_time() const override { return run_.start(); }

  int frames_rendered() const { return rendered_.load(std::memory_order_acquire); }
  std::uint64_t late_polls() const { return late_.load(std::memory_order_relaxed); }

 private:
  cv::Mat render(int k) const {
    const ts::DrivePose b = spec_.path.pose_at(k / spec_.fmt.rate_hz);
    ts::CameraPose cam = cam_;
    const double c = std::cos(b.yaw_rad), s = std::sin(b.yaw_rad);
    cam.x_m = b.x_m + c * mount_.x_m - s * mount_.y_m;
    cam.y_m = b.y_m + s * mount_.x_m + c * mount_.y_m;
    cam.yaw_rad = b.yaw_rad + mount_.yaw_rad;
    // The body rests level on the ground under it: the mount height is above the mean terrain of
    // its footprint (0.8 m x 0.8 m, the path is kept clear of rocks), not above z = 0.
    cam.height_m = mount_.z_m + ground_under(b);
    ts::RenderOptions ro = spec_.render;
    ro.noise_seed = spec_.tile.seed * 1000003ULL + static_cast<std::uint64_t>(k);
    cv::Mat u8 = ts::to_u8(ts::render_camera(*terrain_, cam, sun_, ro).image);
    if (spec_.fmt.format == hal::PixelFormat::kBgr8) {
      cv::Mat bgr;
      cv::cvtColor(u8, bgr, cv::COLOR_GRAY2BGR);
      u8 = bgr;
    }
    return u8.isContinuous() ? u8 : u8.clone();
  }
  double ground_under(const ts::DrivePose& b) const {
    double sum = 0.0;
    int n = 0;
    const double c = std::cos(b.yaw_rad), s = std::sin(b.yaw_rad);
    for (int i = -2; i <= 2; ++i)
      for (int j = -2; j <= 2; ++j) {
        const double u = 0.2 * i, v = 0.2 * j;
        const double z = terrain_->height_at(b.x_m + c * u - s * v, b.y_m + s * u + c * v);
        if (std::isfinite(z)) sum += z, ++n;
      }
    return n > 0 ? sum / n : 0.0;
  }
  void render_rest() {
    for (int k = rendered_.load(); k < spec_.frames && !quit_.load(); ++k) {
      images_[static_cast<std::size_t>(k)] = render(k);
      rendered_.store(k + 1, std::memory_order_release);
    }
  }

  std::string id_;
  std::uint16_t index_ = 0;
  Clock* clock_ = nullptr;
  DriveSpec spec_;
  TimeGrid grid_;
  ts::CameraPose cam_;
  Pose mount_;
  ts::Sun sun_;
  std::unique_ptr<ts::Terrain> terrain_;
  std::vector<cv::Mat> images_;  // sized once; element k written before rendered_ > k
  FrameOutlet outlet_;
  std::atomic<int> rendered_{0};
  std::atomic<bool> quit_{false};
  std::thread worker_;
  RunSpan run_;
  std::atomic<std::uint64_t> late_{0};
};

// ---- encoders ---------------------------------------------------------------------------------

struct DriveWheel {
  std::string name;
  double y_m = 0.0, radius_m = 0.1, slip = 0.0;
};

class DriveEncoders final : public LazyEncoders, public DriveTruth {
 public:
  DriveEncoders(const hal::DeviceContext& ctx, DriveSpec spec, std::vector<DriveWheel> wheels)
      : LazyEncoders(ctx, names(wheels), spec.max_extrapolation),
        spec_(std::move(spec)),
        wheels_(std::move(wheels)),
        grid_(spec_.sample_rate_hz) {}

  const ts::DrivePath& drive_path() const override { return spec_.path; }
  const ts::Terrain* drive_terrain() const override { return nullptr; }
  TimeNs drive_start_time() const override { return start_time(); }

 protected:
  std::int64_t index_at(std::size_t, TimeNs rel) const override { return grid_.index(rel); }
  hal::AngleSample sample(std::size_t wheel, std::int64_t g) const override {
    const DriveWheel& w = wheels_[wheel];
    const TimeNs stamp = grid_.offset(g);
    return {stamp, (1.0 + w.slip) * spec_.path.wheel_distance(w.y_m, to_seconds(stamp)) / w.radius_m};
  }

 private:
  static std::vector<std::string> names(const std::vector<DriveWheel>& w) {
    std::vector<std::string> n;
    for (const auto& x : w) n.push_back(x.name);
    return n;
  }
  DriveSpec spec_;
  std::vector<DriveWheel> wheels_;
  TimeGrid grid_;
};

// ---- IMU --------------------------------------------------------------------------------------

class DriveImu final : public GridImu, public DriveTruth {
 public:
  DriveImu(const hal::DeviceContext& ctx, DriveSpec spec) : GridImu(ctx, spec.imu_rate_hz), spec_(std::move(spec)) {}

  const ts::DrivePath& drive_path() const override { return spec_.path; }
  const ts::Terrain* drive_terrain() const override { return nullptr; }
  TimeNs drive_start_time() const override { return start_time(); }

 private:
  // A level body; heading in the local-level frame (x = the heading at start).
  Attitude attitude(double t) const override {
    return {0.0, 0.0, spec_.path.pose_at(t).yaw_rad - spec_.path.start_yaw_rad};
  }
  void motion(double t, hal::ImuSample& out) const override {
    const cv::Vec2d v = spec_.path.velocity_at(t);
    out.angular_velocity = {0.0, 0.0, v[1]};
    // Specific force on a level body: gravity's reaction plus the centripetal acceleration (left).
    out.linear_acceleration = {0.0, v[0] * v[1], spec_.gravity_mps2};
  }
  DriveSpec spec_;
};

}  // namespace
}  // namespace detail

std::unique_ptr<hal::Camera> make_synthetic_drive_camera(Params& p, const hal::DeviceContext& ctx) {
  detail::DriveSpec spec = detail::read_spec(p, ctx);
  return std::make_unique<detail::DriveCamera>(ctx, std::move(spec), p);
}

std::unique_ptr<hal::WheelEncoders> make_synthetic_drive_encoders(Params& p, const hal::DeviceContext& ctx) {
  detail::DriveSpec spec = detail::read_spec(p, ctx);
  // The wheels are the rover description's wheels reported by this device.
  std::vector<detail::DriveWheel> wheels;
  if (ctx.rover != nullptr)
    for (const Wheel& w : ctx.rover->wheels)
      if (w.encoders == ctx.id)
        wheels.push_back({w.name, w.y_m, w.radius_m, w.y_m >= 0.0 ? spec.slip_left : spec.slip_right});
  if (wheels.empty())
    p.fail({}, "synthetic_drive encoders report the rover's wheels: give rover.wheels entries with `encoders: " +
                   ctx.id + "` (name, x_m, y_m, radius_m)");
  for (const auto& w : wheels)
    if (!(w.radius_m > 0.0))
      p.fail({}, "rover.wheels." + w.name + ".radius_m must be > 0 for synthetic_drive encoders");
  return std::make_unique<detail::DriveEncoders>(ctx, std::move(spec), std::move(wheels));
}

std::unique_ptr<hal::Imu> make_synthetic_drive_imu(Params& p, const hal::DeviceContext& ctx) {
  return std::make_unique<detail::DriveImu>(ctx, detail::read_spec(p, ctx));
}

}  // namespace regolith::mocks
