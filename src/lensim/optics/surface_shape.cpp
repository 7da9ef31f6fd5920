#include "lensim/optics/surface_shape.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace lensim::optics {

bool SurfaceShape::hasPolynomial() const {
  for (size_t p = 1; p < poly.size(); ++p)
    if (poly[p] != 0) return true;
  return false;
}

void SurfaceShape::scaleLengths(double s) {
  for (size_t p = 1; p < poly.size(); ++p) poly[p] *= std::pow(s, 1.0 - double(p));
  if (radius_x_mm) *radius_x_mm *= s;
  if (rotation_radius_mm) *rotation_radius_mm *= s;
}

namespace {

struct Coeffs {
  double cx, cy, ax, ay;  // curvatures and (1 + k) c^2 of the x and y sections
};

Coeffs coeffsOf(double radius_mm, const SurfaceShape& shape) {
  Coeffs k;
  k.cy = radius_mm != 0 ? 1 / radius_mm : 0.0;
  if (shape.radius_x_mm) {
    k.cx = *shape.radius_x_mm != 0 ? 1 / *shape.radius_x_mm : 0.0;
    k.ax = (1 + shape.conic_x) * k.cx * k.cx;
  } else {
    k.cx = k.cy;
    k.ax = (1 + shape.conic) * k.cx * k.cx;
  }
  k.ay = (1 + shape.conic) * k.cy * k.cy;
  return k;
}

// Toroids (see the header for the definition and its source). The y-z curve f(y) and its slope
// f'(y); nullopt where the conic square root is undefined.
struct Profile {
  double f, df;
};
// kSlope false: f only (df left 0; f the same value).
template <bool kSlope = true>
std::optional<Profile> toroidProfile(double c, double a, const std::vector<double>& poly,
                                     double y) {
  // a = (1 + k) c^2; f = c y^2 / (1 + S), f' = c y / S with S = sqrt(1 - a y^2).
  const double arg = 1 - a * y * y;
  if (arg < 0) return std::nullopt;
  const double S = std::sqrt(arg);
  Profile p{};
  p.f = c * y * y / (1 + S);
  if constexpr (kSlope)
    p.df = S > 0 ? c * y / S
                 : (y != 0 ? std::copysign(std::numeric_limits<double>::infinity(), c * y) : 0.0);
  double yp = 1;  // y^(p-1)
  for (size_t k = 1; k < poly.size(); ++k) {
    const double a_p = poly[k];
    if (kSlope && a_p != 0) p.df += double(k) * a_p * yp;
    yp *= y;
    if (a_p != 0) p.f += a_p * yp;
  }
  return p;
}

// The toroid's sag at (x, y): z = f + x^2 / (rho + q), q = sgn(rho) sqrt(rho^2 - x^2),
// rho = R - f(y); gradient dz/dx = x / q, dz/dy = rho f' / q (from q^2 = rho^2 - x^2).
// rot = 0: the cylinder z = f(y). `clamp`: rho^2 - x^2 < 0 (just outside the domain, from the
// sampled domain radius) is taken as 0 instead of failing.
// kGradient false: the sag only (the gradient left 0; z the same value).
template <bool kGradient = true>
std::optional<SagGradient> toroidSag(double c, double a, const std::vector<double>& poly,
                                     double rot, double x, double y, bool clamp) {
  const auto pr = toroidProfile<kGradient>(c, a, poly, y);
  if (!pr) return std::nullopt;
  if (rot == 0) return SagGradient{pr->f, 0.0, pr->df};
  const double rho = rot - pr->f;
  double d = rho * rho - x * x;
  if (d < 0) {
    if (!clamp) return std::nullopt;
    d = 0;
  }
  const double q = std::copysign(std::sqrt(d), rho);
  SagGradient g{};
  if (rho + q == 0) return std::nullopt;  // rho = 0: the curve meets the axis of rotation
  g.z = pr->f + x * x / (rho + q);
  if constexpr (!kGradient) return g;
  if (q != 0) {
    g.dzdx = x / q;
    g.dzdy = rho * pr->df / q;
  } else {  // the rim of the domain: vertical
    const double inf = std::numeric_limits<double>::infinity();
    g.dzdx = x != 0 ? std::copysign(inf, x * rho) : 0.0;
    g.dzdy = pr->df != 0 ? std::copysign(inf, rho * pr->df) : 0.0;
  }
  return g;
}

// toroidSag<kGradient>(c, a, poly, rot, x, y, clamp = true) for lanes [0, n) side by side, with
// the same operations (so the same values) where the scalar function, as ShapeIntersector's
// sagContinued and sagZ call it, takes its common path: r^2 <= bound2 (inside bound_r), the y
// curve's square root positive and rho^2 - x^2 > 0. bad[j] is 1 for lanes off that path (their
// values are not used). Conditions are 0/1 doubles so that GCC vectorises the loops.
constexpr int kLanes = ShapeIntersector::kLanes;
template <bool kGradient>
[[gnu::always_inline]] inline void toroidSagLanes(double c, double a,
                                                  const std::vector<double>& poly, double rot,
                                                  double bound2, int n, const double* x,
                                                  const double* y, double* z, double* gx,
                                                  double* gy, double* bad) {
  double f[kLanes], df[kLanes] = {}, yp[kLanes];
  for (int j = 0; j < n; ++j) {
    const double xj = x[j], yj = y[j];
    const double arg = 1 - a * yj * yj;
    bad[j] = std::max(xj * xj + yj * yj > bound2 ? 1.0 : 0.0, arg > 0 ? 0.0 : 1.0);
    const double S = std::sqrt(std::max(arg, 0.0));
    f[j] = c * yj * yj / (1 + S);
    if constexpr (kGradient) df[j] = c * yj / S;
    yp[j] = 1;
  }
  for (size_t k = 1; k < poly.size(); ++k) {
    const double a_p = poly[k];
    if (a_p == 0) {
      for (int j = 0; j < n; ++j) yp[j] *= y[j];
      continue;
    }
    for (int j = 0; j < n; ++j) {
      if constexpr (kGradient) df[j] += double(k) * a_p * yp[j];
      yp[j] *= y[j];
      f[j] += a_p * yp[j];
    }
  }
  if (rot == 0) {  // a cylinder: the y curve itself (gx, gy are null without kGradient)
    for (int j = 0; j < n; ++j) z[j] = f[j];
    if constexpr (kGradient)
      for (int j = 0; j < n; ++j) gx[j] = 0, gy[j] = df[j];
    return;
  }
  for (int j = 0; j < n; ++j) {
    const double xj = x[j];
    const double rho = rot - f[j];
    const double d = rho * rho - xj * xj;
    bad[j] = std::max(bad[j], d > 0 ? 0.0 : 1.0);
    const double q = std::copysign(std::sqrt(std::max(d, 0.0)), rho);
    z[j] = f[j] + xj * xj / (rho + q);
    if constexpr (kGradient) {
      gx[j] = xj / q;
      gy[j] = rho * df[j] / q;
    }
  }
}

// ShapeIntersector's sagContinued (kGradient) and sagZ for an asphere on a conic base (the
// biconic formula with the polynomial terms, powers of r) for lanes [0, n), with the same
// operations where they take their common path: r^2 <= bound2 and the conic's square root
// positive; bad[j] is 1 for the other lanes.
template <bool kGradient>
[[gnu::always_inline]] inline void asphereSagLanes(double cx, double cy, double ax, double ay,
                                                   const std::vector<std::pair<int, double>>& terms,
                                                   double bound2, int n, const double* x,
                                                   const double* y, double* z, double* gx,
                                                   double* gy, double* bad) {
  double r2[kLanes], r[kLanes], rk[kLanes], slope[kLanes];
  for (int j = 0; j < n; ++j) {
    const double xj = x[j], yj = y[j];
    r2[j] = xj * xj + yj * yj;
    const double arg = 1 - ax * xj * xj - ay * yj * yj;
    bad[j] = std::max(r2[j] > bound2 ? 1.0 : 0.0, arg > 0 ? 0.0 : 1.0);
    const double S = std::sqrt(std::max(arg, 0.0)), N = cx * xj * xj + cy * yj * yj;
    const double den = 1 + S;
    z[j] = N / den;
    if constexpr (kGradient) {
      const double inv = 1 / (den * den), nS = N / S;
      gx[j] = (2 * cx * xj * den + nS * ax * xj) * inv;
      gy[j] = (2 * cy * yj * den + nS * ay * yj) * inv;
    }
  }
  if (terms.empty()) return;
  // polynomialSag: the terms in increasing powers, r^(p-2) kept in rk.
  double pz[kLanes];
  for (int j = 0; j < n; ++j) r[j] = std::sqrt(r2[j]), rk[j] = 1, slope[j] = 0, pz[j] = 0;
  int k = 0;
  for (const auto& [p, a] : terms) {
    if (p == 1) {
      for (int j = 0; j < n; ++j) {
        pz[j] += a * r[j];
        slope[j] += r[j] > 0 ? a / r[j] : 0.0;
      }
      continue;
    }
    for (; k < p - 2; ++k)
      for (int j = 0; j < n; ++j) rk[j] *= r[j];
    for (int j = 0; j < n; ++j) {
      pz[j] += a * rk[j] * r2[j];
      slope[j] += p * a * rk[j];
    }
  }
  for (int j = 0; j < n; ++j) z[j] += pz[j];
  if constexpr (kGradient)
    for (int j = 0; j < n; ++j) gx[j] += slope[j] * x[j], gy[j] += slope[j] * y[j];
}

double toroidA(double radius_mm, const SurfaceShape& shape) {
  const double c = radius_mm != 0 ? 1 / radius_mm : 0.0;
  return (1 + shape.conic) * c * c;
}

}  // namespace

