// Exact tracing of a two-reflection ghost path with the lens's own tracer.
//
// The ghost that reflects first at surface `first` (going back toward the scene) and then at
// surface `second` < `first` meets the surfaces 0 .. first, first - 1 .. second, second + 1 .. N-1
// in that order. Written out as a sequence of interfaces (the two reflecting surfaces as
// mirrors, the surfaces between them with their media swapped for the backward pass), it is an
// ordinary lens with two mirrors, which LensTracer traces exactly: the same intersection,
// clipping, refraction and reflection code as every other trace.
#pragma once

#include <functional>
#include <optional>
#include <span>
#include <vector>

#include "lensim/optics/coating/lens_coatings.h"
#include "lensim/optics/lens_system.h"

namespace lensim::optics {

/// The interfaces of the ghost path (first, second) in the order the light meets them; lens
/// space as the lens's own (z toward the film; image space is not unfolded: two mirrors).
/// Throws lensim::Error naming the pair when it is not 0 <= second < first < N, when either
/// surface has no index step (the stop, a dummy surface: it reflects nothing), or when the lens
/// has mirrors (ghosts of catadioptric lenses are not modelled).
std::vector<Interface> ghostPathInterfaces(const LensSystem& lens, int first, int second);

/// The lens surface that position `index` of the ghost path (first, second) is.
int ghostPathSurface(int first, int second, int index);

/// A tracer of the ghost path: traceFromScene follows a ray from the scene through the path to
/// the film side (its result ray leaves the last surface toward +z).
LensTracer<double> ghostTracer(const LensSystem& lens, int first, int second);

/// A ghost's image on the film of a distant point light at an angle off axis, from real rays.
struct GhostSpot {
  /// Rays of the entrance grid that reached the film, and the grid's rays that met the lens.
  int rays_arrived = 0, rays_launched = 0;
  /// Centroid on the film (mm; x in the meridional plane of the light, y = 0 by symmetry).
  double centroid_x_mm = 0, centroid_y_mm = 0;
  /// RMS distance of the arriving rays from the centroid (mm).
  double rms_radius_mm = 0;
  /// Extent of the arriving rays along x and y (max - min, mm).
  double extent_x_mm = 0, extent_y_mm = 0;
};

/// Traces a square grid (grid x grid, within a disc 1.25 x the front surface's clear aperture)
/// of parallel rays of a point at infinity whose light comes in at `angle_rad` off the axis in
/// the x-z plane (direction (sin, 0, cos)) through `tracer` (ghostTracer, or the lens's own for
/// the direct image) to the film plane `film_z_mm`. `front` is the lens's first surface (where the grid
/// lies). Throws lensim::Error for a grid outside 2..2000 or an angle not within (-90, 90) deg.
GhostSpot traceSpot(const LensTracer<double>& tracer, const Interface& front, double film_z_mm,
                    double angle_rad, int grid);

/// The light a distant point at `angle_rad` off the axis brings to the film along a path, per
/// wavelength: traceSpot's grid of rays traced through the ghost path (first, second), or through
/// the lens itself when `first` < 0, each ray that reaches the film plane weighted by the
/// coatings' reflectance at the path's two reflections and transmittance at every other crossing
/// of an index step, at that ray's own angle of incidence on each surface (LensCoatings::rta:
/// Fresnel's equations or the thin-film stack at that angle), summed over the rays (so in units
/// of one grid ray's light; a ghost's over the direct path's is its intensity relative to the
/// direct image). Geometry at the lens's wavelength, the coatings' indices at each wavelength.
/// Throws as traceSpot and ghostPathInterfaces do.
/// One ray of tracedPathEnergy's grid that reached the film plane: where it crosses it (mm) and
/// its weight per wavelength (the coatings' R and T product along the path).
struct PathRay {
  double film_x_mm = 0, film_y_mm = 0;
  std::span<const double> weight;
};

/// Calls `visit` for every ray of traceSpot's grid that reaches the film plane `film_z_mm` on the
/// path (first, second) (the lens itself when `first` < 0), with its weight per wavelength as
/// tracedPathEnergy defines it (which sums these weights). Throws as tracedPathEnergy does.
void forEachPathRay(const LensSystem& lens, const LensCoatings& coatings, int first, int second,
                    double angle_rad, int grid, std::span<const double> wavelengths_nm,
                    double film_z_mm, const std::function<void(const PathRay&)>& visit);

std::vector<double> tracedPathEnergy(const LensSystem& lens, const LensCoatings& coatings,
                                     int first, int second, double angle_rad, int grid,
                                     std::span<const double> wavelengths_nm);

/// Where a ray that left the ghost path crosses the axis (lens space z, mm), from its meridional
/// height and slope; nullopt when it leaves parallel to the axis.
std::optional<double> axisCrossingZ(const Ray& out);

}  // namespace lensim::optics
