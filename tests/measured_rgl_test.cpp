// pbrt-v4's "measured" material with RGL tensor files (.bsdf). Real RGL files are multi-MB
// downloads, so the test writes its own: a generator below (independent of lensim's reader and
// warp) tabulates an ANALYTIC BRDF on the format's parameterisation (Dupuy & Jakob 2018; pbrt-v4
// book section 9.8): ndf = D, sigma = projected area, vndf = the visible-normal density over
// (u_m, v_m), and the stored values M = f cos theta_i 4 sigma(wo) / D(wm) at the directions the
// inverse of the vndf warp reaches from each grid point of the unit square. The inversion here
// is numeric (cumulative integrals of the bilinear density and bisection), not lensim's closed
// form. Then evaluation is compared with the analytic BRDF, energy with quadrature of the
// analytic BRDF, sampling with evaluation (chi-square), and malformed files must give located
// errors and exit status 1 from `lensim check` and `lensim render`.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "chi2.h"
#include "cli_run.h"
#include "lensim/render/materials/measured_rgl.h"
#include "lensim/sampling/piecewise_linear_2d.h"
#include "lensim/sampling/sampling.h"
#include "lensim/util/error.h"
#include "lensim/util/limits.h"

using namespace lensim;
using namespace lensim::render;
using namespace lensim::sampling;

