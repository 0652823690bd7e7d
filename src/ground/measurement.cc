// Reader, validator and writer of the method C measurement file (format in measurement.h).
#include <boresight/ground/measurement.h>
#include <boresight/io/files.h>
#include <boresight/io/yaml_file.h>

#include <boresight/core/rotation.h>

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <initializer_list>
#include <sstream>

namespace boresight::ground {
namespace {

/// A located parse error, thrown inside this file only and turned into "name:line: reason".
struct Located {
  int line;  // 1-based, 0 = unknown
  std::string what;
};

int lineOf(const YAML::Node& n) { return n.Mark().line >= 0 ? n.Mark().line + 1 : 0; }

[[noreturn]] void fail(const YAML::Node& n, const std::string& what) { throw Located{lineOf(n), what}; }

void checkKeys(const YAML::Node& map, const char* where, std::initializer_list<const char*> allowed) {
  if (!map.IsMap()) fail(map, std::string(where) + ": expected a map");
  for (const auto& kv : map) {
    const std::string k = kv.first.Scalar();
    if (std::none_of(allowed.begin(), allowed.end(), [&](const char* a) { return k == a; }))
      fail(kv.first, std::string(where) + ": unknown key '" + k + "'");
  }
}

YAML::Node need(const YAML::Node& map, const char* key, const char* where) {
  const YAML::Node n = map[key];
  if (!n) fail(map, std::string(where) + ": missing key '" + key + "'");
  return n;
}

/// A number from a scalar's text: strtod (yaml-cpp's as<double> goes through a stringstream, 3x
/// slower); YAML's .nan / .inf spellings are refused like strtod's nan / inf. Shared by the node
/// reader and the sample reader below, so both refuse the same texts with the same words.
double numberText(const std::string& t, int line, const std::string& what) {
  const char* b = t.c_str();
  char* end = nullptr;
  const double x = std::strtod(b, &end);
  const bool special = t == ".nan" || t == ".NaN" || t == ".NAN" || t.find(".inf") != std::string::npos ||
                       t.find(".Inf") != std::string::npos || t.find(".INF") != std::string::npos;
  if (special || (end != b && *end == '\0' && !std::isfinite(x)))
    throw Located{line, what + ": not a finite number ('" + t + "')"};
  if (end == b || *end != '\0') throw Located{line, what + ": '" + t + "' is not a number"};
  return x;
}

double number(const YAML::Node& n, const std::string& what) {
  if (!n.IsScalar()) fail(n, what + ": expected a number");
  return numberText(n.Scalar(), lineOf(n), what);
}

std::vector<double> numbers(const YAML::Node& n, std::size_t count, const std::string& what) {
  if (!n.IsSequence() || n.size() != count)
    fail(n, what + ": expected a list of " + std::to_string(count) + " numbers");
  std::vector<double> v;
  for (std::size_t i = 0; i < count; ++i) v.push_back(number(n[i], what));
  return v;
}

double positive(const YAML::Node& n, const std::string& what) {
  const double x = number(n, what);
  if (!(x > 0)) fail(n, what + ": must be positive");
  return x;
}

// ---- The accelerometer samples --------------------------------------------------------------
// yaml-cpp's scanner costs ~25 us per number, so a file of 3 x 2000 samples took ~60 ms to load
// (its event parser alone ~57 ms: the scanner, not the node tree, is the cost). The samples are
// therefore read by this reader and by nothing else: before yaml-cpp sees the text, the value of
// every `accel_mps2:` key that starts a line (after its indentation and any "- ") is parsed here and
// replaced by the placeholder `!boresight-accel K` plus the value's newlines, so yaml-cpp's line
// numbers stay those of the file. readPosition takes block K; an accel_mps2 value yaml-cpp sees
// without the placeholder (a quoted key, a key after "{" on its line) is refused, never parsed a
// second way. Accepted values: a block list of flow triples (one "- [fx, fy, fz]" per item, an
// item may continue on deeper lines) or a flow list of triples ("[[fx, fy, fz], ...]", across
// lines), with comments. Numbers must be plain scalars (no quotes, anchors or tags).

constexpr const char* kSampleTag = "!boresight-accel";

struct SampleBlock {
  int key_line = 0;
  std::vector<Vec3> samples;
  bool failed = false;
  int err_line = 0;
  std::string err;  // the message after "position N: "
  bool used = false;
};

class SampleReader {
 public:
  explicit SampleReader(const std::string& t) : t_(t), n_(t.size()) {}

