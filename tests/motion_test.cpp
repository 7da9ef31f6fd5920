// Motion blur (issue 12): pbrt-v4's AnimatedTransform against closed forms, and renders of a
// moving square against the box-filtered smear its motion predicts.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>
#include <sstream>

#include "lensim/camera/camera.h"
#include "lensim/camera/realistic.h"
#include "lensim/optics/paraxial.h"
#include "lensim/util/animated_transform.h"
#include "render_test_util.h"
#include "test_paths.h"

namespace lensim {
namespace {

double maxDiff(const Transform& a, const Transform& b) {
  double d = 0;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) d = std::max(d, std::abs(a(i, j) - b(i, j)));
  return d;
}

// ---- AnimatedTransform ----------------------------------------------------------------------

TEST(AnimatedTransform, TranslationIsLinearAndClampedOutsideItsTimes) {
  const AnimatedTransform m(Transform::translate({1, 0, 0}), 2, Transform::translate({3, -4, 8}),
                            6);
  ASSERT_TRUE(m.isAnimated());
  for (double s : {0.0, 0.1, 0.25, 0.5, 0.9, 1.0}) {
    const Vec3 expected = Vec3{1, 0, 0} * (1 - s) + Vec3{3, -4, 8} * s;
    EXPECT_LT(maxDiff(m.interpolate(2 + 4 * s), Transform::translate(expected)), 1e-14) << s;
  }
  EXPECT_EQ(m.interpolate(-5), m.start());
  EXPECT_EQ(m.interpolate(7), m.end());
  EXPECT_FALSE(AnimatedTransform(m.start(), 0, m.start(), 1).isAnimated());
}

// A rotation by theta about an axis turns at a constant rate: theta t at fraction t (slerp),
// which a linear interpolation of the matrices would not give (it shrinks the object midway).
TEST(AnimatedTransform, RotationTurnsAtAConstantRateAboutItsAxis) {
  const Vec3 axis = normalize(Vec3{1, 2, -0.5});
  for (double theta : {10.0, 90.0, 170.0}) {
    const AnimatedTransform m(Transform(), 0, Transform::rotate(theta, axis), 1);
    for (double t : {0.1, 0.3, 0.5, 0.77}) {
      EXPECT_LT(maxDiff(m.interpolate(t), Transform::rotate(theta * t, axis)), 1e-12)
          << theta << " " << t;
    }
    // The midpoint matrix is a rotation (orthonormal), unlike the average of the matrices.
    const Transform mid = m.interpolate(0.5);
    const Vec3 v = mid.applyVector({1, 0, 0});
    EXPECT_NEAR(length(v), 1, 1e-12);
  }
  // More than half a turn goes the shorter way round (pbrt-v4 flips the end quaternion): 270
  // degrees about z is -90 degrees.
  const AnimatedTransform far(Transform(), 0, Transform::rotate(270, {0, 0, 1}), 1);
  EXPECT_LT(maxDiff(far.interpolate(0.5), Transform::rotate(-45, {0, 0, 1})), 1e-12);
}

TEST(AnimatedTransform, ScaleIsInterpolatedLinearly) {
  const AnimatedTransform m(Transform::scale(1, 1, 1), 0, Transform::scale(3, 2, 0.5), 1);
  for (double t : {0.2, 0.5, 0.8})
    EXPECT_LT(maxDiff(m.interpolate(t), Transform::scale(1 + 2 * t, 1 + t, 1 - 0.5 * t)), 1e-12)
        << t;
}

// M = T R S with S symmetric positive definite (a stretch along tilted axes): the polar
// decomposition recovers T, R (as a quaternion, up to sign) and S.
TEST(AnimatedTransform, DecompositionRecoversTheParts) {
  const Transform Q = Transform::rotate(30, normalize(Vec3{0, 1, 1}));
  const Transform S = Q * Transform::scale(2, 3, 0.5) * inverse(Q);
  const Transform R = Transform::rotate(65, normalize(Vec3{-1, 0.5, 2}));
  const Vec3 T{4, -1, 0.25};
  const Decomposition d = decompose(Transform::translate(T) * R * S);
  EXPECT_LT(length(d.translation - T), 1e-12);
  EXPECT_LT(maxDiff(rotationTransform(d.rotation), R), 1e-10);
  EXPECT_LT(maxDiff(Transform(d.scale), S), 1e-10);
  // The quaternion of a rotation by a about n is (n sin(a/2), cos(a/2)).
  const Quaternion q = quaternionFromMatrix(Transform::rotate(65, {0, 0, 1}).matrix());
  EXPECT_NEAR(q.w, std::cos(65 * M_PI / 360), 1e-14);
  EXPECT_NEAR(q.v.z, std::sin(65 * M_PI / 360), 1e-14);
}

// Translation and rotation together: a point follows T(t) + R(theta t) S(t) p, the closed form of
// the decomposed interpolation (here S = 1).
TEST(AnimatedTransform, RotatingAndMovingPointFollowsTheClosedForm) {
  const Vec3 axis{0, 0, 1}, p{1, 0.5, 2};
  const AnimatedTransform m(Transform::translate({0, 0, 0}), 0,
                            Transform::translate({2, 0, 0}) * Transform::rotate(120, axis), 1);
  for (double t : {0.0, 0.2, 0.6, 1.0}) {
    const Vec3 expected = Vec3{2 * t, 0, 0} + Transform::rotate(120 * t, axis).applyPoint(p);
    EXPECT_LT(length(m.interpolate(t).applyPoint(p) - expected), 1e-12) << t;
  }
}

// The motion bound contains the moving box at every time, and is close to the exact bound.
TEST(AnimatedTransform, MotionBoundsContainTheMovingBox) {
  Bounds3 box;
  box.extend({1, 0, 0});
  box.extend({2, 0.1, 0.3});
  const AnimatedTransform m(Transform(), 0,
                            Transform::translate({0.5, 0, 1}) *
                                Transform::rotate(90, normalize(Vec3{0.2, 0.1, 1})) *
                                Transform::scale(1.5, 1, 1),
                            1);
  const Bounds3 b = m.motionBounds(box, 0, 1);
  Bounds3 exact;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0, 1);
  for (int k = 0; k <= 20000; ++k) {
    const double t = k / 20000.0;
    for (int c = 0; c < 8; ++c) {
      const Vec3 x{(c & 1) ? box.max.x : box.min.x, (c & 2) ? box.max.y : box.min.y,
                   (c & 4) ? box.max.z : box.min.z};
      exact.extend(m.interpolate(t).applyPoint(x));
    }
    const Vec3 x{1 + u(rng), 0.1 * u(rng), 0.3 * u(rng)};
    const Vec3 p = m.interpolate(u(rng)).applyPoint(x);
    ASSERT_TRUE(p.x >= b.min.x && p.y >= b.min.y && p.z >= b.min.z && p.x <= b.max.x &&
                p.y <= b.max.y && p.z <= b.max.z);
  }
  // The documented slack: at most 4 sin(0.125 deg) = 0.87% of the largest distance |S x| of a
  // corner from the pivot (here |(3, 0.1, 0.3)| = 3.02), on each side.
  const double slack = 4 * std::sin(0.125 * M_PI / 180) * length(Vec3{3, 0.1, 0.3});
  for (int a = 0; a < 3; ++a) {
    EXPECT_LE(b.min[a], exact.min[a] + 1e-12);
    EXPECT_GE(b.max[a], exact.max[a] - 1e-12);
    EXPECT_LT(exact.min[a] - b.min[a], slack * 1.001);
    EXPECT_LT(b.max[a] - exact.max[a], slack * 1.001);
  }
  // Only part of the motion falls in [0.25, 0.5]: a smaller box.
  const Bounds3 part = m.motionBounds(box, 0.25, 0.5);
  EXPECT_LT(part.max.x - part.min.x, b.max.x - b.min.x);
}

