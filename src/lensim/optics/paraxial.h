// First-order (paraxial) optics of a LensSystem: cardinal points, pupils, f-numbers.
//
// Computed with 2x2 ray-transfer matrices on the reduced state (y, n*u): refraction at a surface
// of curvature c between indices n and n' is [1 0; -(n'-n)c 1], transfer over a distance t in a
// medium of index n is [1 t/n; 0 1]. All z values are in lens space (mm, front vertex at 0, +z
// toward the film).
#pragma once

#include <optional>

#include "lensim/optics/lens_system.h"

namespace lensim::optics {

/// A 2x2 ray-transfer matrix acting on (y, n*u).
struct RayMatrix {
  double a = 1, b = 0, c = 0, d = 1;
  RayMatrix operator*(const RayMatrix& o) const {
    return {a * o.a + b * o.c, a * o.b + b * o.d, c * o.a + d * o.c, c * o.b + d * o.d};
  }
};

/// Matrix of the system from just before surface `first` to just after surface `last`
/// (inclusive), including the transfers between their vertices.
RayMatrix systemMatrix(const LensSystem& lens, int first, int last);

/// Paraxial (first-order) data of a lens system. Lengths in mm, z in lens space.
struct ParaxialData {
  double power_per_mm = 0;               ///< system power 1/EFL
  double effective_focal_length_mm = 0;  ///< EFL = 1/power (object and image space in air)
  double back_focal_length_mm = 0;       ///< rear vertex to rear focal point (+ toward the film)
  double front_focal_length_mm = 0;      ///< front focal point to front vertex (+: F in front)
  double front_focal_point_z_mm = 0;
  double back_focal_point_z_mm = 0;
  double principal_plane_front_z_mm = 0;
  double principal_plane_back_z_mm = 0;
  double nodal_point_front_z_mm = 0;
  double nodal_point_back_z_mm = 0;

  /// The aperture stop, decided with real rays (real_aperture.h): the file's radius-0 row when
  /// it limits the real axial beam from infinity to within 5% of the surface that stops the real
  /// marginal ray (an element clipping slightly more is reported in real_limit_surface), else
  /// that surface (also when the file has no stop, or its stop row limits nothing, as an
  /// image-plane marker). Pupils are paraxial images of it.
  int aperture_stop_surface = -1;
  bool stop_is_file_stop = false;  ///< the stop is the file's radius-0 row
  double aperture_stop_diameter_mm = 0;
  /// The surface that limits the paraxial axial bundle from infinity most (all clear apertures
  /// considered), and the f-number it gives. Differs from the stop when an element's clear
  /// aperture clips the axial beam before the stop does.
  int paraxial_limit_surface = -1;
  double paraxial_limit_f_number = 0;
  double entrance_pupil_z_mm = 0;
  double entrance_pupil_diameter_mm = 0;
  double exit_pupil_z_mm = 0;
  double exit_pupil_diameter_mm = 0;
  double f_number = 0;  ///< at infinity: EFL / entrance pupil diameter
  /// The real on-axis beam from infinity (real_aperture.h): the surface that stops the real
  /// marginal ray, its entrance height h, the real f-number EFL / (2 h), and the image-space
  /// f-number 1 / (2 n' sin u') of that ray.
  int real_limit_surface = -1;
  double real_marginal_height_mm = 0;
  double real_f_number = 0;
  double real_image_space_f_number = 0;
};

/// Computes the paraxial data. Throws lensim::Error for an afocal system, and when no real ray
/// parallel to the axis gets through. real_rays false: first-order data only (the stop is the
/// file's stop row, else paraxial_limit_surface; the real_* fields stay unset), for reporting
/// a lens no real ray passes.
ParaxialData computeParaxial(const LensSystem& lens, bool real_rays = true);

/// Paraxial working f-number 1/(2 n' |u'|) of the marginal ray from an axial object at
/// `object_z_mm` (lens space; use nullopt for infinity).
double workingFNumber(const LensSystem& lens, const ParaxialData& p,
                      std::optional<double> object_z_mm);

}  // namespace lensim::optics
