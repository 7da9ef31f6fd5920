// The bdpt integrator: MIS weights of all the strategies of one path sum to one and, on a
// diffuse scene, equal the balance heuristic computed here from closed-form densities (cosine
// lobes, cosine emission, uniform light area); scene-builder parameters.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "direct_world_util.h"
#include "lensim/camera/camera.h"
#include "lensim/render/image_compare.h"
#include "lensim/render/integrators/bdpt.h"
#include "lensim/render/lights/lights.h"
#include "lensim/render/materials/materials.h"
#include "lensim/render/shapes/accel.h"
#include "lensim/render/textures/textures.h"
#include "lensim/sampling/sampler.h"
#include "render_test_util.h"
#include "scene_test_util.h"
#include "test_paths.h"

using namespace lensim;
using render::bdpt::Vertex;
using render::bdpt::VertexType;
using testutil::buildText;

namespace {

constexpr double kPi = std::numbers::pi;

/// A camera for calling the vertex functions directly: rays from the eye with directions
/// uniform over the hemisphere about +z (so its direction density is 1 / 2 pi).
class HemisphereCamera final : public camera::Camera {
 public:
  std::optional<camera::CameraRay> generateRay(const camera::CameraSample&) const override {
    return std::nullopt;
  }
  std::string describe() const override { return "test hemisphere camera"; }
  bool supportsImportance() const override { return true; }
  camera::CameraRayPdf rayPdf(const Vec3&, const Vec3& d, double, double) const override {
    return {1, d.z > 0 ? 1 / (2 * kPi) : 0.0};
  }
  // A point eye: connections all pass it (a delta, as the pinhole's).
  double pdfWiPos(const Vec3&, const Vec3&, double) const override { return 1; }
};

/// A scene built for calling the bdpt functions directly.
struct Direct : testutil::DirectWorld {
  std::unique_ptr<render::LightSampler> light_sampler;
  HemisphereCamera camera;
  render::bdpt::Context ctx;

  explicit Direct(const std::string& text) : DirectWorld(buildText(text, "bdpt-test.pbrt")) {
    std::vector<const render::Light*> all;
    for (size_t i = 0; i < lights->size(); ++i) all.push_back(&lights->light(i));
    light_sampler = render::LightSampler::create("power", all);
    ctx.sc = &sc;
    ctx.camera = &camera;
    ctx.light_sampler = light_sampler.get();
    ctx.max_depth = sc.max_depth;
  }
};

/// A closed box [-1, 1] x [0, 2] x [-1, 1] of diffuse walls (reflectance 0.5), a small
/// two-sided light near the ceiling; `extra` adds shapes.
std::string boxScene(const std::string& extra) {
  return R"(Integrator "bdpt" "integer maxdepth" 7
Camera "perspective"
WorldBegin
Material "diffuse" "rgb reflectance" [0.5 0.5 0.5]
Shape "trianglemesh" "point3 P" [-1 0 -1  1 0 -1  1 0 1  -1 0 1] "integer indices" [0 1 2 0 2 3]
Shape "trianglemesh" "point3 P" [-1 2 -1  1 2 -1  1 2 1  -1 2 1] "integer indices" [0 1 2 0 2 3]
Shape "trianglemesh" "point3 P" [-1 0 -1  -1 2 -1  -1 2 1  -1 0 1] "integer indices" [0 1 2 0 2 3]
Shape "trianglemesh" "point3 P" [1 0 -1  1 2 -1  1 2 1  1 0 1] "integer indices" [0 1 2 0 2 3]
Shape "trianglemesh" "point3 P" [-1 0 1  1 0 1  1 2 1  -1 2 1] "integer indices" [0 1 2 0 2 3]
Shape "trianglemesh" "point3 P" [-1 0 -1  1 0 -1  1 2 -1  -1 2 -1] "integer indices" [0 1 2 0 2 3]
AttributeBegin
AreaLightSource "diffuse" "rgb L" [4 4 4] "bool twosided" true
Shape "trianglemesh" "point3 P" [-0.3 1.9 -0.3  0.3 1.9 -0.3  0.3 1.9 0.3  -0.3 1.9 0.3]
  "integer indices" [0 1 2 0 2 3]
AttributeEnd
)" + extra;
}

