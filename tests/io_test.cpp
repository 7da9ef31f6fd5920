// Round trips and failure behaviour of lensim::io image files.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include <unistd.h>

#include <png.h>
#include <tiffio.h>

#include "lensim/io/image.h"
#include "lensim/util/error.h"

namespace fs = std::filesystem;
using lensim::io::Image;

namespace {

// A fresh empty directory per test under the build tree's temp dir.
fs::path scratchDir(const std::string& name) {
  fs::path dir =
      fs::temp_directory_path() / ("lensim_io_test_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

Image randomImage(int w, int h, std::vector<std::string> channels, float lo, float hi,
                  unsigned seed) {
  Image img(w, h, std::move(channels));
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(lo, hi);
  for (float& v : img.pixels) v = u(rng);
  return img;
}

int filesIn(const fs::path& dir) {
  int n = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++n;
  return n;
}

double maxAbsDiff(const Image& a, const Image& b) {
  double m = 0;
  for (size_t i = 0; i < a.pixels.size(); ++i)
    m = std::max(m, std::abs(double(a.pixels[i]) - double(b.pixels[i])));
  return m;
}

}  // namespace

TEST(Image, ExrRoundTripIsExactWithChannelsAndMetadata) {
  const fs::path dir = scratchDir("exr");
  Image img = randomImage(37, 23, {"R", "G", "B", "A", "depth"}, -2.0f, 100.0f, 1);
  img.metadata["lensim:partial"] = "17/64 spp";
  const std::string path = (dir / "a.exr").string();
  lensim::io::writeImage(path, img);
  const Image back = lensim::io::readImage(path);
  ASSERT_EQ(back.width, 37);
  ASSERT_EQ(back.height, 23);
  ASSERT_EQ(back.channels, img.channels);
  EXPECT_EQ(maxAbsDiff(img, back), 0.0);
  EXPECT_EQ(back.metadata.at("lensim:partial"), "17/64 spp");
  EXPECT_EQ(filesIn(dir), 1);
  fs::remove_all(dir);
}

TEST(Image, TiffFloatRoundTripIsExact) {
  const fs::path dir = scratchDir("tiff32");
  const Image img = randomImage(40, 31, {"R", "G", "B"}, -1.0f, 50.0f, 2);
  const std::string path = (dir / "a.tif").string();
  lensim::io::writeImage(path, img, {lensim::io::TiffSampleFormat::Float32});
  const Image back = lensim::io::readImage(path);
  ASSERT_EQ(back.channels, img.channels);
  ASSERT_EQ(back.width, 40);
  EXPECT_EQ(maxAbsDiff(img, back), 0.0);
  fs::remove_all(dir);
}

TEST(Image, Tiff16BitRoundTripWithinQuantisation) {
  const fs::path dir = scratchDir("tiff16");
  const Image img = randomImage(33, 17, {"R", "G", "B", "A"}, 0.0f, 1.0f, 3);
  const std::string path = (dir / "a.tiff").string();
  lensim::io::writeImage(path, img, {lensim::io::TiffSampleFormat::UInt16});
  const Image back = lensim::io::readImage(path);
  ASSERT_EQ(back.channels, img.channels);
  EXPECT_LE(maxAbsDiff(img, back), 0.5 / 65535.0 + 1e-7);
  fs::remove_all(dir);
}

TEST(Image, PngRoundTripWithinSrgbQuantisationAndClamps) {
  const fs::path dir = scratchDir("png");
  Image img = randomImage(29, 19, {"R", "G", "B"}, 0.0f, 1.0f, 4);
  img.at(0, 0, 0) = 7.0f;   // clamps to 1
  img.at(1, 0, 1) = -3.0f;  // clamps to 0
  const std::string path = (dir / "a.png").string();
  lensim::io::writeImage(path, img);
  const Image back = lensim::io::readImage(path);
  ASSERT_EQ(back.channels, img.channels);
  EXPECT_FLOAT_EQ(back.at(0, 0, 0), 1.0f);
  EXPECT_FLOAT_EQ(back.at(1, 0, 1), 0.0f);
  // Quantisation happens in the encoded domain: compare there, half a code value.
  double worst = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x)
      for (int c = 0; c < 3; ++c) {
        const float a = lensim::io::linearToSrgb(std::clamp(img.at(x, y, c), 0.0f, 1.0f));
        const float b = lensim::io::linearToSrgb(back.at(x, y, c));
        worst = std::max(worst, std::abs(double(a) - b));
      }
  EXPECT_LE(worst, 0.5 / 255.0 + 1e-5);
  fs::remove_all(dir);
}

TEST(Image, SrgbCurveInvertsAndMatchesKnownPoints) {
  for (float v = 0; v <= 1.0f; v += 0.01f)
    EXPECT_NEAR(lensim::io::srgbToLinear(lensim::io::linearToSrgb(v)), v, 1e-6f);
  EXPECT_NEAR(lensim::io::linearToSrgb(0.18f), 0.4613561f, 1e-5f);  // IEC 61966-2-1 curve
  EXPECT_FLOAT_EQ(lensim::io::linearToSrgb(1.0f), 1.0f);
}

TEST(Image, WriteReplacesExistingFileAndLeavesNoTemporary) {
  const fs::path dir = scratchDir("replace");
  const std::string path = (dir / "out.exr").string();
  lensim::io::writeImage(path, randomImage(8, 8, {"R", "G", "B"}, 0, 1, 5));
  const Image second = randomImage(4, 2, {"R", "G", "B"}, 0, 1, 6);
  lensim::io::writeImage(path, second);
  EXPECT_EQ(lensim::io::readImage(path).width, 4);
  EXPECT_EQ(filesIn(dir), 1);
  fs::remove_all(dir);
}

TEST(Image, UnwritablePathThrowsAndLeavesNoFile) {
  const fs::path dir = scratchDir("unwritable");
  for (const char* name : {"a.exr", "a.tif", "a.png"}) {
    const fs::path path = dir / "missing-subdir" / name;
    EXPECT_THROW(lensim::io::writeImage(path.string(), randomImage(4, 4, {"R", "G", "B"}, 0, 1, 7)),
                 lensim::Error);
    EXPECT_FALSE(fs::exists(path));
  }
  EXPECT_EQ(filesIn(dir), 0);
  fs::remove_all(dir);
}

TEST(Image, FailedRenameLeavesNoTemporaryBehind) {
  const fs::path dir = scratchDir("failed");
  // The destination is a directory: the temporary file is written, the rename fails.
  fs::create_directory(dir / "a.exr");
  EXPECT_THROW(
      lensim::io::writeImage((dir / "a.exr").string(), randomImage(4, 4, {"R", "G", "B"}, 0, 1, 8)),
      lensim::Error);
  EXPECT_EQ(filesIn(dir), 1);  // only the directory
  EXPECT_TRUE(fs::is_directory(dir / "a.exr"));
  // PNG cannot store an image without colour channels.
  EXPECT_THROW(lensim::io::writeImage((dir / "b.png").string(), Image(4, 4, {"depth"})),
               lensim::Error);
  EXPECT_EQ(filesIn(dir), 1);
  fs::remove_all(dir);
}

TEST(Image, BadFilesGiveErrorsNamingTheFile) {
  const fs::path dir = scratchDir("bad");
  for (const char* name : {"bad.exr", "bad.tif", "bad.png"}) {
    const std::string path = (dir / name).string();
    std::ofstream(path) << "this is not an image";
    try {
      lensim::io::readImage(path);
      ADD_FAILURE() << "no error for " << path;
    } catch (const lensim::Error& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(lensim::io::readImage((dir / "absent.exr").string()), lensim::Error);
  EXPECT_THROW(lensim::io::readImage((dir / "a.bmp").string()), lensim::Error);
  fs::remove_all(dir);
}

// Files lensim does not write itself but must read: 8-bit TIFF (sRGB-encoded) and 16-bit PNG.
TEST(Image, Reads8BitTiffAsSrgb) {
  const fs::path dir = scratchDir("tiff8");
  const std::string path = (dir / "a.tif").string();
  TIFF* t = TIFFOpen(path.c_str(), "w");
  ASSERT_NE(t, nullptr);
  TIFFSetField(t, TIFFTAG_IMAGEWIDTH, 2u);
  TIFFSetField(t, TIFFTAG_IMAGELENGTH, 1u);
  TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, uint16_t(3));
  TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, uint16_t(8));
  TIFFSetField(t, TIFFTAG_PLANARCONFIG, uint16_t(PLANARCONFIG_CONTIG));
  TIFFSetField(t, TIFFTAG_PHOTOMETRIC, uint16_t(PHOTOMETRIC_RGB));
  unsigned char row[6] = {0, 128, 255, 10, 20, 30};
  ASSERT_GE(TIFFWriteScanline(t, row, 0, 0), 0);
  TIFFClose(t);
  const Image img = lensim::io::readImage(path);
  ASSERT_EQ(img.channels, (std::vector<std::string>{"R", "G", "B"}));
  EXPECT_FLOAT_EQ(img.at(0, 0, 0), 0.0f);
  EXPECT_NEAR(img.at(0, 0, 1), lensim::io::srgbToLinear(128 / 255.0f), 1e-6);
  EXPECT_FLOAT_EQ(img.at(0, 0, 2), 1.0f);
  EXPECT_NEAR(img.at(1, 0, 2), lensim::io::srgbToLinear(30 / 255.0f), 1e-6);
  fs::remove_all(dir);
}

TEST(Image, Reads16BitAndGreyPng) {
  const fs::path dir = scratchDir("png16");
  const std::string path = (dir / "a.png").string();
  // 16-bit grey, linear values as libpng's simplified API writes them (with a gAMA of 1.0).
  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  png.width = 3;
  png.height = 1;
  png.format = PNG_FORMAT_LINEAR_Y;
  const uint16_t values[3] = {0, 16384, 65535};
  ASSERT_TRUE(png_image_write_to_file(&png, path.c_str(), 0, values, 0, nullptr)) << png.message;
  const Image img = lensim::io::readImage(path);
  ASSERT_EQ(img.channels, (std::vector<std::string>{"Y"}));
  EXPECT_FLOAT_EQ(img.at(0, 0, 0), 0.0f);
  EXPECT_NEAR(img.at(1, 0, 0), 16384 / 65535.0f, 2e-4);
  EXPECT_FLOAT_EQ(img.at(2, 0, 0), 1.0f);
  fs::remove_all(dir);
}

// The other formats lensim writes (through OpenImageIO): TGA keeps alpha, HDR is RGBE (8-bit
// mantissas: relative error below 2^-8 of the pixel's largest channel), JPEG is lossy.
TEST(Image, TgaHdrAndJpegRoundTrips) {
  const fs::path dir = scratchDir("more");
  Image rgba = randomImage(21, 13, {"R", "G", "B", "A"}, 0.0f, 1.0f, 11);
  const std::string tga = (dir / "a.tga").string();
  lensim::io::writeImage(tga, rgba);
  const Image t = lensim::io::readImage(tga);
  ASSERT_EQ(t.channels, rgba.channels);
  for (size_t i = 0; i < t.pixels.size(); ++i) {
    const bool alpha = i % 4 == 3;
    const float want = alpha ? rgba.pixels[i] : lensim::io::linearToSrgb(rgba.pixels[i]);
    const float got = alpha ? t.pixels[i] : lensim::io::linearToSrgb(t.pixels[i]);
    EXPECT_NEAR(got, want, 0.5 / 255.0 + 1e-5) << i;
  }

  Image hdr = randomImage(17, 9, {"R", "G", "B"}, 0.0f, 50.0f, 12);
  const std::string h = (dir / "a.hdr").string();
  lensim::io::writeImage(h, hdr);
  const Image hb = lensim::io::readImage(h);
  ASSERT_EQ(hb.channels, hdr.channels);
  for (int y = 0; y < hdr.height; ++y)
    for (int x = 0; x < hdr.width; ++x) {
      const float m = std::max({hdr.at(x, y, 0), hdr.at(x, y, 1), hdr.at(x, y, 2)});
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(hb.at(x, y, c), hdr.at(x, y, c), m / 128.0);
    }

  Image smooth(32, 16, {"R", "G", "B"});
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 32; ++x) {
      smooth.at(x, y, 0) = 0.2f + 0.5f * x / 32.0f;
      smooth.at(x, y, 1) = 0.4f;
      smooth.at(x, y, 2) = 0.1f + 0.3f * y / 16.0f;
    }
  const std::string j = (dir / "a.jpg").string();
  lensim::io::writeImage(j, smooth);
  const Image jb = lensim::io::readImage(j);
  ASSERT_EQ(jb.width, 32);
  double worst = 0, sum = 0;
  for (size_t i = 0; i < jb.pixels.size(); ++i) {
    const double e = std::abs(double(lensim::io::linearToSrgb(jb.pixels[i])) -
                              lensim::io::linearToSrgb(smooth.pixels[i]));
    worst = std::max(worst, e);
    sum += e;
  }
  // Quality 95 on smooth gradients (chroma subsampled: the worst code off by a few).
  EXPECT_LT(sum / jb.pixels.size(), 1.0 / 255.0);
  EXPECT_LT(worst, 8.0 / 255.0);
  fs::remove_all(dir);
}
