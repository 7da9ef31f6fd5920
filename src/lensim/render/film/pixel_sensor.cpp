// pbrt-v4's PixelSensor; see pixel_sensor.h. The measured data (camera sensitivities, the
// ColorChecker reflectances, the CIE daylight basis) are the files in data/sensors/, compiled in
// as text by cmake/embed_text.cmake; their sources are cited in the files' headers.
#include "lensim/render/film/pixel_sensor.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <stdexcept>

#include "lensim/render/film/film.h"  // daylightChromaticity

namespace lensim::embedded {
extern const char* const kCameraSensorsCsv;
extern const char* const kColorCheckerCsv;
extern const char* const kCieDaylightBasisCsv;
}  // namespace lensim::embedded

namespace lensim::render {

ZeroOutsideSpectrum::ZeroOutsideSpectrum(std::vector<double> lambda_nm, std::vector<double> values)
    : lambda_nm_(std::move(lambda_nm)), values_(std::move(values)) {
  // Evenly spaced samples (all of data/sensors/) are looked up by index, not by search.
  if (lambda_nm_.size() >= 2) {
    const double step = (lambda_nm_.back() - lambda_nm_.front()) / double(lambda_nm_.size() - 1);
    bool even = step > 0;
    for (size_t i = 0; i < lambda_nm_.size() && even; ++i)
      even = std::abs(lambda_nm_[i] - (lambda_nm_.front() + step * double(i))) < 1e-9 * step;
    if (even) inv_step_ = 1 / step;
  }
}

double ZeroOutsideSpectrum::eval(double l) const {
  if (lambda_nm_.empty() || l < lambda_nm_.front() || l > lambda_nm_.back()) return 0;
  size_t i;  // the sample at or after l, at least 1
  if (inv_step_ > 0) {
    const double f = (l - lambda_nm_.front()) * inv_step_;
    i = std::min(lambda_nm_.size() - 1, size_t(f) + 1);
    const double t = f - double(i - 1);
    return values_[i - 1] + t * (values_[i] - values_[i - 1]);
  }
  i = size_t(std::upper_bound(lambda_nm_.begin(), lambda_nm_.end(), l) - lambda_nm_.begin());
  if (i >= lambda_nm_.size()) return values_.back();
  const double t = (l - lambda_nm_[i - 1]) / (lambda_nm_[i] - lambda_nm_[i - 1]);
  return values_[i - 1] + t * (values_[i] - values_[i - 1]);
}

double ZeroOutsideSpectrum::maxValue() const {
  return values_.empty() ? 0 : *std::max_element(values_.begin(), values_.end());
}

namespace {

/// The data rows of an embedded CSV (lines that are neither empty nor '#' comments), split at
/// commas.
std::vector<std::vector<std::string>> csvRows(const char* text) {
  std::vector<std::vector<std::string>> rows;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> fields;
    std::string f;
    std::istringstream ls(line);
    while (std::getline(ls, f, ',')) fields.push_back(f);
    rows.push_back(std::move(fields));
  }
  return rows;
}

std::vector<double> wavelengths(double first, double step, size_t n) {
  std::vector<double> l(n);
  for (size_t i = 0; i < n; ++i) l[i] = first + step * double(i);
  return l;
}

struct CameraTable {
  std::vector<std::string> names;
  std::map<std::string, std::array<std::unique_ptr<ZeroOutsideSpectrum>, 3>> curves;
};

const CameraTable& cameraTable() {
  static const CameraTable table = [] {
    CameraTable t;
    for (const auto& row : csvRows(embedded::kCameraSensorsCsv)) {
      const std::string& name = row.at(0);
      const int c = row.at(1) == "r" ? 0 : row.at(1) == "g" ? 1 : 2;
      std::vector<double> v;
      for (size_t i = 2; i < row.size(); ++i) v.push_back(std::stod(row[i]));
      if (!t.curves.count(name)) t.names.push_back(name);
      t.curves[name][size_t(c)] =
          std::make_unique<ZeroOutsideSpectrum>(wavelengths(380, 10, v.size()), std::move(v));
    }
    return t;
  }();
  return table;
}

}  // namespace

const std::vector<std::string>& cameraSensorNames() {
  return cameraTable().names;
}

const ZeroOutsideSpectrum& cameraSensorCurve(const std::string& camera, int c) {
  return *cameraTable().curves.at(camera).at(size_t(c));
}

