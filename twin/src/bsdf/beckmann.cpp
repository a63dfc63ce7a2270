// beckmann — rough conductor with the Beckmann distribution of normals (Beckmann &
// Spizzichino 1963; Walter et al. 2007 eq. 25), exact Smith Λ (Heitz 2014 eq. 72) and
// visible-normal sampling by Heitz & d'Eon 2014. Same parameters as `conductor`.
#include "bsdf/conductor.hpp"

namespace gonio::twin::bsdf {
namespace {

BsdfPtr build_beckmann(const Params& p, const WavelengthGrid& grid) {
  return make_rough_conductor(p, grid, Distribution::beckmann);
}

}  // namespace

const Registrar kBeckmannRegistered{{"beckmann", conductor_params(), &build_beckmann}};

}  // namespace gonio::twin::bsdf
