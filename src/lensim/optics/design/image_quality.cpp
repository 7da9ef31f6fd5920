#include "lensim/optics/design/image_quality.h"

#include <fmt/format.h>

#include <cmath>
#include <complex>
#include <numbers>

#include "lensim/optics/chief_ray.h"
#include "lensim/optics/paraxial.h"
#include "lensim/optics/wavefront.h"
#include "lensim/util/error.h"

namespace lensim::optics::design {

void floatApertures(LensPrescription& p) {
  for (LensSurface& s : p.surfaces) {
    if (s.isStop()) continue;
    const double extent = sagDomainRadius(s.radius_mm, s.shape);
    s.aperture_diameter_mm = std::min(2 * 0.999 * extent, 2 * s.aperture_diameter_mm);
  }
}

FocusedLens evaluationLens(LensPrescription p) {
  floatApertures(p);
  LensSetup setup;
  if (!(p.fileFilmDistance_mm() > 0))
    throw Error(fmt::format("the film distance (last thickness) {} mm must be > 0",
                            p.fileFilmDistance_mm()));
  setup.film_distance_mm = p.fileFilmDistance_mm();
  return focusLens(std::move(p), setup);
}

FieldBundle::PupilRegion passingPupil(double radius_mm, const std::function<bool(Vec2)>& passes,
                                      double field_deg, int directions) {
  FieldBundle::PupilRegion region;
  region.centre = {0, 0};
  if (!passes({0, 0}))
    throw Error(fmt::format("the chief ray of the {} deg beam does not reach the film", field_deg));
  // The rim along every azimuth: where all of it passes, the disc (as four equal radii: the
  // quadrature of the plain circle, bit for bit).
  std::vector<Vec2> dirs;
  bool lost = false;
  for (int j = 0; j < directions; ++j) {
    const double a = 2 * std::numbers::pi * j / directions;
    dirs.push_back({std::cos(a), std::sin(a)});
    lost = lost || !passes(dirs.back() * radius_mm);
  }
  if (!lost) {
    region.radius.assign(4, radius_mm);
    return region;
  }
  constexpr int kScan = 16;
  for (const Vec2 u : dirs) {
    // Outward from the chief ray: the first lost of 16 points out to the rim, then bisection.
    double lo = 0, hi = radius_mm;
    bool clear = true;
    for (int k = 1; k <= kScan && clear; ++k) {
      const double r = radius_mm * k / kScan;
      if (passes(u * r))
        lo = r;
      else
        hi = r, clear = false;
    }
    if (clear) {
      region.radius.push_back(radius_mm);
      continue;
    }
    while (hi - lo > 1e-12 * radius_mm) {
      const double mid = 0.5 * (lo + hi);
      (passes(u * mid) ? lo : hi) = mid;
    }
    region.radius.push_back(lo);
  }
  return region;
}

FieldBundle fieldBundle(const LensSystem& primary, const ParaxialData& pp, double field_deg) {
  auto chief = chiefRayFromScene(primary, pp, field_deg);
  if (!chief) throw Error(fmt::format("no real chief ray at {} deg", field_deg));
  Vec3 d = normalize(chief->scene_ray.direction);
  if (d.z < 0) d = -d;
  const Ray& c = chief->scene_ray;
  const double t_ep = (pp.entrance_pupil_z_mm - c.origin.z) / c.direction.z;
  FieldBundle b;
  b.field_angle_deg = field_deg;
  b.pupil_centre = c.origin + c.direction * t_ep;
  b.chief_scene = {b.pupil_centre, d};
  b.pupil_radius_mm = pp.entrance_pupil_diameter_mm / 2;
  return b;
}

namespace {

struct Beam {
  FocusedLens fl;
  LensSystem primary;
  FieldBundle bundle;
  Vec2 image_point;
};

Beam beamOf(const LensPrescription& p, double field_deg, double primary_nm) {
  FocusedLens fl = evaluationLens(p);
  LensSystem prim = fl.lens->atWavelength(primary_nm);
  const ParaxialData pp = computeParaxial(prim);
  FieldBundle b = fieldBundle(prim, pp, field_deg);
  auto ip = chiefImagePoint(prim, b, prim.filmZ_mm());
  if (!ip) throw Error(fmt::format("the chief ray at {} deg does not reach the film", field_deg));
  return {std::move(fl), std::move(prim), std::move(b), *ip};
}

// RMS of W over the passing cells after a weighted least-squares fit of a + b alpha + c beta.
double rmsAboutBestPlane(const PupilFunction& pf) {
  // Normal equations of the 3-parameter fit, coordinates relative to the grid centre.
  double m[3][3] = {}, v[3] = {}, sw = 0, sww = 0;
  for (int iy = 0; iy < pf.n; ++iy)
    for (int ix = 0; ix < pf.n; ++ix) {
      const size_t k = static_cast<size_t>(iy) * pf.n + ix;
      const double a = pf.amplitude[k];
      if (!(a > 0)) continue;
      const double f[3] = {1, (ix - 0.5 * (pf.n - 1)) * pf.step, (iy - 0.5 * (pf.n - 1)) * pf.step};
      const double w = pf.opd_waves[k];
      for (int r = 0; r < 3; ++r) {
        v[r] += a * f[r] * w;
        for (int c = 0; c < 3; ++c) m[r][c] += a * f[r] * f[c];
      }
      sw += a, sww += a * w * w;
    }
  if (!(sw > 0)) throw Error("no ray of the beam gets through");
  // Solve m x = v by Cramer's rule (3 x 3, well conditioned for a disc-like pupil).
  auto det = [](const double a[3][3]) {
    return a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
           a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
           a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
  };
  const double d = det(m);
  if (!(std::abs(d) > 0)) throw Error("the beam's pupil is degenerate");
  double x[3];
  for (int c = 0; c < 3; ++c) {
    double mc[3][3];
    for (int r = 0; r < 3; ++r)
      for (int q = 0; q < 3; ++q) mc[r][q] = q == c ? v[r] : m[r][q];
    x[c] = det(mc) / d;
  }
  // Residual sum of squares of a least-squares fit: sum a w^2 - x . v.
  const double rss = sww - (x[0] * v[0] + x[1] * v[1] + x[2] * v[2]);
  return std::sqrt(std::max(0.0, rss / sw));
}

}  // namespace

double rmsWavefront_waves(const LensPrescription& p, double field_deg, double lambda_nm,
                          double primary_nm) {
  const Beam beam = beamOf(p, field_deg, primary_nm);
  const LensSystem lens = beam.fl.lens->atWavelength(lambda_nm);
  auto pf = computePupilFunction(lens, beam.bundle, beam.primary.filmZ_mm(), beam.image_point,
                                 lambda_nm, 64);
  if (!pf) throw Error(fmt::format("no ray of the {} deg beam gets through", field_deg));
  return rmsAboutBestPlane(*pf);
}

double mtfAt(const LensPrescription& p, double field_deg, const std::vector<double>& lambdas_nm,
             double primary_nm, double frequency, bool sagittal) {
  const Beam beam = beamOf(p, field_deg, primary_nm);
  std::complex<double> otf = 0;
  for (double nm : lambdas_nm) {
    const LensSystem lens = beam.fl.lens->atWavelength(nm);
    auto pf = computePupilFunction(lens, beam.bundle, beam.primary.filmZ_mm(), beam.image_point, nm,
                                   0, 0.25, 512, 128);
    if (!pf) throw Error(fmt::format("no ray of the {} deg beam gets through", field_deg));
    otf += fourierOptics(*pf).otfAlongAxis(frequency, sagittal);
  }
  return std::abs(otf) / static_cast<double>(lambdas_nm.size());
}

}  // namespace lensim::optics::design
