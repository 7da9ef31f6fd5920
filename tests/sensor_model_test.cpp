// The camera sensor model (render/sensor/sensor_model.h) against closed forms: photon counts
// from spectral irradiance (h c / lambda, QE read from the data file here), the noise statistics
// of flat and dark frames (Poisson + read noise, per-block z-tests), the photon transfer curve,
// dark current's doubling rule, fixed-pattern noise, and the independence of the noise from how
// the image is split.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "lensim/render/sensor/sensor_model.h"
#include "lensim/util/error.h"

using namespace lensim;
using namespace lensim::render;

namespace {

// The 5D Mark IV's bundled relative curves, read from the data file independently of lensim.
std::vector<std::vector<double>> readCanonCurves() {
  std::ifstream in(std::string(LENSIM_SOURCE_DIR) + "/data/sensors/camera_sensors.csv");
  std::vector<std::vector<double>> rgb(3);
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("canon_eos_5d_mkiv,", 0) != 0) continue;
    std::stringstream ss(line);
    std::string cam, ch, v;
    std::getline(ss, cam, ',');
    std::getline(ss, ch, ',');
    const int c = ch == "r" ? 0 : ch == "g" ? 1 : 2;
    while (std::getline(ss, v, ',')) rgb[size_t(c)].push_back(std::stod(v));
  }
  return rgb;
}

// A unit-area triangle of half-width 1 nm at lambda0 (integer): a monochromatic spectral
// irradiance of 1 W m^-2 (in film units) at lambda0 when integrated at 1 nm.
class Line final : public Spectrum {
 public:
  explicit Line(double l0) : l0_(l0) {}
  double eval(double l) const override { return std::max(0.0, 1 - std::abs(l - l0_)); }
  double maxValue() const override { return 1; }

 private:
  double l0_;
};

SensorConfig noiseConfig() {
  SensorConfig c;
  c.adc_bits = 16;
  c.black_level_dn = 1024;
  c.conversion_gain_e_dn = 2;
  c.read_noise_e = 4;
  c.dark_current_e_s = 0;
  c.full_well_e = 1e6;
  c.exposure_s = 1;
  return c;
}

std::vector<float> flat(int w, int h, double e) { return std::vector<float>(size_t(w * h * 3), float(e)); }

}  // namespace

TEST(SensorModel, MonochromaticPhotonsTimesQe) {
  const auto curves = readCanonCurves();
  ASSERT_EQ(curves[0].size(), 35u);
  double peak = 0;
  for (const auto& c : curves)
    for (double v : c) peak = std::max(peak, v);
  SensorConfig cfg;
  cfg.peak_qe = 0.6;
  cfg.pixel_pitch_um = 4;
  cfg.fill_factor = 0.8;
  cfg.exposure_s = 0.02;
  cfg.irradiance_scale = 1e-3;  // W m^-2 nm^-1 per film unit
  const SensorModel m(cfg);
  const double h = 6.62607015e-34, c = 299792458.0;
  for (int k : {7, 12, 17, 22, 27}) {  // 450, 500, 550, 600, 650 nm
    const double lambda = 380 + 10 * k;
    // Photons on the collecting area: E x A x fill x t / (h c / lambda).
    const double photons = 1e-3 * (4e-6 * 4e-6) * 0.8 * 0.02 / (h * c / (lambda * 1e-9));
    const auto e = m.expectedElectrons(Line(lambda));
    for (int ch = 0; ch < 3; ++ch) {
      const double qe = 0.6 * curves[size_t(ch)][size_t(k)] / peak;
      EXPECT_NEAR(e[size_t(ch)], photons * qe, 1e-9 * photons + 1e-6)
          << "channel " << ch << " at " << lambda << " nm";
    }
  }
}

