// A bilinearly interpolated density on the unit square that can be evaluated, sampled by the
// marginal-conditional inversion method and inverted exactly, optionally depending on up to
// three extra parameters (linear interpolation between tabulated slices). This is the warp the
// RGL measured BSDF data are stored for: pbrt-v4's PiecewiseLinear2D (src/pbrt/util/sampling.h)
// and Mitsuba's Marginal2D (after Dupuy & Jakob 2018); facts taken from pbrt-v4's description,
// implementation written for lensim (double arithmetic, parameters known at run time).
//
// Data layout: [param 0][param 1]...[param D-1][y][x], x fastest, nx x ny nodes covering
// [0,1]^2 (node spacing 1/(nx-1), 1/(ny-1)). A parameter value between two tabulated ones blends
// the two slices linearly; outside the tabulated range the end slice is used (weight clamped).
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "lensim/util/vec.h"

namespace lensim::sampling {

class PiecewiseLinear2D {
 public:
  /// How the table is used.
  enum class Mode {
    /// eval() returns the interpolated values as they are (no sampling).
    Values,
    /// Each slice is normalised to a density on [0,1]^2 and its CDFs are built (sample/invert).
    /// Every slice must have a positive integral (the caller checks; see sliceIntegral).
    Density,
  };

  struct Sample {
    Vec2 p;
    double pdf = 0;
  };

  PiecewiseLinear2D() = default;
  /// `data` holds slices x ny x nx values, slices = product of the param_values sizes; each
  /// param_values[d] is strictly increasing and non-empty; nx, ny >= 2. At most 3 parameters.
  PiecewiseLinear2D(std::span<const float> data, int nx, int ny,
                    std::vector<std::vector<float>> param_values, Mode mode);

  /// Integral over [0,1]^2 of the bilinear interpolant of slice s of `data` (before any
  /// normalisation); the caller refuses a density table with a slice of integral <= 0.
  static double sliceIntegral(std::span<const float> data, int nx, int ny, std::size_t s);

  /// The interpolated value (Values) or density (Density) at pos in [0,1]^2.
  double eval(Vec2 pos, std::span<const double> params = {}) const;
  /// Maps u in [0,1)^2 to a point distributed as the density; returns it with its density.
  Sample sample(Vec2 u, std::span<const double> params = {}) const;
  /// The inverse of sample(): the u that sample() maps to p, with the density at p.
  Sample invert(Vec2 p, std::span<const double> params = {}) const;

  /// Bytes the tables take (for the memory estimate before building).
  static double bytesFor(std::size_t slices, int nx, int ny, Mode mode);

 private:
  struct Corners {
    int n = 1;
    std::size_t slice[8];
    double weight[8];
  };
  Corners corners(std::span<const double> params) const;
  // Blend of table[slice * stride + i] over the corners.
  static double blend(const std::vector<float>& table, std::size_t stride, std::size_t i,
                      const Corners& c);

  int nx_ = 0, ny_ = 0;
  Mode mode_ = Mode::Values;
  std::vector<std::vector<float>> params_;
  std::vector<std::size_t> param_stride_;  // in slices; 0 for a parameter with one value
  std::vector<float> data_, marginal_cdf_, conditional_cdf_;
};

}  // namespace lensim::sampling
