// Level-1 and LCM log sources of the replay engine; input recognition by content.
#include <boresight/io/lcm_log.h>
#include <boresight/stream/sources.h>

#include <algorithm>
#include <cmath>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <sys/stat.h>

namespace boresight::stream {


bool hasLcmMagic(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return false;
  unsigned char b[4] = {0, 0, 0, 0};
  const bool got = std::fread(b, 1, 4, f) == 4;
  std::fclose(f);
  return got && b[0] == 0xED && b[1] == 0xA1 && b[2] == 0xDA && b[3] == 0x01;
}

FileKind identifyFile(const std::string& path) {
  FileKind k;
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode)) {
    k.reason = path + ":0: is a directory, not an input file";
    return k;
  }
  if (std::FILE* f = std::fopen(path.c_str(), "rb")) {
    std::fclose(f);
  } else {
    k.reason = path + ":0: cannot open: " + std::strerror(errno);
    return k;
  }
  if (hasLcmMagic(path)) {
    k.type = FileKind::Type::kLcmLog;
    return k;
  }
  io::LineStream ls;
  std::string err;
  if (!ls.open(path, {}, &err, 4096)) {
    k.reason = err + " (neither an LCM log nor a Level-1 product)";
    return k;
  }
  k.type = FileKind::Type::kLevel1;
  k.product = ls.header().product;
  k.product_name = ls.header().product_name;
  return k;
}

namespace {

/// One star vector as a sample (the SCV1A and STAR_VECTORS sources).
Sample starSample(TimeUs t, int head, const double s[3], const double r[3], double sigma_rad) {
  Sample out;
  out.kind = Sample::Kind::kStar;
  out.t = t;
  out.head_id = head;
  out.star.head_id = head;
  out.star.s_Sk = Vec3(s[0], s[1], s[2]);
  out.star.r_I = Vec3(r[0], r[1], r[2]);
  out.star.sigma_rad = sigma_rad;
  return out;
}

}  // namespace

Source::Next Sca1aSource::next(Sample& out, Reject& why) {
  const Next n = nextRecord(why);
  if (n == Next::kSample) {
    out.kind = Sample::Kind::kHead;
    out.t = rec_.t;
    out.head_id = rec_.head;
    out.q_I_S = quatFromScalarFirst(rec_.q);
    out.star_count = rec_.nstars;
    out.flags = 1;
  }
  return n;
}

Source::Next Acc1aSource::next(Sample& out, Reject& why) {
  const Next n = nextRecord(why);
  if (n != Next::kSample) return n;
  // The same fields and validity bits as the message (io::accelFromAcc1a).
  const io::AccelSample m = io::accelFromAcc1a(rec_, 0);
  if (!(m.flags & 1) && !keep_without_angular_) {
    why = Reject::kInvalidFlag;
    return Next::kRejected;
  }
  out.kind = Sample::Kind::kAccel;
  out.t = m.utime;
  out.a_A = Vec3(m.ang_accel[0], m.ang_accel[1], m.ang_accel[2]);
  out.lin_A = Vec3(m.lin_accel[0], m.lin_accel[1], m.lin_accel[2]);
  out.flags = m.flags;
  return n;
}

Source::Next ScvSource::next(Sample& out, Reject& why) {
  const Next n = nextRecord(why);
  if (n == Next::kSample) out = starSample(rec_.t, rec_.head, rec_.s, rec_.r, 0.0);  // 0: configured sigma
  return n;
}

namespace {
/// An orbit record or message as a sample. The gates are applied before: the GNV1B/GNI1B reader's
/// (rejected lines come as kImplausible) and io::checkInput for ORBIT messages.
void orbitSample(TimeUs t, char frame, const double r[3], const double v[3], Sample& out) {
  out = Sample{};
  out.kind = Sample::Kind::kOrbit;
  out.t = t;
  out.orbit_frame = frame;
  out.r_orbit = Vec3(r[0], r[1], r[2]);
  out.v_orbit = Vec3(v[0], v[1], v[2]);
}
}  // namespace

