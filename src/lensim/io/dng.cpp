// DNG writing on libtiff (dng.h). libtiff knows most DNG tags; ForwardMatrix1/2 (DNG 1.2) it
// does not, so they are registered here with a tag extender.
#include "lensim/io/dng.h"

#include <algorithm>
#include <cstdarg>
#include <cstdio>
#include <mutex>

#include <fmt/format.h>
#include <tiffio.h>

#include "lensim/util/error.h"
#include "lensim/util/file.h"

namespace lensim::io {

namespace {

constexpr ttag_t kForwardMatrix1 = 50964, kForwardMatrix2 = 50965;
constexpr uint16_t kPhotometricLinearRaw = 34892;  // DNG 1.4, PhotometricInterpretation
constexpr uint8_t kCfaWhite = 6;  // TIFF/EP CFAPattern colour code of a white (W) filter

const TIFFFieldInfo kExtraFields[] = {
    {kForwardMatrix1, -1, -1, TIFF_SRATIONAL, FIELD_CUSTOM, 1, 1, const_cast<char*>("ForwardMatrix1")},
    {kForwardMatrix2, -1, -1, TIFF_SRATIONAL, FIELD_CUSTOM, 1, 1, const_cast<char*>("ForwardMatrix2")},
};

TIFFExtendProc g_parent_extender = nullptr;

// libtiff's messages, kept for lensim's own error instead of printed (while a DNG is read or
// written on this thread).
thread_local std::string t_tiff_message;
thread_local bool t_capture = false;
TIFFErrorHandler g_parent_error = nullptr, g_parent_warning = nullptr;

void captureMessage(const char* module, const char* fmt, va_list ap) {
  char buf[512];
  std::vsnprintf(buf, sizeof buf, fmt, ap);
  t_tiff_message = buf;
  (void)module;
}

void errorHandler(const char* module, const char* fmt, va_list ap) {
  if (t_capture) return captureMessage(module, fmt, ap);
  if (g_parent_error) g_parent_error(module, fmt, ap);
}

void warningHandler(const char* module, const char* fmt, va_list ap) {
  if (t_capture) return;  // unknown-tag warnings and the like: not the user's concern
  if (g_parent_warning) g_parent_warning(module, fmt, ap);
}

// Captures libtiff's messages for the scope's lifetime.
struct CaptureTiffMessages {
  CaptureTiffMessages() {
    t_capture = true;
    t_tiff_message.clear();
  }
  ~CaptureTiffMessages() { t_capture = false; }
  static std::string reason() {
    return t_tiff_message.empty() ? std::string() : " (" + t_tiff_message + ")";
  }
};

void extendTags(TIFF* tif) {
  TIFFMergeFieldInfo(tif, kExtraFields, sizeof(kExtraFields) / sizeof(kExtraFields[0]));
  if (g_parent_extender) g_parent_extender(tif);
}

void registerTags() {
  static std::once_flag once;
  std::call_once(once, [] {
    g_parent_extender = TIFFSetTagExtender(extendTags);
    g_parent_error = TIFFSetErrorHandler(errorHandler);
    g_parent_warning = TIFFSetWarningHandler(warningHandler);
  });
}

// libtiff's custom tags take (count, array) or only (array) depending on the field's definition;
// these helpers ask libtiff which and fail loudly instead of writing a wrong tag.
template <typename T>
void setArray(TIFF* tif, ttag_t tag, const T* values, int n, const std::string& path) {
  const TIFFField* f = TIFFFieldWithTag(tif, tag);
  int ok = 0;
  if (f && TIFFFieldPassCount(f))
    ok = TIFFSetField(tif, tag, uint16_t(n), values);
  else if (f)
    ok = TIFFSetField(tif, tag, values);
  if (!ok)
    throw Error(FileLoc{path}, fmt::format("libtiff cannot write DNG tag {}{}", tag,
                                           CaptureTiffMessages::reason()));
}

void setFloats(TIFF* tif, ttag_t tag, const double* v, int n, const std::string& path) {
  float f[16];
  for (int i = 0; i < n; ++i) f[i] = float(v[i]);
  setArray(tif, tag, f, n, path);
}

void check(int ok, const std::string& path, const char* what) {
  if (!ok)
    throw Error(FileLoc{path},
                fmt::format("writing the DNG failed: {}{}", what, CaptureTiffMessages::reason()));
}

void writeTo(const std::string& path, const DngImage& im) {
  registerTags();
  CaptureTiffMessages capture;
  TIFF* tif = TIFFOpen(path.c_str(), "w");
  if (!tif)
    throw Error(FileLoc{path}, "cannot create the DNG file" + CaptureTiffMessages::reason());
  struct Closer {
    TIFF* t;
    ~Closer() { TIFFClose(t); }
  } closer{tif};
  const uint8_t version[4] = {1, 4, 0, 0}, backward[4] = {1, 1, 0, 0};
  const bool has_w = !im.mono && std::find(im.cfa.begin(), im.cfa.end(), kCfaWhite) != im.cfa.end();
  check(TIFFSetField(tif, TIFFTAG_SUBFILETYPE, 0), path, "NewSubFileType");
  check(TIFFSetField(tif, TIFFTAG_IMAGEWIDTH, uint32_t(im.width)), path, "width");
  check(TIFFSetField(tif, TIFFTAG_IMAGELENGTH, uint32_t(im.height)), path, "height");
  check(TIFFSetField(tif, TIFFTAG_BITSPERSAMPLE, 16), path, "bits");
  check(TIFFSetField(tif, TIFFTAG_SAMPLESPERPIXEL, 1), path, "samples");
  check(TIFFSetField(tif, TIFFTAG_COMPRESSION, COMPRESSION_NONE), path, "compression");
  check(TIFFSetField(tif, TIFFTAG_PHOTOMETRIC,
                     im.mono ? kPhotometricLinearRaw : PHOTOMETRIC_CFA),
        path, "photometric");
  check(TIFFSetField(tif, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG), path, "planar");
  check(TIFFSetField(tif, TIFFTAG_ROWSPERSTRIP, uint32_t(im.height)), path, "rows per strip");
  check(TIFFSetField(tif, TIFFTAG_ORIENTATION, ORIENTATION_TOPLEFT), path, "orientation");
  check(TIFFSetField(tif, TIFFTAG_MAKE, im.make.c_str()), path, "make");
  check(TIFFSetField(tif, TIFFTAG_MODEL, im.model.c_str()), path, "model");
  check(TIFFSetField(tif, TIFFTAG_SOFTWARE, im.software.c_str()), path, "software");
  if (!im.description.empty())
    check(TIFFSetField(tif, TIFFTAG_IMAGEDESCRIPTION, im.description.c_str()), path,
          "ImageDescription");
  setArray(tif, TIFFTAG_DNGVERSION, version, 4, path);
  setArray(tif, TIFFTAG_DNGBACKWARDVERSION, backward, 4, path);
  check(TIFFSetField(tif, TIFFTAG_UNIQUECAMERAMODEL, im.unique_model.c_str()), path,
        "UniqueCameraModel");
  if (!im.mono) {
    if (im.cfa_width < 1 || im.cfa_width > 8 || im.cfa_height < 1 || im.cfa_height > 8 ||
        im.cfa.size() != size_t(im.cfa_width) * size_t(im.cfa_height))
      throw Error(FileLoc{path}, fmt::format("a {}x{} CFA pattern of {} colours; expected 1 to 8 "
                                             "columns and rows",
                                             im.cfa_width, im.cfa_height, im.cfa.size()));
    for (uint8_t c : im.cfa)
      if (c > 2 && c != kCfaWhite)
        throw Error(FileLoc{path}, fmt::format("CFA colour {}; expected 0 (red), 1 (green), 2 "
                                               "(blue) or 6 (white)",
                                               c));
    const uint16_t dim[2] = {uint16_t(im.cfa_height), uint16_t(im.cfa_width)};  // rows, columns
    setArray(tif, TIFFTAG_CFAREPEATPATTERNDIM, dim, 2, path);
    setArray(tif, TIFFTAG_CFAPATTERN, im.cfa.data(), int(im.cfa.size()), path);
    if (has_w) {
      const uint8_t planes[4] = {0, 1, 2, kCfaWhite};
      setArray(tif, TIFFTAG_CFAPLANECOLOR, planes, 4, path);
    }
  }
  const float black = float(im.black_level);
  setArray(tif, TIFFTAG_BLACKLEVEL, &black, 1, path);
  const uint32_t white = im.white_level;
  setArray(tif, TIFFTAG_WHITELEVEL, &white, 1, path);
  if (!im.mono) {
    // ColorMatrix: one row (XYZ) per plane; ForwardMatrix: one column per plane.
    const int planes = has_w ? 4 : 3;
    auto colorMatrix = [&](const std::array<double, 9>& m, const std::array<double, 3>& w) {
      std::array<double, 12> out{};
      std::copy(m.begin(), m.end(), out.begin());
      std::copy(w.begin(), w.end(), out.begin() + 9);
      return out;
    };
    auto forwardMatrix = [&](const std::array<double, 9>& m) {
      std::array<double, 12> out{};
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) out[size_t(r * planes + c)] = m[size_t(r * 3 + c)];
      return out;
    };
    setFloats(tif, TIFFTAG_COLORMATRIX1, colorMatrix(im.color_matrix1, im.w_color_row1).data(),
              3 * planes, path);
    setFloats(tif, TIFFTAG_COLORMATRIX2, colorMatrix(im.color_matrix2, im.w_color_row2).data(),
              3 * planes, path);
    setFloats(tif, kForwardMatrix1, forwardMatrix(im.forward_matrix1).data(), 3 * planes, path);
    setFloats(tif, kForwardMatrix2, forwardMatrix(im.forward_matrix2).data(), 3 * planes, path);
    const std::array<double, 4> neutral{im.as_shot_neutral[0], im.as_shot_neutral[1],
                                        im.as_shot_neutral[2], im.w_neutral};
    setFloats(tif, TIFFTAG_ASSHOTNEUTRAL, neutral.data(), planes, path);
    check(TIFFSetField(tif, TIFFTAG_CALIBRATIONILLUMINANT1, uint16_t(im.illuminant1)), path,
          "CalibrationIlluminant1");
    check(TIFFSetField(tif, TIFFTAG_CALIBRATIONILLUMINANT2, uint16_t(im.illuminant2)), path,
          "CalibrationIlluminant2");
  }
  const bool exif = im.exposure_s > 0 || im.f_number > 0 || im.focal_length_mm > 0 ||
                    im.iso > 0 || !im.lens_model.empty();
  if (exif) check(TIFFSetField(tif, TIFFTAG_EXIFIFD, uint64_t(0)), path, "ExifIFD");
  for (int y = 0; y < im.height; ++y)
    check(TIFFWriteScanline(tif, const_cast<uint16_t*>(im.data.data() + size_t(y) * size_t(im.width)),
                            uint32_t(y), 0) == 1,
          path, "image data");
  check(TIFFWriteDirectory(tif), path, "directory");
  if (!exif) return;
  // The EXIF IFD, then the main IFD rewritten to point at it.
  check(TIFFCreateEXIFDirectory(tif) == 0, path, "EXIF directory");
  if (im.exposure_s > 0)
    check(TIFFSetField(tif, EXIFTAG_EXPOSURETIME, im.exposure_s), path, "ExposureTime");
  if (im.f_number > 0) check(TIFFSetField(tif, EXIFTAG_FNUMBER, im.f_number), path, "FNumber");
  if (im.focal_length_mm > 0)
    check(TIFFSetField(tif, EXIFTAG_FOCALLENGTH, im.focal_length_mm), path, "FocalLength");
  if (im.iso > 0) {
    const uint16_t iso = uint16_t(std::min(65535.0, im.iso));
    check(TIFFSetField(tif, EXIFTAG_ISOSPEEDRATINGS, 1, &iso), path, "ISOSpeedRatings");
  }
  if (!im.lens_model.empty())
    check(TIFFSetField(tif, EXIFTAG_LENSMODEL, im.lens_model.c_str()), path, "LensModel");
  uint64_t exif_offset = 0;
  check(TIFFWriteCustomDirectory(tif, &exif_offset), path, "EXIF directory");
  check(TIFFSetDirectory(tif, 0), path, "main directory");
  check(TIFFSetField(tif, TIFFTAG_EXIFIFD, exif_offset), path, "ExifIFD");
  check(TIFFRewriteDirectory(tif), path, "main directory");
}

template <typename T>
bool getArray(TIFF* tif, ttag_t tag, const T*& values, int& n) {
  const TIFFField* f = TIFFFieldWithTag(tif, tag);
  if (!f) return false;
  void* p = nullptr;
  if (TIFFFieldPassCount(f)) {
    if (TIFFFieldReadCount(f) == TIFF_VARIABLE2) {
      uint32_t c = 0;
      if (!TIFFGetField(tif, tag, &c, &p)) return false;
      n = int(c);
    } else {
      uint16_t c = 0;
      if (!TIFFGetField(tif, tag, &c, &p)) return false;
      n = c;
    }
  } else {
    if (!TIFFGetField(tif, tag, &p)) return false;
    n = TIFFFieldReadCount(f);
  }
  values = static_cast<const T*>(p);
  return p != nullptr;
}

}  // namespace

