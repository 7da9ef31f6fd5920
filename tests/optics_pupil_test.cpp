#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <string>

#include "lensim/optics/glass/library.h"
#include "lensim/optics/focus.h"
#include "lensim/optics/pupil.h"
#include "test_paths.h"

using namespace lensim;
using namespace lensim::optics;
using lensim::test::lensPath;

namespace {

struct Case {
  const char* file;
  std::optional<double> aperture_mm;  // nullopt: wide open
};

const Case kCases[] = {{"dgauss.50mm.dat", {}},     {"dgauss.50mm.dat", 6.0},
                       {"fisheye.10mm.dat", {}},    {"fisheye.10mm.dat", 2.0},
                       {"wide.22mm.dat", {}},       {"wide.22mm.dat", 3.0},
                       {"telephoto.250mm.dat", {}}, {"telephoto.250mm.dat", 12.0}};

constexpr double kFilmDiagonal = 35.0;

Vec2 uniformFilm(std::mt19937_64& rng) {
  // Uniform over a 3:2 film of the given diagonal, as a camera would sample it.
  std::uniform_real_distribution<double> u(-1, 1);
  const double w = kFilmDiagonal * 3 / std::sqrt(13.0) / 2,
               h = kFilmDiagonal * 2 / std::sqrt(13.0) / 2;
  return {u(rng) * w, u(rng) * h};
}

// A lens in the realistic camera's set-up (bench/lens-table: 36x24 mm film, focused at 3.3 m, wide
// open, the camera's six wavelength bands for a dispersive lens) and its bounds, with lenses at
// wavelengths across each band (`inside`: where in the band, 0 and 1 its ends).
struct CameraSetUp {
  FocusedLens fl;
  double half_w = 43.3 * 3 / std::sqrt(13.0) / 2, half_h = 43.3 * 2 / std::sqrt(13.0) / 2;
  bool dispersive = false;
  std::vector<LensSystem> edge_lenses, at;  // band edges; wavelengths inside the bands
  std::vector<int> band_of;                 // the band of each of `at`
  std::optional<ExitPupilSampler> sampler;

  CameraSetUp(const std::string& lens, const std::vector<double>& inside)
      : fl(focusLens(readLensFile(lens),
                     {.aperture_diameter_mm = 100.0, .focus_distance_m = 3.3})) {
    ExitPupilOptions o;
    for (const Interface& in : fl.lens->interfaces())
      if (!in.shape.isRotational()) o.rotational = false;
    constexpr int kBands = 6;
    std::vector<double> edges;
    dispersive = fl.lens->dispersive();
    if (dispersive) {
      const double a = 1 / (360.0 * 360.0), c = 1 / (830.0 * 830.0);
      for (int k = 0; k <= kBands; ++k) edges.push_back(1 / std::sqrt(a + (c - a) * k / kBands));
      for (double l : edges) edge_lenses.push_back(fl.lens->atWavelength(l));
      for (int k = 0; k < kBands; ++k) o.bands.push_back({&edge_lenses[k], &edge_lenses[k + 1]});
      for (int k = 0; k < kBands; ++k)
        for (double t : inside) {
          at.push_back(fl.lens->atWavelength(edges[k] + t * (edges[k + 1] - edges[k])));
          band_of.push_back(k);
        }
    }
    o.film_half_extent_mm = {half_w, half_h};
    sampler.emplace(*fl.lens, fl.paraxial, std::hypot(half_w, half_h), o);
  }
  // The lens at wavelength `w` (the lens itself when it is not dispersive) and its band.
  const LensSystem& lens(size_t w) const { return dispersive ? at[w % at.size()] : *fl.lens; }
  int band(size_t w) const { return dispersive ? band_of[w % at.size()] : -1; }
};

}  // namespace

