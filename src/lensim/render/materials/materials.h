// Materials: the BSDF at a surface point from the scene's material description (pbrt-v4
// materials, matte mapped to diffuse by the builder; pbrt-v3's plastic, substrate, uber,
// translucent, glass, metal and mirror as pbrt-v3 defines them, in v3materials.h).
#pragma once

#include <memory>
#include <vector>

#include "lensim/render/materials/bsdf.h"
#include "lensim/render/textures/textures.h"

namespace lensim::scene {
struct Scene;
}

namespace lensim::render {

class Materials {
 public:
  /// Loads the normal maps and the fourier materials' tables; throws lensim::Error (at the
  /// material) for unreadable ones.
  Materials(const scene::Scene& scene, const Textures& textures);
  ~Materials();
  /// The material that shades the point: `mix` materials choose one of theirs with probability
  /// `amount` for the second, by a hash of the point (deterministic); others are themselves.
  int resolve(int material, const TextureEvalContext& ctx, const Vec3& wo) const;
  /// The shading normal after the material's normal map (pbrt-v4: tangent-space RGB 2c - 1 in
  /// the frame of dp/du and the shading normal, read linearly); ns itself without a map.
  Vec3 shadingNormal(int material, const TextureEvalContext& ctx, const Vec3& ns,
                     const Vec3& dpdu) const;
  /// Whether the material has a bump map ("displacement" without a normal map, which wins).
  bool hasBump(int material) const;
  /// The shading normal after pbrt-v4's BumpMap (src/pbrt/materials.h): the displacement d is
  /// evaluated at the point and at points moved by du = dv = 0.0005 along dp/du and dp/dv (pbrt's
  /// step without ray differentials); dp/du' = dp/du + (d(u + du) - d) / du n + d dn/du, likewise
  /// for v, and the normal is their cross product on the side of ns.
  Vec3 bumpedNormal(int material, const TextureEvalContext& ctx, const Vec3& ns, const Vec3& dpdu,
                    const Vec3& dpdv, const Vec3& dndu, const Vec3& dndv) const;
  /// Whether the material only marks a boundary (pbrt's "interface" / ""): rays pass through.
  bool isInterface(int material) const;
  /// The BxDF of `material` at ctx. May terminate secondary wavelengths (dispersive eta). With
  /// `regularize` (pbrt-v4's path "regularize", after a non-specular bounce) microfacet widths
  /// below 0.3 become clamp(2 alpha, 0.1, 0.3), so near-specular lobes blur.
  std::shared_ptr<const BxDF> bxdf(int material, const TextureEvalContext& ctx,
                                   SampledWavelengths& lambda, bool regularize = false) const;

 private:
  const scene::Scene* scene_;
  const Textures* textures_;
  struct NormalMap;
  std::vector<std::shared_ptr<NormalMap>> normal_maps_;  ///< per material, or null
  /// pbrt-v3 "fourier" tables (render/materials/fourier.h), per material, or null.
  std::vector<std::shared_ptr<const class FourierBSDFTable>> fourier_tables_;
};

}  // namespace lensim::render
