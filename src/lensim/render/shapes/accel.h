// The one owner of Embree (3): the device, the scene of world geometry and one Embree scene per
// object definition, instanced with Embree instances. Triangle meshes are Embree triangles,
// bilinear meshes Embree quads (each patch as two triangles: exact for planar parallelograms,
// an approximation for warped patches), quadrics exact user geometry intersected in double
// precision. Embree's errors are collected by its error callback and thrown as lensim::Error.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "lensim/render/shapes/shapes.h"
#include "lensim/util/transform.h"

namespace lensim::scene {
struct Scene;
}

namespace lensim::render {

/// A ray hit with its local geometry in world space.
struct SurfaceHit {
  double t = 0;       ///< ray parameter (units of |d|)
  Vec3 p;             ///< world position
  Vec3 ng;            ///< unit geometric normal, pbrt's orientation (ReverseOrientation applied)
  Vec3 ns;            ///< unit shading normal, on the same side as ng
  Vec3 dpdu;          ///< world dp/du
  Vec3 dpdv;          ///< world dp/dv (bump mapping)
  Vec3 dndu, dndv;    ///< world dn/du, dn/dv of the (shading) normal (bump mapping)
  Vec2 uv;            ///< surface (u, v)
  int shape = -1;     ///< index into Scene::shapes
  int prim = 0;       ///< face index within a mesh (0 for quadrics)
  int instance = -1;  ///< index into Scene::instances, or -1 for world shapes
};

/// A world-space mesh of an emissive shape outside object definitions, for light sampling.
struct WorldMesh {
  int vertices_per_face = 3;
  std::vector<Vec3> p;
  std::vector<Vec3> n;   ///< per-vertex shading normals, or empty
  std::vector<Vec2> uv;  ///< per-vertex (u, v), or empty
  std::vector<int> indices;
  bool flip = false;  ///< the shape's ReverseOrientation xor handedness swap
};

class Accel {
 public:
  /// Builds the Embree scenes for every shape and instance of `scene` (which must outlive this).
  explicit Accel(const scene::Scene& scene);
  ~Accel();
  Accel(const Accel&) = delete;
  Accel& operator=(const Accel&) = delete;

  /// The nearest hit with t in (0, ray.tmax).
  std::optional<SurfaceHit> intersect(const Ray& ray) const;
  /// Whether anything lies along the ray for t in (0, ray.tmax).
  bool occluded(const Ray& ray) const;
  /// World bounds of all geometry (empty for an empty scene).
  Bounds3 bounds() const { return bounds_; }
  /// The world-space mesh of a world (non-instanced) emissive mesh shape; nullptr for others.
  const WorldMesh* worldMesh(int shape) const;
  /// Rays with non-finite or huge origin or direction that were dropped instead of traced.
  uint64_t invalidRays() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
  Bounds3 bounds_;
};

}  // namespace lensim::render
