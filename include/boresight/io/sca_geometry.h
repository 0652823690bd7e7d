// Inter-boresight angles of star camera heads from SCA1A records (and the nominal ones from QSA1B).
// Uses the conventions of core/conventions.h: SCA1A q = q_I_Si, QSA1B q = q_Si_B.
#pragma once

#include <boresight/core/conventions.h>
#include <boresight/io/level1.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <utility>
#include <vector>

namespace boresight::io {

struct PairIba {
  int head_a = 0, head_b = 0;
  std::size_t epochs = 0;        ///< epochs where both heads delivered a quaternion
  double mean_deg = NAN;         ///< mean inter-boresight angle
  double std_arcsec = NAN;       ///< its sample standard deviation
  std::optional<double> nominal_deg;   ///< from QSA1B alignment, when given
  std::optional<double> offset_arcsec; ///< mean - nominal
};

/// A head's alignment valid at t: the latest QSA1B record of the head at or before t, else its
/// earliest record; nullptr when the head has none. (QSA1B may hold a history of alignments.)
inline const QsaRecord* alignmentAt(const std::vector<QsaRecord>& qsa, int head, TimeUs t) {
  const QsaRecord* best = nullptr;
  for (const auto& q : qsa) {
    if (q.sensor != head) continue;
    if (!best) {
      best = &q;
      continue;
    }
    const bool q_valid = q.t <= t, best_valid = best->t <= t;
    if ((q_valid && (!best_valid || q.t >= best->t)) || (!q_valid && !best_valid && q.t < best->t)) best = &q;
  }
  return best;
}

/// Angle between the boresights b_a = R(q_a) axis and b_b = R(q_b) axis (radians), robust near 0 and pi.
inline double boresightAngle(const Quat& q_I_Sa, const Quat& q_I_Sb, const Vec3& axis) {
  Vec3 a = q_I_Sa.normalized() * axis, b = q_I_Sb.normalized() * axis;
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

/// Per head pair statistics over common epochs (same time tag). Heads are taken from the records.
inline std::vector<PairIba> interBoresightAngles(const std::vector<Sca1aRecord>& recs,
                                                 const std::vector<QsaRecord>* qsa = nullptr,
                                                 const Vec3& axis = boresightDefault()) {
  std::map<TimeUs, std::map<int, Quat>> epochs;
  for (const auto& r : recs) epochs[r.t][r.head] = quatFromScalarFirst(r.q);
  std::vector<int> heads;
  for (const auto& r : recs)
    if (std::find(heads.begin(), heads.end(), int(r.head)) == heads.end()) heads.push_back(r.head);
  std::sort(heads.begin(), heads.end());
  std::vector<PairIba> out;
  for (std::size_t i = 0; i < heads.size(); ++i)
    for (std::size_t j = i + 1; j < heads.size(); ++j) {
      PairIba p;
      p.head_a = heads[i];
      p.head_b = heads[j];
      double sum = 0, sum2 = 0, ref = NAN;
      for (const auto& e : epochs) {
        auto ia = e.second.find(p.head_a), ib = e.second.find(p.head_b);
        if (ia == e.second.end() || ib == e.second.end()) continue;
        double ang = boresightAngle(ia->second, ib->second, axis);
        if (std::isnan(ref)) ref = ang;  // accumulate about the first value: no cancellation
        sum += ang - ref;
        sum2 += (ang - ref) * (ang - ref);
        ++p.epochs;
      }
      if (p.epochs > 0) {
        double n = double(p.epochs), m = sum / n;
        p.mean_deg = (ref + m) / kRadPerDeg;
        p.std_arcsec = p.epochs > 1 ? std::sqrt(std::max(0.0, (sum2 - n * m * m) / (n - 1))) * kArcsecPerRad : 0.0;
      }
      if (qsa) {
        const TimeUs t0 = epochs.empty() ? 0 : epochs.begin()->first;
        const QsaRecord *qa = alignmentAt(*qsa, p.head_a, t0), *qb = alignmentAt(*qsa, p.head_b, t0);
        if (qa && qb) {
          // q_Si_B: the boresight in B is R(q)^T axis.
          Vec3 ba = quatFromScalarFirst(qa->q).normalized().conjugate() * axis;
          Vec3 bb = quatFromScalarFirst(qb->q).normalized().conjugate() * axis;
          double nom = std::atan2(ba.cross(bb).norm(), ba.dot(bb));
          p.nominal_deg = nom / kRadPerDeg;
          if (p.epochs > 0) p.offset_arcsec = (p.mean_deg - *p.nominal_deg) * 3600.0;
        }
      }
      out.push_back(p);
    }
  return out;
}


/// interBoresightAngles() over records handed in one at a time, in time order, in memory that does
/// not grow with the span (for `inspect` of full-day files). The results are bit-identical to
/// interBoresightAngles() on the same records. add() returns false (and ignores the record) when a
/// record is older than the previous one: the caller then needs the whole-file function.
class IbaAccumulator {
 public:
  explicit IbaAccumulator(const Vec3& axis = boresightDefault()) : axis_(axis) {}
  bool add(const Sca1aRecord& r) {
    if (any_ && r.t < epoch_t_) return false;
    if (!any_ || r.t != epoch_t_) {
      flushEpoch();
      epoch_t_ = r.t;
      if (!any_) first_t_ = r.t;
      any_ = true;
    }
    const int head = r.head;
    if (std::find(heads_.begin(), heads_.end(), head) == heads_.end()) heads_.push_back(head);
    const Quat q = quatFromScalarFirst(r.q);
    for (auto& e : epoch_)
      if (e.first == head) {
        e.second = q;  // a repeated head in one epoch: the last one counts (as in the map version)
        return true;
      }
    epoch_.emplace_back(head, q);
    return true;
  }
  /// Heads seen, in order of appearance.
  const std::vector<int>& heads() const { return heads_; }
  std::vector<PairIba> finish(const std::vector<QsaRecord>* qsa = nullptr) {
    flushEpoch();
    std::vector<int> heads = heads_;
    std::sort(heads.begin(), heads.end());
    std::vector<PairIba> out;
    for (std::size_t i = 0; i < heads.size(); ++i)
      for (std::size_t j = i + 1; j < heads.size(); ++j) {
        PairIba p;
        p.head_a = heads[i];
        p.head_b = heads[j];
        auto it = std::find_if(acc_.begin(), acc_.end(), [&](const Acc& a) { return a.a == p.head_a && a.b == p.head_b; });
        if (it != acc_.end() && it->n > 0) {
          p.epochs = it->n;
          double n = double(it->n), m = it->sum / n;
          p.mean_deg = (it->ref + m) / kRadPerDeg;
          p.std_arcsec = it->n > 1 ? std::sqrt(std::max(0.0, (it->sum2 - n * m * m) / (n - 1))) * kArcsecPerRad : 0.0;
        }
        if (qsa) {
          const QsaRecord *qa = alignmentAt(*qsa, p.head_a, first_t_), *qb = alignmentAt(*qsa, p.head_b, first_t_);
          if (qa && qb) {
            Vec3 ba = quatFromScalarFirst(qa->q).normalized().conjugate() * axis_;
            Vec3 bb = quatFromScalarFirst(qb->q).normalized().conjugate() * axis_;
            double nom = std::atan2(ba.cross(bb).norm(), ba.dot(bb));
            p.nominal_deg = nom / kRadPerDeg;
            if (p.epochs > 0) p.offset_arcsec = (p.mean_deg - *p.nominal_deg) * 3600.0;
          }
        }
        out.push_back(p);
      }
    return out;
  }

 private:
  struct Acc {
    int a, b;
    std::size_t n = 0;
    double ref = NAN, sum = 0, sum2 = 0;
  };
  void flushEpoch() {
    for (std::size_t i = 0; i < epoch_.size(); ++i)
      for (std::size_t j = 0; j < epoch_.size(); ++j) {
        if (epoch_[i].first >= epoch_[j].first) continue;
        const int a = epoch_[i].first, b = epoch_[j].first;
        auto it = std::find_if(acc_.begin(), acc_.end(), [&](const Acc& x) { return x.a == a && x.b == b; });
        if (it == acc_.end()) {
          acc_.push_back(Acc{a, b});
          it = acc_.end() - 1;
        }
        const double ang = boresightAngle(epoch_[i].second, epoch_[j].second, axis_);
        if (std::isnan(it->ref)) it->ref = ang;
        it->sum += ang - it->ref;
        it->sum2 += (ang - it->ref) * (ang - it->ref);
        ++it->n;
      }
    epoch_.clear();
  }
  Vec3 axis_;
  bool any_ = false;
  TimeUs epoch_t_ = 0, first_t_ = 0;
  std::vector<std::pair<int, Quat>> epoch_;
  std::vector<int> heads_;
  std::vector<Acc> acc_;
};

}  // namespace boresight::io
