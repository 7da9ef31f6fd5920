#include "lensim/optics/placed_lens.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "lensim/optics/frame.h"
#include "lensim/optics/glass.h"
#include "lensim/optics/grating.h"
#include "lensim/optics/refraction.h"

namespace lensim::optics {

Vec3 PlacedLens::toLocal(const Surface& s, const Vec3& v) { return frame::toLocal(s.rotation, v); }

Vec3 PlacedLens::toGlobal(const Surface& s, const Vec3& v) { return frame::toGlobal(s.rotation, v); }

PlacedLens::PlacedLens(const LensPrescription& p, double wavelength_nm)
    : wavelength_nm_(wavelength_nm) {
  if (!p.noncoaxial_loc)
    throw Error(FileLoc{p.path}, "the non-coaxial tracer needs a lens with tilted or decentred "
                                 "surfaces (this one is coaxial)");
  if (!(wavelength_nm > 0) || !std::isfinite(wavelength_nm))
    throw Error(fmt::format("wavelength {} nm must be > 0", wavelength_nm));
  glasses_ = resolveGlasses(p, &diagnostics_);
  const std::vector<Glass>& glasses = glasses_;
  double n_before = 1;
  const auto stop = p.stopIndex();
  stop_ = stop ? *stop : 0;
  for (size_t i = 0; i < p.surfaces.size(); ++i) {
    const LensSurface& ls = p.surfaces[i];
    if (!ls.frame)
      throw Error(ls.loc, "a surface of a non-coaxial lens has no place in space");
    Surface s;
    s.rotation = ls.frame->rotation;
    s.origin = {ls.frame->origin_mm[0], ls.frame->origin_mm[1], ls.frame->origin_mm[2]};
    s.semi = ls.semiAperture_mm();
    s.semi2 = s.semi * s.semi;
    s.inner2 = ls.obscuration_radius_mm * ls.obscuration_radius_mm;
    s.aperture_shape = ls.aperture_shape;
    s.half_x = ls.aperture_half_x_mm, s.half_y = ls.aperture_half_y_mm;
    s.dec_x = ls.aperture_decentre_mm[0], s.dec_y = ls.aperture_decentre_mm[1];
    // Defined out to the aperture's farthest point (a decentred aperture lies off the axis).
    s.shape = ShapeIntersector(ls.radius_mm, ls.shape, ls.apertureReach_mm());
    s.mirror = ls.mirror;
    if (ls.grating) {
      s.grating = true;
      s.order_lines_per_um = ls.grating->order * ls.grating->lines_per_um;
    }
    s.n_before = n_before;
    s.n_after = glasses[i].index(wavelength_nm);
    n_before = s.n_after;
    extent_mm_ = std::max(extent_mm_, length(s.origin) + ls.apertureReach_mm());
    surfaces_.push_back(std::move(s));
  }
  image_.rotation = p.image_frame.rotation;
  image_.origin = {p.image_frame.origin_mm[0], p.image_frame.origin_mm[1],
                   p.image_frame.origin_mm[2]};
  extent_mm_ = 2 * std::max(extent_mm_, length(image_.origin)) + 1;
}

BlockReason PlacedLens::traceSurface(size_t i, const TraceOptions& opts, Vec3& o, Vec3& d,
                                     Vec2* local_hit, bool backward) const {
  const Surface& s = surfaces_[i];
  const Vec3 rel = toLocal(s, o - s.origin);
  Vec3 dir = normalize(toLocal(s, d));
  const auto h = s.shape.intersect(rel, dir, -1e-9);
  if (!h) return BlockReason::Miss;
  const Vec3 q = rel + dir * h->t;
  if (local_hit) *local_hit = {q.x, q.y};
  if (opts.clip_apertures) {
    const double ax = q.x - s.dec_x, ay = q.y - s.dec_y;  // about the aperture's centre
    const double r2 = ax * ax + ay * ay;
    if (r2 > s.semi2 || !insideApertureShape(s.aperture_shape, s.half_x, s.half_y, ax, ay))
      return BlockReason::Aperture;
    if (opts.obscurations && r2 < s.inner2) return BlockReason::Obscured;
  }
  if (s.grating) {
    // Backward the media swap and the order stays: the reversed ray's tangential n s, minus the
    // forward one's, gains the same m lambda / d q and leaves reversed.
    const double k = s.order_lines_per_um * wavelength_nm_ * 1e-3;
    if (!diffract(dir, h->normal, {0, 1, 0}, backward ? s.n_after : s.n_before,
                  backward ? s.n_before : s.n_after, k, s.mirror))
      return BlockReason::Evanescent;
  } else if (s.mirror) {
    dir = dir - h->normal * (2 * dot(dir, h->normal));
  } else if (!refract(dir, h->normal, backward ? s.n_after : s.n_before,
                      backward ? s.n_before : s.n_after)) {
    return BlockReason::TotalInternalReflection;
  }
  o = toGlobal(s, q) + s.origin;
  d = toGlobal(s, dir);
  return BlockReason::None;
}

TraceResult PlacedLens::trace(const Ray& ray, const TraceOptions& opts,
                              std::vector<Vec3>* path) const {
  TraceResult r;
  Vec3 o = ray.origin, d = ray.direction;
  if (path) path->push_back(o);
  for (size_t i = 0; i < surfaces_.size(); ++i) {
    Vec2 local{};
    const BlockReason why = traceSurface(i, opts, o, d, &local);
    if (int(i) == stop_) r.stop_point = local;
    if (why != BlockReason::None) {
      r.ray = {o, d};
      r.blocked_surface = int(i);
      r.reason = why;
      return r;
    }
    if (path) path->push_back(o);
  }
  // The image plane: local z = 0.
  const Vec3 rel = toLocal(image_, o - image_.origin), dir = toLocal(image_, d);
  const double t = dir.z != 0 ? -rel.z / dir.z : -1;
  if (!(t >= -1e-9) || !std::isfinite(t)) {
    r.ray = {o, d};
    r.blocked_surface = surfaceCount();
    r.reason = BlockReason::Miss;
    return r;
  }
  o = o + d * t;
  if (path) path->push_back(o);
  r.ray = {o, d};
  return r;
}

TraceResult PlacedLens::traceBackward(const Ray& ray, const TraceOptions& opts,
                                      std::vector<Vec3>* path) const {
  TraceResult r;
  Vec3 o = ray.origin, d = ray.direction;
  for (size_t k = surfaces_.size(); k-- > 0;) {
    Vec2 local{};
    const BlockReason why = traceSurface(k, opts, o, d, &local, true);
    if (int(k) == stop_) r.stop_point = local;
    if (why != BlockReason::None) {
      r.ray = {o, d};
      r.blocked_surface = int(k);
      r.reason = why;
      return r;
    }
    if (path) path->push_back(o);
  }
  r.ray = {o, d};
  return r;
}

void PlacedLens::setWavelength(double wavelength_nm) {
  if (!(wavelength_nm > 0) || !std::isfinite(wavelength_nm))
    throw Error(fmt::format("wavelength {} nm must be > 0", wavelength_nm));
  double n_before = 1;
  for (size_t i = 0; i < surfaces_.size(); ++i) {
    surfaces_[i].n_before = n_before;
    surfaces_[i].n_after = glasses_[i].index(wavelength_nm);
    n_before = surfaces_[i].n_after;
  }
  wavelength_nm_ = wavelength_nm;
}

bool PlacedLens::dispersive() const {
  return std::any_of(glasses_.begin(), glasses_.end(),
                     [](const Glass& g) { return g.dispersive(); });
}

bool PlacedLens::hasGrating() const {
  return std::any_of(surfaces_.begin(), surfaces_.end(), [](const Surface& s) { return s.grating; });
}

Vec3 PlacedLens::toImageFrame(const Vec3& global) const {
  return toLocal(image_, global - image_.origin);
}

Ray PlacedLens::fieldRay(const Field& f, Vec2 entry) const {
  const Vec3 e{entry.x, entry.y, 0};
  if (!f.at_infinity) return {f.object_point, normalize(e - f.object_point)};
  const double deg = std::numbers::pi / 180;
  const Vec3 d = normalize(Vec3{std::tan(f.angle_x_deg * deg), std::tan(f.angle_y_deg * deg), 1});
  return {e - d * (extent_mm_ / d.z), d};
}

std::optional<Vec2> PlacedLens::aim(const Field& field, Vec2 stop_xy) const {
  const TraceOptions unclipped{false, false};
  auto stopHit = [&](Vec2 e) -> std::optional<Vec2> {
    const TraceResult t = trace(fieldRay(field, e), unclipped);
    if (t.blocked_surface >= 0 && t.blocked_surface <= stop_) return std::nullopt;
    return t.stop_point;
  };
  const double scale = std::max(1.0, surfaces_[size_t(stop_)].semi);
  const double h = 1e-6 * scale, tol = 1e-12 * scale;
  // Newton's method from the object axis, else from the stop's vertex seen along z.
  auto solve = [&](Vec2 e) -> std::optional<Vec2> {
    for (int it = 0; it < 60; ++it) {
      const auto f0 = stopHit(e);
      if (!f0) return std::nullopt;
      const Vec2 r = *f0 - stop_xy;
      if (std::hypot(r.x, r.y) <= tol) return e;
      const auto fx = stopHit({e.x + h, e.y}), fy = stopHit({e.x, e.y + h});
      if (!fx || !fy) return std::nullopt;
      const double a = (fx->x - f0->x) / h, c = (fx->y - f0->y) / h;  // d(stop)/d(entry x)
      const double b = (fy->x - f0->x) / h, dd = (fy->y - f0->y) / h;  // d(stop)/d(entry y)
      const double det = a * dd - b * c;
      if (!(std::abs(det) > 0) || !std::isfinite(det)) return std::nullopt;
      const Vec2 step{(dd * r.x - b * r.y) / det, (a * r.y - c * r.x) / det};
      e = e - step;
      if (!std::isfinite(e.x) || !std::isfinite(e.y)) return std::nullopt;
    }
    return std::nullopt;
  };
  if (auto e = solve({0, 0})) return e;
  return solve({surfaces_[size_t(stop_)].origin.x, surfaces_[size_t(stop_)].origin.y});
}

std::optional<PlacedLens::Spot> PlacedLens::spot(const Field& field, int n) const {
  if (n < 2) return std::nullopt;
  // Two passes of an n x n grid of entry points: first over a square about the chief ray's
  // entry as wide as the widest aperture (no beam is wider), then over the box of the rays that
  // got through, widened by one cell of the first grid.
  double widest = 0;
  for (const Surface& s : surfaces_) widest = std::max(widest, s.semi);
  const Vec2 centre = aim(field, {0, 0}).value_or(Vec2{0, 0});
  double lo_x = centre.x - widest, hi_x = centre.x + widest;
  double lo_y = centre.y - widest, hi_y = centre.y + widest;
  std::vector<Vec2> pts;
  for (int pass = 0; pass < 2; ++pass) {
    pts.clear();
    double in_lo_x = 1e300, in_hi_x = -1e300, in_lo_y = 1e300, in_hi_y = -1e300;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        const Vec2 e{lo_x + (hi_x - lo_x) * i / (n - 1), lo_y + (hi_y - lo_y) * j / (n - 1)};
        const TraceResult t = trace(fieldRay(field, e));
        if (!t.ok()) continue;
        const Vec3 q = toImageFrame(t.ray.origin);
        pts.push_back({q.x, q.y});
        in_lo_x = std::min(in_lo_x, e.x), in_hi_x = std::max(in_hi_x, e.x);
        in_lo_y = std::min(in_lo_y, e.y), in_hi_y = std::max(in_hi_y, e.y);
      }
    if (pts.empty()) return std::nullopt;
    const double cx = (hi_x - lo_x) / (n - 1), cy = (hi_y - lo_y) / (n - 1);
    lo_x = in_lo_x - cx, hi_x = in_hi_x + cx, lo_y = in_lo_y - cy, hi_y = in_hi_y + cy;
  }
  if (pts.empty()) return std::nullopt;
  Spot s;
  s.rays = int(pts.size());
  for (const Vec2& q : pts) s.centroid = s.centroid + q * (1.0 / double(pts.size()));
  double sum = 0;
  for (const Vec2& q : pts) sum += (q.x - s.centroid.x) * (q.x - s.centroid.x) +
                                   (q.y - s.centroid.y) * (q.y - s.centroid.y);
  s.rms_mm = std::sqrt(sum / double(pts.size()));
  return s;
}

}  // namespace lensim::optics
