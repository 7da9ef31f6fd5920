// Embree 3 scene construction and ray queries. See accel.h.
#include "lensim/render/shapes/accel.h"

#include <embree3/rtcore.h>
#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cstring>
#include <mutex>
#include <span>

#include "lensim/render/shapes/accel_curves.h"
#include "lensim/scene/description.h"
#include "lensim/util/error.h"

namespace lensim::render {

namespace {

/// Shape data in its "space": world for world shapes, instance space for shapes of objects.
struct ShapeRecord {
  int shape = -1;
  const scene::Shape* desc = nullptr;
  Transform space_from_object, object_from_space;
  bool flip = false;
  // Meshes, transformed to the space.
  int vertices_per_face = 3;
  std::vector<Vec3> p, n;
  std::vector<Vec2> uv;
  std::span<const int> indices;  ///< the scene mesh's (the scene outlives the Accel)
  Bounds3 bounds;  ///< in the space
  // Curves (render/accel_curves.*): the Bézier segments in the space.
  const scene::Curve* curve = nullptr;
  CurveInSpace curve_space;
  /// An animated shape (motion blur): the shape's data are in its object space (the "space"
  /// above is object space), in an Embree scene of its own that a MotionWrapper places.
  const AnimatedTransform* motion = nullptr;
};

/// An Embree user geometry that places an inner Embree scene by an animated transform (pbrt-v4's
/// AnimatedPrimitive, src/pbrt/cpu/primitive.h): the ray is carried into the inner scene by the
/// transform interpolated at the ray's time (pbrt-v4's AnimatedTransform, decomposed and
/// interpolated; not Embree's linear matrix motion) and intersected there. Its Embree bounds are
/// the motion bounds over the shutter interval.
struct MotionWrapper {
  const AnimatedTransform* motion = nullptr;  ///< parent space from inner space
  RTCScene inner = nullptr;
  Bounds3 bounds;     ///< in the parent space, over the shutter
  int instance = -1;  ///< an animated ObjectInstance (inner: the object's scene), else -1
};

/// The intersect context with the ray's time (seconds). Embree hands the context given to
/// rtcIntersect1/rtcOccluded1 to user geometry callbacks unchanged, so they read the time here.
/// `inner_geom`: the object-scene geometry an animated instance's wrapper last accepted.
struct TimedContext {
  RTCIntersectContext base;
  double time = 0;
  unsigned inner_geom = RTC_INVALID_GEOMETRY_ID;
};

}  // namespace

struct Accel::Impl {
  const scene::Scene* scene = nullptr;
  RTCDevice device = nullptr;
  RTCScene top = nullptr;
  std::vector<RTCScene> object_scenes;  ///< per object definition
  std::vector<ShapeRecord> records;
  std::vector<int> top_geom;                  ///< top-level geomID -> record (or -1: instance)
  std::vector<std::vector<int>> object_geom;  ///< per object: geomID -> record
  std::vector<int> top_geom_instance;         ///< top-level geomID -> instance index
  std::vector<int> shape_record;              ///< shape -> record, -1 if none
  std::vector<WorldMesh> world_meshes;
  std::vector<std::unique_ptr<MotionWrapper>> wrappers;  ///< addresses held by Embree
  std::vector<RTCScene> motion_scenes;                   ///< inner scenes of animated shapes
  /// Per instance: world from instance as rendered (a motion steady over the shutter baked in),
  /// and its motion when it moves while the shutter is open (else nullptr).
  std::vector<Transform> instance_transform;
  std::vector<const AnimatedTransform*> instance_motion;
  std::vector<int> shape_world_mesh;
  std::mutex error_mutex;
  std::string error;
  mutable std::atomic<uint64_t> invalid_rays{0};  ///< rays dropped before Embree (rayIsValid)

  ~Impl() {
    for (RTCScene s : motion_scenes)
      if (s) rtcReleaseScene(s);
    for (RTCScene s : object_scenes)
      if (s) rtcReleaseScene(s);
    if (top) rtcReleaseScene(top);
    if (device) rtcReleaseDevice(device);
  }

  /// Creates the Embree geometry of records[ri] and attaches it to its scene (the top level, an
  /// object definition's, or an animated shape's own scene under a MotionWrapper).
  void addRecordGeometry(size_t ri, bool compact_objects);
  /// Attaches the object instances to the top-level scene (after the object scenes are
  /// committed): Embree instances, or MotionWrappers for instances that move while the shutter
  /// is open.
  void addInstances();

