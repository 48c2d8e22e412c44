#include "regolith/hal_socketcan/socketcan.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <ostream>
#include <stdexcept>

#include <fcntl.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <linux/errqueue.h>
#include <linux/net_tstamp.h>
#include <net/if.h>
#include <net/if_arp.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include "regolith/hal/unopened.hpp"

namespace regolith::hal::socketcan {

namespace {

std::string errno_text(int e) {
  return std::string(std::strerror(e));
}

std::string read_sysfs(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::string s;
  std::getline(in, s);
  return s;
}

std::string can_interface_names() {
  std::string out;
  for (const auto& i : list_can_interfaces()) out += (out.empty() ? "" : ", ") + i.name + (i.up ? "" : " (down)");
  return out.empty() ? "none" : out;
}

/// Wait on the wake eventfd for at most `d`; true when woken (stop requested).
bool wait_wake(int wake_fd, TimeNs d) {
  pollfd p{wake_fd, POLLIN, 0};
  const int ms = static_cast<int>(std::max<TimeNs>(1, d / kNsPerMs));
  return ::poll(&p, 1, ms) > 0;
}

}  // namespace

// ------------------------------------------------------------------------------------------------
void Config::validate() const {
  if (interface.empty() || interface.size() >= IFNAMSIZ) {
    throw FieldError("", "interface",
                     "must be a network interface name of 1.." + std::to_string(IFNAMSIZ - 1) + " characters (got '" +
                         interface + "')");
  }
  if (wheels.empty() && transducers.empty()) throw FieldError("", "wheels", "at least one wheel or transducer");
  std::vector<std::string> seen;
  for (const auto* list : {&wheels, &transducers}) {
    for (const auto& s : *list) {
      if (std::find(seen.begin(), seen.end(), s.name) != seen.end()) {
        throw FieldError("", "wheels", "name '" + s.name + "' is used twice (wheels and transducers share names)");
      }
      seen.push_back(s.name);
      if (s.byte_offset + s.length > 8) {
        throw FieldError("", s.name + ".length", "byte_offset + length must fit a classic CAN payload (8)");
      }
    }
  }
  auto positive = [](double v, const char* field) {
    if (!(v > 0.0) || !std::isfinite(v)) throw FieldError("", field, "must be > 0 and finite");
  };
  positive(stale_timeout_s, "stale_timeout");
  if (!(max_extrapolation_s >= 0.0) || !std::isfinite(max_extrapolation_s)) {
    throw FieldError("", "max_extrapolation", "must be >= 0 and finite");
  }
  validate_backoff(retry_min_s, retry_max_s);
  if (receive_buffer_kb < 16 || receive_buffer_kb > 1 << 16)
    throw FieldError("", "receive_buffer_kb", "must be 16..65536");
  if (frame_history < 1 || frame_history > 1 << 20) throw FieldError("", "frame_history", "must be 1..1048576");
  if (tx_enabled && tx_id > (tx_extended ? CAN_EFF_MASK : CAN_SFF_MASK)) {
    throw FieldError("", "command.id",
                     "out of range for a " + std::string(tx_extended ? "29" : "11") + "-bit identifier");
  }
}

Config config_from_params(Params& p) {
  Config c;
  c.interface = p.require<std::string>("interface", {.doc = "CAN network interface (e.g. can0, vcan0)"});
  auto read_signals = [&p](const char* key, std::vector<CanSignal>& out) {
    Params list = p.child(key);
    for (const auto& name : list.keys()) {
      Params s = list.child(name);
      out.push_back(can_signal_from_params(s, name));
      s.finish();
    }
  };
  read_signals("wheels", c.wheels);
  read_signals("transducers", c.transducers);
  c.stale_timeout_s =
      p.get<double>("stale_timeout", c.stale_timeout_s,
                    {.unit = "s", .min = 0.0, .min_exclusive = true, .doc = "no sample for this long -> wheel stale"});
  c.max_extrapolation_s = p.get<double>(
      "max_extrapolation", c.max_extrapolation_s,
      {.unit = "s", .min = 0.0, .max = 1.0, .doc = "angle_at may extrapolate this far past the newest sample"});
  c.retry_min_s = p.get<double>(
      "retry_min", c.retry_min_s,
      {.unit = "s", .min = 0.001, .max = 60.0, .doc = "first re-open delay after the interface vanished"});
  c.receive_buffer_kb =
      p.get<int>("receive_buffer_kb", c.receive_buffer_kb,
                 {.unit = "KiB",
                  .min = 16,
                  .max = 1 << 16,
                  .doc = "socket receive queue for bursts (beyond net.core.rmem_max needs CAP_NET_ADMIN)"});
  c.frame_history = p.get<int>("frame_history", c.frame_history,
                               {.unit = "frames", .min = 1, .max = 1 << 20, .doc = "raw frames kept for recorders"});
  c.retry_max_s = p.get<double>("retry_max", c.retry_max_s,
                                {.unit = "s", .min = 0.001, .max = 600.0, .doc = "re-open back-off ceiling"});
  c.error_frames = p.get<bool>("error_frames", c.error_frames, {.doc = "receive and decode CAN error frames"});
  c.kernel_timestamps =
      p.get<bool>("kernel_timestamps", c.kernel_timestamps, {.doc = "use kernel receive timestamps (SO_TIMESTAMPING)"});
  if (p.has("command")) {
    Params cmd = p.child("command");
    c.tx_enabled = cmd.get<bool>("enabled", false, {.doc = "allow sending command frames"});
    c.tx_extended = cmd.get<bool>("extended", false, {.doc = "29-bit command identifier"});
    c.tx_id = static_cast<std::uint32_t>(cmd.get<std::int64_t>(
        "id", 0, {.min = 0, .max = c.tx_extended ? 0x1FFFFFFF : 0x7FF, .doc = "command frame identifier"}));
    cmd.finish();
  }
  p.finish_and_check([&] { c.validate(); });
  return c;
}

// ------------------------------------------------------------------------------------------------
CanErrorInfo decode_error_frame(const CanFrame& f) {
  CanErrorInfo e;
  const std::uint32_t cls = f.id & CAN_ERR_MASK;
  const auto byte = [&f](std::size_t i) -> std::uint8_t { return i < f.len ? f.data[i] : 0; };
  e.tx_timeout = (cls & CAN_ERR_TX_TIMEOUT) != 0;
  e.lost_arbitration = (cls & CAN_ERR_LOSTARB) != 0;
  if (e.lost_arbitration && byte(0) != CAN_ERR_LOSTARB_UNSPEC) e.arbitration_bit = byte(0);
  if (cls & CAN_ERR_CRTL) {
    e.controller = true;
    const std::uint8_t c = byte(1);
    e.rx_overflow = (c & CAN_ERR_CRTL_RX_OVERFLOW) != 0;
    e.tx_overflow = (c & CAN_ERR_CRTL_TX_OVERFLOW) != 0;
    e.error_warning = (c & (CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING)) != 0;
    e.error_passive = (c & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE)) != 0;
    e.error_active = (c & CAN_ERR_CRTL_ACTIVE) != 0;
  }
  e.protocol = (cls & CAN_ERR_PROT) != 0;
  e.transceiver = (cls & CAN_ERR_TRX) != 0;
  e.no_ack = (cls & CAN_ERR_ACK) != 0;
  e.bus_off = (cls & CAN_ERR_BUSOFF) != 0;
  e.bus_error = (cls & CAN_ERR_BUSERROR) != 0;
  e.restarted = (cls & CAN_ERR_RESTARTED) != 0;
  if (cls & CAN_ERR_CNT) {
    e.tx_error_count = byte(6);
    e.rx_error_count = byte(7);
  }
  return e;
}

