// Light transport with participating media: pbrt-v4's "volpath" integrator (Pharr, Jakob &
// Humphreys, 4th ed., sec. 14.2), unidirectional path tracing through media by delta tracking
// against majorants (null collisions), ratio-tracking transmittance for next-event estimation,
// and spectral MIS over the path's wavelengths (the rescaled path probabilities r_u, r_l of the
// hero wavelength scheme: each wavelength's pdf of the sampled events relative to the hero's,
// averaged over wavelengths, so chromatic media do not give colour noise without bound).
// Surfaces are handled as by the path integrator (render/integrator.h); MIS between BSDF or
// phase sampling and light sampling is the balance heuristic over the averaged r_u and r_l, as
// pbrt-v4's volpath does.
#pragma once

#include "lensim/render/integrators/base.h"

namespace lensim::render {

using namespace lensim::sampling;

/// Radiance along the camera ray (origin o, unit direction d, shutter time `time`), which starts
/// in medium `medium` (index into Scene::media, -1 for vacuum; SceneContext::media resolves it).
SampledSpectrum volpathLi(const SceneContext& sc, const Vec3& o, const Vec3& d, double time,
                          int medium, SampledWavelengths& lambda, Sampler& sampler,
                          RayCounts& counts);
/// The volpath integrator over `sc` (base.h), which must outlive it. Camera rays start in the
/// camera's medium when the scene's media are rendered (SceneContext::scene_media).
std::unique_ptr<Integrator> makeVolPathIntegrator(const SceneContext& sc);

/// The same at shutter time 0 (a scene without motion looks the same at every time).
inline SampledSpectrum volpathLi(const SceneContext& sc, const Vec3& o, const Vec3& d, int medium,
                                 SampledWavelengths& lambda, Sampler& sampler, RayCounts& counts) {
  return volpathLi(sc, o, d, 0.0, medium, lambda, sampler, counts);
}

}  // namespace lensim::render
