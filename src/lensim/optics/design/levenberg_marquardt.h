// Damped least squares (Levenberg-Marquardt) with bounds and a finite-difference Jacobian whose
// columns are evaluated in parallel (TBB).
//
// Minimises the merit sum_i r_i(x)^2 over x inside [lower, upper]. Each iteration solves
// (J^T J + lambda diag(J^T J)) dx = -J^T r (Marquardt's scaling, so the step does not depend on
// the variables' units), clamps x + dx to the bounds, and accepts the step when the merit falls
// (lambda /= 3) or rejects it (lambda *= 10). It stops when the merit fell by less than
// window_tolerance (relative) over the last `window` iterations, when no step lowers it, or at the
// iteration limit. The Jacobian is by central differences (one
// residual evaluation per side and variable, all concurrent); a side that fails or leaves the
// bounds falls back to a one-sided difference.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace lensim::optics::design {

/// Residuals at x; returns false when x cannot be evaluated (the step is then rejected).
/// Called concurrently from several threads: it must not modify shared state.
using ResidualFn = std::function<bool(const std::vector<double>& x, std::vector<double>& r)>;

struct LmOptions {
  int max_iterations = 100;
  /// Stop when an accepted step lowers the merit by less than this fraction, twice in a row.
  double relative_tolerance = 1e-10;
  /// Stop when the merit fell by less than window_tolerance (relative) over the last `window`
  /// iterations: a merit that crawls down a shallow valley (a lens near its optimum, the
  /// Jacobian's finite differences limiting the steps) stops there instead of at the limit.
  /// 1e-4 of the merit is 5e-5 of the RMS residual. window 0: off.
  int window = 10;
  double window_tolerance = 1e-4;
  /// Stop when the merit is below this.
  double absolute_tolerance = 1e-30;
  double initial_lambda = 1e-3;
  /// Finite-difference step of each variable (empty: 1e-7 (1 + |x_j|)).
  std::vector<double> steps;
  /// Called after every iteration with (iteration, merit, lambda, residuals); may be empty.
  std::function<void(int, double, double, const std::vector<double>&)> progress;
};

struct LmResult {
  std::vector<double> x;
  std::vector<double> residuals;
  double initial_merit = 0;
  double merit = 0;  ///< sum of squared residuals at x
  int iterations = 0;
  int evaluations = 0;  ///< residual evaluations, Jacobian columns included
  std::string stop_reason;
};

/// Runs the optimiser from x0 (clamped to the bounds). lower/upper may be empty (unbounded) or
/// hold one value per variable (+-infinity for a free side). Throws lensim::Error when x0 cannot
/// be evaluated or the sizes disagree.
LmResult levenbergMarquardt(const ResidualFn& f, std::vector<double> x0,
                            const std::vector<double>& lower, const std::vector<double>& upper,
                            const LmOptions& opts = {});

/// Multi-start global search: `starts` runs of levenbergMarquardt, the first from x0 and the
/// others from random points: a variable with both bounds finite (|bound| < 1e299) uniform
/// within them, else x0_j +- spread * max(|x0_j|, scales_j) uniformly, clamped to its bounds.
/// The starts run in parallel (TBB); each draws from its own generator seeded by (seed, start),
/// so a seed reproduces the run exactly whatever the scheduling. The result with the lowest
/// merit is kept (the lowest start index on a tie), its evaluations counting every start's, its
/// initial merit the given start's. `progress` of opts is not called (the
/// starts run concurrently); `on_start` (may be empty) is called once per start, in start order,
/// after all have finished.
struct GlobalOptions {
  int starts = 1;
  std::uint64_t seed = 1;
  double spread = 0.5;
  std::vector<double> scales;  ///< per variable (empty: 1)
  std::function<void(int start, const std::vector<double>& x_start, const LmResult&)> on_start;
};
LmResult multiStartLevenbergMarquardt(const ResidualFn& f, const std::vector<double>& x0,
                                      const std::vector<double>& lower,
                                      const std::vector<double>& upper, const LmOptions& opts,
                                      const GlobalOptions& global);

/// The Jacobian (row-major, m x n) by central differences at x, evaluated in parallel; returns
/// false when a column cannot be evaluated on either side.
bool finiteDifferenceJacobian(const ResidualFn& f, const std::vector<double>& x,
                              const std::vector<double>& r0, const std::vector<double>& lower,
                              const std::vector<double>& upper, const std::vector<double>& steps,
                              std::vector<double>& jac, int* evaluations = nullptr);

/// Solves the symmetric positive definite system A x = b (n x n, row-major) by Cholesky;
/// false when A is not positive definite.
bool solveCholesky(std::vector<double> a, std::vector<double> b, int n, std::vector<double>& x);

}  // namespace lensim::optics::design
