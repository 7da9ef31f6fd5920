// Glass look-up and lens start-up (issue 28 "Glasses", docs/glass.md): looking names up in the
// built-in library (hits, GCAT-ordered hits, a sourced old name), parsing the 23 built-in AGF
// catalogues (what the first look-up of a process pays once), and reading and focusing a
// 30-surface lens whose 15 elements name AGF glasses.
#include <benchmark/benchmark.h>

#include <cstdio>
#include <string>
#include <vector>

#include "lensim/optics/focus.h"
#include "lensim/optics/glass.h"
#include "lensim/optics/glass/embedded.h"

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

}  // namespace

BENCHMARK_MAIN();
