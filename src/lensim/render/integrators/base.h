// The integrator family: what the renderer's tile loop (render/renderer.cpp) asks of an
// integrator, and makeIntegrator, which makes the scene's. Two kinds, as pbrt-v4's
// RayIntegrator and its light-path integrators:
// - camera-sample integrators estimate each camera sample's pixel value (Li): path, volpath and
//   directlighting from the camera ray alone (RayIntegrator), bdpt also from a light subpath
//   whose connections to the camera splat anywhere in the image;
// - the light tracer traces one light path per pixel sample, without camera rays
//   (tracesLightPaths, traceLightPath), every contribution a splat.
// Adding an integrator: a class deriving from RayIntegrator (or Integrator) in its own file, and
// its name in makeIntegrator (integrators/factory.cpp). docs/developer-guide.md walks through it.
#pragma once

#include <cstdint>
#include <memory>

#include "lensim/render/integrators/integrator.h"

namespace lensim::scene {
struct Scene;
}
namespace lensim::camera {
class Camera;
struct CameraRay;
}  // namespace lensim::camera

namespace lensim::render {

using namespace lensim::sampling;

class Film;
class Media;

/// The most surfaces without a BSDF (pbrt's "interface" material, medium boundaries) one ray of
/// a path passes before the path is ended (a scene of interfaces only would loop forever).
constexpr int kMaxInterfaceCrossings = 100;

/// Counts the interfaces a path's ray passes: cross() is true once there were too many.
class InterfaceGuard {
 public:
  bool cross() { return ++crossed_ > kMaxInterfaceCrossings; }

 private:
  int crossed_ = 0;
};

class Integrator {
 public:
  virtual ~Integrator() = default;
  /// Whether its samples splat anywhere in the image (false: each sample adds to its own pixel
  /// only). The film must then have splats enabled.
  virtual bool splats() const { return false; }
  /// Whether a pixel sample is one light path without a camera ray: the tile loop calls
  /// traceLightPath instead of generating camera rays and calling Li.
  virtual bool tracesLightPaths() const { return false; }
  /// One light path at wavelengths lambda, its random numbers from the sampler as it stands;
  /// splats into the film. Returns the number of splats dropped for non-finite values.
  virtual int traceLightPath(SampledWavelengths& /*lambda*/, Sampler& /*sampler*/, Film& /*film*/,
                             RayCounts& /*counts*/) const {
    return 0;
  }
  /// Whether Li is called for a camera sample without a camera ray (bdpt: its light subpath
  /// splats all the same).
  virtual bool estimatesWithoutCameraRay() const { return false; }
  /// Whether a dispersive lens keeps only the hero wavelength of its camera rays (bdpt: its
  /// light subpaths share the camera path's wavelengths).
  virtual bool heroWavelengthOnly() const { return false; }
  /// The pixel estimate of one camera sample: its camera ray (nullptr where the lens blocked
  /// it, only when estimatesWithoutCameraRay()), its shutter time, with the camera ray's weight
  /// applied. Splats go into `film`; those with non-finite values are dropped and counted in
  /// `dropped`.
  virtual SampledSpectrum Li(const camera::CameraRay* ray, double time, SampledWavelengths& lambda,
                             Sampler& sampler, RayCounts& counts, Film& film,
                             uint64_t& dropped) const = 0;
};

/// An integrator of the radiance along the camera ray alone (path, volpath, directlighting): Li
/// is rayLi weighted by the camera ray's weight (per wavelength where the lens gives one).
class RayIntegrator : public Integrator {
 public:
  SampledSpectrum Li(const camera::CameraRay* ray, double time, SampledWavelengths& lambda,
                     Sampler& sampler, RayCounts& counts, Film& film,
                     uint64_t& dropped) const final;
  /// Radiance arriving along the camera ray (origin o, unit direction d, shutter time `time`).
  virtual SampledSpectrum rayLi(const Vec3& o, const Vec3& d, double time,
                                SampledWavelengths& lambda, Sampler& sampler,
                                RayCounts& counts) const = 0;
};

/// The path integrator over `sc` (pathLi, integrator.h), which must outlive it.
std::unique_ptr<Integrator> makePathIntegrator(const SceneContext& sc);

/// What makeIntegrator needs.
struct IntegratorSetup {
  const scene::Scene* scene = nullptr;
  /// The integrator's scene; makeIntegrator sets its media fields (media, scene_media,
  /// camera_medium) for the integrator chosen. It must outlive the integrator.
  SceneContext* sc = nullptr;
  const Media* media = nullptr;
  const camera::Camera* camera = nullptr;
  bool pbrt_v2_quirks = false;
  /// The render setting that rules out splatting integrators (e.g. "--tile", "checkpoints"), or
  /// nullptr when there is none.
  const char* refuses_splats = nullptr;
};

/// The scene's integrator (Scene::integrator): "path", "volpath", "directlighting",
/// "lighttracer" or "bdpt" (the scene builder maps pbrt's other names). A scene with subsurface
/// materials renders "path" as volpath (which tracks them); "bdpt" of a scene it cannot render
/// renders as path or volpath, with a warning. Throws lensim::Error naming the integrator's
/// location for a splatting integrator with setup.refuses_splats set.
std::unique_ptr<Integrator> makeIntegrator(const IntegratorSetup& setup);

/// The shading normal at the hit h of `material` (texture context tctx): the material's normal
/// map, then its bump map, applied to the interpolated normal h.ns.
Vec3 materialShadingNormal(const SceneContext& sc, int material, const TextureEvalContext& tctx,
                           const SurfaceHit& h);

/// How emission found along a path's ray (an infinite light's where the ray escapes, an area
/// light's where it hits one) is weighted against next-event estimation at the path's previous
/// vertex. For each light with non-black emission Le along `ray` (hit: nullptr where the ray
/// escaped), calls add(Le, p_light) with p_light the pdf with which light sampling at prev_p
/// (shading normal prev_n, zero in a medium) would have chosen the ray's direction, or
/// add(Le, std::nullopt) when the emission counts in full (counted_in_full: the camera ray, or
/// after a specular bounce, where no light was sampled).
template <typename Add>
void foundEmission(const SceneContext& sc, const Ray& ray, const SurfaceHit* hit,
                   const SampledWavelengths& lambda, const Vec3& prev_p, const Vec3& prev_n,
                   bool counted_in_full, Add&& add) {
  const auto one = [&](const Light* light, const SampledSpectrum& Le) {
    if (Le.isBlack()) return;
    if (counted_in_full) {
      add(Le, std::optional<double>());
    } else {
      add(Le, std::optional<double>(sc.lights->pmf({prev_p, prev_n}, light) *
                                    light->pdfLi(prev_p, ray.d, hit)));
    }
  };
  if (!hit) {
    for (const Light* light : sc.lights->infinite()) one(light, light->Le(ray.d, lambda));
  } else if (const Light* area = sc.lights->areaLight(hit->shape, hit->prim)) {
    one(area, area->L(*hit, -ray.d, lambda));
  }
}

}  // namespace lensim::render