// Every ray that gets through the lens starts toward a point inside the bounds: sampling only the
// bounds loses no light.
TEST(ExitPupilSampler, BoundsContainEveryPassingRay) {
  for (const Case& c : kCases) {
    SCOPED_TRACE(std::string(c.file) + (c.aperture_mm ? " stopped down" : " wide open"));
    FocusedLens fl =
        focusLens(readLensFile(lensPath(c.file)), {.aperture_diameter_mm = c.aperture_mm});
    ExitPupilSampler sampler(*fl.lens, fl.paraxial, kFilmDiagonal / 2);
    std::mt19937_64 rng(17);
    std::uniform_real_distribution<double> u(-1, 1);
    const double rr = 1.5 * fl.lens->interfaces().back().semi_aperture_mm;
    int passing = 0, outside = 0;
    for (int k = 0; k < 200000; ++k) {
      const Vec2 film = uniformFilm(rng);
      const Vec2 a{u(rng) * rr, u(rng) * rr};
      if (!fl.lens->traceFromFilmPoint(film, a).ok()) continue;
      ++passing;
      if (!sampler.contains(film, a)) ++outside;
    }
    EXPECT_GT(passing, 500);
    EXPECT_EQ(outside, 0) << outside << " of " << passing << " passing rays outside the bounds";
  }
}

// At most 5% of the camera's samples yield no ray.
TEST(ExitPupilSampler, FewSamplesAreWasted) {
  for (const Case& c : kCases) {
    SCOPED_TRACE(std::string(c.file) + (c.aperture_mm ? " stopped down" : " wide open"));
    FocusedLens fl =
        focusLens(readLensFile(lensPath(c.file)), {.aperture_diameter_mm = c.aperture_mm});
    ExitPupilSampler sampler(*fl.lens, fl.paraxial, kFilmDiagonal / 2);
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> u(0, 1);
    int samples = 0, wasted = 0;
    for (int k = 0; k < 100000; ++k) {
      const Vec2 film = uniformFilm(rng);
      auto s = sampler.sample(film, {u(rng), u(rng)});
      if (!s) continue;  // outside the image circle: no ray is traced at all
      ++samples;
      const Vec3 from{film.x, film.y, fl.lens->filmZ_mm()};
      if (!fl.lens->tracer().traceFromFilm(Ray{from, normalize(s->rear_point_mm - from)}).ok())
        ++wasted;
    }
    const double share = static_cast<double>(wasted) / samples;
    RecordProperty("wasted", std::to_string(share));
    EXPECT_LE(share, 0.05) << share;
    EXPECT_GT(samples, 1000);
  }
}

// Samples lie in the bound (contains() agrees with sample()) and the bound turns with the film
// point's azimuth.
TEST(ExitPupilSampler, SamplesLieInTheBoundsAndRotateWithTheFilmPoint) {
  FocusedLens fl = focusLens(readLensFile(lensPath("dgauss.50mm.dat")), {});
  ExitPupilSampler sampler(*fl.lens, fl.paraxial, kFilmDiagonal / 2);
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(0, 1);
  const double r = 12.0;
  for (double ang : {0.0, 1.0, 2.5}) {
    const Vec2 film{r * std::cos(ang), r * std::sin(ang)};
    // The component of the samples across the film point's direction averages to zero (the
    // bound is mirror-symmetric about that direction), within 4.5 standard errors.
    double sum = 0, sum2 = 0;
    const int n = 20000;
    for (int k = 0; k < n; ++k) {
      auto s = sampler.sample(film, {u(rng), u(rng)});
      ASSERT_TRUE(s);
      EXPECT_TRUE(sampler.contains(film, {s->rear_point_mm.x, s->rear_point_mm.y}));
      const double across =
          -std::sin(ang) * s->rear_point_mm.x + std::cos(ang) * s->rear_point_mm.y;
      sum += across;
      sum2 += across * across;
    }
    const double mean = sum / n, se = std::sqrt((sum2 / n - mean * mean) / n);
    EXPECT_LT(std::abs(mean), 4.5 * se + 1e-3) << mean << " se " << se;
    EXPECT_GT(sampler.areaMm2(film), 0);
  }
}

