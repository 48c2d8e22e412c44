// Components built into the runtime: `health` (diagnostics, stale inputs, watchdog gate) and
// `joint_state_publisher` (wheel encoder angles -> sensor_msgs/JointState).
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <thread>

#include "regolith/core/frame_order.hpp"
#include "regolith/dds/participant.hpp"
#include "regolith/dds/sample.hpp"
#include "regolith/dds/topics.hpp"
#include "regolith/hal/wheel_encoders.hpp"
#include "regolith/runtime/application.hpp"
#include "regolith/runtime/health.hpp"
#include "regolith/runtime/joint_state.hpp"

namespace regolith::runtime {
namespace {

using DiagnosticArray = msgs::diagnostic_msgs::DiagnosticArray;
using JointState = msgs::sensor_msgs::JointState;
using ImuMsg = msgs::sensor_msgs::Imu;

constexpr std::uint32_t kValuesPerStatus = 12;
constexpr std::size_t kDiagString = 64;

template <class Msg>
std::shared_ptr<dds::Outbox<Msg>> make_outbox(Context& ctx, const char* topic, dds::OutboxMode mode,
                                              const std::function<void(Msg&)>& reserve) {
  dds::Participant* p = ctx.dds();
  if (p == nullptr) return nullptr;
  const dds::TopicInfo* info = dds::find_topic(topic);
  return p->make_outbox<Msg>(topic, info->writer_qos(), dds::OutboxOptions{mode, 8}, reserve);
}

const char* kind_prefix(HealthEntry::Kind k) {
  switch (k) {
    case HealthEntry::Kind::kComponent: return "component: ";
    case HealthEntry::Kind::kRateGroup: return "rate_group: ";
    case HealthEntry::Kind::kCamera: return "camera: ";
    case HealthEntry::Kind::kEncoders: return "encoders: ";
    case HealthEntry::Kind::kImu: return "imu: ";
  }
  return "";
}

/// diagnostic_msgs/DiagnosticArray from a health snapshot, into pre-reserved strings.
void fill_diagnostics(const HealthSnapshot& s, const std::string& hardware_id, DiagnosticArray& m) {
  dds::set_stamp(m.header.stamp, s.stamp);
  dds::set_length(m.status, s.count);
  for (std::uint32_t i = 0; i < m.status._length; ++i) {
    const HealthEntry& e = s.entries[i];
    auto& st = m.status._buffer[i];
    st.level = static_cast<std::uint8_t>(e.level);
    char name[kDiagString + 1];
    const char* prefix = kind_prefix(e.kind);
    const std::size_t pl = std::strlen(prefix);
    std::memcpy(name, prefix, pl);
    dds::copy_string(name + pl, kDiagString - pl, e.name.data());
    dds::copy_string(st.name, kDiagString, name);
    dds::copy_string(st.message, kDiagString, e.message);
    dds::copy_string(st.hardware_id, kDiagString, hardware_id);
    std::uint32_t n = 0;
    auto kv_int = [&](const char* key, std::int64_t v) {
      if (n >= st.values._maximum) return;
      dds::copy_string(st.values._buffer[n].key, kDiagString, key);
      dds::format_int(st.values._buffer[n].value, kDiagString, v);
      ++n;
    };
    auto kv_us = [&](const char* key, TimeNs v) {
      if (n >= st.values._maximum) return;
      dds::copy_string(st.values._buffer[n].key, kDiagString, key);
      dds::format_double(st.values._buffer[n].value, kDiagString, static_cast<double>(v) / 1e3, 4);
      ++n;
    };
    switch (e.kind) {
      case HealthEntry::Kind::kRateGroup:
        kv_us("period_us", e.period);
        kv_int("cycles", static_cast<std::int64_t>(e.cycles));
        kv_int("cycle_slips", static_cast<std::int64_t>(e.slips));
        kv_int("late_start_slips", static_cast<std::int64_t>(e.late_start_slips));
        kv_int("stall_slips", static_cast<std::int64_t>(e.stall_slips));
        kv_us("exec_mean_us", e.exec.mean);
        kv_us("exec_p99_us", e.exec.p99);
        kv_us("exec_max_us", e.exec.max);
        kv_us("wakeup_p99_us", e.wall.p99);
        break;
      case HealthEntry::Kind::kComponent:
        kv_int("heartbeat", static_cast<std::int64_t>(e.heartbeat));
        kv_us("period_us", e.period);
        kv_int("cycle_slips", static_cast<std::int64_t>(e.slips));
        kv_us("exec_min_us", e.wall.min);
        kv_us("exec_mean_us", e.wall.mean);
        kv_us("exec_p99_us", e.wall.p99);
        kv_us("exec_max_us", e.wall.max);
        kv_int("errors", static_cast<std::int64_t>(e.errors));
        kv_int("stale_inputs", static_cast<std::int64_t>(e.stale_inputs));
        break;
      case HealthEntry::Kind::kCamera:
      case HealthEntry::Kind::kEncoders:
      case HealthEntry::Kind::kImu:
        kv_int(e.kind == HealthEntry::Kind::kCamera ? "frames" : "samples", static_cast<std::int64_t>(e.frames));
        kv_int(e.kind == HealthEntry::Kind::kCamera ? "dropped" : "rejected", static_cast<std::int64_t>(e.dropped));
        kv_int("faults", static_cast<std::int64_t>(e.errors));
        kv_int("stale_inputs", static_cast<std::int64_t>(e.stale_inputs));
        if (e.kind == HealthEntry::Kind::kEncoders) kv_int("lost", static_cast<std::int64_t>(e.lost));
        if (e.kind == HealthEntry::Kind::kCamera) kv_int("bad_stamps", static_cast<std::int64_t>(e.bad_stamps));
        break;
    }
    dds::set_length(st.values, n);
  }
}

void copy_name(std::array<char, kNameLen>& dst, const std::string& src) {
  const std::size_t n = std::min(src.size(), dst.size() - 1);
  std::memcpy(dst.data(), src.data(), n);
  dst[n] = '\0';
}

class HealthComponent final : public Component {
 public:
  void configure(Params& p, Context& ctx) override {
    ctx_ = &ctx;
    // Device lists made once (devices are loaded before any component configures): step() only
    // walks them.
    cameras_ = ctx.devices_of<hal::Camera>();
    encoders_ = ctx.devices_of<hal::WheelEncoders>();
    imus_ = ctx.devices_of<hal::Imu>();
    stall_cycles_ = p.get<int>(
        "stall_cycles", 3,
        {.min = 1, .max = 1000, .doc = "health cycles without a heartbeat before a component is reported stale"});
    out_ = &ctx.produce<HealthSnapshot>("health/snapshot");
    hardware_id_ = p.get<std::string>("hardware_id", "regolith", {.doc = "hardware_id of every DiagnosticStatus"});
    diag_ = make_outbox<DiagnosticArray>(ctx, "/diagnostics", dds::OutboxMode::kLatest, [](DiagnosticArray& m) {
      dds::reserve(m, dds::DiagnosticArrayCapacity{static_cast<std::uint32_t>(kMaxHealthEntries), kValuesPerStatus,
                                                   kDiagString, 32});
    });
  }

