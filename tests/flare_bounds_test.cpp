// Lens flare's per-ghost bounds (issue 31, docs/flare.md "Per-ghost bounds"): each ghost pair
// draws its directions from a box of the sampling plane per film-radius bin instead of the disc
// that holds every pair's rays. Checked: conservative (10^6 points outside the boxes, traced
// through their ghost paths by the lens's tracer here, none gets through), unbiased (the ghost
// irradiance with and without the bounds agrees by a z-test at film points and over the film),
// and more ghost paths get through.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "lensim/camera/realistic.h"
#include "lensim/optics/coating/ghost_trace.h"
#include "lensim/optics/lens_system.h"

using namespace lensim;

namespace {

// The double Gauss at f/2 (bench/flare_ghost_waste.sh's setup), uncoated.
camera::RealisticSettings settings(bool bounds) {
  camera::RealisticSettings s;
  s.lens_path = std::string(LENSIM_SOURCE_DIR) + "/lenses/dgauss.50mm.dat";
  s.setup.aperture_diameter_mm = 17.1;
  s.setup.focus_distance_m = 25;
  s.x_resolution = 64, s.y_resolution = 48;
  s.film_diagonal_mm = 43.3;
  s.flare = true;
  s.flare_ghost_bounds = bounds;
  return s;
}

struct Stats {
  double mean = 0, se = 0, through = 0;
};

// Ghost irradiance estimates (channel 0) of n camera samples at the raster point (or uniformly
// over the film when raster.x < 0), and the fraction of ghost paths that get through.
Stats ghostIrradiance(const camera::RealisticCamera& cam, Vec2 raster, int n, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uni(0, 1);
  camera::CameraSample cs;
  cs.lambda_nm = {550, 550, 550, 550};
  double s1 = 0, s2 = 0, through = 0;
  for (int i = 0; i < n; ++i) {
    cs.film_raster = raster.x >= 0 ? raster : Vec2{64 * uni(rng), 48 * uni(rng)};
    cs.ghost_u = {uni(rng), uni(rng), uni(rng)};
    const auto r = cam.generateGhostRay(cs);
    const double w = r ? r->weight : 0;
    s1 += w, s2 += w * w, through += r ? 1 : 0;
  }
  const double m = s1 / n;
  return {m, std::sqrt(std::max(0.0, s2 / n - m * m) / n), through / n};
}

}  // namespace

TEST(FlareBounds, NoGhostPathGetsThroughOutsideItsBound) {
  const camera::RealisticCamera cam(settings(true));
  const optics::LensSystem& lens = *cam.lens().lens;
  const std::vector<camera::RealisticCamera::GhostChoice> pairs = cam.ghostChoices();
  ASSERT_EQ(pairs.size(), 45u);
  const double z_film = lens.filmZ_mm(), z_plane = cam.ghostPlaneZ_mm();
  const double rear = lens.interfaces().back().semi_aperture_mm;
  const Vec2 corner = cam.filmPoint({0, 0});
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> uni(0, 1);
  const int per_pair = 1000000 / 45 + 1;
  long outside = 0, outside_through = 0, inside = 0, inside_through = 0;
  for (int k = 0; k < int(pairs.size()); ++k) {
    const optics::LensTracer<double> tracer(
        optics::ghostPathInterfaces(lens, pairs[size_t(k)].first, pairs[size_t(k)].second));
    for (int i = 0; i < per_pair; ++i) {
      // A film point over the frame, a point of the sampling plane over a square that holds
      // every ray reaching the rear element (its clear radius plus the film point's offset).
      const Vec2 x{corner.x * (2 * uni(rng) - 1), corner.y * (2 * uni(rng) - 1)};
      const double half = rear + std::hypot(x.x, x.y);
      const Vec2 q{half * (2 * uni(rng) - 1), half * (2 * uni(rng) - 1)};
      const Vec3 from{x.x, x.y, z_film};
      const bool through =
          tracer.traceFromFilm(optics::Ray{from, normalize(Vec3{q.x, q.y, z_plane} - from)}).ok();
      if (cam.ghostRegionHolds(k, x, q)) {
        ++inside, inside_through += through;
      } else {
        ++outside, outside_through += through;
        EXPECT_FALSE(through) << "pair " << pairs[size_t(k)].first << "," << pairs[size_t(k)].second
                              << " film (" << x.x << ", " << x.y << ") plane (" << q.x << ", "
                              << q.y << ")";
      }
    }
  }
  EXPECT_GT(outside, 500000);  // the bounds leave out most of the square
  EXPECT_EQ(outside_through, 0);
  EXPECT_GT(inside_through, 1000);
  std::printf("outside the bounds %ld points, through %ld; inside %ld, through %ld\n", outside,
              outside_through, inside, inside_through);
}

TEST(FlareBounds, GhostIrradianceAgreesAndMorePathsGetThrough) {
  const camera::RealisticCamera with(settings(true)), without(settings(false));
  const int n = 200000;
  for (Vec2 raster : {Vec2{32, 24}, Vec2{50, 36}, Vec2{62, 46}, Vec2{-1, -1}}) {
    const Stats a = ghostIrradiance(with, raster, n, 3), b = ghostIrradiance(without, raster, n, 4);
    const double z = (a.mean - b.mean) / std::hypot(a.se, b.se);
    EXPECT_LT(std::abs(z), 4) << raster.x << " " << raster.y << ": " << a.mean << " +- " << a.se
                              << " against " << b.mean << " +- " << b.se;
    EXPECT_GT(a.through, b.through);
    std::printf(
        "raster (%g, %g): ghost irradiance %.5e +- %.1e with bounds, %.5e +- %.1e "
        "without (z %.2f); through %.3f against %.3f\n",
        raster.x, raster.y, a.mean, a.se, b.mean, b.se, z, a.through, b.through);
  }
}
