// Zemax AGF glass catalogues: the text format in which glass makers publish their catalogues for
// optical design programs.
//
// An AGF file is a list of glasses, each starting at an `NM` line; the lines read here are
//   NM name formula MIL n_d V_d exclude_sub status [melt_freq]  name, dispersion formula number,
//                                                               listed n_d / V_d, status
//   CD c1 c2 ...            the dispersion formula's coefficients (lambda in micrometres)
//   LD min max              the formula's valid wavelength range, micrometres
//   IT lambda tau thickness internal transmittance tau of a sample `thickness` mm thick
//   TD D0 D1 D2 E0 E1 Ltk T thermal data (kept as read)
//   ED TCE TCE100 density dPgF ignore_thermal; OD cost CR FR SR AR PR (kept as read)
// and `CC` (catalogue comment), `GC` (glass comment), `MD`, `BD` lines, which are skipped.
// Files come as ASCII/UTF-8, Latin-1 or UTF-16 (little- or big-endian, with a byte-order mark),
// with CRLF, LF or CR line ends, mixed.
#pragma once

#include <array>
#include <string>
#include <string_view>
#include <vector>

#include "lensim/util/error.h"

namespace lensim::optics {

/// The most coefficients a Zemax dispersion formula has (Sellmeier 5: K1 L1 ... K5 L5).
inline constexpr int kMaxZemaxCoefficients = 10;
using ZemaxCoefficients = std::array<double, kMaxZemaxCoefficients>;

/// Zemax's dispersion formula numbers (the second field of an `NM` line).
enum class ZemaxFormula {
  Schott = 1,        ///< n^2 = a0 + a1 l^2 + a2 l^-2 + a3 l^-4 + a4 l^-6 + a5 l^-8
  Sellmeier1 = 2,    ///< n^2 - 1 = sum_{i=1..3} K_i l^2 / (l^2 - L_i); CD: K1 L1 K2 L2 K3 L3
  Herzberger = 3,    ///< n = A + B L + C L^2 + D l^2 + E l^4 + F l^6, L = 1 / (l^2 - 0.028)
  Sellmeier2 = 4,    ///< n^2 - 1 = A + B1 l^2 / (l^2 - l1^2) + B2 / (l^2 - l2^2)
  Conrady = 5,       ///< n = n0 + A / l + B / l^3.5
  Sellmeier3 = 6,    ///< n^2 - 1 = sum_{i=1..4} K_i l^2 / (l^2 - L_i)
  HandbookOfOptics1 = 7,  ///< n^2 = A + B / (l^2 - C) - D l^2
  HandbookOfOptics2 = 8,  ///< n^2 = A + B l^2 / (l^2 - C) - D l^2
  Sellmeier4 = 9,    ///< n^2 = A + B l^2 / (l^2 - C) + D l^2 / (l^2 - E)
  Extended1 = 10,    ///< n^2 = a0 + a1 l^2 + a2 l^-2 + a3 l^-4 + a4 l^-6 + a5 l^-8 + a6 l^-10 + a7 l^-12
  Sellmeier5 = 11,   ///< n^2 - 1 = sum_{i=1..5} K_i l^2 / (l^2 - L_i)
  Extended2 = 12,    ///< n^2 = a0 + a1 l^2 + a2 l^-2 + a3 l^-4 + a4 l^-6 + a5 l^-8 + a6 l^4 + a7 l^6
  Extended3 = 13,    ///< n^2 = a0 + a1 l^2 + a2 l^4 + a3 l^-2 + a4 l^-4 + a5 l^-6 + a6 l^-8 + a7 l^-10 + a8 l^-12
};

/// The formula's name as Zemax writes it ("Sellmeier 1"); "" for a number Zemax does not define.
const char* zemaxFormulaName(int number);
/// How many CD coefficients the formula uses; 0 for a number Zemax does not define.
int zemaxFormulaCoefficients(int number);
/// The index of refraction from a Zemax dispersion formula at lambda (micrometres).
double zemaxIndex(ZemaxFormula f, const ZemaxCoefficients& c, double lambda_um);

/// One `IT` row: internal transmittance `tau` (0..1) of a sample `thickness_mm` thick.
struct TransmittanceRow {
  double lambda_um = 0, tau = 0, thickness_mm = 0;
};

/// One glass of an AGF file, as listed.
struct AgfGlass {
  std::string name;
  int formula = 0;
  double listed_n_d = 0, listed_v_d = 0;
  /// Zemax's status code: 0 standard, 1 preferred, 2 obsolete, 3 special (the makers' inquiry
  /// and special glasses), 4 melt.
  int status = 0;
  ZemaxCoefficients coefficients{};
  double min_um = 0, max_um = 0;  ///< LD; 0/0 when the file gives no LD line
  std::vector<TransmittanceRow> transmittance;
  /// IT rows that carry no usable transmittance (a value missing, tau outside 0..1, thickness
  /// 0: found in the makers' own files), skipped.
  int skipped_transmittance_rows = 0;
  std::vector<double> thermal, other, extra;  ///< TD, OD, ED as read
  FileLoc loc;                                ///< the NM line
};

/// "standard", "preferred", "obsolete", "special", "melt" or "status N".
std::string agfStatusName(int status);

/// Parses an AGF file (bytes as stored; decoded by decodeTextFile, optics/lens_formats.h). Throws lensim::Error
/// (`path:line:col`) for a malformed line: a number that is not one, an NM line without its
/// fields, a formula number Zemax does not define, a CD/LD/IT line before any NM, an LD range
/// that is empty.
std::vector<AgfGlass> parseAgf(std::string_view bytes, const std::string& path);

}  // namespace lensim::optics
