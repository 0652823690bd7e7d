// LCM log writing and reading for the node's input types.
#include <boresight/io/lcm_log.h>

#include "boresight_lcm/accel_sample_t.hpp"
#include "boresight_lcm/star_head_sample_t.hpp"
#include "boresight_lcm/nominal_mountings_t.hpp"
#include "boresight_lcm/orbit_sample_t.hpp"
#include "boresight_lcm/star_vectors_t.hpp"

#include <boresight/core/plausibility.h>

#include <lcm/lcm-cpp.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <sys/stat.h>
#include <unistd.h>
#include <string>
#include <vector>

namespace boresight::io {
namespace {
// Log event timestamps are Unix microseconds: map the GPS J2000 sensor tag onto them without leap
// seconds. Only the order and spacing of events matter for playback; the message utime is the truth.
constexpr std::int64_t kUnixUsOfGraceEpoch = 946728000LL * 1000000LL;

template <typename Msg>
bool writeMsg(lcm::LogFile& log, const char* channel, std::int64_t utime, const Msg& m, std::vector<char>& buf) {
  int n = m.getEncodedSize();
  if (n < 0) return false;
  buf.resize(static_cast<std::size_t>(n));
  if (m.encode(buf.data(), 0, n) != n) return false;
  lcm::LogEvent ev;
  ev.eventnum = 0;
  ev.timestamp = utime + kUnixUsOfGraceEpoch;
  ev.channel = channel;
  ev.datalen = n;
  ev.data = buf.data();
  return log.writeEvent(&ev) == 0;
}
}  // namespace

struct LcmLogWriter::Impl {
  std::unique_ptr<lcm::LogFile> log;
  std::string path, tmp;  ///< the destination, and the temporary name written until close()
  std::vector<char> buf;
  lcm::LogEvent raw{};  ///< writeRaw's event: its channel keeps its capacity (no allocation per event)
};

LcmLogWriter::LcmLogWriter() : impl_(new Impl) {}
LcmLogWriter::~LcmLogWriter() { abandon(); }

bool LcmLogWriter::open(const std::string& path, std::string* error) {
  abandon();
  // Written under a temporary name in the destination's folder, renamed over it by close(): a run that
  // fails leaves the previous log or none, never a cut one. A device or pipe is written in place.
  struct stat st {};
  const bool special = ::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode);
  if (special && S_ISDIR(st.st_mode)) {
    if (error) *error = path + ": is a directory: cannot write an LCM log there";
    return false;
  }
  impl_->path = path;
  impl_->tmp.clear();
  std::string target = path;
  if (!special) {
    std::string t = path + ".tmp-XXXXXX";
    const int fd = ::mkstemp(t.data());
    if (fd < 0) {
      if (error) *error = path + ": cannot create LCM log: " + std::strerror(errno);
      return false;
    }
    const mode_t u = ::umask(0);
    ::umask(u);
    ::fchmod(fd, static_cast<mode_t>(0666 & ~u));
    ::close(fd);
    impl_->tmp = t;
    target = t;
  }
  impl_->log.reset(new lcm::LogFile(target, "w"));
  if (!impl_->log->good()) {
    impl_->log.reset();
    if (!impl_->tmp.empty()) ::unlink(impl_->tmp.c_str());
    impl_->tmp.clear();
    if (error) *error = path + ": cannot create LCM log: " + std::strerror(errno);
    return false;
  }
  written_ = 0;
  return true;
}

void LcmLogWriter::abandon() {
  impl_->log.reset();
  if (!impl_->tmp.empty()) ::unlink(impl_->tmp.c_str());
  impl_->tmp.clear();
}

bool LcmLogWriter::write(const HeadSample& s) {
  if (!impl_->log) return false;
  boresight_lcm::star_head_sample_t m;
  m.utime = s.utime;
  m.head_id = static_cast<int8_t>(s.head_id);
  for (int i = 0; i < 4; ++i) m.q[i] = s.q[i];
  m.star_count = static_cast<int16_t>(s.star_count);
  m.flags = s.flags;
  m.seq = s.seq;
  bool ok = writeMsg(*impl_->log, kStarHeadChannel, s.utime, m, impl_->buf);
  written_ += ok ? 1 : 0;
  return ok;
}

