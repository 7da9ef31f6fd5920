// Image formats pbrt scenes use besides EXR and PNG (issue 12: images through OpenImageIO): TGA
// (uncompressed and RLE, both origins), PFM (both byte orders, colour and grey, scale) and
// Radiance HDR (flat and RLE scanlines). Every file is written here byte by byte from the format's
// specification (not by OpenImageIO or lensim), with known pixel values; the expected linear
// values are computed here too: 8-bit data through the sRGB curve of IEC 61966-2-1 unless an
// encoding says otherwise, floats as stored, RGBE as mantissa * 2^(exponent - 136) (Radiance's
// and stb_image's decoding, which pbrt-v4 uses). Then the files go through lensim's texture and
// environment-map paths in small renders whose pixels have closed forms.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "lensim/io/image.h"
#include "lensim/util/error.h"
#include "lensim/util/limits.h"
#include "render_test_util.h"

using lensim::io::Image;
using lensim::testutil::renderText;
using lensim::testutil::TempDir;

namespace {

using Bytes = std::vector<uint8_t>;

void writeBytes(const std::string& path, const Bytes& b) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
}

void append(Bytes& b, const std::string& s) {
  b.insert(b.end(), s.begin(), s.end());
}

void appendLe16(Bytes& b, int v) {
  b.push_back(static_cast<uint8_t>(v & 255));
  b.push_back(static_cast<uint8_t>(v >> 8));
}

void appendFloat(Bytes& b, float v, bool little_endian) {
  uint32_t u;
  std::memcpy(&u, &v, 4);
  for (int i = 0; i < 4; ++i) {
    const int shift = little_endian ? 8 * i : 8 * (3 - i);
    b.push_back(static_cast<uint8_t>(u >> shift));
  }
}

// The sRGB decoding curve (IEC 61966-2-1), written out here rather than taken from lensim.
double srgbDecode(int byte) {
  const double v = byte / 255.0;
  return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}

// ---- TGA (Truevision TGA 2.0 specification) -------------------------------------------------

struct Rgba {
  int r, g, b, a = 255;
};

// An 18-byte TGA header: no image ID, no colour map.
Bytes tgaHeader(int type, int width, int height, int bits, int descriptor) {
  Bytes b = {0, 0, static_cast<uint8_t>(type), 0, 0, 0, 0, 0, 0, 0, 0, 0};
  appendLe16(b, width);
  appendLe16(b, height);
  b.push_back(static_cast<uint8_t>(bits));
  b.push_back(static_cast<uint8_t>(descriptor));
  return b;
}

void appendTgaPixel(Bytes& b, const Rgba& p, int bits) {
  if (bits == 8) {
    b.push_back(static_cast<uint8_t>(p.r));
    return;
  }
  b.push_back(static_cast<uint8_t>(p.b));  // stored as B, G, R(, A)
  b.push_back(static_cast<uint8_t>(p.g));
  b.push_back(static_cast<uint8_t>(p.r));
  if (bits == 32) b.push_back(static_cast<uint8_t>(p.a));
}

// `rows`: the picture's rows top to bottom. Uncompressed (type 2, or 3 for 8-bit grey), rows
// stored top first if `top_origin` (descriptor bit 5) else bottom first.
std::string writeTga(const TempDir& dir, const std::string& name,
                     const std::vector<std::vector<Rgba>>& rows, int bits, bool top_origin) {
  const int h = static_cast<int>(rows.size()), w = static_cast<int>(rows[0].size());
  Bytes b =
      tgaHeader(bits == 8 ? 3 : 2, w, h, bits, (top_origin ? 0x20 : 0) | (bits == 32 ? 8 : 0));
  for (int i = 0; i < h; ++i)
    for (const Rgba& p : rows[top_origin ? i : h - 1 - i]) appendTgaPixel(b, p, bits);
  const std::string path = dir.file(name);
  writeBytes(path, b);
  return path;
}

