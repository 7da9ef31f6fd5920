// Lens flare in the realistic camera (issue 31; docs/flare.md, "Rendering ghosts").
//
// With "bool flare" every camera ray may reflect at the lens's interfaces. The measurement is
// the film irradiance over all paths through the lens with any number of reflections; lensim
// keeps the paths with none (the direct image) and with two (the ghosts). Paths with four or
// more reflections are left out: a bias of about the square of the ghosts' share of the light
// (an estimate, not measured: (5.5e-2)^2 ~ 3e-3 of the image for the uncoated double Gauss,
// ~1e-6 multicoated; a plate's four-reflection term is R^4 (1 - R)^2), named in docs/flare.md.
//
// Estimator. Each camera sample is split into two estimates, both added to the pixel:
//  - the direct path, drawn as without flare, its weight multiplied per wavelength by the
//    coatings' transmittance T at every surface it crosses, at its actual angles (so the
//    exposure drops by the reflection losses, ~59% for the uncoated double Gauss);
//  - one ghost path: a pair (first, second) chosen with probability p(pair) proportional to its
//    paraxial intensity from the workbench (`lens ghosts`: coatings at normal incidence, the
//    clear apertures' clipping), mixed with a uniform floor (kUniformShare / pairs) so that every
//    pair that can carry light has p > 0 and the estimator stays unbiased; a direction from the
//    sample's film point drawn uniformly over a disc of the plane where the rear element's
//    clear aperture is nearest the film, large enough to hold every ray from that film point
//    that reaches the rear element (so no path is missed; rays that miss the lens are blocked
//    by the tracer and contribute 0), or over the pair's own bound when smaller ("Per-ghost
//    bounds" below); the exact trace of the ghost path (coating/ghost_trace.h);
//    weight = T_shape cos^4(theta) A / D^2 (A: the region's area) x (prod R at the two reflections
//    x prod T at every other crossing, per wavelength, at the actual angles) / p(pair).
// Why: each ghost carries R^2 of the light (~3e-3 uncoated, 1e-5..1e-6 multicoated); Russian
// roulette at each interface would spend almost every sample on the direct path (the
// probability of a two-reflection path is ~R^2) and leave the ghosts as rare fireflies: per
// sample 15x (uncoated) to 1,000x (coated) the variance of this estimator (bench/bench_flare).
// Splitting gives every sample one ghost path, and the workbench's intensities send the samples to
// the ghosts that matter. Light tracing from the lights would need the scene's lights to be sampled
// through the lens (bdpt's t = 1 strategy) and Hullin-style bundles assume point lights; the split
// works for every light in the scene (area lights, the sky, reflections) with the unidirectional
// integrators.
//
// A dispersive lens (catalogue glasses): both paths are traced at the sample's hero wavelength
// only (hero_only; each thread re-indexes its copy of every pair's tracer), the coatings
// evaluated with that wavelength's indices, and both carry the glasses' internal transmittance
// over their real lengths in each glass (a ghost path crosses the glasses between its two
// reflections three times: Path::film_media names the medium of each of its segments).
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>

#include "lensim/camera/realistic.h"
#include "lensim/optics/anamorphic.h"
#include "lensim/optics/coating/ghost_trace.h"
#include "lensim/optics/coating/ghosts.h"
#include "lensim/optics/coating/lens_coatings.h"
#include "lensim/sampling/sampling.h"
#include "lensim/util/error.h"

