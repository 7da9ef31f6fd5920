// Optical glasses: index of refraction as a function of wavelength.
//
// A lens medium is one of
// - a catalogue glass: a vendor's dispersion formula from the glass library: the user's
//   catalogues, then the built-in ones (the 23 Zemax AGF catalogues of data/glass/agf/, then
//   data/glass/catalog.csv for the glasses they lack; see data/glass/SOURCES.md and docs/glass.md),
//   looked up by name case-insensitively, with or without a catalogue prefix ("schott:N-BK7");
// - a model glass from n_d and V_d: the two-term Cauchy formula n(l) = A + B / l^2 whose n(d) is
//   n_d and whose n(F) - n(C) is (n_d - 1) / V_d, so its V_d is exactly the one given;
// - a constant index (the classic `.dat` lenses: no dispersion).
//
// Wavelengths are in nanometres. The lines: d 587.5618 nm (helium), F 486.1327 nm and
// C 656.2725 nm (hydrogen); V_d = (n_d - 1) / (n_F - n_C).
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "lensim/optics/glass/agf.h"
#include "lensim/optics/prescription.h"
#include "lensim/util/error.h"

namespace lensim::optics {

inline constexpr double kLineD_nm = 587.5618;
inline constexpr double kLineF_nm = 486.1327;
inline constexpr double kLineC_nm = 656.2725;
/// The wavelength the workbench uses when a file names no primary wavelength: the d line.
inline constexpr double kDefaultPrimaryWavelength_nm = kLineD_nm;

/// The dispersion formulas of the catalogue (lambda in micrometres, coefficients c1..c9).
enum class DispersionFormula {
  Constant,    ///< n = c1
  Sellmeier3,  ///< n^2 = 1 + sum_i B_i l^2 / (l^2 - C_i)
  Schott6,     ///< n^2 = c1 + c2 l^2 + c3 l^-2 + c4 l^-4 + c5 l^-6 + c6 l^-8
  Hikari9,     ///< n^2 = c1 + c2 l^2 + c3 l^4 + c4 l^-2 + ... + c9 l^-12
  Cauchy2,     ///< n = c1 + c2 / l^2 (the model glass)
  Zemax,       ///< one of Zemax's numbered formulas (glass/agf.h), from an AGF catalogue
};

/// A medium with its index of refraction n(lambda).
class Glass {
 public:
  /// Air (index 1).
  Glass() = default;
  /// A constant index (no dispersion).
  static Glass constant(double n);
  /// The model glass through n_d and V_d (two-term Cauchy). Throws lensim::Error (at loc) for
  /// n_d < 1 or V_d <= 0 (or not finite).
  static Glass model(double n_d, double v_d, const FileLoc& loc = {});
  /// A catalogue glass from its formula; Sellmeier3 coefficients are B1 B2 B3 C1 C2 C3.
  static Glass formula(std::string vendor, std::string name, DispersionFormula f,
                       const std::array<double, 9>& c, double min_nm = 365, double max_nm = 1014);
  /// A glass with a Zemax dispersion formula, its valid range and its internal transmittance
  /// rows (AGF `IT`; none: transmittance 1).
  static Glass zemax(std::string vendor, std::string name, ZemaxFormula f,
                     const ZemaxCoefficients& c, double min_nm, double max_nm,
                     std::vector<TransmittanceRow> transmittance = {});

  /// Index of refraction at the wavelength (nm). Any wavelength gives a value; the formula is
  /// valid between minWavelength_nm() and maxWavelength_nm().
  double index(double lambda_nm) const;
  double n_d() const { return index(kLineD_nm); }
  /// Abbe number; infinity for a non-dispersive medium.
  double v_d() const;
  bool dispersive() const { return formula_ != DispersionFormula::Constant; }
  bool isAir() const { return !dispersive() && c_[0] == 1.0; }
  DispersionFormula formula() const { return formula_; }
  /// The formula's name: "Sellmeier 1" (Zemax numbering), "sellmeier3", "Cauchy", "constant".
  std::string formulaName() const;

