// Minimisers shared by the noise fits (model/minimise.h).
#include <boresight/model/minimise.h>

#include <cmath>
#include <exception>
#include <limits>
#include <thread>

namespace boresight::model {
namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}  // namespace

Eigen::VectorXd centralGradient(const Objective& f, const Eigen::VectorXd& x, double h, int threads) {
  const Eigen::Index n = x.size();
  Eigen::VectorXd fp(n), fm(n);
  // the evaluations at x + h e_i (sign +1) or x - h e_i (sign -1), every i
  const auto side = [&](double sign, Eigen::VectorXd& out) {
    Eigen::VectorXd a = x;
    for (Eigen::Index i = 0; i < n; ++i) {
      a[i] = x[i] + sign * h;
      out[i] = f(a);
      a[i] = x[i];
    }
  };
  if (threads > 1 && n > 0) {
    std::exception_ptr failed;
    std::thread other([&] {
      try {
        side(-1, fm);
      } catch (...) {
        failed = std::current_exception();
      }
    });
    side(+1, fp);
    other.join();
    if (failed) std::rethrow_exception(failed);
  } else {
    for (Eigen::Index i = 0; i < n; ++i) {  // as before: +h then -h per parameter
      Eigen::VectorXd a = x, b = x;
      a[i] += h;
      b[i] -= h;
      fp[i] = f(a);
      fm[i] = f(b);
    }
  }
  return (fp - fm) / (2 * h);
}

Eigen::VectorXd minimiseBfgs(const Objective& f, Eigen::VectorXd x, int max_iter, bool* converged, std::string* why, int threads) {
  const auto n = x.size();
  double fx = f(x);
  Eigen::VectorXd g = centralGradient(f, x, 1e-4, threads);
  Eigen::MatrixXd H = Eigen::MatrixXd::Identity(n, n);
  *converged = false;
  for (int it = 0; it < max_iter; ++it) {
    Eigen::VectorXd d = -H * g;
    if (g.dot(d) >= 0) {
      H.setIdentity();
      d = -g;
    }
    const double dmax = d.cwiseAbs().maxCoeff();
    if (dmax > 1.0) d /= dmax;
    double t = 1.0, fn = kInf;
    Eigen::VectorXd xn = x;
    const double slope = g.dot(d);
    int k = 0;
    for (; k < 40; ++k) {
      xn = x + t * d;
      fn = f(xn);
      if (std::isfinite(fn) && fn <= fx + 1e-4 * t * slope) break;
      t *= 0.5;
    }
    if (k == 40) {
      // no decrease along the search direction: a minimum to the precision of the gradient
      *converged = g.cwiseAbs().maxCoeff() < 1e-2 * std::max(1.0, std::sqrt(std::abs(fx)));
      if (!*converged && why) *why = "the line search found no decrease";
      return x;
    }
    const Eigen::VectorXd s = xn - x;
    const Eigen::VectorXd gn = centralGradient(f, xn, 1e-4, threads);
    const Eigen::VectorXd y = gn - g;
    const double sy = s.dot(y);
    const double df = fx - fn;
    x = xn;
    fx = fn;
    g = gn;
    if (sy > 1e-12) {
      if (it == 0) H *= sy / y.squaredNorm();
      const double rho = 1.0 / sy;
      const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(n, n);
      H = (I - rho * s * y.transpose()) * H * (I - rho * y * s.transpose()) + rho * s * s.transpose();
    }
    // Converged when the quasi-Newton decrement g^T H g (the expected further decrease of -2 log L,
    // times two) is far below the one unit of -2 log L that a standard error spans.
    if ((it >= 1 && g.dot(H * g) < 1e-3) || (df < 1e-7 && s.cwiseAbs().maxCoeff() < 1e-6)) {
      *converged = true;
      return x;
    }
  }
  if (why) *why = "no convergence in " + std::to_string(max_iter) + " iterations";
  return x;
}

}  // namespace boresight::model
