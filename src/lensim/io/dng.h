// A raw DNG writer (Adobe DNG 1.4 specification) on libtiff: one uncompressed 16-bit CFA (or
// monochrome LinearRaw) image with the colour and exposure metadata raw developers need.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace lensim::io {

struct DngImage {
  int width = 0, height = 0;
  std::vector<uint16_t> data;            ///< width x height DN, row-major
  bool mono = false;                     ///< LinearRaw with one sample (no CFA, no colour)
  /// CFARepeatPatternDim (columns x rows, each 1 to 8) and CFAPattern (TIFF/EP colour codes: 0
  /// red, 1 green, 2 blue, 6 white), row-major.
  int cfa_width = 2, cfa_height = 2;
  std::vector<uint8_t> cfa{0, 1, 1, 2};
  /// A CFA with white (W, panchromatic) pixels has four colour planes (CFAPlaneColor red, green,
  /// blue, white): the W plane's row of ColorMatrix1/2 (XYZ -> W) and its AsShotNeutral entry;
  /// ForwardMatrix1/2 get a zero fourth column.
  std::array<double, 3> w_color_row1{}, w_color_row2{};
  double w_neutral = 1;
  int bits = 14;
  uint32_t black_level = 0, white_level = 16383;
  std::array<double, 9> color_matrix1{}, color_matrix2{};      ///< XYZ -> camera
  std::array<double, 9> forward_matrix1{}, forward_matrix2{};  ///< camera -> XYZ D50
  std::array<double, 3> as_shot_neutral{1, 1, 1};
  int illuminant1 = 17, illuminant2 = 21;  ///< EXIF LightSource codes (A, D65)
  std::string make = "lensim", model = "lensim sensor", unique_model = "lensim sensor";
  std::string software = "lensim";
  std::string description;  ///< ImageDescription (not written if empty)
  // EXIF (0: not written).
  double exposure_s = 0, f_number = 0, focal_length_mm = 0, iso = 0;
  std::string lens_model;
};

/// Reads an uncompressed 16-bit DNG with one CFA (red, green, blue, and white with CFAPlaneColor
/// red, green, blue, white; up to 8x8) or LinearRaw image in its first directory, as writeDng
/// writes them (colour matrices: ColorMatrix2, else ColorMatrix1, into color_matrix2 and
/// w_color_row2); throws lensim::Error naming the file and what is unsupported otherwise.
DngImage readDng(const std::string& path);

/// Writes `image` to `path` (atomically: a temporary file renamed into place); throws
/// lensim::Error on failure.
void writeDng(const std::string& path, const DngImage& image);

}  // namespace lensim::io