  /// Internal transmittance of a path `thickness_mm` long at the wavelength (nm): the catalogue's
  /// IT rows scaled to the thickness (tau^(d / d_row), Beer-Lambert), interpolated linearly in
  /// the absorption coefficient between rows and held at the end rows outside them; 1 for a
  /// glass without rows.
  double internalTransmittance(double lambda_nm, double thickness_mm) const;
  /// The absorption coefficient (1/mm) internalTransmittance uses: exp(-alpha d) is the
  /// transmittance of a path d mm long; 0 for a glass without rows.
  double absorptionCoefficient_per_mm(double lambda_nm) const;
  bool hasTransmittance() const { return transmittance_ && !transmittance_->empty(); }

  /// "catalogue", "model" or "constant".
  const char* kind() const;
  /// Catalogue glasses: the vendor's name ("N-BK7") and the vendor ("Schott"); model glasses a
  /// generated name ("model 1.5168/64.17"); constants "".
  const std::string& name() const { return name_; }
  const std::string& vendor() const { return vendor_; }
  /// "schott:N-BK7", "model n_d 1.5168 V_d 64.17 (Cauchy)", "constant 1.5", "air".
  std::string describe() const;
  double minWavelength_nm() const { return min_nm_; }
  double maxWavelength_nm() const { return max_nm_; }
  bool inRange(double lambda_nm) const { return lambda_nm >= min_nm_ && lambda_nm <= max_nm_; }

 private:
  DispersionFormula formula_ = DispersionFormula::Constant;
  ZemaxFormula zemax_ = ZemaxFormula::Schott;  // with DispersionFormula::Zemax
  ZemaxCoefficients c_{1, 0, 0, 0, 0, 0, 0, 0, 0, 0};
  std::shared_ptr<const std::vector<TransmittanceRow>> transmittance_;
  std::string vendor_, name_;
  double min_nm_ = 0, max_nm_ = std::numeric_limits<double>::infinity();
};

/// One glass of a catalogue, with the n_d and V_d the catalogue lists.
struct CatalogGlass {
  std::string vendor;   ///< "Schott", "Ohara", ...
  std::string name;     ///< "N-BK7"
  std::string catalog;  ///< the catalogue it is from: an AGF file's stem ("schott"), "csv"
  /// The catalogue's status for it: "standard", "preferred", "obsolete", "special", "melt"
  /// (AGF), "" when the catalogue gives none.
  std::string status;
  double listed_n_d = 0, listed_v_d = 0;
  /// Why the glass cannot be used, when its catalogue's formula does not give the n_d the
  /// catalogue lists (by more than 1e-3: e.g. a CD line of zeros); "" for a usable glass.
  std::string problem;
  Glass glass;
  /// "schott:N-BK7"
  std::string qualifiedName() const;
};

/// A list of glass catalogues searched in order: the built-in one, one parsed from an AGF file or
/// from a CSV file in the layout of data/glass/catalog.csv (vendor,glass,nd,vd,formula,c1..c9),
/// or several of them appended (the glass library, glass/library.h).
class GlassCatalog {
 public:
  /// The catalogues compiled into lensim: the AGF files of data/glass/agf/ in the order of
  /// builtinCatalogNames(), then the glasses of data/glass/catalog.csv that none of them has,
  /// then "rii", crystals and plastics from refractiveindex.info (glass/embedded.h).
  static const GlassCatalog& builtin();
  /// The built-in AGF catalogues' names (file stems), in search order: schott, ohara, hoya,
  /// cdgm, sumita, hikari, then the others.
  static const std::vector<std::string>& builtinCatalogNames();
  /// Parses the CSV text; throws lensim::Error (`path:line:col`) for malformed rows.
  static GlassCatalog parse(std::string_view csv, const std::string& path);
  /// Parses an AGF file (parseAgf) into a catalogue named `catalog` (the file stem, lower case),
  /// its glasses' vendor `vendor`.
  static GlassCatalog fromAgf(std::string_view bytes, const std::string& path,
                              const std::string& catalog, const std::string& vendor);
  /// Reads a catalogue file: `.agf` (any case) or `.csv`; named by its stem in lower case.
  /// Throws lensim::Error for a file that cannot be read or parsed.
  static GlassCatalog load(const std::string& path);
  /// Appends another catalogue's glasses, searched after this one's.
  void append(const GlassCatalog& other);

