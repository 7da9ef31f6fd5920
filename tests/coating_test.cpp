// Fresnel reflection, thin-film stacks and coatings (issue 31), checked against closed forms
// (normal-incidence Fresnel, Brewster's angle, total internal reflection, quarter-wave layers,
// the quarter-wave mirror, a bulk metal) and against the Airy summation of a single layer written
// here independently of the matrix method.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <numbers>
#include <utility>
#include <vector>

#include <unistd.h>

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

// ---- Coated lenses: lens files, transmittance, ghosts ----

#include <filesystem>
#include <fstream>

#include "lensim/optics/coating/ghosts.h"
#include "lensim/optics/coating/lens_coatings.h"
#include "lensim/optics/lens_system.h"
#include "lensim/optics/prescription.h"

namespace {

std::string writeTemp(const std::string& name, const std::string& text) {
  // A folder per process: ctest runs this file's tests as parallel processes.
  const auto dir = std::filesystem::temp_directory_path() /
                   ("lensim_coating_test-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto p = dir / name;
  std::ofstream(p) << text;
  return p.string();
}

// A plate of index n, thickness t, in air (a lens file in lensim's JSON).
std::string plateJson(const std::string& top, const std::string& s0, double n) {
  return "{\"format\": \"lensim-lens\", " + top +
         "\"surfaces\": [\n"
         "  {\"radius_mm\": 0, \"thickness_mm\": 5, \"semi_aperture_mm\": 10, \"ior\": " +
         std::to_string(n) + s0 +
         "},\n"
         "  {\"radius_mm\": 0, \"thickness_mm\": 1, \"semi_aperture_mm\": 10},\n"
         "  {\"radius_mm\": 0, \"thickness_mm\": 50, \"semi_aperture_mm\": 10, \"stop\": true}\n"
         "]}\n";
}

}  // namespace

TEST(CoatedLens, JsonCoatingsDefaultsAndUnknownNames) {
  const LensPrescription p = readLensFile(writeTemp(
      "plate.json", plateJson("\"coating\": \"multi\", ", ", \"coating\": \"single\"", 1.5168)));
  const LensCoatings c = resolveCoatings(p);
  ASSERT_EQ(c.label.size(), 3u);
  EXPECT_EQ(c.label[0], "single");
  EXPECT_EQ(c.label[1], "multi");
  EXPECT_EQ(c.label[2], "index-matched");
  // Unknown names: refused at the surface's line / the key's line.
  try {
    readLensFile(writeTemp("bad.json", plateJson("", ", \"coating\": \"nope\"", 1.5)));
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.json:2:3: error: unknown coating 'nope'"),
              std::string::npos)
        << e.what();
  }
  try {
    readLensFile(writeTemp("bad2.json", plateJson("\n\"coating\": \"quad\",\n", "", 1.5)));
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad2.json:2:1: error: unknown lens-wide coating 'quad'"),
              std::string::npos)
        << e.what();
  }
  // A coating file beside the lens defines more names.
  writeTemp("mine.dat", "MATE M\n0.55 1.38 0\nCOAT MINE\nM 0.25\n");
  const LensPrescription q = readLensFile(writeTemp(
      "plate2.json", plateJson("\"coating_file\": \"mine.dat\", \"coating\": \"MINE\", ", "", 1.5)));
  EXPECT_EQ(resolveCoatings(q).label[0], "MINE");
}