TEST(SensorModel, MonteCarloEstimateMatchesIntegral) {
  // The film's per-sample estimate (sampled wavelengths) averages to the integral.
  SensorConfig cfg;
  cfg.irradiance_scale = 1e-3;
  const SensorModel m(cfg);
  const ConstantSpectrum one(1.0);
  const auto exact = m.expectedElectrons(one);
  std::array<double, 3> sum{0, 0, 0};
  const int n = 20000;
  for (int i = 0; i < n; ++i) {
    const SampledWavelengths l = SampledWavelengths::sampleVisible((i + 0.5) / n);
    const auto e = m.expectedElectrons(SampledSpectrum(1.0), l);
    for (int ch = 0; ch < 3; ++ch) sum[size_t(ch)] += e[size_t(ch)] / n;
  }
  for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(sum[size_t(ch)], exact[size_t(ch)], 2e-3 * exact[size_t(ch)]);
}

TEST(SensorModel, UserQeFileAndIrCut) {
  const std::string path = ::testing::TempDir() + "/mono_qe.csv";
  {
    std::ofstream f(path);
    f << "# lambda_nm, qe\n400, 0.2\n600, 0.6\n800 0.6\n";
  }
  SensorConfig cfg;
  cfg.qe = path;
  cfg.cfa = "mono";
  cfg.irradiance_scale = 1;
  cfg.ircut_nm = 650;
  cfg.ircut_width_nm = 10;
  const SensorModel m(cfg);
  EXPECT_NEAR(m.qe(0, 500), 0.4 / (1 + std::exp(-15.0)), 1e-9);
  EXPECT_NEAR(m.qe(0, 650), 0.6 * 0.5, 1e-12);
  EXPECT_NEAR(m.qe(0, 700), 0.6 / (1 + std::exp(5.0)), 1e-9);
  EXPECT_EQ(m.qe(1, 500), 0.0);

  // Bad files: the row and column of the bad value.
  const std::string bad = ::testing::TempDir() + "/bad_qe.csv";
  auto expectError = [&](const std::string& text, const std::string& where,
                         const std::string& what) {
    {
      std::ofstream f(bad);
      f << text;
    }
    try {
      readQeFile(bad);
      ADD_FAILURE() << "no error for " << text;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(bad + where), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  expectError("400, 0.1\n500, 1.5\n", ":2:6", "quantum efficiency 1.5");
  expectError("400, 0.1\n390, 0.2\n", ":2:1", "expected increasing");
  expectError("400, 0.1\n500, x\n", ":2:6", "\"x\" is not a number");
  expectError("400, 0.1, 0.2\n", ":1:1", "3 columns");
}

TEST(SensorModel, FlatFieldMeanAndVarianceMatchPoissonPlusReadNoise) {
  // Per-block z-tests of the mean and the variance of a flat field against
  // mean = S G + black, variance = (S + R^2) G^2 + 1/12 (rounding).
  for (double s : {50.0, 2000.0, 30000.0}) {
    SensorConfig cfg = noiseConfig();
    cfg.seed = 7;
    const SensorModel m(cfg);
    const int w = 256, hgt = 256, b = 32;
    const auto dn = digitizeImage(m, flat(w, hgt, s), w, hgt, 0, 0);
    const double g = cfg.gainDnPerE();
    const double mu = s * g + cfg.black_level_dn;
    const double var = (s + cfg.read_noise_e * cfg.read_noise_e) * g * g + 1.0 / 12;
    double worst_mean = 0, worst_var = 0;
    for (int by = 0; by < hgt; by += b)
      for (int bx = 0; bx < w; bx += b) {
        double sum = 0, sq = 0;
        const int n = b * b;
        for (int y = by; y < by + b; ++y)
          for (int x = bx; x < bx + b; ++x) {
            const double v = dn[size_t(y * w + x)];
            sum += v;
            sq += v * v;
          }
        const double mean = sum / n, svar = (sq - n * mean * mean) / (n - 1);
        worst_mean = std::max(worst_mean, std::abs(mean - mu) / std::sqrt(var / n));
        worst_var = std::max(worst_var, std::abs(svar - var) / (var * std::sqrt(2.0 / (n - 1))));
      }
    // 64 blocks: |z| > 4.5 by chance has probability ~4e-4.
    EXPECT_LT(worst_mean, 4.5) << "S = " << s;
    EXPECT_LT(worst_var, 4.5) << "S = " << s;
  }
}

TEST(SensorModel, PhotonTransferCurveGivesConversionGainAndReadNoise) {
  // Mean against variance over exposure levels: slope 1/K (K: e-/DN), intercept R^2/K^2.
  SensorConfig cfg = noiseConfig();
  cfg.iso = 200;  // analog gain 2: K = conversion gain / 2
  const SensorModel m(cfg);
  const int w = 256, hgt = 256;
  std::vector<double> xs, ys;
  for (double s : {0.0, 500.0, 1000.0, 2000.0, 4000.0, 8000.0}) {
    const auto dn = digitizeImage(m, flat(w, hgt, s), w, hgt, 0, 0);
    double sum = 0, sq = 0;
    for (uint16_t v : dn) {
      sum += v;
      sq += double(v) * v;
    }
    const double n = double(dn.size()), mean = sum / n;
    xs.push_back(mean - cfg.black_level_dn);
    ys.push_back((sq - n * mean * mean) / (n - 1) - 1.0 / 12);
  }
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  const double n = double(xs.size());
  for (size_t i = 0; i < xs.size(); ++i) {
    sx += xs[i], sy += ys[i], sxx += xs[i] * xs[i], sxy += xs[i] * ys[i];
  }
  const double slope = (n * sxy - sx * sy) / (n * sxx - sx * sx);
  const double k = 1 / slope;  // e-/DN
  EXPECT_NEAR(k, cfg.conversion_gain_e_dn / 2, 0.02 * cfg.conversion_gain_e_dn / 2);
  // Read noise from the dark frame (first level): sigma_DN x K.
  const double read = std::sqrt(ys[0]) * (cfg.conversion_gain_e_dn / 2);
  EXPECT_NEAR(read, cfg.read_noise_e, 0.02 * cfg.read_noise_e);
  // SNR = S / sqrt(S + R^2) at S = 4000 (no dark current), within 2 %.
  const double snr = (xs[4] / cfg.gainDnPerE()) / (std::sqrt(ys[4]) / cfg.gainDnPerE());
  EXPECT_NEAR(snr, 4000 / std::sqrt(4000 + 16.0), 0.02 * 4000 / std::sqrt(4016.0));
}

TEST(SensorModel, DarkCurrentDoublesWithTemperature) {
  SensorConfig cfg = noiseConfig();
  cfg.dark_current_e_s = 0.5;
  cfg.dark_ref_c = 25;
  cfg.dark_doubling_c = 6;
  cfg.temperature_c = 37;  // two doublings: 2 e-/s
  cfg.exposure_s = 30;     // 60 e-
  cfg.read_noise_e = 2;
  const SensorModel m(cfg);
  EXPECT_DOUBLE_EQ(cfg.darkCurrent(), 2.0);
  const int w = 128, h = 128;
  const auto dn = digitizeImage(m, flat(w, h, 0), w, h, 0, 0);
  double sum = 0, sq = 0;
  for (uint16_t v : dn) sum += v, sq += double(v) * v;
  const double n = double(dn.size()), mean = sum / n, var = (sq - n * mean * mean) / (n - 1);
  const double g = cfg.gainDnPerE();
  const double mu = 60 * g + cfg.black_level_dn, sigma2 = (60 + 4) * g * g + 1.0 / 12;
  EXPECT_LT(std::abs(mean - mu) / std::sqrt(sigma2 / n), 4.5);
  EXPECT_LT(std::abs(var - sigma2) / (sigma2 * std::sqrt(2 / (n - 1))), 4.5);
}

TEST(SensorModel, FixedPatternNoiseIsSeededAndMeasurable) {
  SensorConfig cfg = noiseConfig();
  cfg.dsnu_e = 5;
  cfg.prnu = 0.01;
  cfg.pattern_seed = 3;
  const SensorModel a(cfg);
  cfg.seed = 99;  // another frame of the same sensor: the same pattern
  const SensorModel b(cfg);
  cfg.pattern_seed = 4;  // another sensor
  const SensorModel c(cfg);
  double sg = 0, sgg = 0, so = 0, soo = 0;
  int same = 0, differ = 0;
  const int n = 200 * 200;
  for (int y = 0; y < 200; ++y)
    for (int x = 0; x < 200; ++x) {
      const auto [g, o] = a.fixedPattern(x, y);
      sg += g, sgg += g * g, so += o, soo += o * o;
      same += a.fixedPattern(x, y) == b.fixedPattern(x, y);
      differ += a.fixedPattern(x, y) != c.fixedPattern(x, y);
    }
  EXPECT_EQ(same, n);
  EXPECT_EQ(differ, n);
  const double prnu = std::sqrt(sgg / n - (sg / n) * (sg / n));
  const double dsnu = std::sqrt(soo / n - (so / n) * (so / n));
  EXPECT_NEAR(prnu, 0.01, 0.01 * 0.03);
  EXPECT_NEAR(dsnu, 5, 5 * 0.03);
  // PRNU from flat fields: the average of many frames removes the temporal noise, leaving the
  // pattern: std of the per-pixel mean / S ~ PRNU (S = 20000, 16 frames).
  const int w = 64, h = 64, frames = 16;
  std::vector<double> acc(size_t(w * h), 0);
  for (int f = 0; f < frames; ++f) {
    SensorConfig fc = noiseConfig();
    fc.prnu = 0.01;
    fc.pattern_seed = 3;
    fc.seed = uint64_t(100 + f);
    const auto dn = digitizeImage(SensorModel(fc), flat(w, h, 20000), w, h, 0, 0);
    for (size_t i = 0; i < acc.size(); ++i) acc[i] += dn[i] / double(frames);
  }
  double s = 0, ss = 0;
  for (double v : acc) s += v, ss += v * v;
  const double mean = s / double(acc.size());
  const double spatial = std::sqrt(ss / double(acc.size()) - mean * mean);
  const double g = noiseConfig().gainDnPerE();
  const double temporal2 = (20000 + 16.0) * g * g / frames;
  const double prnu_est = std::sqrt(spatial * spatial - temporal2) / (mean - 1024);
  EXPECT_NEAR(prnu_est, 0.01, 0.001);
}

TEST(SensorModel, DarkFramesGiveDarkCurrentAndDsnu) {
  // 16 dark frames of one sensor averaged: the mean gives the dark current, the spatial spread
  // of the per-pixel means (less the averaged temporal noise) the DSNU.
  const int w = 64, h = 64, frames = 16;
  std::vector<double> acc(size_t(w * h), 0);
  SensorConfig fc = noiseConfig();
  fc.dark_current_e_s = 2;
  fc.exposure_s = 10;  // 20 e-
  fc.dsnu_e = 6;
  fc.pattern_seed = 8;
  for (int f = 0; f < frames; ++f) {
    fc.seed = uint64_t(500 + f);
    const auto dn = digitizeImage(SensorModel(fc), flat(w, h, 0), w, h, 0, 0);
    for (size_t i = 0; i < acc.size(); ++i) acc[i] += dn[i] / double(frames);
  }
  double s = 0, ss = 0;
  for (double v : acc) s += v, ss += v * v;
  const double n = double(acc.size()), mean = s / n;
  const double g = fc.gainDnPerE();
  EXPECT_NEAR((mean - fc.black_level_dn) / g / fc.exposure_s, 2.0, 0.05 * 2.0);
  const double spatial2 = ss / n - mean * mean;
  const double temporal2 = ((20 + 16.0) * g * g + 1.0 / 12) / frames;
  EXPECT_NEAR(std::sqrt(spatial2 - temporal2) / g, 6.0, 0.05 * 6.0);
}

TEST(SensorModel, NoiseIndependentOfSplitAndReproducibleFromSeed) {
  SensorConfig cfg = noiseConfig();
  cfg.seed = 11;
  cfg.dsnu_e = 2;
  cfg.prnu = 0.02;
  const SensorModel m(cfg);
  const int w = 48, h = 40;
  std::vector<float> e(size_t(w * h * 3));
  for (size_t i = 0; i < e.size(); ++i) e[i] = float(100 + (i * 37) % 5000);
  const auto whole = digitizeImage(m, e, w, h, 10, 20);
  // The same pixels as two windows (rows 0-16 and 17-39).
  const int split = 17;
  const std::vector<float> top(e.begin(), e.begin() + split * w * 3),
      bottom(e.begin() + split * w * 3, e.end());
  auto a = digitizeImage(m, top, w, split, 10, 20);
  const auto b = digitizeImage(m, bottom, w, h - split, 10, 20 + split);
  a.insert(a.end(), b.begin(), b.end());
  EXPECT_EQ(a, whole);
  EXPECT_EQ(digitizeImage(SensorModel(cfg), e, w, h, 10, 20), whole);
  cfg.seed = 12;
  EXPECT_NE(digitizeImage(SensorModel(cfg), e, w, h, 10, 20), whole);
}

TEST(SensorModel, FullWellAndAdcClip) {
  SensorConfig cfg = noiseConfig();
  cfg.full_well_e = 10000;
  cfg.adc_bits = 12;
  cfg.black_level_dn = 64;
  cfg.conversion_gain_e_dn = 1;
  const SensorModel m(cfg);
  const auto dn = digitizeImage(m, flat(16, 16, 1e6), 16, 16, 0, 0);
  for (uint16_t v : dn) EXPECT_LE(v, 4095);
  for (uint16_t v : dn) EXPECT_GE(v, 4095 - 20);  // full well 10000 e- > 4095 DN: the ADC clips
  cfg.conversion_gain_e_dn = 4;                    // 10000 e- = 2500 DN + 64
  const auto dn2 = digitizeImage(SensorModel(cfg), flat(16, 16, 1e6), 16, 16, 0, 0);
  for (uint16_t v : dn2) EXPECT_NEAR(v, 2564, 5);
}

TEST(SensorModel, CfaLayouts) {
  EXPECT_EQ(cfaChannel(parseCfa("RGGB"), 0, 0), 0);
  EXPECT_EQ(cfaChannel(parseCfa("RGGB"), 1, 0), 1);
  EXPECT_EQ(cfaChannel(parseCfa("RGGB"), 0, 1), 1);
  EXPECT_EQ(cfaChannel(parseCfa("RGGB"), 1, 1), 2);
  EXPECT_EQ(cfaChannel(parseCfa("BGGR"), 0, 0), 2);
  EXPECT_EQ(cfaChannel(parseCfa("BGGR"), 3, 3), 0);
  EXPECT_EQ(cfaChannel(parseCfa("GRBG"), 1, 0), 0);
  EXPECT_EQ(cfaChannel(parseCfa("GRBG"), 0, 1), 2);
  EXPECT_EQ(cfaChannel(parseCfa("GBRG"), 1, 0), 2);
  EXPECT_EQ(cfaChannel(parseCfa("GBRG"), 0, 1), 0);
  EXPECT_THROW(parseCfa("RGGX"), Error);
}

TEST(SensorModel, ConfigRoundTripsAndRefusesBadValues) {
  SensorConfig c;
  c.qe = "some/file.csv";
  c.read_noise_e = 1.2345678901234567;
  c.seed = 0xfedcba9876543210ULL;
  c.noise = false;
  const SensorConfig r = SensorConfig::fromText(c.toText());
  EXPECT_EQ(r.toText(), c.toText());
  EXPECT_EQ(r.read_noise_e, c.read_noise_e);
  EXPECT_EQ(r.seed, c.seed);
  SensorConfig bad;
  bad.adc_bits = 20;
  try {
    bad.validate(FileLoc{"s.pbrt", 3, 1});
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("s.pbrt:3:1"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("\"adcbits\": 20"), std::string::npos) << e.what();
  }
}