  void check(const char* what) {
    std::lock_guard lock(error_mutex);
    if (!error.empty()) throw Error(fmt::format("Embree error while {}: {}", what, error));
    const RTCError e = rtcGetDeviceError(device);
    if (e != RTC_ERROR_NONE)
      throw Error(fmt::format("Embree error {} while {}", static_cast<int>(e), what));
  }
};

namespace {

void errorCallback(void* user, RTCError code, const char* str) {
  auto* impl = static_cast<Accel::Impl*>(user);
  std::lock_guard lock(impl->error_mutex);
  if (!impl->error.empty()) impl->error += "; ";
  impl->error += fmt::format("code {}: {}", static_cast<int>(code), str ? str : "");
}

void quadricBounds(const RTCBoundsFunctionArguments* args) {
  const auto* r = static_cast<const ShapeRecord*>(args->geometryUserPtr);
  RTCBounds* b = args->bounds_o;
  b->lower_x = float(r->bounds.min.x), b->lower_y = float(r->bounds.min.y);
  b->lower_z = float(r->bounds.min.z);
  b->upper_x = float(r->bounds.max.x), b->upper_y = float(r->bounds.max.y);
  b->upper_z = float(r->bounds.max.z);
  // Pad for float rounding.
  const float pad =
      1e-6f * (1 + std::max({std::abs(b->lower_x), std::abs(b->upper_x), std::abs(b->lower_y),
                             std::abs(b->upper_y), std::abs(b->lower_z), std::abs(b->upper_z)}));
  b->lower_x -= pad, b->lower_y -= pad, b->lower_z -= pad;
  b->upper_x += pad, b->upper_y += pad, b->upper_z += pad;
}

std::optional<double> quadricHit(const ShapeRecord* r, const float* org, const float* dir,
                                 double tnear, double tfar) {
  const Vec3 o = r->object_from_space.applyPoint({org[0], org[1], org[2]});
  const Vec3 d = r->object_from_space.applyVector({dir[0], dir[1], dir[2]});
  return intersectQuadric(*r->desc, o, d, tnear, tfar);
}

void quadricIntersect(const RTCIntersectFunctionNArguments* args) {
  if (args->N != 1 || !args->valid[0]) return;
  const auto* r = static_cast<const ShapeRecord*>(args->geometryUserPtr);
  RTCRayHit* rh = reinterpret_cast<RTCRayHit*>(args->rayhit);
  const float org[3] = {rh->ray.org_x, rh->ray.org_y, rh->ray.org_z};
  const float dir[3] = {rh->ray.dir_x, rh->ray.dir_y, rh->ray.dir_z};
  auto t = quadricHit(r, org, dir, rh->ray.tnear, rh->ray.tfar);
  if (!t) return;
  rh->ray.tfar = float(*t);
  rh->hit.u = rh->hit.v = 0;
  rh->hit.Ng_x = 0, rh->hit.Ng_y = 0, rh->hit.Ng_z = 1;
  rh->hit.primID = args->primID;
  rh->hit.geomID = args->geomID;
  rh->hit.instID[0] = args->context->instID[0];
}

void quadricOccluded(const RTCOccludedFunctionNArguments* args) {
  if (args->N != 1 || !args->valid[0]) return;
  const auto* r = static_cast<const ShapeRecord*>(args->geometryUserPtr);
  RTCRay* ray = reinterpret_cast<RTCRay*>(args->ray);
  const float org[3] = {ray->org_x, ray->org_y, ray->org_z};
  const float dir[3] = {ray->dir_x, ray->dir_y, ray->dir_z};
  if (quadricHit(r, org, dir, ray->tnear, ray->tfar)) ray->tfar = -INFINITY;
}

void motionBounds(const RTCBoundsFunctionArguments* args) {
  const auto* w = static_cast<const MotionWrapper*>(args->geometryUserPtr);
  RTCBounds* b = args->bounds_o;
  const Bounds3& m = w->bounds;
  const double pad =
      1e-6 * (1 + std::max({std::abs(m.min.x), std::abs(m.max.x), std::abs(m.min.y),
                            std::abs(m.max.y), std::abs(m.min.z), std::abs(m.max.z)}));
  b->lower_x = float(m.min.x - pad), b->lower_y = float(m.min.y - pad);
  b->lower_z = float(m.min.z - pad);
  b->upper_x = float(m.max.x + pad), b->upper_y = float(m.max.y + pad);
  b->upper_z = float(m.max.z + pad);
}

/// The ray (org, dir, tnear, tfar) carried into the wrapper's inner space at the context's time.
void innerRay(const MotionWrapper& w, double time, const RTCRay& in, RTCRay& out) {
  Transform scratch;
  const Transform& m = w.motion->at(time, scratch);
  const Transform::Matrix& mi = m.inverseMatrix();
  const double o[3] = {in.org_x, in.org_y, in.org_z}, d[3] = {in.dir_x, in.dir_y, in.dir_z};
  float oo[3], dd[3];
  for (int r = 0; r < 3; ++r) {
    oo[r] = float(mi[r][0] * o[0] + mi[r][1] * o[1] + mi[r][2] * o[2] + mi[r][3]);
    dd[r] = float(mi[r][0] * d[0] + mi[r][1] * d[1] + mi[r][2] * d[2]);
  }
  out.org_x = oo[0], out.org_y = oo[1], out.org_z = oo[2];
  out.dir_x = dd[0], out.dir_y = dd[1], out.dir_z = dd[2];
  out.tnear = in.tnear;
  out.tfar = in.tfar;
  out.time = 0;
  out.mask = in.mask;
  out.id = in.id;
  out.flags = 0;
}

void motionIntersect(const RTCIntersectFunctionNArguments* args) {
  if (args->N != 1 || !args->valid[0]) return;
  const auto* w = static_cast<const MotionWrapper*>(args->geometryUserPtr);
  auto* ctx = reinterpret_cast<TimedContext*>(args->context);
  RTCRayHit* rh = reinterpret_cast<RTCRayHit*>(args->rayhit);
  TimedContext inner;
  rtcInitIntersectContext(&inner.base);
  inner.time = ctx->time;
  RTCRayHit ih;
  innerRay(*w, ctx->time, rh->ray, ih.ray);
  ih.hit.geomID = ih.hit.primID = ih.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(w->inner, &inner.base, &ih);
  if (ih.hit.geomID == RTC_INVALID_GEOMETRY_ID || !(ih.ray.tfar < rh->ray.tfar)) return;
  rh->ray.tfar = ih.ray.tfar;
  // u, v and Ng stay in the inner space; Accel::intersect carries the hit out again.
  rh->hit.u = ih.hit.u, rh->hit.v = ih.hit.v;
  rh->hit.Ng_x = ih.hit.Ng_x, rh->hit.Ng_y = ih.hit.Ng_y, rh->hit.Ng_z = ih.hit.Ng_z;
  rh->hit.primID = ih.hit.primID;
  rh->hit.geomID = args->geomID;
  rh->hit.instID[0] = args->context->instID[0];
  // The last accepted hit is the nearest so far, so this names the final hit's geometry when
  // the final hit is this wrapper's.
  if (w->instance >= 0) ctx->inner_geom = ih.hit.geomID;
}

void motionOccluded(const RTCOccludedFunctionNArguments* args) {
  if (args->N != 1 || !args->valid[0]) return;
  const auto* w = static_cast<const MotionWrapper*>(args->geometryUserPtr);
  const auto* ctx = reinterpret_cast<const TimedContext*>(args->context);
  RTCRay* ray = reinterpret_cast<RTCRay*>(args->ray);
  TimedContext inner;
  rtcInitIntersectContext(&inner.base);
  inner.time = ctx->time;
  RTCRay ir;
  innerRay(*w, ctx->time, *ray, ir);
  rtcOccluded1(w->inner, &inner.base, &ir);
  if (ir.tfar < 0) ray->tfar = -INFINITY;
}

Bounds3 quadricObjectBounds(const scene::Shape& s) {
  Bounds3 b;
  using scene::ShapeType;
  const double r = s.radius;
  switch (s.type) {
    case ShapeType::Sphere:
      b.extend({-r, -r, s.zmin});
      b.extend({r, r, s.zmax});
      break;
    case ShapeType::Cylinder:
      b.extend({-r, -r, s.zmin});
      b.extend({r, r, s.zmax});
      break;
    case ShapeType::Disk:
      b.extend({-r, -r, s.height});
      b.extend({r, r, s.height});
      break;
    case ShapeType::Cone:
      b.extend({-r, -r, 0});
      b.extend({r, r, s.height});
      break;
    default:
      break;
  }
  return b;
}

/// The transform of an animated shape or instance when it does not change while the shutter is
/// open (an instant shutter, or motion wholly before or after it), else nullopt: such motion is
/// rendered as the static transform it amounts to, exactly as a static scene.
std::optional<Transform> steadyTransform(const scene::Scene& scene, const AnimatedTransform& m) {
  const double open = scene.camera.shutter_open, close = scene.camera.shutter_close;
  if (!m.isAnimated() || close <= m.startTime()) return m.start();
  if (open >= m.endTime()) return m.end();
  if (open == close) return m.interpolate(open);
  return std::nullopt;
}

/// An Embree user geometry for the wrapper (which must outlive it).
RTCGeometry newMotionGeometry(RTCDevice device, MotionWrapper* w) {
  RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_USER);
  rtcSetGeometryUserPrimitiveCount(g, 1);
  rtcSetGeometryUserData(g, w);
  rtcSetGeometryBoundsFunction(g, motionBounds, nullptr);
  rtcSetGeometryIntersectFunction(g, motionIntersect);
  rtcSetGeometryOccludedFunction(g, motionOccluded);
  rtcCommitGeometry(g);
  return g;
}

/// Shape i of the scene in its space (see ShapeRecord); nullopt for a mesh or curve without
/// primitives.
std::optional<ShapeRecord> shapeRecord(const scene::Scene& scene, size_t i) {
  const scene::Shape& s = scene.shapes[i];
  ShapeRecord r;
  r.shape = static_cast<int>(i);
  r.desc = &s;
  Transform xf = s.transform;  // space from object
  if (s.motion >= 0) {
    const AnimatedTransform& motion = scene.motions[static_cast<size_t>(s.motion)];
    if (auto steady = steadyTransform(scene, motion)) {
      xf = *steady;
    } else {
      r.motion = &motion;
      xf = Transform();  // the wrapper places the object space
    }
  }
  r.space_from_object = xf;
  r.object_from_space = inverse(xf);
  // pbrt-v4 builds an animated shape with an identity render-from-object transform
  // (BasicSceneBuilder::Shape, src/pbrt/scene.cpp), so only ReverseOrientation flips it; its
  // normals are then carried out by the interpolated transform.
  r.flip = r.motion ? s.reverse_orientation : s.flipNormals();
  if (s.type == scene::ShapeType::TriangleMesh || s.type == scene::ShapeType::BilinearMesh) {
    if (s.mesh < 0) return std::nullopt;
    const scene::Mesh& mesh = scene.meshes[static_cast<size_t>(s.mesh)];
    if (mesh.indices.empty()) return std::nullopt;
    r.vertices_per_face = mesh.vertices_per_face;
    r.p.reserve(mesh.positions.size());
    for (const Vec3f& q : mesh.positions) {
      r.p.push_back(xf.applyPoint(Vec3(q)));
      r.bounds.extend(r.p.back());
    }
    for (const Vec3f& q : mesh.normals) {
      Vec3 nn = xf.applyNormal(Vec3(q));
      r.n.push_back(length(nn) > 0 ? normalize(nn) : nn);
    }
    for (const auto& t : mesh.uvs) r.uv.push_back({t[0], t[1]});
    r.indices = mesh.indices;  // a view: a copy would cost 12 bytes per triangle
  } else if (s.type == scene::ShapeType::Curve) {
    if (s.curve < 0) return std::nullopt;
    const scene::Curve& c = scene.curves[static_cast<size_t>(s.curve)];
    if (c.cp.empty()) return std::nullopt;
    r.curve = &c;
    r.curve_space = curveInSpace(c, xf);
    r.bounds = r.curve_space.bounds;
  } else {
    r.bounds = xf.applyBounds(quadricObjectBounds(s));
  }
  return r;
}

/// An Embree triangle or quad mesh of the record's faces (not committed).
RTCGeometry newMeshGeometry(RTCDevice device, const ShapeRecord& r) {
  const bool quads = r.vertices_per_face == 4;
  RTCGeometry g =
      rtcNewGeometry(device, quads ? RTC_GEOMETRY_TYPE_QUAD : RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(
      g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), r.p.size()));
  for (size_t k = 0; k < r.p.size(); ++k) {
    v[3 * k] = float(r.p[k].x), v[3 * k + 1] = float(r.p[k].y), v[3 * k + 2] = float(r.p[k].z);
  }
  const size_t faces = r.indices.size() / static_cast<size_t>(r.vertices_per_face);
  if (quads) {
    auto* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT4, 4 * sizeof(unsigned), faces));
    for (size_t f = 0; f < faces; ++f) {
      // pbrt's patch (p00, p10, p01, p11) as Embree's cyclic quad (p00, p10, p11, p01).
      idx[4 * f] = unsigned(r.indices[4 * f]);
      idx[4 * f + 1] = unsigned(r.indices[4 * f + 1]);
      idx[4 * f + 2] = unsigned(r.indices[4 * f + 3]);
      idx[4 * f + 3] = unsigned(r.indices[4 * f + 2]);
    }
  } else {
    // Embree reads the scene mesh's indices in place (the builder checked them against the
    // vertex count; an int and an unsigned share their representation for those values):
    // no second copy of 12 bytes per triangle. Embree never writes an index buffer.
    static_assert(sizeof(int) == sizeof(unsigned));
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                               const_cast<int*>(r.indices.data()), 0, 3 * sizeof(unsigned),
                               faces);
  }
  return g;
}

}  // namespace

