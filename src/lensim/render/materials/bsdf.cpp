#include "lensim/render/materials/bsdf.h"

#include <algorithm>
#include <cmath>

#include "lensim/sampling/sampling.h"

namespace lensim::render {

using namespace lensim::sampling;

// ---------------------------------------------------------------------------------------------
// Fresnel and geometry

double frDielectric(double cos_theta_i, double eta) {
  cos_theta_i = std::clamp(cos_theta_i, -1.0, 1.0);
  if (cos_theta_i < 0) {  // arriving from inside: swap the media
    eta = 1 / eta;
    cos_theta_i = -cos_theta_i;
  }
  const double sin2_t = (1 - cos_theta_i * cos_theta_i) / (eta * eta);
  if (sin2_t >= 1) return 1.0;  // total internal reflection
  const double cos_t = std::sqrt(std::max(0.0, 1 - sin2_t));
  const double r_parl = (eta * cos_theta_i - cos_t) / (eta * cos_theta_i + cos_t);
  const double r_perp = (cos_theta_i - eta * cos_t) / (cos_theta_i + eta * cos_t);
  return (r_parl * r_parl + r_perp * r_perp) / 2;
}

// The complex-index Fresnel equations (pbrt-v4's FrComplex) in real arithmetic: with
// n = eta + ik and sin^2 = 1 - c^2, the transmitted n cos_t = sqrt(n^2 - sin^2) = a + ib, where
// a^2 + b^2 = |n^2 - sin^2| and a = sqrt((a^2 + b^2 + Re(n^2 - sin^2)) / 2); then
//   R_perp = (a^2 + b^2 - 2ac + c^2) / (a^2 + b^2 + 2ac + c^2),
//   R_parl = R_perp (c^2 (a^2 + b^2) - 2ac sin^2 + sin^4) / (c^2 (a^2 + b^2) + 2ac sin^2 + sin^4)
// (pbrt-v3's FrConductor). Two square roots and two or three divisions per wavelength, no
// complex division (libgcc's __divdc3) or complex square root; the four wavelengths vectorise.
SampledSpectrum frComplex(double cos_theta_i, const SampledSpectrum& eta,
                          const SampledSpectrum& k) {
  const double c = std::clamp(cos_theta_i, 0.0, 1.0);
  const double cos2 = c * c, sin2 = 1 - cos2;
  SampledSpectrum r;
  for (int i = 0; i < kSpectrumSamples; ++i) {
    const double eta2 = eta[i] * eta[i], k2 = k[i] * k[i];
    const double t0 = eta2 - k2 - sin2;
    const double a2_plus_b2 = std::sqrt(t0 * t0 + 4 * eta2 * k2);
    // a b = eta k: where Re(n^2 - sin^2) < 0 (beyond a near-dielectric's critical angle) a
    // comes from b, without the cancellation of a2_plus_b2 + t0.
    const double s = std::sqrt((a2_plus_b2 + std::abs(t0)) / 2);
    const double a = t0 >= 0 ? s : std::abs(eta[i] * k[i]) / s;
    const double t1 = a2_plus_b2 + cos2, t2 = 2 * c * a;
    // The numerators are (a - c)^2 + b^2 and (ac - sin^2)^2 + (bc)^2: never negative, but
    // they cancel to -ulps where n is near 1.
    const double r_perp = std::max(0.0, t1 - t2) / (t1 + t2);
    const double t3 = cos2 * a2_plus_b2 + sin2 * sin2, t4 = t2 * sin2;
    const double r_parl = r_perp * std::max(0.0, t3 - t4) / (t3 + t4);
    r[i] = (r_parl + r_perp) / 2;
  }
  return r;
}

SampledSpectrum conductorKFromReflectance(const SampledSpectrum& r) {
  SampledSpectrum k;
  for (int i = 0; i < kSpectrumSamples; ++i) {
    const double ri = std::clamp(r[i], 0.0, 0.9999);
    k[i] = 2 * std::sqrt(ri) / std::sqrt(1 - ri);
  }
  return k;
}

std::optional<Refraction> refract(const Vec3& wi, Vec3 n, double eta) {
  double cos_i = dot(n, wi);
  if (cos_i < 0) {  // wi is inside: flip the interface
    eta = 1 / eta;
    cos_i = -cos_i;
    n = -n;
  }
  const double sin2_t = std::max(0.0, 1 - cos_i * cos_i) / (eta * eta);
  if (sin2_t >= 1) return std::nullopt;
  const double cos_t = std::sqrt(1 - sin2_t);
  return Refraction{-wi / eta + n * (cos_i / eta - cos_t), eta};
}

namespace {

double selectProbability(double pr, double pt) {
  return pr / (pr + pt);
}

Vec3 faceForwardZ(const Vec3& v) {
  return v.z < 0 ? -v : v;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Diffuse

BxDFFlags DiffuseBxDF::flags() const {
  return r_.isBlack() ? BxDFFlags::Unset : BxDFFlags::Reflection | BxDFFlags::Diffuse;
}

SampledSpectrum DiffuseBxDF::f(const Vec3& wo, const Vec3& wi, TransportMode) const {
  if (!sameHemisphere(wo, wi)) return {};
  return r_ * kInvPi;
}

std::optional<BSDFSample> DiffuseBxDF::sample_f(const Vec3& wo, double, Vec2 u, TransportMode,
                                                ReflTrans allowed) const {
  if (!allows(allowed, ReflTrans::Reflection)) return std::nullopt;
  Vec3 wi = sampleCosineHemisphere(u);
  if (wo.z < 0) wi.z = -wi.z;
  const double pdf = cosineHemispherePdf(absCosTheta(wi));
  if (pdf == 0) return std::nullopt;
  return BSDFSample{r_ * kInvPi, wi, pdf, BxDFFlags::Reflection | BxDFFlags::Diffuse};
}

double DiffuseBxDF::pdf(const Vec3& wo, const Vec3& wi, TransportMode, ReflTrans allowed) const {
  if (!allows(allowed, ReflTrans::Reflection) || !sameHemisphere(wo, wi)) return 0;
  return cosineHemispherePdf(absCosTheta(wi));
}

// ---------------------------------------------------------------------------------------------
// Oren-Nayar

OrenNayarBxDF::OrenNayarBxDF(const SampledSpectrum& r, double sigma_deg) : r_(r) {
  const double sigma = sigma_deg * kPi / 180;
  const double s2 = sigma * sigma;
  a_ = 1 - s2 / (2 * (s2 + 0.33));
  b_ = 0.45 * s2 / (s2 + 0.09);
}

BxDFFlags OrenNayarBxDF::flags() const {
  return r_.isBlack() ? BxDFFlags::Unset : BxDFFlags::Reflection | BxDFFlags::Diffuse;
}

SampledSpectrum OrenNayarBxDF::f(const Vec3& wo, const Vec3& wi, TransportMode) const {
  if (!sameHemisphere(wo, wi)) return {};
  const double sin_i = sinTheta(wi), sin_o = sinTheta(wo);
  double max_cos = 0;
  if (sin_i > 1e-4 && sin_o > 1e-4)
    max_cos = std::max(0.0, cosPhi(wi) * cosPhi(wo) + sinPhi(wi) * sinPhi(wo));
  double sin_alpha, tan_beta;
  if (absCosTheta(wi) > absCosTheta(wo)) {
    sin_alpha = sin_o;
    tan_beta = sin_i / absCosTheta(wi);
  } else {
    sin_alpha = sin_i;
    tan_beta = sin_o / absCosTheta(wo);
  }
  return r_ * (kInvPi * (a_ + b_ * max_cos * sin_alpha * tan_beta));
}

std::optional<BSDFSample> OrenNayarBxDF::sample_f(const Vec3& wo, double, Vec2 u,
                                                  TransportMode mode, ReflTrans allowed) const {
  if (!allows(allowed, ReflTrans::Reflection)) return std::nullopt;
  Vec3 wi = sampleCosineHemisphere(u);
  if (wo.z < 0) wi.z = -wi.z;
  const double pdf = cosineHemispherePdf(absCosTheta(wi));
  if (pdf == 0) return std::nullopt;
  return BSDFSample{f(wo, wi, mode), wi, pdf, BxDFFlags::Reflection | BxDFFlags::Diffuse};
}

double OrenNayarBxDF::pdf(const Vec3& wo, const Vec3& wi, TransportMode, ReflTrans allowed) const {
  if (!allows(allowed, ReflTrans::Reflection) || !sameHemisphere(wo, wi)) return 0;
  return cosineHemispherePdf(absCosTheta(wi));
}

// ---------------------------------------------------------------------------------------------
// Diffuse transmission

BxDFFlags DiffuseTransmissionBxDF::flags() const {
  BxDFFlags f = BxDFFlags::Unset;
  if (!r_.isBlack()) f = f | BxDFFlags::Reflection | BxDFFlags::Diffuse;
  if (!t_.isBlack()) f = f | BxDFFlags::Transmission | BxDFFlags::Diffuse;
  return f;
}

SampledSpectrum DiffuseTransmissionBxDF::f(const Vec3& wo, const Vec3& wi, TransportMode) const {
  return sameHemisphere(wo, wi) ? r_ * kInvPi : t_ * kInvPi;
}

std::optional<BSDFSample> DiffuseTransmissionBxDF::sample_f(const Vec3& wo, double uc, Vec2 u,
                                                            TransportMode,
                                                            ReflTrans allowed) const {
  double pr = r_.maxValue(), pt = t_.maxValue();
  if (!allows(allowed, ReflTrans::Reflection)) pr = 0;
  if (!allows(allowed, ReflTrans::Transmission)) pt = 0;
  if (pr <= 0 && pt <= 0) return std::nullopt;
  Vec3 wi = sampleCosineHemisphere(u);
  const double p_r = selectProbability(pr, pt);
  if (uc < p_r) {
    if (wo.z < 0) wi.z = -wi.z;
    return BSDFSample{r_ * kInvPi, wi, cosineHemispherePdf(absCosTheta(wi)) * p_r,
                      BxDFFlags::Reflection | BxDFFlags::Diffuse};
  }
  if (wo.z > 0) wi.z = -wi.z;
  return BSDFSample{t_ * kInvPi, wi, cosineHemispherePdf(absCosTheta(wi)) * (1 - p_r),
                    BxDFFlags::Transmission | BxDFFlags::Diffuse};
}

double DiffuseTransmissionBxDF::pdf(const Vec3& wo, const Vec3& wi, TransportMode,
                                    ReflTrans allowed) const {
  double pr = r_.maxValue(), pt = t_.maxValue();
  if (!allows(allowed, ReflTrans::Reflection)) pr = 0;
  if (!allows(allowed, ReflTrans::Transmission)) pt = 0;
  if (pr <= 0 && pt <= 0) return 0;
  const double p_r = selectProbability(pr, pt);
  return cosineHemispherePdf(absCosTheta(wi)) * (sameHemisphere(wo, wi) ? p_r : 1 - p_r);
}

// ---------------------------------------------------------------------------------------------
// Conductor

BxDFFlags ConductorBxDF::flags() const {
  return distrib_.effectivelySmooth() ? BxDFFlags::Reflection | BxDFFlags::Specular
                                      : BxDFFlags::Reflection | BxDFFlags::Glossy;
}

SampledSpectrum ConductorBxDF::f(const Vec3& wo, const Vec3& wi, TransportMode) const {
  if (!sameHemisphere(wo, wi) || distrib_.effectivelySmooth()) return {};
  const double cos_o = absCosTheta(wo), cos_i = absCosTheta(wi);
  if (cos_i == 0 || cos_o == 0) return {};
  Vec3 wm = wi + wo;
  if (dot(wm, wm) == 0) return {};
  wm = normalize(wm);
  const SampledSpectrum F = frComplex(std::abs(dot(wo, wm)), eta_, k_);
  return F * (distrib_.D(wm) * distrib_.G(wo, wi) / (4 * cos_i * cos_o));
}

std::optional<BSDFSample> ConductorBxDF::sample_f(const Vec3& wo, double, Vec2 u,
                                                  TransportMode mode, ReflTrans allowed) const {
  if (!allows(allowed, ReflTrans::Reflection)) return std::nullopt;
  if (distrib_.effectivelySmooth()) {
    const Vec3 wi(-wo.x, -wo.y, wo.z);
    const double c = absCosTheta(wi);
    if (c == 0) return std::nullopt;
    return BSDFSample{frComplex(c, eta_, k_) / c, wi, 1.0,
                      BxDFFlags::Reflection | BxDFFlags::Specular};
  }
  if (wo.z == 0) return std::nullopt;
  const Vec3 wm = distrib_.sampleWm(wo, u);
  const Vec3 wi = reflect(wo, wm);
  if (!sameHemisphere(wo, wi)) return std::nullopt;
  const double pdf = distrib_.pdf(wo, wm) / (4 * std::abs(dot(wo, wm)));
  if (!(pdf > 0)) return std::nullopt;
  return BSDFSample{f(wo, wi, mode), wi, pdf, BxDFFlags::Reflection | BxDFFlags::Glossy};
}

double ConductorBxDF::pdf(const Vec3& wo, const Vec3& wi, TransportMode, ReflTrans allowed) const {
  if (!allows(allowed, ReflTrans::Reflection) || !sameHemisphere(wo, wi) ||
      distrib_.effectivelySmooth())
    return 0;
  Vec3 wm = wo + wi;
  if (dot(wm, wm) == 0) return 0;
  wm = faceForwardZ(normalize(wm));
  return distrib_.pdf(wo, wm) / (4 * std::abs(dot(wo, wm)));
}

// ---------------------------------------------------------------------------------------------
// Dielectric

BxDFFlags DielectricBxDF::flags() const {
  const BxDFFlags kind =
      eta_ == 1 ? BxDFFlags::Transmission : BxDFFlags::Reflection | BxDFFlags::Transmission;
  return kind | (distrib_.effectivelySmooth() ? BxDFFlags::Specular : BxDFFlags::Glossy);
}

std::optional<BSDFSample> DielectricBxDF::sample_f(const Vec3& wo, double uc, Vec2 u,
                                                   TransportMode mode, ReflTrans allowed) const {
  if (eta_ == 1 || distrib_.effectivelySmooth()) {
    const double R = frDielectric(cosTheta(wo), eta_), T = 1 - R;
    double pr = R, pt = T;
    if (!allows(allowed, ReflTrans::Reflection)) pr = 0;
    if (!allows(allowed, ReflTrans::Transmission)) pt = 0;
    if (pr <= 0 && pt <= 0) return std::nullopt;
    if (uc < selectProbability(pr, pt)) {
      const Vec3 wi(-wo.x, -wo.y, wo.z);
      const double c = absCosTheta(wi);
      if (c == 0) return std::nullopt;
      return BSDFSample{SampledSpectrum(R / c), wi, selectProbability(pr, pt),
                        BxDFFlags::Reflection | BxDFFlags::Specular};
    }
    const auto t = refract(wo, Vec3(0, 0, 1), eta_);
    if (!t) return std::nullopt;
    const double c = absCosTheta(t->wt);
    if (c == 0) return std::nullopt;
    double ft = T / c;
    if (mode == TransportMode::Radiance) ft /= t->etap * t->etap;
    return BSDFSample{SampledSpectrum(ft), t->wt, pt / (pr + pt),
                      BxDFFlags::Transmission | BxDFFlags::Specular, t->etap};
  }

  // Rough: sample a visible microfacet normal, then reflect or refract about it.
  if (wo.z == 0) return std::nullopt;
  const Vec3 wm = distrib_.sampleWm(wo, u);
  const double R = frDielectric(dot(wo, wm), eta_), T = 1 - R;
  double pr = R, pt = T;
  if (!allows(allowed, ReflTrans::Reflection)) pr = 0;
  if (!allows(allowed, ReflTrans::Transmission)) pt = 0;
  if (pr <= 0 && pt <= 0) return std::nullopt;
  if (uc < selectProbability(pr, pt)) {
    const Vec3 wi = reflect(wo, wm);
    if (!sameHemisphere(wo, wi)) return std::nullopt;
    const double pdf =
        distrib_.pdf(wo, wm) / (4 * std::abs(dot(wo, wm))) * selectProbability(pr, pt);
    const double f = distrib_.D(wm) * distrib_.G(wo, wi) * R / (4 * cosTheta(wi) * cosTheta(wo));
    if (!(pdf > 0)) return std::nullopt;
    return BSDFSample{SampledSpectrum(f), wi, pdf, BxDFFlags::Reflection | BxDFFlags::Glossy};
  }
  const auto t = refract(wo, wm, eta_);
  if (!t) return std::nullopt;
  const Vec3 wi = t->wt;
  if (sameHemisphere(wo, wi) || wi.z == 0) return std::nullopt;
  // Generalised half-vector Jacobian |wi.wm| / (wi.wm + wo.wm / eta')^2.
  const double denom = std::pow(dot(wi, wm) + dot(wo, wm) / t->etap, 2);
  const double dwm_dwi = std::abs(dot(wi, wm)) / denom;
  const double pdf = distrib_.pdf(wo, wm) * dwm_dwi * pt / (pr + pt);
  double ft = T * distrib_.D(wm) * distrib_.G(wo, wi) *
              std::abs(dot(wi, wm) * dot(wo, wm) / (cosTheta(wi) * cosTheta(wo) * denom));
  if (mode == TransportMode::Radiance) ft /= t->etap * t->etap;
  if (!(pdf > 0)) return std::nullopt;
  return BSDFSample{SampledSpectrum(ft), wi, pdf, BxDFFlags::Transmission | BxDFFlags::Glossy,
                    t->etap};
}

namespace {
// Generalised half vector of a rough dielectric pair, facing +z; nullopt if degenerate or
// back-facing to either direction.
struct HalfVector {
  Vec3 wm;
  double etap;
  bool reflect;
};
std::optional<HalfVector> dielectricHalfVector(const Vec3& wo, const Vec3& wi, double eta) {
  const double co = cosTheta(wo), ci = cosTheta(wi);
  const bool reflect = co * ci > 0;
  double etap = 1;
  if (!reflect) etap = co > 0 ? eta : 1 / eta;
  Vec3 wm = wi * etap + wo;
  if (ci == 0 || co == 0 || dot(wm, wm) == 0) return std::nullopt;
  wm = faceForwardZ(normalize(wm));
  if (dot(wm, wi) * ci < 0 || dot(wm, wo) * co < 0) return std::nullopt;
  return HalfVector{wm, etap, reflect};
}
}  // namespace

SampledSpectrum DielectricBxDF::f(const Vec3& wo, const Vec3& wi, TransportMode mode) const {
  if (eta_ == 1 || distrib_.effectivelySmooth()) return {};
  const auto h = dielectricHalfVector(wo, wi, eta_);
  if (!h) return {};
  const Vec3& wm = h->wm;
  const double F = frDielectric(dot(wo, wm), eta_);
  if (h->reflect)
    return SampledSpectrum(distrib_.D(wm) * distrib_.G(wo, wi) * F /
                           std::abs(4 * cosTheta(wi) * cosTheta(wo)));
  const double denom =
      std::pow(dot(wi, wm) + dot(wo, wm) / h->etap, 2) * cosTheta(wi) * cosTheta(wo);
  double ft =
      distrib_.D(wm) * (1 - F) * distrib_.G(wo, wi) * std::abs(dot(wi, wm) * dot(wo, wm) / denom);
  if (mode == TransportMode::Radiance) ft /= h->etap * h->etap;
  return SampledSpectrum(ft);
}

double DielectricBxDF::pdf(const Vec3& wo, const Vec3& wi, TransportMode, ReflTrans allowed) const {
  if (eta_ == 1 || distrib_.effectivelySmooth()) return 0;
  const auto h = dielectricHalfVector(wo, wi, eta_);
  if (!h) return 0;
  const Vec3& wm = h->wm;
  const double R = frDielectric(dot(wo, wm), eta_), T = 1 - R;
  double pr = R, pt = T;
  if (!allows(allowed, ReflTrans::Reflection)) pr = 0;
  if (!allows(allowed, ReflTrans::Transmission)) pt = 0;
  if (pr <= 0 && pt <= 0) return 0;
  if (h->reflect) return distrib_.pdf(wo, wm) / (4 * std::abs(dot(wo, wm))) * pr / (pr + pt);
  const double denom = std::pow(dot(wi, wm) + dot(wo, wm) / h->etap, 2);
  return distrib_.pdf(wo, wm) * std::abs(dot(wi, wm)) / denom * pt / (pr + pt);
}

// ---------------------------------------------------------------------------------------------
// Thin dielectric

BxDFFlags ThinDielectricBxDF::flags() const {
  return BxDFFlags::Reflection | BxDFFlags::Transmission | BxDFFlags::Specular;
}

std::optional<BSDFSample> ThinDielectricBxDF::sample_f(const Vec3& wo, double uc, Vec2,
                                                       TransportMode, ReflTrans allowed) const {
  double R = frDielectric(absCosTheta(wo), eta_), T = 1 - R;
  if (R < 1) {  // sum the geometric series of inter-reflections inside the slab
    R += T * T * R / (1 - R * R);
    T = 1 - R;
  }
  double pr = R, pt = T;
  if (!allows(allowed, ReflTrans::Reflection)) pr = 0;
  if (!allows(allowed, ReflTrans::Transmission)) pt = 0;
  if (pr <= 0 && pt <= 0) return std::nullopt;
  const double c = absCosTheta(wo);
  if (c == 0) return std::nullopt;
  if (uc < selectProbability(pr, pt))
    return BSDFSample{SampledSpectrum(R / c), Vec3(-wo.x, -wo.y, wo.z), pr / (pr + pt),
                      BxDFFlags::Reflection | BxDFFlags::Specular};
  return BSDFSample{SampledSpectrum(T / c), -wo, pt / (pr + pt),
                    BxDFFlags::Transmission | BxDFFlags::Specular};
}

}  // namespace lensim::render

namespace lensim::render {

Frame Frame::fromNormalAndTangent(const Vec3& n, const Vec3& dpdu) {
  Frame f;
  f.z = normalize(n);
  Vec3 t = dpdu - f.z * dot(dpdu, f.z);  // Gram-Schmidt
  if (dot(t, t) < 1e-20) {
    // Any perpendicular: cross with the axis least aligned with n.
    const Vec3 a = std::abs(f.z.x) < 0.9 ? Vec3(1, 0, 0) : Vec3(0, 1, 0);
    t = cross(a, f.z);
  }
  f.x = normalize(t);
  f.y = cross(f.z, f.x);
  return f;
}

BSDF::BSDF(const Vec3& ns, const Vec3& dpdus, std::shared_ptr<const BxDF> bxdf)
    : bxdf_(std::move(bxdf)), frame_(Frame::fromNormalAndTangent(ns, dpdus)) {}

SampledSpectrum BSDF::f(const Vec3& wo_render, const Vec3& wi_render, TransportMode mode) const {
  const Vec3 wo = frame_.toLocal(wo_render), wi = frame_.toLocal(wi_render);
  if (wo.z == 0) return {};
  return bxdf_->f(wo, wi, mode);
}

std::optional<BSDFSample> BSDF::sample_f(const Vec3& wo_render, double uc, Vec2 u,
                                         TransportMode mode, ReflTrans allowed) const {
  const Vec3 wo = frame_.toLocal(wo_render);
  if (wo.z == 0 || bxdf_->flags() == BxDFFlags::Unset) return std::nullopt;
  auto bs = bxdf_->sample_f(wo, uc, u, mode, allowed);
  if (!bs || bs->f.isBlack() || !(bs->pdf > 0) || bs->wi.z == 0) return std::nullopt;
  bs->wi = frame_.fromLocal(bs->wi);
  return bs;
}

double BSDF::pdf(const Vec3& wo_render, const Vec3& wi_render, TransportMode mode,
                 ReflTrans allowed) const {
  const Vec3 wo = frame_.toLocal(wo_render), wi = frame_.toLocal(wi_render);
  if (wo.z == 0) return 0;
  return bxdf_->pdf(wo, wi, mode, allowed);
}

}  // namespace lensim::render
