// Reflection and transmission at an interface and through a thin-film stack.
//
// Interfaces: Fresnel's equations for s and p polarisation; lensim's light is unpolarised, so
// the reflectance is the average of the two. Beyond the critical angle the interface reflects
// totally (R = 1, T = 0).
// Stacks: the characteristic (transfer) matrix method (Macleod, "Thin-Film Optical Filters",
// ch. 2): each layer of complex index N = n - ik and physical thickness d has the matrix
//   [[cos d_j, i sin d_j / eta_j], [i eta_j sin d_j, cos d_j]],  d_j = 2 pi N_j d_j cos t_j / lambda,
// with the tilted admittances eta_s = N cos t and eta_p = N / cos t; the stack's product acting on
// (1, eta_substrate) gives (B, C), and
//   R = |(eta0 B - C) / (eta0 B + C)|^2,  T = 4 eta0 Re(eta_sub) / |eta0 B + C|^2,
//   A = 4 eta0 Re(B C* - eta_sub) / |eta0 B + C|^2,  R + T + A = 1.
// The incident medium and the substrate are lossless (air and glass); layers may absorb.
// Unpolarised stacks of lossless layers in which the light propagates (every layer and the
// substrate below the critical angle: every lens coating short of total internal reflection) are
// evaluated in real arithmetic, s and p together; absorbing layers, evanescent waves and single
// polarisations take the complex path. Both are the same formulas (tests/coating_test.cpp).
#pragma once

#include <complex>
#include <span>

namespace lensim::optics {

using ComplexIndex = std::complex<double>;  ///< n - i k (k >= 0 absorbs)

/// Reflectance, transmittance and absorptance (fractions of the incident power).
struct FilmRTA {
  double R = 0, T = 1, A = 0;
};

/// One layer at a given wavelength: complex index and physical thickness (nm).
struct FilmLayer {
  ComplexIndex n{1.0, 0.0};
  double thickness_nm = 0;
};

/// Unpolarised Fresnel reflectance and transmittance of a bare interface from index n1 into n2
/// for light meeting it at cos(theta_i) = cos_i (0 < cos_i <= 1); total internal reflection
/// gives R = 1.
FilmRTA fresnelDielectric(double n1, double n2, double cos_i);
/// The s and p reflectances separately (R_s, R_p).
void fresnelDielectricSP(double n1, double n2, double cos_i, double* rs, double* rp);

/// The stack's R, T, A for light from the lossless medium n0 at cos(theta_0) = cos_0 through
/// `layers` (the first one met first) onto the lossless substrate ns. `polarisation`: 's', 'p',
/// or 'u' (unpolarised: the average of s and p). No layers: the bare interface.
FilmRTA thinFilmStack(double n0, std::span<const FilmLayer> layers, double ns, double lambda_nm,
                      double cos_0, char polarisation = 'u');

/// thinFilmStack(n0, layers, ns, lambda_nm[w], cos_0) (unpolarised) into out[w] for every
/// wavelength, for layers whose indices are the same at all of them (non-dispersive coating
/// materials): the angle's part of the computation is shared.
void thinFilmStackSpectral(double n0, std::span<const FilmLayer> layers, double ns,
                           std::span<const double> lambda_nm, double cos_0, FilmRTA* out);

}  // namespace lensim::optics
