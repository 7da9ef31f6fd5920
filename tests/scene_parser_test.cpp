#include <gtest/gtest.h>

#include "lensim/scene/parser.h"
#include "lensim/scene/tokenizer.h"
#include "scene_test_util.h"

using namespace lensim;
using namespace lensim::scene;

TEST(Tokenizer, SkipsCommentsAndUnescapesStrings) {
  Tokenizer t("# comment\n  Shape \"a\\\"b\\\\c\\n\" [ 1 ] # tail", "x.pbrt");
  Token a = t.next();
  EXPECT_EQ(a.kind, Token::Kind::Word);
  EXPECT_EQ(a.text, "Shape");
  EXPECT_EQ(a.line, 2);
  EXPECT_EQ(a.column, 3);
  Token s = t.next();
  EXPECT_EQ(s.kind, Token::Kind::String);
  EXPECT_EQ(s.text, "a\"b\\c\n");
  EXPECT_EQ(t.next().kind, Token::Kind::LBracket);
  EXPECT_EQ(t.next().text, "1");
  EXPECT_EQ(t.next().kind, Token::Kind::RBracket);
  EXPECT_EQ(t.next().kind, Token::Kind::End);
}

TEST(Tokenizer, UnterminatedStringIsLocated) {
  Tokenizer t("Shape\n  \"sphere", "x.pbrt");
  t.next();
  try {
    t.next();
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "x.pbrt:2:3: error: unterminated string");
  }
}

TEST(Parser, NumbersInAllForms) {
  SceneDesc d = parseString(
      "WorldBegin\nShape \"sphere\" \"float a\" [1e+30 .5 -0 +2 -1.5E-3 7]\n"
      "Shape \"sphere\" \"float b\" 3\n");
  ASSERT_EQ(d.directives.size(), 3u);
  const Param& a = d.directives[1].params[0];
  ASSERT_EQ(a.numbers.size(), 6u);
  EXPECT_EQ(a.numbers[0], 1e30);
  EXPECT_EQ(a.numbers[1], 0.5);
  EXPECT_EQ(a.numbers[2], 0.0);
  EXPECT_TRUE(std::signbit(a.numbers[2]));
  EXPECT_EQ(a.numbers[3], 2.0);
  EXPECT_EQ(a.numbers[4], -1.5e-3);
  EXPECT_EQ(d.directives[2].params[0].numbers, std::vector<double>{3});
}

TEST(Parser, RecordsLocationsOfDirectivesAndParameters) {
  SceneDesc d = parseString(
      "WorldBegin\n  Shape \"disk\"\n    \"float radius\" 2 \"float height\" [1]", "s.pbrt");
  const Directive& s = d.directives[1];
  EXPECT_EQ(s.loc.str(), "s.pbrt:2:3");
  EXPECT_EQ(s.strings, std::vector<std::string>{"disk"});
  ASSERT_EQ(s.params.size(), 2u);
  EXPECT_EQ(s.params[0].loc.str(), "s.pbrt:3:5");
  EXPECT_EQ(s.params[1].loc.str(), "s.pbrt:3:22");
  EXPECT_EQ(s.params[1].name, "height");
}