TEST(ExitPupilSampler, BuildsQuickly) {
  for (const Case& c : kCases) {
    FocusedLens fl =
        focusLens(readLensFile(lensPath(c.file)), {.aperture_diameter_mm = c.aperture_mm});
    ExitPupilSampler sampler(*fl.lens, fl.paraxial, kFilmDiagonal / 2);
    // The issue asks for at most 0.1 s of start-up; the count of traces is the machine-independent
    // measure (bench/ reports the time).
    EXPECT_LT(sampler.tracesAtBuild(), 400000) << c.file;
  }
}

// Bounds limited to the rear element's disc (the pbrt-v1/v2 assignment's aiming rule), in the
// assignment's four set-ups (70 mm film, its film distances and stops): every ray through the
// disc that gets through the lens lies inside them, and at most 5% of the samples they give are
// blocked (by the lens or by falling outside the disc).
TEST(ExitPupilSampler, RearDiscBoundsForTheAssignmentSetUps) {
  struct SetUp {
    const char* file;
    double film_distance_mm, aperture_mm;
  } setups[] = {{"dgauss.50mm.dat", 36.77, 17.1},
                {"telephoto.250mm.dat", 123.7439, 40.5},
                {"wide.22mm.dat", 14.54, 8.756},
                {"fisheye.10mm.dat", 23.192, 6.08}};
  for (const SetUp& s : setups) {
    SCOPED_TRACE(s.file);
    FocusedLens fl =
        focusLens(readLensFile(lensPath(s.file)),
                  {.aperture_diameter_mm = s.aperture_mm, .film_distance_mm = s.film_distance_mm});
    const double disc = fl.lens->interfaces().back().semi_aperture_mm;
    ExitPupilOptions o;
    o.rear_disc_radius_mm = disc;
    o.radial_bins = 40;  // as the realistic camera builds them in this mode
    const double film_radius = 35.0;
    ExitPupilSampler sampler(*fl.lens, fl.paraxial, film_radius, o);
    std::mt19937_64 rng(23);
    std::uniform_real_distribution<double> u(0, 1);
    auto squareFilm = [&] {  // uniform over the square 300x300 film of 70 mm diagonal
      const double half = film_radius / std::sqrt(2.0);
      return Vec2{(2 * u(rng) - 1) * half, (2 * u(rng) - 1) * half};
    };
    int passing = 0, outside = 0;
    for (int k = 0; k < 200000; ++k) {
      const Vec2 film = squareFilm();
      const double r = disc * std::sqrt(u(rng)), phi = 2 * std::numbers::pi * u(rng);
      const Vec2 a{r * std::cos(phi), r * std::sin(phi)};
      if (!fl.lens->traceFromFilmPoint(film, a).ok()) continue;
      ++passing;
      outside += !sampler.contains(film, a);
    }
    EXPECT_GT(passing, 1000);
    EXPECT_EQ(outside, 0) << outside << " of " << passing << " passing rays outside the bounds";
    int samples = 0, wasted = 0;
    for (int k = 0; k < 100000; ++k) {
      const Vec2 film = squareFilm();
      auto p = sampler.sample(film, {u(rng), u(rng)});
      if (!p) continue;
      ++samples;
      const Vec3& q = p->rear_point_mm;
      wasted += q.x * q.x + q.y * q.y > disc * disc ||
                !fl.lens->traceFromFilmPoint(film, {q.x, q.y}).ok();
    }
    std::printf("%s: %d passing rays, %.2f%% of %d samples wasted\n", s.file, passing,
                100.0 * wasted / samples, samples);
    EXPECT_LE(double(wasted) / samples, 0.05);
  }
}

