// GRACE / GRACE-FO Level-1 products: identification, headers, read results and the reader/writer API.
//
// A product file is a header (GRACE-FO YAML header ending "# End of YAML header", or the older
// fixed 80-column header ending "END OF HEADER", which may appear twice) followed by one record per
// line (ASCII) or packed big-endian records (GRACE binary .dat). Records are counted; the header's
// record count is reported but never trusted (the real samples are cut excerpts).
//
// Errors: a malformed record line gives a ParseIssue "file:line: reason". ReadOptions::on_error
// chooses to skip-and-count (default) or to stop at the first one. A file that cannot be read at all
// (missing, unknown product, wrong header) gives ok == false and a one-line error. Readers never throw
// on bad input and never crash, whatever the bytes (they are fuzzed).
#pragma once

#include <boresight/core/conventions.h>
#include <boresight/core/plausibility.h>
#include <boresight/io/text_scan.h>

#include <array>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace boresight::io {

enum class Product : std::uint8_t {
  Unknown,
  SCA1A, SCA1B,
  ACC1A, ACT1A, AHK1A, AHK1B,  // prod_flag products (FlaggedRecord)
  ACC1B, ACT1B,
  QSA1B, QKS1B,
  GNV1B, GNI1B,
  IMU1A, IMU1B,
  THR1A, THR1B,
  IHK1A, IHK1B,
  HRT1A, HRT1B,
  TIM1B,
  CLK1A, CLK1B,
  SCV1A,  // boresight simulator product (star vectors per head), not a GRACE-FO product: see ScvRecord
  Other,  // a recognised Level-1 name without a typed reader (KBR1B, MAG1B, ...): read generically
};

/// "SCA1A" -> Product::SCA1A; any other 5-character Level-1 style name (three letters, '1',
/// 'A' or 'B') -> Product::Other; anything else -> Product::Unknown.
Product productFromName(std::string_view name);
const char* productName(Product p);

/// Identify the product from a path: the file name's first five characters ("SCA1A_2023-..."),
/// then the fixed header's FILENAME entry. Returns the five-letter name ("" when none).
std::string productNameFromPath(std::string_view path);

enum class HeaderStyle : std::uint8_t { None, Yaml, Fixed };

struct Header {
  HeaderStyle style = HeaderStyle::None;
  std::string product_name;  ///< five letters, e.g. "SCA1A" (empty when unknown)
  Product product = Product::Unknown;
  char satellite = '?';      ///< 'A'..'D' from "GRACE C" (YAML platform / SATELLITE NAME)
  std::optional<std::int64_t> declared_records;  ///< num_records / NUMBER OF DATA RECORDS, untrusted
  std::vector<std::string> columns;  ///< YAML `variables:` names in column order (empty for fixed)
  std::array<std::string, 32> flag_fields;  ///< prod_flag bit -> field name (YAML flag_meanings)
  std::vector<std::string> lines;  ///< the header's raw lines, so a writer can keep them
  std::size_t line_count = 0;      ///< lines the header occupies (data line numbers follow)
  /// Fixed header "FILE FORMAT 0=BINARY 1=ASCII : 0": packed big-endian records follow END OF HEADER.
  /// formatProduct() writes binary when this is set (for record types with a binary layout).
  bool binary = false;
  /// YAML start_time_epoch_secs / stop_time_epoch_secs (GRACE-FO RL04): the span the file covers, s
  /// past the epoch; NaN when absent. The readers' time gate uses it (RecordGate).
  double coverage_start_s = std::numeric_limits<double>::quiet_NaN();
  double coverage_stop_s = std::numeric_limits<double>::quiet_NaN();
};

/// Parse a header at the start of `text`. On success returns true and sets *data_offset to the
/// first byte after the header. A file with no recognisable header end is an error. For a binary
/// header (FILE FORMAT 0) parsing stops at the first END OF HEADER line.
bool parseHeader(std::string_view text, Header& h, std::size_t* data_offset, std::string* error);

struct ParseIssue {
  std::string file;
  std::size_t line = 0;  ///< 1-based line number in the file (0: not line-related)
  std::string reason;
  std::string str() const { return file + ":" + std::to_string(line) + ": " + reason; }
};

