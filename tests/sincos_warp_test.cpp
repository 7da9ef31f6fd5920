// The warps' sine and cosine without libm (sinCosSmall, sinCos2Pi) against long double sinl and
// cosl, and the warps that use them against their formulas evaluated in long double.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>

#include "lensim/sampling/sampling.h"

using namespace lensim;
using namespace lensim::sampling;

namespace {

constexpr long double kPiL = std::numbers::pi_v<long double>;

// |got - want| in units of the last place of want rounded to double (at least the smallest
// normal's ulp).
double ulps(double got, long double want) {
  const double w = static_cast<double>(want);
  const double ulp = std::max(std::abs(std::nextafter(w, INFINITY) - w), 0x1p-1074);
  return static_cast<double>(std::abs(static_cast<long double>(got) - want)) / ulp;
}

}  // namespace

TEST(SinCosWarp, SmallAnglesWithinTwoUlp) {
  std::mt19937_64 rng(29);
  std::uniform_real_distribution<double> angle(-std::numbers::pi / 4, std::numbers::pi / 4);
  double worst_s = 0, worst_c = 0;
  for (int i = 0; i < 200000; ++i) {
    double x = angle(rng);
    if (i < 64) x = std::ldexp(1.0, -i) * (i % 2 ? -1 : 1);  // tiny angles
    if (i == 64) x = std::numbers::pi / 4;
    if (i == 65) x = -std::numbers::pi / 4;
    if (i == 66) x = 0;
    const SinCos sc = sinCosSmall(x);
    const long double xl = x;
    worst_s = std::max(worst_s, ulps(sc.sin, std::sin(xl)));
    worst_c = std::max(worst_c, ulps(sc.cos, std::cos(xl)));
    ASSERT_LE(ulps(sc.sin, std::sin(xl)), 2.0) << x;
    ASSERT_LE(ulps(sc.cos, std::cos(xl)), 2.0) << x;
  }
  EXPECT_EQ(sinCosSmall(0.0).sin, 0.0);
  EXPECT_EQ(sinCosSmall(0.0).cos, 1.0);
  char text[64];
  std::snprintf(text, sizeof text, "sin %.3g cos %.3g", worst_s, worst_c);
  RecordProperty("worst_ulps", text);
}

TEST(SinCosWarp, FullTurnsAgainstLongDouble) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(0, 1);
  for (int i = 0; i < 200000; ++i) {
    double u = unit(rng);
    // Quarter and eighth turns and their neighbours, the ends of [0, 1), negative u.
    const double special[] = {0,      0.125, 0.25,  0.375, 0.5,  0.625, 0.75,
                              0.875,  1.0,   -0.3,  -2.71, 3.9,  kOneMinusEpsilon};
    if (i < 13) u = special[i];
    if (i >= 13 && i < 26) u = std::nextafter(special[i - 13], 2.0);
    const SinCos sc = sinCos2Pi(u);
    const long double a = 2 * kPiL * static_cast<long double>(u);
    // The product pi/2 times the reduced angle rounds once: at most about 1 ulp of the angle
    // (pi/4) added to the polynomial's 2 ulp.
    ASSERT_NEAR(sc.sin, static_cast<double>(std::sin(a)), 3.5e-16) << u;
    ASSERT_NEAR(sc.cos, static_cast<double>(std::cos(a)), 3.5e-16) << u;
  }
  // Exact at the quarter turns.
  EXPECT_EQ(sinCos2Pi(0.25).sin, 1.0);
  EXPECT_EQ(sinCos2Pi(0.25).cos, 0.0);
  EXPECT_EQ(sinCos2Pi(0.5).cos, -1.0);
  EXPECT_EQ(sinCos2Pi(0.75).sin, -1.0);
}

TEST(SinCosWarp, WarpsMatchTheirFormulas) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> unit(0, 1);
  for (int i = 0; i < 100000; ++i) {
    const Vec2 u{unit(rng), unit(rng)};
    // Shirley & Chiu's concentric map, its angle in long double (the radius and the other
    // factors are computed in double as the warps do: only the angle's cosine and sine changed).
    const long double a = 2 * u.x - 1, b = 2 * u.y - 1;
    long double r, theta;
    if (std::abs(a) > std::abs(b)) {
      r = a;
      theta = kPiL / 4 * (b / a);
    } else {
      r = b;
      theta = kPiL / 2 - kPiL / 4 * (a / b);
    }
    const Vec2 d = sampleUniformDiskConcentric(u);
    ASSERT_NEAR(d.x, static_cast<double>(r * std::cos(theta)), 5e-16) << u.x << " " << u.y;
    ASSERT_NEAR(d.y, static_cast<double>(r * std::sin(theta)), 5e-16) << u.x << " " << u.y;
    const Vec3 h = sampleCosineHemisphere(u);
    ASSERT_NEAR(h.x, d.x, 0.0);
    ASSERT_GE(h.z, 0.0);
    // Uniform sphere: z = 1 - 2 u.x, phi = 2 pi u.y.
    const Vec3 s = sampleUniformSphere(u);
    const double z = 1 - 2 * u.x;
    const long double rs = std::sqrt(std::max(0.0, 1 - z * z));
    const long double phi = 2 * kPiL * static_cast<long double>(u.y);
    ASSERT_NEAR(s.x, static_cast<double>(rs * std::cos(phi)), 5e-16);
    ASSERT_NEAR(s.y, static_cast<double>(rs * std::sin(phi)), 5e-16);
    ASSERT_EQ(s.z, 1 - 2 * u.x);
    // Uniform cone around +z of half-angle acos(0.3).
    const Vec3 c = sampleUniformCone(u, 0.3);
    const double ct = (1 - u.x) + u.x * 0.3;
    const long double st = std::sqrt(std::max(0.0, 1 - ct * ct));
    ASSERT_NEAR(c.x, static_cast<double>(st * std::cos(phi)), 5e-16);
    ASSERT_NEAR(c.y, static_cast<double>(st * std::sin(phi)), 5e-16);
    const Vec3 hs = sampleUniformHemisphere(u);
    const long double rh = std::sqrt(std::max(0.0, 1 - u.x * u.x));
    ASSERT_NEAR(hs.x, static_cast<double>(rh * std::cos(phi)), 5e-16);
    ASSERT_NEAR(hs.y, static_cast<double>(rh * std::sin(phi)), 5e-16);
  }
  const Vec2 centre = sampleUniformDiskConcentric({0.5, 0.5});
  EXPECT_EQ(centre.x, 0.0);
  EXPECT_EQ(centre.y, 0.0);
}
