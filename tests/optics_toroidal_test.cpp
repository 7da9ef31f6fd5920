// Toroidal surfaces (Zemax TOROIDAL) in the exact tracer, the paraxial code and the readers,
// checked against closed forms written here: the sphere and the cylinder they reduce to, the
// implicit torus equation, thick-lens first-order formulas and a y-nu trace of the file's data.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>
#include <sstream>

#include "lensim/optics/anamorphic.h"
#include "lensim/optics/lens_formats.h"
#include "lensim/optics/lens_system.h"
#include "lensim/optics/paraxial.h"
#include "lensim/optics/surface_shape.h"
#include "test_paths.h"

using namespace lensim;
using namespace lensim::optics;

namespace {

SurfaceShape toroid(double rotation_radius, double conic = 0, std::vector<double> poly = {}) {
  SurfaceShape s;
  s.rotation_radius_mm = rotation_radius;
  s.conic = conic;
  s.poly = std::move(poly);
  return s;
}

// The nearest hit on the vertex sheet of the sphere of radius R with its vertex at the origin
// (centre at z = R): |o + t d - C|^2 = R^2.
std::optional<double> sphereHit(double R, const Vec3& o, const Vec3& d) {
  const Vec3 c{0, 0, R};
  const Vec3 oc = o - c;
  const double b = dot(oc, d), cc = dot(oc, oc) - R * R;
  const double disc = b * b - cc;
  if (disc < 0) return std::nullopt;
  for (double t : {-b - std::sqrt(disc), -b + std::sqrt(disc)}) {
    const Vec3 p = o + d * t;
    if (t >= 0 && (p.z - R) * R < 0) return t;  // the vertex side of the centre
  }
  return std::nullopt;
}

// A ray through the lens from the scene: its exit point and direction, or nullopt if blocked.
std::optional<Ray> traceOut(const LensSystem& lens, const Ray& r) {
  const TraceResult t = lens.tracer().traceFromScene(r);
  if (!t.ok()) return std::nullopt;
  return t.ray;
}

// A singlet: plane stop, then `front` (toroidal or not), then a sphere; glass n = 1.6.
LensPrescription singlet(double front_radius, const SurfaceShape& front_shape) {
  LensPrescription p;
  p.path = "singlet";
  LensSurface stop;
  stop.stop_flag = true;
  stop.thickness_mm = 2;
  stop.aperture_diameter_mm = 16;
  LensSurface a;
  a.radius_mm = front_radius;
  a.shape = front_shape;
  a.thickness_mm = 6;
  a.ior = 1.6;
  a.aperture_diameter_mm = 16;
  LensSurface b;
  b.radius_mm = -60;
  b.thickness_mm = 40;
  b.aperture_diameter_mm = 16;
  p.surfaces = {stop, a, b};
  return p;
}

}  // namespace

TEST(Toroidal, EqualRadiiGiveTheSphere) {
  // (a) R = radius, no conic or terms: the toroid is the sphere; hits and normals agree with the
  // sphere's closed form, and a lens through it traces as the spherical lens does.
  const double R = 30, semi = 10;
  const ShapeIntersector isect(R, toroid(R), semi);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  int hits = 0;
  for (int k = 0; k < 2000; ++k) {
    const Vec3 o{semi * u(rng), semi * u(rng), -20};
    const Vec3 d = normalize(Vec3{0.15 * u(rng), 0.15 * u(rng), 1});
    const auto h = isect.intersect(o, d, 0);
    ASSERT_TRUE(h.has_value()) << k;
    const Vec3 p = o + d * h->t;
    if (p.x * p.x + p.y * p.y > semi * semi) continue;
    const auto ts = sphereHit(R, o, d);
    ASSERT_TRUE(ts.has_value()) << k;
    EXPECT_NEAR(h->t, *ts, 1e-10) << k;
    const Vec3 n_sphere = normalize(p - Vec3{0, 0, R}) * (R > 0 ? 1.0 : -1.0);  // faces -z
    EXPECT_NEAR(dot(h->normal, n_sphere), 1.0, 1e-12) << k;
    ++hits;
  }
  EXPECT_GT(hits, 1200);
  // Whole lenses: the toroidal front (R = 40 both ways) against the sphere of radius 40.
  const LensSystem sph(singlet(40, SurfaceShape{}));
  const LensSystem tor(singlet(40, toroid(40)));
  int traced = 0;
  for (int k = 0; k < 500; ++k) {
    const Ray r{{7 * u(rng), 7 * u(rng), -10}, normalize(Vec3{0.1 * u(rng), 0.1 * u(rng), 1})};
    const auto a = traceOut(sph, r), b = traceOut(tor, r);
    ASSERT_EQ(a.has_value(), b.has_value()) << k;
    if (!a) continue;
    EXPECT_NEAR(length(a->origin - b->origin), 0.0, 1e-9) << k;
    EXPECT_NEAR(length(a->direction - b->direction), 0.0, 1e-12) << k;
    ++traced;
  }
  EXPECT_GT(traced, 300);
}

