// Lens file readers: Zemax .zmx, lentil, ISET3d and lensim JSON; conversion; catalogue names.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "lensim/optics/glass/library.h"
#include "lensim/optics/lens_formats.h"
#include "lensim/optics/lens_system.h"
#include "lensim/optics/paraxial.h"
#include "test_paths.h"

using namespace lensim;
using namespace lensim::optics;

namespace {

std::string sharedLens(const std::string& name) {
  return std::string(LENSIM_SHARED_DIR) + "/lenses/" + name;
}

// A small .zmx: a biconvex singlet in the given unit with an aspheric front.
std::string singletZmx(const std::string& unit, double scale) {
  return fmt::format(
      "VERS 1\nMODE SEQ\nNAME test singlet\nUNIT {} X W X CM MR CPMM\nENPD {}\n"
      "WAVM 1 0.5875618 1\nWAVM 2 0.55 1\nPWAV 1\nFTYP 0 0 1 1 0 0 0\n"
      "SURF 0\n  TYPE STANDARD\n  CURV 0.0\n  DISZ INFINITY\nSURF 1\n  STOP\n  TYPE STANDARD\n"
      "  CURV 0.0\n  DISZ {}\n  DIAM {}\nSURF 2\n  TYPE EVENASPH\n  CURV {}\n  PARM 1 0\n"
      "  PARM 2 {}\n  DISZ {}\n  GLAS ___BLANK 1 0 1.6 50 0 0 0 0 0 0\n  CONI -0.5\n  DIAM {}\n"
      "SURF 3\n  TYPE STANDARD\n  CURV {}\n  DISZ {}\n  DIAM {}\nSURF 4\n  TYPE STANDARD\n"
      "  CURV 0\n  DISZ 0\n  DIAM 1\n",
      unit, 10 / scale, 2 / scale, 5 / scale, 0.02 * scale, 1e-6 * scale * scale * scale, 4 / scale,
      10 / scale, -0.01 * scale, 45 / scale, 10 / scale);
}

std::u16string toU16(const std::string& s) {
  std::u16string out;
  for (char c : s) out += char16_t(static_cast<unsigned char>(c));
  return out;
}

std::string utf16Bytes(const std::string& ascii, bool little_endian) {
  std::string b = little_endian ? std::string("\xFF\xFE") : std::string("\xFE\xFF");
  for (char16_t c : toU16(ascii)) {
    const char lo = char(c & 0xFF), hi = char(c >> 8);
    if (little_endian)
      b += lo, b += hi;
    else
      b += hi, b += lo;
  }
  return b;
}

}  // namespace

TEST(ZmxReader, ReadsSurfacesUnitsAspheresAndTheSystemAperture) {
  const LensPrescription p = parseZmx(singletZmx("MM", 1), "t.zmx");
  ASSERT_EQ(p.surfaces.size(), 3u);
  EXPECT_EQ(p.name, "test singlet");
  EXPECT_TRUE(p.surfaces[0].isStop());
  EXPECT_EQ(p.surfaces[0].loc.line, 14);  // the SURF 1 line
  EXPECT_DOUBLE_EQ(p.surfaces[1].radius_mm, 50);
  EXPECT_DOUBLE_EQ(p.surfaces[1].shape.conic, -0.5);
  ASSERT_GE(p.surfaces[1].shape.poly.size(), 5u);
  EXPECT_DOUBLE_EQ(p.surfaces[1].shape.poly[4], 1e-6);
  EXPECT_DOUBLE_EQ(p.surfaces[1].ior, 1.6);
  EXPECT_TRUE(p.surfaces[1].glass.name.empty());  // ___BLANK: a model glass
  EXPECT_DOUBLE_EQ(*p.surfaces[1].glass.n_d, 1.6);
  EXPECT_DOUBLE_EQ(*p.surfaces[1].glass.v_d, 50);
  EXPECT_DOUBLE_EQ(p.surfaces[2].radius_mm, -100);
  EXPECT_DOUBLE_EQ(p.surfaces.back().thickness_mm, 45);
  ASSERT_EQ(p.wavelengths_nm.size(), 1u);  // FTYP: one wavelength in use
  EXPECT_NEAR(*p.primary_wavelength_nm, 587.5618, 1e-9);
  // ENPD 10 with the stop in front: the stop's diameter is the entrance pupil's.
  EXPECT_NEAR(p.surfaces[0].aperture_diameter_mm, 10, 1e-12);
}

