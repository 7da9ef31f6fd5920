// Tracking through media; see media_tracking.h.
#include "lensim/render/integrators/media_tracking.h"

#include <cstring>

#include "lensim/scene/description.h"

namespace lensim::render {

using namespace lensim::sampling;

int mediumAfter(const SceneContext& sc, const SurfaceHit& h, const Vec3& w, int current,
                bool subsurface) {
  const scene::Shape& s = sc.scene->shapes[size_t(h.shape)];
  int inside = sc.scene_media ? s.inside_medium : -1;
  const int outside = sc.scene_media ? s.outside_medium : -1;
  if (sc.media && subsurface) {
    const int ss = sc.media->subsurface(s.material);
    if (ss >= 0) inside = ss;
  }
  if (inside == outside) return current;
  return dot(w, h.ng) > 0 ? outside : inside;
}

bool isInterfaceHit(const SceneContext& sc, const SurfaceHit& h, const Vec3& wo) {
  const TextureEvalContext tctx{h.p, h.uv, h.ns};
  const int material = sc.materials->resolve(sc.scene->shapes[size_t(h.shape)].material, tctx, wo);
  return sc.materials->isInterface(material);
}

int lightMedium(const SceneContext& sc, const Light& light) {
  if (!sc.scene_media || !sc.media || sc.media->empty()) return -1;
  if (light.shape >= 0) return sc.scene->shapes[size_t(light.shape)].outside_medium;
  return light.medium;
}

SampledSpectrum transmittanceFromInfinity(const SceneContext& sc, int medium,
                                          const SampledWavelengths& lambda) {
  const Medium* m = sc.media && sc.scene_media ? sc.media->get(medium) : nullptr;
  if (!m || !dynamic_cast<const HomogeneousMedium*>(m)) return SampledSpectrum(1.0);
  const MediumProperties mp = m->at(Vec3{0, 0, 0}, lambda);
  return transmittance(INFINITY, mp.sigma_a + mp.sigma_s);
}

Rng pathRng(Sampler& sampler) {
  const double a = sampler.get1D(), b = sampler.get1D();
  uint64_t ua, ub;
  std::memcpy(&ua, &a, sizeof ua);
  std::memcpy(&ub, &b, sizeof ub);
  Rng rng;
  rng.setSequence(hashValues({ua, ub}), mixBits(ub ^ 0x9e3779b97f4a7c15ULL));
  return rng;
}

MediumEvent trackMedium(const Medium& m, const Vec3& o, const Vec3& d, double t_end,
                        const SampledWavelengths& lambda, Sampler& sampler, Rng& rng,
                        SampledSpectrum& beta, SampledSpectrum& r, SampledSpectrum* L_emitted) {
  MediumEvent ev;
  const double u = sampler.get1D();
  double u_mode = sampler.get1D();  // the first collision's; then the stream's
  const SampledSpectrum T_maj = sampleTmaj(
      m, o, d, t_end, u, rng, lambda,
      [&](const Vec3& p, const MediumProperties& mp, const SampledSpectrum& smaj,
          const SampledSpectrum& Tm) {
        if (L_emitted && !mp.Le.isBlack()) {
          // Emission at the collision (pbrt-v4's VolPathIntegrator::Li; its pdf ratio r_e).
          const double pdf = smaj[0] * Tm[0];
          const SampledSpectrum r_e = r * smaj * Tm / pdf;
          if (!r_e.isBlack())
            *L_emitted += beta * Tm / pdf * mp.sigma_a * mp.Le / wavelengthMean(r_e, lambda);
        }
        const double p_absorb = mp.sigma_a[0] / smaj[0];
        const double p_scatter = mp.sigma_s[0] / smaj[0];
        const double um = u_mode;
        u_mode = rng.uniform();
        if (um < p_absorb) {
          ev.kind = MediumEvent::Kind::Absorbed;
          return false;
        }
        if (um < p_absorb + p_scatter) {
          const double pdf = Tm[0] * mp.sigma_s[0];
          beta *= Tm * mp.sigma_s / pdf;
          r *= Tm * mp.sigma_s / pdf;
          ev.kind = beta.isBlack() || r.isBlack() ? MediumEvent::Kind::Absorbed
                                                  : MediumEvent::Kind::Scattered;
          ev.p = p;
          return false;
        }
        // A null collision (none in homogeneous media, whose majorant is sigma_t).
        const SampledSpectrum sigma_n = clampZero(smaj - mp.sigma_a - mp.sigma_s);
        const double pdf = Tm[0] * sigma_n[0];
        if (pdf == 0) {
          beta = SampledSpectrum(0.0);
        } else {
          beta *= Tm * sigma_n / pdf;
          r *= Tm * sigma_n / pdf;
        }
        if (beta.isBlack() || r.isBlack()) {
          ev.kind = MediumEvent::Kind::Absorbed;
          return false;
        }
        return true;
      });
  if (ev.kind != MediumEvent::Kind::Passed) return ev;
  if (!(T_maj[0] > 0)) {
    ev.kind = MediumEvent::Kind::Absorbed;
    return ev;
  }
  beta *= T_maj / T_maj[0];
  r *= T_maj / T_maj[0];
  if (beta.isBlack()) ev.kind = MediumEvent::Kind::Absorbed;
  return ev;
}

SampledSpectrum segmentTransmittance(const SceneContext& sc, const Vec3& from, const Vec3& from_ng,
                                     int medium, const Vec3& to, bool to_infinite, double time,
                                     const SampledWavelengths& lambda, Rng& rng,
                                     RayCounts& counts) {
  const Vec3 w0 = to_infinite ? to : normalize(to - from);
  const bool media = sc.scene_media && sc.media && !sc.media->empty();
  if (!media && !sc.has_interfaces)
    return SampledSpectrum(
        occludedScene(sc, from, from_ng, to, to_infinite, w0, time, counts) ? 0.0 : 1.0);
  const bool on_surface = from_ng.x != 0 || from_ng.y != 0 || from_ng.z != 0;
  Vec3 origin = on_surface ? offsetOrigin(from, from_ng, w0) : from;
  SampledSpectrum T(1.0);
  // As volpath's shadow rays (pbrt-v4's SampleLd and its Transmittance loop).
  for (int guard = 0; guard < 256; ++guard) {
    const Ray ray = shadowRay(origin, to, to_infinite, time);
    auto hit = intersectScene(sc, ray, counts);
    if (hit && !isInterfaceHit(sc, *hit, -ray.d)) return SampledSpectrum(0.0);
    if (const Medium* m = media ? sc.media->get(medium) : nullptr) {
      const double len = length(ray.d);
      const double t_end = (hit ? hit->t : ray.tmax) * len;
      const Vec3 d = ray.d / len;
      if (dynamic_cast<const HomogeneousMedium*>(m)) {
        // Constant coefficients: the transmittance itself (ratio tracking by the majorant
        // sigma_t would only ever give 0 or T / T_hero).
        const MediumProperties mp = m->at(ray.o, lambda);
        T *= transmittance(t_end, mp.sigma_a + mp.sigma_s);
      } else {
        // Ratio tracking by the hero's majorant: unbiased at every wavelength.
        const SampledSpectrum T_maj =
            sampleTmaj(*m, ray.o, d, t_end, rng.uniform(), rng, lambda,
                       [&](const Vec3&, const MediumProperties& mp, const SampledSpectrum& smaj,
                           const SampledSpectrum& Tm) {
                         const SampledSpectrum sigma_n = clampZero(smaj - mp.sigma_a - mp.sigma_s);
                         T *= Tm * sigma_n / (Tm[0] * smaj[0]);
                         // Russian roulette on low transmittance.
                         if (T.maxValue() < 0.05) {
                           const double q = 0.75;
                           if (rng.uniform() < q)
                             T = SampledSpectrum(0.0);
                           else
                             T /= 1 - q;
                         }
                         return !T.isBlack();
                       });
        if (!(T_maj[0] > 0)) return SampledSpectrum(0.0);
        T *= T_maj / T_maj[0];
      }
    }
    if (T.isBlack() || !hit) break;
    medium = mediumAfter(sc, *hit, ray.d, medium, false);
    origin = offsetOrigin(hit->p, hit->ng, ray.d);
    if (!to_infinite && dot(to - origin, ray.d) <= 0) break;
  }
  return T;
}

}  // namespace lensim::render
