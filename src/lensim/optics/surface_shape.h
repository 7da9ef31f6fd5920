// Non-spherical surface shapes: conics, even and odd polynomial aspheres, and (for anamorphic
// lenses) biconic / cylindrical surfaces with a separate x curvature.
//
// Kept apart from the spherical description (`LensSurface::radius_mm`, `Interface::radius_mm`,
// the base radius in the y-z section) so that spherical lenses keep the fast quadratic tracer:
// a surface whose shape is `isSpherical()` is traced exactly as before.
//
// Sag (axial distance of the surface from its vertex plane, +z toward the film), with the base
// curvature c = 1 / radius_mm (0 for a plane), r^2 = x^2 + y^2:
//   rotational:  z(r)   = c r^2 / (1 + sqrt(1 - (1 + k) c^2 r^2)) + sum_p poly[p] r^p
//   biconic:     z(x,y) = (cx x^2 + c y^2) / (1 + sqrt(1 - (1 + kx) cx^2 x^2 - (1 + k) c^2 y^2))
//                         + sum_p poly[p] r^p
// with cx = 1 / radius_x_mm (0: flat in x, i.e. a cylinder curved in y) and kx = conic_x. A
// cylinder curved in x only has radius_mm = 0 (flat in y) and radius_x_mm set.
//   toroidal (Zemax TOROIDAL): the y-z curve
//                f(y)   = c y^2 / (1 + sqrt(1 - (1 + k) c^2 y^2)) + sum_p poly[p] y^p
//              rotated about the axis parallel to y that crosses the z axis at z = R (the radius
//              of rotation, rotation_radius_mm; R = 0 means infinite: a cylinder flat in x).
//              A point of the curve at height y is rho = R - f(y) from that axis, so
//                z(x,y) = R - sgn(rho) sqrt(rho^2 - x^2)
//                       = f + x^2 / (rho + sgn(rho) sqrt(rho^2 - x^2))
//              Its x-z section is the circle of radius R, its y-z section the curve f.
// The toroidal definition is Zemax OpticStudio's ("Toroidal" in the OpticStudio User Guide,
// Surface Types: a curve in the Y-Z plane with base radius, conic and the polynomial terms
// alpha_1 y^2 .. alpha_7 y^14, rotated about an axis parallel to Y at the distance R from the
// vertex; PARM 1 = R, 0 read as infinite; PARM 2..8 = alpha_1..alpha_7; its optional Zernike
// sag terms are not modelled); LensForge's "Toric Y" surface documents the same surface.
#pragma once

#include <limits>
#include <optional>
#include <utility>
#include <vector>

#include "lensim/util/vec.h"

namespace lensim::optics {

/// The shape of a surface beyond its base sphere. Default: a sphere (or plane) of the base radius.
struct SurfaceShape {
  double conic = 0;  ///< conic constant k of the y section (and of both for rotational shapes)
  /// Polynomial aspheric terms: poly[p] is the coefficient of r^p in mm^(1-p) (p >= 1; poly[0]
  /// unused). Zemax EVENASPH PARM 1..8 are p = 2, 4, ..., 16; ODDASPH PARM 1..8 are p = 1..8.
  std::vector<double> poly;
  /// Biconic / cylindrical: the radius of curvature in the x-z section (0: flat in x). Unset for
  /// rotationally symmetric surfaces.
  std::optional<double> radius_x_mm;
  double conic_x = 0;  ///< conic constant of the x section (biconic only)
  /// Toroidal: the radius of rotation R in mm (0: infinite, a cylinder curved in y only). When
  /// set, `conic` and `poly` describe the y-z curve and poly[p] multiplies y^p (even p only),
  /// not r^p. Unset for every other shape; never set together with radius_x_mm.
  std::optional<double> rotation_radius_mm;

  bool hasPolynomial() const;
  bool isToroidal() const { return rotation_radius_mm.has_value(); }
  bool isRotational() const { return !radius_x_mm && !rotation_radius_mm; }
  /// True when the surface is the plain sphere (or plane) of its base radius.
  bool isSpherical() const { return conic == 0 && !hasPolynomial() && isRotational(); }
  /// The even r^2 coefficient (adds 2 * poly[2] to the vertex curvature).
  double r2Coefficient() const { return poly.size() > 2 ? poly[2] : 0.0; }
  /// Scales every length by s (unit conversion): poly[p] -> poly[p] * s^(1-p).
  void scaleLengths(double s);
};

/// Sag and its gradient at (x, y) for base radius `radius_mm` (0: no base curvature) and shape.
/// Returns nullopt where the conic square root is undefined (outside the surface's domain).
struct SagGradient {
  double z = 0;
  double dzdx = 0;
  double dzdy = 0;
};
std::optional<SagGradient> surfaceSag(double radius_mm, const SurfaceShape& shape, double x,
                                      double y);

/// Vertex curvatures (1/mm) of the y-z and x-z sections: what paraxial optics uses.
double vertexCurvatureY(double radius_mm, const SurfaceShape& shape);
double vertexCurvatureX(double radius_mm, const SurfaceShape& shape);

/// Largest radial distance from the axis where the sag is defined in every direction (infinity
/// when the conic square root never fails). For a toroid: the nearest point (x, y) where the
/// y curve's square root fails or |x| reaches the distance R - f(y) from the axis of rotation
/// (found by sampling f; slightly conservative).
double sagDomainRadius(double radius_mm, const SurfaceShape& shape);

/// Exact ray intersection with a non-spherical surface (a bracketed Newton solve).
///
/// The surface is taken as defined up to `bound_r` from the axis (>= the clear semi-aperture and
/// inside the sag's domain) and continued beyond it as a flat annulus at the rim's sag, so that
/// every ray crossing the slab [min sag, max sag] crosses the surface exactly once more than it
/// leaves it; hits beyond the clear aperture are then clipped by the caller. The first root along
/// the ray of g(t) = z(t) - sag(x(t), y(t)) is bracketed (inside bound_r by halving with a bound
/// on the sag's curvature, which isolates it; beyond, by sampling for the first sign change),
/// then refined by Newton steps kept inside the bracket (bisection when a step leaves it), to
/// ~1e-12 mm. There is only one sheet (the sag function's), so no wrong-sheet hits.
/// Conics and cylinders without polynomial terms are quadrics: their hits come from the
/// quadratic, on the vertex sheet (hits beyond bound_r on the true quadric; the flat
/// continuation only where the line misses the vertex sheet). Toroids start Newton's method from
/// the quadric with their vertex curvatures (1/R in x, the y curve's c and conic), as aspheres
/// start from their base quadric, with the same first-crossing check (a proof from the curvature
/// bound, else g's sign at points before the root) and bracketed fallback.
class ShapeIntersector {
 public:
  ShapeIntersector() = default;
  ShapeIntersector(double radius_mm, const SurfaceShape& shape, double semi_aperture_mm);

