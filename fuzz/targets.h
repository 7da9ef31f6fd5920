// The fuzz targets: each takes arbitrary bytes and runs them through one of lensim's readers the
// way the CLI does. Bad input must end in lensim::Error (caught here); anything else -- a crash,
// a sanitizer report, another exception, a hang or runaway memory -- is a finding.
//
// The same functions are built two ways: as libFuzzer executables with ASan+UBSan (scripts/fuzz,
// CMake option LENSIM_FUZZ, clang), and into lensim_fuzz_replay, which the ordinary build and
// test suite use to replay the seed corpora in fuzz/corpus/ (so CI catches regressions without
// clang).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string_view>

namespace lensim::fuzz {

using TargetFn = int (*)(const uint8_t* data, size_t size);

struct Target {
  std::string_view name;  ///< also the corpus folder: fuzz/corpus/<name>/
  TargetFn run;
};

/// Once per process: a memory budget of 256 MiB (so that refused sizes are found well below
/// libFuzzer's RSS limit) and no log output.
void initFuzzing();

int fuzzLens(const uint8_t* data, size_t size);         ///< lens prescription, then focus
int fuzzSceneTokens(const uint8_t* data, size_t size);  ///< the scene tokenizer
int fuzzSceneParse(const uint8_t* data, size_t size);   ///< tokenizer + parser
int fuzzSceneBuild(const uint8_t* data, size_t size);   ///< parser + builder
int fuzzSceneRender(const uint8_t* data, size_t size);  ///< builder + a 4x4 render, 1 spp
int fuzzPly(const uint8_t* data, size_t size);          ///< PLY meshes
int fuzzImage(const uint8_t* data, size_t size);        ///< image headers and data (every format)
int fuzzBrdf(const uint8_t* data, size_t size);         ///< pbrt-v2 irregular .brdf
int fuzzZmx(const uint8_t* data, size_t size);          ///< Zemax .zmx lens files, then focus
int fuzzLensJson(const uint8_t* data, size_t size);     ///< lensim/lentil/ISET JSON lenses
int fuzzBsdf(const uint8_t* data, size_t size);         ///< RGL measured BSDF (.bsdf), then
                                                        ///< evaluation and sampling
int fuzzFourier(const uint8_t* data, size_t size);      ///< pbrt-v3 tabulated BSDF (SCATFUN),
                                                        ///< then evaluation and sampling

/// Every target, in a fixed order.
const Target* targets(size_t& count);

}  // namespace lensim::fuzz
