#include "lensim/optics/configurations.h"

#include <fmt/format.h>

#include <cmath>

#include "lensim/optics/lens_system.h"
#include "lensim/optics/paraxial.h"

namespace lensim::optics {

int configurationCount(const LensPrescription& p) {
  return p.configurations.empty() ? 1 : int(p.configurations.size());
}

namespace {

void checkIndex(const LensPrescription& p, int n, const char* what) {
  const int count = configurationCount(p);
  if (n < 1 || n > count)
    throw Error(FileLoc{p.path},
                count == 1 ? fmt::format("{} {}: the lens has a single configuration (1)", what, n)
                           : fmt::format("{} {}: the lens has configurations 1 to {}", what, n,
                                         count));
}

double efl(const LensPrescription& p) {
  const LensSystem sys(p);
  return computeParaxial(sys).effective_focal_length_mm;
}

}  // namespace

LensPrescription selectConfiguration(const LensPrescription& p, int n) {
  checkIndex(p, n, "configuration");
  LensPrescription out = p;
  out.configurations.clear();
  out.active_configuration = 1;
  if (p.configurations.empty()) return out;
  const LensConfiguration& c = p.configurations[size_t(n - 1)];
  out.surfaces = c.surfaces;
  if (!c.aperture_spec.empty()) out.aperture_spec = c.aperture_spec;
  out.object_distance_mm = c.object_distance_mm;
  if (!c.wavelengths_nm.empty()) out.wavelengths_nm = c.wavelengths_nm;
  if (c.fields) out.fields = c.fields;
  if (p.configurations.size() > 1) out.name = fmt::format("{} (configuration {})", p.name, n);
  return out;
}

LensPrescription interpolateConfigurations(const LensPrescription& p, int a, int b, double t) {
  checkIndex(p, a, "configuration");
  checkIndex(p, b, "configuration");
  if (!(t >= 0 && t <= 1))
    throw Error(FileLoc{p.path}, fmt::format("zoom fraction {} is outside [0, 1]", t));
  LensPrescription out = selectConfiguration(p, a);
  if (p.configurations.empty() || a == b) return out;
  const auto& sa = p.configurations[size_t(a - 1)].surfaces;
  const auto& sb = p.configurations[size_t(b - 1)].surfaces;
  if (sa.size() != sb.size())
    throw Error(FileLoc{p.path}, fmt::format("configurations {} and {} have {} and {} surfaces; "
                                             "only configurations of the same lens interpolate",
                                             a, b, sa.size(), sb.size()));
  for (size_t i = 0; i < sa.size(); ++i) {
    const LensSurface &x = sa[i], &y = sb[i];
    const char* what = x.radius_mm != y.radius_mm               ? "radius"
                       : x.ior != y.ior || x.glass.name != y.glass.name ? "glass"
                       : x.isStop() != y.isStop()                ? "stop"
                       : x.mirror != y.mirror                    ? "mirror"
                                                                 : nullptr;
    if (!what && (x.shape.conic != y.shape.conic || x.shape.poly != y.shape.poly))
      what = "surface shape";
    if (what)
      throw Error(x.loc, fmt::format("surface {}: configurations {} and {} differ in its {}; a "
                                     "zoom between them interpolates thicknesses and clear "
                                     "apertures only",
                                     i, a, b, what));
    out.surfaces[i].thickness_mm = (1 - t) * x.thickness_mm + t * y.thickness_mm;
    out.surfaces[i].aperture_diameter_mm =
        (1 - t) * x.aperture_diameter_mm + t * y.aperture_diameter_mm;
  }
  // The file's design fields hold at its configurations only: kept where both agree.
  const auto& fa = p.configurations[size_t(a - 1)].fields;
  const auto& fb = p.configurations[size_t(b - 1)].fields;
  if (!fa || !fb || fa->kind != fb->kind || fa->xy != fb->xy) out.fields.reset();
  out.name = fmt::format("{} (configurations {}-{} at {:.4f})", p.name, a, b, t);
  return out;
}

double configurationEfl_mm(const LensPrescription& p, int n) {
  return efl(selectConfiguration(p, n));
}

ZoomSetting zoomToFocalLength(const LensPrescription& p, double efl_mm) {
  const int count = configurationCount(p);
  if (count < 2)
    throw Error(FileLoc{p.path}, fmt::format("focal length {} mm: the lens has a single "
                                             "configuration, no zoom data",
                                             efl_mm));
  if (!(std::isfinite(efl_mm) && efl_mm != 0))
    throw Error(FileLoc{p.path},
                fmt::format("focal length {} mm: expected a finite, non-zero value", efl_mm));
  std::vector<double> f(static_cast<size_t>(count));
  for (int n = 1; n <= count; ++n) f[size_t(n - 1)] = configurationEfl_mm(p, n);
  for (int n = 1; n < count; ++n) {
    const double lo = f[size_t(n - 1)], hi = f[size_t(n)];
    if ((efl_mm - lo) * (efl_mm - hi) > 0) continue;
    ZoomSetting z;
    z.config_a = n, z.config_b = n + 1;
    z.requested_efl_mm = efl_mm;
    // Bisection on t: the EFL is continuous in the spacings; the signs at the ends differ.
    double t0 = 0, t1 = 1, g0 = lo - efl_mm;
    double t = g0 == 0 ? 0 : 1;
    if (g0 != 0 && hi != efl_mm) {
      for (int it = 0; it < 200; ++it) {
        t = 0.5 * (t0 + t1);
        const double g = efl(interpolateConfigurations(p, n, n + 1, t)) - efl_mm;
        if (std::abs(g) <= 1e-9 * std::abs(efl_mm) || t1 - t0 < 1e-15) break;
        if ((g < 0) == (g0 < 0)) {
          t0 = t, g0 = g;
        } else {
          t1 = t;
        }
      }
    }
    z.t = t;
    z.prescription = interpolateConfigurations(p, n, n + 1, t);
    z.achieved_efl_mm = efl(z.prescription);
    return z;
  }
  double fmin = f[0], fmax = f[0];
  for (double v : f) fmin = std::min(fmin, v), fmax = std::max(fmax, v);
  throw Error(FileLoc{p.path},
              fmt::format("focal length {} mm is outside the zoom range: the {} configurations "
                          "span {:.6g} to {:.6g} mm",
                          efl_mm, count, fmin, fmax));
}

}  // namespace lensim::optics
