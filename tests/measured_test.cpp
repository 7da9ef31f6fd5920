// pbrt-v2's irregular isotropic measured BRDF: the .brdf reader (good and malformed files), the
// scattered interpolant and its table, MeasuredBxDF's sampling (chi-square), energy (white
// furnace), reciprocity and the colours of the two shared Cornell measurements.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "chi2.h"
#include "lensim/render/materials/measured.h"
#include "lensim/render/materials/microfacet.h"
#include "lensim/sampling/sampling.h"
#include "lensim/util/error.h"
#include "stats.h"

using namespace lensim;
using namespace lensim::render;
using namespace lensim::sampling;
using lensim::test::RunningStats;

namespace {

std::string sharedBrdf(const std::string& name) {
  return std::string(LENSIM_SHARED_DIR) + "/scenes/cs348b-hw3/brdfs/" + name;
}

#define REQUIRE_SHARED(path)                              \
  if (!std::filesystem::exists(path))                     \
  GTEST_SKIP() << "shared scene data not found (" << path \
               << "); the cs348b-hw3 scene lives in ../shared next to the checkout"

// A file in the test's temporary directory with the given content.
std::string writeTemp(const std::string& name, const std::string& content) {
  const auto dir = std::filesystem::temp_directory_path() / "lensim_measured_test";
  std::filesystem::create_directories(dir);
  const auto path = (dir / name).string();
  std::ofstream(path) << content;
  return path;
}

Vec3 direction(double theta, double phi) {
  return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

// Hero-wavelength sample whose first wavelength is lambda0_nm (the others are not checked).
SampledWavelengths heroAt(double lambda0_nm) {
  return SampledWavelengths::sampleUniform((lambda0_nm - kLambdaMin_nm) /
                                           (kLambdaMax_nm - kLambdaMin_nm));
}

const char* const kSmall =
    "# a small measured BRDF\n"
    "3   # wavelengths\n"
    "400 550 700\n"
    "# theta_i phi_i theta_o phi_o values\n"
    "0.5 0 0.5 3.14159265358979 0.1 0.2 0.3\n"
    "0.2 0 0.7 -1.0   0.05 -0.01 0.15  # negative clamps to 0\n";

}  // namespace

// ---------------------------------------------------------------------------------------------
// Reader

TEST(MeasuredReader, ReadsASmallFileWithComments) {
  const auto d = readIrregularBRDF(writeTemp("small.brdf", kSmall));
  ASSERT_EQ(d.wavelengths_nm, (std::vector<double>{400, 550, 700}));
  ASSERT_EQ(d.samples.size(), 2u);
  EXPECT_DOUBLE_EQ(d.samples[1].theta_i, 0.2);
  EXPECT_DOUBLE_EQ(d.samples[1].phi_o, -1.0);
  EXPECT_DOUBLE_EQ(d.sampleValues(0)[2], 0.3);
  EXPECT_DOUBLE_EQ(d.sampleValues(1)[0], 0.05);
  EXPECT_DOUBLE_EQ(d.sampleValues(1)[1], 0.0);
}

TEST(MeasuredReader, MalformedFilesNameTheLineTheValueAndWhatWasExpected) {
  struct Case {
    std::string name, text, loc, fragment;
  };
  const std::vector<Case> cases = {
      {"empty", "# nothing\n", ":1: error:", "expected the count of wavelengths"},
      {"count-word", "three\n400 500 600\n", ":1:1: error:", "'three' is not a number"},
      {"count-fraction", "2.5\n400 500\n", ":1:1:", "whole number"},
      {"count-zero", "0\n", ":1:1:", "whole number from 1 to 1000"},
      {"short-wavelengths", "3\n400 500\n", ":2:", "ends after 2 of the 3 wavelengths"},
      {"decreasing", "3\n400 500 450\n0 0 0 0 1 1 1\n", ":2:9:", "450 nm after 500 nm"},
      {"bad-wavelength", "2\n400 5OO\n", ":2:5:", "'5OO' is not a number; expected wavelength 2"},
      {"no-samples", "2\n400 500\n", ":2:", "no samples after the 2 wavelengths"},
      {"incomplete", "2\n400 500\n0.1 0 0.2 1 0.5 0.5\n0.3 0 0.2 1 0.5\n",
       ":4:1:", "sample 2 is incomplete: the file ends after 5 of its 6 numbers"},
      {"degrees", "2\n400 500\n0.1 0 45 1 0.5 0.5\n",
       ":3:7:", "theta_o of sample 1 is 45; expected radians in [0, pi/2]"},
      {"bad-value", "2\n400 500\n0.1 0 0.2 1 0.5 nan\n",
       ":3:17:", "'nan' is not a number; expected the BRDF value of sample 1 at 500 nm"},
      {"bad-angle", "2\n400 500\n0.1 x 0.2 1 0.5 0.5\n", ":3:5:", "expected phi_i of sample 1"},
  };
  for (const auto& c : cases) {
    const std::string path = writeTemp(c.name + ".brdf", c.text);
    try {
      readIrregularBRDF(path);
      ADD_FAILURE() << c.name << ": no error";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.rfind(path, 0), 0u) << c.name << ": " << what;
      EXPECT_NE(what.find(path + c.loc), std::string::npos) << c.name << ": " << what;
      EXPECT_NE(what.find(c.fragment), std::string::npos) << c.name << ": " << what;
    }
  }
  try {
    readIrregularBRDF("/nonexistent/dir/x.brdf");
    ADD_FAILURE() << "missing file: no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/dir/x.brdf: error: cannot open"),
              std::string::npos)
        << e.what();
  }
}

