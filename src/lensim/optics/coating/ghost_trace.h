// Exact tracing of a two-reflection ghost path with the lens's own tracer.
//
// The ghost that reflects first at surface `first` (going back toward the scene) and then at
// surface `second` < `first` meets the surfaces 0 .. first, first - 1 .. second, second + 1 .. N-1
// in that order. Written out as a sequence of interfaces (the two reflecting surfaces as
// mirrors, the surfaces between them with their media swapped for the backward pass), it is an
// ordinary lens with two mirrors, which LensTracer traces exactly: the same intersection,
// clipping, refraction and reflection code as every other trace.
#pragma once

#include <optional>
#include <vector>

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

/// Where a ray that left the ghost path crosses the axis (lens space z, mm), from its meridional
/// height and slope; nullopt when it leaves parallel to the axis.
std::optional<double> axisCrossingZ(const Ray& out);

}  // namespace lensim::optics
