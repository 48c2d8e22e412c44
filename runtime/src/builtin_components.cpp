// Components built into the runtime: `health` (diagnostics, stale inputs, watchdog gate) and
// `joint_state_publisher` (wheel encoder angles -> sensor_msgs/JointState).
#include <algorithm>
#include <cstring>

#include "regolith/hal/wheel_encoders.hpp"
#include "regolith/runtime/application.hpp"
#include "regolith/runtime/health.hpp"
#include "regolith/runtime/joint_state.hpp"

namespace regolith::runtime {
namespace {

void copy_name(std::array<char, kNameLen>& dst, const std::string& src) {
  const std::size_t n = std::min(src.size(), dst.size() - 1);
  std::memcpy(dst.data(), src.data(), n);
  dst[n] = '\0';
}

class HealthComponent final : public Component {
 public:
  void configure(Params& p, Context& ctx) override {
    ctx_ = &ctx;
    stall_cycles_ = p.get<int>("stall_cycles", 3, {.min = 1, .max = 1000,
        .doc = "health cycles without a heartbeat before a component is reported stale"});
    out_ = &ctx.channel<HealthSnapshot>("health/snapshot");
  }

  void activate() override {
    // The system view is complete now; size the bookkeeping once.
    const auto& v = ctx_->system();
    last_heartbeat_.assign(v.components.size(), 0);
    unchanged_.assign(v.components.size(), 0);
    last_slips_.assign(v.groups.size(), 0);
  }

