#include "lensim/render/spectra/spectrum.h"

#include <algorithm>
#include <complex>
#include <map>
#include <mutex>
#include <numbers>
#include <span>

#include <fmt/format.h>

#include "lensim/render/spectra/spectrum_data.h"
#include "lensim/sampling/sampling.h"
#include "lensim/util/error.h"

namespace lensim::render {

using namespace lensim::sampling;

namespace {
constexpr double kLambdaRange_nm = kLambdaMax_nm - kLambdaMin_nm;
}

// ---------------------------------------------------------------------------------------------
// SampledSpectrum helpers

SampledSpectrum sqrt(const SampledSpectrum& s) {
  SampledSpectrum r;
  for (int i = 0; i < kSpectrumSamples; ++i) r[i] = std::sqrt(std::max(0.0, s[i]));
  return r;
}
SampledSpectrum exp(const SampledSpectrum& s) {
  SampledSpectrum r;
  for (int i = 0; i < kSpectrumSamples; ++i) r[i] = std::exp(s[i]);
  return r;
}
SampledSpectrum clampZero(const SampledSpectrum& s) {
  SampledSpectrum r;
  for (int i = 0; i < kSpectrumSamples; ++i) r[i] = std::max(0.0, s[i]);
  return r;
}
SampledSpectrum safeDiv(const SampledSpectrum& a, const SampledSpectrum& b) {
  SampledSpectrum r;
  for (int i = 0; i < kSpectrumSamples; ++i) r[i] = b[i] != 0.0 ? a[i] / b[i] : 0.0;
  return r;
}

// ---------------------------------------------------------------------------------------------
// SampledWavelengths

SampledWavelengths SampledWavelengths::sampleUniform(double u) {
  SampledWavelengths w;
  w.lambda_nm_[0] = kLambdaMin_nm + u * kLambdaRange_nm;
  const double delta = kLambdaRange_nm / kSpectrumSamples;
  for (int i = 1; i < kSpectrumSamples; ++i) {
    w.lambda_nm_[i] = w.lambda_nm_[i - 1] + delta;
    if (w.lambda_nm_[i] > kLambdaMax_nm) w.lambda_nm_[i] -= kLambdaRange_nm;
  }
  w.pdf_.fill(1.0 / kLambdaRange_nm);
  return w;
}

// Radziszewski, Boryczko, Alda 2009, "An improved technique for full spectral rendering"
// (J. WSCG 17): the density 1/cosh^2(0.0072 (lambda - 538)) restricted to [360, 830] nm; its CDF
// is proportional to tanh. sampleVisible draws from its average over each 1 nm cell (the cell
// masses are exact tanh differences), which keeps the estimator unbiased and needs no
// transcendental function per sample; the pdf differs from the smooth one by at most
// 0.0072 * 2 * 1 nm relative (the slope of log cosh^-2 over a cell).
namespace {
constexpr double kVisibleA = 0.0072, kVisibleCentre_nm = 538.0;

struct VisibleTable {
  static constexpr int kCells = static_cast<int>(kLambdaRange_nm);  // 1 nm cells
  static constexpr int kGuide = 1024;
  std::array<double, kCells> pdf{};      // density in cell k (1/nm) = its probability mass
  std::array<double, kCells + 1> cdf{};  // cdf[k] = mass of cells below k; cdf[kCells] = 1
  std::array<int, kGuide + 1> guide{};   // last cell k with cdf[k] <= g / kGuide
  VisibleTable() {
    auto tanhAt = [](double l) { return std::tanh(kVisibleA * (l - kVisibleCentre_nm)); };
    const double t_lo = tanhAt(kLambdaMin_nm), t_hi = tanhAt(kLambdaMax_nm);
    for (int k = 0; k < kCells; ++k) {
      pdf[size_t(k)] =
          (tanhAt(kLambdaMin_nm + k + 1) - tanhAt(kLambdaMin_nm + k)) / (t_hi - t_lo);
      cdf[size_t(k) + 1] = cdf[size_t(k)] + pdf[size_t(k)];
    }
    // Renormalise away the rounding of the running sum.
    const double total = cdf[kCells];
    for (int k = 0; k < kCells; ++k) pdf[size_t(k)] /= total;
    for (int k = 1; k <= kCells; ++k) cdf[size_t(k)] /= total;
    cdf[kCells] = 1.0;
    int k = 0;
    for (int g = 0; g <= kGuide; ++g) {
      const double u = static_cast<double>(g) / kGuide;
      while (k + 1 < kCells && cdf[size_t(k) + 1] <= u) ++k;
      guide[size_t(g)] = k;
    }
  }
  // The cell holding u in [0, 1): the last k with cdf[k] <= u, found from the guide entry below
  // u by a short forward scan (about one step: 470 cells for 1024 guide entries).
  double sample(double u, double& pdf_out) const {
    int k = guide[size_t(static_cast<int>(u * kGuide))];
    while (k + 1 < kCells && cdf[size_t(k) + 1] <= u) ++k;
    pdf_out = pdf[size_t(k)];
    const double t = pdf_out > 0 ? (u - cdf[size_t(k)]) / pdf_out : 0.0;
    return std::min(kLambdaMin_nm + k + std::clamp(t, 0.0, 1.0), kLambdaMax_nm);
  }
};

const VisibleTable& visibleTable() {
  static const VisibleTable table;
  return table;
}
}  // namespace

double SampledWavelengths::visiblePdfExact(double lambda_nm) {
  if (lambda_nm < kLambdaMin_nm || lambda_nm > kLambdaMax_nm) return 0.0;
  const double t_lo = std::tanh(kVisibleA * (kLambdaMin_nm - kVisibleCentre_nm));
  const double t_hi = std::tanh(kVisibleA * (kLambdaMax_nm - kVisibleCentre_nm));
  const double c = std::cosh(kVisibleA * (lambda_nm - kVisibleCentre_nm));
  return kVisibleA / (t_hi - t_lo) / (c * c);
}

double SampledWavelengths::visiblePdf(double lambda_nm) {
  if (lambda_nm < kLambdaMin_nm || lambda_nm > kLambdaMax_nm) return 0.0;
  const int k = std::min(static_cast<int>(lambda_nm - kLambdaMin_nm), VisibleTable::kCells - 1);
  return visibleTable().pdf[size_t(k)];
}

SampledWavelengths SampledWavelengths::sampleVisible(double u) {
  const VisibleTable& table = visibleTable();
  SampledWavelengths w;
  for (int i = 0; i < kSpectrumSamples; ++i) {
    double up = u + static_cast<double>(i) / kSpectrumSamples;
    if (up >= 1.0) up -= 1.0;
    w.lambda_nm_[size_t(i)] = table.sample(std::clamp(up, 0.0, kOneMinusEpsilon), w.pdf_[size_t(i)]);
  }
  return w;
}

SampledSpectrum SampledWavelengths::pdfs() const {
  SampledSpectrum s;
  for (int i = 0; i < kSpectrumSamples; ++i) s[i] = pdf_[i];
  return s;
}

void SampledWavelengths::terminateSecondary() {
  if (secondaryTerminated()) return;
  for (int i = 1; i < kSpectrumSamples; ++i) pdf_[i] = 0.0;
  pdf_[0] /= kSpectrumSamples;
}

bool SampledWavelengths::secondaryTerminated() const {
  for (int i = 1; i < kSpectrumSamples; ++i)
    if (pdf_[i] != 0.0) return false;
  return true;
}

// ---------------------------------------------------------------------------------------------
// Spectra

SampledSpectrum Spectrum::sample(const SampledWavelengths& lambda) const {
  SampledSpectrum s;
  for (int i = 0; i < kSpectrumSamples; ++i) s[i] = eval(lambda.lambda(i));
  return s;
}

PiecewiseLinearSpectrum::PiecewiseLinearSpectrum(std::vector<double> lambdas_nm,
                                                 std::vector<double> values)
    : lambda_nm_(std::move(lambdas_nm)), values_(std::move(values)) {
  if (lambda_nm_.empty() || lambda_nm_.size() != values_.size())
    throw Error("piecewise-linear spectrum needs as many values as wavelengths (at least one)");
  for (size_t i = 1; i < lambda_nm_.size(); ++i)
    if (!(lambda_nm_[i] > lambda_nm_[i - 1]))
      throw Error(fmt::format("piecewise-linear spectrum: wavelengths must increase ({} after {})",
                              lambda_nm_[i], lambda_nm_[i - 1]));
  if (lambda_nm_.size() >= 2) {
    first_segment_.resize(WavelengthTable::kSize);
    for (int k = 0; k < WavelengthTable::kSize; ++k) {
      const double l = std::clamp(kLambdaMin_nm + k, lambda_nm_.front(), lambda_nm_.back());
      const size_t i =
          std::upper_bound(lambda_nm_.begin(), lambda_nm_.end(), l) - lambda_nm_.begin() - 1;
      first_segment_[size_t(k)] = uint32_t(std::min(i, lambda_nm_.size() - 2));
    }
  }
}

std::shared_ptr<PiecewiseLinearSpectrum> PiecewiseLinearSpectrum::fromInterleaved(
    const std::vector<double>& pairs, bool normalize) {
  if (pairs.size() % 2 != 0)
    throw Error("spectrum needs (wavelength, value) pairs: odd number of values");
  std::vector<double> l, v;
  for (size_t i = 0; i < pairs.size(); i += 2) {
    l.push_back(pairs[i]);
    v.push_back(pairs[i + 1]);
  }
  auto s = std::make_shared<PiecewiseLinearSpectrum>(std::move(l), std::move(v));
  if (normalize) {
    const double y = spectrumToXyz(*s).y;
    if (y > 0) s->scale(1.0 / y);
  }
  return s;
}

size_t PiecewiseLinearSpectrum::segment(double lambda_nm) const {
  if (!WavelengthTable::covers(lambda_nm))
    return std::upper_bound(lambda_nm_.begin(), lambda_nm_.end(), lambda_nm) -
           lambda_nm_.begin() - 1;
  // The segment of the integer nm below, then forward past the knots in between (the last i
  // with lambda_nm_[i] <= lambda_nm, as the binary search finds).
  size_t i = first_segment_[size_t(lambda_nm - kLambdaMin_nm)];
  while (lambda_nm_[i + 1] <= lambda_nm) ++i;
  return i;
}

double PiecewiseLinearSpectrum::eval(double lambda_nm) const {
  if (lambda_nm <= lambda_nm_.front()) return values_.front();
  if (lambda_nm >= lambda_nm_.back()) return values_.back();
  const size_t i = segment(lambda_nm);
  const double t = (lambda_nm - lambda_nm_[i]) / (lambda_nm_[i + 1] - lambda_nm_[i]);
  return values_[i] * (1 - t) + values_[i + 1] * t;
}

SampledSpectrum PiecewiseLinearSpectrum::sample(const SampledWavelengths& lambda) const {
  SampledSpectrum s;
  for (int i = 0; i < kSpectrumSamples; ++i) s[i] = eval(lambda.lambda(i));
  return s;
}

double PiecewiseLinearSpectrum::maxValue() const {
  return *std::max_element(values_.begin(), values_.end());
}

void PiecewiseLinearSpectrum::scale(double s) {
  for (double& v : values_) v *= s;
}

double BlackbodySpectrum::planck(double lambda_nm, double temperature_K) {
  if (temperature_K <= 0) return 0.0;
  constexpr double c = 299792458.0;     // m/s
  constexpr double h = 6.62606957e-34;  // J s
  constexpr double kb = 1.3806488e-23;  // J/K
  const double l = lambda_nm * 1e-9;    // m
  const double l2 = l * l;
  return (2 * h * c * c) / (l2 * l2 * l * (std::exp((h * c) / (l * kb * temperature_K)) - 1));
}

BlackbodySpectrum::BlackbodySpectrum(double temperature_K) : temperature_K_(temperature_K) {
  if (!(temperature_K > 0))
    throw Error(fmt::format("blackbody temperature {} K must be positive", temperature_K));
  // Wien's displacement law: peak at b / T, b = 2.8977721e-3 m K.
  const double peak_nm = 2.8977721e-3 / temperature_K * 1e9;
  norm_ = 1.0 / planck(peak_nm, temperature_K);
  table_ = WavelengthTable([&](double l) { return evalExact(l); });
}

double BlackbodySpectrum::eval(double lambda_nm) const {
  return WavelengthTable::covers(lambda_nm) ? table_(lambda_nm) : evalExact(lambda_nm);
}

SampledSpectrum BlackbodySpectrum::sample(const SampledWavelengths& lambda) const {
  SampledSpectrum s;
  for (int i = 0; i < kSpectrumSamples; ++i) s[i] = eval(lambda.lambda(i));
  return s;
}

// ---------------------------------------------------------------------------------------------
// CIE colorimetry

namespace {
// cieXyzBar's body, inlined into the film's per-sample sampledToXyz.
inline Vec3 cmf(double lambda_nm) {
  const double f = (lambda_nm - data::kCieFirst_nm) / data::kCieStep_nm;
  if (f < 0 || f > 94) return {};
  const int i = std::min(static_cast<int>(f), 93);
  const double t = f - i;
  const auto& a = data::kCie1931_5nm[i];
  const auto& b = data::kCie1931_5nm[i + 1];
  return {a[0] * (1 - t) + b[0] * t, a[1] * (1 - t) + b[1] * t, a[2] * (1 - t) + b[2] * t};
}
}  // namespace

Vec3 cieXyzBar(double lambda_nm) {
  return cmf(lambda_nm);
}

namespace {
// Rectangle rule at 1 nm over 360..830 (the same sum spectrumToXyz uses).
double computeYIntegral() {
  double sum = 0;
  for (int l = 360; l <= 830; ++l) sum += cieXyzBar(l).y;
  return sum;
}
}  // namespace

double cieYIntegral() {
  static const double integral = computeYIntegral();
  return integral;
}

Vec3 spectrumToXyz(const Spectrum& s) {
  Vec3 xyz;
  for (int l = 360; l <= 830; ++l) xyz += cieXyzBar(l) * s.eval(l);
  return xyz / cieYIntegral();
}

Vec3 sampledToXyz(const SampledSpectrum& s, const SampledWavelengths& lambda) {
  Vec3 xyz;
  for (int i = 0; i < kSpectrumSamples; ++i)
    if (lambda.pdf(i) > 0) xyz += cmf(lambda.lambda(i)) * (s[i] / lambda.pdf(i));
  return xyz / (kSpectrumSamples * cieYIntegral());
}

// ---------------------------------------------------------------------------------------------
// Sigmoid polynomials (Jakob & Hanika 2019)

namespace {
double sigmoid(double t) {
  if (std::isinf(t)) return t > 0 ? 1.0 : 0.0;
  return 0.5 + t / (2.0 * std::sqrt(1.0 + t * t));
}
// d sigmoid / dt
double sigmoidDerivative(double t) {
  return 0.5 / std::pow(1.0 + t * t, 1.5);
}
double normalisedLambda(double lambda_nm) {
  return (lambda_nm - kLambdaMin_nm) / kLambdaRange_nm;
}
}  // namespace

double SigmoidPolynomial::eval(double lambda_nm) const {
  const double x = normalisedLambda(lambda_nm);
  return sigmoid((c[0] * x + c[1]) * x + c[2]);
}

SampledSpectrum SigmoidPolynomial::sample(const SampledWavelengths& lambda) const {
  constexpr int n = kSpectrumSamples;
  double t[n], r[n];
  for (int i = 0; i < n; ++i) {
    const double x = normalisedLambda(lambda.lambda(i));
    t[i] = (c[0] * x + c[1]) * x + c[2];
  }
  for (int i = 0; i < n; ++i) r[i] = 0.5 + t[i] / (2.0 * std::sqrt(1.0 + t[i] * t[i]));
  // sigmoid()'s infinite arguments (greys 0 and 1 have an infinite c[2]) as a select.
  for (int i = 0; i < n; ++i) r[i] = std::isinf(t[i]) ? (t[i] > 0 ? 1.0 : 0.0) : r[i];
  SampledSpectrum s;
  for (int i = 0; i < n; ++i) s[i] = r[i];
  return s;
}

double SigmoidPolynomial::maxValue() const {
  // The sigmoid is monotonic: the maximum is at an end or at the parabola's vertex.
  double m = std::max(eval(kLambdaMin_nm), eval(kLambdaMax_nm));
  if (c[0] != 0) {
    const double x = -c[1] / (2 * c[0]);
    if (x > 0 && x < 1) m = std::max(m, eval(kLambdaMin_nm + x * kLambdaRange_nm));
  }
  return m;
}

// ---------------------------------------------------------------------------------------------
// RGB colour space

struct RGBColorSpace::Impl {
  // RGB response (under the illuminant) per 1 nm wavelength sample: rgb = sum_j w[j] s(x_j).
  std::vector<Vec3> weights;
  std::vector<double> x;  // normalised wavelengths
  mutable std::mutex mutex;
  mutable std::map<std::array<double, 3>, SigmoidPolynomial> cache;

