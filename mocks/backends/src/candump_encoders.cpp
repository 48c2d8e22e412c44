// Encoders "candump": replay of a can-utils `candump -l` log, decoded with the shared CanDecoder.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>

#include "backends_internal.hpp"
#include "common.hpp"
#include "regolith/hal/can.hpp"

namespace regolith::mocks {
namespace detail {
namespace {

struct LoggedFrame {
  TimeNs time = 0;  // unix time from the log, ns
  int line = 0;
  hal::CanFrame frame;
};

/// The "(seconds.fraction)" stamp of a line that parse_candump_line accepted, exactly in ns (a
/// double holds a 2023 unix time only to ~0.2 us).
TimeNs exact_stamp(const std::string& line, double approx_s) {
  const auto open = line.find('(');
  const auto dot = line.find('.', open);
  const auto close = line.find(')', open);
  if (open == std::string::npos || dot == std::string::npos || close == std::string::npos || dot > close)
    return static_cast<TimeNs>(std::llround(approx_s * 1e9));
  TimeNs sec = 0;
  for (std::size_t i = open + 1; i < dot; ++i) {
    if (line[i] < '0' || line[i] > '9') return static_cast<TimeNs>(std::llround(approx_s * 1e9));
    sec = sec * 10 + (line[i] - '0');
  }
  TimeNs frac = 0;
  int digits = 0;
  for (std::size_t i = dot + 1; i < close && digits < 9; ++i, ++digits) {
    if (line[i] < '0' || line[i] > '9') return static_cast<TimeNs>(std::llround(approx_s * 1e9));
    frac = frac * 10 + (line[i] - '0');
  }
  for (; digits < 9; ++digits) frac *= 10;
  return sec * kNsPerSec + frac;
}

class CandumpEncoders final : public LazyEncoders {
 public:
  CandumpEncoders(const hal::DeviceContext& ctx, std::vector<std::string> wheels,
                  std::vector<std::vector<hal::AngleSample>> samples, std::vector<hal::CanFrame> frames, TimeNs period,
                  bool loop, std::uint64_t rejected, TimeNs max_extrapolation)
      : LazyEncoders(ctx, std::move(wheels), max_extrapolation),
        samples_(std::move(samples)),
        frames_(std::move(frames)),
        period_(period),
        loop_(loop) {
    rejected_ = rejected;
    for (const auto& s : samples_) loop_gain_.push_back(s.empty() ? 0.0 : s.back().angle - s.front().angle);
  }

  /// The log's frames (every id of the replayed interface), at the times they are replayed.
  bool reads_can() const override { return true; }
  std::size_t can_frames(std::uint64_t& cursor, TimeNs now, std::span<hal::CanFrame> out,
                         std::uint64_t& /*missed*/) const override {
    TimeNs rel = 0;
    if (frames_.empty() || !delivered(now, rel)) return 0;
    const std::uint64_t n = frames_.size();
    std::size_t k = 0;
    for (; k < out.size(); ++cursor, ++k) {
      const std::uint64_t pass = cursor / n;
      if (pass > 0 && !loop_) break;
      hal::CanFrame f = frames_[cursor % n];
      f.stamp += static_cast<TimeNs>(pass) * period_;
      if (f.stamp > rel) break;
      f.stamp += start_time();
      out[k] = f;
    }
    return k;
  }

 protected:
  std::int64_t index_at(std::size_t wheel, TimeNs rel) const override {
    const auto& s = samples_[wheel];
    if (rel < 0 || s.empty()) return -1;
    const auto n = static_cast<std::int64_t>(s.size());
    std::int64_t pass = 0;
    if (loop_) {
      pass = rel / period_;
      rel -= pass * period_;
    }
    const auto it =
        std::upper_bound(s.begin(), s.end(), rel, [](TimeNs t, const hal::AngleSample& a) { return t < a.stamp; });
    const auto i = static_cast<std::int64_t>(it - s.begin()) - 1;  // -1: before this pass's first sample
    return pass * n + i;
  }
  hal::AngleSample sample(std::size_t wheel, std::int64_t g) const override {
    const auto& s = samples_[wheel];
    const auto n = static_cast<std::int64_t>(s.size());
    const std::int64_t pass = g / n;
    const auto& a = s[static_cast<std::size_t>(g % n)];
    // Replayed again and again, the wheel keeps turning: each pass adds the net rotation of one.
    return {a.stamp + pass * period_, a.angle + static_cast<double>(pass) * loop_gain_[wheel]};
  }

