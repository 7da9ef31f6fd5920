// Light samplers (pbrt-v4's bvh, power, uniform and exhaustive): sample() and pmf() agree,
// chosen frequencies follow pmf() (chi-square), every light that can light a point has a
// non-zero probability there (so next-event estimation stays unbiased), closed forms for the
// direction-cone union and the importance of a single point light; and renders with each sampler
// agree within noise, and bvh lowers the error of a veach-mis-like scene.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "chi2.h"
#include "lensim/render/lights/lights.h"
#include "lensim/render/lights/lightsampler.h"
#include "lensim/render/shapes/accel.h"
#include "lensim/render/textures/textures.h"
#include "lensim/sampling/sampling.h"
#include "render_test_util.h"
#include "stats.h"

namespace lensim::render {

using namespace lensim::sampling;
namespace {

// Lights of every kind, of very different power, size and orientation.
const char* kLights = R"(
WorldBegin
LightSource "point" "point3 from" [0 2 0] "rgb I" [1 1 1]
LightSource "spot" "point3 from" [2 2 0] "point3 to" [2 0 0] "rgb I" [5 5 5] "float coneangle" 20
LightSource "infinite" "rgb L" [0.1 0.1 0.1]
LightSource "distant" "point3 from" [0 1 0] "point3 to" [0 0 0] "rgb L" [0.5 0.5 0.5]
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [40 40 40]
  Translate -2 1 0
  Shape "sphere" "float radius" 0.1
AttributeEnd
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [1 1 1]
  Translate 0 3 0
  Rotate 90 1 0 0
  Shape "disk" "float radius" 0.5
AttributeEnd
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [2 2 2] "bool twosided" true
  Shape "trianglemesh" "point3 P" [-3 0 -1  -3 0 1  -3 2 1  -3 2 -1]
        "integer indices" [0 1 2  0 2 3]
AttributeEnd
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [3 1 1]
  Shape "trianglemesh" "point3 P" [1 -1 -2  2 -1 -2  1.5 -0.5 -2] "integer indices" [0 1 2]
AttributeEnd
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [0.5 0.5 0.5] "bool twosided" true
  Translate 0 0 4
  Shape "cylinder" "float radius" 0.3
AttributeEnd
)";

struct Fixture {
  scene::Scene scene;
  Accel accel;
  Textures textures;
  LightSet lights;
  explicit Fixture(const std::string& sampler)
      : scene(testutil::buildText(std::string("Integrator \"path\" \"string lightsampler\" \"") +
                                  sampler + "\"\n" + kLights)),
        accel(scene),
        textures(scene),
        lights(scene, accel, textures) {}
};

// Pearson's chi-square of observed counts against expected counts, bins with an expected count
// under 5 pooled (as the BSDF chi2 tests do); the p-value.
double chi2Test(const std::vector<double>& observed, const std::vector<double>& expected) {
  double chi2 = 0, pooled_o = 0, pooled_e = 0;
  int dof = -1;
  for (size_t i = 0; i < observed.size(); ++i) {
    if (expected[i] < 5) {
      pooled_o += observed[i], pooled_e += expected[i];
      continue;
    }
    chi2 += (observed[i] - expected[i]) * (observed[i] - expected[i]) / expected[i];
    ++dof;
  }
  if (pooled_e >= 5) {
    chi2 += (pooled_o - pooled_e) * (pooled_o - pooled_e) / pooled_e;
    ++dof;
  } else if (pooled_o > 3 * pooled_e + 10) {
    return 0;  // counts where almost none were expected
  }
  return dof > 0 ? test::chi2PValue(chi2, dof) : 1.0;
}

LightSampleContext randomContext(Rng& rng) {
  const Vec3 p{rng.uniform() * 8 - 4, rng.uniform() * 6 - 2, rng.uniform() * 8 - 4};
  const Vec3 n = sampleUniformSphere({rng.uniform(), rng.uniform()});
  return {p, n};
}

class EachSampler : public ::testing::TestWithParam<std::string> {};

TEST_P(EachSampler, SampleAndPmfAgreeAndFrequenciesFollowPmf) {
  Fixture f(GetParam());
  ASSERT_EQ(f.lights.samplerName(), GetParam());
  const size_t n_lights = f.lights.size();
  ASSERT_EQ(n_lights, 10u);  // 4 + sphere + disk + 2 faces + 1 face + cylinder
  Rng rng(3, 5);
  int chi2_tests = 0;
  for (int c = 0; c < 40; ++c) {
    const LightSampleContext ctx = randomContext(rng);
    std::vector<double> pmf(n_lights);
    std::map<const Light*, size_t> index;
    double total = 0;
    for (size_t i = 0; i < n_lights; ++i) {
      index[&f.lights.light(i)] = i;
      pmf[i] = f.lights.pmf(ctx, &f.lights.light(i));
      EXPECT_GE(pmf[i], 0);
      total += pmf[i];
    }
    EXPECT_LE(total, 1 + 1e-9);
    if (GetParam() != "bvh") {
      EXPECT_NEAR(total, 1, 1e-9) << GetParam();
    }
    // sample() returns the pmf that pmf() gives, and chooses with those frequencies.
    const int n = 20000;
    std::vector<double> counts(n_lights, 0);
    int none = 0;
    for (int k = 0; k < n; ++k) {
      const double u = (k + rng.uniform()) / n;  // stratified
      auto s = f.lights.sample(ctx, u);
      if (!s) {
        ++none;
        continue;
      }
      const size_t i = index.at(s->light);
      ASSERT_NEAR(s->pmf, pmf[i], 1e-12 * (1 + pmf[i])) << GetParam() << " light " << i;
      counts[i] += 1;
    }
    EXPECT_NEAR(double(none) / n, 1 - total, 2e-3) << GetParam();
    std::vector<double> expected(n_lights);
    for (size_t i = 0; i < n_lights; ++i) expected[i] = pmf[i] * n;
    const double p = chi2Test(counts, expected);
    EXPECT_GT(p, 1e-4) << GetParam() << " context " << c;
    ++chi2_tests;
  }
  EXPECT_EQ(chi2_tests, 40);
}

// Unbiasedness: wherever a light sends light to the point (a sample of it has non-zero radiance
// and reaches the point's hemisphere... or either side: |cos| > 0), it must have a non-zero
// probability. Uniform and power pass trivially; bvh and exhaustive rest on the importance bound.
TEST_P(EachSampler, EveryLightThatContributesCanBeChosen) {
  Fixture f(GetParam());
  Rng rng(9, 1);
  SampledWavelengths lambda = SampledWavelengths::sampleUniform(0.37);
  int contributing = 0;
  for (int c = 0; c < 3000; ++c) {
    const LightSampleContext ctx = randomContext(rng);
    for (size_t i = 0; i < f.lights.size(); ++i) {
      const Light& light = f.lights.light(i);
      bool contributes = false;
      for (int k = 0; k < 16 && !contributes; ++k) {
        auto ls = light.sampleLi(ctx.p, {rng.uniform(), rng.uniform()}, lambda);
        contributes = ls && ls->pdf > 0 && !ls->L.isBlack() && std::abs(dot(ls->wi, ctx.n)) > 1e-9;
      }
      if (!contributes) continue;
      ++contributing;
      EXPECT_GT(f.lights.pmf(ctx, &light), 0) << GetParam() << " light " << i << " at (" << ctx.p.x
                                              << ", " << ctx.p.y << ", " << ctx.p.z << ")";
    }
  }
  EXPECT_GT(contributing, 10000);
}

INSTANTIATE_TEST_SUITE_P(LightSampler, EachSampler,
                         ::testing::Values("bvh", "power", "uniform", "exhaustive"));

TEST(LightSampler, PowerIsProportionalToPowerAndBvhFavoursTheNearLight) {
  // Two equal point lights and one 100x stronger far away: power picks by power only; the BVH
  // weighs by power / distance^2 (pbrt-v4's importance of a point: phi cos(theta') / d^2).
  const std::string text = R"(Integrator "path" "string lightsampler" "SAMPLER"
WorldBegin
LightSource "point" "point3 from" [0 0 1] "rgb I" [1 1 1]
LightSource "point" "point3 from" [0 0 -1] "rgb I" [1 1 1]
LightSource "point" "point3 from" [0 0 100] "rgb I" [100 100 100]
)";
  for (std::string name : {"power", "bvh", "exhaustive"}) {
    std::string t = text;
    t.replace(t.find("SAMPLER"), 7, name);
    scene::Scene s = testutil::buildText(t);
    Accel accel(s);
    Textures tex(s);
    LightSet lights(s, accel, tex);
    const LightSampleContext ctx{{0, 0, 0}, {0, 0, 0}};
    const double p0 = lights.pmf(ctx, &lights.light(0)), p1 = lights.pmf(ctx, &lights.light(1)),
                 p2 = lights.pmf(ctx, &lights.light(2));
    if (name == "power") {
      EXPECT_NEAR(p0, 1.0 / 102, 1e-12);
      EXPECT_NEAR(p2, 100.0 / 102, 1e-12);
    } else if (name == "exhaustive") {
      // importance = phi / max(d^2, |diagonal|/2) = 4 pi I / d^2 for points.
      const double w0 = 1, w1 = 1, w2 = 100.0 / (100 * 100);
      EXPECT_NEAR(p0, w0 / (w0 + w1 + w2), 1e-9);
      EXPECT_NEAR(p2, w2 / (w0 + w1 + w2), 1e-9);
    } else {
      // The tree's first split pairs some two lights; whichever it is, the far light ends with
      // far less than its power share, and the pmfs sum to 1.
      EXPECT_NEAR(p0 + p1 + p2, 1, 1e-12);
      EXPECT_LT(p2, 0.1);
      EXPECT_GT(p0, 0.3);
    }
  }
}

