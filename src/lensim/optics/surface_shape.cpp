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

// Scalar and batched code are one source here: each kernel below works on lanes [0, n) of
// arrays, in loops over the lanes with conditions as 0/1 doubles (selects that GCC vectorises,
// unlike branches), and a scalar evaluation is the kernel on one lane (docs/developer-guide.md,
// "Scalar and batched code").
constexpr int kLanes = ShapeIntersector::kLanes;
constexpr double kInf = std::numeric_limits<double>::infinity();

// The toroid (see the header for the definition and its source) at (x[j], y[j]): the y-z curve
// f = c y^2 / (1 + S) + sum_k a_k y^k with S = sqrt(1 - a y^2), a = (1 + k) c^2, and its slope
// f' = c y / S + sum_k k a_k y^(k-1); then z = f + x^2 / (rho + q) with rho = rot - f(y) and
// q = sgn(rho) sqrt(rho^2 - x^2), gradient dz/dx = x / q, dz/dy = rho f' / q (from
// q^2 = rho^2 - x^2); rot = 0: the cylinder z = f(y). Writes z and, with kGradient, gx and gy.
// bad[j] is 1 off the common path: x^2 + y^2 > bound2, S not positive or rho^2 - x^2 not
// positive (the batched intersector leaves those lanes to intersect()).
// kRim, for the one-lane evaluations: defined[j] is 0 where the sag is undefined (1 - a y^2 < 0;
// rho^2 - x^2 < 0 unless kClamp, which takes it as 0: just outside the domain, from the sampled
// domain radius; the curve meeting the axis of rotation), and the slopes at the rim of the domain
// (S = 0, q = 0) are infinite.
template <bool kGradient, bool kRim = false, bool kClamp = true>
[[gnu::always_inline]] inline void toroidSagLanes(double c, double a,
                                                  const std::vector<double>& poly, double rot,
                                                  double bound2, int n, const double* x,
                                                  const double* y, double* z, double* gx,
                                                  double* gy, double* bad,
                                                  double* defined = nullptr) {
  double f[kLanes], df[kLanes], yp[kLanes];
  for (int j = 0; j < n; ++j) {
    const double xj = x[j], yj = y[j];
    const double arg = 1 - a * yj * yj;
    bad[j] = std::max(xj * xj + yj * yj > bound2 ? 1.0 : 0.0, arg > 0 ? 0.0 : 1.0);
    const double S = std::sqrt(std::max(arg, 0.0));
    f[j] = c * yj * yj / (1 + S);
    if constexpr (!kGradient)
      df[j] = 0;
    else if constexpr (kRim)
      df[j] = S > 0 ? c * yj / S : (yj != 0 ? std::copysign(kInf, c * yj) : 0.0);
    else
      df[j] = c * yj / S;
    if constexpr (kRim) defined[j] = arg < 0 ? 0.0 : 1.0;
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
  if (rot == 0) {  // a cylinder: the y curve itself (gx, gy may be null without kGradient)
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
    if constexpr (kRim)
      defined[j] = (kClamp || !(d < 0)) && rho + q != 0 ? defined[j] : 0.0;
    if constexpr (kGradient) {
      if constexpr (kRim) {
        if (q == 0) {  // the rim of the domain: vertical
          gx[j] = xj != 0 ? std::copysign(kInf, xj * rho) : 0.0;
          gy[j] = df[j] != 0 ? std::copysign(kInf, rho * df[j]) : 0.0;
          continue;
        }
      }
      gx[j] = xj / q;
      gy[j] = rho * df[j] / q;
    }
  }
}

// The toroid's sag at one point (toroidSagLanes on one lane); nullopt where it is undefined.
// kGradient false: the sag only (the gradient left 0; z the same value).
template <bool kGradient = true, bool kClamp = true>
std::optional<SagGradient> toroidSag(double c, double a, const std::vector<double>& poly,
                                     double rot, double x, double y) {
  SagGradient g;
  double bad, defined;
  toroidSagLanes<kGradient, true, kClamp>(c, a, poly, rot, kInf, 1, &x, &y, &g.z, &g.dzdx,
                                          &g.dzdy, &bad, &defined);
  if (defined == 0) return std::nullopt;
  return g;
}

// ShapeIntersector's sag of an asphere on a conic base (the biconic formula with the polynomial
// terms, powers of r) at (x[j], y[j]): z and with kGradient gx, gy (null without); bad[j] is 1
// off the common path (r^2 > bound2, the conic's square root not positive), where
// sagContinued's flat continuation or the rim of the domain apply.
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
      // d/dx [N / (1 + S)] = (2 cx x (1 + S) - N dS/dx) / (1 + S)^2 with dS/dx = -ax x / S.
      const double inv = 1 / (den * den), nS = N / S;
      gx[j] = (2 * cx * xj * den + nS * ax * xj) * inv;
      gy[j] = (2 * cy * yj * den + nS * ay * yj) * inv;
    }
  }
  if (terms.empty()) return;
  // The terms in increasing powers, r^(p-2) kept in rk; slope: the radial slope over r.
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

