// The midphase stage (gatherCandidates) and the sphere narrowphase.
#include "meshcontact/query.h"

#include "meshcontact/filter.h"
#include "closest_point.h"
#include "gather.h"
#include "meshcontact/triangle.h"
#include "scaled_edges.h"
#include "scratch.h"
#include "validate.h"
#include "voided_features.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <type_traits>

namespace meshcontact {

QueryScratch::QueryScratch() : impl_(std::make_unique<Impl>()) {}
QueryScratch::~QueryScratch() = default;
QueryScratch::QueryScratch(QueryScratch&&) noexcept = default;
QueryScratch& QueryScratch::operator=(QueryScratch&&) noexcept = default;

KeyMode resolveKeyMode(const MeshInstance* instances, std::size_t count, KeyMode requested) {
  if (requested != KeyMode::kAuto) return requested;
  if (count == 1 && instances != nullptr && instances[0].mesh && !instances[0].mesh->hasDuplicateVertices())
    return KeyMode::kVertexIndex;
  return KeyMode::kVertexPosition;
}

namespace {

// An oriented box (query frame) that prunes a midphase query.
struct OrientedBox {
  Pose pose;
  Vec3 half_extents;
};

// gatherCandidates, optionally pruned by a bounding sphere of the shape
// (`bound`, query frame; the box [lo, hi] must contain it): leaves whose box
// is farther than its radius are dropped (TriangleMesh::querySphere); or by
// an oriented box (`box_bound`, likewise): leaves whose box its faces
// separate are dropped (TriangleMesh::queryOrientedBox). With `identity`
// non-null (the pipelines' own midphase), position keys are left to the
// filter: the keys are index keys whatever the mode, and *identity says
// whether the filter must match positions too (detail::VertexIdentity).
Status gather(const MeshInstance* instances, std::size_t count, const Vec3& lo, const Vec3& hi, const Sphere* bound,
              const OrientedBox* box_bound, KeyMode key_mode, QueryScratch& scratch,
              std::vector<CandidateTriangle>& out, detail::VertexIdentity* identity) {
  out.clear();
  if (identity) *identity = detail::VertexIdentity::kKeys;
  if (instances == nullptr && count > 0)
    return {ErrorCode::kMeshNotBuilt, "instances is null with count " + std::to_string(count)};
  if (!detail::isKeyMode(key_mode)) return detail::keyModeError(key_mode);
  if (!detail::inRange(lo) || !detail::inRange(hi) || (lo.array() > hi.array()).any())
    return {ErrorCode::kInvalidShape, "query box " + detail::describe(lo) + " - " + detail::describe(hi) +
                                          " is not finite, reaches beyond +-1e50, or has lo > hi"};
  KeyMode mode = resolveKeyMode(instances, count, key_mode);
  // Meshes with different poses meet at positions that round-off may have
  // set apart: their corners are welded (weldCorners) after the walk. The
  // pipelines' keys are index keys anyway (`identity`); for the callers that
  // take position keys from here, candidates are gathered with index keys
  // when the poses differ, and position keys made after the weld (below).
  const KeyMode resolved = mode;
  bool weld = resolved == KeyMode::kVertexPosition && identity != nullptr;
  if (resolved == KeyMode::kVertexPosition && !identity)
    for (std::size_t m = 1; m < count && !weld; ++m)
      weld = !(instances[m].pose.rotation == instances[0].pose.rotation &&
               instances[m].pose.translation == instances[0].pose.translation);
  if (weld) {
    if (identity) *identity = detail::VertexIdentity::kKeysOrPositions;
    mode = KeyMode::kVertexIndex;
  }
  // Whether two meshes that give candidates have different poses (only
  // those are welded: 16 tiles of one pose cost no weld). Two unposed ones
  // are compared by the flag alone (on 16 tiles, the comparison of whole
  // poses cost 1.5% of a sphere query).
  const Pose* first_pose = nullptr;
  bool first_unposed = false, poses_differ = false;
  QueryScratch::Impl& sc = scratch.impl();
  const Vec3 centre = 0.5 * (lo + hi);
  const Vec3 half = 0.5 * (hi - lo);

  bool first_position = true;
  for (std::size_t m = 0; m < count; ++m) {
    if (instances[m].mesh == nullptr || !instances[m].mesh->isBuilt()) {
      out.clear();
      return {ErrorCode::kMeshNotBuilt, "mesh instance " + std::to_string(m) + " is null or not built"};
    }
    const TriangleMesh& mesh = *instances[m].mesh;
    const Pose& pose = instances[m].pose;
    const bool unposed = pose.isIdentity();
    if (!unposed) {  // the identity pose is valid: no matrix check
      // The name is built only on failure: no string (and no allocation) per query.
      Status s = detail::checkPose(pose, "mesh instance");
      if (!s) {
        out.clear();
        return {s.code(), s.message() + " (instance " + std::to_string(m) + ")"};
      }
    }
    // The query box in the mesh frame: the bounds of the rotated box.
    Vec3 local_lo = lo, local_hi = hi;
    if (!unposed) {
      const Vec3 c = pose.applyInverse(centre);
      const Vec3 h = pose.rotation.transpose().cwiseAbs() * half;
      local_lo = c - h;
      local_hi = c + h;
    }
    // A mesh the box misses is skipped before the walk and its setup (on 16
    // tiles, most instances of every query).
    const Vec3& mesh_lo = mesh.boundsLo();
    const Vec3& mesh_hi = mesh.boundsHi();
    // One branch, not six (| on ints): whether a tile is missed changes from
    // one instance to the next; short-circuit tests measured ~5% slower on
    // the tiles.
    const int missed = static_cast<int>(local_lo.x() > mesh_hi.x()) | static_cast<int>(local_lo.y() > mesh_hi.y()) |
                       static_cast<int>(local_lo.z() > mesh_hi.z()) | static_cast<int>(local_hi.x() < mesh_lo.x()) |
                       static_cast<int>(local_hi.y() < mesh_lo.y()) | static_cast<int>(local_hi.z() < mesh_lo.z());
    if (missed) continue;
    sc.hits.clear();
    if (bound)
      mesh.querySphere(unposed ? bound->center : pose.applyInverse(bound->center), bound->radius, sc.hits,
                       sc.walk_queue);
    else if (box_bound && unposed)
      mesh.queryOrientedBox(local_lo, local_hi, box_bound->pose, box_bound->half_extents, sc.hits, sc.walk_queue);
    else if (box_bound)
      // The box in the mesh's frame (translations subtracted first), inflated
      // by 1e-8 of both translations: the leaf test's own margin scales with
      // mesh-frame magnitudes, but the narrowphase sees the corners moved
      // into the query frame, rounded on the scale of the instance's
      // translation, and a rotation validation accepts 1e-9 off orthonormal
      // is not quite inverted by its transpose.
      mesh.queryOrientedBox(
          local_lo, local_hi,
          {pose.rotation.transpose() * box_bound->pose.rotation, pose.applyInverse(box_bound->pose.translation)},
          box_bound->half_extents +
              Vec3::Constant(1e-8 * (pose.translation.cwiseAbs().sum() +
                                     box_bound->pose.translation.cwiseAbs().sum())),
          sc.hits, sc.walk_queue);
    else
      mesh.queryBox(local_lo, local_hi, sc.hits, sc.walk_queue);
    if (sc.hits.empty()) continue;
    if (weld) {
      if (!first_pose) {
        first_pose = &pose;
        first_unposed = unposed;
      } else if (!poses_differ && !(unposed && first_unposed)) {
        poses_differ = !(pose.rotation == first_pose->rotation && pose.translation == first_pose->translation);
      }
    }
    if (mode == KeyMode::kVertexPosition && first_position) {
      // Upper bound on distinct positions of this query: 3 per triangle of
      // this instance; the map grows if later instances add more.
      sc.positions.reset(3 * sc.hits.size());
      first_position = false;
    }
    // Appended one by one after a reserve: resize() would zero every
    // candidate first (value-initialisation), only for all of it to be
    // overwritten here.
    out.reserve(out.size() + sc.hits.size());
    const std::uint64_t mesh_bits = static_cast<std::uint64_t>(m) << 32;
    // This instance's tag in the vertex-key cache (scratch.h).
    const std::uint64_t generation = mode == KeyMode::kVertexPosition ? sc.nextVertexKeyGeneration() : 0;
    // One instantiation per case (pose applied or not, position or index
    // keys): the per-vertex work branches only on the key cache.
    const auto append = [&](auto moved, auto by_position) {
      for (const std::uint32_t t : sc.hits) {
        const std::uint32_t* tri = mesh.triangle(t);
        CandidateTriangle& c = out.emplace_back();
        c.mesh = static_cast<std::uint32_t>(m);
        c.triangle = t;
        for (int k = 0; k < 3; ++k) {
          if constexpr (decltype(moved)::value) {
            c.vertices[k] = pose.apply(mesh.vertex(tri[k]));
          } else {
            c.vertices[k] = mesh.vertex(tri[k]);
          }
          if constexpr (decltype(by_position)::value) {
            // Equal indices of one instance are equal positions: a vertex
            // seen by an earlier candidate of this instance reuses its key.
            sc.vertexPositionKey(generation, tri[k], c.vertices[k], c.keys[k]);
          } else {
            c.keys[k] = mesh_bits | tri[k];
          }
        }
      }
    };
    using Yes = std::true_type;
    using No = std::false_type;
    const bool by_position = mode == KeyMode::kVertexPosition;
    if (unposed) {
      if (by_position) append(No{}, Yes{});
      else append(No{}, No{});
    } else {
      if (by_position) append(Yes{}, Yes{});
      else append(Yes{}, No{});
    }
  }
  if (poses_differ) {
    // The weld's scale: the largest |translation| + |vertex| of the meshes
    // queried (all of them: which gave candidates is not kept, and a larger
    // scale only widens a tolerance of 1e-12 of it).
    double weld_scale = 0.0;
    for (std::size_t m = 0; m < count; ++m) {
      const TriangleMesh& mesh = *instances[m].mesh;
      const double reach = std::max(mesh.boundsLo().cwiseAbs().maxCoeff(), mesh.boundsHi().cwiseAbs().maxCoeff());
      weld_scale = std::max(weld_scale, instances[m].pose.translation.cwiseAbs().maxCoeff() + reach);
    }
    Status s = weldCorners(out.data(), out.size(), kWeldRoundOff * weld_scale, scratch);
    if (!s) {
      out.clear();
      return s;
    }
  }
  // Position keys after the weld, for the callers that take them from here
  // (the pipelines' filter compares positions itself).
  if (weld && !identity) {
    sc.positions.reset(3 * out.size());
    for (CandidateTriangle& c : out)
      for (int k = 0; k < 3; ++k) c.keys[k] = sc.positionKeyOf(c.vertices[k]);
  }
  return Status::ok();
}

}  // namespace

Status gatherCandidates(const MeshInstance* instances, std::size_t count, const Vec3& lo, const Vec3& hi,
                        KeyMode key_mode, QueryScratch& scratch, std::vector<CandidateTriangle>& out) {
  return gather(instances, count, lo, hi, nullptr, nullptr, key_mode, scratch, out, nullptr);
}

Status detail::gatherCandidatesNearBox(const MeshInstance* instances, std::size_t count, const Vec3& lo,
                                       const Vec3& hi, const Pose& box_pose, const Vec3& half_extents,
                                       KeyMode key_mode, QueryScratch& scratch, std::vector<CandidateTriangle>& out) {
  const OrientedBox box{box_pose, half_extents};
  return gather(instances, count, lo, hi, nullptr, &box, key_mode, scratch, out, nullptr);
}

Status detail::gatherForFilter(const MeshInstance* instances, std::size_t count, const Vec3& lo, const Vec3& hi,
                               KeyMode key_mode, QueryScratch& scratch, std::vector<CandidateTriangle>& out,
                               VertexIdentity& identity) {
  return gather(instances, count, lo, hi, nullptr, nullptr, key_mode, scratch, out, &identity);
}

Status detail::gatherNearBoxForFilter(const MeshInstance* instances, std::size_t count, const Vec3& lo,
                                      const Vec3& hi, const Pose& box_pose, const Vec3& half_extents,
                                      KeyMode key_mode, QueryScratch& scratch, std::vector<CandidateTriangle>& out,
                                      VertexIdentity& identity) {
  const OrientedBox box{box_pose, half_extents};
  return gather(instances, count, lo, hi, nullptr, &box, key_mode, scratch, out, &identity);
}

namespace {

Status checkSphere(const Sphere& sphere) {
  if (!detail::inRange(sphere.center))
    return {ErrorCode::kInvalidShape,
            "sphere centre is not finite or beyond +-1e50: " + detail::describe(sphere.center)};
  if (!inRange(sphere.radius) || sphere.radius < 0.0)
    return {ErrorCode::kInvalidShape,
            "sphere radius must be finite, >= 0 and <= 1e50, got " + detail::describe(sphere.radius)};
  return Status::ok();
}

// Sphere vs one triangle (reference §4a): one-sided, closest point + feature,
// distance test against the inflated radius.
struct SphereNarrowphase {
  Vec3 center;
  double radius;
  double inflated;  // radius + contact distance
  /// The candidates come from TriangleMesh::querySphere, which has already
  /// tested each triangle's box (rounded outward) against this sphere: the
  /// box reject below would pass all of them again.
  bool boxes_tested = false;
  /// inflated^2 (1 - 2^-40): a squared distance below it is surely within
  /// reach (see below). 0, so that the exact tests always decide, when
  /// inflated^2 would be subnormal, where the margin means nothing.
  double reach2_below = 0.0;
  double inflated2 = 0.0;

