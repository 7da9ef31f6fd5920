// pbrt-v3's "fourier" material: a BSDF tabulated in pbrt-v3's FourierBSDFTable file format
// (binary, header "SCATFUN" 0x01; written by Mitsuba's layer tools), as pbrt-v3 reads and
// evaluates it (pbrt-v3 src/core/reflection.cpp: FourierBSDFTable::Read, FourierBSDF::f,
// Sample_f and Pdf; src/core/interpolation.cpp: CatmullRomWeights, SampleCatmullRom2D, Fourier,
// SampleFourier; src/materials/fourier.cpp; Pharr, Jakob, Humphreys, 3rd ed., sec. 8.6).
//
// The table stores, for each pair of zenith cosines (mu_i, mu_o) on a grid of nMu nodes in
// [-1, 1], the Fourier coefficients a_k of f(mu_i, mu_o, phi) |mu_i| in the azimuth difference
// phi: f |mu_i| = sum_k a_k cos(k phi). pbrt-v3's convention: mu_i is the cosine of -wi, so a
// pair with mu_i mu_o < 0 is reflection and mu_i mu_o > 0 transmission. Evaluation interpolates
// the coefficients with Catmull-Rom spline weights in mu_i and mu_o (4 x 4 nodes); sampling draws
// mu_i from the spline of a_0 (its cumulative integrals are stored in the file) and phi from the
// Fourier series by Newton-bisection; the density is the luminance series over 2 pi times the
// integral of a_0.
//
// File layout (little-endian): "SCATFUN" 0x01; int32 flags (1), nMu, nCoeffs, mMax, nChannels
// (1 or 3), nBases (1), three unused int32, float32 eta, four unused int32 (64 bytes); then
// float32 mu[nMu] (increasing), float32 cdf[nMu][nMu], int32 (offset, length)[nMu][nMu] (rows
// mu_o, columns mu_i), float32 coefficients[nCoeffs]. A pair's coefficients are `length` values
// per channel starting at `offset`. Three channels are luminance Y, red and blue (pbrt-v3 derives
// green as 1.39829 Y - 0.100913 B - 0.297375 R, the inverse of the linear sRGB luminance).
//
// lensim is spectral: a three-channel value (R, G, B), clamped to >= 0 as pbrt-v3 clamps its
// RGB spectrum, becomes a spectrum by pbrt-v4's unbounded RGB upsampling (the sigmoid-polynomial
// fit of Jakob & Hanika 2019 to rgb / s, times s = 2 max(rgb); RGBColorSpace::tableSigmoid in
// linear sRGB), evaluated at the path's wavelengths. One-channel tables are grey.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "lensim/render/materials/bsdf.h"

namespace lensim::render {

/// The most a coefficient may be in magnitude: far above real data (a few hundred at most for
/// sharp specular peaks), low enough that sums of products stay finite.
inline constexpr double kMaxFourierCoefficient = 1e15;

class FourierBSDFTable {
 public:
  /// Parses the bytes of a table; `path` names it in messages. Throws lensim::Error
  /// (`path: error: byte N: ...`) for a truncated, oversized or corrupt file: a wrong header,
  /// unsupported flags, channel or basis counts, sizes the file cannot hold (checked before
  /// anything is allocated), mu nodes that are not finite, in [-1, 1] and increasing, a
  /// non-finite cdf value or coefficient, or a coefficient run outside the coefficient array.
  static FourierBSDFTable parse(std::string_view bytes, const std::string& path);
  /// Reads and parses a file (only regular files, at most 1 GiB).
  static FourierBSDFTable read(const std::string& path);
  /// Reads `path` once per process and shares the result (thread-safe).
  static std::shared_ptr<const FourierBSDFTable> loadCached(const std::string& path);

  double eta() const { return eta_; }
  int nMu() const { return n_mu_; }
  int mMax() const { return m_max_; }
  int channels() const { return n_channels_; }

  /// Catmull-Rom weights of the 4 nodes offset .. offset + 3 at cos_theta (pbrt-v3
  /// CatmullRomWeights); false outside [mu_0, mu_last].
  bool weights(double cos_theta, int& offset, double w[4]) const;
  /// The interpolated coefficients at (mu_i, mu_o), `channels()` runs of mMax() values; returns
  /// the number of orders used (0: nothing there).
  int coefficients(double mu_i, double mu_o, double* ak, double w_o[4], int& offset_o) const;
  /// The Fourier series sum_k a_k cos(k phi), k < m (pbrt-v3 Fourier).
  static double fourier(const double* a, int m, double cos_phi);
  /// Samples phi in [0, 2 pi) from the series a (a_0 > 0) with u in [0,1): returns the series'
  /// value there, its density (sr^-1 over phi) and phi (pbrt-v3 SampleFourier).
  double sampleFourier(const double* a, int m, double u, double& pdf, double& phi) const;
  /// Samples mu_i for mu_o from the spline of a_0 with u in [0,1): returns mu_i and its density
  /// (pbrt-v3 SampleCatmullRom2D); nullopt outside the table.
  std::optional<std::pair<double, double>> sampleMu(double mu_o, double u) const;
  /// The integral of a_0 over mu_i at the interpolated row mu_o, weights w_o from offset_o.
  double rowIntegral(const double w_o[4], int offset_o) const;

 private:
  FourierBSDFTable() = default;
  double eta_ = 1;
  int n_mu_ = 0, m_max_ = 0, n_channels_ = 1;
  std::vector<double> mu_, cdf_, a0_, recip_;
  std::vector<float> a_;
  std::vector<uint32_t> offset_, length_;  ///< [o * nMu + i]
};

/// The BxDF of the "fourier" material at one path's wavelengths: reflection and transmission,
/// glossy.
class FourierBxDF final : public BxDF {
 public:
  FourierBxDF(std::shared_ptr<const FourierBSDFTable> table, const SampledWavelengths& lambda)
      : table_(std::move(table)), lambda_(lambda) {}
  BxDFFlags flags() const override {
    return BxDFFlags::Reflection | BxDFFlags::Transmission | BxDFFlags::Glossy;
  }
  SampledSpectrum f(const Vec3& wo, const Vec3& wi, TransportMode mode) const override;
  std::optional<BSDFSample> sample_f(const Vec3& wo, double uc, Vec2 u, TransportMode mode,
                                     ReflTrans allowed = ReflTrans::All) const override;
  double pdf(const Vec3& wo, const Vec3& wi, TransportMode mode,
             ReflTrans allowed = ReflTrans::All) const override;

 private:
  /// f from the interpolated coefficients at cos(phi) for mu_i, mu_o.
  SampledSpectrum value(const double* ak, int m, double cos_phi, double mu_i, double mu_o,
                        TransportMode mode, double y) const;
  std::shared_ptr<const FourierBSDFTable> table_;
  SampledWavelengths lambda_;
};

}  // namespace lensim::render
