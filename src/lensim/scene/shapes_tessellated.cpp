// Tessellation of pbrt's hyperboloid, paraboloid, heightfield and nurbs shapes (see the header).
// Written here from the shapes' definitions in pbrt-v3 (src/shapes/{hyperboloid,paraboloid,
// heightfield,nurbs}.cpp): parameterisations, defaults and orientation follow pbrt; the code and
// the closed-form areas are our own (pbrt-v3's hyperboloid Area() is not used).
#include "lensim/scene/shapes_tessellated.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace lensim::scene {

namespace {

constexpr double kPi = std::numbers::pi;

/// Two triangles per grid cell of an (nu+1) x (nv+1) vertex grid (u fastest), wound so that the
/// face normal is cross(dp/du, dp/dv) as the vertex normals are.
void gridIndices(Mesh& m, int nu, int nv) {
  auto at = [nu](int i, int j) { return j * (nu + 1) + i; };
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      m.indices.insert(m.indices.end(), {at(i, j), at(i + 1, j), at(i + 1, j + 1)});
      m.indices.insert(m.indices.end(), {at(i, j), at(i + 1, j + 1), at(i, j + 1)});
    }
}

Vec3 rotateZ(const Vec3& p, double phi) {
  const double c = std::cos(phi), s = std::sin(phi);
  return {c * p.x - s * p.y, s * p.x + c * p.y, p.z};
}

int sweepSegments(double phimax_deg, int nu) {
  if (nu > 0) return nu;
  return std::max(4, static_cast<int>(std::ceil(phimax_deg / 360.0 * 256)));
}

/// Integral of sqrt(A v^2 + B v + C) over [0, 1], where the quadratic is >= 0 on [0, 1].
double integrateSqrtQuadratic(double A, double B, double C) {
  if (A <= 1e-300) {  // B is then zero too for our profiles; fall back to the general linear form
    if (std::abs(B) < 1e-300) return std::sqrt(std::max(C, 0.0));
    auto F = [&](double v) { return 2.0 / (3.0 * B) * std::pow(std::max(B * v + C, 0.0), 1.5); };
    return F(1) - F(0);
  }
  const double disc = 4 * A * C - B * B;
  auto F = [&](double v) {
    const double q = std::sqrt(std::max(A * v * v + B * v + C, 0.0));
    double f = (2 * A * v + B) * q / (4 * A);
    if (std::abs(disc) > 1e-14 * std::max(1.0, B * B)) {
      const double arg = 2 * std::sqrt(A) * q + 2 * A * v + B;
      if (arg > 0) f += disc / (8 * A * std::sqrt(A)) * std::log(arg);
    }
    return f;
  };
  return F(1) - F(0);
}

}  // namespace

Mesh tessellateHyperboloid(const Vec3& p1, const Vec3& p2, double phimax_deg, int nu, int nv) {
  const double phimax = phimax_deg * kPi / 180;
  nu = sweepSegments(phimax_deg, nu);
  if (nv <= 0) nv = 64;
  const Vec3 d = p2 - p1;
  Mesh m;
  for (int j = 0; j <= nv; ++j) {
    const double v = double(j) / nv;
    const Vec3 pr = p1 * (1 - v) + p2 * v;
    for (int i = 0; i <= nu; ++i) {
      const double u = double(i) / nu, phi = u * phimax;
      const Vec3 p = rotateZ(pr, phi);
      Vec3 n = cross(Vec3{-phimax * p.y, phimax * p.x, 0}, rotateZ(d, phi));
      if (length(n) < 1e-12 * std::max(1.0, dot(d, d))) {
        // On the axis (a cone's apex) dp/du vanishes: take the normal just beside it.
        const double vv = v < 0.5 ? 1e-6 : 1 - 1e-6;
        const Vec3 q = rotateZ(p1 * (1 - vv) + p2 * vv, phi);
        n = cross(Vec3{-q.y, q.x, 0}, rotateZ(d, phi));
      }
      m.positions.push_back(Vec3f(p));
      m.normals.push_back(Vec3f(length(n) > 0 ? normalize(n) : Vec3{0, 0, 1}));
      m.uvs.push_back({float(u), float(v)});
    }
  }
  gridIndices(m, nu, nv);
  return m;
}

double hyperboloidArea(const Vec3& p1, const Vec3& p2, double phimax_deg) {
  // |dp/du x dp/dv| = phimax sqrt(|d|^2 (x^2 + y^2) - (x d_y - y d_x)^2) along the segment
  // (x, y) = p1 + v d, and x d_y - y d_x is constant there.
  const Vec3 d = p2 - p1;
  const double d2 = dot(d, d);
  const double a = d.x * d.x + d.y * d.y, b = 2 * (p1.x * d.x + p1.y * d.y),
               c = p1.x * p1.x + p1.y * p1.y, c0 = p1.x * d.y - p1.y * d.x;
  return phimax_deg * kPi / 180 * integrateSqrtQuadratic(d2 * a, d2 * b, d2 * c - c0 * c0);
}

