// pbrt-v3's materials as pbrt-v3 defines them (render/v3materials.h): chi-square tests of every
// sampled lobe combination against its pdf, white furnaces with closed forms, reciprocity, and
// values computed by hand from pbrt-v3's formulas.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "chi2.h"
#include "lensim/render/materials/v3materials.h"
#include "lensim/sampling/sampling.h"
#include "render_test_util.h"
#include "stats.h"

namespace lensim::render {

using namespace lensim::sampling;
namespace {

using test::RunningStats;

Vec3 direction(double cos_theta, double phi) {
  const double s = std::sqrt(std::max(0.0, 1 - cos_theta * cos_theta));
  return {s * std::cos(phi), s * std::sin(phi), cos_theta};
}

V3Lobe lambert(double r, bool transmit = false) {
  V3Lobe l;
  l.kind = transmit ? V3Lobe::Kind::LambertianTransmission : V3Lobe::Kind::LambertianReflection;
  (transmit ? l.T : l.R) = SampledSpectrum(r);
  return l;
}
V3Lobe microfacet(double s, bool transmit, double alpha, double eta_i, double eta_t,
                  double alpha_y = -1) {
  V3Lobe l;
  l.kind = transmit ? V3Lobe::Kind::MicrofacetTransmission : V3Lobe::Kind::MicrofacetReflection;
  (transmit ? l.T : l.R) = SampledSpectrum(s);
  l.alpha_x = alpha;
  l.alpha_y = alpha_y > 0 ? alpha_y : alpha;
  l.fresnel = V3Lobe::Fresnel::Dielectric;
  l.eta_i = eta_i, l.eta_t = eta_t;
  return l;
}
V3Lobe fresnelBlend(double rd, double rs, double ax, double ay) {
  V3Lobe l;
  l.kind = V3Lobe::Kind::FresnelBlend;
  l.R = SampledSpectrum(rd), l.T = SampledSpectrum(rs);
  l.alpha_x = ax, l.alpha_y = ay;
  return l;
}

struct Case {
  std::string name;
  V3BSDF bsdf;
};

// pbrt-v3's materials at their defaults (roughness remapped as pbrt-v3 does) and variants.
std::vector<Case> cases() {
  const double a01 = roughnessToAlphaV3(0.1);
  return {
      {"plastic", V3BSDF({lambert(0.25), microfacet(0.25, false, a01, 1.5, 1.0)})},
      {"plastic-glossy", V3BSDF({lambert(0.5), microfacet(0.5, false, 0.05, 1.5, 1.0)})},
      {"substrate", V3BSDF({fresnelBlend(0.5, 0.5, a01, a01)})},
      {"substrate-aniso", V3BSDF({fresnelBlend(0.3, 0.2, 0.05, 0.4)})},
      {"translucent",
       V3BSDF({lambert(0.125), lambert(0.125, true), microfacet(0.125, false, a01, 1.0, 1.5),
               microfacet(0.125, true, a01, 1.0, 1.5)})},
      {"rough-glass",
       V3BSDF({microfacet(1.0, false, 0.3, 1.0, 1.5), microfacet(1.0, true, 0.3, 1.0, 1.5)})},
      {"rough-metal",
       [] {
         V3Lobe l;
         l.kind = V3Lobe::Kind::MicrofacetReflection;
         l.R = SampledSpectrum(1.0);
         l.fresnel = V3Lobe::Fresnel::Conductor;
         l.cond_eta = SampledSpectrum(0.2);
         l.cond_k = SampledSpectrum(3.0);
         l.alpha_x = l.alpha_y = roughnessToAlphaV3(0.01);
         return V3BSDF({l});
       }()},
  };
}

TEST(V3Materials, SamplingMatchesPdfChi2) {
  uint64_t seed = 1;
  for (const Case& c : cases())
    for (const Vec3& wo : {direction(0.85, 0.3), direction(0.3, 2.0), direction(-0.6, 4.0)}) {
      // (pdf() and sampling do not depend on the transport mode.)
      for (auto mode : {TransportMode::Radiance}) {
        const test::Chi2Result r = test::chi2TestBxDF(c.bsdf, wo, mode, 100000, seed++);
        EXPECT_GT(r.p_value, 1e-4) << c.name << " wo.z=" << wo.z << " " << r.summary();
        EXPECT_EQ(r.impossible_samples, 0) << c.name;
        EXPECT_LT(r.max_eval_mismatch, 1e-6) << c.name << " wo.z=" << wo.z;
      }
    }
}

// Albedo of a BSDF for wo by its own sampling, specular samples included.
RunningStats albedo(const BxDF& b, const Vec3& wo, int n, uint64_t seed,
                    TransportMode mode = TransportMode::Importance) {
  Rng rng(seed, 9);
  RunningStats s;
  for (int i = 0; i < n; ++i) {
    const auto bs = b.sample_f(wo, rng.uniform(), {rng.uniform(), rng.uniform()}, mode);
    s.add(bs && bs->pdf > 0 ? bs->f[0] * std::abs(bs->wi.z) / bs->pdf : 0.0);
  }
  return s;
}

TEST(V3Materials, FurnacesWithClosedForms) {
  // A white Lambertian plastic without Ks reflects 1; a smooth glass with Kr = Kt = 1 reflects
  // and transmits 1 (importance transport: no 1/eta^2); Kr = Kt = 0.5 gives 0.5; a mirror
  // reflects Kr at every angle (pbrt-v3's FresnelNoOp); an uber of opacity 0.3 passes 0.7 of the
  // light straight through and nothing else.
  for (const Vec3& wo : {direction(0.9, 0.1), direction(0.4, 1.0), direction(-0.7, 2.0)}) {
    const RunningStats white = albedo(V3BSDF({lambert(1.0)}), wo, 40000, 11);
    EXPECT_NEAR(white.mean, 1.0, 4.5 * white.stderror() + 1e-9);
    V3Lobe glass;
    glass.kind = V3Lobe::Kind::FresnelSpecular;
    glass.R = glass.T = SampledSpectrum(1.0);
    glass.fresnel = V3Lobe::Fresnel::Dielectric;
    glass.eta_t = 1.5;
    EXPECT_NEAR(albedo(V3BSDF({glass}), wo, 20000, 12).mean, 1.0, 1e-9);
    glass.R = glass.T = SampledSpectrum(0.5);
    EXPECT_NEAR(albedo(V3BSDF({glass}), wo, 20000, 13).mean, 0.5, 1e-9);
    V3Lobe mirror;
    mirror.kind = V3Lobe::Kind::SpecularReflection;
    mirror.R = SampledSpectrum(0.8);
    EXPECT_NEAR(albedo(V3BSDF({mirror}), wo, 1000, 14).mean, 0.8, 1e-12);
    V3Lobe pass;
    pass.kind = V3Lobe::Kind::SpecularTransmission;
    pass.T = SampledSpectrum(0.7);
    pass.fresnel = V3Lobe::Fresnel::Dielectric;
    pass.eta_t = 1.0;
    const V3BSDF uber({pass});
    const auto s = uber.sample_f(wo, 0.5, {0.5, 0.5}, TransportMode::Radiance);
    ASSERT_TRUE(s);
    EXPECT_NEAR(s->wi.x, -wo.x, 1e-12);
    EXPECT_NEAR(s->wi.z, -wo.z, 1e-12);
    EXPECT_NEAR(s->f[0] * std::abs(s->wi.z) / s->pdf, 0.7, 1e-12);
  }
}

TEST(V3Materials, EnergyNeverGainedAndReciprocity) {
  uint64_t seed = 300;
  for (const Case& c : cases()) {
    for (const Vec3& wo : {direction(0.95, 0.0), direction(0.5, 1.0), direction(0.15, 2.0)}) {
      const RunningStats s = albedo(c.bsdf, wo, 40000, seed++);
      EXPECT_LE(s.mean, 1.0 + 4.5 * s.stderror()) << c.name << " wo.z=" << wo.z;
    }
    // Reflection is reciprocal (importance and radiance modes agree for reflection).
    Rng rng(seed++, 1);
    for (int i = 0; i < 200; ++i) {
      const Vec3 a = sampleUniformSphere({rng.uniform(), rng.uniform()});
      Vec3 b = sampleUniformSphere({rng.uniform(), rng.uniform()});
      if (a.z * b.z < 0) b.z = -b.z;
      const double f1 = c.bsdf.f(a, b, TransportMode::Radiance)[0];
      const double f2 = c.bsdf.f(b, a, TransportMode::Radiance)[0];
      EXPECT_NEAR(f1, f2, 1e-9 * (1 + std::abs(f1))) << c.name;
    }
  }
}

TEST(V3Materials, RoughGlassEqualsPbrtV4sRoughDielectric) {
  // pbrt-v3's MicrofacetReflection + MicrofacetTransmission (Fresnel 1 -> 1.5) and pbrt-v4's
  // rough DielectricBxDF (bsdf.h, written independently from pbrt-v4's formulas) are the same
  // model: f agrees at random direction pairs, in both transport modes.
  for (double a : {0.1, 0.3, 0.8}) {
    const V3BSDF v3({microfacet(1.0, false, a, 1.0, 1.5), microfacet(1.0, true, a, 1.0, 1.5)});
    const DielectricBxDF v4(1.5, TrowbridgeReitz(a, a));
    Rng rng(77, 3);
    int compared = 0;
    for (int i = 0; i < 2000; ++i) {
      const Vec3 wo = sampleUniformSphere({rng.uniform(), rng.uniform()});
      const Vec3 wi = sampleUniformSphere({rng.uniform(), rng.uniform()});
      for (auto mode : {TransportMode::Radiance, TransportMode::Importance}) {
        const double f3 = v3.f(wo, wi, mode)[0], f4 = v4.f(wo, wi, mode)[0];
        EXPECT_NEAR(f3, f4, 1e-9 + 1e-7 * std::abs(f4))
            << "alpha " << a << " wo.z " << wo.z << " wi.z " << wi.z;
        compared += f4 > 0;
      }
    }
    EXPECT_GT(compared, 1000);
  }
}

TEST(V3Materials, PbrtV3FormulasByHand) {
  // RoughnessToAlpha(0.5): x = ln 0.5 = -0.6931472; 1.62142 - 0.5683495 + 0.0833106 - 0.0057014
  // + 0.0001479 = 1.1308275.
  EXPECT_NEAR(roughnessToAlphaV3(0.5), 1.1308275, 1e-6);
  EXPECT_NEAR(roughnessToAlphaV3(0.0), roughnessToAlphaV3(1e-3), 0);
  // Plastic's FresnelDielectric(1.5, 1) (glass-to-air): 0.04 at normal incidence, total
  // reflection beyond the critical angle asin(1/1.5) = 41.8 degrees.
  EXPECT_NEAR(frDielectricV3(1.0, 1.5, 1.0), 0.04, 1e-12);
  EXPECT_EQ(frDielectricV3(std::cos(45 * kPi / 180), 1.5, 1.0), 1.0);
  // Air to glass at 60 degrees: rs = -0.4201, rp = 0.0419 -> (0.17649 + 0.00176) / 2.
  EXPECT_NEAR(frDielectricV3(0.5, 1.0, 1.5), 0.0891, 2e-4);
  // A negative cosine swaps the sides.
  EXPECT_EQ(frDielectricV3(-0.5, 1.5, 1.0), frDielectricV3(0.5, 1.0, 1.5));
  // Substrate (FresnelBlend) at normal incidence, wo = wi = +z: the diffuse term is
  // 28/(23 pi) Rd (1 - Rs) (1 - 0.5^5)^2 and the specular one D(z) / (4 * 1 * 1) * Rs with
  // D(z) = 1 / (pi alpha^2).
  const double rd = 0.5, rs = 0.3, a = 0.2;
  const V3BSDF sub({fresnelBlend(rd, rs, a, a)});
  const double diffuse = 28 / (23 * kPi) * rd * (1 - rs) * std::pow(1 - 1.0 / 32, 2);
  const double spec = 1 / (kPi * a * a) / 4 * rs;
  EXPECT_NEAR(sub.f({0, 0, 1}, {0, 0, 1}, TransportMode::Radiance)[0], diffuse + spec, 1e-9);
}

// Through the renderer, from scene text: pbrt-v3 glass (smooth and rough, Kr = Kt = 1) and a
// white plastic without Ks in a white furnace read 1; a mirror of Kr 0.6 and an uber of opacity
// 0.3 with nothing else read their closed forms (0.6: the sky seen in the mirror; 0.7^2: the sky
// seen straight through both surfaces, the rest absorbed).
TEST(V3Materials, FurnaceRenders) {
  const std::string header = R"(LookAt 0 0 -5  0 0 0  0 1 0
Camera "perspective" "float fov" 30
Film "rgb" "integer xresolution" 16 "integer yresolution" 16 "string filename" "f.exr"
Sampler "independent" "integer pixelsamples" 64
PixelFilter "box"
Integrator "path" "integer maxdepth" 64
WorldBegin
LightSource "infinite" "rgb L" [1 1 1]
)";
  struct F {
    const char* material;
    double expect;
  };
  const F cases[] = {
      {R"(Material "glass")", 1.0},
      {R"(Material "glass" "float uroughness" 0.05 "float vroughness" 0.05 "bool remaproughness" false)",
       1.0},
      {R"(Material "plastic" "color Kd" [1 1 1] "color Ks" [0 0 0])", 1.0},
      {R"(Material "mirror" "color Kr" [0.6 0.6 0.6])", 0.6},
      {R"(Material "uber" "color Kd" [0 0 0] "color Ks" [0 0 0] "color opacity" [0.3 0.3 0.3])",
       0.49}};
  for (const F& f : cases) {
    render::RenderOptions o;
    o.seed = 3;
    const io::Image im =
        testutil::renderText(header + f.material + "\nShape \"sphere\" \"float radius\" 1\n", o)
            .image;
    RunningStats centre;
    for (int y = 5; y < 11; ++y)
      for (int x = 5; x < 11; ++x) centre.add(testutil::luminanceAt(im, x, y));
    std::printf("%s: centre %.4f +- %.4f\n", f.material, centre.mean, centre.stderror());
    // 5 standard errors plus 1% for the RGB -> spectrum -> RGB round trip (and the rough
    // glass's microfacet energy loss, well under 1% at this roughness).
    EXPECT_NEAR(centre.mean, f.expect, 5 * centre.stderror() + 0.01 * f.expect) << f.material;
  }
}

}  // namespace
}  // namespace lensim::render