TEST(Toroidal, InfiniteRadiusOfRotationIsTheCylinder) {
  // (b) R = 0 (Zemax: infinite) is the cylinder curved in y, flat in x: the same hits and normals
  // as lensim's cylindrical surface (radius_x 0) and the circle's closed form along y; a very
  // large R approaches it.
  const double r = 25, semi = 10;
  SurfaceShape cyl;
  cyl.radius_x_mm = 0.0;
  const ShapeIntersector c(r, cyl, semi), t0(r, toroid(0), semi), tbig(r, toroid(1e9), semi);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  int inside = 0;
  for (int k = 0; k < 1000; ++k) {
    const Vec3 o{semi * u(rng), semi * u(rng), -15};
    const Vec3 d = normalize(Vec3{0.3 * u(rng), 0.3 * u(rng), 1});
    const auto a = c.intersect(o, d, 0), b = t0.intersect(o, d, 0), e = tbig.intersect(o, d, 0);
    ASSERT_TRUE(a && b && e) << k;
    // Inside the clear aperture (beyond it the quadric cylinder is hit on the quadric, the
    // general solve on the flat continuation: both are clipped there).
    const Vec3 p = o + d * a->t;
    if (p.x * p.x + p.y * p.y > semi * semi) continue;
    ++inside;
    EXPECT_NEAR(a->t, b->t, 1e-10) << k;
    EXPECT_NEAR(dot(a->normal, b->normal), 1.0, 1e-13) << k;
    EXPECT_NEAR(a->t, e->t, 1e-6) << k;
  }
  EXPECT_GT(inside, 600);
  // Along y at x = 7: the circle of radius 25; along x at y = 0: flat.
  auto h = t0.intersect(Vec3{7, 6, -3}, Vec3{0, 0, 1}, 0);
  ASSERT_TRUE(h.has_value());
  EXPECT_NEAR(h->t - 3, r - std::sqrt(r * r - 36.0), 1e-12);
  h = t0.intersect(Vec3{7, 0, -3}, Vec3{0, 0, 1}, 0);
  ASSERT_TRUE(h.has_value());
  EXPECT_NEAR(h->t, 3.0, 1e-12);
  EXPECT_EQ(vertexCurvatureX(r, toroid(0)), 0.0);
  EXPECT_EQ(vertexCurvatureY(r, toroid(0)), 1 / r);
}