// Top-level primitives above which the BVH is built with Embree's medium quality.
constexpr size_t kHighQualityBuildLimit = size_t{1} << 20;

void Accel::Impl::addRecordGeometry(size_t ri, bool compact_objects) {
  ShapeRecord& r = records[ri];
  const scene::Shape& s = *r.desc;
  RTCScene target = top;
  if (s.object >= 0) {
    RTCScene& os = object_scenes[static_cast<size_t>(s.object)];
    if (!os) {
      os = rtcNewScene(device);
      if (compact_objects) rtcSetSceneFlags(os, RTC_SCENE_FLAG_COMPACT);
    }
    target = os;
  }
  RTCScene parent = target;
  if (r.motion) {
    target = rtcNewScene(device);
    rtcSetSceneBuildQuality(target, RTC_BUILD_QUALITY_HIGH);
    motion_scenes.push_back(target);
  }
  RTCGeometry g;
  if (r.curve) {
    g = newCurveGeometry(device, *r.curve, r.curve_space);
  } else if (!r.indices.empty()) {
    g = newMeshGeometry(device, r);
    if (s.object < 0 && s.area_light >= 0) {  // kept only for emitters (light sampling)
      WorldMesh wm;
      wm.vertices_per_face = r.vertices_per_face;
      wm.p = r.p;
      wm.n = r.n;
      wm.uv = r.uv;
      wm.flip = r.flip;
      wm.indices.assign(r.indices.begin(), r.indices.end());
      shape_world_mesh[static_cast<size_t>(r.shape)] = static_cast<int>(world_meshes.size());
      world_meshes.push_back(std::move(wm));
    }
  } else {
    g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_USER);
    rtcSetGeometryUserPrimitiveCount(g, 1);
    rtcSetGeometryUserData(g, &r);
    rtcSetGeometryBoundsFunction(g, quadricBounds, nullptr);
    rtcSetGeometryIntersectFunction(g, quadricIntersect);
    rtcSetGeometryOccludedFunction(g, quadricOccluded);
  }
  rtcCommitGeometry(g);
  unsigned id = rtcAttachGeometry(target, g);
  rtcReleaseGeometry(g);
  if (r.motion) {
    rtcCommitScene(target);
    auto w = std::make_unique<MotionWrapper>();
    w->motion = r.motion;
    w->inner = target;
    w->bounds =
        r.motion->motionBounds(r.bounds, scene->camera.shutter_open, scene->camera.shutter_close);
    RTCGeometry wg = newMotionGeometry(device, w.get());
    id = rtcAttachGeometry(parent, wg);
    rtcReleaseGeometry(wg);
    wrappers.push_back(std::move(w));
  }
  auto& map = s.object >= 0 ? object_geom[static_cast<size_t>(s.object)] : top_geom;
  if (map.size() <= id) map.resize(id + 1, -1);
  map[id] = static_cast<int>(ri);
  if (s.object < 0) {
    if (top_geom_instance.size() <= id) top_geom_instance.resize(id + 1, -1);
  }
}

