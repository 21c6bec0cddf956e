// Capsule vs mesh: the capsule's core segment against each triangle in closed
// form, then the voided-features filter and the manifold reduction.
//
// Per triangle (a, b, c), unit normal n, core P(t) = P0 + t (P1 - P0),
// height h(t) = n.(P(t) - a), reach = radius + contact distance:
//  1. One-sided (reference §4a applied to the core): the triangle is culled
//     when both ends are strictly behind the plane (h0 < 0 and h1 < 0); for
//     a zero-length capsule this is the sphere's rule. Only the front part
//     of the core (h >= 0) is used for closest features, so every normal has
//     n.normal >= 0 and never pulls the capsule through the triangle's back.
//  2. Closest features (Ericson §5.1.9): the front core's distance to the
//     triangle is the smaller of (i) its lowest height over the triangle's
//     prism (the part of the core whose projection falls inside the
//     triangle: the face region) and (ii) its distance to each edge
//     (segment-segment; the edges' ends cover the vertex regions). Ties go
//     to the face, whose normal is then valid.
//  3. Face region: normal n, points where the whole core enters and leaves
//     the prism (one point if that piece is a point), each kept when within
//     reach, the deeper always: a capsule lying along a face gets 2 points.
//     Depths are r - h and may exceed r when the core crossed the plane
//     inside the triangle (it then has to move that far along n).
//     Feature: the face (the support feature along n).
//  4. Edge / vertex region: normal = normalize(core point - triangle point)
//     (the face normal when they coincide), depth r - d. Feature: where the
//     triangle's closest point lies when separated; the triangle's support
//     feature along the normal when penetrating (DESIGN.md §3). A core
//     running along the edge also gets the ends of that line contact (see
//     operator()). When the core's front piece over the face is also within
//     reach, the points of 3. ride along as the patch's face part, which
//     the filter keeps whether or not it voids the edge / vertex: the
//     core's part over this face is a face contact of its own (a capsule is
//     a swept sphere, and each of those spheres has the face as its closest
//     feature).
#include "meshcontact/mesh.h"
#include "meshcontact/shapes.h"
#include "meshcontact/triangle.h"

#include "capsule_segment.h"
#include "gather.h"
#include "manifold_reduction.h"
#include "scaled_edges.h"
#include "scratch.h"
#include "validate.h"
#include "voided_features.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace meshcontact {

namespace {

Status checkCapsule(const Capsule& capsule, const Pose& pose) {
  if (!inRange(capsule.radius) || capsule.radius < 0.0)
    return {ErrorCode::kInvalidShape,
            "capsule radius must be finite, >= 0 and <= 1e50, got " + detail::describe(capsule.radius)};
  if (!inRange(capsule.half_length) || capsule.half_length < 0.0)
    return {ErrorCode::kInvalidShape,
            "capsule half_length must be finite, >= 0 and <= 1e50, got " + detail::describe(capsule.half_length)};
  return detail::checkPose(pose, "capsule pose");
}

// Shrinks [lo, hi] to where the linear function f(t) = f0 + t (f1 - f0) >= 0.
void clipInterval(double f0, double f1, double& lo, double& hi) {
  if (f0 >= 0.0 && f1 >= 0.0) return;
  if (f0 < 0.0 && f1 < 0.0) {
    lo = 1.0, hi = 0.0;  // empty
    return;
  }
  const double t = f0 / (f0 - f1);  // the sign change, in [0, 1]
  if (f0 < 0.0)
    lo = std::max(lo, t);
  else
    hi = std::min(hi, t);
}

struct CapsuleNarrowphase {
  Vec3 p0, p1;     // core ends, query frame
  double radius;
  double reach;    // radius + contact distance
  double scale;    // radius + half_length: the capsule's size, for tolerances
  double cos_manifold;  // cos(settings.manifold_angle_deg): one contact plane (see the edge patch)
  double coordinates;   // the core ends' largest |coordinate| (the edge planes' rounding)

