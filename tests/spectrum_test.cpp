// Spectral sampling, colorimetry and RGB -> spectrum upsampling.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "lensim/render/spectra/spectrum.h"
#include "lensim/render/spectra/spectrum_data.h"
#include "lensim/util/error.h"

using namespace lensim;
using namespace lensim::render;

namespace {
std::string fmtG(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", v);
  return b;
}
double maxAbs(const Vec3& a) {
  return std::max({std::abs(a.x), std::abs(a.y), std::abs(a.z)});
}
}  // namespace

TEST(Cie1931, YIntegralAndWhitePointMatchPublishedValues) {
  // The integral of y-bar over 360..830 nm at 1 nm is 106.857 (CIE 15:2004; pbrt-v4 uses
  // 106.856895 from the 1 nm table; our 5 nm table interpolated linearly differs slightly).
  EXPECT_NEAR(cieYIntegral(), 106.857, 0.05);
  // D65 chromaticity: x = 0.31272, y = 0.32903 (CIE 15:2004 Table T.3, 2-degree observer).
  const Vec3 w = spectrumToXyz(*namedSpectrum("stdillum-D65"));
  EXPECT_NEAR(w.y, 1.0, 1e-12);  // normalised to Y = 1
  EXPECT_NEAR(w.x / (w.x + w.y + w.z), 0.31272, 2e-4);
  EXPECT_NEAR(w.y / (w.x + w.y + w.z), 0.32903, 2e-4);
}

TEST(RGBColorSpace, MatrixMatchesSrgbStandard) {
  // XYZ of the sRGB red primary per IEC 61966-2-1: (0.4124, 0.2126, 0.0193).
  const Vec3 red = RGBColorSpace::sRGB().toXyz({1, 0, 0});
  EXPECT_NEAR(red.x, 0.4124, 1e-3);
  EXPECT_NEAR(red.y, 0.2126, 1e-3);
  EXPECT_NEAR(red.z, 0.0193, 1e-3);
  const Vec3 back = RGBColorSpace::sRGB().toRgb(RGBColorSpace::sRGB().toXyz({0.2, 0.5, 0.7}));
  EXPECT_LT(maxAbs(back - Vec3(0.2, 0.5, 0.7)), 1e-12);
}

TEST(RGBIlluminantSpectrum, D65WhiteMapsToUnitRgb) {
  const auto& cs = RGBColorSpace::sRGB();
  const RGBIlluminantSpectrum white(cs, {1, 1, 1});
  const Vec3 rgb = cs.toRgb(spectrumToXyz(white));
  EXPECT_LT(maxAbs(rgb - Vec3(1, 1, 1)), 1e-9) << rgb.x << " " << rgb.y << " " << rgb.z;
  // A coloured emitter keeps its colour (to the precision of the fit).
  const RGBIlluminantSpectrum orange(cs, {4.0, 1.5, 0.3});
  const Vec3 o = cs.toRgb(spectrumToXyz(orange));
  EXPECT_LT(maxAbs(o - Vec3(4.0, 1.5, 0.3)), 4.0 * 2e-3);
}

TEST(RGBAlbedoSpectrum, RandomInGamutColoursRoundTrip) {
  // Reflectance lit by D65, integrated against the CIE observer, converted to linear sRGB:
  // must give back the RGB we asked for.
  const auto& cs = RGBColorSpace::sRGB();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  double worst = 0, sum = 0;
  const int n = 300;
  for (int i = 0; i < n; ++i) {
    const Vec3 rgb(u(rng), u(rng), u(rng));
    const RGBAlbedoSpectrum s(cs, rgb);
    const Vec3 xyz = spectrumToXyz(PiecewiseLinearSpectrum(
        [&] {
          std::vector<double> l;
          for (int k = 360; k <= 830; ++k) l.push_back(k);
          return l;
        }(),
        [&] {
          std::vector<double> v;
          for (int k = 360; k <= 830; ++k) v.push_back(s.eval(k) * cs.illuminant()->eval(k));
          return v;
        }()));
    const double err = maxAbs(cs.toRgb(xyz) - rgb);
    worst = std::max(worst, err);
    sum += err;
  }
  RecordProperty("worst_rgb_error", fmtG(worst));
  RecordProperty("mean_rgb_error", fmtG(sum / n));
  EXPECT_LT(sum / n, 1e-4);
  EXPECT_LT(worst, 1e-3);
}

