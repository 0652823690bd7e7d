// boresight::calib - builds a CalibrationSpan from the same epochs the core sees: per-head CRN angular
// accelerations in each head's frame (core::AttitudeRates per head), the accelerometer's through the
// same CRN on the same tags (core::AccAngularFilter), the pair means (core::RelativeAttitudeMeans).
// Bounded memory: observations are decimated to about one per CRN correlation length.
//
// Producers: the replay engine (Level-1 files, LCM logs) via `boresight calibrate`, the node's worker,
// the Monte Carlo bench. Owned by the solver's author; the CLI only calls it.
#pragma once

#include "boresight/calib/problem.h"
#include "boresight/core/pipeline.h"

#include <string>

namespace boresight::calib {

struct SpanOptions {
  double decimation_s = 10.0;          ///< keep one observation per this interval (CRN correlation)
  std::size_t max_observations = 0;    ///< 0 = no limit; else the oldest are dropped
};

class SpanBuilder {
 public:
  /// The core configuration gives heads, nominal mountings, C_B_A and the CRN. False with *error.
  bool configure(const core::PipelineConfig& cfg, const SpanOptions& opt, std::string* error);
  void pushHeads(const core::HeadEpoch& e);
  void pushAcc(TimeUs t, const Vec3& a_A);
  /// End of data: completes what the filters still hold.
  void finish();
  const CalibrationSpan& span() const;
};

}  // namespace boresight::calib
