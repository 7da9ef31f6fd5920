// The "lighttracer" integrator: pbrt-v4's LightPathIntegrator (src/pbrt/cpu/integrators.cpp).
// Each pixel sample starts one light path (a light chosen by power, a ray from it by
// Light::sampleLe) and connects every vertex, the light's own point included, to the camera
// with Camera::sampleWi, splatting the contribution where the connection meets the film
// (Film::addSplat). No camera rays are traced; the image is the splats over the light paths per
// pixel (camera.h has the measurement convention), so it estimates the same image as "path".
#pragma once

#include <string>
#include <vector>

#include "lensim/render/integrators/base.h"

namespace lensim::camera {
class Camera;
}

namespace lensim::render {

using namespace lensim::sampling;

class Film;

class LightTracer {
 public:
  /// Throws lensim::Error when the camera has no importance (Camera::supportsImportance). Lights
  /// without emission sampling (Light::supportsLe) are left out, with a warning.
  LightTracer(const SceneContext& sc, const camera::Camera& camera);
  /// One light path at the wavelengths lambda (which a dispersive lens may reduce to the hero),
  /// its random numbers from the sampler as it stands; splats into the film. Returns the number
  /// of splats dropped for non-finite values.
  int trace(SampledWavelengths& lambda, Sampler& sampler, Film& film, RayCounts& counts) const;
  /// The light that u in [0, 1) chooses by power, and its probability (0: none).
  size_t chooseLight(double u, double* pmf) const;

 private:
  const SceneContext* sc_;
  const camera::Camera* camera_;
  std::vector<const Light*> lights_;  ///< those with emission sampling
  std::vector<double> cdf_;           ///< by power (uniform if no power is known)
  double shutter_open_ = 0, shutter_close_ = 0;
  bool media_ = false;  ///< the scene's media are tracked
  bool flare_ = false;  ///< the camera's lens flare: ghost connections too (sampleGhostWi)
};

/// The light tracer as an integrator of the family (base.h): one light path per pixel sample.
/// Throws as LightTracer's constructor.
std::unique_ptr<Integrator> makeLightTracerIntegrator(const SceneContext& sc,
                                                      const camera::Camera& camera);

}  // namespace lensim::render
