// Participating media in scene files: MakeNamedMedium, MediumInterface on shapes and at the
// camera, presets, and located errors for bad media.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include "lensim/scene/description.h"
#include "lensim/scene/media_presets.h"
#include "scene_test_util.h"

using namespace lensim;
using lensim::testutil::buildText;
using lensim::testutil::errorsOf;

TEST(SceneMedia, HomogeneousMediumParameters) {
  const scene::Scene s = buildText(R"(
MakeNamedMedium "fog" "string type" "homogeneous" "rgb sigma_a" [0.1 0.2 0.3]
  "spectrum sigma_s" [400 1 700 2] "float scale" 2 "float g" 0.5
  "rgb Le" [1 0.5 0.25] "float Lescale" 3
WorldBegin
)");
  ASSERT_EQ(errorsOf(s), "");
  ASSERT_EQ(s.media.size(), 1u);
  const scene::Medium& m = s.media[0];
  EXPECT_EQ(m.name, "fog");
  EXPECT_EQ(m.type, "homogeneous");
  EXPECT_EQ(m.sigma_a.rgb.y, 0.2);
  EXPECT_EQ(m.sigma_s.kind, scene::SpectrumValue::Kind::Sampled);
  EXPECT_EQ(m.sigma_s.samples.size(), 2u);
  EXPECT_EQ(m.scale, 2);
  EXPECT_EQ(m.g, 0.5);
  EXPECT_EQ(m.Le.rgb.x, 1);
  EXPECT_EQ(m.Le_scale, 3);
}

TEST(SceneMedia, DefaultsAreThoseOfPbrtV4) {
  const scene::Scene s = buildText(R"(
MakeNamedMedium "m" "string type" "homogeneous"
WorldBegin
)");
  ASSERT_EQ(errorsOf(s), "");
  const scene::Medium& m = s.media.at(0);
  EXPECT_EQ(m.sigma_a.rgb.x, 1);
  EXPECT_EQ(m.sigma_s.rgb.z, 1);
  EXPECT_EQ(m.scale, 1);
  EXPECT_EQ(m.g, 0);
  EXPECT_EQ(m.Le.rgb.x, 0);
}

TEST(SceneMedia, InterfacesOnShapesAndTheCamerasMedium) {
  const scene::Scene s = buildText(R"(
MakeNamedMedium "air" "string type" "homogeneous" "rgb sigma_a" [0 0 0]
MakeNamedMedium "water" "string type" "homogeneous"
MediumInterface "" "air"
Camera "perspective"
WorldBegin
Shape "sphere"
AttributeBegin
  MediumInterface "water" "air"
  Shape "sphere"
  MediumInterface "water"
  Shape "sphere"
AttributeEnd
Shape "sphere"
)");
  ASSERT_EQ(errorsOf(s), "");
  EXPECT_EQ(s.camera.medium, 0);
  ASSERT_EQ(s.shapes.size(), 4u);
  // The interface current at the camera stays current (pbrt-v4): shapes after it are inside
  // vacuum, outside air.
  EXPECT_EQ(s.shapes[0].inside_medium, -1);
  EXPECT_EQ(s.shapes[0].outside_medium, 0);
  EXPECT_EQ(s.shapes[1].inside_medium, 1);
  EXPECT_EQ(s.shapes[1].outside_medium, 0);
  EXPECT_EQ(s.shapes[2].inside_medium, 1);
  EXPECT_EQ(s.shapes[2].outside_medium, 1);
  EXPECT_EQ(s.shapes[3].outside_medium, 0);
}

TEST(SceneMedia, MediaMayBeDefinedAfterTheyAreNamed) {
  const scene::Scene s = buildText(R"(
WorldBegin
MediumInterface "late" ""
Shape "sphere"
MakeNamedMedium "late" "string type" "homogeneous"
)");
  ASSERT_EQ(errorsOf(s), "");
  EXPECT_EQ(s.shapes.at(0).inside_medium, 0);
}

