// boresight plot FILE.csv --y COL[,COL...] [--x COL] --out PLOT.svg: line plots of CSV columns as SVG.
#include "cli_common.h"
#include "commands.h"

#include <algorithm>
#include <cstdlib>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace boresight::cli {
namespace {

const char* kDescription =
    "Draws the named columns of a CSV table (such as the output of `boresight process`) against the\n"
    "--x column (default: the first column) as an SVG line plot. Empty cells are gaps in the line.";

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::string cur;
  std::istringstream is(s);
  while (std::getline(is, cur, sep)) out.push_back(cur);
  if (!s.empty() && s.back() == sep) out.emplace_back();
  return out;
}

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

}  // namespace

int runPlot(int argc, char** argv) {
  CLI::App app{kDescription, "boresight plot"};
  std::string path, xname, ylist, outpath, title, ylabel, xlabel;
  int smooth = 1;
  bool relative_x = false;
  app.add_option("FILE.csv", path, "the table")->required();
  app.add_option("--y", ylist, "columns to draw, COL[,COL...]")->required()->type_name("COLS");
  app.add_option("--out", outpath, "the SVG file to write")->required()->type_name("PLOT.svg");
  app.add_option("--x", xname, "x column (default: the first column)")->type_name("COL");
  app.add_option("--title", title, "plot title (default: the file name)");
  app.add_option("--ylabel", ylabel, "y axis label");
  app.add_option("--xlabel", xlabel, "x axis label (default: the x column)");
  app.add_flag("--relative-x", relative_x, "subtract the first x value (times in seconds since the start)");
  app.add_option("--smooth", smooth, "plot the centred running mean over N rows (gaps: the mean of what is there)")
      ->check(CLI::PositiveNumber)
      ->type_name("N");
  if (const int rc = parseCommandLine(app, argc, argv); rc >= 0) return rc;
  std::ifstream in(path);
  if (!in) {
    std::fprintf(stderr, "boresight plot: %s: cannot open\n", path.c_str());
    return 1;
  }
  std::string line;
  if (!std::getline(in, line)) {
    std::fprintf(stderr, "boresight plot: %s:1: empty file\n", path.c_str());
    return 1;
  }
  std::vector<std::string> head = split(line, ',');
  auto col = [&](const std::string& name) {
    auto it = std::find(head.begin(), head.end(), name);
    return it == head.end() ? -1 : static_cast<int>(it - head.begin());
  };
  int xc = !xname.empty() ? col(xname) : 0;
  if (xc < 0) {
    std::fprintf(stderr, "boresight plot: %s: no column '%s'\n", path.c_str(), xname.c_str());
    return 1;
  }
  std::vector<int> yc;
  std::vector<std::string> ynames = split(ylist, ',');
  for (const auto& n : ynames) {
    int c = col(n);
    if (c < 0) {
      std::fprintf(stderr, "boresight plot: %s: no column '%s'\n", path.c_str(), n.c_str());
      return 1;
    }
    yc.push_back(c);
  }
  std::vector<double> x;
  std::vector<std::vector<double>> y(yc.size());
  std::size_t line_no = 1, bad = 0;
  while (std::getline(in, line)) {
    ++line_no;
    auto f = split(line, ',');
    auto val = [&](int c) {
      if (c >= static_cast<int>(f.size()) || f[std::size_t(c)].empty()) return double(NAN);
      char* end = nullptr;
      double v = std::strtod(f[std::size_t(c)].c_str(), &end);
      return (end && *end == 0) ? v : double(NAN);
    };
    double xv = val(xc);
    if (!std::isfinite(xv)) {
      ++bad;
      continue;
    }
    x.push_back(xv);
    for (std::size_t k = 0; k < yc.size(); ++k) y[k].push_back(val(yc[k]));
  }
  if (x.empty()) {
    std::fprintf(stderr, "boresight plot: %s: no rows with a numeric x\n", path.c_str());
    return 1;
  }
  if (smooth > 1) {
    for (auto& s : y) {
      std::vector<double> m(s.size(), NAN);
      const long h = smooth / 2, n = static_cast<long>(s.size());
      double sum = 0;
      long cnt = 0;
      // Sliding window [i-h, i+h] over the finite values.
      for (long i = -h; i < n; ++i) {
        long add = i + h, drop = i - h - 1;
        if (add < n && std::isfinite(s[std::size_t(add)])) sum += s[std::size_t(add)], ++cnt;
        if (drop >= 0 && std::isfinite(s[std::size_t(drop)])) sum -= s[std::size_t(drop)], --cnt;
        if (i >= 0 && std::isfinite(s[std::size_t(i)]) && cnt > 0) m[std::size_t(i)] = sum / double(cnt);
      }
      s = m;
    }
  }
  double x0 = relative_x ? x.front() : 0.0;
  for (double& v : x) v -= x0;
  double xmin = *std::min_element(x.begin(), x.end()), xmax = *std::max_element(x.begin(), x.end());
  double ymin = INFINITY, ymax = -INFINITY;
  for (const auto& s : y)
    for (double v : s)
      if (std::isfinite(v)) ymin = std::min(ymin, v), ymax = std::max(ymax, v);
  if (!std::isfinite(ymin)) ymin = 0, ymax = 1;
  if (ymax - ymin < 1e-300) ymin -= 0.5, ymax += 0.5;
  if (xmax - xmin < 1e-300) xmax = xmin + 1;
  double pad = 0.05 * (ymax - ymin);
  ymin -= pad;
  ymax += pad;

  const double W = 900, H = 420, L = 90, R = 20, T = 40, B = 55;
  auto px = [&](double v) { return L + (v - xmin) / (xmax - xmin) * (W - L - R); };
  auto py = [&](double v) { return H - B - (v - ymin) / (ymax - ymin) * (H - T - B); };
  static const char* colors[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2"};
  std::ostringstream svg;
  svg << "<svg xmlns='http://www.w3.org/2000/svg' width='" << W << "' height='" << H
      << "' font-family='sans-serif' font-size='12'>\n<rect width='100%' height='100%' fill='white'/>\n";
  svg << "<text x='" << W / 2 << "' y='22' text-anchor='middle' font-size='15'>"
      << esc(title.empty() ? path : title) << "</text>\n";
  double xs = tickStep(xmax - xmin, 8), ys = tickStep(ymax - ymin, 6);
  for (double t = std::ceil(xmin / xs) * xs; t <= xmax + 1e-9 * xs; t += xs) {
    svg << "<line x1='" << px(t) << "' y1='" << T << "' x2='" << px(t) << "' y2='" << H - B << "' stroke='#ddd'/>";
    svg << "<text x='" << px(t) << "' y='" << H - B + 16 << "' text-anchor='middle'>" << t << "</text>\n";
  }
  for (double t = std::ceil(ymin / ys) * ys; t <= ymax + 1e-9 * ys; t += ys) {
    svg << "<line x1='" << L << "' y1='" << py(t) << "' x2='" << W - R << "' y2='" << py(t) << "' stroke='#ddd'/>";
    svg << "<text x='" << L - 6 << "' y='" << py(t) + 4 << "' text-anchor='end'>" << t << "</text>\n";
  }
  svg << "<rect x='" << L << "' y='" << T << "' width='" << W - L - R << "' height='" << H - T - B
      << "' fill='none' stroke='#444'/>\n";
  svg << "<text x='" << (L + W - R) / 2 << "' y='" << H - 12 << "' text-anchor='middle'>"
      << esc(!xlabel.empty() ? xlabel : head[std::size_t(xc)] + (x0 != 0 ? " - " + std::to_string(x0) : "")) << "</text>\n";
  svg << "<text transform='translate(16," << (T + H - B) / 2 << ") rotate(-90)' text-anchor='middle'>"
      << esc(ylabel) << "</text>\n";
  for (std::size_t k = 0; k < y.size(); ++k) {
    const char* c = colors[k % 7];
    svg << "<path fill='none' stroke='" << c << "' stroke-width='1.3' d='";
    bool pen = false;
    for (std::size_t i = 0; i < x.size(); ++i) {
      if (!std::isfinite(y[k][i])) {
        pen = false;
        continue;
      }
      svg << (pen ? " L" : " M") << px(x[i]) << ' ' << py(y[k][i]);
      pen = true;
    }
    svg << "'/>\n";
    svg << "<rect x='" << L + 10 + 150 * double(k) << "' y='" << T + 8 << "' width='14' height='3' fill='" << c
        << "'/><text x='" << L + 28 + 150 * double(k) << "' y='" << T + 13 << "'>" << esc(ynames[k]) << "</text>\n";
  }
  svg << "</svg>\n";
  std::ofstream out(outpath);
  if (!(out << svg.str())) {
    std::fprintf(stderr, "boresight plot: cannot write %s\n", outpath.c_str());
    return 1;
  }
  std::printf("%s: %zu points, %zu series%s\n", outpath.c_str(), x.size(), y.size(),
              bad ? (", " + std::to_string(bad) + " rows without x skipped").c_str() : "");
  return 0;
}

}  // namespace boresight::cli