/// Camera subpaths from the eye (0, 1, -0.9) looking along +z that end on the light, cut there:
/// complete paths the s = 0 strategy found (the light seen directly included). Up to `count`.
std::vector<std::vector<Vertex>> pathsEndingOnLight(Direct& d, int count) {
  std::vector<std::vector<Vertex>> out;
  sampling::IndependentSampler sampler(1, 7);
  std::vector<Vertex> buf(size_t(d.ctx.max_depth) + 3);
  render::RayCounts counts;
  for (int i = 0; i < 200000 && int(out.size()) < count; ++i) {
    sampler.startPixelSample({i, 0}, 0);
    Vec3 dir = sampling::sampleUniformHemisphere(sampler.get2D());
    camera::CameraRay ray;
    ray.origin = {0, 1, -0.9};
    ray.direction = dir;
    render::SampledWavelengths lambda = render::SampledWavelengths::sampleVisible(0.3);
    const int n = render::bdpt::cameraSubpath(d.ctx, ray, lambda, sampler, counts, buf.data());
    for (int k = 1; k < n; ++k) {
      // Short segments (into corners) are left out: the walk's densities are those of its
      // sampled directions, the weights' of the vertices' positions, which lie along rays from
      // origins offset off the surfaces (~4e-5); over a segment of length l they differ by
      // ~4e-5 / l relative per vertex, ~1e-3 over a path's product.
      if (length(buf[size_t(k)].p - buf[size_t(k - 1)].p) < 0.25) break;
      if (buf[size_t(k)].type == VertexType::Surface && buf[size_t(k)].light) {
        out.emplace_back(buf.begin(), buf.begin() + k + 1);
        break;
      }
    }
  }
  return out;
}

/// The light and camera subpaths with which strategy (s, n - s) makes the complete camera path
/// `cam` (cam[0] the eye, cam.back() on the light), with the densities each subpath's walk
/// would have given, and the vertex the strategy samples at its end (s = 1: the light point;
/// t = 1: the eye).
struct Split {
  std::vector<Vertex> light, camera;
  Vertex sampled;
};
Split split(const Direct& d, const std::vector<Vertex>& cam, int s, bool recompute) {
  const int n = int(cam.size());
  std::vector<Vertex> path = cam;
  if (recompute) {
    // Every vertex's densities from the positions (bdpt::pdf), instead of the walk's, which are
    // those of its sampled directions from ray origins offset off the surfaces.
    Vertex y0 = cam[size_t(n - 1)];
    y0.type = VertexType::Light;
    for (int k = 1; k < n; ++k) {
      Vertex& v = path[size_t(k)];
      v.pdf_fwd = render::bdpt::pdf(d.ctx, cam[size_t(k - 1)],
                                    k >= 2 ? &cam[size_t(k - 2)] : nullptr, v, 550);
      if (k == n - 1)
        v.pdf_rev = render::bdpt::pdfLightOrigin(d.ctx, y0, cam[size_t(n - 2)]);
      else if (k == n - 2)
        v.pdf_rev = render::bdpt::pdfLight(d.ctx, y0, v);
      else
        v.pdf_rev = render::bdpt::pdf(d.ctx, cam[size_t(k + 1)], &cam[size_t(k + 2)], v, 550);
    }
  }
  Split r;
  r.camera.assign(path.begin(), path.begin() + (n - s));
  for (int j = 0; j < s; ++j) {
    Vertex v = path[size_t(n - 1 - j)];
    std::swap(v.pdf_fwd, v.pdf_rev);
    r.light.push_back(v);
  }
  // The light end: a light vertex, its origin density and the emission density of y1.
  Vertex y0 = path[size_t(n - 1)];
  y0.type = VertexType::Light;
  y0.pdf_fwd = render::bdpt::pdfLightOrigin(d.ctx, y0, path[size_t(n - 2)]);
  y0.pdf_rev = path[size_t(n - 1)].pdf_fwd;
  if (s >= 1) r.light[0] = y0;
  if (s >= 2) r.light[1].pdf_fwd = render::bdpt::pdfLight(d.ctx, y0, path[size_t(n - 2)]);
  r.sampled = s == 1 && n > 2 ? y0 : path[0];
  return r;
}