// ---- renders of a moving square -------------------------------------------------------------

// The scene: a camera at the origin looking down +z (perspective, fov 90, 32 x 8 pixels, so the
// screen window is [-4, 4] x [-1, 1]), a grey diffuse square in the plane z = kDepth lit by a
// distant light along the view axis (constant spectra: every camera ray that hits the square
// returns the same radiance K, up to the wavelength sampling's noise; misses return 0), box
// pixel filter and independent samples. The square spans x in [kX0, kX1], y in [kY0, kY1] at
// time 0 and moves by kTravel along x until time 1.
constexpr double kDepth = 2, kX0 = -2.3, kX1 = -1.1, kY0 = -0.7, kY1 = 0.6, kTravel = 2.5;
constexpr int kW = 32, kH = 8;

struct SquareScene {
  double shutter_open = 0, shutter_close = 1;
  double object_travel = kTravel;  ///< the square's motion (ActiveTransform EndTime)
  double camera_travel = 0;        ///< the camera's motion along x
  double static_offset = 0;        ///< a plain Translate of the square (no motion)
  bool big = false;                ///< a square filling the frame (calibration)
  /// 0: a plain shape; 1: an ObjectInstance of the square moves; 2: the square moves inside its
  /// object definition, instanced still.
  int instancing = 0;
  int spp = 256;
  std::string text() const {
    std::ostringstream f;
    f << "LookAt 0 0 0  0 0 1  0 1 0\n";
    // Moving the camera by c moves camera_from_world's end by Translate(-c) applied last.
    if (camera_travel != 0)
      f << "ActiveTransform EndTime\nTranslate " << -camera_travel << " 0 0\nActiveTransform All\n";
    f << "Camera \"perspective\" \"float fov\" [90] \"float shutteropen\" [" << shutter_open
      << "] \"float shutterclose\" [" << shutter_close << "]\n"
      << "Film \"rgb\" \"integer xresolution\" [" << kW << "] \"integer yresolution\" [" << kH
      << "] \"string filename\" [\"motion.exr\"]\n"
      << "Sampler \"independent\" \"integer pixelsamples\" [" << spp << "]\n"
      << "PixelFilter \"box\"\nIntegrator \"path\" \"integer maxdepth\" [1]\n"
      << "WorldBegin\n"
      << "LightSource \"distant\" \"point3 from\" [0 0 0] \"point3 to\" [0 0 1] "
         "\"spectrum L\" [300 2 800 2]\n"
      << "Material \"diffuse\" \"spectrum reflectance\" [300 0.5 800 0.5]\n";
    const double x0 = big ? -20 : kX0, x1 = big ? 20 : kX1, y0 = big ? -5 : kY0, y1 = big ? 5 : kY1;
    std::ostringstream shape;
    shape << "Shape \"bilinearmesh\" \"point3 P\" [" << x0 << " " << y0 << " " << kDepth << " "
          << x1 << " " << y0 << " " << kDepth << " " << x0 << " " << y1 << " " << kDepth << " "
          << x1 << " " << y1 << " " << kDepth << "]\n";
    std::ostringstream motion;
    if (static_offset != 0) motion << "Translate " << static_offset << " 0 0\n";
    if (object_travel != 0)
      motion << "ActiveTransform EndTime\nTranslate " << object_travel
             << " 0 0\nActiveTransform All\n";
    if (instancing == 0)
      f << "AttributeBegin\n" << motion.str() << shape.str() << "AttributeEnd\n";
    else if (instancing == 1)
      f << "ObjectBegin \"square\"\n"
        << shape.str() << "ObjectEnd\nAttributeBegin\n"
        << motion.str() << "ObjectInstance \"square\"\nAttributeEnd\n";
    else
      f << "ObjectBegin \"square\"\n"
        << motion.str() << shape.str() << "ObjectEnd\nObjectInstance \"square\"\n";
    return f.str();
  }
};