  void activate() override {
    // The system view is complete now; size the bookkeeping once.
    const auto& v = ctx_->system();
    last_heartbeat_.assign(v.components.size(), 0);
    unchanged_.assign(v.components.size(), 0);
    last_slips_.assign(v.groups.size(), 0);
    last_late_.assign(v.groups.size(), 0);
    last_stall_.assign(v.groups.size(), 0);
    slipped_.assign(v.groups.size(), 0);
    last_exec_count_.assign(v.components.size(), 0);
    last_exec_total_.assign(v.components.size(), 0.0);
    interval_exec_.assign(v.components.size(), 0.0);
    entry_of_.assign(v.components.size(), static_cast<std::uint32_t>(kMaxHealthEntries));
    last_lost_.assign(encoders_.size(), 0);
    last_bad_stamps_.assign(cameras_.size(), 0);
    group_of_.assign(v.components.size(), v.groups.size());
    for (std::size_t gi = 0; gi < v.groups.size(); ++gi)
      for (const Component* m : v.groups[gi]->members()) {
        const auto it = std::find(v.components.begin(), v.components.end(), m);
        if (it != v.components.end()) group_of_[static_cast<std::size_t>(it - v.components.begin())] = gi;
      }
  }

  void step(const CycleInfo& cycle) override {
    HealthSnapshot* s = out_->begin_write();
    if (s == nullptr) return;
    if (started_ < 0) started_ = cycle.now;
    s->stamp = cycle.now;
    s->count = 0;
    s->all_critical_ok = true;
    report_groups(*s);
    report_components(*s, cycle);
    blame_slips(*s);
    for (std::uint32_t i = 0; i < s->count; ++i)
      if (gates_watchdog(s->entries[i])) s->all_critical_ok = false;
    report_devices(*s, cycle.now);
    out_->commit();
    if (diag_) {
      if (DiagnosticArray* m = diag_->begin()) {
        fill_diagnostics(*s, hardware_id_, *m);
        diag_->commit();
      }
    }
  }

