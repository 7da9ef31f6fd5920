#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "lensim/optics/focus.h"
#include "lensim/optics/lens_system.h"
#include "test_paths.h"

using namespace lensim;
using namespace lensim::optics;
using lensim::test::kClassicLenses;
using lensim::test::lensPath;

namespace {

// A lens focused at infinity.
LensSystem infinityLens(const std::string& file) {
  FocusedLens fl = focusLens(readLensFile(lensPath(file)), {});
  return *fl.lens;
}

Vec2 uniformDisk(std::mt19937_64& rng, double r) {
  std::uniform_real_distribution<double> u(0, 1);
  const double rr = r * std::sqrt(u(rng)), phi = 2 * std::numbers::pi * u(rng);
  return {rr * std::cos(phi), rr * std::sin(phi)};
}

Vec3 rotateZ(const Vec3& v, double a) {
  return {v.x * std::cos(a) - v.y * std::sin(a), v.x * std::sin(a) + v.y * std::cos(a), v.z};
}

double maxAbsDiff(const Vec3& a, const Vec3& b) {
  return std::max({std::abs(a.x - b.x), std::abs(a.y - b.y), std::abs(a.z - b.z)});
}

}  // namespace

TEST(LensTracer, OnAxisRayStaysOnAxis) {
  for (const char* file : kClassicLenses) {
    SCOPED_TRACE(file);
    LensSystem lens = infinityLens(file);
    TraceResult r = lens.traceFromFilmPoint({0, 0}, {0, 0});
    ASSERT_TRUE(r.ok());
    EXPECT_EQ(r.ray.origin.x, 0.0);
    EXPECT_EQ(r.ray.origin.y, 0.0);
    EXPECT_EQ(r.ray.direction.x, 0.0);
    EXPECT_EQ(r.ray.direction.y, 0.0);
    EXPECT_NEAR(r.ray.direction.z, -1.0, 1e-14);  // unit to rounding (not renormalised)
    EXPECT_NEAR(r.ray.origin.z, 0.0, 1e-12);      // leaves at the front vertex
  }
}

TEST(LensTracer, RotationallySymmetric) {
  std::mt19937_64 rng(7);
  for (const char* file : kClassicLenses) {
    SCOPED_TRACE(file);
    LensSystem lens = infinityLens(file);
    const double rear = lens.interfaces().back().semi_aperture_mm;
    int passed = 0;
    for (int k = 0; k < 500; ++k) {
      const Vec2 f = uniformDisk(rng, 10), a = uniformDisk(rng, rear);
      const double ang = std::uniform_real_distribution<double>(0, 2 * std::numbers::pi)(rng);
      const Vec3 fr = rotateZ({f.x, f.y, 0}, ang), ar = rotateZ({a.x, a.y, 0}, ang);
      TraceResult r0 = lens.traceFromFilmPoint(f, a);
      TraceResult r1 = lens.traceFromFilmPoint({fr.x, fr.y}, {ar.x, ar.y});
      ASSERT_EQ(r0.ok(), r1.ok());
      if (!r0.ok()) {
        EXPECT_EQ(r0.blocked_surface, r1.blocked_surface);
        continue;
      }
      ++passed;
      EXPECT_LT(maxAbsDiff(rotateZ(r0.ray.origin, ang), r1.ray.origin), 1e-9);
      EXPECT_LT(maxAbsDiff(rotateZ(r0.ray.direction, ang), r1.ray.direction), 1e-12);
    }
    EXPECT_GT(passed, 20);
  }
}

TEST(LensTracer, FilmToSceneAndBackReturnsToTheStart) {
  std::mt19937_64 rng(11);
  for (const char* file : kClassicLenses) {
    SCOPED_TRACE(file);
    LensSystem lens = infinityLens(file);
    const double rear = lens.interfaces().back().semi_aperture_mm;
    int passed = 0;
    for (int k = 0; k < 2000 && passed < 200; ++k) {
      const Vec2 f = uniformDisk(rng, 12), a = uniformDisk(rng, rear);
      TraceResult out = lens.traceFromFilmPoint(f, a);
      if (!out.ok()) continue;
      ++passed;
      TraceResult back = lens.tracer().traceFromScene(Ray{out.ray.origin, -out.ray.direction});
      ASSERT_TRUE(back.ok());
      // Intersect the returning ray with the film plane.
      const double t = (lens.filmZ_mm() - back.ray.origin.z) / back.ray.direction.z;
      const Vec3 hit = back.ray.origin + back.ray.direction * t;
      EXPECT_NEAR(hit.x, f.x, 1e-9);
      EXPECT_NEAR(hit.y, f.y, 1e-9);
      const Vec3 d0 =
          normalize(Vec3{a.x, a.y, lens.rearVertexZ_mm()} - Vec3{f.x, f.y, lens.filmZ_mm()});
      EXPECT_LT(maxAbsDiff(back.ray.direction, -d0), 1e-12);
    }
    EXPECT_GT(passed, 50);
  }
}

