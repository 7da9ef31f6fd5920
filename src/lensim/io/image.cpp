#include "lensim/io/image.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>
#include <png.h>
#include <tiffio.h>

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>

#include <fmt/format.h>

#include "lensim/util/error.h"
#include "lensim/util/file.h"
#include "lensim/util/limits.h"
#include "lensim/util/log.h"
#include "lensim/util/text.h"

namespace lensim::io {

namespace fs = std::filesystem;

Image::Image(int width_px, int height_px, std::vector<std::string> channel_names)
    : width(width_px), height(height_px), channels(std::move(channel_names)) {
  if (width < 0 || height < 0) throw Error(fmt::format("bad image size {}x{}", width, height));
  // Sizes come from file headers: check the buffer against the memory budget before allocating.
  checkMemory(4.0 * width * height * static_cast<double>(channels.size()), FileLoc{},
              fmt::format("a {}x{} image with {} channels", width, height, channels.size()));
  pixels.assign(static_cast<size_t>(width) * height * channels.size(), 0.0f);
}

std::optional<int> Image::channelIndex(std::string_view name) const {
  for (size_t i = 0; i < channels.size(); ++i)
    if (channels[i] == name) return static_cast<int>(i);
  return std::nullopt;
}

float linearToSrgb(float v) {
  if (!(v > 0.0f)) return 0.0f;  // also maps NaN to 0
  if (v <= 0.0031308f) return 12.92f * v;
  return 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

float srgbToLinear(float v) {
  if (v <= 0.04045f) return v / 12.92f;
  return std::pow((v + 0.055f) / 1.055f, 2.4f);
}

ImageFormat imageFormatFromPath(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  if (ext == ".exr") return ImageFormat::Exr;
  if (ext == ".tif" || ext == ".tiff") return ImageFormat::Tiff;
  if (ext == ".png") return ImageFormat::Png;
  throw Error(
      FileLoc{path},
      fmt::format("unsupported image extension \"{}\" (use .exr, .tif, .tiff or .png)", ext));
}

namespace {

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  throw Error(FileLoc{path}, what);
}

// ---------------------------------------------------------------------------------------------
// Channel selection for the 8/16-bit formats, which only know grey, grey+alpha, RGB and RGBA.

struct ColorLayout {
  std::vector<int> source;  // channel indices in the Image, in file order
  bool has_alpha = false;
};

ColorLayout colorLayout(const Image& image, const std::string& path) {
  ColorLayout l;
  auto r = image.channelIndex("R"), g = image.channelIndex("G"), b = image.channelIndex("B");
  auto y = image.channelIndex("Y"), a = image.channelIndex("A");
  if (r && g && b)
    l.source = {*r, *g, *b};
  else if (y)
    l.source = {*y};
  else
    fail(path, "image needs channels R,G,B or Y to be written in this format");
  if (a) {
    l.source.push_back(*a);
    l.has_alpha = true;
  }
  return l;
}

std::vector<std::string> colorChannelNames(int samples, bool alpha_last) {
  std::vector<std::string> names;
  if (samples == 1 || (samples == 2 && alpha_last))
    names = {"Y"};
  else
    names = {"R", "G", "B"};
  while (static_cast<int>(names.size()) < samples) {
    if (alpha_last && static_cast<int>(names.size()) == samples - 1)
      names.push_back("A");
    else
      names.push_back(fmt::format("C{}", names.size()));
  }
  return names;
}

// ---------------------------------------------------------------------------------------------
// OpenEXR

void writeExr(const std::string& path, const Image& image) {
  Imf::Header header(image.width, image.height);
  header.compression() = Imf::ZIP_COMPRESSION;
  for (const auto& [key, value] : image.metadata) header.insert(key, Imf::StringAttribute(value));
  Imf::FrameBuffer fb;
  const size_t nc = image.channels.size();
  for (size_t c = 0; c < nc; ++c) {
    header.channels().insert(image.channels[c], Imf::Channel(Imf::FLOAT));
    fb.insert(image.channels[c], Imf::Slice(Imf::FLOAT, (char*)(image.pixels.data() + c),
                                            sizeof(float) * nc, sizeof(float) * nc * image.width));
  }
  Imf::OutputFile file(path.c_str(), header);
  file.setFrameBuffer(fb);
  file.writePixels(image.height);
}

// OpenEXR allocates each header attribute at the size the file claims before reading it, so a
// 347-byte file claiming a 1.9 GB string attribute costs 1.9 GB (found by fuzzing). Walk the
// header(s) first and refuse attribute sizes that do not fit in the file.
void checkExrHeader(const std::string& path) {
  std::string data = readRegularFile(path, "EXR file", uint64_t{16} << 30);
  const size_t n = data.size();
  if (n < 8) fail(path, "not an OpenEXR file (too short)");
  const bool multipart = (static_cast<unsigned char>(data[5]) & 0x10) != 0;
  size_t pos = 8;
  auto cstring = [&](const char* what) {
    const size_t end = data.find('\0', pos);
    if (end == std::string::npos || end - pos > 255)
      fail(path, fmt::format("bad EXR header: unterminated {}", what));
    std::string out = data.substr(pos, end - pos);
    pos = end + 1;
    return out;
  };
  auto int32At = [&](size_t at) {
    if (at + 4 > n) fail(path, "bad EXR header: truncated");
    int32_t v = 0;
    std::memcpy(&v, data.data() + at, 4);  // little-endian, as the format says
    return v;
  };
  // OpenEXR reads each attribute by its type, not by the size the file gives: fixed types take
  // their own size, a channel list runs to its empty name; strings, vectors, previews and unknown
  // types allocate what they claim. Follow it the same way.
  static const std::map<std::string, size_t> fixed = {
      {"box2i", 16}, {"box2f", 16}, {"compression", 1}, {"lineOrder", 1}, {"float", 4},
      {"double", 8}, {"int", 4}, {"v2i", 8}, {"v2f", 8}, {"v2d", 16}, {"v3i", 12}, {"v3f", 12},
      {"v3d", 24}, {"m33f", 36}, {"m44f", 64}, {"m33d", 72}, {"m44d", 128},
      {"chromaticities", 32}, {"envmap", 1}, {"keycode", 28}, {"timecode", 8}, {"rational", 8},
      {"tiledesc", 9}, {"deepImageState", 1}};
  for (int header = 0; header < 1000; ++header) {
    for (;;) {
      const std::string name = cstring("attribute name");
      if (name.empty()) break;
      const std::string type = cstring("attribute type");
      const int32_t size = int32At(pos);
      pos += 4;
      if (size < 0 || static_cast<size_t>(size) > n - pos)
        fail(path, fmt::format("bad EXR header: attribute \"{}\" claims {} bytes, but the file "
                               "has only {} after it",
                               shortToken(name), size, n - pos));
      if (auto it = fixed.find(type); it != fixed.end()) {
        pos += it->second;
      } else if (type == "chlist") {
        for (;;) {
          if (cstring("channel name").empty()) break;
          pos += 16;  // pixel type, pLinear, reserved, x and y sampling
        }
      } else if (type == "preview") {
        const int64_t w = static_cast<uint32_t>(int32At(pos)), h = static_cast<uint32_t>(int32At(pos + 4));
        if (w * h * 4 > static_cast<int64_t>(n - pos))
          fail(path, fmt::format("bad EXR header: a {}x{} preview image in a {}-byte file", w, h,
                                 n));
        pos += 8 + static_cast<size_t>(w * h * 4);
      } else {
        pos += static_cast<size_t>(size);  // string, stringvector, floatvector, unknown types
      }
      if (pos > n) fail(path, "bad EXR header: truncated");
    }
    // Multi-part files: headers follow one another until an empty one.
    if (!multipart || pos >= n || data[pos] == '\0') return;
  }
}

Image readExr(const std::string& path) {
  checkExrHeader(path);
  Imf::InputFile file(path.c_str());
  const Imath::Box2i dw = file.header().dataWindow();
  // In 64 bits: a data window from INT_MIN to INT_MAX must not wrap around.
  const int64_t w64 = int64_t{dw.max.x} - dw.min.x + 1, h64 = int64_t{dw.max.y} - dw.min.y + 1;
  if (w64 <= 0 || h64 <= 0 || w64 > 1000000 || h64 > 1000000)
    fail(path, fmt::format("bad EXR data window {}x{}", w64, h64));
  const int w = static_cast<int>(w64), h = static_cast<int>(h64);
  // RGBA first in that order, then the other channels in the file's (alphabetical) order.
  std::vector<std::string> names;
  for (const char* n : {"R", "G", "B", "A"})
    if (file.header().channels().findChannel(n)) names.push_back(n);
  for (auto it = file.header().channels().begin(); it != file.header().channels().end(); ++it)
    if (std::find(names.begin(), names.end(), it.name()) == names.end()) names.push_back(it.name());
  Image image(w, h, names);
  const size_t nc = names.size();
  Imf::FrameBuffer fb;
  // Slices are addressed with absolute data-window coordinates.
  char* base = (char*)(image.pixels.data()) -
               (static_cast<ptrdiff_t>(dw.min.x) + static_cast<ptrdiff_t>(dw.min.y) * w) *
                   static_cast<ptrdiff_t>(sizeof(float) * nc);
  for (size_t c = 0; c < nc; ++c)
    fb.insert(names[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float), sizeof(float) * nc,
                                   sizeof(float) * nc * w));
  file.setFrameBuffer(fb);
  file.readPixels(dw.min.y, dw.max.y);
  for (auto it = file.header().begin(); it != file.header().end(); ++it)
    if (const auto* s = dynamic_cast<const Imf::StringAttribute*>(&it.attribute()))
      image.metadata[it.name()] = s->value();
  return image;
}

// ---------------------------------------------------------------------------------------------
// libtiff. Messages go to a per-file string instead of libtiff's default stderr printing.

int tiffMessage(TIFF*, void* user, const char* module, const char* format, va_list args) {
  char buf[512];
  std::vsnprintf(buf, sizeof buf, format, args);
  auto* out = static_cast<std::string*>(user);
  if (out->empty()) *out = module && *module ? fmt::format("{}: {}", module, buf) : buf;
  return 1;
}
int tiffIgnore(TIFF*, void*, const char*, const char*, va_list) {
  return 1;
}

struct TiffCloser {
  void operator()(TIFF* t) const { TIFFClose(t); }
};

std::unique_ptr<TIFF, TiffCloser> openTiff(const std::string& path, const char* mode,
                                           std::string* errors) {
  TIFFOpenOptions* opts = TIFFOpenOptionsAlloc();
  TIFFOpenOptionsSetErrorHandlerExtR(opts, tiffMessage, errors);
  TIFFOpenOptionsSetWarningHandlerExtR(opts, tiffIgnore, nullptr);
  TIFF* t = TIFFOpenExt(path.c_str(), mode, opts);
  TIFFOpenOptionsFree(opts);
  if (!t) fail(path, errors->empty() ? "cannot open TIFF file" : *errors);
  return std::unique_ptr<TIFF, TiffCloser>(t);
}

void writeTiff(const std::string& path, const Image& image, TiffSampleFormat format) {
  const ColorLayout layout = colorLayout(image, path);
  const int spp = static_cast<int>(layout.source.size());
  const bool is_float = format == TiffSampleFormat::Float32;
  std::string errors;
  auto tif = openTiff(path, "w", &errors);
  TIFF* t = tif.get();
  TIFFSetField(t, TIFFTAG_IMAGEWIDTH, static_cast<uint32_t>(image.width));
  TIFFSetField(t, TIFFTAG_IMAGELENGTH, static_cast<uint32_t>(image.height));
  TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, static_cast<uint16_t>(spp));
  TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, static_cast<uint16_t>(is_float ? 32 : 16));
  TIFFSetField(t, TIFFTAG_SAMPLEFORMAT,
               static_cast<uint16_t>(is_float ? SAMPLEFORMAT_IEEEFP : SAMPLEFORMAT_UINT));
  TIFFSetField(t, TIFFTAG_PLANARCONFIG, static_cast<uint16_t>(PLANARCONFIG_CONTIG));
  TIFFSetField(t, TIFFTAG_PHOTOMETRIC,
               static_cast<uint16_t>(spp >= 3 ? PHOTOMETRIC_RGB : PHOTOMETRIC_MINISBLACK));
  TIFFSetField(t, TIFFTAG_COMPRESSION, static_cast<uint16_t>(COMPRESSION_ADOBE_DEFLATE));
  TIFFSetField(t, TIFFTAG_ORIENTATION, static_cast<uint16_t>(ORIENTATION_TOPLEFT));
  TIFFSetField(t, TIFFTAG_ROWSPERSTRIP, TIFFDefaultStripSize(t, 0));
  if (layout.has_alpha) {
    uint16_t extra = EXTRASAMPLE_UNASSALPHA;
    TIFFSetField(t, TIFFTAG_EXTRASAMPLES, static_cast<uint16_t>(1), &extra);
  }
  std::vector<float> row_f(static_cast<size_t>(image.width) * spp);
  std::vector<uint16_t> row_u(row_f.size());
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < spp; ++c) {
        const float v = image.at(x, y, layout.source[c]);
        row_f[x * spp + c] = v;
        row_u[x * spp + c] = static_cast<uint16_t>(
            std::lround(std::clamp(std::isnan(v) ? 0.0f : v, 0.0f, 1.0f) * 65535.0f));
      }
    void* row = is_float ? static_cast<void*>(row_f.data()) : static_cast<void*>(row_u.data());
    if (TIFFWriteScanline(t, row, static_cast<uint32_t>(y), 0) < 0)
      fail(path, errors.empty() ? "cannot write TIFF scanline" : errors);
  }
  if (!TIFFFlush(t)) fail(path, errors.empty() ? "cannot write TIFF file" : errors);
}