namespace {

constexpr double kPI = 3.14159265358979323846;

// ---- writing tensor files --------------------------------------------------------------------

struct Field {
  std::string name;
  uint8_t dtype;  // 1 uint8, 10 float32
  std::vector<uint64_t> shape;
  std::string data;
};

void putLE(std::string& s, uint64_t v, int n) {
  for (int i = 0; i < n; ++i) s.push_back(char((v >> (8 * i)) & 0xff));
}

std::string floatData(const std::vector<float>& v) {
  std::string s(v.size() * 4, '\0');
  for (std::size_t i = 0; i < v.size(); ++i) {
    uint32_t bits;
    std::memcpy(&bits, &v[i], 4);
    for (int k = 0; k < 4; ++k) s[4 * i + k] = char((bits >> (8 * k)) & 0xff);
  }
  return s;
}

// The layout of pbrt-v4's Tensor reader: "tensor_file\0", version 1.0, uint32 field count, per
// field uint16 name length, name, uint16 ndim, uint8 dtype, uint64 offset, ndim x uint64 shape;
// the data after the headers.
std::string tensorFile(const std::vector<Field>& fields) {
  std::string head("tensor_file\0", 12);
  head.push_back(1);
  head.push_back(0);
  putLE(head, fields.size(), 4);
  std::size_t header_size = head.size();
  for (const Field& f : fields) header_size += 2 + f.name.size() + 2 + 1 + 8 + 8 * f.shape.size();
  std::string data;
  for (const Field& f : fields) {
    putLE(head, f.name.size(), 2);
    head += f.name;
    putLE(head, f.shape.size(), 2);
    head.push_back(char(f.dtype));
    putLE(head, header_size + data.size(), 8);
    for (uint64_t e : f.shape) putLE(head, e, 8);
    data += f.data;
  }
  return head + data;
}

// ---- the analytic BRDFs ----------------------------------------------------------------------

struct GGX {
  double alpha;
  double D(const Vec3& m) const {
    if (m.z <= 0) return 0;
    const double c2 = m.z * m.z, t2 = (1 - c2) / c2;
    const double e = 1 + t2 / (alpha * alpha);
    return 1 / (kPI * alpha * alpha * c2 * c2 * e * e);
  }
  double Lambda(const Vec3& w) const {
    const double c2 = w.z * w.z, t2 = std::max(0.0, 1 - c2) / c2;
    return 0.5 * (std::sqrt(1 + alpha * alpha * t2) - 1);
  }
  // sigma(w) = int D(m) max(0, w.m) dm = cos theta (1 + Lambda(w)) for Smith microsurfaces.
  double sigma(const Vec3& w) const { return w.z * (1 + Lambda(w)); }
};

Vec3 dir(double theta, double phi) {
  return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}
Vec3 norm3(const Vec3& v) {
  return v / std::sqrt(dot(v, v));
}

// An analytic BRDF: f(wo, wi, lambda_nm).
using Brdf = std::function<double(const Vec3&, const Vec3&, double)>;

Brdf lambertian(double albedo) {
  return [albedo](const Vec3& wo, const Vec3& wi, double) {
    return wo.z > 0 && wi.z > 0 ? albedo / kPI : 0.0;
  };
}

// Schlick's reflectance with F0 linear in wavelength (so that linear interpolation between the
// file's wavelengths is exact), or F = 1 for `white`.
double conductorF0(double lambda) {
  return 0.95 - 0.4 * (lambda - 400) / 300;
}

Brdf ggxConductor(double alpha, bool white) {
  return [alpha, white](const Vec3& wo, const Vec3& wi, double lambda) {
    if (wo.z <= 0 || wi.z <= 0) return 0.0;
    const GGX g{alpha};
    const Vec3 m = norm3(wo + wi);
    const double f0 = white ? 1.0 : conductorF0(lambda);
    const double F = f0 + (1 - f0) * std::pow(1 - dot(wi, m), 5);
    const double G2 = 1 / (1 + g.Lambda(wo) + g.Lambda(wi));  // height-correlated Smith
    return F * g.D(m) * G2 / (4 * wo.z * wi.z);
  };
}

// ---- the generator ---------------------------------------------------------------------------

// Bilinear interpolation of a [ny][nx] table on [0,1]^2.
double bilinear(const std::vector<double>& t, int nx, int ny, double x, double y) {
  const double fx = std::clamp(x, 0.0, 1.0) * (nx - 1), fy = std::clamp(y, 0.0, 1.0) * (ny - 1);
  const int i = std::min(int(fx), nx - 2), j = std::min(int(fy), ny - 2);
  const double s = fx - i, u = fy - j;
  auto at = [&](int a, int b) { return t[std::size_t(b) * nx + a]; };
  return (1 - u) * ((1 - s) * at(i, j) + s * at(i + 1, j)) +
         u * ((1 - s) * at(i, j + 1) + s * at(i + 1, j + 1));
}

// Integral over [0, x] of a function linear between the nodes v[k] at k / (n - 1).
double integratePiecewiseLinear(const std::vector<double>& v, double x) {
  const int n = int(v.size());
  const double h = 1.0 / (n - 1);
  double sum = 0;
  for (int k = 0; k + 1 < n; ++k) {
    const double a = k * h, b = a + h;
    if (x <= a) break;
    const double e = std::min(x, b), t = (e - a) / h;
    // integral of v[k] + (v[k+1] - v[k]) s / h over [a, e]
    sum += h * (v[k] * t + 0.5 * (v[k + 1] - v[k]) * t * t);
  }
  return sum;
}

// The point of [0,1]^2 that the marginal-then-conditional inversion of the bilinear density
// `t` maps u to, found by bisection on the cumulative integrals.
Vec2 warpByBisection(const std::vector<double>& t, int nx, int ny, Vec2 u) {
  std::vector<double> rows(static_cast<std::size_t>(ny));
  for (int j = 0; j < ny; ++j) {
    std::vector<double> row(t.begin() + std::ptrdiff_t(j) * nx,
                            t.begin() + std::ptrdiff_t(j + 1) * nx);
    rows[std::size_t(j)] = integratePiecewiseLinear(row, 1.0);
  }
  const double total = integratePiecewiseLinear(rows, 1.0);
  auto bisect = [](const std::function<double(double)>& cdf, double target) {
    double lo = 0, hi = 1;
    for (int it = 0; it < 60; ++it) {
      const double mid = 0.5 * (lo + hi);
      (cdf(mid) < target ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
  };
  const double y =
      bisect([&](double y_) { return integratePiecewiseLinear(rows, y_); }, u.y * total);
  std::vector<double> row(static_cast<std::size_t>(nx));
  for (int i = 0; i < nx; ++i) row[std::size_t(i)] = bilinear(t, nx, ny, double(i) / (nx - 1), y);
  const double row_total = integratePiecewiseLinear(row, 1.0);
  const double x =
      bisect([&](double x_) { return integratePiecewiseLinear(row, x_); }, u.x * row_total);
  return {x, y};
}

struct GenOptions {
  double param_alpha = 0.5;  // the GGX of the parameterisation (ndf, sigma, vndf)
  int n_theta_i = 9;         // incident elevations 0, 10, .. 80 degrees
  int n_phi_i = 1;           // 1: isotropic layout; more: azimuths -pi .. pi (anisotropic)
  int n_ndf = 64;            // ndf and sigma nodes per axis
  int n_vndf = 48;           // vndf nodes per axis
  int n_values = 48;         // luminance and spectra nodes per axis
  std::vector<float> wavelengths = {400, 500, 600, 700};
  bool rgb = false;  // store "rgb" (3 channels of the value at 550 nm) instead
};

// A .bsdf file for an isotropic analytic BRDF.
std::string generate(const Brdf& brdf, const GenOptions& o) {
  const GGX g{o.param_alpha};
  auto u2theta = [](double u) { return u * u * kPI / 2; };
  auto u2phi = [](double v) { return (2 * v - 1) * kPI; };
  std::vector<float> theta_i(std::size_t(o.n_theta_i));
  for (int k = 0; k < o.n_theta_i; ++k)
    theta_i[std::size_t(k)] = float(k * (80.0 / (o.n_theta_i - 1)) * kPI / 180);
  std::vector<float> phi_i = {0};
  if (o.n_phi_i > 1) {
    phi_i.clear();
    for (int p = 0; p < o.n_phi_i; ++p)
      phi_i.push_back(float(-kPI + 2 * kPI * p / (o.n_phi_i - 1)));
  }

  // ndf and sigma over (u, v) of a direction (v = absolute azimuth: isotropic, so constant).
  std::vector<float> ndf, sigma;
  for (int j = 0; j < o.n_ndf; ++j)
    for (int i = 0; i < o.n_ndf; ++i) {
      const Vec3 w = dir(u2theta(double(i) / (o.n_ndf - 1)), u2phi(double(j) / (o.n_ndf - 1)));
      ndf.push_back(float(g.D(w)));
      sigma.push_back(float(g.sigma(w) > 0 ? g.sigma(w) : g.sigma(dir(kPI / 2 - 1e-4, 0))));
    }

  const int nv = o.n_vndf, nm = o.n_values;
  const std::size_t nwl = o.rgb ? 3 : o.wavelengths.size();
  std::vector<float> vndf, lum, spectra;
  // The (u, v) of the vndf and of the values: v is the azimuth of wm relative to wo's in the
  // isotropic layout (wo at azimuth 0 there), absolute in the anisotropic one.
  for (float phi_o : phi_i) {
    for (int k = 0; k < o.n_theta_i; ++k) {
      const Vec3 wo = dir(theta_i[std::size_t(k)], phi_o);
      // The visible-normal density over (u_m, v_m) (v_m: azimuth relative to wo's), with the
      // Jacobian of the parameterisation: dw_m = 2 pi^2 u sin(theta_m) du dv.
      std::vector<double> dens(std::size_t(nv) * nv);
      for (int j = 0; j < nv; ++j)
        for (int i = 0; i < nv; ++i) {
          const double u = double(i) / (nv - 1), th = u2theta(u);
          const Vec3 m = dir(th, u2phi(double(j) / (nv - 1)) + (o.n_phi_i > 1 ? 0.0 : phi_o));
          dens[std::size_t(j) * nv + i] =
              g.D(m) * std::max(0.0, dot(wo, m)) / g.sigma(wo) * 2 * kPI * kPI * u * std::sin(th);
        }
      for (double d : dens) vndf.push_back(float(d));
      // The values M at the directions the vndf warp reaches from each grid point.
      std::vector<std::vector<float>> m_wl(nwl, std::vector<float>(std::size_t(nm) * nm));
      std::vector<float> m_lum(std::size_t(nm) * nm);
      for (int j = 0; j < nm; ++j)
        for (int i = 0; i < nm; ++i) {
          const Vec2 um =
              warpByBisection(dens, nv, nv, {double(i) / (nm - 1), double(j) / (nm - 1)});
          const Vec3 m = dir(u2theta(um.x), u2phi(um.y) + (o.n_phi_i > 1 ? 0.0 : phi_o));
          const Vec3 wi = m * (2 * dot(wo, m)) - wo;
          double sum = 0;
          for (std::size_t w = 0; w < nwl; ++w) {
            const double lambda = o.rgb ? 550.0 : o.wavelengths[w];
            const double M = wi.z > 0 && g.D(m) > 0
                                 ? brdf(wo, wi, lambda) * wi.z * 4 * g.sigma(wo) / g.D(m)
                                 : 0.0;
            m_wl[w][std::size_t(j) * nm + i] = float(M);
            sum += M;
          }
          m_lum[std::size_t(j) * nm + i] = float(sum / double(nwl));
        }
      for (float v : m_lum) lum.push_back(v);
      for (const auto& v : m_wl) spectra.insert(spectra.end(), v.begin(), v.end());
    }
  }
  const std::string desc = "analytic test BRDF";
  std::vector<Field> fields = {
      {"description", 1, {desc.size()}, desc},
      {"jacobian", 1, {1}, std::string(1, '\1')},
      {"theta_i", 10, {theta_i.size()}, floatData(theta_i)},
      {"phi_i", 10, {phi_i.size()}, floatData(phi_i)},
      {"ndf", 10, {uint64_t(o.n_ndf), uint64_t(o.n_ndf)}, floatData(ndf)},
      {"sigma", 10, {uint64_t(o.n_ndf), uint64_t(o.n_ndf)}, floatData(sigma)},
      {"vndf", 10, {phi_i.size(), theta_i.size(), uint64_t(nv), uint64_t(nv)}, floatData(vndf)},
      {"luminance", 10, {phi_i.size(), theta_i.size(), uint64_t(nm), uint64_t(nm)}, floatData(lum)},
  };
  if (o.rgb) {
    fields.push_back({"rgb",
                      10,
                      {phi_i.size(), theta_i.size(), 3, uint64_t(nm), uint64_t(nm)},
                      floatData(spectra)});
  } else {
    fields.push_back({"wavelengths", 10, {o.wavelengths.size()}, floatData(o.wavelengths)});
    fields.push_back(
        {"spectra",
         10,
         {phi_i.size(), theta_i.size(), o.wavelengths.size(), uint64_t(nm), uint64_t(nm)},
         floatData(spectra)});
  }
  return tensorFile(fields);
}

// The generated files, built once per test binary.
const std::string& lambertianFile() {
  static const std::string f = [] {
    GenOptions o;
    o.param_alpha = 0.7;
    return generate(lambertian(0.5), o);
  }();
  return f;
}
const std::string& conductorFile() {
  static const std::string f = [] {
    GenOptions o;
    o.param_alpha = 0.3;
    return generate(ggxConductor(0.3, false), o);
  }();
  return f;
}
const std::string& whiteConductorFile() {
  static const std::string f = [] {
    GenOptions o;
    o.param_alpha = 0.3;
    return generate(ggxConductor(0.3, true), o);
  }();
  return f;
}

std::shared_ptr<const RGLMeasuredBRDF> parsed(const std::string& bytes) {
  return std::make_shared<const RGLMeasuredBRDF>(RGLMeasuredBRDF::parse(bytes, "test.bsdf"));
}

// Wavelengths whose first one is lambda0 (the others follow with the hero spacing).
SampledWavelengths heroAt(double lambda0_nm) {
  return SampledWavelengths::sampleUniform((lambda0_nm - kLambdaMin_nm) /
                                           (kLambdaMax_nm - kLambdaMin_nm));
}

// Relative errors of f against the analytic BRDF at the first wavelength over a grid of
// direction pairs (theta up to theta_max), returned sorted.
std::vector<double> relativeErrors(const RGLMeasuredBRDF& b, const Brdf& truth, double lambda,
                                   double theta_max, double min_f) {
  std::vector<double> errs;
  const SampledWavelengths wl = heroAt(lambda);
  for (int a = 0; a < 8; ++a)
    for (int c = 0; c < 8; ++c)
      for (int p = 0; p < 9; ++p) {
        const Vec3 wo = dir(theta_max * (a + 0.5) / 8, 0.3 + 0.7 * a);
        const Vec3 wi = dir(theta_max * (c + 0.5) / 8, 0.3 + 0.7 * a + kPI * (p + 0.5) / 9 * 2);
        const double expect = truth(wo, wi, wl.lambda(0));
        if (expect < min_f) continue;
        const double got = b.f(wo, wi, wl)[0];
        errs.push_back(std::abs(got - expect) / expect);
      }
  std::sort(errs.begin(), errs.end());
  return errs;
}

double quantile(const std::vector<double>& v, double q) {
  return v.empty() ? 0 : v[std::min(v.size() - 1, std::size_t(q * double(v.size())))];
}

// Directional albedo int f cos dwi of an analytic BRDF by midpoint quadrature in (cos, phi).
double analyticAlbedo(const Brdf& f, const Vec3& wo, double lambda) {
  const int n = 400;
  double sum = 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double mu = (i + 0.5) / n, phi = 2 * kPI * (j + 0.5) / n;
      const Vec3 wi = dir(std::acos(mu), phi);
      sum += f(wo, wi, lambda) * mu;
    }
  return sum * (1.0 / n) * (2 * kPI / n);
}

// Monte Carlo albedo through sample_f (f cos / pdf), first wavelength.
double sampledAlbedo(const BxDF& b, const Vec3& wo, int n) {
  double sum = 0;
  for (int k = 0; k < n; ++k) {
    // A (0,2) sequence in base 2 (Sobol' first two dimensions) for low noise.
    uint32_t a = uint32_t(k), x = 0, y = 0, v = 1u << 31, w = 1u << 31;
    for (; a; a >>= 1, v >>= 1, w ^= w >> 1)
      if (a & 1) x ^= v, y ^= w;
    const Vec2 u{(x + 0.5) / 4294967296.0, (y + 0.5) / 4294967296.0};
    if (auto s = b.sample_f(wo, 0.5, u, TransportMode::Radiance))
      sum += s->f[0] * std::abs(s->wi.z) / s->pdf;
  }
  return sum / n;
}

}  // namespace

// ---- the warp --------------------------------------------------------------------------------

TEST(PiecewiseLinear2D, SampleAndInvertAreInversesAndTheDensityIsNormalised) {
  // A lopsided bilinear table with two parameter slices.
  const int nx = 5, ny = 4;
  std::vector<float> data;
  for (int s = 0; s < 2; ++s)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) data.push_back(float(0.1 + (s ? i * i : j + 2 * i) + 0.5 * j));
  const PiecewiseLinear2D w(data, nx, ny, {{0.f, 1.f}}, PiecewiseLinear2D::Mode::Density);
  for (double p : {0.0, 0.3, 1.0}) {
    const double params[1] = {p};
    double integral = 0;
    const int n = 200;
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) integral += w.eval({(i + 0.5) / n, (j + 0.5) / n}, params);
    EXPECT_NEAR(integral / (n * n), 1.0, 1e-4) << p;
    for (double ux : {0.05, 0.37, 0.81})
      for (double uy : {0.11, 0.5, 0.93}) {
        const auto s = w.sample({ux, uy}, params);
        const auto inv = w.invert(s.p, params);
        EXPECT_NEAR(inv.p.x, ux, 1e-9);
        EXPECT_NEAR(inv.p.y, uy, 1e-9);
        EXPECT_NEAR(s.pdf, w.eval(s.p, params), 1e-9 * s.pdf);
        // The independent bisection inversion of the first slice agrees.
        if (p == 0.0) {
          std::vector<double> t(data.begin(), data.begin() + nx * ny);
          const Vec2 ref = warpByBisection(t, nx, ny, {ux, uy});
          EXPECT_NEAR(s.p.x, ref.x, 1e-7);
          EXPECT_NEAR(s.p.y, ref.y, 1e-7);
        }
      }
  }
}

