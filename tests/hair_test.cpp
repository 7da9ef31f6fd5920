// pbrt-v4's hair BSDF (render/materials/hair.h) against closed forms and statistics, in the
// manner of pbrt-v4's own hair tests (src/pbrt/bsdfs_test.cpp: WhiteFurnace, SamplingWeights,
// WhiteFurnaceSampled; its Reciprocity test is disabled there because the model is not
// reciprocal, so none is written here):
//  - white furnace: with sigma_a = 0, f |cos| integrates to 1 over the sphere for any wo, h,
//    roughness and scale tilt (uniform sphere directions, jittered-stratified);
//  - with absorption, at h = 0 and wo perpendicular to the fibre, the integral is the Fresnel and
//    Beer-Lambert series f + (1 - f)^2 T / (1 - T f), f = ((eta - 1) / (eta + 1))^2, T = e^(-2
//    sigma_a);
//  - sampling weights f |cos| / pdf are exactly 1 without absorption (perfect importance
//    sampling), the pdf integrates to 1, and a chi-square test of sample_f against pdf;
//  - the material's parameters as pbrt-v4's HairMaterial reads them, the curve's v as pbrt-v4's
//    curve intersection computes it, and renders under a uniform sky (a white-furnace render of
//    non-absorbing hair returns the sky; absorbing hair never exceeds it).
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <string>

#include "chi2.h"
#include "lensim/render/materials/hair.h"
#include "lensim/render/materials/materials.h"
#include "lensim/render/shapes/accel.h"
#include "lensim/render/textures/textures.h"
#include "lensim/sampling/sampling.h"
#include "render_test_util.h"

namespace lensim::render {

using namespace lensim::sampling;
namespace {

constexpr double kPi = std::numbers::pi;

/// Integral of f |cos| (or of the pdf) over the sphere: n x n jittered strata of uniform sphere
/// directions.
template <typename F>
double sphereIntegral(F&& g, int n, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> U(0, 1);
  double sum = 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const Vec2 u{(i + U(rng)) / n, (j + U(rng)) / n};
      sum += g(sampleUniformSphere(u));
    }
  return sum / (double(n) * n * uniformSpherePdf());
}

/// The BxDF with its fibre along +z instead of +x (a rotation: x, y, z -> y, z, x), so that the
/// chi-square test's bins (cos theta and phi about z) follow the fibre's longitudinal angle and
/// azimuth; about the fibre the density has a seam (its azimuth is undefined there) that
/// midpoint quadrature in bins crossing it misses.
class FibreAlongZ final : public BxDF {
 public:
  explicit FibreAlongZ(const BxDF& b) : b_(b) {}
  static Vec3 toFibre(const Vec3& w) { return {w.z, w.x, w.y}; }
  static Vec3 fromFibre(const Vec3& w) { return {w.y, w.z, w.x}; }
  BxDFFlags flags() const override { return b_.flags(); }
  SampledSpectrum f(const Vec3& wo, const Vec3& wi, TransportMode m) const override {
    return b_.f(toFibre(wo), toFibre(wi), m);
  }
  std::optional<BSDFSample> sample_f(const Vec3& wo, double uc, Vec2 u, TransportMode m,
                                     ReflTrans a) const override {
    auto bs = b_.sample_f(toFibre(wo), uc, u, m, a);
    if (bs) bs->wi = fromFibre(bs->wi);
    return bs;
  }
  double pdf(const Vec3& wo, const Vec3& wi, TransportMode m, ReflTrans a) const override {
    return b_.pdf(toFibre(wo), toFibre(wi), m, a);
  }

