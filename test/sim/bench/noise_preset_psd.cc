// The noise preset's power spectral density per head axis and per accelerometer axis, by part, against
// the white levels measured on the real excerpts: log-log SVG plots (report/svg_plot.h, axes in log10)
// and a table of what each part contributes where, so that no power is counted twice.
//
//   ninja -C build noise_preset_psd && build/test/sim/bench/noise_preset_psd --out DIR
//       [--scenario config/sim_gracefo_realistic.yaml] [--hours 24] [--seed 1]
//
// Heads (one-sided PSD of the attitude error per head axis, arcsec^2/Hz, sampled at the head rate):
// white 2 sigma^2 T (sigma after head_overrides / cross_noise / anisotropic_noise), coloured_noise and
// thermal_wander from their noise.h models (psdSampled), fov_error estimated: the simulator runs the
// scenario for --hours and the error is taken at every head epoch (blinded epochs recomputed from the
// catalogue stars through the expected attitude, so the series has no gaps), Welch with Hann segments
// of 8192 s, averaged over log-spaced bands. Total = the sum. The excerpt's white levels (the audit's
// estimates, config/preset_realistic.yaml) are drawn as horizontal lines, the 3-10 mHz band of Inacio
// et al. 2015 as two vertical lines.
// Accelerometer (per A axis, (rad/s^2)^2/Hz at 10 Hz): white and Gauss-Markov of the scenario
// (model::AccNoiseModel's noise.h models), acc_coloured_noise, acc_bias_wander; the excerpts' white
// levels (second differences, test/sim/bench/real_white_levels.sh) as lines.
// The table: each part's RMS, its share of the variance above 1/16 Hz relative to the white part there
// (the band in which the 16 s excerpt measured the white level: a share near 0 means the white level
// is not counted twice), and the parts' shares of the 3-10 mHz band.
#include "../../model/psd_check.h"

#include <boresight/model/stochastic.h>
#include <boresight/report/svg_plot.h>
#include <boresight/sim/scenario.h>
#include <boresight/sim/simulator.h>
#include <boresight/sim/stars.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