Image readTiff(const std::string& path) {
  std::string errors;
  auto tif = openTiff(path, "r", &errors);
  TIFF* t = tif.get();
  uint32_t w = 0, h = 0;
  uint16_t spp = 1, bps = 8, sample_format = SAMPLEFORMAT_UINT, planar = PLANARCONFIG_CONTIG;
  uint16_t extra_count = 0;
  uint16_t* extra_types = nullptr;
  TIFFGetField(t, TIFFTAG_IMAGEWIDTH, &w);
  TIFFGetField(t, TIFFTAG_IMAGELENGTH, &h);
  TIFFGetFieldDefaulted(t, TIFFTAG_SAMPLESPERPIXEL, &spp);
  TIFFGetFieldDefaulted(t, TIFFTAG_BITSPERSAMPLE, &bps);
  TIFFGetFieldDefaulted(t, TIFFTAG_SAMPLEFORMAT, &sample_format);
  TIFFGetFieldDefaulted(t, TIFFTAG_PLANARCONFIG, &planar);
  TIFFGetFieldDefaulted(t, TIFFTAG_EXTRASAMPLES, &extra_count, &extra_types);
  if (TIFFIsTiled(t)) fail(path, "tiled TIFF files are not supported");
  if (planar != PLANARCONFIG_CONTIG) fail(path, "planar (separate) TIFF files are not supported");
  const bool u8 = bps == 8 && sample_format == SAMPLEFORMAT_UINT;
  const bool u16 = bps == 16 && sample_format == SAMPLEFORMAT_UINT;
  const bool f32 = bps == 32 && sample_format == SAMPLEFORMAT_IEEEFP;
  if (!u8 && !u16 && !f32)
    fail(path,
         fmt::format("unsupported TIFF sample format ({} bits, format {})", bps, sample_format));
  if (w == 0 || h == 0 || spp == 0) fail(path, "empty TIFF image");
  if (w > 1000000 || h > 1000000) fail(path, fmt::format("bad TIFF image size {}x{}", w, h));
  Image image(static_cast<int>(w), static_cast<int>(h), colorChannelNames(spp, extra_count > 0));
  std::vector<unsigned char> row(TIFFScanlineSize(t));
  if (row.size() < static_cast<size_t>(w) * spp * (bps / 8)) fail(path, "bad TIFF scanline size");
  for (uint32_t y = 0; y < h; ++y) {
    if (TIFFReadScanline(t, row.data(), y, 0) < 0)
      fail(path, errors.empty() ? "cannot read TIFF scanline" : errors);
    for (uint32_t i = 0; i < w * spp; ++i) {
      float v;
      const bool alpha = extra_count > 0 && i % spp == spp - 1u;
      if (u8) {
        v = row[i] / 255.0f;
        if (!alpha) v = srgbToLinear(v);  // 8-bit TIFFs are display-encoded (sRGB)
      } else if (u16) {
        uint16_t s;
        std::memcpy(&s, row.data() + 2 * i, 2);
        v = s / 65535.0f;
      } else {
        std::memcpy(&v, row.data() + 4 * i, 4);
      }
      image.pixels[static_cast<size_t>(y) * w * spp + i] = v;
    }
  }
  return image;
}

