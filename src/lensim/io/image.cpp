#include "lensim/io/image.h"

#include <Imath/half.h>
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>
#include <dlfcn.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string_view>

#include <fmt/format.h>

#include "lensim/io/oiio_module.h"
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

namespace {

std::string lowerExtension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext;
}

}  // namespace

ImageFormat imageFormatFromPath(const std::string& path) {
  const std::string ext = lowerExtension(path);
  if (ext == ".exr") return ImageFormat::Exr;
  if (ext == ".tif" || ext == ".tiff") return ImageFormat::Tiff;
  if (ext == ".png") return ImageFormat::Png;
  if (ext == ".pfm") return ImageFormat::Pfm;
  if (ext == ".hdr") return ImageFormat::Hdr;
  if (ext == ".jpg" || ext == ".jpeg") return ImageFormat::Jpeg;
  if (ext == ".tga") return ImageFormat::Tga;
  throw Error(FileLoc{path},
              fmt::format("unsupported image extension \"{}\" for writing (use .exr, .tif, .tiff, "
                          ".png, .pfm, .hdr, .jpg, .jpeg or .tga)",
                          ext));
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
// OpenEXR. EXR files are written with OpenEXR itself, not OpenImageIO: lensim's EXR header is
// exactly the image's channels as 32-bit FLOAT (spectral films have dozens), ZIP compression and
// the image's string attributes under their own names ("lensim:spp_range", ...), which the part
// merger, checkpoints and `lensim compare` read back. OpenImageIO's EXR writer renames attributes
// it knows under other names (an attribute "DateTime" is written as EXR's capDate, "Copyright" as
// owner, ...; checked with OIIO 2.4), so the metadata would not come back as written; and the
// channel layout and the incomplete-file check below are what lensim's EXR readers rely on.

// With `half` (Film "savefp16" true) the channels are 16-bit HALF, as pbrt-v4 writes them
// (src/pbrt/film.cpp, RGBFilm::GetImage: PixelFormat::Half when writeFP16); `report_as` names
// the file in the warning about values clamped to half's range.
void writeExr(const std::string& path, const std::string& report_as, const Image& image,
              bool half) {
  Imf::Header header(image.width, image.height);
  header.compression() = Imf::ZIP_COMPRESSION;
  for (const auto& [key, value] : image.metadata) header.insert(key, Imf::StringAttribute(value));
  Imf::FrameBuffer fb;
  const size_t nc = image.channels.size();
  std::vector<Imath::half> halves;
  if (half) {
    // Half's largest finite value; anything larger in magnitude would become an infinity.
    constexpr float kHalfMax = 65504.0f;
    halves.resize(image.pixels.size());
    size_t clamped_values = 0, clamped_pixels = 0;
    for (size_t p = 0; p < image.pixels.size(); p += nc) {
      bool pixel_clamped = false;
      for (size_t c = 0; c < nc; ++c) {
        float v = image.pixels[p + c];
        if (!std::isfinite(v)) v = 0;  // never written (the renderer writes such values as 0)
        if (std::abs(v) > kHalfMax) {
          v = std::copysign(kHalfMax, v);
          ++clamped_values;
          pixel_clamped = true;
        }
        halves[p + c] = Imath::half(v);
      }
      clamped_pixels += pixel_clamped;
    }
    if (clamped_values > 0)
      logWarning(
          fmt::format("{}: {} pixels ({} values) exceed the half-float range of a "
                      "\"savefp16\" EXR and are written as +-65504",
                      report_as, clamped_pixels, clamped_values));
  }
  for (size_t c = 0; c < nc; ++c) {
    if (half) {
      header.channels().insert(image.channels[c], Imf::Channel(Imf::HALF));
      fb.insert(image.channels[c],
                Imf::Slice(Imf::HALF, (char*)(halves.data() + c), sizeof(Imath::half) * nc,
                           sizeof(Imath::half) * nc * image.width));
      continue;
    }
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
      {"box2i", 16},    {"box2f", 16},   {"compression", 1},
      {"lineOrder", 1}, {"float", 4},    {"double", 8},
      {"int", 4},       {"v2i", 8},      {"v2f", 8},
      {"v2d", 16},      {"v3i", 12},     {"v3f", 12},
      {"v3d", 24},      {"m33f", 36},    {"m44f", 64},
      {"m33d", 72},     {"m44d", 128},   {"chromaticities", 32},
      {"envmap", 1},    {"keycode", 28}, {"timecode", 8},
      {"rational", 8},  {"tiledesc", 9}, {"deepImageState", 1}};
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
        const int64_t w = static_cast<uint32_t>(int32At(pos)),
                      h = static_cast<uint32_t>(int32At(pos + 4));
        if (w * h * 4 > static_cast<int64_t>(n - pos))
          fail(path,
               fmt::format("bad EXR header: a {}x{} preview image in a {}-byte file", w, h, n));
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

// The string attributes of an EXR file's first part, under their own names. Read with OpenEXR:
// OpenImageIO renames standard attributes and reports some non-string ones as strings (e.g.
// "compression"), so its spec cannot tell which strings the file holds.
std::map<std::string, std::string> exrStringAttributes(const std::string& path) {
  std::map<std::string, std::string> out;
  Imf::InputFile file(path.c_str());
  for (auto it = file.header().begin(); it != file.header().end(); ++it)
    if (const auto* s = dynamic_cast<const Imf::StringAttribute*>(&it.attribute()))
      out[it.name()] = s->value();
  return out;
}

// ---------------------------------------------------------------------------------------------
// The OpenImageIO module, loaded on first use (see oiio_module.h). Looked for in
// $LENSIM_OIIO_MODULE, beside the executable, in ../lib/lensim from it, and where this build put
// it.

const oiio::Api& oiioApi() {
  static const oiio::Api* api = nullptr;
  static std::string failure;
  static std::once_flag once;
  std::call_once(once, [] {
    std::vector<std::string> candidates;
    if (const char* env = std::getenv("LENSIM_OIIO_MODULE"); env && *env) candidates.push_back(env);
    std::error_code ec;
    const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
    if (!ec) {
      candidates.push_back((exe.parent_path() / "liblensim_oiio.so").string());
      candidates.push_back(
          (exe.parent_path() / ".." / "lib" / "lensim" / "liblensim_oiio.so").string());
    }
#ifdef LENSIM_OIIO_MODULE_PATH
    candidates.push_back(LENSIM_OIIO_MODULE_PATH);
#endif
    std::string tried;
    for (const std::string& c : candidates) {
      if (!fs::exists(c, ec)) {
        tried += fmt::format("{}{}", tried.empty() ? "" : ", ", c);
        continue;
      }
      void* handle = ::dlopen(c.c_str(), RTLD_NOW | RTLD_LOCAL);
      if (!handle) {
        failure = fmt::format("cannot load the OpenImageIO module {}: {}", c, ::dlerror());
        return;
      }
      auto entry = reinterpret_cast<const oiio::Api* (*)()>(::dlsym(handle, "lensim_oiio_api"));
      const oiio::Api* a = entry ? entry() : nullptr;
      if (!a || a->version != oiio::kApiVersion) {
        failure = fmt::format("the OpenImageIO module {} does not match this lensim", c);
        return;
      }
      api = a;
      return;
    }
    failure = fmt::format("the OpenImageIO module liblensim_oiio.so was not found (looked for {})",
                          tried);
  });
  if (!api) throw Error(failure);
  return *api;
}

// ---------------------------------------------------------------------------------------------
// Reading through OpenImageIO

// The transfer curve integer pixel values are decoded with.
struct Decoding {
  enum Kind { Linear, Srgb, Gamma } kind = Srgb;
  float gamma = 1;
  float operator()(float encoded) const {
    switch (kind) {
      case Linear:
        return encoded;
      case Srgb:
        return srgbToLinear(encoded);
      case Gamma:
        return std::pow(encoded, gamma);
    }
    return encoded;
  }
};

// The decoding for integer data: the caller's encoding if given (pbrt-v4 textures' "encoding",
// src/pbrt/textures.cpp, ColorEncoding::Get), else the file's convention (see image.h).
Decoding integerDecoding(const std::string& encoding, const oiio::Spec& spec,
                         const std::string& path) {
  Decoding d;
  if (encoding == "sRGB") return d;
  if (encoding == "linear") return {Decoding::Linear};
  if (encoding.rfind("gamma ", 0) == 0) {
    d.kind = Decoding::Gamma;
    char* end = nullptr;
    d.gamma = std::strtof(encoding.c_str() + 6, &end);
    if (end != encoding.c_str() + 6 && *end == '\0' && d.gamma > 0 && std::isfinite(d.gamma))
      return d;
  }
  if (!encoding.empty())
    fail(path, fmt::format("bad image encoding \"{}\"; expected \"sRGB\", \"linear\" or "
                           "\"gamma <positive number>\"",
                           encoding));
  // A file that says it is linear (a PNG with a gAMA of 1.0; OpenImageIO reports "Linear").
  std::string cs = spec.color_space;
  std::transform(cs.begin(), cs.end(), cs.begin(), [](unsigned char c) { return std::tolower(c); });
  if (cs == "linear") return {Decoding::Linear};
  // 8-bit data is display-encoded (pbrt-v4 reads PNG and the stb_image formats as sRGB, and so
  // does every paint program); pbrt-v4 decodes 16-bit PNGs with the same encoding (ReadPNG).
  // Other 16-bit files (TIFF, PNM) are read linearly, as lensim writes 16-bit TIFFs.
  if (spec.bytes_per_channel == 1 || spec.format == "png") return d;
  return {Decoding::Linear};
}

// EXR channels: R, G, B, A first in that order, then the others in the file's (alphabetical)
// order, as lensim has always returned them.
std::vector<std::string> exrChannelOrder(const std::vector<std::string>& names) {
  std::vector<std::string> out;
  for (const char* n : {"R", "G", "B", "A"})
    if (std::find(names.begin(), names.end(), n) != names.end()) out.push_back(n);
  std::vector<std::string> rest;
  for (const std::string& n : names)
    if (std::find(out.begin(), out.end(), n) == out.end()) rest.push_back(n);
  std::sort(rest.begin(), rest.end());
  out.insert(out.end(), rest.begin(), rest.end());
  return out;
}

Image readWithOiio(const std::string& path, const ImageReadOptions& options) {
  const bool exr = lowerExtension(path) == ".exr";
  if (exr) checkExrHeader(path);
  const oiio::Api& api = oiioApi();
  oiio::Spec spec;
  std::string error;
  void* reader = api.open(path, &spec, &error);
  if (!reader) fail(path, fmt::format("cannot read image: {}", error));
  struct Closer {
    const oiio::Api& api;
    void* reader;
    ~Closer() { api.close(reader); }
  } closer{api, reader};
  if (spec.deep) fail(path, "deep images are not supported");
  const int64_t w64 = spec.width, h64 = spec.height, nc = spec.nchannels;
  if (w64 <= 0 || h64 <= 0 || nc <= 0 || w64 > 1000000 || h64 > 1000000 || nc > 4096)
    fail(path, fmt::format("bad image size {}x{} with {} channels", w64, h64, nc));
  const int w = static_cast<int>(w64), h = static_cast<int>(h64);
  const bool any_uint32 = std::find(spec.channel_is_uint32.begin(), spec.channel_is_uint32.end(),
                                    true) != spec.channel_is_uint32.end();

  // Names and order in the Image; `from[i]`: the file channel of Image channel i.
  std::vector<std::string> names;
  std::vector<int> from(nc);
  if (exr) {
    names = exrChannelOrder(spec.channel_names);
    for (int i = 0; i < nc; ++i)
      from[i] = static_cast<int>(
          std::find(spec.channel_names.begin(), spec.channel_names.end(), names[i]) -
          spec.channel_names.begin());
  } else {
    names = colorChannelNames(static_cast<int>(nc), spec.alpha_channel == nc - 1 && nc != 3);
    for (int i = 0; i < nc; ++i) from[i] = i;
  }
  bool identity = true;
  for (int i = 0; i < nc; ++i) identity = identity && from[i] == i;

  // The memory budget is checked here, before any pixel is read (the size is the header's).
  Image image(w, h, names);
  const size_t count = image.pixels.size();
  auto readAll = [&](oiio::PixelType type, void* data) {
    if (!api.read(reader, type, data, &error))
      fail(path, fmt::format("cannot read image: {}", error));
  };
  auto permute = [&](auto convert) {
    for (size_t p = 0; p < count; p += nc)
      for (int i = 0; i < nc; ++i) image.pixels[p + i] = convert(p + from[i], from[i]);
  };
  auto checkSecondBuffer = [&] {
    checkMemory(8.0 * static_cast<double>(count), FileLoc{path},
                fmt::format("reading a {}x{} image with {} channels", w, h, nc));
  };
  if (spec.is_float && !any_uint32) {
    // Linear floats as stored (EXR half/float, PFM, HDR, float TIFF).
    if (identity) {
      readAll(oiio::PixelType::Float, image.pixels.data());
    } else {
      checkSecondBuffer();
      std::vector<float> buf(count);
      readAll(oiio::PixelType::Float, buf.data());
      permute([&](size_t k, int) { return buf[k]; });
    }
  } else if (any_uint32) {
    // EXR UINT channels (ids, sample counts) keep their values; OpenImageIO's conversion to
    // float would scale them to [0, 1].
    checkSecondBuffer();
    std::vector<float> f(count);
    readAll(oiio::PixelType::Float, f.data());
    std::vector<uint32_t> u(count);
    readAll(oiio::PixelType::UInt32, u.data());
    permute([&](size_t k, int c) {
      return spec.channel_is_uint32[c] ? static_cast<float>(u[k]) : f[k];
    });
  } else {
    // Integer data through a table of its 256 or 65536 codes, decoded with the transfer curve
    // (never alpha).
    const Decoding decode = integerDecoding(options.encoding, spec, path);
    const bool wide = spec.bytes_per_channel > 1;
    const int codes = wide ? 65536 : 256;
    std::vector<float> colour(codes), linear(codes);
    for (int k = 0; k < codes; ++k) {
      linear[k] = k / float(codes - 1);
      colour[k] = decode(linear[k]);
    }
    const int alpha = spec.alpha_channel;
    if (wide) {
      std::vector<uint16_t> buf(count);
      readAll(oiio::PixelType::UInt16, buf.data());
      permute([&](size_t k, int c) { return c == alpha ? linear[buf[k]] : colour[buf[k]]; });
    } else {
      std::vector<uint8_t> buf(count);
      readAll(oiio::PixelType::UInt8, buf.data());
      permute([&](size_t k, int c) { return c == alpha ? linear[buf[k]] : colour[buf[k]]; });
    }
  }
  if (exr) image.metadata = exrStringAttributes(path);
  return image;
}

// ---------------------------------------------------------------------------------------------
// PFM output. OpenImageIO 2.4 (Debian 12) reads PFM but has no PFM writer, so these few lines
// write it: "PF" (RGB) or "Pf" (grey), the size, a scale whose sign gives the byte order
// (negative: little-endian), then the rows bottom to top (as pbrt-v4's WritePFM,
// src/pbrt/util/image.cpp).

void writePfm(const std::string& path, const std::string& report_as, const Image& image,
              const std::vector<int>& source) {
  const int nc = static_cast<int>(source.size());
  std::string out = fmt::format("{}\n{} {}\n{}\n", nc == 3 ? "PF" : "Pf", image.width, image.height,
                                std::endian::native == std::endian::little ? "-1" : "1");
  const size_t header = out.size();
  out.resize(header + static_cast<size_t>(image.width) * image.height * nc * sizeof(float));
  char* p = out.data() + header;
  for (int y = image.height - 1; y >= 0; --y)
    for (int x = 0; x < image.width; ++x)
      for (int c : source) {
        const float v = image.at(x, y, c);
        std::memcpy(p, &v, sizeof v);
        p += sizeof v;
      }
  std::ofstream f(path, std::ios::binary);
  f.write(out.data(), static_cast<std::streamsize>(out.size()));
  f.close();
  if (!f) fail(report_as, fmt::format("cannot write image: {}", std::strerror(errno)));
}

// ---------------------------------------------------------------------------------------------
// Writing through OpenImageIO (all formats but EXR and PFM)

void writeWithOiio(const std::string& path, const std::string& report_as, const Image& image,
                   ImageFormat format, const ImageWriteOptions& options) {
  ColorLayout layout = colorLayout(image, report_as);
  // Formats without alpha (pbrt-v4 writes RGB only too); HDR stores exactly three channels.
  const bool alpha_ok =
      format == ImageFormat::Png || format == ImageFormat::Tiff || format == ImageFormat::Tga;
  if (layout.has_alpha && !alpha_ok) {
    layout.source.pop_back();
    layout.has_alpha = false;
  }
  if (format == ImageFormat::Pfm) {
    writePfm(path, report_as, image, layout.source);
    return;
  }
  if (format == ImageFormat::Hdr && layout.source.size() == 1)
    layout.source = {layout.source[0], layout.source[0], layout.source[0]};
  const int spp = static_cast<int>(layout.source.size());
  const int colour_channels = spp - (layout.has_alpha ? 1 : 0);

  const bool eight_bit =
      format == ImageFormat::Png || format == ImageFormat::Jpeg || format == ImageFormat::Tga;
  const bool sixteen =
      format == ImageFormat::Tiff && options.tiff_format == TiffSampleFormat::UInt16;
  oiio::WriteSpec spec;
  spec.width = image.width;
  spec.height = image.height;
  spec.type = eight_bit ? oiio::PixelType::UInt8
              : sixteen ? oiio::PixelType::UInt16
                        : oiio::PixelType::Float;
  spec.channel_names = colour_channels == 1 ? std::vector<std::string>{"Y"}
                                            : std::vector<std::string>{"R", "G", "B"};
  if (layout.has_alpha) {
    spec.channel_names.push_back("A");
    spec.alpha_channel = spp - 1;
  }
  if (eight_bit) spec.color_space = "sRGB";
  if (format == ImageFormat::Tiff) spec.compression = "zip";
  if (format == ImageFormat::Jpeg) spec.compression = "jpeg:95";

  // Interleaved pixels in the output type: 8-bit sRGB-encoded, 16-bit linear, or floats.
  const size_t n = static_cast<size_t>(image.width) * image.height * spp;
  std::vector<float> f(eight_bit || sixteen ? 0 : n);
  std::vector<uint8_t> u8(eight_bit ? n : 0);
  std::vector<uint16_t> u16(sixteen ? n : 0);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < spp; ++c) {
        const size_t i = (static_cast<size_t>(y) * image.width + x) * spp + c;
        const float v = image.at(x, y, layout.source[c]);
        const float clamped = std::clamp(std::isnan(v) ? 0.0f : v, 0.0f, 1.0f);
        if (eight_bit) {
          const bool alpha = layout.has_alpha && c == spp - 1;
          u8[i] =
              static_cast<uint8_t>(std::lround((alpha ? clamped : linearToSrgb(clamped)) * 255.0f));
        } else if (sixteen) {
          u16[i] = static_cast<uint16_t>(std::lround(clamped * 65535.0f));
        } else {
          f[i] = v;
        }
      }
  const void* data = eight_bit ? static_cast<const void*>(u8.data())
                     : sixteen ? static_cast<const void*>(u16.data())
                               : static_cast<const void*>(f.data());
  std::string error;
  if (!oiioApi().write(path, spec, data, &error))
    fail(report_as, fmt::format("cannot write image: {}", error));
}

}  // namespace

