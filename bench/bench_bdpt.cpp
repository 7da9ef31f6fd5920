// Error at equal time, bdpt against path (issue 13), on two scenes where bidirectional light
// transport should pay: a caustic (a glass sphere on a diffuse floor lit by a small light) and
// bokeh (two small bright lights far behind the focus of the double Gauss at f/2.9); and, against
// volpath, fog (a sphere of scattering fog holding a small light above a glass ball on a diffuse
// floor: volumetric and floor caustics).
//
// For each scene: a long bdpt render is the reference (both integrators are unbiased: the
// consistency tests in render_bdpt_test check that they agree within noise); then each integrator
// renders K seeds in the same CPU time (process CPU seconds, which the other jobs on a shared
// machine do not inflate as they do wall time): the samples per pixel are set from a pilot
// render's CPU time per sample. The error of a render is its RMSE against the reference over the
// pixels' R, G, B, and its relative MSE (MSE / mean^2); the mean over the seeds is printed, and
// the ratios bdpt / path. Usage (bench/bdpt runs it):
//   lensim_bench_bdpt [--scene caustic|bokeh|fog|all] [--seconds T] [--reference-seconds R]
//                     [--seeds K] [--threads N]
#include <fmt/format.h>
#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "lensim/render/renderer.h"
#include "lensim/scene/description.h"
#include "lensim/scene/parser.h"
#include "lensim/util/error.h"

using namespace lensim;

namespace {

double cpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

std::string causticScene(const std::string& integrator) {
  return fmt::format(R"(LookAt 0 2.2 -3.2  0 0.3 0  0 1 0
Camera "perspective" "float fov" 35
Film "rgb" "integer xresolution" 64 "integer yresolution" 48 "string filename" "caustic.exr"
Sampler "independent"
PixelFilter "box" "float xradius" 0.5 "float yradius" 0.5
Integrator "{}" "integer maxdepth" 8
WorldBegin
AttributeBegin
  Translate -1.2 2.5 0.8
  AreaLightSource "diffuse" "rgb L" [400 400 400]
  Shape "sphere" "float radius" 0.05
AttributeEnd
Material "diffuse" "rgb reflectance" [0.6 0.6 0.6]
Shape "trianglemesh" "point3 P" [-4 0 -4  4 0 -4  4 0 4  -4 0 4] "integer indices" [0 2 1 0 3 2]
Material "dielectric" "float eta" 1.5
AttributeBegin
  Translate 0 0.5 0
  Shape "sphere" "float radius" 0.5
AttributeEnd
)",
                     integrator);
}

std::string bokehScene(const std::string& integrator) {
  return fmt::format(R"(LookAt 0 0.3 -1  0 0.3 0  0 1 0
Camera "realistic" "string lensfile" "{}/lenses/dgauss.50mm.dat" "float aperturediameter" 17
  "float focusdistance" 0.5
Film "rgb" "integer xresolution" 64 "integer yresolution" 48 "float diagonal" 10
  "string filename" "bokeh.exr"
Sampler "independent"
PixelFilter "box" "float xradius" 0.5 "float yradius" 0.5
Integrator "{}" "integer maxdepth" 5
WorldBegin
LightSource "infinite" "rgb L" [0.02 0.02 0.02]
AttributeBegin
  Translate 0.07 0.36 5
  AreaLightSource "diffuse" "rgb L" [3000 3000 3000]
  Shape "sphere" "float radius" 0.01
AttributeEnd
AttributeBegin
  Translate -0.1 0.27 6
  AreaLightSource "diffuse" "rgb L" [2000 1200 600]
  Shape "sphere" "float radius" 0.01
AttributeEnd
Material "diffuse" "rgb reflectance" [0.5 0.5 0.5]
Shape "trianglemesh" "point3 P" [-3 0 -2  3 0 -2  3 0 8  -3 0 8] "integer indices" [0 2 1 0 3 2]
Material "diffuse" "rgb reflectance" [0.6 0.3 0.2]
AttributeBegin
  Translate 0.02 0.28 -0.5
  Shape "sphere" "float radius" 0.03
AttributeEnd
)",
                     LENSIM_SOURCE_DIR, integrator);
}

std::string fogScene(const std::string& integrator) {
  return fmt::format(R"(LookAt 0 1.2 -3.4  0 0.8 0  0 1 0
Camera "perspective" "float fov" 40
Film "rgb" "integer xresolution" 64 "integer yresolution" 48 "string filename" "fog.exr"
Sampler "independent"
PixelFilter "box" "float xradius" 0.5 "float yradius" 0.5
Integrator "{}" "integer maxdepth" 8
MakeNamedMedium "fog" "string type" "homogeneous" "rgb sigma_a" [0.05 0.05 0.05]
  "rgb sigma_s" [0.4 0.4 0.4] "float g" 0.2
WorldBegin
AttributeBegin
  MediumInterface "fog" ""
  Material "interface"
  Translate 0 1 0
  Shape "sphere" "float radius" 2.5
AttributeEnd
MediumInterface "fog" "fog"
AttributeBegin
  Translate -0.6 2.2 0.4
  AreaLightSource "diffuse" "rgb L" [300 300 300]
  Shape "sphere" "float radius" 0.05
AttributeEnd
Material "diffuse" "rgb reflectance" [0.6 0.6 0.6]
Shape "trianglemesh" "point3 P" [-1.5 0 -1.5  1.5 0 -1.5  1.5 0 1.5  -1.5 0 1.5]
  "integer indices" [0 2 1 0 3 2]
MediumInterface "" "fog"
Material "dielectric" "float eta" 1.5
AttributeBegin
  Translate 0 0.6 0
  Shape "sphere" "float radius" 0.45
AttributeEnd
)",
                     integrator);
}

