// Internal to scene/builder.cpp and scene/build/*.cpp: the Builder that turns parsed
// directives into a Scene. Its member functions are defined by family in scene/build/.
#pragma once

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include "lensim/io/ply.h"
#include "lensim/scene/description.h"
#include "lensim/scene/sensor_settings.h"
#include "lensim/scene/media_presets.h"
#include "lensim/scene/params.h"
#include "lensim/scene/shapes_tessellated.h"
#include "lensim/util/limits.h"

namespace lensim::scene::detail {

namespace fs = std::filesystem;

// Graphics state pushed by AttributeBegin.
struct GraphicsState {
  Transform ctm[2];
  bool active[2] = {true, true};
  bool reverse_orientation = false;
  int material = -1;
  // NamedMaterial of a name not (yet) defined: resolved when the scene is complete.
  std::string material_name;
  FileLoc material_name_loc;
  int area_light = -1;
  ParamList shape_attrs, light_attrs, material_attrs, texture_attrs, medium_attrs;
  // MediumInterface: medium names ("" is vacuum) and where they were given.
  std::string inside_medium, outside_medium;
  FileLoc medium_loc;
  // pbrt-v1–v3 files only: named materials belong to the graphics state (pbrt-v3
  // src/core/api.cpp: GraphicsState::namedMaterials, saved by AttributeBegin and restored by
  // AttributeEnd), and NamedMaterial names one that the Shape looks up in its own scope
  // (GraphicsState::CreateMaterial). Shared until a block writes it (copy on write).
  std::shared_ptr<const std::map<std::string, int>> scoped_materials;
  std::string scoped_material_name;  ///< NamedMaterial's name, looked up at each Shape
  FileLoc scoped_material_loc;
};

struct MaterialReader;

class Builder {
 public:
  friend struct MaterialReader;  // build/materials.cpp: the parameters of each material kind

  explicit Builder(const SceneDesc& desc);

  bool pbrt_v2_ = false;  // the file uses syntax only pbrt-v1/v2 have

  Scene run();

 private:
  void warn(const FileLoc& loc, std::string msg);
  void warnOnce(const std::string& key, const FileLoc& loc, std::string msg);
  void finish(ParamSet& ps) { ps.reportUnused(scene_.diagnostics); }

  void requireInvertible(const FileLoc& loc, std::string_view what, int which = 0);
  /// Scene::motions index of the animated CTM (-1 if static); see builder.cpp.
  int motionOfCtm(const FileLoc& loc, std::string_view what);
  /// Warns once that animated `what` (lights, media, textures) use the start transform.
  void warnIfAnimated(const FileLoc& loc, std::string_view what);

  const Param* findLightScale(ParamSet& ps);
  void applyLightScale(const Param* p, Light& l);

  std::string resolve(const std::string& name, const FileLoc& loc, std::string_view what);

  SpectrumValue spectrumOf(const Param& p);

  int textureIndex(const std::string& name, TextureKind kind, const FileLoc& loc);

  std::optional<Input> spectrumInput(ParamSet& ps, ParamSet::Names names);
  Input spectrumInput(ParamSet& ps, ParamSet::Names names, double def);

  std::optional<Input> floatInput(ParamSet& ps, ParamSet::Names names);
  Input floatInput(ParamSet& ps, ParamSet::Names names, double def);

  void directive(const Directive& d);
  bool transformDirective(const Directive& d);
  void materialDirective(const Directive& d);

  void popState(bool transform_only);

  void objectBegin(const Directive& d);

  void option(const Directive& d);

  void attribute(const Directive& d);

  void camera(const Directive& d);
  LegacyRealistic legacyRealistic(const Directive& d, ParamSet& ps);

  void checkSensor(ParamSet& ps, const Film& f);

  void spectralFilm(ParamSet& ps, Film& f);
  void rawFilm(ParamSet& ps, Film& f);

  void film(const Directive& d);

  void sampler(const Directive& d);

  void filter(const Directive& d);

