// What a replay used and rejected, printed the same way by every command that runs the engine
// (process, calibrate): per source "NAME: N read, M used, K REASON" and the first rejected lines.
#pragma once

#include <boresight/stream/engine.h>

#include <cstdio>

namespace boresight::cli {

inline void printSourceCounters(const stream::Engine& engine) {
  for (std::size_t i = 0; i < engine.sourceCount(); ++i) {
    const auto& c = engine.counters(i);
    const auto& s = engine.source(i);
    std::printf("%s: %llu read, %llu used", s.name().c_str(), static_cast<unsigned long long>(c.read),
                static_cast<unsigned long long>(c.used()));
    for (int r = 0; r < stream::kRejectCount; ++r)
      if (c.rejected[std::size_t(r)])
        std::printf(", %llu %s", static_cast<unsigned long long>(c.rejected[std::size_t(r)]),
                    io::rejectText(stream::Reject(r)));
    std::printf("\n");
    auto issues = s.issues();
    for (std::size_t k = 0; k < issues.size() && k < 5; ++k) std::printf("    rejected %s\n", issues[k].c_str());
  }
}

/// The core's health counters that are not zero, one per line.
inline void printCoreHealth(const core::Health& h) {
  std::printf("core health (inputs by outcome):\n");
  for (int s = 0; s < core::kStatusCount; ++s)
    if (h.by_status[std::size_t(s)])
      std::printf("  %-22s %llu\n", core::statusName(core::Status(s)),
                  static_cast<unsigned long long>(h.by_status[std::size_t(s)]));
}

}  // namespace boresight::cli