DngImage readDng(const std::string& path) {
  registerTags();
  requireRegularFile(path, "DNG file");
  CaptureTiffMessages capture;
  TIFF* tif = TIFFOpen(path.c_str(), "r");
  if (!tif)
    throw Error(FileLoc{path}, "cannot read the file as TIFF/DNG" + CaptureTiffMessages::reason());
  struct Closer {
    TIFF* t;
    ~Closer() { TIFFClose(t); }
  } closer{tif};
  auto unsupported = [&](const std::string& what) {
    return Error(FileLoc{path}, fmt::format("unsupported DNG: {}; expected an uncompressed 16-bit "
                                            "CFA or LinearRaw image (as lensim writes)",
                                            what));
  };
  DngImage im;
  uint32_t w = 0, h = 0;
  uint16_t bits = 0, spp = 1, comp = 1, photometric = 0, planar = 1;
  TIFFGetField(tif, TIFFTAG_IMAGEWIDTH, &w);
  TIFFGetField(tif, TIFFTAG_IMAGELENGTH, &h);
  TIFFGetFieldDefaulted(tif, TIFFTAG_BITSPERSAMPLE, &bits);
  TIFFGetFieldDefaulted(tif, TIFFTAG_SAMPLESPERPIXEL, &spp);
  TIFFGetFieldDefaulted(tif, TIFFTAG_COMPRESSION, &comp);
  TIFFGetFieldDefaulted(tif, TIFFTAG_PLANARCONFIG, &planar);
  TIFFGetField(tif, TIFFTAG_PHOTOMETRIC, &photometric);
  if (bits != 16) throw unsupported(fmt::format("{} bits per sample", bits));
  if (spp != 1) throw unsupported(fmt::format("{} samples per pixel", spp));
  if (comp != COMPRESSION_NONE) throw unsupported(fmt::format("compression {}", comp));
  if (photometric != PHOTOMETRIC_CFA && photometric != kPhotometricLinearRaw)
    throw unsupported(fmt::format("photometric interpretation {}", photometric));
  if (w == 0 || h == 0 || uint64_t(w) * h > (uint64_t{1} << 28))
    throw unsupported(fmt::format("{}x{} pixels", w, h));
  im.width = int(w);
  im.height = int(h);
  im.mono = photometric == kPhotometricLinearRaw;
  im.data.resize(size_t(w) * h);
  if (TIFFScanlineSize64(tif) != uint64_t(w) * 2) throw unsupported("scanline layout");
  for (uint32_t y = 0; y < h; ++y)
    if (TIFFReadScanline(tif, im.data.data() + size_t(y) * w, y, 0) != 1)
      throw Error(FileLoc{path},
                  fmt::format("cannot read image row {}{}", y, CaptureTiffMessages::reason()));
  int n = 0;
  if (!im.mono) {
    const uint16_t* dim = nullptr;
    const uint8_t* pat = nullptr;
    if (!getArray(tif, TIFFTAG_CFAREPEATPATTERNDIM, dim, n) || n != 2 || dim[0] < 1 ||
        dim[0] > 8 || dim[1] < 1 || dim[1] > 8)
      throw unsupported("no CFARepeatPatternDim of 1 to 8 rows and columns");
    im.cfa_height = dim[0];
    im.cfa_width = dim[1];
    if (!getArray(tif, TIFFTAG_CFAPATTERN, pat, n) || n != im.cfa_width * im.cfa_height)
      throw unsupported(fmt::format("no CFAPattern of {}x{} colours", im.cfa_width,
                                    im.cfa_height));
    im.cfa.assign(pat, pat + n);
    for (uint8_t c : im.cfa)
      if (c > 2 && c != kCfaWhite) throw unsupported(fmt::format("CFA colour {}", c));
  }
  // White (W) pixels: four planes, CFAPlaneColor red, green, blue, white (as writeDng writes).
  const bool has_w = !im.mono && std::find(im.cfa.begin(), im.cfa.end(), kCfaWhite) != im.cfa.end();
  const int planes = has_w ? 4 : 3;
  if (has_w) {
    const uint8_t* pc = nullptr;
    if (!getArray(tif, TIFFTAG_CFAPLANECOLOR, pc, n) || n != 4 || pc[0] != 0 || pc[1] != 1 ||
        pc[2] != 2 || pc[3] != kCfaWhite)
      throw unsupported("a CFA with white pixels without CFAPlaneColor red, green, blue, white");
  }
  const float* f = nullptr;
  if (getArray(tif, TIFFTAG_BLACKLEVEL, f, n) && n >= 1) im.black_level = uint32_t(f[0]);
  const uint32_t* wl = nullptr;
  im.white_level = 65535;
  if (getArray(tif, TIFFTAG_WHITELEVEL, wl, n) && n >= 1) im.white_level = wl[0];
  if (!(im.white_level > im.black_level))
    throw unsupported(fmt::format("WhiteLevel {} not above BlackLevel {}", im.white_level,
                                  im.black_level));
  if (!im.mono) {
    if ((getArray(tif, TIFFTAG_COLORMATRIX2, f, n) && n == 3 * planes) ||
        (getArray(tif, TIFFTAG_COLORMATRIX1, f, n) && n == 3 * planes)) {
      for (int i = 0; i < 9; ++i) im.color_matrix2[size_t(i)] = f[i];
      if (has_w)
        for (int i = 0; i < 3; ++i) im.w_color_row2[size_t(i)] = f[9 + i];
    } else {
      throw unsupported(fmt::format("no {}x3 ColorMatrix1/2", planes));
    }
    if (getArray(tif, TIFFTAG_ASSHOTNEUTRAL, f, n) && n == planes) {
      for (int i = 0; i < 3; ++i) im.as_shot_neutral[size_t(i)] = f[i];
      if (has_w) im.w_neutral = f[3];
    }
  }
  return im;
}

void writeDng(const std::string& path, const DngImage& im) {
  if (im.width <= 0 || im.height <= 0 || im.data.size() != size_t(im.width) * size_t(im.height))
    throw Error(FileLoc{path}, fmt::format("DNG of {}x{} pixels with {} values", im.width,
                                           im.height, im.data.size()));
  writeAtomically(path, [&](const std::string& tmp) { writeTo(tmp, im); });
}

}  // namespace lensim::io
