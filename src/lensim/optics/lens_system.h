// A lens system in lens space, ready for exact ray tracing.
//
// Lens space (the one convention every optics function and CLI output uses): millimetres; z is the
// optical axis; the vertex of the front (scene-side) surface is at z = 0; +z points toward the
// film. Surface i has its vertex at z_i = sum of the thicknesses before it; a sphere of signed
// radius R has its centre at z_i + R. The film is the plane z = rearVertexZ() + filmDistance().
// Mirrors (catadioptric lenses): thicknesses are signed z distances as in Zemax, so after a mirror
// the surfaces follow toward -z; after an odd number of mirrors image space runs toward -z and is
// unfolded about the rear vertex plane (z -> 2 rearVertexZ - z) by the tracers, so that the film
// still lies at +z for everything downstream (realFilmZ_mm() is where it physically is).
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "lensim/optics/glass.h"
#include "lensim/optics/prescription.h"
#include "lensim/util/vec.h"

namespace lensim::optics {

/// A ray in lens space: origin in millimetres, unit direction.
template <typename T>
struct RayT {
  Vec3T<T> origin;
  Vec3T<T> direction;
};
using Ray = RayT<double>;

/// Why a traced ray did not leave the lens.
enum class BlockReason : std::uint8_t {
  None,      ///< not blocked
  Aperture,  ///< hit the surface (or stop plane) outside its clear aperture
  Miss,      ///< the line misses the sphere (or the plane) entirely
  TotalInternalReflection,
  Obscured,  ///< hit the surface inside its central obscuration
  Evanescent,  ///< a grating's order has no real direction (|sin| > 1): no ray leaves
};

/// "aperture", "miss", "tir", "obscured", "evanescent" or "none".
const char* blockReasonName(BlockReason r);

/// The outcome of an exact trace: the ray leaving the last surface, or where and why it stopped.
template <typename T>
struct TraceResultT {
  RayT<T> ray;  ///< the outgoing ray when not blocked; otherwise the ray as it was when blocked
  int blocked_surface = -1;  ///< surface index (0 = front) where it stopped, -1 if it got through
  BlockReason reason = BlockReason::None;
  /// Where the ray crossed the plane of the aperture stop (lens space x, y in mm), if it got
  /// that far: shaped apertures test it.
  Vec2T<T> stop_point{};

  bool ok() const { return reason == BlockReason::None; }
};
using TraceResult = TraceResultT<double>;

/// One interface of a LensSystem in lens space.
struct Interface {
  double radius_mm = 0;         ///< signed; 0 for the stop (a plane)
  double z_mm = 0;              ///< vertex position on the axis
  double semi_aperture_mm = 0;  ///< clear semi-aperture (the stop's may be overridden)
  double ior_before = 1;        ///< index on the scene side
  double ior_after = 1;         ///< index on the film side
  bool is_stop = false;
  /// A mirror: reflects instead of refracting (ior_after == ior_before).
  bool is_mirror = false;
  /// Rays meeting the surface closer than this to the axis are blocked (0: no obscuration).
  double obscuration_radius_mm = 0;
  /// A rectangular or elliptical aperture inside the semi-aperture (LensSurface's).
  ApertureShape aperture_shape = ApertureShape::Circle;
  double aperture_half_x_mm = 0, aperture_half_y_mm = 0;
  /// The direction of travel along z in the medium before and after the surface: +1 toward the
  /// film, -1 after an odd number of mirrors. Paraxial optics uses the signed indices
  /// n * direction (the n -> -n convention for mirrors), the exact tracer the magnitudes.
  int dir_before = 1, dir_after = 1;
  /// Signed indices for paraxial optics.
  double nBefore() const { return dir_before * ior_before; }
  double nAfter() const { return dir_after * ior_after; }
  /// Non-spherical shape (conic, asphere, cylinder); spherical by default. Non-spherical
  /// interfaces are traced by ShapeIntersector, spherical ones by the quadratic as before.
  SurfaceShape shape;

  /// Vertex curvature of the y-z section (1/mm), what paraxial optics uses.
  double paraxialCurvature() const { return vertexCurvatureY(radius_mm, shape); }
};

/// What a trace records and checks.
struct TraceOptions {
  bool clip_apertures = true;  ///< false: ignore clear apertures (used to find chief rays)
  /// false: ignore central obscurations (searches for the outer boundary of a beam or pupil,
  /// which an obscured centre would otherwise hide); only with clip_apertures.
  bool obscurations = true;
};
/// Options for searches of the outer boundary of a beam or pupil (clear apertures only).
inline constexpr TraceOptions kOuterBoundary{true, false};

/// A contiguous copy of the interfaces in precision T, with the exact tracer.
///
/// The tracer intersects each sphere with the numerically stable quadratic written relative to
/// the surface vertex (no cancellation for huge radii), keeps the root on the vertex side of the
/// sphere, clips at the clear aperture, and refracts with the vector form of Snell's law.
template <typename T>
class LensTracer {
 public:
  LensTracer() = default;
  explicit LensTracer(const std::vector<Interface>& interfaces);