  const std::vector<CatalogGlass>& glasses() const { return glasses_; }
  /// The catalogues' names in search order.
  const std::vector<std::string>& catalogs() const { return catalogs_; }
  bool hasCatalog(std::string_view name) const;
  /// Looks a name up: case-insensitive, "catalogue:name" (catalogue name or vendor) or a bare
  /// name: the first catalogue in search order that has it. nullptr if none.
  const CatalogGlass* find(std::string_view name) const;
  /// The same, searching the catalogues named in `first` (a lens file's GCAT), in that order,
  /// before the others.
  const CatalogGlass* find(std::string_view name, const std::vector<std::string>& first) const;
  /// Up to `count` catalogue names closest to `name` (edit distance on upper-case letters
  /// and digits), for did-you-mean hints.
  std::vector<std::string> suggestions(std::string_view name, int count = 3) const;
  /// The glass nearest in the (n_d, V_d) plane: distance sqrt((100 dn)^2 + dV^2) (0.01 in
  /// index weighs as one Abbe unit). Without V_d (NaN): nearest n_d among Schott glasses.
  const CatalogGlass& nearest(double n_d, double v_d) const;

 private:
  int rank(const CatalogGlass& g) const;
  /// Rebuilds by_name_ from glasses_ (after a factory filled glasses_ directly).
  void reindex();
  std::vector<CatalogGlass> glasses_;
  std::vector<std::string> catalogs_;
  /// Positions in glasses_ by upper-case name, ascending: find() looks at those alone instead of
  /// scanning every catalogue (about 4,500 glasses built in).
  std::unordered_map<std::string, std::vector<std::uint32_t>> by_name_;
};

/// A catalogue glass by name (GlassCatalog::find on the built-in catalogue) or, when the name
/// is not in it, through lensim's short table of former glass names whose successor is known
/// (each row cites its source; e.g. E-LAFH3 -> hikari:J-LAFH3). `successor_of` is set to true
/// when the table was used. nullptr when neither knows the name.
/// The name is looked up in the glass library (glass/library.h), the catalogues `catalogs` first.
const CatalogGlass* findGlassOrSuccessor(std::string_view name, bool* successor_of = nullptr,
                                         const std::vector<std::string>& catalogs = {});

/// Resolves a lens file's GlassSpec into a medium:
/// - a name found in the catalogue: that glass (a note when the file's n_d differs from the
///   catalogue's by more than 1e-3); a former name with a known successor: the successor, with a
///   warning;
/// - a name not found, with n_d and V_d given: the model glass from them, with a warning;
/// - a name not found alone: lensim::Error at spec.loc with did-you-mean hints;
/// - no name, V_d given: the model glass from n_d (spec.n_d, else constant_ior) and V_d;
/// - nothing: Glass::constant(constant_ior) (air when it is 1 or 0).
/// Warnings and notes go to `diagnostics` when given.
Glass resolveGlass(const GlassSpec& spec, double constant_ior,
                   std::vector<Diagnostic>* diagnostics = nullptr);

/// The medium after each surface of a prescription (resolveGlass on each; air rows stay air).
std::vector<Glass> resolveGlasses(const LensPrescription& p,
                                  std::vector<Diagnostic>* diagnostics = nullptr);

/// `--glass-match`: gives every non-air medium of the prescription that names no glass the
/// catalogue glass nearest to its (index, V_d) (GlassSpec filled with the catalogue name and
/// n_d, V_d). Returns one note per element saying which glass was chosen.
std::vector<Diagnostic> matchCatalogGlasses(LensPrescription& p);

/// The wavelength the workbench and focusing use for a prescription: its primary wavelength,
/// else the d line.
double primaryWavelength_nm(const LensPrescription& p);

/// Throws lensim::Error unless 200 nm <= lambda <= 2500 nm (a finite wavelength for the
/// workbench); `what` names the option.
void checkWavelength(double lambda_nm, const std::string& what);

}  // namespace lensim::optics
