// The method A calibration result for programs (JSON), for people (the same tree as YAML) and as a
// report (report.md with SVG plots): `boresight calibrate --json FILE --yaml FILE --report DIR`.
//
// JSON keys (issue 8): heads[] {id, error_angles_arcsec[3], sigma_arcsec[3] (null where not
// determined), crlb_arcsec[3] (null where infinite), observable[3]}; unobservable_directions_B[];
// covariance_arcsec2 (all head angles, 3n x 3n row-major, head order as heads[]); accelerometer
// {bias_radps2, bias_sigma_radps2, scale, scale_sigma, nonorthogonality_arcsec,
// nonorthogonality_sigma_arcsec} with only what was estimated; time_offset_s and time_offset_sigma_s
// (null when not estimated; positive: the accelerometer's tags are late relative to the star cameras'
// for the same instant); thermal; residual_rms_radps2; epochs; span_s. Also: datum, conventions,
// excitation_eigenvalues_radps2_sq, options, solver message, inputs. A number that is not finite is
// written as null.
#pragma once

#include <boresight/calib/problem.h>
#include <boresight/calib/solver.h>
#include <boresight/calib/span_builder.h>
#include <boresight/calib/thermal_fit.h>
#include <boresight/core/pipeline.h>

#include <nlohmann/json.hpp>

#include <string>
#include <utility>
#include <vector>

namespace boresight::report {

/// JSON with the keys in the order they were written (the result reads top-down like the issue).
using Json = nlohmann::ordered_json;

/// What the command knows besides the solver's result.
struct CalibrationContext {
  std::string config;                                        ///< platform file
  std::vector<std::string> inputs;                           ///< files used
  std::vector<std::pair<std::string, std::string>> ignored;  ///< (file, product) not used
  calib::SolveOptions options;
  calib::SpanOptions span_options;
  Json thermal;  ///< the `thermal` section as built by the caller (null: not computed)
};

Json calibrationJson(const calib::SolveResult& r, const CalibrationContext& c);

/// The `thermal` section from the harmonic fit (calib/thermal_fit.h): the datum head, where u came from,
/// the harmonics, beta (its modulation "not determined" unless the span let beta move), and per non-datum
/// head: datum_head, determined (reason when not), epochs, chi2_per_dof, and per axis x, y, z of the
/// datum head's frame the constant and per harmonic the cosine and sine amplitudes with sigmas (arcsec),
/// the beta modulation terms or "not determined", RMS before and after the model (arcsec).
Json thermalJson(const calib::ThermalFitResult& t);

/// The JSON tree as block YAML (same keys, same values; number arrays in flow style).
std::string toYaml(const Json& j);


/// Writes DIR/report.md and DIR/{residuals,excitation,estimates}.svg (DIR is created). False with
/// *error when a file cannot be written.
bool writeCalibrationReport(const std::string& dir, const calib::CalibrationSpan& span, const calib::SolveResult& r,
                            const Json& result, std::string* error);

}  // namespace boresight::report