io::Image renderSquare(const SquareScene& s, int seed = 1) {
  render::RenderOptions o;
  o.seed = seed;
  o.threads = 2;
  return testutil::renderText(s.text(), o).image;
}

double overlap(double a0, double a1, double b0, double b1) {
  return std::max(0.0, std::min(a1, b1) - std::max(a0, b0));
}

/// The share of pixel (i, j) and of the shutter [0, 1] during which the square covers it: the
/// box-filtered smear. Its x extent at time t is [kX0 + travel t, kX1 + travel t] (+ offset); on
/// the plane z = kDepth a pixel spans kDepth times its screen window.
double coverage(int i, int j, double travel, double offset = 0) {
  const double px0 = kDepth * (-4 + 8.0 * i / kW), px1 = kDepth * (-4 + 8.0 * (i + 1) / kW);
  const double py1 = kDepth * (1 - 2.0 * j / kH), py0 = kDepth * (1 - 2.0 * (j + 1) / kH);
  const double cy = overlap(kY0, kY1, py0, py1) / (py1 - py0);
  // The time average of the x overlap (piecewise linear in t): midpoint rule, 20000 steps.
  const int n = 20000;
  double cx = 0;
  for (int k = 0; k < n; ++k) {
    const double t = (k + 0.5) / n, d = offset + travel * t;
    cx += overlap(kX0 + d, kX1 + d, px0, px1);
  }
  cx /= n * (px1 - px0);
  return cx * cy;
}

