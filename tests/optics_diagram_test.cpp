#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>

#include "lensim/optics/diagram.h"
#include "lensim/optics/plots.h"
#include "lensim/util/file.h"
#include "lensim/util/svg.h"
#include "test_paths.h"

using namespace lensim;
using namespace lensim::optics;
using lensim::test::kClassicLenses;
using lensim::test::lensPath;

namespace {

FocusedLens focused(const std::string& file, LensSetup setup = {}) {
  return focusLens(readLensFile(lensPath(file)), setup);
}

int countOf(const std::string& text, const std::string& needle) {
  int n = 0;
  for (size_t pos = text.find(needle); pos != std::string::npos; pos = text.find(needle, pos + 1))
    ++n;
  return n;
}

// Well-formed XML, checked by xmllint (libxml2-utils, installed by scripts/install-deps).
void expectWellFormedXml(const std::string& text, const std::string& name) {
  const auto path = std::filesystem::temp_directory_path() / ("lensim_test_" + name + ".svg");
  writeFileAtomically(path.string(), text);
  const std::string cmd = "xmllint --noout '" + path.string() + "'";
  EXPECT_EQ(std::system(cmd.c_str()), 0) << name << " is not well-formed XML";
  std::filesystem::remove(path);
}

int glassGaps(const LensSystem& lens) {
  int n = 0;
  for (int i = 0; i + 1 < lens.surfaceCount(); ++i) n += lens.interfaces()[i].ior_after > 1;
  return n;
}

}  // namespace

TEST(LensDiagram, OneClosedShapePerElementAndOnePolylinePerRay) {
  for (const char* file : kClassicLenses) {
    SCOPED_TRACE(file);
    FocusedLens fl = focused(file);
    DiagramOptions opts;
    opts.rays = 9;
    LensDiagram d = buildLensDiagram(fl, opts);
    EXPECT_EQ(static_cast<int>(d.elements.size()), glassGaps(*fl.lens));
    EXPECT_EQ(d.rays.size(), 3u * 9u);
    const std::string svg = lensDiagramSheet({d}, false);
    expectWellFormedXml(svg, "diagram");
    EXPECT_EQ(countOf(svg, "<polygon"), static_cast<int>(d.elements.size()));
    EXPECT_EQ(countOf(svg, "class=\"element\""), static_cast<int>(d.elements.size()));
    EXPECT_EQ(countOf(svg, "class=\"ray\""), static_cast<int>(d.rays.size()));
    int blocked = 0;
    for (const DiagramRay& r : d.rays) blocked += !r.result.ok();
    EXPECT_EQ(countOf(svg, "class=\"block-mark\""), 2 * blocked);
    EXPECT_EQ(countOf(svg, "class=\"stop\""), 2);  // two blades
    // Each element outline is closed and lies within its surfaces' vertex range plus sags.
    for (const DiagramElement& e : d.elements) {
      ASSERT_GE(e.outline.size(), 4u);
      double zmin = 1e9, zmax = -1e9;
      for (const Vec2& q : e.outline) zmin = std::min(zmin, q.x), zmax = std::max(zmax, q.x);
      const auto& s = fl.lens->interfaces();
      EXPECT_LE(zmin, s[e.front_surface].z_mm + 1e-9);
      EXPECT_GE(zmax, s[e.front_surface + 1].z_mm - 1e-9);
    }
  }
}

// The drawn rays are the exact tracer's rays: re-tracing each bundle ray gives the same points.
TEST(LensDiagram, DrawnRaysAreTheTracersRays) {
  for (DiagramSource source : {DiagramSource::Film, DiagramSource::Scene}) {
    for (const char* file : kClassicLenses) {
      SCOPED_TRACE(file);
      FocusedLens fl = focused(file);
      DiagramOptions opts;
      opts.source = source;
      LensDiagram d = buildLensDiagram(fl, opts);
      int through = 0;
      for (const DiagramRay& r : d.rays) {
        std::vector<Vec3> path;
        TraceResult again = source == DiagramSource::Film
                                ? fl.lens->tracer().traceFromFilm(r.start, {}, &path)
                                : fl.lens->tracer().traceFromScene(r.start, {}, &path);
        ASSERT_LE(path.size(), r.points.size());
        for (size_t k = 0; k < path.size(); ++k) {
          EXPECT_EQ(path[k].x, r.points[k].x);
          EXPECT_EQ(path[k].z, r.points[k].z);
        }
        EXPECT_EQ(again.ok(), r.result.ok());
        if (!again.ok()) {
          EXPECT_EQ(again.blocked_surface, r.result.blocked_surface);
          continue;
        }
        ++through;
        // The extension continues the outgoing ray.
        ASSERT_EQ(r.points.size(), path.size() + 1);
        const Vec3 ext = r.points.back() - again.ray.origin;
        EXPECT_LT(length(cross(normalize(ext), again.ray.direction)), 1e-9);
      }
      EXPECT_GT(through, 0);
      if (source == DiagramSource::Film) {
        // On-axis bundle from the film centre: every ray starts at the film centre.
        for (const DiagramRay& r : d.rays)
          if (r.field == 0) {
            EXPECT_EQ(r.points.front(), (Vec3{0, 0, fl.lens->filmZ_mm()}));
          }
      }
    }
  }
}

TEST(LensDiagram, SheetKeepsTheOrderOfItsLenses) {
  std::vector<LensDiagram> ds;
  for (const char* file : kClassicLenses) ds.push_back(buildLensDiagram(focused(file), {}));
  for (bool same : {false, true}) {
    const std::string svg = lensDiagramSheet(ds, same);
    expectWellFormedXml(svg, "sheet");
    EXPECT_EQ(countOf(svg, "class=\"lens-diagram\""), 4);
    const size_t a = svg.find("D-GAUSS"), b = svg.find("fisheye"), c = svg.find("Wide-angle"),
                 e = svg.find("telephoto");
    EXPECT_LT(a, b);
    EXPECT_LT(b, c);
    EXPECT_LT(c, e);
  }
}

