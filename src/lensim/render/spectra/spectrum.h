// Spectral quantities for a spectral path tracer in the style of pbrt-v4.
//
// A camera path carries kSpectrumSamples wavelengths (hero-wavelength sampling, Wilkie et al.
// 2014). Spectra are functions of wavelength in nanometres; a SampledSpectrum holds their values
// at the path's wavelengths. RGB inputs are turned into smooth spectra with the sigmoid
// polynomials of Jakob & Hanika 2019, "A Low-Dimensional Function Space for Efficient Spectral
// Upsampling" (Computer Graphics Forum 38(2)); the three coefficients are fitted at run time by a
// damped Gauss-Newton solve and cached.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "lensim/util/vec.h"

namespace lensim::render {

/// Number of wavelengths carried by one camera path.
inline constexpr int kSpectrumSamples = 4;
/// The visible range spectra are sampled in, nanometres.
inline constexpr double kLambdaMin_nm = 360.0;
inline constexpr double kLambdaMax_nm = 830.0;

/// Values of a spectrum at the kSpectrumSamples wavelengths of a path (units of the spectrum).
class SampledSpectrum {
 public:
  SampledSpectrum() { v_.fill(0.0); }
  explicit SampledSpectrum(double c) { v_.fill(c); }
  double operator[](int i) const { return v_[i]; }
  double& operator[](int i) { return v_[i]; }

  SampledSpectrum& operator+=(const SampledSpectrum& o) {
    for (int i = 0; i < kSpectrumSamples; ++i) v_[i] += o.v_[i];
    return *this;
  }
  SampledSpectrum& operator+=(double s) {
    for (int i = 0; i < kSpectrumSamples; ++i) v_[i] += s;
    return *this;
  }
  friend SampledSpectrum operator+(SampledSpectrum a, const SampledSpectrum& b) { return a += b; }
  friend SampledSpectrum operator+(SampledSpectrum a, double s) { return a += s; }
  SampledSpectrum& operator-=(const SampledSpectrum& o) {
    for (int i = 0; i < kSpectrumSamples; ++i) v_[i] -= o.v_[i];
    return *this;
  }
  SampledSpectrum& operator-=(double s) {
    for (int i = 0; i < kSpectrumSamples; ++i) v_[i] -= s;
    return *this;
  }
  friend SampledSpectrum operator-(SampledSpectrum a, const SampledSpectrum& b) { return a -= b; }
  friend SampledSpectrum operator-(SampledSpectrum a, double s) { return a -= s; }
  SampledSpectrum& operator*=(const SampledSpectrum& o) {
    for (int i = 0; i < kSpectrumSamples; ++i) v_[i] *= o.v_[i];
    return *this;
  }
  SampledSpectrum& operator*=(double s) {
    for (int i = 0; i < kSpectrumSamples; ++i) v_[i] *= s;
    return *this;
  }
  friend SampledSpectrum operator*(SampledSpectrum a, const SampledSpectrum& b) { return a *= b; }
  friend SampledSpectrum operator*(SampledSpectrum a, double s) { return a *= s; }
  SampledSpectrum& operator/=(const SampledSpectrum& o) {
    for (int i = 0; i < kSpectrumSamples; ++i) v_[i] /= o.v_[i];
    return *this;
  }
  SampledSpectrum& operator/=(double s) {
    for (int i = 0; i < kSpectrumSamples; ++i) v_[i] /= s;
    return *this;
  }
  friend SampledSpectrum operator/(SampledSpectrum a, const SampledSpectrum& b) { return a /= b; }
  friend SampledSpectrum operator/(SampledSpectrum a, double s) { return a /= s; }
  friend SampledSpectrum operator*(double s, SampledSpectrum a) { return a *= s; }

  bool isBlack() const {
    for (double x : v_)
      if (x != 0.0) return false;
    return true;
  }
  double maxValue() const {
    double m = v_[0];
    for (double x : v_) m = std::max(m, x);
    return m;
  }
  double average() const {
    double s = 0;
    for (double x : v_) s += x;
    return s / kSpectrumSamples;
  }