std::optional<SagGradient> surfaceSag(double radius_mm, const SurfaceShape& shape, double x,
                                      double y) {
  if (shape.isToroidal())
    return toroidSag(radius_mm != 0 ? 1 / radius_mm : 0.0, toroidA(radius_mm, shape), shape.poly,
                     *shape.rotation_radius_mm, x, y, false);
  const Coeffs k = coeffsOf(radius_mm, shape);
  const double arg = 1 - k.ax * x * x - k.ay * y * y;
  if (arg < 0) return std::nullopt;
  const double S = std::sqrt(arg);
  const double N = k.cx * x * x + k.cy * y * y;
  const double den = 1 + S;
  SagGradient g;
  g.z = N / den;
  // d/dx [N / (1 + S)] = (2 cx x (1 + S) - N dS/dx) / (1 + S)^2 with dS/dx = -ax x / S.
  if (S > 0) {
    g.dzdx = (2 * k.cx * x * den + N * k.ax * x / S) / (den * den);
    g.dzdy = (2 * k.cy * y * den + N * k.ay * y / S) / (den * den);
  } else {  // the rim of the conic's domain: the surface is vertical there
    const double inf = std::numeric_limits<double>::infinity();
    g.dzdx = x != 0 ? std::copysign(inf, x * (k.cx != 0 ? k.cx : 1)) : 0;
    g.dzdy = y != 0 ? std::copysign(inf, y * (k.cy != 0 ? k.cy : 1)) : 0;
  }
  if (shape.hasPolynomial()) {
    const double r = std::sqrt(x * x + y * y);
    // sum p a_p r^(p-2): the radial slope divided by r (the p = 1 cone term is singular at 0).
    double z = 0, slope_over_r = 0, rp = 1;  // rp = r^p
    for (size_t p = 1; p < shape.poly.size(); ++p) {
      const double rpm2 = rp / std::max(r, 1e-300);  // r^(p-2) before updating rp
      rp *= r;
      const double a = shape.poly[p];
      if (a == 0) continue;
      z += a * rp;
      if (p == 1) {
        if (r > 0) slope_over_r += a / r;
      } else {
        slope_over_r += double(p) * a * (p == 2 ? 1.0 : rpm2);
      }
    }
    g.z += z;
    g.dzdx += slope_over_r * x;
    g.dzdy += slope_over_r * y;
  }
  return g;
}