  Vec3 rgbOf(const std::array<double, 3>& c) const {
    Vec3 rgb;
    for (size_t j = 0; j < x.size(); ++j)
      rgb += weights[j] * sigmoid((c[0] * x[j] + c[1]) * x[j] + c[2]);
    return rgb;
  }
  SigmoidPolynomial fit(const Vec3& target) const;
  /// Damped Gauss-Newton from c toward goal; returns the final squared RGB error.
  double refine(std::array<double, 3>& c, const Vec3& goal, int max_iterations) const;

  // Lazily filled coefficient table (see RGBColorSpace::tableSigmoid).
  static constexpr int kRes = 32;
  std::vector<double> z_nodes;
  mutable std::vector<std::array<double, 3>> table;       // [max channel][z][y][x]
  mutable std::unique_ptr<std::once_flag[]> column_once;  // [max channel][y][x]
  void fitColumn(int channel, int xi, int yi) const;
  const std::array<double, 3>& tableEntry(int channel, int zi, int yi, int xi) const {
    std::call_once(column_once[(channel * kRes + yi) * kRes + xi],
                   [&] { fitColumn(channel, xi, yi); });
    return table[((static_cast<size_t>(channel) * kRes + zi) * kRes + yi) * kRes + xi];
  }
};

namespace {
void invert3(const std::array<double, 9>& m, std::array<double, 9>& inv) {
  const double det = m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) +
                     m[2] * (m[3] * m[7] - m[4] * m[6]);
  inv = {(m[4] * m[8] - m[5] * m[7]) / det, (m[2] * m[7] - m[1] * m[8]) / det,
         (m[1] * m[5] - m[2] * m[4]) / det, (m[5] * m[6] - m[3] * m[8]) / det,
         (m[0] * m[8] - m[2] * m[6]) / det, (m[2] * m[3] - m[0] * m[5]) / det,
         (m[3] * m[7] - m[4] * m[6]) / det, (m[1] * m[6] - m[0] * m[7]) / det,
         (m[0] * m[4] - m[1] * m[3]) / det};
}
Vec3 mul(const std::array<double, 9>& m, const Vec3& v) {
  return {m[0] * v.x + m[1] * v.y + m[2] * v.z, m[3] * v.x + m[4] * v.y + m[5] * v.z,
          m[6] * v.x + m[7] * v.y + m[8] * v.z};
}
SpectrumPtr makeD65() {
  std::vector<double> pairs;
  for (int i = 0; i < 95; ++i) {
    pairs.push_back(data::kCieFirst_nm + data::kCieStep_nm * i);
    pairs.push_back(data::kD65_5nm[i]);
  }
  return PiecewiseLinearSpectrum::fromInterleaved(pairs, true);
}
}  // namespace