bool LcmLogWriter::write(const AccelSample& s) {
  if (!impl_->log) return false;
  boresight_lcm::accel_sample_t m;
  m.utime = s.utime;
  for (int i = 0; i < 3; ++i) {
    m.ang_accel[i] = s.ang_accel[i];
    m.lin_accel[i] = s.lin_accel[i];
  }
  m.flags = s.flags;
  m.seq = s.seq;
  bool ok = writeMsg(*impl_->log, kAccelChannel, s.utime, m, impl_->buf);
  written_ += ok ? 1 : 0;
  return ok;
}

bool LcmLogWriter::write(const StarVectors& s) {
  if (!impl_->log || s.n_stars < 0 || s.n_stars > StarVectors::kCapacity) return false;
  boresight_lcm::star_vectors_t m{};
  m.utime = s.utime;
  m.head_id = static_cast<int8_t>(s.head_id);
  m.seq = s.seq;
  m.n_stars = static_cast<int16_t>(s.n_stars);
  for (int i = 0; i < StarVectors::kCapacity; ++i) {
    const bool used = i < s.n_stars;
    m.star_id[i] = used ? s.star_id[i] : 0;
    for (int k = 0; k < 3; ++k) {
      m.s_head[i][k] = used ? s.s_head[i][k] : 0.0;
      m.r_inertial[i][k] = used ? s.r_inertial[i][k] : 0.0;
    }
    m.sigma_rad[i] = used ? s.sigma_rad[i] : 0.0f;
    m.magnitude[i] = used ? s.magnitude[i] : 0.0f;
  }
  m.flags = s.flags;
  bool ok = writeMsg(*impl_->log, kStarVectorsChannel, s.utime, m, impl_->buf);
  written_ += ok ? 1 : 0;
  return ok;
}

bool decodeStarVectors(const void* data, int size, StarVectors& out) {
  boresight_lcm::star_vectors_t m{};
  if (m.decode(data, 0, size) != size) return false;
  if (m.n_stars < 0 || m.n_stars > StarVectors::kCapacity) return false;
  out.utime = m.utime;
  out.head_id = m.head_id;
  out.seq = m.seq;
  out.n_stars = m.n_stars;
  for (int i = 0; i < StarVectors::kCapacity; ++i) {
    out.star_id[i] = m.star_id[i];
    for (int k = 0; k < 3; ++k) {
      out.s_head[i][k] = m.s_head[i][k];
      out.r_inertial[i][k] = m.r_inertial[i][k];
    }
    out.sigma_rad[i] = m.sigma_rad[i];
    out.magnitude[i] = m.magnitude[i];
  }
  out.flags = m.flags;
  return true;
}

bool LcmLogWriter::write(const NominalMountings& s) {
  if (!impl_->log || s.n_heads < 1 || s.n_heads > NominalMountings::kCapacity) return false;
  boresight_lcm::nominal_mountings_t m{};
  m.utime = s.utime;
  m.n_heads = static_cast<int8_t>(s.n_heads);
  for (int i = 0; i < NominalMountings::kCapacity; ++i) {
    const bool used = i < s.n_heads;
    m.head_id[i] = static_cast<int8_t>(used ? s.head_id[i] : 0);
    for (int k = 0; k < 4; ++k) m.q_Si_B[i][k] = used ? s.q_Si_B[i][k] : 0.0;
  }
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m.C_B_A[r][c] = s.C_B_A[r][c];
  m.source = static_cast<int8_t>(s.source);
  bool ok = writeMsg(*impl_->log, kMountingsChannel, s.utime, m, impl_->buf);
  written_ += ok ? 1 : 0;
  return ok;
}

bool LcmLogWriter::write(const OrbitSample& s) {
  if (!impl_->log) return false;
  boresight_lcm::orbit_sample_t m{};
  m.utime = s.utime;
  m.frame = static_cast<int8_t>(s.frame);
  for (int k = 0; k < 3; ++k) {
    m.r_m[k] = s.r_m[k];
    m.v_m_s[k] = s.v_m_s[k];
  }
  m.seq = s.seq;
  bool ok = writeMsg(*impl_->log, kOrbitChannel, s.utime, m, impl_->buf);
  written_ += ok ? 1 : 0;
  return ok;
}

