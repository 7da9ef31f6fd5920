// The pixel samplers' cost per pixel sample (issue 29): a pixel sample draws the film position
// and then, per bounce of a five-bounce path, one 1-D and three 2-D values (the pattern of the
// path integrator: lens, light choice and position, BSDF). 64 spp over a 64 x 64 tile of a
// 200 x 200 film (32 spp for ZSobol's odd power of two, 8 x 8 strata for stratified), a pixel's
// samples in order as the render loop draws them. Counters: pixel samples per second, and
// values (1-D or 2-D draws, 21 per pixel sample) per second.
// Also the pixel filters' importance sampling (pbrt-v4's defaults of the tabulated filters) and
// PiecewiseConstant1D::sample on a spiky 1000-cell function, each from 4096 uniform values drawn
// beforehand; the cosine-hemisphere and uniform-sphere warps and their sine and cosine.
// Counters: calls per second.
// Run: build/bench/lensim_bench_sampler.
#include <benchmark/benchmark.h>

#include <cmath>
#include <memory>
#include <vector>

#include "lensim/sampling/filter.h"
#include "lensim/sampling/sampler.h"
#include "lensim/sampling/sampling.h"

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

std::vector<double> uniforms(size_t n) {
  Rng rng(29, 1);
  std::vector<double> u(n);
  for (double& v : u) v = rng.uniform();
  return u;
}

void filterSamples(benchmark::State& state, const Filter& f) {
  const std::vector<double> u = uniforms(8192);
  double sum = 0;
  int64_t n = 0;
  for (auto _ : state) {
    for (size_t i = 0; i < u.size(); i += 2) {
      const FilterSample s = f.sample(Vec2(u[i], u[i + 1]));
      sum += s.weight + s.p.x;
    }
    n += static_cast<int64_t>(u.size() / 2);
    benchmark::DoNotOptimize(sum);
  }
  state.counters["calls/s"] = benchmark::Counter(double(n), benchmark::Counter::kIsRate);
}
void BM_FilterGaussian(benchmark::State& state) {
  filterSamples(state, GaussianFilter());
}
void BM_FilterMitchell(benchmark::State& state) {
  filterSamples(state, MitchellFilter());
}
void BM_FilterLanczos(benchmark::State& state) {
  filterSamples(state, LanczosSincFilter());
}

void BM_PiecewiseConstant1D(benchmark::State& state) {
  const std::vector<double> u = uniforms(4096);
  std::vector<double> f = uniforms(1000);
  for (size_t i = 0; i < f.size(); ++i)
    if (i % 7 == 0) f[i] = 0;
    else if (i % 97 == 0) f[i] *= 1000;
  const PiecewiseConstant1D d(f, -1.0, 2.0);
  double sum = 0;
  int64_t n = 0;
  for (auto _ : state) {
    for (double v : u) sum += d.sample(v).x;
    n += static_cast<int64_t>(u.size());
    benchmark::DoNotOptimize(sum);
  }
  state.counters["calls/s"] = benchmark::Counter(double(n), benchmark::Counter::kIsRate);
}

// The warps' angles: sampleCosineHemisphere (concentric disk) and sampleUniformSphere on 4096
// uniform pairs, and libm's sin and cos of 2 pi u for comparison (what the warps called before).
template <typename F>
void warp(benchmark::State& state, F f) {
  const std::vector<double> u = uniforms(8192);
  double sum = 0;
  int64_t n = 0;
  for (auto _ : state) {
    for (size_t i = 0; i + 1 < u.size(); i += 2) sum += f(Vec2{u[i], u[i + 1]});
    n += static_cast<int64_t>(u.size() / 2);
    benchmark::DoNotOptimize(sum);
  }
  state.counters["calls/s"] = benchmark::Counter(double(n), benchmark::Counter::kIsRate);
}
void BM_CosineHemisphere(benchmark::State& state) {
  warp(state, [](Vec2 u) { return sampleCosineHemisphere(u).x; });
}
void BM_UniformSphere(benchmark::State& state) {
  warp(state, [](Vec2 u) { return sampleUniformSphere(u).y; });
}
void BM_SinCos2Pi(benchmark::State& state) {
  warp(state, [](Vec2 u) {
    const SinCos sc = sinCos2Pi(u.y);
    return sc.sin + sc.cos;
  });
}
void BM_LibmSinCos2Pi(benchmark::State& state) {
  warp(state, [](Vec2 u) { return std::sin(2 * kPi * u.y) + std::cos(2 * kPi * u.y); });
}

}  // namespace

BENCHMARK(BM_PaddedSobol)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ZSobol)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ZSobol32)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ZSobolOwen)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Stratified)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Independent)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FilterGaussian);
BENCHMARK(BM_FilterMitchell);
BENCHMARK(BM_FilterLanczos);
BENCHMARK(BM_PiecewiseConstant1D);
BENCHMARK(BM_CosineHemisphere);
BENCHMARK(BM_UniformSphere);
BENCHMARK(BM_SinCos2Pi);
BENCHMARK(BM_LibmSinCos2Pi);
BENCHMARK_MAIN();
