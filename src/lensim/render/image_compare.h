// Comparing a Monte Carlo render with a reference image within noise: block means, their
// standard errors from the images themselves, and a per-block z-test with a multiple-comparison
// (Bonferroni) correction. Used by `lensim compare` and the reference tests.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "lensim/io/image.h"

namespace lensim::render {

struct CompareOptions {
  int block = 10;  ///< block side (pixels); partial blocks at the right and bottom are ignored
  /// A second render of the same scene with another seed: the compared image is the mean of
  /// the two, and their difference gives the render's per-pixel variance. Without it there is
  /// no noise estimate and no z-test.
  const io::Image* second = nullptr;
  int spp = 0;            ///< samples per pixel of each render (for the reference's noise model)
  int reference_spp = 0;  ///< samples per pixel of the reference
  /// A render of the reference's own renderer at fewer samples (reference_low_spp): the
  /// reference's per-pixel variance is (low - reference)^2 / (reference_spp / low_spp - 1).
  /// Without it the reference is taken to have the render's variance per sample (needs spp and
  /// reference_spp), or, lacking those too, to be exact.
  const io::Image* reference_low = nullptr;
  int reference_low_spp = 0;
  double family_error = 0.01;  ///< family-wise error rate of the Bonferroni-corrected z-test
  /// Differences smaller than this share of the reference's image mean never count as failures
  /// or outliers (blocks that both renders leave black have a sample variance of 0).
  double floor_rel = 1e-3;
  double outlier_sigmas = 5, outlier_rel = 0.02;  ///< outlier: |diff| > k sigma + rel * ref
};

struct BlockDifference {
  int bx = 0, by = 0;                     ///< block indices
  double test = 0, reference = 0, z = 0;  ///< block means (RGB average) and z score
};

struct CompareResult {
  int blocks = 0;
  double mean_ratio = 0;                 ///< sum of the render / sum of the reference (R, G, B)
  double mad_rel = 0;                    ///< mean |block difference| / reference image mean
  bool has_noise = false;                ///< a noise estimate exists (a second render was given)
  std::string reference_noise;           ///< how the reference's noise was modelled
  double z_bound = 0;                    ///< two-sided Bonferroni bound
  int z_failures = 0;                    ///< blocks beyond z_bound (and above the floor)
  int outliers = 0;                      ///< blocks beyond outlier_sigmas sigma + outlier_rel
  std::vector<BlockDifference> failing;  ///< the z failures, largest z first
  double family_error = 0, outlier_sigmas = 0, outlier_rel = 0;  ///< as in the options
  double zFailShare() const { return blocks ? double(z_failures) / blocks : 0; }
  double outlierShare() const { return blocks ? double(outliers) / blocks : 0; }
};

/// Compares `test` (and options.second) with `reference`. Throws lensim::Error when the sizes
/// differ or an image lacks R, G and B.
CompareResult compareImages(const io::Image& test, const io::Image& reference,
                            const CompareOptions& options);

/// The result as readable lines (as `lensim compare` prints it).
std::string formatCompare(const CompareResult& r, int max_listed = 10);

/// What a comparison must show to pass (`lensim compare` exits 0 on pass, 1 on fail).
struct VerdictOptions {
  /// With a noise estimate: the share of blocks allowed beyond the z bound. 0 (the default) is
  /// the family-wise test itself: a render equal to the reference in expectation fails with
  /// probability at most the family-wise error rate.
  double max_fail_share = 0;
  /// Without a noise estimate (no second render): pass iff |mean ratio - 1| and the mean
  /// |block difference| (relative to the image mean) are both at most this.
  double tolerance = 0.05;
};

struct Verdict {
  bool pass = false;
  std::string reason;  ///< one line: what was tested and the figures
};

Verdict verdict(const CompareResult& r, const VerdictOptions& options = {});

}  // namespace lensim::render
