#include "regolith/runtime/stats.hpp"

#include <bit>

namespace regolith::runtime {

int ExecHistogram::bucket_of(TimeNs ns) {
  if (ns < 1) return 0;
  const auto u = static_cast<std::uint64_t>(ns);
  const int msb = 63 - std::countl_zero(u);
  if (msb < kSubBits) return static_cast<int>(u);  // exact for tiny values
  const int sub = static_cast<int>((u >> (msb - kSubBits)) & ((1U << kSubBits) - 1));
  return ((msb - kSubBits + 1) << kSubBits) + sub;
}

TimeNs ExecHistogram::bucket_upper(int b) {
  if (b < (1 << kSubBits)) return b;
  const int msb = (b >> kSubBits) + kSubBits - 1;
  const int sub = b & ((1 << kSubBits) - 1);
  const std::uint64_t base = (std::uint64_t{1} << msb) | (static_cast<std::uint64_t>(sub) << (msb - kSubBits));
  return static_cast<TimeNs>(base + (std::uint64_t{1} << (msb - kSubBits)) - 1);
}

void ExecHistogram::record(TimeNs ns) {
  if (ns < 0) ns = 0;
  buckets_[static_cast<std::size_t>(bucket_of(ns))].fetch_add(1, std::memory_order_relaxed);
  count_.fetch_add(1, std::memory_order_relaxed);
  sum_.fetch_add(ns, std::memory_order_relaxed);
  // Single writer: plain load/store pairs are enough.
  if (ns < min_.load(std::memory_order_relaxed)) min_.store(ns, std::memory_order_relaxed);
  if (ns > max_.load(std::memory_order_relaxed)) max_.store(ns, std::memory_order_relaxed);
}

StatsSummary ExecHistogram::summary() const {
  StatsSummary s;
  s.count = count_.load(std::memory_order_relaxed);
  if (s.count == 0) return s;
  s.min = min_.load(std::memory_order_relaxed);
  s.max = max_.load(std::memory_order_relaxed);
  s.mean = sum_.load(std::memory_order_relaxed) / static_cast<TimeNs>(s.count);
  std::uint64_t total = 0;
  for (const auto& b : buckets_) total += b.load(std::memory_order_relaxed);
  const std::uint64_t r50 = (total * 50 + 99) / 100;
  const std::uint64_t r99 = (total * 99 + 99) / 100;
  std::uint64_t acc = 0;
  bool got50 = false;
  for (int i = 0; i < kBuckets; ++i) {
    acc += buckets_[static_cast<std::size_t>(i)].load(std::memory_order_relaxed);
    if (!got50 && acc >= r50 && acc > 0) {
      s.p50 = std::min(bucket_upper(i), s.max);
      got50 = true;
    }
    if (acc >= r99 && acc > 0) {
      s.p99 = std::min(bucket_upper(i), s.max);
      break;
    }
  }
  s.p50 = std::max(s.p50, s.min);
  s.p99 = std::max(s.p99, s.min);
  return s;
}

void ExecHistogram::reset() {
  for (auto& b : buckets_) b.store(0, std::memory_order_relaxed);
  count_.store(0);
  sum_.store(0);
  min_.store(INT64_MAX);
  max_.store(0);
}

}  // namespace regolith::runtime
