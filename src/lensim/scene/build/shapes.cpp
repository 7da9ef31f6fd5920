// Builder: Shape: quadrics, meshes, curves, tessellated and PLY shapes; Loop subdivision.
#include "lensim/scene/build/builder_internal.h"
#include "lensim/scene/loop_subdivision.h"

namespace lensim::scene::detail {

// ---- shapes --------------------------------------------------------------------------------
void Builder::shape(const Directive& d) {
  const std::string& type = d.strings[0];
  ParamSet ps(d.params, d.loc, fmt::format("Shape \"{}\"", type));
  ps.addDefaults(gs_.shape_attrs);
  Shape s;
  s.type_as_written = type;
  s.loc = d.loc;
  s.transform = gs_.ctm[0];
  s.reverse_orientation = gs_.reverse_orientation;
  s.alpha = floatInput(ps, {"alpha"});
  requireInvertible(d.loc, fmt::format("Shape \"{}\"", type));
  s.motion = motionOfCtm(d.loc, fmt::format("Shape \"{}\"", type));
  if (type == "sphere") {
    s.type = ShapeType::Sphere;
    s.radius = ps.getFloat({"radius"}, 1);
    s.zmin = std::clamp(ps.getFloat({"zmin"}, -s.radius), -s.radius, s.radius);
    s.zmax = std::clamp(ps.getFloat({"zmax"}, s.radius), -s.radius, s.radius);
    if (s.zmin > s.zmax) std::swap(s.zmin, s.zmax);
    s.phimax_deg = ps.getFloat({"phimax"}, 360);
  } else if (type == "disk") {
    s.type = ShapeType::Disk;
    s.height = ps.getFloat({"height"}, 0);
    s.radius = ps.getFloat({"radius"}, 1);
    s.inner_radius = ps.getFloat({"innerradius"}, 0);
    if (s.inner_radius < 0 || s.inner_radius >= s.radius)
      throw Error(
          ps.peek({"innerradius"}) ? ps.peek({"innerradius"})->loc : d.loc,
          fmt::format("disk inner radius {} outside [0, radius {})", s.inner_radius, s.radius));
    s.phimax_deg = ps.getFloat({"phimax"}, 360);
  } else if (type == "cylinder") {
    s.type = ShapeType::Cylinder;
    s.radius = ps.getFloat({"radius"}, 1);
    s.zmin = ps.getFloat({"zmin"}, -1);
    s.zmax = ps.getFloat({"zmax"}, 1);
    if (s.zmin > s.zmax) std::swap(s.zmin, s.zmax);
    s.phimax_deg = ps.getFloat({"phimax"}, 360);
  } else if (type == "cone") {
    s.type = ShapeType::Cone;
    s.height = ps.getFloat({"height"}, 1);
    s.radius = ps.getFloat({"radius"}, 1);
    s.phimax_deg = ps.getFloat({"phimax"}, 360);
  } else if (type == "trianglemesh" || type == "bilinearmesh" || type == "loopsubdiv") {
    s.type = type == "bilinearmesh" ? ShapeType::BilinearMesh : ShapeType::TriangleMesh;
    s.mesh = inlineMesh(type, ps, d.loc);
  } else if (type == "plymesh") {
    s.type = ShapeType::TriangleMesh;
    s.mesh = plyMesh(ps, d.loc);
  } else if (type == "curve") {
    s.type = ShapeType::Curve;
    s.curve = curveShape(ps, d.loc);
  } else if (type == "hyperboloid" || type == "paraboloid" || type == "heightfield" ||
             type == "nurbs") {
    s.type = ShapeType::TriangleMesh;
    s.mesh = tessellatedShape(type, ps, d.loc);
  } else {
    ps.markAllUsed();
    warnOnce("shape " + type, d.loc,
             fmt::format("shape \"{}\" is not rendered by lensim; it is left out", type));
    return;
  }
  if (s.phimax_deg <= 0 || s.phimax_deg > 360) {
    const Param* p = ps.peek({"phimax"});
    throw Error(p ? p->loc : d.loc,
                fmt::format("phimax {} outside (0, 360] degrees", s.phimax_deg));
  }
  if (s.radius <= 0 && s.type != ShapeType::TriangleMesh && s.type != ShapeType::BilinearMesh &&
      s.type != ShapeType::Curve) {
    const Param* p = ps.peek({"radius"});
    throw Error(p ? p->loc : d.loc, fmt::format("radius {} must be positive", s.radius));
  }
  finish(ps);
  s.material = currentMaterial();
  if (!gs_.material_name.empty())
    pending_materials_.push_back(
        {static_cast<int>(scene_.shapes.size()), gs_.material_name, gs_.material_name_loc});
  if (gs_.area_light >= 0) {
    // pbrt-v4 (src/pbrt/scene.cpp, area lights in BasicScene::CreateAggregate): "Animated area
    // lights are not supported." (an error there too).
    if (s.motion >= 0)
      throw Error(d.loc,
                  "animated area lights are not supported (as in pbrt-v4): the shape's transform "
                  "differs at the start and end times (ActiveTransform)");
    if (s.type == ShapeType::Curve) {
      warnOnce("curve area light", d.loc,
               "area lights on curves are not supported; the curve does not emit");
    } else if (current_object_ >= 0) {
      warnOnce("instanced area light", d.loc,
               "area lights in object definitions are not supported (as in pbrt-v4); the shape "
               "does not emit");
    } else {
      s.area_light = gs_.area_light;
      ++scene_.lights[static_cast<size_t>(gs_.area_light)].shape_count;
    }
  }
  if (current_object_ >= 0) {
    s.object = current_object_;
    scene_.objects[static_cast<size_t>(current_object_)].shapes.push_back(
        static_cast<int>(scene_.shapes.size()));
  }
  if (!gs_.inside_medium.empty() || !gs_.outside_medium.empty())
    pending_media_.push_back({static_cast<int>(scene_.shapes.size()), gs_.inside_medium,
                              gs_.outside_medium, gs_.medium_loc});
  scene_.shapes.push_back(std::move(s));
}

int Builder::inlineMesh(const std::string& type, ParamSet& ps, const FileLoc& loc) {
  Mesh m;
  const int fv = type == "bilinearmesh" ? 4 : 3;
  m.vertices_per_face = fv;
  const Param* P = ps.find({"P"}, {ParamType::Point3});
  if (!P) throw Error(loc, fmt::format("{}: missing \"point3 P\"", type));
  std::vector<Vec3> pos;
  for (size_t i = 0; i + 2 < P->numbers.size(); i += 3)
    pos.push_back({P->numbers[i], P->numbers[i + 1], P->numbers[i + 2]});
  const Param* I = ps.find({"indices"}, {ParamType::Integer});
  std::vector<int> idx;
  if (I) {
    for (double v : I->numbers) idx.push_back(static_cast<int>(v));
    if (idx.size() % static_cast<size_t>(fv) != 0)
      ps.fail(*I, fmt::format("expected a multiple of {} indices, got {}", fv, idx.size()));
    for (int i : idx)
      if (i < 0 || static_cast<size_t>(i) >= pos.size())
        ps.fail(*I, fmt::format("index {} out of range: there are {} vertices", i, pos.size()));
  } else if (pos.size() == static_cast<size_t>(fv)) {
    for (int i = 0; i < fv; ++i) idx.push_back(i);
  } else {
    throw Error(loc, fmt::format("{}: missing \"integer indices\" (only a single {} may omit "
                                 "them)",
                                 type, fv == 3 ? "triangle" : "patch"));
  }
  if (type == "loopsubdiv") {
    int levels = ps.getInt({"levels", "nlevels"}, 3);
    if (levels < 0 || levels > 8) throw Error(loc, fmt::format("loopsubdiv: {} levels", levels));
    // Every level makes four triangles of one; with the topology tables about 400 bytes a
    // triangle at the last level.
    const double triangles = static_cast<double>(idx.size() / 3) * std::pow(4.0, levels);
    checkMemory(400.0 * triangles, loc,
                fmt::format("loopsubdiv: {} levels of {} triangles ({:.3g} triangles)", levels,
                            idx.size() / 3, triangles));
    loopSubdivide(pos, idx, levels);
  }
  for (const Vec3& p : pos) m.positions.push_back(Vec3f(p));
  m.indices = std::move(idx);
  auto perVertex = [&](const Param* p, size_t per) {
    if (p && p->numbers.size() != pos.size() * per)
      ps.fail(*p, fmt::format("expected one value per vertex ({}), got {}", pos.size(),
                              p->numbers.size() / per));
  };
  if (type != "loopsubdiv") {
    const Param* N = ps.find({"N"}, {ParamType::Normal3});
    perVertex(N, 3);
    if (N)
      for (size_t i = 0; i + 2 < N->numbers.size(); i += 3)
        m.normals.push_back(Vec3f(Vec3{N->numbers[i], N->numbers[i + 1], N->numbers[i + 2]}));
    const Param* UV = ps.find({"uv", "st"}, {ParamType::Point2, ParamType::Float});
    perVertex(UV, 2);
    if (UV)
      for (size_t i = 0; i + 1 < UV->numbers.size(); i += 2)
        m.uvs.push_back({float(UV->numbers[i]), float(UV->numbers[i + 1])});
    if (fv == 3) {
      const Param* S = ps.find({"S"}, {ParamType::Vector3});
      perVertex(S, 3);
      if (S)
        for (size_t i = 0; i + 2 < S->numbers.size(); i += 3)
          m.tangents.push_back(Vec3f(Vec3{S->numbers[i], S->numbers[i + 1], S->numbers[i + 2]}));
    }
    m.face_indices = ps.getInts({"faceIndices"});
  }
  scene_.meshes.push_back(std::move(m));
  return static_cast<int>(scene_.meshes.size()) - 1;
}

// pbrt-v4 Curve::Create (src/pbrt/shapes.cpp): "P", "basis" bezier|bspline, "degree" 2|3
// (3), "type" flat|ribbon|cylinder (flat), "N" for ribbons (nSegments + 1), "width" (1),
// "width0"/"width1" (width), "splitdepth" (pbrt's refinement; read and ignored).
int Builder::curveShape(ParamSet& ps, const FileLoc& loc) {
  const std::string basis = ps.getString({"basis"}, "bezier");
  if (basis != "bezier" && basis != "bspline") {
    const Param* p = ps.peek({"basis"});
    throw Error(p ? p->loc : loc, fmt::format("curve basis \"{}\": expected \"bezier\" or "
                                              "\"bspline\"",
                                              basis));
  }
  const int degree = ps.getInt({"degree"}, 3);
  if (degree != 2 && degree != 3) {
    const Param* p = ps.peek({"degree"});
    throw Error(p ? p->loc : loc, fmt::format("curve degree {}: expected 2 or 3", degree));
  }
  const std::vector<Vec3> P = ps.getVec3s({"P"}, {ParamType::Point3});
  const bool bspline = basis == "bspline";
  const int segments = curveSegmentCount(bspline, degree, P.size());
  if (segments <= 0) {
    const Param* p = ps.peek({"P"});
    throw Error(p ? p->loc : loc,
                bspline ? fmt::format("curve: {} control points; a degree {} b-spline needs at "
                                      "least {}",
                                      P.size(), degree, degree + 1)
                        : fmt::format("curve: {} control points; a degree {} Bézier curve "
                                      "needs {} + n * {}",
                                      P.size(), degree, degree + 1, degree));
  }
  const std::string type = ps.getString({"type"}, "flat");
  CurveKind kind = CurveKind::Flat;
  if (type == "ribbon")
    kind = CurveKind::Ribbon;
  else if (type == "cylinder")
    kind = CurveKind::Cylinder;
  else if (type != "flat") {
    // pbrt-v4 reports an unknown type and uses "cylinder".
    const Param* p = ps.peek({"type"});
    warnOnce(fmt::format("curve type {}", type), p ? p->loc : loc,
             fmt::format("unknown curve type \"{}\"; using \"cylinder\" (as pbrt-v4)", type));
    kind = CurveKind::Cylinder;
  }
  std::vector<Vec3> N = ps.getVec3s({"N"}, {ParamType::Normal3});
  if (!N.empty() && kind != CurveKind::Ribbon) {
    warnOnce("curve normals", loc, "curve normals \"N\" are only used with \"ribbon\" curves");
    N.clear();
  } else if (kind == CurveKind::Ribbon && N.size() != size_t(segments) + 1) {
    throw Error(loc, fmt::format("ribbon curve: {} normals \"N\" given; {} needed (one per "
                                 "segment end, {} segments)",
                                 N.size(), segments + 1, segments));
  }
  const double width = ps.getFloat({"width"}, 1);
  const double w0 = ps.getFloat({"width0"}, width), w1 = ps.getFloat({"width1"}, width);
  if (w0 < 0 || w1 < 0)
    throw Error(loc, fmt::format("curve widths {} and {} must be >= 0", w0, w1));
  ps.getInt({"splitdepth"}, 3);  // pbrt's subdivision depth: Embree needs none
  scene_.curves.push_back(makeCurve(kind, bspline, degree, P, w0, w1, N));
  return static_cast<int>(scene_.curves.size()) - 1;
}

// pbrt's hyperboloid, paraboloid, heightfield and nurbs as meshes (scene/shapes_tessellated).
int Builder::tessellatedShape(const std::string& type, ParamSet& ps, const FileLoc& loc) {
  auto phimaxOf = [&] {
    const double phimax = ps.getFloat({"phimax"}, 360);
    if (phimax <= 0 || phimax > 360) {
      const Param* p = ps.peek({"phimax"});
      throw Error(p ? p->loc : loc, fmt::format("phimax {} outside (0, 360] degrees", phimax));
    }
    return phimax;
  };
  Mesh m;
  if (type == "hyperboloid") {
    // pbrt-v3 CreateHyperboloidShape (src/shapes/hyperboloid.cpp): p1 (0,0,0), p2 (1,1,1).
    const Vec3 p1 = ps.findPoint3({"p1"}).value_or(Vec3{0, 0, 0});
    const Vec3 p2 = ps.findPoint3({"p2"}).value_or(Vec3{1, 1, 1});
    const double phimax = phimaxOf();
    if (p1 == p2) throw Error(loc, "hyperboloid: p1 and p2 are the same point");
    m = tessellateHyperboloid(p1, p2, phimax);
  } else if (type == "paraboloid") {
    // pbrt-v3 CreateParaboloidShape (src/shapes/paraboloid.cpp): radius 1, zmin 0, zmax 1;
    // the constructor orders zmin/zmax and keeps z >= 0.
    const double radius = ps.getFloat({"radius"}, 1);
    double zmin = ps.getFloat({"zmin"}, 0), zmax = ps.getFloat({"zmax"}, 1);
    const double phimax = phimaxOf();
    if (zmin > zmax) std::swap(zmin, zmax);
    zmin = std::max(zmin, 0.0);
    if (radius <= 0) {
      const Param* p = ps.peek({"radius"});
      throw Error(p ? p->loc : loc, fmt::format("radius {} must be positive", radius));
    }
    if (zmax <= zmin)
      throw Error(loc, fmt::format("paraboloid: empty z range [{}, {}] (z >= 0)", zmin, zmax));
    m = tessellateParaboloid(radius, zmin, zmax, phimax);
  } else if (type == "heightfield") {
    // pbrt-v3 CreateHeightfield (src/shapes/heightfield.cpp): nu, nv, nu*nv floats Pz.
    const int nu = ps.getInt({"nu"}, -1), nv = ps.getInt({"nv"}, -1);
    const Param* pz = ps.find({"Pz"}, {ParamType::Float});
    if (nu < 2 || nv < 2)
      throw Error(loc, fmt::format("heightfield: \"integer nu\" {} and \"integer nv\" {} "
                                   "must both be given and >= 2",
                                   nu, nv));
    if (!pz) throw Error(loc, "heightfield: missing \"float Pz\"");
    if (pz->numbers.size() != size_t(nu) * size_t(nv))
      ps.fail(*pz, fmt::format("expected nu*nv = {} heights, got {}", nu * nv, pz->numbers.size()));
    m = heightfieldMesh(nu, nv, pz->numbers);
  } else {
    m = nurbsMeshOf(ps, loc);
  }
  scene_.meshes.push_back(std::move(m));
  return static_cast<int>(scene_.meshes.size()) - 1;
}

// pbrt-v3 CreateNURBS (src/shapes/nurbs.cpp): nu, nv, uorder, vorder, uknots (nu+uorder),
// vknots (nv+vorder), u0/u1 default uknots[uorder-1]/uknots[nu] (v likewise), and either
// "point3 P" or homogeneous "float Pw" (x w, y w, z w, w); diced 30 x 30.
Mesh Builder::nurbsMeshOf(ParamSet& ps, const FileLoc& loc) {
  NurbsPatch n;
  n.nu = ps.getInt({"nu"}, -1);
  n.nv = ps.getInt({"nv"}, -1);
  n.uorder = ps.getInt({"uorder"}, -1);
  n.vorder = ps.getInt({"vorder"}, -1);
  if (n.nu < 1 || n.nv < 1 || n.uorder < 1 || n.vorder < 1)
    throw Error(loc,
                "nurbs: \"integer nu\", \"nv\", \"uorder\" and \"vorder\" must be given "
                "and positive");
  if (n.uorder > n.nu || n.vorder > n.nv)
    throw Error(loc, fmt::format("nurbs: order ({}, {}) exceeds the control points ({}, {})",
                                 n.uorder, n.vorder, n.nu, n.nv));
  auto knots = [&](std::string_view name, size_t count) {
    const Param* k = ps.find({name}, {ParamType::Float});
    if (!k) throw Error(loc, fmt::format("nurbs: missing \"float {}\"", name));
    if (k->numbers.size() != count)
      ps.fail(*k, fmt::format("expected {} knots, got {}", count, k->numbers.size()));
    for (size_t i = 1; i < count; ++i)
      if (k->numbers[i] < k->numbers[i - 1]) ps.fail(*k, "knots must be non-decreasing");
    return k->numbers;
  };
  n.uknots = knots("uknots", size_t(n.nu + n.uorder));
  n.vknots = knots("vknots", size_t(n.nv + n.vorder));
  n.u0 = ps.getFloat({"u0"}, n.uknots[size_t(n.uorder - 1)]);
  n.u1 = ps.getFloat({"u1"}, n.uknots[size_t(n.nu)]);
  n.v0 = ps.getFloat({"v0"}, n.vknots[size_t(n.vorder - 1)]);
  n.v1 = ps.getFloat({"v1"}, n.vknots[size_t(n.nv)]);
  const size_t count = size_t(n.nu) * size_t(n.nv);
  if (const Param* P = ps.find({"P"}, {ParamType::Point3})) {
    if (P->numbers.size() != 3 * count)
      ps.fail(*P, fmt::format("expected nu*nv = {} points, got {}", count, P->numbers.size() / 3));
    for (size_t i = 0; i < count; ++i)
      n.P.push_back({P->numbers[3 * i], P->numbers[3 * i + 1], P->numbers[3 * i + 2]});
    n.w.assign(count, 1.0);
  } else if (const Param* Pw = ps.find({"Pw"}, {ParamType::Float})) {
    if (Pw->numbers.size() != 4 * count)
      ps.fail(*Pw,
              fmt::format("expected 4 nu*nv = {} values, got {}", 4 * count, Pw->numbers.size()));
    for (size_t i = 0; i < count; ++i) {
      const double w = Pw->numbers[4 * i + 3];
      if (!(w > 0)) ps.fail(*Pw, fmt::format("weight {} of point {} must be positive", w, i));
      n.P.push_back(Vec3{Pw->numbers[4 * i], Pw->numbers[4 * i + 1], Pw->numbers[4 * i + 2]} / w);
      n.w.push_back(w);
    }
  } else {
    throw Error(loc, "nurbs: missing \"point3 P\" or \"float Pw\"");
  }
  return nurbsMesh(n);
}

int Builder::plyMesh(ParamSet& ps, const FileLoc& loc) {
  const Param* fn = ps.find({"filename"}, {ParamType::String});
  if (!fn) throw Error(loc, "plymesh: missing \"string filename\"");
  std::string path = resolve(fn->strings[0], fn->loc, "PLY file");
  if (floatInput(ps, {"displacement"}))
    warnOnce("plymesh displacement", ps.peek({"displacement"})->loc,
             "plymesh \"displacement\" is not rendered; the mesh is used undisplaced");
  ps.getFloat({"edgelength"}, 1);
  io::PlyMesh ply;
  try {
    ply = io::readPly(path);
  } catch (const Error& e) {
    throw Error(fn->loc, e.message());
  }
  Mesh m;
  m.source = path;
  m.positions = std::move(ply.positions);
  m.normals = std::move(ply.normals);
  m.uvs = std::move(ply.uvs);
  m.indices = std::move(ply.triangles);
  // Quads (pbrt-v4 bilinear order p00 p10 p01 p11) become two triangles each.
  for (size_t q = 0; q + 3 < ply.quads.size(); q += 4) {
    const int* v = &ply.quads[q];
    m.indices.insert(m.indices.end(), {v[0], v[1], v[3], v[0], v[3], v[2]});
  }
  scene_.meshes.push_back(std::move(m));
  return static_cast<int>(scene_.meshes.size()) - 1;
}

}  // namespace lensim::scene::detail