// Every hit lies on its sphere, on the cap that faces the vertex, within the clear aperture.
TEST(LensTracer, EverySurfaceIsHitOnTheVertexSide) {
  std::mt19937_64 rng(3);
  for (const char* file : kClassicLenses) {
    SCOPED_TRACE(file);
    LensSystem lens = infinityLens(file);
    const auto& s = lens.interfaces();
    const int n = lens.surfaceCount();
    const double rear = s.back().semi_aperture_mm;
    int passed = 0;
    for (int k = 0; k < 3000; ++k) {
      std::vector<Vec3> path;
      TraceResult r =
          lens.traceFromFilmPoint(uniformDisk(rng, 12), uniformDisk(rng, rear), {}, &path);
      if (!r.ok()) continue;
      ++passed;
      ASSERT_EQ(static_cast<int>(path.size()), n + 1);
      for (int i = 0; i < n; ++i) {
        const Vec3 p = path[n - i];  // film-to-scene order
        const double R = s[i].radius_mm;
        const double h = std::hypot(p.x, p.y);
        EXPECT_LE(h, s[i].semi_aperture_mm + 1e-12);
        if (R == 0) {
          EXPECT_NEAR(p.z, s[i].z_mm, 1e-12);
          continue;
        }
        const Vec3 c{0, 0, s[i].z_mm + R};
        EXPECT_NEAR(length(p - c), std::abs(R), 1e-9 * std::abs(R));
        // Vertex side: the hit is within the cap's sag of the vertex plane.
        const double sag = R - std::copysign(std::sqrt(R * R - h * h), R);
        EXPECT_NEAR(p.z - s[i].z_mm, sag, 1e-9);
      }
      // Film to scene, every hit moves toward the scene.
      for (int k2 = 1; k2 <= n; ++k2) EXPECT_LT(path[k2].z, path[k2 - 1].z);
    }
    EXPECT_GT(passed, 100);
  }
}

// A near-tangent ray: the stable roots keep the hit on the sphere; a ray just outside misses.
TEST(LensTracer, NearTangentHits) {
  const double R = 20;
  std::vector<Interface> one{{R, 0, R, 1.0, 1.5, false}};  // full hemisphere aperture
  LensTracer<double> tracer(one);
  for (double eps : {1e-3, 1e-6, 1e-9}) {
    // Ray parallel to the axis at height just below R: grazes the rim of the hemisphere.
    Ray in{{R * (1 - eps), 0, -50}, {0, 0, 1}};
    std::vector<Vec3> path;
    TraceResult r = tracer.traceFromScene(in, {}, &path);
    ASSERT_EQ(path.size(), 2u) << eps;
    const Vec3 c{0, 0, R};
    EXPECT_NEAR(length(path[1] - c), R, 1e-9) << eps;
    EXPECT_LT(path[1].z, R) << eps;  // on the vertex hemisphere
    (void)r;
  }
  // A ray tangent-ish in the other direction: crossing the cap nearly perpendicular to the axis.
  Ray across{{-30, 0, 0.5}, {1, 0, 0}};
  std::vector<Vec3> path;
  TraceResult r = tracer.traceFromScene(across, {}, &path);
  ASSERT_GE(path.size(), 2u);
  EXPECT_LT(path[1].x, 0);  // the first of the two cap crossings
  EXPECT_NEAR(length(path[1] - Vec3{0, 0, R}), R, 1e-12);
  (void)r;
  // Just outside the sphere: a miss.
  TraceResult miss = tracer.traceFromScene(Ray{{R * (1 + 1e-9), 0, -50}, {0, 0, 1}});
  EXPECT_EQ(miss.reason, BlockReason::Miss);
  EXPECT_EQ(miss.blocked_surface, 0);
}