 private:
  std::vector<std::vector<hal::AngleSample>> samples_;  // per wheel, stamps relative to the first frame
  std::vector<hal::CanFrame> frames_;                   // every frame replayed, stamps likewise
  std::vector<double> loop_gain_;
  TimeNs period_ = 1;
  bool loop_ = false;
};

}  // namespace
}  // namespace detail

std::unique_ptr<hal::WheelEncoders> make_candump_encoders(Params& p, const hal::DeviceContext& ctx) {
  const std::string raw_file = p.require<std::string>("file", {.doc = "can-utils `candump -l` log file"});
  const std::string iface =
      p.get<std::string>("interface", "", {.doc = "replay only frames of this interface (empty = all)"});
  const bool loop = p.get<bool>("loop", false, {.doc = "replay the log again from the start when it ends"});
  const double rate_scale = p.get<double>(
      "rate_scale", 1.0,
      {.min = 0.0, .max = 1000.0, .min_exclusive = true, .doc = "replay speed factor (2 = twice as fast)"});
  const bool skip_bad =
      p.get<bool>("skip_bad_lines", false, {.doc = "count malformed lines in stats().rejected instead of failing"});
  Params wheels_p = p.require_child("wheels");
  std::vector<std::string> names = wheels_p.keys();
  if (names.empty()) wheels_p.fail({}, "needs at least one wheel: <name>: {id: ..., ...}");
  std::vector<hal::CanSignal> signals;
  for (const auto& n : names) {
    Params c = wheels_p.child(n);
    signals.push_back(hal::can_signal_from_params(c, n));
    c.finish();
  }
  wheels_p.finish();
  const TimeNs max_ex = detail::read_max_extrapolation(p);

  const std::string file = hal::resolve_path(ctx, raw_file);
  std::ifstream in(file);
  if (!in) p.fail("file", "cannot open candump log '" + file + "'");
  std::vector<detail::LoggedFrame> frames;
  std::uint64_t rejected = 0;
  std::string line, ifname, error;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.find_first_not_of(" \t\r\n") == std::string::npos) continue;
    detail::LoggedFrame lf;
    lf.line = line_no;
    double time_s = 0.0;
    if (!hal::parse_candump_line(line, lf.frame, ifname, time_s, error)) {
      if (skip_bad) {
        ++rejected;
        continue;
      }
      throw ConfigError(file + ":" + std::to_string(line_no) + ": " + error);
    }
    if (!iface.empty() && ifname != iface) continue;
    lf.time = detail::exact_stamp(line, time_s);
    frames.push_back(lf);
  }
  if (frames.empty()) p.fail("file", "'" + file + "' has no CAN frames" + (iface.empty() ? "" : " on " + iface));
  // candump timestamps are normally in order; a reordered line is replayed at its own time.
  std::stable_sort(frames.begin(), frames.end(),
                   [](const detail::LoggedFrame& a, const detail::LoggedFrame& b) { return a.time < b.time; });

  hal::CanDecoder decoder(signals);
  std::vector<std::vector<hal::AngleSample>> samples(signals.size());
  const TimeNs t0 = frames.front().time;
  auto scaled = [&](TimeNs t) {
    return rate_scale == 1.0 ? t - t0 : static_cast<TimeNs>(std::llround(static_cast<double>(t - t0) / rate_scale));
  };
  std::vector<hal::CanFrame> raw;
  raw.reserve(frames.size());
  for (const auto& lf : frames) {
    const TimeNs stamp = scaled(lf.time);
    raw.push_back(lf.frame);
    raw.back().stamp = stamp;
    decoder.decode(lf.frame, [&](std::size_t i, double v) {
      auto& s = samples[i];
      if (!s.empty() && s.back().stamp == stamp) {
        s.back().angle = v;  // two frames with one timestamp: keep the newer value
      } else {
        s.push_back({stamp, v});
      }
    });
  }
  rejected += decoder.short_frames();
  for (std::size_t i = 0; i < signals.size(); ++i) {
    if (samples[i].empty()) {
      char id[16];
      std::snprintf(id, sizeof id, signals[i].extended ? "%08X" : "%03X", static_cast<unsigned>(signals[i].id));
      p.fail("wheels", "wheel '" + names[i] + "': no frame with CAN id " + id + " in '" + file + "'");
    }
  }
  // Loop period: the log's span plus one mean frame interval, so the last and the first frame of
  // consecutive passes are not on top of each other.
  const TimeNs span = scaled(frames.back().time);
  const TimeNs gap =
      frames.size() > 1 ? std::max<TimeNs>(1, span / static_cast<TimeNs>(frames.size() - 1)) : 10 * kNsPerMs;
  return std::make_unique<detail::CandumpEncoders>(ctx, names, std::move(samples), std::move(raw), span + gap, loop,
                                                   rejected, max_ex);
}

}  // namespace regolith::mocks
