// Lens files with one line changed: every outcome of reading them and computing what `lens info`
// computes is a lens or a located lensim::Error, never a crash, a hang or another exception.
//
// The mutations are single-line and semantic (issue 28): a line deleted, two lines swapped
// (TYPE, PARM, GLAS, DIAM and CURV lines exchanged between surfaces), a number replaced by
// 0, -1, 1e300 or nan, and the file truncated after a line.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "lensim/optics/chief_ray.h"
#include "lensim/optics/focus.h"
#include "lensim/optics/lens_formats.h"
#include "lensim/optics/paraxial.h"
#include "lensim/optics/prescription.h"
#include "lensim/util/error.h"
#include "test_paths.h"

using namespace lensim;
using namespace lensim::optics;

namespace {

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::vector<std::string> splitLines(const std::string& text) {
  std::vector<std::string> lines;
  std::string cur;
  for (char c : text) {
    if (c == '\n') {
      lines.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  if (!cur.empty()) lines.push_back(cur);
  return lines;
}

std::string joinLines(const std::vector<std::string>& lines) {
  std::string out;
  for (const std::string& l : lines) out += l + "\n";
  return out;
}

// The first word of a line (its keyword in a .zmx file).
std::string keyOf(const std::string& line) {
  std::istringstream in(line);
  std::string k;
  in >> k;
  return k;
}

LensPrescription parseByExtension(const std::string& text, const std::string& name) {
  const std::string ext = std::filesystem::path(name).extension().string();
  if (ext == ".zmx") return parseZmx(text, name);
  if (ext == ".json") return parseLensJson(text, name);
  return parseLensPrescription(text, name);
}

// What `lens info` computes from a lens file (focus at infinity or the file's film): the
// outcome "ok", or the error; anything but lensim::Error escapes and fails the test.
std::string lensInfoOutcome(const std::string& text, const std::string& name) {
  try {
    LensPrescription p = parseByExtension(text, name);
    FocusedLens fl = [&] {
      try {
        return focusLens(std::move(p), LensSetup{});
      } catch (const Error& e) {
        // Focus errors have no row of their own: the CLI names the lens file (setUpLens).
        if (e.loc().valid()) throw;
        throw Error(FileLoc{name}, e.message());
      }
    }();
    const LensSystem& lens = *fl.lens;
    (void)workingFNumber(lens, fl.paraxial, std::nullopt);
    (void)fieldOfView(lens, fl.paraxial, 43.27);
    (void)closestFocusDistance_m(lens, fl.paraxial);
    return "ok";
  } catch (const Error& e) {
    return e.what();
  }
}

// Number-like tokens of a line: (start, length).
std::vector<std::pair<size_t, size_t>> numberTokens(const std::string& line) {
  std::vector<std::pair<size_t, size_t>> out;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == ',' ||
                               line[i] == ':' || line[i] == '[' || line[i] == ']'))
      ++i;
    const size_t s = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t' && line[i] != ',' && line[i] != ']')
      ++i;
    if (i > s &&
        (std::isdigit(static_cast<unsigned char>(line[s])) || line[s] == '-' || line[s] == '.'))
      out.push_back({s, i - s});
  }
  return out;
}

struct Mutant {
  std::string what;
  std::string text;
};

// The mutations of one file, deterministic: every stride-th of each kind (time).
std::vector<Mutant> mutate(const std::string& text, size_t stride) {
  const std::vector<std::string> lines = splitLines(text);
  std::vector<Mutant> out;
  size_t counter = 0;
  for (size_t i = 0; i < lines.size(); ++i) {
    std::vector<std::string> m = lines;
    m.erase(m.begin() + long(i));
    if (i % stride == 0) out.push_back({fmt::format("delete line {}", i + 1), joinLines(m)});
    if (i % (3 * stride) == 1)
      out.push_back({fmt::format("truncate after line {}", i + 1),
                     joinLines({lines.begin(), lines.begin() + long(i)}) +
                         lines[i].substr(0, lines[i].size() / 2)});
    // The first two numbers of a line (the values; the rest are mostly solve flags).
    auto nums = numberTokens(lines[i]);
    if (nums.size() > 2) nums.resize(2);
    for (const auto& [s, n] : nums) {
      for (const char* v : {"0", "-1", "1e300", "nan"}) {
        if (counter++ % stride != 0) continue;
        std::vector<std::string> mm = lines;
        mm[i] = lines[i].substr(0, s) + v + lines[i].substr(s + n);
        out.push_back({fmt::format("line {} col {} -> {}", i + 1, s + 1, v), joinLines(mm)});
      }
    }
  }
  // Semantic swaps: lines with the same keyword exchanged between places (surfaces).
  for (const char* key : {"TYPE", "PARM", "GLAS", "DIAM", "CURV", "DISZ", "STOP"}) {
    std::vector<size_t> at;
    for (size_t i = 0; i < lines.size(); ++i)
      if (keyOf(lines[i]) == key) at.push_back(i);
    for (size_t a = 0; a < at.size(); ++a)
      for (size_t b = a + 1; b < at.size() && b < a + 4; ++b) {
        if (lines[at[a]] == lines[at[b]] || counter++ % stride != 0) continue;
        std::vector<std::string> m = lines;
        std::swap(m[at[a]], m[at[b]]);
        out.push_back({fmt::format("swap lines {} and {}", at[a] + 1, at[b] + 1), joinLines(m)});
      }
  }
  // Adjacent lines swapped (a surface's line moved into the next block).
  for (size_t i = 0; i + 1 < lines.size(); i += 2 * stride) {
    std::vector<std::string> m = lines;
    std::swap(m[i], m[i + 1]);
    out.push_back({fmt::format("swap lines {} and {}", i + 1, i + 2), joinLines(m)});
  }
  return out;
}

