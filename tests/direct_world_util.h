// A built scene's render world (acceleration structure, textures, materials, lights, media) and
// the SceneContext over it, for tests that call integrator functions directly rather than
// through render::render.
#pragma once

#include <memory>
#include <utility>

#include "lensim/render/integrators/integrator.h"
#include "lensim/render/lights/lights.h"
#include "lensim/render/materials/materials.h"
#include "lensim/render/media/media.h"
#include "lensim/render/shapes/accel.h"
#include "lensim/render/textures/textures.h"
#include "lensim/scene/description.h"
#include "lensim/util/error.h"

namespace lensim::testutil {

struct DirectWorld {
  scene::Scene scene;
  std::unique_ptr<render::Accel> accel;
  std::unique_ptr<render::Textures> textures;
  std::unique_ptr<render::Materials> materials;
  std::unique_ptr<render::LightSet> lights;
  std::unique_ptr<render::Media> media;
  render::SceneContext sc;

  /// Throws the scene's diagnostics if it has errors.
  explicit DirectWorld(scene::Scene built) : scene(std::move(built)) {
    if (scene.hasErrors()) throw Error(formatDiagnostics(scene.diagnostics));
    accel = std::make_unique<render::Accel>(scene);
    textures = std::make_unique<render::Textures>(scene);
    materials = std::make_unique<render::Materials>(scene, *textures);
    lights = std::make_unique<render::LightSet>(scene, *accel, *textures);
    media = std::make_unique<render::Media>(scene);
    sc.scene = &scene;
    sc.accel = accel.get();
    sc.textures = textures.get();
    sc.materials = materials.get();
    sc.lights = lights.get();
    sc.media = media.get();
    sc.max_depth = scene.integrator.max_depth;
  }
  // The world and the context point into `scene`: not to be copied or moved.
  DirectWorld(const DirectWorld&) = delete;
  DirectWorld& operator=(const DirectWorld&) = delete;
};

}  // namespace lensim::testutil
