// Exit-pupil bounds for the placed camera (camera/realistic_placed.h; issue 28): per region of
// the film, a box of the sampling plane (the plane of the rear surface's own frame the camera
// aims at) that holds every ray from that region's film points that gets through the lens.
// The film is not rotationally symmetric about anything here, so the bins are 2-D.
//
// Built as pbrt-v4's BoundExitPupil and the flare's per-ghost bounds are (traced grids, the
// passing points' extent, widened), with the motion across a bin interpolated rather than added:
// at each bin corner (a node) the passing region's extent is found from a grid over the disc
// that holds every ray reaching the rear surface, each grid row's and column's outermost passing
// point moved out to the boundary by bisection (the blocked end kept), the extreme row widened
// by the most it differs from its neighbours (a bound between rows for a convex region). A film
// point's box is the bilinear blend of its bin's four corners' extents, widened by 1.5 times the
// most the blend falls short of the extents found at the bin's edge middles and centre (checks).
// A dispersive lens's nodes hold the union of the extents at the rendered range's ends and the
// primary wavelength, widened by half the most an edge moves between neighbouring ones. A bin
// where some node or check sees no grid point pass keeps the whole disc.
// tests/placed_pupil_test.cpp traces 10^6 random film/plane points at 48 wavelengths and finds
// no passing ray outside the boxes.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "lensim/util/vec.h"

namespace lensim::camera {

/// A box [x0, x1] x [y0, y1] of the sampling plane (the rear surface's frame, mm).
struct PlacedBox {
  double x0 = 0, x1 = 0, y0 = 0, y1 = 0;
  double area() const { return (x1 - x0) * (y1 - y0); }
  bool holds(Vec2 q) const { return q.x >= x0 && q.x <= x1 && q.y >= y0 && q.y <= y1; }
};

class PlacedPupilBounds {
 public:
  /// Whether the ray from the film point `film` (the image surface's frame, mm) through the
  /// point `q` of the sampling plane gets through the lens at `lambda_nm`. Called from several
  /// threads at once, each call of a task at one wavelength.
  using Passes = std::function<bool(Vec2 film, Vec2 q, double lambda_nm)>;
  /// The radius of the disc (about the rear surface's axis) that holds every ray from a film
  /// point that reaches the rear surface.
  using DiscRadius = std::function<double(Vec2 film)>;

  PlacedPupilBounds() = default;
  /// Bounds for film points in [-half.x, half.x] x [-half.y, half.y] at `wavelengths_nm` (the
  /// primary wavelength first: the checks are traced at it).
  PlacedPupilBounds(Vec2 half_mm, const std::vector<double>& wavelengths_nm,
                    const DiscRadius& disc_radius, const Passes& passes);

  /// The box for the film point `film`; nullopt: the whole disc (outside the bounded film, or a
  /// bin without a bound).
  std::optional<PlacedBox> box(Vec2 film) const;
  int binsX() const { return nx_; }
  int binsY() const { return ny_; }
  /// Bins that keep the whole disc.
  int wholeBins() const;
  std::uint64_t traces() const { return traces_; }

 private:
  int nx_ = 0, ny_ = 0;
  Vec2 half_{};
  struct Bin {
    bool bounded = false;             // false: the whole disc
    std::array<double, 4> margin{};  // widening of the blend's x0, x1, y0, y1
  };
  std::vector<std::optional<PlacedBox>> nodes_;  // (nx + 1) x (ny + 1) corners, row-major
  std::vector<Bin> bins_;                        // nx x ny, row-major
  std::uint64_t traces_ = 0;
};

}  // namespace lensim::camera