TEST(RGBColorSpace, TableLookupIsCloseToExactFit) {
  // The interpolated table (for textures) reproduces random colours to about 1e-3.
  const auto& cs = RGBColorSpace::sRGB();
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  double worst = 0, sum = 0;
  const int n = 200;
  for (int i = 0; i < n; ++i) {
    const Vec3 rgb(u(rng), u(rng), u(rng));
    const SigmoidPolynomial p = cs.tableSigmoid(rgb);
    Vec3 xyz;
    for (int l = 360; l <= 830; ++l) xyz += cieXyzBar(l) * (p.eval(l) * cs.illuminant()->eval(l));
    const double err = maxAbs(cs.toRgb(xyz / cieYIntegral()) - rgb);
    worst = std::max(worst, err);
    sum += err;
    for (double l = kLambdaMin_nm; l <= kLambdaMax_nm; l += 10) {
      ASSERT_GE(p.eval(l), 0.0);
      ASSERT_LE(p.eval(l), 1.0);
    }
  }
  RecordProperty("table_worst_rgb_error", fmtG(worst));
  RecordProperty("table_mean_rgb_error", fmtG(sum / n));
  EXPECT_LT(sum / n, 2e-3);
  EXPECT_LT(worst, 1e-2);
  // Greys are exact constants.
  EXPECT_NEAR(cs.tableSigmoid({0.3, 0.3, 0.3}).eval(500), 0.3, 1e-12);
}

TEST(RGBAlbedoSpectrum, StaysInUnitInterval) {
  const auto& cs = RGBColorSpace::sRGB();
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < 200; ++i) {
    const Vec3 rgb(u(rng), u(rng), u(rng));
    const RGBAlbedoSpectrum s(cs, rgb);
    for (double l = kLambdaMin_nm; l <= kLambdaMax_nm; l += 2.5) {
      ASSERT_GE(s.eval(l), 0.0);
      ASSERT_LE(s.eval(l), 1.0);
    }
    EXPECT_LE(s.maxValue(), 1.0);
  }
  // Extremes: black, white, pure primaries.
  for (const Vec3& rgb :
       {Vec3(0, 0, 0), Vec3(1, 1, 1), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)}) {
    const RGBAlbedoSpectrum s(cs, rgb);
    for (double l = kLambdaMin_nm; l <= kLambdaMax_nm; l += 5) {
      EXPECT_GE(s.eval(l), 0.0);
      EXPECT_LE(s.eval(l), 1.0);
    }
  }
  EXPECT_THROW(RGBAlbedoSpectrum(cs, Vec3(1.5, 0, 0)), Error);
}

TEST(RGBUnboundedSpectrum, ScalesAboveOne) {
  const auto& cs = RGBColorSpace::sRGB();
  const RGBUnboundedSpectrum s(cs, {3.0, 3.0, 3.0});
  EXPECT_NEAR(s.eval(550), 3.0, 1e-12);
  const RGBUnboundedSpectrum z(cs, {0, 0, 0});
  EXPECT_EQ(z.eval(550), 0.0);
}

