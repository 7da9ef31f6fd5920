// Colour of raw DNG files developed by third-party programs and by lensim: a ColorChecker (the
// shared Ohta 1997 reflectances, independent of the Pascale data the colour matrices are fitted
// to), digitised or rendered on Bayer, RGBW, X-Trans and Quad Bayer sensors, developed by LibRaw's
// dcraw_emu, dcraw, darktable-cli and lensim develop to within a mean CIEDE2000 of 3 (CIEDE2000
// written out here from the paper); serve's raw preview against lensim develop.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "cli_run.h"
#include "lensim/io/dng.h"
#include "lensim/io/image.h"
#include "lensim/render/sensor/develop.h"
#include "lensim/render/sensor/raw_output.h"
#include "lensim/render/sensor/sensor_color.h"
#include "lensim/render/sensor/sensor_model.h"
#include "sensor_dng_util.h"

using namespace lensim;
using namespace lensim::render;
using namespace lensim::test::dng;

namespace {

// CIE L*a*b* of XYZ relative to the white (Xn, Yn, Zn).
std::array<double, 3> lab(const Vec3& xyz, const Vec3& white) {
  auto f = [](double t) {
    return t > 216.0 / 24389 ? std::cbrt(t) : (24389.0 / 27 * t + 16) / 116;
  };
  const double fx = f(xyz.x / white.x), fy = f(xyz.y / white.y), fz = f(xyz.z / white.z);
  return {116 * fy - 16, 500 * (fx - fy), 200 * (fy - fz)};
}

// CIEDE2000 (Sharma, Wu and Dalal, Color Res. Appl. 30, 2005), written out from the paper.
double deltaE2000(const std::array<double, 3>& p, const std::array<double, 3>& q) {
  const double kPi = M_PI;
  const double L1 = p[0], a1 = p[1], b1 = p[2], L2 = q[0], a2 = q[1], b2 = q[2];
  const double C1 = std::hypot(a1, b1), C2 = std::hypot(a2, b2), Cm = (C1 + C2) / 2;
  const double G = 0.5 * (1 - std::sqrt(std::pow(Cm, 7) / (std::pow(Cm, 7) + std::pow(25.0, 7))));
  const double a1p = (1 + G) * a1, a2p = (1 + G) * a2;
  const double C1p = std::hypot(a1p, b1), C2p = std::hypot(a2p, b2);
  auto hue = [&](double b, double a) {
    if (a == 0 && b == 0) return 0.0;
    double h = std::atan2(b, a) * 180 / kPi;
    return h < 0 ? h + 360 : h;
  };
  const double h1p = hue(b1, a1p), h2p = hue(b2, a2p);
  const double dLp = L2 - L1, dCp = C2p - C1p;
  double dhp = 0;
  if (C1p * C2p != 0) {
    dhp = h2p - h1p;
    if (dhp > 180) dhp -= 360;
    if (dhp < -180) dhp += 360;
  }
  const double dHp = 2 * std::sqrt(C1p * C2p) * std::sin(dhp / 2 * kPi / 180);
  const double Lpm = (L1 + L2) / 2, Cpm = (C1p + C2p) / 2;
  double hpm = h1p + h2p;
  if (C1p * C2p != 0) {
    if (std::abs(h1p - h2p) <= 180)
      hpm = (h1p + h2p) / 2;
    else
      hpm = (h1p + h2p < 360) ? (h1p + h2p + 360) / 2 : (h1p + h2p - 360) / 2;
  }
  const double T = 1 - 0.17 * std::cos((hpm - 30) * kPi / 180) +
                   0.24 * std::cos(2 * hpm * kPi / 180) +
                   0.32 * std::cos((3 * hpm + 6) * kPi / 180) -
                   0.20 * std::cos((4 * hpm - 63) * kPi / 180);
  const double dTheta = 30 * std::exp(-std::pow((hpm - 275) / 25, 2));
  const double Rc = 2 * std::sqrt(std::pow(Cpm, 7) / (std::pow(Cpm, 7) + std::pow(25.0, 7)));
  const double Sl = 1 + 0.015 * std::pow(Lpm - 50, 2) / std::sqrt(20 + std::pow(Lpm - 50, 2));
  const double Sc = 1 + 0.045 * Cpm, Sh = 1 + 0.015 * Cpm * T;
  const double Rt = -std::sin(2 * dTheta * kPi / 180) * Rc;
  return std::sqrt(std::pow(dLp / Sl, 2) + std::pow(dCp / Sc, 2) + std::pow(dHp / Sh, 2) +
                   Rt * (dCp / Sc) * (dHp / Sh));
}

// The 24 patches of the shared Ohta (1997) reflectance table.
std::vector<PiecewiseLinearSpectrum> ohtaPatches() {
  std::ifstream in(std::string(LENSIM_SHARED_DIR) + "/data/colorchecker/colorchecker-ohta1997.csv");
  std::vector<double> lambda;
  std::vector<std::vector<double>> refl(24);
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::string v;
    std::getline(ss, v, ',');
    lambda.push_back(std::stod(v));
    for (int i = 0; i < 24 && std::getline(ss, v, ','); ++i) refl[size_t(i)].push_back(std::stod(v));
  }
  std::vector<PiecewiseLinearSpectrum> out;
  for (const auto& r : refl) out.emplace_back(lambda, r);
  return out;
}

