// Box vs mesh: per triangle, the triangle feature that OWNS the contact (the
// box's analogue of the sphere's closest feature, reference §4a), then the
// voided-features filter and the manifold reduction.
//
// Per triangle, in the box's frame (box = [-e, e], centre at the origin,
// triangle v0 v1 v2, unit normal n, edges E_k = v_k+1 - v_k, inward edge
// normals m_k = n x E_k; the triangle's prism is where m_k.(x - v_k) >= 0):
//  1. One-sided, the sphere's rule applied to the box's core: the triangle is
//     culled when the box's centre is behind its plane (to round-off). A box
//     beside a cliff's wall whose centre is below the ledge is never pushed
//     up onto the ledge, whatever its corners touch.
//  2. Separating axes (Ericson §4.4, Gottschalk's OBB test adapted to a
//     triangle): the box's face normals u_i (first: the cheapest rejection),
//     n, and the crosses u_i x E_k. An axis separating by more than the
//     contact distance: no contact. Any separating (or touching) axis: the
//     box and the triangle are disjoint (step 3); none: they intersect
//     (steps 4-5). SAT is exact for this test.
//  3. Apart: the EXACT closest points of the two polytopes, the closest of
//     the vertex-face, face-vertex and edge-edge pairs (a closest pair of two
//     disjoint convex polytopes always contains one of these): the box's
//     corners against the triangle (Ericson §5.1.5, which also tells face /
//     edge k / vertex k), the triangle's vertices against the box (clamping),
//     and the box's 12 edges against the triangle's 3 (Ericson §5.1.9; the
//     triangle's feature is its edge, or an end vertex when the parameter is
//     clamped). Pruned, exactly: the box's closest point is the clamp of the
//     triangle's, so a box face x_i = -e_i (+e_i) can hold it only when some
//     vertex has x_i <= -e_i (>= e_i); the triangle's closest point is inside
//     edge k only when the box reaches outside that edge's inward plane; a
//     feature whose height over the plane exceeds the best distance so far
//     cannot beat it. Ties (to 1e-9 of the box's size) go to the face, then
//     an edge, then a vertex; a pair along n is a face pair (the box point
//     lies over the closed triangle). That feature is the patch's, exactly as
//     the sphere's closest point's (reference §4), and the distance its key.
//     Face: normal n, the box's face most anti-parallel to n clipped to the
//     prism, plus the box's closest point; depth = -(height above the plane).
//     Edge / vertex: normal = normalize(box point - triangle point); one
//     point, or, when that direction is a box face's normal (a box face
//     parallel to the triangle's edge or facing its vertex), the triangle
//     clipped to that face's side planes (a line contact gets 2 points).
//     An edge or vertex pair along n (to 3 degrees: the box's face nearly
//     level, held up elsewhere) offers its face patch, the incident face
//     clipped to the prism at its distances, in its place: written when
//     the patch is kept, or voided by a face contact in the same plane.
//  4. Intersecting, ownership: s = the box's deepest point below the plane,
//     the average of the lowest corners when several tie (a box lying flat:
//     its bottom face's centre). When s projects onto the closed triangle
//     (to round-off), the triangle owns the contact: a face patch, normal n,
//     depth = s's depth (the push along n that clears the plane), points
//     from the incident face clipped to the prism. Tiles of a plane agree on
//     the owner, whose face contact voids the internal edges near the box's
//     deepest point. (Closed, not strict: s exactly on an internal edge makes
//     both neighbours owners, both with the plane's normal, where a strict
//     test would leave the edge to step 5 on both sides.) Unless one of step
//     5's tilted axes needs less push (by step 5's bias): then the owner's
//     patch is step 5's, ranked by s's depth (so first), with the face patch
//     as its stand-in (below). A box tilted by 1e-4 rad beside a plate's
//     edge, its deepest corner under the plate: the owner's face contact
//     pushed it up onto the plate by its whole depth below it.
//  5. Intersecting, not owned: the separating axis of least penetration
//     among directions with N.n >= -sin 15 degrees (kSidewaysDip: no normal
//     pulls the box through the triangle's back, while a box's side face
//     tilted by a little still counts as sideways). Ties and near-ties
//     prefer the triangle normal, then the box faces, then the edges: a
//     later axis must beat the current one by 5% of |pen| plus 1e-6 of the
//     box's size (Box2D's reference-face bias, Gregorius' "Robust Contact
//     Creation"). For n the penetration is its exact directional depth (the
//     box's deepest point over the triangle, not the SAT overlap). When
//     that point lies inside the prism and the candidates are only some of
//     the triangles the box touches (CandidateCoverage::kPartial: another
//     engine's contact list), the bias is 50% (kPartialCoverageFaceBias):
//     the filter's plane test (below) can tell where the surface goes on
//     only from the triangles it is given. A lone triangle under a box's
//     corner, its neighbours missing from FCL's list, looked like a plate
//     of one triangle, and a side face's axis pushed the box off it
//     sideways (43 degrees off the floor's normal). With every triangle
//     the box touches (the core's own midphase), the plane test decides:
//     with the 50% bias there, a box sunk 0.005-0.01 at the foot of a 0.03
//     curb, pressed 0.02 into it, was popped up onto the curb at 184 of
//     361 yaws (the curb's triangles over its corner kept their face
//     contacts, 0.035-0.04 deep).
//     Manifold (points on the box, depths along N):
//     - N = n: the incident face clipped to the prism, plus the deepest
//       point over the triangle; a face patch (n is the support feature);
//     - N = +-u_i: the triangle clipped to the side planes of the box face
//       facing it (reference face), projected onto it;
//     - N = edge axis: closest points of the box's supporting edge and the
//       triangle's supporting edge (or vertex) along N.
//     For a tilted N the feature and the sort key are NOT the support
//     feature along N (which near an internal edge names the edge on both
//     of its triangles, and nothing voids it): they are where the box's lower
//     envelope is least over the triangle, and that depth (envelopeMinimum),
//     which orders a plane's triangles so that each such edge is voided by
//     the deeper neighbour across it. Where that minimum is inside the
//     triangle (the owner's s, or a box edge's shadow), the feature is the
//     edge that N leaves the triangle through.
//     Such a patch also offers its face patch along n (as for N = n) to the
//     filter as a stand-in, never written beside it (voided_features.h):
//     - in its place when no tilted axis clears the query's triangles of
//       this plane connected to it (its piece of surface) for less than
//       the push along n (the surface goes on across the edge: a box sunk
//       into a tessellated floor over a strip of this triangle narrower
//       than its depth); and when a face contact in the same plane voids
//       it;
//     - not at all, nor the patch, when another tilted axis clears the
//       piece cheaply and its own does not (it pushes along the plane);
//     - otherwise the tilted patch stands (a plate's or a ledge's edge).
//     That is why a patch carries its push along n, less the bias toward it
//     (face_push), and the narrowphase gives the box's extent along an axis.
//  Points deeper than -contact distance are kept; more than 4:
//  selectManifoldPoints (deepest, then largest area).
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
#include <type_traits>

