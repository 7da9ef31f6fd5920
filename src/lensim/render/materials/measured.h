// pbrt-v2's "measured" material for irregularly sampled isotropic BRDFs (the Cornell `.brdf`
// text files of the CS348B assignment scenes): the file reader, an interpolant of the scattered
// measurements precomputed on a regular table, and a BxDF that evaluates and samples it.
//
// File format (facts from pbrt-v2's src/materials/measured.cpp comment and from the files):
// whitespace-separated numbers; `#` starts a comment that runs to the end of the line. The first
// number is the count of wavelengths n, then n wavelengths in nm, then any number of samples of
// 4 + n numbers each: theta_i, phi_i, theta_o, phi_o (radians; theta from the normal), then the
// BRDF (sr^-1) at the n wavelengths. There is no sample count: the numbers after the wavelengths
// must split into whole samples. Both shared files: 31 wavelengths (400..700 nm by 10), 1439
// samples, theta_i in {10, 20, .., 80} degrees, phi_i = 0, ten theta_o rings in [0, 79] degrees.
#pragma once

#include <array>
#include <cstddef>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "lensim/render/materials/bsdf.h"
#include "lensim/render/spectra/spectrum.h"
#include "lensim/sampling/sampling.h"
#include "lensim/util/vec.h"

namespace lensim::render {

using namespace lensim::sampling;

/// The contents of an irregular isotropic `.brdf` file.
struct IrregularBRDFData {
  struct Sample {
    double theta_i, phi_i, theta_o, phi_o;  ///< radians, as in the file
  };
  std::vector<double> wavelengths_nm;  ///< strictly increasing
  std::vector<Sample> samples;
  /// BRDF values (sr^-1), samples.size() rows of wavelengths_nm.size() values; negative file
  /// values are clamped to 0 (pbrt-v2 clamps its interpolated values the same way).
  std::vector<double> values;

  std::size_t numWavelengths() const { return wavelengths_nm.size(); }
  std::span<const double> sampleValues(std::size_t i) const {
    return {values.data() + i * numWavelengths(), numWavelengths()};
  }
};

/// The most wavelengths a .brdf file may list.
inline constexpr double kMaxBRDFWavelengths = 1000;
/// The largest BRDF value accepted (1/sr; a mirror-like peak is far below it; float tables
/// overflow near 3.4e38).
inline constexpr double kMaxBRDFValue = 1e12;

/// Parses the text of a `.brdf` file; `path` is used in messages only. Throws lensim::Error
/// (`path:line:col: error: ...`) naming the offending value and what was expected.
IrregularBRDFData parseIrregularBRDF(std::string_view text, const std::string& path);
/// Reads and parses a `.brdf` file (lensim::Error if it cannot be read or is malformed).
IrregularBRDFData readIrregularBRDF(const std::string& path);

/// An isotropic BRDF interpolated from scattered measurements.
///
/// Interpolant (our choice; pbrt-v2 instead averaged the kd-tree neighbours of
/// (sin_i sin_o, dphi/pi, cos_i cos_o) with Gaussian weights exp(-100 d^2), which smooths and does
/// not reproduce the measurements): a local modified Shepard interpolation (Franke & Nielson
/// 1980; weights ((R - d) / (R d))^2 over the k nearest samples, R = distance of the (k+1)-th),
/// which reproduces every measurement exactly, is continuous, and stays inside the range of its
/// neighbours (no overshoot, never negative). Distances are measured between configurations, not
/// between coordinates: d^2 = min |wi - M wi'|^2 + |wo - M wo'|^2 over rotations about the normal
/// (isotropy), the swap wi <-> wo (reciprocity) and mirroring; it has a closed form and no
/// singularity at normal incidence, where (theta, phi) coordinates have one.
///
/// For speed the interpolant is evaluated once, at load time, on a regular table over
/// (theta_i, theta_o, dphi) in [0, pi/2]^2 x [0, pi] (default 2 degrees x 2 degrees x 5
/// degrees, all wavelengths), and looked up trilinearly: the grid is the same on both theta axes
/// and the interpolant is symmetric, so the lookup is exactly reciprocal.
class MeasuredBRDF {
 public:
  struct Options {
    int n_theta = 46;  ///< table nodes over theta in [0, pi/2]
    int n_phi = 37;    ///< table nodes over dphi in [0, pi]
    int neighbours = 10;
  };
  explicit MeasuredBRDF(IrregularBRDFData data) : MeasuredBRDF(std::move(data), Options{}) {}
  MeasuredBRDF(IrregularBRDFData data, Options options);
  /// Reads `path` once per process and shares the result (thread-safe); lensim::Error on failure.
  static std::shared_ptr<const MeasuredBRDF> loadCached(const std::string& path);

