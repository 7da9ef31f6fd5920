// Pearson chi-square goodness-of-fit test of a BxDF's sample_f against its pdf, in the manner
// of pbrt-v3's bsdfs test and Mitsuba's chi2 tester: directions are binned on a sphere grid
// (equal-area bins: uniform in cos theta and phi), expected counts come from integrating pdf
// over each bin by quadrature, bins expecting fewer than 5 samples are pooled, and the p-value
// comes from the chi-square distribution's upper tail.
#pragma once

#include <string>

#include "lensim/render/materials/bsdf.h"

namespace lensim::test {

/// Regularised upper incomplete gamma function Q(a, x) = Gamma(a, x) / Gamma(a).
/// Hand-written (series and Lentz continued fraction, as in Press et al., Numerical Recipes,
/// 6.2) because the Debian packages that provide it are heavy (Boost.Math) or GPL (GSL) for one
/// ~40-line function.
double gammaQ(double a, double x);

/// Upper tail probability of a chi-square statistic with `dof` degrees of freedom.
inline double chi2PValue(double chi2, int dof) {
  return gammaQ(0.5 * dof, 0.5 * chi2);
}

/// Outcome of one chi-square run.
struct Chi2Result {
  double p_value = 0;
  double chi2 = 0;
  int dof = 0;
  /// Worst relative mismatch between sample_f's (f, pdf) and f(), pdf() at the sampled wi.
  double max_eval_mismatch = 0;
  /// Samples landing in bins whose integrated pdf is zero (must be 0).
  int impossible_samples = 0;
  /// Integral of pdf over the sphere (quadrature).
  double pdf_integral = 0;
  std::string summary() const;
};

/// Draws n samples from bxdf.sample_f(wo, ...) with a seeded PCG32 and tests them against
/// bxdf.pdf on a theta_res x phi_res grid. Specular samples are not allowed. Each bin's pdf
/// integral uses quadrature x quadrature midpoints; tabulated (piecewise-constant) pdfs, whose
/// cell edges cut the bins, need more than the default to keep the quadrature error below the
/// sampling noise.
Chi2Result chi2TestBxDF(const render::BxDF& bxdf, const Vec3& wo, render::TransportMode mode, int n,
                        uint64_t seed, int theta_res = 10, int phi_res = 20, int quadrature = 48);

}  // namespace lensim::test