TEST(SampledWavelengths, UniformHeroSamplingIsStratifiedAndUnbiased) {
  // Hero wavelengths are spaced by 470/4 nm modulo the range; all pdfs are 1/470.
  for (double u : {0.0, 0.3, 0.99}) {
    const auto w = SampledWavelengths::sampleUniform(u);
    for (int i = 0; i < kSpectrumSamples; ++i) {
      EXPECT_GE(w.lambda(i), kLambdaMin_nm);
      EXPECT_LE(w.lambda(i), kLambdaMax_nm);
      EXPECT_DOUBLE_EQ(w.pdf(i), 1.0 / 470.0);
    }
  }
  // Monte Carlo XYZ of D65 converges to the quadrature value.
  const auto d65 = namedSpectrum("stdillum-D65");
  const Vec3 exact = spectrumToXyz(*d65);
  for (int which = 0; which < 2; ++which) {
    const int n = 20000;
    Vec3 sum, sum2;
    std::mt19937 rng(9 + which);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int i = 0; i < n; ++i) {
      const auto w = which == 0 ? SampledWavelengths::sampleUniform(u(rng))
                                : SampledWavelengths::sampleVisible(u(rng));
      const Vec3 e = sampledToXyz(d65->sample(w), w);
      sum += e;
      sum2 += Vec3(e.x * e.x, e.y * e.y, e.z * e.z);
    }
    const Vec3 mean = sum / n;
    for (int c = 0; c < 3; ++c) {
      const double var = sum2[c] / n - mean[c] * mean[c];
      const double se = std::sqrt(var / n);
      EXPECT_NEAR(mean[c], exact[c], 4 * se + 1e-3) << "sampler " << which << " channel " << c;
    }
  }
}

TEST(SampledWavelengths, VisiblePdfIntegratesToOne) {
  double sum = 0;
  for (double l = kLambdaMin_nm; l < kLambdaMax_nm; l += 0.01)
    sum += SampledWavelengths::visiblePdf(l + 0.005) * 0.01;
  EXPECT_NEAR(sum, 1.0, 1e-6);
}

TEST(SampledWavelengths, TerminateSecondaryKeepsHeroOnly) {
  auto w = SampledWavelengths::sampleUniform(0.25);
  const double pdf0 = w.pdf(0);
  w.terminateSecondary();
  EXPECT_TRUE(w.secondaryTerminated());
  EXPECT_DOUBLE_EQ(w.pdf(0), pdf0 / kSpectrumSamples);
  EXPECT_EQ(w.pdf(1), 0.0);
}

TEST(BlackbodySpectrum, PeaksAtOneAtWienWavelength) {
  const BlackbodySpectrum b(6500);
  const double peak = 2.8977721e-3 / 6500 * 1e9;
  EXPECT_NEAR(b.evalExact(peak), 1.0, 1e-12);
  EXPECT_NEAR(b.eval(peak), 1.0, 6e-6);  // the 1 nm table's bound (TabulatedBlackbody...)
  EXPECT_LT(b.eval(peak - 20), 1.0);
  EXPECT_LT(b.eval(peak + 20), 1.0);
  // A 6504 K blackbody is close to D65's white: chromaticity within 0.01.
  const Vec3 xyz = spectrumToXyz(BlackbodySpectrum(6504));
  EXPECT_NEAR(xyz.x / (xyz.x + xyz.y + xyz.z), 0.3135, 0.01);
}

TEST(NamedSpectrum, MetalsHavePlausibleNormalReflectance) {
  // Normal-incidence reflectance ((n-1)^2 + k^2) / ((n+1)^2 + k^2) at 450 and 650 nm:
  // gold and copper reflect red far more than blue; silver and aluminium are near-neutral and high.
  auto refl = [](const std::string& metal, double l) {
    const double n = namedSpectrum("metal-" + metal + "-eta")->eval(l);
    const double k = namedSpectrum("metal-" + metal + "-k")->eval(l);
    return ((n - 1) * (n - 1) + k * k) / ((n + 1) * (n + 1) + k * k);
  };
  EXPECT_GT(refl("Au", 650), refl("Au", 450) + 0.4);
  EXPECT_GT(refl("Cu", 650), refl("Cu", 450) + 0.3);
  EXPECT_GT(refl("Ag", 450), 0.85);
  EXPECT_GT(refl("Ag", 650), 0.9);
  EXPECT_GT(refl("Al", 450), 0.85);
  EXPECT_GT(refl("Al", 650), 0.85);
  for (const auto& name : namedSpectrumNames()) EXPECT_NE(namedSpectrum(name), nullptr) << name;
  EXPECT_EQ(namedSpectrum("metal-Unobtainium-eta"), nullptr);
}

