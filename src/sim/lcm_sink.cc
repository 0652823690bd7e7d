// The simulator's LCM log output, through io::LcmLogWriter (the node's input message types).
#include <boresight/io/lcm_log.h>
#include <boresight/sim/output.h>

#include <algorithm>

namespace boresight::sim {

struct LcmSink::Impl {
  io::LcmLogWriter w;
  std::int32_t seq_head[16] = {};
  std::int32_t seq_acc = 0;
  std::int32_t seq_stars = 0;
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
  if (s.blind || !impl_->open) return;  // a blinded head delivers nothing
  io::HeadSample m;
  m.utime = s.tag;
  m.head_id = s.head;
  quatToScalarFirst(s.q_I_Si, m.q);
  m.star_count = s.nstars;
  m.flags = 1;
  m.seq = impl_->seq_head[s.head & 15]++;
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
  m.seq = impl_->seq_acc++;
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

bool LcmSink::close(std::string* error) {
  if (impl_->open) impl_->w.close();
  impl_->open = false;
  if (impl_->failed && error) *error = "LCM log: a write failed";
  return !impl_->failed;
}

std::uint64_t LcmSink::written() const { return impl_->w.written(); }

}  // namespace boresight::sim
