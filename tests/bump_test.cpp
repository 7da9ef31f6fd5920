// Bump mapping from "displacement" (pbrt-v4's BumpMap) against closed forms: a displacement
// linear in u tilts the normal by atan(slope); a constant displacement of a sphere leaves its
// normal unchanged (dp/du + d dn/du stays parallel to dp/du); the differential geometry the
// renderer computes (dp/dv, dn/du) is that of the surface; a 60-degree tilt halves the light a
// diffuse plane reflects from a lamp straight above it.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "lensim/render/materials/materials.h"
#include "lensim/render/shapes/accel.h"
#include "lensim/render/textures/textures.h"
#include "render_test_util.h"

namespace lensim::render {

using namespace lensim::sampling;
namespace {

TEST(Bump, LinearDisplacementTiltsTheNormal) {
  for (double a : {0.25, 1.0, std::sqrt(3.0)}) {
    const std::string text =
        "WorldBegin\nTexture \"d\" \"float\" \"bilerp\" \"float v00\" 0 "
        "\"float v10\" " +
        std::to_string(a) + " \"float v01\" 0 \"float v11\" " + std::to_string(a) +
        "\nMaterial \"diffuse\" \"texture displacement\" \"d\"\n";
    scene::Scene s = testutil::buildText(text);
    ASSERT_EQ(testutil::errorsOf(s), "");
    EXPECT_TRUE(s.diagnostics.empty()) << s.diagnostics[0].message;
    Textures tx(s);
    Materials mats(s, tx);
    ASSERT_TRUE(mats.hasBump(0));
    TextureEvalContext ctx;
    ctx.p = {0.3, 0.6, 0};
    ctx.uv = {0.3, 0.6};
    const Vec3 n = mats.bumpedNormal(0, ctx, {0, 0, 1}, {1, 0, 0}, {0, 1, 0}, {0, 0, 0}, {0, 0, 0});
    const Vec3 expect = normalize(Vec3{-a, 0, 1});
    EXPECT_NEAR(n.x, expect.x, 1e-6) << a;
    EXPECT_NEAR(n.y, expect.y, 1e-6) << a;
    EXPECT_NEAR(n.z, expect.z, 1e-6) << a;
  }
}

TEST(Bump, SurfaceDerivativesAndConstantDisplacementOfASphere) {
  scene::Scene s = testutil::buildText(R"(WorldBegin
Texture "c" "float" "constant" "float value" 0.3
Material "diffuse" "texture displacement" "c"
AttributeBegin
  Translate 0 0 5
  Shape "sphere" "float radius" 2
AttributeEnd
Shape "trianglemesh" "point3 P" [-1 -1 -3  1 -1 -3  0 1 -3] "integer indices" [0 1 2]
      "point2 uv" [0 0  2 0  1 4]
)");
  ASSERT_EQ(testutil::errorsOf(s), "");
  Accel accel(s);
  Textures tx(s);
  Materials mats(s, tx);
  for (const Vec3& d : {normalize(Vec3{0.1, 0.2, 1}), normalize(Vec3{-0.3, 0.1, 1})}) {
    auto h = accel.intersect({{0, 0, 0}, d, INFINITY});
    ASSERT_TRUE(h);
    // dp/du and dp/dv span the tangent plane; dn/du = dp/du / r for a sphere.
    EXPECT_NEAR(dot(h->dpdv, h->ng), 0, 1e-9 * length(h->dpdv));
    EXPECT_NEAR(std::abs(dot(normalize(cross(h->dpdu, h->dpdv)), h->ng)), 1, 1e-9);
    EXPECT_NEAR(length(h->dndu - h->dpdu / 2.0), 0, 1e-9 * length(h->dpdu));
    const TextureEvalContext ctx{h->p, h->uv, h->ns};
    const Vec3 n =
        mats.bumpedNormal(s.shapes[0].material, ctx, h->ns, h->dpdu, h->dpdv, h->dndu, h->dndv);
    EXPECT_NEAR(length(n - h->ns), 0, 1e-6);
  }
  // The triangle: p = P0 + (1, 0, 0) u + (0, 0.5, 0) v reproduces its three vertices and (u, v).
  auto h = accel.intersect({{0, -0.2, 0}, {0, 0, -1}, INFINITY});
  ASSERT_TRUE(h);
  EXPECT_NEAR(length(h->dpdu - Vec3{1, 0, 0}), 0, 1e-12);
  EXPECT_NEAR(length(h->dpdv - Vec3{0, 0.5, 0}), 0, 1e-12);
}

TEST(Bump, TiltedDiffusePlaneReflectsCosineOfTheTilt) {
  // Seen from above by an orthographic camera, lit by a point light straight above: a slope of
  // sqrt(3) (60 degrees) halves what the plane reflects.
  auto render = [](bool bump) {
    std::string text = R"(LookAt 0 0 5  0 0 0  0 1 0
Camera "orthographic" "float screenwindow" [-0.2 0.2 -0.2 0.2]
Film "rgb" "integer xresolution" 8 "integer yresolution" 8 "string filename" "b.exr"
Sampler "independent" "integer pixelsamples" 16
Integrator "path" "integer maxdepth" 1
WorldBegin
LightSource "point" "point3 from" [0 0 1000] "rgb I" [1000000 1000000 1000000]
Texture "d" "float" "bilerp" "float v00" 0 "float v10" 1.7320508 "float v01" 0 "float v11" 1.7320508
)";
    text +=
        bump ? "Material \"diffuse\" \"texture displacement\" \"d\"\n" : "Material \"diffuse\"\n";
    text += R"(Shape "trianglemesh" "point3 P" [-1 -1 0  1 -1 0  1 1 0  -1 1 0]
      "integer indices" [0 1 2  0 2 3] "point2 uv" [-1 -1  1 -1  1 1  -1 1]
)";
    const io::Image im = testutil::renderText(text).image;
    return testutil::regionMean(im, 1, 0, 8, 0, 8);
  };
  const double flat = render(false), tilted = render(true);
  EXPECT_GT(flat, 0.1);
  EXPECT_NEAR(tilted / flat, 0.5, 0.01);
}

}  // namespace
}  // namespace lensim::render
