// pbrt-v4's HairBxDF (see hair.h); the place in pbrt-v4 each piece follows is named beside it.
#include "lensim/render/materials/hair.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace lensim::render {

namespace {

constexpr double kPi = std::numbers::pi;

double sqr(double x) {
  return x * x;
}
double safeSqrt(double x) {
  return std::sqrt(std::max(0.0, x));
}
double safeAsin(double x) {
  return std::asin(std::clamp(x, -1.0, 1.0));
}

/// d'Eon et al. 2011's longitudinal scattering function
/// M_p = csch(1/v) / (2v) exp(-sin(theta_i) sin(theta_o) / v) I0(cos(theta_i) cos(theta_o) / v),
/// given log_norm = log(csch(1/v) / (2v)). I0 by the polynomial approximations of Abramowitz &
/// Stegun 9.8.1 (x < 3.75) and 9.8.2 (e^-x sqrt(x) I0(x) for x >= 3.75), both within 2e-7
/// relative; the exponentials are combined before evaluation so that nothing overflows for
/// small v (pbrt-v4's HairBxDF::Mp switches to logarithms below v = 0.1 for the same reason).
double Mp(double cos_i, double cos_o, double sin_i, double sin_o, double v, double log_norm) {
  const double a = cos_i * cos_o / v, b = sin_i * sin_o / v;
  if (a < 3.75) {
    const double t = sqr(a / 3.75);
    const double i0 =
        1 +
        t * (3.5156229 +
             t * (3.0899424 + t * (1.2067492 + t * (0.2659732 + t * (0.0360768 + t * 0.0045813)))));
    return i0 * std::exp(log_norm - b);
  }
  const double t = 3.75 / a;
  const double q =
      0.39894228 +
      t * (0.01328592 +
           t * (0.00225319 +
                t * (-0.00157565 +
                     t * (0.00916281 +
                          t * (-0.02057706 +
                               t * (0.02635537 + t * (-0.01647633 + t * 0.00392377)))))));
  return q / std::sqrt(a) * std::exp(a - b + log_norm);
}

/// log(csch(1/v) / (2v)) = log 2 - 1/v - log(1 - e^(-2/v)) - log(2v).
double mpLogNorm(double v) {
  const double y = 1 / v;
  return std::numbers::ln2 - y - std::log1p(-std::exp(-2 * y)) - std::log(2 * v);
}

// The logistic distribution of scale s and its restriction to [-pi, pi] (pbrt-v4
// src/pbrt/util/math.h Logistic, LogisticCDF, TrimmedLogistic; sampling.h
// SampleTrimmedLogistic).
double logistic(double x, double s) {
  x = std::abs(x);
  const double e = std::exp(-x / s);
  return e / (s * sqr(1 + e));
}
double logisticCdf(double x, double s) {
  return 1 / (1 + std::exp(-x / s));
}

double sampleTrimmedLogistic(double u, double s) {
  const double lo = logisticCdf(-kPi, s), k = logisticCdf(kPi, s) - lo;
  const double x = -s * std::log(1 / (u * k + lo) - 1);
  return std::clamp(x, -kPi, kPi);
}

/// The azimuth of path p's exit relative to phi_o (pbrt-v4 HairBxDF::Phi).
double Phi(int p, double gamma_o, double gamma_t) {
  return 2 * p * gamma_t - 2 * gamma_o + p * kPi;
}

/// N_p: the logistic about Phi(p) trimmed to [-pi, pi] (inv_k: 1 over its mass there), phi
/// wrapped to [-pi, pi] (pbrt-v4 HairBxDF::Np).
double Np(double phi, int p, double s, double inv_k, double gamma_o, double gamma_t) {
  const double dphi = std::remainder(phi - Phi(p, gamma_o, gamma_t), 2 * kPi);
  return logistic(dphi, s) * inv_k;
}

}  // namespace