TEST(MeasuredReader, ReadsTheSharedCornellFiles) {
  for (const char* name : {"garnet_red.brdf", "krylon_blue.brdf"}) {
    const std::string path = sharedBrdf(name);
    REQUIRE_SHARED(path);
    const auto d = readIrregularBRDF(path);
    EXPECT_EQ(d.numWavelengths(), 31u) << name;
    EXPECT_DOUBLE_EQ(d.wavelengths_nm.front(), 400) << name;
    EXPECT_DOUBLE_EQ(d.wavelengths_nm.back(), 700) << name;
    EXPECT_EQ(d.samples.size(), 1439u) << name;
    // First row of both files: theta_i 0.872665, theta_s 0.573513.
    EXPECT_DOUBLE_EQ(d.samples[0].theta_i, 0.872665) << name;
    EXPECT_DOUBLE_EQ(d.samples[0].theta_o, 0.573513) << name;
  }
}

// ---------------------------------------------------------------------------------------------
// Interpolation

TEST(MeasuredInterpolation, ReproducesEverySampleAndIsSymmetric) {
  const std::string path = sharedBrdf("garnet_red.brdf");
  REQUIRE_SHARED(path);
  const auto brdf = MeasuredBRDF::loadCached(path);
  const auto& d = brdf->data();
  double worst = 0;
  for (std::size_t s = 0; s < d.samples.size(); ++s) {
    const auto& smp = d.samples[s];
    const auto v = brdf->interpolate(smp.theta_i, smp.theta_o, smp.phi_o - smp.phi_i);
    const auto sw = brdf->interpolate(smp.theta_o, smp.theta_i, smp.phi_i - smp.phi_o);
    for (std::size_t w = 0; w < d.numWavelengths(); ++w) {
      const double ref = d.sampleValues(s)[w];
      worst = std::max(worst, std::abs(v[w] - ref) / std::max(ref, 1e-6));
      EXPECT_NEAR(sw[w], v[w], 1e-12 * std::max(1.0, v[w]));
    }
  }
  EXPECT_LT(worst, 1e-6);
}

