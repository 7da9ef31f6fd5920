// Light transport: pbrt-v4's "path" integrator (unidirectional path tracing with next-event
// estimation, multiple importance sampling by the power heuristic and Russian roulette).
// "directlighting" is the same with maxdepth 1 (mapped by the scene builder).
#pragma once

#include <cstdint>

#include "lensim/render/lights/lights.h"
#include "lensim/render/materials/materials.h"
#include "lensim/render/shapes/accel.h"
#include "lensim/render/textures/textures.h"
#include "lensim/sampling/sampler.h"
#include "lensim/util/transform.h"

namespace lensim::scene {
struct Scene;
}

namespace lensim::render {

using namespace lensim::sampling;

class Media;

/// Everything the integrator reads; all of it is immutable during a render.
struct SceneContext {
  const scene::Scene* scene = nullptr;
  const Accel* accel = nullptr;
  const Textures* textures = nullptr;
  const Materials* materials = nullptr;
  const LightSet* lights = nullptr;
  int max_depth = 5;
  bool regularize = false;  ///< pbrt-v4's "regularize": roughen near-specular BSDFs after a
                            ///< non-specular bounce
  bool has_alpha = false;   ///< some shape has an alpha texture
  /// Reproduce pbrt-v2's ray epsilon (RenderOptions::pbrt_v2_quirks): a hit at ray parameter t
  /// gets epsilon 1e-3 t (triangles) or 5e-4 t (quadrics), where a camera ray's parameter is
  /// counted in camera-space units (pbrt-v2 normalises camera rays there), and shadow and
  /// BSDF-sampled rays from the hit skip everything closer than epsilon (scene units). With a
  /// scaled camera transform this skips shadows and distant light hits.
  bool pbrt_v2_epsilon = false;
  Transform camera_from_world;   ///< for pbrt_v2_epsilon
  const Media* media = nullptr;  ///< participating media (volpath); nullptr or empty: none
  int camera_medium = -1;        ///< the medium camera rays start in (Scene::media index)
  bool has_interfaces = false;   ///< some material is "interface" (volpath's shadow rays pass)
  /// Scene media (MediumInterface, the camera's medium) are rendered; false when the path
  /// integrator uses volpath's code for subsurface materials only.
  bool scene_media = true;
};

/// Per-thread ray counts.
struct RayCounts {
  uint64_t intersect = 0, shadow = 0;
  /// Lens flare: light-side connections through a ghost path of the lens that carried light
  /// to the film (the light tracer's sampleGhostWi splats; bdpt's s >= 1 strategies of a ghost
  /// camera subpath).
  uint64_t ghost_connections = 0;
};

/// The closest hit along the ray, skipping surfaces cut out by alpha textures.
std::optional<SurfaceHit> intersectScene(const SceneContext& sc, Ray ray, RayCounts& counts);
/// A shadow ray from `origin` (already offset) to the point `to`, stopping just short of it
/// (t < 1 - 1e-4 with the unnormalised direction to - origin), or, when `infinite`, along the
/// direction `to` without end.
inline Ray shadowRay(const Vec3& origin, const Vec3& to, bool infinite, double time) {
  Ray r;
  r.o = origin;
  r.time = time;
  r.d = infinite ? to : to - origin;
  r.tmax = infinite ? INFINITY : 1 - 1e-4;
  return r;
}
/// Whether the segment from p (offset along n) to p_light is blocked at shutter time `time`;
/// infinite: toward direction wi without end.
bool occludedScene(const SceneContext& sc, const Vec3& p, const Vec3& n, const Vec3& p_light,
                   bool infinite, const Vec3& wi, double time, RayCounts& counts);

/// Radiance along the camera ray (origin o, unit direction d, shutter time `time`: every ray of
/// the path is traced at it, as pbrt-v4's rays inherit their parent's time) at the sampled
/// wavelengths (which may be reduced to the hero wavelength by dispersive materials).
SampledSpectrum pathLi(const SceneContext& sc, const Vec3& o, const Vec3& d, double time,
                       SampledWavelengths& lambda, Sampler& sampler, RayCounts& counts);

/// A ray origin moved off the surface at p (normal n) to the side of direction w, far enough
/// to escape the surface's float-precision error.
Vec3 offsetOrigin(const Vec3& p, const Vec3& n, const Vec3& w);

}  // namespace lensim::render
