#include "lensim/render/materials/v3materials.h"

#include <algorithm>
#include <cmath>

#include "lensim/render/materials/bxdf_arena.h"
#include "lensim/render/materials/material_eval.h"
#include "lensim/render/materials/microfacet.h"
#include "lensim/sampling/sampling.h"

namespace lensim::render {

using namespace lensim::sampling;

namespace {

constexpr double kInvPi = 1 / kPi;

// pbrt-v3 Refract (src/core/reflection.h): n on wi's side; false on total internal reflection.
bool refractV3(const Vec3& wi, const Vec3& n, double eta, Vec3& wt) {
  const double cos_i = dot(n, wi);
  const double sin2_i = std::max(0.0, 1 - cos_i * cos_i);
  const double sin2_t = eta * eta * sin2_i;
  if (sin2_t >= 1) return false;
  const double cos_t = std::sqrt(1 - sin2_t);
  wt = -wi * eta + n * (eta * cos_i - cos_t);
  return true;
}

SampledSpectrum fresnel(const V3Lobe& l, double cos_i) {
  switch (l.fresnel) {
    case V3Lobe::Fresnel::NoOp:
      return SampledSpectrum(1.0);
    case V3Lobe::Fresnel::Dielectric:
      return SampledSpectrum(frDielectricV3(cos_i, l.eta_i, l.eta_t));
    case V3Lobe::Fresnel::Conductor:
      return frComplex(std::abs(cos_i), l.cond_eta, l.cond_k);
  }
  return SampledSpectrum(1.0);
}

// The visible-normal density pbrt-v3 uses (TrowbridgeReitzDistribution::Pdf with
// sampleVisibleArea): D(wh) G1(wo) |wo.wh| / |cos wo|, symmetric under flipping both.
double pdfWh(const TrowbridgeReitz& d, const Vec3& wo, const Vec3& wh) {
  const double c = absCosTheta(wo);
  if (c == 0) return 0;
  return d.D(wh) * d.G1(wo) * std::abs(dot(wo, wh)) / c;
}

// TrowbridgeReitzDistribution::Sample_wh: visible normals of the flipped direction when wo is
// below the surface.
Vec3 sampleWh(const TrowbridgeReitz& d, const Vec3& wo, Vec2 u) {
  const bool flip = wo.z < 0;
  const Vec3 wh = d.sampleWm(flip ? -wo : wo, u);
  return flip ? -wh : wh;
}

// Refraction through a microfacet that faces away from wo or wi cannot happen (pbrt-v4 discards
// it: DielectricBxDF::f/PDF, src/pbrt/bxdfs.cpp); pbrt-v3's MicrofacetTransmission::f and ::Pdf
// do not, so they give such pairs a density its sampling never produces (its pdf then
// integrates to more than 1, +6.5% at cos theta_o = 0.3 with alpha 0.3). Discarded here so that
// f, pdf and sampling agree; wh is the upward half vector.
bool backFacing(const Vec3& wh, const Vec3& wo, const Vec3& wi) {
  return dot(wh, wi) * cosTheta(wi) < 0 || dot(wh, wo) * cosTheta(wo) < 0;
}

double pow5(double v) {
  return (v * v) * (v * v) * v;
}

// ---- the lobes (pbrt-v3 src/core/reflection.cpp) --------------------------------------------

SampledSpectrum lobeF(const V3Lobe& l, const Vec3& wo, const Vec3& wi, TransportMode mode) {
  using K = V3Lobe::Kind;
  switch (l.kind) {
    case K::LambertianReflection:
      return l.R * kInvPi;
    case K::LambertianTransmission:
      return l.T * kInvPi;
    case K::MicrofacetReflection: {
      const double co = absCosTheta(wo), ci = absCosTheta(wi);
      Vec3 wh = wi + wo;
      if (ci == 0 || co == 0 || (wh.x == 0 && wh.y == 0 && wh.z == 0)) return {};
      wh = normalize(wh);
      const TrowbridgeReitz d(l.alpha_x, l.alpha_y);
      const Vec3 whf = wh.z < 0 ? -wh : wh;  // Faceforward(wh, (0, 0, 1))
      return l.R * fresnel(l, dot(wi, whf)) * (d.D(wh) * d.G(wo, wi) / (4 * ci * co));
    }
    case K::MicrofacetTransmission: {
      if (sameHemisphere(wo, wi)) return {};
      const double co = cosTheta(wo), ci = cosTheta(wi);
      if (ci == 0 || co == 0) return {};
      const double eta = co > 0 ? l.eta_t / l.eta_i : l.eta_i / l.eta_t;
      Vec3 wh = normalize(wo + wi * eta);
      if (wh.z < 0) wh = -wh;
      if (dot(wo, wh) * dot(wi, wh) > 0 || backFacing(wh, wo, wi)) return {};
      const SampledSpectrum F(frDielectricV3(dot(wo, wh), l.eta_i, l.eta_t));
      const double sqrt_denom = dot(wo, wh) + eta * dot(wi, wh);
      const double factor = mode == TransportMode::Radiance ? 1 / eta : 1;
      const TrowbridgeReitz d(l.alpha_x, l.alpha_y);
      return (SampledSpectrum(1.0) - F) * l.T *
             std::abs(d.D(wh) * d.G(wo, wi) * eta * eta * std::abs(dot(wi, wh)) *
                      std::abs(dot(wo, wh)) * factor * factor /
                      (ci * co * sqrt_denom * sqrt_denom));
    }
    case K::FresnelBlend: {
      // Ashikhmin & Shirley's model as pbrt-v3 writes it: Rd in l.R, Rs in l.T.
      const SampledSpectrum& rd = l.R;
      const SampledSpectrum& rs = l.T;
      const SampledSpectrum diffuse = rd * (SampledSpectrum(1.0) - rs) *
                                      (28.0 / (23.0 * kPi) * (1 - pow5(1 - 0.5 * absCosTheta(wi))) *
                                       (1 - pow5(1 - 0.5 * absCosTheta(wo))));
      Vec3 wh = wi + wo;
      if (wh.x == 0 && wh.y == 0 && wh.z == 0) return {};
      wh = normalize(wh);
      const TrowbridgeReitz d(l.alpha_x, l.alpha_y);
      const double denom = 4 * std::abs(dot(wi, wh)) * std::max(absCosTheta(wi), absCosTheta(wo));
      if (denom == 0) return diffuse;
      const SampledSpectrum schlick = rs + (SampledSpectrum(1.0) - rs) * pow5(1 - dot(wi, wh));
      return diffuse + schlick * (d.D(wh) / denom);
    }
    default:
      return {};  // specular lobes: no density
  }
}

double lobePdf(const V3Lobe& l, const Vec3& wo, const Vec3& wi) {
  using K = V3Lobe::Kind;
  switch (l.kind) {
    case K::LambertianReflection:
      return sameHemisphere(wo, wi) ? absCosTheta(wi) * kInvPi : 0;
    case K::LambertianTransmission:
      return !sameHemisphere(wo, wi) ? absCosTheta(wi) * kInvPi : 0;
    case K::MicrofacetReflection: {
      if (!sameHemisphere(wo, wi)) return 0;
      const Vec3 wh = normalize(wo + wi);
      const double c = dot(wo, wh);
      if (c <= 0) return 0;
      return pdfWh(TrowbridgeReitz(l.alpha_x, l.alpha_y), wo, wh) / (4 * c);
    }
    case K::MicrofacetTransmission: {
      if (sameHemisphere(wo, wi) || wo.z == 0 || wi.z == 0) return 0;
      const double eta = cosTheta(wo) > 0 ? l.eta_t / l.eta_i : l.eta_i / l.eta_t;
      Vec3 wh = normalize(wo + wi * eta);
      if (wh.z < 0) wh = -wh;
      if (dot(wo, wh) * dot(wi, wh) > 0 || backFacing(wh, wo, wi)) return 0;
      const double sqrt_denom = dot(wo, wh) + eta * dot(wi, wh);
      const double dwh_dwi = std::abs(eta * eta * dot(wi, wh) / (sqrt_denom * sqrt_denom));
      return pdfWh(TrowbridgeReitz(l.alpha_x, l.alpha_y), wo, wh) * dwh_dwi;
    }
    case K::FresnelBlend: {
      if (!sameHemisphere(wo, wi)) return 0;
      const Vec3 wh = normalize(wo + wi);
      const double c = dot(wo, wh);
      const double spec =
          c > 0 ? pdfWh(TrowbridgeReitz(l.alpha_x, l.alpha_y), wo, wh) / (4 * c) : 0;
      return 0.5 * (absCosTheta(wi) * kInvPi + spec);
    }
    default:
      return 0;
  }
}

std::optional<BSDFSample> lobeSample(const V3Lobe& l, const Vec3& wo, double uc, Vec2 u,
                                     TransportMode mode) {
  using K = V3Lobe::Kind;
  BSDFSample s;
  s.flags = l.flags();
  switch (l.kind) {
    case K::LambertianReflection:
    case K::LambertianTransmission: {
      Vec3 wi = sampleCosineHemisphere(u);
      const bool trans = l.kind == K::LambertianTransmission;
      if ((!trans && wo.z < 0) || (trans && wo.z > 0)) wi.z = -wi.z;
      s.wi = wi;
      break;
    }
    case K::MicrofacetReflection: {
      if (wo.z == 0) return std::nullopt;
      const Vec3 wh = sampleWh(TrowbridgeReitz(l.alpha_x, l.alpha_y), wo, u);
      if (dot(wo, wh) < 0) return std::nullopt;
      s.wi = reflect(wo, wh);
      if (!sameHemisphere(wo, s.wi)) return std::nullopt;
      break;
    }
    case K::MicrofacetTransmission: {
      if (wo.z == 0) return std::nullopt;
      const Vec3 wh = sampleWh(TrowbridgeReitz(l.alpha_x, l.alpha_y), wo, u);
      if (dot(wo, wh) < 0) return std::nullopt;
      const double eta = cosTheta(wo) > 0 ? l.eta_i / l.eta_t : l.eta_t / l.eta_i;
      if (!refractV3(wo, wh, eta, s.wi)) return std::nullopt;
      s.eta = 1 / eta;
      break;
    }
    case K::FresnelBlend: {
      if (uc < 0.5) {
        Vec3 wi = sampleCosineHemisphere(u);
        if (wo.z < 0) wi.z = -wi.z;
        s.wi = wi;
      } else {
        const Vec3 wh = sampleWh(TrowbridgeReitz(l.alpha_x, l.alpha_y), wo, u);
        s.wi = reflect(wo, wh);
        if (!sameHemisphere(wo, s.wi)) return std::nullopt;
      }
      break;
    }
    case K::SpecularReflection: {
      s.wi = {-wo.x, -wo.y, wo.z};
      if (s.wi.z == 0) return std::nullopt;
      s.pdf = 1;
      s.f = fresnel(l, cosTheta(s.wi)) * l.R / absCosTheta(s.wi);
      return s;
    }
    case K::SpecularTransmission:
    case K::FresnelSpecular: {
      if (wo.z == 0) return std::nullopt;
      const double F = frDielectricV3(cosTheta(wo), l.eta_i, l.eta_t);
      if (l.kind == K::FresnelSpecular && uc < F) {
        s.wi = {-wo.x, -wo.y, wo.z};
        s.pdf = F;
        s.f = l.R * (F / absCosTheta(s.wi));
        s.flags = BxDFFlags::Reflection | BxDFFlags::Specular;
        return s;
      }
      const bool entering = cosTheta(wo) > 0;
      const double ei = entering ? l.eta_i : l.eta_t, et = entering ? l.eta_t : l.eta_i;
      if (!refractV3(wo, Vec3(0, 0, entering ? 1 : -1), ei / et, s.wi)) return std::nullopt;
      // SpecularTransmission evaluates its Fresnel at the transmitted direction, FresnelSpecular
      // at wo; both are the interface's transmittance 1 - F.
      const double Ft =
          l.kind == K::FresnelSpecular ? F : frDielectricV3(cosTheta(s.wi), l.eta_i, l.eta_t);
      SampledSpectrum ft = l.T * (1 - Ft);
      if (mode == TransportMode::Radiance) ft *= (ei * ei) / (et * et);
      s.pdf = l.kind == K::FresnelSpecular ? 1 - F : 1;
      s.f = ft / absCosTheta(s.wi);
      s.eta = et / ei;
      s.flags = BxDFFlags::Transmission | BxDFFlags::Specular;
      return s;
    }
  }
  s.pdf = lobePdf(l, wo, s.wi);
  if (s.pdf == 0) return std::nullopt;
  s.f = lobeF(l, wo, s.wi, mode);
  return s;
}

bool matches(const V3Lobe& l, ReflTrans allowed) {
  const BxDFFlags f = l.flags();
  return (any(f, BxDFFlags::Reflection) && allows(allowed, ReflTrans::Reflection)) ||
         (any(f, BxDFFlags::Transmission) && allows(allowed, ReflTrans::Transmission));
}

}  // namespace

double frDielectricV3(double cos_i, double eta_i, double eta_t) {
  cos_i = std::clamp(cos_i, -1.0, 1.0);
  if (!(cos_i > 0)) {
    std::swap(eta_i, eta_t);
    cos_i = std::abs(cos_i);
  }
  const double sin_i = std::sqrt(std::max(0.0, 1 - cos_i * cos_i));
  const double sin_t = eta_i / eta_t * sin_i;
  if (sin_t >= 1) return 1;
  const double cos_t = std::sqrt(std::max(0.0, 1 - sin_t * sin_t));
  const double r_parl = (eta_t * cos_i - eta_i * cos_t) / (eta_t * cos_i + eta_i * cos_t);
  const double r_perp = (eta_i * cos_i - eta_t * cos_t) / (eta_i * cos_i + eta_t * cos_t);
  return (r_parl * r_parl + r_perp * r_perp) / 2;
}

double roughnessToAlphaV3(double roughness) {
  // pbrt-v3 src/core/microfacet.h: TrowbridgeReitzDistribution::RoughnessToAlpha.
  const double x = std::log(std::max(roughness, 1e-3));
  return 1.62142 + 0.819955 * x + 0.1734 * x * x + 0.0171201 * x * x * x +
         0.000640711 * x * x * x * x;
}

BxDFFlags V3Lobe::flags() const {
  using K = Kind;
  switch (kind) {
    case K::LambertianReflection:
      return BxDFFlags::Reflection | BxDFFlags::Diffuse;
    case K::LambertianTransmission:
      return BxDFFlags::Transmission | BxDFFlags::Diffuse;
    case K::MicrofacetReflection:
    case K::FresnelBlend:
      return BxDFFlags::Reflection | BxDFFlags::Glossy;
    case K::MicrofacetTransmission:
      return BxDFFlags::Transmission | BxDFFlags::Glossy;
    case K::SpecularReflection:
      return BxDFFlags::Reflection | BxDFFlags::Specular;
    case K::SpecularTransmission:
      return BxDFFlags::Transmission | BxDFFlags::Specular;
    case K::FresnelSpecular:
      return BxDFFlags::Reflection | BxDFFlags::Transmission | BxDFFlags::Specular;
  }
  return BxDFFlags::Unset;
}

V3BSDF::V3BSDF(std::vector<V3Lobe> lobes) : lobes_(std::move(lobes)) {
  for (const V3Lobe& l : lobes_) flags_ = flags_ | l.flags();
}

// pbrt-v3 BSDF::f (src/core/reflection.cpp): the non-specular lobes of the side wi is on (the
// shading normal decides the side here; pbrt-v3 asks the geometric normal).
SampledSpectrum V3BSDF::f(const Vec3& wo, const Vec3& wi, TransportMode mode) const {
  if (wo.z == 0) return {};
  const bool reflect = sameHemisphere(wo, wi);
  SampledSpectrum f;
  for (const V3Lobe& l : lobes_) {
    const BxDFFlags fl = l.flags();
    if (isSpecular(fl)) continue;
    if ((reflect && any(fl, BxDFFlags::Reflection)) ||
        (!reflect && any(fl, BxDFFlags::Transmission)))
      f += lobeF(l, wo, wi, mode);
  }
  return f;
}

// pbrt-v3 BSDF::Sample_f: a matching lobe chosen uniformly; for a non-specular choice the pdf is
// the mean over the matching lobes and f the sum over the lobes of wi's side.
std::optional<BSDFSample> V3BSDF::sample_f(const Vec3& wo, double uc, Vec2 u, TransportMode mode,
                                           ReflTrans allowed) const {
  int n = 0;
  for (const V3Lobe& l : lobes_) n += matches(l, allowed);
  if (n == 0 || wo.z == 0) return std::nullopt;
  const int comp = std::min(int(uc * n), n - 1);
  const double uc2 = std::min(uc * n - comp, 1 - 1e-16);
  const V3Lobe* chosen = nullptr;
  for (int i = 0, k = 0; i < int(lobes_.size()); ++i)
    if (matches(lobes_[size_t(i)], allowed) && k++ == comp) chosen = &lobes_[size_t(i)];
  auto s = lobeSample(*chosen, wo, uc2, u, mode);
  if (!s || s->pdf == 0) return std::nullopt;
  if (!s->isSpecular()) {
    for (const V3Lobe& l : lobes_)
      if (&l != chosen && matches(l, allowed)) s->pdf += lobePdf(l, wo, s->wi);
    const bool reflect = sameHemisphere(wo, s->wi);
    s->f = {};
    for (const V3Lobe& l : lobes_) {
      const BxDFFlags fl = l.flags();
      if (isSpecular(fl) || !matches(l, allowed)) continue;
      if ((reflect && any(fl, BxDFFlags::Reflection)) ||
          (!reflect && any(fl, BxDFFlags::Transmission)))
        s->f += lobeF(l, wo, s->wi, mode);
    }
    s->flags = (reflect ? BxDFFlags::Reflection : BxDFFlags::Transmission) |
               (any(flags_, BxDFFlags::Diffuse) ? BxDFFlags::Diffuse : BxDFFlags::Glossy);
  }
  if (n > 1) s->pdf /= n;
  if (s->wi.z == 0) return std::nullopt;
  return s;
}

double V3BSDF::pdf(const Vec3& wo, const Vec3& wi, TransportMode, ReflTrans allowed) const {
  int n = 0;
  double p = 0;
  for (const V3Lobe& l : lobes_)
    if (matches(l, allowed)) {
      ++n;
      p += lobePdf(l, wo, wi);
    }
  return n ? p / n : 0;
}

// ---- materials ----------------------------------------------------------------------------

namespace {

// Builds a pbrt-v3 BSDF lobe by lobe from a material's inputs at the point.
struct V3Lobes {
  const MaterialEvalContext& c;
  std::vector<V3Lobe> lobes;
  using K = V3Lobe::Kind;
  using F = V3Lobe::Fresnel;

