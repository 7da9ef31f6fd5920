// Zemax files as they come (issue 28): automatic semi-diameters against OpticStudio's own values
// and a closed form, refusals at the line, and the outcome of every file of the shared corpus.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <regex>
#include <sstream>

#include "lensim/optics/lens_formats.h"
#include "lensim/optics/lens_system.h"
#include "lensim/optics/placed_lens.h"
#include "lensim/optics/paraxial.h"
#include "lensim/util/error.h"
#include "test_paths.h"

using namespace lensim;
using namespace lensim::optics;

namespace {

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string zmxDir() {
  return std::string(LENSIM_SHARED_DIR) + "/lenses/zmx/";
}

std::vector<std::string> linesOf(const std::string& text) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : text) {
    if (c == '\n') {
      out.push_back(cur);
      cur.clear();
    } else if (c != '\r') {
      cur += c;
    }
  }
  if (!cur.empty()) out.push_back(cur);
  return out;
}

std::vector<std::string> words(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> w;
  for (std::string s; in >> s;) w.push_back(s);
  return w;
}

// n_d of the glasses the corpus names, from the vendors' catalogues (Schott optical glass
// data sheets 2017/2023, Ohara catalogue 2023): independent of lensim's glass table.
const std::map<std::string, double> kPublishedNd = {
    {"N-SK4", 1.61272},  {"SF1", 1.71736},     {"S-LAH64", 1.78800},
    {"N-BAK1", 1.57250}, {"N-BALF4", 1.57956}, {"N-SK16", 1.62041},
    {"N-SF2", 1.64769},  {"N-LAK9", 1.69100},  {"N-BK7", 1.51680},
    {"L-BAL35", 1.58913}, {"B270", 1.5230}};  // B 270: Schott's B 270 technical details

// An independent paraxial (y, nu) trace of a .zmx file's surfaces at the d line: curvatures
// (with EVENASPH PARM 1, the r^2 term, adding 2 a_1), signed thicknesses, n_d from the table
// above, mirrors by n -> -n. Returns the EFL in mm (object at infinity, in air).
double independentEfl(const std::string& text) {
  struct S {
    double c = 0, t = 0, n = 1;
    bool mirror = false, evenasph = false;
    double a1 = 0;
  };
  std::vector<S> surfs;
  double unit = 1;
  for (const std::string& line : linesOf(text)) {
    const auto w = words(line);
    if (w.empty()) continue;
    if (w[0] == "UNIT") unit = w[1] == "IN" ? 25.4 : w[1] == "CM" ? 10 : w[1] == "M" ? 1000 : 1;
    if (w[0] == "SURF") surfs.push_back({});
    if (surfs.empty()) continue;
    S& s = surfs.back();
    if (w[0] == "CURV") s.c = std::stod(w[1]);
    if (w[0] == "DISZ" && w[1] != "INFINITY") s.t = std::stod(w[1]);
    if (w[0] == "TYPE") s.evenasph = w[1] == "EVENASPH";
    if (w[0] == "PARM" && w[1] == "1") s.a1 = std::stod(w[2]);
    if (w[0] == "GLAS") {
      if (w[1] == "MIRROR") {
        s.mirror = true;
      } else {
        const auto it = kPublishedNd.find(w[1]);
        if (it == kPublishedNd.end()) throw std::runtime_error("no published n_d for " + w[1]);
        s.n = it->second;
      }
    }
  }
  double y = 1, nu = 0, n = 1;  // signed index
  for (size_t k = 1; k + 1 < surfs.size(); ++k) {
    const S& s = surfs[k];
    const double c = (s.c + (s.evenasph ? 2 * s.a1 : 0.0)) / unit;
    const double n_after = s.mirror ? -n : (n > 0 ? 1 : -1) * s.n;
    nu -= y * c * (n_after - n);
    n = n_after;
    y += s.t * unit * nu / n;
  }
  return -1 / nu;
}

// lensim's EFL of a lens at the d line.
double lensimEfl(const LensPrescription& p) {
  return computeParaxial(LensSystem(p).atWavelength(587.5618)).effective_focal_length_mm;
}

}  // namespace

