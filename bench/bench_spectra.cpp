// Per-hit spectrum evaluation, wavelength sampling, the film's XYZ conversion and pixel-filter
// sampling (issue 29): the values a path tracer computes at every intersection or camera sample.
// Each benchmark iterates over 1024 wavelength draws (stratified u) and evaluates the spectrum at
// the four wavelengths of each. Also conductor Fresnel at four wavelengths. Counter: calls per
// second. Run: build/bench/lensim_bench_spectra.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <complex>
#include <vector>

#include "lensim/render/materials/bsdf.h"
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

// Conductor Fresnel at four wavelengths (gold's eta and k) over 1024 cosines: frComplex, and the
// complex-arithmetic form it replaced (pbrt-v4's FrComplex with std::complex) for comparison.
template <typename F>
void fresnel(benchmark::State& state, F f) {
  SampledSpectrum eta, k;
  const double es[4] = {1.38, 0.62, 0.21, 0.13}, ks[4] = {1.91, 2.08, 3.27, 4.10};
  for (int i = 0; i < kSpectrumSamples; ++i) eta[i] = es[i], k[i] = ks[i];
  double sum = 0;
  int64_t n = 0;
  for (auto _ : state) {
    for (int i = 0; i < 1024; ++i) {
      const SampledSpectrum r = f((i + 0.5) / 1024, eta, k);
      sum += r[0] + r[3];
    }
    n += 1024;
    benchmark::DoNotOptimize(sum);
  }
  state.counters["calls/s"] = benchmark::Counter(double(n), benchmark::Counter::kIsRate);
}
void BM_FrComplex(benchmark::State& state) {
  fresnel(state, frComplex);
}
void BM_FrComplexStdComplex(benchmark::State& state) {
  fresnel(state, [](double cos_i, const SampledSpectrum& eta, const SampledSpectrum& k) {
    using C = std::complex<double>;
    const double c = std::clamp(cos_i, 0.0, 1.0);
    SampledSpectrum r;
    for (int i = 0; i < kSpectrumSamples; ++i) {
      const C n(eta[i], k[i]);
      const C sin2_t = (1 - c * c) / (n * n);
      const C cos_t = std::sqrt(1.0 - sin2_t);
      const C r_parl = (n * c - cos_t) / (n * c + cos_t);
      const C r_perp = (c - n * cos_t) / (c + n * cos_t);
      r[i] = (std::norm(r_parl) + std::norm(r_perp)) / 2;
    }
    return r;
  });
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
BENCHMARK(BM_FrComplex);
BENCHMARK(BM_FrComplexStdComplex);

BENCHMARK_MAIN();
