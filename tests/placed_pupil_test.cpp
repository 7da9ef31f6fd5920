// The placed camera's exit-pupil bounds (issue 28, camera/placed_pupil.h): per 2-D film bin, a
// box of the sampling plane instead of the disc that holds every ray reaching the rear surface.
// Checked: conservative (10^6 random film/plane points at random wavelengths, each ray built
// here from the lens file's frames and traced backward by the placed tracer: none outside the
// sampled region gets through), unbiased (the flat field with and without the bounds agrees by
// a z-test per film region and per 5x5 block of a render) and less wasteful (fewer samples
// without a ray, a smaller variance at equal samples: printed for docs/lens-files.md).
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "lensim/camera/realistic_placed.h"
#include "lensim/io/image.h"
#include "lensim/optics/frame.h"
#include "lensim/optics/lens_formats.h"
#include "lensim/render/image_compare.h"
#include "lensim/render/renderer.h"
#include "lensim/scene/description.h"

using namespace lensim;

namespace {

// The decentred 1897 double Gauss of scenes/lenses/decentred-double-gauss.pbrt on a 36 x 24 mm
// film (30 x 20 pixels), f/5.9, focused at 3.3 m.
struct LensSetup {
  std::string lens;
  camera::RealisticSettings settings;
};
LensSetup decentredDoubleGauss() {
  LensSetup s;
  s.lens = std::string(LENSIM_SOURCE_DIR) + "/scenes/lenses/decentred-double-gauss.zmx";
  s.settings.setup.aperture_diameter_mm = 8.43;
  s.settings.setup.focus_distance_m = 3.3;
  s.settings.x_resolution = 30, s.settings.y_resolution = 20;
  s.settings.film_diagonal_mm = 43.3;
  return s;
}

std::unique_ptr<camera::PlacedRealisticCamera> makeCamera(const LensSetup& s, bool bounds) {
  return std::make_unique<camera::PlacedRealisticCamera>(s.settings, optics::readLensFile(s.lens),
                                                         bounds);
}

Vec3 place(const optics::SurfaceFrame& f, const Vec3& v) {
  return optics::frame::toGlobal(f.rotation, v) +
         Vec3{f.origin_mm[0], f.origin_mm[1], f.origin_mm[2]};
}

// optiland's fold-mirror file (five tilted mirrors and a BK7 singlet) on a 7 x 7 mm film at
// f/2.75, focused at infinity: light reaches only part of the film.
LensSetup foldMirrors() {
  LensSetup s;
  s.lens =
      std::string(LENSIM_SHARED_DIR) + "/lenses/zmx/optiland/complicated_fold_mirrors_setup_v2.zmx";
  s.settings.setup.aperture_diameter_mm = 20;
  s.settings.setup.focus_distance_m = 1e6;
  s.settings.x_resolution = s.settings.y_resolution = 40;
  s.settings.film_diagonal_mm = 10;
  return s;
}

// n random film points over the film, each with a point of the sampling plane (half over the
// disc's square, half over the polygon's bounding box widened to twice its size: the boundary's
// neighbourhood) and one of 48 wavelengths over the rendered range (most of them not among the
// bounds'); the ray is built here from the lens file's frames. Returns the points outside the
// sampled regions and, of those, the ones that get through (must be 0).
struct Containment {
  long outside = 0, outside_through = 0, inside = 0, inside_through = 0, unbounded = 0;
};
Containment containment(const LensSetup& s, int n) {
  const auto cam = makeCamera(s, true);
  const optics::LensPrescription p = optics::readLensFile(s.lens);
  EXPECT_TRUE(p.noncoaxial_loc.has_value());
  EXPECT_GT(cam->pupilBounds().binsX() * cam->pupilBounds().binsY(), 16);
  std::printf(
      "%s: %d x %d bins (%d without a bound), %llu traces, camera start-up %.3f s (%.3f s on one "
      "core)\n",
      s.lens.c_str(), cam->pupilBounds().binsX(), cam->pupilBounds().binsY(),
      cam->pupilBounds().wholeBins(), static_cast<unsigned long long>(cam->pupilBounds().traces()),
      cam->startupSeconds(), cam->startupCpuSeconds());
  std::vector<optics::PlacedLens> lenses;
  for (int k = 0; k < 48; ++k) lenses.emplace_back(p, 360 + (830 - 360) * (k + 0.5) / 48);
  const optics::SurfaceFrame& rear = *p.surfaces.back().frame;
  const double z_plane = cam->samplingPlaneZ_mm();
  const Vec2 corner = cam->filmPoint({0, 0});
  std::mt19937_64 rng(28);
  std::uniform_real_distribution<double> uni(0, 1);
  Containment c;
  for (int i = 0; i < n; ++i) {
    const Vec2 x{corner.x * (2 * uni(rng) - 1), corner.y * (2 * uni(rng) - 1)};
    const camera::PlacedRealisticCamera::SamplingRegion region = cam->samplingRegion(x);
    const double r = region.disc_radius;
    Vec2 lo{-r, -r}, hi{r, r};
    if (i % 2 == 1 && region.polygon) {
      lo = {1e300, 1e300}, hi = {-1e300, -1e300};
      for (int k = 0; k < region.polygon->n; ++k) {
        const Vec2 v = region.polygon->v[size_t(k)];
        lo = {std::min(lo.x, v.x), std::min(lo.y, v.y)};
        hi = {std::max(hi.x, v.x), std::max(hi.y, v.y)};
      }
      const Vec2 w = hi - lo;
      lo = lo - w * 0.5, hi = hi + w * 0.5;
    }
    c.unbounded += region.polygon ? 0 : 1;
    const Vec2 q{lo.x + (hi.x - lo.x) * uni(rng), lo.y + (hi.y - lo.y) * uni(rng)};
    const Vec3 from = place(p.image_frame, {x.x, x.y, cam->filmOffset_mm()});
    const Vec3 to = place(rear, {q.x, q.y, z_plane});
    const bool through =
        lenses[size_t(uni(rng) * 48)].traceBackward({from, normalize(to - from)}).ok();
    if (region.holds(q)) {
      ++c.inside, c.inside_through += through;
    } else {
      ++c.outside, c.outside_through += through;
      EXPECT_FALSE(through) << "film (" << x.x << ", " << x.y << ") plane (" << q.x << ", " << q.y
                            << ")";
    }
  }
  std::printf(
      "outside the sampled regions %ld points, through %ld; inside %ld, through %ld; %ld film "
      "points without a bound\n",
      c.outside, c.outside_through, c.inside, c.inside_through, c.unbounded);
  return c;
}

}  // namespace