class Product final : public Spectrum {
 public:
  Product(const Spectrum& a, const Spectrum& b) : a_(a), b_(b) {}
  double eval(double l) const override { return a_.eval(l) * b_.eval(l); }
  double maxValue() const override { return a_.maxValue() * b_.maxValue(); }

 private:
  const Spectrum &a_, &b_;
};

// The chart lit by D65 as a sensor with the CFA `cfa` records it (noise on), written as a DNG,
// developed by LibRaw's dcraw_emu (as-shot white balance, AHD demosaic for three colours, VNG for
// four, the DNG's ColorMatrix2 to linear sRGB), against the patches' colours computed here from
// the same reflectances and the CIE 1931 observer; exposure normalised on the white patch. The
// mean CIEDE2000 over the 24 patches, and the largest in `worst`.
double dcrawEmuChartDeltaE(const std::string& cfa, double* worst_out) {
  const std::vector<PiecewiseLinearSpectrum> patches = ohtaPatches();
  EXPECT_EQ(patches.size(), 24u);
  if (patches.size() != 24) return 1e9;
  const std::shared_ptr<const Spectrum> d65 = daylightIlluminant(6500);
  SensorConfig cfg;
  cfg.cfa = cfa;
  cfg.seed = 3;
  const SensorModel m(cfg);
  const auto white = m.expectedElectrons(Product(patches[18], *d65));
  // The white patch at 40000 e- in its brightest pixel (a W pixel: the channels' sum).
  const double scale = 40000 / (m.cfa().hasW() ? white[0] + white[1] + white[2]
                                               : std::max({white[0], white[1], white[2]}));
  const int p = 24, w = 6 * p, h = 4 * p;
  io::Image im(w, h, {"R", "G", "B"});
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const auto e = m.expectedElectrons(Product(patches[size_t((y / p) * 6 + x / p)], *d65));
      for (int c = 0; c < 3; ++c) im.at(x, y, c) = float(e[size_t(c)] * scale);
    }
  im.metadata[kRawSensorKey] = cfg.toText();
  const std::string dir = tmpDir("colour");
  const std::string path = dir + "/chart.dng";
  writeRawImage(path, im, 0, 0);
  int st = -1;
  const std::string log = run("dcraw_emu -w -o 1 -4 -q 3 -T " + path, &st);
  EXPECT_EQ(st, 0) << log;
  const io::Image dev = io::readImage(path + ".tiff");
  EXPECT_EQ(dev.width, w);
  EXPECT_EQ(dev.height, h);
  if (dev.width != w || dev.height != h) return 1e9;
  // Linear sRGB to XYZ (IEC 61966-2-1).
  auto toXyz = [](double r, double g, double b) {
    return Vec3{0.4124 * r + 0.3576 * g + 0.1805 * b, 0.2126 * r + 0.7152 * g + 0.0722 * b,
                0.0193 * r + 0.1192 * g + 0.9505 * b};
  };
  std::vector<Vec3> got, want;
  const ConstantSpectrum one(1.0);
  const Vec3 wn = spectrumToXyz(Product(one, *d65));
  for (int k = 0; k < 24; ++k) {
    double s[3] = {0, 0, 0};
    int n = 0;
    for (int y = (k / 6) * p + 6; y < (k / 6) * p + p - 6; ++y)
      for (int x = (k % 6) * p + 6; x < (k % 6) * p + p - 6; ++x, ++n)
        for (int c = 0; c < 3; ++c) s[c] += dev.at(x, y, c);
    got.push_back(toXyz(s[0] / n, s[1] / n, s[2] / n));
    want.push_back(spectrumToXyz(Product(patches[size_t(k)], *d65)) / wn.y);
  }
  const double expose = want[18].y / got[18].y;
  const Vec3 white_ref = wn / wn.y;
  double sum = 0, worst = 0;
  for (int k = 0; k < 24; ++k) {
    const double de = deltaE2000(lab(got[size_t(k)] * expose, white_ref), lab(want[size_t(k)], white_ref));
    sum += de;
    worst = std::max(worst, de);
  }
  *worst_out = worst;
  return sum / 24;
}

}  // namespace