TEST(LightSampler, DirectionConeUnionClosedForms) {
  // Two 10-degree cones whose axes are 90 degrees apart: the union is a 55-degree cone about
  // the bisector; a cone inside another returns the outer one; opposite axes need the sphere.
  const double c10 = std::cos(10 * M_PI / 180);
  DirectionCone a{{1, 0, 0}, c10, false}, b{{0, 1, 0}, c10, false};
  DirectionCone u = unionCones(a, b);
  EXPECT_NEAR(u.cos_theta, std::cos(55 * M_PI / 180), 1e-12);
  EXPECT_NEAR(u.w.x, std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(u.w.y, std::sqrt(0.5), 1e-12);
  DirectionCone wide{{0, 0, 1}, std::cos(80 * M_PI / 180), false};
  DirectionCone narrow{{std::sin(0.2), 0, std::cos(0.2)}, std::cos(0.1), false};
  EXPECT_EQ(unionCones(wide, narrow).cos_theta, wide.cos_theta);
  EXPECT_EQ(unionCones(DirectionCone{}, narrow).cos_theta, narrow.cos_theta);
  DirectionCone down{{0, 0, -1}, c10, false}, up{{0, 0, 1}, c10, false};
  EXPECT_EQ(unionCones(up, down).cos_theta, -1);
  // Box subtended from outside: a unit sphere's bounding box (radius sqrt 3) seen from 10 away.
  Bounds3 box;
  box.extend({-1, -1, -1});
  box.extend({1, 1, 1});
  DirectionCone sub = boundSubtendedDirections(box, {10, 0, 0});
  EXPECT_NEAR(sub.cos_theta, std::sqrt(1 - 3.0 / 100), 1e-12);
  EXPECT_EQ(boundSubtendedDirections(box, {0.5, 0, 0}).cos_theta, -1);
}

TEST(LightSampler, ImportanceOfAOneSidedFaceIsZeroBehindIt) {
  // A one-sided emitter facing +z (cos theta_o = 1, theta_e = 90 degrees): points in front get
  // phi cos / d^2 (times the receiver's cosine), points well behind it get nothing.
  LightBounds lb;
  lb.bounds.extend({-0.01, -0.01, 0});
  lb.bounds.extend({0.01, 0.01, 0});
  lb.phi = 2;
  lb.w = {0, 0, 1};
  lb.cos_theta_o = 1;
  lb.cos_theta_e = 0;
  EXPECT_EQ(lb.importance({0, 0, -3}, {0, 0, 0}), 0);
  const double d = 3, front = lb.importance({0, 0, d}, {0, 0, 0});
  EXPECT_NEAR(front, 2 / (d * d), 1e-9);
  // A receiver normal perpendicular to the direction: the factor cos(theta_i - theta_b).
  const double side = lb.importance({0, 0, d}, {1, 0, 0});
  const double sin_b = std::sqrt(2 * 0.01 * 0.01) / d;
  EXPECT_NEAR(side / front, sin_b, 1e-6);
  lb.two_sided = true;
  EXPECT_NEAR(lb.importance({0, 0, -3}, {0, 0, 0}), front, 1e-12);
}

// ---- renders -------------------------------------------------------------------------------

// A scene in the spirit of Veach's multiple-importance-sampling scene (pbrt-v4-scenes'
// veach-mis): four spherical lights of radius 0.03 to 0.9 and equal power above glossy plates of
// different roughness, and a dim large light behind the camera.
std::string veachScene(const std::string& sampler, int res_x, int res_y) {
  return "LookAt 0 2 15  0 -3 3.5  0 1 0\nCamera \"perspective\" \"float fov\" 22\n"
         "Film \"rgb\" \"integer xresolution\" " +
         std::to_string(res_x) + " \"integer yresolution\" " + std::to_string(res_y) +
         " \"string filename\" \"veach.exr\"\n"
         "Sampler \"independent\"\n"
         "Integrator \"path\" \"integer maxdepth\" 3 \"string lightsampler\" \"" +
         sampler + "\"\n" + R"(
WorldBegin
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [800 800 800]
  Translate -3.75 0 0
  Shape "sphere" "float radius" 0.0333
AttributeEnd
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [100 60 30]
  Translate -1.25 0 0
  Shape "sphere" "float radius" 0.1
AttributeEnd
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [11 11 22]
  Translate 1.25 0 0
  Shape "sphere" "float radius" 0.3
AttributeEnd
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [1.2 1.5 1.2]
  Translate 3.75 0 0
  Shape "sphere" "float radius" 0.9
AttributeEnd
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [0.3 0.3 0.3]
  Translate 0 6 25
  Rotate 180 0 1 0
  Shape "trianglemesh" "point3 P" [-10 -10 0  10 -10 0  10 10 0  -10 10 0]
        "integer indices" [0 1 2  0 2 3]
AttributeEnd
Material "conductor" "spectrum eta" "metal-Ag-eta" "spectrum k" "metal-Ag-k" "float roughness" 0.02
Shape "trianglemesh" "point3 P" [-5 -3 4  5 -3 4  5 -2.7 2.5  -5 -2.7 2.5] "integer indices" [0 1 2  0 2 3]
Material "conductor" "spectrum eta" "metal-Ag-eta" "spectrum k" "metal-Ag-k" "float roughness" 0.08
Shape "trianglemesh" "point3 P" [-5 -3.5 5.5  5 -3.5 5.5  5 -3.05 4.1  -5 -3.05 4.1] "integer indices" [0 1 2  0 2 3]
Material "diffuse" "rgb reflectance" [0.4 0.4 0.4]
Shape "trianglemesh" "point3 P" [-20 -4 -10  20 -4 -10  20 -4 20  -20 -4 20] "integer indices" [0 1 2  0 2 3]
Shape "trianglemesh" "point3 P" [-20 -4 -2  20 -4 -2  20 20 -2  -20 20 -2] "integer indices" [0 1 2  0 2 3]
)";
}

