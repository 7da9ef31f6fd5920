// The sensor's signal chain (sensor_model.h).
#include "lensim/render/sensor/sensor_model.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <sstream>

#include <fmt/format.h>

#include "lensim/render/film/pixel_sensor.h"
#include "lensim/util/file.h"

namespace lensim::render {

namespace {

constexpr double kPlanck = 6.62607015e-34;    // J s (exact, SI 2019)
constexpr double kLightSpeed = 299792458.0;   // m/s (exact)
constexpr int kTableMin = 360, kTableMax = 830;

// SplitMix64 (Steele, Lea and Flood 2014): a counter-based generator, seeded from the pixel's
// position, so each pixel's noise is independent of the order pixels are processed in.
struct PixelRng {
  using result_type = uint64_t;
  uint64_t s;
  static constexpr result_type min() { return 0; }
  static constexpr result_type max() { return std::numeric_limits<uint64_t>::max(); }
  result_type operator()() {
    uint64_t z = (s += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
};

PixelRng pixelRng(uint64_t seed, uint64_t stream, int x, int y) {
  PixelRng r{seed * 0x632be59bd9b4e019ULL + stream};
  r.s ^= (uint64_t(uint32_t(x)) << 32 | uint32_t(y)) * 0xd6e8feb86659fd93ULL;
  r();
  r.s ^= r();
  return r;
}

double gaussian(PixelRng& r) {
  // Box-Muller from two 53-bit uniforms (std::normal_distribution keeps state between calls).
  const double u1 = (double(r() >> 11) + 1) * 0x1p-53, u2 = double(r() >> 11) * 0x1p-53;
  return std::sqrt(-2 * std::log(u1)) * std::cos(2 * M_PI * u2);
}

SpectralTable tabulate(const auto& f) {
  SpectralTable t;
  t.v.resize(size_t(kTableMax - kTableMin + 1));
  for (int l = kTableMin; l <= kTableMax; ++l) t.v[size_t(l - kTableMin)] = f(double(l));
  return t;
}

std::vector<std::string> splitFields(const std::string& line, std::vector<int>& cols) {
  std::vector<std::string> out;
  size_t i = 0;
  while (i <= line.size()) {
    size_t j = line.find_first_of(",\t ", i);
    if (j == std::string::npos) j = line.size();
    if (j > i) {
      out.push_back(line.substr(i, j - i));
      cols.push_back(int(i) + 1);
    }
    i = j + 1;
  }
  return out;
}

}  // namespace

double SpectralTable::eval(double l) const {
  if (!(l >= kTableMin && l <= kTableMax) || v.empty()) return 0;
  const double t = l - kTableMin;
  const size_t i = std::min(size_t(t), v.size() - 2);
  const double f = t - double(i);
  return v[i] * (1 - f) + v[i + 1] * f;
}

// ---- QE files ----

std::vector<SpectralTable> readQeFile(const std::string& path) {
  return parseQeText(readRegularFile(path, "QE file", uint64_t{16} << 20), path);
}

std::vector<SpectralTable> parseQeText(const std::string& text, const std::string& path) {
  std::istringstream in(text);
  std::vector<double> lambda;
  std::vector<std::vector<double>> qe;
  int n_cols = 0, line_no = 0;
  for (std::string line; std::getline(in, line);) {
    ++line_no;
    const size_t hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    std::vector<int> cols;
    const std::vector<std::string> f = splitFields(line, cols);
    if (f.empty()) continue;
    if (n_cols == 0) {
      n_cols = int(f.size());
      if (n_cols != 2 && n_cols != 4)
        throw Error(FileLoc{path, line_no, 1},
                    fmt::format("{} columns; expected 2 (lambda_nm, qe) or 4 (lambda_nm, qe_r, "
                                "qe_g, qe_b)",
                                n_cols));
      qe.resize(size_t(n_cols - 1));
    }
    if (int(f.size()) != n_cols)
      throw Error(FileLoc{path, line_no, 1},
                  fmt::format("{} columns; expected {} as on the first row", f.size(), n_cols));
    for (size_t k = 0; k < f.size(); ++k) {
      double v = 0;
      size_t used = 0;
      try {
        v = std::stod(f[k], &used);
      } catch (const std::exception&) {
        used = 0;
      }
      const FileLoc at{path, line_no, cols[k]};
      if (used != f[k].size() || !std::isfinite(v))
        throw Error(at, fmt::format("\"{}\" is not a number", f[k]));
      if (k == 0) {
        if (!(v >= 200 && v <= 2000))
          throw Error(at, fmt::format("wavelength {} nm; expected 200 to 2000 nm", v));
        if (!lambda.empty() && !(v > lambda.back()))
          throw Error(at, fmt::format("wavelength {} nm after {} nm; expected increasing "
                                      "wavelengths",
                                      v, lambda.back()));
        lambda.push_back(v);
      } else {
        if (!(v >= 0 && v <= 1))
          throw Error(at, fmt::format("quantum efficiency {}; expected a fraction in [0, 1]", v));
        qe[k - 1].push_back(v);
      }
    }
  }
  if (lambda.size() < 2)
    throw Error(FileLoc{path, line_no, 1}, "fewer than 2 rows; expected a QE curve");
  std::vector<SpectralTable> out;
  for (const auto& q : qe) {
    const ZeroOutsideSpectrum s(lambda, q);
    out.push_back(tabulate([&](double l) { return s.eval(l); }));
  }
  return out;
}

// ---- SensorModel ----

SensorModel::SensorModel(SensorConfig config, const FileLoc& loc, const std::string* qe_text)
    : config_(std::move(config)), cfa_(parseCfa(config_.cfa, loc)), loc_(loc) {
  config_.validate(loc);
  std::array<SpectralTable, 3> raw;
  const auto& names = cameraSensorNames();
  if (std::find(names.begin(), names.end(), config_.qe) != names.end()) {
    // Bundled curves are relative (green peak 1): scaled to peak_qe at the highest peak.
    double peak = 0;
    for (int c = 0; c < 3; ++c) {
      const ZeroOutsideSpectrum& s = cameraSensorCurve(config_.qe, c);
      raw[size_t(c)] = tabulate([&](double l) { return s.eval(l); });
      for (double v : raw[size_t(c)].v) peak = std::max(peak, v);
    }
    for (auto& t : raw)
      for (double& v : t.v) v *= config_.peak_qe / peak;
    // A monochrome sensor has no colour filters: its QE is the W curve, the sum of the three.
    if (cfa_.mono) {
      SpectralTable sum = raw[0];
      for (size_t i = 0; i < sum.v.size(); ++i) sum.v[i] += raw[1].v[i] + raw[2].v[i];
      raw = {sum, SpectralTable{}, SpectralTable{}};
    }
  } else {
    std::vector<SpectralTable> t;
    try {
      t = qe_text ? parseQeText(*qe_text, config_.qe) : readQeFile(config_.qe);
    } catch (const Error& e) {
      if (config_.qe.find('/') == std::string::npos && config_.qe.find('.') == std::string::npos) {
        std::string list;
        for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
        throw Error(loc, fmt::format("\"qe\": unknown sensor \"{}\"; expected a QE file or one "
                                     "of {}",
                                     config_.qe, list));
      }
      throw;
    }
    if (cfa_.mono && t.size() != 1)
      throw Error(FileLoc{config_.qe}, "a monochrome sensor needs 2 columns (lambda_nm, qe)");
    if (!cfa_.mono && t.size() != 3)
      throw Error(FileLoc{config_.qe},
                  fmt::format("a {} sensor needs 4 columns (lambda_nm, qe_r, qe_g, qe_b)",
                              config_.cfa));
    for (size_t c = 0; c < t.size(); ++c) raw[c] = t[c];
  }
  // IR-cut: a logistic edge, transmission 1/2 at ircut_nm.
  const double cut = config_.ircut_nm, width = config_.ircut_width_nm;
  for (size_t c = 0; c < 3; ++c) {
    if (raw[c].v.empty()) {
      qe_[c] = tabulate([](double) { return 0.0; });
    } else {
      qe_[c] = tabulate([&](double l) {
        const double ir = cut > 0 ? 1 / (1 + std::exp((l - cut) / width)) : 1;
        return raw[c].eval(l) * ir;
      });
    }
    resp_[c] = tabulate([&](double l) { return qe_[c].eval(l) * photonsPerUnit(l); });
  }
  // The W (or bundled monochrome) curve, a sum of curves, must stay a fraction.
  if (cfa_.hasW() || cfa_.mono) {
    for (int l = kTableMin; l <= kTableMax; ++l) {
      const double w = qe(cfa_.mono ? 0 : CfaPattern::kW, l);
      if (w > 1 + 1e-12)
        throw Error(loc, fmt::format("\"cfa\" \"{}\" with \"qe\" \"{}\" (peak {}): the {} "
                                     "quantum efficiency, the sum of the R, G and B curves, is "
                                     "{:.4g} at {} nm; expected at most 1 (lower \"peakqe\" or "
                                     "the QE file's curves)",
                                     cfa_.text(), config_.qe, config_.peak_qe,
                                     cfa_.mono ? "monochrome" : "W", w, l));
    }
  }
}

double SensorModel::qe(int c, double lambda_nm) const {
  if (c == CfaPattern::kW)
    return qe_[0].eval(lambda_nm) + qe_[1].eval(lambda_nm) + qe_[2].eval(lambda_nm);
  return qe_[size_t(c)].eval(lambda_nm);
}

double SensorModel::electronsPerUnit(int c, double lambda_nm) const {
  if (c == CfaPattern::kW)
    return resp_[0].eval(lambda_nm) + resp_[1].eval(lambda_nm) + resp_[2].eval(lambda_nm);
  return resp_[size_t(c)].eval(lambda_nm);
}

double SensorModel::photonsPerUnit(double lambda_nm) const {
  // Spectral irradiance (W m^-2 nm^-1) x collecting area x time / photon energy h c / lambda.
  const double area_m2 = config_.pixel_pitch_um * config_.pixel_pitch_um * 1e-12 *
                         config_.fill_factor;
  const double photon_j = kPlanck * kLightSpeed / (lambda_nm * 1e-9);
  return config_.irradiance_scale * area_m2 * config_.exposure_s / photon_j;
}

std::array<double, 3> SensorModel::expectedElectrons(const SampledSpectrum& L,
                                                     const SampledWavelengths& lambda) const {
  std::array<double, 3> e{0, 0, 0};
  for (int i = 0; i < kSpectrumSamples; ++i) {
    const double pdf = lambda.pdf(i);
    if (!(pdf > 0)) continue;
    const double l = lambda.lambda(i), v = L[i] / pdf;
    for (size_t c = 0; c < 3; ++c) e[c] += resp_[c].eval(l) * v;
  }
  for (double& v : e) v /= kSpectrumSamples;
  return e;
}

std::array<double, 3> SensorModel::expectedElectrons(const Spectrum& s) const {
  std::array<double, 3> e{0, 0, 0};
  for (int l = kTableMin; l <= kTableMax; ++l) {
    const double w = (l == kTableMin || l == kTableMax) ? 0.5 : 1.0;  // trapezoid
    for (size_t c = 0; c < 3; ++c) e[c] += w * resp_[c].v[size_t(l - kTableMin)] * s.eval(l);
  }
  return e;
}

std::pair<double, double> SensorModel::fixedPattern(int x, int y) const {
  if (config_.prnu == 0 && config_.dsnu_e == 0) return {1.0, 0.0};
  PixelRng r = pixelRng(config_.pattern_seed, 0x5f5f, x, y);
  const double g = 1 + config_.prnu * gaussian(r);
  const double d = config_.dsnu_e * gaussian(r);
  return {std::max(0.0, g), d};
}

uint16_t SensorModel::digitize(int x, int y, const std::array<double, 3>& e) const {
  const SensorConfig& c = config_;
  const double signal = std::max(0.0, channelElectrons(cfaChannel(cfa_, x, y), e));
  const auto [gain, offset] = fixedPattern(x, y);
  const double mean = signal * gain + c.darkCurrent() * c.exposure_s;
  double n = mean + offset, read = 0;
  if (c.noise) {
    PixelRng r = pixelRng(c.seed, 0xa11ce, x, y);
    // Poisson counts: exact (std::poisson_distribution, deterministic from the engine) up to
    // 1e7 e-, beyond which the Gaussian limit differs from it by < 1e-3 of its spread.
    double counts;
    if (mean < 1e7) {
      std::poisson_distribution<long long> pd(mean);
      counts = mean > 0 ? double(pd(r)) : 0.0;
    } else {
      counts = std::round(mean + std::sqrt(mean) * gaussian(r));
    }
    n = counts + offset;
    read = c.read_noise_e * gaussian(r);
  }
  n = std::clamp(n, 0.0, c.full_well_e);
  const double dn = std::round((n + read) * c.gainDnPerE()) + c.black_level_dn;
  return uint16_t(std::clamp(dn, 0.0, double(c.whiteLevel())));
}

std::vector<uint16_t> digitizeImage(const SensorModel& m, const std::vector<float>& rgb, int w,
                                    int h, int x0, int y0) {
  std::vector<uint16_t> out(size_t(w) * size_t(h));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t i = size_t(y) * size_t(w) + size_t(x);
      out[i] = m.digitize(x0 + x, y0 + y, {rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]});
    }
  return out;
}

}  // namespace lensim::render