/// Whether strategy s of the path can make it: both connection vertices are connectible.
bool strategyExists(const std::vector<Vertex>& cam, int s) {
  const int n = int(cam.size());
  if (s == 0) return true;
  const Vertex& ys = cam[size_t(n - s)];  // light-side end of the connection
  if (ys.type == VertexType::Surface && !render::isNonSpecular(ys.bsdf.flags()) && s >= 2)
    return false;
  const Vertex& yt = cam[size_t(n - s - 1)];
  return yt.type != VertexType::Surface || render::isNonSpecular(yt.bsdf.flags());
}

double weightSum(Direct& d, const std::vector<Vertex>& cam, std::vector<double>* weights,
                 bool recompute = false) {
  const int n = int(cam.size());
  double sum = 0;
  for (int s = 0; s < n; ++s) {
    const int t = n - s;
    if (!strategyExists(cam, s)) {
      if (weights) weights->push_back(0);
      continue;
    }
    Split sp = split(d, cam, s, recompute);
    const double w =
        render::bdpt::misWeight(d.ctx, sp.light.data(), sp.camera.data(), sp.sampled, s, t, 550);
    if (weights) weights->push_back(w);
    sum += w;
  }
  return sum;
}

}  // namespace

TEST(Bdpt, MisWeightsOfAPathSumToOne) {
  // Diffuse walls, a rough conductor and a smooth glass sphere (specular vertices that some
  // strategies cannot connect through).
  Direct d(boxScene(R"(Material "conductor" "float roughness" 0.2
Shape "trianglemesh" "point3 P" [-0.99 0.1 0.2  -0.99 1.2 0.2  -0.99 1.2 0.9  -0.99 0.1 0.9]
  "integer indices" [0 1 2 0 2 3]
Material "dielectric" "float eta" 1.5
AttributeBegin
Translate 0.3 0.5 0.3
Shape "sphere" "float radius" 0.35
AttributeEnd
)"));
  const auto paths = pathsEndingOnLight(d, 60);
  ASSERT_GE(paths.size(), 40u);
  int longest = 0, with_specular = 0;
  for (double exponent : {1.0, 2.0}) {
    d.ctx.mis_exponent = exponent;
    for (const auto& cam : paths) {
      longest = std::max(longest, int(cam.size()));
      bool specular = false;
      for (const Vertex& v : cam) specular = specular || v.delta;
      with_specular += specular;
      // For the fixed path (densities from its vertices' positions) the weights sum to one
      // to rounding; with the walks' own densities, to the ray offsets' effect.
      EXPECT_NEAR(weightSum(d, cam, nullptr, true), 1.0, 1e-9)
          << cam.size() << " vertices, heuristic exponent " << exponent;
      EXPECT_NEAR(weightSum(d, cam, nullptr, false), 1.0, 5e-3)
          << cam.size() << " vertices, heuristic exponent " << exponent;
    }
  }
  EXPECT_GE(longest, 5);
  EXPECT_GT(with_specular, 0);
}

TEST(Bdpt, MisWeightsAreTheBalanceHeuristicOfClosedFormDensities) {
  Direct d(boxScene(""));
  const auto paths = pathsEndingOnLight(d, 30);
  ASSERT_GE(paths.size(), 20u);
  // The light: two-sided, area 0.36 (to float rounding of the mesh: 1e-7), two triangles of
  // equal power.
  const double light_area = 0.36;
  // The tolerance: ray-origin offsets (see pathsEndingOnLight).
  int direct = 0;  // paths of the light seen directly: strategies (0, 2) and (1, 1)
  for (const auto& cam : paths) {
    const int n = int(cam.size());
    direct += n == 2;
    // y_j = cam[n - 1 - j]: y_0 on the light, y_{n-1} the eye.
    auto y = [&](int j) -> const Vertex& { return cam[size_t(n - 1 - j)]; };
    auto cosAt = [](const Vertex& v, const Vec3& w) { return std::abs(dot(v.ng, w)); };
    auto toArea = [&](const Vertex& from, const Vertex& to, double pdf_dir) {
      const Vec3 w = to.p - from.p;
      const double d2 = dot(w, w);
      return pdf_dir * cosAt(to, w / std::sqrt(d2)) / d2;
    };
    // Densities of y_j sampled from the light side (pl) and from the camera side (pc).
    std::vector<double> pl(size_t(n), 0), pc(size_t(n), 0);
    pl[0] = 1 / light_area;
    pl[1] = toArea(y(0), y(1), cosAt(y(0), normalize(y(1).p - y(0).p)) / kPi * 0.5);
    for (int j = 2; j < n - 1; ++j)
      pl[size_t(j)] = toArea(y(j - 1), y(j), cosAt(y(j - 1), normalize(y(j).p - y(j - 1).p)) / kPi);
    pc[size_t(n - 2)] = toArea(y(n - 1), y(n - 2), 1 / (2 * kPi));
    for (int j = n - 3; j >= 0; --j)
      pc[size_t(j)] = toArea(y(j + 1), y(j), cosAt(y(j + 1), normalize(y(j).p - y(j + 1).p)) / kPi);
    std::vector<double> p;
    for (int s = 0; s < n; ++s) {
      double ps = 1;
      for (int j = 0; j < s; ++j) ps *= pl[size_t(j)];
      for (int j = s; j < n - 1; ++j) ps *= pc[size_t(j)];
      p.push_back(ps);
    }
    for (double exponent : {1.0, 2.0})
      for (bool recompute : {true, false}) {
        d.ctx.mis_exponent = exponent;
        std::vector<double> w;
        weightSum(d, cam, &w, recompute);
        ASSERT_EQ(w.size(), p.size());
        double sum = 0;
        for (double ps : p) sum += std::pow(ps, exponent);
        for (size_t s = 0; s < p.size(); ++s)
          EXPECT_NEAR(w[s], std::pow(p[s], exponent) / sum,
                      1e-12 + (recompute ? 1e-6 : 5e-3) * w[s])
              << "strategy s = " << s << " of a path of " << n << " vertices"
              << (recompute ? "" : " (the walks' densities)");
      }
  }
  EXPECT_GT(direct, 0);
}

TEST(Bdpt, BuilderParameters) {
  scene::Scene s = buildText(
      "Integrator \"bdpt\" \"integer maxdepth\" 9 \"bool regularize\" true \"bool "
      "visualizeweights\" true \"string lightsampler\" \"bvh\"\nWorldBegin\n",
      "b.pbrt");
  EXPECT_EQ(s.integrator.type, "bdpt");
  EXPECT_EQ(s.integrator.max_depth, 9);
  EXPECT_TRUE(s.integrator.regularize);
  EXPECT_EQ(s.integrator.light_sampler, "power");
  int warnings = 0;
  for (const auto& dg : s.diagnostics) warnings += dg.severity == Severity::Warning;
  EXPECT_EQ(warnings, 2);  // bvh light sampler, visualizeweights
  // With media, bdpt renders the scene (it traces them: render_bdpt_media_test), unwarned.
  scene::Scene m = buildText(
      "Integrator \"bdpt\"\nWorldBegin\nMakeNamedMedium \"fog\" \"string type\" \"homogeneous\"\n"
      "MediumInterface \"fog\" \"\"\nShape \"sphere\"\n",
      "m.pbrt");
  EXPECT_EQ(m.integrator.type, "bdpt");
  for (const auto& dg : m.diagnostics) EXPECT_NE(dg.severity, Severity::Warning) << dg.message;
}

namespace {

/// A box with a diffuse sphere, a rough metal panel and a rough glass sphere, lit by a small area
/// light, a spot light and (extra) more lights; camera and film given. (No smooth glass: path
/// cannot see a point light through it, bdpt can.)
std::string litBox(const std::string& camera, const std::string& integrator,
                   const std::string& extra = "") {
  return camera +
         fmt::format(R"(Integrator "{}" "integer maxdepth" 5
WorldBegin
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [6 6 6]
  Shape "trianglemesh" "point3 P" [-0.3 1.99 -0.3  0.3 1.99 -0.3  0.3 1.99 0.3  -0.3 1.99 0.3]
    "integer indices" [0 1 2 0 2 3]
AttributeEnd
LightSource "spot" "point3 from" [0.8 1.8 -0.8] "point3 to" [0 0 0.5] "float coneangle" 30
  "rgb I" [1.5 1.5 1.5]
Material "diffuse" "rgb reflectance" [0.7 0.7 0.7]
Shape "trianglemesh" "point3 P" [-1 0 -1  1 0 -1  1 0 1  -1 0 1  -1 2 -1  1 2 -1  1 2 1  -1 2 1]
  "integer indices" [0 2 1 0 3 2  4 5 6 4 6 7  3 7 6 3 6 2]
Material "diffuse" "rgb reflectance" [0.7 0.1 0.1]
Shape "trianglemesh" "point3 P" [-1 0 -1  -1 0 1  -1 2 1  -1 2 -1] "integer indices" [0 2 1 0 3 2]
Material "conductor" "float roughness" 0.15
Shape "trianglemesh" "point3 P" [1 0 -1  1 0 1  1 2 1  1 2 -1] "integer indices" [0 1 2 0 2 3]
Material "diffuse" "rgb reflectance" [0.5 0.5 0.8]
AttributeBegin
  Translate 0.3 0.35 0.2
  Shape "sphere" "float radius" 0.35
AttributeEnd
Material "dielectric" "float eta" 1.5 "float roughness" 0.3
AttributeBegin
  Translate -0.4 0.3 -0.2
  Shape "sphere" "float radius" 0.3
AttributeEnd
)",
                     integrator) +
         extra;
}

/// bdpt (two renders of `spp`) against path (4 x spp) by the per-block z-test; `whole`: also
/// the z-test of the whole image's mean (one block).
render::CompareResult bdptAgainstPath(const std::string& camera, int spp,
                                      const std::string& extra = "", int block = 6,
                                      render::CompareResult* whole = nullptr) {
  render::RenderOptions o;
  o.spp = spp;
  o.seed = 31;
  const io::Image a = testutil::renderText(litBox(camera, "bdpt", extra), o).image;
  o.seed = 32;
  const io::Image b = testutil::renderText(litBox(camera, "bdpt", extra), o).image;
  o.seed = 33;
  o.spp = 4 * spp;
  const io::Image ref = testutil::renderText(litBox(camera, "path", extra), o).image;
  o.seed = 34;
  o.spp = spp;
  const io::Image ref_low = testutil::renderText(litBox(camera, "path", extra), o).image;
  render::CompareOptions co;
  co.block = block;
  co.second = &b;
  co.spp = spp;
  co.reference_spp = 4 * spp;
  co.reference_low = &ref_low;
  co.reference_low_spp = spp;
  if (whole) {
    render::CompareOptions one = co;
    one.block = std::min(ref.width, ref.height);
    *whole = render::compareImages(a, ref, one);
  }
  return render::compareImages(a, ref, co);
}

// The z-test takes pixels as independent: a splat reconstructed with a wide filter adds to
// several pixels, so the consistency tests use the box filter of one pixel.
const char* kPerspective = R"(LookAt 0 1 -3.2  0 1 0  0 1 0
Camera "perspective" "float fov" 40
Film "rgb" "integer xresolution" 24 "integer yresolution" 24 "string filename" "b.exr"
Sampler "independent"
PixelFilter "box" "float xradius" 0.5 "float yradius" 0.5
)";

}  // namespace