// Run-length encoded (type 10): each row as a run packet of its first pixel repeated while equal,
// then one raw packet of the rest (the packets never cross rows, as the specification advises).
std::string writeTgaRle(const TempDir& dir, const std::string& name,
                        const std::vector<std::vector<Rgba>>& rows, int bits, bool top_origin) {
  const int h = static_cast<int>(rows.size()), w = static_cast<int>(rows[0].size());
  Bytes b = tgaHeader(10, w, h, bits, (top_origin ? 0x20 : 0) | (bits == 32 ? 8 : 0));
  auto same = [](const Rgba& a, const Rgba& c) {
    return a.r == c.r && a.g == c.g && a.b == c.b && a.a == c.a;
  };
  for (int i = 0; i < h; ++i) {
    const std::vector<Rgba>& row = rows[top_origin ? i : h - 1 - i];
    int run = 1;
    while (run < w && same(row[run], row[0])) ++run;
    b.push_back(static_cast<uint8_t>(0x80 | (run - 1)));  // run packet
    appendTgaPixel(b, row[0], bits);
    if (run < w) {
      b.push_back(static_cast<uint8_t>(w - run - 1));  // raw packet
      for (int x = run; x < w; ++x) appendTgaPixel(b, row[x], bits);
    }
  }
  const std::string path = dir.file(name);
  writeBytes(path, b);
  return path;
}

// ---- PFM (Portable Float Map: "PF" colour / "Pf" grey, width height, scale; rows bottom to
// top; a negative scale means little-endian floats, |scale| multiplies the values) -------------

std::string writePfm(const TempDir& dir, const std::string& name,
                     const std::vector<std::vector<std::vector<float>>>& rows_top_first,
                     const std::string& scale, bool little_endian) {
  const int h = static_cast<int>(rows_top_first.size());
  const int w = static_cast<int>(rows_top_first[0].size());
  const int nc = static_cast<int>(rows_top_first[0][0].size());
  Bytes b;
  append(b, (nc == 3 ? "PF\n" : "Pf\n") + std::to_string(w) + " " + std::to_string(h) + "\n" +
                scale + "\n");
  for (int i = h - 1; i >= 0; --i)
    for (const auto& px : rows_top_first[i])
      for (float v : px) appendFloat(b, v, little_endian);
  const std::string path = dir.file(name);
  writeBytes(path, b);
  return path;
}

// ---- Radiance HDR (RGBE: value = mantissa * 2^(exponent - 136)) -------------------------------

struct Rgbe {
  int r, g, b, e;
  double value(int m) const { return m * std::ldexp(1.0, e - 136); }
};

// Flat scanlines (4 bytes per pixel), or the "new" run-length encoding for rows 8 to 32767
// pixels wide: 2, 2, width (big-endian 16 bits), then each component as runs (count > 128:
// count - 128 copies of the next byte) or literals (count <= 128: that many bytes).
std::string writeHdr(const TempDir& dir, const std::string& name,
                     const std::vector<std::vector<Rgbe>>& rows, bool rle) {
  const int h = static_cast<int>(rows.size()), w = static_cast<int>(rows[0].size());
  Bytes b;
  append(b,
         "#?RADIANCE\n# written byte by byte by lensim's image_formats_test\n"
         "FORMAT=32-bit_rle_rgbe\n\n-Y " +
             std::to_string(h) + " +X " + std::to_string(w) + "\n");
  for (const auto& row : rows) {
    if (!rle) {
      for (const Rgbe& p : row)
        for (int v : {p.r, p.g, p.b, p.e}) b.push_back(static_cast<uint8_t>(v));
      continue;
    }
    b.insert(b.end(), {2, 2, static_cast<uint8_t>(w >> 8), static_cast<uint8_t>(w & 255)});
    for (int c = 0; c < 4; ++c) {
      auto comp = [&](int x) {
        const Rgbe& p = row[x];
        return c == 0 ? p.r : c == 1 ? p.g : c == 2 ? p.b : p.e;
      };
      int x = 0;
      while (x < w) {
        int run = 1;
        while (x + run < w && run < 127 && comp(x + run) == comp(x)) ++run;
        if (run >= 3) {
          b.push_back(static_cast<uint8_t>(128 + run));
          b.push_back(static_cast<uint8_t>(comp(x)));
          x += run;
        } else {
          int lit = 0;  // literals up to the next run of 3
          while (x + lit < w && lit < 128 &&
                 !(x + lit + 2 < w && comp(x + lit) == comp(x + lit + 1) &&
                   comp(x + lit) == comp(x + lit + 2)))
            ++lit;
          if (lit == 0) lit = 1;
          b.push_back(static_cast<uint8_t>(lit));
          for (int k = 0; k < lit; ++k) b.push_back(static_cast<uint8_t>(comp(x + k)));
          x += lit;
        }
      }
    }
  }
  const std::string path = dir.file(name);
  writeBytes(path, b);
  return path;
}