  detail::PatchOutcome operator()(const CandidateTriangle& tri, detail::Patch& patch) const {
    using detail::PatchOutcome;
    const Vec3* v = tri.vertices;
    const detail::ScaledEdges scaled = detail::scaledEdges(v[0], v[1], v[2]);  // the build's test, at any scale
    if (scaled.degenerate) {
      patch.distance = (0.5 * (p0 + p1) - v[0]).norm();
      return PatchOutcome::kDegenerate;
    }
    const Vec3 n = scaled.unitNormal();
    const double h0 = n.dot(p0 - v[0]), h1 = n.dot(p1 - v[0]);
    if (h0 < 0.0 && h1 < 0.0) {
      patch.distance = -std::max(h0, h1);
      return PatchOutcome::kBackFacing;
    }
    if (std::min(h0, h1) > reach) {  // the plane alone is too far
      patch.distance = std::min(h0, h1);
      return PatchOutcome::kBeyondContactDistance;
    }
    const Vec3 dir = p1 - p0;
    const auto height = [&](double t) { return h0 + t * (h1 - h0); };

    // Front part of the core, [s0, s1]: where h >= 0.
    double s0 = 0.0, s1 = 1.0;
    clipInterval(h0, h1, s0, s1);
    // The core's piece over the triangle, [q0, q1]: inside the three
    // inward-facing edge planes m_k = n x (v_k+1 - v_k) (counter-clockwise).
    // A core end within rounding of an edge plane counts as on it (inside):
    // a core lying over an edge (an internal diagonal under a capsule laid
    // along it) has both ends' values at rounding noise of either sign, and
    // clipping at their ratio would cut the piece at an arbitrary point, or
    // away, on both triangles of the edge (one core end left unsupported).
    // The noise bound: the ends are rounded on the scale of their
    // coordinates, n and m within a few ulps, the dot products over
    // |m| |p - v_k|; 2^-40 of |m|_1 (|p0 - v_k|_1 + |p1 - v_k|_1 + the
    // coordinates) covers them, and is far below any distance that matters
    // to a contact. One bound serves the three edges: every component of an
    // edge is below 4 scale (scaled_edges.h), so |m|_1 < 21 scale and
    // |v_k - v_0|_1 < 6 scale.
    // Computed once per triangle, and only for one whose edge planes cut
    // the core (the tolerance decides nothing where both ends are inside).
    double noise = -1.0;
    double q0 = 0.0, q1 = 1.0;
    for (int k = 0; k < 3 && q0 <= q1; ++k) {
      const Vec3 m = n.cross(v[(k + 1) % 3] - v[k]);
      double e0 = m.dot(p0 - v[k]), e1 = m.dot(p1 - v[k]);
      if (e0 < 0.0 || e1 < 0.0) {
        if (noise < 0.0)
          noise = 0x1p-40 * 32.0 * scaled.scale *
                  ((p0 - v[0]).cwiseAbs().sum() + (p1 - v[0]).cwiseAbs().sum() + 12.0 * scaled.scale + coordinates);
        if (std::abs(e0) <= noise) e0 = 0.0;
        if (std::abs(e1) <= noise) e1 = 0.0;
      }
      clipInterval(e0, e1, q0, q1);
    }
    const double f0 = std::max(q0, s0), f1 = std::min(q1, s1);  // front piece over the face
    const double face_distance =
        f0 <= f1 ? std::max(0.0, std::min(height(f0), height(f1))) : std::numeric_limits<double>::infinity();

    // Distance from the front core to the edges (and, at their ends, vertices).
    const Vec3 front0 = p0 + s0 * dir, front1 = p0 + s1 * dir;
    detail::SegmentPair best;
    int best_edge = -1;
    for (int k = 0; k < 3; ++k) {
      const detail::SegmentPair pair = detail::closestSegmentSegment(front0, front1, v[k], v[(k + 1) % 3]);
      if (best_edge < 0 || pair.distance2 < best.distance2) best = pair, best_edge = k;
    }

    // The face owns the contact when its distance ties with the edges'
    // (to a relative 1e-9): then the core's lowest point over the face lies
    // above an edge, where both give the face normal, and a face patch voids
    // the neighbours' edge patches instead of being voided by them.
    // Ends of the whole core's piece over the face, deeper first; the second
    // one when the piece has a length (|tb - ta|: after the swap tb < ta,
    // and a signed test dropped the second end whenever the core's P1 end
    // was the lower one) and that end is within reach.
    const auto facePoints = [&](Vec3* points, double* depths) {
      double ta = q0, tb = q1;
      if (height(tb) < height(ta)) std::swap(ta, tb);
      int count = 0;
      for (const double t : {ta, tb}) {
        if (count == 1 && (std::abs(tb - ta) * dir.norm() <= 1e-9 * scale || height(t) > reach)) break;
        points[count] = p0 + t * dir - radius * n;
        depths[count] = radius - height(t);
        ++count;
      }
      return count;
    };
    if (face_distance <= std::sqrt(best.distance2) + 1e-9 * scale) {
      patch.distance = face_distance;
      if (face_distance > reach) return PatchOutcome::kBeyondContactDistance;
      patch.feature = Feature::face();
      patch.normal = n;
      patch.count = facePoints(patch.points, patch.depths);
      return PatchOutcome::kContact;
    }
    // The edge (or vertex) is closer, yet the core's front part also passes
    // over the face within reach: that part is a face contact of its own,
    // which the filter keeps even when it voids the edge patch
    // (voided_features.h). Over a flat tessellated floor a tilted core's
    // closest point to every triangle but the one under its lower end lies
    // on the edge toward that end, closer than the face by only
    // ~h theta^2 cot^2(phi) / 2 (height h, tilt theta, edge at phi to the
    // core), and that edge is voided by the neighbour: without the face part
    // a core tilted by 1e-4 rad kept only its piece over one triangle, its
    // upper end unsupported.
    if (face_distance <= reach) {
      patch.face_normal = n;
      patch.face_count = facePoints(patch.face_points, patch.face_depths);
    }

    // The closest pair again, the same way on every triangle that finds it
    // (it is the patch's distance, the filter's sort key): two triangles
    // sharing the edge walk it in opposite directions, and those around a
    // vertex reach it through their own edges, each rounded its own way, so
    // the frame's round-off chose which of the tied triangles ranked first
    // and kept its patch (whose line along its edge differs): capsules near
    // the sine terrains of
    // SurfaceInvariance.TurningTheWholeSceneKeepsTheContacts, at 20,000
    // placements, changed contacts at 16 of 30,231 touching ones when the
    // scene was turned (5 now). Now the edge from its lexicographically
    // smaller end, and a vertex by itself (the front core against the
    // vertex): the pairs tie exactly where the front cores agree, and the
    // (mesh, triangle) order breaks the tie in every frame. Once per
    // triangle within reach, for the pair found: +1.5-1.8% instructions per
    // capsule query (callgrind, fcl_bench's Core capsule poses), where
    // walking all three edges that way cost 7.5% of the time.
    if (best.distance2 <= reach * reach) {
      const int k = best_edge;
      const Vec3& a = v[k];
      const Vec3& b = v[(k + 1) % 3];
      if (best.t <= 0.0 || best.t >= 1.0) {
        const double t = best.t <= 0.0 ? 0.0 : 1.0;  // which end: the feature
        const Vec3& vertex = t == 0.0 ? a : b;
        best = detail::closestSegmentSegment(front0, front1, vertex, vertex);
        best.t = t;
      } else if (std::lexicographical_compare(b.data(), b.data() + 3, a.data(), a.data() + 3)) {
        best = detail::closestSegmentSegment(front0, front1, b, a);
        best.t = 1.0 - best.t;  // along v_k -> v_k+1, as before
      }
    }
    const double d = std::sqrt(best.distance2);
    patch.distance = d;
    if (d > reach) return PatchOutcome::kBeyondContactDistance;
    // §4b: on the feature itself the direction is undefined: the face normal.
    const double tiny = 1e-12 * std::max(scale, scaled.longestEdge());
    patch.normal = d > tiny ? normalizedOr(best.p - best.q, n) : n;
    patch.count = 1;
    patch.points[0] = best.p - radius * patch.normal;
    patch.depths[0] = radius - d;
    // A core running along the edge (a capsule lying along a ridge, or
    // along a table's edge) touches it along a line, as a core lying on a
    // face does (3.): the closest pair alone gives one point of it
    // (anywhere along the line when the two are parallel), and a capsule
    // held at one point of its length pivots about it. The line's ends are
    // the ends of the core's piece over the edge (the part that projects
    // onto the edge between its vertices); each is a point of the patch
    // when within reach and in the same contact plane, its direction from
    // the edge within the manifold angle of the normal (a core crossing the
    // edge has its piece's ends far off that direction). Its depth is r
    // minus its own distance.
    {
      const int k = best_edge;
      const Vec3 e = v[(k + 1) % 3] - v[k];
      const double e2 = e.squaredNorm();
      // [g0, g1], on the front part: where 0 <= (P(s) - v_k) . e <= |e|^2.
      const double a0 = (front0 - v[k]).dot(e), a1 = (front1 - v[k]).dot(e);
      double g0 = 0.0, g1 = 1.0;
      clipInterval(a0, a1, g0, g1);
      clipInterval(e2 - a0, e2 - a1, g0, g1);
      const double apart = 1e-9 * scale / ((s1 - s0) * dir.norm());  // a parameter step that is a length
      for (const double g : {g0, g1}) {
        if (g0 > g1 || !(std::abs(g - best.s) > apart) || (g == g1 && !(g1 - g0 > apart))) continue;
        const Vec3 end = front0 + g * (front1 - front0);
        const double u = std::clamp((end - v[k]).dot(e) / e2, 0.0, 1.0);
        const Vec3 w = end - (v[k] + u * e);
        const double distance = w.norm();
        if (distance <= reach && w.dot(patch.normal) >= cos_manifold * distance) {
          patch.points[patch.count] = end - radius * patch.normal;
          patch.depths[patch.count] = radius - distance;
          ++patch.count;
        }
      }
    }
    if (patch.depths[0] > 0.0) {
      patch.feature = supportFeature(v[0], v[1], v[2], patch.normal);
    } else {
      const int k = best_edge;
      patch.feature = best.t <= 0.0 ? Feature::vertex(k)
                      : best.t >= 1.0 ? Feature::vertex((k + 1) % 3)
                                      : Feature::edge(k);
    }
    return PatchOutcome::kContact;
  }
};

CapsuleNarrowphase makeNarrowphase(const Capsule& capsule, const Pose& pose, const QuerySettings& settings) {
  const Vec3 axis = pose.rotation.col(2) * capsule.half_length;
  return {pose.translation - axis,
          pose.translation + axis,
          capsule.radius,
          capsule.radius + settings.contact_distance,
          capsule.radius + capsule.half_length,
          std::cos(settings.manifold_angle_deg * (M_PI / 180.0)),
          std::max((pose.translation - axis).cwiseAbs().maxCoeff(), (pose.translation + axis).cwiseAbs().maxCoeff())};
}

Status checkQuery(const Capsule& capsule, const Pose& pose, const QuerySettings& settings) {
  Status s = checkCapsule(capsule, pose);
  if (!s) return s;
  s = detail::checkQuerySettings(settings);
  if (!s) return s;
  return detail::checkManifoldSettings(settings);
}

}  // namespace

