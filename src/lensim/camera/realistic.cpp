#include "lensim/camera/realistic.h"

#include <fmt/format.h>

#include <chrono>
#include <cmath>

#include "lensim/scene/builder.h"
#include "lensim/util/error.h"
#include "lensim/util/log.h"

namespace lensim::camera {

RealisticCamera::RealisticCamera(RealisticSettings settings) : settings_(std::move(settings)) {
  const auto t0 = std::chrono::steady_clock::now();
  if (!(settings_.film_diagonal_mm > 0))
    throw Error(fmt::format("film diagonal {} mm must be > 0", settings_.film_diagonal_mm));
  optics::LensPrescription prescription = optics::readLensFile(settings_.lens_path);

  // The set stop radius (the aperture shape's unit); the physical stop opens to the shape's
  // extent, and the shape decides what passes.
  optics::LensSetup setup = settings_.setup;
  {
    const std::optional<int> stop = prescription.stopIndex();
    const std::optional<double> max_d =
        stop ? std::optional<double>(prescription.surfaces[*stop].aperture_diameter_mm)
             : std::nullopt;
    double d = setup.aperture_diameter_mm ? *setup.aperture_diameter_mm : max_d.value_or(0);
    if (max_d && d > *max_d) d = *max_d;  // focusLens warns about the clamp below
    stop_radius_mm_ = d / 2;
    if (!settings_.aperture.isRound() && setup.aperture_diameter_mm)
      setup.aperture_diameter_mm = *setup.aperture_diameter_mm * settings_.aperture.extent();
  }
  lens_ = optics::focusLens(std::move(prescription), setup);

  // Film extent from the diagonal and the image's aspect ratio.
  const double aspect = static_cast<double>(settings_.y_resolution) / settings_.x_resolution;
  const double width = settings_.film_diagonal_mm / std::sqrt(1 + aspect * aspect);
  half_width_mm_ = width / 2;
  half_height_mm_ = aspect * width / 2;
  optics::ExitPupilOptions pupil_options;
  if (settings_.rear_disc_only) {
    // The disc's edge makes the region change faster across the film: twice the radial nodes
    // keep the waste under 5% (fisheye: 5.1% with the default 24, 4.3% with 48).
    pupil_options.rear_disc_radius_mm = lens_.lens->interfaces().back().semi_aperture_mm;
    pupil_options.radial_bins = 48;
  }
  for (const optics::Interface& in : lens_.lens->interfaces())
    if (!in.shape.isRotational()) pupil_options.rotational = false;  // anamorphic: 2-D bound
  pupil_.emplace(*lens_.lens, lens_.paraxial, std::hypot(half_width_mm_, half_height_mm_),
                 pupil_options);
  centre_area_mm2_ = pupil_->area_mm2({0, 0});
  if (settings_.simple_weighting && !(centre_area_mm2_ > 0))
    throw Error("simpleweighting: no light reaches the centre of the film to normalise by");
  startup_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

Vec2 RealisticCamera::filmPoint(Vec2 raster) const {
  const double sx = raster.x / settings_.x_resolution, sy = raster.y / settings_.y_resolution;
  // pbrt: the raster x axis runs along -x of the film (the lens turns the image around).
  const double fx = -half_width_mm_ + 2 * half_width_mm_ * sx;
  const double fy = -half_height_mm_ + 2 * half_height_mm_ * sy;
  return {-fx, fy};
}

std::optional<RealisticCamera::FilmRay> RealisticCamera::filmRay(
    const CameraSample& sample, Vec2 film, const std::optional<optics::PupilSample>& ps) const {
  const optics::LensSystem& lens = *lens_.lens;
  if (!ps) return std::nullopt;
  if (settings_.rear_disc_only) {
    const double rr = lens.interfaces().back().semi_aperture_mm;
    const Vec3& q = ps->rear_point_mm;
    if (q.x * q.x + q.y * q.y > rr * rr) return std::nullopt;
  }
  const double z_film = lens.filmZ_mm();
  const Vec3 from{film.x, film.y, z_film};
  if (settings_.zero_if_neighbour_blocked) {
    for (const Vec2 shift : {Vec2{1, 0}, Vec2{0, 1}}) {
      const Vec2 f = filmPoint(sample.film_raster + shift);
      const Vec3 o{f.x, f.y, z_film};
      const Vec3 d = normalize(ps->rear_point_mm - o);
      if (!lens.tracerFloat().traceFromFilm(optics::RayT<float>{Vec3f(o), Vec3f(d)}).ok())
        return std::nullopt;
    }
  }
  const Vec3 to_rear = ps->rear_point_mm - from;
  const Vec3 dir = to_rear / length(to_rear);
  // The float tracer: it agrees with the double one to ~1e-4 mm (optics tests) and is faster.
  return FilmRay{optics::RayT<float>{Vec3f(from), Vec3f(dir)}, -dir.z, ps->area_mm2};
}

std::optional<CameraRay> RealisticCamera::finish(const optics::TraceResultT<float>& r,
                                                 const FilmRay& f, double time) const {
  double transmission = 1;
  if (!settings_.aperture.isRound() && stop_radius_mm_ > 0) {
    transmission = settings_.aperture.transmission(
        Vec2{r.stop_point.x / stop_radius_mm_, r.stop_point.y / stop_radius_mm_});
    if (transmission <= 0) return std::nullopt;
  }
  const optics::LensSystem& lens = *lens_.lens;
  // Lens space (mm, +z toward the film) to camera space (camera units, +z toward the scene).
  const double u = settings_.camera_units_per_mm;
  // Camera-space z: distance toward the scene from the film (pbrt-v3/v4) or from the front
  // vertex (the v1/v2 assignment's convention).
  const double z0 = settings_.origin_at_front_vertex ? 0.0 : lens.filmZ_mm();
  const Vec3 o_cam{r.ray.origin.x * u, r.ray.origin.y * u, (z0 - r.ray.origin.z) * u};
  const Vec3 d_cam{double(r.ray.direction.x), double(r.ray.direction.y),
                   -double(r.ray.direction.z)};
  CameraRay ray;
  ray.origin = settings_.world_from_camera.applyPoint(o_cam);
  ray.direction = normalize(settings_.world_from_camera.applyVector(d_cam));
  // w = T cos^4(theta) A / z^2 (z: film to the rear-vertex plane, where the pupil is sampled);
  // the film multiplies by the exposure time (and ISO / 100), as pbrt-v4's imaging ratio does.
  const double z = lens.filmDistance_mm();
  const double c2 = f.cos_theta * f.cos_theta;
  const double norm = settings_.simple_weighting ? centre_area_mm2_ : z * z;
  ray.weight = transmission * c2 * c2 * f.area_mm2 / norm;
  ray.time = time * settings_.exposure_time;
  return ray;
}

std::optional<CameraRay> RealisticCamera::generateRay(const CameraSample& sample) const {
  const Vec2 film = filmPoint(sample.film_raster);
  const std::optional<FilmRay> f = filmRay(sample, film, pupil_->sample(film, sample.lens));
  if (!f) return std::nullopt;
  const optics::TraceResultT<float> r = lens_.lens->tracerFloat().traceFromFilm(f->ray);
  if (!r.ok()) return std::nullopt;
  return finish(r, *f, sample.time);
}

void RealisticCamera::generateRays(const CameraSample* samples, int n,
                                   std::optional<CameraRay>* rays) const {
  constexpr int kB = optics::LensTracer<float>::kBatch;
  static_assert(kB >= kMaxBatch);
  FilmRay lanes[kB];
  optics::RayT<float> in[kB];
  optics::TraceResultT<float> out[kB];
  static_assert(optics::ExitPupilSampler::kBatch >= kMaxBatch);
  int index[kB];
  Vec2 film[kB], u[kB];
  std::optional<optics::PupilSample> ps[kB];
  n = std::min(n, int(kMaxBatch));
  for (int i = 0; i < n; ++i) {
    film[i] = filmPoint(samples[i].film_raster);
    u[i] = samples[i].lens;
  }
  pupil_->sampleBatch(film, u, n, ps);
  int m = 0;
  for (int i = 0; i < n; ++i) {
    rays[i].reset();
    if (std::optional<FilmRay> f = filmRay(samples[i], film[i], ps[i])) {
      lanes[m] = *f;
      in[m] = f->ray;
      index[m++] = i;
    }
  }
  lens_.lens->tracerFloat().traceFromFilmBatch(in, m, out);
  for (int k = 0; k < m; ++k)
    if (out[k].ok()) rays[index[k]] = finish(out[k], lanes[k], samples[index[k]].time);
}

bool RealisticCamera::reachesFilm(Vec2 film_raster) const {
  return pupil_->area_mm2(filmPoint(film_raster)) > 0;
}

std::string RealisticCamera::describe() const {
  const optics::LensSystem& lens = *lens_.lens;
  return fmt::format(
      "realistic: {} ({}), f = {:.2f} mm, f/{:.2f}, film distance {:.3f} mm, focus {}, "
      "{:.1f} x {:.1f} mm film, aperture {}",
      lens.prescription().name, lens.prescription().path, lens_.paraxial.effective_focal_length_mm,
      lens_.paraxial.f_number, lens.filmDistance_mm(),
      std::isinf(lens_.focus_distance_m) ? std::string("at infinity")
                                         : fmt::format("{:.4g} m", lens_.focus_distance_m),
      2 * half_width_mm_, 2 * half_height_mm_, settings_.aperture.describe());
}

std::unique_ptr<Camera> makeRealisticCamera(const scene::Scene& scene,
                                            const CameraOptions& options) {
  const scene::Camera& c = scene.camera;
  RealisticSettings s;
  s.x_resolution = scene.film.x_resolution;
  s.y_resolution = scene.film.y_resolution;
  s.world_from_camera = inverse(c.camera_from_world);
  s.zero_if_neighbour_blocked = options.pbrt_v2_quirks;
  try {
    if (c.legacy_realistic) {
      // pbrt-v1/v2 (CS348B): camera space in millimetres, film distance given, no exposure time.
      const scene::LegacyRealistic& r = *c.legacy_realistic;
      s.lens_path = r.lens_file;
      s.setup.aperture_diameter_mm = r.aperture_diameter_mm;
      s.setup.film_distance_mm = r.film_distance_mm;
      s.film_diagonal_mm = r.film_diagonal_mm;
      s.camera_units_per_mm = 1.0;
      s.exposure_time = 1.0;
      s.rear_disc_only = true;
      s.origin_at_front_vertex = true;
    } else if (c.realistic) {
      const scene::Realistic& r = *c.realistic;
      s.lens_path = r.lens_file;
      s.setup.aperture_diameter_mm = r.aperture_diameter_mm;
      if (r.film_distance_mm)
        s.setup.film_distance_mm = r.film_distance_mm;
      else
        s.setup.focus_distance_m = r.focus_distance_m;
      s.setup.focus_method = optics::parseFocusMethod(r.focus_method);
      s.film_diagonal_mm = scene.film.diagonal_mm;
      s.camera_units_per_mm = scene::Realistic::kSceneUnitsPerLensUnit;
      s.exposure_time = c.shutter_close - c.shutter_open;
      s.simple_weighting = r.simple_weighting;
      if (r.blades > 0)
        s.aperture = ApertureShape::polygon(r.blades, r.blade_rotation_deg);
      else if (!r.aperture.empty())
        s.aperture = ApertureShape::isNamed(r.aperture) ? ApertureShape::named(r.aperture)
                                                        : ApertureShape::image(r.aperture);
    } else {
      throw Error(c.loc, "realistic camera without lens parameters");
    }
    auto camera = std::make_unique<RealisticCamera>(std::move(s));
    logDiagnostics(camera->diagnostics());
    return camera;
  } catch (const Error& e) {
    // Errors in the lens file keep their own location; the others belong to the camera.
    if (e.loc().valid()) throw;
    throw Error(c.loc, "realistic camera: " + e.message());
  }
}

}  // namespace lensim::camera
