// Phase 1 of scene loading: reads pbrt scene files (v4, and the v1–v3 syntax) into a SceneDesc
// that records what the files say, with Includes expanded and a file:line:col on every directive
// and parameter. Only syntax and block structure are checked here; the builder (builder.h)
// validates parameters and creates objects.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "lensim/util/error.h"

namespace lensim::scene {

/// The value type of a parameter, under its pbrt-v4 name.
enum class ParamType {
  Float,
  Integer,
  Bool,
  String,
  Texture,
  Point2,
  Point3,
  Vector2,
  Vector3,
  Normal3,
  Rgb,
  Spectrum,
  Blackbody
};

/// The pbrt-v4 spelling of a parameter type ("float", "point3", "rgb", ...).
std::string_view paramTypeName(ParamType t);

/// One parameter as written: `"type name" value` or `"type name" [values]`.
struct Param {
  ParamType type = ParamType::Float;
  std::string type_as_written;  ///< e.g. "color" or "point" in v1–v3 files
  std::string name;
  FileLoc loc;                       ///< where the declaration string starts
  std::vector<double> numbers;       ///< numeric types, and spectrum given as values
  std::vector<std::string> strings;  ///< string, texture, and spectrum given by name or file
  std::vector<bool> bools;           ///< bool
};

using ParamList = std::vector<Param>;

/// One directive as written (Include and Import are expanded in place and not listed).
struct Directive {
  std::string name;                  ///< as written: "Shape", "Filter", "SurfaceIntegrator", ...
  FileLoc loc;                       ///< where the directive name starts
  std::vector<std::string> strings;  ///< positional strings (type, name, texture class, ...)
  std::vector<double> numbers;       ///< positional numbers (Translate, LookAt, Transform, ...)
  std::string word;                  ///< ActiveTransform's StartTime / EndTime / All
  ParamList params;
};

/// Everything the scene files say, in order.
struct SceneDesc {
  std::string path;  ///< the top-level file as given
  std::vector<Directive> directives;
  /// Errors that did not stop parsing (a missing Include file); parsing continued after them.
  std::vector<Diagnostic> diagnostics;
  /// True if the files use syntax that only pbrt v1–v3 accept (WorldEnd, `color`, ...).
  bool legacy_syntax = false;
  /// Every scene file read, top-level first.
  std::vector<std::string> files;
};

/// Parses a scene file and the files it includes. Throws lensim::Error for syntax errors and
/// block-structure errors; records missing Include files in SceneDesc::diagnostics.
SceneDesc parseFile(const std::string& path);
/// Parses scene text; Include paths are relative to the directory of `file_name`.
SceneDesc parseString(std::string_view text, const std::string& file_name = "<string>");

}  // namespace lensim::scene