enum class OnError : std::uint8_t { Skip, Stop };

struct ReadOptions {
  OnError on_error = OnError::Skip;
  std::size_t max_issues_kept = 1000;  ///< issues beyond this are counted but not kept
  /// Force the product instead of identifying it from the file name and header.
  Product product = Product::Unknown;
  /// Threads for the record lines of an ASCII file: 0 = automatic (all hardware threads for bodies
  /// of 8 MB and more, else one), n = exactly n. OnError::Stop always parses on one thread.
  int threads = 0;
  /// Tolerance on | |q| - 1 | of measured attitude quaternions (SCA1A, SCA1B): the platform's
  /// heads.unit_norm_tolerance when the records go to the core, so that a record is refused once, here.
  double quat_norm_tolerance = plausibility::kQuatNormTolerance;
  /// false: no plausibility gate (RecordGate), only the format is checked. For tests of the codecs'
  /// exactness with values no instrument gives; every program reads with the gates.
  bool plausibility_gates = true;
};

/// The physical plausibility gates a reader applies to every well-formed record
/// (boresight/core/plausibility.h): quaternion norms, accelerations, orbit radius and speed, and the
/// time tag against the time the file covers (the header's coverage, else the date in the file name,
/// with a margin; no time gate for static products and files named without a date). A record outside
/// a gate is rejected like a malformed line ("file:line: implausible ...") and counted apart.
struct RecordGate {
  bool enabled = true;
  double quat_norm_tolerance = plausibility::kQuatNormTolerance;
  bool has_window = false;
  TimeUs t_min = 0, t_max = 0;  ///< accepted tags (inclusive)
  std::string window;           ///< where the window comes from, for messages
};
RecordGate makeRecordGate(const Header& h, std::string_view file, const ReadOptions& opt);

/// The start of the day named in a Level-1 file name ("SCA1A_2023-06-01_C_04.txt" -> 2023-06-01
/// 00:00:00 GPS, as a tag); false when the name has no date.
bool dateFromFileName(std::string_view path, TimeUs& day_start);

template <typename Rec>
struct ProductFile {
  std::string file;  ///< the name used in messages
  Header header;
  std::vector<Rec> records;
  std::vector<ParseIssue> rejected;  ///< the first ReadOptions::max_issues_kept rejected lines
  std::size_t rejected_count = 0;    ///< all rejected lines
  std::size_t implausible_count = 0; ///< of those: well-formed records outside a plausibility gate
  bool ok = true;                    ///< false: the file could not be read (see error)
  std::string error;                 ///< "file:line: reason" when !ok
};

// ------------------------------------------------------------------------------------------------
// Records. Time tags are TimeUs (microseconds past the GPS J2000 epoch; receiver time for L1A).
// Quaternions are stored scalar-first as in the files; see core/conventions.h for their direction.
// ------------------------------------------------------------------------------------------------

/// SCA1A: one head's quaternion q_I_Si at receiver time (three heads interleaved in one file).
struct Sca1aRecord {
  TimeUs t = 0;           ///< rcvtime_intg * 1e6 + rcvtime_frac
  char satellite = 'C';   ///< GRACEFO_id
  std::uint8_t head = 1;  ///< sca_id, 1..3
  char desig = 'P';       ///< sca_desig
  double q[4] = {1, 0, 0, 0};  ///< quatangle, quaticoeff, quatjcoeff, quatkcoeff
  std::int32_t nlocks = 0;
  std::int32_t nstars = 0;
  std::int32_t confid = 0;  ///< sca_confid
  std::int32_t null1 = 0, null2 = 0;
  Bits mode{0, 8};     ///< sca_mode
  Bits qualflg{0, 8};
  friend bool operator==(const Sca1aRecord&, const Sca1aRecord&);
};

