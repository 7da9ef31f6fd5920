// The Zemax .zmx writer (lens_formats.h): sequential surfaces in millimetres, and for a lens with
// tilted or decentred surfaces the coordinate breaks that place each surface where its frame is.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include "lensim/optics/frame.h"
#include "lensim/optics/lens_formats.h"

namespace lensim::optics {

namespace {

using frame::M3;  // rows; columns are a frame's axes
using frame::V3;

std::string num(double v) {
  return fmt::format("{:.17g}", v);
}

Error unwritable(const LensSurface& s, size_t row, const std::string& what) {
  return Error(s.loc, fmt::format("surface {} cannot be written to .zmx: {}", row, what));
}

// The lines of one real surface (after its SURF line), thickness `disz` (lens units: mm).
std::string surfaceLines(const LensSurface& s, size_t row, double disz) {
  if (!s.shape.isRotational())
    throw unwritable(s, row, "the writer writes rotationally symmetric surfaces only");
  if (s.aperture_shape != ApertureShape::Circle)
    throw unwritable(s, row, "the writer writes circular apertures only");
  bool odd = false;
  for (size_t k = 1; k < s.shape.poly.size(); ++k)
    odd = odd || (k % 2 == 1 && s.shape.poly[k] != 0);
  if (odd) throw unwritable(s, row, "odd aspheric terms (the writer writes EVENASPH)");
  if (s.shape.poly.size() > 17)
    throw unwritable(s, row, "aspheric terms beyond r^16 (EVENASPH has 8)");
  if (s.grating && s.shape.hasPolynomial())
    throw unwritable(s, row, "a grating on an aspheric surface (DGRATING is a sphere or conic)");
  std::string o = fmt::format("  TYPE {}\n", s.grating                 ? "DGRATING"
                                             : s.shape.hasPolynomial() ? "EVENASPH"
                                                                       : "STANDARD");
  o += fmt::format("  CURV {}\n", s.radius_mm == 0 ? "0" : num(1 / s.radius_mm));
  if (s.shape.conic != 0) o += fmt::format("  CONI {}\n", num(s.shape.conic));
  if (s.grating)
    o += fmt::format("  PARM 1 {}\n  PARM 2 {}\n", num(s.grating->lines_per_um), s.grating->order);
  for (size_t k = 2; k < s.shape.poly.size(); k += 2)
    if (s.shape.poly[k] != 0) o += fmt::format("  PARM {} {}\n", k / 2, num(s.shape.poly[k]));
  if (s.isStop()) o += "  STOP\n";
  if (s.mirror) {
    o += "  GLAS MIRROR\n";
  } else if (!s.glass.empty() || s.glass.n_d) {
    if (!s.glass.name.empty()) {
      o += fmt::format("  GLAS {} 0 0 {} {} 0 0 0 0 0 0\n", s.glass.name,
                       num(s.glass.n_d.value_or(s.ior)), num(s.glass.v_d.value_or(0)));
    } else {
      if (!s.glass.v_d || !(*s.glass.v_d > 0))
        throw unwritable(s, row, "a model glass needs V_d > 0");
      o += fmt::format("  GLAS ___BLANK 1 0 {} {} 0 0 0 0 0 0\n", num(*s.glass.n_d),
                       num(*s.glass.v_d));
    }
  } else if (s.ior != 1 && s.ior != 0) {
    throw unwritable(s, row,
                     fmt::format("the medium after it has index {} and no dispersion, "
                                 "which a .zmx file cannot state (a model glass needs "
                                 "V_d > 0); give it a glass or n_d and V_d",
                                 s.ior));
  }
  if (!s.coating.empty()) o += fmt::format("  COAT {}\n", s.coating);
  o += fmt::format("  DISZ {}\n", num(disz));
  o += fmt::format("  DIAM {} 1 0 0 1 \"\"\n", num(s.semiAperture_mm()));
  if (s.obscuration_radius_mm > 0)
    o += fmt::format("  OBSC 0 {} 0\n", num(s.obscuration_radius_mm));
  if (s.apertureDecentred())  // OBDC decentres an explicit aperture
    o += fmt::format("  CLAP 0 {} 0\n  OBDC {} {}\n", num(s.semiAperture_mm()), num(s.aperture_decentre_mm[0]),
                     num(s.aperture_decentre_mm[1]));
  return o;
}

// A coordinate break taking frame a to frame b, given a's thickness already brings the origin
// to b's plane along a's z: decentre (x, y) in a's axes, then tilts about x, the new y, the new z
// (order 0), as coordinate_break.cpp reads them. Empty when b is a's frame moved along its z.
std::string breakLines(const SurfaceFrame& a, const SurfaceFrame& b) {
  const M3 ra_t = frame::transpose(a.rotation);
  const V3 d{b.origin_mm[0] - a.origin_mm[0], b.origin_mm[1] - a.origin_mm[1],
             b.origin_mm[2] - a.origin_mm[2]};
  const V3 local = frame::mul(ra_t, d);
  const M3 rel = frame::mul(ra_t, b.rotation);
  // rel = Rx(tx) Ry(ty) Rz(tz): rel[0][2] = sin ty, rel[1][2] = -sin tx cos ty,
  // rel[2][2] = cos tx cos ty, rel[0][1] = -cos ty sin tz, rel[0][0] = cos ty cos tz.
  const double deg = 180 / std::numbers::pi;
  const double ty = std::asin(std::clamp(rel[0][2], -1.0, 1.0)) * deg;
  const double tx = std::atan2(-rel[1][2], rel[2][2]) * deg;
  const double tz = std::atan2(-rel[0][1], rel[0][0]) * deg;
  const double eps = 1e-13;
  if (std::abs(local[0]) < eps && std::abs(local[1]) < eps && std::abs(tx) < eps &&
      std::abs(ty) < eps && std::abs(tz) < eps)
    return {};
  return fmt::format(
      "  TYPE COORDBRK\n  CURV 0\n  PARM 1 {}\n  PARM 2 {}\n  PARM 3 {}\n"
      "  PARM 4 {}\n  PARM 5 {}\n  PARM 6 0\n  DISZ 0\n",
      num(local[0]), num(local[1]), num(tx), num(ty), num(tz));
}

// The distance along a's z from a's vertex to b's plane through b's origin, as a thickness.
double axialGap(const SurfaceFrame& a, const SurfaceFrame& b) {
  double z = 0;
  for (int k = 0; k < 3; ++k)
    z += a.rotation[size_t(k)][2] * (b.origin_mm[size_t(k)] - a.origin_mm[size_t(k)]);
  return z;
}

}  // namespace

std::string writeLensZmx(const LensPrescription& p) {
  if (p.fold_loc)
    throw Error(*p.fold_loc,
                "a lens folded by mirrors is written as its coaxial twin only by "
                ".json; the .zmx writer does not write folds");
  if (!p.configurations.empty())
    throw Error("a multi-configuration lens cannot be written to .zmx by lensim");
  if (!p.focus_group.empty())
    throw Error("a lens with a focus group cannot be written to .zmx (write .json)");
  if (p.floating_focus)
    throw Error(p.floating_focus->loc, "a lens with floating focus cannot be written to .zmx");
  if (!p.default_coating.empty() || !p.coating_file.empty())
    throw Error(p.default_coating_loc.valid() ? p.default_coating_loc : p.coating_file_loc,
                "a lens-wide coating or coating file cannot be written to .zmx (write .json)");
  std::string o = "VERS 190513 80 123457 L123457\nMODE SEQ\n";
  o += fmt::format("NAME {}\n", p.name);
  o += "UNIT MM X W X CM MR CPMM\nFLOA\n";
  for (size_t i = 0; i < p.wavelengths_nm.size(); ++i) {
    o += fmt::format("WAVM {} {} 1\n", i + 1, num(p.wavelengths_nm[i] / 1000));
    if (p.primary_wavelength_nm && *p.primary_wavelength_nm == p.wavelengths_nm[i])
      o += fmt::format("PWAV {}\n", i + 1);
  }
  o += fmt::format("SURF 0\n  TYPE STANDARD\n  CURV 0\n  DISZ {}\n",
                   p.object_distance_mm ? num(*p.object_distance_mm) : "INFINITY");
  const bool placed = p.noncoaxial_loc.has_value();
  int number = 1;
  SurfaceFrame prev;  // the frame after the object: the placed lens's global frame
  for (size_t i = 0; i < p.surfaces.size(); ++i) {
    const LensSurface& s = p.surfaces[i];
    if (placed && !s.frame) throw unwritable(s, i, "a surface of a non-coaxial lens has no frame");
    double disz = s.thickness_mm;
    if (placed) {
      if (i == 0 && std::abs(s.frame->origin_mm[2]) > 1e-12)
        throw unwritable(s, i, "the front surface is moved along the axis");
      const std::string cb = breakLines(prev, *s.frame);
      if (!cb.empty()) o += fmt::format("SURF {}\n{}", number++, cb);
      const SurfaceFrame& next =
          i + 1 < p.surfaces.size() ? *p.surfaces[i + 1].frame : p.image_frame;
      disz = axialGap(*s.frame, next);
      prev = *s.frame;
      for (int k = 0; k < 3; ++k) prev.origin_mm[size_t(k)] += disz * prev.rotation[size_t(k)][2];
    }
    o += fmt::format("SURF {}\n{}", number++, surfaceLines(s, i, disz));
  }
  if (placed) {
    const std::string cb = breakLines(prev, p.image_frame);
    if (!cb.empty()) o += fmt::format("SURF {}\n{}", number++, cb);
  }
  o += fmt::format("SURF {}\n  TYPE STANDARD\n  CURV 0\n  DISZ 0\n", number);
  return o;
}

}  // namespace lensim::optics
