#include "regolith/hal_libcamera/libcamera.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <map>
#include <mutex>
#include <ostream>
#include <thread>

#include <sys/mman.h>

#include <libcamera/camera.h>
#include <libcamera/camera_manager.h>
#include <libcamera/control_ids.h>
#include <libcamera/formats.h>
#include <libcamera/framebuffer_allocator.h>
#include <libcamera/property_ids.h>
#include <libcamera/request.h>
#include <libcamera/stream.h>

#include "regolith/core/image_limits.hpp"
#include "regolith/hal/unopened.hpp"
#include "regolith/hal_v4l2/convert.hpp"
#include "regolith/hal_v4l2/v4l2.hpp"

namespace regolith::hal::libcam {

namespace lc = libcamera;
using v4l2::DeviceFormat;

namespace {

// libcamera allows one CameraManager per process: every camera of this backend shares it.
std::mutex g_manager_mutex;
std::weak_ptr<lc::CameraManager> g_manager;

std::shared_ptr<lc::CameraManager> shared_manager() {
  std::lock_guard<std::mutex> lock(g_manager_mutex);
  if (auto m = g_manager.lock()) return m;
  std::shared_ptr<lc::CameraManager> m(new lc::CameraManager(), [](lc::CameraManager* cm) {
    cm->stop();
    delete cm;
  });
  const int r = m->start();
  if (r < 0) throw std::runtime_error("libcamera camera manager failed to start: " + std::string(std::strerror(-r)));
  g_manager = m;
  return m;
}

bool device_format_of(const lc::PixelFormat& pf, DeviceFormat& out) {
  // libcamera names formats by the little-endian word: BGR888 is R,G,B in memory
  if (pf == lc::formats::BGR888) {
    out = DeviceFormat::kRgb24;
    return true;
  }
  if (pf == lc::formats::RGB888) {
    out = DeviceFormat::kBgr24;
    return true;
  }
  if (pf == lc::formats::YUYV) {
    out = DeviceFormat::kYuyv;
    return true;
  }
  if (pf == lc::formats::UYVY) {
    out = DeviceFormat::kUyvy;
    return true;
  }
  if (pf == lc::formats::R8) {
    out = DeviceFormat::kGrey;
    return true;
  }
  if (pf == lc::formats::MJPEG) {
    out = DeviceFormat::kMjpeg;
    return true;
  }
  return false;
}

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
  return s.empty() ? "none" : s;
}

lc::StreamRole role_of(const std::string& r) {
  if (r == "raw") return lc::StreamRole::Raw;
  if (r == "still") return lc::StreamRole::StillCapture;
  if (r == "viewfinder") return lc::StreamRole::Viewfinder;
  return lc::StreamRole::VideoRecording;
}

std::vector<std::string> camera_ids(lc::CameraManager& m) {
  std::vector<std::string> ids;
  for (const auto& c : m.cameras()) ids.push_back(c->id());
  return ids;
}

}  // namespace

// ------------------------------------------------------------------------------------------------
void Config::validate() const {
  if (index < 0) throw FieldError("", "index", "must be >= 0");
  if (role != "raw" && role != "still" && role != "video" && role != "viewfinder") {
    throw FieldError("", "role", "must be raw, still, video or viewfinder (got '" + role + "')");
  }
  validate_capture(width, height, frame_timeout_s);
  if (buffers < 1 || buffers > 16) throw FieldError("", "buffers", "must be in [1, 16]");
  if (!(rate_hz >= 0.0) || rate_hz > 1000.0)
    throw FieldError("", "rate", "must be in [0, 1000] Hz (0: the camera's own)");
  validate_backoff(retry_min_s, retry_max_s);
  if (max_readers < 1 || max_readers > 64) throw FieldError("", "max_readers", "must be in [1, 64]");
}

