#pragma once
// systemd integration for `regolith run` under a Type=notify service with
// WatchdogSec:
//   READY=1     once every rate group has completed at least one cycle;
//   WATCHDOG=1  once per *new* health snapshot (its stamp advanced past the
//   last one fed) whose
//               all_critical_ok is true: a critical component that stalls or
//               fails, or a health monitor that stops publishing, stops the
//               feeding and systemd restarts the service;
//   STATUS=...  one line naming why the watchdog is withheld (shown by
//   `systemctl status`); STOPPING=1  on shutdown.
// The decisions are plain logic over HealthSnapshot and the deployment's
// SystemView; the transport is an injectable function, so the logic is tested
// without systemd, under the simulated clock. Everything here runs on the
// non-real-time thread that drives the application (not in a cycle).
#include <cstdint>
#include <functional>
#include <string>

#include "regolith/core/time.hpp"
#include "regolith/runtime/health.hpp"

namespace regolith::runtime {

struct SystemView;

class SystemdNotifier {
 public:
  /// Sends one notification (newline-separated "KEY=value" assignments, as
  /// sd_notify); returns false when it could not be delivered.
  using NotifyFn = std::function<bool(const std::string& state)>;

  /// The real notifier: active when the process was started by systemd with
  /// $NOTIFY_SOCKET (sd_notify from libsystemd when built with it, else the
  /// same datagram protocol directly); the watchdog interval comes from
  /// $WATCHDOG_USEC / $WATCHDOG_PID (sd_watchdog_enabled). Outside systemd
  /// every call is a cheap no-op.
  SystemdNotifier();
  /// Injected transport (tests, other supervisors). `watchdog_interval` as
  /// WatchdogSec (ns; 0 = no watchdog: WATCHDOG=1 is never sent).
  SystemdNotifier(NotifyFn notify, TimeNs watchdog_interval);

  bool active() const { return static_cast<bool>(notify_); }
  TimeNs watchdog_interval() const { return watchdog_interval_; }

  /// READY=1 (sent once; later calls do nothing).
  void ready();
  /// STATUS=<text> (sent only when the text changed since the last STATUS).
  void status(const std::string& text);
  /// WATCHDOG=1 when `latest` is fresh and healthy: its stamp is newer than the
  /// stamp of the last snapshot fed, and all_critical_ok. `latest == nullptr`
  /// (no snapshot yet) never feeds. Returns true when WATCHDOG=1 was sent.
  bool tick(const HealthSnapshot* latest);
  bool tick(const HealthSnapshot& latest) { return tick(&latest); }
  /// STOPPING=1.
  void stopping();

  /// The whole per-iteration job of the run loop: READY=1 once every group of
  /// `view` has cycled, then tick(latest), and STATUS / one log line whenever
  /// the verdict changes (healthy -> "watchdog withheld: component 'x': no
  /// heartbeat: component stalled", health monitor silent for more than
  /// `max_silence`, or back to healthy). `now` is the executor clock (simulated
  /// under --sim-time). `max_silence` <= 0 means three periods of the health
  /// component's group.
  void update(const SystemView& view, const HealthSnapshot* latest, TimeNs now, TimeNs max_silence = 0);

  // ---- counters (diagnostics and tests) ----
  std::uint64_t feeds() const { return feeds_; }
  std::uint64_t withheld() const { return withheld_; }  ///< fresh snapshots not fed (unhealthy)
  bool is_ready() const { return ready_sent_; }
  bool healthy() const { return healthy_; }  ///< verdict of the last update()
  const std::string& last_status() const { return last_status_; }
  TimeNs last_fed_stamp() const { return last_fed_stamp_; }

  /// Why a snapshot is unhealthy, e.g. "component 'sinkage': no heartbeat:
  /// component stalled"; empty when all_critical_ok.
  static std::string describe(const HealthSnapshot& s);
  /// True once every rate group in `view` has completed at least one cycle.
  static bool all_groups_running(const SystemView& view);

 private:
  bool send(const std::string& state);

  NotifyFn notify_;
  TimeNs watchdog_interval_ = 0;
  bool ready_sent_ = false;
  bool healthy_ = true;
  bool interval_checked_ = false;
  TimeNs last_fed_stamp_ = 0;
  TimeNs last_withheld_stamp_ = 0;
  TimeNs first_update_at_ = -1;  // executor time of the first update()
  TimeNs last_seen_stamp_ = 0;
  TimeNs last_seen_at_ = 0;  // executor time when last_seen_stamp_ first appeared
  std::uint64_t feeds_ = 0;
  std::uint64_t withheld_ = 0;
  std::string last_status_;
};

}  // namespace regolith::runtime
