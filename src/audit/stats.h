// The audit's distribution functions are the model library's (model/stats.h), shared with the noise
// library's whiteness tests.
#pragma once

#include <boresight/model/stats.h>

namespace boresight::audit {
namespace stats = model::stats;
}  // namespace boresight::audit