  /// The text for yaml-cpp (the samples replaced by placeholders); fills `blocks`.
  std::string run(std::vector<SampleBlock>& blocks) {
    std::string out;
    out.reserve(n_ / 8 + 256);
    std::size_t i = 0, copied = 0;
    int line = 1;
    while (i < n_) {
      std::size_t j = i;
      while (j < n_ && t_[j] == ' ') ++j;
      while (j + 1 < n_ && t_[j] == '-' && (t_[j + 1] == ' ' || t_[j + 1] == '\t')) {
        j += 2;
        while (j < n_ && (t_[j] == ' ' || t_[j] == '\t')) ++j;
      }
      static constexpr char kKey[] = "accel_mps2:";
      constexpr std::size_t kLen = sizeof kKey - 1;
      if (t_.compare(j, kLen, kKey) == 0 && (j + kLen == n_ || isBlank(t_[j + kLen]) || isEol(t_[j + kLen]))) {
        SampleBlock b;
        b.key_line = line;
        const std::size_t v = j + kLen;
        std::size_t end = v;
        int end_line = line;
        readValue(v, line, static_cast<int>(j - i), b, end, end_line);
        out.append(t_, copied, v - copied);
        out += ' ';
        out += kSampleTag;
        out += ' ';
        out += std::to_string(blocks.size());
        out.append(static_cast<std::size_t>(end_line - line), '\n');
        blocks.push_back(std::move(b));
        copied = end;
        i = end;
        line = end_line;
        if (i > 0 && i < n_ && t_[i - 1] == '\n') continue;  // the value ended at a line start
      }
      const std::size_t nl = t_.find('\n', i);
      if (nl == std::string::npos) break;
      i = nl + 1;
      ++line;
    }
    if (copied < n_) out.append(t_, copied, std::string::npos);
    return out;
  }

 private:
  static bool isBlank(char c) { return c == ' ' || c == '\t'; }
  static bool isEol(char c) { return c == '\n' || c == '\r'; }

  /// Skips blanks, '\r', comments (a '#' after a blank or at a line start) and, when `lines`, newlines.
  void skipSpace(std::size_t& i, int& line, std::size_t lim, bool lines) const {
    while (i < lim) {
      const char c = t_[i];
      if (isBlank(c) || c == '\r') {
        ++i;
      } else if (c == '\n' && lines) {
        ++i;
        ++line;
      } else if (c == '#' && (i == 0 || isBlank(t_[i - 1]) || t_[i - 1] == '\n')) {
        while (i < lim && t_[i] != '\n') ++i;
      } else {
        return;
      }
    }
  }

  /// End of the flow collection opening at `i` (index after its closing bracket; npos if unclosed).
  std::size_t flowEnd(std::size_t i) const {
    int depth = 0;
    for (; i < n_; ++i) {
      const char c = t_[i];
      if (c == '[' || c == '{') {
        ++depth;
      } else if (c == ']' || c == '}') {
        if (--depth == 0) return i + 1;
      } else if (c == '#' && i > 0 && (isBlank(t_[i - 1]) || t_[i - 1] == '\n')) {
        while (i + 1 < n_ && t_[i + 1] != '\n') ++i;
      } else if (c == '"' || c == '\'') {
        for (++i; i < n_ && t_[i] != c; ++i)
          if (c == '"' && t_[i] == '\\') ++i;
      }
    }
    return std::string::npos;
  }

