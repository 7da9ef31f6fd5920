// Object instancing (ObjectBegin/ObjectInstance as Embree instances, issue 29): hits on instances
// against closed forms of their transforms (translation, rotation, non-uniform scale, with the
// normal carried by the inverse transpose), and a render of an instanced scene against the same
// shapes written out flat with the same transforms.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "lensim/render/shapes/accel.h"
#include "render_test_util.h"

namespace lensim::render {

using namespace lensim::sampling;
namespace {

// A unit square (two triangles) at z = 0 and a ball of radius 0.25 at (0.5, 0.5, 0), each an
// object, placed by instances whose transforms the tests below invert by hand.
constexpr const char* kObjects = R"(
ObjectBegin "tile"
Shape "trianglemesh" "point3 P" [0 0 0  1 0 0  1 1 0  0 1 0] "integer indices" [0 1 2  0 2 3]
ObjectEnd
ObjectBegin "ball"
Translate 0.5 0.5 0
Shape "sphere" "float radius" 0.25
ObjectEnd
)";

void expectNear(const Vec3& a, const Vec3& b, double tol, const char* what) {
  EXPECT_NEAR(a.x, b.x, tol) << what;
  EXPECT_NEAR(a.y, b.y, tol) << what;
  EXPECT_NEAR(a.z, b.z, tol) << what;
}

TEST(Instancing, HitsFollowTheInstanceTransforms) {
  const std::string text = std::string("WorldBegin\n") + kObjects + R"(
AttributeBegin
Translate 3 0 0
Rotate 90 0 0 1
Scale 2 2 2
ObjectInstance "tile"
AttributeEnd
AttributeBegin
Translate 0 0 2
Rotate 90 1 0 0
ObjectInstance "tile"
AttributeEnd
AttributeBegin
Translate -5 0 0
Scale 1 1 3
ObjectInstance "ball"
AttributeEnd
)";
  const scene::Scene s = testutil::buildText(text);
  ASSERT_EQ(testutil::errorsOf(s), "");
  ASSERT_EQ(s.instances.size(), 3u);
  const Accel accel(s);

  // Instance 0: p -> (3 - 2 y, 2 x, 0); object (0.7, 0.4) is world (2.2, 1.4, 0).
  {
    const auto h = accel.intersect({{2.2, 1.4, 5}, {0, 0, -1}, INFINITY});
    ASSERT_TRUE(h);
    EXPECT_EQ(h->instance, 0);
    EXPECT_NEAR(h->t, 5, 1e-5);
    expectNear(h->p, {2.2, 1.4, 0}, 1e-5, "p");
    EXPECT_NEAR(std::abs(h->ng.z), 1, 1e-6);
    // Just outside its image (object y = 1.05 would be world x = 0.9): the ray misses.
    EXPECT_FALSE(accel.intersect({{0.9, 1.4, 5}, {0, 0, -1}, INFINITY}));
    // World (2.5, 1.9) is object (0.95, 0.25), inside only because of the scale by 2.
    EXPECT_TRUE(accel.intersect({{2.5, 1.9, 5}, {0, 0, -1}, INFINITY}));
  }
  // Instance 1: Rotate 90 about x takes (x, y, 0) to (x, 0, y), then up by 2: the square stands
  // in the plane y = 0 over z in [2, 3], its normal along y.
  {
    const auto h = accel.intersect({{0.3, -5, 2.6}, {0, 1, 0}, INFINITY});
    ASSERT_TRUE(h);
    EXPECT_EQ(h->instance, 1);
    EXPECT_NEAR(h->t, 5, 1e-5);
    expectNear(h->p, {0.3, 0, 2.6}, 1e-5, "p");
    EXPECT_NEAR(std::abs(h->ng.y), 1, 1e-6);
    EXPECT_FALSE(accel.intersect({{0.3, -5, 3.2}, {0, 1, 0}, INFINITY}));
  }
  // Instance 2: the ball scaled by 3 along z is an ellipsoid centred at (-4.5, 0.5, 0) with
  // semi-axes (0.25, 0.25, 0.75); its normal is the gradient (x / a^2, y / b^2, z / c^2).
  // Embree hands the sphere the ray in instance space in single precision, so positions agree
  // to ~1e-6 and the normal, which the scale steepens threefold, to ~1e-4.
  {
    const auto top = accel.intersect({{-4.5, 0.5, 5}, {0, 0, -1}, INFINITY});
    ASSERT_TRUE(top);
    EXPECT_EQ(top->instance, 2);
    EXPECT_NEAR(top->t, 5 - 0.75, 1e-5);
    expectNear(top->ng, {0, 0, 1}, 1e-4, "top normal");
    const double z = 0.375, a = 0.25, c = 0.75;
    const double x = -a * std::sqrt(1 - (z / c) * (z / c));  // relative to the centre
    const auto side = accel.intersect({{-10, 0.5, z}, {1, 0, 0}, INFINITY});
    ASSERT_TRUE(side);
    EXPECT_EQ(side->instance, 2);
    expectNear(side->p, {-4.5 + x, 0.5, z}, 1e-5, "side p");
    expectNear(side->ng, normalize(Vec3{x / (a * a), 0, z / (c * c)}), 1e-4, "side normal");
    EXPECT_TRUE(accel.occluded({{-10, 0.5, z}, {1, 0, 0}, 6}));
    EXPECT_FALSE(accel.occluded({{-10, 0.5, z}, {1, 0, 0}, 5}));
  }
}

