// Star catalogue and field of view; Sun/Earth/Moon exclusion; Sun and Moon directions.
#include <boresight/io/time_format.h>
#include "sim_test_util.h"
#include "test_files.h"

#include <boresight/model/ephemeris.h>
#include <boresight/sim/output.h>
#include <boresight/sim/stars.h>

#include <cstdio>
#include <filesystem>

namespace boresight {
namespace {

using simtest::gracefo;
using simtest::run;

const sim::StarCatalogue& catalogue() {
  static sim::StarCatalogue c = [] {
    sim::StarCatalogue k;
    std::string err;
    EXPECT_TRUE(k.load(simtest::sourceDir() + "/config/stars_bright.csv", &err)) << err;
    return k;
  }();
  return c;
}

Vec3 randomDir(const model::CounterRng& r, std::uint64_t i) {
  return Vec3(r.normal(i, 0), r.normal(i, 1), r.normal(i, 2)).normalized();
}

TEST(SimStars, CatalogueHasTheExtractedBrightStars) {
  const auto& c = catalogue();
  EXPECT_EQ(c.stars().size(), 7982u);  // Hp <= 6.5 in Hipparcos 2 (tools/extract_stars.py)
  EXPECT_LE(c.faintest(), 6.5);
  // Sirius (HIP 32349): RA 101.287 deg, Dec -16.716 deg at J2000, the brightest star.
  const sim::Star* sirius = nullptr;
  for (const auto& s : c.stars())
    if (s.hip == 32349) sirius = &s;
  ASSERT_NE(sirius, nullptr);
  EXPECT_LT(sirius->mag, -1.0);
  const double ra = 101.28715533 * kRadPerDeg, dec = -16.71611586 * kRadPerDeg;
  const Vec3 u(std::cos(dec) * std::cos(ra), std::cos(dec) * std::sin(ra), std::sin(dec));
  EXPECT_LT(std::acos(std::min(1.0, u.dot(sirius->u_I))) * kArcsecPerRad, 2.0);
}

TEST(SimStars, FovCounterMatchesABruteForceCountOfTheCatalogue) {
  const auto& c = catalogue();
  const model::CounterRng rng(5, model::Stream::Attitude, 0);
  for (double mag : {5.0, 6.0, 6.5}) {
    sim::FovStarCounter counter(&c, 10 * kRadPerDeg, mag);
    // A slowly moving boresight (a great circle at 0.1 deg per call) and random jumps.
    Vec3 d = randomDir(rng, 1);
    const Vec3 axis = d.cross(randomDir(rng, 2)).normalized();
    for (int i = 0; i < 4000; ++i) {
      d = Eigen::AngleAxisd(0.1 * kRadPerDeg, axis) * d;
      const Vec3 q = (i % 100 == 99) ? randomDir(rng, 100 + static_cast<std::uint64_t>(i)) : d;
      ASSERT_EQ(static_cast<std::size_t>(counter.count(q)), c.countInCone(q, 10 * kRadPerDeg, mag)) << i;
    }
    EXPECT_LT(counter.refreshes(), 400u);
  }
}

TEST(SimStars, MeanCountMatchesTheCatalogueDensityForTheLimitingMagnitude) {
  // Over 3000 random directions the mean count in a 10 deg cone equals N(<= m) times the cone's
  // share of the sky, (1 - cos 10 deg) / 2, within 4 % (the cone holds ~60 stars; the galactic plane
  // makes the count vary, the average over the sphere does not).
  const auto& c = catalogue();
  const model::CounterRng rng(9, model::Stream::Attitude, 1);
  for (double mag : {4.5, 5.5, 6.5}) {
    std::size_t total = 0, n_mag = 0;
    for (const auto& s : c.stars()) n_mag += s.mag <= mag;
    for (std::uint64_t i = 0; i < 3000; ++i) total += c.countInCone(randomDir(rng, i), 10 * kRadPerDeg, mag);
    const double mean = static_cast<double>(total) / 3000.0;
    const double expected = static_cast<double>(n_mag) * (1 - std::cos(10 * kRadPerDeg)) / 2;
    std::printf("limiting Hp %.1f: mean count in a 10 deg cone %.2f, catalogue density gives %.2f\n", mag, mean, expected);
    EXPECT_NEAR(mean, expected, 0.04 * expected);
  }
}

TEST(SimStars, SimulatedStarCountsAreTheCatalogueCountsInTheHeadFov) {
  auto sc = gracefo();
  sc.heads[0].limiting_mag = 5.5;
  auto r = run(sc, 3, 600);
  for (int id = 1; id <= 3; ++id) {
    const auto& hc = r->sim.heads()[static_cast<std::size_t>(id - 1)].config();
    const auto h = r->cap.head(id);
    ASSERT_FALSE(h.empty());
    for (std::size_t i = 0; i < h.size(); i += 17) {
      const Vec3 b = h[i].q_I_Si_expected * hc.boresight_Si;
      EXPECT_EQ(static_cast<std::size_t>(h[i].nstars), r->sim.stars().countInCone(b, hc.fov_half_angle_rad, hc.limiting_mag));
      const auto vecs = sim::starVectorsInHead(r->sim.stars(), h[i].q_I_Si_expected, hc.boresight_Si,
                                               hc.fov_half_angle_rad, hc.limiting_mag);
      EXPECT_EQ(vecs.size(), static_cast<std::size_t>(h[i].nstars));
      for (const auto& v : vecs) EXPECT_GE(v.z(), std::cos(hc.fov_half_angle_rad) - 1e-12);
    }
  }
  // A limiting magnitude fainter than the catalogue cannot be simulated honestly.
  sc.heads[0].limiting_mag = 7.5;
  sim::Simulator s;
  std::string err;
  EXPECT_FALSE(s.init(sc, 1, 10, &err));
  EXPECT_NE(err.find("fainter than the star catalogue"), std::string::npos) << err;
}

TEST(SimStars, SunAndMoonDirectionsAreRight) {
  // March equinox 2023-03-20 21:24 UTC: the Sun crosses the equator at RA 0; June solstice
  // 2023-06-21 14:58 UTC: declination +23.44 deg, RA 90 deg (GPS = UTC + 18 s).
  TimeUs eq, sol;
  ASSERT_TRUE(io::parseGpsCalendar("2023-03-20T21:24:18", eq));
  ASSERT_TRUE(io::parseGpsCalendar("2023-06-21T14:58:18", sol));
  const Vec3 se = model::sunDirection(toSeconds(eq)), ss = model::sunDirection(toSeconds(sol));
  EXPECT_NEAR(std::asin(se.z()) / kRadPerDeg, 0.0, 0.02);
  EXPECT_NEAR(std::atan2(se.y(), se.x()) / kRadPerDeg, 0.0, 0.05);
  EXPECT_NEAR(std::asin(ss.z()) / kRadPerDeg, 23.44, 0.02);
  EXPECT_NEAR(std::atan2(ss.y(), ss.x()) / kRadPerDeg, 90.0, 0.05);
  TimeUs t;
  ASSERT_TRUE(io::parseGpsCalendar("2023-06-01T00:00:00", t));
  EXPECT_EQ(t, 738849600LL * 1000000);
  EXPECT_EQ(io::formatDate(t), "2023-06-01");
  EXPECT_NEAR(model::earthVelocity(toSeconds(t)).norm(), 29.4e3, 0.3e3);
  // The Moon stays between perigee and apogee distances.
  for (int d = 0; d < 30; ++d) {
    const double r = model::moonPosition(toSeconds(t) + d * 86400.0).norm();
    EXPECT_GT(r, 355e6);
    EXPECT_LT(r, 408e6);
  }
}

TEST(SimStars, ExclusionConesBlindHeadsWhenTheSunEarthOrMoonIsInside) {
  const auto sc = gracefo();
  auto r = run(sc, 11, 6000);
  std::size_t blinded = 0, delivered = 0;
  for (const auto& s : r->cap.heads) {
    const auto& hc = r->sim.heads()[static_cast<std::size_t>(s.head - 1)].config();
    const double t = toSeconds(sc.start) + s.t_true_s;
    Vec3 rI, vI;
    r->sim.orbit().posVel(t, rI, vI);
    const Vec3 b = s.q_I_Si_expected * hc.boresight_Si;
    const double sun = std::acos(std::clamp(b.dot(model::sunDirection(t)), -1.0, 1.0));
    const double earth = std::acos(std::clamp(b.dot(-rI.normalized()), -1.0, 1.0)) -
                         std::asin(model::kEarthRadius_m / rI.norm());
    const double moon = std::acos(std::clamp(b.dot((model::moonPosition(t) - rI).normalized()), -1.0, 1.0));
    const double margin = 0.02 * kRadPerDeg;  // the simulator caches Sun/Moon directions for 10/30 s
    if (s.blind) {
      ++blinded;
      EXPECT_TRUE(sun < hc.sun_exclusion_rad + margin || earth < hc.earth_exclusion_rad + margin ||
                  moon < hc.moon_exclusion_rad + margin);
    } else {
      ++delivered;
      EXPECT_GT(sun, hc.sun_exclusion_rad - margin);
      EXPECT_GT(earth, hc.earth_exclusion_rad - margin);
      EXPECT_GT(moon, hc.moon_exclusion_rad - margin);
    }
  }
  std::printf("6000 s: %zu head samples delivered, %zu blinded\n", delivered, blinded);
  EXPECT_GT(blinded, 100u);  // head 3 looks near the Sun part of each orbit in this scenario
  // A head whose Sun cone covers the sky delivers nothing, in the files too.
  auto sc2 = gracefo();
  sc2.heads[1].sun_exclusion_rad = 179.9 * kRadPerDeg;
  sim::Simulator sim2;
  std::string err;
  ASSERT_TRUE(sim2.init(sc2, 11, 120, &err)) << err;
  const std::filesystem::path dir = testutil::makeTempDir("boresight_sim_blind");
  sim::Level1Sink l1;
  ASSERT_TRUE(l1.open(dir.string(), sc2, &err)) << err;
  sim2.run(l1);
  ASSERT_TRUE(l1.close(&err)) << err;
  const auto f = io::readProduct<io::Sca1aRecord>(l1.files()[0]);
  ASSERT_TRUE(f.ok) << f.error;
  std::size_t per_head[4] = {0, 0, 0, 0};
  for (const auto& rec : f.records) ++per_head[rec.head & 3];
  EXPECT_EQ(per_head[2], 0u);
  EXPECT_EQ(per_head[1], 240u);
  EXPECT_EQ(sim2.stats().head_blinded_sun[1], 240u);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace boresight
