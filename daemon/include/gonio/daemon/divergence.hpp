// Divergence monitor: does a measured point agree with the twin's prediction?
//
// Per channel c (docs/architecture.md §6):
//     z_c = (m_c − p_c) / √(σm_c² + σp_c² + (tol · p_c)²)
// with σm the measurement's standard uncertainty, σp the twin's standard error and tol the
// sample's relative tolerance (which absorbs what neither uncertainty models: the catalog
// BSDF is a model of the sample, not the sample). A point diverges when max |z| passes
// z_threshold or when the CIEDE2000 difference of the two spectra (D65, 10° observer,
// computed on the scan's grid) passes delta_e_threshold. m diverged points among the last
// n make a sustained divergence. Reference drift compares the dark-corrected reference
// white signal with the scan's first reading: a stable lamp and detector keep the ratio 1.
#pragma once

#include <cstddef>
#include <deque>
#include <memory>
#include <optional>

#include "gonio/proto/spectrum.hpp"
#include "gonio/twin/color.hpp"

namespace gonio::daemon {

struct DivergenceSettings {
  double z_threshold = 5.0;
  double delta_e_threshold = 3.0;
  int sustained_m = 3;
  int sustained_n = 5;
  double reference_drift = 0.05;
};

struct PointDivergence {
  double z_max = 0;
  std::size_t worst_channel = 0;
  std::optional<double> delta_e00;  // nullopt without a colorimeter for the grid
  bool diverged = false;
};

// `colorimeter` may be null (grid without visible overlap). Spectra on the same grid.
PointDivergence evaluate_point(const Spectrum& measured, const Spectrum& predicted,
                               double tolerance, const twin::Colorimeter* colorimeter,
                               const DivergenceSettings& s);

// D65 / 10° colorimeter on `grid`, or null when the grid cannot carry colour.
std::shared_ptr<const twin::Colorimeter> colorimeter_for(const WavelengthGrid& grid);

// m of the last n.
class SustainedWindow {
 public:
  SustainedWindow(int m, int n) : m_(m), n_(n) {}
  // Records a point; true when the window now holds at least m diverged points.
  bool push(bool diverged);
  int diverged_in_window() const noexcept { return count_; }
  void clear() {
    window_.clear();
    count_ = 0;
  }

 private:
  int m_, n_;
  std::deque<bool> window_;
  int count_ = 0;
};

// Relative drift |current / baseline − 1| of the channel-mean reference signal; nullopt
// when the baseline is not positive.
std::optional<double> reference_drift(const std::vector<double>& baseline,
                                      const std::vector<double>& current);

}  // namespace gonio::daemon
