// pbrt-v3's tabulated "fourier" BSDF (render/materials/fourier.h), on tables written here: a
// Lambertian reflector of albedo rho is a_0 = rho/pi |mu_i| for every reflection pair
// (mu_i mu_o < 0 in pbrt-v3's convention, mu_i the cosine of -wi) and nothing else, because the
// table stores f |mu_i| and a diffuse f is rho/pi at every angle. Its cdf rows are the
// Catmull-Rom integrals of a_0 (pbrt-v3 IntegrateCatmullRom). A Catmull-Rom spline reproduces a
// linear function exactly, so away from the kink of |mu_i| at 0 (the two nodes beside it) the
// interpolated f is rho/pi to float precision.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include <fmt/format.h>
#include "chi2.h"
#include "lensim/render/materials/fourier.h"
#include "lensim/render/spectra/spectrum.h"
#include "lensim/util/error.h"

using namespace lensim;
using namespace lensim::render;

namespace {

struct TableSpec {
  int n_mu = 21;          ///< nodes -1 .. 1, evenly spaced
  bool near_zero = true;  ///< and two more at +-0.001, so that the splines across the kink of
                          ///< |mu_i| at 0 (and the row mu_o = 0, empty) stay within +-0.001
  double rho[3] = {0.8, 0.8, 0.8};  ///< Y, R, B albedos
  int channels = 1;
  float eta = 1;
  bool transmit = false;  ///< also a Lambertian transmission of the same albedo
};

template <class T>
void put(std::string& s, T v) {
  char b[sizeof v];
  std::memcpy(b, &v, sizeof v);
  s.append(b, sizeof v);
}

std::vector<double> integrateCatmullRom(const std::vector<double>& x,
                                        const std::vector<double>& f) {
  std::vector<double> cdf{0.0};
  double sum = 0;
  const size_t n = x.size();
  for (size_t i = 0; i + 1 < n; ++i) {
    const double x0 = x[i], x1 = x[i + 1], f0 = f[i], f1 = f[i + 1], w = x1 - x0;
    const double d0 = i > 0 ? w * (f1 - f[i - 1]) / (x1 - x[i - 1]) : f1 - f0;
    const double d1 = i + 2 < n ? w * (f[i + 2] - f0) / (x[i + 2] - x0) : f1 - f0;
    sum += ((d0 - d1) / 12 + (f0 + f1) / 2) * w;
    cdf.push_back(sum);
  }
  return cdf;
}

std::string lambertTable(const TableSpec& spec) {
  std::vector<double> mu;
  for (int i = 0; i < spec.n_mu; ++i) mu.push_back(-1 + 2.0 * i / (spec.n_mu - 1));
  if (spec.near_zero) {
    mu.push_back(-0.001);
    mu.push_back(0.001);
    std::sort(mu.begin(), mu.end());
  }
  const int n = int(mu.size());
  std::vector<float> coeffs, cdf;
  std::vector<int32_t> pairs;
  for (int o = 0; o < n; ++o) {
    std::vector<double> row;
    for (int i = 0; i < n; ++i) {
      const bool refl = mu[size_t(i)] * mu[size_t(o)] < 0;
      const bool on = refl || (spec.transmit && mu[size_t(i)] * mu[size_t(o)] > 0);
      row.push_back(on ? spec.rho[0] / M_PI * std::abs(mu[size_t(i)]) : 0.0);
      if (on) {
        pairs.push_back(int32_t(coeffs.size()));
        pairs.push_back(1);
        for (int c = 0; c < spec.channels; ++c)
          coeffs.push_back(float(spec.rho[c] / M_PI * std::abs(mu[size_t(i)])));
      } else {
        pairs.push_back(0);
        pairs.push_back(0);
      }
    }
    for (double v : integrateCatmullRom(mu, row)) cdf.push_back(float(v));
  }
  std::string s("SCATFUN\x01", 8);
  for (int32_t v : {1, n, int32_t(coeffs.size()), 1, spec.channels, 1, 0, 0, 0}) put(s, v);
  put(s, spec.eta);
  for (int k = 0; k < 4; ++k) put(s, int32_t(0));
  for (double m : mu) put(s, float(m));
  for (float v : cdf) put(s, v);
  for (int32_t v : pairs) put(s, v);
  for (float v : coeffs) put(s, v);
  return s;
}

std::shared_ptr<const FourierBSDFTable> table(const TableSpec& spec) {
  return std::make_shared<const FourierBSDFTable>(
      FourierBSDFTable::parse(lambertTable(spec), "lambert.bsdf"));
}

Vec3 dir(double theta, double phi) {
  return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

const SampledWavelengths kLambda = SampledWavelengths::sampleUniform(0.3);

}  // namespace

TEST(FourierBSDF, LambertianTableEvaluatesToRhoOverPi) {
  const FourierBxDF bx(table({}), kLambda);
  double worst = 0;
  // mu_o >= 0.1 keeps its stencil (4 rows) off the empty row mu_o = 0; every mu_i < -0.001 is
  // on the straight part of |mu_i|.
  for (double to : {0.1, 0.5, 1.0, 1.4})
    for (double ti : {0.05, 0.6, 1.1, 1.41})
      for (double dphi : {0.0, 1.0, 2.5, 4.0}) {
        const Vec3 wo = dir(to, 0.3), wi = dir(ti, 0.3 + dphi);
        const SampledSpectrum f = bx.f(wo, wi, TransportMode::Radiance);
        for (int k = 0; k < kSpectrumSamples; ++k)
          worst = std::max(worst, std::abs(f[k] - 0.8 / M_PI));
        // Transmission: nothing; below the surface the reflection is there too (a table covers
        // both sides).
        EXPECT_EQ(bx.f(wo, Vec3(wi.x, wi.y, -wi.z), TransportMode::Radiance)[0], 0.0);
        EXPECT_NEAR(bx.f(-wo, -wi, TransportMode::Radiance)[0], 0.8 / M_PI, 1e-6);
      }
  std::printf("worst |f - rho/pi| %.3g\n", worst);
  EXPECT_LT(worst, 1e-6);
}

TEST(FourierBSDF, SamplingMatchesPdfChiSquare) {
  for (const bool transmit : {false, true}) {
    TableSpec spec;
    spec.transmit = transmit;
    spec.n_mu = 9;
    const FourierBxDF bx(table(spec), kLambda);
    uint64_t seed = 11;
    for (const Vec3& wo : {dir(0.3, 0.2), dir(1.2, 2.0), dir(2.5, -1.0)}) {
      const test::Chi2Result r =
          test::chi2TestBxDF(bx, wo, TransportMode::Radiance, 200000, seed++, 10, 20, 24);
      std::printf("transmit %d, wo.z %.2f: %s\n", int(transmit), wo.z, r.summary().c_str());
      EXPECT_GT(r.p_value, 1e-4) << r.summary();
      EXPECT_EQ(r.impossible_samples, 0);
      EXPECT_LT(r.max_eval_mismatch, 1e-4) << r.summary();
      EXPECT_NEAR(r.pdf_integral, 1, 0.01) << r.summary();
    }
  }
}

TEST(FourierBSDF, EnergyIsRhoAndNeverAboveOne) {
  // Directional albedo two ways: by quadrature of f cos over the sphere (midpoints in mu_i and
  // phi, f alone), and by the BSDF's own importance sampling, E[f cos / pdf]. Both are rho (the
  // spline departs from |mu_i| only within 0.001 of 0) and so never above 1 for rho = 0.99.
  for (const double rho : {0.8, 0.99}) {
    TableSpec spec;
    spec.rho[0] = spec.rho[1] = spec.rho[2] = rho;
    const FourierBxDF bx(table(spec), kLambda);
    for (const double theta : {0.0, 0.7, 1.3, 1.45}) {  // mu_o >= 0.1 (see above)
      const Vec3 wo = dir(theta, 0.4);
      double quad = 0;
      const int nm = 400, np = 64;
      for (int a = 0; a < nm; ++a)
        for (int b = 0; b < np; ++b) {
          const double z = -1 + (a + 0.5) * 2.0 / nm, phi = (b + 0.5) * 2 * M_PI / np;
          const double r = std::sqrt(1 - z * z);
          const Vec3 wi{r * std::cos(phi), r * std::sin(phi), z};
          quad +=
              bx.f(wo, wi, TransportMode::Radiance)[0] * std::abs(z) * (2.0 / nm) * (2 * M_PI / np);
        }
      double sum = 0;
      const int n = 20000;
      for (int i = 0; i < n; ++i) {
        const Vec2 u{(i + 0.5) / n, std::fmod((i + 0.5) * 0.6180339887498949, 1.0)};
        if (auto s = bx.sample_f(wo, 0.5, u, TransportMode::Radiance))
          sum += s->f[0] * std::abs(s->wi.z) / s->pdf;
      }
      const double albedo = sum / n;
      std::printf("rho %.2f theta %.2f: albedo %.5f (quadrature %.5f)\n", rho, theta, albedo, quad);
      EXPECT_NEAR(albedo, rho, 1e-3 * rho);
      EXPECT_NEAR(quad, rho, 2e-3 * rho);
      EXPECT_LE(albedo, 1.0);
      EXPECT_LE(quad, 1.0);
    }
  }
}

TEST(FourierBSDF, ThreeChannelsBecomeAnRgbSpectrum) {
  // Y, R, B all equal: green is 1.39829 Y - 0.100913 B - 0.297375 R = 1.000002 Y, a grey: the
  // spectrum equals the one-channel table's. Red above blue: the spectrum rises toward red.
  TableSpec grey;
  grey.channels = 3;
  const FourierBxDF g(table(grey), kLambda), mono(table({}), kLambda);
  const Vec3 wo = dir(0.4, 0), wi = dir(0.7, 2);
  const SampledSpectrum fg = g.f(wo, wi, TransportMode::Radiance),
                        fm = mono.f(wo, wi, TransportMode::Radiance);
  for (int k = 0; k < kSpectrumSamples; ++k) EXPECT_NEAR(fg[k], fm[k], 2e-3 * fm[k]);
  TableSpec red;
  red.channels = 3;
  red.rho[0] = 0.4, red.rho[1] = 0.9, red.rho[2] = 0.1;  // Y, R, B
  const SampledWavelengths lam = SampledWavelengths::sampleUniform(0.0);
  const FourierBxDF r(table(red), lam);
  const SampledSpectrum fr = r.f(wo, wi, TransportMode::Radiance);
  int lo = 0, hi = 0;
  for (int k = 0; k < kSpectrumSamples; ++k) {
    if (lam.lambda(k) < lam.lambda(lo)) lo = k;
    if (lam.lambda(k) > lam.lambda(hi)) hi = k;
  }
  std::printf("red table: f(%.0f nm) %.4f, f(%.0f nm) %.4f\n", lam.lambda(lo), fr[lo],
              lam.lambda(hi), fr[hi]);
  EXPECT_GT(fr[hi], 3 * fr[lo]);
}

TEST(FourierBSDF, TransmissionScalesRadianceByTheIndex) {
  // A transmitting table with eta 1.5: radiance going from outside (mu_o > 0) to inside is
  // scaled by 1/eta^2 (pbrt-v3: eta = 1/table eta when mu_i > 0), importance is not.
  TableSpec spec;
  spec.transmit = true;
  spec.eta = 1.5f;
  const FourierBxDF bx(table(spec), kLambda);
  const Vec3 wo = dir(0.5, 0), wi = dir(M_PI - 0.6, 1);  // mu_i = -wi.z > 0, mu_o > 0
  const double rad = bx.f(wo, wi, TransportMode::Radiance)[0];
  const double imp = bx.f(wo, wi, TransportMode::Importance)[0];
  EXPECT_NEAR(imp, 0.8 / M_PI, 1e-6);
  EXPECT_NEAR(rad, imp / (1.5 * 1.5), 1e-6);
  EXPECT_NEAR(bx.f(-wo, -wi, TransportMode::Radiance)[0], imp * 1.5 * 1.5, 1e-5);
}

TEST(FourierBSDF, CorruptTablesGiveLocatedErrors) {
  TableSpec spec;
  spec.near_zero = false;  // 21 nodes; 200 reflection pairs of 1 coefficient
  const std::string good = lambertTable(spec);
  auto message = [](const std::string& bytes) {
    try {
      FourierBSDFTable::parse(bytes, "t.bsdf");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  auto patched = [&](size_t at, auto value) {
    std::string s = good;
    std::memcpy(s.data() + at, &value, sizeof value);
    return s;
  };
  auto expect = [&](const std::string& bytes, const std::string& text) {
    const std::string m = message(bytes);
    EXPECT_NE(m.find(text), std::string::npos) << m;
    EXPECT_EQ(m.rfind("t.bsdf: error: byte ", 0), 0u) << m;
  };
  expect("tensor_file\0abc", "byte 0: not a pbrt-v3 tabulated BSDF");
  expect(good.substr(0, 30), "byte 30: the file ends after 30 bytes, inside the 64-byte header");
  expect(good.substr(0, good.size() - 1), "byte 12: the header's sizes (nMu 21, nCoeffs 200) need");
  expect(patched(8, int32_t(2)), "byte 8: flags 2; expected 1");
  expect(patched(12, int32_t(1 << 30)),
         "byte 12: the header's sizes (nMu 1073741824, nCoeffs 200)");
  expect(patched(20, int32_t(0)), "byte 20: highest Fourier order count mMax 0");
  expect(patched(24, int32_t(2)), "byte 24: 2 channels; expected 1");
  expect(patched(28, int32_t(3)), "byte 28: 3 basis functions");
  expect(patched(44, float(NAN)), "byte 44: relative index eta nan");
  expect(patched(64 + 4 * 5, float(2)), "byte 84: zenith node mu[5] = 2");
  expect(patched(64 + 4 * 5, float(-0.75)), "byte 84: zenith node mu[5] = -0.75 is not above");
  const size_t cdf0 = 64 + 4 * 21, pair0 = cdf0 + 4 * 21 * 21, coeff0 = pair0 + 8 * 21 * 21;
  expect(patched(cdf0 + 4 * 30, float(INFINITY)),
         fmt::format("byte {}: cdf value inf of row 1", cdf0 + 4 * 30));
  // Pair 36 is (mu_o -0.9, mu_i 0.5), a reflection pair with one coefficient.
  expect(patched(pair0 + 8 * 36, int32_t(200)),
         fmt::format("byte {}: pair (mu_o 1, mu_i 15) has coefficients 200 to 200, outside the 200",
                     pair0 + 288));
  expect(patched(pair0 + 8 * 36 + 4, int32_t(2)),
         fmt::format("byte {}: pair (mu_o 1, mu_i 15) has 2 orders; expected 0 to mMax (1)",
                     pair0 + 292));
  expect(patched(coeff0 + 4 * 7, float(NAN)),
         fmt::format("byte {}: coefficient 7 is nan", coeff0 + 28));
  EXPECT_EQ(message(good), "(accepted)");
}