TEST(Bdpt, AgreesWithPathThroughAPerspectiveCamera) {
  const render::CompareResult r = bdptAgainstPath(kPerspective, 32);
  std::printf("%s", render::formatCompare(r).c_str());
  EXPECT_EQ(r.z_failures, 0) << render::formatCompare(r);
  // (The path reference is noisy in the rough glass's caustic: at 512 / 4096 samples the ratio
  // is 0.993.)
  EXPECT_NEAR(r.mean_ratio, 1.0, 0.04) << render::formatCompare(r);
  // The test can fail: bdpt with its light subpaths' contributions doubled is found.
  // (A brighter spot light in the bdpt render only.)
  render::RenderOptions o;
  o.spp = 32;
  o.seed = 31;
  std::string brighter = litBox(kPerspective, "bdpt");
  brighter.replace(brighter.find("[1.5 1.5 1.5]"), 13, "[2.0 2.0 2.0]");
  const io::Image w = testutil::renderText(brighter, o).image;
  o.seed = 33;
  o.spp = 128;
  const io::Image ref = testutil::renderText(litBox(kPerspective, "path"), o).image;
  o.seed = 32;
  o.spp = 32;
  const io::Image b = testutil::renderText(litBox(kPerspective, "bdpt"), o).image;
  render::CompareOptions co;
  co.block = 6;
  co.second = &b;
  co.spp = 32;
  co.reference_spp = 128;
  EXPECT_GT(render::compareImages(w, ref, co).z_failures, 0);
}

