// Slow noise of the heads through their pair residuals (head_colour.h).
#include "head_colour.h"

#include <boresight/model/minimise.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <thread>

namespace boresight::audit::detail {
namespace {

constexpr double kLog2Pi = 1.8378770664093453;
/// Threads of the fits' numerical gradients (model::minimiseBfgs): their evaluations are shared by two
/// threads where the machine has two cores (BORESIGHT_THREADS=1 keeps them on one, to compare or on a
/// shared machine); the fits' results do not depend on it.
int fitThreads() {
  const char* e = std::getenv("BORESIGHT_THREADS");
  if (e && std::atoi(e) == 1) return 1;
  return std::thread::hardware_concurrency() >= 2 ? 2 : 1;
}
const int kFitThreads = fitThreads();

/// The rows' map of the heads' states (3 per head slot, sensor axes): pairs (ref, o) in slot order.
Eigen::MatrixXd observationMap(const HeadColourModel& m, unsigned mask, int n) {
  Eigen::MatrixXd D = Eigen::MatrixXd::Zero(n, 3 * m.heads);
  int ref = 0;
  while (ref < m.heads && !((mask >> ref) & 1u)) ++ref;
  int j = 0;
  for (int o = ref + 1; o < m.heads && 3 * j < n; ++o) {
    if (!((mask >> o) & 1u)) continue;
    D.block<3, 3>(3 * j, 3 * o) = m.C_B_S[static_cast<std::size_t>(o)];
    D.block<3, 3>(3 * j, 3 * ref) = -m.C_B_S[static_cast<std::size_t>(ref)];
    ++j;
  }
  return D;
}

std::string fmtd(const char* f, double v) {
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

}  // namespace

bool HeadColourModel::coloured() const {
  for (int k = 0; k < heads; ++k)
    if (sigma_cross[static_cast<std::size_t>(k)] > 0 || sigma_about[static_cast<std::size_t>(k)] > 0) return true;
  return false;
}

std::string HeadColourModel::describe(const std::vector<int>& ids) const {
  std::string s;
  for (int k = 0; k < heads; ++k)
    s += "head " + std::to_string(static_cast<std::size_t>(k) < ids.size() ? ids[static_cast<std::size_t>(k)] : k + 1) + ": " + fmtd("%.2g", sigma_cross[static_cast<std::size_t>(k)] * kArcsecPerRad) + "\"/" +
         fmtd("%.2g", sigma_about[static_cast<std::size_t>(k)] * kArcsecPerRad) + "\" (cross/about); ";
  return s + "tau " + fmtd("%.0f", tau_s) + " s; white variance x" + fmtd("%.3g", white_factor);
}

HeadColourFilter::HeadColourFilter(const HeadColourModel& m, int columns) : m_(m), ns_(3 * m.heads) {
  X_ = Eigen::MatrixXd::Zero(ns_, columns);
  q_ = Eigen::VectorXd::Zero(ns_);
  for (int k = 0; k < m.heads; ++k) {
    const double c = m.sigma_cross[static_cast<std::size_t>(k)], a = m.sigma_about[static_cast<std::size_t>(k)];
    q_[3 * k] = q_[3 * k + 1] = c * c;
    q_[3 * k + 2] = a * a;
  }
  P_ = q_.asDiagonal();
}

void HeadColourFilter::predict(double t) {
  if (!started_) {
    started_ = true;
    t_prev_ = t;
    return;
  }
  const double dt = t - t_prev_;
  t_prev_ = t;
  if (!(dt > 0)) return;
  const double phi = std::exp(-dt / m_.tau_s);
  X_ *= phi;
  P_ *= phi * phi;
  P_.diagonal() += (1 - phi * phi) * q_;
}

void HeadColourFilter::skip(double t) { predict(t); }

double HeadColourFilter::whiten(const PairBlock& b, Eigen::Ref<Eigen::MatrixXd> rows) {
  predict(b.t);
  const Eigen::MatrixXd D = observationMap(m_, b.mask, b.n);
  const Eigen::MatrixXd PDt = P_ * D.transpose();
  Eigen::MatrixXd S = D * PDt + m_.white_factor * b.S;
  const Eigen::LLT<Eigen::MatrixXd> llt(S);
  rows -= D * X_;
  const Eigen::MatrixXd K = llt.solve(PDt.transpose()).transpose();  // P D' S^-1
  X_ += K * rows;
  P_ -= K * PDt.transpose();
  P_ = 0.5 * (P_ + P_.transpose()).eval();
  llt.matrixL().solveInPlace(rows);
  return 2 * llt.matrixLLT().diagonal().array().log().sum();
}

HeadColourData mergeForFit(const std::vector<PairBlock>& blocks, int q, const BlockRows& rows, double superbin_s,
                           int profiled) {
  HeadColourData d;
  d.superbin_s = superbin_s;
  struct Acc {
    Eigen::MatrixXd A, a;  // sum S^-1, sum S^-1 [X y]
    double tsum = 0;
    int count = 0;
  };
  std::map<unsigned, Acc> cur;
  std::vector<Eigen::MatrixXd> vals;  // per merged block: n x (q + 1)
  auto flush = [&] {
    for (auto& [mask, acc] : cur) {
      PairBlock m;
      m.mask = mask;
      m.n = static_cast<int>(acc.A.rows());
      m.t = acc.tsum / acc.count;
      const Eigen::LLT<Eigen::MatrixXd> llt(acc.A);
      m.S = llt.solve(Eigen::MatrixXd::Identity(m.n, m.n));
      m.row0 = d.rows;
      d.rows += m.n;
      vals.push_back(llt.solve(acc.a));
      d.blocks.push_back(std::move(m));
    }
    cur.clear();
  };
  long idx = -1;
  Eigen::MatrixXd v;
  for (const auto& b : blocks) {
    if (b.held) continue;
    const long k = static_cast<long>(std::floor(b.t / superbin_s));
    if (k != idx) flush(), idx = k;
    const Eigen::MatrixXd Si = b.S.llt().solve(Eigen::MatrixXd::Identity(b.n, b.n));
    v.resize(b.n, q + 1);
    rows(b, v);
    auto& acc = cur[b.mask];
    if (acc.count == 0) acc.A = Eigen::MatrixXd::Zero(b.n, b.n), acc.a = Eigen::MatrixXd::Zero(b.n, q + 1);
    acc.A += Si;
    acc.a += Si * v;
    acc.tsum += b.t;
    ++acc.count;
  }
  flush();
  d.X.resize(d.rows, q);
  d.y.resize(d.rows);
  for (std::size_t i = 0; i < d.blocks.size(); ++i) {
    const auto& b = d.blocks[i];
    d.X.middleRows(b.row0, b.n) = vals[i].leftCols(q);
    d.y.segment(b.row0, b.n) = vals[i].col(q);
  }
  std::vector<int> all(static_cast<std::size_t>(profiled < 0 ? q : std::min(profiled, q)));
  for (std::size_t j = 0; j < all.size(); ++j) all[j] = static_cast<int>(j);
  setBasis(d, all);
  return d;
}

void setBasis(HeadColourData& d, const std::vector<int>& cols) {
  const int q = static_cast<int>(cols.size());
  Eigen::MatrixXd Xm(d.rows, q);
  for (int j = 0; j < q; ++j) Xm.col(j) = d.X.col(cols[static_cast<std::size_t>(j)]);
  // the columns reduced to an orthonormal basis (white metric) of their span
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(q, q);
  for (const auto& b : d.blocks) {
    Eigen::MatrixXd w = Xm.middleRows(b.row0, b.n);
    b.S.llt().matrixL().solveInPlace(w);
    G.noalias() += w.transpose() * w;
  }
  if (q == 0) {
    d.B = Eigen::MatrixXd(d.rows, 0);
    return;
  }
  const Eigen::VectorXd sc = G.diagonal().cwiseMax(1e-300).cwiseSqrt().cwiseInverse();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(sc.asDiagonal() * G * sc.asDiagonal());
  const double emax = es.eigenvalues().maxCoeff();
  std::vector<int> keep;
  for (int j = 0; j < q; ++j)
    if (es.eigenvalues()[j] > 1e-9 * emax) keep.push_back(j);
  d.B.resize(d.rows, static_cast<int>(keep.size()));
  for (std::size_t j = 0; j < keep.size(); ++j)
    d.B.col(static_cast<int>(j)) = Xm * (sc.asDiagonal() * es.eigenvectors().col(keep[j])) / std::sqrt(es.eigenvalues()[keep[j]]);
}

std::vector<double> stepReductions(double white_factor, const HeadColourData& d, const Eigen::MatrixXd& M,
                                   const std::vector<double>& taus) {
  const int r = static_cast<int>(d.B.cols()), g = static_cast<int>(M.cols()), w = r + g + 1;
  // per block its whitened [B M y]' [B M y]; the blocks' times are non-decreasing (super-bin order)
  const int nb = static_cast<int>(d.blocks.size());
  std::vector<Eigen::MatrixXd> blockG(static_cast<std::size_t>(nb));
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(w, w), rows;
  for (int i = 0; i < nb; ++i) {
    const auto& b = d.blocks[static_cast<std::size_t>(i)];
    rows.resize(b.n, w);
    rows.leftCols(r) = d.B.middleRows(b.row0, b.n);
    rows.middleCols(r, g) = M.middleRows(b.row0, b.n);
    rows.col(w - 1) = d.y.segment(b.row0, b.n);
    const Eigen::MatrixXd S = white_factor * b.S;
    S.llt().matrixL().solveInPlace(rows);
    blockG[static_cast<std::size_t>(i)] = rows.transpose() * rows;
    G += blockG[static_cast<std::size_t>(i)];
  }
  const Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> bb(G.topLeftCorner(r, r));
  const Eigen::VectorXd by = G.col(w - 1).head(r);
  // a step at tau: the signature from tau on; its Gram entries are sums over the blocks from tau on
  std::vector<double> out(taus.size(), 0.0);
  std::vector<std::size_t> order(taus.size());
  for (std::size_t j = 0; j < taus.size(); ++j) order[j] = j;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return taus[a] > taus[b]; });
  Eigen::MatrixXd suf = Eigen::MatrixXd::Zero(g, w);  // rows of [B M y]' restricted to the signature, from tau on
  int i = nb - 1;
  for (std::size_t j : order) {
    for (; i >= 0 && d.blocks[static_cast<std::size_t>(i)].t >= taus[j]; --i) suf += blockG[static_cast<std::size_t>(i)].middleRows(r, g);
    const Eigen::MatrixXd zb = suf.leftCols(r);
    Eigen::MatrixXd zz = Eigen::MatrixXd::Zero(g, g);
    // the step's own Gram: sum over blocks from tau on of M' M (the middle block of suf, same rows)
    zz = suf.middleCols(r, g);
    Eigen::VectorXd zy = suf.col(w - 1);
    if (r > 0) {
      const Eigen::MatrixXd P = bb.solve(zb.transpose());  // r x g
      zz -= zb * P;
      zy -= P.transpose() * by;
    }
    out[j] = zy.dot(zz.completeOrthogonalDecomposition().solve(zy));
  }
  return out;
}

