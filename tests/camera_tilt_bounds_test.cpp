// The exit-pupil bounds of the realistic camera's tilted film (issue 30; docs/zoom.md, "Sampling
// and weight"): per film point a polygon of the rear surface's plane (camera/placed_pupil.h)
// instead of the disc that holds every ray reaching the rear surface. Checked: conservative
// (random film/plane points, each ray built here from the tilt written out in the test and traced
// by the double-precision tracer, at 48 wavelengths for a dispersive lens: none outside the
// sampled region gets through), unbiased (the film irradiance with and without the bounds agrees
// by a z-test at film points across the film) and less wasteful (printed for docs/zoom.md).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "lensim/camera/realistic.h"
#include "lensim/optics/lens_system.h"
#include "test_paths.h"

using namespace lensim;

namespace {

constexpr double kDeg = M_PI / 180;

struct Case {
  std::string lens;
  double aperture_mm, focus_m;
  Vec2 tilt, shift;
};

// The table scene's lens and tilt (scenes/tiltshift/table-tilt.pbrt, f/2.8 on a 43.3 mm
// diagonal), a tilt about both axes with a shift, and a dispersive Zemax double Gauss.
std::vector<Case> cases() {
  return {{test::lensPath("dgauss.50mm.dat"), 12.4, 1.28, {-7.02, 0}, {0, 0}},
          {test::lensPath("dgauss.50mm.dat"), 12, 3, {5, -3}, {-2, 4}},
          {std::string(LENSIM_SHARED_DIR) + "/lenses/zmx/US00583336-2-scaled.zmx",
           10,
           3,
           {4, 2},
           {0, 0}}};
}

camera::RealisticSettings settings(const Case& c, bool bounds) {
  camera::RealisticSettings s;
  s.lens_path = c.lens;
  s.setup.aperture_diameter_mm = c.aperture_mm;
  s.setup.focus_distance_m = c.focus_m;
  s.x_resolution = 36;
  s.y_resolution = 24;
  s.film_diagonal_mm = 43.3;
  s.tilt_shift.tilt_deg = c.tilt;
  s.tilt_shift.shift_mm = c.shift;
  s.tilt_pupil_bounds = bounds;
  return s;
}

// Film frame to lens space written out here: R = Ry(b) Rx(a), p_lens = R^T (p - s) + z_film.
Vec3 rotXT(const Vec3& v, double a) {
  return {v.x, std::cos(a) * v.y + std::sin(a) * v.z, -std::sin(a) * v.y + std::cos(a) * v.z};
}
Vec3 rotYT(const Vec3& v, double b) {
  return {std::cos(b) * v.x - std::sin(b) * v.z, v.y, std::sin(b) * v.x + std::cos(b) * v.z};
}
Vec3 lensFromFilm(Vec2 film, const Case& c, double z_film) {
  Vec3 p =
      rotXT(rotYT({film.x - c.shift.x, film.y - c.shift.y, 0}, c.tilt.y * kDeg), c.tilt.x * kDeg);
  p.z += z_film;
  return p;
}

}  // namespace