// Every other light type: an environment, a distant light and a goniometric point light (their
// light subpaths start on the scene's bounding disk or at the point).
TEST(Bdpt, AgreesWithPathUnderInfiniteDistantAndGoniometricLights) {
  const render::CompareResult r = bdptAgainstPath(kPerspective, 32, R"(
LightSource "infinite" "rgb L" [0.3 0.3 0.3]
LightSource "distant" "point3 from" [0.3 1 -1] "point3 to" [0 0 0] "rgb L" [0.5 0.5 0.5]
AttributeBegin
  Translate 0 1.5 0.5
  LightSource "goniometric" "rgb I" [0.5 0.5 0.5]
AttributeEnd
)");
  std::printf("%s", render::formatCompare(r).c_str());
  EXPECT_EQ(r.z_failures, 0) << render::formatCompare(r);
  EXPECT_NEAR(r.mean_ratio, 1.0, 0.04) << render::formatCompare(r);
}

// Splats are exact fixed-point sums: the image does not depend on the thread count.
TEST(Bdpt, SameImageWithAnyThreadCount) {
  const std::string s = litBox(kPerspective, "bdpt");
  render::RenderOptions o;
  o.spp = 2;
  o.threads = 1;
  const io::Image a = testutil::renderText(s, o).image;
  o.threads = 3;
  const io::Image b = testutil::renderText(s, o).image;
  EXPECT_EQ(a.pixels, b.pixels);
}

