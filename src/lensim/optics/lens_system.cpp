#include "lensim/optics/lens_system.h"

#include "lensim/optics/refraction.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>

namespace lensim::optics {

const char* blockReasonName(BlockReason r) {
  switch (r) {
    case BlockReason::None:
      return "none";
    case BlockReason::Aperture:
      return "aperture";
    case BlockReason::Miss:
      return "miss";
    case BlockReason::TotalInternalReflection:
      return "tir";
    case BlockReason::Obscured:
      return "obscured";
    case BlockReason::Evanescent:
      return "evanescent";
  }
  return "none";
}

// ---------------------------------------------------------------------------------------------
// Exact tracer

template <typename T>
LensTracer<T>::LensTracer(const std::vector<Interface>& interfaces) {
  for (const Interface& s : interfaces) {
    radius_.push_back(T(s.radius_mm));
    inv_radius_.push_back(s.radius_mm != 0 ? T(1 / s.radius_mm) : T(0));
    z_.push_back(T(s.z_mm));
    semi2_.push_back(T(s.semi_aperture_mm * s.semi_aperture_mm));
    inner2_.push_back(T(s.obscuration_radius_mm * s.obscuration_radius_mm));
    aperture_shape_.push_back(s.aperture_shape);
    half_x_.push_back(T(s.aperture_half_x_mm));
    half_y_.push_back(T(s.aperture_half_y_mm));
    const bool shaped_aperture = s.aperture_shape != ApertureShape::Circle;
    eta_before_.push_back(T(s.ior_before));
    eta_after_.push_back(T(s.ior_after));
    is_stop_.push_back(s.is_stop ? 1 : 0);
    is_mirror_.push_back(s.is_mirror ? 1 : 0);
    if (s.is_mirror) reversed_ = !reversed_;
    lanes_.push_back(0);
    if (s.shape.isSpherical()) {
      shape_index_.push_back(-1);
    } else {
      shape_index_.push_back(static_cast<int>(shapes_.size()));
      shapes_.emplace_back(s.radius_mm, s.shape, s.semi_aperture_mm);
      if (!s.is_mirror && s.obscuration_radius_mm == 0 && !shaped_aperture &&
          shapes_.back().hasLanes())
        lanes_.back() = 1;
    }
    per_lane_.push_back(shape_index_.back() >= 0 || s.is_mirror || s.obscuration_radius_mm > 0 ||
                        shaped_aperture);
  }
  if (!interfaces.empty()) z_unfold_ = T(2 * interfaces.back().z_mm);
}

template <typename T>
void LensTracer<T>::setIndices(const double* before, const double* after) {
  for (int i = 0; i < size(); ++i) eta_before_[i] = T(before[i]), eta_after_[i] = T(after[i]);
}

namespace {

// The smallest distance along a ray at which a surface counts as hit (slightly negative, so that a
// ray starting on a surface finds it), by the tracer's precision.
template <typename T>
constexpr double kTMin = std::is_same_v<T, float> ? -1e-4 : -1e-9;

// One surface's term of a ray's margin (LensTracer::marginSquared): (r / semi-aperture)^2 at the
// hit (infinite for a zero semi-aperture off the axis, 0 on it) and, where the ray goes into a
// rarer medium (rarer 1, else 0), sin^2 of the refracted angle. Branch-free, so that the batch
// loops vectorise.
template <typename T>
[[gnu::always_inline]] inline T marginTerm(T r2, T semi2, T sin2_t, T rarer) {
  const T ra = r2 / semi2;  // 0 / 0 on the axis of a zero aperture: NaN, taken as 0
  return std::max(ra != ra ? T(0) : ra, sin2_t * rarer);
}

// refract() for one lane of a batch, branch-free (the same operations, so the same results):
// the direction (dx, dy, dz) refracted at the unit normal n (either orientation) into e, where
// `refracts` is 1 (else e = d); sin2_t: sin^2 of the refracted angle; tir: 1 where totally
// reflected (and refracting).
template <typename T>
[[gnu::always_inline]] inline void refractLane(T dx, T dy, T dz, T nx, T ny, T nz, T eta,
                                               T refracts, T& ex, T& ey, T& ez, T& sin2_t, T& tir) {
  const T zero(0), one(1);
  T cos_i = -(nx * dx + ny * dy + nz * dz);
  const T s = cos_i < zero ? -one : one;
  cos_i *= s;
  sin2_t = eta * eta * std::max(zero, one - cos_i * cos_i);
  tir = sin2_t >= one ? refracts : zero;
  const T cos_t = std::sqrt(std::max(zero, one - sin2_t));
  const T k = (eta * cos_i - cos_t) * s;
  ex = refracts != zero ? dx * eta + nx * k : dx;
  ey = refracts != zero ? dy * eta + ny * k : dy;
  ez = refracts != zero ? dz * eta + nz * k : dz;
}

// A refracting non-spherical surface that ShapeIntersector intersects side by side (a quadric:
// a cylinder or a conic; a toroid or an asphere on a quadric base) for lanes [0, nv): the same
// operations as traceShaped (in double precision: direction normalised,
// ShapeIntersector::intersectLanes for intersect(), clipping at the clear aperture, refraction as
// refract()), so the same results. Lanes that intersectLanes does not decide are marked in
// one_by_one for the caller to trace one by one; lanes not alive are not solved (fate 1, their
// other values unset). kMargin: no clipping, and each lane's margin term (as
// LensTracer::marginSquared) in term.
template <typename T, bool kMargin>
[[gnu::always_inline]] inline void shapeLanes(const ShapeIntersector& shape, T zv, T semi2, T eta_i,
                                              T eta_t, int nv, const bool* alive, const T* ox,
                                              const T* oy, const T* oz, const T* dx, const T* dy,
                                              const T* dz, T* px, T* py, T* pz, T* ex, T* ey, T* ez,
                                              T* fate, T* term, bool* one_by_one) {
  constexpr int kLanes = ShapeIntersector::kLanes;
  static_assert(kLanes >= LensTracer<T>::kBatch);
  const double t_min = kTMin<T>, zero = 0, one = 1;
  const double eta = double(eta_i) / double(eta_t);
  const double refracts = double(eta_i) != double(eta_t) ? one : zero;
  const T rarer = eta_i > eta_t ? T(1) : T(0);
  // The live lanes packed to the front (a toroid's Newton solve costs every lane it is given),
  // padded to a multiple of 4 with copies of the first.
  int idx[kLanes], m = 0;
  for (int j = 0; j < nv; ++j) {
    one_by_one[j] = false, fate[j] = T(1);
    if (alive[j]) idx[m++] = j;
  }
  if (m == 0) return;
  const int mv = std::min(kLanes, (m + 3) & ~3);
  for (int i = m; i < mv; ++i) idx[i] = idx[0];
  double rx[kLanes], ry[kLanes], rz[kLanes], ux[kLanes], uy[kLanes], uz[kLanes];
  double t[kLanes], nx[kLanes], ny[kLanes], nz[kLanes], status[kLanes];
  for (int i = 0; i < mv; ++i) {
    const int j = idx[i];
    const double x = double(dx[j]), y = double(dy[j]), z = double(dz[j]);
    const double len = std::sqrt(x * x + y * y + z * z);
    ux[i] = x / len, uy[i] = y / len, uz[i] = z / len;
    rx[i] = double(ox[j]), ry[i] = double(oy[j]), rz[i] = double(oz[j]) - double(zv);
  }
  shape.intersectLanes(mv, rx, ry, rz, ux, uy, uz, t_min, t, nx, ny, nz, status);
  T qx[kLanes], qy[kLanes], qz[kLanes], fx[kLanes], fy[kLanes], fz[kLanes], fa[kLanes],
      tm[kLanes] = {};
  for (int i = 0; i < mv; ++i) {
    const double hx = rx[i] + ux[i] * t[i], hy = ry[i] + uy[i] * t[i], hz = rz[i] + uz[i] * t[i];
    qx[i] = T(hx), qy[i] = T(hy), qz[i] = T(hz + double(zv));
    const double inside = kMargin || hx * hx + hy * hy <= double(semi2) ? one : zero;
    double sin2_t, tir, e[3];
    refractLane(ux[i], uy[i], uz[i], nx[i], ny[i], nz[i], eta, refracts, e[0], e[1], e[2], sin2_t,
                tir);
    fx[i] = T(e[0]), fy[i] = T(e[1]), fz[i] = T(e[2]);
    if constexpr (kMargin)
      tm[i] = marginTerm(qx[i] * qx[i] + qy[i] * qy[i], semi2, T(sin2_t), rarer);
    fa[i] = status[i] == one ? T(1) : (inside != zero ? (tir != zero ? T(3) : T(0)) : T(2));
  }
  for (int i = 0; i < m; ++i) {
    const int j = idx[i];
    px[j] = qx[i], py[j] = qy[i], pz[j] = qz[i], ex[j] = fx[i], ey[j] = fy[i], ez[j] = fz[i];
    fate[j] = fa[i], one_by_one[j] = status[i] == 2;
    if constexpr (kMargin) term[j] = tm[i];
  }
}

// The lanes [0, nv) of a batch (LensTracer::traceBatch) at a plane (the stop) at z = zv: the hit
// (p), the direction after it (e; refracted only when kRefract, between different indices, which
// a stop rarely has: the common case has no refraction, which vectorises) and each lane's fate
// (0 through, 1 miss, 2 aperture, 3 total internal reflection). kMargin: no clipping, and each
// lane's margin term in term. Branch-free, so that the loop vectorises.
template <typename T, bool kMargin, bool kRefract>
[[gnu::always_inline]] inline void planeLanes(T zv, T semi2, T eta, T rarer, int nv, const T* ox,
                                              const T* oy, const T* oz, const T* dx, const T* dy,
                                              const T* dz, T* px, T* py, T* pz, T* ex, T* ey, T* ez,
                                              T* fate, T* term) {
  const T t_min = T(kTMin<T>);
  const T zero(0), one(1);
  for (int j = 0; j < nv; ++j) {
    const T rz = oz[j] - zv;
    const T tq = -rz / dz[j];  // inf or NaN when dz is 0: dropped by the select
    const T t = dz[j] != zero ? tq : zero;
    const T hit = dz[j] != zero ? (t >= t_min ? one : zero) : zero;
    px[j] = ox[j] + dx[j] * t, py[j] = oy[j] + dy[j] * t, pz[j] = oz[j] + dz[j] * t;
    const T r2 = px[j] * px[j] + py[j] * py[j];
    const T inside = kMargin || r2 <= semi2 ? one : zero;
    T tir = zero, sin2_t = zero;
    if constexpr (kRefract) {  // the normal (0, 0, -1)
      refractLane(dx[j], dy[j], dz[j], zero, zero, -one, eta, one, ex[j], ey[j], ez[j], sin2_t,
                  tir);
    } else {
      ex[j] = dx[j], ey[j] = dy[j], ez[j] = dz[j];
    }
    if constexpr (kMargin) term[j] = marginTerm(r2, semi2, sin2_t, rarer);
    fate[j] = hit != zero ? (inside != zero ? (tir != zero ? T(3) : zero) : T(2)) : one;
  }
}

// The lanes [0, nv) of a batch at a sphere of radius R (inverse inv_r) with its vertex at z = zv,
// refracting where `refracts` is 1: outputs as planeLanes. The same operations as the scalar
// trace (intersection, clipping at the clear aperture, refract()), branch-free.
template <typename T, bool kMargin>
[[gnu::always_inline]] inline void sphereLanes(T R, T inv_r, T zv, T semi2, T eta, T refracts,
                                               T rarer, int nv, const T* ox, const T* oy,
                                               const T* oz, const T* dx, const T* dy, const T* dz,
                                               T* px, T* py, T* pz, T* ex, T* ey, T* ez, T* fate,
                                               T* term) {
  const T t_min = T(kTMin<T>);
  const T zero(0), one(1);
  for (int j = 0; j < nv; ++j) {
    const T rz = oz[j] - zv;
    const T b = ox[j] * dx[j] + oy[j] * dy[j] + rz * dz[j] - R * dz[j];
    const T c = ox[j] * ox[j] + oy[j] * oy[j] + rz * rz - T(2) * R * rz;
    const T disc = b * b - c;
    const T root = std::sqrt(std::max(disc, zero));
    const T q = -(b + (b < zero ? -root : root));  // copysign(root, b) for b != -0
    const T cq = c / q;  // inf or NaN when q is 0: dropped by the select
    const T t0 = q, t1 = q != zero ? cq : zero;
    const T ok0 = t0 >= t_min ? ((rz + t0 * dz[j] - R) * R < zero ? one : zero) : zero;
    const T ok1 = t1 >= t_min ? ((rz + t1 * dz[j] - R) * R < zero ? one : zero) : zero;
    const T hit = disc >= zero ? std::max(ok0, ok1) : zero;
    const T t01 = std::min(t0, t1);
    const T t = ok0 != zero ? (ok1 != zero ? t01 : t0) : t1;
    const T nx = (ox[j] + dx[j] * t) * inv_r, ny = (oy[j] + dy[j] * t) * inv_r,
            nz = (rz + dz[j] * t - R) * inv_r;
    px[j] = ox[j] + dx[j] * t, py[j] = oy[j] + dy[j] * t, pz[j] = oz[j] + dz[j] * t;
    const T r2 = px[j] * px[j] + py[j] * py[j];
    const T inside = kMargin || r2 <= semi2 ? one : zero;
    T sin2_t, tir;
    refractLane(dx[j], dy[j], dz[j], nx, ny, nz, eta, refracts, ex[j], ey[j], ez[j], sin2_t,
                tir);
    if constexpr (kMargin) term[j] = marginTerm(r2, semi2, sin2_t, rarer);
    fate[j] = hit != zero ? (inside != zero ? (tir != zero ? T(3) : zero) : T(2)) : one;
  }
}

}  // namespace

template <typename T>
BlockReason LensTracer<T>::clip(int i, const TraceOptions& opts, T x, T y) const {
  const T r2 = x * x + y * y;
  if (r2 > semi2_[i]) return BlockReason::Aperture;
  if (!insideApertureShape(aperture_shape_[i], half_x_[i], half_y_[i], x, y))
    return BlockReason::Aperture;
  if (opts.obscurations && r2 < inner2_[i]) return BlockReason::Obscured;
  return BlockReason::None;
}

template <typename T>
BlockReason LensTracer<T>::traceOne(int i, bool from_film, const TraceOptions& opts, Vec3T<T>& o,
                                    Vec3T<T>& d, Vec3T<T>& hit, T* sin2) const {
  if (shape_index_[i] >= 0) return traceShaped(i, from_film, opts, o, d, hit, sin2);
  // A ray may start on the previous surface; accept roots a hair behind the origin so that
  // surfaces touching at the rim do not lose rays to rounding.
  const T t_min = T(kTMin<T>);
  const T R = radius_[i];
  const Vec3T<T> rel{o.x, o.y, o.z - z_[i]};  // origin relative to the vertex
  T t;
  Vec3T<T> normal;
  if (R == T(0)) {
    // Plane at the vertex (the aperture stop).
    if (d.z == T(0)) return BlockReason::Miss;
    t = -rel.z / d.z;
    if (!(t >= t_min)) return BlockReason::Miss;
    normal = {T(0), T(0), T(-1)};
  } else {
    // Sphere through the vertex with centre at (0, 0, R) relative to it:
    //   |rel + t d|^2 - 2 R (rel.z + t d.z) = 0,  i.e.  t^2 + 2 b t + c = 0 (|d| = 1) with
    //   b = rel.d - R d.z,  c = |rel|^2 - 2 R rel.z.
    // Stable roots: q = -(b + sign(b) sqrt(b^2 - c)); t = q and t = c / q.
    const T b = dot(rel, d) - R * d.z;
    const T c = dot(rel, rel) - T(2) * R * rel.z;
    const T disc = b * b - c;
    if (disc < T(0)) return BlockReason::Miss;
    const T q = -(b + std::copysign(std::sqrt(disc), b));
    const T t0 = q;
    const T t1 = q != T(0) ? c / q : T(0);
    // Keep the root on the vertex-side hemisphere: (z - R) / R < 0 relative to the vertex.
    // (The same cap whichever way the ray travels: after a mirror it meets it from behind.)
    auto onCap = [&](T tt) {
      const T pz = rel.z + tt * d.z;
      return tt >= t_min && (pz - R) * R < T(0);
    };
    const bool ok0 = onCap(t0), ok1 = onCap(t1);
    if (!ok0 && !ok1) return BlockReason::Miss;
    t = ok0 && ok1 ? std::min(t0, t1) : (ok0 ? t0 : t1);
    const Vec3T<T> p = rel + d * t;
    const T inv_r = inv_radius_[i];
    normal = Vec3T<T>{p.x * inv_r, p.y * inv_r, (p.z - R) * inv_r};  // unit; toward -z on the cap
  }
  hit = o + d * t;
  if (opts.clip_apertures) {
    const BlockReason why = clip(i, opts, hit.x, hit.y);
    if (why != BlockReason::None) return why;
  }
  if (is_mirror_[i]) {
    d = d - normal * (T(2) * dot(d, normal));
    return BlockReason::None;
  }
  const T eta_i = from_film ? eta_after_[i] : eta_before_[i];
  const T eta_t = from_film ? eta_before_[i] : eta_after_[i];
  if (!refract(d, normal, eta_i, eta_t, sin2)) return BlockReason::TotalInternalReflection;
  return BlockReason::None;
}

template <typename T>
template <bool kFromFilm>
TraceResultT<T> LensTracer<T>::trace(const RayT<T>& in, const TraceOptions& opts,
                                     std::vector<Vec3T<T>>* path) const {
  TraceResultT<T> res;
  Vec3T<T> o = in.origin;
  Vec3T<T> d = in.direction;
  if (kFromFilm && reversed_) unfold(o, d);  // the film side to real coordinates
  if (path) path->push_back(o);
  const int n = size();
  for (int k = 0; k < n; ++k) {
    const int i = kFromFilm ? n - 1 - k : k;
    Vec3T<T> p{};
    const Vec3T<T> d_in = d;
    const BlockReason why = traceOne(i, kFromFilm, opts, o, d, p);
    if (why == BlockReason::Miss) return {RayT<T>{o, d_in}, i, why, res.stop_point};
    if (path) path->push_back(p);
    if (is_stop_[i]) res.stop_point = {p.x, p.y};
    if (why != BlockReason::None) return {RayT<T>{p, d_in}, i, why, res.stop_point};
    o = p;
  }
  if (!kFromFilm && reversed_) unfold(o, d);  // image space unfolded, the film at +z
  res.ray = {o, d};
  return res;
}

template <typename T>
void LensTracer<T>::traceFromFilmBatch(const RayT<T>* rays, int n, TraceResultT<T>* results) const {
  traceBatch<false>(rays, n, results, nullptr);
}

template <typename T>
void LensTracer<T>::marginSquaredBatch(const RayT<T>* rays, int n, T* m2) const {
  // One ray: the plain trace (the same value) without a batch's padding lanes.
  if (n == 1) {
    m2[0] = marginSquared(rays[0]);
    return;
  }
  traceBatch<true>(rays, n, nullptr, m2);
}

template <typename T>
T LensTracer<T>::marginSquared(const RayT<T>& ray) const {
  Vec3T<T> o = ray.origin, d = ray.direction;
  if (reversed_) unfold(o, d);
  const TraceOptions opts{.clip_apertures = false};
  T m2(0);
  for (int i = size() - 1; i >= 0; --i) {
    Vec3T<T> p{};
    T sin2(0);
    const BlockReason why = traceOne(i, true, opts, o, d, p, &sin2);
    if (why == BlockReason::Miss) return std::numeric_limits<T>::infinity();
    const T rarer = eta_after_[i] > eta_before_[i] ? T(1) : T(0);
    m2 = std::max(m2, marginTerm(p.x * p.x + p.y * p.y, semi2_[i], sin2, rarer));
    if (why != BlockReason::None) return m2;  // totally reflected here
    o = p;
  }
  return m2;
}

template <typename T>
template <bool kMargin>
__attribute__((target_clones("avx2", "default"))) void LensTracer<T>::traceBatch(
    const RayT<T>* rays, int n, TraceResultT<T>* results, T* margin2) const {
  // Structure of arrays. Per surface, a branch-free loop over all lanes that the compiler
  // vectorises (blocked lanes keep computing, their values are ignored; conditions are 0/1
  // values of type T because GCC does not vectorise mixed bool masks here; the library is
  // built with -fno-math-errno -fno-trapping-math so that square roots, divisions and selects
  // can be), then a short loop that records the lanes blocked at that surface.
  // kMargin: no clipping; each lane's margin (marginSquared) instead of a result.
  T ox[kBatch], oy[kBatch], oz[kBatch], dx[kBatch], dy[kBatch], dz[kBatch];
  T px[kBatch], py[kBatch], pz[kBatch], ex[kBatch], ey[kBatch], ez[kBatch];
  T fate[kBatch];  // 0 through, 1 miss, 2 aperture, 3 total internal reflection, 4 obscured
  T sx[kBatch] = {}, sy[kBatch] = {};
  T mg[kBatch] = {}, term[kBatch] = {};  // kMargin: the margin so far, this surface's
  bool alive[kBatch];
  n = std::min(n, kBatch);
  // Lanes computed: n rounded up to a multiple of 4 (a vector of floats), the rest copies.
  const int nv = std::min(kBatch, (n + 3) & ~3);
  for (int j = 0; j < nv; ++j) {
    const RayT<T>& r = rays[j < n ? j : 0];
    ox[j] = r.origin.x, oy[j] = r.origin.y, oz[j] = r.origin.z;
    dx[j] = r.direction.x, dy[j] = r.direction.y, dz[j] = r.direction.z;
    if (reversed_) oz[j] = z_unfold_ - oz[j], dz[j] = -dz[j];
    alive[j] = j < n;
  }
  const T zero(0), one(1), inf = std::numeric_limits<T>::infinity();
  for (int i = size() - 1; i >= 0; --i) {
    const T R = radius_[i], inv_r = inv_radius_[i], zv = z_[i], semi2 = semi2_[i];
    const T eta_i = eta_after_[i], eta_t = eta_before_[i];
    const T eta = eta_i / eta_t;
    const T refracts = eta_i != eta_t ? one : zero;
    // kMargin: whether sin^2 of the refracted angle counts (into a rarer medium).
    const T rarer = eta_i > eta_t ? one : zero;
    // Lanes to trace one by one (traceOne), after a non-spherical surface's side-by-side loop.
    bool one_by_one[kBatch] = {};
    const bool side_by_side = lanes_[i] != 0;
    if (side_by_side)
      shapeLanes<T, kMargin>(shapes_[size_t(shape_index_[i])], zv, semi2, eta_i, eta_t, nv, alive,
                             ox, oy, oz, dx, dy, dz, px, py, pz, ex, ey, ez, fate, term,
                             one_by_one);
    if (per_lane_[i]) {
      // A non-spherical surface (the bracketed Newton solve), a mirror or an obscured surface:
      // lane by lane (spherical refracting lenses never come here); of a side-by-side surface
      // only the lanes shapeLanes left.
      const TraceOptions opts{.clip_apertures = !kMargin};
      for (int j = 0; j < nv; ++j) {
        // Lanes already stopped (or padding) are skipped: a blocked ray can cost a non-spherical
        // surface's slowest search.
        if (j >= n || !alive[j] || (side_by_side && !one_by_one[j])) continue;
        Vec3T<T> o{ox[j], oy[j], oz[j]}, d{dx[j], dy[j], dz[j]}, p{};
        T sin2_t = zero;
        const BlockReason why = traceOne(i, true, opts, o, d, p, kMargin ? &sin2_t : nullptr);
        px[j] = p.x, py[j] = p.y, pz[j] = p.z;
        ex[j] = d.x, ey[j] = d.y, ez[j] = d.z;
        if constexpr (kMargin) term[j] = marginTerm(p.x * p.x + p.y * p.y, semi2, sin2_t, rarer);
        fate[j] = why == BlockReason::None                      ? zero
                  : why == BlockReason::Miss                    ? one
                  : why == BlockReason::Aperture                ? T(2)
                  : why == BlockReason::TotalInternalReflection ? T(3)
                                                                : T(4);
        if (why != BlockReason::None) ex[j] = dx[j], ey[j] = dy[j], ez[j] = dz[j];
      }
    } else if (R == zero && refracts == zero) {
      planeLanes<T, kMargin, false>(zv, semi2, eta, rarer, nv, ox, oy, oz, dx, dy, dz, px, py, pz,
                                    ex, ey, ez, fate, term);
    } else if (R == zero) {
      planeLanes<T, kMargin, true>(zv, semi2, eta, rarer, nv, ox, oy, oz, dx, dy, dz, px, py, pz, ex,
                                   ey, ez, fate, term);
    } else {
      sphereLanes<T, kMargin>(R, inv_r, zv, semi2, eta, refracts, rarer, nv, ox, oy, oz, dx, dy, dz,
                              px, py, pz, ex, ey, ez, fate, term);
    }
    if constexpr (kMargin) {
      for (int j = 0; j < n; ++j) {
        if (!alive[j]) continue;
        if (fate[j] == one) {
          mg[j] = inf, alive[j] = false;
          continue;
        }
        mg[j] = std::max(mg[j], term[j]);
        if (fate[j] != zero) alive[j] = false;  // totally reflected here
      }
    } else {
      const bool stop = is_stop_[i] != 0;
      for (int j = 0; j < n; ++j) {
        if (!alive[j]) continue;
        if (fate[j] == one) {
          results[j] = {RayT<T>{{ox[j], oy[j], oz[j]}, {dx[j], dy[j], dz[j]}},
                        i,
                        BlockReason::Miss,
                        {sx[j], sy[j]}};
          alive[j] = false;
          continue;
        }
        if (stop) sx[j] = px[j], sy[j] = py[j];
        if (fate[j] != zero) {
          results[j] = {RayT<T>{{px[j], py[j], pz[j]}, {dx[j], dy[j], dz[j]}},
                        i,
                        fate[j] == T(2)   ? BlockReason::Aperture
                        : fate[j] == T(3) ? BlockReason::TotalInternalReflection
                                          : BlockReason::Obscured,
                        {sx[j], sy[j]}};
          alive[j] = false;
        }
      }
    }
    for (int j = 0; j < nv; ++j) {
      ox[j] = px[j], oy[j] = py[j], oz[j] = pz[j];
      dx[j] = ex[j], dy[j] = ey[j], dz[j] = ez[j];
    }
  }
  if constexpr (kMargin) {
    for (int j = 0; j < n; ++j) margin2[j] = mg[j];
  } else {
    for (int j = 0; j < n; ++j)
      if (alive[j])
        results[j] = {RayT<T>{{ox[j], oy[j], oz[j]}, {dx[j], dy[j], dz[j]}},
                      -1,
                      BlockReason::None,
                      {sx[j], sy[j]}};
  }
}

template <typename T>
BlockReason LensTracer<T>::traceShaped(int i, bool from_film, const TraceOptions& opts, Vec3T<T>& o,
                                       Vec3T<T>& d, Vec3T<T>& hit, T* sin2) const {
  const ShapeIntersector& shape = shapes_[size_t(shape_index_[i])];
  const double t_min = kTMin<T>;
  const Vec3 rel{double(o.x), double(o.y), double(o.z) - double(z_[i])};
  Vec3 dir{double(d.x), double(d.y), double(d.z)};
  dir = normalize(dir);
  const auto h = shape.intersect(rel, dir, t_min);
  if (!h) return BlockReason::Miss;
  const Vec3 p = rel + dir * h->t;
  hit = {T(p.x), T(p.y), T(p.z + double(z_[i]))};
  if (opts.clip_apertures) {
    const BlockReason why = clip(i, opts, T(p.x), T(p.y));
    if (why != BlockReason::None) return why;
  }
  if (is_mirror_[i]) {
    dir = dir - h->normal * (2 * dot(dir, h->normal));
    d = {T(dir.x), T(dir.y), T(dir.z)};
    return BlockReason::None;
  }
  const double eta_i = from_film ? double(eta_after_[i]) : double(eta_before_[i]);
  const double eta_t = from_film ? double(eta_before_[i]) : double(eta_after_[i]);
  double s2 = 0;
  const bool through = refract(dir, h->normal, eta_i, eta_t, &s2);
  if (sin2) *sin2 = T(s2);
  if (!through) return BlockReason::TotalInternalReflection;
  d = {T(dir.x), T(dir.y), T(dir.z)};
  return BlockReason::None;
}

template <typename T>
TraceResultT<T> LensTracer<T>::traceFromFilm(const RayT<T>& ray, const TraceOptions& opts,
                                             std::vector<Vec3T<T>>* path) const {
  return trace<true>(ray, opts, path);
}

template <typename T>
TraceResultT<T> LensTracer<T>::traceFromScene(const RayT<T>& ray, const TraceOptions& opts,
                                              std::vector<Vec3T<T>>* path) const {
  return trace<false>(ray, opts, path);
}

template class LensTracer<double>;
template class LensTracer<float>;

// ---------------------------------------------------------------------------------------------
// LensSystem

LensSystem::LensSystem(LensPrescription prescription, const LensSystemOptions& opts)
    : prescription_(std::move(prescription)) {
  const auto& surfaces = prescription_.surfaces;
  if (surfaces.empty()) throw Error(FileLoc{prescription_.path}, "lens has no surfaces");
  // A grating makes any lens non-coaxial, whether or not the prescription says so (a coaxial
  // twin built from a placed lens keeps its rows).
  if (const LensSurface* g = firstGrating(prescription_); g && !prescription_.noncoaxial_loc)
    throw Error(g->grating->loc, "a lens with a diffraction grating is not rotationally "
                                 "symmetric: lensim's coaxial tracers do not model it");
  if (prescription_.noncoaxial_loc)
    throw Error(*prescription_.noncoaxial_loc,
                fmt::format("{}: a {}: lensim's coaxial tracers (first-order data, pupils, "
                            "rendering) do not model it; `lensim lens info` traces real rays "
                            "through it",
                            prescription_.noncoaxial_reason,
                            firstGrating(prescription_) ? "lens with a diffraction grating"
                                                      : "tilted or decentred lens"));
  double z = 0;
  double ior_before = 1.0;
  int dir = 1;  // direction of travel along z: -1 after an odd number of mirrors
  for (size_t i = 0; i < surfaces.size(); ++i) {
    const LensSurface& s = surfaces[i];
    Interface in;
    in.radius_mm = s.radius_mm;
    in.z_mm = z;
    in.semi_aperture_mm = s.semiAperture_mm();
    in.ior_before = ior_before;
    in.ior_after = s.ior;
    in.is_stop = s.isStop();
    in.shape = s.shape;
    in.is_mirror = s.mirror;
    in.obscuration_radius_mm = s.obscuration_radius_mm;
    in.aperture_shape = s.aperture_shape;
    in.aperture_half_x_mm = s.aperture_half_x_mm;
    in.aperture_half_y_mm = s.aperture_half_y_mm;
    if (s.apertureDecentred())
      throw Error(s.loc, fmt::format("surface {}: its aperture is decentred ({}, {} mm), so the "
                                     "lens is not rotationally symmetric; only the non-coaxial "
                                     "tracer models it",
                                     i, s.aperture_decentre_mm[0], s.aperture_decentre_mm[1]));
    if (!(s.obscuration_radius_mm >= 0) || s.obscuration_radius_mm >= s.semiAperture_mm())
      throw Error(s.loc, fmt::format("surface {}: obscuration radius {} mm must be >= 0 and "
                                     "smaller than the semi-aperture {} mm",
                                     i, s.obscuration_radius_mm, s.semiAperture_mm()));
    in.dir_before = dir;
    if (s.mirror) {
      // The medium after a mirror is the one before it (readers repeat it).
      if (s.ior != ior_before)
        throw Error(s.loc, fmt::format("surface {} is a mirror: the medium after it must be the "
                                       "one before it (index {}), not index {}",
                                       i, ior_before, s.ior));
      dir = -dir;
      ++mirror_count_;
    }
    in.dir_after = dir;
    // Thicknesses are signed z distances (Zemax's convention): after an odd number of mirrors
    // the next surface lies toward -z.
    if (i + 1 < surfaces.size() && s.thickness_mm * dir < 0)
      throw Error(s.loc,
                  fmt::format("surface {}: thickness {} mm points against the direction "
                              "the light travels after {} mirror{} (expected a {} "
                              "thickness)",
                              i, s.thickness_mm, mirror_count_, mirror_count_ == 1 ? "" : "s",
                              dir > 0 ? "positive" : "negative"));
    interfaces_.push_back(in);
    if (in.is_stop) {
      stop_index_ = static_cast<int>(i);
      max_stop_diameter_mm_ = s.aperture_diameter_mm;
    }
    ior_before = s.ior;
    if (i + 1 < surfaces.size()) z += s.thickness_mm;
  }

  if (opts.aperture_diameter_mm) {
    double d = *opts.aperture_diameter_mm;
    if (!(d > 0) || !std::isfinite(d))
      throw Error(fmt::format("aperture diameter {} mm must be > 0", d));
    if (!stop_index_) {
      diagnostics_.push_back({Severity::Warning, FileLoc{prescription_.path},
                              fmt::format("the lens has no aperture stop (radius 0 row); the "
                                          "aperture diameter {} mm is ignored",
                                          d)});
    } else if (d > *max_stop_diameter_mm_) {
      diagnostics_.push_back(
          {Severity::Warning, surfaces[*stop_index_].loc,
           fmt::format("aperture diameter {} mm is larger than the stop allows; clamped to {} mm",
                       d, *max_stop_diameter_mm_)});
    } else {
      interfaces_[*stop_index_].semi_aperture_mm = d / 2;
      if (d / 2 <= interfaces_[*stop_index_].obscuration_radius_mm)
        diagnostics_.push_back(
            {Severity::Warning, surfaces[*stop_index_].loc,
             fmt::format("aperture diameter {} mm lies inside the stop's central obscuration "
                         "(radius {} mm): no light passes the lens",
                         d, interfaces_[*stop_index_].obscuration_radius_mm)});
    }
  }
  // The film distance is measured along the direction image space runs (negative in the file
  // after an odd number of mirrors).
  film_distance_mm_ =
      opts.film_distance_mm ? *opts.film_distance_mm : prescription_.fileFilmDistance_mm() * dir;
  if (opts.film_distance_mm && !(*opts.film_distance_mm > 0))
    throw Error(fmt::format("film distance {} mm must be > 0", *opts.film_distance_mm));
  resolveMedia();
  rebuildTracers();
}

void LensSystem::resolveMedia() {
  // Media from the GlassSpecs; the indices are set at the primary wavelength (the one focus is
  // solved at). Non-dispersive media keep the file's index exactly.
  glasses_ = resolveGlasses(prescription_, &diagnostics_);
  dispersive_ = false;
  for (const Glass& g : glasses_) dispersive_ = dispersive_ || g.dispersive();
  wavelength_nm_ = primaryWavelength_nm(prescription_);
  if (dispersive_) {
    std::vector<double> before(interfaces_.size()), after(interfaces_.size());
    indicesAt(wavelength_nm_, before.data(), after.data());
    for (size_t i = 0; i < interfaces_.size(); ++i)
      interfaces_[i].ior_before = before[i], interfaces_[i].ior_after = after[i];
  }
}

void LensSystem::indicesAt(double lambda_nm, double* before, double* after) const {
  double n_before = 1.0;
  for (size_t i = 0; i < interfaces_.size(); ++i) {
    const double n_after = glasses_[i].index(lambda_nm);
    before[i] = n_before, after[i] = n_after;
    n_before = n_after;
  }
}

void LensSystem::setWavelength(double lambda_nm) {
  if (!(lambda_nm > 0) || !std::isfinite(lambda_nm))
    throw Error(fmt::format("wavelength {} nm must be > 0", lambda_nm));
  wavelength_nm_ = lambda_nm;
  if (!dispersive_) return;
  std::vector<double> before(interfaces_.size()), after(interfaces_.size());
  indicesAt(lambda_nm, before.data(), after.data());
  for (size_t i = 0; i < interfaces_.size(); ++i)
    interfaces_[i].ior_before = before[i], interfaces_[i].ior_after = after[i];
  // Only the indices change: the tracers keep their surfaces' intersectors (whose set-up samples
  // each non-spherical surface's sag).
  tracer_d_.setIndices(before.data(), after.data());
  tracer_f_.setIndices(before.data(), after.data());
}

LensSystem LensSystem::atWavelength(double lambda_nm) const {
  LensSystem s = *this;
  s.setWavelength(lambda_nm);
  return s;
}

std::optional<double> LensSystem::stopDiameter_mm() const {
  if (!stop_index_) return std::nullopt;
  return 2 * interfaces_[*stop_index_].semi_aperture_mm;
}

void LensSystem::setFilmDistance_mm(double d) {
  if (!(d > 0) || !std::isfinite(d))
    throw Error(fmt::format("film distance {} mm must be a finite distance > 0", d));
  film_distance_mm_ = d;
}

void LensSystem::rebuildTracers() {
  tracer_d_ = LensTracer<double>(interfaces_);
  tracer_f_ = LensTracer<float>(interfaces_);
}

Ray LensSystem::filmPointRay(Vec2 film_mm, Vec2 rear_plane_mm) const {
  Vec3 from{film_mm.x, film_mm.y, filmZ_mm()};
  Vec3 to{rear_plane_mm.x, rear_plane_mm.y, rearVertexZ_mm()};
  Vec3 dir = to - from;
  if (!(dir.z < 0))
    throw Error(fmt::format("film distance {} mm: the film must lie behind the rear vertex",
                            film_distance_mm_));
  return Ray{from, normalize(dir)};
}

TraceResult LensSystem::traceFromFilmPoint(Vec2 film_mm, Vec2 rear_plane_mm,
                                           const TraceOptions& opts,
                                           std::vector<Vec3>* path) const {
  return tracer_d_.traceFromFilm(filmPointRay(film_mm, rear_plane_mm), opts, path);
}

}  // namespace lensim::optics
