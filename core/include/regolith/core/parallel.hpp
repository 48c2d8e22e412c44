#pragma once
// Data-parallel work inside one call, without tying an algorithm to a framework: an algorithm
// takes a `ParallelFor*` (nullptr = serial, on the calling thread) and hands it independent jobs;
// the runtime's WorkerPool (threads made at configure time) is the implementation a component
// passes in. Nothing here allocates.
#include <type_traits>

namespace regolith {

class ParallelFor {
 public:
  virtual ~ParallelFor() = default;
  /// Calls fn(ctx, i) once for every i in [0, n), in any order, on any of its threads (the
  /// caller's included), and returns when every call has returned. fn must not throw.
  virtual void run(int n, void (*fn)(void*, int), void* ctx) = 0;
  /// Threads that may run jobs at once (the caller's included).
  virtual int threads() const = 0;
};

/// f(i) for every i in [0, n): on `par` when given (and n > 1), else in order on this thread.
/// `f` must not throw.
template <class F>
void parallel_for(ParallelFor* par, int n, F&& f) {
  if (par == nullptr || par->threads() <= 1 || n <= 1) {
    for (int i = 0; i < n; ++i) f(i);
    return;
  }
  using Fn = std::remove_reference_t<F>;
  par->run(
      n, [](void* ctx, int i) { (*static_cast<Fn*>(ctx))(i); }, const_cast<void*>(static_cast<const void*>(&f)));
}

}  // namespace regolith