Source::Next OrbitFileSource::next(Sample& out, Reject& why) {
  const Next n = nextRecord(why);
  if (n != Next::kSample) return n;
  if (rec_.coord_ref != 'I' && rec_.coord_ref != 'E') {
    why = Reject::kMalformed;
    return Next::kRejected;
  }
  orbitSample(rec_.t, rec_.coord_ref, rec_.pos, rec_.vel, out);
  return Next::kSample;
}

LcmLogSource::LcmLogSource() = default;
LcmLogSource::~LcmLogSource() = default;

bool LcmLogSource::open(const std::string& path, std::string* error) {
  name_ = path;
  r_ = std::make_unique<io::LcmLogReader>();
  if (!r_->open(path, error)) {
    r_.reset();
    return false;
  }
  return true;
}

Source::Next LcmLogSource::next(Sample& out, Reject& why) {
  if (!r_) return Next::kEnd;
  if (star_next_ < star_n_) {  // the rest of a STAR_VECTORS message, one star per sample
    const io::StarVectors& m = r_->stars();
    const auto k = static_cast<std::size_t>(star_next_++);
    out = starSample(m.utime, m.head_id, m.s_head[k], m.r_inertial[k], m.sigma_rad[k]);
    return Next::kSample;
  }
  io::HeadSample h;
  io::AccelSample a;
  const std::uint64_t undecodable = r_->decodeFailures(), other_version = r_->otherVersions();
  const io::LcmLogReader::Kind k = r_->next(h, a);
  if (k == io::LcmLogReader::Kind::End) return Next::kEnd;
  if (k == io::LcmLogReader::Kind::Skipped) {
    why = r_->otherVersions() != other_version ? Reject::kOtherVersion
          : r_->decodeFailures() != undecodable ? Reject::kMalformed
                                                : Reject::kOtherChannel;
    return Next::kRejected;
  }
  // The node's rule (io::checkInput) and its reasons.
  const io::InputMessage& m = r_->message();
  switch (io::checkInput(m, quat_tol_)) {
    case io::InputFault::kNone: break;
    case io::InputFault::kInvalidFlag: why = Reject::kInvalidFlag; return Next::kRejected;
    case io::InputFault::kNonFinite: why = Reject::kNonFinite; return Next::kRejected;
    case io::InputFault::kNonUnit: why = Reject::kNonUnit; return Next::kRejected;
    case io::InputFault::kImplausible: why = Reject::kImplausible; return Next::kRejected;
  }
  switch (m.kind) {
    case io::InputKind::kHead:
      out = Sample{};
      out.kind = Sample::Kind::kHead;
      out.t = h.utime;
      out.head_id = h.head_id;
      out.q_I_S = quatFromScalarFirst(h.q);
      out.star_count = h.star_count;
      out.flags = h.flags;
      return Next::kSample;
    case io::InputKind::kAccel:
      out = Sample{};
      out.kind = Sample::Kind::kAccel;
      out.t = a.utime;
      out.a_A = Vec3(a.ang_accel[0], a.ang_accel[1], a.ang_accel[2]);
      out.lin_A = Vec3(a.lin_accel[0], a.lin_accel[1], a.lin_accel[2]);
      out.flags = a.flags;
      return Next::kSample;
    case io::InputKind::kStars:  // one sample per star
      star_n_ = m.stars.n_stars;
      star_next_ = 0;
      return next(out, why);
    case io::InputKind::kOrbit: {
      const io::OrbitSample& o = m.orbit;
      orbitSample(o.utime, o.frame, o.r_m, o.v_m_s, out);
      return Next::kSample;
    }
  }
  return Next::kEnd;
}

Source::Next PushSource::next(Sample& out, Reject&) {
  if (!buf_.pop(out)) return closed_ ? Next::kEnd : Next::kPending;
  return Next::kSample;
}

}  // namespace boresight::stream
