// Encoders "scripted": wheel angles from a constant speed or a CSV angle profile, sampled on the
// report grid of a real encoder stream, with optional deterministic noise.
#include <algorithm>
#include <cmath>
#include <fstream>

#include "backends_internal.hpp"
#include "common.hpp"
#include "regolith/core/csv.hpp"
#include "script.hpp"

namespace regolith::mocks {
namespace detail {

AngleProfile AngleProfile::load_csv(const std::string& file, const std::vector<std::string>& wanted, bool loop) {
  std::ifstream in(file);
  if (!in) throw ConfigError(file + ": cannot open angle profile");
  AngleProfile prof;
  prof.loop_ = loop;
  std::string line;
  int line_no = 0;
  std::vector<std::string> header;
  std::vector<std::size_t> column_of;  // wheel -> CSV column
  while (std::getline(in, line)) {
    ++line_no;
    const std::string t = trim_blanks(line);
    if (t.empty() || t.front() == '#') continue;
    const auto where = file + ":" + std::to_string(line_no) + ": ";
    const auto cells = split_csv_line(t);
    if (header.empty()) {
      header = cells;
      if (header.size() < 2 || header.front() != "time_s")
        throw ConfigError(where + "header must be 'time_s,<wheel>,...' (got '" + t + "')");
      std::vector<std::string> names = wanted;
      if (names.empty()) names.assign(header.begin() + 1, header.end());
      for (const auto& w : names) {
        const auto it = std::find(header.begin() + 1, header.end(), w);
        if (it == header.end()) throw ConfigError(where + "no column for wheel '" + w + "' in the header");
        column_of.push_back(static_cast<std::size_t>(it - header.begin()));
      }
      prof.wheels_ = names;
      prof.angles_.resize(names.size());
      continue;
    }
    if (cells.size() != header.size())
      throw ConfigError(where + "expected " + std::to_string(header.size()) + " values, got " +
                        std::to_string(cells.size()));
    std::vector<double> v(cells.size());
    for (std::size_t c = 0; c < cells.size(); ++c) {
      std::size_t pos = 0;
      bool ok = !cells[c].empty();
      try {
        v[c] = ok ? std::stod(cells[c], &pos) : 0.0;
      } catch (...) {
        ok = false;
      }
      if (!ok || pos != cells[c].size() || !std::isfinite(v[c]))
        throw ConfigError(where + "column '" + header[c] + "': '" + cells[c] + "' is not a finite number");
    }
    if (!prof.times_.empty() && !(v[0] > prof.times_.back()))
      throw ConfigError(where + "time_s " + cells[0] + " is not after the previous row's");
    if (prof.times_.empty() && v[0] < 0.0) throw ConfigError(where + "time_s must be >= 0");
    prof.times_.push_back(v[0]);
    for (std::size_t w = 0; w < column_of.size(); ++w) prof.angles_[w].push_back(v[column_of[w]]);
  }
  if (header.empty()) throw ConfigError(file + ":1: empty profile (expected a 'time_s,<wheel>,...' header)");
  if (prof.times_.empty()) throw ConfigError(file + ":" + std::to_string(line_no) + ": profile has no data rows");
  if (loop && prof.times_.size() < 2)
    throw ConfigError(file + ":" + std::to_string(line_no) + ": a looping profile needs at least two rows");
  return prof;
}

double AngleProfile::at(std::size_t wheel, double t) const {
  const auto& a = angles_[wheel];
  const double t0 = times_.front();
  const double t1 = times_.back();
  double offset = 0.0;
  if (loop_ && t > t1) {
    // The profile repeats with period (t1 - t0); the wheel keeps turning: each repetition adds
    // the net rotation of one pass so the angle stays continuous.
    const double period = t1 - t0;
    const double n = std::floor((t - t0) / period);
    t -= n * period;
    offset = n * (a.back() - a.front());
  }
  if (t <= t0) return a.front() + offset;
  if (t >= t1) return a.back() + offset;
  const auto it = std::upper_bound(times_.begin(), times_.end(), t);
  const auto i = static_cast<std::size_t>(it - times_.begin());  // times_[i-1] <= t < times_[i]
  const double f = (t - times_[i - 1]) / (times_[i] - times_[i - 1]);
  return a[i - 1] + f * (a[i] - a[i - 1]) + offset;
}

ScriptedMotion ScriptedMotion::from_params(Params& p, const hal::DeviceContext& ctx, std::vector<std::string> wheels) {
  ScriptedMotion m;
  const bool has_csv = p.has("profile_csv");
  if (has_csv && (p.has("speed_rad_s") || p.has("initial_angle_rad")))
    p.fail("profile_csv", "give either profile_csv or speed_rad_s / initial_angle_rad, not both");
  if (has_csv) {
    const std::string f =
        p.get<std::string>("profile_csv", "", {.doc = "CSV 'time_s,<wheel>,...' of angles (rad), interpolated"});
    const bool loop = p.get<bool>("loop", false, {.doc = "repeat the profile (angles keep accumulating)"});
    m.profile_ = std::make_shared<AngleProfile>(AngleProfile::load_csv(hal::resolve_path(ctx, f), wheels, loop));
    m.wheels_ = m.profile_->wheels();
    return m;
  }
  if (wheels.empty()) p.fail("wheels", "required list of wheel names is missing");
  m.wheels_ = wheels;
  auto per_wheel = [&](const char* key, double def, std::string_view unit, const char* doc) {
    std::vector<double> v;
    if (p.has(key) && p.node()[key].IsSequence()) {
      v = p.get<std::vector<double>>(key, {}, {.unit = unit, .min = -1e6, .max = 1e6, .doc = doc});
      if (v.size() != wheels.size())
        p.fail(key, "has " + std::to_string(v.size()) + " values for " + std::to_string(wheels.size()) + " wheels");
    } else {
      v.assign(wheels.size(), p.get<double>(key, def, {.unit = unit, .min = -1e6, .max = 1e6, .doc = doc}));
    }
    return v;
  };
  m.speed_ = per_wheel("speed_rad_s", 1.0, "rad/s", "wheel speed: one value for all wheels or one per wheel");
  m.initial_ = per_wheel("initial_angle_rad", 0.0, "rad", "angle at start(): one value or one per wheel");
  return m;
}

double ScriptedMotion::angle(std::size_t wheel, double t) const {
  if (profile_) return profile_->at(wheel, t);
  return initial_[wheel] + speed_[wheel] * t;
}

namespace {

class ScriptedEncoders final : public LazyEncoders {
 public:
  ScriptedEncoders(const hal::DeviceContext& ctx, ScriptedMotion motion, double rate_hz, double noise_rad,
                   std::uint64_t seed, TimeNs max_extrapolation)
      : LazyEncoders(ctx, motion.wheels(), max_extrapolation),
        motion_(std::move(motion)),
        grid_(rate_hz),
        noise_(noise_rad),
        seed_(seed) {}

