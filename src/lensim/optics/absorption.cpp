#include "lensim/optics/absorption.h"

#include <cmath>

namespace lensim::optics {

LensAbsorption::LensAbsorption(const LensSystem& lens) {
  const std::vector<Interface>& s = lens.interfaces();
  const int n = int(s.size());
  for (int i = 0; i + 1 < n; ++i) {
    const Glass& g = lens.glasses()[size_t(i)];
    media_.push_back(g);
    axial_mm_.push_back(std::abs(s[size_t(i) + 1].z_mm - s[size_t(i)].z_mm));
    if (g.hasTransmittance())
      any_ = true;
    else if (!g.isAir())
      without_data_.push_back(i);
  }
  if (!any_) return;
  const size_t m = media_.size();
  table_.assign(size_t(kTo_nm - kFrom_nm + 1) * m, 0.0);
  for (int l = kFrom_nm; l <= kTo_nm; ++l)
    for (size_t i = 0; i < m; ++i)
      table_[size_t(l - kFrom_nm) * m + i] = media_[i].absorptionCoefficient_per_mm(l);
}

double LensAbsorption::alpha(size_t i, double lambda_nm) const {
  const double u = lambda_nm - kFrom_nm;
  if (!(u >= 0 && u < kTo_nm - kFrom_nm)) return media_[i].absorptionCoefficient_per_mm(lambda_nm);
  const size_t k = size_t(u), m = media_.size();
  const double a = u - double(k), lo = table_[k * m + i], hi = table_[(k + 1) * m + i];
  return lo + a * (hi - lo);
}

template <typename T, typename MediumOf>
double LensAbsorption::transmittance(const std::vector<Vec3T<T>>& path, size_t first,
                                     MediumOf medium_of, double lambda_nm) const {
  if (!any_) return 1;
  const int m = int(media_.size());  // surfaces - 1
  double optical_depth = 0;
  for (size_t j = first; j + 1 < path.size(); ++j) {
    const int medium = medium_of(j);
    if (medium < 0 || medium >= m) continue;
    const Glass& g = media_[size_t(medium)];
    if (!g.hasTransmittance()) continue;
    const Vec3T<T> d = path[j + 1] - path[j];
    const double len = std::sqrt(double(d.x) * double(d.x) + double(d.y) * double(d.y) +
                                 double(d.z) * double(d.z));
    optical_depth += alpha(size_t(medium), lambda_nm) * len;
  }
  return std::exp(-optical_depth);
}

template <typename T>
double LensAbsorption::alongPath(const std::vector<Vec3T<T>>& path, bool from_film,
                                 double lambda_nm) const {
  const int m = int(media_.size());  // surfaces - 1
  // Scene: path[k + 1] is on surface k, so path[k + 1] -> path[k + 2] lies in medium k.
  // Film: path[j] is on surface m + 1 - j (m + 1 surfaces), so path[j] -> path[j + 1] lies in
  // medium m - j.
  return transmittance(
      path, 1, [&](size_t j) { return from_film ? m - int(j) : int(j) - 1; }, lambda_nm);
}

template <typename T>
double LensAbsorption::alongMedia(const std::vector<Vec3T<T>>& path, const std::vector<int>& media,
                                  double lambda_nm) const {
  return transmittance(
      path, 0, [&](size_t j) { return j < media.size() ? media[j] : -1; }, lambda_nm);
}

template double LensAbsorption::alongPath(const std::vector<Vec3T<double>>&, bool, double) const;
template double LensAbsorption::alongPath(const std::vector<Vec3T<float>>&, bool, double) const;
template double LensAbsorption::alongMedia(const std::vector<Vec3T<double>>&,
                                           const std::vector<int>&, double) const;

double LensAbsorption::axial(double lambda_nm) const {
  double optical_depth = 0;
  for (size_t i = 0; i < media_.size(); ++i)
    optical_depth += media_[i].absorptionCoefficient_per_mm(lambda_nm) * axial_mm_[i];
  return std::exp(-optical_depth);
}

}  // namespace lensim::optics
