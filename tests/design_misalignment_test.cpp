// Decentre and tilt tolerances (issue 33, docs/design.md): placed builds traced by the
// non-coaxial tracer against closed forms computed here (a decentred relay lens moves the image
// by d (1 - m), a tilted plate shifts a ray by t sin(theta) (1 - cos(theta) / sqrt(n^2 -
// sin^2(theta)))), the evenness of a symmetric lens's spot in the decentre, the unmoved placed
// lens against the coaxial evaluation, and Monte Carlo runs reproduced by their seed.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>

#include "lensim/optics/design/design_job.h"
#include "lensim/optics/design/placed_build.h"
#include "lensim/optics/design/tolerance.h"
#include "lensim/optics/lens_formats.h"
#include "lensim/optics/placed_lens.h"

namespace fs = std::filesystem;
using namespace lensim;
using namespace lensim::optics;
using namespace lensim::optics::design;

namespace {

struct TempDir {
  fs::path path;
  TempDir() {
    path =
        fs::temp_directory_path() / ("lensim_misalign_" + std::to_string(std::random_device{}()));
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(path / name) << text;
    return (path / name).string();
  }
};

// A lensim JSON lens from rows (radius, thickness, semi-aperture, index after; the first row is
// the stop, a plane).
struct Row {
  double radius, thickness, semi, n;
};
std::string lensJson(const std::vector<Row>& rows) {
  std::string s =
      "{\"format\": \"lensim-lens\", \"version\": 1, \"units\": \"mm\", \"surfaces\": [\n";
  for (size_t i = 0; i < rows.size(); ++i)
    s += "  {\"radius_mm\": " + std::to_string(rows[i].radius) +
         ", \"thickness_mm\": " + std::to_string(rows[i].thickness) +
         ", \"semi_aperture_mm\": " + std::to_string(rows[i].semi) +
         ", \"ior\": " + std::to_string(rows[i].n) + (i == 0 ? ", \"stop\": true" : "") + "}" +
         (i + 1 < rows.size() ? ",\n" : "\n");
  return s + "]}\n";
}

std::string job(const std::string& lens, const std::string& fields, const std::string& criterion,
                const std::string& compensator, int seed, const std::string& tolerances,
                int builds = 0) {
  return "{\"lens\": \"" + lens + "\", \"fields_deg\": " + fields +
         ", \"wavelengths_nm\": [587.56],\n \"tolerancing\": {\"criterion\": \"" + criterion +
         "\", \"compensator\": \"" + compensator +
         "\", \"monte_carlo\": " + std::to_string(builds) + ", \"seed\": " + std::to_string(seed) +
         ",\n  \"tolerances\": [\n" + tolerances + "\n]}}\n";
}

// Paraxial y-nu trace (independent of lensim) of a ray at height y, slope u through rows
// first..last of `rows` (refraction at each, then the row's thickness; the last row's thickness
// is replaced by `last_gap`): the height at the end.
double paraxialHeight(const std::vector<Row>& rows, size_t first, size_t last, double y, double u,
                      double n_before, double last_gap) {
  double n = n_before, nu = n * u;
  for (size_t i = first; i <= last; ++i) {
    const double c = rows[i].radius == 0 ? 0 : 1 / rows[i].radius;
    nu -= y * (rows[i].n - n) * c;
    n = rows[i].n;
    y += (i == last ? last_gap : rows[i].thickness) * nu / n;
  }
  return y;
}

// The gap after row `last` at which a ray parallel to the axis (entering at `first`) crosses it.
double paraxialFocus(const std::vector<Row>& rows, size_t first, size_t last) {
  const double y0 = paraxialHeight(rows, first, last, 1, 0, 1, 0);
  const double y1 = paraxialHeight(rows, first, last, 1, 0, 1, 1);
  return -y0 / (y1 - y0);
}

// A stop, a biconvex lens, a gap past its focus, a second (relay) lens: rows 0 .. 5.
std::vector<Row> relayLens() {
  std::vector<Row> r = {
      {0, 5, 4, 1}, {50, 4, 10, 1.5168}, {-50, 110, 10, 1}, {30, 3, 10, 1.62}, {-60, 0, 10, 1}};
  r.back().thickness = paraxialFocus(r, 0, 4);  // the film at the paraxial image
  return r;
}

TEST(Misalignment, UnmovedPlacedLensMatchesTheCoaxialEvaluation) {
  TempDir dir;
  dir.write("relay.json", lensJson(relayLens()));
  const DesignJob j = readDesignJob(
      dir.write("job.json",
                job("relay.json", "[0, 3]", "rms_spot", "back_focus", 1,
                    "{\"type\": \"decentre\", \"axis\": \"x\", \"element\": 1, \"delta\": 0.01}")));
  const LensPrescription coaxial = j.start;
  const LensPrescription placed = toleranceNominal(j);
  ASSERT_TRUE(placed.noncoaxial_loc);
  for (double f : {0.0, 3.0}) {
    const SpotQuadratic c = spotQuadratic(coaxial, f, 587.56, 587.56, 6);
    const PlacedBeam p = placedBeam(placed, f, 587.56, 587.56, 6);
    EXPECT_NEAR(p.spot.a, c.a, 1e-9 * c.a) << f;
    EXPECT_NEAR(p.spot.b, c.b, 1e-9 * std::abs(c.b) + 1e-15) << f;
    EXPECT_NEAR(p.spot.c, c.c, 1e-9 * c.c) << f;
  }
}

TEST(Misalignment, DecentredRelayLensMovesTheImageByDTimesOneMinusM) {
  // The relay lens (rows 3, 4) images the first lens's focus F onto the film with lateral
  // magnification m. Decentred by d, it images F (on the old axis, -d in its own frame) to
  // -d m in its frame, i.e. d (1 - m) from the old axis. On axis the chief ray runs along the
  // axis to the relay, entering it at -d parallel to its axis, so it meets the film there too
  // (paraxially exact; the real ray differs by order d^3). m: the height on the film of a ray
  // parallel to the axis at unit height in the space before the relay.
  const std::vector<Row> rows = relayLens();
  const double m = paraxialHeight(rows, 3, 4, 1, 0, 1, rows[4].thickness);
  ASSERT_LT(m, -0.5);  // a real relay: the image inverted
  TempDir dir;
  dir.write("relay.json", lensJson(rows));
  const double d = 0.02;
  const DesignJob j = readDesignJob(
      dir.write("job.json",
                job("relay.json", "[0]", "boresight", "none", 1,
                    "{\"type\": \"decentre\", \"axis\": \"y\", \"element\": 3, \"delta\": 0.02}")));
  ASSERT_EQ(j.tolerance.tolerances[0].last_surface, 4);
  const LensPrescription nominal = toleranceNominal(j);
  for (double sign : {1.0, -1.0}) {
    const LensPrescription moved = applyTolerance(nominal, j.tolerance.tolerances[0], sign * d);
    EXPECT_NEAR(moved.surfaces[3].frame->origin_mm[1], sign * d, 1e-15);
    const PlacedBeam b = placedBeam(moved, 0, 587.56, 587.56, 6);
    EXPECT_NEAR(b.chief.y, sign * d * (1 - m), 1e-5 * d) << "m " << m;
    EXPECT_NEAR(b.chief.x, 0, 1e-15);
  }
  const ToleranceResult r = runTolerancing(j);
  EXPECT_NEAR(r.nominal, 0, 1e-12);
  EXPECT_NEAR(r.sensitivity[0].plus, d * (1 - m), 1e-5 * d);
  EXPECT_NEAR(r.sensitivity[0].minus, d * (1 - m), 1e-5 * d);
  // The whole lens decentred (both elements about row 1): infinity is imaged on the moved axis.
  const DesignJob all = readDesignJob(
      dir.write("all.json",
                job("relay.json", "[0]", "boresight", "none", 1,
                    "{\"type\": \"decentre\", \"axis\": \"y\", \"element\": 1, \"delta\": 0.02},"
                    "{\"type\": \"decentre\", \"axis\": \"y\", \"element\": 3, \"delta\": 0.02}")));
  LensPrescription both = toleranceNominal(all);
  for (const Tolerance& t : all.tolerance.tolerances) both = applyTolerance(both, t, d);
  EXPECT_NEAR(placedBeam(both, 0, 587.56, 587.56, 6).chief.y, d, 1e-5 * d);
}

TEST(Misalignment, TiltedPlateShiftsARayByTheClosedForm) {
  // A plane-parallel plate of thickness t and index n tilted by theta displaces a ray parallel
  // to its old normal by t sin(theta) (1 - cos(theta) / sqrt(n^2 - sin^2(theta))), direction
  // unchanged.
  const double t = 6, n = 1.7;
  const std::vector<Row> rows = {{0, 10, 8, 1}, {0, t, 12, n}, {0, 20, 12, 1}};
  TempDir dir;
  dir.write("plate.json", lensJson(rows));
  for (const char* axis : {"x", "y"})
    for (double deg : {-20.0, 5.0, 30.0}) {
      const DesignJob j = readDesignJob(
          dir.write("job.json", job("plate.json", "[0]", "rms_spot", "none", 1,
                                    std::string("{\"type\": \"tilt\", \"axis\": \"") + axis +
                                        "\", \"element\": 1, \"delta\": 40}")));
      const LensPrescription p =
          applyTolerance(toleranceNominal(j), j.tolerance.tolerances[0], deg);
      const PlacedLens lens(p, 587.56);
      const Ray in{{0.3, -0.2, -5}, {0, 0, 1}};
      const TraceResult r = lens.trace(in);
      ASSERT_TRUE(r.ok());
      EXPECT_NEAR(r.ray.direction.x, 0, 1e-14);
      EXPECT_NEAR(r.ray.direction.y, 0, 1e-14);
      const double th = deg * std::numbers::pi / 180, s = std::sin(th);
      const double expected = t * s * (1 - std::cos(th) / std::sqrt(n * n - s * s));
      // Tilting about x turns the plate's normal toward -y for a positive angle (right-handed),
      // so the ray moves toward -y; about y, toward +x.
      const double shift =
          axis[0] == 'x' ? -(r.ray.origin.y - in.origin.y) : r.ray.origin.x - in.origin.x;
      const double other =
          axis[0] == 'x' ? r.ray.origin.x - in.origin.x : r.ray.origin.y - in.origin.y;
      EXPECT_NEAR(shift, expected, 1e-12) << axis << " " << deg;
      EXPECT_NEAR(other, 0, 1e-13);
    }
}

// A symmetric biconvex singlet behind a stop in front of it.
const std::vector<Row> kSymmetric = {{0, 4, 6, 1}, {60, 5, 12, 1.5168}, {-60, 55, 12, 1}};

TEST(Misalignment, SpotOfASymmetricLensIsEvenInTheDecentre) {
  TempDir dir;
  dir.write("sym.json", lensJson(kSymmetric));
  const std::string tols =
      "{\"type\": \"decentre\", \"axis\": \"x\", \"element\": 1, \"delta\": 0.1},\n"
      "{\"type\": \"decentre\", \"axis\": \"y\", \"element\": 1, \"delta\": 0.1},\n"
      "{\"type\": \"tilt\", \"axis\": \"y\", \"element\": 1, \"delta\": 0.5},\n"
      "{\"type\": \"tilt\", \"axis\": \"x\", \"surface\": 2, \"delta\": 0.5}";
  // On axis every decentre and tilt is even: the lens turned by 180 degrees about the axis.
  const ToleranceResult axial = runTolerancing(readDesignJob(
      dir.write("a.json", job("sym.json", "[0]", "rms_spot", "back_focus", 1, tols))));
  for (const SensitivityRow& row : axial.sensitivity) {
    EXPECT_GT(row.plus, 1e-3 * axial.nominal) << row.label;
    EXPECT_NEAR(row.plus, row.minus, 1e-7 * row.plus) << row.label;
  }
  // A field along x: decentre and tilt across the field plane stay even (the mirror y -> -y);
  // within it they are not (coma of the decentred lens adds to or takes from the field's).
  const ToleranceResult field = runTolerancing(readDesignJob(
      dir.write("f.json", job("sym.json", "[6]", "rms_spot", "back_focus", 1, tols))));
  EXPECT_GT(std::abs(field.sensitivity[0].plus - field.sensitivity[0].minus),
            0.05 * std::abs(field.sensitivity[0].plus));
  // The per-field RMS spots (one compensated film) make up the criterion: the root of their mean
  // square.
  const ToleranceResult two = runTolerancing(readDesignJob(
      dir.write("t.json", job("sym.json", "[0, 6]", "rms_spot", "back_focus", 1, tols))));
  auto rootMeanSquare = [](const std::vector<double>& v) {
    double s2 = 0;
    for (double x : v) s2 += x * x;
    return std::sqrt(s2 / double(v.size()));
  };
  ASSERT_EQ(two.nominal_fields.size(), 2u);
  // The film is best for both fields, so the axial spot is no smaller than at its own best film.
  EXPECT_GE(two.nominal_fields[0], axial.nominal);
  EXPECT_NEAR(rootMeanSquare(two.nominal_fields), two.nominal, 1e-12);
  for (const SensitivityRow& row : two.sensitivity) {
    EXPECT_NEAR(rootMeanSquare(row.fields_plus), two.nominal + row.plus, 1e-12) << row.label;
    EXPECT_NEAR(rootMeanSquare(row.fields_minus), two.nominal + row.minus, 1e-12) << row.label;
  }
  EXPECT_NEAR(field.sensitivity[1].plus, field.sensitivity[1].minus,
              1e-7 * std::abs(field.sensitivity[1].plus));
  EXPECT_GT(std::abs(field.sensitivity[2].plus - field.sensitivity[2].minus),
            0.05 * std::abs(field.sensitivity[2].plus));
  EXPECT_NEAR(field.sensitivity[3].plus, field.sensitivity[3].minus,
              1e-7 * std::abs(field.sensitivity[3].plus));
}

TEST(Misalignment, MonteCarloIsReproducibleBySeedAndBuildsKeepTheirCriterion) {
  TempDir dir;
  dir.write("sym.json", lensJson(kSymmetric));
  const std::string tols =
      "{\"type\": \"decentre\", \"axis\": \"x\", \"element\": 1, \"delta\": 0.05, "
      "\"distribution\": \"normal\"},\n"
      "{\"type\": \"tilt\", \"axis\": \"y\", \"element\": 1, \"delta\": 0.3},\n"
      "{\"type\": \"thickness\", \"surface\": 1, \"delta\": 0.1, \"distribution\": "
      "\"end_point\"},\n"
      "{\"type\": \"radius\", \"surface\": 2, \"delta\": 0.5}";
  const DesignJob j = readDesignJob(
      dir.write("j.json", job("sym.json", "[0, 5]", "rms_spot", "back_focus", 11, tols, 40)));
  const ToleranceResult a = runTolerancing(j), b = runTolerancing(j);
  EXPECT_EQ(a.builds, b.builds);
  EXPECT_GT(a.stddev, 0.01 * a.nominal);
  const DesignJob other = readDesignJob(
      dir.write("k.json", job("sym.json", "[0, 5]", "rms_spot", "back_focus", 12, tols, 40)));
  EXPECT_NE(runTolerancing(other).builds, a.builds);
  // An as-built lens (compensated image surface included) has its build's criterion, and the
  // compensator finds nothing more to move.
  for (int k : {0, 7}) {
    const LensPrescription p = asBuiltLens(j, k);
    ASSERT_TRUE(p.noncoaxial_loc);
    double dz = 1;
    EXPECT_NEAR(toleranceCriterion(j, p, &dz), a.builds[size_t(k)], 1e-9 * a.builds[size_t(k)]);
    EXPECT_NEAR(dz, 0, 1e-9);
  }
  // Boresight: decentres move the image, so builds have a non-zero boresight; seeds reproduce.
  const DesignJob bj = readDesignJob(
      dir.write("b.json", job("sym.json", "[0, 5]", "boresight", "back_focus", 11, tols, 20)));
  const ToleranceResult c = runTolerancing(bj), e = runTolerancing(bj);
  EXPECT_EQ(c.builds, e.builds);
  EXPECT_NEAR(c.nominal, 0, 1e-12);
  EXPECT_GT(c.mean, 1e-3);
}

// A cemented doublet and a singlet with model glasses (which a .zmx file can state).
const char* kGlassLens = R"({"format": "lensim-lens", "version": 1, "units": "mm", "name": "two",
  "wavelengths_nm": [486.13, 587.56, 656.27], "primary_wavelength_nm": 587.56, "surfaces": [
  {"radius_mm": 0, "thickness_mm": 3, "semi_aperture_mm": 5, "stop": true},
  {"radius_mm": 40, "thickness_mm": 5, "semi_aperture_mm": 10, "glass": {"n_d": 1.62, "v_d": 60.3}},
  {"radius_mm": -30, "thickness_mm": 2, "semi_aperture_mm": 10, "glass": {"n_d": 1.72, "v_d": 29.5}},
  {"radius_mm": -200, "thickness_mm": 6, "semi_aperture_mm": 10},
  {"radius_mm": 60, "thickness_mm": 4, "semi_aperture_mm": 10, "glass": {"n_d": 1.5168, "v_d": 64.17},
   "conic": -0.5, "aspheric": {"4": 1e-6, "6": -2e-9}},
  {"radius_mm": 0, "thickness_mm": 40, "semi_aperture_mm": 10}]})";

