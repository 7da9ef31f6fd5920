// Tracking rays through participating media, shared by the volpath, bdpt and lighttracer
// integrators (pbrt-v4, Pharr, Jakob & Humphreys, 4th ed., sec. 14.1-14.2; its SampleT_maj in
// src/pbrt/media.h and the media code of VolPathIntegrator, LightPathIntegrator and
// BDPTIntegrator's RandomWalk in src/pbrt/cpu/integrators.cpp).
//
// Spectral (chromatic) media: distances are sampled by the hero wavelength's majorant; a path's
// throughput beta is divided by the hero's pdf, and r[i] is the pdf of the same path with
// wavelength i as the hero divided by the hero's. beta / wavelengthMean(r) is the one-sample MIS
// estimate over the hero choice (balance heuristic), as volpath's r_u.
#pragma once

#include <cmath>

#include "lensim/render/integrators/integrator.h"
#include "lensim/render/media/media.h"
#include "lensim/sampling/sampling.h"

namespace lensim::render {

using namespace lensim::sampling;

/// The average of rescaled path pdfs r over the wavelengths that are still carried: the one-sample
/// MIS over wavelengths. Once a dispersive interface (or lens) has kept only the hero wavelength,
/// its estimate is the hero's alone (r[0]); averaging in the others' pdfs would bias it.
inline double wavelengthMean(const SampledSpectrum& r, const SampledWavelengths& lambda) {
  return lambda.secondaryTerminated() ? r[0] : r.average();
}

/// exp(-dt sigma) per wavelength, 1 where sigma is 0 (also for an infinite dt).
inline SampledSpectrum transmittance(double dt, const SampledSpectrum& sigma) {
  SampledSpectrum T;
  for (int i = 0; i < kSpectrumSamples; ++i) T[i] = sigma[i] == 0 ? 1.0 : std::exp(-dt * sigma[i]);
  return T;
}

/// pbrt-v4's SampleT_maj: delta tracking along the ray o + t d (d unit), t in [0, tmax), in
/// `medium` by the hero wavelength's majorant. At each tentative collision calls
/// callback(p, properties, sigma_maj, T_maj) with T_maj the majorant transmittance since the
/// previous collision; stops when it returns false (and then returns 1). Otherwise returns the
/// majorant transmittance from the last collision to tmax.
template <class Callback>
SampledSpectrum sampleTmaj(const Medium& medium, const Vec3& o, const Vec3& d, double tmax,
                           double u, Rng& rng, const SampledWavelengths& lambda,
                           Callback&& callback) {
  SampledSpectrum T_maj(1.0);
  bool stopped = false;
  medium.majorants(o, d, tmax, lambda, [&](double t0, double t1, const SampledSpectrum& smaj) {
    if (smaj[0] == 0) {
      T_maj *= transmittance(t1 - t0, smaj);
      return true;
    }
    double t_min = t0;
    for (;;) {
      const double t = t_min - std::log1p(-u) / smaj[0];
      u = rng.uniform();
      if (t >= t1) {
        T_maj *= transmittance(t1 - t_min, smaj);
        return true;
      }
      T_maj *= transmittance(t - t_min, smaj);
      const Vec3 p = o + d * t;
      if (!callback(p, medium.at(p, lambda), smaj, T_maj)) {
        stopped = true;
        return false;
      }
      T_maj = SampledSpectrum(1.0);
      t_min = t;
    }
  });
  return stopped ? SampledSpectrum(1.0) : T_maj;
}

/// The medium a ray enters when it leaves the surface hit `h` in direction w (pbrt-v4: shapes
/// whose inside and outside media are the same are no boundary).
/// A shape of subsurface material has that material's medium inside (render/media/subsurface.h)
/// unless `subsurface` is false. Without scene media (the path integrator) MediumInterface is
/// ignored.
int mediumAfter(const SceneContext& sc, const SurfaceHit& h, const Vec3& w, int current,
                bool subsurface = true);

/// Whether the surface at h has the "interface" material (a medium boundary rays pass).
bool isInterfaceHit(const SceneContext& sc, const SurfaceHit& h, const Vec3& wo);

/// The medium a light's paths start in: an area light's, the outside medium of its shape's
/// MediumInterface (pbrt-v4 gives area lights that medium); another light's, the outside medium
/// current at its LightSource. -1 (vacuum) when scene media are not rendered.
int lightMedium(const SceneContext& sc, const Light& light);

/// For lights at infinity (infinite, distant), whose light paths start on a disk outside the
/// scene: the transmittance of their medium from infinity to that disk. 0 (where sigma_t > 0)
/// in a homogeneous medium, which has no end, as a camera ray escaping into it never arrives
/// (so bdpt and lighttracer agree with volpath); 1 in vacuum and in grid media, which end at
/// their bounds.
SampledSpectrum transmittanceFromInfinity(const SceneContext& sc, int medium,
                                          const SampledWavelengths& lambda);

/// A random number stream for one path's tracking steps (their count varies), seeded by two of
/// the sampler's dimensions.
Rng pathRng(Sampler& sampler);

/// What delta tracking found along a ray through one medium.
struct MediumEvent {
  enum class Kind { Passed, Scattered, Absorbed } kind = Kind::Passed;
  Vec3 p;  ///< Scattered: the real scattering point
};

/// Delta tracking along o + t d (d unit, t in [0, t_end)) in medium m, as volpath's (absorption,
/// real scattering or a null collision chosen by the hero's probabilities). beta and r (see the
/// file comment) are updated for the event. Emission at the collisions is added to *L_emitted,
/// weighted by one-sample MIS over wavelengths, when L_emitted is not null. Two of the sampler's
/// dimensions, then the stream's numbers.
MediumEvent trackMedium(const Medium& m, const Vec3& o, const Vec3& d, double t_end,
                        const SampledWavelengths& lambda, Sampler& sampler, Rng& rng,
                        SampledSpectrum& beta, SampledSpectrum& r, SampledSpectrum* L_emitted);

/// The transmittance between `from` and `to` (to_infinite: the direction `to` without end),
/// starting in medium `medium` (scene media index; -1 vacuum), through interface surfaces (their
/// other side's medium): an unbiased estimate per wavelength (exact in homogeneous media, ratio
/// tracking by the hero's majorant in others), 0 where an opaque surface blocks it, at shutter
/// time `time`. from_ng: the
/// geometric normal of the surface `from` lies on (the ray starts off it), or zero.
SampledSpectrum segmentTransmittance(const SceneContext& sc, const Vec3& from, const Vec3& from_ng,
                                     int medium, const Vec3& to, bool to_infinite, double time,
                                     const SampledWavelengths& lambda, Rng& rng, RayCounts& counts);

}  // namespace lensim::render
