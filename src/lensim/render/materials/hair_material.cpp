#include "lensim/render/materials/hair_material.h"

#include <algorithm>
#include <map>
#include <mutex>
#include <unordered_map>
#include <utility>

#include "lensim/render/materials/bxdf_arena.h"
#include "lensim/render/materials/hair.h"
#include "lensim/scene/builder.h"

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
  for (int i = 0; i < kSpectrumSamples; ++i) s[i] = scale * poly.eval(lambda.lambda(i));
  return s;
}

}  // namespace

std::shared_ptr<const BxDF> makeHairBxDF(const scene::Material& m, const Textures& tx,
                                         const TextureEvalContext& ctx,
                                         const SampledWavelengths& lambda) {
  const double beta_m = std::clamp(tx.evalFloat(m.hair_beta_m, ctx), 1e-2, 1.0);
  const double beta_n = std::clamp(tx.evalFloat(m.hair_beta_n, ctx), 1e-2, 1.0);
  const double alpha = tx.evalFloat(m.hair_alpha, ctx);
  const double eta = tx.evalFloat(m.eta, ctx);
  SampledSpectrum sigma_a;
  using A = scene::Material::HairAbsorption;
  switch (m.hair_absorption) {
    case A::SigmaA:
      sigma_a = clampZero(tx.evalSpectrum(m.hair_sigma_a, ctx, lambda, SpectrumType::Unbounded));
      break;
    case A::Reflectance:
      sigma_a = HairBxDF::sigmaAFromReflectance(
          tx.evalSpectrum(m.reflectance, ctx, lambda, SpectrumType::Albedo), beta_n);
      break;
    case A::Melanin:
      sigma_a =
          melaninSigmaA(std::max(0.0, tx.evalFloat(m.hair_eumelanin, ctx)),
                        std::max(0.0, tx.evalFloat(m.hair_pheomelanin, ctx)),
                        m.hair_eumelanin.texture < 0 && m.hair_pheomelanin.texture < 0, lambda);
      break;
  }
  // The offset across the fibre from the surface's v (pbrt-v4: h = -1 + 2 uv[1]; for curves v
  // runs across the width as pbrt-v4's curve intersection computes it). Kept as pbrt-v4 has it,
  // although by the model's geometry (R leaves at phi_o - 2 gamma_o, h = sin gamma_o) this side
  // convention mirrors the lobes about the fibre relative to a geometric cylinder; it shows only
  // where a fibre spans several pixels.
  const double h = -1 + 2 * ctx.uv.y;
  return makeBxDF<HairBxDF>(h, eta, sigma_a, beta_m, beta_n, alpha);
}

}  // namespace lensim::render