// Renders a 2x2 RGB texture on a diffuse transmitter (transmittance 0) filling an orthographic
// view under a uniform white sky: each pixel reads the reflectance of its texel exactly (the
// furnace argument: the sky behind the quad is transmitted with weight 0). Returns the texel
// RGBs as rendered, top-left, top-right, bottom-left, bottom-right of the picture (pbrt-v4's
// orientation: the image's top row at v = 1; the camera mirrors x, so texel columns swap).
struct Texels {
  double rgb[4][3];
  double tol[4][3];
};
Texels renderTexture(const std::string& file, const std::string& extra = "") {
  const std::string text = R"(
LookAt 0 0 -1  0 0 0  0 1 0
Camera "orthographic" "float screenwindow" [-0.5 0.5 -0.5 0.5]
Film "rgb" "integer xresolution" 8 "integer yresolution" 8 "string filename" "t.exr"
Sampler "independent" "integer pixelsamples" 16
PixelFilter "box"
Integrator "path" "integer maxdepth" 1
WorldBegin
LightSource "infinite" "rgb L" [1 1 1]
Texture "img" "spectrum" "imagemap" "string filename" ")" +
                           file + "\" \"string filter\" \"point\" " + extra + R"(
Material "diffusetransmission" "texture reflectance" "img" "rgb transmittance" [0 0 0]
Shape "bilinearmesh" "point3 P" [0.5 -0.5 0  -0.5 -0.5 0  0.5 0.5 0  -0.5 0.5 0]
  "point2 uv" [0 0 1 0 0 1 1 1]
)";
  const Image out = renderText(text).image;
  Texels t{};
  const int x0[4] = {0, 4, 0, 4}, y0[4] = {0, 0, 4, 4};
  for (int k = 0; k < 4; ++k)
    for (int c = 0; c < 3; ++c) {
      // Inner 2x2 pixels of each 4x4 block (away from texel edges).
      double s = 0, s2 = 0;
      for (int y = y0[k] + 1; y < y0[k] + 3; ++y)
        for (int x = x0[k] + 1; x < x0[k] + 3; ++x) {
          const double v = out.at(x, y, c);
          s += v, s2 += v * v;
        }
      t.rgb[k][c] = s / 4;
      const double var = std::max(0.0, s2 / 4 - t.rgb[k][c] * t.rgb[k][c]);
      // Spectral noise of 16 wavelength samples per pixel and the RGB -> spectrum -> RGB round
      // trip of albedo upsampling.
      t.tol[k][c] = 5 * std::sqrt(var / 3) + 0.02;
    }
  return t;
}

// The expected texel (x, y) of a 2x2 image seen in picture quadrant k (see renderTexture).
void expectTexels(const Texels& t, const double want[2][2][3], const std::string& what) {
  const int tx[4] = {1, 0, 1, 0}, ty[4] = {0, 0, 1, 1};  // x mirrored by the camera
  for (int k = 0; k < 4; ++k)
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(t.rgb[k][c], want[ty[k]][tx[k]][c], t.tol[k][c])
          << what << ": quadrant " << k << " channel " << c;
}

const std::vector<std::vector<Rgba>> kTgaRows = {
    {{200, 30, 10, 255}, {200, 30, 10, 128}, {5, 250, 60, 0}},
    {{0, 128, 255, 64}, {90, 90, 90, 255}, {90, 90, 90, 255}},
};

