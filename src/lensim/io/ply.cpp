#include "lensim/io/ply.h"

#include <fmt/format.h>
#include <zlib.h>

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <sstream>

#include "lensim/util/error.h"
#include "lensim/util/file.h"
#include "lensim/util/limits.h"

namespace lensim::io {

namespace {

enum class Scalar { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

Scalar scalarFromName(const std::string& s, const std::string& name) {
  if (s == "char" || s == "int8") return Scalar::Int8;
  if (s == "uchar" || s == "uint8") return Scalar::UInt8;
  if (s == "short" || s == "int16") return Scalar::Int16;
  if (s == "ushort" || s == "uint16") return Scalar::UInt16;
  if (s == "int" || s == "int32") return Scalar::Int32;
  if (s == "uint" || s == "uint32") return Scalar::UInt32;
  if (s == "float" || s == "float32") return Scalar::Float32;
  if (s == "double" || s == "float64") return Scalar::Float64;
  throw Error(fmt::format("{}: unknown PLY property type \"{}\"", name, s));
}

size_t scalarSize(Scalar s) {
  switch (s) {
    case Scalar::Int8:
    case Scalar::UInt8:
      return 1;
    case Scalar::Int16:
    case Scalar::UInt16:
      return 2;
    case Scalar::Int32:
    case Scalar::UInt32:
    case Scalar::Float32:
      return 4;
    case Scalar::Float64:
      return 8;
  }
  return 0;
}

struct Property {
  std::string name;
  bool is_list = false;
  Scalar count_type = Scalar::UInt8;
  Scalar type = Scalar::Float32;
};

struct Element {
  std::string name;
  size_t count = 0;
  std::vector<Property> props;
};

enum class Format { Ascii, BinaryLE, BinaryBE };

// Reads values one at a time from the body, in the file's format.
class BodyReader {
 public:
  BodyReader(const std::string& data, size_t pos, Format f, const std::string& name)
      : data_(data), pos_(pos), format_(f), name_(name) {}

  double read(Scalar s) {
    if (format_ == Format::Ascii) return readAscii();
    size_t n = scalarSize(s);
    if (pos_ + n > data_.size()) throw Error(fmt::format("{}: unexpected end of PLY data", name_));
    unsigned char b[8];
    std::memcpy(b, data_.data() + pos_, n);
    pos_ += n;
    bool file_le = format_ == Format::BinaryLE;
    bool host_le = std::endian::native == std::endian::little;
    if (file_le != host_le)
      for (size_t i = 0; i < n / 2; ++i) std::swap(b[i], b[n - 1 - i]);
    switch (s) {
      case Scalar::Int8: {
        int8_t v;
        std::memcpy(&v, b, 1);
        return v;
      }
      case Scalar::UInt8: {
        uint8_t v;
        std::memcpy(&v, b, 1);
        return v;
      }
      case Scalar::Int16: {
        int16_t v;
        std::memcpy(&v, b, 2);
        return v;
      }
      case Scalar::UInt16: {
        uint16_t v;
        std::memcpy(&v, b, 2);
        return v;
      }
      case Scalar::Int32: {
        int32_t v;
        std::memcpy(&v, b, 4);
        return v;
      }
      case Scalar::UInt32: {
        uint32_t v;
        std::memcpy(&v, b, 4);
        return v;
      }
      case Scalar::Float32: {
        float v;
        std::memcpy(&v, b, 4);
        return v;
      }
      case Scalar::Float64: {
        double v;
        std::memcpy(&v, b, 8);
        return v;
      }
    }
    return 0;
  }

 private:
  double readAscii() {
    while (pos_ < data_.size() && std::isspace(static_cast<unsigned char>(data_[pos_]))) ++pos_;
    size_t start = pos_;
    while (pos_ < data_.size() && !std::isspace(static_cast<unsigned char>(data_[pos_]))) ++pos_;
    if (start == pos_) throw Error(fmt::format("{}: unexpected end of PLY data", name_));
    const char* b = data_.data() + start;
    if (*b == '+') ++b;
    double v = 0;
    auto [ptr, ec] = std::from_chars(b, data_.data() + pos_, v);
    if (ec != std::errc() || ptr != data_.data() + pos_)
      throw Error(fmt::format("{}: bad number \"{}\" in PLY data", name_,
                              data_.substr(start, pos_ - start)));
    return v;
  }