// OpticStudio computed the semi-diameters of the Laikin wide-angle lens in the optiland sample
// (DIAM lines with the automatic solve) with ray aiming on: with them removed (DIAM 0), lensim
// computes them again. Surface 10 (with a CLAP) and the stop keep theirs.
TEST(ZmxAutoSemiDiameter, ReproducesOpticStudiosValues) {
  const std::string path = zmxDir() + "optiland/circular_aperture_example_with_aperture.zmx";
  const std::string text = decodeTextFile(slurp(path), path);
  std::map<int, double> zemax;  // surface -> semi-diameter in inches
  std::string edited;
  int surf = -1;
  for (std::string line : linesOf(text)) {
    const auto w = words(line);
    if (!w.empty() && w[0] == "SURF") surf = std::stoi(w[1]);
    if (!w.empty() && w[0] == "DIAM" && surf >= 2 && surf <= 17 && surf != 10 && surf != 11) {
      zemax[surf] = std::stod(w[1]);
      line = "  DIAM 0 0 0 0 1 \"\"";
    }
    edited += line + "\n";
  }
  ASSERT_EQ(zemax.size(), 14u);
  const LensPrescription p = parseZmx(edited, "laikin.zmx");
  // Rows: surface k is row k - 1 (a plane stop adds none).
  for (const auto& [k, semi_in] : zemax) {
    SCOPED_TRACE(fmt::format("surface {}", k));
    EXPECT_NEAR(p.surfaces[size_t(k - 1)].semiAperture_mm() / 25.4, semi_in, 2e-5 * semi_in);
  }
  int notes = 0;
  for (const Diagnostic& d : p.diagnostics)
    notes += d.message.find("computed from real rays") != std::string::npos;
  EXPECT_EQ(notes, 15);  // the 14 above and surface 1 (DIAM 0 in the file)
}

// Without ray aiming, in closed form: a stop at the front (ENPD 10 mm) and a glass plate 20 mm
// behind it, field 10 degrees. Rays through the pupil's edge meet the plate's front at most
// d tan(theta) + r from the axis, and its back at (d tan(theta) + t tan(theta')) + r, with
// sin(theta') = sin(theta) / n (the d line, where the model glass has its n_d).
TEST(ZmxAutoSemiDiameter, PlateBehindAStopInClosedForm) {
  const double n = 1.5, d = 20, t = 5, theta = 10 * M_PI / 180, r = 5;
  const std::string zmx = fmt::format(
      "MODE SEQ\nUNIT MM\nENPD 10\nFTYP 0 0 2 1 0 0 0\nXFLN 0 0\nYFLN 0 10\nWAVM 1 0.5875618 1\n"
      "PWAV 1\nSURF 0\n  CURV 0\n  DISZ INFINITY\nSURF 1\n  STOP\n  CURV 0\n  DISZ {}\n"
      "SURF 2\n  CURV 0\n  DISZ {}\n  GLAS ___BLANK 1 0 {} 50 0 0 0 0 0 0\nSURF 3\n  CURV 0\n"
      "  DISZ 10\nSURF 4\n  CURV 0.02\n  DISZ 30\n  GLAS ___BLANK 1 0 1.5 50 0 0 0 0 0 0\n"
      "  DIAM 20\nSURF 5\n  CURV 0\n  DISZ 50\n  DIAM 20\nSURF 6\n  CURV 0\n  DISZ 0\n",
      d, t, n);
  const LensPrescription p = parseZmx(zmx, "plate.zmx");
  const double front = d * std::tan(theta) + r;
  const double back = d * std::tan(theta) + t * std::tan(std::asin(std::sin(theta) / n)) + r;
  EXPECT_NEAR(p.surfaces[1].semiAperture_mm(), front, 1e-7);
  EXPECT_NEAR(p.surfaces[2].semiAperture_mm(), back, 1e-7);
  EXPECT_NEAR(p.surfaces[0].semiAperture_mm(), r, 1e-9);  // the stop, from ENPD
}