TEST(PlacedPupil, NoPassingRayOutsideTheBounds) {
  const LensSetup s = decentredDoubleGauss();
  ASSERT_TRUE(makeCamera(s, false)->lens().dispersive());  // the bounds span the wavelengths
  const Containment c = containment(s, 1000000);
  EXPECT_EQ(c.unbounded, 0);  // light reaches the whole film
  EXPECT_GT(c.outside, 400000);
  EXPECT_EQ(c.outside_through, 0);
  EXPECT_GT(c.inside_through, 100000);
}

TEST(PlacedPupil, NoPassingRayOutsideTheFoldMirrorsBounds) {
  const LensSetup s = foldMirrors();
  if (!std::filesystem::exists(s.lens)) GTEST_SKIP() << s.lens << " not present";
  const Containment c = containment(s, 500000);
  EXPECT_GT(c.unbounded, 0);  // bins the light does not wholly reach keep the disc
  EXPECT_LT(c.unbounded, 400000);
  EXPECT_GT(c.outside, 200000);
  EXPECT_EQ(c.outside_through, 0);
  EXPECT_GT(c.inside_through, 20000);
}

namespace {

// The flat field's irradiance (uniform radiance 1) estimated from n camera samples over the
// raster rectangle [lo, hi] at hero wavelengths uniform over the rendered range: mean, its
// standard error, the per-sample variance and the share of samples without a ray.
struct Estimate {
  double mean = 0, se = 0, variance = 0, no_ray = 0;
};
Estimate flatField(const camera::Camera& cam, Vec2 lo, Vec2 hi, int n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uni(0, 1);
  double s1 = 0, s2 = 0, none = 0;
  for (int i = 0; i < n; ++i) {
    camera::CameraSample cs;
    cs.film_raster = {lo.x + (hi.x - lo.x) * uni(rng), lo.y + (hi.y - lo.y) * uni(rng)};
    cs.lens = {uni(rng), uni(rng)};
    cs.lambda_nm.fill(360 + 470 * uni(rng));
    const auto r = cam.generateRay(cs);
    const double w = r ? r->weight : 0;
    s1 += w, s2 += w * w, none += r ? 0 : 1;
  }
  Estimate e;
  e.mean = s1 / n;
  e.variance = std::max(0.0, s2 / n - e.mean * e.mean);
  e.se = std::sqrt(e.variance / n);
  e.no_ray = none / n;
  return e;
}

std::string writeScene(const std::string& name, const std::string& text) {
  const auto dir = std::filesystem::temp_directory_path() / "lensim_placed_pupil_test";
  std::filesystem::create_directories(dir);
  const std::string path = (dir / name).string();
  std::ofstream(path) << text;
  return path;
}

}  // namespace

