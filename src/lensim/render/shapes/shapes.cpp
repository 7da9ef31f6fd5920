// Quadric intersection and sampling. Parameterisations are pbrt-v4's (Pharr, Jakob, Humphreys,
// "Physically Based Rendering", 4th ed., ch. 6): phi = atan2(y, x) in [0, 2pi), u = phi/phimax;
// sphere v from theta_zmin to theta_zmax, cylinder v = (z - zmin)/(zmax - zmin), disk
// v = (radius - r)/(radius - innerradius), cone v = z / height with the apex at z = height.
#include "lensim/render/shapes/shapes.h"

#include <algorithm>

#include "lensim/scene/description.h"

namespace lensim::render {

namespace {

constexpr double kTwoPi = 2 * M_PI;

double phiOf(double x, double y) {
  double phi = std::atan2(y, x);
  return phi < 0 ? phi + kTwoPi : phi;
}

/// Real roots of a t^2 + b t + c = 0, sorted; numerically stable form.
bool quadratic(double a, double b, double c, double* t0, double* t1) {
  if (a == 0) {
    if (b == 0) return false;
    *t0 = *t1 = -c / b;
    return true;
  }
  const double disc = b * b - 4 * a * c;
  if (disc < 0) return false;
  const double root = std::sqrt(disc);
  const double q = b < 0 ? -0.5 * (b - root) : -0.5 * (b + root);
  *t0 = q / a;
  *t1 = q != 0 ? c / q : *t0;
  if (*t0 > *t1) std::swap(*t0, *t1);
  return true;
}

double phiMax(const scene::Shape& s) {
  return std::clamp(s.phimax_deg, 0.0, 360.0) * M_PI / 180;
}

/// Whether the object-space point lies inside the quadric's z range and sweep.
bool inside(const scene::Shape& s, const Vec3& p) {
  using scene::ShapeType;
  switch (s.type) {
    case ShapeType::Sphere: {
      const double zmin = std::clamp(std::min(s.zmin, s.zmax), -s.radius, s.radius);
      const double zmax = std::clamp(std::max(s.zmin, s.zmax), -s.radius, s.radius);
      if ((zmin > -s.radius && p.z < zmin) || (zmax < s.radius && p.z > zmax)) return false;
      break;
    }
    case ShapeType::Cylinder:
      if (p.z < std::min(s.zmin, s.zmax) || p.z > std::max(s.zmin, s.zmax)) return false;
      break;
    case ShapeType::Cone:
      if (p.z < 0 || p.z > s.height) return false;
      break;
    default:
      break;
  }
  if (s.phimax_deg < 360 && phiOf(p.x, p.y) > phiMax(s)) return false;
  return true;
}

}  // namespace

std::optional<double> intersectQuadric(const scene::Shape& s, const Vec3& o, const Vec3& d,
                                       double tmin, double tmax) {
  using scene::ShapeType;
  if (s.type == ShapeType::Disk) {
    if (d.z == 0) return std::nullopt;
    const double t = (s.height - o.z) / d.z;
    if (!(t > tmin && t < tmax)) return std::nullopt;
    const Vec3 p = o + d * t;
    const double r2 = p.x * p.x + p.y * p.y;
    if (r2 > s.radius * s.radius || r2 < s.inner_radius * s.inner_radius) return std::nullopt;
    if (s.phimax_deg < 360 && phiOf(p.x, p.y) > phiMax(s)) return std::nullopt;
    return t;
  }
  double a, b, c;
  if (s.type == ShapeType::Sphere) {
    a = dot(d, d);
    b = 2 * dot(d, o);
    c = dot(o, o) - s.radius * s.radius;
  } else if (s.type == ShapeType::Cylinder) {
    a = d.x * d.x + d.y * d.y;
    b = 2 * (d.x * o.x + d.y * o.y);
    c = o.x * o.x + o.y * o.y - s.radius * s.radius;
  } else if (s.type == ShapeType::Cone) {
    // x^2 + y^2 = k (z - h)^2 with k = (r / h)^2.
    const double k = (s.radius / s.height) * (s.radius / s.height);
    const double oz = o.z - s.height;
    a = d.x * d.x + d.y * d.y - k * d.z * d.z;
    b = 2 * (d.x * o.x + d.y * o.y - k * d.z * oz);
    c = o.x * o.x + o.y * o.y - k * oz * oz;
  } else {
    return std::nullopt;
  }
  double t0, t1;
  if (!quadratic(a, b, c, &t0, &t1)) return std::nullopt;
  for (double t : {t0, t1})
    if (t > tmin && t < tmax && inside(s, o + d * t)) return t;
  return std::nullopt;
}

LocalGeometry quadricGeometry(const scene::Shape& s, Vec3 p) {
  using scene::ShapeType;
  LocalGeometry g;
  const double phimax = phiMax(s);
  switch (s.type) {
    case ShapeType::Sphere: {
      p = p * (s.radius / length(p));
      if (p.x == 0 && p.y == 0) p.x = 1e-5 * s.radius;
      const double phi = phiOf(p.x, p.y);
      const double zmin = std::clamp(std::min(s.zmin, s.zmax), -s.radius, s.radius);
      const double zmax = std::clamp(std::max(s.zmin, s.zmax), -s.radius, s.radius);
      const double theta_min = std::acos(std::clamp(zmin / s.radius, -1.0, 1.0));
      const double theta_max = std::acos(std::clamp(zmax / s.radius, -1.0, 1.0));
      const double theta = std::acos(std::clamp(p.z / s.radius, -1.0, 1.0));
      g.uv = {phi / phimax, (theta - theta_min) / (theta_max - theta_min)};
      g.dpdu = {-phimax * p.y, phimax * p.x, 0};
      g.n = normalize(p);
      // pbrt-v4 Sphere: dp/dv = (theta_max - theta_min) (z cos phi, z sin phi, -r sin theta);
      // n = p / r, so dn/du = dp/du / r and dn/dv = dp/dv / r.
      g.dpdv = Vec3{p.z * std::cos(phi), p.z * std::sin(phi), -s.radius * std::sin(theta)} *
               (theta_max - theta_min);
      g.dndu = g.dpdu / s.radius;
      g.dndv = g.dpdv / s.radius;
      break;
    }
    case ShapeType::Cylinder: {
      const double r = std::hypot(p.x, p.y);
      p.x *= s.radius / r;
      p.y *= s.radius / r;
      const double zmin = std::min(s.zmin, s.zmax), zmax = std::max(s.zmin, s.zmax);
      g.uv = {phiOf(p.x, p.y) / phimax, (p.z - zmin) / (zmax - zmin)};
      g.dpdu = {-phimax * p.y, phimax * p.x, 0};
      g.n = normalize(Vec3{p.x, p.y, 0});
      g.dpdv = {0, 0, zmax - zmin};
      g.dndu = g.dpdu / s.radius;
      break;
    }
    case ShapeType::Disk: {
      p.z = s.height;
      const double r = std::hypot(p.x, p.y);
      g.uv = {phiOf(p.x, p.y) / phimax, (s.radius - r) / (s.radius - s.inner_radius)};
      g.dpdu = {-phimax * p.y, phimax * p.x, 0};
      if (r == 0) g.dpdu = {1, 0, 0};
      g.n = {0, 0, 1};
      g.dpdv = r > 0 ? Vec3{p.x, p.y, 0} * ((s.inner_radius - s.radius) / r) : Vec3{0, 1, 0};
      break;
    }
    case ShapeType::Cone: {
      g.uv = {phiOf(p.x, p.y) / phimax, p.z / s.height};
      g.dpdu = {-phimax * p.y, phimax * p.x, 0};
      {
        const double one_v = 1 - p.z / s.height;
        g.dpdv = one_v > 1e-12 ? Vec3{-p.x / one_v, -p.y / one_v, s.height} : Vec3{0, 0, s.height};
      }
      // Outward normal of x^2 + y^2 = k (z - h)^2: gradient (x, y, -k (z - h)).
      const double k = (s.radius / s.height) * (s.radius / s.height);
      Vec3 n{p.x, p.y, -k * (p.z - s.height)};
      g.n = length(n) > 0 ? normalize(n) : Vec3{0, 0, 1};
      if (length(g.dpdu) == 0) g.dpdu = {1, 0, 0};
      break;
    }
    default:
      break;
  }
  g.p = p;
  return g;
}

double quadricArea(const scene::Shape& s) {
  using scene::ShapeType;
  const double phimax = phiMax(s);
  switch (s.type) {
    case ShapeType::Sphere: {
      const double zmin = std::clamp(std::min(s.zmin, s.zmax), -s.radius, s.radius);
      const double zmax = std::clamp(std::max(s.zmin, s.zmax), -s.radius, s.radius);
      return phimax * s.radius * (zmax - zmin);
    }
    case ShapeType::Cylinder:
      return (std::max(s.zmin, s.zmax) - std::min(s.zmin, s.zmax)) * s.radius * phimax;
    case ShapeType::Disk:
      return phimax * 0.5 * (s.radius * s.radius - s.inner_radius * s.inner_radius);
    case ShapeType::Cone:
      return s.radius * std::sqrt(s.height * s.height + s.radius * s.radius) * phimax / 2;
    default:
      return 0;
  }
}

std::optional<LocalGeometry> sampleQuadricArea(const scene::Shape& s, Vec2 u) {
  using scene::ShapeType;
  const double phimax = phiMax(s);
  const double phi = u.x * phimax;
  Vec3 p;
  switch (s.type) {
    case ShapeType::Sphere: {
      // Uniform in z (Archimedes) and phi within the sphere's z range.
      const double zmin = std::clamp(std::min(s.zmin, s.zmax), -s.radius, s.radius);
      const double zmax = std::clamp(std::max(s.zmin, s.zmax), -s.radius, s.radius);
      const double z = zmin + u.y * (zmax - zmin);
      const double rxy = std::sqrt(std::max(0.0, s.radius * s.radius - z * z));
      p = {rxy * std::cos(phi), rxy * std::sin(phi), z};
      break;
    }
    case ShapeType::Cylinder: {
      const double z = s.zmin + u.y * (s.zmax - s.zmin);
      p = {s.radius * std::cos(phi), s.radius * std::sin(phi), z};
      break;
    }
    case ShapeType::Disk: {
      const double ri2 = s.inner_radius * s.inner_radius;
      const double r = std::sqrt(ri2 + u.y * (s.radius * s.radius - ri2));
      p = {r * std::cos(phi), r * std::sin(phi), s.height};
      break;
    }
    case ShapeType::Cone: {
      // Area grows linearly with the distance t = sqrt(u) from the apex.
      const double t = std::sqrt(u.y);
      p = {s.radius * t * std::cos(phi), s.radius * t * std::sin(phi), s.height * (1 - t)};
      break;
    }
    default:
      return std::nullopt;
  }
  return quadricGeometry(s, p);
}

}  // namespace lensim::render