namespace {

using namespace boresight;

struct HeadSeries {
  std::vector<Vec3> fov;                 ///< per head epoch, head axes, rad (NaN where recomputed later)
  std::vector<Quat> q_exp;               ///< expected attitude (for blinded epochs)
  std::vector<bool> blind;
};

struct Collect : sim::SimSink {
  std::vector<HeadSeries> h;
  void head(const sim::HeadSampleOut& s) override {
    auto& x = h[static_cast<std::size_t>(s.head - 1)];
    x.fov.push_back(s.fov_rad);
    x.q_exp.push_back(s.q_I_Si_expected);
    x.blind.push_back(s.blind != 0);
  }
};

std::vector<double> logspace(double a, double b, int n) {
  std::vector<double> f(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) f[static_cast<std::size_t>(i)] = a * std::pow(b / a, static_cast<double>(i) / (n - 1));
  return f;
}

double lg(double v) { return v > 0 ? std::log10(v) : std::nan(""); }

/// Integral of a PSD over [f0, f1] (trapezoid on a log grid).
template <class F>
double bandPower(F psd, double f0, double f1) {
  const auto f = logspace(f0, f1, 400);
  double s = 0;
  for (std::size_t i = 1; i < f.size(); ++i) s += 0.5 * (psd(f[i]) + psd(f[i - 1])) * (f[i] - f[i - 1]);
  return s;
}

/// Band averages of a Welch estimate at the plot frequencies (NaN where no bin falls in the band).
std::vector<double> bandAverage(const testpsd::Welch& W, const std::vector<double>& f) {
  std::vector<double> out(f.size(), std::nan(""));
  for (std::size_t i = 0; i < f.size(); ++i) {
    const double lo = i ? std::sqrt(f[i] * f[i - 1]) : f[i] / 1.05, hi = i + 1 < f.size() ? std::sqrt(f[i] * f[i + 1]) : f[i] * 1.05;
    double s = 0;
    int n = 0;
    for (std::size_t k = 1; k < W.psd.size() - 1; ++k)
      if (W.f(k) >= lo && W.f(k) < hi) s += W.psd[k], ++n;
    if (n) out[i] = s / n;
  }
  return out;
}

report::Series line(const std::string& name, const std::vector<double>& f, const std::vector<double>& p) {
  report::Series s;
  s.name = name;
  for (std::size_t i = 0; i < f.size(); ++i) {
    s.x.push_back(lg(f[i]));
    s.y.push_back(lg(p[i]));
  }
  return s;
}

report::Series hline(const std::string& name, double f0, double f1, double level) {
  report::Series s;
  s.name = name;
  s.x = {lg(f0), lg(f1)};
  s.y = {lg(level), lg(level)};
  return s;
}

report::Series vline(const std::string& name, double f, double y0, double y1) {
  report::Series s;
  s.name = name;
  s.x = {lg(f), lg(f)};
  s.y = {lg(y0), lg(y1)};
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  std::string scenario = std::string(BORESIGHT_SOURCE_DIR) + "/config/sim_gracefo_realistic.yaml", out;
  double hours = 24;
  std::uint64_t seed = 1;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--scenario" && i + 1 < argc) scenario = argv[++i];
    else if (a == "--out" && i + 1 < argc) out = argv[++i];
    else if (a == "--hours" && i + 1 < argc) hours = std::atof(argv[++i]);
    else if (a == "--seed" && i + 1 < argc) seed = std::strtoull(argv[++i], nullptr, 10);
    else {
      std::fprintf(stderr, "usage: noise_preset_psd --out DIR [--scenario FILE] [--hours H] [--seed N]\n");
      return 2;
    }
  }
  if (out.empty()) {
    std::fprintf(stderr, "noise_preset_psd: --out DIR is required\n");
    return 2;
  }
  std::filesystem::create_directories(out);
  sim::Scenario sc;
  std::string err;
  if (!sim::loadScenario(scenario, sc, &err)) {
    std::fprintf(stderr, "%s\n", err.c_str());
    return 1;
  }
  sc.output.star_vectors_interval_s = 0;
  sim::Simulator S;
  if (!S.init(sc, seed, hours * 3600, &err)) {
    std::fprintf(stderr, "%s\n", err.c_str());
    return 1;
  }
  Collect c;
  c.h.resize(S.heads().size());
  S.run(c);
  const double T = 1.0 / sc.heads[0].rate_hz;
  const double a2 = kArcsecPerRad * kArcsecPerRad;
  const double f_excerpt = 1.0 / 16;  // the real excerpt's span: what it sees of a process is above 1/16 Hz
  const auto f = logspace(1e-5, 0.5 / T, 160);

  // Measured excerpt levels (audit, real_white_levels.sh), per head: cross, about.
  const double meas[3][2] = {{2.29, 21.1}, {1.69, 30.8}, {2.32, 29.9}};

