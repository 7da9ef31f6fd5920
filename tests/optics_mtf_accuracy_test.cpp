// The workbench's MTF accuracy (issue 28): the default pupil grid against the converged
// 512-cell grid, and the pupil's edge and the numerical aperture against the forward marginal
// ray found here by bisection with plain traces (no pupil or bundle code of the library).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <optional>
#include <string>

#include "lensim/optics/mtf.h"
#include "lensim/optics/wavefront.h"
#include "test_paths.h"

using namespace lensim;
using namespace lensim::optics;

namespace {

std::string shared(const std::string& name) {
  return std::string(LENSIM_SHARED_DIR) + "/lenses/" + name;
}

// n' sin u' of the real marginal ray of the on-axis object point: rays from the object (a
// parallel beam from infinity) aimed at height h on the plane z = 0, h bisected between a
// passing and a blocked one; the image-space direction of the last passing ray.
double forwardMarginalNa(const LensSystem& lens, std::optional<double> object_z_mm) {
  auto ray = [&](double h) {
    if (!object_z_mm) return Ray{{h, 0, -1}, {0, 0, 1}};
    const Vec3 o{0, 0, *object_z_mm};
    return Ray{o, normalize(Vec3{h, 0, 0} - o)};
  };
  auto passes = [&](double h) {
    TraceResult r = lens.tracer().traceFromScene(ray(h));
    return r.ok() && r.ray.direction.z > 0;
  };
  EXPECT_TRUE(passes(0));
  double lo = 0, hi = 1;
  while (passes(hi)) {
    lo = hi;
    hi *= 2;
  }
  for (int it = 0; it < 60; ++it) {
    const double mid = 0.5 * (lo + hi);
    (passes(mid) ? lo : hi) = mid;
  }
  const TraceResult r = lens.tracer().traceFromScene(ray(lo));
  return lens.imageIor() * std::hypot(r.ray.direction.x, r.ray.direction.y);
}

std::optional<double> objectZ(const FocusedLens& fl) {
  if (std::isinf(fl.focus_distance_m)) return std::nullopt;
  return fl.lens->filmZ_mm() - fl.focus_distance_m * 1000;
}

// The default grid against 512 cells on axis: within 0.5% wherever the MTF exceeds 0.1 (below
// that, 0.002), tangential and sagittal, up to 100 cycles/mm. 64 cells (the former default)
// gave the double Gauss wide open +3% at 20 cycles/mm.
void expectDefaultGridConverged(const std::string& path, LensSetup setup = {}) {
  const FocusedLens fl = focusLens(readLensFile(path), setup);
  MtfOptions o;
  o.fields = {0};
  o.geometric = false;
  o.max_frequency = 100;
  o.samples = 51;
  const MtfData def = computeMtf(monochromatic(fl), 35, o);
  o.pupil_cells = 512;
  const MtfData ref = computeMtf(monochromatic(fl), 35, o);
  ASSERT_EQ(def.fields.size(), 1u);
  ASSERT_EQ(ref.fields.size(), 1u);
  EXPECT_LT(def.fields[0].pupil_cells, 512) << path << ": the default must be a coarser grid";
  for (size_t k = 0; k < def.frequency.size(); ++k) {
    for (bool sag : {false, true}) {
      const double a =
          (sag ? def.fields[0].diffraction_sagittal : def.fields[0].diffraction_tangential)[k];
      const double b =
          (sag ? ref.fields[0].diffraction_sagittal : ref.fields[0].diffraction_tangential)[k];
      const double tol = b > 0.1 ? 0.005 * b : 0.002;
      EXPECT_NEAR(a, b, tol) << path << " at " << def.frequency[k] << " cycles/mm"
                             << (sag ? " sagittal" : " tangential");
    }
  }
}

}  // namespace

