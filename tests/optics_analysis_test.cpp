// The engineer's analyses (issue 17): converged spots, the real-ray stop and f-number, the
// diffraction MTF against closed forms, PSF, ray fans and field curves against independent
// facts (paraxial focus, symmetry, published figures of an optical design library).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>

#include "lensim/optics/chief_ray.h"
#include "lensim/optics/fans.h"
#include "lensim/optics/field_curves.h"
#include "lensim/optics/mtf.h"
#include "lensim/optics/plots.h"
#include "lensim/optics/psf.h"
#include "lensim/optics/wavefront.h"
#include "optics_test_lenses.h"
#include "test_paths.h"

using namespace lensim;
using namespace lensim::optics;

namespace {

std::string shared(const std::string& name) {
  return std::string(LENSIM_SHARED_DIR) + "/lenses/" + name;
}

FocusedLens focused(const std::string& path, LensSetup setup = {}) {
  return focusLens(readLensFile(path), setup);
}

// The aberration-free MTF of a circular pupil, written out here (not the library's).
double circleMtf(double v) {
  if (v >= 1) return 0;
  return 2 / std::numbers::pi * (std::acos(v) - v * std::sqrt(1 - v * v));
}

// A synthetic pupil: radius `na` in direction cosines, n x n cells, edge coverage by 8x8
// sub-samples, wave aberration w20 rho^2 (waves).
PupilFunction syntheticPupil(int n, double na, double w20, double nm) {
  PupilFunction pf;
  pf.n = n;
  pf.step = 2.06 * na / n;
  pf.wavelength_nm = nm;
  pf.amplitude.assign(size_t(n) * n, 0);
  pf.opd_waves.assign(size_t(n) * n, 0);
  for (int iy = 0; iy < n; ++iy)
    for (int ix = 0; ix < n; ++ix) {
      int in = 0;
      for (int sy = 0; sy < 8; ++sy)
        for (int sx = 0; sx < 8; ++sx) {
          const double x = (ix - 0.5 * n + (sx + 0.5) / 8) * pf.step;
          const double y = (iy - 0.5 * n + (sy + 0.5) / 8) * pf.step;
          in += x * x + y * y <= na * na;
        }
      const double x = (ix + 0.5 - 0.5 * n) * pf.step, y = (iy + 0.5 - 0.5 * n) * pf.step;
      pf.amplitude[size_t(iy) * n + ix] = in / 64.0;
      pf.opd_waves[size_t(iy) * n + ix] = w20 * (x * x + y * y) / (na * na);
    }
  return pf;
}

// The OTF of a circular pupil with defocus W = w20 rho^2 (waves) at v = nu / cutoff, by direct
// quadrature of the overlap integral (4/pi) int_0^{1-v} sqrt(1 - (x + v)^2) cos(8 pi w20 v x) dx
// (shift s = 2v of the unit pupil; the phase difference across the overlap is 4 pi w20 s x).
double defocusOtf(double v, double w20) {
  const double a = 1 - v;
  if (a <= 0) return 0;
  const int n = 20000;
  double sum = 0;
  for (int k = 0; k < n; ++k) {
    const double x = (k + 0.5) * a / n;
    const double r = 1 - (x + v) * (x + v);
    sum += std::sqrt(std::max(0.0, r)) * std::cos(8 * std::numbers::pi * w20 * v * x);
  }
  return 4 / std::numbers::pi * sum * a / n;
}

}  // namespace

