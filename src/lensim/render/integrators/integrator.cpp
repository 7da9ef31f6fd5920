// The path integrator. Estimator as pbrt-v4's PathIntegrator (Pharr, Jakob, Humphreys, 4th ed.,
// sec. 13.3-13.4; Veach 1997 for MIS): emission found by BSDF sampling is weighted against light
// sampling with the power heuristic, next-event estimation at every non-specular vertex, Russian
// roulette after the first bounces when the throughput (times the squared relative index crossed)
// falls below 1.
#include "lensim/render/integrators/integrator.h"

#include "lensim/render/integrators/base.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "lensim/scene/description.h"
#include "lensim/util/check.h"

namespace lensim::render {

using namespace lensim::sampling;

Vec3 offsetOrigin(const Vec3& p, const Vec3& n, const Vec3& w) {
  const double m = std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)});
  const double eps = 2e-5 * (1 + m);
  return p + n * (dot(n, w) < 0 ? -eps : eps);
}

namespace {

/// A uniform number in [0,1) from a hit's position, for stochastic alpha (deterministic).
double hashUniform(const Vec3& p, const Vec3& d) {
  auto bits = [](double v) {
    uint64_t u;
    std::memcpy(&u, &v, sizeof u);
    return u;
  };
  const uint64_t h = hashValues({bits(p.x), bits(p.y), bits(p.z), bits(d.x), bits(d.y)});
  return double(h >> 11) * 0x1.0p-53;
}

bool cutOut(const SceneContext& sc, const SurfaceHit& h, const Vec3& d) {
  const scene::Shape& s = sc.scene->shapes[size_t(h.shape)];
  if (!s.alpha) return false;
  const double a = sc.textures->evalFloat(*s.alpha, {h.p, h.uv, h.ns});
  if (a >= 1) return false;
  if (a <= 0) return true;
  return hashUniform(h.p, d) > a;
}

/// pbrt-v2's ray epsilon at a hit (see SceneContext::pbrt_v2_epsilon), in scene units.
double pbrtV2Epsilon(const SceneContext& sc, const SurfaceHit& h, const Ray& ray, bool camera_ray) {
  const double len = length(ray.d);
  double t = h.t * len;  // scene units
  if (camera_ray) t *= length(sc.camera_from_world.applyVector(ray.d / len));
  const scene::ShapeType type = sc.scene->shapes[size_t(h.shape)].type;
  const bool triangles =
      type == scene::ShapeType::TriangleMesh || type == scene::ShapeType::BilinearMesh;
  return (triangles ? 1e-3 : 5e-4) * t;
}

/// Whether the light sample is blocked, the segment starting `skip` scene units from the hit (as
/// pbrt-v2's VisibilityTester: from epsilon to (1 - 1e-3) of the distance; empty, hence
/// unblocked, when epsilon is longer).
bool shadowed(const SceneContext& sc, const SurfaceHit& h, const LightLiSample& ls, double skip,
              double time, RayCounts& counts) {
  if (skip > 0 && !ls.infinite && skip >= length(ls.p_light - h.p) * (1 - 1e-3)) return false;
  return occludedScene(sc, h.p + ls.wi * skip, h.ng, ls.p_light, ls.infinite, ls.wi, time, counts);
}

}  // namespace

std::optional<SurfaceHit> intersectScene(const SceneContext& sc, Ray ray, RayCounts& counts) {
  for (int guard = 0; guard < 256; ++guard) {
    ++counts.intersect;
    auto h = sc.accel->intersect(ray);
    if (!h || !sc.has_alpha || !cutOut(sc, *h, ray.d)) return h;
    const Vec3 o = offsetOrigin(h->p, h->ng, ray.d);
    if (std::isfinite(ray.tmax)) ray.tmax -= dot(o - ray.o, ray.d) / dot(ray.d, ray.d);
    ray.o = o;
    if (ray.tmax <= 0) return std::nullopt;
  }
  return std::nullopt;
}

bool occludedScene(const SceneContext& sc, const Vec3& p, const Vec3& n, const Vec3& p_light,
                   bool infinite, const Vec3& wi, double time, RayCounts& counts) {
  const Ray r = shadowRay(offsetOrigin(p, n, wi), infinite ? wi : p_light, infinite, time);
  if (!sc.has_alpha) {
    ++counts.shadow;
    return sc.accel->occluded(r);
  }
  return intersectScene(sc, r, counts).has_value();
}