// ---------------------------------------------------------------------------------------------
// libpng (simplified API of libpng 1.6)

void writePng(const std::string& path, const Image& image) {
  const ColorLayout layout = colorLayout(image, path);
  const int spp = static_cast<int>(layout.source.size());
  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  png.width = static_cast<png_uint_32>(image.width);
  png.height = static_cast<png_uint_32>(image.height);
  png.format =
      (spp >= 3 ? PNG_FORMAT_FLAG_COLOR : 0) | (layout.has_alpha ? PNG_FORMAT_FLAG_ALPHA : 0);
  std::vector<png_byte> bytes(static_cast<size_t>(image.width) * image.height * spp);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < spp; ++c) {
        float v = image.at(x, y, layout.source[c]);
        v = std::clamp(std::isnan(v) ? 0.0f : v, 0.0f, 1.0f);
        const bool alpha = layout.has_alpha && c == spp - 1;
        if (!alpha) v = linearToSrgb(v);
        bytes[(static_cast<size_t>(y) * image.width + x) * spp + c] =
            static_cast<png_byte>(std::lround(v * 255.0f));
      }
  if (!png_image_write_to_file(&png, path.c_str(), 0, bytes.data(), 0, nullptr)) {
    std::string msg = png.message;
    png_image_free(&png);
    fail(path, "cannot write PNG: " + msg);
  }
}