// Film points uniform over the film (out to the pixel filter's reach), plane points half over
// the disc's square, half over the polygon's bounding box widened to twice its size (the
// boundary's neighbourhood), wavelengths over 360-830 nm for the dispersive lens: every ray that
// gets through the lens lies in the film point's sampled region.
TEST(TiltPupilBounds, NoPassingRayOutsideTheRegion) {
  for (const Case& c : cases()) {
    const camera::RealisticCamera cam(settings(c, true));
    const optics::LensSystem& lens = *cam.lens().lens;
    const camera::PlacedPupilBounds& b = cam.tiltPupilBounds();
    ASSERT_GT(b.binsX() * b.binsY(), 16);
    const bool dispersive = c.lens.ends_with(".zmx");
    std::vector<optics::LensSystem> lenses;
    if (dispersive)
      for (int k = 0; k < 48; ++k) lenses.push_back(lens.atWavelength(360 + 470 * (k + 0.5) / 48));
    const Vec3 normal = rotXT(rotYT({0, 0, 1}, c.tilt.y * kDeg), c.tilt.x * kDeg);
    const double zp = cam.tiltPlaneZ_mm();
    // The film's sampled extent: the corner pixel's centre less the filter's half pixel.
    const Vec2 corner = cam.filmPoint({0, 0});
    std::mt19937_64 rng(30);
    std::uniform_real_distribution<double> u01(0, 1);
    long outside = 0, outside_through = 0, inside = 0, inside_through = 0, polygons = 0;
    double area_ratio = 0;
    const int n = getenv("TILT_N") ? atoi(getenv("TILT_N")) : 150000;
    for (int i = 0; i < n; ++i) {
      const Vec2 film{corner.x * (2 * u01(rng) - 1), corner.y * (2 * u01(rng) - 1)};
      const camera::PupilRegion region = cam.tiltRegion(film);
      const double r = region.disc_radius;
      ASSERT_GT(r, 0);
      area_ratio += region.area() / (M_PI * r * r);
      polygons += region.polygon ? 1 : 0;
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
      const Vec2 q{lo.x + (hi.x - lo.x) * u01(rng), lo.y + (hi.y - lo.y) * u01(rng)};
      const Vec3 x = lensFromFilm(film, c, lens.filmZ_mm());
      const Vec3 d = normalize(Vec3{q.x, q.y, zp} - x);
      const optics::LensSystem& l = dispersive ? lenses[size_t(u01(rng) * 48)] : lens;
      const bool through = dot(d, normal) < 0 && l.tracer().traceFromFilm(optics::Ray{x, d}).ok();
      if (region.holds(q)) {
        ++inside, inside_through += through;
      } else {
        ++outside, outside_through += through;
        // How far outside the region q lies (mm).
        double out = std::hypot(q.x, q.y) - r;
        if (region.polygon) {
          out = 0;
          const camera::PlacedPolygon& p = *region.polygon;
          for (int k = 0; k < p.n; ++k) {
            const Vec2 a = p.v[size_t(k)], e = p.v[size_t((k + 1) % p.n)] - a;
            out = std::max(out, (e.y * (q.x - a.x) - e.x * (q.y - a.y)) / std::hypot(e.x, e.y));
          }
        }
        // The camera's own (float) tracer too, for the message.
        const bool through_float =
            l.tracerFloat().traceFromFilm(optics::RayT<float>{Vec3f(x), Vec3f(d)}).ok();
        EXPECT_FALSE(through) << "film (" << film.x << ", " << film.y << ") plane (" << q.x << ", "
                              << q.y << "), " << out << " mm outside; float tracer "
                              << (through_float ? "passes" : "blocks");
      }
    }
    std::printf(
        "%s tilt (%g, %g) shift (%g, %g): %d x %d bins (%d without a bound), %llu traces; %.1f%% "
        "of film points with a polygon, mean area / disc area %.3f; outside %ld (through %ld), "
        "inside %ld (through %ld)\n",
        c.lens.c_str(), c.tilt.x, c.tilt.y, c.shift.x, c.shift.y, b.binsX(), b.binsY(),
        b.wholeBins(), static_cast<unsigned long long>(b.traces()), 100.0 * polygons / n,
        area_ratio / n, outside, outside_through, inside, inside_through);
    EXPECT_EQ(outside_through, 0);
    EXPECT_GT(inside_through, 0);
    EXPECT_GT(polygons, n / 2);      // most of the film has a bound
    EXPECT_LT(area_ratio / n, 0.8);  // and it is smaller than the disc
  }
}

// The camera's mean ray weight (the film irradiance of a uniform radiance field) with and
// without the bounds at film points across the film: a z-test on the difference (|z| < 4.5), and
// the bounds' waste (samples without a ray) and standard error per sample, printed.
TEST(TiltPupilBounds, FlatFieldAgreesWithTheDisc) {
  for (const Case& c : cases()) {
    const camera::RealisticCamera bounded(settings(c, true)), disc(settings(c, false));
    EXPECT_EQ(disc.tiltPupilBounds().binsX(), 0);
    long none_bounded = 0, none_disc = 0;
    for (const Vec2 raster : {Vec2{18, 12}, Vec2{1, 1}, Vec2{35, 2}, Vec2{3, 22}, Vec2{30, 18}}) {
      struct Stats {
        double sum = 0, sum2 = 0;
        long none = 0;
      };
      const auto run = [&](const camera::RealisticCamera& cam, unsigned seed) {
        std::mt19937_64 rng(seed);
        std::uniform_real_distribution<double> u01(0, 1);
        Stats s;
        for (int i = 0; i < 100000; ++i) {
          camera::CameraSample cs;
          cs.film_raster = raster;
          cs.lens = {u01(rng), u01(rng)};
          const std::optional<camera::CameraRay> r = cam.generateRay(cs);
          const double w = r ? r->weight : 0.0;
          s.none += r ? 0 : 1;
          s.sum += w, s.sum2 += w * w;
        }
        return s;
      };
      const Stats a = run(bounded, 1), b = run(disc, 2);
      const double n = 100000, ma = a.sum / n, mb = b.sum / n;
      const double va = a.sum2 / n - ma * ma, vb = b.sum2 / n - mb * mb;
      const double se = std::sqrt(va / n + vb / n);
      std::printf(
          "tilt (%g, %g) raster (%g, %g): bounded %.6f (%.1f%% no ray, sd %.4f), disc %.6f "
          "(%.1f%% no ray, sd %.4f), z %+.2f\n",
          c.tilt.x, c.tilt.y, raster.x, raster.y, ma, 100 * a.none / n, std::sqrt(va), mb,
          100 * b.none / n, std::sqrt(vb), (ma - mb) / se);
      ASSERT_GT(mb, 0);
      EXPECT_LT(std::abs(ma - mb) / se, 4.5) << raster.x << ", " << raster.y;
      EXPECT_LT(se, 0.015 * mb);  // the test can see a 7% difference
      none_bounded += a.none, none_disc += b.none;
    }
    EXPECT_LT(none_bounded, none_disc);
  }
}
