#include "lensim/optics/wavefront.h"

#include <fftw3.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <numbers>

namespace lensim::optics {

namespace {

// Azimuths along which the forward beam's edge is bisected: the 256-gon's chord is within
// 1 - cos(pi / 256) = 7.5e-5 of a circular edge.
constexpr int kEdgeDirections = 256;

// Optical path (mm) from P' back through the lens to the object-side reference, or nullopt when
// the ray is blocked. `a` is n' times the forward direction cosines (alpha, beta) at P'.
struct BackTracer {
  const LensSystem& lens;
  const FieldBundle& b;
  Vec3 start;
  double n_img;

  std::optional<double> opl(Vec2 a) const {
    const double ax = a.x / n_img, ay = a.y / n_img;
    const double s2 = ax * ax + ay * ay;
    if (s2 >= 1) return std::nullopt;
    const Vec3 dir{-ax, -ay, -std::sqrt(1 - s2)};
    thread_local std::vector<Vec3> path;
    path.clear();
    TraceResult r = lens.tracer().traceFromFilm({start, dir}, {}, &path);
    if (!r.ok() || !(r.ray.direction.z < 0)) return std::nullopt;
    const auto& s = lens.interfaces();
    const int n = lens.surfaceCount();
    // path[0] = P', path[k] = surface n - k; the medium before path[k + 1] (toward the film side)
    // is the one behind surface n - k - 1 ... ior_before of surface n - k for k >= 1.
    double L = n_img * length(path[1] - path[0]);
    for (int k = 1; k < n; ++k) L += s[n - k].ior_before * length(path[k + 1] - path[k]);
    const Vec3 q = r.ray.origin, e = r.ray.direction;
    const double n_obj = lens.objectIor();
    if (b.object) return L + n_obj * length(*b.object - q);
    // Plane through a point of the chief ray in front of the lens, normal to it.
    const Vec3 d = b.chief_scene.direction;
    const double t = dot(b.chief_scene.origin - q, d) / dot(e, d);
    return L + n_obj * t;
  }
};

}  // namespace

double perfectMtf(double v) {
  if (v <= 0) return 1;
  if (v >= 1) return 0;
  return 2 / std::numbers::pi * (std::acos(v) - v * std::sqrt(1 - v * v));
}

double PupilFunction::halfWidth() const {
  double r = 0;
  for (const Vec2& q : edge) r = std::max(r, std::hypot(q.x - centre.x, q.y - centre.y));
  return r;
}

std::optional<PupilFunction> computePupilFunction(const LensSystem& lens, const FieldBundle& b,
                                                  double film_z_mm, Vec2 image_point_mm,
                                                  double wavelength_nm, int cells,
                                                  double max_step_waves, int max_cells,
                                                  int min_cells) {
  const double n_img = lens.imageIor();
  BackTracer bt{lens, b, {image_point_mm.x, image_point_mm.y, film_z_mm}, n_img};
  long traced = 0;
  auto opl = [&](Vec2 a) {
    ++traced;
    return bt.opl(a);
  };
  // The beam's edge from the forward (object-side) beam: the boundary of the entrance-pupil
  // region whose rays get through, traced forward to image-space direction cosines. Rays traced
  // back from P' would see a different cone where the lens is aberrated (the forward marginal
  // ray does not pass through P'): 3.9% wider for US 583,336 at f/4.5.
  auto region = b.pupilRegion(lens, kEdgeDirections);
  if (!region) return std::nullopt;
  std::vector<Vec2> edge;
  edge.reserve(region->radius.size());
  for (size_t j = 0; j < region->radius.size(); ++j) {
    const double ang = 2 * std::numbers::pi * double(j) / double(region->radius.size());
    const Vec2 o = region->centre + Vec2{std::cos(ang), std::sin(ang)} * region->radius[j];
    // Apertures ignored: the ray grazes the one that stops it.
    TraceResult r = lens.tracer().traceFromScene(b.sceneRay(o), TraceOptions{false});
    ++traced;
    if (!r.ok() || !(r.ray.direction.z > 0)) continue;
    edge.push_back({n_img * r.ray.direction.x, n_img * r.ray.direction.y});
  }
  if (edge.size() < 8) return std::nullopt;
  auto insideEdge = [&](Vec2 a) {  // even-odd rule: the edge polygon need not be convex
    bool in = false;
    for (size_t i = 0, j = edge.size() - 1; i < edge.size(); j = i++)
      if ((edge[i].y > a.y) != (edge[j].y > a.y) &&
          a.x < edge[j].x + (a.y - edge[j].y) * (edge[i].x - edge[j].x) / (edge[i].y - edge[j].y))
        in = !in;
    return in;
  };
  // A cell passes when its direction lies in the forward beam and its ray traced back from P'
  // gets through (it gives W).
  auto pupilOpl = [&](Vec2 a) -> std::optional<double> {
    if (!insideEdge(a)) return std::nullopt;
    return opl(a);
  };
  Vec2 lo_pt = edge[0], hi_pt = edge[0];
  for (const Vec2& q : edge) {
    lo_pt = {std::min(lo_pt.x, q.x), std::min(lo_pt.y, q.y)};
    hi_pt = {std::max(hi_pt.x, q.x), std::max(hi_pt.y, q.y)};
  }
  const Vec2 centre = (lo_pt + hi_pt) * 0.5;
  const double half = 1.03 * 0.5 * std::max(hi_pt.x - lo_pt.x, hi_pt.y - lo_pt.y);
  // W's reference: the chief ray's direction at P' (or, vignetted, the grid centre, else any
  // passing direction of the edge polygon's bounding square).
  std::optional<double> ref;
  {
    TraceResult r = lens.tracer().traceFromScene(b.sceneRay({0, 0}), TraceOptions{false});
    if (r.ok() && r.ray.direction.z > 0)
      ref = pupilOpl({n_img * r.ray.direction.x, n_img * r.ray.direction.y});
  }
  if (!ref) ref = pupilOpl(centre);
  for (int grid : {16, 64})
    for (int iy = 0; iy < grid && !ref; ++iy)
      for (int ix = 0; ix < grid && !ref; ++ix)
        ref = pupilOpl(centre + Vec2{half * (2.0 * (ix + 0.5) / grid - 1),
                                     half * (2.0 * (iy + 0.5) / grid - 1)});
  if (!ref) return std::nullopt;

  PupilFunction pf;
  for (int n = cells > 0 ? cells : std::max(8, min_cells);; n *= 2) {
    pf = PupilFunction{};
    pf.edge = edge;
    pf.n = n;
    pf.step = 2 * half / n;
    pf.centre = centre;
    pf.wavelength_nm = wavelength_nm;
    pf.image_point_mm = image_point_mm;
    const double lambda_mm = wavelength_nm * 1e-6;
    pf.amplitude.assign(size_t(n) * n, 0.0);
    pf.opd_waves.assign(size_t(n) * n, 0.0);
    auto cellPoint = [&](double ix, double iy) {
      return Vec2{centre.x + (ix + 0.5 - 0.5 * n) * pf.step,
                  centre.y + (iy + 0.5 - 0.5 * n) * pf.step};
    };
    std::vector<std::uint8_t> pass(size_t(n) * n, 0);
    for (int iy = 0; iy < n; ++iy)
      for (int ix = 0; ix < n; ++ix) {
        const size_t k = size_t(iy) * n + ix;
        if (auto L = pupilOpl(cellPoint(ix, iy))) {
          pass[k] = 1;
          pf.amplitude[k] = 1;
          pf.opd_waves[k] = (*L - *ref) / lambda_mm;
        }
      }
    // Edge cells (a 4-neighbour differs): 4x4 sub-rays give the covered fraction and mean W.
    for (int iy = 0; iy < n; ++iy)
      for (int ix = 0; ix < n; ++ix) {
        const size_t k = size_t(iy) * n + ix;
        bool edge = false;
        const int nb[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
        for (const auto& d : nb) {
          const int jx = ix + d[0], jy = iy + d[1];
          const bool other = jx >= 0 && jy >= 0 && jx < n && jy < n && pass[size_t(jy) * n + jx];
          if (other != bool(pass[k])) edge = true;
        }
        if (!edge) continue;
        int hits = 0;
        double sum = 0;
        for (int sy = 0; sy < 4; ++sy)
          for (int sx = 0; sx < 4; ++sx)
            if (auto L =
                    pupilOpl(cellPoint(ix - 0.5 + (sx + 0.5) / 4, iy - 0.5 + (sy + 0.5) / 4))) {
              ++hits;
              sum += (*L - *ref) / lambda_mm;
            }
        pf.amplitude[k] = hits / 16.0;
        pf.opd_waves[k] = hits > 0 ? sum / hits : 0.0;
      }
    // Aliasing check: the largest step of W between neighbouring passing cells.
    double max_step = 0, sw = 0, swx = 0, swxx = 0;
    for (int iy = 0; iy < n; ++iy)
      for (int ix = 0; ix < n; ++ix) {
        const size_t k = size_t(iy) * n + ix;
        const double a = pf.amplitude[k];
        if (a <= 0) continue;
        sw += a;
        swx += a * pf.opd_waves[k];
        swxx += a * pf.opd_waves[k] * pf.opd_waves[k];
        if (ix + 1 < n && pass[k] && pass[k + 1])
          max_step = std::max(max_step, std::abs(pf.opd_waves[k + 1] - pf.opd_waves[k]));
        if (iy + 1 < n && pass[k] && pass[k + n])
          max_step = std::max(max_step, std::abs(pf.opd_waves[k + n] - pf.opd_waves[k]));
      }
    pf.max_step_waves = max_step;
    const double mean = sw > 0 ? swx / sw : 0;
    pf.rms_opd_waves = sw > 0 ? std::sqrt(std::max(0.0, swxx / sw - mean * mean)) : 0;
    if (cells > 0 || max_step < max_step_waves || 2 * n > max_cells) break;
  }
  pf.rays_traced = traced;
  return pf;
}

namespace {

// FFTW's planner is not thread-safe (only fftw_execute is): plans are made and destroyed under
// this lock, so pupil functions can be transformed concurrently (the design operands evaluate
// them from parallel Jacobian columns).
std::mutex& fftwPlannerMutex() {
  static std::mutex m;
  return m;
}

fftw_plan planDft2d(int m, fftw_complex* buf, int sign) {
  std::lock_guard<std::mutex> lock(fftwPlannerMutex());
  return fftw_plan_dft_2d(m, m, buf, buf, sign, FFTW_ESTIMATE);
}

void destroyPlan(fftw_plan p) {
  std::lock_guard<std::mutex> lock(fftwPlannerMutex());
  fftw_destroy_plan(p);
}

}  // namespace

FourierOptics fourierOptics(const PupilFunction& pf) {
  const int n = pf.n, m = 2 * n;
  const double lambda_mm = pf.wavelength_nm * 1e-6;
  FourierOptics fo;
  fo.m = m;
  fo.psf_pitch_mm = lambda_mm / (m * pf.step);
  fo.frequency_step = pf.step / lambda_mm;
  const size_t mm = size_t(m) * m;
  auto* buf = static_cast<fftw_complex*>(fftw_malloc(sizeof(fftw_complex) * mm));
  fftw_plan plan = planDft2d(m, buf, FFTW_BACKWARD);
  // The pupil, placed so that its centre cell sits at index 0 (a linear phase only moves the
  // PSF; this keeps P' at index 0 of the transform).
  std::fill(reinterpret_cast<double*>(buf), reinterpret_cast<double*>(buf) + 2 * mm, 0.0);
  double amp_sum = 0;
  for (int iy = 0; iy < n; ++iy)
    for (int ix = 0; ix < n; ++ix) {
      const double a = pf.amplitude[size_t(iy) * n + ix];
      if (a <= 0) continue;
      amp_sum += a;
      const double ph = 2 * std::numbers::pi * pf.opd_waves[size_t(iy) * n + ix];
      const int jx = (ix - n / 2 + m) % m, jy = (iy - n / 2 + m) % m;
      buf[size_t(jy) * m + jx][0] = a * std::cos(ph);
      buf[size_t(jy) * m + jx][1] = a * std::sin(ph);
    }
  fftw_execute(plan);
  // PSF = |U|^2, centred (fftshift), normalised to sum 1. The aberration-free peak is
  // (sum a)^2 at the same scale.
  std::vector<double> raw(mm);
  double total = 0, peak = 0;
  for (size_t k = 0; k < mm; ++k) {
    raw[k] = buf[k][0] * buf[k][0] + buf[k][1] * buf[k][1];
    total += raw[k];
    peak = std::max(peak, raw[k]);
  }
  fo.strehl = amp_sum > 0 ? peak / (amp_sum * amp_sum) : 0;
  fo.psf.assign(mm, 0.0);
  for (int y = 0; y < m; ++y)
    for (int x = 0; x < m; ++x)
      fo.psf[size_t((y + m / 2) % m) * m + (x + m / 2) % m] = raw[size_t(y) * m + x] / total;
  fo.lsf_x.assign(m, 0.0);
  fo.lsf_y.assign(m, 0.0);
  for (int y = 0; y < m; ++y)
    for (int x = 0; x < m; ++x) {
      const double v = fo.psf[size_t(y) * m + x];
      fo.lsf_x[x] += v;
      fo.lsf_y[y] += v;
    }
  // OTF = transform of the PSF (the pupil's autocorrelation), normalised to 1 at zero frequency.
  // The sign of the transform gives OTF(nu) = sum PSF(x) exp(-i 2 pi nu x).
  for (size_t k = 0; k < mm; ++k) {
    buf[k][0] = raw[k];
    buf[k][1] = 0;
  }
  fftw_plan fwd = planDft2d(m, buf, FFTW_FORWARD);
  fftw_execute(fwd);
  fo.otf.resize(mm);
  const double o0 = buf[0][0];
  for (size_t k = 0; k < mm; ++k) fo.otf[k] = {buf[k][0] / o0, buf[k][1] / o0};
  destroyPlan(fwd);
  destroyPlan(plan);
  fftw_free(buf);
  return fo;
}

std::complex<double> FourierOptics::otfAt(double nu_x, double nu_y) const {
  const double fx = nu_x / frequency_step, fy = nu_y / frequency_step;
  const double half = m / 2 - 1;
  if (std::abs(fx) > half || std::abs(fy) > half) return 0;
  const int x0 = static_cast<int>(std::floor(fx)), y0 = static_cast<int>(std::floor(fy));
  const double tx = fx - x0, ty = fy - y0;
  auto at = [&](int x, int y) { return otf[size_t((y + m) % m) * m + size_t((x + m) % m)]; };
  return (1 - ty) * ((1 - tx) * at(x0, y0) + tx * at(x0 + 1, y0)) +
         ty * ((1 - tx) * at(x0, y0 + 1) + tx * at(x0 + 1, y0 + 1));
}

std::complex<double> FourierOptics::otfAlongAxis(double nu, bool along_y) const {
  const std::vector<double>& lsf = along_y ? lsf_y : lsf_x;
  // exp(-i 2 pi nu x) by recurrence from P' outward in both directions (each side's phase
  // error grows only as m epsilon).
  const double w = -2 * std::numbers::pi * nu * psf_pitch_mm;
  std::complex<double> sum = lsf[size_t(m / 2)];
  const std::complex<double> step{std::cos(w), std::sin(w)};
  std::complex<double> e = 1, ec = 1;
  for (int k = 1; k <= m / 2; ++k) {
    e *= step;
    ec = std::conj(e);
    if (m / 2 + k < m) sum += lsf[size_t(m / 2 + k)] * e;
    sum += lsf[size_t(m / 2 - k)] * ec;
  }
  return sum;
}

double FourierOptics::psfAt(double dx, double dy) const {
  const double fx = dx / psf_pitch_mm + m / 2, fy = dy / psf_pitch_mm + m / 2;
  if (fx < 0 || fy < 0 || fx > m - 1 || fy > m - 1) return 0;
  const int x0 = std::min(static_cast<int>(fx), m - 2), y0 = std::min(static_cast<int>(fy), m - 2);
  const double tx = fx - x0, ty = fy - y0;
  auto at = [&](int x, int y) { return psf[size_t(y) * m + x]; };
  return (1 - ty) * ((1 - tx) * at(x0, y0) + tx * at(x0 + 1, y0)) +
         ty * ((1 - tx) * at(x0, y0 + 1) + tx * at(x0 + 1, y0 + 1));
}

}  // namespace lensim::optics
