// Exit-pupil sampling for a realistic camera: bounds of the region of the rear-vertex plane
// through which light reaches each film point, so that camera rays are aimed only where they can
// get through the lens.
//
// The region is found at film radii r_0 = 0 < r_1 < ... < r_n = film radius: from a point inside
// it (the real chief ray's crossing), rays are searched to its boundary along fixed directions,
// giving a star-shaped polygon. Between two radii the polygon's centre and vertex distances are
// interpolated linearly. Each node's polygon is checked against boundary points at the half-way
// directions, and each interval's interpolated polygon against the true boundary half-way
// between the radii; where the region changes fast (near the edge of the image circle) the
// interval is split, and wherever the true boundary reaches beyond an edge of the polygon, that
// edge's vertices are moved out until it contains it; then all by a small safety margin. Film
// points off the x axis use the bound rotated about the axis (the lens is rotationally symmetric;
// for anamorphic lenses see ExitPupilOptions::rotational).
// Sampling is uniform in the polygon, so a camera's estimator weight uses its area.
//
// A boundary point is found on the ray's margin (its largest ratio of hit radius to clear
// semi-aperture over the surfaces, with sin of the refracted angle where total internal
// reflection can occur): it varies continuously, is <= 1 exactly where the ray gets through, and
// its secant steps find a boundary in two or three traces (bisection took ~9); a region's sliver
// near the edge of the image circle is found by pattern searches on it (a 96x96 grid before).
// A dispersive lens gets bounds per wavelength band (ExitPupilOptions::bands) sharing the
// lens's own structure; a band lens's vertex distance is predicted from those already found at
// the node (linearly in 1/lambda^2) and a search from a good guess (that, or a checked polygon's
// edge) ends at a blocked point the margin puts within 0.1-0.2% past the boundary: about two
// traces a vertex. A blocked point still bounds the (star-shaped) region, so that only the
// overshoot, not containment, depends on the guess.
// A polygon's searches (one per direction, each a small state machine) run side by side and
// their rays are traced in batches (LensTracer::marginSquaredBatch, vectorised across the rays
// for spherical surfaces, quadrics, toroids and aspheres on a quadric base), which hides the
// latency of each trace's chain of square roots and divisions: about 3x cheaper a trace than one at
// a time.
//
// Measured (tests/optics_pupil_test.cpp and a 2-million-ray check): no passing ray outside the
// bounds for the double Gauss, wide-angle and telephoto; for the fisheye one in two million,
// at a sharp corner of the region near the edge of its image circle, where a polygon vertex
// cannot follow the corner exactly. 2-3% of the samples yield no ray.
// Lenses with central obscurations (catadioptric lenses): the polygon is the outer boundary of
// the region (obscurations ignored), and a hole is cut out of it: a second star-shaped polygon
// about the same centre, each vertex the first passing point along its direction (found with
// real rays at both ends and the middle of each radial interval, interpolated like the outer
// one, pulled in by the safety margin and checked with real rays in between). Off axis the
// secondary's shadow moves off the outer region's centre; a scaled copy of the outer polygon
// (the former hole) had to shrink to its nearest side and wasted 13% of the Cassegrain's samples.
#pragma once

#include <optional>
#include <vector>

#include "lensim/optics/lens_system.h"
#include "lensim/optics/paraxial.h"