/// The radiance K of a covered sample and the relative variance v of one sample's estimate of
/// it (the wavelength sampling's noise), from a static square that fills the frame.
struct Calibration {
  double K = 0, v = 0;
};
Calibration calibrate() {
  SquareScene s;
  s.big = true;
  s.object_travel = 0;
  const io::Image im = renderSquare(s, 7);
  double sum = 0, sum2 = 0;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) sum += im.at(x, y, 1), sum2 += im.at(x, y, 1) * im.at(x, y, 1);
  const double n = kW * kH, mean = sum / n, var = sum2 / n - mean * mean;
  return {mean, std::max(0.0, var) * s.spp / (mean * mean)};
}

/// Largest |z| of the pixels of `im` (green) against the expected coverage p: a pixel's estimate
/// is the mean of spp samples each K W B (B ~ Bernoulli(p) the coverage, W the spectral weight of
/// mean 1 and relative variance v), of variance K^2 (p (1 + v) - p^2) / spp.
double maxZ(const io::Image& im, const Calibration& c, int spp,
            const std::function<double(int, int)>& p_of) {
  double worst = 0;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      const double p = p_of(x, y);
      const double sd = c.K * std::sqrt(std::max(p * (1 + c.v) - p * p, 0.0) / spp);
      const double diff = im.at(x, y, 1) - c.K * p;
      worst = std::max(worst, sd > 0 ? std::abs(diff) / sd : std::abs(diff) / (1e-9 * c.K));
    }
  return worst;
}

TEST(MotionBlur, MovingSquareIsTheBoxFilteredSmear) {
  const Calibration c = calibrate();
  ASSERT_GT(c.K, 0);
  SquareScene s;
  const io::Image im = renderSquare(s);
  const double z = maxZ(im, c, s.spp, [](int x, int y) { return coverage(x, y, kTravel); });
  std::printf(
      "moving square: K %.4g, spectral relative variance %.3g, worst |z| %.2f over %d "
      "pixels\n",
      c.K, c.v, z, kW * kH);
  EXPECT_LT(z, 4.5);
  // The test can tell: the square held at its start position is far off.
  EXPECT_GT(maxZ(im, c, s.spp, [](int x, int y) { return coverage(x, y, 0); }), 20);
}

// The same through object instancing: a moving ObjectInstance, and a moving shape inside an
// object definition instanced still.
TEST(MotionBlur, MovingInstancesAreSmearedAlike) {
  const Calibration c = calibrate();
  for (int instancing : {1, 2}) {
    SquareScene s;
    s.instancing = instancing;
    const double z =
        maxZ(renderSquare(s, 3), c, s.spp, [](int x, int y) { return coverage(x, y, kTravel); });
    EXPECT_LT(z, 4.5) << "instancing " << instancing;
  }
}

