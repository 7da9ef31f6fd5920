// EXR files whose pixels cover a window of a larger image (the data window inside the display
// window), with 32-bit float and 32-bit unsigned integer channels and string metadata: the
// format of the parts of a distributed render and of render checkpoints (see render/parts.h).
// Kept apart from image.h, whose Image is float-only and always starts at the origin.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace lensim::io {

struct ExrWindowFile {
  int display_width = 0, display_height = 0;  ///< the whole image
  int x0 = 0, y0 = 0, width = 0, height = 0;  ///< the data window (pixels stored)
  /// Float channels: name -> width * height values, rows top to bottom.
  std::map<std::string, std::vector<float>> float_channels;
  /// Unsigned 32-bit channels: name -> width * height values.
  std::map<std::string, std::vector<uint32_t>> uint_channels;
  std::map<std::string, std::string> metadata;  ///< string attributes
};

/// Writes `file` atomically (temporary file, then rename). Throws lensim::Error naming the path.
void writeExrWindow(const std::string& path, const ExrWindowFile& file);

/// Reads every channel of an EXR file as stored (FLOAT and HALF channels as float, UINT as
/// uint32) with its windows and string attributes. Throws lensim::Error naming the path.
ExrWindowFile readExrWindow(const std::string& path);

}  // namespace lensim::io