 private:
  const BxDF& b_;
};

struct HairCase {
  double h, beta_m, beta_n, alpha;
  Vec3 wo;
  std::string str() const {
    return fmt::format(
        "h={:.3f} beta_m={:.3f} beta_n={:.3f} alpha={:.2f} wo=({:.3f},{:.3f},{:.3f})", h, beta_m,
        beta_n, alpha, wo.x, wo.y, wo.z);
  }
};

/// Random cases: beta_m, beta_n in [0.1, 1], h in (-1, 1), alpha in [0, 5] degrees, wo uniform.
std::vector<HairCase> randomCases(int n, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> U(0, 1);
  std::vector<HairCase> cases;
  for (int i = 0; i < n; ++i) {
    HairCase c;
    c.h = -0.999 + 1.998 * U(rng);
    c.beta_m = 0.1 + 0.9 * U(rng);
    c.beta_n = 0.1 + 0.9 * U(rng);
    c.alpha = 5 * U(rng);
    const double a = U(rng), b = U(rng);
    c.wo = sampleUniformSphere({a, b});
    cases.push_back(c);
  }
  return cases;
}

TEST(HairBxDF, WhiteFurnaceIntegratesToOne) {
  // pbrt-v4's grid corners plus random cases; 800 x 800 strata each.
  std::vector<HairCase> cases = randomCases(6, 7);
  cases.push_back({0.3, 0.1, 0.1, 0, normalize(Vec3{0.3, 0.5, 0.8})});
  cases.push_back({-0.8, 0.9, 0.9, 2, normalize(Vec3{-0.6, 0.1, 0.3})});
  cases.push_back({0.0, 0.1, 0.9, 2, normalize(Vec3{0.9, 0.1, 0.2})});
  double worst = 0;
  for (const HairCase& c : cases) {
    const HairBxDF hair(c.h, 1.55, SampledSpectrum(0.0), c.beta_m, c.beta_n, c.alpha);
    const double I = sphereIntegral(
        [&](const Vec3& wi) {
          return hair.f(c.wo, wi, TransportMode::Radiance).average() * std::abs(wi.z);
        },
        800, 11);
    EXPECT_NEAR(I, 1.0, 0.01) << c.str();
    worst = std::max(worst, std::abs(I - 1));
  }
  RecordProperty("worst_furnace_error", fmt::format("{:.4f}", worst));
}

TEST(HairBxDF, AbsorbingFurnaceIsTheFresnelBeerLambertSeries) {
  // At h = 0 with wo perpendicular to the fibre the first hit is at normal incidence and every
  // chord is a diameter (2 radii): the lobes' weights are f, (1-f)^2 T, (1-f)^2 T^2 f, ... and
  // each lobe integrates to 1.
  const double eta = 1.55, f = std::pow((eta - 1) / (eta + 1), 2);
  SampledSpectrum sigma;
  sigma[0] = 0.1, sigma[1] = 0.5, sigma[2] = 1.0, sigma[3] = 3.0;
  const HairBxDF hair(0.0, eta, sigma, 0.4, 0.5, 2);
  const Vec3 wo = normalize(Vec3{0, 0.6, 0.8});
  for (int i = 0; i < kSpectrumSamples; ++i) {
    const double I = sphereIntegral(
        [&](const Vec3& wi) { return hair.f(wo, wi, TransportMode::Radiance)[i] * std::abs(wi.z); },
        500, 3);
    const double T = std::exp(-2 * sigma[i]);
    EXPECT_NEAR(I, f + (1 - f) * (1 - f) * T / (1 - T * f), 0.01) << "sigma_a=" << sigma[i];
  }
}

TEST(HairBxDF, SamplingWeightsAreOneWithoutAbsorption) {
  // pbrt-v4's SamplingWeights: beta_m 0.1..0.9, beta_n 0.4..0.9, random h and wo.
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> U(0, 1);
  int samples = 0, none = 0;
  double worst = 0;
  for (double beta_m = 0.1; beta_m < 1; beta_m += 0.2)
    for (double beta_n = 0.4; beta_n < 1; beta_n += 0.2)
      for (int i = 0; i < 2000; ++i) {
        const HairBxDF hair(-1 + 2 * U(rng), 1.55, SampledSpectrum(0.0), beta_m, beta_n, 2);
        const double a = U(rng), b = U(rng);
        const Vec3 wo = sampleUniformSphere({a, b});
        const double uc = U(rng), u0 = U(rng), u1 = U(rng);
        const auto bs = hair.sample_f(wo, uc, {u0, u1}, TransportMode::Radiance);
        if (!bs || !(bs->pdf > 0)) {
          ++none;
          continue;
        }
        ++samples;
        const double w = bs->f.average() * std::abs(bs->wi.z) / bs->pdf;
        worst = std::max(worst, std::abs(w - 1));
        ASSERT_NEAR(w, 1, 1e-9) << "beta_m=" << beta_m << " beta_n=" << beta_n;
        EXPECT_NEAR(length(bs->wi), 1, 1e-12);
      }
  EXPECT_LT(none, samples / 1000);
  RecordProperty("worst_weight_error", fmt::format("{:.3g}", worst));
}

TEST(HairBxDF, PdfIntegratesToOneAndMatchesSampleFChiSquare) {
  std::vector<HairCase> cases = randomCases(5, 21);
  for (HairCase& c : cases) {  // lobes wider than a bin
    c.beta_m = std::max(c.beta_m, 0.25);
    c.beta_n = std::max(c.beta_n, 0.3);
  }
  cases.push_back({0.5, 0.3, 0.3, 2, normalize(Vec3{0.2, 0.4, 0.9})});  // pbrt-v4's defaults
  const double alpha = 0.01 / double(cases.size());                     // Bonferroni
  double min_p = 1, worst_integral = 0;
  std::string p_values;
  uint64_t seed = 100;
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> U(0, 2);
  for (const HairCase& c : cases) {
    SampledSpectrum sigma;
    for (int i = 0; i < kSpectrumSamples; ++i) sigma[i] = U(rng);
    const HairBxDF hair(c.h, 1.55, sigma, c.beta_m, c.beta_n, c.alpha);
    const double I = sphereIntegral(
        [&](const Vec3& wi) { return hair.pdf(c.wo, wi, TransportMode::Radiance); }, 600, 13);
    EXPECT_NEAR(I, 1.0, 0.02) << c.str();
    worst_integral = std::max(worst_integral, std::abs(I - 1));
    const auto r = lensim::test::chi2TestBxDF(FibreAlongZ(hair), FibreAlongZ::fromFibre(c.wo),
                                              TransportMode::Radiance, 200000, seed++, 16, 32, 24);
    EXPECT_GT(r.p_value, alpha) << c.str() << ": " << r.summary();
    EXPECT_EQ(r.impossible_samples, 0) << c.str();
    EXPECT_LT(r.max_eval_mismatch, 1e-9) << c.str();
    min_p = std::min(min_p, r.p_value);
    p_values += fmt::format("{}{:.3g}", p_values.empty() ? "" : " ", r.p_value);
  }
  RecordProperty("min_p_value", fmt::format("{:.3g}", min_p));
  RecordProperty("p_values", p_values);
  RecordProperty("worst_pdf_integral_error", fmt::format("{:.4f}", worst_integral));
}

TEST(HairBxDF, AbsorptionFromReflectanceAndMelanin) {
  // Chiang et al. 2016's inversion as pbrt-v4 writes it: at beta_n = 0.3 the divisor is
  // 5.969 - 0.0645 + 0.22788 - 0.28971 + 0.0451494 + 0.00059535.
  const double d =
      5.969 - 0.215 * 0.3 + 2.532 * 0.09 - 10.73 * 0.027 + 5.574 * 0.0081 + 0.245 * 0.00243;
  SampledSpectrum c;
  c[0] = 0.5, c[1] = 0.1, c[2] = 1.0, c[3] = 0.0;
  const SampledSpectrum s = HairBxDF::sigmaAFromReflectance(c, 0.3);
  EXPECT_NEAR(s[0], std::pow(std::log(0.5) / d, 2), 1e-12);
  EXPECT_NEAR(s[1], std::pow(std::log(0.1) / d, 2), 1e-12);
  EXPECT_EQ(s[2], 0.0);
  EXPECT_EQ(s[3], INFINITY);  // black: nothing gets through
  const Vec3 m = HairBxDF::sigmaAFromConcentration(1.3, 0.5);
  EXPECT_NEAR(m.x, 1.3 * 0.419 + 0.5 * 0.187, 1e-12);
  EXPECT_NEAR(m.z, 1.3 * 1.37 + 0.5 * 1.05, 1e-12);
  // Infinite absorption leaves only the surface reflection R.
  const HairBxDF black(0.2, 1.55, SampledSpectrum(INFINITY), 0.3, 0.3, 0);
  const Vec3 wo = normalize(Vec3{0.1, 0.5, 0.8});
  const double I = sphereIntegral(
      [&](const Vec3& wi) {
        return black.f(wo, wi, TransportMode::Radiance).average() * std::abs(wi.z);
      },
      400, 1);
  const double cos_theta_o = std::sqrt(1 - 0.01 / dot(Vec3{0.1, 0.5, 0.8}, Vec3{0.1, 0.5, 0.8}));
  EXPECT_NEAR(I, frDielectric(cos_theta_o * std::sqrt(1 - 0.04), 1.55), 0.01);
}

// ---- the material and the curve --------------------------------------------------------------

const char* kView = R"(LookAt 0 0 5  0 0 0  0 1 0
Camera "orthographic" "float screenwindow" [-2 2 -2 2]
Film "rgb" "integer xresolution" 32 "integer yresolution" 32 "string filename" "h.exr"
Sampler "independent" "integer pixelsamples" 64
)";

