// The page's files (web/), embedded into the binary at build time by cmake/embed_files.cmake so
// that `lensim serve` needs nothing beside itself.
#pragma once

#include <cstddef>
#include <string_view>

namespace lensim::serve {

struct WebAsset {
  std::string_view path;  ///< URL path, e.g. "/app.js"
  std::string_view content;
};

/// Every embedded file; "/index.html" is also served at "/".
const WebAsset* webAssets(size_t* count);

}  // namespace lensim::serve
