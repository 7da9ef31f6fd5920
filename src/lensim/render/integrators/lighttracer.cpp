// The light tracer; see lighttracer.h. The estimator follows pbrt-v4's
// LightPathIntegrator::EvaluatePixelSample (src/pbrt/cpu/integrators.cpp): the light's point is
// connected to the camera with weight Le |cos| W / (pmf pdf_pos pdf_camera), and every surface
// vertex with beta f |cos| W / pdf_camera, beta starting at Le |cos| / (pmf pdf_pos pdf_dir) and
// multiplied by f |cos| / pdf at each BSDF sample (importance transport); no Russian roulette;
// a path ends after maxdepth surface vertices, which gives it the path tracer's path lengths.
// Where pbrt-v4 divides the light's point by its solid-angle density from the lens, lensim
// uses the area density it sampled the point with (the two agree for area-sampled lights).
// Media (as pbrt-v4's LightPathIntegrator): the path is tracked through them by delta tracking
// (render/integrators/media_tracking.h) from the light's medium; real scattering events are
// vertices connected to the camera with the phase function, each connection carries the
// transmittance from the camera (in its medium) to the vertex, and chromatic media are weighted
// by the one-sample MIS over the hero wavelength as volpath's. Media's own emission is not
// traced (no light path starts in a medium; warned).
#include "lensim/render/integrators/lighttracer.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>

#include "lensim/camera/camera.h"
#include "lensim/render/film/film.h"
#include "lensim/render/integrators/media_tracking.h"
#include "lensim/render/materials/layered.h"
#include "lensim/scene/description.h"
#include "lensim/util/error.h"
#include "lensim/util/log.h"

