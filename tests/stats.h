// Small statistics helpers shared by the Monte Carlo tests.
#pragma once

#include <cmath>
#include <cstddef>

namespace lensim::test {

/// Running mean and variance (Welford).
struct RunningStats {
  std::size_t n = 0;
  double mean = 0, m2 = 0;
  void add(double x) {
    ++n;
    const double d = x - mean;
    mean += d / n;
    m2 += d * (x - mean);
  }
  double variance() const { return n > 1 ? m2 / (n - 1) : 0.0; }
  /// Standard error of the mean.
  double stderror() const { return std::sqrt(variance() / n); }
};

}  // namespace lensim::test