/// Everything f, pdf and sample_f need that depends on wo alone.
struct HairBxDF::WoTerms {
  double sin_o = 0, cos_o = 1, phi_o = 0;
  double gamma_t = 0;
  /// sin and cos of theta_o rotated by the scales for each p (p = 3 unrotated).
  std::array<double, kPMax + 1> sin_p{}, cos_p{};
  std::array<SampledSpectrum, kPMax + 1> ap;
  std::array<double, kPMax + 1> ap_pdf{};
};

HairBxDF::HairBxDF(double h, double eta, const SampledSpectrum& sigma_a, double beta_m,
                   double beta_n, double alpha_deg)
    : h_(std::clamp(h, -1.0, 1.0)),
      gamma_o_(safeAsin(h_)),
      cos_gamma_o_(std::cos(gamma_o_)),
      eta_(std::max(eta, 1.0)),
      sigma_a_(sigma_a) {
  // Longitudinal variances from beta_m; TT narrower, TRT and beyond wider (pbrt-v4 HairBxDF
  // constructor, after Chiang et al. 2016).
  v_[0] = sqr(0.726 * beta_m + 0.812 * sqr(beta_m) + 3.7 * std::pow(beta_m, 20));
  v_[1] = 0.25 * v_[0];
  v_[2] = 4 * v_[0];
  v_[3] = v_[2];
  // Azimuthal logistic scale from beta_n: sqrt(pi/8) (0.265 bn + 1.194 bn^2 + 5.372 bn^22).
  s_ = std::sqrt(kPi / 8) * (0.265 * beta_n + 1.194 * sqr(beta_n) + 5.372 * std::pow(beta_n, 22));
  for (size_t p = 0; p <= kPMax; ++p) log_norm_[p] = mpLogNorm(v_[p]);
  inv_k_ = 1 / (logisticCdf(kPi, s_) - logisticCdf(-kPi, s_));
  // sin and cos of 2^k alpha for k = 0, 1, 2 by the double-angle formulas.
  sin2k_alpha_[0] = std::sin(alpha_deg * kPi / 180);
  cos2k_alpha_[0] = safeSqrt(1 - sqr(sin2k_alpha_[0]));
  for (size_t i = 1; i < 3; ++i) {
    sin2k_alpha_[i] = 2 * cos2k_alpha_[i - 1] * sin2k_alpha_[i - 1];
    cos2k_alpha_[i] = sqr(cos2k_alpha_[i - 1]) - sqr(sin2k_alpha_[i - 1]);
  }
}