bool LcmLogWriter::writeRaw(const std::string& channel, TimeUs utime, const void* data, int size) {
  if (!impl_->log || size < 0) return false;
  lcm::LogEvent& ev = impl_->raw;
  ev.eventnum = 0;
  ev.timestamp = utime + kUnixUsOfGraceEpoch;
  ev.channel.assign(channel);  // reuses the capacity of the longest channel name so far
  ev.datalen = size;
  ev.data = const_cast<void*>(data);
  const bool ok = impl_->log->writeEvent(&ev) == 0;
  written_ += ok ? 1 : 0;
  return ok;
}

bool applyNominalMountings(const NominalMountings& m, core::HeadSetConfig& heads, std::uint32_t keep_mask, Reject& why) {
  core::HeadSetConfig h = heads;
  for (int k = 0; k < h.n_heads; ++k) {
    auto& hk = h.head[static_cast<std::size_t>(k)];
    if ((keep_mask >> k) & 1u) continue;
    int j = 0;
    while (j < m.n_heads && m.head_id[j] != hk.id) ++j;
    if (j == m.n_heads) {
      why = Reject::kUnknownHead;
      return false;
    }
    const Quat q(m.q_Si_B[j][0], m.q_Si_B[j][1], m.q_Si_B[j][2], m.q_Si_B[j][3]);
    if (!q.coeffs().allFinite()) {
      why = Reject::kNonFinite;
      return false;
    }
    if (std::abs(q.norm() - 1) > 1e-6) {
      why = Reject::kNonUnit;
      return false;
    }
    hk.q_Si_B = q.normalized();
  }
  heads = h;
  return true;
}

bool firstNominalMountings(const std::string& path, NominalMountings& out) {
  LcmLogReader r;
  if (!r.open(path, nullptr)) return false;
  LcmLogReader::RawEvent ev;
  for (int k = 0; k < 100000 && r.nextRaw(ev); ++k)
    if (ev.size >= 0 && *ev.channel == kMountingsChannel && decodeNominalMountings(ev.data, ev.size, out)) return true;
  return false;
}

bool decodeNominalMountings(const void* data, int size, NominalMountings& out) {
  boresight_lcm::nominal_mountings_t m{};
  if (m.decode(data, 0, size) != size) return false;
  if (m.n_heads < 1 || m.n_heads > NominalMountings::kCapacity) return false;
  out = NominalMountings{};
  out.utime = m.utime;
  out.n_heads = m.n_heads;
  for (int i = 0; i < m.n_heads; ++i) {
    out.head_id[i] = m.head_id[i];
    for (int k = 0; k < 4; ++k) out.q_Si_B[i][k] = m.q_Si_B[i][k];
  }
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out.C_B_A[r][c] = m.C_B_A[r][c];
  out.source = m.source;
  return true;
}

bool decodeOrbit(const void* data, int size, OrbitSample& out) {
  boresight_lcm::orbit_sample_t m{};
  if (m.decode(data, 0, size) != size) return false;
  if (m.frame != 'I' && m.frame != 'E') return false;
  out.utime = m.utime;
  out.frame = static_cast<char>(m.frame);
  for (int k = 0; k < 3; ++k) {
    out.r_m[k] = m.r_m[k];
    out.v_m_s[k] = m.v_m_s[k];
  }
  out.seq = m.seq;
  return true;
}

bool LcmLogWriter::close(std::string* error) {
  if (!impl_->log) return true;
  impl_->log.reset();  // flushes and closes
  if (impl_->tmp.empty()) return true;
  const bool ok = std::rename(impl_->tmp.c_str(), impl_->path.c_str()) == 0;
  if (!ok) {
    if (error) *error = impl_->path + ": cannot write the LCM log: " + std::strerror(errno);
    ::unlink(impl_->tmp.c_str());
  }
  impl_->tmp.clear();
  return ok;
}

// The reader parses the log format itself (with a 1 MB buffer) instead of lcm::LogFile, which reads
// field by field with a seek per event. An event: sync word 0xEDA1DA01, int64 event number, int64
// timestamp, int32 channel length, int32 data length, channel bytes, data bytes (big-endian).
struct LcmLogReader::Impl {
  struct Event {
    std::string channel;
    const void* data = nullptr;
    std::int32_t datalen = 0;  ///< -1: a stretch of bytes that is not an event (skipped up to the next sync word)
    std::int64_t timestamp = 0;
  };
  std::FILE* f = nullptr;
  std::vector<char> buf;
  std::size_t begin = 0, end = 0;
  bool eof = false;
  std::uint64_t file_size = 0, file_read = 0;  ///< size at open; bytes read from the file so far
  Event ev;

