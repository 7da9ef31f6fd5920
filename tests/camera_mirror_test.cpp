// The realistic camera through a catadioptric lens (lenses/cassegrain.500mm.json): an
// out-of-focus point images as the annular pupil, a ring with a dark centre whose inner/outer
// radius ratio is the obscuration's, 15 mm / 31.25 mm (the front obscuration over the stop, the
// primary mirror; the entrance pupil is the primary itself).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "lensim/camera/realistic.h"
#include "test_paths.h"

using namespace lensim;
using namespace lensim::camera;

TEST(RealisticCamera, CatadioptricLensGivesRingBokeh) {
  RealisticSettings s;
  s.lens_path = "lenses:cassegrain.500mm";
  s.setup.aperture_diameter_mm = 62.5;  // wide open (f/8)
  s.setup.focus_distance_m = 5.0;
  constexpr int kRes = 64;
  s.x_resolution = s.y_resolution = kRes;
  s.film_diagonal_mm = 10 * std::sqrt(2.0);  // 10 x 10 mm around the axis, 0.156 mm pixels
  RealisticCamera cam(s);
  // A disc of radius 1 cm on the axis 20 m from the film: its sharp image is 0.26 mm across. Out
  // of focus, by the thick-lens equation (the Cassegrain's front principal plane lies 411 mm in
  // front of its front vertex, 613 mm from the film; object distances 4387 and 19387 mm, image
  // distances 564.3 and 513.2 mm) its blur is 62.5 mm x (564.3 - 513.2) / 513.2 = 6.2 mm across,
  // a radius of 19.9 pixels.
  const double z = 20.0, radius = 0.01;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<double> hits(kRes * kRes, 0.0);
  double cx = 0, cy = 0, total = 0;
  for (int y = 0; y < kRes; ++y)
    for (int x = 0; x < kRes; ++x) {
      for (int k = 0; k < 128; ++k) {
        auto r = cam.generateRay({{x + u(rng), y + u(rng)}, {u(rng), u(rng)}, 0});
        if (!r) continue;
        const double t = (z - r->origin.z) / r->direction.z;
        const Vec3 p = r->origin + r->direction * t;
        if (std::hypot(p.x, p.y) < radius) hits[size_t(y * kRes + x)] += r->weight;
      }
      const double h = hits[size_t(y * kRes + x)];
      cx += h * (x + 0.5), cy += h * (y + 0.5), total += h;
    }
  ASSERT_GT(total, 0);
  cx /= total, cy /= total;
  // Radial profile about the centroid, in 1-pixel rings.
  std::vector<double> sum(kRes, 0.0), cnt(kRes, 0.0);
  for (int y = 0; y < kRes; ++y)
    for (int x = 0; x < kRes; ++x) {
      const int ring = int(std::hypot(x + 0.5 - cx, y + 0.5 - cy));
      if (ring < kRes) sum[size_t(ring)] += hits[size_t(y * kRes + x)], cnt[size_t(ring)] += 1;
    }
  std::vector<double> prof(kRes, 0.0);
  double peak = 0;
  for (int i = 0; i < kRes; ++i) {
    prof[size_t(i)] = cnt[size_t(i)] > 0 ? sum[size_t(i)] / cnt[size_t(i)] : 0.0;
    peak = std::max(peak, prof[size_t(i)]);
  }
  // Inner and outer radii where the profile crosses half its peak.
  int inner = -1, outer = -1;
  for (int i = 0; i < kRes; ++i)
    if (prof[size_t(i)] >= 0.5 * peak) {
      if (inner < 0) inner = i;
      outer = i;
    }
  ASSERT_GT(inner, 0) << "no dark centre";
  const double r_in = inner, r_out = outer + 1;  // ring edges (pixels)
  EXPECT_NEAR(r_out, 19.9, 2.0);                 // the blur from the thick-lens estimate
  EXPECT_NEAR(r_in / r_out, 15.0 / 31.25, 0.1);  // the obscuration ratio
  // The centre (inside half the hole) against the ring's middle.
  double centre = 0, ring = 0, nc = 0, nr = 0;
  for (int i = 0; i < kRes; ++i) {
    if (i < 0.5 * r_in) centre += sum[size_t(i)], nc += cnt[size_t(i)];
    if (i >= r_in + 1 && i + 1 <= r_out - 1) ring += sum[size_t(i)], nr += cnt[size_t(i)];
  }
  const double ratio = (centre / nc) / (ring / nr);
  RecordProperty("centre_to_ring", std::to_string(ratio));
  RecordProperty("ring_radii_px", std::to_string(r_in) + " " + std::to_string(r_out));
  EXPECT_LT(ratio, 0.01);
}
