// Rough conductor shared by `conductor` (GGX) and `beckmann`.
#pragma once

#include "gonio/twin/detail/bsdf/microfacet.hpp"
#include "gonio/twin/detail/bsdf/model.hpp"

namespace gonio::twin::bsdf {

// Params: alpha (scalar), eta and k (spectral).
BsdfPtr make_rough_conductor(const Params& p, const WavelengthGrid& grid, Distribution d);

// The parameter table both share.
std::vector<ParamInfo> conductor_params();

}  // namespace gonio::twin::bsdf