TEST(RealAperture, FNumbersAndStopsOfTheIndependentComparison) {
  // Figures of the independent comparison with an optical design library (issue 17).
  const FocusedLens dg = focused(lensim::test::lensPath("dgauss.50mm.dat"));
  EXPECT_NEAR(dg.paraxial.real_f_number, 2.018, 0.001);
  EXPECT_EQ(dg.paraxial.aperture_stop_surface, 5);  // the file's stop, 2% from the limit
  EXPECT_EQ(dg.paraxial.real_limit_surface, 2);
  const FocusedLens wide = focused(lensim::test::lensPath("wide.22mm.dat"));
  EXPECT_NEAR(wide.paraxial.real_f_number, 2.788, 0.001);
  // The real marginal ray's height is that of the traced ray that just gets through.
  EXPECT_TRUE(
      wide.lens->tracer()
          .traceFromScene({{0.999 * wide.paraxial.real_marginal_height_mm, 0, -1}, {0, 0, 1}})
          .ok());
  EXPECT_FALSE(
      wide.lens->tracer()
          .traceFromScene({{1.001 * wide.paraxial.real_marginal_height_mm, 0, -1}, {0, 0, 1}})
          .ok());
  EXPECT_EQ(wide.paraxial.real_limit_surface, 6);
  // The ISET Petzval: real rays above 17.84 mm are stopped by its stop row (f/1.40); the
  // paraxial trace would pick the front element.
  const FocusedLens pz = focused(shared("isetcam/petzval.12deg.50.0mm.dat"));
  EXPECT_EQ(pz.paraxial.aperture_stop_surface, 5);
  EXPECT_TRUE(pz.paraxial.stop_is_file_stop);
  EXPECT_NEAR(pz.paraxial.real_marginal_height_mm, 17.84, 0.01);
  EXPECT_NEAR(pz.paraxial.real_f_number, 1.40, 0.005);
  EXPECT_NEAR(pz.paraxial.real_image_space_f_number, 1.40, 0.005);
  // ... and its chief rays pass the stop: distortion -5.03% at 14.53 deg (+2.27% through the
  // front vertex).
  auto c0 = chiefRayFromScene(*pz.lens, pz.paraxial, 0.05);
  auto c = chiefRayFromScene(*pz.lens, pz.paraxial, 14.5335);
  ASSERT_TRUE(c0 && c);
  const double f = c0->film_height_mm / std::tan(0.05 * std::numbers::pi / 180);
  const double dist =
      100 * (c->film_height_mm / (f * std::tan(14.5335 * std::numbers::pi / 180)) - 1);
  EXPECT_NEAR(dist, -5.03, 0.03);
  // The ISET reversed telephoto's stop row marks the image plane: an element is the stop.
  const FocusedLens rt = focused(shared("isetcam/reversed.telephoto.37deg.100mm.dat"));
  EXPECT_FALSE(rt.paraxial.stop_is_file_stop);
  EXPECT_LT(rt.paraxial.aperture_stop_surface, 10);
}

TEST(Spots, RmsRadiusConvergesWithHexapolarRings) {
  // The square grid this replaced was off by up to 6% (dgauss.22deg +6.2%).
  for (const std::string& path :
       {shared("isetcam/dgauss.22deg.50.0mm.dat"), shared("isetcam/wide.40deg.50.0mm.dat"),
        lensim::test::lensPath("dgauss.50mm.dat")}) {
    const FocusedLens fl = focused(path);
    const auto a = computeSpots(fl, {0, 0.7, 1}, 35);  // the default, 48 rings
    const auto b = computeSpots(fl, {0, 0.7, 1}, 35, 192);
    ASSERT_EQ(a.size(), b.size()) << path;
    ASSERT_FALSE(a.empty());
    for (size_t i = 0; i < a.size(); ++i) {
      EXPECT_NEAR(a[i].rms_radius_mm / b[i].rms_radius_mm, 1, 0.005)
          << path << " field " << a[i].film_height_mm;
      EXPECT_EQ(a[i].rays_traced, 3 * 48 * 49);
      EXPECT_LE(a[i].display.size(), a[i].points_mm.size());
    }
  }
}

