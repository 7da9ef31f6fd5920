// Cost of pbrt-v4's hair BSDF (render/materials/hair.h) per call: f (what next-event estimation
// pays at a hair vertex), sample_f (what BSDF sampling pays: f and pdf at the sampled
// direction), and pdf; at pbrt-v4's default roughness (beta 0.3) and a smooth fibre (beta_m
// 0.05, where M_p takes the large-argument Bessel branch). Diffuse f for scale.
// Run: cmake --build build --target lensim_bench_hair && build/bench/lensim_bench_hair
#include <benchmark/benchmark.h>

#include <vector>

#include "lensim/render/materials/bsdf.h"
#include "lensim/render/materials/hair.h"
#include "lensim/sampling/sampling.h"

using namespace lensim;
using namespace lensim::render;
using namespace lensim::sampling;

namespace {

constexpr int kPairs = 4096;

struct Pairs {
  std::vector<Vec3> wo, wi;
  std::vector<double> uc;
  std::vector<Vec2> u;
};

const Pairs& pairs() {
  static const Pairs p = [] {
    Pairs p;
    Rng rng(1, 0);
    for (int i = 0; i < kPairs; ++i) {
      p.wo.push_back(sampleUniformSphere({rng.uniform(), rng.uniform()}));
      p.wi.push_back(sampleUniformSphere({rng.uniform(), rng.uniform()}));
      p.uc.push_back(rng.uniform());
      p.u.push_back({rng.uniform(), rng.uniform()});
    }
    return p;
  }();
  return p;
}

HairBxDF hair(double beta_m) {
  SampledSpectrum sigma;
  sigma[0] = 0.3, sigma[1] = 0.5, sigma[2] = 0.9, sigma[3] = 1.6;  // brown-ish
  return HairBxDF(0.3, 1.55, sigma, beta_m, 0.3, 2);
}

void BM_HairF(benchmark::State& state) {
  const HairBxDF b = hair(double(state.range(0)) / 100);
  const Pairs& p = pairs();
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(b.f(p.wo[i], p.wi[i], TransportMode::Radiance));
    i = (i + 1) % kPairs;
  }
}
BENCHMARK(BM_HairF)->Arg(30)->Arg(5);

void BM_HairSample(benchmark::State& state) {
  const HairBxDF b = hair(double(state.range(0)) / 100);
  const Pairs& p = pairs();
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(b.sample_f(p.wo[i], p.uc[i], p.u[i], TransportMode::Radiance));
    i = (i + 1) % kPairs;
  }
}
BENCHMARK(BM_HairSample)->Arg(30)->Arg(5);

void BM_HairPdf(benchmark::State& state) {
  const HairBxDF b = hair(double(state.range(0)) / 100);
  const Pairs& p = pairs();
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(b.pdf(p.wo[i], p.wi[i], TransportMode::Radiance));
    i = (i + 1) % kPairs;
  }
}
BENCHMARK(BM_HairPdf)->Arg(30);

void BM_HairConstruct(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(hair(0.3));
}
BENCHMARK(BM_HairConstruct);

void BM_DiffuseF(benchmark::State& state) {
  const DiffuseBxDF b(SampledSpectrum(0.5));
  const Pairs& p = pairs();
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(b.f(p.wo[i], p.wi[i], TransportMode::Radiance));
    i = (i + 1) % kPairs;
  }
}
BENCHMARK(BM_DiffuseF);

}  // namespace

BENCHMARK_MAIN();