  bool critical() const override { return true; }

 private:
  // ---- step()'s parts: one entry per rate group, component and device, in that order ----

  // The next entry of `s`, cleared; nullptr when the snapshot is full.
  static HealthEntry* add_entry(HealthSnapshot& s) {
    if (s.count >= kMaxHealthEntries) return nullptr;
    HealthEntry& e = s.entries[s.count++];
    e = HealthEntry{};
    return &e;
  }

  // Rate groups: cycles, slips (a warning when it slipped since the last report), timing.
  void report_groups(HealthSnapshot& s) {
    const auto& v = ctx_->system();
    for (std::size_t gi = 0; gi < v.groups.size(); ++gi) {
      const RateGroup& g = *v.groups[gi];
      HealthEntry* e = add_entry(s);
      if (e == nullptr) break;
      const auto c = g.counters();
      e->kind = HealthEntry::Kind::kRateGroup;
      copy_name(e->name, g.config().name);
      e->cycles = c.cycles;
      e->slips = c.slips;
      e->period = g.config().period;
      e->exec = g.cycle_exec().summary();
      e->wall = g.wakeup_latency().summary();
      e->late_start_slips = c.late_start_slips;
      e->stall_slips = c.stall_slips;
      // Slips a member caused (the cycle overran) get a culprit; slips from a late start or a
      // stall alone (another thread or group had the CPU, the host descheduled it) are the
      // group's warning only.
      const std::uint64_t overrun = c.slips - c.late_start_slips - c.stall_slips;
      slipped_[gi] = overrun > last_slips_[gi];
      if (slipped_[gi]) {
        e->level = Level::kWarn;
        e->message = "cycle slips since last report";
      } else if (c.late_start_slips > last_late_[gi]) {
        e->level = Level::kWarn;
        e->message = "cycle slips since last report: started late (CPU taken outside the group)";
      } else if (c.stall_slips > last_stall_[gi]) {
        e->level = Level::kWarn;
        e->message = "cycle slips since last report: stalled mid-cycle (CPU taken outside the group)";
      }
      last_late_[gi] = c.late_start_slips;
      last_stall_[gi] = c.stall_slips;
      last_slips_[gi] = overrun;
    }
  }