TEST(SceneMedia, UnknownMediumNameIsALocatedError) {
  const scene::Scene s = buildText(R"(MakeNamedMedium "fog" "string type" "homogeneous"
WorldBegin
MediumInterface "fgo" ""
Shape "sphere"
Shape "sphere"
)");
  // One error at the MediumInterface (not one per shape), with a hint.
  EXPECT_EQ(errorsOf(s),
            "test.pbrt:3:1: error: MediumInterface: unknown medium \"fgo\"; did you mean "
            "\"fog\"?\n");
}

TEST(SceneMedia, UnknownCameraMediumIsALocatedError) {
  const scene::Scene s = buildText(R"(MediumInterface "" "smoke"
Camera "perspective"
WorldBegin
)");
  EXPECT_EQ(errorsOf(s),
            "test.pbrt:1:1: error: MediumInterface: unknown medium \"smoke\" (no "
            "MakeNamedMedium defines it)\n");
}

TEST(SceneMedia, PresetsGiveMeasuredCoefficients) {
  const scene::Scene s = buildText(R"(
MakeNamedMedium "milk" "string type" "homogeneous" "string preset" "Wholemilk" "float scale" 1000
WorldBegin
)");
  ASSERT_EQ(errorsOf(s), "");
  const scene::Medium& m = s.media.at(0);
  // Jensen et al. 2001, whole milk: sigma_s' = (2.55, 3.21, 3.77), sigma_a = (0.0011, 0.0024,
  // 0.014) per mm.
  EXPECT_EQ(m.sigma_s.rgb.y, 3.21);
  EXPECT_EQ(m.sigma_a.rgb.z, 0.014);
  EXPECT_EQ(m.scale, 1000);
  EXPECT_EQ(scene::mediumPresetNames().size(), 47u);
}