TEST(Toroidal, HitsLieOnTheTorusWithItsGradientAsNormal) {
  // (d) A circular y curve of radius r rotated about an axis at R: the torus
  // F = (sqrt(x^2 + (z - R)^2) - sgn(R) (R - r))^2 + y^2 - r^2 = 0 (tube radius |r|, the tube's
  // centre |R - r| from the axis). Hits (rays in the x-z plane, then any rays) satisfy it to 1e-9
  // mm (|F| / |grad F|) and the normal is grad F.
  for (const auto& [r, R] :
       {std::pair{40.0, 20.0}, std::pair{15.0, 50.0}, std::pair{-30.0, -18.0}}) {
    const double semi = 9;
    const ShapeIntersector isect(r, toroid(R), semi);
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> u(-1, 1);
    for (int k = 0; k < 1000; ++k) {
      const bool xz = k < 300;
      const Vec3 o{semi * u(rng), xz ? 0.0 : semi * u(rng), -25};
      const Vec3 d = normalize(Vec3{0.3 * u(rng), xz ? 0.0 : 0.3 * u(rng), 1});
      const auto h = isect.intersect(o, d, 0);
      ASSERT_TRUE(h.has_value()) << k;
      const Vec3 p = o + d * h->t;
      if (p.x * p.x + p.y * p.y > semi * semi) continue;
      if (xz) {
        EXPECT_EQ(p.y, 0.0);
      }
      const double D = std::sqrt(p.x * p.x + (p.z - R) * (p.z - R));
      const double s = D - (R > 0 ? 1 : -1) * (R - r);
      const double F = s * s + p.y * p.y - r * r;
      const Vec3 grad{2 * s * p.x / D, 2 * p.y, 2 * s * (p.z - R) / D};
      EXPECT_LT(std::abs(F) / length(grad), 1e-9) << k << " r " << r << " R " << R;
      const Vec3 n = normalize(grad) * (grad.z > 0 ? -1.0 : 1.0);  // facing -z
      EXPECT_NEAR(dot(h->normal, n), 1.0, 1e-12) << k;
    }
  }
}

TEST(Toroidal, SagGradientAndHitsWithConicAndTerms) {
  // A toroid with a conic y curve and y^2, y^4 terms: hits lie on the sag, the normal is the
  // sag's gradient, and the gradient agrees with central differences of the sag.
  const double r = 35, R = -22, semi = 8;
  const SurfaceShape s = toroid(R, -0.7, {0, 0, 2e-3, 0, -1e-5});
  for (double x : {0.0, 3.0, -6.5}) {
    for (double y : {0.0, 4.0, -7.0}) {
      const auto g = surfaceSag(r, s, x, y);
      ASSERT_TRUE(g.has_value());
      const double h = 1e-6;
      const double dx = (surfaceSag(r, s, x + h, y)->z - surfaceSag(r, s, x - h, y)->z) / (2 * h);
      const double dy = (surfaceSag(r, s, x, y + h)->z - surfaceSag(r, s, x, y - h)->z) / (2 * h);
      EXPECT_NEAR(g->dzdx, dx, 1e-8) << x << " " << y;
      EXPECT_NEAR(g->dzdy, dy, 1e-8) << x << " " << y;
    }
  }
  // Vertex curvatures: y from the curve (c + 2 a_2), x from the radius of rotation.
  EXPECT_DOUBLE_EQ(vertexCurvatureY(r, s), 1 / r + 4e-3);
  EXPECT_DOUBLE_EQ(vertexCurvatureX(r, s), 1 / R);
  const ShapeIntersector isect(r, s, semi);
  std::mt19937_64 rng(13);
  std::uniform_real_distribution<double> u(-1, 1);
  int hits = 0;
  for (int k = 0; k < 2000; ++k) {
    const Vec3 o{semi * u(rng), semi * u(rng), -30};
    const Vec3 d = normalize(Vec3{0.12 * u(rng), 0.12 * u(rng), 1});
    const auto h = isect.intersect(o, d, 0);
    ASSERT_TRUE(h.has_value()) << k;
    const Vec3 p = o + d * h->t;
    if (p.x * p.x + p.y * p.y > semi * semi) continue;
    const auto g = surfaceSag(r, s, p.x, p.y);
    ASSERT_TRUE(g.has_value());
    EXPECT_NEAR(p.z, g->z, 1e-10);
    EXPECT_NEAR(dot(normalize(Vec3{g->dzdx, g->dzdy, -1}), h->normal), 1.0, 1e-12);
    ++hits;
  }
  EXPECT_GT(hits, 1200);
}