  // Components: heartbeat (stalled after stall_cycles reports without one), errors, stale inputs,
  // timing, and the execution time since the last report (for blame_slips).
  void report_components(HealthSnapshot& s, const CycleInfo& cycle) {
    const auto& v = ctx_->system();
    std::fill(entry_of_.begin(), entry_of_.end(), static_cast<std::uint32_t>(kMaxHealthEntries));
    for (std::size_t ci = 0; ci < v.components.size(); ++ci) {
      const Component& comp = *v.components[ci];
      HealthEntry* e = add_entry(s);
      if (e == nullptr) break;
      e->kind = HealthEntry::Kind::kComponent;
      copy_name(e->name, comp.name());
      if (group_of_[ci] < v.groups.size()) {
        const RateGroup& g = *v.groups[group_of_[ci]];
        copy_name(e->group, g.config().name);
        e->slips = g.counters().slips;
        e->period = g.config().period;
      }
      e->heartbeat = comp.heartbeat();
      e->errors = comp.errors();
      e->exec = comp.exec().summary();
      e->wall = comp.wall().summary();
      e->critical = comp.critical();
      e->message = comp.status_message();
      // An input is stale when its timeout has passed since its last update, or since the start
      // when it never had one (not before: the first frame is still on its way).
      for (const auto& in : comp.inputs()) {
        const TimeNs last = in->last_update.load(std::memory_order_relaxed);
        if (cycle.now - (last == 0 ? started_ : last) > in->timeout) {
          ++e->stale_inputs;
          in->stale_cycles.fetch_add(1, std::memory_order_relaxed);
        }
      }
      if (&comp == this) {
        unchanged_[ci] = 0;
      } else if (e->heartbeat == last_heartbeat_[ci]) {
        ++unchanged_[ci];
      } else {
        unchanged_[ci] = 0;
      }
      last_heartbeat_[ci] = e->heartbeat;
      if (comp.state() == Lifecycle::kError) {
        e->level = Level::kError;
        e->message = "component in error state";
      } else if (unchanged_[ci] >= static_cast<std::uint64_t>(stall_cycles_) &&
                 e->period < static_cast<TimeNs>(stall_cycles_) * cycle.period) {
        e->level = Level::kStale;
        e->message = "no heartbeat: component stalled";
      } else if (e->stale_inputs > 0) {
        e->level = Level::kWarn;
        e->message = "stale input";
      }
      // This report's execution time of the component on its group's clock (the histogram is
      // cumulative): what makes a group slip (in real time its wall time; under the simulated
      // clock the simulated execution time a member charged, e.g. cpu_load).
      const auto total = static_cast<double>(e->exec.mean) * static_cast<double>(e->exec.count);
      interval_exec_[ci] = e->exec.count > last_exec_count_[ci] ? total - last_exec_total_[ci] : 0.0;
      last_exec_count_[ci] = e->exec.count;
      last_exec_total_[ci] = total;
      entry_of_[ci] = s.count - 1;
    }
  }

  // The culprit of each group that slipped since the last report: the member that took the most
  // time in it (a warning; only a stalled or failed critical component stops the watchdog).
  void blame_slips(HealthSnapshot& s) {
    const auto& v = ctx_->system();
    for (std::size_t gi = 0; gi < v.groups.size(); ++gi) {
      if (!slipped_[gi]) continue;
      std::size_t worst = v.components.size();
      for (std::size_t ci = 0; ci < v.components.size(); ++ci) {
        if (group_of_[ci] != gi) continue;
        if (entry_of_[ci] < s.count && (worst == v.components.size() || interval_exec_[ci] > interval_exec_[worst]))
          worst = ci;
      }
      if (worst == v.components.size()) continue;
      HealthEntry& e = s.entries[entry_of_[worst]];
      if (e.level == Level::kOk) {
        e.level = Level::kWarn;
        e.message = "overruns its rate group's period";
      }
    }
  }

