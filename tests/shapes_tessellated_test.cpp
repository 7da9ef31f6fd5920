// pbrt's hyperboloid, paraboloid, heightfield and nurbs shapes (tessellated): areas against closed
// forms, vertices on the implicit surfaces, normals equal to the normalised gradients, partial
// shapes (phimax, zmin/zmax), the builder's parameters and errors, and a render whose image mean
// has a closed form (black shapes against a uniform sky, seen along their axis).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>

#include "lensim/scene/shapes_tessellated.h"
#include "render_test_util.h"

namespace lensim::scene {
namespace {

constexpr double kPi = std::numbers::pi;

double meshArea(const Mesh& m) {
  double a = 0;
  for (size_t f = 0; f + 2 < m.indices.size(); f += 3) {
    const Vec3 p0(m.positions[size_t(m.indices[f])]), p1(m.positions[size_t(m.indices[f + 1])]),
        p2(m.positions[size_t(m.indices[f + 2])]);
    a += 0.5 * length(cross(p1 - p0, p2 - p0));
  }
  return a;
}

/// Every face's geometric normal points the same way as its vertices' shading normals.
void expectFacesAgreeWithNormals(const Mesh& m) {
  int disagree = 0;
  for (size_t f = 0; f + 2 < m.indices.size(); f += 3) {
    const Vec3 p0(m.positions[size_t(m.indices[f])]), p1(m.positions[size_t(m.indices[f + 1])]),
        p2(m.positions[size_t(m.indices[f + 2])]);
    const Vec3 ng = cross(p1 - p0, p2 - p0);
    if (length(ng) < 1e-12) continue;  // degenerate triangle at an apex
    Vec3 ns{0, 0, 0};
    for (int k = 0; k < 3; ++k) ns += Vec3(m.normals[size_t(m.indices[f + size_t(k)])]);
    if (dot(ng, ns) <= 0) ++disagree;
  }
  EXPECT_EQ(disagree, 0);
}

TEST(Hyperboloid, AreaMatchesClosedFormsOfCylinderAndCone) {
  // A segment parallel to the axis sweeps a cylinder (2 pi r h); through the axis, a cone
  // (pi r l with slant l).
  EXPECT_NEAR(hyperboloidArea({1, 0, -1}, {1, 0, 1}, 360), 4 * kPi, 1e-12);
  EXPECT_NEAR(hyperboloidArea({0, 0, 0}, {1, 0, 1}, 360), kPi * std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(hyperboloidArea({0, 0, 0}, {1, 1, 1}, 90), kPi * std::sqrt(2.0) * std::sqrt(3.0) / 4,
              1e-12);
  // A flat annulus (p1.z == p2.z, radial segment): pi (r2^2 - r1^2).
  EXPECT_NEAR(hyperboloidArea({0.5, 0, 0}, {2, 0, 0}, 360), kPi * (4 - 0.25), 1e-12);
}

TEST(Hyperboloid, TessellationConvergesToTheClosedFormAreaAndLiesOnTheSurface) {
  // A twisted segment sweeps a hyperboloid of one sheet: x^2 + y^2 = r^2(z) with
  // r^2 = (1 - v)^2 + v^2, v = (z + 1)/2.
  const Vec3 p1{1, 0, -1}, p2{0, 1, 1};
  for (double phimax : {360.0, 135.0}) {
    const Mesh m = tessellateHyperboloid(p1, p2, phimax);
    const double exact = hyperboloidArea(p1, p2, phimax);
    EXPECT_NEAR(meshArea(m) / exact, 1, 2e-4) << phimax;
    // Closed form against a direct midpoint integration of |dp/du x dp/dv|.
    double numeric = 0;
    const int n = 20000;
    for (int i = 0; i < n; ++i) {
      const double v = (i + 0.5) / n;
      const Vec3 pr = p1 * (1 - v) + p2 * v;
      numeric += length(cross(Vec3{-pr.y, pr.x, 0}, p2 - p1)) / n;
    }
    EXPECT_NEAR(exact, numeric * phimax * kPi / 180, 1e-6);
    double worst_surface = 0, worst_normal = 0, max_phi = 0;
    for (size_t i = 0; i < m.positions.size(); ++i) {
      const Vec3 p(m.positions[i]);
      const double v = (p.z + 1) / 2, r2 = (1 - v) * (1 - v) + v * v;
      worst_surface = std::max(worst_surface, std::abs(p.x * p.x + p.y * p.y - r2));
      // Gradient of x^2 + y^2 - r^2(z): (2x, 2y, -dr^2/dz), dr^2/dz = (4v - 2)/2.
      const Vec3 grad = normalize(Vec3{2 * p.x, 2 * p.y, -(4 * v - 2) / 2});
      worst_normal = std::max(worst_normal, 1 - std::abs(dot(grad, Vec3(m.normals[i]))));
      const Vec3 pr = p1 * (1 - v) + p2 * v;
      double phi = std::atan2(p.y, p.x) - std::atan2(pr.y, pr.x);
      while (phi < -1e-6) phi += 2 * kPi;
      if (phimax < 360) max_phi = std::max(max_phi, phi);
    }
    EXPECT_LT(worst_surface, 1e-6);
    EXPECT_LT(worst_normal, 1e-6);
    if (phimax < 360) {
      EXPECT_NEAR(max_phi, phimax * kPi / 180, 1e-5);
    }
    expectFacesAgreeWithNormals(m);
  }
}

TEST(Paraboloid, AreaMatchesTheTextbookFormula) {
  // Full paraboloid of radius r and height h: pi r / (6 h^2) ((r^2 + 4 h^2)^(3/2) - r^3).
  for (auto [r, h] : {std::pair{1.0, 1.0}, std::pair{2.0, 0.5}}) {
    const double textbook = kPi * r / (6 * h * h) * (std::pow(r * r + 4 * h * h, 1.5) - r * r * r);
    EXPECT_NEAR(paraboloidArea(r, 0, h, 360), textbook, 1e-12 * textbook);
  }
}

TEST(Paraboloid, TessellationIsOnTheSurfaceWithGradientNormalsAndPartialRanges) {
  const double R = 2, zmin = 0.25, zmax = 1.5, phimax = 270;
  const Mesh m = tessellateParaboloid(R, zmin, zmax, phimax);
  EXPECT_NEAR(meshArea(m) / paraboloidArea(R, zmin, zmax, phimax), 1, 2e-4);
  const double k = R * R / zmax;
  double worst_surface = 0, worst_normal = 0, lo = 1e9, hi = -1e9;
  for (size_t i = 0; i < m.positions.size(); ++i) {
    const Vec3 p(m.positions[i]);
    worst_surface = std::max(worst_surface, std::abs(p.x * p.x + p.y * p.y - k * p.z));
    const Vec3 grad = normalize(Vec3{2 * p.x, 2 * p.y, -k});
    worst_normal = std::max(worst_normal, 1 - dot(grad, Vec3(m.normals[i])));
    lo = std::min(lo, double(p.z));
    hi = std::max(hi, double(p.z));
  }
  EXPECT_LT(worst_surface, 1e-5);
  EXPECT_LT(worst_normal, 1e-6);
  EXPECT_NEAR(lo, zmin, 1e-6);
  EXPECT_NEAR(hi, zmax, 1e-6);
  expectFacesAgreeWithNormals(m);
  // The chord error: the middle of every triangle lies within 1e-3 of the surface (relative).
  double worst_mid = 0;
  for (size_t f = 0; f + 2 < m.indices.size(); f += 3) {
    Vec3 c{0, 0, 0};
    for (int j = 0; j < 3; ++j) c += Vec3(m.positions[size_t(m.indices[f + size_t(j)])]) / 3.0;
    const double r = std::sqrt(c.x * c.x + c.y * c.y);
    worst_mid = std::max(worst_mid, std::abs(r - std::sqrt(k * c.z)));
  }
  EXPECT_LT(worst_mid / R, 1e-3);
}

TEST(Heightfield, VerticesAreasAndUvFollowPbrt) {
  // The plane z = x + 2y sampled on 5 x 4 heights: area sqrt(1 + 1 + 4) over the unit square.
  std::vector<double> pz;
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 5; ++i) pz.push_back(i / 4.0 + 2 * j / 3.0);
  const Mesh m = heightfieldMesh(5, 4, pz);
  EXPECT_EQ(m.positions.size(), 20u);
  EXPECT_EQ(m.faceCount(), 2u * 4 * 3);
  EXPECT_NEAR(meshArea(m), std::sqrt(6.0), 1e-6);
  EXPECT_FLOAT_EQ(m.positions[7].x, 0.5f);
  EXPECT_FLOAT_EQ(m.positions[7].y, 1.0f / 3);
  EXPECT_FLOAT_EQ(m.uvs[7][0], 0.5f);
  // Faces face +z (pbrt's winding).
  const Vec3 p0(m.positions[size_t(m.indices[0])]), p1(m.positions[size_t(m.indices[1])]),
      p2(m.positions[size_t(m.indices[2])]);
  EXPECT_GT(cross(p1 - p0, p2 - p0).z, 0);
}

TEST(Nurbs, RationalQuadraticReproducesACircleExactly) {
  // The quarter circle as a rational quadratic (weights 1, 1/sqrt2, 1) extruded along z by a
  // linear (order 2) v: a quarter cylinder of radius 1 and height 2, area pi.
  NurbsPatch n;
  n.nu = 3;
  n.nv = 2;
  n.uorder = 3;
  n.vorder = 2;
  n.uknots = {0, 0, 0, 1, 1, 1};
  n.vknots = {0, 0, 1, 1};
  const double w = std::sqrt(0.5);
  for (double z : {0.0, 2.0}) {
    n.P.insert(n.P.end(), {Vec3{1, 0, z}, Vec3{1, 1, z}, Vec3{0, 1, z}});
    n.w.insert(n.w.end(), {1, w, 1});
  }
  double worst = 0;
  for (double u = 0; u <= 1.0001; u += 0.05) {
    const NurbsPoint e = evaluateNurbs(n, std::min(u, 1.0), 0.3);
    worst = std::max(worst, std::abs(std::hypot(e.p.x, e.p.y) - 1));
    EXPECT_NEAR(e.p.z, 0.6, 1e-12);
    // dp/du is tangent to the circle; dp/dv is the extrusion.
    EXPECT_NEAR(e.dpdu.x * e.p.x + e.dpdu.y * e.p.y, 0, 1e-9);
    EXPECT_NEAR(length(e.dpdv - Vec3{0, 0, 2}), 0, 1e-9);
  }
  EXPECT_LT(worst, 1e-12);
  // Derivatives against finite differences.
  const NurbsPoint a = evaluateNurbs(n, 0.4, 0.5), b = evaluateNurbs(n, 0.4 + 1e-6, 0.5);
  EXPECT_NEAR(length((b.p - a.p) / 1e-6 - a.dpdu), 0, 1e-4);
  const Mesh m = nurbsMesh(n);
  EXPECT_EQ(m.positions.size(), 900u);
  EXPECT_NEAR(meshArea(m) / kPi, 1, 1e-3);
  // Normals cross(dp/du, dp/dv): on the quarter cylinder they point outward.
  for (size_t i = 0; i < m.positions.size(); i += 37) {
    const Vec3 p(m.positions[i]);
    EXPECT_NEAR(dot(Vec3(m.normals[i]), normalize(Vec3{p.x, p.y, 0})), 1, 1e-5);
  }
  expectFacesAgreeWithNormals(m);
}

TEST(TessellatedShapes, BuilderReadsPbrtParametersWithoutWarnings) {
  const Scene s = testutil::buildText(R"(WorldBegin
Shape "hyperboloid"
Shape "paraboloid" "float radius" 2 "float zmin" 0.5 "float zmax" 1 "float phimax" 180
Shape "heightfield" "integer nu" 2 "integer nv" 3 "float Pz" [0 0 1 1 0 0]
Shape "nurbs" "integer nu" 2 "integer nv" 2 "integer uorder" 2 "integer vorder" 2
  "float uknots" [0 0 1 1] "float vknots" [0 0 1 1] "point3 P" [0 0 0 1 0 0 0 1 0 1 1 0]
Shape "nurbs" "integer nu" 2 "integer nv" 2 "integer uorder" 2 "integer vorder" 2
  "float uknots" [0 0 1 1] "float vknots" [0 0 1 1] "float u1" 0.5
  "float Pw" [0 0 0 1  2 0 0 2  0 1 0 1  2 2 0 2]
)");
  EXPECT_EQ(testutil::errorsOf(s), "");
  for (const Diagnostic& d : s.diagnostics) ADD_FAILURE() << d.str();
  ASSERT_EQ(s.shapes.size(), 5u);
  ASSERT_EQ(s.meshes.size(), 5u);
  for (const Shape& sh : s.shapes) EXPECT_EQ(sh.type, ShapeType::TriangleMesh);
  // pbrt's defaults: hyperboloid p1 (0,0,0) to p2 (1,1,1) is a cone of slant sqrt(3).
  EXPECT_NEAR(meshArea(s.meshes[0]) / (kPi * std::sqrt(2.0) * std::sqrt(3.0)), 1, 1e-3);
  EXPECT_NEAR(meshArea(s.meshes[1]) / paraboloidArea(2, 0.5, 1, 180), 1, 1e-3);
  EXPECT_EQ(s.meshes[2].positions.size(), 6u);
  EXPECT_NEAR(meshArea(s.meshes[3]), 1, 1e-6);
  // Pw is homogeneous (x w, y w, z w, w): the points are the unit square's corners with weights
  // 1 (x = 0) and 2 (x = 1), so x(u) = 2u / (1 + u) and u1 = 0.5 ends at x = 2/3.
  EXPECT_NEAR(meshArea(s.meshes[4]), 2.0 / 3.0, 1e-6);
}

TEST(TessellatedShapes, BadParametersAreErrorsAtTheirLocation) {
  auto err = [](const std::string& shape) {
    try {
      const Scene s = testutil::buildText("WorldBegin\n" + shape + "\n");
      return testutil::errorsOf(s);
    } catch (const Error& e) {
      return std::string(e.what());
    }
  };
  EXPECT_NE(err(R"(Shape "heightfield" "integer nu" 2 "integer nv" 2 "float Pz" [0 0 0])")
                .find("expected nu*nv = 4 heights, got 3"),
            std::string::npos);
  EXPECT_NE(err(R"(Shape "heightfield" "float Pz" [0 0 0 0])").find("nu"), std::string::npos);
  EXPECT_NE(err(R"(Shape "paraboloid" "float phimax" 400)").find("phimax 400"), std::string::npos);
  EXPECT_NE(
      err(R"(Shape "nurbs" "integer nu" 2 "integer nv" 2 "integer uorder" 2 "integer vorder" 2 "float uknots" [0 0 1] "float vknots" [0 0 1 1] "point3 P" [0 0 0 1 0 0 0 1 0 1 1 0])")
          .find("expected 4 knots, got 3"),
      std::string::npos);
}

TEST(TessellatedShapes, BlackShapesAgainstAUniformSkyCoverTheirProjectedArea) {
  // Seen along -z by an orthographic camera, a black shape against a uniform sky darkens the
  // image by its projected area / the screen area: a paraboloid of radius 1 swept by 180 degrees
  // covers a half disk (pi/2), a hyperboloid from (1,0,0) to (1,1,1) the disk of radius sqrt2
  // minus the throat of radius 1 that the sky shows through (pi).
  auto mean = [](const std::string& shape) {
    const std::string text = R"(LookAt 0 0 5  0 0 0  0 1 0
Camera "orthographic" "float screenwindow" [-2 2 -2 2]
Film "rgb" "integer xresolution" 64 "integer yresolution" 64 "string filename" "s.exr"
Sampler "independent" "integer pixelsamples" 16
Integrator "path" "integer maxdepth" 1
WorldBegin
LightSource "infinite" "rgb L" [1 1 1]
Material "diffuse" "rgb reflectance" [0 0 0]
)" + shape + "\n";
    const io::Image im = testutil::renderText(text).image;
    return testutil::regionMean(im, 1, 0, 64, 0, 64);
  };
  const double sky = mean("");
  ASSERT_GT(sky, 0.1);
  EXPECT_NEAR(mean(R"(Shape "paraboloid" "float phimax" 180)") / sky, 1 - (kPi / 2) / 16, 3e-3);
  EXPECT_NEAR(mean(R"(Shape "hyperboloid" "point3 p1" [1 0 0] "point3 p2" [1 1 1])") / sky,
              1 - kPi / 16, 3e-3);
}

}  // namespace
}  // namespace lensim::scene