TEST(Wavefront, PerfectCircularPupilGivesTheClosedFormMtf) {
  const double nm = 550, na = 0.2;
  const FourierOptics fo = fourierOptics(syntheticPupil(128, na, 0, nm));
  const double cutoff = 2 * na / (nm * 1e-6);
  for (double v = 0; v <= 1.0001; v += 0.05) {
    EXPECT_NEAR(std::abs(fo.otfAt(v * cutoff, 0)), circleMtf(v), 0.01) << v;
    EXPECT_NEAR(std::abs(fo.otfAt(0, v * cutoff)), circleMtf(v), 0.01) << v;
  }
  EXPECT_NEAR(fo.strehl, 1, 0.02);
  // The PSF on its grid nodes is the Airy pattern [2 J1(x) / x]^2, x = 2 pi NA r / lambda.
  const double peak = fo.psfAt(0, 0);
  for (int k = 1; k <= 8; ++k) {
    const double r = k * fo.psf_pitch_mm;
    const double x = 2 * std::numbers::pi * na * r / (nm * 1e-6);
    const double airy = std::pow(2 * std::cyl_bessel_j(1.0, x) / x, 2);
    EXPECT_NEAR(fo.psfAt(r, 0) / peak, airy, 0.01) << r;
  }
}

TEST(Wavefront, DefocusedPupilHasTheKnownMtfZero) {
  const double nm = 550, na = 0.1, w20 = 1.0;  // one wave of defocus at the rim
  const FourierOptics fo = fourierOptics(syntheticPupil(128, na, w20, nm));
  const double cutoff = 2 * na / (nm * 1e-6);
  // The whole curve, and the first zero of the defocus MTF.
  double first_zero_quad = 0;
  for (double v = 0.005; v < 1; v += 0.0025)
    if (defocusOtf(v, w20) < 0) {
      first_zero_quad = v;
      break;
    }
  ASSERT_GT(first_zero_quad, 0.05);
  ASSERT_LT(first_zero_quad, 0.5);
  for (double v = 0; v < 1; v += 0.05)
    EXPECT_NEAR(std::abs(fo.otfAt(v * cutoff, 0)), std::abs(defocusOtf(v, w20)), 0.01) << v;
  double v_min = 0, m_min = 1;
  for (double v = first_zero_quad - 0.05; v < first_zero_quad + 0.05; v += 0.0005) {
    const double m = std::abs(fo.otfAt(v * cutoff, 0));
    if (m < m_min) {
      m_min = m;
      v_min = v;
    }
  }
  EXPECT_NEAR(v_min, first_zero_quad, 0.01);
  EXPECT_LT(m_min, 0.01);
}

TEST(Wavefront, StoppedDownLensOnAxisIsDiffractionLimited) {
  LensSetup setup;
  setup.aperture_diameter_mm = 2.0;  // about f/25: spherical aberration far below a wave
  const FocusedLens fl = focused(lensim::test::lensPath("dgauss.50mm.dat"), setup);
  MtfOptions o;
  o.fields = {0};
  o.geometric = false;
  const MtfData d = computeMtf(monochromatic(fl), 35, o);
  ASSERT_EQ(d.fields.size(), 1u);
  // The cone's NA is the real marginal ray's, EFL / (2 N) about.
  EXPECT_NEAR(
      d.working_f_number,
      std::abs(fl.paraxial.effective_focal_length_mm) / fl.paraxial.entrance_pupil_diameter_mm,
      0.02 * d.working_f_number);
  for (size_t k = 0; k < d.frequency.size(); ++k)
    EXPECT_NEAR(d.fields[0].diffraction_tangential[k], circleMtf(d.frequency[k] / d.cutoff), 0.015)
        << d.frequency[k];
  EXPECT_GT(d.fields[0].strehl, 0.95);
}

TEST(Wavefront, PsfCentroidIsTheSpotCentroid) {
  // Off axis the PSF's energy centroid (wave optics) and the spot's centroid (geometric) are
  // both offset from the chief ray's image point by the same coma: this checks the sign and
  // scale of the Fourier relation between pupil and film.
  LensSetup setup;
  setup.aperture_diameter_mm = 8.0;
  const FocusedLens fl = focused(lensim::test::lensPath("dgauss.50mm.dat"), setup);
  const auto spots = computeSpots(fl, {0.9}, 35, 64);
  const auto psf = computePsf(monochromatic(fl), 35, {0.9});
  ASSERT_EQ(spots.size(), 1u);
  ASSERT_EQ(psf.size(), 1u);
  const Vec2 spot_offset = spots[0].centroid_mm - psf[0].image_point_mm;
  EXPECT_GT(std::abs(spot_offset.x), 2 * psf[0].airy_radius_mm / 10);  // a real coma offset
  EXPECT_NEAR(psf[0].centroid_mm.x, spot_offset.x, 0.1 * std::abs(spot_offset.x) + 2e-4);
  EXPECT_NEAR(psf[0].centroid_mm.y, 0, 1e-4);
}

