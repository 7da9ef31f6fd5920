#include "lensim/io/exr_window.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>
#include <fmt/format.h>

#include <cstddef>
#include <filesystem>

#include "lensim/util/error.h"
#include "lensim/util/file.h"

namespace lensim::io {

namespace {

// Slices address pixels with absolute data-window coordinates: the base pointer is offset so
// that (x0, y0) lands on the first value.
template <typename T>
char* sliceBase(const T* data, int x0, int y0, int width) {
  return (char*)(data) - (static_cast<ptrdiff_t>(x0) + static_cast<ptrdiff_t>(y0) * width) *
                             static_cast<ptrdiff_t>(sizeof(T));
}

}  // namespace

void writeExrWindow(const std::string& path, const ExrWindowFile& f) {
  const size_t n = static_cast<size_t>(f.width) * static_cast<size_t>(f.height);
  if (f.width <= 0 || f.height <= 0 || f.display_width <= 0 || f.display_height <= 0)
    throw Error(FileLoc{path}, "cannot write an empty image");
  for (const auto& [name, v] : f.float_channels)
    if (v.size() != n)
      throw Error(FileLoc{path}, fmt::format("channel {} has the wrong size", name));
  for (const auto& [name, v] : f.uint_channels)
    if (v.size() != n)
      throw Error(FileLoc{path}, fmt::format("channel {} has the wrong size", name));
  writeAtomically(path, [&](const std::string& tmp) {
    try {
      const Imath::Box2i display(Imath::V2i(0, 0),
                                 Imath::V2i(f.display_width - 1, f.display_height - 1));
      const Imath::Box2i data(Imath::V2i(f.x0, f.y0),
                              Imath::V2i(f.x0 + f.width - 1, f.y0 + f.height - 1));
      Imf::Header header(display, data);
      header.compression() = Imf::ZIP_COMPRESSION;
      for (const auto& [key, value] : f.metadata) header.insert(key, Imf::StringAttribute(value));
      Imf::FrameBuffer fb;
      for (const auto& [name, v] : f.float_channels) {
        header.channels().insert(name, Imf::Channel(Imf::FLOAT));
        fb.insert(name, Imf::Slice(Imf::FLOAT, sliceBase(v.data(), f.x0, f.y0, f.width),
                                   sizeof(float), sizeof(float) * f.width));
      }
      for (const auto& [name, v] : f.uint_channels) {
        header.channels().insert(name, Imf::Channel(Imf::UINT));
        fb.insert(name, Imf::Slice(Imf::UINT, sliceBase(v.data(), f.x0, f.y0, f.width),
                                   sizeof(uint32_t), sizeof(uint32_t) * f.width));
      }
      Imf::OutputFile out(tmp.c_str(), header);
      out.setFrameBuffer(fb);
      out.writePixels(f.height);
    } catch (const Error&) {
      throw;
    } catch (const std::exception& e) {
      throw Error(FileLoc{path}, fmt::format("cannot write EXR file: {}", e.what()));
    }
  });
}

ExrWindowFile readExrWindow(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw Error(FileLoc{path}, "no such file");
  try {
    Imf::InputFile in(path.c_str());
    const Imf::Header& h = in.header();
    ExrWindowFile f;
    const Imath::Box2i dw = h.dataWindow(), disp = h.displayWindow();
    f.display_width = disp.max.x - disp.min.x + 1;
    f.display_height = disp.max.y - disp.min.y + 1;
    f.x0 = dw.min.x, f.y0 = dw.min.y;
    f.width = dw.max.x - dw.min.x + 1, f.height = dw.max.y - dw.min.y + 1;
    const size_t n = static_cast<size_t>(f.width) * static_cast<size_t>(f.height);
    Imf::FrameBuffer fb;
    for (auto it = h.channels().begin(); it != h.channels().end(); ++it) {
      if (it.channel().xSampling != 1 || it.channel().ySampling != 1)
        throw Error(FileLoc{path}, fmt::format("channel {} is subsampled", it.name()));
      if (it.channel().type == Imf::UINT) {
        auto& v = f.uint_channels[it.name()];
        v.assign(n, 0);
        fb.insert(it.name(), Imf::Slice(Imf::UINT, sliceBase(v.data(), f.x0, f.y0, f.width),
                                        sizeof(uint32_t), sizeof(uint32_t) * f.width));
      } else {
        auto& v = f.float_channels[it.name()];
        v.assign(n, 0.0f);
        fb.insert(it.name(), Imf::Slice(Imf::FLOAT, sliceBase(v.data(), f.x0, f.y0, f.width),
                                        sizeof(float), sizeof(float) * f.width));
      }
    }
    in.setFrameBuffer(fb);
    in.readPixels(dw.min.y, dw.max.y);
    for (auto it = h.begin(); it != h.end(); ++it)
      if (const auto* s = dynamic_cast<const Imf::StringAttribute*>(&it.attribute()))
        f.metadata[it.name()] = s->value();
    return f;
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw Error(FileLoc{path}, fmt::format("cannot read EXR file: {}", e.what()));
  }
}

}  // namespace lensim::io