// Anamorphic lenses (lentil's rear-anamorphic double Gauss and Cooke's front anamorphic): the
// 2-D bound (ExitPupilOptions::rotational = false) holds (nearly) every passing ray; the share
// of its samples that are blocked (wasted) and its build time are printed.
TEST(ExitPupilSampler, AnamorphicBoundsContainEveryPassingRay) {
  for (const char* name : {"lentil:2003", "lentil:2004"}) {
    SCOPED_TRACE(name);
    FocusedLens fl = focusLens(readLensFile(name), {});
    ExitPupilOptions o;
    o.rotational = false;
    ExitPupilSampler sampler(*fl.lens, fl.paraxial, kFilmDiagonal / 2, o);
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> u(-1, 1), u01(0, 1);
    const double rr = 1.5 * fl.lens->interfaces().back().semi_aperture_mm;
    int passing = 0, outside = 0, sampled = 0, sampled_ok = 0;
    for (int k = 0; k < 60000; ++k) {
      const Vec2 film = uniformFilm(rng);
      const Vec2 a{u(rng) * rr, u(rng) * rr};
      if (fl.lens->traceFromFilmPoint(film, a).ok()) {
        ++passing;
        if (!sampler.contains(film, a)) {
          ++outside;
          if (outside < 4)
            std::printf("  outside: film %.3f %.3f (r %.3f) rear %.3f %.3f, area %.3f\n", film.x,
                        film.y, std::hypot(film.x, film.y), a.x, a.y, sampler.areaMm2(film));
        }
      }
      if (auto s = sampler.sample(film, {u01(rng), u01(rng)})) {
        ++sampled;
        sampled_ok +=
            fl.lens->traceFromFilmPoint(film, {s->rear_point_mm.x, s->rear_point_mm.y}).ok();
      }
    }
    EXPECT_GT(passing, 300);
    // Measured: 0 of 10630 (2003) and 0 of 12023 (2004) with 4 wedges of 2 azimuths (with one
    // bound over 8 azimuths around the whole circle: 1 of 12023 outside); allowed: below 1e-3.
    EXPECT_LE(outside, passing / 1000) << outside << " of " << passing << " passing rays outside";
    std::printf(
        "%s: %d of %d passing rays outside the bounds; %.1f%% of %d bound samples blocked; build "
        "%.3f s, %ld traces, %d intervals\n",
        name, outside, passing, 100.0 * (sampled - sampled_ok) / std::max(sampled, 1), sampled,
        sampler.buildSeconds(), sampler.tracesAtBuild(), sampler.intervals());
  }
}

// The budgets for lenses that are not spherical, for the bound at one wavelength (the
// camera widens a dispersive aspheric/anamorphic lens's bound by 5%, see realistic.cpp): at most
// 5% of the samples inside the image circle wasted, and a bounded build cost. Start-up time is not
// asserted (bench/lens-table measures it); its machine-independent proxy, the number of rays traced
// to build the bound, is. Each aspheric trace costs a few microseconds (Newton solves), so the
// asphere's limit is set well under what the former dense bracketing traced (201228 for
// ACL3026U, 160038 for lentil:0014) and the anamorphic's under the former 584276 (lentil:2003).
TEST(ExitPupilSampler, AsphericAndAnamorphicLensesMeetTheBudgets) {
  setModelGlassAllowed(true);  // ACL3026U's B270 is in no catalogue (--model-glass)
  struct Budget {
    std::string lens;
    long max_traces;
  };
  const Budget budgets[] = {
      {std::string(LENSIM_SHARED_DIR) + "/lenses/zmx/ACL3026U-Zemax(ZMX).zmx", 60000},
      {"lentil:0014", 45000},
      {"lentil:2003", 170000},
  };
  for (const Budget& b : budgets) {
    SCOPED_TRACE(b.lens);
    FocusedLens fl = focusLens(readLensFile(b.lens), {});
    ExitPupilOptions o;
    for (const Interface& in : fl.lens->interfaces())
      if (!in.shape.isRotational()) o.rotational = false;
    ExitPupilSampler sampler(*fl.lens, fl.paraxial, kFilmDiagonal / 2, o);
    EXPECT_LE(sampler.tracesAtBuild(), b.max_traces);
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> u(0, 1);
    int samples = 0, wasted = 0;
    for (int k = 0; k < 40000; ++k) {
      const Vec2 film = uniformFilm(rng);
      auto s = sampler.sample(film, {u(rng), u(rng)});
      if (!s) continue;
      ++samples;
      wasted += !fl.lens->traceFromFilmPoint(film, {s->rear_point_mm.x, s->rear_point_mm.y}).ok();
    }
    EXPECT_GT(samples, 10000);
    EXPECT_LE(double(wasted) / samples, 0.05) << wasted << " of " << samples;
    std::printf("%s: %ld traces, %.3f s; %.2f%% of %d samples wasted\n", b.lens.c_str(),
                sampler.tracesAtBuild(), sampler.buildSeconds(), 100.0 * wasted / samples, samples);
  }
}