double remlM2ll(const HeadColourModel& m, const HeadColourData& d) {
  const int r = static_cast<int>(d.B.cols());
  HeadColourFilter f(m, r + 1);
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(r + 1, r + 1);
  double logdet = 0;
  Eigen::MatrixXd rows;
  for (const auto& b : d.blocks) {
    rows.resize(b.n, r + 1);
    rows.leftCols(r) = d.B.middleRows(b.row0, b.n);
    rows.col(r) = d.y.segment(b.row0, b.n);
    logdet += f.whiten(b, rows);
    G.selfadjointView<Eigen::Lower>().rankUpdate(rows.transpose());
  }
  G = G.selfadjointView<Eigen::Lower>();
  double m2ll = logdet + d.rows * kLog2Pi + G(r, r);
  if (r > 0) {
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(G.topLeftCorner(r, r));
    const Eigen::VectorXd g = G.col(r).head(r);
    m2ll -= g.dot(ldlt.solve(g));
    if (d.reml) m2ll += ldlt.vectorD().array().max(1e-300).log().sum();
  }
  return m2ll;
}

HeadColourModel fitWhiteFactor(const HeadColourData& d, HeadColourModel m, double* m2ll) {
  const double lo = std::log(0.05), hi = std::log(20.0);
  const model::Objective fw = [&](const Eigen::VectorXd& x) {
    const double c = std::clamp(x[0], lo, hi);
    HeadColourModel t = m;
    t.white_factor = std::exp(c);
    return remlM2ll(t, d) + 1e3 * (x[0] - c) * (x[0] - c);
  };
  bool conv = false;
  Eigen::VectorXd xw = Eigen::VectorXd::Constant(1, std::log(std::max(m.white_factor, 0.05)));
  xw = model::minimiseBfgs(fw, xw, 30, &conv, nullptr, kFitThreads);
  m.white_factor = std::exp(std::clamp(xw[0], lo, hi));
  if (m2ll) *m2ll = remlM2ll(m, d);
  return m;
}