TEST(Mtf, GeometricAndDiffractionAgreeForALargeAberration) {
  // Far from the diffraction limit (the wide-open double Gauss off axis) the diffraction MTF at
  // low frequencies tends to the geometric one.
  const FocusedLens fl = focused(lensim::test::lensPath("dgauss.50mm.dat"));
  MtfOptions o;
  o.fields = {0.7};
  o.max_frequency = 40;
  o.samples = 5;
  const MtfData d = computeMtf(monochromatic(fl), 35, o);
  ASSERT_EQ(d.fields.size(), 1u);
  for (size_t k = 0; k < d.frequency.size(); ++k)
    EXPECT_NEAR(d.fields[0].diffraction_sagittal[k], d.fields[0].geometric_sagittal[k], 0.06)
        << d.frequency[k];
}

TEST(FieldCurves, AxialFociAreTheParaxialFocus) {
  const FocusedLens fl = focused(lensim::test::lensPath("dgauss.50mm.dat"));  // film at the BFL
  const FieldCurves c = computeFieldCurves(monochromatic(fl), 35, 10);
  ASSERT_FALSE(c.field_angle_deg.empty());
  EXPECT_NEAR(c.field_angle_deg[0], 0, 1e-9);
  // Thin bundles about the axis focus at the paraxial back focal point, which is the film.
  EXPECT_NEAR(c.tangential_mm[0][0], 0, 1e-4);
  EXPECT_NEAR(c.sagittal_mm[0][0], 0, 1e-4);
  // Off axis the astigmatic foci separate.
  EXPECT_GT(std::abs(c.tangential_mm[0].back() - c.sagittal_mm[0].back()), 1e-3);
}

TEST(RayFans, AxialFansAreOddAndEqual) {
  const FocusedLens fl = focused(lensim::test::lensPath("dgauss.50mm.dat"));
  const auto fans = computeRayFans(monochromatic(fl), 35, {0}, 41, 1.0);
  ASSERT_EQ(fans.size(), 1u);
  const RayFan& r = fans[0].fans[0];
  ASSERT_EQ(r.tangential_pupil.size(), r.sagittal_pupil.size());
  const size_t n = r.tangential_pupil.size();
  ASSERT_GT(n, 20u);
  for (size_t k = 0; k < n; ++k) {
    EXPECT_NEAR(r.tangential_ex_mm[k], -r.tangential_ex_mm[n - 1 - k], 1e-9);
    EXPECT_NEAR(r.tangential_ex_mm[k], r.sagittal_ey_mm[k], 1e-9);
  }
}

TEST(ThroughFocus, StoppedDownLensPeaksAtTheFilm) {
  LensSetup setup;
  setup.aperture_diameter_mm = 4.0;
  const FocusedLens fl = focused(lensim::test::lensPath("dgauss.50mm.dat"), setup);
  const ThroughFocusData d = computeThroughFocusMtf(monochromatic(fl), 35, {0}, 40, 0.3, 31);
  ASSERT_EQ(d.fields.size(), 1u);
  const auto& t = d.fields[0].diffraction_tangential;
  const size_t best = std::max_element(t.begin(), t.end()) - t.begin();
  // Symmetric about the paraxial focus within a step (little spherical aberration at f/12).
  EXPECT_LE(std::abs(d.defocus_mm[best]), 0.02 + 1e-12);
  EXPECT_LT(t.front(), 0.5 * t[best]);
}