double vertexCurvatureY(double radius_mm, const SurfaceShape& shape) {
  return (radius_mm != 0 ? 1 / radius_mm : 0.0) + 2 * shape.r2Coefficient();
}

double vertexCurvatureX(double radius_mm, const SurfaceShape& shape) {
  if (shape.isToroidal())  // the x-z section is the circle of radius R
    return *shape.rotation_radius_mm != 0 ? 1 / *shape.rotation_radius_mm : 0.0;
  if (!shape.radius_x_mm) return vertexCurvatureY(radius_mm, shape);
  return (*shape.radius_x_mm != 0 ? 1 / *shape.radius_x_mm : 0.0) + 2 * shape.r2Coefficient();
}

double sagDomainRadius(double radius_mm, const SurfaceShape& shape) {
  if (shape.isToroidal()) {
    // The y curve's domain, then the nearest point (|rho(y)|, y) where x reaches the axis of
    // rotation's distance: min over y of hypot(rho(y), y). Beyond y = the best so far no point
    // can be nearer, so sampling [0, min(domain_y, |R|)] finds it.
    const double c = radius_mm != 0 ? 1 / radius_mm : 0.0, a = toroidA(radius_mm, shape);
    double best = a > 0 ? 1 / std::sqrt(a) : std::numeric_limits<double>::infinity();
    const double rot = *shape.rotation_radius_mm;
    if (rot == 0) return best;
    best = std::min(best, std::abs(rot));
    const double span = best;
    constexpr int kSamples = 4096;
    for (int i = 1; i <= kSamples; ++i) {
      const double y = span * i / kSamples;
      const auto pr = toroidProfile(c, a, shape.poly, y);
      if (!pr) break;
      best = std::min(best, std::hypot(rot - pr->f, y));
    }
    return best * (1 - 1e-6);
  }
  const Coeffs k = coeffsOf(radius_mm, shape);
  const double a = std::max(k.ax, k.ay);
  return a > 0 ? 1 / std::sqrt(a) : std::numeric_limits<double>::infinity();
}

// ---------------------------------------------------------------------------------------------

ShapeIntersector::ShapeIntersector(double radius_mm, const SurfaceShape& shape,
                                   double semi_aperture_mm)
    : radius_(radius_mm), shape_(shape), toroidal_(shape.isToroidal()) {
  if (toroidal_) {  // the y curve's c and (1 + k) c^2; the terms are powers of y
    cy_ = radius_mm != 0 ? 1 / radius_mm : 0.0, ay_ = toroidA(radius_mm, shape);
  } else {
    const Coeffs k = coeffsOf(radius_mm, shape);
    cx_ = k.cx, cy_ = k.cy, ax_ = k.ax, ay_ = k.ay;
    for (size_t p = 1; p < shape.poly.size(); ++p)
      if (shape.poly[p] != 0) terms_.push_back({int(p), shape.poly[p]});
  }
  const double domain = sagDomainRadius(radius_mm, shape);
  const double semi = std::max(semi_aperture_mm, 1e-6);
  bound_r_ = std::min(1.25 * semi, domain * (1 - 1e-9));
  // Slab of the surface: sag sampled on a polar grid over a quadrant (every shape here is
  // symmetric in x -> -x and y -> -y), padded for the extremes between samples.
  const int n_ang = shape.isRotational() ? 1 : 9;
  double lo = 0, hi = 0;
  for (int a = 0; a < n_ang; ++a) {
    const double phi = n_ang == 1 ? 0.0 : (std::numbers::pi / 2) * a / (n_ang - 1);
    for (int k = 0; k <= 128; ++k) {
      const double r = bound_r_ * k / 128;
      const SagGradient g = sagContinued(r * std::cos(phi), r * std::sin(phi));
      lo = std::min(lo, g.z), hi = std::max(hi, g.z);
    }
  }
  const double pad = 0.02 * (hi - lo) + 1e-7;
  z_lo_ = lo - pad, z_hi_ = hi + pad;
  if (toroidal_) {
    // Not a quadric; the quadric with the toroid's vertex curvatures and the y curve's conic
    // (exact for a sphere, R = radius and k = 0, and for a cylinder, R = 0) predicts the hit
    // that Newton's method refines, as for the aspheres.
    const double c = radius_mm != 0 ? 1 / radius_mm : 0.0;
    const double rot = *shape.rotation_radius_mm;
    base_quadric_ = true;
    quadric_ = false;
    qcx_ = rot != 0 ? 1 / rot : 0.0, qcy_ = c;
    qe_ = c != 0 ? (1 + shape.conic) * c : qcx_;
    boundSagCurvature();
    return;
  }
  // Quadric when (1 + k) c is the same for every curved section.
  {
    const Coeffs k = coeffsOf(radius_mm, shape);
    const double ex = k.cx != 0 ? k.ax / k.cx : 0.0, ey = k.cy != 0 ? k.ay / k.cy : 0.0;
    if (k.cx == 0 || k.cy == 0 || std::abs(ex - ey) <= 1e-12 * std::max(std::abs(ex), 1e-300)) {
      base_quadric_ = true;
      quadric_ = !shape.hasPolynomial();
      qcx_ = k.cx, qcy_ = k.cy, qe_ = k.cx != 0 ? ex : ey;
    }
  }
  if (!quadric_) boundSagCurvature();
}