// A dispersive lens's bounds per wavelength band (as the realistic camera builds them: six bands
// of equal steps in 1/lambda^2 over 360-830 nm, each holding its two ends' regions): every ray
// that gets through at a wavelength starts toward a point of its band's bound (checked at
// wavelengths spread over every band, not only its ends), and few of a band's samples are
// blocked at the band's wavelengths. SF66 (V_d 21) and the asphere move their regions most.
TEST(ExitPupilSampler, WavelengthBandBoundsHoldEveryWavelengthsRays) {
  setModelGlassAllowed(true);  // ACL3026U's B270 is in no catalogue (--model-glass)
  const std::string lenses[] = {
      lensPath("landscape.sf66.dat"),
      std::string(LENSIM_SHARED_DIR) + "/lenses/zmx/ACL3026U-Zemax(ZMX).zmx", "lentil:0005"};
  for (const std::string& file : lenses) {
    SCOPED_TRACE(file);
    FocusedLens fl = focusLens(readLensFile(file), {});
    ASSERT_TRUE(fl.lens->dispersive());
    constexpr int kBands = 6;
    const double a = 1 / (360.0 * 360.0), b = 1 / (830.0 * 830.0);
    std::vector<double> edges;
    for (int k = 0; k <= kBands; ++k) edges.push_back(1 / std::sqrt(a + (b - a) * k / kBands));
    std::vector<LensSystem> edge_lenses;
    for (double l : edges) edge_lenses.push_back(fl.lens->atWavelength(l));
    ExitPupilOptions o;
    for (int k = 0; k < kBands; ++k) o.bands.push_back({&edge_lenses[k], &edge_lenses[k + 1]});
    ExitPupilSampler sampler(*fl.lens, fl.paraxial, kFilmDiagonal / 2, o);
    ASSERT_EQ(sampler.bands(), kBands);
    // Four wavelengths inside each band (not its ends).
    std::vector<LensSystem> at;
    std::vector<int> band_of;
    for (int k = 0; k < kBands; ++k)
      for (double t : {0.2, 0.4, 0.6, 0.8}) {
        at.push_back(fl.lens->atWavelength(edges[k] + t * (edges[k + 1] - edges[k])));
        band_of.push_back(k);
      }
    std::mt19937_64 rng(29);
    std::uniform_real_distribution<double> u(0, 1);
    const double rr = 1.5 * fl.lens->interfaces().back().semi_aperture_mm;
    int passing = 0, outside = 0;
    for (int k = 0; k < 120000; ++k) {
      const Vec2 film = uniformFilm(rng);
      const Vec2 q{(2 * u(rng) - 1) * rr, (2 * u(rng) - 1) * rr};
      const size_t w = size_t(k) % at.size();
      if (!at[w].traceFromFilmPoint(film, q).ok()) continue;
      ++passing;
      outside += !sampler.contains(film, q, band_of[w]);
    }
    EXPECT_GT(passing, 1000);
    // The condenser asphere's region has corners near the rear rim (|q| ~ 14 mm of 15) that the
    // polygons do not follow exactly: a few in 10^4 of its passing rays fall outside, at the
    // primary wavelength too (3 in 34346 with the lens's own bound, the same rays as before the
    // wavelength bands and the secant boundary search). The others lose none.
    const bool asphere = file.find("ACL3026U") != std::string::npos;
    EXPECT_LE(outside, asphere ? passing / 1000 : 0)
        << outside << " of " << passing << " passing rays outside the bounds";
    int samples = 0, wasted = 0;
    for (int k = 0; k < 40000; ++k) {
      const Vec2 film = uniformFilm(rng);
      const size_t w = size_t(k) % at.size();
      auto s = sampler.sample(film, {u(rng), u(rng)}, band_of[w]);
      if (!s) continue;
      ++samples;
      wasted += !at[w].traceFromFilmPoint(film, {s->rear_point_mm.x, s->rear_point_mm.y}).ok();
    }
    std::printf("%s: %ld traces, %.3f s; %d passing rays; %.2f%% of %d samples wasted\n",
                file.c_str(), sampler.tracesAtBuild(), sampler.buildSeconds(), passing,
                100.0 * wasted / samples, samples);
    EXPECT_LE(double(wasted) / samples, 0.05);
  }
}

