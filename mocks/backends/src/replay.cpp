// Cameras, encoders and IMUs "replay": what a device delivered in a HAL recording (`regolith run
// --record`, record/include/regolith/record/hal_recorder.hpp), served again on the process clock.
// Times are kept relative to the recording's time origin: a replay started at the same clock value
// (always under --sim-time) sees the very stamps the recorded run saw, and the recorded query
// answers (angle_at, attitude_at) are given back bit for bit.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <mutex>

#include <spdlog/spdlog.h>

#include "backends_internal.hpp"
#include "common.hpp"
#include "regolith/core/error.hpp"
#include "regolith/record/hal_messages.hpp"
#include "regolith/record/hal_recorder.hpp"
#include "regolith/record/mcap_reader.hpp"
#include "regolith/record/mcap_writer.hpp"

namespace regolith::mocks {
namespace detail {
namespace {

struct RecordedCamera {
  std::vector<cv::Mat> images;
  std::vector<TimeNs> rel;  // capture time - origin
  std::vector<std::uint64_t> sequence;
  std::vector<char> corrupt;
  double rate_hz = 10.0;
};

struct RecordedWheel {
  std::vector<hal::AngleSample> samples;           // stamps relative to the origin, ascending
  std::vector<std::pair<TimeNs, double>> queries;  // (rel t, angle or NaN), ascending t
};

struct RecordedEncoders {
  std::vector<std::string> wheels;
  std::vector<RecordedWheel> per_wheel;
};

struct RecordedImu {
  std::vector<hal::ImuSample> samples;               // stamps relative to the origin, ascending
  std::vector<std::pair<TimeNs, Attitude>> queries;  // (rel t, attitude or NaN), ascending t
  std::vector<std::pair<TimeNs, Attitude>> exact;    // each sample's attitude as recorded (load only)
};

/// One HAL recording, read once and shared by every replay device of a deployment.
struct Recording {
  std::string file;
  TimeNs origin = 0;
  std::map<std::string, RecordedCamera> cameras;
  std::map<std::string, RecordedEncoders> encoders;
  std::map<std::string, RecordedImu> imus;

  static std::shared_ptr<const Recording> load(const std::string& path);