namespace meshcontact {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

Status checkBox(const Box& box, const Pose& pose) {
  const Vec3& e = box.half_extents;
  if (!detail::inRange(e) || (e.array() < 0.0).any())
    return {ErrorCode::kInvalidShape,
            "box half_extents must be finite, >= 0 and <= 1e50, got " + detail::describe(e)};
  if (!(e.maxCoeff() > 0.0))
    return {ErrorCode::kInvalidShape, "box has zero extent: all half_extents are 0"};
  return detail::checkPose(pose, "box pose");
}

// Axis preference (step 5): a later axis replaces the current one only if its
// penetration is smaller by this fraction of |current| (plus 1e-6 of the
// box's size).
constexpr double kFaceBias = 0.05;
// n's, when the box is deepest over the face's interior and the candidates
// are partial (CandidateCoverage::kPartial; step 5).
constexpr double kPartialCoverageFaceBias = 0.5;
// A tilted axis may point below the triangle's plane by up to 15 degrees
// (sin 15°): pushing along it still moves the box sideways much more than
// through the plane. A box tilted by a little beside a plate's edge has its
// side face's normal dipping by the tilt; with the plane itself as the limit
// (N.n >= 0), a tilt of 1e-4 rad left n the only push, and the box was
// popped up onto the plate by its whole depth below it.
constexpr double kSidewaysDip = 0.25881904510252074;

// Ties between closest pairs of a separated box (face preferred), times the
// box's size.
constexpr double kTie = 1e-9;
// Round-off on lengths, times the query's magnitude (box size + distance from
// the origin, which bounds the cancellation in moving the triangle to the
// box's frame): below it an edge or face is parallel to the plane (corners
// tie in s), a point lies on an edge, a depth ties, a centre is on the plane.
constexpr double kFlat = 1e-14;

// A SAT axis, with the projections of both shapes on it.
struct Axis {
  Vec3 L;                 // u_i or u_i x E_j, not normalized
  double length;          // |L|
  double rb, tmin, tmax;  // along L (times |L|): box on [-rb, rb], triangle on [tmin, tmax]
  int kind;               // 1: box face u_i, 2: edge-edge u_i x E_j
  int box_axis, edge;
};

// Whether some axis pointing at most kSidewaysDip below the plane (step 5's
// candidates) pushes the box clear of the triangle by less than `limit`: the
// owner's face contact stands, without step 5, when none does. In squares,
// without the axes' lengths (a square root each), which step 5 then computes.
bool tiltedAxisMayBeCheaper(const Axis* axes, int count, const Vec3& n, double limit) {
  if (!(limit > 0.0)) return false;
  constexpr double kDip2 = kSidewaysDip * kSidewaysDip;
  for (int a = 0; a < count; ++a) {
    const Axis& ax = axes[a];
    const double length2 = ax.L.squaredNorm(), along = ax.L.dot(n);
    const double reach2 = limit * limit * length2;
    for (int o = 0; o < 2; ++o) {
      const double along_n = o == 0 ? along : -along;
      if (along_n < 0.0 && along_n * along_n > kDip2 * length2) continue;
      const double push = o == 0 ? ax.tmax + ax.rb : ax.rb - ax.tmin;  // times |L|
      if (push < 0.0 || push * push < reach2) return true;
    }
  }
  return false;
}

// The box's deepest point below the triangle's plane among its points over
// the triangle (box ∩ prism): the exact distance the box must move along n to
// clear the triangle, and where on the triangle that happens. Depth is
// linear, so its maximum is at a vertex of box ∩ prism: a box corner inside
// the prism, a box edge crossing a prism side, or a prism edge (the line
// v_k + s n) crossing a box face.
//
// As a function of the position x in the plane, the box's lowest height over
// x (its lower envelope) is convex over the box's shadow; this is its minimum
// over the triangle. `mask` tells where on the triangle the minimum is: bit k
// when it lies on edge k (m_k.(x - v_k) within round-off of 0). A minimum on
// the boundary of a triangle that does not hold the envelope's global
// minimum is not where the surface is deepest: going from it toward the
// global minimum descends at once into the neighbour across that edge (or
// around that vertex), whose own minimum is therefore strictly deeper; the
// filter, meeting triangles deepest first, voids the feature (reference §5a
// with this depth in place of the sphere's distance). Any minimizer will do
// when several tie (an edge of the box parallel to the plane).
struct DeepestOver {
  double depth = -kInf;  // -infinity when the box is not over the triangle
  Vec3 where = Vec3::Zero();
  int mask = 0;
};

DeepestOver deepestOverTriangle(const Vec3 v[3], const Vec3& n, const Vec3 m[3], const Vec3& e, double flat) {
  DeepestOver out;
  bool any = false;  // some point of the box lies over the triangle
  const auto offer = [&](const Vec3& x, double depth) {
    any = true;
    if (depth > out.depth) out.depth = depth, out.where = x;
  };
  // The 12 box edges share 8 corners (bit i of c: x_i = +e_i): each corner's
  // values against the prism's sides, side[c][s] = m_s.(x_c - v_s), and its
  // depth n.(v_0 - x_c), once, not once per edge end. A corner coordinate is
  // -e_i or +e_i, so each product m_s,i (x_i - v_s,i) and n_i (v_0,i - x_i)
  // takes two values: computed once, and summed per corner in the order of
  // the dot products they stand for (the same values).
  double ms[3][3][2], nd[3][2];
  for (int i = 0; i < 3; ++i) {
    for (int s = 0; s < 3; ++s) {
      ms[s][i][0] = m[s][i] * (-e[i] - v[s][i]);
      ms[s][i][1] = m[s][i] * (e[i] - v[s][i]);
    }
    nd[i][0] = n[i] * (v[0][i] - -e[i]);
    nd[i][1] = n[i] * (v[0][i] - e[i]);
  }
  Vec3 corner[8];
  double side[8][3], corner_depth[8];
  int outside[8];  // bit s: beyond side s (side[c][s] < 0)
  for (int c = 0; c < 8; ++c) {
    const int b0 = c & 1, b1 = (c >> 1) & 1, b2 = (c >> 2) & 1;
    corner[c] = Vec3(b0 ? e[0] : -e[0], b1 ? e[1] : -e[1], b2 ? e[2] : -e[2]);
    outside[c] = 0;
    for (int s = 0; s < 3; ++s) {
      side[c][s] = ms[s][0][b0] + ms[s][1][b1] + ms[s][2][b2];
      outside[c] |= int(side[c][s] < 0.0) << s;
    }
    corner_depth[c] = nd[0][b0] + nd[1][b1] + nd[2][b2];
  }
  // Edge q = 4 i + c (along u_i) runs from corner kEdgeFrom[q] to that
  // corner | 1 << i. An edge whose two ends are beyond one side has no point
  // over the triangle (about 7 of the 12 on a floor): a bit per edge to
  // visit, set without a branch. A side cuts an edge where it separates its
  // ends (exactly one end beyond it), at t = f0 / (f0 - f1) from the first
  // end: from below when that end is beyond (the interval starts there),
  // from above otherwise. The edges are visited and their ends offered in
  // the order of index, the offers kept without a branch: these branches,
  // on arbitrary corners, mispredicted (the function took ~290 ns a call,
  // now ~210, replaying 200,000 of compare_bench's box calls). An end that
  // no side cut is its corner (a + 1 (b - a) == b: the edge runs from -e_i
  // to e_i), whose depth is known. Ties keep the first offer.
  static constexpr int kEdgeFrom[12] = {0, 2, 4, 6, 0, 4, 1, 5, 0, 1, 2, 3};
  unsigned visit = 0;
  for (int q = 0; q < 12; ++q) {
    const int ca = kEdgeFrom[q], cb = ca | (1 << (q >> 2));
    visit |= unsigned((outside[ca] & outside[cb]) == 0) << q;
  }
  double best_depth = out.depth;
  double wx = 0.0, wy = 0.0, wz = 0.0;
  for (; visit != 0; visit &= visit - 1) {
    const int q = __builtin_ctz(visit);
    const int ca = kEdgeFrom[q], cb = ca | (1 << (q >> 2));
    const int split = outside[ca] ^ outside[cb];
    double lo = 0.0, hi = 1.0;
    for (int s = 0; s < 3; ++s) {
      const double f0 = side[ca][s], f1 = side[cb][s];
      const bool cut = (split >> s) & 1;
      const double t = f0 / (cut ? f0 - f1 : 1.0);  // f0 - f1 != 0 when cut
      lo = cut && f0 < 0.0 ? std::max(lo, t) : lo;
      hi = cut && !(f0 < 0.0) ? std::min(hi, t) : hi;
    }
    const bool valid = lo <= hi;
    any = any || valid;
    const Vec3& a = corner[ca];
    const Vec3 ab = corner[cb] - a;
    for (int end = 0; end < 2; ++end) {
      const double t = end == 0 ? lo : hi;
      const Vec3 x = a + t * ab;
      const double d = t == 0.0 ? corner_depth[ca] : (t == 1.0 ? corner_depth[cb] : n.dot(v[0] - x));
      const bool better = valid && d > best_depth;
      best_depth = better ? d : best_depth;
      wx = better ? x.x() : wx;
      wy = better ? x.y() : wy;
      wz = better ? x.z() : wz;
    }
  }
  if (best_depth > out.depth) out.depth = best_depth, out.where = Vec3(wx, wy, wz);
  for (int k = 0; k < 3; ++k) {  // the prism's edges through the box's faces
    double lo = -kInf, hi = kInf;
    bool empty = false;
    for (int i = 0; i < 3 && !empty; ++i) {
      // Parallel to face pair i, to round-off: dividing by an n_i of noise
      // gave a bound of noise over noise where the line runs along a face (a
      // mesh vertex under a box corner), and a point part-way up the box's
      // edge, at depth 0, that took a real corner's place in the patch.
      if (std::abs(n[i]) <= 1e-12) {
        empty = std::abs(v[k][i]) > e[i];
        continue;
      }
      const double s0 = (-e[i] - v[k][i]) / n[i], s1 = (e[i] - v[k][i]) / n[i];
      lo = std::max(lo, std::min(s0, s1));
      hi = std::min(hi, std::max(s0, s1));
      empty = lo > hi;
    }
    if (!empty) {  // lowest point of the line inside the box
      const Vec3 x = v[k] + lo * n;
      offer(x, n.dot(v[0] - x));
    }
  }
  if (!any) return out;
  for (int k = 0; k < 3; ++k)
    if (m[k].dot(out.where - v[k]) <= flat * m[k].norm()) out.mask |= 1 << k;
  return out;
}

// The triangle feature of a boundary mask (bit k: on edge k); face for 0.
Feature maskFeature(int mask) {
  switch (mask) {
    case 1: return Feature::edge(0);
    case 2: return Feature::edge(1);
    case 4: return Feature::edge(2);
    case 3: return Feature::vertex(1);  // edges 0 and 1 meet at v1
    case 6: return Feature::vertex(2);
    case 5: return Feature::vertex(0);
    case 7: return Feature::vertex(0);  // a sliver: any of its vertices
    default: return Feature::face();
  }
}

// Up to 9 points of a manifold under construction (a quad clipped by 3
// planes, or a triangle by 4, has at most 7 vertices; one more is appended).
struct Polygon {
  static constexpr int kCapacity = 9;
  Vec3 buffer[2][kCapacity];
  double depth[kCapacity];
  Vec3* pts = buffer[0];
  int count = 0;
  Vec3* spare() { return pts == buffer[0] ? buffer[1] : buffer[0]; }
};

// Keeps the polygon's part where plane.(x) + offset >= 0 (Sutherland-Hodgman),
// in place. A value within `noise` of 0 is 0 (on the plane, kept): a
// polygon edge lying along the plane (a box face's edge over a triangle's
// edge: a box on a grid whose cells it covers) has values of rounding noise
// of either sign, and clipping at their ratio put a point mid-edge in place
// of a corner. Each vertex's value is computed once, first: a polygon with
// no vertex beyond the plane (most of a triangle's sides against the box's
// face, on a floor) is kept as it is, where the clipping loop copied every
// vertex to the other buffer and added none.
void clipPolygon(Polygon& poly, const Vec3& plane, double offset, double noise) {
  const int count = poly.count;
  double d[Polygon::kCapacity];
  bool beyond = false;
  for (int i = 0; i < count; ++i) {
    const double x = plane.dot(poly.pts[i]) + offset;
    d[i] = std::abs(x) <= noise ? 0.0 : x;
    beyond |= d[i] < 0.0;
  }
  if (!beyond) return;
  const Vec3* in = poly.pts;
  Vec3* out = poly.spare();
  int n = 0;
  for (int i = 0; i < count; ++i) {
    const int next = i + 1 == count ? 0 : i + 1;
    const Vec3& a = in[i];
    const double da = d[i], db = d[next];
    if (da >= 0.0) out[n++] = a;
    // Only a strict crossing adds a point: an end on the plane (0) is that
    // point already, kept as a or as the next edge's a. (Added again, a
    // corner of the box over a mesh vertex came out twice, and the two
    // copies took two of a patch's four places from a real corner.)
    if ((da > 0.0 && db < 0.0) || (da < 0.0 && db > 0.0)) out[n++] = a + (da / (da - db)) * (in[next] - a);
  }
  poly.pts = out;
  poly.count = n;
}

// Where the filter should meet a triangle that the box enters without
// owning s, and which of its features that is. The box's lower envelope phi
// (its lowest height over each point x of the plane) is convex, and minimal
// at s. Triangles met in order of their minimum of phi, each tagged with
// where that minimum lies, void each other like the sphere's (reference §5a
// with phi in place of the distance): from a minimum on a triangle's edge,
// the way down toward s enters the neighbour across that edge at once, so
// that neighbour's minimum is deeper and it is met first, voiding the edge.
// phi alone ties when a face or an edge of the box is parallel to the plane
// (a box lying flat), and orders by round-off when it is nearly so; the
// strictly convex
//     Phi(x) = phi(x) + eps |x - s|^2   (in-plane distance, eps = 1e-9 / box size)
// has s as its only minimum, orders such triangles by their distance to s,
// and changes nothing else by more than 4e-9 of the box's size.
//
// phi is linear over each lower face of the box (the shadow of face x_i = -s_i
// e_i with s_i = sign(n_i)), so Phi's minimum over the triangle is on the
// boundary of one of the lower faces' parts over the triangle (a smooth
// minimum inside would be Phi's global one, s): at a vertex of that clipped
// face, or where Phi is stationary along one of its edges. Returns false when
// the box is over the triangle only through faces (nearly) perpendicular to
// the plane.
bool envelopeMinimum(const Vec3 v[3], const Vec3& n, const Vec3 m[3], const Vec3& e, const Vec3& s, double eps,
                     double flat, double& value, Feature& feature) {
  const double h0 = n.dot(v[0]);
  value = kInf;
  Vec3 best = Vec3::Zero();
  const auto inPlane = [&](const Vec3& d) { return Vec3(d - d.dot(n) * n); };
  for (int i = 0; i < 3; ++i) {
    if (!(std::abs(n[i]) > 1e-12)) continue;  // its shadow has no area
    const int j = (i + 1) % 3, k = (i + 2) % 3;
    static constexpr double sj[4] = {1, -1, -1, 1}, sk[4] = {1, 1, -1, -1};
    Polygon poly;
    for (int c = 0; c < 4; ++c) {
      poly.pts[c][i] = n[i] > 0.0 ? -e[i] : e[i];
      poly.pts[c][j] = sj[c] * e[j];
      poly.pts[c][k] = sk[c] * e[k];
    }
    poly.count = 4;
    for (int q = 0; q < 3 && poly.count > 0; ++q) {
      clipPolygon(poly, m[q], -m[q].dot(v[q]), flat * m[q].norm());
    }
    for (int c = 0; c < poly.count; ++c) {
      const Vec3& a = poly.pts[c];
      const Vec3& b = poly.pts[(c + 1) % poly.count];
      const double ha = n.dot(a) - h0, dh = n.dot(b) - h0 - ha;
      const Vec3 wa = inPlane(a - s), dw = inPlane(b - a);
      const double va = ha + eps * wa.squaredNorm();
      if (va < value) value = va, best = a;
      const double dw2 = dw.squaredNorm();
      if (!(dw2 > 0.0)) continue;
      const double t = -(dh / (2.0 * eps) + wa.dot(dw)) / dw2;  // d Phi / dt = 0 along a -> b
      if (!(t > 0.0 && t < 1.0)) continue;
      const double vt = ha + t * dh + eps * (wa + t * dw).squaredNorm();
      if (vt < value) value = vt, best = a + t * (b - a);
    }
  }
  if (!(value < kInf)) return false;
  int mask = 0;
  for (int q = 0; q < 3; ++q)
    if (m[q].dot(best - v[q]) <= flat * m[q].norm()) mask |= 1 << q;
  feature = maskFeature(mask);
  return true;
}

// The box face most anti-parallel to n (the incident face) clipped to the
// triangle's prism; depths are how far below the plane.
void incidentFace(const Vec3 v[3], const Vec3& n, const Vec3 m[3], const Vec3& e, double flat, Polygon& poly) {
  int i = 0;
  for (int k = 1; k < 3; ++k)
    if (std::abs(n[k]) > std::abs(n[i])) i = k;
  const int j = (i + 1) % 3, k = (i + 2) % 3;
  const double xi = n[i] > 0.0 ? -e[i] : e[i];
  static constexpr double sj[4] = {1, -1, -1, 1}, sk[4] = {1, 1, -1, -1};  // not rebuilt on the stack per call
  poly.pts = poly.buffer[0];
  for (int c = 0; c < 4; ++c) {
    poly.pts[c][i] = xi;
    poly.pts[c][j] = sj[c] * e[j];
    poly.pts[c][k] = sk[c] * e[k];
  }
  poly.count = 4;
  for (int s = 0; s < 3 && poly.count > 0; ++s) {  // inward edge planes of the triangle
    clipPolygon(poly, m[s], -m[s].dot(v[s]), flat * m[s].norm());
  }
  for (int c = 0; c < poly.count; ++c) poly.depth[c] = n.dot(v[0] - poly.pts[c]);
}

// The triangle clipped to the side planes of the box face with outward
// normal -s u_i (at x_i = -s e_i, s = +-1), projected onto that face; depths
// are how far inside the face the triangle's points are.
void referenceFace(const Vec3 v[3], int i, double s, const Vec3& e, double flat, Polygon& poly) {
  poly.pts = poly.buffer[0];
  for (int c = 0; c < 3; ++c) poly.pts[c] = v[c];
  poly.count = 3;
  for (int side = 0; side < 4 && poly.count > 0; ++side) {
    const int j = (i + 1 + side / 2) % 3;
    const double sgn = side % 2 == 0 ? -1.0 : 1.0;  // keep sgn * x_j + e_j >= 0
    clipPolygon(poly, sgn * Vec3::Unit(j), e[j], flat);
  }
  for (int c = 0; c < poly.count; ++c) {
    poly.depth[c] = e[i] + s * poly.pts[c][i];
    poly.pts[c][i] = -s * e[i];
  }
}

// The closest pair of a box and a triangle that do not intersect (step 3).
// `flat` is round-off on lengths: the prunings below are exact tests of
// which features may hold the pair, and a triangle lying on a box face
// (a box set down on a floor) sits on their boundaries, where round-off
// must not rule a feature out: a box whose bottom face noise put 1e-17
// below all three vertices skipped its bottom corners and edges, and got
// the vertex under it (distance 0, the lowest rank) for every triangle
// around that vertex, which voided all but one: the box stood on a corner
// of one triangle.
struct ClosestPair {
  Vec3 b, t;  // on the box, on the triangle (box frame)
  double d = kInf;
  Feature feature = Feature::vertex(0);
};

int featureRank(Feature f) { return f.type == FeatureType::kFace ? 2 : (f.type == FeatureType::kEdge ? 1 : 0); }

ClosestPair closestPair(const Vec3 v[3], const Vec3& n, const Vec3 m[3], const Vec3& e, double tie, double flat) {
  ClosestPair best;
  const auto offer = [&](const Vec3& b, const Vec3& t, Feature f) {
    const double d2 = (b - t).squaredNorm();
    const double reach = best.d + tie;
    if (d2 > reach * reach) return;
    const double d = std::sqrt(d2);
    if (d < best.d - tie || featureRank(f) > featureRank(best.feature)) best = {b, t, d, f};
  };
  // allowed[i][0]: the face x_i = -e_i may hold the closest point; [1]: x_i = +e_i.
  bool allowed[3][2];
  for (int i = 0; i < 3; ++i) {
    allowed[i][0] = std::min({v[0][i], v[1][i], v[2][i]}) <= -e[i] + flat;
    allowed[i][1] = std::max({v[0][i], v[1][i], v[2][i]}) >= e[i] - flat;
  }
  // A point's height over the plane bounds its distance to the triangle from
  // below: features that cannot beat the best pair so far are skipped.
  const double h0 = n.dot(v[0]);
  const auto height = [&](const Vec3& x) { return n.dot(x) - h0; };
  const auto hopeless = [&](double bound) { return bound > best.d + tie; };
  for (int k = 0; k < 3; ++k)  // face-vertex: the triangle's vertices
    offer(v[k].cwiseMax(-e).cwiseMin(e), v[k], Feature::vertex(k));
  for (int c = 0; c < 8; ++c) {  // vertex-face: the box's corners
    const int s[3] = {c & 1, (c >> 1) & 1, (c >> 2) & 1};
    if (!allowed[0][s[0]] || !allowed[1][s[1]] || !allowed[2][s[2]]) continue;
    const Vec3 corner(s[0] ? e[0] : -e[0], s[1] ? e[1] : -e[1], s[2] ? e[2] : -e[2]);
    const double h = height(corner);
    if (hopeless(std::abs(h))) continue;
    const ClosestPoint cp = closestPointOnTriangle(corner, v[0], v[1], v[2]);
    // A corner below the plane over the triangle would give a normal into
    // the triangle's back (the box reaching under it from the side): not a
    // face pair for this one-sided triangle; its edges still count below.
    // (Within round-off of the plane it is on it: step 3 takes n then.)
    if (cp.feature.type == FeatureType::kFace && h < -flat) continue;
    offer(corner, cp.point, cp.feature);
  }
  // The triangle's closest point is inside edge q only when the box's is in
  // that edge's Voronoi region, outside the edge's inward plane: with the
  // whole box inside it, edge q's ends (the vertices above) are all it offers.
  bool edge_possible[3];
  for (int q = 0; q < 3; ++q) edge_possible[q] = -m[q].dot(v[q]) - e.dot(m[q].cwiseAbs()) <= flat * m[q].norm();
  for (int i = 0; i < 3; ++i) {  // edge-edge: the 4 box edges along u_i
    const int j = (i + 1) % 3, k = (i + 2) % 3;
    for (int c = 0; c < 4; ++c) {
      const int sj = c & 1, sk = (c >> 1) & 1;
      if (!allowed[j][sj] || !allowed[k][sk]) continue;
      Vec3 a, b;
      a[j] = b[j] = sj ? e[j] : -e[j];
      a[k] = b[k] = sk ? e[k] : -e[k];
      a[i] = -e[i];
      b[i] = e[i];
      const double ha = height(a), hb = height(b);
      if (hopeless(ha * hb <= 0.0 ? 0.0 : std::min(std::abs(ha), std::abs(hb)))) continue;
      for (int q = 0; q < 3; ++q) {
        if (!edge_possible[q]) continue;
        const int r = (q + 1) % 3;
        // The edge from its lexicographically smaller end: the neighbour
        // sharing it walks it the other way, and the pair (its distance is
        // the filter's sort key) is then bitwise the same for both. Walked
        // each its own way, the two distances differed in the last bits, so
        // the frame's round-off chose which of the tied triangles came first
        // (and a box's stand-in rule then kept an edge contact or a face
        // patch): boxes near the sine terrains of
        // SurfaceInvariance.TurningTheWholeSceneKeepsTheContacts changed
        // contacts at 17 and 16 of 2,000 placements when the scene was turned.
        const bool forward = std::lexicographical_compare(v[q].data(), v[q].data() + 3, v[r].data(), v[r].data() + 3);
        const int from = forward ? q : r, to = forward ? r : q;
        const detail::SegmentPair p = detail::closestSegmentSegment(a, b, v[from], v[to]);
        offer(p.p, p.q, p.t <= 0.0 ? Feature::vertex(from) : (p.t >= 1.0 ? Feature::vertex(to) : Feature::edge(q)));
      }
    }
  }
  // The box point straight above the (closed) triangle: the face's region.
  if (best.feature.type != FeatureType::kFace) {
    const Vec3 w = best.b - best.t;
    const double up = w.dot(n);
    if (up > 0.0 && (w - up * n).squaredNorm() <= 1e-18 * w.squaredNorm()) best.feature = Feature::face();
  }
  return best;
}

struct BoxNarrowphase {
  // Face parts (step 5's tilted patches) only stand in for voided patches.
  static constexpr bool kFacePartsStandIn = true;