TEST(Plots, DistortionSmallForDoubleGaussLargeForFisheye) {
  DistortionData dg = computeDistortion(focused("dgauss.50mm.dat"), 35);
  ASSERT_FALSE(dg.percent_tan.empty());
  EXPECT_LT(std::abs(dg.percent_tan.back()), 5.0);
  EXPECT_EQ(dg.percent_tan.front(), 0.0);
  // Image height grows with the field angle.
  for (size_t k = 1; k < dg.height_mm.size(); ++k) EXPECT_GT(dg.height_mm[k], dg.height_mm[k - 1]);
  // The small-angle reference is the focal length at infinity focus.
  EXPECT_NEAR(dg.f_reference_mm, 50.358, 0.01);

  DistortionData fe = computeDistortion(focused("fisheye.10mm.dat"), 35);
  EXPECT_GT(fe.angle_deg.back(), 70);
  EXPECT_LT(fe.percent_tan.back(), -50);  // strong barrel distortion against f tan(theta)
  // The Muller fisheye is close to an equidistant (f theta) projection.
  EXPECT_LT(std::abs(fe.percent_equidistant.back()), 5.0);
  expectWellFormedXml(distortionSvg(focused("fisheye.10mm.dat"), fe, true), "distortion");
}

TEST(Plots, RelativeIlluminationFallsMonotonicallyForDoubleGauss) {
  FocusedLens fl = focused("dgauss.50mm.dat");  // wide open, f/2
  VignettingData v = computeVignetting(fl, 35);
  ASSERT_GT(v.film_radius_mm.size(), 10u);
  EXPECT_DOUBLE_EQ(v.relative_illumination.front(), 1.0);
  EXPECT_DOUBLE_EQ(v.unobstructed.front(), 1.0);
  for (size_t k = 1; k < v.relative_illumination.size(); ++k) {
    EXPECT_LE(v.relative_illumination[k], v.relative_illumination[k - 1] + 1e-9) << k;
    EXPECT_LE(v.cos4[k], 1.0);
  }
  EXPECT_LT(v.relative_illumination.back(), 0.6);  // the corners are clearly darker
  expectWellFormedXml(vignettingSvg(fl, v), "vignetting");
}

// The polar integration agrees with brute-force counting on a fine grid.
TEST(Plots, RelativeIlluminationAgreesWithGridCount) {
  FocusedLens fl = focused("wide.22mm.dat");
  VignettingData v = computeVignetting(fl, 35, 4);
  const LensSystem& lens = *fl.lens;
  const double rr = 1.5 * lens.interfaces().back().semi_aperture_mm;
  const double z = lens.filmDistance_mm();
  auto grid = [&](double h) {
    double sum = 0;
    const int n = 400;
    for (int iy = 0; iy < n; ++iy)
      for (int ix = 0; ix < n; ++ix) {
        const Vec2 a{rr * (2.0 * (ix + 0.5) / n - 1), rr * (2.0 * (iy + 0.5) / n - 1)};
        if (!lens.traceFromFilmPoint({h, 0}, a).ok()) continue;
        const double c2 = z * z / ((a.x - h) * (a.x - h) + a.y * a.y + z * z);
        sum += c2 * c2;
      }
    return sum;
  };
  const double g0 = grid(0);
  for (size_t k = 1; k < v.film_radius_mm.size(); ++k)
    EXPECT_NEAR(v.relative_illumination[k], grid(v.film_radius_mm[k]) / g0, 0.01) << k;
}

TEST(Plots, SpotsShrinkWhenStoppedDown) {
  FocusedLens open = focused("dgauss.50mm.dat");
  FocusedLens stopped = focused("dgauss.50mm.dat", {.aperture_diameter_mm = 4.0});
  auto a = computeSpots(open, {0.0, 0.7}, 35);
  auto b = computeSpots(stopped, {0.0, 0.7}, 35);
  ASSERT_EQ(a.size(), 2u);
  ASSERT_EQ(b.size(), 2u);
  EXPECT_LT(b[0].rms_radius_mm, a[0].rms_radius_mm);
  // On axis the spot is centred on the axis.
  EXPECT_NEAR(a[0].centroid_mm.x, 0, 1e-9);
  EXPECT_NEAR(a[0].centroid_mm.y, 0, 1e-9);
  // Off axis the centroid lies near the target image height.
  EXPECT_NEAR(a[1].centroid_mm.x, a[1].film_height_mm, 0.05);
  expectWellFormedXml(spotSvg(open, a), "spot");
}

TEST(Plots, FocusCurveRunsFromClosestFocusTowardInfinity) {
  FocusedLens fl = focused("telephoto.250mm.dat");
  FocusCurve c = computeFocusCurve(fl);
  ASSERT_GT(c.focus_distance_m.size(), 10u);
  EXPECT_GT(c.focus_distance_m.front(), c.closest_m);
  for (size_t k = 1; k < c.focus_distance_m.size(); ++k) {
    EXPECT_LT(c.film_distance_thick_mm[k], c.film_distance_thick_mm[k - 1]);
    EXPECT_GT(c.film_distance_thick_mm[k], c.infinity_thick_mm);
  }
  EXPECT_NEAR(c.infinity_thick_mm, fl.paraxial.back_focal_length_mm, 1e-9);
  expectWellFormedXml(focusSvg(fl, c), "focus");
}