TEST(MeasuredInterpolation, TableMatchesTheSamples) {
  // The table (2 x 2 x 5 degrees, trilinear) against the measurements, in each material's
  // bright band (garnet 600 nm, krylon 450 nm). It cannot hit them exactly: beyond the grid
  // spacing, the data are not reciprocal near grazing (e.g. garnet at 600 nm: 0.0080 for
  // theta_i 80, theta_o 50.2 degrees, 0.0136 for the nearly swapped 50, 79.05), so the symmetric
  // interpolant has steep ridges between such pairs and the table averages them; samples at
  // theta_i = 80 degrees (the largest measured, next to the 0.5-degree-wide grazing highlight)
  // are reported but not bounded.
  for (auto [name, w] : {std::pair{"garnet_red.brdf", 20}, {"krylon_blue.brdf", 5}}) {
    const std::string path = sharedBrdf(name);
    REQUIRE_SHARED(path);
    const auto brdf = MeasuredBRDF::loadCached(path);
    const auto& d = brdf->data();
    std::vector<double> rel, rel80;
    for (std::size_t s = 0; s < d.samples.size(); ++s) {
      const auto& smp = d.samples[s];
      const double ref = d.sampleValues(s)[w];
      const double t = brdf->lookup(smp.theta_i, smp.theta_o, smp.phi_o - smp.phi_i, w);
      (smp.theta_i < 75 * kPi / 180 ? rel : rel80)
          .push_back(std::abs(t - ref) / std::max(ref, 1e-3));
    }
    std::sort(rel.begin(), rel.end());
    std::sort(rel80.begin(), rel80.end());
    const double median = rel[rel.size() / 2], p95 = rel[rel.size() * 95 / 100];
    RecordProperty(fmt::format("{}_table_rel_error_median", name), fmt::format("{:.3g}", median));
    RecordProperty(fmt::format("{}_table_rel_error_p95", name), fmt::format("{:.3g}", p95));
    RecordProperty(fmt::format("{}_table_rel_error_max", name), fmt::format("{:.3g}", rel.back()));
    RecordProperty(fmt::format("{}_table_rel_error_median_theta_i_80", name),
                   fmt::format("{:.3g}", rel80[rel80.size() / 2]));
    EXPECT_LT(median, 0.01) << name;
    EXPECT_LT(p95, 0.08) << name;
    EXPECT_LT(rel.back(), 0.3) << name;
  }
}

TEST(MeasuredInterpolation, VariesSmoothlyBetweenSamples) {
  // Along arcs through and between measured configurations the interpolant has no jumps: with
  // steps of 0.02 degrees no step changes the value by more than a small fraction of the range
  // seen along the arc (a jump would show up as one large step however fine the steps).
  const std::string path = sharedBrdf("garnet_red.brdf");
  REQUIRE_SHARED(path);
  const auto brdf = MeasuredBRDF::loadCached(path);
  const double deg = kPi / 180;
  struct Arc {
    double ti0, to0, p0, ti1, to1, p1;
  };
  const std::vector<Arc> arcs = {
      {30 * deg, 0, 180 * deg, 30 * deg, 85 * deg, 180 * deg},  // through the highlight
      {20 * deg, 40 * deg, 0, 20 * deg, 40 * deg, 180 * deg},   // around in azimuth
      {0, 45 * deg, 90 * deg, 89 * deg, 45 * deg, 90 * deg},    // theta_i beyond the data
      {15 * deg, 15 * deg, 170 * deg, 75 * deg, 75 * deg, 170 * deg}};
  const int steps = 4000;
  for (const Arc& a : arcs) {
    double lo = 1e30, hi = 0, max_step = 0, prev = 0, prev_t = 0;
    for (int i = 0; i <= steps; ++i) {
      const double t = double(i) / steps;
      const double ti = a.ti0 + t * (a.ti1 - a.ti0), to = a.to0 + t * (a.to1 - a.to0),
                   p = a.p0 + t * (a.p1 - a.p0);
      const double v = brdf->interpolate(ti, to, p)[25];
      const double tv = brdf->lookup(ti, to, p, 25);
      lo = std::min(lo, v), hi = std::max(hi, v);
      if (i > 0) max_step = std::max({max_step, std::abs(v - prev), std::abs(tv - prev_t)});
      prev = v, prev_t = tv;
      ASSERT_GE(v, 0);
    }
    EXPECT_LT(max_step, 0.01 * (hi - lo) + 1e-9) << fmt::format(
        "arc ({},{},{})->({},{},{}) range [{:.4g},{:.4g}] max step {:.3g}", a.ti0 / deg,
        a.to0 / deg, a.p0 / deg, a.ti1 / deg, a.to1 / deg, a.p1 / deg, lo, hi, max_step);
  }
}