// A bar turning 90 degrees about the view axis over the shutter: each pixel's coverage is the
// share of its area and of the shutter during which the bar, turned by 90 t degrees (a constant
// rate), covers it; expected from an independent Monte Carlo of that geometry (2e4 points per
// pixel), compared per 4 x 4 block. Interpolating the matrices instead (pbrt's decomposition not
// used) would shrink the bar midway by cos 45 degrees: that model is rejected.
TEST(MotionBlur, TurningBarFollowsTheDecomposedRotation) {
  constexpr int N = 24;
  constexpr double a = 0.8, b = 0.12, depth = 2;  // bar half-length, half-width; plane z = 2
  std::ostringstream f;
  f << "LookAt 0 0 0  0 0 1  0 1 0\nCamera \"perspective\" \"float fov\" [60]\n"
    << "Film \"rgb\" \"integer xresolution\" [" << N << "] \"integer yresolution\" [" << N
    << "] \"string filename\" [\"bar.exr\"]\n"
    << "Sampler \"independent\" \"integer pixelsamples\" [256]\n"
    << "PixelFilter \"box\"\nIntegrator \"path\" \"integer maxdepth\" [1]\nWorldBegin\n"
    << "LightSource \"distant\" \"point3 from\" [0 0 0] \"point3 to\" [0 0 1] "
       "\"spectrum L\" [300 2 800 2]\n"
    << "Material \"diffuse\" \"spectrum reflectance\" [300 0.5 800 0.5]\n"
    << "ActiveTransform EndTime\nRotate 90 0 0 1\nActiveTransform All\n"
    << "Shape \"bilinearmesh\" \"point3 P\" [" << -a << " " << -b << " " << depth << " " << a << " "
    << -b << " " << depth << " " << -a << " " << b << " " << depth << " " << a << " " << b << " "
    << depth << "]\n";
  render::RenderOptions o;
  o.seed = 4;
  o.threads = 2;
  const io::Image im = testutil::renderText(f.str(), o).image;
  const Calibration c = calibrate();
  // Pixel (i, j) spans screen [-t + 2t i / N, ...] (x) and [t - 2t (j + 1) / N, ...] (y),
  // t = tan 30 degrees; world = screen x depth.
  const double tn = std::tan(M_PI / 6);
  std::mt19937_64 rng(99);
  std::uniform_real_distribution<double> u(0, 1);
  // Per pixel: the render and the two models' coverage; then a z-test per 4 x 4 block (4096
  // samples), over the blocks where at least 20 samples are expected on the bar (the normal
  // approximation of the count holds there).
  std::vector<double> p_rot(N * N), p_lerp(N * N);
  constexpr int M = 20000;
  for (int j = 0; j < N; ++j)
    for (int i = 0; i < N; ++i) {
      int in_rot = 0, in_lerp = 0;
      for (int k = 0; k < M; ++k) {
        const double x = depth * tn * (-1 + 2 * (i + u(rng)) / N);
        const double y = depth * tn * (1 - 2 * (j + u(rng)) / N);
        const double th = 0.5 * M_PI * u(rng), s = std::sin(th), co = std::cos(th);
        // Turned by th: the bar's own coordinates of (x, y).
        const double xr = x * co + y * s, yr = -x * s + y * co;
        in_rot += std::abs(xr) < a && std::abs(yr) < b;
        // Matrix lerp: M = (1 - t) I + t R(90), t = th / (pi/2); invert M (a scaled rotation).
        const double t = th / (0.5 * M_PI), m = (1 - t), det = m * m + t * t;
        const double xl = (m * x + t * y) / det, yl = (-t * x + m * y) / det;
        in_lerp += std::abs(xl) < a && std::abs(yl) < b;
      }
      p_rot[size_t(j * N + i)] = double(in_rot) / M;
      p_lerp[size_t(j * N + i)] = double(in_lerp) / M;
    }
  auto worstBlockZ = [&](const std::vector<double>& pm) {
    double worst = 0;
    for (int by = 0; by < N; by += 4)
      for (int bx = 0; bx < N; bx += 4) {
        double v = 0, e = 0, var = 0, p_sum = 0;
        for (int j = by; j < by + 4; ++j)
          for (int i = bx; i < bx + 4; ++i) {
            const double p = pm[size_t(j * N + i)];
            v += im.at(i, j, 1), e += c.K * p, p_sum += p;
            var += c.K * c.K * (std::max(p * (1 + c.v) - p * p, 0.0) / 256 + p * (1 - p) / M);
          }
        if (p_sum * 256 < 20) continue;
        worst = std::max(worst, std::abs(v - e) / std::sqrt(var));
      }
    return worst;
  };
  const double worst_slerp = worstBlockZ(p_rot), worst_lerp = worstBlockZ(p_lerp);
  std::printf("turning bar: worst |z| %.2f (decomposed rotation), %.2f (matrix lerp)\n",
              worst_slerp, worst_lerp);
  EXPECT_LT(worst_slerp, 4.5);
  EXPECT_GT(worst_lerp, 10.0);
}