  /// Sample `index` "[fx, fy, fz]" with `i` at its '['; throws Located.
  Vec3 triple(std::size_t& i, int& line, std::size_t lim, std::size_t index) const {
    const int line0 = line;
    const auto what = [index] { return sampleWhat(index); };
    const auto shape = [&] { return what() + ": expected a list of 3 numbers"; };
    std::size_t tb[3] = {0, 0, 0}, te[3] = {0, 0, 0};
    int tl[3] = {0, 0, 0};
    int count = 0;
    ++i;
    for (;;) {
      skipSpace(i, line, lim, true);
      if (i >= lim) throw Located{line0, what() + ": the [ list is not closed"};
      const char c = t_[i];
      if (c == ']') {
        ++i;
        break;
      }
      if (c == '"' || c == '\'') throw Located{line, what() + ": a quoted value where a plain number belongs"};
      if (c == ',' || c == '[' || c == '{' || c == '}') throw Located{line0, shape()};
      const std::size_t b = i;
      while (i < lim) {
        const char d = t_[i];
        if (d == ',' || d == ']' || d == '[' || d == '{' || d == '}' || isEol(d)) break;
        if (d == '#' && isBlank(t_[i - 1])) break;
        ++i;
      }
      std::size_t e = i;
      while (e > b && isBlank(t_[e - 1])) --e;
      if (count < 3) {
        tb[count] = b;
        te[count] = e;
        tl[count] = line;
      }
      ++count;
      skipSpace(i, line, lim, true);
      if (i >= lim) throw Located{line0, what() + ": the [ list is not closed"};
      if (t_[i] == ',') {
        ++i;
      } else if (t_[i] == ']') {
        ++i;
        break;
      } else {
        throw Located{line0, shape()};
      }
    }
    if (count != 3) throw Located{line0, shape()};
    Vec3 f;
    for (int k = 0; k < 3; ++k) {
      // strtod in place; anything it does not take whole as a finite number goes through numberText
      // for the same verdict and message as every other number of the file
      const char* b = t_.c_str() + tb[k];
      char* e = nullptr;
      f[k] = std::strtod(b, &e);
      if (e != t_.c_str() + te[k] || e == b || !std::isfinite(f[k]))
        f[k] = numberText(t_.substr(tb[k], te[k] - tb[k]), tl[k], what());
    }
    return f;
  }

  static std::string sampleWhat(std::size_t k) { return "accel_mps2 sample " + std::to_string(k + 1); }

