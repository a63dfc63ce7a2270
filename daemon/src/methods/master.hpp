// Catalogues made from master references (sample.create's `reference`, sample.export): a
// completed scan as a master, instrument-corrected; a model fitted to it with its misfit; a
// master exported by another instrument (docs/decision-rule.md, "Master references").
#pragma once

#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "gonio/daemon/instrument/catalogue.hpp"
#include "gonio/daemon/methods/methods.hpp"

namespace gonio::daemon::methods {

struct MadeCatalogue {
  std::string bsdf;  // the twin's spec: the master's table file, or the fitted model
  Catalogue catalogue;
};

// From sample.create's `reference` ({scan, model?} or {file}); `name` is the sample's. A
// master's table is written to <state>/masters/<name>.ssdd (`written` says whether this call
// created it, so that a refused sample can take it back). Errors name "reference.…".
MadeCatalogue make_catalogue(Services& s, const nlohmann::json& reference, const std::string& name,
                             bool& written);

// A sample's master as a document another goniod reads back (`reference: {file}`):
// {"format": "gonio-master", "version": 1, "sample", "master_scan", "wavelengths",
//  "points": [{theta_i, theta_r, beta, u}]}, β instrument-corrected.
nlohmann::json master_document(const Sample& sample, const Catalogue& c);

}  // namespace gonio::daemon::methods