Image readPng(const std::string& path) {
  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&png, path.c_str())) {
    std::string msg = png.message;
    png_image_free(&png);
    fail(path, "cannot read PNG: " + msg);
  }
  const bool wide = png.format & PNG_FORMAT_FLAG_LINEAR;  // 16-bit file
  png.format &= ~(PNG_FORMAT_FLAG_COLORMAP | PNG_FORMAT_FLAG_AFIRST | PNG_FORMAT_FLAG_BGR);
  const int spp = PNG_IMAGE_SAMPLE_CHANNELS(png.format);
  const bool alpha = png.format & PNG_FORMAT_FLAG_ALPHA;
  std::optional<Image> checked;
  try {
    checked.emplace(static_cast<int>(png.width), static_cast<int>(png.height),
                    colorChannelNames(spp, alpha));
  } catch (...) {
    png_image_free(&png);  // the memory budget refused the size the header claims
    throw;
  }
  Image& image = *checked;
  std::vector<png_byte> bytes(PNG_IMAGE_SIZE(png));
  if (!png_image_finish_read(&png, nullptr, bytes.data(), 0, nullptr)) {
    std::string msg = png.message;
    png_image_free(&png);
    fail(path, "cannot read PNG: " + msg);
  }
  const size_t n = image.pixels.size();
  for (size_t i = 0; i < n; ++i) {
    const bool is_alpha = alpha && static_cast<int>(i % spp) == spp - 1;
    if (wide) {
      // 16-bit: libpng returns linear values (alpha premultiplied; undo that).
      uint16_t s;
      std::memcpy(&s, bytes.data() + 2 * i, 2);
      image.pixels[i] = s / 65535.0f;
    } else {
      const float v = bytes[i] / 255.0f;
      image.pixels[i] = is_alpha ? v : srgbToLinear(v);
    }
  }
  if (wide && alpha) {
    for (size_t p = 0; p < n; p += spp) {
      const float a = image.pixels[p + spp - 1];
      for (int c = 0; c < spp - 1; ++c)
        image.pixels[p + c] = a > 0 ? image.pixels[p + c] / a : 0.0f;
    }
  }
  return image;
}

}  // namespace

