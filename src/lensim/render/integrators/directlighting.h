// pbrt-v3's "directlighting" integrator (DirectLightingIntegrator, pbrt-v3
// src/integrators/directlighting.cpp; Pharr, Jakob, Humphreys, 3rd ed., sec. 14.3): at each hit,
// the emission of an area light hit, plus direct lighting from the lights, plus, while depth + 1 <
// maxdepth (camera rays have depth 0), the radiance along the specular reflection and the
// specular transmission of the surface, each traced recursively. No other indirect light.
//
// Direct lighting (pbrt-v3 src/core/integrator.cpp, EstimateDirect): a light sample and a BSDF
// sample, combined by multiple importance sampling with the power heuristic (the BSDF sample only
// for lights that are not delta lights), over the non-specular part of the BSDF. Strategy "all"
// (UniformSampleAllLights, the default) estimates every light; "one" (UniformSampleOneLight)
// one light chosen uniformly, divided by its probability.
//
// "all" takes each light's pbrt-v1–v3 "nsamples" (default 1) samples per hit, as pbrt-v3 does
// (independent samples here, where pbrt-v3 draws them as stratified sample arrays).
//
// Differences from pbrt-v3, none of which changes the expected value: a BSDF
// sample that lands on a specular lobe (pbrt-v3 excludes those lobes from the choice) counts zero,
// and the specular reflection (transmission) is one BSDF sample restricted to reflection
// (transmission) that counts only when it is specular, so a BSDF with both specular and
// non-specular lobes is estimated stochastically where pbrt-v3 evaluates its specular lobes
// deterministically.
#pragma once

#include "lensim/render/integrators/base.h"

namespace lensim::render {

using namespace lensim::sampling;

struct DirectLightingOptions {
  bool all_lights = true;  ///< strategy "all"; false: "one"
  int max_depth = 5;       ///< pbrt-v3's maxdepth: specular recursion while depth + 1 < it
};

/// Radiance along the camera ray (origin o, unit direction d, shutter time `time`) by pbrt-v3's
/// directlighting.
SampledSpectrum directLightingLi(const SceneContext& sc, const DirectLightingOptions& opt,
                                 const Vec3& o, const Vec3& d, double time,
                                 SampledWavelengths& lambda, Sampler& sampler, RayCounts& counts);

/// The directlighting integrator over `sc` (base.h), which must outlive it.
std::unique_ptr<Integrator> makeDirectLightingIntegrator(const SceneContext& sc,
                                                         const DirectLightingOptions& opt);

}  // namespace lensim::render
