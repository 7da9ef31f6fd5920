#include <gtest/gtest.h>
#include <zlib.h>

#include <filesystem>
#include <fstream>
#include <set>

#include "lensim/scene/description.h"
#include "lensim/scene/format.h"
#include "scene_test_util.h"

using namespace lensim;
using namespace lensim::scene;
namespace fs = std::filesystem;

namespace {

const fs::path kScenes = fs::path(LENSIM_SHARED_DIR) / "scenes";

size_t warningCount(const Scene& s) {
  size_t n = 0;
  for (const Diagnostic& d : s.diagnostics) n += d.severity == Severity::Warning;
  return n;
}

bool hasWarning(const Scene& s, const std::string& text) {
  for (const Diagnostic& d : s.diagnostics)
    if (d.severity == Severity::Warning && d.message.find(text) != std::string::npos) return true;
  return false;
}

}  // namespace

// ---- the shared scenes ------------------------------------------------------------------------

// Top-level scenes that must check cleanly. Files only included by others (hw3_scene.pbrt,
// box-world.pbrt) are checked through these.
const std::vector<std::string> kCleanScenes = {
    "cs348b-hw3/hw3_dgauss.pbrt",
    "cs348b-hw3/hw3_fisheye.pbrt",
    "ntu-dis-2015-dof-dragons/dof-dragons.dgauss.pbrt",
    "ntu-dis-2015-dof-dragons/dof-dragons.fisheye.pbrt",
    "ntu-dis-2015-dof-dragons/dof-dragons.telephoto.pbrt",
    "ntu-dis-2015-dof-dragons/dof-dragons.wide.pbrt",
    "pbrt-v4-refs/box-dgauss.pbrt",
    "pbrt-v4-refs/box-perspective.pbrt",
};
const std::set<std::string> kIncludedOnly = {"cs348b-hw3/hw3_scene.pbrt",
                                             "pbrt-v4-refs/box-world.pbrt"};
// Its geometry (hundreds of MB) is not in the shared folder.
const std::string kSanMiguel = "pbrt-v4-sanmiguel-realistic/sanmiguel-realistic-courtyard.pbrt";

TEST(SharedScenes, EveryTopLevelSceneChecksCleanly) {
  for (const std::string& name : kCleanScenes) {
    SCOPED_TRACE(name);
    Scene s;
    ASSERT_NO_THROW(s = loadScene((kScenes / name).string()));
    EXPECT_FALSE(s.camera.defaulted);
    EXPECT_FALSE(s.shapes.empty());
    EXPECT_FALSE(s.lights.empty());
  }
}

TEST(SharedScenes, EverySceneFileIsCovered) {
  std::set<std::string> known(kCleanScenes.begin(), kCleanScenes.end());
  known.insert(kIncludedOnly.begin(), kIncludedOnly.end());
  known.insert(kSanMiguel);
  for (const auto& e : fs::recursive_directory_iterator(kScenes)) {
    if (e.path().extension() != ".pbrt") continue;
    EXPECT_TRUE(known.count(e.path().lexically_relative(kScenes).generic_string()))
        << e.path() << ": a new scene; add it to kCleanScenes";
  }
}

TEST(SharedScenes, SanMiguelReportsEachMissingFileWithItsLocation) {
  // The San Miguel example ships without its geometry: every missing Include and the missing
  // sky texture are errors at their own line, and nothing else is.
  std::string path = (kScenes / kSanMiguel).string();
  Scene s = build(parseFile(path));
  std::ifstream in(path);
  std::string line;
  std::vector<int> include_lines;
  for (int n = 1; std::getline(in, line); ++n)
    if (line.rfind("Include", 0) == 0) include_lines.push_back(n);
  ASSERT_EQ(include_lines.size(), 21u);
  std::vector<int> error_lines;
  int sky = 0;
  for (const Diagnostic& d : s.diagnostics) {
    if (d.severity != Severity::Error) continue;
    EXPECT_EQ(d.loc.file, path);
    if (d.message.find("included file \"geometry/") == 0) {
      error_lines.push_back(d.loc.line);
      EXPECT_EQ(d.loc.column, 1);
    } else {
      EXPECT_EQ(d.message.find("environment map \"textures/sky.exr\" not found"), 0u) << d.str();
      EXPECT_EQ(d.loc.line, 38);
      ++sky;
    }
  }
  EXPECT_EQ(error_lines, include_lines);
  EXPECT_EQ(sky, 1);
  // The v4 realistic camera (the second Camera directive) is understood.
  ASSERT_TRUE(s.camera.realistic);
  EXPECT_EQ(s.camera.realistic->focus_distance_m, 40);
  EXPECT_EQ(s.camera.realistic->aperture_diameter_mm, 8.7);
  EXPECT_TRUE(fs::exists(s.camera.realistic->lens_file));
  EXPECT_EQ(s.film.iso, 1300);
  EXPECT_TRUE(hasWarning(s, "second Camera"));
  EXPECT_THROW(loadScene(path), Error);
}

