// Fresnel reflection, thin-film stacks and coatings (issue 31), checked against closed forms
// (normal-incidence Fresnel, Brewster's angle, total internal reflection, quarter-wave layers,
// the quarter-wave mirror, a bulk metal) and against the Airy summation of a single layer written
// here independently of the matrix method.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <numbers>
#include <vector>

#include "lensim/optics/coating/coating.h"
#include "lensim/optics/coating/thin_film.h"
#include "lensim/util/error.h"

using namespace lensim;
using namespace lensim::optics;
using Cx = std::complex<double>;

namespace {

double sq(double x) { return x * x; }

// Airy summation of one layer (index n1 - i k1, thickness d) between lossless n0 and ns:
// r = (r01 + r12 e^{-2 i beta}) / (1 + r01 r12 e^{-2 i beta}), beta = 2 pi N1 d cos t1 / lambda,
// with Fresnel amplitude coefficients; cos t in each medium from Snell's law, the decaying branch.
double airyR(double n0, Cx n1, double ns, double d, double lambda, double theta0, bool p) {
  const double inv = n0 * std::sin(theta0);
  auto cosIn = [&](Cx n) {
    Cx c = std::sqrt(Cx(1) - (inv / n) * (inv / n));
    if ((n * c).imag() > 0) c = -c;
    return c;
  };
  const Cx c0 = std::cos(theta0), c1 = cosIn(n1), cs = cosIn(Cx(ns));
  auto r = [&](Cx na, Cx ca, Cx nb, Cx cb) {
    return p ? (nb * ca - na * cb) / (nb * ca + na * cb) : (na * ca - nb * cb) / (na * ca + nb * cb);
  };
  const Cx r01 = r(n0, c0, n1, c1), r12 = r(n1, c1, ns, cs);
  const Cx beta = 2 * std::numbers::pi * n1 * d * c1 / lambda;
  const Cx e = std::exp(Cx(0, -2) * beta);
  return std::norm((r01 + r12 * e) / (1.0 + r01 * r12 * e));
}

}  // namespace

TEST(Fresnel, NormalIncidenceMatchesClosedForm) {
  for (double n2 : {1.3, 1.5168, 1.9, 2.4}) {
    const double want = sq((1 - n2) / (1 + n2));
    EXPECT_NEAR(fresnelDielectric(1.0, n2, 1.0).R, want, 1e-14);
    EXPECT_NEAR(fresnelDielectric(n2, 1.0, 1.0).R, want, 1e-14);
    EXPECT_NEAR(thinFilmStack(1.0, {}, n2, 550, 1.0).R, want, 1e-12);
  }
  // Uncoated crown glass reflects about 4 %.
  EXPECT_NEAR(fresnelDielectric(1.0, 1.5168, 1.0).R, 0.0422, 5e-4);
}

TEST(Fresnel, BrewsterAngleHasNoPReflection) {
  const double n2 = 1.5168;
  const double tb = std::atan(n2);
  double rs, rp;
  fresnelDielectricSP(1.0, n2, std::cos(tb), &rs, &rp);
  EXPECT_LT(rp, 1e-15);
  EXPECT_GT(rs, 0.1);
  EXPECT_LT(thinFilmStack(1.0, {}, n2, 550, std::cos(tb), 'p').R, 1e-15);
  EXPECT_NEAR(thinFilmStack(1.0, {}, n2, 550, std::cos(tb), 's').R, rs, 1e-12);
  // Inside the glass, Brewster's angle is atan(1/n).
  fresnelDielectricSP(n2, 1.0, std::cos(std::atan(1 / n2)), &rs, &rp);
  EXPECT_LT(rp, 1e-15);
}

TEST(Fresnel, TotalInternalReflectionBeyondTheCriticalAngle) {
  const double n = 1.5, crit = std::asin(1 / n);
  for (double t : {crit + 1e-3, crit + 0.2, 1.4}) {
    EXPECT_EQ(fresnelDielectric(n, 1.0, std::cos(t)).R, 1.0);
    const FilmRTA s = thinFilmStack(n, {}, 1.0, 550, std::cos(t));
    EXPECT_NEAR(s.R, 1.0, 1e-12);
    EXPECT_NEAR(s.T, 0.0, 1e-12);
    // A lossless coating cannot stop total internal reflection either.
    const FilmLayer l{{1.38, 0}, 99.6};
    EXPECT_NEAR(thinFilmStack(n, {&l, 1}, 1.0, 550, std::cos(t)).R, 1.0, 1e-12);
  }
  EXPECT_LT(fresnelDielectric(n, 1.0, std::cos(crit - 1e-3)).R, 1.0);
}

TEST(Fresnel, EnergyIsConservedAtEveryAngle) {
  for (double t = 0; t < 1.5; t += 0.05) {
    const FilmRTA f = fresnelDielectric(1.0, 1.7, std::cos(t));
    EXPECT_NEAR(f.R + f.T, 1.0, 1e-14);
    const FilmRTA s = thinFilmStack(1.0, {}, 1.7, 550, std::cos(t));
    EXPECT_NEAR(s.R, f.R, 1e-12);
    EXPECT_NEAR(s.R + s.T + s.A, 1.0, 1e-12);
  }
}

