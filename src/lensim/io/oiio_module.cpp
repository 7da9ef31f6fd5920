// The OpenImageIO module (liblensim_oiio.so): see oiio_module.h. Loaded with dlopen by image.cpp.
#include "lensim/io/oiio_module.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <memory>
#include <string>
#include <vector>

namespace lensim::io::oiio {
namespace {

using OIIO::ImageInput;
using OIIO::ImageOutput;
using OIIO::ImageSpec;
using OIIO::TypeDesc;

std::string trimmed(std::string t) {
  while (!t.empty() && (t.back() == '\n' || t.back() == ' ')) t.pop_back();
  return t.empty() ? "unknown error" : t;
}

TypeDesc typeOf(PixelType t) {
  switch (t) {
    case PixelType::UInt8:
      return TypeDesc::UINT8;
    case PixelType::UInt16:
      return TypeDesc::UINT16;
    case PixelType::UInt32:
      return TypeDesc::UINT32;
    case PixelType::Float:
      return TypeDesc::FLOAT;
  }
  return TypeDesc::FLOAT;
}

void* openImage(const std::string& path, Spec* out, std::string* error) {
  ImageSpec config;
  // Alpha as stored: OpenImageIO would premultiply PNG, TGA and TIFF colours by it otherwise.
  config.attribute("oiio:UnassociatedAlpha", 1);
  std::unique_ptr<ImageInput> in = ImageInput::open(path, &config);
  if (!in) {
    *error = trimmed(OIIO::geterror());
    return nullptr;
  }
  const ImageSpec& s = in->spec();
  out->width = s.width;
  out->height = s.height;
  out->nchannels = s.nchannels;
  out->alpha_channel = s.alpha_channel;
  out->deep = s.deep;
  out->is_float = s.format.is_floating_point();
  out->bytes_per_channel = static_cast<int>(s.format.size());
  out->bits_per_sample = s.get_int_attribute("oiio:BitsPerSample", out->bytes_per_channel * 8);
  out->format = in->format_name();
  out->color_space = s.get_string_attribute("oiio:ColorSpace");
  out->channel_names.assign(s.channelnames.begin(), s.channelnames.end());
  out->channel_is_uint32.assign(s.nchannels, false);
  for (int c = 0; c < s.nchannels; ++c) {
    const TypeDesc t =
        c < static_cast<int>(s.channelformats.size()) ? s.channelformats[c] : s.format;
    out->channel_is_uint32[c] = t.basetype == TypeDesc::UINT32 || t.basetype == TypeDesc::INT32;
  }
  return in.release();
}

bool readImage(void* reader, PixelType type, void* data, std::string* error) {
  auto* in = static_cast<ImageInput*>(reader);
  const ImageSpec& s = in->spec();
  const TypeDesc t = typeOf(type);
  if (s.channelformats.empty()) {
    // Read the file's own pixel type (TypeDesc::UNKNOWN: straight into the buffer), then
    // convert. Any other request makes OpenImageIO 2.4's read_scanlines convert through a
    // temporary of 64 MB whatever the image's size (imageinput.cpp, "try to use around 64 MB";
    // heaptrack: 67 MB at the peak for a 2x2 texture); the native copy costs the image's own
    // size (half of the float image for half data).
    const size_t values = size_t(s.image_pixels()) * size_t(s.nchannels);
    std::vector<char> native(values * s.format.size());
    if (!in->read_image(0, 0, 0, s.nchannels, TypeDesc::UNKNOWN, native.data())) {
      *error = trimmed(in->geterror());
      return false;
    }
    constexpr size_t kChunk = size_t(1) << 24;  // convert_pixel_values counts in int
    for (size_t i = 0; i < values; i += kChunk) {
      const int n = int(std::min(kChunk, values - i));
      if (!OIIO::convert_pixel_values(s.format, native.data() + i * s.format.size(), t,
                                      static_cast<char*>(data) + i * t.size(), n)) {
        *error = "cannot convert the file's pixel values";
        return false;
      }
    }
    return true;
  }
  if (in->read_image(0, 0, 0, s.nchannels, t, data)) return true;
  *error = trimmed(in->geterror());
  return false;
}

void closeImage(void* reader) {
  auto* in = static_cast<ImageInput*>(reader);
  in->close();
  (void)in->geterror();  // OpenImageIO complains at exit about errors nobody collected
  delete in;
}

bool writeImage(const std::string& path, const WriteSpec& w, const void* data, std::string* error) {
  const TypeDesc type = typeOf(w.type);
  ImageSpec spec(w.width, w.height, static_cast<int>(w.channel_names.size()), type);
  spec.channelnames = w.channel_names;
  spec.alpha_channel = w.alpha_channel;
  if (w.alpha_channel >= 0) spec.attribute("oiio:UnassociatedAlpha", 1);  // never un-premultiply
  if (!w.color_space.empty()) spec.attribute("oiio:ColorSpace", w.color_space);
  if (!w.compression.empty()) spec.attribute("compression", w.compression);
  std::unique_ptr<ImageOutput> out = ImageOutput::create(path);
  if (!out) {
    *error = trimmed(OIIO::geterror());
    return false;
  }
  bool ok = out->open(path, spec) && out->write_image(type, data);
  ok = out->close() && ok;
  if (!ok) *error = trimmed(out->geterror());
  return ok;
}

const Api kApi = {kApiVersion, openImage, readImage, closeImage, writeImage};

}  // namespace
}  // namespace lensim::io::oiio

extern "C" __attribute__((visibility("default"))) const lensim::io::oiio::Api* lensim_oiio_api() {
  return &lensim::io::oiio::kApi;
}