Config config_from_params(Params& p) {
  Config c;
  c.camera =
      p.get<std::string>("camera", "", {.doc = "libcamera camera id as `cam --list` prints it (empty: use index)"});
  c.index = p.get<int>("index", c.index, {.min = 0, .max = 63, .doc = "camera index when no id is given"});
  c.role = p.get<std::string>("role", c.role,
                              {.choices = {"raw", "still", "video", "viewfinder"}, .doc = "libcamera stream role"});
  c.width = p.get<int>("width", c.width, {.unit = "px", .min = 1, .max = kMaxImageSidePx, .doc = "frame width"});
  c.height = p.get<int>("height", c.height, {.unit = "px", .min = 1, .max = kMaxImageSidePx, .doc = "frame height"});
  c.pixel_format = p.get<std::string>("format", c.pixel_format,
                                      {.choices = {"auto", "BGR888", "RGB888", "YUYV", "UYVY", "R8", "MJPEG"},
                                       .doc = "libcamera pixel format (auto: cheapest the camera offers)"});
  c.output = pixel_format_from_string(
      p.get<std::string>("pixel_format", "bgr8", {.choices = {"mono8", "bgr8"}, .doc = "output pixel format"}));
  c.buffers = p.get<int>("buffers", c.buffers, {.min = 1, .max = 16, .doc = "requests in flight"});
  c.rate_hz = p.get<double>("rate", c.rate_hz,
                            {.unit = "Hz",
                             .min = 0.0,
                             .max = 1000.0,
                             .doc = "frame rate, set through FrameDurationLimits when the camera has it (0: the "
                                    "camera's own, unknown to the components)"});
  c.frame_timeout_s = p.get<double>("frame_timeout", c.frame_timeout_s,
                                    {.unit = "s",
                                     .min = 0.0,
                                     .max = 60.0,
                                     .min_exclusive = true,
                                     .doc = "no completed request for this long -> fault and restart"});
  c.retry_min_s =
      p.get<double>("retry_min", c.retry_min_s, {.unit = "s", .min = 0.001, .max = 60.0, .doc = "first restart delay"});
  c.retry_max_s = p.get<double>("retry_max", c.retry_max_s,
                                {.unit = "s", .min = 0.001, .max = 600.0, .doc = "restart back-off ceiling"});
  c.max_readers = p.get<int>("max_readers", c.max_readers, {.min = 1, .max = 64, .doc = "simultaneous frame leases"});
  Params ctl = p.child("controls");
  for (const auto& name : ctl.keys()) {
    c.controls.emplace_back(name, ctl.require<std::string>(name, {.doc = "libcamera control value"}));
  }
  ctl.finish();
  p.finish_and_check([&] { c.validate(); });
  return c;
}

// ------------------------------------------------------------------------------------------------
struct LibcameraCamera::Impl {
  struct Mapped {
    std::uint8_t* data = nullptr;  // plane 0
    std::size_t length = 0;
    void* base = nullptr;
    std::size_t map_length = 0;
  };

  Config cfg;
  std::string id;
  std::uint16_t index = 0;
  Clock* clock = nullptr;
  std::unique_ptr<Clock> own_clock;
  CameraFormat format;
  DeviceFormat dev_format = DeviceFormat::kRgb24;
  std::string dev_format_name;
  std::size_t stride = 0;
  std::unique_ptr<FramePool> pool;

  std::shared_ptr<lc::CameraManager> manager;
  std::shared_ptr<lc::Camera> cam;
  std::string cam_id;
  std::unique_ptr<lc::CameraConfiguration> config;
  lc::Stream* stream = nullptr;
  std::unique_ptr<lc::FrameBufferAllocator> alloc;
  std::vector<std::unique_ptr<lc::Request>> requests;
  std::map<const lc::FrameBuffer*, Mapped> maps;
  std::unique_ptr<lc::ControlList> controls;
  bool acquired = false;
  bool cam_started = false;

  std::atomic<bool> running{false};
  std::atomic<bool> accepting{false};  // completion callback may re-queue
  std::atomic<bool> fault_flag{false};
  std::atomic<TimeNs> last_complete{0};
  bool have_seq = false;
  std::uint32_t last_seq = 0;
  std::thread monitor;
  std::mutex wait_mutex;
  std::condition_variable wait_cv;
  bool stop_requested = false;

  std::atomic<std::uint64_t> frames{0}, dropped{0}, corrupt{0}, faults{0}, recoveries{0};
  std::atomic<DeviceState> state{DeviceState::kStopped};
  std::atomic<TimeNs> last_frame_time{0};
  mutable std::mutex text_mutex;
  std::string last_error;

