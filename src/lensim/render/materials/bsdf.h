// Scattering functions (BxDFs) in the local shading frame, over sampled spectra, with the
// semantics of pbrt-v4's materials.
//
// Frame: +z is the shading normal; wo (toward the viewer/previous vertex) and wi (toward the
// light/next vertex) are unit vectors pointing away from the surface. f is in sr^-1 (per unit
// projected solid angle, without the cosine), pdfs are per unit solid angle of wi.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>

#include "lensim/render/materials/microfacet.h"
#include "lensim/render/spectra/spectrum.h"
#include "lensim/util/vec.h"

namespace lensim::render {

/// What kind of scattering a BxDF or a sample is.
enum class BxDFFlags : unsigned {
  Unset = 0,
  Reflection = 1,
  Transmission = 2,
  Diffuse = 4,
  Glossy = 8,
  Specular = 16,
};
inline BxDFFlags operator|(BxDFFlags a, BxDFFlags b) {
  return static_cast<BxDFFlags>(static_cast<unsigned>(a) | static_cast<unsigned>(b));
}
inline bool any(BxDFFlags a, BxDFFlags b) {
  return (static_cast<unsigned>(a) & static_cast<unsigned>(b)) != 0;
}
inline bool isSpecular(BxDFFlags f) {
  return any(f, BxDFFlags::Specular);
}
inline bool isNonSpecular(BxDFFlags f) {
  return any(f, BxDFFlags::Diffuse | BxDFFlags::Glossy);
}

/// Which hemispheres a caller allows sample_f / pdf to choose.
enum class ReflTrans : unsigned { Reflection = 1, Transmission = 2, All = 3 };
inline bool allows(ReflTrans r, ReflTrans which) {
  return (static_cast<unsigned>(r) & static_cast<unsigned>(which)) != 0;
}

/// Whether the path carries radiance (camera paths) or importance (light paths); refraction
/// scales radiance by 1/eta^2 but not importance.
enum class TransportMode { Radiance, Importance };

/// A sampled direction: f (sr^-1), wi, pdf (sr^-1; a probability for specular samples), flags,
/// the relative index eta crossed (1 for reflection), and whether pdf is only proportional to
/// the true density (stochastic layered BxDFs): then f cos / pdf is still the right weight.
struct BSDFSample {
  SampledSpectrum f;
  Vec3 wi;
  double pdf = 0;
  BxDFFlags flags = BxDFFlags::Unset;
  double eta = 1;
  bool pdf_is_proportional = false;
  bool isReflection() const { return any(flags, BxDFFlags::Reflection); }
  bool isTransmission() const { return any(flags, BxDFFlags::Transmission); }
  bool isSpecular() const { return any(flags, BxDFFlags::Specular); }
};

/// A BxDF in the local shading frame.
class BxDF {
 public:
  virtual ~BxDF() = default;
  virtual BxDFFlags flags() const = 0;
  /// f(wo, wi), sr^-1; zero for specular BxDFs.
  virtual SampledSpectrum f(const Vec3& wo, const Vec3& wi, TransportMode mode) const = 0;
  /// Samples wi given wo with uc in [0,1) (lobe choice) and u in [0,1)^2; nullopt if no sample.
  virtual std::optional<BSDFSample> sample_f(const Vec3& wo, double uc, Vec2 u, TransportMode mode,
                                             ReflTrans allowed = ReflTrans::All) const = 0;
  /// Density of sample_f producing wi (sr^-1); zero for specular BxDFs.
  virtual double pdf(const Vec3& wo, const Vec3& wi, TransportMode mode,
                     ReflTrans allowed = ReflTrans::All) const = 0;
};

/// Fresnel reflectance of a dielectric interface for unpolarised light; cos_theta_i is taken on
/// the side of the normal the light arrives from (negative: from inside), eta = n_inside/n_outside.
double frDielectric(double cos_theta_i, double eta);
/// Fresnel reflectance of a conductor with complex index eta + i k (relative to the outside).
SampledSpectrum frComplex(double cos_theta_i, const SampledSpectrum& eta, const SampledSpectrum& k);
/// pbrt-v4's conductor "reflectance" parameterisation: with eta = 1, the absorption k whose
/// normal-incidence Fresnel reflectance k^2 / (4 + k^2) equals r (r in [0,1)), k = 2 sqrt(r/(1-r)).
SampledSpectrum conductorKFromReflectance(const SampledSpectrum& r);
/// Mirror reflection of wo about n.
inline Vec3 reflect(const Vec3& wo, const Vec3& n) {
  return -wo + n * (2 * dot(wo, n));
}
/// Refraction of wi through the interface with normal n and relative index eta; nullopt on total
/// internal reflection. etap is the index ratio actually crossed (eta or 1/eta).
struct Refraction {
  Vec3 wt;
  double etap;
};
std::optional<Refraction> refract(const Vec3& wi, Vec3 n, double eta);

/// "diffuse": Lambertian reflection, f = R / pi.
class DiffuseBxDF final : public BxDF {
 public:
  explicit DiffuseBxDF(const SampledSpectrum& r) : r_(r) {}
  BxDFFlags flags() const override;
  SampledSpectrum f(const Vec3& wo, const Vec3& wi, TransportMode mode) const override;
  std::optional<BSDFSample> sample_f(const Vec3& wo, double uc, Vec2 u, TransportMode mode,
                                     ReflTrans allowed = ReflTrans::All) const override;
  double pdf(const Vec3& wo, const Vec3& wi, TransportMode mode,
             ReflTrans allowed = ReflTrans::All) const override;