void expectTgaPixels(const Image& im, bool alpha, const std::string& what) {
  ASSERT_EQ(im.width, 3) << what;
  ASSERT_EQ(im.height, 2) << what;
  ASSERT_EQ(im.channels, alpha ? (std::vector<std::string>{"R", "G", "B", "A"})
                               : (std::vector<std::string>{"R", "G", "B"}))
      << what;
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 3; ++x) {
      const Rgba& p = kTgaRows[y][x];
      EXPECT_NEAR(im.at(x, y, 0), srgbDecode(p.r), 1e-6) << what << " " << x << "," << y;
      EXPECT_NEAR(im.at(x, y, 1), srgbDecode(p.g), 1e-6) << what << " " << x << "," << y;
      EXPECT_NEAR(im.at(x, y, 2), srgbDecode(p.b), 1e-6) << what << " " << x << "," << y;
      if (alpha) {
        EXPECT_NEAR(im.at(x, y, 3), p.a / 255.0, 1e-6) << what;  // never decoded
      }
    }
}

}  // namespace

TEST(ImageFormats, TgaUncompressedAndRleInBothOrigins) {
  TempDir dir("lensim-tga");
  expectTgaPixels(lensim::io::readImage(writeTga(dir, "bl24.tga", kTgaRows, 24, false)), false,
                  "24-bit bottom-left");
  expectTgaPixels(lensim::io::readImage(writeTga(dir, "tl32.tga", kTgaRows, 32, true)), true,
                  "32-bit top-left");
  expectTgaPixels(lensim::io::readImage(writeTgaRle(dir, "rle24.tga", kTgaRows, 24, false)), false,
                  "RLE 24-bit bottom-left");
  expectTgaPixels(lensim::io::readImage(writeTgaRle(dir, "rle32.tga", kTgaRows, 32, true)), true,
                  "RLE 32-bit top-left");
  // 8-bit grey (type 3).
  const Image grey = lensim::io::readImage(
      writeTga(dir, "grey.tga", {{{10, 0, 0}, {128, 0, 0}}, {{255, 0, 0}, {0, 0, 0}}}, 8, false));
  ASSERT_EQ(grey.channels, std::vector<std::string>{"Y"});
  EXPECT_NEAR(grey.at(0, 0, 0), srgbDecode(10), 1e-6);
  EXPECT_NEAR(grey.at(1, 0, 0), srgbDecode(128), 1e-6);
  EXPECT_NEAR(grey.at(0, 1, 0), 1.0, 1e-6);
  EXPECT_NEAR(grey.at(1, 1, 0), 0.0, 1e-6);
}

TEST(ImageFormats, EncodingsOfEightBitData) {
  // pbrt-v4's "encoding": sRGB (the default for 8-bit data), linear, gamma g.
  TempDir dir("lensim-encoding");
  const std::string file = writeTga(dir, "a.tga", kTgaRows, 24, true);
  const Image lin = lensim::io::readImage(file, {.encoding = "linear"});
  const Image gam = lensim::io::readImage(file, {.encoding = "gamma 2.2"});
  const Image srgb = lensim::io::readImage(file, {.encoding = "sRGB"});
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 3; ++x) {
      const Rgba& p = kTgaRows[y][x];
      EXPECT_NEAR(lin.at(x, y, 0), p.r / 255.0, 1e-6);
      EXPECT_NEAR(gam.at(x, y, 1), std::pow(p.g / 255.0, 2.2), 1e-6);
      EXPECT_NEAR(srgb.at(x, y, 2), srgbDecode(p.b), 1e-6);
    }
  EXPECT_THROW(lensim::io::readImage(file, {.encoding = "gamma x"}), lensim::Error);
}