void ShapeIntersector::boundSagCurvature() {
  // The largest spectral norm of the sag's Hessian, from central differences of its gradient on
  // the slab's polar grid (over a quadrant: every shape here is symmetric in x -> -x and
  // y -> -y), doubled for the extremes between samples, as the slab is padded. Infinite where
  // the sag is undefined within a step of the disc (a surface whose domain ends at bound_r).
  auto gradient = [&](double x, double y) { return surfaceSag(radius_, shape_, x, y); };
  const double h = 1e-5 * bound_r_;
  const int n_ang = shape_.isRotational() ? 1 : 9;
  double most = 0;
  for (int a = 0; a < n_ang; ++a) {
    const double phi = n_ang == 1 ? 0.0 : (std::numbers::pi / 2) * a / (n_ang - 1);
    for (int k = 0; k <= 128; ++k) {
      const double r = bound_r_ * k / 128, x = r * std::cos(phi), y = r * std::sin(phi);
      const auto px = gradient(x + h, y), mx = gradient(x - h, y);
      const auto py = gradient(x, y + h), my = gradient(x, y - h);
      if (!px || !mx || !py || !my) return;
      const double hxx = (px->dzdx - mx->dzdx) / (2 * h), hyy = (py->dzdy - my->dzdy) / (2 * h);
      const double hxy = 0.5 * ((px->dzdy - mx->dzdy) + (py->dzdx - my->dzdx)) / (2 * h);
      // The symmetric 2x2 matrix's largest absolute eigenvalue.
      const double norm = 0.5 * std::abs(hxx + hyy) + std::hypot(0.5 * (hxx - hyy), hxy);
      if (!std::isfinite(norm)) return;
      most = std::max(most, norm);
    }
  }
  hess_bound_ = 2 * most;
}

// Whether the Newton solve's root t is the first crossing after the slab's entry ta, from the
// bound on the sag's curvature: g(tau) = z(tau) - sag(x(tau), y(tau)) along the ray has
// |g''| <= H |d_xy|^2 (H the bound on the Hessian's norm) wherever the path stays inside the disc
// of radius bound_r (so from ta to t when both ends do: the disc is convex), so that
// g(t - delta) = g(t) - g'(t) delta + e with |e| <= H |d_xy|^2 delta^2 / 2: g keeps the sign of
// -g'(t) for delta up to 2 |g'(t)| / (H |d_xy|^2). Asked for half of that (g'(t) is taken from
// the gradient at the last iterate, within 1e-13 of t), on [ta, t). Near the axis and at the
// usual angles it holds by a wide margin (a lens's ray crosses a slab a few millimetres deep at
// a slope well below 1, where g'' is a few hundredths of g'); where it does not, the solve checks
// g's sign at points along the ray instead. intersectLanes computes the same expression.
bool ShapeIntersector::firstCrossingProven(double ox, double oy, double dx, double dy, double dz,
                                           double ta, double t, double sx, double sy) const {
  const double xa = ox + ta * dx, ya = oy + ta * dy, xt = ox + t * dx, yt = oy + t * dy;
  const double bound2 = bound_r_ * bound_r_;
  const double slope = dz - sx * dx - sy * dy;
  const double curv = hess_bound_ * (dx * dx + dy * dy);
  return xa * xa + ya * ya <= bound2 && xt * xt + yt * yt <= bound2 &&
         (t - ta) * curv < std::abs(slope);
}

double ShapeIntersector::alongRay(const Vec3& o, const Vec3& d, double t, SagGradient* sg) const {
  const double x = o.x + t * d.x, y = o.y + t * d.y;
  if (!sg) return o.z + t * d.z - sagZ(x, y);
  *sg = sagContinued(x, y);
  return o.z + t * d.z - sg->z;
}

