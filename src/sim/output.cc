#include <boresight/io/time_format.h>
#include <boresight/model/rotation.h>
#include <boresight/sim/output.h>

#include <yaml-cpp/yaml.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>

namespace boresight::sim {
namespace {

std::size_t countLines(const std::string& s) {
  std::size_t n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

/// Byte offset after the first `lines` newlines.
std::size_t afterLines(const std::string& s, std::size_t lines) {
  std::size_t pos = 0;
  for (std::size_t i = 0; i < lines; ++i) {
    const auto nl = s.find('\n', pos);
    if (nl == std::string::npos) return s.size();
    pos = nl + 1;
  }
  return pos;
}

}  // namespace

template <typename Rec>
ChunkedProductWriter<Rec>::~ChunkedProductWriter() {
  if (body_) std::fclose(body_);
}

template <typename Rec>
bool ChunkedProductWriter<Rec>::open(const std::string& path, const io::ProductFile<Rec>& proto, std::string* error,
                                     std::size_t chunk_records) {
  path_ = path;
  chunk_ = proto;
  chunk_.records.clear();
  chunk_size_ = chunk_records == 0 ? 1 : chunk_records;
  chunk_.records.reserve(chunk_size_);
  std::string header = io::formatProduct(chunk_);
  header_lines_ = countLines(header);
  count_ = 0;
  io_error_ = false;
  // The record count is known only at the end: give its header field a fixed width now (the readers
  // trim blanks) and overwrite it in place at close(), so the body is written once, straight to the file.
  count_offset_ = std::string::npos;
  count_width_ = 0;
  for (const char* key : {"    num_records: ", "NUMBER OF DATA RECORDS"}) {
    const auto p = header.find(key);
    if (p == std::string::npos) continue;
    const auto eol = header.find('\n', p);
    std::size_t v = p + std::strlen(key);
    if (key[0] == 'N') v = header.find(':', p) + 2;  // fixed header: "KEY   : value"
    if (key[0] == ' ') header.replace(v, eol - v, std::string(kCountWidth, ' '));
    count_offset_ = v;
    count_width_ = key[0] == ' ' ? kCountWidth : header.find('\n', p) - v;
    break;
  }
  body_ = std::fopen(path_.c_str(), "wb");
  if (!body_) {
    if (error) *error = path_ + ": " + std::strerror(errno);
    return false;
  }
  if (std::fwrite(header.data(), 1, header.size(), body_) != header.size()) io_error_ = true;
  return true;
}

template <typename Rec>
void ChunkedProductWriter<Rec>::flush() {
  if (chunk_.records.empty() || !body_) return;
  const std::string text = io::formatProduct(chunk_);
  const std::size_t off = afterLines(text, header_lines_);
  if (std::fwrite(text.data() + off, 1, text.size() - off, body_) != text.size() - off) io_error_ = true;
  count_ += chunk_.records.size();
  chunk_.records.clear();
}

template <typename Rec>
bool ChunkedProductWriter<Rec>::close(std::string* error) {
  if (!body_) return true;
  flush();
  bool ok = !io_error_;
  if (ok && count_offset_ != std::string::npos) {
    std::string n = std::to_string(count_);
    if (n.size() > count_width_) n = n.substr(0, count_width_);  // cannot happen below 10^12 records
    n.resize(count_width_, ' ');
    ok = std::fseek(body_, static_cast<long>(count_offset_), SEEK_SET) == 0 &&
         std::fwrite(n.data(), 1, n.size(), body_) == n.size();
  }
  ok = (std::fclose(body_) == 0) && ok;
  body_ = nullptr;
  if (!ok && error) *error = path_ + ": write failed";
  return ok;
}

template class ChunkedProductWriter<io::Sca1aRecord>;
template class ChunkedProductWriter<io::FlaggedRecord>;
template class ChunkedProductWriter<io::GnvRecord>;
template class ChunkedProductWriter<io::ScvRecord>;

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
  auto f = io::makeProduct<io::QsaRecord>(io::Product::QSA1B, sim.scenario().satellite);
  f.header.style = io::HeaderStyle::Fixed;  // GRACE-FO static products use the fixed header
  for (const auto& h : sim.heads()) {
    io::QsaRecord r;
    r.t = (sim.scenario().start / kUsPerSecond) * kUsPerSecond;
    r.satellite = sim.scenario().satellite;
    r.sensor = h.config().id;
    quatToScalarFirst(h.config().q_Si_B, r.q);
    r.zero = 0;
    r.qualflg = io::Bits{0, 8};
    f.records.push_back(r);
  }
  return io::writeProduct(path, f, error);
}

namespace {

void emitVec(YAML::Emitter& y, const Vec3& v, double scale = 1.0) {
  y << YAML::Flow << YAML::BeginSeq << v.x() * scale << v.y() * scale << v.z() * scale << YAML::EndSeq;
}
void emitQuat(YAML::Emitter& y, const Quat& q) {
  double a[4];
  quatToScalarFirst(q, a);
  y << YAML::Flow << YAML::BeginSeq << a[0] << a[1] << a[2] << a[3] << YAML::EndSeq;
}
void emitMat(YAML::Emitter& y, const Mat3& m) {
  y << YAML::BeginSeq;
  for (int i = 0; i < 3; ++i) y << YAML::Flow << YAML::BeginSeq << m(i, 0) << m(i, 1) << m(i, 2) << YAML::EndSeq;
  y << YAML::EndSeq;
}

}  // namespace

bool writeTruthYaml(const std::string& path, const Simulator& sim, const std::vector<std::string>& effect_args,
                    const std::vector<std::string>& files, std::string* error) {
  const Scenario& sc = sim.scenario();
  const SimStats& st = sim.stats();
  YAML::Emitter y;
  y.SetDoublePrecision(17);
  y << YAML::Comment(
      "boresight simulate: the truth behind the simulated files. Angles in arcseconds unless named; quaternions "
      "scalar first; q_Si_B maps body (SRF) to head; C_B_A maps accelerometer-frame vectors to the body (as in the configuration files).");
  y << YAML::BeginMap;
  y << YAML::Key << "scenario" << YAML::Value << sc.file;
  y << YAML::Key << "seed" << YAML::Value << sim.seed();
  y << YAML::Key << "satellite" << YAML::Value << std::string(1, sc.satellite);
  y << YAML::Key << "start_gps_us" << YAML::Value << sc.start;
  y << YAML::Key << "start_date_gps" << YAML::Value << io::formatDate(sc.start);
  y << YAML::Key << "duration_s" << YAML::Value << sim.duration();
  y << YAML::Key << "effect_args" << YAML::Value << YAML::Flow << effect_args;
  y << YAML::Key << "effects" << YAML::Value << YAML::BeginSeq;
  for (const auto& e : sc.effects) {
    y << YAML::BeginMap << YAML::Key << "name" << YAML::Value << e.name << YAML::Key << "sensor" << YAML::Value
      << e.sensor << YAML::Key << "origin" << YAML::Value << e.origin;
    for (const auto& [k, v] : e.values) y << YAML::Key << k << YAML::Value << v;
    y << YAML::EndMap;
  }
  y << YAML::EndSeq;
  y << YAML::Key << "heads" << YAML::Value << YAML::BeginSeq;
  for (std::size_t i = 0; i < sim.heads().size(); ++i) {
    const auto& h = sim.heads()[i];
    const auto& c = h.config();
    const auto& e = h.effects();
    y << YAML::BeginMap;
    y << YAML::Key << "id" << YAML::Value << c.id;
    y << YAML::Key << "q_Si_B_nominal" << YAML::Value;
    emitQuat(y, c.q_Si_B);
    y << YAML::Key << "q_Si_B_true" << YAML::Value;
    emitQuat(y, h.qSiBTrue());
    y << YAML::Comment("constant mounting; time-varying effects below come on top");
    y << YAML::Key << "mounting_error_arcsec" << YAML::Value;
    emitVec(y, c.mounting_error_rad, kArcsecPerRad);
    y << YAML::Key << "relative_misalignment_arcsec" << YAML::Value;
    emitVec(y, e.misalignment_rad, kArcsecPerRad);
    y << YAML::Key << "boresight" << YAML::Value;
    emitVec(y, c.boresight_Si);
    y << YAML::Key << "noise_cross_arcsec" << YAML::Value << h.sigmaCross() * kArcsecPerRad;
    y << YAML::Key << "noise_about_arcsec" << YAML::Value << h.sigmaAbout() * kArcsecPerRad;
    y << YAML::Key << "time_offset_s" << YAML::Value << e.time_offset_s;
    y << YAML::Key << "rate_hz" << YAML::Value << c.rate_hz;
    y << YAML::Key << "samples_written" << YAML::Value << st.head_samples[i];
    y << YAML::Key << "blinded_sun" << YAML::Value << st.head_blinded_sun[i];
    y << YAML::Key << "blinded_earth" << YAML::Value << st.head_blinded_earth[i];
    y << YAML::Key << "blinded_moon" << YAML::Value << st.head_blinded_moon[i];
    y << YAML::Key << "missing_gaps_dropouts" << YAML::Value << st.head_missing[i];
    y << YAML::Key << "outliers" << YAML::Value << st.head_outliers[i];
    y << YAML::Key << "sign_flips" << YAML::Value << st.head_sign_flips[i];
    y << YAML::EndMap;
  }
  y << YAML::EndSeq;
  const auto& a = sim.accel();
  y << YAML::Key << "accelerometer" << YAML::Value << YAML::BeginMap;
  y << YAML::Key << "C_B_A_nominal" << YAML::Value;
  emitMat(y, a.config().C_A_B.transpose());
  y << YAML::Key << "C_B_A_true" << YAML::Value;
  emitMat(y, a.C_A_B_true().transpose());
  y << YAML::Key << "misalignment_arcsec" << YAML::Value;
  emitVec(y, a.effects().misalignment_rad, kArcsecPerRad);
  y << YAML::Key << "bias_rad_s2" << YAML::Value;
  emitVec(y, a.config().bias_rad_s2 + a.effects().bias_rad_s2);
  y << YAML::Key << "injected_bias_rad_s2" << YAML::Value;
  emitVec(y, a.effects().bias_rad_s2);
  y << YAML::Key << "scale_error" << YAML::Value;
  emitVec(y, a.effects().scale);
  y << YAML::Key << "white_noise_rad_s2" << YAML::Value;
  emitVec(y, a.config().white_rad_s2);
  y << YAML::Key << "lowfreq_noise_rad_s2" << YAML::Value;
  emitVec(y, a.config().lowfreq_rad_s2);
  y << YAML::Key << "time_offset_s" << YAML::Value << a.effects().time_offset_s;
  y << YAML::Key << "samples_written" << YAML::Value << st.acc_samples;
  y << YAML::Key << "missing_gaps" << YAML::Value << st.acc_missing;
  y << YAML::EndMap;
  y << YAML::Key << "attitude" << YAML::Value << YAML::BeginMap;
  y << YAML::Key << "thruster_pulses" << YAML::Value << st.thruster_pulses;
  y << YAML::Key << "max_abs_angular_acceleration_rad_s2" << YAML::Value << st.max_abs_alpha;
  y << YAML::EndMap;
  y << YAML::Key << "files" << YAML::Value << files;
  y << YAML::EndMap;
  std::ofstream out(path);
  out << y.c_str() << "\n";
  if (!out) {
    if (error) *error = path + ": write failed";
    return false;
  }
  return true;
}

}  // namespace boresight::sim