  std::printf("noise preset PSD: %s, %.0f h, seed %llu\n", scenario.c_str(), hours, static_cast<unsigned long long>(seed));
  std::printf("%-6s %-6s %8s %9s %9s %9s | %-31s | %-25s\n", "head", "axis", "white\"", "coloured\"", "wander\"", "fov\"",
              "share above 1/16 Hz (of white)", "share of 3-10 mHz power");
  std::printf("%-6s %-6s %8s %9s %9s %9s | %9s %9s %9s | %7s %7s %7s %7s\n", "", "", "", "", "", "", "coloured", "wander", "fov",
              "white", "colour", "wander", "fov");
  report::Plot plot[2];
  const char* axis_name[2] = {"cross-boresight (per axis)", "about the boresight"};
  for (int g = 0; g < 2; ++g) {
    plot[g].title = std::string("preset realistic: head attitude error PSD, ") + axis_name[g];
    plot[g].xlabel = "log10 frequency [Hz]";
    plot[g].ylabel = "log10 PSD [arcsec^2/Hz]";
    plot[g].width = 1000;
    plot[g].height = 560;
  }
  for (std::size_t i = 0; i < S.heads().size() && i < 3; ++i) {
    const model::HeadModel& hm = S.heads()[i];
    const model::HeadEffects& e = hm.effects();
    auto& hs = c.h[i];
    // fov_error at every epoch: blinded epochs recomputed through the expected attitude
    const auto& cc = hm.config();
    for (std::size_t k = 0; k < hs.fov.size(); ++k)
      if (hs.blind[k] && hm.hasFovError()) {
        const auto st = sim::starVectorsInHead(S.stars(), hs.q_exp[k], cc.boresight_Si, cc.fov_half_angle_rad, cc.limiting_mag);
        hs.fov[k] = hm.toHeadAxes(hm.fovAttitudeError(st.data(), st.size()));
      }
    for (int g = 0; g < 2; ++g) {
      const double sw = g == 0 ? hm.sigmaCross() : hm.sigmaAbout();
      const model::NoiseModel& col = g == 0 ? e.coloured_cross : e.coloured_about;
      const model::NoiseModel& wan = g == 0 ? e.wander_cross : e.wander_about;
      // fov: the Welch estimate of axis e1 (cross; e2 alike) or b
      std::vector<double> x;
      for (const auto& v : hs.fov) x.push_back(v[g == 0 ? 0 : 2] * kArcsecPerRad);
      const testpsd::Welch W = testpsd::welch(x, T, 16384);
      double fov_var = 0;
      for (double v : x) fov_var += v * v;
      fov_var /= static_cast<double>(x.size());
      const auto fov_psd = bandAverage(W, f);
      std::vector<double> pw(f.size()), pc(f.size()), pn(f.size()), pt(f.size());
      for (std::size_t k = 0; k < f.size(); ++k) {
        pw[k] = 2 * sw * sw * T * a2;
        pc[k] = col.empty() ? 0 : col.psdSampled(f[k], T) * a2;
        pn[k] = wan.empty() ? 0 : wan.psdSampled(f[k], T) * a2;
        pt[k] = pw[k] + pc[k] + pn[k] + (std::isfinite(fov_psd[k]) ? fov_psd[k] : 0);
      }
      // shares: above the excerpt's lowest frequency, relative to the white power there; 3-10 mHz
      const auto welchPower = [&](double f0, double f1) {
        double s = 0;
        for (std::size_t k = 1; k < W.psd.size(); ++k)
          if (W.f(k) >= f0 && W.f(k) < f1) s += W.psd[k] / (static_cast<double>(W.L) * T);
        return s;
      };
      const double nyq = 0.5 / T;
      const double white_hi = 2 * sw * sw * T * a2 * (nyq - f_excerpt);
      const double c_hi = col.empty() ? 0 : bandPower([&](double q) { return col.psdSampled(q, T) * a2; }, f_excerpt, nyq);
      const double w_hi = wan.empty() ? 0 : bandPower([&](double q) { return wan.psdSampled(q, T) * a2; }, f_excerpt, nyq);
      const double v_hi = welchPower(f_excerpt, nyq);
      const double b_w = 2 * sw * sw * T * a2 * 7e-3;
      const double b_c = col.empty() ? 0 : bandPower([&](double q) { return col.psdSampled(q, T) * a2; }, 3e-3, 1e-2);
      const double b_n = wan.empty() ? 0 : bandPower([&](double q) { return wan.psdSampled(q, T) * a2; }, 3e-3, 1e-2);
      const double b_f = welchPower(3e-3, 1e-2);
      const double b_t = b_w + b_c + b_n + b_f;
      std::printf("%-6zu %-6s %8.2f %9.2f %9.2f %9.2f | %8.2f%% %8.2f%% %8.2f%% | %6.1f%% %6.1f%% %6.1f%% %6.1f%%\n", i + 1,
                  g == 0 ? "cross" : "about", sw * kArcsecPerRad, std::sqrt(col.variance() * a2), std::sqrt(wan.variance() * a2),
                  std::sqrt(fov_var), 100 * c_hi / white_hi, 100 * w_hi / white_hi, 100 * v_hi / white_hi, 100 * b_w / b_t,
                  100 * b_c / b_t, 100 * b_n / b_t, 100 * b_f / b_t);
      auto& P = plot[g];
      const std::string id = "head " + std::to_string(i + 1);
      P.series.push_back(line(id + " total", f, pt));
      P.series.push_back(line(id + " fov_error (simulated)", f, fov_psd));
      if (i == 0) {  // the same models on every head
        P.series.push_back(line("coloured_noise (each head)", f, pc));
        P.series.push_back(line("thermal_wander (each head)", f, pn));
      }
      P.series.push_back(hline(id + " white, real excerpt " + std::to_string(meas[i][g]).substr(0, 5) + "\"", f_excerpt, f.back(),
                               2 * meas[i][g] * meas[i][g] * T));
    }
  }
  for (int g = 0; g < 2; ++g) {
    plot[g].series.push_back(vline("3 and 10 mHz (Inacio et al. 2015)", 3e-3, 1e-4, 1e6));
    plot[g].series.push_back(vline("", 1e-2, 1e-4, 1e6));
    const std::string path = out + (g == 0 ? "/preset_realistic_heads_cross.svg" : "/preset_realistic_heads_about.svg");
    if (!report::writeSvgPlot(path, plot[g], &err)) {
      std::fprintf(stderr, "%s\n", err.c_str());
      return 1;
    }
  }