// ---- evaluation against the analytic BRDFs ---------------------------------------------------

TEST(RGLMeasured, LambertianMatchesItsAlbedoOverThePi) {
  const auto b = parsed(lambertianFile());
  EXPECT_TRUE(b->isotropic());
  EXPECT_FALSE(b->rgb());
  EXPECT_EQ(b->description(), "analytic test BRDF");
  const auto errs = relativeErrors(*b, lambertian(0.5), 550, 1.3, 0);
  ASSERT_GT(errs.size(), 400u);
  RecordProperty("median_rel_err", fmt::format("{:.2e}", quantile(errs, 0.5)));
  RecordProperty("p95_rel_err", fmt::format("{:.2e}", quantile(errs, 0.95)));
  EXPECT_LT(quantile(errs, 0.5), 0.01);
  EXPECT_LT(quantile(errs, 0.95), 0.05);
  EXPECT_LT(errs.back(), 0.25);
}

TEST(RGLMeasured, GGXConductorMatchesTheAnalyticBRDFAtEachWavelength) {
  const auto b = parsed(conductorFile());
  for (double lambda : {420.0, 550.0, 690.0}) {
    // Where f is not tiny (1e-3 of the peak): the interpolation error is relative to f.
    const auto errs = relativeErrors(*b, ggxConductor(0.3, false), lambda, 1.2, 0.01);
    ASSERT_GT(errs.size(), 200u);
    RecordProperty(fmt::format("median_rel_err_{}", int(lambda)),
                   fmt::format("{:.2e}", quantile(errs, 0.5)));
    EXPECT_LT(quantile(errs, 0.5), 0.02) << lambda;
    EXPECT_LT(quantile(errs, 0.9), 0.08) << lambda;
  }
  // The specular peak and the spectral shape: F0 falls linearly from 400 to 700 nm.
  const Vec3 wo = dir(0.4, 0.2), wi = dir(0.4, 0.2 + kPI);
  for (double lambda : {420.0, 550.0, 690.0}) {
    const double expect = ggxConductor(0.3, false)(wo, wi, lambda);
    EXPECT_NEAR(b->f(wo, wi, heroAt(lambda))[0], expect, 0.03 * expect) << lambda;
  }
}