  /// Traces a ray that starts behind the lens (film side, direction toward -z) out to the scene.
  /// If `path` is given, receives the start point and every surface intersection in order.
  TraceResultT<T> traceFromFilm(const RayT<T>& ray, const TraceOptions& opts = {},
                                std::vector<Vec3T<T>>* path = nullptr) const;
  /// Traces a ray from the scene (direction toward +z) through the lens to the film side.
  TraceResultT<T> traceFromScene(const RayT<T>& ray, const TraceOptions& opts = {},
                                 std::vector<Vec3T<T>>* path = nullptr) const;

  /// The most rays traceFromFilmBatch takes at once.
  static constexpr int kBatch = 16;
  /// Traces n <= kBatch rays from the film as traceFromFilm does each (same operations, same
  /// results), surface by surface across the rays: independent rays overlap in the processor,
  /// which hides the latency of each trace's chain of square roots and divisions. Quadrics,
  /// toroids and aspheres on a quadric base go side by side too
  /// (ShapeIntersector::intersectLanes); mirrors, obscured surfaces, other shapes and the rays
  /// those do not decide are traced lane by lane.
  void traceFromFilmBatch(const RayT<T>* rays, int n, TraceResultT<T>* results) const;

  /// The square of a ray's aperture margin (from the film): the ray traced without clipping,
  /// the largest over the surfaces of (hit's distance from the axis / clear semi-aperture)^2
  /// and, where it goes into a rarer medium, sin^2 of the refracted angle (>= 1: totally
  /// reflected, where the trace ends); infinite where it misses a surface. At most 1 exactly
  /// where the clipped trace gets through (obscurations aside), and continuous across rays
  /// up to a miss, so that a search for the edge of a beam can use secant steps on it.
  T marginSquared(const RayT<T>& ray) const;
  /// marginSquared for n <= kBatch rays at once (as traceFromFilmBatch): m2[0 .. n).
  void marginSquaredBatch(const RayT<T>* rays, int n, T* m2) const;

  int size() const { return static_cast<int>(radius_.size()); }

  /// Replaces the indices of the interfaces (size() values each, the media before and after
  /// each surface): the realistic camera re-indexes a per-thread copy for each wavelength.
  void setIndices(const double* before, const double* after);

 private:
  // traceFromFilmBatch (kMargin false) and marginSquaredBatch (true): the same loops.
  template <bool kMargin>
  void traceBatch(const RayT<T>* rays, int n, TraceResultT<T>* results, T* margin2) const;
  template <bool kFromFilm>
  TraceResultT<T> trace(const RayT<T>& ray, const TraceOptions& opts,
                        std::vector<Vec3T<T>>* path) const;

  // Traces surface i with its ShapeIntersector (in double precision): hit point and refracted
  // direction, or why it stopped.
  /// The apertures of surface i at the point (x, y) it is met: Aperture, Obscured or None.
  BlockReason clip(int i, const TraceOptions& opts, T x, T y) const;
  BlockReason traceShaped(int i, bool from_film, const TraceOptions& opts, Vec3T<T>& o, Vec3T<T>& d,
                          Vec3T<T>& hit, T* sin2 = nullptr) const;
  // One surface for one ray (any kind: sphere, plane, shaped, mirror, obscured): hit point and
  // new direction, or why it stopped. Used by the batch tracer for the lanes of such surfaces.
  // sin2: where given, receives sin^2 of the refracted angle where the indices differ.
  BlockReason traceOne(int i, bool from_film, const TraceOptions& opts, Vec3T<T>& o, Vec3T<T>& d,
                       Vec3T<T>& hit, T* sin2 = nullptr) const;
  // Image space after an odd number of mirrors runs toward -z; the tracers unfold it (mirror z
  // about the rear vertex plane) so that the film lies at +z as for any lens.
  void unfold(Vec3T<T>& o, Vec3T<T>& d) const {
    o.z = z_unfold_ - o.z;
    d.z = -d.z;
  }

  std::vector<T> radius_, inv_radius_, z_, semi2_, inner2_, eta_before_, eta_after_;
  std::vector<T> half_x_, half_y_;  // a Rectangle or Ellipse aperture's half-widths
  std::vector<ApertureShape> aperture_shape_;
  std::vector<std::uint8_t> is_stop_, is_mirror_, per_lane_;
  bool reversed_ = false;         // odd number of mirrors: image space unfolded
  T z_unfold_ = 0;                // 2 z_rear
  std::vector<int> shape_index_;  // -1: spherical (the quadratic); else into shapes_
  std::vector<ShapeIntersector> shapes_;
  // Per surface: 1 for a refracting non-spherical surface without obscuration whose intersector
  // works side by side (ShapeIntersector::hasLanes: quadrics, toroids, aspheres on a quadric base),
  // which the batch tracers intersect so.
  std::vector<std::uint8_t> lanes_;
};

extern template class LensTracer<double>;
extern template class LensTracer<float>;

/// Options when building a LensSystem from a prescription.
struct LensSystemOptions {
  /// Overrides the stop's diameter (pbrt's `aperturediameter`); clamped to the stop's maximum.
  std::optional<double> aperture_diameter_mm;
  /// Lens-to-film distance from the rear vertex; default: the file's last thickness.
  std::optional<double> film_distance_mm;
};

/// A lens prescription placed in lens space, with its stop setting and film position.
class LensSystem {
 public:
  /// Builds the system; throws lensim::Error for invalid options (e.g. aperture <= 0).
  explicit LensSystem(LensPrescription prescription, const LensSystemOptions& opts = {});

