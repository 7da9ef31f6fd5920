// The spherical camera (pbrt-v4's SphericalCamera). With "mapping" "equirectangular" raster
// x/width is the azimuth phi / 2pi and raster y/height the polar angle theta / pi about the
// camera's +y axis: the direction is (sin theta cos phi, cos theta, sin theta sin phi) in camera
// space. With "equalarea" (pbrt-v4's default; square images) the raster position in [0,1]^2 goes
// through the equal-area octahedral mapping, then y and z are swapped, as in pbrt-v4.
//
// Importance (camera.h): pbrt-v4 defines none for this camera; lensim derives it as pbrt-v4 does
// for a pinhole. Film points are uniform over the image, so the density of a direction is
// 1 / (4 pi) per steradian for the equal-area mapping and 1 / (2 pi^2 sin theta) for the
// equirectangular one (d omega = sin theta d theta d phi = 2 pi^2 sin theta du dv); a point camera
// has no facing, so the importance of a ray is that density, with the camera's "normal" at the
// eye taken along the connection (cos 1) and a position density of 1 (a delta, as a pinhole's).
#include <fmt/format.h>
#include <cmath>

#include <algorithm>

#include "lensim/camera/projective.h"
#include "lensim/sampling/equal_area.h"
#include "lensim/scene/description.h"

namespace lensim::camera {

namespace {

class SphericalCamera final : public Camera {
 public:
  explicit SphericalCamera(const scene::Scene& scene)
      : scene_(&scene),
        motion_(worldFromCamera(scene)),
        equal_area_(scene.camera.spherical_mapping == "equalarea") {}

  bool supportsImportance() const override { return true; }

  std::optional<CameraWiSample> sampleWi(const Vec3& ref, Vec2,
                                         const std::array<double, kCameraWavelengths>&,
                                         double time) const override {
    Transform scratch;
    const Transform& cw = motion_.at(time, scratch);
    const Vec3 eye = cw.applyPoint({0, 0, 0});
    CameraWiSample s;
    s.p_lens = eye;
    const Vec3 d = eye - ref;
    s.distance = length(d);
    if (!(s.distance > 0)) return std::nullopt;
    s.wi = d / s.distance;
    s.n_lens = -s.wi;
    s.pdf = s.distance * s.distance;
    const double w = directionDensity(inverse(cw).applyVector(-s.wi), &s.film_raster);
    if (w == 0) return std::nullopt;
    s.importance.fill(w);
    return s;
  }
  double importance(const Vec3&, const Vec3& d, double, Vec2* film_raster,
                    double time) const override {
    Transform scratch;
    const Transform& cw = motion_.at(time, scratch);
    Vec2 raster;
    const double w = directionDensity(inverse(cw).applyVector(d), &raster);
    if (film_raster) *film_raster = raster;
    return w;
  }
  double pdfWiPos(const Vec3&, const Vec3&, double) const override { return 1; }
  CameraRayPdf rayPdf(const Vec3&, const Vec3& d, double, double time) const override {
    Transform scratch;
    const Transform& cw = motion_.at(time, scratch);
    Vec2 raster;
    return {1, directionDensity(inverse(cw).applyVector(d), &raster)};
  }

  /// The solid-angle density of camera-space direction d and its raster point (0 outside the
  /// film's sample bounds).
  double directionDensity(Vec3 d, Vec2* raster) const {
    const double len = length(d);
    if (!(len > 0)) return 0;
    d = d / len;
    const double xr = scene_->film.x_resolution, yr = scene_->film.y_resolution;
    double density;
    if (equal_area_) {
      const Vec2 uv = sampling::equalAreaSphereToSquare({d.x, d.z, d.y});
      *raster = {uv.x * xr, uv.y * yr};
      density = 1 / (4 * M_PI);
    } else {
      const double theta = std::acos(std::clamp(d.y, -1.0, 1.0));
      double phi = std::atan2(d.z, d.x);
      if (phi < 0) phi += 2 * M_PI;
      *raster = {phi / (2 * M_PI) * xr, theta / M_PI * yr};
      const double sin_theta = std::sin(theta);
      if (!(sin_theta > 0)) return 0;
      density = 1 / (2 * M_PI * M_PI * sin_theta);
    }
    // Film points beyond the image edge (the filter's margin) map back inside (the mapping
    // wraps or clamps), so a path tracer's edge pixels with a filter wider than a pixel see
    // directions from across the seam that a splat, landing on the one raster point of its
    // direction, does not reach: light-traced edge pixels differ there (not with "box").
    if (raster->x < 0 || raster->x > xr || raster->y < 0 || raster->y > yr) return 0;
    return density;
  }

  std::optional<CameraRay> generateRay(const CameraSample& s) const override {
    const double u = s.film_raster.x / scene_->film.x_resolution;
    const double v = s.film_raster.y / scene_->film.y_resolution;
    Vec3 d;
    if (equal_area_) {
      const Vec3 e =
          sampling::equalAreaSquareToSphere({std::clamp(u, 0.0, 1.0), std::clamp(v, 0.0, 1.0)});
      d = {e.x, e.z, e.y};
    } else {
      const double theta = M_PI * v, phi = 2 * M_PI * u;
      d = {std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi)};
    }
    CameraRay r;
    const scene::Camera& c = scene_->camera;
    r.time = c.shutter_open + s.time * (c.shutter_close - c.shutter_open);
    Transform scratch;
    const Transform& cw = motion_.at(r.time, scratch);
    r.origin = cw.applyPoint({0, 0, 0});
    r.direction = normalize(cw.applyVector(d));
    return r;
  }
  std::string describe() const override {
    return equal_area_ ? "spherical (equal-area)" : "spherical (equirectangular)";
  }

 private:
  const scene::Scene* scene_;
  AnimatedTransform motion_;  ///< world from camera over the shutter
  bool equal_area_;
};

}  // namespace

std::unique_ptr<Camera> makeSphericalCamera(const scene::Scene& scene) {
  return std::make_unique<SphericalCamera>(scene);
}

}  // namespace lensim::camera
