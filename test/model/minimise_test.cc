// The shared minimiser (model/minimise.h): BFGS finds the minimum of a known function, and the
// numerical gradient on two threads is the one-thread gradient to the bit (the audit's head-noise fits
// run on two threads and must give the same results), an exception in either thread reaches the caller.
#include <boresight/model/minimise.h>
#include <boresight/model/parallel.h>

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <stdexcept>
#include <thread>
#include <vector>

namespace {

using boresight::model::centralGradient;
using boresight::model::minimiseBfgs;
using boresight::model::Objective;

/// A smooth function of four parameters with its minimum at (1, -2, 0.5, 3): a scaled Rosenbrock-like
/// valley plus a quadratic, rounding-sensitive enough that a changed order of arithmetic would show.
double valley(const Eigen::VectorXd& x) {
  const double a = x[1] + 2 - 0.3 * (x[0] - 1) * (x[0] - 1);
  return std::pow(x[0] - 1, 2) + 10 * a * a + std::exp(x[2] - 0.5) - (x[2] - 0.5) + 0.1 * std::pow(x[3] - 3, 4) +
         0.5 * std::pow(x[3] - 3, 2);
}

TEST(Minimise, TheGradientOnTwoThreadsIsTheOneThreadGradientToTheBit) {
  std::atomic<int> calls{0};
  const Objective f = [&](const Eigen::VectorXd& x) {
    ++calls;
    return valley(x);
  };
  const Eigen::VectorXd x = (Eigen::VectorXd(4) << 0.3, -1.1, 2.0, 7.5).finished();
  const Eigen::VectorXd g1 = centralGradient(f, x, 1e-4, 1);
  const int serial_calls = calls.exchange(0);
  const Eigen::VectorXd g2 = centralGradient(f, x, 1e-4, 2);
  EXPECT_EQ(calls.load(), serial_calls);
  EXPECT_EQ(serial_calls, 8);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(g1[i], g2[i]) << i;  // bitwise: the same evaluations
  // and it is the gradient: against the analytic one at a point where it is easy
  const Eigen::VectorXd xm = (Eigen::VectorXd(4) << 1, -2, 0.5, 4).finished();
  const Eigen::VectorXd gm = centralGradient(f, xm, 1e-4, 2);
  EXPECT_NEAR(gm[0], 0, 1e-6);
  EXPECT_NEAR(gm[1], 0, 1e-6);
  EXPECT_NEAR(gm[2], 0, 1e-6);
  EXPECT_NEAR(gm[3], 0.4 + 1.0, 1e-6);  // d/dx (0.1 u^4 + 0.5 u^2) at u = 1
}

TEST(Minimise, BfgsFindsTheMinimumAndTakesTheSamePathOnTwoThreads) {
  const Objective f = valley;
  const Eigen::VectorXd x0 = (Eigen::VectorXd(4) << -1, 1, 2, 0).finished();
  bool c1 = false, c2 = false;
  const Eigen::VectorXd x1 = minimiseBfgs(f, x0, 200, &c1, nullptr, 1);
  const Eigen::VectorXd x2 = minimiseBfgs(f, x0, 200, &c2, nullptr, 2);
  EXPECT_TRUE(c1);
  EXPECT_TRUE(c2);
  // converged means the quasi-Newton decrement is under 1e-3: the value within about that of the
  // minimum (1 at (1, -2, 0.5, 3)), the parameters within a few hundredths where the curvature is ~1
  EXPECT_LT(valley(x1) - 1.0, 1e-3);
  EXPECT_NEAR(x1[0], 1, 0.05);
  EXPECT_NEAR(x1[1], -2, 0.05);
  EXPECT_NEAR(x1[2], 0.5, 0.05);
  EXPECT_NEAR(x1[3], 3, 0.05);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(x1[i], x2[i]) << i;
}

TEST(Minimise, AnExceptionInTheOtherThreadReachesTheCaller) {
  // the -h side runs on the second thread: make only it throw
  const Eigen::VectorXd x = (Eigen::VectorXd(2) << 0.0, 0.0).finished();
  const Objective f = [](const Eigen::VectorXd& y) {
    if (y[1] < 0) throw std::runtime_error("objective failed");
    return y.squaredNorm();
  };
  EXPECT_THROW(centralGradient(f, x, 1e-4, 2), std::runtime_error);
  EXPECT_THROW(centralGradient(f, x, 1e-4, 1), std::runtime_error);
}

TEST(ParallelFor, EveryIndexRunsOnceAndTheFirstExceptionReachesTheCaller) {
  for (const unsigned threads : {1u, 2u, 5u}) {
    std::vector<std::atomic<int>> hits(1000);
    boresight::model::parallelFor(hits.size(), threads, [&](std::size_t i) { ++hits[i]; });
    for (std::size_t i = 0; i < hits.size(); ++i) ASSERT_EQ(hits[i].load(), 1) << "index " << i << ", " << threads << " threads";
  }
  boresight::model::parallelFor(0, 2, [](std::size_t) { FAIL() << "no index to run"; });
  std::atomic<int> ran{0};
  EXPECT_THROW(boresight::model::parallelFor(100, 2,
                                             [&](std::size_t i) {
                                               ++ran;
                                               if (i == 7) throw std::runtime_error("index 7");
                                             }),
               std::runtime_error);
  EXPECT_LE(ran.load(), 100);
  EXPECT_GE(ran.load(), 8);
}

}  // namespace
