// The realistic camera's importance (camera.h, CameraWiSample): light arriving from the scene,
// traced backward through the lens to the film.
//
// The measure. generateRay draws a film point uniformly in its pixel (by the filter) and a point
// q of the sampled region (area A(x)) of the rear-vertex plane, and weighs the ray by
// w = T cos^4(theta) A / z^2 (realistic.h). A ray's measure on the film side is
// dA_film cos(theta) d omega_film = dA_film dA_rear cos^4(theta) / z^2, and the lens conserves
// it (etendue, air on both sides): dA_film cos(theta) d omega_film = dA_front cos(n) d omega_front
// at the front element. So a pixel's estimate E[w L] is the integral of T L over the rays through
// the pixel in that measure divided by the pixel's area: the importance per unit front-element
// area and projected solid angle is T / A_film for every ray that reaches the film, A_film the
// area of the whole image (the light tracer's normalisation, camera.h), times z^2 / A0 with
// "simpleweighting" (whose weight has A0 where the irradiance has z^2). No Jacobian of the lens
// map is needed: the conserved measure carries it. A tilted or shifted film (realistic.cpp,
// "Tilt and shift") changes none of this: its weight T G A integrates the film-side measure
// dA_film cos_film d omega (cos_film against the placed film's normal), which the lens conserves
// too; light traced back meets the placed film, and must pass the region placedFilmRay samples.
//
// sampleWi draws a point of the front surface (uniform in its projection on the vertex plane,
// within the clear semi-aperture: density |n_z| / (pi R^2) per unit surface area, n the surface
// normal), traces the line from the scene point through it into the lens (exact tracer) to the
// film, and rejects it if the lens stops it, the line meets the front surface first elsewhere
// (that entry point has its own chance to be drawn), it lands off the film (beyond the filter's
// margin, film_bounds.h) or outside the region camera rays are drawn from (exit-pupil bounds;
// v1/v2 scenes: the rear disc). Its solid-angle density at the scene point is
// p_area r^2 / |cos(n, wi)|. pbrt-v4 has no realistic-camera importance (its RealisticCamera::We
// is unimplemented and its bdpt refuses the camera, pbrt-v4 issue #279).
//
// Dispersive lenses: the connection is traced at the path's hero wavelength and is valid for it
// alone (each wavelength would meet the film at its own point): CameraWiSample::hero_only, the
// light tracer then keeps only the hero wavelength (pbrt-v4's TerminateSecondary), which is
// unbiased. pbrt-v2's neighbour quirk (RealisticSettings::zero_if_neighbour_blocked) is not
// reproduced by importance.
#include <algorithm>
#include <cmath>
#include <vector>

#include "lensim/camera/realistic.h"
#include "lensim/optics/surface_shape.h"
#include "lensim/sampling/sampling.h"

