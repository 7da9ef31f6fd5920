// The volpath integrator. See volpath.h. Notation as pbrt-v4 (4th ed., sec. 14.2): beta is the
// path throughput divided by the hero wavelength's path pdf; r_u[i] (r_l[i]) is the pdf of the
// path sampled unidirectionally (ending with a light sample) at wavelength i divided by the hero's
// unidirectional pdf. A contribution beta * f / average(r_u + r_l) is then the one-sample MIS
// estimate over wavelengths and strategies (balance heuristic).
#include "lensim/render/integrators/volpath.h"

#include <cmath>

#include "lensim/render/integrators/base.h"
#include "lensim/render/integrators/media_tracking.h"
#include "lensim/render/materials/layered.h"
#include "lensim/render/media/media.h"
#include "lensim/render/media/subsurface.h"
#include "lensim/scene/description.h"

namespace lensim::render {

using namespace lensim::sampling;

namespace {

/// The medium of index `medium` for tracking: `walk` where the index is that of the walk whose
/// coefficients it holds (a textured subsurface material, evaluated where the walk entered).
const Medium* trackedMedium(const SceneContext& sc, int medium, int walk_index,
                            const WalkMedium& walk) {
  if (medium >= 0 && medium == walk_index) return &walk;
  return sc.media ? sc.media->get(medium) : nullptr;
}

/// When a path leaves the surface hit `h` (texture context tctx) into medium `next` from
/// `current`, and `next` is the inside of a subsurface material with textured coefficients:
/// sets `walk` to them, evaluated at this entry point, and walk_index to next.
void enterMedium(const SceneContext& sc, int next, int current, const TextureEvalContext& tctx,
                 const SampledWavelengths& lambda, WalkMedium& walk, int& walk_index) {
  if (next == current || !sc.media) return;
  if (const SubsurfaceMedium* ss = sc.media->texturedSubsurface(next)) {
    walk.set(ss->coefficientsAt(*sc.textures, tctx, lambda), ss->g());
    walk_index = next;
  }
}

/// The most scattering events and boundary hits of one random walk inside a subsurface shape
/// (they do not count toward maxdepth, as the pbrt-v4 BSSRDF's inner bounces do not).
constexpr int kMaxWalkSteps = 100000;

/// A scattering vertex for next-event estimation: a surface (bsdf set) or a medium point.
struct Vertex {
  Vec3 p;
  Vec3 ng;  ///< surface: geometric normal (ray offsets); medium: zero
  Vec3 ns;  ///< surface: shading normal
  Vec3 wo;
  int medium = -1;  ///< medium point: its medium; surface: unused (by direction)
  const SurfaceHit* hit = nullptr;
  const BSDF* bsdf = nullptr;
  const HenyeyGreenstein* phase = nullptr;
  double time = 0;  ///< the path's shutter time
};

/// pbrt-v4's SampleLd: a light sample, its transmittance by ratio tracking through media and
/// interface surfaces, MIS-weighted against BSDF/phase sampling. r_p: the path's r_u.
SampledSpectrum sampleLd(const SceneContext& sc, const Vertex& v, const SampledWavelengths& lambda,
                         Sampler& sampler, Rng& rng, const SampledSpectrum& beta,
                         const SampledSpectrum& r_p, RayCounts& counts) {
  const double u_light = sampler.get1D();
  const Vec2 u_light2 = sampler.get2D();
  auto choice = sc.lights->sample({v.p, v.ns}, u_light);
  if (!choice) return {};
  auto ls = choice->light->sampleLi(v.p, u_light2, lambda);
  if (!ls || ls->pdf <= 0 || ls->L.isBlack()) return {};
  const double p_l = choice->pmf * ls->pdf;
  SampledSpectrum f_hat;
  double scatter_pdf;
  if (v.bsdf) {
    f_hat = v.bsdf->f(v.wo, ls->wi) * std::abs(dot(ls->wi, v.ns));
    scatter_pdf = v.bsdf->pdf(v.wo, ls->wi);
  } else {
    const double ph = v.phase->p(v.wo, ls->wi);
    f_hat = SampledSpectrum(ph);
    scatter_pdf = ph;
  }
  if (f_hat.isBlack()) return {};

  SampledSpectrum T_ray(1.0), r_l(1.0), r_u(1.0);
  if ((!sc.media || sc.media->empty()) && !sc.has_interfaces) {
    // No media and no interface surfaces: a plain shadow ray, as the path integrator traces it.
    if (occludedScene(sc, v.p, v.ng, ls->p_light, ls->infinite, ls->wi, v.time, counts)) return {};
  } else {
    int medium = v.bsdf ? mediumAfter(sc, *v.hit, ls->wi, v.medium) : v.medium;
    // A shadow ray into a textured subsurface shape: its coefficients where it enters.
    WalkMedium walk;
    int walk_index = -1;
    if (v.bsdf)
      enterMedium(sc, medium, v.medium, {v.hit->p, v.hit->uv, v.hit->ns}, lambda, walk, walk_index);
    Vec3 origin = v.bsdf ? offsetOrigin(v.p, v.ng, ls->wi) : v.p;
    for (int guard = 0; guard < 256; ++guard) {
      const Ray r = shadowRay(origin, ls->infinite ? ls->wi : ls->p_light, ls->infinite, v.time);
      auto hit = intersectScene(sc, r, counts);
      if (hit && !isInterfaceHit(sc, *hit, -r.d)) return {};
      if (const Medium* m = trackedMedium(sc, medium, walk_index, walk)) {
        const double len = length(r.d);
        const double t_end = (hit ? hit->t : r.tmax) * len;
        const Vec3 d = r.d / len;
        const SampledSpectrum T_maj =
            sampleTmaj(*m, r.o, d, t_end, rng.uniform(), rng, lambda,
                       [&](const Vec3&, const MediumProperties& mp, const SampledSpectrum& smaj,
                           const SampledSpectrum& Tm) {
                         const SampledSpectrum sigma_n = clampZero(smaj - mp.sigma_a - mp.sigma_s);
                         const double pdf = Tm[0] * smaj[0];
                         T_ray *= Tm * sigma_n / pdf;
                         r_l *= Tm * smaj / pdf;
                         r_u *= Tm * sigma_n / pdf;
                         // Russian roulette on low transmittance.
                         const SampledSpectrum Tr = T_ray / wavelengthMean(r_l + r_u, lambda);
                         if (Tr.maxValue() < 0.05) {
                           const double q = 0.75;
                           if (rng.uniform() < q)
                             T_ray = SampledSpectrum(0.0);
                           else
                             T_ray /= 1 - q;
                         }
                         return !T_ray.isBlack();
                       });
        T_ray *= T_maj / T_maj[0];
        r_l *= T_maj / T_maj[0];
        r_u *= T_maj / T_maj[0];
      }
      if (T_ray.isBlack()) return {};
      if (!hit) break;
      medium = mediumAfter(sc, *hit, r.d, medium);
      origin = offsetOrigin(hit->p, hit->ng, r.d);
      if (!ls->infinite && dot(ls->p_light - origin, r.d) <= 0) break;
    }
  }
  r_l *= r_p * p_l;
  r_u *= r_p * scatter_pdf;
  if (choice->light->isDelta()) return beta * f_hat * T_ray * ls->L / wavelengthMean(r_l, lambda);
  return beta * f_hat * T_ray * ls->L / wavelengthMean(r_l + r_u, lambda);
}

/// The state of a volpath path between its vertices (beta, r_u, r_l: see the file comment).
struct PathState {
  SampledSpectrum L = SampledSpectrum(0.0), beta = SampledSpectrum(1.0);
  SampledSpectrum r_u = SampledSpectrum(1.0), r_l = SampledSpectrum(1.0);
  bool specular_bounce = false, any_non_specular = false;
  Vec3 prev_p;
  Vec3 prev_n{0, 0, 0};  ///< the previous vertex's shading normal (zero in a medium)
  int depth = 0, walk_steps = 0;
  Ray ray;
};

/// How the path's ray through a medium ended.
enum class MediumResult {
  ReachedSurface,  ///< it passed the medium up to the surface hit (or to infinity)
  Scattered,       ///< it scattered: the state's ray is the new one
  Ended,           ///< absorbed, out of depth or of throughput: the path ends
};

/// Delta tracking of the path's ray through medium m (of index `medium`) up to t_end, the hit's
/// distance: emission at collisions, absorption, real scattering (with a light sample, except
/// in a random walk) and null collisions chosen by the hero wavelength's probabilities.
MediumResult traverseMedium(const SceneContext& sc, const Medium& m, int medium, double t_end,
                            bool in_walk, double time, PathState& s, Rng& rng,
                            SampledWavelengths& lambda, Sampler& sampler, RayCounts& counts) {
  SampledSpectrum &L = s.L, &beta = s.beta, &r_u = s.r_u, &r_l = s.r_l;
  bool &specular_bounce = s.specular_bounce, &any_non_specular = s.any_non_specular;
  int &depth = s.depth, &walk_steps = s.walk_steps;
  Vec3 &prev_p = s.prev_p, &prev_n = s.prev_n;
  Ray& ray = s.ray;
  bool scattered = false, terminated = false;
  const Vec3 dir = ray.d / length(ray.d);
  const double u = sampler.get1D();
  double u_mode = sampler.get1D();  // the first collision's; then the stream's
  const SampledSpectrum T_maj =
      sampleTmaj(m, ray.o, dir, t_end, u, rng, lambda,
                 [&](const Vec3& p, const MediumProperties& mp, const SampledSpectrum& smaj,
                     const SampledSpectrum& Tm) {
                   if (beta.isBlack()) {
                     terminated = true;
                     return false;
                   }
                   // Emission at the collision.
                   if (depth < sc.max_depth && !mp.Le.isBlack()) {
                     const double pdf = smaj[0] * Tm[0];
                     const SampledSpectrum betap = beta * Tm / pdf;
                     const SampledSpectrum r_e = r_u * smaj * Tm / pdf;
                     if (!r_e.isBlack())
                       L += betap * mp.sigma_a * mp.Le / wavelengthMean(r_e, lambda);
                   }
                   // Absorption, real scattering or a null collision, by the hero's
                   // probabilities.
                   const double p_absorb = mp.sigma_a[0] / smaj[0];
                   const double p_scatter = mp.sigma_s[0] / smaj[0];
                   const double um = u_mode;
                   u_mode = rng.uniform();
                   if (um < p_absorb) {
                     terminated = true;
                     return false;
                   }
                   if (um < p_absorb + p_scatter) {
                     if (in_walk ? ++walk_steps > kMaxWalkSteps : depth++ >= sc.max_depth) {
                       terminated = true;
                       return false;
                     }
                     const double pdf = Tm[0] * mp.sigma_s[0];
                     beta *= Tm * mp.sigma_s / pdf;
                     r_u *= Tm * mp.sigma_s / pdf;
                     if (!beta.isBlack() && !r_u.isBlack()) {
                       const HenyeyGreenstein phase(m.g());
                       Vertex v;
                       v.p = p;
                       v.time = time;
                       v.wo = -dir;
                       v.medium = medium;
                       v.phase = &phase;
                       if (!in_walk)
                         L += sampleLd(sc, v, lambda, sampler, rng, beta, r_u, counts);
                       auto ps = phase.sample(-dir, sampler.get2D());
                       if (!ps || ps->pdf <= 0) {
                         terminated = true;
                       } else {
                         beta *= ps->p / ps->pdf;
                         r_l = r_u / ps->pdf;
                         prev_p = p;
                         prev_n = Vec3{0, 0, 0};
                         scattered = true;
                         ray = Ray{p, ps->wi, INFINITY, time};
                         // Without a light sample, emission found next counts in full.
                         specular_bounce = in_walk;
                         any_non_specular = true;
                       }
                     }
                     return false;
                   }
                   // Null collision (none for homogeneous media, whose majorant is sigma_t).
                   const SampledSpectrum sigma_n = clampZero(smaj - mp.sigma_a - mp.sigma_s);
                   const double pdf = Tm[0] * sigma_n[0];
                   beta *= Tm * sigma_n / pdf;
                   if (pdf == 0) beta = SampledSpectrum(0.0);
                   r_u *= Tm * sigma_n / pdf;
                   r_l *= Tm * smaj / pdf;
                   return !beta.isBlack() && !r_u.isBlack();
                 });
  if (terminated || beta.isBlack() || r_u.isBlack()) return MediumResult::Ended;
  if (scattered) return MediumResult::Scattered;
  beta *= T_maj / T_maj[0];
  r_u *= T_maj / T_maj[0];
  r_l *= T_maj / T_maj[0];
  return MediumResult::ReachedSurface;
}

}  // namespace

SampledSpectrum volpathLi(const SceneContext& sc, const Vec3& o, const Vec3& d, double time,
                          int medium, SampledWavelengths& lambda, Sampler& sampler,
                          RayCounts& counts) {
  PathState s;
  SampledSpectrum &L = s.L, &beta = s.beta, &r_u = s.r_u, &r_l = s.r_l;
  bool &specular_bounce = s.specular_bounce, &any_non_specular = s.any_non_specular;
  double eta_scale = 1;
  Vec3 &prev_p = s.prev_p, &prev_n = s.prev_n;
  int &depth = s.depth, &walk_steps = s.walk_steps;
  InterfaceGuard interfaces;
  // The walk in a textured subsurface material: its medium index and coefficients.
  WalkMedium walk;
  int walk_index = -1;
  const bool has_media = sc.media && (!sc.media->empty() || sc.media->hasSubsurface());
  // Random numbers for the tracking steps (their count varies): a stream per path.
  Rng rng;
  if (has_media) rng = pathRng(sampler);
  if (!has_media || !sc.scene_media) medium = -1;
  Ray& ray = s.ray;
  ray = Ray{o, d, INFINITY, time};
  for (;;) {
    auto hit = intersectScene(sc, ray, counts);
    // Inside a subsurface shape (a random walk): its boundary is no light's window (it is not
    // an interface), so no light is sampled from inside and scattering is not counted as depth.
    const bool in_walk = has_media && sc.media->isSubsurface(medium);
    if (const Medium* m = has_media ? trackedMedium(sc, medium, walk_index, walk) : nullptr) {
      const double t_end = hit ? hit->t * length(ray.d) : INFINITY;
      const MediumResult r = traverseMedium(sc, *m, medium, t_end, in_walk, time, s, rng, lambda,
                                            sampler, counts);
      if (r == MediumResult::Ended) return L;
      if (r == MediumResult::Scattered) continue;
    }

    // Emission found by BSDF or phase sampling: the balance heuristic over the averaged r_u and
    // r_l.
    foundEmission(sc, ray, hit ? &*hit : nullptr, lambda, prev_p, prev_n,
                  depth == 0 || specular_bounce,
                  [&](const SampledSpectrum& Le, std::optional<double> p_l) {
                    if (!p_l) {
                      L += beta * Le / wavelengthMean(r_u, lambda);
                    } else {
                      const SampledSpectrum rl = r_l * *p_l;
                      L += beta * Le / wavelengthMean(r_u + rl, lambda);
                    }
                  });
    if (!hit) break;
    const SurfaceHit& h = *hit;
    const Vec3 wo = -ray.d;
    const TextureEvalContext tctx{h.p, h.uv, h.ns};
    const int material =
        sc.materials->resolve(sc.scene->shapes[size_t(h.shape)].material, tctx, wo);
    if (sc.materials->isInterface(material)) {
      // A medium boundary without a surface: the ray goes on, into the other medium.
      if (interfaces.cross()) break;
      medium = mediumAfter(sc, h, ray.d, medium);
      ray.o = offsetOrigin(h.p, h.ng, ray.d);
      continue;
    }
    if (in_walk ? ++walk_steps > kMaxWalkSteps : depth++ >= sc.max_depth) break;
    auto bxdf = sc.materials->bxdf(material, tctx, lambda, sc.regularize && any_non_specular);
    const Vec3 ns = materialShadingNormal(sc, material, tctx, h);
    const BSDF bsdf(ns, h.dpdu, bxdf);
    if (isNonSpecular(bsdf.flags())) {
      Vertex v;
      v.p = h.p;
      v.time = time;
      v.ng = h.ng;
      v.ns = ns;
      v.wo = wo;
      v.medium = medium;
      v.hit = &h;
      v.bsdf = &bsdf;
      L += sampleLd(sc, v, lambda, sampler, rng, beta, r_u, counts);
    } else {
      sampler.get1D();  // keep the dimensions of the light sample in step with non-specular
      sampler.get2D();
    }
    prev_p = h.p;
    prev_n = ns;
    const double uc = sampler.get1D();
    const Vec2 u = sampler.get2D();
    auto bs = bsdf.sample_f(wo, uc, u);
    if (!bs) break;
    beta *= bs->f * (std::abs(dot(bs->wi, ns)) / bs->pdf);
    r_l = r_u / (bs->pdf_is_proportional ? bsdf.pdf(wo, bs->wi) : bs->pdf);
    specular_bounce = bs->isSpecular();
    any_non_specular = any_non_specular || !specular_bounce;
    if (bs->isTransmission()) eta_scale *= bs->eta * bs->eta;
    const int next_medium = mediumAfter(sc, h, bs->wi, medium);
    if (has_media) enterMedium(sc, next_medium, medium, tctx, lambda, walk, walk_index);
    medium = next_medium;
    ray = Ray{offsetOrigin(h.p, h.ng, bs->wi), bs->wi, INFINITY, time};
    if (beta.isBlack()) break;
    const SampledSpectrum rr_beta = beta * eta_scale / wavelengthMean(r_u, lambda);
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

class VolPathIntegrator final : public RayIntegrator {
 public:
  explicit VolPathIntegrator(const SceneContext& sc) : sc_(&sc) {}
  SampledSpectrum rayLi(const Vec3& o, const Vec3& d, double time, SampledWavelengths& lambda,
                        Sampler& sampler, RayCounts& counts) const override {
    return volpathLi(*sc_, o, d, time, sc_->scene_media ? sc_->camera_medium : -1, lambda,
                     sampler, counts);
  }

 private:
  const SceneContext* sc_;
};

}  // namespace

std::unique_ptr<Integrator> makeVolPathIntegrator(const SceneContext& sc) {
  return std::make_unique<VolPathIntegrator>(sc);
}

}  // namespace lensim::render