TEST(SharedScenes, DofDragonsDgaussSummary) {
  Scene s = loadScene((kScenes / "ntu-dis-2015-dof-dragons/dof-dragons.dgauss.pbrt").string());
  // 11 instances of 2 cone objects.
  ASSERT_EQ(s.objects.size(), 2u);
  EXPECT_EQ(s.instances.size(), 11u);
  for (const ObjectDef& o : s.objects) {
    ASSERT_EQ(o.shapes.size(), 1u);
    const Shape& cone = s.shapes[static_cast<size_t>(o.shapes[0])];
    EXPECT_EQ(cone.type, ShapeType::Cone);
    EXPECT_EQ(cone.height, 0.15);
    EXPECT_EQ(cone.radius, 0.05);
    EXPECT_EQ(s.materials[static_cast<size_t>(cone.material)].type, "diffuse");
  }
  int b = 0;
  for (const Instance& i : s.instances)
    b += s.objects[static_cast<size_t>(i.object)].name == "dragon-b";
  EXPECT_EQ(b, 6);
  // A disk area light.
  ASSERT_EQ(s.lights.size(), 1u);
  EXPECT_EQ(s.lights[0].type, "diffuse");
  EXPECT_EQ(s.lights[0].emission.rgb, (Vec3{40, 40, 40}));
  EXPECT_EQ(s.lights[0].shape_count, 1);
  const Shape* disk = nullptr;
  for (const Shape& sh : s.shapes)
    if (sh.area_light == 0) disk = &sh;
  ASSERT_NE(disk, nullptr);
  EXPECT_EQ(disk->type, ShapeType::Disk);
  EXPECT_EQ(disk->radius, 8);
  // The imagemap → scale texture chain feeding the floor's matte Kd.
  ASSERT_EQ(s.textures.size(), 2u);
  EXPECT_EQ(s.textures[0].type, "imagemap");
  EXPECT_TRUE(s.textures[0].filename.ends_with("textures/lines.exr"));
  EXPECT_EQ(s.textures[1].type, "scale");
  EXPECT_EQ(s.textures[1].tex1.texture, 0);
  EXPECT_EQ(s.textures[1].tex2.spectrum.rgb, (Vec3{0.5, 0.5, 0.5}));
  const Shape& floor = s.shapes[1];
  EXPECT_EQ(floor.type, ShapeType::TriangleMesh);
  EXPECT_EQ(s.materials[static_cast<size_t>(floor.material)].as<DiffuseParams>().reflectance.texture, 1);
  EXPECT_EQ(s.meshes[static_cast<size_t>(floor.mesh)].uvs.size(), 4u);
  // The legacy realistic camera, in millimetres.
  ASSERT_TRUE(s.camera.legacy_realistic);
  const LegacyRealistic& r = *s.camera.legacy_realistic;
  EXPECT_EQ(r.film_distance_mm, 36.77);
  EXPECT_EQ(r.aperture_diameter_mm, 17.1);
  EXPECT_EQ(r.film_diagonal_mm, 70);
  EXPECT_EQ(r.lens_file_as_written, "dgauss.50mm.dat");
  EXPECT_TRUE(fs::exists(r.lens_file));
  EXPECT_EQ(s.camera.hither, 0.001);
  EXPECT_EQ(s.camera.yon, 1e30);
  EXPECT_NEAR(length(s.camera.camera_from_world.applyVector({1, 0, 0})), 5000, 1e-9);
  EXPECT_EQ(s.film.x_resolution, 300);
  EXPECT_EQ(s.film.filename, "dof-dragons.dgauss512.exr");
  EXPECT_EQ(s.sampler.pixel_samples, 4);

  std::string text = summary(s);
  EXPECT_NE(text.find("instances: 11: \"dragon-b\" ×6, \"dragon-a\" ×5"), std::string::npos)
      << text;
  EXPECT_NE(text.find("focus: film distance 36.77 mm"), std::string::npos) << text;
  EXPECT_NE(text.find("\"sgrid\": spectrum scale: texture \"grid\" × rgb [0.5 0.5 0.5]"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("area light area (as diffuse): L rgb [40 40 40], on 1 shape (disk ×1)"),
            std::string::npos)
      << text;
}

TEST(SharedScenes, Hw3MeasuredMaterialsAreBuilt) {
  Scene s = loadScene((kScenes / "cs348b-hw3/hw3_dgauss.pbrt").string());
  for (const Diagnostic& d : s.diagnostics)
    EXPECT_EQ(d.message.find("\"measured\""), std::string::npos) << d.str();
  int measured = 0;
  for (const Material& m : s.materials)
    if (m.type == "measured") {
      ++measured;
      const MeasuredParams& p = m.as<MeasuredParams>();
      EXPECT_TRUE(p.file.ends_with(".brdf"));
      EXPECT_TRUE(std::filesystem::exists(p.file)) << p.file;
    }
  EXPECT_EQ(measured, 5);
  EXPECT_EQ(s.instances.size(), 16u);
  EXPECT_EQ(s.objects.size(), 5u);
  // pbrt-v2 syntax (a specfile camera): image textures keep v2's row order.
  for (const Texture& t : s.textures) EXPECT_TRUE(t.rows_from_top) << t.name;
}

TEST(SharedScenes, BoxDgaussV4RealisticCamera) {
  Scene s = loadScene((kScenes / "pbrt-v4-refs/box-dgauss.pbrt").string());
  ASSERT_TRUE(s.camera.realistic);
  EXPECT_EQ(s.camera.realistic->aperture_diameter_mm, 12.5);
  EXPECT_EQ(s.camera.realistic->focus_distance_m, 2.2);
  EXPECT_EQ(Realistic::kSceneUnitsPerLensUnit, 0.001);
  EXPECT_TRUE(fs::exists(s.camera.realistic->lens_file));
  EXPECT_EQ(s.film.diagonal_mm, 43.3);
  EXPECT_EQ(s.integrator.max_depth, 10);
  EXPECT_EQ(warningCount(s), 0u);
  int conductors = 0;
  for (const Material& m : s.materials)
    if (m.type == "conductor") {
      ++conductors;
      EXPECT_EQ(m.as<ConductorParams>().index.eta.spectrum.name, "metal-Au-eta");
      EXPECT_EQ(m.as<ConductorParams>().roughness.u.value, 0.1);
    }
  EXPECT_EQ(conductors, 1);
}

// ---- parameters -------------------------------------------------------------------------------

TEST(Params, UnusedParametersAreErrorsAtTheirLocation) {
  Scene s = testutil::buildText(
      "WorldBegin\nShape \"sphere\" \"float radius\" 1\n  \"float raduis\" 2\n", "u.pbrt");
  EXPECT_EQ(testutil::errorsOf(s),
            "u.pbrt:3:3: error: \"raduis\": unused parameter; did you mean \"radius\"?\n");
}

TEST(Params, RenamedParametersAreAcceptedUnderTheirOldNames) {
  testutil::TempDir dir("lensim-renamed");
  dir.write("sky.exr", "");
  std::string path = dir.write(
      "s.pbrt",
      "WorldBegin\n"
      "Material \"matte\" \"color Kd\" [.1 .2 .3]\n"
      "Material \"plastic\" \"color Kd\" [.4 .4 .4] \"color Ks\" [.1 .1 .1] \"float roughness\" "
      ".2\n"
      "Material \"uber\" \"color Kd\" [.5 .5 .5] \"float roughness\" .3\n"
      "Material \"glass\" \"float index\" 1.7\n"
      "Material \"metal\" \"spectrum eta\" \"metal-Ag-eta\" \"spectrum k\" \"metal-Ag-k\"\n"
      "Material \"mirror\" \"color Kr\" [.8 .8 .8]\n"
      "AreaLightSource \"area\" \"color L\" [1 2 3] \"integer nsamples\" 4\n"
      "LightSource \"infinite\" \"string mapname\" \"sky.exr\"\n");
  Scene s = build(parseFile(path));
  EXPECT_EQ(testutil::errorsOf(s), "");
  ASSERT_EQ(s.materials.size(), 6u);
  EXPECT_EQ(s.materials[0].type, "diffuse");
  EXPECT_EQ(s.materials[0].as<DiffuseParams>().reflectance.spectrum.rgb, (Vec3{.1, .2, .3}));
  // pbrt-v3's materials keep their names and are rendered as pbrt-v3 defines them.
  EXPECT_EQ(s.materials[1].type, "plastic");
  EXPECT_EQ(s.materials[1].as<PlasticParams>().roughness.u.value, 0.2);
  EXPECT_EQ(s.materials[1].as<PlasticParams>().ks.spectrum.rgb, (Vec3{.1, .1, .1}));
  EXPECT_EQ(s.materials[2].type, "uber");
  EXPECT_EQ(s.materials[2].as<UberParams>().kd.spectrum.rgb, (Vec3{.5, .5, .5}));
  EXPECT_EQ(s.materials[3].type, "glass");
  EXPECT_EQ(s.materials[3].as<GlassParams>().eta.value, 1.7);
  EXPECT_EQ(s.materials[4].type, "metal");
  EXPECT_EQ(s.materials[4].as<MetalParams>().k.spectrum.name, "metal-Ag-k");
  EXPECT_EQ(s.materials[5].type, "mirror");
  EXPECT_EQ(s.materials[5].as<MirrorParams>().kr.spectrum.rgb, (Vec3{.8, .8, .8}));
  ASSERT_EQ(s.lights.size(), 2u);
  EXPECT_EQ(s.lights[0].type, "diffuse");
  EXPECT_EQ(s.lights[0].emission.rgb, (Vec3{1, 2, 3}));
  EXPECT_TRUE(s.lights[1].filename.ends_with("sky.exr"));
  EXPECT_FALSE(hasWarning(s, "\"Ks\""));

  Scene f = testutil::buildText(
      "PixelFilter \"gaussian\" \"float xwidth\" 2 \"float ywidth\" 3\n"
      "WorldBegin\n");
  EXPECT_EQ(f.filter.x_radius, 2);
  EXPECT_EQ(f.filter.y_radius, 3);
}

TEST(Params, WrongTypeForAKnownParameterIsAnError) {
  Scene s = testutil::buildText("WorldBegin\nShape \"disk\" \"rgb radius\" [1 1 1]\n", "t.pbrt");
  EXPECT_EQ(testutil::errorsOf(s),
            "t.pbrt:2:14: error: \"radius\": wrong parameter type \"rgb\" for Shape \"disk\" "
            "parameter; expected float\n");
}

TEST(Params, AttributeDefaultsApplyAndAreOverridden) {
  Scene s = testutil::buildText(
      "WorldBegin\nAttributeBegin\nAttribute \"shape\" \"float radius\" 3\nShape \"sphere\"\n"
      "Shape \"sphere\" \"float radius\" 4\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 "
      "0]\n"
      "AttributeEnd\nShape \"sphere\"\n");
  EXPECT_EQ(testutil::errorsOf(s), "");
  ASSERT_EQ(s.shapes.size(), 4u);
  EXPECT_EQ(s.shapes[0].radius, 3);
  EXPECT_EQ(s.shapes[1].radius, 4);
  EXPECT_EQ(s.shapes[3].radius, 1);
}

// ---- shapes -------------------------------------------------------------------------------------

TEST(Shapes, QuadricParameters) {
  Scene s = testutil::buildText(
      "WorldBegin\n"
      "Shape \"sphere\" \"float radius\" 2 \"float zmin\" -1 \"float zmax\" 1.5 \"float phimax\" "
      "180\n"
      "Shape \"disk\" \"float height\" 0.5 \"float radius\" 3 \"float innerradius\" 1 \"float "
      "phimax\" 90\n"
      "Shape \"cylinder\" \"float radius\" 0.5 \"float zmin\" 0 \"float zmax\" 2\n"
      "Shape \"cone\" \"float height\" 0.15 \"float radius\" 0.05 \"float phimax\" 360\n");
  ASSERT_EQ(s.shapes.size(), 4u) << testutil::errorsOf(s);
  EXPECT_EQ(s.shapes[0].zmin, -1);
  EXPECT_EQ(s.shapes[0].zmax, 1.5);
  EXPECT_EQ(s.shapes[0].phimax_deg, 180);
  EXPECT_EQ(s.shapes[1].height, 0.5);
  EXPECT_EQ(s.shapes[1].inner_radius, 1);
  EXPECT_EQ(s.shapes[2].zmax, 2);
  EXPECT_EQ(s.shapes[3].type, ShapeType::Cone);
  Bounds3 b = objectBounds(s, s.shapes[3]);
  EXPECT_EQ(b.max.z, 0.15);
  Scene bad = testutil::buildText("WorldBegin\nShape \"sphere\" \"float phimax\" 400\n", "p.pbrt");
  EXPECT_EQ(testutil::errorsOf(bad), "p.pbrt:2:16: error: phimax 400 outside (0, 360] degrees\n");
}

TEST(Shapes, TriangleMeshes) {
  Scene s = testutil::buildText(
      "WorldBegin\n"
      "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0]\n"  // three vertices, no indices
      "Shape \"trianglemesh\" \"point P\" [0 0 0 1 0 0 1 1 0 0 1 0] \"integer indices\" [0 1 2 0 2 "
      "3]\n"
      "  \"normal N\" [0 0 1 0 0 1 0 0 1 0 0 1] \"vector S\" [1 0 0 1 0 0 1 0 0 1 0 0]\n"
      "  \"float uv\" [0 0 1 0 1 1 0 1]\n"
      "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0] \"point2 uv\" [0 0 1 0 0 1]\n"
      "  \"float alpha\" 0.5\n"
      "Shape \"bilinearmesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0 1 1 0]\n");
  ASSERT_EQ(s.meshes.size(), 4u) << testutil::errorsOf(s);
  EXPECT_EQ(s.meshes[0].indices, (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(s.meshes[1].faceCount(), 2u);
  EXPECT_EQ(s.meshes[1].normals.size(), 4u);
  EXPECT_EQ(s.meshes[1].tangents.size(), 4u);
  EXPECT_EQ(s.meshes[1].uvs[2], (std::array<float, 2>{1, 1}));
  EXPECT_EQ(s.meshes[2].uvs.size(), 3u);
  ASSERT_TRUE(s.shapes[2].alpha);
  EXPECT_EQ(s.shapes[2].alpha->value, 0.5);
  EXPECT_EQ(s.shapes[3].type, ShapeType::BilinearMesh);
  EXPECT_EQ(s.meshes[3].vertices_per_face, 4);
  EXPECT_EQ(s.triangleCount(), 1u + 2u + 1u + 2u);

  Scene n = testutil::buildText(
      "WorldBegin\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0 1 1 0]\n"
      "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0] \"normal N\" [0 0 1]\n",
      "m.pbrt");
  EXPECT_EQ(testutil::errorsOf(n),
            "m.pbrt:2:1: error: trianglemesh: missing \"integer indices\" (only a single triangle "
            "may omit them)\n"
            "m.pbrt:3:53: error: \"N\": expected one value per vertex (3), got 1\n");
}

TEST(Shapes, LoopSubdivisionRefinesToTheGivenLevel) {
  // A tetrahedron: V = 4, E = 6, F = 4. Each level: V' = V + E, E' = 2E + 3F, F' = 4F.
  const std::string tetra =
      "\"point P\" [1 1 1  -1 -1 1  -1 1 -1  1 -1 -1] \"integer indices\" [0 1 2  0 3 1  0 2 3  1 "
      "3 2]";
  Scene s = testutil::buildText("WorldBegin\nShape \"loopsubdiv\" \"integer nlevels\" 1 " + tetra +
                                "\nShape \"loopsubdiv\" \"integer levels\" 2 " + tetra + "\n");
  ASSERT_EQ(s.meshes.size(), 2u) << testutil::errorsOf(s);
  EXPECT_EQ(s.meshes[0].positions.size(), 10u);
  EXPECT_EQ(s.meshes[0].faceCount(), 16u);
  EXPECT_EQ(s.meshes[1].positions.size(), 34u);
  EXPECT_EQ(s.meshes[1].faceCount(), 64u);
  // Loop subdivision shrinks a convex surface toward its inside; by symmetry the centroid stays.
  Vec3 c;
  for (const Vec3f& p : s.meshes[1].positions) {
    EXPECT_LT(std::abs(p.x), 1.0f);
    c += Vec3(p);
  }
  EXPECT_NEAR(length(c), 0, 1e-6);
  // Level 1: the original vertex (1,1,1) of valence 3 moves to 7/16 v + 3/16 (sum of
  // neighbours) = (1/4, 1/4, 1/4); its new neighbours are the edge points (1/2, 0, 0),
  // (0, 1/2, 0), (0, 0, 1/2). The limit rule (valence 3: g = 1/5) then gives
  // 2/5 · 1/4 + 1/5 · 1/2 = 1/5 in each coordinate.
  EXPECT_NEAR(s.meshes[0].positions[0].x, 0.2f, 1e-6);
  EXPECT_NEAR(s.meshes[0].positions[0].z, 0.2f, 1e-6);
  // A flat open mesh stays flat, and its straight boundary stays straight.
  Scene flat = testutil::buildText(
      "WorldBegin\nShape \"loopsubdiv\" \"integer levels\" 2 \"point3 P\" [0 0 0 2 0 0 2 2 0 0 2 0]"
      " \"integer indices\" [0 1 2 0 2 3]\n");
  ASSERT_EQ(flat.meshes.size(), 1u);
  EXPECT_EQ(flat.meshes[0].faceCount(), 32u);
  for (const Vec3f& p : flat.meshes[0].positions) {
    EXPECT_EQ(p.z, 0.0f);
    EXPECT_GE(p.x, -1e-6f);
    EXPECT_LE(p.x, 2.0f + 1e-6f);
  }
}

TEST(Shapes, CarryMaterialAreaLightAndObject) {
  Scene s = testutil::buildText(
      "WorldBegin\nMakeNamedMaterial \"red\" \"string type\" \"diffuse\" \"rgb reflectance\" [1 0 "
      "0]\n"
      "AttributeBegin\nAreaLightSource \"diffuse\" \"blackbody L\" 6500 \"float scale\" 2\n"
      "NamedMaterial \"red\"\nShape \"sphere\"\nAttributeEnd\nShape \"sphere\"\n"
      "ObjectBegin \"o\"\nMaterial \"conductor\"\nShape \"disk\"\nObjectEnd\n"
      "ObjectInstance \"o\"\nObjectInstance \"o\"\nObjectInstance \"o\"\n");
  ASSERT_EQ(s.shapes.size(), 3u) << testutil::errorsOf(s);
  EXPECT_EQ(s.materials[static_cast<size_t>(s.shapes[0].material)].name, "red");
  EXPECT_EQ(s.shapes[0].area_light, 0);
  EXPECT_EQ(s.lights[0].emission.kind, SpectrumValue::Kind::Blackbody);
  EXPECT_EQ(s.lights[0].emission.temperature_k, 6500);
  EXPECT_EQ(s.lights[0].scale, 2);
  EXPECT_EQ(s.shapes[1].area_light, -1);
  EXPECT_EQ(s.materials[static_cast<size_t>(s.shapes[1].material)].type_as_written, "(default)");
  // Instancing keeps one copy of the geometry.
  EXPECT_EQ(s.shapes[2].object, 0);
  EXPECT_EQ(s.instances.size(), 3u);
  EXPECT_EQ(s.objects[0].shapes, std::vector<int>{2});
}

TEST(Shapes, PlyMeshesAreLoadedRelativeToTheScene) {
  testutil::TempDir dir("lensim-plyscene");
  dir.write("meshes/quad.ply",
            "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
            "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
            "0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n");
  std::string path = dir.write(
      "s.pbrt", "WorldBegin\nShape \"plymesh\" \"string filename\" \"meshes/quad.ply\"\n");
  Scene s = loadScene(path);
  ASSERT_EQ(s.meshes.size(), 1u);
  EXPECT_EQ(s.meshes[0].faceCount(), 2u);
  EXPECT_EQ(s.meshes[0].positions.size(), 4u);
}

// ---- other descriptions -----------------------------------------------------------------------

TEST(Builder, UnsupportedTypesWarnOnceWithAFallback) {
  Scene s = testutil::buildText(
      "Camera \"environment\"\nSampler \"bestcandidate\" \"integer pixelsamples\" 8\n"
      "Film \"photo\"\nIntegrator \"mlt\" \"integer maxdepth\" 7\nWorldBegin\n"
      "Material \"kdsubsurface\" \"float eta\" 1\nMaterial \"kdsubsurface\"\n"
      "Shape \"curve\" \"point3 P\" [0 0 0 1 1 1 2 2 2 3 3 3]\n"
      "Texture \"w\" \"float\" \"ptex\"\nLightSource \"sky\"\n",
      "w.pbrt");
  EXPECT_EQ(testutil::errorsOf(s), "");
  EXPECT_EQ(warningCount(s), 7u);  // the curve is built (issue 12), not warned
  EXPECT_TRUE(
      hasWarning(s, "material \"kdsubsurface\" is not rendered by lensim; it renders as diffuse"));
  EXPECT_EQ(s.diagnostics[0].loc.str(), "w.pbrt:1:1");
  EXPECT_EQ(s.sampler.pixel_samples, 8);
  EXPECT_EQ(s.integrator.max_depth, 7);
  ASSERT_EQ(s.shapes.size(), 1u);
  EXPECT_EQ(s.shapes[0].type, ShapeType::Curve);
  EXPECT_TRUE(s.lights.empty());
  EXPECT_TRUE(s.materials[0].fallback);
}

TEST(Builder, TexturesOfAllKinds) {
  Scene s = testutil::buildText(
      "WorldBegin\nTexture \"f\" \"float\" \"constant\" \"float value\" 0.25\n"
      "Texture \"c\" \"spectrum\" \"checkerboard\" \"float uscale\" 4 \"rgb tex1\" [1 0 0] "
      "\"texture tex2\" \"x\"\n");
  EXPECT_EQ(testutil::errorsOf(s), "test.pbrt:3:75: error: unknown spectrum texture \"x\"\n");
  Scene t = testutil::buildText(
      "WorldBegin\nTexture \"f\" \"float\" \"constant\" \"float value\" 0.25\n"
      "Texture \"s\" \"spectrum\" \"scale\" \"rgb tex\" [1 1 1] \"texture scale\" \"f\"\n"
      "Texture \"m\" \"color\" \"mix\" \"texture tex1\" \"s\" \"color tex2\" [0 0 1] \"texture "
      "amount\" \"f\"\n"
      "Material \"diffuse\" \"texture reflectance\" \"m\"\n");
  ASSERT_EQ(t.textures.size(), 3u) << testutil::errorsOf(t);
  EXPECT_EQ(t.textures[0].tex1.value, 0.25);
  EXPECT_EQ(t.textures[1].tex2.texture, 0);
  EXPECT_TRUE(t.textures[1].scale_is_float);
  EXPECT_EQ(t.textures[2].amount.texture, 0);
  EXPECT_EQ(t.materials[0].as<DiffuseParams>().reflectance.texture, 2);
}

TEST(Builder, DefaultsFollowTheSyntaxVersion) {
  Scene v4 = testutil::buildText("WorldBegin\n");
  EXPECT_EQ(v4.film.x_resolution, 1280);
  EXPECT_EQ(v4.filter.type, "gaussian");
  Scene v2 = testutil::buildText("WorldBegin\nWorldEnd\n");
  EXPECT_TRUE(v2.legacy_syntax);
  EXPECT_EQ(v2.film.x_resolution, 640);
  EXPECT_EQ(v2.filter.type, "box");
  EXPECT_EQ(v2.filter.x_radius, 0.5);
}

TEST(Format, ReprintedSceneBuildsToTheSameScene) {
  for (const std::string& name : kCleanScenes) {
    SCOPED_TRACE(name);
    std::string path = (kScenes / name).string();
    SceneDesc d = parseFile(path);
    Scene a = build(d);
    std::string text = formatPbrtV4(d);
    // Parsed under the original name so that relative file names resolve the same way.
    Scene b = build(parseString(text, path));
    EXPECT_EQ(testutil::errorsOf(b), "") << text;
    EXPECT_EQ(a.shapes.size(), b.shapes.size());
    EXPECT_EQ(a.instances.size(), b.instances.size());
    EXPECT_EQ(a.triangleCount(), b.triangleCount());
    EXPECT_EQ(a.materials.size(), b.materials.size());
    EXPECT_EQ(a.textures.size(), b.textures.size());
    EXPECT_EQ(a.lights.size(), b.lights.size());
    EXPECT_EQ(text.find("\"color "), std::string::npos);
    EXPECT_EQ(text.find("WorldEnd"), std::string::npos);
    EXPECT_EQ(text.find("\"matte\""), std::string::npos);
  }
}

TEST(Camera, LegacyRealisticKeepsMillimetresAndResolvesFiles) {
  testutil::TempDir dir("lensim-legacycam");
  dir.write("lens/d.dat", "# lens\n");
  dir.write("zones.txt", ".3 .4 .3 .4\n");
  std::string path = dir.write(
      "s.pbrt",
      "Scale 1000 1000 1000\nCamera \"realistic\" \"string specfile\" \"lens/d.dat\"\n"
      "  \"float filmdistance\" 40.5 \"float aperture_diameter\" 10 \"float filmdiag\" 43.3\n"
      "  \"string af_zones\" \"zones.txt\" \"float hither\" 0.01 \"float yon\" 1e5\n"
      "  \"float shutteropen\" 0 \"float shutterclose\" 0.5\nWorldBegin\n");
  Scene s = loadScene(path);
  ASSERT_TRUE(s.camera.legacy_realistic);
  const LegacyRealistic& r = *s.camera.legacy_realistic;
  EXPECT_EQ(r.film_distance_mm, 40.5);
  EXPECT_EQ(r.aperture_diameter_mm, 10);
  EXPECT_EQ(r.film_diagonal_mm, 43.3);
  EXPECT_EQ(fs::path(r.lens_file), (dir.path() / "lens/d.dat").lexically_normal());
  EXPECT_EQ(fs::path(r.af_zones_file), (dir.path() / "zones.txt").lexically_normal());
  EXPECT_EQ(s.camera.hither, 0.01);
  EXPECT_EQ(s.camera.shutter_close, 0.5);
  EXPECT_EQ(s.camera.loc.file, path);
  EXPECT_NE(summary(s).find("camera space: millimetres, 1000 mm per world unit"), std::string::npos)
      << summary(s);

  Scene bad =
      testutil::buildText("Camera \"realistic\" \"string specfile\" \"" + dir.file("lens/d.dat") +
                              "\" \"float filmdistance\" 40\nWorldBegin\n",
                          "b.pbrt");
  EXPECT_EQ(testutil::errorsOf(bad),
            "b.pbrt:1:1: error: realistic camera: missing \"float aperture_diameter\" (mm)\n");
}

TEST(Camera, V3RealisticParameters) {
  testutil::TempDir dir("lensim-v3cam");
  dir.write("wide.dat", "# lens\n");
  std::string path = dir.write(
      "s.pbrt",
      "Camera \"realistic\" \"string lensfile\" \"wide.dat\" \"float aperturediameter\" 4\n"
      "  \"float focusdistance\" 1.5 \"bool simpleweighting\" false \"string aperture\" \"star\"\n"
      "WorldBegin\n");
  Scene s = loadScene(path);
  ASSERT_TRUE(s.camera.realistic);
  EXPECT_EQ(s.camera.realistic->aperture_diameter_mm, 4);
  EXPECT_EQ(s.camera.realistic->focus_distance_m, 1.5);
  EXPECT_FALSE(s.camera.realistic->simple_weighting);
  EXPECT_EQ(s.camera.realistic->aperture, "star");
}

TEST(Builder, SpectraOfAllForms) {
  testutil::TempDir dir("lensim-spectra");
  dir.write("spd/led.spd", "400 1\n700 2\n");
  std::string path = dir.write(
      "s.pbrt",
      "WorldBegin\nLightSource \"point\" \"spectrum I\" \"spd/led.spd\"\n"
      "LightSource \"point\" \"spectrum I\" [400 1 500 2 600 3]\n"
      "LightSource \"point\" \"blackbody I\" [5500 2]\n"
      "LightSource \"spot\" \"spectrum I\" \"stdillum-D65\" \"point3 "
      "from\" [0 1 0] \"point3 to\" [0 0 0]\n"
      "LightSource \"point\" \"spectrum I\" \"nothere.spd\"\n"
      "Material \"conductor\" \"spectrum eta\" \"metal-Au-et\" \"spectrum k\" \"metal-Au-k\"\n");
  Scene s = build(parseFile(path));
  ASSERT_EQ(s.lights.size(), 4u);
  EXPECT_EQ(s.lights[0].emission.kind, SpectrumValue::Kind::File);
  EXPECT_TRUE(s.lights[0].emission.name.ends_with("spd/led.spd"));
  EXPECT_EQ(s.lights[1].emission.samples.size(), 3u);
  EXPECT_EQ(s.lights[1].emission.samples[2], (std::pair<double, double>{600, 3}));
  EXPECT_EQ(s.lights[2].emission.blackbody_scale, 2);
  EXPECT_EQ(s.lights[3].emission.kind, SpectrumValue::Kind::Named);
  EXPECT_EQ(s.lights[3].from, (Vec3{0, 1, 0}));
  EXPECT_NE(
      testutil::errorsOf(s).find("s.pbrt:6:21: error: spectrum file \"nothere.spd\" not found"),
      std::string::npos)
      << testutil::errorsOf(s);
  EXPECT_NE(testutil::errorsOf(s).find("s.pbrt:7:22: error: \"eta\": unknown named spectrum "
                                       "\"metal-Au-et\"; did you mean \"metal-Au-eta\"?"),
            std::string::npos)
      << testutil::errorsOf(s);
}

TEST(Builder, OptionsAndUnknownOptions) {
  Scene s = testutil::buildText(
      "Option \"bool disablepixeljitter\" true\nOption \"seed\" 7\n"
      "Option \"rendercoordsys\" \"world\"\n"
      "Option \"bool nosuchoption\" false\nWorldBegin\n",
      "o.pbrt");
  EXPECT_EQ(s.options.at("disablepixeljitter"), "true");
  EXPECT_EQ(s.options.at("seed"), "7");
  EXPECT_EQ(s.options.at("rendercoordsys"), "world");
  EXPECT_EQ(testutil::errorsOf(s), "o.pbrt:4:8: error: \"nosuchoption\": unknown option\n");
}

TEST(Builder, AlphaTexturesAndNamedMaterials) {
  Scene s = testutil::buildText(
      "WorldBegin\nTexture \"mask\" \"float\" \"checkerboard\"\n"
      "MakeNamedMaterial \"glass\" \"string type\" \"dielectric\" \"spectrum eta\" \"glass-BK7\"\n"
      "NamedMaterial \"glass\"\nShape \"sphere\" \"texture alpha\" \"mask\"\n");
  ASSERT_EQ(s.shapes.size(), 1u) << testutil::errorsOf(s);
  ASSERT_TRUE(s.shapes[0].alpha);
  EXPECT_EQ(s.shapes[0].alpha->texture, 0);
  const Material& m = s.materials[static_cast<size_t>(s.shapes[0].material)];
  EXPECT_EQ(m.name, "glass");
  EXPECT_EQ(m.as<DielectricParams>().eta.spectrum.name, "glass-BK7");
  Scene bad = testutil::buildText(
      "WorldBegin\nMakeNamedMaterial \"x\" \"rgb reflectance\" [1 1 1]\n", "n.pbrt");
  EXPECT_EQ(testutil::errorsOf(bad),
            "n.pbrt:2:1: error: MakeNamedMaterial \"x\": missing \"string type\"\n");
}

TEST(Shapes, GzippedPlyMeshInAScene) {
  testutil::TempDir dir("lensim-plygzscene");
  std::string ply =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
      "property float u\nproperty float v\nelement face 1\n"
      "property list uchar int vertex_indices\nend_header\n"
      "0 0 0 0 0 1 0 0\n1 0 0 0 0 1 1 0\n0 1 0 0 0 1 0 1\n3 0 1 2\n";
  gzFile f = gzopen(dir.file("tri.ply.gz").c_str(), "wb");
  ASSERT_NE(f, nullptr);
  gzwrite(f, ply.data(), static_cast<unsigned>(ply.size()));
  gzclose(f);
  std::string path =
      dir.write("s.pbrt", "WorldBegin\nShape \"plymesh\" \"string filename\" \"tri.ply.gz\"\n");
  Scene s = loadScene(path);
  ASSERT_EQ(s.meshes.size(), 1u);
  EXPECT_EQ(s.meshes[0].normals.size(), 3u);
  EXPECT_EQ(s.meshes[0].uvs.size(), 3u);
  EXPECT_EQ(s.triangleCount(), 1u);
}

TEST(Format, NormalisesVersionOneToThreeNames) {
  SceneDesc d = parseString(
      "Option \"seed\" 3\nFilter \"gaussian\" \"float xwidth\" 2\n"
      "SurfaceIntegrator \"directlighting\" \"integer maxdepth\" 5\n"
      "Sampler \"lowdiscrepancy\" \"integer pixelsamples\" 4\nFilm \"image\"\nWorldBegin\n"
      "AttributeBegin\nMaterial \"glass\" \"float index\" 1.5\n"
      "Shape \"trianglemesh\" \"point P\" [0 0 0 1 0 0 0 1 0] \"normal N\" [0 0 1 0 0 1 0 0 1]\n"
      "AttributeEnd\nWorldEnd\n",
      "f.pbrt");
  std::string text = formatPbrtV4(d);
  EXPECT_NE(text.find("Option \"seed\" 3\n"), std::string::npos) << text;
  EXPECT_NE(text.find("PixelFilter \"gaussian\" \"float xradius\" 2\n"), std::string::npos) << text;
  EXPECT_NE(text.find("Integrator \"path\" \"integer maxdepth\" 1\n"), std::string::npos) << text;
  EXPECT_NE(text.find("Sampler \"paddedsobol\" \"integer pixelsamples\" 4\n"), std::string::npos)
      << text;
  EXPECT_NE(text.find("Film \"rgb\"\n"), std::string::npos) << text;
  EXPECT_NE(text.find("  Material \"dielectric\" \"float eta\" 1.5\n"), std::string::npos) << text;
  EXPECT_NE(text.find("\"point3 P\" [ 0 0 0 1 0 0 0 1 0 ] \"normal N\" [ 0 0 1 0 0 1 0 0 1 ]"),
            std::string::npos)
      << text;
  EXPECT_EQ(text.find("WorldEnd"), std::string::npos) << text;
  Scene s = build(parseString(text, "f.pbrt"));
  EXPECT_EQ(testutil::errorsOf(s), "");
  EXPECT_EQ(s.integrator.max_depth, 1);
}