RGBColorSpace::RGBColorSpace()
    : impl_(std::make_shared<Impl>()),
      illuminant_(makeD65()),
      illuminant_table_([this](double l) { return illuminant_->eval(l); }) {
  // Primaries' chromaticities (ITU-R BT.709 / sRGB); white = XYZ of the D65 table.
  const double xr = 0.64, yr = 0.33, xg = 0.30, yg = 0.60, xb = 0.15, yb = 0.06;
  const Vec3 white = spectrumToXyz(*illuminant_);
  const std::array<double, 9> prim = {
      xr / yr,           xg / yg, xb / yb, 1.0, 1.0, 1.0, (1 - xr - yr) / yr, (1 - xg - yg) / yg,
      (1 - xb - yb) / yb};
  std::array<double, 9> prim_inv;
  invert3(prim, prim_inv);
  const Vec3 scale = mul(prim_inv, white);  // luminance of each primary so they sum to white
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) rgb_to_xyz_[3 * r + c] = prim[3 * r + c] * scale[c];
  invert3(rgb_to_xyz_, xyz_to_rgb_);

  // Weights for the sigmoid fit: the RGB of a reflectance under the illuminant.
  for (int l = 360; l <= 830; ++l) {
    const Vec3 xyz = cieXyzBar(l) * (illuminant_->eval(l) / cieYIntegral());
    impl_->weights.push_back(mul(xyz_to_rgb_, xyz));
    impl_->x.push_back(normalisedLambda(l));
  }
  // z nodes crowd toward 0 and 1 (smoothstep of smoothstep), where coefficients change fastest.
  constexpr int res = Impl::kRes;
  auto smoothstep = [](double t) { return t * t * (3 - 2 * t); };
  for (int k = 0; k < res; ++k)
    impl_->z_nodes.push_back(smoothstep(smoothstep(static_cast<double>(k) / (res - 1))));
  impl_->table.resize(static_cast<size_t>(3) * res * res * res);
  impl_->column_once = std::make_unique<std::once_flag[]>(3 * res * res);
}

