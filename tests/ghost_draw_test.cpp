// `lens draw --ghost I,J` (issue 31): the ghost path traced exactly by the lens's tracer, against
// the paraxial ghost focus of `lens ghosts --json` (checked independently in coating_test.cpp)
// and a closed-form vergence; the SVG's ghost rays; refusals of bad pairs.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cli_run.h"
#include "lensim/optics/coating/ghost_trace.h"
#include "lensim/optics/diagram.h"
#include "lensim/optics/focus.h"
#include "lensim/optics/lens_system.h"
#include "lensim/optics/prescription.h"
#include "lensim/util/error.h"
#include "test_paths.h"

using namespace lensim;
using namespace lensim::optics;
using lensim::test::lensPath;
using lensim::test::runLensim;
using nlohmann::json;

namespace {

const std::string kGauss = lensPath("dgauss.50mm.dat");

std::string tempPath(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / "lensim_ghost_draw_test";
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

size_t countOf(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
  return n;
}

// The z where a meridional ray at entrance height h, parallel to the axis, crosses the axis
// after the ghost path (nullopt: blocked or leaving parallel).
std::optional<double> tracedCrossing(const LensTracer<double>& tracer, double h) {
  const TraceResult r = tracer.traceFromScene(Ray{{h, 0, -10}, {0, 0, 1}});
  if (!r.ok()) return std::nullopt;
  return axisCrossingZ(r.ray);
}

}  // namespace

TEST(GhostDraw, TracedCrossingMatchesTheParaxialFocusOfLensGhosts) {
  const auto r = runLensim("lens ghosts " + kGauss + " --json");
  ASSERT_EQ(r.status, 0) << r.out;
  const json j = json::parse(r.out.substr(r.out.find("{\n")));
  const FocusedLens fl = focusLens(readLensFile(kGauss), LensSetup{});
  const LensSystem& lens = *fl.lens;
  ASSERT_NEAR(lens.filmZ_mm(), j["film_z_mm"].get<double>(), 1e-6) << "a different focus";
  int checked = 0;
  for (const json& g : j["ghosts"]) {
    const int first = g["first_reflection_surface"], second = g["second_reflection_surface"];
    if (lens.interfaces()[size_t(first)].is_stop || lens.interfaces()[size_t(second)].is_stop)
      continue;  // the stop reflects nothing: no ghost to trace (refused, below)
    if (g["focus_z_mm"].is_null()) continue;
    const double focus = g["focus_z_mm"];
    const LensTracer<double> tracer = ghostTracer(lens, first, second);
    // A ray 1 um from the axis: aberrations ~ (h / R)^2 ~ 1e-9 of the distance to the focus.
    const double h = 1e-3;
    const auto z = tracedCrossing(tracer, h);
    ASSERT_TRUE(z) << first << "," << second;
    EXPECT_NEAR(*z, focus, 1e-5 * std::max(1.0, std::abs(focus - lens.rearVertexZ_mm())))
        << "ghost " << first << "," << second;
    // Symmetric about the axis.
    EXPECT_NEAR(*tracedCrossing(tracer, -h), *z, 1e-9 * std::max(1.0, std::abs(*z)));
    ++checked;
  }
  EXPECT_EQ(checked, 45);  // C(11,2) = 55 pairs, less the 10 that involve the stop
}

TEST(GhostDraw, PlanoConvexGhostFocusMatchesVergences) {
  // As in coating_test: R = 50 mm front, flat back, t = 5, n = 1.5; ghost (1, 0) by reduced
  // vergences V = n / s: refract at the front, to the back, back to the front, reflect there
  // (a concave mirror in glass: +2 n / R), to the back again, out (a flat: V unchanged).
  const double rr = 50, t = 5, n = 1.5;
  auto transfer = [](double v0, double d, double idx) { return 1 / (1 / v0 - d / idx); };
  double v = transfer(transfer((n - 1) / rr, t, n), t, n) + 2 * n / rr;
  v = transfer(v, t, n);
  const double focus = t + 1 / v;
  std::ofstream(tempPath("pcx.json"))
      << "{\"format\": \"lensim-lens\", \"surfaces\": [\n"
         "  {\"radius_mm\": 50, \"thickness_mm\": 5, \"semi_aperture_mm\": 10, \"ior\": 1.5},\n"
         "  {\"radius_mm\": 0, \"thickness_mm\": 1, \"semi_aperture_mm\": 10},\n"
         "  {\"radius_mm\": 0, \"thickness_mm\": 90, \"semi_aperture_mm\": 10, \"stop\": true}\n"
         "]}\n";
  LensSystem lens(readLensFile(tempPath("pcx.json")));
  const auto z = tracedCrossing(ghostTracer(lens, 1, 0), 1e-3);
  ASSERT_TRUE(z);
  EXPECT_NEAR(*z, focus, 1e-6);
  // The path: front, back (mirror), front (mirror, from the glass side), back.
  const std::vector<Interface> path = ghostPathInterfaces(lens, 1, 0);
  ASSERT_EQ(path.size(), 5u);
  EXPECT_TRUE(path[1].is_mirror && path[2].is_mirror);
  EXPECT_DOUBLE_EQ(path[2].ior_before, 1.5);
  EXPECT_EQ(ghostPathSurface(1, 0, 2), 0);
  EXPECT_EQ(ghostPathSurface(1, 0, 4), 2);
}

TEST(GhostDraw, PlateGhostLeavesParallelAndDisplaced) {
  // A plane-parallel plate: the ghost (1, 0) leaves parallel to the axis at its entrance height.
  std::ofstream(tempPath("plate.json"))
      << "{\"format\": \"lensim-lens\", \"surfaces\": [\n"
         "  {\"radius_mm\": 0, \"thickness_mm\": 5, \"semi_aperture_mm\": 10, \"ior\": 1.5},\n"
         "  {\"radius_mm\": 0, \"thickness_mm\": 1, \"semi_aperture_mm\": 10},\n"
         "  {\"radius_mm\": 0, \"thickness_mm\": 50, \"semi_aperture_mm\": 10, \"stop\": true}\n"
         "]}\n";
  LensSystem lens(readLensFile(tempPath("plate.json")));
  const TraceResult r = ghostTracer(lens, 1, 0).traceFromScene(Ray{{3, 0, -10}, {0, 0, 1}});
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR(r.ray.origin.x, 3, 1e-12);
  EXPECT_NEAR(r.ray.direction.z, 1, 1e-15);
  EXPECT_FALSE(axisCrossingZ(r.ray));
}

TEST(GhostDraw, DiagramHoldsTheGhostBundle) {
  LensSetup setup;
  const FocusedLens fl = focusLens(readLensFile(kGauss), setup);
  DiagramOptions opts;
  LensDiagram d = buildLensDiagram(fl, opts);
  setGhostBundle(d, fl, 10, 8, 15);
  ASSERT_EQ(d.rays.size(), 15u);
  int through = 0;
  for (const DiagramRay& r : d.rays) {
    EXPECT_EQ(r.ghost, "10,8");
    if (!r.result.ok()) continue;
    ++through;
    // Start, 11 + 2 + 2 surface hits (surfaces 9, 8 twice more), the film.
    ASSERT_EQ(r.points.size(), 1u + 15u + 1u);
    EXPECT_NEAR(r.points.back().z, fl.lens->filmZ_mm(), 1e-9);
  }
  EXPECT_GE(through, 13);  // the edge rays sit on the rim of the beam that gets through
  EXPECT_THROW(setGhostBundle(d, fl, 5, 2, 5), Error);  // the stop reflects nothing
}

TEST(GhostDraw, CliDrawsOnePolylinePerGhostRay) {
  const std::string out = tempPath("ghost.svg");
  std::filesystem::remove(out);
  const auto r = runLensim("lens draw " + kGauss + " --ghost 10,8 --rays 13 -o " + out);
  ASSERT_EQ(r.status, 0) << r.out;
  std::ifstream in(out);
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string svg = ss.str();
  EXPECT_EQ(countOf(svg, "class=\"ghost-ray\""), 13u);
  EXPECT_EQ(countOf(svg, "data-ghost=\"10,8\""), 13u);
  EXPECT_EQ(countOf(svg, "class=\"ray\""), 0u);                          // only the ghost's rays
  EXPECT_NE(svg.find("paraxial focus z 54.501 mm"), std::string::npos);  // from `lens ghosts`
}

TEST(GhostDraw, CliRefusesBadPairs) {
  const std::string out = tempPath("bad.svg");
  for (const std::string bad : {"3,10", "40,1", "10,10", "x", "10,", "-1,2", "5,2", "10,5"}) {
    std::filesystem::remove(out);
    const auto r = runLensim("lens draw " + kGauss + " --ghost " + bad + " -o " + out);
    EXPECT_EQ(r.status, 1) << bad << ": " << r.out;
    EXPECT_NE(r.out.find("ghost " + bad), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("error: "), std::string::npos) << r.out;
    EXPECT_FALSE(std::filesystem::exists(out)) << bad;
  }
}

TEST(GhostDraw, PlotGhostsBarsAreProportionalToLensGhostsIntensities) {
  const auto r = runLensim("lens ghosts " + kGauss + " --json --top 20");
  ASSERT_EQ(r.status, 0) << r.out;
  const json j = json::parse(r.out.substr(r.out.find("{\n")));
  const std::string out = tempPath("ghosts.svg");
  std::filesystem::remove(out);
  const auto p = runLensim("lens plot ghosts " + kGauss + " -o " + out);
  ASSERT_EQ(p.status, 0) << p.out;
  std::ifstream in(out);
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string svg = ss.str();
  // The bars in order: their heights (pixels) from the rect elements.
  std::vector<double> heights;
  for (size_t at = svg.find("class=\"bar\""); at != std::string::npos;
       at = svg.find("class=\"bar\"", at + 1)) {
    const size_t rect = svg.rfind("<rect", at);
    const size_t h = svg.find("height=\"", rect);
    ASSERT_LT(h, at);
    heights.push_back(std::stod(svg.substr(h + 8)));
  }
  ASSERT_EQ(heights.size(), 20u);
  const double i0 = j["ghosts"][0]["relative_intensity"];
  for (size_t k = 0; k < heights.size(); ++k) {
    const double ik = j["ghosts"][k]["relative_intensity"];
    EXPECT_NEAR(heights[k] / heights[0], ik / i0, 1e-4) << "bar " << k;
  }
  EXPECT_NE(svg.find("1: 10,9"), std::string::npos);  // the brightest, as `lens ghosts` ranks it
}
