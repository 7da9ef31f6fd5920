// Per-hit spectrum evaluation (issue 29): the four-wavelength evaluations against formulas and
// interpolations written here, independently of render/spectra, and the per-thread cache of
// constant spectra (Textures::constantRef).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <thread>
#include <vector>

#include "lensim/render/spectra/spectrum.h"
#include "lensim/render/spectra/spectrum_data.h"
#include "lensim/render/textures/textures.h"
#include "lensim/scene/scene_values.h"
#include "scene_test_util.h"

namespace lensim::render {
namespace {

// Jakob & Hanika 2019: s(lambda) = 1/2 + t / (2 sqrt(1 + t^2)), t = c0 x^2 + c1 x + c2 with
// x = (lambda - 360) / 470; the limits 0 and 1 for t = -inf and +inf. In long double.
long double sigmoidReference(const std::array<double, 3>& c, double lambda_nm) {
  const long double x = (static_cast<long double>(lambda_nm) - 360.0L) / 470.0L;
  const long double t = c[0] * x * x + c[1] * x + c[2];
  if (std::isinf(t)) return t > 0 ? 1.0L : 0.0L;
  return 0.5L + t / (2.0L * std::sqrt(1.0L + t * t));
}

// Linear interpolation of a table with a value every 5 nm from 360 nm (95 rows).
long double lerp5nm(const double* values, size_t stride, double lambda_nm) {
  const long double f = (static_cast<long double>(lambda_nm) - 360.0L) / 5.0L;
  const size_t i = std::min<size_t>(static_cast<size_t>(f), 93);
  const long double t = f - static_cast<long double>(i);
  return values[i * stride] * (1 - t) + values[(i + 1) * stride] * t;
}

std::vector<SampledWavelengths> someWavelengths() {
  std::vector<SampledWavelengths> w;
  for (int i = 0; i < 200; ++i) {
    w.push_back(SampledWavelengths::sampleVisible((i + 0.37) / 200));
    w.push_back(SampledWavelengths::sampleUniform((i + 0.81) / 200));
  }
  w.push_back(SampledWavelengths::sampleUniform(0.0));  // 360 nm exactly
  w.push_back(SampledWavelengths::sampleVisible(std::nextafter(1.0, 0.0)));
  return w;
}

TEST(SigmoidPolynomialSample, FourWavelengthsMatchTheFormulaAndEval) {
  std::mt19937_64 rng(29);
  std::uniform_real_distribution<double> coef(-60.0, 60.0);
  std::vector<std::array<double, 3>> cs = {
      {0, 0, 0},
      {0, 0, std::numeric_limits<double>::infinity()},
      {0, 0, -std::numeric_limits<double>::infinity()},
      {0, 0, -0.3},
      {1e6, -1e6, 3e5},  // steep: values pinned near 0 and 1
  };
  for (int i = 0; i < 200; ++i) cs.push_back({coef(rng), coef(rng), coef(rng)});
  double max_err = 0;
  for (const auto& c : cs) {
    const SigmoidPolynomial poly{c};
    for (const auto& w : someWavelengths()) {
      const SampledSpectrum s = poly.sample(w);
      for (int i = 0; i < kSpectrumSamples; ++i) {
        const double want = static_cast<double>(sigmoidReference(c, w.lambda(i)));
        max_err = std::max(max_err, std::abs(s[i] - want));
        ASSERT_NEAR(s[i], want, 1e-12)
            << c[0] << " " << c[1] << " " << c[2] << " at " << w.lambda(i);
        // Bit for bit what eval gives (renders stay byte-identical).
        ASSERT_EQ(s[i], poly.eval(w.lambda(i)));
      }
    }
  }
  EXPECT_LT(max_err, 1e-13);
}

TEST(RGBIlluminantSpectrumSample, IsScaleTimesSigmoidTimesInterpolatedD65) {
  // D65 normalised to luminance 1: Y = sum over whole nm of y-bar D65 / sum of y-bar, both
  // interpolated linearly from the 5 nm CIE tables here.
  long double ybar_sum = 0, y = 0;
  for (int l = 360; l <= 830; ++l) {
    const long double yb = lerp5nm(&data::kCie1931_5nm[0][1], 3, l);
    ybar_sum += yb;
    y += yb * lerp5nm(data::kD65_5nm, 1, l);
  }
  const long double norm = ybar_sum / y;
  const auto& cs = RGBColorSpace::sRGB();
  double max_rel = 0;
  for (const Vec3& rgb : {Vec3(7, 6.6, 6), Vec3(0.2, 3, 0.5), Vec3(1, 1, 1), Vec3(0, 0, 0.4)}) {
    const RGBIlluminantSpectrum s(cs, rgb);
    const double scale = 2 * std::max({rgb.x, rgb.y, rgb.z});
    const SigmoidPolynomial poly = cs.fitSigmoid(rgb / scale);
    for (const auto& w : someWavelengths()) {
      const SampledSpectrum v = s.sample(w);
      for (int i = 0; i < kSpectrumSamples; ++i) {
        const double l = w.lambda(i);
        const long double want =
            scale * sigmoidReference(poly.c, l) * lerp5nm(data::kD65_5nm, 1, l) * norm;
        const double rel = static_cast<double>(std::abs(v[i] - want) / want);
        max_rel = std::max(max_rel, rel);
        ASSERT_LT(rel, 1e-9) << l;
        ASSERT_EQ(v[i], s.eval(l));
      }
    }
  }
  EXPECT_LT(max_rel, 1e-12);
}

TEST(RGBUnboundedSpectrumSample, IsScaleTimesSigmoid) {
  const auto& cs = RGBColorSpace::sRGB();
  const Vec3 rgb(3, 0.5, 0.1);
  const RGBUnboundedSpectrum s(cs, rgb);
  const SigmoidPolynomial poly = cs.fitSigmoid(rgb / 6.0);
  for (const auto& w : someWavelengths()) {
    const SampledSpectrum v = s.sample(w);
    for (int i = 0; i < kSpectrumSamples; ++i)
      ASSERT_NEAR(v[i], 6.0 * static_cast<double>(sigmoidReference(poly.c, w.lambda(i))), 1e-12);
  }
}

// Constant inputs of materials, looked up at every hit through the per-thread cache: the same
// spectrum as the shared Textures::constant, for more inputs than the direct-mapped table
// holds, in any order, from several threads, and never one of another Textures.
TEST(TexturesConstantRef, IsTheSharedConstantForManyInputsAndThreads) {
  const scene::Scene scene = testutil::buildText("WorldBegin\n");
  std::vector<scene::SpectrumValue> values(300);
  for (size_t i = 0; i < values.size(); ++i)
    values[i].rgb = {0.1 + 0.8 * double(i % 17) / 16, 0.2 + 0.7 * double(i % 5) / 4,
                     0.05 + 0.9 * double(i % 11) / 10};
  const SpectrumType types[] = {SpectrumType::Albedo, SpectrumType::Unbounded,
                                SpectrumType::Illuminant};
  const auto& cs = RGBColorSpace::sRGB();
  const SampledWavelengths w = SampledWavelengths::sampleVisible(0.37);
  auto check = [&](const Textures& tx, int pass, int& failures) {
    for (size_t k = 0; k < values.size(); ++k) {
      const size_t i = pass % 2 ? values.size() - 1 - k : (k * 7) % values.size();
      for (const SpectrumType type : types) {
        const Spectrum& s = tx.constantRef(values[i], type);
        if (&s != tx.constant(values[i], type).get()) ++failures;
        SampledSpectrum want;
        if (type == SpectrumType::Albedo) want = RGBAlbedoSpectrum(cs, values[i].rgb).sample(w);
        if (type == SpectrumType::Unbounded)
          want = RGBUnboundedSpectrum(cs, values[i].rgb).sample(w);
        if (type == SpectrumType::Illuminant)
          want = RGBIlluminantSpectrum(cs, values[i].rgb).sample(w);
        const SampledSpectrum got = s.sample(w);
        for (int j = 0; j < kSpectrumSamples; ++j)
          if (got[j] != want[j]) ++failures;
      }
    }
  };
  {
    const Textures tx(scene);
    int failures = 0;
    for (int pass = 0; pass < 3; ++pass) check(tx, pass, failures);
    EXPECT_EQ(failures, 0);
    int f1 = 0, f2 = 0;
    std::thread t1([&] {
      for (int pass = 0; pass < 3; ++pass) check(tx, pass, f1);
    });
    std::thread t2([&] {
      for (int pass = 1; pass < 4; ++pass) check(tx, pass, f2);
    });
    t1.join();
    t2.join();
    EXPECT_EQ(f1, 0);
    EXPECT_EQ(f2, 0);
  }
  // A new Textures (possibly at the same address) builds its own spectra; this thread's cache
  // holds the old object's entries and must not return them.
  const Textures tx2(scene);
  int failures = 0;
  check(tx2, 0, failures);
  EXPECT_EQ(failures, 0);
  const Spectrum& a = tx2.constantRef(values[3], SpectrumType::Albedo);
  EXPECT_EQ(&a, tx2.constant(values[3], SpectrumType::Albedo).get());
}

}  // namespace
}  // namespace lensim::render