  std::string devices(const char* kind) const {
    std::string s;
    auto add = [&](const std::string& id) { s += (s.empty() ? "" : ", ") + id; };
    if (std::string_view(kind) == hal::Camera::kKind)
      for (const auto& [id, c] : cameras) add(id);
    if (std::string_view(kind) == hal::WheelEncoders::kKind)
      for (const auto& [id, c] : encoders) add(id);
    if (std::string_view(kind) == hal::Imu::kKind)
      for (const auto& [id, c] : imus) add(id);
    return s.empty() ? "none" : s;
  }
};

/// "/hal/<kind>/<id>/<leaf>" -> kind, id, leaf; false for other topics.
bool split_topic(const std::string& topic, std::string& kind, std::string& id, std::string& leaf) {
  if (topic.rfind("/hal/", 0) != 0) return false;
  const std::size_t a = topic.find('/', 5);
  const std::size_t b = topic.rfind('/');
  if (a == std::string::npos || b <= a) return false;
  kind = topic.substr(5, a - 5);
  id = topic.substr(a + 1, b - a - 1);
  leaf = topic.substr(b + 1);
  return true;
}

/// The HAL messages of one file of a recording into `rec` (series sorted afterwards).
void read_file(record::McapReader& reader, const std::string& file, Recording& rec) {
  for (const auto& [cid, ch] : reader.info().channels) {
    std::string kind, id, leaf;
    if (!split_topic(ch.topic, kind, id, leaf)) continue;
    if (kind == "cameras") {
      auto r = ch.metadata.find("rate_hz");
      if (r != ch.metadata.end()) rec.cameras[id].rate_hz = std::stod(r->second);
    } else if (kind == "encoders") {
      auto w = ch.metadata.find("wheels");
      RecordedEncoders& e = rec.encoders[id];
      if (w != ch.metadata.end() && e.wheels.empty()) {
        std::size_t at = 0;
        while (at <= w->second.size()) {
          const std::size_t comma = std::min(w->second.find(',', at), w->second.size());
          if (comma > at) e.wheels.push_back(w->second.substr(at, comma - at));
          at = comma + 1;
        }
        e.per_wheel.resize(e.wheels.size());
      }
    }
  }
  const std::vector<record::ReadProblem> problems = reader.for_each_message([&](const record::MessageView& m) {
    std::string kind, id, leaf;
    if (!split_topic(m.channel.topic, kind, id, leaf)) return;
    try {
      if (kind == "cameras") {
        record::DecodedImage d = record::decode_image(m.data);
        RecordedCamera& c = rec.cameras[id];
        c.images.push_back(std::move(d.image));
        c.rel.push_back(d.stamp - rec.origin);
        c.sequence.push_back(m.sequence);
        c.corrupt.push_back(leaf == "image_corrupt" ? 1 : 0);
      } else if (kind == "encoders") {
        const record::DecodedWheelAngle d = record::decode_wheel_angle(m.data);
        RecordedEncoders& e = rec.encoders[id];
        auto w = std::find(e.wheels.begin(), e.wheels.end(), d.wheel);
        if (w == e.wheels.end()) {
          e.wheels.push_back(d.wheel);
          e.per_wheel.emplace_back();
          w = e.wheels.end() - 1;
        }
        RecordedWheel& rw = e.per_wheel[static_cast<std::size_t>(w - e.wheels.begin())];
        if (leaf == "queries") {
          rw.queries.emplace_back(d.stamp - rec.origin, d.angle);
        } else {
          rw.samples.push_back({d.stamp - rec.origin, d.angle});
        }
      } else if (kind == "imus") {
        RecordedImu& u = rec.imus[id];
        if (leaf == "queries" || leaf == "attitude") {
          const record::DecodedAttitude d = record::decode_attitude(m.data);
          (leaf == "queries" ? u.queries : u.exact).emplace_back(d.stamp - rec.origin, d.a);
        } else {
          hal::ImuSample s = record::decode_imu(m.data);
          s.stamp -= rec.origin;
          s.sequence = m.sequence;
          u.samples.push_back(s);
        }
      }
    } catch (const std::exception& e) {
      throw InputError(file + ": " + m.channel.topic + " message at log time " + std::to_string(m.log_time) + ": " +
                       e.what());
    }
  });
  for (const auto& p : problems) spdlog::warn("replay: {} (skipped)", reader.describe(p));
}

std::shared_ptr<const Recording> Recording::load(const std::string& path) {
  static std::mutex mutex;
  static std::map<std::string, std::weak_ptr<const Recording>> cache;
  std::lock_guard<std::mutex> lock(mutex);
  if (auto r = cache[path].lock()) return r;

  auto rec = std::make_shared<Recording>();
  rec->file = path;
  // A split recording (drive.mcap, drive_001.mcap, ...) is one recording: every file of it (same
  // HAL time origin) is read; a sibling of another recording is not.
  const std::vector<std::filesystem::path> files = record::mcap_recording_files(path);
  if (const std::size_t split = record::mcap_split_files(path).size(); split > files.size())
    spdlog::warn("replay: {} is not part of the recording {} (another recording id or time origin): not replayed",
                 record::mcap_split_path(path, files.size()).string(), path);
  for (std::size_t f = 0; f < files.size(); ++f) {
    const std::string file = files[f].string();
    record::McapReader reader(file);  // InputError naming the file when it is not MCAP
    const record::HalRecordingInfo hal = record::hal_recording_info(reader.info(), file);
    if (hal.found && hal.origin_ns >= 0) rec->origin = hal.origin_ns;
    if (!hal.found || hal.origin_ns < 0)
      throw InputError(file +
                       ": no HAL recording in this file (no `regolith_hal` metadata: record with `regolith run "
                       "--record`, which records the devices' inputs)");
    read_file(reader, file, *rec);
  }
  if (files.size() > 1)
    spdlog::info("replay: {} and the {} later file(s) of its split recording", path, files.size() - 1);
  // Chunks arrive in file order, each sorted by log time: sort the series by their own stamps.
  for (auto& camera : rec->cameras) {
    auto& c = camera.second;  // a reference, not a binding: the comparator captures it (clang 14)
    std::vector<std::size_t> order(c.rel.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return c.rel[a] < c.rel[b]; });
    RecordedCamera s;
    s.rate_hz = c.rate_hz;
    for (std::size_t i : order) {
      s.images.push_back(c.images[i]);
      s.rel.push_back(c.rel[i]);
      s.sequence.push_back(c.sequence[i]);
      s.corrupt.push_back(c.corrupt[i]);
    }
    c = std::move(s);
  }
  for (auto& [id, e] : rec->encoders) {
    for (auto& w : e.per_wheel) {
      std::stable_sort(w.samples.begin(), w.samples.end(),
                       [](const auto& a, const auto& b) { return a.stamp < b.stamp; });
      std::stable_sort(w.queries.begin(), w.queries.end(),
                       [](const auto& a, const auto& b) { return a.first < b.first; });
    }
  }
  for (auto& [id, u] : rec->imus) {
    std::stable_sort(u.samples.begin(), u.samples.end(),
                     [](const auto& a, const auto& b) { return a.stamp < b.stamp; });
    std::stable_sort(u.queries.begin(), u.queries.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    // The samples' attitudes exactly as the device gave them (not through the quaternion).
    std::map<TimeNs, Attitude> exact(u.exact.begin(), u.exact.end());
    for (auto& smp : u.samples) {
      auto it = exact.find(smp.stamp);
      if (it != exact.end()) smp.attitude = it->second;
    }
    u.exact.clear();
  }
  cache[path] = rec;
  return rec;
}

struct ReplaySource {
  std::shared_ptr<const Recording> rec;
  std::string device;  // the recorded device played by this one
};

ReplaySource read_source(Params& p, const hal::DeviceContext& ctx, const char* kind) {
  ReplaySource s;
  const std::string file = hal::resolve_path(
      ctx, p.require<std::string>("file", {.doc = "MCAP file with a HAL recording (`regolith run --record`)"}));
  s.device = p.get<std::string>("device", ctx.id, {.doc = "the recorded device to play (default: this device's name)"});
  try {
    s.rec = Recording::load(file);
  } catch (const InputError& e) {
    p.fail("file", e.what());
  }
  const Recording& r = *s.rec;
  const bool found = std::string_view(kind) == hal::Camera::kKind          ? r.cameras.count(s.device) > 0
                     : std::string_view(kind) == hal::WheelEncoders::kKind ? r.encoders.count(s.device) > 0
                                                                           : r.imus.count(s.device) > 0;
  if (!found)
    p.fail(p.has("device") ? "device" : "file", "no " + std::string(kind) + " '" + s.device + "' in the recording " +
                                                    file + " (recorded: " + r.devices(kind) + ")");
  return s;
}

// ---- camera -------------------------------------------------------------------------------------

class ReplayCamera final : public PreloadedCamera {
 public:
  ReplayCamera(const hal::DeviceContext& ctx, hal::CameraFormat fmt, std::shared_ptr<const Recording> rec,
               const RecordedCamera& cam)
      : PreloadedCamera(ctx, fmt, cam.images, false), rec_(std::move(rec)), cam_(cam) {}

