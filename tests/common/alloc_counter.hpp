#pragma once
// Heap allocations counted in a test or bench binary: the one replacement of the global operator
// new / delete (malloc / free underneath) that the allocation tests share.
//
// Include it in exactly ONE source file of a binary (it defines the replacement operators for the
// whole program). Define REGOLITH_ALLOC_COUNT_CYCLES before including it in a binary that links
// regolith::runtime to also count the allocations made inside rate-group cycles (on the group's
// thread, or on a worker pool's thread for the member; runtime::in_rate_group_cycle()).
//
//   regolith::testing::allocations()         every operator new so far, all threads
//   regolith::testing::thread_allocations()  those of the calling thread
//   regolith::testing::cycle_allocations()   those inside rate-group cycles (REGOLITH_ALLOC_COUNT_CYCLES)
//   regolith::testing::trace_cycle_allocations(n)  print the call stacks of the next n of those on
//                                                  stderr (addr2line / gdb turn them into lines)
//   regolith::testing::attribute_cycle_allocations(on)  from now on (or no longer) also count them per
//                                                  rate-group member (runtime::current_cycle_member())
//   regolith::testing::member_allocations(member)  those counted for one member (a Component*)
//   regolith::testing::unattributed_cycle_allocations()  those made between members, or past the
//                                                  table's kMaxMembers
//
// A window is the difference of two readings around the code under test.
#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <new>

#ifdef REGOLITH_ALLOC_COUNT_CYCLES
#include <execinfo.h>
#include <unistd.h>

#include "regolith/runtime/rate_group.hpp"
#endif

// GCC pairs inlined library deletes with the malloc inside these replacements and warns.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"

namespace regolith::testing {
namespace detail {
inline std::atomic<std::uint64_t> all{0};
inline std::atomic<std::uint64_t> in_cycle{0};
inline std::atomic<int> trace_left{0};
inline thread_local std::uint64_t this_thread = 0;
#ifdef REGOLITH_ALLOC_COUNT_CYCLES
// Per-member counts without allocating: a fixed table of (member, count), claimed lock-free.
inline constexpr std::size_t kMaxMembers = 64;
inline std::atomic<bool> attributing{false};
inline std::atomic<const void*> member_key[kMaxMembers] = {};
inline std::atomic<std::uint64_t> member_count[kMaxMembers] = {};
inline std::atomic<std::uint64_t> unattributed{0};

inline void attribute(const void* member) {
  if (member != nullptr)
    for (std::size_t i = 0; i < kMaxMembers; ++i) {
      const void* expected = nullptr;
      if (member_key[i].load(std::memory_order_acquire) == member ||
          member_key[i].compare_exchange_strong(expected, member) || expected == member) {
        member_count[i].fetch_add(1, std::memory_order_relaxed);
        return;
      }
    }
  unattributed.fetch_add(1, std::memory_order_relaxed);
}
#endif
}  // namespace detail

inline std::uint64_t allocations() {
  return detail::all.load(std::memory_order_relaxed);
}
inline std::uint64_t thread_allocations() {
  return detail::this_thread;
}
inline std::uint64_t cycle_allocations() {
  return detail::in_cycle.load(std::memory_order_relaxed);
}
inline void trace_cycle_allocations(int n) {
  detail::trace_left.store(n, std::memory_order_relaxed);
}
#ifdef REGOLITH_ALLOC_COUNT_CYCLES
inline void attribute_cycle_allocations(bool on) {
  detail::attributing.store(on, std::memory_order_relaxed);
}
inline std::uint64_t member_allocations(const void* member) {
  for (std::size_t i = 0; i < detail::kMaxMembers; ++i)
    if (detail::member_key[i].load(std::memory_order_acquire) == member)
      return detail::member_count[i].load(std::memory_order_relaxed);
  return 0;
}
inline std::uint64_t unattributed_cycle_allocations() {
  return detail::unattributed.load(std::memory_order_relaxed);
}
#endif
}  // namespace regolith::testing

void* operator new(std::size_t n) {
  namespace d = regolith::testing::detail;
  d::all.fetch_add(1, std::memory_order_relaxed);
  ++d::this_thread;
#ifdef REGOLITH_ALLOC_COUNT_CYCLES
  if (regolith::runtime::in_rate_group_cycle()) {
    d::in_cycle.fetch_add(1, std::memory_order_relaxed);
    if (d::attributing.load(std::memory_order_relaxed)) d::attribute(regolith::runtime::current_cycle_member());
    if (d::trace_left.load(std::memory_order_relaxed) > 0 && d::trace_left.fetch_sub(1) > 0) {
      void* frames[24];
      const int depth = backtrace(frames, 24);
      backtrace_symbols_fd(frames, depth, STDERR_FILENO);
      (void)!write(STDERR_FILENO, "----\n", 5);
    }
  }
#endif
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n) {
  return operator new(n);
}
// The nothrow forms too (std::stable_sort's temporary buffer, among others): counted like the
// others, and freed by the free() below (left to the library, a sanitizer's new would be paired
// with this file's delete: ASan reports alloc-dealloc-mismatch).
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  try {
    return operator new(n);
  } catch (...) {
    return nullptr;
  }
}
void* operator new[](std::size_t n, const std::nothrow_t& t) noexcept {
  return operator new(n, t);
}
void operator delete(void* p, const std::nothrow_t&) noexcept {
  std::free(p);
}
void operator delete[](void* p, const std::nothrow_t&) noexcept {
  std::free(p);
}
void operator delete(void* p) noexcept {
  std::free(p);
}
void operator delete[](void* p) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
  std::free(p);
}
void operator delete[](void* p, std::size_t) noexcept {
  std::free(p);
}
