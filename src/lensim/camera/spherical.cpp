// The spherical camera (pbrt-v4's SphericalCamera). With "mapping" "equirectangular" raster
// x/width is the azimuth phi / 2pi and raster y/height the polar angle theta / pi about the
// camera's +y axis: the direction is (sin theta cos phi, cos theta, sin theta sin phi) in camera
// space. With "equalarea" (pbrt-v4's default; square images) the raster position in [0,1]^2 goes
// through the equal-area octahedral mapping, then y and z are swapped, as in pbrt-v4.
#include <fmt/format.h>
#include <cmath>

#include <algorithm>

#include "lensim/camera/projective.h"
#include "lensim/sampling/equal_area.h"
#include "lensim/scene/builder.h"

namespace lensim::camera {

namespace {

class SphericalCamera final : public Camera {
 public:
  explicit SphericalCamera(const scene::Scene& scene)
      : scene_(&scene),
        world_from_camera_(inverse(scene.camera.camera_from_world)),
        equal_area_(scene.camera.spherical_mapping == "equalarea") {}

  std::optional<CameraRay> generateRay(const CameraSample& s) const override {
    const double u = s.film_raster.x / scene_->film.x_resolution;
    const double v = s.film_raster.y / scene_->film.y_resolution;
    Vec3 d;
    if (equal_area_) {
      const Vec3 e =
          render::equalAreaSquareToSphere({std::clamp(u, 0.0, 1.0), std::clamp(v, 0.0, 1.0)});
      d = {e.x, e.z, e.y};
    } else {
      const double theta = M_PI * v, phi = 2 * M_PI * u;
      d = {std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi)};
    }
    CameraRay r;
    r.origin = world_from_camera_.applyPoint({0, 0, 0});
    r.direction = normalize(world_from_camera_.applyVector(d));
    const scene::Camera& c = scene_->camera;
    r.time = c.shutter_open + s.time * (c.shutter_close - c.shutter_open);
    return r;
  }
  std::string describe() const override {
    return equal_area_ ? "spherical (equal-area)" : "spherical (equirectangular)";
  }

 private:
  const scene::Scene* scene_;
  Transform world_from_camera_;
  bool equal_area_;
};

}  // namespace

std::unique_ptr<Camera> makeSphericalCamera(const scene::Scene& scene) {
  return std::make_unique<SphericalCamera>(scene);
}

}  // namespace lensim::camera
