// Placeholder: the Collector's binning lands with the audit implementation.
#include <boresight/audit/audit.h>

namespace boresight::audit {
struct Collector::Impl {};
Collector::Collector() : impl_(std::make_unique<Impl>()) {}
Collector::~Collector() = default;
bool Collector::configure(const core::PipelineConfig&, const AuditOptions&, std::string* error) {
  if (error) *error = "audit: not implemented yet";
  return false;
}
void Collector::onHeads(const core::HeadEpoch&, core::Status) {}
void Collector::onAcc(TimeUs, const Vec3&, core::Status) {}
void Collector::onEnd() {}
bool Collector::write(const core::PipelineRow&) { return true; }
void Collector::addOrbit(const model::OrbitSample&) {}
void Collector::addReference(TimeUs, const Quat&) {}
void Collector::noteRejected(TimeUs, int) {}
}  // namespace boresight::audit
