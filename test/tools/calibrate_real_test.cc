// The real GRACE-FO 16 s excerpts cannot be calibrated: `boresight calibrate` refuses them, says why,
// and what span the CRN and the Cramer-Rao bound would need. Skips when ../shared/data/real is absent.
#include "real_data.h"
#include "test_files.h"

#include <gtest/gtest.h>

using boresight::test::realFile;

TEST(CalibrateReal, TheSixteenSecondExcerptsAreRefusedWithTheSpanTheyWouldNeed) {
  BORESIGHT_REQUIRE_REAL_DATA();
  const std::string d = testutil::makeTempDir("calibrate_real");
  // The SCA1A excerpt with the accelerometer as ACC1A and as ACT1A (both 16 s; 2023-06-03 has no SCA1A).
  for (const char* acc : {"ACC1A", "ACT1A"}) {
    const std::string l1a = "gracefo/2023-06-01_L1A/";
    const std::string args = std::string("calibrate --config ") + BORESIGHT_SOURCE_DIR + "/config/gracefo.yaml " +
                             realFile(l1a + "SCA1A_2023-06-01_C_04.txt") + " " +
                             realFile(l1a + acc + "_2023-06-01_C_04.txt") + " " +
                             realFile("gracefo/static_2018-05-22/QSA1B_2018-05-22_C_04.txt") + " --json " + d +
                             "/r.json";
    const testutil::CliRun r = testutil::runProgram(BORESIGHT_CLI, args);
    std::printf("%s\n", r.out.c_str());
    EXPECT_EQ(r.status, 1) << r.out;
    EXPECT_NE(r.out.find("refused: the span is too short"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("Tf = 70.7 s"), std::string::npos) << r.out;    // the CRN's need
    EXPECT_NE(r.out.find("of excited data"), std::string::npos) << r.out;  // the bound's need
    EXPECT_NE(r.out.find("the Cramer-Rao bound needs about"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("no CRN angular acceleration"), std::string::npos) << r.out;
    EXPECT_TRUE(testutil::slurp(d + "/r.json").empty());
  }
}
