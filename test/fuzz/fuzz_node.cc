// libFuzzer target of the node's message handlers (boresight::node::Node): arbitrary bytes as LCM
// messages on the node's channels, the way live traffic arrives. Checks that nothing crashes and that
// every message is accounted for (received == used + sum(rejected)); the worker is off (one thread).
//
// Input: frames [channel byte][length, 2 bytes little-endian][payload]. Channel byte & 7 picks STAR_HEAD,
// ACCEL, STAR_VECTORS, NOMINAL_MOUNTINGS, ORBIT, another channel, BORESIGHT_COMMAND, or bytes that are no
// event at all;
// bit 7 set prefixes the payload with the channel type's fingerprint (so mutations reach the decoders'
// fields, not only the fingerprint check). A short input runs in microseconds.
// BORESIGHT_FUZZ_MAKE_SEED=FILE writes a seed: a minute of valid messages of every input channel.
#include <boresight/node/node.h>

#include "boresight_lcm/accel_sample_t.hpp"
#include "boresight_lcm/node_command_t.hpp"
#include "boresight_lcm/nominal_mountings_t.hpp"
#include "boresight_lcm/orbit_sample_t.hpp"
#include "boresight_lcm/star_head_sample_t.hpp"
#include "boresight_lcm/star_vectors_t.hpp"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

using namespace boresight;