void Accel::Impl::addInstances() {
  instance_transform.resize(scene->instances.size());
  instance_motion.assign(scene->instances.size(), nullptr);
  for (size_t i = 0; i < scene->instances.size(); ++i) {
    const scene::Instance& inst = scene->instances[i];
    RTCScene os = object_scenes[static_cast<size_t>(inst.object)];
    if (!os) continue;  // an empty object
    std::optional<Transform> steady = inst.transform;
    if (inst.motion >= 0) steady = steadyTransform(*scene, scene->motions[size_t(inst.motion)]);
    instance_transform[i] = steady.value_or(Transform());
    RTCGeometry g;
    if (steady) {
      g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_INSTANCE);
      rtcSetGeometryInstancedScene(g, os);
      float xfm[12];  // column-major 3x4
      for (int c = 0; c < 4; ++c)
        for (int rr = 0; rr < 3; ++rr) xfm[3 * c + rr] = float((*steady)(rr, c));
      rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, xfm);
      rtcCommitGeometry(g);
    } else {
      auto w = std::make_unique<MotionWrapper>();
      w->motion = &scene->motions[size_t(inst.motion)];
      w->inner = os;
      w->instance = static_cast<int>(i);
      instance_motion[i] = w->motion;
      RTCBounds ob;
      rtcGetSceneBounds(os, &ob);
      Bounds3 object_bounds;
      object_bounds.extend({ob.lower_x, ob.lower_y, ob.lower_z});
      object_bounds.extend({ob.upper_x, ob.upper_y, ob.upper_z});
      w->bounds = w->motion->motionBounds(object_bounds, scene->camera.shutter_open,
                                          scene->camera.shutter_close);
      g = newMotionGeometry(device, w.get());
      wrappers.push_back(std::move(w));
    }
    const unsigned id = rtcAttachGeometry(top, g);
    rtcReleaseGeometry(g);
    if (top_geom.size() <= id) top_geom.resize(id + 1, -1);
    if (top_geom_instance.size() <= id) top_geom_instance.resize(id + 1, -1);
    top_geom_instance[id] = static_cast<int>(i);
  }
}

