// core::Ring and core::SpscRing (include/boresight/core/ring.h) against a std::deque model, and the
// SPSC form across two threads; neither allocates after its storage is set.
#include <boresight/core/ring.h>

#include <gtest/gtest.h>

#include <cstdint>
#include <deque>
#include <random>
#include <thread>

#include "alloc_interpose.h"

namespace {

using boresight::core::Ring;
using boresight::core::SpscRing;

/// Random pushes, overwriting pushes, pops, emplaces and clears; after every operation the ring and a
/// deque holding the same elements agree on size and every element, oldest first.
template <class R>
void againstDeque(R& r, std::size_t cap, std::uint32_t seed) {
  std::deque<int> d;
  std::mt19937 rng(seed);
  int next = 0;
  for (int op = 0; op < 20000; ++op) {
    const int k = static_cast<int>(rng() % 100);
    if (k < 35) {
      const bool ok = r.push(next);
      ASSERT_EQ(ok, d.size() < cap);
      if (ok) d.push_back(next);
    } else if (k < 55) {
      const bool dropped = r.pushOverwrite(next);
      ASSERT_EQ(dropped, d.size() == cap);
      if (dropped) d.pop_front();
      d.push_back(next);
    } else if (k < 65) {
      if (d.size() == cap) d.pop_front();  // a full ring drops its oldest, as pushOverwrite does
      r.emplaceBack() = next;
      d.push_back(next);
    } else if (k < 95) {
      int out = -1;
      const bool ok = r.pop(out);
      ASSERT_EQ(ok, !d.empty());
      if (ok) {
        ASSERT_EQ(out, d.front());
        d.pop_front();
      }
    } else if (k < 97) {
      r.popFront();
      if (!d.empty()) d.pop_front();
    } else if (k == 99) {
      r.clear();
      d.clear();
    }
    ++next;
    ASSERT_EQ(r.size(), d.size());
    ASSERT_EQ(r.empty(), d.empty());
    ASSERT_EQ(r.full(), d.size() == cap);
    for (std::size_t i = 0; i < d.size(); ++i) ASSERT_EQ(r[i], d[i]) << "op " << op << " index " << i;
    if (!d.empty()) {
      ASSERT_EQ(r.front(), d.front());
      ASSERT_EQ(r.back(), d.back());
    }
  }
}

TEST(Ring, FixedCapacityBehavesAsABoundedDeque) {
  Ring<int, 5> r;
  EXPECT_EQ(r.capacity(), 5u);
  againstDeque(r, 5, 1);
  Ring<int, 1> one;
  againstDeque(one, 1, 2);
}

TEST(Ring, DynamicCapacityBehavesAsABoundedDeque) {
  for (std::size_t cap : {1u, 2u, 7u, 64u}) {
    Ring<int> r(cap);
    EXPECT_EQ(r.capacity(), cap);
    againstDeque(r, cap, static_cast<std::uint32_t>(cap));
  }
  Ring<int> zero(0);  // taken as 1
  EXPECT_EQ(zero.capacity(), 1u);
}

TEST(Ring, NoAllocationAfterItsStorageIsSet) {
  Ring<std::uint64_t> r(100);
  Ring<std::uint64_t, 16> f;
  allocguard::arm();
  std::uint64_t sum = 0, x = 0;
  for (std::uint64_t i = 0; i < 10000; ++i) {
    r.pushOverwrite(i);
    f.pushOverwrite(i);
    if (i % 3 == 0 && r.pop(x)) sum += x;
    sum += f[f.size() - 1];
  }
  const long n = allocguard::disarm();
  EXPECT_EQ(n, 0);
  EXPECT_GT(sum, 0u);
}

TEST(SpscRing, CapacityIsThePowerOfTwoAtOrAboveTheRequest) {
  SpscRing<int> r;
  r.init(5);
  EXPECT_EQ(r.capacity(), 8u);
  for (int i = 0; i < 8; ++i) EXPECT_TRUE(r.push(i));
  EXPECT_FALSE(r.push(8));  // full
  int x = -1;
  EXPECT_TRUE(r.pop(x));
  EXPECT_EQ(x, 0);
  EXPECT_TRUE(r.push(8));
  EXPECT_EQ(r.size(), 8u);
}

TEST(SpscRing, TwoThreadsHandOverEveryItemInOrder) {
  SpscRing<std::uint64_t> r;
  r.init(64);
  constexpr std::uint64_t kItems = 200000;
  std::uint64_t bad = 0, got = 0;
  std::thread consumer([&] {
    std::uint64_t expect = 0, v = 0;
    while (expect < kItems) {
      if (!r.pop(v)) {
        std::this_thread::yield();
        continue;
      }
      if (v != expect) ++bad;
      expect = v + 1;
      ++got;
    }
  });
  allocguard::arm(/*this_thread_only=*/true);
  for (std::uint64_t i = 0; i < kItems; ++i)
    while (!r.push(i)) std::this_thread::yield();
  const long n = allocguard::disarm();
  consumer.join();
  EXPECT_EQ(n, 0);
  EXPECT_EQ(got, kItems);
  EXPECT_EQ(bad, 0u);
}

}  // namespace