  /// Parses the value after the key at `v` (key column `keycol`): its extent [v, end) ends on line
  /// end_line; the samples or the first error go to `b`.
  void readValue(std::size_t v, int line, int keycol, SampleBlock& b, std::size_t& end, int& end_line) const {
    std::size_t k = v;
    while (k < n_ && isBlank(t_[k])) ++k;
    try {
      if (k < n_ && t_[k] == '[') {  // flow list [[fx, fy, fz], ...]
        end = flowEnd(k);
        const bool closed = end != std::string::npos;
        if (!closed) end = n_;
        end_line = line + static_cast<int>(std::count(t_.begin() + static_cast<long>(v), t_.begin() + static_cast<long>(end), '\n'));
        if (!closed) throw Located{line, "accel_mps2: the [ list is not closed"};
        std::size_t after = end;  // what may follow the list on its line (a flow map's ',' or '}')
        while (after < n_ && (isBlank(t_[after]) || t_[after] == '\r')) ++after;
        if (after < n_ && t_[after] != '\n' && t_[after] != '#' && t_[after] != ',' && t_[after] != '}' && t_[after] != ']') {
          end = std::min(t_.find('\n', after), n_);  // the placeholder takes the tail too
          throw Located{end_line, "accel_mps2: unexpected text after the list"};
        }
        std::size_t i = k + 1;
        int ln = line;
        for (;;) {
          skipSpace(i, ln, end, true);
          if (i >= end) throw Located{line, "accel_mps2: the [ list is not closed"};
          if (t_[i] == ']') break;
          if (t_[i] != '[') throw Located{ln, sampleWhat(b.samples.size()) + ": expected a list of 3 numbers"};
          b.samples.push_back(triple(i, ln, end, b.samples.size()));
          skipSpace(i, ln, end, true);
          if (i < end && t_[i] == ',') {
            ++i;
          } else if (!(i < end && t_[i] == ']')) {
            throw Located{ln, "accel_mps2: expected ',' or ']' after sample " + std::to_string(b.samples.size())};
          }
        }
        return;
      }
      if (k < n_ && !isEol(t_[k]) && t_[k] != '#') {  // neither list form: refused where it stands
        end = t_.find('\n', k);
        if (end == std::string::npos) end = n_;
        end_line = line;
        throw Located{line, "accel_mps2: expected a list of [fx, fy, fz]"};
      }
      // block list: the items "- [...]" at one column >= the key's, deeper lines continue an item
      std::size_t pos = t_.find('\n', k);
      pos = pos == std::string::npos ? n_ : pos + 1;
      int ln = line + (pos < n_ || (n_ > 0 && t_[n_ - 1] == '\n') ? 1 : 0);
      end = pos;
      end_line = ln;
      int col = -1;
      while (pos < n_) {
        std::size_t f = pos;
        while (f < n_ && t_[f] == ' ') ++f;
        const int ind = static_cast<int>(f - pos);
        const bool blank = f >= n_ || isEol(t_[f]) || t_[f] == '#';
        const bool item = f < n_ && t_[f] == '-' && (f + 1 >= n_ || isBlank(t_[f + 1]) || isEol(t_[f + 1]));
        if (!blank) {
          if (col < 0 && item && ind >= keycol) {
            col = ind;
          } else if (col < 0 || !(ind > col || (ind == col && item))) {
            break;
          }
        }
        const std::size_t nl = t_.find('\n', pos);
        pos = nl == std::string::npos ? n_ : nl + 1;
        ++ln;
        if (!blank) {
          end = pos;
          end_line = nl == std::string::npos ? ln - 1 : ln;
        }
      }
      if (col < 0) {  // nothing below the key: a null value
        end = k;
        end_line = line;
        throw Located{line, "accel_mps2: expected a list of [fx, fy, fz]"};
      }
      std::size_t i = t_.find('\n', k) + 1;
      ln = line + 1;
      while (i < end) {
        skipSpace(i, ln, end, true);
        if (i >= end) break;
        std::size_t ls = t_.rfind('\n', i);
        ls = ls == std::string::npos ? 0 : ls + 1;
        const std::size_t index = b.samples.size();
        if (static_cast<int>(i - ls) != col || t_[i] != '-')
          throw Located{ln, "accel_mps2: unexpected text in the list of samples"};
        ++i;
        while (i < end && isBlank(t_[i])) ++i;
        if (i >= end || t_[i] != '[') throw Located{ln, sampleWhat(index) + ": expected a list of 3 numbers"};
        b.samples.push_back(triple(i, ln, end, index));
        skipSpace(i, ln, end, false);
        if (i < end && t_[i] != '\n') throw Located{ln, sampleWhat(index) + ": unexpected text after the list"};
      }
    } catch (const Located& e) {
      b.failed = true;
      b.err_line = e.line;
      b.err = e.what;
    }
  }

  const std::string& t_;
  std::size_t n_;
};

/// The samples of position map `p` (its accel_mps2 value is a placeholder left by SampleReader).
std::vector<Vec3> takeSamples(const YAML::Node& p, const std::string& where, std::vector<SampleBlock>& blocks) {
  const YAML::Node n = need(p, "accel_mps2", where.c_str());
  std::size_t k = blocks.size();
  if (n.IsScalar() && n.Tag() == kSampleTag) {
    const std::string& s = n.Scalar();
    if (!s.empty() && s.size() < 10 && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; }))
      k = static_cast<std::size_t>(std::stoul(s));
  }
  if (k >= blocks.size() || blocks[k].used) {
    for (const auto& kv : p)  // point at the key: the value may start lines below it
      if (kv.first.Scalar() == "accel_mps2")
        fail(kv.first, where + ": accel_mps2: write it as a plain key at the start of its line (the samples' reader "
                               "looks for it there), followed by '- [fx, fy, fz]' rows or a [[fx, fy, fz], ...] list");
    fail(n, where + ": accel_mps2: write it as a plain key at the start of its line (the samples' reader looks "
                    "for it there), followed by '- [fx, fy, fz]' rows or a [[fx, fy, fz], ...] list");
  }
  SampleBlock& b = blocks[k];
  b.used = true;
  if (b.failed) throw Located{b.err_line, where + ": " + b.err};
  return std::move(b.samples);
}