/// ACC1A, ACT1A, AHK1A, AHK1B: receiver/GPS time, then only the fields whose prod_flag bit is set.
struct FlaggedRecord {
  TimeUs t = 0;
  char time_ref = 'R';  ///< 'R' receiver time, 'G' GPS time
  char satellite = 'C';
  Bits qualflg{0, 8};
  Bits prod_flag{0, 32};
  std::array<double, 32> value{};  ///< value[bit] is meaningful only when prod_flag has the bit
  Bits status_flag{0, 32};         ///< AHK bit 29 "Status flag", a bit string
  bool has(int bit) const { return prod_flag.test(bit); }
  friend bool operator==(const FlaggedRecord&, const FlaggedRecord&);
};

/// prod_flag bits of ACC1A / ACT1A.
namespace acc_bits {
constexpr int kLinX = 0, kLinY = 1, kLinZ = 2, kAngX = 3, kAngY = 4, kAngZ = 5, kIcuBlock = 26;
}
/// ACC1A / ACT1A in their science layout, compact (104 bytes against FlaggedRecord's 296, which
/// matters for a full day of 864 000 records): prod_flag may use only bits 0-5 (linear and angular
/// acceleration) and 26-28 (ICU block number, 10 Hz and MHz clock counts). A line with any other
/// field is rejected with a reason that says so; read such files as FlaggedRecord.
struct Acc1aRecord {
  TimeUs t = 0;
  char time_ref = 'R';
  char satellite = 'C';
  Bits qualflg{0, 8};
  Bits prod_flag{0, 32};
  double lin[3] = {0, 0, 0};  ///< m/s^2, accelerometer frame A (bits 0-2)
  double ang[3] = {0, 0, 0};  ///< rad/s^2, accelerometer frame A (bits 3-5)
  double counters[3] = {0, 0, 0};  ///< icu_blk_nr, Tenhz_count, Mhz_count (bits 26-28)
  bool has(int bit) const { return prod_flag.test(bit); }
  friend bool operator==(const Acc1aRecord&, const Acc1aRecord&);
};
/// The prod_flag bits an Acc1aRecord can hold.
constexpr std::uint32_t kAcc1aRecordBits = 0x3Fu | (7u << 26);

/// AHK1A/AHK1B: the bit that holds a 32-character status bit string.
constexpr int kAhkStatusFlagBit = 29;

/// SCV1A: one star seen by one head (a boresight SIMULATOR product: GRACE-FO publishes no Level-1
/// star vectors; the layout follows SCA1A). Receiver time, YAML header like the other Level-1 files:
///   rcvtime_intg rcvtime_frac GRACEFO_id sca_id star_id s_x s_y s_z r_x r_y r_z magnitude
/// s: measured unit direction in the head frame Si (noise included); r: unit direction in the inertial
/// frame I (ICRS/GCRF axes) with the aberration the simulator applies to the head (so a Wahba solution
/// of (s, r) gives the head's geometric attitude); star_id: Hipparcos number; magnitude: Hp.
struct ScvRecord {
  TimeUs t = 0;
  char satellite = 'C';
  std::uint8_t head = 1;    ///< sca_id, 1..9
  std::int32_t star = 0;    ///< Hipparcos catalogue number
  double s[3] = {0, 0, 1};  ///< unit vector, head frame
  double r[3] = {0, 0, 1};  ///< unit vector, inertial frame
  double mag = 0;           ///< Hp magnitude
  friend bool operator==(const ScvRecord&, const ScvRecord&);
};

/// QSA1B (star camera to SRF alignment, q_Si_B) and QKS1B (KBR to SRF): static records.
/// time id sca_id q0 qi qj qk 0 qualflg
struct QsaRecord {
  TimeUs t = 0;  ///< whole seconds past the epoch (0 in the GRACE 2003 files)
  char satellite = 'C';
  std::int32_t sensor = 1;  ///< sca_id (1..3); 0..2 in QKS1B
  double q[4] = {1, 0, 0, 0};
  double zero = 0;  ///< the always-zero 8th column
  Bits qualflg{0, 8};
  friend bool operator==(const QsaRecord&, const QsaRecord&);
};