namespace lensim::render {

using namespace lensim::sampling;

LightTracer::LightTracer(const SceneContext& sc, const camera::Camera& camera)
    : sc_(&sc),
      camera_(&camera),
      shutter_open_(sc.scene->camera.shutter_open),
      shutter_close_(sc.scene->camera.shutter_close),
      flare_(camera.flare()) {
  if (!camera.supportsImportance())
    throw Error(sc.scene->camera.loc,
                fmt::format("integrator \"lighttracer\": the camera ({}) has no importance "
                            "function, so light paths cannot reach its film; render it with "
                            "\"path\"",
                            camera.describe()));
  std::map<std::string, int> left_out;
  double total = 0;
  for (size_t i = 0; i < sc.lights->size(); ++i) {
    const Light& l = sc.lights->light(i);
    if (!l.supportsLe()) {
      ++left_out[l.typeName()];
      continue;
    }
    lights_.push_back(&l);
    total += std::max(0.0, l.power());
    cdf_.push_back(total);
  }
  if (total <= 0)  // no power known: uniform
    for (size_t i = 0; i < cdf_.size(); ++i) cdf_[i] = double(i + 1);
  media_ = sc.scene_media && sc.media && !sc.media->empty();
  if (media_) {
    bool emissive = false;
    for (size_t i = 0; i < sc.scene->media.size(); ++i)
      if (const Medium* m = sc.media->get(int(i))) emissive = emissive || m->isEmissive();
    if (emissive)
      logWarning(
          "integrator \"lighttracer\" does not trace the emission of media (no light "
          "path starts in a medium); \"volpath\" or \"bdpt\" render it");
  }
  for (const auto& [type, n] : left_out)
    logWarning(
        fmt::format("integrator \"lighttracer\": {} {} light{} cannot start light paths "
                    "(no emission sampling) and {} left out of the image",
                    n, type, n > 1 ? "s" : "", n > 1 ? "are" : "is"));
}

size_t LightTracer::chooseLight(double u, double* pmf) const {
  const double x = u * cdf_.back();
  const size_t k =
      size_t(std::min<std::ptrdiff_t>(std::upper_bound(cdf_.begin(), cdf_.end(), x) - cdf_.begin(),
                                      std::ptrdiff_t(cdf_.size()) - 1));
  *pmf = (cdf_[k] - (k > 0 ? cdf_[k - 1] : 0.0)) / cdf_.back();
  return k;
}

namespace {

// Splats L beta W / pdf at the connection's film point (ghost: into the ghost layer too); a
// non-finite value is dropped and counted. Whether it was splatted.
bool splatConnection(const camera::CameraWiSample& cs, SampledSpectrum L, SampledWavelengths& lambda,
                     Film& film, bool ghost, int& dropped) {
  if (cs.hero_only) lambda.terminateSecondary();
  for (int i = 0; i < kSpectrumSamples; ++i) L[i] *= cs.importance[size_t(i)] / cs.pdf;
  for (int i = 0; i < kSpectrumSamples; ++i)
    if (!std::isfinite(L[i])) {
      ++dropped;
      return false;
    }
  film.addSplat(cs.film_raster, L, lambda, ghost);
  return true;
}

}  // namespace

int LightTracer::trace(SampledWavelengths& lambda, Sampler& sampler, Film& film,
                       RayCounts& counts) const {
  const double u_light = sampler.get1D();
  const double u_time = sampler.get1D();
  const Vec2 u1 = sampler.get2D(), u2 = sampler.get2D();
  if (lights_.empty()) return 0;
  const double time = shutter_open_ + u_time * (shutter_close_ - shutter_open_);
  double pmf = 0;
  const Light& light = *lights_[chooseLight(u_light, &pmf)];
  if (!(pmf > 0)) return 0;
  std::array<double, camera::kCameraWavelengths> lambda_nm{};
  auto wavelengths = [&] {
    for (int i = 0; i < kSpectrumSamples; ++i) lambda_nm[size_t(i)] = lambda.lambda(i);
    return lambda_nm;
  };
  int dropped = 0;
  // Lens flare: each connection to the camera is also made through one ghost path of the lens
  // (Camera::sampleGhostWi: a pair drawn with the camera side's probabilities). One pair per
  // connection rather than all of them: with coatings each ghost path's thin-film stacks cost
  // tens of microseconds (docs/flare.md), and the pairs' probabilities follow their intensities.
  // Its random numbers come after the direct connection's, drawn only with flare.
  auto ghostU = [&] {
    std::array<double, 3> u{};
    if (flare_) {
      u[0] = sampler.get1D();
      const Vec2 v = sampler.get2D();
      u[1] = v.x, u[2] = v.y;
    }
    return u;
  };

  const Vec2 u_cam0 = sampler.get2D();
  const std::array<double, 3> u_ghost0 = ghostU();
  const std::optional<LightLeSample> les = light.sampleLe(u1, u2, lambda);
  if (!les || !(les->pdf_pos > 0) || !(les->pdf_dir > 0) || les->L.isBlack()) return 0;
  // Media and interface surfaces: connections are traced from the camera, in its medium.
  const bool tracked = media_ || sc_->has_interfaces;
  Rng rng;
  if (media_) rng = pathRng(sampler);
  const int camera_medium = media_ ? sc_->camera_medium : -1;
  // Whether the connection from the point p (on a surface of geometric normal ng, or zero) to
  // the lens is open; T its transmittance.
  auto visible = [&](const Vec3& p, const Vec3& ng, const camera::CameraWiSample& cs,
                     SampledSpectrum& T) {
    if (!tracked) return !occludedScene(*sc_, p, ng, cs.p_lens, false, cs.wi, time, counts);
    T = segmentTransmittance(*sc_, cs.p_lens, Vec3{0, 0, 0}, camera_medium, p, false, time, lambda,
                             rng, counts);
    return !T.isBlack();
  };
  // The connections from p to the camera: the direct one (u_cam) and, with lens flare, one
  // through a ghost path (u_ghost). value(cs): the splat before the importance, or nullopt.
  using Splat = std::optional<SampledSpectrum>;
  auto toCamera = [&](const Vec3& p, Vec2 u_cam, const std::array<double, 3>& u_ghost,
                      const auto& value) {
    if (auto cs = camera_->sampleWi(p, u_cam, wavelengths(), time); cs && cs->pdf > 0)
      if (const Splat L = value(*cs)) splatConnection(*cs, *L, lambda, film, false, dropped);
    if (flare_)
      if (auto cs = camera_->sampleGhostWi(p, u_ghost, wavelengths(), time); cs && cs->pdf > 0)
        if (const Splat L = value(*cs))
          if (splatConnection(*cs, *L, lambda, film, true, dropped) && !L->isBlack())
            ++counts.ghost_connections;
  };
  // The light's own point seen by the camera (area lights; a point light is a delta the film
  // cannot see).
  if (les->on_surface)
    toCamera(les->o, u_cam0, u_ghost0, [&](const camera::CameraWiSample& cs) -> Splat {
      SurfaceHit h;
      h.ng = les->n;
      h.uv = les->uv;
      const SampledSpectrum Le = light.L(h, cs.wi, lambda);
      SampledSpectrum T(1.0);
      if (Le.isBlack() || !visible(les->o, les->n, cs, T)) return std::nullopt;
      return T * Le * (std::abs(dot(les->n, cs.wi)) / (pmf * les->pdf_pos));
    });
  const double cos0 = les->on_surface ? std::abs(dot(les->n, les->d)) : 1.0;
  SampledSpectrum beta = les->L * (cos0 / (pmf * les->pdf_pos * les->pdf_dir));
  SampledSpectrum r(1.0);  // chromatic media: media_tracking.h
  int medium = media_ ? lightMedium(*sc_, light) : -1;
  if (light.isInfinite() || light.isDeltaDirection())
    beta *= transmittanceFromInfinity(*sc_, medium, lambda);
  Ray ray{les->on_surface ? offsetOrigin(les->o, les->n, les->d) : les->o, les->d, INFINITY, time};
  int depth = 0;
  InterfaceGuard interfaces;
  for (;;) {
    const auto hit = intersectScene(*sc_, ray, counts);
    if (const Medium* m = media_ ? sc_->media->get(medium) : nullptr) {
      const double len = length(ray.d);
      const Vec3 dir = ray.d / len;
      const MediumEvent ev = trackMedium(*m, ray.o, dir, hit ? hit->t * len : INFINITY, lambda,
                                         sampler, rng, beta, r, nullptr);
      if (ev.kind == MediumEvent::Kind::Absorbed) break;
      if (ev.kind == MediumEvent::Kind::Scattered) {
        if (depth++ == sc_->max_depth) break;
        const HenyeyGreenstein phase(m->g());
        const Vec2 u_cam = sampler.get2D();
        const std::array<double, 3> u_ghost = ghostU();
        toCamera(ev.p, u_cam, u_ghost, [&](const camera::CameraWiSample& cs) -> Splat {
          SampledSpectrum T(1.0);
          const double ph = phase.p(-dir, cs.wi);
          if (!(ph > 0) || !visible(ev.p, Vec3{0, 0, 0}, cs, T)) return std::nullopt;
          if (cs.hero_only) lambda.terminateSecondary();
          return T * beta * ph / wavelengthMean(r, lambda);
        });
        auto ps = phase.sample(-dir, sampler.get2D());
        if (!ps || ps->pdf <= 0) break;
        beta *= ps->p / ps->pdf;
        ray = Ray{ev.p, ps->wi, INFINITY};
        continue;
      }
    }
    if (!hit) break;
    const SurfaceHit& h = *hit;
    const Vec3 wo = -ray.d;
    const TextureEvalContext tctx{h.p, h.uv, h.ns};
    const int material =
        sc_->materials->resolve(sc_->scene->shapes[size_t(h.shape)].material, tctx, wo);
    if (sc_->materials->isInterface(material)) {
      if (interfaces.cross()) break;
      if (media_) medium = mediumAfter(*sc_, h, ray.d, medium, false);
      ray.o = offsetOrigin(h.p, h.ng, ray.d);
      continue;
    }
    if (depth++ == sc_->max_depth) break;
    auto bxdf = sc_->materials->bxdf(material, tctx, lambda, false);
    const Vec3 ns = materialShadingNormal(*sc_, material, tctx, h);
    const BSDF bsdf(ns, h.dpdu, bxdf);
    // Connect to the camera.
    const Vec2 u_cam = sampler.get2D();
    const std::array<double, 3> u_ghost = ghostU();
    if (isNonSpecular(bsdf.flags()))
      toCamera(h.p, u_cam, u_ghost, [&](const camera::CameraWiSample& cs) -> Splat {
        const SampledSpectrum f =
            bsdf.f(wo, cs.wi, TransportMode::Importance) * std::abs(dot(cs.wi, ns));
        SampledSpectrum T(1.0);
        if (f.isBlack() || !visible(h.p, h.ng, cs, T)) return std::nullopt;
        if (cs.hero_only) lambda.terminateSecondary();
        return T * beta * f / wavelengthMean(r, lambda);
      });
    // Continue the path.
    const double uc = sampler.get1D();
    const Vec2 u = sampler.get2D();
    auto bs = bsdf.sample_f(wo, uc, u, TransportMode::Importance);
    if (!bs) break;
    beta *= bs->f * (std::abs(dot(bs->wi, ns)) / bs->pdf);
    if (beta.isBlack()) break;
    if (media_) medium = mediumAfter(*sc_, h, bs->wi, medium, false);
    ray = Ray{offsetOrigin(h.p, h.ng, bs->wi), bs->wi, INFINITY, time};
  }
  return dropped;
}

namespace {

class LightTracerIntegrator final : public Integrator {
 public:
  LightTracerIntegrator(const SceneContext& sc, const camera::Camera& camera)
      : tracer_(sc, camera) {}
  bool splats() const override { return true; }
  bool tracesLightPaths() const override { return true; }
  int traceLightPath(SampledWavelengths& lambda, Sampler& sampler, Film& film,
                     RayCounts& counts) const override {
    return tracer_.trace(lambda, sampler, film, counts);
  }
  SampledSpectrum Li(const camera::CameraRay*, double, SampledWavelengths&, Sampler&, RayCounts&,
                     Film&, uint64_t&) const override {
    return SampledSpectrum(0.0);  // never called: tracesLightPaths()
  }

 private:
  LightTracer tracer_;
};

}  // namespace

std::unique_ptr<Integrator> makeLightTracerIntegrator(const SceneContext& sc,
                                                      const camera::Camera& camera) {
  return std::make_unique<LightTracerIntegrator>(sc, camera);
}

}  // namespace lensim::render
