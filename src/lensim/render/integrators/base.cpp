// The integrator family's shared parts and the factory. See base.h.
#include "lensim/render/integrators/base.h"

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <string_view>

#include "lensim/camera/camera.h"
#include "lensim/render/integrators/bdpt.h"
#include "lensim/render/integrators/directlighting.h"
#include "lensim/render/integrators/lighttracer.h"
#include "lensim/render/integrators/volpath.h"
#include "lensim/render/media/media.h"
#include "lensim/scene/description.h"
#include "lensim/util/check.h"
#include "lensim/util/error.h"
#include "lensim/util/log.h"

namespace lensim::render {

using namespace lensim::sampling;

Vec3 materialShadingNormal(const SceneContext& sc, int material, const TextureEvalContext& tctx,
                           const SurfaceHit& h) {
  Vec3 ns = sc.materials->shadingNormal(material, tctx, h.ns, h.dpdu);
  if (sc.materials->hasBump(material))
    ns = sc.materials->bumpedNormal(material, tctx, ns, h.dpdu, h.dpdv, h.dndu, h.dndv);
  return ns;
}

SampledSpectrum RayIntegrator::Li(const camera::CameraRay* ray, double /*time*/,
                                  SampledWavelengths& lambda, Sampler& sampler,
                                  RayCounts& counts, Film& /*film*/,
                                  uint64_t& /*dropped*/) const {
  LENSIM_DCHECK(ray != nullptr);
  LENSIM_DCHECK_NEAR(length(ray->direction), 1, 1e-6);
  SampledSpectrum L = rayLi(ray->origin, ray->direction, ray->time, lambda, sampler, counts);
  // A dispersive lens that weights each wavelength by its own film point.
  if (ray->per_wavelength && !lambda.secondaryTerminated()) {
    for (int c = 0; c < kSpectrumSamples; ++c) L[c] *= ray->wavelength_weight[size_t(c)];
  } else {
    L = L * ray->weight;
  }
  return L;
}

namespace {

enum class IntegratorKind { Path, VolPath, DirectLighting, LightTracer, Bdpt };

struct IntegratorName {
  std::string_view name;
  IntegratorKind kind;
  const char* splats;  ///< what of its samples splats anywhere in the image, or nullptr
};

constexpr std::array<IntegratorName, 5> kIntegrators{{
    {"path", IntegratorKind::Path, nullptr},
    {"volpath", IntegratorKind::VolPath, nullptr},
    {"directlighting", IntegratorKind::DirectLighting, nullptr},
    {"lighttracer", IntegratorKind::LightTracer, "light paths"},
    {"bdpt", IntegratorKind::Bdpt, "light subpaths"},
}};

/// The entry of the scene's integrator; others (which the scene builder maps) render as path.
const IntegratorName& lookup(const std::string& type) {
  for (const IntegratorName& n : kIntegrators)
    if (n.name == type) return n;
  return kIntegrators[0];
}

}  // namespace

std::unique_ptr<Integrator> makeIntegrator(const IntegratorSetup& setup) {
  LENSIM_CHECK(setup.scene && setup.sc && setup.media && setup.camera);
  const scene::Scene& scene = *setup.scene;
  SceneContext& sc = *setup.sc;
  const Media& media = *setup.media;
  const IntegratorName& entry = lookup(scene.integrator.type);
  // Subsurface materials need volpath's tracking (render/media/subsurface.h): the path integrator
  // renders them with it too, without the scene's media (which it ignores, with a warning).
  bool volpath = entry.kind == IntegratorKind::VolPath || media.hasSubsurface();
  // lighttracer and bdpt track the scene's media too (render/integrators/media_tracking.h).
  const bool splatting = entry.splats != nullptr;
  if (volpath || splatting) sc.media = &media;
  sc.scene_media = entry.kind == IntegratorKind::VolPath || splatting;
  sc.camera_medium = scene.camera.medium;
  if (entry.kind == IntegratorKind::DirectLighting) {
    // pbrt-v1–v3's directlighting (render/integrators/directlighting.h).
    if (setup.pbrt_v2_quirks)
      logWarning(
          fmt::format("{}: --pbrt-v2-quirks: pbrt-v2's ray epsilon is reproduced by the path "
                      "integrator only; \"directlighting\" uses lensim's ray offsets",
                      scene.integrator.loc.str()));
    return makeDirectLightingIntegrator(
        sc, DirectLightingOptions{scene.integrator.all_lights, scene.integrator.max_depth});
  }
  // A splatting integrator (lighttracer, bdpt): each pixel sample starts a light path that
  // splats anywhere in the image, so a tile's pixels are not its own: no tiles of a distributed
  // render, no exact part sums, no checkpoints, no resuming (render/film.h, splats).
  if (splatting && setup.refuses_splats)
    throw Error(scene.integrator.loc,
                fmt::format("integrator \"{}\" does not support {}: its {} splat anywhere in "
                            "the image (split a render by --spp-range and average the images "
                            "instead)",
                            entry.name, setup.refuses_splats, entry.splats));
  if (entry.kind == IntegratorKind::LightTracer)
    return makeLightTracerIntegrator(sc, *setup.camera);
  if (entry.kind == IntegratorKind::Bdpt) {
    // Scenes bdpt cannot render (a camera without importance, lights without emission sampling)
    // render with path (volpath where the scene has media), warned.
    const std::string why = BdptIntegrator::unsupported(sc, *setup.camera);
    if (why.empty()) return makeBdptFamilyIntegrator(sc, *setup.camera);
    volpath = volpath || !media.empty();
    logWarning(fmt::format("{}: integrator \"bdpt\" renders as \"{}\": {}",
                           scene.integrator.loc.str(), volpath ? "volpath" : "path", why));
  }
  return volpath ? makeVolPathIntegrator(sc) : makePathIntegrator(sc);
}

}  // namespace lensim::render