Accel::Accel(const scene::Scene& scene) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.scene = &scene;
  m.device = rtcNewDevice(nullptr);
  if (!m.device)
    throw Error(fmt::format("cannot create the Embree device (error {})",
                            static_cast<int>(rtcGetDeviceError(nullptr))));
  rtcSetDeviceErrorFunction(m.device, errorCallback, &m);
  m.top = rtcNewScene(m.device);
  rtcSetSceneBuildQuality(m.top, RTC_BUILD_QUALITY_HIGH);
  m.object_scenes.resize(scene.objects.size(), nullptr);
  m.object_geom.resize(scene.objects.size());
  m.shape_record.assign(scene.shapes.size(), -1);
  m.shape_world_mesh.assign(scene.shapes.size(), -1);
  // Records first (their addresses must not move once Embree holds them).
  m.records.reserve(scene.shapes.size());
  for (size_t i = 0; i < scene.shapes.size(); ++i) {
    std::optional<ShapeRecord> r = shapeRecord(scene, i);
    if (!r) continue;
    m.shape_record[i] = static_cast<int>(m.records.size());
    m.records.push_back(std::move(*r));
  }
  // Embree's high-quality build (spatial splits) pays for itself on scenes of moderate size; on
  // millions of top-level primitives it costs more time and memory in the build than it saves in
  // a render, so those get the medium (binned SAH) build.
  size_t top_primitives = 0;
  for (const ShapeRecord& r : m.records)
    if (r.desc->object < 0 && !r.motion && r.vertices_per_face > 0)
      top_primitives += r.indices.size() / static_cast<size_t>(r.vertices_per_face);
  if (top_primitives > kHighQualityBuildLimit)
    rtcSetSceneBuildQuality(m.top, RTC_BUILD_QUALITY_MEDIUM);
  // Object definitions of millions of primitives (scenes built to be instanced at scale) get
  // Embree's compact BVH, which leaves the vertices in the vertex buffer instead of copying
  // them into its leaves: 24 % less peak memory and a faster build on 3 M unique triangles
  // (docs/performance.md) for a render within a few per cent; the hits are the same.
  size_t object_primitives = 0;
  for (const ShapeRecord& r : m.records)
    if (r.desc->object >= 0 && r.vertices_per_face > 0)
      object_primitives += r.indices.size() / static_cast<size_t>(r.vertices_per_face);
  const bool compact_objects = object_primitives > kHighQualityBuildLimit;
  for (size_t ri = 0; ri < m.records.size(); ++ri) m.addRecordGeometry(ri, compact_objects);
  for (RTCScene os : m.object_scenes)
    if (os) rtcCommitScene(os);
  m.check("building object definitions");
  m.addInstances();
  rtcCommitScene(m.top);
  m.check("building the scene");
  RTCBounds b;
  rtcGetSceneBounds(m.top, &b);
  if (b.lower_x <= b.upper_x) {
    bounds_.extend({b.lower_x, b.lower_y, b.lower_z});
    bounds_.extend({b.upper_x, b.upper_y, b.upper_z});
  }
}

