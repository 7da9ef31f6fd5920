// Per-hit spectrum evaluation, wavelength sampling, the film's XYZ conversion and pixel-filter
// sampling (issue 29): the values a path tracer computes at every intersection or camera sample.
// Each benchmark iterates over 1024 wavelength draws (stratified u) and evaluates the spectrum at
// the four wavelengths of each. Counter: calls per second. Run: build/bench/lensim_bench_spectra.
#include <benchmark/benchmark.h>

#include <vector>

#include "lensim/render/spectra/spectrum.h"
#include "lensim/sampling/filter.h"

using namespace lensim;
using namespace lensim::render;
using namespace lensim::sampling;

namespace {

std::vector<SampledWavelengths> wavelengths() {
  std::vector<SampledWavelengths> w;
  for (int i = 0; i < 1024; ++i) w.push_back(SampledWavelengths::sampleVisible((i + 0.37) / 1024));
  return w;
}

void evalSpectrum(benchmark::State& state, const Spectrum& s) {
  const auto w = wavelengths();
  double sum = 0;
  int64_t n = 0;
  for (auto _ : state) {
    for (const auto& l : w) sum += s.sample(l)[0] + s.sample(l)[3];
    n += 2 * static_cast<int64_t>(w.size());
    benchmark::DoNotOptimize(sum);
  }
  state.counters["calls/s"] = benchmark::Counter(double(n), benchmark::Counter::kIsRate);
}

void BM_RGBIlluminantSpectrum(benchmark::State& state) {
  const RGBIlluminantSpectrum s(RGBColorSpace::sRGB(), Vec3(7, 6.6, 6));
  evalSpectrum(state, s);
}
void BM_RGBAlbedoSpectrum(benchmark::State& state) {
  const RGBAlbedoSpectrum s(RGBColorSpace::sRGB(), Vec3(0.7, 0.08, 0.06));
  evalSpectrum(state, s);
}
void BM_NamedMetalAuEta(benchmark::State& state) {
  evalSpectrum(state, *namedSpectrum("metal-Au-eta"));
}
void BM_D65(benchmark::State& state) {
  evalSpectrum(state, *namedSpectrum("stdillum-D65"));
}
void BM_Blackbody3200(benchmark::State& state) {
  const BlackbodySpectrum s(3200);
  evalSpectrum(state, s);
}

void BM_SampleVisibleWavelengths(benchmark::State& state) {
  double sum = 0;
  int64_t n = 0;
  for (auto _ : state) {
    for (int i = 0; i < 1024; ++i) {
      const auto w = SampledWavelengths::sampleVisible((i + 0.37) / 1024);
      sum += w.lambda(1) + w.pdf(2);
    }
    n += 1024;
    benchmark::DoNotOptimize(sum);
  }
  state.counters["calls/s"] = benchmark::Counter(double(n), benchmark::Counter::kIsRate);
}

// The film's per-sample conversion of the path's radiance to XYZ (CIE curves at the four
// wavelengths, divided by their pdfs).
void BM_SampledToXyz(benchmark::State& state) {
  const auto w = wavelengths();
  const SampledSpectrum L(0.8);
  Vec3 sum;
  int64_t n = 0;
  for (auto _ : state) {
    for (const auto& l : w) sum += sampledToXyz(L, l);
    n += static_cast<int64_t>(w.size());
    benchmark::DoNotOptimize(sum);
  }
  state.counters["calls/s"] = benchmark::Counter(double(n), benchmark::Counter::kIsRate);
}

void BM_GaussianFilterSample(benchmark::State& state) {
  const GaussianFilter f;
  double sum = 0;
  int64_t n = 0;
  for (auto _ : state) {
    for (int i = 0; i < 32; ++i)
      for (int j = 0; j < 32; ++j) {
        const auto s = f.sample(Vec2((i + 0.37) / 32, (j + 0.61) / 32));
        sum += s.weight + s.p.x;
      }
    n += 1024;
    benchmark::DoNotOptimize(sum);
  }
  state.counters["calls/s"] = benchmark::Counter(double(n), benchmark::Counter::kIsRate);
}

}  // namespace

BENCHMARK(BM_RGBIlluminantSpectrum);
BENCHMARK(BM_RGBAlbedoSpectrum);
BENCHMARK(BM_NamedMetalAuEta);
BENCHMARK(BM_D65);
BENCHMARK(BM_Blackbody3200);
BENCHMARK(BM_SampleVisibleWavelengths);
BENCHMARK(BM_SampledToXyz);
BENCHMARK(BM_GaussianFilterSample);

BENCHMARK_MAIN();
