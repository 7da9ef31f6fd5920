// The evaluations material kinds share (material_eval.h), with pbrt-v4's parameter semantics.
#include "lensim/render/materials/material_eval.h"

#include <algorithm>

namespace lensim::render {

SampledSpectrum MaterialEvalContext::albedo(const scene::Input& in) const {
  return clampZero(tx.evalSpectrum(in, ctx, lambda, SpectrumType::Albedo));
}

double MaterialEvalContext::regularized(double alpha) const {
  return regularize && alpha < 0.3 ? std::clamp(2 * alpha, 0.1, 0.3) : alpha;
}

TrowbridgeReitz MaterialEvalContext::distribution(const scene::Roughness& r) const {
  double u = evalFloat(r.u), v = evalFloat(r.v);
  if (r.remap) u = roughnessToAlpha(u), v = roughnessToAlpha(v);
  return TrowbridgeReitz(regularized(u), regularized(v));
}

double MaterialEvalContext::dielectricEta(const scene::Input& eta) const {
  double e;
  if (eta.texture >= 0) {
    e = evalFloat(eta);
  } else if (eta.spectrum.kind == scene::SpectrumValue::Kind::Rgb &&
             eta.spectrum.rgb == Vec3{0, 0, 0}) {
    e = eta.value;  // a float eta
  } else {
    const Spectrum& s = tx.constantRef(eta.spectrum, SpectrumType::Unbounded);
    e = s.eval(lambda.lambda(0));
    if (s.eval(lambda.lambda(1)) != e) lambda.terminateSecondary();
  }
  return e == 0 ? 1 : e;
}

std::pair<SampledSpectrum, SampledSpectrum> MaterialEvalContext::conductorIndex(
    const scene::ConductorIndex& c) const {
  if (c.has_reflectance)
    return {SampledSpectrum(1.0), conductorKFromReflectance(albedo(c.reflectance))};
  return {unbounded(c.eta), unbounded(c.k)};
}

LayerParams MaterialEvalContext::layer(const scene::LayerInputs& l, double thickness) const {
  LayerParams lp;
  lp.thickness = thickness;
  lp.albedo = albedo(l.albedo);
  lp.g = evalFloat(l.g);
  lp.max_depth = l.max_depth;
  lp.n_samples = l.n_samples;
  return lp;
}

}  // namespace lensim::render
