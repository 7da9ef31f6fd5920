// Focus breathing through the realistic camera (docs/zoom.md, "Group focusing and focus
// breathing"): the triplet whose middle element focuses (tests/data/lenses/group_focus_triplet.
// json), at infinity focus and at 0.5 m. The image of a point is measured as the renderer sees
// it: the irradiance centroid of the light reaching the film from it (the camera's sampleWi
// over a stratified grid of lens points, each weighted by importance / pdf, as the light tracer
// splats it). Predicted by a paraxial y-nu trace of the lens written here, with the group
// position solved here (bisection) so that the object at 0.5 m images on the film that stays at
// the infinity focus's place: the image height of a distant point at a fixed angle changes by the
// predicted factor (breathing), and points of the focused plane image at the predicted
// magnification.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <limits>

#include "lensim/camera/realistic.h"
#include "lensim/optics/lens_system.h"
#include "test_paths.h"

using namespace lensim;

namespace {

// The triplet: radius, thickness, index after; gaps 1 and 3 are the focus group's (a = 10 + x,
// b = 10 - x: the middle element moves by x toward the film).
struct Row {
  double r, t, n;
};
constexpr std::array<Row, 6> kLens = {
    {{50, 4, 1.6}, {-200, 10, 1}, {40, 4, 1.6}, {100, 10, 1}, {-30, 3, 1.6}, {-60, 0, 1}}};

// (y, u) at the rear vertex and its z, for a ray (y, u) at the front vertex (z = 0).
std::array<double, 3> trace(double a, double b, double y, double u) {
  double n = 1, z = 0;
  for (size_t i = 0; i < kLens.size(); ++i) {
    const double nu = n * u - y * (kLens[i].n - n) / kLens[i].r;
    n = kLens[i].n;
    u = nu / n;
    if (i + 1 == kLens.size()) break;
    const double t = i == 1 ? a : i == 3 ? b : kLens[i].t;
    y += t * u;
    z += t;
  }
  return {y, u, z};
}

// Height on the film at z_film of the ray from the object point (h, z_obj) through the front
// vertex's centre (the stop: the lens has no other; the chief ray).
double chiefHeight(double a, double b, double h, double z_obj, double z_film) {
  const auto o = trace(a, b, 0, -h / -z_obj);
  return o[0] + (z_film - o[2]) * o[1];
}

// The group position x that images the axial point at z_obj on the film at z_film.
double solveGroup(double z_obj, double z_film) {
  auto miss = [&](double x) {
    const double u0 = 1e-3;
    const auto o = trace(10 + x, 10 - x, -z_obj * u0, u0);
    return o[0] + (z_film - o[2]) * o[1];  // the axial ray's height on the film
  };
  double lo = -9.9, hi = 0;  // the element moves toward the scene to focus closer
  EXPECT_LT(miss(lo) * miss(hi), 0);
  for (int i = 0; i < 200; ++i) {
    const double m = 0.5 * (lo + hi);
    (miss(m) * miss(lo) > 0 ? lo : hi) = m;
  }
  return 0.5 * (lo + hi);
}

constexpr int kWidth = 640, kHeight = 480;

camera::RealisticSettings settings(double focus_m) {
  camera::RealisticSettings s;
  s.lens_path = test::dataPath("lenses/group_focus_triplet.json");  // full aperture, f/4.8
  s.setup.focus_distance_m = focus_m;
  s.x_resolution = kWidth;
  s.y_resolution = kHeight;
  s.film_diagonal_mm = 20;
  return s;
}

// The irradiance centroid on the film (film mm, lens space x, y) of a point at camera-space
// (0, y_m, z_m) metres (the camera at the origin looking along +z).
Vec2 centroid(const camera::RealisticCamera& cam, double y_m, double z_m) {
  constexpr int kGrid = 160;
  double w = 0;
  Vec2 c{0, 0};
  for (int i = 0; i < kGrid; ++i)
    for (int j = 0; j < kGrid; ++j) {
      const Vec2 u{(i + 0.5) / kGrid, (j + 0.5) / kGrid};
      const auto s = cam.sampleWi({0, y_m, z_m}, u, {0, 0, 0, 0}, 0);
      if (!s || !(s->pdf > 0)) continue;
      const double e = s->importance[0] / s->pdf;
      const Vec2 f = cam.filmPoint(s->film_raster);
      c = c + f * e;
      w += e;
    }
  EXPECT_GT(w, 0);
  return c * (1 / w);
}

}  // namespace