TEST(Toroidal, NewtonHitsAreTheFirstCrossingAlongTheRay) {
  // Toroids and aspheres on a conic base are solved by Newton's method from their vertex
  // quadric's hit, accepted where a bound on the sag's curvature proves that g = z - sag keeps
  // its sign from the slab's entry to the root (else after g's sign at points along the ray).
  // Steep and grazing rays, many of which cross the surface twice or more within its slab, must
  // still stop at the first crossing: here the first sign change of g in a scan of 20,000 steps
  // along the ray, bisected (rays whose scan leaves the disc of 1.2 semi-apertures before a
  // crossing, where the intersector continues the surface flat, are left out; g exactly 0 at
  // a step counts as the side it was on). The side-by-side
  // solve (intersectLanes) gives the same hits, bit for bit, where it decides.
  struct Case {
    double r;
    SurfaceShape shape;
  };
  SurfaceShape asphere;
  asphere.conic = -2.5;
  asphere.poly = {0, 0, 0, 0, 3e-5, 0, -2e-7};
  const double semi = 8;
  int multiple = 0, compared = 0, lanes_compared = 0;
  for (const Case& c : {Case{20, toroid(-12)}, Case{-25, toroid(15, -0.5, {0, 0, 0, 0, 2e-5})},
                        Case{14, asphere}}) {
    const ShapeIntersector isect(c.r, c.shape, semi);
    std::mt19937_64 rng(17);
    std::uniform_real_distribution<double> u(-1, 1);
    auto g = [&](const Vec3& o, const Vec3& d, double t) -> std::optional<double> {
      const Vec3 p = o + d * t;
      if (p.x * p.x + p.y * p.y > 1.44 * semi * semi) return std::nullopt;
      const auto s = surfaceSag(c.r, c.shape, p.x, p.y);
      if (!s) return std::nullopt;
      return p.z - s->z;
    };
    constexpr int kLanes = ShapeIntersector::kLanes;
    double ox[kLanes], oy[kLanes], oz[kLanes], dx[kLanes], dy[kLanes], dz[kLanes];
    std::optional<ShapeIntersector::Hit> single[kLanes];
    int m = 0;
    for (int k = 0; k < 3000; ++k) {
      Vec3 o, d;
      if (k % 2 == 0) {
        // From in front of the surface, slopes up to 0.8 or 3 (72 degrees off the axis).
        const double slope = k % 4 == 0 ? 3.0 : 0.8;
        o = {1.2 * semi * u(rng), 1.2 * semi * u(rng), -10};
        d = normalize(Vec3{slope * u(rng), slope * u(rng), 1});
      } else {
        // Grazing: from the rim of the disc at a height within the sags' range, across the
        // surface nearly parallel to it, forward or backward.
        const double psi = std::numbers::pi * u(rng), turn = 0.5 * u(rng);
        o = {-1.15 * semi * std::cos(psi), -1.15 * semi * std::sin(psi), 3 * u(rng)};
        d = normalize(Vec3{std::cos(psi + turn), std::sin(psi + turn), 0.4 * u(rng)});
      }
      const auto hit = isect.intersect(o, d, 0);
      // The scan: 20,000 steps of at most 4 um, until the ray leaves the disc or z leaves
      // [-10, 10] (the surfaces' sags lie within +-6 over the disc).
      const double t0 = 0, t1 = std::min(80.0, 20 / std::abs(d.z));
      constexpr int kSteps = 20000;
      std::optional<double> ga = g(o, d, t0);
      double a = t0, root = -1;
      int changes = 0;
      bool left = !ga;
      for (int i = 1; i <= kSteps && !left; ++i) {
        const double b = t0 + (t1 - t0) * i / kSteps;
        const std::optional<double> gb = g(o, d, b);
        if (!gb) {
          left = root < 0;
          break;
        }
        if ((*gb < 0) != (*ga < 0)) {
          ++changes;
          if (root < 0) {
            double lo = a, hi = b, glo = *ga;
            for (int it = 0; it < 100; ++it) {
              const double mid = 0.5 * (lo + hi), gm = *g(o, d, mid);
              if ((gm < 0) == (glo < 0))
                lo = mid, glo = gm;
              else
                hi = mid;
            }
            root = 0.5 * (lo + hi);
          }
        }
        a = b, ga = gb;
      }
      if (!left && root >= 0) {
        ASSERT_TRUE(hit.has_value()) << k;
        EXPECT_NEAR(hit->t, root, 1e-9) << k << " r " << c.r;
        ++compared;
        multiple += changes > 1;
      }
      ox[m] = o.x, oy[m] = o.y, oz[m] = o.z, dx[m] = d.x, dy[m] = d.y, dz[m] = d.z;
      single[m++] = hit;
      if (m == kLanes) {
        double t[kLanes], nx[kLanes], ny[kLanes], nz[kLanes], status[kLanes];
        isect.intersectLanes(m, ox, oy, oz, dx, dy, dz, 0, t, nx, ny, nz, status);
        for (int j = 0; j < m; ++j) {
          if (status[j] == 1) {
            EXPECT_FALSE(single[j].has_value());
          }
          if (status[j] != 0) continue;
          ASSERT_TRUE(single[j].has_value());
          EXPECT_EQ(t[j], single[j]->t);
          EXPECT_EQ(nx[j], single[j]->normal.x);
          EXPECT_EQ(nz[j], single[j]->normal.z);
          ++lanes_compared;
        }
        m = 0;
      }
    }
  }
  RecordProperty("compared", compared);
  RecordProperty("multiple", multiple);
  RecordProperty("lanes_compared", lanes_compared);
  EXPECT_GT(compared, 3000);
  EXPECT_GT(multiple, 100);  // rays that cross more than once before leaving the slab
  EXPECT_GT(lanes_compared, 3000);
}