  ~Impl() { close(); }
  void close() {
    if (f) std::fclose(f);
    f = nullptr;
  }
  static std::uint32_t be32(const unsigned char* p) {
    return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | std::uint32_t{p[3]};
  }
  /// Unread bytes: in the buffer and in the file after it (as of the size at open).
  std::uint64_t available() const {
    return (end - begin) + (file_size > file_read ? file_size - file_read : 0);
  }
  /// At least n unread bytes in buf (false: the file ends before).
  bool need(std::size_t n) {
    while (end - begin < n) {
      if (eof || !f) return false;
      // An event header that claims more bytes than the file has left is a cut (or damaged) last
      // event: answered without growing the buffer to the claimed size (up to 64 MB per event).
      if (file_size > 0 && n > available()) {
        eof = true;
        return false;
      }
      if (begin > 0) {
        std::memmove(buf.data(), buf.data() + begin, end - begin);
        end -= begin;
        begin = 0;
      }
      // 1 MB reads, or the whole file when it is smaller.
      const std::size_t chunk = file_size > 0 ? static_cast<std::size_t>(std::min<std::uint64_t>(file_size, 1u << 20)) : (1u << 20);
      if (buf.size() < std::max(n, chunk)) buf.resize(std::max(n, chunk));
      const std::size_t got = std::fread(buf.data() + end, 1, buf.size() - end, f);
      end += got;
      file_read += got;
      if (got == 0) eof = true;
    }
    return true;
  }
  const Event* readNextEvent() {
    constexpr std::size_t kHeader = 28;
    constexpr std::uint32_t kSync = 0xEDA1DA01u, kMaxChannel = 1024, kMaxData = 64u << 20;
    bool skipped = false;
    auto notAnEvent = [&] {
      ev.channel.clear();
      ev.data = nullptr;
      ev.datalen = -1;
      return &ev;
    };
    for (;;) {
      if (!need(kHeader)) {
        // The end. Bytes left over (a cut last event, trailing junk) are reported once, not dropped.
        if (end > begin || skipped) {
          begin = end;
          return notAnEvent();
        }
        return nullptr;
      }
      const auto* p = reinterpret_cast<const unsigned char*>(buf.data() + begin);
      const std::uint32_t clen = be32(p + 20), dlen = be32(p + 24);
      // A length that runs past the end of the file is damage, not an event: resynchronise at the
      // next sync word (so one bad length costs that event, not the rest of the log).
      if (be32(p) != kSync || clen > kMaxChannel || dlen > kMaxData ||
          (file_size > 0 && kHeader + clen + dlen > available())) {
        ++begin;  // not an event here: look for the next sync word
        skipped = true;
        continue;
      }
      if (skipped) return notAnEvent();
      if (!need(kHeader + clen + dlen)) {
        begin = end;  // a cut last event
        return notAnEvent();
      }
      p = reinterpret_cast<const unsigned char*>(buf.data() + begin);
      ev.timestamp = static_cast<std::int64_t>((std::uint64_t{be32(p + 12)} << 32) | be32(p + 16));
      ev.channel.assign(reinterpret_cast<const char*>(p + kHeader), clen);
      ev.data = p + kHeader + clen;
      ev.datalen = static_cast<std::int32_t>(dlen);
      begin += kHeader + clen + dlen;
      return &ev;
    }
  }
};

LcmLogReader::LcmLogReader() : impl_(new Impl) {}
LcmLogReader::~LcmLogReader() = default;