TEST(CoatedLens, UncoatedDoubleGaussTransmittanceIsTheProductOfFresnelLosses) {
  LensSystem lens(readLensFile(std::string(LENSIM_SOURCE_DIR) + "/lenses/dgauss.50mm.dat"));
  const LensCoatings c = resolveCoatings(lens.prescription());
  // Independent: (1 - ((n1 - n2) / (n1 + n2))^2) over the interfaces at 550 nm.
  std::vector<double> nb(size_t(lens.surfaceCount())), na(size_t(lens.surfaceCount()));
  lens.indicesAt(550, nb.data(), na.data());
  double want = 1;
  int air_glass = 0;
  for (size_t k = 0; k < nb.size(); ++k) {
    want *= 1 - sq((nb[k] - na[k]) / (nb[k] + na[k]));
    air_glass += (nb[k] == 1) != (na[k] == 1);
  }
  EXPECT_EQ(air_glass, 8);
  const double t = axialTransmittance(lens, c, 550);
  EXPECT_NEAR(t, want, 1e-12);
  // Eight air-glass surfaces of 1.6-1.7 glass: about 60 %.
  EXPECT_GT(t, 0.55);
  EXPECT_LT(t, 0.66);
  // Multicoated: at the stack's design wavelength (510 nm) each air-glass surface reflects as
  // two quarter waves, Y = n_MgF2^2 n_glass / n_Al2O3^2; cemented surfaces stay bare.
  LensPrescription pm = lens.prescription();
  pm.default_coating = "multi";
  LensSystem multi(pm);
  lens.indicesAt(510, nb.data(), na.data());
  double want_multi = 1;
  for (size_t k = 0; k < nb.size(); ++k) {
    if ((nb[k] == 1) != (na[k] == 1)) {
      const double y = sq(1.38) * std::max(nb[k], na[k]) / sq(1.63);
      want_multi *= 1 - sq((1 - y) / (1 + y));
    } else {
      want_multi *= 1 - sq((nb[k] - na[k]) / (nb[k] + na[k]));
    }
  }
  const double tm = axialTransmittance(multi, resolveCoatings(pm), 510);
  EXPECT_NEAR(tm, want_multi, 1e-12);
  EXPECT_GT(tm, 0.92);  // uncoated: 0.59
}

TEST(CoatedLens, PlateGhostCarriesRSquaredAndStaysCollimated) {
  // An uncoated plate: the one ghost (reflected at the back, then the front) carries R^2 of the
  // direct beam: the second term of T = (1 - R)^2 (1 + R^2 + R^4 + ...) = (1 - R)^2 / (1 - R^2).
  const double n = 1.5168;
  LensSystem lens(readLensFile(writeTemp("plate3.json", plateJson("", "", n))));
  const LensCoatings c = resolveCoatings(lens.prescription());
  const double w[] = {550};
  const GhostAnalysis g = analyseGhosts(lens, c, w);
  const double r = sq((n - 1) / (n + 1));
  // Surfaces: 0 front, 1 back, 2 the stop in air (it reflects nothing).
  ASSERT_EQ(g.ghosts.size(), 3u);
  EXPECT_EQ(g.ghosts[0].b, 1);
  EXPECT_EQ(g.ghosts[0].a, 0);
  EXPECT_EQ(g.ghosts[1].relative_intensity, 0.0);
  EXPECT_NEAR(g.ghosts[0].relative_intensity, r * r, 1e-14);
  EXPECT_NEAR(g.direct_transmittance[0] * (1 + g.ghosts[0].relative_intensity),
              sq(1 - r) * (1 + r * r), 1e-14);
  EXPECT_TRUE(std::isinf(g.ghosts[0].focus_z_mm));
  EXPECT_NEAR(g.ghosts[0].film_diameter_mm, 20, 1e-9);
}

TEST(CoatedLens, GhostFocusOfAPlanoConvexLensMatchesVergences) {
  // Plano-convex: R = 50 mm front, flat back, t = 5 mm, n = 1.5. Ghost (1, 0): refract at the
  // front, reflect at the flat back (no power), reflect at the front from inside (a concave
  // mirror of radius 50 mm in glass: vergence change 2 n / R), refract out at the flat back.
  // Independently with reduced vergences V = n / s (mm^-1), all distances from the surfaces:
  const double rr = 50, t = 5, n = 1.5;
  double v = (n - 1) / rr;                       // after the front surface (object at infinity)
  auto transfer = [](double v0, double d, double idx) { return 1 / (1 / v0 - d / idx); };
  v = transfer(v, t, n);                         // at the back surface
  // Reflection at the flat back: unfolding the path, the vergence continues; then travel back.
  v = transfer(v, t, n);                         // at the front surface, from inside
  v += 2 * n / rr;                               // reflection at the front (concave from inside)
  v = transfer(v, t, n);                         // at the back again
  // Refraction at the flat back into air: V unchanged (reduced vergence); focus behind it:
  const double s_focus = 1 / v;                  // in air, from the back surface
  const std::string text =
      "{\"format\": \"lensim-lens\", \"surfaces\": [\n"
      "  {\"radius_mm\": 50, \"thickness_mm\": 5, \"semi_aperture_mm\": 10, \"ior\": 1.5},\n"
      "  {\"radius_mm\": 0, \"thickness_mm\": 1, \"semi_aperture_mm\": 10},\n"
      "  {\"radius_mm\": 0, \"thickness_mm\": 90, \"semi_aperture_mm\": 10, \"stop\": true}\n"
      "]}\n";
  LensSystem lens(readLensFile(writeTemp("pcx.json", text)));
  const double w[] = {550};
  const GhostAnalysis g = analyseGhosts(lens, resolveCoatings(lens.prescription()), w);
  ASSERT_EQ(g.ghosts.size(), 3u);
  ASSERT_EQ(g.ghosts[0].b, 1);
  EXPECT_NEAR(g.ghosts[0].focus_z_mm, t + s_focus, 1e-9);
  // Its energy: R_back (glass to air) * R_front (from inside) over the direct beam, with the
  // front surface's transmission counted once on both paths.
  const double r = sq((n - 1) / (n + 1));
  EXPECT_NEAR(g.ghosts[0].relative_intensity, r * r * std::min(1.0, g.ghosts[0].aperture_fraction),
              1e-14);
}

