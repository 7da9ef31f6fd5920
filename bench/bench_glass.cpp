// Glass look-up and lens start-up (issue 28 "Glasses", docs/glass.md): looking names up in the
// built-in library (hits, GCAT-ordered hits, a sourced old name), parsing the 23 built-in AGF
// catalogues (what the first look-up of a process pays once), and reading and focusing a
// 30-surface lens whose 15 elements name AGF glasses.
#include <benchmark/benchmark.h>

#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "lensim/camera/realistic.h"
#include "lensim/optics/focus.h"
#include "lensim/optics/glass.h"
#include "lensim/optics/glass/embedded.h"
#include "lensim/sampling/filter.h"

using namespace lensim;
using namespace lensim::optics;

namespace {

const std::vector<std::string> kNames = {"N-BK7", "N-SF66", "S-LAH64",  "H-K9L", "J-LAFH3",
                                         "E48R",  "CAF2",   "rii:PMMA", "F2",    "N-LASF9"};

void BM_GlassLookup(benchmark::State& state) {
  const GlassCatalog& cat = GlassCatalog::builtin();
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(cat.find(kNames[i]));
    i = (i + 1) % kNames.size();
  }
}
BENCHMARK(BM_GlassLookup);

void BM_GlassLookupGcat(benchmark::State& state) {
  const GlassCatalog& cat = GlassCatalog::builtin();
  const std::vector<std::string> gcat{"ohara", "schott"};
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(cat.find(kNames[i], gcat));
    i = (i + 1) % kNames.size();
  }
}
BENCHMARK(BM_GlassLookupGcat);

void BM_OldNameLookup(benchmark::State& state) {
  GlassCatalog::builtin();
  for (auto _ : state) {
    bool successor = false;
    benchmark::DoNotOptimize(findGlassOrSuccessor("BK7", &successor));
  }
}
BENCHMARK(BM_OldNameLookup);

// The built-in library's one-time cost: every embedded AGF file parsed into a catalogue.
void BM_ParseBuiltinAgf(benchmark::State& state) {
  for (auto _ : state) {
    size_t glasses = 0;
    for (const embedded::EmbeddedAgf& f : embedded::agfFiles())
      glasses += GlassCatalog::fromAgf(std::string_view(reinterpret_cast<const char*>(f.begin),
                                                        size_t(f.end - f.begin)),
                                       f.stem, f.stem, f.vendor)
                     .glasses()
                     .size();
    benchmark::DoNotOptimize(glasses);
  }
}
BENCHMARK(BM_ParseBuiltinAgf)->Unit(benchmark::kMillisecond);

// A 30-surface lens (stop, 13 singlets of crowns and flints, a cemented doublet), every element
// a named AGF glass: read (glass look-ups included) and focused.
std::string writeLens30() {
  const char* glasses[] = {"N-BK7", "N-SF66", "S-LAH64", "N-SF6", "N-LAK9", "F2", "N-SK16"};
  const std::string path = "/tmp/lensim_bench_glass30.dat";
  std::FILE* f = std::fopen(path.c_str(), "w");
  std::fprintf(f, "0 2 0 12\n");
  for (int e = 0; e < 13; ++e)
    std::fprintf(f, "%d 3 1.6 20 - %s\n%d 1 0 20\n", 1500 + 10 * e, glasses[e % 7], -1500 - 10 * e);
  std::fprintf(f, "300 3 1.6 20 - N-BK7\n-200 2 1.7 20 - N-SF66\n-800 0 0 20\n");
  std::fclose(f);
  return path;
}

void BM_LensStartup30(benchmark::State& state) {
  const std::string path = writeLens30();
  GlassCatalog::builtin();
  LensSetup setup;
  setup.focus_distance_m = 5;
  for (auto _ : state) {
    FocusedLens fl = focusLens(readLensFile(path), setup);
    benchmark::DoNotOptimize(fl.paraxial.effective_focal_length_mm);
  }
}
BENCHMARK(BM_LensStartup30)->Unit(benchmark::kMicrosecond);

// The realistic camera's rays through US 5,331,467's telephoto (26 surfaces, 14 AGF-glass
// elements), every wavelength weighted by its film point (the path tracer's case), with the
// glasses' absorption (state.range(0) 1) and without (0): absorption's cost per camera ray.
void BM_CameraRayAbsorption(benchmark::State& state) {
  camera::RealisticSettings s;
  s.lens_path = std::string(LENSIM_SOURCE_DIR) + "/../shared/lenses/zmx/US05331467-1.zmx";
  s.setup.focus_distance_m = 100;
  s.film_diagonal_mm = 43.3;
  s.x_resolution = s.y_resolution = 256;
  s.glass_absorption = state.range(0) != 0;
  const camera::RealisticCamera cam(s);
  const sampling::BoxFilter box;
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<camera::CameraSample> samples(4096);
  for (camera::CameraSample& c : samples) {
    c.film_raster = {256 * u(rng), 256 * u(rng)};
    c.lens = {u(rng), u(rng)};
    const double l = 360 + 470 * u(rng);
    for (int j = 0; j < camera::kCameraWavelengths; ++j)
      c.lambda_nm[size_t(j)] =
          360 + std::fmod(l - 360 + 470.0 * j / camera::kCameraWavelengths, 470);
    c.pixel_centre = {std::floor(c.film_raster.x) + 0.5, std::floor(c.film_raster.y) + 0.5};
    c.filter = &box;
  }
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(cam.generateRay(samples[i]));
    i = (i + 1) % samples.size();
  }
}
BENCHMARK(BM_CameraRayAbsorption)->Arg(0)->Arg(1);

}  // namespace

BENCHMARK_MAIN();