// The first root of g(t) = z(t) - sag(x(t), y(t)) on [lo, hi], a part of the ray inside the disc
// of radius bound_r, isolated with the bound on g'' (H |d_xy|^2, as firstCrossingProven): the
// segments are visited left to right and halved; one whose ends have g of one sign holds no
// root where g cannot reach 0 between them (it lies within H |d_xy|^2 w^2 / 8 of its chord on a
// segment of width w), and one whose ends differ in sign holds exactly one where g's slope at
// its middle is steeper than the curvature can turn over half its width (g is monotone there).
// That one is the bracket. (A 16-sample scan missed pairs of crossings of a ray grazing the
// surface, and a crossing near the start of a long slab.) Segments narrower than 1e-12 (1 + |t|)
// are not halved: a ray tangent to the surface there does not cross it.
bool ShapeIntersector::firstBracketInside(const Vec3& o, const Vec3& d, double lo, double hi,
                                          double& a, double& ga, double& b, double& gb) const {
  const double curv = hess_bound_ * (d.x * d.x + d.y * d.y);
  auto g = [&](double t) { return alongRay(o, d, t, nullptr); };
  struct Seg {
    double a, ga, b, gb;
  };
  // Depth-first, the left half on top; at most one pending right half per level.
  constexpr int kMaxDepth = 60;
  Seg stack[kMaxDepth + 2];
  int n = 0;
  stack[n++] = {lo, g(lo), hi, g(hi)};
  int evaluations = 0;
  while (n > 0) {
    const Seg s = stack[--n];
    if (s.ga == 0) {
      a = b = s.a, ga = gb = 0;
      return true;
    }
    const bool change = s.gb == 0 || (s.gb < 0) != (s.ga < 0);
    const double w = s.b - s.a, m = 0.5 * (s.a + s.b);
    double gm;
    if (!change) {
      const double reach = curv * w * w / 8;
      if (s.ga < 0 ? std::max(s.ga, s.gb) + reach < 0 : std::min(s.ga, s.gb) - reach > 0) continue;
    } else {
      SagGradient sg;
      gm = alongRay(o, d, m, &sg);
      ++evaluations;
      if (std::abs(d.z - sg.dzdx * d.x - sg.dzdy * d.y) > curv * w / 2) {
        a = s.a, ga = s.ga, b = s.b, gb = s.gb;
        return true;
      }
    }
    if (w <= 1e-12 * (1 + std::abs(m)) || n >= kMaxDepth || evaluations > 4096) {
      if (!change) continue;
      a = s.a, ga = s.ga, b = s.b, gb = s.gb;  // tangent or unresolved: a root lies here
      return true;
    }
    if (!change) gm = g(m), ++evaluations;
    stack[n++] = {m, gm, s.b, s.gb};
    stack[n++] = {s.a, s.ga, m, gm};
  }
  return false;
}

std::optional<double> ShapeIntersector::quadricRoot(const Vec3& o, const Vec3& d,
                                                    double t_min) const {
  // A t^2 + 2 B t + C = 0; stable roots; the nearest on the vertex sheet.
  const double A = qcx_ * d.x * d.x + qcy_ * d.y * d.y + qe_ * d.z * d.z;
  const double B = qcx_ * o.x * d.x + qcy_ * o.y * d.y + qe_ * o.z * d.z - d.z;
  const double C = qcx_ * o.x * o.x + qcy_ * o.y * o.y + qe_ * o.z * o.z - 2 * o.z;
  double roots[2];
  int nr = 0;
  if (A == 0) {
    if (B != 0) roots[nr++] = -C / (2 * B);
  } else {
    const double disc = B * B - A * C;
    if (disc >= 0) {
      const double q = -(B + std::copysign(std::sqrt(disc), B));
      roots[nr++] = q / A;
      if (q != 0) roots[nr++] = C / q;
    }
  }
  if (nr == 2 && roots[1] < roots[0]) std::swap(roots[0], roots[1]);
  for (int i = 0; i < nr; ++i) {
    const double t = roots[i];
    if (!(t >= t_min)) continue;
    if (1 - qe_ * (o.z + t * d.z) <= 0) continue;  // the other sheet
    return t;
  }
  return std::nullopt;
}

