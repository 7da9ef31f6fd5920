// The pixel samplers' cost per pixel sample (issue 29): a pixel sample draws the film position
// and then, per bounce of a five-bounce path, one 1-D and three 2-D values (the pattern of the
// path integrator: lens, light choice and position, BSDF). 64 spp over a 64 x 64 tile of a
// 200 x 200 film (32 spp for ZSobol's odd power of two, 8 x 8 strata for stratified), a pixel's
// samples in order as the render loop draws them. Counters: pixel samples per second, and
// values (1-D or 2-D draws, 21 per pixel sample) per second.
// Run: build/bench/lensim_bench_sampler.
#include <benchmark/benchmark.h>

#include <memory>

#include "lensim/sampling/sampler.h"

using namespace lensim;
using namespace lensim::sampling;

namespace {

void drawTile(benchmark::State& state, Sampler& s) {
  double sum = 0;
  int64_t n = 0;
  for (auto _ : state) {
    for (int y = 0; y < 64; ++y)
      for (int x = 0; x < 64; ++x)
        for (int i = 0; i < s.samplesPerPixel(); ++i) {
          s.startPixelSample({x, y}, i);
          Vec2 p = s.getPixel2D();
          sum += p.x + p.y;
          for (int b = 0; b < 5; ++b) {
            sum += s.get1D();
            for (int k = 0; k < 3; ++k) sum += s.get2D().x;
          }
          ++n;
        }
    benchmark::DoNotOptimize(sum);
  }
  state.counters["samples/s"] = benchmark::Counter(double(n), benchmark::Counter::kIsRate);
  state.counters["values/s"] = benchmark::Counter(21.0 * double(n), benchmark::Counter::kIsRate);
}

void BM_PaddedSobol(benchmark::State& state) {
  PaddedSobolSampler s(64, 0);
  drawTile(state, s);
}
void BM_ZSobol(benchmark::State& state) {
  ZSobolSampler s(64, {200, 200});
  drawTile(state, s);
}
void BM_ZSobol32(benchmark::State& state) {
  ZSobolSampler s(32, {200, 200});
  drawTile(state, s);
}
void BM_ZSobolOwen(benchmark::State& state) {
  ZSobolSampler s(64, {200, 200}, SobolRandomization::Owen);
  drawTile(state, s);
}
void BM_Stratified(benchmark::State& state) {
  StratifiedSampler s(8, 8);
  drawTile(state, s);
}
void BM_Independent(benchmark::State& state) {
  IndependentSampler s(64, 0);
  drawTile(state, s);
}

}  // namespace

BENCHMARK(BM_PaddedSobol)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ZSobol)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ZSobol32)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ZSobolOwen)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Stratified)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Independent)->Unit(benchmark::kMillisecond);
BENCHMARK_MAIN();