  Pose pose;           // box in the query frame
  Vec3 e;              // half extents
  double contact_distance;
  double scale;        // |e|: the box's size, for tolerances
  double flat_;        // round-off tolerance on lengths (see kFlat)
  // n's bias when the box is deepest over the face's interior (step 5):
  // kFaceBias, or kPartialCoverageFaceBias for partial candidates.
  double interior_face_bias;

  // How far apart a pair may be and still be in contact: the contact
  // distance plus round-off. A box lying exactly on a tessellated plane is
  // 0 +- 1e-17 from each triangle once the triangle is moved to the box's
  // frame; without the round-off term, which triangles touch (and so where
  // the manifold's points are) was decided by that noise: a box set down
  // exactly on a floor got its points from one triangle in one corner and
  // tipped over.
  double reach() const { return contact_distance + flat_; }

  // Keeps the points within the contact distance, at most 4 of them, and
  // writes them in the query frame. Returns how many (0: none left).
  int keepPoints(Polygon& poly, const Vec3& N, Vec3 points[4], double depths[4]) const {
    int kept = 0;
    for (int c = 0; c < poly.count; ++c)
      if (poly.depth[c] >= -reach()) {
        poly.pts[kept] = poly.pts[c];
        // Within round-off of the contact distance: at it (depth >= -contact distance holds).
        poly.depth[kept] = std::max(poly.depth[c], -contact_distance);
        ++kept;
      }
    if (kept == 0) return 0;
    int keep[4];
    const int count = selectPatchPoints(poly, kept, N, keep);
    for (int c = 0; c < count; ++c) {
      points[c] = pose.apply(poly.pts[keep[c]]);
      depths[c] = poly.depth[keep[c]];
    }
    return count;
  }