Accel::~Accel() = default;

uint64_t Accel::invalidRays() const {
  return impl_->invalid_rays.load();
}

const WorldMesh* Accel::worldMesh(int shape) const {
  if (shape < 0 || static_cast<size_t>(shape) >= impl_->shape_world_mesh.size()) return nullptr;
  const int i = impl_->shape_world_mesh[static_cast<size_t>(shape)];
  return i < 0 ? nullptr : &impl_->world_meshes[static_cast<size_t>(i)];
}

namespace {

// What Embree accepts (its ray.valid(), asserted in Debian's build): origin and direction
// components finite and within +-1.844e18 (FLT_LARGE), a non-zero direction, tmax >= 0. A scene
// with NaN or huge numbers can make other rays; they are counted and dropped (no hit).
constexpr double kEmbreeLarge = 1.844e18;
bool rayIsValid(const Ray& ray) {
  const double c[6] = {ray.o.x, ray.o.y, ray.o.z, ray.d.x, ray.d.y, ray.d.z};
  for (double v : c)
    if (!(std::abs(v) <= kEmbreeLarge)) return false;
  if (ray.d.x == 0 && ray.d.y == 0 && ray.d.z == 0) return false;
  return ray.tmax >= 0;  // false for NaN
}

void setRay(RTCRay& r, const Ray& ray) {
  r.org_x = float(ray.o.x), r.org_y = float(ray.o.y), r.org_z = float(ray.o.z);
  r.dir_x = float(ray.d.x), r.dir_y = float(ray.d.y), r.dir_z = float(ray.d.z);
  r.tnear = 0;
  r.tfar = std::isfinite(ray.tmax) ? float(ray.tmax) : INFINITY;
  r.time = 0;  // Embree's own motion blur is not used; TimedContext carries the time
  r.mask = 0xFFFFFFFFu;
  r.id = 0;
  r.flags = 0;
}

Vec3 faceForward(const Vec3& v, const Vec3& ref) {
  return dot(v, ref) < 0 ? -v : v;
}

/// Any unit vector perpendicular to n.
Vec3 perpendicular(const Vec3& n) {
  const Vec3 a = std::abs(n.x) > 0.9 ? Vec3{0, 1, 0} : Vec3{1, 0, 0};
  return normalize(cross(n, a));
}

/// A hit's surface in its record's space (world, an instance's or an animated shape's object
/// space): the fields of SurfaceHit that the record's transform carries to world.
struct LocalHit {
  Vec3 p, ng, ns, dpdu;
  Vec3 dpdv{0, 0, 0}, dndu{0, 0, 0}, dndv{0, 0, 0};
  Vec2 uv;
};

/// A mesh hit's shading normal from its interpolated vertex normals sn (the geometric normal
/// where sn vanishes), the geometric normal turned to its side.
void shadingNormal(LocalHit& out, const Vec3& sn) {
  out.ns = length(sn) > 0 ? normalize(sn) : out.ng;
  out.ng = faceForward(out.ng, out.ns);
}

/// A mesh hit without vertex normals: the geometric normal (flipped for reverseorientation)
/// shades.
void geometricOnly(LocalHit& out, bool flip) {
  if (flip) out.ng = -out.ng;
  out.ns = out.ng;
}

/// The surface of a curve segment hit at Embree's (u, v) and ray parameter t.
LocalHit curveHit(const ShapeRecord& r, int prim, const RTCHit& hit, const Vec3& o, const Vec3& d,
                  double t) {
  LocalHit out;
  const CurveHitGeometry g =
      curveHitGeometry(*r.curve, r.curve_space, static_cast<size_t>(prim), hit.u, hit.v,
                       Vec3{hit.Ng_x, hit.Ng_y, hit.Ng_z}, o + d * t, d);
  out.p = g.p;
  out.ng = r.flip ? -g.n : g.n;
  out.ns = out.ng;
  out.dpdu = g.dpdu;
  out.dpdv = g.dpdv;
  out.uv = g.uv;
  return out;
}

/// The surface of a quadric hit by the ray (o, d); refines t in double precision from the
/// object-space ray (Embree's float t is the start).
LocalHit quadricHit(const ShapeRecord& r, const Vec3& o, const Vec3& d, double& t) {
  LocalHit out;
  const Vec3 oo = r.object_from_space.applyPoint(o), od = r.object_from_space.applyVector(d);
  const double t0 = std::max(0.0, t * (1 - 1e-4) - 1e-7);
  auto refined = intersectQuadric(*r.desc, oo, od, t0, t * (1 + 1e-4) + 1e-7);
  if (refined) t = *refined;
  const LocalGeometry g = quadricGeometry(*r.desc, oo + od * t);
  out.p = r.space_from_object.applyPoint(g.p);
  out.ng = normalize(r.space_from_object.applyNormal(g.n));
  if (r.flip) out.ng = -out.ng;
  out.ns = out.ng;
  out.dpdu = r.space_from_object.applyVector(g.dpdu);
  out.dpdv = r.space_from_object.applyVector(g.dpdv);
  out.dndu = r.space_from_object.applyNormal(g.dndu);
  out.dndv = r.space_from_object.applyNormal(g.dndv);
  out.uv = g.uv;
  return out;
}

/// The surface of triangle `prim` at Embree's barycentrics (hit.u, hit.v).
LocalHit triangleHit(const ShapeRecord& r, int prim, const RTCHit& hit) {
  LocalHit out;
  const int* f = &r.indices[3 * static_cast<size_t>(prim)];
  const Vec3 &p0 = r.p[size_t(f[0])], &p1 = r.p[size_t(f[1])], &p2 = r.p[size_t(f[2])];
  const double b1 = hit.u, b2 = hit.v, b0 = 1 - b1 - b2;
  out.p = p0 * b0 + p1 * b1 + p2 * b2;
  Vec3 n = cross(p0 - p2, p1 - p2);
  out.ng = length(n) > 0 ? normalize(n) : Vec3{0, 0, 1};
  Vec2 uv0{0, 0}, uv1{1, 0}, uv2{1, 1};
  if (!r.uv.empty()) uv0 = r.uv[size_t(f[0])], uv1 = r.uv[size_t(f[1])], uv2 = r.uv[size_t(f[2])];
  out.uv = uv0 * b0 + uv1 * b1 + uv2 * b2;
  const Vec2 duv02 = uv0 - uv2, duv12 = uv1 - uv2;
  const double det = duv02.x * duv12.y - duv02.y * duv12.x;
  if (std::abs(det) > 1e-12) {
    out.dpdu = ((p0 - p2) * duv12.y - (p1 - p2) * duv02.y) / det;
    // pbrt-v4 Triangle::InteractionFromIntersection: dp/dv, and dn/du, dn/dv from the
    // vertex normals.
    out.dpdv = ((p1 - p2) * duv02.x - (p0 - p2) * duv12.x) / det;
    if (!r.n.empty()) {
      const Vec3 dn1 = r.n[size_t(f[0])] - r.n[size_t(f[2])];
      const Vec3 dn2 = r.n[size_t(f[1])] - r.n[size_t(f[2])];
      out.dndu = (dn1 * duv12.y - dn2 * duv02.y) / det;
      out.dndv = (dn2 * duv02.x - dn1 * duv12.x) / det;
    }
  }
  if (!r.n.empty())
    shadingNormal(out, r.n[size_t(f[0])] * b0 + r.n[size_t(f[1])] * b1 + r.n[size_t(f[2])] * b2);
  else
    geometricOnly(out, r.flip);
  return out;
}

/// The surface of bilinear patch `prim` at Embree's (hit.u, hit.v) on the ray (o, d) at t.
LocalHit bilinearHit(const ShapeRecord& r, int prim, const RTCHit& hit, const Vec3& o,
                     const Vec3& d, double t) {
  LocalHit out;
  const int* f = &r.indices[4 * static_cast<size_t>(prim)];
  const Vec3 &p00 = r.p[size_t(f[0])], &p10 = r.p[size_t(f[1])], &p01 = r.p[size_t(f[2])],
             &p11 = r.p[size_t(f[3])];
  const double u = hit.u, v = hit.v;
  // The point on the triangle Embree hit (a warped patch's bilinear point at (u, v) is off
  // that surface).
  out.p = o + d * t;
  out.dpdu = (p10 - p00) * (1 - v) + (p11 - p01) * v;
  out.dpdv = (p01 - p00) * (1 - u) + (p11 - p10) * u;
  Vec3 n = cross(out.dpdu, out.dpdv);
  out.ng = length(n) > 0 ? normalize(n) : Vec3{0, 0, 1};
  // The surface Embree intersects is one of the patch's two triangles: its normal (oriented as
  // the patch's) is the geometric normal, so light pdfs use the surface actually hit.
  const Vec3 tn{hit.Ng_x, hit.Ng_y, hit.Ng_z};
  if (length(tn) > 0) out.ng = dot(tn, out.ng) < 0 ? -normalize(tn) : normalize(tn);
  out.uv = {u, v};
  if (!r.uv.empty()) {
    const Vec2 &a = r.uv[size_t(f[0])], &b = r.uv[size_t(f[1])], &c = r.uv[size_t(f[2])],
               &e = r.uv[size_t(f[3])];
    out.uv = (a * (1 - u) + b * u) * (1 - v) + (c * (1 - u) + e * u) * v;
  }
  if (!r.n.empty())
    shadingNormal(out, (r.n[size_t(f[0])] * (1 - u) + r.n[size_t(f[1])] * u) * (1 - v) +
                           (r.n[size_t(f[2])] * (1 - u) + r.n[size_t(f[3])] * u) * v);
  else
    geometricOnly(out, r.flip);
  return out;
}

}  // namespace