TEST(Misalignment, AsBuiltLensWrittenAsZmxReadsBackWithTheSameTraces) {
  TempDir dir;
  dir.write("two.json", kGlassLens);
  const std::string tols =
      "{\"type\": \"decentre\", \"axis\": \"x\", \"element\": 1, \"delta\": 0.1},\n"
      "{\"type\": \"tilt\", \"axis\": \"y\", \"element\": 1, \"delta\": 1.5},\n"
      "{\"type\": \"tilt\", \"axis\": \"x\", \"element\": 4, \"delta\": 2},\n"
      "{\"type\": \"decentre\", \"axis\": \"y\", \"surface\": 5, \"delta\": 0.2},\n"
      "{\"type\": \"thickness\", \"surface\": 3, \"delta\": 0.5}";
  const DesignJob j = readDesignJob(
      dir.write("j.json", job("two.json", "[0, 4]", "rms_spot", "back_focus", 5, tols, 3)));
  for (int k = 0; k < 3; ++k) {
    const LensPrescription built = asBuiltLens(j, k);
    const std::string zmx = writeLensZmx(built);
    EXPECT_NE(zmx.find("TYPE COORDBRK"), std::string::npos);
    const LensPrescription back = readLensFile(dir.write("b.zmx", zmx));
    ASSERT_TRUE(back.noncoaxial_loc);
    ASSERT_EQ(back.surfaces.size(), built.surfaces.size());
    for (size_t i = 0; i < built.surfaces.size(); ++i) {
      const LensSurface &a = built.surfaces[i], &b = back.surfaces[i];
      EXPECT_NEAR(a.radius_mm, b.radius_mm, 1e-12 * std::abs(a.radius_mm)) << i;
      EXPECT_EQ(a.shape.conic, b.shape.conic);
      EXPECT_EQ(a.glass.n_d, b.glass.n_d);
      EXPECT_EQ(a.isStop(), b.isStop());
      for (int r = 0; r < 3; ++r) {
        EXPECT_NEAR(a.frame->origin_mm[r], b.frame->origin_mm[r], 1e-12) << i;
        for (int c = 0; c < 3; ++c)
          EXPECT_NEAR(a.frame->rotation[r][c], b.frame->rotation[r][c], 1e-14) << i;
      }
    }
    for (int r = 0; r < 3; ++r)
      EXPECT_NEAR(built.image_frame.origin_mm[r], back.image_frame.origin_mm[r], 1e-12);
    for (double nm : {486.13, 656.27}) {
      const PlacedLens pa(built, nm), pb(back, nm);
      for (double h : {-3.0, 0.0, 2.5}) {
        const Ray in{{h, 0.7 * h, -5}, normalize(Vec3{0.05, -0.02, 1})};
        const TraceResult ra = pa.trace(in), rb = pb.trace(in);
        ASSERT_TRUE(ra.ok() && rb.ok());
        EXPECT_NEAR(ra.ray.origin.x, rb.ray.origin.x, 1e-10);
        EXPECT_NEAR(ra.ray.origin.y, rb.ray.origin.y, 1e-10);
        EXPECT_NEAR(ra.ray.direction.x, rb.ray.direction.x, 1e-12);
      }
    }
  }
  // The nominal (coaxial) lens: no breaks, the rows as they were.
  const std::string zmx = writeLensZmx(j.start);
  EXPECT_EQ(zmx.find("COORDBRK"), std::string::npos);
  const LensPrescription back = readLensFile(dir.write("n.zmx", zmx));
  ASSERT_FALSE(back.noncoaxial_loc);
  ASSERT_EQ(back.surfaces.size(), j.start.surfaces.size());
  for (size_t i = 0; i < back.surfaces.size(); ++i) {
    EXPECT_NEAR(back.surfaces[i].thickness_mm, j.start.surfaces[i].thickness_mm, 1e-12);
    EXPECT_NEAR(back.surfaces[i].semiAperture_mm(), j.start.surfaces[i].semiAperture_mm(), 1e-12);
    EXPECT_EQ(back.surfaces[i].shape.poly, j.start.surfaces[i].shape.poly);
  }
  // A medium with an index and no dispersion cannot be stated: refused, naming the surface.
  dir.write("sym.json", lensJson(kSymmetric));
  try {
    writeLensZmx(readLensFile((dir.path / "sym.json").string()));
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("surface 1 cannot be written to .zmx: the medium after it "
                                         "has index 1.5168 and no dispersion"),
              std::string::npos)
        << e.what();
  }
}

