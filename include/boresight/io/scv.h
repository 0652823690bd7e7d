// SCV1A star vectors (the simulator's product, io::ScvRecord in level1.h) as core Wahba inputs.
#pragma once

#include <boresight/core/wahba.h>
#include <boresight/io/level1.h>

#include <cstddef>
#include <vector>

namespace boresight::io {

/// Fills `out` with the records recs[begin..) that share the time tag of recs[begin] (an SCV1A file
/// is written in time order, all heads of one tag together) and returns the index after them. Stars
/// beyond core::kMaxStarInputs are skipped and counted in *dropped (if given). sigma_rad is 0: the
/// head's configured sigma. Returns begin when begin is past the end.
std::size_t nextStarEpoch(const std::vector<ScvRecord>& recs, std::size_t begin, core::StarEpoch& out,
                          std::size_t* dropped = nullptr);

}  // namespace boresight::io