__attribute__((target_clones("avx2", "default"))) void ShapeIntersector::intersectLanes(
    int n, const double* __restrict ox, const double* __restrict oy, const double* __restrict oz,
    const double* __restrict dx, const double* __restrict dy, const double* __restrict dz,
    double t_min, double* __restrict t, double* __restrict nx, double* __restrict ny,
    double* __restrict nz, double* __restrict status) const {
  // intersect()'s operations lane by lane in branch-free loops (selects of 0/1 doubles), so that
  // the compiler vectorises them and each lane's values are the scalar ones; a lane that would
  // take another branch there is given status 2 and intersect() traces it.
  const double zero = 0, one = 1, two = 2, kMax = std::numeric_limits<double>::max();
  // Members as locals: the compiler cannot tell that the stores below leave them alone.
  const bool quadric = quadric_;
  const double quad = quadric ? one : zero;  // (a select on a bool stops the vectoriser)
  const double cx = qcx_, cy = qcy_, e = qe_, z_lo = z_lo_, z_hi = z_hi_;
  n = std::min(n, kLanes);
  double ta[kLanes], tb[kLanes];
  for (int j = 0; j < n; ++j) {
    // The slab.
    const double t0 = (z_lo - oz[j]) / dz[j], t1 = (z_hi - oz[j]) / dz[j];
    ta[j] = std::max(std::min(t0, t1), t_min), tb[j] = std::max(t0, t1);
    const double flat = std::abs(dz[j]) > 1e-12 ? zero : one;
    const double crosses = ta[j] <= tb[j] ? one : zero;
    // quadricRoot: A t^2 + 2 B t + C = 0; stable roots; the nearest on the vertex sheet.
    const double A = cx * dx[j] * dx[j] + cy * dy[j] * dy[j] + e * dz[j] * dz[j];
    const double B = cx * ox[j] * dx[j] + cy * oy[j] * dy[j] + e * oz[j] * dz[j] - dz[j];
    const double C = cx * ox[j] * ox[j] + cy * oy[j] * oy[j] + e * oz[j] * oz[j] - 2 * oz[j];
    const double disc = B * B - A * C;
    const double q = -(B + std::copysign(std::sqrt(std::max(disc, zero)), B));
    const double r0 = q / A, r1 = q != zero ? C / q : r0;
    const double lo = std::min(r0, r1), hi = std::max(r0, r1);
    const double ok_lo = lo >= t_min ? (1 - e * (oz[j] + lo * dz[j]) > zero ? one : zero) : zero;
    const double ok_hi = hi >= t_min ? (1 - e * (oz[j] + hi * dz[j]) > zero ? one : zero) : zero;
    const double tq = ok_lo != zero ? lo : hi;
    const double root = A != zero ? (disc >= zero ? std::max(ok_lo, ok_hi) : zero) : zero;
    t[j] = tq;
    // A Newton solve (toroid, asphere) starts from a quadric hit inside the slab.
    const double in_slab = tq >= ta[j] ? (tq <= tb[j] ? one : zero) : zero;
    const double start = std::max(std::min(root, in_slab), std::min(root, quad));
    status[j] = flat != zero ? two : (crosses == zero ? one : (start != zero ? zero : two));
  }
  if (quadric) {  // the normal from the quadric's gradient (2 cx x, 2 cy y, 2 e z - 2)
    for (int j = 0; j < n; ++j) {
      const double hx = ox[j] + dx[j] * t[j], hy = oy[j] + dy[j] * t[j], hz = oz[j] + dz[j] * t[j];
      const double gx = cx * hx, gy = cy * hy, gz = e * hz - 1;
      const double len = std::sqrt(gx * gx + gy * gy + gz * gz);
      nx[j] = gx / len, ny[j] = gy / len, nz[j] = gz / len;
    }
    return;
  }

  // A toroid or an asphere on a quadric base: Newton's method from the quadric's hit, kept
  // inside the slab (as intersect()).
  const bool toroidal = toroidal_;
  const double rot = toroidal ? *shape_.rotation_radius_mm : 0.0, bound2 = bound_r_ * bound_r_;
  const double c = cy_, a = ay_;
  double act[kLanes], sx[kLanes] = {}, sy[kLanes] = {};
  double x[kLanes], y[kLanes], z[kLanes], gx[kLanes], gy[kLanes], bad[kLanes];
  // Whether any lane is still iterating (a loop of its own: a reduction in the lanes' loops
  // would stop their vectorisation).
  auto anyActive = [&] {
    bool any = false;
    for (int j = 0; j < n; ++j) any = any || act[j] != zero;
    return any;
  };
  for (int j = 0; j < n; ++j) act[j] = status[j] == zero ? one : zero;
  for (int it = 0; it < 12 && anyActive(); ++it) {
    for (int j = 0; j < n; ++j) x[j] = ox[j] + t[j] * dx[j], y[j] = oy[j] + t[j] * dy[j];
    if (toroidal)
      toroidSagLanes<true>(c, a, shape_.poly, rot, bound2, n, x, y, z, gx, gy, bad);
    else
      asphereSagLanes<true>(cx_, cy_, ax_, ay_, terms_, bound2, n, x, y, z, gx, gy, bad);
    for (int j = 0; j < n; ++j) {
      const double gt = oz[j] + t[j] * dz[j] - z[j];
      const double dg = dz[j] - gx[j] * dx[j] - gy[j] * dy[j];
      const double tn = t[j] - gt / dg;
      // intersect() stops here. (0/1 values combined with max: a nested select whose outer
      // branch is a constant stops the vectoriser.)
      const double fails =
          std::max(std::max(bad[j], dg == zero ? one : zero),
                   std::max(std::abs(dg) <= kMax ? zero : one,
                            std::max(tn >= ta[j] ? zero : one, tn <= tb[j] ? zero : one)));
      const double step = std::abs(tn - t[j]);
      const double done = step <= 1e-13 * (1 + std::abs(tn)) ? one : zero;
      const double on = act[j] != zero ? one - fails : zero;
      status[j] = act[j] != zero ? (fails != zero ? two : status[j]) : status[j];
      t[j] = on != zero ? tn : t[j];
      sx[j] = on != zero ? gx[j] : sx[j];
      sy[j] = on != zero ? gy[j] : sy[j];
      act[j] = on != zero ? one - done : zero;
    }
  }
  // Still iterating after 12 steps: not converged.
  for (int j = 0; j < n; ++j) {
    status[j] = act[j] != zero ? two : status[j];
    act[j] = status[j] == zero ? one : zero;
  }
  // The first-crossing check: g keeps its sign from the slab's entry to just before the root.
  // Proven from the bound on the sag's curvature (firstCrossingProven, the same expression), else
  // checked at 5 points along the ray: those only where a lane needs them.
  const double hb = hess_bound_;
  double g0[kLanes], first[kLanes], sag[kLanes], proven[kLanes];
  for (int j = 0; j < n; ++j) {
    const double xa = ox[j] + ta[j] * dx[j], ya = oy[j] + ta[j] * dy[j];
    const double xt = ox[j] + t[j] * dx[j], yt = oy[j] + t[j] * dy[j];
    const double slope = dz[j] - sx[j] * dx[j] - sy[j] * dy[j];
    const double curv = hb * (dx[j] * dx[j] + dy[j] * dy[j]);
    const double in_a = xa * xa + ya * ya <= bound2 ? one : zero;
    const double in_t = xt * xt + yt * yt <= bound2 ? one : zero;
    const double near = (t[j] - ta[j]) * curv < std::abs(slope) ? one : zero;
    proven[j] = std::min(std::min(in_a, in_t), near);
    first[j] = one;
  }
  bool check = false;
  for (int j = 0; j < n; ++j) check = check || (act[j] != zero && proven[j] == zero);
  for (int k = 0; k <= 4 && check; ++k) {
    for (int j = 0; j < n; ++j) {
      const double tk = k == 0 ? ta[j] : ta[j] + (t[j] - ta[j]) * k / 5.0;
      x[j] = ox[j] + tk * dx[j], y[j] = oy[j] + tk * dy[j], z[j] = oz[j] + tk * dz[j];
    }
    if (toroidal)
      toroidSagLanes<false>(c, a, shape_.poly, rot, bound2, n, x, y, sag, nullptr, nullptr, bad);
    else
      asphereSagLanes<false>(cx_, cy_, ax_, ay_, terms_, bound2, n, x, y, sag, nullptr, nullptr,
                             bad);
    if (k == 0)
      for (int j = 0; j < n; ++j) g0[j] = z[j] - sag[j];
    for (int j = 0; j < n; ++j) {
      const double gk = z[j] - sag[j];
      // gk != 0 with g0's sign (for k = 0: g0 != 0).
      const double same = gk < zero ? (g0[j] < zero ? one : zero)
                                    : (gk > zero ? (g0[j] > zero ? one : zero) : zero);
      first[j] = bad[j] != zero ? zero : std::min(first[j], same);
    }
  }
  for (int j = 0; j < n; ++j) {
    // The normal from the gradient at the last iterate (as intersect()).
    const double finite = std::abs(sx[j]) <= kMax ? (std::abs(sy[j]) <= kMax ? one : zero) : zero;
    const double len = std::sqrt(sx[j] * sx[j] + sy[j] * sy[j] + 1.0);  // |(sx, sy, -1)|
    nx[j] = sx[j] / len, ny[j] = sy[j] / len, nz[j] = -1.0 / len;
    const double ok = std::min(std::max(first[j], proven[j]), finite);
    status[j] = act[j] != zero ? (ok == zero ? two : status[j]) : status[j];
  }
}