namespace lensim::optics {

struct ExitPupilOptions {
  int radial_bins = 24;  ///< intervals across the film radius (before refinement)
  int directions = 48;   ///< polygon vertices
  double margin = 0.01;  ///< relative widening beyond the traced boundary
  /// If > 0, only rear-plane points within this distance of the axis count as passing: the
  /// bounds then cover the part of the region inside that disc (for a camera that aims only at
  /// the rear element's disc, as the CS348B assignment's did).
  double rear_disc_radius_mm = 0;
  /// false for lenses that are not rotationally symmetric (anamorphic, symmetric under x -> -x
  /// and y -> -y): film points are mirrored into the first quadrant, which is cut into `sectors`
  /// wedges. A bound of its own is built along each wedge edge (film azimuth k 90 / sectors
  /// degrees, k = 0 .. sectors), for the region of each film point on it moved (not rotated) so
  /// that its paraxial chief-ray crossing (x and y exit pupils apart) lies on the +x axis. A film
  /// point inside a wedge uses the polygon blended linearly by azimuth between the two edges'
  /// (centre and vertex distances), widened where checks of the true region at the wedge's middle
  /// azimuth (at every node and interval middle of both edges) reach beyond it; sampling moves the
  /// bound back to the film point's azimuth without rotating it and mirrors it back (a 2-D bound:
  /// an anamorphic lens's elliptical exit pupil keeps its orientation). (Before: each wedge's
  /// bound was the union of its edges' regions, which wasted 13.8% of lentil:2004's samples.)
  bool rotational = true;
  int sectors = 4;  ///< anamorphic: wedges of the first quadrant
  /// Anamorphic: the film's rectangle where points are sampled, half width and half height (mm,
  /// centred on the axis; 0: a disc of the film radius). The bound along each wedge edge then
  /// reaches only as far as the rectangle does at the azimuths of its two wedges, and each
  /// wedge's checks as far as it does across that wedge: on a wide film the short side's wedges
  /// stop short of the film radius, and with them often the costliest part of the build, the
  /// region's vanishing edge beyond the image circle.
  Vec2 film_half_extent_mm{0, 0};
  /// The same lens at other wavelengths (a dispersive lens at the ends of the spectrum): a
  /// rear-plane point counts as passing if it passes through any of them too, so that the bound
  /// holds the region of every wavelength without a wide blanket margin. Traced only where the
  /// lens itself blocks the ray.
  std::vector<const LensSystem*> also_cover;
  /// Wavelength bands: for each, the lenses (the lens at other wavelengths) whose regions that
  /// band's bound must hold. The bounds share the lens's own structure (its film radii, polygon
  /// centres and the widening its checks found) and re-solve only each polygon's vertex
  /// distances, as the farthest of the band's lenses' boundaries: a few traces per vertex
  /// instead of a build of their own. Where a band's lens sees nothing about a node's centre
  /// (near the edge of the image circle, which moves with the wavelength), that lens's polygon is
  /// traced on its own once per node, or found empty, and shared by the two bands it bounds.
  /// sample(..., band) etc. use them.
  std::vector<std::vector<const LensSystem*>> bands;
};

/// A point to aim a camera ray at, and the area of the region it was drawn from (pdf = 1/area).
struct PupilSample {
  Vec3 rear_point_mm;  ///< on the plane of the rear vertex, lens space
  double area_mm2 = 0;
};

class ExitPupilSampler {
 public:
  /// Builds the bounds for film points up to `film_radius_mm` from the axis.
  ExitPupilSampler(const LensSystem& lens, const ParaxialData& p, double film_radius_mm,
                   const ExitPupilOptions& opts = {});

  /// A uniformly distributed point of the bound for the film point, from u in [0,1)^2; nullopt
  /// where the film point sees nothing (outside the image circle).
  /// band: an index into ExitPupilOptions::bands, or -1 for the lens's own bound.
  std::optional<PupilSample> sample(Vec2 film_mm, Vec2 u, int band = -1) const;
  /// The most film points sampleBatch takes at once.
  static constexpr int kBatch = 16;
  /// sample() for n <= kBatch film points, the same results; the binary searches of the points
  /// run side by side, so that their chains of dependent loads overlap.
  void sampleBatch(const Vec2* film_mm, const Vec2* u, int n, std::optional<PupilSample>* out,
                   int band = -1) const;

  /// Whether the bound for the film point contains the rear-plane point.
  bool contains(Vec2 film_mm, Vec2 rear_mm, int band = -1) const;

  /// The area of the bound for the film point (0 where it sees nothing).
  double area_mm2(Vec2 film_mm, int band = -1) const;
  /// The number of wavelength bands (ExitPupilOptions::bands).
  int bands() const { return static_cast<int>(sets_.size()) - 1; }

