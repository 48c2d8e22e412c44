#pragma once
// The component model. A component is configured once (allocate, validate: throws ConfigError),
// activated, stepped by its rate group every cycle, and deactivated. `step` must not allocate,
// lock, log-format or block. Components are created by type name from the deployment YAML.
#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "regolith/core/params.hpp"
#include "regolith/core/time.hpp"
#include "regolith/runtime/stats.hpp"

namespace regolith::runtime {

class Context;
class WorkerPool;  // worker_pool.hpp

/// What a rate group tells each member every cycle.
struct CycleInfo {
  TimeNs release = 0;  ///< scheduled start of this cycle (absolute, process clock)
  TimeNs now = 0;      ///< clock reading when the member starts
  TimeNs period = 0;
  std::uint64_t cycle = 0;
};

enum class Lifecycle : std::uint8_t { kUnconfigured, kInactive, kActive, kFinalized, kError };
const char* to_string(Lifecycle s);

/// Health level, as diagnostic_msgs/DiagnosticStatus: OK=0, WARN=1, ERROR=2, STALE=3.
enum class Level : std::uint8_t { kOk = 0, kWarn = 1, kError = 2, kStale = 3 };

/// A named input whose freshness the health monitor watches.
struct InputWatch {
  std::string name;
  TimeNs timeout = 0;
  std::atomic<TimeNs> last_update{0};
  std::atomic<std::uint64_t> updates{0};
  std::atomic<std::uint64_t> stale_cycles{0};
};

class Component {
 public:
  virtual ~Component() = default;

  /// Read parameters (declare every one; `params.finish()` is called by the runtime afterwards),
  /// look up devices and channels, allocate every buffer. Throw ConfigError on bad input.
  virtual void configure(Params& params, Context& ctx) = 0;
  virtual void activate() {}
  virtual void step(const CycleInfo& cycle) = 0;
  virtual void deactivate() {}
  /// Extra key/values for diagnostics (called from the health thread, not real time).
  virtual void diagnostics(std::vector<std::pair<std::string, std::string>>& /*kv*/) const {}
  /// A critical component's health gates the systemd watchdog: the deployment's `critical: true`
  /// on the component (any type), or the type's own choice (the health monitor always is).
  virtual bool critical() const { return configured_critical_; }
  /// The latest output in one line for the live summary ("sinkage 19.8 mm (conf 0.93)"), empty
  /// before the first. Called off the real-time threads (may allocate); a component reads its own
  /// output through a channel lease, so this never races with step().
  virtual std::string result() const { return {}; }

  // ---- filled in by the runtime ----
  const std::string& name() const { return name_; }
  const std::string& type() const { return type_; }
  Lifecycle state() const { return state_.load(); }
  std::uint64_t heartbeat() const { return heartbeat_.load(std::memory_order_relaxed); }
  const ExecHistogram& exec() const { return exec_; }
  const ExecHistogram& wall() const { return wall_; }
  /// CPU time of step() on its thread (CLOCK_THREAD_CPUTIME_ID) plus what its worker pool's
  /// threads spent in that step (use_workers): what the component cost, without preemption or
  /// sleeps; exec() / wall() are elapsed times.
  const ExecHistogram& cpu() const { return cpu_; }
  /// CPU time of the component's worker threads so far (0 without a pool), ns.
  TimeNs worker_cpu_ns() const;
  const std::vector<std::unique_ptr<InputWatch>>& inputs() const { return inputs_; }
  /// Errors counted by the component (bad frames, failed devices...), published in diagnostics.
  std::uint64_t errors() const { return errors_.load(std::memory_order_relaxed); }
  /// Latest human-readable status message (set outside step, or a static string inside step).
  const char* status_message() const { return status_.load(std::memory_order_relaxed); }

 protected:
  /// Declare a watched input (in configure). Returns the watch to call `input_updated` on.
  InputWatch& watch_input(const std::string& name, TimeNs timeout);
  /// Mark an input as fresh with the stamp of the data received (real-time safe).
  static void input_updated(InputWatch& w, TimeNs stamp) {
    w.last_update.store(stamp, std::memory_order_relaxed);
    w.updates.fetch_add(1, std::memory_order_relaxed);
  }
  void count_error() { errors_.fetch_add(1, std::memory_order_relaxed); }
  /// In configure: the pool this component runs data-parallel work on (it owns it); its workers'
  /// CPU time is added to cpu().
  void use_workers(const WorkerPool* pool) { workers_ = pool; }
  /// `msg` must be a string literal or otherwise outlive the component (no formatting in step).
  void set_status(const char* msg) { status_.store(msg, std::memory_order_relaxed); }

 private:
  friend class RateGroup;
  friend class Application;
  std::string name_;
  std::string type_;
  std::atomic<Lifecycle> state_{Lifecycle::kUnconfigured};
  std::atomic<std::uint64_t> heartbeat_{0};
  std::atomic<std::uint64_t> errors_{0};
  std::atomic<const char*> status_{"ok"};
  bool configured_critical_ = false;
  const WorkerPool* workers_ = nullptr;
  ExecHistogram exec_;
  ExecHistogram wall_;
  ExecHistogram cpu_;
  std::vector<std::unique_ptr<InputWatch>> inputs_;
};

/// Component types by name, for YAML (`type: sfs`).
class ComponentRegistry {
 public:
  using Factory = std::function<std::unique_ptr<Component>()>;
  static ComponentRegistry& instance();
  void add(const std::string& type, const std::string& doc, Factory f);
  /// Throws ConfigError located at `params`'s `type` key, with did-you-mean, for unknown types.
  std::unique_ptr<Component> make(Params& params, const std::string& type) const;
  std::vector<std::pair<std::string, std::string>> types() const;

 private:
  struct Entry {
    std::string doc;
    Factory make;
  };
  std::map<std::string, Entry> entries_;
};

}  // namespace regolith::runtime
