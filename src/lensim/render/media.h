// Participating media for the volpath integrator (pbrt-v4's media, Pharr, Jakob & Humphreys,
// 4th ed., ch. 11 and sec. 14.1): coefficients per scene unit at the path's wavelengths, majorant
// segments along a ray, and the Henyey-Greenstein phase function (render/layered.h).
//
// Units: sigma_a, sigma_s and the majorant in 1/scene unit (1/m); Le is radiance in the film's
// units (an RGB Le of (1,1,1) emitted over an optical depth of absorption 1 reads (1,1,1)).
#pragma once

#include <functional>
#include <memory>
#include <vector>

#include "lensim/render/spectrum.h"
#include "lensim/util/vec.h"

namespace lensim::scene {
struct Scene;
struct Medium;
}  // namespace lensim::scene

namespace lensim::render {

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
  /// Calls fn(t0, t1, sigma_maj) for consecutive intervals of the ray o + t d (d unit) covering
  /// [0, tmax), sigma_maj bounding sigma_a + sigma_s over each, until fn returns false.
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

/// The media of a scene, indexed as Scene::media (nullptr for types not rendered).
class Media {
 public:
  explicit Media(const scene::Scene& scene);
  ~Media();
  /// The medium of index i (Scene::media), or nullptr for -1 (vacuum) and media left out.
  const Medium* get(int i) const { return i < 0 ? nullptr : media_[size_t(i)].get(); }
  bool empty() const { return !any_; }

 private:
  std::vector<std::unique_ptr<Medium>> media_;
  bool any_ = false;
};

}  // namespace lensim::render