TEST(SensorDng, ColorCheckerDevelopedByDcrawEmuWithinDeltaE2000) {
  double worst = 0;
  const double mean = dcrawEmuChartDeltaE("RGGB", &worst);
  std::printf("ColorChecker through dcraw_emu: mean dE2000 %.2f, max %.2f\n", mean, worst);
  EXPECT_LT(mean, 3.0);
}

TEST(SensorDng, RgbwColorCheckerDevelopedByDcrawEmuWithinDeltaE2000) {
  // An RGBW sensor's DNG (four colour planes, the W row of ColorMatrix the sum of the others):
  // LibRaw develops it as a four-colour CFA.
  double worst = 0;
  const double mean = dcrawEmuChartDeltaE("RG/BW", &worst);
  std::printf("RGBW ColorChecker through dcraw_emu: mean dE2000 %.2f, max %.2f\n", mean, worst);
  EXPECT_LT(mean, 3.0);
}

namespace {

// The 24 patches as spectral diffuse quads (the Ohta 1997 reflectances) on a 0.2 grid under a
// uniform D65 sky, seen from `distance` on the axis through `camera`, rendered to a raw DNG with
// noise and developed by dcraw_emu as above. Returns the mean CIEDE2000 (and the largest in
// *worst). The patches are located from the black patch's centroid (Y 3 % of the sky's; the only
// region of the lower right quarter below 5 %), which gives the image scale.
double renderedChartDeltaE(const std::string& name, const std::string& camera, double distance,
                           const std::string& film_extra, double* worst,
                           const std::string& developer = "dcraw_emu") {
  std::ifstream csv(std::string(LENSIM_SHARED_DIR) +
                    "/data/colorchecker/colorchecker-ohta1997.csv");
  std::vector<std::string> spectra(24);
  std::string line;
  std::getline(csv, line);
  while (std::getline(csv, line)) {
    std::stringstream ss(line);
    std::string lambda, v;
    std::getline(ss, lambda, ',');
    for (int i = 0; i < 24 && std::getline(ss, v, ','); ++i)
      spectra[size_t(i)] += lambda + " " + v + " ";
  }
  const std::string dir = tmpDir(name);
  const std::string scene = dir + "/chart.pbrt";
  {
    std::ofstream f(scene);
    f << "LookAt 0 0 " << -distance << "  0 0 0  0 1 0\n"
      << camera << "\n"
      << "Sampler \"independent\" \"integer pixelsamples\" 16\n"
         "Film \"raw\" \"integer xresolution\" 240 \"integer yresolution\" 160\n"
         "  \"float pixelpitch\" 5 \"float nits\" 10 \"float fnumber\" 4 "
      << film_extra
      << "\nIntegrator \"path\" \"integer maxdepth\" 1\n"
         "WorldBegin\n"
         "LightSource \"infinite\" \"spectrum L\" \"stdillum-D65\"\n";
    // Patch k: column k % 6, row k / 6 (row 0 at the top), 0.16 wide on a 0.2 grid.
    for (int k = 0; k < 24; ++k) {
      const double cx = (k % 6 - 2.5) * 0.2, cy = (1.5 - k / 6) * 0.2, r = 0.08;
      f << "AttributeBegin\nMaterial \"diffuse\" \"spectrum reflectance\" [" << spectra[size_t(k)]
        << "]\nShape \"bilinearmesh\" \"point3 P\" [" << cx - r << " " << cy - r << " 0 "
        << cx + r << " " << cy - r << " 0 " << cx - r << " " << cy + r << " 0 " << cx + r << " "
        << cy + r << " 0]\nAttributeEnd\n";
    }
  }
  auto r = lensim::test::runLensim("render -q " + scene + " -o " + dir + "/chart.dng");
  EXPECT_EQ(r.status, 0) << r.out;
  int st = -1;
  std::string developed = dir + "/chart.dng.tiff";
  if (developer == "lensim" || developer == "lensim-ignore-w") {
    developed = dir + "/developed.exr";
    r = lensim::test::runLensim("develop -q " + dir + "/chart.dng -o " + developed +
                                (developer == "lensim" ? "" : " --ignore-w"));
    EXPECT_EQ(r.status, 0) << r.out;
  } else if (developer == "darktable") {
    // darktable-cli with no workflow defaults (no filmic or base curve: its raw steps, the DNG's
    // ColorMatrix and as-shot white balance, sRGB output), a fresh configuration, no library.
    developed = dir + "/darktable.png";
    std::filesystem::remove(developed);
    const std::string log =
        run("timeout 120 darktable-cli " + dir + "/chart.dng " + developed + " --core --configdir " +
                dir + "/dtconfig --library :memory: --conf plugins/darkroom/workflow=none",
            &st);
    EXPECT_EQ(st, 0) << log;
  } else if (developer == "dcraw") {
    // dcraw's own X-Trans interpolation (LibRaw 0.20's fails on X-Trans DNGs at -q 3).
    developed = dir + "/chart.tiff";
    const std::string log = run("dcraw -w -o 1 -4 -T " + dir + "/chart.dng", &st);
    EXPECT_EQ(st, 0) << log;
  } else {
    const std::string log = run("dcraw_emu -w -o 1 -4 -q 3 -T " + dir + "/chart.dng", &st);
    EXPECT_EQ(st, 0) << log;
  }
  const io::Image dev = io::readImage(developed);
  if (dev.width != 240 || dev.height != 160) {
    ADD_FAILURE() << "developed image " << dev.width << "x" << dev.height;
    return 1e9;
  }
  const std::vector<PiecewiseLinearSpectrum> patches = ohtaPatches();
  const std::shared_ptr<const Spectrum> d65 = daylightIlluminant(6500);
  const ConstantSpectrum one(1.0);
  const Vec3 wn = spectrumToXyz(Product(one, *d65));
  auto toXyz = [](double r, double g, double b) {
    return Vec3{0.4124 * r + 0.3576 * g + 0.1805 * b, 0.2126 * r + 0.7152 * g + 0.0722 * b,
                0.0193 * r + 0.1192 * g + 0.9505 * b};
  };
  // The scale from the black patch's centroid (its centre is at (0.5, -0.3) on the chart).
  const double sky = toXyz(dev.at(6, 6, 0), dev.at(6, 6, 1), dev.at(6, 6, 2)).y;
  double sx = 0, sy = 0, n_dark = 0;
  for (int y = 80; y < 156; ++y)  // the lower right quarter, not the demosaic's edge pixels
    for (int x = 120; x < 236; ++x)
      if (toXyz(dev.at(x, y, 0), dev.at(x, y, 1), dev.at(x, y, 2)).y < 0.05 * sky)
        sx += x + 0.5, sy += y + 0.5, ++n_dark;
  EXPECT_GT(n_dark, 50);
  const double scale = (sx / n_dark - 120) / 0.5;  // pixels per metre on the chart
  EXPECT_NEAR((sy / n_dark - 80) / 0.3, scale, 0.1 * scale);
  std::vector<Vec3> got, want;
  for (int k = 0; k < 24; ++k) {
    const double cx = (k % 6 - 2.5) * 0.2, cy = (1.5 - k / 6) * 0.2;
    const int x0 = int(std::lround(120 + cx * scale)), y0 = int(std::lround(80 - cy * scale));
    double s[3] = {0, 0, 0};
    int n = 0;
    for (int y = y0 - 7; y < y0 + 7; ++y)
      for (int x = x0 - 7; x < x0 + 7; ++x, ++n)
        for (int c = 0; c < 3; ++c) s[c] += dev.at(std::clamp(x, 0, 239), std::clamp(y, 0, 159), c);
    got.push_back(toXyz(s[0] / n, s[1] / n, s[2] / n));
    want.push_back(spectrumToXyz(Product(patches[size_t(k)], *d65)) / wn.y);
  }
  const double expose = want[18].y / got[18].y;
  double sum = 0;
  *worst = 0;
  for (int k = 0; k < 24; ++k) {
    const double de =
        deltaE2000(lab(got[size_t(k)] * expose, wn / wn.y), lab(want[size_t(k)], wn / wn.y));
    sum += de;
    *worst = std::max(*worst, de);
  }
  return sum / 24;
}

}  // namespace

