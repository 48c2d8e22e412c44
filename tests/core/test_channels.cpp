// Channels between rate groups: single-thread semantics and concurrent producer/consumer tests
// (run under the tsan preset too: `ctest --preset tsan`).
#include <array>
#include <atomic>
#include <thread>

#include <gtest/gtest.h>

#include "regolith/core/channels.hpp"

using namespace regolith;

TEST(LatestValue, EmptyThenNewest) {
  LatestValue<int> v;
  EXPECT_FALSE(v.read().has_value());
  v.write(1);
  v.write(2);
  EXPECT_EQ(v.read().value(), 2);
  std::uint64_t gen = 0;
  int out = 0;
  ASSERT_TRUE(v.read(out, &gen));
  EXPECT_EQ(gen, 2u);
}

TEST(LatestPool, LeasedSlotIsNeverOverwritten) {
  LatestPool<int> pool(2);  // 4 slots
  pool.publish(1);
  auto a = pool.acquire();
  for (int i = 2; i < 50; ++i) ASSERT_TRUE(pool.publish(i));
  EXPECT_EQ(*a, 1) << "the writer must skip a leased slot";
  auto b = pool.acquire();
  EXPECT_EQ(*b, 49);
  auto c = pool.acquire();
  // Two leases held on two slots: the writer still has free slots.
  EXPECT_TRUE(pool.publish(50));
  EXPECT_EQ(pool.write_failures(), 0u);
}

TEST(LatestPool, WriterReportsWhenAllSlotsAreLeased) {
  LatestPool<int> pool(0);  // 2 slots: one published, one free
  pool.publish(1);
  auto a = pool.acquire();
  EXPECT_TRUE(pool.publish(2));  // uses the second slot
  auto b = pool.acquire();       // both leased now
  EXPECT_FALSE(pool.publish(3));
  EXPECT_EQ(pool.write_failures(), 1u);
  EXPECT_EQ(*b, 2);
}

TEST(BoundedQueue, DropNewestRejectsWhenFull) {
  BoundedQueue<int> q(3, DropPolicy::kDropNewest);
  EXPECT_TRUE(q.push(1));
  EXPECT_TRUE(q.push(2));
  EXPECT_TRUE(q.push(3));
  EXPECT_FALSE(q.push(4));
  EXPECT_EQ(q.dropped(), 1u);
  int v = 0;
  std::vector<int> got;
  while (q.pop(v)) got.push_back(v);
  EXPECT_EQ(got, (std::vector<int>{1, 2, 3}));
}

TEST(BoundedQueue, DropOldestKeepsTheNewest) {
  BoundedQueue<int> q(3, DropPolicy::kDropOldest);
  for (int i = 1; i <= 5; ++i) EXPECT_TRUE(q.push(i));
  EXPECT_EQ(q.dropped(), 2u);
  int v = 0;
  std::vector<int> got;
  while (q.pop(v)) got.push_back(v);
  EXPECT_EQ(got, (std::vector<int>{3, 4, 5}));
}

// A payload whose consistency a torn read would break.
struct Block {
  std::array<std::uint64_t, 64> words{};
};

TEST(Concurrency, LatestPoolReadersNeverSeeTornValues) {
  LatestPool<Block> pool(3);
  std::atomic<bool> done{false};
  std::atomic<std::uint64_t> torn{0}, reads{0}, backwards{0};
  // The writer keeps publishing until the readers have overlapped with it for long enough, however
  // the threads get scheduled on a loaded machine.
  std::thread writer([&] {
    for (std::uint64_t i = 1; i <= 200000 || reads.load() < 30000; ++i) {
      Block* slot = pool.begin_write();
      if (slot == nullptr) continue;
      for (auto& w : slot->words) w = i;
      pool.commit();
    }
    done = true;
  });
  std::vector<std::thread> readers;
  for (int r = 0; r < 3; ++r) {
    readers.emplace_back([&] {
      std::uint64_t last = 0;
      while (!done.load()) {
        auto lease = pool.acquire();
        if (!lease) continue;
        const std::uint64_t first = lease->words[0];
        for (auto w : lease->words) {
          if (w != first) ++torn;
        }
        if (first < last) ++backwards;
        last = first;
        ++reads;
      }
    });
  }
  writer.join();
  for (auto& t : readers) t.join();
  EXPECT_EQ(torn.load(), 0u);
  EXPECT_EQ(backwards.load(), 0u) << "a reader saw an older value after a newer one";
  EXPECT_GE(reads.load(), 30000u);
}

TEST(Concurrency, BoundedQueueDeliversEverythingInOrderWhenNotFull) {
  BoundedQueue<std::uint64_t> q(1024, DropPolicy::kDropNewest);
  constexpr std::uint64_t kN = 200000;
  std::thread producer([&] {
    for (std::uint64_t i = 0; i < kN; ++i) {
      while (!q.push(i)) {
      }
    }
  });
  std::uint64_t expect = 0, out = 0;
  while (expect < kN) {
    if (q.pop(out)) {
      ASSERT_EQ(out, expect);
      ++expect;
    }
  }
  producer.join();
  // The producer retries on full, so the queue counted those attempts as drops of the newest.
  EXPECT_EQ(expect, kN);
}

TEST(Concurrency, BoundedQueueDropOldestUnderContention) {
  BoundedQueue<std::uint64_t> q(8, DropPolicy::kDropOldest);
  constexpr std::uint64_t kN = 100000;
  std::atomic<bool> done{false};
  std::thread producer([&] {
    for (std::uint64_t i = 1; i <= kN; ++i) q.push(i);
    done = true;
  });
  std::uint64_t received = 0, last = 0, v = 0, out_of_order = 0;
  while (!done.load() || q.size() > 0) {
    if (q.pop(v)) {
      if (v <= last) ++out_of_order;
      last = v;
      ++received;
    }
  }
  producer.join();
  EXPECT_EQ(out_of_order, 0u);
  EXPECT_EQ(received + q.dropped(), kN) << "every element is either received or counted as dropped";
  EXPECT_EQ(last, kN) << "drop-oldest always keeps the newest";
}
