// The within-noise comparison (lensim/render/image_compare.h, `lensim compare`) on synthetic
// images whose noise is known: agreeing images pass, a shifted block is found, and the noise of
// the reference estimated from a low-sample sibling matches the truth.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <random>

#include "cli_run.h"
#include "lensim/io/image.h"
#include "lensim/render/image_compare.h"
#include "lensim/util/error.h"

using namespace lensim;

namespace {

/// A 200x100 "render": a smooth image plus Gaussian noise of a sample mean of n samples of
/// standard deviation 1 per sample.
io::Image noisy(int n, uint64_t seed, double shift_block_by = 0) {
  io::Image im(200, 100, {"R", "G", "B"});
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0, 1 / std::sqrt(double(n)));
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x)
      for (int c = 0; c < 3; ++c) {
        double v = 2 + std::sin(x * 0.05) + 0.01 * y + g(rng);
        if (x >= 50 && x < 60 && y >= 20 && y < 30) v += shift_block_by;
        im.at(x, y, c) = float(v);
      }
  return im;
}

}  // namespace

TEST(ImageCompare, AgreeingImagesPassAndAShiftedBlockIsFound) {
  const io::Image ref = noisy(1024, 1), ref_low = noisy(32, 2);
  const io::Image a = noisy(16, 3), b = noisy(16, 4);
  render::CompareOptions o;
  o.second = &b;
  o.spp = 16;
  o.reference_spp = 1024;
  o.reference_low = &ref_low;
  o.reference_low_spp = 32;
  const render::CompareResult r = render::compareImages(a, ref, o);
  EXPECT_EQ(r.blocks, 200);
  EXPECT_NEAR(r.mean_ratio, 1.0, 0.002);
  EXPECT_EQ(r.z_failures, 0);
  EXPECT_EQ(r.outliers, 0);
  // One block of one render shifted by 0.2: the mean of the two moves by 0.1; its standard
  // error is sqrt((2/16 + 0.2^2) / 2 / 300 / 2 + (1/32 + 1/1024) / 31 / 300) = 0.0119 (the
  // shift inflates the two renders' difference), so z is about 8.4.
  const io::Image shifted = noisy(16, 3, 0.2);
  const render::CompareResult s = render::compareImages(shifted, ref, o);
  ASSERT_EQ(s.z_failures, 1);
  EXPECT_EQ(s.failing[0].bx, 5);
  EXPECT_EQ(s.failing[0].by, 2);
  EXPECT_NEAR(s.failing[0].z, 8.4, 3.0);
  EXPECT_TRUE(render::verdict(r).pass);
  EXPECT_FALSE(render::verdict(s).pass);
  EXPECT_TRUE(render::verdict(s, {0.005, 0.05}).pass);  // 1 of 200 allowed
  // Without a second render there is no noise estimate, hence no z-test.
  o.second = nullptr;
  EXPECT_FALSE(render::compareImages(shifted, ref, o).has_noise);
}

TEST(ImageCompare, RejectsMismatchedImages) {
  const io::Image a = noisy(16, 3);
  io::Image small(10, 10, {"R", "G", "B"});
  io::Image grey(200, 100, {"Y"});
  EXPECT_THROW(render::compareImages(a, small, {}), Error);
  EXPECT_THROW(render::compareImages(grey, a, {}), Error);
}

TEST(ImageCompare, CommandLine) {
  const auto dir = std::filesystem::temp_directory_path() / "lensim_compare_test";
  std::filesystem::create_directories(dir);
  const std::string ref = (dir / "ref.exr").string(), a = (dir / "a.exr").string(),
                    b = (dir / "b.exr").string();
  io::writeImage(ref, noisy(1024, 1));
  io::writeImage(a, noisy(16, 3, 0.2));
  io::writeImage(b, noisy(16, 4));
  // One shifted block: the family-wise z-test fails it, exit status 1.
  const auto r = test::runLensim("compare " + a + " " + ref + " --second " + b +
                                 " --spp 16 --reference-spp 1024 --json");
  ASSERT_EQ(r.status, 1) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["blocks"], 200);
  EXPECT_EQ(j["z_failures"], 1);
  EXPECT_EQ(j["failing_blocks"][0]["bx"], 5);
  EXPECT_EQ(j["verdict"], "fail");
  // Allowing 1% of the blocks (2 of 200) to fail passes it.
  const auto tolerant = test::runLensim("compare " + a + " " + ref + " --second " + b +
                                        " --spp 16 --reference-spp 1024 --max-fail-share 0.01");
  EXPECT_EQ(tolerant.status, 0) << tolerant.out;
  EXPECT_NE(tolerant.out.find("verdict: PASS (1 of 200 blocks beyond the z bound"),
            std::string::npos)
      << tolerant.out;
  // An unshifted render of the same scene passes.
  const std::string a2 = (dir / "a2.exr").string();
  io::writeImage(a2, noisy(16, 3));
  const auto pass = test::runLensim("compare " + a2 + " " + ref + " --second " + b +
                                    " --spp 16 --reference-spp 1024");
  EXPECT_EQ(pass.status, 0) << pass.out;
  EXPECT_NE(pass.out.find("verdict: PASS (0 of 200"), std::string::npos) << pass.out;
  // Without a second render: no z-test, the verdict is by --tolerance on the means.
  const auto text = test::runLensim("compare " + a + " " + ref);
  EXPECT_NE(text.out.find("no z-test"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("verdict: "), std::string::npos) << text.out;
  const auto strict = test::runLensim("compare " + a + " " + ref + " --tolerance 0");
  EXPECT_EQ(strict.status, 1) << strict.out;
  EXPECT_NE(strict.out.find("verdict: FAIL (no noise estimate"), std::string::npos) << strict.out;
  const auto loose = test::runLensim("compare " + a + " " + ref + " --tolerance 0.5");
  EXPECT_EQ(loose.status, 0) << loose.out;
  const auto missing = test::runLensim("compare " + a + " " + (dir / "none.exr").string());
  EXPECT_EQ(missing.status, 1);
  EXPECT_NE(missing.out.find("none.exr"), std::string::npos) << missing.out;
}