TEST(RGLMeasured, RGBFileOfAGreyLambertianIsFlatAcrossWavelengths) {
  GenOptions o;
  o.param_alpha = 0.7;
  o.rgb = true;
  const auto b = parsed(generate(lambertian(0.5), o));
  EXPECT_TRUE(b->rgb());
  const Vec3 wo = dir(0.5, 0.1), wi = dir(0.7, 2.0);
  for (double lambda : {400.0, 500.0, 600.0, 700.0})
    EXPECT_NEAR(b->f(wo, wi, heroAt(lambda))[0], 0.5 / kPI, 0.03 * 0.5 / kPI) << lambda;
}

TEST(RGLMeasured, ReciprocalWithinInterpolationError) {
  // The format conditions its tables on one direction, so reciprocity holds only up to the
  // interpolation error (the tabulated BRDFs are reciprocal).
  for (const std::string* file : {&lambertianFile(), &conductorFile()}) {
    const auto b = parsed(*file);
    const SampledWavelengths wl = heroAt(550);
    std::vector<double> errs;
    for (int a = 0; a < 10; ++a)
      for (int c = 0; c < 10; ++c) {
        const Vec3 wo = dir(1.2 * (a + 0.5) / 10, 0.4 * a),
                   wi = dir(1.2 * (c + 0.5) / 10, 2.0 + 0.9 * c);
        const double f1 = b->f(wo, wi, wl)[0], f2 = b->f(wi, wo, wl)[0];
        if (std::max(f1, f2) < 0.01) continue;
        errs.push_back(std::abs(f1 - f2) / std::max(f1, f2));
      }
    std::sort(errs.begin(), errs.end());
    EXPECT_LT(quantile(errs, 0.5), 0.02);
    EXPECT_LT(quantile(errs, 0.9), 0.08);
  }
}

