// Exit-pupil bounds for the placed camera (camera/realistic_placed.h; issue 28): per film point,
// a convex polygon of the sampling plane (the plane of the rear surface's own frame the camera
// aims at) that holds every ray from it that gets through the lens. The film is not rotationally
// symmetric about anything here, so the film is binned in 2-D.
//
// Built as pbrt-v4's BoundExitPupil and the flare's per-ghost bounds are (traced grids, the
// passing points' extent, widened), with two changes that cut the waste: the extent is taken in
// 8 directions (every 45 degrees: an octagon holds a disc with 5 % to spare, a box with 27 %),
// and the motion across a bin is interpolated rather than added. At each bin corner (a node) the
// passing region's support in each direction is found from a grid over the disc that holds
// every ray reaching the rear surface: on each grid line along the direction the outermost
// passing point is moved out to the boundary by bisection (the blocked end kept), and the
// extreme line's value is widened by the most it differs from its neighbouring lines' (for a
// convex region that bounds the boundary between lines: the tangent through the extreme line and
// its neighbour lies outside it), or by a grid step where no neighbouring line passes, and
// always by at least the bisection's final bracket (the widening alone can come out near zero
// where the boundary runs along a grid line; a passing ray was then found 0.5 um out). A film
// point's supports are the bilinear blend of its bin's four nodes', widened by 1.5 times the
// most the blend falls short of the supports found at the bin's edge middles and centre
// (checks); the polygon is the disc's square cut by the 8 half-planes. A dispersive lens's
// nodes hold the largest support over the rendered range's ends and the primary wavelength,
// widened by half the most it moves between neighbouring ones. A bin where some node or check
// sees no grid point pass (light reaches only part of it) is cut into quarters, each with its own
// nodes and checks, bounded the same way where all of them see a region; the rest keeps the
// whole disc. tests/placed_pupil_test.cpp traces 10^6 random film/plane points at 48
// wavelengths and finds no passing ray outside the polygons.
//
// The bounds know the lens only through the two functions they are given (the disc's radius
// and whether a film/plane pair passes), so the coaxial camera's tilted film (realistic.cpp,
// "Tilt and shift") uses them too: its film frame, the plane of its rear surface's extreme.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "lensim/util/vec.h"

namespace lensim::camera {

/// A convex polygon of the sampling plane (the rear surface's frame, mm), counter-clockwise.
struct PlacedPolygon {
  static constexpr int kMaxVertices = 12;
  std::array<Vec2, kMaxVertices> v{};
  int n = 0;
  double area() const;
  bool holds(Vec2 q) const;
  /// A point uniform over the polygon from u in [0,1)^2 (a fan of triangles from v[0], one
  /// chosen by area with u.x, which is then reused within it).
  Vec2 sample(Vec2 u) const;
};

/// What a film point samples on the plane: the disc of disc_radius about the axis, or the
/// polygon where it is given (PlacedPupilBounds::region: where it is the smaller).
struct PupilRegion {
  double disc_radius = 0;
  Vec2 centre{};  ///< the disc's centre (a decentred rear aperture's; the polygons' frame else)
  std::optional<PlacedPolygon> polygon;
  double area() const;
  bool holds(Vec2 q) const;
  /// A point uniform over the region from u in [0,1)^2.
  Vec2 sample(Vec2 u) const;
};

class PlacedPupilBounds {
 public:
  static constexpr int kDirections = 8;
  using Support = std::array<double, kDirections>;  // along (cos, sin) of k x 45 degrees

  /// Whether the ray from the film point `film` (the image surface's frame, mm) through the
  /// point `q` of the sampling plane gets through the lens at `lambda_nm`. Called from several
  /// threads at once.
  using Passes = std::function<bool(Vec2 film, Vec2 q, double lambda_nm)>;
  /// The radius of the disc (about the rear surface's axis) that holds every ray from a film
  /// point that reaches the rear surface.
  using DiscRadius = std::function<double(Vec2 film)>;

  PlacedPupilBounds() = default;
  /// Bounds for film points in [-half.x, half.x] x [-half.y, half.y] at `wavelengths_nm` (the
  /// primary wavelength first: the checks are traced at it).
  PlacedPupilBounds(Vec2 half_mm, const std::vector<double>& wavelengths_nm,
                    const DiscRadius& disc_radius, const Passes& passes);

  /// The polygon for the film point `film`, within the square [-r, r]^2 of its disc (radius r);
  /// nullopt: the whole disc (outside the bounded film, or a bin without a bound).
  std::optional<PlacedPolygon> polygon(Vec2 film, double r) const;
  /// The region the film point samples: its polygon where smaller than its disc (radius r).
  PupilRegion region(Vec2 film, double r) const;
  int binsX() const { return nx_; }
  int binsY() const { return ny_; }
  /// Bins without a bound of their own (light reaches only part of them, or none).
  int wholeBins() const;
  /// Of those, the bins cut into quarters (some quarters may have a bound).
  int splitBins() const;
  std::uint64_t traces() const { return traces_; }
  /// The build's tasks' times added up: its cost on one core (s).
  double taskSeconds() const { return task_seconds_; }

 private:
  struct Cell {
    bool bounded = false;  // false: the whole disc
    Support margin{};      // widening of the blended supports
  };
  struct Bin {
    Cell whole;
    bool split = false;  // not bounded as a whole: its quarters (x, then y)
    std::array<Cell, 4> quarter{};
  };
  int nx_ = 0, ny_ = 0, px_ = 0;
  Vec2 half_{};
  std::vector<std::optional<Support>> nodes_;  // on the lattice at a quarter bin's spacing
  std::vector<Bin> bins_;                      // nx x ny, row-major
  std::uint64_t traces_ = 0;
  double task_seconds_ = 0;
};

}  // namespace lensim::camera