TEST(NamedSpectrum, MetalsArePbrtV4sTables) {
  // metal-*-eta / -k mean what they mean in pbrt-v4: its tables (src/pbrt/util/spectrum.cpp,
  // Ag_eta ... Cu_k; the LuxPop values Mitsuba 0.5 ships as data/ior/*.spd). Values read off those
  // tables at their nodes, and linear interpolation between nodes (pbrt-v4's
  // PiecewiseLinearSpectrum).
  struct Node {
    const char* name;
    double lambda, value;
  };
  const Node nodes[] = {
      {"metal-Ag-eta", 551.040771, 0.124375}, {"metal-Ag-k", 551.040771, 3.348125},
      {"metal-Ag-eta", 399.948975, 0.173},    {"metal-Ag-k", 652.548279, 4.15},
      {"metal-Au-eta", 495.936707, 0.916},    {"metal-Au-k", 495.936707, 1.84},
      {"metal-Au-eta", 619.920898, 0.194},    {"metal-Au-k", 670.184753, 3.445812},
      {"metal-Cu-eta", 590.400818, 0.468},    {"metal-Cu-k", 590.400818, 2.809},
      {"metal-Cu-eta", 799.897949, 0.254188}, {"metal-Cu-k", 387.450562, 2.21},
      {"metal-Al-eta", 551.040771, 0.963},    {"metal-Al-k", 551.040771, 6.7},
      {"metal-Al-eta", 826.561157, 2.74},     {"metal-Al-k", 751.41925, 8.62},
      {"metal-MgO-eta", 589.258972, 1.73737}, {"metal-MgO-k", 589.258972, 0.0},
      {"metal-TiO2-eta", 499.919006, 3.03},   {"metal-TiO2-k", 334.990997, 0.788},
  };
  for (const Node& n : nodes)
    EXPECT_NEAR(namedSpectrum(n.name)->eval(n.lambda), n.value, 1e-9) << n.name << " " << n.lambda;
  // Half-way between Au_eta's nodes 495.936707 (0.916) and 506.057861 (0.7545).
  EXPECT_NEAR(namedSpectrum("metal-Au-eta")->eval(0.5 * (495.936707 + 506.057861)),
              0.5 * (0.916 + 0.7545), 1e-9);
  // The whole visible range is inside the tables (298.76 to 885.60 nm): no extrapolation.
  for (const char* m : {"Ag", "Al", "Au", "Cu"})
    for (double l = 360; l <= 830; l += 10) {
      EXPECT_GT(namedSpectrum(std::string("metal-") + m + "-eta")->eval(l), 0.05) << m << l;
      EXPECT_GT(namedSpectrum(std::string("metal-") + m + "-k")->eval(l), 1.0) << m << l;
    }
}

// ---------------------------------------------------------------------------------------------
// 1 nm tables and table-driven wavelength sampling (issue 29), each against the exact function
// written here.

namespace {
// Planck's law normalised to 1 at Wien's peak (CODATA 2010 constants, as pbrt-v4).
double planckNormalised(double lambda_nm, double t) {
  const double c = 299792458.0, h = 6.62606957e-34, kb = 1.3806488e-23;
  auto b = [&](double l_nm) {
    const double l = l_nm * 1e-9;
    return 2 * h * c * c / (std::pow(l, 5) * std::expm1(h * c / (l * kb * t)));
  };
  return b(lambda_nm) / b(2.8977721e-3 / t * 1e9);
}
// Off-grid wavelengths: every cell of the range at three fractions, and random ones.
std::vector<double> offGridWavelengths() {
  std::vector<double> l;
  for (int k = 360; k < 830; ++k)
    for (double f : {0.11, 0.5, 0.93}) l.push_back(k + f);
  std::mt19937 rng(29);
  std::uniform_real_distribution<double> u(360.0, 830.0);
  for (int i = 0; i < 2000; ++i) l.push_back(u(rng));
  l.push_back(360.0);
  l.push_back(830.0);
  return l;
}
}  // namespace

