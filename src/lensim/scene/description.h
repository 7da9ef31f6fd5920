// Phase 2 of scene loading: validates a SceneDesc and builds the typed descriptions the renderer
// consumes (shapes and meshes, object instances, materials, textures, lights, camera, film,
// sampler, filter, integrator).
//
// Units: scene space is metres, as in pbrt-v4. Camera parameters keep the units the file uses,
// named in the field (`film_distance_mm`); pbrt-v1/v2 `realistic` cameras work in camera-space
// millimetres (their scenes put `Scale 5000 5000 5000` or similar before the camera).
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "lensim/scene/curves.h"
#include "lensim/scene/material.h"
#include "lensim/scene/parser.h"
#include "lensim/scene/realistic_options.h"
#include "lensim/util/animated_transform.h"
#include "lensim/scene/sensor_config.h"
#include "lensim/util/error.h"
#include "lensim/util/transform.h"
#include "lensim/util/vec.h"

namespace lensim::scene {

/// Texture value kind, as in pbrt's `Texture "name" "float"|"spectrum" ...`.
enum class TextureKind { Float, Spectrum };

/// A texture description. `type` is the pbrt-v4 class lensim renders: imagemap, scale (product
/// of tex1 and tex2), mix, directionmix, checkerboard, constant (tex1), or the procedural fbm,
/// wrinkled, windy, marble, dots, bilerp (render/textures/procedural.h).
struct Texture {
  std::string name;
  TextureKind kind = TextureKind::Spectrum;
  std::string type;             ///< rendered class
  std::string type_as_written;  ///< class in the file
  FileLoc loc;
  Transform texture_from_world;  ///< inverse of the transform at the declaration (3D mappings)
  // imagemap
  std::string filename;  ///< resolved path of the image
  std::string filename_as_written;
  double uscale = 1, vscale = 1, udelta = 0, vdelta = 0;
  std::string mapping = "uv";     ///< uv, spherical, cylindrical, planar
  Vec3 v1{1, 0, 0}, v2{0, 1, 0};  ///< planar mapping axes
  std::string wrap = "repeat";
  std::string encoding;  ///< "sRGB", "linear", "gamma g"; empty: by file type
  /// Image rows run with t from the top (pbrt-v1/v2) instead of from the bottom (v3/v4).
  bool rows_from_top = false;
  double scale = 1;
  bool invert = false;
  std::string filter = "bilinear";
  double max_anisotropy = 8;
  // scale, mix, checkerboard, constant
  Input tex1, tex2;
  bool scale_is_float = false;  ///< scale: tex2 is pbrt-v4's float `scale`
  Input amount;                 ///< mix
  Vec3 direction{0, 1, 0};      ///< directionmix: world-space unit direction
  int dimension = 2;            ///< checkerboard
  // fbm, wrinkled, marble (octaves, roughness = omega, marble variation; marble also uses
  // `scale`); dots (tex1 inside, tex2 outside); bilerp (v00, v01, v10, v11).
  int octaves = 8;
  double omega = 0.5, variation = 0.2;
  Input v00, v01, v10, v11;
};

/// Kinds of shape lensim builds; meshes live in Scene::meshes.
enum class ShapeType { Sphere, Disk, Cylinder, Cone, TriangleMesh, BilinearMesh, Curve };
std::string_view shapeTypeName(ShapeType t);

/// A triangle (3 indices per face) or bilinear-patch (4) mesh in object space.
struct Mesh {
  int vertices_per_face = 3;
  std::vector<Vec3f> positions;
  std::vector<int> indices;
  std::vector<Vec3f> normals;             ///< empty or one per vertex
  std::vector<Vec3f> tangents;            ///< `S`: empty or one per vertex
  std::vector<std::array<float, 2>> uvs;  ///< empty or one per vertex
  std::vector<int> face_indices;
  std::string source;  ///< PLY file it came from, if any
  size_t faceCount() const { return indices.size() / static_cast<size_t>(vertices_per_face); }
};

/// A shape with everything that applies to it. Quadrics are in object space (z is their axis).
struct Shape {
  ShapeType type = ShapeType::Sphere;
  std::string type_as_written;
  FileLoc loc;
  /// object → world; for shapes of an object definition, object → instance.
  Transform transform;
  bool reverse_orientation = false;
  int material = -1;           ///< index into Scene::materials
  int area_light = -1;         ///< index into Scene::lights, or -1
  std::optional<Input> alpha;  ///< float: 1 opaque, 0 cut out
  int object = -1;             ///< index into Scene::objects when part of an object definition
  // Quadrics (scene units, degrees).
  double radius = 1, inner_radius = 0, height = 0, zmin = -1, zmax = 1, phimax_deg = 360;
  int mesh = -1;   ///< index into Scene::meshes for meshes
  int curve = -1;  ///< index into Scene::curves for curves
  /// Index into Scene::motions when the transform is animated (ActiveTransform; `transform` is
  /// then the start transform), -1 for a static shape.
  int motion = -1;
  /// MediumInterface at the shape: indices into Scene::media, -1 for vacuum. A shape whose
  /// inside and outside are the same is no medium boundary (rays keep their medium, as pbrt-v4).
  int inside_medium = -1, outside_medium = -1;