const std::vector<ZeroOutsideSpectrum>& colorCheckerReflectances() {
  static const std::vector<ZeroOutsideSpectrum> patches = [] {
    std::vector<ZeroOutsideSpectrum> p;
    for (const auto& row : csvRows(embedded::kColorCheckerCsv)) {
      std::vector<double> v;
      for (size_t i = 2; i < row.size(); ++i) v.push_back(std::stod(row[i]));
      p.emplace_back(wavelengths(380, 10, v.size()), std::move(v));
    }
    return p;
  }();
  return patches;
}

std::shared_ptr<const Spectrum> daylightIlluminant(double temperature_k) {
  // pbrt-v4 src/pbrt/util/spectrum.cpp, Spectra::D: the nominal temperature is converted to a
  // CCT with the current second radiation constant; below 4000 K CIE D is not defined and a
  // blackbody is used.
  const double cct = temperature_k * 1.4388 / 1.4380;
  if (cct < 4000) return std::make_shared<BlackbodySpectrum>(cct);
  const Vec2 xy = daylightChromaticity(cct);
  const double x = xy.x, y = xy.y;
  const double m = 0.0241 + 0.2562 * x - 0.7341 * y;
  const double m1 = (-1.3515 - 1.7703 * x + 5.9114 * y) / m;
  const double m2 = (0.0300 - 31.4424 * x + 30.0717 * y) / m;
  static const std::vector<std::vector<std::string>> basis =
      csvRows(embedded::kCieDaylightBasisCsv);
  std::vector<double> l, v;
  for (const auto& row : basis) {
    l.push_back(std::stod(row.at(0)));
    v.push_back((std::stod(row.at(1)) + m1 * std::stod(row.at(2)) + m2 * std::stod(row.at(3))) *
                0.01);
  }
  return std::make_shared<ZeroOutsideSpectrum>(std::move(l), std::move(v));
}

Vec3 projectReflectance(const Spectrum& refl, const Spectrum& illum,
                        const std::array<const Spectrum*, 3>& b) {
  // pbrt-v4 src/pbrt/film.h, PixelSensor::ProjectReflectance (1 nm steps over Lambda_min..max).
  Vec3 r;
  double g = 0;
  for (double l = 360; l <= 830; l += 1) {
    const double il = illum.eval(l), ri = refl.eval(l) * il;
    g += b[1]->eval(l) * il;
    r += Vec3{b[0]->eval(l), b[1]->eval(l), b[2]->eval(l)} * ri;
  }
  return r / g;
}

Vec3 mulMat3(const Mat3d& m, const Vec3& v) {
  return {m[0] * v.x + m[1] * v.y + m[2] * v.z, m[3] * v.x + m[4] * v.y + m[5] * v.z,
          m[6] * v.x + m[7] * v.y + m[8] * v.z};
}

Mat3d mulMat3(const Mat3d& a, const Mat3d& b) {
  Mat3d r{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k)
        r[size_t(3 * i + j)] += a[size_t(3 * i + k)] * b[size_t(3 * k + j)];
  return r;
}

Mat3d invertMat3(const Mat3d& m) {
  const double det = m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) +
                     m[2] * (m[3] * m[7] - m[4] * m[6]);
  return {(m[4] * m[8] - m[5] * m[7]) / det, (m[2] * m[7] - m[1] * m[8]) / det,
          (m[1] * m[5] - m[2] * m[4]) / det, (m[5] * m[6] - m[3] * m[8]) / det,
          (m[0] * m[8] - m[2] * m[6]) / det, (m[2] * m[3] - m[0] * m[5]) / det,
          (m[3] * m[7] - m[4] * m[6]) / det, (m[1] * m[6] - m[0] * m[7]) / det,
          (m[0] * m[4] - m[1] * m[3]) / det};
}

Mat3d bradfordAdaptation(Vec2 src, const Vec3& dst) {
  // Lam 1985; the matrix as published by Lindbloom. pbrt-v4's WhiteBalance (src/pbrt/util/
  // color.cpp) is the same von Kries scaling in its LMS space.
  const Mat3d mb{0.8951, 0.2664, -0.1614, -0.7502, 1.7135, 0.0367, 0.0389, -0.0685, 1.0296};
  const Vec3 src_xyz{src.x / src.y, 1.0, (1 - src.x - src.y) / src.y};
  const Vec3 ls = mulMat3(mb, src_xyz), ld = mulMat3(mb, dst / dst.y);
  const Mat3d d{ld.x / ls.x, 0, 0, 0, ld.y / ls.y, 0, 0, 0, ld.z / ls.z};
  return mulMat3(invertMat3(mb), mulMat3(d, mb));
}