  // Devices: cameras (faults, corrupt and future-stamped frames), encoder sets (rejected, lost,
  // stale wheels), IMUs.
  void report_devices(HealthSnapshot& s, TimeNs now) {
    for (std::size_t k = 0; k < cameras_.size(); ++k) {
      const auto& [name, cam] = cameras_[k];
      HealthEntry* e = add_entry(s);
      if (e == nullptr) break;
      const hal::CameraStats st = cam->stats();
      e->kind = HealthEntry::Kind::kCamera;
      copy_name(e->name, name);
      e->frames = st.frames;
      e->dropped = st.dropped;
      e->errors = st.faults + st.corrupt;
      e->bad_stamps = st.bad_stamps;
      e->message = hal::to_string(st.state).data();
      if (st.state == hal::DeviceState::kFaulted || st.state == hal::DeviceState::kRecovering) {
        e->level = Level::kError;
      } else if (st.bad_stamps > last_bad_stamps_[k]) {
        e->level = Level::kWarn;
        e->message = "frames stamped in the future withheld since last report (device clock)";
      }
      last_bad_stamps_[k] = st.bad_stamps;
    }
    for (std::size_t k = 0; k < encoders_.size(); ++k) {
      const auto& [name, enc] = encoders_[k];
      HealthEntry* e = add_entry(s);
      if (e == nullptr) break;
      const hal::EncoderStats st = enc->stats();
      e->kind = HealthEntry::Kind::kEncoders;
      copy_name(e->name, name);
      e->frames = st.samples;
      e->dropped = st.rejected;
      e->errors = st.faults;
      e->lost = st.lost;
      e->message = hal::to_string(st.state).data();
      for (std::size_t w = 0; w < enc->wheel_count(); ++w) {
        if (enc->stale(w, now, stale_timeout_)) ++e->stale_inputs;
      }
      if (st.state == hal::DeviceState::kFaulted) {
        e->level = Level::kError;
      } else if (e->stale_inputs > 0) {
        e->level = Level::kWarn;
      } else if (st.lost > last_lost_[k]) {
        e->level = Level::kWarn;
        e->message = "frames lost since last report (receive queue overflowed)";
      }
      last_lost_[k] = st.lost;
    }
    for (const auto& [name, imu] : imus_) {
      HealthEntry* e = add_entry(s);
      if (e == nullptr) break;
      const hal::DeviceCounters st = imu->counters();
      e->kind = HealthEntry::Kind::kImu;
      copy_name(e->name, name);
      e->frames = st.delivered;
      e->dropped = st.rejected;
      e->errors = st.faults;
      e->message = hal::to_string(st.state).data();
      if (st.state == hal::DeviceState::kFaulted || st.state == hal::DeviceState::kRecovering) e->level = Level::kError;
    }
  }