// Paraxial image-height fields (FTYP 2) of an object at infinity are the angles atan(h / EFL):
// lens1 with its 3 angles written as image heights gives the same semi-diameters.
TEST(ZmxAutoSemiDiameter, ParaxialImageHeightFields) {
  const std::string path = zmxDir() + "optiland/lens1.zmx";
  const std::string text = slurp(path);
  const LensPrescription angles = parseZmx(text, path);
  const double efl = lensimEfl(angles);  // at the d line; the file's primary is the d line too
  std::string heights;
  for (const std::string& line : linesOf(text)) {
    const auto w = words(line);
    if (!w.empty() && w[0] == "FTYP") {
      heights += "FTYP 2 0 3 3 0 0 0\n";
    } else if (!w.empty() && w[0] == "YFLN") {
      heights += "YFLN";
      for (size_t i = 1; i < w.size(); ++i)
        heights += fmt::format(" {:.17g}", efl * std::tan(std::stod(w[i]) * M_PI / 180));
      heights += "\n";
    } else {
      heights += line + "\n";
    }
  }
  const LensPrescription p = parseZmx(heights, path);
  ASSERT_EQ(p.surfaces.size(), angles.surfaces.size());
  for (size_t i = 0; i < p.surfaces.size(); ++i)
    EXPECT_NEAR(p.surfaces[i].semiAperture_mm(), angles.surfaces[i].semiAperture_mm(), 1e-9);
}

TEST(ZmxAutoSemiDiameter, StopWithoutSizeUnderFloaIsRefusedAtItsLine) {
  const std::string zmx =
      "MODE SEQ\nFLOA\nSURF 0\n  DISZ INFINITY\nSURF 1\n  STOP\n  CURV 0\n  DISZ 5\n"
      "SURF 2\n  CURV 0.01\n  DISZ 5\n  GLAS ___BLANK 1 0 1.5 50\n  DIAM 10\nSURF 3\n  DISZ 0\n";
  try {
    parseZmx(zmx, "floa.zmx");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.loc().line, 5);
    EXPECT_NE(e.message().find("FLOA"), std::string::npos) << e.what();
  }
}