// The bounds this session's changes reshaped, in the camera's set-up (bench/lens-table: 36x24 mm
// film, focused at 3.3 m, wide open, the camera's six wavelength bands for a dispersive lens):
// the Cassegrain's hole with a vertex distance per direction, and the anamorphic lenses' bounds
// blended by azimuth between wedge edges, and the searches that accept a blocked point near a
// predicted boundary (the wavelength bands' vertices, the checks from a polygon's edges).
// Densely: 250 rear-plane points (750 for 0014) for each of 400 film points that see something, at
// wavelengths inside every band (not only the band's ends); no ray that gets through may start
// outside its band's bound. Waste is checked as in bench/lens-table.
TEST(ExitPupilSampler, ReshapedBoundsHoldEveryPassingRayInTheCameraSetUp) {
  struct Budget {
    const char* lens;
    double max_waste;
    int rear_points = 250;  // per film point (0014's region is a small share of the square)
  };
  // Measured waste: Cassegrain 4.0% (13.3% with the scaled-copy hole), lentil:2003 2.5%,
  // lentil:2004 7.0% (12.6% with each wedge the union of its edges' regions): over the issue's
  // 5%, see the README's lens table.
  // lentil:0005 (spherical) and 0014 (four even aspheres), both dispersive: their wavelength
  // bands' vertex distances are accepted from one blocked trace near the predicted boundary,
  // and every polygon's checks start at its edges (measured 3.4% and 5.1% on the film).
  const Budget budgets[] = {{"lenses:cassegrain.500mm", 0.05},
                            {"lentil:2003", 0.05},
                            {"lentil:2004", 0.08},
                            {"lentil:0005", 0.05},
                            {"lentil:0014", 0.06, 750}};
  for (const Budget& b : budgets) {
    SCOPED_TRACE(b.lens);
    const CameraSetUp cs(b.lens, {0.15, 0.5, 0.85});
    const ExitPupilSampler& sampler = *cs.sampler;
    const double half_w = cs.half_w, half_h = cs.half_h;
    const FocusedLens& fl = cs.fl;
    std::mt19937_64 rng(31);
    std::uniform_real_distribution<double> u(0, 1);
    const double rr = 1.5 * fl.lens->interfaces().back().semi_aperture_mm;
    int films = 0, passing = 0, outside = 0, samples = 0, wasted = 0;
    for (int tries = 0; films < 400 && tries < 100000; ++tries) {
      const Vec2 film{(2 * u(rng) - 1) * half_w, (2 * u(rng) - 1) * half_h};
      const int band = cs.band(size_t(tries));
      const LensSystem& lens = cs.lens(size_t(tries));
      if (!(sampler.areaMm2(film, band) > 0)) continue;
      ++films;
      for (int k = 0; k < b.rear_points; ++k) {
        const Vec2 q{(2 * u(rng) - 1) * rr, (2 * u(rng) - 1) * rr};
        if (!lens.traceFromFilmPoint(film, q).ok()) continue;
        ++passing;
        outside += !sampler.contains(film, q, band);
      }
      for (int k = 0; k < 50; ++k) {
        const auto s = sampler.sample(film, {u(rng), u(rng)}, band);
        ASSERT_TRUE(s);
        ++samples;
        wasted += !lens.traceFromFilmPoint(film, {s->rear_point_mm.x, s->rear_point_mm.y}).ok();
      }
    }
    EXPECT_EQ(films, 400);
    EXPECT_GT(passing, 5000);
    EXPECT_EQ(outside, 0) << outside << " of " << passing << " passing rays outside the bounds";
    EXPECT_LE(double(wasted) / samples, b.max_waste) << wasted << " of " << samples;
    std::printf("%s: %d of %d passing rays outside; %.2f%% of %d samples wasted; %ld traces\n",
                b.lens, outside, passing, 100.0 * wasted / samples, samples,
                sampler.tracesAtBuild());
  }
}

