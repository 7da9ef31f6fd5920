// pbrt-v3's directlighting integrator (see directlighting.h).
#include "lensim/render/integrators/directlighting.h"

#include <algorithm>
#include <cmath>

#include "lensim/render/integrators/base.h"
#include "lensim/scene/description.h"

namespace lensim::render {

using namespace lensim::sampling;

namespace {

struct Ctx {
  const SceneContext& sc;
  const DirectLightingOptions& opt;
  SampledWavelengths& lambda;
  Sampler& sampler;
  RayCounts& counts;
  double time;  ///< the path's shutter time
};

/// pbrt-v3's EstimateDirect (src/core/integrator.cpp) without media, over the non-specular part
/// of the BSDF: the light sample weighted against the BSDF's density, and, for lights that are
/// not delta lights, a BSDF sample weighted against the light's density.
SampledSpectrum estimateDirect(Ctx& c, const SurfaceHit& h, const Vec3& ns, const BSDF& bsdf,
                               const Vec3& wo, const Light& light) {
  SampledSpectrum Ld(0.0);
  const Vec2 u_light = c.sampler.get2D();
  const double uc = c.sampler.get1D();
  const Vec2 u_scatter = c.sampler.get2D();
  if (auto ls = light.sampleLi(h.p, u_light, c.lambda); ls && ls->pdf > 0 && !ls->L.isBlack()) {
    const SampledSpectrum f = bsdf.f(wo, ls->wi) * std::abs(dot(ls->wi, ns));
    if (!f.isBlack() &&
        !occludedScene(c.sc, h.p, h.ng, ls->p_light, ls->infinite, ls->wi, c.time, c.counts)) {
      if (light.isDelta()) {
        Ld += f * ls->L / ls->pdf;
      } else {
        const double pb = bsdf.pdf(wo, ls->wi);
        Ld += f * ls->L * (powerHeuristic(1, ls->pdf, 1, pb) / ls->pdf);
      }
    }
  }
  if (light.isDelta()) return Ld;
  auto bs = bsdf.sample_f(wo, uc, u_scatter);
  if (!bs || bs->isSpecular()) return Ld;
  const SampledSpectrum f = bs->f * std::abs(dot(bs->wi, ns));
  if (f.isBlack()) return Ld;
  const double pb = bs->pdf_is_proportional ? bsdf.pdf(wo, bs->wi) : bs->pdf;
  const Ray ray{offsetOrigin(h.p, h.ng, bs->wi), bs->wi, INFINITY, c.time};
  const auto hit = intersectScene(c.sc, ray, c.counts);
  SampledSpectrum Li(0.0);
  double pl = 0;
  if (hit) {
    if (c.sc.lights->areaLight(hit->shape, hit->prim) == &light) {
      Li = light.L(*hit, -bs->wi, c.lambda);
      pl = light.pdfLi(h.p, bs->wi, &*hit);
    }
  } else if (light.isInfinite()) {
    Li = light.Le(bs->wi, c.lambda);
    pl = light.pdfLi(h.p, bs->wi, nullptr);
  }
  if (Li.isBlack() || pl <= 0) return Ld;
  return Ld + f * Li * (powerHeuristic(1, pb, 1, pl) / bs->pdf);
}

SampledSpectrum li(Ctx& c, Ray ray, int depth) {
  SampledSpectrum L(0.0);
  std::optional<SurfaceHit> hit;
  int material = -1;
  TextureEvalContext tctx;
  // Surfaces without a BSDF (pbrt's "interface") are passed at the same depth.
  for (InterfaceGuard interfaces;;) {
    hit = intersectScene(c.sc, ray, c.counts);
    if (!hit) {
      for (const Light* light : c.sc.lights->infinite()) L += light->Le(ray.d, c.lambda);
      return L;
    }
    tctx = TextureEvalContext{hit->p, hit->uv, hit->ns};
    material =
        c.sc.materials->resolve(c.sc.scene->shapes[size_t(hit->shape)].material, tctx, -ray.d);
    if (!c.sc.materials->isInterface(material)) break;
    if (interfaces.cross()) return L;
    ray.o = offsetOrigin(hit->p, hit->ng, ray.d);
  }
  const SurfaceHit& h = *hit;
  const Vec3 wo = -ray.d;
  if (const Light* area = c.sc.lights->areaLight(h.shape, h.prim)) L += area->L(h, wo, c.lambda);
  auto bxdf = c.sc.materials->bxdf(material, tctx, c.lambda);
  const Vec3 ns = materialShadingNormal(c.sc, material, tctx, h);
  const BSDF bsdf(ns, h.dpdu, bxdf);

  const size_t n_lights = c.sc.lights->size();
  if (n_lights > 0 && isNonSpecular(bsdf.flags())) {
    if (c.opt.all_lights) {
      // UniformSampleAllLights: each light's nsamples estimates, averaged.
      for (size_t i = 0; i < n_lights; ++i) {
        const Light& light = c.sc.lights->light(i);
        const int n = std::max(1, light.n_samples);
        SampledSpectrum Ld(0.0);
        for (int k = 0; k < n; ++k) Ld += estimateDirect(c, h, ns, bsdf, wo, light);
        L += n == 1 ? Ld : Ld / double(n);
      }
    } else {
      // UniformSampleOneLight: a light chosen uniformly, divided by its probability 1/n.
      const double u = c.sampler.get1D();
      const size_t i = std::min(size_t(u * double(n_lights)), n_lights - 1);
      L += estimateDirect(c, h, ns, bsdf, wo, c.sc.lights->light(i)) * double(n_lights);
    }
  }
  // SpecularReflect / SpecularTransmit (pbrt-v3 src/core/integrator.cpp).
  if (depth + 1 < c.opt.max_depth && isSpecular(bsdf.flags())) {
    for (const ReflTrans side : {ReflTrans::Reflection, ReflTrans::Transmission}) {
      const double uc = c.sampler.get1D();
      const Vec2 u = c.sampler.get2D();
      auto bs = bsdf.sample_f(wo, uc, u, TransportMode::Radiance, side);
      if (!bs || !bs->isSpecular()) continue;
      if (bs->isReflection() != (side == ReflTrans::Reflection)) continue;
      const double cos = std::abs(dot(bs->wi, ns));
      if (!(bs->pdf > 0) || cos == 0 || bs->f.isBlack()) continue;
      const SampledSpectrum w = bs->f * (cos / bs->pdf);
      L += w * li(c, Ray{offsetOrigin(h.p, h.ng, bs->wi), bs->wi, INFINITY, c.time}, depth + 1);
    }
  }
  return L;
}

}  // namespace

SampledSpectrum directLightingLi(const SceneContext& sc, const DirectLightingOptions& opt,
                                 const Vec3& o, const Vec3& d, double time,
                                 SampledWavelengths& lambda, Sampler& sampler, RayCounts& counts) {
  Ctx c{sc, opt, lambda, sampler, counts, time};
  return li(c, Ray{o, d, INFINITY, time}, 0);
}

namespace {

class DirectLightingIntegrator final : public RayIntegrator {
 public:
  DirectLightingIntegrator(const SceneContext& sc, const DirectLightingOptions& opt)
      : sc_(&sc), opt_(opt) {}
  SampledSpectrum rayLi(const Vec3& o, const Vec3& d, double time, SampledWavelengths& lambda,
                        Sampler& sampler, RayCounts& counts) const override {
    return directLightingLi(*sc_, opt_, o, d, time, lambda, sampler, counts);
  }

 private:
  const SceneContext* sc_;
  DirectLightingOptions opt_;
};

}  // namespace

std::unique_ptr<Integrator> makeDirectLightingIntegrator(const SceneContext& sc,
                                                         const DirectLightingOptions& opt) {
  return std::make_unique<DirectLightingIntegrator>(sc, opt);
}

}  // namespace lensim::render
