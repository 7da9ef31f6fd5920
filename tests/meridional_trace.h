// An exact meridional ray trace through spherical surfaces, written for the design tests as an
// independent check of lensim's tracer (nothing of lensim's optics is used).
#pragma once

#include <cmath>
#include <vector>

namespace lensim::test {

struct MeridionalRow {
  double radius = 0;     ///< mm; 0: flat
  double thickness = 0;  ///< mm to the next row (the last: to the film)
  double n_after = 1;    ///< index after the row; 0: unchanged (a stop row)
};

/// Film height (mm) of the ray that starts 1 mm in front of the first vertex at height `y0`
/// with angle `angle_rad` to the axis (towards +y); NaN when it misses a surface or is totally
/// reflected.
inline double meridionalFilmHeight(const std::vector<MeridionalRow>& rows, double y0,
                                   double angle_rad) {
  double ry = y0, rz = -1, dy = std::sin(angle_rad), dz = std::cos(angle_rad), ni = 1, zv = 0;
  for (const MeridionalRow& s : rows) {
    const double n2 = s.n_after == 0 ? ni : s.n_after;
    double ny = 0, nz = 1;  // unit normal, along +z at the vertex
    if (s.radius == 0) {
      const double t = (zv - rz) / dz;
      ry += t * dy;
      rz += t * dz;
    } else {
      const double cz = zv + s.radius;  // centre of curvature
      const double oz = rz - cz, b = ry * dy + oz * dz, c = ry * ry + oz * oz - s.radius * s.radius;
      const double disc = b * b - c;
      if (disc < 0) return std::nan("");
      // The intersection on the vertex's side of the sphere.
      const double t = s.radius > 0 ? -b - std::sqrt(disc) : -b + std::sqrt(disc);
      ry += t * dy;
      rz += t * dz;
      ny = -ry / s.radius;
      nz = -(rz - cz) / s.radius;
    }
    // Vector refraction with the normal along the propagation: d' = mu d + (cos_t - mu cos_i) n.
    const double mu = ni / n2, ci = dy * ny + dz * nz;
    const double k = 1 - mu * mu * (1 - ci * ci);
    if (k < 0) return std::nan("");
    const double g = std::sqrt(k) - mu * ci;
    dy = mu * dy + g * ny;
    dz = mu * dz + g * nz;
    ni = n2;
    zv += s.thickness;
  }
  // zv is now the film's z.
  return ry + (zv - rz) / dz * dy;
}

}  // namespace lensim::test
