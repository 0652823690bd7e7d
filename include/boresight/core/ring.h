// boresight::core - the one first-in first-out ring of the project, and its lock-free single-producer
// single-consumer form for handing items between two threads.
//
// Ring<T, N>: at most N elements in the object (std::array), nothing allocated ever. Ring<T> (N =
// kDynamic): the capacity is given once by reset(capacity) - the only call that allocates - before the
// real-time phase. Neither throws or allocates after that. Index 0 is the oldest element.
// SpscRing<T>: one thread pushes, one pops; capacity a power of two, allocated by init() before the
// two threads start; push and pop never block, allocate or throw.
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <type_traits>
#include <vector>

namespace boresight::core {

inline constexpr std::size_t kDynamic = 0;

namespace ring_detail {
template <class T, std::size_t N>
struct Storage {
  std::array<T, N> buf{};
  static constexpr std::size_t capacity() { return N; }
};
template <class T>
struct Storage<T, kDynamic> {
  std::vector<T> buf;
  std::size_t capacity() const { return buf.size(); }
};
}  // namespace ring_detail

template <class T, std::size_t N = kDynamic>
class Ring {
 public:
  Ring() = default;
  /// Dynamic capacity only: the storage, allocated here once (capacity 0 is taken as 1).
  explicit Ring(std::size_t capacity) { reset(capacity); }
  void reset(std::size_t capacity) {
    static_assert(N == kDynamic, "a fixed ring's capacity is its template argument");
    s_.buf.assign(capacity < 1 ? 1 : capacity, T{});
    head_ = n_ = 0;
  }

  std::size_t capacity() const { return s_.capacity(); }
  std::size_t size() const { return n_; }
  bool empty() const { return n_ == 0; }
  bool full() const { return n_ == capacity(); }
  void clear() { head_ = n_ = 0; }

  /// The i-th oldest element (i < size()).
  T& operator[](std::size_t i) { return s_.buf[wrap(head_ + i)]; }
  const T& operator[](std::size_t i) const { return s_.buf[wrap(head_ + i)]; }
  T& front() { return s_.buf[head_]; }
  const T& front() const { return s_.buf[head_]; }
  T& back() { return (*this)[n_ - 1]; }
  const T& back() const { return (*this)[n_ - 1]; }

  /// Appends x; false (and nothing changed) when full.
  bool push(const T& x) {
    if (full()) return false;
    s_.buf[wrap(head_ + n_)] = x;
    ++n_;
    return true;
  }
  /// Appends x; when full the oldest goes first. Returns true when one went.
  bool pushOverwrite(const T& x) {
    const bool drop = full();
    if (drop) popFront();
    s_.buf[wrap(head_ + n_)] = x;
    ++n_;
    return drop;
  }
  /// A new element at the back (its old content is left; the caller writes it); when full the
  /// oldest goes first, as with pushOverwrite.
  T& emplaceBack() {
    if (full()) popFront();
    ++n_;
    return back();
  }
  /// Drops the oldest (no-op when empty).
  void popFront() {
    if (n_ == 0) return;
    head_ = wrap(head_ + 1);
    --n_;
  }
  /// Moves the oldest to out; false when empty.
  bool pop(T& out) {
    if (n_ == 0) return false;
    out = s_.buf[head_];
    popFront();
    return true;
  }

 private:
  std::size_t wrap(std::size_t i) const {
    const std::size_t c = capacity();
    return i >= c ? i - c : i;  // every caller passes i < 2 * capacity
  }
  ring_detail::Storage<T, N> s_;
  std::size_t head_ = 0, n_ = 0;
};

/// Bounded lock-free single-producer/single-consumer ring. T must be copy-assignable without
/// allocation for push/pop to stay allocation-free.
template <class T>
class SpscRing {
 public:
  /// capacity: rounded up to a power of two (at least 2). Before either thread uses the ring.
  void init(std::size_t capacity) {
    std::size_t c = 2;
    while (c < capacity) c <<= 1;
    buf_.assign(c, T{});
    mask_ = c - 1;
    head_.store(0, std::memory_order_relaxed);
    tail_.store(0, std::memory_order_relaxed);
  }
  std::size_t capacity() const { return mask_ + 1; }
  /// Producer: false when full.
  bool push(const T& x) {
    const std::size_t h = head_.load(std::memory_order_relaxed);
    if (h - tail_.load(std::memory_order_acquire) > mask_) return false;
    buf_[h & mask_] = x;
    head_.store(h + 1, std::memory_order_release);
    return true;
  }
  /// Consumer: false when empty.
  bool pop(T& out) {
    const std::size_t t = tail_.load(std::memory_order_relaxed);
    if (head_.load(std::memory_order_acquire) == t) return false;
    out = buf_[t & mask_];
    tail_.store(t + 1, std::memory_order_release);
    return true;
  }
  /// Either thread: a snapshot of the fill.
  std::size_t size() const { return head_.load(std::memory_order_acquire) - tail_.load(std::memory_order_acquire); }

 private:
  std::vector<T> buf_;
  std::size_t mask_ = 0;
  alignas(64) std::atomic<std::size_t> head_{0};
  alignas(64) std::atomic<std::size_t> tail_{0};
};

}  // namespace boresight::core
