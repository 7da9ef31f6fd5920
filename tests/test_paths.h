// Paths of the data the tests use.
#pragma once

#include <string>

namespace lensim::test {

/// A lens shipped in the repository's lenses/ folder.
inline std::string lensPath(const std::string& name) {
  return std::string(LENSIM_SOURCE_DIR) + "/lenses/" + name;
}
/// A file under tests/data/.
inline std::string dataPath(const std::string& name) {
  return std::string(LENSIM_SOURCE_DIR) + "/tests/data/" + name;
}
/// The four classic lenses of the assignment.
inline const char* const kClassicLenses[] = {"dgauss.50mm.dat", "fisheye.10mm.dat", "wide.22mm.dat",
                                             "telephoto.250mm.dat"};

}  // namespace lensim::test