SampledSpectrum pathLi(const SceneContext& sc, const Vec3& o, const Vec3& d, double time,
                       SampledWavelengths& lambda, Sampler& sampler, RayCounts& counts) {
  SampledSpectrum L(0.0), beta(1.0);
  bool specular_bounce = false;
  double eta_scale = 1;
  double prev_pdf = 0;  // BSDF pdf of the last sampled direction (solid angle)
  Vec3 prev_p;
  Vec3 prev_ns;  // shading normal there (the light sampler's context)
  int depth = 0;
  InterfaceGuard interfaces;
  bool any_non_specular = false;
  Ray ray{o, d, INFINITY, time};
  for (;;) {
    auto hit = intersectScene(sc, ray, counts);
    // Emission found by BSDF sampling, weighted against light sampling by the power heuristic.
    foundEmission(sc, ray, hit ? &*hit : nullptr, lambda, prev_p, prev_ns,
                  depth == 0 || specular_bounce,
                  [&](const SampledSpectrum& Le, std::optional<double> pl) {
                    if (!pl)
                      L += beta * Le;
                    else
                      L += beta * Le * powerHeuristic(1, prev_pdf, 1, *pl);
                  });
    if (!hit) break;
    const SurfaceHit& h = *hit;
    const Vec3 wo = -ray.d;
    const double skip = sc.pbrt_v2_epsilon ? pbrtV2Epsilon(sc, h, ray, depth == 0) : 0.0;
    const TextureEvalContext tctx{h.p, h.uv, h.ns};
    const int material =
        sc.materials->resolve(sc.scene->shapes[size_t(h.shape)].material, tctx, wo);
    if (sc.materials->isInterface(material)) {
      if (interfaces.cross()) break;
      ray.o = offsetOrigin(h.p, h.ng, ray.d);
      continue;
    }
    if (depth++ == sc.max_depth) break;
    auto bxdf = sc.materials->bxdf(material, tctx, lambda, sc.regularize && any_non_specular);
    const Vec3 ns = materialShadingNormal(sc, material, tctx, h);
    const BSDF bsdf(ns, h.dpdu, bxdf);
    // Next-event estimation.
    const double u_light = sampler.get1D();
    const Vec2 u_light2 = sampler.get2D();
    if (isNonSpecular(bsdf.flags())) {
      if (auto choice = sc.lights->sample({h.p, ns}, u_light)) {
        if (auto ls = choice->light->sampleLi(h.p, u_light2, lambda)) {
          if (ls->pdf > 0 && !ls->L.isBlack()) {
            const SampledSpectrum f = bsdf.f(wo, ls->wi) * std::abs(dot(ls->wi, ns));
            if (!f.isBlack() && !shadowed(sc, h, *ls, skip, time, counts)) {
              const double pl = choice->pmf * ls->pdf;
              if (choice->light->isDelta()) {
                L += beta * f * ls->L / pl;
              } else {
                const double pb = bsdf.pdf(wo, ls->wi);
                L += beta * f * ls->L * (powerHeuristic(1, pl, 1, pb) / pl);
              }
            }
          }
        }
      }
    }
    // BSDF sampling.
    const double uc = sampler.get1D();
    const Vec2 u = sampler.get2D();
    auto bs = bsdf.sample_f(wo, uc, u);
    if (!bs) break;
    LENSIM_DCHECK_GT(bs->pdf, 0);
    LENSIM_DCHECK_FINITE(bs->pdf);
    beta *= bs->f * (std::abs(dot(bs->wi, ns)) / bs->pdf);
    prev_pdf = bs->pdf_is_proportional ? bsdf.pdf(wo, bs->wi) : bs->pdf;
    specular_bounce = bs->isSpecular();
    any_non_specular = any_non_specular || !specular_bounce;
    if (bs->isTransmission()) eta_scale *= bs->eta * bs->eta;
    prev_p = h.p;
    prev_ns = ns;
    ray = Ray{offsetOrigin(h.p + bs->wi * skip, h.ng, bs->wi), bs->wi, INFINITY, time};
    if (beta.isBlack()) break;
    const SampledSpectrum rr_beta = beta * eta_scale;
    const double u_rr = sampler.get1D();
    if (rr_beta.maxValue() < 1 && depth > 1) {
      const double q = std::max(0.0, 1 - rr_beta.maxValue());
      if (u_rr < q) break;
      beta /= 1 - q;
    }
  }
  return L;
}

namespace {

class PathIntegrator final : public RayIntegrator {
 public:
  explicit PathIntegrator(const SceneContext& sc) : sc_(&sc) {}
  SampledSpectrum rayLi(const Vec3& o, const Vec3& d, double time, SampledWavelengths& lambda,
                        Sampler& sampler, RayCounts& counts) const override {
    return pathLi(*sc_, o, d, time, lambda, sampler, counts);
  }

 private:
  const SceneContext* sc_;
};

}  // namespace

std::unique_ptr<Integrator> makePathIntegrator(const SceneContext& sc) {
  return std::make_unique<PathIntegrator>(sc);
}

}  // namespace lensim::render
