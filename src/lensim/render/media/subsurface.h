// pbrt-v4's "subsurface" material, rendered by a volumetric random walk instead of pbrt-v4's
// tabulated photon-beam-diffusion BSSRDF. Why: the walk is exact for any shape (thin parts, edges
// and concave regions, where a BSSRDF built for a semi-infinite flat slab is wrong), for any
// albedo and anisotropy, and needs no table or probe rays; its cost is more ray casts inside
// optically thick objects. The surface is a (rough) dielectric BSDF of `eta`; a path refracted
// into a shape whose material is subsurface travels in a homogeneous medium of the material's
// coefficients (SubsurfaceMedium) by the volpath integrator's delta tracking, until it leaves
// through the boundary. The shape must be closed, with normals facing out (as for pbrt media).
#pragma once

#include "lensim/render/media/media.h"
#include "lensim/render/textures/textures.h"

namespace lensim::scene {
struct SubsurfaceParams;
}

namespace lensim::render {

/// The inside of a subsurface material: sigma_a, sigma_s (times scale) and g, or, from
/// `reflectance` and `mfp`, sigma_t = 1 / (scale mfp) and the single-scattering albedo whose
/// semi-infinite, index-matched, isotropic medium has that diffuse reflectance
/// (albedoForDiffuseReflectance).
///
/// Textured coefficients (any of the four a spectrum texture): the integrator evaluates them by
/// coefficientsAt where a path enters the shape and runs that walk in a WalkMedium of those
/// constant coefficients, as pbrt-v4 evaluates its BSSRDF's coefficients at the entry point
/// (SubsurfaceMaterial::GetBSSRDF, src/pbrt/materials.h, called with the intersection where
/// the BSDF sample refracts in). at() and majorants() serve untextured materials only.
class SubsurfaceMedium final : public Medium {
 public:
  explicit SubsurfaceMedium(const scene::SubsurfaceParams& m);
  MediumProperties at(const Vec3& p, const SampledWavelengths& lambda) const override;
  void majorants(const Vec3& o, const Vec3& d, double tmax, const SampledWavelengths& lambda,
                 const SegmentFn& fn) const override;
  /// Some coefficient is a texture: walks need coefficientsAt and a WalkMedium.
  bool textured() const { return textured_; }
  /// The coefficients with the textures evaluated at ctx (the walk's entry point).
  MediumProperties coefficientsAt(const Textures& textures, const TextureEvalContext& ctx,
                                  const SampledWavelengths& lambda) const;

 private:
  MediumProperties coefficients(const SampledWavelengths& lambda) const;
  /// sigma_a, sigma_s from reflectance r and mean free path mfp (before scale) per wavelength.
  MediumProperties fromReflectance(const SampledSpectrum& r, const SampledSpectrum& mfp) const;
  SpectrumPtr sigma_a_, sigma_s_, reflectance_, mfp_;
  const scene::SubsurfaceParams* material_ = nullptr;  ///< the description (textured ones)
  bool from_reflectance_ = false, textured_ = false;
  double scale_ = 1;
};

/// A homogeneous medium of given coefficients: the inside of a textured subsurface material
/// for one random walk, with the coefficients evaluated where the walk entered.
class WalkMedium final : public Medium {
 public:
  void set(const MediumProperties& mp, double g) {
    mp_ = mp;
    sigma_t_ = mp.sigma_a + mp.sigma_s;
    g_ = g;
  }
  MediumProperties at(const Vec3&, const SampledWavelengths&) const override { return mp_; }
  void majorants(const Vec3&, const Vec3&, double tmax, const SampledWavelengths&,
                 const SegmentFn& fn) const override {
    fn(0, tmax, sigma_t_);
  }

 private:
  MediumProperties mp_;
  SampledSpectrum sigma_t_;
};

/// The diffuse (hemispherical-hemispherical) reflectance of a semi-infinite medium of
/// single-scattering albedo `albedo` with isotropic scattering and an index-matched boundary:
/// 1 - 2 sqrt(1 - albedo) int_0^1 H(mu) mu dmu, Chandrasekhar's H function (Radiative Transfer,
/// 1950, ch. 5) computed by iterating its integral equation.
double diffuseReflectanceOfAlbedo(double albedo);
/// The inverse of diffuseReflectanceOfAlbedo for r in [0, 1] (from a table, interpolated).
double albedoForDiffuseReflectance(double r);

}  // namespace lensim::render
