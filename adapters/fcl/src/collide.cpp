// The drop-in collide(): FCL's signature, meshcontact's pipeline on the
// model's own BVH for mesh-vs-shape pairs, fcl::collide for the rest.
#include "internal.h"

#include <fcl/config.h>  // FCL_HAVE_OCTOMAP
#include <fcl/geometry/shape/halfspace.h>
#include <fcl/geometry/shape/plane.h>
#include <fcl/narrowphase/collision.h>
#include <meshcontact/triangle.h>

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <numeric>
#include <string>

namespace meshcontact::fcl {

Scratch::Scratch() : impl_(std::make_unique<Impl>()) {}
Scratch::~Scratch() = default;
Scratch::Scratch(Scratch&&) noexcept = default;
Scratch& Scratch::operator=(Scratch&&) noexcept = default;

namespace detail {

namespace {

void orthonormalizeIfOff(Mat3& rotation, double err) {
  if (err > 1e-12) rotation = Eigen::Quaterniond(rotation).normalized().toRotationMatrix();
}

}  // namespace

Status poseFromTransform(const ::fcl::Transform3d& tf, const char* what, Pose& out) {
  out.rotation = tf.linear();
  out.translation = tf.translation();
  if (!out.rotation.allFinite() || !out.translation.allFinite())
    return {ErrorCode::kInvalidPose, std::string(what) + ": transform has a non-finite entry"};
  const double err = (out.rotation.transpose() * out.rotation - Mat3::Identity()).cwiseAbs().maxCoeff();
  if (!(err <= 1e-6) || !(out.rotation.determinant() > 0.0))
    return {ErrorCode::kInvalidPose, std::string(what) +
                                         ": rotation is not a proper orthonormal matrix (|R^T R - I| = " +
                                         describeValue(err) + ")"};
  // Every pose taken from FCL is a rotation: the shape's pose in the model
  // frame (the core's input) and the mesh's pose, which maps the contacts
  // back to the world. Rotated by the matrix as given, off by up to 1e-6, a
  // normal came out up to ~1e-6 from unit length (fuzz_fcl_adapter).
  orthonormalizeIfOff(out.rotation, err);
  return Status::ok();
}

Pose relativePose(const Pose& mesh, const Pose& shape) {
  Pose p = mesh.inverse() * shape;
  orthonormalizeIfOff(p.rotation, (p.rotation.transpose() * p.rotation - Mat3::Identity()).cwiseAbs().maxCoeff());
  return p;
}

Status checkPair(const MeshDesc& mesh, const ::fcl::CollisionObjectd& mesh_object,
                 const ::fcl::CollisionObjectd& shape_object, const char* mesh_name, const char* shape_name,
                 Pose& mesh_pose, Pose& shape_in_model) {
  Status s = checkModel(mesh, mesh_name);
  if (!s) return s;
  const ::fcl::Transform3d& mesh_tf = mesh_object.getTransform();
  if (mesh_tf.linear() == Mat3::Identity() && mesh_tf.translation() == Vec3::Zero()) {
    // The mesh at the world's origin (a static environment, the common
    // case): the shape's pose is its pose in the model frame. relativePose
    // would give the same (its products with exact ones and zeros are
    // exact, up to the sign of a zero), with the same re-orthonormalization,
    // for one rotation check instead of three.
    mesh_pose = Pose::identity();
    return poseFromTransform(shape_object.getTransform(), shape_name, shape_in_model);
  }
  Pose shape_pose;
  s = poseFromTransform(mesh_tf, mesh_name, mesh_pose);
  if (!s) return s;
  s = poseFromTransform(shape_object.getTransform(), shape_name, shape_pose);
  if (!s) return s;
  shape_in_model = relativePose(mesh_pose, shape_pose);
  return Status::ok();
}

void convertContacts(const std::vector<Contact>& contacts, const Pose& to_world, bool mesh_first,
                     const ::fcl::CollisionGeometryd* const* mesh_geometries, const ::fcl::CollisionGeometryd* shape,
                     std::size_t room, std::vector<std::uint32_t>& order, std::vector<::fcl::Contactd>& out) {
  out.clear();
  const std::size_t n = contacts.size();
  order.resize(n);
  std::iota(order.begin(), order.end(), 0u);
  if (n > room) {
    // The deepest `room` contacts, ties to the earlier one, back in order.
    std::partial_sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(room), order.end(),
                      [&](std::uint32_t a, std::uint32_t b) {
                        if (contacts[a].depth != contacts[b].depth) return contacts[a].depth > contacts[b].depth;
                        return a < b;
                      });
    order.resize(room);
    std::sort(order.begin(), order.end());
  }
  const bool identity = to_world.isIdentity();
  for (const std::uint32_t i : order) {
    const Contact& c = contacts[i];
    const ::fcl::CollisionGeometryd* mesh = mesh_geometries[c.mesh];
    const int triangle = static_cast<int>(c.triangle);
    const Vec3 normal = identity ? c.normal : Vec3(to_world.rotation * c.normal);
    const Vec3 point = identity ? c.point : to_world.apply(c.point);
    // int{NONE}: a copy. emplace_back's forwarding reference would odr-use the
    // static member, which FCL declares but never defines (clang: link error).
    if (mesh_first)
      out.emplace_back(mesh, shape, triangle, int{::fcl::Contactd::NONE}, point, normal, c.depth);
    else
      out.emplace_back(shape, mesh, int{::fcl::Contactd::NONE}, triangle, point, Vec3(-normal), c.depth);
  }
}

Contact planeContact(const CandidateTriangle& c, const Vec3& n, const Vec3& deepest, double depth) {
  Contact out;
  out.point = deepest;
  out.normal = n;
  out.depth = std::max(depth, 0.0);
  out.mesh = c.mesh;
  out.triangle = c.triangle;
  out.feature = Feature::face();
  return out;
}

bool passesThrough(const ShapeDesc& shape, const Pose& pose, const CandidateTriangle& c, const Vec3& n,
                   double depth, const ::fcl::CollisionRequestd* confirm) {
  // FCL's own tolerance decides touching pairs; this band only skips
  // triangles whose plane the shape clearly does not reach.
  const double band = 1e-6 * shape.size;
  const Vec3& a = c.vertices[0];
  if (depth < -band) return false;                                  // wholly in front of the plane: the pipeline had it
  if (n.dot(supportPoint(shape, pose, n) - a) < -band) return false;  // wholly behind: no overlap
  // The walk keeps degenerate triangles (the narrowphases reject them):
  // tested only here, for the few candidates that get this far.
  if (isDegenerateTriangle(a, c.vertices[1], c.vertices[2])) return false;
  if (!confirm) return true;
  // The shape's bounding ball must reach the triangle (Ericson 5.2.7)
  // before the two-sided test is asked: near misses straddle the planes of
  // several candidates, and that test runs FCL's GJK for most shapes.
  const Vec3 q = closestPointOnTriangle(pose.translation, a, c.vertices[1], c.vertices[2]).point;
  const double reach = shape.bound + band;
  if ((q - pose.translation).squaredNorm() > reach * reach) return false;
  // For a sphere that test is the whole test (the ball is the shape).
  return shape.kind == ShapeKind::kSphere ||
         shapeOverlapsTriangle(shape, pose, a, c.vertices[1], c.vertices[2], q, confirm->gjk_tolerance);
}

bool throughContact(const ShapeDesc& shape, const Pose& pose, const CandidateTriangle* candidates,
                    std::size_t count, const ::fcl::CollisionRequestd* confirm, Contact& out, bool first_overlap) {
  bool found = false;
  const double band = 1e-6 * shape.size;  // passesThrough's
  for (std::size_t k = 0; k < count && !(first_overlap && found); ++k) {
    const CandidateTriangle& c = candidates[k];
    const Vec3& a = c.vertices[0];
    const Vec3 cross = (c.vertices[1] - a).cross(c.vertices[2] - a);
    // A sphere whose centre is in front of this triangle's plane and that
    // overlaps the triangle gets a contact from the core's narrowphase
    // (reference §4a: only a centre behind the plane is culled), and this
    // fallback runs only when the pipeline gave none: no overlap here. Tested
    // first: it skips most of a sphere's candidates before any support call,
    // and on the unnormalised normal (height > band as s > band |cross|,
    // squared), before the division that normalising costs. Only where
    // band^2, |cross|^2 and their product are normal numbers: an underflow
    // to zero or a subnormal would skip triangles the height test keeps (an
    // overflow to Inf skips none).
    if (confirm && shape.kind == ShapeKind::kSphere) {
      const double s = cross.dot(pose.translation - a);
      const double band2 = band * band, cross2 = cross.squaredNorm(), limit = band2 * cross2;
      constexpr double kNormal = std::numeric_limits<double>::min();
      if (band2 >= kNormal && cross2 >= kNormal && limit >= kNormal && s > 0.0 && s * s > limit) continue;
    }
    const Vec3 n = normalizedOr(cross, Vec3::Zero());
    if (n.isZero()) continue;
    const Vec3 deepest = supportPoint(shape, pose, -n);
    const double depth = n.dot(a - deepest);  // how far the shape must move along n to clear the plane
    if (found && !(depth > out.depth || (depth == out.depth && c.triangle < out.triangle))) continue;
    if (!passesThrough(shape, pose, c, n, depth, confirm)) continue;
    found = true;
    out = planeContact(c, n, deepest, depth);
  }
  return found;
}

}  // namespace detail