TEST(ImageFormats, PfmBothByteOrdersColourAndGrey) {
  TempDir dir("lensim-pfm");
  const std::vector<std::vector<std::vector<float>>> colour = {
      {{1.5f, -2.0f, 0.25f}, {3.0f, 4.0f, 5.0f}},
      {{1e-3f, 6.5f, 7.0f}, {100.0f, 0.0f, 0.125f}},
  };
  struct Case {
    const char* name;
    const char* scale;
    bool little_endian;
    double factor;
  } cases[] = {{"le.pfm", "-1.0", true, 1.0},
               {"be.pfm", "1.0", false, 1.0},
               {"le_scale.pfm", "-0.5", true, 0.5},
               {"be_scale.pfm", "4", false, 4.0}};
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const Image im = lensim::io::readImage(writePfm(dir, c.name, colour, c.scale, c.little_endian));
    ASSERT_EQ(im.channels, (std::vector<std::string>{"R", "G", "B"}));
    ASSERT_EQ(im.width, 2);
    ASSERT_EQ(im.height, 2);
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 2; ++x)
        for (int k = 0; k < 3; ++k)
          EXPECT_FLOAT_EQ(im.at(x, y, k), float(colour[y][x][k] * c.factor)) << x << "," << y;
  }
  const std::vector<std::vector<std::vector<float>>> grey = {{{0.5f}, {2.0f}, {-1.0f}},
                                                             {{8.0f}, {0.0f}, {1e6f}}};
  for (bool le : {true, false}) {
    SCOPED_TRACE(le ? "grey little-endian" : "grey big-endian");
    const Image im =
        lensim::io::readImage(writePfm(dir, le ? "gl.pfm" : "gb.pfm", grey, le ? "-1" : "1", le));
    ASSERT_EQ(im.channels, std::vector<std::string>{"Y"});
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 3; ++x) EXPECT_FLOAT_EQ(im.at(x, y, 0), grey[y][x][0]);
  }
}

TEST(ImageFormats, HdrFlatAndRunLengthScanlines) {
  TempDir dir("lensim-hdr");
  // 2x2 flat: exponents around 136 make mantissas exact values.
  const std::vector<std::vector<Rgbe>> flat = {{{128, 64, 32, 129}, {255, 1, 0, 136}},
                                               {{10, 20, 30, 140}, {0, 0, 0, 0}}};
  const Image a = lensim::io::readImage(writeHdr(dir, "flat.hdr", flat, false));
  ASSERT_EQ(a.channels, (std::vector<std::string>{"R", "G", "B"}));
  ASSERT_EQ(a.width, 2);
  ASSERT_EQ(a.height, 2);
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 2; ++x) {
      const Rgbe& p = flat[y][x];
      EXPECT_FLOAT_EQ(a.at(x, y, 0), float(p.value(p.r))) << x << "," << y;
      EXPECT_FLOAT_EQ(a.at(x, y, 1), float(p.value(p.g))) << x << "," << y;
      EXPECT_FLOAT_EQ(a.at(x, y, 2), float(p.value(p.b))) << x << "," << y;
    }
  // 12x3 with run-length scanlines: runs and literals in every component.
  std::vector<std::vector<Rgbe>> rle(3, std::vector<Rgbe>(12));
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 12; ++x)
      rle[y][x] = x < 6 ? Rgbe{200, 100, 50, 130 + y} : Rgbe{17 * x, 255 - 9 * x, 3 * x + y, 128};
  const Image b = lensim::io::readImage(writeHdr(dir, "rle.hdr", rle, true));
  ASSERT_EQ(b.width, 12);
  ASSERT_EQ(b.height, 3);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 12; ++x) {
      const Rgbe& p = rle[y][x];
      EXPECT_FLOAT_EQ(b.at(x, y, 0), float(p.value(p.r))) << x << "," << y;
      EXPECT_FLOAT_EQ(b.at(x, y, 1), float(p.value(p.g))) << x << "," << y;
      EXPECT_FLOAT_EQ(b.at(x, y, 2), float(p.value(p.b))) << x << "," << y;
    }
}