HairBxDF::WoTerms HairBxDF::terms(const Vec3& wo) const {
  WoTerms t;
  t.sin_o = std::clamp(wo.x, -1.0, 1.0);
  t.cos_o = safeSqrt(1 - sqr(t.sin_o));
  t.phi_o = std::atan2(wo.z, wo.y);
  // The refracted ray: its longitudinal angle and, in the normal plane, the modified index
  // eta' = sqrt(eta^2 - sin^2 theta_o) / cos theta_o and gamma_t = asin(h / eta').
  const double sin_t = t.sin_o / eta_, cos_t = safeSqrt(1 - sqr(sin_t));
  const double etap = t.cos_o > 0 ? safeSqrt(sqr(eta_) - sqr(t.sin_o)) / t.cos_o : INFINITY;
  const double sin_gamma_t = h_ / etap, cos_gamma_t = safeSqrt(1 - sqr(sin_gamma_t));
  t.gamma_t = safeAsin(sin_gamma_t);
  // Transmittance of one chord through the fibre (Beer-Lambert, radius 1); an infinite
  // absorption gives 0.
  const double chord = 2 * cos_gamma_t / cos_t;
  SampledSpectrum T;
  for (int i = 0; i < kSpectrumSamples; ++i)
    T[i] = sigma_a_[i] == INFINITY ? 0.0 : std::exp(-sigma_a_[i] * chord);
  // A_p (pbrt-v4 HairBxDF::Ap): Fresnel at the first hit, then (1-f)^2 T (T f)^(p-1), and the
  // geometric series of every longer path in A_3.
  const double f = frDielectric(t.cos_o * cos_gamma_o_, eta_);
  t.ap[0] = SampledSpectrum(f);
  t.ap[1] = T * sqr(1 - f);
  t.ap[2] = t.ap[1] * T * f;
  for (int i = 0; i < kSpectrumSamples; ++i) {
    const double tf = T[i] * f;
    t.ap[3][i] = tf < 1 ? t.ap[2][i] * tf / (1 - tf) : 0.0;
  }
  // The lobe probabilities (pbrt-v4 HairBxDF::ApPDF): each A_p's average over the wavelengths.
  double sum = 0;
  for (int p = 0; p <= kPMax; ++p) sum += t.ap[size_t(p)].average();
  for (int p = 0; p <= kPMax; ++p)
    t.ap_pdf[size_t(p)] = sum > 0 ? t.ap[size_t(p)].average() / sum : 0.0;
  // theta_o tilted by the scales: R by -2 alpha, TT by alpha, TRT by 4 alpha (pbrt-v4
  // HairBxDF::f); |cos| guards rotations past the pole.
  const double s = t.sin_o, c = t.cos_o;
  t.sin_p[0] = s * cos2k_alpha_[1] - c * sin2k_alpha_[1];
  t.cos_p[0] = c * cos2k_alpha_[1] + s * sin2k_alpha_[1];
  t.sin_p[1] = s * cos2k_alpha_[0] + c * sin2k_alpha_[0];
  t.cos_p[1] = c * cos2k_alpha_[0] - s * sin2k_alpha_[0];
  t.sin_p[2] = s * cos2k_alpha_[2] + c * sin2k_alpha_[2];
  t.cos_p[2] = c * cos2k_alpha_[2] - s * sin2k_alpha_[2];
  t.sin_p[3] = s;
  t.cos_p[3] = c;
  for (double& cp : t.cos_p) cp = std::abs(cp);
  return t;
}

SampledSpectrum HairBxDF::fsum(const WoTerms& t, const Vec3& wi) const {
  const double sin_i = std::clamp(wi.x, -1.0, 1.0), cos_i = safeSqrt(1 - sqr(sin_i));
  const double phi = std::atan2(wi.z, wi.y) - t.phi_o;
  SampledSpectrum sum;
  for (int p = 0; p < kPMax; ++p) {
    const auto q = size_t(p);
    sum += t.ap[q] * (Mp(cos_i, t.cos_p[q], sin_i, t.sin_p[q], v_[q], log_norm_[q]) *
                      Np(phi, p, s_, inv_k_, gamma_o_, t.gamma_t));
  }
  sum +=
      t.ap[kPMax] * (Mp(cos_i, t.cos_o, sin_i, t.sin_o, v_[kPMax], log_norm_[kPMax]) / (2 * kPi));
  return sum;
}

double HairBxDF::pdfOf(const WoTerms& t, const Vec3& wi) const {
  const double sin_i = std::clamp(wi.x, -1.0, 1.0), cos_i = safeSqrt(1 - sqr(sin_i));
  const double phi = std::atan2(wi.z, wi.y) - t.phi_o;
  double pdf = 0;
  for (int p = 0; p < kPMax; ++p) {
    const auto q = size_t(p);
    if (t.ap_pdf[q] == 0) continue;
    pdf += t.ap_pdf[q] * Mp(cos_i, t.cos_p[q], sin_i, t.sin_p[q], v_[q], log_norm_[q]) *
           Np(phi, p, s_, inv_k_, gamma_o_, t.gamma_t);
  }
  if (t.ap_pdf[kPMax] > 0)
    pdf += t.ap_pdf[kPMax] * Mp(cos_i, t.cos_o, sin_i, t.sin_o, v_[kPMax], log_norm_[kPMax]) /
           (2 * kPi);
  return pdf;
}

SampledSpectrum HairBxDF::f(const Vec3& wo, const Vec3& wi, TransportMode) const {
  SampledSpectrum s = fsum(terms(wo), wi);
  if (wi.z != 0) s /= std::abs(wi.z);
  return s;
}

