#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "lensim/camera/realistic.h"
#include "lensim/optics/plots.h"
#include "test_paths.h"

using namespace lensim;
using namespace lensim::camera;
using lensim::test::lensPath;

namespace {

RealisticSettings settings(const std::string& lens, std::optional<double> aperture_mm = {},
                           double focus_m = 2.0) {
  RealisticSettings s;
  s.lens_path = lensPath(lens);
  s.setup.aperture_diameter_mm = aperture_mm;
  s.setup.focus_distance_m = focus_m;
  s.film_diagonal_mm = 35;
  s.x_resolution = 300;
  s.y_resolution = 200;
  return s;
}

struct WeightStats {
  double mean = 0, se = 0;
  double no_ray = 0;  // share of samples without a ray
};

// Mean weight (the film irradiance per unit radiance) at a raster point, over uniform lens samples.
WeightStats meanWeight(const RealisticCamera& cam, Vec2 raster, int n = 200000, int seed = 1) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  double sum = 0, sum2 = 0;
  int none = 0;
  for (int k = 0; k < n; ++k) {
    auto r = cam.generateRay({raster, {u(rng), u(rng)}, 0});
    const double w = r ? r->weight : 0;
    none += !r;
    sum += w;
    sum2 += w * w;
  }
  const double mean = sum / n;
  return {mean, std::sqrt((sum2 / n - mean * mean) / n), static_cast<double>(none) / n};
}

}  // namespace

// Looking down +z from the origin, the centre of the film sees straight ahead, a raster point on
// the right sees to the right (+x, as pbrt's cameras) and one at the top sees up (+y).
TEST(RealisticCamera, ImageIsOrientedAsPbrt) {
  RealisticCamera cam(settings("dgauss.50mm.dat", 4.0));
  // Average over the pupil to get the chief direction of an off-centre pixel.
  auto dirAt = [&](Vec2 raster) {
    Vec3 sum{0, 0, 0};
    for (int i = 0; i < 16; ++i)
      for (int j = 0; j < 16; ++j)
        if (auto r = cam.generateRay({raster, {(i + 0.5) / 16, (j + 0.5) / 16}, 0}))
          sum += r->direction;
    return normalize(sum);
  };
  const Vec3 centre = dirAt({150, 100}), right = dirAt({290, 100}), top = dirAt({150, 5});
  EXPECT_NEAR(centre.x, 0, 1e-3);
  EXPECT_NEAR(centre.y, 0, 1e-3);
  EXPECT_GT(right.x, 0.2);
  EXPECT_NEAR(right.y, 0, 1e-3);
  EXPECT_GT(top.y, 0.1);
  EXPECT_NEAR(top.x, 0, 1e-3);
  // Rays start on the front surface of the lens, its vertex being filmZ in front of the film
  // (camera space metres); the stopped-down on-axis bundle leaves near the vertex.
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> u(0, 1);
  std::optional<CameraRay> c;
  while (!c) c = cam.generateRay({{150, 100}, {u(rng), u(rng)}, 0});
  EXPECT_NEAR(c->origin.z, cam.lens().lens->filmZ_mm() * 1e-3, 1e-4);
}

// The camera's mean weight at the film centre is the traced irradiance integral of the optics
// core (relative illumination, cos^4 / z^2 over the pupil), and paraxially pi / (4 N_w^2).
TEST(RealisticCamera, CentreIrradianceMatchesTheOpticsCore) {
  for (const char* lens : {"dgauss.50mm.dat", "telephoto.250mm.dat"}) {
    SCOPED_TRACE(lens);
    RealisticCamera cam(settings(lens));
    const WeightStats w = meanWeight(cam, {150, 100});
    const optics::LensSystem& ls = *cam.lens().lens;
    const double n_w = optics::workingFNumber(ls, cam.lens().paraxial,
                                              ls.filmZ_mm() - cam.lens().focus_distance_m * 1000);
    const double paraxial = std::numbers::pi / (4 * n_w * n_w);
    EXPECT_NEAR(w.mean, paraxial, 0.08 * paraxial) << "N_w " << n_w;
    EXPECT_LT(w.no_ray, 0.05);
  }
}

// Exposure: half the stop diameter passes a quarter of the light at the centre.
TEST(RealisticCamera, HalfTheStopDiameterQuartersTheExposure) {
  RealisticCamera full(settings("dgauss.50mm.dat", 12.0));
  RealisticCamera half(settings("dgauss.50mm.dat", 6.0));
  const WeightStats a = meanWeight(full, {150, 100}), b = meanWeight(half, {150, 100});
  const double ratio = a.mean / b.mean;
  const double se = ratio * std::hypot(a.se / a.mean, b.se / b.mean);
  EXPECT_NEAR(ratio, 4.0, 0.04 * 4 + 4.5 * se);
}