/// SCA1B (combined attitude q_I_B, GPS time): gps_time id sca_id q0 qi qj qk qual_rss qualflg
struct Sca1bRecord {
  TimeUs t = 0;
  char satellite = 'C';
  std::int32_t sca_id = 23;  ///< which heads were combined (23: SCA1+2+3+IMU on GRACE-FO)
  double q[4] = {1, 0, 0, 0};
  double qual_rss = 0;
  Bits qualflg{0, 8};
  friend bool operator==(const Sca1bRecord&, const Sca1bRecord&);
};

/// ACC1B (GRACE, SRF, non-zero angular acceleration) and ACT1B (GRACE-FO, angular acceleration 0):
/// gps_time id lin_accl_x/y/z ang_accl_x/y/z acl_x/y/z_res qualflg
struct Acc1bRecord {
  TimeUs t = 0;
  char satellite = 'C';
  double lin[3] = {0, 0, 0};  ///< m/s^2
  double ang[3] = {0, 0, 0};  ///< rad/s^2
  double res[3] = {0, 0, 0};
  Bits qualflg{0, 8};
  friend bool operator==(const Acc1bRecord&, const Acc1bRecord&);
};

/// GNV1B / GNI1B (orbit, Earth-fixed 'E' or inertial 'I'): gps_time id coord_ref xpos ypos zpos
/// xpos_err ypos_err zpos_err xvel yvel zvel xvel_err yvel_err zvel_err qualflg  (m, m/s; 1e33 = none)
struct GnvRecord {
  TimeUs t = 0;
  char satellite = 'C';
  char coord_ref = 'E';
  double pos[3] = {0, 0, 0};
  double pos_err[3] = {0, 0, 0};
  double vel[3] = {0, 0, 0};
  double vel_err[3] = {0, 0, 0};
  Bits qualflg{0, 8};
  friend bool operator==(const GnvRecord&, const GnvRecord&);
};

/// IMU1A / IMU1B (gyro filtered angle, three gyros interleaved):
/// rcvtime_intg rcvtime_frac time_ref GRACEFO_id gyro_id FiltAng qualflg
struct ImuRecord {
  TimeUs t = 0;
  char time_ref = 'R';
  char satellite = 'C';
  std::int32_t gyro_id = 1;  ///< 1..3
  double filt_ang = 0;       ///< accumulated filtered angle [deg]
  Bits qualflg{0, 8};
  friend bool operator==(const ImuRecord&, const ImuRecord&);
};

/// THR1A / THR1B (thruster firings): time_intg time_frac time_ref id, 14 thrust counts
/// (att_ctrl_1_1..1_6, att_ctrl_2_1..2_6, undef_1..2), 14 on-times [ms] (att_ctrl_1_1..2_6,
/// orb_ctrl_1..2), 14 accumulated durations [ms], qualflg. All counters are integers.
constexpr int kThrusters = 14;
struct ThrRecord {
  TimeUs t = 0;
  char time_ref = 'R';
  char satellite = 'C';
  std::int64_t thrust_count[kThrusters] = {};
  std::int64_t on_time[kThrusters] = {};    ///< ms
  std::int64_t accum_dur[kThrusters] = {};  ///< ms
  Bits qualflg{0, 8};
  friend bool operator==(const ThrRecord&, const ThrRecord&);
};

/// IHK1A / IHK1B (housekeeping, one sensor per record):
/// time_intg time_frac time_ref id qualflg sensortype sensorvalue sensorname
/// The name is a short code ("21", "rfsp"); it is kept in a fixed array so the record stays
/// trivially copyable. A name of several words is read with single spaces between them.
constexpr std::size_t kIhkNameMax = 15;
struct IhkRecord {
  TimeUs t = 0;
  char time_ref = 'R';
  char satellite = 'C';
  Bits qualflg{0, 8};
  char sensortype = 'T';  ///< 'T' temperature, 'V' voltage, 'A' current, other characters occur
  double value = 0;
  char name[kIhkNameMax + 1] = {};  ///< NUL-terminated
  std::string_view sensorName() const {
    std::size_t n = 0;
    while (n < sizeof name && name[n] != '\0') ++n;
    return std::string_view(name, n);
  }
  /// Sets the name; false (and no change) when longer than kIhkNameMax or empty.
  bool setSensorName(std::string_view n);
  friend bool operator==(const IhkRecord&, const IhkRecord&);
};

