// systemd notification and watchdog gating (see watchdog.hpp).
#include "regolith/runtime/watchdog.hpp"

#include <algorithm>
#include <cstddef>
#include <cstdlib>
#include <cstring>

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <spdlog/spdlog.h>

#include "regolith/runtime/application.hpp"

#ifdef REGOLITH_HAVE_SYSTEMD
#include <systemd/sd-daemon.h>
#endif

namespace regolith::runtime {
namespace {

#ifndef REGOLITH_HAVE_SYSTEMD
// The sd_notify datagram protocol without libsystemd: one AF_UNIX datagram to
// $NOTIFY_SOCKET (a leading '@' names an abstract socket).
bool notify_datagram(const std::string& socket_path, const std::string& state) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (socket_path.size() >= sizeof(addr.sun_path)) return false;
  std::memcpy(addr.sun_path, socket_path.data(), socket_path.size());
  if (addr.sun_path[0] == '@') addr.sun_path[0] = '\0';
  const int fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return false;
  const auto len = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + socket_path.size());
  const ssize_t n = ::sendto(fd, state.data(), state.size(), MSG_NOSIGNAL, reinterpret_cast<sockaddr*>(&addr), len);
  ::close(fd);
  return n == static_cast<ssize_t>(state.size());
}
#endif

/// Period of the rate group running the deployment's `health` component; 0 when
/// there is none.
TimeNs health_period(const SystemView& view) {
  for (const Component* c : view.components) {
    if (c->type() != "health") continue;
    for (const RateGroup* g : view.groups) {
      const auto& m = g->members();
      if (std::find(m.begin(), m.end(), c) != m.end()) return g->config().period;
    }
  }
  return 0;
}

std::string seconds_text(TimeNs t) {
  return fmt::format("{:.1f} s", to_seconds(t));
}

}  // namespace

SystemdNotifier::SystemdNotifier() {
  const char* socket_env = std::getenv("NOTIFY_SOCKET");
  if (socket_env == nullptr || *socket_env == '\0') return;
#ifdef REGOLITH_HAVE_SYSTEMD
  notify_ = [](const std::string& state) { return sd_notify(0, state.c_str()) > 0; };
  std::uint64_t usec = 0;
  if (sd_watchdog_enabled(0, &usec) > 0) watchdog_interval_ = static_cast<TimeNs>(usec) * kNsPerUs;
#else
  const std::string path = socket_env;
  notify_ = [path](const std::string& state) { return notify_datagram(path, state); };
  const char* usec_env = std::getenv("WATCHDOG_USEC");
  const char* pid_env = std::getenv("WATCHDOG_PID");
  const bool for_us = pid_env == nullptr || std::strtol(pid_env, nullptr, 10) == static_cast<long>(::getpid());
  if (usec_env != nullptr && for_us) watchdog_interval_ = std::strtoll(usec_env, nullptr, 10) * kNsPerUs;
#endif
}

SystemdNotifier::SystemdNotifier(NotifyFn notify, TimeNs watchdog_interval)
    : notify_(std::move(notify)), watchdog_interval_(std::max<TimeNs>(0, watchdog_interval)) {}

bool SystemdNotifier::send(const std::string& state) {
  return notify_ && notify_(state);
}

void SystemdNotifier::ready() {
  if (ready_sent_ || !active()) return;
  ready_sent_ = true;
  send("READY=1");
}

void SystemdNotifier::status(const std::string& text) {
  if (!active() || text == last_status_) return;
  last_status_ = text;
  send("STATUS=" + text);
}

void SystemdNotifier::stopping() {
  if (!active()) return;
  send("STOPPING=1\nSTATUS=stopping");
  last_status_ = "stopping";
}