  Context* ctx_ = nullptr;
  std::vector<std::pair<std::string, hal::Camera*>> cameras_;
  std::vector<std::pair<std::string, hal::WheelEncoders*>> encoders_;
  std::vector<std::pair<std::string, hal::Imu*>> imus_;
  LatestPool<HealthSnapshot>* out_ = nullptr;
  TimeNs started_ = -1;  // the first report's time: an input never updated is stale a timeout after it
  int stall_cycles_ = 3;
  TimeNs stale_timeout_ = 500 * kNsPerMs;
  std::string hardware_id_;
  std::shared_ptr<dds::Outbox<DiagnosticArray>> diag_;
  std::vector<std::uint64_t> last_heartbeat_;
  std::vector<std::uint64_t> unchanged_;
  std::vector<std::uint64_t> last_slips_;       // per group: slips the group's own cycles caused, at the last report
  std::vector<std::uint64_t> last_late_;        // per group: late-start slips at the last report
  std::vector<std::uint64_t> last_stall_;       // per group: stall slips at the last report
  std::vector<unsigned char> slipped_;          // per group: overran (slipped by its own cycles) since the last report
  std::vector<std::uint64_t> last_exec_count_;  // per component: its exec histogram at the last report
  std::vector<double> last_exec_total_;
  std::vector<double> interval_exec_;           // ... and its execution time since then (ns)
  std::vector<std::uint32_t> entry_of_;         // its entry in this snapshot (kMaxHealthEntries: none)
  std::vector<std::size_t> group_of_;           // its rate group's index (groups.size(): none)
  std::vector<std::uint64_t> last_lost_;        // per encoder set: frames lost at the last report
  std::vector<std::uint64_t> last_bad_stamps_;  // per camera: frames withheld for their stamp at the last report
};

class JointStatePublisher final : public Component {
 public:
  void configure(Params& p, Context& ctx) override {
    enc_ = &ctx.encoders(p, "encoders");
    stale_timeout_ = static_cast<TimeNs>(
        p.get<double>(
            "stale_timeout_s", 0.5,
            {.unit = "s", .min = 0.0, .min_exclusive = true, .doc = "a wheel without samples for this long is stale"}) *
        1e9);
    if (enc_->wheel_count() > kMaxJoints) p.fail("encoders", "more wheels than JointState supports (16)");
    out_ = &ctx.produce<JointStateSample>("joint_states");
    input_ = &watch_input("encoders", stale_timeout_);
    order_ = FrameOrder(stale_timeout_);
    wheel_order_.fill(FrameOrder(stale_timeout_));
    held_stamp_.fill(std::numeric_limits<TimeNs>::min());  // no stamp held yet (0 is a valid one)
    frame_id_ = p.get<std::string>("frame_id", "base_link", {.doc = "header.frame_id of joint_states"});
    const auto& names = enc_->wheel_names();
    const std::string frame = frame_id_;
    js_ = make_outbox<JointState>(ctx, "joint_states", dds::OutboxMode::kFifo, [&names, &frame](JointState& m) {
      dds::reserve(m, dds::JointStateCapacity{static_cast<std::uint32_t>(names.size()), 32, 32});
      dds::copy_string(m.header.frame_id, 32, frame);
      dds::set_length(m.name, names.size());
      for (std::size_t i = 0; i < names.size(); ++i) dds::copy_string(m.name._buffer[i], 32, names[i]);
    });
  }
  void step(const CycleInfo& cycle) override {
    JointStateSample* s = out_->begin_write();
    if (s == nullptr) return;
    s->count = static_cast<std::uint32_t>(enc_->wheel_count());
    TimeNs newest = 0;
    bool any = false;
    std::array<TimeNs, kMaxJoints> used{};  // the stamp of each wheel's sample in this one
    for (std::size_t w = 0; w < s->count; ++w) {
      hal::AngleSample a;
      double vel = 0.0;
      if (!enc_->latest(w, cycle.now, a)) continue;
      // FrameOrder per wheel (the stale timeout as its limit): a newest usable sample older than
      // the one already published (its newer ones were rejected as implausible) leaves the wheel
      // at what was published, and is counted once however many cycles it stays the newest; a
      // step back past the timeout is the clock itself (a time sync), and the wheel goes on from
      // there rather than freeze.
      const bool held =
          !wheel_order_[w].repeats(a.stamp) &&
          (a.stamp == held_stamp_[w] || wheel_order_[w].judge(a.stamp) == FrameOrder::Verdict::kOutOfOrder);
      if (held) {
        held_stamp_[w] = a.stamp;
        a = published_[w];
        vel = published_velocity_[w];
      } else if (!enc_->velocity(w, cycle.now, vel)) {
        vel = 0.0;
      }
      s->position[w] = a.angle;
      s->velocity[w] = vel;
      used[w] = a.stamp;
      newest = std::max(newest, a.stamp);
      any = true;
    }
    if (!any) return;  // nothing to publish yet; the slot is reused next cycle
    s->stamp = newest;
    // The same rule for the stream: a sample is new when its stamp is later than the last one
    // published, or the clock stepped back past the timeout.
    const bool fresh = !order_.repeats(newest) && order_.admit(newest) != FrameOrder::Verdict::kOutOfOrder;
    if (fresh) {
      input_updated(*input_, cycle.now);
      for (std::size_t w = 0; w < s->count; ++w) {
        if (used[w] == 0) continue;
        published_[w] = {used[w], s->position[w]};
        published_velocity_[w] = s->velocity[w];
        wheel_order_[w].take(used[w]);
      }
    }
    out_->commit();
    if (js_ && fresh) {
      if (JointState* m = js_->begin()) {
        dds::set_stamp(m->header.stamp, s->stamp);
        dds::set_length(m->position, s->count);
        dds::set_length(m->velocity, s->count);
        dds::set_length(m->effort, 0);
        for (std::uint32_t w = 0; w < s->count; ++w) {
          m->position._buffer[w] = s->position[w];
          m->velocity._buffer[w] = s->velocity[w];
        }
        js_->commit();
      }
    }
  }
  void diagnostics(std::vector<std::pair<std::string, std::string>>& kv) const override {
    // Wheel samples held at the published one, plus stream samples skipped (FrameOrder's counters
    // may be read from this, the health thread).
    // Clock steps: the stream's, and each wheel's summed (a wheel read from a node of its own can
    // step alone, which the stream does not see while another wheel's stamps are newer).
    long held = order_.out_of_order(), wheel_steps = 0;
    for (std::size_t w = 0; w < enc_->wheel_count() && w < kMaxJoints; ++w) {
      held += wheel_order_[w].out_of_order();
      wheel_steps += wheel_order_[w].clock_steps();
    }
    kv.emplace_back("samples_out_of_order", std::to_string(held));
    kv.emplace_back("clock_steps", std::to_string(order_.clock_steps()));
    kv.emplace_back("wheel_clock_steps", std::to_string(wheel_steps));
  }
  const hal::WheelEncoders& encoders() const { return *enc_; }

