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
// map is needed: the conserved measure carries it.
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
#include <cmath>
#include <vector>

#include "lensim/camera/realistic.h"
#include "lensim/optics/surface_shape.h"
#include "lensim/render/sampling.h"

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

Vec3 RealisticCamera::lensFromWorldPoint(const Vec3& p) const {
  const Vec3 c = camera_from_world_.applyPoint(p);
  const double u = settings_.camera_units_per_mm;
  const double z0 = settings_.origin_at_front_vertex ? 0.0 : lens_.lens->filmZ_mm();
  return {c.x / u, c.y / u, z0 - c.z / u};
}
Vec3 RealisticCamera::lensFromWorldVector(const Vec3& v) const {
  const Vec3 c = camera_from_world_.applyVector(v);
  return {c.x, c.y, -c.z};
}
Vec3 RealisticCamera::worldFromLensPoint(const Vec3& p) const {
  const double u = settings_.camera_units_per_mm;
  const double z0 = settings_.origin_at_front_vertex ? 0.0 : lens_.lens->filmZ_mm();
  return settings_.world_from_camera.applyPoint({p.x * u, p.y * u, (z0 - p.z) * u});
}
Vec3 RealisticCamera::worldFromLensVector(const Vec3& v) const {
  return settings_.world_from_camera.applyVector({v.x, v.y, -v.z});
}

std::optional<RealisticCamera::FilmHit> RealisticCamera::traceToFilm(const Vec3& o_lens,
                                                                     const Vec3& d_lens,
                                                                     double lambda_nm,
                                                                     const Vec3* front_hit) const {
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
  const optics::TraceResultT<float> r = tracer.traceFromScene(
      optics::RayT<float>{Vec3f(o), Vec3f(d_lens)}, {}, front_hit ? &path : nullptr);
  if (!r.ok()) return std::nullopt;
  if (front_hit) {
    if (path.size() < 2) return std::nullopt;
    const Vec3 h{path[1]};
    if (length(h - *front_hit) > 1e-3 * (1 + length(*front_hit))) return std::nullopt;
  }
  const Vec3 ro{r.ray.origin}, rd{r.ray.direction};
  if (!(rd.z > 0)) return std::nullopt;
  const double z_film = lens.filmZ_mm(), z_rear = lens.rearVertexZ_mm();
  const Vec3 x = ro + rd * ((z_film - ro.z) / rd.z), q = ro + rd * ((z_rear - ro.z) / rd.z);
  FilmHit hit;
  hit.film_mm = {x.x, x.y};
  hit.raster = rasterPoint(hit.film_mm);
  const Vec2 fr = settings_.filter_radius;
  if (!(hit.raster.x >= 0.5 - fr.x && hit.raster.x < settings_.x_resolution + fr.x - 0.5 &&
        hit.raster.y >= 0.5 - fr.y && hit.raster.y < settings_.y_resolution + fr.y - 0.5))
    return std::nullopt;
  // Only rays camera rays can take count: through the sampled rear-plane region.
  if (settings_.rear_disc_only) {
    const double rr = lens.interfaces().back().semi_aperture_mm;
    if (q.x * q.x + q.y * q.y > rr * rr) return std::nullopt;
  }
  if (!(pupil_->area_mm2(hit.film_mm) > 0) || !pupil_->contains(hit.film_mm, {q.x, q.y}))
    return std::nullopt;
  double transmission = 1;
  if (!settings_.aperture.isRound() && stop_radius_mm_ > 0) {
    transmission = settings_.aperture.transmission(
        Vec2{r.stop_point.x / stop_radius_mm_, r.stop_point.y / stop_radius_mm_});
    if (!(transmission > 0)) return std::nullopt;
  }
  const double z = lens.filmDistance_mm();
  const double norm = settings_.simple_weighting ? centre_area_mm2_ : z * z;
  const double film_area_mm2 = 4 * half_width_mm_ * half_height_mm_;
  const double units = settings_.camera_units_per_mm;
  hit.cos_theta = rd.z / length(rd);
  hit.importance = transmission * z * z / (norm * film_area_mm2 * units * units);
  return hit;
}

