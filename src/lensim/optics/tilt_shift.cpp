#include "lensim/optics/tilt_shift.h"

#include <fmt/format.h>

#include <cmath>
#include <limits>

#include "lensim/util/error.h"

namespace lensim::optics {

FilmPlacement::FilmPlacement(const TiltShift& ts, double z_film_mm) : ts_(ts), z_film_(z_film_mm) {
  const double ax = ts.tilt_deg.x * M_PI / 180, ay = ts.tilt_deg.y * M_PI / 180;
  const double cx = std::cos(ax), sx = std::sin(ax), cy = std::cos(ay), sy = std::sin(ay);
  // R = Ry(ay) Rx(ax), Rx = [1 0 0; 0 cx -sx; 0 sx cx], Ry = [cy 0 sy; 0 1 0; -sy 0 cy].
  r_[0] = {cy, sy * sx, sy * cx};
  r_[1] = {0, cx, -sx};
  r_[2] = {-sy, cy * sx, cy * cx};
}

Vec3 FilmPlacement::filmFromLensVector(const Vec3& v) const {
  return {dot(r_[0], v), dot(r_[1], v), dot(r_[2], v)};
}

Vec3 FilmPlacement::lensFromFilmVector(const Vec3& v) const {
  return r_[0] * v.x + r_[1] * v.y + r_[2] * v.z;  // R^T v
}

Vec3 FilmPlacement::lensFromFilmPoint(const Vec3& p) const {
  Vec3 q = lensFromFilmVector({p.x - ts_.shift_mm.x, p.y - ts_.shift_mm.y, p.z});
  q.z += z_film_;
  return q;
}

Vec3 FilmPlacement::lensFromFilm(Vec2 film_mm) const {
  return lensFromFilmPoint({film_mm.x, film_mm.y, 0});
}

Vec3 FilmPlacement::filmFromLensPoint(const Vec3& p) const {
  Vec3 q = filmFromLensVector({p.x, p.y, p.z - z_film_});
  q.x += ts_.shift_mm.x;
  q.y += ts_.shift_mm.y;
  return q;
}

bool FilmPlacement::intersectFilm(const Vec3& o, const Vec3& d, Vec2* film_mm, double* t) const {
  const Vec3 of = filmFromLensPoint(o), df = filmFromLensVector(d);
  if (df.z == 0) return false;
  const double s = -of.z / df.z;
  *film_mm = {of.x + s * df.x, of.y + s * df.y};
  *t = s;
  return true;
}

ScheimpflugData scheimpflug(const ParaxialData& p, const FilmPlacement& placement) {
  if (!placement.tiltShift().tilted())
    throw Error(
        "Scheimpflug: the film is not tilted (its plane of focus is the lens's normal plane)");
  const double f = p.effective_focal_length_mm;
  const double zh = p.principal_plane_front_z_mm, zh2 = p.principal_plane_back_z_mm;
  const double v = placement.filmZ_mm() - zh2;
  if (!(f > 0)) throw Error(fmt::format("Scheimpflug: focal length {} mm must be > 0", f));
  if (!(v > 0))
    throw Error(
        fmt::format("Scheimpflug: the film's axial point lies {} mm from the rear "
                    "principal plane; expected behind it (> 0)",
                    v));
  const Vec3 n = placement.filmNormal();  // unit, toward +z
  const double nl = std::hypot(n.x, n.y), nz = n.z;
  const Vec3 u_lat{n.x / nl, n.y / nl, 0};  // toward the hinge
  const Vec3 along{-u_lat.y, u_lat.x, 0};   // the lines' direction
  ScheimpflugData s;
  s.tilt_deg = std::atan2(nl, nz) * 180 / M_PI;
  const double cot = nz / nl;
  s.hinge_distance_mm = f * std::hypot(1.0, cot);  // f / sin(tilt)
  // Hinge: the plane through the front nodal point (= front principal point in air) parallel to
  // the film, n . (x - N) = 0, meets the front focal plane z = zh - f.
  s.hinge_point_mm = u_lat * (f * cot) + Vec3{0, 0, zh - f};
  s.hinge_direction = along;
  // Scheimpflug line: the film plane n . (x - (0, 0, z_film)) = 0 at z = zh2 is u_lat . x =
  // nz v / nl; carried to the front principal plane at the same height.
  s.scheimpflug_point_mm = u_lat * (v * cot) + Vec3{0, 0, zh};
  s.scheimpflug_direction = along;
  // The plane through both lines: u_lat . x_lat = cot (v + (f - v) / f (zh - z)), i.e.
  // normal (u_lat, cot (f - v) / f) (before normalising).
  const Vec3 m{u_lat.x, u_lat.y, cot * (f - v) / f};
  s.focus_plane_normal = normalize(m);
  s.image_distance_mm = v;
  if (v == f) {
    s.object_distance_mm = std::numeric_limits<double>::infinity();
    s.focus_plane_axis_z_mm = -std::numeric_limits<double>::infinity();
  } else {
    s.object_distance_mm = f * v / (v - f);
    s.focus_plane_axis_z_mm = zh - s.object_distance_mm;
  }
  const auto angle = [](const Vec3& a, const Vec3& b) {
    return std::acos(std::min(1.0, std::abs(dot(a, b)))) * 180 / M_PI;
  };
  s.focus_plane_to_film_deg = angle(s.focus_plane_normal, n);
  s.focus_plane_to_lens_plane_deg = angle(s.focus_plane_normal, Vec3{0, 0, 1});
  return s;
}

double distanceToFocusPlane(const ScheimpflugData& s, const Vec3& p) {
  // The plane holds the hinge point.
  return dot(s.focus_plane_normal, p - s.hinge_point_mm);
}

}  // namespace lensim::optics