  void integrator(const Directive& d);
  void integratorBdpt(ParamSet& ps, Integrator& it);
  void integratorDirectLighting(ParamSet& ps, Integrator& it);

  void texture(const Directive& d);
  void imageMapTexture(Texture& t, ParamSet& ps, const FileLoc& loc);  // build/textures.cpp

  Material material(const std::string& type, ParamSet& ps, const FileLoc& loc);
  HairParams hairMaterial(ParamSet& ps, const FileLoc& loc);  // build/hair.cpp

  int currentMaterial();
  /// The named material `name` for a NamedMaterial or a mix: pbrt-v1–v3 files look in the
  /// current block's scope, pbrt-v4 files in the global table; -1 if not (yet) defined.
  int namedMaterial(const std::string& name) const;
  /// pbrt-v1–v3 semantics of MakeNamedMaterial / NamedMaterial (scene/build/named_materials.cpp).
  void makeNamedMaterialScoped(const Directive& d, Material m);
  void namedMaterialScoped(const Directive& d);

  void checkStackMemory(const Directive& d);

  void light(const Directive& d);

  void areaLight(const Directive& d);

  void shape(const Directive& d);

  int inlineMesh(const std::string& type, ParamSet& ps, const FileLoc& loc);

  int curveShape(ParamSet& ps, const FileLoc& loc);

  int tessellatedShape(const std::string& type, ParamSet& ps, const FileLoc& loc);

  Mesh nurbsMeshOf(ParamSet& ps, const FileLoc& loc);

  int plyMesh(ParamSet& ps, const FileLoc& loc);

  const SceneDesc& desc_;
  Scene scene_;
  fs::path top_dir_;
  GraphicsState gs_;
  std::vector<GraphicsState> stack_;
  std::map<std::string, std::pair<Transform, Transform>> named_cs_;
  std::map<std::string, int> float_textures_, spectrum_textures_, named_materials_, object_index_;
  std::set<std::string> warned_;
  int current_object_ = -1;
  int default_material_ = -1;
  struct PendingInstance {
    std::string name;
    FileLoc loc;
    Transform transform;
    int motion = -1;  ///< Scene::motions index when animated
  };
  std::vector<PendingInstance> pending_instances_;
  // Media named by MediumInterface, resolved after all MakeNamedMedium (as pbrt-v4 does).
  struct PendingMedia {
    int shape;  ///< index into Scene::shapes, or -1 for the camera or a light
    std::string inside, outside;
    FileLoc loc;
    int light = -1;  ///< index into Scene::lights (shape -1)
  };
  std::vector<PendingMedia> pending_media_;
  std::map<std::string, int> named_media_;

  void makeNamedMedium(const Directive& d);

  void gridMedium(Medium& m, ParamSet& ps, const FileLoc& loc);
  void proceduralMedium(Medium& m, ParamSet& ps, const FileLoc& loc);  ///< cloud, nanovdb
  /// Reports the medium's unused parameters and registers it under its name (a redefinition
  /// warned).
  void addNamedMedium(Medium m, ParamSet& ps);
  /// out = the spectrum-valued parameter `name` (rgb, spectrum or blackbody), if given.
  void optionalSpectrum(ParamSet& ps, const char* name, SpectrumValue& out);
  void subsurfaceCoefficients(SubsurfaceParams& m, ParamSet& ps, const FileLoc& loc);

  int mediumIndex(const std::string& name, const FileLoc& loc);

  void resolveMedia();
  // Shapes whose NamedMaterial named a material not defined before them: pbrt-v4 looks named
  // materials up only when it creates the scene (BasicScene::CreateMaterials and the shape
  // lookups after it, src/pbrt/scene.cpp), so a MakeNamedMaterial may follow its use.
  struct PendingMaterial {
    int shape;
    std::string name;
    FileLoc loc;
  };
  std::vector<PendingMaterial> pending_materials_;
  void resolveNamedMaterials();
};

}  // namespace lensim::scene::detail