namespace {
Image readImageAsIs(const std::string& path);
}  // namespace

Image readImage(const std::string& path) {
  Image image = readImageAsIs(path);
  // Every number read from a file is finite: NaN and infinite pixels (EXR, float TIFF) become 0,
  // with a warning, so that textures, environment maps and their sampling tables stay finite.
  size_t bad = 0;
  for (float& v : image.pixels)
    if (!std::isfinite(v)) v = 0, ++bad;
  if (bad)
    logWarning(fmt::format("{}: {} NaN or infinite pixel values read as 0", path, bad));
  return image;
}

namespace {

Image readImageAsIs(const std::string& path) {
  const ImageFormat format = imageFormatFromPath(path);
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) fail(path, "no such image file");
  try {
    switch (format) {
      case ImageFormat::Exr:
        return readExr(path);
      case ImageFormat::Tiff:
        return readTiff(path);
      case ImageFormat::Png:
        return readPng(path);
    }
  } catch (const Error& e) {
    if (!e.loc().valid()) fail(path, e.message());  // e.g. the memory budget: name the file
    throw;
  } catch (const std::exception& e) {
    fail(path, fmt::format("cannot read image: {}", e.what()));
  }
  fail(path, "unknown image format");
}

}  // namespace

void writeImage(const std::string& path, const Image& image, const ImageWriteOptions& options) {
  const ImageFormat format = imageFormatFromPath(path);
  if (image.pixels.size() !=
      static_cast<size_t>(image.width) * image.height * image.channels.size())
    fail(path, "image pixel buffer does not match its size and channels");
  if (image.width <= 0 || image.height <= 0) fail(path, "cannot write an empty image");
  writeAtomically(path, [&](const std::string& tmp) {
    switch (format) {
      case ImageFormat::Exr: {
        writeExr(tmp, image);
        // OpenEXR finishes the file (line offsets) in a destructor that swallows errors: read it
        // back, so that a full disk is an error and not a truncated image.
        bool complete = false;
        try {
          complete = Imf::InputFile(tmp.c_str()).isComplete();
        } catch (const std::exception&) {
        }
        if (!complete) fail(path, "writing failed: the written EXR file is incomplete (disk full?)");
        break;
      }
      case ImageFormat::Tiff:
        writeTiff(tmp, image, options.tiff_format);
        break;
      case ImageFormat::Png:
        writePng(tmp, image);
        break;
    }
  });
}

}  // namespace lensim::io
