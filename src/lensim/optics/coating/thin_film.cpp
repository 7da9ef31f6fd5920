#include "lensim/optics/coating/thin_film.h"

#include <algorithm>
#include <array>
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

// s and p of a stack at once when every layer is lossless and the light propagates in each layer
// and in the substrate (n_j > n0 sin(theta_0), ns too): then every cos(theta_j), phase thickness
// and admittance is real, the matrices [[cos d, i sin d / eta], [i eta sin d, cos d]] act on
// (B, C) = (Br + i Bi, Cr + i Ci) with real arithmetic, and s and p share each layer's cos(theta)
// and phase (only the admittances differ). The same result as stackOnePolarisation (the
// complex path, used otherwise) with one square root per layer and one sine/cosine per layer and
// wavelength instead of complex ones per polarisation. Several wavelengths at one angle (the
// layers' indices the same at all of them) share the angle's part: cos(theta_j), the admittances
// and the phase thickness times lambda. Returns false where it does not apply.
bool losslessStackUnpolarised(double n0, std::span<const FilmLayer> layers, double ns,
                              std::span<const double> lambda_nm, double cos_0, FilmRTA* out) {
  const double inv2 = n0 * n0 * std::max(0.0, 1 - cos_0 * cos_0);  // (n0 sin_0)^2
  if (ns * ns <= inv2) return false;
  for (const FilmLayer& l : layers)
    if (l.n.imag() != 0 || l.n.real() * l.n.real() <= inv2) return false;
  struct BC {
    double br = 1, bi = 0, cr = 0, ci = 0;
    void apply(double cd, double sd, double eta, double inv_eta) {
      const double nbr = cd * br - sd * inv_eta * ci, nbi = cd * bi + sd * inv_eta * cr;
      const double ncr = cd * cr - eta * sd * bi, nci = cd * ci + eta * sd * br;
      br = nbr, bi = nbi, cr = ncr, ci = nci;
    }
    // R and T for the incident admittance eta0 and the substrate's eta_sub.
    void rt(double eta0, double eta_sub, double* r, double* t) const {
      const double ur = eta0 * br - cr, ui = eta0 * bi - ci;
      const double vr = eta0 * br + cr, vi = eta0 * bi + ci;
      const double inv_den = 1 / (vr * vr + vi * vi);
      *r = (ur * ur + ui * ui) * inv_den;
      *t = 4 * eta0 * eta_sub * inv_den;
    }
  };
  const double cs = std::sqrt(1 - inv2 / (ns * ns));
  constexpr size_t kChunk = 8;  // wavelengths carried through the layers together
  for (size_t w0 = 0; w0 < lambda_nm.size(); w0 += kChunk) {
    const size_t m = std::min(kChunk, lambda_nm.size() - w0);
    std::array<BC, kChunk> s, p;
    std::array<double, kChunk> k0;
    for (size_t w = 0; w < m; ++w) {
      s[w].cr = ns * cs, p[w].cr = ns / cs;
      k0[w] = 2 * std::numbers::pi / lambda_nm[w0 + w];
    }
    for (auto it = layers.rbegin(); it != layers.rend(); ++it) {
      const double n = it->n.real();
      const double c = std::sqrt(1 - inv2 / (n * n));
      const double phase = n * it->thickness_nm * c;  // delta = 2 pi phase / lambda
      const double eta_s = n * c, eta_p = n / c;
      const double inv_s = 1 / eta_s, inv_p = c / n;
      for (size_t w = 0; w < m; ++w) {
        const double delta = k0[w] * phase;
        const double cd = std::cos(delta), sd = std::sin(delta);
        s[w].apply(cd, sd, eta_s, inv_s);
        p[w].apply(cd, sd, eta_p, inv_p);
      }
    }
    for (size_t w = 0; w < m; ++w) {
      double rs, ts, rp, tp;
      s[w].rt(n0 * cos_0, ns * cs, &rs, &ts);
      p[w].rt(n0 / cos_0, ns / cs, &rp, &tp);
      out[w0 + w] = FilmRTA{0.5 * (rs + rp), 0.5 * (ts + tp), 0};
    }
  }
  return true;
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
  if (FilmRTA fast; losslessStackUnpolarised(n0, layers, ns, {&lambda_nm, 1}, cos_0, &fast))
    return fast;
  const FilmRTA s = stackOnePolarisation(n0, layers, ns, lambda_nm, cos_0, false);
  const FilmRTA p = stackOnePolarisation(n0, layers, ns, lambda_nm, cos_0, true);
  return FilmRTA{0.5 * (s.R + p.R), 0.5 * (s.T + p.T), 0.5 * (s.A + p.A)};
}

void thinFilmStackSpectral(double n0, std::span<const FilmLayer> layers, double ns,
                           std::span<const double> lambda_nm, double cos_0, FilmRTA* out) {
  cos_0 = std::clamp(cos_0, 1e-12, 1.0);
  if (losslessStackUnpolarised(n0, layers, ns, lambda_nm, cos_0, out)) return;
  for (size_t w = 0; w < lambda_nm.size(); ++w)
    out[w] = thinFilmStack(n0, layers, ns, lambda_nm[w], cos_0);
}

}  // namespace lensim::optics
