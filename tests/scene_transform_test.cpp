// Transform algebra: the matrices of the transform directives against hand-computed ones.
#include <gtest/gtest.h>

#include <cmath>

#include "lensim/scene/description.h"
#include "lensim/util/transform.h"
#include "scene_test_util.h"

using namespace lensim;
using namespace lensim::scene;

namespace {

void expectMatrix(const Transform& t, const Transform::Matrix& m, double tol = 1e-12) {
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) EXPECT_NEAR(t(i, j), m[i][j], tol) << "at " << i << "," << j;
}

void expectVec(const Vec3& a, const Vec3& b, double tol = 1e-12) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.y, b.y, tol);
  EXPECT_NEAR(a.z, b.z, tol);
}

}  // namespace

TEST(Transform, RotateAboutCoordinateAxes) {
  // Rotate 90 about z: x → y, y → -x.
  expectMatrix(Transform::rotate(90, {0, 0, 1}),
               {{{0, -1, 0, 0}, {1, 0, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}}});
  // Rotate 90 about x: y → z.
  expectMatrix(Transform::rotate(90, {1, 0, 0}),
               {{{1, 0, 0, 0}, {0, 0, -1, 0}, {0, 1, 0, 0}, {0, 0, 0, 1}}});
  // Rotate 30 about y: cos 30 = 0.866.., sin 30 = 0.5.
  double c = std::sqrt(3.0) / 2;
  expectMatrix(Transform::rotate(30, {0, 2, 0}),
               {{{c, 0, 0.5, 0}, {0, 1, 0, 0}, {-0.5, 0, c, 0}, {0, 0, 0, 1}}});
}

TEST(Transform, RotateAboutDiagonalPermutesAxes) {
  // 120 degrees about (1,1,1) maps x → y → z → x.
  Transform r = Transform::rotate(120, {1, 1, 1});
  expectMatrix(r, {{{0, 0, 1, 0}, {1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 0, 1}}});
}

TEST(Transform, LookAtIsCameraFromWorld) {
  // Camera at the origin looking down +x with +y up: camera x (right) is world -z.
  Transform t = Transform::lookAt({0, 0, 0}, {1, 0, 0}, {0, 1, 0});
  expectMatrix(t, {{{0, 0, -1, 0}, {0, 1, 0, 0}, {1, 0, 0, 0}, {0, 0, 0, 1}}});
  // Camera at (1, 2, 3) looking down +z: a pure translation by -eye.
  expectMatrix(Transform::lookAt({1, 2, 3}, {1, 2, 10}, {0, 1, 0}),
               {{{1, 0, 0, -1}, {0, 1, 0, -2}, {0, 0, 1, -3}, {0, 0, 0, 1}}});
  // The look-at point lies on the camera's +z axis.
  Transform u = Transform::lookAt({2.3, 0.1, -0.7}, {0.4, 0, -0.9}, {0, 1, 0});
  Vec3 p = u.applyPoint({0.4, 0, -0.9});
  EXPECT_NEAR(p.x, 0, 1e-12);
  EXPECT_NEAR(p.y, 0, 1e-12);
  EXPECT_GT(p.z, 0);
}

TEST(Transform, InverseAndComposition) {
  Transform t = Transform::translate({1, 2, 3}) * Transform::rotate(33, {1, 2, 3}) *
                Transform::scale(2, 3, 4);
  Transform i = t * inverse(t);
  expectMatrix(i, {{{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}}}, 1e-12);
  expectMatrix(Transform(t.matrix()) * inverse(t),
               {{{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}}}, 1e-12);
  // a * b applies b first.
  expectVec((Transform::translate({1, 0, 0}) * Transform::scale(2, 2, 2)).applyPoint({1, 1, 1}),
            {3, 2, 2});
  // A singular matrix is accepted with a NaN inverse, as pbrt-v4 does; the builder refuses it
  // only where it places something rendered.
  EXPECT_TRUE(Transform(Transform::scale(0, 1, 1).matrix()).isSingular());
  EXPECT_TRUE(inverse(Transform::scale(1, 0, 1)).isSingular());
  EXPECT_TRUE((Transform::scale(1, 1, 0) * Transform::translate({1, 2, 3})).isSingular());
  EXPECT_FALSE(t.isSingular());
}

