// `lensim check` from the command line: exit status, summary, errors, --format.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <cstdio>
#include <string>
#include "cli_run.h"

namespace {

using Result = lensim::test::CliResult;

Result run(const std::string& args) {
  return lensim::test::runLensim(args);
}

const std::string kShared = LENSIM_SHARED_DIR;

}  // namespace

TEST(CheckCommand, SummarisesTheDofDragonsScene) {
  Result r = run("check " + kShared + "/scenes/ntu-dis-2015-dof-dragons/dof-dragons.dgauss.pbrt");
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("instances: 11"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("objects: 2: \"dragon-b\" (cone ×1), \"dragon-a\" (cone ×1)"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("film distance 36.77 mm"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("film: image (as rgb), 300×300, output \"dof-dragons.dgauss512.exr\""),
            std::string::npos)
      << r.out;
}

TEST(CheckCommand, FailsWithLocatedErrors) {
  Result r = run("check " + std::string(LENSIM_SOURCE_DIR) +
                 "/tests/data/bad_scenes/unknown_shape_param.pbrt");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("unknown_shape_param.pbrt:2:31: error: \"innerradus\": unused parameter"),
            std::string::npos)
      << r.out;
  EXPECT_EQ(r.out.find("shapes:"), std::string::npos);
  Result missing = run("check /nonexistent/scene.pbrt");
  EXPECT_EQ(missing.status, 1);
  EXPECT_NE(missing.out.find("error: cannot open scene file"), std::string::npos);
}

TEST(CheckCommand, FormatPrintsPbrtV4) {
  Result r =
      run("check --format " + kShared + "/scenes/ntu-dis-2015-dof-dragons/dof-dragons.dgauss.pbrt");
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("Material \"diffuse\" \"texture reflectance\" \"sgrid\""), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("AreaLightSource \"diffuse\" \"rgb L\" [ 40 40 40 ]"), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("\"point2 uv\" [ 0 0 5 0 5 5 0 5 ]"), std::string::npos) << r.out;
}

TEST(CheckCommand, ReportsEveryMissingFileOfTheSanMiguelExample) {
  // The San Miguel geometry is not in the shared folder: 21 missing Includes and the sky map.
  Result r = run("check " + kShared +
                 "/scenes/pbrt-v4-sanmiguel-realistic/sanmiguel-realistic-courtyard.pbrt");
  EXPECT_EQ(r.status, 1);
  size_t errors = 0;
  for (size_t pos = 0; (pos = r.out.find(": error: ", pos)) != std::string::npos; ++pos) ++errors;
  EXPECT_EQ(errors, 22u) << r.out;
  EXPECT_NE(r.out.find("sanmiguel-realistic-courtyard.pbrt:45:1: error: included file "
                       "\"geometry/sanmiguel-mat.pbrt\" not found"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("sanmiguel-realistic-courtyard.pbrt:38:9: error: environment map "
                       "\"textures/sky.exr\" not found"),
            std::string::npos)
      << r.out;
}