TEST(ThinFilm, QuarterWaveLayerReachesItsClosedFormMinimum) {
  // MgF2 (1.38) on N-BK7 (1.5168) at 550 nm: R = ((n0 ns - n1^2) / (n0 ns + n1^2))^2 = 1.284 %.
  const double n1 = 1.38, ns = 1.5168, lambda = 550;
  const FilmLayer l{{n1, 0}, lambda / (4 * n1)};
  const double want = sq((ns - n1 * n1) / (ns + n1 * n1));
  EXPECT_NEAR(want, 0.01284, 1e-5);
  EXPECT_NEAR(thinFilmStack(1.0, {&l, 1}, ns, lambda, 1.0).R, want, 1e-12);
  // It is the minimum over wavelength, and the layer is absent at twice its frequency.
  EXPECT_GT(thinFilmStack(1.0, {&l, 1}, ns, 450, 1.0).R, want);
  EXPECT_GT(thinFilmStack(1.0, {&l, 1}, ns, 650, 1.0).R, want);
  EXPECT_NEAR(thinFilmStack(1.0, {&l, 1}, ns, lambda / 2, 1.0).R, sq((1 - ns) / (1 + ns)), 1e-12);
  // The built-in "single" coating is that layer.
  CoatingLibrary lib;
  EXPECT_NEAR(lib.interfaceRTA(lib.find("single"), 1.0, ns, lambda, 1.0, 587.56).R, want, 1e-12);
  // From the glass side the lossless stack reflects the same.
  EXPECT_NEAR(lib.interfaceRTA(lib.find("single"), ns, 1.0, lambda, 1.0, 587.56).R, want, 1e-12);
}

TEST(ThinFilm, SingleLayerMatchesAiryAtAnyAngleAndWavelength) {
  for (Cx n1 : {Cx(1.38, 0), Cx(2.3, 0), Cx(1.9, -0.3)})
    for (double lambda : {420.0, 550.0, 700.0})
      for (double t : {0.0, 0.4, 0.9, 1.3}) {
        const FilmLayer l{n1, 137.0};
        for (char pol : {'s', 'p'}) {
          const double got = thinFilmStack(1.0, {&l, 1}, 1.62, lambda, std::cos(t), pol).R;
          EXPECT_NEAR(got, airyR(1.0, Cx(n1.real(), -std::abs(n1.imag())), 1.62, 137.0, lambda,
                                 t, pol == 'p'),
                      1e-12)
              << "n1 " << n1 << " lambda " << lambda << " theta " << t << " " << pol;
        }
      }
}

TEST(ThinFilm, TwoQuarterWavesAndTheQuarterHalfQuarterStack) {
  // Two quarter waves (outer n1, inner n2) on ns: admittance Y = n1^2 ns / n2^2,
  // R = ((1 - Y) / (1 + Y))^2; the half-wave layer of the "multi" stack is absent at its design
  // wavelength, so "multi" (MgF2 / ZrO2 half / Al2O3) reflects that at 510 nm.
  const double ns = 1.5168, y = sq(1.38) * ns / sq(1.63);
  const double want = sq((1 - y) / (1 + y));
  CoatingLibrary lib;
  const Coating* multi = lib.find("MULTI");
  ASSERT_TRUE(multi);
  EXPECT_NEAR(lib.interfaceRTA(multi, 1.0, ns, 510, 1.0, 587.56).R, want, 1e-12);
  // Broadband: over 420..680 nm it reflects less than the single layer on average and stays
  // below 1 % (a bare surface: 4.2 %).
  double sum_multi = 0, sum_single = 0;
  int n = 0;
  for (double l = 420; l <= 680; l += 10, ++n) {
    const double rm = lib.interfaceRTA(multi, 1.0, ns, l, 1.0, 587.56).R;
    EXPECT_LT(rm, 0.01) << l;
    sum_multi += rm;
    sum_single += lib.interfaceRTA(lib.find("single"), 1.0, ns, l, 1.0, 587.56).R;
  }
  EXPECT_LT(sum_multi / n, 0.5 * sum_single / n);
}

TEST(ThinFilm, QuarterWaveMirrorMatchesMacleodsFormula) {
  // (HL)^p H on glass at the design wavelength: Y = (nH / nL)^(2p) nH^2 / ns,
  // R = ((1 - Y) / (1 + Y))^2 (Macleod, Thin-Film Optical Filters, sec. 7.1).
  const double nh = 2.35, nl = 1.38, ns = 1.52, lambda = 600;
  for (int p : {1, 3, 6}) {
    std::vector<FilmLayer> layers;
    for (int i = 0; i < p; ++i) {
      layers.push_back({{nh, 0}, lambda / (4 * nh)});
      layers.push_back({{nl, 0}, lambda / (4 * nl)});
    }
    layers.push_back({{nh, 0}, lambda / (4 * nh)});
    const double y = std::pow(nh / nl, 2 * p) * nh * nh / ns;
    const FilmRTA r = thinFilmStack(1.0, layers, ns, lambda, 1.0);
    EXPECT_NEAR(r.R, sq((1 - y) / (1 + y)), 1e-10) << p;
    EXPECT_NEAR(r.R + r.T, 1.0, 1e-12);
  }
}