TEST(Bdpt, RefusesTiles) {
  render::RenderOptions o;
  o.spp = 1;
  o.tile = {{0, 2}};
  try {
    testutil::renderText(litBox(kPerspective, "bdpt"), o);
    FAIL() << "a tile of a bdpt render was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--tile"), std::string::npos) << e.what();
  }
}

// Through each classic lens: the camera connections (t = 1) enter the lens at its front element
// (Camera::sampleWi), camera samples the lens blocks still trace their light subpaths, and the
// image agrees with path's.
TEST(Bdpt, AgreesWithPathThroughEachClassicLens) {
  for (const char* lens : lensim::test::kClassicLenses) {
    SCOPED_TRACE(lens);
    const std::string camera = fmt::format(
        R"(LookAt 0 1 -3.2  0 1 0  0 1 0
Camera "realistic" "string lensfile" "{}" "float aperturediameter" 5 "float focusdistance" 3
Film "rgb" "integer xresolution" 24 "integer yresolution" 24 "float diagonal" 35
  "string filename" "l.exr"
Sampler "independent"
PixelFilter "box" "float xradius" 0.5 "float yradius" 0.5
)",
        lensim::test::lensPath(lens));
    render::CompareResult whole;
    const render::CompareResult r = bdptAgainstPath(camera, 24, "", 6, &whole);
    // Vignetted corners are nearly black and their two-render variance estimates unreliable: at
    // most one block beyond the Bonferroni bound, none beyond 5 sigma + 2% (as the volpath lens
    // test). The image means agree within their noise (the fisheye sees the small light, whose
    // direct view is noisy for path: its ratio is 0.93-1.09 at 24-512 spp, 0.9986 at 4096 spp
    // against path's 16384, no block beyond the bound).
    EXPECT_LE(r.z_failures, 1) << render::formatCompare(r);
    EXPECT_EQ(r.outliers, 0) << render::formatCompare(r);
    EXPECT_EQ(whole.z_failures, 0) << render::formatCompare(whole);
    std::printf("%s: bdpt/path mean ratio %.4f, %d z failures\n", lens, r.mean_ratio, r.z_failures);
  }
}