std::string CanErrorInfo::describe() const {
  std::string s;
  auto add = [&s](bool on, const char* what) {
    if (on) s += (s.empty() ? "" : ", ") + std::string(what);
  };
  add(bus_off, "bus-off");
  add(error_passive, "error-passive");
  add(error_warning, "error-warning");
  add(error_active, "back to error-active");
  add(lost_arbitration, "lost arbitration");
  add(rx_overflow, "rx overflow");
  add(tx_overflow, "tx overflow");
  add(controller && !rx_overflow && !tx_overflow && !error_warning && !error_passive && !error_active,
      "controller problem");
  add(protocol, "protocol violation");
  add(transceiver, "transceiver error");
  add(no_ack, "no ACK");
  add(bus_error, "bus error");
  add(tx_timeout, "tx timeout");
  add(restarted, "controller restarted");
  if (lost_arbitration && arbitration_bit >= 0) s += " (bit " + std::to_string(arbitration_bit) + ")";
  if (tx_error_count >= 0) {
    s += " (tx errors " + std::to_string(tx_error_count) + ", rx errors " + std::to_string(rx_error_count) + ")";
  }
  return s.empty() ? "unspecified error" : s;
}

// ------------------------------------------------------------------------------------------------
struct SocketCanEncoders::Counters {
  std::atomic<std::uint64_t> samples{0}, rejected{0}, faults{0}, stale_events{0}, recoveries{0};
  std::atomic<DeviceState> state{DeviceState::kStopped};
  std::atomic<std::uint64_t> frames{0}, unexpected{0}, short_frames{0}, error_frames{0}, bus_off{0}, error_passive{0},
      error_warning{0}, lost_arb{0}, controller{0}, protocol{0}, transceiver{0}, no_ack{0}, restarts{0},
      rx_overflows{0}, iface_down{0}, tx_frames{0}, tx_errors{0};
  std::atomic<bool> kernel_ts{false};
  std::atomic<int> rcvbuf{0};
  mutable std::mutex text_mutex;
  std::string last_error;
};

