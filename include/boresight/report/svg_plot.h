// SVG plots for the reports the tools write: line plots of series against x (`boresight plot`), and
// points with error bars (the calibration report's estimates against the Cramer-Rao bound), linear or
// logarithmic axes (spectra). One renderer for every program: axes with "nice" ticks, a legend that
// wraps into rows (every series listed), gaps where y is not finite.
//
//   report::Plot p;  p.title = "residuals";  p.xlabel = "t - t0 [s]";
//   p.series.push_back({"head 1 x", x, y});
//   std::string svg = report::svgPlot(p);
#pragma once

#include <string>
#include <vector>

namespace boresight::report {

struct Series {
  std::string name;                 ///< legend entry
  std::vector<double> x, y;         ///< same length; a non-finite y is a gap (lines) or no point
  std::vector<double> yerr;         ///< empty, or the half-length of an error bar at each point
  enum class Style { kLine, kPoints } style = Style::kLine;
  double dx = 0.0;                  ///< shift of the points in x units (side by side error bars)
  std::vector<double> yerr_lo;      ///< empty, or the bar's length below the point (yerr then the length above)
};

struct Plot {
  std::string title, xlabel, ylabel;
  std::vector<Series> series;
  double width = 900, height = 420;
  /// Labels at x = 0, 1, 2, ... instead of numeric ticks (categorical x axis), when not empty.
  std::vector<std::string> xcategories;
  /// Logarithmic axes (spectra): ticks at powers of ten; values <= 0 are gaps.
  bool logx = false, logy = false;
};

/// Vertical lines at `xs` from ylo to yhi as one series (gaps between them): markers such as the orbit
/// harmonics on a spectrum.
Series verticalMarkers(std::string name, const std::vector<double>& xs, double ylo, double yhi);

/// The plot as an SVG document. Empty series or all-gap data give an empty frame, not an error.
std::string svgPlot(const Plot& p);

/// Writes svgPlot(p) to `path`; false with *error ("cannot write PATH").
bool writeSvgPlot(const std::string& path, const Plot& p, std::string* error);

}  // namespace boresight::report
