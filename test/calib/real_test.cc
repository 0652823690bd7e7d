// The real GRACE-FO Level-1A excerpts (16 s) through the span builder and the solver: refused, with the
// span the CRN needs (the CRN needs ~35 s of data each side of an epoch, so no epoch exists at all).
#include "boresight/calib/solver.h"
#include "boresight/calib/span_builder.h"
#include "boresight/io/level1.h"
#include "real_data.h"

#include <gtest/gtest.h>

namespace boresight::calib {
namespace {

TEST(CalibReal, SixteenSecondExcerptIsRefusedWithWhatTheCrnNeeds) {
  BORESIGHT_REQUIRE_REAL_DATA();
  const auto S = io::readProduct<io::Sca1aRecord>(test::realFile("gracefo/2023-06-01_L1A/SCA1A_2023-06-01_C_04.txt"));
  const auto A = io::readProduct<io::Acc1aRecord>(test::realFile("gracefo/2023-06-01_L1A/ACC1A_2023-06-01_C_04.txt"));
  ASSERT_GT(S.records.size(), 30u);
  ASSERT_GE(A.records.size(), 100u);  // 10 s at 10 Hz
  core::PipelineConfig cfg;
  cfg.heads.n_heads = 3;
  // the design-level head geometry of config/sim_gracefo.yaml (within 0.25 deg of QSA1B): the mountings
  // do not matter here, no epoch reaches the solver
  const Quat q[3] = {Quat(-0.1843610150, 0.6881349921, 0.6762283734, 0.1876071319),
                     Quat(0.2495963317, -0.0402839151, 0.8505722893, 0.4610918109),
                     Quat(-0.4611496071, 0.8536225615, -0.0423220733, -0.2384919381)};
  for (int h = 0; h < 3; ++h) {
    cfg.heads.head[static_cast<std::size_t>(h)].id = h + 1;
    cfg.heads.head[static_cast<std::size_t>(h)].q_Si_B = q[h].normalized();
  }
  SpanBuilder b;
  std::string err;
  ASSERT_TRUE(b.configure(cfg, SpanOptions{}, &err)) << err;
  std::size_t ia = 0, is = 0;
  while (is < S.records.size()) {
    core::HeadEpoch e;
    e.t = S.records[is].t;
    while (is < S.records.size() && S.records[is].t == e.t) {
      if (e.n < kMaxHeads) {
        auto& s = e.sample[static_cast<std::size_t>(e.n++)];
        s.head_id = S.records[is].head;
        s.q_I_Si = quatFromScalarFirst(S.records[is].q);
      }
      ++is;
    }
    for (; ia < A.records.size() && A.records[ia].t <= e.t; ++ia)
      b.pushAcc(A.records[ia].t, Vec3(A.records[ia].ang[0], A.records[ia].ang[1], A.records[ia].ang[2]));
    b.pushHeads(e);
  }
  for (; ia < A.records.size(); ++ia)
    b.pushAcc(A.records[ia].t, Vec3(A.records[ia].ang[0], A.records[ia].ang[1], A.records[ia].ang[2]));
  b.finish();
  const CalibrationSpan& s = b.span();
  EXPECT_GT(s.head_epochs, 20u);
  EXPECT_LT(toSeconds(s.t_last - s.t_first), 20.0);
  EXPECT_TRUE(s.obs.empty());
  const SolveResult r = solve(s, SolveOptions{});
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("too few epochs: 0"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("35.3 s each side"), std::string::npos) << r.message;
}

}  // namespace
}  // namespace boresight::calib