TEST(ImageFormats, TexturesFromTgaPfmAndHdrRender) {
  // The same 2x2 picture (top row red-ish | green-ish, bottom row blue-ish | grey) in each
  // format, as an image texture: the rendered texels are its linear values.
  TempDir dir("lensim-textures");
  const int bytes[2][2][3] = {{{230, 60, 40}, {40, 200, 90}}, {{30, 70, 220}, {160, 160, 160}}};
  double srgb[2][2][3], linear[2][2][3];
  std::vector<std::vector<Rgba>> rows(2, std::vector<Rgba>(2));
  std::vector<std::vector<std::vector<float>>> floats(2, std::vector<std::vector<float>>(2));
  std::vector<std::vector<Rgbe>> rgbe(2, std::vector<Rgbe>(2));
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 2; ++x) {
      const int* b = bytes[y][x];
      rows[y][x] = {b[0], b[1], b[2]};
      rgbe[y][x] = {b[0], b[1], b[2], 136 - 8};  // value = byte / 256
      for (int c = 0; c < 3; ++c) {
        srgb[y][x][c] = srgbDecode(b[c]);
        linear[y][x][c] = b[c] / 255.0;
        floats[y][x].push_back(float(srgb[y][x][c]));
      }
    }
  expectTexels(renderTexture(writeTga(dir, "t.tga", rows, 24, false)), srgb, "TGA");
  expectTexels(renderTexture(writeTgaRle(dir, "r.tga", rows, 24, true)), srgb, "TGA RLE");
  expectTexels(
      renderTexture(writeTga(dir, "l.tga", rows, 24, false), "\"string encoding\" \"linear\""),
      linear, "TGA linear");
  expectTexels(renderTexture(writePfm(dir, "t.pfm", floats, "-1", true)), srgb, "PFM");
  double by256[2][2][3];
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 2; ++x)
      for (int c = 0; c < 3; ++c) by256[y][x][c] = bytes[y][x][c] / 256.0;
  expectTexels(renderTexture(writeHdr(dir, "t.hdr", rgbe, false)), by256, "HDR");
}

TEST(ImageFormats, HdrEnvironmentMapAndTgaTextureRender) {
  // A pinhole camera sees a constant HDR environment map directly in the corners (radiance
  // L = its colour), and in the middle a diffuse transmitter (transmittance 0) textured from a
  // TGA: under a uniform environment it reflects L times the texel's reflectance.
  TempDir dir("lensim-envmap-formats");
  const int w = 16, h = 8;  // lat-long
  auto constantHdr = [&](const std::string& name, Rgbe c) {
    return writeHdr(dir, name, std::vector<std::vector<Rgbe>>(h, std::vector<Rgbe>(w, c)), true);
  };
  const std::string grey = constantHdr("grey.hdr", {128, 128, 128, 128});  // 0.5
  const std::vector<std::vector<Rgba>> rows = {{{230, 60, 40}, {230, 60, 40}},
                                               {{30, 70, 220}, {30, 70, 220}}};
  const std::string tga = writeTgaRle(dir, "tex.tga", rows, 24, false);
  const std::string scene = R"(
LookAt 0 0 -1  0 0 0  0 1 0
Camera "perspective" "float fov" 90
Film "rgb" "integer xresolution" 16 "integer yresolution" 16 "string filename" "e.exr"
Sampler "independent" "integer pixelsamples" 16
PixelFilter "box"
Integrator "path" "integer maxdepth" 1
WorldBegin
LightSource "infinite" "string filename" ")" +
                            grey + R"("
Texture "img" "spectrum" "imagemap" "string filename" ")" +
                            tga + R"(" "string filter" "point"
Material "diffusetransmission" "texture reflectance" "img" "rgb transmittance" [0 0 0]
Shape "bilinearmesh" "point3 P" [0.5 -0.5 0  -0.5 -0.5 0  0.5 0.5 0  -0.5 0.5 0]
  "point2 uv" [0 0 1 0 0 1 1 1]
)";
  const Image out = renderText(scene).image;
  // Mean and standard error of the mean of channel c over pixel rectangles.
  auto stats = [&](int c, std::vector<std::array<int, 4>> rects) {
    double s = 0, s2 = 0;
    int n = 0;
    for (const auto& r : rects)
      for (int y = r[2]; y < r[3]; ++y)
        for (int x = r[0]; x < r[1]; ++x) {
          const double v = out.at(x, y, c);
          s += v, s2 += v * v, ++n;
        }
    const double mean = s / n;
    return std::pair{mean, std::sqrt(std::max(0.0, s2 / n - mean * mean) / (n - 1))};
  };
  // The quad covers pixels 4..11 in both directions (fov 90 at distance 1: half-width 1).
  const int tb[3] = {230, 60, 40}, bb[3] = {30, 70, 220};
  for (int c = 0; c < 3; ++c) {
    const auto [sky, sky_sem] =
        stats(c, {{0, 3, 0, 3}, {13, 16, 0, 3}, {0, 3, 13, 16}, {13, 16, 13, 16}});
    const auto [top, top_sem] = stats(c, {{5, 11, 5, 7}});
    const auto [bottom, bottom_sem] = stats(c, {{5, 11, 9, 11}});
    std::printf(
        "channel %d: sky %.4f +- %.4f (0.5), top %.4f +- %.4f (%.4f), bottom %.4f +- "
        "%.4f (%.4f)\n",
        c, sky, sky_sem, top, top_sem, 0.5 * srgbDecode(tb[c]), bottom, bottom_sem,
        0.5 * srgbDecode(bb[c]));
    // Spectral noise (wavelengths sampled per pixel sample), plus 1 % for the RGB -> spectrum ->
    // RGB round trip of the upsampled reflectance and illuminant.
    EXPECT_NEAR(sky, 0.5, 5 * sky_sem + 0.005);
    EXPECT_NEAR(top, 0.5 * srgbDecode(tb[c]), 5 * top_sem + 0.01 * 0.5);
    EXPECT_NEAR(bottom, 0.5 * srgbDecode(bb[c]), 5 * bottom_sem + 0.01 * 0.5);
  }
  // A coloured constant environment (RGBE 0.25, 0.5, 1.0) seen directly: its colour.
  const std::string coloured = constantHdr("col.hdr", {32, 64, 128, 129});
  const Image sky = renderText(R"(
LookAt 0 0 0  0 0 1  0 1 0
Camera "perspective" "float fov" 60
Film "rgb" "integer xresolution" 4 "integer yresolution" 4 "string filename" "s.exr"
Sampler "independent" "integer pixelsamples" 64
WorldBegin
LightSource "infinite" "string filename" ")" +
                               coloured + R"("
)")
                        .image;
  const double want[3] = {0.25, 0.5, 1.0};
  for (int c = 0; c < 3; ++c) {
    const double v = lensim::testutil::regionMean(sky, c, 0, 4, 0, 4);
    std::printf("coloured sky channel %d: %.4f (%.2f)\n", c, v, want[c]);
    EXPECT_NEAR(v, want[c], 0.02 * want[c] + 0.005);
  }
}