SocketCanEncoders::SocketCanEncoders(Config cfg, const DeviceContext& ctx)
    : cfg_(std::move(cfg)), id_(ctx.id), clock_(ctx.clock), decoder_({}), c_(std::make_unique<Counters>()) {
  cfg_.validate();
  if (clock_ == nullptr) {
    own_clock_ = std::make_unique<SystemClock>();
    clock_ = own_clock_.get();
  }
  std::vector<CanSignal> all = cfg_.wheels;
  all.insert(all.end(), cfg_.transducers.begin(), cfg_.transducers.end());
  for (const auto& s : all) names_.push_back(s.name);
  decoder_ = CanDecoder(std::move(all));
  for (std::size_t i = 0; i < names_.size(); ++i) history_.push_back(std::make_unique<AngleHistory>());
  frames_ = std::make_unique<CanFrameHistory>(static_cast<std::size_t>(cfg_.frame_history));
  stale_ = std::make_unique<std::atomic<bool>[]>(names_.size());
  last_stamp_ = std::make_unique<std::atomic<TimeNs>[]>(names_.size());
  wake_fd_ = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (wake_fd_ < 0) throw std::runtime_error("socketcan '" + id_ + "': eventfd: " + errno_text(errno));
  const std::string who = "socketcan '" + id_ + "': ";
  try {
    open_socket();
  } catch (const DeviceUnavailableError& e) {
    ::close(wake_fd_);
    throw DeviceUnavailableError("interface", who + e.what());
  } catch (const std::exception& e) {
    ::close(wake_fd_);
    throw DeviceConfigError("interface", who + e.what());
  }
  if (!interface_up()) {
    close_socket();
    ::close(wake_fd_);
    throw DeviceUnavailableError("interface", who + "interface '" + cfg_.interface +
                                                  "' is down (bring it up: ip link set " + cfg_.interface + " up)");
  }
}

SocketCanEncoders::~SocketCanEncoders() {
  stop();
  close_socket();
  if (wake_fd_ >= 0) ::close(wake_fd_);
}

