// The versions of the LCM message types (src/lcmtypes/versions.txt): every type's VERSION constant and
// the fingerprint of the layout this build generates match the table's current line - a field added
// without a new version line fails here - and the readers' lookup names other layouts.
#include <boresight/io/lcm_log.h>

#include "boresight_lcm/accel_sample_t.hpp"
#include "boresight_lcm/boresight_monitor_t.hpp"
#include "boresight_lcm/calibration_t.hpp"
#include "boresight_lcm/fused_attitude_t.hpp"
#include "boresight_lcm/node_command_t.hpp"
#include "boresight_lcm/node_health_t.hpp"
#include "boresight_lcm/nominal_mountings_t.hpp"
#include "boresight_lcm/orbit_sample_t.hpp"
#include "boresight_lcm/star_head_sample_t.hpp"
#include "boresight_lcm/star_vectors_t.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <map>
#include <set>
#include <string>
#include <vector>

namespace {
using boresight::io::LcmTypeVersion;

const LcmTypeVersion* find(const std::string& type, int version) {
  int n = 0;
  const LcmTypeVersion* t = boresight::io::lcmTypeVersions(n);
  for (int i = 0; i < n; ++i)
    if (type == t[i].type && t[i].version == version) return &t[i];
  return nullptr;
}

template <class T>
void checkType(const char* name) {
  SCOPED_TRACE(name);
  const LcmTypeVersion* v = find(name, T::VERSION);
  ASSERT_NE(v, nullptr) << name << " VERSION " << T::VERSION << " has no line in src/lcmtypes/versions.txt";
  EXPECT_TRUE(v->current) << "a higher version of " << name << " is listed than its VERSION constant";
  EXPECT_EQ(v->fingerprint, static_cast<std::uint64_t>(T::getHash()))
      << name << ": the generated layout's fingerprint is not the one listed for VERSION " << T::VERSION
      << " - its fields changed: raise VERSION and add a line to versions.txt";
  // and an encoded message opens with it, which is what the lookup reads
  T m{};
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(m.getEncodedSize()));
  ASSERT_EQ(m.encode(buf.data(), 0, static_cast<int>(buf.size())), static_cast<int>(buf.size()));
  const LcmTypeVersion* w = boresight::io::lcmTypeVersionOf(buf.data(), static_cast<int>(buf.size()));
  ASSERT_NE(w, nullptr);
  EXPECT_STREQ(w->type, name);
  EXPECT_EQ(w->version, T::VERSION);
  EXPECT_FALSE(boresight::io::isOtherVersion(name, buf.data(), static_cast<int>(buf.size())));
}

TEST(LcmVersions, EveryTypeIsAtItsListedCurrentLayout) {
  checkType<boresight_lcm::accel_sample_t>("accel_sample_t");
  checkType<boresight_lcm::star_head_sample_t>("star_head_sample_t");
  checkType<boresight_lcm::star_vectors_t>("star_vectors_t");
  checkType<boresight_lcm::nominal_mountings_t>("nominal_mountings_t");
  checkType<boresight_lcm::orbit_sample_t>("orbit_sample_t");
  checkType<boresight_lcm::node_command_t>("node_command_t");
  checkType<boresight_lcm::calibration_t>("calibration_t");
  checkType<boresight_lcm::node_health_t>("node_health_t");
  checkType<boresight_lcm::fused_attitude_t>("fused_attitude_t");
  checkType<boresight_lcm::boresight_monitor_t>("boresight_monitor_t");
}

TEST(LcmVersions, TheTableNumbersEachTypeFromOneWithDistinctFingerprints) {
  int n = 0;
  const LcmTypeVersion* t = boresight::io::lcmTypeVersions(n);
  ASSERT_GE(n, 10);
  std::map<std::string, std::vector<int>> versions;
  std::set<std::uint64_t> fps;
  for (int i = 0; i < n; ++i) {
    versions[t[i].type].push_back(t[i].version);
    EXPECT_TRUE(fps.insert(t[i].fingerprint).second) << t[i].type << " v" << t[i].version << ": fingerprint listed twice";
  }
  EXPECT_EQ(versions.size(), 10u);
  for (const auto& [type, vs] : versions) {
    int current = 0;
    for (std::size_t i = 0; i < vs.size(); ++i) EXPECT_EQ(vs[i], static_cast<int>(i) + 1) << type << ": versions 1, 2, ... in order";
    for (int i = 0; i < n; ++i)
      if (type == t[i].type && t[i].current) ++current;
    EXPECT_EQ(current, 1) << type;
  }
}

TEST(LcmVersions, AMessageOfAnEarlierLayoutIsNamedNotTakenForDamage) {
  // A monitor message as the node wrote it before the pair corrections (version 1): its bytes open with
  // that layout's fingerprint (the payload here is today's, which is what a decoder must not read).
  boresight_lcm::boresight_monitor_t m{};
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(buf.data(), 0, static_cast<int>(buf.size()));
  const LcmTypeVersion* v1 = find("boresight_monitor_t", 1);
  ASSERT_NE(v1, nullptr);
  for (int i = 0; i < 8; ++i) buf[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(v1->fingerprint >> (56 - 8 * i));
  boresight_lcm::boresight_monitor_t back{};
  EXPECT_LT(back.decode(buf.data(), 0, static_cast<int>(buf.size())), 0) << "the generated decoder refuses it";
  const int size = static_cast<int>(buf.size());
  const LcmTypeVersion* w = boresight::io::lcmTypeVersionOf(buf.data(), size);
  ASSERT_NE(w, nullptr);
  EXPECT_EQ(w->version, 1);
  EXPECT_FALSE(w->current);
  EXPECT_TRUE(boresight::io::isOtherVersion("boresight_monitor_t", buf.data(), size));
  EXPECT_FALSE(boresight::io::isOtherVersion("fused_attitude_t", buf.data(), size)) << "another type's layout is not a version";
  // damaged bytes are no version of anything
  buf[3] ^= 0x40;
  EXPECT_EQ(boresight::io::lcmTypeVersionOf(buf.data(), size), nullptr);
  EXPECT_EQ(boresight::io::lcmTypeVersionOf(buf.data(), 7), nullptr);
  EXPECT_EQ(boresight::io::lcmTypeVersionOf(nullptr, 0), nullptr);
}

}  // namespace