namespace {

using detail::MeshDesc;
using detail::ShapeDesc;

const char* nodeTypeName(::fcl::NODE_TYPE t) {
  switch (t) {
    case ::fcl::BV_UNKNOWN: return "BV_UNKNOWN";
    case ::fcl::BV_AABB: return "BV_AABB";
    case ::fcl::BV_OBB: return "BV_OBB";
    case ::fcl::BV_RSS: return "BV_RSS";
    case ::fcl::BV_kIOS: return "BV_kIOS";
    case ::fcl::BV_OBBRSS: return "BV_OBBRSS";
    case ::fcl::BV_KDOP16: return "BV_KDOP16";
    case ::fcl::BV_KDOP18: return "BV_KDOP18";
    case ::fcl::BV_KDOP24: return "BV_KDOP24";
    case ::fcl::GEOM_BOX: return "GEOM_BOX";
    case ::fcl::GEOM_SPHERE: return "GEOM_SPHERE";
    case ::fcl::GEOM_ELLIPSOID: return "GEOM_ELLIPSOID";
    case ::fcl::GEOM_CAPSULE: return "GEOM_CAPSULE";
    case ::fcl::GEOM_CONE: return "GEOM_CONE";
    case ::fcl::GEOM_CYLINDER: return "GEOM_CYLINDER";
    case ::fcl::GEOM_CONVEX: return "GEOM_CONVEX";
    case ::fcl::GEOM_PLANE: return "GEOM_PLANE";
    case ::fcl::GEOM_HALFSPACE: return "GEOM_HALFSPACE";
    case ::fcl::GEOM_TRIANGLE: return "GEOM_TRIANGLE";
    case ::fcl::GEOM_OCTREE: return "GEOM_OCTREE";
    default: return "NODE_TYPE?";
  }
}

// A BVHModel of any BV FCL knows must be finished before FCL touches it
// (FCL reads its null node array otherwise).
Status checkAnyModel(const ::fcl::CollisionGeometryd* g, const char* what) {
  MeshDesc mesh;
  if (detail::describeMesh(g, mesh)) return detail::checkModel(mesh, what);
  if (g->getObjectType() != ::fcl::OT_BVH) return Status::ok();
  auto check = [what](const auto& m) -> Status {
    if (m.build_state != ::fcl::BVH_BUILD_STATE_PROCESSED && m.build_state != ::fcl::BVH_BUILD_STATE_UPDATED)
      return {ErrorCode::kMeshNotBuilt, std::string(what) + ": the BVHModel is not finished (endModel() not called)"};
    return Status::ok();
  };
  switch (g->getNodeType()) {
    case ::fcl::BV_KDOP16: return check(static_cast<const ::fcl::BVHModel<::fcl::KDOPd<16>>&>(*g));
    case ::fcl::BV_KDOP18: return check(static_cast<const ::fcl::BVHModel<::fcl::KDOPd<18>>&>(*g));
    case ::fcl::BV_KDOP24: return check(static_cast<const ::fcl::BVHModel<::fcl::KDOPd<24>>&>(*g));
    default: return Status::ok();
  }
}

// FCL 0.7's table of collision functions (CollisionFunctionMatrix's
// constructor, collision_func_matrix-inl.h), as rules: any two primitive
// shapes (box through halfspace in NODE_TYPE, so not GEOM_TRIANGLE); a BVH
// with a shape or with a BVH of its own BV type; an octree with a shape, a
// BVH or an octree, both ways, when FCL was built with octomap. Not the
// table itself: getCollisionFunctionLookTable's one instantiation holds
// every BVH-shape collider (~80 s of compiling per build, for one lookup).
// DropIn.SupportedPairsAreFcls compares every pair with fcl::collide.
bool fclCollides(::fcl::NODE_TYPE bvh_first, ::fcl::NODE_TYPE other) {
  const auto shape = [](::fcl::NODE_TYPE t) { return t >= ::fcl::GEOM_BOX && t <= ::fcl::GEOM_HALFSPACE; };
  const auto bvh = [](::fcl::NODE_TYPE t) { return t >= ::fcl::BV_AABB && t <= ::fcl::BV_KDOP24; };
  if (shape(bvh_first) && shape(other)) return true;
  if (bvh(bvh_first) && (shape(other) || other == bvh_first)) return true;
#if FCL_HAVE_OCTOMAP
  const auto octree = [](::fcl::NODE_TYPE t) { return t == ::fcl::GEOM_OCTREE; };
  if (octree(bvh_first) && (shape(other) || bvh(other) || octree(other))) return true;
  if (octree(other) && (shape(bvh_first) || bvh(bvh_first))) return true;
#endif
  return false;
}

// FCL 0.7's libccd solver (gjk_solver_libccd-inl.h) has closed forms for a
// plane or a halfspace against each primitive shape but a convex against a
// plane, and against a triangle given with its transform (the leaf tests of
// the oriented BVs: OBB, RSS, kIOS, OBBRSS), not one in the world frame (the
// generic leaf test of AABB and k-DOP models). The pairs it has none for go
// to libccd's MPR with the plane's support function, which FCL leaves null:
// a call through a null pointer as soon as the two (a leaf's box, for a
// model) overlap. GST_INDEP has no such hole. DropInBadInput.PairsFclCrashesOn
// shows each crash.
bool fclLibccdCrashes(::fcl::NODE_TYPE t1, ::fcl::NODE_TYPE t2) {
  const auto planar = [](::fcl::NODE_TYPE t) { return t == ::fcl::GEOM_PLANE || t == ::fcl::GEOM_HALFSPACE; };
  const auto generic_leaf = [](::fcl::NODE_TYPE t) {
    return t == ::fcl::BV_AABB || t == ::fcl::BV_KDOP16 || t == ::fcl::BV_KDOP18 || t == ::fcl::BV_KDOP24;
  };
  const auto one_way = [&](::fcl::NODE_TYPE a, ::fcl::NODE_TYPE b) {
    return planar(a) && (generic_leaf(b) || (a == ::fcl::GEOM_PLANE && b == ::fcl::GEOM_CONVEX));
  };
  return one_way(t1, t2) || one_way(t2, t1);
}

// A primitive with a NaN, infinite or negative size, a convex with a
// non-finite vertex, or a plane with a non-finite normal or offset:
// fcl::collide answers with non-finite contacts (a sphere of radius NaN
// against a box: a NaN normal and depth) or an answer for a shape that
// cannot exist (a sphere of radius -1 in contact with a box). Sizes of zero
// are FCL's to answer (a flat box), as every other forwarded input.
Status checkForwardedShape(const ::fcl::CollisionGeometryd* g, const char* what) {
  const auto sizes = [g, what](std::initializer_list<double> values) -> Status {
    for (const double v : values)
      if (!std::isfinite(v) || v < 0.0)
        return {ErrorCode::kInvalidShape, std::string(what) + ": a size of the " + nodeTypeName(g->getNodeType()) +
                                              " is NaN, infinite or negative: " + std::to_string(v)};
    return Status::ok();
  };
  const auto radiusAndLength = [&sizes](const auto& shape) { return sizes({shape.radius, shape.lz}); };
  const auto threeSizes = [&sizes](const Vec3& v) { return sizes({v.x(), v.y(), v.z()}); };
  const auto plane = [what](const Vec3& n, double d) -> Status {
    if (!n.allFinite() || !std::isfinite(d))
      return {ErrorCode::kInvalidShape, std::string(what) + ": the plane's normal or offset is not finite"};
    return Status::ok();
  };
  switch (g->getNodeType()) {
    case ::fcl::GEOM_SPHERE: return sizes({static_cast<const ::fcl::Sphered&>(*g).radius});
    case ::fcl::GEOM_CAPSULE: return radiusAndLength(static_cast<const ::fcl::Capsuled&>(*g));
    case ::fcl::GEOM_CYLINDER: return radiusAndLength(static_cast<const ::fcl::Cylinderd&>(*g));
    case ::fcl::GEOM_CONE: return radiusAndLength(static_cast<const ::fcl::Coned&>(*g));
    case ::fcl::GEOM_BOX: return threeSizes(static_cast<const ::fcl::Boxd&>(*g).side);
    case ::fcl::GEOM_ELLIPSOID: return threeSizes(static_cast<const ::fcl::Ellipsoidd&>(*g).radii);
    case ::fcl::GEOM_CONVEX: {
      const auto& vertices = static_cast<const ::fcl::Convexd&>(*g).getVertices();
      for (std::size_t i = 0; i < vertices.size(); ++i)
        if (!vertices[i].allFinite())
          return {ErrorCode::kInvalidShape,
                  std::string(what) + ": convex vertex " + std::to_string(i) + " is not finite"};
      return Status::ok();
    }
    case ::fcl::GEOM_PLANE: {
      const auto& p = static_cast<const ::fcl::Planed&>(*g);
      return plane(p.n, p.d);
    }
    case ::fcl::GEOM_HALFSPACE: {
      const auto& h = static_cast<const ::fcl::Halfspaced&>(*g);
      return plane(h.n, h.d);
    }
    default: return Status::ok();
  }
}

}  // namespace