TEST(HairMaterial, ParametersAsPbrtV4Reads) {
  const scene::Scene s = testutil::buildText(std::string(kView) + R"(WorldBegin
Material "hair"
Material "hair" "rgb sigma_a" [0.1 0.2 0.3] "float eumelanin" 2
Material "hair" "rgb color" [0.5 0.5 0.5] "float beta_m" 0.5 "float beta_n" 0.7
Material "hair" "rgb reflectance" [0.3 0.3 0.3] "float pheomelanin" 1
Material "hair" "float pheomelanin" 0.5 "float eta" 1.4 "float alpha" 0
Shape "sphere"
)");
  ASSERT_EQ(testutil::errorsOf(s), "");
  using A = scene::HairParams::Absorption;
  auto hair = [&](size_t i) -> const scene::HairParams& { return s.materials[i].as<scene::HairParams>(); };
  ASSERT_GE(s.materials.size(), 5u);
  const auto& m = s.materials;
  EXPECT_EQ(m[0].type, "hair");
  EXPECT_EQ(hair(0).absorption, A::Melanin);
  EXPECT_EQ(hair(0).eumelanin.value, 1.3);  // pbrt-v4's default
  EXPECT_EQ(hair(0).eta.value, 1.55);
  EXPECT_EQ(hair(0).beta_m.value, 0.3);
  EXPECT_EQ(hair(0).beta_n.value, 0.3);
  EXPECT_EQ(hair(0).alpha.value, 2);
  EXPECT_EQ(hair(1).absorption, A::SigmaA);
  EXPECT_EQ(hair(2).absorption, A::Reflectance);  // pbrt-v3's "color"
  EXPECT_EQ(hair(2).beta_m.value, 0.5);
  EXPECT_EQ(hair(3).absorption, A::Reflectance);
  EXPECT_EQ(hair(4).absorption, A::Melanin);
  EXPECT_EQ(hair(4).eumelanin.value, 0);
  EXPECT_EQ(hair(4).pheomelanin.value, 0.5);
  EXPECT_EQ(hair(4).eta.value, 1.4);
  int ignored = 0;
  for (const Diagnostic& d : s.diagnostics) {
    EXPECT_EQ(d.message.find("not rendered"), std::string::npos) << d.str();
    if (d.message.find("is ignored since") != std::string::npos) ++ignored;
  }
  EXPECT_EQ(ignored, 2);  // eumelanin beside sigma_a, pheomelanin beside reflectance
}