/// The two theodolite angles of a prism or target map, either convention, in radians.
void readAngles(const YAML::Node& m, const std::string& where, double& az, double& el) {
  const bool ccw = bool(m["azimuth_deg"]), cw = bool(m["azimuth_cw_deg"]);
  const bool elev = bool(m["elevation_deg"]), zen = bool(m["zenith_deg"]);
  if (ccw == cw) fail(m, where + (ccw ? ": both azimuth_deg and azimuth_cw_deg given" : ": missing key 'azimuth_deg'"));
  if (elev == zen) fail(m, where + (elev ? ": both elevation_deg and zenith_deg given" : ": missing key 'elevation_deg'"));
  az = ccw ? number(m["azimuth_deg"], where + ": azimuth_deg") : -number(m["azimuth_cw_deg"], where + ": azimuth_cw_deg");
  el = elev ? number(m["elevation_deg"], where + ": elevation_deg") : 90.0 - number(m["zenith_deg"], where + ": zenith_deg");
  if (el < -90.0 || el > 90.0) fail(m, where + ": elevation outside [-90, 90] deg");
  az *= kRadPerDeg;
  el *= kRadPerDeg;
}

void readCamera(const YAML::Node& c, CameraPrior& cam) {
  checkKeys(c, "camera", {"focal_length_px", "principal_point_px", "pixel_aspect", "focal_length_sigma_px",
                          "principal_point_sigma_px", "pixel_aspect_sigma", "detector_px", "radial_k1",
                          "radial_k1_sigma"});
  cam.nominal.f = positive(need(c, "focal_length_px", "camera"), "camera: focal_length_px");
  const auto pp = numbers(need(c, "principal_point_px", "camera"), 2, "camera: principal_point_px");
  cam.nominal.u0 = pp[0];
  cam.nominal.v0 = pp[1];
  cam.nominal.sx = positive(need(c, "pixel_aspect", "camera"), "camera: pixel_aspect");
  cam.f_sigma_px = positive(need(c, "focal_length_sigma_px", "camera"), "camera: focal_length_sigma_px");
  cam.pp_sigma_px = positive(need(c, "principal_point_sigma_px", "camera"), "camera: principal_point_sigma_px");
  cam.sx_sigma = positive(need(c, "pixel_aspect_sigma", "camera"), "camera: pixel_aspect_sigma");
  if (c["detector_px"]) {
    const auto d = numbers(c["detector_px"], 2, "camera: detector_px");
    if (!(d[0] > 0 && d[1] > 0)) fail(c["detector_px"], "camera: detector_px must be positive");
    cam.width_px = d[0];
    cam.height_px = d[1];
  }
  if (c["radial_k1"]) cam.nominal.k1 = number(c["radial_k1"], "camera: radial_k1");
  if (c["radial_k1_sigma"]) {
    cam.k1_sigma = positive(c["radial_k1_sigma"], "camera: radial_k1_sigma");
    cam.estimate_k1 = true;
  }
}