TEST(Toroidal, ParaxialXAndYOfASingletAgreeWithTheThickLensFormula) {
  // (c) A .zmx singlet whose front is toroidal (y: radius 40 mm plus a y^2 term 1e-3; x: radius
  // of rotation 25 mm), back sphere -60 mm, 6 mm of n = 1.6: EFL and BFL of each section from the
  // thick-lens formulas, written here; then real rays near the axis in x and in y cross the axis
  // at the back focal points.
  const std::string text =
      "MODE SEQ\nUNIT MM\nSURF 0\n  CURV 0\n  DISZ INFINITY\nSURF 1\n  STOP\n  CURV 0\n"
      "  DISZ 2\n  DIAM 8\nSURF 2\n  TYPE TOROIDAL\n  CURV 0.025\n  PARM 1 25\n  PARM 2 1e-3\n"
      "  DISZ 6\n  GLAS ___BLANK 1 0 1.6 50 0 0 0 0 0 0\n  DIAM 8\nSURF 3\n  CURV "
      "-0.0166666666666666667\n  DISZ 30\n  DIAM 8\nSURF 4\n  CURV 0\n  DISZ 0\n  DIAM 20\n";
  const LensPrescription p = parseZmx(text, "t.zmx");
  ASSERT_TRUE(p.surfaces[1].shape.isToroidal());
  const LensSystem lens(p);
  const AnamorphicData ad = anamorphicData(lens);
  ASSERT_TRUE(ad.x && ad.y);
  const double n = 1.6, t = 6;
  auto thick = [&](double c1, double c2) {
    const double p1 = (n - 1) * c1, p2 = (1 - n) * c2;
    const double phi = p1 + p2 - p1 * p2 * t / n;
    return std::pair{1 / phi, (1 - p1 * t / n) / phi};  // EFL, BFL
  };
  const auto [efl_y, bfl_y] = thick(1 / 40.0 + 2e-3, -1 / 60.0);
  const auto [efl_x, bfl_x] = thick(1 / 25.0, -1 / 60.0);
  EXPECT_NEAR(ad.y->effective_focal_length_mm / efl_y, 1, 1e-6);
  EXPECT_NEAR(ad.y->back_focal_length_mm / bfl_y, 1, 1e-6);
  EXPECT_NEAR(ad.x->effective_focal_length_mm / efl_x, 1, 1e-6);
  EXPECT_NEAR(ad.x->back_focal_length_mm / bfl_x, 1, 1e-6);
  EXPECT_NEAR(ad.squeeze / (efl_y / efl_x), 1, 1e-6);
  // Real rays 0.01 mm off the axis (aberrations ~h^2: < 1e-5 mm here).
  const double z_back = 8;  // the back vertex
  for (int axis = 0; axis < 2; ++axis) {
    const double h = 0.01;
    const Ray r{{axis == 0 ? h : 0.0, axis == 1 ? h : 0.0, -5}, {0, 0, 1}};
    const auto out = traceOut(lens, r);
    ASSERT_TRUE(out.has_value());
    const double o = axis == 0 ? out->origin.x : out->origin.y;
    const double dd = axis == 0 ? out->direction.x : out->direction.y;
    const double z_cross = out->origin.z - o / dd * out->direction.z;
    EXPECT_NEAR(z_cross - z_back, axis == 0 ? bfl_x : bfl_y, 1e-4) << "axis " << axis;
  }
}