  const LensPrescription& prescription() const { return prescription_; }
  const std::vector<Interface>& interfaces() const { return interfaces_; }
  /// True if some surface has a central obscuration (a catadioptric lens's secondary mirror).
  bool hasObscuration() const {
    for (const Interface& s : interfaces_)
      if (s.obscuration_radius_mm > 0) return true;
    return false;
  }
  int surfaceCount() const { return static_cast<int>(interfaces_.size()); }

  /// Index of the radius-0 stop, if the file has one.
  std::optional<int> stopIndex() const { return stop_index_; }
  /// Current stop diameter (after any override), if there is a stop.
  std::optional<double> stopDiameter_mm() const;
  /// The largest stop diameter the file allows.
  std::optional<double> maxStopDiameter_mm() const { return max_stop_diameter_mm_; }

  double rearVertexZ_mm() const { return interfaces_.back().z_mm; }
  double filmDistance_mm() const { return film_distance_mm_; }
  /// The film plane. After an odd number of mirrors the image lies toward -z from the rear
  /// vertex; every image-side z (film, back focal point, exit pupil) is then given in image space
  /// unfolded about the rear vertex plane (z_real = 2 rearVertexZ - z), where the film lies at
  /// +z as for any lens; realFilmZ_mm() is where it physically is.
  double filmZ_mm() const { return rearVertexZ_mm() + film_distance_mm_; }
  double realFilmZ_mm() const {
    return imageSpaceReversed() ? rearVertexZ_mm() - film_distance_mm_ : filmZ_mm();
  }
  /// Mirrors in the lens, and whether image space is reversed (an odd number of them).
  int mirrorCount() const { return mirror_count_; }
  bool imageSpaceReversed() const { return mirror_count_ % 2 == 1; }
  /// Moves the film; the distance is measured from the rear vertex and must be > 0.
  void setFilmDistance_mm(double d);
  /// Index of the medium in front of the lens (air) and behind it (at the film).
  double objectIor() const { return 1.0; }
  double imageIor() const { return interfaces_.back().ior_after; }

  /// Warnings from building (e.g. an aperture larger than the stop allows), besides the
  /// prescription's own.
  const std::vector<Diagnostic>& diagnostics() const { return diagnostics_; }

  /// Dispersion. The medium after each surface (glass.h; resolved from the prescription's
  /// GlassSpecs, air and constant indices included), and the wavelength the interfaces' indices
  /// (Interface::ior_before/after, the tracers, paraxial data, focus) are at: the prescription's
  /// primary wavelength (else the d line, 587.56 nm) until setWavelength.
  const std::vector<Glass>& glasses() const { return glasses_; }
  /// Whether any medium's index varies with wavelength.
  bool dispersive() const { return dispersive_; }
  double wavelength_nm() const { return wavelength_nm_; }
  /// Sets every interface's indices to the media's indices at lambda_nm, and rebuilds the
  /// tracers. A no-op for the indices of a non-dispersive lens.
  void setWavelength(double lambda_nm);
  /// A copy of this system (stop, film distance kept) at another wavelength: the per-wavelength
  /// system for ray fans, spot diagrams, MTF and plots at several wavelengths.
  LensSystem atWavelength(double lambda_nm) const;
  /// The indices before and after every interface at lambda_nm (arrays of surfaceCount()),
  /// without building a system (for LensTracer::setIndices).
  void indicesAt(double lambda_nm, double* before, double* after) const;

  const LensTracer<double>& tracer() const { return tracer_d_; }
  const LensTracer<float>& tracerFloat() const { return tracer_f_; }

  /// The ray from a film point toward a point on the plane of the rear vertex.
  Ray filmPointRay(Vec2 film_mm, Vec2 rear_plane_mm) const;
  /// Exact trace from a film point toward a point on the plane of the rear vertex.
  TraceResult traceFromFilmPoint(Vec2 film_mm, Vec2 rear_plane_mm, const TraceOptions& opts = {},
                                 std::vector<Vec3>* path = nullptr) const;

 private:
  void rebuildTracers();
  void resolveMedia();

  LensPrescription prescription_;
  std::vector<Interface> interfaces_;
  std::optional<int> stop_index_;
  int mirror_count_ = 0;
  std::optional<double> max_stop_diameter_mm_;
  double film_distance_mm_ = 0;
  std::vector<Diagnostic> diagnostics_;
  LensTracer<double> tracer_d_;
  LensTracer<float> tracer_f_;
  std::vector<Glass> glasses_;
  bool dispersive_ = false;
  double wavelength_nm_ = kDefaultPrimaryWavelength_nm;
};

}  // namespace lensim::optics
