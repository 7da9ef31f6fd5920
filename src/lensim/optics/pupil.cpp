#include "lensim/optics/pupil.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>

#include "lensim/optics/pupil/build.h"

namespace lensim::optics {

using pupil::cross2;

ExitPupilSampler::ExitPupilSampler(const LensSystem& lens, const ParaxialData& p,
                                   double film_radius_mm, const ExitPupilOptions& opts)
    : film_radius_mm_(film_radius_mm),
      rotational_(opts.rotational),
      z_rear_mm_(lens.rearVertexZ_mm()),
      directions_(std::max(8, opts.directions)) {
  const auto t0 = std::chrono::steady_clock::now();
  pupil::Context ctx(lens, p, film_radius_mm, opts);
  dirs_ = ctx.dirs;
  kappa_x_ = ctx.kappa_x, kappa_y_ = ctx.kappa_y;
  pupil::Bounds bounds = pupil::buildBounds(ctx);
  sets_ = std::move(bounds.sets);
  wedges_ = std::move(bounds.wedges);
  traces_ = bounds.traces;
  intervals_ = sets_[0].front().intervals;
  radius_lut_ = sets_[0].front().lut;
  lut_scale_ = sets_[0].front().lut_scale;
  build_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

const ExitPupilSampler::Interval* ExitPupilSampler::locate(Vec2 film_mm, double& t, double& cos_a,
                                                           double& sin_a, int set) const {
  // Film coordinates are millimetres: no overflow for hypot to guard against.
  const double r = std::sqrt(film_mm.x * film_mm.x + film_mm.y * film_mm.y);
  if (set < 0 || set >= static_cast<int>(sets_.size())) return nullptr;
  const std::vector<Sector>& sectors = sets_[size_t(set)];
  if (r > film_radius_mm_ * (1 + 1e-9) || sectors.empty()) return nullptr;
  // Rotationally symmetric lenses only (anamorphic ones: blended()).
  const Sector* sec = &sectors.front();
  if (sec->intervals.empty()) return nullptr;
  const Interval& iv =
      sec->intervals[size_t(pupil::intervalIn(sec->intervals, sec->lut, sec->lut_scale, r))];
  if (iv.empty) return nullptr;
  t = iv.r1 > iv.r0 ? std::clamp((r - iv.r0) / (iv.r1 - iv.r0), 0.0, 1.0) : 0.0;
  const double inv_r = r > 0 ? 1 / r : 0.0;
  cos_a = r > 0 ? film_mm.x * inv_r : 1.0;
  sin_a = r > 0 ? film_mm.y * inv_r : 0.0;
  return &iv;
}

std::optional<PupilSample> ExitPupilSampler::sample(Vec2 film_mm, Vec2 u, int band) const {
  std::optional<PupilSample> out;
  sampleBatch(&film_mm, &u, 1, &out, band);
  return out;
}

void ExitPupilSampler::wedgeOf(Vec2 film_mm, int& wedge, double& s, double& r) const {
  const double fx = std::abs(film_mm.x), fy = std::abs(film_mm.y);
  r = std::sqrt(fx * fx + fy * fy);
  const int n = static_cast<int>(wedges_.size());
  const double q = std::atan2(fy, fx) / (std::numbers::pi / 2) * n;
  wedge = std::clamp(static_cast<int>(q), 0, n - 1);
  s = std::clamp(q - wedge, 0.0, 1.0);
}

bool ExitPupilSampler::blended(int set, int wedge, double r, double s, Vec2& c, double* R) const {
  if (set < 0 || set >= static_cast<int>(sets_.size())) return false;
  return pupil::blendedPolygon(sets_[size_t(set)], &wedges_[size_t(wedge)], directions_,
                               film_radius_mm_, wedge, r, s, c, R);
}

std::optional<PupilSample> ExitPupilSampler::sampleAnamorphic(Vec2 film_mm, Vec2 u, int set) const {
  const int nd = directions_;
  int wedge;
  double s, r;
  wedgeOf(film_mm, wedge, s, r);
  thread_local std::vector<double> R, P;
  R.resize(size_t(nd));
  P.resize(size_t(nd) + 1);
  Vec2 c;
  if (!blended(set, wedge, r, s, c, R.data())) return std::nullopt;
  P[0] = 0;
  for (int j = 0; j < nd; ++j)
    P[size_t(j) + 1] = P[size_t(j)] + R[size_t(j)] * R[size_t((j + 1) % nd)];
  const double total = P[size_t(nd)];
  if (!(total > 0)) return std::nullopt;
  // A fan triangle by area, then uniform in it (as sampleBatch).
  const double target = u.x * total;
  const int j = std::min(
      static_cast<int>(std::upper_bound(P.begin() + 1, P.end(), target) - (P.begin() + 1)), nd - 1);
  const int j1 = (j + 1) % nd;
  const double tri = P[size_t(j) + 1] - P[size_t(j)];
  const double ux = tri > 0 ? std::clamp((target - P[size_t(j)]) / tri, 0.0, 1.0) : 0.0;
  const Vec2 local = c + (dirs_[size_t(j)] * (R[size_t(j)] * (1 - u.y)) +
                          dirs_[size_t(j1)] * (R[size_t(j1)] * u.y)) *
                             std::sqrt(ux);
  const double fx = std::abs(film_mm.x), fy = std::abs(film_mm.y);
  const double ca = r > 0 ? fx / r : 1.0, sa = r > 0 ? fy / r : 0.0;
  Vec2 rear = toFilmAzimuth(local, r, ca, sa);
  rear = {film_mm.x < 0 ? -rear.x : rear.x, film_mm.y < 0 ? -rear.y : rear.y};
  return PupilSample{{rear.x, rear.y, z_rear_mm_}, 0.5 * total * dirs_[1].y};
}

void ExitPupilSampler::sampleBatch(const Vec2* film_mm, const Vec2* u, int n,
                                   std::optional<PupilSample>* out, int band) const {
  if (!rotational_) {
    for (int i = 0; i < std::min(n, kBatch); ++i)
      out[i] = sampleAnamorphic(film_mm[i], u[i], band + 1);
    return;
  }
  const int nd = directions_;
  const Interval* iv[kBatch];
  double t[kBatch], ca[kBatch], sa[kBatch], w0[kBatch], w1[kBatch], w2[kBatch], target[kBatch],
      total[kBatch];
  int lo[kBatch], lane[kBatch];
  int m = 0;
  auto cum = [&](int k, int j) {
    const double* P = iv[k]->P.data() + 3 * j;
    return w0[k] * P[0] + w1[k] * P[1] + w2[k] * P[2];
  };
  for (int i = 0; i < std::min(n, kBatch); ++i) {
    out[i].reset();
    const Interval* v = locate(film_mm[i], t[m], ca[m], sa[m], band + 1);
    if (!v) continue;
    iv[m] = v;
    const double tt = t[m];
    w0[m] = (1 - tt) * (1 - tt), w1[m] = tt * (1 - tt), w2[m] = tt * tt;
    total[m] = cum(m, nd);
    target[m] = u[i].x * total[m];
    lo[m] = 0;
    lane[m++] = i;
  }
  // Pick a triangle of the fan by area, reusing u.x for the position inside it: j is the first
  // triangle whose cumulative area cum(j + 1) exceeds the target (the last if none does), found
  // by a branch-free binary search over cum(1 .. nd - 1) (its comparisons are unpredictable), the
  // same number of steps for every point.
  for (int len = nd - 1; len > 1;) {
    const int half = len / 2;
    for (int k = 0; k < m; ++k)
      lo[k] = cum(k, lo[k] + half + 1) <= target[k] ? lo[k] + half : lo[k];
    len -= half;
  }
  for (int k = 0; k < m; ++k) {
    const int j = std::min(lo[k] + (cum(k, lo[k] + 1) <= target[k] ? 1 : 0), nd - 1);
    const int j1 = (j + 1) % nd;
    const double c_lo = cum(k, j), tri = cum(k, j + 1) - c_lo;
    const double ux = tri > 0 ? std::clamp((target[k] - c_lo) / tri, 0.0, 1.0) : 0.0;
    const Interval& v = *iv[k];
    const double tt = t[k];
    const Vec2 a = dirs_[j] * (v.A[j] * (1 - tt) + v.B[j] * tt);
    const Vec2 b = dirs_[j1] * (v.A[j1] * (1 - tt) + v.B[j1] * tt);
    const Vec2 centre = v.c0 * (1 - tt) + v.c1 * tt;
    const double uy = u[lane[k]].y;
    Vec2 local;
    if (!v.hasHole()) {
      // Uniform in the fan triangle (centre, a, b): the fraction of the way out, s, has s^2
      // uniform.
      local = centre + (a * (1 - uy) + b * uy) * std::sqrt(ux);
    } else {
      // Uniform in the fan triangle minus the hole's (centre, ha, hb): the quadrilateral
      // (ha, a, b, hb), split along a diagonal that lies inside it into two triangles, one picked
      // by area (reusing ux), then uniform in it.
      const Vec2 ha = dirs_[j] * (v.HA[j] * (1 - tt) + v.HB[j] * tt);
      const Vec2 hb = dirs_[j1] * (v.HA[j1] * (1 - tt) + v.HB[j1] * tt);
      Vec2 p0 = ha, p1 = a, p2 = b, q0 = ha, q1 = b, q2 = hb;
      double s1 = cross2(a - ha, b - ha), s2 = cross2(b - ha, hb - ha);
      if (s1 < 0 || s2 < 0) {  // the other diagonal
        p0 = a, p1 = b, p2 = hb, q0 = a, q1 = hb, q2 = ha;
        s1 = cross2(b - a, hb - a), s2 = cross2(hb - a, ha - a);
      }
      s1 = std::max(s1, 0.0), s2 = std::max(s2, 0.0);
      const double f1 = s1 + s2 > 0 ? s1 / (s1 + s2) : 1.0;
      double w = ux;
      if (w < f1) {
        w = f1 > 0 ? w / f1 : 0.0;
      } else {
        w = (w - f1) / (1 - f1);
        p0 = q0, p1 = q1, p2 = q2;
      }
      const double sw = std::sqrt(std::clamp(w, 0.0, 1.0));
      local = centre + p0 * (1 - sw) + (p1 * (1 - uy) + p2 * uy) * sw;
    }
    // From the +x film frame to the film point's azimuth.
    const Vec2 f = film_mm[lane[k]];
    const Vec2 rear = toFilmAzimuth(local, std::hypot(f.x, f.y), ca[k], sa[k]);
    out[lane[k]] = PupilSample{{rear.x, rear.y, z_rear_mm_}, 0.5 * total[k] * dirs_[1].y};
  }
}

bool ExitPupilSampler::contains(Vec2 film_mm, Vec2 rear_mm, int band) const {
  if (!rotational_) {
    // Into the first quadrant's frame, then relative to the blended polygon's centre.
    const int nd = directions_;
    int wedge;
    double s, r;
    wedgeOf(film_mm, wedge, s, r);
    thread_local std::vector<double> R;
    R.resize(size_t(nd));
    Vec2 c;
    if (!blended(band + 1, wedge, r, s, c, R.data())) return false;
    const double fx = std::abs(film_mm.x), fy = std::abs(film_mm.y);
    const double ca = r > 0 ? fx / r : 1.0, sa = r > 0 ? fy / r : 0.0;
    const Vec2 rq{film_mm.x < 0 ? -rear_mm.x : rear_mm.x, film_mm.y < 0 ? -rear_mm.y : rear_mm.y};
    const Vec2 q{rq.x - (kappa_x_ * ca - kappa_x_) * r - c.x, rq.y - kappa_y_ * sa * r - c.y};
    const double dphi = 2 * std::numbers::pi / nd;
    double ang = std::atan2(q.y, q.x);
    if (ang < 0) ang += 2 * std::numbers::pi;
    const int j = std::min(static_cast<int>(ang / dphi), nd - 1), j1 = (j + 1) % nd;
    const Vec2 a = dirs_[size_t(j)] * R[size_t(j)], b = dirs_[size_t(j1)] * R[size_t(j1)];
    return cross2(b - a, q - a) >= 0;
  }
  double t, ca, sa;
  const Interval* iv = locate(film_mm, t, ca, sa, band + 1);
  if (!iv) return false;
  const Vec2 centre = iv->c0 * (1 - t) + iv->c1 * t;
  // Into the +x frame, relative to the centre.
  const Vec2 q{ca * rear_mm.x + sa * rear_mm.y - centre.x,
               -sa * rear_mm.x + ca * rear_mm.y - centre.y};
  const int nd = directions_;
  const double dphi = 2 * std::numbers::pi / nd;
  double ang = std::atan2(q.y, q.x);
  if (ang < 0) ang += 2 * std::numbers::pi;
  const int j = std::min(static_cast<int>(ang / dphi), nd - 1), j1 = (j + 1) % nd;
  const Vec2 a = dirs_[j] * (iv->A[j] * (1 - t) + iv->B[j] * t);
  const Vec2 b = dirs_[j1] * (iv->A[j1] * (1 - t) + iv->B[j1] * t);
  // Inside the fan triangle (0, a, b): on the origin's side of the edge a-b; and not inside the
  // hole's triangle (0, ha, hb).
  if (iv->hasHole()) {
    const Vec2 ha = dirs_[j] * (iv->HA[j] * (1 - t) + iv->HB[j] * t);
    const Vec2 hb = dirs_[j1] * (iv->HA[j1] * (1 - t) + iv->HB[j1] * t);
    if (cross2(hb - ha, q - ha) > 0) return false;
  }
  return cross2(b - a, q - a) >= 0;
}

double ExitPupilSampler::areaMm2(Vec2 film_mm, int band) const {
  if (!rotational_) {
    const int nd = directions_;
    int wedge;
    double s, r;
    wedgeOf(film_mm, wedge, s, r);
    thread_local std::vector<double> R;
    R.resize(size_t(nd));
    Vec2 c;
    if (!blended(band + 1, wedge, r, s, c, R.data())) return 0.0;
    double total = 0;
    for (int j = 0; j < nd; ++j) total += R[size_t(j)] * R[size_t((j + 1) % nd)];
    return 0.5 * total * dirs_[1].y;
  }
  double t, ca, sa;
  const Interval* iv = locate(film_mm, t, ca, sa, band + 1);
  if (!iv) return 0.0;
  const int nd = directions_;
  const double total = (1 - t) * (1 - t) * iv->P[3 * nd] + t * (1 - t) * iv->P[3 * nd + 1] +
                       t * t * iv->P[3 * nd + 2];
  return 0.5 * total * dirs_[1].y;
}

}  // namespace lensim::optics
