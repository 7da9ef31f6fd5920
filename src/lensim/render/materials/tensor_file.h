// The "tensor file" container of the RGL material database (Dupuy & Jakob 2018, "An Adaptive
// Parameterization for Efficient Material Acquisition and Rendering"): a binary file of named
// n-dimensional arrays, read by pbrt-v4's `measured` material and Mitsuba's `measured` BSDF.
//
// Layout (facts from pbrt-v4 src/pbrt/bxdfs.cpp, class Tensor, which reads it with fread on
// little-endian machines; all integers little-endian):
//   offset 0:  12 bytes  "tensor_file\0"
//   offset 12: 2 bytes   version: major 1, minor 0
//   offset 14: uint32    number of fields
//   then per field:  uint16 name length, the name (no terminator), uint16 ndim, uint8 dtype,
//                    uint64 byte offset of the data in the file, ndim x uint64 shape
// dtype: 1 uint8, 2 int8, 3 uint16, 4 int16, 5 uint32, 6 int32, 7 uint64, 8 int64, 9 float16,
// 10 float32, 11 float64. The data of a field is the product of its shape elements of its dtype,
// row-major (last index fastest), at its offset.
//
// Errors name the file and the byte offset of the bad header entry or value:
// `x.bsdf: error: byte 14: ...`.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace lensim::render {

/// One named array of a tensor file.
struct TensorField {
  enum class DType : uint8_t {
    Invalid = 0,
    UInt8,
    Int8,
    UInt16,
    Int16,
    UInt32,
    Int32,
    UInt64,
    Int64,
    Float16,
    Float32,
    Float64,
  };
  std::string name;
  DType dtype = DType::Invalid;
  std::vector<uint64_t> shape;
  uint64_t count = 0;          ///< product of shape (1 for ndim 0)
  uint64_t data_offset = 0;    ///< byte offset of the data in the file
  uint64_t header_offset = 0;  ///< byte offset of the field's header entry (for messages)
};

/// Bytes of one element of `t` (0 for Invalid).
std::size_t tensorTypeSize(TensorField::DType t);
/// "float32", "uint8", ...
std::string_view tensorTypeName(TensorField::DType t);

/// A tensor file held in memory. Every field's data is checked to lie inside the file (so a
/// header cannot claim more data than the file holds), with overflow-checked sizes.
class TensorFile {
 public:
  /// Parses `bytes` (the whole file); `path` names it in messages. Throws lensim::Error.
  TensorFile(std::string bytes, std::string path);
  /// Reads a regular file of at most 1 GiB and parses it.
  static TensorFile read(const std::string& path);

  const std::string& path() const { return path_; }
  const std::vector<TensorField>& fields() const { return fields_; }
  /// nullptr when there is no such field.
  const TensorField* find(std::string_view name) const;
  /// The field, or lensim::Error "has no field "<name>" (...)".
  const TensorField& require(std::string_view name, std::string_view what) const;

  /// Element i of a float32 field as a double; the caller has checked the dtype.
  double float32At(const TensorField& f, uint64_t i) const;
  uint8_t uint8At(const TensorField& f, uint64_t i) const;
  /// Byte offset of element i (for messages).
  uint64_t byteOffset(const TensorField& f, uint64_t i) const {
    return f.data_offset + i * tensorTypeSize(f.dtype);
  }
  /// Throws lensim::Error at `byte`: "<path>: error: byte <byte>: <message>".
  [[noreturn]] void fail(uint64_t byte, const std::string& message) const;

 private:
  std::string bytes_;
  std::string path_;
  std::vector<TensorField> fields_;
};

}  // namespace lensim::render
