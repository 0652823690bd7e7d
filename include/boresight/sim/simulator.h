// The telemetry simulator: a time-ordered stream of head, accelerometer and orbit samples drawn from
// the scenario's orbit, attitude dynamics and sensor/effect models. Memory is bounded: the dynamics
// keep a fixed ring of steps and every sample goes straight to the sinks.
//
// Time tags: a sensor's tag pattern is start + offset + n / rate (+ drift, + shared jitter); a tag is
// the (receiver) time at which the sample was taken, so without a time_offset effect the sample
// describes the truth at exactly its tag.
#pragma once

#include <boresight/model/sensors.h>
#include <boresight/sim/attitude.h>
#include <boresight/sim/orbit.h>
#include <boresight/sim/scenario.h>
#include <boresight/sim/stars.h>

#include <array>
#include <functional>
#include <memory>

namespace boresight::sim {

enum BlindReason : std::uint8_t {
  kBlindNone = 0, kBlindSun = model::kBlindBitSun, kBlindEarth = model::kBlindBitEarth, kBlindMoon = model::kBlindBitMoon
};

struct HeadSampleOut {
  TimeUs tag = 0;
  int head = 1;
  std::uint64_t index = 0;  ///< sample number of this head since the start
  Quat q_I_Si = Quat::Identity();  ///< what the head delivers (noise, effects)
  int nstars = 0;
  std::uint8_t blind = kBlindNone;  ///< a blinded head delivers nothing (sinks skip it)
  bool outlier = false, sign_flipped = false;
  // Truth, for tests and the audit:
  double t_true_s = 0;           ///< seconds since the start at which the sample describes the truth
  Quat q_I_B = Quat::Identity();
  Quat q_I_Si_expected = Quat::Identity();  ///< model prediction without noise (thermal_wander included)
  // The coloured parts, head axes (e1, e2, b), rad (zero when the effect is off):
  Vec3 coloured_rad = Vec3::Zero();  ///< coloured_noise at t_true_s (in q_I_Si, not in q_I_Si_expected)
  Vec3 wander_rad = Vec3::Zero();    ///< thermal_wander at t_true_s (a mounting rotation: in q_I_Si_expected)
  Vec3 fov_rad = Vec3::Zero();       ///< fov_error attitude error (in q_I_Si; 0 for a blinded sample)
};

/// Most star vectors one head delivers per epoch (the core's kMaxStarsPerHead, the LCM message's 16).
constexpr int kMaxSimStarsPerHead = 16;

/// The star vectors of one head sample (brightest first), see io::ScvRecord for the product.
struct StarVectorsOut {
  TimeUs tag = 0;
  int head = 1;
  std::uint64_t index = 0;  ///< the head sample's number
  int n = 0;
  struct Star {
    int hip = 0;
    double mag = 0;
    Vec3 s_Si = Vec3::UnitZ();       ///< measured unit direction, head frame (noise included)
    Vec3 r_I = Vec3::UnitZ();        ///< unit direction, inertial, with the head's aberration applied
    Vec3 s_Si_true = Vec3::UnitZ();  ///< truth: noise-free direction in the head frame
  };
  std::array<Star, kMaxSimStarsPerHead> star{};
  // Truth, for tests:
  Quat q_I_Si_geometric = Quat::Identity();  ///< the head's true attitude without aberration
  double sigma_rad = 0;                      ///< the noise used, per axis
};

struct AccSampleOut {
  TimeUs tag = 0;
  std::uint64_t index = 0;
  Vec3 ang_A = Vec3::Zero();   ///< rad/s^2, frame A, what the accelerometer delivers
  Vec3 lin_A = Vec3::Zero();   ///< m/s^2, frame A
  double t_true_s = 0;
  Vec3 a_B_true = Vec3::Zero();  ///< true mean angular acceleration over the sample, B
  Vec3 w_B_true = Vec3::Zero();  ///< true body rate at t_true_s, B (rad/s)
  Vec3 coloured_rad_s2 = Vec3::Zero();     ///< acc_coloured_noise at t_true_s, frame A (in ang_A)
  Vec3 bias_wander_rad_s2 = Vec3::Zero();  ///< acc_bias_wander at t_true_s, frame A (in ang_A)
};

struct OrbitSampleOut {
  TimeUs t = 0;                ///< GPS time
  Vec3 r_E = Vec3::Zero(), v_E = Vec3::Zero();  ///< Earth-fixed (GNV1B 'E'), m and m/s
  Vec3 r_I = Vec3::Zero(), v_I = Vec3::Zero();
};

class SimSink {
 public:
  virtual ~SimSink() = default;
  virtual void head(const HeadSampleOut&) {}
  virtual void accel(const AccSampleOut&) {}
  virtual void orbit(const OrbitSampleOut&) {}
  /// Star vectors of a head sample (after its head() call; never for a blinded head).
  virtual void stars(const StarVectorsOut&) {}
};

constexpr std::size_t kMaxRecordedMissingRuns = 500;

struct SimStats {
  std::vector<std::uint64_t> head_samples, head_blinded_sun, head_blinded_earth, head_blinded_moon, head_missing,
      head_outliers, head_sign_flips, head_star_epochs;
  std::uint64_t acc_samples = 0, acc_missing = 0, orbit_samples = 0, thruster_pulses = 0, star_refreshes = 0;
  /// Runs of consecutive missing samples (random gaps, explicit gaps, dropouts): [tag of the first
  /// missing sample, tag of the next sample or the end), s since the start; the first
  /// kMaxRecordedMissingRuns are kept, all are counted.
  std::vector<std::vector<model::Interval>> head_missing_runs;
  std::vector<std::uint64_t> head_missing_run_count;
  std::vector<model::Interval> acc_missing_runs;
  std::uint64_t acc_missing_run_count = 0;
  double max_abs_alpha = 0;  ///< rad/s^2, largest true angular acceleration component seen by the accelerometer
  /// Sums of squares over the delivered samples, head axes (rad^2): coloured_noise, thermal_wander,
  /// fov_error; frame A ((rad/s^2)^2): acc_coloured_noise, acc_bias_wander (truth.yaml's realised RMS).
  std::vector<Vec3> head_coloured_ss, head_wander_ss, head_fov_ss;
  std::vector<Vec3> head_fov_sum;  ///< sum of the fov_error attitude errors (its mean acts as a misalignment)
  Vec3 acc_coloured_ss = Vec3::Zero(), acc_bias_wander_ss = Vec3::Zero();
};

class Simulator {
 public:
  Simulator();
  ~Simulator();
  /// Builds orbit, dynamics and models; draws the random mounting errors. False with *error.
  bool init(const Scenario& sc, std::uint64_t seed, double duration_s, std::string* error);
  /// Runs the whole span, calling the sink in time order; progress(fraction) about every 1 %.
  void run(SimSink& sink, const std::function<void(double)>& progress = {});

  const Scenario& scenario() const { return sc_; }
  std::uint64_t seed() const { return seed_; }
  double duration() const { return duration_s_; }
  const std::vector<model::HeadModel>& heads() const { return heads_; }
  const model::AccelModel& accel() const { return acc_; }
  const Orbit& orbit() const { return *orbit_; }
  const StarCatalogue& stars() const { return stars_; }
  const SimStats& stats() const { return stats_; }
  /// Orbit context at an absolute GPS time (what the effect models see).
  model::OrbitContext context(double t_rel_s) const;

 private:
  struct Impl;
  Scenario sc_;
  std::uint64_t seed_ = 0;
  double duration_s_ = 0;
  std::unique_ptr<Orbit> orbit_;
  std::vector<model::HeadModel> heads_;
  model::AccelModel acc_;
  StarCatalogue stars_;
  SimStats stats_;
};

}  // namespace boresight::sim
