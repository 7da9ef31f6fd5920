#include "lensim/camera/realistic.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <tuple>

#include "lensim/camera/film_bounds.h"
#include "lensim/camera/realistic_placed.h"
#include "lensim/optics/anamorphic.h"
#include "lensim/optics/configurations.h"
#include "lensim/optics/design/design_job.h"
#include "lensim/optics/design/tolerance.h"
#include "lensim/optics/glass/library.h"
#include "lensim/optics/surface_shape.h"
#include "lensim/sampling/filter.h"
#include "lensim/sampling/sampling.h"
#include "lensim/scene/description.h"
#include "lensim/util/error.h"
#include "lensim/util/log.h"

namespace lensim::camera {

namespace {

// Processor time of the whole process (every thread), seconds.
double processCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

// Monte Carlo build `as_built` of the design job's tolerancing, exactly as `lens tolerance
// --write-builds` writes it (optics/design/tolerance.h, asBuiltLens).
optics::LensPrescription asBuiltPrescription(const RealisticSettings& s) {
  try {
    const optics::design::DesignJob job = optics::design::readDesignJob(s.tolerance_job);
    if (job.tolerance.tolerances.empty())
      throw Error(fmt::format("design job {} has no \"tolerancing\" section with tolerances",
                              s.tolerance_job));
    std::error_code ec;
    const bool same = job.lens_path == s.lens_path ||
                      std::filesystem::equivalent(job.lens_path, s.lens_path, ec);
    if (!same)
      throw Error(fmt::format("lensfile {} is not the design job's lens {}", s.lens_path,
                              job.lens_path));
    if (s.as_built < 0 || s.as_built >= job.tolerance.monte_carlo)
      throw Error(fmt::format("asbuilt {}: expected a build index from 0 to {} (the job runs {} "
                              "Monte Carlo builds)",
                              s.as_built, job.tolerance.monte_carlo - 1,
                              job.tolerance.monte_carlo));
    optics::LensPrescription p = optics::design::asBuiltLens(job, s.as_built);
    logInfo(fmt::format("{}: rendering {}", s.tolerance_loc.str(), p.name));
    return p;
  } catch (const Error& e) {
    if (e.loc().valid() && e.loc().line > 0) throw;
    throw Error(s.tolerance_loc, e.message());
  }
}

}  // namespace

RealisticCamera::RealisticCamera(RealisticSettings settings) : settings_(std::move(settings)) {
  const auto t0 = std::chrono::steady_clock::now();
  const double cpu0 = processCpuSeconds();
  if (!(settings_.film_diagonal_mm > 0))
    throw Error(fmt::format("film diagonal {} mm must be > 0", settings_.film_diagonal_mm));
  optics::LensPrescription prescription =
      settings_.prescription            ? *settings_.prescription
      : !settings_.tolerance_job.empty() ? asBuiltPrescription(settings_)
                                         : optics::readLensFile(settings_.lens_path);
  if (prescription.fold_loc)
    throw Error(*prescription.fold_loc,
                "a lens folded by coordinate breaks (TYPE COORDBRK) cannot be rendered: the "
                "camera models coaxial lenses (`lensim lens info` reads it)");
  if (prescription.noncoaxial_loc)
    throw Error(*prescription.noncoaxial_loc,
                fmt::format("{}: a lens with tilted or decentred surfaces cannot be rendered "
                            "here: the pbrt-v1/v2 camera is coaxial only (a pbrt-v3/v4 realistic "
                            "camera renders it, camera/realistic_placed.h)",
                            prescription.noncoaxial_reason));
  optics::LensSetup setup = settings_.setup;
  if (!settings_.tolerance_job.empty() && settings_.as_built_film) {
    setup.film_distance_mm = prescription.surfaces.back().thickness_mm;
    setup.focus_distance_m.reset();
  }
  if (settings_.configuration || settings_.zoom_focal_length_mm) {
    try {
      if (settings_.configuration) {
        prescription = optics::selectConfiguration(prescription, *settings_.configuration);
      } else {
        optics::ZoomSetting z =
            optics::zoomToFocalLength(prescription, *settings_.zoom_focal_length_mm);
        logInfo(fmt::format("{}: zoom between configurations {} and {} at t = {:.6f} "
                            "(thicknesses linear in t): EFL {:.6f} mm for {:.6f} mm requested",
                            settings_.zoom_loc.str(), z.config_a, z.config_b, z.t,
                            z.achieved_efl_mm, z.requested_efl_mm));
        prescription = std::move(z.prescription);
      }
    } catch (const Error& e) {
      throw Error(settings_.zoom_loc, e.message());
    }
  }

  // The set stop radius (the aperture shape's unit); the physical stop opens to the shape's
  // extent, and the shape decides what passes.
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
  if (settings_.glass_match)
    for (const Diagnostic& d : optics::matchCatalogGlasses(prescription)) logDiagnostic(d);
  // Focus is solved at the lens's primary wavelength (the file's, else the d line).
  lens_ = optics::focusLens(std::move(prescription), setup);
  dispersive_ = lens_.lens->dispersive();
  {
    std::vector<Diagnostic> ranges;
    optics::checkRenderGlassRanges(lens_.lens->glasses(), kIndexFrom_nm, kIndexTo_nm,
                                   lens_.lens->prescription().path, &ranges);
    logDiagnostics(ranges);
  }
  // Glasses with transmittance data are catalogue glasses, which disperse: absorption is applied
  // where the wavelengths are (dispersiveRay, traceToFilm).
  absorption_ = optics::LensAbsorption(*lens_.lens);
  absorbs_ = settings_.glass_absorption && dispersive_ && absorption_.any();
  if (dispersive_) {
    const int n = lens_.lens->surfaceCount();
    const int steps = int(std::lround((kIndexTo_nm - kIndexFrom_nm) / kIndexStep_nm));
    std::vector<double> before(size_t(n), 1.0), after(size_t(n), 1.0);
    index_table_.resize(size_t(steps + 1) * size_t(n));
    for (int k = 0; k <= steps; ++k) {
      lens_.lens->indicesAt(kIndexFrom_nm + k * kIndexStep_nm, before.data(), after.data());
      std::copy(after.begin(), after.end(), index_table_.begin() + ptrdiff_t(k) * n);
    }
  }
  {
    static std::atomic<std::uint64_t> next_id{1};
    id_ = next_id++;
  }

  // Film extent from the diagonal and the image's aspect ratio.
  const Vec2 half = filmHalfExtent_mm(settings_.film_diagonal_mm, settings_.x_resolution,
                                      settings_.y_resolution);
  half_width_mm_ = half.x;
  half_height_mm_ = half.y;
  optics::ExitPupilOptions pupil_options;
  if (settings_.rear_disc_only) {
    // The disc's edge makes the region change faster across the film: twice the radial nodes
    // keep the waste under 5% (fisheye: 5.1% with the default 24, 4.3% with 48).
    pupil_options.rear_disc_radius_mm = lens_.lens->interfaces().back().semi_aperture_mm;
    pupil_options.radial_bins = 48;
  }
  // Anamorphic: a 2-D bound.
  pupil_options.rotational = optics::isRotationallySymmetric(lens_.lens->prescription());
  // The film's samples reach beyond the image by the pixel filter's radius less half a pixel
  // (film_bounds.h): the bounds cover that rectangle (an anamorphic lens's only as far as it
  // reaches at each azimuth, ExitPupilOptions::film_half_extent_mm).
  const Vec2 sampled{half_width_mm_ * (1 + 2 * std::max(0.0, settings_.filter_radius.x - 0.5) /
                                               settings_.x_resolution),
                     half_height_mm_ * (1 + 2 * std::max(0.0, settings_.filter_radius.y - 0.5) /
                                                settings_.y_resolution)};
  // A shifted lens sees the film up to |shift| farther from its axis: the bound covers that.
  const Vec2 reach{sampled.x + std::abs(settings_.tilt_shift.shift_mm.x),
                   sampled.y + std::abs(settings_.tilt_shift.shift_mm.y)};
  pupil_options.film_half_extent_mm = reach;
  const double film_radius = std::hypot(reach.x, reach.y);
  // Other wavelengths move the region's edge (the lens's power changes by about 1/V_d between F
  // and C, and much more toward 360 nm), so rays of 360-830 nm must not be lost (checked
  // through the film irradiance at 450 and 620 nm in tests/render_dispersion_test.cpp, and ray
  // by ray in tests/optics_pupil_test.cpp). One bound holding the regions of both ends of the
  // spectrum wasted up to 20% of a strongly dispersive lens's samples (landscape.sf66 20.7%,
  // ACL3026U 10%, as did a 5% margin); a dispersive lens gets a bound per wavelength band
  // instead, each holding the regions at its band's two ends (ExitPupilOptions::bands: they
  // share the lens's own bound's structure and cost a few traces per polygon vertex and lens),
  // and a sample uses its hero wavelength's band (4.6% and 5.0% wasted). Bands are equal steps
  // of 1/lambda^2 (index changes about evenly across them).
  std::vector<optics::LensSystem> band_lenses;
  if (dispersive_) {
    const double a = 1 / (kIndexFrom_nm * kIndexFrom_nm), b = 1 / (kIndexTo_nm * kIndexTo_nm);
    for (int k = 0; k <= kWavelengthBands; ++k)
      band_edges_nm_.push_back(1 / std::sqrt(a + (b - a) * k / kWavelengthBands));
    band_lenses.reserve(size_t(kWavelengthBands + 1));
    for (int k = 0; k <= kWavelengthBands; ++k)
      band_lenses.push_back(lens_.lens->atWavelength(band_edges_nm_[size_t(k)]));
    for (int k = 0; k < kWavelengthBands; ++k)
      pupil_options.bands.push_back({&band_lenses[size_t(k)], &band_lenses[size_t(k) + 1]});
  }
  pupil_.emplace(*lens_.lens, lens_.paraxial, film_radius, pupil_options);
  centre_area_mm2_ = pupil_->areaMm2({0, 0});
  camera_from_world_ = inverse(settings_.world_from_camera.start());
  // The front surface's axial extent (lens space), for light arriving from the scene.
  std::tie(front_zmin_mm_, front_zmax_mm_) = surfaceZRange(lens_.lens->interfaces().front());
  setUpTiltShift(sampled);
  if (settings_.simple_weighting && !(centre_area_mm2_ > 0))
    throw Error("simpleweighting: no light reaches the centre of the film to normalise by");
  if (settings_.flare) setUpFlare();
  startup_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  startup_cpu_seconds_ = processCpuSeconds() - cpu0;
}

// Tilt and shift (optics/tilt_shift.h). Camera space is the film's frame; film points and the
// rays leaving the lens are carried between it and lens space by the film's placement.
// - Shift only: the film stays on the lens's normal plane, so the exit-pupil bound applies as
//   it is, at the film point's position relative to the axis (built out to the film's corners
//   plus the shift), with the usual weight cos^4(theta) A / z^2.
// - Tilt: film points leave the plane the bound was built for, and the bound is not valid off
//   it. Instead each film point samples a disc on the plane z = rear_zmax_mm_ (the rear
//   surface's extreme toward the film) uniformly: every ray from the film that reaches the rear
//   surface's clear aperture (|s| <= a, z_s in [zmin, zmax]) crosses that plane at
//   (1 - t) x + t s with t = (x_z - zmax) / (x_z - z_s) in [t_min, 1], t_min = (x_z - zmax) /
//   (x_z - zmin), so within radius max(a, (1 - t_min) |x| + t_min a) of the axis: the disc
//   holds all of them and the estimate stays unbiased (the tracer stops the rest). The weight
//   is the film irradiance integrand over that plane, cos_film cos_plane / r^2 times the disc's
//   area, with cos_film against the tilted film's normal. The disc is the whole rear element,
//   not the exit pupil's image of the stop, so most film points sample a smaller region
//   instead: a convex polygon of the same plane that holds every ray from them that passes
//   (placed_pupil.h's bounds, built over the tilted film's frame from rays traced through this
//   lens, the same rays generateRay traces), with the polygon's area in place of pi r^2, where
//   it is smaller than the disc. Importance (realistic_importance.cpp) accepts a ray only
//   through the same region.
void RealisticCamera::setUpTiltShift(const Vec2& sampled) {
  const optics::TiltShift& ts = settings_.tilt_shift;
  if (!ts.any()) return;
  const FileLoc& loc = settings_.tilt_shift_loc;
  const std::string where = loc.valid() ? loc.str() : std::string("lenstilt/lensshift");
  const optics::LensSystem& lens = *lens_.lens;
  if (lens.mirrorCount() > 0)
    throw Error(loc,
                "lenstilt/lensshift: not supported for a lens with mirrors (its image "
                "space is folded)");
  if (settings_.flare)
    throw Error(settings_.flare_loc.valid() ? settings_.flare_loc : loc,
                "flare: not supported with lenstilt/lensshift (the ghost paths are traced for an "
                "untilted, centred film)");
  if (settings_.origin_at_front_vertex || settings_.rear_disc_only ||
      settings_.zero_if_neighbour_blocked)
    throw Error(loc, "lenstilt/lensshift: not supported with the pbrt-v1/v2 camera conventions");
  placement_.emplace(ts, lens.filmZ_mm());
  if (!ts.tilted()) {
    logInfo(fmt::format("{}: lens shifted by ({:g}, {:g}) mm: its axis meets the film there", where,
                        ts.shift_mm.x, ts.shift_mm.y));
    return;
  }
  const optics::Interface& r = lens.interfaces().back();
  rear_semi_mm_ = r.semi_aperture_mm;
  std::tie(rear_zmin_mm_, rear_zmax_mm_) = surfaceZRange(r);
  // The sampled points' film plane must lie wholly behind the rear surface (z is linear over
  // the film, so its corners decide).
  for (int cx = -1; cx <= 1; cx += 2)
    for (int cy = -1; cy <= 1; cy += 2) {
      const Vec3 p = placement_->lensFromFilm({cx * sampled.x, cy * sampled.y});
      if (!(p.z > rear_zmax_mm_ + 1e-3))
        throw Error(loc, fmt::format("lenstilt [{:g} {:g}]: the film's corner ({:.3f}, {:.3f}) mm "
                                     "comes to z = {:.4f} mm, into the lens (its rear surface "
                                     "reaches z = {:.4f} mm); tilt less or focus farther",
                                     ts.tilt_deg.x, ts.tilt_deg.y, cx * sampled.x, cy * sampled.y,
                                     p.z, rear_zmax_mm_));
    }
  if (settings_.tilt_pupil_bounds) {
    // A dispersive lens: bounds holding the rendered range's ends and the primary wavelength.
    std::vector<double> lambdas{lens.wavelength_nm()};
    if (dispersive_) lambdas.insert(lambdas.end(), {kIndexFrom_nm, kIndexTo_nm});
    const auto t0 = std::chrono::steady_clock::now();
    tilt_bounds_ = PlacedPupilBounds(
        sampled, lambdas, [&](Vec2 film) { return tiltDiscRadius(placement_->lensFromFilm(film)); },
        [&](Vec2 film, Vec2 q, double lambda_nm) {
          const Vec3 p = placement_->lensFromFilm(film);
          const Vec3 d = normalize(Vec3{q.x, q.y, rear_zmax_mm_} - p);
          if (!(-dot(d, placement_->filmNormal()) > 0)) return false;  // placedFilmRay's rule
          const optics::RayT<float> ray{Vec3f(p), Vec3f(d)};
          return (dispersive_ ? tracerAt(lambda_nm) : lens.tracerFloat()).traceFromFilm(ray).ok();
        });
    logInfo(fmt::format(
        "{}: tilted film's exit-pupil bounds: {} x {} film bins ({} without a bound of their own, "
        "{} cut into quarters), {} traces, {:.3f} s ({:.3f} s on one core)",
        where, tilt_bounds_.binsX(), tilt_bounds_.binsY(), tilt_bounds_.wholeBins(),
        tilt_bounds_.splitBins(), tilt_bounds_.traces(),
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
        tilt_bounds_.taskSeconds()));
  }
  try {
    scheimpflug_ = optics::scheimpflug(lens_.paraxial, *placement_);
  } catch (const Error& e) {
    throw Error(loc, e.message());
  }
  const optics::ScheimpflugData& sd = *scheimpflug_;
  logInfo(fmt::format(
      "{}: lens tilted {:.4f} deg (shift ({:g}, {:g}) mm): hinge line J = f / sin(tilt) = {:.2f} "
      "mm from the front nodal point, through ({:.2f}, {:.2f}, {:.2f}) mm (lens space); plane of "
      "focus through it meets the axis {} and lies at {:.3f} deg to the film (first-order)",
      where, sd.tilt_deg, ts.shift_mm.x, ts.shift_mm.y, sd.hinge_distance_mm, sd.hinge_point_mm.x,
      sd.hinge_point_mm.y, sd.hinge_point_mm.z,
      std::isfinite(sd.object_distance_mm)
          ? fmt::format("{:.4g} m in front of the front principal plane",
                        sd.object_distance_mm / 1000)
          : std::string("at infinity"),
      sd.focus_plane_to_film_deg));
}

std::optional<RealisticCamera::FilmRay> RealisticCamera::placedFilmRay(const CameraSample& sample,
                                                                       Vec2 film) const {
  const Vec3 p = placement_->lensFromFilm(film);
  if (!placement_->tiltShift().tilted()) {
    const Vec2 at{p.x, p.y};
    std::optional<FilmRay> f =
        filmRay(sample, at, pupil_->sample(at, sample.lens, bandAt(sample.lambda_nm[0])));
    if (f) {
      const double z = lens_.lens->filmDistance_mm(), c2 = f->cos_theta * f->cos_theta;
      f->g_per_mm2 = c2 * c2 / (z * z);
    }
    return f;
  }
  const PupilRegion region = tilt_bounds_.region(film, tiltDiscRadius(p));
  const Vec2 d = region.sample(sample.lens);
  const Vec3 q{d.x, d.y, rear_zmax_mm_};
  const Vec3 to = q - p;
  const double r2 = dot(to, to);
  const Vec3 dir = to / std::sqrt(r2);
  const double cos_plane = -dir.z, cos_film = -dot(dir, placement_->filmNormal());
  if (!(cos_plane > 0) || !(cos_film > 0)) return std::nullopt;
  return FilmRay{optics::RayT<float>{Vec3f(p), Vec3f(dir)}, cos_plane, region.area(),
                 cos_film * cos_plane / r2};
}

PupilRegion RealisticCamera::tiltRegion(Vec2 film) const {
  if (!placement_ || !placement_->tiltShift().tilted()) return {};
  return tilt_bounds_.region(film, tiltDiscRadius(placement_->lensFromFilm(film)));
}

double RealisticCamera::tiltDiscRadius(const Vec3& p) const {
  const double lat = std::hypot(p.x, p.y);
  const double t_min = (p.z - rear_zmax_mm_) / (p.z - rear_zmin_mm_);
  return std::max(rear_semi_mm_, (1 - t_min) * lat + t_min * rear_semi_mm_);
}

std::pair<double, double> RealisticCamera::surfaceZRange(const optics::Interface& f) {
  const double r = f.semi_aperture_mm;
  double zmin = f.z_mm, zmax = f.z_mm;
  if (f.radius_mm != 0 || !f.shape.isSpherical())
    for (int i = 0; i <= 64; ++i)
      for (int k = 0; k < 16; ++k) {
        const double h = r * i / 64, a = 2 * M_PI * k / 16;
        if (auto sg = optics::surfaceSag(f.radius_mm, f.shape, h * std::cos(a), h * std::sin(a))) {
          zmin = std::min(zmin, f.z_mm + sg->z);
          zmax = std::max(zmax, f.z_mm + sg->z);
        }
      }
  return {zmin, zmax};
}

int RealisticCamera::bandAt(double lambda_nm) const {
  if (band_edges_nm_.size() < 2 || !(lambda_nm > 0)) return -1;
  const auto it = std::upper_bound(band_edges_nm_.begin() + 1, band_edges_nm_.end() - 1, lambda_nm);
  return static_cast<int>(it - (band_edges_nm_.begin() + 1));
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
                                                 const FilmRay& f, double u_time) const {
  double transmission = 1;
  if (!settings_.aperture.isRound() && stop_radius_mm_ > 0) {
    transmission = settings_.aperture.transmission(
        Vec2{r.stop_point.x / stop_radius_mm_, r.stop_point.y / stop_radius_mm_});
    if (transmission <= 0) return std::nullopt;
  }
  CameraRay ray = placeRay(Vec3(r.ray.origin), Vec3(r.ray.direction), u_time);
  // w = T cos^4(theta) A / z^2 (z: film to the rear-vertex plane, where the pupil is sampled);
  // the film multiplies by the exposure time (and ISO / 100), as pbrt-v4's imaging ratio does.
  const double c2 = f.cos_theta * f.cos_theta;
  if (placement_) {
    // A tilted or shifted film: the same integrand, T G A (placedFilmRay; G = cos^4 / z^2 when
    // the film is not tilted).
    const double z = lens_.lens->filmDistance_mm();
    ray.weight = transmission * f.g_per_mm2 * f.area_mm2 *
                 (settings_.simple_weighting ? z * z / centre_area_mm2_ : 1.0);
  } else {
    ray.weight = transmission * c2 * c2 * f.area_mm2 / weightNorm();
  }
  return ray;
}

double RealisticCamera::weightNorm() const {
  const double z = lens_.lens->filmDistance_mm();
  return settings_.simple_weighting ? centre_area_mm2_ : z * z;
}

CameraRay RealisticCamera::placeRay(const Vec3& o_lens, const Vec3& d_lens, double u_time) const {
  const optics::LensSystem& lens = *lens_.lens;
  // Lens space (mm, +z toward the film) to camera space (camera units, +z toward the scene).
  const double u = settings_.camera_units_per_mm;
  // Camera-space z: distance toward the scene from the film (pbrt-v3/v4) or from the front
  // vertex (the v1/v2 assignment's convention).
  const double z0 = settings_.origin_at_front_vertex ? 0.0 : lens.filmZ_mm();
  Vec3 o_cam{o_lens.x * u, o_lens.y * u, (z0 - o_lens.z) * u};
  Vec3 d_cam{d_lens.x, d_lens.y, -d_lens.z};
  if (placement_) {  // camera space is the film's frame (film at z = 0, the scene toward +z)
    const Vec3 o = placement_->filmFromLensPoint(o_lens);
    const Vec3 d = placement_->filmFromLensVector(d_lens);
    o_cam = {o.x * u, o.y * u, -o.z * u};
    d_cam = {d.x, d.y, -d.z};
  }
  CameraRay ray;
  // pbrt-v4's CameraBase::SampleTime (a time uniform over the shutter) and the camera transform
  // at that time (CameraTransform::RenderFromCamera); the lens itself is in camera space.
  ray.time = settings_.shutter_open + u_time * (settings_.shutter_close - settings_.shutter_open);
  const auto place = [&](const Transform& cw) {
    ray.origin = cw.applyPoint(o_cam);
    ray.direction = normalize(cw.applyVector(d_cam));
  };
  if (settings_.world_from_camera.isAnimated())
    place(settings_.world_from_camera.interpolate(ray.time));
  else
    place(settings_.world_from_camera.start());
  return ray;
}

// Dispersive lenses. With hero-wavelength sampling a path carries N wavelengths, but through a
// dispersive lens each leaves the lens in its own direction. Choices (all unbiased):
// (a) one camera ray per wavelength: N scene paths per sample, each single-wavelength: N times
//     the path cost for what (b) gives with N samples;
// (b) refract at the hero wavelength and terminate the other ones, as pbrt-v4 does at a
//     dispersive dielectric (hero pdf divided by N): one path per sample, but one wavelength per
//     path instead of N, which costs much colour noise (measured on the demo scene through the
//     glass-matched double Gauss: 34x the colour variance at equal time, bench/dispersion);
// (c) keep every wavelength on the hero's world ray. That ray is not where wavelength i's
//     camera would have started it: traced back through the lens at lambda_i it meets the film
//     at another point x_i (lateral colour) through another rear-plane point q_i. So wavelength i
//     gets the importance of the ray at x_i (the pixel filter there) and the one-sample MIS
//     (balance) weight over the N ways the same ray could have been drawn (each wavelength as the
//     hero, with its own film point): weight_i = W_i / ((1/N) sum_j p_j), where
//       W_j = f(x_j - pixel) T_j z^2 / norm,   p_j = pdf_f(x_j - pixel) [q_j in bounds] / A(x_j)
//             x z^2 / cos^4(theta_j)
//     in the measure of world rays (the lens conserves etendue, so a ray's measure is
//     cos^4(theta) / z^2 dA_film dA_rear at every wavelength and no Jacobian of the lens map is
//     needed). Summed over the N rotations of the wavelength set this is exactly the integral
//     for each wavelength (Wilkie et al. 2014's hero-wavelength MIS, here for the camera vertex);
//     it reduces to today's weight for a non-dispersive lens. Cost: N - 1 extra traces through
//     the lens per sample, and no extra scene paths; where lateral colour is small against the
//     pixel filter all N wavelengths keep nearly full weight, so the colour noise stays close to
//     the non-dispersive lens's.
// lensim does (c) in the renderer (which hands the camera the pixel and its filter), and (b)
// where the filter is not known. A path that later meets a dispersive material keeps only its
// hero wavelength; its camera weight is then the hero's own (`weight`), as in (b).
// A non-dispersive lens takes none of this: the batched tracer, and every wavelength kept.
//
void RealisticCamera::indicesAt(double lambda_nm, double* before, double* after) const {
  const optics::LensSystem& lens = *lens_.lens;
  const double u = (lambda_nm - kIndexFrom_nm) / kIndexStep_nm;
  const int n = lens.surfaceCount();
  const int last = int(index_table_.size()) / n - 1;
  if (!(u >= 0 && u < last)) {
    lens.indicesAt(lambda_nm, before, after);
    return;
  }
  const int k = int(u);
  const double a = u - k;
  const double* r0 = index_table_.data() + ptrdiff_t(k) * n;
  const double* r1 = r0 + n;
  double b = 1.0;
  for (int i = 0; i < n; ++i) {
    const double next = r0[i] + a * (r1[i] - r0[i]);
    before[i] = b, after[i] = next;
    b = next;
  }
}

// Each wavelength's tracer must carry the indices at that wavelength: every thread keeps a copy
// of the float tracer and re-indexes it from a table of the media's indices every 0.25 nm
// (linear interpolation, error under 2e-8: below the float tracer's rounding), no locks, no
// allocation per sample.
const optics::LensTracer<float>& RealisticCamera::tracerAt(double lambda_nm) const {
  struct PerThread {
    std::uint64_t owner = 0;
    optics::LensTracer<float> tracer;
    std::vector<double> before, after;
    double lambda_nm = -1;
  };
  thread_local PerThread t;
  const optics::LensSystem& lens = *lens_.lens;
  if (t.owner != id_) {
    t.owner = id_;
    t.tracer = lens.tracerFloat();
    t.before.resize(lens.surfaceCount());
    t.after.resize(lens.surfaceCount());
    t.lambda_nm = -1;
  }
  if (t.lambda_nm != lambda_nm) {
    indicesAt(lambda_nm, t.before.data(), t.after.data());
    t.tracer.setIndices(t.before.data(), t.after.data());
    t.lambda_nm = lambda_nm;
  }
  return t.tracer;
}

Vec2 RealisticCamera::rasterPoint(Vec2 film_mm) const {
  const double fx = -film_mm.x, fy = film_mm.y;
  return {(fx + half_width_mm_) / (2 * half_width_mm_) * settings_.x_resolution,
          (fy + half_height_mm_) / (2 * half_height_mm_) * settings_.y_resolution};
}

std::optional<CameraRay> RealisticCamera::dispersiveRay(const CameraSample& sample,
                                                        const FilmRay& f) const {
  if (!(sample.lambda_nm[0] > 0)) {  // no wavelength given: the lens at its primary wavelength
    const optics::TraceResultT<float> r = lens_.lens->tracerFloat().traceFromFilm(f.ray);
    std::optional<CameraRay> ray = r.ok() ? finish(r, f, sample.time) : std::nullopt;
    if (ray && flare_) applyReflectionLosses(sample, f, *ray);
    return ray;
  }
  // The paths through the lens, for the glasses' absorption and flare's reflection losses
  // (recorded only where needed).
  thread_local std::vector<Vec3f> path;
  path.clear();
  const bool record = absorbs_ || flare_;
  const optics::TraceResultT<float> r =
      tracerAt(sample.lambda_nm[0]).traceFromFilm(f.ray, {}, record ? &path : nullptr);
  if (!r.ok()) return std::nullopt;
  std::optional<CameraRay> ray = finish(r, f, sample.time);
  if (!ray) return ray;
  const double hero_transmittance = pathTransmittance(path, true, sample.lambda_nm[0]);
  ray->weight *= hero_transmittance;
  // (b) also for a tilted or shifted film: (c)'s densities assume the untilted, centred film;
  // and with flare, whose ghost paths are traced at the hero wavelength only.
  if (flare_) {
    ray->weight *= heroReflectionLosses(path, r.ray.direction, sample.lambda_nm[0]);
    ray->hero_only = true;
    return ray;
  }
  if (!sample.filter || !(sample.filter_weight != 0) || placement_) {
    ray->hero_only = true;  // (b)
    return ray;
  }
  // (c): each wavelength's film point for the hero's world ray, its importance and its density.
  const optics::LensSystem& lens = *lens_.lens;
  const sampling::Filter& filter = *sample.filter;
  const double z = lens.filmDistance_mm(), z_film = lens.filmZ_mm(), z_rear = lens.rearVertexZ_mm();
  const double norm = settings_.simple_weighting ? centre_area_mm2_ : z * z;
  auto transmission = [&](Vec2T<float> stop) {
    if (settings_.aperture.isRound() || !(stop_radius_mm_ > 0)) return 1.0;
    return settings_.aperture.transmission(
        Vec2{stop.x / stop_radius_mm_, stop.y / stop_radius_mm_});
  };
  std::array<double, kCameraWavelengths> w{}, p{};
  {
    const Vec2 o = sample.film_raster - sample.pixel_centre;
    const double c2 = f.cos_theta * f.cos_theta;
    w[0] = filter.eval(o) * transmission(r.stop_point) * hero_transmittance * z * z / norm;
    p[0] = filter.pdf(o) / f.area_mm2 * z * z / (c2 * c2);
  }
  const optics::RayT<float> back{r.ray.origin, -r.ray.direction};
  for (int j = 1; j < kCameraWavelengths; ++j) {
    const double l = sample.lambda_nm[size_t(j)];
    if (!(l > 0)) continue;
    path.clear();
    const optics::TraceResultT<float> b =
        tracerAt(l).traceFromScene(back, {}, absorbs_ ? &path : nullptr);
    if (!b.ok() || !(b.ray.direction.z > 0)) continue;
    const Vec3 o{b.ray.origin}, d{b.ray.direction};
    const Vec3 x = o + d * ((z_film - o.z) / d.z), q = o + d * ((z_rear - o.z) / d.z);
    const Vec2 xf{x.x, x.y};
    const Vec2 offset = rasterPoint(xf) - sample.pixel_centre;
    const double fw = filter.eval(offset);
    const double c = d.z / length(d), c2 = c * c;
    w[size_t(j)] =
        fw * transmission(b.stop_point) * pathTransmittance(path, false, l) * z * z / norm;
    if (settings_.rear_disc_only) {
      const double rr = lens.interfaces().back().semi_aperture_mm;
      if (q.x * q.x + q.y * q.y > rr * rr) continue;
    }
    // Wavelength j's own strategy: its band's bound.
    const int band = bandAt(l);
    const double area = pupil_->areaMm2(xf, band);
    if (area > 0 && pupil_->contains(xf, {q.x, q.y}, band))
      p[size_t(j)] = filter.pdf(offset) / area * z * z / (c2 * c2);
  }
  double mean_p = 0;
  for (double v : p) mean_p += v / kCameraWavelengths;
  for (int i = 0; i < kCameraWavelengths; ++i)
    ray->wavelength_weight[size_t(i)] =
        mean_p > 0 ? w[size_t(i)] / mean_p / sample.filter_weight : 0.0;
  ray->per_wavelength = true;
  return ray;
}

std::optional<CameraRay> RealisticCamera::generateRay(const CameraSample& sample) const {
  const Vec2 film = filmPoint(sample.film_raster);
  const std::optional<FilmRay> f =
      placement_
          ? placedFilmRay(sample, film)
          : filmRay(sample, film, pupil_->sample(film, sample.lens, bandAt(sample.lambda_nm[0])));
  if (!f) return std::nullopt;
  if (dispersive_) return dispersiveRay(sample, *f);
  const optics::TraceResultT<float> r = lens_.lens->tracerFloat().traceFromFilm(f->ray);
  if (!r.ok()) return std::nullopt;
  std::optional<CameraRay> ray = finish(r, *f, sample.time);
  if (ray && flare_) applyReflectionLosses(sample, *f, *ray);
  return ray;
}

void RealisticCamera::generateRays(const CameraSample* samples, int n,
                                   std::optional<CameraRay>* rays) const {
  if (placement_) {  // one by one (tilt and shift: placedFilmRay)
    for (int i = 0; i < std::min(n, int(kMaxBatch)); ++i) rays[i] = generateRay(samples[i]);
    return;
  }
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
  if (pupil_->bands() == 0) {
    pupil_->sampleBatch(film, u, n, ps);
  } else {  // each sample its hero wavelength's band: the samples of a band together
    int band[kB];
    bool done[kB] = {};
    for (int i = 0; i < n; ++i) band[i] = bandAt(samples[i].lambda_nm[0]);
    for (int i = 0; i < n; ++i) {
      if (done[i]) continue;
      Vec2 f[kB], v[kB];
      int idx[kB], m = 0;
      for (int j = i; j < n; ++j)
        if (!done[j] && band[j] == band[i])
          f[m] = film[j], v[m] = u[j], idx[m++] = j, done[j] = true;
      std::optional<optics::PupilSample> got[kB];
      pupil_->sampleBatch(f, v, m, got, band[i]);
      for (int k = 0; k < m; ++k) ps[idx[k]] = got[k];
    }
  }
  int m = 0;
  for (int i = 0; i < n; ++i) {
    rays[i].reset();
    if (std::optional<FilmRay> f = filmRay(samples[i], film[i], ps[i])) {
      lanes[m] = *f;
      in[m] = f->ray;
      index[m++] = i;
    }
  }
  if (dispersive_) {
    // Each sample its own wavelengths (see "Dispersive lenses" above).
    for (int k = 0; k < m; ++k) rays[index[k]] = dispersiveRay(samples[index[k]], lanes[k]);
    return;
  }
  lens_.lens->tracerFloat().traceFromFilmBatch(in, m, out);
  for (int k = 0; k < m; ++k)
    if (out[k].ok()) {
      rays[index[k]] = finish(out[k], lanes[k], samples[index[k]].time);
      if (rays[index[k]] && flare_)
        applyReflectionLosses(samples[index[k]], lanes[k], *rays[index[k]]);
    }
}

bool RealisticCamera::reachesFilm(const CameraSample& sample) const {
  // The bound the sample is drawn from (generateRay): its hero wavelength's band. A dispersive
  // lens's image circle shrinks with the wavelength; where the sample's band has no bound, no
  // pupil point is drawn and nothing is traced (counting those as wasted put lentil:0007 at
  // 5.7% instead of 4.2%).
  if (placement_) {
    if (placement_->tiltShift().tilted()) return true;  // every film point has its region
    const Vec3 p = placement_->lensFromFilm(filmPoint(sample.film_raster));
    return pupil_->areaMm2({p.x, p.y}, bandAt(sample.lambda_nm[0])) > 0;
  }
  return pupil_->areaMm2(filmPoint(sample.film_raster), bandAt(sample.lambda_nm[0])) > 0;
}

std::string RealisticCamera::describe() const {
  const optics::LensSystem& lens = *lens_.lens;
  return fmt::format(
             "realistic: {} ({}), f = {:.2f} mm, f/{:.2f}, film distance {:.3f} mm, focus {}, "
             "{:.1f} x {:.1f} mm film, aperture {}{}",
             lens.prescription().name, lens.prescription().path,
             lens_.paraxial.effective_focal_length_mm, lens_.paraxial.f_number,
             lens.filmDistance_mm(),
             std::isinf(lens_.focus_distance_m) ? std::string("at infinity")
                                                : fmt::format("{:.4g} m", lens_.focus_distance_m),
             2 * half_width_mm_, 2 * half_height_mm_, settings_.aperture.describe(),
             dispersive_ ? fmt::format(", dispersive (focused at {:.2f} nm; hero wavelength only)",
                                       lens.wavelength_nm())
                         : std::string()) +
         fmt::format("; exit-pupil bound: {} traces, {:.3f} s, {} radial intervals{}{}",
                     pupil_->tracesAtBuild(), pupil_->buildSeconds(), pupil_->intervals(),
                     pupil_->rotationallySymmetric() ? "" : ", 2-D (anamorphic)",
                     pupil_->bands() > 0 ? fmt::format(", {} wavelength bands", pupil_->bands())
                                         : std::string()) +
         (placement_
              ? fmt::format(
                    "; lens shift ({:g}, {:g}) mm, tilt ({:g}, {:g}) deg{}",
                    settings_.tilt_shift.shift_mm.x, settings_.tilt_shift.shift_mm.y,
                    settings_.tilt_shift.tilt_deg.x, settings_.tilt_shift.tilt_deg.y,
                    settings_.tilt_shift.tilted()
                        ? (tilt_bounds_.binsX() > 0
                               ? ", rays aimed at exit-pupil polygons on the rear element's plane"
                               : ", rays aimed at the rear element's disc")
                        : "")
              : std::string());
}

namespace {

// ", aperturediameter D mm" of the Camera line, for errors its value may cause.
std::string apertureNote(const scene::Camera& c) {
  if (c.realistic)
    return fmt::format(", aperturediameter {} mm", c.realistic->aperture_diameter_mm);
  if (c.legacy_realistic)
    return fmt::format(", aperture_diameter {} mm", c.legacy_realistic->aperture_diameter_mm);
  return {};
}

}  // namespace

std::unique_ptr<Camera> makeRealisticCamera(const scene::Scene& scene,
                                            const CameraOptions& options) {
  const scene::Camera& c = scene.camera;
  RealisticSettings s;
  s.x_resolution = scene.film.x_resolution;
  s.y_resolution = scene.film.y_resolution;
  s.world_from_camera = worldFromCamera(scene);
  s.shutter_open = c.shutter_open;
  s.shutter_close = c.shutter_close;
  s.zero_if_neighbour_blocked = options.pbrt_v2_quirks;
  s.filter_radius = {scene.filter.x_radius, scene.filter.y_radius};
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
      static_cast<scene::RealisticOptions&>(s) = r;  // the options taken as they are
      if (!s.tilt_shift_loc.valid()) s.tilt_shift_loc = c.loc;
      s.as_built_film = !r.focus_given;
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
      if (r.blades > 0)
        s.aperture = ApertureShape::polygon(r.blades, r.blade_rotation_deg);
      else if (!r.aperture.empty())
        s.aperture = ApertureShape::isNamed(r.aperture) ? ApertureShape::named(r.aperture)
                                                        : ApertureShape::image(r.aperture);
    } else {
      throw Error(c.loc, "realistic camera without lens parameters");
    }
    if (c.realistic || c.legacy_realistic) {
      // Read (or build) once: a lens with tilted or decentred surfaces, or an as-built lens whose
      // elements were decentred or tilted, takes the placed camera.
      auto p = std::make_shared<optics::LensPrescription>(
          s.tolerance_job.empty() ? optics::readLensFile(s.lens_path) : asBuiltPrescription(s));
      if (const optics::LensSurface* g = optics::firstGrating(*p))
        throw Error(c.loc, fmt::format("realistic camera: the lens file {} has a diffraction "
                                       "grating (line {}): {}",
                                       s.lens_path, g->grating->loc.line, gratingCameraRefusal()));
      if (c.realistic && p->noncoaxial_loc && !p->fold_loc) {
        logDiagnostics(p->diagnostics);
        return std::make_unique<PlacedRealisticCamera>(std::move(s), std::move(*p));
      }
      s.prescription = std::move(p);
    }
    auto camera = std::make_unique<RealisticCamera>(std::move(s));
    logDiagnostics(camera->diagnostics());
    return camera;
  } catch (const Error& e) {
    // Errors at a line of a file (the lens file's syntax, a glass) keep their location. The
    // others (the lens as a whole: afocal, no real ray through it at this aperture, a film
    // inside it; the camera's settings) belong to the Camera line, naming the lens file.
    if (e.loc().valid() && e.loc().line > 0) throw;
    const std::string lens = c.realistic          ? c.realistic->lens_file
                             : c.legacy_realistic ? c.legacy_realistic->lens_file
                                                  : std::string();
    const std::string other =
        e.loc().valid() && e.loc().file != lens ? e.loc().file + ": " : std::string();
    throw Error(
        c.loc, fmt::format("realistic camera: {}{}{}", other, e.message(),
                           lens.empty() ? std::string()
                                        : fmt::format(" (lens file {}{})", lens, apertureNote(c))));
  }
}

}  // namespace lensim::camera