// The slab [z_lo, z_hi] along a ray not parallel to it: the ray parameters [ta, tb] inside it,
// from t_min on.
[[gnu::always_inline]] inline void slabOf(double z_lo, double z_hi, double oz, double dz,
                                          double t_min, double& ta, double& tb) {
  const double t0 = (z_lo - oz) / dz, t1 = (z_hi - oz) / dz;
  ta = std::max(std::min(t0, t1), t_min), tb = std::max(t0, t1);
}

// The quadric cx x^2 + cy y^2 + e z^2 - 2 z = 0's first root t >= t_min along o + t d on its
// vertex sheet (1 - e z > 0), from A t^2 + 2 B t + C = 0 with the stable roots. Returns 1 where
// there is one (t set), else 0. kLinear: with the one root of A = 0 (B != 0) too (one lane: the
// batched intersector leaves those rays to intersect()).
template <bool kLinear>
[[gnu::always_inline]] inline double quadricHit(double cx, double cy, double e, double ox,
                                                double oy, double oz, double dx, double dy,
                                                double dz, double t_min, double& t) {
  const double A = cx * dx * dx + cy * dy * dy + e * dz * dz;
  const double B = cx * ox * dx + cy * oy * dy + e * oz * dz - dz;
  const double C = cx * ox * ox + cy * oy * oy + e * oz * oz - 2 * oz;
  if constexpr (kLinear) {
    if (A == 0) {
      t = -C / (2 * B);
      return B != 0 && t >= t_min && 1 - e * (oz + t * dz) > 0 ? 1.0 : 0.0;
    }
  }
  const double disc = B * B - A * C;
  const double q = -(B + std::copysign(std::sqrt(std::max(disc, 0.0)), B));
  const double r0 = q / A, r1 = q != 0 ? C / q : r0;
  const double lo = std::min(r0, r1), hi = std::max(r0, r1);
  const double ok_lo = lo >= t_min ? (1 - e * (oz + lo * dz) > 0 ? 1.0 : 0.0) : 0.0;
  const double ok_hi = hi >= t_min ? (1 - e * (oz + hi * dz) > 0 ? 1.0 : 0.0) : 0.0;
  t = ok_lo != 0 ? lo : hi;
  return A != 0 ? (disc >= 0 ? std::max(ok_lo, ok_hi) : 0.0) : 0.0;
}

double toroidA(double radius_mm, const SurfaceShape& shape) {
  const double c = radius_mm != 0 ? 1 / radius_mm : 0.0;
  return (1 + shape.conic) * c * c;
}

}  // namespace