// What lensim does not model is refused at the line that asks for it.
// optiland's lens_floa.zmx: a biconvex N-BK7 singlet (R 20 mm, 5 mm thick), the stop 10 mm behind
// it with semi-diameter 8.5 mm under FLOA, no DIAM on the lens. Paraxially the stop images to an
// entrance pupil of radius ~20.24 mm, but the singlet's spherical aberration turns the real rays
// back: their stop height peaks near 1.93 mm and the stop's rim is never reached. OpticStudio
// would trace the paraxial pupil's edge off the lens (no RAIM line: ray aiming off), so the file
// is refused, with the numbers; these come from an independent meridional trace written here.
TEST(ZmxAutoSemiDiameter, FloaStopNoRayFillsIsRefusedWithItsNumbers) {
  const double n = 1.51680, r = 20, t = 5, gap = 10;  // n_d of N-BK7 (Schott)
  // The height at the stop plane of a ray parallel to the axis at height h; nullopt if it misses
  // a sphere or is totally reflected.
  auto stopHeight = [&](double h) -> std::optional<double> {
    // Front sphere, centre at z = r: the hit, its normal (pointing to the centre's side), Snell.
    if (h >= r) return std::nullopt;
    double z = r - std::sqrt(r * r - h * h), y = h;
    double nz = (z - r) / r, ny = y / r;  // outward normal
    auto refract = [](double dz, double dy, double mz, double my, double eta, double& oz,
                      double& oy) {
      double c = -(dz * mz + dy * my);
      if (c < 0) mz = -mz, my = -my, c = -c;
      const double k = 1 - eta * eta * (1 - c * c);
      if (k < 0) return false;
      const double f = eta * c - std::sqrt(k);
      oz = eta * dz + f * mz, oy = eta * dy + f * my;
      return true;
    };
    double dz, dy;
    if (!refract(1, 0, nz, ny, 1 / n, dz, dy)) return std::nullopt;
    // Rear sphere: vertex at z = t, centre at z = t - r; the far intersection.
    const double cz = t - r, oz = z - cz;
    const double b = oz * dz + y * dy, c = oz * oz + y * y - r * r, disc = b * b - c;
    if (disc < 0) return std::nullopt;
    const double s = -b + std::sqrt(disc);
    if (!(s > 0)) return std::nullopt;  // beyond the rims' meeting (9.68 mm): behind the ray
    z += s * dz, y += s * dy;
    nz = (z - cz) / r, ny = y / r;
    double ez, ey;
    if (!refract(dz, dy, nz, ny, n, ez, ey)) return std::nullopt;
    return y + (t + gap - z) * ey / ez;
  };
  // The paraxial pupil radius, the peak of the rising branch and where the rays start failing.
  const double pupil = 8.5 / (*stopHeight(1e-6) / 1e-6);
  double peak = 0, peak_at = 0, fails = 0;
  bool falling = false;
  for (double h = 1e-3; h < pupil; h += 1e-3) {
    const auto y = stopHeight(h);
    if (!y) {
      fails = h;
      break;
    }
    if (!falling && *y >= peak)
      peak = *y, peak_at = h;
    else
      falling = true;
  }
  ASSERT_TRUE(falling);
  ASSERT_GT(fails, 0);
  for (double h = peak_at - 2e-3; h < peak_at + 2e-3; h += 1e-6)
    if (const auto y = stopHeight(h); y && *y > peak) peak = *y, peak_at = h;
  for (double h = fails - 1e-3; h < fails; h += 1e-7)
    if (!stopHeight(h)) {
      fails = h;
      break;
    }
  EXPECT_NEAR(pupil, 20.2366, 1e-3);
  EXPECT_LT(peak, 8.5);

  const std::string path = zmxDir() + "optiland/lens_floa.zmx";
  try {
    parseZmx(slurp(path), path);
    FAIL() << "no error";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_EQ(e.loc().line, 13) << m;  // the front surface, which the pupil's edge ray misses
    std::smatch g;
    ASSERT_TRUE(std::regex_search(
        m, g,
        std::regex("semi-diameter 8.5 mm images to a paraxial entrance pupil of radius ([0-9.]+) "
                   "mm, but real rays parallel to the axis at 587.6 nm, traced outward from the "
                   "axis, meet the stop at most ([0-9.]+) mm from its centre \\(through the "
                   "entrance pupil's plane ([0-9.]+) mm off the axis\\), their stop height "
                   "falling beyond \\(aberration\\), and from ([0-9.]+) mm off the axis they "
                   "miss a surface or are totally reflected: no ray aimed at the paraxial pupil "
                   "or at the stop \\(RAIM\\) fills it; give the stop a DIAM of at most ([0-9.]+) "
                   "mm")))
        << m;
    // The lens scans the pupil in steps of radius / 4000 (5 um): its peak within that.
    EXPECT_NEAR(std::stod(g[1]), pupil, 1e-4 * pupil);
    EXPECT_NEAR(std::stod(g[2]), peak, 1e-4);
    EXPECT_NEAR(std::stod(g[3]), peak_at, 0.01);
    EXPECT_NEAR(std::stod(g[4]), fails, 0.006);
    EXPECT_EQ(g[5], g[2]);
  }
}

TEST(ZmxRefusals, EachAtItsLine) {
  const std::string head = "MODE SEQ\nENPD 5\nSURF 0\n  DISZ INFINITY\nSURF 1\n  STOP\n";
  const std::string tail =
      "  CURV 0\n  DISZ 5\n  DIAM 5\nSURF 2\n  CURV 0.01\n  DISZ 5\n"
      "  GLAS ___BLANK 1 0 1.5 50\n  DIAM 10\nSURF 3\n  DISZ 0\n";
  struct Case {
    std::string line, what;
  };
  const Case cases[] = {
      {"  TYPE COORDBRK", "COORDBRK"}, {"  TYPE BINARY_2", "BINARY_2"},
      {"  TYPE QTYPEASP", "QTYPEASP"}, {"  TYPE SZERNSAG", "SZERNSAG"},
      {"  SQOB 2 3 0", "SQOB"},        {"  ELAP 2 3 0.5", "ELAP"},
      {"  OBSC 1 2 0", "OBSC"},        {"  OBDC 0.5 0", "OBDC"},
      {"  DECX 0 1.5", "DECX"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.line);
    try {
      parseZmx(head + c.line + "\n" + tail, "r.zmx");
      ADD_FAILURE() << "no error";
    } catch (const Error& e) {
      EXPECT_EQ(e.loc().line, 7) << e.what();
      EXPECT_NE(std::string(e.what()).find(c.what), std::string::npos) << e.what();
    }
  }
  for (const char* sys : {"NUMA 0.1"}) {
    SCOPED_TRACE(sys);
    try {
      parseZmx(std::string("MODE SEQ\n") + sys + "\n" + head.substr(9) + tail, "r.zmx");
      ADD_FAILURE() << "no error";
    } catch (const Error& e) {
      EXPECT_EQ(e.loc().line, 2) << e.what();
    }
  }
}

