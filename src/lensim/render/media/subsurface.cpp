// The subsurface material's medium. See subsurface.h.
#include "lensim/render/media/subsurface.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "lensim/render/textures/textures.h"
#include "lensim/scene/description.h"

namespace lensim::render {

namespace {

/// Gauss-Legendre nodes and weights on [0, 1] (n = 32, by Newton's method on P_n).
struct Quadrature {
  static constexpr int n = 32;
  std::array<double, n> x, w;
  Quadrature() {
    for (int i = 0; i < n; ++i) {
      double z = std::cos(M_PI * (i + 0.75) / (n + 0.5)), dp = 0;
      for (int it = 0; it < 100; ++it) {
        double p0 = 1, p1 = 0;
        for (int k = 1; k <= n; ++k) {
          const double p2 = p1;
          p1 = p0;
          p0 = ((2 * k - 1) * z * p1 - (k - 1) * p2) / k;
        }
        dp = n * (z * p0 - p1) / (z * z - 1);
        const double dz = p0 / dp;
        z -= dz;
        if (std::abs(dz) < 1e-15) break;
      }
      x[size_t(i)] = 0.5 * (1 - z);
      w[size_t(i)] = 1 / ((1 - z * z) * dp * dp);  // 2/((1-z^2) P'^2), halved for [0, 1]
    }
  }
};

const Quadrature& quadrature() {
  static const Quadrature q;
  return q;
}

/// Table of the diffuse reflectance at albedos 1 - (1 - k/N)^2 (dense near 1).
struct ReflectanceTable {
  static constexpr int N = 256;
  std::array<double, N + 1> albedo, r;
  ReflectanceTable() {
    for (int k = 0; k <= N; ++k) {
      const double t = 1 - double(k) / N;
      albedo[size_t(k)] = 1 - t * t;
      r[size_t(k)] = diffuseReflectanceOfAlbedo(albedo[size_t(k)]);
    }
  }
};

}  // namespace

double diffuseReflectanceOfAlbedo(double a) {
  a = std::clamp(a, 0.0, 1.0);
  if (a == 0) return 0;
  const Quadrature& q = quadrature();
  // 1 / H(mu) = sqrt(1 - a) + (a / 2) int_0^1 mu' H(mu') / (mu + mu') dmu' (Chandrasekhar's
  // alternative form of the H equation for isotropic scattering), iterated from H = 1.
  std::array<double, Quadrature::n> H;
  H.fill(1.0);
  const double s = std::sqrt(1 - a);
  for (int it = 0; it < 2000; ++it) {
    double change = 0;
    std::array<double, Quadrature::n> next;
    for (int i = 0; i < q.n; ++i) {
      double integral = 0;
      for (int j = 0; j < q.n; ++j)
        integral +=
            q.w[size_t(j)] * q.x[size_t(j)] * H[size_t(j)] / (q.x[size_t(i)] + q.x[size_t(j)]);
      next[size_t(i)] = 1 / (s + 0.5 * a * integral);
      change = std::max(change, std::abs(next[size_t(i)] - H[size_t(i)]));
    }
    H = next;
    if (change < 1e-12) break;
  }
  double h1 = 0;
  for (int i = 0; i < q.n; ++i) h1 += q.w[size_t(i)] * q.x[size_t(i)] * H[size_t(i)];
  return 1 - 2 * s * h1;
}

double albedoForDiffuseReflectance(double r) {
  static const ReflectanceTable t;
  r = std::clamp(r, 0.0, 1.0);
  const auto it = std::lower_bound(t.r.begin(), t.r.end(), r);
  if (it == t.r.begin()) return 0;
  if (it == t.r.end()) return 1;
  const size_t k = size_t(it - t.r.begin());
  const double f = (r - t.r[k - 1]) / (t.r[k] - t.r[k - 1]);
  return t.albedo[k - 1] + f * (t.albedo[k] - t.albedo[k - 1]);
}

SubsurfaceMedium::SubsurfaceMedium(const scene::SubsurfaceParams& m) {
  scale_ = m.scale;
  g_ = m.g;
  from_reflectance_ = m.from_reflectance;
  if (from_reflectance_)
    textured_ = m.reflectance.texture >= 0 || m.mfp.texture >= 0;
  else
    textured_ = m.sigma_a.texture >= 0 || m.sigma_s.texture >= 0;
  if (textured_) {
    material_ = &m;
  } else if (from_reflectance_) {
    reflectance_ = makeSpectrum(m.reflectance.spectrum, SpectrumType::Albedo);
    mfp_ = makeSpectrum(m.mfp.spectrum, SpectrumType::Unbounded);
  } else {
    sigma_a_ = makeSpectrum(m.sigma_a.spectrum, SpectrumType::Unbounded);
    sigma_s_ = makeSpectrum(m.sigma_s.spectrum, SpectrumType::Unbounded);
  }
}

MediumProperties SubsurfaceMedium::fromReflectance(const SampledSpectrum& r,
                                                   const SampledSpectrum& mfp) const {
  MediumProperties mp;
  for (int i = 0; i < kSpectrumSamples; ++i) {
    const double free_path = scale_ * mfp[i];
    const double sigma_t = free_path > 0 ? 1 / free_path : 0;
    const double a = albedoForDiffuseReflectance(r[i]);
    mp.sigma_s[i] = a * sigma_t;
    mp.sigma_a[i] = (1 - a) * sigma_t;
  }
  return mp;
}

MediumProperties SubsurfaceMedium::coefficients(const SampledWavelengths& lambda) const {
  // Textured: the integrators track a WalkMedium of coefficientsAt instead (volpath.cpp,
  // enterMedium); nothing reaches this, and it answers vacuum rather than a guess.
  if (material_) return {};
  if (!reflectance_) {
    MediumProperties mp;
    mp.sigma_a = clampZero(sigma_a_->sample(lambda) * scale_);
    mp.sigma_s = clampZero(sigma_s_->sample(lambda) * scale_);
    return mp;
  }
  return fromReflectance(reflectance_->sample(lambda), mfp_->sample(lambda));
}

MediumProperties SubsurfaceMedium::coefficientsAt(const Textures& textures,
                                                  const TextureEvalContext& ctx,
                                                  const SampledWavelengths& lambda) const {
  if (!material_) return coefficients(lambda);
  const scene::SubsurfaceParams& m = *material_;
  // pbrt-v4's GetBSSRDF: sigma_a, sigma_s clamped at zero; reflectance clamped to [0, 1] (by
  // albedoForDiffuseReflectance) with mfp; all times scale.
  if (from_reflectance_)
    return fromReflectance(
        textures.evalSpectrum(m.reflectance, ctx, lambda, SpectrumType::Albedo),
        textures.evalSpectrum(m.mfp, ctx, lambda, SpectrumType::Unbounded));
  MediumProperties mp;
  mp.sigma_a =
      clampZero(textures.evalSpectrum(m.sigma_a, ctx, lambda, SpectrumType::Unbounded) * scale_);
  mp.sigma_s =
      clampZero(textures.evalSpectrum(m.sigma_s, ctx, lambda, SpectrumType::Unbounded) * scale_);
  return mp;
}

MediumProperties SubsurfaceMedium::at(const Vec3&, const SampledWavelengths& lambda) const {
  return coefficients(lambda);
}

void SubsurfaceMedium::majorants(const Vec3&, const Vec3&, double tmax,
                                 const SampledWavelengths& lambda, const SegmentFn& fn) const {
  const MediumProperties mp = coefficients(lambda);
  fn(0, tmax, mp.sigma_a + mp.sigma_s);
}

}  // namespace lensim::render
