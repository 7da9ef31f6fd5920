// The "hair" material's BxDF at a surface point (pbrt-v4's HairMaterial::GetBxDF,
// src/pbrt/materials.h): the textures evaluated, beta_m and beta_n clamped to [0.01, 1], the
// absorption from sigma_a, the reflectance or the melanin concentrations, and h = -1 + 2 v.
#include <algorithm>
#include <map>
#include <mutex>
#include <unordered_map>
#include <utility>

#include "lensim/render/materials/bxdf_arena.h"
#include "lensim/render/materials/hair.h"
#include "lensim/render/materials/material_eval.h"

namespace lensim::render {

namespace {

/// sigma_a of melanin concentrations as pbrt-v4 makes it: the unbounded spectrum of the rgb
/// HairBxDF::sigmaAFromConcentration (an RGBUnboundedSpectrum). Constant concentrations use the
/// exact fit, cached per (ce, cp); textured ones the tabulated fit, per point.
SampledSpectrum melaninSigmaA(double ce, double cp, bool constant,
                              const SampledWavelengths& lambda) {
  const Vec3 rgb = HairBxDF::sigmaAFromConcentration(ce, cp);
  SampledSpectrum s;
  if (constant) {
    thread_local std::map<std::pair<double, double>, SpectrumPtr> local;
    auto it = local.find({ce, cp});
    if (it == local.end()) {
      static std::mutex mutex;
      static std::map<std::pair<double, double>, SpectrumPtr> shared;
      std::lock_guard lock(mutex);
      auto sit = shared.find({ce, cp});
      if (sit == shared.end())
        sit = shared
                  .emplace(std::pair{ce, cp},
                           std::make_shared<RGBUnboundedSpectrum>(RGBColorSpace::sRGB(), rgb))
                  .first;
      it = local.emplace(std::pair{ce, cp}, sit->second).first;
    }
    return it->second->sample(lambda);
  }
  const double scale = 2 * std::max({rgb.x, rgb.y, rgb.z});
  if (!(scale > 0)) return s;
  const SigmoidPolynomial poly = RGBColorSpace::sRGB().tableSigmoid(rgb / scale);
  return poly.sample(lambda) * scale;
}

}  // namespace

std::shared_ptr<const BxDF> bxdfOf(const scene::HairParams& p, const MaterialEvalContext& c) {
  const double beta_m = std::clamp(c.evalFloat(p.beta_m), 1e-2, 1.0);
  const double beta_n = std::clamp(c.evalFloat(p.beta_n), 1e-2, 1.0);
  const double alpha = c.evalFloat(p.alpha);
  const double eta = c.evalFloat(p.eta);
  SampledSpectrum sigma_a;
  using A = scene::HairParams::Absorption;
  switch (p.absorption) {
    case A::SigmaA:
      sigma_a = clampZero(c.unbounded(p.sigma_a));
      break;
    case A::Reflectance:
      sigma_a = HairBxDF::sigmaAFromReflectance(
          c.tx.evalSpectrum(p.reflectance, c.ctx, c.lambda, SpectrumType::Albedo), beta_n);
      break;
    case A::Melanin:
      sigma_a = melaninSigmaA(std::max(0.0, c.evalFloat(p.eumelanin)),
                              std::max(0.0, c.evalFloat(p.pheomelanin)),
                              p.eumelanin.texture < 0 && p.pheomelanin.texture < 0, c.lambda);
      break;
  }
  // The offset across the fibre from the surface's v (pbrt-v4: h = -1 + 2 uv[1]; for curves v
  // runs across the width as pbrt-v4's curve intersection computes it). Kept as pbrt-v4 has it,
  // although by the model's geometry (R leaves at phi_o - 2 gamma_o, h = sin gamma_o) this side
  // convention mirrors the lobes about the fibre relative to a geometric cylinder; it shows only
  // where a fibre spans several pixels.
  const double h = -1 + 2 * c.ctx.uv.y;
  return makeBxDF<HairBxDF>(h, eta, sigma_a, beta_m, beta_n, alpha);
}

}  // namespace lensim::render