// Per film region (3 x 3 over the film, and the whole film): the flat field's estimate with the
// bounds agrees with the whole disc's (z-test, 10 comparisons at |z| < 4), with fewer samples
// wasted and a smaller variance per sample.
TEST(PlacedPupil, FlatFieldAgreesWithAndWithoutBounds) {
  const LensSetup s = decentredDoubleGauss();
  const auto bounded = makeCamera(s, true), whole = makeCamera(s, false);
  EXPECT_EQ(whole->pupilBounds().binsX(), 0);
  const double w = s.settings.x_resolution, h = s.settings.y_resolution;
  const int n = 100000;
  for (int region = 0; region < 10; ++region) {
    Vec2 lo{0, 0}, hi{w, h};
    if (region < 9) {
      const int i = region % 3, j = region / 3;
      lo = {w * i / 3, h * j / 3}, hi = {w * (i + 1) / 3, h * (j + 1) / 3};
    }
    const Estimate a = flatField(*bounded, lo, hi, n, 100 + uint64_t(region));
    const Estimate b = flatField(*whole, lo, hi, n, 200 + uint64_t(region));
    const double z = (a.mean - b.mean) / std::hypot(a.se, b.se);
    EXPECT_LT(std::abs(z), 4) << "raster [" << lo.x << ", " << hi.x << "] x [" << lo.y << ", "
                              << hi.y << "]: " << a.mean << " +- " << a.se << " against " << b.mean
                              << " +- " << b.se;
    EXPECT_LT(a.no_ray, b.no_ray);
    EXPECT_LT(a.variance, b.variance);
    std::printf(
        "raster [%4.1f, %4.1f] x [%4.1f, %4.1f]: %.5e +- %.1e bounded, %.5e +- %.1e whole disc "
        "(z %+.2f); no ray %.1f %% against %.1f %%; variance ratio %.2f\n",
        lo.x, hi.x, lo.y, hi.y, a.mean, a.se, b.mean, b.se, z, 100 * a.no_ray, 100 * b.no_ray,
        b.variance / a.variance);
  }
}

