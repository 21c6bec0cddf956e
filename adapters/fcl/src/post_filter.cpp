// postFilter(): FCL's raw mesh-vs-shape contacts, made consistent (signs,
// features) and run through the core's voided-features filter.
#include "internal.h"

#include <meshcontact/triangle.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>

namespace meshcontact::fcl {

namespace {

using detail::MeshDesc;
using detail::ShapeDesc;

// The raw contact's triangle, with its vertices in the model frame.
// Returns false (and an error) when the contact is not of this pair or
// names a triangle the model does not have.
// FCL collides an AABB model through a temporary copy (its BVHShapeCollider
// moves the copy's vertices to the world frame, keeping the triangles'
// order, and deletes it on return): such a contact names the copy, a freed
// address, on the mesh's side. There only the shape's side is matched.
Status rawTriangle(const ::fcl::Contactd& rc, std::size_t i, const MeshDesc& mesh, const ShapeDesc& shape,
                   CandidateTriangle& c, bool& contact_mesh_first) {
  const bool copied = mesh.bv == detail::BvKind::kAABB;
  if ((rc.o1 == mesh.geometry || (copied && rc.o1 != shape.geometry)) && rc.o2 == shape.geometry)
    contact_mesh_first = true;
  else if (rc.o1 == shape.geometry && (rc.o2 == mesh.geometry || (copied && rc.o2 != shape.geometry)))
    contact_mesh_first = false;
  else
    return {ErrorCode::kInvalidSettings, "raw contact " + std::to_string(i) + " belongs to another pair of geometries"};
  const intptr_t t = contact_mesh_first ? rc.b1 : rc.b2;
  const ::fcl::Vector3d* vertices = detail::modelVertices(mesh);
  const ::fcl::Triangle* triangles = detail::modelTriangles(mesh);
  const auto vertex_count = static_cast<std::size_t>(detail::modelVertexCount(mesh));
  if (t < 0 || t >= detail::modelTriangleCount(mesh))
    return {ErrorCode::kIndexOutOfRange, "raw contact " + std::to_string(i) + " names triangle " + std::to_string(t) +
                                             ", which the model does not have"};
  c.mesh = 0;
  c.triangle = static_cast<std::uint32_t>(t);
  for (int k = 0; k < 3; ++k) {
    const std::size_t v = triangles[t][k];
    if (v >= vertex_count)
      return {ErrorCode::kIndexOutOfRange, "triangle " + std::to_string(t) + " references vertex " + std::to_string(v) +
                                               " of a model with " + std::to_string(vertex_count) + " vertices"};
    c.vertices[k] = vertices[v];
    c.keys[k] = v;  // the vertex index, for assignPositionKeysFromIndices
  }
  return Status::ok();
}

}  // namespace

Status postFilter(const ::fcl::CollisionObjectd* o1, const ::fcl::CollisionObjectd* o2,
                  const ::fcl::CollisionRequestd& request, const ::fcl::CollisionResultd& raw,
                  ::fcl::CollisionResultd& cleaned, const Options& options, Scratch& scratch, Report* report) {
  Report local_report;
  Report& rep = report ? *report : local_report;
  rep = Report();
  cleaned.clear();
  if (o1 == nullptr || o2 == nullptr) return {ErrorCode::kInvalidShape, "a CollisionObject is null"};
  const ::fcl::CollisionGeometryd* g1 = o1->collisionGeometry().get();
  const ::fcl::CollisionGeometryd* g2 = o2->collisionGeometry().get();
  if (g1 == nullptr || g2 == nullptr) return {ErrorCode::kInvalidShape, "a CollisionObject has no geometry"};
  if (request.num_max_contacts == 0) return {ErrorCode::kInvalidSettings, "request.num_max_contacts is 0"};
  if (!std::isfinite(options.face_tolerance) || !(options.face_tolerance > 0.0))
    return {ErrorCode::kInvalidSettings, "face_tolerance must be finite and > 0"};
  if (options.post_filter != PostFilterMode::kRecompute && options.post_filter != PostFilterMode::kClassifyFcl)
    return {ErrorCode::kInvalidSettings, "post_filter " + std::to_string(static_cast<int>(options.post_filter)) +
                                             " is neither PostFilterMode::kRecompute nor kClassifyFcl"};

  MeshDesc mesh;
  ShapeDesc shape;
  bool mesh_first = true;
  if (!detail::classifyPair(g1, g2, mesh, shape, mesh_first)) {
    return {ErrorCode::kInvalidShape,
            "postFilter needs a BVHModel (AABB, OBB, RSS, kIOS, OBBRSS) and a sphere, capsule, box, cylinder, "
            "cone, ellipsoid or convex"};
  }
  const ::fcl::CollisionObjectd& mesh_object = mesh_first ? *o1 : *o2;
  const ::fcl::CollisionObjectd& shape_object = mesh_first ? *o2 : *o1;
  Pose mesh_pose, shape_in_model;
  Status s = detail::checkPair(mesh, mesh_object, shape_object, mesh_first ? "o1" : "o2", mesh_first ? "o2" : "o1",
                               mesh_pose, shape_in_model);
  if (!s) return s;
  if (raw.numContacts() == 0) return Status::ok();
  if (!request.enable_contact)
    return {ErrorCode::kInvalidSettings,
            "the raw contacts carry no geometry: call fcl::collide with request.enable_contact = true"};

  const Pose world_to_model = mesh_pose.inverse();
  const bool sphere = shape.kind == detail::ShapeKind::kSphere;
  const bool classify = options.post_filter == PostFilterMode::kClassifyFcl;
  // FCL's sign conventions (DESIGN.md §4): the sphere-triangle routine, which
  // both solvers share, returns the depth negated; GST_INDEP's EPA returns
  // the normal and the depth negated for every other shape.
  const bool depth_negated = sphere || request.gjk_solver_type == ::fcl::GST_INDEP;
  const bool normal_negated = !sphere && request.gjk_solver_type == ::fcl::GST_INDEP;

  Scratch::Impl& sc = scratch.impl();
  sc.candidates.clear();
  sc.patches.clear();
  for (std::size_t i = 0; i < raw.numContacts(); ++i) {
    const ::fcl::Contactd& rc = raw.getContact(i);
    CandidateTriangle c;
    bool contact_mesh_first = true;
    s = rawTriangle(rc, i, mesh, shape, c, contact_mesh_first);
    if (!s) return s;
    if (isDegenerateTriangle(c.vertices[0], c.vertices[1], c.vertices[2])) continue;  // no normal, no feature
    // Checked in both modes (fcl.h): kRecompute does not read the raw
    // geometry, but a NaN in FCL's result is a broken input all the same.
    if (!rc.normal.allFinite() || !std::isfinite(rc.penetration_depth) || !rc.pos.allFinite())
      return {ErrorCode::kInvalidSettings, "raw contact " + std::to_string(i) + " is not finite"};
    TrianglePatch p;
    if (classify) {
      // FCL's normal and depth, from the mesh toward the shape, depth > 0.
      Vec3 n = normal_negated ? Vec3(-rc.normal) : rc.normal;
      const double depth = depth_negated ? -rc.penetration_depth : rc.penetration_depth;
      if (!contact_mesh_first) n = -n;
      const Vec3 face =
          normalizedOr((c.vertices[1] - c.vertices[0]).cross(c.vertices[2] - c.vertices[0]), Vec3::UnitZ());
      n = normalizedOr(world_to_model.rotation * n, face);
      // One-sided (reference §4a): a normal toward the triangle's back would
      // push the shape through it; the fallback below handles a shape that
      // only has such contacts.
      if (n.dot(face) < 0.0) continue;
      // The feature is the triangle's support feature along the normal
      // (DESIGN.md §3); a face contact has the face's normal.
      p.feature = supportFeature(c.vertices[0], c.vertices[1], c.vertices[2], n, options.face_tolerance);
      if (p.feature.type == FeatureType::kFace) n = face;
      p.normal = n;
      p.distance = -depth;
      p.count = 1;
      p.points[0] = world_to_model.apply(rc.pos);
      p.depths[0] = depth;
    }
    sc.candidates.push_back(c);
    sc.patches.push_back(p);
  }

  // One patch per triangle (a raw result may name one twice): the deepest
  // (patch distances are only set with kClassifyFcl; otherwise the first).
  const std::size_t n_raw = sc.candidates.size();
  sc.order.resize(n_raw);
  std::iota(sc.order.begin(), sc.order.end(), 0u);
  std::sort(sc.order.begin(), sc.order.end(), [&](std::uint32_t a, std::uint32_t b) {
    if (sc.candidates[a].triangle != sc.candidates[b].triangle)
      return sc.candidates[a].triangle < sc.candidates[b].triangle;
    if (sc.patches[a].distance != sc.patches[b].distance) return sc.patches[a].distance < sc.patches[b].distance;
    return a < b;
  });
  sc.gathered.clear();
  sc.gathered_patches.clear();
  for (const std::uint32_t i : sc.order) {
    if (!sc.gathered.empty() && sc.gathered.back().triangle == sc.candidates[i].triangle) continue;
    sc.gathered.push_back(sc.candidates[i]);
    sc.gathered_patches.push_back(sc.patches[i]);
  }
  rep.candidates = sc.gathered.size();
  s = assignPositionKeysFromIndices(sc.gathered.data(), sc.gathered.size(), sc.query);
  if (!s) return s;

  if (classify) {
    s = filterPatches(sc.gathered.data(), sc.gathered_patches.data(), sc.gathered.size(), shape.size,
                      options.settings, sc.query, sc.contacts);
  } else {
    // meshcontact's narrowphase (and filter) on exactly the triangles FCL
    // named: some of those the shape touches (GST_INDEP names one of the
    // two a box's corner sinks into).
    s = detail::collideCandidates(shape, shape_in_model, sc.gathered.data(), sc.gathered.size(), options.settings,
                                  sc.query, sc.contacts, CandidateCoverage::kPartial);
  }
  if (!s) return s;
  rep.contacts = sc.contacts.size();

  if (sc.contacts.empty()) {
    // FCL reported a collision that the one-sided contacts do not show: the
    // same fallback as collide(), over every triangle FCL named (FCL has
    // already found them overlapping: not asked again, its boolean and
    // contact answers can disagree).
    sc.candidates.clear();
    for (std::size_t i = 0; i < raw.numContacts(); ++i) {
      CandidateTriangle c;
      bool contact_mesh_first = true;
      s = rawTriangle(raw.getContact(i), i, mesh, shape, c, contact_mesh_first);
      if (!s) return s;
      if (!isDegenerateTriangle(c.vertices[0], c.vertices[1], c.vertices[2])) sc.candidates.push_back(c);
    }
    Contact through;
    if (detail::throughContact(shape, shape_in_model, sc.candidates.data(), sc.candidates.size(), nullptr, through)) {
      sc.contacts.push_back(through);
      rep.through_contacts = 1;
    }
  }

  const ::fcl::CollisionGeometryd* mesh_geometry = mesh.geometry;
  detail::convertContacts(sc.contacts, mesh_pose, mesh_first, &mesh_geometry, shape.geometry,
                          request.num_max_contacts, sc.order, sc.out);
  for (const ::fcl::Contactd& c : sc.out) cleaned.addContact(c);
  rep.added = sc.out.size();
  return Status::ok();
}

Status postFilter(const ::fcl::CollisionObjectd* o1, const ::fcl::CollisionObjectd* o2,
                  const ::fcl::CollisionRequestd& request, const ::fcl::CollisionResultd& raw,
                  ::fcl::CollisionResultd& cleaned) {
  static const Options kDefaults;
  return postFilter(o1, o2, request, raw, cleaned, kDefaults, detail::threadScratch());
}

}  // namespace meshcontact::fcl