  const std::string& data_;
  size_t pos_;
  Format format_;
  const std::string& name_;
};

// A list's length as the file gives it: a whole number in [0, max], or an error.
size_t listLength(double v, const std::string& name) {
  if (!(v >= 0 && v <= 1e6) || v != std::floor(v))
    throw Error(fmt::format("{}: bad PLY list length {}", name, v));
  return static_cast<size_t>(v);
}

// The fewest bytes one element can take in the body (lists as empty lists).
size_t minElementBytes(const Element& e, Format format) {
  size_t n = 0;
  for (const Property& p : e.props)
    n += format == Format::Ascii ? 2 : scalarSize(p.is_list ? p.count_type : p.type);
  return n;
}

std::string readGzFile(const std::string& path) {
  // Only regular files (a FIFO blocks, /dev/zero never ends); the decompressed size is held to
  // the memory budget.
  requireRegularFile(path, "PLY file", uint64_t{64} << 30);
  const double budget = static_cast<double>(memoryBudgetBytes()) / 2;
  gzFile f = gzopen(path.c_str(), "rb");  // reads uncompressed files unchanged
  if (!f) throw Error(fmt::format("cannot open PLY file \"{}\"", path));
  std::string data;
  char buf[1 << 16];
  for (;;) {
    int n = gzread(f, buf, sizeof buf);
    if (n < 0) {
      int err = 0;
      std::string msg = gzerror(f, &err);
      gzclose(f);
      throw Error(fmt::format("{}: cannot decompress: {}", path, msg));
    }
    if (n == 0) break;
    data.append(buf, static_cast<size_t>(n));
    if (static_cast<double>(data.size()) > budget) {
      gzclose(f);
      checkMemory(static_cast<double>(data.size()) * 2, FileLoc{path},
                  "decompressing this PLY file");
    }
  }
  gzclose(f);
  return data;
}

/// A PLY header: the body's format, its elements and where the body starts.
struct Header {
  Format format = Format::Ascii;
  std::vector<Element> elements;
  size_t body_start = 0;
};

/// Parses the header: lines up to "end_header".
Header parseHeader(const std::string& data, const std::string& name) {
  size_t pos = 0;
  auto nextLine = [&]() -> std::string {
    size_t e = data.find('\n', pos);
    if (e == std::string::npos) throw Error(fmt::format("{}: PLY header has no end_header", name));
    std::string line = data.substr(pos, e - pos);
    pos = e + 1;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return line;
  };
  if (nextLine() != "ply") throw Error(fmt::format("{}: not a PLY file", name));
  Format format = Format::Ascii;
  bool have_format = false;
  std::vector<Element> elements;
  for (;;) {
    std::string line = nextLine();
    std::istringstream ls(line);
    std::string word;
    ls >> word;
    if (word == "end_header") break;
    if (word.empty() || word == "comment" || word == "obj_info") continue;
    if (word == "format") {
      std::string f, version;
      ls >> f >> version;
      if (f == "ascii")
        format = Format::Ascii;
      else if (f == "binary_little_endian")
        format = Format::BinaryLE;
      else if (f == "binary_big_endian")
        format = Format::BinaryBE;
      else
        throw Error(fmt::format("{}: unknown PLY format \"{}\"", name, f));
      have_format = true;
    } else if (word == "element") {
      Element e;
      ls >> e.name >> e.count;
      if (ls.fail()) throw Error(fmt::format("{}: bad PLY element line \"{}\"", name, line));
      elements.push_back(e);
    } else if (word == "property") {
      if (elements.empty()) throw Error(fmt::format("{}: PLY property before any element", name));
      Property p;
      std::string t;
      ls >> t;
      if (t == "list") {
        std::string ct, it;
        ls >> ct >> it >> p.name;
        p.is_list = true;
        p.count_type = scalarFromName(ct, name);
        p.type = scalarFromName(it, name);
      } else {
        p.type = scalarFromName(t, name);
        ls >> p.name;
      }
      if (p.name.empty()) throw Error(fmt::format("{}: bad PLY property line \"{}\"", name, line));
      elements.back().props.push_back(p);
    } else {
      throw Error(fmt::format("{}: unknown PLY header line \"{}\"", name, line));
    }
  }
  if (!have_format) throw Error(fmt::format("{}: PLY header has no format line", name));
  return {format, std::move(elements), pos};
}

/// Refuses element counts the body is too short for: a small file must not claim a billion
/// elements, each takes a few bytes at least.
void checkElementCounts(const Header& h, size_t data_size, const std::string& name) {
  const size_t body_bytes = data_size - h.body_start;
  for (const Element& e : h.elements) {
    const size_t per = std::max<size_t>(1, minElementBytes(e, h.format));
    if (e.count > body_bytes / per)
      throw Error(
          fmt::format("{}: PLY element \"{}\" claims {} entries, but the file has only "
                      "{} bytes of data (at least {} bytes an entry)",
                      name, e.name, e.count, body_bytes, per));
  }
}

/// Reads the vertex element e: positions (refused unless finite), and normals and (u, v) where
/// the element has them.
void readVertices(const Element& e, BodyReader& body, PlyMesh& mesh, const std::string& name) {
  int ix = -1, iy = -1, iz = -1, inx = -1, iny = -1, inz = -1, iu = -1, iv = -1;
  for (size_t i = 0; i < e.props.size(); ++i) {
    const std::string& n = e.props[i].name;
    int k = static_cast<int>(i);
    if (n == "x")
      ix = k;
    else if (n == "y")
      iy = k;
    else if (n == "z")
      iz = k;
    else if (n == "nx")
      inx = k;
    else if (n == "ny")
      iny = k;
    else if (n == "nz")
      inz = k;
    else if (n == "u" || n == "s" || n == "texture_u" || n == "texture_s")
      iu = k;
    else if (n == "v" || n == "t" || n == "texture_v" || n == "texture_t")
      iv = k;
  }
  if (ix < 0 || iy < 0 || iz < 0)
    throw Error(fmt::format("{}: PLY vertex element lacks x, y or z", name));
  bool normals = inx >= 0 && iny >= 0 && inz >= 0, uvs = iu >= 0 && iv >= 0;
  mesh.positions.reserve(e.count);
  std::vector<double> vals(e.props.size());
  for (size_t v = 0; v < e.count; ++v) {
    for (size_t i = 0; i < e.props.size(); ++i) {
      const Property& p = e.props[i];
      if (p.is_list) {
        size_t n = listLength(body.read(p.count_type), name);
        for (size_t j = 0; j < n; ++j) body.read(p.type);
        vals[i] = 0;
      } else {
        vals[i] = body.read(p.type);
      }
    }
    for (int k : {ix, iy, iz})
      if (!(std::abs(vals[static_cast<size_t>(k)]) <= kMaxSceneNumber))
        throw Error(
            fmt::format("{}: vertex {} has a coordinate that is not a finite number "
                        "({})",
                        name, v, vals[static_cast<size_t>(k)]));
    mesh.positions.push_back(Vec3f(Vec3{vals[ix], vals[iy], vals[iz]}));
    if (normals) mesh.normals.push_back(Vec3f(Vec3{vals[inx], vals[iny], vals[inz]}));
    if (uvs) mesh.uvs.push_back({float(vals[iu]), float(vals[iv])});
  }
}

/// Reads the face element e: vertex index lists (checked against the vertices read), quads
/// kept as bilinear patches, other polygons as triangle fans; "face_indices".
void readFaces(const Element& e, BodyReader& body, PlyMesh& mesh, const std::string& name) {
  for (size_t f = 0; f < e.count; ++f) {
    for (const Property& p : e.props) {
      if (p.is_list) {
        size_t n = listLength(body.read(p.count_type), name);
        std::vector<int> idx(n);
        for (size_t j = 0; j < n; ++j) {
          const double x = body.read(p.type);
          // Out of range or fractional values become -1, which the range check refuses.
          idx[j] = x >= 0 && x < 2147483647.0 && x == std::floor(x) ? static_cast<int>(x) : -1;
        }
        if (p.name != "vertex_indices" && p.name != "vertex_index") continue;
        for (int i : idx)
          if (i < 0 || static_cast<size_t>(i) >= mesh.positions.size())
            throw Error(fmt::format("{}: face {} has vertex index {} out of range [0, {})",
                                    name, f, i, mesh.positions.size()));
        if (n < 3) throw Error(fmt::format("{}: face {} has {} vertices", name, f, n));
        if (n == 4) {
          // pbrt-v4 order for bilinear patches: p00 p10 p01 p11.
          mesh.quads.insert(mesh.quads.end(), {idx[0], idx[1], idx[3], idx[2]});
        } else {
          for (size_t j = 1; j + 1 < n; ++j)
            mesh.triangles.insert(mesh.triangles.end(), {idx[0], idx[j], idx[j + 1]});
        }
      } else {
        double v = body.read(p.type);
        if (p.name == "face_indices")
          mesh.face_indices.push_back(std::abs(v) < 2147483647.0 ? static_cast<int>(v) : -1);
      }
    }
  }
}

/// Reads past an element lensim does not use.
void skipElement(const Element& e, BodyReader& body, const std::string& name) {
  for (size_t k = 0; k < e.count; ++k)
    for (const Property& p : e.props) {
      if (p.is_list) {
        size_t n = listLength(body.read(p.count_type), name);
        for (size_t j = 0; j < n; ++j) body.read(p.type);
      } else {
        body.read(p.type);
      }
    }
}

}  // namespace

PlyMesh readPly(const std::string& path) {
  return parsePly(readGzFile(path), path);
}

PlyMesh parsePly(const std::string& data, const std::string& name) {
  const Header h = parseHeader(data, name);
  checkElementCounts(h, data.size(), name);
  PlyMesh mesh;
  BodyReader body(data, h.body_start, h.format, name);
  for (const Element& e : h.elements) {
    if (e.name == "vertex")
      readVertices(e, body, mesh, name);
    else if (e.name == "face")
      readFaces(e, body, mesh, name);
    else
      skipElement(e, body, name);
  }
  return mesh;
}

}  // namespace lensim::io
