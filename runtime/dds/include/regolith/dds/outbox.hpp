#pragma once
// Real-time-safe publishing. A rate-group thread never calls dds_write (it
// serialises, may allocate and may block on a reliable writer). Instead it
// fills one of `slots` samples that were pre-allocated at configure time and
// hands its index over through a lock-free queue; the participant's publisher
// thread (not real time) writes it and returns the slot.
//
//   RT side (one thread per Outbox):            publisher thread (one per
//   Participant):
//     Msg* m = box.begin();  // no alloc, no lock     pop ready index ->
//     dds_write -> push free if (m) { fill *m; box.commit(); }
//
// Modes: kFifo writes every committed sample in order (streams: joint_states,
// sinkage); kLatest writes only the newest one pending (state topics: maps,
// soil), older ones count as dropped. When no slot is free, begin() returns
// nullptr and the sample counts as dropped.
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>

#include <dds/dds.h>

#include "regolith/core/channels.hpp"
#include "regolith/dds/qos.hpp"
#include "regolith/dds/sample.hpp"
#include "regolith/dds/types.hpp"

namespace regolith::dds {

/// Error from the Cyclone DDS C API: the message names the call, the topic and
/// the return code.
class DdsError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};
/// Throws DdsError "<what>: <dds_strretcode(rc)>" when rc < 0; returns rc
/// otherwise.
dds_return_t check(dds_return_t rc, std::string_view what);

enum class OutboxMode { kFifo, kLatest };

struct OutboxOptions {
  OutboxMode mode = OutboxMode::kFifo;
  std::uint32_t slots = 8;  ///< pre-allocated samples (>= 2)
};

/// Wake-up counter shared by a participant's publisher thread and its outboxes.
/// notify() is one atomic increment plus, only when the publisher sleeps, one
/// futex wake: no lock, no allocation.
struct Waker {
  std::atomic<std::uint32_t> counter{0};
  void notify() noexcept {
    counter.fetch_add(1, std::memory_order_release);
    counter.notify_one();
  }
};

/// The DDS source timestamp of a sample as it is written (ROS time, ns since 1970); empty = the
/// writer's own clock (dds_write: wall time). Participant::set_source_clock.
using SourceClock = std::function<TimeNs()>;

struct OutboxStats {
  std::string topic;                  ///< ROS name, e.g. "/rover1/joint_states"
  std::string ros_type;               ///< e.g. "sensor_msgs/msg/JointState"
  std::uint64_t committed = 0;        ///< samples handed over by the RT side
  std::uint64_t published = 0;        ///< successful dds_write calls
  std::uint64_t dropped = 0;          ///< no free slot at begin() + superseded (kLatest)
  std::uint64_t write_errors = 0;     ///< dds_write failures
  std::uint64_t deadline_missed = 0;  ///< offered-deadline-missed events (listener)
  std::uint32_t matched_readers = 0;  ///< currently matched readers
};

/// Type-independent part: the writer, the counters, the listener.
class OutboxBase {
 public:
  virtual ~OutboxBase();
  OutboxBase(const OutboxBase&) = delete;
  OutboxBase& operator=(const OutboxBase&) = delete;

  const std::string& topic() const { return topic_; }
  std::string_view ros_type() const { return ros_type_; }
  dds_entity_t writer() const { return writer_; }
  std::uint64_t committed() const { return committed_.load(std::memory_order_relaxed); }
  std::uint64_t published() const { return published_.load(std::memory_order_relaxed); }
  std::uint64_t dropped() const { return dropped_.load(std::memory_order_relaxed); }
  std::uint64_t write_errors() const { return write_errors_.load(std::memory_order_relaxed); }
  std::uint64_t deadline_missed() const { return deadline_missed_.load(std::memory_order_relaxed); }
  std::uint32_t matched_readers() const;
  OutboxStats stats() const;

  /// Publisher side (non real time): writes what is pending. Returns the number
  /// of samples written. Called by the participant's publisher thread, or
  /// directly when no thread runs. `source_clock` stamps each sample when it
  /// is written, after it was taken from the queue: under simulated time the
  /// clock cannot have moved past the cycle that committed it (time waits
  /// until every outbox is idle), so the stamp is that cycle's time.
  virtual std::size_t flush(const SourceClock& source_clock) = 0;
  /// True when nothing committed is waiting to be written.
  virtual bool idle() const = 0;

 protected:
  OutboxBase(dds_entity_t participant, dds_entity_t topic, std::string ros_topic, std::string_view ros_type,
             const QosProfile& qos, std::shared_ptr<Waker> waker);
  bool write_sample(const void* sample, const SourceClock& source_clock);  // publisher side; counts

  std::shared_ptr<Waker> waker_;
  std::atomic<std::uint64_t> committed_{0};
  std::atomic<std::uint64_t> dropped_{0};

