// Lens design's stopping rule and global search (issue 33, docs/design.md): closed-form problems
// with known minima, and a design job whose start lies in the wrong basin.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "lensim/optics/design/design_job.h"
#include "lensim/optics/design/levenberg_marquardt.h"
#include "lensim/util/error.h"

namespace fs = std::filesystem;
using namespace lensim;
using namespace lensim::optics::design;

namespace {

// Two minima: merit (x^2 - 1)^2 + 0.1 (x - 1)^2 + (y - 2)^2 is 0 at (1, 2), the global minimum,
// and has a local one at the root of 4x^3 - 3.8x - 0.2 = 0 near x = -0.947 (merit about 0.39).
bool twoMinima(const std::vector<double>& x, std::vector<double>& r) {
  r = {x[0] * x[0] - 1, std::sqrt(0.1) * (x[0] - 1), x[1] - 2};
  return true;
}

// The local minimum's x by Newton's method on the cubic's derivative condition.
double localMinimumX() {
  double x = -1;
  for (int i = 0; i < 50; ++i) x -= (4 * x * x * x - 3.8 * x - 0.2) / (12 * x * x - 3.8);
  return x;
}

TEST(DesignGlobalSearch, PlainLmStaysInTheLocalBasin) {
  const LmResult r = levenbergMarquardt(twoMinima, {-1.5, 0.0}, {-2, -5}, {2, 5});
  const double xl = localMinimumX();
  EXPECT_NEAR(r.x[0], xl, 1e-6);
  EXPECT_NEAR(r.x[1], 2, 1e-6);
  EXPECT_NEAR(r.merit, std::pow(xl * xl - 1, 2) + 0.1 * std::pow(xl - 1, 2), 1e-9);
}

TEST(DesignGlobalSearch, MultiStartFindsTheGlobalMinimumReproducibly) {
  GlobalOptions g;
  g.starts = 8;
  g.seed = 42;
  std::vector<std::vector<double>> starts;
  g.on_start = [&](int k, const std::vector<double>& x, const LmResult&) {
    EXPECT_EQ(k, static_cast<int>(starts.size()));
    starts.push_back(x);
  };
  const LmResult r = multiStartLevenbergMarquardt(twoMinima, {-1.5, 0.0}, {-2, -5}, {2, 5}, {}, g);
  EXPECT_NEAR(r.x[0], 1, 1e-6);
  EXPECT_NEAR(r.x[1], 2, 1e-6);
  EXPECT_LT(r.merit, 1e-12);
  ASSERT_EQ(starts.size(), 8u);
  EXPECT_EQ(starts[0], (std::vector<double>{-1.5, 0.0}));  // the given start comes first
  for (const auto& s : starts) {
    EXPECT_GE(s[0], -2);
    EXPECT_LE(s[0], 2);
    EXPECT_GE(s[1], -5);
    EXPECT_LE(s[1], 5);
  }
  // The same seed gives the same starts and result; another seed other starts.
  std::vector<std::vector<double>> again, other;
  g.on_start = [&](int, const std::vector<double>& x, const LmResult&) { again.push_back(x); };
  const LmResult r2 = multiStartLevenbergMarquardt(twoMinima, {-1.5, 0.0}, {-2, -5}, {2, 5}, {}, g);
  EXPECT_EQ(again, starts);
  EXPECT_EQ(r2.x, r.x);
  g.seed = 43;
  g.on_start = [&](int, const std::vector<double>& x, const LmResult&) { other.push_back(x); };
  multiStartLevenbergMarquardt(twoMinima, {-1.5, 0.0}, {-2, -5}, {2, 5}, {}, g);
  EXPECT_NE(other[1], starts[1]);
}

TEST(DesignGlobalSearch, UnboundedVariablesSpreadAboutTheStart) {
  GlobalOptions g;
  g.starts = 64;
  g.spread = 0.5;
  g.scales = {1.0, 10.0};
  double lo0 = 1e9, hi0 = -1e9, lo1 = 1e9, hi1 = -1e9;
  g.on_start = [&](int, const std::vector<double>& x, const LmResult&) {
    lo0 = std::min(lo0, x[0]), hi0 = std::max(hi0, x[0]);
    lo1 = std::min(lo1, x[1]), hi1 = std::max(hi1, x[1]);
  };
  multiStartLevenbergMarquardt(twoMinima, {4.0, 0.0}, {}, {}, {}, g);
  // x0 +- 0.5 max(|x0|, scale): [2, 6] and [-5, 5], nearly filled by 64 draws.
  EXPECT_GE(lo0, 2);
  EXPECT_LE(hi0, 6);
  EXPECT_LT(lo0, 2.3);
  EXPECT_GT(hi0, 5.7);
  EXPECT_GE(lo1, -5);
  EXPECT_LE(hi1, 5);
  EXPECT_LT(lo1, -4);
  EXPECT_GT(hi1, 4);
}

TEST(DesignStoppingRule, WindowRuleStopsACrawlAndNamesIt) {
  // Merit 1 + 1e-6 exp(-2x): every step gains (Gauss-Newton moves x by 1), but all the gains
  // together are below 1e-6 of the merit, so the window rule (1e-4 over 10 iterations) stops
  // after exactly 10 iterations. The per-step rule is switched off to isolate it.
  auto f = [](const std::vector<double>& x, std::vector<double>& r) {
    r = {1, 1e-3 * std::exp(-x[0])};
    return true;
  };
  LmOptions o;
  o.relative_tolerance = 0;
  const LmResult r = levenbergMarquardt(f, {0.0}, {}, {}, o);
  EXPECT_EQ(r.stop_reason, "merit fell by less than 0.0001 over the last 10 iterations");
  EXPECT_EQ(r.iterations, 10);
  EXPECT_NEAR(r.x[0], 10, 1e-2);  // x moved by 1 per iteration: every step was accepted
  o.window = 0;
  const LmResult r2 = levenbergMarquardt(f, {0.0}, {}, {}, o);
  EXPECT_GT(r2.iterations, 10);
  EXPECT_NE(r2.stop_reason, r.stop_reason);
}

// A design job with a global search: no worse than the plain run from the same lens (the first
// start is that run), and the same lens again from the same seed.
TEST(DesignGlobalSearch, DesignJobKeepsTheBestStartReproducibly) {
  fs::path dir =
      fs::temp_directory_path() / ("lensim_design_g_" + std::to_string(std::random_device{}()));
  fs::create_directories(dir);
  std::ofstream(dir / "singlet.dat") << "0 5 1 20\n80 4 1.5168 30\n-120 90 1 30\n";
  auto job = [&](const std::string& global) {
    std::ofstream(dir / "job.json")
        << "{\"lens\": \"singlet.dat\", \"max_iterations\": 30" << global << ",\n"
        << " \"variables\": [{\"type\": \"curvature\", \"surface\": 1}, {\"type\": \"curvature\", "
           "\"surface\": 2},\n"
        << "   {\"type\": \"thickness\", \"surface\": 2, \"min\": 50, \"max\": 150}],\n"
        << " \"operands\": [{\"type\": \"efl\", \"target\": 100, \"weight\": 1000}, {\"type\": "
           "\"rms_spot\", \"weight\": 100}]}";
    return readDesignJob((dir / "job.json").string());
  };
  const DesignResult plain = optimiseDesign(job(""));
  std::vector<std::string> log;
  const DesignResult g = optimiseDesign(job(", \"global\": {\"starts\": 4, \"seed\": 3}"),
                                        [&](const std::string& s) { log.push_back(s); });
  EXPECT_LE(g.merit, plain.merit * (1 + 1e-12));
  int start_lines = 0;
  for (const auto& l : log) start_lines += l.rfind("optimise start", 0) == 0;
  EXPECT_EQ(start_lines, 4);
  const DesignResult again = optimiseDesign(job(", \"global\": {\"starts\": 4, \"seed\": 3}"));
  for (size_t i = 0; i < g.lens.surfaces.size(); ++i) {
    EXPECT_EQ(again.lens.surfaces[i].radius_mm, g.lens.surfaces[i].radius_mm);
    EXPECT_EQ(again.lens.surfaces[i].thickness_mm, g.lens.surfaces[i].thickness_mm);
  }
  fs::remove_all(dir);
}

TEST(DesignGlobalSearch, JobKeyIsParsedAndChecked) {
  fs::path dir =
      fs::temp_directory_path() / ("lensim_design_g_" + std::to_string(std::random_device{}()));
  fs::create_directories(dir);
  std::ofstream(dir / "singlet.dat") << "0 5 1 20\n80 4 1.5168 30\n-120 90 1 30\n";
  auto job = [&](const std::string& g) {
    std::ofstream(dir / "job.json") << "{\"lens\": \"singlet.dat\",\n \"global\": " << g
                                    << ",\n \"operands\": [{\"type\": \"efl\", \"target\": 100}]}";
    return readDesignJob((dir / "job.json").string());
  };
  const DesignJob j = job("{\"starts\": 5, \"seed\": 9}");
  EXPECT_EQ(j.global_starts, 5);
  EXPECT_EQ(j.global_seed, 9u);
  auto err = [&](const std::string& g) {
    try {
      job(g);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(err("{\"starts\": 0}")
                .find("job.json:2:2: error: \"starts\" 0 must be an integer 1 to 10000"),
            std::string::npos)
      << err("{\"starts\": 0}");
  EXPECT_NE(err("{\"starts\": 2, \"sead\": 1}").find("unknown key \"sead\""), std::string::npos);
  fs::remove_all(dir);
}

}  // namespace
