// The "hair" material's BxDF at a surface point (pbrt-v4's HairMaterial::GetBxDF,
// src/pbrt/materials.h): the textures evaluated, beta_m and beta_n clamped to [0.01, 1], the
// absorption from sigma_a, the reflectance or the melanin concentrations, and h = -1 + 2 v.
#pragma once

#include <memory>

#include "lensim/render/materials/bsdf.h"
#include "lensim/render/textures/textures.h"

namespace lensim::scene {
struct Material;
}

namespace lensim::render {

std::shared_ptr<const BxDF> makeHairBxDF(const scene::Material& m, const Textures& tx,
                                         const TextureEvalContext& ctx,
                                         const SampledWavelengths& lambda);

}  // namespace lensim::render
