// Sample generators for pixel estimates (pbrt-v4 semantics: "independent", "stratified",
// and a scrambled low-discrepancy "sobol"-family sampler).
//
// Every value depends only on (seed, pixel, sample index, dimension), never on the order of
// calls across pixels, so a render is identical whatever the number or scheduling of threads.
// Use one Sampler per thread (clone()); call startPixelSample before drawing a pixel sample's
// dimensions in a fixed order.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "lensim/sampling/dimension_cache.h"
#include "lensim/sampling/sampling.h"
#include "lensim/util/vec.h"

namespace lensim::sampling {

/// Integer pixel coordinates (raster space, x right, y down).
using Point2i = Vec2T<int>;

/// Source of sample values in [0,1) for one pixel sample at a time.
class Sampler {
 public:
  virtual ~Sampler() = default;
  /// Samples per pixel this sampler produces (after any rounding it needs).
  virtual int samplesPerPixel() const = 0;
  /// Begins sample `sample_index` of `pixel`; the next value drawn is `dimension`.
  virtual void startPixelSample(Point2i pixel, int sample_index, int dimension = 0) = 0;
  /// The next 1-D value, in [0,1).
  virtual double get1D() = 0;
  /// The next 2-D value, in [0,1)^2.
  virtual Vec2 get2D() = 0;
  /// The 2-D value for the film position within the pixel (the first dimensions).
  virtual Vec2 getPixel2D() { return get2D(); }
  /// The dimension the next value comes from (as startPixelSample counts them): drawing up to
  /// here and restarting the sample at this dimension give the same values from then on.
  virtual int dimension() const = 0;
  /// An independent copy with the same parameters, for another thread.
  virtual std::unique_ptr<Sampler> clone() const = 0;
};

/// Uniform random values (PCG32) seeded by hash(seed, pixel, sample index).
class IndependentSampler final : public Sampler {
 public:
  explicit IndependentSampler(int samples_per_pixel, int seed = 0);
  int samplesPerPixel() const override { return spp_; }
  void startPixelSample(Point2i pixel, int sample_index, int dimension = 0) override;
  double get1D() override {
    ++dim_;
    return rng_.uniform();
  }
  Vec2 get2D() override {
    dim_ += 2;
    const double a = rng_.uniform();
    return {a, rng_.uniform()};
  }
  int dimension() const override { return dim_; }
  std::unique_ptr<Sampler> clone() const override;

 private:
  int spp_, seed_;
  int dim_ = 0;
  Rng rng_;
};

/// Jittered stratification: per dimension, x_samples * y_samples strata (2-D) or that many
/// intervals (1-D) per pixel, each pixel sample taking a stratum through a per-pixel,
/// per-dimension random permutation; jitter inside the stratum unless jitter is false.
class StratifiedSampler final : public Sampler {
 public:
  StratifiedSampler(int x_samples, int y_samples, bool jitter = true, int seed = 0);
  int samplesPerPixel() const override { return xs_ * ys_; }
  void startPixelSample(Point2i pixel, int sample_index, int dimension = 0) override;
  double get1D() override;
  Vec2 get2D() override;
  int dimension() const override { return dim_; }
  std::unique_ptr<Sampler> clone() const override;

 private:
  const PermutationKeys& keys(int dim);
  int stratum(int dim);
  Rng pixelRng() const;
  Rng jitterRng(int dim) const;
  int xs_, ys_, seed_;
  bool jitter_;
  Point2i pixel_{};
  int index_ = 0, dim_ = 0;
  uint32_t stratum_index_ = 0;  ///< index_ % samplesPerPixel()
  Rng pixel_rng_;               ///< the pixel's jitter stream at its start
  Rng sample_rng_;              ///< pixel_rng_ advanced to sample index_'s stretch
  DimensionCache<PermutationKeys> keys_;  ///< each dimension's stratum permutation keys
};

/// Padded Sobol sampler: each dimension pair is the first two Sobol dimensions (a (0,2)-sequence
/// in base 2), Owen-scrambled with a hash of (seed, pixel, dimension), and the sample index is
/// shuffled per pixel and dimension so pairs are decorrelated. The samples per pixel are rounded
/// up to a power of two, as the (0,2)-sequence's stratification needs.
class PaddedSobolSampler final : public Sampler {
 public:
  explicit PaddedSobolSampler(int samples_per_pixel, int seed = 0);
  int samplesPerPixel() const override { return spp_; }
  void startPixelSample(Point2i pixel, int sample_index, int dimension = 0) override;
  double get1D() override;
  Vec2 get2D() override;
  int dimension() const override { return dim_; }
  std::unique_ptr<Sampler> clone() const override;

