// PLY reader: ASCII, binary little and big endian, gzip, with and without normals and uv. The
// test files are written by the tests themselves.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <zlib.h>

#include <bit>
#include <cstdint>
#include <cstring>

#include "lensim/io/ply.h"
#include "lensim/util/error.h"
#include "scene_test_util.h"

using namespace lensim;

namespace {

enum class Fmt { Ascii, LE, BE };

struct Options {
  Fmt format = Fmt::Ascii;
  bool normals = false;
  bool uvs = false;
  bool double_positions = false;
};

// Four vertices; faces: one triangle (0 1 2), one quad (0 1 2 3), one pentagon (fan of 3).
const float kP[5][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5f, 1.5f, 0}};

template <typename T>
void putBinary(std::string& out, T v, bool big) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if (big == (std::endian::native == std::endian::little))
    for (size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
  out.append(reinterpret_cast<const char*>(b), sizeof(T));
}

std::string makePly(const Options& o) {
  std::string h = "ply\n";
  h += o.format == Fmt::Ascii ? "format ascii 1.0\n"
       : o.format == Fmt::LE  ? "format binary_little_endian 1.0\n"
                              : "format binary_big_endian 1.0\n";
  h += "comment written by io_ply_test\n";
  h += "element vertex 5\n";
  const char* pt = o.double_positions ? "double" : "float";
  h += fmt::format("property {} x\nproperty {} y\nproperty {} z\n", pt, pt, pt);
  if (o.normals) h += "property float nx\nproperty float ny\nproperty float nz\n";
  if (o.uvs) h += "property float u\nproperty float v\n";
  h += "property uchar red\n";  // ignored
  h += "element face 3\nproperty list uchar int vertex_indices\nproperty int face_indices\n";
  h += "element extra 2\nproperty short a\nproperty list ushort uint b\n";  // skipped
  h += "end_header\n";
  std::vector<std::vector<int>> faces = {{0, 1, 2}, {0, 1, 2, 3}, {0, 1, 2, 4, 3}};
  if (o.format == Fmt::Ascii) {
    for (int i = 0; i < 5; ++i) {
      h += fmt::format("{} {} {}", kP[i][0], kP[i][1], kP[i][2]);
      if (o.normals) h += " 0 0 1";
      if (o.uvs) h += fmt::format(" {} {}", kP[i][0], kP[i][1]);
      h += " 255\n";
    }
    for (size_t f = 0; f < faces.size(); ++f) {
      h += std::to_string(faces[f].size());
      for (int i : faces[f]) h += fmt::format(" {}", i);
      h += fmt::format(" {}\n", f + 10);
    }
    h += "1 2 7 8\n-3 0\n";
    return h;
  }
  bool big = o.format == Fmt::BE;
  for (int i = 0; i < 5; ++i) {
    for (int k = 0; k < 3; ++k) {
      if (o.double_positions)
        putBinary<double>(h, kP[i][k], big);
      else
        putBinary<float>(h, kP[i][k], big);
    }
    if (o.normals) {
      putBinary<float>(h, 0, big);
      putBinary<float>(h, 0, big);
      putBinary<float>(h, 1, big);
    }
    if (o.uvs) {
      putBinary<float>(h, kP[i][0], big);
      putBinary<float>(h, kP[i][1], big);
    }
    putBinary<uint8_t>(h, 255, big);
  }
  for (size_t f = 0; f < faces.size(); ++f) {
    putBinary<uint8_t>(h, static_cast<uint8_t>(faces[f].size()), big);
    for (int i : faces[f]) putBinary<int32_t>(h, i, big);
    putBinary<int32_t>(h, static_cast<int32_t>(f + 10), big);
  }
  putBinary<int16_t>(h, 1, big);
  putBinary<uint16_t>(h, 2, big);
  putBinary<uint32_t>(h, 7, big);
  putBinary<uint32_t>(h, 8, big);
  putBinary<int16_t>(h, -3, big);
  putBinary<uint16_t>(h, 0, big);
  return h;
}

void expectMesh(const io::PlyMesh& m, const Options& o) {
  ASSERT_EQ(m.positions.size(), 5u);
  for (int i = 0; i < 5; ++i) EXPECT_EQ(m.positions[i], (Vec3f{kP[i][0], kP[i][1], kP[i][2]}));
  EXPECT_EQ(m.normals.size(), o.normals ? 5u : 0u);
  if (o.normals) {
    EXPECT_EQ(m.normals[3], (Vec3f{0, 0, 1}));
  }
  EXPECT_EQ(m.uvs.size(), o.uvs ? 5u : 0u);
  if (o.uvs) {
    EXPECT_EQ(m.uvs[2], (std::array<float, 2>{1, 1}));
  }
  // The triangle, then the pentagon's fan.
  EXPECT_EQ(m.triangles, (std::vector<int>{0, 1, 2, 0, 1, 2, 0, 2, 4, 0, 4, 3}));
  // The quad in pbrt-v4 bilinear order.
  EXPECT_EQ(m.quads, (std::vector<int>{0, 1, 3, 2}));
  EXPECT_EQ(m.face_indices, (std::vector<int>{10, 11, 12}));
}

void writeGz(const std::string& path, const std::string& data) {
  gzFile f = gzopen(path.c_str(), "wb");
  ASSERT_NE(f, nullptr);
  ASSERT_EQ(gzwrite(f, data.data(), static_cast<unsigned>(data.size())),
            static_cast<int>(data.size()));
  gzclose(f);
}

}  // namespace

TEST(Ply, AsciiBinaryLittleAndBigEndianWithAndWithoutAttributes) {
  testutil::TempDir dir("lensim-ply");
  for (Fmt f : {Fmt::Ascii, Fmt::LE, Fmt::BE})
    for (bool normals : {false, true})
      for (bool uvs : {false, true}) {
        Options o{f, normals, uvs, f == Fmt::BE};
        SCOPED_TRACE(fmt::format("format {} normals {} uvs {}", int(f), normals, uvs));
        std::string path = dir.write("m.ply", makePly(o));
        expectMesh(io::readPly(path), o);
      }
}

TEST(Ply, GzipCompressed) {
  testutil::TempDir dir("lensim-plygz");
  for (Fmt f : {Fmt::Ascii, Fmt::LE, Fmt::BE}) {
    Options o{f, true, true, false};
    std::string path = dir.file("m.ply.gz");
    writeGz(path, makePly(o));
    expectMesh(io::readPly(path), o);
  }
}

TEST(Ply, ErrorsNameTheFile) {
  testutil::TempDir dir("lensim-plybad");
  std::string good = makePly({Fmt::LE, false, false, false});
  std::string truncated = dir.write("t.ply", good.substr(0, good.size() - 20));
  try {
    io::readPly(truncated);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("t.ply: unexpected end of PLY data"), std::string::npos);
  }
  std::string ascii = makePly({Fmt::Ascii, false, false, false});
  ascii.replace(ascii.find("4 0 1 2 3"), 9, "4 0 1 2 9");
  EXPECT_THROW(io::readPly(dir.write("r.ply", ascii)), Error);
  EXPECT_THROW(io::readPly(dir.write("n.ply", "plx\n")), Error);
  EXPECT_THROW(io::readPly(dir.file("missing.ply")), Error);
}