TEST(HairMaterial, BxDFAtAPointIsPbrtV4sHair) {
  const scene::Scene s = testutil::buildText(std::string(kView) + R"(WorldBegin
Material "hair" "rgb color" [0.5 0.5 0.5] "float beta_m" 0.5 "float beta_n" 0.7 "float alpha" 3
Shape "sphere"
Material "hair" "float beta_m" 2 "float beta_n" 0 "rgb sigma_a" [0.25 0.25 0.25]
Shape "sphere"
)");
  ASSERT_EQ(testutil::errorsOf(s), "");
  const Textures tx(s);
  const Materials mats(s, tx);
  SampledWavelengths lambda = SampledWavelengths::sampleUniform(0.3);
  const TextureEvalContext ctx{{0, 0, 0}, {0.4, 0.8}, {0, 0, 1}};
  const Vec3 wo = normalize(Vec3{0.3, 0.2, 0.9});
  // The reflectance's grey spectrum is flat 0.5; h = -1 + 2 v = 0.6.
  {
    auto b = mats.bxdf(s.shapes[0].material, ctx, lambda);
    const SampledSpectrum sigma = HairBxDF::sigmaAFromReflectance(SampledSpectrum(0.5), 0.7);
    const HairBxDF ref(0.6, 1.55, sigma, 0.5, 0.7, 3);
    for (const Vec3& wi : {normalize(Vec3{-0.3, 0.5, 0.2}), normalize(Vec3{0.1, -0.9, 0.3})}) {
      const SampledSpectrum a = b->f(wo, wi, TransportMode::Radiance),
                            e = ref.f(wo, wi, TransportMode::Radiance);
      for (int i = 0; i < kSpectrumSamples; ++i) EXPECT_NEAR(a[i], e[i], 1e-3 * e[i]);
      EXPECT_NEAR(b->pdf(wo, wi, TransportMode::Radiance), ref.pdf(wo, wi, TransportMode::Radiance),
                  1e-6);
    }
  }
  // beta_m and beta_n clamped to [0.01, 1] as pbrt-v4's GetBxDF does.
  {
    auto b = mats.bxdf(s.shapes[1].material, ctx, lambda);
    const HairBxDF ref(0.6, 1.55, SampledSpectrum(0.25), 1.0, 0.01, 2);
    const Vec3 wi = normalize(Vec3{-0.3, 0.5, 0.2});
    EXPECT_NEAR(b->pdf(wo, wi, TransportMode::Radiance), ref.pdf(wo, wi, TransportMode::Radiance),
                1e-9);
  }
}

