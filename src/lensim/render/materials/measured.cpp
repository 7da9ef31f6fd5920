#include "lensim/render/materials/measured.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "lensim/render/materials/microfacet.h"
#include "lensim/sampling/sampling.h"
#include "lensim/util/error.h"
#include "lensim/util/file.h"
#include "lensim/util/limits.h"
#include "lensim/util/path_cache.h"

namespace lensim::render {

using namespace lensim::sampling;

// ---------------------------------------------------------------------------------------------
// Reader

namespace {

struct Token {
  std::string_view text;
  int line, column;
};

// Splits into whitespace-separated tokens, dropping `#` comments (to the end of the line).
std::vector<Token> tokenize(std::string_view text) {
  std::vector<Token> tokens;
  int line = 1;
  std::size_t line_start = 0, i = 0;
  const std::size_t n = text.size();
  while (i < n) {
    const char c = text[i];
    if (c == '\n') {
      ++line;
      line_start = ++i;
    } else if (c == '#') {
      while (i < n && text[i] != '\n') ++i;
    } else if (c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v') {
      ++i;
    } else {
      const std::size_t start = i;
      while (i < n && !std::isspace(static_cast<unsigned char>(text[i])) && text[i] != '#') ++i;
      tokens.push_back({text.substr(start, i - start), line, int(start - line_start) + 1});
    }
  }
  return tokens;
}

std::optional<double> toNumber(std::string_view s) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  double v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || end != s.data() + s.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

const char* const kAngleNames[4] = {"theta_i", "phi_i", "theta_o", "phi_o"};

}  // namespace

IrregularBRDFData parseIrregularBRDF(std::string_view text, const std::string& path) {
  const std::vector<Token> tokens = tokenize(text);
  auto loc = [&](const Token& t) { return FileLoc{path, t.line, t.column}; };
  auto number = [&](const Token& t, const std::string& what) {
    const auto v = toNumber(t.text);
    if (!v) throw Error(loc(t), fmt::format("'{}' is not a number; expected {}", t.text, what));
    return *v;
  };

  if (tokens.empty())
    throw Error(FileLoc{path, 1, 0},
                "no numbers in the file; expected the count of wavelengths (an irregular "
                "isotropic BRDF: count, wavelengths, then samples)");
  IrregularBRDFData d;
  const double count = number(tokens[0], "the count of wavelengths");
  if (count < 1 || count != std::floor(count) || count > kMaxBRDFWavelengths)
    throw Error(loc(tokens[0]), fmt::format("the count of wavelengths is {}; expected a whole "
                                            "number from 1 to {}",
                                            tokens[0].text, kMaxBRDFWavelengths));
  const std::size_t nw = std::size_t(count);
  // The interpolation table holds every node for every wavelength (MeasuredBRDF::Options).
  {
    const MeasuredBRDF::Options o;
    checkMemory(4.0 * o.n_theta * o.n_theta * o.n_phi * static_cast<double>(nw), loc(tokens[0]),
                fmt::format("the BRDF table for {} wavelengths", nw));
  }
  if (tokens.size() < 1 + nw)
    throw Error(loc(tokens.back()),
                fmt::format("the file ends after {} of the {} wavelengths", tokens.size() - 1, nw));
  for (std::size_t i = 0; i < nw; ++i) {
    const Token& t = tokens[1 + i];
    const double wl = number(t, fmt::format("wavelength {} of {} (nm)", i + 1, nw));
    if (wl <= 0)
      throw Error(loc(t), fmt::format("wavelength {} of {} is {}; expected a positive number of nm",
                                      i + 1, nw, t.text));
    if (!d.wavelengths_nm.empty() && wl <= d.wavelengths_nm.back())
      throw Error(loc(t), fmt::format("wavelength {} of {} is {} nm after {} nm; expected "
                                      "increasing wavelengths",
                                      i + 1, nw, t.text, d.wavelengths_nm.back()));
    d.wavelengths_nm.push_back(wl);
  }

  const std::size_t per = 4 + nw, first = 1 + nw, rest = tokens.size() - first;
  if (rest == 0)
    throw Error(loc(tokens.back()), fmt::format("no samples after the {} wavelengths; expected "
                                                "samples of {} numbers (theta_i phi_i theta_o "
                                                "phi_o and {} values)",
                                                nw, per, nw));
  if (rest % per != 0) {
    const std::size_t k = rest / per;
    throw Error(loc(tokens[first + k * per]),
                fmt::format("sample {} is incomplete: the file ends after {} of its {} numbers "
                            "(theta_i phi_i theta_o phi_o and {} values); expected {} whole "
                            "samples or {}",
                            k + 1, rest % per, per, nw, k, k + 1));
  }
  const std::size_t ns = rest / per;
  d.samples.reserve(ns);
  d.values.reserve(ns * nw);
  for (std::size_t s = 0; s < ns; ++s) {
    double a[4];
    for (int j = 0; j < 4; ++j) {
      const Token& t = tokens[first + s * per + j];
      a[j] = number(t, fmt::format("{} of sample {} (radians)", kAngleNames[j], s + 1));
      if ((j == 0 || j == 2) && (a[j] < -1e-6 || a[j] > kPi / 2 + 1e-6))
        throw Error(loc(t), fmt::format("{} of sample {} is {}; expected radians in [0, pi/2] "
                                        "(a direction above the surface)",
                                        kAngleNames[j], s + 1, t.text));
    }
    d.samples.push_back(
        {std::clamp(a[0], 0.0, kPi / 2), a[1], std::clamp(a[2], 0.0, kPi / 2), a[3]});
    for (std::size_t w = 0; w < nw; ++w) {
      const Token& t = tokens[first + s * per + 4 + w];
      const double v = number(
          t, fmt::format("the BRDF value of sample {} at {} nm", s + 1, d.wavelengths_nm[w]));
      if (v > kMaxBRDFValue)
        throw Error(loc(t), fmt::format("the BRDF value of sample {} is {}; expected at most {:g} "
                                        "(1/sr)",
                                        s + 1, t.text, kMaxBRDFValue));
      d.values.push_back(std::max(0.0, v));
    }
  }
  return d;
}

IrregularBRDFData readIrregularBRDF(const std::string& path) {
  // Only regular files (no FIFO or device), at most 1 GiB.
  return parseIrregularBRDF(readRegularFile(path, "measured BRDF file"), path);
}

// ---------------------------------------------------------------------------------------------
// Interpolation

namespace {

// Relative azimuth folded into [0, pi] (isotropy and mirror symmetry).
double foldPhi(double dphi) {
  dphi = std::fmod(std::abs(dphi), 2 * kPi);
  return dphi > kPi ? 2 * kPi - dphi : dphi;
}

// acos to about 7e-5 rad (Abramowitz & Stegun 1964, 4.4.45: acos x = sqrt(1 - x) (a0 + a1 x +
// a2 x^2 + a3 x^3) on [0, 1], |error| <= 6.7e-5), extended by acos(-x) = pi - acos(x); far below
// the table spacing and several times faster than std::acos.
inline double fastAcos(double x) {
  const double ax = std::min(1.0, std::abs(x));
  const double r =
      std::sqrt(1 - ax) * (1.5707288 + ax * (-0.2121144 + ax * (0.0742610 - 0.0187293 * ax)));
  return x < 0 ? kPi - r : r;
}

// Continuous grid coordinate of x in [0, range] over n nodes: lower node and fraction.
inline void gridCoord(double x, double range, int n, int& i, double& f) {
  const double u = std::clamp(x / range, 0.0, 1.0) * (n - 1);
  i = std::min(int(u), n - 2);
  f = u - i;
}

}  // namespace

MeasuredBRDF::MeasuredBRDF(IrregularBRDFData data, Options options)
    : data_(std::move(data)), options_(options) {
  const std::size_t nw = data_.numWavelengths();
  if (nw == 0 || data_.samples.empty() || data_.values.size() != nw * data_.samples.size())
    throw Error("MeasuredBRDF: no samples, or values that do not match samples x wavelengths");
  options_.n_theta = std::max(2, options_.n_theta);
  options_.n_phi = std::max(2, options_.n_phi);
  options_.neighbours = std::max(1, options_.neighbours);
  configs_.reserve(data_.samples.size());
  for (const auto& s : data_.samples) {
    const double dphi = foldPhi(s.phi_o - s.phi_i);
    configs_.push_back({std::sin(s.theta_i), std::cos(s.theta_i), std::sin(s.theta_o),
                        std::cos(s.theta_o), std::cos(dphi), std::sin(dphi)});
  }

  // The table: the interpolant at every node; it is symmetric in (theta_i, theta_o), so each
  // node pair is computed once.
  const int nt = options_.n_theta, np = options_.n_phi;
  table_.assign(std::size_t(nt) * nt * np * nw, 0.0f);
  std::vector<double> v(nw);
  for (int a = 0; a < nt; ++a)
    for (int b = a; b < nt; ++b)
      for (int p = 0; p < np; ++p) {
        const double ti = kPi / 2 * a / (nt - 1), to = kPi / 2 * b / (nt - 1);
        interpolateInto(ti, to, kPi * p / (np - 1), v.data());
        float* ab = &table_[((std::size_t(a) * nt + b) * np + p) * nw];
        float* ba = &table_[((std::size_t(b) * nt + a) * np + p) * nw];
        for (std::size_t w = 0; w < nw; ++w) ab[w] = ba[w] = float(v[w]);
      }
  buildLobes();
}

void MeasuredBRDF::buildLobes() {
  const int nt = options_.n_theta, np = options_.n_phi;
  const std::size_t nw = data_.numWavelengths();
  // The table averaged over wavelengths.
  std::vector<double> avg(std::size_t(nt) * nt * np);
  for (std::size_t n = 0; n < avg.size(); ++n) {
    double sum = 0;
    for (std::size_t w = 0; w < nw; ++w) sum += table_[n * nw + w];
    avg[n] = sum / double(nw);
  }
  auto lookupAvg = [&](double theta_i, int b, double dphi) {
    int a, p;
    double fa, fp;
    gridCoord(theta_i, kPi / 2, nt, a, fa);
    gridCoord(dphi, kPi, np, p, fp);
    double v = 0;
    for (int c = 0; c < 4; ++c) {
      const int da = c & 1, dp = c >> 1;
      v += (da ? fa : 1 - fa) * (dp ? fp : 1 - fp) *
           avg[(std::size_t(a + da) * nt + b) * np + (p + dp)];
    }
    return v;
  };
  std::vector<double> g(std::size_t(kLobeCos) * kLobePhi);
  lobes_.clear();
  lobes_.reserve(nt);
  for (int b = 0; b < nt; ++b) {
    for (int ip = 0; ip < kLobePhi; ++ip)
      for (int ix = 0; ix < kLobeCos; ++ix) {
        const double x = (ix + 0.5) / kLobeCos, dphi = kPi * (ip + 0.5) / kLobePhi;
        g[std::size_t(ip) * kLobeCos + ix] = lookupAvg(std::acos(x), b, dphi) * x;
      }
    lobes_.emplace_back(g, kLobeCos, kLobePhi, Vec2(0, 0), Vec2(1, kPi));
  }
}

std::shared_ptr<const MeasuredBRDF> MeasuredBRDF::loadCached(const std::string& path) {
  return loadOncePerPath<MeasuredBRDF>(path, readIrregularBRDF);
}

std::vector<double> MeasuredBRDF::interpolate(double theta_i, double theta_o, double dphi) const {
  std::vector<double> v(data_.numWavelengths());
  interpolateInto(theta_i, theta_o, dphi, v.data());
  return v;
}

namespace {

// Where wo falls between the table's theta_o nodes (wo.z >= 0).
inline void thetaNode(const Vec3& wo, int nt, int& b, double& fb) {
  gridCoord(fastAcos(std::min(1.0, wo.z)), kPi / 2, nt, b, fb);
}

// |dphi| in [0, pi] between the azimuths of wo and wi (0 when either is along the normal).
inline double relativeAzimuth(const Vec3& wo, const Vec3& wi) {
  const double den = std::sqrt((wo.x * wo.x + wo.y * wo.y) * (wi.x * wi.x + wi.y * wi.y));
  return den > 0 ? fastAcos((wo.x * wi.x + wo.y * wi.y) / den) : 0.0;
}

}  // namespace

Vec3 MeasuredBRDF::sampleWi(const Vec3& wo, double uc, Vec2 u) const {
  if (uc < kCosineFraction) return sampleCosineHemisphere(u);
  uc = std::min((uc - kCosineFraction) / (1 - kCosineFraction), 1 - 1e-16);
  int b;
  double fb;
  thetaNode(wo, options_.n_theta, b, fb);
  int node = b;
  if (uc < 1 - fb) {
    uc /= 1 - fb;
  } else {
    node = b + 1;
    uc = (uc - (1 - fb)) / fb;
  }
  const double sign = uc < 0.5 ? 1.0 : -1.0;
  const auto s = lobes_[node].sample(u);
  const double cos_i = std::clamp(s.p.x, 0.0, 1.0), sin_i = std::sqrt(1 - cos_i * cos_i);
  const double phi = std::atan2(wo.y, wo.x) + sign * s.p.y;
  return {sin_i * std::cos(phi), sin_i * std::sin(phi), cos_i};
}

double MeasuredBRDF::pdfWi(const Vec3& wo, const Vec3& wi) const {
  int b;
  double fb;
  thetaNode(wo, options_.n_theta, b, fb);
  const Vec2 p(std::clamp(wi.z, 0.0, 1.0), relativeAzimuth(wo, wi));
  double lobe = (1 - fb) * lobes_[b].pdf(p);
  if (fb > 0) lobe += fb * lobes_[b + 1].pdf(p);
  // The lobe density is per unit (cos theta_i, |dphi|); dphi's sign halves it, and
  // d omega = d cos theta d phi.
  return kCosineFraction * cosineHemispherePdf(wi.z) + (1 - kCosineFraction) * lobe / 2;
}

void MeasuredBRDF::interpolateInto(double theta_i, double theta_o, double dphi, double* out) const {
  const std::size_t nw = data_.numWavelengths(), n = configs_.size();
  dphi = foldPhi(dphi);
  const double si = std::sin(theta_i), ci = std::cos(theta_i), so = std::sin(theta_o),
               co = std::cos(theta_o), cp = std::cos(dphi), sp = std::sin(dphi);

  // The k + 1 nearest samples, by squared configuration distance, kept sorted.
  const std::size_t k = std::min<std::size_t>(options_.neighbours, n);
  const std::size_t keep = std::min(k + 1, n);
  constexpr std::size_t kMaxKeep = 64;
  double best_d2[kMaxKeep] = {};
  std::size_t best_i[kMaxKeep] = {};
  const std::size_t cap = std::min(keep, kMaxKeep);
  std::size_t found = 0;
  for (std::size_t j = 0; j < n; ++j) {
    const Config& c = configs_[j];
    // Configuration distance (see the header): |wi - R wi'|^2 + |wo - R wo'|^2 minimised over
    // the rotation R about the normal is 4 - 2 (zi zi' + zo zo' + |ci conj(ci') + co conj(co')|)
    // with c = x + i y; with the swapped sample, primes of i and o exchange. Mirroring never
    // helps when both relative azimuths are folded into [0, pi].
    const double cdiff = cp * c.cp + sp * c.sp;
    const double p = 2 * si * so * c.si * c.so * cdiff;
    const double a2 = si * c.si * si * c.si + so * c.so * so * c.so + p;
    const double b2 = si * c.so * si * c.so + so * c.si * so * c.si + p;
    const double d2a = 4 - 2 * (ci * c.ci + co * c.co + std::sqrt(std::max(0.0, a2)));
    const double d2b = 4 - 2 * (ci * c.co + co * c.ci + std::sqrt(std::max(0.0, b2)));
    const double d2 = std::max(0.0, std::min(d2a, d2b));
    if (found == cap && d2 >= best_d2[cap - 1]) continue;
    std::size_t pos = found < cap ? found++ : cap - 1;
    while (pos > 0 && best_d2[pos - 1] > d2) {
      best_d2[pos] = best_d2[pos - 1];
      best_i[pos] = best_i[pos - 1];
      --pos;
    }
    best_d2[pos] = d2;
    best_i[pos] = j;
  }
  const std::size_t used = std::min(k, found);

  std::fill(out, out + nw, 0.0);
  // A measured configuration (up to rounding): its value, averaged with exact duplicates.
  constexpr double kSame2 = 1e-20;
  if (best_d2[0] < kSame2) {
    std::size_t m = 0;
    for (; m < found && best_d2[m] < kSame2; ++m) {
      const auto row = data_.sampleValues(best_i[m]);
      for (std::size_t w = 0; w < nw; ++w) out[w] += row[w];
    }
    for (std::size_t w = 0; w < nw; ++w) out[w] /= double(m);
    return;
  }
  // Franke-Little weights ((R - d) / (R d))^2 with R the distance of the (k+1)-th neighbour; with
  // k or fewer samples in all, R lies beyond the farthest so every sample counts.
  const double r = found > used ? std::sqrt(best_d2[used]) : 1.5 * std::sqrt(best_d2[found - 1]);
  double wsum = 0;
  for (std::size_t m = 0; m < used; ++m) {
    const double d = std::sqrt(best_d2[m]);
    const double w = std::max(0.0, r - d) / (r * d);
    const double w2 = w * w;
    if (w2 == 0) continue;
    wsum += w2;
    const auto row = data_.sampleValues(best_i[m]);
    for (std::size_t w = 0; w < nw; ++w) out[w] += w2 * row[w];
  }
  if (wsum > 0) {
    for (std::size_t w = 0; w < nw; ++w) out[w] /= wsum;
    return;
  }
  // All k at the same distance as the (k+1)-th (a tie): their plain mean.
  for (std::size_t m = 0; m < used; ++m) {
    const auto row = data_.sampleValues(best_i[m]);
    for (std::size_t w = 0; w < nw; ++w) out[w] += row[w] / double(used);
  }
}

MeasuredBRDF::WavelengthWeight MeasuredBRDF::wavelengthWeight(double lambda_nm) const {
  const auto& wl = data_.wavelengths_nm;
  if (lambda_nm <= wl.front()) return {0, 0, 0};
  if (lambda_nm >= wl.back()) return {wl.size() - 1, wl.size() - 1, 0};
  const std::size_t i1 =
      std::size_t(std::upper_bound(wl.begin(), wl.end(), lambda_nm) - wl.begin());
  const std::size_t i0 = i1 - 1;
  return {i0, i1, (lambda_nm - wl[i0]) / (wl[i1] - wl[i0])};
}

double MeasuredBRDF::lookup(double theta_i, double theta_o, double dphi, std::size_t w) const {
  const int nt = options_.n_theta, np = options_.n_phi;
  const std::size_t nw = data_.numWavelengths();
  int a, b, p;
  double fa, fb, fp;
  gridCoord(theta_i, kPi / 2, nt, a, fa);
  gridCoord(theta_o, kPi / 2, nt, b, fb);
  gridCoord(foldPhi(dphi), kPi, np, p, fp);
  double v = 0;
  for (int c = 0; c < 8; ++c) {
    const int da = c & 1, db = (c >> 1) & 1, dp = c >> 2;
    const double wt = (da ? fa : 1 - fa) * (db ? fb : 1 - fb) * (dp ? fp : 1 - fp);
    v += wt * table_[((std::size_t(a + da) * nt + (b + db)) * np + (p + dp)) * nw + w];
  }
  return v;
}

SampledSpectrum MeasuredBRDF::eval(
    const Vec3& wo, const Vec3& wi,
    const std::array<WavelengthWeight, kSpectrumSamples>& lambda) const {
  const int nt = options_.n_theta, np = options_.n_phi;
  const std::size_t nw = data_.numWavelengths();
  const double theta_o = fastAcos(std::abs(wo.z));
  const double theta_i = fastAcos(std::abs(wi.z));
  const double ho2 = wo.x * wo.x + wo.y * wo.y, hi2 = wi.x * wi.x + wi.y * wi.y;
  const double den = std::sqrt(ho2 * hi2);
  const double dphi = den > 0 ? fastAcos((wo.x * wi.x + wo.y * wi.y) / den) : 0.0;
  int a, b, p;
  double fa, fb, fp;
  gridCoord(theta_i, kPi / 2, nt, a, fa);
  gridCoord(theta_o, kPi / 2, nt, b, fb);
  gridCoord(dphi, kPi, np, p, fp);
  SampledSpectrum v(0.0);
  for (int c = 0; c < 8; ++c) {
    const int da = c & 1, db = (c >> 1) & 1, dp = c >> 2;
    const double wt = (da ? fa : 1 - fa) * (db ? fb : 1 - fb) * (dp ? fp : 1 - fp);
    if (wt == 0) continue;
    const float* row = &table_[((std::size_t(a + da) * nt + (b + db)) * np + (p + dp)) * nw];
    for (int l = 0; l < kSpectrumSamples; ++l) {
      const auto& ww = lambda[l];
      v[l] += wt * ((1 - ww.t) * row[ww.i0] + ww.t * row[ww.i1]);
    }
  }
  return v;
}

// ---------------------------------------------------------------------------------------------
// BxDF

MeasuredBxDF::MeasuredBxDF(std::shared_ptr<const MeasuredBRDF> brdf,
                           const SampledWavelengths& lambda)
    : brdf_(std::move(brdf)) {
  for (int l = 0; l < kSpectrumSamples; ++l) lambda_[l] = brdf_->wavelengthWeight(lambda.lambda(l));
}

BxDFFlags MeasuredBxDF::flags() const {
  return BxDFFlags::Reflection | BxDFFlags::Glossy;
}

SampledSpectrum MeasuredBxDF::f(const Vec3& wo, const Vec3& wi, TransportMode) const {
  if (!sameHemisphere(wo, wi)) return {};
  return brdf_->eval(wo, wi, lambda_);
}

std::optional<BSDFSample> MeasuredBxDF::sample_f(const Vec3& wo, double uc, Vec2 u, TransportMode,
                                                 ReflTrans allowed) const {
  if (!allows(allowed, ReflTrans::Reflection) || wo.z == 0) return std::nullopt;
  // Two-sided: work above the surface and mirror back.
  const double side = wo.z < 0 ? -1.0 : 1.0;
  const Vec3 wo_up(wo.x, wo.y, side * wo.z);
  const Vec3 wi_up = brdf_->sampleWi(wo_up, uc, u);
  const double pdf = brdf_->pdfWi(wo_up, wi_up);
  if (pdf == 0 || wi_up.z <= 0) return std::nullopt;
  return BSDFSample{brdf_->eval(wo_up, wi_up, lambda_), Vec3(wi_up.x, wi_up.y, side * wi_up.z), pdf,
                    flags()};
}

double MeasuredBxDF::pdf(const Vec3& wo, const Vec3& wi, TransportMode, ReflTrans allowed) const {
  if (!allows(allowed, ReflTrans::Reflection) || !sameHemisphere(wo, wi)) return 0;
  const double side = wo.z < 0 ? -1.0 : 1.0;
  return brdf_->pdfWi(Vec3(wo.x, wo.y, side * wo.z), Vec3(wi.x, wi.y, side * wi.z));
}

}  // namespace lensim::render
