// pbrt's procedural textures: Perlin noise and its sums (fbm, wrinkled = turbulence, windy),
// marble, polka dots and bilinear interpolation, as pbrt-v4 defines them (src/pbrt/util/noise.cpp
// and src/pbrt/textures.{h,cpp}; pbrt-v3 has the same definitions). lensim traces no ray
// differentials, so every octave is summed (pbrt-v4 drops the octaves finer than a pixel, which
// only changes the antialiasing).
#pragma once

#include "lensim/util/vec.h"

namespace lensim::render {

/// Ken Perlin's improved noise (gradient noise with the 6t^5 - 15t^4 + 10t^3 fade), pbrt's
/// Noise(x, y, z); y and z default to 0.5 as in pbrt. Zero at integer lattice points.
double perlinNoise(double x, double y = 0.5, double z = 0.5);
/// Sum over `octaves` octaves of omega^i Noise(1.99^i p) (pbrt's FBm with zero differentials).
double fbm(const Vec3& p, double omega, int octaves);
/// pbrt's Turbulence with zero differentials: the sum of |Noise| octaves, plus the term pbrt adds
/// for its last (partial) octave, omega^octaves * 0.2.
double turbulence(const Vec3& p, double omega, int octaves);
/// pbrt's WindyTexture: |FBm(0.1 p, 0.5, 3)| * FBm(p, 0.5, 6).
double windy(const Vec3& p);
/// pbrt's InsidePolkaDot: one dot of radius 0.35 in about half of the unit cells, jittered.
bool insidePolkaDot(Vec2 st);
/// pbrt's MarbleTexture as linear sRGB: sin of p.y + variation FBm(p) through its colour spline
/// (p already scaled by the texture's scale).
Vec3 marbleRgb(const Vec3& p, int octaves, double omega, double variation);

}  // namespace lensim::render