  // The patch's points (keepPoints), normal and distance. False when no
  // point is left.
  bool finish(Polygon& poly, const Vec3& N, detail::Patch& patch) const {
    patch.count = keepPoints(poly, N, patch.points, patch.depths);
    if (patch.count == 0) return false;
    double deepest = -kInf;
    for (int c = 0; c < patch.count; ++c) deepest = std::max(deepest, patch.depths[c]);
    patch.normal = queryFrameNormal(N);
    patch.distance = -deepest;
    return true;
  }

  // At most 4 of the patch's `count` points. A patch is one triangle's piece
  // of a manifold that reduceManifolds reduces again over all the
  // triangles, and on a tessellated plane the union of the incident face's
  // pieces is the face: its extreme points are the box's corners, never the
  // clip points where a triangle's edge crosses the face. A per-patch choice
  // made on the patch alone (largest area) can trade a corner for a nearby
  // clip point, which the final reduction can no longer recover: the box
  // then stands on a polygon that shrinks and grows as it slides across
  // internal edges, and rocks. So: the deepest point (the patch's depth),
  // then the box's corners in the patch, then selectManifoldPoints' choice.
  int selectPatchPoints(const Polygon& poly, int count, const Vec3& N, int keep[4]) const {
    if (count <= 4) {
      for (int c = 0; c < count; ++c) keep[c] = c;
      return count;
    }
    int chosen[4];
    const int natural = detail::selectManifoldPoints(poly.pts, poly.depth, count, N, scale, chosen);
    int n = 0;
    const auto add = [&](int c) {
      for (int k = 0; k < n; ++k)
        if (keep[k] == c) return;
      if (n < 4) keep[n++] = c;
    };
    add(chosen[0]);  // the deepest
    // Corners: the incident face's vertices survive clipping bit for bit.
    int corners[9], corner_count = 0;
    for (int c = 0; c < count; ++c)
      if (c != chosen[0] && (poly.pts[c].cwiseAbs() - e).cwiseAbs().maxCoeff() == 0.0) corners[corner_count++] = c;
    if (corner_count <= 3) {
      for (int k = 0; k < corner_count; ++k) add(corners[k]);
    } else {  // a triangle under the whole face and a deepest point off it: the widest 3 corners
      Vec3 pts[9];
      double depths[9];
      pts[0] = poly.pts[chosen[0]];
      depths[0] = kInf;
      for (int k = 0; k < corner_count; ++k) pts[k + 1] = poly.pts[corners[k]], depths[k + 1] = 0.0;
      int sub[4];
      const int m = detail::selectManifoldPoints(pts, depths, corner_count + 1, N, scale, sub);
      for (int k = 0; k < m; ++k)
        if (sub[k] > 0) add(corners[sub[k] - 1]);
    }
    for (int k = 1; k < natural; ++k) add(chosen[k]);
    return n;
  }

