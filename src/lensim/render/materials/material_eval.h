// What a material kind needs to make its BxDF at a surface point, and the BxDF of each kind
// from its parameters (scene/material.h): one bxdfOf overload per kind, defined beside the
// kind's BxDFs (pbrt_v4_materials.cpp, v3materials.cpp, hair_material.cpp); Materials::bxdf
// (materials.cpp) dispatches on the kind. The BxDFs are made in the per-thread scratch arena
// (bxdf_arena.h).
#pragma once

#include <memory>
#include <utility>

#include "lensim/render/materials/bsdf.h"
#include "lensim/render/materials/layered.h"
#include "lensim/render/textures/textures.h"
#include "lensim/scene/material.h"

namespace lensim::render {

/// The point, the wavelengths and the textures a BxDF is made for, with the evaluations the
/// kinds share.
struct MaterialEvalContext {
  const Textures& tx;
  const TextureEvalContext& ctx;
  SampledWavelengths& lambda;
  /// pbrt-v4's path "regularize" (after a non-specular bounce): microfacet widths below 0.3
  /// become clamp(2 alpha, 0.1, 0.3), so near-specular lobes blur.
  bool regularize = false;

  double evalFloat(const scene::Input& in) const { return tx.evalFloat(in, ctx); }
  /// A reflectance-like spectrum, negative values clamped to 0.
  SampledSpectrum albedo(const scene::Input& in) const;
  SampledSpectrum unbounded(const scene::Input& in) const {
    return tx.evalSpectrum(in, ctx, lambda, SpectrumType::Unbounded);
  }
  double regularized(double alpha) const;
  /// Trowbridge-Reitz with pbrt-v4's roughness remapping (square root) unless turned off.
  TrowbridgeReitz distribution(const scene::Roughness& r) const;
  /// A dielectric's index: a float, a float texture or a spectrum; one that varies with
  /// wavelength keeps only the hero wavelength (terminates the secondary ones). 0 becomes 1.
  double dielectricEta(const scene::Input& eta) const;
  /// A conductor's complex index eta + i k.
  std::pair<SampledSpectrum, SampledSpectrum> conductorIndex(const scene::ConductorIndex& c) const;
  LayerParams layer(const scene::LayerInputs& l, double thickness) const;
};

// pbrt-v4's materials (pbrt_v4_materials.cpp).
std::shared_ptr<const BxDF> bxdfOf(const scene::DiffuseParams& p, const MaterialEvalContext& c);
std::shared_ptr<const BxDF> bxdfOf(const scene::CoatedDiffuseParams& p,
                                   const MaterialEvalContext& c);
std::shared_ptr<const BxDF> bxdfOf(const scene::CoatedConductorParams& p,
                                   const MaterialEvalContext& c);
std::shared_ptr<const BxDF> bxdfOf(const scene::ConductorParams& p, const MaterialEvalContext& c);
std::shared_ptr<const BxDF> bxdfOf(const scene::DielectricParams& p, const MaterialEvalContext& c);
std::shared_ptr<const BxDF> bxdfOf(const scene::ThinDielectricParams& p,
                                   const MaterialEvalContext& c);
std::shared_ptr<const BxDF> bxdfOf(const scene::DiffuseTransmissionParams& p,
                                   const MaterialEvalContext& c);
/// The subsurface material's boundary (the volume is render/media/subsurface.h).
std::shared_ptr<const BxDF> bxdfOf(const scene::SubsurfaceParams& p, const MaterialEvalContext& c);
std::shared_ptr<const BxDF> bxdfOf(const scene::MeasuredParams& p, const MaterialEvalContext& c);
// hair_material.cpp
std::shared_ptr<const BxDF> bxdfOf(const scene::HairParams& p, const MaterialEvalContext& c);
// pbrt-v3's materials (v3materials.cpp).
std::shared_ptr<const BxDF> bxdfOf(const scene::PlasticParams& p, const MaterialEvalContext& c);
std::shared_ptr<const BxDF> bxdfOf(const scene::SubstrateParams& p, const MaterialEvalContext& c);
std::shared_ptr<const BxDF> bxdfOf(const scene::UberParams& p, const MaterialEvalContext& c);
std::shared_ptr<const BxDF> bxdfOf(const scene::TranslucentParams& p, const MaterialEvalContext& c);
std::shared_ptr<const BxDF> bxdfOf(const scene::GlassParams& p, const MaterialEvalContext& c);
std::shared_ptr<const BxDF> bxdfOf(const scene::MetalParams& p, const MaterialEvalContext& c);
std::shared_ptr<const BxDF> bxdfOf(const scene::MirrorParams& p, const MaterialEvalContext& c);

}  // namespace lensim::render