// A denser check, over the whole film (film points that see nothing at the wavelength included)
// and at the bands' ends as well as inside them: 3000 film points, 300 rear-plane points each. The
// bounds miss a few passing rays, all of them near the edge of the image circle, where the region
// shrinks to a sliver and moves fast with the film point and the wavelength, and where the
// blended polygon of an anamorphic wedge follows it least. Measured (23 November, checks that end
// where the polygon covers the region): lentil:0005 2 of 81,339, 0014 6 of 14,698, 2004 6 of
// 148,564, and the toroidal anamorphic 290 of 158,610 (0.18%; at film radii 14.4-18.5 mm, its
// image circle's x radius 16.9 mm, mostly at film azimuths 25-35 degrees, between wedge checks).
// The caps below fail on a bound that loses more, or loses rays away from the edge.
TEST(ExitPupilSampler, RaysOutsideTheBoundsAreFewAndOnlyNearTheEdgeOfTheImageCircle) {
  struct Cap {
    const char* lens;
    double max_outside;  // share of the passing rays
    double edge;         // share of the farthest passing film radius beyond which they may lie
  };
  const Cap caps[] = {{"lentil:0005", 1e-4, 0.85},
                      {"lentil:0014", 6e-4, 0.85},
                      {"lentil:2004", 1e-4, 0.75},
                      {"lenses:toroidal-anamorphic.50mm", 2.5e-3, 0.6}};
  for (const Cap& c : caps) {
    SCOPED_TRACE(c.lens);
    const CameraSetUp cs(c.lens, {0.0, 0.3, 0.7, 1.0});
    std::mt19937_64 rng(77);
    std::uniform_real_distribution<double> u(0, 1);
    const double rr = 1.5 * cs.fl.lens->interfaces().back().semi_aperture_mm;
    long passing = 0, outside = 0;
    double r_far = 0, r_out = kFilmDiagonal * 10;  // farthest passing, nearest outside
    for (int f = 0; f < 3000; ++f) {
      const Vec2 film{(2 * u(rng) - 1) * cs.half_w, (2 * u(rng) - 1) * cs.half_h};
      const double r = std::hypot(film.x, film.y);
      for (int k = 0; k < 300; ++k) {
        const Vec2 q{(2 * u(rng) - 1) * rr, (2 * u(rng) - 1) * rr};
        if (!cs.lens(size_t(f)).traceFromFilmPoint(film, q).ok()) continue;
        ++passing;
        r_far = std::max(r_far, r);
        if (!cs.sampler->contains(film, q, cs.band(size_t(f)))) {
          ++outside;
          r_out = std::min(r_out, r);
        }
      }
    }
    std::printf(
        "%s: %ld of %ld passing rays outside, the nearest at film radius %.2f mm (%.2f of "
        "the farthest passing, %.2f mm)\n",
        c.lens, outside, passing, outside ? r_out : 0.0, outside ? r_out / r_far : 0.0, r_far);
    EXPECT_GT(passing, 10000);
    EXPECT_LE(double(outside), c.max_outside * double(passing));
    if (outside > 0) {
      EXPECT_GE(r_out, c.edge * r_far);
    }
  }
}