TEST(MeasuredInterpolation, WavelengthsBetweenAndBeyondTheTableAreInterpolatedAndHeld) {
  const auto brdf = MeasuredBRDF::loadCached(writeTemp("small2.brdf", kSmall));
  const auto w = brdf->wavelengthWeight(475);
  EXPECT_EQ(w.i0, 0u);
  EXPECT_EQ(w.i1, 1u);
  EXPECT_DOUBLE_EQ(w.t, 0.5);
  const auto below = brdf->wavelengthWeight(360), above = brdf->wavelengthWeight(830);
  EXPECT_EQ(below.i0, 0u);
  EXPECT_EQ(below.t, 0);
  EXPECT_EQ(above.i0, 2u);
  EXPECT_EQ(above.t, 0);
  // At the first sample's configuration, wavelength 475 nm is halfway between 0.1 and 0.2.
  const Vec3 wo = direction(0.5, kPi), wi = direction(0.5, 0);
  std::array<MeasuredBRDF::WavelengthWeight, kSpectrumSamples> ws = {w, below, above, w};
  const auto f = brdf->eval(wo, wi, ws);
  const double at400 = brdf->lookup(0.5, 0.5, kPi, 0), at550 = brdf->lookup(0.5, 0.5, kPi, 1);
  EXPECT_NEAR(f[0], 0.5 * (at400 + at550), 1e-6);
  EXPECT_NEAR(f[1], at400, 1e-6);
  EXPECT_NEAR(f[2], brdf->lookup(0.5, 0.5, kPi, 2), 1e-6);
  // The node (0.5 rad is not a node) is near the sample: the table value is close to 0.1.
  EXPECT_NEAR(brdf->interpolate(0.5, 0.5, kPi)[0], 0.1, 1e-12);
}

// ---------------------------------------------------------------------------------------------
// BxDF

namespace {

std::vector<Vec3> outgoing() {
  return {direction(0.05, 0.3), direction(0.6, 2.0), direction(1.1, 4.0), direction(1.45, 1.0)};
}

}  // namespace

TEST(MeasuredBxDF, ChiSquareGoodnessOfFit) {
  // The shared harness (bins uniform in cos theta and absolute phi). Its per-bin quadrature
  // cannot integrate the tabulated lobe's piecewise-constant density precisely enough where that
  // density is very concentrated (the grazing highlight: most of the probability in one 1 x 3
  // degree cell), so grazing wo is tested by the aligned test below.
  const std::string path = sharedBrdf("krylon_blue.brdf");
  REQUIRE_SHARED(path);
  const MeasuredBxDF b(MeasuredBRDF::loadCached(path), SampledWavelengths::sampleUniform(0.3));
  const std::vector<Vec3> wos = {direction(0.05, 0.3), direction(0.6, 2.0), direction(1.1, 4.0)};
  const double alpha = 0.01 / double(wos.size());
  uint64_t seed = 1;
  for (const Vec3& wo : wos) {
    const auto r =
        lensim::test::chi2TestBxDF(b, wo, TransportMode::Radiance, 200000, seed++, 10, 20, 128);
    const std::string where = fmt::format("wo.z={:.3f}: {}", wo.z, r.summary());
    EXPECT_GT(r.p_value, alpha) << where;
    EXPECT_EQ(r.impossible_samples, 0) << where;
    EXPECT_LT(r.max_eval_mismatch, 1e-9) << where;
    EXPECT_NEAR(r.pdf_integral, 1.0, 2e-3) << where;
    RecordProperty(fmt::format("p_value_woz_{:.3f}", wo.z), fmt::format("{:.3g}", r.p_value));
  }
}

