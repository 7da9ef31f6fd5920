// Exact lens traces per second (film -> scene) for the four classic lenses: random film points
// on a 35 mm-diagonal film disc and random points on the rear element, lens focused at infinity.
// Prints the share of traces that are vignetted (blocked by an aperture, missed or TIR), the
// waste a renderer's camera would see without pupil sampling. This is the baseline for later
// performance work; run it with bench/run.
#include <benchmark/benchmark.h>

#include <cmath>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "lensim/optics/focus.h"
#include "lensim/optics/pupil.h"

using namespace lensim;
using namespace lensim::optics;

namespace {

constexpr double kFilmDiagonal_mm = 35.0;
constexpr int kRays = 1 << 14;

struct Workload {
  std::unique_ptr<LensSystem> lens;
  std::vector<Ray> rays;
};

Workload makeWorkload(const std::string& file) {
  Workload w;
  w.lens = focusLens(readLensFile(file.find(':') != std::string::npos
                                      ? file
                                      : std::string(LENSIM_SOURCE_DIR) + "/lenses/" + file),
                     {})
               .lens;
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(0, 1);
  auto disk = [&](double r) {
    const double rr = r * std::sqrt(u(rng)), phi = 2 * std::numbers::pi * u(rng);
    return Vec2{rr * std::cos(phi), rr * std::sin(phi)};
  };
  const double rear = w.lens->interfaces().back().semi_aperture_mm;
  for (int i = 0; i < kRays; ++i) {
    const Vec2 f = disk(kFilmDiagonal_mm / 2), a = disk(rear);
    const Vec3 from{f.x, f.y, w.lens->filmZ_mm()};
    const Vec3 to{a.x, a.y, w.lens->rearVertexZ_mm()};
    w.rays.push_back({from, normalize(to - from)});
  }
  return w;
}

template <typename T>
void BM_TraceFromFilm(benchmark::State& state, const std::string& file) {
  Workload w = makeWorkload(file);
  std::vector<RayT<T>> rays;
  for (const Ray& r : w.rays) rays.push_back({Vec3T<T>(r.origin), Vec3T<T>(r.direction)});
  const LensTracer<T>* tracer;
  if constexpr (std::is_same_v<T, float>)
    tracer = &w.lens->tracerFloat();
  else
    tracer = &w.lens->tracer();
  size_t i = 0, blocked = 0, traced = 0;
  for (auto _ : state) {
    TraceResultT<T> r = tracer->traceFromFilm(rays[i]);
    benchmark::DoNotOptimize(r);
    blocked += !r.ok();
    ++traced;
    if (++i == rays.size()) i = 0;
  }
  state.SetItemsProcessed(static_cast<int64_t>(traced));
  state.counters["traces/s"] =
      benchmark::Counter(static_cast<double>(traced), benchmark::Counter::kIsRate);
  state.counters["vignetted"] = traced ? static_cast<double>(blocked) / traced : 0.0;
}

// The same rays traced in batches of LensTracer::kBatch (traceFromFilmBatch).
void BM_TraceFromFilmBatch(benchmark::State& state, const std::string& file) {
  Workload w = makeWorkload(file);
  std::vector<RayT<float>> rays;
  for (const Ray& r : w.rays) rays.push_back({Vec3f(r.origin), Vec3f(r.direction)});
  const LensTracer<float>& tracer = w.lens->tracerFloat();
  constexpr int kB = LensTracer<float>::kBatch;
  TraceResultT<float> out[kB];
  size_t i = 0, traced = 0;
  for (auto _ : state) {
    tracer.traceFromFilmBatch(&rays[i], kB, out);
    benchmark::DoNotOptimize(out);
    traced += kB;
    i += kB;
    if (i + kB > rays.size()) i = 0;
  }
  state.SetItemsProcessed(static_cast<int64_t>(traced));
  state.counters["traces/s"] =
      benchmark::Counter(static_cast<double>(traced), benchmark::Counter::kIsRate);
}

// The exit-pupil build's trace: ray margins (LensTracer<double>::marginSquaredBatch) in batches
// of LensTracer::kBatch, for lenses whose non-spherical surfaces the batch intersects side by
// side (quadrics, toroids) and the double Gauss.
void BM_MarginSquaredBatch(benchmark::State& state, const std::string& file) {
  Workload w = makeWorkload(file);
  const LensTracer<double>& tracer = w.lens->tracer();
  constexpr int kB = LensTracer<double>::kBatch;
  double m2[kB];
  size_t i = 0, traced = 0;
  for (auto _ : state) {
    tracer.marginSquaredBatch(&w.rays[i], kB, m2);
    benchmark::DoNotOptimize(m2);
    traced += kB;
    i += kB;
    if (i + kB > w.rays.size()) i = 0;
  }
  state.SetItemsProcessed(static_cast<int64_t>(traced));
  state.counters["traces/s"] =
      benchmark::Counter(static_cast<double>(traced), benchmark::Counter::kIsRate);
}

// Building the exit-pupil bounds a realistic camera samples (start-up cost), and the share of
// camera samples, over a 3:2 film of 35 mm diagonal, that the bounds waste (no ray gets through).
void BM_ExitPupilBuild(benchmark::State& state, const std::string& file) {
  FocusedLens fl = focusLens(readLensFile(std::string(LENSIM_SOURCE_DIR) + "/lenses/" + file), {});
  long traces = 0;
  for (auto _ : state) {
    ExitPupilSampler sampler(*fl.lens, fl.paraxial, kFilmDiagonal_mm / 2);
    traces = sampler.tracesAtBuild();
    benchmark::DoNotOptimize(sampler);
  }
  ExitPupilSampler sampler(*fl.lens, fl.paraxial, kFilmDiagonal_mm / 2);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0, 1);
  const double w = kFilmDiagonal_mm * 3 / std::sqrt(13.0),
               h = kFilmDiagonal_mm * 2 / std::sqrt(13.0);
  long samples = 0, wasted = 0;
  for (int k = 0; k < 200000; ++k) {
    const Vec2 film{(u(rng) - 0.5) * w, (u(rng) - 0.5) * h};
    auto s = sampler.sample(film, {u(rng), u(rng)});
    if (!s) continue;
    ++samples;
    const Vec3 from{film.x, film.y, fl.lens->filmZ_mm()};
    wasted += !fl.lens->tracer().traceFromFilm(Ray{from, normalize(s->rear_point_mm - from)}).ok();
  }
  state.counters["traces"] = static_cast<double>(traces);
  state.counters["intervals"] = sampler.intervals();
  state.counters["wasted"] = samples ? static_cast<double>(wasted) / samples : 0.0;
}