scene::Scene build(const std::string& text) {
  scene::Scene s = scene::build(scene::parseString(text, "bench-bdpt.pbrt"));
  if (s.hasErrors()) throw Error(formatDiagnostics(s.diagnostics));
  return s;
}

struct Render {
  io::Image image;
  double cpu_s = 0;
};

Render renderOnce(const scene::Scene& s, int spp, int seed, int threads) {
  render::RenderOptions o;
  o.spp = spp;
  o.seed = seed;
  o.threads = threads;
  const double t0 = cpuSeconds();
  Render r;
  r.image = render::render(s, o).image;
  r.cpu_s = cpuSeconds() - t0;
  return r;
}

struct Error2 {
  double rmse = 0, rel_mse = 0;
};

Error2 errorOf(const io::Image& im, const io::Image& ref) {
  double se = 0, sum = 0;
  size_t n = 0;
  for (int y = 0; y < ref.height; ++y)
    for (int x = 0; x < ref.width; ++x)
      for (int c = 0; c < 3; ++c) {
        const double d = double(im.at(x, y, c)) - double(ref.at(x, y, c));
        se += d * d;
        sum += ref.at(x, y, c);
        ++n;
      }
  const double mse = se / double(n), mean = sum / double(n);
  return {std::sqrt(mse), mse / (mean * mean)};
}

/// bdpt against `rival` (path, or volpath for media).
void runScene(const std::string& name, std::string (*text)(const std::string&), double seconds,
              double ref_seconds, int seeds, int threads, const char* rival = "path") {
  const scene::Scene bdpt = build(text("bdpt")), path = build(text(rival));
  // CPU seconds per sample per pixel, from pilots.
  auto perSpp = [&](const scene::Scene& s) {
    const int spp = 4;
    const Render r = renderOnce(s, spp, 999, threads);
    return r.cpu_s / spp;
  };
  const double t_bdpt = perSpp(bdpt), t_path = perSpp(path);
  const int ref_spp = std::max(16, int(ref_seconds / t_bdpt));
  const Render ref = renderOnce(bdpt, ref_spp, 12345, threads);
  const int spp_bdpt = std::max(1, int(std::lround(seconds / t_bdpt)));
  const int spp_path = std::max(1, int(std::lround(seconds / t_path)));
  fmt::print(
      "{}: reference bdpt {} spp ({:.0f} CPU s); equal time {:.1f} CPU s: {} {} spp, "
      "bdpt {} spp; {} seeds\n",
      name, ref_spp, ref.cpu_s, seconds, rival, spp_path, spp_bdpt, seeds);
  double rmse[2] = {0, 0}, rel[2] = {0, 0}, cpu[2] = {0, 0};
  for (int k = 0; k < seeds; ++k)
    for (int i = 0; i < 2; ++i) {
      const Render r =
          renderOnce(i == 0 ? path : bdpt, i == 0 ? spp_path : spp_bdpt, 100 + k, threads);
      const Error2 e = errorOf(r.image, ref.image);
      rmse[i] += e.rmse / seeds;
      rel[i] += e.rel_mse / seeds;
      cpu[i] += r.cpu_s / seeds;
    }
  fmt::print("  {}: RMSE {:.4g}, relative MSE {:.4g} ({:.1f} CPU s)\n", rival, rmse[0], rel[0],
             cpu[0]);
  fmt::print("  bdpt: RMSE {:.4g}, relative MSE {:.4g} ({:.1f} CPU s)\n", rmse[1], rel[1], cpu[1]);
  // MSE falls as 1 / time: the ratio of MSE x time is the ratio at exactly equal time.
  fmt::print("  bdpt / {} at equal time: RMSE {:.3f}, MSE {:.3f} (MSE x CPU time {:.3f})\n", rival,
             rmse[1] / rmse[0], rel[1] / rel[0], rel[1] * cpu[1] / (rel[0] * cpu[0]));
}

}  // namespace

int main(int argc, char** argv) {
  std::string which = "all";
  double seconds = 6, ref_seconds = 120;
  int seeds = 3, threads = 0;
  for (int i = 1; i < argc; ++i) {
    auto next = [&]() -> const char* {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "lensim_bench_bdpt: %s needs a value\n", argv[i]);
        std::exit(2);
      }
      return argv[++i];
    };
    if (!std::strcmp(argv[i], "--scene"))
      which = next();
    else if (!std::strcmp(argv[i], "--seconds"))
      seconds = std::atof(next());
    else if (!std::strcmp(argv[i], "--reference-seconds"))
      ref_seconds = std::atof(next());
    else if (!std::strcmp(argv[i], "--seeds"))
      seeds = std::atoi(next());
    else if (!std::strcmp(argv[i], "--threads"))
      threads = std::atoi(next());
    else {
      std::fprintf(stderr, "lensim_bench_bdpt: unknown argument %s\n", argv[i]);
      return 2;
    }
  }
  try {
    if (which == "caustic" || which == "all")
      runScene("caustic (glass sphere, small light)", causticScene, seconds, ref_seconds, seeds,
               threads);
    if (which == "bokeh" || which == "all")
      runScene("bokeh (small lights behind the focus of the double Gauss)", bokehScene, seconds,
               ref_seconds, seeds, threads);
    if (which == "fog" || which == "all")
      runScene("fog (a small light above a glass ball in a sphere of fog)", fogScene, seconds,
               ref_seconds, seeds, threads, "volpath");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lensim_bench_bdpt: %s\n", e.what());
    return 1;
  }
  return 0;
}
