// See check.h.
#include "lensim/util/check.h"

#include <cstdio>
#include <cstdlib>

namespace lensim {

void checkFailed(const char* condition, const char* file, int line, const std::string& values) {
  std::fprintf(stderr, "%s:%d: internal error: check failed: %s%s%s\n", file, line, condition,
               values.empty() ? "" : " ", values.c_str());
  std::fflush(stderr);
  std::abort();
}

}  // namespace lensim