// A render of the flat field through the bounds against one through the whole disc: per-block
// z-test (two seeds of the bounded render against the unbounded one), and the renderer's count
// of samples without a ray.
TEST(PlacedPupil, BoundedRenderMatchesTheUnboundedOne) {
  const LensSetup s = decentredDoubleGauss();
  const std::string scene = writeScene(
      "flat.pbrt",
      fmt::format("Camera \"realistic\" \"string lensfile\" \"{}\" \"float aperturediameter\" "
                  "8.43 \"float focusdistance\" 3.3\nFilm \"rgb\" \"integer xresolution\" 30 "
                  "\"integer yresolution\" 20 \"float diagonal\" 43.3\nSampler \"independent\" "
                  "\"integer pixelsamples\" 256\nPixelFilter \"box\" \"float xradius\" 0.5 "
                  "\"float yradius\" 0.5\nWorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\n",
                  s.lens));
  const std::shared_ptr<const camera::Camera> bounded = makeCamera(s, true),
                                              whole = makeCamera(s, false);
  const auto render = [&](const std::shared_ptr<const camera::Camera>& cam, int seed) {
    render::RenderOptions o;
    o.seed = seed;
    o.camera = cam;
    return render::render(scene::loadScene(scene), o);
  };
  const render::RenderResult a = render(bounded, 1), b = render(bounded, 2), ref = render(whole, 3),
                             ref2 = render(whole, 4);
  // The render noise at equal samples: the mean squared difference of two seeds' pixels.
  const auto noise = [](const io::Image& x, const io::Image& y) {
    double d2 = 0;
    for (int j = 0; j < x.height; ++j)
      for (int i = 0; i < x.width; ++i)
        for (int k = 0; k < 3; ++k) d2 += std::pow(x.at(i, j, k) - y.at(i, j, k), 2);
    return d2;
  };
  const double variance_ratio = noise(ref.image, ref2.image) / noise(a.image, b.image);
  std::printf("render variance at 256 spp, whole disc over bounded: %.2f\n", variance_ratio);
  EXPECT_GT(variance_ratio, 1.5);
  const auto waste = [](const render::RenderStats& st) {
    return double(st.no_ray_samples) / double(st.camera_samples);
  };
  std::printf("camera samples without a ray: bounded %.1f %%, whole disc %.1f %% (%llu samples)\n",
              100 * waste(a.stats), 100 * waste(ref.stats),
              static_cast<unsigned long long>(a.stats.camera_samples));
  EXPECT_LT(waste(a.stats), 0.5 * waste(ref.stats));
  render::CompareOptions o;
  o.block = 5;
  o.second = &b.image;
  o.spp = 256;
  o.reference_spp = 256;
  const render::CompareResult m = render::compareImages(a.image, ref.image, o);
  std::printf("bounded vs whole disc: mean ratio %.4f, %d of %d blocks beyond z %.2f\n",
              m.mean_ratio, m.z_failures, m.blocks, m.z_bound);
  EXPECT_NEAR(m.mean_ratio, 1.0, 0.02);
  EXPECT_EQ(m.z_failures, 0);
}

// The polygon's sampling is uniform: a pentagon (the square [0, 2]^2 cut by x + y <= 3, area
// 3.5) sampled 10^5 times puts 2 / 3.5 of its points at x < 1 and 1 / 3.5 at y < 0.5 (areas
// by hand), all inside it.
TEST(PlacedPupil, PolygonSamplesUniformly) {
  camera::PlacedPolygon p;
  p.n = 5;
  p.v[0] = {0, 0}, p.v[1] = {2, 0}, p.v[2] = {2, 1}, p.v[3] = {1, 2}, p.v[4] = {0, 2};
  EXPECT_NEAR(p.area(), 3.5, 1e-12);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> uni(0, 1);
  const int n = 100000;
  int left = 0, low = 0, inside = 0;
  for (int i = 0; i < n; ++i) {
    const Vec2 q = p.sample({uni(rng), uni(rng)});
    left += q.x < 1, low += q.y < 0.5, inside += p.holds(q);
  }
  EXPECT_EQ(inside, n);
  EXPECT_NEAR(double(left) / n, 2 / 3.5, 0.006);
  EXPECT_NEAR(double(low) / n, 1 / 3.5, 0.006);
  EXPECT_FALSE(p.holds({1.6, 1.6}));
  EXPECT_TRUE(p.holds({0.5, 1.9}));
}
