#include "lensim/optics/paraxial.h"

#include "lensim/optics/real_aperture.h"

#include <fmt/format.h>

#include <cmath>
#include <limits>
#include <vector>

namespace lensim::optics {

namespace {

// How much more than the most limiting element the file's stop may limit the axial beam and
// still be the aperture stop (5% in f-number).
constexpr double kStopTolerance = 1.05;

// With mirrors the indices are signed (n -> -n after a reflection, Interface::nBefore/nAfter):
// a mirror's power is -2 n c, and t / n stays positive for the negative thicknesses after it.
RayMatrix refraction(const Interface& s) {
  double power = (s.nAfter() - s.nBefore()) * s.paraxialCurvature();
  return {1, 0, -power, 1};
}

RayMatrix transfer(double t_mm, double ior) {
  return {1, t_mm / ior, 0, 1};
}

}  // namespace

RayMatrix systemMatrix(const LensSystem& lens, int first, int last) {
  const auto& s = lens.interfaces();
  RayMatrix m;
  for (int i = first; i <= last; ++i) {
    if (i > first) m = transfer(s[i].z_mm - s[i - 1].z_mm, s[i].nBefore()) * m;
    m = refraction(s[i]) * m;
  }
  return m;
}

ParaxialData computeParaxial(const LensSystem& lens, bool real_rays) {
  const auto& s = lens.interfaces();
  const int n = lens.surfaceCount();
  // Image space unfolded after an odd number of mirrors (lens_system.h): its index counts as
  // positive, so that image-side z (focal point, exit pupil) lie at +z from the rear vertex.
  const double n_obj = lens.objectIor(), n_img = lens.imageIor();
  ParaxialData p;

  // Cardinal points from the whole-system matrix.
  const RayMatrix m = systemMatrix(lens, 0, n - 1);
  const double power = -m.c;
  if (std::abs(power) < 1e-12)
    throw Error(FileLoc{lens.prescription().path}, "the lens is afocal (zero optical power)");
  p.power_per_mm = power;
  p.effective_focal_length_mm = 1 / power;
  p.back_focal_length_mm = m.a * n_img / power;
  p.back_focal_point_z_mm = lens.rearVertexZ_mm() + p.back_focal_length_mm;
  p.front_focal_length_mm = n_obj * m.d / power;
  p.front_focal_point_z_mm = -p.front_focal_length_mm;
  p.principal_plane_back_z_mm = p.back_focal_point_z_mm - n_img / power;
  p.principal_plane_front_z_mm = p.front_focal_point_z_mm + n_obj / power;
  p.nodal_point_front_z_mm = p.principal_plane_front_z_mm + (n_img - n_obj) / power;
  p.nodal_point_back_z_mm = p.principal_plane_back_z_mm + (n_img - n_obj) / power;

  // The surface whose clear aperture limits the axial bundle from infinity most (ray entering at
  // height 1 parallel to the axis); the aperture stop when the file has no radius-0 row.
  double y = 1, w = 0;
  double best_ratio = std::numeric_limits<double>::infinity();
  for (int i = 0; i < n; ++i) {
    if (i > 0) y += (s[i].z_mm - s[i - 1].z_mm) * w / s[i].nBefore();
    if (std::abs(y) > 1e-300) {
      double ratio = s[i].semi_aperture_mm / std::abs(y);
      if (ratio < best_ratio) {
        best_ratio = ratio;
        p.paraxial_limit_surface = i;
      }
    }
    RayMatrix r = refraction(s[i]);
    w = r.c * y + w;
  }
  p.paraxial_limit_f_number = std::abs(p.effective_focal_length_mm) / (2 * best_ratio);
  // The aperture stop is decided with real rays: a paraxial trace extrapolates the first-order
  // beam to the rim and can name the wrong surface (the ISET Petzval's front element, while
  // real rays above 17.84 mm are stopped by its stop row). The file's stop is the aperture stop
  // when it (nearly) limits the real axial beam; an element that clips a few percent more is
  // reported (real_limit_surface), not promoted. A stop row that limits nothing (ISET's reversed
  // telephoto puts one at the image plane) is not the aperture stop: the limiting element is.
  if (!real_rays) {
    // First order only: the file's stop, else the surface that limits the paraxial beam.
    p.aperture_stop_surface = lens.stopIndex() ? *lens.stopIndex() : p.paraxial_limit_surface;
  } else {
    const RealAxialBeam real = realAxialBeam(lens, p.effective_focal_length_mm);
    p.real_limit_surface = real.limit_surface;
    p.real_marginal_height_mm = real.marginal_height_mm;
    p.real_f_number = real.f_number_entrance;
    p.real_image_space_f_number = real.f_number;
    p.aperture_stop_surface = real.limit_surface;
    if (lens.stopIndex()) {
      const double stop_h = real.surface_limit_height_mm[*lens.stopIndex()];
      if (stop_h <= kStopTolerance * real.marginal_height_mm)
        p.aperture_stop_surface = *lens.stopIndex();
    }
  }
  const int st = p.aperture_stop_surface;
  p.stop_is_file_stop = s[st].is_stop;
  p.aperture_stop_diameter_mm = 2 * s[st].semi_aperture_mm;

  // Entrance pupil: image of the stop through the surfaces in front of it. With M_f from object
  // space (at the front vertex) to just before the stop, an axial object point at z images to
  // the stop centre when B(M_f T(-z)) = 0, i.e. z = n B/A; the pupil's magnification is A.
  RayMatrix front;
  if (st > 0)
    front = transfer(s[st].z_mm - s[st - 1].z_mm, s[st].nBefore()) * systemMatrix(lens, 0, st - 1);
  p.entrance_pupil_z_mm = n_obj * front.b / front.a;
  p.entrance_pupil_diameter_mm = p.aperture_stop_diameter_mm / std::abs(front.a);

  // Exit pupil: image of the stop through the surfaces behind it (after the stop's own
  // refraction). With M_r = [A B; C D] to the rear vertex, z = z_rear - n' B / D and the
  // magnification is 1/D (det M_r = n/n' products give 1 in reduced coordinates).
  RayMatrix rear;
  if (st + 1 < n)
    rear = systemMatrix(lens, st + 1, n - 1) *
           transfer(s[st + 1].z_mm - s[st].z_mm, s[st + 1].nBefore());
  p.exit_pupil_z_mm = lens.rearVertexZ_mm() - n_img * rear.b / rear.d;
  p.exit_pupil_diameter_mm = p.aperture_stop_diameter_mm / std::abs(rear.d);

  p.f_number = std::abs(p.effective_focal_length_mm) / p.entrance_pupil_diameter_mm;
  return p;
}

double workingFNumber(const LensSystem& lens, const ParaxialData& p,
                      std::optional<double> object_z_mm) {
  // Marginal ray from the axial object point through the rim of the entrance pupil.
  double y, w;
  const double r_ep = p.entrance_pupil_diameter_mm / 2;
  if (!object_z_mm) {
    y = r_ep;
    w = 0;
  } else {
    const double dz = p.entrance_pupil_z_mm - *object_z_mm;
    const double u = r_ep / dz;
    y = u * (0 - *object_z_mm);
    w = lens.objectIor() * u;
  }
  const RayMatrix m = systemMatrix(lens, 0, lens.surfaceCount() - 1);
  const double w_out = m.c * y + m.d * w;
  return 1 / (2 * std::abs(w_out));
}

}  // namespace lensim::optics