// An instant shutter renders the scene as it stands at that time: exactly the static scene
// (same samples, same image), at the start and midway.
TEST(MotionBlur, InstantShutterRendersLikeTheStaticScene) {
  for (double t : {0.0, 0.5}) {
    SquareScene moving;
    moving.shutter_open = moving.shutter_close = t;
    SquareScene still;
    still.shutter_open = still.shutter_close = t;
    still.object_travel = 0;
    still.static_offset = kTravel * t;
    const io::Image a = renderSquare(moving), b = renderSquare(still);
    int differ = 0;
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x)
        for (int ch = 0; ch < 3; ++ch) differ += a.at(x, y, ch) != b.at(x, y, ch);
    EXPECT_EQ(differ, 0) << "time " << t;
  }
}

// The camera moving left by d is the square moving right by d: both match the same smear.
TEST(MotionBlur, CameraMotionEqualsOppositeObjectMotion) {
  const Calibration c = calibrate();
  SquareScene cam;
  cam.object_travel = 0;
  cam.camera_travel = -kTravel;
  const io::Image a = renderSquare(cam, 11);
  const io::Image b = renderSquare(SquareScene{}, 12);
  EXPECT_LT(maxZ(a, c, cam.spp, [](int x, int y) { return coverage(x, y, kTravel); }), 4.5);
  // Pixel by pixel, the two independent renders agree (variance of the difference: twice one's).
  double worst = 0;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      const double p = coverage(x, y, kTravel);
      const double sd = c.K * std::sqrt(2 * std::max(p * (1 + c.v) - p * p, 0.0) / cam.spp);
      const double diff = a.at(x, y, 1) - b.at(x, y, 1);
      worst = std::max(worst, sd > 0 ? std::abs(diff) / sd : std::abs(diff) / (1e-9 * c.K));
    }
  EXPECT_LT(worst, 4.5);
}

/// Centroid and variance (pixels) of the column profile (green, summed over rows) of an image.
struct Profile {
  double centroid = 0, variance = 0;
};
Profile columnProfile(const io::Image& im) {
  double s = 0, sx = 0, sxx = 0;
  for (int x = 0; x < im.width; ++x) {
    double col = 0;
    for (int y = 0; y < im.height; ++y) col += im.at(x, y, 1);
    const double c = x + 0.5;
    s += col, sx += col * c, sxx += col * c * c;
  }
  Profile p;
  p.centroid = sx / s;
  p.variance = sxx / s - p.centroid * p.centroid;
  return p;
}

