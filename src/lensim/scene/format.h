// Text output of scenes: the `lensim check` summary (declared in builder.h) and `--format`, the
// scene re-printed in normalised pbrt-v4 syntax.
#pragma once

#include <string>

#include "lensim/scene/parser.h"

namespace lensim::scene {

/// The scene in pbrt-v4 syntax: Includes expanded, v1–v3 directive, type and parameter names
/// replaced by their pbrt-v4 equivalents where the meaning is the same, one directive per line.
/// Constructs pbrt-v4 lacks (the pbrt-v1/v2 realistic camera) are kept and marked in a comment.
std::string formatPbrtV4(const SceneDesc& desc);

}  // namespace lensim::scene