  /// The box's least and greatest values along a unit axis of the query
  /// frame (the filter's plane test, markPlanePushes).
  void extentAlong(const Vec3& axis, double& low, double& high) const {
    const double centre = axis.dot(pose.translation), half = (pose.rotation.transpose() * axis).cwiseAbs().dot(e);
    low = centre - half;
    high = centre + half;
  }

  /// A unit normal of the box frame, in the query frame. The validation
  /// accepts rotations with |R^T R - I| up to 1e-9 per entry, and such an R
  /// stretches a unit vector by up to ~1.5e-9 (3 * 1e-9 / 2, along (1,1,1)):
  /// normalizing keeps Contact::normal unit for every accepted pose.
  Vec3 queryFrameNormal(const Vec3& n) const { return (pose.rotation * n).normalized(); }

  detail::PatchOutcome operator()(const CandidateTriangle& tri, detail::Patch& patch) const {
    using detail::PatchOutcome;
    Vec3 v[3];
    for (int k = 0; k < 3; ++k) v[k] = pose.applyInverse(tri.vertices[k]);
    // The box's face axes first: the cheapest rejection of the midphase's
    // candidates (collideBox's midphase drops those whose bounds the box's
    // faces separate, but the triangle itself may be separated where its
    // bounds are not).
    Vec3 lo = v[0].cwiseMin(v[1]).cwiseMin(v[2]), hi = v[0].cwiseMax(v[1]).cwiseMax(v[2]);
    const double face_gap = std::max((lo - e).maxCoeff(), (-hi - e).maxCoeff());
    if (face_gap > reach()) {
      patch.distance = face_gap;
      return PatchOutcome::kBeyondContactDistance;
    }
    const Vec3 edges[3] = {v[1] - v[0], v[2] - v[1], v[0] - v[2]};
    const detail::ScaledEdges scaled = detail::scaledEdges(v[0], v[1], v[2]);  // the build's test, at any scale
    if (scaled.degenerate) {
      patch.distance = v[0].norm();
      return PatchOutcome::kDegenerate;
    }
    const Vec3 n = scaled.unitNormal();
    const double tie = kTie * scale;
    const double flat = flat_;

    // 1. The centre's height over the plane; the box's half-thickness along n.
    const double centre_height = -n.dot(v[0]);
    if (centre_height < -flat) {
      patch.distance = -centre_height;
      return PatchOutcome::kBackFacing;
    }
    const double thickness = e.dot(n.cwiseAbs());
    double separation = std::max(std::abs(centre_height) - thickness, face_gap);  // SAT along n and u_i
    if (separation > reach()) {
      patch.distance = separation;
      return PatchOutcome::kBeyondContactDistance;
    }

    // 2. The other 12 axes, unnormalized (a square root only when an axis
    // separates, to compare with the contact distance).
    Axis axes[12];
    int axis_count = 0;
    for (int i = 0; i < 3; ++i) {  // the box's faces (their gaps are in `separation` already)
      Axis& a = axes[axis_count++];
      a.L = Vec3::Unit(i);
      a.length = 1.0;
      a.rb = e[i];
      a.tmin = lo[i];
      a.tmax = hi[i];
      a.kind = 1, a.box_axis = i, a.edge = 0;
    }
    // u_i x E_j, i outer, j inner. Each pair is its own copy (I and J are
    // compile-time constants): with run-time indices, the index arithmetic
    // ((i + 1) % 3, ...) and the indexed loads cost more than the axis's own
    // arithmetic, on the ~2.5 triangles per box query that get this far.
    // The values are those of the loop it replaces, expression for
    // expression.
    const double edge2[3] = {edges[0].squaredNorm(), edges[1].squaredNorm(), edges[2].squaredNorm()};
    const auto crossAxis = [&](auto I, auto J) -> bool {  // false: separated beyond the contact distance
      constexpr int i = decltype(I)::value, j = decltype(J)::value;
      constexpr int j1 = (i + 1) % 3, j2 = (i + 2) % 3, w = (j + 2) % 3;
      const Vec3& E = edges[j];
      const double length2 = E[j1] * E[j1] + E[j2] * E[j2];
      if (length2 < 1e-12 * edge2[j]) return true;  // parallel: nothing beyond the face axes
      Axis& a = axes[axis_count];
      a.L[i] = 0.0;
      a.L[j1] = -E[j2];
      a.L[j2] = E[j1];
      a.length = 0.0;  // computed when needed
      a.rb = e[j1] * std::abs(E[j2]) + e[j2] * std::abs(E[j1]);
      // E_j's ends project alike: the triangle spans two values.
      const double p0 = a.L[j1] * v[j][j1] + a.L[j2] * v[j][j2];
      const double p1 = a.L[j1] * v[w][j1] + a.L[j2] * v[w][j2];
      a.tmin = std::min(p0, p1);
      a.tmax = std::max(p0, p1);
      a.kind = 2, a.box_axis = i, a.edge = j;
      const double gap = std::max(a.tmin, -a.tmax) - a.rb;
      if (gap >= 0.0) {
        a.length = std::sqrt(a.L.squaredNorm());
        separation = std::max(separation, gap / a.length);
        if (separation > reach()) return false;
      }
      ++axis_count;
      return true;
    };
    using C0 = std::integral_constant<int, 0>;
    using C1 = std::integral_constant<int, 1>;
    using C2 = std::integral_constant<int, 2>;
    const bool beyond = !(crossAxis(C0{}, C0{}) && crossAxis(C0{}, C1{}) && crossAxis(C0{}, C2{}) &&
                          crossAxis(C1{}, C0{}) && crossAxis(C1{}, C1{}) && crossAxis(C1{}, C2{}) &&
                          crossAxis(C2{}, C0{}) && crossAxis(C2{}, C1{}) && crossAxis(C2{}, C2{}));
    if (beyond) {
      patch.distance = separation;
      return PatchOutcome::kBeyondContactDistance;
    }
    const Vec3 m[3] = {n.cross(edges[0]), n.cross(edges[1]), n.cross(edges[2])};
    Polygon poly;

    // 3. Apart: the exact closest pair and its triangle feature. Touching to
    // round-off (the axes' gaps are 0 +- noise), the pair's features are
    // chosen on noise and may be the wrong ones, which the pair's distance
    // then shows: far beyond round-off (1,000 times it), or beyond reach,
    // while every axis says touching. That pair is not taken: the triangle
    // is treated as intersecting (4.), which is what it is to round-off. (A
    // box set down exactly on a yawed floor found a vertical box edge
    // against a triangle edge 0.04 away: no contact at contact distance 0;
    // within a positive one, a box face "facing" a triangle vertex beside
    // it, and the triangle clipped to that face's sides: a sideways contact
    // as deep as the box is wide, on 4 of 6,000 such boxes.)
    const ClosestPair pair = separation >= 0.0 ? closestPair(v, n, m, e, tie, flat) : ClosestPair();
    const bool touching_by_noise =
        separation >= 0.0 && separation <= flat && (pair.d > 1e3 * flat || pair.d > reach());
    if (separation >= 0.0 && !touching_by_noise) {
      patch.distance = pair.d;
      if (pair.d > reach()) return PatchOutcome::kBeyondContactDistance;
      patch.feature = pair.feature;
      Vec3 N = n;
      if (pair.feature.type == FeatureType::kFace) {
        incidentFace(v, n, m, e, flat, poly);
        poly.pts[poly.count] = pair.b;  // may lie off the incident face
        poly.depth[poly.count++] = -pair.d;
      } else {
        // Touching to round-off: b - t is noise, take the plane's normal as for b == t.
        N = pair.d > flat ? normalizedOr(pair.b - pair.t, n) : n;
        int i = 0;
        for (int k = 1; k < 3; ++k)
          if (std::abs(N[k]) > std::abs(N[i])) i = k;
        if (1.0 - std::abs(N[i]) <= 1e-12) {  // a box face facing the edge / vertex
          N = Vec3::Zero();
          // Touching (b == t, or b - t within round-off, whose sign is
          // noise): the side the triangle faces, never its back. (Taken
          // from the noise, it put the contact on the box's far face, the
          // normal into the mesh and the depth at the box's thickness.)
          N[i] = pair.d > flat && pair.b[i] != pair.t[i] ? (pair.b[i] > pair.t[i] ? 1.0 : -1.0)
                                                         : (n[i] >= 0.0 ? 1.0 : -1.0);
          referenceFace(v, i, N[i], e, flat, poly);
        } else {
          poly.pts[0] = pair.b;
          poly.depth[0] = -pair.d;
          poly.count = 1;
        }
      }
      if (!finish(poly, N, patch)) return PatchOutcome::kBeyondContactDistance;
      // An edge or vertex pair along the plane's normal (to 3 degrees): the
      // box's face nearly level over this triangle, held up by its closest
      // corner elsewhere (a box tilted by 1e-4 rad hovering within the
      // contact distance). Its face part, the incident face clipped to the
      // prism, stands in should a face contact in this plane void the
      // feature (the filter meets these patches by distance from that
      // contact outward): without it the tiles of the floor away from the
      // lowest corner had no point, and the box had 3 contacts near one
      // corner, on every such placement. Not a push (the box is apart):
      // face_push infinite, which markPlanePushes leaves to that rule.
      if (pair.feature.type != FeatureType::kFace && N.dot(n) >= detail::kStandInCosine) {
        Polygon face;
        incidentFace(v, n, m, e, flat, face);
        patch.face_count = keepPoints(face, n, patch.face_points, patch.face_depths);
        patch.face_normal = queryFrameNormal(n);
        patch.face_push = kInf;
      }
      return PatchOutcome::kContact;
    }

    // 4. Intersecting: does this triangle own the contact? s = the lowest
    // corners' average; along u_i the corners tie when |n_i| e_i is nil.
    Vec3 s;
    for (int i = 0; i < 3; ++i) s[i] = 2.0 * std::abs(n[i]) * e[i] <= flat ? 0.0 : (n[i] > 0.0 ? -e[i] : e[i]);
    bool owned = true;
    for (int k = 0; k < 3 && owned; ++k) owned = m[k].dot(s - v[k]) >= -flat * std::sqrt(edges[k].squaredNorm());
    const auto own = [&]() {
      patch.feature = Feature::face();
      incidentFace(v, n, m, e, flat, poly);
      if (!finish(poly, n, patch)) {  // not expected: s lies on the incident face, over the triangle
        patch.count = 1;
        patch.points[0] = pose.apply(s);
        patch.depths[0] = thickness - centre_height;
        patch.normal = queryFrameNormal(n);
        patch.distance = -patch.depths[0];
      }
      return PatchOutcome::kContact;
    };

    // 5. The axis of least penetration, n first. For n the penetration is the
    // exact depth over the triangle: the SAT overlap (box's lowest point
    // anywhere) overstates the push needed when the box's deepest part is not
    // over this triangle. The owner's is s's depth, and interior (the
    // box's deepest point lies over the triangle): its face contact stands
    // unless a tilted axis needs less push, by the interior bias (step 4).
    if (owned && !tiltedAxisMayBeCheaper(axes, axis_count, n,
                                         (1.0 - interior_face_bias) * (thickness - centre_height) - 1e-6 * scale))
      return own();
    DeepestOver over;
    if (owned) {
      over.depth = thickness - centre_height;
      over.where = s;
    } else {
      over = deepestOverTriangle(v, n, m, e, flat);
    }
    const double n_depth = over.depth;
    const Vec3& deepest_point = over.where;
    struct Best {
      Vec3 N;
      double pen;
      int kind, box_axis, edge;
    } best{n, n_depth > -kInf ? n_depth : kInf, 0, 0, 0};
    // The deepest point over the triangle strictly inside the prism: near an
    // internal edge the per-triangle overlap along a tilted axis is often
    // smaller only because the triangle ends. The filter's plane test tells
    // that from the surface ending (a ledge's edge), given the triangles
    // around; with partial candidates it cannot, and n is kept unless
    // another axis needs less than half the push.
    const bool interior = std::isfinite(best.pen) && over.mask == 0;
    const double n_bias = interior ? interior_face_bias : kFaceBias;
    // Every axis's length, slope along n and pushes, first, in a loop with
    // no branch: its square roots and divisions overlap in the pipeline,
    // where the choice below (data-dependent branches) left each waiting on
    // the last. (|u_i| = 1 exactly; a length computed when its axis
    // separated is this same expression.)
    double along[12], push[12][2];
    for (int a = 0; a < axis_count; ++a) {
      Axis& ax = axes[a];
      ax.length = std::sqrt(ax.L.squaredNorm());
      along[a] = ax.L.dot(n) / ax.length;
      push[a][0] = (ax.tmax + ax.rb) / ax.length;  // along +L
      push[a][1] = (ax.rb - ax.tmin) / ax.length;  // along -L
    }
    for (int a = 0; a < axis_count; ++a) {
      const Axis& ax = axes[a];
      for (int o = 0; o < 2; ++o) {
        const double along_n = o == 0 ? along[a] : -along[a];
        if (along_n < -kSidewaysDip) continue;  // would pull the box through the triangle's back
        const double pen = push[a][o];
        const double bias = best.kind == 0 ? n_bias : kFaceBias;
        const double margin =
            ax.kind > best.kind && std::isfinite(best.pen) ? bias * std::abs(best.pen) + 1e-6 * scale : 0.0;
        if (pen < best.pen - margin) {
          const Vec3 L = ax.L / ax.length;
          best = {o == 0 ? L : Vec3(-L), pen, ax.kind, ax.box_axis, ax.edge};
        }
      }
    }
    if (!std::isfinite(best.pen)) {  // not expected: intersecting boxes have a finite push
      patch.distance = 0.0;
      return PatchOutcome::kDegenerate;
    }
    if (owned && best.kind == 0) return own();
    const Vec3& N = best.N;
    // The face patch along n: the incident face clipped to the prism, and
    // the deepest point over the triangle unless it is one of that
    // polygon's vertices to round-off (a box corner over the triangle, found
    // by both: once, as its two copies may map to one point of the query
    // frame).
    const auto facePolygon = [&](Polygon& face) {
      incidentFace(v, n, m, e, flat, face);
      for (int c = 0; c < face.count; ++c)
        if ((face.pts[c] - deepest_point).cwiseAbs().maxCoeff() <= flat) return;
      face.pts[face.count] = deepest_point;
      face.depth[face.count++] = n_depth;
    };
    if (best.kind == 0) {
      facePolygon(poly);
    } else if (best.kind == 1) {
      referenceFace(v, best.box_axis, N[best.box_axis], e, flat, poly);
    } else {
      // Box edge along u_i that is lowest along N; triangle's highest feature along N.
      const int i = best.box_axis, j = best.edge;
      Vec3 corner;
      for (int k = 0; k < 3; ++k) corner[k] = N[k] > 0.0 ? -e[k] : e[k];
      Vec3 lo = corner, hi = corner;
      lo[i] = -e[i];
      hi[i] = e[i];
      const Vec3& a = v[j];
      const Vec3& b = v[(j + 1) % 3];
      const Vec3& opposite = v[(j + 2) % 3];
      const bool vertex_higher = N.dot(opposite - a) > 1e-9 * scaled.longestEdge();
      const detail::SegmentPair pair =
          vertex_higher ? detail::closestSegmentSegment(lo, hi, opposite, opposite) : detail::closestSegmentSegment(lo, hi, a, b);
      poly.pts[0] = pair.p;
      poly.depth[0] = N.dot(pair.q - pair.p);
      poly.count = 1;
    }
    if (!finish(poly, N, patch)) {
      // Clipping left nothing within reach: the box's deepest corner along
      // -N carries the SAT depth.
      for (int k = 0; k < 3; ++k) poly.pts[0][k] = N[k] > 0.0 ? -e[k] : e[k];
      poly.depth[0] = best.pen;
      poly.count = 1;
      finish(poly, N, patch);
    }
    if (best.kind == 0) {
      patch.feature = Feature::face();  // the support feature along n
      return PatchOutcome::kContact;
    }
    // A tilted axis: the feature and the sort key are where the box's lower
    // envelope is least over the triangle (envelopeMinimum), so that the
    // neighbour holding the deeper part is met first and voids the edge.
    double key = 0.0;
    if (owned) {  // s, Phi's global minimum
      patch.feature = Feature::face();
      patch.distance = -n_depth;
    } else if (envelopeMinimum(v, n, m, e, s, 1e-9 / scale, flat, key, patch.feature)) {
      patch.distance = key;
    } else {
      patch.feature = maskFeature(over.mask);
      patch.distance = -n_depth;
    }
    if (patch.feature.type == FeatureType::kFace) {
      // The minimum inside the triangle: the box is deepest over the face,
      // and N is a cheaper way out through one of its edges, the one whose
      // outward normal is closest to N. (The box beside a plate's edge: its
      // bottom's lowest edge under the plate, or s. Whether the plate goes
      // on beyond that edge, only the filter can tell.)
      int exit = 0;
      double out = -kInf;
      for (int k = 0; k < 3; ++k) {
        const double o = -m[k].dot(N) / std::sqrt(m[k].squaredNorm());
        if (o > out) out = o, exit = k;
      }
      patch.feature = Feature::edge(exit);
    }
    // Its stand-in, should the surface go on across the feature in this
    // face's plane (the filter checks): the face patch along n. Then the
    // tilted axis was least only because this triangle ends there (a box
    // sunk by d over a strip of it narrower than d), and pushing along it
    // would slide the box onto the neighbour, not out of the surface. The
    // box's part over this triangle is still in the surface, and the
    // neighbour's face patch is clipped to its own prism: without the
    // stand-in, that part (a corner of a box sunk into a tessellated floor)
    // had no point, and the box stood on a smaller polygon than its face.
    // Where the plane ends (a boundary edge), the tilted patch stands alone:
    // pushing a box beside a plate's edge up by its depth would pop it onto
    // the plate. For the filter's test, the push along n that a tilted axis
    // must beat.
    if (n_depth >= -reach()) {
      Polygon face;
      facePolygon(face);
      patch.face_count = keepPoints(face, n, patch.face_points, patch.face_depths);
      patch.face_normal = queryFrameNormal(n);
      patch.face_push = (1.0 - n_bias) * n_depth - 1e-6 * scale;
    }
    return PatchOutcome::kContact;
  }
};

Status checkQuery(const Box& box, const Pose& pose, const QuerySettings& settings) {
  Status s = checkBox(box, pose);
  if (!s) return s;
  s = detail::checkQuerySettings(settings);
  if (!s) return s;
  return detail::checkManifoldSettings(settings);
}

BoxNarrowphase makeNarrowphase(const Box& box, const Pose& pose, const QuerySettings& settings,
                               CandidateCoverage coverage) {
  const double scale = box.half_extents.norm();
  return {pose, box.half_extents, settings.contact_distance, scale,
          kFlat * (scale + pose.translation.cwiseAbs().maxCoeff()),
          coverage == CandidateCoverage::kPartial ? kPartialCoverageFaceBias : kFaceBias};
}

}  // namespace

