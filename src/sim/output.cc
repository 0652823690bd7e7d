#include <boresight/io/time_format.h>
#include <boresight/model/rotation.h>
#include <boresight/sim/output.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>

namespace boresight::sim {

std::string productFileName(const char* product, const Scenario& sc) {
  return std::string(product) + "_" + io::formatDate(sc.start) + "_" + sc.satellite + "_" + sc.output.version + ".txt";
}

bool Level1Sink::open(const std::string& dir, const Scenario& sc, std::string* error) {
  sat_ = sc.satellite;
  files_ = {dir + "/" + productFileName("SCA1A", sc), dir + "/" + productFileName("ACC1A", sc),
            dir + "/" + productFileName("GNV1B", sc)};
  scv_on_ = sc.output.star_vectors_interval_s > 0;
  if (scv_on_) files_.push_back(dir + "/" + productFileName("SCV1A", sc));
  return sca_.open(files_[0], io::makeProduct<io::Sca1aRecord>(io::Product::SCA1A, sat_), error) &&
         acc_.open(files_[1], io::makeProduct<io::FlaggedRecord>(io::Product::ACC1A, sat_), error) &&
         gnv_.open(files_[2], io::makeProduct<io::GnvRecord>(io::Product::GNV1B, sat_), error, 4096) &&
         (!scv_on_ || scv_.open(files_[3], io::makeProduct<io::ScvRecord>(io::Product::SCV1A, sat_), error, 8192));
}

void toScv1a(const StarVectorsOut& s, char satellite, std::vector<io::ScvRecord>& out) {
  out.clear();
  for (int k = 0; k < s.n; ++k) {
    const auto& st = s.star[static_cast<std::size_t>(k)];
    io::ScvRecord r;
    r.t = s.tag;
    r.satellite = satellite;
    r.head = static_cast<std::uint8_t>(s.head);
    r.star = st.hip;
    for (int j = 0; j < 3; ++j) {
      r.s[j] = st.s_Si[j];
      r.r[j] = st.r_I[j];
    }
    r.mag = st.mag;
    out.push_back(r);
  }
}

void Level1Sink::stars(const StarVectorsOut& s) {
  if (!scv_on_) return;
  toScv1a(s, sat_, scv_buf_);
  for (const auto& r : scv_buf_) scv_.add(r);
}

io::Sca1aRecord toSca1a(const HeadSampleOut& s, char satellite) {
  io::Sca1aRecord r;
  r.t = s.tag;
  r.satellite = satellite;
  r.head = static_cast<std::uint8_t>(s.head);
  r.desig = 'P';
  quatToScalarFirst(s.q_I_Si, r.q);
  r.nlocks = 0;
  r.nstars = s.nstars;
  r.confid = s.nstars >= 20 ? 1 : s.nstars >= 8 ? 2 : 3;
  // sca_mode / qualflg bit patterns as in the 2023-06-01 GRACE C sample (11000001 / 11000000).
  r.mode = io::Bits{0xC1, 8};
  r.qualflg = io::Bits{0xC0, 8};
  return r;
}

io::FlaggedRecord toAcc1a(const AccSampleOut& a, char satellite) {
  io::FlaggedRecord r;
  r.t = a.tag;
  r.time_ref = 'R';
  r.satellite = satellite;
  r.qualflg = io::Bits{0, 8};
  r.prod_flag = io::Bits{(1u << io::acc_bits::kIcuBlock) | 0x3Fu, 32};
  for (int k = 0; k < 3; ++k) {
    r.value[static_cast<std::size_t>(io::acc_bits::kLinX + k)] = a.lin_A[k];
    r.value[static_cast<std::size_t>(io::acc_bits::kAngX + k)] = a.ang_A[k];
  }
  r.value[io::acc_bits::kIcuBlock] = 0;
  return r;
}

io::GnvRecord toGnv1b(const OrbitSampleOut& o, char satellite) {
  io::GnvRecord g;
  g.t = o.t;
  g.satellite = satellite;
  g.coord_ref = 'E';
  for (int k = 0; k < 3; ++k) {
    g.pos[k] = o.r_E[k];
    g.vel[k] = o.v_E[k];
    g.pos_err[k] = 1e-3;  // m, 1-sigma (the simulated orbit is exact; the value marks it as good)
    g.vel_err[k] = 1e-6;  // m/s
  }
  g.qualflg = io::Bits{0, 8};
  return g;
}

void Level1Sink::head(const HeadSampleOut& s) {
  if (s.blind) return;  // a blinded head delivers nothing
  sca_.add(toSca1a(s, sat_));
}

void Level1Sink::accel(const AccSampleOut& a) { acc_.add(toAcc1a(a, sat_)); }

void Level1Sink::orbit(const OrbitSampleOut& o) { gnv_.add(toGnv1b(o, sat_)); }

bool Level1Sink::close(std::string* error) {
  return sca_.close(error) && acc_.close(error) && gnv_.close(error) && scv_.close(error);
}

bool writeQsa1b(const std::string& path, const Simulator& sim, std::string* error) {
  std::vector<std::pair<std::int32_t, Quat>> heads;
  for (const auto& h : sim.heads()) heads.emplace_back(h.config().id, h.config().q_Si_B);
  return io::writeProduct(path, io::mountingsQsa1b(sim.scenario().satellite, sim.scenario().start, heads), error);
}

}  // namespace boresight::sim
