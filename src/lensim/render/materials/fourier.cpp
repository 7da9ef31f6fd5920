// pbrt-v3's tabulated "fourier" BSDF (see fourier.h). Facts from pbrt-v3
// src/core/reflection.cpp (FourierBSDFTable::Read, FourierBSDF) and src/core/interpolation.cpp
// (CatmullRomWeights, SampleCatmullRom2D, Fourier, SampleFourier); the code is lensim's.
#include "lensim/render/materials/fourier.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "lensim/render/spectra/spectrum.h"
#include "lensim/util/error.h"
#include "lensim/util/file.h"
#include "lensim/util/limits.h"
#include "lensim/util/path_cache.h"

namespace lensim::render {

namespace {

constexpr char kMagic[8] = {'S', 'C', 'A', 'T', 'F', 'U', 'N', '\x01'};
constexpr uint64_t kHeaderBytes = 64;
// Newton-bisection steps before giving up on convergence (pbrt-v3 loops until converged; a
// corrupt table could make that slow, and the bracket is tiny long before this).
constexpr int kMaxIterations = 100;

uint32_t u32At(std::string_view b, uint64_t at) {
  uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = (v << 8) | static_cast<unsigned char>(b[at + uint64_t(i)]);
  return v;
}
int32_t i32At(std::string_view b, uint64_t at) {
  const uint32_t u = u32At(b, at);
  int32_t v;
  std::memcpy(&v, &u, 4);
  return v;
}
float f32At(std::string_view b, uint64_t at) {
  const uint32_t u = u32At(b, at);
  float v;
  std::memcpy(&v, &u, 4);
  return v;
}

/// pbrt's FindInterval: the largest i in [0, size - 2] with pred(i) true, pred monotone.
template <class Pred>
int findInterval(int size, Pred pred) {
  int first = 0, len = size;
  while (len > 0) {
    const int half = len >> 1, middle = first + half;
    if (pred(middle)) {
      first = middle + 1;
      len -= half + 1;
    } else {
      len = half;
    }
  }
  return std::clamp(first - 1, 0, size - 2);
}

/// pbrt-v3's CosDPhi: the cosine of the azimuth between wa and wb (1 when either is vertical).
double cosDPhi(const Vec3& wa, const Vec3& wb) {
  const double a = wa.x * wa.x + wa.y * wa.y, b = wb.x * wb.x + wb.y * wb.y;
  if (a == 0 || b == 0) return 1;
  return std::clamp((wa.x * wb.x + wa.y * wb.y) / std::sqrt(a * b), -1.0, 1.0);
}

/// Per-thread scratch for the interpolated coefficients (channels x mMax).
std::vector<double>& scratch(size_t n) {
  thread_local std::vector<double> buf;
  buf.assign(n, 0.0);
  return buf;
}

}  // namespace

FourierBSDFTable FourierBSDFTable::read(const std::string& path) {
  const std::string bytes = readRegularFile(path, "tabulated BSDF file");
  return parse(bytes, path);
}

FourierBSDFTable FourierBSDFTable::parse(std::string_view b, const std::string& path) {
  auto fail = [&](uint64_t byte, const std::string& message) {
    throw Error(FileLoc{path}, fmt::format("byte {}: {}", byte, message));
  };
  const uint64_t size = b.size();
  if (size < sizeof kMagic || std::memcmp(b.data(), kMagic, sizeof kMagic) != 0)
    fail(0,
         "not a pbrt-v3 tabulated BSDF: expected the header \"SCATFUN\" and version byte 1 "
         "(pbrt-v3's FourierBSDFTable format)");
  if (size < kHeaderBytes)
    fail(size, fmt::format("the file ends after {} bytes, inside the {}-byte header (truncated?)",
                           size, kHeaderBytes));
  FourierBSDFTable t;
  const int32_t flags = i32At(b, 8), n_mu = i32At(b, 12), n_coeffs = i32At(b, 16),
                m_max = i32At(b, 20), n_channels = i32At(b, 24), n_bases = i32At(b, 28);
  const float eta = f32At(b, 44);
  if (flags != 1)
    fail(8, fmt::format("flags {}; expected 1 (pbrt-v3 reads only tables of uniform, untextured "
                        "parameters)",
                        flags));
  if (n_mu < 2) fail(12, fmt::format("{} zenith nodes (nMu); expected at least 2", n_mu));
  if (n_coeffs < 1)
    fail(16, fmt::format("{} coefficients (nCoeffs); expected at least 1", n_coeffs));
  if (m_max < 1 || m_max > n_coeffs)
    fail(20, fmt::format("highest Fourier order count mMax {}; expected 1 to nCoeffs ({})", m_max,
                         n_coeffs));
  if (n_channels != 1 && n_channels != 3)
    fail(24, fmt::format("{} channels; expected 1 (monochrome) or 3 (Y, R, B)", n_channels));
  if (n_bases != 1)
    fail(28,
         fmt::format("{} basis functions; expected 1 (pbrt-v3 reads no textured tables)", n_bases));
  if (!(std::isfinite(eta) && eta > 0 && eta <= 1e3))
    fail(44, fmt::format("relative index eta {}; expected a finite value in (0, 1000]", eta));

  // Sizes from the header, checked against the file before anything is allocated.
  const uint64_t pairs = uint64_t(n_mu) * uint64_t(n_mu);  // < 2^62: no overflow
  const uint64_t words = uint64_t(n_mu) + pairs + 2 * pairs + uint64_t(n_coeffs);
  const auto need = checkedAdd(kHeaderBytes, 4 * words);  // words < 2^63 / 4
  if (!need || *need > size)
    fail(12, fmt::format("the header's sizes (nMu {}, nCoeffs {}) need {} bytes; the file has {} "
                         "(truncated, or a corrupt header)",
                         n_mu, n_coeffs, need ? fmt::format("{}", *need) : "over 2^64", size));
  checkMemory(
      double(pairs) * (3 * 8 + 2 * 4) + double(n_coeffs) * 4 + double(n_mu) * 8 + double(m_max) * 8,
      FileLoc{path}, "the tabulated BSDF");

  t.eta_ = eta;
  t.n_mu_ = n_mu;
  t.m_max_ = m_max;
  t.n_channels_ = n_channels;
  uint64_t at = kHeaderBytes;
  t.mu_.resize(size_t(n_mu));
  for (int i = 0; i < n_mu; ++i, at += 4) {
    const double v = f32At(b, at);
    if (!(std::isfinite(v) && v >= -1 && v <= 1))
      fail(at, fmt::format("zenith node mu[{}] = {}; expected a cosine in [-1, 1]", i, v));
    if (i > 0 && !(v > t.mu_[size_t(i) - 1]))
      fail(at, fmt::format("zenith node mu[{}] = {} is not above mu[{}] = {}; expected increasing "
                           "nodes",
                           i, v, i - 1, t.mu_[size_t(i) - 1]));
    t.mu_[size_t(i)] = v;
  }
  t.cdf_.resize(pairs);
  for (uint64_t i = 0; i < pairs; ++i, at += 4) {
    const double v = f32At(b, at);
    if (!(std::isfinite(v) && std::abs(v) <= kMaxFourierCoefficient))
      fail(at, fmt::format("cdf value {} of row {}; expected a finite number of magnitude at most "
                           "{:g}",
                           v, i / uint64_t(n_mu), kMaxFourierCoefficient));
    t.cdf_[i] = v;
  }
  t.offset_.resize(pairs);
  t.length_.resize(pairs);
  for (uint64_t i = 0; i < pairs; ++i, at += 8) {
    const int32_t offset = i32At(b, at), length = i32At(b, at + 4);
    const uint64_t o = i / uint64_t(n_mu), in = i % uint64_t(n_mu);
    if (length < 0 || length > m_max)
      fail(at + 4, fmt::format("pair (mu_o {}, mu_i {}) has {} orders; expected 0 to mMax ({})", o,
                               in, length, m_max));
    if (offset < 0 ||
        uint64_t(offset) + uint64_t(length) * uint64_t(n_channels) > uint64_t(n_coeffs))
      fail(at, fmt::format("pair (mu_o {}, mu_i {}) has coefficients {} to {}, outside the {} "
                           "coefficients of the file",
                           o, in, offset,
                           int64_t(offset) + int64_t(length) * int64_t(n_channels) - 1, n_coeffs));
    t.offset_[i] = uint32_t(offset);
    t.length_[i] = uint32_t(length);
  }
  t.a_.resize(size_t(n_coeffs));
  for (int i = 0; i < n_coeffs; ++i, at += 4) {
    const float v = f32At(b, at);
    if (!(std::isfinite(v) && std::abs(double(v)) <= kMaxFourierCoefficient))
      fail(at, fmt::format("coefficient {} is {}; expected a finite number of magnitude at most "
                           "{:g}",
                           i, v, kMaxFourierCoefficient));
    t.a_[size_t(i)] = v;
  }
  t.a0_.resize(pairs);
  for (uint64_t i = 0; i < pairs; ++i) t.a0_[i] = t.length_[i] > 0 ? t.a_[t.offset_[i]] : 0.0;
  t.recip_.resize(size_t(m_max));
  for (int k = 0; k < m_max; ++k) t.recip_[size_t(k)] = k > 0 ? 1.0 / k : 0.0;
  return t;
}

std::shared_ptr<const FourierBSDFTable> FourierBSDFTable::loadCached(const std::string& path) {
  return loadOncePerPath<FourierBSDFTable>(path, [](const std::string& p) { return read(p); });
}

bool FourierBSDFTable::weights(double x, int& offset, double w[4]) const {
  const int n = n_mu_;
  const double* nodes = mu_.data();
  if (!(x >= nodes[0] && x <= nodes[n - 1])) return false;
  const int idx = findInterval(n, [&](int i) { return nodes[i] <= x; });
  offset = idx - 1;
  const double x0 = nodes[idx], x1 = nodes[idx + 1];
  const double t = (x - x0) / (x1 - x0), t2 = t * t, t3 = t2 * t;
  w[1] = 2 * t3 - 3 * t2 + 1;
  w[2] = -2 * t3 + 3 * t2;
  if (idx > 0) {
    const double w0 = (t3 - 2 * t2 + t) * (x1 - x0) / (x1 - nodes[idx - 1]);
    w[0] = -w0;
    w[2] += w0;
  } else {
    const double w0 = t3 - 2 * t2 + t;
    w[0] = 0;
    w[1] -= w0;
    w[2] += w0;
  }
  if (idx + 2 < n) {
    const double w3 = (t3 - t2) * (x1 - x0) / (nodes[idx + 2] - x0);
    w[1] -= w3;
    w[3] = w3;
  } else {
    const double w3 = t3 - t2;
    w[1] -= w3;
    w[2] += w3;
    w[3] = 0;
  }
  return true;
}

int FourierBSDFTable::coefficients(double mu_i, double mu_o, double* ak, double w_o[4],
                                   int& offset_o) const {
  int offset_i;
  double w_i[4];
  if (!weights(mu_i, offset_i, w_i) || !weights(mu_o, offset_o, w_o)) return -1;
  int m = 0;
  for (int b = 0; b < 4; ++b)
    for (int a = 0; a < 4; ++a) {
      const double w = w_i[a] * w_o[b];
      if (w == 0) continue;
      const size_t pair = size_t(offset_o + b) * size_t(n_mu_) + size_t(offset_i + a);
      const int len = int(length_[pair]);
      const float* ap = a_.data() + offset_[pair];
      m = std::max(m, len);
      for (int c = 0; c < n_channels_; ++c)
        for (int k = 0; k < len; ++k)
          ak[size_t(c) * size_t(m_max_) + size_t(k)] += w * double(ap[c * len + k]);
    }
  return m;
}

double FourierBSDFTable::fourier(const double* a, int m, double cos_phi) {
  double value = 0, cos_prev = cos_phi, cos_k = 1;
  for (int k = 0; k < m; ++k) {
    value += a[k] * cos_k;
    const double cos_next = 2 * cos_phi * cos_k - cos_prev;
    cos_prev = cos_k;
    cos_k = cos_next;
  }
  return value;
}

double FourierBSDFTable::sampleFourier(const double* ak, int m, double u, double& pdf,
                                       double& phi_out) const {
  // Sample one half of the circle and mirror (the series is even in phi); on [0, pi] invert
  // F(phi) = a_0 phi + sum_k a_k sin(k phi) / k = u a_0 pi by Newton steps inside a bisection
  // bracket.
  const bool flip = u >= 0.5;
  u = flip ? 1 - 2 * (u - 0.5) : 2 * u;
  double a = 0, b = M_PI, phi = 0.5 * M_PI, F = 0, f = 0;
  for (int it = 0; it < kMaxIterations; ++it) {
    const double cos_phi = std::cos(phi);
    const double sin_phi = std::sqrt(std::max(0.0, 1 - cos_phi * cos_phi));
    double cos_prev = cos_phi, cos_cur = 1, sin_prev = -sin_phi, sin_cur = 0;
    F = ak[0] * phi;
    f = ak[0];
    for (int k = 1; k < m; ++k) {
      const double sin_next = 2 * cos_phi * sin_cur - sin_prev;
      const double cos_next = 2 * cos_phi * cos_cur - cos_prev;
      sin_prev = sin_cur, sin_cur = sin_next;
      cos_prev = cos_cur, cos_cur = cos_next;
      F += ak[k] * recip_[size_t(k)] * sin_next;
      f += ak[k] * cos_next;
    }
    F -= u * ak[0] * M_PI;
    if (F > 0)
      b = phi;
    else
      a = phi;
    if (std::abs(F) < 1e-6 || b - a < 1e-6) break;
    phi -= F / f;
    if (!(phi > a && phi < b)) phi = 0.5 * (a + b);
  }
  if (flip) phi = 2 * M_PI - phi;
  pdf = f / (2 * M_PI * ak[0]);
  phi_out = phi;
  return f;
}

std::optional<std::pair<double, double>> FourierBSDFTable::sampleMu(double mu_o, double u) const {
  const int n = n_mu_;
  int offset;
  double w[4];
  if (!weights(mu_o, offset, w)) return std::nullopt;
  auto interp = [&](const std::vector<double>& array, int idx) {
    double v = 0;
    for (int i = 0; i < 4; ++i)
      if (w[i] != 0) v += array[size_t(offset + i) * size_t(n) + size_t(idx)] * w[i];
    return v;
  };
  const double maximum = interp(cdf_, n - 1);
  if (!(maximum > 0)) return std::nullopt;
  u *= maximum;
  const int idx = findInterval(n, [&](int i) { return interp(cdf_, i) <= u; });
  const double f0 = interp(a0_, idx), f1 = interp(a0_, idx + 1);
  const double x0 = mu_[size_t(idx)], x1 = mu_[size_t(idx) + 1], width = x1 - x0;
  u = (u - interp(cdf_, idx)) / width;
  const double d0 =
      idx > 0 ? width * (f1 - interp(a0_, idx - 1)) / (x1 - mu_[size_t(idx) - 1]) : f1 - f0;
  const double d1 =
      idx + 2 < n ? width * (interp(a0_, idx + 2) - f0) / (mu_[size_t(idx) + 2] - x0) : f1 - f0;
  // Invert the spline segment's integral: a first guess from the linear interpolant, then
  // Newton steps inside a bisection bracket.
  double t =
      f0 != f1 ? (f0 - std::sqrt(std::max(0.0, f0 * f0 + 2 * u * (f1 - f0)))) / (f0 - f1) : u / f0;
  double a = 0, b = 1, Fhat = 0, fhat = 0;
  for (int it = 0; it < kMaxIterations; ++it) {
    if (!(t >= a && t <= b)) t = 0.5 * (a + b);
    Fhat = t * (f0 + t * (.5 * d0 + t * ((1.0 / 3.0) * (-2 * d0 - d1) + f1 - f0 +
                                         t * (.25 * (d0 + d1) + .5 * (f0 - f1)))));
    fhat = f0 + t * (d0 + t * (-2 * d0 - d1 + 3 * (f1 - f0) + t * (d0 + d1 + 2 * (f0 - f1))));
    if (std::abs(Fhat - u) < 1e-6 || b - a < 1e-6) break;
    if (Fhat - u < 0)
      a = t;
    else
      b = t;
    t -= (Fhat - u) / fhat;
  }
  const double pdf = fhat / maximum;
  const double mu_i = x0 + width * t;
  if (!(pdf > 0) || !std::isfinite(pdf) || !std::isfinite(mu_i)) return std::nullopt;
  return std::pair{std::clamp(mu_i, -1.0, 1.0), pdf};
}

double FourierBSDFTable::rowIntegral(const double w_o[4], int offset_o) const {
  double r = 0;
  for (int o = 0; o < 4; ++o)
    if (w_o[o] != 0) r += w_o[o] * cdf_[size_t(offset_o + o) * size_t(n_mu_) + size_t(n_mu_) - 1];
  return r;
}

// ---- the BxDF --------------------------------------------------------------------------------

SampledSpectrum FourierBxDF::value(const double* ak, int m, double cos_phi, double mu_i,
                                   double mu_o, TransportMode mode, double y) const {
  const FourierBSDFTable& t = *table_;
  double scale = mu_i != 0 ? 1 / std::abs(mu_i) : 0.0;
  // Radiance crossing the interface is scaled by the squared index ratio (pbrt-v3: when
  // mu_i mu_o > 0, i.e. transmission).
  if (mode == TransportMode::Radiance && mu_i * mu_o > 0) {
    const double e = mu_i > 0 ? 1 / t.eta() : t.eta();
    scale *= e * e;
  }
  if (!std::isfinite(y * scale)) return SampledSpectrum(0.0);
  if (t.channels() == 1) return SampledSpectrum(std::max(0.0, y * scale));
  const double r = FourierBSDFTable::fourier(ak + t.mMax(), m, cos_phi);
  const double bl = FourierBSDFTable::fourier(ak + 2 * t.mMax(), m, cos_phi);
  const double g = 1.39829 * y - 0.100913 * bl - 0.297375 * r;
  const Vec3 rgb{std::max(0.0, r * scale), std::max(0.0, g * scale), std::max(0.0, bl * scale)};
  if (!std::isfinite(rgb.x + rgb.y + rgb.z)) return SampledSpectrum(0.0);
  const double mx = std::max({rgb.x, rgb.y, rgb.z});
  SampledSpectrum s(0.0);
  if (!(mx > 0) || !std::isfinite(mx)) return s;
  // pbrt-v4's RGBUnboundedSpectrum: scale 2 max(rgb), the sigmoid fit of rgb / scale.
  const double sc = 2 * mx;
  const SigmoidPolynomial poly = RGBColorSpace::sRGB().tableSigmoid(rgb / sc);
  return poly.sample(lambda_) * sc;
}

SampledSpectrum FourierBxDF::f(const Vec3& wo, const Vec3& wi, TransportMode mode) const {
  const FourierBSDFTable& t = *table_;
  const double mu_i = -wi.z, mu_o = wo.z;
  const double cos_phi = cosDPhi(-wi, wo);
  std::vector<double>& ak = scratch(size_t(t.mMax()) * size_t(t.channels()));
  double w_o[4];
  int offset_o;
  const int m = t.coefficients(mu_i, mu_o, ak.data(), w_o, offset_o);
  if (m <= 0) return {};
  const double y = std::max(0.0, FourierBSDFTable::fourier(ak.data(), m, cos_phi));
  return value(ak.data(), m, cos_phi, mu_i, mu_o, mode, y);
}

std::optional<BSDFSample> FourierBxDF::sample_f(const Vec3& wo, double, Vec2 u, TransportMode mode,
                                                ReflTrans allowed) const {
  const FourierBSDFTable& t = *table_;
  const double mu_o = wo.z;
  const auto mu = t.sampleMu(mu_o, u.y);
  if (!mu) return std::nullopt;
  const auto [mu_i, pdf_mu] = *mu;
  std::vector<double>& ak = scratch(size_t(t.mMax()) * size_t(t.channels()));
  double w_o[4];
  int offset_o;
  const int m = t.coefficients(mu_i, mu_o, ak.data(), w_o, offset_o);
  if (m <= 0 || !(ak[0] > 0)) return std::nullopt;
  double pdf_phi, phi;
  const double y = t.sampleFourier(ak.data(), m, u.x, pdf_phi, phi);
  const double pdf = pdf_phi * pdf_mu;
  if (!(pdf > 0) || !std::isfinite(pdf)) return std::nullopt;
  // wi: -wi has zenith cosine mu_i and the azimuth of wo turned by phi (pbrt-v3 Sample_f). For
  // a vertical wo, whose azimuth is undefined, phi is measured from +x.
  const double sin_i = std::sqrt(std::max(0.0, 1 - mu_i * mu_i));
  const double sin_o2 = wo.x * wo.x + wo.y * wo.y;
  const double sp = std::sin(phi), cp = std::cos(phi);
  Vec3 wi;
  if (sin_o2 > 0) {
    const double norm = sin_i / std::sqrt(sin_o2);
    wi = -Vec3(norm * (cp * wo.x - sp * wo.y), norm * (sp * wo.x + cp * wo.y), mu_i);
  } else {
    wi = -Vec3(sin_i * cp, sin_i * sp, mu_i);
  }
  const double len = length(wi);
  if (!(len > 0)) return std::nullopt;
  wi = wi / len;
  if (wi.z == 0 || wo.z == 0) return std::nullopt;
  const bool reflection = wi.z * wo.z > 0;
  if (!allows(allowed, reflection ? ReflTrans::Reflection : ReflTrans::Transmission))
    return std::nullopt;
  BSDFSample s;
  s.f = value(ak.data(), m, cp, mu_i, mu_o, mode, y);
  s.wi = wi;
  s.pdf = pdf;
  s.flags = BxDFFlags::Glossy | (reflection ? BxDFFlags::Reflection : BxDFFlags::Transmission);
  return s;
}

double FourierBxDF::pdf(const Vec3& wo, const Vec3& wi, TransportMode, ReflTrans allowed) const {
  if (wo.z == 0 || wi.z == 0) return 0;
  const bool reflection = wi.z * wo.z > 0;
  if (!allows(allowed, reflection ? ReflTrans::Reflection : ReflTrans::Transmission)) return 0;
  const FourierBSDFTable& t = *table_;
  std::vector<double>& ak = scratch(size_t(t.mMax()) * size_t(t.channels()));
  double w_o[4];
  int offset_o;
  const int m = t.coefficients(-wi.z, wo.z, ak.data(), w_o, offset_o);
  if (m <= 0) return 0;
  const double rho = t.rowIntegral(w_o, offset_o) * 2 * M_PI;
  const double y = FourierBSDFTable::fourier(ak.data(), m, cosDPhi(-wi, wo));
  return rho > 0 && y > 0 ? y / rho : 0.0;
}

}  // namespace lensim::render
