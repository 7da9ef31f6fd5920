#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

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
    EXPECT_GT(sampler.area_mm2(film), 0);
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
