// calib_mc: the Monte Carlo of the method A solver (issue 8). Prints, per case, the Cramer-Rao bound,
// the injected errors (6x the bound), bias, RMS error / CRLB, reported sigma / CRLB, NEES with its 95 %
// bounds, the time offset and scale z-scores, hard-vs-prior agreement and the unobservable directions.
#include "../mc.h"

#include <cstdlib>
#include <cstring>
#include <iostream>

int main(int argc, char** argv) {
  using namespace boresight::calib;
  int runs = 200;
  std::uint64_t seed0 = 1000;
  std::string only;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::cout << "usage: calib_mc [--runs N] [--seed S] [--case NAME]\n"
                   "  Monte Carlo of the method A solver on synthetic spans through the real SpanBuilder.\n"
                   "  --runs N    runs per case (default 200)\n"
                   "  --seed S    first seed (runs use S, S+1, ...; default 1000)\n"
                   "  --case NAME one case only; cases:\n";
      for (const auto& c : mc::cases()) std::cout << "    " << c.name << ": " << c.what << "\n";
      return 0;
    }
    auto value = [&](const char* name) -> std::string {
      if (i + 1 >= argc) {
        std::cerr << "calib_mc: " << name << " needs a value (see --help)\n";
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--runs") {
      runs = std::atoi(value("--runs").c_str());
    } else if (a == "--seed") {
      seed0 = std::strtoull(value("--seed").c_str(), nullptr, 10);
    } else if (a == "--case") {
      only = value("--case");
    } else {
      std::cerr << "calib_mc: unknown option " << a << " (see --help)\n";
      return 2;
    }
  }
  if (runs < 1) {
    std::cerr << "calib_mc: --runs must be >= 1\n";
    return 2;
  }
  bool any = false;
  for (auto c : mc::cases()) {
    if (!only.empty() && c.name != only) continue;
    any = true;
    const mc::Result r = mc::run(c, runs, seed0);
    mc::prepareCase(c, seed0);  // the printed truth is the case's
    mc::print(c, r);
    std::fflush(stdout);
  }
  if (!any) {
    std::cerr << "calib_mc: no case named " << only << " (see --help)\n";
    return 2;
  }
  return 0;
}
