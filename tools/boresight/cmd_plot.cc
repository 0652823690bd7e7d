// boresight plot FILE.csv --y COL[,COL...] [--x COL] --out PLOT.svg: line plots of CSV columns as SVG.
#include <boresight/report/svg_plot.h>
#include <boresight/io/files.h>

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
// This file's own names, in a namespace of their own: the program builds as unity sources (several
// cmd_*.cc in one translation unit, tools/CMakeLists.txt), where anonymous namespaces would merge.
namespace cmd_plot {
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
      ->check(finiteRange(1, 1e9))
      ->type_name("N");
  if (const int rc = parseCommandLine(app, argc, argv); rc >= 0) return rc;
  std::string err, text;
  if (!io::checkOutputs({path}, {{"--out", outpath}}, &err) ||
      !io::readBounded(path, io::kMaxTableBytes, "CSV table", text, &err)) {
    std::fprintf(stderr, "boresight plot: %s\n", err.c_str());
    return 1;
  }
  std::istringstream in(text);
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
  report::Plot plot;
  plot.title = title.empty() ? path : title;
  plot.ylabel = ylabel;
  plot.xlabel = !xlabel.empty() ? xlabel : head[std::size_t(xc)] + (x0 != 0 ? " - " + std::to_string(x0) : "");
  for (std::size_t k = 0; k < y.size(); ++k) {
    report::Series se;
    se.name = ynames[k];
    se.x = x;
    se.y = y[k];
    plot.series.push_back(std::move(se));
  }
  if (!report::writeSvgPlot(outpath, plot, &err)) {
    std::fprintf(stderr, "boresight plot: %s\n", err.c_str());
    return 1;
  }
  std::printf("%s: %zu points, %zu series%s\n", outpath.c_str(), x.size(), y.size(),
              bad ? (", " + std::to_string(bad) + " rows without x skipped").c_str() : "");
  return 0;
}

}  // namespace cmd_plot

int runPlot(int argc, char** argv) { return cmd_plot::runPlot(argc, argv); }

}  // namespace boresight::cli