 private:
  std::array<double, kSpectrumSamples> v_;
};

/// Component-wise helpers.
SampledSpectrum sqrt(const SampledSpectrum& s);
SampledSpectrum exp(const SampledSpectrum& s);
SampledSpectrum clampZero(const SampledSpectrum& s);
/// a / b with 0 where b is 0.
SampledSpectrum safeDiv(const SampledSpectrum& a, const SampledSpectrum& b);

/// The wavelengths (nm) of one camera path and the pdf (1/nm) each was sampled with.
class SampledWavelengths {
 public:
  /// Hero-wavelength sampling, uniform over [kLambdaMin_nm, kLambdaMax_nm]: lambda_0 from u in
  /// [0,1), the others equally spaced after it with wrap-around; every pdf is 1/470 nm.
  static SampledWavelengths sampleUniform(double u);
  /// Hero-wavelength sampling of the visible-importance density of Radziszewski et al. 2009,
  /// 1/cosh^2(0.0072 (lambda - 538)) on [360, 830] nm, averaged over each 1 nm cell (a
  /// piecewise-constant density whose CDF is inverted exactly with a table, no transcendental
  /// function per sample); the i-th wavelength uses u + i/N modulo 1.
  static SampledWavelengths sampleVisible(double u);
  /// Density (1/nm) of sampleVisible's marginal at lambda_nm.
  static double visiblePdf(double lambda_nm);
  /// The density sampleVisible approximates: the normalised 1/cosh^2 of Radziszewski et al.
  static double visiblePdfExact(double lambda_nm);

  double lambda(int i) const { return lambda_nm_[i]; }
  double pdf(int i) const { return pdf_[i]; }
  SampledSpectrum pdfs() const;
  /// Keeps only the hero wavelength (for wavelength-dependent refraction): the others get pdf 0
  /// and the hero's pdf is divided by kSpectrumSamples.
  void terminateSecondary();
  bool secondaryTerminated() const;

 private:
  std::array<double, kSpectrumSamples> lambda_nm_{};
  std::array<double, kSpectrumSamples> pdf_{};
};

/// A spectral distribution: value as a function of wavelength in nm (units depend on use:
/// reflectance is unitless, illuminants relative power, eta/k unitless).
class Spectrum {
 public:
  virtual ~Spectrum() = default;
  /// Value at lambda_nm.
  virtual double eval(double lambda_nm) const = 0;
  /// An upper bound of eval over the visible range.
  virtual double maxValue() const = 0;
  /// Values at the path's wavelengths (all at once; kinds with tables override it).
  virtual SampledSpectrum sample(const SampledWavelengths& lambda) const;
};

/// A function of wavelength tabulated at every integer nm of [kLambdaMin_nm, kLambdaMax_nm] and
/// read by linear interpolation (pbrt-v4's DenselySampledSpectrum, without its rounding to the
/// nearest nm). For a function with |f''| <= M on the range the error is at most M / 8 (1 nm
/// spacing); a function linear between integer wavelengths is reproduced exactly.
class WavelengthTable {
 public:
  static constexpr int kSize = static_cast<int>(kLambdaMax_nm - kLambdaMin_nm) + 1;
  WavelengthTable() { v_.fill(0.0); }
  template <class F>
  explicit WavelengthTable(F f) {
    for (int i = 0; i < kSize; ++i) v_[size_t(i)] = f(kLambdaMin_nm + i);
  }
  /// Whether lambda_nm lies in the tabulated range.
  static bool covers(double lambda_nm) {
    return lambda_nm >= kLambdaMin_nm && lambda_nm <= kLambdaMax_nm;
  }
  /// Interpolated value; lambda_nm must be covered.
  double operator()(double lambda_nm) const {
    const double f = lambda_nm - kLambdaMin_nm;
    const int i = std::min(static_cast<int>(f), kSize - 2);
    const double t = f - i;
    return v_[size_t(i)] * (1 - t) + v_[size_t(i) + 1] * t;
  }
  double maxValue() const { return *std::max_element(v_.begin(), v_.end()); }

 private:
  std::array<double, kSize> v_;
};

using SpectrumPtr = std::shared_ptr<const Spectrum>;

/// The same value at every wavelength.
class ConstantSpectrum final : public Spectrum {
 public:
  explicit ConstantSpectrum(double c) : c_(c) {}
  double eval(double) const override { return c_; }
  double maxValue() const override { return c_; }
  SampledSpectrum sample(const SampledWavelengths&) const override { return SampledSpectrum(c_); }