io::Image renderVeach(const std::string& sampler, int spp, int seed, int rx = 40, int ry = 30) {
  render::RenderOptions o;
  o.spp = spp;
  o.seed = seed;
  return testutil::renderText(veachScene(sampler, rx, ry), o).image;
}

// Mean luminance of 4x3 blocks over several seeds, per sampler: every sampler must give the same
// image within noise (a per-block z-test between each sampler and bvh).
TEST(LightSamplerRender, AllSamplersRenderTheSameImageWithinNoise) {
  const int seeds = 6, spp = 8, bx = 4, by = 3, rx = 40, ry = 30;
  std::map<std::string, std::vector<test::RunningStats>> blocks;
  for (std::string name : {"bvh", "power", "uniform"}) {
    std::vector<test::RunningStats>& st = blocks[name];
    st.resize(bx * by);
    for (int seed = 0; seed < seeds; ++seed) {
      io::Image im = renderVeach(name, spp, 1000 * seed + 17, rx, ry);
      for (int b = 0; b < bx * by; ++b) {
        const int x0 = (b % bx) * rx / bx, y0 = (b / bx) * ry / by;
        double s = 0;
        for (int y = y0; y < y0 + ry / by; ++y)
          for (int x = x0; x < x0 + rx / bx; ++x) s += testutil::luminanceAt(im, x, y);
        st[size_t(b)].add(s / ((rx / bx) * (ry / by)));
      }
    }
  }
  for (std::string name : {"power", "uniform"})
    for (int b = 0; b < bx * by; ++b) {
      const auto &a = blocks["bvh"][size_t(b)], &c = blocks[name][size_t(b)];
      const double se = std::sqrt(a.variance() / a.n + c.variance() / c.n);
      const double z = std::abs(a.mean - c.mean) / std::max(se, 1e-6 * std::abs(a.mean));
      EXPECT_LT(z, 4.5) << name << " block " << b << ": " << a.mean << " vs " << c.mean;
    }
}