 protected:
  std::int64_t index_at(std::size_t, TimeNs rel) const override { return grid_.index(rel); }
  hal::AngleSample sample(std::size_t wheel, std::int64_t g) const override {
    hal::AngleSample s;
    s.stamp = grid_.offset(g);
    s.angle = motion_.angle(wheel, to_seconds(s.stamp));
    if (noise_ > 0.0) s.angle += noise_ * gaussian(seed_, wheel, static_cast<std::uint64_t>(g));
    return s;
  }

 private:
  ScriptedMotion motion_;
  TimeGrid grid_;
  double noise_ = 0.0;
  std::uint64_t seed_ = 1;
};

}  // namespace
}  // namespace detail

std::unique_ptr<hal::WheelEncoders> make_scripted_encoders(Params& p, const hal::DeviceContext& ctx) {
  const auto wheels = p.get<std::vector<std::string>>(
      "wheels", {}, {.doc = "wheel names (with profile_csv: default = the CSV columns)"});
  const double rate = detail::read_sample_rate(p, "encoder report rate: samples lie on this grid");
  detail::ScriptedMotion motion = detail::ScriptedMotion::from_params(p, ctx, wheels);
  const double noise =
      p.get<double>("noise_rad", 0.0,
                    {.unit = "rad", .min = 0.0, .max = 10.0, .doc = "std dev of Gaussian angle noise (deterministic)"});
  const auto seed = p.get<std::int64_t>("seed", 1, {.min = 0, .doc = "noise seed"});
  const TimeNs max_ex = detail::read_max_extrapolation(p);
  return std::make_unique<detail::ScriptedEncoders>(ctx, std::move(motion), rate, noise,
                                                    static_cast<std::uint64_t>(seed), max_ex);
}

}  // namespace regolith::mocks