 private:
  double c_;
};

/// Linear interpolation between tabulated (lambda_nm, value) points; constant beyond the ends.
/// In the visible range the segment is found from a per-nm index table instead of a binary
/// search (the same segment, so the same value).
class PiecewiseLinearSpectrum final : public Spectrum {
 public:
  PiecewiseLinearSpectrum(std::vector<double> lambdas_nm, std::vector<double> values);
  /// From interleaved (lambda_nm, value) pairs, sorted by wavelength. With normalize, scaled so
  /// that its CIE Y (luminance, integral of y-bar times it over CIE_Y_integral) is 1, as pbrt-v4
  /// normalises named illuminants.
  static std::shared_ptr<PiecewiseLinearSpectrum> fromInterleaved(const std::vector<double>& pairs,
                                                                  bool normalize);
  double eval(double lambda_nm) const override;
  double maxValue() const override;
  SampledSpectrum sample(const SampledWavelengths& lambda) const override;
  void scale(double s);

 private:
  /// Index i of the segment [lambda_nm_[i], lambda_nm_[i+1]) holding lambda_nm, for lambda_nm
  /// strictly inside (front, back).
  size_t segment(double lambda_nm) const;
  std::vector<double> lambda_nm_, values_;
  /// segment() of each integer nm of the visible range (where it is inside (front, back)).
  std::vector<uint32_t> first_segment_;
};

/// Planck's law for temperature T (kelvin), normalised to a peak value of 1 at Wien's
/// displacement wavelength (pbrt-v4's BlackbodySpectrum). In the visible range eval reads a
/// 1 nm WavelengthTable (absolute error below 6e-6 of the peak value 1 for any T; relative
/// error up to ~1e-3 only where the value is under 1e-2, at T <= 1000 K; see spectrum_test).
class BlackbodySpectrum final : public Spectrum {
 public:
  explicit BlackbodySpectrum(double temperature_K);
  double eval(double lambda_nm) const override;
  double maxValue() const override { return 1.0; }
  SampledSpectrum sample(const SampledWavelengths& lambda) const override;
  /// The normalised value from Planck's law itself (no table).
  double evalExact(double lambda_nm) const { return planck(lambda_nm, temperature_K_) * norm_; }
  /// Unnormalised spectral radiance of a blackbody, W / (m^2 sr m), at lambda_nm.
  static double planck(double lambda_nm, double temperature_K);

 private:
  double temperature_K_, norm_;
  WavelengthTable table_;
};

/// CIE 1931 2-degree colour matching functions at lambda_nm (linear interpolation of the
/// 5 nm table, zero outside 360..830 nm).
Vec3 cieXyzBar(double lambda_nm);
/// Integral of y-bar over 360..830 nm (nm), the normalisation of spectrum -> Y.
double cieYIntegral();
/// XYZ of a spectrum (integrated over 360..830 nm at 1 nm, divided by cieYIntegral()).
Vec3 spectrumToXyz(const Spectrum& s);
/// Monte Carlo estimate of XYZ from values at the path's wavelengths:
/// mean over i of cmf(lambda_i) s_i / pdf_i, divided by cieYIntegral(). Terminated (pdf 0)
/// wavelengths contribute nothing.
Vec3 sampledToXyz(const SampledSpectrum& s, const SampledWavelengths& lambda);

/// Sigmoid-polynomial coefficients of Jakob & Hanika 2019, in normalised wavelength
/// x = (lambda - 360 nm) / 470 nm: s(x) = sigmoid(c0 x^2 + c1 x + c2),
/// sigmoid(t) = 1/2 + t / (2 sqrt(1 + t^2)).
struct SigmoidPolynomial {
  std::array<double, 3> c{0.0, 0.0, 0.0};
  double eval(double lambda_nm) const;
  /// eval at the path's wavelengths: the same operations, bit for bit, done for all of them at
  /// once without branches (so that the compiler evaluates them as vectors).
  SampledSpectrum sample(const SampledWavelengths& lambda) const;
  double maxValue() const;
};

/// The RGB colour space lensim renders in: linear sRGB primaries (ITU-R BT.709) with a D65
/// white; the white point is taken from the tabulated D65 spectrum so that an illuminant RGB of
/// (1,1,1) reproduces exactly (1,1,1).
class RGBColorSpace {
 public:
  /// The linear sRGB colour space (built on first use).
  static const RGBColorSpace& sRGB();
  /// Linear RGB from CIE XYZ, and back.
  Vec3 toRgb(const Vec3& xyz) const;
  Vec3 toXyz(const Vec3& rgb) const;
  /// The colour space's standard illuminant (D65), normalised to luminance Y = 1.
  const SpectrumPtr& illuminant() const { return illuminant_; }
  /// The illuminant at 1 nm (exact: the D65 table's knots lie on whole nm).
  const WavelengthTable& illuminantTable() const { return illuminant_table_; }
  /// Sigmoid polynomial whose reflectance spectrum, lit by the illuminant, has linear RGB `rgb`
  /// (each component in [0,1]). Fitted by Gauss-Newton on first request and cached; thread-safe.
  SigmoidPolynomial fitSigmoid(const Vec3& rgb) const;
  /// Fast approximation of fitSigmoid for per-texel use: trilinear interpolation of coefficients
  /// tabulated per dominant channel on a 32^3 grid (dominant value z with nodes crowded toward
  /// 0 and 1, the other two channels as ratios to it), after Jakob & Hanika's table layout. Table
  /// columns are fitted lazily on first use (~1 ms each); thread-safe.
  SigmoidPolynomial tableSigmoid(const Vec3& rgb) const;