  // Accelerometer.
  const model::AccNoiseModel acc(S.accel().config(), seed);
  const auto& ae = S.accel().effects();
  const double Ta = 1.0 / S.accel().config().rate_hz;
  const auto fa = logspace(1e-6, 0.5 / Ta, 160);
  // excerpt white levels per A axis (second differences): 2023-06-01 and 2023-06-03
  const double acc_meas[3][2] = {{1.43e-7, 1.90e-7}, {2.98e-8, 2.65e-8}, {7.44e-8, 3.01e-8}};
  std::printf("\naccelerometer (rad/s^2)   white   GM(scenario)  acc_coloured  bias_wander | share above 1/16 Hz of white: GM, coloured, wander\n");
  for (int k = 0; k < 3; ++k) {
    report::Plot P;
    P.title = std::string("preset realistic: accelerometer angular acceleration PSD, A ") + "xyz"[k];
    P.xlabel = "log10 frequency [Hz]";
    P.ylabel = "log10 PSD [(rad/s^2)^2/Hz]";
    P.width = 1000;
    P.height = 520;
    const model::NoiseModel& m = acc.model(k);
    model::NoiseModel white, gm;
    for (const auto& t : m.terms) (t.kind == model::NoiseKind::White ? white : gm).add(t);
    const model::NoiseModel& col = ae.coloured[static_cast<std::size_t>(k)];
    const model::NoiseModel& bw = ae.bias_wander[static_cast<std::size_t>(k)];
    std::vector<double> pw(fa.size()), pg(fa.size()), pc(fa.size()), pb(fa.size()), pt(fa.size());
    for (std::size_t i = 0; i < fa.size(); ++i) {
      pw[i] = white.empty() ? 0 : white.psdSampled(fa[i], Ta);
      pg[i] = gm.empty() ? 0 : gm.psdSampled(fa[i], Ta);
      pc[i] = col.empty() ? 0 : col.psdSampled(fa[i], Ta);
      pb[i] = bw.empty() ? 0 : bw.psdSampled(fa[i], Ta);
      pt[i] = pw[i] + pg[i] + pc[i] + pb[i];
    }
    const double nyq = 0.5 / Ta;
    const double wh = white.whiteVariance() * 2 * Ta * (nyq - f_excerpt);
    auto hi = [&](const model::NoiseModel& x) { return x.empty() ? 0.0 : bandPower([&](double q) { return x.psdSampled(q, Ta); }, f_excerpt, nyq); };
    std::printf("A %c  %21.2e %12.2e %13.2e %12.2e | %.2f%%, %.2f%%, %.2f%%\n", "xyz"[k], std::sqrt(white.variance()),
                std::sqrt(gm.variance()), std::sqrt(col.variance()), std::sqrt(bw.variance()), 100 * hi(gm) / wh, 100 * hi(col) / wh,
                100 * hi(bw) / wh);
    P.series.push_back(line("total", fa, pt));
    P.series.push_back(line("white (scenario)", fa, pw));
    P.series.push_back(line("Gauss-Markov (scenario)", fa, pg));
    P.series.push_back(line("acc_coloured_noise", fa, pc));
    P.series.push_back(line("acc_bias_wander", fa, pb));
    for (int d = 0; d < 2; ++d) {
      char name[96];
      std::snprintf(name, sizeof name, "white, real excerpt 2023-06-0%c: %.2e", d == 0 ? '1' : '3', acc_meas[k][d]);
      P.series.push_back(hline(name, d == 0 ? 0.1 : 1.0 / 67, nyq, 2 * acc_meas[k][d] * acc_meas[k][d] * Ta));
    }
    const std::string path = out + "/preset_realistic_acc_" + "xyz"[k] + ".svg";
    if (!report::writeSvgPlot(path, P, &err)) {
      std::fprintf(stderr, "%s\n", err.c_str());
      return 1;
    }
  }
  std::printf("\nwrote %s/preset_realistic_{heads_cross,heads_about,acc_x,acc_y,acc_z}.svg\n", out.c_str());
  return 0;
}
