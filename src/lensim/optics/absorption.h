// Absorption in a lens's glasses: the internal transmittance of a traced path (Beer-Lambert with
// each glass's catalogue transmittance, Glass::absorptionCoefficient_per_mm) and of the axis.
//
// A path runs through the media between the lens's first and last surfaces; medium i is the one
// after surface i (LensSystem::glasses()). Its transmittance at lambda is
//   T = exp(-sum_i alpha_i(lambda) L_i),
// L_i the path's length in medium i. Glasses without transmittance data (AGF `IT` rows),
// constant indices, model glasses and air absorb nothing (T = 1 there). Reflection losses at the
// surfaces are not included (coating/lens_coatings.h has those).
#pragma once

#include <vector>

#include "lensim/optics/lens_system.h"

namespace lensim::optics {

class LensAbsorption {
 public:
  LensAbsorption() = default;
  explicit LensAbsorption(const LensSystem& lens);

  /// Whether any medium inside the lens has transmittance data.
  bool any() const { return any_; }
  /// The media (by surface index) inside the lens that are glasses without transmittance data,
  /// for lens info.
  const std::vector<int>& mediaWithoutData() const { return without_data_; }

  /// The transmittance of a path as LensTracer records it (`path`: the start point, then each
  /// surface met, in the order met) for a trace from the film (from_film) or from the scene.
  /// A path cut short (a blocked ray) counts the media it crossed.
  template <typename T>
  double alongPath(const std::vector<Vec3T<T>>& path, bool from_film, double lambda_nm) const;
  /// The transmittance of a path whose segments lie in the given media: segment path[j] ->
  /// path[j + 1] in medium media[j] (the medium after that lens surface; -1 or out of range:
  /// outside the lens). For paths that do not meet the surfaces in the lens's order (a ghost
  /// path, which runs back through some media).
  template <typename T>
  double alongMedia(const std::vector<Vec3T<T>>& path, const std::vector<int>& media,
                    double lambda_nm) const;
  /// The transmittance along the optical axis: each medium's axial thickness (its vertex
  /// spacing, a mirror's return included).
  double axial(double lambda_nm) const;

 private:
  // The absorption coefficient of medium i at lambda: from the table between kFrom_nm and
  // kTo_nm (every nanometre, linear in between: exact where the catalogue's rows lie on whole
  // nanometres, as all of the built-in catalogues' rows below 1000 nm do; elsewhere the error
  // stays inside the nanometre that holds the row), from the glass beyond.
  double alpha(size_t i, double lambda_nm) const;
  /// exp(-sum alpha L) over the segments j of `path` (1 <= j), medium_of(j) the medium of
  /// path[j] -> path[j + 1].
  template <typename T, typename MediumOf>
  double transmittance(const std::vector<Vec3T<T>>& path, size_t first, MediumOf medium_of,
                       double lambda_nm) const;
  static constexpr int kFrom_nm = 300, kTo_nm = 1100;
  std::vector<double> table_;     // (kTo_nm - kFrom_nm + 1) rows of media_.size() values
  std::vector<Glass> media_;      // after surface i, i < surfaces - 1
  std::vector<double> axial_mm_;  // |vertex spacing| after surface i
  std::vector<int> without_data_;
  bool any_ = false;
};

}  // namespace lensim::optics