TEST(CoatedLens, ZemaxCoatNamesResolveThroughTheCoatingFileBesideTheLens) {
  std::ifstream in(std::string(LENSIM_SHARED_DIR) + "/lenses/zmx/US00583336-2-scaled.zmx",
                   std::ios::binary);
  ASSERT_TRUE(in);
  std::string lines, line;
  std::vector<std::string> v;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    v.push_back(line);
  }
  auto zmxWith = [&](const std::string& coat) {
    std::string out;
    for (size_t i = 0; i < v.size(); ++i) {
      if (v[i].rfind("COFN", 0) == 0) continue;  // the file's own (COATING.DAT, absent)
      out += v[i] + "\n";
      if (v[i] == "MODE SEQ") out += "COFN QF \"ZCOAT.DAT\" \"SCATTER_PROFILE.DAT\"\n";
      if (v[i] == "SURF 1") out += "  COAT " + coat + "\n";
    }
    return out;
  };
  writeTemp("ZCOAT.DAT", "MATE MGF2\n0.4 1.38 0\n0.7 1.38 0\nCOAT QW\nMGF2 0.25\n");
  const LensPrescription p = readLensFile(writeTemp("coated.zmx", zmxWith("QW")));
  const LensCoatings c = resolveCoatings(p);
  EXPECT_EQ(c.label[0], "QW");
  EXPECT_EQ(c.label[1], "uncoated");
  // Unknown: refused at the COAT line (one COFN line added, the two of the file dropped).
  try {
    readLensFile(writeTemp("coated2.zmx", zmxWith("NOPE")));
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("coated2.zmx:66:8: error: unknown coating 'NOPE'"),
              std::string::npos)
        << e.what();
  }
}

// The unpolarised real-arithmetic path (lossless layers, propagating waves) against the Airy
// summation written above and against the complex matrix path (s and p separately), at every
// angle up to grazing, from air and from the glass side (through the critical angle).
TEST(ThinFilm, UnpolarisedFastPathMatchesAiryAndTheComplexPath) {
  for (Cx n1 : {Cx(1.38, 0), Cx(2.3, 0)})
    for (auto [n0, ns] : {std::pair{1.0, 1.62}, std::pair{1.62, 1.0}})
      for (double lambda = 380; lambda <= 780; lambda += 25)
        for (double deg = 0; deg < 90; deg += 1.5) {
          const double t = deg * std::numbers::pi / 180;
          const FilmLayer l{n1, 137.0};
          const double got = thinFilmStack(n0, {&l, 1}, ns, lambda, std::cos(t)).R;
          const double sp = 0.5 * (thinFilmStack(n0, {&l, 1}, ns, lambda, std::cos(t), 's').R +
                                   thinFilmStack(n0, {&l, 1}, ns, lambda, std::cos(t), 'p').R);
          EXPECT_NEAR(got, sp, 1e-12) << n1 << " " << n0 << " " << lambda << " " << deg;
          if (n0 * std::sin(t) >= ns) continue;  // total reflection: Airy's cos t is imaginary
          EXPECT_NEAR(got,
                      0.5 * (airyR(n0, n1, ns, 137.0, lambda, t, false) +
                             airyR(n0, n1, ns, 137.0, lambda, t, true)),
                      1e-12)
              << n1 << " " << n0 << " " << lambda << " " << deg;
        }
}

