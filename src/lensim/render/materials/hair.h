// pbrt-v4's hair BSDF (the "hair" material): the fibre model of Chiang, Bitterli, Tappan and
// Burley 2016, "A Practical and Controllable Hair and Fur Model for Production Path Tracing"
// (Computer Graphics Forum 35(2)), with the longitudinal scattering function of d'Eon, Francois,
// Hill, Letteri and Aubry 2011, "An Energy-Conserving Hair Reflectance Model" (EGSR), as
// pbrt-v4 implements it (src/pbrt/bxdfs.h and bxdfs.cpp, HairBxDF; the parameters as
// src/pbrt/materials.h/.cpp HairMaterial reads them).
//
// The fibre is a dielectric cylinder of index eta with absorbing interior. Light leaves after p
// internal paths: p = 0 reflection (R), 1 transmission (TT), 2 one internal reflection (TRT),
// and 3 standing for all longer paths. Each term is M_p (longitudinal: d'Eon's normalised
// von Mises-Fisher marginal with variance v_p from beta_m), A_p (attenuation: Fresnel and
// Beer-Lambert along the chord 2 cos(gamma_t) / cos(theta_t), in fibre radii) and N_p
// (azimuthal: a trimmed logistic of scale s from beta_n about the specular azimuth of path p;
// uniform for p = 3). Cuticle scales tilt the R, TT and TRT lobes by -2 alpha, alpha and 4 alpha.
//
// Frame: x is the fibre's direction (dp/du), z the shading normal, y = z x x; sin(theta) = w.x,
// phi = atan2(w.z, w.y). As in pbrt-v4, f is the sum of the lobes divided by |cos| to the
// shading normal, so that f |cos| is the fibre's scattering function: with sigma_a = 0 it
// integrates to 1 over the sphere for every wo (white furnace). h in [-1, 1] is where across
// the fibre's width the ray hit it (pbrt-v4: h = -1 + 2 v of the curve intersection).
//
// The model is not reciprocal: A_p and the azimuthal offsets depend on wo alone (pbrt-v4 keeps
// its reciprocity test disabled, src/pbrt/bsdfs_test.cpp "#if 0 TEST(Hair, Reciprocity)").
#pragma once

#include <array>

#include "lensim/render/materials/bsdf.h"

namespace lensim::render {

class HairBxDF final : public BxDF {
 public:
  static constexpr int kPMax = 3;
  /// h: offset across the fibre in [-1, 1]; eta: the fibre's index (values below 1 are taken
  /// as 1); sigma_a: absorption per fibre radius at the path's wavelengths (>= 0, may be
  /// infinite); beta_m, beta_n: longitudinal and azimuthal roughness in (0, 1]; alpha_deg: the
  /// cuticle scales' tilt in degrees.
  HairBxDF(double h, double eta, const SampledSpectrum& sigma_a, double beta_m, double beta_n,
           double alpha_deg);
  BxDFFlags flags() const override { return BxDFFlags::Glossy | BxDFFlags::Reflection; }
  SampledSpectrum f(const Vec3& wo, const Vec3& wi, TransportMode mode) const override;
  std::optional<BSDFSample> sample_f(const Vec3& wo, double uc, Vec2 u, TransportMode mode,
                                     ReflTrans allowed = ReflTrans::All) const override;
  double pdf(const Vec3& wo, const Vec3& wi, TransportMode mode,
             ReflTrans allowed = ReflTrans::All) const override;

  /// pbrt-v4's HairBxDF::SigmaAFromConcentration: the linear sRGB absorption of eumelanin and
  /// pheomelanin concentrations, ce (0.419, 0.697, 1.37) + cp (0.187, 0.4, 1.05), the
  /// coefficients pbrt-v4 takes from Chiang et al. 2016.
  static Vec3 sigmaAFromConcentration(double eumelanin, double pheomelanin);
  /// pbrt-v4's HairBxDF::SigmaAFromReflectance (Chiang et al. 2016's fit of absorption against
  /// the colour of multiply scattered light): for a colour c in [0, 1] and roughness beta_n,
  /// sigma_a = (ln c / (5.969 - 0.215 bn + 2.532 bn^2 - 10.73 bn^3 + 5.574 bn^4 + 0.245 bn^5))^2.
  static SampledSpectrum sigmaAFromReflectance(const SampledSpectrum& c, double beta_n);

  /// The longitudinal variance v_p (exposed for tests).
  double variance(int p) const { return v_[size_t(p)]; }

 private:
  struct WoTerms;
  WoTerms terms(const Vec3& wo) const;
  SampledSpectrum fsum(const WoTerms& t, const Vec3& wi) const;
  double pdfOf(const WoTerms& t, const Vec3& wi) const;

  double h_, gamma_o_, cos_gamma_o_, eta_;
  SampledSpectrum sigma_a_;
  std::array<double, kPMax + 1> v_{}, log_norm_{};  ///< M_p's variance and log normalisation
  double s_, inv_k_;                                ///< logistic scale, 1 / its mass on [-pi, pi]
  std::array<double, 3> sin2k_alpha_{}, cos2k_alpha_{};
};

}  // namespace lensim::render