Status collideCapsuleCandidates(const Capsule& capsule, const Pose& pose, const CandidateTriangle* candidates,
                                std::size_t count, const QuerySettings& settings, QueryScratch& scratch,
                                std::vector<Contact>& contacts) {
  contacts.clear();
  if (settings.trace) settings.trace->clear();
  Status s = checkQuery(capsule, pose, settings);
  if (!s) return s;
  s = detail::checkCandidates(candidates, count);
  if (!s) return s;
  detail::manifoldContacts(makeNarrowphase(capsule, pose, settings), candidates, count, settings,
                           detail::candidateIdentity(settings), scratch, contacts);
  return Status::ok();
}

Status collideCapsule(const MeshInstance* instances, std::size_t count, const Capsule& capsule, const Pose& pose,
                      const QuerySettings& settings, QueryScratch& scratch, std::vector<Contact>& contacts) {
  contacts.clear();
  if (settings.trace) settings.trace->clear();
  Status s = checkQuery(capsule, pose, settings);
  if (!s) return s;
  const CapsuleNarrowphase np = makeNarrowphase(capsule, pose, settings);
  const Vec3 reach = Vec3::Constant(np.reach);
  QueryScratch::Impl& sc = scratch.impl();
  detail::VertexIdentity identity;
  s = detail::gatherForFilter(instances, count, np.p0.cwiseMin(np.p1) - reach, np.p0.cwiseMax(np.p1) + reach,
                              settings.key_mode, scratch, sc.candidates, identity);
  if (!s) return s;
  // Checked once above, not again per stage.
  detail::manifoldContacts(np, sc.candidates.data(), sc.candidates.size(), settings, identity, scratch, contacts);
  return Status::ok();
}

Status collideCapsule(const TriangleMesh& mesh, const Capsule& capsule, const Pose& pose,
                      const QuerySettings& settings, QueryScratch& scratch, std::vector<Contact>& contacts) {
  const MeshInstance instance{&mesh, Pose::identity()};
  return collideCapsule(&instance, 1, capsule, pose, settings, scratch, contacts);
}

}  // namespace meshcontact
