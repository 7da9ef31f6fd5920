// Exit-pupil sampling for a realistic camera: bounds of the region of the rear-vertex plane
// through which light reaches each film point, so that camera rays are aimed only where they can
// get through the lens. Sampling is uniform in the bound, so a camera's estimator weight uses its
// area.
//
// The bound. The region is found at film radii r_0 = 0 < r_1 < ... < r_n = film radius (nodes):
// from a point inside it (the neighbouring node's centre or the real chief ray's crossing),
// rays are searched to its boundary along fixed directions, giving a star-shaped polygon. Between
// two radii the polygon's centre and vertex distances are interpolated linearly. Film points off
// the x axis use the bound rotated about the axis; an anamorphic lens gets 2-D bounds (see
// ExitPupilOptions::rotational).
//
// The margin. A boundary point is found on the ray's margin: its largest ratio of hit radius to
// clear semi-aperture over the surfaces (with sin of the refracted angle where total internal
// reflection can occur). It varies continuously and is <= 1 exactly where the ray gets through,
// so that secant steps find a boundary in two or three traces, and a sliver of region near the
// edge of the image circle is found by a coarse grid and pattern searches on it. A search that
// ends at a blocked point still bounds the (star-shaped) region, so that a guess changes only
// the overshoot, not containment. A polygon's searches (one per direction, each a small state
// machine) run side by side and their rays are traced in batches
// (LensTracer::marginSquaredBatch).
//
// The build, in stages (optics/pupil/, declared in pupil/build.h; the pieces of each stage run
// side by side, each from a fresh Probe, so that the bound does not depend on the schedule):
//   0. nodes.cpp    the nodes at uniform film radii, each found from its neighbour and checked
//                   against boundary points at the half-way directions;
//   1. refine.cpp   each interval's interpolated polygon checked against the true boundary
//                   half-way between its nodes; split where the region changes fast (near the
//                   edge of the image circle); each edge's vertices moved out until it contains
//                   the boundary points beyond it, then all by a safety margin;
//   2. bands.cpp    a dispersive lens's wavelength bands (ExitPupilOptions::bands): the same
//                   nodes, each vertex distance re-solved from a prediction linear in
//                   1/lambda^2 (about two traces a vertex);
//   3. tables.cpp   the sampling tables: per interval the scaled vertex distances at its ends and
//                   prefix sums of the fan's areas, a table from film radius to interval, and for
//                   lenses with central obscurations a hole: a second star-shaped polygon about
//                   the same centre, each vertex the first passing point along its direction,
//                   pulled in by the safety margin and checked with real rays in between;
//   4. wedges.cpp   anamorphic lenses: each wedge's polygon blended between its edges' bounds,
//                   checked against the true region at the wedge's middle azimuth and widened.
// probe.cpp holds the margin and the boundary searches, find_inside.cpp the search for a point
// inside the region, edge_search.h one search's state machine, bound.h the finished bound's data
// and build.cpp the driver.
//
// Measured (tests/optics_pupil_test.cpp and a 2-million-ray check): no passing ray outside the
// bounds for the double Gauss, wide-angle and telephoto; for the fisheye one in two million, at
// a sharp corner of the region near the edge of its image circle, where a polygon vertex cannot
// follow the corner exactly. 2-3% of the samples yield no ray.
#pragma once

#include <optional>
#include <vector>

#include "lensim/optics/lens_system.h"
#include "lensim/optics/paraxial.h"
#include "lensim/optics/pupil/bound.h"

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
  /// an anamorphic lens's elliptical exit pupil keeps its orientation).
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
  double areaMm2(Vec2 film_mm, int band = -1) const;
  /// The number of wavelength bands (ExitPupilOptions::bands).
  int bands() const { return static_cast<int>(sets_.size()) - 1; }

  double buildSeconds() const { return build_seconds_; }
  long tracesAtBuild() const { return traces_; }
  /// Intervals of film radius after adaptive refinement.
  int intervals() const { return static_cast<int>(intervals_.size()); }
  /// false for the 2-D bounds of a lens that is not rotationally symmetric.
  bool rotationallySymmetric() const { return rotational_; }

 private:
  using Interval = pupil::Interval;
  using Sector = pupil::Sector;
  using WedgeCheck = pupil::WedgeCheck;
  // Anamorphic: the polygon of bound set `set` for film radius r in wedge `wedge`, blended at
  // s in [0, 1] across it (centre c, vertex distances R[0 .. directions_)); false where it sees
  // nothing.
  bool blended(int set, int wedge, double r, double s, Vec2& c, double* R) const;
  // Anamorphic: the wedge, blend weight and film radius of a film point (any quadrant).
  void wedgeOf(Vec2 film_mm, int& wedge, double& s, double& r) const;
  std::optional<PupilSample> sampleAnamorphic(Vec2 film_mm, Vec2 u, int set) const;
  // Anamorphic: per wedge, the checks of its blended polygon.
  std::vector<WedgeCheck> wedges_;
  // The interval, t and rotation for a film point; nullptr where it sees nothing.
  const Interval* locate(Vec2 film_mm, double& t, double& cos_a, double& sin_a, int set) const;

  // Where the rear-plane point `local` of the +x frame lies for a film point at distance r and
  // azimuth (ca, sa): rotated (symmetric lenses) or moved by the chief-ray model (anamorphic).
  Vec2 toFilmAzimuth(Vec2 local, double r, double ca, double sa) const {
    return pupil::toFilmAzimuth(rotational_, kappa_x_, kappa_y_, local, r, ca, sa);
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
  // The bounds: one sector for rotationally symmetric lenses; one per wedge edge of the first
  // quadrant for anamorphic ones (film points elsewhere are mirrored into it).
  // sets_[0]: the lens's own bounds; sets_[1 + b]: wavelength band b's.
  std::vector<std::vector<Sector>> sets_;
  double build_seconds_ = 0;
  long traces_ = 0;
};

}  // namespace lensim::optics