TEST(Mtf, PolychromaticIsTheWeightedMeanOverTheSystemsOfEachWavelength) {
  // Each wavelength traces the system `lens_for` gives (glass dispersion plugs in here); on the
  // stopped-down lens each is diffraction limited at its own cutoff.
  LensSetup setup;
  setup.aperture_diameter_mm = 2.0;
  const FocusedLens fl = focused(lensim::test::lensPath("dgauss.50mm.dat"), setup);
  SpectralLens sl = monochromatic(fl, {{450, 1}, {650, 3}});
  int calls = 0;
  sl.lens_for = [&](double) -> const LensSystem& {
    ++calls;
    return *fl.lens;
  };
  MtfOptions o;
  o.fields = {0};
  o.geometric = false;
  o.samples = 21;
  const MtfData d = computeMtf(sl, 35, o);
  ASSERT_EQ(d.fields.size(), 1u);
  EXPECT_GT(calls, 1);
  const double na = d.image_space_na;
  for (size_t k = 0; k < d.frequency.size(); ++k) {
    const double nu = d.frequency[k];
    const double expect =
        (circleMtf(nu * 450e-6 / (2 * na)) + 3 * circleMtf(nu * 650e-6 / (2 * na))) / 4;
    EXPECT_NEAR(d.fields[0].diffraction_tangential[k], expect, 0.015) << nu;
    EXPECT_NEAR(d.diffraction_limit[k], expect, 1e-12) << nu;
  }
}

namespace {

// Coddington's equations along a real chief ray (written here, independent of the thin-bundle
// crossings the library uses): at each surface, with incidence and refraction angles I, I' and
// the oblique power P = c (n' cos I' - n cos I),
//   sagittal   n' / s' = n / s + P,   tangential  n' cos^2 I' / t' = n cos^2 I / t + P,
// then s and t shrink by the distance to the next intersection. Returns the axial positions of
// the tangential and sagittal foci (z) for an object at infinity.
std::pair<double, double> coddingtonFoci(const LensSystem& lens, const Ray& chief) {
  std::vector<Vec3> path;
  TraceResult r = lens.tracer().traceFromScene(chief, TraceOptions{false}, &path);
  EXPECT_TRUE(r.ok());
  const auto& s = lens.interfaces();
  double inv_s = 0, inv_t = 0;  // n / s and n cos^2 I / t before the surface: object at infinity
  Vec3 d = chief.direction;
  double s_dist = 0, t_dist = 0;
  for (int i = 0; i < lens.surfaceCount(); ++i) {
    const Vec3 p = path[i + 1];
    if (i > 0) {
      const double D = length(p - path[i]);
      // Transfer: the distances from the previous surface, less D, in the medium before i.
      s_dist -= D;
      t_dist -= D;
      const double n = s[i].ior_before;
      inv_s = n / s_dist;
      inv_t = n / t_dist;  // times cos^2 I below
    }
    const Vec3 dir_in = d;
    Vec3 normal{0, 0, -1};
    double c = 0;
    if (s[i].radius_mm != 0) {
      c = 1 / s[i].radius_mm;
      normal = normalize(p - Vec3{0, 0, s[i].z_mm + s[i].radius_mm});
    }
    const double n = s[i].ior_before, n2 = s[i].ior_after;
    const double cos_i = std::abs(dot(dir_in, normal));
    const double sin2_r = (n / n2) * (n / n2) * (1 - cos_i * cos_i);
    const double cos_r = std::sqrt(1 - sin2_r);
    // The signed power: a positive curvature bends toward the axis for n2 > n.
    const double P = c * (n2 * cos_r - n * cos_i);
    const double ns = (i == 0 ? 0.0 : inv_s) + P;
    const double nt = (i == 0 ? 0.0 : inv_t * cos_i * cos_i) + P;
    s_dist = n2 / ns;
    t_dist = n2 * cos_r * cos_r / nt;
    // The refracted direction: the next segment of the path (or the outgoing ray).
    d = i + 2 < static_cast<int>(path.size()) ? normalize(path[i + 2] - p) : r.ray.direction;
  }
  const Vec3 last = path.back();
  return {last.z + d.z * t_dist, last.z + d.z * s_dist};
}

}  // namespace