  void set_error(const std::string& s) {
    std::lock_guard<std::mutex> lock(text_mutex);
    last_error = s;
  }
  std::string who() const { return "libcamera camera '" + id + "'" + (cam_id.empty() ? "" : " (" + cam_id + ")"); }

  void open(bool first);
  void build_controls();
  void set_frame_rate(const lc::ControlInfoMap& info);
  void start_streaming();
  void teardown();
  void on_complete(lc::Request* r);
  void on_disconnect() {
    fault_flag.store(true);
    wait_cv.notify_all();
  }
  void run_monitor();
  bool wait_for(TimeNs d) {  // true when stop was requested
    std::unique_lock<std::mutex> lock(wait_mutex);
    wait_cv.wait_for(lock, std::chrono::nanoseconds(d), [this] { return stop_requested || fault_flag.load(); });
    return stop_requested;
  }
};

void LibcameraCamera::Impl::open(bool first) {
  if (!manager) manager = shared_manager();
  auto cams = manager->cameras();
  const bool missing =
      cfg.camera.empty() ? static_cast<std::size_t>(cfg.index) >= cams.size() : !manager->get(cfg.camera);
  if (missing && !first && manager.use_count() == 1) {
    // the camera may have re-appeared: a camera manager without udev does not hot-plug, so
    // restart it (only when no other camera of this process holds it)
    manager.reset();
    manager = shared_manager();
    cams = manager->cameras();
  }
  if (cams.empty()) {
    throw DeviceUnavailableError(
        "camera", who() + ": libcamera sees no camera (needs libcamera-ipa and udev-initialised devices)");
  }
  if (!cfg.camera.empty()) {
    cam = manager->get(cfg.camera);
    if (!cam)
      throw DeviceUnavailableError(
          "camera", who() + ": no camera '" + cfg.camera + "' (cameras: " + join(camera_ids(*manager)) + ")");
  } else {
    if (static_cast<std::size_t>(cfg.index) >= cams.size()) {
      throw DeviceUnavailableError("index", who() + ": index " + std::to_string(cfg.index) + " but only " +
                                                std::to_string(cams.size()) +
                                                " camera(s): " + join(camera_ids(*manager)));
    }
    cam = cams[static_cast<std::size_t>(cfg.index)];
  }
  cam_id = cam->id();
  if (cam->acquire() < 0) {
    cam.reset();
    throw DeviceUnavailableError("camera", who() + ": busy (acquired by another process or camera)");
  }
  acquired = true;
  config = cam->generateConfiguration({role_of(cfg.role)});
  if (!config || config->empty()) throw DeviceConfigError("role", who() + ": does not support role '" + cfg.role + "'");
  lc::StreamConfiguration& sc = config->at(0);
  const auto offered = sc.formats().pixelformats();
  std::vector<std::string> offered_names;
  for (const auto& f : offered) offered_names.push_back(f.toString());
  lc::PixelFormat chosen;
  if (cfg.pixel_format == "auto") {
    for (DeviceFormat want : v4l2::preferred_formats(cfg.output)) {
      for (const auto& f : offered) {
        DeviceFormat have{};
        if (device_format_of(f, have) && have == want) {
          chosen = f;
          break;
        }
      }
      if (chosen.isValid()) break;
    }
    if (!chosen.isValid())
      throw DeviceConfigError("format", who() + ": offers no convertible format (offers: " + join(offered_names) + ")");
  } else {
    chosen = lc::PixelFormat::fromString(cfg.pixel_format);
    if (std::find(offered.begin(), offered.end(), chosen) == offered.end()) {
      throw DeviceConfigError("format", who() + ": does not offer " + cfg.pixel_format + " for role '" + cfg.role +
                                            "' (offers: " + join(offered_names) + ")");
    }
  }
  sc.pixelFormat = chosen;
  sc.size = lc::Size(static_cast<unsigned>(cfg.width), static_cast<unsigned>(cfg.height));
  sc.bufferCount = static_cast<unsigned>(cfg.buffers);
  const auto status = config->validate();
  if (status == lc::CameraConfiguration::Invalid) {
    throw DeviceConfigError("format", who() + ": configuration " + sc.toString() + " is invalid");
  }
  if (sc.size.width != static_cast<unsigned>(cfg.width) || sc.size.height != static_cast<unsigned>(cfg.height)) {
    throw DeviceConfigError("width", who() + ": cannot produce " + std::to_string(cfg.width) + "x" +
                                         std::to_string(cfg.height) + " in " + chosen.toString() + " (it proposed " +
                                         sc.size.toString() + "; range " + sc.formats().range(chosen).toString() + ")");
  }
  if (sc.pixelFormat != chosen) {
    throw DeviceConfigError("format", who() + ": replaced " + chosen.toString() + " by " + sc.pixelFormat.toString());
  }
  if (const int r = cam->configure(config.get()); r < 0) {
    throw std::runtime_error(who() + ": configure " + sc.toString() + ": " + std::strerror(-r));
  }
  device_format_of(sc.pixelFormat, dev_format);
  dev_format_name = sc.pixelFormat.toString();
  stride = sc.stride;
  stream = sc.stream();
  if (first) format = CameraFormat{cfg.width, cfg.height, cfg.output, cfg.rate_hz};
  build_controls();
  alloc = std::make_unique<lc::FrameBufferAllocator>(cam);
  if (alloc->allocate(stream) < 0) throw std::runtime_error(who() + ": cannot allocate buffers");
  std::uint64_t cookie = 0;
  for (const auto& fb : alloc->buffers(stream)) {
    const auto& plane = fb->planes().at(0);
    const std::size_t map_len = plane.offset + plane.length;
    void* base = ::mmap(nullptr, map_len, PROT_READ, MAP_SHARED, plane.fd.get(), 0);
    if (base == MAP_FAILED) throw std::runtime_error(who() + ": mmap of a frame buffer: " + std::strerror(errno));
    maps[fb.get()] = Mapped{static_cast<std::uint8_t*>(base) + plane.offset, plane.length, base, map_len};
    auto req = cam->createRequest(cookie++);
    if (!req || req->addBuffer(stream, fb.get()) < 0) throw std::runtime_error(who() + ": cannot create a request");
    requests.push_back(std::move(req));
  }
  cam->requestCompleted.connect(this, &Impl::on_complete);
  cam->disconnected.connect(this, &Impl::on_disconnect);
}