// A huge radius refracts like a plane.
TEST(LensTracer, HugeRadiusBehavesLikeAPlane) {
  for (double R : {1e7, -1e7}) {
    std::vector<Interface> sphere{{50, 0, 15, 1.0, 1.6, false}, {R, 6, 15, 1.6, 1.0, false}};
    std::vector<Interface> plane{{50, 0, 15, 1.0, 1.6, false}, {0, 6, 15, 1.6, 1.0, false}};
    LensTracer<double> ts(sphere), tp(plane);
    for (double h : {0.0, 3.0, 9.0}) {
      for (double ang : {0.0, 0.2, -0.3}) {
        Ray in{{h, 1, -20}, normalize(Vec3{std::sin(ang), 0, std::cos(ang)})};
        TraceResult a = ts.traceFromScene(in), b = tp.traceFromScene(in);
        ASSERT_TRUE(a.ok());
        ASSERT_TRUE(b.ok());
        // Sag at 15 mm is 1.1e-5 mm and the normal tilts by 1.5e-6 rad.
        EXPECT_LT(maxAbsDiff(a.ray.origin, b.ray.origin), 2e-5) << R << " " << h << " " << ang;
        EXPECT_LT(maxAbsDiff(a.ray.direction, b.ray.direction), 5e-6) << R << " " << h;
      }
    }
  }
}

TEST(LensTracer, TotalInternalReflectionBeyondTheCriticalAngle) {
  const double n = 1.5;
  const double critical = std::asin(1 / n);
  std::vector<Interface> exit{{0, 0, 100, n, 1.0, false}};  // glass to air, a plane at z = 0
  LensTracer<double> tracer(exit);
  for (double delta : {1e-3, 1e-6}) {
    for (double sign : {-1.0, 1.0}) {
      const double th = critical + sign * delta;
      Ray in{{0, 0, -1}, {std::sin(th), 0, std::cos(th)}};
      TraceResult r = tracer.traceFromScene(in);
      if (sign > 0) {
        EXPECT_EQ(r.reason, BlockReason::TotalInternalReflection) << delta;
        EXPECT_EQ(r.blocked_surface, 0);
      } else {
        ASSERT_TRUE(r.ok()) << delta;
        // Snell: sin(out) = n sin(in)
        EXPECT_NEAR(std::hypot(r.ray.direction.x, r.ray.direction.y), n * std::sin(th), 1e-12);
      }
    }
  }
  // From the air side there is never TIR.
  std::vector<Interface> entry{{0, 0, 100, 1.0, n, false}};
  LensTracer<double> in_tracer(entry);
  TraceResult r = in_tracer.traceFromScene(Ray{{0, 0, -1}, normalize(Vec3{0.999, 0, 0.01})});
  EXPECT_TRUE(r.ok());
}

TEST(LensTracer, BlockedRaysSayWhereAndWhy) {
  LensSystem lens = infinityLens("dgauss.50mm.dat");
  // Aimed far outside the rear element.
  TraceResult r = lens.traceFromFilmPoint({0, 0}, {12, 0});
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.reason, BlockReason::Aperture);
  EXPECT_EQ(r.blocked_surface, lens.surfaceCount() - 1);
  // Stopped down: a ray through the stop's rim region is blocked at the stop.
  FocusedLens stopped =
      focusLens(readLensFile(lensPath("dgauss.50mm.dat")), {.aperture_diameter_mm = 2.0});
  TraceResult s = stopped.lens->traceFromFilmPoint({0, 0}, {5, 0});
  EXPECT_EQ(s.reason, BlockReason::Aperture);
  EXPECT_EQ(s.blocked_surface, *stopped.lens->stopIndex());
}