  SphereNarrowphase(const Vec3& c, double r, double contact_distance, bool tested)
      : center(c), radius(r), inflated(r + contact_distance), boxes_tested(tested) {
    inflated2 = inflated * inflated;
    if (inflated >= 0x1p-500) reach2_below = inflated2 * (1.0 - 0x1p-40);
  }

  // Edge and vertex contacts (most candidates on a floor; nearly all of them
  // voided by the filter) are deferred: the filter ranks them by squared
  // distance and finish() computes the square root, normal, point and depth
  // for the few it keeps (detail::generateContacts, "deferred"). Until then
  // the patch holds the squared distance in `distance`, the scaled offset
  // from the feature to the centre in points[0] and the scale in depths[0].
  // Ranking by d^2 s^2 (exact: s is a power of two) orders the patches as
  // their distances sqrt(d^2) s do, except that two squared distances which
  // round to one distance are no longer a tie.
  static constexpr bool kDefersEdgesAndVertices = true;

  void finish(const CandidateTriangle& t, detail::Patch& p) const {
    const Vec3 d = p.points[0];
    const double scale = p.depths[0];
    const double length = d.norm();
    const double distance = length * scale;
    // §4b: if the centre is on the feature, fall back to the face normal.
    // "On" is relative to the scene's scale, not an absolute epsilon.
    const double tiny = 1e-12 * std::max(radius, scale);
    if (distance > tiny) {
      p.normal = d / length;
    } else {
      const detail::ScaledEdges edges = detail::scaledEdges(t.vertices[0], t.vertices[1], t.vertices[2]);
      p.normal = edges.unitNormal();
    }
    p.distance = distance;
    p.points[0] = center - radius * p.normal;
    p.depths[0] = radius - distance;
  }

