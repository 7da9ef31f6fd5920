// The cloud and nanovdb media against closed forms: Beer-Lambert transmittance through a
// constant-density box of a NanoVDB file written here with NanoVDB's own GridBuilder (not the
// reader under test), the blackbody emission of a hot, optically thick "temperature" grid
// (Planck's law), and majorants that bound every density sample along random rays.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nanovdb/NanoVDB.h>
#include <nanovdb/util/GridBuilder.h>
#include <nanovdb/util/IO.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <random>
#include <string>

#include "direct_world_util.h"
#include "lensim/render/integrators/volpath.h"
#include "lensim/render/lights/lights.h"
#include "lensim/render/materials/materials.h"
#include "lensim/render/media/media.h"
#include "lensim/render/media/media_volumes.h"
#include "lensim/render/shapes/accel.h"
#include "lensim/render/textures/textures.h"
#include "render_test_util.h"

using namespace lensim;
using lensim::testutil::buildText;

namespace {

namespace fs = std::filesystem;

/// A fresh directory for the test's files.
fs::path testDir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / fmt::format("lensim-vdb-{}-{}", name, ::getpid());
  fs::create_directories(d);
  return d;
}

/// Writes a .nvdb file with float fog-volume grids: "density" with value(i, j, k) over the
/// index box [0, n)^3 and, if temperature > 0, a constant "temperature" grid over the same box;
/// voxel size h, the index origin at world point `origin`.
template <class F>
void writeNvdb(const fs::path& file, int n, double h, const nanovdb::Vec3d& origin, F value,
               double temperature = 0) {
  std::vector<nanovdb::GridHandle<nanovdb::HostBuffer>> handles;
  {
    nanovdb::GridBuilder<float> builder(0.0f, nanovdb::GridClass::FogVolume);
    auto acc = builder.getAccessor();
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) acc.setValue(nanovdb::Coord(i, j, k), float(value(i, j, k)));
    handles.push_back(builder.getHandle<>(h, origin, "density"));
  }
  if (temperature > 0) {
    nanovdb::GridBuilder<float> builder(0.0f, nanovdb::GridClass::FogVolume);
    auto acc = builder.getAccessor();
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) acc.setValue(nanovdb::Coord(i, j, k), float(temperature));
    handles.push_back(builder.getHandle<>(h, origin, "temperature"));
  }
  nanovdb::io::writeGrids(file.string(), handles);
}

/// A scene built for calling the integrator directly.
struct Direct : testutil::DirectWorld {
  Direct(const std::string& text, const fs::path& dir)
      : DirectWorld(scene::build(scene::parseString(text, (dir / "scene.pbrt").string()))) {}
};

/// Mean radiance (and its standard error) at each wavelength of the set drawn with u0, over
/// paths from o along dir starting in medium 0; each wavelength in turn is the hero.
struct Estimate {
  double lambda[4], mean[4], sem[4];
};
Estimate radiance(const Direct& d, const Vec3& o, const Vec3& dir, int paths) {
  const double u0 = 0.13;
  const render::SampledWavelengths base = render::SampledWavelengths::sampleUniform(u0);
  sampling::IndependentSampler sampler(paths, 9);
  render::RayCounts counts;
  double sum[4] = {}, sum2[4] = {};
  for (int k = 0; k < 4; ++k) {
    const render::SampledWavelengths lambda =
        render::SampledWavelengths::sampleUniform(std::fmod(u0 + k / 4.0, 1.0));
    int slot[4] = {};
    for (int c = 0; c < 4; ++c)
      for (int j = 0; j < 4; ++j)
        if (std::abs(lambda.lambda(c) - base.lambda(j)) < 1e-6) slot[c] = j;
    for (int i = 0; i < paths; ++i) {
      sampler.startPixelSample({k, 0}, i);
      render::SampledWavelengths l = lambda;
      const render::SampledSpectrum L = render::volpathLi(d.sc, o, dir, 0, l, sampler, counts);
      for (int c = 0; c < 4; ++c) sum[slot[c]] += L[c], sum2[slot[c]] += L[c] * L[c];
    }
  }
  Estimate e;
  const double n = 4.0 * paths;
  for (int j = 0; j < 4; ++j) {
    e.lambda[j] = base.lambda(j);
    e.mean[j] = sum[j] / n;
    e.sem[j] = std::sqrt(std::max(0.0, sum2[j] / n - e.mean[j] * e.mean[j]) / (n - 1));
  }
  return e;
}

}  // namespace