TEST(Parser, ParameterTypesOfAllVersions) {
  SceneDesc d = parseString(
      "WorldBegin\nShape \"x\" \"bool a\" \"true\" \"bool b\" false \"bool c\" [true false]\n"
      "\"color d\" [1 2 3] \"point e\" [1 2 3 4 5 6] \"vector f\" [0 0 1] \"normal g\" [0 1 0]\n"
      "\"point2 h\" [0 1] \"vector2 i\" [1 0] \"normal3 j\" [1 0 0] \"texture k\" \"t\"\n"
      "\"spectrum l\" [400 1 700 2] \"spectrum m\" \"metal-Au-eta\" \"blackbody n\" 6500\n"
      "\"blackbody o\" [5500 2] \"integer p\" [1 -2] \"string q\" \"s\" \"rgb r\" [.1 .2 .3]\n");
  EXPECT_TRUE(d.legacy_syntax);
  const ParamList& p = d.directives[1].params;
  ASSERT_EQ(p.size(), 18u);
  EXPECT_EQ(p[0].bools, std::vector<bool>{true});
  EXPECT_EQ(p[1].bools, std::vector<bool>{false});
  EXPECT_EQ(p[2].bools, (std::vector<bool>{true, false}));
  EXPECT_EQ(p[3].type, ParamType::Rgb);
  EXPECT_EQ(p[3].type_as_written, "color");
  EXPECT_EQ(p[4].type, ParamType::Point3);
  EXPECT_EQ(p[5].type, ParamType::Vector3);
  EXPECT_EQ(p[6].type, ParamType::Normal3);
  EXPECT_EQ(p[7].type, ParamType::Point2);
  EXPECT_EQ(p[8].type, ParamType::Vector2);
  EXPECT_EQ(p[10].type, ParamType::Texture);
  EXPECT_EQ(p[10].strings[0], "t");
  EXPECT_EQ(p[11].numbers.size(), 4u);
  EXPECT_EQ(p[12].strings[0], "metal-Au-eta");
  EXPECT_EQ(p[13].numbers, std::vector<double>{6500});
  EXPECT_EQ(p[14].numbers, (std::vector<double>{5500, 2}));
  EXPECT_EQ(p[15].numbers, (std::vector<double>{1, -2}));
}

TEST(Parser, AllDirectivesAreRecognised) {
  SceneDesc d = parseString(R"(
Option "bool disablepixeljitter" true
ColorSpace "srgb"
TransformTimes 0 1
ActiveTransform EndTime
Translate 1 0 0
ActiveTransform All
Identity Translate 1 2 3 Scale 1 2 3 Rotate 30 0 1 0
LookAt 0 0 -1  0 0 0  0 1 0
CoordinateSystem "a" CoordSysTransform "a"
Transform [1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1]
ConcatTransform [1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1]
Camera "perspective" Sampler "halton" Film "rgb" PixelFilter "box" Filter "box"
Integrator "path" SurfaceIntegrator "directlighting" VolumeIntegrator "single"
Accelerator "bvh"
MakeNamedMedium "fog" "string type" "homogeneous"
MediumInterface "fog" ""
MediumInterface "fog"
WorldBegin
AttributeBegin TransformBegin TransformEnd AttributeEnd
Attribute "shape" "float radius" 2
ReverseOrientation
Shape "sphere" Material "diffuse" MakeNamedMaterial "m" "string type" "diffuse" NamedMaterial "m"
Texture "t" "float" "constant"
LightSource "point" AreaLightSource "diffuse"
ObjectBegin "o" ObjectEnd ObjectInstance "o"
WorldEnd
)");
  EXPECT_EQ(d.directives.size(), 45u);
  EXPECT_EQ(d.directives[3].word, "EndTime");
}

TEST(Parser, IncludePathsAreRelativeToTheIncludingFile) {
  testutil::TempDir dir("lensim-include");
  dir.write("main.pbrt", "WorldBegin\nInclude \"sub/a.pbrt\"\nShape \"sphere\"\n");
  dir.write("sub/a.pbrt", "Include \"b.pbrt\"\n");
  dir.write("sub/b.pbrt", "Shape \"disk\"\nImport \"../c.pbrt\"\n");
  dir.write("c.pbrt", "Shape \"cone\"\n");
  SceneDesc d = parseFile(dir.file("main.pbrt"));
  EXPECT_TRUE(d.diagnostics.empty());
  ASSERT_EQ(d.directives.size(), 4u);
  EXPECT_EQ(d.directives[1].strings[0], "disk");
  EXPECT_EQ(d.directives[1].loc.line, 1);
  EXPECT_TRUE(d.directives[1].loc.file.ends_with("sub/b.pbrt"));
  EXPECT_EQ(d.directives[2].strings[0], "cone");
  EXPECT_EQ(d.directives[3].strings[0], "sphere");
  EXPECT_EQ(d.files.size(), 4u);
}