TEST(SceneMedia, BadParametersAreLocatedErrors) {
  EXPECT_EQ(errorsOf(buildText(R"(MakeNamedMedium "m" "string type" "homogeneous"
  "string preset" "Wholemlk"
)")),
            "test.pbrt:2:3: error: \"preset\": unknown medium preset \"Wholemlk\"; did you mean "
            "\"Wholemilk\"?\n");
  EXPECT_EQ(errorsOf(buildText(R"(MakeNamedMedium "m" "string type" "homogeneous" "float g" 1
)")),
            "test.pbrt:1:49: error: medium \"m\": g 1 outside (-1, 1)\n");
  EXPECT_EQ(errorsOf(buildText(R"(MakeNamedMedium "m" "string type" "homogeneous" "float sigma" 1
)")),
            "test.pbrt:1:49: error: \"sigma\": unused parameter; did you mean \"sigma_a\"?\n");
  EXPECT_EQ(errorsOf(buildText(R"(MakeNamedMedium "m" "float g" 0.5
)")),
            "test.pbrt:1:1: error: MakeNamedMedium \"m\": missing \"string type\"\n");
}

TEST(SceneMedia, GridMedia) {
  const scene::Scene s = buildText(R"(
AttributeBegin
  Translate 1 2 3
  MakeNamedMedium "smoke" "string type" "uniformgrid" "integer nx" 2 "integer ny" 1
    "integer nz" 1 "float density" [0.5 2] "point3 p0" [-1 -1 -1] "float scale" 3
MakeNamedMedium "tint" "string type" "rgbgrid" "rgb sigma_s" [1 0 0] "rgb Le" [0 1 0]
  "float Lescale" 2
AttributeEnd
WorldBegin
)");
  ASSERT_EQ(errorsOf(s), "");
  ASSERT_EQ(s.media.size(), 2u);
  EXPECT_EQ(s.media[0].type, "uniformgrid");
  EXPECT_EQ(s.media[0].nx, 2);
  EXPECT_EQ(s.media[0].density.size(), 2u);
  EXPECT_EQ(s.media[0].p0.x, -1);
  EXPECT_EQ(s.media[0].p1.z, 1);
  EXPECT_EQ(s.media[0].medium_from_world.applyPoint({1, 2, 3}), (Vec3{0, 0, 0}));
  EXPECT_EQ(s.media[1].type, "rgbgrid");
  EXPECT_TRUE(s.media[1].sigma_a_grid.empty());
  EXPECT_EQ(s.media[1].sigma_s_grid.size(), 1u);
  EXPECT_EQ(s.media[1].Le_grid.at(0).y, 1);
  EXPECT_EQ(s.media[1].Le_scale, 2);

  // pbrt-v3's name for the density grid.
  const scene::Scene v3 = buildText(R"(MakeNamedMedium "smoke" "string type" "heterogeneous"
  "float density" [0.5] "rgb sigma_a" [1 1 1] "rgb sigma_s" [2 2 2]
WorldBegin
)");
  ASSERT_EQ(errorsOf(v3), "");
  EXPECT_EQ(v3.media.at(0).type, "uniformgrid");
  EXPECT_EQ(v3.media.at(0).type_as_written, "heterogeneous");

  EXPECT_EQ(errorsOf(buildText(R"(MakeNamedMedium "m" "string type" "uniformgrid" "integer nx" 2
  "float density" [1 2 3]
)")),
            "test.pbrt:2:3: error: medium \"m\": \"density\" has 3 values; expected nx*ny*nz = "
            "2\n");
  EXPECT_EQ(errorsOf(buildText(R"(MakeNamedMedium "m" "string type" "uniformgrid"
)")),
            "test.pbrt:1:1: error: medium \"m\": missing \"float density\"\n");
  EXPECT_EQ(errorsOf(buildText(R"(MakeNamedMedium "m" "string type" "rgbgrid" "rgb sigma_a" [1 -1 0]
)")),
            "test.pbrt:1:45: error: medium \"m\": \"sigma_a\" has a negative value -1\n");
}

TEST(SceneMedia, UnrenderedTypesAreWarnedAndLeftOut) {
  const scene::Scene s = buildText(R"(
MakeNamedMedium "haze" "string type" "spectralfog" "float density" 2
WorldBegin
MediumInterface "haze" ""
Shape "sphere"
)");
  ASSERT_EQ(errorsOf(s), "");
  EXPECT_EQ(s.shapes.at(0).inside_medium, -1);
  bool warned = false;
  for (const Diagnostic& d : s.diagnostics)
    warned = warned || d.message.find("\"spectralfog\" is not rendered") != std::string::npos;
  EXPECT_TRUE(warned);
}

TEST(SceneMedia, CloudAndNanoVDBParameters) {
  const testutil::TempDir dir("lensim-scene-vdb");
  dir.write("smoke.nvdb", "x");  // only its existence matters to the builder
  const scene::Scene s = scene::build(scene::parseFile(dir.write("s.pbrt", R"(
MakeNamedMedium "c" "string type" "cloud" "float density" 2 "float wispiness" 0.5
  "float frequency" 7 "point3 p0" [-1 0 -1] "point3 p1" [1 1 1] "rgb sigma_s" [3 2 1]
  "float scale" 4 "float g" 0.7
MakeNamedMedium "v" "string type" "nanovdb" "string filename" "smoke.nvdb"
  "float LeScale" 5 "float temperaturecutoff" 300 "float temperaturescale" 2
WorldBegin
)")));
  ASSERT_EQ(errorsOf(s), "");
  ASSERT_EQ(s.media.size(), 2u);
  const scene::Medium& c = s.media[0];
  EXPECT_EQ(c.type, "cloud");
  EXPECT_EQ(c.cloud_density, 2);
  EXPECT_EQ(c.wispiness, 0.5);
  EXPECT_EQ(c.frequency, 7);
  EXPECT_EQ(c.p0.x, -1);
  EXPECT_EQ(c.sigma_s.rgb.x, 3);
  EXPECT_EQ(c.sigma_a.rgb.x, 1);  // pbrt-v4's default
  EXPECT_EQ(c.scale, 4);
  EXPECT_EQ(c.g, 0.7);
  const scene::Medium& v = s.media[1];
  EXPECT_EQ(v.type, "nanovdb");
  EXPECT_EQ(v.filename, dir.file("smoke.nvdb"));
  EXPECT_EQ(v.Le_scale, 5);
  EXPECT_EQ(v.temperature_offset, 300);
  EXPECT_EQ(v.temperature_scale, 2);
  // Defaults as pbrt-v4's CloudMedium::Create.
  const scene::Scene defaults =
      buildText("MakeNamedMedium \"c\" \"string type\" \"cloud\"\nWorldBegin\n");
  const scene::Medium& d = defaults.media.at(0);
  EXPECT_EQ(d.cloud_density, 1);
  EXPECT_EQ(d.wispiness, 1);
  EXPECT_EQ(d.frequency, 5);
  EXPECT_EQ(d.p1.y, 1);
  // Located errors.
  EXPECT_EQ(errorsOf(buildText(R"(MakeNamedMedium "v" "string type" "nanovdb"
)")),
            "test.pbrt:1:1: error: medium \"v\": nanovdb needs \"string filename\" (a .nvdb "
            "file)\n");
  EXPECT_NE(
      errorsOf(buildText(R"(MakeNamedMedium "v" "string type" "nanovdb" "string filename" "no.nvdb"
)"))
          .find("NanoVDB file \"no.nvdb\" not found"),
      std::string::npos);
  EXPECT_EQ(errorsOf(buildText(R"(MakeNamedMedium "c" "string type" "cloud" "float density" -1
)")),
            "test.pbrt:1:43: error: medium \"c\": density -1 must not be negative\n");
}

TEST(SceneMedia, SubsurfaceMaterialParameters) {
  const scene::Scene s = buildText(R"(
WorldBegin
Material "subsurface" "string name" "Skin1" "float scale" 10 "float g" 0.4
Shape "sphere"
Material "subsurface" "rgb sigma_a" [0.1 0.2 0.3] "rgb sigma_s" [1 2 3] "float eta" 1.5
  "float g" 0.3 "float roughness" 0.2
Shape "sphere"
Material "subsurface" "rgb reflectance" [0.8 0.5 0.2] "rgb mfp" [1 2 3]
Shape "sphere"
Material "subsurface"
Shape "sphere"
)");
  ASSERT_EQ(errorsOf(s), "");
  ASSERT_EQ(s.materials.size(), 4u);
  const scene::Material& a = s.materials[0];
  EXPECT_EQ(a.type, "subsurface");
  const scene::SubsurfaceParams& ap = a.as<scene::SubsurfaceParams>();
  EXPECT_EQ(ap.preset, "Skin1");
  scene::SpectrumValue sa, ss;
  ASSERT_TRUE(scene::mediumPreset("Skin1", sa, ss));
  EXPECT_EQ(ap.sigma_a.spectrum.rgb, sa.rgb);
  EXPECT_EQ(ap.sigma_s.spectrum.rgb, ss.rgb);
  EXPECT_EQ(ap.g, 0);  // forced to 0 with a named medium, with a warning
  EXPECT_EQ(ap.scale, 10);
  EXPECT_EQ(ap.eta.value, 1.33);  // pbrt-v4's default
  bool warned = false;
  for (const Diagnostic& d : s.diagnostics)
    warned = warned || d.message.find("\"g\" is ignored") != std::string::npos;
  EXPECT_TRUE(warned);
  const scene::SubsurfaceParams& b = s.materials[1].as<scene::SubsurfaceParams>();
  EXPECT_EQ(b.sigma_s.spectrum.rgb.z, 3);
  EXPECT_EQ(b.g, 0.3);
  EXPECT_EQ(b.eta.value, 1.5);
  EXPECT_EQ(b.roughness.u.value, 0.2);
  const scene::SubsurfaceParams& c = s.materials[2].as<scene::SubsurfaceParams>();
  EXPECT_TRUE(c.from_reflectance);
  EXPECT_EQ(c.reflectance.spectrum.rgb.x, 0.8);
  EXPECT_EQ(c.mfp.spectrum.rgb.z, 3);
  const scene::Material& d = s.materials[3];  // whole milk, as pbrt-v4's default
  EXPECT_EQ(d.as<scene::SubsurfaceParams>().sigma_s.spectrum.rgb.x, 2.55);
  EXPECT_FALSE(d.fallback);
  EXPECT_EQ(errorsOf(buildText(R"(WorldBegin
Material "subsurface" "string name" "Skim milk"
)")),
            "test.pbrt:2:23: error: \"name\": unknown measured medium \"Skim milk\"; did you "
            "mean \"Skimmilk\"?\n");
  EXPECT_EQ(errorsOf(buildText(R"(WorldBegin
Material "subsurface" "rgb sigma_a" [1 1 1]
)")),
            "test.pbrt:2:1: error: subsurface: \"sigma_a\" given without \"sigma_s\"\n");
}

TEST(SceneMedia, VolpathIsItsOwnIntegrator) {
  EXPECT_EQ(buildText("Integrator \"volpath\"\nWorldBegin\n").integrator.type, "volpath");
  EXPECT_EQ(buildText("Integrator \"path\"\nWorldBegin\n").integrator.type, "path");
  // pbrt-v4's default; pbrt-v1–v3 files keep theirs (pbrt-v2's directlighting: path, depth 1).
  EXPECT_EQ(buildText("WorldBegin\n").integrator.type, "volpath");
  const scene::Scene legacy = buildText("WorldBegin\nWorldEnd\n");
  EXPECT_EQ(legacy.integrator.type, "path");
  EXPECT_EQ(legacy.integrator.max_depth, 1);
}

TEST(SceneMedia, PathIgnoresMediaWithAWarningAndOtherIntegratorsKeepThem) {
  const scene::Scene s = buildText(R"(Integrator "path"
MakeNamedMedium "fog" "string type" "homogeneous"
WorldBegin
MediumInterface "fog" ""
Shape "sphere"
)");
  ASSERT_EQ(errorsOf(s), "");
  bool warned = false;
  for (const Diagnostic& d : s.diagnostics)
    warned = warned || (d.loc.str() == "test.pbrt:1:1" &&
                        d.message.find("participating media but integrator \"path\" ignores "
                                       "them") != std::string::npos);
  EXPECT_TRUE(warned);
  // mlt is not rendered; its stand-in renders media (pbrt-v4 files).
  EXPECT_EQ(buildText("Integrator \"mlt\"\nWorldBegin\n").integrator.type, "volpath");
}

// bdpt's and lighttracer's subpaths do not run the subsurface walk: bdpt renders such a scene
// with volpath (warned), lighttracer warns; without a subsurface shape bdpt stays bdpt.
TEST(SceneMedia, SubsurfaceShapesMakeBdptRenderWithVolpath) {
  auto withIntegrator = [](const std::string& integrator, const std::string& material) {
    return buildText(fmt::format(R"(
Integrator "{}"
WorldBegin
Material "{}"
Shape "sphere"
)",
                                 integrator, material));
  };
  auto warned = [](const scene::Scene& s, const std::string& text) {
    for (const Diagnostic& d : s.diagnostics)
      if (d.message.find(text) != std::string::npos) return true;
    return false;
  };
  const scene::Scene b = withIntegrator("bdpt", "subsurface");
  ASSERT_EQ(errorsOf(b), "");
  EXPECT_EQ(b.integrator.type, "volpath");
  EXPECT_TRUE(warned(b, "does not walk inside \"subsurface\""));
  const scene::Scene l = withIntegrator("lighttracer", "subsurface");
  EXPECT_EQ(l.integrator.type, "lighttracer");
  EXPECT_TRUE(warned(l, "render as their dielectric boundary"));
  const scene::Scene d = withIntegrator("bdpt", "diffuse");
  EXPECT_EQ(d.integrator.type, "bdpt");
  EXPECT_FALSE(warned(d, "subsurface"));
}