TEST(MeasuredBxDF, ChiSquareOnTheLobeCells) {
  // Bins aligned with the tabulated lobe's cells: cos theta_i in 64 steps, azimuth relative to wo
  // in 128 steps over [-pi, pi). In each bin the lobe density is constant and the cosine part
  // linear in cos theta_i, so pdf at the bin centre times the bin's solid angle is its exact
  // probability: no quadrature error, whatever the concentration. Both materials, wo from
  // normal to grazing (theta_o 87 degrees, beyond the last measured 80).
  const int nx = MeasuredBRDF::kLobeCos, np = 2 * MeasuredBRDF::kLobePhi, n = 400000;
  int runs = 0;
  for (const char* name : {"garnet_red.brdf", "krylon_blue.brdf"}) {
    const std::string path = sharedBrdf(name);
    REQUIRE_SHARED(path);
    const MeasuredBxDF b(MeasuredBRDF::loadCached(path), SampledWavelengths::sampleUniform(0.7));
    uint64_t seed = 77;
    for (double theta_o : {0.0, 0.3, 0.9, 1.25, 1.4, 1.52}) {
      const Vec3 wo = direction(theta_o, 0.8);
      const double phi_o = std::atan2(wo.y, wo.x);
      std::vector<double> observed(std::size_t(nx) * np + 1, 0.0), expected(observed.size(), 0.0);
      Rng rng(seed++, 0);
      for (int i = 0; i < n; ++i) {
        const double uc = rng.uniform();
        const auto s = b.sample_f(wo, uc, {rng.uniform(), rng.uniform()}, TransportMode::Radiance);
        if (!s || s->wi.z <= 0) {
          observed.back() += 1;
          continue;
        }
        double rel = std::atan2(s->wi.y, s->wi.x) - phi_o;
        rel -= 2 * kPi * std::floor((rel + kPi) / (2 * kPi));  // [-pi, pi)
        const int ix = std::min(nx - 1, int(s->wi.z * nx));
        const int ip = std::clamp(int((rel + kPi) / (2 * kPi) * np), 0, np - 1);
        observed[std::size_t(ix) * np + ip] += 1;
      }
      double total = 0;
      for (int ix = 0; ix < nx; ++ix)
        for (int ip = 0; ip < np; ++ip) {
          const double x = (ix + 0.5) / nx, rel = -kPi + 2 * kPi * (ip + 0.5) / np;
          const double sx = std::sqrt(1 - x * x);
          const Vec3 wi(sx * std::cos(phi_o + rel), sx * std::sin(phi_o + rel), x);
          const double pr = b.pdf(wo, wi, TransportMode::Radiance) * (1.0 / nx) * (2 * kPi / np);
          expected[std::size_t(ix) * np + ip] = pr * n;
          total += pr;
        }
      expected.back() = std::max(0.0, 1 - total) * n;
      double chi2 = 0, po = 0, pe = 0;
      int kept = 0;
      for (std::size_t k = 0; k < observed.size(); ++k) {
        if (expected[k] < 5) {
          po += observed[k], pe += expected[k];
          continue;
        }
        chi2 += (observed[k] - expected[k]) * (observed[k] - expected[k]) / expected[k];
        ++kept;
      }
      if (pe > 0) chi2 += (po - pe) * (po - pe) / pe, ++kept;
      const int dof = std::max(1, kept - 1);
      const double p = lensim::test::chi2PValue(chi2, dof);
      EXPECT_NEAR(total, 1.0, 1e-3) << name << " theta_o " << theta_o;
      EXPECT_GT(p, 0.01 / 12) << fmt::format("{} theta_o {}: chi2 {:.1f} dof {}", name, theta_o,
                                             chi2, dof);
      RecordProperty(fmt::format("{}_theta_o_{}_p", name, theta_o), fmt::format("{:.3g}", p));
      ++runs;
    }
  }
  EXPECT_EQ(runs, 12);
}