// The system aperture read right: ENPD is the entrance pupil's diameter, FNUM the ratio
// EFL / EPD, FLOA the stop's own size (a stop in front: the pupil is the stop), OBNA the sine
// of the axial marginal ray's angle from a finite object.
TEST(ZmxRefusals, SystemApertureSpecs) {
  const std::string body =
      "SURF 0\n  DISZ INFINITY\nSURF 1\n  STOP\n  CURV 0\n  DISZ 5\n  DIAM 3\nSURF 2\n"
      "  CURV 0.01\n  DISZ 5\n  GLAS ___BLANK 1 0 1.5 50\n  DIAM 10\nSURF 3\n  CURV 0\n"
      "  DISZ 100\n  DIAM 10\nSURF 4\n  DISZ 0\n";
  const double efl = 1 / (0.5 * 0.01);  // plano-convex, thin in power: 200 mm
  auto stopSemi = [&](const std::string& spec) {
    const LensPrescription p = parseZmx("MODE SEQ\n" + spec + "\n" + body, "a.zmx");
    return p.surfaces[0].semiAperture_mm();
  };
  EXPECT_NEAR(stopSemi("ENPD 8"), 4, 1e-12);
  EXPECT_NEAR(stopSemi("FNUM 25"), efl / 25 / 2, 1e-9);
  EXPECT_NEAR(stopSemi("FLOA"), 3, 1e-12);
  // OBNA: a finite object 100 mm in front of the stop (the front surface, so the entrance pupil):
  // the marginal ray at asin(0.1) reaches 100 tan(asin 0.1) from the axis there.
  std::string finite = "MODE SEQ\nOBNA 0.1 0\n" + body;
  finite.replace(finite.find("DISZ INFINITY"), 13, "DISZ 100");
  const LensPrescription p = parseZmx(finite, "na.zmx");
  EXPECT_NEAR(p.surfaces[0].semiAperture_mm(), 100 * std::tan(std::asin(0.1)), 1e-9);
  EXPECT_EQ(p.aperture_spec, "OBNA 0.1");
  // At infinity, or outside (0, 1): refused at the value.
  for (const char* spec : {"OBNA 0.1 0", "OBNA 1.2 0"}) {
    SCOPED_TRACE(spec);
    try {
      parseZmx("MODE SEQ\n" + std::string(spec) + "\n" + body, "na.zmx");
      ADD_FAILURE() << "no error";
    } catch (const Error& e) {
      EXPECT_EQ(e.loc().line, 2) << e.what();
      EXPECT_EQ(e.loc().column, 6) << e.what();
    }
  }
}

