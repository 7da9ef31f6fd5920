// DNG colour matrices from spectral curves (sensor_color.h).
#include "lensim/render/sensor/sensor_color.h"

#include <algorithm>
#include <memory>
#include <vector>

namespace lensim::render {

namespace {

// reflectance x illuminant.
class ProductSpectrum final : public Spectrum {
 public:
  ProductSpectrum(const Spectrum& a, const Spectrum& b) : a_(a), b_(b) {}
  double eval(double l) const override { return a_.eval(l) * b_.eval(l); }
  double maxValue() const override { return a_.maxValue() * b_.maxValue(); }

 private:
  const Spectrum &a_, &b_;
};

class ConstantOne final : public Spectrum {
 public:
  double eval(double) const override { return 1; }
  double maxValue() const override { return 1; }
};

// The D50 white of the DNG profile connection space (ICC: X 0.9642, Y 1, Z 0.8249).
constexpr Vec3 kD50{0.96422, 1.0, 0.82521};

struct Fit {
  Mat3d cm, fm;
};

Fit fitFor(const SensorModel& m, const Spectrum& illum) {
  const ConstantOne one;
  const ProductSpectrum white(one, illum);
  const Vec3 cam_white = cameraResponse(m, white), xyz_white = spectrumToXyz(white);
  std::vector<Vec3> cam, xyz;
  for (const ZeroOutsideSpectrum& r : colorCheckerReflectances()) {
    const ProductSpectrum p(r, illum);
    cam.push_back(cameraResponse(m, p) / cam_white.y);
    xyz.push_back(spectrumToXyz(p) / xyz_white.y);
  }
  const Vec3 w = cam_white / cam_white.y, xw = xyz_white / xyz_white.y;
  Fit f;
  // ColorMatrix: camera = CM XYZ; normalised so the illuminant's white maps to a camera neutral
  // whose largest component is 1 (DNG 1.4, "Camera to XYZ (D50) Transform").
  f.cm = linearLeastSquares(xyz, cam);
  const Vec3 n = mulMat3(f.cm, xw);
  const double s = 1 / std::max({n.x, n.y, n.z});
  for (double& v : f.cm) v *= s;
  // ForwardMatrix: XYZ(D50) = FM (camera / neutral), the target XYZ adapted from the illuminant's
  // white to D50 (Bradford); rows scaled so that FM (1, 1, 1) is exactly D50, as the spec
  // requires.
  const double sum = xw.x + xw.y + xw.z;
  const Mat3d adapt = bradfordAdaptation({xw.x / sum, xw.y / sum}, kD50);
  std::vector<Vec3> bal, d50;
  for (size_t i = 0; i < cam.size(); ++i) {
    bal.push_back({cam[i].x / w.x, cam[i].y / w.y, cam[i].z / w.z});
    d50.push_back(mulMat3(adapt, xyz[i]));
  }
  f.fm = linearLeastSquares(bal, d50);
  const double target[3] = {kD50.x, kD50.y, kD50.z};
  for (int r = 0; r < 3; ++r) {
    const double rs = f.fm[size_t(3 * r)] + f.fm[size_t(3 * r + 1)] + f.fm[size_t(3 * r + 2)];
    for (int c = 0; c < 3; ++c) f.fm[size_t(3 * r + c)] *= target[r] / rs;
  }
  return f;
}

}  // namespace

Vec3 cameraResponse(const SensorModel& m, const Spectrum& s) {
  const std::array<double, 3> e = m.expectedElectrons(s);
  return {e[0], e[1], e[2]};
}

DngColor fitDngColor(const SensorModel& m, double white_balance_k) {
  DngColor d;
  const BlackbodySpectrum a(2856);  // CIE standard illuminant A (CIE 15:2004, 2856 K Planckian)
  const std::shared_ptr<const Spectrum> d65 = daylightIlluminant(6500);
  const Fit f1 = fitFor(m, a), f2 = fitFor(m, *d65);
  d.color_matrix1 = f1.cm;
  d.forward_matrix1 = f1.fm;
  d.color_matrix2 = f2.cm;
  d.forward_matrix2 = f2.fm;
  const std::shared_ptr<const Spectrum> wb =
      daylightIlluminant(white_balance_k > 0 ? white_balance_k : 6500);
  const ConstantOne one;
  const Vec3 n = cameraResponse(m, ProductSpectrum(one, *wb));
  d.as_shot_neutral = n / std::max({n.x, n.y, n.z});
  auto rowSum = [](const Mat3d& m) {
    return Vec3{m[0] + m[3] + m[6], m[1] + m[4] + m[7], m[2] + m[5] + m[8]};
  };
  d.w_color_row1 = rowSum(d.color_matrix1);
  d.w_color_row2 = rowSum(d.color_matrix2);
  d.w_neutral = d.as_shot_neutral.x + d.as_shot_neutral.y + d.as_shot_neutral.z;
  return d;
}

}  // namespace lensim::render