TEST(Misalignment, ThirdPartyZmxFilesRewrittenKeepTheirRays) {
  // OpticStudio files with coordinate breaks (a tilted lens, a system folded with decentres) and
  // coaxial ones, written by writeLensZmx and read back: the same surfaces, frames and spots.
  TempDir dir;
  const std::string zmx = std::string(LENSIM_SHARED_DIR) + "/lenses/zmx/";
  for (const char* name : {"HoO-V2C18Ex66.zmx", "optiland/complicated_fold_mirrors_setup_v2.zmx",
                           "US00583336-2-scaled.zmx", "optiland/lens1.zmx"}) {
    const LensPrescription a = readLensFile(zmx + name);
    const LensPrescription b = readLensFile(dir.write("re.zmx", writeLensZmx(a)));
    ASSERT_EQ(a.surfaces.size(), b.surfaces.size()) << name;
    ASSERT_EQ(a.noncoaxial_loc.has_value(), b.noncoaxial_loc.has_value()) << name;
    for (size_t i = 0; i < a.surfaces.size(); ++i) {
      EXPECT_EQ(a.surfaces[i].radius_mm, b.surfaces[i].radius_mm) << name << " " << i;
      EXPECT_EQ(a.surfaces[i].glass.name, b.surfaces[i].glass.name) << name << " " << i;
      EXPECT_EQ(a.surfaces[i].ior, b.surfaces[i].ior) << name << " " << i;
      EXPECT_EQ(a.surfaces[i].semiAperture_mm(), b.surfaces[i].semiAperture_mm())
          << name << " " << i;
      if (!a.noncoaxial_loc) {
        EXPECT_NEAR(a.surfaces[i].thickness_mm, b.surfaces[i].thickness_mm, 1e-12)
            << name << " " << i;
      }
    }
    if (!a.noncoaxial_loc) continue;
    for (size_t i = 0; i < a.surfaces.size(); ++i)
      for (int r = 0; r < 3; ++r) {
        EXPECT_NEAR(a.surfaces[i].frame->origin_mm[r], b.surfaces[i].frame->origin_mm[r], 1e-9)
            << name;
        for (int c = 0; c < 3; ++c)
          EXPECT_NEAR(a.surfaces[i].frame->rotation[r][c], b.surfaces[i].frame->rotation[r][c],
                      1e-14);
      }
    const PlacedLens la(a, 587.56), lb(b, 587.56);
    const auto sa = la.spot({true, 0, 1, {}}), sb = lb.spot({true, 0, 1, {}});
    ASSERT_TRUE(sa && sb) << name;
    EXPECT_EQ(sa->rays, sb->rays) << name;
    EXPECT_NEAR(sa->rms_mm, sb->rms_mm, 1e-9) << name;
    EXPECT_NEAR(sa->centroid.y, sb->centroid.y, 1e-9) << name;
  }
}

