// Which coated (layered) BSDF is right: lensim's, or pbrt-v4's weighting of exits through a rough
// coating (issue 12: lensim's coated materials render darker than pbrt-v4's)? Settled by closed
// forms and an independent estimator, for both weightings (LayerParams::pbrt_v4_exit_weight):
//   - white furnace: a white Lambertian base under a non-absorbing smooth coating reflects
//     everything; what f() carries (all but the coating's mirror reflection) integrates to
//     1 - F(theta_o), F the Fresnel reflectance of the coating;
//   - the random walk of sample_f (no MIS, no next-event estimation: an independent estimator of
//     the same layered BSDF) against the integral of f() cos over the sphere, for rough coatings;
//   - reciprocity: f(wo, wi) = f(wi, wo).
// f() is a stochastic estimate seeded by its directions; independent estimates at "the same"
// directions come from moving wi by 1e-9 (far below any variation of the BSDF).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>

#include "lensim/render/materials/layered.h"
#include "lensim/sampling/sampling.h"
#include "stats.h"

namespace lensim::render {

using namespace lensim::sampling;
namespace {

using test::RunningStats;

Vec3 direction(double cos_theta, double phi) {
  const double s = std::sqrt(std::max(0.0, 1 - cos_theta * cos_theta));
  return {s * std::cos(phi), s * std::sin(phi), cos_theta};
}

// Fresnel reflectance of unpolarised light from outside onto a dielectric of index eta.
double fresnelDielectric(double cos_i, double eta) {
  const double sin2_t = (1 - cos_i * cos_i) / (eta * eta);
  if (sin2_t >= 1) return 1;
  const double cos_t = std::sqrt(1 - sin2_t);
  const double rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
  const double rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
  return 0.5 * (rs * rs + rp * rp);
}

std::shared_ptr<CoatedBxDF> whiteUnderCoat(double alpha, bool pbrt_weight) {
  LayerParams p;
  p.thickness = 1e-6;  // no absorption in the coating
  p.max_depth = 400;   // and a walk long enough to let everything out
  p.pbrt_v4_exit_weight = pbrt_weight;
  return std::make_shared<CoatedBxDF>(DielectricBxDF(1.5, TrowbridgeReitz(alpha, alpha)),
                                      std::make_shared<DiffuseBxDF>(SampledSpectrum(1.0)), p);
}

// Integral of f(wo, wi) |cos wi| over the sphere (cosine-weighted hemisphere samples).
RunningStats integralOfF(const BxDF& b, const Vec3& wo, int n, uint64_t seed) {
  Rng rng(seed, 3);
  RunningStats s;
  for (int i = 0; i < n; ++i) {
    const Vec3 wi = sampleCosineHemisphere({rng.uniform(), rng.uniform()});
    const double pdf = wi.z / kPi;
    s.add(pdf > 0 ? b.f(wo, wi, TransportMode::Radiance)[0] * wi.z / pdf : 0.0);
  }
  return s;
}

// Albedo from sample_f's random walk (all samples).
RunningStats albedoByWalk(const BxDF& b, const Vec3& wo, int n, uint64_t seed) {
  Rng rng(seed, 5);
  RunningStats s;
  for (int i = 0; i < n; ++i) {
    const auto bs =
        b.sample_f(wo, rng.uniform(), {rng.uniform(), rng.uniform()}, TransportMode::Radiance);
    s.add(bs && bs->pdf > 0 ? bs->f[0] * std::abs(bs->wi.z) / bs->pdf : 0.0);
  }
  return s;
}

TEST(CoatedFurnace, SmoothLosslessCoatOverWhiteIntegratesToOneMinusFresnel) {
  // A specular coating: no MIS between exits at all, so both weightings agree; the closed form
  // checks the walk, the Fresnel transmissions in and out and the radiance scaling.
  uint64_t seed = 1;
  for (bool pbrt : {false, true})
    for (double c : {0.9, 0.5, 0.15}) {
      const auto b = whiteUnderCoat(0.0, pbrt);
      const RunningStats s = integralOfF(*b, direction(c, 0.3), 20000, seed++);
      const double expected = 1 - fresnelDielectric(c, 1.5);
      std::printf("smooth coat, %s weights, cos %.2f: integral of f cos %.4f +- %.4f, 1 - F %.4f\n",
                  pbrt ? "pbrt-v4" : "lensim", c, s.mean, s.stderror(), expected);
      EXPECT_NEAR(s.mean, expected, 4.5 * s.stderror() + 2e-3) << c;
    }
}

TEST(CoatedFurnace, RoughCoatFMatchesTheRandomWalkOnlyWithLensimsWeights) {
  // With a rough coating, exits through it are estimated twice (next-event estimation from the
  // base, and the base's sampled direction leaving through the coating) and weighed by MIS. The
  // random walk of sample_f estimates the same albedo without any of that. lensim's weights agree
  // with it; pbrt-v4's (a density over outside directions against one over inside directions)
  // count the exits more than once and exceed it.
  uint64_t seed = 100;
  for (double alpha : {0.1, 0.3})
    for (double c : {0.9, 0.4}) {
      const Vec3 wo = direction(c, 1.1);
      const RunningStats walk = albedoByWalk(*whiteUnderCoat(alpha, false), wo, 40000, seed++);
      const RunningStats ours = integralOfF(*whiteUnderCoat(alpha, false), wo, 40000, seed++);
      const RunningStats pbrt = integralOfF(*whiteUnderCoat(alpha, true), wo, 40000, seed++);
      std::printf(
          "rough coat alpha %.1f, cos %.1f: random walk %.4f +- %.4f; integral of f cos: lensim "
          "%.4f +- %.4f, pbrt-v4 weights %.4f +- %.4f\n",
          alpha, c, walk.mean, walk.stderror(), ours.mean, ours.stderror(), pbrt.mean,
          pbrt.stderror());
      const double se_ours = std::hypot(walk.stderror(), ours.stderror());
      const double se_pbrt = std::hypot(walk.stderror(), pbrt.stderror());
      EXPECT_NEAR(ours.mean, walk.mean, 4.5 * se_ours) << alpha << " " << c;
      // pbrt-v4's weights are too high wherever the two exit strategies overlap much (measured
      // +4% and +2% at alpha 0.1, +7% and +8% at alpha 0.3); assert it where it is many sigma.
      if (alpha >= 0.3) {
        EXPECT_GT(pbrt.mean - walk.mean, 4.5 * se_pbrt) << alpha << " " << c;
      }
      // Nothing is gained in the white furnace (the rough interface loses a little energy: its
      // microfacet model has no multiple scattering between facets).
      EXPECT_LE(ours.mean, 1 + 4.5 * ours.stderror());
    }
}

TEST(CoatedReciprocity, FIsSymmetricInItsDirections) {
  // f(wo, wi) = f(wi, wo) for a coated diffuse and a coated rough conductor, rough coatings:
  // independent estimates (wi moved by 1e-9) averaged, compared by a z-test.
  LayerParams p;
  p.max_depth = 50;
  const auto diffuse =
      std::make_shared<CoatedBxDF>(DielectricBxDF(1.5, TrowbridgeReitz(0.2, 0.2)),
                                   std::make_shared<DiffuseBxDF>(SampledSpectrum(0.7)), p);
  SampledSpectrum eta(0.2), k(3.0);
  const auto conductor = std::make_shared<CoatedBxDF>(
      DielectricBxDF(1.5, TrowbridgeReitz(0.15, 0.15)),
      std::make_shared<ConductorBxDF>(TrowbridgeReitz(0.3, 0.3), eta, k), p);
  const std::pair<Vec3, Vec3> pairs[] = {{direction(0.9, 0.2), direction(0.4, 2.0)},
                                         {direction(0.3, 1.0), direction(0.7, 4.0)},
                                         {direction(0.6, 0.0), direction(0.55, 3.0)}};
  for (const auto& b : {diffuse, conductor})
    for (const auto& [a, c] : pairs) {
      RunningStats fwd, bwd;
      for (int i = 0; i < 6000; ++i) {
        const Vec3 d{1e-9 * (i % 97), 1e-9 * (i / 97), 0};
        fwd.add(b->f(a, normalize(c + d), TransportMode::Radiance)[0]);
        bwd.add(b->f(c, normalize(a + d), TransportMode::Radiance)[0]);
      }
      const double se = std::hypot(fwd.stderror(), bwd.stderror());
      EXPECT_NEAR(fwd.mean, bwd.mean, 4.5 * se) << a.z << " " << c.z;
    }
}

}  // namespace
}  // namespace lensim::render
