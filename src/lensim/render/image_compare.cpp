#include "lensim/render/image_compare.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>

#include "lensim/util/error.h"

namespace lensim::render {

namespace {

std::array<int, 3> rgbChannels(const io::Image& im, const char* what) {
  std::array<int, 3> c{};
  const char* names[3] = {"R", "G", "B"};
  for (int k = 0; k < 3; ++k) {
    const std::optional<int> i = im.channelIndex(names[k]);
    if (!i) throw Error(fmt::format("{} image has no {} channel", what, names[k]));
    c[size_t(k)] = *i;
  }
  return c;
}

/// Two-sided standard normal quantile: the z with P(|Z| > z) = alpha (bisection on erfc).
double twoSidedBound(double alpha) {
  double lo = 0, hi = 40;
  for (int it = 0; it < 100; ++it) {
    const double mid = 0.5 * (lo + hi);
    (std::erfc(mid / std::sqrt(2.0)) > alpha ? lo : hi) = mid;
  }
  return hi;
}

}  // namespace

CompareResult compareImages(const io::Image& test, const io::Image& ref, const CompareOptions& o) {
  auto sameSize = [&](const io::Image& im, const char* what) {
    if (im.width != ref.width || im.height != ref.height)
      throw Error(fmt::format("{} image is {}x{}, the reference {}x{}", what, im.width, im.height,
                              ref.width, ref.height));
  };
  sameSize(test, "test");
  if (o.second) sameSize(*o.second, "second");
  if (o.reference_low) sameSize(*o.reference_low, "low-sample reference");
  if (o.block < 1) throw Error(fmt::format("block size {} must be >= 1", o.block));
  if (o.reference_low && !(o.reference_spp > o.reference_low_spp && o.reference_low_spp > 0))
    throw Error(
        fmt::format("the low-sample reference needs reference spp > its spp > 0 (got {} and {})",
                    o.reference_spp, o.reference_low_spp));
  const auto ct = rgbChannels(test, "test"), cr = rgbChannels(ref, "reference");
  std::array<int, 3> c2{}, cl{};
  if (o.second) c2 = rgbChannels(*o.second, "second");
  if (o.reference_low) cl = rgbChannels(*o.reference_low, "low-sample reference");

  CompareResult r;
  r.has_noise = o.second != nullptr;
  r.family_error = o.family_error;
  r.outlier_sigmas = o.outlier_sigmas;
  r.outlier_rel = o.outlier_rel;
  if (o.reference_low)
    r.reference_noise = fmt::format("from the {}-spp reference", o.reference_low_spp);
  else if (o.spp > 0 && o.reference_spp > 0)
    r.reference_noise = "the render's variance per sample";
  else
    r.reference_noise = "none (taken as exact)";
  const int bw = ref.width / o.block, bh = ref.height / o.block;
  r.blocks = bw * bh;
  r.z_bound = twoSidedBound(o.family_error / std::max(1, r.blocks));
  double image_mean = 0;
  for (int y = 0; y < ref.height; ++y)
    for (int x = 0; x < ref.width; ++x)
      for (int k = 0; k < 3; ++k) image_mean += ref.at(x, y, cr[size_t(k)]);
  image_mean /= 3.0 * ref.width * ref.height;

  double sum_t = 0, sum_r = 0, sum_abs = 0;
  for (int by = 0; by < bh; ++by)
    for (int bx = 0; bx < bw; ++bx) {
      double mt = 0, mr = 0, d2 = 0, l2 = 0;
      for (int y = by * o.block; y < (by + 1) * o.block; ++y)
        for (int x = bx * o.block; x < (bx + 1) * o.block; ++x)
          for (size_t k = 0; k < 3; ++k) {
            const double a = test.at(x, y, ct[k]);
            const double b = o.second ? o.second->at(x, y, c2[k]) : a;
            mt += 0.5 * (a + b);
            mr += ref.at(x, y, cr[k]);
            d2 += (a - b) * (a - b);
            if (o.reference_low) {
              const double d = o.reference_low->at(x, y, cl[k]) - ref.at(x, y, cr[k]);
              l2 += d * d;
            }
          }
      const double n = 3.0 * o.block * o.block;
      mt /= n, mr /= n;
      sum_t += mt, sum_r += mr, sum_abs += std::abs(mt - mr);
      if (!r.has_noise) continue;
      const double pixel_var = d2 / n / 2;  // one render's per-pixel variance
      double ref_pixel_var = 0;
      if (o.reference_low)
        ref_pixel_var = l2 / n / (double(o.reference_spp) / o.reference_low_spp - 1);
      else if (o.spp > 0 && o.reference_spp > 0)
        ref_pixel_var = pixel_var * o.spp / o.reference_spp;
      const double sigma = std::sqrt(pixel_var / n / 2 + ref_pixel_var / n);
      const double diff = std::abs(mt - mr);
      const double z = diff / std::max(sigma, 1e-300);
      if (diff <= o.floor_rel * image_mean) continue;
      if (z > r.z_bound) {
        ++r.z_failures;
        r.failing.push_back({bx, by, mt, mr, z});
      }
      r.outliers += diff > o.outlier_sigmas * sigma + o.outlier_rel * mr;
    }
  r.mean_ratio = sum_r > 0 ? sum_t / sum_r : 0;
  r.mad_rel = sum_r > 0 ? sum_abs / sum_r : 0;
  std::sort(r.failing.begin(), r.failing.end(),
            [](const BlockDifference& a, const BlockDifference& b) { return a.z > b.z; });
  return r;
}

std::string formatCompare(const CompareResult& r, int max_listed) {
  std::string s = fmt::format(
      "{} blocks; mean ratio (render / reference) {:.4f}; mean |block difference| {:.4f} of "
      "the image mean\n",
      r.blocks, r.mean_ratio, r.mad_rel);
  if (!r.has_noise) {
    s += "no noise estimate (give a second render with --second): no z-test\n";
    return s;
  }
  s += fmt::format(
      "z-test (reference noise: {}): {} blocks ({:.2f}%) beyond the bound z = {:.2f} "
      "(Bonferroni, {:g}% family-wise); {} blocks ({:.2f}%) beyond {:g} sigma + {:g}%\n",
      r.reference_noise, r.z_failures, 100 * r.zFailShare(), r.z_bound, 100 * r.family_error,
      r.outliers, 100 * r.outlierShare(), r.outlier_sigmas, 100 * r.outlier_rel);
  for (size_t i = 0; i < r.failing.size() && int(i) < max_listed; ++i) {
    const BlockDifference& b = r.failing[i];
    s += fmt::format("  block ({}, {}): render {:.5g}, reference {:.5g}, z {:.1f}\n", b.bx, b.by,
                     b.test, b.reference, b.z);
  }
  return s;
}

Verdict verdict(const CompareResult& r, const VerdictOptions& o) {
  Verdict v;
  if (r.has_noise) {
    const int allowed = int(std::floor(o.max_fail_share * r.blocks + 1e-9));
    v.pass = r.z_failures <= allowed;
    v.reason = fmt::format("{} of {} blocks beyond the z bound {:.2f} (allowed {})", r.z_failures,
                           r.blocks, r.z_bound, allowed);
  } else {
    const double dm = std::abs(r.mean_ratio - 1);
    v.pass = dm <= o.tolerance && r.mad_rel <= o.tolerance;
    v.reason = fmt::format(
        "no noise estimate: |mean ratio - 1| {:.4f} and mean |block difference| {:.4f} against "
        "the tolerance {:g}",
        dm, r.mad_rel, o.tolerance);
  }
  return v;
}

}  // namespace lensim::render
