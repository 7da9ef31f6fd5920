// Materials: the BSDF at a surface point from the scene's material description (pbrt-v4
// materials; the builder has already mapped pbrt-v1–v3 names: matte -> diffuse, plastic /
// substrate / uber -> coateddiffuse, metal -> conductor, mirror -> conductor with a reflectance,
// glass -> dielectric).
#pragma once

#include <memory>

#include "lensim/render/bsdf.h"
#include "lensim/render/textures.h"

namespace lensim::scene {
struct Scene;
}

namespace lensim::render {

class Materials {
 public:
  Materials(const scene::Scene& scene, const Textures& textures);
  /// Whether the material only marks a boundary (pbrt's "interface" / ""): rays pass through.
  bool isInterface(int material) const;
  /// The BxDF of `material` at ctx. May terminate secondary wavelengths (dispersive eta).
  std::shared_ptr<const BxDF> bxdf(int material, const TextureEvalContext& ctx,
                                   SampledWavelengths& lambda) const;

 private:
  const scene::Scene* scene_;
  const Textures* textures_;
};

}  // namespace lensim::render
