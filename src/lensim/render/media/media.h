// Participating media for the volpath integrator (pbrt-v4's media, Pharr, Jakob & Humphreys,
// 4th ed., ch. 11 and sec. 14.1): coefficients per scene unit at the path's wavelengths, majorant
// segments along a ray, and the Henyey-Greenstein phase function (render/layered.h).
//
// Units: sigma_a, sigma_s and the majorant in 1/scene unit (1/m); Le is radiance in the film's
// units (an RGB Le of (1,1,1) emitted over an optical depth of absorption 1 reads (1,1,1)).
#pragma once

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <vector>

#include "lensim/render/spectra/spectrum.h"
#include "lensim/util/transform.h"
#include "lensim/util/vec.h"

namespace lensim::scene {
struct Scene;
struct Medium;
}  // namespace lensim::scene

namespace lensim::render {

class SubsurfaceMedium;

/// Scattering properties at a point of a medium.
struct MediumProperties {
  SampledSpectrum sigma_a, sigma_s;  ///< absorption and scattering coefficients (1/m)
  SampledSpectrum Le;                ///< emitted radiance (emission is sigma_a Le per metre)
};

class Medium {
 public:
  virtual ~Medium() = default;
  /// Properties at world point p.
  virtual MediumProperties at(const Vec3& p, const SampledWavelengths& lambda) const = 0;
  /// Calls fn(t0, t1, sigma_maj) for consecutive intervals of the ray o + t d (d unit, t in
  /// [0, tmax)) in increasing order, sigma_maj bounding sigma_a + sigma_s over each, until fn
  /// returns false. Parts of the ray where the medium is zero may be left out.
  using SegmentFn = std::function<bool(double t0, double t1, const SampledSpectrum& sigma_maj)>;
  virtual void majorants(const Vec3& o, const Vec3& d, double tmax,
                         const SampledWavelengths& lambda, const SegmentFn& fn) const = 0;
  /// Henyey-Greenstein asymmetry.
  double g() const { return g_; }
  bool isEmissive() const { return emissive_; }

 protected:
  double g_ = 0;
  bool emissive_ = false;
};

/// pbrt-v4's "homogeneous": constant spectral sigma_a, sigma_s (times scale), Le (times
/// Lescale, normalised as light spectra are) and g. The majorant is sigma_t itself, so delta
/// tracking never takes a null collision.
class HomogeneousMedium final : public Medium {
 public:
  explicit HomogeneousMedium(const scene::Medium& desc);
  MediumProperties at(const Vec3& p, const SampledWavelengths& lambda) const override;
  void majorants(const Vec3& o, const Vec3& d, double tmax, const SampledWavelengths& lambda,
                 const SegmentFn& fn) const override;

 private:
  SpectrumPtr sigma_a_, sigma_s_, Le_;
  double scale_ = 1, Le_scale_ = 1;
};

/// Values on an nx x ny x nz grid over [0,1]^3 (x fastest), looked up as pbrt-v4's SampledGrid:
/// trilinear between voxel centres, zero beyond the outer centres' neighbours.
template <class T>
class SampledGrid {
 public:
  SampledGrid() = default;
  SampledGrid(std::vector<T> values, int nx, int ny, int nz)
      : v_(std::move(values)), nx_(nx), ny_(ny), nz_(nz) {}
  bool empty() const { return v_.empty(); }
  const T& at(int x, int y, int z) const { return v_[(size_t(z) * ny_ + y) * nx_ + x]; }
  /// convert(T) of the voxel (x, y, z), or convert(T{}) outside the grid.
  template <class F>
  auto voxel(int x, int y, int z, F convert) const {
    if (x < 0 || y < 0 || z < 0 || x >= nx_ || y >= ny_ || z >= nz_) return convert(T{});
    return convert(at(x, y, z));
  }
  /// The interpolated value at p in [0,1]^3.
  template <class F>
  auto lookup(const Vec3& p, F convert) const {
    const double sx = p.x * nx_ - 0.5, sy = p.y * ny_ - 0.5, sz = p.z * nz_ - 0.5;
    const int ix = int(std::floor(sx)), iy = int(std::floor(sy)), iz = int(std::floor(sz));
    const double dx = sx - ix, dy = sy - iy, dz = sz - iz;
    auto lerp = [](double t, const auto& a, const auto& b) { return a * (1 - t) + b * t; };
    const auto d00 = lerp(dx, voxel(ix, iy, iz, convert), voxel(ix + 1, iy, iz, convert));
    const auto d10 = lerp(dx, voxel(ix, iy + 1, iz, convert), voxel(ix + 1, iy + 1, iz, convert));
    const auto d01 = lerp(dx, voxel(ix, iy, iz + 1, convert), voxel(ix + 1, iy, iz + 1, convert));
    const auto d11 =
        lerp(dx, voxel(ix, iy + 1, iz + 1, convert), voxel(ix + 1, iy + 1, iz + 1, convert));
    return lerp(dz, lerp(dy, d00, d10), lerp(dy, d01, d11));
  }
  /// The largest convert(T) (a double) of the voxels that influence lookups in [lo, hi].
  template <class F>
  double maxValue(const Vec3& lo, const Vec3& hi, F convert) const {
    const int x0 = std::max(int(std::floor(lo.x * nx_ - 0.5)), 0);
    const int y0 = std::max(int(std::floor(lo.y * ny_ - 0.5)), 0);
    const int z0 = std::max(int(std::floor(lo.z * nz_ - 0.5)), 0);
    const int x1 = std::min(int(std::floor(hi.x * nx_ - 0.5)) + 1, nx_ - 1);
    const int y1 = std::min(int(std::floor(hi.y * ny_ - 0.5)) + 1, ny_ - 1);
    const int z1 = std::min(int(std::floor(hi.z * nz_ - 0.5)) + 1, nz_ - 1);
    double m = convert(at(x0, y0, z0));
    for (int z = z0; z <= z1; ++z)
      for (int y = y0; y <= y1; ++y)
        for (int x = x0; x <= x1; ++x) m = std::max(m, double(convert(at(x, y, z))));
    return m;
  }

