#pragma once
// Execution-time statistics from a fixed-size log-linear histogram: written by one rate-group
// thread without allocation or locks, read by any thread (relaxed atomics).
#include <array>
#include <atomic>
#include <cstdint>

#include "regolith/core/time.hpp"

namespace regolith::runtime {

struct StatsSummary {
  std::uint64_t count = 0;
  TimeNs min = 0;
  TimeNs mean = 0;
  TimeNs max = 0;
  TimeNs p50 = 0;
  TimeNs p99 = 0;
};

class ExecHistogram {
 public:
  /// 8 sub-buckets per power of two: relative resolution 12.5 %, range 1 ns .. 2^63 ns.
  static constexpr int kSubBits = 3;
  static constexpr int kBuckets = 64 << kSubBits;

  void record(TimeNs ns);
  StatsSummary summary() const;
  void reset();

  static int bucket_of(TimeNs ns);
  static TimeNs bucket_upper(int b);  ///< largest value that falls in bucket b

 private:
  std::array<std::atomic<std::uint32_t>, kBuckets> buckets_{};
  std::atomic<std::uint64_t> count_{0};
  std::atomic<std::int64_t> sum_{0};
  std::atomic<std::int64_t> min_{INT64_MAX};
  std::atomic<std::int64_t> max_{0};
};

}  // namespace regolith::runtime