const RGBColorSpace& RGBColorSpace::sRGB() {
  static const RGBColorSpace cs;
  return cs;
}

Vec3 RGBColorSpace::toRgb(const Vec3& xyz) const {
  return mul(xyz_to_rgb_, xyz);
}
Vec3 RGBColorSpace::toXyz(const Vec3& rgb) const {
  return mul(rgb_to_xyz_, rgb);
}

// Levenberg-Marquardt-damped Gauss-Newton on the linear RGB residual.
double RGBColorSpace::Impl::refine(std::array<double, 3>& c, const Vec3& goal,
                                   int max_iterations) const {
  double lambda = 1e-3;
  Vec3 r = goal - rgbOf(c);
  double err = dot(r, r);
  for (int it = 0; it < max_iterations && err > 1e-14; ++it) {
    // Jacobian of rgb with respect to c (3x3, columns are d rgb / d c_k).
    Vec3 J[3];
    for (size_t j = 0; j < x.size(); ++j) {
      const double t = (c[0] * x[j] + c[1]) * x[j] + c[2];
      const Vec3 d = weights[j] * sigmoidDerivative(t);
      J[0] += d * (x[j] * x[j]);
      J[1] += d * x[j];
      J[2] += d;
    }
    // Normal equations (J^T J + lambda diag) dc = J^T r.
    std::array<double, 9> A;
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) A[3 * a + b] = dot(J[a], J[b]);
      A[4 * a] *= 1.0 + lambda;
    }
    const Vec3 g(dot(J[0], r), dot(J[1], r), dot(J[2], r));
    std::array<double, 9> Ainv;
    invert3(A, Ainv);
    const Vec3 dc = mul(Ainv, g);
    const std::array<double, 3> trial = {c[0] + dc.x, c[1] + dc.y, c[2] + dc.z};
    const Vec3 rt = goal - rgbOf(trial);
    const double et = dot(rt, rt);
    if (std::isfinite(et) && et < err) {
      c = trial, r = rt, err = et;
      lambda = std::max(lambda * 0.3, 1e-9);
    } else {
      lambda *= 10;
      if (lambda > 1e8) break;
    }
  }
  return err;
}