// Every integrator traces the whole path at the camera sample's time (bdpt's and the light
// tracer's light subpaths included): the square, moving or seen from a moving camera, gives the
// column profile of the box-filtered smear (its centroid and spread; held still, the spread
// would be 0.7 px instead of 1.6).
TEST(MotionBlur, EveryIntegratorTracesThePathAtItsTime) {
  io::Image expected(kW, kH, {"R", "G", "B"});
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) expected.at(x, y, 1) = float(coverage(x, y, kTravel));
  const Profile e = columnProfile(expected);
  const double centre = e.centroid, variance = e.variance;
  for (const char* integrator : {"path", "volpath", "bdpt", "lighttracer"})
    for (bool camera_moves : {false, true}) {
      SCOPED_TRACE(std::string(integrator) + (camera_moves ? ", camera moves" : ", object moves"));
      SquareScene s;
      s.spp = 256;
      if (camera_moves) s.object_travel = 0, s.camera_travel = -kTravel;
      std::string text = s.text();
      const std::string from = "Integrator \"path\"";
      text.replace(text.find(from), from.size(), std::string("Integrator \"") + integrator + "\"");
      render::RenderOptions o;
      o.seed = 5;
      o.threads = 2;
      const Profile p = columnProfile(testutil::renderText(text, o).image);
      std::printf("%-11s %-14s centroid %.4f (expected %.4f), spread %.4f px (expected %.4f)\n",
                  integrator, camera_moves ? "camera moves" : "object moves", p.centroid, centre,
                  std::sqrt(p.variance), std::sqrt(variance));
      // About 4 standard deviations of the estimates at 256 spp (measured over seeds); a square
      // held still, or light paths at another time, miss by 3.5 px and by half the spread.
      EXPECT_NEAR(p.centroid, centre, 0.2);
      EXPECT_NEAR(std::sqrt(p.variance), std::sqrt(variance), 0.05 * std::sqrt(variance));
    }
}

// ---- the realistic camera -------------------------------------------------------------------

// The moving square through the double Gauss (focused on it): the image moves by the paraxial
// magnification times the square's travel. Measured on the column profile (summed over rows):
// the centroid of a render at shutter time 1 minus that at time 0 is the image travel; the
// motion-blurred render's centroid lies midway and its variance exceeds the static one's (at
// the middle time) by travel^2 / 12, the variance of the box the motion convolves with.
TEST(MotionBlur, RealisticCameraSmearFollowsTheLensMagnification) {
  constexpr int W = 64, H = 16;
  constexpr double D = 1.0, travel_m = 0.2, half = 0.03;
  // The square moves by travel_m, or stands still at its mid position while the camera moves by
  // camera_travel, centred on it (camera_from_world is Translate(-position)).
  auto sceneText = [&](double open, double close, double camera_travel = 0) {
    std::ostringstream f;
    f << "LookAt 0 0 0  0 0 1  0 1 0\n";
    if (camera_travel != 0)
      f << "Translate " << camera_travel / 2 << " 0 0\nActiveTransform EndTime\nTranslate "
        << -camera_travel << " 0 0\nActiveTransform All\n";
    f << "Camera \"realistic\" \"string lensfile\" \"" << test::lensPath("dgauss.50mm.dat")
      << "\" \"float aperturediameter\" [4] \"float focusdistance\" [" << D
      << "] \"float shutteropen\" [" << open << "] \"float shutterclose\" [" << close << "]\n"
      << "Film \"rgb\" \"integer xresolution\" [" << W << "] \"integer yresolution\" [" << H
      << "] \"string filename\" [\"motion.exr\"]\n"
      << "Sampler \"independent\" \"integer pixelsamples\" [64]\n"
      << "PixelFilter \"box\"\nIntegrator \"path\" \"integer maxdepth\" [1]\n"
      << "WorldBegin\n"
      << "LightSource \"distant\" \"point3 from\" [0 0 0] \"point3 to\" [0 0 1] "
         "\"spectrum L\" [300 2 800 2]\n"
      << "Material \"diffuse\" \"spectrum reflectance\" [300 0.5 800 0.5]\n"
      << "Translate " << (camera_travel != 0 ? 0 : -travel_m / 2) << " 0 0\n";
    if (camera_travel == 0)
      f << "ActiveTransform EndTime\nTranslate " << travel_m << " 0 0\nActiveTransform All\n";
    f << "Shape \"bilinearmesh\" \"point3 P\" [" << -half << " " << -half << " " << D << " " << half
      << " " << -half << " " << D << " " << -half << " " << half << " " << D << " " << half << " "
      << half << " " << D << "]\n";
    return f.str();
  };
  auto profile = [&](double open, double close, double camera_travel = 0) {
    return columnProfile(testutil::renderText(sceneText(open, close, camera_travel), {}).image);
  };
  // The paraxial prediction: magnification m = s' / s from the principal planes (lens space,
  // mm, +z toward the film; the object lies D in front of the film).
  scene::Scene sc = testutil::buildText(sceneText(0, 1), "realistic-motion.pbrt");
  auto cam = camera::makeRealisticCamera(sc);
  const auto& rc = dynamic_cast<const camera::RealisticCamera&>(*cam);
  const optics::LensSystem& lens = *rc.lens().lens;
  const optics::ParaxialData px = optics::computeParaxial(lens);
  const double z_obj = lens.filmZ_mm() - D * 1000;
  const double m =
      (lens.filmZ_mm() - px.principal_plane_back_z_mm) / (px.principal_plane_front_z_mm - z_obj);
  const double pitch_mm = sc.film.diagonal_mm / std::hypot(W, H);
  const double expected_px = m * travel_m * 1000 / pitch_mm;

  const Profile start = profile(0, 0), end = profile(1, 1), mid = profile(0.5, 0.5);
  const Profile blur = profile(0, 1);
  const double measured = end.centroid - start.centroid;
  const double smear = std::sqrt(12 * (blur.variance - mid.variance));
  std::printf(
      "realistic camera: magnification %.5f, predicted image travel %.3f px; measured "
      "%.3f px (centroids), %.3f px (blur variance); blurred centroid %.3f, midway %.3f\n",
      m, expected_px, measured, smear, blur.centroid, mid.centroid);
  EXPECT_NEAR(measured, expected_px, 0.03 * expected_px);
  EXPECT_NEAR(smear, expected_px, 0.06 * expected_px);
  EXPECT_NEAR(blur.centroid, mid.centroid, 0.3);
  // The camera moving the other way smears the still square alike: the time reaches the camera
  // transform (the lens itself stays in camera space).
  const Profile moving_camera = profile(0, 1, -travel_m);
  const double cam_smear = std::sqrt(12 * (moving_camera.variance - mid.variance));
  std::printf("realistic camera moving: smear %.3f px, centroid %.3f\n", cam_smear,
              moving_camera.centroid);
  EXPECT_NEAR(cam_smear, expected_px, 0.06 * expected_px);
  EXPECT_NEAR(moving_camera.centroid, mid.centroid, 0.3);
}

}  // namespace
}  // namespace lensim

