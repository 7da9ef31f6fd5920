// Lens coatings: named layer stacks, the built-in ones and those of a Zemax coating file.
//
// A coating sits on the glass side of an air-glass surface; its first layer is the outermost
// one (the one light from the air meets first). Light from the glass side meets the layers in
// reverse order. Layer thicknesses are physical (nm) or optical in waves of a design
// wavelength (0.25: a quarter wave, d = 0.25 lambda0 / n(lambda0)).
//
// Built-in coatings (lensim's lens-wide defaults):
// - "uncoated": no layers (the bare interface's Fresnel reflection);
// - "single": a quarter wave of MgF2 (n = 1.38) at 550 nm, the classic single-layer coating;
// - "multi": the quarter-half-quarter broadband anti-reflection stack (air | MgF2 lambda/4 |
//   ZrO2 (n = 2.05) lambda/2 | Al2O3 (n = 1.63) lambda/4 | glass) at 510 nm.
//
// Zemax coating files (COATING.DAT syntax):
//   MATE NAME                 a material, then rows "wavelength_um n k" (k >= 0; ascending)
//   COAT NAME                 a coating, then rows "MATERIAL thickness [is_absolute]": thickness
//                             in waves of the design wavelength, or micrometres when
//                             is_absolute is 1
// `!` starts a comment. Other Zemax blocks (TAPR, ENCI, TABLE, IDEAL ...) are refused at their
// line rather than ignored, since they would change the reflectance.
#pragma once

#include <map>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "lensim/optics/coating/thin_film.h"
#include "lensim/util/error.h"

namespace lensim::optics {

/// A coating material: its complex index n - ik tabulated over wavelength (linear
/// interpolation, held constant beyond the table), or constant (one row).
struct CoatingMaterial {
  std::string name;
  std::vector<double> lambda_nm, n, k;
  FileLoc loc;
  ComplexIndex index(double lambda_nm) const;
  static CoatingMaterial constant(std::string name, double n, double k = 0);
};

struct CoatingLayer {
  int material = 0;        ///< index into CoatingLibrary::materials()
  double thickness = 0;    ///< waves of the design wavelength, or nm when absolute
  bool absolute = false;   ///< thickness is physical (nm)
};

/// A named stack of layers.
struct Coating {
  std::string name;
  std::vector<CoatingLayer> layers;  ///< outermost (air side) first
  /// The wavelength its optical thicknesses refer to; 0: the lens's primary wavelength.
  double design_wavelength_nm = 0;
  FileLoc loc;
};

/// Materials and coatings by name (names compare case-insensitively, as Zemax's do).
class CoatingLibrary {
 public:
  /// The built-in coatings ("uncoated", "single", "multi") and their materials.
  CoatingLibrary();
  /// Adds the materials and coatings of a Zemax coating file's text (`path` for messages);
  /// a name already defined is replaced. Throws lensim::Error at the offending line.
  void addZemaxCoatingFile(std::string_view text, const std::string& path);
  /// Reads and adds a Zemax coating file. Throws lensim::Error when unreadable or malformed.
  void readZemaxCoatingFile(const std::string& path);

  /// The coating of that name, or nullptr.
  const Coating* find(std::string_view name) const;
  const std::vector<CoatingMaterial>& materials() const { return materials_; }
  /// Names of all coatings (for messages), sorted.
  std::vector<std::string> names() const;

  /// The layers of `c` at a wavelength: complex indices and physical thicknesses (nm).
  /// `fallback_design_nm` is used when the coating has no design wavelength of its own.
  std::vector<FilmLayer> layersAt(const Coating& c, double lambda_nm,
                                  double fallback_design_nm) const;

  /// R, T, A of an interface between lossless media n_before and n_after for light meeting it
  /// at cos_i (from the n_before side), coated with `c` (nullptr: bare). The coating is on the
  /// side of the higher index (the glass); light from that side meets its layers in reverse.
  FilmRTA interfaceRTA(const Coating* c, double n_before, double n_after, double lambda_nm,
                       double cos_i, double fallback_design_nm) const;
  /// interfaceRTA at every wavelength of lambda_nm (out[w]), sharing the angle's part of the
  /// thin-film computation when the coating's materials are non-dispersive.
  void interfaceRTASpectral(const Coating* c, double n_before, double n_after,
                            std::span<const double> lambda_nm, double cos_i,
                            double fallback_design_nm, FilmRTA* out) const;

 private:
  /// The layers of `c` at a wavelength into out[0 .. c.layers.size()), in reverse order when
  /// `reversed` (light from the glass side).
  void fillLayers(const Coating& c, double lambda_nm, double fallback_design_nm, bool reversed,
                  FilmLayer* out) const;
  int addMaterial(CoatingMaterial m);
  std::vector<CoatingMaterial> materials_;
  std::map<std::string, int> material_by_name_;  // upper-case name -> index
  std::map<std::string, Coating> coatings_;      // upper-case name -> coating
};

/// The coating names lensim's lens files may use as a lens-wide default.
inline constexpr const char* kLensWideCoatings[] = {"uncoated", "single", "multi"};

}  // namespace lensim::optics