  struct Hit {
    double t;
    Vec3 normal;  ///< unit, facing -z (toward the scene)
  };
  /// Ray origin relative to the vertex and unit direction; roots below t_min are ignored.
  std::optional<Hit> intersect(const Vec3& rel_origin, const Vec3& dir, double t_min) const;

  /// intersect() for up to kLanes rays side by side (the batch tracers), from the same source
  /// (the kernels that intersect() runs on one lane), so the same hits: a quadric's closed form,
  /// and the Newton solve from the base quadric with the first-crossing check of a toroid or an
  /// asphere on a quadric base. Origins relative to the vertex, unit directions. status[j]: 0 a
  /// hit (t[j] and the unit normal set), 1 a miss (the ray does not cross the surface's slab), 2
  /// not decided here, for intersect() to decide: a ray nearly parallel to the slab, no root on
  /// the quadric's vertex sheet, and for a Newton solve a quadric hit outside the slab, Newton's
  /// method leaving the slab or not converging, a point beyond bound_r or at the rim of the sag's
  /// domain, or a sign change before the root. Only where hasLanes().
  static constexpr int kLanes = 16;
  bool hasLanes() const { return quadric_ || base_quadric_; }
  /// Whether the hits are a quadric's closed form (rotational conics, biconics and cylinders
  /// without polynomial terms), exact beyond bound_r too; else the surface is traced as defined
  /// within the disc of radius bound_r only (the flat continuation beyond it).
  bool quadric() const { return quadric_; }
  void intersectLanes(int n, const double* ox, const double* oy, const double* oz, const double* dx,
                      const double* dy, const double* dz, double t_min, double* t, double* nx,
                      double* ny, double* nz, double* status) const;

  /// Sag with the flat continuation beyond bound_r.
  SagGradient sagContinued(double x, double y) const;
  /// sagContinued(x, y).z without the gradient (the first-crossing checks of the Newton solve).
  double sagZ(double x, double y) const;

 private:
  double radius_ = 0;
  SurfaceShape shape_;
  double cx_ = 0, cy_ = 0, ax_ = 0, ay_ = 0;   // cached section curvatures and (1 + k) c^2
  std::vector<std::pair<int, double>> terms_;  // the non-zero polynomial terms (power, coeff)
  // Quadrics (rotational conics and cylinders without polynomial terms) have a closed form:
  // cx x^2 + cy y^2 + e z^2 - 2 z = 0, the vertex sheet where 1 - e z > 0.
  bool quadric_ = false;
  // The base quadric (the shape without its polynomial terms), when it is one: its hit predicts
  // the aspheric one, which Newton's method then refines.
  bool base_quadric_ = false;
  double qcx_ = 0, qcy_ = 0, qe_ = 0;
  std::optional<double> quadricRoot(const Vec3& o, const Vec3& d, double t_min) const;
  bool toroidal_ = false;
  // The first-crossing proof of the Newton solve (newtonLanes): a bound on the spectral norm of
  // the sag's Hessian over the disc of radius bound_r (infinite: none).
  void boundSagCurvature();
  // The kernels intersect() (kOne: one lane) and intersectLanes share (surface_shape.cpp).
  template <bool kGradient, bool kOne>
  void sagLanes(int n, const double* x, const double* y, double* z, double* gx, double* gy,
                double* bad) const;
  template <bool kOne>
  void newtonLanes(int n, const double* ox, const double* oy, const double* oz, const double* dx,
                   const double* dy, const double* dz, const double* ta, const double* tb,
                   double* t, double* nx, double* ny, double* nz, double* status) const;
  bool firstBracketInside(const Vec3& o, const Vec3& d, double lo, double hi, double& a, double& ga,
                          double& b, double& gb) const;
  // g(t) = z(t) - sag(x(t), y(t)) along the ray o + t d (the continued sag), and where sg is
  // given the sag and its gradient there.
  double alongRay(const Vec3& o, const Vec3& d, double t, SagGradient* sg) const;
  double hess_bound_ = std::numeric_limits<double>::infinity();
  double bound_r_ = 0;
  double z_lo_ = 0, z_hi_ = 0;  // slab of the (continued) surface relative to the vertex
};

}  // namespace lensim::optics
