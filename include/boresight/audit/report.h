// The model audit's outputs: audit.json for programs and report.md with SVG plots for people
// (`boresight audit --out DIR`).
//
// audit.json keys (issue 11): baseline {description, span_s, bin_s, head_epochs, acc_samples,
// reference_samples, orbit_samples, families[], missing[], values{}}; tests (how many candidates were
// tested: the Bonferroni divisor); effects[] {name, sensor, family, statistic, threshold, p_value, dof,
// detected, named, params{KEY: {value, sigma, unit[, truth]}}, note}; named_causes[] (the same keys,
// the canonical catalogue names of model::effectCatalogue()); not_explained[] {family, what, statistic,
// threshold}; ambiguous[] {causes[], separate_by, correlation}; extended[] (the extended model's effects
// re-estimated together, keys as effects[]); gain {family, unit, rms_before, rms_after,
// heldout_rms_before, heldout_rms_after, whiteness_before, whiteness_after, delta_bic} (delta_bic
// negative when the extended model is better); gains[] (the same keys, every residual family);
// findings[]; truth[] {effect, sensor, key, unit, truth, before, after} only when a truth was given.
// A number that is not finite is written as null.
//
// report.md: what is wrong (the findings), the named causes with their evidence (statistic against
// threshold, p-value) and estimates, every test, the gain table, the ambiguities with what would
// separate them, what is not explained, the truth comparison; plots (report/svg_plot.h):
// residuals_<family>.svg (series before/after), spectrum_<family>.svg (amplitude before/after),
// iba.svg (inter-boresight angle series: family "relative", label "iba..."), estimates_<unit>.svg (the
// extended model's parameters that have a sigma, +- sigma, with the truth when given).
#pragma once

#include <boresight/audit/audit.h>

#include <string>
#include <utility>
#include <vector>

namespace boresight::audit {

/// What the report says about the run besides the result (optional).
struct ReportContext {
  std::string command;                ///< how it was run, e.g. "boresight audit --config ..."
  std::vector<std::string> inputs;    ///< files used, with their role ("SCA1A_...: heads")
  std::vector<std::string> notes;     ///< e.g. the reference's time base, ignored files
  /// --write-model: the overlay written, what it carries and not, and the second pass's comparison
  /// (audit/extension.h), one line each; a section of its own after the gain.
  std::vector<std::string> extension;
  /// Figures the caller wrote into the report's folder for that section: file name and caption.
  std::vector<std::pair<std::string, std::string>> extension_figures;
};

/// The result as JSON text (pretty-printed, keys in the order above).
std::string auditJsonText(const AuditResult& r);

/// Writes auditJsonText(r) to PATH. False with *error ("cannot write PATH: reason").
bool writeAuditJson(const AuditResult& r, const std::string& path, std::string* error);

/// Writes DIR/report.md and its SVG plots (DIR is created). False with *error naming the file or
/// directory that cannot be written.
bool writeAuditReport(const AuditResult& r, const std::string& dir, std::string* error,
                      const ReportContext* context = nullptr);

/// The files writeAuditReport writes besides report.md (SVG names), for a caller that lists them.
std::vector<std::string> auditPlotFiles(const AuditResult& r);

}  // namespace boresight::audit