namespace {

// The sample lens's surfaces as the file gives them, read with a tokenizer written here (only
// CURV, PARM 1 and DISZ of each SURF block), for a y-nu trace independent of the reader.
struct RawSurf {
  double curv = 0, rot = 0, disz = 0;
  bool toroidal = false;
};
std::vector<RawSurf> rawSurfaces(const std::string& path) {
  std::ifstream in(path);
  std::vector<RawSurf> out;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream ss(line);
    std::string key;
    ss >> key;
    if (key == "SURF") out.push_back({});
    if (out.empty()) continue;
    std::string v;
    if (key == "CURV") ss >> out.back().curv;
    if (key == "TYPE") ss >> v, out.back().toroidal = v == "TOROIDAL";
    if (key == "PARM") {
      int i = 0;
      double x = 0;
      ss >> i >> x;
      if (i == 1) out.back().rot = x;
    }
    if (key == "DISZ") {
      ss >> v;
      out.back().disz = v == "INFINITY" ? 0.0 : std::stod(v);
    }
  }
  return out;
}

}  // namespace

TEST(Toroidal, SampleAnamorphicFirstOrderDataAgreeWithAYNuTrace) {
  // lenses/toroidal-anamorphic.50mm.zmx: a y-nu trace of the file's curvatures (x: 1/R of the
  // toroids) with the glasses' indices at the primary wavelength; both sections focus on the
  // same plane (the front attachment is afocal in both).
  const std::string path = lensim::test::lensPath("toroidal-anamorphic.50mm.zmx");
  const LensSystem lens(readLensFile(path));
  const AnamorphicData ad = anamorphicData(lens);
  ASSERT_TRUE(ad.x && ad.y);
  const std::vector<RawSurf> raw = rawSurfaces(path);
  ASSERT_EQ(raw.size(), 17u);  // object, 15 surfaces, image
  for (int section = 0; section < 2; ++section) {
    double y = 1, nu = 0, n = 1;
    for (size_t k = 1; k + 1 < raw.size(); ++k) {
      const double c =
          section == 0 && raw[k].toroidal ? (raw[k].rot != 0 ? 1 / raw[k].rot : 0.0) : raw[k].curv;
      // The surfaces map one to one (the stop is a plane of its own in this file).
      const double n2 = lens.interfaces()[k - 1].ior_after;
      nu = nu - y * c * (n2 - n);
      n = n2;
      if (k + 2 < raw.size()) y += nu / n * raw[k].disz;
    }
    const double efl = -1 / nu, bfl = -y / nu;
    const ParaxialData& pd = section == 0 ? *ad.x : *ad.y;
    EXPECT_NEAR(pd.effective_focal_length_mm / efl, 1, 1e-9) << "section " << section;
    EXPECT_NEAR(pd.back_focal_length_mm / bfl, 1, 1e-9) << "section " << section;
  }
  EXPECT_NEAR(ad.x->back_focal_length_mm, ad.y->back_focal_length_mm, 1e-3);
  EXPECT_GT(ad.squeeze, 2.0);
  EXPECT_LT(ad.squeeze, 2.2);
}

