// The malformed-scene corpus: every file in data/bad_scenes/MANIFEST.tsv must be rejected with
// the listed location and message.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "lensim/scene/description.h"

using namespace lensim;
namespace fs = std::filesystem;

namespace {

struct BadScene {
  std::string file, location, message;
};

const fs::path kDir = fs::path(LENSIM_SOURCE_DIR) / "tests" / "data" / "bad_scenes";

std::vector<BadScene> manifest() {
  std::vector<BadScene> rows;
  std::ifstream in(kDir / "MANIFEST.tsv");
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    BadScene b;
    std::getline(ls, b.file, '\t');
    std::getline(ls, b.location, '\t');
    std::getline(ls, b.message);
    rows.push_back(b);
  }
  return rows;
}

}  // namespace

TEST(BadScenes, EachIsRejectedWithItsLocationAndMessage) {
  auto rows = manifest();
  ASSERT_GE(rows.size(), 20u);
  for (const BadScene& b : rows) {
    SCOPED_TRACE(b.file);
    std::string path = (kDir / b.file).string();
    try {
      scene::loadScene(path);
      ADD_FAILURE() << b.file << " was accepted";
    } catch (const Error& e) {
      auto colon = b.location.find(':');
      fs::path expected_file = (kDir / b.location.substr(0, colon)).lexically_normal();
      EXPECT_EQ(fs::path(e.loc().file).lexically_normal(), expected_file);
      EXPECT_EQ(fmt::format("{}:{}", e.loc().line, e.loc().column), b.location.substr(colon + 1));
      EXPECT_NE(e.message().find(b.message), std::string::npos)
          << "message: " << e.message() << "\nexpected: " << b.message;
      EXPECT_NE(std::string(e.what()).find(": error: "), std::string::npos);
    }
  }
}

TEST(BadScenes, EveryFileIsInTheManifest) {
  std::set<std::string> listed;
  for (const BadScene& b : manifest()) listed.insert(b.file);
  for (const auto& entry : fs::directory_iterator(kDir)) {
    if (entry.path().extension() != ".pbrt") continue;
    EXPECT_TRUE(listed.count(entry.path().filename().string()))
        << entry.path() << " is not in MANIFEST.tsv";
  }
}
