#include <boresight/io/time_format.h>
#include <boresight/model/rotation.h>
#include <boresight/sim/output.h>

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
ChunkedProductWriter<Rec>::~ChunkedProductWriter() = default;  // not closed: the temporary file goes

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
  if (!file_.open(path_, error)) return false;  // whole at close() or not at all (io::AtomicFile)
  body_ = file_.file();
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
  body_ = nullptr;
  if (!ok) {
    file_.abandon();
    if (error) *error = path_ + ": write failed";
    return false;
  }
  return file_.commit(error);
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
  std::vector<std::pair<std::int32_t, Quat>> heads;
  for (const auto& h : sim.heads()) heads.emplace_back(h.config().id, h.config().q_Si_B);
  return io::writeProduct(path, io::mountingsQsa1b(sim.scenario().satellite, sim.scenario().start, heads), error);
}

}  // namespace boresight::sim