void SocketCanEncoders::open_socket() {
  // The interface first (a generic socket, not AF_CAN): a missing interface is reported as such,
  // and as unavailable (it may appear later), even on a kernel without SocketCAN.
  const unsigned ifindex = ::if_nametoindex(cfg_.interface.c_str());
  if (ifindex == 0) {
    const int e = errno;
    if (e == ENODEV || e == ENXIO) {
      throw DeviceUnavailableError("interface", "interface '" + cfg_.interface +
                                                    "' does not exist (CAN interfaces: " + can_interface_names() + ")");
    }
    throw std::runtime_error("interface '" + cfg_.interface + "': " + errno_text(e));
  }
  const std::string type = read_sysfs("/sys/class/net/" + cfg_.interface + "/type");
  if (!type.empty() && type != std::to_string(ARPHRD_CAN)) {
    throw std::runtime_error("interface '" + cfg_.interface + "' is not a CAN interface (link type " + type +
                             "; CAN interfaces: " + can_interface_names() + ")");
  }
  const int fd = ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) {
    const int e = errno;
    if (e == EAFNOSUPPORT || e == EPROTONOSUPPORT) {
      throw std::runtime_error("this kernel has no SocketCAN (socket(PF_CAN, SOCK_RAW, CAN_RAW): " + errno_text(e) +
                               "); load can-raw or run the driver tests in tests/hw/run.sh");
    }
    throw std::runtime_error("socket(PF_CAN): " + errno_text(e));
  }
  auto fail = [fd](const std::string& msg) {
    ::close(fd);
    throw std::runtime_error(msg);
  };
  // Kernel receive filters: exactly the decoder's ids, data frames only.
  std::vector<can_filter> filters;
  for (const auto& [id, ext] : decoder_.ids()) {
    can_filter f{};
    f.can_id = ext ? (id | CAN_EFF_FLAG) : id;
    f.can_mask = (ext ? CAN_EFF_MASK : CAN_SFF_MASK) | CAN_EFF_FLAG | CAN_RTR_FLAG;
    filters.push_back(f);
  }
  if (::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, filters.data(),
                   static_cast<socklen_t>(filters.size() * sizeof(can_filter))) < 0) {
    fail("setsockopt(CAN_RAW_FILTER): " + errno_text(errno));
  }
  const can_err_mask_t err_mask = cfg_.error_frames ? CAN_ERR_MASK : 0;
  if (::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof err_mask) < 0) {
    fail("setsockopt(CAN_RAW_ERR_FILTER): " + errno_text(errno));
  }
  const int on = 1;
  (void)::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FD_FRAMES, &on, sizeof on);  // accept FD frames if any
  (void)::setsockopt(fd, SOL_SOCKET, SO_RXQ_OVFL, &on, sizeof on);         // socket-queue drop counter
  // A receive queue for bursts at full bus load: SO_RCVBUFFORCE past net.core.rmem_max when
  // permitted (CAP_NET_ADMIN), else SO_RCVBUF (capped by rmem_max); the size the kernel granted is
  // in BusStats::receive_buffer_bytes.
  const int want = cfg_.receive_buffer_kb * 1024;
  if (::setsockopt(fd, SOL_SOCKET, SO_RCVBUFFORCE, &want, sizeof want) < 0)
    (void)::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &want, sizeof want);
  int granted = 0;
  socklen_t granted_len = sizeof granted;
  if (::getsockopt(fd, SOL_SOCKET, SO_RCVBUF, &granted, &granted_len) == 0) c_->rcvbuf.store(granted);
  bool kts = false;
  if (cfg_.kernel_timestamps) {
    const int flags = SOF_TIMESTAMPING_RX_SOFTWARE | SOF_TIMESTAMPING_SOFTWARE;
    kts = ::setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPING, &flags, sizeof flags) == 0;
  }
  c_->kernel_ts.store(kts);
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = static_cast<int>(ifindex);
  if (::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) < 0) {
    const int e = errno;
    if (e == ENODEV || e == ENXIO) {  // removed since the look-up above
      ::close(fd);
      throw DeviceUnavailableError("interface", "bind to '" + cfg_.interface + "': " + errno_text(e));
    }
    fail("bind to '" + cfg_.interface + "': " + errno_text(e));
  }
  fd_ = fd;
  socket_drops_ = 0;  // a new socket counts its drops from 0
}

void SocketCanEncoders::close_socket() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

bool SocketCanEncoders::interface_up() const {
  const std::string flags = read_sysfs("/sys/class/net/" + cfg_.interface + "/flags");
  if (flags.empty()) return false;
  return (std::stoul(flags, nullptr, 16) & IFF_UP) != 0;
}

void SocketCanEncoders::note_error(const std::string& what) {
  std::lock_guard<std::mutex> lock(c_->text_mutex);
  c_->last_error = what;
}

