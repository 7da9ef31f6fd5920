// Images in memory and on disk (EXR, TIFF, PNG), chosen by file extension.
//
// Pixel values in memory are always linear floats. Encodings on disk:
//   .exr          32-bit float per channel, any channel names, string metadata in the header.
//   .tif/.tiff    write: 16-bit unsigned (linear, clamped to [0,1]) or 32-bit IEEE float;
//                 read: 8-bit (sRGB-encoded, decoded to linear), 16-bit (linear) or 32-bit float.
//   .png          write: 8-bit, sRGB transfer curve, clamped to [0,1];
//                 read: 8-bit (sRGB, decoded to linear) or 16-bit (linearised by libpng).
// Writes go to a temporary file in the destination directory that is renamed over the target,
// so a crash never leaves a half-written image under the final name.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace lensim::io {

/// A width x height raster of named float channels, stored interleaved, rows top to bottom.
/// Values are linear (no transfer curve) in whatever units the producer chose.
struct Image {
  int width = 0;
  int height = 0;
  /// Channel names, e.g. {"R", "G", "B"} or {"R", "G", "B", "A"} or {"Y"}.
  std::vector<std::string> channels;
  /// width * height * channels.size() values; pixel (x, y) channel c at (y*width + x)*nc + c.
  std::vector<float> pixels;
  /// String attributes; written to and read from EXR headers (e.g. "lensim:partial"),
  /// ignored by the other formats.
  std::map<std::string, std::string> metadata;

  Image() = default;
  /// A black image with the given channels.
  Image(int width_px, int height_px, std::vector<std::string> channel_names);

  int channelCount() const { return static_cast<int>(channels.size()); }
  /// Index of the channel called `name`, if any.
  std::optional<int> channelIndex(std::string_view name) const;
  float& at(int x, int y, int c) { return pixels[index(x, y, c)]; }
  float at(int x, int y, int c) const { return pixels[index(x, y, c)]; }

 private:
  size_t index(int x, int y, int c) const {
    return (static_cast<size_t>(y) * width + x) * channels.size() + c;
  }
};

/// Storage precision for TIFF output (other formats ignore it).
enum class TiffSampleFormat { UInt16, Float32 };

/// Options for writeImage.
struct ImageWriteOptions {
  TiffSampleFormat tiff_format = TiffSampleFormat::Float32;
};

/// Image file formats lensim reads and writes.
enum class ImageFormat { Exr, Tiff, Png };

/// The format for a path's extension (case-insensitive); throws lensim::Error for others.
ImageFormat imageFormatFromPath(const std::string& path);

/// Reads an EXR, TIFF or PNG file (by extension) into linear floats. NaN and infinite values are
/// read as 0 (with a warning). Throws lensim::Error naming the file if it is missing, unreadable,
/// unsupported or larger than the memory budget allows.
Image readImage(const std::string& path);

/// Writes `image` to `path` in the format its extension names, atomically (temporary file in the
/// same directory, then rename). PNG and TIFF need channels R,G,B (optionally A) or Y.
/// Throws lensim::Error naming the file on failure and leaves no file behind.
void writeImage(const std::string& path, const Image& image, const ImageWriteOptions& options = {});

/// sRGB transfer curve: linear [0,1] -> encoded [0,1] (IEC 61966-2-1), and its inverse.
float linearToSrgb(float linear);
float srgbToLinear(float encoded);

}  // namespace lensim::io
