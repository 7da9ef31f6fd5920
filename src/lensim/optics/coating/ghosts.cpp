#include "lensim/optics/coating/ghosts.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "lensim/optics/lens_system.h"

namespace lensim::optics {

namespace {

// The paraxial marginal ray per unit entrance height along a path of events.
struct ParaxialPath {
  double y = 1, w = 0;  // height and n*u (signed index)
  double n = 1;         // signed index of the current medium
  double z = 0;         // z of the last surface met
  double clip = std::numeric_limits<double>::infinity();  // smallest semi-aperture / |y|

  void meet(const Interface& s, double n_after_signed) {
    y += (s.z_mm - z) * w / n;
    z = s.z_mm;
    if (std::abs(y) > 0) clip = std::min(clip, s.semi_aperture_mm / std::abs(y));
    w -= y * (n_after_signed - n) * s.paraxialCurvature();
    n = n_after_signed;
  }
};

}  // namespace

GhostAnalysis analyseGhosts(const LensSystem& lens, const LensCoatings& coatings,
                            std::span<const double> wavelengths_nm) {
  if (lens.mirrorCount() > 0)
    throw Error("ghost analysis: the lens has mirrors (ghosts of catadioptric lenses are not "
                "modelled)");
  const auto& s = lens.interfaces();
  const int n = lens.surfaceCount();
  GhostAnalysis out;
  out.wavelengths_nm.assign(wavelengths_nm.begin(), wavelengths_nm.end());

  // Per wavelength, each surface's forward and backward transmittance and its reflectance from
  // either side (normal incidence).
  const size_t nw = wavelengths_nm.size();
  std::vector<std::vector<double>> t_fwd(nw), t_bwd(nw), r_fwd(nw), r_bwd(nw);
  std::vector<double> nb(static_cast<size_t>(n)), na(static_cast<size_t>(n));
  for (size_t w = 0; w < nw; ++w) {
    lens.indicesAt(wavelengths_nm[w], nb.data(), na.data());
    for (int k = 0; k < n; ++k) {
      const FilmRTA f = coatings.rta(k, nb[size_t(k)], na[size_t(k)], wavelengths_nm[w], 1.0);
      const FilmRTA b = coatings.rta(k, na[size_t(k)], nb[size_t(k)], wavelengths_nm[w], 1.0);
      t_fwd[w].push_back(f.T);
      r_fwd[w].push_back(f.R);
      t_bwd[w].push_back(b.T);
      r_bwd[w].push_back(b.R);
    }
    out.direct_transmittance.push_back(axialTransmittance(lens, coatings, wavelengths_nm[w]));
  }

  // The direct beam's paraxial clipping (the entrance pupil radius when the stop limits it).
  ParaxialPath direct;
  for (int k = 0; k < n; ++k) direct.meet(s[size_t(k)], s[size_t(k)].nAfter());
  const double h_direct = direct.clip;

  for (int b = 1; b < n; ++b)
    for (int a = 0; a < b; ++a) {
      ParaxialPath p;
      for (int k = 0; k < b; ++k) p.meet(s[size_t(k)], s[size_t(k)].nAfter());
      p.meet(s[size_t(b)], -s[size_t(b)].nBefore());
      for (int k = b - 1; k > a; --k) p.meet(s[size_t(k)], -s[size_t(k)].nBefore());
      p.meet(s[size_t(a)], s[size_t(a)].nAfter());
      for (int k = a + 1; k < n; ++k) p.meet(s[size_t(k)], s[size_t(k)].nAfter());

      Ghost g;
      g.a = a, g.b = b;
      const double h = std::min(h_direct, p.clip);
      g.aperture_fraction = (h / h_direct) * (h / h_direct);
      double sum = 0;
      for (size_t w = 0; w < nw; ++w) {
        double e = r_fwd[w][size_t(b)] * r_bwd[w][size_t(a)];
        for (int k = 0; k < n; ++k) {
          // Passed forward once: before a, and from b on (b after the reflections).
          if (k < a || k >= b) e *= t_fwd[w][size_t(k)];
          if (k > a && k < b) e *= t_fwd[w][size_t(k)] * t_bwd[w][size_t(k)] * t_fwd[w][size_t(k)];
        }
        // Surface a is passed forward once, before the reflections.
        e *= t_fwd[w][size_t(a)];
        const double rel = out.direct_transmittance[w] > 0
                               ? e * g.aperture_fraction / out.direct_transmittance[w]
                               : 0.0;
        g.relative_intensity_per_wavelength.push_back(rel);
        sum += rel;
      }
      g.relative_intensity = nw ? sum / double(nw) : 0.0;
      // Image space: y(z) = y + (z - z_last) w / n per unit entrance height.
      const double film_z = lens.filmZ_mm();
      const double y_film = p.y + (film_z - p.z) * p.w / p.n;
      g.film_diameter_mm = 2 * std::abs(y_film) * h;
      if (std::abs(p.w) > 1e-15 * std::abs(p.y)) {
        g.focus_z_mm = p.z - p.y * p.n / p.w;
        g.defocus_mm = g.focus_z_mm - film_z;
      } else {
        g.focus_z_mm = g.defocus_mm = std::numeric_limits<double>::infinity();
      }
      out.ghosts.push_back(std::move(g));
    }
  std::stable_sort(out.ghosts.begin(), out.ghosts.end(), [](const Ghost& x, const Ghost& y) {
    return x.relative_intensity > y.relative_intensity;
  });
  return out;
}

}  // namespace lensim::optics
