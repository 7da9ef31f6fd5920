// Lens flare (issue 31): the ghost estimator of the realistic camera's "bool flare" against plain
// Russian roulette at the interfaces, in a flat field (radiance 1) at the film centre.
//
// Both draw the direction from the film point uniformly over the same disc (realistic_flare.cpp),
// so they differ only in how a ghost is chosen:
//  - flare's: pair k with probability p_k (the workbench's intensities with a floor), weight
//    w_k / p_k, where w_k = G F_k (G the geometric weight of the direction, F_k the product of the
//    ghost path's R and T at its angles): per direction E[Y^2] = sum_k w_k^2 / p_k;
//  - Russian roulette (an analog walk that reflects with probability R and passes with T at each
//    interface): the direction becomes ghost k with probability F_k and then scores G, so
//    E[X^2] = G sum_k F_k G = G sum_k w_k (paths with four or more reflections left out, which
//    favours roulette slightly).
// The means agree (sum_k w_k); the ratio of the variances is the factor in samples. w_k is read
// from the camera (generateGhostRay with the choice u set inside pair k's interval, times p_k);
// G at the film centre is cos^4(theta) pi r^2 / z^2 (r the rear element's clear radius, z the
// film distance, the rear vertex being the rear surface's point nearest the film, as in the
// double Gauss). Also the camera's cost per sample with and without flare.
//
// Then the variance per sample with the per-ghost bounds (on by default in renders).
// Usage: lensim_bench_flare [COATING]   (uncoated by default; single, multi)
#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "lensim/camera/realistic.h"
#include "lensim/optics/lens_system.h"
#include "lensim/sampling/sampling.h"

using namespace lensim;

int main(int argc, char** argv) {
  const std::string coating = argc > 1 ? argv[1] : "uncoated";
  camera::RealisticSettings s;
  s.lens_path = std::string(LENSIM_SOURCE_DIR) + "/lenses/dgauss.50mm.dat";
  s.setup.aperture_diameter_mm = 12;
  s.setup.focus_distance_m = 3;
  s.x_resolution = s.y_resolution = 256;
  s.flare = true;
  s.flare_coating = coating;
  // The roulette comparison below draws directions over the disc that holds every pair's rays;
  // the per-ghost bounds (on by default) are measured separately after it.
  s.flare_ghost_bounds = false;
  const camera::RealisticCamera cam(s);
  const std::vector<camera::RealisticCamera::GhostChoice> choices = cam.ghostChoices();
  const optics::LensSystem& lens = *cam.lens().lens;
  const double z = lens.filmDistance_mm(), r = lens.interfaces().back().semi_aperture_mm;

  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> uni(0, 1);
  const int n = 20000;
  double mean = 0, m2_flare = 0, m2_rr = 0;
  camera::CameraSample cs;
  cs.film_raster = {128, 128};
  cs.lambda_nm = {550, 550, 550, 550};
  for (int i = 0; i < n; ++i) {
    cs.ghost_u[1] = uni(rng), cs.ghost_u[2] = uni(rng);
    const Vec2 d = sampling::sampleUniformDiskConcentric({cs.ghost_u[1], cs.ghost_u[2]}) * r;
    const double c2 = z * z / (z * z + d.x * d.x + d.y * d.y);
    const double g = c2 * c2 * M_PI * r * r / (z * z);
    double lo = 0, sum_w = 0, sum_w2p = 0;
    for (const auto& ch : choices) {
      cs.ghost_u[0] = lo + 0.5 * ch.probability;
      lo += ch.probability;
      const std::optional<camera::CameraRay> ray = cam.generateGhostRay(cs);
      if (!ray) continue;
      const double w = ray->weight * ch.probability;
      sum_w += w;
      sum_w2p += w * w / ch.probability;
    }
    mean += sum_w / n;
    m2_flare += sum_w2p / n;
    m2_rr += g * sum_w / n;
  }
  const double var_flare = m2_flare - mean * mean, var_rr = m2_rr - mean * mean;

  // The same estimator with the per-ghost bounds: its variance per sample (each pair's
  // directions drawn from its own bound).
  camera::RealisticSettings sb = s;
  sb.flare_ghost_bounds = true;
  const auto t_setup = std::chrono::steady_clock::now();
  const camera::RealisticCamera bounded(sb);
  const double setup_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_setup).count();
  double mean_b = 0, m2_b = 0;
  for (int i = 0; i < n; ++i) {
    cs.ghost_u[1] = uni(rng), cs.ghost_u[2] = uni(rng);
    double lo = 0, sum_w = 0, sum_w2p = 0;
    for (const auto& ch : choices) {
      cs.ghost_u[0] = lo + 0.5 * ch.probability;
      lo += ch.probability;
      const std::optional<camera::CameraRay> ray = bounded.generateGhostRay(cs);
      if (!ray) continue;
      const double w = ray->weight * ch.probability;
      sum_w += w;
      sum_w2p += w * w / ch.probability;
    }
    mean_b += sum_w / n;
    m2_b += sum_w2p / n;
  }
  std::printf(
      "with per-ghost bounds (camera set up in %.2f s): ghost irradiance %.4e, variance "
      "per sample %.3e (%.2fx less than without)\n",
      setup_s, mean_b, m2_b - mean_b * mean_b, var_flare / (m2_b - mean_b * mean_b));

  // Cost per camera sample: generateRay alone (flare off) and generateRay + generateGhostRay.
  camera::RealisticSettings off = s;
  off.flare = false;
  off.flare_coating.clear();
  const camera::RealisticCamera plain(off);
  auto time = [&](bool with_flare) {
    const int m = 200000;
    double sink = 0;
    const auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; i < m; ++i) {
      camera::CameraSample c = cs;
      c.film_raster = {256 * uni(rng), 256 * uni(rng)};
      c.lens = {uni(rng), uni(rng)};
      c.ghost_u = {uni(rng), uni(rng), uni(rng)};
      const camera::RealisticCamera& k = with_flare ? bounded : plain;
      if (auto ray = k.generateRay(c)) sink += ray->weight;
      if (with_flare)
        if (auto g = k.generateGhostRay(c)) sink += g->weight;
    }
    const double s_per =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / m;
    if (sink < 0) std::printf("%g", sink);
    return s_per;
  };
  const double t_off = time(false), t_on = time(true);
  std::printf(
      "dgauss.50mm f/%.2f (12 mm stop), %s, film centre, flat field, %d directions x %zu pairs:\n"
      "  ghost irradiance %.4e; variance per sample: flare %.3e, Russian roulette %.3e: %.1fx "
      "fewer samples with flare\n"
      "  camera cost per sample: %.2f us without flare, %.2f us with (direct losses + one ghost "
      "path): %.1fx; at equal camera time %.1fx (the scene's path cost not counted)\n",
      cam.lens().paraxial.f_number, coating.c_str(), n, choices.size(), mean, var_flare, var_rr,
      var_rr / var_flare, 1e6 * t_off, 1e6 * t_on, t_on / t_off, var_rr / var_flare * t_off / t_on);
  return 0;
}