// Continuation from the grey of the same mean (whose exact solution is a constant) toward the
// target, so that each solve starts close to its answer (Jakob & Hanika fit their table the same
// way, outward from grey).
SigmoidPolynomial RGBColorSpace::Impl::fit(const Vec3& target) const {
  const double grey = std::clamp((target.x + target.y + target.z) / 3.0, 1e-4, 1.0 - 1e-4);
  std::array<double, 3> c = {0.0, 0.0, (grey - 0.5) / std::sqrt(grey * (1.0 - grey))};
  constexpr int kSteps = 8;
  for (int step = 1; step <= kSteps; ++step) {
    const double f = static_cast<double>(step) / kSteps;
    refine(c, Vec3(grey, grey, grey) * (1 - f) + target * f, 60);
  }
  return SigmoidPolynomial{c};
}

// One column of the table: fixed dominant channel and chromaticity ratios (x, y), all z nodes.
// Solved at z = 1/5 of the grid from grey, then outward in z, each solve warm-started from its
// neighbour (falling back to the continuation fit if that does not converge).
void RGBColorSpace::Impl::fitColumn(int channel, int xi, int yi) const {
  const double xr = static_cast<double>(xi) / (kRes - 1), yr = static_cast<double>(yi) / (kRes - 1);
  auto target = [&](int zi) {
    const double z = z_nodes[zi];
    double rgb[3];
    rgb[channel] = z;
    rgb[(channel + 1) % 3] = xr * z;
    rgb[(channel + 2) % 3] = yr * z;
    return Vec3(rgb[0], rgb[1], rgb[2]);
  };
  auto store = [&](int zi, const std::array<double, 3>& c) {
    table[((static_cast<size_t>(channel) * kRes + zi) * kRes + yi) * kRes + xi] = c;
  };
  const int start = kRes / 5;
  const std::array<double, 3> c0 = fit(target(start)).c;
  store(start, c0);
  for (int dir : {+1, -1}) {
    std::array<double, 3> c = c0;
    for (int zi = start + dir; zi >= 0 && zi < kRes; zi += dir) {
      if (refine(c, target(zi), 30) > 1e-12) {
        std::array<double, 3> fresh = fit(target(zi)).c;
        Vec3 r1 = target(zi) - rgbOf(fresh), r2 = target(zi) - rgbOf(c);
        if (dot(r1, r1) < dot(r2, r2)) c = fresh;
      }
      store(zi, c);
    }
  }
}