// `rate`: both frame-duration limits at 1 / rate, when the camera has the control. A camera without
// it keeps its own rate, and `rate` is the nominal one the components time their inputs by (what
// the V4L2 backend does with a driver that has no frame intervals).
void LibcameraCamera::Impl::set_frame_rate(const lc::ControlInfoMap& info) {
  if (!(cfg.rate_hz > 0.0)) return;
  const auto it = info.find(lc::controls::FrameDurationLimits.id());
  if (it == info.end()) return;
  const auto us = static_cast<std::int64_t>(std::llround(1e6 / cfg.rate_hz));
  const lc::ControlInfo& range = it->second;
  const auto scalar64 = [](const lc::ControlValue& v) { return v.type() == lc::ControlTypeInteger64 && !v.isArray(); };
  if (scalar64(range.min()) && scalar64(range.max()) &&
      (us < range.min().get<std::int64_t>() || us > range.max().get<std::int64_t>())) {
    char rate[32];
    std::snprintf(rate, sizeof rate, "%g", cfg.rate_hz);
    throw DeviceConfigError("rate", who() + ": rate " + rate + " Hz is a frame duration of " + std::to_string(us) +
                                        " us, outside the camera's " + range.toString() + " us");
  }
  const std::array<std::int64_t, 2> limits{us, us};
  controls->set(lc::controls::FrameDurationLimits, lc::Span<const std::int64_t, 2>(limits));
}