// A 20^3 box of voxels of density c (voxel size 0.1 m, index origin at (-1, -1, -1)) absorbs
// with sigma_a(lambda) linear from 0.3 at 360 nm to 1.3 at 830 nm. A two-sided emitter inside
// the box at x = 0.5 is seen from (-0.5, 0, 0) along +x: the path of 1 m lies where every
// trilinear lookup meets voxels of value c only, so T = exp(-sigma_a c 1 m); the same scene
// with scale 0 gives the unattenuated radiance.
TEST(NanoVDBMedium, BeerLambertThroughAConstantBox) {
  const fs::path dir = testDir("beer");
  const double c = 1.7;
  writeNvdb(dir / "box.nvdb", 20, 0.1, nanovdb::Vec3d(-1, -1, -1),
            [&](int, int, int) { return c; });
  auto text = [](double scale) {
    return fmt::format(R"(
Integrator "volpath" "integer maxdepth" 5
WorldBegin
MakeNamedMedium "vdb" "string type" "nanovdb" "string filename" "box.nvdb"
  "spectrum sigma_a" [360 0.3 830 1.3] "rgb sigma_s" [0 0 0] "float scale" {}
AttributeBegin
  MediumInterface "vdb" ""
  Material "interface"
  Shape "sphere" "float radius" 3
AttributeEnd
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [1 1 1] "bool twosided" true
  Shape "trianglemesh" "point3 P" [0.5 -0.2 -0.2  0.5 -0.2 0.2  0.5 0.2 0.2  0.5 0.2 -0.2]
    "integer indices" [0 1 2 0 2 3]
AttributeEnd
)",
                       scale);
  };
  const Direct medium(text(1), dir), clear(text(0), dir);
  const Estimate L = radiance(medium, {-0.5, 0, 0}, {1, 0, 0}, 60000);
  const Estimate L0 = radiance(clear, {-0.5, 0, 0}, {1, 0, 0}, 50);
  for (int j = 0; j < 4; ++j) {
    const double sigma = 0.3 + (L.lambda[j] - 360) / 470;
    const double expected = std::exp(-sigma * c * 1.0);
    ASSERT_GT(L0.mean[j], 0);
    const double T = L.mean[j] / L0.mean[j], sem = L.sem[j] / L0.mean[j];
    std::printf("nanovdb %.1f nm: T %.5f +- %.5f, exp(-sigma_a c d) %.5f\n", L.lambda[j], T, sem,
                expected);
    EXPECT_NEAR(T, expected, 4 * sem + 1e-6) << "at " << L.lambda[j] << " nm";
    EXPECT_LT(sem, 0.03 * expected);
  }
  fs::remove_all(dir);
}

// An optically thick, purely absorbing box at a constant 2000 K (temperaturescale 2 of a grid
// holding 1000, offset 0): seen from inside, the radiance is the emitted Le = Lescale B(T)
// (pbrt-v4: the blackbody normalised to 1 at its peak), from Planck's law here.
TEST(NanoVDBMedium, HotOpaqueGridGlowsAsABlackbody) {
  const fs::path dir = testDir("hot");
  writeNvdb(
      dir / "fire.nvdb", 20, 0.1, nanovdb::Vec3d(-1, -1, -1), [](int, int, int) { return 1.0; },
      1000);
  const Direct d(R"(
Integrator "volpath" "integer maxdepth" 5
WorldBegin
MakeNamedMedium "fire" "string type" "nanovdb" "string filename" "fire.nvdb"
  "rgb sigma_a" [1 1 1] "rgb sigma_s" [0 0 0] "float scale" 60 "float Lescale" 3
  "float temperaturescale" 2
AttributeBegin
  MediumInterface "fire" ""
  Material "interface"
  Shape "sphere" "float radius" 3
AttributeEnd
)",
                 dir);
  const Estimate L = radiance(d, {0, 0, 0}, {0, 0, 1}, 2000);
  auto planck = [](double lambda_nm, double T) {
    const double c = 299792458, h = 6.62606957e-34, kb = 1.3806488e-23, l = lambda_nm * 1e-9;
    return 2 * h * c * c / (std::pow(l, 5) * (std::exp(h * c / (l * kb * T)) - 1));
  };
  const double T = 2000, peak = 2.897771955e-3 / T * 1e9;
  for (int j = 0; j < 4; ++j) {
    // (1 - exp(-tau)) with tau = 60 over 0.9 m of full density: 1 to 1e-23.
    const double expected = 3 * planck(L.lambda[j], T) / planck(peak, T);
    std::printf("blackbody %.1f nm: L %.5f +- %.5f, expected %.5f\n", L.lambda[j], L.mean[j],
                L.sem[j], expected);
    EXPECT_NEAR(L.mean[j], expected, 4 * L.sem[j] + 1e-3 * expected) << L.lambda[j] << " nm";
  }
  fs::remove_all(dir);
}