Status collideBoxCandidates(const Box& box, const Pose& pose, const CandidateTriangle* candidates, std::size_t count,
                            const QuerySettings& settings, QueryScratch& scratch, std::vector<Contact>& contacts) {
  return collideBoxCandidates(box, pose, candidates, count, settings, scratch, contacts, CandidateCoverage::kComplete);
}

Status collideBoxCandidates(const Box& box, const Pose& pose, const CandidateTriangle* candidates, std::size_t count,
                            const QuerySettings& settings, QueryScratch& scratch, std::vector<Contact>& contacts,
                            CandidateCoverage coverage) {
  contacts.clear();
  if (settings.trace) settings.trace->clear();
  Status s = checkQuery(box, pose, settings);
  if (!s) return s;
  if (coverage != CandidateCoverage::kComplete && coverage != CandidateCoverage::kPartial)
    return {ErrorCode::kInvalidSettings,
            "candidate coverage " + std::to_string(static_cast<int>(coverage)) + " is none of CandidateCoverage's"};
  s = detail::checkCandidates(candidates, count);
  if (!s) return s;
  detail::manifoldContacts(makeNarrowphase(box, pose, settings, coverage), candidates, count, settings,
                           detail::candidateIdentity(settings), scratch, contacts);
  return Status::ok();
}

