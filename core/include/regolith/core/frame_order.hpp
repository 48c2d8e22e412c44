#pragma once
// FrameOrder: the rule that keeps a stream of per-frame outputs from going back in time, one rule
// for every component that publishes per camera frame (terrain_map, sfs and what reads its DTM,
// wheel_sinkage, soil_stiffness) and for `regolith map REC.mcap` (which then maps the frames the
// live terrain_map mapped). Framework-free, allocation-free.
//
// A frame stamped at or before the last one admitted (a camera clock that stepped back by up to
// the limit, or a frame delivered twice) is out of order: skipped by the caller, since everything
// made from it would be older than what was already published, and everything timed by it (the
// wheel angle at its capture time) would be read at the wrong time. A step back by more than the
// limit (callers use their input timeout) is the clock itself stepping back (a time sync): waiting
// for the stamps to pass the last one would stop the stream that long, so the stream goes on from
// the new time base. joint_states (runtime/src/builtin_components.cpp) applies it per wheel and to
// its stream, where the same sample read again is nothing new (`repeats`), not out of order. Both
// are counted: the counters may be read from another thread (a component's diagnostics() on the
// health thread) while the owner judges, so a component reports them straight from its FrameOrder.
#include <atomic>
#include <cstdint>

namespace regolith {

class FrameOrder {
 public:
  enum class Verdict { kNext, kOutOfOrder, kClockStep };

  /// `step_back_limit_ns` >= 0: a step back by more than this is a clock step.
  explicit FrameOrder(std::int64_t step_back_limit_ns = 0) : limit_(step_back_limit_ns) {}
  FrameOrder(const FrameOrder& o) { *this = o; }
  FrameOrder& operator=(const FrameOrder& o) {
    limit_ = o.limit_;
    last_ = o.last_;
    have_ = o.have_;
    out_of_order_.store(o.out_of_order(), std::memory_order_relaxed);
    clock_steps_.store(o.clock_steps(), std::memory_order_relaxed);
    return *this;
  }

  /// The frame stamped `t_ns` against the last one admitted; counts what it finds. Admits
  /// nothing (see admit() and take()).
  Verdict judge(std::int64_t t_ns) {
    if (!have_ || t_ns > last_) return Verdict::kNext;
    if (last_ - t_ns <= limit_) {
      out_of_order_.fetch_add(1, std::memory_order_relaxed);
      return Verdict::kOutOfOrder;
    }
    clock_steps_.fetch_add(1, std::memory_order_relaxed);
    return Verdict::kClockStep;
  }
  /// The frame stamped `t_ns` was used: later frames are judged against it.
  void take(std::int64_t t_ns) {
    last_ = t_ns;
    have_ = true;
  }
  /// judge(), then take() unless the frame is out of order.
  Verdict admit(std::int64_t t_ns) {
    const Verdict v = judge(t_ns);
    if (v != Verdict::kOutOfOrder) take(t_ns);
    return v;
  }
  /// `t_ns` is the stamp last taken: the same sample read again (a poll faster than the source),
  /// which a caller that polls skips before judging it.
  bool repeats(std::int64_t t_ns) const { return have_ && t_ns == last_; }
  /// Frames judged out of order and clock steps so far (any thread).
  long out_of_order() const { return out_of_order_.load(std::memory_order_relaxed); }
  long clock_steps() const { return clock_steps_.load(std::memory_order_relaxed); }

 private:
  std::int64_t limit_ = 0, last_ = 0;
  bool have_ = false;
  std::atomic<long> out_of_order_{0}, clock_steps_{0};
};

}  // namespace regolith