void SocketCanEncoders::start() {
  if (running_.exchange(true)) return;
  const TimeNs now = clock_->now();
  for (std::size_t i = 0; i < names_.size(); ++i) {
    last_stamp_[i].store(now);
    stale_[i].store(false);
  }
  std::uint64_t drain = 0;
  (void)!::read(wake_fd_, &drain, sizeof drain);
  c_->state.store(fd_ >= 0 ? DeviceState::kStreaming : DeviceState::kRecovering);
  thread_ = std::thread([this] { run(); });
}

void SocketCanEncoders::stop() {
  if (!running_.exchange(false)) return;
  const std::uint64_t one = 1;
  (void)!::write(wake_fd_, &one, sizeof one);
  if (thread_.joinable()) thread_.join();
  c_->state.store(DeviceState::kStopped);
}

void SocketCanEncoders::check_stale(TimeNs now) {
  const auto timeout = static_cast<TimeNs>(cfg_.stale_timeout_s * 1e9);
  for (std::size_t i = 0; i < names_.size(); ++i) {
    if (!stale_[i].load(std::memory_order_relaxed) && now - last_stamp_[i].load(std::memory_order_relaxed) > timeout) {
      stale_[i].store(true);
      c_->stale_events.fetch_add(1);
    }
  }
}

void SocketCanEncoders::handle_frame(const CanFrame& f) {
  c_->frames.fetch_add(1, std::memory_order_relaxed);
  frames_->push(f);
  if (f.error) {
    const CanErrorInfo e = decode_error_frame(f);
    // State first, counters after: a reader that sees a counter move (bus_off, restarts) also sees
    // the state it caused (all seq_cst).
    if (e.bus_off) {
      c_->faults.fetch_add(1);
      c_->state.store(DeviceState::kFaulted);
    } else if ((e.restarted || e.error_active) && c_->state.load() == DeviceState::kFaulted) {
      c_->recoveries.fetch_add(1);
      c_->state.store(DeviceState::kStreaming);
    }
    note_error("error frame: " + e.describe());  // the text first: a reader that sees a count grow finds its reason
    c_->error_frames.fetch_add(1);
    if (e.bus_off) c_->bus_off.fetch_add(1);
    if (e.error_passive) c_->error_passive.fetch_add(1);
    if (e.error_warning) c_->error_warning.fetch_add(1);
    if (e.lost_arbitration) c_->lost_arb.fetch_add(1);
    if (e.controller) c_->controller.fetch_add(1);
    if (e.rx_overflow || e.tx_overflow) c_->rx_overflows.fetch_add(1);
    if (e.protocol) c_->protocol.fetch_add(1);
    if (e.transceiver) c_->transceiver.fetch_add(1);
    if (e.no_ack) c_->no_ack.fetch_add(1);
    if (e.restarted) c_->restarts.fetch_add(1);
    return;
  }
  const std::uint64_t short_before = decoder_.short_frames();
  const int n = decoder_.decode(f, [this, &f](std::size_t i, double v) {
    history_[i]->push(AngleSample{f.stamp, v});
    last_stamp_[i].store(f.stamp, std::memory_order_relaxed);
    stale_[i].store(false, std::memory_order_relaxed);
  });
  if (n > 0) {
    c_->samples.fetch_add(static_cast<std::uint64_t>(n), std::memory_order_relaxed);
    if (c_->state.load() == DeviceState::kFaulted) {  // data flows again (bus-off recovered silently)
      c_->recoveries.fetch_add(1);
      c_->state.store(DeviceState::kStreaming);
    }
  } else {
    c_->rejected.fetch_add(1);
    if (decoder_.short_frames() != short_before) {
      // The text before the count: whoever sees the count grow then finds its reason in last_error.
      note_error("frame 0x" +
                 [&f] {
                   char b[16];
                   std::snprintf(b, sizeof b, "%X", f.id);
                   return std::string(b);
                 }() +
                 " has DLC " + std::to_string(f.len) + ", too short for its signals");
      c_->short_frames.fetch_add(1);
    } else {
      c_->unexpected.fetch_add(1);
    }
  }
}

