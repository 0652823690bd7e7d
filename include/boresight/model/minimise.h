// Unconstrained minimisers of smooth objectives of a few parameters (the noise fits': model/noise.h
// and the audit's head-noise fit). Parameters are on a fitting scale where one unit is a large step
// (logarithms of levels and times).
#pragma once

#include <Eigen/Core>

#include <functional>
#include <string>

namespace boresight::model {

using Objective = std::function<double(const Eigen::VectorXd&)>;

/// Central-difference gradient of f at x with step h. With threads > 1 the 2 n evaluations are shared
/// by two threads (f must then be safe to call concurrently); the result is the same to the bit (each
/// evaluation is the same arithmetic, and the differences are formed after both finish).
Eigen::VectorXd centralGradient(const Objective& f, const Eigen::VectorXd& x, double h, int threads = 1);

/// BFGS with a step capped at one unit of the fitting scale and an Armijo backtracking line search;
/// converged when the quasi-Newton decrement g^T H g falls below 1e-3 (for f = -2 log L: far below
/// the one unit a standard error spans). `why` (optional) says why not converged. `threads` as in
/// centralGradient: the minimiser's path and result do not depend on it.
Eigen::VectorXd minimiseBfgs(const Objective& f, Eigen::VectorXd x, int max_iter, bool* converged, std::string* why,
                             int threads = 1);

}  // namespace boresight::model