void readPosition(const YAML::Node& p, std::size_t index, Position& pos, std::vector<SampleBlock>& blocks) {
  const std::string where = "position " + std::to_string(index + 1);
  checkKeys(p, where.c_str(), {"name", "prisms", "accel_mps2", "targets"});
  pos.line = lineOf(p);
  pos.name = p["name"] ? p["name"].Scalar() : where;

  const YAML::Node prisms = need(p, "prisms", where.c_str());
  if (!prisms.IsSequence()) fail(prisms, where + ": prisms: expected a list");
  for (std::size_t i = 0; i < prisms.size(); ++i) {
    const YAML::Node& q = prisms[i];
    const std::string w = where + " prism " + std::to_string(i + 1);
    checkKeys(q, w.c_str(), {"axis_t", "azimuth_deg", "elevation_deg", "azimuth_cw_deg", "zenith_deg"});
    PrismReading r;
    r.line = lineOf(q);
    const auto a = numbers(need(q, "axis_t", w.c_str()), 3, w + ": axis_t");
    r.axis_t = Vec3(a[0], a[1], a[2]);
    if (std::abs(r.axis_t.norm() - 1.0) > 1e-3) fail(q["axis_t"], w + ": axis_t is not a unit vector");
    r.axis_t.normalize();
    readAngles(q, w, r.az_rad, r.el_rad);
    pos.prisms.push_back(r);
  }
  pos.accel_mps2 = takeSamples(p, where, blocks);
  const YAML::Node tg = need(p, "targets", where.c_str());
  if (!tg.IsSequence()) fail(tg, where + ": targets: expected a list");
  for (std::size_t i = 0; i < tg.size(); ++i) {
    const YAML::Node& t = tg[i];
    const std::string w = where + " target " + std::to_string(i + 1);
    checkKeys(t, w.c_str(), {"azimuth_deg", "elevation_deg", "azimuth_cw_deg", "zenith_deg", "centroid_px"});
    TargetReading r;
    r.line = lineOf(t);
    readAngles(t, w, r.az_rad, r.el_rad);
    const auto c = numbers(need(t, "centroid_px", w.c_str()), 2, w + ": centroid_px");
    r.u_px = c[0];
    r.v_px = c[1];
    pos.targets.push_back(r);
  }
}

std::string at(const std::string& name, int line) {
  return line > 0 ? name + ":" + std::to_string(line) + ": " : name + ": ";
}

}  // namespace

bool validateMeasurement(const Measurement& m, const std::string& name, std::string* error) {
  auto bad = [&](int line, const std::string& what) {
    if (error) *error = at(name, line) + what;
    return false;
  };
  if (!(m.gravity_mps2 > 1.0 && m.gravity_mps2 < 30.0)) return bad(0, "gravity_mps2 out of range");
  if (m.positions.empty()) return bad(0, "no positions");
  const CameraPrior& c = m.camera;
  if (!(c.f_sigma_px > 0 && c.pp_sigma_px > 0 && c.sx_sigma > 0 && (!c.estimate_k1 || c.k1_sigma > 0)))
    return bad(0, "camera: every prior sigma must be positive");
  if (!(c.nominal.f > 0 && c.nominal.sx > 0 && c.width_px > 0 && c.height_px > 0))
    return bad(0, "camera: focal length, pixel aspect and detector size must be positive");
  if (!(m.noise.centroid_sigma_px > 0 && m.noise.theodolite_sigma_rad > 0 && m.noise.accel_sigma_mps2 >= 0))
    return bad(0, "noise: the centroid and theodolite sigmas must be positive");
  for (std::size_t k = 0; k < m.positions.size(); ++k) {
    const Position& p = m.positions[k];
    // A name is printed in reports and written back into the file: control characters (a NUL, a line
    // break) would not survive the round trip (the fuzzer found "position\0 1" read back as another
    // name). Checked here, after the readers, so their more specific findings come first.
    if (std::any_of(p.name.begin(), p.name.end(), [](char ch) { return static_cast<unsigned char>(ch) < 0x20 || ch == 0x7f; }))
      return bad(p.line, "position " + std::to_string(k + 1) + ": name: a control character in it");
    const std::string where = "position '" + p.name + "'";
    if (p.prisms.empty()) return bad(p.line, where + ": no prism reading (the yaw needs at least one face)");
    if (p.accel_mps2.empty()) return bad(p.line, where + ": no accelerometer samples");
    for (const auto& f : p.accel_mps2)
      if (!core::allFinite(f)) return bad(p.line, where + ": non-finite accelerometer sample");
    Vec3 mean = Vec3::Zero();
    for (const auto& f : p.accel_mps2) mean += f;
    mean /= static_cast<double>(p.accel_mps2.size());
    if (std::abs(mean.norm() / m.gravity_mps2 - 1.0) > 0.05)
      return bad(p.line, where + ": mean specific force " + std::to_string(mean.norm()) +
                             " m/s^2 differs from gravity_mps2 by more than 5 % (units? not at rest?)");
    if (p.targets.size() < 4)
      return bad(p.line, where + ": " + std::to_string(p.targets.size()) + " targets, at least 4 are needed");
    for (const auto& t : p.targets) {
      if (!std::isfinite(t.u_px) || !std::isfinite(t.v_px) || !std::isfinite(t.az_rad) || !std::isfinite(t.el_rad))
        return bad(t.line, "non-finite target value");
      if (t.u_px < 0 || t.u_px > c.width_px || t.v_px < 0 || t.v_px > c.height_px) {
        char buf[160];
        std::snprintf(buf, sizeof buf, "centroid (%.3f, %.3f) px outside the detector (0..%g, 0..%g)", t.u_px, t.v_px,
                      c.width_px, c.height_px);
        return bad(t.line, buf);
      }
    }
    // Targets on a line: the centroid scatter must have a second principal direction. (The same
    // test on the theodolite directions would be equivalent for a working sensor.)
    double su = 0, sv = 0;
    for (const auto& t : p.targets) {
      su += t.u_px;
      sv += t.v_px;
    }
    const double n = static_cast<double>(p.targets.size());
    su /= n;
    sv /= n;
    double a = 0, b = 0, d = 0;
    for (const auto& t : p.targets) {
      a += (t.u_px - su) * (t.u_px - su);
      b += (t.u_px - su) * (t.v_px - sv);
      d += (t.v_px - sv) * (t.v_px - sv);
    }
    const double tr = a + d, det = a * d - b * b;
    const double lmin = 0.5 * (tr - std::sqrt(std::max(0.0, tr * tr - 4 * det)));
    const double lmax = tr - lmin;
    // thickness below 1 % of the length (or all targets within 1 px): a line, not an area
    if (lmax <= 1.0 * n || lmin < 1e-4 * lmax)
      return bad(p.line, where + ": the targets lie on a line (or one point) in the image; the mounting needs "
                             "targets spread over an area");
  }
  return true;
}