TEST(Breathing, ImageScaleChangesByThePredictedFactor) {
  const camera::RealisticCamera far(settings(std::numeric_limits<double>::infinity()));
  const camera::RealisticCamera near(settings(0.5));
  // The film stays where the infinity focus puts it: the rest lens's paraxial BFL.
  const auto inf = trace(10, 10, 1, 0);
  const double z_film = inf[2] - inf[0] / inf[1];
  ASSERT_NEAR(far.lens().lens->filmZ_mm(), z_film, 1e-6);
  ASSERT_NEAR(near.lens().lens->filmZ_mm(), z_film, 1e-6);
  const double x = solveGroup(z_film - 500, z_film);
  const auto& rows = near.lens().lens->prescription().surfaces;
  EXPECT_NEAR(rows[1].thickness_mm, 10 + x, 1e-6);
  EXPECT_NEAR(rows[3].thickness_mm, 10 - x, 1e-6);
  const double pixel = 2 * far.filmPoint({0, 0}).x / kWidth;  // film width / pixels
  std::printf("group moved %.5f mm for 0.5 m; pixel %.4f mm\n", x, pixel);

  // A distant point (100 m) at 3 degrees: its image height at both focus settings.
  const double deg = M_PI / 180, d = 100, a = 3 * deg;
  const double h = d * std::sin(a) * 1000, z_obj = z_film - d * std::cos(a) * 1000;
  const double pred_far = chiefHeight(10, 10, h, z_obj, z_film);
  const double pred_near = chiefHeight(10 + x, 10 - x, h, z_obj, z_film);
  const Vec2 m_far = centroid(far, d * std::sin(a), d * std::cos(a));
  const Vec2 m_near = centroid(near, d * std::sin(a), d * std::cos(a));
  std::printf(
      "3 deg at 100 m: image height at infinity focus %.5f mm (paraxial %.5f), at 0.5 m %.5f mm "
      "(paraxial %.5f); scale change %.5f (paraxial %.5f)\n",
      m_far.y, pred_far, m_near.y, pred_near, m_near.y / m_far.y, pred_near / pred_far);
  EXPECT_NEAR(m_far.x, 0, 1e-3);
  EXPECT_NEAR(m_near.x, 0, 1e-3);
  // The image scale changes by the predicted factor, within a quarter of a pixel at this height
  // (measured 0.17 px: the full-aperture beam's centroid lies about 0.5% of the image height off
  // the paraxial chief ray, the lens's aberrations, nearly alike at both focus settings).
  EXPECT_NEAR(m_near.y, m_far.y * pred_near / pred_far, 0.25 * pixel);
  // And breathing is there to see: several pixels of change (6.7).
  EXPECT_GT(std::abs(m_near.y - m_far.y), 5 * pixel);

  // Points of the focused plane (0.5 m from the film) at the predicted magnification.
  // Within a pixel (measured 0.22 and 0.45 px: the same 0.4% of the image height).
  for (double hy : {10.0, 20.0}) {
    const double zo = z_film - 500;
    const double pred = chiefHeight(10 + x, 10 - x, hy, zo, z_film);
    const Vec2 m = centroid(near, hy / 1000, 0.5);
    std::printf("object %.0f mm at 0.5 m: image %.5f mm, paraxial %.5f mm (magnification %.6f)\n",
                hy, m.y, pred, pred / hy);
    EXPECT_NEAR(m.y, pred, pixel);
  }
}
