#include "lensim/optics/design/levenberg_marquardt.h"

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <cstdint>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <optional>

#include "lensim/util/error.h"

namespace lensim::optics::design {

namespace {

double sumSquares(const std::vector<double>& r) {
  double s = 0;
  for (double v : r) s += v * v;
  return s;
}

bool allFinite(const std::vector<double>& r) {
  return std::all_of(r.begin(), r.end(), [](double v) { return std::isfinite(v); });
}

}  // namespace

bool solveCholesky(std::vector<double> a, std::vector<double> b, int n, std::vector<double>& x) {
  for (int j = 0; j < n; ++j) {
    double d = a[j * n + j];
    for (int k = 0; k < j; ++k) d -= a[j * n + k] * a[j * n + k];
    if (!(d > 0)) return false;
    d = std::sqrt(d);
    a[j * n + j] = d;
    for (int i = j + 1; i < n; ++i) {
      double s = a[i * n + j];
      for (int k = 0; k < j; ++k) s -= a[i * n + k] * a[j * n + k];
      a[i * n + j] = s / d;
    }
  }
  for (int i = 0; i < n; ++i) {  // L y = b
    double s = b[i];
    for (int k = 0; k < i; ++k) s -= a[i * n + k] * b[k];
    b[i] = s / a[i * n + i];
  }
  x.assign(n, 0);
  for (int i = n - 1; i >= 0; --i) {  // L^T x = y
    double s = b[i];
    for (int k = i + 1; k < n; ++k) s -= a[k * n + i] * x[k];
    x[i] = s / a[i * n + i];
  }
  return true;
}

bool finiteDifferenceJacobian(const ResidualFn& f, const std::vector<double>& x,
                              const std::vector<double>& r0, const std::vector<double>& lower,
                              const std::vector<double>& upper, const std::vector<double>& steps,
                              std::vector<double>& jac, int* evaluations) {
  const int n = static_cast<int>(x.size()), m = static_cast<int>(r0.size());
  jac.assign(static_cast<size_t>(m) * n, 0);
  // Both sides of every variable, 2n evaluations side by side.
  std::vector<std::vector<double>> rs(2 * n);
  std::vector<char> ok(2 * n, 0);
  std::vector<double> h(n);
  for (int j = 0; j < n; ++j) h[j] = steps.empty() ? 1e-7 * (1 + std::abs(x[j])) : steps[j];
  std::atomic<int> count{0};
  tbb::parallel_for(0, 2 * n, [&](int k) {
    const int j = k / 2;
    const double xs = x[j] + (k % 2 ? -h[j] : h[j]);
    if ((!lower.empty() && xs < lower[j]) || (!upper.empty() && xs > upper[j])) return;
    std::vector<double> xk = x;
    xk[j] = xs;
    std::vector<double> r;
    ++count;
    if (f(xk, r) && r.size() == r0.size() && allFinite(r)) {
      rs[k] = std::move(r);
      ok[k] = 1;
    }
  });
  if (evaluations) *evaluations += count;
  for (int j = 0; j < n; ++j) {
    const bool p = ok[2 * j], q = ok[2 * j + 1];
    if (!p && !q) return false;
    for (int i = 0; i < m; ++i) {
      double d;
      if (p && q)
        d = (rs[2 * j][i] - rs[2 * j + 1][i]) / (2 * h[j]);
      else if (p)
        d = (rs[2 * j][i] - r0[i]) / h[j];
      else
        d = (r0[i] - rs[2 * j + 1][i]) / h[j];
      jac[static_cast<size_t>(i) * n + j] = d;
    }
  }
  return true;
}

LmResult levenbergMarquardt(const ResidualFn& f, std::vector<double> x0,
                            const std::vector<double>& lower, const std::vector<double>& upper,
                            const LmOptions& opts) {
  const int n = static_cast<int>(x0.size());
  if ((!lower.empty() && static_cast<int>(lower.size()) != n) ||
      (!upper.empty() && static_cast<int>(upper.size()) != n) ||
      (!opts.steps.empty() && static_cast<int>(opts.steps.size()) != n))
    throw Error("levenbergMarquardt: bounds or steps do not match the variables");
  auto clamp = [&](std::vector<double>& x) {
    for (int j = 0; j < n; ++j) {
      if (!lower.empty()) x[j] = std::max(x[j], lower[j]);
      if (!upper.empty()) x[j] = std::min(x[j], upper[j]);
    }
  };
  clamp(x0);
  LmResult res;
  res.x = x0;
  if (!f(res.x, res.residuals) || !allFinite(res.residuals))
    throw Error("the starting point cannot be evaluated");
  res.evaluations = 1;
  const int m = static_cast<int>(res.residuals.size());
  res.merit = res.initial_merit = sumSquares(res.residuals);
  double lambda = opts.initial_lambda;
  int small_steps = 0;
  std::vector<double> history{res.merit};  // merit after each iteration, the start first
  std::vector<double> jac, jtj(static_cast<size_t>(n) * n), jtr(n), dx, xt, rt;
  for (int it = 0; it < opts.max_iterations; ++it) {
    if (res.merit <= opts.absolute_tolerance) {
      res.stop_reason = "merit below the absolute tolerance";
      return res;
    }
    if (!finiteDifferenceJacobian(f, res.x, res.residuals, lower, upper, opts.steps, jac,
                                  &res.evaluations)) {
      res.stop_reason = "the Jacobian cannot be evaluated";
      return res;
    }
    for (int a = 0; a < n; ++a) {
      double g = 0;
      for (int i = 0; i < m; ++i) g += jac[static_cast<size_t>(i) * n + a] * res.residuals[i];
      jtr[a] = -g;
      for (int b = 0; b <= a; ++b) {
        double s = 0;
        for (int i = 0; i < m; ++i)
          s += jac[static_cast<size_t>(i) * n + a] * jac[static_cast<size_t>(i) * n + b];
        jtj[a * n + b] = jtj[b * n + a] = s;
      }
    }
    // Damp until a step lowers the merit (or lambda runs away).
    bool accepted = false;
    while (lambda < 1e16) {
      std::vector<double> damped = jtj;
      for (int a = 0; a < n; ++a)
        damped[a * n + a] += lambda * std::max(jtj[a * n + a], 1e-30);
      if (solveCholesky(damped, jtr, n, dx)) {
        xt = res.x;
        for (int a = 0; a < n; ++a) xt[a] += dx[a];
        clamp(xt);
        ++res.evaluations;
        if (f(xt, rt) && static_cast<int>(rt.size()) == m && allFinite(rt)) {
          const double mt = sumSquares(rt);
          if (mt < res.merit) {
            const double drop = (res.merit - mt) / std::max(res.merit, 1e-300);
            res.x = xt;
            res.residuals = rt;
            res.merit = mt;
            lambda = std::max(lambda / 3, 1e-12);
            accepted = true;
            small_steps = drop < opts.relative_tolerance ? small_steps + 1 : 0;
            break;
          }
        }
      }
      lambda *= 10;
    }
    res.iterations = it + 1;
    if (opts.progress) opts.progress(res.iterations, res.merit, lambda, res.residuals);
    if (!accepted) {
      res.stop_reason = "no step lowers the merit (a minimum within the bounds)";
      return res;
    }
    history.push_back(res.merit);
    if (small_steps >= 2) {
      res.stop_reason = "merit change below the relative tolerance";
      return res;
    }
    if (opts.window > 0 && static_cast<int>(history.size()) > opts.window) {
      const double before = history[history.size() - 1 - opts.window];
      if (before - res.merit < opts.window_tolerance * before) {
        res.stop_reason = fmt::format("merit fell by less than {:g} over the last {} iterations",
                                      opts.window_tolerance, opts.window);
        return res;
      }
    }
  }
  res.stop_reason = fmt::format("iteration limit ({})", opts.max_iterations);
  return res;
}

namespace {

// SplitMix64: a small, well-mixed generator; one stream per (seed, start).
struct SplitMix64 {
  std::uint64_t state;
  std::uint64_t next() {
    std::uint64_t z = (state += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }  // [0, 1)
};

}  // namespace

LmResult multiStartLevenbergMarquardt(const ResidualFn& f, const std::vector<double>& x0,
                                      const std::vector<double>& lower,
                                      const std::vector<double>& upper, const LmOptions& opts,
                                      const GlobalOptions& global) {
  const int n = static_cast<int>(x0.size());
  if (global.starts < 1) throw Error("multiStartLevenbergMarquardt: starts must be >= 1");
  if (!global.scales.empty() && static_cast<int>(global.scales.size()) != n)
    throw Error("multiStartLevenbergMarquardt: scales do not match the variables");
  std::vector<std::vector<double>> xs(global.starts, x0);
  for (int k = 1; k < global.starts; ++k) {
    SplitMix64 rng{global.seed * 0x2545f4914f6cdd1dULL + static_cast<std::uint64_t>(k)};
    rng.next();
    for (int j = 0; j < n; ++j) {
      const double lo = lower.empty() ? -1e300 : lower[j], hi = upper.empty() ? 1e300 : upper[j];
      const double u = rng.uniform();
      double v;
      if (std::abs(lo) < 1e299 && std::abs(hi) < 1e299) {
        v = lo + (hi - lo) * u;
      } else {
        const double s = global.spread *
                         std::max(std::abs(x0[j]), global.scales.empty() ? 1.0 : global.scales[j]);
        v = x0[j] + s * (2 * u - 1);
      }
      xs[k][j] = std::clamp(v, lo, hi);
    }
  }
  LmOptions quiet = opts;
  quiet.progress = nullptr;
  std::vector<std::optional<LmResult>> results(global.starts);
  std::vector<std::string> errors(global.starts);
  tbb::parallel_for(0, global.starts, [&](int k) {
    try {
      results[k] = levenbergMarquardt(f, xs[k], lower, upper, quiet);
    } catch (const Error& e) {
      errors[k] = e.message();  // a random start the merit cannot be evaluated at
    }
  });
  if (!results[0]) throw Error(errors[0]);
  int best = 0;
  for (int k = 0; k < global.starts; ++k) {
    if (global.on_start) {
      if (results[k]) {
        global.on_start(k, xs[k], *results[k]);
      } else {
        LmResult failed;
        failed.x = xs[k];
        failed.stop_reason = "the start cannot be evaluated: " + errors[k];
        failed.merit = failed.initial_merit = std::numeric_limits<double>::infinity();
        global.on_start(k, xs[k], failed);
      }
    }
    if (results[k] && results[k]->merit < results[best]->merit) best = k;
  }
  LmResult out = *results[best];
  for (int k = 0; k < global.starts; ++k)
    if (k != best && results[k]) out.evaluations += results[k]->evaluations;
  out.initial_merit = results[0]->initial_merit;
  return out;
}

}  // namespace lensim::optics::design
