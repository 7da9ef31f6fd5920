// pbrt-v3's materials rendered as pbrt-v3 defines them, instead of being mapped onto pbrt-v4's
// with losses: plastic, substrate, uber, translucent, glass (with its Kr/Kt tints), metal and
// mirror. Each is pbrt-v3's BSDF: a sum of lobes (Lambertian reflection and transmission,
// Trowbridge-Reitz microfacet reflection and transmission, specular reflection and transmission,
// Fresnel-weighted specular, Ashikhmin-Shirley's FresnelBlend), sampled as pbrt-v3's
// BSDF::Sample_f does (one matching lobe chosen uniformly, the pdf averaged over the matching
// non-specular lobes, f summed over them). Roughness is remapped by pbrt-v3's
// TrowbridgeReitzDistribution::RoughnessToAlpha (a polynomial in log roughness), not pbrt-v4's
// square root. Facts from pbrt-v3's src/materials/{plastic,substrate,uber,translucent,glass,metal,
// mirror}.cpp and src/core/{reflection,microfacet}.cpp; each place is cited beside its use.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "lensim/render/materials/bsdf.h"

namespace lensim::render {

/// pbrt-v3's FrDielectric(cos_theta_i, eta_i, eta_t) with its conventions: a negative cosine
/// swaps the indices; total internal reflection returns 1.
double frDielectricV3(double cos_theta_i, double eta_i, double eta_t);

/// pbrt-v3's TrowbridgeReitzDistribution::RoughnessToAlpha (roughness clamped to >= 1e-3).
double roughnessToAlphaV3(double roughness);

/// One lobe of a pbrt-v3 BSDF, in the shading frame.
struct V3Lobe {
  enum class Kind {
    LambertianReflection,
    LambertianTransmission,
    MicrofacetReflection,
    MicrofacetTransmission,
    SpecularReflection,
    SpecularTransmission,
    FresnelSpecular,
    FresnelBlend
  };
  enum class Fresnel { NoOp, Dielectric, Conductor };
  Kind kind = Kind::LambertianReflection;
  SampledSpectrum R{0.0}, T{0.0};  ///< reflection / transmission scale (FresnelBlend: Rd, Rs)
  double alpha_x = 0, alpha_y = 0;
  Fresnel fresnel = Fresnel::NoOp;
  double eta_i = 1, eta_t = 1.5;               ///< dielectric Fresnel and refraction indices
  SampledSpectrum cond_eta{1.0}, cond_k{0.0};  ///< conductor Fresnel

  BxDFFlags flags() const;
};

/// pbrt-v3's BSDF over a list of lobes.
class V3BSDF final : public BxDF {
 public:
  explicit V3BSDF(std::vector<V3Lobe> lobes);
  BxDFFlags flags() const override { return flags_; }
  SampledSpectrum f(const Vec3& wo, const Vec3& wi, TransportMode mode) const override;
  std::optional<BSDFSample> sample_f(const Vec3& wo, double uc, Vec2 u, TransportMode mode,
                                     ReflTrans allowed = ReflTrans::All) const override;
  double pdf(const Vec3& wo, const Vec3& wi, TransportMode mode,
             ReflTrans allowed = ReflTrans::All) const override;
  const std::vector<V3Lobe>& lobes() const { return lobes_; }

 private:
  std::vector<V3Lobe> lobes_;
  BxDFFlags flags_ = BxDFFlags::Unset;
};

}  // namespace lensim::render