 private:
  static void on_deadline_missed(dds_entity_t, dds_offered_deadline_missed_status_t st, void* arg);
  std::string topic_;
  std::string_view ros_type_;
  dds_entity_t writer_ = 0;
  std::atomic<std::uint64_t> published_{0};
  std::atomic<std::uint64_t> write_errors_{0};
  std::atomic<std::uint64_t> deadline_missed_{0};
};

template <class Msg>
class Outbox final : public OutboxBase {
 public:
  /// `reserve` is called once per slot on a zeroed sample and must pre-allocate
  /// every string and sequence the RT side will fill (see sample.hpp for the
  /// rules). Use Participant::make_outbox.
  Outbox(dds_entity_t participant, dds_entity_t topic, std::string ros_topic, const QosProfile& qos,
         const OutboxOptions& opt, const std::function<void(Msg&)>& reserve, std::shared_ptr<Waker> waker)
      : OutboxBase(participant, topic, std::move(ros_topic), MsgTraits<Msg>::ros_type, qos, std::move(waker)),
        mode_(opt.mode),
        slots_(opt.slots),
        samples_(new Msg[opt.slots]()),
        free_(opt.slots, DropPolicy::kDropNewest),
        ready_(opt.slots, DropPolicy::kDropNewest) {
    if (opt.slots < 2)
      throw std::invalid_argument("OutboxOptions.slots: must be >= 2 (got " + std::to_string(opt.slots) + ")");
    try {
      for (std::uint32_t i = 0; i < slots_; ++i) {
        if (reserve) reserve(samples_[i]);
        free_.push(i);
      }
    } catch (...) {
      release_samples();
      throw;
    }
  }
  ~Outbox() override { release_samples(); }

  /// RT side: a pre-allocated sample to fill, or nullptr when every slot is in
  /// flight (counted as dropped). Calling begin() again before commit() returns
  /// the same sample. Never allocates, never blocks. The previous content of
  /// the slot is whatever was last written into it.
  Msg* begin() noexcept {
    if (writing_ != kNone) return &samples_[writing_];
    std::uint32_t i = 0;
    if (!free_.pop(i)) {
      dropped_.fetch_add(1, std::memory_order_relaxed);
      return nullptr;
    }
    writing_ = i;
    return &samples_[i];
  }
  /// RT side: hand the sample from begin() to the publisher thread and wake it.
  void commit() noexcept {
    if (writing_ == kNone) return;
    committed_.fetch_add(1, std::memory_order_release);  // before the push: idle() stays exact
    ready_.push(writing_);
    writing_ = kNone;
    waker_->notify();
  }
  /// RT side: give the sample from begin() back without publishing it.
  void abandon() noexcept {
    if (writing_ == kNone) return;
    free_.push(writing_);
    writing_ = kNone;
  }

  std::size_t flush(const SourceClock& source_clock) override {
    std::size_t written = 0;
    std::uint32_t i = 0;
    if (mode_ == OutboxMode::kFifo) {
      while (ready_.pop(i)) {
        written += write_sample(&samples_[i], source_clock) ? 1 : 0;
        free_.push(i);
        consumed_.fetch_add(1, std::memory_order_release);
      }
      return written;
    }
    std::uint32_t newest = kNone;
    while (ready_.pop(i)) {
      if (newest != kNone) {
        free_.push(newest);
        dropped_.fetch_add(1, std::memory_order_relaxed);
        consumed_.fetch_add(1, std::memory_order_release);
      }
      newest = i;
    }
    if (newest != kNone) {
      written += write_sample(&samples_[newest], source_clock) ? 1 : 0;
      free_.push(newest);
      consumed_.fetch_add(1, std::memory_order_release);
    }
    return written;
  }
  /// Every committed sample has been written (or superseded), including the
  /// dds_write call.
  bool idle() const override {
    return consumed_.load(std::memory_order_acquire) >= committed_.load(std::memory_order_acquire);
  }
  std::uint32_t slots() const { return slots_; }

 private:
  static constexpr std::uint32_t kNone = 0xffffffffu;
  void release_samples() noexcept {
    if (!samples_) return;
    for (std::uint32_t i = 0; i < slots_; ++i) free_contents(MsgTraits<Msg>::descriptor(), &samples_[i]);
    samples_.reset();
  }

  OutboxMode mode_;
  std::uint32_t slots_;
  std::unique_ptr<Msg[]> samples_;
  BoundedQueue<std::uint32_t> free_;
  BoundedQueue<std::uint32_t> ready_;
  std::uint32_t writing_ = kNone;           // RT side only
  std::atomic<std::uint64_t> consumed_{0};  // publisher side: samples written or superseded
};

}  // namespace regolith::dds