void LibcameraCamera::Impl::build_controls() {
  controls = std::make_unique<lc::ControlList>(cam->controls());
  const lc::ControlInfoMap& info = cam->controls();
  set_frame_rate(info);
  std::vector<std::string> names;
  for (const auto& [cid, ci] : info) names.push_back(cid->name());
  std::sort(names.begin(), names.end());
  for (const auto& control : cfg.controls) {
    const std::string& name = control.first;  // named, not bound: lambdas capture them (clang 14)
    const std::string& text = control.second;
    auto it = std::find_if(info.begin(), info.end(), [&](const auto& kv) { return kv.first->name() == name; });
    if (it == info.end()) {
      std::string msg = who() + ": has no control '" + name + "'";
      const std::string guess = did_you_mean(name, names);
      if (!guess.empty()) msg += " (did you mean '" + guess + "'?)";
      throw DeviceConfigError("controls", msg + "; controls: " + join(names));
    }
    const lc::ControlId* cid = it->first;
    const lc::ControlInfo& range = it->second;
    auto bad = [&](const std::string& why) {
      throw DeviceConfigError(
          "controls", who() + ": control " + name + " = '" + text + "': " + why + " (range " + range.toString() + ")");
    };
    try {
      std::size_t pos = 0;
      switch (cid->type()) {
        case lc::ControlTypeBool: {
          if (text != "true" && text != "false") bad("expected true or false");
          controls->set(cid->id(), lc::ControlValue(text == "true"));
          break;
        }
        case lc::ControlTypeInteger32: {
          const long long v = std::stoll(text, &pos, 0);
          if (pos != text.size()) bad("not an integer");
          if (v < range.min().get<std::int32_t>() || v > range.max().get<std::int32_t>()) bad("out of range");
          controls->set(cid->id(), lc::ControlValue(static_cast<std::int32_t>(v)));
          break;
        }
        case lc::ControlTypeInteger64: {
          const long long v = std::stoll(text, &pos, 0);
          if (pos != text.size()) bad("not an integer");
          controls->set(cid->id(), lc::ControlValue(static_cast<std::int64_t>(v)));
          break;
        }
        case lc::ControlTypeFloat: {
          const float v = std::stof(text, &pos);
          if (pos != text.size() || !std::isfinite(v)) bad("not a number");
          if (v < range.min().get<float>() || v > range.max().get<float>()) bad("out of range");
          controls->set(cid->id(), lc::ControlValue(v));
          break;
        }
        default: bad("only bool, integer and float controls can be set from YAML");
      }
    } catch (const std::invalid_argument&) {
      bad("not a number");
    } catch (const std::out_of_range&) {
      bad("out of range");
    }
  }
}

void LibcameraCamera::Impl::start_streaming() {
  have_seq = false;
  if (const int r = cam->start(controls.get()); r < 0)
    throw std::runtime_error(who() + ": start: " + std::strerror(-r));
  cam_started = true;
  accepting.store(true);
  last_complete.store(clock->now());
  for (auto& req : requests) {
    if (const int r = cam->queueRequest(req.get()); r < 0)
      throw std::runtime_error(who() + ": queueRequest: " + std::strerror(-r));
  }
}

void LibcameraCamera::Impl::teardown() {
  accepting.store(false);
  if (cam && cam_started) cam->stop();
  cam_started = false;
  if (cam) {
    cam->requestCompleted.disconnect(this);
    cam->disconnected.disconnect(this);
  }
  requests.clear();
  for (auto& [fb, m] : maps) ::munmap(m.base, m.map_length);
  maps.clear();
  if (alloc && stream) alloc->free(stream);
  alloc.reset();
  config.reset();
  stream = nullptr;
  if (cam && acquired) cam->release();
  acquired = false;
  cam.reset();
}

void LibcameraCamera::Impl::on_complete(lc::Request* r) {
  if (r->status() == lc::Request::RequestCancelled || !accepting.load()) return;
  const TimeNs now = clock->now();
  last_complete.store(now);
  const auto& bufs = r->buffers();
  if (!bufs.empty()) {
    const lc::FrameBuffer* fb = bufs.begin()->second;
    const lc::FrameMetadata& md = fb->metadata();
    dropped.fetch_add(v4l2::sequence_gap(have_seq, last_seq, md.sequence));
    have_seq = true;
    last_seq = md.sequence;
    TimeNs stamp = now;
    const auto sensor = r->metadata().get(lc::controls::SensorTimestamp);
    const TimeNs kernel = sensor ? static_cast<TimeNs>(*sensor) : static_cast<TimeNs>(md.timestamp);
    if (!clock->simulated() && kernel > 0) {
      const TimeNs mapped = kernel + (now - monotonic_now());  // libcamera stamps are CLOCK_MONOTONIC
      if (mapped - now < kNsPerSec && now - mapped < 10 * kNsPerSec) stamp = std::min(mapped, now);
    }
    auto it = maps.find(fb);
    Frame* slot = it == maps.end() ? nullptr : pool->begin_write();
    if (slot == nullptr) {
      dropped.fetch_add(1);
    } else {
      const std::size_t used = md.planes().empty() ? it->second.length : md.planes()[0].bytesused;
      std::string err;
      if (v4l2::convert_frame(dev_format, it->second.data, std::min(used, it->second.length), format.width,
                              format.height, stride, format.format, slot->image, err)) {
        slot->capture_time = stamp;
        slot->sequence = md.sequence;
        slot->camera_index = index;
        slot->corrupt = md.status == lc::FrameMetadata::FrameError;
        pool->commit();
        frames.fetch_add(1);
        if (slot->corrupt) corrupt.fetch_add(1);
        last_frame_time.store(stamp);
      } else {
        corrupt.fetch_add(1);
        set_error("frame " + std::to_string(md.sequence) + ": " + err);
      }
    }
  }
  if (accepting.load()) {
    r->reuse(lc::Request::ReuseBuffers);
    if (cam->queueRequest(r) < 0) {
      fault_flag.store(true);
      wait_cv.notify_all();
    }
  }
}

