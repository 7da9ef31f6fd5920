#include "lensim/optics/coating/thin_film.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace lensim::optics {

namespace {

using C = std::complex<double>;

// cos(theta) in a medium of complex index N for the invariant n0 sin(theta0), on the branch
// whose admittance N cos(theta) decays into the medium (Im(N cos t) <= 0 for N = n - ik with the
// exp(i(wt - kz)) convention, so that the substrate's evanescent wave beyond the critical angle
// carries no power).
C cosInMedium(C n, double n0_sin0) {
  const C s = n0_sin0 / n;
  C c = std::sqrt(C(1.0) - s * s);
  if ((n * c).imag() > 0) c = -c;
  if ((n * c).real() < 0 && (n * c).imag() == 0) c = -c;
  return c;
}

FilmRTA stackOnePolarisation(double n0, std::span<const FilmLayer> layers, double ns,
                             double lambda_nm, double cos_0, bool p) {
  const double sin_0 = std::sqrt(std::max(0.0, 1 - cos_0 * cos_0));
  const double inv = n0 * sin_0;
  auto admittance = [p](C n, C c) { return p ? n / c : n * c; };
  const double eta0 = p ? n0 / cos_0 : n0 * cos_0;
  const C cs = cosInMedium(C(ns, 0), inv);
  const C eta_s = admittance(C(ns, 0), cs);
  // (B, C) = M_1 M_2 ... M_q (1, eta_s): apply the matrices from the substrate outward.
  C b(1.0, 0.0), c = eta_s;
  for (auto it = layers.rbegin(); it != layers.rend(); ++it) {
    const C n = C(it->n.real(), -std::abs(it->n.imag()));  // n - ik
    const C cj = cosInMedium(n, inv);
    const C eta = admittance(n, cj);
    const C delta = 2 * std::numbers::pi * n * it->thickness_nm * cj / lambda_nm;
    const C cd = std::cos(delta), sd = std::sin(delta);
    const C i(0.0, 1.0);
    const C nb = cd * b + i * sd / eta * c;
    const C nc = i * eta * sd * b + cd * c;
    b = nb, c = nc;
  }
  const C den = eta0 * b + c;
  const double d2 = std::norm(den);
  FilmRTA out;
  out.R = std::norm((eta0 * b - c) / den);
  out.T = 4 * eta0 * std::max(0.0, eta_s.real()) / d2;
  out.A = std::max(0.0, 4 * eta0 * (b * std::conj(c) - eta_s).real() / d2);
  return out;
}

}  // namespace

void fresnelDielectricSP(double n1, double n2, double cos_i, double* rs, double* rp) {
  cos_i = std::clamp(cos_i, 0.0, 1.0);
  const double sin_t = n1 / n2 * std::sqrt(std::max(0.0, 1 - cos_i * cos_i));
  if (sin_t >= 1) {
    *rs = *rp = 1;
    return;
  }
  const double cos_t = std::sqrt(1 - sin_t * sin_t);
  const double s = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
  const double q = (n2 * cos_i - n1 * cos_t) / (n2 * cos_i + n1 * cos_t);
  *rs = s * s;
  *rp = q * q;
}

FilmRTA fresnelDielectric(double n1, double n2, double cos_i) {
  double rs, rp;
  fresnelDielectricSP(n1, n2, cos_i, &rs, &rp);
  const double r = 0.5 * (rs + rp);
  return FilmRTA{r, 1 - r, 0};
}

FilmRTA thinFilmStack(double n0, std::span<const FilmLayer> layers, double ns, double lambda_nm,
                      double cos_0, char polarisation) {
  cos_0 = std::clamp(cos_0, 1e-12, 1.0);
  if (polarisation == 's' || polarisation == 'p')
    return stackOnePolarisation(n0, layers, ns, lambda_nm, cos_0, polarisation == 'p');
  const FilmRTA s = stackOnePolarisation(n0, layers, ns, lambda_nm, cos_0, false);
  const FilmRTA p = stackOnePolarisation(n0, layers, ns, lambda_nm, cos_0, true);
  return FilmRTA{0.5 * (s.R + p.R), 0.5 * (s.T + p.T), 0.5 * (s.A + p.A)};
}

}  // namespace lensim::optics