TEST(RGLMeasured, AnisotropicLayoutUsesAbsoluteAzimuths) {
  // An isotropic GGX conductor stored in the anisotropic layout (azimuths -pi .. pi in 30 degree
  // steps, the half vector's azimuth absolute): at the tabulated azimuths of wo it must match the
  // analytic BRDF as the isotropic layout does, whatever the azimuth of the pair.
  GenOptions o;
  o.param_alpha = 0.3;
  o.n_phi_i = 13;
  o.n_theta_i = 7;
  o.n_vndf = 32;
  o.n_values = 32;
  const auto b = parsed(generate(ggxConductor(0.3, false), o));
  EXPECT_FALSE(b->isotropic());
  const Brdf truth = ggxConductor(0.3, false);
  const SampledWavelengths wl = heroAt(550);
  std::vector<double> errs;
  for (int p = 0; p < 12; ++p) {
    const double phi_o = -kPI + 2 * kPI * p / 12;
    for (int a = 0; a < 5; ++a)
      for (int c = 0; c < 12; ++c) {
        const Vec3 wo = dir(0.15 + 0.22 * a, phi_o);
        const Vec3 wi = dir(0.1 + 0.1 * c, phi_o + kPI + 0.5 * (c - 6) * 0.2);
        const double expect = truth(wo, wi, wl.lambda(0));
        if (expect < 0.05) continue;
        errs.push_back(std::abs(b->f(wo, wi, wl)[0] - expect) / expect);
      }
  }
  std::sort(errs.begin(), errs.end());
  ASSERT_GT(errs.size(), 200u);
  RecordProperty("median_rel_err", fmt::format("{:.2e}", quantile(errs, 0.5)));
  EXPECT_LT(quantile(errs, 0.5), 0.03);
  EXPECT_LT(quantile(errs, 0.9), 0.10);
  // Sampling matches the pdf between tabulated azimuths too (slices blended).
  const RGLMeasuredBxDF bx(b, wl);
  const auto r =
      lensim::test::chi2TestBxDF(bx, dir(0.7, 0.3), TransportMode::Radiance, 100000, 3, 10, 20, 48);
  EXPECT_GT(r.p_value, 0.001) << r.summary();
  EXPECT_LT(r.max_eval_mismatch, 1e-6) << r.summary();
}

