// One libFuzzer executable per target: LENSIM_FUZZ_TARGET names the function (see CMakeLists).
#include <cstddef>
#include <cstdint>

#include "targets.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return lensim::fuzz::LENSIM_FUZZ_TARGET(data, size);
}