 protected:
  std::int64_t frame_index(TimeNs rel) const override {
    const auto it = std::upper_bound(cam_.rel.begin(), cam_.rel.end(), rel);
    return static_cast<std::int64_t>(it - cam_.rel.begin()) - 1;
  }
  TimeNs frame_offset(std::int64_t k) const override { return cam_.rel[static_cast<std::size_t>(k)]; }
  std::uint64_t frame_sequence(std::int64_t k) const override { return cam_.sequence[static_cast<std::size_t>(k)]; }
  bool frame_corrupt(std::int64_t k) const override { return cam_.corrupt[static_cast<std::size_t>(k)] != 0; }

 private:
  std::shared_ptr<const Recording> rec_;  // keeps cam_ alive
  const RecordedCamera& cam_;
};

// ---- encoders -----------------------------------------------------------------------------------

class ReplayEncoders final : public LazyEncoders {
 public:
  ReplayEncoders(const hal::DeviceContext& ctx, std::shared_ptr<const Recording> rec, const RecordedEncoders& enc,
                 TimeNs max_extrapolation)
      : LazyEncoders(ctx, enc.wheels, max_extrapolation), rec_(std::move(rec)), enc_(enc) {}

  bool angle_at(std::size_t wheel, TimeNs t, double& angle) const override {
    if (wheel < enc_.per_wheel.size()) {
      // The recorded answer to this very question, when the recorded run asked it.
      const auto& q = enc_.per_wheel[wheel].queries;
      const TimeNs rel = t - start_time();
      const auto it = std::lower_bound(q.begin(), q.end(), rel, [](const auto& a, TimeNs v) { return a.first < v; });
      if (it != q.end() && it->first == rel) {
        if (std::isnan(it->second)) return false;
        angle = it->second;
        return true;
      }
    }
    return LazyEncoders::angle_at(wheel, t, angle);
  }