 private:
  /// What a dimension's values need of (seed, pixel, dimension): the index permutation's keys
  /// and the two Owen scrambling seeds.
  struct DimensionKeys {
    PermutationKeys permutation;
    uint32_t owen[2] = {};
  };
  uint64_t dimensionHash(int dim) const;
  const DimensionKeys& keys(int dim);
  uint32_t permutedIndex(const DimensionKeys& k) const;
  int spp_, seed_;
  Point2i pixel_{};
  int index_ = 0, dim_ = 0;
  uint32_t index_in_block_ = 0;  ///< index_ % spp_
  DimensionCache<DimensionKeys> keys_;
};

/// Randomisation of pbrt-v4's Sobol samplers ("string randomization").
enum class SobolRandomization { None, PermuteDigits, FastOwen, Owen };

/// pbrt-v4's ZSobolSampler (Ahmed & Wonka 2020, "Screen-space blue-noise diffusion of Monte
/// Carlo sampling error via hierarchical ordering of pixels"): the sample index is the Morton
/// code of the pixel followed by the sample number, its base-4 digits permuted by a hash of the
/// higher digits and the dimension, and the value is the first (1-D) or first two (2-D) Sobol
/// dimensions at that index, scrambled by a hash of (dimension, seed). For power-of-two sample
/// counts the values are pbrt-v4's (in double precision); other counts draw the requested
/// number of samples from the next power of two's index block (pbrt-v4 warns and uses a power
/// of two).
class ZSobolSampler final : public Sampler {
 public:
  ZSobolSampler(int samples_per_pixel, Point2i full_resolution,
                SobolRandomization randomization = SobolRandomization::FastOwen, int seed = 0);
  int samplesPerPixel() const override { return spp_; }
  void startPixelSample(Point2i pixel, int sample_index, int dimension = 0) override;
  double get1D() override;
  Vec2 get2D() override;
  int dimension() const override { return dim_; }
  std::unique_ptr<Sampler> clone() const override;
  /// The permuted Sobol index of the current pixel sample at the current dimension.
  uint64_t sampleIndex() const;

 private:
  /// The permuted index digits of the current pixel sample at dimension dim_ above the lowest
  /// full base-4 digit, and that digit's permutation, for the sample key (the Morton index
  /// without its lowest digit) they were made for. Each is a function of its key and the
  /// dimension; for a new key only the digits at and below the highest changed bit are
  /// permuted again (a pixel's samples follow each other, and neighbouring pixels share the
  /// high digits: about one or two digits per four samples).
  struct DimensionCache {
    uint64_t sample_key = ~0ULL;  // a key is at most 2^62 - 1: ~0 is never one
    uint64_t prefix = 0;
    uint64_t flip_key = ~0ULL;  // odd log2 spp: the last bit's flip, for morton_ >> 1
    uint32_t flip = 0;
    uint8_t low_permutation = 0;
  };
  uint32_t scrambleReversed(uint32_t reversed, uint32_t hash) const;
  uint64_t permuteDigits(int from_digit, int to_digit) const;
  uint64_t dimensionHash(int dim) const;
  int spp_, seed_, log2_spp_, base4_digits_;
  SobolRandomization randomization_;
  uint64_t morton_ = 0;
  int dim_ = 0;
  Point2i pixel_{-1, -1};
  uint64_t pixel_morton_ = ~0ULL;  ///< Morton code of pixel_ (of (-1, -1): all ones)
  mutable std::vector<DimensionCache> cache_;
  std::vector<uint64_t> dim_hash_;  ///< pbrt-v4 Hash(d, seed) for small d
};

/// Parses pbrt-v4's "randomization" values ("none", "permutedigits", "fastowen", "owen"; empty
/// is "fastowen"); throws Error naming the value otherwise.
SobolRandomization parseSobolRandomization(const std::string& name);

/// The unscrambled first (van der Corput) and second Sobol dimensions as 32-bit fractions.
uint32_t sobolDimension0(uint32_t index);
uint32_t sobolDimension1(uint32_t index);
/// Owen (nested uniform) scrambling of a 32-bit fraction: the flip of each bit depends only on
/// the seed and the bits above it (hash-based, Laine-Karras / Burley 2020).
uint32_t owenScramble(uint32_t v, uint64_t seed);
/// owenScramble's core on bit-reversed values: owenScramble(v, seed) is
/// reverseBits(owenScrambleReversed(reverseBits(v), uint32_t(mixBits(seed)))).
uint32_t owenScrambleReversed(uint32_t reversed, uint32_t seed);

}  // namespace lensim::sampling
