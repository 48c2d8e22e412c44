#pragma once
// QoS presets (architecture.md, frameworks.md section 5.3).
//  * state       : maps, soil: RELIABLE, KEEP_LAST 1, TRANSIENT_LOCAL
//  ("latched"), optional offered
//                  deadline (a late writer raises a local
//                  offered-deadline-missed event).
//  * stream      : joint_states, sinkage: RELIABLE, KEEP_LAST depth, VOLATILE.
//  * diagnostics : RELIABLE, KEEP_LAST 10, VOLATILE (the ROS default profile).
// Readers never request a finite deadline (ROS writers offer an infinite one,
// and a finite request would make them incompatible); a BEST_EFFORT reader
// matches every writer.
#include <cstdint>
#include <string>

#include <dds/dds.h>

#include "regolith/core/time.hpp"

namespace regolith::dds {

enum class Reliability { kBestEffort, kReliable };
enum class Durability { kVolatile, kTransientLocal };

struct QosProfile {
  Reliability reliability = Reliability::kReliable;
  Durability durability = Durability::kVolatile;
  int depth = 10;                           ///< KEEP_LAST depth [samples], >= 1
  TimeNs deadline_ns = 0;                   ///< offered deadline [ns] on writers; 0 = infinite
  TimeNs max_blocking_ns = 100 * kNsPerMs;  ///< reliable writer's max blocking time [ns]
  /// KEEP_ALL history instead of KEEP_LAST(depth): a reliable writer then delivers every sample,
  /// blocking the (non real-time) publisher thread under back-pressure. Used under simulated time.
  bool keep_all = false;

  /// Latched state: reliable, keep-last 1, transient-local, offered deadline (0
  /// = none).
  static QosProfile state(TimeNs offered_deadline_ns = 0);
  /// Stream: reliable, keep-last `depth`, volatile.
  static QosProfile stream(int depth = 10);
  /// /diagnostics: reliable, keep-last 10, volatile.
  static QosProfile diagnostics();
  /// Reader profile: never a deadline.
  static QosProfile reader(Reliability r, Durability d, int depth = 10);

  /// Throws std::invalid_argument naming the field (depth < 1, negative times).
  void validate() const;
  std::string describe() const;  ///< e.g. "reliable keep_last(1) transient_local deadline 500 ms"
};

/// Owning dds_qos_t built from a profile. Reader QoS never carries a deadline.
class Qos {
 public:
  enum class For { kWriter, kReader };
  Qos(const QosProfile& p, For role);
  ~Qos();
  Qos(const Qos&) = delete;
  Qos& operator=(const Qos&) = delete;
  const dds_qos_t* get() const { return qos_; }

 private:
  dds_qos_t* qos_ = nullptr;
};

}  // namespace regolith::dds
