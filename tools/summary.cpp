#include "summary.hpp"

#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "regolith/runtime/dds_hooks.hpp"

namespace regolith::cli {
namespace {

std::string us(TimeNs ns) {
  if (ns >= 10 * kNsPerMs) return fmt::format("{:.1f}ms", static_cast<double>(ns) / 1e6);
  return fmt::format("{:.0f}us", static_cast<double>(ns) / 1e3);
}

}  // namespace

Summary::Summary(runtime::Application& app, bool redraw)
    : app_(app), redraw_(redraw), start_wall_(monotonic_now()), start_clock_(app.clock().now()) {}

void Summary::print(std::ostream& os, bool final) {
  const auto& v = app_.view();
  std::ostringstream out;
  const double wall = to_seconds(monotonic_now() - start_wall_);
  const double sim = to_seconds(app_.clock().now() - start_clock_);
  out << fmt::format(
      "regolith '{}'  {:.1f} s{}{}\n", app_.name(), app_.sim_time() ? sim : wall,
      app_.sim_time() ? fmt::format(" simulated in {:.1f} s wall ({:.0f}x)", wall, wall > 0 ? sim / wall : 0.0) : "",
      final ? "  [final]" : "");
  // late / stall = slips from a late start / a stall mid-cycle alone (the CPU was taken outside the
  // group: RateGroupCounters).
  out << fmt::format("{:<12} {:>8} {:>9} {:>6} {:>5} {:>5} {:>9} {:>9} {:>9} {:>10}\n", "rate group", "rate Hz",
                     "cycles", "slips", "late", "stall", "exec avg", "exec p99", "exec max", "wake p99");
  for (const auto* g : v.groups) {
    const auto c = g->counters();
    const auto e = g->cycle_exec().summary();
    const auto w = g->wakeup_latency().summary();
    // Under --sim-time the cycle times are simulated (members cost nothing unless they model it):
    // the per-component CPU times below are the meaningful numbers then.
    out << fmt::format("{:<12} {:>8.1f} {:>9} {:>6} {:>5} {:>5} {:>9} {:>9} {:>9} {:>10}\n", g->config().name,
                       1e9 / static_cast<double>(g->config().period), c.cycles, c.slips, c.late_start_slips,
                       c.stall_slips, app_.sim_time() ? "-" : us(e.mean), app_.sim_time() ? "-" : us(e.p99),
                       app_.sim_time() ? "-" : us(e.max), app_.sim_time() ? "-" : us(w.p99));
  }
  // cpu = CLOCK_THREAD_CPUTIME_ID around step(); wall = elapsed (includes preemption, page faults).
  out << fmt::format("{:<16} {:>7} {:>9} {:>9} {:>9} {:>9} {:>6} {:>5}  {}\n", "component", "steps", "cpu avg",
                     "cpu p99", "wall avg", "wall p99", "errors", "stale", "status");
  for (const auto* c : v.components) {
    const auto cpu = c->cpu().summary();
    const auto elapsed = c->wall().summary();
    std::uint64_t stale = 0;
    for (const auto& in : c->inputs()) stale += in->stale_cycles.load();
    out << fmt::format("{:<16} {:>7} {:>9} {:>9} {:>9} {:>9} {:>6} {:>5}  {}\n", c->name(), c->heartbeat(),
                       us(cpu.mean), us(cpu.p99), us(elapsed.mean), us(elapsed.p99), c->errors(), stale,
                       c->status_message());
  }
  out << "latest results\n";
  for (const auto* c : v.components) {
    const std::string r = c->result();
    if (!r.empty()) out << fmt::format("  {:<14} {}\n", c->name(), r);
  }
  if (final) {  // each component's own counters (Component::diagnostics), once at the end
    out << "component details\n";
    for (const auto* c : v.components) {
      std::vector<std::pair<std::string, std::string>> kv;
      c->diagnostics(kv);
      if (kv.empty()) continue;
      std::string line;
      for (const auto& [key, value] : kv) line += fmt::format(" {}={}", key, value);
      out << fmt::format("  {:<14}{}\n", c->name(), line);
    }
  }
  for (const auto& [name, cam] : app_.context().devices_of<hal::Camera>()) {
    const auto s = cam->stats();
    out << fmt::format("camera {:<15} {} frames {} dropped {} corrupt {} faults {} recoveries {}\n", name,
                       hal::to_string(s.state), s.frames, s.dropped, s.corrupt, s.faults, s.recoveries);
  }
  for (const auto& [name, enc] : app_.context().devices_of<hal::WheelEncoders>()) {
    const auto s = enc->stats();
    out << fmt::format("encoders {:<13} {} samples {} rejected {} faults {}\n", name, hal::to_string(s.state),
                       s.samples, s.rejected, s.faults);
  }
  for (const auto& [name, imu] : app_.context().devices_of<hal::Imu>()) {
    const auto c = imu->counters();
    out << fmt::format("imu {:<18} {} samples {} rejected {} faults {}\n", name, hal::to_string(c.state), c.delivered,
                       c.rejected, c.faults);
  }
  if (app_.dds() != nullptr) out << runtime::dds_summary(*app_.dds());
  const std::string text = out.str();
  if (redraw_ && lines_printed_ > 0 && !final) os << "\x1b[" << lines_printed_ << "F\x1b[J";
  os << text << std::flush;
  lines_printed_ = static_cast<int>(std::count(text.begin(), text.end(), '\n'));
  if (!redraw_) os << '\n';
}

void print_resolved(std::ostream& os, const std::vector<ResolvedParam>& params) {
  for (const auto& p : params) {
    os << p.path << ": " << p.value;
    if (!p.unit.empty()) os << " [" << p.unit << "]";
    if (p.defaulted) os << "  # default";
    if (!p.range.empty()) os << (p.defaulted ? ", " : "  # ") << p.range;
    os << '\n';
  }
}

}  // namespace regolith::cli