TEST(FieldCurves, ThinBundleFociAgreeWithCoddington) {
  for (const char* name : {"dgauss.50mm.dat", "wide.22mm.dat"}) {
    const FocusedLens fl = focused(lensim::test::lensPath(name));
    const FieldCurves c = computeFieldCurves(monochromatic(fl), 35, 8);
    ASSERT_GE(c.film_height_mm.size(), 8u);
    for (size_t k = 1; k < c.film_height_mm.size(); k += 2) {
      auto b = FieldBundle::fromFilmHeight(fl, *fl.lens, c.film_height_mm[k]);
      ASSERT_TRUE(b);
      const auto [zt, zs] = coddingtonFoci(*fl.lens, b->sceneRay({0, 0}));
      EXPECT_NEAR(c.tangential_mm[0][k], zt - fl.lens->filmZ_mm(), 1e-5) << name << " " << k;
      EXPECT_NEAR(c.sagittal_mm[0][k], zs - fl.lens->filmZ_mm(), 1e-5) << name << " " << k;
    }
  }
}

TEST(ThroughFocus, OneWaveOfDefocusGivesTheDefocusOtf) {
  // The stopped-down (diffraction-limited) lens with its film moved by dz = 2 lambda / NA^2: one
  // wave of defocus at the rim, W = -dz NA^2 rho^2 / (2 lambda) to within NA^2 / 4.
  LensSetup setup;
  setup.aperture_diameter_mm = 2.0;
  const FocusedLens fl = focused(lensim::test::lensPath("dgauss.50mm.dat"), setup);
  const SpectralLens sl = monochromatic(fl);
  MtfOptions o;
  o.fields = {};
  const MtfData axis = computeMtf(sl, 35, o);
  const double na = axis.image_space_na, lambda = kDLineNm * 1e-6;
  const double dz = 2 * lambda / (na * na);
  for (double v : {0.05, 0.1, 0.15, 0.2, 0.3, 0.5}) {
    const ThroughFocusData d = computeThroughFocusMtf(sl, 35, {0}, v * axis.cutoff, dz, 3);
    ASSERT_EQ(d.fields.size(), 1u);
    const double expect = std::abs(defocusOtf(v, 1.0));
    EXPECT_NEAR(d.fields[0].diffraction_tangential[2], expect, 0.02) << v;
    EXPECT_NEAR(d.fields[0].diffraction_tangential[0], expect, 0.02) << v;
    EXPECT_NEAR(d.fields[0].diffraction_tangential[1], circleMtf(v), 0.02) << v;
  }
}

TEST(Mtf, PerfectConicLensIsDiffractionLimitedOnAxis) {
  // The conic k = -n^2 images an axial point at infinity perfectly; the sphere does not.
  MtfOptions o;
  o.fields = {0};
  o.geometric = false;
  // f = 40 mm, 12 mm aperture: about f/3.3, where the sphere is far from the limit.
  const FocusedLens conic =
      focusLens(lensim::test::planoConvexConic(-1.5 * 1.5, 1.5, 12), LensSetup{});
  const MtfData d = computeMtf(monochromatic(conic), 1, o);
  ASSERT_EQ(d.fields.size(), 1u);
  for (size_t k = 0; k < d.frequency.size(); ++k) {
    EXPECT_NEAR(d.fields[0].diffraction_tangential[k], circleMtf(d.frequency[k] / d.cutoff), 0.01)
        << d.frequency[k];
    EXPECT_NEAR(d.fields[0].diffraction_sagittal[k], circleMtf(d.frequency[k] / d.cutoff), 0.01)
        << d.frequency[k];
  }
  EXPECT_GT(d.fields[0].strehl, 0.99);

  const FocusedLens sphere = focusLens(lensim::test::planoConvexConic(0, 1.5, 12), LensSetup{});
  const MtfData s = computeMtf(monochromatic(sphere), 1, o);
  ASSERT_EQ(s.fields.size(), 1u);
  EXPECT_LT(s.fields[0].strehl, 0.5);
}