// Towards the corners the camera's irradiance follows the optics core's relative illumination.
TEST(RealisticCamera, FallOffFollowsRelativeIllumination) {
  RealisticCamera cam(settings("wide.22mm.dat"));
  // Along the +x film axis; the raster point whose film point is (-h, 0) mirrors it, same value.
  const optics::VignettingData v = optics::computeVignetting(cam.lens(), 35, 4);
  const WeightStats c = meanWeight(cam, {150, 100});
  for (size_t k = 1; k < v.film_radius_mm.size(); ++k) {
    const double h = v.film_radius_mm[k];
    // Film width is 35 / sqrt(1 + (2/3)^2) = 29.1 mm over 300 pixels.
    const double half_w = 35 / std::sqrt(1 + 4.0 / 9) / 2;
    if (h >= half_w) break;
    const Vec2 raster{150 + h / half_w * 150, 100};
    const WeightStats w = meanWeight(cam, raster, 200000, 7 + static_cast<int>(k));
    const double measured = w.mean / c.mean;
    const double se = measured * std::hypot(w.se / w.mean, c.se / c.mean);
    EXPECT_NEAR(measured, v.relative_illumination[k], 4.5 * se + 0.01) << "h " << h;
  }
}

TEST(RealisticCamera, PolygonalStopKeepsTheExposure) {
  RealisticSettings round = settings("dgauss.50mm.dat", 8.0);
  RealisticSettings penta = settings("dgauss.50mm.dat", 8.0);
  penta.aperture = ApertureShape::polygon(5, 90);
  RealisticCamera a(round), b(penta);
  const WeightStats wa = meanWeight(a, {150, 100}), wb = meanWeight(b, {150, 100});
  EXPECT_NEAR(wb.mean / wa.mean, 1.0, 0.02 + 4.5 * std::hypot(wa.se / wa.mean, wb.se / wb.mean));
}

TEST(ApertureShape, EveryShapeTransmitsAsMuchAsTheRoundStop) {
  std::vector<ApertureShape> shapes = {
      ApertureShape::round(),         ApertureShape::polygon(6, 0),
      ApertureShape::named("square"), ApertureShape::named("pentagon"),
      ApertureShape::named("star"),   ApertureShape::named("gaussian")};
  for (const ApertureShape& s : shapes) {
    SCOPED_TRACE(s.describe());
    // Midpoint quadrature over the square around the extent.
    const int n = 800;
    const double e = s.extent() * 1.01, cell = 2 * e / n;
    double sum = 0;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        sum += s.transmission({-e + (i + 0.5) * cell, -e + (j + 0.5) * cell});
    EXPECT_NEAR(sum * cell * cell, std::numbers::pi, 0.01);
    EXPECT_EQ(s.transmission({1.02 * s.extent(), 0}), 0.0);
  }
  EXPECT_THROW(ApertureShape::named("hexagon"), Error);
  EXPECT_THROW(ApertureShape::polygon(2, 0), Error);
}

TEST(RealisticCamera, ClearErrorsForImpossibleSettings) {
  EXPECT_THROW(RealisticCamera(settings("dgauss.50mm.dat", {}, 0.05)), Error);  // too close
  RealisticSettings bad = settings("no-such-lens.dat");
  EXPECT_THROW(RealisticCamera{bad}, Error);
}

// Flat field: under uniform radiance L the film centre receives E = pi L sin^2(theta), theta the
// half-angle of the cone of real rays that reach the film centre through the lens.
TEST(RealisticCamera, FlatFieldCentreIrradianceIsPiSinSquared) {
  for (const char* lens : {"dgauss.50mm.dat", "wide.22mm.dat", "telephoto.250mm.dat"}) {
    SCOPED_TRACE(lens);
    RealisticCamera cam(settings(lens, 6.0, 3.0));
    const optics::LensSystem& ls = *cam.lens().lens;
    const double sin_theta = lensim::test::realMarginalSin(ls);
    const double expected = std::numbers::pi * sin_theta * sin_theta;
    const WeightStats w = meanWeight(cam, {150, 100}, 400000);
    EXPECT_NEAR(w.mean, expected, 0.02 * expected + 4.5 * w.se);
  }
}

