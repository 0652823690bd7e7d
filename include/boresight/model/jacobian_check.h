// The Jacobian check of a Ceres problem's cost functors: each residual block's automatic derivatives
// against central differences of the same functor (ceres::GradientChecker), at the parameter values
// the problem holds. Header-only: for the solvers that build Ceres problems (method A's CRN solver,
// calib::checkJacobians; method C's refinement, ground::checkJacobians), which link Ceres.
#pragma once

#include <ceres/ceres.h>
#include <ceres/gradient_checker.h>

#include <algorithm>
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

namespace boresight::model {

/// One functor's result.
struct JacobianCheck {
  std::string functor;
  std::size_t blocks = 0, failed = 0;  ///< probed, and outside the relative precision
  double max_relative_error = 0;       ///< over the probed blocks
  std::string first_error;             ///< Ceres's log of the first failure
};

/// Probes up to max_blocks of `ids` (spread over them) and appends the result under `name` to *out
/// (nothing when ids is empty).
inline void probeJacobians(const ceres::Problem& problem, const std::vector<ceres::ResidualBlockId>& ids, const std::string& name,
                           std::size_t max_blocks, double relative_precision, std::vector<JacobianCheck>* out) {
  if (ids.empty()) return;
  JacobianCheck c;
  c.functor = name;
  const std::size_t every = std::max<std::size_t>(1, ids.size() / std::max<std::size_t>(max_blocks, 1));
  std::vector<double*> params;
  const ceres::NumericDiffOptions nd;
  for (std::size_t k = 0; k < ids.size() && c.blocks < max_blocks; k += every) {
    problem.GetParameterBlocksForResidualBlock(ids[k], &params);
    const ceres::GradientChecker checker(problem.GetCostFunctionForResidualBlock(ids[k]),
                                         static_cast<const std::vector<const ceres::Manifold*>*>(nullptr), nd);
    ceres::GradientChecker::ProbeResults r;
    const bool ok = checker.Probe(params.data(), relative_precision, &r);
    ++c.blocks;
    c.max_relative_error = std::max(c.max_relative_error, r.maximum_relative_error);
    if (!ok) {
      if (c.failed == 0) c.first_error = r.error_log;
      ++c.failed;
    }
  }
  out->push_back(std::move(c));
}

}  // namespace boresight::model
