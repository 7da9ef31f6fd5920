// The realistic camera's cost per sample (film point -> pupil sample -> exact trace -> weight),
// for the four assignment (dof-dragons) set-ups: 300x300 pixels, 70 mm film diagonal, the
// scenes' film distances and stops, pbrt-v1/v2 conventions. Counters: samples/s, and the share of
// samples that yield a ray. Run with bench/run.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "lensim/camera/realistic.h"
#include "lensim/sampling/filter.h"

using namespace lensim;
using namespace lensim::camera;

namespace {

struct Setup {
  const char* lens;
  double film_distance_mm, aperture_mm;
};

RealisticSettings settingsFor(const Setup& setup) {
  RealisticSettings s;
  s.lens_path = std::string(LENSIM_SOURCE_DIR) + "/lenses/" + setup.lens;
  s.setup.film_distance_mm = setup.film_distance_mm;
  s.setup.aperture_diameter_mm = setup.aperture_mm;
  s.film_diagonal_mm = 70;
  s.x_resolution = s.y_resolution = 300;
  s.camera_units_per_mm = 1;
  s.exposure_time = 1;
  s.rear_disc_only = s.origin_at_front_vertex = true;
  return s;
}

// Random samples over the whole film.
std::vector<CameraSample> randomSamples() {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<CameraSample> samples(1 << 14);
  for (CameraSample& c : samples) c = {{300 * u(rng), 300 * u(rng)}, {u(rng), u(rng)}, 0};
  return samples;
}

void BM_RealisticCameraSample(benchmark::State& state, Setup setup) {
  const RealisticCamera cam(settingsFor(setup));
  const std::vector<CameraSample> samples = randomSamples();
  size_t i = 0, n = 0, rays = 0;
  for (auto _ : state) {
    const auto r = cam.generateRay(samples[i]);
    benchmark::DoNotOptimize(r);
    rays += r.has_value();
    ++n;
    if (++i == samples.size()) i = 0;
  }
  state.counters["samples/s"] = benchmark::Counter(double(n), benchmark::Counter::kIsRate);
  state.counters["rays"] = n ? double(rays) / n : 0.0;
}

// The same samples 16 at a time through generateRays (the lens traced side by side), as the
// renderer calls it.
void BM_RealisticCameraBatch(benchmark::State& state, Setup setup) {
  const RealisticCamera cam(settingsFor(setup));
  constexpr int kB = Camera::kMaxBatch;
  const std::vector<CameraSample> samples = randomSamples();
  std::optional<CameraRay> out[kB];
  size_t i = 0, n = 0;
  for (auto _ : state) {
    cam.generateRays(&samples[i], kB, out);
    benchmark::DoNotOptimize(out);
    n += kB;
    i += kB;
    if (i + kB > samples.size()) i = 0;
  }
  state.counters["samples/s"] = benchmark::Counter(double(n), benchmark::Counter::kIsRate);
}

// Dispersion (issue 10): the same lens with every element given its nearest catalogue glass
// (glassmatch), each sample carrying its hero wavelength: one re-indexed scalar trace per sample
// instead of the batched trace. Against the same samples through the non-dispersive lens.
void BM_RealisticCameraDispersion(benchmark::State& state, Setup setup, bool dispersive) {
  RealisticSettings st = settingsFor(setup);
  st.glass_match = dispersive;
  const RealisticCamera cam(st);
  constexpr int kB = Camera::kMaxBatch;
  std::vector<CameraSample> samples = randomSamples();
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> u(360, 830);
  // As the renderer hands them over: the path's four wavelengths (the hero and three others
  // equally spaced, wrapping around), the pixel and its filter.
  const sampling::GaussianFilter filter;
  for (CameraSample& c : samples) {
    const double l0 = u(rng);
    for (int i = 0; i < kCameraWavelengths; ++i)
      c.lambda_nm[size_t(i)] = 360 + std::fmod(l0 - 360 + i * 470.0 / kCameraWavelengths, 470.0);
    c.pixel_centre = {std::floor(c.film_raster.x) + 0.5, std::floor(c.film_raster.y) + 0.5};
    c.filter = &filter;
    c.filter_weight = filter.integral();
  }
  std::optional<CameraRay> out[kB];
  size_t i = 0, n = 0, rays = 0;
  for (auto _ : state) {
    cam.generateRays(&samples[i], kB, out);
    benchmark::DoNotOptimize(out);
    for (const auto& r : out) rays += r.has_value();
    n += kB;
    i += kB;
    if (i + kB > samples.size()) i = 0;
  }
  state.counters["camera rays/s"] = benchmark::Counter(double(rays), benchmark::Counter::kIsRate);
  state.counters["samples/s"] = benchmark::Counter(double(n), benchmark::Counter::kIsRate);
}

// Any lens lensim reads (catalogue names included), focused at 3 m, wide open, on a 3:2 film of
// 43.3 mm diagonal as in the demo scene: camera samples/s and camera rays/s (samples that yield
// a ray), batched as the renderer calls it. Compares aspheric and anamorphic lenses, whose
// non-spherical surfaces take the Newton / quadric path, with the all-spherical double Gauss.
void BM_RealisticCameraLens(benchmark::State& state, std::string lens) {
  RealisticSettings s;
  s.lens_path = lens.find(':') != std::string::npos
                    ? lens
                    : std::string(LENSIM_SOURCE_DIR) + "/lenses/" + lens;
  s.setup.focus_distance_m = 3.0;
  s.film_diagonal_mm = 43.3;
  s.x_resolution = 360;
  s.y_resolution = 240;
  s.camera_units_per_mm = 1;
  s.exposure_time = 1;
  const RealisticCamera cam(s);
  constexpr int kB = Camera::kMaxBatch;
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<CameraSample> samples(1 << 14);
  for (CameraSample& c : samples) c = {{360 * u(rng), 240 * u(rng)}, {u(rng), u(rng)}, 0};
  std::optional<CameraRay> out[kB];
  size_t i = 0, n = 0, rays = 0;
  for (auto _ : state) {
    cam.generateRays(&samples[i], kB, out);
    for (int k = 0; k < kB; ++k) rays += out[k].has_value();
    n += kB;
    i += kB;
    if (i + kB > samples.size()) i = 0;
  }
  state.counters["samples/s"] = benchmark::Counter(double(n), benchmark::Counter::kIsRate);
  state.counters["rays/s"] = benchmark::Counter(double(rays), benchmark::Counter::kIsRate);
  state.counters["startup_s"] = cam.startupSeconds();
}

}  // namespace