TEST(Parser, MissingIncludesAreAllReportedAndParsingContinues) {
  SceneDesc d = parseString("WorldBegin\nInclude \"a.pbrt\"\nInclude \"b.pbrt\"\nShape \"disk\"\n",
                            "/nonexistent/x.pbrt");
  ASSERT_EQ(d.diagnostics.size(), 2u);
  EXPECT_EQ(d.diagnostics[0].str(),
            "/nonexistent/x.pbrt:2:1: error: included file \"a.pbrt\" not found (looked for "
            "/nonexistent/a.pbrt)");
  EXPECT_EQ(d.diagnostics[1].loc.line, 3);
  EXPECT_EQ(d.directives.size(), 2u);
}

TEST(Parser, ObjectInstanceMayPrecedeItsDefinition) {
  EXPECT_NO_THROW(parseString("WorldBegin\nObjectInstance \"a\"\nObjectBegin \"a\"\nObjectEnd\n"));
}

TEST(Parser, StructureErrors) {
  auto msg = [](const std::string& text) {
    try {
      parseString(text, "s.pbrt");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(msg("WorldBegin\nObjectBegin \"a\"\nObjectBegin \"b\"\n"),
            "s.pbrt:3:1: error: ObjectBegin inside the definition of object begun at s.pbrt:2:1");
  EXPECT_EQ(
      msg("WorldBegin\nObjectBegin \"a\"\nObjectInstance \"a\"\nObjectEnd\n"),
      "s.pbrt:3:1: error: ObjectInstance inside the definition of object begun at s.pbrt:2:1");
  EXPECT_EQ(msg("WorldBegin\nObjectBegin \"a\"\n"),
            "s.pbrt:2:1: error: ObjectBegin without matching ObjectEnd");
  EXPECT_EQ(msg("WorldBegin\nWorldBegin\n"), "s.pbrt:2:1: error: WorldBegin after WorldBegin");
  EXPECT_EQ(msg("WorldBegin\nWorldEnd\nShape \"sphere\"\n"),
            "s.pbrt:3:1: error: Shape after WorldEnd");
  EXPECT_EQ(msg("Translate 1 2\nWorldBegin"),
            "s.pbrt:1:1: error: Translate: expected 3 numbers, got 2");
  EXPECT_EQ(msg("ActiveTransform Sometimes"),
            "s.pbrt:1:17: error: ActiveTransform: expected StartTime, EndTime or All");
  EXPECT_EQ(msg("WorldBegin\nShape \"sphere\" \"float\" 1"),
            "s.pbrt:2:16: error: bad parameter declaration \"float\"; expected \"type name\"");
  EXPECT_EQ(msg("WorldBegin\nShape \"sphere\" \"float radius\""),
            "s.pbrt:2:16: error: \"float radius\": missing value");
  EXPECT_EQ(
      msg("WorldBegin\nAtributeBegin"),
      "s.pbrt:2:1: error: unknown directive \"AtributeBegin\"; did you mean \"AttributeBegin\"?");
  EXPECT_EQ(msg("WorldBegin\nFoo"), "s.pbrt:2:1: error: unknown directive \"Foo\"");
  EXPECT_EQ(msg("WorldBegin\n\"sphere\""),
            "s.pbrt:2:1: error: unexpected string \"sphere\"; expected a directive");
  EXPECT_EQ(msg("WorldBegin\nShape \"trianglemesh\" \"blackbody L\" [1 2 3]"),
            "s.pbrt:2:22: error: \"blackbody L\": expected a temperature (and, in pbrt-v3, a "
            "scale), got 3 values");
}

TEST(Parser, IncludeCyclesAreErrors) {
  testutil::TempDir dir("lensim-cycle");
  std::string a = dir.write("a.pbrt", "WorldBegin\nInclude \"b.pbrt\"\n");
  dir.write("b.pbrt", "Include \"b.pbrt\"\n");
  try {
    parseFile(a);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(e.message().find("nested too deeply"), std::string::npos);
    EXPECT_TRUE(e.loc().file.ends_with("b.pbrt"));
  }
}