TEST(ThinFilm, AbsorbingLayersConserveEnergyAndReachTheBulkMetal) {
  // Aluminium near 550 nm: N = 0.96 - 6.69 i.
  const Cx al(0.96, 6.69);
  for (double d : {5.0, 10.0, 20.0})
    for (double t : {0.0, 0.5, 1.0})
      for (char pol : {'s', 'p', 'u'}) {
        const FilmLayer l{al, d};
        const FilmRTA r = thinFilmStack(1.0, {&l, 1}, 1.52, 550, std::cos(t), pol);
        EXPECT_NEAR(r.R + r.T + r.A, 1.0, 1e-12);
        EXPECT_GT(r.A, 0.01);
        EXPECT_GT(r.T, 0.0);
      }
  // Thick: nothing gets through, and the reflectance is the bulk metal's
  // ((n - 1)^2 + k^2) / ((n + 1)^2 + k^2).
  const FilmLayer thick{al, 500};
  const FilmRTA r = thinFilmStack(1.0, {&thick, 1}, 1.52, 550, 1.0);
  EXPECT_LT(r.T, 1e-12);
  const double bulk = (sq(0.96 - 1) + sq(6.69)) / (sq(0.96 + 1) + sq(6.69));
  EXPECT_NEAR(r.R, bulk, 1e-9);
}

TEST(ZemaxCoatingFile, MaterialsCoatingsAndThicknesses) {
  CoatingLibrary lib;
  lib.addZemaxCoatingFile(
      "! a coating file\n"
      "MATE MGF2X\n"
      "  0.40 1.38 0.0\n"
      "  0.70 1.38 0.0\n"
      "COAT QW\n"
      "MGF2X 0.25\n"
      "COAT ABS\n"
      "MGF2X 0.0996 1 ! 99.6 nm\n"
      "COAT LATE\n"
      "ZNS 0.25\n"
      "MATE ZNS\n"
      "0.5 2.35\n",
      "c.dat");
  const double ns = 1.5168;
  const Coating* qw = lib.find("qw");
  ASSERT_TRUE(qw);
  // Waves of the lens's design (primary) wavelength: a quarter wave at 550 nm.
  EXPECT_NEAR(lib.interfaceRTA(qw, 1.0, ns, 550, 1.0, 550).R, sq((ns - 1.9044) / (ns + 1.9044)),
              1e-12);
  const Coating* abs = lib.find("ABS");
  ASSERT_TRUE(abs);
  const std::vector<FilmLayer> l = lib.layersAt(*abs, 550, 550);
  ASSERT_EQ(l.size(), 1u);
  EXPECT_NEAR(l[0].thickness_nm, 99.6, 1e-9);
  const Coating* late = lib.find("late");
  ASSERT_TRUE(late);
  EXPECT_NEAR(lib.layersAt(*late, 600, 600)[0].thickness_nm, 600 / (4 * 2.35), 1e-9);
  // The built-ins stay.
  EXPECT_TRUE(lib.find("multi"));
}

TEST(ZemaxCoatingFile, BadInputIsRefusedAtItsLine) {
  auto err = [](const char* text) {
    CoatingLibrary lib;
    try {
      lib.addZemaxCoatingFile(text, "c.dat");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(err("COAT A\nNOPE 0.25\n").find("c.dat:2:1: error: coating A: unknown material 'NOPE'"),
            std::string::npos)
      << err("COAT A\nNOPE 0.25\n");
  EXPECT_NE(err("MATE M\n0.5 x 0\n").find("c.dat:2:5"), std::string::npos);
  EXPECT_NE(err("MATE M\n0.5 1.4 -1\n").find("c.dat:2"), std::string::npos);
  EXPECT_NE(err("MATE M\n0.6 1.4\n0.5 1.4\n").find("does not ascend"), std::string::npos);
  EXPECT_NE(err("TAPR X\n").find("not supported"), std::string::npos);
  EXPECT_NE(err("MGF2 0.25\n").find("outside a MATE or COAT block"), std::string::npos);
  EXPECT_NE(err("MATE M\n").find("no 'wavelength_um n k' rows"), std::string::npos);
  EXPECT_NE(err("COAT A\nMGF2 0.25 2\n").find("is_absolute must be 0 or 1"), std::string::npos);
  EXPECT_NE(err("COAT A\nMGF2 0.25\nCOAT A\n").find("c.dat:3:1: error: coating A is defined twice"),
            std::string::npos);
}
