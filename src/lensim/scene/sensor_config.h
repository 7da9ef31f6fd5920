// The parameters of a camera's sensor (Film "raw", issue 34), each in the unit its name says;
// the model that uses them is render/sensor/sensor_model.h, the parameters' documentation
// docs/sensor.md.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "lensim/util/error.h"

namespace lensim::scene {

/// A colour filter array: a width x height tile of filters (0 red, 1 green, 2 blue, 3 W: no colour
/// filter, panchromatic), row-major, repeated over the full image from its top-left pixel; or a
/// monochrome sensor (no filters).
struct CfaPattern {
  static constexpr uint8_t kW = 3;  ///< the W (panchromatic) filter's channel
  int width = 2, height = 2;
  std::vector<uint8_t> colors{0, 1, 1, 2};
  bool mono = false;
  /// The filter (0 red, 1 green, 2 blue, 3 W; 0 for mono) over pixel (x, y) of the full image.
  int channel(int x, int y) const;
  /// Whether the tile has W (panchromatic) pixels.
  bool hasW() const;
  /// The pattern as scenes write it: "mono", or the rows' letters joined by '/' ("RG/GB").
  std::string text() const;
  /// Whether a DNG of this pattern is read right by dcraw and LibRaw, which hold a CFA as 8 rows
  /// of 2 columns (`filters`) or as Fujifilm's 6x6 X-Trans: a tile 1 or 2 pixels wide and 1, 2, 4
  /// or 8 high (with R, G, B only, one whose greens dcraw does not misplace), or 6x6 without W.
  bool dngReadable() const;
  bool operator==(const CfaPattern&) const = default;
};

/// Parses a CFA: "mono"; or the filters' letters R, G, B (and W, panchromatic) row by row, rows
/// separated by '/' ("RGGB/GBRG"), or without '/' a square tile ("RGGB" is 2x2, 16 letters 4x4);
/// at most 8x8, each of R, G and B at least once. Throws lensim::Error at loc naming the bad value
/// otherwise.
CfaPattern parseCfa(const std::string& text, const FileLoc& loc = {});

/// Throws lensim::Error at loc if a DNG cannot hold `cfa` so that dcraw and LibRaw read it
/// right (CfaPattern::dngReadable), unless `dng_cfa` is "bayer" (the DNG is remosaiced).
void checkDngCfa(const CfaPattern& cfa, const FileLoc& loc, const std::string& dng_cfa = "native");

/// The sensor's parameters, each in the unit its name says. Defaults: see docs/sensor.md.
struct SensorConfig {
  std::string qe = "canon_eos_5d_mkiv";  ///< bundled camera curves, or a QE file (docs/sensor.md)
  std::string cfa = "RGGB";     ///< parseCfa's text
  /// The DNG's mosaic: "native" (the CFA's own) or "bayer" (remosaiced to RGGB)
  std::string dng_cfa = "native";
  double peak_qe = 0.5;          ///< bundled (relative) curves: QE at the highest peak
  double ircut_nm = 0;           ///< IR-cut filter 50 % wavelength (0: none)
  double ircut_width_nm = 10;    ///< its logistic edge width
  double pixel_pitch_um = 5.36;  ///< pixel pitch (micrometres)
  double fill_factor = 1;        ///< light-collecting fraction of the pixel (0, 1]
  double exposure_s = 0.01;      ///< exposure time (seconds)
  double iso = 100, base_iso = 100;
  double irradiance_scale = 1;   ///< W m^-2 nm^-1 per unit of the film's spectral value
  double temperature_c = 25;
  double dark_current_e_s = 0.2;  ///< dark current at dark_ref_c (e-/s per pixel)
  double dark_ref_c = 25;
  double dark_doubling_c = 6.3;   ///< dark current doubles every this many degrees C
  double read_noise_e = 3;        ///< read noise (e- rms)
  double dsnu_e = 0;              ///< dark-signal non-uniformity (e- rms, fixed pattern)
  double prnu = 0;                ///< photo-response non-uniformity (fraction rms)
  double full_well_e = 60000;
  double conversion_gain_e_dn = 4;  ///< e- per DN at base ISO
  int adc_bits = 14;
  int black_level_dn = 512;
  uint64_t seed = 0;          ///< frame seed (temporal noise)
  uint64_t pattern_seed = 1;  ///< sensor seed (fixed-pattern noise)
  bool noise = true;          ///< false: expected values only (no random noise)

  /// Key=value text of every field (parts carry it to lensim merge); fromText inverts it.
  std::string toText() const;
  static SensorConfig fromText(const std::string& text);
  /// Checks every range; throws lensim::Error at loc naming the bad value.
  void validate(const FileLoc& loc = {}) const;
  /// Dark current at temperature_c (e-/s).
  double darkCurrent() const;
  /// DN per electron: (iso / base_iso) / conversion_gain_e_dn.
  double gainDnPerE() const;
  int whiteLevel() const { return (1 << adc_bits) - 1; }
};

}  // namespace lensim::scene