// The instanced scene and the same shapes written out with the same transforms.
std::string sceneText(bool instanced, double shift = 0) {
  std::string s = R"(LookAt 0 -4 5  0 0 0  0 0 1
Camera "perspective" "float fov" 60
Film "rgb" "integer xresolution" 48 "integer yresolution" 32 "string filename" "i.exr"
Sampler "independent" "integer pixelsamples" 8
Integrator "path" "integer maxdepth" 3
WorldBegin
LightSource "distant" "point3 from" [1 -1 4] "point3 to" [0 0 0] "blackbody L" 5500
LightSource "infinite" "rgb L" [0.2 0.2 0.3]
Material "diffuse" "rgb reflectance" [0.5 0.5 0.5]
Shape "bilinearmesh" "point3 P" [-9 -9 -0.5  9 -9 -0.5  -9 9 -0.5  9 9 -0.5]
)";
  const std::string tile =
      "Material \"diffuse\" \"rgb reflectance\" [0.8 0.2 0.1]\n"
      "Shape \"trianglemesh\" \"point3 P\" [0 0 0  1 0 0  1 1 0  0 1 0] \"integer indices\" [0 1 "
      "2  0 2 3]\n";
  const std::string ball =
      "Material \"conductor\"\nTranslate 0.5 0.5 0\nShape \"sphere\" \"float radius\" 0.25\n";
  const char* placements[] = {"Translate -2 0 0\nRotate 30 0 0 1\nScale 1.5 1 1\n",
                              "Translate 0.5 -0.5 0.3\nRotate 60 1 1 0\n",
                              "Translate -1 1 0\nScale 1 1 2\n"};
  if (instanced)
    s += "ObjectBegin \"tile\"\n" + tile + "ObjectEnd\nObjectBegin \"ball\"\n" + ball +
         "ObjectEnd\n";
  for (int k = 0; k < 3; ++k) {
    s += "AttributeBegin\nTranslate " + std::to_string(k == 1 ? shift : 0) + " 0 0\n";
    s += placements[k];
    const std::string& what = k == 2 ? ball : tile;
    s += instanced ? std::string("ObjectInstance \"") + (k == 2 ? "ball" : "tile") + "\"\n" : what;
    s += "AttributeEnd\n";
  }
  return s;
}

TEST(Instancing, RendersAsTheFlattenedScene) {
  RenderOptions o;
  o.seed = 7;
  o.threads = 2;
  const io::Image inst = testutil::renderText(sceneText(true), o).image;
  const io::Image flat = testutil::renderText(sceneText(false), o).image;
  const io::Image moved = testutil::renderText(sceneText(false, 0.3), o).image;
  ASSERT_EQ(inst.pixels.size(), flat.pixels.size());
  // Same random numbers, same geometry up to float rounding (Embree transforms the ray into the
  // instance instead of the vertices into the world): equal but for rare samples that graze an
  // edge (on this machine they come out bit-identical).
  double sum = 0, diff = 0, moved_diff = 0;
  size_t off = 0;
  for (size_t k = 0; k < inst.pixels.size(); ++k) {
    sum += std::abs(flat.pixels[k]);
    const double d = std::abs(double(inst.pixels[k]) - flat.pixels[k]);
    diff += d;
    moved_diff += std::abs(double(moved.pixels[k]) - flat.pixels[k]);
    if (d > 1e-3 * std::max(1e-3, double(std::abs(flat.pixels[k])))) ++off;
  }
  ASSERT_GT(sum, 0);
  EXPECT_LT(diff / sum, 2e-3);
  EXPECT_LT(double(off) / double(inst.pixels.size()), 0.02) << off << " values differ";
  // The comparison sees a 0.3 shift of one tile.
  EXPECT_GT(moved_diff / sum, 10 * diff / sum + 1e-3);
}

}  // namespace
}  // namespace lensim::render