// An anamorphic lens's bound on a film rectangle (ExitPupilOptions::film_half_extent_mm, as the
// camera builds it) reaches only as far as the rectangle does at each wedge's azimuths: every ray
// that gets through from film points along the rectangle's edges (where each wedge edge's bound
// ends) starts inside it, the build traces fewer rays than the bound over the whole film radius,
// and a film point beyond the rectangle's reach gets no sample rather than one from a bound that
// was not built for it.
TEST(ExitPupilSampler, AnamorphicBoundsOnAFilmRectangleHoldItsEdgesPassingRays) {
  for (const char* name : {"lenses:toroidal-anamorphic.50mm", "lentil:2004"}) {
    SCOPED_TRACE(name);
    const FocusedLens fl =
        focusLens(readLensFile(name), {.aperture_diameter_mm = 100.0, .focus_distance_m = 3.3});
    const double half_w = 18, half_h = 12, radius = std::hypot(half_w, half_h);
    ExitPupilOptions o;
    o.rotational = false;
    const ExitPupilSampler disc(*fl.lens, fl.paraxial, radius, o);
    o.film_half_extent_mm = {half_w, half_h};
    const ExitPupilSampler rect(*fl.lens, fl.paraxial, radius, o);
    EXPECT_LT(rect.tracesAtBuild(), disc.tracesAtBuild());
    std::mt19937_64 rng(41);
    std::uniform_real_distribution<double> u(0, 1);
    const double rr = 1.5 * fl.lens->interfaces().back().semi_aperture_mm;
    long passing = 0, outside = 0, lost = 0;  // lost: inside the disc's bound, not the rectangle's
    for (int f = 0; f < 800; ++f) {
      // A point on one of the rectangle's four edges.
      const double t = 2 * u(rng) - 1, side = u(rng) < 0.5 ? -1 : 1;
      const Vec2 film = f % 2 ? Vec2{t * half_w, side * half_h} : Vec2{side * half_w, t * half_h};
      for (int k = 0; k < 200; ++k) {
        const Vec2 q{(2 * u(rng) - 1) * rr, (2 * u(rng) - 1) * rr};
        if (!fl.lens->traceFromFilmPoint(film, q).ok()) continue;
        ++passing;
        const bool in_rect = rect.contains(film, q);
        outside += !in_rect;
        lost += disc.contains(film, q) && !in_rect;
      }
    }
    std::printf(
        "%s: %ld traces on the rectangle, %ld on the disc; %ld of %ld passing rays from "
        "the rectangle's edges outside (%ld inside the disc's bound)\n",
        name, rect.tracesAtBuild(), disc.tracesAtBuild(), outside, passing, lost);
    EXPECT_GT(passing, 5000);
    // Measured: toroidal 6 of 8327 outside both bounds (near its image circle's edge, as in
    // RaysOutsideTheBoundsAreFewAndOnlyNearTheEdgeOfTheImageCircle), 2004 none.
    EXPECT_LE(double(outside), 1e-3 * double(passing));
    EXPECT_EQ(lost, 0);
    // On the y axis past the rectangle's reach (the 90-degree wedge edge's bound ends at the first
    // node past 12 / sin 67.5 = 13 mm) but inside the film radius, where the disc's bound holds
    // a region.
    const Vec2 beyond{0, 15};
    EXPECT_GT(disc.areaMm2(beyond), 0.0);
    EXPECT_FALSE(rect.sample(beyond, {0.5, 0.5}));
    EXPECT_EQ(rect.areaMm2(beyond), 0.0);
  }
}
