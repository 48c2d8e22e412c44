#include "regolith/hal_v4l2/v4l2.hpp"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <ostream>
#include <stdexcept>

#include <fcntl.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include "regolith/core/image_limits.hpp"
#include "regolith/core/params.hpp"
#include "regolith/hal/unopened.hpp"

namespace regolith::hal::v4l2 {

namespace {

int xioctl(int fd, unsigned long request, void* arg) {
  int r = 0;
  do {
    r = ::ioctl(fd, request, arg);
  } while (r == -1 && errno == EINTR);
  return r;
}

std::string errno_text(int e) {
  return std::string(std::strerror(e));
}

/// open() failures that say the node is not usable *now* (absent, gone, busy, not yet accessible:
/// udev may still be creating it or setting its group) rather than a wrong configuration. EPERM
/// (a device cgroup denying it, e.g. the unit's DevicePolicy) is not among them: it stays so.
bool unavailable_errno(int e) {
  return e == ENOENT || e == ENODEV || e == ENXIO || e == EBUSY || e == EACCES;
}

std::string cstr(const __u8* s, std::size_t n) {
  const auto* c = reinterpret_cast<const char*>(s);
  return std::string(c, strnlen(c, n));
}

std::string describe_capture_devices(const std::vector<DeviceInfo>& devs) {
  std::string s;
  for (const auto& d : devs) {
    if (!d.capture) continue;
    s += (s.empty() ? "" : "; ") + d.path + " card '" + d.card + "' bus_info '" + d.bus_info + "'";
  }
  return s.empty() ? "none" : s;
}

int video_number(const std::string& path) {
  const auto digits = path.find_first_of("0123456789");
  return digits == std::string::npos ? 1 << 20 : std::atoi(path.c_str() + digits);
}

}  // namespace

// ------------------------------------------------------------------------------------------------
void Config::validate() const {
  if (device.empty() && card.empty() && bus_info.empty()) {
    throw FieldError("", "device", "give device (e.g. /dev/video0), card or bus_info");
  }
  validate_capture(width, height, frame_timeout_s);
  if (fourcc != "auto") {
    DeviceFormat f{};
    std::uint32_t code = 0;
    try {
      code = fourcc_from_string(fourcc);
    } catch (const std::invalid_argument& e) {
      throw FieldError("", "fourcc", e.what());
    }
    if (!device_format_from_fourcc(code, f)) {
      throw FieldError("", "fourcc",
                       "'" + fourcc + "' cannot be converted (use auto, YUYV, UYVY, GREY, RGB3, BGR3 or MJPG)");
    }
  }
  if (!(rate_hz > 0.0) || rate_hz > 1000.0) throw FieldError("", "rate", "must be in (0, 1000] Hz");
  if (buffers < 2 || buffers > 32) throw FieldError("", "buffers", "must be in [2, 32]");
  validate_backoff(retry_min_s, retry_max_s);
  if (max_readers < 1 || max_readers > 64) throw FieldError("", "max_readers", "must be in [1, 64]");
  for (const auto& c : controls) {
    if (c.name.empty()) throw FieldError("", "controls", "empty control name");
  }
}

Config config_from_params(Params& p) {
  Config c;
  c.device = p.get<std::string>("device", "", {.doc = "video node, e.g. /dev/video0 (or select by card / bus_info)"});
  c.card = p.get<std::string>("card", "", {.doc = "select the capture node whose card name is exactly this"});
  c.bus_info = p.get<std::string>("bus_info", "", {.doc = "select the capture node with this bus_info"});
  c.width = p.get<int>("width", c.width, {.unit = "px", .min = 1, .max = kMaxImageSidePx, .doc = "frame width"});
  c.height = p.get<int>("height", c.height, {.unit = "px", .min = 1, .max = kMaxImageSidePx, .doc = "frame height"});
  c.fourcc = p.get<std::string>("fourcc", c.fourcc,
                                {.choices = {"auto", "YUYV", "UYVY", "GREY", "RGB3", "BGR3", "MJPG"},
                                 .doc = "device pixel format (auto: cheapest the device offers)"});
  c.output = pixel_format_from_string(
      p.get<std::string>("pixel_format", "mono8", {.choices = {"mono8", "bgr8"}, .doc = "output pixel format"}));
  c.rate_hz =
      p.get<double>("rate", c.rate_hz,
                    {.unit = "Hz", .min = 0.0, .max = 1000.0, .min_exclusive = true, .doc = "requested frame rate"});
  c.buffers = p.get<int>("buffers", c.buffers, {.min = 2, .max = 32, .doc = "mmap buffers queued in the driver"});
  c.frame_timeout_s = p.get<double>("frame_timeout", c.frame_timeout_s,
                                    {.unit = "s",
                                     .min = 0.0,
                                     .max = 60.0,
                                     .min_exclusive = true,
                                     .doc = "no frame for this long -> fault and restart"});
  c.retry_min_s = p.get<double>("retry_min", c.retry_min_s,
                                {.unit = "s", .min = 0.001, .max = 60.0, .doc = "first reconnection delay"});
  c.retry_max_s = p.get<double>("retry_max", c.retry_max_s,
                                {.unit = "s", .min = 0.001, .max = 600.0, .doc = "reconnection back-off ceiling"});
  c.max_readers = p.get<int>("max_readers", c.max_readers, {.min = 1, .max = 64, .doc = "simultaneous frame leases"});
  Params ctl = p.child("controls");
  for (const auto& name : ctl.keys()) {
    c.controls.push_back(
        {name, ctl.require<std::string>(name, {.doc = "V4L2 control value (integer, bool or menu entry)"})});
  }
  ctl.finish();
  p.finish_and_check([&] { c.validate(); });
  return c;
}

std::uint64_t sequence_gap(bool have_previous, std::uint32_t previous, std::uint32_t current) {
  if (!have_previous) return 0;
  const std::uint32_t d = current - previous;  // modulo 2^32
  if (d == 0 || d >= 0x80000000U) return 0;    // repeated or restarted numbering
  return d - 1;
}

std::string normalise_control_name(std::string_view v4l2_name) {
  std::string out;
  bool pending = false;
  for (char ch : v4l2_name) {
    const auto c = static_cast<unsigned char>(ch);
    if (std::isalnum(c)) {
      if (pending && !out.empty()) out += '_';
      pending = false;
      out += static_cast<char>(std::tolower(c));
    } else {
      pending = true;
    }
  }
  return out;
}

// ------------------------------------------------------------------------------------------------
std::vector<DeviceInfo> list_v4l2_devices(bool with_formats) {
  std::vector<std::string> paths;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator("/dev", ec)) {
    const std::string n = e.path().filename().string();
    if (n.rfind("video", 0) == 0) paths.push_back(e.path().string());
  }
  std::sort(paths.begin(), paths.end(), [](const auto& a, const auto& b) { return video_number(a) < video_number(b); });
  std::vector<DeviceInfo> out;
  for (const auto& path : paths) {
    const int fd = ::open(path.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) continue;
    v4l2_capability cap{};
    if (xioctl(fd, VIDIOC_QUERYCAP, &cap) < 0) {
      ::close(fd);
      continue;
    }
    DeviceInfo d;
    d.path = path;
    d.driver = cstr(cap.driver, sizeof cap.driver);
    d.card = cstr(cap.card, sizeof cap.card);
    d.bus_info = cstr(cap.bus_info, sizeof cap.bus_info);
    const std::uint32_t caps = (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
    d.capture = (caps & V4L2_CAP_VIDEO_CAPTURE) && (caps & V4L2_CAP_STREAMING);
    if (d.capture && with_formats) {
      for (std::uint32_t i = 0;; ++i) {
        v4l2_fmtdesc fd_desc{};
        fd_desc.index = i;
        fd_desc.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        if (xioctl(fd, VIDIOC_ENUM_FMT, &fd_desc) < 0) break;
        FormatInfo fi;
        fi.fourcc = fourcc_to_string(fd_desc.pixelformat);
        fi.description = cstr(fd_desc.description, sizeof fd_desc.description);
        DeviceFormat df{};
        fi.convertible = device_format_from_fourcc(fd_desc.pixelformat, df);
        for (std::uint32_t j = 0;; ++j) {
          v4l2_frmsizeenum fs{};
          fs.index = j;
          fs.pixel_format = fd_desc.pixelformat;
          if (xioctl(fd, VIDIOC_ENUM_FRAMESIZES, &fs) < 0) break;
          if (fs.type != V4L2_FRMSIZE_TYPE_DISCRETE) {
            fi.size_range = std::to_string(fs.stepwise.min_width) + "x" + std::to_string(fs.stepwise.min_height) +
                            " - " + std::to_string(fs.stepwise.max_width) + "x" +
                            std::to_string(fs.stepwise.max_height) + " step " + std::to_string(fs.stepwise.step_width) +
                            "x" + std::to_string(fs.stepwise.step_height);
            break;
          }
          FrameSize size;
          size.width = static_cast<int>(fs.discrete.width);
          size.height = static_cast<int>(fs.discrete.height);
          for (std::uint32_t k = 0; k < 32; ++k) {
            v4l2_frmivalenum iv{};
            iv.index = k;
            iv.pixel_format = fd_desc.pixelformat;
            iv.width = fs.discrete.width;
            iv.height = fs.discrete.height;
            if (xioctl(fd, VIDIOC_ENUM_FRAMEINTERVALS, &iv) < 0 || iv.type != V4L2_FRMIVAL_TYPE_DISCRETE) break;
            if (iv.discrete.numerator > 0) {
              size.rates_hz.push_back(static_cast<double>(iv.discrete.denominator) / iv.discrete.numerator);
            }
          }
          fi.sizes.push_back(std::move(size));
        }
        d.formats.push_back(std::move(fi));
      }
    }
    ::close(fd);
    out.push_back(std::move(d));
  }
  return out;
}

std::string select_device(const std::vector<DeviceInfo>& devices, const std::string& device, const std::string& card,
                          const std::string& bus_info) {
  for (const auto& d : devices) {
    if (!d.capture) continue;
    if (!device.empty() && d.path != device) continue;
    if (!card.empty() && d.card != card) continue;
    if (!bus_info.empty() && d.bus_info != bus_info) continue;
    return d.path;
  }
  std::string what;
  if (!device.empty()) what += "device '" + device + "'";
  if (!card.empty()) what += std::string(what.empty() ? "" : ", ") + "card '" + card + "'";
  if (!bus_info.empty()) what += std::string(what.empty() ? "" : ", ") + "bus_info '" + bus_info + "'";
  throw std::runtime_error("no video capture device matches " + what +
                           " (capture devices: " + describe_capture_devices(devices) + ")");
}

// ------------------------------------------------------------------------------------------------
V4l2Camera::V4l2Camera(Config cfg, const DeviceContext& ctx)
    : cfg_(std::move(cfg)), id_(ctx.id), index_(ctx.index), clock_(ctx.clock) {
  try {
    cfg_.validate();
  } catch (const FieldError& e) {
    throw DeviceConfigError(e.field(), "v4l2 camera '" + id_ + "': " + e.what());
  }
  if (clock_ == nullptr) {
    own_clock_ = std::make_unique<SystemClock>();
    clock_ = own_clock_.get();
  }
  wake_fd_ = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (wake_fd_ < 0) throw std::runtime_error("v4l2 camera '" + id_ + "': eventfd: " + errno_text(errno));
  try {
    open_and_configure(true);
  } catch (...) {
    close_device();
    ::close(wake_fd_);
    throw;
  }
  pool_ = make_frame_pool(format_.width, format_.height, format_.format, static_cast<std::size_t>(cfg_.max_readers));
}

V4l2Camera::~V4l2Camera() {
  stop();
  close_device();
  if (wake_fd_ >= 0) ::close(wake_fd_);
}

std::string V4l2Camera::device_path() const {
  std::lock_guard<std::mutex> lock(text_mutex_);
  return path_;
}

std::string V4l2Camera::last_error() const {
  std::lock_guard<std::mutex> lock(text_mutex_);
  return last_error_;
}

void V4l2Camera::set_error(const std::string& what) {
  std::lock_guard<std::mutex> lock(text_mutex_);
  last_error_ = what;
}

// Opens the device (found by card / bus_info when configured), sets its format, frame rate and
// controls and maps its buffers. `first`: the format the camera reports is taken from this open
// (a reopen after a fault keeps the one the frame pool was made for).
void V4l2Camera::open_and_configure(bool first) {
  const std::string dev = open_device();
  const DeviceFormat chosen = choose_format(dev);
  set_format(dev, chosen);
  const double rate = set_frame_rate();
  if (first) {
    format_ = CameraFormat{cfg_.width, cfg_.height, cfg_.output, rate};
  }
  apply_controls();
  map_buffers(dev);
  have_seq_ = false;
}

std::string V4l2Camera::open_device() {
  const std::string who = "v4l2 camera '" + id_ + "'";
  std::string path = cfg_.device;
  if (!cfg_.card.empty() || !cfg_.bus_info.empty()) {
    try {
      path = select_device(list_v4l2_devices(false), cfg_.device, cfg_.card, cfg_.bus_info);
    } catch (const std::runtime_error& e) {
      throw DeviceUnavailableError(cfg_.card.empty() ? "bus_info" : "card", who + ": " + e.what());
    }
  }
  {
    std::lock_guard<std::mutex> lock(text_mutex_);
    path_ = path;
  }
  const std::string dev = who + " (" + path + ")";
  fd_ = ::open(path.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) {
    const int e = errno;
    std::string msg = dev + ": cannot open: " + errno_text(e);
    if (e == ENOENT || e == ENODEV)
      msg += " (capture devices: " + describe_capture_devices(list_v4l2_devices(false)) + ")";
    if (e == EACCES) msg += " (add the user to the 'video' group)";
    if (unavailable_errno(e)) throw DeviceUnavailableError("device", msg);
    throw DeviceConfigError("device", msg);
  }
  v4l2_capability cap{};
  if (xioctl(fd_, VIDIOC_QUERYCAP, &cap) < 0) {
    throw DeviceConfigError("device", dev + ": not a V4L2 device (VIDIOC_QUERYCAP: " + errno_text(errno) + ")");
  }
  const std::uint32_t caps = (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
  if (!(caps & V4L2_CAP_VIDEO_CAPTURE) || !(caps & V4L2_CAP_STREAMING)) {
    throw DeviceConfigError("device", dev + ": card '" + cstr(cap.card, sizeof cap.card) +
                                          "' is not a single-planar video capture node with streaming I/O");
  }
  return dev;
}

DeviceFormat V4l2Camera::choose_format(const std::string& dev) const {
  std::vector<std::uint32_t> offered;
  for (std::uint32_t i = 0;; ++i) {
    v4l2_fmtdesc d{};
    d.index = i;
    d.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (xioctl(fd_, VIDIOC_ENUM_FMT, &d) < 0) break;
    offered.push_back(d.pixelformat);
  }
  auto offered_text = [&offered] {
    std::string s;
    for (auto f : offered) s += (s.empty() ? "" : ", ") + fourcc_to_string(f);
    return s.empty() ? std::string("none") : s;
  };
  auto is_offered = [&offered](DeviceFormat f) {
    return std::find(offered.begin(), offered.end(), fourcc_of(f)) != offered.end();
  };
  if (cfg_.fourcc == "auto") {
    for (DeviceFormat f : preferred_formats(cfg_.output))
      if (is_offered(f)) return f;
    throw DeviceConfigError("fourcc", dev + ": offers no format regolith converts (offers: " + offered_text() + ")");
  }
  DeviceFormat chosen{};
  device_format_from_fourcc(fourcc_from_string(cfg_.fourcc), chosen);
  if (!is_offered(chosen)) {
    throw DeviceConfigError("fourcc", dev + ": does not offer '" + cfg_.fourcc + "' (offers: " + offered_text() + ")");
  }
  return chosen;
}

void V4l2Camera::set_format(const std::string& dev, DeviceFormat chosen) {
  v4l2_format fmt{};
  fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  fmt.fmt.pix.width = static_cast<__u32>(cfg_.width);
  fmt.fmt.pix.height = static_cast<__u32>(cfg_.height);
  fmt.fmt.pix.pixelformat = fourcc_of(chosen);
  fmt.fmt.pix.field = V4L2_FIELD_NONE;
  if (xioctl(fd_, VIDIOC_S_FMT, &fmt) < 0) {
    const int e = errno;
    if (e == EBUSY) throw DeviceUnavailableError("device", dev + ": busy (another process is streaming from it)");
    throw DeviceConfigError("fourcc", dev + ": VIDIOC_S_FMT " + std::string(to_string(chosen)) + ": " + errno_text(e));
  }
  if (static_cast<int>(fmt.fmt.pix.width) != cfg_.width || static_cast<int>(fmt.fmt.pix.height) != cfg_.height) {
    std::string sizes;
    for (std::uint32_t j = 0; j < 64; ++j) {
      v4l2_frmsizeenum fs{};
      fs.index = j;
      fs.pixel_format = fourcc_of(chosen);
      if (xioctl(fd_, VIDIOC_ENUM_FRAMESIZES, &fs) < 0) break;
      if (fs.type != V4L2_FRMSIZE_TYPE_DISCRETE) {
        sizes = "up to " + std::to_string(fs.stepwise.max_width) + "x" + std::to_string(fs.stepwise.max_height);
        break;
      }
      sizes +=
          (sizes.empty() ? "" : ", ") + std::to_string(fs.discrete.width) + "x" + std::to_string(fs.discrete.height);
    }
    throw DeviceConfigError("width", dev + ": cannot capture " + std::to_string(cfg_.width) + "x" +
                                         std::to_string(cfg_.height) + " in " + std::string(to_string(chosen)) +
                                         " (the driver proposed " + std::to_string(fmt.fmt.pix.width) + "x" +
                                         std::to_string(fmt.fmt.pix.height) + "; sizes: " + sizes + ")");
  }
  if (fmt.fmt.pix.pixelformat != fourcc_of(chosen)) {
    throw DeviceConfigError("fourcc", dev + ": driver replaced " + std::string(to_string(chosen)) + " by " +
                                          fourcc_to_string(fmt.fmt.pix.pixelformat));
  }
  dev_format_ = chosen;
  stride_ = fmt.fmt.pix.bytesperline;
}

double V4l2Camera::set_frame_rate() {
  double rate = cfg_.rate_hz;
  v4l2_streamparm parm{};
  parm.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (xioctl(fd_, VIDIOC_G_PARM, &parm) == 0 && (parm.parm.capture.capability & V4L2_CAP_TIMEPERFRAME)) {
    parm.parm.capture.timeperframe.numerator = 1000;
    parm.parm.capture.timeperframe.denominator = static_cast<__u32>(std::lround(cfg_.rate_hz * 1000.0));
    if (xioctl(fd_, VIDIOC_S_PARM, &parm) == 0 && parm.parm.capture.timeperframe.numerator > 0) {
      rate = static_cast<double>(parm.parm.capture.timeperframe.denominator) / parm.parm.capture.timeperframe.numerator;
    }
  }
  return rate;
}

void V4l2Camera::map_buffers(const std::string& dev) {
  v4l2_requestbuffers req{};
  req.count = static_cast<__u32>(cfg_.buffers);
  req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  req.memory = V4L2_MEMORY_MMAP;
  if (xioctl(fd_, VIDIOC_REQBUFS, &req) < 0) {
    const int e = errno;
    if (e == EBUSY) throw DeviceUnavailableError("device", dev + ": busy (another process owns its buffers)");
    throw DeviceConfigError("buffers", dev + ": VIDIOC_REQBUFS: " + errno_text(e));
  }
  if (req.count < 2)
    throw DeviceConfigError("buffers", dev + ": driver granted only " + std::to_string(req.count) + " buffer(s)");
  buffers_.assign(req.count, Buffer{});
  for (std::uint32_t i = 0; i < req.count; ++i) {
    v4l2_buffer b{};
    b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    b.memory = V4L2_MEMORY_MMAP;
    b.index = i;
    if (xioctl(fd_, VIDIOC_QUERYBUF, &b) < 0) throw std::runtime_error(dev + ": VIDIOC_QUERYBUF: " + errno_text(errno));
    void* m = ::mmap(nullptr, b.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, b.m.offset);
    if (m == MAP_FAILED) throw std::runtime_error(dev + ": mmap: " + errno_text(errno));
    buffers_[i] = Buffer{m, b.length};
  }
}

void V4l2Camera::apply_controls() {
  if (cfg_.controls.empty()) return;
  const std::string dev = "v4l2 camera '" + id_ + "' (" + path_ + ")";
  struct Info {
    v4l2_query_ext_ctrl q;
  };
  std::map<std::string, Info> by_name;
  v4l2_query_ext_ctrl q{};
  q.id = V4L2_CTRL_FLAG_NEXT_CTRL | V4L2_CTRL_FLAG_NEXT_COMPOUND;
  while (xioctl(fd_, VIDIOC_QUERY_EXT_CTRL, &q) == 0) {
    if (q.type != V4L2_CTRL_TYPE_CTRL_CLASS && !(q.flags & V4L2_CTRL_FLAG_DISABLED)) {
      by_name[normalise_control_name(cstr(reinterpret_cast<const __u8*>(q.name), sizeof q.name))] = Info{q};
    }
    q.id |= V4L2_CTRL_FLAG_NEXT_CTRL | V4L2_CTRL_FLAG_NEXT_COMPOUND;
  }
  std::vector<std::string> names;
  for (const auto& kv : by_name) names.push_back(kv.first);
  for (const auto& setting : cfg_.controls) {
    const std::string key = normalise_control_name(setting.name);
    auto it = by_name.find(key);
    if (it == by_name.end()) {
      std::string msg = dev + ": has no control '" + setting.name + "'";
      const std::string guess = did_you_mean(key, names);
      if (!guess.empty()) msg += " (did you mean '" + guess + "'?)";
      std::string all;
      for (const auto& n : names) all += (all.empty() ? "" : ", ") + n;
      throw DeviceConfigError("controls", msg + "; controls: " + all);
    }
    const v4l2_query_ext_ctrl& c = it->second.q;
    std::int64_t value = 0;
    const std::string& text = setting.value;
    if (c.type == V4L2_CTRL_TYPE_BOOLEAN && (text == "true" || text == "false")) {
      value = text == "true" ? 1 : 0;
    } else if (!parse_integer(text, value)) {
      bool matched = false;
      if (c.type == V4L2_CTRL_TYPE_MENU) {
        for (std::int64_t i = c.minimum; i <= c.maximum && !matched; ++i) {
          v4l2_querymenu m{};
          m.id = c.id;
          m.index = static_cast<__u32>(i);
          if (xioctl(fd_, VIDIOC_QUERYMENU, &m) == 0 &&
              normalise_control_name(cstr(m.name, sizeof m.name)) == normalise_control_name(text)) {
            value = i;
            matched = true;
          }
        }
      }
      if (!matched) {
        throw DeviceConfigError("controls", dev + ": control '" + setting.name + "': '" + text + "' is not an integer" +
                                                (c.type == V4L2_CTRL_TYPE_MENU ? " or a menu entry" : ""));
      }
    }
    if (c.type != V4L2_CTRL_TYPE_BUTTON && (value < c.minimum || value > c.maximum)) {
      throw DeviceConfigError("controls", dev + ": control '" + setting.name + "' = " + std::to_string(value) +
                                              " is outside [" + std::to_string(c.minimum) + ", " +
                                              std::to_string(c.maximum) + "]");
    }
    if (c.flags & V4L2_CTRL_FLAG_READ_ONLY) {
      throw DeviceConfigError("controls", dev + ": control '" + setting.name + "' is read-only");
    }
    v4l2_ext_control ec{};
    ec.id = c.id;
    if (c.type == V4L2_CTRL_TYPE_INTEGER64) {
      ec.value64 = value;
    } else {
      ec.value = static_cast<__s32>(value);
    }
    v4l2_ext_controls ecs{};
    ecs.which = V4L2_CTRL_ID2WHICH(c.id);
    ecs.count = 1;
    ecs.controls = &ec;
    if (xioctl(fd_, VIDIOC_S_EXT_CTRLS, &ecs) < 0) {
      throw DeviceConfigError("controls", dev + ": setting control '" + setting.name + "' = " + std::to_string(value) +
                                              " failed: " + errno_text(errno));
    }
  }
}

void V4l2Camera::stream_on() {
  for (std::uint32_t i = 0; i < buffers_.size(); ++i) {
    v4l2_buffer b{};
    b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    b.memory = V4L2_MEMORY_MMAP;
    b.index = i;
    if (xioctl(fd_, VIDIOC_QBUF, &b) < 0) throw std::runtime_error(path_ + ": VIDIOC_QBUF: " + errno_text(errno));
  }
  int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (xioctl(fd_, VIDIOC_STREAMON, &type) < 0) {
    const int e = errno;
    throw std::runtime_error("v4l2 camera '" + id_ + "' (" + path_ + "): VIDIOC_STREAMON: " + errno_text(e) +
                             (e == EBUSY ? " (device busy)" : ""));
  }
  have_seq_ = false;
}

void V4l2Camera::close_device() {
  if (fd_ >= 0) {
    int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    (void)xioctl(fd_, VIDIOC_STREAMOFF, &type);
  }
  for (auto& b : buffers_) {
    if (b.start != nullptr) ::munmap(b.start, b.length);
  }
  buffers_.clear();
  if (fd_ >= 0) {
    // release the buffers so the next open can allocate them again
    v4l2_requestbuffers req{};
    req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    req.memory = V4L2_MEMORY_MMAP;
    (void)xioctl(fd_, VIDIOC_REQBUFS, &req);
    ::close(fd_);
  }
  fd_ = -1;
}

void V4l2Camera::start() {
  if (running_.load()) return;
  if (fd_ < 0) {
    try {
      open_and_configure(false);
    } catch (const std::exception& e) {
      close_device();
      throw std::runtime_error(e.what());
    }
  }
  try {
    stream_on();
  } catch (...) {
    close_device();
    throw;
  }
  std::uint64_t drain = 0;
  (void)!::read(wake_fd_, &drain, sizeof drain);
  state_.store(DeviceState::kStreaming);
  running_.store(true);
  thread_ = std::thread([this] { run(); });
}

void V4l2Camera::stop() {
  if (!running_.exchange(false)) return;
  const std::uint64_t one = 1;
  (void)!::write(wake_fd_, &one, sizeof one);
  if (thread_.joinable()) thread_.join();
  close_device();
  state_.store(DeviceState::kStopped);
}

bool V4l2Camera::wait_stop(TimeNs d) {
  pollfd p{wake_fd_, POLLIN, 0};
  return ::poll(&p, 1, static_cast<int>(std::max<TimeNs>(1, d / kNsPerMs))) > 0;
}

void V4l2Camera::fault(const std::string& what) {
  faults_.fetch_add(1);
  state_.store(DeviceState::kFaulted);
  set_error(what);
}

bool V4l2Camera::latest(TimeNs /*now*/, FrameLease& out) {
  if (state_.load(std::memory_order_acquire) != DeviceState::kStreaming) {
    out.reset();
    return false;
  }
  out = pool_->acquire();
  return static_cast<bool>(out);
}

CameraStats V4l2Camera::stats() const {
  CameraStats s;
  s.frames = frames_.load();
  s.dropped = dropped_.load();
  s.corrupt = corrupt_.load();
  s.faults = faults_.load();
  s.recoveries = recoveries_.load();
  s.state = state_.load();
  s.last_frame_time = last_frame_time_.load();
  return s;
}

bool V4l2Camera::capture_one(TimeNs& last_frame) {
  for (;;) {
    v4l2_buffer b{};
    b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    b.memory = V4L2_MEMORY_MMAP;
    if (xioctl(fd_, VIDIOC_DQBUF, &b) < 0) {
      if (errno == EAGAIN) return true;
      fault("v4l2 camera '" + id_ + "' (" + path_ + "): VIDIOC_DQBUF: " + errno_text(errno));
      return false;
    }
    const TimeNs now = clock_->now();
    dropped_.fetch_add(sequence_gap(have_seq_, last_seq_, b.sequence), std::memory_order_relaxed);
    have_seq_ = true;
    last_seq_ = b.sequence;
    TimeNs stamp = now;
    const bool monotonic = (b.flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) == V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC;
    if (monotonic && !clock_->simulated()) {
      const TimeNs kernel =
          static_cast<TimeNs>(b.timestamp.tv_sec) * kNsPerSec + static_cast<TimeNs>(b.timestamp.tv_usec) * kNsPerUs;
      const TimeNs mapped = kernel + (now - monotonic_now());
      // vivid stamps the end of the frame period, which can lie slightly ahead of the dequeue:
      // clamp to the dequeue time; stamps that are far off fall back to the dequeue time
      if (mapped - now < kNsPerSec && now - mapped < 10 * kNsPerSec) {
        stamp = std::min(mapped, now);
      } else {
        non_mono_.fetch_add(1, std::memory_order_relaxed);
      }
    } else {
      non_mono_.fetch_add(1, std::memory_order_relaxed);
    }
    if (b.index < buffers_.size()) {
      const Buffer& buf = buffers_[b.index];
      const std::size_t used = b.bytesused > 0 ? b.bytesused : buf.length;
      Frame* slot = pool_->begin_write();
      if (slot == nullptr) {
        dropped_.fetch_add(1, std::memory_order_relaxed);  // every slot leased: reader too slow
      } else {
        std::string err;
        if (convert_frame(dev_format_, static_cast<const std::uint8_t*>(buf.start), std::min(used, buf.length),
                          format_.width, format_.height, stride_, format_.format, slot->image, err)) {
          slot->capture_time = stamp;
          slot->sequence = b.sequence;
          slot->camera_index = index_;
          slot->corrupt = (b.flags & V4L2_BUF_FLAG_ERROR) != 0;
          pool_->commit();
          frames_.fetch_add(1, std::memory_order_relaxed);
          if (slot->corrupt) corrupt_.fetch_add(1, std::memory_order_relaxed);
          last_frame_time_.store(stamp, std::memory_order_relaxed);
          last_frame = now;
        } else {
          corrupt_.fetch_add(1, std::memory_order_relaxed);
          set_error("frame " + std::to_string(b.sequence) + ": " + err);
        }
      }
    }
    if (xioctl(fd_, VIDIOC_QBUF, &b) < 0) {
      fault("v4l2 camera '" + id_ + "' (" + path_ + "): VIDIOC_QBUF: " + errno_text(errno));
      return false;
    }
  }
}

void V4l2Camera::run() {
  Backoff backoff(static_cast<TimeNs>(cfg_.retry_min_s * 1e9), static_cast<TimeNs>(cfg_.retry_max_s * 1e9));
  const auto frame_timeout = static_cast<TimeNs>(cfg_.frame_timeout_s * 1e9);
  TimeNs last_frame = clock_->now();
  while (running_.load()) {
    if (fd_ < 0) {
      state_.store(DeviceState::kRecovering);
      try {
        open_and_configure(false);
        stream_on();
        backoff.reset();
        last_frame = clock_->now();
        recoveries_.fetch_add(1);
        state_.store(DeviceState::kStreaming);
        set_error("recovered on " + device_path());
      } catch (const std::exception& e) {
        close_device();
        set_error(std::string("reconnecting: ") + e.what());
        if (wait_stop(backoff.next())) break;
        continue;
      }
    }
    pollfd pfd[2] = {{fd_, POLLIN | POLLPRI, 0}, {wake_fd_, POLLIN, 0}};
    const int r = ::poll(pfd, 2, static_cast<int>(std::clamp<TimeNs>(frame_timeout / kNsPerMs, 10, 250)));
    if (r < 0 && errno != EINTR) {
      fault("v4l2 camera '" + id_ + "': poll: " + errno_text(errno));
      close_device();
      continue;
    }
    if (pfd[1].revents & POLLIN) break;
    bool ok = true;
    if (r > 0 && (pfd[0].revents & (POLLIN | POLLERR | POLLHUP | POLLNVAL))) {
      ok = capture_one(last_frame);
      if (ok && (pfd[0].revents & (POLLHUP | POLLNVAL))) {
        fault("v4l2 camera '" + id_ + "' (" + path_ + "): device hung up");
        ok = false;
      }
    }
    if (ok && clock_->now() - last_frame > frame_timeout) {
      fault("v4l2 camera '" + id_ + "' (" + path_ + "): no frame for " + std::to_string(cfg_.frame_timeout_s) + " s");
      ok = false;
    }
    if (!ok) close_device();
  }
}

// ------------------------------------------------------------------------------------------------
void register_v4l2_backend(BackendRegistry& r) {
  r.add_lister("v4l2", [](std::ostream& os) {
    const auto v4l2 = hal::v4l2::list_v4l2_devices(true);
    os << "V4L2 cameras (backend: v4l2):" << (v4l2.empty() ? " none\n" : "\n");
    for (const auto& d : v4l2) {
      if (!d.capture) continue;
      os << "  " << d.path << "  card: \"" << d.card << "\"  bus_info: \"" << d.bus_info << "\"  driver: " << d.driver
         << "\n";
      for (const auto& f : d.formats) {
        os << "    " << f.fourcc << (f.convertible ? "" : " (not convertible)") << "  " << f.description << ":";
        for (const auto& s : f.sizes) {
          os << " " << s.width << "x" << s.height;
          if (!s.rates_hz.empty()) {
            os << "@";
            for (std::size_t i = 0; i < s.rates_hz.size(); ++i) os << (i ? "/" : "") << s.rates_hz[i];
          }
        }
        if (!f.size_range.empty()) os << " " << f.size_range;
        os << "\n";
      }
    }
  });
  r.add_camera("v4l2", "Video4Linux2 capture node (USB/CSI/virtual): mmap streaming, kernel timestamps, auto-reconnect",
               [](Params& p, const DeviceContext& ctx) -> std::unique_ptr<Camera> {
                 Config c = config_from_params(p);
                 if (!ctx.open_devices) {
                   return make_unopened_camera(ctx.id, CameraFormat{c.width, c.height, c.output, c.rate_hz});
                 }
                 try {
                   return std::make_unique<V4l2Camera>(std::move(c), ctx);
                 } catch (const DeviceError& e) {
                   rethrow_located(p, e);  // ConfigError, or DeviceUnavailableError (may appear later)
                 }
               });
}

}  // namespace regolith::hal::v4l2