 private:
  SampledSpectrum r_;
};

/// Oren-Nayar rough diffuse reflection (the qualitative model of Oren & Nayar 1994, as pbrt's
/// legacy "matte" with sigma), sigma = standard deviation of facet slope angle in degrees.
class OrenNayarBxDF final : public BxDF {
 public:
  OrenNayarBxDF(const SampledSpectrum& r, double sigma_deg);
  BxDFFlags flags() const override;
  SampledSpectrum f(const Vec3& wo, const Vec3& wi, TransportMode mode) const override;
  std::optional<BSDFSample> sample_f(const Vec3& wo, double uc, Vec2 u, TransportMode mode,
                                     ReflTrans allowed = ReflTrans::All) const override;
  double pdf(const Vec3& wo, const Vec3& wi, TransportMode mode,
             ReflTrans allowed = ReflTrans::All) const override;

 private:
  SampledSpectrum r_;
  double a_, b_;
};

/// "diffusetransmission": Lambertian reflection R / pi and transmission T / pi.
class DiffuseTransmissionBxDF final : public BxDF {
 public:
  DiffuseTransmissionBxDF(const SampledSpectrum& r, const SampledSpectrum& t) : r_(r), t_(t) {}
  BxDFFlags flags() const override;
  SampledSpectrum f(const Vec3& wo, const Vec3& wi, TransportMode mode) const override;
  std::optional<BSDFSample> sample_f(const Vec3& wo, double uc, Vec2 u, TransportMode mode,
                                     ReflTrans allowed = ReflTrans::All) const override;
  double pdf(const Vec3& wo, const Vec3& wi, TransportMode mode,
             ReflTrans allowed = ReflTrans::All) const override;

 private:
  SampledSpectrum r_, t_;
};

/// "conductor": Fresnel reflection with complex index eta + i k, smooth (specular) or
/// Trowbridge-Reitz rough (Torrance-Sparrow with height-correlated Smith G), sampled from the
/// visible normals.
class ConductorBxDF final : public BxDF {
 public:
  ConductorBxDF(const TrowbridgeReitz& distrib, const SampledSpectrum& eta,
                const SampledSpectrum& k)
      : distrib_(distrib), eta_(eta), k_(k) {}
  BxDFFlags flags() const override;
  SampledSpectrum f(const Vec3& wo, const Vec3& wi, TransportMode mode) const override;
  std::optional<BSDFSample> sample_f(const Vec3& wo, double uc, Vec2 u, TransportMode mode,
                                     ReflTrans allowed = ReflTrans::All) const override;
  double pdf(const Vec3& wo, const Vec3& wi, TransportMode mode,
             ReflTrans allowed = ReflTrans::All) const override;

