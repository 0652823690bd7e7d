// SVG plot renderer (include/boresight/report/svg_plot.h).
#include <boresight/report/svg_plot.h>
#include <boresight/io/files.h>

#include <algorithm>
#include <cmath>
#include <limits>
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
  // Values are mapped through tx / ty (log10 on a logarithmic axis; non-positive values are gaps).
  auto tx = [&](double v) { return p.logx ? (v > 0 ? std::log10(v) : NAN) : v; };
  auto ty = [&](double v) { return p.logy ? (v > 0 ? std::log10(v) : NAN) : v; };
  double xmin = INFINITY, xmax = -INFINITY, ymin = INFINITY, ymax = -INFINITY;
  for (const Series& s : p.series)
    for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      const double x = tx(s.x[i] + s.dx);
      if (!std::isfinite(x)) continue;
      xmin = std::min(xmin, x), xmax = std::max(xmax, x);
      if (!std::isfinite(ty(s.y[i]))) continue;
      const double e = i < s.yerr.size() && std::isfinite(s.yerr[i]) ? std::abs(s.yerr[i]) : 0.0;
      const double el = i < s.yerr_lo.size() && std::isfinite(s.yerr_lo[i]) ? std::abs(s.yerr_lo[i]) : e;
      const double lo = ty(s.y[i] - el), hi = ty(s.y[i] + e);
      ymin = std::min(ymin, std::isfinite(lo) ? lo : ty(s.y[i])), ymax = std::max(ymax, hi);
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

  // The legend wraps into rows above the plot area: every series is listed.
  const double W = p.width, L = 90, R = 20, B = 55;
  std::vector<std::pair<double, double>> legend_at;  // (x, y) of each entry
  {
    double lx = L, ly = 40;
    for (const Series& s : p.series) {
      const double w = 28 + 7.0 * static_cast<double>(s.name.size()) + 14;
      if (lx + w > W - R && lx > L) {
        lx = L;
        ly += 16;
      }
      legend_at.emplace_back(lx, ly);
      lx += w;
    }
  }
  const double T = p.series.empty() ? 40 : legend_at.back().second + 12;
  const double H = p.height + (T - 40);
  auto px = [&](double v) { return L + (tx(v) - xmin) / (xmax - xmin) * (W - L - R); };
  auto py = [&](double v) { return H - B - (ty(v) - ymin) / (ymax - ymin) * (H - T - B); };
  auto pxt = [&](double t) { return L + (t - xmin) / (xmax - xmin) * (W - L - R); };  // t already mapped
  auto pyt = [&](double t) { return H - B - (t - ymin) / (ymax - ymin) * (H - T - B); };
  std::ostringstream svg;
  svg << "<svg xmlns='http://www.w3.org/2000/svg' width='" << W << "' height='" << H
      << "' font-family='sans-serif' font-size='12'>\n<rect width='100%' height='100%' fill='white'/>\n";
  svg << "<text x='" << W / 2 << "' y='22' text-anchor='middle' font-size='15'>" << esc(p.title) << "</text>\n";
  auto label = [](double t, bool log) {
    std::ostringstream o;
    if (log) {
      const double e = std::round(t);
      if (std::abs(t - e) < 1e-9) o << "1e" << static_cast<int>(e);
      else o << std::pow(10.0, t);
    } else {
      o << t;
    }
    return o.str();
  };
  // Ticks of a mapped range: decades on a log axis (with 2 and 5 when it spans under two decades).
  auto ticks = [&](double lo, double hi, bool log, int target) {
    std::vector<double> t;
    if (log) {
      const bool minor = hi - lo < 2;
      for (double d = std::floor(lo); d <= hi + 1e-9; d += 1)
        for (double m : {1.0, 2.0, 5.0}) {
          if (m != 1.0 && !minor) continue;
          const double v = d + std::log10(m);
          if (v >= lo - 1e-9 && v <= hi + 1e-9) t.push_back(v);
        }
      if (t.size() > 12) {  // very wide ranges: every other decade
        std::vector<double> u;
        for (std::size_t i = 0; i < t.size(); i += 2) u.push_back(t[i]);
        t = u;
      }
    } else {
      const double st = tickStep(hi - lo, target);
      for (double v = std::ceil(lo / st) * st; v <= hi + 1e-9 * st; v += st) t.push_back(v);
    }
    return t;
  };
  if (p.xcategories.empty()) {
    for (double t : ticks(xmin, xmax, p.logx, 8)) {
      svg << "<line x1='" << pxt(t) << "' y1='" << T << "' x2='" << pxt(t) << "' y2='" << H - B << "' stroke='#ddd'/>";
      svg << "<text x='" << pxt(t) << "' y='" << H - B + 16 << "' text-anchor='middle'>" << label(t, p.logx) << "</text>\n";
    }
  } else {
    for (std::size_t k = 0; k < p.xcategories.size(); ++k) {
      const double t = double(k);
      svg << "<line x1='" << pxt(t) << "' y1='" << T << "' x2='" << pxt(t) << "' y2='" << H - B << "' stroke='#eee'/>";
      svg << "<text x='" << pxt(t) << "' y='" << H - B + 16 << "' text-anchor='middle'>" << esc(p.xcategories[k])
          << "</text>\n";
    }
  }
  for (double t : ticks(ymin, ymax, p.logy, 6)) {
    svg << "<line x1='" << L << "' y1='" << pyt(t) << "' x2='" << W - R << "' y2='" << pyt(t) << "' stroke='#ddd'/>";
    svg << "<text x='" << L - 6 << "' y='" << pyt(t) + 4 << "' text-anchor='end'>" << label(t, p.logy) << "</text>\n";
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
    auto ok = [&](std::size_t i) { return std::isfinite(ty(s.y[i])) && std::isfinite(tx(s.x[i] + s.dx)); };
    if (s.style == Series::Style::kLine) {
      svg << "<path fill='none' stroke='" << c << "' stroke-width='1.3' d='";
      bool pen = false;
      for (std::size_t i = 0; i < n; ++i) {
        if (!ok(i)) {
          pen = false;
          continue;
        }
        svg << (pen ? " L" : " M") << px(s.x[i] + s.dx) << ' ' << py(s.y[i]);
        pen = true;
      }
      svg << "'/>\n";
    } else {
      for (std::size_t i = 0; i < n; ++i) {
        if (!ok(i)) continue;
        const double x = px(s.x[i] + s.dx);
        if (i < s.yerr.size() && std::isfinite(s.yerr[i])) {
          const double el = i < s.yerr_lo.size() && std::isfinite(s.yerr_lo[i]) ? s.yerr_lo[i] : s.yerr[i];
          const double lo = ty(s.y[i] - std::abs(el));
          svg << "<line x1='" << x << "' y1='" << (std::isfinite(lo) ? pyt(lo) : H - B) << "' x2='" << x << "' y2='"
              << py(s.y[i] + std::abs(s.yerr[i])) << "' stroke='" << c << "' stroke-width='2'/>";
        }
        svg << "<circle cx='" << x << "' cy='" << py(s.y[i]) << "' r='3' fill='" << c << "'/>\n";
      }
    }
    const auto [lx, ly] = legend_at[k];
    svg << "<rect x='" << lx << "' y='" << ly - 5 << "' width='14' height='3' fill='" << c << "'/><text x='" << lx + 18
        << "' y='" << ly << "'>" << esc(s.name) << "</text>\n";
  }
  svg << "</svg>\n";
  return svg.str();
}

bool writeSvgPlot(const std::string& path, const Plot& p, std::string* error) {
  return io::writeFileAtomic(path, svgPlot(p), error);
}

Series verticalMarkers(std::string name, const std::vector<double>& xs, double ylo, double yhi) {
  Series h;
  h.name = std::move(name);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (double x : xs) {
    h.x.insert(h.x.end(), {x, x, x});
    h.y.insert(h.y.end(), {ylo, yhi, nan});
  }
  return h;
}

}  // namespace boresight::report