 private:
  hal::WheelEncoders* enc_ = nullptr;
  LatestPool<JointStateSample>* out_ = nullptr;
  InputWatch* input_ = nullptr;
  TimeNs stale_timeout_ = 0;
  FrameOrder order_;                                      // the stream's stamps (stale timeout as limit)
  std::array<FrameOrder, kMaxJoints> wheel_order_;        // each wheel's
  std::array<TimeNs, kMaxJoints> held_stamp_{};           // per wheel: the older sample last held (counted once)
  std::array<hal::AngleSample, kMaxJoints> published_{};  // per wheel: the sample last published
  std::array<double, kMaxJoints> published_velocity_{};
  std::string frame_id_;
  std::shared_ptr<dds::Outbox<JointState>> js_;
};

/// imu_publisher: the IMU device's newest sample -> channel "imu" (hal::ImuSample, e.g. for the
/// drive-long map) and DDS topic imu (sensor_msgs/Imu, covariances unknown = 0).
class ImuPublisher final : public Component {
 public:
  void configure(Params& p, Context& ctx) override {
    imu_ = &ctx.device<hal::Imu>(p, "imu");
    const double stale_s = p.get<double>(
        "stale_timeout_s", 0.5,
        {.unit = "s", .min = 0.0, .min_exclusive = true, .doc = "the IMU is stale after this long without a sample"});
    frame_id_ =
        p.get<std::string>("frame_id", "base_link", {.doc = "header.frame_id of imu (the IMU is body-aligned)"});
    if (frame_id_.size() > 32) p.fail("frame_id", "longer than 32 characters");
    input_ = &watch_input("imu", from_seconds(stale_s));
    out_ = &ctx.produce<hal::ImuSample>("imu");
    const std::string frame = frame_id_;
    msg_ = make_outbox<ImuMsg>(ctx, "imu", dds::OutboxMode::kFifo, [frame](ImuMsg& m) {
      dds::reserve(m, 32);
      dds::copy_string(m.header.frame_id, 32, frame);
    });
  }
  void step(const CycleInfo& cycle) override {
    hal::ImuSample s;
    if (!imu_->latest(cycle.now, s) || !new_sample_(s.sequence)) return;
    input_updated(*input_, cycle.now);
    if (hal::ImuSample* o = out_->begin_write()) {
      *o = s;
      out_->commit();
    }
    if (msg_) {
      if (ImuMsg* m = msg_->begin()) {
        dds::set_stamp(m->header.stamp, s.stamp);
        const hal::Quaternion q = hal::to_quaternion(s.attitude);
        m->orientation = {q.x, q.y, q.z, q.w};
        m->angular_velocity = {s.angular_velocity.x, s.angular_velocity.y, s.angular_velocity.z};
        m->linear_acceleration = {s.linear_acceleration.x, s.linear_acceleration.y, s.linear_acceleration.z};
        msg_->commit();
      }
    }
  }
  std::string result() const override {
    const auto l = out_ != nullptr ? out_->acquire() : decltype(out_->acquire()){};
    if (!l) return {};
    constexpr double kDeg = 180.0 / 3.14159265358979323846;
    char buf[96];
    std::snprintf(buf, sizeof buf, "roll %.1f pitch %.1f yaw %.1f deg", l->attitude.roll_rad * kDeg,
                  l->attitude.pitch_rad * kDeg, l->attitude.yaw_rad * kDeg);
    return buf;
  }