// The float tracer (for a renderer's hot path) agrees with the double one.
TEST(LensTracer, FloatAgreesWithDouble) {
  std::mt19937_64 rng(5);
  for (const char* file : kClassicLenses) {
    SCOPED_TRACE(file);
    LensSystem lens = infinityLens(file);
    const double rear = lens.interfaces().back().semi_aperture_mm;
    int both = 0, disagree = 0, total = 0;
    double max_pos = 0, max_dir = 0;
    for (int k = 0; k < 20000; ++k) {
      const Vec2 f = uniformDisk(rng, 12), a = uniformDisk(rng, rear);
      const Vec3 from{f.x, f.y, lens.filmZ_mm()};
      const Vec3 dir = normalize(Vec3{a.x, a.y, lens.rearVertexZ_mm()} - from);
      TraceResult rd = lens.tracer().traceFromFilm(Ray{from, dir});
      TraceResultT<float> rf =
          lens.tracerFloat().traceFromFilm(RayT<float>{Vec3f(from), Vec3f(dir)});
      ++total;
      if (rd.ok() != rf.ok()) {
        ++disagree;
        continue;
      }
      if (!rd.ok()) continue;
      ++both;
      max_pos = std::max(max_pos, maxAbsDiff(rd.ray.origin, Vec3(rf.ray.origin)));
      max_dir = std::max(max_dir, maxAbsDiff(rd.ray.direction, Vec3(rf.ray.direction)));
    }
    EXPECT_GT(both, 100);
    // Only rays within float rounding of an aperture rim may differ.
    EXPECT_LE(disagree, total / 1000) << disagree << " of " << total;
    EXPECT_LT(max_pos, 1e-3) << max_pos;
    EXPECT_LT(max_dir, 1e-4) << max_dir;
  }
}

// The batched tracer (rays interleaved surface by surface) gives exactly what tracing each ray
// alone gives, in float and double: same fate, same blocking surface and reason, and bit-equal
// exit rays and stop points for rays that get through. Random film points and rear-element
// points, many of them vignetted; batches of every size up to the maximum.
template <typename T>
void checkBatch(const LensTracer<T>& tracer, const LensSystem& lens, std::mt19937_64& rng) {
  std::vector<RayT<T>> rays;
  const double rear = lens.interfaces().back().semi_aperture_mm;
  for (int k = 0; k < 2000; ++k) {
    const Vec2 f = uniformDisk(rng, 17.5), a = uniformDisk(rng, rear * 1.1);
    const Vec3 from{f.x, f.y, lens.filmZ_mm()};
    const Vec3 to{a.x, a.y, lens.rearVertexZ_mm()};
    const Vec3 d = normalize(to - from);
    rays.push_back({Vec3T<T>(from), Vec3T<T>(d)});
  }
  int ok = 0;
  for (size_t start = 0, n = 1; start < rays.size();
       start += n, n = n % LensTracer<T>::kBatch + 1) {
    const int m = int(std::min(n, rays.size() - start));
    TraceResultT<T> batch[LensTracer<T>::kBatch];
    tracer.traceFromFilmBatch(&rays[start], m, batch);
    for (int j = 0; j < m; ++j) {
      const TraceResultT<T> one = tracer.traceFromFilm(rays[start + size_t(j)]);
      ASSERT_EQ(one.reason, batch[j].reason) << "ray " << start + size_t(j);
      ASSERT_EQ(one.blocked_surface, batch[j].blocked_surface);
      if (!one.ok()) continue;
      ++ok;
      EXPECT_EQ(one.ray.origin.x, batch[j].ray.origin.x);
      EXPECT_EQ(one.ray.origin.y, batch[j].ray.origin.y);
      EXPECT_EQ(one.ray.origin.z, batch[j].ray.origin.z);
      EXPECT_EQ(one.ray.direction.x, batch[j].ray.direction.x);
      EXPECT_EQ(one.ray.direction.y, batch[j].ray.direction.y);
      EXPECT_EQ(one.ray.direction.z, batch[j].ray.direction.z);
      EXPECT_EQ(one.stop_point.x, batch[j].stop_point.x);
      EXPECT_EQ(one.stop_point.y, batch[j].stop_point.y);
    }
  }
  EXPECT_GT(ok, 50);  // both fates are exercised
  EXPECT_LT(ok, 1950);
}

