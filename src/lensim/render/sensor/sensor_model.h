// The camera's sensor (issue 34): photo-electrons per pixel from the film's spectral irradiance
// through a colour filter array with per-channel quantum efficiency, then the noise and the
// electronics that turn them into the raw digital numbers (DN) of a raw file.
//
// Signal chain of one pixel at full-image raster position (x, y), CFA channel c:
//   S  = expected photo-electrons (film: the integral over wavelength of the spectral irradiance
//        x pixel area x fill factor x exposure time x QE_c x IR-cut / (h c / lambda))
//   n  = Poisson(S (1 + PRNU_xy) + D) + DSNU_xy      D = dark current (T) x exposure time
//   n  = clamp(n, 0, full well)
//   DN = round((n + N(0, read noise)) x G) + black level, clamped to [0, 2^bits - 1]
//   G  = (ISO / base ISO) / conversion gain            (conversion gain in e-/DN at base ISO)
// PRNU_xy and DSNU_xy are zero-mean Gaussian fixed patterns drawn from the pattern seed (the same
// in every frame of a sensor); the temporal noise is drawn from the frame seed and the pixel's
// full-image position, so it does not depend on threads, tiles or sample slices.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "lensim/render/spectra/spectrum.h"
#include "lensim/scene/sensor_config.h"
#include "lensim/util/error.h"

namespace lensim::render {

using scene::CfaPattern;
using scene::parseCfa;
/// The channel (0 red, 1 green, 2 blue, 3 W; 0 for mono) of pixel (x, y) of the full image.
inline int cfaChannel(const CfaPattern& cfa, int x, int y) { return cfa.channel(x, y); }

using scene::SensorConfig;

/// A channel's spectral response tabulated every nm over [360, 830].
struct SpectralTable {
  std::vector<double> v;  ///< 471 values, v[i] at 360 + i nm
  double eval(double lambda_nm) const;
};

class SensorModel {
 public:
  /// Loads the QE curves (throws lensim::Error at loc for a bad file or name); `qe_text`: the
  /// QE file's content, when it travels with the image instead of being read from config.qe.
  explicit SensorModel(SensorConfig config, const FileLoc& loc = {},
                       const std::string* qe_text = nullptr);
  const SensorConfig& config() const { return config_; }
  const CfaPattern& cfa() const { return cfa_; }
  /// Quantum efficiency of channel c (0 red, 1 green, 2 blue, 3 W) at lambda, including the
  /// IR-cut filter. W (a pixel without a colour filter) is the sum of the R, G and B curves, so a
  /// W pixel's electrons are the sum of the film's three channels: the film, its split-render
  /// parts and lensim merge keep three channels whatever the CFA.
  double qe(int c, double lambda_nm) const;
  /// Expected photo-electrons per channel (noise free, no PRNU) of a pixel whose film value is
  /// the spectrum L carried by lambda (Monte Carlo estimate over lambda's samples).
  std::array<double, 3> expectedElectrons(const SampledSpectrum& L,
                                          const SampledWavelengths& lambda) const;
  /// The same for a spectrum known everywhere (integrated at 1 nm over 360-830 nm).
  std::array<double, 3> expectedElectrons(const Spectrum& s) const;
  /// Electrons per unit of film value at lambda for channel c (what expectedElectrons integrates;
  /// channel 3, W, the sum of the three).
  double electronsPerUnit(int c, double lambda_nm) const;
  /// The expected electrons of channel c (0-2, or 3: W, their sum) from the three channels'.
  static double channelElectrons(int c, const std::array<double, 3>& e) {
    return c == CfaPattern::kW ? e[0] + e[1] + e[2] : e[size_t(c)];
  }
  /// Photons reaching the pixel's collecting area per unit film value at lambda, per nm.
  double photonsPerUnit(double lambda_nm) const;

  /// The raw DN of pixel (x, y) (full-image raster) whose expected electrons per channel are e.
  uint16_t digitize(int x, int y, const std::array<double, 3>& e) const;
  /// The pixel's fixed patterns: PRNU gain factor 1 + prnu x N(0,1) and DSNU offset (e-).
  std::pair<double, double> fixedPattern(int x, int y) const;

 private:
  SensorConfig config_;
  CfaPattern cfa_;
  std::array<SpectralTable, 3> qe_, resp_;
  FileLoc loc_;
};

/// The DN mosaic of an image of expected electrons (channels R, G, B per pixel, row-major over
/// a w x h window whose top-left pixel is (x0, y0) of the full image).
std::vector<uint16_t> digitizeImage(const SensorModel& m, const std::vector<float>& electrons_rgb,
                                    int w, int h, int x0, int y0);

/// Reads a QE file (docs/sensor.md): '#' comments, then rows "lambda_nm, qe_r, qe_g, qe_b" (or
/// "lambda_nm, qe" for a monochrome sensor), QE as fractions in [0, 1], wavelengths increasing.
/// Returns the 3 (or 1) channel tables; throws lensim::Error "file:line:col: ..." on bad input.
std::vector<SpectralTable> readQeFile(const std::string& path);
/// The same for a QE file's content (`path` names it in errors).
std::vector<SpectralTable> parseQeText(const std::string& text, const std::string& path);

}  // namespace lensim::render