void SocketCanEncoders::run() {
  Backoff backoff(static_cast<TimeNs>(cfg_.retry_min_s * 1e9), static_cast<TimeNs>(cfg_.retry_max_s * 1e9));
  const TimeNs timeout = static_cast<TimeNs>(cfg_.stale_timeout_s * 1e9);
  const int poll_ms = static_cast<int>(std::clamp<TimeNs>(timeout / 4 / kNsPerMs, 5, 50));
  bool iface_down = false;
  // Frames are read in batches of kBatch per system call (recvmmsg): at full bus load the reader
  // then costs a fraction of a syscall per frame, and the stamp conversion is done once per batch.
  constexpr unsigned kBatch = 32;
  constexpr std::size_t kControl = CMSG_SPACE(sizeof(scm_timestamping)) + CMSG_SPACE(sizeof(std::uint32_t)) + 64;
  struct alignas(cmsghdr) Control {
    char bytes[kControl];
  };
  std::array<canfd_frame, kBatch> bufs{};
  std::array<Control, kBatch> controls{};
  std::array<iovec, kBatch> iovs{};
  std::array<mmsghdr, kBatch> msgs{};
  while (running_.load()) {
    if (fd_ < 0) {
      try {
        open_socket();
        backoff.reset();
        iface_down = !interface_up();
        if (!iface_down) {
          c_->recoveries.fetch_add(1);
          c_->state.store(DeviceState::kStreaming);
        }
      } catch (const std::exception& e) {
        note_error(e.what());
        if (wait_wake(wake_fd_, backoff.next())) break;
        continue;
      }
    }
    pollfd pfd[2] = {{fd_, POLLIN, 0}, {wake_fd_, POLLIN, 0}};
    const int pr = ::poll(pfd, 2, poll_ms);
    if (pr < 0 && errno != EINTR) {
      note_error(std::string("poll: ") + errno_text(errno));
      wait_wake(wake_fd_, 10 * kNsPerMs);
    }
    if (pfd[1].revents & POLLIN) break;
    const TimeNs now = clock_->now();
    check_stale(now);
    if (iface_down && interface_up()) {
      iface_down = false;
      c_->recoveries.fetch_add(1);
      c_->state.store(DeviceState::kStreaming);
      note_error("interface '" + cfg_.interface + "' is up again");
    }
    if (pr <= 0 || (pfd[0].revents & (POLLIN | POLLERR)) == 0) continue;
    for (int burst = 0; burst < 8; ++burst) {  // up to 8 x kBatch frames before polling again
      for (unsigned i = 0; i < kBatch; ++i) {
        iovs[i] = iovec{&bufs[i], sizeof(canfd_frame)};
        msgs[i] = mmsghdr{};
        msgs[i].msg_hdr.msg_iov = &iovs[i];
        msgs[i].msg_hdr.msg_iovlen = 1;
        msgs[i].msg_hdr.msg_control = controls[i].bytes;
        msgs[i].msg_hdr.msg_controllen = kControl;
      }
      const int got = ::recvmmsg(fd_, msgs.data(), kBatch, MSG_DONTWAIT, nullptr);
      if (got < 0) {
        const int e = errno;
        if (e == EAGAIN || e == EWOULDBLOCK || e == EINTR) break;
        note_error(e == ENETDOWN ? "interface '" + cfg_.interface + "' went down"
                                 : "receive on '" + cfg_.interface + "': " + errno_text(e));
        c_->faults.fetch_add(1);
        if (e == ENETDOWN) {
          c_->iface_down.fetch_add(1);
          c_->state.store(DeviceState::kFaulted);
          iface_down = true;
        } else {  // ENODEV (interface removed) or anything else: re-create the socket
          if (e == ENODEV) c_->iface_down.fetch_add(1);
          c_->state.store(DeviceState::kRecovering);
          close_socket();
          if (wait_wake(wake_fd_, backoff.next())) return;
        }
        break;
      }
      // realtime kernel stamps -> monotonic: shift by the current realtime/monotonic offset
      const TimeNs proc_now = clock_->now();
      const TimeNs rt_to_proc = proc_now - realtime_now();
      for (int i = 0; i < got; ++i) {
        const msghdr& msg = msgs[static_cast<std::size_t>(i)].msg_hdr;
        const auto n = static_cast<ssize_t>(msgs[static_cast<std::size_t>(i)].msg_len);
        const canfd_frame* cf = &bufs[static_cast<std::size_t>(i)];
        if (n != static_cast<ssize_t>(CAN_MTU) && n != static_cast<ssize_t>(CANFD_MTU)) continue;
        CanFrame f;
        f.fd = n == static_cast<ssize_t>(CANFD_MTU);
        f.extended = (cf->can_id & CAN_EFF_FLAG) != 0;
        f.remote = (cf->can_id & CAN_RTR_FLAG) != 0;
        f.error = (cf->can_id & CAN_ERR_FLAG) != 0;
        f.id = cf->can_id & (f.error ? CAN_ERR_MASK : (f.extended ? CAN_EFF_MASK : CAN_SFF_MASK));
        f.len = std::min<std::uint8_t>(cf->len, f.fd ? 64 : 8);
        std::memcpy(f.data.data(), cf->data, f.len);
        TimeNs kernel_rt = 0;
        for (const cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr;
             c = CMSG_NXTHDR(const_cast<msghdr*>(&msg), const_cast<cmsghdr*>(c))) {
          if (c->cmsg_level != SOL_SOCKET) continue;
          if (c->cmsg_type == SO_TIMESTAMPING) {
            scm_timestamping ts{};
            std::memcpy(&ts, CMSG_DATA(c), sizeof ts);
            kernel_rt = static_cast<TimeNs>(ts.ts[0].tv_sec) * kNsPerSec + ts.ts[0].tv_nsec;
          } else if (c->cmsg_type == SO_RXQ_OVFL) {
            std::uint32_t dropped = 0;
            std::memcpy(&dropped, CMSG_DATA(c), sizeof dropped);
            // the socket's running total: add what it dropped since the last frame
            if (dropped != socket_drops_)
              c_->rx_overflows.fetch_add(static_cast<std::uint32_t>(dropped - socket_drops_));
            socket_drops_ = dropped;
          }
        }
        f.stamp = kernel_rt > 0 && !clock_->simulated() ? std::min(kernel_rt + rt_to_proc, proc_now) : proc_now;
        handle_frame(f);
      }
      if (got < static_cast<int>(kBatch)) break;  // the queue is drained
    }
  }
}