SigmoidPolynomial RGBColorSpace::fitSigmoid(const Vec3& rgb_in) const {
  const Vec3 rgb(std::clamp(rgb_in.x, 0.0, 1.0), std::clamp(rgb_in.y, 0.0, 1.0),
                 std::clamp(rgb_in.z, 0.0, 1.0));
  // Greys are constants; 0 and 1 need infinite offsets, which sigmoid() handles.
  if (rgb.x == rgb.y && rgb.y == rgb.z) {
    const double g = rgb.x;
    const double c2 = g <= 0 ? -INFINITY : g >= 1 ? INFINITY : (g - 0.5) / std::sqrt(g * (1.0 - g));
    return SigmoidPolynomial{{0.0, 0.0, c2}};
  }
  const std::array<double, 3> key = {rgb.x, rgb.y, rgb.z};
  {
    std::lock_guard lock(impl_->mutex);
    if (auto it = impl_->cache.find(key); it != impl_->cache.end()) return it->second;
  }
  const SigmoidPolynomial poly = impl_->fit(rgb);
  std::lock_guard lock(impl_->mutex);
  impl_->cache.emplace(key, poly);
  return poly;
}

SigmoidPolynomial RGBColorSpace::tableSigmoid(const Vec3& rgb_in) const {
  const Vec3 rgb(std::clamp(rgb_in.x, 0.0, 1.0), std::clamp(rgb_in.y, 0.0, 1.0),
                 std::clamp(rgb_in.z, 0.0, 1.0));
  if (rgb.x == rgb.y && rgb.y == rgb.z) return fitSigmoid(rgb);  // exact constant
  constexpr int res = Impl::kRes;
  const double v[3] = {rgb.x, rgb.y, rgb.z};
  const int c = (v[0] >= v[1] && v[0] >= v[2]) ? 0 : (v[1] >= v[2] ? 1 : 2);
  const double z = v[c];
  const double x = v[(c + 1) % 3] / z * (res - 1), y = v[(c + 2) % 3] / z * (res - 1);
  const int xi = std::min(static_cast<int>(x), res - 2),
            yi = std::min(static_cast<int>(y), res - 2);
  const auto& zn = impl_->z_nodes;
  const int zi = std::clamp(
      static_cast<int>(std::upper_bound(zn.begin(), zn.end(), z) - zn.begin()) - 1, 0, res - 2);
  const double dx = x - xi, dy = y - yi, dz = (z - zn[zi]) / (zn[zi + 1] - zn[zi]);
  SigmoidPolynomial out;
  for (int corner = 0; corner < 8; ++corner) {
    const int ox = corner & 1, oy = (corner >> 1) & 1, oz = (corner >> 2) & 1;
    const double w = (ox ? dx : 1 - dx) * (oy ? dy : 1 - dy) * (oz ? dz : 1 - dz);
    if (w == 0) continue;
    const auto& e = impl_->tableEntry(c, zi + oz, yi + oy, xi + ox);
    for (int k = 0; k < 3; ++k) out.c[k] += w * e[k];
  }
  return out;
}

