// The bdpt integrator. Structure and MIS as pbrt-v4's src/pbrt/cpu/integrators.cpp
// (BDPTIntegrator::Li, GenerateCameraSubpath, GenerateLightSubpath, RandomWalk, ConnectBDPT,
// MISWeight, InfiniteLightDensity) and its Vertex (integrators.h): read there, written anew.
#include "lensim/render/integrators/bdpt.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "lensim/camera/camera.h"
#include "lensim/render/film/film.h"
#include "lensim/render/integrators/media_tracking.h"
#include "lensim/render/materials/layered.h"
#include "lensim/scene/description.h"
#include "lensim/util/error.h"

namespace lensim::render {

using namespace lensim::sampling;
namespace bdpt {

namespace {

Vec3 unitOrZero(const Vec3& v, double& len2) {
  len2 = dot(v, v);
  return len2 > 0 ? v / std::sqrt(len2) : Vec3{0, 0, 0};
}

/// pbrt-v4's CorrectShadingNormal: light paths scattered with shading normals need the
/// adjoint's factor |wo.ns||wi.ng| / (|wo.ng||wi.ns|) (Veach 1997, sec. 5.3).
double correctShadingNormal(const Vertex& v, const Vec3& wo, const Vec3& wi, TransportMode mode) {
  if (mode != TransportMode::Importance) return 1;
  const double num = std::abs(dot(wo, v.ns) * dot(wi, v.ng));
  const double den = std::abs(dot(wo, v.ng) * dot(wi, v.ns));
  return den == 0 ? 0 : num / den;
}

/// Radiance emitted by the light vertex v toward `toward`.
SampledSpectrum emitted(const Context& ctx, const Vertex& v, const Vertex& toward,
                        const SampledWavelengths& lambda) {
  if (!isLight(v)) return SampledSpectrum(0.0);
  double d2;
  const Vec3 w = unitOrZero(toward.p - v.p, d2);
  if (d2 == 0) return SampledSpectrum(0.0);
  if (isInfiniteLight(v)) {
    SampledSpectrum Le(0.0);
    for (const Light* l : ctx.infinite) Le += l->Le(-w, lambda);
    return Le;
  }
  return v.light->L(v.hit, w, lambda);
}

/// The scattering function at v toward next: the BSDF at a surface vertex, the phase function
/// at a medium vertex (pbrt-v4's Vertex::f).
SampledSpectrum scatterF(const Vertex& v, const Vertex& next, TransportMode mode) {
  double d2;
  const Vec3 wi = unitOrZero(next.p - v.p, d2);
  if (d2 == 0) return SampledSpectrum(0.0);
  if (v.type == VertexType::Medium) return SampledSpectrum(HenyeyGreenstein(v.g).p(v.wo, wi));
  if (v.type != VertexType::Surface) return SampledSpectrum(0.0);
  return v.bsdf.f(v.wo, wi, mode);
}

/// Density of the infinite lights sending light along the propagation direction w (pbrt-v4's
/// InfiniteLightDensity): their choice probability times the density of the direction -w.
double infiniteLightDensity(const Context& ctx, const Vec3& w) {
  double pdf = 0;
  for (const Light* l : ctx.infinite)
    pdf += ctx.light_sampler->pmf({}, l) * l->pdfLi(Vec3{0, 0, 0}, -w, nullptr);
  return pdf;
}

/// A surface vertex at a hit, with its BSDF; nullopt for an "interface" material (the walk
/// passes through).
bool makeSurfaceVertex(const Context& ctx, const SurfaceHit& h, const Vec3& ray_d,
                       SampledWavelengths& lambda, bool regularize, Vertex& v) {
  const SceneContext& sc = *ctx.sc;
  const Vec3 wo = -normalize(ray_d);
  const TextureEvalContext tctx{h.p, h.uv, h.ns};
  const int material = sc.materials->resolve(sc.scene->shapes[size_t(h.shape)].material, tctx, wo);
  if (sc.materials->isInterface(material)) return false;
  auto bxdf = sc.materials->bxdf(material, tctx, lambda, regularize);
  const Vec3 ns = materialShadingNormal(sc, material, tctx, h);
  v = Vertex{};
  v.type = VertexType::Surface;
  v.p = h.p;
  v.ng = h.ng;
  v.ns = ns;
  v.wo = wo;
  v.bsdf = BSDF(ns, h.dpdu, bxdf);
  v.hit = h;
  v.light = sc.lights->areaLight(h.shape, h.prim);
  return true;
}

/// pbrt-v4's RandomWalk: extends path[1..] from path[0] along ray, which starts in `medium`;
/// returns the number of vertices added. L_medium: see cameraSubpath.
int randomWalk(const Context& ctx, Ray ray, int medium, SampledWavelengths& lambda,
               Sampler& sampler, Rng* rng, SampledSpectrum beta, double pdf_dir, int max_depth,
               TransportMode mode, RayCounts& counts, Vertex* path, SampledSpectrum* L_medium) {
  if (max_depth <= 0) return 0;
  const SceneContext& sc = *ctx.sc;
  int bounces = 0;
  InterfaceGuard interfaces;
  bool any_non_specular = false;
  double pdf_fwd = pdf_dir;
  SampledSpectrum r(1.0);
  for (;;) {
    auto hit = intersectScene(sc, ray, counts);
    Vertex& prev = path[bounces];
    Vertex& v = path[bounces + 1];
    if (const Medium* m = ctx.media && rng ? sc.media->get(medium) : nullptr) {
      // Delta tracking to a real scattering event, absorption, or the hit (pbrt-v4's
      // RandomWalk with SampleT_maj).
      const double len = length(ray.d);
      const Vec3 dir = ray.d / len;
      // Emission at collisions counts for paths of at most maxdepth scattering events before
      // it (as volpath's).
      SampledSpectrum* L_e = L_medium && bounces < ctx.max_depth ? L_medium : nullptr;
      const MediumEvent ev = trackMedium(*m, ray.o, dir, hit ? hit->t * len : INFINITY, lambda,
                                         sampler, *rng, beta, r, L_e);
      if (ev.kind == MediumEvent::Kind::Absorbed) break;
      if (ev.kind == MediumEvent::Kind::Scattered) {
        v = Vertex{};
        v.type = VertexType::Medium;
        v.p = ev.p;
        v.wo = -dir;
        v.medium = medium;
        v.g = m->g();
        v.beta = beta;
        v.r = r;
        v.pdf_fwd = convertDensity(prev, pdf_fwd, v);
        if (++bounces >= max_depth) break;
        const HenyeyGreenstein phase(v.g);
        auto ps = phase.sample(v.wo, sampler.get2D());
        if (!ps || ps->pdf <= 0) break;
        beta *= ps->p / ps->pdf;
        // The phase function is symmetric: the reverse density is the forward one.
        pdf_fwd = ps->pdf;
        prev.pdf_rev = convertDensity(v, ps->pdf, prev);
        any_non_specular = true;
        ray = Ray{v.p, ps->wi, INFINITY};
        continue;
      }
    }
    if (!hit) {
      // A camera ray that escapes ends on the infinite lights (pbrt-v4 adds the vertex
      // whether or not there are any; its emission is then zero).
      if (mode == TransportMode::Radiance) {
        v = Vertex{};
        v.type = VertexType::Light;
        v.p = ray.o + normalize(ray.d);
        v.beta = beta;
        v.r = r;
        v.medium = medium;
        v.pdf_fwd = pdf_fwd;
        ++bounces;
      }
      break;
    }
    if (!makeSurfaceVertex(ctx, *hit, ray.d, lambda, sc.regularize && any_non_specular, v)) {
      if (interfaces.cross()) break;
      if (ctx.media) medium = mediumAfter(sc, *hit, ray.d, medium, false);
      ray.o = offsetOrigin(hit->p, hit->ng, ray.d);
      continue;
    }
    v.beta = beta;
    v.r = r;
    v.medium = medium;
    v.pdf_fwd = convertDensity(prev, pdf_fwd, v);
    if (++bounces >= max_depth) break;
    const double uc = sampler.get1D();
    const Vec2 u = sampler.get2D();
    auto bs = v.bsdf.sample_f(v.wo, uc, u, mode);
    if (!bs) break;
    pdf_fwd = bs->pdf_is_proportional ? v.bsdf.pdf(v.wo, bs->wi, mode) : bs->pdf;
    any_non_specular = any_non_specular || !bs->isSpecular();
    beta *= bs->f * (std::abs(dot(bs->wi, v.ns)) / bs->pdf);
    beta *= correctShadingNormal(v, v.wo, bs->wi, mode);
    const TransportMode reverse =
        mode == TransportMode::Radiance ? TransportMode::Importance : TransportMode::Radiance;
    double pdf_rev = v.bsdf.pdf(bs->wi, v.wo, reverse);
    if (bs->isSpecular()) {
      v.delta = true;
      pdf_rev = pdf_fwd = 0;
    }
    prev.pdf_rev = convertDensity(v, pdf_rev, prev);
    if (beta.isBlack()) break;
    if (ctx.media) medium = mediumAfter(sc, *hit, bs->wi, medium, false);
    ray = Ray{offsetOrigin(v.p, v.ng, bs->wi), bs->wi, INFINITY, ray.time};
  }
  return bounces;
}

/// The medium a connection from the camera-side vertex v toward direction w starts in.
int mediumToward(const Context& ctx, const Vertex& v, const Vec3& w) {
  if (v.type == VertexType::Surface) return mediumAfter(*ctx.sc, v.hit, w, v.medium, false);
  return v.medium;
}

/// The transmittance of a connection from the camera-side vertex a to b (to the direction wi
/// when b is on an infinite light), traced from a, whose medium is known.
SampledSpectrum connectionT(const Context& ctx, const Vertex& a, const Vertex& b, bool infinite,
                            const Vec3& wi, double time, const SampledWavelengths& lambda, Rng& rng,
                            RayCounts& counts) {
  const Vec3 w = infinite ? wi : normalize(b.p - a.p);
  const Vec3 ng = a.onSurface() ? a.ng : Vec3{0, 0, 0};
  return segmentTransmittance(*ctx.sc, a.p, ng, mediumToward(ctx, a, w), infinite ? wi : b.p,
                              infinite, time, lambda, rng, counts);
}

bool segmentOccluded(const Context& ctx, const Vertex& a, const Vertex& b, double time,
                     RayCounts& counts) {
  // Start from the vertex on a surface (offset along its normal); the far end stops short.
  if (a.onSurface())
    return occludedScene(*ctx.sc, a.p, a.ng, b.p, false, normalize(b.p - a.p), time, counts);
  if (b.onSurface())
    return occludedScene(*ctx.sc, b.p, b.ng, a.p, false, normalize(a.p - b.p), time, counts);
  return occludedScene(*ctx.sc, a.p, Vec3{0, 0, 0}, b.p, false, normalize(b.p - a.p), time, counts);
}

/// pbrt-v4's ConnectBDPT: the contribution of strategy (s, t), weighted by MIS; raster is set
/// for t = 1.
SampledSpectrum connect(const Context& ctx, Vertex* light, Vertex* camera, int s, int t,
                        SampledWavelengths& lambda, double time, Sampler& sampler, Rng& rng,
                        RayCounts& counts, Vec2* raster) {
  SampledSpectrum L(0.0);
  // A camera subpath ending on an infinite light is only used by s = 0.
  if (t > 1 && s != 0 && camera[t - 1].type == VertexType::Light) return L;
  // Connections see media and pass interface surfaces where the scene has them; else a shadow
  // ray (started from the surface end).
  const bool tracked = ctx.media || ctx.sc->has_interfaces;
  Vertex sampled;
  SampledSpectrum r(1.0);  // the strategy's density ratios over wavelengths (bdpt.h)
  if (s == 0) {
    const Vertex& pt = camera[t - 1];
    if (isLight(pt)) L = emitted(ctx, pt, camera[t - 2], lambda) * pt.beta;
    r = pt.r;
  } else if (t == 1) {
    const Vertex& qs = light[s - 1];
    if (!isConnectible(qs)) return L;
    std::array<double, camera::kCameraWavelengths> lambda_nm{};
    for (int c = 0; c < kSpectrumSamples; ++c) lambda_nm[size_t(c)] = lambda.lambda(c);
    const Vec2 u = sampler.get2D();
    auto cs = ctx.camera->sampleWi(qs.p, u, lambda_nm, time);
    if (!cs || cs->pdf <= 0) return L;
    // Through a dispersive lens only the hero wavelength reaches this film point.
    if (cs->hero_only) lambda.terminateSecondary();
    sampled = Vertex{};
    sampled.type = VertexType::Camera;
    sampled.p = cs->p_lens;
    sampled.medium = ctx.camera_medium;
    sampled.time = time;
    for (int c = 0; c < kSpectrumSamples; ++c)
      sampled.beta[c] = cs->importance[size_t(c)] / cs->pdf;
    if (qs.type == VertexType::Light) {
      // s = 1: the area light's own point seen through the camera.
      L = emitted(ctx, qs, sampled, lambda) *
          (std::abs(dot(cs->wi, qs.ng)) / std::max(qs.pdf_fwd, 1e-300)) * sampled.beta;
    } else {
      L = qs.beta * scatterF(qs, sampled, TransportMode::Importance) * sampled.beta;
      if (qs.onSurface()) L *= std::abs(dot(cs->wi, qs.ns));
    }
    if (L.isBlack()) return SampledSpectrum(0.0);
    if (tracked)
      L *= connectionT(ctx, sampled, qs, false, {}, time, lambda, rng, counts);
    else if (segmentOccluded(ctx, qs, sampled, time, counts))
      return SampledSpectrum(0.0);
    *raster = cs->film_raster;
    r = qs.r;
  } else if (s == 1) {
    const Vertex& pt = camera[t - 1];
    if (!isConnectible(pt)) return L;
    const double ul = sampler.get1D();
    const Vec2 u = sampler.get2D();
    auto choice = ctx.light_sampler->sample({pt.p, pt.ns}, ul);
    if (!choice || choice->pmf <= 0) return L;
    auto ls = choice->light->sampleLi(pt.p, u, lambda);
    if (!ls || ls->pdf <= 0 || ls->L.isBlack()) return L;
    sampled = Vertex{};
    sampled.type = VertexType::Light;
    sampled.light = choice->light;
    sampled.p = ls->p_light;
    sampled.ng = ls->n_light;
    sampled.ns = ls->n_light;
    sampled.beta = ls->L / (choice->pmf * ls->pdf);
    sampled.pdf_fwd = pdfLightOrigin(ctx, sampled, pt);
    L = pt.beta * scatterF(pt, sampled, TransportMode::Radiance) * sampled.beta;
    if (pt.onSurface()) L *= std::abs(dot(ls->wi, pt.ns));
    if (L.isBlack()) return L;
    if (tracked)
      L *= connectionT(ctx, pt, sampled, ls->infinite, ls->wi, time, lambda, rng, counts);
    else if (occludedScene(*ctx.sc, pt.p, pt.ng, ls->p_light, ls->infinite, ls->wi, time, counts))
      return SampledSpectrum(0.0);
    r = pt.r;
  } else {
    const Vertex &qs = light[s - 1], &pt = camera[t - 1];
    if (!isConnectible(qs) || !isConnectible(pt)) return L;
    L = qs.beta * scatterF(qs, pt, TransportMode::Importance) *
        scatterF(pt, qs, TransportMode::Radiance) * pt.beta;
    if (L.isBlack()) return L;
    double d2;
    const Vec3 w = unitOrZero(pt.p - qs.p, d2);
    if (d2 == 0) return SampledSpectrum(0.0);
    double g = 1 / d2;
    if (qs.onSurface()) g *= std::abs(dot(qs.ns, w));
    if (pt.onSurface()) g *= std::abs(dot(pt.ns, w));
    L *= g;
    if (L.isBlack()) return SampledSpectrum(0.0);
    if (tracked)
      L *= connectionT(ctx, pt, qs, false, {}, time, lambda, rng, counts);
    else if (segmentOccluded(ctx, qs, pt, time, counts))
      return SampledSpectrum(0.0);
    r = qs.r * pt.r;
  }
  if (L.isBlack()) return L;
  return L * (misWeight(ctx, light, camera, sampled, s, t, lambda.lambda(0)) /
              wavelengthMean(r, lambda));
}

}  // namespace

bool isAreaLightEnd(const Vertex& v) {
  return isLight(v) && !isInfiniteLight(v) && v.onSurface();
}

bool isConnectible(const Vertex& v) {
  switch (v.type) {
    case VertexType::Light:
      return !v.light || !v.light->isDeltaDirection();
    case VertexType::Camera:
      return true;
    case VertexType::Surface:
      return isNonSpecular(v.bsdf.flags());
    case VertexType::Medium:
      return true;
  }
  return false;
}

bool isLight(const Vertex& v) {
  return v.type == VertexType::Light || (v.type == VertexType::Surface && v.light);
}

bool isDeltaLight(const Vertex& v) {
  return v.type == VertexType::Light && v.light && v.light->isDelta();
}

bool isInfiniteLight(const Vertex& v) {
  return v.type == VertexType::Light &&
         (!v.light || v.light->isInfinite() || v.light->isDeltaDirection());
}

double convertDensity(const Vertex& from, double pdf, const Vertex& next) {
  if (isInfiniteLight(next)) return pdf;  // solid angle
  double d2;
  const Vec3 w = unitOrZero(next.p - from.p, d2);
  if (d2 == 0) return 0;
  if (next.onSurface()) pdf *= std::abs(dot(next.ng, w));
  return pdf / d2;
}

double pdf(const Context& ctx, const Vertex& v, const Vertex* prev, const Vertex& next,
           double lambda_nm) {
  if (v.type == VertexType::Light) return pdfLight(ctx, v, next);
  double d2;
  const Vec3 wn = unitOrZero(next.p - v.p, d2);
  if (d2 == 0) return 0;
  double p = 0;
  if (v.type == VertexType::Camera) {
    p = ctx.camera->rayPdf(v.p, wn, lambda_nm, v.time).pdf_dir;
  } else if (v.type == VertexType::Medium) {
    if (!prev) return 0;
    double dp2;
    const Vec3 wp = unitOrZero(prev->p - v.p, dp2);
    if (dp2 == 0) return 0;
    p = HenyeyGreenstein(v.g).p(wp, wn);
  } else {
    if (!prev) return 0;
    double dp2;
    const Vec3 wp = unitOrZero(prev->p - v.p, dp2);
    if (dp2 == 0) return 0;
    p = v.bsdf.pdf(wp, wn);
  }
  return convertDensity(v, p, next);
}

double pdfLight(const Context& ctx, const Vertex& v, const Vertex& next) {
  double d2;
  const Vec3 w = unitOrZero(next.p - v.p, d2);
  if (d2 == 0) return 0;
  double p;
  if (isInfiniteLight(v)) {
    // A density per unit area of the disk light subpaths of infinite lights start on.
    p = 1 / (M_PI * ctx.scene_radius * ctx.scene_radius);
  } else {
    p = v.light->pdfLe(v.p, v.ng, w).second / d2;
  }
  if (next.onSurface()) p *= std::abs(dot(next.ng, w));
  return p;
}

double pdfLightOrigin(const Context& ctx, const Vertex& v, const Vertex& next) {
  double d2;
  const Vec3 w = unitOrZero(next.p - v.p, d2);
  if (d2 == 0) return 0;
  if (isInfiniteLight(v)) return infiniteLightDensity(ctx, w);
  return ctx.light_sampler->pmf({}, v.light) * v.light->pdfLe(v.p, v.ng, w).first;
}

double cameraPositionRatio(const Context& ctx, double pdf_pos, const Vec3& x0, const Vec3& x1,
                           double time) {
  if (!(pdf_pos > 0)) return 1;
  double r = ctx.camera->pdfWiPos(x1, x0, time) / pdf_pos;
  if (ctx.camera_delta_direction) {
    const Vec3 d = x1 - x0;
    const double d2 = dot(d, d);
    r = d2 > 0 ? r / d2 : 0;
  }
  return r;
}

double misWeight(const Context& ctx, Vertex* light, Vertex* camera, const Vertex& sampled, int s,
                 int t, double lambda_nm) {
  // A light seen directly: by the camera ray (s = 0, t = 2) or, for an area light, by the light
  // point connected to the camera (s = 1, t = 1, which pbrt-v4 leaves out); the two are weighted
  // against each other. Other lights have the one strategy.
  if (s + t == 2) {
    const Vertex& end = s == 0 ? camera[1] : light[0];
    if (!isAreaLightEnd(end)) return 1;
  }
  // The end vertices take the sampled one's place, and the connection vertices' reverse
  // densities and delta flags those of this strategy, for the duration of the call.
  Vertex saved_end;
  Vertex* end = t == 1 ? &camera[0] : s == 1 ? &light[0] : nullptr;
  if (end) {
    saved_end = *end;
    *end = sampled;
  }
  Vertex* qs = s > 0 ? &light[s - 1] : nullptr;
  Vertex* pt = t > 0 ? &camera[t - 1] : nullptr;
  Vertex* qs_minus = s > 1 ? &light[s - 2] : nullptr;
  Vertex* pt_minus = t > 1 ? &camera[t - 2] : nullptr;
  struct Saved {
    double* at;
    double value;
  };
  Saved saved[4];
  int n_saved = 0;
  const bool pt_delta = pt ? pt->delta : false, qs_delta = qs ? qs->delta : false;
  double new_pt_rev = 0, new_pt_minus_rev = 0, new_qs_rev = 0, new_qs_minus_rev = 0;
  if (pt)
    new_pt_rev =
        s > 0 ? pdf(ctx, *qs, qs_minus, *pt, lambda_nm) : pdfLightOrigin(ctx, *pt, *pt_minus);
  if (pt_minus)
    new_pt_minus_rev =
        s > 0 ? pdf(ctx, *pt, qs, *pt_minus, lambda_nm) : pdfLight(ctx, *pt, *pt_minus);
  // The camera position's density ratio (t = 1 over generateRay's): the t >= 2 strategies
  // found it with the camera subpath; t = 1 computes it here, from the ray to qs.
  double pos_ratio = t >= 2 ? camera[0].wi_pos_ratio : 1;
  if (t == 1 && qs) {
    double d2;
    const Vec3 w = unitOrZero(qs->p - pt->p, d2);
    if (d2 > 0) {
      const camera::CameraRayPdf rp = ctx.camera->rayPdf(pt->p, w, lambda_nm, pt->time);
      new_qs_rev = convertDensity(*pt, rp.pdf_dir, *qs);
      pos_ratio = cameraPositionRatio(ctx, rp.pdf_pos, pt->p, qs->p, pt->time);
    }
    if (!(pos_ratio > 0)) {
      // sampleWi cannot pick this camera point for qs: the strategy has no density here.
      if (end) *end = saved_end;
      return 0;
    }
  } else if (qs) {
    new_qs_rev = pdf(ctx, *pt, pt_minus, *qs, lambda_nm);
  }
  if (qs_minus) new_qs_minus_rev = pdf(ctx, *qs, pt, *qs_minus, lambda_nm);
  auto assign = [&](double& at, double value) {
    saved[n_saved++] = {&at, at};
    at = value;
  };
  if (pt) assign(pt->pdf_rev, new_pt_rev);
  if (pt_minus) assign(pt_minus->pdf_rev, new_pt_minus_rev);
  if (qs) assign(qs->pdf_rev, new_qs_rev);
  if (qs_minus) assign(qs_minus->pdf_rev, new_qs_minus_rev);
  if (pt) pt->delta = false;
  if (qs) qs->delta = false;

  auto remap0 = [](double f) { return f != 0 ? f : 1.0; };
  const double e = ctx.mis_exponent;
  auto power = [e](double r) { return e == 1 ? r : std::pow(r, e); };
  double sum_ri = 0;
  double ri = 1;
  // A ghost camera subpath (lens flare): its t = 1 strategy would be a connection through the
  // same ghost path, which sampleWi does not make; it gets weight 0 and the other strategies'
  // weights sum to 1 without it (term i = 1 left out).
  const bool ghost = t >= 2 && camera[0].ghost;
  for (int i = t - 1; i > 0; --i) {
    ri *= remap0(camera[i].pdf_rev) / remap0(camera[i].pdf_fwd);
    if (i == 1) ri *= pos_ratio;  // the t = 1 strategy picks the camera point by sampleWi
    if (!camera[i].delta && !camera[i - 1].delta && !(ghost && i == 1)) sum_ri += power(ri);
  }
  ri = 1;
  for (int i = s - 1; i >= 0; --i) {
    ri *= remap0(light[i].pdf_rev) / remap0(light[i].pdf_fwd);
    if (t == 1 && i == s - 1) ri /= pos_ratio;  // strategies from here on use generateRay's
    const bool delta_light_vertex = i > 0 ? light[i - 1].delta : isDeltaLight(light[0]);
    if (!light[i].delta && !delta_light_vertex) sum_ri += power(ri);
  }

  for (int k = n_saved - 1; k >= 0; --k) *saved[k].at = saved[k].value;
  if (pt) pt->delta = pt_delta;
  if (qs) qs->delta = qs_delta;
  if (end) *end = saved_end;
  return 1 / (1 + sum_ri);
}

int cameraSubpath(const Context& ctx, const camera::CameraRay& ray, SampledWavelengths& lambda,
                  Sampler& sampler, RayCounts& counts, Vertex* path, Rng* rng,
                  SampledSpectrum* L_medium) {
  const int max_vertices = ctx.max_depth + 2;
  Vertex& v = path[0];
  v = Vertex{};
  v.type = VertexType::Camera;
  v.p = ray.origin;
  v.beta = SampledSpectrum(ray.weight);
  // Lens flare: the camera weighs each wavelength by the coatings along its path.
  if (ray.per_wavelength && !lambda.secondaryTerminated())
    for (int c = 0; c < kSpectrumSamples; ++c) v.beta[c] = ray.wavelength_weight[size_t(c)];
  v.medium = ctx.camera_medium;
  v.time = ray.time;
  v.ghost = ray.ghost;
  // A ghost path's own densities are not needed: only generateRay-side strategies (t >= 2)
  // weigh it, and they read the camera vertex's densities only in the t = 1 term (misWeight).
  const camera::CameraRayPdf rp =
      ray.ghost ? camera::CameraRayPdf{}
                : ctx.camera->rayPdf(ray.origin, ray.direction, lambda.lambda(0), ray.time);
  const int n = randomWalk(ctx, Ray{ray.origin, ray.direction, INFINITY, ray.time}, v.medium,
                           lambda, sampler, rng, v.beta, rp.pdf_dir, max_vertices - 1,
                           TransportMode::Radiance, counts, path, L_medium) +
                1;
  // The t = 1 strategy can pick this camera point from a surface or a medium vertex.
  if (!ray.ghost && n >= 2 && (path[1].onSurface() || path[1].type == VertexType::Medium))
    path[0].wi_pos_ratio = cameraPositionRatio(ctx, rp.pdf_pos, path[0].p, path[1].p, ray.time);
  return n;
}

int lightSubpath(const Context& ctx, double time, SampledWavelengths& lambda, Sampler& sampler,
                 RayCounts& counts, Vertex* path, Rng* rng) {
  const int max_vertices = ctx.max_depth + 1;
  const double ul = sampler.get1D();
  const Vec2 u1 = sampler.get2D(), u2 = sampler.get2D();
  auto choice = ctx.light_sampler->sample({}, ul);
  if (!choice || choice->pmf <= 0) return 0;
  const Light* light = choice->light;
  auto le = light->sampleLe(u1, u2, lambda);
  if (!le || le->pdf_pos <= 0 || le->pdf_dir <= 0 || le->L.isBlack()) return 0;
  Vertex& v = path[0];
  v = Vertex{};
  v.type = VertexType::Light;
  v.light = light;
  v.p = le->o;
  if (le->on_surface) {
    v.ng = v.ns = le->n;
    v.hit.ng = le->n;
    v.hit.uv = le->uv;
  }
  v.beta = le->L;
  v.medium = ctx.media ? lightMedium(*ctx.sc, *light) : -1;
  v.pdf_fwd = le->pdf_pos * choice->pmf;
  const bool on_surface = v.onSurface();
  const double cos_o = on_surface ? std::abs(dot(le->n, le->d)) : 1;
  SampledSpectrum beta = le->L * (cos_o / (choice->pmf * le->pdf_pos * le->pdf_dir));
  if (isInfiniteLight(v) && v.medium >= 0) {
    beta *= transmittanceFromInfinity(*ctx.sc, v.medium, lambda);
    if (beta.isBlack()) return 1;
  }
  // The light's own surface must not stop its ray.
  const Vec3 o = on_surface ? offsetOrigin(le->o, le->n, le->d) : le->o;
  const int n =
      randomWalk(ctx, Ray{o, le->d, INFINITY, time}, v.medium, lambda, sampler, rng, beta,
                 le->pdf_dir, max_vertices - 1, TransportMode::Importance, counts, path, nullptr);
  // Infinite lights: the first surface vertex's density is the disk's positional density
  // projected onto it, and the light vertex's the direction's (pbrt-v4).
  if (isInfiniteLight(v)) {
    if (n > 0) {
      path[1].pdf_fwd = le->pdf_pos;
      if (path[1].onSurface()) path[1].pdf_fwd *= std::abs(dot(le->d, path[1].ng));
    }
    v.pdf_fwd = infiniteLightDensity(ctx, le->d);
  }
  return n + 1;
}

}  // namespace bdpt

BdptIntegrator::BdptIntegrator(const SceneContext& sc, const camera::Camera& camera,
                               double mis_exponent) {
  if (const std::string why = unsupported(sc, camera); !why.empty()) throw Error(why);
  std::vector<const Light*> all;
  for (size_t i = 0; i < sc.lights->size(); ++i) all.push_back(&sc.lights->light(i));
  // pbrt-v4's bdpt chooses lights by power (its "lightsampler" default): a choice that does not
  // depend on the point, as the light subpath and the MIS densities need.
  const std::string& name = sc.scene->integrator.light_sampler;
  light_sampler_ = LightSampler::create(name == "uniform" ? "uniform" : "power", all);
  ctx_.sc = &sc;
  ctx_.camera = &camera;
  ctx_.light_sampler = light_sampler_.get();
  ctx_.infinite = sc.lights->infinite();
  for (size_t i = 0; i < sc.lights->size(); ++i)
    if (sc.lights->light(i).isDeltaDirection()) ctx_.infinite.push_back(&sc.lights->light(i));
  // The scene's bounding sphere as LightSet gives it to infinite and distant lights.
  const Bounds3 b = sc.accel->bounds();
  ctx_.scene_radius = b.empty() ? 1 : std::max(1e-3, 0.5 * length(b.max - b.min));
  ctx_.mis_exponent = mis_exponent;
  ctx_.max_depth = std::clamp(sc.max_depth, 0, 1000);
  const scene::Camera& c = sc.scene->camera;
  ctx_.camera_delta_direction = c.type == "orthographic" && c.lens_radius == 0;
  ctx_.media = sc.scene_media && sc.media && !sc.media->empty();
  ctx_.camera_medium = ctx_.media ? sc.camera_medium : -1;
}

BdptIntegrator::~BdptIntegrator() = default;

std::string BdptIntegrator::unsupported(const SceneContext& sc, const camera::Camera& camera) {
  if (!camera.supportsImportance())
    return fmt::format("the camera ({}) has no importance for light subpaths", camera.describe());
  for (size_t i = 0; i < sc.lights->size(); ++i)
    if (!sc.lights->light(i).supportsLe())
      return fmt::format("{} lights do not sample emitted rays yet",
                         sc.lights->light(i).typeName());
  return "";
}

SampledSpectrum BdptIntegrator::Li(const camera::CameraRay* ray, double time,
                                   SampledWavelengths& lambda, Sampler& sampler, RayCounts& counts,
                                   std::vector<BdptSplat>& splats) const {
  using namespace bdpt;
  // Per-thread vertex storage, reused across samples.
  thread_local std::vector<Vertex> camera_buf, light_buf;
  const size_t need = size_t(ctx_.max_depth) + 3;
  if (camera_buf.size() < need) camera_buf.resize(need);
  if (light_buf.size() < need) light_buf.resize(need);
  Vertex* camera_path = camera_buf.data();
  Vertex* light_path = light_buf.data();
  int n_camera = 0;
  // The stream for tracking steps in media (their count varies).
  Rng rng;
  if (ctx_.media) rng = pathRng(sampler);
  SampledSpectrum L(0.0);
  if (ray) {
    n_camera = cameraSubpath(ctx_, *ray, lambda, sampler, counts, camera_path, &rng, &L);
  } else {
    // No camera ray: only the t = 1 strategies, whose camera vertex is sampled anew.
    camera_path[0].type = VertexType::Camera;
    camera_path[0].time = time;
    n_camera = 1;
  }
  // The light subpath at the camera sample's time (pbrt-v4's BDPTIntegrator::Li).
  const int n_light = lightSubpath(ctx_, time, lambda, sampler, counts, light_path, &rng);
  for (int t = 1; t <= n_camera; ++t)
    for (int s = 0; s <= n_light; ++s) {
      const int depth = t + s - 2;
      if (depth < 0 || depth > ctx_.max_depth) continue;
      if (s == 1 && t == 1 && !isAreaLightEnd(light_path[0])) continue;
      if (!ray && s == 0) continue;
      if (t == 1 && ray && ray->ghost) continue;  // weight 0 for ghost paths (misWeight)
      Vec2 raster;
      const SampledSpectrum Lpath =
          connect(ctx_, light_path, camera_path, s, t, lambda, time, sampler, rng, counts, &raster);
      if (Lpath.isBlack()) continue;
      if (ray && ray->ghost && s >= 1) ++counts.ghost_connections;
      if (t == 1)
        splats.push_back({raster, Lpath});
      else
        L += Lpath;
    }
  return L;
}

namespace {

class BdptFamilyIntegrator final : public Integrator {
 public:
  BdptFamilyIntegrator(const SceneContext& sc, const camera::Camera& camera) : bdpt_(sc, camera) {}
  bool splats() const override { return true; }
  bool estimatesWithoutCameraRay() const override { return true; }
  bool heroWavelengthOnly() const override { return true; }
  SampledSpectrum Li(const camera::CameraRay* ray, double time, SampledWavelengths& lambda,
                     Sampler& sampler, RayCounts& counts, Film& film,
                     uint64_t& dropped) const override {
    // The t = 1 splats of a sample, kept per thread to save an allocation per sample.
    thread_local std::vector<BdptSplat> splats;
    splats.clear();
    const SampledSpectrum L = bdpt_.Li(ray, time, lambda, sampler, counts, splats);
    for (const BdptSplat& sp : splats) {
      bool ok = true;
      for (int c = 0; c < kSpectrumSamples; ++c) ok = ok && std::isfinite(sp.L[c]);
      if (ok)
        film.addSplat(sp.raster, sp.L, lambda);
      else
        ++dropped;
    }
    return L;
  }

 private:
  BdptIntegrator bdpt_;
};

}  // namespace

std::unique_ptr<Integrator> makeBdptFamilyIntegrator(const SceneContext& sc,
                                                     const camera::Camera& camera) {
  return std::make_unique<BdptFamilyIntegrator>(sc, camera);
}

}  // namespace lensim::render