  SampledSpectrum albedo(const scene::Input& in) const { return c.albedo(in); }
  static SampledSpectrum clamp01(SampledSpectrum s) {
    for (int i = 0; i < kSpectrumSamples; ++i) s[i] = std::clamp(s[i], 0.0, 1.0);
    return s;
  }
  /// A float eta (pbrt-v3 has no spectral one); 1.5 when not positive.
  double floatEta(const scene::Input& eta) const {
    const double e = eta.texture >= 0 ? c.evalFloat(eta) : eta.value;
    return e > 0 ? e : 1.5;
  }
  void alphas(V3Lobe& l, const scene::Roughness& r) const {
    double u = c.evalFloat(r.u), v = c.evalFloat(r.v);
    if (r.remap) u = roughnessToAlphaV3(u), v = roughnessToAlphaV3(v);
    l.alpha_x = c.regularized(std::max(u, 1e-4));
    l.alpha_y = c.regularized(std::max(v, 1e-4));
  }
  void lambert(const SampledSpectrum& r, bool transmit) {
    if (r.isBlack()) return;
    V3Lobe l;
    l.kind = transmit ? K::LambertianTransmission : K::LambertianReflection;
    (transmit ? l.T : l.R) = r;
    lobes.push_back(l);
  }
  void microfacet(const SampledSpectrum& s, bool transmit, double eta_i, double eta_t,
                  const scene::Roughness& r) {
    if (s.isBlack()) return;
    V3Lobe l;
    l.kind = transmit ? K::MicrofacetTransmission : K::MicrofacetReflection;
    (transmit ? l.T : l.R) = s;
    l.fresnel = F::Dielectric;
    l.eta_i = eta_i, l.eta_t = eta_t;
    alphas(l, r);
    lobes.push_back(l);
  }
  void specular(const SampledSpectrum& s, bool transmit, F fr, double eta_t) {
    if (s.isBlack()) return;
    V3Lobe l;
    l.kind = transmit ? K::SpecularTransmission : K::SpecularReflection;
    (transmit ? l.T : l.R) = s;
    l.fresnel = fr;
    l.eta_i = 1, l.eta_t = eta_t;
    lobes.push_back(l);
  }
  std::shared_ptr<const BxDF> bsdf() { return makeBxDF<V3BSDF>(std::move(lobes)); }
};

}  // namespace

// plastic.cpp: Lambertian(Kd) + MicrofacetReflection(Ks, FresnelDielectric(1.5, 1)).
std::shared_ptr<const BxDF> bxdfOf(const scene::PlasticParams& p, const MaterialEvalContext& c) {
  V3Lobes b{c, {}};
  b.lambert(b.albedo(p.kd), false);
  b.microfacet(b.albedo(p.ks), false, 1.5, 1.0, p.roughness);
  return b.bsdf();
}

// substrate.cpp: FresnelBlend(Kd, Ks, TrowbridgeReitz(u, v)).
std::shared_ptr<const BxDF> bxdfOf(const scene::SubstrateParams& p, const MaterialEvalContext& c) {
  V3Lobes b{c, {}};
  const SampledSpectrum d = b.albedo(p.kd), s = b.albedo(p.ks);
  if (!d.isBlack() || !s.isBlack()) {
    V3Lobe l;
    l.kind = V3Lobe::Kind::FresnelBlend;
    l.R = d, l.T = s;
    b.alphas(l, p.roughness);
    b.lobes.push_back(l);
  }
  return b.bsdf();
}

// uber.cpp: (1 - opacity) passes straight through; the rest is op * (Kd Lambertian, Ks
// microfacet and Kr specular reflection with FresnelDielectric(1, eta), Kt specular
// transmission).
std::shared_ptr<const BxDF> bxdfOf(const scene::UberParams& p, const MaterialEvalContext& c) {
  using F = V3Lobe::Fresnel;
  V3Lobes b{c, {}};
  const double eta = b.floatEta(p.eta);
  const SampledSpectrum op = V3Lobes::clamp01(b.albedo(p.opacity));
  b.specular(V3Lobes::clamp01(SampledSpectrum(1.0) - op), true, F::Dielectric, 1.0);
  b.lambert(op * b.albedo(p.kd), false);
  b.microfacet(op * b.albedo(p.ks), false, 1.0, eta, p.roughness);
  b.specular(op * b.albedo(p.kr), false, F::Dielectric, eta);
  b.specular(op * b.albedo(p.kt), true, F::Dielectric, eta);
  return b.bsdf();
}

// translucent.cpp: reflect x (Kd Lambertian, Ks microfacet), transmit x (Kd Lambertian
// transmission, Ks microfacet transmission), eta 1.5.
std::shared_ptr<const BxDF> bxdfOf(const scene::TranslucentParams& p,
                                   const MaterialEvalContext& c) {
  V3Lobes b{c, {}};
  const SampledSpectrum r = b.albedo(p.reflect), t = b.albedo(p.transmit);
  const SampledSpectrum kd = b.albedo(p.kd), ks = b.albedo(p.ks);
  if (!r.isBlack() || !t.isBlack()) {
    b.lambert(r * kd, false);
    b.lambert(t * kd, true);
    b.microfacet(r * ks, false, 1.0, 1.5, p.roughness);
    b.microfacet(t * ks, true, 1.0, 1.5, p.roughness);
  }
  return b.bsdf();
}

// glass.cpp: smooth: FresnelSpecular(Kr, Kt, 1, eta); rough: microfacet reflection and
// transmission, scaled by Kr and Kt.
std::shared_ptr<const BxDF> bxdfOf(const scene::GlassParams& p, const MaterialEvalContext& c) {
  V3Lobes b{c, {}};
  const double eta = b.floatEta(p.eta);
  const SampledSpectrum R = b.albedo(p.kr), T = b.albedo(p.kt);
  const bool smooth = c.evalFloat(p.roughness.u) == 0 && c.evalFloat(p.roughness.v) == 0;
  if (smooth && !c.regularize) {
    if (!R.isBlack() || !T.isBlack()) {
      V3Lobe l;
      l.kind = V3Lobe::Kind::FresnelSpecular;
      l.R = R, l.T = T;
      l.fresnel = V3Lobe::Fresnel::Dielectric;
      l.eta_i = 1, l.eta_t = eta;
      b.lobes.push_back(l);
    }
  } else {
    b.microfacet(R, false, 1.0, eta, p.roughness);
    b.microfacet(T, true, 1.0, eta, p.roughness);
  }
  return b.bsdf();
}

// metal.cpp: MicrofacetReflection(1, FresnelConductor(1, eta, k)).
std::shared_ptr<const BxDF> bxdfOf(const scene::MetalParams& p, const MaterialEvalContext& c) {
  V3Lobes b{c, {}};
  V3Lobe l;
  l.kind = V3Lobe::Kind::MicrofacetReflection;
  l.R = SampledSpectrum(1.0);
  l.fresnel = V3Lobe::Fresnel::Conductor;
  l.cond_eta = c.unbounded(p.eta);
  l.cond_k = c.unbounded(p.k);
  b.alphas(l, p.roughness);
  b.lobes.push_back(l);
  return b.bsdf();
}

// mirror.cpp: SpecularReflection(Kr, FresnelNoOp).
std::shared_ptr<const BxDF> bxdfOf(const scene::MirrorParams& p, const MaterialEvalContext& c) {
  V3Lobes b{c, {}};
  b.specular(b.albedo(p.kr), false, V3Lobe::Fresnel::NoOp, 1.0);
  return b.bsdf();
}

}  // namespace lensim::render
