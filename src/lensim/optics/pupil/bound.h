// The exit-pupil bound's data (the result of the build, read while sampling): per wedge edge and
// wavelength band, the film-radius intervals with their interpolated polygons and sampling
// tables; anamorphic lenses' wedge checks; the lookups shared by the build and the sampler.
// Part of ExitPupilSampler (optics/pupil.h); the build's stages are in optics/pupil/build.h.
#pragma once

#include <cmath>
#include <vector>

#include "lensim/util/vec.h"

namespace lensim::optics::pupil {

inline Vec2 unit(double phi) {
  return {std::cos(phi), std::sin(phi)};
}
inline double cross2(Vec2 a, Vec2 b) {
  return a.x * b.y - a.y * b.x;
}
inline double dot2(Vec2 a, Vec2 b) {
  return a.x * b.x + a.y * b.y;
}

// Sampling tables of one interval: the scaled vertex distances at its two ends (the distance
// at film radius r is A (1 - t) + B t), and prefix sums of the fan's triangle products split by
// powers of t, so that the fan's cumulative area at any t costs three multiplies.
struct Interval {
  double r0 = 0, r1 = 0;
  bool empty = true;
  Vec2 c0, c1;
  std::vector<double> A, B;  // per vertex
  std::vector<double> P;     // prefix sums P0, P1, P2 interleaved: 3 (n + 1) values
  // A lens with central obscurations: a hole, the star-shaped polygon about the same centre
  // with vertex distances HA (1 - t) + HB t, lies in the obscured (blocked) middle of the
  // region all across the interval; samples are drawn from the polygon minus the hole (each
  // fan triangle minus the hole's, a quadrilateral). Empty: no hole.
  std::vector<double> HA, HB;
  bool hasHole() const { return !HA.empty(); }
};

// The bound along one wedge edge (the only one of a rotationally symmetric lens): its intervals
// and a table from film radius to the first interval that can hold it.
struct Sector {
  std::vector<Interval> intervals;
  std::vector<int> lut;  // first interval for film radii k / lut_scale
  double lut_scale = 0;
};

// Anamorphic: per wedge, the film radii of its checks and the widening factors per vertex
// they found (a film radius between two uses the larger of theirs).
struct WedgeCheck {
  std::vector<double> r;
  std::vector<std::vector<double>> f;
};

// The index of the first interval whose upper end reaches film radius r (the last if none),
// through the table (radius_lut, lut_scale) where it is not empty.
int intervalIn(const std::vector<Interval>& intervals, const std::vector<int>& radius_lut,
               double lut_scale, double r);

// Anamorphic: the polygon for film radius r in wedge `wedge` (of the bound's wedge edges
// `lines`), blended at s in [0, 1] across it (centre c, vertex distances R[0 .. nd)), widened by
// the wedge's checks `wc` (nullptr: unwidened); false where it sees nothing.
bool blendedPolygon(const std::vector<Sector>& lines, const WedgeCheck* wc, int nd,
                    double film_radius_mm, int wedge, double r, double s, Vec2& c, double* R);

// Where the rear-plane point `local` of the +x frame lies for a film point at distance r and
// azimuth (ca, sa): rotated (rotationally symmetric lenses) or moved by the paraxial chief-ray
// model, kappa_x and kappa_y rear-plane mm per film mm (anamorphic).
inline Vec2 toFilmAzimuth(bool rotational, double kappa_x, double kappa_y, Vec2 local, double r,
                          double ca, double sa) {
  if (rotational) return {ca * local.x - sa * local.y, sa * local.x + ca * local.y};
  return {local.x + (kappa_x * ca - kappa_x) * r, local.y + kappa_y * sa * r};
}

}  // namespace lensim::optics::pupil