 protected:
  std::int64_t index_at(std::size_t wheel, TimeNs rel) const override {
    const auto& s = enc_.per_wheel[wheel].samples;
    const auto it = std::upper_bound(s.begin(), s.end(), rel, [](TimeNs v, const auto& a) { return v < a.stamp; });
    return static_cast<std::int64_t>(it - s.begin()) - 1;
  }
  hal::AngleSample sample(std::size_t wheel, std::int64_t g) const override {
    return enc_.per_wheel[wheel].samples[static_cast<std::size_t>(g)];
  }

 private:
  std::shared_ptr<const Recording> rec_;
  const RecordedEncoders& enc_;
};

// ---- IMU ----------------------------------------------------------------------------------------

class ReplayImu final : public hal::Imu {
 public:
  ReplayImu(const hal::DeviceContext& ctx, std::shared_ptr<const Recording> rec, const RecordedImu& imu)
      : id_(ctx.id), clock_(clock_of(ctx)), rec_(std::move(rec)), imu_(imu) {}

  const std::string& id() const override { return id_; }
  void start() override { run_.begin(clock_->now()); }
  void stop() override { run_.end(clock_->now()); }

  bool latest(TimeNs now, hal::ImuSample& out) const override {
    const std::int64_t k = newest(now);
    if (k < 0) return false;
    out = imu_.samples[static_cast<std::size_t>(k)];
    out.stamp += run_.start();
    return true;
  }

  bool attitude_at(TimeNs t, Attitude& out) const override {
    if (!run_.running()) return false;
    const TimeNs rel = t - run_.start();
    const auto& q = imu_.queries;
    const auto it = std::lower_bound(q.begin(), q.end(), rel, [](const auto& a, TimeNs v) { return a.first < v; });
    if (it != q.end() && it->first == rel) {
      if (std::isnan(it->second.roll_rad)) return false;
      out = it->second;
      return true;
    }
    // Not asked in the recorded run: interpolate between the recorded samples around t.
    const auto& s = imu_.samples;
    const auto hi = std::lower_bound(s.begin(), s.end(), rel, [](const auto& a, TimeNs v) { return a.stamp < v; });
    if (hi == s.end() || (hi == s.begin() && hi->stamp != rel)) return false;
    if (hi->stamp == rel) {
      out = hi->attitude;
      return true;
    }
    const auto lo = hi - 1;
    const double f = static_cast<double>(rel - lo->stamp) / static_cast<double>(hi->stamp - lo->stamp);
    out.roll_rad = lo->attitude.roll_rad + f * (hi->attitude.roll_rad - lo->attitude.roll_rad);
    out.pitch_rad = lo->attitude.pitch_rad + f * (hi->attitude.pitch_rad - lo->attitude.pitch_rad);
    out.yaw_rad = lo->attitude.yaw_rad + f * std::remainder(hi->attitude.yaw_rad - lo->attitude.yaw_rad, 2 * M_PI);
    return true;
  }