namespace {

const char* const kChannels[7] = {"STAR_HEAD", "ACCEL", "STAR_VECTORS", "NOMINAL_MOUNTINGS", "ORBIT", "ELSEWHERE",
                                  "BORESIGHT_COMMAND"};

node::NodeConfig makeConfig() {
  node::NodeConfig cfg;
  cfg.file = "fuzz";
  cfg.pipeline.heads.n_heads = 3;
  for (int k = 0; k < 3; ++k) {
    auto& h = cfg.pipeline.heads.head[static_cast<std::size_t>(k)];
    h.id = k + 1;
    h.q_Si_B = Quat(Eigen::AngleAxisd(0.7 * (k + 1), Vec3(1, 0.5, -0.2).normalized()));
  }
  cfg.mountings_from_log = false;
  cfg.calibration.enabled = false;
  cfg.ring_capacity = 16;
  return cfg;
}

std::int64_t hashOf(int c) {
  switch (c) {
    case 0: return boresight_lcm::star_head_sample_t::getHash();
    case 1: return boresight_lcm::accel_sample_t::getHash();
    case 2: return boresight_lcm::star_vectors_t::getHash();
    case 3: return boresight_lcm::nominal_mountings_t::getHash();
    case 4: return boresight_lcm::orbit_sample_t::getHash();
    case 6: return boresight_lcm::node_command_t::getHash();
    default: return 0;
  }
}

template <typename M>
void frame(std::vector<std::uint8_t>& out, int c, const M& m) {
  std::vector<std::uint8_t> b(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(b.data(), 0, static_cast<int>(b.size()));
  out.push_back(static_cast<std::uint8_t>(c));
  out.push_back(static_cast<std::uint8_t>(b.size() & 0xff));
  out.push_back(static_cast<std::uint8_t>(b.size() >> 8));
  out.insert(out.end(), b.begin(), b.end());
}

int writeSeed(const char* path) {
  std::vector<std::uint8_t> out;
  const node::NodeConfig cfg = makeConfig();
  const std::int64_t t0 = 738849600LL * 1000000LL;
  boresight_lcm::nominal_mountings_t nm{};
  nm.utime = t0;
  nm.n_heads = 3;
  for (int k = 0; k < 3; ++k) {
    const Quat q = cfg.pipeline.heads.head[static_cast<std::size_t>(k)].q_Si_B;
    nm.head_id[k] = static_cast<int8_t>(k + 1);
    nm.q_Si_B[k][0] = q.w(), nm.q_Si_B[k][1] = q.x(), nm.q_Si_B[k][2] = q.y(), nm.q_Si_B[k][3] = q.z();
  }
  frame(out, 3, nm);
  for (int i = 0; i < 600; ++i) {
    const std::int64_t t = t0 + i * 100000LL;
    if (i % 100 == 0) {
      boresight_lcm::orbit_sample_t o{};
      o.utime = t;
      o.frame = 'I';
      o.r_m[0] = 6.868e6;
      o.v_m_s[1] = 7.6e3;
      o.seq = i / 100;
      frame(out, 4, o);
    }
    if (i % 50 == 0) {
      boresight_lcm::star_vectors_t sv{};
      sv.utime = t;
      sv.head_id = 1;
      sv.seq = i / 50;
      sv.n_stars = 3;
      for (int j = 0; j < 3; ++j) sv.s_head[j][j] = sv.r_inertial[j][j] = 1.0;
      sv.flags = 1;
      frame(out, 2, sv);
    }
    if (i == 300) {  // a ground command (refused here: nothing held, nothing handed)
      boresight_lcm::node_command_t cmd{};
      cmd.utime = t;
      cmd.command = 2;
      cmd.calibration_id = 1;
      frame(out, 6, cmd);
    }
    boresight_lcm::accel_sample_t a{};
    a.utime = t;
    a.ang_accel[0] = 1e-6;
    a.flags = 3;
    a.seq = i;
    frame(out, 1, a);
    if (i % 5 != 0) continue;
    for (int k = 0; k < 3; ++k) {
      boresight_lcm::star_head_sample_t h{};
      h.utime = t;
      h.head_id = static_cast<int8_t>(k + 1);
      const Quat q = cfg.pipeline.heads.head[static_cast<std::size_t>(k)].q_Si_B.conjugate();
      h.q[0] = q.w(), h.q[1] = q.x(), h.q[2] = q.y(), h.q[3] = q.z();
      h.flags = 1;
      h.seq = i / 5;
      frame(out, 0, h);
    }
  }
  std::FILE* f = std::fopen(path, "wb");
  if (!f) return 1;
  const bool ok = std::fwrite(out.data(), 1, out.size(), f) == out.size();
  return std::fclose(f) == 0 && ok ? 0 : 1;
}

struct NoOutput : node::Output {
  void publish(const std::string&, TimeUs, const void*, int) override {}
};

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  if (const char* seed = std::getenv("BORESIGHT_FUZZ_MAKE_SEED")) std::exit(writeSeed(seed));
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const node::NodeConfig cfg = makeConfig();
  NoOutput out;
  node::Node n;
  std::string err;
  if (!n.configure(cfg, node::Node::Mode::kReplay, &out, &err)) std::abort();
  std::vector<std::uint8_t> buf;
  std::size_t p = 0;
  std::uint64_t sent = 0;
  while (p + 3 <= size) {
    const int c = data[p] & 7;
    const bool prefix = (data[p] & 0x80) != 0;
    std::size_t len = data[p + 1] | (std::size_t{data[p + 2]} << 8);
    p += 3;
    if (len > size - p) len = size - p;
    buf.clear();
    if (prefix && (c < 5 || c == 6)) {
      const auto h = static_cast<std::uint64_t>(hashOf(c));
      for (int i = 7; i >= 0; --i) buf.push_back(static_cast<std::uint8_t>(h >> (8 * i)));
    }
    buf.insert(buf.end(), data + p, data + p + len);
    p += len;
    ++sent;
    if (c == 7) n.onGarbage();
    else n.onMessage(kChannels[c], buf.data(), static_cast<int>(buf.size()));
  }
  n.finish();
  const node::Counters& k = n.counters();
  if (k.received != sent || k.received != k.used + k.rejectedTotal()) {
    std::fprintf(stderr, "fuzz_node: %llu sent, %llu received, %llu used, %llu rejected\n",
                 static_cast<unsigned long long>(sent), static_cast<unsigned long long>(k.received),
                 static_cast<unsigned long long>(k.used), static_cast<unsigned long long>(k.rejectedTotal()));
    std::abort();
  }
  return 0;
}