namespace lensim::scene {
namespace {

TEST(TessellatedShapes, TestSceneLoadsAndRendersWithoutDiagnostics) {
  const Scene s =
      build(parseFile(std::string(LENSIM_SOURCE_DIR) + "/tests/data/shapes/tessellated.pbrt"));
  for (const Diagnostic& d : s.diagnostics) ADD_FAILURE() << d.str();
  ASSERT_EQ(s.shapes.size(), 4u);
  // The nurbs quarter cylinder of radius 1, height 1: area pi/2.
  double a = 0;
  const Mesh& m = s.meshes[size_t(s.shapes[3].mesh)];
  for (size_t f = 0; f + 2 < m.indices.size(); f += 3) {
    const Vec3 p0(m.positions[size_t(m.indices[f])]), p1(m.positions[size_t(m.indices[f + 1])]),
        p2(m.positions[size_t(m.indices[f + 2])]);
    a += 0.5 * length(cross(p1 - p0, p2 - p0));
  }
  EXPECT_NEAR(a / (kPi / 2), 1, 1e-3);
  const render::RenderResult r = render::render(s, {});
  const double mean = testutil::regionMean(r.image, 1, 0, 32, 0, 24);
  EXPECT_TRUE(std::isfinite(mean));
  EXPECT_GT(mean, 0.05);
}

}  // namespace
}  // namespace lensim::scene