SagGradient ShapeIntersector::sagContinued(double x, double y) const {
  const double r2 = x * x + y * y;
  if (r2 > bound_r_ * bound_r_) {
    // The flat annulus beyond the bound, at the rim's sag in this direction.
    const double s = bound_r_ / std::sqrt(r2);
    auto g = surfaceSag(radius_, shape_, x * s, y * s);
    if (!g && toroidal_)
      g = toroidSag(cy_, ay_, shape_.poly, *shape_.rotation_radius_mm, x * s, y * s, true);
    return {g ? g->z : 0.0, 0.0, 0.0};
  }
  if (toroidal_) {
    if (auto g = toroidSag(cy_, ay_, shape_.poly, *shape_.rotation_radius_mm, x, y, true))
      return *g;
    return {0.0, std::numeric_limits<double>::infinity(), 0.0};  // not reached inside bound_r_
  }
  // surfaceSag's formula with the coefficients cached (the hot path of the Newton solve).
  const double arg = std::max(0.0, 1 - ax_ * x * x - ay_ * y * y);
  const double S = std::sqrt(arg), N = cx_ * x * x + cy_ * y * y, den = 1 + S;
  SagGradient g;
  g.z = N / den;
  if (S > 0) {
    const double inv = 1 / (den * den), nS = N / S;
    g.dzdx = (2 * cx_ * x * den + nS * ax_ * x) * inv;
    g.dzdy = (2 * cy_ * y * den + nS * ay_ * y) * inv;
  } else {
    return *surfaceSag(radius_, shape_, x, y);  // the domain's rim (not inside bound_r_)
  }
  if (!terms_.empty()) {
    double slope_over_r;
    g.z += polynomialSag(r2, slope_over_r);
    g.dzdx += slope_over_r * x;
    g.dzdy += slope_over_r * y;
  }
  return g;
}

double ShapeIntersector::sagZ(double x, double y) const {
  const double r2 = x * x + y * y;
  // Inside the bound the plain asphere and the toroid have cheaper forms (no gradient: the same
  // z); elsewhere the full evaluation.
  if (r2 > bound_r_ * bound_r_) return sagContinued(x, y).z;
  if (toroidal_) {  // as sagContinued: 0 where the toroid is undefined (not reached inside)
    const auto g = toroidSag<false>(cy_, ay_, shape_.poly, *shape_.rotation_radius_mm, x, y, true);
    return g ? g->z : 0.0;
  }
  const double arg = 1 - ax_ * x * x - ay_ * y * y;
  if (!(arg > 0)) return sagContinued(x, y).z;
  const double z0 = (cx_ * x * x + cy_ * y * y) / (1 + std::sqrt(arg));
  if (terms_.empty()) return z0;
  double slope_over_r;
  return z0 + polynomialSag(r2, slope_over_r);  // as sagContinued adds it: the same value
}

double ShapeIntersector::polynomialSag(double r2, double& slope_over_r) const {
  const double r = std::sqrt(r2);
  double z = 0;
  slope_over_r = 0;
  double rk = 1;  // r^k; the terms come in increasing powers
  int k = 0;
  for (const auto& [p, a] : terms_) {
    if (p == 1) {
      z += a * r;
      if (r > 0) slope_over_r += a / r;
    } else {
      while (k < p - 2) rk *= r, ++k;
      z += a * rk * r2;
      slope_over_r += p * a * rk;
    }
  }
  return z;
}

