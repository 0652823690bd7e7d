// Placeholder: the analysis lands with the audit implementation.
#include <boresight/audit/audit.h>

namespace boresight::audit {
std::vector<std::string> AuditResult::namedCauseNames() const {
  std::vector<std::string> out;
  for (const auto& e : named) {
    bool seen = false;
    for (const auto& s : out) seen |= s == e.name;
    if (!seen) out.push_back(e.name);
  }
  return out;
}
AuditResult analyse(const Collector&, const AuditOptions&, const Truth*) { return {}; }
}  // namespace boresight::audit