Status collideBox(const MeshInstance* instances, std::size_t count, const Box& box, const Pose& pose,
                  const QuerySettings& settings, QueryScratch& scratch, std::vector<Contact>& contacts) {
  contacts.clear();
  if (settings.trace) settings.trace->clear();
  Status s = checkQuery(box, pose, settings);
  if (!s) return s;
  const BoxNarrowphase narrowphase = makeNarrowphase(box, pose, settings, CandidateCoverage::kComplete);
  QueryScratch::Impl& sc = scratch.impl();
  // The rotated box's bounds, inflated by the narrowphase's reach (the
  // contact distance and round-off): a box set down exactly on a floor at
  // z = 0 under a yaw has |R|(2,2) = 1 - 1e-16, and bounds inflated by the
  // contact distance alone (0) stopped 5e-17 above the floor: no triangle
  // was gathered, and the box got no contact.
  const Vec3 half = pose.rotation.cwiseAbs() * box.half_extents + Vec3::Constant(narrowphase.reach());
  const Vec3 lo = pose.translation - half, hi = pose.translation + half;
  detail::VertexIdentity identity;
  if (settings.trace)  // the trace lists every triangle of the bounds, with its verdict
    s = detail::gatherForFilter(instances, count, lo, hi, settings.key_mode, scratch, sc.candidates, identity);
  else  // without those whose bounds the box's faces hold beyond the narrowphase's reach (its first test)
    s = detail::gatherNearBoxForFilter(instances, count, lo, hi, pose,
                                       box.half_extents + Vec3::Constant(narrowphase.reach()), settings.key_mode,
                                       scratch, sc.candidates, identity);
  if (!s) return s;
  // Checked once above, not again per stage.
  detail::manifoldContacts(narrowphase, sc.candidates.data(), sc.candidates.size(), settings, identity, scratch,
                           contacts);
  return Status::ok();
}

Status collideBox(const TriangleMesh& mesh, const Box& box, const Pose& pose, const QuerySettings& settings,
                  QueryScratch& scratch, std::vector<Contact>& contacts) {
  const MeshInstance instance{&mesh, Pose::identity()};
  return collideBox(&instance, 1, box, pose, settings, scratch, contacts);
}

}  // namespace meshcontact