TEST(ImageFormats, CorruptAndTruncatedFilesGiveErrorsNamingTheFile) {
  TempDir dir("lensim-bad-formats");
  std::vector<std::pair<std::string, Bytes>> files;
  Bytes tga = tgaHeader(2, 100, 100, 24, 0);
  tga.insert(tga.end(), 30, 7);  // 10 of 10000 pixels
  files.push_back({"short.tga", tga});
  Bytes pfm;
  append(pfm, "PF\n4 4\n-1\n");
  appendFloat(pfm, 1.0f, true);
  files.push_back({"short.pfm", pfm});
  Bytes hdr;
  append(hdr, "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 50 +X 50\n");
  hdr.insert(hdr.end(), {1, 2, 3});
  files.push_back({"short.hdr", hdr});
  Bytes junk;
  append(junk, "not an image at all");
  files.push_back({"junk.hdr", junk});
  files.push_back({"junk.pfm", junk});
  files.push_back({"junk.jpg", junk});
  for (const auto& [name, bytes] : files) {
    SCOPED_TRACE(name);
    const std::string path = dir.file(name);
    writeBytes(path, bytes);
    try {
      (void)lensim::io::readImage(path);
      ADD_FAILURE() << "no error for " << name;
    } catch (const lensim::Error& e) {
      EXPECT_EQ(e.loc().file, path);
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
  }
}

TEST(ImageFormats, HeaderSizesAreCheckedAgainstTheMemoryBudgetBeforeReading) {
  // Small files whose headers claim 60000 x 60000 pixels (40 GiB as floats): refused from the
  // header, naming the file and the size, before any pixel is read.
  TempDir dir("lensim-huge-formats");
  const uint64_t budget = lensim::memoryBudgetBytes();
  lensim::setMemoryBudgetBytes(uint64_t{1} << 30);
  Bytes tga = tgaHeader(2, 60000, 60000, 24, 0);
  tga.insert(tga.end(), 300, 1);
  Bytes pfm;
  append(pfm, "PF\n60000 60000\n-1\n");
  pfm.insert(pfm.end(), 48, 0);
  Bytes hdr;
  append(hdr, "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 60000 +X 60000\n");
  hdr.insert(hdr.end(), 64, 1);
  for (const auto& [name, bytes] : std::vector<std::pair<std::string, Bytes>>{
           {"huge.tga", tga}, {"huge.pfm", pfm}, {"huge.hdr", hdr}}) {
    SCOPED_TRACE(name);
    const std::string path = dir.file(name);
    writeBytes(path, bytes);
    try {
      (void)lensim::io::readImage(path);
      ADD_FAILURE() << "no error for " << name;
    } catch (const lensim::Error& e) {
      EXPECT_EQ(e.loc().file, path);
      EXPECT_NE(std::string(e.what()).find("60000x60000"), std::string::npos) << e.what();
    }
  }
  lensim::setMemoryBudgetBytes(budget);
}

TEST(ImageFormats, WrittenPfmAndTgaAreReadByTheSpecification) {
  // lensim's PFM and TGA output, checked by parsing the bytes here.
  TempDir dir("lensim-write-formats");
  Image im(3, 2, {"R", "G", "B"});
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 3; ++x)
      for (int c = 0; c < 3; ++c) im.at(x, y, c) = 0.1f * (1 + x + 3 * y) + 0.01f * c;
  const std::string pfm = dir.file("o.pfm");
  lensim::io::writeImage(pfm, im);
  std::ifstream in(pfm, std::ios::binary);
  std::string magic;
  int w = 0, h = 0;
  double scale = 0;
  in >> magic >> w >> h >> scale;
  in.get();  // the single whitespace after the scale
  ASSERT_EQ(magic, "PF");
  ASSERT_EQ(w, 3);
  ASSERT_EQ(h, 2);
  ASSERT_NE(scale, 0.0);
  const bool le = scale < 0;
  std::vector<uint8_t> data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_EQ(data.size(), 3u * 2 * 3 * 4);
  for (int row = 0; row < 2; ++row)  // bottom row first
    for (int x = 0; x < 3; ++x)
      for (int c = 0; c < 3; ++c) {
        const uint8_t* p = &data[((row * 3 + x) * 3 + c) * 4];
        uint32_t u = 0;
        for (int i = 0; i < 4; ++i) u |= uint32_t(p[i]) << (le ? 8 * i : 8 * (3 - i));
        float v;
        std::memcpy(&v, &u, 4);
        EXPECT_FLOAT_EQ(v * float(std::abs(scale)), im.at(x, 1 - row, c));
      }

  const std::string tga = dir.file("o.tga");
  lensim::io::writeImage(tga, im);
  std::ifstream tin(tga, std::ios::binary);
  std::vector<uint8_t> t((std::istreambuf_iterator<char>(tin)), std::istreambuf_iterator<char>());
  ASSERT_GE(t.size(), 18u);
  const int id_len = t[0], type = t[2], tw = t[12] | t[13] << 8, th = t[14] | t[15] << 8;
  const int bits = t[16];
  const bool top = t[17] & 0x20;
  ASSERT_EQ(type, 2) << "uncompressed true-colour expected";
  ASSERT_EQ(tw, 3);
  ASSERT_EQ(th, 2);
  ASSERT_EQ(bits, 24);
  const size_t cmap = t[1] ? size_t(t[5] | t[6] << 8) * ((t[7] + 7) / 8) : 0;
  const size_t off = 18 + id_len + cmap;
  ASSERT_GE(t.size(), off + 18);
  for (int row = 0; row < 2; ++row)
    for (int x = 0; x < 3; ++x) {
      const int y = top ? row : 1 - row;
      const uint8_t* p = &t[off + (row * 3 + x) * 3];
      for (int c = 0; c < 3; ++c) {
        const double want = im.at(x, y, c);
        EXPECT_NEAR(srgbDecode(p[2 - c]), want, 0.01) << x << "," << y << " c" << c;
      }
    }
}