HeadColourFit fitHeadColour(const HeadColourData& d, const HeadColourModel& start) {
  HeadColourFit out;
  const int H = start.heads;
  std::atomic<int> evals{0};  // the objective runs on two threads (kFitThreads)
  // white factor alone
  HeadColourModel w = start;
  w.sigma_cross.fill(0);
  w.sigma_about.fill(0);
  const auto clampLog = [](double x, double lo, double hi, double& pen) {
    const double c = std::clamp(x, lo, hi);
    pen += 1e3 * (x - c) * (x - c);
    return c;
  };
  bool conv = false;
  w = fitWhiteFactor(d, w, &out.m2ll_white);
  out.white = w;
  // coloured: [log white factor, log sigma_cross per head, log sigma_about per head, log tau]
  double s_ref = 0;  // typical white standard deviation of a merged row
  {
    std::vector<double> v;
    for (const auto& b : d.blocks)
      for (int i = 0; i < b.n; ++i) v.push_back(std::sqrt(std::max(b.S(i, i), 1e-300)));
    if (!v.empty()) {
      std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
      s_ref = v[v.size() / 2];
    }
  }
  double span = 0;
  if (!d.blocks.empty()) span = d.blocks.back().t - d.blocks.front().t;
  const double lo_s = std::log(std::max(s_ref, 1e-12) * 1e-3), hi_s = std::log(std::max(s_ref, 1e-12) * 1e2);
  const double lo_t = std::log(2 * d.superbin_s), hi_t = std::log(std::max(4 * d.superbin_s, span));
  const int np = 2 + 2 * H;
  const auto modelOf = [&](const Eigen::VectorXd& x, double& pen) {
    HeadColourModel m = start;
    m.white_factor = std::exp(clampLog(x[0], std::log(0.05), std::log(20.0), pen));
    for (int k = 0; k < H; ++k) {
      m.sigma_cross[static_cast<std::size_t>(k)] = std::exp(clampLog(x[1 + k], lo_s, hi_s, pen));
      m.sigma_about[static_cast<std::size_t>(k)] = std::exp(clampLog(x[1 + H + k], lo_s, hi_s, pen));
    }
    m.tau_s = std::exp(clampLog(x[np - 1], lo_t, hi_t, pen));
    return m;
  };
  const model::Objective fc = [&](const Eigen::VectorXd& x) {
    double pen = 0;
    const HeadColourModel m = modelOf(x, pen);
    ++evals;
    return remlM2ll(m, d) + pen;
  };
  Eigen::VectorXd x0 = Eigen::VectorXd::Zero(std::max(np, 2));
  x0[0] = std::log(w.white_factor);
  for (int k = 0; k < H; ++k) {
    const double c = start.sigma_cross[static_cast<std::size_t>(k)], a = start.sigma_about[static_cast<std::size_t>(k)];
    x0[1 + k] = std::clamp(std::log(c > 0 ? c : 0.5 * s_ref), lo_s, hi_s);
    x0[1 + H + k] = std::clamp(std::log(a > 0 ? a : 0.5 * s_ref), lo_s, hi_s);
  }
  x0[np - 1] = std::clamp(std::log(start.tau_s > 0 ? start.tau_s : 600.0), lo_t, hi_t);
  const Eigen::VectorXd x = model::minimiseBfgs(fc, x0, 40, &conv, nullptr, kFitThreads);
  double pen = 0;
  out.model = modelOf(x, pen);
  out.m2ll = remlM2ll(out.model, d);
  if (out.m2ll > out.m2ll_white) {  // no colour found: the white model with zero-level states
    out.model = w;
    out.m2ll = out.m2ll_white;
  }
  out.params = 2 * H + 1;
  out.evaluations = evals.load();
  out.converged = conv;
  return out;
}

}  // namespace boresight::audit::detail
