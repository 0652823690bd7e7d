// Inter-boresight angles of star camera heads from SCA1A records (and the nominal ones from QSA1B).
// Uses the conventions of core/conventions.h: SCA1A q = q_I_Si, QSA1B q = q_Si_B.
#pragma once

#include <boresight/core/conventions.h>
#include <boresight/io/level1.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
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

}  // namespace boresight::io