 private:
  const hal::Imu* imu_ = nullptr;
  LatestPool<hal::ImuSample>* out_ = nullptr;
  InputWatch* input_ = nullptr;
  NewValue new_sample_;
  std::string frame_id_;
  std::shared_ptr<dds::Outbox<ImuMsg>> msg_;
};

/// Load for fault drills (tests/storm, tests/soak, a bench's watchdog check): spends `busy_ms` in
/// every `every`-th cycle (more than the group's period: a component that overruns) and, with
/// `stall_after_s`, once stops returning from step for `stall_s` (a component that is really
/// stuck). On the real clock both are real: thread CPU time spun, CLOCK_MONOTONIC slept (the one
/// component allowed to block in step: that is its purpose). On the simulated clock they are
/// simulated execution time: the step advances the clock by that much, so the cycle ends late
/// exactly as a slow member would, without spending it (the lockstep executor runs every group on
/// one thread: the other groups start late by as much, and slip only if that pushes them past
/// their own period).
class CpuLoad final : public Component {
 public:
  void configure(Params& p, Context& ctx) override {
    busy_ = static_cast<TimeNs>(std::llround(
        p.get<double>("busy_ms", 1.0, {.unit = "ms", .min = 0.0, .max = 10000.0, .doc = "time spent in a busy cycle"}) *
        1e6));
    every_ = p.get<std::int64_t>("every", 1,
                                 {.unit = "cycles",
                                  .min = 1,
                                  .max = std::int64_t{1} << 40,
                                  .doc = "busy in every N-th cycle (the first, then every N)"});
    stall_after_ = static_cast<TimeNs>(
        std::llround(p.get<double>("stall_after_s", 0.0,
                                   {.unit = "s",
                                    .min = 0.0,
                                    .max = 86400.0,
                                    .doc = "time after the first step at which it stalls once (0 = never)"}) *
                     1e9));
    stall_ = static_cast<TimeNs>(std::llround(
        p.get<double>("stall_s", 5.0, {.unit = "s", .min = 0.0, .max = 3600.0, .doc = "how long the stall lasts"}) *
        1e9));
    sim_ = dynamic_cast<SimClock*>(&ctx.clock());
  }
  void step(const CycleInfo&) override {
    const TimeNs now = sim_ != nullptr ? sim_->now() : monotonic_now();
    if (first_ == 0) first_ = now;
    if (stall_after_ > 0 && !stalled_ && now - first_ >= stall_after_) {
      stalled_ = true;
      set_status("stalled (drill)");
      if (sim_ != nullptr) {
        sim_->advance(stall_);
      } else {
        while (monotonic_now() < now + stall_) std::this_thread::sleep_for(std::chrono::milliseconds(1));
      }
      set_status("ok");
    }
    const bool busy = cycle_++ % every_ == 0;
    if (!busy || busy_ == 0) return;
    busy_cycles_.fetch_add(1, std::memory_order_relaxed);
    if (sim_ != nullptr) {
      sim_->advance(busy_);
      return;
    }
    const TimeNs c0 = thread_cpu_now();
    while (thread_cpu_now() - c0 < busy_) {
    }
  }
  void diagnostics(std::vector<std::pair<std::string, std::string>>& kv) const override {
    kv.emplace_back("busy_cycles", std::to_string(busy_cycles_.load(std::memory_order_relaxed)));
  }
  std::string result() const override { return stalled_ ? "stalled once" : std::string(); }

 private:
  TimeNs busy_ = 0, stall_after_ = 0, stall_ = 0, first_ = 0;
  std::int64_t every_ = 1, cycle_ = 0;
  SimClock* sim_ = nullptr;
  std::atomic<std::uint64_t> busy_cycles_{0};
  std::atomic<bool> stalled_{false};
};

}  // namespace

void register_builtin_components() {
  auto& r = ComponentRegistry::instance();
  r.add("health", "per-component heartbeat, execution statistics, slips, stale inputs -> /diagnostics",
        [] { return std::make_unique<HealthComponent>(); });
  r.add("imu_publisher", "IMU attitude, rates and specific force -> channel imu + imu (sensor_msgs/Imu)",
        [] { return std::make_unique<ImuPublisher>(); });
  r.add("cpu_load",
        "fault drills: busy_ms in every N-th cycle (overruns), stalls once for stall_s after stall_after_s (simulated "
        "time under --sim-time)",
        [] { return std::make_unique<CpuLoad>(); });
  r.add("joint_state_publisher", "wheel encoder angles and velocities -> joint_states (sensor_msgs/JointState)",
        [] { return std::make_unique<JointStatePublisher>(); });
}

}  // namespace regolith::runtime