bool SocketCanEncoders::latest(std::size_t wheel, TimeNs /*now*/, AngleSample& out) const {
  if (wheel >= history_.size()) return false;
  return history_[wheel]->latest(out);
}

bool SocketCanEncoders::angle_at(std::size_t wheel, TimeNs t, double& angle) const {
  if (wheel >= history_.size()) return false;
  return history_[wheel]->at(t, static_cast<TimeNs>(cfg_.max_extrapolation_s * 1e9), angle);
}

std::size_t SocketCanEncoders::samples_since(std::size_t wheel, TimeNs after, TimeNs /*now*/,
                                             std::span<AngleSample> out) const {
  if (wheel >= history_.size()) return 0;
  return history_[wheel]->since(after, out);
}

std::size_t SocketCanEncoders::can_frames(std::uint64_t& cursor, TimeNs /*now*/, std::span<CanFrame> out,
                                          std::uint64_t& missed) const {
  return frames_->since(cursor, out, missed);
}

bool SocketCanEncoders::stale_flag(std::size_t wheel) const {
  return wheel < names_.size() && stale_[wheel].load();
}

EncoderStats SocketCanEncoders::stats() const {
  EncoderStats s;
  s.samples = c_->samples.load();
  s.rejected = c_->rejected.load();
  s.faults = c_->faults.load();
  s.stale_events = c_->stale_events.load();
  s.lost = c_->rx_overflows.load();
  s.state = c_->state.load();
  return s;
}

BusStats SocketCanEncoders::bus_stats() const {
  BusStats b;
  b.frames = c_->frames.load();
  b.unexpected_ids = c_->unexpected.load();
  b.short_frames = c_->short_frames.load();
  b.error_frames = c_->error_frames.load();
  b.bus_off = c_->bus_off.load();
  b.error_passive = c_->error_passive.load();
  b.error_warning = c_->error_warning.load();
  b.lost_arbitration = c_->lost_arb.load();
  b.controller_problems = c_->controller.load();
  b.protocol_violations = c_->protocol.load();
  b.transceiver_errors = c_->transceiver.load();
  b.no_ack = c_->no_ack.load();
  b.restarts = c_->restarts.load();
  b.rx_overflows = c_->rx_overflows.load();
  b.interface_down = c_->iface_down.load();
  b.tx_frames = c_->tx_frames.load();
  b.tx_errors = c_->tx_errors.load();
  b.kernel_timestamps = c_->kernel_ts.load();
  b.receive_buffer_bytes = static_cast<std::uint64_t>(std::max(0, c_->rcvbuf.load()));
  std::lock_guard<std::mutex> lock(c_->text_mutex);
  b.last_error = c_->last_error;
  return b;
}