/// HRT1A / HRT1B (30 high-resolution temperatures [deg C], old fixed header):
/// time_intg time_frac time_ref id T1..T30 [qualflg]
/// The trailing qualflg varies in width and may be absent (qualflg.width == 0 then, and the
/// writer leaves it out again).
constexpr int kHrtTemps = 30;
struct HrtRecord {
  TimeUs t = 0;
  char time_ref = 'R';
  char satellite = 'C';
  double temp[kHrtTemps] = {};
  Bits qualflg{0, 8};
  friend bool operator==(const HrtRecord&, const HrtRecord&);
};

/// TIM1B (OBC to receiver time mapping):
/// obctime id TS_suppid rcvtime_intg rcvtime_frac first_icu_blknr final_icu_blknr qualflg
/// rcvtime_frac is kept as written: NANOseconds in GRACE-FO RL04 (valid 0..999999999), microseconds
/// in the GRACE 2003 files. t is obctime (whole seconds).
struct TimRecord {
  TimeUs t = 0;  ///< obctime * 1e6
  char satellite = 'C';
  std::int32_t ts_suppid = 0;
  std::int64_t rcvtime_intg = 0;
  std::int64_t rcvtime_frac = 0;
  std::int64_t first_icu_blknr = -1;
  std::int64_t final_icu_blknr = -1;
  Bits qualflg{0, 8};
  friend bool operator==(const TimRecord&, const TimRecord&);
};

/// CLK1A / CLK1B (receiver clock offset; GPS time = rcv_time + eps_time):
/// rcv_time id clock_id eps_time eps_err eps_drift drift_err qualflg
struct ClkRecord {
  TimeUs t = 0;  ///< rcv_time, whole seconds
  char satellite = 'C';
  std::int32_t clock_id = -1;
  double eps_time = 0;   ///< s
  double eps_err = 0;    ///< s
  double eps_drift = 0;  ///< s/s
  double drift_err = 0;  ///< s/s
  Bits qualflg{0, 8};
  friend bool operator==(const ClkRecord&, const ClkRecord&);
};

// ------------------------------------------------------------------------------------------------
// Reading and writing. Each record type has explicit instantiations in src/io.
// ------------------------------------------------------------------------------------------------

/// Read a whole file from disk.
template <typename Rec>
ProductFile<Rec> readProduct(const std::string& path, const ReadOptions& opt = {});

/// Parse text already in memory; `file` is the name used in messages and for identification.
template <typename Rec>
ProductFile<Rec> parseProduct(std::string_view text, std::string_view file, const ReadOptions& opt = {});

/// The whole product as text: the kept header lines (or a minimal synthesised header of the right
/// style with the record count updated) followed by one line per record. When f.header.binary is
/// set and the record type has a GRACE binary layout (Sca1bRecord, Acc1bRecord, GnvRecord), the
/// header is a fixed one with FILE FORMAT 0 and packed big-endian records follow it.
template <typename Rec>
std::string formatProduct(const ProductFile<Rec>& f);

/// formatProduct() to a file. Returns false and sets *error on I/O failure.
template <typename Rec>
bool writeProduct(const std::string& path, const ProductFile<Rec>& f, std::string* error);

/// A fresh, empty product of the given kind with a synthesised header (for simulators and converters).
template <typename Rec>
ProductFile<Rec> makeProduct(Product product, char satellite);

/// A static QSA1B product of head mountings (the fixed header of GRACE-FO's static products): one record
/// per head (sca_id, q_Si_B with R(q_Si_B) = C_Si_B, written scalar first) at the whole second of t.
ProductFile<QsaRecord> mountingsQsa1b(char satellite, TimeUs t, const std::vector<std::pair<std::int32_t, Quat>>& heads);

/// One record line (without its newline, not blank) into r; false with s.reason() when the line is
/// malformed (every field is parsed and checked, and nothing may follow the last field). The
/// building block of the streaming readers (boresight/io/product_stream.h).
template <typename Rec>
bool parseRecord(FieldScanner& s, Rec& r, Product product);