// ---- energy ----------------------------------------------------------------------------------

TEST(RGLMeasured, WhiteFurnaceAlbedoMatchesQuadratureOfTheAnalyticBRDF) {
  // Lambertian 0.5 reflects 0.5 of the light at every angle; a white (F = 1) GGX conductor
  // reflects its single-scattering albedo, below 1 (computed by quadrature of the analytic BRDF).
  const auto lam = parsed(lambertianFile());
  const auto white = parsed(whiteConductorFile());
  const SampledWavelengths wl = heroAt(550);
  for (double theta : {0.1, 0.6, 1.0, 1.3}) {
    const Vec3 wo = dir(theta, 0.7);
    const double a_lam = sampledAlbedo(RGLMeasuredBxDF(lam, wl), wo, 1 << 15);
    EXPECT_NEAR(a_lam, 0.5, 0.015) << theta;
    const double expect = analyticAlbedo(ggxConductor(0.3, true), wo, 550);
    const double got = sampledAlbedo(RGLMeasuredBxDF(white, wl), wo, 1 << 15);
    EXPECT_NEAR(got, expect, 0.02) << theta;
    EXPECT_LE(got, 1.0) << theta;
    RecordProperty(fmt::format("albedo_white_ggx_theta_{}", theta),
                   fmt::format("{:.4f} (quadrature {:.4f})", got, expect));
  }
}