namespace lensim::camera {

namespace {

/// The front surface at (x, y): its sag (lens space z of the point) and unit normal facing the
/// scene (-z); nullopt outside the sag's domain.
struct FrontPoint {
  Vec3 p;
  Vec3 n;
};
std::optional<FrontPoint> frontPoint(const optics::Interface& f, double x, double y) {
  double z = 0, gx = 0, gy = 0;
  if (f.radius_mm != 0 || !f.shape.isSpherical()) {
    const auto sg = optics::surfaceSag(f.radius_mm, f.shape, x, y);
    if (!sg) return std::nullopt;
    z = sg->z, gx = sg->dzdx, gy = sg->dzdy;
  }
  return FrontPoint{{x, y, f.z_mm + z}, normalize(Vec3{gx, gy, -1})};
}

}  // namespace

const Transform& RealisticCamera::cameraFromWorld(double time, Transform& scratch) const {
  if (!settings_.world_from_camera.isAnimated()) return camera_from_world_;
  scratch = inverse(settings_.world_from_camera.interpolate(time));
  return scratch;
}

// Camera space (camera units, +z toward the scene) and lens space (mm, +z toward the film):
// without tilt or shift z_lens = z0 - z_cam; with them camera space is the film's frame
// (realistic.cpp, placeRay), carried to lens space by the film's placement.
Vec3 RealisticCamera::lensFromWorldPoint(const Vec3& p, double time) const {
  Transform scratch;
  const Vec3 c = cameraFromWorld(time, scratch).applyPoint(p);
  const double u = settings_.camera_units_per_mm;
  if (placement_) return placement_->lensFromFilmPoint({c.x / u, c.y / u, -c.z / u});
  const double z0 = settings_.origin_at_front_vertex ? 0.0 : lens_.lens->filmZ_mm();
  return {c.x / u, c.y / u, z0 - c.z / u};
}
Vec3 RealisticCamera::lensFromWorldVector(const Vec3& v, double time) const {
  Transform scratch;
  const Vec3 c = cameraFromWorld(time, scratch).applyVector(v);
  if (placement_) return placement_->lensFromFilmVector({c.x, c.y, -c.z});
  return {c.x, c.y, -c.z};
}
Vec3 RealisticCamera::worldFromLensPoint(const Vec3& p, double time) const {
  Transform scratch;
  const double u = settings_.camera_units_per_mm;
  Vec3 c;
  if (placement_) {
    const Vec3 f = placement_->filmFromLensPoint(p);
    c = {f.x * u, f.y * u, -f.z * u};
  } else {
    const double z0 = settings_.origin_at_front_vertex ? 0.0 : lens_.lens->filmZ_mm();
    c = {p.x * u, p.y * u, (z0 - p.z) * u};
  }
  return settings_.world_from_camera.at(time, scratch).applyPoint(c);
}
Vec3 RealisticCamera::worldFromLensVector(const Vec3& v, double time) const {
  Transform scratch;
  Vec3 c{v.x, v.y, -v.z};
  if (placement_) {
    const Vec3 f = placement_->filmFromLensVector(v);
    c = {f.x, f.y, -f.z};
  }
  return settings_.world_from_camera.at(time, scratch).applyVector(c);
}

double RealisticCamera::importanceScale() const {
  const double z = lens_.lens->filmDistance_mm();
  const double norm = settings_.simple_weighting ? centre_area_mm2_ : z * z;
  const double film_area_mm2 = 4 * half_width_mm_ * half_height_mm_;
  const double units = settings_.camera_units_per_mm;
  return z * z / (norm * film_area_mm2 * units * units);
}

bool RealisticCamera::onFilm(Vec2 raster) const {
  const Vec2 fr = settings_.filter_radius;
  return raster.x >= 0.5 - fr.x && raster.x < settings_.x_resolution + fr.x - 0.5 &&
         raster.y >= 0.5 - fr.y && raster.y < settings_.y_resolution + fr.y - 0.5;
}

std::optional<RealisticCamera::FilmHit> RealisticCamera::traceToFilm(const Vec3& o_lens,
                                                                     const Vec3& d_lens,
                                                                     double lambda_nm,
                                                                     const Vec3* front_hit,
                                                                     Vec3* front_out) const {
  const optics::LensSystem& lens = *lens_.lens;
  if (!(d_lens.z > 0)) return std::nullopt;
  // Start the trace just before the front surface's slab: nothing of the lens lies before it,
  // and float keeps its precision there.
  Vec3 o = o_lens;
  const double z_start = front_zmin_mm_ - 1;
  if (o.z < z_start) o = o + d_lens * ((z_start - o.z) / d_lens.z);
  const optics::LensTracer<float>& tracer =
      dispersive_ && lambda_nm > 0 ? tracerAt(lambda_nm) : lens.tracerFloat();
  thread_local std::vector<Vec3f> path;
  path.clear();
  const bool absorbs = absorbs_ && lambda_nm > 0;
  const optics::TraceResultT<float> r =
      tracer.traceFromScene(optics::RayT<float>{Vec3f(o), Vec3f(d_lens)}, {},
                            front_hit || front_out || absorbs ? &path : nullptr);
  if (!r.ok()) return std::nullopt;
  if (front_out) {
    if (path.size() < 2) return std::nullopt;
    *front_out = Vec3{path[1]};
  }
  if (front_hit) {
    if (path.size() < 2) return std::nullopt;
    const Vec3 h{path[1]};
    if (length(h - *front_hit) > 1e-3 * (1 + length(*front_hit))) return std::nullopt;
  }
  const Vec3 ro{r.ray.origin}, rd{r.ray.direction};
  if (!(rd.z > 0)) return std::nullopt;
  const double z_film = lens.filmZ_mm(), z_rear = lens.rearVertexZ_mm();
  FilmHit hit;
  // The film point (film frame with tilt or shift, else lens space) and its lens-space point.
  Vec3 x;
  if (placement_) {
    Vec2 f;
    double t = 0;
    if (!placement_->intersectFilm(ro, rd, &f, &t) || !(t > 0)) return std::nullopt;
    hit.film_mm = f;
    x = ro + rd * t;
  } else {
    x = ro + rd * ((z_film - ro.z) / rd.z);
    hit.film_mm = {x.x, x.y};
  }
  hit.raster = rasterPoint(hit.film_mm);
  if (!onFilm(hit.raster)) return std::nullopt;
  // Only rays camera rays can take count: through the region generateRay samples for x, with
  // the density it samples them at (FilmHit::area_mm2, g_per_mm2).
  hit.cos_theta = rd.z / length(rd);
  const double z = lens.filmDistance_mm();
  if (placement_ && placement_->tiltShift().tilted()) {
    // The region of the plane z = rear_zmax_mm_ placedFilmRay samples (its polygon or disc).
    const Vec3 q = ro + rd * ((rear_zmax_mm_ - ro.z) / rd.z);
    const PupilRegion region = tilt_bounds_.region(hit.film_mm, tiltDiscRadius(x));
    if (!region.holds({q.x, q.y})) return std::nullopt;
    const Vec3 to = q - x;
    const double r2 = dot(to, to);
    const double cos_film = dot(normalize(rd), placement_->filmNormal());
    if (!(cos_film > 0) || !(r2 > 0)) return std::nullopt;
    hit.area_mm2 = region.area();
    hit.g_per_mm2 = cos_film * hit.cos_theta / r2;
  } else {
    // The exit-pupil bound at x's offset from the axis (shifted or not).
    const Vec3 q = ro + rd * ((z_rear - ro.z) / rd.z);
    const Vec2 at{x.x, x.y};
    if (settings_.rear_disc_only) {
      const double rr = lens.interfaces().back().semi_aperture_mm;
      if (q.x * q.x + q.y * q.y > rr * rr) return std::nullopt;
    }
    hit.area_mm2 = pupil_->areaMm2(at);
    if (!(hit.area_mm2 > 0) || !pupil_->contains(at, {q.x, q.y})) return std::nullopt;
    const double c2 = hit.cos_theta * hit.cos_theta;
    hit.g_per_mm2 = c2 * c2 / (z * z);
  }
  double transmission = 1;
  if (!settings_.aperture.isRound() && stop_radius_mm_ > 0) {
    transmission = settings_.aperture.transmission(
        Vec2{r.stop_point.x / stop_radius_mm_, r.stop_point.y / stop_radius_mm_});
    if (!(transmission > 0)) return std::nullopt;
  }
  hit.importance = transmission * importanceScale();
  if (absorbs) hit.importance *= pathTransmittance(path, false, lambda_nm);
  return hit;
}

bool RealisticCamera::connectionGeometry(const Vec3& ref, const Vec3& p, const Vec3& n,
                                          double disc_area_mm2, double time,
                                          CameraWiSample& s) const {
  s.p_lens = worldFromLensPoint(p, time);
  const Vec3 to_lens = s.p_lens - ref;
  s.distance = length(to_lens);
  if (!(s.distance > 0)) return false;
  s.wi = to_lens / s.distance;
  s.n_lens = normalize(worldFromLensVector(n, time));
  const double cos_n = std::abs(dot(s.n_lens, s.wi));
  if (!(cos_n > 0)) return false;
  // Uniform over the disc: |n_z| / area per unit of front-surface area, in world units.
  const double units = settings_.camera_units_per_mm;
  const double pdf_area = std::abs(n.z) / (disc_area_mm2 * units * units);
  s.pdf = pdf_area * s.distance * s.distance / cos_n;
  return true;
}

std::optional<CameraWiSample> RealisticCamera::sampleWi(
    const Vec3& ref, Vec2 u, const std::array<double, kCameraWavelengths>& lambda_nm,
    double time) const {
  const optics::Interface& front = lens_.lens->interfaces().front();
  const Vec3 r_l = lensFromWorldPoint(ref, time);
  if (!(r_l.z < front_zmin_mm_)) return std::nullopt;  // not in front of the lens
  const double R = front.semi_aperture_mm;
  const FrontDisc disc = frontDisc(r_l);
  if (!(disc.radius > 0)) return std::nullopt;
  const Vec2 xy = disc.centre + sampling::sampleUniformDiskConcentric(u) * disc.radius;
  if (xy.x * xy.x + xy.y * xy.y > R * R) return std::nullopt;
  const std::optional<FrontPoint> fp = frontPoint(front, xy.x, xy.y);
  if (!fp) return std::nullopt;
  const Vec3 d_l = normalize(fp->p - r_l);
  const double hero = lambda_nm[0];
  const std::optional<FilmHit> hit = traceToFilm(r_l, d_l, hero, &fp->p);
  if (!hit) return std::nullopt;
  CameraWiSample s;
  if (!connectionGeometry(ref, fp->p, fp->n, M_PI * disc.radius * disc.radius, time, s))
    return std::nullopt;
  s.film_raster = hit->raster;
  if (dispersive_ && hero > 0) {
    s.hero_only = true;
    s.importance = {hit->importance, 0, 0, 0};
  } else {
    s.importance.fill(hit->importance);
  }
  if (flare_) {
    // The reflection losses of the direct path, as generateRay's weight has them.
    std::array<double, kCameraWavelengths> t{};
    const double z_start = front_zmin_mm_ - 1;
    if (!reflectionLossesFromScene(r_l + d_l * ((z_start - r_l.z) / d_l.z), d_l, lambda_nm, t))
      return std::nullopt;
    for (int c = 0; c < kCameraWavelengths; ++c) s.importance[size_t(c)] *= t[size_t(c)];
  }
  return s;
}

// Flare's ghost connections (camera.h, sampleGhostWi). The pair is chosen with the probabilities
// of the camera side's ghost paths (realistic_flare.cpp); the front point uniformly over the
// front surface's projection within its clear semi-aperture (density |n_z| / (pi R^2) per unit
// surface area): each ghost enters through its own part of the front element, which sampleWi's
// bound (made for the direct path) does not hold. The measure argument above holds for the
// ghost path too (reflection and refraction conserve etendue), so the importance is the direct
// path's importanceScale times the aperture shape's transmission and the coatings' factor over
// the pair's probability. Every ray that reaches the film through a ghost path crosses the rear
// element, so it lies in the disc the camera side draws ghost directions from: only the film's
// bounds limit it.
std::optional<CameraWiSample> RealisticCamera::sampleGhostWi(
    const Vec3& ref, const std::array<double, 3>& u,
    const std::array<double, kCameraWavelengths>& lambda_nm, double time) const {
  if (!flare_) return std::nullopt;
  const optics::Interface& front = lens_.lens->interfaces().front();
  const Vec3 r_l = lensFromWorldPoint(ref, time);
  if (!(r_l.z < front_zmin_mm_)) return std::nullopt;
  const double R = front.semi_aperture_mm;
  const Vec2 xy = sampling::sampleUniformDiskConcentric({u[1], u[2]}) * R;
  const std::optional<FrontPoint> fp = frontPoint(front, xy.x, xy.y);
  if (!fp) return std::nullopt;
  const Vec3 d_l = normalize(fp->p - r_l);
  if (!(d_l.z > 0)) return std::nullopt;
  const double z_start = front_zmin_mm_ - 1;
  const Vec3 o = r_l.z < z_start ? r_l + d_l * ((z_start - r_l.z) / d_l.z) : r_l;
  const std::optional<GhostFromScene> g = traceGhostFromScene(u[0], o, d_l, lambda_nm);
  if (!g) return std::nullopt;
  // The line must enter the lens at the point drawn (another entry point has its own chance).
  if (length(g->front - fp->p) > 1e-6 * (1 + length(fp->p))) return std::nullopt;
  CameraWiSample s;
  s.film_raster = rasterPoint(g->film_mm);
  if (!onFilm(s.film_raster)) return std::nullopt;
  if (!connectionGeometry(ref, fp->p, fp->n, M_PI * R * R, time, s)) return std::nullopt;
  const double scale = importanceScale();
  for (int c = 0; c < kCameraWavelengths; ++c)
    s.importance[size_t(c)] = scale * g->factor[size_t(c)];
  return s;
}

// The front bounds, from the camera rays themselves: 65536 rays (a 128 x 128 grid of film points
// over the film's sample bounds, 4 exit-pupil points each) are traced out of the lens;
// each leaves the front element at a point p in direction w, which light from the scene arriving
// along -w enters at p. Binned by the angle theta of -w to the axis (0.25 degree bins) and turned
// to azimuth 0, the points of a bin are bounded by a disc, widened by twice the points' mean
// spacing (the sampled points cover the region only that finely) and 1% of the front radius (3%
// for a dispersive lens, whose other wavelengths leave elsewhere). Built on the first sampleWi
// (a light tracer's), never for camera rays.
void RealisticCamera::buildFrontBounds() const {
  const optics::LensSystem& lens = *lens_.lens;
  const double R = lens.interfaces().front().semi_aperture_mm;
  constexpr int kBins = 360, kFilm = 128, kPupil = 2;
  FrontBoundTable t;
  t.step_rad = 0.25 * M_PI / 180;
  std::vector<std::vector<Vec2>> pts(kBins);
  const Vec2 fr = settings_.filter_radius;
  const double x0 = 0.5 - fr.x, x1 = settings_.x_resolution + fr.x - 0.5;
  const double y0 = 0.5 - fr.y, y1 = settings_.y_resolution + fr.y - 0.5;
  for (int i = 0; i < kFilm; ++i)
    for (int j = 0; j < kFilm; ++j) {
      CameraSample cs;
      cs.film_raster = {x0 + (i + 0.5) / kFilm * (x1 - x0), y0 + (j + 0.5) / kFilm * (y1 - y0)};
      const Vec2 film = filmPoint(cs.film_raster);
      for (int a = 0; a < kPupil * kPupil; ++a) {
        // The R2 low-discrepancy sequence (Roberts 2018) over all the rays: every film point
        // gets other pupil points.
        const double n = double((i * kFilm + j) * kPupil * kPupil + a);
        const Vec2 u{std::fmod(0.5 + n * 0.7548776662466927, 1.0),
                     std::fmod(0.5 + n * 0.5698402909980532, 1.0)};
        cs.lens = u;
        const std::optional<FilmRay> f =
            placement_ ? placedFilmRay(cs, film) : filmRay(cs, film, pupil_->sample(film, u));
        if (!f) continue;
        const optics::TraceResultT<float> r = lens.tracerFloat().traceFromFilm(f->ray);
        if (!r.ok()) continue;
        const Vec3 p{r.ray.origin}, w = -normalize(Vec3{r.ray.direction});
        if (!(w.z > 0)) continue;
        const int k = int(std::acos(std::min(1.0, w.z)) / t.step_rad);
        if (k >= kBins) continue;
        const double phi = std::atan2(w.y, w.x), c = std::cos(phi), sn = std::sin(phi);
        pts[size_t(k)].push_back({p.x * c + p.y * sn, -p.x * sn + p.y * c});
      }
    }
  t.centre.assign(kBins, 0.0);
  t.radius.assign(kBins, -1.0);
  for (int k = 0; k < kBins; ++k) {
    const std::vector<Vec2>& v = pts[size_t(k)];
    if (v.empty()) continue;
    double a = v[0].x, b = v[0].x;
    for (const Vec2& q : v) a = std::min(a, q.x), b = std::max(b, q.x);
    const double c = 0.5 * (a + b);
    double r = 0;
    for (const Vec2& q : v) r = std::max(r, std::hypot(q.x - c, q.y));
    const double spacing = std::sqrt(M_PI * r * r / double(v.size()));
    t.centre[size_t(k)] = c;
    t.radius[size_t(k)] = r + 2 * spacing + (dispersive_ ? 0.03 : 0.01) * R;
  }
  front_bounds_ = std::move(t);
}

RealisticCamera::FrontDisc RealisticCamera::frontDisc(const Vec3& r) const {
  const optics::LensSystem& lens = *lens_.lens;
  const optics::Interface& front = lens.interfaces().front();
  const double R = front.semi_aperture_mm;
  const FrontDisc whole{{0, 0}, R};
  if (!pupil_->rotationallySymmetric()) return whole;  // anamorphic
  std::call_once(*front_once_, [this] { buildFrontBounds(); });
  const FrontBoundTable& t = front_bounds_;
  const Vec3 to_front = Vec3{0, 0, front.z_mm} - r;
  const double dist = length(to_front);
  const double reach = R + (front_zmax_mm_ - front_zmin_mm_);
  if (!(dist > 2 * reach)) return whole;
  // The directions from r to the front element: within spread of the central one.
  const double theta_c = std::acos(std::clamp(to_front.z / dist, -1.0, 1.0));
  const double spread = std::asin(reach / dist);
  const int n = int(t.radius.size());
  const int k0 = int(std::floor((theta_c - spread) / t.step_rad)) - 1;
  const int k1 = int(std::ceil((theta_c + spread) / t.step_rad)) + 1;
  if (k1 >= n) return whole;  // near 90 degrees: no table
  const int kc = std::clamp(int(std::lround(theta_c / t.step_rad)), 0, n - 1);
  double rho = -1, c_spread = 0, c_max = 0;
  const double c0 = t.centre[size_t(kc)];
  for (int k = std::max(0, k0); k <= k1; ++k) {
    if (t.radius[size_t(k)] < 0) continue;
    rho = std::max(rho, t.radius[size_t(k)]);
    c_spread = std::max(c_spread, std::abs(t.centre[size_t(k)] - c0));
    c_max = std::max(c_max, std::abs(t.centre[size_t(k)]));
  }
  if (rho < 0) return {};  // no light from r's directions reaches the film
  // The azimuths of the directions from r: within asin(reach / lateral) of the central one.
  const double lateral = std::hypot(r.x, r.y);
  const double dphi = lateral > reach ? std::asin(reach / lateral) : M_PI;
  const double radius = rho + c_spread + c_max * std::min(2.0, dphi);
  if (radius >= R) return whole;
  const double phi = std::atan2(-r.y, -r.x);
  return {{c0 * std::cos(phi), c0 * std::sin(phi)}, radius};
}

double RealisticCamera::pdfWiPos(const Vec3& ref, const Vec3& p_lens, double time) const {
  const optics::Interface& front = lens_.lens->interfaces().front();
  const Vec3 r_l = lensFromWorldPoint(ref, time), p = lensFromWorldPoint(p_lens, time);
  if (!(r_l.z < front_zmin_mm_)) return 0;
  const FrontDisc disc = frontDisc(r_l);
  const double R = front.semi_aperture_mm;
  const Vec2 xy{p.x, p.y};
  if (!(disc.radius > 0) || xy.x * xy.x + xy.y * xy.y > R * R ||
      std::hypot(xy.x - disc.centre.x, xy.y - disc.centre.y) > disc.radius)
    return 0;
  const std::optional<FrontPoint> fp = frontPoint(front, xy.x, xy.y);
  if (!fp) return 0;
  const double units = settings_.camera_units_per_mm;
  return std::abs(fp->n.z) / (M_PI * disc.radius * disc.radius * units * units);
}

double RealisticCamera::importance(const Vec3& o, const Vec3& d, double lambda_nm,
                                   Vec2* film_raster, double time) const {
  // The ray leaves the lens at o toward d: the line back into the lens runs along -d.
  const Vec3 o_l = lensFromWorldPoint(o, time), d_l = normalize(lensFromWorldVector(-d, time));
  const std::optional<FilmHit> hit = traceToFilm(o_l, d_l, lambda_nm);
  if (!hit) return 0;
  if (film_raster) *film_raster = hit->raster;
  if (flare_) {  // the direct path's reflection losses, at this wavelength
    std::array<double, kCameraWavelengths> t{};
    const double z_start = front_zmin_mm_ - 1;
    const Vec3 from = o_l.z < z_start ? o_l + d_l * ((z_start - o_l.z) / d_l.z) : o_l;
    if (!reflectionLossesFromScene(from, d_l, {lambda_nm, lambda_nm, lambda_nm, lambda_nm}, t))
      return 0;
    return hit->importance * t[0];
  }
  return hit->importance;
}

CameraRayPdf RealisticCamera::rayPdf(const Vec3& o, const Vec3& d, double lambda_nm,
                                     double time) const {
  // pdf_pos: sampleWi's density of the front-surface point (so that bdpt's strategies agree on
  // the camera vertex); pdf_dir: generateRay's joint density of the ray over it. generateRay
  // draws the film point uniformly over the image (1/A_film, as pbrt-v4's PDF_We takes it) and
  // a point uniformly over a region of area A(x) on a plane (the exit-pupil bound on the
  // rear-vertex plane; with tilt, the polygon or disc on the rear surface's plane): per unit
  // film area and projected solid angle (against the film's normal) that is 1 / (A_film A(x) G),
  // G = cos_film cos_plane / r^2 (cos^4(theta) / z^2 for an untilted film). The lens conserves
  // that measure (etendue), so per unit front area and solid angle it is that times cos(n).
  const optics::Interface& front = lens_.lens->interfaces().front();
  const Vec3 o_l = lensFromWorldPoint(o, time), back = normalize(lensFromWorldVector(-d, time));
  const std::optional<FrontPoint> fp = frontPoint(front, o_l.x, o_l.y);
  const std::optional<FilmHit> hit = traceToFilm(o_l, back, lambda_nm);
  if (!fp || !hit || !(hit->area_mm2 > 0) || !(hit->g_per_mm2 > 0)) return {};
  const double units = settings_.camera_units_per_mm, R = front.semi_aperture_mm;
  const double film_area_mm2 = 4 * half_width_mm_ * half_height_mm_;
  const double p_proj = 1 / (film_area_mm2 * hit->area_mm2 * hit->g_per_mm2);
  const double p_front = p_proj * std::abs(dot(fp->n, back)) / (units * units);
  const double pdf_pos = std::abs(fp->n.z) / (M_PI * R * R * units * units);
  return {pdf_pos, p_front / pdf_pos};
}

}  // namespace lensim::camera