RGBAlbedoSpectrum::RGBAlbedoSpectrum(const RGBColorSpace& cs, const Vec3& rgb) {
  if (rgb.x < 0 || rgb.y < 0 || rgb.z < 0 || rgb.x > 1 || rgb.y > 1 || rgb.z > 1)
    throw Error(fmt::format("RGB reflectance ({}, {}, {}) must lie in [0,1]", rgb.x, rgb.y, rgb.z));
  poly_ = cs.fitSigmoid(rgb);
}

namespace {
void unboundedFit(const RGBColorSpace& cs, const Vec3& rgb, double& scale,
                  SigmoidPolynomial& poly) {
  if (rgb.x < 0 || rgb.y < 0 || rgb.z < 0)
    throw Error(fmt::format("RGB value ({}, {}, {}) must not be negative", rgb.x, rgb.y, rgb.z));
  const double m = std::max({rgb.x, rgb.y, rgb.z});
  scale = 2 * m;
  poly = cs.fitSigmoid(scale > 0 ? rgb / scale : Vec3());
}
}  // namespace

RGBUnboundedSpectrum::RGBUnboundedSpectrum(const RGBColorSpace& cs, const Vec3& rgb) {
  unboundedFit(cs, rgb, scale_, poly_);
}

RGBIlluminantSpectrum::RGBIlluminantSpectrum(const RGBColorSpace& cs, const Vec3& rgb)
    : illuminant_(cs.illuminant()), illuminant_table_(&cs.illuminantTable()) {
  unboundedFit(cs, rgb, scale_, poly_);
}

