// The coating of every surface of a lens, and what they do to its light: reflection losses
// (transmittance) and the two-reflection ghosts.
//
// Which coating a surface has: the one its row names (JSON "coating", Zemax COAT); else, on an
// air-glass surface, the lens-wide default (JSON top-level "coating"; "uncoated" when unset);
// cemented surfaces and index-matched ones (the stop) stay bare (they reflect by their index
// step alone). Mirrors reflect fully and are not coated.
#pragma once

#include <memory>
#include <span>
#include <string>
#include <vector>

#include "lensim/optics/coating/coating.h"
#include "lensim/optics/prescription.h"

namespace lensim::optics {

class LensSystem;

struct LensCoatings {
  std::shared_ptr<const CoatingLibrary> library;
  /// Per surface: the coating, or nullptr for a bare interface.
  std::vector<const Coating*> coating;
  /// Per surface, for reports: "multi", "uncoated", "cemented", "mirror", "index-matched".
  std::vector<std::string> label;
  /// The wavelength Zemax-style coatings' optical thicknesses refer to (the lens's primary).
  double design_wavelength_nm = 587.56;

  /// R, T, A of surface k between indices n_before and n_after at a wavelength, for light from
  /// the n_before side at cos_i.
  FilmRTA rta(int k, double n_before, double n_after, double lambda_nm, double cos_i) const;
  /// rta at several wavelengths at once (out[w] for lambda_nm[w]), the indices the same at all.
  void rtaSpectral(int k, double n_before, double n_after, std::span<const double> lambda_nm,
                   double cos_i, FilmRTA* out) const;
};

/// Resolves the prescription's coating names (and reads its coating file). Throws lensim::Error
/// at the line naming an unknown coating, listing the known names.
LensCoatings resolveCoatings(const LensPrescription& p);

/// The fraction of the light of an axial point at infinity that the lens passes, counting the
/// reflection losses of its interfaces (normal incidence: the paraxial axial beam) but not the
/// glasses' absorption; mirrors count as perfect.
double axialTransmittance(const LensSystem& lens, const LensCoatings& c, double lambda_nm);

}  // namespace lensim::optics