bool parseMeasurement(const std::string& yaml_text, const std::string& name, Measurement& out, std::string* error) {
  Measurement m;
  try {
    std::vector<SampleBlock> blocks;
    const YAML::Node root = YAML::Load(SampleReader(yaml_text).run(blocks));
    if (!root || !root.IsMap()) throw Located{0, "not a YAML map (is this a measurement file?)"};
    if (std::string dup; !io::checkDuplicateKeys(root, name, &dup)) {
      if (error) *error = dup;
      return false;
    }
    checkKeys(root, "file", {"gravity_mps2", "camera", "design_q_s_t", "noise", "positions"});
    m.gravity_mps2 = positive(need(root, "gravity_mps2", "file"), "gravity_mps2");
    readCamera(need(root, "camera", "file"), m.camera);
    const YAML::Node qn = need(root, "design_q_s_t", "file");
    const auto q = numbers(qn, 4, "design_q_s_t");
    const double qn2 = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (std::abs(qn2 - 1.0) > 1e-6) fail(qn, "design_q_s_t: not a unit quaternion (norm " + std::to_string(qn2) + ")");
    m.q_s_t_design = quatFromScalarFirst(q[0] / qn2, q[1] / qn2, q[2] / qn2, q[3] / qn2);
    if (const YAML::Node nz = root["noise"]) {
      checkKeys(nz, "noise", {"centroid_sigma_px", "theodolite_sigma_arcsec", "accel_sigma_mps2"});
      if (nz["centroid_sigma_px"]) m.noise.centroid_sigma_px = positive(nz["centroid_sigma_px"], "noise: centroid_sigma_px");
      if (nz["theodolite_sigma_arcsec"])
        m.noise.theodolite_sigma_rad = positive(nz["theodolite_sigma_arcsec"], "noise: theodolite_sigma_arcsec") * kRadPerArcsec;
      if (nz["accel_sigma_mps2"]) m.noise.accel_sigma_mps2 = positive(nz["accel_sigma_mps2"], "noise: accel_sigma_mps2");
    }
    const YAML::Node ps = need(root, "positions", "file");
    if (!ps.IsSequence() || ps.size() == 0) fail(ps, "positions: expected a non-empty list");
    m.positions.resize(ps.size());
    for (std::size_t k = 0; k < ps.size(); ++k) readPosition(ps[k], k, m.positions[k], blocks);
    for (const SampleBlock& b : blocks)
      if (!b.used) throw Located{b.key_line, "accel_mps2 here is not a position's key (inside a text value?)"};
  } catch (const Located& e) {
    if (error) *error = at(name, e.line) + e.what;
    return false;
  } catch (const YAML::Exception& e) {
    if (error) *error = at(name, e.mark.line >= 0 ? e.mark.line + 1 : 0) + e.msg;
    return false;
  }
  if (!validateMeasurement(m, name, error)) return false;
  out = std::move(m);
  return true;
}