// fcl::collide prints to stderr and returns 0 for pairs it cannot handle,
// crashes on a few (above), reads a null node array for an unfinished
// model, and answers with NaNs for a shape of NaN size (above).
Status detail::forward(const ::fcl::CollisionObjectd* o1, const ::fcl::CollisionObjectd* o2,
                       const ::fcl::CollisionRequestd& request, ::fcl::CollisionResultd& result, Report& report) {
  report.route = Report::Route::kForwarded;
  const ::fcl::CollisionGeometryd* g1 = o1->collisionGeometry().get();
  const ::fcl::CollisionGeometryd* g2 = o2->collisionGeometry().get();
  Status s = checkAnyModel(g1, "o1");
  if (!s) return s;
  s = checkAnyModel(g2, "o2");
  if (!s) return s;
  s = checkForwardedShape(g1, "o1");
  if (!s) return s;
  s = checkForwardedShape(g2, "o2");
  if (!s) return s;
  if (!o1->getTransform().matrix().allFinite() || !o2->getTransform().matrix().allFinite())
    return {ErrorCode::kInvalidPose, "a transform has a non-finite entry"};
  ::fcl::NODE_TYPE t1 = g1->getNodeType(), t2 = g2->getNodeType();
  // fcl::collide looks (BVH, shape) pairs up with the BVH first.
  if (g1->getObjectType() == ::fcl::OT_GEOM && g2->getObjectType() == ::fcl::OT_BVH) std::swap(t1, t2);
  if (!fclCollides(t1, t2))
    return {ErrorCode::kInvalidShape, std::string("FCL has no collision function for ") + nodeTypeName(t1) +
                                          " vs " + nodeTypeName(t2)};
  if (request.gjk_solver_type == ::fcl::GST_LIBCCD && fclLibccdCrashes(t1, t2))
    return {ErrorCode::kInvalidShape, std::string("fcl::collide crashes on ") + nodeTypeName(t1) + " vs " +
                                          nodeTypeName(t2) +
                                          " with GST_LIBCCD (FCL 0.7 asks libccd for a plane's or a "
                                          "halfspace's support point, which it does not define); use GST_INDEP, "
                                          "or for a model an OBB, RSS, kIOS or OBBRSS hierarchy"};
  const std::size_t before = result.numContacts();
  ::fcl::collide(o1, o2, request, result);
  report.added = result.numContacts() - before;
  return Status::ok();
}