TEST(Misalignment, JobErrorsNameTheLineAndValue) {
  TempDir dir;
  dir.write("sym.json", lensJson(kSymmetric));
  auto err = [&](const std::string& criterion, const std::string& tol) {
    try {
      readDesignJob(dir.write("bad.json", job("sym.json", "[0]", criterion, "none", 1, tol)));
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(err("rms_spot", "{\"type\": \"tilt\", \"element\": 1, \"delta\": 0.1}")
                .find("bad.json:4:1: error: \"axis\" missing: expected \"x\" or \"y\""),
            std::string::npos)
      << err("rms_spot", "{\"type\": \"tilt\", \"element\": 1, \"delta\": 0.1}");
  EXPECT_NE(
      err("rms_spot", "{\"type\": \"decentre\", \"axis\": \"z\", \"element\": 1, \"delta\": 0.1}")
          .find("\"axis\" \"z\": expected"),
      std::string::npos);
  EXPECT_NE(
      err("rms_spot", "{\"type\": \"decentre\", \"axis\": \"x\", \"element\": 2, \"delta\": 0.1}")
          .find("\"element\" 2: the medium after that row is air"),
      std::string::npos);
  EXPECT_NE(err("rms_spot",
                "{\"type\": \"decentre\", \"axis\": \"x\", \"element\": 1, \"surface\": 1, "
                "\"delta\": 0.1}")
                .find("either \"element\""),
            std::string::npos);
  EXPECT_NE(
      err("rms_spot", "{\"type\": \"decentre\", \"axis\": \"x\", \"element\": 1, \"delta\": 7}")
          .find("\"delta\" 7 must be > 0 and below 6 mm"),
      std::string::npos)
      << err("rms_spot", "{\"type\": \"decentre\", \"axis\": \"x\", \"element\": 1, \"delta\": 7}");
  EXPECT_NE(err("efl", "{\"type\": \"tilt\", \"axis\": \"x\", \"element\": 1, \"delta\": 0.1}")
                .find("bad.json:4:1: error: a decentre or tilt makes the lens non-coaxial"),
            std::string::npos)
      << err("efl", "{\"type\": \"tilt\", \"axis\": \"x\", \"element\": 1, \"delta\": 0.1}");
}

}  // namespace

TEST(Misalignment, BoresightReferenceComputedOnceGivesTheSameCriterion) {
  // runTolerancing measures every lens against the nominal on-axis image point computed once
  // (criterionReference); each value must equal the per-evaluation path (which traces the
  // nominal lens again) exactly, and the test's own evaluation: the 0-degree chief ray on the
  // film moved by -sum(b)/sum(c) of the job fields' spot quadratics, against the nominal's.
  TempDir dir;
  dir.write("sym.json", lensJson(kSymmetric));
  const std::string tols =
      "{\"type\": \"decentre\", \"axis\": \"x\", \"element\": 1, \"delta\": 0.05},\n"
      "{\"type\": \"tilt\", \"axis\": \"y\", \"element\": 1, \"delta\": 0.3},\n"
      "{\"type\": \"radius\", \"surface\": 2, \"delta\": 0.5}";
  for (const char* comp : {"back_focus", "none"}) {
    const DesignJob j = readDesignJob(
        dir.write("b.json", job("sym.json", "[0, 5]", "boresight", comp, 5, tols, 12)));
    auto point = [&](const LensPrescription& p) {
      double b = 0, c = 0;
      for (double f : j.fields_deg) {
        const SpotQuadratic q = placedBeam(p, f, 587.56, 587.56, j.rings).spot;
        b += q.b, c += q.c;
      }
      const PlacedBeam beam = placedBeam(p, 0, 587.56, 587.56, 1);
      const double dz = j.tolerance.back_focus_compensator ? -b / c : 0;
      return beam.chief + beam.chief_slope * dz;
    };
    const LensPrescription nominal = toleranceNominal(j);
    const Vec2 p0 = point(nominal);
    const ToleranceResult r = runTolerancing(j);
    EXPECT_EQ(r.nominal, 0) << comp;
    ASSERT_EQ(r.builds.size(), 12u);
    for (int k = 0; k < 12; ++k) {
      LensPrescription p = nominal;
      for (size_t i = 0; i < j.tolerance.tolerances.size(); ++i)
        p = applyTolerance(p, j.tolerance.tolerances[i],
                           drawTolerance(j.tolerance.tolerances[i], 5, k, int(i)));
      EXPECT_EQ(r.builds[size_t(k)], toleranceCriterion(j, p)) << comp << " build " << k;
      const Vec2 pk = point(p);
      EXPECT_NEAR(r.builds[size_t(k)], std::hypot(pk.x - p0.x, pk.y - p0.y), 1e-12)
          << comp << " build " << k;
    }
    EXPECT_GT(r.mean, 1e-3) << comp;  // the decentre moves the image: the values are not all 0
    for (size_t i = 0; i < j.tolerance.tolerances.size(); ++i)
      EXPECT_EQ(r.sensitivity[i].plus,
                toleranceCriterion(j, applyTolerance(nominal, j.tolerance.tolerances[i],
                                                     j.tolerance.tolerances[i].delta)))
          << comp << " row " << i;
  }
}