Mesh tessellateParaboloid(double radius, double zmin, double zmax, double phimax_deg, int nu,
                          int nv) {
  const double phimax = phimax_deg * kPi / 180;
  nu = sweepSegments(phimax_deg, nu);
  if (nv <= 0) nv = 64;
  const double k = radius * radius / zmax;  // x^2 + y^2 = k z
  // Rows equally spaced in the radius (not in z) so the apex is resolved.
  const double rmin = std::sqrt(k * zmin), rmax = std::sqrt(k * zmax);
  Mesh m;
  for (int j = 0; j <= nv; ++j) {
    const double r = rmin + (rmax - rmin) * j / nv;
    const double z = j == nv ? zmax : (j == 0 ? zmin : r * r / k);
    const double v = (z - zmin) / (zmax - zmin);
    for (int i = 0; i <= nu; ++i) {
      const double u = double(i) / nu, phi = u * phimax;
      const Vec3 p{r * std::cos(phi), r * std::sin(phi), z};
      // cross(dp/du, dp/dv) is along (x, y, -k/2): the normalised gradient of x^2 + y^2 - k z.
      m.positions.push_back(Vec3f(p));
      m.normals.push_back(Vec3f(normalize(Vec3{p.x, p.y, -k / 2})));
      m.uvs.push_back({float(u), float(v)});
    }
  }
  gridIndices(m, nu, nv);
  return m;
}

double paraboloidArea(double radius, double zmin, double zmax, double phimax_deg) {
  // Surface of revolution r(z) = sqrt(k z): r sqrt(1 + r'^2) = sqrt(k z + k^2/4).
  const double k = radius * radius / zmax;
  auto F = [k](double z) { return 2.0 / (3.0 * k) * std::pow(k * z + k * k / 4, 1.5); };
  return phimax_deg * kPi / 180 * (F(zmax) - F(zmin));
}

Mesh heightfieldMesh(int nu, int nv, const std::vector<double>& Pz) {
  Mesh m;
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const double x = double(i) / (nu - 1), y = double(j) / (nv - 1);
      m.positions.push_back(
          Vec3f(Vec3{x, y, Pz[static_cast<size_t>(j) * static_cast<size_t>(nu) + size_t(i)]}));
      m.uvs.push_back({float(x), float(y)});
    }
  gridIndices(m, nu - 1, nv - 1);
  return m;
}

namespace {

/// Values and first derivatives of the n B-spline basis functions of `order` on `knots` at t
/// (Cox–de Boor recursion). At the end of the knot range the last non-empty span is used, so the
/// curve is closed on the right.
void bsplineBasis(int n, int order, const std::vector<double>& knots, double t,
                  std::vector<double>& N, std::vector<double>& dN) {
  const int m = n + order;  // number of knots
  // Find the span [knots[s], knots[s+1]) that holds t (order-1 <= s <= n-1).
  int s = order - 1;
  while (s < n - 1 && t >= knots[size_t(s + 1)]) ++s;
  // B[i] holds N_{i,k}; there are m - k of them for order k.
  std::vector<double> B(size_t(m - 1), 0.0), prev;
  B[size_t(s)] = 1;
  dN.assign(size_t(n), 0.0);
  for (int k = 2; k <= order; ++k) {
    prev = B;
    for (int i = 0; i < m - k; ++i) {
      const double d1 = knots[size_t(i + k - 1)] - knots[size_t(i)];
      const double d2 = knots[size_t(i + k)] - knots[size_t(i + 1)];
      double val = 0, der = 0;
      if (d1 > 0) {
        val += (t - knots[size_t(i)]) / d1 * prev[size_t(i)];
        der += (k - 1) / d1 * prev[size_t(i)];
      }
      if (d2 > 0) {
        val += (knots[size_t(i + k)] - t) / d2 * prev[size_t(i + 1)];
        der -= (k - 1) / d2 * prev[size_t(i + 1)];
      }
      B[size_t(i)] = val;
      if (k == order) dN[size_t(i)] = der;
    }
  }
  N.assign(B.begin(), B.begin() + n);
}

}  // namespace

NurbsPoint evaluateNurbs(const NurbsPatch& P, double u, double v) {
  std::vector<double> Nu, dNu, Nv, dNv;
  bsplineBasis(P.nu, P.uorder, P.uknots, u, Nu, dNu);
  bsplineBasis(P.nv, P.vorder, P.vknots, v, Nv, dNv);
  Vec3 S{0, 0, 0}, Su{0, 0, 0}, Sv{0, 0, 0};
  double W = 0, Wu = 0, Wv = 0;
  for (int j = 0; j < P.nv; ++j)
    for (int i = 0; i < P.nu; ++i) {
      const size_t idx = size_t(j) * size_t(P.nu) + size_t(i);
      const double w = P.w[idx];
      const Vec3 wp = P.P[idx] * w;
      const double b = Nu[size_t(i)] * Nv[size_t(j)];
      const double bu = dNu[size_t(i)] * Nv[size_t(j)];
      const double bv = Nu[size_t(i)] * dNv[size_t(j)];
      S += wp * b;
      Su += wp * bu;
      Sv += wp * bv;
      W += w * b;
      Wu += w * bu;
      Wv += w * bv;
    }
  NurbsPoint r;
  r.p = S / W;
  r.dpdu = (Su - r.p * Wu) / W;
  r.dpdv = (Sv - r.p * Wv) / W;
  return r;
}

Mesh nurbsMesh(const NurbsPatch& patch, int dice) {
  Mesh m;
  const int n = dice - 1;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const double u = patch.u0 + (patch.u1 - patch.u0) * i / n;
      const double v = patch.v0 + (patch.v1 - patch.v0) * j / n;
      const NurbsPoint e = evaluateNurbs(patch, u, v);
      const Vec3 nrm = cross(e.dpdu, e.dpdv);
      m.positions.push_back(Vec3f(e.p));
      if (length(nrm) > 0) m.normals.push_back(Vec3f(normalize(nrm)));
      m.uvs.push_back({float(u), float(v)});
    }
  if (m.normals.size() != m.positions.size()) m.normals.clear();  // degenerate: face normals
  gridIndices(m, n, n);
  return m;
}

}  // namespace lensim::scene