bool SystemdNotifier::tick(const HealthSnapshot* latest) {
  if (!active() || watchdog_interval_ <= 0 || latest == nullptr) return false;
  if (latest->stamp <= last_fed_stamp_) return false;  // nothing new since the last feed
  if (!latest->all_critical_ok) {
    if (latest->stamp != last_withheld_stamp_) {
      last_withheld_stamp_ = latest->stamp;
      ++withheld_;
    }
    return false;
  }
  last_fed_stamp_ = latest->stamp;
  ++feeds_;
  send("WATCHDOG=1");
  return true;
}

std::string SystemdNotifier::describe(const HealthSnapshot& s) {
  if (s.all_critical_ok) return {};
  std::string out;
  const std::uint32_t n = std::min<std::uint32_t>(s.count, static_cast<std::uint32_t>(kMaxHealthEntries));
  for (std::uint32_t i = 0; i < n; ++i) {
    const HealthEntry& e = s.entries[i];
    if (!gates_watchdog(e)) continue;
    if (!out.empty()) out += "; ";
    out += fmt::format("component '{}': {}", e.name.data(), e.message != nullptr ? e.message : "unhealthy");
  }
  return out.empty() ? std::string("a critical component is unhealthy") : out;
}

bool SystemdNotifier::all_groups_running(const SystemView& view) {
  if (view.groups.empty()) return false;
  return std::all_of(view.groups.begin(), view.groups.end(),
                     [](const RateGroup* g) { return g->counters().cycles > 0; });
}

void SystemdNotifier::update(const SystemView& view, const HealthSnapshot* latest, TimeNs now, TimeNs max_silence) {
  if (!active()) return;
  if (first_update_at_ < 0) first_update_at_ = now;
  const TimeNs hp = health_period(view);
  if (!interval_checked_) {
    interval_checked_ = true;
    if (watchdog_interval_ > 0 && hp == 0) {
      spdlog::warn(
          "systemd watchdog is enabled (WatchdogSec={}) but the "
          "deployment has no 'health' component: "
          "the watchdog will never be fed",
          seconds_text(watchdog_interval_));
    } else if (watchdog_interval_ > 0 && watchdog_interval_ < 2 * hp) {
      spdlog::warn(
          "systemd WatchdogSec={} is shorter than two periods of the "
          "health rate group ({} each): "
          "raise WatchdogSec or the health rate",
          seconds_text(watchdog_interval_), seconds_text(hp));
    }
  }
  if (max_silence <= 0) max_silence = 3 * (hp > 0 ? hp : kNsPerSec);

  if (!ready_sent_ && all_groups_running(view)) {
    ready();
    status(fmt::format("running: {} rate groups, {} components", view.groups.size(), view.components.size()));
  }

  if (latest != nullptr && latest->stamp != last_seen_stamp_) {
    last_seen_stamp_ = latest->stamp;
    last_seen_at_ = now;
  }
  tick(latest);

  // Verdict for STATUS and the log: only transitions are reported.
  std::string why;
  if (latest == nullptr) {
    if (now - first_update_at_ > max_silence)
      why = "no health snapshot published (is a 'health' component configured?)";
  } else if (!latest->all_critical_ok) {
    why = describe(*latest);
  } else if (now - last_seen_at_ > max_silence) {
    why = "health monitor silent for " + seconds_text(now - last_seen_at_) + " (health rate group stalled)";
  }
  const bool healthy = why.empty();
  if (!healthy) {
    const std::string text = "watchdog withheld: " + why;
    // The silence duration grows every tick: log and publish it once per cause,
    // not per tick.
    const bool same_cause = !healthy_ && last_status_.rfind("watchdog withheld: health monitor silent", 0) == 0 &&
                            why.rfind("health monitor silent", 0) == 0;
    if (healthy_ || (!same_cause && text != last_status_)) {
      spdlog::error("{}", text);
      status(text);
    }
  } else if (!healthy_ && ready_sent_) {
    spdlog::info("watchdog: every critical component healthy again");
    status(fmt::format("running: {} rate groups, {} components", view.groups.size(), view.components.size()));
  }
  healthy_ = healthy;
}

}  // namespace regolith::runtime