bool LcmLogReader::open(const std::string& path, std::string* error) {
  // An LCM log is recognised by its content: every event starts with the sync word 0xEDA1DA01
  // (big-endian), so the first four bytes of a log are that word. Anything else is refused here
  // rather than read as an empty log.
  {
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) {
      if (error) *error = path + ": cannot open LCM log: " + std::strerror(errno);
      return false;
    }
    unsigned char b[4] = {0, 0, 0, 0};
    const std::size_t got = std::fread(b, 1, 4, f);
    std::fclose(f);
    // An empty file is an empty log (a writer that wrote no events leaves one).
    if (got != 0 && (got != 4 || b[0] != 0xED || b[1] != 0xA1 || b[2] != 0xDA || b[3] != 0x01)) {
      if (error)
        *error = path + ": not an LCM log: " +
                 (got < 4 ? std::string("shorter than one event header")
                          : std::string("no LCM event sync word (0xEDA1DA01) at byte 0"));
      return false;
    }
  }
  impl_->close();
  impl_->f = std::fopen(path.c_str(), "rb");
  if (!impl_->f) {
    if (error) *error = path + ": cannot open LCM log: " + std::strerror(errno);
    return false;
  }
  impl_->begin = impl_->end = 0;
  impl_->eof = false;
  impl_->file_read = 0;
  impl_->file_size = 0;
  if (std::fseek(impl_->f, 0, SEEK_END) == 0) {
    const long size = std::ftell(impl_->f);
    impl_->file_size = size > 0 ? static_cast<std::uint64_t>(size) : 0;
  }
  std::rewind(impl_->f);
  unknown_channel_ = decode_failures_ = other_versions_ = 0;  // a reader opened again counts the new log only
  return true;
}

bool LcmLogReader::nextRaw(RawEvent& out) {
  const Impl::Event* ev = impl_->readNextEvent();
  if (!ev) return false;
  out.channel = &ev->channel;
  out.data = ev->data;
  out.size = ev->datalen;
  out.timestamp = ev->timestamp;
  return true;
}

bool inputKindOf(const std::string& channel, InputKind& kind) {
  if (channel == kStarHeadChannel) kind = InputKind::kHead;
  else if (channel == kAccelChannel) kind = InputKind::kAccel;
  else if (channel == kStarVectorsChannel) kind = InputKind::kStars;
  else if (channel == kOrbitChannel) kind = InputKind::kOrbit;
  else return false;
  return true;
}

LcmLogReader::Kind LcmLogReader::next(HeadSample& head, AccelSample& accel) {
  const Impl::Event* ev = impl_->readNextEvent();
  if (!ev) return Kind::End;
  if (ev->datalen < 0) {  // bytes that are no event, up to the next sync word
    ++decode_failures_;
    return Kind::Skipped;
  }
  InputKind kind;
  if (!inputKindOf(ev->channel, kind)) {
    ++unknown_channel_;
    return Kind::Skipped;
  }
  if (!decodeInput(kind, ev->data, ev->datalen, msg_)) {
    ++(isOtherVersion(inputTypeName(kind), ev->data, ev->datalen) ? other_versions_ : decode_failures_);
    return Kind::Skipped;
  }
  switch (kind) {
    case InputKind::kHead: head = msg_.head; return Kind::Head;
    case InputKind::kAccel: accel = msg_.accel; return Kind::Accel;
    case InputKind::kStars: return Kind::Stars;
    case InputKind::kOrbit: return Kind::Orbit;
  }
  return Kind::Skipped;
}

TimeUs InputMessage::utime() const {
  switch (kind) {
    case InputKind::kHead: return head.utime;
    case InputKind::kAccel: return accel.utime;
    case InputKind::kStars: return stars.utime;
    case InputKind::kOrbit: return orbit.utime;
  }
  return 0;
}

std::int32_t InputMessage::seq() const {
  switch (kind) {
    case InputKind::kHead: return head.seq;
    case InputKind::kAccel: return accel.seq;
    case InputKind::kStars: return stars.seq;
    case InputKind::kOrbit: return orbit.seq;
  }
  return 0;
}

namespace {
struct VersionRow {
  const char* type;
  int version;
  std::uint64_t fingerprint;
};
constexpr VersionRow kVersionRows[] = {
#include "boresight_lcm/versions.inc"
};
constexpr int kNumVersions = static_cast<int>(sizeof kVersionRows / sizeof kVersionRows[0]);
constexpr bool sameName(const char* a, const char* b) {
  for (; *a && *a == *b; ++a, ++b) {
  }
  return *a == *b;
}
/// The table with `current` set (the highest version of each type), formed at compile time.
constexpr std::array<LcmTypeVersion, kNumVersions> makeVersionTable() {
  std::array<LcmTypeVersion, kNumVersions> t{};
  for (int i = 0; i < kNumVersions; ++i) {
    const VersionRow& r = kVersionRows[i];
    int newest = 0;
    for (int j = 0; j < kNumVersions; ++j)
      if (sameName(kVersionRows[j].type, r.type) && kVersionRows[j].version > newest) newest = kVersionRows[j].version;
    t[static_cast<std::size_t>(i)] = LcmTypeVersion{r.type, r.version, r.fingerprint, r.version == newest};
  }
  return t;
}
constexpr std::array<LcmTypeVersion, kNumVersions> kVersionTable = makeVersionTable();
}  // namespace