bool SocketCanEncoders::send(const std::uint8_t* data, std::size_t len) {
  if (!cfg_.tx_enabled) throw std::logic_error("socketcan '" + id_ + "': send() needs command.enabled: true");
  if (len > 8)
    throw std::invalid_argument("socketcan '" + id_ + "': command payload of " + std::to_string(len) +
                                " bytes (max 8)");
  can_frame f{};
  f.can_id = cfg_.tx_extended ? (cfg_.tx_id | CAN_EFF_FLAG) : cfg_.tx_id;
  f.len = static_cast<std::uint8_t>(len);
  if (len > 0) std::memcpy(f.data, data, len);
  const int fd = fd_;
  if (fd < 0 || ::write(fd, &f, sizeof f) != static_cast<ssize_t>(sizeof f)) {
    note_error("send on '" + cfg_.interface + "': " + (fd < 0 ? std::string("no socket") : errno_text(errno)));
    c_->tx_errors.fetch_add(1);
    return false;
  }
  c_->tx_frames.fetch_add(1);
  return true;
}

// ------------------------------------------------------------------------------------------------
std::vector<CanInterfaceInfo> list_can_interfaces() {
  std::vector<CanInterfaceInfo> out;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator("/sys/class/net", ec)) {
    const auto dir = entry.path();
    if (read_sysfs(dir / "type") != std::to_string(ARPHRD_CAN)) continue;
    CanInterfaceInfo i;
    i.name = dir.filename().string();
    const std::string flags = read_sysfs(dir / "flags");
    i.up = !flags.empty() && (std::stoul(flags, nullptr, 16) & IFF_UP) != 0;
    const std::string mtu = read_sysfs(dir / "mtu");
    i.mtu = mtu.empty() ? 0 : std::stoi(mtu);
    std::error_code ec2;
    const auto drv = std::filesystem::read_symlink(dir / "device" / "driver", ec2);
    i.virtual_can = ec2.operator bool();
    i.kind = ec2 ? "virtual (vcan/vxcan)" : drv.filename().string();
    out.push_back(std::move(i));
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.name < b.name; });
  return out;
}

void register_socketcan_backend(BackendRegistry& r) {
  r.add_lister("socketcan", [](std::ostream& os) {
    const auto cans = hal::socketcan::list_can_interfaces();
    os << "CAN interfaces (backend: socketcan):" << (cans.empty() ? " none\n" : "\n");
    for (const auto& c : cans) {
      os << "  " << c.name << "  " << (c.up ? "up" : "down") << "  kind: " << c.kind
         << (c.virtual_can ? " (virtual)" : "") << "  mtu: " << c.mtu << (c.mtu >= 72 ? " (CAN FD)" : "") << "\n";
    }
  });
  r.add_encoders("socketcan",
                 "wheel angles (and bench transducers) from a SocketCAN interface, kernel-filtered and timestamped",
                 [](Params& p, const DeviceContext& ctx) -> std::unique_ptr<WheelEncoders> {
                   Config c = config_from_params(p);
                   if (!ctx.open_devices) {
                     std::vector<std::string> names;
                     for (const auto& w : c.wheels) names.push_back(w.name);
                     for (const auto& t : c.transducers) names.push_back(t.name);
                     return make_unopened_encoders(ctx.id, std::move(names));
                   }
                   try {
                     return std::make_unique<SocketCanEncoders>(std::move(c), ctx);
                   } catch (const DeviceError& e) {
                     rethrow_located(p, e);  // ConfigError, or DeviceUnavailableError (may appear later)
                   }
                 });
}

}  // namespace regolith::hal::socketcan
