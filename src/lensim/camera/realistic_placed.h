// The realistic camera through a lens with tilted or decentred surfaces (Zemax coordinate
// breaks, LensPrescription::noncoaxial_loc; issue 28). No axis holds such a lens, so nothing of
// the coaxial camera's machinery applies (paraxial focus, exit-pupil bounds, the float tracers):
// every camera ray is traced backward with the exact double tracer (optics/placed_lens.h).
//
// Geometry. The film lies in the image surface's plane (the lens file's image surface), moved
// along that surface's own z axis by the focus solve below; film points are (x, y) of the image
// surface's own frame. Camera space is the front surface's frame turned as pbrt's is: (x, y, z)
// mm -> (x, y, -z) x camera units per mm, so the camera's origin is the front vertex and it
// looks down +z along the object space's axis (a LookAt aims the lens's object-side axis). A
// raster point at the right of the image lies at -x of the film frame, as for the coaxial camera.
//
// Sampling: each film point p aims at a disc on the plane of the rear surface's own frame that
// touches the surface's extreme toward the film (z_near; z_far the other extreme over the clear
// aperture a). Every ray from p that reaches the
// rear surface's clear aperture crosses that plane within radius max(a, (1 - t_min)|p_xy| +
// t_min a) of the rear surface's axis, t_min = (p_z - z_near) / (p_z - z_far) (all in the rear
// surface's frame): the disc is a superset of what can carry light, so the estimate is unbiased
// (the tracer stops the rest). The weight is the film irradiance integrand over that plane,
//   w = T cos_film cos_plane / r^2 x pi R^2,
// cos_film against the film's normal, cos_plane against the rear surface's axis, r the distance
// from the film point to the disc point, R the disc's radius, T the aperture shape's
// transmission and the glasses' internal transmittance: the coaxial camera's cos^4 A / z^2
// when both planes face each other along one axis.
//
// Exit-pupil bounds (camera/placed_pupil.h): most of the disc carries no light (the beam fills
// a small part of it, moved with the film point), so at start-up the film is cut into 2-D bins
// and each film point gets a convex polygon (an octagon at most, cut from the disc's square) of
// that plane holding every passing ray from it, blended from its bin's (or the bin's quarter's)
// corners, whose grids were traced at start-up. A film point samples its polygon uniformly when
// smaller than the disc, with the polygon's area in place of pi R^2.
//
// Focus: `focusdistance` (metres; infinity allowed) is honoured by moving the film along the
// image surface's axis to where the real rays from that object point, through an equal-area
// grid over the stop (72 rays), have the smallest RMS spot (the spot's second moment is
// quadratic in the move: solved in closed form). Where the object space's axis and the image
// surface's axis are parallel (decentred or tilted elements, no net fold) the object lies on the
// film's axis at focusdistance from the film centre (docs/conventions.md); the film's place
// depends on the focus, so the move is found by fixed-point iteration to 1e-9 mm (refused if it
// does not converge in 200 steps). A folded lens measures it from the front vertex along the
// object axis.
//
// Not supported, refused when the scene asks for them: the pbrt-v1/v2 camera conventions,
// filmdistance, lenstilt/lensshift, flare, zoom configurations, as-built lenses, simpleweighting;
// camera importance (so the light tracer and bdpt refuse the camera at its line).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "lensim/camera/placed_pupil.h"
#include "lensim/camera/realistic.h"
#include "lensim/optics/placed_lens.h"

namespace lensim::camera {

/// Why the realistic cameras refuse a lens with a diffraction grating.
inline const char* gratingCameraRefusal() {
  return "the realistic cameras do not render through diffraction gratings (a grating sends "
         "each wavelength into its own direction, and its other orders are not modelled); "
         "`lensim lens info` traces real rays through the lens";
}

class PlacedRealisticCamera final : public Camera {
 public:
  /// The camera for `prescription` (non-coaxial) with `settings` (as makeRealisticCamera fills
  /// them). Throws lensim::Error for settings it does not support or a lens no ray passes.
  /// pupil_bounds false: every film point samples its whole disc (to compare: tests, bench).
  PlacedRealisticCamera(RealisticSettings settings, optics::LensPrescription prescription,
                        bool pupil_bounds = true);

  std::optional<CameraRay> generateRay(const CameraSample& sample) const override;
  double startupSeconds() const override { return startup_seconds_; }
  /// The start-up's time on one core: the exit-pupil bounds' traces are built side by side.
  double startupCpuSeconds() const override { return startup_cpu_seconds_; }
  std::string describe() const override;

  /// The lens at its primary wavelength, with the stop set to the aperture.
  const optics::PlacedLens& lens() const { return lens_; }
  /// How far the focus solve moved the film from the image surface, along its z axis (mm).
  double filmOffset_mm() const { return film_offset_mm_; }
  /// The film point (the image surface's own frame, mm) of a raster position.
  Vec2 filmPoint(Vec2 raster) const;
  /// What a film point (the image surface's frame, mm) samples on the plane z = samplingPlaneZ
  /// of the rear surface's frame: the disc of disc_radius about its axis, or the polygon when
  /// given.
  using SamplingRegion = PupilRegion;
  SamplingRegion samplingRegion(Vec2 film) const;
  double samplingPlaneZ_mm() const { return z_near_; }
  /// The exit-pupil bounds (empty without them).
  const PlacedPupilBounds& pupilBounds() const { return bounds_; }

 private:
  /// The film point (image frame, z = the film offset) in the front surface's frame.
  Vec3 filmToLens(Vec2 film) const;
  /// The radius of the disc a film point (lens coordinates) samples; its plane is z_near_ in
  /// the rear surface's frame, its centre the rear aperture's (rear_centre_).
  double discRadius(const Vec3& film_lens) const;
  /// The point q of the sampling plane in lens coordinates.
  Vec3 planePoint(Vec2 q) const;
  /// Builds bounds_ for the film out to `reach` (mm, half extents).
  void buildBounds(Vec2 reach);
  /// Solves film_offset_mm_ for an object at `distance_m` (see the top of this file).
  void focus(double distance_m);
  /// The film offset of the smallest RMS spot of real rays from `field` (distance_m for messages).
  struct FocusSolve {
    double offset_mm = 0, rms_mm = 0;
    int rays = 0;
  };
  FocusSolve bestFocus(const optics::PlacedLens::Field& field, double distance_m) const;
  /// The lens re-indexed at lambda_nm (a per-thread copy).
  const optics::PlacedLens& lensAt(double lambda_nm) const;

  RealisticSettings settings_;
  std::string name_, path_;
  double stop_radius_mm_ = 0;  // the set stop radius (the aperture shape's unit); set with lens_
  optics::PlacedLens lens_;
  optics::SurfaceFrame image_frame_, rear_frame_;
  double rear_semi_mm_ = 0, z_near_ = 0, z_far_ = 0;  // the rear surface (its own frame)
  Vec2 rear_centre_{};  // its aperture's centre (decentred: an off-axis mirror)
  double film_offset_mm_ = 0;
  double focus_distance_m_ = 0;
  bool film_referenced_ = true;  // focus measured from the film (axes parallel), else the front
  double half_width_mm_ = 0, half_height_mm_ = 0;
  bool dispersive_ = false, absorbs_ = false;
  std::uint64_t id_ = 0;
  PlacedPupilBounds bounds_;
  double startup_seconds_ = 0, startup_cpu_seconds_ = 0;
};

}  // namespace lensim::camera