 private:
  std::vector<T> v_;
  int nx_ = 0, ny_ = 0, nz_ = 0;
};

/// The media with voxel grids over a box [p0, p1] in medium space: pbrt-v4's "uniformgrid"
/// (a density grid scaling constant sigma_a, sigma_s; Le times an optional Lescale grid) and
/// "rgbgrid" (RGB sigma_a, sigma_s and Le per voxel). Majorants come from a 16^3 grid of the
/// largest voxel values over each cell, walked by a 3-D DDA along the ray (pbrt-v4's
/// DDAMajorantIterator), so delta tracking takes few null collisions in sparse grids.
class GridMedium final : public Medium {
 public:
  explicit GridMedium(const scene::Medium& desc);
  MediumProperties at(const Vec3& p, const SampledWavelengths& lambda) const override;
  void majorants(const Vec3& o, const Vec3& d, double tmax, const SampledWavelengths& lambda,
                 const SegmentFn& fn) const override;

 private:
  Vec3 toGrid(const Vec3& p) const;  ///< world -> [0,1]^3 of the bounds
  bool rgb_ = false;
  Transform medium_from_world_;
  Vec3 p0_, p1_;
  double scale_ = 1, Le_scale_ = 1;
  // uniformgrid
  SpectrumPtr sigma_a_, sigma_s_, Le_;
  SampledGrid<double> density_, Le_grid_;
  // rgbgrid: per-voxel spectra (null: the default, 1 for sigma, 0 for Le)
  SampledGrid<std::shared_ptr<const Spectrum>> sigma_a_grid_, sigma_s_grid_, Le_rgb_grid_;
  // majorants: per cell, max density (uniformgrid) or max sigma_a + sigma_s (rgbgrid)
  static constexpr int kRes = 16;
  std::vector<double> majorant_;
};

/// Walks the ray og + t dg in grid space (the unit cube [0,1]^3 over a medium's bounds; t in
/// [0, tmax)) through a res^3 grid of majorant cells (x fastest) by a 3-D DDA, calling
/// fn(t0, t1, sigma_t * cell) for each cell the ray crosses, in order.
void walkMajorantGrid(const Vec3& og, const Vec3& dg, double tmax, int res,
                      const std::vector<double>& cells, const SampledSpectrum& sigma_t,
                      const Medium::SegmentFn& fn);

/// The media of a scene, indexed as Scene::media (nullptr for types not rendered), followed by
/// one homogeneous medium per subsurface material (its inside, for the random walk).
class Media {
 public:
  explicit Media(const scene::Scene& scene);
  ~Media();
  /// The medium of index i (Scene::media), or nullptr for -1 (vacuum) and media left out.
  const Medium* get(int i) const { return i < 0 ? nullptr : media_[size_t(i)].get(); }
  /// No scene medium is rendered (subsurface interiors aside).
  bool empty() const { return !any_; }
  /// The medium inside shapes of subsurface material `material` (an index for get()), or -1.
  int subsurface(int material) const {
    return material < 0 || subsurface_.empty() ? -1 : subsurface_[size_t(material)];
  }
  /// Whether medium index i is a subsurface material's inside.
  bool isSubsurface(int i) const { return i >= n_scene_; }
  bool hasSubsurface() const { return has_subsurface_; }
  /// Medium index i as the inside of a subsurface material with textured coefficients (its
  /// walks need the coefficients at their entry point, SubsurfaceMedium::coefficientsAt), or
  /// nullptr.
  const SubsurfaceMedium* texturedSubsurface(int i) const {
    return i < n_scene_ || textured_.empty() ? nullptr : textured_[size_t(i - n_scene_)];
  }

 private:
  std::vector<std::unique_ptr<Medium>> media_;
  std::vector<int> subsurface_;                    ///< per material: its medium index, or -1
  std::vector<const SubsurfaceMedium*> textured_;  ///< per subsurface medium: textured, or null
  int n_scene_ = 0;
  bool any_ = false, has_subsurface_ = false;
};

}  // namespace lensim::render