std::optional<ShapeIntersector::Hit> ShapeIntersector::intersect(const Vec3& o, const Vec3& d,
                                                                 double t_min) const {
  // The part of the ray inside the slab.
  double ta, tb;
  if (std::abs(d.z) > 1e-12) {
    const double t0 = (z_lo_ - o.z) / d.z, t1 = (z_hi_ - o.z) / d.z;
    ta = std::min(t0, t1), tb = std::max(t0, t1);
  } else {
    if (o.z < z_lo_ || o.z > z_hi_) return std::nullopt;
    ta = t_min;
    tb = t_min + 4 * bound_r_ + std::sqrt(o.x * o.x + o.y * o.y);
  }
  ta = std::max(ta, t_min);
  if (!(ta <= tb)) return std::nullopt;
  if (quadric_) {
    if (auto t = quadricRoot(o, d, t_min)) {
      const Vec3 p = o + d * *t;
      // Normal from the quadric's gradient (2 cx x, 2 cy y, 2 e z - 2), facing -z.
      return Hit{*t, normalize(Vec3{qcx_ * p.x, qcy_ * p.y, qe_ * p.z - 1})};
    }
    // No vertex-sheet hit: the general search below finds the continuation beyond bound_r.
  }
  auto g = [&](double t, SagGradient* sg) { return alongRay(o, d, t, sg); };
  // Aspheres on a quadric base: Newton's method from the base quadric's hit, accepted when it
  // converges inside the slab and g keeps its sign from the slab's entry to just before the root
  // (from the bound on the sag's curvature, else checked at 5 points; so the root is the first
  // crossing); else the bracketing search below.
  if (base_quadric_ && !quadric_) {
    if (auto tq = quadricRoot(o, d, t_min); tq && *tq >= ta && *tq <= tb) {
      double t = *tq;
      bool converged = false;
      SagGradient s;  // at the last iterate before t
      for (int it = 0; it < 12; ++it) {
        const double gt = g(t, &s);
        const double dg = d.z - s.dzdx * d.x - s.dzdy * d.y;
        if (dg == 0 || !std::isfinite(dg)) break;
        const double tn = t - gt / dg;
        if (!(tn >= ta && tn <= tb)) break;
        const double step = std::abs(tn - t);
        t = tn;
        if (step <= 1e-13 * (1 + std::abs(t))) {
          converged = true;
          break;
        }
      }
      if (converged) {
        // Else g's sign at the slab's entry and 4 points up to the root.
        bool first = firstCrossingProven(o.x, o.y, d.x, d.y, d.z, ta, t, s.dzdx, s.dzdy);
        if (!first) {
          const double g0 = g(ta, nullptr);
          first = g0 != 0;
          for (int k = 1; k <= 4 && first; ++k) {
            const double gk = g(ta + (t - ta) * k / 5.0, nullptr);
            first = gk != 0 && (gk < 0) == (g0 < 0);
          }
        }
        if (first) {
          // The normal from the gradient at the last iterate, which lies within 1e-13 (1 + |t|)
          // of t: no further evaluation.
          const Vec3 n{s.dzdx, s.dzdy, -1.0};
          if (std::isfinite(n.x) && std::isfinite(n.y)) return Hit{t, normalize(n)};
        }
      }
    }
  }
  // The first crossing along the ray: a bracket [a, b] of it (g(a) and g(b) of opposite signs, or
  // g(a) = 0), in the parts of [ta, tb] before, inside and after the cylinder of radius bound_r
  // in turn. Inside it the sag is smooth and the bound on its curvature isolates the first root
  // (firstBracketInside); outside it (the flat continuation, and inside for a surface without
  // the bound) the first sign change over 16 samples.
  double a = ta, ga = 0, b = ta, gb = 0;
  bool found = false;
  auto sampled = [&](double lo, double hi) {
    constexpr int kSamples = 16;
    a = lo, ga = g(lo, nullptr), b = lo, gb = ga;
    if (ga == 0) return true;
    for (int k = 1; k <= kSamples; ++k) {
      b = lo + (hi - lo) * k / kSamples;
      gb = g(b, nullptr);
      if (gb == 0 || (gb < 0) != (ga < 0)) return true;
      a = b, ga = gb;
    }
    return false;
  };
  // The ray inside the cylinder: t in [c0, c1].
  double c0 = tb, c1 = tb;
  {
    const double A = d.x * d.x + d.y * d.y, B = o.x * d.x + o.y * d.y;
    const double C = o.x * o.x + o.y * o.y - bound_r_ * bound_r_;
    if (A == 0) {
      if (C <= 0) c0 = ta;
    } else if (const double disc = B * B - A * C; disc >= 0) {
      const double q = std::sqrt(disc);
      c0 = std::clamp((-B - q) / A, ta, tb), c1 = std::clamp((-B + q) / A, ta, tb);
    }
  }
  if (c0 > ta) found = sampled(ta, c0);
  if (!found && c1 > c0) {
    found = std::isfinite(hess_bound_) ? firstBracketInside(o, d, c0, c1, a, ga, b, gb)
                                       : sampled(c0, c1);
  }
  if (!found && tb > c1) found = sampled(c1, tb);
  if (!found) return std::nullopt;
  double t;
  if (ga == 0) {
    t = a;
  } else if (gb == 0) {
    t = b;
  } else {
    // Newton's method kept inside the bracket [a, b] (bisection when a step leaves it).
    t = a - ga * (b - a) / (gb - ga);  // start from the secant
    for (int it = 0; it < 60; ++it) {
      SagGradient s;
      const double gt = g(t, &s);
      if (gt == 0) break;
      if ((gt < 0) == (ga < 0))
        a = t, ga = gt;
      else
        b = t, gb = gt;
      const double dg = d.z - s.dzdx * d.x - s.dzdy * d.y;
      double tn = dg != 0 ? t - gt / dg : 0.5 * (a + b);
      if (!(tn > a && tn < b)) tn = 0.5 * (a + b);
      const double step = std::abs(tn - t);
      t = tn;
      if (step <= 1e-14 * (1 + std::abs(t)) || b - a <= 1e-14 * (1 + std::abs(t))) break;
    }
  }
  SagGradient s;
  g(t, &s);
  Vec3 n{s.dzdx, s.dzdy, -1.0};
  if (!std::isfinite(n.x) || !std::isfinite(n.y)) return std::nullopt;
  return Hit{t, normalize(n)};
}

}  // namespace lensim::optics
