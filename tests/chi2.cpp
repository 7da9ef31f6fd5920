#include "chi2.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <fmt/format.h>

#include "lensim/sampling/sampling.h"

namespace lensim::test {

using namespace lensim::render;
using namespace lensim::sampling;

double gammaQ(double a, double x) {
  if (x <= 0) return 1.0;
  const double log_prefactor = -x + a * std::log(x) - std::lgamma(a);
  constexpr double eps = 1e-15, tiny = 1e-300;
  if (x < a + 1) {
    // Series for P(a, x); Q = 1 - P.
    double ap = a, sum = 1.0 / a, del = sum;
    for (int n = 0; n < 100000; ++n) {
      ap += 1;
      del *= x / ap;
      sum += del;
      if (std::abs(del) < std::abs(sum) * eps) break;
    }
    return std::max(0.0, 1.0 - sum * std::exp(log_prefactor));
  }
  // Continued fraction for Q(a, x), modified Lentz.
  double b = x + 1 - a, c = 1 / tiny, d = 1 / b, h = d;
  for (int i = 1; i < 100000; ++i) {
    const double an = -i * (i - a);
    b += 2;
    d = an * d + b;
    if (std::abs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1 / d;
    const double del = d * c;
    h *= del;
    if (std::abs(del - 1) < eps) break;
  }
  return std::exp(log_prefactor) * h;
}

std::string Chi2Result::summary() const {
  return fmt::format(
      "chi2={:.2f} dof={} p={:.3g} pdf_integral={:.5f} eval_mismatch={:.2g} "
      "impossible={}",
      chi2, dof, p_value, pdf_integral, max_eval_mismatch, impossible_samples);
}

Chi2Result chi2TestBxDF(const BxDF& bxdf, const Vec3& wo, TransportMode mode, int n, uint64_t seed,
                        int theta_res, int phi_res, int quadrature) {
  Chi2Result res;
  const int nbins = theta_res * phi_res;
  auto binOf = [&](const Vec3& w) {
    const double c = std::clamp(w.z, -1.0, 1.0);
    const int t = std::clamp(static_cast<int>((1 - c) / 2 * theta_res), 0, theta_res - 1);
    double phi = std::atan2(w.y, w.x);
    if (phi < 0) phi += 2 * kPi;
    const int p = std::clamp(static_cast<int>(phi / (2 * kPi) * phi_res), 0, phi_res - 1);
    return t * phi_res + p;
  };

  // Observed counts; the last slot counts "no sample".
  std::vector<double> observed(nbins + 1, 0.0);
  Rng rng(seed, 0);
  auto rel = [](double a, double b) {
    return std::abs(a - b) / std::max({std::abs(a), std::abs(b), 1e-12});
  };
  for (int i = 0; i < n; ++i) {
    const double uc = rng.uniform();
    const Vec2 u(rng.uniform(), rng.uniform());
    const auto s = bxdf.sample_f(wo, uc, u, mode);
    if (!s || s->pdf == 0 || s->f.isBlack()) {
      observed[nbins] += 1;
      continue;
    }
    if (s->isSpecular()) throw std::logic_error("chi2 test given a specular sample");
    observed[binOf(s->wi)] += 1;
    const SampledSpectrum fe = bxdf.f(wo, s->wi, mode);
    const double pe = bxdf.pdf(wo, s->wi, mode);
    double m = rel(s->pdf, pe);
    for (int k = 0; k < kSpectrumSamples; ++k) m = std::max(m, rel(s->f[k], fe[k]));
    res.max_eval_mismatch = std::max(res.max_eval_mismatch, m);
  }

  // Expected counts: midpoint rule in (theta, phi) inside each bin, dw = sin theta dtheta dphi.
  const int kSub = quadrature;
  std::vector<double> expected(nbins + 1, 0.0);
  for (int t = 0; t < theta_res; ++t) {
    const double th0 = std::acos(1 - 2.0 * t / theta_res);
    const double th1 = std::acos(std::max(-1.0, 1 - 2.0 * (t + 1) / theta_res));
    const double dth = (th1 - th0) / kSub;
    for (int p = 0; p < phi_res; ++p) {
      const double ph0 = 2 * kPi * p / phi_res, dph = 2 * kPi / phi_res / kSub;
      double sum = 0;
      for (int i = 0; i < kSub; ++i) {
        const double th = th0 + (i + 0.5) * dth;
        const double st = std::sin(th), ct = std::cos(th);
        for (int j = 0; j < kSub; ++j) {
          const double ph = ph0 + (j + 0.5) * dph;
          sum += bxdf.pdf(wo, Vec3(st * std::cos(ph), st * std::sin(ph), ct), mode) * st;
        }
      }
      expected[t * phi_res + p] = sum * dth * dph;
    }
  }
  double integral = 0;
  for (int b = 0; b < nbins; ++b) integral += expected[b];
  res.pdf_integral = integral;
  for (int b = 0; b < nbins; ++b) expected[b] *= n;
  expected[nbins] = std::max(0.0, 1 - integral) * n;

  // Pool low-expectation bins, flag samples where nothing is expected.
  double chi2 = 0, pooled_o = 0, pooled_e = 0;
  int kept = 0;
  for (int b = 0; b <= nbins; ++b) {
    if (expected[b] < 1e-9 * n && observed[b] > 0) res.impossible_samples += int(observed[b]);
    if (expected[b] < 5) {
      pooled_o += observed[b];
      pooled_e += expected[b];
      continue;
    }
    chi2 += (observed[b] - expected[b]) * (observed[b] - expected[b]) / expected[b];
    ++kept;
  }
  if (pooled_e > 0) {
    chi2 += (pooled_o - pooled_e) * (pooled_o - pooled_e) / pooled_e;
    ++kept;
  }
  res.chi2 = chi2;
  res.dof = std::max(1, kept - 1);
  res.p_value = chi2PValue(chi2, res.dof);
  return res;
}

}  // namespace lensim::test