  const IrregularBRDFData& data() const { return data_; }
  const Options& options() const { return options_; }

  /// The scattered interpolant itself (slow: a pass over all samples), at every tabulated
  /// wavelength; for building the table and for tests. theta in [0, pi/2], dphi any angle.
  std::vector<double> interpolate(double theta_i, double theta_o, double dphi) const;

  /// Table lookup at tabulated wavelength index `w`; theta in [0, pi/2], dphi in [0, pi].
  double lookup(double theta_i, double theta_o, double dphi, std::size_t w) const;

  /// Where a wavelength falls between the tabulated ones: value = (1 - t) v[i0] + t v[i1];
  /// outside the tabulated range the end value is held.
  struct WavelengthWeight {
    std::size_t i0 = 0, i1 = 0;
    double t = 0;
  };
  WavelengthWeight wavelengthWeight(double lambda_nm) const;

  /// Table lookup for the local-frame directions wo, wi (same hemisphere, not checked) at the
  /// given wavelength weights.
  SampledSpectrum eval(const Vec3& wo, const Vec3& wi,
                       const std::array<WavelengthWeight, kSpectrumSamples>& lambda) const;

  /// Importance sampling of wi given wo, both above the surface (wo.z > 0): with probability
  /// kCosineFraction the cosine-weighted hemisphere, otherwise a tabulated lobe: for each
  /// theta_o node of the table, a piecewise-constant density over (cos theta_i, |dphi|)
  /// (64 x 64 cells) proportional to the wavelength-averaged f cos theta_i, mixed linearly
  /// between the two theta_o nodes around wo, with a random sign of dphi. uc picks the branch,
  /// the node and the sign; u the direction.
  static constexpr double kCosineFraction = 0.2;
  /// Cells of the tabulated lobes: cos theta_i in [0, 1], |dphi| in [0, pi].
  static constexpr int kLobeCos = 64, kLobePhi = 64;
  Vec3 sampleWi(const Vec3& wo, double uc, Vec2 u) const;
  /// The exact density (sr^-1) of sampleWi producing wi (both with z > 0).
  double pdfWi(const Vec3& wo, const Vec3& wi) const;

 private:
  IrregularBRDFData data_;
  Options options_;
  // Per sample: sin/cos of theta_i, theta_o and cos/sin of dphi in [0, pi].
  struct Config {
    double si, ci, so, co, cp, sp;
  };
  std::vector<Config> configs_;
  std::vector<float> table_;                // [theta_i][theta_o][dphi][wavelength]
  std::vector<PiecewiseConstant2D> lobes_;  // per theta_o node; u = cos theta_i, v = |dphi|
  void interpolateInto(double theta_i, double theta_o, double dphi, double* out) const;
  void buildLobes();
};

/// The BxDF of the "measured" material at one path's wavelengths: reflection only, isotropic,
/// f(wo, wi) = f(wi, wo); sampled by MeasuredBRDF::sampleWi (cosine-weighted hemisphere mixed
/// with a tabulated lobe), with its exact pdf. Two-sided: below the surface both directions are
/// mirrored.
class MeasuredBxDF final : public BxDF {
 public:
  MeasuredBxDF(std::shared_ptr<const MeasuredBRDF> brdf, const SampledWavelengths& lambda);
  BxDFFlags flags() const override;
  SampledSpectrum f(const Vec3& wo, const Vec3& wi, TransportMode mode) const override;
  std::optional<BSDFSample> sample_f(const Vec3& wo, double uc, Vec2 u, TransportMode mode,
                                     ReflTrans allowed = ReflTrans::All) const override;
  double pdf(const Vec3& wo, const Vec3& wi, TransportMode mode,
             ReflTrans allowed = ReflTrans::All) const override;

 private:
  std::shared_ptr<const MeasuredBRDF> brdf_;
  std::array<MeasuredBRDF::WavelengthWeight, kSpectrumSamples> lambda_;
};

}  // namespace lensim::render
