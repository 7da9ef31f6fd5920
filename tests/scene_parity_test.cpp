// pbrt parity of the parser and builder (issue 12): files pbrt accepts are accepted and mean
// what they mean in pbrt. The expected behaviour of each case is taken from pbrt's source (cited
// beside each test), not from lensim's output; the scene files are in tests/data/parity/.
#include <gtest/gtest.h>

#include <string>

#include "lensim/scene/description.h"
#include "lensim/scene/parser.h"
#include "scene_test_util.h"

namespace lensim::scene {
namespace {

std::string parity(const std::string& name) {
  return std::string(LENSIM_SOURCE_DIR) + "/tests/data/parity/" + name;
}

size_t countSeverity(const Scene& s, Severity sev) {
  size_t n = 0;
  for (const Diagnostic& d : s.diagnostics) n += d.severity == sev;
  return n;
}

std::string allDiagnostics(const Scene& s) {
  std::string out;
  for (const Diagnostic& d : s.diagnostics) out += d.str() + "\n";
  return out;
}

// pbrt-v4 reads any scene file whose name ends in ".gz" through zlib, top-level or included
// (Tokenizer::CreateFromFile, src/pbrt/parser.cpp).
TEST(Parity, GzipCompressedSceneAndInclude) {
  Scene s = build(parseFile(parity("gz_main.pbrt.gz")));
  EXPECT_EQ(countSeverity(s, Severity::Error), 0u) << allDiagnostics(s);
  ASSERT_EQ(s.shapes.size(), 2u);
  EXPECT_EQ(s.shapes[0].type, ShapeType::Sphere);
  EXPECT_DOUBLE_EQ(s.shapes[0].radius, 0.25);
  EXPECT_EQ(s.shapes[1].type, ShapeType::Disk);
  EXPECT_EQ(s.film.x_resolution, 16);
  ASSERT_EQ(s.materials.size(), 2u);  // the sphere's and the default one of the disk
  EXPECT_EQ(s.materials[0].as<DiffuseParams>().reflectance.spectrum.rgb.y, 0.4);
  // Locations name the compressed file the directive came from.
  EXPECT_NE(s.shapes[0].loc.file.find("gz_geometry.pbrt.gz"), std::string::npos);
  EXPECT_EQ(s.shapes[0].loc.line, 4);
}

TEST(Parity, CorruptGzipIsAnErrorNamingTheFile) {
  testutil::TempDir dir("lensim-parity-gz");
  std::string p = dir.write("bad.pbrt.gz", std::string("\x1f\x8b\x08\x00garbage-not-deflate", 23));
  try {
    parseFile(p);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.pbrt.gz"), std::string::npos) << e.what();
  }
}

// pbrt-v4's parser reads one token stream: at the end of an included file it goes on with the
// including file (`nextToken` pops the file stack, src/pbrt/parser.cpp), so a parameter list
// may continue after the Include.
TEST(Parity, ParameterListContinuesAfterInclude) {
  Scene s = build(parseFile(parity("include_params_main.pbrt")));
  EXPECT_EQ(countSeverity(s, Severity::Error), 0u) << allDiagnostics(s);
  ASSERT_EQ(s.shapes.size(), 2u);
  ASSERT_EQ(s.shapes[0].type, ShapeType::TriangleMesh);
  const Mesh& m = s.meshes.at(static_cast<size_t>(s.shapes[0].mesh));
  EXPECT_EQ(m.indices, (std::vector<int>{0, 1, 2}));
  ASSERT_EQ(m.uvs.size(), 3u);
  EXPECT_EQ(m.uvs[1][0], 1.0f);
  // The Shape is located in the included file, its continued parameters in the main one.
  EXPECT_NE(s.shapes[0].loc.file.find("include_params_mesh.pbrt"), std::string::npos);
  EXPECT_EQ(s.shapes[1].type, ShapeType::Sphere);
}

TEST(Parity, DirectiveSplitAcrossIncludeEnd) {
  testutil::TempDir dir("lensim-parity-split");
  dir.write("part.pbrt", "WorldBegin\nShape \"sphere\"\n");
  std::string main = dir.write("main.pbrt", "Include \"part.pbrt\" \"float radius\" 3\n");
  Scene s = build(parseFile(main));
  EXPECT_EQ(countSeverity(s, Severity::Error), 0u) << allDiagnostics(s);
  ASSERT_EQ(s.shapes.size(), 1u);
  EXPECT_DOUBLE_EQ(s.shapes[0].radius, 3);
}

// A parameter given twice: pbrt-v4's ParameterDictionary reverses the list, so every lookup
// finds the last one written, and ReportUnused accepts the shadowed earlier one
// (src/pbrt/paramdict.cpp); pbrt-v3's ParamSet::Add* erase the earlier one. No error.
TEST(Parity, DuplicatedParameterTheLastOneWins) {
  Scene s = build(parseFile(parity("duplicate_param.pbrt")));
  EXPECT_EQ(countSeverity(s, Severity::Error), 0u) << allDiagnostics(s);
  EXPECT_EQ(countSeverity(s, Severity::Warning), 0u) << allDiagnostics(s);
  EXPECT_DOUBLE_EQ(s.camera.fov_deg, 30);
  ASSERT_EQ(s.shapes.size(), 2u);
  EXPECT_DOUBLE_EQ(s.shapes[0].radius, 2);
  EXPECT_DOUBLE_EQ(s.shapes[1].radius, 4);
  const Material& m = s.materials.at(static_cast<size_t>(s.shapes[1].material));
  EXPECT_EQ(m.as<DiffuseParams>().reflectance.spectrum.rgb.x, 0.5);
  EXPECT_EQ(m.as<DiffuseParams>().reflectance.spectrum.rgb.z, 0.125);
}

TEST(Parity, DuplicateWithAnotherTypeWarnsAndUsesTheLastOne) {
  Scene s =
      testutil::buildText("WorldBegin\nShape \"sphere\" \"integer radius\" 1 \"float radius\" 2\n");
  EXPECT_EQ(countSeverity(s, Severity::Error), 0u) << allDiagnostics(s);
  ASSERT_EQ(countSeverity(s, Severity::Warning), 1u) << allDiagnostics(s);
  EXPECT_NE(allDiagnostics(s).find("test.pbrt:2:16: warning: \"radius\": given again"),
            std::string::npos)
      << allDiagnostics(s);
  EXPECT_DOUBLE_EQ(s.shapes.at(0).radius, 2);
}

// pbrt-v4 keeps a singular transform with a NaN inverse (Transform(const SquareMatrix<4>&),
// src/pbrt/util/transform.h) and goes on; lensim does too, and refuses it only where it places
// something rendered.
TEST(Parity, SingularTransformNothingUsesIsAccepted) {
  Scene s = build(parseFile(parity("singular_unused.pbrt")));
  EXPECT_EQ(countSeverity(s, Severity::Error), 0u) << allDiagnostics(s);
  EXPECT_EQ(s.shapes.size(), 1u);
}

TEST(Parity, SingularTransformOnAShapeIsAnErrorAtTheShape) {
  Scene s = build(parseFile(parity("singular_shape.pbrt")));
  ASSERT_EQ(countSeverity(s, Severity::Error), 1u) << allDiagnostics(s);
  const std::string e = testutil::errorsOf(s);
  EXPECT_NE(e.find("singular_shape.pbrt:5:3: error: Shape \"sphere\": the current transformation "
                   "matrix is singular"),
            std::string::npos)
      << e;
  // The other shape is still built, so one run lists every problem.
  ASSERT_EQ(s.shapes.size(), 1u);
  EXPECT_DOUBLE_EQ(s.shapes[0].radius, 2);
}

TEST(Parity, SingularTransformOnCameraLightInstanceAndProjectedTexture) {
  const std::string text = R"(Scale 0 1 1
Camera "perspective"
WorldBegin
AttributeBegin
  Scale 1 1 0
  LightSource "point"
  Texture "t" "float" "checkerboard" "string mapping" "planar"
  Texture "u" "float" "checkerboard"
AttributeEnd
ObjectBegin "o"
  Shape "sphere"
ObjectEnd
AttributeBegin
  Scale 0 0 0
  ObjectInstance "o"
AttributeEnd
)";
  Scene s = testutil::buildText(text);
  const std::string e = testutil::errorsOf(s);
  EXPECT_EQ(countSeverity(s, Severity::Error), 4u) << e;
  EXPECT_NE(e.find("test.pbrt:2:1: error: Camera"), std::string::npos) << e;
  EXPECT_NE(e.find("test.pbrt:6:3: error: LightSource"), std::string::npos) << e;
  EXPECT_NE(e.find("test.pbrt:7:3: error: texture \"t\": its planar mapping"), std::string::npos)
      << e;
  EXPECT_NE(e.find("test.pbrt:15:3: error: ObjectInstance"), std::string::npos) << e;
}

// pbrt-v3 reads a light's "scale" as a spectrum and multiplies the emission by it in RGB
// (e.g. CreatePointLight: `Spectrum sc = paramSet.FindOneSpectrum("scale", Spectrum(1.0))`,
// src/lights/point.cpp; the same in spot, distant, infinite and diffuse area lights).
TEST(Parity, V3ColourLightScale) {
  Scene s = build(parseFile(parity("v3_light_scale.pbrt")));
  EXPECT_EQ(countSeverity(s, Severity::Error), 0u) << allDiagnostics(s);
  ASSERT_EQ(s.lights.size(), 5u);
  const Light& point = s.lights[0];
  EXPECT_EQ(point.emission.kind, SpectrumValue::Kind::Rgb);
  EXPECT_EQ(point.emission.rgb.x, 2);  // I (1,1,1) × scale (2,1,0.5), channel by channel
  EXPECT_EQ(point.emission.rgb.y, 1);
  EXPECT_EQ(point.emission.rgb.z, 0.5);
  EXPECT_EQ(point.scale, 1);
  const Light& spot = s.lights[1];  // a grey scale is a factor
  EXPECT_EQ(spot.scale, 3);
  EXPECT_EQ(spot.emission.rgb.x, 0.5);
  const Light& distant = s.lights[2];  // blackbody × colour: applied as its luminance, warned
  EXPECT_NEAR(distant.scale, 0.2126 + 2 * 0.7152 + 0.0722, 1e-12);
  EXPECT_EQ(s.lights[3].scale, 0.25);  // pbrt-v4's float scale
  const Light& area = s.lights[4];
  EXPECT_EQ(area.type, "diffuse");
  EXPECT_EQ(area.emission.rgb.x, 0.5);
  EXPECT_EQ(area.emission.rgb.y, 1);
  EXPECT_EQ(area.emission.rgb.z, 6);
  EXPECT_EQ(countSeverity(s, Severity::Warning), 1u) << allDiagnostics(s);
}

// pbrt-v2's Renderer directive: pbrt-v3/v4 have none; ignored with a warning.
TEST(Parity, V2RendererIsIgnoredWithAWarning) {
  Scene s = build(parseFile(parity("v2_renderer.pbrt")));
  EXPECT_EQ(countSeverity(s, Severity::Error), 0u) << allDiagnostics(s);
  ASSERT_EQ(countSeverity(s, Severity::Warning), 1u) << allDiagnostics(s);
  EXPECT_NE(allDiagnostics(s).find("v2_renderer.pbrt:2:1: warning: Renderer \"sampler\""),
            std::string::npos)
      << allDiagnostics(s);
  EXPECT_TRUE(s.legacy_syntax);
}

// pbrt-v4 records NamedMaterial as a name and looks named materials up only when it creates the
// scene (BasicScene::CreateMaterials, then each shape's lookup, src/pbrt/scene.cpp), so a shape
// may use a material that a later MakeNamedMaterial defines (contemporary-bathroom in
// pbrt-v4-scenes does: its lights use materials that the Include after them defines).
TEST(Parity, NamedMaterialMayPrecedeItsDefinition) {
  testutil::TempDir dir("lensim-parity-named");
  std::string main = dir.write("main.pbrt",
                               "WorldBegin\n"
                               "NamedMaterial \"gold\"\n"
                               "Shape \"sphere\"\n"
                               "MakeNamedMaterial \"gold\" \"string type\" \"conductor\"\n"
                               "Material \"dielectric\"\n"
                               "Shape \"disk\"\n"
                               "NamedMaterial \"gold\"\n"
                               "Shape \"cylinder\"\n");
  Scene s = build(parseFile(main));
  EXPECT_EQ(countSeverity(s, Severity::Error), 0u) << allDiagnostics(s);
  ASSERT_EQ(s.shapes.size(), 3u);
  EXPECT_EQ(s.materials.at(static_cast<size_t>(s.shapes[0].material)).type, "conductor");
  EXPECT_EQ(s.shapes[0].material, s.shapes[2].material);
  EXPECT_EQ(s.materials.at(static_cast<size_t>(s.shapes[1].material)).type, "dielectric");
}

// A name that no MakeNamedMaterial defines is an error where pbrt-v4 has one: at a shape that
// uses it ("no named material defined"); lensim places it at the NamedMaterial, once.
TEST(Parity, NamedMaterialNeverDefinedIsAnErrorAtTheNamedMaterial) {
  testutil::TempDir dir("lensim-parity-named-bad");
  std::string main = dir.write(
      "main.pbrt", "WorldBegin\nNamedMaterial \"gold\"\nShape \"sphere\"\nShape \"disk\"\n");
  Scene s = build(parseFile(main));
  ASSERT_EQ(countSeverity(s, Severity::Error), 1u) << allDiagnostics(s);
  for (const Diagnostic& d : s.diagnostics) {
    if (d.severity != Severity::Error) continue;
    EXPECT_EQ(d.loc.line, 2);
    EXPECT_EQ(d.loc.column, 1);
    EXPECT_NE(d.message.find("unknown material \"gold\""), std::string::npos) << d.message;
  }
}

}  // namespace
}  // namespace lensim::scene