TEST(MeasuredBxDF, ReciprocalAndIsotropic) {
  const std::string path = sharedBrdf("garnet_red.brdf");
  REQUIRE_SHARED(path);
  const MeasuredBxDF b(MeasuredBRDF::loadCached(path), SampledWavelengths::sampleUniform(0.6));
  Rng rng(7, 0);
  for (int i = 0; i < 2000; ++i) {
    const Vec3 wo = sampleUniformHemisphere({rng.uniform(), rng.uniform()});
    const Vec3 wi = sampleUniformHemisphere({rng.uniform(), rng.uniform()});
    const auto a = b.f(wo, wi, TransportMode::Radiance), c = b.f(wi, wo, TransportMode::Radiance);
    // Rotating both directions about the normal, or mirroring them, changes nothing.
    const double rot = 2 * kPi * rng.uniform(), cr = std::cos(rot), sr = std::sin(rot);
    auto rotate = [&](const Vec3& w) {
      return Vec3(cr * w.x - sr * w.y, sr * w.x + cr * w.y, w.z);
    };
    const auto r = b.f(rotate(wo), rotate(wi), TransportMode::Radiance);
    const auto m = b.f(Vec3(wo.x, -wo.y, wo.z), Vec3(wi.x, -wi.y, wi.z), TransportMode::Radiance);
    // Both below the surface (two-sided use): the same value.
    const auto below =
        b.f(Vec3(wo.x, wo.y, -wo.z), Vec3(wi.x, wi.y, -wi.z), TransportMode::Radiance);
    for (int k = 0; k < kSpectrumSamples; ++k) {
      const double tol = 1e-9 * std::max(1.0, a[k]);
      EXPECT_NEAR(a[k], c[k], tol);
      EXPECT_NEAR(a[k], r[k], 1e-6 * std::max(1.0, a[k]));
      EXPECT_NEAR(a[k], m[k], 1e-6 * std::max(1.0, a[k]));
      EXPECT_NEAR(a[k], below[k], tol);
      EXPECT_GE(a[k], 0);
    }
    // Opposite hemispheres: no transmission.
    EXPECT_TRUE(b.f(wo, Vec3(wi.x, wi.y, -wi.z), TransportMode::Radiance).isBlack());
  }
  // At normal incidence the azimuth of wi is irrelevant.
  const Vec3 n(0, 0, 1);
  const auto ref = b.f(n, direction(0.7, 0), TransportMode::Radiance);
  for (double phi : {0.5, 1.7, 3.0, 4.4})
    for (int k = 0; k < kSpectrumSamples; ++k)
      EXPECT_NEAR(b.f(n, direction(0.7, phi), TransportMode::Radiance)[k], ref[k], 1e-6 * ref[k]);
}

namespace {

// Directional albedo at each tabulated wavelength by cosine sampling (the BxDF's own sampling).
std::vector<RunningStats> albedo(const MeasuredBRDF& brdf, const Vec3& wo, int n, uint64_t seed) {
  std::vector<RunningStats> s(brdf.data().numWavelengths());
  Rng rng(seed, 0);
  for (int i = 0; i < n; ++i) {
    const Vec3 wi = sampleCosineHemisphere({rng.uniform(), rng.uniform()});
    const double ti = std::acos(wi.z), to = std::acos(wo.z);
    const double dphi = std::atan2(wi.y, wi.x) - std::atan2(wo.y, wo.x);
    for (std::size_t w = 0; w < s.size(); ++w) s[w].add(brdf.lookup(ti, to, dphi, w) * kPi);
  }
  return s;
}

}  // namespace

