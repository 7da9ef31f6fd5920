// See check.h.
#include "lensim/util/check.h"

#include <cstdio>
#include <cstdlib>

namespace lensim {

void checkFailed(const char* condition, const char* file, int line) {
  std::fprintf(stderr, "%s:%d: internal error: check failed: %s\n", file, line, condition);
  std::fflush(stderr);
  std::abort();
}

}  // namespace lensim
