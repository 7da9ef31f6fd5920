// The perspective (pinhole or thin-lens) camera, as pbrt-v4's PerspectiveCamera: camera space
// looks down +z with +y up; the screen window at z = 1 is scaled by tan(fov / 2).
//
// Importance (camera.h, CameraWiSample): pbrt-v4's PerspectiveCamera::We, PDF_We and SampleWi
// (src/pbrt/cameras.cpp): a ray leaving the lens at angle theta to the axis carries
// W = 1 / (A lens_area cos^4 theta), A the area of the whole image on the plane z = 1 and
// lens_area pi r^2 (1 for a pinhole), so that the importance integrated over the film is 1 per
// image: one light path per pixel and sample, splatted and divided by the samples per pixel,
// estimates the same image as camera rays of weight 1. pbrt-v4 defines no importance for the
// orthographic camera; lensim derives it the same way (ProjectiveCamera::orthoImportance below).
// Both take the camera transform to be rigid (lens and film areas in scene units): a scaling
// camera transform would scale them.
#include <fmt/format.h>
#include <cmath>

#include "lensim/camera/film_bounds.h"
#include "lensim/camera/projective.h"
#include "lensim/sampling/sampling.h"
#include "lensim/scene/description.h"
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
        motion_(worldFromCamera(scene)),
        world_from_camera_(inverse(scene.camera.camera_from_world)),
        inverse_(scene.camera.camera_from_world),
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
    film_ = FilmSampleBounds(scene);
    const double sx = window_[1] - window_[0], sy = window_[3] - window_[2];
    image_area_ =
        ortho_ ? std::abs(sx * sy) : std::abs(sx * sy) * tan_half_fov_ * tan_half_fov_;  // at z = 1
    lens_area_ = lens_radius_ > 0 ? M_PI * lens_radius_ * lens_radius_ : 1.0;
  }

  bool supportsImportance() const override { return true; }

  /// World from camera at `time`, and its inverse (the static ones without motion).
  struct Placement {
    Transform moving;
    const Transform* world_from_camera;
    Transform camera_from_world_moving;
    const Transform* camera_from_world;
  };
  void place(double time, Placement& p) const {
    if (!motion_.isAnimated()) {
      p.world_from_camera = &world_from_camera_;
      p.camera_from_world = &inverse_;
      return;
    }
    p.moving = motion_.interpolate(time);
    p.camera_from_world_moving = inverse(p.moving);
    p.world_from_camera = &p.moving;
    p.camera_from_world = &p.camera_from_world_moving;
  }

  std::optional<CameraWiSample> sampleWi(const Vec3& ref, Vec2 u,
                                         const std::array<double, kCameraWavelengths>&,
                                         double time) const override {
    Placement pl;
    place(time, pl);
    const Transform& cw = *pl.world_from_camera;
    const Transform& cfw = *pl.camera_from_world;
    const Vec3 ref_c = cfw.applyPoint(ref);
    if (ortho_) return orthoSampleWi(ref_c, u, cw);
    // pbrt-v4's PerspectiveCamera::SampleWi: a uniform point on the lens disc (the eye for a
    // pinhole), its solid-angle density at ref and the importance of the ray toward ref.
    const Vec2 l =
        lens_radius_ > 0 ? sampling::sampleUniformDiskConcentric(u) * lens_radius_ : Vec2{0, 0};
    CameraWiSample s;
    s.p_lens = cw.applyPoint({l.x, l.y, 0});
    const Vec3 d = s.p_lens - ref;
    s.distance = length(d);
    if (!(s.distance > 0)) return std::nullopt;
    s.wi = d / s.distance;
    s.n_lens = normalize(cw.applyVector({0, 0, 1}));
    const double cos_lens = std::abs(dot(s.n_lens, s.wi));
    if (cos_lens == 0) return std::nullopt;
    s.pdf = s.distance * s.distance / (cos_lens * lens_area_);
    const double w = We({l.x, l.y, 0}, cfw.applyVector(-s.wi), &s.film_raster);
    if (w == 0) return std::nullopt;
    s.importance.fill(w);
    return s;
  }

  double pdfWiPos(const Vec3& ref, const Vec3& p_lens, double time) const override {
    if (lens_radius_ == 0) return 1;
    Placement pl;
    place(time, pl);
    const Transform& cfw = *pl.camera_from_world;
    const Vec3 p = cfw.applyPoint(p_lens);
    const double r2 = lens_radius_ * lens_radius_ * (1 + 1e-9);
    if (!ortho_) return p.x * p.x + p.y * p.y > r2 ? 0 : 1 / lens_area_;
    // The orthographic thin lens: p_lens = ref - d ref.z / d.z, d set by the lens point l, so
    // p_lens.xy = ref.xy + l ref.z / fd: the density of l, 1 / (pi r^2), times (fd / ref.z)^2,
    // where that l lies on the lens disc (the disc is about the film point, not the axis).
    const Vec3 rc = cfw.applyPoint(ref);
    if (!(rc.z > 0)) return 0;
    const double lx = (p.x - rc.x) * focal_distance_ / rc.z;
    const double ly = (p.y - rc.y) * focal_distance_ / rc.z;
    if (lx * lx + ly * ly > r2) return 0;
    return focal_distance_ * focal_distance_ / (rc.z * rc.z * lens_area_);
  }

  double importance(const Vec3& o, const Vec3& d, double, Vec2* film_raster,
                    double time) const override {
    Placement pl;
    place(time, pl);
    const Transform& cfw = *pl.camera_from_world;
    const Vec3 o_c = cfw.applyPoint(o), d_c = cfw.applyVector(d);
    Vec2 raster;
    const double w = ortho_ ? orthoWe(o_c, d_c, &raster) : We(o_c, d_c, &raster);
    if (film_raster) *film_raster = raster;
    return w;
  }

  CameraRayPdf rayPdf(const Vec3& o, const Vec3& d, double, double time) const override {
    Placement pl;
    place(time, pl);
    const Transform& cfw = *pl.camera_from_world;
    const Vec3 o_c = cfw.applyPoint(o), d_c = normalize(cfw.applyVector(d));
    Vec2 raster;
    if (ortho_) {
      if (orthoWe(o_c, d_c, &raster) == 0 && lens_radius_ > 0) return {};
      // Origins uniform over the image (the film point; the lens offset moves it), directions
      // by the lens point: fd^2 / (pi r^2 cos^3); a pinhole's direction is a delta (pdf 1).
      const double c = d_c.z;
      if (lens_radius_ == 0) return {1 / image_area_, 1};
      return {1 / image_area_, focal_distance_ * focal_distance_ / (lens_area_ * c * c * c)};
    }
    if (We(o_c, d_c, &raster) == 0) return {};
    // pbrt-v4's PerspectiveCamera::PDF_We.
    const double c = d_c.z;
    return {lens_radius_ > 0 ? 1 / lens_area_ : 1.0, 1 / (image_area_ * c * c * c)};
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
      const Vec2 lens = sampling::sampleUniformDiskConcentric(s.lens) * lens_radius_;
      const double ft = focal_distance_ / d.z;
      const Vec3 focus = o + d * ft;
      o = {o.x + lens.x, o.y + lens.y, 0};
      d = normalize(focus - o);
    }
    CameraRay r;
    // pbrt-v4's CameraBase::SampleTime: a time uniform over the shutter; the ray is placed by
    // the camera transform at that time (CameraTransform::RenderFromCamera(ray)).
    r.time = shutter_open_ + s.time * (shutter_close_ - shutter_open_);
    const auto place = [&](const Transform& cw) {
      r.origin = cw.applyPoint(o);
      r.direction = normalize(cw.applyVector(d));
    };
    if (motion_.isAnimated())
      place(motion_.interpolate(r.time));
    else
      place(world_from_camera_);
    return r;
  }

  /// Importance of the camera-space ray (o on the lens, d toward the scene) and its raster
  /// point (pbrt-v4's PerspectiveCamera::We); 0 outside the film's sample bounds.
  double We(const Vec3& o, Vec3 d, Vec2* raster) const {
    d = normalize(d);
    const double c = d.z;
    if (!(c > 0)) return 0;
    // The film point: through the point the ray crosses the plane of focus, back through the
    // lens centre (a pinhole: the direction itself).
    Vec3 q = d / c;
    if (lens_radius_ > 0) {
      if (o.x * o.x + o.y * o.y > lens_radius_ * lens_radius_ * (1 + 1e-9)) return 0;
      q = (o + d * (focal_distance_ / c)) / focal_distance_;
    }
    *raster = screenToRaster({q.x / tan_half_fov_, q.y / tan_half_fov_});
    if (!film_.inside(*raster)) return 0;
    return 1 / (image_area_ * lens_area_ * c * c * c * c);
  }

  /// The orthographic camera's importance, derived as pbrt-v4 derives the perspective one: a
  /// film point x (uniform over the image, area A in camera units) and a lens point l (uniform on
  /// the disc) give the ray from o = x + l toward the point of focus x + (0, 0, fd), direction
  /// d = (-l, fd) / |(-l, fd)|; the density of (o, d) per unit area and solid angle is
  /// (1/A) (1/(pi r^2)) fd^2 / cos^3, so W = fd^2 / (A pi r^2 cos^4). A pinhole's rays all run
  /// along +z: its importance is 1/A per unit area, a delta in direction (returned for d = +z
  /// by sampleWi only; 0 here).
  double orthoWe(const Vec3& o, Vec3 d, Vec2* raster) const {
    d = normalize(d);
    const double c = d.z;
    if (!(c > 0) || lens_radius_ == 0) return 0;
    const Vec2 l{-d.x / c * focal_distance_, -d.y / c * focal_distance_};
    if (l.x * l.x + l.y * l.y > lens_radius_ * lens_radius_) return 0;
    *raster = screenToRaster({o.x - l.x, o.y - l.y});
    if (!film_.inside(*raster)) return 0;
    return focal_distance_ * focal_distance_ / (image_area_ * lens_area_ * c * c * c * c);
  }

  std::optional<CameraWiSample> orthoSampleWi(const Vec3& ref_c, Vec2 u,
                                              const Transform& cw) const {
    if (!(ref_c.z > 0)) return std::nullopt;
    CameraWiSample s;
    s.n_lens = normalize(cw.applyVector({0, 0, 1}));
    if (lens_radius_ == 0) {
      // The one ray through ref: along -z to the film plane. Importance 1/A per unit area and
      // pdf 1 (a delta direction), so that W L |cos| / pdf is the projected-area measure.
      const Vec3 o{ref_c.x, ref_c.y, 0};
      s.film_raster = screenToRaster({o.x, o.y});
      if (!film_.inside(s.film_raster)) return std::nullopt;
      s.p_lens = cw.applyPoint(o);
      s.wi = -s.n_lens;
      s.distance = length(s.p_lens - cw.applyPoint(ref_c));
      s.pdf = 1;
      s.importance.fill(1 / image_area_);
      return s;
    }
    // The lens point fixes the direction; the ray through ref in that direction meets z = 0 at o.
    const Vec2 l = sampling::sampleUniformDiskConcentric(u) * lens_radius_;
    const Vec3 d = normalize(Vec3{-l.x, -l.y, focal_distance_});
    const Vec3 o = ref_c - d * (ref_c.z / d.z);
    const double w = orthoWe(o, d, &s.film_raster);
    if (w == 0) return std::nullopt;
    s.p_lens = cw.applyPoint(o);
    const Vec3 to_lens = s.p_lens - cw.applyPoint(ref_c);
    s.distance = length(to_lens);
    s.wi = to_lens / s.distance;
    // Solid angle of directions per lens area: cos^3 / fd^2.
    s.pdf = focal_distance_ * focal_distance_ / (d.z * d.z * d.z * lens_area_);
    s.importance.fill(w);
    return s;
  }

  Vec2 screenToRaster(Vec2 screen) const {
    const double fx = (screen.x - window_[0]) / (window_[1] - window_[0]);
    const double fy = (window_[3] - screen.y) / (window_[3] - window_[2]);
    return {fx * scene_->film.x_resolution, fy * scene_->film.y_resolution};
  }

  std::string describe() const override {
    if (ortho_) return fmt::format("orthographic, lens radius {}", lens_radius_);
    return fmt::format("perspective, fov {:.4g} deg, lens radius {}, focal distance {}",
                       scene_->camera.fov_deg, lens_radius_, focal_distance_);
  }

 private:
  const scene::Scene* scene_;
  AnimatedTransform motion_;               ///< world from camera over the shutter
  Transform world_from_camera_, inverse_;  ///< at the start time
  std::array<double, 4> window_;
  bool ortho_;
  double lens_radius_, focal_distance_, tan_half_fov_, shutter_open_, shutter_close_;
  FilmSampleBounds film_;
  double image_area_ = 1, lens_area_ = 1;
};

}  // namespace

std::unique_ptr<Camera> makePerspectiveCamera(const scene::Scene& scene) {
  return std::make_unique<ProjectiveCamera>(scene, false);
}

std::unique_ptr<Camera> makeOrthographicCamera(const scene::Scene& scene) {
  return std::make_unique<ProjectiveCamera>(scene, true);
}

}  // namespace lensim::camera