Mat3d linearLeastSquares(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  // Normal equations: (A^T A) X = A^T B with rows a_i, b_i; M = X^T maps a to b.
  Mat3d ata{}, atb{};
  for (size_t i = 0; i < a.size(); ++i) {
    const double ai[3] = {a[i].x, a[i].y, a[i].z}, bi[3] = {b[i].x, b[i].y, b[i].z};
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) {
        ata[size_t(3 * r + c)] += ai[r] * ai[c];
        atb[size_t(3 * r + c)] += ai[r] * bi[c];
      }
  }
  const Mat3d x = mulMat3(invertMat3(ata), atb);
  return {x[0], x[3], x[6], x[1], x[4], x[7], x[2], x[5], x[8]};
}

PixelSensor::PixelSensor(const std::string& name, double white_balance_k, double imaging_ratio)
    : name_(name), imaging_ratio_(imaging_ratio) {
  const RGBColorSpace& cs = RGBColorSpace::sRGB();
  if (name == "cie1931") {
    // pbrt-v4's XYZ sensor: white balancing only when asked for.
    if (white_balance_k > 0) {
      illuminant_ = daylightIlluminant(white_balance_k);
      const Vec3 w = spectrumToXyz(*illuminant_);
      xyz_from_sensor_ = bradfordAdaptation({w.x / (w.x + w.y + w.z), w.y / (w.x + w.y + w.z)},
                                            cs.toXyz({1, 1, 1}));
    }
    return;
  }
  for (int c = 0; c < 3; ++c) curves_[size_t(c)] = &cameraSensorCurve(name, c);
  illuminant_ = daylightIlluminant(white_balance_k > 0 ? white_balance_k : 6500);
  // pbrt-v4 src/pbrt/film.h, the PixelSensor constructor for r, g, b curves: camera RGB of the
  // patches under the sensor illuminant, normalised to the illuminant's green; target XYZ under
  // the output space's illuminant, normalised to its Y, times sensor white Y / sensor white G
  // (so the matrix keeps the luminance the sensor sees).
  const std::array<const Spectrum*, 3> rgb = {curves_[0], curves_[1], curves_[2]};
  struct Cmf final : Spectrum {
    int c;
    explicit Cmf(int c_) : c(c_) {}
    double eval(double l) const override {
      const Vec3 v = cieXyzBar(l);
      return c == 0 ? v.x : c == 1 ? v.y : v.z;
    }
    double maxValue() const override { return 2; }
  };
  const Cmf x(0), y(1), z(2);
  const std::array<const Spectrum*, 3> xyz = {&x, &y, &z};
  double white_g = 0, white_y = 0;
  for (double l = 360; l <= 830; l += 1) {
    white_g += curves_[1]->eval(l) * illuminant_->eval(l);
    white_y += cieXyzBar(l).y * illuminant_->eval(l);
  }
  const Spectrum& out_illum = *cs.illuminant();
  for (const ZeroOutsideSpectrum& patch : colorCheckerReflectances()) {
    trainingRgb.push_back(projectReflectance(patch, *illuminant_, rgb));
    trainingXyz.push_back(projectReflectance(patch, out_illum, xyz) * (white_y / white_g));
  }
  xyz_from_sensor_ = linearLeastSquares(trainingRgb, trainingXyz);
}

Vec3 PixelSensor::toSensorRgb(const SampledSpectrum& L, const SampledWavelengths& lambda) const {
  if (!curves_[0]) return sampledToXyz(L, lambda) * imaging_ratio_;
  // pbrt-v4's ToSensorRGB: the Monte Carlo estimate of the integral of L against each curve. Its
  // radiance is lensim's divided by CIE_Y_integral (lensim's lights have unit luminance where
  // pbrt-v4's have a unit integral against y-bar), hence the division, as in sampledToXyz.
  Vec3 s;
  for (int i = 0; i < kSpectrumSamples; ++i) {
    const double pdf = lambda.pdf(i);
    if (!(pdf > 0)) continue;
    const double l = lambda.lambda(i), v = L[i] / pdf;
    s += Vec3{curves_[0]->eval(l), curves_[1]->eval(l), curves_[2]->eval(l)} * v;
  }
  return s * (imaging_ratio_ / (kSpectrumSamples * cieYIntegral()));
}

}  // namespace lensim::render
