#pragma once
// One way for a decorator to serve `samples_since` through a filter: the wrapped device's samples
// after `after` are read in batches, oldest first, and those `keep` accepts (it may change them,
// e.g. a fault injector damaging them) go to `out`. Used by the plausibility checks (hal) and the
// fault-injection decorators (mocks). No allocation: the batch lives on the stack.
#include <array>
#include <cstddef>
#include <span>

#include "regolith/core/time.hpp"

namespace regolith::hal {

/// `fetch(after, batch)` returns how many samples with stamp > after it wrote into `batch` (the
/// wrapped device's samples_since); `keep(sample&)` returns false to leave a sample out. Reads on
/// past rejected samples until `out` is full or the device has no more; returns how many were kept.
template <class Sample, std::size_t Batch = 64, class Fetch, class Keep>
std::size_t filter_samples(TimeNs after, std::span<Sample> out, Fetch&& fetch, Keep&& keep) {
  if (out.empty()) return 0;
  std::array<Sample, Batch> batch{};
  std::size_t n = 0;
  for (;;) {
    const TimeNs from = after;
    const std::size_t got = fetch(after, std::span<Sample>(batch));
    for (std::size_t i = 0; i < got; ++i) {
      after = batch[i].stamp;
      if (!keep(batch[i])) continue;
      out[n] = batch[i];
      if (++n == out.size()) return n;
    }
    if (got < batch.size() || after == from) return n;
  }
}

}  // namespace regolith::hal