TEST(SensorDng, RenderedColorCheckerDevelopedByDcrawEmu) {
  double worst = 0;
  const double mean = renderedChartDeltaE(
      "chart_pinhole", "Camera \"perspective\" \"float fov\" 10.28 \"float shutterclose\" 1", 5,
      "", &worst);
  std::printf("rendered ColorChecker (perspective) through dcraw_emu: mean dE2000 %.2f, max %.2f\n",
              mean, worst);
  EXPECT_LT(mean, 3.0);
}

TEST(SensorDng, ColorCheckerThroughDoubleGaussDevelopedByDcrawEmu) {
  double worst = 0;
  const double mean = renderedChartDeltaE(
      "chart_dgauss",
      "Camera \"realistic\" \"string lensfile\" \"" + std::string(LENSIM_SOURCE_DIR) +
          "/lenses/dgauss.50mm.dat\" \"float aperturediameter\" 12.5 \"float focusdistance\" 6 "
          "\"float shutterclose\" 1",
      6, "\"float diagonal\" 15", &worst);
  std::printf("ColorChecker through the double Gauss, dcraw_emu: mean dE2000 %.2f, max %.2f\n",
              mean, worst);
  EXPECT_LT(mean, 3.0);
}

TEST(SensorDng, ColorCheckerThroughDoubleGaussDevelopedByLensim) {
  // The same DNG developed by lensim's own pipeline (`lensim develop`).
  double worst = 0;
  const double mean = renderedChartDeltaE(
      "chart_dgauss_lensim",
      "Camera \"realistic\" \"string lensfile\" \"" + std::string(LENSIM_SOURCE_DIR) +
          "/lenses/dgauss.50mm.dat\" \"float aperturediameter\" 12.5 \"float focusdistance\" 6 "
          "\"float shutterclose\" 1",
      6, "\"float diagonal\" 15", &worst, "lensim");
  std::printf("ColorChecker through the double Gauss, lensim develop: mean dE2000 %.2f, max %.2f\n",
              mean, worst);
  EXPECT_LT(mean, 3.0);
  // Refusals: not a DNG, an unknown output format.
  auto r = lensim::test::runLensim("develop " + std::string(LENSIM_SOURCE_DIR) +
                                   "/lenses/dgauss.50mm.dat -o " + tmpDir("dev_bad") + "/x.png");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("dgauss.50mm.dat: error: cannot read the file as TIFF/DNG"),
            std::string::npos)
      << r.out;
  EXPECT_FALSE(std::filesystem::exists(tmpDir("dev_bad") + "/x.png"));
}