void LibcameraCamera::Impl::run_monitor() {
  Backoff backoff(static_cast<TimeNs>(cfg.retry_min_s * 1e9), static_cast<TimeNs>(cfg.retry_max_s * 1e9));
  const auto timeout = static_cast<TimeNs>(cfg.frame_timeout_s * 1e9);
  while (running.load()) {
    if (wait_for(std::clamp<TimeNs>(timeout / 4, 10 * kNsPerMs, 250 * kNsPerMs))) break;
    const bool stalled = clock->now() - last_complete.load() > timeout;
    if (!fault_flag.load() && !stalled) continue;
    faults.fetch_add(1);
    state.store(DeviceState::kFaulted);
    set_error(who() + (fault_flag.load() ? ": disconnected or request failed"
                                         : ": no frame for " + std::to_string(cfg.frame_timeout_s) + " s"));
    teardown();
    fault_flag.store(false);
    while (running.load()) {
      state.store(DeviceState::kRecovering);
      if (wait_for(backoff.next())) return;
      fault_flag.store(false);
      try {
        open(false);
        start_streaming();
        backoff.reset();
        recoveries.fetch_add(1);
        state.store(DeviceState::kStreaming);
        set_error(who() + ": restarted");
        break;
      } catch (const std::exception& e) {
        set_error(std::string("restarting: ") + e.what());
        teardown();
      }
    }
  }
}

// ------------------------------------------------------------------------------------------------
LibcameraCamera::LibcameraCamera(Config cfg, const DeviceContext& ctx) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.cfg = std::move(cfg);
  m.id = ctx.id;
  m.index = ctx.index;
  m.clock = ctx.clock;
  try {
    m.cfg.validate();
  } catch (const FieldError& e) {
    throw DeviceConfigError(e.field(), "libcamera camera '" + m.id + "': " + e.what());
  }
  if (m.clock == nullptr) {
    m.own_clock = std::make_unique<SystemClock>();
    m.clock = m.own_clock.get();
  }
  try {
    m.open(true);
  } catch (...) {
    m.teardown();
    throw;
  }
  m.pool =
      make_frame_pool(m.format.width, m.format.height, m.format.format, static_cast<std::size_t>(m.cfg.max_readers));
}

LibcameraCamera::~LibcameraCamera() {
  stop();
  impl_->teardown();
}

const std::string& LibcameraCamera::id() const {
  return impl_->id;
}
CameraFormat LibcameraCamera::format() const {
  return impl_->format;
}
std::string LibcameraCamera::camera_id() const {
  return impl_->cam_id;
}
std::string LibcameraCamera::device_format() const {
  return impl_->dev_format_name;
}
std::string LibcameraCamera::last_error() const {
  std::lock_guard<std::mutex> lock(impl_->text_mutex);
  return impl_->last_error;
}

