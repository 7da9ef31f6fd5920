// Tabulated published spectral data (CIE observer, CIE illuminant D65, metal optical constants).
// Only the numbers live in spectrum_data.cpp; see the comments there for sources.
#pragma once

#include <span>

namespace lensim::render::data {

/// CIE 1931 2-degree standard observer, 360..830 nm every 5 nm (95 rows): x-bar, y-bar, z-bar.
extern const double kCie1931_5nm[95][3];
/// First wavelength and spacing of kCie1931_5nm, nanometres.
inline constexpr double kCieFirst_nm = 360.0;
inline constexpr double kCieStep_nm = 5.0;

/// CIE standard illuminant D65 relative spectral power, 360..830 nm every 5 nm (95 values;
/// 100 at 560 nm).
extern const double kD65_5nm[95];

/// Interleaved (wavelength nm, value) pairs of tabulated metal optical constants: pbrt-v4's
/// named-spectrum tables (298.76-885.60 nm; sources in spectrum_data.cpp).
extern const std::span<const double> kAuEta, kAuK, kAgEta, kAgK, kAlEta, kAlK, kCuEta, kCuK;
/// pbrt-v4's metal-MgO-* and metal-TiO2-* tables.
extern const std::span<const double> kMgOEta, kMgOK, kTiO2Eta, kTiO2K;

}  // namespace lensim::render::data