TEST(LensTracer, BatchMatchesSingleTraces) {
  std::mt19937_64 rng(11);
  for (const char* file : kClassicLenses) {
    SCOPED_TRACE(file);
    const LensSystem lens = infinityLens(file);
    checkBatch(lens.tracer(), lens, rng);
    checkBatch(lens.tracerFloat(), lens, rng);
  }
  // Surfaces the batch intersects side by side: cylinders (lentil:2004), toroids (Newton's
  // method lane by lane), conics and aspheres on a conic base (lentil:0014).
  for (const std::string& file :
       {std::string("lentil:2004"), std::string("lentil:0014"),
        std::string(LENSIM_SOURCE_DIR) + "/lenses/toroidal-anamorphic.50mm.zmx"}) {
    SCOPED_TRACE(file);
    const FocusedLens fl = focusLens(readLensFile(file), {});
    checkBatch(fl.lens->tracer(), *fl.lens, rng);
    checkBatch(fl.lens->tracerFloat(), *fl.lens, rng);
  }
  // A stop between glass and air refracts (the batch's other plane loop).
  SCOPED_TRACE("stop in glass");
  const FocusedLens fl = focusLens(parseLensPrescription("40 6 1.6 24\n"
                                                         "0 4 1 14\n"
                                                         "-60 3 1.7 22\n"
                                                         "-200 30 1 22\n",
                                                         "glass-stop.dat"),
                                   {});
  ASSERT_TRUE(fl.lens->interfaces()[1].is_stop);
  ASSERT_NE(fl.lens->interfaces()[1].ior_before, fl.lens->interfaces()[1].ior_after);
  checkBatch(fl.lens->tracer(), *fl.lens, rng);
  checkBatch(fl.lens->tracerFloat(), *fl.lens, rng);
}

// The aperture margin (LensTracer::marginSquared) against the clipped trace, independently of
// how it is computed: at most 1 exactly where the clipped trace gets through (rays within
// rounding of a rim aside), infinite only where the unclipped trace misses a surface, and the
// batched version bit-equal to the single one. Spherical, cylindrical (lentil:2004), toroidal
// and aspheric (lentil:0014) lenses, focused at 3.3 m, random film and rear-plane points.
TEST(LensTracer, MarginIsAtMostOneExactlyWhereTheClippedTracePasses) {
  std::mt19937_64 rng(5);
  const std::vector<std::string> lenses = {
      lensPath("dgauss.50mm.dat"), "lentil:2004", "lentil:0014",
      std::string(LENSIM_SOURCE_DIR) + "/lenses/toroidal-anamorphic.50mm.zmx"};
  for (const std::string& file : lenses) {
    SCOPED_TRACE(file);
    const FocusedLens fl =
        focusLens(readLensFile(file), {.aperture_diameter_mm = 100.0, .focus_distance_m = 3.3});
    const LensSystem& lens = *fl.lens;
    const LensTracer<double>& tracer = lens.tracer();
    const double rear = lens.interfaces().back().semi_aperture_mm;
    std::vector<Ray> rays;
    for (int k = 0; k < 3000; ++k)
      rays.push_back(lens.filmPointRay(uniformDisk(rng, 21.6), uniformDisk(rng, rear * 1.2)));
    int pass = 0, near_rim = 0, misses = 0;
    for (size_t start = 0, n = 1; start < rays.size();
         start += n, n = n % LensTracer<double>::kBatch + 1) {
      const int m = int(std::min(n, rays.size() - start));
      double batch[LensTracer<double>::kBatch];
      tracer.marginSquaredBatch(&rays[start], m, batch);
      for (int j = 0; j < m; ++j) {
        const Ray& ray = rays[start + size_t(j)];
        const double m2 = tracer.marginSquared(ray);
        ASSERT_EQ(m2, batch[j]) << "ray " << start + size_t(j);
        const TraceResult clipped = tracer.traceFromFilm(ray);
        const TraceResult open = tracer.traceFromFilm(ray, {.clip_apertures = false});
        ASSERT_EQ(std::isinf(m2), open.reason == BlockReason::Miss);
        misses += std::isinf(m2);
        pass += clipped.ok();
        if (std::abs(m2 - 1) < 1e-9) {
          ++near_rim;
          continue;
        }
        EXPECT_EQ(m2 <= 1, clipped.ok()) << "ray " << start + size_t(j) << ": margin^2 " << m2;
      }
    }
    EXPECT_GT(pass, 50);  // both sides are exercised
    EXPECT_LT(pass, 2900);
    EXPECT_LE(near_rim, 3);
    RecordProperty(file + " misses", misses);
  }
}