  double buildSeconds() const { return build_seconds_; }
  long tracesAtBuild() const { return traces_; }
  /// Intervals of film radius after adaptive refinement.
  int intervals() const { return static_cast<int>(intervals_.size()); }
  /// false for the 2-D bounds of a lens that is not rotationally symmetric.
  bool rotationallySymmetric() const { return rotational_; }

 private:
  // A star-shaped polygon in the frame of a film point on the +x axis: vertices
  // centre + radius[j] (cos 2 pi j / n, sin 2 pi j / n).
  struct Polygon {
    double r = 0;  // film radius of a node
    bool empty = true;
    Vec2 centre;
    std::vector<double> radius;
    std::vector<double> raw, node_f;  // vertex distances before the node's check, its factors
  };
  // The unscaled polygon interpolated between two nodes at radius r (used while building).
  bool interpolateBetween(const Polygon& a, const Polygon& b, double r, Polygon& poly) const;
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
  static int intervalIn(const std::vector<Interval>& intervals, const std::vector<int>& radius_lut,
                        double lut_scale, double r);
  std::vector<Interval> buildIntervals(const std::vector<Polygon>& nodes,
                                       const std::vector<std::vector<double>>& scales) const;
  // Anamorphic: the polygon of bound set `set` for film radius r in wedge `wedge`, blended at
  // s in [0, 1] across it (centre c, vertex distances R[0 .. directions_)); false where it sees
  // nothing.
  bool blended(int set, int wedge, double r, double s, Vec2& c, double* R) const;
  // Anamorphic: the wedge, blend weight and film radius of a film point (any quadrant).
  void wedgeOf(Vec2 film_mm, int& wedge, double& s, double& r) const;
  std::optional<PupilSample> sampleAnamorphic(Vec2 film_mm, Vec2 u, int set) const;
  // Anamorphic: per wedge, the film radii of its checks and the widening factors per vertex
  // they found (a film radius between two uses the larger of theirs).
  struct WedgeCheck {
    std::vector<double> r;
    std::vector<std::vector<double>> f;
  };
  std::vector<WedgeCheck> wedges_;
  // The interval, t and rotation for a film point; nullptr where it sees nothing.
  const Interval* locate(Vec2 film_mm, double& t, double& cos_a, double& sin_a, int set) const;

  // Where the rear-plane point `local` of the +x frame lies for a film point at distance r and
  // azimuth (ca, sa): rotated (symmetric lenses) or moved by the chief-ray model (anamorphic).
  Vec2 toFilmAzimuth(Vec2 local, double r, double ca, double sa) const {
    if (rotational_) return {ca * local.x - sa * local.y, sa * local.x + ca * local.y};
    return {local.x + (kappa_x_ * ca - kappa_x_) * r, local.y + kappa_y_ * sa * r};
  }

  double film_radius_mm_;
  bool rotational_ = true;
  // Rear-plane chief-ray crossing per mm of film x and y (paraxial, each section's exit pupil).
  double kappa_x_ = 0, kappa_y_ = 0;
  double z_rear_mm_;
  int directions_;
  std::vector<Vec2> dirs_;  // unit vectors of the polygon directions
  std::vector<Interval> intervals_;
  std::vector<int> radius_lut_;  // first interval for film radii k / lut_scale_
  double lut_scale_ = 0;
  // The bounds: one set for rotationally symmetric lenses; one per wedge of the first quadrant
  // for anamorphic ones (film points elsewhere are mirrored into it).
  struct Sector {
    std::vector<Interval> intervals;
    std::vector<int> lut;
    double lut_scale = 0;
  };
  // sets_[0]: the lens's own bounds; sets_[1 + b]: wavelength band b's.
  std::vector<std::vector<Sector>> sets_;
  double build_seconds_ = 0;
  long traces_ = 0;
};

}  // namespace lensim::optics
