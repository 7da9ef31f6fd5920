// BxDFs from material descriptions with pbrt-v4's parameter semantics (roughness remapped by
// sqrt unless remaproughness is false; conductor "reflectance" means eta = 1 and k from the
// normal-incidence reflectance; a dielectric eta that varies with wavelength keeps only the
// hero wavelength).
#include "lensim/render/materials.h"

#include "lensim/render/layered.h"
#include "lensim/scene/builder.h"

namespace lensim::render {

Materials::Materials(const scene::Scene& scene, const Textures& textures)
    : scene_(&scene), textures_(&textures) {}

bool Materials::isInterface(int material) const {
  return material >= 0 && scene_->materials[size_t(material)].type == "interface";
}

std::shared_ptr<const BxDF> Materials::bxdf(int material, const TextureEvalContext& ctx,
                                            SampledWavelengths& lambda) const {
  if (material < 0) return std::make_shared<DiffuseBxDF>(SampledSpectrum(0.5));
  const scene::Material& m = scene_->materials[size_t(material)];
  const Textures& tx = *textures_;
  auto distribution = [&]() {
    double ur = tx.evalFloat(m.uroughness, ctx), vr = tx.evalFloat(m.vroughness, ctx);
    if (m.remap_roughness) ur = roughnessToAlpha(ur), vr = roughnessToAlpha(vr);
    return TrowbridgeReitz(ur, vr);
  };
  auto dielectricEta = [&]() -> double {
    if (m.eta.texture >= 0) return tx.evalFloat(m.eta, ctx);
    if (m.eta.spectrum.kind == scene::SpectrumValue::Kind::Rgb &&
        m.eta.spectrum.rgb == Vec3{0, 0, 0})
      return m.eta.value;  // a float eta
    SpectrumPtr s = tx.constant(m.eta.spectrum, SpectrumType::Unbounded);
    const double e = s->eval(lambda.lambda(0));
    if (s->eval(lambda.lambda(1)) != e) lambda.terminateSecondary();
    return e;
  };
  if (m.type == "diffuse") {
    const SampledSpectrum r =
        clampZero(tx.evalSpectrum(m.reflectance, ctx, lambda, SpectrumType::Albedo));
    return std::make_shared<DiffuseBxDF>(r);
  }
  if (m.type == "conductor") {
    SampledSpectrum eta, k;
    if (m.has_reflectance) {
      const SampledSpectrum r =
          clampZero(tx.evalSpectrum(m.reflectance, ctx, lambda, SpectrumType::Albedo));
      eta = SampledSpectrum(1.0);
      k = conductorKFromReflectance(r);
    } else {
      eta = tx.evalSpectrum(m.eta, ctx, lambda, SpectrumType::Unbounded);
      k = tx.evalSpectrum(m.k, ctx, lambda, SpectrumType::Unbounded);
    }
    return std::make_shared<ConductorBxDF>(distribution(), eta, k);
  }
  if (m.type == "dielectric") {
    double eta = dielectricEta();
    if (eta == 0) eta = 1;
    return std::make_shared<DielectricBxDF>(eta, distribution());
  }
  if (m.type == "thindielectric") {
    double eta = dielectricEta();
    if (eta == 0) eta = 1;
    return std::make_shared<ThinDielectricBxDF>(eta);
  }
  if (m.type == "coateddiffuse") {
    const SampledSpectrum r =
        clampZero(tx.evalSpectrum(m.reflectance, ctx, lambda, SpectrumType::Albedo));
    double eta = dielectricEta();
    if (eta == 0) eta = 1;
    LayerParams lp;
    lp.thickness =
        m.thickness.texture >= 0 || m.thickness.value != 0 ? tx.evalFloat(m.thickness, ctx) : 0.01;
    lp.albedo = clampZero(tx.evalSpectrum(m.albedo, ctx, lambda, SpectrumType::Albedo));
    lp.g = tx.evalFloat(m.g, ctx);
    lp.max_depth = m.max_depth;
    lp.n_samples = m.n_samples;
    return std::make_shared<CoatedBxDF>(DielectricBxDF(eta, distribution()),
                                        std::make_shared<DiffuseBxDF>(r), lp);
  }
  return std::make_shared<DiffuseBxDF>(SampledSpectrum(0.5));
}

}  // namespace lensim::render
