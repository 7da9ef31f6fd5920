#include "lensim/optics/design/placed_build.h"

#include <fmt/format.h>

#include <cmath>

#include "lensim/optics/coordinate_break.h"
#include "lensim/optics/design/image_quality.h"
#include "lensim/optics/frame.h"
#include "lensim/optics/paraxial.h"
#include "lensim/optics/placed_lens.h"

namespace lensim::optics::design {

namespace {

using frame::M3;
using frame::mul;
using frame::V3;

void requirePlaced(const LensPrescription& p) {
  if (!p.noncoaxial_loc) throw Error("internal: a placed build needs frames (placeOnAxis)");
}

}  // namespace

LensPrescription placeOnAxis(LensPrescription p, const FileLoc& loc) {
  if (p.noncoaxial_loc) return p;
  double z = 0;
  for (LensSurface& s : p.surfaces) {
    s.frame = SurfaceFrame{};
    s.frame->origin_mm = {0, 0, z};
    z += s.thickness_mm;
  }
  p.image_frame = SurfaceFrame{};
  p.image_frame.origin_mm = {0, 0, z};
  p.noncoaxial_loc = loc;
  p.noncoaxial_reason = "decentred or tilted by tolerances";
  return p;
}

void moveRows(LensPrescription& p, int first, int last, double dx, double dy, double tx,
              double ty) {
  requirePlaced(p);
  const M3 r = mul(axisRotation(0, tx), axisRotation(1, ty));
  const V3 pivot = p.surfaces[size_t(first)].frame->origin_mm;
  for (int i = first; i <= last; ++i) {
    SurfaceFrame& f = *p.surfaces[size_t(i)].frame;
    const V3 rel{f.origin_mm[0] - pivot[0], f.origin_mm[1] - pivot[1], f.origin_mm[2] - pivot[2]};
    const V3 q = mul(r, rel);
    f.origin_mm = {pivot[0] + dx + q[0], pivot[1] + dy + q[1], pivot[2] + q[2]};
    f.rotation = mul(r, f.rotation);
  }
}

void changeThickness(LensPrescription& p, int row, double delta) {
  requirePlaced(p);
  p.surfaces[size_t(row)].thickness_mm += delta;
  const M3& r = p.surfaces[size_t(row)].frame->rotation;
  auto move = [&](SurfaceFrame& f) {
    for (int k = 0; k < 3; ++k) f.origin_mm[size_t(k)] += delta * r[size_t(k)][2];
  };
  for (size_t i = size_t(row) + 1; i < p.surfaces.size(); ++i) move(*p.surfaces[i].frame);
  move(p.image_frame);
}

void shiftImage(LensPrescription& p, double dz) {
  requirePlaced(p);
  for (int k = 0; k < 3; ++k)
    p.image_frame.origin_mm[size_t(k)] += dz * p.image_frame.rotation[size_t(k)][2];
  p.surfaces.back().thickness_mm += dz;
}

PlacedBeam placedBeam(const LensPrescription& p, double field_deg, double lambda_nm,
                      double primary_nm, int rings) {
  requirePlaced(p);
  // The entrance pupil of the coaxial twin (evaluationLens floats the apertures as below).
  LensPrescription twin = p;
  for (LensSurface& s : twin.surfaces) s.frame.reset();
  twin.noncoaxial_loc.reset();
  const FocusedLens fl = evaluationLens(twin);
  const ParaxialData pp = computeParaxial(fl.lens->atWavelength(primary_nm));
  LensPrescription floated = p;
  floatApertures(floated);
  const PlacedLens prim(floated, primary_nm);
  const PlacedLens::Field field{true, field_deg, 0, {}};
  const auto entry = prim.aim(field, {0, 0});
  if (!entry) throw Error(fmt::format("no real chief ray at {} deg", field_deg));
  const Ray chief = prim.fieldRay(field, *entry);
  const Vec3 d = chief.direction;
  const Vec3 centre = chief.origin + d * ((pp.entrance_pupil_z_mm - chief.origin.z) / d.z);
  const PlacedLens lens = lambda_nm == primary_nm ? prim : PlacedLens(floated, lambda_nm);
  const auto& rot = p.image_frame.rotation;
  // A scene ray through the pupil-plane point centre + offset, traced to the image surface:
  // its hit and slopes in the image surface's frame; false when it does not get there.
  auto traceTo = [&](Vec2 offset, Vec2& hit, Vec2& slope) {
    const Vec3 at = centre + Vec3{offset.x, offset.y, 0};
    const Vec3 e = at - d * (at.z / d.z);  // on the front vertex's plane z = 0
    const TraceResult r = lens.trace(lens.fieldRay(field, {e.x, e.y}), TraceOptions{false});
    const Vec3 dl = frame::toLocal(rot, r.ray.direction);
    if (!r.ok() || !(dl.z > 0)) return false;
    const Vec3 q = lens.toImageFrame(r.ray.origin);
    hit = {q.x, q.y};
    slope = {dl.x / dl.z, dl.y / dl.z};
    return true;
  };
  // The beam: the coaxial twin's paraxial entrance pupil, less the rays that cannot pass.
  PlacedBeam out;
  out.spot = beamSpot(pp.entrance_pupil_diameter_mm / 2, field_deg, rings, traceTo);
  if (!traceTo({0, 0}, out.chief, out.chief_slope))
    throw Error(fmt::format("the chief ray of the {} deg beam does not reach the film", field_deg));
  return out;
}

}  // namespace lensim::optics::design
