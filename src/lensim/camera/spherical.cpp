// The spherical camera with the equirectangular mapping (pbrt-v4's SphericalCamera with
// "mapping" "equirectangular"): raster x/width is the azimuth phi / 2pi, raster y/height the
// polar angle theta / pi, in a frame whose pole is the camera's +y axis: the direction is
// (sin theta cos phi, cos theta, sin theta sin phi) in camera space.
#include <fmt/format.h>
#include <cmath>

#include "lensim/camera/projective.h"
#include "lensim/scene/builder.h"

namespace lensim::camera {

namespace {

class SphericalCamera final : public Camera {
 public:
  explicit SphericalCamera(const scene::Scene& scene)
      : scene_(&scene), world_from_camera_(inverse(scene.camera.camera_from_world)) {}

  std::optional<CameraRay> generateRay(const CameraSample& s) const override {
    const double u = s.film_raster.x / scene_->film.x_resolution;
    const double v = s.film_raster.y / scene_->film.y_resolution;
    const double theta = M_PI * v, phi = 2 * M_PI * u;
    const Vec3 d{std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi)};
    CameraRay r;
    r.origin = world_from_camera_.applyPoint({0, 0, 0});
    r.direction = normalize(world_from_camera_.applyVector(d));
    const scene::Camera& c = scene_->camera;
    r.time = c.shutter_open + s.time * (c.shutter_close - c.shutter_open);
    return r;
  }
  std::string describe() const override { return "spherical (equirectangular)"; }

 private:
  const scene::Scene* scene_;
  Transform world_from_camera_;
};

}  // namespace

std::unique_ptr<Camera> makeSphericalCamera(const scene::Scene& scene) {
  return std::make_unique<SphericalCamera>(scene);
}

}  // namespace lensim::camera