  detail::PatchOutcome operator()(const CandidateTriangle& t, detail::Patch& p) const {
    const Vec3& a = t.vertices[0];
    if (!boxes_tested) {
      // Cheap reject (Ericson 5.2.5, sphere vs AABB): the midphase's box test
      // passes triangles whose box only overlaps a corner of the sphere's box
      // (half the candidates on a flat floor). Squared distance from the
      // centre to the triangle's box, against the inflated radius.
      const Vec3& b = t.vertices[1];
      const Vec3& c = t.vertices[2];
      double d2 = 0.0;
      for (int k = 0; k < 3; ++k) {
        const double lo = std::min(a[k], std::min(b[k], c[k]));
        const double hi = std::max(a[k], std::max(b[k], c[k]));
        const double e = std::max(0.0, std::max(lo - center[k], center[k] - hi));
        d2 += e * e;
      }
      if (d2 > inflated * inflated) {
        p.distance = std::sqrt(d2);  // a lower bound of the distance (trace only)
        return detail::PatchOutcome::kBeyondContactDistance;
      }
    }
    // Work relative to vertex a, scaled to the triangle's size (scaled_edges.h):
    // the result does not depend on where the triangle sits. The degenerate
    // test is the one the mesh build applies.
    const detail::ScaledEdges edges = detail::scaledEdges(a, t.vertices[1], t.vertices[2]);
    if (edges.degenerate) {
      p.distance = (center - a).norm();
      return detail::PatchOutcome::kDegenerate;
    }
    // Not degenerate: |ab x ac|^2 > 1e-24 * longest^4 >= 1e-24, and the
    // scaled components are below 2, so the length is normal and finite.
    // The plane tests screen with s = (ab x ac) . rel = height * |ab x ac|
    // and s^2 against inflated^2 |ab x ac|^2, not with the unit normal: most
    // candidates are edge or vertex contacts that never need it, and its
    // square root and divisions sat on every candidate's critical path.
    // The screen decides alone only where it is sure of the height that the
    // unit normal gives (the test before this screen): s and that height
    // are both within ~2^-51 sum|cross_i rel_i| (/ |cross|) of their exact
    // values, so a margin of 2^-40 of that sum, not of |s| (which cancels),
    // covers them. Near the plane or the reach, the exact tests on the
    // height decide as before (a face touching exactly at the reach), and
    // a centre within rounding of the plane that the screen lets through
    // counts as in front of it, at distance 0.
    const Vec3& cross = edges.cross;
    const double cross2 = edges.cross2;
    const Vec3 rel = center - a;
    const double sx = cross.x() * rel.x(), sy = cross.y() * rel.y(), sz = cross.z() * rel.z();
    const double s = sx + sy + sz;
    const double margin = 0x1p-40 * (std::abs(sx) + std::abs(sy) + std::abs(sz));
    if (s < -margin) {  // centre behind the plane
      p.distance = -s / std::sqrt(cross2);
      return detail::PatchOutcome::kBackFacing;
    }
    const double below = s - margin;
    if (below > 0.0 && below * below > inflated2 * cross2 * (1.0 + 0x1p-40)) {  // the plane is too far (fig. 1)
      p.distance = s / std::sqrt(cross2);
      return detail::PatchOutcome::kBeyondContactDistance;
    }
    if (s < 0.0 || s * s > inflated2 * cross2) {
      const double height = edges.unitNormal().dot(rel);
      if (height < 0.0) {
        p.distance = -height;
        return detail::PatchOutcome::kBackFacing;
      }
      if (height > inflated) {
        p.distance = height;
        return detail::PatchOutcome::kBeyondContactDistance;
      }
    }
    const Vec3 rel_scaled = rel * edges.inv_scale;  // exact
    Vec3 closest;
    p.feature = detail::closestPointInline(rel_scaled, Vec3::Zero(), edges.ab, edges.ac, closest);
    if (p.feature.type != FeatureType::kFace) {
      // In the triangle's scale, where |d| neither overflows nor underflows
      // for any sphere within reach of a non-degenerate triangle.
      const Vec3 d = rel_scaled - closest;
      const double d2 = d.squaredNorm();
      const double key = d2 * edges.scale * edges.scale;
      // Surely within reach: d^2 s^2 < inflated^2 (1 - 2^-40) puts the
      // rounded distance below `inflated` whatever the roundings (each is
      // within 2^-52; the margin also covers a compiler that contracts the
      // squared norm differently). Otherwise (near the limit, beyond it, not
      // finite, or inflated too small for the margin) the exact test on the
      // rounded distance decides, as finish() would compute it. The key is
      // d^2 s^2 exactly unless it underflows (a distance below ~1e-154):
      // then it still orders below every distance in the normal range.
      if (!(key < reach2_below)) {
        const double distance = std::sqrt(d2) * edges.scale;
        p.distance = distance;
        if (!std::isfinite(distance)) return detail::PatchOutcome::kDegenerate;  // unreachable within kMaxCoordinate
        if (distance > inflated) return detail::PatchOutcome::kBeyondContactDistance;
      }
      p.distance = key;
      p.count = 1;
      p.points[0] = d;
      p.depths[0] = edges.scale;
      return detail::PatchOutcome::kContact;
    }
    const Vec3 n = edges.unitNormal();
    const double height = n.dot(rel);  // the distance, exact for the face region
    if (!std::isfinite(height)) return detail::PatchOutcome::kDegenerate;  // unreachable within kMaxCoordinate
    // s >= 0 was tested on the unnormalised normal: clamp a rounding below zero.
    const double distance = std::max(0.0, height);
    p.normal = n;
    p.distance = distance;
    if (distance > inflated) return detail::PatchOutcome::kBeyondContactDistance;
    p.count = 1;
    p.points[0] = center - radius * p.normal;
    p.depths[0] = radius - distance;
    return detail::PatchOutcome::kContact;
  }
};

}  // namespace

namespace {

void sphereContacts(const Sphere& sphere, const CandidateTriangle* candidates, std::size_t count, bool boxes_tested,
                    const QuerySettings& settings, detail::VertexIdentity identity, QueryScratch& scratch,
                    std::vector<Contact>& contacts) {
  const SphereNarrowphase narrowphase(sphere.center, sphere.radius, settings.contact_distance, boxes_tested);
  detail::generateContacts(candidates, count, narrowphase, settings, identity, scratch.impl().filter, contacts);
}

}  // namespace

Status gatherCandidatesNearSphere(const MeshInstance* instances, std::size_t count, const Sphere& bound,
                                  KeyMode key_mode, QueryScratch& scratch, std::vector<CandidateTriangle>& out) {
  out.clear();
  const Status s = checkSphere(bound);
  if (!s) return s;
  const Vec3 extent = Vec3::Constant(bound.radius);
  return gather(instances, count, bound.center - extent, bound.center + extent, &bound, nullptr, key_mode, scratch, out,
                nullptr);
}

Status collideSphereCandidates(const Sphere& sphere, const CandidateTriangle* candidates, std::size_t count,
                               const QuerySettings& settings, QueryScratch& scratch,
                               std::vector<Contact>& contacts) {
  contacts.clear();
  if (settings.trace) settings.trace->clear();
  Status s = checkSphere(sphere);
  if (!s) return s;
  s = detail::checkQuerySettings(settings);
  if (!s) return s;
  s = detail::checkCandidates(candidates, count);
  if (!s) return s;
  sphereContacts(sphere, candidates, count, false, settings, detail::candidateIdentity(settings), scratch, contacts);
  return Status::ok();
}

Status collideSphere(const MeshInstance* instances, std::size_t count, const Sphere& sphere,
                     const QuerySettings& settings, QueryScratch& scratch, std::vector<Contact>& contacts) {
  contacts.clear();
  if (settings.trace) settings.trace->clear();
  Status s = checkSphere(sphere);
  if (!s) return s;
  s = detail::checkQuerySettings(settings);
  if (!s) return s;
  const double reach = sphere.radius + settings.contact_distance;
  const Vec3 extent = Vec3::Constant(reach);
  QueryScratch::Impl& sc = scratch.impl();
  const Sphere bound{sphere.center, reach};
  detail::VertexIdentity identity;
  s = gather(instances, count, sphere.center - extent, sphere.center + extent, &bound, nullptr, settings.key_mode, scratch,
             sc.candidates, &identity);
  if (!s) return s;
  sphereContacts(sphere, sc.candidates.data(), sc.candidates.size(), true, settings, identity, scratch, contacts);
  return Status::ok();
}

Status collideSphere(const TriangleMesh& mesh, const Sphere& sphere, const QuerySettings& settings,
                     QueryScratch& scratch, std::vector<Contact>& contacts) {
  const MeshInstance instance{&mesh, Pose::identity()};
  return collideSphere(&instance, 1, sphere, settings, scratch, contacts);
}

}  // namespace meshcontact