/// Whether the record type reads that product (SCA1A for Sca1aRecord, ACC1A/ACT1A/AHK1A/AHK1B for
/// FlaggedRecord, ...).
template <typename Rec>
bool recordAccepts(Product product);

/// The plausibility gates (RecordGate) on a well-formed record: false with *reason
/// ("implausible: ...") when it is outside one.
template <typename Rec>
bool checkRecord(const Rec& r, Product product, const RecordGate& gate, std::string* reason);

/// Declares the specialisations a record type provides (defined in src/io by BORESIGHT_IO_INSTANTIATE).
#define BORESIGHT_IO_DECLARE(Rec)                                                                          \
  template <>                                                                                              \
  ProductFile<Rec> readProduct<Rec>(const std::string& path, const ReadOptions& opt);                     \
  template <>                                                                                              \
  ProductFile<Rec> parseProduct<Rec>(std::string_view text, std::string_view file, const ReadOptions& opt); \
  template <>                                                                                              \
  std::string formatProduct<Rec>(const ProductFile<Rec>& f);                                               \
  template <>                                                                                              \
  bool writeProduct<Rec>(const std::string& path, const ProductFile<Rec>& f, std::string* error);         \
  template <>                                                                                              \
  ProductFile<Rec> makeProduct<Rec>(Product product, char satellite);                                      \
  template <>                                                                                              \
  bool parseRecord<Rec>(FieldScanner & s, Rec & r, Product product);                                       \
  template <>                                                                                              \
  bool recordAccepts<Rec>(Product product);                                                                \
  template <>                                                                                              \
  bool checkRecord<Rec>(const Rec& r, Product product, const RecordGate& gate, std::string* reason);

BORESIGHT_IO_DECLARE(Sca1aRecord)
BORESIGHT_IO_DECLARE(FlaggedRecord)
BORESIGHT_IO_DECLARE(Acc1aRecord)
BORESIGHT_IO_DECLARE(QsaRecord)
BORESIGHT_IO_DECLARE(ScvRecord)
BORESIGHT_IO_DECLARE(Sca1bRecord)
BORESIGHT_IO_DECLARE(Acc1bRecord)
BORESIGHT_IO_DECLARE(GnvRecord)
BORESIGHT_IO_DECLARE(ImuRecord)
BORESIGHT_IO_DECLARE(ThrRecord)
BORESIGHT_IO_DECLARE(IhkRecord)
BORESIGHT_IO_DECLARE(HrtRecord)
BORESIGHT_IO_DECLARE(TimRecord)
BORESIGHT_IO_DECLARE(ClkRecord)

/// GRACE big-endian binary Level-1B record sizes (bytes), as read by JPL's GraceRead library.
namespace binary_layout {
constexpr std::size_t kSca1b = 47;  ///< int32 gps_time, char id, int8 sca_id, 5 x float64, uint8 qualflg
constexpr std::size_t kAcc1b = 78;  ///< int32 gps_time, char id, 9 x float64, uint8 qualflg
constexpr std::size_t kGnv1b = 103; ///< int32 gps_time, char id, char coord_ref, 12 x float64, uint8 qualflg
}  // namespace binary_layout

/// Whole file into memory, at most max_bytes (64 MiB at most for a device or a pipe: a larger or
/// endless input is refused with the limit).
/// Returns false and sets *error ("file: reason") on failure.
bool readFileToString(const std::string& path, std::string& out, std::string* error,
                      std::uint64_t max_bytes = std::uint64_t{1} << 30);

/// Size limits of Level-1 files, bytes: a month of the product at its full rate (static products
/// 1 MiB; a file whose product is not known from its name 64 MiB). Readers refuse a larger file, or
/// an endless input, with the limit. Record lines are at most kMaxLineBytes and headers at most
/// kMaxHeaderBytes (real ones: under 1 kB and about 10 kB). Nothing is allocated from the count a
/// header promises.
std::uint64_t maxFileBytes(Product p);
constexpr std::size_t kMaxLineBytes = 64u << 10;
constexpr std::size_t kMaxHeaderBytes = 1u << 20;

}  // namespace boresight::io