namespace lensim {
namespace {

// What pbrt-v4 does not animate: lights, media and texture transforms keep the start transform
// with a warning; an area light on a moving shape is an error at the shape.
TEST(MotionScene, UnanimatedThingsAreWarnedAndAnimatedAreaLightsRefused) {
  const std::string head =
      "Camera \"perspective\"\nWorldBegin\nAttributeBegin\nActiveTransform EndTime\n"
      "Translate 1 0 0\nActiveTransform All\n";
  const scene::Scene s = testutil::buildText(
      head + "LightSource \"point\"\nTexture \"t\" \"float\" \"constant\"\nAttributeEnd\n");
  EXPECT_FALSE(s.hasErrors());
  std::string all;
  for (const auto& d : s.diagnostics) all += d.message + "\n";
  EXPECT_NE(all.find("animated lights are not supported"), std::string::npos) << all;
  EXPECT_NE(all.find("animated texture transforms are not supported"), std::string::npos) << all;
  const scene::Scene bad =
      testutil::buildText(head + "AreaLightSource \"diffuse\"\nShape \"sphere\"\nAttributeEnd\n");
  ASSERT_TRUE(bad.hasErrors());
  bool found = false;
  for (const auto& d : bad.diagnostics)
    if (d.severity == Severity::Error) {
      EXPECT_NE(d.message.find("animated area lights are not supported"), std::string::npos);
      EXPECT_EQ(d.loc.line, 8);
      found = true;
    }
  EXPECT_TRUE(found);
  // A moving shape without a light is fine, and counted in the summary.
  const scene::Scene ok = testutil::buildText(head + "Shape \"sphere\"\nAttributeEnd\n");
  EXPECT_FALSE(ok.hasErrors());
  ASSERT_EQ(ok.motions.size(), 1u);
  EXPECT_EQ(ok.shapes[0].motion, 0);
  EXPECT_NE(scene::summary(ok).find("motion blur: 1 shape and 0 instances move"),
            std::string::npos);
}

}  // namespace
}  // namespace lensim