TEST(TabulatedBlackbody, WithinBoundOfPlancksLaw) {
  // Linear interpolation at 1 nm: |error| <= max|f''| / 8. Measured maxima (of the peak value 1):
  // 1.9e-6 at 3200 K, 5.0e-6 at 6500 K; the bound tested is 6e-6 for every temperature, and the
  // relative error where the value exceeds 1e-2 is under 1e-4.
  for (double t : {500.0, 1000.0, 2700.0, 3200.0, 5000.0, 6500.0, 10000.0, 40000.0}) {
    const BlackbodySpectrum b(t);
    double max_abs = 0, max_rel = 0;
    for (double l : offGridWavelengths()) {
      const double exact = planckNormalised(l, t), got = b.eval(l);
      max_abs = std::max(max_abs, std::abs(got - exact));
      if (exact > 1e-2) max_rel = std::max(max_rel, std::abs(got - exact) / exact);
    }
    EXPECT_LT(max_abs, 6e-6) << t << " K";
    EXPECT_LT(max_rel, 1e-4) << t << " K";
    EXPECT_GT(max_abs, 0.0) << t << " K";  // it is a table, not the formula
    // Outside the table the formula itself is used.
    EXPECT_NEAR(b.eval(300.5), planckNormalised(300.5, t), 1e-12 * planckNormalised(300.5, t));
    EXPECT_NEAR(b.eval(900.5), planckNormalised(900.5, t), 1e-12);
  }
}

TEST(TabulatedIlluminant, D65TableIsExactAndSampleMatchesEval) {
  // D65's knots are every 5 nm, so its 1 nm table interpolates it exactly. Reference: the raw
  // CIE table interpolated here, times the Y normalisation the colour space applies.
  const auto& cs = RGBColorSpace::sRGB();
  const auto d65 = cs.illuminant();
  const double norm = d65->eval(560.0) / 100.0;  // the table's value is 100 at 560 nm
  const double d65_5nm[] = {  // CIE 15:2004 D65, 360..400 nm (the first nine rows)
      46.6383, 49.3637, 52.0891, 51.0323, 49.9755, 52.3118, 54.6482, 68.7015, 82.7549};
  for (int k = 0; k < 8; ++k)
    for (double f : {0.0, 0.13, 0.5, 0.87}) {
      const double l = 360 + 5 * (k + f);
      const double want = norm * (d65_5nm[k] * (1 - f) + d65_5nm[k + 1] * f);
      EXPECT_NEAR(cs.illuminantTable()(l), want, 1e-6 * want) << l;
    }
  double max_err = 0;
  const RGBIlluminantSpectrum s(cs, Vec3(7, 6.6, 6));
  for (double l : offGridWavelengths()) {
    max_err = std::max(max_err, std::abs(cs.illuminantTable()(l) - d65->eval(l)) / d65->eval(l));
  }
  EXPECT_LT(max_err, 1e-13);
  // The four-at-once evaluation of every kind equals eval at each wavelength.
  const std::vector<SpectrumPtr> kinds = {
      std::make_shared<RGBIlluminantSpectrum>(cs, Vec3(7, 6.6, 6)),
      std::make_shared<RGBAlbedoSpectrum>(cs, Vec3(0.7, 0.08, 0.06)),
      std::make_shared<RGBUnboundedSpectrum>(cs, Vec3(3, 0.5, 0.1)),
      std::make_shared<BlackbodySpectrum>(3200), std::make_shared<ConstantSpectrum>(0.25),
      namedSpectrum("metal-Au-k"), d65};
  for (double u : {0.0, 0.2, 0.77, 0.999}) {
    const auto w = SampledWavelengths::sampleVisible(u);
    for (const auto& k : kinds) {
      const SampledSpectrum v = k->sample(w);
      for (int i = 0; i < kSpectrumSamples; ++i) EXPECT_EQ(v[i], k->eval(w.lambda(i)));
    }
  }
}