TEST(Transform, NormalsUseTheInverseTranspose) {
  Transform s = Transform::scale(2, 1, 1);
  // The plane x + y = 0 has normal (1, 1, 0); scaled by 2 in x its normal is (1, 2, 0) (up to
  // length).
  Vec3 n = s.applyNormal({1, 1, 0});
  EXPECT_NEAR(n.y / n.x, 2, 1e-12);
}

TEST(Transform, DirectivesPostMultiplyTheCurrentTransform) {
  Scene s = testutil::buildText(
      "WorldBegin\nTranslate 1 0 0\nRotate 90 0 0 1\nScale 2 2 2\nShape \"sphere\"\n"
      "Transform [1 0 0 0  0 1 0 0  0 0 1 0  2 3 4 1]\nShape \"sphere\"\n"
      "ConcatTransform [2 0 0 0  0 2 0 0  0 0 2 0  0 0 0 1]\nShape \"sphere\"\n");
  ASSERT_EQ(s.shapes.size(), 3u) << testutil::errorsOf(s);
  // (1,0,0) → scale (2,0,0) → rotate (0,2,0) → translate (1,2,0).
  expectVec(s.shapes[0].transform.applyPoint({1, 0, 0}), {1, 2, 0});
  // Transform's 16 values are the matrix in column-major order (pbrt): a translation.
  expectVec(s.shapes[1].transform.applyPoint({0, 0, 0}), {2, 3, 4});
  expectVec(s.shapes[2].transform.applyPoint({1, 1, 1}), {4, 5, 6});
}

TEST(Transform, CoordinateSystemsAndCameraSpace) {
  Scene s = testutil::buildText(
      "LookAt 0 0 -5  0 0 0  0 1 0\nCamera \"perspective\"\nWorldBegin\n"
      "Translate 7 0 0\nCoordinateSystem \"here\"\nIdentity\n"
      "CoordSysTransform \"here\"\nShape \"sphere\"\n"
      "CoordSysTransform \"camera\"\nShape \"sphere\"\n"
      "CoordSysTransform \"world\"\nShape \"sphere\"\n");
  ASSERT_EQ(s.shapes.size(), 3u) << testutil::errorsOf(s);
  expectMatrix(s.camera.camera_from_world,
               {{{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 5}, {0, 0, 0, 1}}});
  expectVec(s.shapes[0].transform.applyPoint({0, 0, 0}), {7, 0, 0});
  // "camera": camera → world; the camera-space origin is the eye.
  expectVec(s.shapes[1].transform.applyPoint({0, 0, 0}), {0, 0, -5});
  expectVec(s.shapes[1].transform.applyPoint({0, 0, 1}), {0, 0, -4});
  EXPECT_TRUE(s.shapes[2].transform.isIdentity());
}

TEST(Transform, ActiveTransformAndAttributeScopes) {
  Scene s = testutil::buildText(
      "LookAt 0 0 0  0 0 1  0 1 0\nActiveTransform EndTime\nTranslate 0 0 1\nActiveTransform All\n"
      "Camera \"perspective\"\nWorldBegin\nAttributeBegin\nTranslate 1 0 0\nAttributeEnd\n"
      "TransformBegin\nTranslate 0 1 0\nTransformEnd\nShape \"sphere\"\n");
  EXPECT_TRUE(s.camera.camera_from_world.isIdentity());
  expectVec(s.camera.camera_from_world_end.applyPoint({0, 0, 0}), {0, 0, 1});
  ASSERT_EQ(s.shapes.size(), 1u);
  EXPECT_TRUE(s.shapes[0].transform.isIdentity());
}

