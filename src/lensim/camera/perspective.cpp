// The perspective (pinhole or thin-lens) camera, as pbrt-v4's PerspectiveCamera: camera space
// looks down +z with +y up; the screen window at z = 1 is scaled by tan(fov / 2).
#include <fmt/format.h>
#include <cmath>

#include "lensim/camera/projective.h"
#include "lensim/sampling/sampling.h"
#include "lensim/scene/builder.h"
#include "lensim/util/error.h"

namespace lensim::camera {

std::array<double, 4> screenWindow(const scene::Scene& scene) {
  const scene::Camera& c = scene.camera;
  if (c.screen_window) return *c.screen_window;
  const double aspect = c.frame_aspect_ratio.value_or(double(scene.film.x_resolution) /
                                                      double(scene.film.y_resolution));
  if (aspect > 1) return {-aspect, aspect, -1, 1};
  return {-1, 1, -1 / aspect, 1 / aspect};
}

Vec2 rasterToScreen(const scene::Scene& scene, const std::array<double, 4>& w, Vec2 raster) {
  const double fx = raster.x / scene.film.x_resolution, fy = raster.y / scene.film.y_resolution;
  return {w[0] + fx * (w[1] - w[0]), w[3] - fy * (w[3] - w[2])};
}

namespace {

/// Shared by the projective cameras: the thin lens (Kolb-free textbook model; pbrt-v4's
/// ProjectiveCamera): a point on a disk of radius lens_radius at z = 0 aims at the point where
/// the pinhole ray meets the plane z = focal_distance.
class ProjectiveCamera : public Camera {
 public:
  ProjectiveCamera(const scene::Scene& scene, bool orthographic)
      : scene_(&scene),
        world_from_camera_(inverse(scene.camera.camera_from_world)),
        window_(screenWindow(scene)),
        ortho_(orthographic),
        lens_radius_(scene.camera.lens_radius),
        focal_distance_(scene.camera.focal_distance),
        tan_half_fov_(std::tan(scene.camera.fov_deg * M_PI / 360.0)),
        shutter_open_(scene.camera.shutter_open),
        shutter_close_(scene.camera.shutter_close) {
    const scene::Camera& c = scene.camera;
    if (!ortho_ && (c.fov_deg <= 0 || c.fov_deg >= 180))
      throw Error(c.loc,
                  fmt::format("perspective camera: fov {} is not in (0, 180) degrees", c.fov_deg));
    if (lens_radius_ < 0) throw Error(c.loc, "camera: lensradius must not be negative");
    if (lens_radius_ > 0 && focal_distance_ <= 0)
      throw Error(c.loc, "camera: focaldistance must be positive with a lens radius");
  }

  std::optional<CameraRay> generateRay(const CameraSample& s) const override {
    const Vec2 screen = rasterToScreen(*scene_, window_, s.film_raster);
    Vec3 o, d;
    if (ortho_) {
      o = {screen.x, screen.y, 0};
      d = {0, 0, 1};
    } else {
      o = {0, 0, 0};
      d = normalize(Vec3{screen.x * tan_half_fov_, screen.y * tan_half_fov_, 1});
    }
    if (lens_radius_ > 0) {
      const Vec2 lens = render::sampleUniformDiskConcentric(s.lens) * lens_radius_;
      const double ft = focal_distance_ / d.z;
      const Vec3 focus = o + d * ft;
      o = {o.x + lens.x, o.y + lens.y, 0};
      d = normalize(focus - o);
    }
    CameraRay r;
    r.origin = world_from_camera_.applyPoint(o);
    r.direction = normalize(world_from_camera_.applyVector(d));
    r.time = shutter_open_ + s.time * (shutter_close_ - shutter_open_);
    return r;
  }

  std::string describe() const override {
    if (ortho_) return fmt::format("orthographic, lens radius {}", lens_radius_);
    return fmt::format("perspective, fov {:.4g} deg, lens radius {}, focal distance {}",
                       scene_->camera.fov_deg, lens_radius_, focal_distance_);
  }

 private:
  const scene::Scene* scene_;
  Transform world_from_camera_;
  std::array<double, 4> window_;
  bool ortho_;
  double lens_radius_, focal_distance_, tan_half_fov_, shutter_open_, shutter_close_;
};

}  // namespace

std::unique_ptr<Camera> makePerspectiveCamera(const scene::Scene& scene) {
  return std::make_unique<ProjectiveCamera>(scene, false);
}

std::unique_ptr<Camera> makeOrthographicCamera(const scene::Scene& scene) {
  return std::make_unique<ProjectiveCamera>(scene, true);
}

}  // namespace lensim::camera