const LcmTypeVersion* lcmTypeVersions(int& n) {
  n = kNumVersions;
  return kVersionTable.data();
}

const LcmTypeVersion* lcmTypeVersionOf(const void* data, int size) {
  if (!data || size < 8) return nullptr;
  const auto* b = static_cast<const unsigned char*>(data);
  std::uint64_t fp = 0;
  for (int i = 0; i < 8; ++i) fp = (fp << 8) | b[i];
  for (const LcmTypeVersion& v : kVersionTable)
    if (v.fingerprint == fp) return &v;
  return nullptr;
}

bool isOtherVersion(const char* type, const void* data, int size) {
  const LcmTypeVersion* v = lcmTypeVersionOf(data, size);
  return v && !v->current && sameName(v->type, type);
}

const char* inputTypeName(InputKind kind) {
  switch (kind) {
    case InputKind::kHead: return "star_head_sample_t";
    case InputKind::kAccel: return "accel_sample_t";
    case InputKind::kStars: return "star_vectors_t";
    case InputKind::kOrbit: return "orbit_sample_t";
  }
  return "";
}

bool decodeInput(InputKind kind, const void* data, int size, InputMessage& out) {
  out.kind = kind;
  switch (kind) {
    case InputKind::kHead: {
      boresight_lcm::star_head_sample_t m;
      if (m.decode(data, 0, size) != size) return false;
      HeadSample& h = out.head;
      h.utime = m.utime;
      h.head_id = m.head_id;
      for (int i = 0; i < 4; ++i) h.q[i] = m.q[i];
      h.star_count = m.star_count;
      h.flags = m.flags;
      h.seq = m.seq;
      return true;
    }
    case InputKind::kAccel: {
      boresight_lcm::accel_sample_t m;
      if (m.decode(data, 0, size) != size) return false;
      AccelSample& a = out.accel;
      a.utime = m.utime;
      for (int i = 0; i < 3; ++i) {
        a.ang_accel[i] = m.ang_accel[i];
        a.lin_accel[i] = m.lin_accel[i];
      }
      a.flags = m.flags;
      a.seq = m.seq;
      return true;
    }
    case InputKind::kStars: return decodeStarVectors(data, size, out.stars);
    case InputKind::kOrbit: return decodeOrbit(data, size, out.orbit);
  }
  return false;
}

const char* inputFaultName(InputFault f) {
  switch (f) {
    case InputFault::kNone: return "none";
    case InputFault::kInvalidFlag: return "invalid_flag";
    case InputFault::kNonFinite: return "non_finite";
    case InputFault::kNonUnit: return "non_unit";
    case InputFault::kImplausible: return "implausible";
  }
  return "?";
}

InputFault checkInput(const InputMessage& m, double quat_tol) {
  auto finite = [](const double* v, int n) {
    for (int i = 0; i < n; ++i)
      if (!std::isfinite(v[i])) return false;
    return true;
  };
  switch (m.kind) {
    case InputKind::kHead:
      if (!(m.head.flags & 1)) return InputFault::kInvalidFlag;
      switch (plausibility::checkQuaternion(m.head.q, quat_tol)) {
        case plausibility::Quaternion::kOk: return InputFault::kNone;
        case plausibility::Quaternion::kNonFinite: return InputFault::kNonFinite;
        default: return InputFault::kNonUnit;
      }
    case InputKind::kAccel:
      if (!(m.accel.flags & 1)) return InputFault::kInvalidFlag;
      if (!finite(m.accel.ang_accel, 3)) return InputFault::kNonFinite;
      return plausibility::angularAccelPlausible(m.accel.ang_accel) ? InputFault::kNone : InputFault::kImplausible;
    case InputKind::kStars: {
      const StarVectors& s = m.stars;
      if (!(s.flags & 1) || s.n_stars == 0) return InputFault::kInvalidFlag;
      for (int i = 0; i < s.n_stars; ++i)
        if (!finite(s.s_head[i], 3) || !finite(s.r_inertial[i], 3) || !std::isfinite(s.sigma_rad[i]))
          return InputFault::kNonFinite;
      for (int i = 0; i < s.n_stars; ++i)
        if (!plausibility::directionPlausible(s.s_head[i]) || !plausibility::directionPlausible(s.r_inertial[i]))
          return InputFault::kNonUnit;
      for (int i = 0; i < s.n_stars; ++i)
        if (s.sigma_rad[i] < 0) return InputFault::kImplausible;
      return InputFault::kNone;
    }
    case InputKind::kOrbit:
      if (!finite(m.orbit.r_m, 3) || !finite(m.orbit.v_m_s, 3)) return InputFault::kNonFinite;
      return plausibility::orbitRadiusPlausible(m.orbit.r_m) && plausibility::orbitSpeedPlausible(m.orbit.v_m_s)
                 ? InputFault::kNone
                 : InputFault::kImplausible;
  }
  return InputFault::kNone;
}