 private:
  RGBColorSpace();
  struct Impl;
  std::shared_ptr<Impl> impl_;
  SpectrumPtr illuminant_;
  WavelengthTable illuminant_table_;
  std::array<double, 9> xyz_to_rgb_{}, rgb_to_xyz_{};
};

/// A reflectance spectrum in [0,1] from an RGB albedo in [0,1]^3.
class RGBAlbedoSpectrum final : public Spectrum {
 public:
  RGBAlbedoSpectrum(const RGBColorSpace& cs, const Vec3& rgb);
  double eval(double lambda_nm) const override { return poly_.eval(lambda_nm); }
  double maxValue() const override { return poly_.maxValue(); }
  SampledSpectrum sample(const SampledWavelengths& lambda) const override;

 private:
  SigmoidPolynomial poly_;
};

/// An unbounded spectrum (e.g. scattering coefficients) from any non-negative RGB:
/// scale * sigmoid spectrum of rgb / scale with scale = 2 max(rgb).
class RGBUnboundedSpectrum final : public Spectrum {
 public:
  RGBUnboundedSpectrum(const RGBColorSpace& cs, const Vec3& rgb);
  double eval(double lambda_nm) const override { return scale_ * poly_.eval(lambda_nm); }
  double maxValue() const override { return scale_ * poly_.maxValue(); }
  SampledSpectrum sample(const SampledWavelengths& lambda) const override;

 private:
  double scale_ = 0;
  SigmoidPolynomial poly_;
};

/// An emission spectrum from a non-negative RGB: the unbounded spectrum times the colour space's
/// illuminant, so RGB (1,1,1) is that illuminant (pbrt-v4's RGBIlluminantSpectrum).
class RGBIlluminantSpectrum final : public Spectrum {
 public:
  RGBIlluminantSpectrum(const RGBColorSpace& cs, const Vec3& rgb);
  double eval(double lambda_nm) const override;
  double maxValue() const override;
  SampledSpectrum sample(const SampledWavelengths& lambda) const override;

 private:
  /// The colour space's illuminant at lambda_nm (its 1 nm table in the visible range).
  double illuminant(double lambda_nm) const;
  double scale_ = 0;
  SigmoidPolynomial poly_;
  SpectrumPtr illuminant_;
  const WavelengthTable* illuminant_table_;  // the colour space's (which outlives the program)
};

/// Spectra that pbrt-v4 scenes name by string: "stdillum-D65" (normalised to Y = 1),
/// "metal-{Cu,Au,Ag,Al}-{eta,k}". Returns nullptr for unknown names.
SpectrumPtr namedSpectrum(std::string_view name);
/// The names namedSpectrum knows.
std::vector<std::string> namedSpectrumNames();

}  // namespace lensim::render
