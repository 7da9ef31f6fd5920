// pbrt-v1–v3 named-material scoping (scene/build/named_materials.cpp): pbrt-v3 keeps named
// materials in the graphics state, so AttributeBegin/End scope them; pbrt-v4 keeps one global
// table.
#include <gtest/gtest.h>

#include "lensim/scene/description.h"
#include "scene_test_util.h"

using namespace lensim;
using namespace lensim::scene;

namespace {

bool hasWarning(const Scene& s, const std::string& text) {
  for (const Diagnostic& d : s.diagnostics)
    if (d.severity == Severity::Warning && d.message.find(text) != std::string::npos) return true;
  return false;
}

const Material& materialOf(const Scene& s, size_t shape) {
  return s.materials[static_cast<size_t>(s.shapes[shape].material)];
}

// Two blocks define the same name with different materials; each shape uses its block's one.
// WorldEnd makes the file a pbrt-v1–v3 one.
const char* kTwoBlocks =
    "WorldBegin\n"
    "AttributeBegin\n"
    "  MakeNamedMaterial \"m\" \"string type\" \"matte\" \"rgb Kd\" [1 0 0]\n"
    "  NamedMaterial \"m\"\n"
    "  Shape \"sphere\"\n"
    "AttributeEnd\n"
    "AttributeBegin\n"
    "  MakeNamedMaterial \"m\" \"string type\" \"mirror\"\n"
    "  NamedMaterial \"m\"\n"
    "  Shape \"sphere\"\n"
    "AttributeEnd\n";

}  // namespace

TEST(NamedMaterialScope, PbrtV3BlocksKeepTheirOwnDefinitions) {
  Scene s = testutil::buildText(std::string(kTwoBlocks) + "WorldEnd\n");
  ASSERT_TRUE(s.legacy_syntax);
  ASSERT_EQ(s.shapes.size(), 2u) << testutil::errorsOf(s);
  EXPECT_EQ(materialOf(s, 0).type_as_written, "matte");
  EXPECT_EQ(materialOf(s, 0).as<DiffuseParams>().reflectance.spectrum.rgb, (Vec3{1, 0, 0}));
  EXPECT_EQ(materialOf(s, 1).type_as_written, "mirror");
  EXPECT_FALSE(hasWarning(s, "redefined"));
}

TEST(NamedMaterialScope, PbrtV4NamesAreGlobalAndARedefinitionWarns) {
  // The same text without WorldEnd is a pbrt-v4 file: one global table, resolved when the scene
  // is complete, so both shapes get the last definition, and the redefinition is warned.
  Scene s = testutil::buildText(kTwoBlocks);
  ASSERT_FALSE(s.legacy_syntax);
  ASSERT_EQ(s.shapes.size(), 2u) << testutil::errorsOf(s);
  EXPECT_EQ(materialOf(s, 0).type_as_written, "matte");  // defined before its use
  EXPECT_EQ(materialOf(s, 1).type_as_written, "mirror");
  EXPECT_TRUE(hasWarning(s, "named material \"m\" redefined"));
  // After the block, pbrt-v4 still knows the name.
  Scene after = testutil::buildText(
      "WorldBegin\nAttributeBegin\nMakeNamedMaterial \"m\" \"string type\" \"conductor\"\n"
      "AttributeEnd\nNamedMaterial \"m\"\nShape \"sphere\"\n");
  ASSERT_EQ(after.shapes.size(), 1u) << testutil::errorsOf(after);
  EXPECT_EQ(materialOf(after, 0).type_as_written, "conductor");
}

TEST(NamedMaterialScope, PbrtV3NameIsGoneAfterItsBlock) {
  // pbrt-v3's GraphicsState::CreateMaterial: a name not in scope falls back to the current
  // Material (here "plastic"); lensim says so.
  Scene s = testutil::buildText(
      "WorldBegin\nMaterial \"plastic\"\n"
      "AttributeBegin\nMakeNamedMaterial \"m\" \"string type\" \"mirror\"\nAttributeEnd\n"
      "NamedMaterial \"m\"\nShape \"sphere\"\nWorldEnd\n");
  ASSERT_EQ(s.shapes.size(), 1u) << testutil::errorsOf(s);
  EXPECT_EQ(materialOf(s, 0).type_as_written, "plastic");
  EXPECT_TRUE(hasWarning(s, "NamedMaterial \"m\": no MakeNamedMaterial of that name"));
}

TEST(NamedMaterialScope, PbrtV3InnerBlocksSeeOuterNamesAndLookupIsAtTheShape) {
  // An inner block inherits the outer scope; the Shape looks the name up in its own scope, so
  // a redefinition between NamedMaterial and Shape applies (pbrt-v3 CreateMaterial). A Material
  // directive ends the NamedMaterial (pbrtMaterial clears currentNamedMaterial). TransformBegin
  // does not scope (it saves only the transform).
  Scene s = testutil::buildText(
      "WorldBegin\nMakeNamedMaterial \"m\" \"string type\" \"matte\"\n"
      "AttributeBegin\nNamedMaterial \"m\"\nShape \"sphere\"\n"
      "MakeNamedMaterial \"m\" \"string type\" \"metal\"\nShape \"sphere\"\n"
      "Material \"glass\"\nShape \"sphere\"\nAttributeEnd\n"
      "TransformBegin\nMakeNamedMaterial \"t\" \"string type\" \"substrate\"\nTransformEnd\n"
      "NamedMaterial \"t\"\nShape \"sphere\"\n"
      "NamedMaterial \"m\"\nShape \"sphere\"\nWorldEnd\n");
  ASSERT_EQ(s.shapes.size(), 5u) << testutil::errorsOf(s);
  EXPECT_EQ(materialOf(s, 0).type_as_written, "matte");
  EXPECT_EQ(materialOf(s, 1).type_as_written, "metal");
  EXPECT_EQ(materialOf(s, 2).type_as_written, "glass");
  EXPECT_EQ(materialOf(s, 3).type_as_written, "substrate");
  EXPECT_EQ(materialOf(s, 4).type_as_written, "matte");  // the block's "metal" is gone
}

TEST(NamedMaterialScope, PbrtV3MixUsesTheScope) {
  Scene s = testutil::buildText(
      "WorldBegin\nAttributeBegin\nMakeNamedMaterial \"a\" \"string type\" \"matte\"\n"
      "AttributeEnd\nMakeNamedMaterial \"a\" \"string type\" \"mirror\"\n"
      "MakeNamedMaterial \"b\" \"string type\" \"metal\"\n"
      "Material \"mix\" \"string namedmaterial1\" \"a\" \"string namedmaterial2\" \"b\"\n"
      "Shape \"sphere\"\nWorldEnd\n");
  ASSERT_EQ(s.shapes.size(), 1u) << testutil::errorsOf(s);
  const Material& mix = materialOf(s, 0);
  EXPECT_EQ(s.materials[size_t(mix.as<MixParams>().materials[0])].type_as_written, "mirror");
  EXPECT_EQ(s.materials[size_t(mix.as<MixParams>().materials[1])].type_as_written, "metal");
}
