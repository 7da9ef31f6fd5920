// Images in memory and on disk. Reading goes through OpenImageIO for every format it knows
// (EXR, PNG, TIFF, TGA, PFM, HDR, JPEG, BMP, GIF, PNM, ...); writing goes through OpenImageIO
// for PNG, TIFF, PFM, HDR, JPEG and TGA, and through OpenEXR for EXR (see writeExr in image.cpp).
//
// Pixel values in memory are always linear floats. Conversions (pbrt-v4's conventions,
// src/pbrt/util/image.cpp, Image::Read and its readers):
//   float data (EXR half/float, PFM, HDR, float TIFF): linear as stored; PFM rows are stored
//     bottom to top and scaled by |scale| (the scale's sign gives the byte order), HDR is RGBE.
//   8-bit data (PNG, TGA, JPEG, 8-bit TIFF, ...): sRGB-encoded unless ImageReadOptions::encoding
//     says otherwise ("linear", "gamma g"), or the file itself says it is linear (a PNG gAMA of 1).
//   16-bit data: PNG like 8-bit (pbrt-v4 applies the encoding to 16-bit PNGs); 16-bit TIFF and
//     the rest linear (lensim writes 16-bit TIFFs linear), unless the encoding says otherwise.
//   Alpha is never decoded and never premultiplied.
// On disk when writing:
//   .exr          32-bit float per channel, any channel names, string metadata in the header.
//   .tif/.tiff    16-bit unsigned (linear, clamped to [0,1]) or 32-bit IEEE float.
//   .png/.tga     8-bit, sRGB transfer curve, clamped to [0,1], with alpha if the image has A.
//   .jpg/.jpeg    8-bit sRGB (quality 95), no alpha.
//   .pfm          32-bit float, R,G,B or Y, no alpha.   .hdr  RGBE (Radiance), R,G,B, no alpha.
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
  /// EXR: 16-bit HALF channels instead of 32-bit FLOAT (pbrt-v4's Film "savefp16"). Values
  /// beyond half's largest finite value (65504) are written as +-65504, with a warning that
  /// counts them, never as infinities.
  bool exr_half = false;
};

/// Image file formats lensim writes.
enum class ImageFormat { Exr, Tiff, Png, Pfm, Hdr, Jpeg, Tga };

/// The format to write for a path's extension (case-insensitive); throws lensim::Error for others.
ImageFormat imageFormatFromPath(const std::string& path);

/// Options for readImage.
struct ImageReadOptions {
  /// How 8- and 16-bit pixel values become linear: "sRGB", "linear" or "gamma g" (value^g), as
  /// pbrt-v4's "encoding" parameter; empty: the file's own convention (see the top of this file).
  /// Float data is always linear and ignores it.
  std::string encoding;
};

/// Reads an image file into linear floats (see the top of this file). NaN and infinite values are
/// read as 0 (with a warning). Throws lensim::Error naming the file (with OpenImageIO's reason)
/// if it is missing, not a regular file, unreadable, corrupt, of an unknown format, or larger
/// than the memory budget allows (checked from the header, before the pixels are read).
Image readImage(const std::string& path, const ImageReadOptions& options = {});

/// Writes `image` to `path` in the format its extension names, atomically (temporary file in the
/// same directory, then rename). Formats other than EXR need channels R,G,B (optionally A) or Y.
/// Throws lensim::Error naming the file on failure and leaves no file behind.
void writeImage(const std::string& path, const Image& image, const ImageWriteOptions& options = {});

/// sRGB transfer curve: linear [0,1] -> encoded [0,1] (IEC 61966-2-1), and its inverse.
float linearToSrgb(float linear);
float srgbToLinear(float encoded);

}  // namespace lensim::io
