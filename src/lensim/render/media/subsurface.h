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

namespace lensim::scene {
struct Material;
}

namespace lensim::render {

/// The inside of a subsurface material: sigma_a, sigma_s (times scale) and g, or, from
/// `reflectance` and `mfp`, sigma_t = 1 / (scale mfp) and the single-scattering albedo whose
/// semi-infinite, index-matched, isotropic medium has that diffuse reflectance
/// (albedoForDiffuseReflectance).
class SubsurfaceMedium final : public Medium {
 public:
  explicit SubsurfaceMedium(const scene::Material& m);
  MediumProperties at(const Vec3& p, const SampledWavelengths& lambda) const override;
  void majorants(const Vec3& o, const Vec3& d, double tmax, const SampledWavelengths& lambda,
                 const SegmentFn& fn) const override;

 private:
  MediumProperties coefficients(const SampledWavelengths& lambda) const;
  SpectrumPtr sigma_a_, sigma_s_, reflectance_, mfp_;
  double scale_ = 1;
};

/// The diffuse (hemispherical-hemispherical) reflectance of a semi-infinite medium of
/// single-scattering albedo `albedo` with isotropic scattering and an index-matched boundary:
/// 1 - 2 sqrt(1 - albedo) int_0^1 H(mu) mu dmu, Chandrasekhar's H function (Radiative Transfer,
/// 1950, ch. 5) computed by iterating its integral equation.
double diffuseReflectanceOfAlbedo(double albedo);
/// The inverse of diffuseReflectanceOfAlbedo for r in [0, 1] (from a table, interpolated).
double albedoForDiffuseReflectance(double r);

}  // namespace lensim::render
