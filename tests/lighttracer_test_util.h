// Comparing a light-traced render with a path-traced one (tests of camera importance).
#pragma once

#include <fmt/format.h>

#include <cmath>
#include <functional>
#include <string>

#include "lensim/render/image_compare.h"
#include "render_test_util.h"

namespace lensim::testutil {

struct LtComparison {
  render::CompareResult result;
  double lt_mean = 0, path_mean = 0;  ///< image means (RGB average)
  double mean_se = 0;                 ///< standard error of their difference
  double mean_z = 0;                  ///< (lt - path) / mean_se
  std::string summary() const {
    return fmt::format(
        "{} blocks, {} beyond |z| {:.2f}; image mean light tracer {:.5g}, path {:.5g}, ratio "
        "{:.4f}, z {:.2f}",
        result.blocks, result.z_failures, result.z_bound, lt_mean, path_mean,
        path_mean != 0 ? lt_mean / path_mean : 0.0, mean_z);
  }
};

inline double imageMean(const io::Image& im) {
  double s = 0;
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x)
      for (int c = 0; c < 3; ++c) s += im.at(x, y, c);
  return s / (3.0 * im.width * im.height);
}

/// Renders scene(integrator) with "lighttracer" 8 times at lt_spp (seeds 1..8) and "path" at
/// path_spp (seed 11) and path_spp / 4 (seed 12), and compares them by blocks of `block` pixels:
/// the z-test takes the mean of the first four light-traced renders and that of the last four as
/// its two renders. The image means' standard errors: the light tracer's from the spread of its
/// 8 image means (its pixels are correlated: one light path splats into several), the path
/// tracer's from its per-pixel variance (independent pixels), (low - ref)^2 / 3.
inline LtComparison compareLightTracer(const std::function<std::string(const char*)>& scene,
                                       int lt_spp, int path_spp, int block = 8) {
  constexpr int kRuns = 8;
  render::RenderOptions o;
  o.spp = lt_spp;
  const std::string lt_scene = scene("lighttracer");
  io::Image halves[2];
  double means[kRuns];
  for (int k = 0; k < kRuns; ++k) {
    o.seed = k + 1;
    const io::Image im = renderText(lt_scene, o).image;
    means[k] = imageMean(im);
    io::Image& h = halves[k / (kRuns / 2)];
    if (h.pixels.empty())
      h = im;
    else
      for (size_t i = 0; i < h.pixels.size(); ++i) h.pixels[i] += im.pixels[i];
  }
  for (io::Image& h : halves)
    for (float& v : h.pixels) v /= float(kRuns / 2);
  o.spp = path_spp;
  o.seed = 11;
  const std::string path_scene = scene("path");
  const io::Image ref = renderText(path_scene, o).image;
  o.spp = path_spp / 4;
  o.seed = 12;
  const io::Image low = renderText(path_scene, o).image;
  render::CompareOptions co;
  co.block = block;
  co.second = &halves[1];
  co.spp = lt_spp * kRuns / 2;
  co.reference_spp = path_spp;
  co.reference_low = &low;
  co.reference_low_spp = path_spp / 4;
  LtComparison c;
  c.result = render::compareImages(halves[0], ref, co);
  double m = 0, v = 0;
  for (double x : means) m += x / kRuns;
  for (double x : means) v += (x - m) * (x - m) / (kRuns - 1);
  c.lt_mean = m;
  c.path_mean = imageMean(ref);
  double var_path = 0;
  for (int y = 0; y < ref.height; ++y)
    for (int x = 0; x < ref.width; ++x)
      for (int ch = 0; ch < 3; ++ch) {
        const double d = double(low.at(x, y, ch)) - ref.at(x, y, ch);
        var_path += d * d / 3;
      }
  // The mean of 3 N values, each of variance var_pixel: var / (3 N)^2 summed.
  const double n = 3.0 * ref.width * ref.height;
  var_path /= n * n;
  c.mean_se = std::sqrt(v / kRuns + var_path);
  c.mean_z = c.mean_se > 0 ? (c.lt_mean - c.path_mean) / c.mean_se : 0;
  return c;
}

}  // namespace lensim::testutil