namespace lensim::camera {

namespace {

/// Probability share spread uniformly over the ghost pairs (the floor that keeps every pair).
constexpr double kUniformShare = 0.1;

/// One interface of a path (direct or ghost) as light from the scene meets it: the lens surface,
/// the indices its coating sees (light from the first's side) and whether it reflects there.
struct Step {
  int surface = 0;
  double n_from = 1, n_to = 1;        ///< the path's media before and after (the same at a mirror)
  double coat_from = 1, coat_to = 1;  ///< the surface's media, the light's side first
  bool mirror = false;                ///< the path reflects here (R), else it passes (T)
  bool stop = false;
  bool backward = false;  ///< the light meets the surface from the film's side
  /// The indices of the step for the lens's media at a wavelength (before[k], after[k]: those
  /// of surface k).
  void setIndices(const double* before, const double* after) {
    const double near = backward ? after[surface] : before[surface];
    const double far = backward ? before[surface] : after[surface];
    n_from = coat_from = near;
    coat_to = far;
    n_to = mirror ? near : far;
  }
};

/// A ghost pair's bound for film points in one film-radius bin: the box [u0, u1] x [-v1, v1] of
/// the sampling plane in the frame turned so that the film point lies on +u (the lens is
/// rotationally symmetric); `whole`: no bound, the disc that holds every pair's rays.
struct GhostBox {
  double u0 = 0, u1 = 0, v1 = 0;
  bool whole = true;
};

}  // namespace

struct RealisticCamera::Flare {
  optics::LensCoatings coatings;
  std::vector<Step> direct;  ///< the lens's own surfaces
  struct Path {
    int first = 0, second = 0;
    double probability = 0;
    optics::LensTracer<double> tracer;
    std::vector<Step> steps;
    /// The lens medium (after that surface; -1: outside the lens) of each segment of a path
    /// traced from the film: film_media[j] holds pts[j] -> pts[j + 1].
    std::vector<int> film_media;
    /// Per film-radius bin (bin_width_mm wide from the centre): where its directions are drawn.
    std::vector<GhostBox> bounds;
  };
  std::vector<Path> ghosts;
  std::vector<double> cdf;  ///< cumulative probabilities (last = 1)
  /// The plane (lens z, mm) where ghost directions are sampled: the rear element's clear
  /// aperture nearest the film; t_min: the least fraction of the way from the film to the rear
  /// element at which a ray to it crosses that plane.
  double z_plane_mm = 0, t_min = 1, rear_radius_mm = 0;
  double bin_width_mm = 0;  ///< 0: no per-ghost bounds
};

namespace {

/// Per wavelength: the product of R (reflections) and T (passes) over the path's steps, at the
/// angles of a ray traced from the film with points pts (pts[0] the film point, pts[j] the hit
/// at step size - j) leaving along out_dir. Steps without an index step and no mirror are
/// skipped (T = 1).
/// `wavelengths`: how many of lambda_nm to evaluate (1: the hero only). `before`, `after`: the
/// lens's media's indices at the hero wavelength (a dispersive lens; else null: the steps' own).
void pathFactor(const optics::LensCoatings& coatings, const std::vector<Step>& steps,
                const std::vector<Vec3>& pts, const Vec3& out_dir,
                const std::array<double, kCameraWavelengths>& lambda_nm, double primary_nm,
                std::array<double, kCameraWavelengths>& factor, int wavelengths = kCameraWavelengths,
                const double* before = nullptr, const double* after = nullptr) {
  factor.fill(1.0);
  std::array<double, kCameraWavelengths> l;
  for (int c = 0; c < wavelengths; ++c)
    l[size_t(c)] = lambda_nm[size_t(c)] > 0 ? lambda_nm[size_t(c)] : primary_nm;
  const int m = int(steps.size());
  for (int i = 0; i < m; ++i) {
    Step s = steps[size_t(i)];
    if (before) s.setIndices(before, after);
    if (!s.mirror && s.n_from == s.n_to) continue;
    const int j = m - i;
    // a: the traced (film-to-scene) direction arriving at the surface, b: leaving it. Light
    // from the scene arrives along -b in n_from and leaves along -a; the normal is parallel to
    // n_to a - n_from b (Snell's law in vector form; for a mirror n_to = n_from).
    const Vec3 a = normalize(pts[size_t(j)] - pts[size_t(j - 1)]);
    const Vec3 b = j < m ? normalize(pts[size_t(j + 1)] - pts[size_t(j)]) : normalize(out_dir);
    const Vec3 nrm = a * s.n_to - b * s.n_from;
    const double len = length(nrm);
    const double cos_i = len > 1e-12 ? std::min(1.0, std::abs(dot(b, nrm)) / len) : 1.0;
    std::array<optics::FilmRTA, kCameraWavelengths> f;
    coatings.rtaSpectral(s.surface, s.coat_from, s.coat_to, {l.data(), size_t(wavelengths)}, cos_i,
                         f.data());
    for (int c = 0; c < wavelengths; ++c)
      factor[size_t(c)] *= s.mirror ? f[size_t(c)].R : f[size_t(c)].T;
  }
}

}  // namespace

namespace {

/// Where a ghost direction from film point x is drawn in the plane z_plane_mm: the disc that
/// holds every pair's rays (centre, radius), or, when smaller, the pair's box for x's
/// film-radius bin cut to that disc's square, in the frame (e_u, e_v) turned so that x lies on
/// +u.
struct GhostRegion {
  bool box = false;
  Vec2 centre;
  double radius = 0;
  Vec2 e_u{1, 0}, e_v{0, 1};
  double u0 = 0, u1 = 0, v1 = 0;
  double area() const { return box ? (u1 - u0) * 2 * v1 : M_PI * radius * radius; }
  /// The point of the region for u in [0, 1)^2 (uniform in area).
  Vec2 at(Vec2 u) const {
    if (!box) {
      const Vec2 d = sampling::sampleUniformDiskConcentric(u);
      return {centre.x + radius * d.x, centre.y + radius * d.y};
    }
    const double a = u0 + (u1 - u0) * u.x, b = v1 * (2 * u.y - 1);
    return {e_u.x * a + e_v.x * b, e_u.y * a + e_v.y * b};
  }
  bool holds(Vec2 q) const {
    if (!box) return std::hypot(q.x - centre.x, q.y - centre.y) <= radius;
    const double a = e_u.x * q.x + e_u.y * q.y, b = e_v.x * q.x + e_v.y * q.y;
    return a >= u0 && a <= u1 && std::abs(b) <= v1;
  }
};

// Every ray from the film point x that meets the rear element's clear aperture (radius r,
// between z_lo and z_hi) crosses the plane z_hi at x (1 - t) + s t, t in [t_min, 1]: within
// r + |x| (1 - t_min) of x (1 - t_min).
// spread = 1 - t_min; bin_width_mm: of the bounds' film-radius bins (0: no bounds).
GhostRegion ghostRegion(double spread, double rear_radius_mm, double bin_width_mm,
                        const std::vector<GhostBox>& bounds, Vec2 x) {
  GhostRegion g;
  const double rho = std::hypot(x.x, x.y);
  g.centre = {x.x * spread, x.y * spread};
  g.radius = rear_radius_mm + rho * spread;
  if (!(bin_width_mm > 0)) return g;
  const size_t bin = size_t(rho / bin_width_mm);
  if (bin >= bounds.size() || bounds[bin].whole) return g;
  const GhostBox& b = bounds[bin];
  if (rho > 0) g.e_u = {x.x / rho, x.y / rho}, g.e_v = {-g.e_u.y, g.e_u.x};
  const double c = rho * spread;
  g.u0 = std::max(b.u0, c - g.radius), g.u1 = std::min(b.u1, c + g.radius);
  g.v1 = std::min(b.v1, g.radius);
  // The box when it is the smaller region (both hold every ray that gets through).
  g.box = g.u1 > g.u0 && g.v1 > 0 && (g.u1 - g.u0) * 2 * g.v1 < M_PI * g.radius * g.radius;
  return g;
}

// Per-ghost bounds. The disc above holds every ray from a film point that reaches the rear
// element, but each ghost path's clear apertures pass only part of it (29 % of all pairs' paths
// at f/2, 1.2 % for the narrowest pair: bench/flare_ghost_waste.sh). Per pair and per film-radius
// bin: the ghost path is traced from film points on +x at kBoundRadii radii across the bin to a
// grid over the disc (v >= 0: the lens is symmetric about the film point's meridian), then to a
// finer grid over the passing points' extent widened by two coarse steps; the box around the
// fine grid's passing points is widened by twice its step (a passing region reaches at most a
// step beyond its outermost passing grid point unless it is narrower than a step there) plus the
// most that edge moves from one sampled radius to the next. A bin where no grid point passes, or
// where the region appears or vanishes between sampled radii, keeps the whole disc.
// tests/flare_bounds_test.cpp traces 10^6 points outside the boxes and finds none that gets
// through.
constexpr int kBoundBins = 8, kBoundRadii = 3, kBoundGrid = 24;

// The extent of the grid points of [ulo, uhi] x [0, vhi] (kBoundGrid + 1 columns, kBoundGrid / 2
// + 1 rows) inside the disc (centre c on +u, radius r) whose ghost path from the film point
// (rho, 0) gets through; `h`: the larger grid step.
struct RadiusExtent {
  bool any = false;
  double u0 = 1e300, u1 = -1e300, v1 = -1e300, h = 0;
};
RadiusExtent passingExtent(const optics::LensTracer<double>& tracer, double rho, double z_film,
                           double z_plane_mm, double c, double r, double ulo, double uhi,
                           double vhi) {
  RadiusExtent x;
  const double hu = (uhi - ulo) / kBoundGrid, hv = vhi / (kBoundGrid / 2);
  x.h = std::max(hu, hv);
  const Vec3 from{rho, 0, z_film};
  for (int a = 0; a <= kBoundGrid; ++a)
    for (int e = 0; e <= kBoundGrid / 2; ++e) {
      const double u = ulo + a * hu, v = e * hv;
      if ((u - c) * (u - c) + v * v > r * r) continue;
      const Vec3 dir = normalize(Vec3{u, v, z_plane_mm} - from);
      if (!tracer.traceFromFilm(optics::Ray{from, dir}).ok()) continue;
      x.any = true;
      x.u0 = std::min(x.u0, u), x.u1 = std::max(x.u1, u), x.v1 = std::max(x.v1, v);
    }
  return x;
}

std::vector<GhostBox> ghostBounds(double spread, double rear_radius_mm, double z_plane_mm,
                                  const optics::LensTracer<double>& tracer, double z_film,
                                  double film_radius_mm) {
  // The passing extent at each sampled film radius (bins share their end radii): a coarse grid
  // over the disc, then a grid over the coarse extent widened by two coarse steps.
  const int radii = kBoundBins * (kBoundRadii - 1) + 1;
  std::vector<RadiusExtent> at(static_cast<size_t>(radii));
  for (int j = 0; j < radii; ++j) {
    const double rho = film_radius_mm * j / (radii - 1);
    const double c = rho * spread, r = rear_radius_mm + rho * spread;
    const RadiusExtent coarse =
        passingExtent(tracer, rho, z_film, z_plane_mm, c, r, c - r, c + r, r);
    if (!coarse.any) continue;
    const double w = 2 * coarse.h;
    at[size_t(j)] = passingExtent(tracer, rho, z_film, z_plane_mm, c, r, coarse.u0 - w,
                                  coarse.u1 + w, std::min(r, coarse.v1 + w));
  }
  std::vector<GhostBox> out(static_cast<size_t>(kBoundBins));
  for (int b = 0; b < kBoundBins; ++b) {
    GhostBox box{1e300, -1e300, -1e300, false};
    std::array<double, 3> moved{};  // the most each edge (u0, u1, v1) moves between radii
    double step = 0;
    bool all = true;
    for (int i = 0; i < kBoundRadii && all; ++i) {
      const RadiusExtent& x = at[size_t(b * (kBoundRadii - 1) + i)];
      all = x.any;
      if (!all) break;
      if (i > 0) {
        const RadiusExtent& p = at[size_t(b * (kBoundRadii - 1) + i - 1)];
        moved = {std::max(moved[0], std::abs(x.u0 - p.u0)),
                 std::max(moved[1], std::abs(x.u1 - p.u1)),
                 std::max(moved[2], std::abs(x.v1 - p.v1))};
      }
      step = std::max(step, x.h);
      box.u0 = std::min(box.u0, x.u0), box.u1 = std::max(box.u1, x.u1);
      box.v1 = std::max(box.v1, x.v1);
    }
    if (!all) continue;  // whole
    out[size_t(b)] = {box.u0 - 2 * step - moved[0], box.u1 + 2 * step + moved[1],
                      box.v1 + 2 * step + moved[2], false};
  }
  return out;
}

}  // namespace

void RealisticCamera::setUpFlare() {
  const optics::LensSystem& lens = *lens_.lens;
  const FileLoc& loc = settings_.flare_loc;
  if (lens.mirrorCount() > 0)
    throw Error(loc,
                "flare: the lens has mirrors (ghosts of catadioptric lenses are not "
                "modelled)");
  auto f = std::make_shared<Flare>();
  optics::LensPrescription pr = lens.prescription();
  if (!settings_.flare_coating.empty()) {
    pr.default_coating = settings_.flare_coating;
    pr.default_coating_loc = settings_.flare_coating_loc;
  }
  f->coatings = optics::resolveCoatings(pr);
  const auto& s = lens.interfaces();
  const int n = lens.surfaceCount();
  for (int k = 0; k < n; ++k)
    f->direct.push_back({k, s[size_t(k)].ior_before, s[size_t(k)].ior_after,
                         s[size_t(k)].ior_before, s[size_t(k)].ior_after, false,
                         s[size_t(k)].is_stop});

  // The pairs and their paraxial intensities (400-700 nm, as `lens ghosts`).
  std::vector<double> wl;
  for (int l = 400; l <= 700; l += 10) wl.push_back(l);
  const optics::GhostAnalysis ga = optics::analyseGhosts(lens, f->coatings, wl);
  // Pairs with a surface without an index step (the stop, a dummy surface) reflect nothing.
  std::vector<optics::Ghost> pairs;
  for (const optics::Ghost& g : ga.ghosts)
    if (s[size_t(g.a)].ior_before != s[size_t(g.a)].ior_after &&
        s[size_t(g.b)].ior_before != s[size_t(g.b)].ior_after)
      pairs.push_back(g);
  if (pairs.empty()) throw Error(loc, "flare: the lens has no pair of reflecting surfaces");
  // The diagnostic restriction to listed pairs (the estimator stays unbiased for their sum).
  if (!settings_.flare_ghosts.empty()) {
    std::vector<optics::Ghost> kept;
    for (const auto& [i, j] : settings_.flare_ghosts) {
      const auto it = std::find_if(pairs.begin(), pairs.end(), [&](const optics::Ghost& g) {
        return g.b == i && g.a == j;
      });
      if (it == pairs.end())
        throw Error(settings_.flare_ghosts_loc,
                    fmt::format("flareghosts: {},{} is not a ghost pair of the lens (expected "
                                "I,J with 0 <= J < I <= {}, both surfaces with an index step)",
                                i, j, n - 1));
      kept.push_back(*it);
    }
    pairs = std::move(kept);
  }
  double sum = 0;
  for (const optics::Ghost& g : pairs) sum += std::max(0.0, g.relative_intensity);
  const double m = double(pairs.size());
  for (const optics::Ghost& g : pairs) {
    Flare::Path p;
    p.first = g.b, p.second = g.a;
    p.probability =
        (sum > 0 ? (1 - kUniformShare) * std::max(0.0, g.relative_intensity) / sum : 0.0) +
        (sum > 0 ? kUniformShare : 1.0) / m;
    const std::vector<optics::Interface> path =
        optics::ghostPathInterfaces(lens, p.first, p.second);
    p.tracer = optics::LensTracer<double>(path);
    for (int i = 0; i < int(path.size()); ++i) {
      const int k = optics::ghostPathSurface(p.first, p.second, i);
      const optics::Interface& in = path[size_t(i)];
      Step st{k,
              in.ior_before,
              in.ior_after,
              in.ior_before,
              in.ior_after,
              in.is_mirror,
              s[size_t(k)].is_stop};
      // Between the reflections (`second` included: it is met from the film side) the light
      // runs back toward the scene.
      st.backward = i > p.first && i <= 2 * p.first - p.second;
      // The reflecting surfaces, the indices of the light's side first: `first` is met from the
      // scene side, `second` from the film side.
      if (st.mirror) {
        const bool from_scene = k == p.first;
        st.coat_from = from_scene ? s[size_t(k)].ior_before : s[size_t(k)].ior_after;
        st.coat_to = from_scene ? s[size_t(k)].ior_after : s[size_t(k)].ior_before;
      }
      p.steps.push_back(st);
    }
    // The medium after each position of the path (the lens's medium k lies after surface k):
    // forward, after the surface; going back (the reflection at `first` included), before it;
    // after the reflection at `second`, forward again in the medium after it.
    const int len = int(path.size());
    std::vector<int> after_step(static_cast<size_t>(len));
    for (int i = 0; i < len; ++i) {
      const Step& st = p.steps[size_t(i)];
      const bool back_after = (st.backward && !st.mirror) || (st.mirror && st.surface == p.first);
      after_step[size_t(i)] = back_after ? st.surface - 1 : st.surface;
      if (after_step[size_t(i)] >= n - 1) after_step[size_t(i)] = -1;
    }
    // From the film, pts[j] -> pts[j + 1] lies between steps m - j and m - 1 - j.
    for (int j = 0; j < len; ++j) p.film_media.push_back(after_step[size_t(len - 1 - j)]);
    f->ghosts.push_back(std::move(p));
  }
  double c = 0;
  for (const Flare::Path& p : f->ghosts) f->cdf.push_back(c += p.probability);
  f->cdf.back() = 1;

  const auto [zlo, zhi] = surfaceZRange(s.back());
  const double z_film = lens.filmZ_mm();
  if (!(z_film > zhi))
    throw Error(loc, "flare: the rear element reaches the film; no ghost direction can be drawn");
  f->z_plane_mm = zhi;
  f->t_min = (z_film - zhi) / (z_film - zlo);
  f->rear_radius_mm = s.back().semi_aperture_mm;
  // Per-ghost bounds: for rotationally symmetric lenses traced at one wavelength (a dispersive
  // lens's ghost paths move with the hero wavelength: they keep the disc). Film points beyond
  // the bins (the pixel filter's margin) keep the disc too.
  if (settings_.flare_ghost_bounds && !dispersive_ &&
      optics::isRotationallySymmetric(lens.prescription())) {
    const double film_radius = std::hypot(half_width_mm_, half_height_mm_);
    f->bin_width_mm = film_radius / kBoundBins;
    for (Flare::Path& p : f->ghosts)
      p.bounds = ghostBounds(1 - f->t_min, f->rear_radius_mm, f->z_plane_mm, p.tracer, z_film,
                             film_radius);
  }
  flare_ = std::move(f);
}

double RealisticCamera::ghostPlaneZ_mm() const {
  return flare_ ? flare_->z_plane_mm : 0;
}

bool RealisticCamera::ghostRegionHolds(int k, Vec2 film_mm, Vec2 q_mm) const {
  if (!flare_ || k < 0 || k >= int(flare_->ghosts.size())) return false;
  const Flare& fl = *flare_;
  return ghostRegion(1 - fl.t_min, fl.rear_radius_mm, fl.bin_width_mm, fl.ghosts[size_t(k)].bounds,
                     film_mm)
      .holds(q_mm);
}

std::vector<RealisticCamera::GhostChoice> RealisticCamera::ghostChoices() const {
  std::vector<GhostChoice> out;
  if (flare_)
    for (const Flare::Path& p : flare_->ghosts) out.push_back({p.first, p.second, p.probability});
  return out;
}

void RealisticCamera::applyReflectionLosses(const CameraSample& sample, const FilmRay& f,
                                            CameraRay& ray) const {
  // The float tracer again, now recording the hits: the same operations as the batch trace
  // that made the ray, so the same surfaces.
  thread_local std::vector<Vec3f> ptsf;
  thread_local std::vector<Vec3> pts;
  ptsf.clear();
  const optics::TraceResultT<float> r = lens_.lens->tracerFloat().traceFromFilm(f.ray, {}, &ptsf);
  if (!r.ok()) {
    ray.weight = 0;
    return;
  }
  pts.clear();
  for (const Vec3f& p : ptsf) pts.push_back(Vec3(p));
  std::array<double, kCameraWavelengths> t{};
  pathFactor(flare_->coatings, flare_->direct, pts, Vec3(r.ray.direction), sample.lambda_nm,
             lens_.lens->wavelength_nm(), t);
  for (int c = 0; c < kCameraWavelengths; ++c)
    ray.wavelength_weight[size_t(c)] = ray.weight * t[size_t(c)];
  ray.weight = ray.wavelength_weight[0];
  ray.per_wavelength = true;
}

double RealisticCamera::heroReflectionLosses(const std::vector<Vec3f>& path, const Vec3f& out_dir,
                                             double lambda_nm) const {
  const int n = lens_.lens->surfaceCount();
  thread_local std::vector<double> before, after;
  thread_local std::vector<Vec3> pts;
  before.resize(size_t(n)), after.resize(size_t(n));
  indicesAt(lambda_nm, before.data(), after.data());
  pts.clear();
  for (const Vec3f& p : path) pts.push_back(Vec3(p));
  std::array<double, kCameraWavelengths> lambda{}, t{};
  lambda[0] = lambda_nm;
  pathFactor(flare_->coatings, flare_->direct, pts, Vec3(out_dir), lambda,
             lens_.lens->wavelength_nm(), t, 1, before.data(), after.data());
  return t[0];
}

std::optional<CameraRay> RealisticCamera::generateGhostRay(const CameraSample& sample) const {
  if (!flare_) return std::nullopt;
  const Flare& fl = *flare_;
  const int k = std::min(
      int(std::lower_bound(fl.cdf.begin(), fl.cdf.end(), sample.ghost_u[0]) - fl.cdf.begin()),
      int(fl.ghosts.size()) - 1);
  const Flare::Path& path = fl.ghosts[size_t(k)];
  // A dispersive lens: the ghost path is traced at the hero wavelength only (each thread keeps
  // a copy of every pair's tracer, re-indexed for the wavelength), and the ray's other
  // wavelengths are terminated (hero_only), as for the direct path.
  const double hero_nm = sample.lambda_nm[0];
  const bool hero_only = dispersive_ && hero_nm > 0;
  const optics::LensTracer<double>* tracer = &path.tracer;
  struct PerThread {
    std::uint64_t owner = 0;
    std::vector<optics::LensTracer<double>> tracers;
    std::vector<double> before, after, path_before, path_after;
  };
  thread_local PerThread t;
  if (hero_only) {
    const int n = lens_.lens->surfaceCount();
    if (t.owner != id_) {
      t.owner = id_;
      t.tracers.clear();
      for (const Flare::Path& p : fl.ghosts) t.tracers.push_back(p.tracer);
      t.before.resize(size_t(n)), t.after.resize(size_t(n));
    }
    indicesAt(hero_nm, t.before.data(), t.after.data());
    t.path_before.clear(), t.path_after.clear();
    for (Step st : path.steps) {
      st.setIndices(t.before.data(), t.after.data());
      t.path_before.push_back(st.n_from), t.path_after.push_back(st.n_to);
    }
    t.tracers[size_t(k)].setIndices(t.path_before.data(), t.path_after.data());
    tracer = &t.tracers[size_t(k)];
  }
  // The direction: uniform over the pair's region of the plane z_plane (ghostRegion).
  const optics::LensSystem& lens = *lens_.lens;
  const Vec2 x = filmPoint(sample.film_raster);
  const double z_film = lens.filmZ_mm();
  const GhostRegion region =
      ghostRegion(1 - fl.t_min, fl.rear_radius_mm, fl.bin_width_mm, path.bounds, x);
  const Vec2 qp = region.at({sample.ghost_u[1], sample.ghost_u[2]});
  const Vec3 from{x.x, x.y, z_film};
  const Vec3 q{qp.x, qp.y, fl.z_plane_mm};
  const Vec3 dir = normalize(q - from);
  thread_local std::vector<Vec3> pts;
  pts.clear();
  const optics::TraceResult r = tracer->traceFromFilm(optics::Ray{from, dir}, {}, &pts);
  if (!r.ok()) return std::nullopt;
  // A shaped aperture passes the path at every crossing of the stop.
  double shape = 1;
  if (!settings_.aperture.isRound() && stop_radius_mm_ > 0) {
    const int m = int(path.steps.size());
    for (int i = 0; i < m; ++i)
      if (path.steps[size_t(i)].stop) {
        const Vec3& p = pts[size_t(m - i)];
        shape *= settings_.aperture.transmission({p.x / stop_radius_mm_, p.y / stop_radius_mm_});
      }
    if (!(shape > 0)) return std::nullopt;
  }
  std::array<double, kCameraWavelengths> factor{};
  if (hero_only) {
    pathFactor(fl.coatings, path.steps, pts, r.ray.direction, sample.lambda_nm,
               lens.wavelength_nm(), factor, 1, t.before.data(), t.after.data());
    // The glasses' absorption over the ghost path's real lengths in each medium.
    if (absorbs_) factor[0] *= absorption_.alongMedia(pts, path.film_media, hero_nm);
  } else {
    pathFactor(fl.coatings, path.steps, pts, r.ray.direction, sample.lambda_nm,
               lens.wavelength_nm(), factor);
  }
  // Film irradiance per unit area of the sampling plane at distance D: cos^4(theta) / D^2.
  const double dist = z_film - fl.z_plane_mm, c = -dir.z;
  const double area = region.area();
  const double geometric = shape * c * c * c * c * area / (dist * dist) *
                           (lens.filmDistance_mm() * lens.filmDistance_mm() / weightNorm());
  CameraRay ray = placeRay(r.ray.origin, r.ray.direction, sample.time);
  ray.ghost = true;
  if (hero_only) {
    ray.weight = geometric * factor[0] / path.probability;
    ray.hero_only = true;
    return ray;
  }
  for (int i = 0; i < kCameraWavelengths; ++i)
    ray.wavelength_weight[size_t(i)] = geometric * factor[size_t(i)] / path.probability;
  ray.weight = ray.wavelength_weight[0];
  ray.per_wavelength = true;
  return ray;
}

}  // namespace lensim::camera

