// The BxDFs of pbrt-v4's materials from their parameters (pbrt-v4 src/pbrt/materials.h): roughness
// remapped by sqrt unless remaproughness is false; conductor "reflectance" means eta = 1 and k
// from the normal-incidence reflectance; a dielectric eta that varies with wavelength keeps only
// the hero wavelength.
#include "lensim/render/materials/bxdf_arena.h"
#include "lensim/render/materials/material_eval.h"
#include "lensim/render/materials/measured.h"
#include "lensim/render/materials/measured_rgl.h"

namespace lensim::render {

std::shared_ptr<const BxDF> bxdfOf(const scene::DiffuseParams& p, const MaterialEvalContext& c) {
  const SampledSpectrum r = c.albedo(p.reflectance);
  const double sigma = c.evalFloat(p.sigma);
  if (sigma > 0) return makeBxDF<OrenNayarBxDF>(r, sigma);
  return makeBxDF<DiffuseBxDF>(r);
}

std::shared_ptr<const BxDF> bxdfOf(const scene::CoatedDiffuseParams& p,
                                   const MaterialEvalContext& c) {
  const SampledSpectrum r = c.albedo(p.reflectance);
  const double eta = c.dielectricEta(p.eta);
  const scene::Input& t = p.layer.thickness;
  const LayerParams lp = c.layer(p.layer, t.texture >= 0 || t.value != 0 ? c.evalFloat(t) : 0.01);
  return makeBxDF<CoatedBxDF>(DielectricBxDF(eta, c.distribution(p.roughness)),
                              makeBxDF<DiffuseBxDF>(r), lp);
}

std::shared_ptr<const BxDF> bxdfOf(const scene::CoatedConductorParams& p,
                                   const MaterialEvalContext& c) {
  auto [ceta, ck] = c.conductorIndex(p.conductor);
  const double eta = c.dielectricEta(p.interface_eta);
  // pbrt-v4: the conductor sits under a medium of index eta, so its index is relative to it.
  ceta /= eta;
  ck /= eta;
  const TrowbridgeReitz conductor = c.distribution(p.conductor_roughness);
  const LayerParams lp = c.layer(p.layer, c.evalFloat(p.layer.thickness));
  return makeBxDF<CoatedBxDF>(DielectricBxDF(eta, c.distribution(p.interface_roughness)),
                              makeBxDF<ConductorBxDF>(conductor, ceta, ck), lp);
}

std::shared_ptr<const BxDF> bxdfOf(const scene::ConductorParams& p, const MaterialEvalContext& c) {
  const auto [eta, k] = c.conductorIndex(p.index);
  return makeBxDF<ConductorBxDF>(c.distribution(p.roughness), eta, k);
}

std::shared_ptr<const BxDF> bxdfOf(const scene::DielectricParams& p, const MaterialEvalContext& c) {
  return makeBxDF<DielectricBxDF>(c.dielectricEta(p.eta), c.distribution(p.roughness));
}

std::shared_ptr<const BxDF> bxdfOf(const scene::ThinDielectricParams& p,
                                   const MaterialEvalContext& c) {
  return makeBxDF<ThinDielectricBxDF>(c.dielectricEta(p.eta));
}

std::shared_ptr<const BxDF> bxdfOf(const scene::DiffuseTransmissionParams& p,
                                   const MaterialEvalContext& c) {
  return makeBxDF<DiffuseTransmissionBxDF>(c.albedo(p.reflectance) * p.scale,
                                           c.albedo(p.transmittance) * p.scale);
}

std::shared_ptr<const BxDF> bxdfOf(const scene::SubsurfaceParams& p, const MaterialEvalContext& c) {
  return makeBxDF<DielectricBxDF>(c.dielectricEta(p.eta), c.distribution(p.roughness));
}

std::shared_ptr<const BxDF> bxdfOf(const scene::MeasuredParams& p, const MaterialEvalContext& c) {
  if (p.rgl) return makeBxDF<RGLMeasuredBxDF>(RGLMeasuredBRDF::loadCached(p.file), c.lambda);
  return makeBxDF<MeasuredBxDF>(MeasuredBRDF::loadCached(p.file), c.lambda);
}

}  // namespace lensim::render
