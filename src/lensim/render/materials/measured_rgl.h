// pbrt-v4's "measured" material with RGL measured BSDF files (`.bsdf`; Dupuy & Jakob 2018, "An
// Adaptive Parameterization for Efficient Material Acquisition and Rendering"; the EPFL RGL
// material database): the reader of the tensor-file fields, and the BxDF that evaluates and
// samples them as pbrt-v4 does (src/pbrt/bxdfs.cpp, MeasuredBxDF; pbrt-v4 book section 9.8).
//
// The file stores, for incident directions on a (phi_i, theta_i) grid:
//   ndf       [n_phi_m][n_theta_m]          the microfacet distribution D(wm) on the unit square
//   sigma     [n_phi][n_theta]              its projected area sigma(w) = int D(m) <w, m>+ dm
//   vndf      [phi_i][theta_i][ny][nx]      the visible-normal density warp R (PiecewiseLinear2D)
//   luminance [phi_i][theta_i][n][n]        luminance of the stored values, for sampling
//   spectra   [phi_i][theta_i][n_wl][n][n]  the values M at `wavelengths` (nm), or, in RGB
//   rgb       [phi_i][theta_i][3][n][n]     files, at the three linear sRGB channels
//   theta_i, phi_i (radians), description (text), jacobian (uint8 flag)
// Unit-square coordinates of a direction: u = sqrt(2 theta / pi), v = (phi + pi) / (2 pi); for
// isotropic data (phi_i with at most 2 values) the azimuth of wm is relative to the incident one.
//
// Evaluation (pbrt-v4 book Eq. 9.45): f(wo, wi) = M(R^-1(wo, wm)) D(wm) / (4 sigma(wo) cos
// theta_i), wm the half vector, M interpolated at the path's wavelengths (linearly between the
// file's wavelengths; the end value held outside them). A file whose `jacobian` flag is 0
// stores M = f cos theta_i directly (Mitsuba's convention; pbrt-v4 ignores the flag).
// Sampling: u -> luminance warp -> vndf warp -> wm -> wi = reflect(wo, wm), with density
// pdf_lum * pdf_vndf / (4 (wo.wm) 2 pi^2 u_m sin theta_m).
//
// Difference from pbrt-v4 (commit 4607f0e): its f() and PDF() take the tables' incident
// direction from wi (and f() divides by cos theta of that same direction) while its Sample_f()
// takes it from wo; lensim uses wo throughout, as the book's Eq. 9.45 and Mitsuba's `measured`
// plugin do, so that sample_f's pdf and f agree exactly with pdf() and f(). For reciprocal
// data the two conventions give the same f up to interpolation error.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "lensim/render/materials/bsdf.h"
#include "lensim/render/spectra/spectrum.h"
#include "lensim/sampling/piecewise_linear_2d.h"
#include "lensim/util/vec.h"

namespace lensim::render {

using namespace lensim::sampling;

/// The most a stored value may be in magnitude (ndf, sigma, spectra); far above real data, low
/// enough that products stay finite in float.
inline constexpr double kMaxRGLValue = 1e15;

class RGLMeasuredBRDF {
 public:
  /// Parses the bytes of a `.bsdf` file; `path` names it in messages. Throws lensim::Error
  /// (`path: error: byte N: ...`) for a truncated or corrupt file, a missing or mis-shaped
  /// field, a non-finite or out-of-range value, or tables beyond the memory budget.
  static RGLMeasuredBRDF parse(std::string bytes, const std::string& path);
  /// Reads and parses a file (only regular files, at most 1 GiB).
  static RGLMeasuredBRDF read(const std::string& path);
  /// Reads `path` once per process and shares the result (thread-safe).
  static std::shared_ptr<const RGLMeasuredBRDF> loadCached(const std::string& path);

  bool isotropic() const { return isotropic_; }
  bool rgb() const { return rgb_; }
  bool jacobian() const { return jacobian_; }
  const std::string& description() const { return description_; }
  const std::vector<float>& wavelengths() const { return wavelengths_; }

  /// f(wo, wi) in sr^-1 for wo.z > 0 and wi.z > 0 (zero otherwise).
  SampledSpectrum f(const Vec3& wo, const Vec3& wi, const SampledWavelengths& lambda) const;
  /// Samples wi for wo.z > 0; nullopt when the sampled direction is below the surface.
  std::optional<BSDFSample> sample(const Vec3& wo, Vec2 u, const SampledWavelengths& lambda) const;
  /// Density of sample() producing wi (sr^-1).
  double pdf(const Vec3& wo, const Vec3& wi) const;

 private:
  RGLMeasuredBRDF() = default;
  SampledSpectrum values(Vec2 sample, double phi_o, double theta_o,
                         const SampledWavelengths& lambda) const;

  PiecewiseLinear2D ndf_, sigma_, vndf_, luminance_, spectra_;
  std::vector<float> wavelengths_;
  bool isotropic_ = true, rgb_ = false, jacobian_ = true;
  std::string description_;
};

/// The BxDF of the "measured" material with an RGL file at one path's wavelengths: reflection
/// only, glossy; two-sided (below the surface both directions are mirrored, as pbrt-v4 does).
class RGLMeasuredBxDF final : public BxDF {
 public:
  RGLMeasuredBxDF(std::shared_ptr<const RGLMeasuredBRDF> brdf, const SampledWavelengths& lambda)
      : brdf_(std::move(brdf)), lambda_(lambda) {}
  BxDFFlags flags() const override { return BxDFFlags::Reflection | BxDFFlags::Glossy; }
  SampledSpectrum f(const Vec3& wo, const Vec3& wi, TransportMode mode) const override;
  std::optional<BSDFSample> sample_f(const Vec3& wo, double uc, Vec2 u, TransportMode mode,
                                     ReflTrans allowed = ReflTrans::All) const override;
  double pdf(const Vec3& wo, const Vec3& wi, TransportMode mode,
             ReflTrans allowed = ReflTrans::All) const override;

 private:
  std::shared_ptr<const RGLMeasuredBRDF> brdf_;
  SampledWavelengths lambda_;
};

/// True when the file at `path` starts with the tensor-file header (an RGL `.bsdf`); false when
/// it cannot be read or is something else (the caller's reader then says why).
bool isRGLMeasuredFile(const std::string& path);

}  // namespace lensim::render