void registerAll() {
  for (const char* file :
       {"dgauss.50mm.dat", "fisheye.10mm.dat", "wide.22mm.dat", "telephoto.250mm.dat"}) {
    benchmark::RegisterBenchmark((std::string("TraceFromFilm<double>/") + file).c_str(),
                                 BM_TraceFromFilm<double>, std::string(file));
    benchmark::RegisterBenchmark((std::string("TraceFromFilm<float>/") + file).c_str(),
                                 BM_TraceFromFilm<float>, std::string(file));
    benchmark::RegisterBenchmark((std::string("TraceFromFilmBatch<float>/") + file).c_str(),
                                 BM_TraceFromFilmBatch, std::string(file));
    benchmark::RegisterBenchmark((std::string("ExitPupilBuild/") + file).c_str(), BM_ExitPupilBuild,
                                 std::string(file))
        ->Unit(benchmark::kMillisecond);
  }
  for (const char* file :
       {"dgauss.50mm.dat", "lentil:2004", "lentil:0014", "toroidal-anamorphic.50mm.zmx"})
    benchmark::RegisterBenchmark((std::string("MarginSquaredBatch<double>/") + file).c_str(),
                                 BM_MarginSquaredBatch, std::string(file));
}

}  // namespace

int main(int argc, char** argv) {
  registerAll();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