 private:
  TrowbridgeReitz distrib_;
  SampledSpectrum eta_, k_;
};

/// "dielectric": Fresnel reflection and refraction with relative index eta (inside/outside,
/// inside is -z), smooth or rough (Walter et al. 2007 with the generalised half vector).
/// Transmitted radiance is scaled by 1/eta'^2 in Radiance mode.
class DielectricBxDF final : public BxDF {
 public:
  DielectricBxDF(double eta, const TrowbridgeReitz& distrib) : eta_(eta), distrib_(distrib) {}
  BxDFFlags flags() const override;
  double eta() const { return eta_; }
  SampledSpectrum f(const Vec3& wo, const Vec3& wi, TransportMode mode) const override;
  std::optional<BSDFSample> sample_f(const Vec3& wo, double uc, Vec2 u, TransportMode mode,
                                     ReflTrans allowed = ReflTrans::All) const override;
  double pdf(const Vec3& wo, const Vec3& wi, TransportMode mode,
             ReflTrans allowed = ReflTrans::All) const override;

 private:
  double eta_;
  TrowbridgeReitz distrib_;
};

/// "thindielectric": a thin slab with index eta, all internal reflections summed
/// (R' = R + T^2 R / (1 - R^2)); light passes straight through without bending.
class ThinDielectricBxDF final : public BxDF {
 public:
  explicit ThinDielectricBxDF(double eta) : eta_(eta) {}
  BxDFFlags flags() const override;
  SampledSpectrum f(const Vec3&, const Vec3&, TransportMode) const override { return {}; }
  std::optional<BSDFSample> sample_f(const Vec3& wo, double uc, Vec2 u, TransportMode mode,
                                     ReflTrans allowed = ReflTrans::All) const override;
  double pdf(const Vec3&, const Vec3&, TransportMode, ReflTrans) const override { return 0; }

 private:
  double eta_;
};

}  // namespace lensim::render

namespace lensim::render {

/// An orthonormal frame (x, y, z) in render space; z is the shading normal.
struct Frame {
  Vec3 x{1, 0, 0}, y{0, 1, 0}, z{0, 0, 1};
  /// The frame with normal n (unit) and x along the part of dpdu perpendicular to n; any
  /// perpendicular x when dpdu is parallel to n or zero.
  static Frame fromNormalAndTangent(const Vec3& n, const Vec3& dpdu);
  Vec3 toLocal(const Vec3& v) const { return {dot(v, x), dot(v, y), dot(v, z)}; }
  Vec3 fromLocal(const Vec3& v) const { return x * v.x + y * v.y + z * v.z; }
};

/// A BxDF placed at a surface point: converts render-space directions to the local shading
/// frame and back. Directions are unit vectors pointing away from the surface.
class BSDF {
 public:
  BSDF() = default;
  /// ns: shading normal (unit, render space); dpdus: shading tangent (render space).
  BSDF(const Vec3& ns, const Vec3& dpdus, std::shared_ptr<const BxDF> bxdf);
  explicit operator bool() const { return static_cast<bool>(bxdf_); }
  BxDFFlags flags() const { return bxdf_->flags(); }
  const Frame& frame() const { return frame_; }
  /// f (sr^-1) for render-space wo, wi; zero when wo is exactly tangent.
  SampledSpectrum f(const Vec3& wo_render, const Vec3& wi_render,
                    TransportMode mode = TransportMode::Radiance) const;
  /// A sample with wi in render space; nullopt when the BxDF gives none or a useless one
  /// (zero f or pdf, wi tangent).
  std::optional<BSDFSample> sample_f(const Vec3& wo_render, double uc, Vec2 u,
                                     TransportMode mode = TransportMode::Radiance,
                                     ReflTrans allowed = ReflTrans::All) const;
  double pdf(const Vec3& wo_render, const Vec3& wi_render,
             TransportMode mode = TransportMode::Radiance,
             ReflTrans allowed = ReflTrans::All) const;

 private:
  std::shared_ptr<const BxDF> bxdf_;
  Frame frame_;
};

}  // namespace lensim::render