std::optional<CameraWiSample> RealisticCamera::sampleWi(
    const Vec3& ref, Vec2 u, const std::array<double, kCameraWavelengths>& lambda_nm,
    double) const {
  const optics::Interface& front = lens_.lens->interfaces().front();
  const Vec3 r_l = lensFromWorldPoint(ref);
  if (!(r_l.z < front_zmin_mm_)) return std::nullopt;  // not in front of the lens
  const double R = front.semi_aperture_mm;
  const Vec2 xy = render::sampleUniformDiskConcentric(u) * R;
  const std::optional<FrontPoint> fp = frontPoint(front, xy.x, xy.y);
  if (!fp) return std::nullopt;
  const Vec3 d_l = normalize(fp->p - r_l);
  const double hero = lambda_nm[0];
  const std::optional<FilmHit> hit = traceToFilm(r_l, d_l, hero, &fp->p);
  if (!hit) return std::nullopt;
  CameraWiSample s;
  s.p_lens = worldFromLensPoint(fp->p);
  const Vec3 to_lens = s.p_lens - ref;
  s.distance = length(to_lens);
  if (!(s.distance > 0)) return std::nullopt;
  s.wi = to_lens / s.distance;
  s.n_lens = normalize(worldFromLensVector(fp->n));
  const double cos_n = std::abs(dot(s.n_lens, s.wi));
  if (!(cos_n > 0)) return std::nullopt;
  const double units = settings_.camera_units_per_mm;
  const double pdf_area = std::abs(fp->n.z) / (M_PI * R * R * units * units);  // per world area
  s.pdf = pdf_area * s.distance * s.distance / cos_n;
  s.film_raster = hit->raster;
  if (dispersive_ && hero > 0) {
    s.hero_only = true;
    s.importance = {hit->importance, 0, 0, 0};
  } else {
    s.importance.fill(hit->importance);
  }
  return s;
}

double RealisticCamera::importance(const Vec3& o, const Vec3& d, double lambda_nm,
                                   Vec2* film_raster) const {
  // The ray leaves the lens at o toward d: the line back into the lens runs along -d.
  const std::optional<FilmHit> hit =
      traceToFilm(lensFromWorldPoint(o), normalize(lensFromWorldVector(-d)), lambda_nm);
  if (!hit) return 0;
  if (film_raster) *film_raster = hit->raster;
  return hit->importance;
}

CameraRayPdf RealisticCamera::rayPdf(const Vec3& o, const Vec3& d, double lambda_nm) const {
  // pdf_pos: sampleWi's density of the front-surface point (so that bdpt's strategies agree on
  // the camera vertex); pdf_dir: generateRay's joint density of the ray over it. generateRay's
  // density per unit film area and film-side solid angle is (1/A_film) (1/A(x)) z^2 / cos^3
  // (film point uniform over the image, as pbrt-v4's PDF_We takes it; rear-plane point uniform
  // over the region A(x)); per unit front area and solid angle it is that times
  // cos(n) / cos(theta) (etendue).
  const optics::Interface& front = lens_.lens->interfaces().front();
  const Vec3 o_l = lensFromWorldPoint(o), back = normalize(lensFromWorldVector(-d));
  const std::optional<FrontPoint> fp = frontPoint(front, o_l.x, o_l.y);
  const std::optional<FilmHit> hit = traceToFilm(o_l, back, lambda_nm);
  if (!fp || !hit) return {};
  const double area = pupil_->area_mm2(hit->film_mm);
  if (!(area > 0)) return {};
  const double units = settings_.camera_units_per_mm, R = front.semi_aperture_mm;
  const double z = lens_.lens->filmDistance_mm(), c = hit->cos_theta;
  const double film_area_mm2 = 4 * half_width_mm_ * half_height_mm_;
  const double p_film = z * z / (film_area_mm2 * area * c * c * c);  // per mm^2 sr, film side
  const double p_front = p_film * std::abs(dot(fp->n, back)) / c / (units * units);
  const double pdf_pos = std::abs(fp->n.z) / (M_PI * R * R * units * units);
  return {pdf_pos, p_front / pdf_pos};
}

}  // namespace lensim::camera