// Every file of ../shared/lenses/zmx/ (and optiland/): read with its EFL matching an independent
// paraxial trace, or refused with an error at the named line. A change of outcome fails here.
TEST(ZmxCorpus, EveryFileReadsOrIsRefusedAtItsLine) {
  struct Outcome {
    const char* file;
    int error_line;      // 0: reads
    const char* reason;  // a word of the error, or why the EFL is not checked here
    bool check_efl;
    int noncoaxial_line = 0;  // tilted or decentred: where the axis is lost (reason: a word why)
  };
  const Outcome table[] = {
      // Schott's B 270, tabulated by refractiveindex.info (built-in rii:B270).
      {"ACL3026U-Zemax(ZMX).zmx", 0, "", true},
      {"HoO-V2C18Ex03.zmx", 0, "", true},
      // Mirrors tilted by coordinate breaks (an off-axis reflective system): placed in space.
      {"HoO-V2C18Ex66.zmx", 0, "tilted against the axis", false, 92},
      {"US00583336-2-scaled.zmx", 0, "", true},
      {"US05331467-1.zmx", 0, "placeholder glasses (J-LAK02, ...)", false},
      // An off-axis parabolic mirror: a break decentres it, its CLAP is decentred back onto
      // the beam (OBDC); the image surface is tilted to face the reflected beam (SCBD).
      {"zmax_37992.zmx", 0, "off the axis", false, 94},
      {"optiland/circular_aperture_example_with_aperture.zmx", 0, "", true},
      {"optiland/circular_aperture_example_without_aperture.zmx", 0, "", true},
      // Decentres after its folds: a surface leaves the axis; placed in space.
      {"optiland/complicated_fold_mirrors_setup_v2.zmx", 0, "off the axis", false, 266},
      // Diffraction gratings: not rotationally symmetric, placed in space at their TYPE line.
      {"optiland/curved_reflective_grating.zmx", 0, "diffraction grating", false, 77},
      {"optiland/curved_transmission_grating.zmx", 0, "diffraction grating", false, 102},
      {"optiland/flat_transmission_grating.zmx", 0, "diffraction grating", false, 102},
      {"optiland/lens1.zmx", 0, "", true},
      {"optiland/lens2.zmx", 0, "", true},  // Ohara's moldable L-BAL35
      // FLOA with the stop's semi-diameter 8.5 mm: no real ray reaches the stop's rim (the
      // test above has the numbers).
      {"optiland/lens_floa.zmx", 13, "no ray aimed at the paraxial pupil or at the stop", false},
      {"optiland/lens_thorlabs_iso_8859_1.zmx", 0, "", true},
      // Folds by plane mirrors, afocal (no lens): their twins' power checked below.
      {"optiland/one_mirror_up_45deg.zmx", 0, "afocal", false},
      {"optiland/simple_fold_mirror_up.zmx", 0, "afocal", false},
      // A cylinder (R 2.02 mm in y, flat in x) with a 3 x 2 mm half-width SQAP: the rectangle
      // lies within the cylinder's extent (|y| < 2.02 mm, any x).
      {"optiland/thorlabs_lj1598l1.zmx", 0, "", true},
  };
  // The table covers the folder.
  size_t files = 0;
  for (const auto& dir : {zmxDir(), zmxDir() + "optiland/"})
    for (const auto& e : std::filesystem::directory_iterator(dir))
      files += e.path().extension() == ".zmx";
  EXPECT_EQ(files, std::size(table));

  for (const Outcome& o : table) {
    SCOPED_TRACE(o.file);
    const std::string path = zmxDir() + o.file;
    const std::string bytes = slurp(path);
    ASSERT_FALSE(bytes.empty());
    try {
      const LensPrescription p = parseZmx(bytes, path);
      EXPECT_EQ(o.error_line, 0) << "read, but expected an error at line " << o.error_line;
      EXPECT_EQ(p.noncoaxial_loc.has_value(), o.noncoaxial_line != 0);
      if (p.noncoaxial_loc) {
        // The coaxial tools refuse it at that line; real rays go through it to the image.
        EXPECT_EQ(p.noncoaxial_loc->line, o.noncoaxial_line);
        EXPECT_NE(p.noncoaxial_reason.find(o.reason), std::string::npos) << p.noncoaxial_reason;
        EXPECT_THROW(lensimEfl(p), Error);
        const PlacedLens lens(p, primaryWavelength_nm(p));
        const auto e = lens.aim({}, {0, 0});
        ASSERT_TRUE(e.has_value());
        EXPECT_TRUE(lens.trace(lens.fieldRay({}, *e)).ok());
        continue;
      }
      if (std::string(o.reason) == "afocal") {
        // Folds of plane surfaces only: the twin has every row plane and no power.
        for (const LensSurface& s : p.surfaces) EXPECT_EQ(s.radius_mm, 0.0);
        EXPECT_TRUE(p.fold_loc.has_value());
        EXPECT_THROW(lensimEfl(p), Error);
        continue;
      }
      const double efl = lensimEfl(p);
      if (o.check_efl) {
        const double ref = independentEfl(decodeTextFile(bytes, path));
        EXPECT_NEAR(std::abs(efl), std::abs(ref), 2e-4 * std::abs(ref));
      }
    } catch (const Error& e) {
      EXPECT_EQ(e.loc().line, o.error_line) << e.what();
      EXPECT_NE(std::string(e.what()).find(o.reason), std::string::npos) << e.what();
    }
  }
}
