// pbrt-v4's procedural and file-based media (src/pbrt/media.{h,cpp}): "cloud", a density made of
// Perlin noise, and "nanovdb", density (and optional blackbody temperature) grids read from a
// NanoVDB file with Debian's libnanovdb-dev. Both scale constant sigma_a, sigma_s spectra by the
// density and bound it with majorant grids for delta tracking (see media.h).
#pragma once

#include <memory>
#include <vector>

#include "lensim/render/media/media.h"

namespace lensim::render {

/// pbrt-v4's CloudMedium: sigma_{a,s} = scale sigma_{a,s} d(p), d in [0, 1] from fractal noise
/// at the medium-space point p (not normalised to the bounds), zero outside [p0, p1]. Its
/// majorant is sigma_t scale over the bounds (d never exceeds 1), as in pbrt-v4.
class CloudMedium final : public Medium {
 public:
  explicit CloudMedium(const scene::Medium& desc);
  MediumProperties at(const Vec3& p, const SampledWavelengths& lambda) const override;
  void majorants(const Vec3& o, const Vec3& d, double tmax, const SampledWavelengths& lambda,
                 const SegmentFn& fn) const override;
  /// pbrt-v4's CloudMedium::Density at the medium-space point p: five octaves (lacunarity 1.99)
  /// of Perlin noise at frequency * p, the lookup point first pushed along the noise gradient
  /// (two octaves, 0.05 wispiness and half that), times (1 - y) 4.5 density, clamped to [0, 1],
  /// plus 2 max(0, 0.5 - y), clamped to [0, 1].
  double density(const Vec3& p) const;

 private:
  Transform medium_from_world_;
  Vec3 p0_, p1_;
  SpectrumPtr sigma_a_, sigma_s_;
  double scale_ = 1, density_ = 1, wispiness_ = 1, frequency_ = 5;
};

/// pbrt-v4's NanoVDBMedium: the file's float grid "density" (trilinear in NanoVDB's index space,
/// voxel values at integer index coordinates, as NanoVDB's sampler and pbrt-v4 read it) scales
/// sigma_a, sigma_s; the optional float grid "temperature" T emits Le = Lescale B((T - offset)
/// scale), B the blackbody normalised to peak 1, none at or below 100 K. The medium's bounds are
/// the density grid's world bounding box (in medium space); majorants come from a 64^3 grid of
/// the largest voxel values that influence each cell (pbrt-v4's resolution and rule).
class NanoVDBMedium final : public Medium {
 public:
  /// Reads the file; throws lensim::Error at the medium for an unreadable file or a missing or
  /// non-float "density" grid.
  explicit NanoVDBMedium(const scene::Medium& desc);
  ~NanoVDBMedium() override;
  MediumProperties at(const Vec3& p, const SampledWavelengths& lambda) const override;
  void majorants(const Vec3& o, const Vec3& d, double tmax, const SampledWavelengths& lambda,
                 const SegmentFn& fn) const override;
  /// The interpolated density at a medium-space point (before scale).
  double density(const Vec3& p_medium) const;
  /// The majorant grid's resolution and its cells (largest density per cell, before scale).
  static constexpr int kRes = 64;
  const std::vector<double>& majorantCells() const { return majorant_; }

 private:
  struct Grids;
  std::unique_ptr<Grids> grids_;
  Transform medium_from_world_;
  Vec3 p0_, p1_;
  SpectrumPtr sigma_a_, sigma_s_;
  double scale_ = 1, Le_scale_ = 1, temperature_offset_ = 0, temperature_scale_ = 1;
  std::vector<double> majorant_;
};

}  // namespace lensim::render