TEST(ReverseOrientation, FlipsNormals) {
  Scene s = testutil::buildText(
      "WorldBegin\nShape \"disk\"\nAttributeBegin\nReverseOrientation\nShape \"disk\"\n"
      "Scale -1 1 1\nShape \"disk\"\nAttributeEnd\nScale 1 1 -1\nShape \"disk\"\nShape \"disk\"\n");
  ASSERT_EQ(s.shapes.size(), 5u);
  EXPECT_FALSE(s.shapes[0].flipNormals());
  EXPECT_TRUE(s.shapes[1].reverse_orientation);
  EXPECT_TRUE(s.shapes[1].flipNormals());
  // ReverseOrientation and a handedness-swapping transform cancel.
  EXPECT_FALSE(s.shapes[2].flipNormals());
  EXPECT_FALSE(s.shapes[3].reverse_orientation);
  EXPECT_TRUE(s.shapes[3].flipNormals());
  // The disk's +z normal in world space, flipped as pbrt does.
  auto worldNormal = [](const Shape& sh) {
    Vec3 n = normalize(sh.transform.applyNormal({0, 0, 1}));
    return sh.flipNormals() ? -n : n;
  };
  expectVec(worldNormal(s.shapes[0]), {0, 0, 1});
  expectVec(worldNormal(s.shapes[1]), {0, 0, -1});
  // Scale 1 1 -1 mirrors the disk's normal to -z and swaps handedness: the flip turns it back.
  expectVec(worldNormal(s.shapes[3]), {0, 0, 1});
}

TEST(Instances, WorldBoundsApplyTheInstanceTransform) {
  Scene s = testutil::buildText(
      "WorldBegin\nObjectBegin \"ball\"\nTranslate 0 0 1\nShape \"sphere\" \"float radius\" 1\n"
      "ObjectEnd\nTranslate 10 0 0\nScale 2 2 2\nObjectInstance \"ball\"\n"
      "Rotate 90 1 0 0\nObjectInstance \"ball\"\n");
  ASSERT_EQ(s.instances.size(), 2u) << testutil::errorsOf(s);
  Bounds3 b = worldBounds(s, s.instances[0]);
  expectVec(b.min, {8, -2, 0});
  expectVec(b.max, {12, 2, 4});
  // Rotated 90° about x: object +z becomes world -y... after the scale, y in [-4, 0].
  Bounds3 r = worldBounds(s, s.instances[1]);
  expectVec(r.min, {8, -4, -2}, 1e-12);
  expectVec(r.max, {12, 0, 2}, 1e-12);
}

TEST(Transform, TransformBeginScopesFollowTheSyntaxVersion) {
  // pbrt-v1–v3: TransformEnd restores only the transform; pbrt-v4: the whole graphics state.
  const std::string body =
      "TransformBegin\nTranslate 1 0 0\nMaterial \"conductor\"\nTransformEnd\nShape \"sphere\"\n";
  Scene v3 = testutil::buildText("WorldBegin\n" + body + "WorldEnd\n");
  Scene v4 = testutil::buildText("WorldBegin\n" + body);
  ASSERT_EQ(v3.shapes.size(), 1u);
  ASSERT_EQ(v4.shapes.size(), 1u);
  EXPECT_TRUE(v3.shapes[0].transform.isIdentity());
  EXPECT_TRUE(v4.shapes[0].transform.isIdentity());
  EXPECT_EQ(v3.materials[static_cast<size_t>(v3.shapes[0].material)].type, "conductor");
  EXPECT_EQ(v4.materials[static_cast<size_t>(v4.shapes[0].material)].type, "diffuse");
  EXPECT_EQ(v3.diagnostics.size(), 0u);
  ASSERT_EQ(v4.diagnostics.size(), 1u);
  EXPECT_NE(v4.diagnostics[0].message.find("deprecated"), std::string::npos);
}