TEST(MeasuredBxDF, WhiteFurnaceAndPlausibleColours) {
  for (const char* name : {"garnet_red.brdf", "krylon_blue.brdf"}) {
    const std::string path = sharedBrdf(name);
    REQUIRE_SHARED(path);
    const auto brdf = MeasuredBRDF::loadCached(path);
    // Energy: albedo <= 1 at every wavelength for directions from normal to grazing.
    uint64_t seed = 100;
    for (const Vec3& wo : outgoing()) {
      const auto s = albedo(*brdf, wo, 20000, seed++);
      for (std::size_t w = 0; w < s.size(); ++w)
        EXPECT_LE(s[w].mean, 1.0 + 4.5 * s[w].stderror())
            << name << " wo.z=" << wo.z << " at " << brdf->data().wavelengths_nm[w] << " nm";
      RecordProperty(fmt::format("{}_albedo_woz_{:.3f}_450_550_650nm", name, wo.z),
                     fmt::format("{:.4f} {:.4f} {:.4f}", s[5].mean, s[15].mean, s[25].mean));
    }
    // Colour at normal incidence: garnet red reflects long wavelengths, krylon blue short.
    const auto s = albedo(*brdf, Vec3(0, 0, 1), 20000, 1);
    const double a450 = s[5].mean, a650 = s[25].mean;
    if (std::string(name) == "garnet_red.brdf") {
      EXPECT_GT(a650, 3 * a450) << name;
      EXPECT_GT(a650, 0.05) << name;
      EXPECT_LT(a650, 0.6) << name;
    } else {
      EXPECT_GT(a450, 3 * a650) << name;
      EXPECT_GT(a450, 0.05) << name;
      EXPECT_LT(a450, 0.6) << name;
    }
    // The BxDF itself (path wavelengths, its sampling) gives the same albedo: 450 nm hero.
    const MeasuredBxDF b(brdf, heroAt(450));
    RunningStats bs;
    Rng rng(3, 0);
    for (int i = 0; i < 20000; ++i) {
      const auto smp = b.sample_f(Vec3(0, 0, 1), rng.uniform(), {rng.uniform(), rng.uniform()},
                                  TransportMode::Radiance);
      bs.add(smp ? smp->f[0] * absCosTheta(smp->wi) / smp->pdf : 0.0);
    }
    EXPECT_NEAR(bs.mean, a450, 4.5 * std::hypot(bs.stderror(), s[5].stderror())) << name;
  }
}

TEST(MeasuredBxDF, SamplingAgreesWithUniformIntegrationAndBeatsCosineAtGrazing) {
  // E[f cos / pdf] under sample_f equals the albedo integrated with uniform directions, and the
  // tabulated lobe lowers the variance where the BRDF is peaked (grazing highlight).
  const std::string path = sharedBrdf("garnet_red.brdf");
  REQUIRE_SHARED(path);
  const auto brdf = MeasuredBRDF::loadCached(path);
  const MeasuredBxDF b(brdf, heroAt(650));
  uint64_t seed = 500;
  for (double theta_o : {0.2, 0.8, 1.2, 1.396}) {
    const Vec3 wo = direction(theta_o, 1.3);
    RunningStats own, uni, cosine;
    Rng rng(seed++, 0);
    for (int i = 0; i < 100000; ++i) {
      const auto s =
          b.sample_f(wo, rng.uniform(), {rng.uniform(), rng.uniform()}, TransportMode::Radiance);
      own.add(s ? s->f[0] * absCosTheta(s->wi) / s->pdf : 0.0);
      const Vec3 wu = sampleUniformHemisphere({rng.uniform(), rng.uniform()});
      uni.add(b.f(wo, wu, TransportMode::Radiance)[0] * wu.z / uniformHemispherePdf());
      const Vec3 wc = sampleCosineHemisphere({rng.uniform(), rng.uniform()});
      cosine.add(b.f(wo, wc, TransportMode::Radiance)[0] * kPi);
    }
    EXPECT_NEAR(own.mean, uni.mean, 4.5 * std::hypot(own.stderror(), uni.stderror()))
        << "theta_o " << theta_o;
    RecordProperty(fmt::format("albedo_650nm_theta_o_{}", theta_o),
                   fmt::format("{:.4f}", own.mean));
    RecordProperty(fmt::format("variance_ratio_cosine_over_lobe_theta_o_{}", theta_o),
                   fmt::format("{:.3g}", cosine.variance() / own.variance()));
    if (theta_o > 1.3) {
      EXPECT_LT(own.variance(), 0.5 * cosine.variance()) << "theta_o " << theta_o;
    }
  }
}