// Majorants bound the medium everywhere: along random rays through a noisy grid (rotated and
// scaled by the CTM) and a cloud, every sigma_t sampled in a segment is at most its majorant.
// The segments leave out only parts of the ray where the density is zero.
TEST(NanoVDBMedium, MajorantsBoundEveryDensitySample) {
  const fs::path dir = testDir("maj");
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> U(0, 1);
  std::vector<double> values(size_t(24 * 24 * 24));
  for (double& v : values) v = U(rng) < 0.3 ? 0 : 5 * U(rng) * U(rng);
  writeNvdb(dir / "noise.nvdb", 24, 0.05, nanovdb::Vec3d(-0.6, -0.6, -0.6),
            [&](int i, int j, int k) { return values[size_t((k * 24 + j) * 24 + i)]; });
  const scene::Scene s = scene::build(scene::parseString(R"(
WorldBegin
AttributeBegin
  Rotate 30 1 1 0
  Scale 1 2 0.7
  MakeNamedMedium "vdb" "string type" "nanovdb" "string filename" "noise.nvdb"
    "rgb sigma_a" [0.2 0.5 0.9] "rgb sigma_s" [1 0.5 0.3] "float scale" 3
  MakeNamedMedium "cloud" "string type" "cloud" "float density" 2 "float wispiness" 1.5
    "point3 p0" [-1 -0.5 -1] "point3 p1" [1 1 1] "rgb sigma_s" [2 1 0.5]
AttributeEnd
)",
                                                         (dir / "scene.pbrt").string()));
  ASSERT_FALSE(s.hasErrors()) << formatDiagnostics(s.diagnostics);
  const render::Media media(s);
  for (int mi = 0; mi < 2; ++mi) {
    const render::Medium* m = media.get(mi);
    ASSERT_NE(m, nullptr);
    int samples = 0, nonzero = 0;
    double worst = 0;
    for (int r = 0; r < 300; ++r) {
      const Vec3 o{4 * U(rng) - 2, 4 * U(rng) - 2, 4 * U(rng) - 2};
      Vec3 dvec{U(rng) - 0.5, U(rng) - 0.5, U(rng) - 0.5};
      dvec = normalize(dvec);
      const render::SampledWavelengths lambda = render::SampledWavelengths::sampleUniform(U(rng));
      double covered_end = 0;
      std::vector<std::pair<double, double>> segments;
      m->majorants(
          o, dvec, 10, lambda, [&](double t0, double t1, const render::SampledSpectrum& smaj) {
            EXPECT_LE(t0, t1);
            EXPECT_GE(t0, covered_end - 1e-9);  // in order, not overlapping
            covered_end = t1;
            segments.push_back({t0, t1});
            for (int k = 0; k < 40; ++k) {
              const double t = t0 + (t1 - t0) * U(rng);
              const render::MediumProperties mp = m->at(o + dvec * t, lambda);
              for (int c = 0; c < 4; ++c) {
                const double st = mp.sigma_a[c] + mp.sigma_s[c];
                ++samples;
                nonzero += st > 0;
                worst = std::max(worst, st - smaj[c]);
                EXPECT_LE(st, smaj[c] * (1 + 1e-6) + 1e-9) << "medium " << mi << " at t " << t;
              }
            }
            return true;
          });
      // Outside the segments the medium is empty.
      for (int k = 0; k < 40; ++k) {
        const double t = 10 * U(rng);
        bool in = false;
        for (auto [a, b] : segments) in = in || (t >= a && t <= b);
        if (!in) {
          const render::MediumProperties mp = m->at(o + dvec * t, lambda);
          EXPECT_EQ(mp.sigma_a.maxValue() + mp.sigma_s.maxValue(), 0) << "medium " << mi;
        }
      }
    }
    std::printf("medium %d: %d samples, %d non-zero, worst excess %.3g\n", mi, samples, nonzero,
                worst);
    EXPECT_GT(nonzero, samples / 10);  // the rays did cross the media
  }
  // The majorant grid is tight where it matters: the largest cell is the largest voxel value.
  const auto* vdb = dynamic_cast<const render::NanoVDBMedium*>(media.get(0));
  ASSERT_NE(vdb, nullptr);
  double max_cell = 0, max_voxel = 0;
  for (double v : vdb->majorantCells()) max_cell = std::max(max_cell, v);
  for (double v : values) max_voxel = std::max(max_voxel, double(float(v)));
  EXPECT_NEAR(max_cell, max_voxel, 1e-6);
  fs::remove_all(dir);
}