int main(int argc, char** argv) {
  for (const char* lens : {"dgauss.50mm.dat", "lentil:0001", "lentil:0014", "lentil:2004",
                           "lentil:2003", "toroidal-anamorphic.50mm.zmx"})
    benchmark::RegisterBenchmark((std::string("RealisticCameraLens/") + lens).c_str(),
                                 BM_RealisticCameraLens, std::string(lens));
  for (const Setup& s :
       {Setup{"dgauss.50mm.dat", 36.77, 17.1}, Setup{"telephoto.250mm.dat", 123.7439, 40.5},
        Setup{"wide.22mm.dat", 14.54, 8.756}, Setup{"fisheye.10mm.dat", 23.192, 6.08}}) {
    benchmark::RegisterBenchmark((std::string("RealisticCameraSample/") + s.lens).c_str(),
                                 BM_RealisticCameraSample, s);
    benchmark::RegisterBenchmark((std::string("RealisticCameraBatch16/") + s.lens).c_str(),
                                 BM_RealisticCameraBatch, s);
  }
  for (bool dispersive : {false, true}) {
    const Setup s{"dgauss.50mm.dat", 36.77, 17.1};
    benchmark::RegisterBenchmark((std::string("RealisticCameraBatch16/") + s.lens +
                                  (dispersive ? "/dispersive (glassmatch)" : "/non-dispersive"))
                                     .c_str(),
                                 BM_RealisticCameraDispersion, s, dispersive);
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
