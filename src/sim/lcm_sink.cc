// The simulator's LCM log output, through io::LcmLogWriter (the node's input message types).
#include <boresight/io/lcm_log.h>
#include <boresight/sim/output.h>

#include <algorithm>

namespace boresight::sim {

struct LcmSink::Impl {
  io::LcmLogWriter w;
  // Sequence numbers count what a sender sent: a sample lost to the `gaps` effect consumes its number
  // (seq = the sample index), a blinded head sends nothing and consumes none (blinded samples so far
  // are subtracted). Star vectors: one counter for the channel.
  std::uint64_t blinded[16] = {};
  std::int32_t seq_stars = 0;
  std::int32_t seq_orbit = 0;
  bool open = false;
  bool failed = false;
};

LcmSink::LcmSink() : impl_(std::make_unique<Impl>()) {}
LcmSink::~LcmSink() {
  if (impl_->open) impl_->w.close();
}

bool LcmSink::open(const std::string& path, std::string* error) {
  impl_->open = impl_->w.open(path, error);
  return impl_->open;
}

void LcmSink::head(const HeadSampleOut& s) {
  if (!impl_->open) return;
  if (s.blind) {  // a blinded head delivers nothing
    ++impl_->blinded[s.head & 15];
    return;
  }
  io::HeadSample m;
  m.utime = s.tag;
  m.head_id = s.head;
  quatToScalarFirst(s.q_I_Si, m.q);
  m.star_count = s.nstars;
  m.flags = 1;
  m.seq = static_cast<std::int32_t>(static_cast<std::uint32_t>(s.index - impl_->blinded[s.head & 15]));
  impl_->failed |= !impl_->w.write(m);
}

void LcmSink::accel(const AccSampleOut& a) {
  if (!impl_->open) return;
  io::AccelSample m;
  m.utime = a.tag;
  for (int k = 0; k < 3; ++k) {
    m.ang_accel[k] = a.ang_A[k];
    m.lin_accel[k] = a.lin_A[k];
  }
  m.flags = 3;
  m.seq = static_cast<std::int32_t>(static_cast<std::uint32_t>(a.index));
  impl_->failed |= !impl_->w.write(m);
}

void LcmSink::stars(const StarVectorsOut& s) {
  if (!impl_->open) return;
  io::StarVectors m;
  m.utime = s.tag;
  m.head_id = s.head;
  m.seq = impl_->seq_stars++;
  m.n_stars = std::min(s.n, io::StarVectors::kCapacity);
  for (int k = 0; k < m.n_stars; ++k) {
    const auto& st = s.star[static_cast<std::size_t>(k)];
    m.star_id[k] = st.hip;
    for (int j = 0; j < 3; ++j) {
      m.s_head[k][j] = st.s_Si[j];
      m.r_inertial[k][j] = st.r_I[j];
    }
    m.sigma_rad[k] = static_cast<float>(s.sigma_rad);
    m.magnitude[k] = static_cast<float>(st.mag);
  }
  m.flags = 1;
  impl_->failed |= !impl_->w.write(m);
}

void LcmSink::orbit(const OrbitSampleOut& o) {
  if (!impl_->open) return;
  io::OrbitSample m;
  m.utime = o.t;
  m.frame = 'I';
  for (int k = 0; k < 3; ++k) {
    m.r_m[k] = o.r_I[k];
    m.v_m_s[k] = o.v_I[k];
  }
  m.seq = impl_->seq_orbit++;
  impl_->failed |= !impl_->w.write(m);
}

bool LcmSink::writeMountings(const Simulator& sim) {
  if (!impl_->open) return false;
  io::NominalMountings m;
  m.utime = sim.scenario().start;
  m.n_heads = static_cast<int>(std::min<std::size_t>(sim.heads().size(), io::NominalMountings::kCapacity));
  for (int i = 0; i < m.n_heads; ++i) {
    const auto& h = sim.heads()[static_cast<std::size_t>(i)].config();
    m.head_id[i] = h.id;
    quatToScalarFirst(h.q_Si_B, m.q_Si_B[i]);
  }
  const Mat3 C_B_A = sim.accel().config().C_A_B.transpose();  // nominal, as the configuration says
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m.C_B_A[r][c] = C_B_A(r, c);
  m.source = 2;
  const bool ok = impl_->w.write(m);
  impl_->failed |= !ok;
  return ok;
}

bool LcmSink::close(std::string* error) {
  if (impl_->open) impl_->w.close();
  impl_->open = false;
  if (impl_->failed && error) *error = "LCM log: a write failed";
  return !impl_->failed;
}

std::uint64_t LcmSink::written() const { return impl_->w.written(); }

}  // namespace boresight::sim