// Bokeh: a small bright disc far out of focus images as the stop's shape. With a pentagonal stop
// the blur has the pentagon's area (the round stop's, by the normalisation rule) and turns with
// the blades.
TEST(RealisticCamera, BokehShowsTheStopShape) {
  struct Blur {
    double area_px = 0;
    double corner_deg = 0;  // direction of the farthest lit pixel from the centroid
  };
  auto bokeh = [](int blades, double rotation) {
    RealisticSettings s = settings("dgauss.50mm.dat", 10.0, 3.0);
    constexpr int kRes = 64;
    s.x_resolution = s.y_resolution = kRes;
    s.film_diagonal_mm = 4;  // a small film around the axis: 0.044 mm pixels
    if (blades) s.aperture = ApertureShape::polygon(blades, rotation);
    RealisticCamera cam(s);
    // A disc of radius 2 mm, 0.6 m from the film on the axis: its sharp image is 4 pixels
    // across, its blur about 21.
    const double z = 0.6, radius = 0.002;
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> u(0, 1);
    std::vector<int> lit;
    double cx = 0, cy = 0;
    for (int y = 0; y < kRes; ++y)
      for (int x = 0; x < kRes; ++x) {
        int hits = 0;
        for (int k = 0; k < 256; ++k) {
          auto r = cam.generateRay({{x + u(rng), y + u(rng)}, {u(rng), u(rng)}, 0});
          if (!r) continue;
          const double t = (z - r->origin.z) / r->direction.z;
          const Vec3 p = r->origin + r->direction * t;
          hits += std::hypot(p.x, p.y) < radius;
        }
        if (hits >= 3) {
          lit.push_back(y * kRes + x);
          cx += x, cy += y;
        }
      }
    Blur b;
    b.area_px = static_cast<double>(lit.size());
    cx /= lit.size();
    cy /= lit.size();
    double far = 0;
    for (int i : lit) {
      const double dx = i % kRes - cx, dy = i / kRes - cy, d = std::hypot(dx, dy);
      if (d > far) far = d, b.corner_deg = std::atan2(-dy, dx) * 180 / std::numbers::pi;
    }
    return b;
  };
  const Blur round = bokeh(0, 0), penta = bokeh(5, 90), turned = bokeh(5, 126);
  ASSERT_GT(round.area_px, 150);
  EXPECT_NEAR(penta.area_px / round.area_px, 1.0, 0.06);
  // A pentagon's corners repeat every 72 degrees; turning the blades by 36 degrees turns the
  // blur's corners by 36 degrees (either way round, as the image is flipped).
  auto mod72 = [](double a) { return std::fmod(std::fmod(a, 72.0) + 72.0, 72.0); };
  const double turn = std::abs(mod72(turned.corner_deg - penta.corner_deg) - 36.0);
  EXPECT_LT(turn, 8.0) << penta.corner_deg << " -> " << turned.corner_deg;
}

// --pbrt-v2-quirks: pbrt-v2's Camera::GenerateRayDifferential gives a sample weight 0 when the
// ray one pixel to the right or one pixel down, through the same lens point, is blocked; the
// assignment's realistic camera inherits it. The camera keeps exactly the rays it would give
// anyway, and the share it keeps agrees with an independent count on the rear disc (double
// tracer, uniform points) of the points through which all three rays pass.
TEST(RealisticCamera, PbrtV2QuirkDropsSamplesWhoseNeighbourRaysAreBlocked) {
  RealisticSettings s = settings("wide.22mm.dat", 8.756);
  s.setup.focus_distance_m.reset();
  s.setup.film_distance_mm = 14.54;  // the assignment's wide-angle scene
  s.film_diagonal_mm = 70;
  s.x_resolution = s.y_resolution = 300;
  s.rear_disc_only = true;
  s.origin_at_front_vertex = true;
  const RealisticCamera plain(s);
  s.zero_if_neighbour_blocked = true;
  const RealisticCamera quirky(s);
  const optics::LensSystem& lens = *plain.lens().lens;
  const double rear_r = lens.interfaces().back().semi_aperture_mm;

  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0, 1);
  for (const Vec2 raster : {Vec2{150.5, 150.5}, Vec2{40.5, 150.5}, Vec2{80.5, 225.5}}) {
    SCOPED_TRACE(::testing::Message() << "raster " << raster.x << ", " << raster.y);
    // The camera: rays with and without the rule, same samples.
    int plain_rays = 0, kept = 0;
    for (int k = 0; k < 100000; ++k) {
      const CameraSample cs{raster, {u(rng), u(rng)}, 0};
      const auto a = plain.generateRay(cs);
      const auto b = quirky.generateRay(cs);
      plain_rays += a.has_value();
      kept += b.has_value();
      if (b) {
        ASSERT_TRUE(a.has_value());
        EXPECT_EQ(a->weight, b->weight);
        EXPECT_EQ(a->direction.x, b->direction.x);
      }
    }
    // Independent: uniform points on the rear disc, traced from the three film points.
    const Vec2 p0 = plain.filmPoint(raster), px = plain.filmPoint(raster + Vec2{1, 0}),
               py = plain.filmPoint(raster + Vec2{0, 1});
    int pass = 0, all3 = 0;
    for (int k = 0; k < 200000; ++k) {
      const double r = rear_r * std::sqrt(u(rng)), phi = 2 * std::numbers::pi * u(rng);
      const Vec2 q{r * std::cos(phi), r * std::sin(phi)};
      if (!lens.traceFromFilmPoint(p0, q).ok()) continue;
      ++pass;
      all3 += lens.traceFromFilmPoint(px, q).ok() && lens.traceFromFilmPoint(py, q).ok();
    }
    ASSERT_GT(plain_rays, 1000);
    ASSERT_GT(pass, 1000);
    const double share_cam = double(kept) / plain_rays, share_ref = double(all3) / pass;
    const double se =
        std::sqrt(share_ref * (1 - share_ref) / pass + share_cam * (1 - share_cam) / plain_rays);
    std::printf("raster (%.1f, %.1f): camera keeps %.4f of its rays, rear-disc count %.4f\n",
                raster.x, raster.y, share_cam, share_ref);
    EXPECT_NEAR(share_cam, share_ref, 4 * se + 1e-3);
    if (raster.x < 100) {
      EXPECT_LT(share_cam, 0.999);  // off-axis: the rule drops samples
    }
  }
}