Image readImage(const std::string& path, const ImageReadOptions& options) {
  Image image;
  try {
    // Only regular files (a FIFO would hang the reader, /dev/zero never end); the size limit is
    // the EXR reader's, whose header check reads the whole file.
    requireRegularFile(path, "image file", uint64_t{16} << 30);
    image = readWithOiio(path, options);
  } catch (const Error& e) {
    if (!e.loc().valid()) fail(path, e.message());  // e.g. the memory budget: name the file
    throw;
  } catch (const std::exception& e) {
    fail(path, fmt::format("cannot read image: {}", e.what()));
  }
  // Every number read from a file is finite: NaN and infinite pixels (EXR, float TIFF) become 0,
  // with a warning, so that textures, environment maps and their sampling tables stay finite.
  size_t bad = 0;
  for (float& v : image.pixels)
    if (!std::isfinite(v)) v = 0, ++bad;
  if (bad) logWarning(fmt::format("{}: {} NaN or infinite pixel values read as 0", path, bad));
  return image;
}

void writeImage(const std::string& path, const Image& image, const ImageWriteOptions& options) {
  const ImageFormat format = imageFormatFromPath(path);
  if (image.pixels.size() !=
      static_cast<size_t>(image.width) * image.height * image.channels.size())
    fail(path, "image pixel buffer does not match its size and channels");
  if (image.width <= 0 || image.height <= 0) fail(path, "cannot write an empty image");
  if (format != ImageFormat::Exr) colorLayout(image, path);  // fail before creating a file
  writeAtomically(path, [&](const std::string& tmp) {
    if (format != ImageFormat::Exr) {
      writeWithOiio(tmp, path, image, format, options);
      return;
    }
    writeExr(tmp, path, image, options.exr_half);
    // OpenEXR finishes the file (line offsets) in a destructor that swallows errors: read it
    // back, so that a full disk is an error and not a truncated image.
    bool complete = false;
    try {
      complete = Imf::InputFile(tmp.c_str()).isComplete();
    } catch (const std::exception&) {
    }
    if (!complete) fail(path, "writing failed: the written EXR file is incomplete (disk full?)");
  });
}

}  // namespace lensim::io
