#include "lensim/optics/anamorphic.h"

namespace lensim::optics {

bool isRotationallySymmetric(const LensPrescription& p) {
  for (const LensSurface& s : p.surfaces)
    if (!s.shape.isRotational()) return false;
  return true;
}

LensPrescription xSection(const LensPrescription& p) {
  LensPrescription x = p;
  for (LensSurface& s : x.surfaces) {
    if (s.shape.isToroidal()) {
      // A toroid's x-z section is the circle of radius R (0: flat), with no conic or terms.
      if (!s.stop_flag) s.stop_flag = s.isStop();
      s.radius_mm = *s.shape.rotation_radius_mm;
      s.shape = SurfaceShape{};
      continue;
    }
    if (!s.shape.radius_x_mm) continue;
    if (!s.stop_flag) s.stop_flag = s.isStop();  // a flat x section must not become the stop
    s.radius_mm = *s.shape.radius_x_mm;
    s.shape.conic = s.shape.conic_x;
    s.shape.radius_x_mm.reset();
    s.shape.conic_x = 0;
  }
  return x;
}

LensPrescription ySection(const LensPrescription& p) {
  LensPrescription y = p;
  for (LensSurface& s : y.surfaces) {
    if (s.shape.isRotational()) continue;
    if (!s.stop_flag) s.stop_flag = s.isStop();
    // On x = 0 a biconic's and a toroid's sag is the rotational one of the same radius, conic
    // and terms (a toroid's terms are powers of y = r there).
    s.shape.radius_x_mm.reset();
    s.shape.conic_x = 0;
    s.shape.rotation_radius_mm.reset();
  }
  return y;
}

AnamorphicData anamorphicData(const LensSystem& lens) {
  AnamorphicData a;
  auto tryParaxial = [](const LensSystem& l) -> std::optional<ParaxialData> {
    try {
      return computeParaxial(l);
    } catch (const Error&) {
      return std::nullopt;  // afocal in this section
    }
  };
  LensSystemOptions opts;
  opts.film_distance_mm =
      lens.filmDistance_mm() > 0 ? std::optional(lens.filmDistance_mm()) : std::nullopt;
  if (lens.stopDiameter_mm()) opts.aperture_diameter_mm = lens.stopDiameter_mm();
  a.y = tryParaxial(lens);
  a.x = tryParaxial(LensSystem(xSection(lens.prescription()), opts));
  a.squeeze = a.x && a.y ? a.y->effective_focal_length_mm / a.x->effective_focal_length_mm : 0.0;
  return a;
}

}  // namespace lensim::optics
