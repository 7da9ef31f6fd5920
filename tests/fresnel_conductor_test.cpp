// frComplex (conductor Fresnel, real arithmetic) against the complex-index Fresnel equations as
// pbrt-v4 writes them (FrComplex), transcribed here in long double complex arithmetic, and
// against closed forms at normal and grazing incidence and for a real index.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <complex>
#include <vector>

#include "lensim/render/materials/bsdf.h"

using namespace lensim;
using namespace lensim::render;

namespace {

// pbrt-v4 FrComplex(cosTheta_i, eta): s^2 = (1 - cos^2) / eta^2, cos_t = sqrt(1 - s^2),
// r_parl = (eta cos_i - cos_t) / (eta cos_i + cos_t), r_perp = (cos_i - eta cos_t) /
// (cos_i + eta cos_t), R = (|r_parl|^2 + |r_perp|^2) / 2.
long double referenceFresnel(long double c, long double eta, long double k) {
  using C = std::complex<long double>;
  const C n(eta, k);
  const C sin2_t = (1 - c * c) / (n * n);
  const C cos_t = std::sqrt(1.0L - sin2_t);
  const C r_parl = (n * c - cos_t) / (n * c + cos_t);
  const C r_perp = (c - n * cos_t) / (c + n * cos_t);
  return (std::norm(r_parl) + std::norm(r_perp)) / 2;
}

}  // namespace

TEST(FresnelConductor, MatchesComplexFormOverAGrid) {
  // Indices of metals (gold, silver, aluminium, chromium, copper in the visible), of glass with
  // k = 0 (both sides of the critical angle from eta < 1), and extremes.
  const std::vector<double> etas = {0.03, 0.13, 0.2, 0.5, 0.67, 0.9, 1.0, 1.1,
                                    1.38, 1.5, 2.4, 3.1, 5.0, 12.0, 40.0};
  const std::vector<double> ks = {0.0, 1e-6, 0.01, 0.3, 1.0, 1.91, 2.9, 4.1, 7.5, 20.0, 60.0};
  double worst = 0;
  int n = 0;
  for (size_t e = 0; e < etas.size(); e += 4) {
    // The four wavelengths carry four different (eta, k) pairs, so every lane is checked.
    for (size_t j = 0; j < ks.size(); ++j) {
      SampledSpectrum eta, k;
      for (int i = 0; i < kSpectrumSamples; ++i) {
        eta[i] = etas[(e + size_t(i)) % etas.size()];
        k[i] = ks[(j + size_t(i)) % ks.size()];
      }
      for (int m = 0; m <= 400; ++m) {
        const double c = m / 400.0;
        const SampledSpectrum r = frComplex(c, eta, k);
        for (int i = 0; i < kSpectrumSamples; ++i) {
          if (c == 0 && eta[i] == 1 && k[i] == 0) continue;  // 0/0 in both forms
          const double want = static_cast<double>(referenceFresnel(c, eta[i], k[i]));
          ASSERT_TRUE(std::isfinite(r[i])) << c << " " << eta[i] << " " << k[i];
          const double err = std::abs(r[i] - want);
          worst = std::max(worst, err);
          EXPECT_LE(err, 1e-13) << "cos " << c << " eta " << eta[i] << " k " << k[i] << ": "
                                << r[i] << " against " << want;
          EXPECT_GE(r[i], 0.0);
          EXPECT_LE(r[i], 1.0 + 1e-15);
          ++n;
        }
      }
    }
  }
  EXPECT_GT(n, 10000);
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", worst);
  RecordProperty("worst_abs_error", text);
}

TEST(FresnelConductor, ClosedForms) {
  SampledSpectrum eta, k;
  const double es[4] = {1.38, 0.13, 2.0, 1.5}, kk[4] = {1.91, 4.1, 0.0, 0.0};
  for (int i = 0; i < kSpectrumSamples; ++i) eta[i] = es[i], k[i] = kk[i];
  // Normal incidence: ((n - 1)^2 + k^2) / ((n + 1)^2 + k^2).
  const SampledSpectrum f1 = frComplex(1.0, eta, k);
  for (int i = 0; i < kSpectrumSamples; ++i) {
    const double n = eta[i], kv = k[i];
    EXPECT_NEAR(f1[i], ((n - 1) * (n - 1) + kv * kv) / ((n + 1) * (n + 1) + kv * kv), 1e-15);
  }
  // Grazing incidence reflects everything; cosines outside [0, 1] are clamped.
  const SampledSpectrum f0 = frComplex(0.0, eta, k);
  const SampledSpectrum fneg = frComplex(-0.3, eta, k);
  const SampledSpectrum fbig = frComplex(1.7, eta, k);
  for (int i = 0; i < kSpectrumSamples; ++i) {
    EXPECT_DOUBLE_EQ(f0[i], 1.0);
    EXPECT_EQ(fneg[i], f0[i]);
    EXPECT_EQ(fbig[i], f1[i]);
  }
  // A real index is the dielectric's Fresnel reflectance (frDielectric).
  for (double c : {0.05, 0.3, 0.7, 0.95}) {
    const SampledSpectrum f = frComplex(c, eta, k);
    EXPECT_NEAR(f[2], frDielectric(c, 2.0), 1e-15) << c;
    EXPECT_NEAR(f[3], frDielectric(c, 1.5), 1e-15) << c;
  }
}
