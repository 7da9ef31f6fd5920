// The optical workbench's analyses (issue 17) on the 50 mm double Gauss at infinity focus,
// wide open (f/2, strongly aberrated: the pupil grids refine to 256-512 cells off axis) and at
// --aperture-diameter 8 (f/4.3): spots (48 hexapolar rings), MTF (diffraction and geometric, to
// the cutoff), through-focus MTF (31 film positions), PSF images, each for the fields 0, 0.7, 1.
#include <benchmark/benchmark.h>

#include <optional>
#include <string>

#include "lensim/optics/mtf.h"
#include "lensim/optics/plots.h"
#include "lensim/optics/psf.h"

using namespace lensim::optics;

namespace {

const FocusedLens& lens(bool stopped) {
  static FocusedLens open, closed;
  static bool ready = false;
  if (!ready) {
    const std::string path = std::string(LENSIM_SOURCE_DIR) + "/lenses/dgauss.50mm.dat";
    open = focusLens(readLensFile(path), {});
    LensSetup s;
    s.aperture_diameter_mm = 8;
    closed = focusLens(readLensFile(path), s);
    ready = true;
  }
  return stopped ? closed : open;
}

const std::vector<double> kFields{0, 0.7, 1};

void Spots(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(computeSpots(lens(state.range(0)), kFields, 35));
}
void Mtf(benchmark::State& state) {
  MtfOptions o;
  o.fields = kFields;
  for (auto _ : state)
    benchmark::DoNotOptimize(computeMtf(monochromatic(lens(state.range(0))), 35, o));
}
void ThroughFocus(benchmark::State& state) {
  for (auto _ : state)
    benchmark::DoNotOptimize(
        computeThroughFocusMtf(monochromatic(lens(state.range(0))), 35, kFields, 50));
}
void Psf(benchmark::State& state) {
  for (auto _ : state)
    benchmark::DoNotOptimize(computePsf(monochromatic(lens(state.range(0))), 35, kFields));
}

}  // namespace

// Argument: 0 wide open, 1 at 8 mm.
BENCHMARK(Spots)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(Mtf)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(ThroughFocus)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(Psf)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK_MAIN();