TEST(HairMaterial, CurveVIsPbrtV4sEdgeFunctionSide) {
  // pbrt-v4's curve intersection: v = 0.5 -/+ distance / width with the sign of the edge
  // function (pc x dpc/dw).z in ray space, pc the curve point relative to the ray. Curves along
  // +x seen from above (ray direction -z): a hit at +y from the axis has pc = (0, -y) and tangent
  // (1, 0) in the ray's plane up to a rotation about z, so the edge function is -y < 0 and
  // v = 0.5 - y / width; at -y it is 0.5 + y / width.
  const scene::Scene s = testutil::buildText(std::string(kView) + R"(WorldBegin
Shape "curve" "point3 P" [-1 0 0  -0.3333333 0 0  0.3333333 0 0  1 0 0] "float width" 0.2
Shape "curve" "point3 P" [-1 1 0  -0.3333333 1 0  0.3333333 1 0  1 1 0] "float width" 0.2
  "string type" "cylinder"
Shape "curve" "point3 P" [-1 -1 0  -0.3333333 -1 0  0.3333333 -1 0  1 -1 0] "float width" 0.2
  "string type" "ribbon" "normal N" [0 0.6 0.8  0 0.6 0.8]
)");
  ASSERT_EQ(testutil::errorsOf(s), "");
  const Accel accel(s);
  for (double y0 : {0.0, 1.0})
    for (double dy : {0.05, -0.05, 0.08}) {
      const auto h = accel.intersect({{0.5, y0 + dy, 3}, {0, 0, -1}, INFINITY});
      ASSERT_TRUE(h) << y0 << " " << dy;
      EXPECT_NEAR(h->uv.y, 0.5 - dy / 0.2, 2e-3) << "curve at y=" << y0 << ", offset " << dy;
    }
  // Seen from below the same offsets change side.
  const auto below = accel.intersect({{0.5, 0.05, -3}, {0, 0, 1}, INFINITY});
  ASSERT_TRUE(below);
  EXPECT_NEAR(below->uv.y, 0.75, 2e-3);
  // The ribbon (normal (0, 0.6, 0.8)) spans 0.2 * 0.8 in y seen from above: a hit 0.04 off its
  // middle is half-way to its edge.
  const auto r = accel.intersect({{0.5, -1 + 0.04, 3}, {0, 0, -1}, INFINITY});
  ASSERT_TRUE(r);
  EXPECT_NEAR(r->uv.y, 0.25, 5e-3);
}