bool loadMeasurement(const std::string& path, Measurement& out, std::string* error) {
  std::string text;
  if (!io::readBounded(path, io::kMaxMeasurementBytes, "ground measurement file", text, error)) return false;
  return parseMeasurement(text, path, out, error);
}

bool writeMeasurement(const std::string& path, const Measurement& m, std::string* error) {
  io::AtomicFile af;  // complete or not there: a failed write never leaves half a measurement
  if (!af.open(path, error)) return false;
  std::FILE* f = af.file();
  const CameraPrior& c = m.camera;
  double q[4];
  quatToScalarFirst(m.q_s_t_design, q);
  std::fprintf(f, "# method C ground measurement: angles in degrees, pixels, m/s^2 (boresight measurement file)\n");
  std::fprintf(f, "gravity_mps2: %.9g\n", m.gravity_mps2);
  std::fprintf(f,
               "camera: {focal_length_px: %.10g, principal_point_px: [%.10g, %.10g], pixel_aspect: %.12g,\n"
               "         focal_length_sigma_px: %.6g, principal_point_sigma_px: %.6g, pixel_aspect_sigma: %.6g,\n"
               "         detector_px: [%.10g, %.10g]",
               c.nominal.f, c.nominal.u0, c.nominal.v0, c.nominal.sx, c.f_sigma_px, c.pp_sigma_px, c.sx_sigma,
               c.width_px, c.height_px);
  if (c.nominal.k1 != 0.0) std::fprintf(f, ", radial_k1: %.10g", c.nominal.k1);
  if (c.estimate_k1) std::fprintf(f, ", radial_k1_sigma: %.6g", c.k1_sigma);
  std::fprintf(f, "}\n");
  std::fprintf(f, "design_q_s_t: [%.15g, %.15g, %.15g, %.15g]\n", q[0], q[1], q[2], q[3]);
  std::fprintf(f, "noise: {centroid_sigma_px: %.6g, theodolite_sigma_arcsec: %.6g", m.noise.centroid_sigma_px,
               m.noise.theodolite_sigma_rad * kArcsecPerRad);
  if (m.noise.accel_sigma_mps2 > 0) std::fprintf(f, ", accel_sigma_mps2: %.6g", m.noise.accel_sigma_mps2);
  std::fprintf(f, "}\npositions:\n");
  for (const Position& p : m.positions) {
    std::string name;  // a double-quoted YAML scalar: escape backslashes and quotes
    for (char ch : p.name) {
      if (ch == '"' || ch == '\\') name += '\\';
      name += ch;
    }
    std::fprintf(f, "  - name: \"%s\"\n    prisms:\n", name.c_str());
    for (const PrismReading& r : p.prisms)
      std::fprintf(f, "      - {axis_t: [%.15g, %.15g, %.15g], azimuth_deg: %.12f, elevation_deg: %.12f}\n",
                   r.axis_t.x(), r.axis_t.y(), r.axis_t.z(), r.az_rad / kRadPerDeg, r.el_rad / kRadPerDeg);
    std::fprintf(f, "    targets:\n");
    for (const TargetReading& t : p.targets)
      std::fprintf(f, "      - {azimuth_deg: %.12f, elevation_deg: %.12f, centroid_px: [%.6f, %.6f]}\n",
                   t.az_rad / kRadPerDeg, t.el_rad / kRadPerDeg, t.u_px, t.v_px);
    std::fprintf(f, "    accel_mps2:\n");
    for (const Vec3& a : p.accel_mps2) std::fprintf(f, "      - [%.9f, %.9f, %.9f]\n", a.x(), a.y(), a.z());
  }
  return af.commit(error);
}

}  // namespace boresight::ground
