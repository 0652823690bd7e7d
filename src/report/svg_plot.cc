// SVG plot renderer (include/boresight/report/svg_plot.h).
#include <boresight/report/svg_plot.h>
#include <boresight/io/files.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

namespace boresight::report {
namespace {

std::string esc(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '<') o += "&lt;";
    else if (c == '>') o += "&gt;";
    else if (c == '&') o += "&amp;";
    else o += c;
  }
  return o;
}

/// "Nice" tick step for a range.
double tickStep(double range, int target) {
  double raw = range / target, p = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (raw <= m * p) return m * p;
  return 10 * p;
}

const char* const kColors[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2"};

}  // namespace

std::string svgPlot(const Plot& p) {
  double xmin = INFINITY, xmax = -INFINITY, ymin = INFINITY, ymax = -INFINITY;
  for (const Series& s : p.series)
    for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (!std::isfinite(s.x[i])) continue;
      xmin = std::min(xmin, s.x[i] + s.dx), xmax = std::max(xmax, s.x[i] + s.dx);
      if (!std::isfinite(s.y[i])) continue;
      const double e = i < s.yerr.size() && std::isfinite(s.yerr[i]) ? std::abs(s.yerr[i]) : 0.0;
      ymin = std::min(ymin, s.y[i] - e), ymax = std::max(ymax, s.y[i] + e);
    }
  if (!p.xcategories.empty()) {
    xmin = std::min(xmin, -0.5), xmax = std::max(xmax, double(p.xcategories.size()) - 0.5);
  }
  if (!std::isfinite(xmin)) xmin = 0, xmax = 1;
  if (!std::isfinite(ymin)) ymin = 0, ymax = 1;
  if (ymax - ymin < 1e-300) ymin -= 0.5, ymax += 0.5;
  if (xmax - xmin < 1e-300) xmax = xmin + 1;
  const double pad = 0.05 * (ymax - ymin);
  ymin -= pad;
  ymax += pad;

  const double W = p.width, H = p.height, L = 90, R = 20, T = 40, B = 55;
  auto px = [&](double v) { return L + (v - xmin) / (xmax - xmin) * (W - L - R); };
  auto py = [&](double v) { return H - B - (v - ymin) / (ymax - ymin) * (H - T - B); };
  std::ostringstream svg;
  svg << "<svg xmlns='http://www.w3.org/2000/svg' width='" << W << "' height='" << H
      << "' font-family='sans-serif' font-size='12'>\n<rect width='100%' height='100%' fill='white'/>\n";
  svg << "<text x='" << W / 2 << "' y='22' text-anchor='middle' font-size='15'>" << esc(p.title) << "</text>\n";
  if (p.xcategories.empty()) {
    const double xs = tickStep(xmax - xmin, 8);
    for (double t = std::ceil(xmin / xs) * xs; t <= xmax + 1e-9 * xs; t += xs) {
      svg << "<line x1='" << px(t) << "' y1='" << T << "' x2='" << px(t) << "' y2='" << H - B << "' stroke='#ddd'/>";
      svg << "<text x='" << px(t) << "' y='" << H - B + 16 << "' text-anchor='middle'>" << t << "</text>\n";
    }
  } else {
    for (std::size_t k = 0; k < p.xcategories.size(); ++k) {
      const double t = double(k);
      svg << "<line x1='" << px(t) << "' y1='" << T << "' x2='" << px(t) << "' y2='" << H - B << "' stroke='#eee'/>";
      svg << "<text x='" << px(t) << "' y='" << H - B + 16 << "' text-anchor='middle'>" << esc(p.xcategories[k])
          << "</text>\n";
    }
  }
  const double ys = tickStep(ymax - ymin, 6);
  for (double t = std::ceil(ymin / ys) * ys; t <= ymax + 1e-9 * ys; t += ys) {
    svg << "<line x1='" << L << "' y1='" << py(t) << "' x2='" << W - R << "' y2='" << py(t) << "' stroke='#ddd'/>";
    svg << "<text x='" << L - 6 << "' y='" << py(t) + 4 << "' text-anchor='end'>" << t << "</text>\n";
  }
  svg << "<rect x='" << L << "' y='" << T << "' width='" << W - L - R << "' height='" << H - T - B
      << "' fill='none' stroke='#444'/>\n";
  svg << "<text x='" << (L + W - R) / 2 << "' y='" << H - 12 << "' text-anchor='middle'>" << esc(p.xlabel)
      << "</text>\n";
  svg << "<text transform='translate(16," << (T + H - B) / 2 << ") rotate(-90)' text-anchor='middle'>"
      << esc(p.ylabel) << "</text>\n";
  for (std::size_t k = 0; k < p.series.size(); ++k) {
    const Series& s = p.series[k];
    const char* c = kColors[k % 7];
    const std::size_t n = std::min(s.x.size(), s.y.size());
    if (s.style == Series::Style::kLine) {
      svg << "<path fill='none' stroke='" << c << "' stroke-width='1.3' d='";
      bool pen = false;
      for (std::size_t i = 0; i < n; ++i) {
        if (!std::isfinite(s.y[i]) || !std::isfinite(s.x[i])) {
          pen = false;
          continue;
        }
        svg << (pen ? " L" : " M") << px(s.x[i] + s.dx) << ' ' << py(s.y[i]);
        pen = true;
      }
      svg << "'/>\n";
    } else {
      for (std::size_t i = 0; i < n; ++i) {
        if (!std::isfinite(s.y[i]) || !std::isfinite(s.x[i])) continue;
        const double x = px(s.x[i] + s.dx);
        if (i < s.yerr.size() && std::isfinite(s.yerr[i]))
          svg << "<line x1='" << x << "' y1='" << py(s.y[i] - std::abs(s.yerr[i])) << "' x2='" << x << "' y2='"
              << py(s.y[i] + std::abs(s.yerr[i])) << "' stroke='" << c << "' stroke-width='2'/>";
        svg << "<circle cx='" << x << "' cy='" << py(s.y[i]) << "' r='3' fill='" << c << "'/>\n";
      }
    }
    svg << "<rect x='" << L + 10 + 150 * double(k) << "' y='" << T + 8 << "' width='14' height='3' fill='" << c
        << "'/><text x='" << L + 28 + 150 * double(k) << "' y='" << T + 13 << "'>" << esc(s.name) << "</text>\n";
  }
  svg << "</svg>\n";
  return svg.str();
}

bool writeSvgPlot(const std::string& path, const Plot& p, std::string* error) {
  return io::writeFileAtomic(path, svgPlot(p), error);
}

}  // namespace boresight::report