void runMutations(const std::string& path, size_t stride) {
  const std::string text = decodeTextFile(slurp(path), path);  // UTF-16 files as UTF-8
  ASSERT_FALSE(text.empty()) << path;
  const std::string name = std::filesystem::path(path).filename().string();
  ASSERT_EQ(lensInfoOutcome(text, name), "ok") << path;
  int ok = 0, refused = 0;
  for (const Mutant& m : mutate(text, stride)) {
    SCOPED_TRACE(fmt::format("{}: {}", name, m.what));
    std::string outcome;
    try {
      outcome = lensInfoOutcome(m.text, name);
    } catch (const std::exception& e) {
      ADD_FAILURE() << "not a lensim::Error: " << e.what();
      continue;
    }
    if (outcome == "ok") {
      ++ok;
    } else {
      ++refused;
      // Located: the message starts with the file's name.
      EXPECT_EQ(outcome.rfind(name, 0), 0u) << outcome;
    }
  }
  // Both outcomes occur: the mutations reach the readers' checks and leave some lenses readable.
  EXPECT_GT(ok, 0) << name;
  EXPECT_GT(refused, 0) << name;
}

}  // namespace

// The crash of issue 28: TYPE TOROIDAL and TYPE STANDARD swapped between two surfaces. Surface
// 4 of the anamorphic lens becomes a toroid without PARM lines (a cylinder, radius of rotation
// infinite) whose first-crossing check ran with no gradient buffers.
TEST(LensFileMutation, SwappedToroidalAndStandardTypesDoNotCrash) {
  std::string text = slurp(test::lensPath("toroidal-anamorphic.50mm.zmx"));
  std::vector<std::string> lines = splitLines(text);
  std::vector<size_t> toroidal, standard;
  for (size_t i = 0; i < lines.size(); ++i) {
    if (lines[i].find("TYPE TOROIDAL") != std::string::npos) toroidal.push_back(i);
    if (lines[i].find("TYPE STANDARD") != std::string::npos) standard.push_back(i);
  }
  ASSERT_GE(toroidal.size(), 4u);
  ASSERT_GE(standard.size(), 3u);
  int ok = 0;
  for (size_t a : toroidal)
    for (size_t b : standard) {
      // Surface 9's TYPE STANDARD (the crash) with every toroid, a few other pairs (time).
      if (lines[b - 1].find("SURF 9") == std::string::npos && (a + b) % 5 != 0) continue;
      std::vector<std::string> m = lines;
      std::swap(m[a], m[b]);
      SCOPED_TRACE(fmt::format("swap lines {} and {}", a + 1, b + 1));
      const std::string outcome = lensInfoOutcome(joinLines(m), "anamorphic.zmx");
      if (outcome == "ok")
        ++ok;
      else
        EXPECT_EQ(outcome.rfind("anamorphic.zmx:", 0), 0u) << outcome;
    }
  EXPECT_GT(ok, 0);
}

TEST(LensFileMutation, ZemaxFiles) {
  runMutations(test::lensPath("toroidal-anamorphic.50mm.zmx"), 7);
  runMutations(std::string(LENSIM_SHARED_DIR) + "/lenses/zmx/US00583336-2-scaled.zmx", 4);
}

// Surfaces without DIAM: the automatic semi-diameters' rays under every mutation.
TEST(LensFileMutation, ZemaxFileWithoutSemiDiameters) {
  runMutations(std::string(LENSIM_SHARED_DIR) + "/lenses/zmx/optiland/lens1.zmx", 1);
  // With ray aiming (RAIM) and a surface with DIAM 0.
  runMutations(std::string(LENSIM_SHARED_DIR) +
                   "/lenses/zmx/optiland/circular_aperture_example_with_aperture.zmx",
               40);
}

TEST(LensFileMutation, DatAndJsonFiles) {
  runMutations(test::lensPath("dgauss.50mm.dat"), 2);
  runMutations(test::lensPath("fisheye.10mm.dat"), 3);
  runMutations(test::lensPath("cassegrain.500mm.json"), 3);
  runMutations(test::lensPath("us583336-double-gauss.json"), 3);
}