  std::size_t samples_since(TimeNs after, TimeNs now, std::span<hal::ImuSample> out) const override {
    const std::int64_t last = newest(now);
    std::size_t n = 0;
    const TimeNs t0 = run_.start();
    for (std::int64_t k = 0; k <= last && n < out.size(); ++k) {
      hal::ImuSample s = imu_.samples[static_cast<std::size_t>(k)];
      s.stamp += t0;
      if (s.stamp > after) out[n++] = s;
    }
    return n;
  }

  hal::DeviceCounters counters() const override {
    hal::DeviceCounters c;
    TimeNs rel = 0;
    if (!run_.counted(clock_->now(), rel)) return c;
    c.state = run_.state();
    c.delivered = static_cast<std::uint64_t>(newest_at(rel) + 1);
    return c;
  }

 private:
  std::int64_t newest(TimeNs now) const { return run_.running() ? newest_at(now - run_.start()) : -1; }
  std::int64_t newest_at(TimeNs rel) const {
    const auto& s = imu_.samples;
    const auto it = std::upper_bound(s.begin(), s.end(), rel, [](TimeNs v, const auto& a) { return v < a.stamp; });
    return static_cast<std::int64_t>(it - s.begin()) - 1;
  }
  std::string id_;
  Clock* clock_;
  std::shared_ptr<const Recording> rec_;
  const RecordedImu& imu_;
  RunSpan run_;
};

}  // namespace
}  // namespace detail

std::unique_ptr<hal::Camera> make_replay_camera(Params& p, const hal::DeviceContext& ctx) {
  detail::ReplaySource s = detail::read_source(p, ctx, hal::Camera::kKind);
  const detail::RecordedCamera& cam = s.rec->cameras.at(s.device);
  if (cam.images.empty()) p.fail("file", "camera '" + s.device + "' has no frames in " + s.rec->file);
  hal::CameraFormat fmt;
  fmt.width = cam.images.front().cols;
  fmt.height = cam.images.front().rows;
  fmt.format = cam.images.front().channels() == 1 ? hal::PixelFormat::kMono8 : hal::PixelFormat::kBgr8;
  fmt.rate_hz = cam.rate_hz;
  for (std::size_t i = 0; i < cam.images.size(); ++i) {
    if (cam.images[i].size() != cam.images.front().size() || cam.images[i].type() != cam.images.front().type())
      p.fail("file", "camera '" + s.device + "': frame " + std::to_string(cam.sequence[i]) + " in " + s.rec->file +
                         " has another geometry than the first frame");
  }
  return std::make_unique<detail::ReplayCamera>(ctx, fmt, s.rec, cam);
}

std::unique_ptr<hal::WheelEncoders> make_replay_encoders(Params& p, const hal::DeviceContext& ctx) {
  detail::ReplaySource s = detail::read_source(p, ctx, hal::WheelEncoders::kKind);
  const TimeNs max_extrapolation = detail::read_max_extrapolation(p);
  return std::make_unique<detail::ReplayEncoders>(ctx, s.rec, s.rec->encoders.at(s.device), max_extrapolation);
}

std::unique_ptr<hal::Imu> make_replay_imu(Params& p, const hal::DeviceContext& ctx) {
  detail::ReplaySource s = detail::read_source(p, ctx, hal::Imu::kKind);
  return std::make_unique<detail::ReplayImu>(ctx, s.rec, s.rec->imus.at(s.device));
}

}  // namespace regolith::mocks