// Several wavelengths at one angle (shared angle part, chunks of 8) against one at a time by the
// complex path, for the multicoating's stack, a five-layer stack and one with an absorbing layer
// (which takes the complex path); and the quarter-wave closed form at its design wavelength in
// the middle of a spectral call.
TEST(ThinFilm, SpectralMatchesOneWavelengthAtATime) {
  const std::vector<FilmLayer> multi{{Cx(1.38, 0), 510.0 / 4 / 1.38},
                                     {Cx(2.05, 0), 510.0 / 2 / 2.05},
                                     {Cx(1.63, 0), 510.0 / 4 / 1.63}};
  const std::vector<FilmLayer> five{
      {Cx(1.45, 0), 90}, {Cx(2.2, 0), 60}, {Cx(1.45, 0), 120}, {Cx(2.2, 0), 30}, {Cx(1.7, 0), 200}};
  const std::vector<FilmLayer> absorbing{{Cx(1.38, 0), 99.6}, {Cx(0.96, -6.69), 5}};
  std::vector<double> lambda;
  for (double l = 380; l <= 780; l += 20) lambda.push_back(l);  // 21: three chunks
  std::vector<FilmRTA> out(lambda.size());
  for (const auto* stack : {&multi, &five, &absorbing})
    for (auto [n0, ns] : {std::pair{1.0, 1.75}, std::pair{1.75, 1.0}})
      for (double c : {1.0, 0.9, 0.6, 0.3, 0.05}) {
        thinFilmStackSpectral(n0, *stack, ns, lambda, c, out.data());
        for (size_t w = 0; w < lambda.size(); ++w) {
          const FilmRTA s = thinFilmStack(n0, *stack, ns, lambda[w], c, 's');
          const FilmRTA p = thinFilmStack(n0, *stack, ns, lambda[w], c, 'p');
          EXPECT_NEAR(out[w].R, 0.5 * (s.R + p.R), 1e-12) << lambda[w] << " cos " << c;
          EXPECT_NEAR(out[w].T, 0.5 * (s.T + p.T), 1e-12) << lambda[w] << " cos " << c;
          EXPECT_NEAR(out[w].A, 0.5 * (s.A + p.A), 1e-12) << lambda[w] << " cos " << c;
        }
      }
  for (double ns : {1.5168, 1.75, 1.9}) {
    const FilmLayer qw{Cx(1.38, 0), 550.0 / 4 / 1.38};
    const std::vector<double> l3{450, 550, 650};
    std::vector<FilmRTA> r(3);
    thinFilmStackSpectral(1.0, {&qw, 1}, ns, l3, 1.0, r.data());
    EXPECT_NEAR(r[1].R, sq((ns - 1.38 * 1.38) / (ns + 1.38 * 1.38)), 1e-12) << ns;
    EXPECT_NEAR(r[1].R + r[1].T, 1.0, 1e-12);
  }
}

// A coated interface's spectral evaluation against one wavelength at a time: built-in coatings
// (non-dispersive: the shared path) and a Zemax coating of a tabulated, dispersive material (one
// stack per wavelength), from both sides.
TEST(Coatings, InterfaceSpectralMatchesOneWavelengthAtATime) {
  CoatingLibrary lib;
  lib.addZemaxCoatingFile(
      "MATE DISP\n"
      "  0.40 1.48 0.0\n"
      "  0.70 1.40 0.0\n"
      "COAT DQW\n"
      "DISP 0.25\n"
      "MGF2 0.25\n",
      "c.dat");
  const std::vector<double> lambda{400, 455, 510, 587.56, 640, 700};
  std::vector<FilmRTA> out(lambda.size());
  for (const char* name : {"uncoated", "single", "multi", "DQW"})
    for (auto [nb, na] : {std::pair{1.0, 1.6}, std::pair{1.6, 1.0}})
      for (double c : {1.0, 0.8, 0.4}) {
        const Coating* coat = lib.find(name);
        ASSERT_TRUE(coat);
        lib.interfaceRTASpectral(coat, nb, na, lambda, c, 587.56, out.data());
        for (size_t w = 0; w < lambda.size(); ++w) {
          const FilmRTA one = lib.interfaceRTA(coat, nb, na, lambda[w], c, 587.56);
          EXPECT_NEAR(out[w].R, one.R, 1e-14) << name << " " << lambda[w];
          EXPECT_NEAR(out[w].T, one.T, 1e-14) << name << " " << lambda[w];
        }
      }
  // The dispersive layer is evaluated at its own index per wavelength: at 400 nm the DQW stack
  // differs from the same stack with the index held at 700 nm's.
  lib.interfaceRTASpectral(lib.find("DQW"), 1.0, 1.6, lambda, 1.0, 587.56, out.data());
  EXPECT_NE(out[0].R, out[5].R);
}
