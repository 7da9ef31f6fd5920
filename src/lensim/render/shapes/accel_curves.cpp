#include "lensim/render/shapes/accel_curves.h"

#include <algorithm>
#include <cmath>

namespace lensim::render {

namespace {

Vec3 bezierTangent(const Vec3* b, double u) {
  const double s = 1 - u;
  return (b[1] - b[0]) * (3 * s * s) + (b[2] - b[1]) * (6 * s * u) + (b[3] - b[2]) * (3 * u * u);
}

Vec3 bezierPoint(const Vec3* b, double u) {
  const double s = 1 - u;
  return b[0] * (s * s * s) + b[1] * (3 * s * s * u) + b[2] * (3 * s * u * u) + b[3] * (u * u * u);
}

/// Any unit vector perpendicular to t.
Vec3 perpendicular(const Vec3& t) {
  const Vec3 a = std::abs(t.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  return normalize(cross(t, a));
}

}  // namespace

CurveInSpace curveInSpace(const scene::Curve& curve, const Transform& xf) {
  CurveInSpace c;
  const Vec3 ex = xf.applyVector({1, 0, 0}), ey = xf.applyVector({0, 1, 0}),
             ez = xf.applyVector({0, 0, 1});
  const double scale = std::cbrt(std::abs(dot(ex, cross(ey, ez))));
  for (size_t i = 0; i < curve.cp.size(); ++i) {
    c.p.push_back(xf.applyPoint(curve.cp[i]));
    c.radius.push_back(0.5 * curve.width[i] * scale);
    const double r = c.radius.back();
    c.bounds.extend(c.p.back() - Vec3{r, r, r});
    c.bounds.extend(c.p.back() + Vec3{r, r, r});
  }
  for (const Vec3& nn : curve.normal) {
    const Vec3 t = xf.applyNormal(nn);
    c.n.push_back(length(t) > 0 ? normalize(t) : t);
  }
  return c;
}

RTCGeometry newCurveGeometry(RTCDevice device, const scene::Curve& curve, const CurveInSpace& c) {
  RTCGeometryType type = RTC_GEOMETRY_TYPE_FLAT_BEZIER_CURVE;
  if (curve.kind == scene::CurveKind::Cylinder) type = RTC_GEOMETRY_TYPE_ROUND_BEZIER_CURVE;
  if (curve.kind == scene::CurveKind::Ribbon) type = RTC_GEOMETRY_TYPE_NORMAL_ORIENTED_BEZIER_CURVE;
  RTCGeometry g = rtcNewGeometry(device, type);
  auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(
      g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 4 * sizeof(float), c.p.size()));
  for (size_t k = 0; k < c.p.size(); ++k) {
    v[4 * k] = float(c.p[k].x), v[4 * k + 1] = float(c.p[k].y), v[4 * k + 2] = float(c.p[k].z);
    v[4 * k + 3] = float(c.radius[k]);
  }
  const size_t segments = c.p.size() / 4;
  auto* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
      g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT, sizeof(unsigned), segments));
  for (size_t s = 0; s < segments; ++s) idx[s] = unsigned(4 * s);
  if (curve.kind == scene::CurveKind::Ribbon) {
    auto* n = static_cast<float*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_NORMAL, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), c.n.size()));
    for (size_t k = 0; k < c.n.size(); ++k) {
      n[3 * k] = float(c.n[k].x), n[3 * k + 1] = float(c.n[k].y), n[3 * k + 2] = float(c.n[k].z);
    }
  }
  return g;
}

CurveHitGeometry curveHitGeometry(const scene::Curve& curve, const CurveInSpace& c, size_t seg,
                                  double u, double v, Vec3 embree_ng, Vec3 p, Vec3 d) {
  CurveHitGeometry g;
  g.p = p;
  u = std::clamp(u, 0.0, 1.0);
  const Vec3* b = &c.p[4 * seg];
  Vec3 t = bezierTangent(b, u);
  if (!(length(t) > 0)) t = b[3] - b[0];
  if (!(length(t) > 0)) t = {0, 0, 1};
  const Vec3 tn = normalize(t);
  const double width = 2 * (c.radius[4 * seg] + (c.radius[4 * seg + 3] - c.radius[4 * seg]) * u);
  // Flat curves face the ray: the normal is -d made perpendicular to the tangent. Embree's Ng is
  // the tangent there; for ribbons and cylinders it is the surface normal.
  Vec3 n;
  double vv = 0.5;
  if (curve.kind == scene::CurveKind::Flat) {
    n = -(d - tn * dot(d, tn));
    vv = 0.5 * (v + 1);
  } else {
    n = embree_ng - tn * dot(embree_ng, tn);
    if (curve.kind == scene::CurveKind::Ribbon) vv = v;
  }
  n = length(n) > 0 ? normalize(n) : perpendicular(tn);
  // v as pbrt-v4's Curve::RecursiveIntersect computes it for every curve type (shapes.cpp,
  // "Compute v coordinate of curve intersection point"): in ray space, 0.5 plus or minus the
  // hit's distance from the curve over the (projected) width, on the side given by the edge
  // function (pc x dpc/dw).z, pc the curve point relative to the ray. In render space that side
  // is the sign of r . (d x t), r the hit relative to the axis point; the hair BSDF's offset
  // h = -1 + 2 v depends on it.
  const Vec3 across = cross(d, tn);
  if (length(across) > 0 && width > 0) {
    const Vec3 e = normalize(across);
    // The half-width seen along the ray: the radius, or for a ribbon its band's projection.
    double half = 0.5 * width;
    if (curve.kind == scene::CurveKind::Ribbon) half *= std::abs(dot(normalize(cross(n, tn)), e));
    if (half > 0) {
      const Vec3 r = p - bezierPoint(b, u);
      vv = 0.5 + 0.5 * std::clamp(dot(r, e) / half, -1.0, 1.0);
    }
  }
  g.n = n;
  g.dpdu = t;
  g.dpdv = normalize(cross(n, tn)) * width;
  g.uv = {u, std::clamp(vv, 0.0, 1.0)};
  return g;
}

}  // namespace lensim::render