double RGBIlluminantSpectrum::illuminant(double lambda_nm) const {
  return WavelengthTable::covers(lambda_nm) ? (*illuminant_table_)(lambda_nm)
                                            : illuminant_->eval(lambda_nm);
}

double RGBIlluminantSpectrum::eval(double lambda_nm) const {
  return scale_ * poly_.eval(lambda_nm) * illuminant(lambda_nm);
}

SampledSpectrum RGBIlluminantSpectrum::sample(const SampledWavelengths& lambda) const {
  SampledSpectrum s = poly_.sample(lambda);
  for (int i = 0; i < kSpectrumSamples; ++i) s[i] = s[i] * scale_ * illuminant(lambda.lambda(i));
  return s;
}

SampledSpectrum RGBAlbedoSpectrum::sample(const SampledWavelengths& lambda) const {
  return poly_.sample(lambda);
}

SampledSpectrum RGBUnboundedSpectrum::sample(const SampledWavelengths& lambda) const {
  return poly_.sample(lambda) * scale_;
}
double RGBIlluminantSpectrum::maxValue() const {
  return scale_ * poly_.maxValue() * illuminant_->maxValue();
}

// ---------------------------------------------------------------------------------------------
// Named spectra

namespace {

SpectrumPtr interleaved(std::span<const double> d) {
  return PiecewiseLinearSpectrum::fromInterleaved(std::vector<double>(d.begin(), d.end()), false);
}

}  // namespace

std::vector<std::string> namedSpectrumNames() {
  return {"stdillum-D65", "metal-Cu-eta",   "metal-Cu-k",   "metal-Au-eta", "metal-Au-k",
          "metal-Ag-eta", "metal-Ag-k",     "metal-Al-eta", "metal-Al-k",   "metal-MgO-eta",
          "metal-MgO-k",  "metal-TiO2-eta", "metal-TiO2-k"};
}

SpectrumPtr namedSpectrum(std::string_view name) {
  if (name == "stdillum-D65") return RGBColorSpace::sRGB().illuminant();
  if (name == "metal-Cu-eta") return interleaved(data::kCuEta);
  if (name == "metal-Cu-k") return interleaved(data::kCuK);
  if (name == "metal-Au-eta") return interleaved(data::kAuEta);
  if (name == "metal-Au-k") return interleaved(data::kAuK);
  if (name == "metal-Ag-eta") return interleaved(data::kAgEta);
  if (name == "metal-Ag-k") return interleaved(data::kAgK);
  if (name == "metal-Al-eta") return interleaved(data::kAlEta);
  if (name == "metal-Al-k") return interleaved(data::kAlK);
  if (name == "metal-MgO-eta") return interleaved(data::kMgOEta);
  if (name == "metal-MgO-k") return interleaved(data::kMgOK);
  if (name == "metal-TiO2-eta") return interleaved(data::kTiO2Eta);
  if (name == "metal-TiO2-k") return interleaved(data::kTiO2K);
  return nullptr;
}

}  // namespace lensim::render
