#include <boresight/model/orbit_context.h>
#include <boresight/model/random.h>
#include <boresight/model/rotation.h>
#include <boresight/model/stochastic.h>
#include <boresight/model/ephemeris.h>
#include <boresight/sim/simulator.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace boresight::sim {
namespace {

using model::CounterRng;
using model::Stream;

/// A sensor's tags in time order: the model's pattern (model::TagModel) with a cursor.
struct TagStream {
  model::TagModel m;
  std::uint64_t n = 0;
  TimeUs cached = 0;  ///< tag(n), updated by advance()
  std::uint64_t advance() {
    const std::uint64_t k = n++;
    cached = m.tag(n);
    return k;
  }
  TimeUs next() const { return cached; }
};

TagStream makeTags(TimeUs start, double rate_hz, TimeUs offset_us, double drift, double jitter, std::uint64_t seed,
                   Stream stream) {
  TagStream s;
  s.m = model::makeTagModel(start, rate_hz, offset_us, drift, jitter, seed, stream);
  s.cached = s.m.tag(0);
  return s;
}

/// Runs of consecutive missing samples of one sensor (truth.yaml's realised gap intervals).
struct MissingRuns {
  std::vector<model::Interval>* runs = nullptr;
  std::uint64_t* count = nullptr;
  bool open = false;
  void sample(double t, bool missing) {
    if (missing && !open) {
      open = true;
      ++*count;
      if (runs->size() < kMaxRecordedMissingRuns) runs->push_back({t, t});
    } else if (!missing && open) {
      close(t);
    }
  }
  void close(double t) {
    if (open && *count <= kMaxRecordedMissingRuns) runs->back().end_s = t;
    open = false;
  }
};

}  // namespace

Simulator::Simulator() = default;
Simulator::~Simulator() = default;

bool Simulator::init(const Scenario& sc, std::uint64_t seed, double duration_s, std::string* error) {
  sc_ = sc;
  seed_ = seed;
  duration_s_ = duration_s > 0 ? duration_s : sc.duration_s;
  stats_ = SimStats{};
  if (!stars_.load(sc_.star_catalogue, error)) return false;
  for (const auto& h : sc_.heads)
    if (h.limiting_mag > stars_.faintest() + 1e-9) {
      if (error)
        *error = sc_.file + ": head " + std::to_string(h.id) + ": limiting_magnitude " + std::to_string(h.limiting_mag) +
                 " is fainter than the star catalogue's limit " + std::to_string(stars_.faintest());
      return false;
    }
  orbit_ = makeOrbit(sc_.orbit, toSeconds(sc_.start), duration_s_ + 5.0, error);
  if (!orbit_) return false;
  heads_.clear();
  for (auto h : sc_.heads) {
    if (sc_.mounting_error_sigma_rad > 0) {
      const CounterRng r(seed, Stream::MountingDraw, static_cast<std::uint64_t>(h.id));
      h.mounting_error_rad += sc_.mounting_error_sigma_rad * Vec3(r.normal(0, 0), r.normal(0, 1), r.normal(0, 2));
    }
    heads_.emplace_back(h, model::headEffectsFor(sc_.effects, h.id));
    // fov_error: the j-th spec of this head draws its field on (HeadFovField, processKey(head, j)).
    const auto& fov = heads_.back().effects().fov;
    std::vector<model::FovErrorField> fields;
    for (std::size_t j = 0; j < fov.size(); ++j)
      fields.push_back(model::drawFovErrorField(
          fov[j], CounterRng(seed, Stream::HeadFovField, model::processKey(static_cast<std::uint64_t>(h.id), j))));
    heads_.back().setFovFields(std::move(fields));
  }
  acc_ = model::AccelModel(sc_.acc, model::accEffectsFor(sc_.effects));
  const std::size_t n = heads_.size();
  stats_.head_samples.assign(n, 0);
  stats_.head_blinded_sun.assign(n, 0);
  stats_.head_blinded_earth.assign(n, 0);
  stats_.head_blinded_moon.assign(n, 0);
  stats_.head_missing.assign(n, 0);
  stats_.head_outliers.assign(n, 0);
  stats_.head_sign_flips.assign(n, 0);
  stats_.head_star_epochs.assign(n, 0);
  stats_.head_missing_runs.assign(n, {});
  stats_.head_missing_run_count.assign(n, 0);
  stats_.head_coloured_ss.assign(n, Vec3::Zero());
  stats_.head_wander_ss.assign(n, Vec3::Zero());
  stats_.head_fov_ss.assign(n, Vec3::Zero());
  stats_.head_fov_sum.assign(n, Vec3::Zero());
  if (sc_.output.star_vectors_per_head < 1 || sc_.output.star_vectors_per_head > kMaxSimStarsPerHead) {
    if (error) *error = sc_.file + ": output.star_vectors_per_head must be in 1.." + std::to_string(kMaxSimStarsPerHead);
    return false;
  }
  return true;
}