// generateRays (the lens traced for a batch of samples side by side) gives exactly the rays
// generateRay gives one at a time, with a shaped stop and in the pbrt-v2 quirk mode too.
TEST(RealisticCamera, BatchedRaysEqualSingleRays) {
  for (int variant = 0; variant < 3; ++variant) {
    RealisticSettings s = settings(variant == 2 ? "wide.22mm.dat" : "dgauss.50mm.dat", 10.0);
    if (variant == 1) s.aperture = ApertureShape::polygon(5, 10);
    if (variant == 2) {
      s.rear_disc_only = true;
      s.zero_if_neighbour_blocked = true;
    }
    const RealisticCamera cam(s);
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> u(0, 1);
    int rays = 0;
    for (int batch = 0; batch < 400; ++batch) {
      const int n = 1 + batch % Camera::kMaxBatch;
      CameraSample cs[Camera::kMaxBatch];
      std::optional<CameraRay> out[Camera::kMaxBatch];
      for (int i = 0; i < n; ++i) cs[i] = {{300 * u(rng), 200 * u(rng)}, {u(rng), u(rng)}, u(rng)};
      cam.generateRays(cs, n, out);
      for (int i = 0; i < n; ++i) {
        const auto one = cam.generateRay(cs[i]);
        ASSERT_EQ(one.has_value(), out[i].has_value()) << "variant " << variant;
        if (!one) continue;
        ++rays;
        EXPECT_EQ(one->origin.x, out[i]->origin.x);
        EXPECT_EQ(one->origin.z, out[i]->origin.z);
        EXPECT_EQ(one->direction.y, out[i]->direction.y);
        EXPECT_EQ(one->weight, out[i]->weight);
        EXPECT_EQ(one->time, out[i]->time);
      }
    }
    EXPECT_GT(rays, 1000);
  }
}

// Render statistics count a sample without a ray as wasted only where light reaches its film
// point at its hero wavelength (reachesFilm): a dispersive lens's image circle shrinks with the
// wavelength, and where the sample's band has no bound no pupil point is drawn. So reachesFilm
// false means generateRay gives nothing, and near the edge of lentil:0007's image circle some
// film points are reached at one wavelength and not at another.
TEST(RealisticCamera, ReachesFilmAtTheSamplesWavelength) {
  RealisticSettings s;
  s.lens_path = "lentil:0007";
  s.setup.aperture_diameter_mm = 100.0;
  s.setup.focus_distance_m = 3.3;
  s.film_diagonal_mm = 43.3;
  s.x_resolution = 240;
  s.y_resolution = 160;
  const RealisticCamera cam(s);
  ASSERT_TRUE(cam.lens().lens->dispersive());
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0, 1);
  int unreached = 0, reached_elsewhere = 0;
  for (int k = 0; k < 200000; ++k) {
    CameraSample a;
    a.film_raster = {240 * u(rng), 160 * u(rng)};
    a.lens = {u(rng), u(rng)};
    a.lambda_nm = {360 + 470 * u(rng), 0, 0, 0};
    if (cam.reachesFilm(a)) continue;
    ++unreached;
    EXPECT_FALSE(cam.generateRay(a).has_value());
    CameraSample b = a;
    for (double l : {400.0, 500.0, 600.0, 700.0, 800.0}) {
      b.lambda_nm[0] = l;
      if (cam.reachesFilm(b)) {
        ++reached_elsewhere;
        break;
      }
    }
  }
  EXPECT_GT(unreached, 0);
  EXPECT_GT(reached_elsewhere, 0);
}
