// The thermal fit on the real GRACE-FO sample (SCA1A + GNI1B / GNV1B, 2023-06-01): the excerpt is far
// shorter than a revolution, so the fit must refuse with the reason and what it needs, after using the
// real epochs with u from the real orbit (no epoch left without u).
#include <boresight/calib/thermal_fit.h>
#include <boresight/io/core_config.h>

#include <gtest/gtest.h>

#include <cstdio>
#include <map>

#include "real_data.h"

namespace boresight {
namespace {

TEST(ThermalFitReal, TheRealExcerptIsRefusedWithTheSpanItNeeds) {
  BORESIGHT_REQUIRE_REAL_DATA();
  io::PlatformConfig pc;
  std::string err;
  ASSERT_TRUE(io::loadPlatformConfig(std::string(BORESIGHT_SOURCE_DIR) + "/config/gracefo.yaml", pc, &err)) << err;
  const auto sca = io::readProduct<io::Sca1aRecord>(test::realFile("gracefo/2023-06-01_L1A/SCA1A_2023-06-01_C_04.txt"));
  ASSERT_GT(sca.records.size(), 50u);
  if (pc.mounting_from_qsa1b) {
    const auto qsa = io::readProduct<io::QsaRecord>(test::realFile("gracefo/static_2018-05-22/QSA1B_2018-05-22_C_04.txt"));
    ASSERT_TRUE(io::applyQsa1bMounting(pc, qsa.records, sca.records.front().t, &err)) << err;
  }
  // head samples with the same tag form one epoch
  std::map<TimeUs, core::HeadEpoch> by_t;
  for (const io::Sca1aRecord& r : sca.records) {
    core::HeadEpoch& e = by_t[r.t];
    e.t = r.t;
    if (e.n >= core::kMaxHeads) continue;
    core::HeadSample& s = e.sample[static_cast<std::size_t>(e.n++)];
    s.head_id = r.head;
    s.q_I_Si = quatFromScalarFirst(r.q);
  }
  std::vector<core::HeadEpoch> epochs;
  for (const auto& kv : by_t) epochs.push_back(kv.second);
  for (const char* product : {"GNI1B", "GNV1B"}) {
    const auto orbit = io::readProduct<io::GnvRecord>(test::realFile(std::string("gracefo/2023-06-01_L1B/") + product +
                                                                     "_2023-06-01_C_04.txt"));
    ASSERT_GT(orbit.records.size(), 50u);
    const calib::ThermalFitResult r = calib::fitThermal(pc.pipeline.heads, {}, epochs, orbit.records);
    std::printf("%s: %zu head epochs, %llu without u, span %.1f s, %.4f revolutions\n%s\n", product, epochs.size(),
                static_cast<unsigned long long>(r.epochs_without_orbit), r.span_s, r.revolutions, r.error.c_str());
    EXPECT_FALSE(r.ok);
    EXPECT_NE(r.error.find("revolutions"), std::string::npos) << r.error;
    EXPECT_EQ(r.u_from_earth_fixed, std::string(product) == "GNV1B");
    EXPECT_GT(r.span_s, 10.0);
    EXPECT_LT(r.revolutions, 0.1);
    EXPECT_GT(r.revolutions, 0.0);
    EXPECT_EQ(r.head_epochs, epochs.size());
    EXPECT_EQ(r.orbit_records_rejected, 0u);
  }
}

}  // namespace
}  // namespace boresight