TEST(SensorDng, XTransColorCheckerDevelopedByDcrawAndLensim) {
  // The rendered chart of the tests above on an X-Trans sensor: dcraw's X-Trans demosaic and
  // lensim develop's normalised convolution.
  const std::string film = std::string("\"string cfa\" \"") + kXTrans + "\"";
  const std::string camera = "Camera \"perspective\" \"float fov\" 10.28 \"float shutterclose\" 1";
  double worst = 0;
  const double dcraw = renderedChartDeltaE("chart_xtrans", camera, 5, film, &worst, "dcraw");
  std::printf("X-Trans ColorChecker, dcraw: mean dE2000 %.2f, max %.2f\n", dcraw, worst);
  EXPECT_LT(dcraw, 3.0);
  const double own = renderedChartDeltaE("chart_xtrans_lensim", camera, 5, film, &worst, "lensim");
  std::printf("X-Trans ColorChecker, lensim develop: mean dE2000 %.2f, max %.2f\n", own, worst);
  EXPECT_LT(own, 3.0);
}

TEST(SensorDng, RgbwColorCheckerDevelopedByDcrawEmuAndLensim) {
  // The rendered chart on an RGBW sensor (RG/BW): LibRaw's four-colour path, and lensim
  // develop's normalised convolution of the R, G and B pixels, with the W pixels' luminance and
  // without: using W may not worsen the mean CIEDE2000 by more than 0.1.
  const std::string film = "\"string cfa\" \"RG/BW\"";
  const std::string camera = "Camera \"perspective\" \"float fov\" 10.28 \"float shutterclose\" 1";
  double worst = 0;
  const double emu = renderedChartDeltaE("chart_rgbw", camera, 5, film, &worst);
  std::printf("RGBW ColorChecker, dcraw_emu: mean dE2000 %.2f, max %.2f\n", emu, worst);
  EXPECT_LT(emu, 3.0);
  const double own = renderedChartDeltaE("chart_rgbw_lensim", camera, 5, film, &worst, "lensim");
  std::printf("RGBW ColorChecker, lensim develop: mean dE2000 %.2f, max %.2f\n", own, worst);
  EXPECT_LT(own, 3.0);
  const double no_w =
      renderedChartDeltaE("chart_rgbw_lensim_no_w", camera, 5, film, &worst, "lensim-ignore-w");
  std::printf("RGBW ColorChecker, lensim develop --ignore-w: mean dE2000 %.2f, max %.2f\n", no_w,
              worst);
  EXPECT_LT(own, no_w + 0.1);
}

