// The interface between lensim's image I/O (image.cpp) and the OpenImageIO module
// (oiio_module.cpp, built as liblensim_oiio.so and loaded with dlopen on the first image read or
// write). OpenImageIO pulls in about 250 shared libraries (codecs, OpenCV, OpenVDB, ...) whose
// relocation costs 0.2 s of CPU at every start of a program linked with it (measured: `lensim
// --version` 204 ms instead of 7 ms of task-clock); loaded on demand, only runs that read or
// write an image pay it, once. The module links OpenImageIO only (no lensim library, so
// lensim's process-wide state such as the memory budget stays in one copy): it reports sizes and
// reads pixels, and image.cpp decides what to allocate and how to decode.
#pragma once

#include <string>
#include <vector>

namespace lensim::io::oiio {

/// Pixel types the module reads and writes.
enum class PixelType { UInt8, UInt16, UInt32, Float };

/// The header of an image file as OpenImageIO reports it (subimage 0, MIP level 0).
struct Spec {
  int width = 0, height = 0, nchannels = 0;  ///< the data window
  int alpha_channel = -1;
  bool deep = false;
  bool is_float = false;      ///< the widest channel type is floating point
  int bytes_per_channel = 1;  ///< of the widest channel type
  int bits_per_sample = 8;    ///< as stored (e.g. 8 for a palette PNG)
  std::string format;         ///< "png", "openexr", "targa", "pnm", "hdr", "jpeg", ...
  std::string color_space;    ///< oiio:ColorSpace, e.g. "sRGB", "Linear"
  std::vector<std::string> channel_names;
  std::vector<bool> channel_is_uint32;  ///< per channel: 32-bit integer (EXR UINT)
};

/// What to write: interleaved pixels of `type`, channels named as given.
struct WriteSpec {
  int width = 0, height = 0;
  std::vector<std::string> channel_names;
  int alpha_channel = -1;
  PixelType type = PixelType::Float;
  std::string color_space;  ///< "sRGB" for 8-bit output, empty otherwise
  std::string compression;  ///< e.g. "zip", "jpeg:95"; empty for the format's default
};

struct Api {
  int version;
  /// Opens `path` for reading; nullptr with `error` set on failure.
  void* (*open)(const std::string& path, Spec* spec, std::string* error);
  /// Reads all channels of the open image into `data` (width * height * nchannels of `type`;
  /// integer types keep their codes, floats as stored). False with `error` set on failure.
  bool (*read)(void* reader, PixelType type, void* data, std::string* error);
  void (*close)(void* reader);
  /// Writes `data` to `path` in the format its extension names. False with `error` set.
  bool (*write)(const std::string& path, const WriteSpec& spec, const void* data,
                std::string* error);
};

inline constexpr int kApiVersion = 1;

}  // namespace lensim::io::oiio

/// The module's entry point, looked up with dlsym.
extern "C" const lensim::io::oiio::Api* lensim_oiio_api();
