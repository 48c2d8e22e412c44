#pragma once
// Channels between rate groups and HAL threads. None of them takes a lock: a real-time reader or
// writer never blocks, and nothing allocates after construction.
//
//  * LatestPool<T>   : the newest value, read in place through a lease (frames: pixels stay valid
//                      while the lease lives; the writer never overwrites a leased slot).
//  * LatestValue<T>  : the newest value, copied out (encoder angles, small results).
//  * BoundedQueue<T> : FIFO with a fixed capacity that drops the oldest or the newest element
//                      when full, counting drops.
#include <array>
#include <atomic>
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

namespace regolith {

/// "Is this a value I have not processed yet?" for a component that polls an input every cycle:
/// true the first time an id is seen after a different one. The id is a channel lease's
/// generation() (every write gets a new one) or a camera frame's sequence number.
class NewValue {
 public:
  bool operator()(std::uint64_t id) {
    if (seen_ && id == last_) return false;
    seen_ = true;
    last_ = id;
    return true;
  }
  /// Forget the last id (e.g. on activate()): the next value counts as new.
  void reset() { seen_ = false; }

 private:
  bool seen_ = false;
  std::uint64_t last_ = 0;
};

/// Newest-value slot pool with leases. One writer thread; any number of readers (up to
/// `max_readers` simultaneous leases). Slots are constructed once, by `init`, and reused.
template <class T>
class LatestPool {
 public:
  class Lease {
   public:
    Lease() = default;
    Lease(const Lease&) = delete;
    Lease& operator=(const Lease&) = delete;
    Lease(Lease&& o) noexcept : pool_(std::exchange(o.pool_, nullptr)), slot_(o.slot_) {}
    Lease& operator=(Lease&& o) noexcept {
      if (this != &o) {
        reset();
        pool_ = std::exchange(o.pool_, nullptr);
        slot_ = o.slot_;
      }
      return *this;
    }
    ~Lease() { reset(); }
    void reset() {
      if (pool_ != nullptr) {
        pool_->slots_[slot_].readers.fetch_sub(1, std::memory_order_acq_rel);
        pool_ = nullptr;
      }
    }
    explicit operator bool() const { return pool_ != nullptr; }
    const T& operator*() const { return pool_->slots_[slot_].value; }
    const T* operator->() const { return &pool_->slots_[slot_].value; }
    /// Generation of the value: increases by one with every publish.
    std::uint64_t generation() const { return pool_->slots_[slot_].generation; }

   private:
    friend class LatestPool;
    Lease(const LatestPool* p, std::size_t s) : pool_(p), slot_(s) {}
    const LatestPool* pool_ = nullptr;
    std::size_t slot_ = 0;
  };

  /// `max_readers` simultaneous leases; the pool holds max_readers + 2 slots, each made by `make`.
  explicit LatestPool(
      std::size_t max_readers, const std::function<T()>& make = [] { return T{}; })
      : slots_(max_readers + 2) {
    for (auto& s : slots_) s.value = make();
  }

  LatestPool(const LatestPool&) = delete;
  LatestPool& operator=(const LatestPool&) = delete;

  /// Writer: a slot no reader holds and that is not the published one. Never fails while at most
  /// `max_readers` leases are held; returns nullptr (and the caller drops its sample) otherwise.
  //
  // Ordering: the writer publishes `current_` then checks a slot's reader count; a reader bumps
  // the count then re-checks `current_`. That is a store->load (Dekker) pattern, so these four
  // operations are sequentially consistent: acquire/release alone lets the writer miss a reader
  // that still sees the old `current_` (torn reads, seen in the concurrency test).
  T* begin_write() {
    const std::size_t cur = current_.load(std::memory_order_seq_cst);
    for (std::size_t i = 0; i < slots_.size(); ++i) {
      const std::size_t s = (write_hint_ + i) % slots_.size();
      if (s == cur && has_value()) continue;
      if (slots_[s].readers.load(std::memory_order_seq_cst) == 0) {
        writing_ = s;
        write_hint_ = s + 1;
        return &slots_[s].value;
      }
    }
    ++write_failures_;
    return nullptr;
  }
  /// Writer: publish the slot returned by the last successful begin_write().
  void commit() {
    slots_[writing_].generation = ++generation_;
    current_.store(writing_, std::memory_order_seq_cst);
    has_value_.store(true, std::memory_order_release);
  }
  /// Writer convenience: copy-assign and publish. Returns false if no slot was free.
  bool publish(const T& v) {
    T* slot = begin_write();
    if (slot == nullptr) return false;
    *slot = v;
    commit();
    return true;
  }

  /// Reader: lease the newest value; empty lease when nothing was published yet. Lock-free.
  Lease acquire() const {
    if (!has_value()) return {};
    for (;;) {
      const std::size_t s = current_.load(std::memory_order_seq_cst);
      slots_[s].readers.fetch_add(1, std::memory_order_seq_cst);
      if (current_.load(std::memory_order_seq_cst) == s) return Lease(this, s);
      slots_[s].readers.fetch_sub(1, std::memory_order_acq_rel);
    }
  }

  bool has_value() const { return has_value_.load(std::memory_order_acquire); }
  std::uint64_t write_failures() const { return write_failures_; }