  void step(const CycleInfo& cycle) override {
    const auto& v = ctx_->system();
    HealthSnapshot* s = out_->begin_write();
    if (s == nullptr) return;
    s->stamp = cycle.now;
    s->count = 0;
    s->all_critical_ok = true;
    auto add = [&]() -> HealthEntry* {
      if (s->count >= kMaxHealthEntries) return nullptr;
      HealthEntry& e = s->entries[s->count++];
      e = HealthEntry{};
      return &e;
    };

    for (std::size_t gi = 0; gi < v.groups.size(); ++gi) {
      const RateGroup& g = *v.groups[gi];
      HealthEntry* e = add();
      if (e == nullptr) break;
      const auto c = g.counters();
      e->kind = HealthEntry::Kind::kRateGroup;
      copy_name(e->name, g.config().name);
      e->cycles = c.cycles;
      e->slips = c.slips;
      e->period = g.config().period;
      e->exec = g.cycle_exec().summary();
      e->wall = g.wakeup_latency().summary();
      if (c.slips > last_slips_[gi]) {
        e->level = Level::kWarn;
        e->message = "cycle slips since last report";
      }
      last_slips_[gi] = c.slips;
    }

    for (std::size_t ci = 0; ci < v.components.size(); ++ci) {
      const Component& comp = *v.components[ci];
      HealthEntry* e = add();
      if (e == nullptr) break;
      e->kind = HealthEntry::Kind::kComponent;
      copy_name(e->name, comp.name());
      for (const RateGroup* g : v.groups) {
        if (std::find(g->members().begin(), g->members().end(), &comp) != g->members().end()) {
          copy_name(e->group, g->config().name);
          e->slips = g->counters().slips;
          e->period = g->config().period;
        }
      }
      e->heartbeat = comp.heartbeat();
      e->errors = comp.errors();
      e->exec = comp.exec().summary();
      e->wall = comp.wall().summary();
      e->critical = comp.critical();
      e->message = comp.status_message();
      for (const auto& in : comp.inputs()) {
        const TimeNs last = in->last_update.load(std::memory_order_relaxed);
        if (last == 0 || cycle.now - last > in->timeout) {
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
      if (e->critical && e->level != Level::kOk) s->all_critical_ok = false;
    }

    for (const auto& [name, cam] : ctx_->cameras()) {
      HealthEntry* e = add();
      if (e == nullptr) break;
      const hal::CameraStats st = cam->stats();
      e->kind = HealthEntry::Kind::kCamera;
      copy_name(e->name, name);
      e->frames = st.frames;
      e->dropped = st.dropped;
      e->errors = st.faults + st.corrupt;
      e->message = hal::to_string(st.state).data();
      if (st.state == hal::DeviceState::kFaulted || st.state == hal::DeviceState::kRecovering) e->level = Level::kError;
    }
    for (const auto& [name, enc] : ctx_->encoders()) {
      HealthEntry* e = add();
      if (e == nullptr) break;
      const hal::EncoderStats st = enc->stats();
      e->kind = HealthEntry::Kind::kEncoders;
      copy_name(e->name, name);
      e->frames = st.samples;
      e->dropped = st.rejected;
      e->errors = st.faults;
      e->message = hal::to_string(st.state).data();
      for (std::size_t w = 0; w < enc->wheel_count(); ++w) {
        if (enc->stale(w, cycle.now, stale_timeout_)) ++e->stale_inputs;
      }
      if (st.state == hal::DeviceState::kFaulted) e->level = Level::kError;
      else if (e->stale_inputs > 0) e->level = Level::kWarn;
    }
    out_->commit();
  }

  bool critical() const override { return true; }

 private:
  Context* ctx_ = nullptr;
  LatestPool<HealthSnapshot>* out_ = nullptr;
  int stall_cycles_ = 3;
  TimeNs stale_timeout_ = 500 * kNsPerMs;
  std::vector<std::uint64_t> last_heartbeat_;
  std::vector<std::uint64_t> unchanged_;
  std::vector<std::uint64_t> last_slips_;
};

class JointStatePublisher final : public Component {
 public:
  void configure(Params& p, Context& ctx) override {
    enc_ = &ctx.encoders(p, "encoders");
    stale_timeout_ = static_cast<TimeNs>(
        p.get<double>("stale_timeout_s", 0.5, {.unit = "s", .min = 0.0, .min_exclusive = true,
                                               .doc = "a wheel without samples for this long is stale"}) * 1e9);
    if (enc_->wheel_count() > kMaxJoints) p.fail("encoders", "more wheels than JointState supports (16)");
    out_ = &ctx.channel<JointStateSample>("joint_states");
    input_ = &watch_input("encoders", stale_timeout_);
  }
  void step(const CycleInfo& cycle) override {
    JointStateSample* s = out_->begin_write();
    if (s == nullptr) return;
    s->count = static_cast<std::uint32_t>(enc_->wheel_count());
    TimeNs newest = 0;
    bool any = false;
    for (std::size_t w = 0; w < s->count; ++w) {
      hal::AngleSample a;
      double vel = 0.0;
      if (enc_->latest(w, cycle.now, a)) {
        s->position[w] = a.angle;
        s->velocity[w] = enc_->velocity(w, cycle.now, vel) ? vel : 0.0;
        newest = std::max(newest, a.stamp);
        any = true;
      }
    }
    if (!any) return;  // nothing to publish yet; the slot is reused next cycle
    s->stamp = newest;
    if (newest != last_stamp_) input_updated(*input_, cycle.now);
    last_stamp_ = newest;
    out_->commit();
  }
  const hal::WheelEncoders& encoders() const { return *enc_; }

 private:
  hal::WheelEncoders* enc_ = nullptr;
  LatestPool<JointStateSample>* out_ = nullptr;
  InputWatch* input_ = nullptr;
  TimeNs stale_timeout_ = 0;
  TimeNs last_stamp_ = 0;
};

}  // namespace

void register_builtin_components() {
  auto& r = ComponentRegistry::instance();
  r.add("health", "per-component heartbeat, execution statistics, slips, stale inputs -> /diagnostics",
        [] { return std::make_unique<HealthComponent>(); });
  r.add("joint_state_publisher", "wheel encoder angles and velocities -> joint_states (sensor_msgs/JointState)",
        [] { return std::make_unique<JointStatePublisher>(); });
}

}  // namespace regolith::runtime