double HairBxDF::pdf(const Vec3& wo, const Vec3& wi, TransportMode, ReflTrans allowed) const {
  if (!allows(allowed, ReflTrans::Reflection)) return 0;
  return pdfOf(terms(wo), wi);
}

std::optional<BSDFSample> HairBxDF::sample_f(const Vec3& wo, double uc, Vec2 u, TransportMode,
                                             ReflTrans allowed) const {
  if (!allows(allowed, ReflTrans::Reflection)) return std::nullopt;
  const WoTerms t = terms(wo);
  // Choose the lobe p with probability ap_pdf[p] and rescale uc to reuse it for the azimuth
  // (pbrt-v4 SampleDiscrete with uRemapped).
  int p = 0;
  double cdf = 0;
  for (; p < kPMax; ++p) {
    const double next = cdf + t.ap_pdf[size_t(p)];
    if (uc < next) break;
    cdf = next;
  }
  const double w = t.ap_pdf[size_t(p)];
  if (!(w > 0)) return std::nullopt;
  uc = std::clamp((uc - cdf) / w, 0.0, 0x1.fffffffffffffp-1);
  const auto q = size_t(p);
  // theta_i from M_p: a von Mises-Fisher direction about the mirror of the tilted theta_o,
  // cos(theta) = 1 + v ln(u0 + (1 - u0) e^(-2/v)) from it and a uniform angle around it,
  // projected on the fibre (d'Eon et al. 2013's sampling as pbrt-v4 HairBxDF::Sample_f does it;
  // lensim keeps u0 = 0 instead of clamping it to 1e-5).
  const double v = v_[q];
  const double arg = u.x + (1 - u.x) * std::exp(-2 / v);
  const double cos_theta = arg > 0 ? std::max(-1.0, 1 + v * std::log(arg)) : -1.0;
  const double sin_theta = safeSqrt(1 - sqr(cos_theta));
  const double cos_phi = std::cos(2 * kPi * u.y);
  const double sin_i =
      std::clamp(-cos_theta * t.sin_p[q] + sin_theta * cos_phi * t.cos_p[q], -1.0, 1.0);
  const double cos_i = safeSqrt(1 - sqr(sin_i));
  // The azimuth from N_p: about Phi(p) for p < 3, uniform for the rest.
  const double dphi =
      p < kPMax ? Phi(p, gamma_o_, t.gamma_t) + sampleTrimmedLogistic(uc, s_) : 2 * kPi * uc;
  const double phi_i = t.phi_o + dphi;
  BSDFSample bs;
  bs.wi = {sin_i, cos_i * std::cos(phi_i), cos_i * std::sin(phi_i)};
  bs.pdf = pdfOf(t, bs.wi);
  bs.f = fsum(t, bs.wi);
  if (bs.wi.z != 0) bs.f /= std::abs(bs.wi.z);
  bs.flags = flags();
  return bs;
}

Vec3 HairBxDF::sigmaAFromConcentration(double eumelanin, double pheomelanin) {
  const Vec3 eu{0.419, 0.697, 1.37}, pheo{0.187, 0.4, 1.05};
  return eu * eumelanin + pheo * pheomelanin;
}

SampledSpectrum HairBxDF::sigmaAFromReflectance(const SampledSpectrum& c, double beta_n) {
  const double bn = beta_n;
  const double d = 5.969 - 0.215 * bn + 2.532 * sqr(bn) - 10.73 * std::pow(bn, 3) +
                   5.574 * std::pow(bn, 4) + 0.245 * std::pow(bn, 5);
  SampledSpectrum s;
  for (int i = 0; i < kSpectrumSamples; ++i) {
    const double ci = std::clamp(c[i], 0.0, 1.0);
    s[i] = ci > 0 ? sqr(std::log(ci) / d) : INFINITY;
  }
  return s;
}

}  // namespace lensim::render