void LibcameraCamera::start() {
  Impl& m = *impl_;
  if (m.running.load()) return;
  try {
    if (!m.cam) m.open(false);
    m.start_streaming();
  } catch (const DeviceError& e) {
    m.teardown();
    throw std::runtime_error(e.what());
  } catch (...) {
    m.teardown();
    throw;
  }
  {
    std::lock_guard<std::mutex> lock(m.wait_mutex);
    m.stop_requested = false;
  }
  m.fault_flag.store(false);
  m.state.store(DeviceState::kStreaming);
  m.running.store(true);
  m.monitor = std::thread([&m] { m.run_monitor(); });
}

void LibcameraCamera::stop() {
  Impl& m = *impl_;
  if (!m.running.exchange(false)) return;
  {
    std::lock_guard<std::mutex> lock(m.wait_mutex);
    m.stop_requested = true;
  }
  m.wait_cv.notify_all();
  if (m.monitor.joinable()) m.monitor.join();
  m.teardown();
  m.state.store(DeviceState::kStopped);
}

bool LibcameraCamera::latest(TimeNs /*now*/, FrameLease& out) {
  if (impl_->state.load(std::memory_order_acquire) != DeviceState::kStreaming) {
    out.reset();
    return false;
  }
  out = impl_->pool->acquire();
  return static_cast<bool>(out);
}

CameraStats LibcameraCamera::stats() const {
  const Impl& m = *impl_;
  CameraStats s;
  s.frames = m.frames.load();
  s.dropped = m.dropped.load();
  s.corrupt = m.corrupt.load();
  s.faults = m.faults.load();
  s.recoveries = m.recoveries.load();
  s.state = m.state.load();
  s.last_frame_time = m.last_frame_time.load();
  return s;
}

// ------------------------------------------------------------------------------------------------
std::vector<CameraInfo> list_libcamera_cameras() {
  std::vector<CameraInfo> out;
  std::shared_ptr<lc::CameraManager> m = shared_manager();
  for (const auto& cam : m->cameras()) {
    CameraInfo ci;
    ci.id = cam->id();
    if (auto model = cam->properties().get(lc::properties::Model)) ci.model = *model;
    auto cfg = cam->generateConfiguration({lc::StreamRole::VideoRecording});
    if (cfg && !cfg->empty()) {
      const auto& formats = cfg->at(0).formats();
      for (const auto& pf : formats.pixelformats()) {
        CameraInfo::Format f;
        f.pixel_format = pf.toString();
        for (const auto& s : formats.sizes(pf))
          f.sizes.emplace_back(static_cast<int>(s.width), static_cast<int>(s.height));
        f.size_range = formats.range(pf).toString();
        ci.formats.push_back(std::move(f));
      }
    }
    for (const auto& [cid, info] : cam->controls()) ci.controls.push_back(cid->name() + " " + info.toString());
    std::sort(ci.controls.begin(), ci.controls.end());
    out.push_back(std::move(ci));
  }
  return out;
}

void register_libcamera_backend(BackendRegistry& r) {
  r.add_lister(
      "libcamera",
      [](std::ostream& os) {
        const auto cams = hal::libcam::list_libcamera_cameras();
        os << "libcamera cameras (backend: libcamera):" << (cams.empty() ? " none\n" : "\n");
        for (const auto& c : cams) {
          os << "  id: \"" << c.id << "\"" << (c.model.empty() ? "" : "  model: " + c.model) << "\n";
          for (const auto& f : c.formats) {
            os << "    " << f.pixel_format << ":";
            for (const auto& [w, h] : f.sizes) os << " " << w << "x" << h;
            if (!f.size_range.empty()) os << " (" << f.size_range << ")";
            os << "\n";
          }
        }
      },
      /*slow: the camera manager takes seconds to start*/ true);
  r.add_camera(
      "libcamera",
      "libcamera camera (CSI sensors with ISP pipelines, UVC, vimc): request queue, sensor timestamps, auto-restart",
      [](Params& p, const DeviceContext& ctx) -> std::unique_ptr<Camera> {
        Config c = config_from_params(p);
        if (!ctx.open_devices) {
          return make_unopened_camera(ctx.id, CameraFormat{c.width, c.height, c.output, c.rate_hz});
        }
        try {
          return std::make_unique<LibcameraCamera>(std::move(c), ctx);
        } catch (const DeviceError& e) {
          rethrow_located(p, e);  // ConfigError, or DeviceUnavailableError (may appear later)
        }
      });
}

}  // namespace regolith::hal::libcam