std::optional<SagGradient> surfaceSag(double radius_mm, const SurfaceShape& shape, double x,
                                      double y) {
  if (shape.isToroidal())
    return toroidSag<true, false>(radius_mm != 0 ? 1 / radius_mm : 0.0, toroidA(radius_mm, shape),
                                  shape.poly, *shape.rotation_radius_mm, x, y);
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
      const auto f = toroidSag<false>(c, a, shape.poly, 0.0, 0.0, y);  // rot 0: the y curve
      if (!f) break;
      best = std::min(best, std::hypot(rot - f->z, y));
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
    // The quadric with the toroid's vertex curvatures and the y curve's conic predicts the hit
    // that Newton's method refines, as for the aspheres. A cylinder (R = 0) without polynomial
    // terms is that quadric: its hits are the closed form's, at any x (its sag is defined for
    // every x, not only within bound_r).
    const double c = radius_mm != 0 ? 1 / radius_mm : 0.0;
    const double rot = *shape.rotation_radius_mm;
    base_quadric_ = true;
    quadric_ = rot == 0 && !shape.hasPolynomial();
    qcx_ = rot != 0 ? 1 / rot : 0.0, qcy_ = c;
    qe_ = c != 0 ? (1 + shape.conic) * c : qcx_;
    if (!quadric_) boundSagCurvature();
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

// The sag and, with kGradient, its gradient at lanes [0, n) of (x, y), inside bound_r on the
// common path (asphereSagLanes, toroidSagLanes); bad[j] 1 elsewhere. kOne: one lane (intersect()
// and the scalar sag), where a point off that path takes sagContinued's value (the flat
// continuation, the rim of the domain) instead of being marked.
template <bool kGradient, bool kOne>
[[gnu::always_inline]] inline void ShapeIntersector::sagLanes(int n, const double* x,
                                                              const double* y, double* z,
                                                              double* gx, double* gy,
                                                              double* bad) const {
  const double bound2 = bound_r_ * bound_r_;
  auto continued = [&] {
    const SagGradient g = sagContinued(x[0], y[0]);
    z[0] = g.z;
    if constexpr (kGradient) gx[0] = g.dzdx, gy[0] = g.dzdy;
    bad[0] = 0;
  };
  if constexpr (kOne) {
    if (x[0] * x[0] + y[0] * y[0] > bound2) return continued();  // no kernel to run there
  }
  if (toroidal_)
    toroidSagLanes<kGradient>(cy_, ay_, shape_.poly, *shape_.rotation_radius_mm, bound2, n, x, y,
                              z, gx, gy, bad);
  else
    asphereSagLanes<kGradient>(cx_, cy_, ax_, ay_, terms_, bound2, n, x, y, z, gx, gy, bad);
  if constexpr (kOne) {
    if (bad[0] != 0) continued();  // the rim of the domain
  }
}

// The Newton solve of a toroid or an asphere on a quadric base for lanes [0, n): from the base
// quadric's hit t[j] (lanes with status[j] 0; the others are left alone), kept inside the slab
// [ta[j], tb[j]], then the first-crossing check. On success t[j] is the root and n the unit
// normal from the gradient at the last iterate (within 1e-13 (1 + |t|) of t: no further
// evaluation); else status[j] is 2: Newton's method leaving the slab or not converging in 12
// steps, a zero or infinite slope, a sign change before the root, and without kOne a point off
// the sag's common path (sagLanes).
//
// The first-crossing check: g(tau) = z(tau) - sag(x(tau), y(tau)) along the ray has
// |g''| <= H |d_xy|^2 (H the bound on the Hessian's norm) wherever the path stays inside the disc
// of radius bound_r (so from ta to t when both ends do: the disc is convex), so that
// g(t - delta) = g(t) - g'(t) delta + e with |e| <= H |d_xy|^2 delta^2 / 2: g keeps the sign of
// -g'(t) for delta up to 2 |g'(t)| / (H |d_xy|^2). Asked for half of that (g'(t) is taken from
// the gradient at the last iterate), on [ta, t), the root is proven the first crossing after the
// slab's entry. Near the axis and at the usual angles it holds by a wide margin (a lens's ray
// crosses a slab a few millimetres deep at a slope well below 1, where g'' is a few hundredths of
// g'); where it does not, g's sign is checked at the slab's entry and 4 points up to the root.
template <bool kOne>
[[gnu::always_inline]] inline void ShapeIntersector::newtonLanes(
    int n, const double* __restrict ox, const double* __restrict oy, const double* __restrict oz,
    const double* __restrict dx, const double* __restrict dy, const double* __restrict dz,
    const double* __restrict ta, const double* __restrict tb, double* __restrict t,
    double* __restrict nx, double* __restrict ny, double* __restrict nz,
    double* __restrict status) const {
  const double zero = 0, one = 1, two = 2, kMax = std::numeric_limits<double>::max();
  const double bound2 = bound_r_ * bound_r_;
  double act[kLanes], sx[kLanes], sy[kLanes];
  double x[kLanes], y[kLanes], z[kLanes], gx[kLanes], gy[kLanes], bad[kLanes];
  // Whether any lane is still iterating (a loop of its own: a reduction in the lanes' loops
  // would stop their vectorisation).
  auto anyActive = [&] {
    bool any = false;
    for (int j = 0; j < n; ++j) any = any || act[j] != zero;
    return any;
  };
  for (int j = 0; j < n; ++j) act[j] = status[j] == zero ? one : zero, sx[j] = sy[j] = zero;
  for (int it = 0; it < 12 && anyActive(); ++it) {
    for (int j = 0; j < n; ++j) x[j] = ox[j] + t[j] * dx[j], y[j] = oy[j] + t[j] * dy[j];
    sagLanes<true, kOne>(n, x, y, z, gx, gy, bad);
    for (int j = 0; j < n; ++j) {
      const double gt = oz[j] + t[j] * dz[j] - z[j];
      const double dg = dz[j] - gx[j] * dx[j] - gy[j] * dy[j];
      const double tn = t[j] - gt / dg;
      // (0/1 values combined with max: a nested select whose outer branch is a constant stops
      // the vectoriser.)
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
  // The first-crossing check (above): the proof, else g's sign at 5 points along the ray, those
  // only where a lane needs them.
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
    sagLanes<false, kOne>(n, x, y, sag, nullptr, nullptr, bad);
    if (k == 0)
      for (int j = 0; j < n; ++j) g0[j] = z[j] - sag[j];
    for (int j = 0; j < n; ++j) {
      const double gk = z[j] - sag[j];
      // gk != 0 with g0's sign (for k = 0: g0 != 0).
      const double same = gk < zero ? (g0[j] < zero ? one : zero)
                                    : (gk > zero ? (g0[j] > zero ? one : zero) : zero);
      first[j] = bad[j] != zero ? zero : std::min(first[j], same);
    }
    if constexpr (kOne) check = first[0] != zero;  // (intersect() stops at the first failure)
  }
  for (int j = 0; j < n; ++j) {
    const double finite = std::abs(sx[j]) <= kMax ? (std::abs(sy[j]) <= kMax ? one : zero) : zero;
    const double len = std::sqrt(sx[j] * sx[j] + sy[j] * sy[j] + 1.0);  // |(sx, sy, -1)|
    nx[j] = sx[j] / len, ny[j] = sy[j] / len, nz[j] = -1.0 / len;
    const double ok = std::min(std::max(first[j], proven[j]), finite);
    status[j] = act[j] != zero ? (ok == zero ? two : status[j]) : status[j];
  }
}

double ShapeIntersector::alongRay(const Vec3& o, const Vec3& d, double t, SagGradient* sg) const {
  const double x = o.x + t * d.x, y = o.y + t * d.y;
  if (!sg) return o.z + t * d.z - sagZ(x, y);
  *sg = sagContinued(x, y);
  return o.z + t * d.z - sg->z;
}

// The first root of g(t) = z(t) - sag(x(t), y(t)) on [lo, hi], a part of the ray inside the disc
// of radius bound_r, isolated with the bound on g'' (H |d_xy|^2, as newtonLanes' proof): the
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
  double t;
  if (quadricHit<true>(qcx_, qcy_, qe_, o.x, o.y, o.z, d.x, d.y, d.z, t_min, t) == 0)
    return std::nullopt;
  return t;
}

__attribute__((target_clones("avx2", "default"))) void ShapeIntersector::intersectLanes(
    int n, const double* __restrict ox, const double* __restrict oy, const double* __restrict oz,
    const double* __restrict dx, const double* __restrict dy, const double* __restrict dz,
    double t_min, double* __restrict t, double* __restrict nx, double* __restrict ny,
    double* __restrict nz, double* __restrict status) const {
  // intersect()'s kernels on the lanes; a lane that would take another branch there is given
  // status 2 and intersect() traces it.
  const double zero = 0, one = 1, two = 2;
  // Members as locals: the compiler cannot tell that the stores below leave them alone.
  const bool quadric = quadric_;
  const double quad = quadric ? one : zero;  // (a select on a bool stops the vectoriser)
  const double cx = qcx_, cy = qcy_, e = qe_, z_lo = z_lo_, z_hi = z_hi_;
  n = std::min(n, kLanes);
  double ta[kLanes], tb[kLanes];
  for (int j = 0; j < n; ++j) {
    slabOf(z_lo, z_hi, oz[j], dz[j], t_min, ta[j], tb[j]);
    const double flat = std::abs(dz[j]) > 1e-12 ? zero : one;
    const double crosses = ta[j] <= tb[j] ? one : zero;
    double tq;
    const double root =
        quadricHit<false>(cx, cy, e, ox[j], oy[j], oz[j], dx[j], dy[j], dz[j], t_min, tq);
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
  newtonLanes<false>(n, ox, oy, oz, dx, dy, dz, ta, tb, t, nx, ny, nz, status);
}

SagGradient ShapeIntersector::sagContinued(double x, double y) const {
  const double r2 = x * x + y * y;
  if (r2 > bound_r_ * bound_r_) {
    // The flat annulus beyond the bound, at the rim's sag in this direction.
    const double s = bound_r_ / std::sqrt(r2);
    auto g = surfaceSag(radius_, shape_, x * s, y * s);
    if (!g && toroidal_)
      g = toroidSag(cy_, ay_, shape_.poly, *shape_.rotation_radius_mm, x * s, y * s);
    return {g ? g->z : 0.0, 0.0, 0.0};
  }
  SagGradient g;
  double bad;
  sagLanes<true, false>(1, &x, &y, &g.z, &g.dzdx, &g.dzdy, &bad);
  if (bad == 0) return g;
  // The rim of the domain (not reached inside bound_r_).
  if (toroidal_) {
    if (auto t = toroidSag(cy_, ay_, shape_.poly, *shape_.rotation_radius_mm, x, y)) return *t;
    return {0.0, std::numeric_limits<double>::infinity(), 0.0};
  }
  return *surfaceSag(radius_, shape_, x, y);
}

double ShapeIntersector::sagZ(double x, double y) const {
  double z, bad;
  sagLanes<false, true>(1, &x, &y, &z, nullptr, nullptr, &bad);
  return z;
}

// The intersection with a ray's general path: the slab, a quadric's closed form, the Newton solve
// from the base quadric (newtonLanes on one lane), else the bracketed first crossing.
std::optional<ShapeIntersector::Hit> ShapeIntersector::intersect(const Vec3& o, const Vec3& d,
                                                                 double t_min) const {
  // The part of the ray inside the slab.
  double ta, tb;
  if (std::abs(d.z) > 1e-12) {
    slabOf(z_lo_, z_hi_, o.z, d.z, t_min, ta, tb);
  } else {
    if (o.z < z_lo_ || o.z > z_hi_) return std::nullopt;
    ta = t_min;
    tb = t_min + 4 * bound_r_ + std::sqrt(o.x * o.x + o.y * o.y);
  }
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
  // Aspheres on a quadric base and toroids: Newton's method from the base quadric's hit inside
  // the slab, accepted when it converges and is the first crossing (newtonLanes); else the
  // bracketing search below.
  if (base_quadric_ && !quadric_) {
    if (auto tq = quadricRoot(o, d, t_min); tq && *tq >= ta && *tq <= tb) {
      double t = *tq, status = 0;
      Vec3 n;
      newtonLanes<true>(1, &o.x, &o.y, &o.z, &d.x, &d.y, &d.z, &ta, &tb, &t, &n.x, &n.y, &n.z,
                        &status);
      if (status == 0) return Hit{t, n};
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