TEST(ZmxReader, UnitsScaleEveryLength) {
  const LensPrescription mm = parseZmx(singletZmx("MM", 1), "a.zmx");
  for (auto [unit, scale] : {std::pair{"CM", 10.0}, {"IN", 25.4}, {"M", 1000.0}}) {
    const LensPrescription p = parseZmx(singletZmx(unit, scale), "b.zmx");
    ASSERT_EQ(p.surfaces.size(), mm.surfaces.size()) << unit;
    for (size_t i = 0; i < p.surfaces.size(); ++i) {
      EXPECT_NEAR(p.surfaces[i].radius_mm, mm.surfaces[i].radius_mm, 1e-9) << unit;
      EXPECT_NEAR(p.surfaces[i].thickness_mm, mm.surfaces[i].thickness_mm, 1e-9) << unit;
      EXPECT_NEAR(p.surfaces[i].aperture_diameter_mm, mm.surfaces[i].aperture_diameter_mm, 1e-9);
    }
    EXPECT_NEAR(p.surfaces[1].shape.poly[4], 1e-6, 1e-15) << unit;
  }
}

TEST(ZmxReader, EncodingsAndLineEndingsGiveTheSameLens) {
  const std::string lf = singletZmx("MM", 1);
  std::string crlf;
  for (char c : lf) crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
  const LensPrescription a = parseZmx(lf, "a.zmx");
  for (const std::string& bytes :
       {crlf, utf16Bytes(crlf, true), utf16Bytes(lf, false), std::string("\xEF\xBB\xBF") + lf}) {
    const LensPrescription b = parseZmx(bytes, "b.zmx");
    ASSERT_EQ(a.surfaces.size(), b.surfaces.size());
    for (size_t i = 0; i < a.surfaces.size(); ++i) {
      EXPECT_EQ(a.surfaces[i].radius_mm, b.surfaces[i].radius_mm);
      EXPECT_EQ(a.surfaces[i].loc.line, b.surfaces[i].loc.line);
    }
  }
}