// Curves across the whole screen under a uniform sky; returns the mean of the sky-only margin
// and of the rows the curves cover.
struct SkyAndHair {
  double sky, hair;
};
SkyAndHair renderHair(const std::string& material, const std::string& type) {
  const std::string text = std::string(kView) + R"(Integrator "path" "integer maxdepth" 100
WorldBegin
LightSource "infinite" "rgb L" [1 1 1]
)" + material + "\n" +
                           fmt::format(R"(Shape "curve" "string type" "{0}" "float width" 0.25
  "point3 P" [-3 0.125 0  -1 0.125 0  1 0.125 0  3 0.125 0] {1}
Shape "curve" "string type" "{0}" "float width" 0.25
  "point3 P" [-3 -0.125 0.1  -1 -0.125 0.1  1 -0.125 0.1  3 -0.125 0.1] {1}
)",
                                       type,
                                       type == "ribbon" ? R"("normal N" [0 0 1  0 0 1])" : "");
  const io::Image im = testutil::renderText(text).image;
  // Rows 14..17 of 32 lie within |y| < 0.25 (the two curves); rows 0..7 are sky.
  SkyAndHair r{0, 0};
  for (int c = 0; c < 3; ++c) {
    r.sky += testutil::regionMean(im, c, 0, 32, 0, 8) / 3;
    r.hair += testutil::regionMean(im, c, 0, 32, 14, 18) / 3;
  }
  return r;
}

TEST(HairMaterial, WhiteHairInAWhiteFurnaceRendersTheSky) {
  for (const char* type : {"flat", "cylinder", "ribbon"}) {
    const SkyAndHair r = renderHair(R"(Material "hair" "rgb sigma_a" [0 0 0])", type);
    ASSERT_GT(r.sky, 0.1);
    EXPECT_NEAR(r.hair / r.sky, 1.0, 0.02) << type;
    RecordProperty(fmt::format("furnace_render_{}", type), fmt::format("{:.4f}", r.hair / r.sky));
  }
}

TEST(HairMaterial, AbsorbingHairIsDarkerThanTheSky) {
  const SkyAndHair brown = renderHair(R"(Material "hair")", "cylinder");  // eumelanin 1.3
  EXPECT_LT(brown.hair, 0.9 * brown.sky);
  EXPECT_GT(brown.hair, 0.0);
  const SkyAndHair black = renderHair(R"(Material "hair" "float eumelanin" 8)", "cylinder");
  EXPECT_LT(black.hair, brown.hair);
  RecordProperty("brown_over_sky", fmt::format("{:.4f}", brown.hair / brown.sky));
  RecordProperty("black_over_sky", fmt::format("{:.4f}", black.hair / black.sky));
}

}  // namespace
}  // namespace lensim::render