TEST(Toroidal, ZmxRoundTripsThroughLensimJsonAndBadParametersAreLocated) {
  // (e) The sample .zmx converts to lensim JSON and back with the same toroids and first-order
  // data; a malformed TOROIDAL is a located error at its line.
  const std::string path = lensim::test::lensPath("toroidal-anamorphic.50mm.zmx");
  const LensPrescription a = readLensFile(path);
  const auto tmp = std::filesystem::temp_directory_path() / "lensim_toroidal_roundtrip.json";
  { std::ofstream(tmp) << writeLensJson(a); }
  const LensPrescription b = readLensFile(tmp.string());
  std::filesystem::remove(tmp);
  ASSERT_EQ(a.surfaces.size(), b.surfaces.size());
  int toroids = 0;
  for (size_t i = 0; i < a.surfaces.size(); ++i) {
    EXPECT_EQ(a.surfaces[i].radius_mm, b.surfaces[i].radius_mm);
    EXPECT_EQ(a.surfaces[i].shape.rotation_radius_mm, b.surfaces[i].shape.rotation_radius_mm);
    EXPECT_EQ(a.surfaces[i].shape.poly, b.surfaces[i].shape.poly);
    toroids += b.surfaces[i].shape.isToroidal();
  }
  EXPECT_EQ(toroids, 4);
  const AnamorphicData da = anamorphicData(LensSystem(a)), db = anamorphicData(LensSystem(b));
  EXPECT_DOUBLE_EQ(da.x->effective_focal_length_mm, db.x->effective_focal_length_mm);
  EXPECT_DOUBLE_EQ(da.y->effective_focal_length_mm, db.y->effective_focal_length_mm);
  // .dat cannot hold it: the error names the surface and "toroidal".
  try {
    writeLensDat(a);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("surface 0 cannot be written to .dat: it is toroidal"),
              std::string::npos)
        << e.what();
  }

  auto errorOf = [](const std::string& text) {
    try {
      parseZmx(text, "x.zmx");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string head =
      "MODE SEQ\nSURF 0\n  DISZ INFINITY\nSURF 1\n  STOP\n  DISZ 2\n  DIAM 8\nSURF 2\n"
      "  TYPE TOROIDAL\n  CURV 0.025\n";  // lines 1-10
  const std::string tail =
      "  DISZ 6\n  GLAS ___BLANK 1 0 1.6 50 0 0 0 0 0 0\n  DIAM 8\nSURF 3\n  CURV -0.02\n"
      "  DISZ 30\n  DIAM 8\nSURF 4\n  DISZ 0\n  DIAM 20\n";
  EXPECT_EQ(errorOf(head + "  PARM 1 25\n" + tail), "no error");
  std::string e = errorOf(head + "  PARM 1 abc\n" + tail);
  EXPECT_NE(e.find("x.zmx:11:10: error: expected a number for the parameter value, found 'abc'"),
            std::string::npos)
      << e;
  e = errorOf(head + "  PARM 1 25\n  PARM 13 4\n" + tail);
  EXPECT_NE(e.find("x.zmx:12:11: error: surface 2: TOROIDAL PARM 13 = 4: Zernike sag terms"),
            std::string::npos)
      << e;
  e = errorOf(head + "  PARM 1 25\n  PARM 10 1\n" + tail);
  EXPECT_NE(e.find("x.zmx:12:11: error: surface 2: TOROIDAL PARM 10 = 1"), std::string::npos) << e;
  // A radius of rotation of 5 mm closes the toroid inside the 8 mm semi-diameter.
  e = errorOf(head + "  PARM 1 5\n" + tail);
  EXPECT_NE(e.find("x.zmx:11:10: error: surface 2: radius of rotation 5: the toroid closes"),
            std::string::npos)
      << e;
  e = errorOf(head + "  PARM 1 25\n  XDAT 3 0.5 0 0 0\n" + tail);
  EXPECT_NE(e.find("x.zmx:12:10: error: surface 2: TOROIDAL extra data"), std::string::npos) << e;
}
