#include "lensim/render/textures/procedural.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace lensim::render {

namespace {

// Ken Perlin's permutation of 0..255 (his reference implementation of "Improving Noise",
// SIGGRAPH 2002; also pbrt's NoisePerm), repeated once so indices up to 511 need no wrap.
constexpr std::array<int, 256> kPerm = {
    151, 160, 137, 91,  90,  15,  131, 13,  201, 95,  96,  53,  194, 233, 7,   225, 140, 36,  103,
    30,  69,  142, 8,   99,  37,  240, 21,  10,  23,  190, 6,   148, 247, 120, 234, 75,  0,   26,
    197, 62,  94,  252, 219, 203, 117, 35,  11,  32,  57,  177, 33,  88,  237, 149, 56,  87,  174,
    20,  125, 136, 171, 168, 68,  175, 74,  165, 71,  134, 139, 48,  27,  166, 77,  146, 158, 231,
    83,  111, 229, 122, 60,  211, 133, 230, 220, 105, 92,  41,  55,  46,  245, 40,  244, 102, 143,
    54,  65,  25,  63,  161, 1,   216, 80,  73,  209, 76,  132, 187, 208, 89,  18,  169, 200, 196,
    135, 130, 116, 188, 159, 86,  164, 100, 109, 198, 173, 186, 3,   64,  52,  217, 226, 250, 124,
    123, 5,   202, 38,  147, 118, 126, 255, 82,  85,  212, 207, 206, 59,  227, 47,  16,  58,  17,
    182, 189, 28,  42,  223, 183, 170, 213, 119, 248, 152, 2,   44,  154, 163, 70,  221, 153, 101,
    155, 167, 43,  172, 9,   129, 22,  39,  253, 19,  98,  108, 110, 79,  113, 224, 232, 178, 185,
    112, 104, 218, 246, 97,  228, 251, 34,  242, 193, 238, 210, 144, 12,  191, 179, 162, 241, 81,
    51,  145, 235, 249, 14,  239, 107, 49,  192, 214, 31,  181, 199, 106, 157, 184, 84,  204, 176,
    115, 121, 50,  45,  127, 4,   150, 254, 138, 236, 205, 93,  222, 114, 67,  29,  24,  72,  243,
    141, 128, 195, 78,  66,  215, 61,  156, 180};

int perm(int i) {
  return kPerm[size_t(i & 255)];
}

// The gradient of lattice point (x, y, z) dotted with the offset (dx, dy, dz): one of 12 edge
// directions of a cube (Perlin 2002), chosen by the hashed lattice point.
double grad(int x, int y, int z, double dx, double dy, double dz) {
  const int h = perm(perm(perm(x) + y) + z) & 15;
  const double u = h < 8 || h == 12 || h == 13 ? dx : dy;
  const double v = h < 4 || h == 12 || h == 13 ? dy : dz;
  return ((h & 1) ? -u : u) + ((h & 2) ? -v : v);
}

double fade(double t) {
  return t * t * t * (t * (t * 6 - 15) + 10);
}

double lerp(double t, double a, double b) {
  return (1 - t) * a + t * b;
}

}  // namespace

double perlinNoise(double x, double y, double z) {
  // Keep the coordinates small enough for int cells (pbrt takes them modulo 2^30).
  x = std::fmod(x, double(1 << 30));
  y = std::fmod(y, double(1 << 30));
  z = std::fmod(z, double(1 << 30));
  int ix = int(std::floor(x)), iy = int(std::floor(y)), iz = int(std::floor(z));
  const double dx = x - ix, dy = y - iy, dz = z - iz;
  ix &= 255, iy &= 255, iz &= 255;
  const double w000 = grad(ix, iy, iz, dx, dy, dz);
  const double w100 = grad(ix + 1, iy, iz, dx - 1, dy, dz);
  const double w010 = grad(ix, iy + 1, iz, dx, dy - 1, dz);
  const double w110 = grad(ix + 1, iy + 1, iz, dx - 1, dy - 1, dz);
  const double w001 = grad(ix, iy, iz + 1, dx, dy, dz - 1);
  const double w101 = grad(ix + 1, iy, iz + 1, dx - 1, dy, dz - 1);
  const double w011 = grad(ix, iy + 1, iz + 1, dx, dy - 1, dz - 1);
  const double w111 = grad(ix + 1, iy + 1, iz + 1, dx - 1, dy - 1, dz - 1);
  const double wx = fade(dx), wy = fade(dy), wz = fade(dz);
  const double y0 = lerp(wy, lerp(wx, w000, w100), lerp(wx, w010, w110));
  const double y1 = lerp(wy, lerp(wx, w001, w101), lerp(wx, w011, w111));
  return lerp(wz, y0, y1);
}

double fbm(const Vec3& p, double omega, int octaves) {
  double sum = 0, lambda = 1, o = 1;
  for (int i = 0; i < octaves; ++i) {
    const Vec3 q = p * lambda;
    sum += o * perlinNoise(q.x, q.y, q.z);
    lambda *= 1.99;
    o *= omega;
  }
  return sum;
}

double turbulence(const Vec3& p, double omega, int octaves) {
  double sum = 0, lambda = 1, o = 1;
  for (int i = 0; i < octaves; ++i) {
    const Vec3 q = p * lambda;
    sum += o * std::abs(perlinNoise(q.x, q.y, q.z));
    lambda *= 1.99;
    o *= omega;
  }
  // pbrt's partial-octave term at a fractional octave count of 0: Lerp(0, 0.2, |N|) = 0.2.
  return sum + o * 0.2;
}

double windy(const Vec3& p) {
  const double strength = fbm(p * 0.1, 0.5, 3);
  const double height = fbm(p, 0.5, 6);
  return std::abs(strength) * height;
}

bool insidePolkaDot(Vec2 st) {
  const int s_cell = int(std::floor(st.x + 0.5)), t_cell = int(std::floor(st.y + 0.5));
  if (perlinNoise(s_cell + 0.5, t_cell + 0.5) > 0) {
    const double radius = 0.35, max_shift = 0.5 - radius;
    const double s_center = s_cell + max_shift * perlinNoise(s_cell + 1.5, t_cell + 2.8);
    const double t_center = t_cell + max_shift * perlinNoise(s_cell + 4.5, t_cell + 9.8);
    const double ds = st.x - s_center, dt = st.y - t_center;
    if (ds * ds + dt * dt < radius * radius) return true;
  }
  return false;
}

Vec3 marbleRgb(const Vec3& p, int octaves, double omega, double variation) {
  const double marble = p.y + variation * fbm(p, omega, octaves);
  double t = 0.5 + 0.5 * std::sin(marble);
  // pbrt's marble colour spline: cubic Bezier segments through these control points.
  static const Vec3 c[] = {{.58, .58, .6}, {.58, .58, .6}, {.58, .58, .6},
                           {.5, .5, .5},   {.6, .59, .58}, {.58, .58, .6},
                           {.58, .58, .6}, {.2, .2, .33},  {.58, .58, .6}};
  const int n_seg = 9 - 3;
  const int first = std::min(int(std::floor(t * n_seg)), n_seg - 1);
  t = t * n_seg - first;
  // De Casteljau evaluation of the segment's four control points.
  Vec3 a = c[first] * (1 - t) + c[first + 1] * t, b = c[first + 1] * (1 - t) + c[first + 2] * t,
       d = c[first + 2] * (1 - t) + c[first + 3] * t;
  a = a * (1 - t) + b * t;
  b = b * (1 - t) + d * t;
  return (a * (1 - t) + b * t) * 1.5;
}

}  // namespace lensim::render
