// Runs independent pieces of batch work (noise fits per axis, ...) on a few threads: the programs'
// share of the machine's cores, never the real-time core's (core/ has no threads).
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace boresight::model {

/// The threads a batch program uses by default: the machine's cores, at most `cap`, at least one.
inline unsigned defaultThreads(unsigned cap = 2) { return std::max(1u, std::min(cap, std::thread::hardware_concurrency())); }

/// f(i) for every i in [0, n), on up to `threads` threads (the calling thread is one of them). Each i
/// runs exactly once; which thread runs it does not matter when f(i) depends on i alone, so the result
/// is that of the sequential loop. The first exception thrown by any f(i) is rethrown here after every
/// thread has stopped (the remaining indices are skipped).
template <class F>
void parallelFor(std::size_t n, unsigned threads, F&& f) {
  const unsigned workers = static_cast<unsigned>(std::min<std::size_t>(std::max(1u, threads), n));
  if (workers <= 1) {
    for (std::size_t i = 0; i < n; ++i) f(i);
    return;
  }
  std::atomic<std::size_t> next{0};
  std::atomic<bool> stop{false};
  std::exception_ptr failed;
  std::mutex m;
  const auto work = [&] {
    for (std::size_t i = next++; i < n && !stop; i = next++) {
      try {
        f(i);
      } catch (...) {
        const std::lock_guard<std::mutex> lock(m);
        if (!failed) failed = std::current_exception();
        stop = true;
      }
    }
  };
  std::vector<std::thread> th;
  for (unsigned w = 1; w < workers; ++w) th.emplace_back(work);
  work();
  for (auto& t : th) t.join();
  if (failed) std::rethrow_exception(failed);
}

}  // namespace boresight::model
