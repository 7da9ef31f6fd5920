// Colour noise of the hero-wavelength scheme through a dispersive lens, at equal time (issue 10).
//
// Renders a scene K times with different seeds through a dispersive lens and its non-dispersive
// twin: a lens file that names glasses against the same rows with constant indices, or a legacy
// lens glass-matched (the camera's glassmatch) against the file as it is. The dispersive lens
// twice: every wavelength weighted by its own film point (lensim's spectral MIS) and the hero
// wavelength only (pbrt-v4's way). Per pixel, the variance over the
// seeds of the luminance Y and of the two colour differences R - G and B - G; the mean variance
// relative to the squared mean luminance is the noise; variance x render time is the cost of a
// given noise (equal-time efficiency: lower is better). Usage (bench/dispersion runs it):
//   lensim_bench_dispersion SCENE [--lens FILE] [--spp N] [--seeds K] [--threads T]
//                           [--pixelbounds x0 x1 y0 y1]
#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "lensim/optics/glass.h"
#include "lensim/optics/lens_system.h"
#include "lensim/render/renderer.h"
#include "lensim/scene/description.h"
#include "lensim/util/log.h"

using namespace lensim;

namespace {

struct Measure {
  double seconds = 0;  // mean wall time of one render
  double mean_y = 0;
  double var_y = 0, var_chroma = 0;  // relative to mean_y^2
};

Measure measure(const scene::Scene& scene, int spp, int seeds, int threads,
                const std::optional<std::array<int, 4>>& bounds, bool hero_only) {
  std::vector<std::vector<double>> y, rg, bg;
  Measure m;
  for (int s = 0; s < seeds; ++s) {
    render::RenderOptions o;
    o.spp = spp;
    o.seed = 1000 + s;
    o.threads = threads;
    o.pixelbounds = bounds;
    o.dispersion_hero_only = hero_only;
    const auto t0 = std::chrono::steady_clock::now();
    const render::RenderResult r = render::render(scene, o);
    m.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const io::Image& im = r.image;
    const size_t n = size_t(im.width) * im.height;
    if (y.empty()) y.assign(n, {}), rg.assign(n, {}), bg.assign(n, {});
    for (int j = 0; j < im.height; ++j)
      for (int i = 0; i < im.width; ++i) {
        const size_t k = size_t(j) * im.width + i;
        const double R = im.at(i, j, 0), G = im.at(i, j, 1), B = im.at(i, j, 2);
        y[k].push_back(0.2126 * R + 0.7152 * G + 0.0722 * B);
        rg[k].push_back(R - G);
        bg[k].push_back(B - G);
      }
  }
  m.seconds /= seeds;
  auto variance = [](const std::vector<double>& v) {
    double mean = 0, s2 = 0;
    for (double x : v) mean += x;
    mean /= double(v.size());
    for (double x : v) s2 += (x - mean) * (x - mean);
    return s2 / double(v.size() - 1);
  };
  double sum_y = 0, vy = 0, vc = 0;
  for (size_t k = 0; k < y.size(); ++k) {
    for (double x : y[k]) sum_y += x;
    vy += variance(y[k]);
    vc += variance(rg[k]) + variance(bg[k]);
  }
  m.mean_y = sum_y / double(y.size() * seeds);
  m.var_y = vy / double(y.size()) / (m.mean_y * m.mean_y);
  m.var_chroma = vc / double(y.size()) / (m.mean_y * m.mean_y);
  return m;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr,
                 "usage: %s SCENE [--spp N] [--seeds K] [--threads T] "
                 "[--pixelbounds x0 x1 y0 y1]\n",
                 argv[0]);
    return 2;
  }
  int spp = 16, seeds = 8, threads = 0;
  std::optional<std::array<int, 4>> bounds;
  std::string lens;
  for (int i = 2; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--spp") && i + 1 < argc)
      spp = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--seeds") && i + 1 < argc)
      seeds = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--threads") && i + 1 < argc)
      threads = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--lens") && i + 1 < argc)
      lens = argv[++i];
    else if (!std::strcmp(argv[i], "--pixelbounds") && i + 4 < argc) {
      bounds = std::array<int, 4>{std::atoi(argv[i + 1]), std::atoi(argv[i + 2]),
                                  std::atoi(argv[i + 3]), std::atoi(argv[i + 4])};
      i += 4;
    }
  }
  try {
    setQuiet(true);
    scene::Scene scene = scene::loadScene(argv[1]);
    if (!scene.camera.realistic) {
      std::fprintf(stderr, "%s: the scene needs a pbrt-v3/v4 realistic camera\n", argv[1]);
      return 1;
    }
    if (!lens.empty()) scene.camera.realistic->lens_file = lens;
    // The non-dispersive twin: the lens as written if it names no glass (its dispersive version is
    // then the glass-matched one), else the same rows without their glass columns.
    const std::string file = scene.camera.realistic->lens_file;
    const bool file_disperses = optics::LensSystem(optics::readLensFile(file)).dispersive();
    std::string plain = file;
    if (file_disperses) {
      optics::LensPrescription p = optics::readLensFile(file);
      plain = "/tmp/lensim_bench_dispersion_plain.dat";
      std::FILE* out = std::fopen(plain.c_str(), "w");
      for (const optics::LensSurface& r : p.surfaces)
        std::fprintf(out, "%.17g %.17g %.17g %.17g\n", r.radius_mm, r.thickness_mm,
                     r.ior == 1 ? 0.0 : optics::resolveGlass(r.glass, r.ior).n_d(),
                     r.aperture_diameter_mm);
      std::fclose(out);
    }
    std::printf("%s through %s, %d spp, %d seeds\n", argv[1], file.c_str(), spp, seeds);
    std::printf("%-44s %9s %10s %10s %11s %11s %11s\n", "lens", "s/render", "mean Y", "var Y",
                "var colour", "var Y x s", "colour x s");
    Measure base;
    for (int variant = 0; variant < 3; ++variant) {
      scene.camera.realistic->lens_file = variant == 0 ? plain : file;
      scene.camera.realistic->glass_match = variant > 0 && !file_disperses;
      const Measure m = measure(scene, spp, seeds, threads, bounds, variant == 2);
      if (variant == 0) base = m;
      const char* names[3] = {"non-dispersive (constant indices)",
                              "dispersive: every wavelength, MIS (lensim)",
                              "dispersive: hero wavelength only (pbrt-v4)"};
      std::printf("%-44s %9.3f %10.4g %10.4g %11.4g %11.4g %11.4g\n", names[variant], m.seconds,
                  m.mean_y, m.var_y, m.var_chroma, m.var_y * m.seconds, m.var_chroma * m.seconds);
      if (variant > 0)
        std::printf(
            "  at equal time: %.2fx the colour variance, %.2fx the luminance variance of "
            "the non-dispersive lens\n",
            m.var_chroma * m.seconds / (base.var_chroma * base.seconds),
            m.var_y * m.seconds / (base.var_y * base.seconds));
    }
  } catch (const Error& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
  return 0;
}