TEST(PiecewiseLinearSpectrum, IndexTableFindsTheBinarySearchSegment) {
  // Knots off the nm grid, several inside one nm, and ends inside the visible range; the value
  // must be that of a plain linear interpolation (written here) bit for bit.
  const std::vector<double> l = {398.2, 400.1, 400.2, 400.7, 401.5, 455.55, 455.56, 700.0, 801.3};
  const std::vector<double> v = {0.3, 0.9, 0.1, 0.5, 0.45, 2.0, 1.0, 0.25, 0.6};
  const PiecewiseLinearSpectrum s(l, v);
  auto interpolate = [](const std::vector<double>& l, const std::vector<double>& v, double x) {
    if (x <= l.front()) return v.front();
    if (x >= l.back()) return v.back();
    size_t i = 0;
    while (!(l[i] <= x && x < l[i + 1])) ++i;
    const double t = (x - l[i]) / (l[i + 1] - l[i]);
    return v[i] * (1 - t) + v[i + 1] * t;
  };
  auto reference = [&](double x) { return interpolate(l, v, x); };
  std::vector<double> xs = offGridWavelengths();
  for (double k : l) {
    xs.push_back(k);
    xs.push_back(std::nextafter(k, 0.0));
    xs.push_back(std::nextafter(k, 1e9));
  }
  for (double x : {300.0, 359.9, 830.5, 900.0}) xs.push_back(x);
  for (double x : xs) EXPECT_EQ(s.eval(x), reference(x)) << x;
  // A metal table (pbrt-v4's gold, knots every few nm off the integer grid).
  std::vector<double> al, av;
  for (size_t i = 0; i < data::kAuK.size(); i += 2) {
    al.push_back(data::kAuK[i]);
    av.push_back(data::kAuK[i + 1]);
  }
  const auto au = namedSpectrum("metal-Au-k");
  for (double x : offGridWavelengths()) EXPECT_EQ(au->eval(x), interpolate(al, av, x)) << x;
}

TEST(SampledWavelengths, VisibleTableInvertsItsCdfExactly) {
  // The piecewise-constant density: cell k of [360 + k, 361 + k) has the mass of the smooth
  // density 1/cosh^2(0.0072 (lambda - 538)) over it (tanh differences, written here).
  const double a = 0.0072;
  auto T = [&](double l) { return std::tanh(a * (l - 538.0)); };
  const double tl = T(360), th = T(830);
  auto cdf = [&](double l) {
    const double k = std::floor(l);
    const double cell = (T(k + 1) - T(k)) / (th - tl);
    return (T(k) - tl) / (th - tl) + (l - k) * cell;
  };
  double max_rel_pdf = 0;
  for (int i = 0; i < 4000; ++i) {
    const double u = (i + 0.5) / 4000;
    const auto w = SampledWavelengths::sampleVisible(u);
    for (int j = 0; j < kSpectrumSamples; ++j) {
      double uj = u + 0.25 * j;
      if (uj >= 1) uj -= 1;
      const double l = w.lambda(j);
      ASSERT_GE(l, kLambdaMin_nm);
      ASSERT_LE(l, kLambdaMax_nm);
      EXPECT_NEAR(cdf(l), uj, 1e-12) << u << " " << j;
      const double k = std::floor(l);
      EXPECT_NEAR(w.pdf(j), (T(k + 1) - T(k)) / (th - tl), 1e-15);
      EXPECT_EQ(w.pdf(j), SampledWavelengths::visiblePdf(l));
      // The closed form sampleVisible replaced (atanh of the inverted tanh CDF) lands within
      // the same 1 nm cell.
      const double smooth = 538.0 + std::atanh(tl + uj * (th - tl)) / a;
      EXPECT_LT(std::abs(smooth - l), 1.0);
    }
  }
  // The cell average differs from the smooth density by at most 2a = 1.44 % (the slope of
  // log cosh^-2 over 1 nm).
  for (double l : offGridWavelengths()) {
    const double c = std::cosh(a * (l - 538.0));
    const double smooth = a / (th - tl) / (c * c);
    EXPECT_NEAR(SampledWavelengths::visiblePdfExact(l), smooth, 1e-15);
    max_rel_pdf = std::max(max_rel_pdf, std::abs(SampledWavelengths::visiblePdf(l) / smooth - 1));
  }
  EXPECT_LT(max_rel_pdf, 2 * a);
  EXPECT_GT(max_rel_pdf, 0.0);
}