TEST(ZmxReader, UnsupportedThingsAreRefusedAtTheirLine) {
  auto errorOf = [](const std::string& text) {
    try {
      parseZmx(text, "x.zmx");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  std::string base = singletZmx("MM", 1);
  std::string cb = base;
  cb.replace(cb.find("SURF 2\n  TYPE EVENASPH"), 22, "SURF 2\n  TYPE BINARY_2");
  EXPECT_NE(errorOf(cb).find("x.zmx:21:3: error: surface 2: TYPE BINARY_2 is not supported"),
            std::string::npos)
      << errorOf(cb);
  // A coordinate break carries no glass (optics_coordbrk_test.cpp tests the breaks).
  std::string cbg = base;
  cbg.replace(cbg.find("SURF 2\n  TYPE EVENASPH"), 22, "SURF 2\n  TYPE COORDBRK");
  EXPECT_NE(errorOf(cbg).find("a coordinate break has no glass"), std::string::npos)
      << errorOf(cbg);
  // A mirror followed by a positive thickness would send the light backward: refused at DISZ.
  std::string mirror = base;
  mirror.replace(mirror.find("GLAS ___BLANK"), 13, "GLAS MIRROR");
  EXPECT_NE(errorOf(mirror).find("x.zmx:25:8: error: surface 2: thickness 4 is positive after 1 "
                                 "mirror"),
            std::string::npos)
      << errorOf(mirror);
  std::string unit = base;
  unit.replace(unit.find("UNIT MM"), 7, "UNIT FT");
  EXPECT_NE(errorOf(unit).find("x.zmx:4:6: error: unknown lens unit 'FT'"), std::string::npos);
  std::string nsc = base;
  nsc.replace(nsc.find("MODE SEQ"), 8, "MODE NSC");
  EXPECT_NE(errorOf(nsc).find("x.zmx:2:6: error: MODE NSC"), std::string::npos);
}

TEST(ZmxReader, BadUtf16IsALocatedError) {
  std::string bytes = utf16Bytes("MODE SEQ\nSURF 0\n", true);
  bytes += std::string("\x00\xD8", 2);  // a lone high surrogate on line 3
  bytes += "A";
  bytes += '\0';
  try {
    parseZmx(bytes, "u.zmx");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("u.zmx:3: error: malformed UTF-16 LE"), std::string::npos)
        << e.what();
  }
}

TEST(ZmxReader, SharedSamplesReadOrAreRefusedWithReasons) {
  // The refracting and the on-axis mirror samples read (optics_mirror_test.cpp checks the
  // mirror ones); the coordinate-break ones are refused where the unsupported surface is.
  // ACL3026U's glass B270: the built-in rii:B270 (glass_tabulated_test.cpp checks it).
  setModelGlassAllowed(false);
  const LensPrescription acl = readLensFile(sharedLens("zmx/ACL3026U-Zemax(ZMX).zmx"));
  EXPECT_EQ(acl.format, "zmx");
  const LensSystem acl_sys(acl);
  const ParaxialData pa = computeParaxial(acl_sys);
  EXPECT_NEAR(pa.entrance_pupil_diameter_mm, 27.0, 1e-9);  // ENPD 2.7E+1
  const LensPrescription dg = readLensFile(sharedLens("zmx/US00583336-2-scaled.zmx"));
  const ParaxialData pd = computeParaxial(LensSystem(dg));
  EXPECT_NEAR(pd.f_number, 4.5, 1e-9);  // FNUM 4.5
  EXPECT_EQ(dg.wavelengths_nm.size(), 3u);
  EXPECT_NEAR(*dg.primary_wavelength_nm, 587.5618, 1e-9);
  // An off-axis parabola (decentred aperture) and tilted mirrors: read, placed in space; the
  // coaxial system refuses them.
  const LensPrescription oap = readLensFile(sharedLens("zmx/zmax_37992.zmx"));
  EXPECT_TRUE(oap.noncoaxial_loc.has_value());
  EXPECT_THROW(LensSystem{oap}, Error);
  const LensPrescription ex66 = readLensFile(sharedLens("zmx/HoO-V2C18Ex66.zmx"));
  EXPECT_TRUE(ex66.noncoaxial_loc.has_value());
  EXPECT_THROW(LensSystem{ex66}, Error);
  for (const char* f : {"zmx/HoO-V2C18Ex03.zmx", "zmx/US05331467-1.zmx"})
    EXPECT_NO_THROW(readLensFile(sharedLens(f))) << f;
}

TEST(JsonLens, LentilDesignsAllRead) {
  // All 24 designs of lentil's database, by name from the catalogue.
  int n = 0, aspheric = 0, anamorphic = 0;
  for (const char* key : {"0001", "0002", "0003", "0004", "0005", "0006", "0007", "0008",
                          "0009", "0010", "0011", "0012", "0013", "0014", "0015", "0016",
                          "2001", "2002", "2003", "2004", "9991", "9992", "9993", "9994"}) {
    const LensPrescription p = readLensFile(std::string("lentil:") + key);
    EXPECT_EQ(p.format, "lentil");
    // Every design but the single-cylinder test lens 9991 (no power in y) has y-section data.
    if (std::string(key) != "9991") {
      EXPECT_NO_THROW(computeParaxial(LensSystem(p))) << key;
    }
    EXPECT_GT(p.surfaces.size(), 2u) << key;
    for (const auto& s : p.surfaces) {
      aspheric += s.shape.hasPolynomial();
      anamorphic += s.shape.radius_x_mm.has_value();
      EXPECT_GE(s.ior, 1.0);
    }
    ++n;
  }
  EXPECT_EQ(n, 24);
  EXPECT_EQ(aspheric, 4);  // lens 0014's four aspheric surfaces
  EXPECT_GT(anamorphic, 10);
  EXPECT_THROW(readLensFile("lentil:4242"), Error);
}

TEST(JsonLens, LentilAsphereAndGlass) {
  const LensPrescription p = readLensFile("lentil:0014");
  int asph = 0;
  for (const auto& s : p.surfaces)
    if (s.shape.hasPolynomial()) {
      ++asph;
      EXPECT_EQ(s.shape.poly.size(), 11u);  // r^4 .. r^10
    }
  EXPECT_EQ(asph, 4);
  EXPECT_DOUBLE_EQ(*p.surfaces[0].glass.n_d, 1.883);
  EXPECT_DOUBLE_EQ(*p.surfaces[0].glass.v_d, 40.81);
  EXPECT_GT(p.surfaces[0].loc.line, 1);  // located in the database
}

TEST(JsonLens, IsetJsonMatchesTheDatTable) {
  // ISET's JSON double Gauss (tests/data/iset/, from ISET/isetlens).
  const LensPrescription j =
      readLensFile(lensim::test::dataPath("iset/dgauss.77deg.3.5201mm.json"));
  EXPECT_EQ(j.format, "iset-json");
  ASSERT_EQ(j.surfaces.size(), 11u);
  EXPECT_TRUE(j.surfaces[5].isStop());
  EXPECT_EQ(j.surfaces[5].ior, 1.0);
  EXPECT_EQ(j.surfaces[3].loc.line, 24);
}

TEST(JsonLens, LensimJsonRoundTripsEveryFormat) {
  setModelGlassAllowed(true);  // ACL3026U's B270 is in no catalogue (--model-glass)
  const auto tmp = std::filesystem::temp_directory_path() / "lensim_roundtrip.json";
  for (const std::string& src :
       {lensim::test::lensPath("dgauss.50mm.dat"), std::string("lentil:0014"),
        std::string("lentil:2003"), sharedLens("zmx/ACL3026U-Zemax(ZMX).zmx")}) {
    const LensPrescription a = readLensFile(src);
    { std::ofstream(tmp) << writeLensJson(a); }
    const LensPrescription b = readLensFile(tmp.string());
    ASSERT_EQ(a.surfaces.size(), b.surfaces.size()) << src;
    for (size_t i = 0; i < a.surfaces.size(); ++i) {
      EXPECT_EQ(a.surfaces[i].radius_mm, b.surfaces[i].radius_mm);
      EXPECT_EQ(a.surfaces[i].thickness_mm, b.surfaces[i].thickness_mm);
      EXPECT_EQ(a.surfaces[i].ior, b.surfaces[i].ior);
      EXPECT_EQ(a.surfaces[i].isStop(), b.surfaces[i].isStop());
      EXPECT_EQ(a.surfaces[i].shape.conic, b.surfaces[i].shape.conic);
      EXPECT_EQ(a.surfaces[i].shape.radius_x_mm, b.surfaces[i].shape.radius_x_mm);
      EXPECT_EQ(a.surfaces[i].shape.hasPolynomial(), b.surfaces[i].shape.hasPolynomial());
    }
    const double fa = computeParaxial(LensSystem(a)).effective_focal_length_mm;
    const double fb = computeParaxial(LensSystem(b)).effective_focal_length_mm;
    EXPECT_DOUBLE_EQ(fa, fb) << src;
  }
  std::filesystem::remove(tmp);
}

TEST(JsonLens, DatWriterRefusesWhatDatCannotHold) {
  EXPECT_THROW(writeLensDat(readLensFile("lentil:0014")), Error);  // aspheres
  EXPECT_THROW(writeLensDat(readLensFile("lentil:2001")), Error);  // cylinders
  // A spherical zmx lens converts and reads back with the same focal length.
  const LensPrescription z = readLensFile(sharedLens("zmx/US00583336-2-scaled.zmx"));
  const LensPrescription d = parseLensPrescription(writeLensDat(z), "z.dat");
  // The .dat keeps the glasses (columns 5 and 6); compare at the d line (the .dat's wavelength).
  EXPECT_NEAR(computeParaxial(LensSystem(d)).effective_focal_length_mm,
              computeParaxial(LensSystem(z).atWavelength(587.5618)).effective_focal_length_mm,
              1e-6);
}
