#include "lensim/render/materials/tensor_file.h"

#include <cmath>
#include <cstring>

#include <fmt/format.h>

#include "lensim/util/error.h"
#include "lensim/util/file.h"
#include "lensim/util/limits.h"

namespace lensim::render {

namespace {

constexpr char kMagic[12] = {'t', 'e', 'n', 's', 'o', 'r', '_', 'f', 'i', 'l', 'e', '\0'};

// Little-endian integers from the byte string (bounds checked by the caller).
uint64_t readLE(const std::string& b, uint64_t at, int n) {
  uint64_t v = 0;
  for (int i = n - 1; i >= 0; --i) v = (v << 8) | static_cast<unsigned char>(b[at + i]);
  return v;
}

}  // namespace

std::size_t tensorTypeSize(TensorField::DType t) {
  using D = TensorField::DType;
  switch (t) {
    case D::UInt8:
    case D::Int8:
      return 1;
    case D::UInt16:
    case D::Int16:
    case D::Float16:
      return 2;
    case D::UInt32:
    case D::Int32:
    case D::Float32:
      return 4;
    case D::UInt64:
    case D::Int64:
    case D::Float64:
      return 8;
    case D::Invalid:
      break;
  }
  return 0;
}

std::string_view tensorTypeName(TensorField::DType t) {
  using D = TensorField::DType;
  switch (t) {
    case D::UInt8:
      return "uint8";
    case D::Int8:
      return "int8";
    case D::UInt16:
      return "uint16";
    case D::Int16:
      return "int16";
    case D::UInt32:
      return "uint32";
    case D::Int32:
      return "int32";
    case D::UInt64:
      return "uint64";
    case D::Int64:
      return "int64";
    case D::Float16:
      return "float16";
    case D::Float32:
      return "float32";
    case D::Float64:
      return "float64";
    case D::Invalid:
      break;
  }
  return "invalid";
}

void TensorFile::fail(uint64_t byte, const std::string& message) const {
  throw Error(FileLoc{path_}, fmt::format("byte {}: {}", byte, message));
}

TensorFile TensorFile::read(const std::string& path) {
  return TensorFile(readRegularFile(path, "measured BSDF file"), path);
}

TensorFile::TensorFile(std::string bytes, std::string path)
    : bytes_(std::move(bytes)), path_(std::move(path)) {
  const uint64_t size = bytes_.size();
  // `need` bytes at `at` for `what`, or a located error saying the file ends early.
  auto need = [&](uint64_t at, uint64_t n, std::string_view what) {
    if (at > size || n > size - at)
      fail(at, fmt::format("the file ends after {} bytes, inside {} ({} bytes needed); expected "
                           "a complete tensor file (truncated?)",
                           size, what, n));
  };
  if (size < sizeof kMagic || std::memcmp(bytes_.data(), kMagic, sizeof kMagic) != 0)
    fail(0,
         "not a tensor file: expected the header \"tensor_file\" (an RGL measured BSDF, "
         ".bsdf)");
  need(12, 2, "the version");
  const int major = static_cast<unsigned char>(bytes_[12]);
  const int minor = static_cast<unsigned char>(bytes_[13]);
  if (major != 1 || minor != 0)
    fail(12, fmt::format("tensor file version {}.{}; expected version 1.0", major, minor));
  need(14, 4, "the field count");
  const uint64_t n_fields = readLE(bytes_, 14, 4);
  // Each field header takes at least 2 + 2 + 1 + 8 bytes.
  if (n_fields > (size - 18) / 13)
    fail(14, fmt::format("the header claims {} fields, more than the {} bytes of the file can "
                         "hold",
                         n_fields, size));
  uint64_t at = 18;
  fields_.reserve(n_fields);
  for (uint64_t i = 0; i < n_fields; ++i) {
    TensorField f;
    f.header_offset = at;
    const std::string field_what = fmt::format("the header of field {} of {}", i + 1, n_fields);
    need(at, 2, field_what);
    const uint64_t name_len = readLE(bytes_, at, 2);
    at += 2;
    need(at, name_len, field_what);
    f.name = bytes_.substr(at, name_len);
    at += name_len;
    need(at, 2 + 1 + 8, field_what);
    const uint64_t ndim = readLE(bytes_, at, 2);
    const uint64_t dtype = readLE(bytes_, at + 2, 1);
    f.data_offset = readLE(bytes_, at + 3, 8);
    if (dtype == 0 || dtype > static_cast<uint64_t>(TensorField::DType::Float64))
      fail(at + 2, fmt::format("field \"{}\" has data type {}; expected 1..11 (uint8 .. float64)",
                               f.name, dtype));
    f.dtype = static_cast<TensorField::DType>(dtype);
    at += 11;
    need(at, 8 * ndim, fmt::format("the shape of field \"{}\"", f.name));
    f.count = 1;
    for (uint64_t d = 0; d < ndim; ++d) {
      const uint64_t extent = readLE(bytes_, at, 8);
      const auto c = checkedMul(f.count, extent);
      if (!c) fail(at, fmt::format("the shape of field \"{}\" overflows 64 bits", f.name));
      f.count = *c;
      f.shape.push_back(extent);
      at += 8;
    }
    const auto bytes = checkedMul(f.count, tensorTypeSize(f.dtype));
    const auto end = bytes ? checkedAdd(f.data_offset, *bytes) : std::nullopt;
    if (!end || *end > size) {
      std::string shape;
      for (uint64_t e : f.shape) shape += fmt::format("{}{}", shape.empty() ? "" : " x ", e);
      fail(f.header_offset,
           fmt::format("field \"{}\" ({} {}) claims {} bytes of data at byte {}, beyond the end "
                       "of the {}-byte file; expected its data inside the file (truncated?)",
                       f.name, shape.empty() ? "scalar" : shape, tensorTypeName(f.dtype),
                       bytes ? fmt::format("{}", *bytes) : std::string("2^64 or more"),
                       f.data_offset, size));
    }
    for (const TensorField& g : fields_)
      if (g.name == f.name)
        fail(f.header_offset, fmt::format("field \"{}\" appears twice", f.name));
    fields_.push_back(std::move(f));
  }
}

const TensorField* TensorFile::find(std::string_view name) const {
  for (const TensorField& f : fields_)
    if (f.name == name) return &f;
  return nullptr;
}

const TensorField& TensorFile::require(std::string_view name, std::string_view what) const {
  if (const TensorField* f = find(name)) return *f;
  std::string names;
  for (const TensorField& f : fields_)
    names += fmt::format("{}\"{}\"", names.empty() ? "" : ", ", f.name);
  fail(14, fmt::format("no field \"{}\" ({}); the file has {}", name, what,
                       names.empty() ? std::string("no fields") : names));
}

double TensorFile::float32At(const TensorField& f, uint64_t i) const {
  const uint32_t bits = static_cast<uint32_t>(readLE(bytes_, byteOffset(f, i), 4));
  float v;
  std::memcpy(&v, &bits, 4);
  return v;
}

uint8_t TensorFile::uint8At(const TensorField& f, uint64_t i) const {
  return static_cast<uint8_t>(bytes_[byteOffset(f, i)]);
}

}  // namespace lensim::render