Status collide(const ::fcl::CollisionObjectd* o1, const ::fcl::CollisionObjectd* o2,
               const ::fcl::CollisionRequestd& request, ::fcl::CollisionResultd& result, const Options& options,
               Scratch& scratch, Report* report) {
  Report local_report;
  Report& rep = report ? *report : local_report;
  rep = Report();
  if (o1 == nullptr || o2 == nullptr) return {ErrorCode::kInvalidShape, "a CollisionObject is null"};
  const ::fcl::CollisionGeometryd* g1 = o1->collisionGeometry().get();
  const ::fcl::CollisionGeometryd* g2 = o2->collisionGeometry().get();
  if (g1 == nullptr || g2 == nullptr) return {ErrorCode::kInvalidShape, "a CollisionObject has no geometry"};
  if (request.num_max_contacts == 0)
    return {ErrorCode::kInvalidSettings, "request.num_max_contacts is 0 (no contact could be returned)"};
  const double cd = options.settings.contact_distance;
  if (!std::isfinite(cd) || cd < 0.0)
    return {ErrorCode::kInvalidSettings, "contact_distance must be finite and >= 0, got " + detail::describeValue(cd)};
  const KeyMode key_mode = options.settings.key_mode;
  if (key_mode != KeyMode::kAuto && key_mode != KeyMode::kVertexIndex && key_mode != KeyMode::kVertexPosition)
    return {ErrorCode::kInvalidSettings, "settings.key_mode " + std::to_string(static_cast<int>(key_mode)) +
                                             " is none of kAuto, kVertexIndex, kVertexPosition"};

  MeshDesc mesh;
  ShapeDesc shape;
  bool mesh_first = true;
  if (!detail::classifyPair(g1, g2, mesh, shape, mesh_first)) return detail::forward(o1, o2, request, result, rep);
  // Cost sources are FCL's own output: let FCL compute them.
  if (request.enable_cost) return detail::forward(o1, o2, request, result, rep);

  const ::fcl::CollisionObjectd& mesh_object = mesh_first ? *o1 : *o2;
  const ::fcl::CollisionObjectd& shape_object = mesh_first ? *o2 : *o1;
  Pose mesh_pose, shape_in_model;
  Status s = detail::checkPair(mesh, mesh_object, shape_object, mesh_first ? "o1" : "o2", mesh_first ? "o2" : "o1",
                               mesh_pose, shape_in_model);
  if (!s) return s;
  const std::size_t have = result.numContacts();
  if (have >= request.num_max_contacts) return Status::ok();  // as fcl::collide: already satisfied

  Scratch::Impl& sc = scratch.impl();
  sc.candidates.clear();
  sc.contacts.clear();
  detail::QueryVolume volume = detail::makeQueryVolume(shape, shape_in_model, cd);
  const TriangleMesh* compact = options.cache ? options.cache->impl().find(mesh) : nullptr;
  const std::size_t room = request.num_max_contacts - have;
  // Collision checking: a boolean request wanting one contact stops at the
  // first triangle in contact. For a sphere, capsule or box, one candidate
  // at a time gives a contact exactly when the whole query would give some
  // (the filter never voids the first patch it processes). A support shape's
  // whole query picks one shrink scale for all its triangles, so a deep pose
  // can differ before the pass-through fallback below; with it, the
  // in-collision answers agree (tests/fcl/fcl_boolean_test.cpp).
  const bool checking = !request.enable_contact && room == 1 && options.settings.trace == nullptr;

  // The per-candidate test of collision checking. Only a triangle whose
  // plane the shape reaches (within the contact distance) can be in contact.
  // Support shapes (cylinder, cone, ellipsoid, convex) go through the core's
  // ConvexContactProbe: the per-query setup (validation, bounds) once, then
  // per triangle the answer of that triangle's own query, without building
  // its contacts. The walk visits the candidates nearest the shape first
  // (the answer is whether any candidate gives a contact: the order does not
  // change it).
  struct Checker final : detail::LeafVisitor {
    Checker(const ShapeDesc& shape_, const Pose& pose_, const Options& options_, Scratch::Impl& sc_, double cd_,
            const ConvexContactProbe* probe_, const ::fcl::CollisionRequestd& request_)
        : shape(shape_), pose(pose_), options(options_), sc(sc_), cd(cd_), probe(probe_), request(request_) {}
    const ShapeDesc& shape;
    const Pose& pose;
    const Options& options;
    Scratch::Impl& sc;
    double cd;
    const ConvexContactProbe* probe;
    const ::fcl::CollisionRequestd& request;
    Status status;
    bool hit = false;
    bool through = false;  // the hit is the pass-through fallback's (see below)
    Contact found;  // a support shape's hit, or the fallback's (see below)
    bool visit(const CandidateTriangle& c) override {
      // The walk keeps every triangle its volume reaches (model.cpp): a
      // vertex edited to NaN or Inf after endModel() is an error here, as
      // the candidates' stage (checkCandidates) makes it for contacts.
      // Beyond +-1e50 too, as checkCandidates: there the triangle's normal
      // overflowed to Inf, normalizedOr gave zero, and the triangle was
      // skipped as degenerate (a sphere on a model at 1e300: "no
      // collision", no error).
      for (int k = 0; k < 3; ++k)
        if (!(inRange(c.vertices[k].x()) && inRange(c.vertices[k].y()) && inRange(c.vertices[k].z()))) {
          status = {ErrorCode::kNonFiniteVertex, "triangle " + std::to_string(c.triangle) + " corner " +
                                                     std::to_string(k) +
                                                     " has a non-finite vertex or one beyond +-1e50"};
          return true;
        }
      const Vec3 n = normalizedOr((c.vertices[1] - c.vertices[0]).cross(c.vertices[2] - c.vertices[0]), Vec3::Zero());
      if (n.isZero()) return false;
      const Vec3 lowest = detail::supportPoint(shape, pose, -n);
      const double depth = n.dot(c.vertices[0] - lowest);
      if (depth < -cd) return false;
      // The shape's origin (a primitive's centre) behind the triangle's
      // plane: the triangle's own one-sided query (reference §4a) nearly
      // never has a contact (2.4% of such probes on fcl_bench's convex
      // path), and with the shape sunk into a floor every candidate was
      // queried (a support shape's probe through all its deep passes) and
      // missed before the pass-through fallback asked its two-sided test. That
      // test, for this triangle, is asked first here. It answers only where
      // the fallback's own test holds, a pose the old order also found in
      // collision, so the in-collision answer is unchanged; it is reached
      // at the first overlapping triangle, as fcl::collide reaches it.
      if (n.dot(pose.translation - c.vertices[0]) < 0.0 && detail::passesThrough(shape, pose, c, n, depth, &request)) {
        found = detail::planeContact(c, n, lowest, depth);
        hit = through = true;
        return true;
      }
      if (probe) {
        // Whether the triangle's own query has a contact, without computing
        // it (GJK to convergence is most of its cost): FCL reports no
        // geometry for enable_contact false, and the contact added is the
        // triangle's plane contact (its face normal, the shape's deepest
        // point along it, the depth that clears the plane), as the fallback
        // builds. probe->check() would give the exact one.
        status = probe->touches(c, hit);
        if (status && hit) found = detail::planeContact(c, n, lowest, depth);
        return !status || hit;
      }
      status = detail::collideCandidates(shape, pose, &c, 1, options.settings, sc.query, sc.contacts);
      hit = status && !sc.contacts.empty();
      return !status || hit;
    }
  };
  detail::SupportStorage storage;
  const SupportShape* support = checking ? detail::supportShape(shape, storage) : nullptr;
  ConvexContactProbe probe;
  if (checking) {
    // The shape, pose and settings are checked even with no triangle near.
    if (support)
      s = probe.prepare(*support, shape_in_model, options.settings);
    else
      s = detail::collideCandidates(shape, shape_in_model, nullptr, 0, options.settings, sc.query, sc.contacts);
    if (!s) return s;
  }
  Checker checker(shape, shape_in_model, options, sc, cd, support ? &probe : nullptr, request);

  if (checking && !volume.ball_only) {
    // Collision checking needs only the triangles the shape may touch: those
    // within the contact distance of its (sharp) box, so within the box's
    // bounding ball, a smaller one than the axis-aligned bounds' (the walk's
    // first test). Slack: the tolerance of FCL's GJK in the fallback's
    // overlap test (below), absolute.
    const double slack = std::max(request.gjk_tolerance, 0.0) + 1e-6 * shape.size;
    volume.radius = std::min(volume.radius, volume.half.norm() + slack);
    // The shape's own ball about its frame's origin, when smaller still: a
    // cylinder's or a prism's (sqrt(r^2 + h^2) against its box's
    // sqrt(2 r^2 + h^2)). Fewer nodes and candidates to visit when nothing
    // is in contact, where the check visits them all.
    const double own = shape.bound + cd + slack;
    if (own < volume.radius) {
      volume.center = shape_in_model.translation;
      volume.radius = own;
    }
  }

  // Every branch leaves index keys; by_position: whether the filter also
  // matches positions (KeyMode::kVertexPosition on index keys, query.h).
  bool by_position = false;
  if (compact) {
    // The compact copy of the hierarchy (the ModelCache's TriangleMesh).
    if (checking) {
      // The triangles near the ball (tightened above) one at a time, nearest
      // the query's centre first, as the walk of FCL's tree below: the first
      // in contact ends the check, most of the hierarchy unvisited.
      // Gathering them all first cost the whole walk, and along a path made
      // checking with a cache slower than without one.
      struct CompactVisitor final : TriangleVisitor {
        CompactVisitor(const TriangleMesh& m, Checker& c, std::vector<CandidateTriangle>& o)
            : mesh(m), checker(c), out(o) {}
        const TriangleMesh& mesh;
        Checker& checker;
        std::vector<CandidateTriangle>& out;
        bool visit(std::uint32_t t) override {
          const std::uint32_t* tri = mesh.triangle(t);
          CandidateTriangle& c = out.emplace_back();
          c.mesh = 0;
          c.triangle = t;
          for (int k = 0; k < 3; ++k) {
            c.vertices[k] = mesh.vertex(tri[k]);
            c.keys[k] = tri[k];  // one candidate per query (Checker::visit): keys compare nothing
          }
          return checker.visit(c);
        }
      };
      CompactVisitor visitor(*compact, checker, sc.candidates);
      compact->visitNearSphere(volume.center, volume.radius, visitor, sc.stack);
    } else {
      // The core's own midphase, on the query volume's bounds; for a sphere
      // only the triangles near the ball, as the walk of FCL's tree below
      // keeps. Index keys, and the filter matches positions where the
      // core's rule for this model asks for position keys (below): the same
      // verdicts, without hashing every corner.
      const MeshInstance instance{compact, Pose::identity()};
      by_position = resolveKeyMode(&instance, 1, key_mode) == KeyMode::kVertexPosition;
      if (volume.ball_only)
        s = gatherCandidatesNearSphere(&instance, 1, Sphere{volume.center, volume.radius}, KeyMode::kVertexIndex,
                                       sc.query, sc.candidates);
      else
        s = gatherCandidates(&instance, 1, volume.lo, volume.hi, KeyMode::kVertexIndex, sc.query, sc.candidates);
      if (!s) return s;
    }
  } else {
    s = detail::gatherModel(mesh, volume, Pose::identity(), 0, sc.stack, sc.candidates, checking ? &checker : nullptr);
    if (!s) return s;
    // The walk leaves each corner's vertex index in its key. Vertex identity
    // by position unless the caller asked for index keys: an FCL model may
    // duplicate its vertices (an STL file's, pieces appended), and the walk
    // in place cannot tell (kAuto). The filter matches positions itself
    // (KeyMode::kVertexPosition on index keys, query.h): cheaper than
    // assignPositionKeysFromIndices, which hashes every corner. The
    // narrowphase checks the corners either way.
    by_position = key_mode != KeyMode::kVertexIndex;
  }
  if (checking) {
    if (!checker.status) return checker.status;
    // A support shape's hit, or the fallback's reached early: its plane
    // contact (otherwise the other shapes left their one-candidate query's
    // contacts in sc.contacts).
    if (support || checker.through) {
      sc.contacts.clear();
      if (checker.hit) sc.contacts.push_back(checker.found);
    }
  } else {
    QuerySettings settings = options.settings;
    settings.key_mode = by_position ? KeyMode::kVertexPosition : KeyMode::kVertexIndex;
    // A support shape's deep passes gather their own, wider candidates
    // (convex.h, CandidateSource): the same hierarchy on their box, with
    // the same index keys.
    struct SameHierarchy final : CandidateSource {
      const detail::MeshDesc& mesh;
      const TriangleMesh* compact;
      Scratch::Impl& sc;
      SameHierarchy(const detail::MeshDesc& m, const TriangleMesh* c, Scratch::Impl& s) : mesh(m), compact(c), sc(s) {}
      Status gather(const Vec3& lo, const Vec3& hi, std::vector<CandidateTriangle>& out) override {
        out.clear();
        if (compact) {
          const MeshInstance instance{compact, Pose::identity()};
          return gatherCandidates(&instance, 1, lo, hi, KeyMode::kVertexIndex, sc.query, out);
        }
        return detail::gatherModel(mesh, detail::boxQueryVolume(lo, hi), Pose::identity(), 0, sc.stack, out);
      }
    } deeper(mesh, compact, sc);
    s = detail::collideCandidates(shape, shape_in_model, sc.candidates.data(), sc.candidates.size(), settings,
                                  sc.query, sc.contacts, CandidateCoverage::kComplete, &deeper);
    if (!s) return s;
  }
  rep.candidates = sc.candidates.size();
  // A hit of the fallback's test, reached early (Checker::visit): the
  // fallback's contact, not the pipeline's.
  rep.contacts = checker.through ? 0 : sc.contacts.size();
  rep.through_contacts = checker.through ? 1 : 0;
  if (sc.contacts.empty() && !sc.candidates.empty()) {
    // Collision checking takes the first overlapping candidate in the order
    // the check visited them (nearest the shape first): the walk's order.
    Contact through;
    if (detail::throughContact(shape, shape_in_model, sc.candidates.data(), sc.candidates.size(), &request, through,
                               checking)) {
      sc.contacts.push_back(through);
      rep.through_contacts = 1;
    }
  }

  const ::fcl::CollisionGeometryd* mesh_geometry = mesh.geometry;
  detail::convertContacts(sc.contacts, mesh_pose, mesh_first, &mesh_geometry, shape.geometry, room, sc.order, sc.out);
  for (const ::fcl::Contactd& c : sc.out) result.addContact(c);
  rep.added = sc.out.size();
  return Status::ok();
}

Scratch& detail::threadScratch() {
  thread_local Scratch scratch;
  return scratch;
}

namespace {

Status& threadStatus() {
  thread_local Status status;
  return status;
}

}  // namespace

std::size_t collide(const ::fcl::CollisionObjectd* o1, const ::fcl::CollisionObjectd* o2,
                    const ::fcl::CollisionRequestd& request, ::fcl::CollisionResultd& result) {
  static const Options kDefaults;
  threadStatus() = collide(o1, o2, request, result, kDefaults, detail::threadScratch());
  return result.numContacts();
}

const Status& lastStatus() { return threadStatus(); }

}  // namespace meshcontact::fcl