std::optional<SurfaceHit> Accel::intersect(const Ray& ray) const {
  const Impl& m = *impl_;
  if (!rayIsValid(ray)) {
    m.invalid_rays.fetch_add(1, std::memory_order_relaxed);
    return std::nullopt;
  }
  RTCRayHit rh;
  setRay(rh.ray, ray);
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  TimedContext ctx;
  rtcInitIntersectContext(&ctx.base);
  ctx.time = ray.time;
  rtcIntersect1(m.top, &ctx.base, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;

  SurfaceHit h;
  h.t = rh.ray.tfar;
  int record;
  // World from the record's space: an instance's transform (static, or animated and taken at
  // the ray's time), then an animated shape's own motion at that time.
  const Transform* world_from_space = nullptr;
  std::optional<Transform> moved;  // only for motion (no copies for static scenes)
  Vec3 o = ray.o, d = ray.d;
  if (rh.hit.instID[0] != RTC_INVALID_GEOMETRY_ID) {
    h.instance = m.top_geom_instance[rh.hit.instID[0]];
    const scene::Instance& inst = m.scene->instances[static_cast<size_t>(h.instance)];
    world_from_space = &m.instance_transform[size_t(h.instance)];
    record = m.object_geom[static_cast<size_t>(inst.object)][rh.hit.geomID];
  } else if (m.top_geom_instance[rh.hit.geomID] >= 0) {  // an animated instance's wrapper
    h.instance = m.top_geom_instance[rh.hit.geomID];
    const scene::Instance& inst = m.scene->instances[static_cast<size_t>(h.instance)];
    moved = m.instance_motion[size_t(h.instance)]->interpolate(ray.time);
    world_from_space = &*moved;
    record = m.object_geom[static_cast<size_t>(inst.object)][ctx.inner_geom];
  } else {
    record = m.top_geom[rh.hit.geomID];
  }
  const ShapeRecord& r = m.records[static_cast<size_t>(record)];
  if (r.motion) {
    const Transform shape_moved = r.motion->interpolate(ray.time);
    moved = world_from_space ? *world_from_space * shape_moved : shape_moved;
    world_from_space = &*moved;
  }
  if (world_from_space) {
    const Transform space_from_world = inverse(*world_from_space);
    o = space_from_world.applyPoint(o);
    d = space_from_world.applyVector(d);
  }
  h.shape = r.shape;
  h.prim = static_cast<int>(rh.hit.primID);
  LocalHit g;
  if (r.curve)
    g = curveHit(r, h.prim, rh.hit, o, d, h.t);
  else if (r.indices.empty())
    g = quadricHit(r, o, d, h.t);
  else if (r.vertices_per_face == 3)
    g = triangleHit(r, h.prim, rh.hit);
  else
    g = bilinearHit(r, h.prim, rh.hit, o, d, h.t);
  Vec3 p = g.p, ng = g.ng, ns = g.ns, dpdu = g.dpdu, dpdv = g.dpdv, dndu = g.dndu, dndv = g.dndv;
  const Vec2 uv = g.uv;
  if (world_from_space) {
    p = world_from_space->applyPoint(p);
    ng = normalize(world_from_space->applyNormal(ng));
    ns = normalize(world_from_space->applyNormal(ns));
    dpdu = world_from_space->applyVector(dpdu);
    dpdv = world_from_space->applyVector(dpdv);
    dndu = world_from_space->applyNormal(dndu);
    dndv = world_from_space->applyNormal(dndv);
  }
  if (length(dpdu) == 0 || !std::isfinite(dpdu.x)) dpdu = perpendicular(ns);
  if (length(dpdv) == 0 || !std::isfinite(dpdv.x)) dpdv = cross(ns, dpdu);
  h.p = p;
  h.ng = ng;
  h.ns = ns;
  h.dpdu = dpdu;
  h.dpdv = dpdv;
  h.dndu = dndu;
  h.dndv = dndv;
  h.uv = uv;
  return h;
}

bool Accel::occluded(const Ray& ray) const {
  if (!rayIsValid(ray)) {
    impl_->invalid_rays.fetch_add(1, std::memory_order_relaxed);
    return true;  // no light arrives along a ray that cannot be traced
  }
  RTCRay r;
  setRay(r, ray);
  TimedContext ctx;
  rtcInitIntersectContext(&ctx.base);
  ctx.time = ray.time;
  rtcOccluded1(impl_->top, &ctx.base, &r);
  return r.tfar < 0;
}

}  // namespace lensim::render