HeadSample headFromSca1a(const Sca1aRecord& r, std::int32_t seq) {
  HeadSample h;
  h.utime = r.t;
  h.head_id = r.head;
  for (int i = 0; i < 4; ++i) h.q[i] = r.q[i];
  h.star_count = r.nstars;
  h.flags = 1;
  h.seq = seq;
  return h;
}

AccelSample accelFromAcc1a(const FlaggedRecord& r, std::int32_t seq) {
  AccelSample s;
  s.utime = r.t;
  s.flags = 0;
  if (r.has(acc_bits::kAngX) && r.has(acc_bits::kAngY) && r.has(acc_bits::kAngZ)) {
    for (int i = 0; i < 3; ++i) s.ang_accel[i] = r.value[static_cast<std::size_t>(acc_bits::kAngX + i)];
    s.flags |= 1;
  }
  if (r.has(acc_bits::kLinX) && r.has(acc_bits::kLinY) && r.has(acc_bits::kLinZ)) {
    for (int i = 0; i < 3; ++i) s.lin_accel[i] = r.value[static_cast<std::size_t>(acc_bits::kLinX + i)];
    s.flags |= 2;
  }
  s.seq = seq;
  return s;
}

Sca1aRecord sca1aFromHead(const HeadSample& h, char satellite) {
  Sca1aRecord rec;
  rec.t = h.utime;
  rec.satellite = satellite;
  rec.head = static_cast<std::uint8_t>(h.head_id);
  for (int i = 0; i < 4; ++i) rec.q[i] = h.q[i];
  rec.nstars = h.star_count;
  return rec;
}

FlaggedRecord acc1aFromAccel(const AccelSample& s, char satellite) {
  FlaggedRecord rec;
  rec.t = s.utime;
  rec.time_ref = 'R';
  rec.satellite = satellite;
  rec.prod_flag = Bits{0, 32};
  if (s.flags & 2) {
    rec.prod_flag.value |= 0x7u;
    for (int i = 0; i < 3; ++i) rec.value[static_cast<std::size_t>(acc_bits::kLinX + i)] = s.lin_accel[i];
  }
  if (s.flags & 1) {
    rec.prod_flag.value |= 0x38u;
    for (int i = 0; i < 3; ++i) rec.value[static_cast<std::size_t>(acc_bits::kAngX + i)] = s.ang_accel[i];
  }
  return rec;
}

bool readLcmAsLevel1(const std::string& path, char satellite, bool drop_invalid, LcmAsLevel1& out,
                     std::string* error) {
  out = LcmAsLevel1{};
  LcmLogReader r;
  if (!r.open(path, error)) return false;
  HeadSample h;
  AccelSample s;
  for (;;) {
    auto k = r.next(h, s);
    if (k == LcmLogReader::Kind::End) break;
    if (k == LcmLogReader::Kind::Head) {
      if (!(h.flags & 1)) {
        ++out.invalid_heads;
        if (drop_invalid) continue;
      }
      out.sca.push_back(sca1aFromHead(h, satellite));
    } else if (k == LcmLogReader::Kind::Accel) {
      if (!(s.flags & 1)) {
        ++out.invalid_accel;
        if (drop_invalid) continue;
      }
      out.acc.push_back(acc1aFromAccel(s, satellite));
    }
  }
  out.unknown_channel = r.unknownChannel();
  out.decode_failures = r.decodeFailures();
  return true;
}

}  // namespace boresight::io