TEST(SensorDng, QuadBayerColorCheckerRemosaicedDevelopedByDcrawEmuAndDarktable) {
  // The rendered chart on a Quad Bayer sensor and on Kodak's 4x4 RGBW, written as RGGB DNGs
  // ("string dngcfa" "bayer") and developed by LibRaw's dcraw_emu (AHD); the Quad Bayer one also
  // by darktable-cli (as RenderedColorCheckerDevelopedByDarktable).
  const std::string camera = "Camera \"perspective\" \"float fov\" 10.28 \"float shutterclose\" 1";
  double worst = 0;
  const double quad = renderedChartDeltaE(
      "chart_quad", camera, 5, "\"string cfa\" \"RRGG/RRGG/GGBB/GGBB\" \"string dngcfa\" \"bayer\"",
      &worst);
  std::printf("Quad Bayer remosaiced to RGGB, dcraw_emu: mean dE2000 %.2f, max %.2f\n", quad, worst);
  EXPECT_LT(quad, 3.0);
  const double kodak = renderedChartDeltaE(
      "chart_kodak", camera, 5, "\"string cfa\" \"WBWG/BWGW/WGWR/GWRW\" \"string dngcfa\" \"bayer\"",
      &worst);
  std::printf("4x4 RGBW remosaiced to RGGB, dcraw_emu: mean dE2000 %.2f, max %.2f\n", kodak, worst);
  EXPECT_LT(kodak, 3.0);
  if (std::system("command -v darktable-cli >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "darktable-cli is not installed (scripts/install-deps installs it)";
  const double dt = renderedChartDeltaE(
      "chart_quad_darktable", camera, 5,
      "\"string cfa\" \"RRGG/RRGG/GGBB/GGBB\" \"string dngcfa\" \"bayer\"", &worst, "darktable");
  std::printf("Quad Bayer remosaiced to RGGB, darktable-cli: mean dE2000 %.2f, max %.2f\n", dt, worst);
  EXPECT_LT(dt, 3.0);
}

TEST(SensorDng, RawPreviewIsNeutralForWhiteAndMatchesLensimDevelop) {
  // serve's preview of a raw film: a white surface under CIE D 6500 K (the default white
  // balance) is neutral, and a flat field equals lensim develop's picture of its DNG.
  SensorConfig cfg;
  cfg.noise = false;
  cfg.read_noise_e = 0;
  cfg.dark_current_e_s = 0;
  const SensorModel model(cfg);
  const std::shared_ptr<const Spectrum> d65 = daylightIlluminant(6500);
  const Vec3 white = cameraResponse(model, *d65);
  const double k = 20000 / std::max({white.x, white.y, white.z});  // 20000 e- at most
  io::Image im(24, 24, {"R", "G", "B"});
  for (int y = 0; y < 24; ++y)
    for (int x = 0; x < 24; ++x) {
      im.at(x, y, 0) = float(white.x * k);
      im.at(x, y, 1) = float(white.y * k);
      im.at(x, y, 2) = float(white.z * k);
    }
  im.metadata[kRawSensorKey] = cfg.toText();
  const io::Image p = previewRawImage(im);
  ASSERT_EQ(p.channelCount(), 3);
  EXPECT_NEAR(p.at(5, 5, 0) / p.at(5, 5, 1), 1.0, 0.01);
  EXPECT_NEAR(p.at(5, 5, 2) / p.at(5, 5, 1), 1.0, 0.01);
  // Another colour (more red, less blue), against the developed DNG's centre.
  for (int y = 0; y < 24; ++y)
    for (int x = 0; x < 24; ++x) {
      im.at(x, y, 0) *= 1.5f;
      im.at(x, y, 2) *= 0.6f;
    }
  const io::Image q = previewRawImage(im);
  const std::string path = tmpDir("preview") + "/flat.dng";
  writeRawImage(path, im, 0, 0);
  const io::Image d = developRaw(io::readDng(path));
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(q.at(12, 12, c), d.at(12, 12, c), 2e-3 * d.at(12, 12, 1)) << c;
  // Not a raw image: returned as it is.
  io::Image plain(2, 2, {"R", "G", "B"});
  plain.at(1, 1, 2) = 0.25f;
  EXPECT_EQ(previewRawImage(plain).at(1, 1, 2), 0.25f);
}

TEST(SensorDng, RenderedColorCheckerDevelopedByDarktable) {
  if (std::system("command -v darktable-cli >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "darktable-cli is not installed (scripts/install-deps installs it)";
  double worst = 0;
  const double mean = renderedChartDeltaE(
      "chart_darktable", "Camera \"perspective\" \"float fov\" 10.28 \"float shutterclose\" 1",
      5, "", &worst, "darktable");
  std::printf("rendered ColorChecker (perspective) through darktable-cli: mean dE2000 %.2f, max %.2f\n",
              mean, worst);
  EXPECT_LT(mean, 3.0);
}