  /// pbrt's rule: normals are flipped if ReverseOrientation xor the transform swaps handedness.
  bool flipNormals() const { return reverse_orientation != transform.swapsHandedness(); }
};

/// An object definition (ObjectBegin/ObjectEnd): shapes stored once, referenced by instances.
struct ObjectDef {
  std::string name;
  FileLoc loc;
  std::vector<int> shapes;  ///< indices into Scene::shapes
};

/// One ObjectInstance.
struct Instance {
  int object = -1;      ///< index into Scene::objects
  Transform transform;  ///< instance → world
  FileLoc loc;
  int motion = -1;  ///< index into Scene::motions when animated (`transform`: the start)
};

/// A light description. `type` is the pbrt-v4 light type: point, spot, goniometric, projection,
/// distant, infinite, diffuse (area lights, attached to shapes through Shape::area_light).
struct Light {
  std::string type;
  std::string type_as_written;
  FileLoc loc;
  Transform transform;  ///< light → world
  SpectrumValue emission =
      SpectrumValue::gray(1);  ///< L (area, distant, infinite) or I (point, spot)
  double scale = 1;
  std::optional<double> power;  ///< pbrt-v4 `power` (W), if given
  Vec3 from{0, 0, 0}, to{0, 0, 1};
  double cone_angle_deg = 30, cone_delta_deg = 5;
  double fov_deg = 90;       ///< projection: field of view of the shorter image axis
  std::string filename;      ///< infinite: environment map; goniometric, projection, diffuse: image
  std::vector<Vec3> portal;  ///< infinite: 4 points of a portal quad, or empty
  bool two_sided = false;
  int shape_count = 0;  ///< area lights: shapes that emit with it
  int n_samples = 1;    ///< pbrt-v1–v3 "nsamples" (directlighting "all": samples per hit)
  /// Other lights: the outside medium of the MediumInterface current at LightSource, or -1.
  int medium = -1;
};

/// pbrt-v1/v2 `realistic` camera (Stanford CS348B): camera space is millimetres.
struct LegacyRealistic {
  std::string lens_file;  ///< resolved path of `specfile`
  std::string lens_file_as_written;
  double film_distance_mm = 0;      ///< `filmdistance`: last lens vertex to film
  double aperture_diameter_mm = 0;  ///< `aperture_diameter`
  double film_diagonal_mm = 35;     ///< `filmdiag`
  std::string af_zones_file;        ///< resolved `af_zones`, empty if none
};

/// pbrt-v3/v4 `realistic` camera: lens data in millimetres, scene in metres. The options the
/// camera takes as they are: RealisticOptions.
struct Realistic : RealisticOptions {
  std::string lens_file;  ///< resolved path of `lensfile`
  std::string lens_file_as_written;
  double aperture_diameter_mm = 1;
  double focus_distance_m = 10;
  std::string aperture;  ///< pbrt-v4 aperture shape name or image file; empty: circular
  // lensim's own extras (documented in docs/scene-support.md):
  std::optional<double> film_distance_mm;  ///< `filmdistance` (mm), instead of focusdistance
  std::string focus_method = "thick";      ///< `focusmethod`: thick (pbrt-v4) or exact
  int blades = 0;                          ///< `blades`: polygonal stop (0: round)
  double blade_rotation_deg = 0;           ///< `bladerotation`
  /// focusdistance or filmdistance was written (otherwise an as-built lens keeps the film where
  /// its back-focus compensator put it)
  bool focus_given = false;
  static constexpr double kSceneUnitsPerLensUnit = 0.001;  ///< lens mm → scene metres
};

/// The camera description. `type`: perspective, orthographic, spherical or realistic.
struct Camera {
  std::string type = "perspective";
  std::string type_as_written;
  FileLoc loc;  ///< also the file relative to which lens files were resolved
  Transform camera_from_world, camera_from_world_end;  ///< CTM at Camera (start/end time)
  /// TransformTimes at the Camera directive: when camera_from_world and _end apply.
  double transform_start_time = 0, transform_end_time = 1;
  double shutter_open = 0, shutter_close = 1;
  double hither = 1e-3, yon = 1e30;  ///< camera-space units (mm for LegacyRealistic)
  double fov_deg = 90;
  double lens_radius = 0, focal_distance = 1e6;
  std::optional<double> frame_aspect_ratio;
  std::optional<std::array<double, 4>> screen_window;
  std::string spherical_mapping = "equalarea";  ///< spherical: "equalarea" or "equirectangular"
  std::optional<LegacyRealistic> legacy_realistic;
  std::optional<Realistic> realistic;
  bool defaulted = true;  ///< no Camera directive
  int medium = -1;        ///< the outside medium of the MediumInterface current at Camera, or -1
};

/// A participating medium (MakeNamedMedium). `type` is the pbrt-v4 medium lensim renders:
/// homogeneous. Coefficients are per scene unit (metre), multiplied by `scale` when rendered.
struct Medium {
  std::string name;
  std::string type;  ///< "homogeneous"
  std::string type_as_written;
  FileLoc loc;
  Transform medium_from_world;  ///< inverse of the CTM at MakeNamedMedium
  SpectrumValue sigma_a = SpectrumValue::gray(1), sigma_s = SpectrumValue::gray(1);
  std::string preset;  ///< pbrt-v4 `preset` (measured medium) that gave sigma_a/sigma_s
  double scale = 1;    ///< multiplies sigma_a and sigma_s
  double g = 0;        ///< Henyey-Greenstein asymmetry in (-1, 1)
  SpectrumValue Le = SpectrumValue::gray(0);  ///< emitted radiance (times sigma_a)
  double Le_scale = 1;                        ///< `Lescale`
  // uniformgrid and rgbgrid: nx * ny * nz voxel values (x fastest) over the medium-space box
  // [p0, p1], interpolated trilinearly between voxel centres (zero beyond the outer ones).
  int nx = 1, ny = 1, nz = 1;
  Vec3 p0{0, 0, 0}, p1{1, 1, 1};
  std::vector<double> density;        ///< uniformgrid: scales sigma_a and sigma_s
  std::vector<double> Le_scale_grid;  ///< uniformgrid: per-voxel `Lescale`, or empty
  std::vector<Vec3> sigma_a_grid, sigma_s_grid, Le_grid;  ///< rgbgrid (empty: 1, 1, 0)
  // cloud (pbrt-v4's CloudMedium): procedural density over [p0, p1] from these parameters.
  double cloud_density = 1, wispiness = 1, frequency = 5;
  // nanovdb (pbrt-v4's NanoVDBMedium): the resolved .nvdb file with a "density" grid and an
  // optional "temperature" grid emitting blackbody light (Le_scale times the normalised
  // blackbody at (T - temperature_offset) * temperature_scale kelvin, none at or below 100 K).
  std::string filename;
  double temperature_offset = 0, temperature_scale = 1;
};

/// The film (image) description.
struct Film {
  std::string type = "rgb";
  std::string type_as_written;
  FileLoc loc;
  int x_resolution = 1280, y_resolution = 720;
  std::string filename = "pbrt.exr";
  std::array<double, 4> crop_window{0, 1, 0, 1};
  std::optional<std::array<int, 4>> pixel_bounds;
  double scale = 1;         ///< pbrt-v3 `scale` of pixel values
  double diagonal_mm = 35;  ///< pbrt-v4 film diagonal (v4 realistic/perspective sensor size)
  double iso = 100;
  double white_balance_k = 0;
  std::string sensor = "cie1931";
  double max_component_value = 1e300;
  /// `savefp16`: EXR output as 16-bit half floats. pbrt-v4 defaults it to true; lensim writes
  /// 32-bit float unless the file asks (float holds every half value exactly and more).
  bool save_fp16 = false;
  bool defaulted = true;
  /// pbrt-v4 "spectral" film (type "spectral"): radiance in `spectral_buckets` equal buckets
  /// over [lambda_min_nm, lambda_max_nm] beside the RGB.
  int spectral_buckets = 16;
  double lambda_min_nm = 360, lambda_max_nm = 830;
  /// pbrt-v4 "gbuffer" film (type "gbuffer"): "coordinatesystem" of its positions and normals,
  /// "camera" or "world".
  std::string gbuffer_coordinates = "camera";
  /// Film "raw" (type "raw", issue 34): the camera sensor (its exposure time, ISO and seed are
  /// filled in from the camera, film and sampler when rendered); `raw_nits`: the luminance
  /// (cd/m^2) of a unit-luminance scene radiance; `raw_fnumber`: the f-number that turns the
  /// radiance a camera without a lens (perspective, ...) records into irradiance.
  SensorConfig raw_sensor;
  double raw_nits = 1, raw_fnumber = 0;
  int raw_noise_seed = 0;
};

/// The sampler description; `type` is the pbrt-v4 sampler lensim uses.
struct Sampler {
  std::string type = "zsobol";
  std::string type_as_written;
  FileLoc loc;
  int pixel_samples = 16;
  int seed = 0;
  bool jitter = true;         ///< stratified
  std::string randomization;  ///< pbrt-v4 sobol randomization; empty: the sampler's default
  bool defaulted = true;
};

/// The pixel reconstruction filter; radii in pixels.
struct Filter {
  std::string type = "gaussian";
  std::string type_as_written;
  FileLoc loc;
  double x_radius = 1.5, y_radius = 1.5;
  double sigma = 0.5;               ///< gaussian (pbrt-v4)
  double b = 1.0 / 3, c = 1.0 / 3;  ///< mitchell
  double tau = 3;                   ///< lanczos
  bool defaulted = true;
};

/// The light transport algorithm: `type` "path", "volpath" (media), "lighttracer", "bdpt" or
/// "directlighting" (pbrt-v1–v3). The builder makes volpath the default of pbrt-v4 files, as
/// pbrt-v4 does; v1–v3 files default to path.
struct Integrator {
  std::string type = "path";
  std::string type_as_written;
  FileLoc loc;
  int max_depth = 5;
  bool regularize = false;
  std::string light_sampler = "bvh";
  bool all_lights = true;  ///< directlighting: strategy "all" (every light) or "one"
  bool defaulted = true;
};

/// Everything a scene file describes, built and validated.
struct Scene {
  std::string path;            ///< the top-level scene file as given
  bool legacy_syntax = false;  ///< written for pbrt v1–v3
  Camera camera;
  Film film;
  Sampler sampler;
  Filter filter;
  Integrator integrator;
  std::vector<Shape> shapes;  ///< world shapes and shapes of object definitions
  std::vector<Mesh> meshes;
  std::vector<Curve> curves;  ///< cubic Bézier segments of `curve` shapes
  std::vector<ObjectDef> objects;
  std::vector<Instance> instances;
  std::vector<Material> materials;
  std::vector<Texture> textures;
  std::vector<Light> lights;
  std::vector<Medium> media;                   ///< MakeNamedMedium, in order
  std::map<std::string, std::string> options;  ///< `Option` values, as text
  std::string color_space = "srgb";
  double transform_start_time = 0, transform_end_time = 1;  ///< TransformTimes
  /// Animated transforms of shapes and instances (Shape::motion, Instance::motion).
  std::vector<AnimatedTransform> motions;
  std::vector<Diagnostic> diagnostics;  ///< warnings, and errors if the scene is invalid

  bool hasErrors() const;
  /// Triangles of all meshes, each stored mesh counted once (bilinear patches count 2).
  size_t triangleCount() const;
};

/// Bounds of a shape in its object space.
Bounds3 objectBounds(const Scene& scene, const Shape& shape);
/// World bounds of an instance (its object's shapes, through the instance transform).
Bounds3 worldBounds(const Scene& scene, const Instance& instance);

/// Builds a Scene from a parsed description. Errors do not stop the build (each directive that
/// fails is skipped); they and the warnings are in Scene::diagnostics, parse diagnostics first.
Scene build(const SceneDesc& desc);

/// Parses and builds a scene file; throws lensim::Error (the first error, with a count of the
/// others) if there are errors. Warnings are left in Scene::diagnostics.
Scene loadScene(const std::string& path);

/// The human-readable summary `lensim check` prints.
std::string summary(const Scene& scene);

}  // namespace lensim::scene