TEST(MtfAccuracy, DefaultGridWithinHalfPercentOf512CellsOnTheDoubleGaussAtF2) {
  const std::string path = lensim::test::lensPath("dgauss.50mm.dat");
  expectDefaultGridConverged(path);
  // 20 cycles/mm, the figure, on its own.
  const FocusedLens fl = focusLens(readLensFile(path), {});
  MtfOptions o;
  o.fields = {0};
  o.geometric = false;
  o.max_frequency = 20;
  o.samples = 2;
  const MtfData def = computeMtf(monochromatic(fl), 35, o);
  EXPECT_NEAR(def.working_f_number, 2.0, 0.05);
  o.pupil_cells = 512;
  const MtfData ref = computeMtf(monochromatic(fl), 35, o);
  EXPECT_NEAR(def.fields[0].diffraction_tangential[1] / ref.fields[0].diffraction_tangential[1], 1,
              0.005);
}

TEST(MtfAccuracy, DefaultGridWithinHalfPercentOf512CellsOnTheWideAngleAndTelephoto) {
  expectDefaultGridConverged(lensim::test::lensPath("wide.22mm.dat"));
  expectDefaultGridConverged(lensim::test::lensPath("telephoto.250mm.dat"));
}

// US 583,336 at f/4.5 has large spherical aberration: the cone traced back from the film point
// is 3.9% wider than the forward beam. The pupil's edge, its passing area and the MTF's NA
// follow the forward marginal ray.
TEST(MtfAccuracy, PupilEdgeIsTheForwardBeamOfUs583336) {
  const FocusedLens fl = focusLens(readLensFile(shared("zmx/US00583336-2-scaled.zmx")), {});
  const LensSystem& lens = *fl.lens;
  const double na = forwardMarginalNa(lens, objectZ(fl));
  auto axis = FieldBundle::fromFilmHeight(fl, lens, 0);
  ASSERT_TRUE(axis);
  const double film_z = lens.filmZ_mm();
  auto pf = computePupilFunction(lens, *axis, film_z, {0, 0}, kDLineNm, 128);
  ASSERT_TRUE(pf);
  EXPECT_NEAR(pf->halfWidth(), na, 1e-5 * na);
  // The passing cells' area is that of the forward cone's disc, pi NA^2 (within the edge
  // cells' 4x4 supersampling; the backward cone's area is 8% larger).
  double area = 0;
  for (double a : pf->amplitude) area += a * pf->step * pf->step;
  EXPECT_NEAR(area / (std::numbers::pi * na * na), 1, 0.004);
  MtfOptions o;
  o.fields = {};
  const MtfData d = computeMtf(monochromatic(fl), 35, o);
  EXPECT_NEAR(d.image_space_na, na, 1e-5 * na);
}

// The MTF's numerical aperture and cutoff are the forward marginal ray's n' sin u' and
// 2 NA / lambda, with no half-cell excess (1.4% high at 64 cells before).
TEST(MtfAccuracy, NumericalApertureAndCutoffAreTheMarginalRays) {
  for (const char* name : {"dgauss.50mm.dat", "telephoto.250mm.dat"}) {
    for (std::optional<double> focus : {std::optional<double>(), std::optional<double>(2.0)}) {
      LensSetup setup;
      if (focus) setup.focus_distance_m = *focus;
      const FocusedLens fl = focusLens(readLensFile(lensim::test::lensPath(name)), setup);
      const double na = forwardMarginalNa(*fl.lens, objectZ(fl));
      for (int cells : {0, 64}) {
        MtfOptions o;
        o.fields = {};
        o.pupil_cells = cells;
        const MtfData d = computeMtf(monochromatic(fl), 35, o);
        EXPECT_NEAR(d.image_space_na, na, 1e-5 * na) << name;
        EXPECT_NEAR(d.cutoff, 2 * na / (kDLineNm * 1e-6), 1e-5 * d.cutoff) << name;
        EXPECT_NEAR(d.working_f_number, 1 / (2 * na), 1e-5 * d.working_f_number) << name;
      }
    }
  }
}
