// Calendar formatting of GPS J2000 time tags (for reports and file names). No leap seconds: the
// GRACE time scale is GPS time, a calendar built on it is "GPS calendar" time.
#pragma once

#include <boresight/core/conventions.h>

#include <cmath>
#include <cstdio>
#include <locale>
#include <sstream>
#include <string>

namespace boresight::io {

struct CivilTime {
  int year, month, day, hour, minute, second, microsecond;
};

/// GPS calendar of a tag (microseconds past 2000-01-01 12:00:00 GPS).
inline CivilTime civilFromTime(TimeUs t) {
  // Days since 2000-01-01 00:00 and microseconds in the day, floor-divided.
  const std::int64_t us_day = 86400LL * kUsPerSecond;
  std::int64_t us = t + 12LL * 3600 * kUsPerSecond;
  std::int64_t days = us / us_day, rem = us % us_day;
  if (rem < 0) {
    rem += us_day;
    --days;
  }
  // Civil date from days since 1970-01-01 (H. Hinnant's algorithm, public domain description).
  std::int64_t z = days + 10957 + 719468;
  std::int64_t era = (z >= 0 ? z : z - 146096) / 146097;
  std::int64_t doe = z - era * 146097;
  std::int64_t yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
  std::int64_t y = yoe + era * 400;
  std::int64_t doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
  std::int64_t mp = (5 * doy + 2) / 153;
  std::int64_t d = doy - (153 * mp + 2) / 5 + 1;
  std::int64_t m = mp < 10 ? mp + 3 : mp - 9;
  CivilTime c{};
  c.year = static_cast<int>(m <= 2 ? y + 1 : y);
  c.month = static_cast<int>(m);
  c.day = static_cast<int>(d);
  std::int64_t s = rem / kUsPerSecond;
  c.hour = static_cast<int>(s / 3600);
  c.minute = static_cast<int>((s / 60) % 60);
  c.second = static_cast<int>(s % 60);
  c.microsecond = static_cast<int>(rem % kUsPerSecond);
  return c;
}

/// "2023-06-01 00:00:00.029992"
inline std::string formatTime(TimeUs t) {
  CivilTime c = civilFromTime(t);
  char buf[96];
  std::snprintf(buf, sizeof buf, "%04d-%02d-%02d %02d:%02d:%02d.%06d", c.year, c.month, c.day, c.hour, c.minute,
                c.second, c.microsecond);
  return buf;
}

/// "2023-06-01"
inline std::string formatDate(TimeUs t) {
  CivilTime c = civilFromTime(t);
  char buf[96];
  std::snprintf(buf, sizeof buf, "%04d-%02d-%02d", c.year, c.month, c.day);
  return buf;
}

/// GPS calendar "YYYY-MM-DD" or "YYYY-MM-DDTHH:MM:SS[.ffffff]" (a space may replace the T) ->
/// microseconds past the GPS J2000 epoch; false when the text is not such a date. The inverse of
/// formatTime / formatDate.
inline bool parseGpsCalendar(const std::string& text, TimeUs& t) {
  int y = 0, mo = 0, d = 0, hh = 0, mm = 0;
  double ss = 0;
  char c1 = 0, c2 = 0;
  std::istringstream is(text);
  is.imbue(std::locale::classic());
  is >> y >> c1 >> mo >> c2 >> d;
  if (is.fail() || c1 != '-' || c2 != '-' || mo < 1 || mo > 12 || d < 1 || d > 31) return false;
  if (!is.eof()) {
    char sep = 0, k1 = 0, k2 = 0;
    is >> std::noskipws >> sep >> std::skipws >> hh >> k1 >> mm >> k2 >> ss;
    if (is.fail() || (sep != 'T' && sep != ' ') || k1 != ':' || k2 != ':' || hh < 0 || hh > 23 || mm < 0 ||
        mm > 59 || ss < 0 || ss >= 60)
      return false;
    is >> std::ws;
    if (!is.eof()) return false;
  }
  // Days from civil (H. Hinnant's algorithm), relative to 2000-01-01.
  const int yy = y - (mo <= 2 ? 1 : 0);
  const int era = (yy >= 0 ? yy : yy - 399) / 400;
  const int yoe = yy - era * 400;
  const int doy = (153 * (mo + (mo > 2 ? -3 : 9)) + 2) / 5 + d - 1;
  const int doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  const std::int64_t days = static_cast<std::int64_t>(era) * 146097 + doe - 719468 - 10957;
  const std::int64_t whole_s = days * 86400 + hh * 3600 + mm * 60 - 43200;
  t = whole_s * kUsPerSecond + static_cast<TimeUs>(std::llround(ss * 1e6));
  return true;
}

}  // namespace boresight::io
