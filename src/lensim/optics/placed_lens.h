// Exact ray tracing through a non-coaxial lens: surfaces tilted or decentred so that no single axis
// holds them (LensPrescription::noncoaxial_loc, from Zemax coordinate breaks). Each ray is moved
// into a surface's own frame (SurfaceFrame), intersected there as the coaxial tracer would
// intersect that surface on its axis, clipped at its apertures, refracted or reflected, and moved
// back; a grating surface diffracts it into its order instead (optics/grating.h, at the lens's
// wavelength). Double precision, one ray at a time. Coordinates are those of the front surface's frame
// (mm, z its axis, the object space's axis). The coaxial tracers (LensTracer, pupils) refuse such
// lenses (LensSystem's constructor); the realistic camera traces them with this one, backward
// from the film (camera/realistic_placed.h).
//
// On top of the tracer, what a non-coaxial lens allows honestly (no first-order data, which
// needs rotational symmetry): rays aimed through a point of the stop (the real chief ray through
// its centre, marginal rays through its edge) and the spot at the image surface from a grid of
// real rays.
#pragma once

#include <array>
#include <optional>
#include <vector>

#include "lensim/optics/glass.h"
#include "lensim/optics/lens_system.h"
#include "lensim/optics/prescription.h"
#include "lensim/optics/surface_shape.h"

namespace lensim::optics {

class PlacedLens {
 public:
  /// The lens at `wavelength_nm` (media resolved as LensSystem resolves them). Throws Error when
  /// the prescription is coaxial (no frames: use LensSystem) or a glass cannot be resolved.
  PlacedLens(const LensPrescription& p, double wavelength_nm);

  int surfaceCount() const { return int(surfaces_.size()); }
  int stopIndex() const { return stop_; }
  double stopSemiAperture_mm() const { return surfaces_[size_t(stop_)].semi; }
  double wavelength_nm() const { return wavelength_nm_; }
  const std::vector<Diagnostic>& diagnostics() const { return diagnostics_; }

  /// Traces a ray given in the front surface's frame through every surface and on to the image
  /// surface (the plane through its vertex, normal to its z axis). The result's ray starts on
  /// the image surface (global coordinates); stop_point is the hit in the stop's own frame.
  /// blocked_surface == surfaceCount() means the ray missed the image plane.
  TraceResult trace(const Ray& ray, const TraceOptions& opts = {},
                    std::vector<Vec3>* path = nullptr) const;
  /// Traces a ray backward, from the image side (global coordinates, toward the last surface)
  /// through every surface from the last to the front one, as a camera ray goes. The result's
  /// ray leaves the front surface toward the object space (global coordinates); stop_point as
  /// trace's. blocked_surface: the surface that stopped it. path: the hits, last surface first.
  TraceResult traceBackward(const Ray& ray, const TraceOptions& opts = {},
                            std::vector<Vec3>* path = nullptr) const;
  /// Re-indexes every medium at `wavelength_nm` from the glasses (a per-thread copy of the
  /// lens follows each sample's wavelength this way).
  void setWavelength(double wavelength_nm);
  /// The medium after each surface (as resolved at construction).
  const std::vector<Glass>& glasses() const { return glasses_; }
  /// Whether some medium's index depends on the wavelength.
  bool dispersive() const;
  /// Whether some surface is a diffraction grating (its rays' directions depend on the
  /// wavelength even without dispersion).
  bool hasGrating() const;
  /// A global point in the image surface's own frame (x, y, z).
  Vec3 toImageFrame(const Vec3& global) const;

  /// A field point: an object at infinity seen at angles (x, y in degrees, the ray direction's
  /// slopes tan x, tan y), or a finite object's point (mm, in the front surface's frame).
  struct Field {
    bool at_infinity = true;
    double angle_x_deg = 0, angle_y_deg = 0;
    Vec3 object_point{};
  };
  /// The ray from `field` through the point `entry` of the plane z = 0 (the front vertex's).
  Ray fieldRay(const Field& field, Vec2 entry) const;
  /// The entry point (on z = 0) whose ray meets the stop at `stop_xy` (the stop's own frame),
  /// by Newton's method on unclipped traces; nullopt when it does not converge.
  std::optional<Vec2> aim(const Field& field, Vec2 stop_xy) const;

  struct Spot {
    int rays = 0;          ///< rays of the grid that got through every aperture
    Vec2 centroid{};       ///< on the image surface (its own frame, mm)
    double rms_mm = 0;     ///< RMS radius about the centroid
  };
  /// The spot of `field` on the image surface from an n x n grid of parallel (or, for a finite
  /// object, diverging) rays over the entry-plane box that holds the beam (found by a first,
  /// coarse grid as wide as the widest aperture), clipped by every real aperture. nullopt when
  /// no ray gets through.
  std::optional<Spot> spot(const Field& field, int n = 41) const;

 private:
  struct Surface {
    std::array<std::array<double, 3>, 3> rotation;  // columns: local axes in global coordinates
    Vec3 origin;
    ShapeIntersector shape;
    double semi = 0, semi2 = 0, inner2 = 0;
    ApertureShape aperture_shape = ApertureShape::Circle;
    double half_x = 0, half_y = 0;
    double dec_x = 0, dec_y = 0;  // the aperture's centre (LensSurface::aperture_decentre_mm)
    bool mirror = false;
    double n_before = 1, n_after = 1;
    // A grating (LensSurface::grating): order * lines per micrometre; 0: none.
    bool grating = false;
    double order_lines_per_um = 0;
  };
  static Vec3 toLocal(const Surface& s, const Vec3& v);   // a direction into s's frame
  static Vec3 toGlobal(const Surface& s, const Vec3& v);  // a direction out of it
  // The ray (o, d) through surface i (global), or why it stopped.
  // backward: the ray comes from the image side (the media swap).
  BlockReason traceSurface(size_t i, const TraceOptions& opts, Vec3& o, Vec3& d,
                           Vec2* local_hit, bool backward = false) const;

  std::vector<Surface> surfaces_;
  std::vector<Glass> glasses_;
  Surface image_;
  int stop_ = 0;
  double extent_mm_ = 1;  // a length beyond every vertex and semi-aperture (ray start-up)
  double wavelength_nm_ = 0;
  std::vector<Diagnostic> diagnostics_;
};

}  // namespace lensim::optics