// ---- sampling --------------------------------------------------------------------------------

TEST(RGLMeasured, ChiSquareSamplingMatchesThePdf) {
  for (const std::string* file : {&lambertianFile(), &conductorFile()}) {
    const RGLMeasuredBxDF b(parsed(*file), heroAt(550));
    uint64_t seed = 7;
    for (const Vec3& wo : {dir(0.2, 0.5), dir(0.8, 2.0), dir(1.25, -1.0), dir(2.5, 1.0)}) {
      const auto r =
          lensim::test::chi2TestBxDF(b, wo, TransportMode::Radiance, 100000, seed++, 10, 20, 48);
      const std::string where = fmt::format("wo.z={:.3f}: {}", wo.z, r.summary());
      EXPECT_GT(r.p_value, 0.01 / 8) << where;
      EXPECT_EQ(r.impossible_samples, 0) << where;
      EXPECT_LT(r.max_eval_mismatch, 1e-6) << where;
      EXPECT_LE(r.pdf_integral, 1.0 + 2e-3) << where;
      EXPECT_GT(r.pdf_integral, 0.9) << where;
    }
  }
}

// ---- malformed files -------------------------------------------------------------------------

namespace {

std::string parseError(const std::string& bytes) {
  try {
    (void)RGLMeasuredBRDF::parse(bytes, "bad.bsdf");
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

// The lambertian file with one float of field `name` (element i) replaced.
std::string withValue(std::string bytes, const std::string& name, std::size_t i, float v) {
  const std::size_t at = bytes.find(name);
  // name, uint16 ndim, uint8 dtype, uint64 offset
  uint64_t off = 0;
  for (int k = 7; k >= 0; --k)
    off = (off << 8) | static_cast<unsigned char>(bytes[at + name.size() + 3 + std::size_t(k)]);
  std::memcpy(&bytes[off + 4 * i], &v, 4);
  return bytes;
}

}  // namespace

TEST(RGLMeasuredErrors, MalformedFilesGiveLocatedErrors) {
  const std::string good = lambertianFile();
  // Truncated: the data of the last field ends beyond the file.
  std::string e = parseError(good.substr(0, good.size() - 100));
  EXPECT_NE(e.find("bad.bsdf: error: byte "), std::string::npos) << e;
  EXPECT_NE(e.find("truncated"), std::string::npos) << e;
  // Truncated inside the header.
  e = parseError(good.substr(0, 40));
  EXPECT_NE(e.find("byte 14: the header claims 10 fields, more than the 40 bytes"),
            std::string::npos)
      << e;
  e = parseError(good.substr(0, 16));
  EXPECT_NE(e.find("byte 14: the file ends after 16 bytes, inside the field count"),
            std::string::npos)
      << e;
  e = parseError(good.substr(0, 200));
  EXPECT_NE(e.find("beyond the end of the 200-byte file"), std::string::npos) << e;
  // Wrong magic.
  std::string bad = good;
  bad[0] = 'T';
  e = parseError(bad);
  EXPECT_NE(e.find("byte 0: not a tensor file"), std::string::npos) << e;
  // Wrong version.
  bad = good;
  bad[12] = 2;
  e = parseError(bad);
  EXPECT_NE(e.find("byte 12: tensor file version 2.0; expected version 1.0"), std::string::npos)
      << e;
  // NaN and infinity in the values, at their byte offsets.
  e = parseError(withValue(good, "spectra", 17, std::numeric_limits<float>::quiet_NaN()));
  EXPECT_NE(e.find("value 17 of field \"spectra\" is nan; expected a finite number"),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("bad.bsdf: error: byte "), std::string::npos) << e;
  e = parseError(withValue(good, "ndf", 3, std::numeric_limits<float>::infinity()));
  EXPECT_NE(e.find("value 3 of field \"ndf\" is inf"), std::string::npos) << e;
  e = parseError(withValue(good, "theta_i", 2, 0.0f));
  EXPECT_NE(e.find("expected increasing values"), std::string::npos) << e;
  e = parseError(withValue(good, "vndf", 5, -1.0f));
  EXPECT_NE(e.find("value 5 of field \"vndf\" is -1"), std::string::npos) << e;
  // A missing field.
  e = parseError(tensorFile({{"theta_i", 10, {1}, floatData({0.f})}}));
  EXPECT_NE(e.find("no field \"phi_i\""), std::string::npos) << e;
  // A huge shape: refused before anything is allocated, data beyond the file.
  e = parseError(tensorFile({{"spectra", 10, {1u << 20, 1u << 20, 1u << 20}, ""}}));
  EXPECT_NE(e.find("claims"), std::string::npos) << e;
  EXPECT_NE(e.find("beyond the end"), std::string::npos) << e;
  e = parseError(tensorFile({{"spectra", 10, {~uint64_t{0}, 16}, ""}}));
  EXPECT_NE(e.find("overflows 64 bits"), std::string::npos) << e;
}

TEST(RGLMeasuredErrors, AFileThatIsNeitherFormatIsRefusedAtTheParameter) {
  const auto dir = std::filesystem::temp_directory_path() / "lensim_measured_rgl_test";
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "m.txt") << "not a measured BRDF\n";
  std::ofstream(dir / "t.pbrt") << "WorldBegin\nMaterial \"measured\" \"string filename\" "
                                   "\"m.txt\"\nShape \"sphere\"\n";
  const auto r = lensim::test::runLensim("check " + (dir / "t.pbrt").string());
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("t.pbrt:2:"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("expected an RGL measured BSDF (a .bsdf tensor file) or a pbrt-v2"),
            std::string::npos)
      << r.out;
}

TEST(RGLMeasuredErrors, TablesBeyondTheMemoryBudgetAreRefused) {
  const uint64_t saved = memoryBudgetBytes();
  setMemoryBudgetBytes(uint64_t{1} << 18);  // the lambertian file's tables take ~0.9 MiB
  const std::string e = parseError(lambertianFile());
  setMemoryBudgetBytes(saved);
  EXPECT_NE(e.find("the measured BSDF tables needs about"), std::string::npos) << e;
}

TEST(RGLMeasuredErrors, CheckAndRenderExitWithOneAndSayWhere) {
  const auto dir = std::filesystem::temp_directory_path() / "lensim_measured_rgl_test";
  std::filesystem::create_directories(dir);
  const std::string scene = R"(Film "rgb" "integer xresolution" 8 "integer yresolution" 8
Camera "perspective"
Sampler "independent" "integer pixelsamples" 1
WorldBegin
LightSource "infinite" "rgb L" [1 1 1]
Material "measured" "string filename" "m.bsdf"
Shape "sphere"
)";
  std::ofstream(dir / "s.pbrt") << "LookAt 0 0 -3  0 0 0  0 1 0\n" << scene;
  auto writeBsdf = [&](const std::string& bytes) {
    std::ofstream(dir / "m.bsdf", std::ios::binary) << bytes;
  };
  const std::string out = (dir / "o.exr").string();
  // A good file renders.
  writeBsdf(lambertianFile());
  auto r = lensim::test::runLensim("check " + (dir / "s.pbrt").string());
  EXPECT_EQ(r.status, 0) << r.out;
  r = lensim::test::runLensim("render -q " + (dir / "s.pbrt").string() + " -o " + out);
  EXPECT_EQ(r.status, 0) << r.out;
  // A NaN and a truncated file: exit 1 with the byte offset, from check and from render.
  for (const std::string& bytes :
       {withValue(lambertianFile(), "sigma", 0, std::numeric_limits<float>::quiet_NaN()),
        lambertianFile().substr(0, 1000)}) {
    writeBsdf(bytes);
    for (const std::string cmd : {"check ", "render -q "}) {
      r = lensim::test::runLensim(cmd + (dir / "s.pbrt").string() +
                                  (cmd == "check " ? "" : " -o " + out));
      EXPECT_EQ(r.status, 1) << cmd << r.out;
      EXPECT_NE(r.out.find("m.bsdf: error: byte "), std::string::npos) << cmd << r.out;
    }
  }
}
