// Cost of the "measured" material's BRDF (pbrt-v2 irregular isotropic .brdf files of the
// cs348b-hw3 scene): table lookup per evaluation (what a path vertex pays), sample_f, the
// scattered interpolant the table is built from (what a per-evaluation neighbour query would
// cost without the table), and building the table at load time. Diffuse f for scale.
// Run: cmake --build build --target lensim_bench_measured && build/bench/lensim_bench_measured
#include <benchmark/benchmark.h>

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "lensim/render/materials/bsdf.h"
#include "lensim/render/materials/measured.h"
#include "lensim/sampling/sampling.h"

using namespace lensim;
using namespace lensim::render;
using namespace lensim::sampling;

namespace {

const std::string kGarnet =
    std::string(LENSIM_SOURCE_DIR) + "/../shared/scenes/cs348b-hw3/brdfs/garnet_red.brdf";

constexpr int kPairs = 4096;

struct Pairs {
  std::vector<Vec3> wo, wi;
  std::vector<Vec2> u;
};

const Pairs& pairs() {
  static const Pairs p = [] {
    Pairs p;
    Rng rng(1, 0);
    for (int i = 0; i < kPairs; ++i) {
      p.wo.push_back(sampleUniformHemisphere({rng.uniform(), rng.uniform()}));
      p.wi.push_back(sampleCosineHemisphere({rng.uniform(), rng.uniform()}));
      p.u.push_back({rng.uniform(), rng.uniform()});
    }
    return p;
  }();
  return p;
}

std::shared_ptr<const MeasuredBRDF> garnet(benchmark::State& state) {
  if (!std::filesystem::exists(kGarnet)) {
    state.SkipWithError("shared cs348b-hw3 scene data not found");
    return nullptr;
  }
  return MeasuredBRDF::loadCached(kGarnet);
}

void BM_MeasuredF(benchmark::State& state) {
  const auto brdf = garnet(state);
  if (!brdf) return;
  const MeasuredBxDF b(brdf, SampledWavelengths::sampleUniform(0.37));
  const Pairs& p = pairs();
  int i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(b.f(p.wo[i], p.wi[i], TransportMode::Radiance));
    i = (i + 1) & (kPairs - 1);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_MeasuredF);

void BM_MeasuredSampleF(benchmark::State& state) {
  const auto brdf = garnet(state);
  if (!brdf) return;
  const MeasuredBxDF b(brdf, SampledWavelengths::sampleUniform(0.37));
  const Pairs& p = pairs();
  int i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(b.sample_f(p.wo[i], 0.5, p.u[i], TransportMode::Radiance));
    i = (i + 1) & (kPairs - 1);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_MeasuredSampleF);

void BM_MeasuredScatteredInterpolant(benchmark::State& state) {
  const auto brdf = garnet(state);
  if (!brdf) return;
  const Pairs& p = pairs();
  int i = 0;
  for (auto _ : state) {
    const Vec3 &wo = p.wo[i], &wi = p.wi[i];
    benchmark::DoNotOptimize(brdf->interpolate(std::acos(wi.z), std::acos(wo.z),
                                               std::atan2(wi.y, wi.x) - std::atan2(wo.y, wo.x)));
    i = (i + 1) & (kPairs - 1);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_MeasuredScatteredInterpolant);

void BM_MeasuredTableBuild(benchmark::State& state) {
  if (!std::filesystem::exists(kGarnet)) {
    state.SkipWithError("shared cs348b-hw3 scene data not found");
    return;
  }
  const IrregularBRDFData data = readIrregularBRDF(kGarnet);
  for (auto _ : state) benchmark::DoNotOptimize(MeasuredBRDF(data));
}
BENCHMARK(BM_MeasuredTableBuild)->Unit(benchmark::kMillisecond);

void BM_DiffuseF(benchmark::State& state) {
  const DiffuseBxDF b(SampledSpectrum(0.5));
  const Pairs& p = pairs();
  int i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(b.f(p.wo[i], p.wi[i], TransportMode::Radiance));
    i = (i + 1) & (kPairs - 1);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_DiffuseF);

}  // namespace

BENCHMARK_MAIN();