model::OrbitContext Simulator::context(double t_rel) const {
  const double t = toSeconds(sc_.start) + t_rel;
  const OrbitState os = orbit_->state(t);
  model::OrbitContext c;
  c.t_s = t_rel;
  c.arg_lat_rad = os.arg_lat_rad;
  c.beta_rad = os.beta_rad;
  c.v_sat_I = os.v_I;
  c.v_earth_I = model::earthVelocity(t);
  return c;
}

void Simulator::run(SimSink& sink, const std::function<void(double)>& progress) {
  const double t0 = toSeconds(sc_.start);
  const TimeUs end = sc_.start + static_cast<TimeUs>(std::llround(duration_s_ * 1e6));
  AttitudeSim att(sc_.attitude, *orbit_, t0, seed_);
  const std::size_t nh = heads_.size();

  std::vector<TagStream> head_tags;
  std::vector<model::GapProcess> head_gaps;
  std::vector<model::OutlierSampler> outl;
  std::vector<model::SignFlipSampler> flip;
  std::vector<CounterRng> noise, star_noise;
  std::vector<MissingRuns> head_runs(nh);
  const TimeUs star_period =
      sc_.output.star_vectors_interval_s > 0 ? static_cast<TimeUs>(std::llround(sc_.output.star_vectors_interval_s * 1e6)) : 0;
  std::vector<std::int64_t> star_slot(nh, -1);  ///< last interval that got star vectors, per head
  std::vector<int> fov;
  StarVectorsOut sv;
  std::vector<FovStarCounter> counters;
  std::vector<Quat> prev_q(nh, Quat(1, 0, 0, 0));
  // Coloured processes per head (head axes e1, e2, b), drawn at every tag's true time.
  std::vector<model::NoiseProcess3> coloured, wander;
  std::vector<Vec3> fov_s;  ///< the stars in a head's FOV, head frame (fov_error)
  for (std::size_t i = 0; i < nh; ++i) {
    const auto& c = heads_[i].config();
    const auto& e = heads_[i].effects();
    const auto id = static_cast<std::uint64_t>(c.id);
    head_tags.push_back(makeTags(sc_.start, c.rate_hz, c.tag_offset_us, c.tag_drift_ppm, c.tag_jitter_us, seed_, Stream::HeadTagJitter));
    head_gaps.emplace_back(e.random_gaps, e.gaps, e.dropouts, seed_, Stream::HeadGap, id);
    outl.emplace_back(e.outliers, seed_, id);
    flip.emplace_back(e.sign_flip_probs, seed_, id);
    noise.emplace_back(seed_, Stream::HeadNoise, id);
    star_noise.emplace_back(seed_, Stream::StarNoise, id);
    counters.emplace_back(&stars_, c.fov_half_angle_rad, c.limiting_mag);
    coloured.emplace_back(model::headAxisModels(e.coloured_cross, e.coloured_about), seed_, Stream::HeadColouredNoise, id);
    wander.emplace_back(model::headAxisModels(e.wander_cross, e.wander_about), seed_, Stream::HeadThermalWander, id);
    head_runs[i].runs = &stats_.head_missing_runs[i];
    head_runs[i].count = &stats_.head_missing_run_count[i];
  }
  const auto& ac = acc_.config();
  const auto& ae = acc_.effects();
  TagStream acc_tags = makeTags(sc_.start, ac.rate_hz, ac.tag_offset_us, ac.tag_drift_ppm, ac.tag_jitter_us, seed_, Stream::AccTagJitter);
  model::GapProcess acc_gaps(ae.random_gaps, ae.gaps, {}, seed_, Stream::AccGap, 0);
  MissingRuns acc_runs{&stats_.acc_missing_runs, &stats_.acc_missing_run_count};
  const model::AccNoiseModel acc_noise(ac, seed_);
  const auto acc_T_us = static_cast<std::int64_t>(std::llround(1e6 / ac.rate_hz));
  const auto acc_offset_us = static_cast<std::int64_t>(std::llround(ae.time_offset_s * 1e6));
  Vec3 lf = acc_noise.lowFreqInitial();
  model::NoiseProcess3 acc_coloured(ae.coloured, seed_, Stream::AccColouredNoise, 0);
  model::NoiseProcess3 acc_bias_wander(ae.bias_wander, seed_, Stream::AccBiasWander, 0);

  const TimeUs gnv_period = static_cast<TimeUs>(std::llround(sc_.output.gnv1b_interval_s * 1e6));
  TimeUs gnv_next = ((sc_.start + gnv_period - 1) / gnv_period) * gnv_period;

  // Slowly varying directions, cached.
  double sun_t = -1e300, moon_t = -1e300;
  Vec3 sun_I = Vec3::UnitX(), moon_I = Vec3::UnitX(), v_earth = Vec3::Zero();
  double ctx_tau = std::numeric_limits<double>::quiet_NaN();
  model::OrbitContext ctx;
  Vec3 r_I = Vec3::Zero(), v_I = Vec3::Zero();
  auto contextAt = [&](double tau) {
    if (tau == ctx_tau) return;
    ctx_tau = tau;
    const double t = t0 + tau;
    if (std::abs(t - sun_t) > 10.0) {
      sun_t = t;
      sun_I = model::sunDirection(t);
      v_earth = model::earthVelocity(t);
    }
    if (std::abs(t - moon_t) > 30.0) {
      moon_t = t;
      moon_I = model::moonPosition(t);
    }
    orbit_->posVel(t, r_I, v_I);
    ctx.t_s = tau;
    ctx.arg_lat_rad = model::argumentOfLatitude(r_I, v_I);
    ctx.beta_rad = model::betaAngle(r_I, v_I, sun_I);
    ctx.v_sat_I = v_I;
    ctx.v_earth_I = v_earth;
  };

  double next_progress = 0;
  for (;;) {
    // The earliest pending sample of all streams (heads in order, then accelerometer, then orbit).
    TimeUs tmin = std::numeric_limits<TimeUs>::max();
    int which = -3;
    for (std::size_t i = 0; i < nh; ++i)
      if (head_tags[i].next() < tmin) {
        tmin = head_tags[i].next();
        which = static_cast<int>(i);
      }
    if (acc_tags.next() < tmin) {
      tmin = acc_tags.next();
      which = -1;
    }
    if (gnv_next < tmin) {
      tmin = gnv_next;
      which = -2;
    }
    if (tmin >= end) break;
    const double tag_rel = static_cast<double>(tmin - sc_.start) * 1e-6;
    if (progress && tag_rel >= next_progress) {
      progress(tag_rel / duration_s_);
      next_progress += duration_s_ / 100.0;
    }
    att.advanceTo(tag_rel + 3.0);

    if (which == -2) {
      OrbitSampleOut o;
      o.t = tmin;
      const double t = toSeconds(tmin);
      orbit_->posVel(t, o.r_I, o.v_I);
      const Mat3 C = model::C_E_I(t);
      o.r_E = C * o.r_I;
      o.v_E = C * (o.v_I - Vec3(0, 0, model::kEarthRate_rad_s).cross(o.r_I));
      sink.orbit(o);
      ++stats_.orbit_samples;
      gnv_next += gnv_period;
      continue;
    }
    if (which == -1) {
      const std::uint64_t n = acc_tags.advance();
      // Low-frequency noise: one Gauss-Markov step per sample, whether or not the sample is missing.
      const Vec3 lf_now = lf;
      lf = acc_noise.lowFreqNext(lf, n);
      const std::int64_t t_true_us =
          ae.clock_drifts.empty()
              ? (tmin - sc_.start) - acc_offset_us
              : static_cast<std::int64_t>(std::llround(model::trueTimeOfTag(ae.time_offset_s, ae.clock_drifts, tag_rel) * 1e6));
      const double t_true_s = static_cast<double>(t_true_us) * 1e-6;
      // The coloured processes advance at every tag (missing too), at the sample's true time.
      const Vec3 col = acc_coloured.empty() ? Vec3::Zero() : acc_coloured.next(t_true_s);
      const Vec3 bw = acc_bias_wander.empty() ? Vec3::Zero() : acc_bias_wander.next(t_true_s);
      const bool acc_missing = acc_gaps.missing(tag_rel);
      acc_runs.sample(tag_rel, acc_missing);
      if (acc_missing) {
        ++stats_.acc_missing;
        continue;
      }
      AccSampleOut a;
      a.tag = tmin;
      a.index = n;
      a.t_true_s = t_true_s;
      a.a_B_true = att.meanAngularAcceleration(t_true_us, acc_T_us);
      a.w_B_true = att.bodyRate(t_true_s);
      stats_.max_abs_alpha = std::max(stats_.max_abs_alpha, a.a_B_true.cwiseAbs().maxCoeff());
      Vec3 w_ang, w_lin;
      acc_noise.white(n, w_ang, w_lin);
      a.ang_A = acc_.predict(a.a_B_true) + w_ang + lf_now;
      if (!acc_coloured.empty() || !acc_bias_wander.empty()) {
        a.coloured_rad_s2 = col;
        a.bias_wander_rad_s2 = bw;
        a.ang_A += col + bw;
        stats_.acc_coloured_ss += col.cwiseAbs2();
        stats_.acc_bias_wander_ss += bw.cwiseAbs2();
      }
      a.lin_A = ac.lin_bias_m_s2 + w_lin;
      ++stats_.acc_samples;
      sink.accel(a);
      continue;
    }
    const auto i = static_cast<std::size_t>(which);
    const std::uint64_t n = head_tags[i].advance();
    const model::HeadModel& hm = heads_[i];
    const auto& hc = hm.config();
    const double t_true_s = model::trueTimeOfTag(hm.effects().time_offset_s, hm.effects().clock_drifts, tag_rel);
    // The coloured processes advance at every tag (missing and blinded too), at the sample's true time.
    const Vec3 col = coloured[i].empty() ? Vec3::Zero() : coloured[i].next(t_true_s);
    const Vec3 wan = wander[i].empty() ? Vec3::Zero() : wander[i].next(t_true_s);
    const bool head_missing = head_gaps[i].missing(tag_rel);
    head_runs[i].sample(tag_rel, head_missing);
    if (head_missing) {
      ++stats_.head_missing[i];
      continue;
    }
    HeadSampleOut s;
    s.tag = tmin;
    s.head = hc.id;
    s.index = n;
    s.t_true_s = t_true_s;
    s.coloured_rad = col;
    s.wander_rad = wan;
    Vec3 w_B;
    att.eval(s.t_true_s, s.q_I_B, w_B);
    contextAt(s.t_true_s);
    const Vec3 wander_Si = wander[i].empty() ? Vec3::Zero() : hm.fromHeadAxes(wan);
    s.q_I_Si_expected = wander[i].empty() ? hm.predict(s.q_I_B, ctx) : hm.predict(s.q_I_B, ctx, wander_Si);
    const Vec3 b_I = hm.boresightInertial(s.q_I_Si_expected);
    s.blind = model::blindMask(hc, b_I, sun_I, moon_I, r_I);
    if (s.blind) {
      stats_.head_blinded_sun[i] += (s.blind & kBlindSun) != 0;
      stats_.head_blinded_earth[i] += (s.blind & kBlindEarth) != 0;
      stats_.head_blinded_moon[i] += (s.blind & kBlindMoon) != 0;
      sink.head(s);
      continue;
    }
    Vec3 err = hm.noiseRotVec(noise[i], n);
    if (!coloured[i].empty()) err += hm.fromHeadAxes(col);
    if (hm.hasFovError()) {
      // The stars in the FOV through the expected attitude, in the head frame; their displacements'
      // least-squares rotation is the attitude error (the count is the one `count` gives).
      counters[i].select(b_I, fov);
      const Mat3 C_Si_I = s.q_I_Si_expected.toRotationMatrix().transpose();
      fov_s.resize(fov.size());
      for (std::size_t k = 0; k < fov.size(); ++k) fov_s[k] = C_Si_I * stars_.stars()[static_cast<std::size_t>(fov[k])].u_I;
      const Vec3 f = hm.fovAttitudeError(fov_s.data(), fov_s.size());
      s.fov_rad = hm.toHeadAxes(f);
      err += f;
    }
    Quat q = s.q_I_Si_expected * model::quatExp(err);
    if (outl[i].apply(n, q)) {
      s.outlier = true;
      ++stats_.head_outliers[i];
    }
    // Deliver a sign-continuous quaternion (q0 >= 0 at the first sample).
    if (q.coeffs().dot(prev_q[i].coeffs()) < 0) q.coeffs() = -q.coeffs();
    prev_q[i] = q;
    if (flip[i].fires(n)) {
      q.coeffs() = -q.coeffs();
      s.sign_flipped = true;
      ++stats_.head_sign_flips[i];
    }
    s.q_I_Si = q;
    s.nstars = hm.hasFovError() ? static_cast<int>(fov.size()) : counters[i].count(b_I);
    ++stats_.head_samples[i];
    stats_.head_coloured_ss[i] += col.cwiseAbs2();
    stats_.head_wander_ss[i] += wan.cwiseAbs2();
    stats_.head_fov_ss[i] += s.fov_rad.cwiseAbs2();
    stats_.head_fov_sum[i] += s.fov_rad;
    sink.head(s);
    if (star_period > 0) {
      const std::int64_t slot = (tmin - sc_.start) / star_period;
      if (slot > star_slot[i]) {
        star_slot[i] = slot;
        // The head sees the catalogue directions through its reported (aberrated) attitude; the
        // inertial directions given with them carry that aberration, so (s, r) solve for the
        // geometric attitude q_I_B q_Si_B(t)^-1 (mounting error and thermal effects included).
        const Quat q_geom =
            (s.q_I_B * (wander[i].empty() ? hm.qSiB(ctx) : hm.qSiB(ctx, wander_Si)).conjugate()).normalized();
        const Mat3 C_exp = s.q_I_Si_expected.toRotationMatrix();
        const Mat3 C_geom = q_geom.toRotationMatrix();
        counters[i].select(b_I, fov);
        // brightest first (ties: catalogue order), at most star_vectors_per_head
        std::stable_sort(fov.begin(), fov.end(), [&](int a, int b) {
          return stars_.stars()[static_cast<std::size_t>(a)].mag < stars_.stars()[static_cast<std::size_t>(b)].mag;
        });
        sv.tag = tmin;
        sv.head = hc.id;
        sv.index = n;
        sv.q_I_Si_geometric = q_geom;
        sv.sigma_rad = hm.sigmaStar();
        sv.n = std::min<int>(static_cast<int>(fov.size()), sc_.output.star_vectors_per_head);
        for (int k = 0; k < sv.n; ++k) {
          const Star& st = stars_.stars()[static_cast<std::size_t>(fov[static_cast<std::size_t>(k)])];
          auto& o = sv.star[static_cast<std::size_t>(k)];
          o.hip = st.hip;
          o.mag = st.mag;
          o.s_Si_true = (C_exp.transpose() * st.u_I).normalized();
          o.r_I = (C_geom * o.s_Si_true).normalized();
          // the measured direction: displaced by the field-of-view error, then the star noise
          o.s_Si = hm.noisyStar(hm.hasFovError() ? hm.fovDisplacedStar(o.s_Si_true) : o.s_Si_true, star_noise[i], n,
                                static_cast<std::uint64_t>(k));
        }
        ++stats_.head_star_epochs[i];
        sink.stars(sv);
      }
    }
  }
  const double t_end = static_cast<double>(end - sc_.start) * 1e-6;
  for (auto& r : head_runs) r.close(t_end);
  acc_runs.close(t_end);
  stats_.thruster_pulses = att.thrusterPulses();
  for (const auto& c : counters) stats_.star_refreshes += c.refreshes();
  if (progress) progress(1.0);
}

}  // namespace boresight::sim
