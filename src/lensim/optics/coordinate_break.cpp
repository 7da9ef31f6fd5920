#include "lensim/optics/coordinate_break.h"

#include <cmath>
#include <string>
#include <fmt/format.h>

#include "lensim/optics/frame.h"

namespace lensim::optics {

namespace {

using frame::M3;
using frame::mul;
using frame::V3;

V3 add(V3 a, const V3& b, double s = 1) {
  for (int i = 0; i < 3; ++i) a[i] += s * b[i];
  return a;
}
double dot(const V3& a, const V3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
M3 identity() { return {V3{1, 0, 0}, V3{0, 1, 0}, V3{0, 0, 1}}; }
V3 column(const M3& m, int j) { return {m[0][j], m[1][j], m[2][j]}; }

M3 rotation(int axis, double deg) { return axisRotation(axis, deg); }

// Where a break's message points: its first non-zero PARM, else its SURF line.
FileLoc breakLoc(const FoldSurface& s) {
  for (int i = 0; i < 6; ++i)
    if (s.parm[size_t(i)] != 0 && s.parm_loc[size_t(i)].valid()) return s.parm_loc[size_t(i)];
  return s.loc;
}

std::string decentredApertureWhat(const FoldSurface& s) {
  return fmt::format("surface {}: its aperture is decentred (OBDC), so it is not rotationally "
                     "symmetric about the axis (an off-axis mirror or lens)",
                     s.number);
}

}  // namespace

std::array<std::array<double, 3>, 3> axisRotation(int axis, double deg) {
  const double a = deg * (M_PI / 180.0);
  const double c = std::cos(a), s = std::sin(a);
  const int i = (axis + 1) % 3, j = (axis + 2) % 3;
  M3 r = identity();
  r[i][i] = c, r[i][j] = -s, r[j][i] = s, r[j][j] = c;
  return r;
}

std::vector<SurfaceFrame> placeSurfaces(const std::vector<FoldSurface>& surfs) {
  std::vector<SurfaceFrame> frames(surfs.size());
  M3 R = identity();
  V3 O{0, 0, 0};
  for (size_t i = 1; i < surfs.size(); ++i) {
    const FoldSurface& s = surfs[i];
    if (s.coordbrk) {
      const auto& p = s.parm;
      const V3 dec{p[0], p[1], 0};
      if (p[5] == 0) {
        O = add(O, mul(R, dec));
        R = mul(mul(mul(R, rotation(0, p[2])), rotation(1, p[3])), rotation(2, p[4]));
      } else {
        R = mul(mul(mul(R, rotation(2, p[4])), rotation(1, p[3])), rotation(0, p[2]));
        O = add(O, mul(R, dec));
      }
    }
    frames[i] = SurfaceFrame{R, O};
    if (i + 1 < surfs.size()) O = add(O, column(R, 2), s.thickness);
    bool finite = true;
    for (int r = 0; r < 3; ++r) {
      finite = finite && std::isfinite(O[size_t(r)]);
      for (int c = 0; c < 3; ++c) finite = finite && std::isfinite(R[size_t(r)][size_t(c)]);
    }
    if (!finite)
      throw Error(s.coordbrk ? breakLoc(s) : s.loc,
                  fmt::format("surface {}: the surfaces after it would lie at a non-finite place "
                              "(decentres or thicknesses beyond double precision)",
                              s.number));
  }
  return frames;
}

PlacedSystem placeCoordinateBreaks(const std::vector<FoldSurface>& surfs) {
  PlacedSystem out;
  bool any_break = false, any_decentred = false;
  for (const FoldSurface& s : surfs) {
    any_break = any_break || s.coordbrk;
    any_decentred = any_decentred || s.decentred_aperture_loc.valid();
  }
  if (!any_break && !any_decentred) {
    out.unfolded = unfoldCoordinateBreaks(surfs);
    return out;
  }
  if (surfs.size() >= 2 && (surfs.front().coordbrk || surfs.back().coordbrk)) {
    const FoldSurface& s = surfs.front().coordbrk ? surfs.front() : surfs.back();
    throw Error(s.loc, fmt::format("surface {}: a coordinate break as the {} surface is not "
                                   "supported",
                                   s.number, &s == &surfs.front() ? "object" : "image"));
  }
  out.frames = placeSurfaces(surfs);  // refuses non-finite places before anything is traced
  try {
    out.unfolded = unfoldCoordinateBreaks(surfs);
    out.frames.clear();
  } catch (const Error& e) {
    out.coaxial = false;
    out.refusal = e;
  }
  return out;
}

UnfoldedSystem unfoldCoordinateBreaks(const std::vector<FoldSurface>& surfs) {
  UnfoldedSystem out;
  const size_t n = surfs.size();
  for (const FoldSurface& s : surfs) out.any_break = out.any_break || s.coordbrk;
  // A decentred aperture before any break: no axis of symmetry from there on.
  for (const FoldSurface& s : surfs) {
    if (s.coordbrk) break;
    if (s.decentred_aperture_loc.valid())
      throw Error(s.decentred_aperture_loc, decentredApertureWhat(s));
  }
  if (!out.any_break) {
    for (size_t i = 0; i < n; ++i) out.kept.push_back(i), out.thickness.push_back(surfs[i].thickness);
    return out;
  }
  if (surfs.front().coordbrk || surfs.back().coordbrk) {
    const FoldSurface& s = surfs.front().coordbrk ? surfs.front() : surfs.back();
    throw Error(s.loc, fmt::format("surface {}: a coordinate break as the {} surface is not "
                                   "supported",
                                   s.number, &s == &surfs.front() ? "object" : "image"));
  }
  double scale = 1;
  for (size_t i = 1; i + 1 < n; ++i)
    if (std::isfinite(surfs[i].thickness)) scale += std::abs(surfs[i].thickness);
  const double tol_pos = 1e-9 * scale, tol_dir = 1e-9;

  // Every surface's frame (global: rotation R, origin O; surface 1 at the origin) and the
  // unfolding isometry p -> A p + b that undoes the plane mirrors met so far.
  const std::vector<SurfaceFrame> frames = placeSurfaces(surfs);
  M3 A = identity();
  V3 b{0, 0, 0};
  int mirrors = 0;
  const FoldSurface* last_break = nullptr;
  std::vector<double> z_unfolded;
  std::vector<int> mirrors_after;
  out.kept.push_back(0);
  z_unfolded.push_back(0), mirrors_after.push_back(0);

  auto refuse = [&](const FoldSurface& s, const std::string& what) -> Error {
    if (last_break)
      return Error(breakLoc(*last_break),
                   fmt::format("surface {}: after the coordinate break at surface {}, surface "
                               "{} {}",
                               last_break->number, last_break->number, s.number, what));
    return Error(s.loc, fmt::format("surface {}: {}", s.number, what));
  };

  for (size_t i = 1; i < n; ++i) {
    const FoldSurface& s = surfs[i];
    if (s.coordbrk) {
      last_break = &s;
      continue;
    }
    const M3& R = frames[i].rotation;
    const V3& O = frames[i].origin_mm;
    const V3 g = add(mul(A, O), b);  // the vertex, unfolded
    const M3 G = mul(A, R);          // the surface's axes, unfolded
    const V3 gz = column(G, 2);
    if (!(std::abs(g[0]) <= tol_pos && std::abs(g[1]) <= tol_pos))
      throw refuse(s, fmt::format("lies {:.6g}, {:.6g} off the axis (x, y)", g[0], g[1]));
    if (s.decentred_aperture_loc.valid())
      throw Error(s.decentred_aperture_loc, decentredApertureWhat(s));
    const double expected = mirrors % 2 ? -1.0 : 1.0;
    if (s.mirror && s.plane && i + 1 < n) {
      // A plane mirror at any tilt: its normal may leave the axis, not its vertex.
      const double c = std::abs(gz[2]);
      if (!(c > 1e-6))
        throw refuse(s, "is a mirror parallel to the axis (the light grazes it)");
      if (c < 1 - tol_dir) {
        if (!s.symmetric)
          throw refuse(s, "is a tilted mirror with a non-circular aperture");
        const bool along_y = std::abs(gz[0]) <= tol_dir, along_x = std::abs(gz[1]) <= tol_dir;
        if (!along_x && !along_y)
          throw refuse(s, "is a mirror tilted about an axis other than x or y of the axis "
                          "frame (its aperture would be a rotated ellipse)");
        out.tilted_mirrors.push_back({out.kept.size(), along_x ? c : 1.0, along_y ? c : 1.0});
      }
      const V3 nrm = column(R, 2);  // global normal; reflect in the plane through O
      M3 refl = identity();
      for (int r = 0; r < 3; ++r)
        for (int q = 0; q < 3; ++q) refl[size_t(r)][size_t(q)] -= 2 * nrm[size_t(r)] * nrm[size_t(q)];
      const V3 shift{2 * dot(O, nrm) * nrm[0], 2 * dot(O, nrm) * nrm[1], 2 * dot(O, nrm) * nrm[2]};
      b = add(mul(A, shift), b);
      A = mul(A, refl);
      ++mirrors;
    } else {
      if (!(std::abs(gz[0]) <= tol_dir && std::abs(gz[1]) <= tol_dir &&
            std::abs(gz[2] - expected) <= tol_dir))
        throw refuse(s, std::abs(gz[2] + expected) <= tol_dir
                            ? std::string("is turned to face the other way (tilted by 180 "
                                          "degrees)")
                            : fmt::format("is tilted against the axis (its normal {:.6g}, "
                                          "{:.6g}, {:.6g})",
                                          gz[0], gz[1], gz[2] * expected));
      if (!s.symmetric) {
        const V3 gx = column(G, 0);
        if (!(std::abs(gx[0] - 1) <= tol_dir))
          throw refuse(s, "is not rotationally symmetric and is turned about the axis");
      }
      if (s.mirror) ++mirrors;
    }
    out.kept.push_back(i);
    z_unfolded.push_back(g[2]);
    mirrors_after.push_back(mirrors);
  }
  // Coaxial thicknesses: unfolded gaps, negative after an odd number of mirrors.
  out.thickness.push_back(surfs.front().thickness);
  for (size_t k = 1; k < out.kept.size(); ++k) {
    if (k + 1 == out.kept.size()) {
      out.thickness.push_back(surfs[out.kept[k]].thickness);
    } else {
      const double gap = z_unfolded[k + 1] - z_unfolded[k];
      out.thickness.push_back(mirrors_after[k] % 2 ? -gap : gap);
    }
  }
  return out;
}

}  // namespace lensim::optics