TEST(NanoVDBMedium, BadFilesAreLocatedErrors) {
  const fs::path dir = testDir("bad");
  {
    std::FILE* f = std::fopen((dir / "junk.nvdb").c_str(), "wb");
    std::fputs("not a nanovdb file", f);
    std::fclose(f);
  }
  writeNvdb(dir / "nodensity.nvdb", 2, 1, nanovdb::Vec3d(0, 0, 0), [](int, int, int) { return 1; });
  for (auto [file, message] :
       {std::pair{"junk.nvdb", "cannot read NanoVDB file"}, {"missing.nvdb", "not found"}}) {
    const std::string text = fmt::format(
        "WorldBegin\nMakeNamedMedium \"m\" \"string type\" \"nanovdb\" \"string filename\" "
        "\"{}\"\n",
        file);
    try {
      const scene::Scene s = scene::build(scene::parseString(text, (dir / "scene.pbrt").string()));
      if (s.hasErrors()) throw Error(formatDiagnostics(s.diagnostics));
      const render::Media media(s);
      ADD_FAILURE() << "no error for " << file;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("scene.pbrt:2"), std::string::npos) << e.what();
    }
  }
  fs::remove_all(dir);
}

// pbrt-v4's cloud density is 1 wherever y < 0 (its 2 max(0, 0.5 - y) term saturates), whatever
// the noise: a ray along x at y = -0.5 through the box [-1, 1]^3 meets 2 m of density 1, so
// T = exp(-sigma_a scale 2 m); outside the box the medium is empty.
TEST(CloudMedium, BeerLambertBelowTheCloudBase) {
  const fs::path dir = testDir("cloud");
  auto text = [](double scale) {
    return fmt::format(R"(
Integrator "volpath" "integer maxdepth" 5
WorldBegin
MakeNamedMedium "c" "string type" "cloud" "point3 p0" [-1 -1 -1] "point3 p1" [1 1 1]
  "spectrum sigma_a" [360 0.3 830 1.3] "rgb sigma_s" [0 0 0] "float scale" {}
AttributeBegin
  MediumInterface "c" ""
  Material "interface"
  Shape "sphere" "float radius" 3
AttributeEnd
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [1 1 1] "bool twosided" true
  Shape "trianglemesh" "point3 P" [1.5 -0.7 -0.2  1.5 -0.7 0.2  1.5 -0.3 0.2  1.5 -0.3 -0.2]
    "integer indices" [0 1 2 0 2 3]
AttributeEnd
)",
                       scale);
  };
  const double scale = 0.6;
  const Direct medium(text(scale), dir), clear(text(0), dir);
  const Estimate L = radiance(medium, {-1.5, -0.5, 0}, {1, 0, 0}, 20000);
  const Estimate L0 = radiance(clear, {-1.5, -0.5, 0}, {1, 0, 0}, 50);
  for (int j = 0; j < 4; ++j) {
    const double sigma = 0.3 + (L.lambda[j] - 360) / 470;
    const double expected = std::exp(-sigma * scale * 2);
    const double T = L.mean[j] / L0.mean[j], sem = L.sem[j] / L0.mean[j];
    std::printf("cloud %.1f nm: T %.5f +- %.5f, closed form %.5f\n", L.lambda[j], T, sem, expected);
    EXPECT_NEAR(T, expected, 4 * sem + 1e-6) << "at " << L.lambda[j] << " nm";
  }
  fs::remove_all(dir);
}
