#include "lensim/camera/realistic_placed.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>

#include "lensim/camera/film_bounds.h"
#include "lensim/optics/frame.h"
#include "lensim/optics/glass.h"
#include "lensim/optics/glass/library.h"
#include "lensim/optics/surface_shape.h"
#include "lensim/sampling/sampling.h"
#include "lensim/util/error.h"
#include "lensim/util/log.h"

namespace lensim::camera {

namespace {

// A frame's rotation columns are its axes in lens (front-frame) coordinates.
Vec3 toGlobal(const optics::SurfaceFrame& f, const Vec3& v) {
  return optics::frame::toGlobal(f.rotation, v);
}
Vec3 toLocal(const optics::SurfaceFrame& f, const Vec3& v) {
  return optics::frame::toLocal(f.rotation, v);
}
Vec3 origin(const optics::SurfaceFrame& f) {
  return {f.origin_mm[0], f.origin_mm[1], f.origin_mm[2]};
}
Vec3 axisZ(const optics::SurfaceFrame& f) {
  return {f.rotation[0][2], f.rotation[1][2], f.rotation[2][2]};
}

// What the placed camera does not model, refused where the scene asks for it.
void refuseUnsupported(const RealisticSettings& s) {
  const auto at = [](const FileLoc& loc) { return loc.valid() ? loc : FileLoc{}; };
  const std::string why = "not supported for a lens with tilted or decentred surfaces";
  if (s.rear_disc_only || s.origin_at_front_vertex || s.zero_if_neighbour_blocked)
    throw Error(fmt::format("the pbrt-v1/v2 realistic camera conventions are {}", why));
  if (s.flare) throw Error(at(s.flare_loc), fmt::format("flare: {}", why));
  if (s.tilt_shift.any())
    throw Error(at(s.tilt_shift_loc), fmt::format("lenstilt/lensshift: {}", why));
  if (s.configuration || s.zoom_focal_length_mm)
    throw Error(at(s.zoom_loc), fmt::format("configuration/focallength: {}", why));
  if (s.simple_weighting) throw Error(fmt::format("simpleweighting: {}", why));
  if (s.setup.film_distance_mm)
    throw Error(
        fmt::format("filmdistance: {} (give focusdistance: the film then moves along the "
                    "image surface's axis to the best focus of real rays)",
                    why));
}

}  // namespace

PlacedRealisticCamera::PlacedRealisticCamera(RealisticSettings settings, optics::LensPrescription p,
                                             bool pupil_bounds)
    : settings_(std::move(settings)), lens_([&]() -> optics::PlacedLens {
        refuseUnsupported(settings_);
        if (const optics::LensSurface* g = optics::firstGrating(p))
          throw Error(g->grating->loc, gratingCameraRefusal());
        if (settings_.glass_match)
          for (const Diagnostic& d : optics::matchCatalogGlasses(p)) logDiagnostic(d);
        // The set stop radius is the aperture shape's unit; the physical stop opens to the
        // shape's extent (clamped to the file's stop) and the shape decides what passes.
        if (const std::optional<int> stop = p.stopIndex()) {
          optics::LensSurface& s = p.surfaces[size_t(*stop)];
          const double max_d = s.aperture_diameter_mm;
          double d = settings_.setup.aperture_diameter_mm.value_or(max_d);
          if (!(d > 0)) throw Error(fmt::format("aperturediameter {} mm must be > 0", d));
          if (d > max_d) {
            logWarning(
                fmt::format("{}: aperturediameter {} mm is larger than the stop's clear "
                            "diameter {} mm: using {} mm",
                            p.path, d, max_d, max_d));
            d = max_d;
          }
          stop_radius_mm_ = d / 2;
          const double extent = settings_.aperture.isRound() ? 1.0 : settings_.aperture.extent();
          s.aperture_diameter_mm = std::min(max_d, d * extent);
        }
        return optics::PlacedLens(p, p.primary_wavelength_nm.value_or(optics::kLineD_nm));
      }()) {
  const auto t0 = std::chrono::steady_clock::now();
  name_ = p.name;
  path_ = p.path;
  logDiagnostics(lens_.diagnostics());
  {
    std::vector<Diagnostic> ranges;
    optics::checkRenderGlassRanges(lens_.glasses(), kRenderedMin_nm, kRenderedMax_nm, path_,
                                   &ranges);
    logDiagnostics(ranges);
  }
  image_frame_ = p.image_frame;
  const optics::LensSurface& rear = p.surfaces.back();
  rear_frame_ = *rear.frame;
  rear_semi_mm_ = rear.semiAperture_mm();
  // A decentred aperture (an off-axis mirror): the sampled disc is centred on it.
  rear_centre_ = {rear.aperture_decentre_mm[0], rear.aperture_decentre_mm[1]};
  if (!(rear_semi_mm_ > 0))
    throw Error(rear.loc, "the last surface has no clear aperture to aim camera rays at");
  // The rear surface's z extent over its clear aperture (its own frame; about the aperture's
  // centre, which a decentred aperture moves off the vertex).
  double zmin = std::numeric_limits<double>::infinity(), zmax = -zmin;
  if (rear.radius_mm != 0 || !rear.shape.isSpherical())
    for (int i = 0; i <= 64; ++i)
      for (int k = 0; k < 16; ++k) {
        const double h = rear_semi_mm_ * i / 64, a = 2 * std::numbers::pi * k / 16;
        if (auto sg = optics::surfaceSag(rear.radius_mm, rear.shape,
                                         rear_centre_.x + h * std::cos(a),
                                         rear_centre_.y + h * std::sin(a))) {
          zmin = std::min(zmin, sg->z);
          zmax = std::max(zmax, sg->z);
        }
      }
  if (!(zmin <= zmax)) zmin = zmax = 0;  // a plane (or no sample defined): the vertex plane
  dispersive_ = lens_.dispersive();
  absorbs_ = settings_.glass_absorption &&
             std::any_of(lens_.glasses().begin(), lens_.glasses().end(),
                         [](const optics::Glass& g) { return g.hasTransmittance(); });
  {
    static std::atomic<std::uint64_t> next_id{1};
    id_ = next_id++;
  }
  const Vec2 half = filmHalfExtent_mm(settings_.film_diagonal_mm, settings_.x_resolution,
                                      settings_.y_resolution);
  half_width_mm_ = half.x;
  half_height_mm_ = half.y;

  if (!settings_.tolerance_job.empty() && settings_.as_built_film) {
    // An as-built lens without a focusdistance: the film is the build's image surface, where the
    // tolerancing's back-focus compensator put it (as the coaxial camera does).
    focus_distance_m_ = std::numeric_limits<double>::infinity();
    film_offset_mm_ = 0;
    logInfo(fmt::format("{}: the film is the as-built lens's compensated image surface",
                        settings_.tolerance_loc.str()));
  } else {
    focus(settings_.setup.focus_distance_m.value_or(std::numeric_limits<double>::infinity()));
  }

  // The film, out to the filter's reach beyond the image, must lie wholly on one side of the
  // rear surface's slab (its z is linear over the film: the corners decide); the sampled plane
  // is the slab's face toward it.
  const Vec2 reach{half_width_mm_ * (1 + 2 * std::max(0.0, settings_.filter_radius.x - 0.5) /
                                             settings_.x_resolution),
                   half_height_mm_ * (1 + 2 * std::max(0.0, settings_.filter_radius.y - 0.5) /
                                              settings_.y_resolution)};
  int above = 0, below = 0;
  for (int cx = -1; cx <= 1; cx += 2)
    for (int cy = -1; cy <= 1; cy += 2) {
      const Vec3 q =
          toLocal(rear_frame_, filmToLens({cx * reach.x, cy * reach.y}) - origin(rear_frame_));
      above += q.z > zmax + 1e-6;
      below += q.z < zmin - 1e-6;
    }
  // A refusal of the lens at these settings, not of a line of its file: the scene's Camera
  // line reports it, naming the lens file.
  if (above != 4 && below != 4)
    throw Error(fmt::format("the film ({:.3f} x {:.3f} mm, moved {:.4f} mm along the image "
                            "surface's axis) reaches into the last surface's (line {}) z range "
                            "[{:.4f}, {:.4f}] mm (its own frame){}",
                            2 * half_width_mm_, 2 * half_height_mm_, film_offset_mm_,
                            rear.loc.line, zmin, zmax,
                            rear.apertureDecentred()
                                ? "; the camera samples the last surface from a film wholly on "
                                  "one side of it, and an off-axis mirror's image lies beside "
                                  "it"
                                : ""));
  // The film must stay on the image side of the last surface, where the file's image surface
  // is: a focus that moves it across (a virtual image, an object too close) cannot be used.
  const double image_z = toLocal(rear_frame_, origin(image_frame_) - origin(rear_frame_)).z;
  if ((above == 4) != (image_z > zmax))
    throw Error(
        fmt::format("focusdistance {:g} m: the best focus of real rays lies {:.4f} mm "
                    "along the image surface's axis, on the object side of the last "
                    "surface (a virtual image): focus farther",
                    focus_distance_m_, film_offset_mm_));
  z_near_ = above == 4 ? zmax : zmin;
  z_far_ = above == 4 ? zmin : zmax;
  const auto t_bounds = std::chrono::steady_clock::now();
  // The bounds are built about the vertex: a decentred rear aperture keeps its disc.
  pupil_bounds = pupil_bounds && rear_centre_.x == 0 && rear_centre_.y == 0;
  if (pupil_bounds) buildBounds(reach);
  const auto t1 = std::chrono::steady_clock::now();
  startup_seconds_ = std::chrono::duration<double>(t1 - t0).count();
  startup_cpu_seconds_ =
      std::chrono::duration<double>(t_bounds - t0).count() + bounds_.taskSeconds();
  if (pupil_bounds)
    logInfo(fmt::format(
        "{}: exit-pupil bounds: {} x {} film bins ({} without a bound of their own, {} cut into "
        "quarters), {} traces, {:.3f} s ({:.3f} s on one core)",
        path_.empty() ? name_ : path_, bounds_.binsX(), bounds_.binsY(), bounds_.wholeBins(),
        bounds_.splitBins(), bounds_.traces(), std::chrono::duration<double>(t1 - t_bounds).count(),
        bounds_.taskSeconds()));
}

PlacedRealisticCamera::FocusSolve PlacedRealisticCamera::bestFocus(
    const optics::PlacedLens::Field& field, double distance_m) const {
  // Real rays through a grid of equal areas over the stop (as set): 6 rings of equal area, 12
  // rays each, so that the spot's moments are those of a uniformly filled stop. Each ray's exit
  // point a and direction d in the image surface's frame: on the plane z = dz it lands at
  // a_xy + d_xy / d_z dz, linear in dz, so the spot's second moment about its centroid is
  // quadratic in dz and its minimum is closed-form.
  const double semi = lens_.stopSemiAperture_mm();
  std::vector<Vec2> u, v;  // landing = u + v dz
  constexpr int kRings = 6, kPerRing = 12;
  for (int ring = 0; ring < kRings; ++ring) {
    const double r = semi * std::sqrt((ring + 0.5) / kRings);
    for (int k = 0; k < kPerRing; ++k) {
      const double a = 2 * std::numbers::pi * (k + 0.5 * (ring % 2)) / kPerRing;
      const auto e = lens_.aim(field, {r * std::cos(a), r * std::sin(a)});
      if (!e) continue;
      const optics::TraceResult t = lens_.trace(lens_.fieldRay(field, *e));
      if (!t.ok()) continue;
      const Vec3 o = lens_.toImageFrame(t.ray.origin);
      const Vec3 d = toLocal(image_frame_, t.ray.direction);
      if (!(std::abs(d.z) > 1e-9)) continue;
      u.push_back({o.x - d.x / d.z * o.z, o.y - d.y / d.z * o.z});
      v.push_back({d.x / d.z, d.y / d.z});
    }
  }
  if (u.size() < 3)
    throw Error(
        fmt::format("focusdistance {} m: {} real rays from the object point on the axis "
                    "reach the image surface (3 or more needed to focus)",
                    distance_m, u.size()));
  Vec2 mu{}, mv{};
  const double share = 1.0 / double(u.size());
  for (size_t i = 0; i < u.size(); ++i) mu = mu + u[i] * share, mv = mv + v[i] * share;
  double uv = 0, vv = 0;
  for (size_t i = 0; i < u.size(); ++i) {
    const Vec2 du = u[i] - mu, dv = v[i] - mv;
    uv += du.x * dv.x + du.y * dv.y;
    vv += dv.x * dv.x + dv.y * dv.y;
  }
  if (!(vv > 0))
    throw Error(
        fmt::format("focusdistance {} m: the rays leave the lens parallel (an afocal "
                    "system): no film position focuses them",
                    distance_m));
  FocusSolve f;
  f.offset_mm = -uv / vv;
  f.rays = int(u.size());
  double ms = 0;
  for (size_t i = 0; i < u.size(); ++i) {
    const Vec2 q = (u[i] - mu) + (v[i] - mv) * f.offset_mm;
    ms += (q.x * q.x + q.y * q.y) / double(u.size());
  }
  f.rms_mm = std::sqrt(ms);
  return f;
}

void PlacedRealisticCamera::focus(double distance_m) {
  if (!(distance_m > 0)) throw Error(fmt::format("focusdistance {} m must be > 0", distance_m));
  focus_distance_m_ = distance_m;
  // Where the object space's axis (the front frame's z) and the image surface's axis are
  // parallel, focusdistance is measured from the film centre along the film's axis, as for the
  // coaxial camera (docs/conventions.md); a folded lens has no such line, and measures it from
  // the front vertex along the object axis.
  film_referenced_ = dot(axisZ(image_frame_), Vec3{0, 0, 1}) > 1 - 1e-12;
  optics::PlacedLens::Field field;
  FocusSolve f;
  int iterations = 0;
  if (!std::isfinite(distance_m)) {
    f = bestFocus(field, distance_m);
  } else if (!film_referenced_) {
    field.at_infinity = false;
    field.object_point = {0, 0, -1000 * distance_m};
    f = bestFocus(field, distance_m);
  } else {
    // The film's place depends on the focus: fixed-point iteration on the film offset. Each
    // step's change is the previous one's times the longitudinal magnification, so it converges
    // unless the object is near unit magnification or closer.
    field.at_infinity = false;
    const Vec3 axis = axisZ(image_frame_);
    constexpr int kMaxIterations = 200;
    constexpr double kTolerance_mm = 1e-9;
    double offset = 0, step = std::numeric_limits<double>::infinity();
    for (; iterations < kMaxIterations && !(std::abs(step) <= kTolerance_mm); ++iterations) {
      const Vec3 film_centre = origin(image_frame_) + axis * offset;
      field.object_point = film_centre - axis * (1000 * distance_m);
      if (!(field.object_point.z < 0)) {
        if (iterations == 0)
          throw Error(fmt::format(
              "focusdistance {:g} m: the object, {:g} m from the film centre, would lie {:.4f} "
              "mm behind the lens's front vertex: focus farther",
              distance_m, distance_m, field.object_point.z));
        throw Error(fmt::format(
            "focusdistance {:g} m (from the film): closer than this lens focuses (the film "
            "position diverged: after {} fixed-point steps the object would lie behind the "
            "front vertex): focus farther",
            distance_m, iterations));
      }
      f = bestFocus(field, distance_m);
      step = f.offset_mm - offset;
      offset = f.offset_mm;
    }
    if (!(std::abs(step) <= kTolerance_mm))
      throw Error(fmt::format(
          "focusdistance {:g} m: the film position (focus measured from the film) did not converge "
          "in {} "
          "iterations (last change {:.3g} mm; the object is too close for this lens): focus "
          "farther",
          distance_m, kMaxIterations, step));
  }
  film_offset_mm_ = f.offset_mm;
  logInfo(fmt::format(
      "{}: focused at {}{} by moving the film {:.6f} mm along the image surface's axis (RMS "
      "spot {:.6f} mm, {} real rays{})",
      path_.empty() ? name_ : path_,
      std::isfinite(distance_m) ? fmt::format("{:g} m", distance_m) : std::string("infinity"),
      !std::isfinite(distance_m) ? ""
      : film_referenced_         ? " from the film"
                                 : " from the front vertex (a folded lens: the object and "
                                   "image axes are not parallel)",
      film_offset_mm_, f.rms_mm, f.rays,
      iterations > 0 ? fmt::format(", {} fixed-point iterations", iterations) : std::string()));
}

Vec2 PlacedRealisticCamera::filmPoint(Vec2 raster) const {
  const double sx = raster.x / settings_.x_resolution, sy = raster.y / settings_.y_resolution;
  return {half_width_mm_ - 2 * half_width_mm_ * sx, -half_height_mm_ + 2 * half_height_mm_ * sy};
}

Vec3 PlacedRealisticCamera::filmToLens(Vec2 film) const {
  return toGlobal(image_frame_, {film.x, film.y, film_offset_mm_}) + origin(image_frame_);
}

double PlacedRealisticCamera::discRadius(const Vec3& q) const {
  const double t_min = (q.z - z_near_) / (q.z - z_far_);
  return std::max(rear_semi_mm_, (1 - t_min) * std::hypot(q.x - rear_centre_.x,
                                                          q.y - rear_centre_.y) +
                                     t_min * rear_semi_mm_);
}

Vec3 PlacedRealisticCamera::planePoint(Vec2 q) const {
  return toGlobal(rear_frame_, {q.x, q.y, z_near_}) + origin(rear_frame_);
}

void PlacedRealisticCamera::buildBounds(Vec2 reach) {
  // A dispersive lens's beam moves with the wavelength: bound it at the rendered range's ends
  // and the primary wavelength.
  std::vector<double> lambdas{lens_.wavelength_nm()};
  if (dispersive_) lambdas.insert(lambdas.end(), {kRenderedMin_nm, kRenderedMax_nm});
  bounds_ = PlacedPupilBounds(
      reach, lambdas,
      [&](Vec2 film) {
        return discRadius(toLocal(rear_frame_, filmToLens(film) - origin(rear_frame_)));
      },
      [&](Vec2 film, Vec2 q, double lambda_nm) {
        const optics::PlacedLens& lens = dispersive_ ? lensAt(lambda_nm) : lens_;
        const Vec3 p = filmToLens(film);
        return lens.traceBackward({p, normalize(planePoint(q) - p)}).ok();
      });
}

PlacedRealisticCamera::SamplingRegion PlacedRealisticCamera::samplingRegion(Vec2 film) const {
  SamplingRegion r = bounds_.region(
      film, discRadius(toLocal(rear_frame_, filmToLens(film) - origin(rear_frame_))));
  r.centre = rear_centre_;  // the disc's (a decentred rear aperture has no polygons)
  return r;
}

const optics::PlacedLens& PlacedRealisticCamera::lensAt(double lambda_nm) const {
  struct PerThread {
    std::uint64_t owner = 0;
    std::optional<optics::PlacedLens> lens;
  };
  thread_local PerThread t;
  if (t.owner != id_) {
    t.lens = lens_;
    t.owner = id_;
  }
  if (t.lens->wavelength_nm() != lambda_nm) t.lens->setWavelength(lambda_nm);
  return *t.lens;
}

std::optional<CameraRay> PlacedRealisticCamera::generateRay(const CameraSample& sample) const {
  const Vec2 film = filmPoint(sample.film_raster);
  const Vec3 p = filmToLens(film);
  const SamplingRegion region = samplingRegion(film);
  const Vec2 q = region.sample(sample.lens);
  const Vec3 to = planePoint(q) - p;
  const double r2 = dot(to, to);
  const Vec3 dir = to / std::sqrt(r2);
  const double cos_plane = std::abs(dot(dir, axisZ(rear_frame_)));
  const double cos_film = std::abs(dot(dir, axisZ(image_frame_)));
  const double hero = sample.lambda_nm[0];
  const bool per_wavelength = dispersive_ && hero > 0;
  const optics::PlacedLens& lens = per_wavelength ? lensAt(hero) : lens_;
  thread_local std::vector<Vec3> path;
  path.clear();
  const optics::TraceResult r =
      lens.traceBackward({p, dir}, {}, absorbs_ && hero > 0 ? &path : nullptr);
  if (!r.ok()) return std::nullopt;
  double w = cos_film * cos_plane / r2 * region.area();
  if (!settings_.aperture.isRound() && stop_radius_mm_ > 0) {
    w *= settings_.aperture.transmission(
        Vec2{r.stop_point.x / stop_radius_mm_, r.stop_point.y / stop_radius_mm_});
    if (!(w > 0)) return std::nullopt;
  }
  // Internal transmittance: path[j] is the hit on surface n-1-j, so the segment to path[j+1]
  // runs in the medium after surface n-2-j.
  const int n = lens.surfaceCount();
  for (size_t j = 0; j + 1 < path.size(); ++j) {
    const optics::Glass& g = lens.glasses()[size_t(n - 2 - int(j))];
    if (g.hasTransmittance())
      w *= std::exp(-g.absorptionCoefficient_per_mm(hero) * length(path[j + 1] - path[j]));
  }
  // Lens coordinates (mm) to camera space (camera units, the scene toward +z).
  const double u = settings_.camera_units_per_mm;
  const Vec3 o_cam{r.ray.origin.x * u, r.ray.origin.y * u, -r.ray.origin.z * u};
  const Vec3 d_cam{r.ray.direction.x, r.ray.direction.y, -r.ray.direction.z};
  CameraRay ray;
  ray.time =
      settings_.shutter_open + sample.time * (settings_.shutter_close - settings_.shutter_open);
  const Transform& cw = settings_.world_from_camera.isAnimated()
                            ? settings_.world_from_camera.interpolate(ray.time)
                            : settings_.world_from_camera.start();
  ray.origin = cw.applyPoint(o_cam);
  ray.direction = normalize(cw.applyVector(d_cam));
  ray.weight = w;
  ray.hero_only = per_wavelength;  // refracted at the hero wavelength only
  return ray;
}

std::string PlacedRealisticCamera::describe() const {
  return fmt::format(
      "realistic, tilted or decentred lens: {} ({}), exact double-precision trace, film moved "
      "{:.4f} mm along the image surface's axis (focus {}{}), {:.1f} x {:.1f} "
      "mm film, aperture {}, rays aimed at the last surface's clear aperture ({:g} mm "
      "semi-diameter){}{}; no camera importance (path tracing only)",
      name_, path_, film_offset_mm_,
      std::isfinite(focus_distance_m_) ? fmt::format("{:.4g} m", focus_distance_m_)
                                       : std::string("at infinity"),
      !std::isfinite(focus_distance_m_) ? ""
      : film_referenced_                ? " from the film"
                                        : " from the front vertex: folded lens",
      2 * half_width_mm_, 2 * half_height_mm_, settings_.aperture.describe(), rear_semi_mm_,
      bounds_.binsX() > 0
          ? fmt::format(" within exit-pupil bounds ({} x {} film bins, {} without a bound of "
                        "their own, {} of them cut into quarters)",
                        bounds_.binsX(), bounds_.binsY(), bounds_.wholeBins(), bounds_.splitBins())
          : std::string(),
      dispersive_ ? ", dispersive (hero wavelength only)" : "");
}

}  // namespace lensim::camera