// Error at equal samples against a converged render: bvh must beat power clearly on this scene
// (lights of very different size and power: power-proportional choice wastes samples on lights
// that barely reach a point).
TEST(LightSamplerRender, BvhReducesErrorOnVeachLikeScene) {
  const int rx = 40, ry = 30;
  io::Image ref = renderVeach("bvh", 1024, 99, rx, ry);
  auto rmse = [&](const io::Image& im) {
    double s = 0;
    for (int y = 0; y < ry; ++y)
      for (int x = 0; x < rx; ++x)
        for (int c = 0; c < 3; ++c) {
          const double d = im.at(x, y, c) - ref.at(x, y, c);
          s += d * d;
        }
    return std::sqrt(s / (rx * ry * 3));
  };
  double e_bvh = 0, e_power = 0, e_uniform = 0;
  for (int seed = 1; seed <= 2; ++seed) {
    e_bvh += rmse(renderVeach("bvh", 16, seed, rx, ry));
    e_power += rmse(renderVeach("power", 16, seed, rx, ry));
    e_uniform += rmse(renderVeach("uniform", 16, seed, rx, ry));
  }
  std::printf("RMSE at 16 spp vs 1024 spp: bvh %.4f power %.4f uniform %.4f (bvh/power %.3f)\n",
              e_bvh / 2, e_power / 2, e_uniform / 2, e_bvh / e_power);
  EXPECT_LT(e_bvh, 0.8 * e_power);
  EXPECT_LT(e_bvh, 0.8 * e_uniform);
}

}  // namespace
}  // namespace lensim::render