 private:
  struct Slot {
    T value{};
    std::uint64_t generation = 0;
    mutable std::atomic<int> readers{0};
  };
  std::vector<Slot> slots_;
  std::atomic<std::size_t> current_{0};
  std::atomic<bool> has_value_{false};
  std::size_t writing_ = 0;
  std::size_t write_hint_ = 0;
  std::uint64_t generation_ = 0;
  std::uint64_t write_failures_ = 0;
};

/// Newest value, copied out. Built on LatestPool; `T` should be cheap to copy.
template <class T>
class LatestValue {
 public:
  explicit LatestValue(std::size_t max_readers = 4) : pool_(max_readers) {}
  bool write(const T& v) { return pool_.publish(v); }
  /// Copy of the newest value, or nullopt before the first write.
  std::optional<T> read() const {
    auto lease = pool_.acquire();
    if (!lease) return std::nullopt;
    return *lease;
  }
  /// Copy into `out`; returns false before the first write. Returns the generation in `gen`.
  bool read(T& out, std::uint64_t* gen = nullptr) const {
    auto lease = pool_.acquire();
    if (!lease) return false;
    out = *lease;
    if (gen != nullptr) *gen = lease.generation();
    return true;
  }

 private:
  LatestPool<T> pool_;
};

enum class DropPolicy { kDropOldest, kDropNewest };

/// Bounded multi-producer / multi-consumer FIFO (Vyukov's sequence-numbered ring). When full,
/// `push` either rejects the new element (drop newest) or removes the oldest one first (drop
/// oldest). Lock-free; capacity is rounded up to a power of two.
template <class T>
class BoundedQueue {
 public:
  BoundedQueue(std::size_t capacity, DropPolicy policy) : policy_(policy) {
    std::size_t cap = 2;
    while (cap < capacity) cap <<= 1;
    cells_ = std::make_unique<Cell[]>(cap);
    mask_ = cap - 1;
    capacity_ = capacity;
    for (std::size_t i = 0; i < cap; ++i) cells_[i].seq.store(i, std::memory_order_relaxed);
  }

  /// Returns false when the element pushed was dropped (drop-newest policy and full).
  bool push(const T& v) {
    for (int attempt = 0;; ++attempt) {
      if (size() >= capacity_ || !try_push(v)) {
        if (policy_ == DropPolicy::kDropNewest) {
          dropped_.fetch_add(1, std::memory_order_relaxed);
          return false;
        }
        T discard;
        if (try_pop(discard)) dropped_.fetch_add(1, std::memory_order_relaxed);
        continue;
      }
      return true;
    }
  }
  bool pop(T& out) { return try_pop(out); }

  std::size_t size() const {
    const std::size_t e = enqueue_pos_.load(std::memory_order_acquire);
    const std::size_t d = dequeue_pos_.load(std::memory_order_acquire);
    return e >= d ? e - d : 0;
  }
  std::size_t capacity() const { return capacity_; }
  std::uint64_t dropped() const { return dropped_.load(std::memory_order_relaxed); }

 private:
  struct Cell {
    std::atomic<std::size_t> seq{0};
    T value{};
  };
  bool try_push(const T& v) {
    std::size_t pos = enqueue_pos_.load(std::memory_order_relaxed);
    for (;;) {
      Cell& c = cells_[pos & mask_];
      const std::size_t seq = c.seq.load(std::memory_order_acquire);
      const auto diff = static_cast<std::ptrdiff_t>(seq) - static_cast<std::ptrdiff_t>(pos);
      if (diff == 0) {
        if (enqueue_pos_.compare_exchange_weak(pos, pos + 1, std::memory_order_relaxed)) {
          c.value = v;
          c.seq.store(pos + 1, std::memory_order_release);
          return true;
        }
      } else if (diff < 0) {
        return false;  // full
      } else {
        pos = enqueue_pos_.load(std::memory_order_relaxed);
      }
    }
  }
  bool try_pop(T& out) {
    std::size_t pos = dequeue_pos_.load(std::memory_order_relaxed);
    for (;;) {
      Cell& c = cells_[pos & mask_];
      const std::size_t seq = c.seq.load(std::memory_order_acquire);
      const auto diff = static_cast<std::ptrdiff_t>(seq) - static_cast<std::ptrdiff_t>(pos + 1);
      if (diff == 0) {
        if (dequeue_pos_.compare_exchange_weak(pos, pos + 1, std::memory_order_relaxed)) {
          out = c.value;
          c.seq.store(pos + mask_ + 1, std::memory_order_release);
          return true;
        }
      } else if (diff < 0) {
        return false;  // empty
      } else {
        pos = dequeue_pos_.load(std::memory_order_relaxed);
      }
    }
  }

  std::unique_ptr<Cell[]> cells_;
  std::size_t mask_ = 0;
  std::size_t capacity_ = 0;
  DropPolicy policy_;
  alignas(64) std::atomic<std::size_t> enqueue_pos_{0};
  alignas(64) std::atomic<std::size_t> dequeue_pos_{0};
  std::atomic<std::uint64_t> dropped_{0};
};

}  // namespace regolith
