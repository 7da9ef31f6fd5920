#include "lensim/optics/file_fields.h"

#include <cmath>
#include <numbers>

namespace lensim::optics {

FileFieldSummary largestFileField(const FileFields& f, const ParaxialData& p,
                                  const std::optional<double>& object_distance_mm) {
  if (f.xy.empty()) throw Error(f.loc, "the file lists no fields");
  constexpr double kDeg = std::numbers::pi / 180;
  const bool angle = f.kind == FileFields::Kind::Angle;
  auto radial = [&](const std::pair<double, double>& xy) {
    return angle ? std::atan(std::hypot(std::tan(xy.first * kDeg), std::tan(xy.second * kDeg))) /
                       kDeg
                 : std::hypot(xy.first, xy.second);
  };
  FileFieldSummary s;
  for (size_t i = 0; i < f.xy.size(); ++i)
    if (const double r = radial(f.xy[i]); i == 0 || r > s.value) s.value = r, s.field = int(i + 1);
  static constexpr const char* kKinds[] = {"angle", "object height", "paraxial image height",
                                           "real image height"};
  s.kind = kKinds[int(f.kind)];
  s.unit = angle ? "deg" : "mm";
  const double efl = p.effective_focal_length_mm;
  switch (f.kind) {
    case FileFields::Kind::ParaxialImageHeight:
      s.paraxial_image_height_mm = s.value;
      break;
    case FileFields::Kind::RealImageHeight:
      break;
    case FileFields::Kind::Angle:
    case FileFields::Kind::ObjectHeight: {
      if (!object_distance_mm) {
        if (angle) s.paraxial_image_height_mm = std::abs(efl * std::tan(s.value * kDeg));
        break;
      }
      // Object at z = -d (front vertex at 0); Gaussian imaging from the principal planes.
      const double z_object = -*object_distance_mm;
      const double h = angle ? (p.entrance_pupil_z_mm - z_object) * std::tan(s.value * kDeg)
                             : s.value;
      const double s_o = p.principal_plane_front_z_mm - z_object;
      const double s_i = 1 / (1 / efl - 1 / s_o);
      if (std::isfinite(s_i)) s.paraxial_image_height_mm = std::abs(s_i / s_o * h);
      break;
    }
  }
  return s;
}

}  // namespace lensim::optics