// The light tracer's side (realistic_importance.cpp, sampleWi and sampleGhostWi): the same paths
// traced from the scene, weighted by the same factors (pathFactor on the points in the film-first
// order it reads).
namespace lensim::camera {

namespace {

/// A scene-first trace's points (start, then the hit at each step) in pathFactor's order: the
/// film point, then the hits from the last step to the first.
void filmFirst(const std::vector<Vec3>& scene_first, const Vec3& film, std::vector<Vec3>& out) {
  out.clear();
  out.push_back(film);
  for (size_t j = scene_first.size(); j-- > 1;) out.push_back(scene_first[j]);
}

}  // namespace

bool RealisticCamera::reflectionLossesFromScene(
    const Vec3& o_lens, const Vec3& d_lens, const std::array<double, kCameraWavelengths>& lambda_nm,
    std::array<double, kCameraWavelengths>& t) const {
  const optics::LensSystem& lens = *lens_.lens;
  thread_local std::vector<Vec3f> ptsf;
  thread_local std::vector<Vec3> scene_first, pts;
  ptsf.clear();
  const optics::TraceResultT<float> r =
      lens.tracerFloat().traceFromScene(optics::RayT<float>{Vec3f(o_lens), Vec3f(d_lens)}, {},
                                        &ptsf);
  if (!r.ok() || !(r.ray.direction.z > 0)) return false;
  scene_first.clear();
  for (const Vec3f& p : ptsf) scene_first.push_back(Vec3(p));
  const Vec3 ro{r.ray.origin}, rd{r.ray.direction};
  filmFirst(scene_first, ro + rd * ((lens.filmZ_mm() - ro.z) / rd.z), pts);
  pathFactor(flare_->coatings, flare_->direct, pts, -d_lens, lambda_nm, lens.wavelength_nm(), t);
  return true;
}

std::optional<RealisticCamera::GhostFromScene> RealisticCamera::traceGhostFromScene(
    double u_pair, const Vec3& o_lens, const Vec3& d_lens,
    const std::array<double, kCameraWavelengths>& lambda_nm) const {
  if (!flare_) return std::nullopt;
  const Flare& fl = *flare_;
  const int k = int(std::lower_bound(fl.cdf.begin(), fl.cdf.end(), u_pair) - fl.cdf.begin());
  const Flare::Path& path = fl.ghosts[size_t(std::min(k, int(fl.ghosts.size()) - 1))];
  const optics::LensSystem& lens = *lens_.lens;
  thread_local std::vector<Vec3> scene_first, pts;
  scene_first.clear();
  const optics::TraceResult r =
      path.tracer.traceFromScene(optics::Ray{o_lens, d_lens}, {}, &scene_first);
  if (!r.ok() || !(r.ray.direction.z > 0)) return std::nullopt;
  const int m = int(path.steps.size());
  if (int(scene_first.size()) != m + 1) return std::nullopt;
  GhostFromScene g;
  const Vec3 film = r.ray.origin + r.ray.direction * ((lens.filmZ_mm() - r.ray.origin.z) /
                                                      r.ray.direction.z);
  g.film_mm = {film.x, film.y};
  g.front = scene_first[1];
  g.cos_theta = r.ray.direction.z / length(r.ray.direction);
  // A shaped aperture passes the path at every crossing of the stop (as generateGhostRay).
  double shape = 1;
  if (!settings_.aperture.isRound() && stop_radius_mm_ > 0) {
    for (int i = 0; i < m; ++i)
      if (path.steps[size_t(i)].stop) {
        const Vec3& p = scene_first[size_t(i + 1)];
        shape *= settings_.aperture.transmission({p.x / stop_radius_mm_, p.y / stop_radius_mm_});
      }
    if (!(shape > 0)) return std::nullopt;
  }
  filmFirst(scene_first, film, pts);
  pathFactor(fl.coatings, path.steps, pts, -d_lens, lambda_nm, lens.wavelength_nm(), g.factor);
  for (double& f : g.factor) f *= shape / path.probability;
  return g;
}

}  // namespace lensim::camera
