// Support shapes (general convex, hull, cylinder) vs mesh triangles.
//
// The shape is a core K swept by a ball of radius m (convex.h). Per
// triangle T the core plays the part of the sphere's centre in the
// reference's method, and m the part of its radius:
//  - separated core (the common case: resting, sliding, penetrating by less
//    than m): the closest points of K and T (our GJK distance, Gilbert-
//    Johnson-Keerthi in van den Bergen's form) give the normal u =
//    normalize(k - t) and the depth m - d; the feature is the triangle's
//    support feature along u (DESIGN.md §3). The closest-point *direction* of
//    two convex sets is unique even when the witness points are not (a core
//    face parallel to the triangle touches along a polygon and GJK may
//    return any point of it, a triangle vertex included), so the feature
//    never depends on which witness GJK happened to return.
//  - Why this removes ghosts on flat ground (the sphere's argument, reference
//    §4-5, with K for the centre): if K is above a plane tessellated by
//    triangles, the distance f(y) = dist(y, K) from a point y of the plane
//    to K is a convex function of y. A triangle whose minimizer of f
//    lies on its boundary has a neighbour across that edge (or vertex) at
//    least as close, and strictly closer unless the closest vector is
//    already the plane normal; the face triangle under K's lowest point
//    voids its edges and vertices, and the sorted, unconditionally voiding
//    pass carries that through the rest. Nothing depends on the triangles'
//    shapes or on K's.
//  - Two exact face tests avoid trusting GJK's convergence for the triangle
//    under the shape: K's lowest point along -n lies over T's interior (then
//    the closest vector is exactly along n), or GJK's distance equals K's
//    height above T's plane (the plane's distance is a lower bound of the
//    triangle's, reached only along n).
//  - Cost: one separating-axis test per triangle (the axis from the
//    triangle's point nearest the shape's center; one support call) rejects
//    most candidates of a resting shape; GJK (in a frame at the triangle,
//    early exit once its lower bound passes the reach) runs on the few left.
//  - Deep penetration (K touches a triangle): the whole query is redone with
//    K scaled toward the shape's center() by 1/2, 1/4, then 0 (the center
//    point, i.e. exactly the sphere's rule), the first scale that clears K of
//    every candidate. The same scaled K serves every triangle, so the
//    argument above still holds; each contact's depth and point come from
//    the full shape along the normal (the separation of the two projections
//    on it, as in SAT). Two details keep it exact on flat ground:
//    (a) the triangle under the full shape's deepest point owns a face patch
//        with that point (face-ownership rule: the scaled core's face
//        triangle may be another one, whose patch alone would understate
//        the depth), and so does, once the scaled core is found clear of
//        it, any triangle under the shape's supporting face; but not a
//        triangle the shape leaves sooner by moving within its plane (a
//        cliff's wall under a box overhanging the brink: the ledge holds
//        it);
//    (b) a triangle within the scaled core's reach but whose projection
//        along its normal does not reach the shape still goes through the
//        filter, as a patch with no point: it is voided, and voids, in its
//        turn. Its trace entry reads as a contact with no point. Such a
//        triangle may lie up to (1 - s) * coreRadius() beyond the shape's
//        box (the first gather's): each pass gathers its own candidates
//        (CandidateSource, runCandidates), or the contacts would depend on
//        what the midphase gave beyond that box (a sharp box hull in a bowl
//        kept or lost an edge contact 0.031 deep by one such triangle).
//    A deeper pass that some triangle certainly voids (the scaled core
//    crosses the triangle's plane inside it: the test that stands in for
//    GJK there) is not run. The first pass notes such passes from the
//    support points it already has, and checks the triangles it never
//    reached; on fcl_bench's random poses that cut a cylinder query by 5-24%
//    (the most along a path), a hull's by 2-11%. The tests compare against
//    GJK on every triangle and every pass (convex_passes.h): the same
//    contacts, bit for bit.

#include "meshcontact/convex.h"

#include "capsule_segment.h"
#include "convex_passes.h"
#include "convex_patch.h"
#include "gather.h"
#include "gjk_distance.h"
#include "hull3d.h"
#include "manifold_reduction.h"
#include "meshcontact/triangle.h"
#include "scaled_edges.h"
#include "scratch.h"
#include "validate.h"
#include "voided_features.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace meshcontact {

SupportShape::~SupportShape() = default;

Vec3 SupportShape::center() const {
  Vec3 sum = Vec3::Zero();
  for (int k = 0; k < 3; ++k) sum += support(Vec3::Unit(k)) + support(-Vec3::Unit(k));
  return sum / 6.0;
}

double SupportShape::coreRadius() const {
  const Vec3 c = center();
  Vec3 lo, hi;
  for (int k = 0; k < 3; ++k) {
    hi[k] = support(Vec3::Unit(k))[k];
    lo[k] = support(-Vec3::Unit(k))[k];
  }
  // The farthest corner, coordinate by coordinate (NaN stays NaN).
  const Vec3 far = (hi - c).cwiseAbs().cwiseMax((lo - c).cwiseAbs());
  return far.norm();
}

bool SupportShape::nearestCorePoint(const Vec3& /*x*/, Vec3& /*out*/) const { return false; }

Vec3 SupportShape::shapeSupport(const Vec3& d) const {
  return support(d) + margin() * normalizedOr(d, Vec3::Zero());
}

namespace {

// Supporting-face slack: points within this slope times the shape's size of
// the extreme height join the face (about 3 degrees of tilt).
constexpr double kFaceSlope = 0.05;
// ConvexHull::supportFace: a point joins only from a face facing the
// direction within 60 degrees (or level with the extreme point).
constexpr double kFacingCosine = 0.5;

// Points seen along the unit vector u: their coordinates in the plane
// normal to u, about `origin` (axes: a unit vector normal to u, and u
// cross it; counter-clockwise about u). ConvexHull::supportFace (its
// outline's sectors), overVertex and overEdge.
struct ViewAlong {
  Vec3 x_axis, y_axis, origin;
  ViewAlong(const Vec3& u, const Vec3& o)
      : x_axis(normalizedOr(u.unitOrthogonal(), Vec3::UnitX())), y_axis(u.cross(x_axis)), origin(o) {}
  detail::FacePoint operator()(const Vec3& p) const {
    detail::FacePoint f;
    f.p = p;
    f.x = x_axis.dot(p - origin);
    f.y = y_axis.dot(p - origin);
    return f;
  }
};

// The largest explicit margin accepted, as a fraction of the inradius: the
// core keeps at least half the shape's thickness.
constexpr double kMaxMarginFraction = 0.5;

}  // namespace

// ---------------------------------------------------------------------------
// ConvexHull

Status ConvexHull::build(const std::vector<Vec3>& points, double margin) {
  points_.clear();
  core_.clear();
  face_normals_.clear();
  point_face_begin_.clear();
  point_faces_.clear();
  diameter_ = inradius_ = margin_ = 0.0;
  centroid_.setZero();
  if (points.size() < 4)
    return {ErrorCode::kInvalidShape,
            "convex hull needs at least 4 points, got " + std::to_string(points.size())};
  for (std::size_t i = 0; i < points.size(); ++i)
    if (!detail::inRange(points[i]))
      return {ErrorCode::kInvalidShape, "convex hull point " + std::to_string(i) +
                                            " is not finite or beyond +-1e50: " + detail::describe(points[i])};
  Vec3 lo = points[0], hi = points[0];
  for (const Vec3& p : points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const double diameter = (hi - lo).norm();  // within sqrt(3) of the true diameter
  const double tol = 1e-9 * diameter;
  if (!(diameter > 0.0)) return {ErrorCode::kInvalidShape, "convex hull points are all coincident"};
  for (std::size_t i = 0; i < points.size(); ++i)
    for (std::size_t j = i + 1; j < points.size(); ++j)
      if ((points[i] - points[j]).norm() <= tol)
        return {ErrorCode::kInvalidShape, "convex hull points " + std::to_string(i) + " and " + std::to_string(j) +
                                              " coincide (closer than 1e-9 of the hull's size): " +
                                              detail::describe(points[i])};
  // Volume: the farthest point from p0, then from the line, then from the plane.
  const Vec3& p0 = points[0];
  std::size_t i1 = 0;
  for (std::size_t i = 1; i < points.size(); ++i)
    if ((points[i] - p0).squaredNorm() > (points[i1] - p0).squaredNorm()) i1 = i;
  const Vec3 axis = (points[i1] - p0).normalized();
  std::size_t i2 = 0;
  double best = -1.0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double d = (points[i] - p0).cross(axis).norm();
    if (d > best) best = d, i2 = i;
  }
  if (!(best > tol)) return {ErrorCode::kInvalidShape, "convex hull points are collinear: the hull has no volume"};
  const Vec3 normal = axis.cross(points[i2] - p0).normalized();
  double height = 0.0;
  for (const Vec3& p : points) height = std::max(height, std::abs(normal.dot(p - p0)));
  if (!(height > tol)) return {ErrorCode::kInvalidShape, "convex hull points are coplanar: the hull has no volume"};

  // Face planes, relative to an interior point: first the mean of the
  // points (a point set that spans a volume holds its mean inside its hull),
  // then the hull's volume centroid (below), and the planes again about it.
  Vec3 centroid = Vec3::Zero();
  for (const Vec3& p : points) centroid += p;
  centroid /= static_cast<double>(points.size());
  std::vector<Vec3> local(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) local[i] = points[i] - centroid;
  // The plane tests multiply lengths: at the smallest scales they underflow
  // and find no volume where there is one (a cube of side 1e-85), which is
  // then said as it is, not as coplanar points.
  const auto noPlanes = [diameter]() -> Status {
    if (diameter < 1e-75)
      return {ErrorCode::kInvalidShape, "convex hull points span only " + detail::describe(diameter) +
                                            ": below the convex shapes' supported scale (~1e-80, geometry.h), "
                                            "where the hull's plane tests underflow"};
    return {ErrorCode::kInvalidShape, "convex hull points are (nearly) coplanar: the hull has no volume"};
  };
  std::vector<detail::HullPlane> planes;
  if (!detail::hullPlanes(local.data(), local.size(), 1e-10 * diameter, planes)) return noPlanes();
  // The center (the point the core shrinks toward under deep penetration)
  // and the inradius (the automatic margin's scale) are the hull's, not the
  // point set's: points on a face (allowed, and dropped) pulled the mean
  // toward that face, and a cube given with 81 points on its bottom face had
  // its center 0.045 above that face and a margin a tenth of the plain
  // cube's, and fell through a floor it sank into by 0.05. The volume
  // centroid: the pyramids from the mean to each face, each face a fan of
  // triangles over its vertices (the hull's vertices on it, the points on
  // three planes or more, in angular order; a face's other points would make
  // the fan a star).
  // A point lies on a face plane to within 1e-9 of the diameter; the hull's
  // vertices are the points on at least three of its (distinct) face
  // planes: points inside, on a face or along an edge never support
  // anything alone.
  const auto onPlane = [&](const detail::HullPlane& f, const Vec3& p) {
    return f.normal.dot(p) - f.offset >= -1e-9 * diameter;
  };
  const auto hullVertices = [&]() {
    std::vector<Vec3> vertices;
    for (const Vec3& p : local) {
      int on = 0;
      for (const detail::HullPlane& f : planes) on += onPlane(f, p);
      if (on >= 3) vertices.push_back(p);
    }
    return vertices;
  };
  {
    const std::vector<Vec3> vertices = hullVertices();
    Vec3 moment = Vec3::Zero();
    double volume = 0.0;
    std::vector<std::pair<double, Vec3>> ring;
    std::vector<Vec3> on;
    for (const detail::HullPlane& f : planes) {
      ring.clear();
      on.clear();
      const Vec3 u = f.normal.unitOrthogonal(), w = f.normal.cross(u);
      Vec3 mid = Vec3::Zero();
      for (const Vec3& p : vertices)
        if (onPlane(f, p)) on.push_back(p), mid += p;
      if (on.size() < 3) continue;
      mid /= static_cast<double>(on.size());
      for (const Vec3& p : on) ring.emplace_back(std::atan2(w.dot(p - mid), u.dot(p - mid)), p);
      std::sort(ring.begin(), ring.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
      for (std::size_t i = 0; i < ring.size(); ++i) {
        // The tetrahedron (mean, mid, ring[i], ring[i + 1]): its volume is
        // |det| / 6 (the mean, the origin here, is inside; points along the
        // face's edges add slivers of zero volume).
        const Vec3& a = ring[i].second;
        const Vec3& b = ring[(i + 1) % ring.size()].second;
        const double v = std::abs(mid.dot(a.cross(b))) / 6.0;
        volume += v;
        moment += v * (mid + a + b) / 4.0;
      }
    }
    if (volume > 0.0 && (moment / volume).allFinite()) {
      const Vec3 shift = moment / volume;
      centroid += shift;
      for (Vec3& p : local) p -= shift;
      std::vector<detail::HullPlane> recentred;
      if (!detail::hullPlanes(local.data(), local.size(), 1e-10 * diameter, recentred)) return noPlanes();
      planes = std::move(recentred);
    }
  }
  double inradius = std::numeric_limits<double>::infinity();
  for (const detail::HullPlane& f : planes) inradius = std::min(inradius, f.offset);
  if (!(inradius > tol))
    return {ErrorCode::kInvalidShape, "convex hull is too thin around its centroid (inradius " +
                                          detail::describe(inradius) + ")"};
  double m = kDefaultMarginFraction * inradius;
  if (margin != kAutoMargin) {
    if (!std::isfinite(margin) || margin < 0.0 || margin > kMaxMarginFraction * inradius)
      return {ErrorCode::kInvalidShape, "convex hull margin must be kAutoMargin or in [0, " +
                                            detail::describe(kMaxMarginFraction * inradius) +
                                            "] (half the inradius), got " + detail::describe(margin)};
    m = margin;
  }

  // The hull's vertices about the centroid.
  const std::vector<Vec3> boundary = hullVertices();
  std::vector<Vec3> core;
  // Each hull vertex's core point (an index into `core`), or -1 where the
  // core is not one point per vertex (Q's own vertices, below).
  std::vector<int> core_of(boundary.size(), -1);
  if (m > 0.0) {
    // The inner parallel body Q = {x : n_f . x <= o_f - m} (every face plane
    // moved in by m: Q (+) ball(m) is the hull with its edges and corners
    // rounded). Its vertices are the duals of the facets of the hull of the
    // points y_f = n_f / (o_f - m) (polar duality about the centroid, an
    // interior point: x is in Q iff x . y_f <= 1 for all f). Any supporting
    // plane (N, D) of the y_f maps to x = N / D with x . y_f <= 1, a point of
    // Q, so a dual facet computed slightly wrong still gives a point inside
    // Q, never outside: the rounded hull never pokes out of the hull.
    std::vector<Vec3> dual(planes.size());
    Vec3 dlo = Vec3::Constant(std::numeric_limits<double>::infinity()), dhi = -dlo;
    for (std::size_t f = 0; f < planes.size(); ++f) {
      dual[f] = planes[f].normal / (planes[f].offset - m);
      dlo = dlo.cwiseMin(dual[f]);
      dhi = dhi.cwiseMax(dual[f]);
    }
    std::vector<detail::HullPlane> dual_planes;
    std::vector<Vec3> q_vertices;
    if (detail::hullPlanes(dual.data(), dual.size(), 1e-10 * (dhi - dlo).norm(), dual_planes)) {
      for (const detail::HullPlane& g : dual_planes) {
        if (!(g.offset > 0.0)) continue;
        Vec3 x = g.normal / g.offset;
        // Rounding: pull x toward the centroid onto Q if it pokes out.
        double t = 1.0;
        for (const detail::HullPlane& f : planes) {
          const double h = f.normal.dot(x);
          if (h > f.offset - m) t = std::min(t, (f.offset - m) / h);
        }
        if ((t * x).allFinite()) q_vertices.push_back(t * x);
      }
    }
    // Q has a vertex per triple of face planes meeting at a hull vertex:
    // 2F - 4 of them for F faces (116 for a random 32-point hull, whose
    // vertices each split into a small cluster). The core keeps one point
    // per hull vertex, the point of Q nearest to it (GJK against Q's
    // vertices: exact for a polytope). Still inside Q, so still inside the
    // hull once rounded; exactly Q where hull vertices are simple (a box);
    // elsewhere its faces lie within a few percent of m of the hull's
    // (measured: 3% of m on random 32-point hulls), for a quarter of the
    // support cost.
    if (q_vertices.size() >= 4) {
      const auto q_support = [&](const Vec3& d) {
        std::size_t best = 0;
        for (std::size_t i = 1; i < q_vertices.size(); ++i)
          if (q_vertices[i].dot(d) > q_vertices[best].dot(d)) best = i;
        return q_vertices[best];
      };
      for (std::size_t i = 0; i < boundary.size(); ++i) {
        const Vec3& v = boundary[i];
        const auto at_v = [&](const Vec3&) { return v; };
        const detail::GjkResult g = detail::gjkDistance(q_support, at_v, Vec3(-v), diameter);
        const Vec3 x = g.status == detail::GjkStatus::kSeparated ? g.point_a : v;
        if (!x.allFinite()) continue;
        int same = -1;
        for (std::size_t j = 0; j < core.size() && same < 0; ++j)
          if ((x - core[j]).norm() <= 1e-9 * diameter) same = static_cast<int>(j);
        if (same < 0) {
          same = static_cast<int>(core.size());
          core.push_back(x);
        }
        core_of[i] = same;
      }
      if (core.size() < 4) {
        core = q_vertices;
        std::fill(core_of.begin(), core_of.end(), -1);
      }
    }
    if (core.size() < 4) {
      // The dual hull failed (it should not): scale the hull about the
      // centroid by 1 - m / inradius, which moves every face plane in by at
      // least m (Q contains this core).
      core.clear();
      const double k = 1.0 - m / inradius;
      for (std::size_t i = 0; i < boundary.size(); ++i) {
        core.push_back(k * boundary[i]);
        core_of[i] = static_cast<int>(i);
      }
    }
  } else {
    core = boundary;  // a sharp hull is its own core
    for (std::size_t i = 0; i < boundary.size(); ++i) core_of[i] = static_cast<int>(i);
  }
  // Each core point's faces (supportFace): a core point is on the faces its
  // hull vertex is on (the core's faces are the hull's moved in by m, with
  // the same normals); without that correspondence, on those it lies on
  // within rounding once moved in.
  std::vector<Vec3> face_normals;
  std::vector<std::vector<std::uint32_t>> faces_of(core.size());
  const bool mapped = std::find(core_of.begin(), core_of.end(), -1) == core_of.end();
  for (const detail::HullPlane& f : planes) {
    const std::uint32_t index = static_cast<std::uint32_t>(face_normals.size());
    bool any = false;
    if (mapped) {
      for (std::size_t i = 0; i < boundary.size(); ++i)
        if (onPlane(f, boundary[i])) {
          std::vector<std::uint32_t>& list = faces_of[static_cast<std::size_t>(core_of[i])];
          if (list.empty() || list.back() != index) list.push_back(index);
          any = true;
        }
    } else {
      for (std::size_t j = 0; j < core.size(); ++j)
        if (f.normal.dot(core[j]) - (f.offset - m) >= -1e-6 * diameter) {
          faces_of[j].push_back(index);
          any = true;
        }
    }
    if (any) face_normals.push_back(f.normal);
  }
  std::vector<std::uint32_t> point_face_begin{0}, point_faces;
  for (const std::vector<std::uint32_t>& list : faces_of) {
    point_faces.insert(point_faces.end(), list.begin(), list.end());
    point_face_begin.push_back(static_cast<std::uint32_t>(point_faces.size()));
  }
  for (Vec3& x : core) x += centroid;

  points_ = points;
  core_ = std::move(core);
  face_normals_ = std::move(face_normals);
  point_face_begin_ = std::move(point_face_begin);
  point_faces_ = std::move(point_faces);
  centroid_ = centroid;
  diameter_ = diameter;
  inradius_ = inradius;
  margin_ = m;
  core_radius_ = 0.0;
  for (const Vec3& x : core_) core_radius_ = std::max(core_radius_, (x - centroid).norm());
  return Status::ok();
}

Vec3 ConvexHull::support(const Vec3& d) const {
  // Linear scan: for a few dozen points it beats hill climbing, which needs
  // adjacency and branches on every step. Ties keep the first point.
  std::size_t best = 0;
  double best_h = core_[0].dot(d);
  for (std::size_t i = 1; i < core_.size(); ++i) {
    const double h = core_[i].dot(d);
    if (h > best_h) best_h = h, best = i;
  }
  return core_[best];
}

int ConvexHull::supportFace(const Vec3& d, Vec3* out) const {
  const Vec3 u = normalizedOr(d, Vec3::UnitZ());
  std::size_t extreme = 0;
  double top = -std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < core_.size(); ++i) {
    const double h = core_[i].dot(u);
    if (h > top) top = h, extreme = i;
  }
  const double floor = top - kFaceSlope * diameter_;
  // Which points join the extreme one: those within the slope times the
  // size below it that lie on a face facing u (within 60 degrees), and the
  // other ends of the extreme point's edges level with it to the slope (an
  // edge normal to u between steeper faces: a wedge's edge). Not a point
  // of the far side: of a 2 x 2 x 0.1 plate lying flat (the window holds its
  // top face), the top corners of the side facing down by a fraction of a
  // degree lie just outside the bottom ones seen along u, and the plane
  // projection (clippedSupportFace) kept them in their place, 0.1 above the
  // floor: dropped, and the plate was held at its one deepest point.
  const auto joins = [&](std::uint32_t i, double h) {
    if (i == extreme) return true;
    if (!(h >= floor)) return false;
    const std::uint32_t* faces = point_faces_.data() + point_face_begin_[i];
    const std::uint32_t* faces_end = point_faces_.data() + point_face_begin_[i + 1];
    for (const std::uint32_t* f = faces; f != faces_end; ++f)
      if (face_normals_[*f].dot(u) >= kFacingCosine) return true;
    // Faces on both (ascending lists): 2 for an edge between them.
    const std::uint32_t* e = point_faces_.data() + point_face_begin_[extreme];
    const std::uint32_t* e_end = point_faces_.data() + point_face_begin_[extreme + 1];
    int shared = 0;
    for (const std::uint32_t* f = faces; f != faces_end && e != e_end;) {
      if (*f < *e) {
        ++f;
      } else if (*e < *f) {
        ++e;
      } else {
        ++shared, ++f, ++e;
      }
    }
    if (shared < 2) return false;
    const Vec3 along = core_[i] - core_[extreme];
    const double drop = top - h;
    return drop <= kFaceSlope * (along + drop * u).norm();
  };
  // The joining points' indices, ascending: all of them when there are at
  // most kMaxFacePoints. More (a 32-gon prism standing on its cap): the
  // deepest of them were the rim's one half, level to rounding, and the
  // contacts held the prism on that half (their mean 0.1 to 0.29 off its
  // axis at 85 of 200 placements on a floor). Then the outline's points: in
  // each of kMaxFacePoints sectors about the points' mean (seen along u),
  // the farthest from it (ties by index), the extreme point in its own.
  std::uint32_t picked[kMaxFacePoints];
  int count = 0;
  Vec3 mean = Vec3::Zero();
  for (std::uint32_t i = 0; i < core_.size(); ++i) {
    if (!joins(i, core_[i].dot(u))) continue;
    if (count < kMaxFacePoints) picked[count] = i;
    ++count;
    mean += core_[i];
  }
  if (count > kMaxFacePoints) {
    mean /= count;
    const ViewAlong view(u, mean);
    double reach[kMaxFacePoints];
    constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
    for (int k = 0; k < kMaxFacePoints; ++k) picked[k] = kNone, reach[k] = -1.0;
    for (std::uint32_t i = 0; i < core_.size(); ++i) {
      if (!joins(i, core_[i].dot(u))) continue;
      const detail::FacePoint seen = view(core_[i]);
      const double x = seen.x, y = seen.y;
      const double angle = std::atan2(y, x);  // [-pi, pi]
      const int k = std::min(kMaxFacePoints - 1, static_cast<int>((angle + M_PI) * (kMaxFacePoints / (2.0 * M_PI))));
      if (picked[k] == extreme) continue;
      const double d = std::sqrt(x * x + y * y);
      if (i == extreme || d > reach[k]) picked[k] = i, reach[k] = d;
    }
    count = static_cast<int>(std::remove(picked, picked + kMaxFacePoints, kNone) - picked);
    std::sort(picked, picked + count);
  }
  // Deepest first (ties by index): insertion into a small sorted array, no
  // allocation.
  double heights[kMaxFacePoints];
  for (int n = 0; n < count; ++n) {
    const Vec3& p = core_[picked[n]];
    const double h = p.dot(u);
    int at = n;
    while (at > 0 && heights[at - 1] < h) --at;
    for (int k = n; k > at; --k) {
      heights[k] = heights[k - 1];
      out[k] = out[k - 1];
    }
    heights[at] = h;
    out[at] = p;
  }
  return count;
}

Status ConvexHull::validate() const {
  if (!isBuilt()) return {ErrorCode::kInvalidShape, "convex hull is empty: build() has not succeeded"};
  return Status::ok();
}

// ---------------------------------------------------------------------------
// CylinderShape

CylinderShape::CylinderShape(const Cylinder& cylinder, double margin) : cylinder_(cylinder) {
  const double smallest = std::min(cylinder.radius, cylinder.half_length);
  if (margin == kAutoMargin) {
    margin_ = std::isfinite(smallest) && smallest > 0.0 ? kDefaultMarginFraction * smallest : 0.0;
  } else {
    margin_ = margin;
    margin_in_range_ = std::isfinite(margin) && margin >= 0.0 && margin <= kMaxMarginFraction * smallest;
    if (!margin_in_range_) margin_ = 0.0;
  }
  core_radius_ = cylinder.radius - margin_;
  core_half_length_ = cylinder.half_length - margin_;
}

double CylinderShape::coreRadius() const { return std::hypot(core_radius_, core_half_length_); }

Vec3 CylinderShape::support(const Vec3& d) const {
  const double r = core_radius_, h = core_half_length_;
  // sqrt, not hypot (5x slower here): directions come from GJK and the
  // queries, far from overflow; an underflowing x, y is the axis case.
  const double rxy = std::sqrt(d.x() * d.x() + d.y() * d.y());
  const double z = d.z() >= 0.0 ? h : -h;
  if (!(rxy > 0.0)) return Vec3(0.0, 0.0, z);  // along the axis: the cap's centre is extreme
  return Vec3(r * d.x() / rxy, r * d.y() / rxy, z);
}

int CylinderShape::supportFace(const Vec3& d, Vec3* out) const {
  const double r = core_radius_, h = core_half_length_;
  const Vec3 u = normalizedOr(d, Vec3::UnitZ());
  const double along = std::abs(u.z());
  const double z = u.z() >= 0.0 ? h : -h;
  if (along >= std::sqrt(1.0 - kFaceSlope * kFaceSlope)) {
    // The cap: 8 rim points (an inscribed octagon, see convex.h).
    const double c = std::sqrt(0.5) * r;
    const double xy[8][2] = {{r, 0}, {c, c}, {0, r}, {-c, c}, {-r, 0}, {-c, -c}, {0, -r}, {c, -c}};
    for (int k = 0; k < 8; ++k) out[k] = Vec3(xy[k][0], xy[k][1], z);
    return 8;
  }
  if (along <= kFaceSlope) {
    // Lying on its side: the segment of the side that is extreme.
    const double rxy = std::hypot(u.x(), u.y());
    const Vec3 rim(r * u.x() / rxy, r * u.y() / rxy, 0.0);
    out[0] = rim - Vec3(0, 0, h);
    out[1] = rim + Vec3(0, 0, h);
    return 2;
  }
  out[0] = support(d);
  return 1;
}

bool CylinderShape::nearestCorePoint(const Vec3& x, Vec3& out) const {
  const double r = core_radius_, h = core_half_length_;
  const double rxy = std::sqrt(x.x() * x.x() + x.y() * x.y());
  const double z = std::clamp(x.z(), -h, h);
  if (rxy <= r) {
    out = Vec3(x.x(), x.y(), z);
  } else {
    const double k = r / rxy;
    out = Vec3(k * x.x(), k * x.y(), z);
  }
  return true;
}

Status CylinderShape::validate() const {
  const Cylinder& c = cylinder_;
  if (!detail::inRange(c.radius) || !(c.radius > 0.0))
    return {ErrorCode::kInvalidShape, "cylinder radius must be finite and > 0, got " + detail::describe(c.radius)};
  if (!detail::inRange(c.half_length) || !(c.half_length > 0.0))
    return {ErrorCode::kInvalidShape,
            "cylinder half_length must be finite and > 0, got " + detail::describe(c.half_length)};
  if (!margin_in_range_)
    return {ErrorCode::kInvalidShape, "cylinder margin must be kAutoMargin or in [0, " +
                                          detail::describe(kMaxMarginFraction * std::min(c.radius, c.half_length)) +
                                          "] (half of min(radius, half_length))"};
  return Status::ok();
}

// ---------------------------------------------------------------------------
// Narrowphase

namespace {

// The scales of the core about its center, pass by pass (convex.h, deep
// penetration): the core itself, halved, quartered, then the center alone.
constexpr double kPassScales[] = {1.0, 0.5, 0.25, 0.0};
// Round-off on lengths, times the query's magnitude: the shape's size plus
// its distance from the origin, which bound the cancellation in placing the
// core and in moving a triangle to it (the box path's kFlat, box.cpp).
// Pairs this far beyond the contact distance are at it: the narrowphase's
// reach tests and the midphase's bounds take it on, and the depths given
// back are clamped to -contact_distance. The core is built by rounding (a
// box-shaped hull's corners moved in by the margin), so a shape set down
// exactly on a floor sits ~1e-17 above or below its nominal place; with a
// reach of exactly margin + contact distance, 743 of 1,000 box-shaped hulls
// and 524 of 1,000 cylinders so set down got no contact at all
// (ConvexScenes.SetDownExactlyOnAFloorTouches), and a dConvex cube fell for
// a step in ODE and came back up at 1.1 cm/s.
constexpr double kRoundOff = 1e-14;
double roundOffReach(double size, const Vec3& center) { return kRoundOff * (size + center.cwiseAbs().maxCoeff()); }
// The deeper passes that the first can prove void: bit k for kPassScales[k + 1].
constexpr int kSkippablePasses = 2;
constexpr int kAllSkippable = (1 << kSkippablePasses) - 1;

// A point of the core moved to the core scaled by s about `center`.
inline Vec3 scaledAbout(const Vec3& center, double s, const Vec3& p) { return center + s * (p - center); }

struct Counters {
  bool support_not_finite = false;
  bool core_intersects = false;  // this pass must be redone with a smaller core
  // The candidate that set core_intersects, and the deeper passes (scales
  // 1/2: bit 0, 1/4: bit 1) found certainly void on the way
  // (ConvexNarrowphase::crossingBits): runCandidates skips them.
  const CandidateTriangle* intersecting = nullptr;
  int void_deeper = 0;
  bool certainlyVoid(double scale) const {
    for (int k = 0; k < kSkippablePasses; ++k)
      if (scale == kPassScales[k + 1] && (void_deeper >> k & 1)) return true;
    return false;
  }
  // Collision checking (ConvexNarrowphase::predict): the full shape was
  // found meeting the triangle, and then, in a deeper pass, a contact.
  bool full_meets = false;
  bool predicted_contact = false;
};

// The core in the query frame, scaled by `scale` about `center`.
struct PlacedCore {
  const SupportShape* shape;
  const Mat3* rotation;
  Vec3 translation;
  Vec3 center;
  double scale;
  Counters* counters;

  Vec3 full(const Vec3& d) const {
    const Vec3 p = *rotation * shape->support(rotation->transpose() * d) + translation;
    if (!p.allFinite()) {
      counters->support_not_finite = true;
      return center;
    }
    return p;
  }
  Vec3 operator()(const Vec3& d) const {
    const Vec3 p = full(d);
    return scale == 1.0 ? p : scaledAbout(center, scale, p);
  }
  // The scaled core's point nearest to x, when the shape gives its core's
  // (SupportShape::nearestCorePoint): the scaling about the center is a
  // similarity, so it maps nearest points to nearest points.
  bool nearest(const Vec3& x, Vec3& out) const {
    if (scale == 0.0) {
      out = center;
      return true;
    }
    const Vec3 y = scale == 1.0 ? x : Vec3(center + (x - center) / scale);
    Vec3 local;
    if (!shape->nearestCorePoint(rotation->transpose() * (y - translation), local)) return false;
    const Vec3 p = *rotation * local + translation;
    out = scale == 1.0 ? p : scaledAbout(center, scale, p);
    return true;
  }
};

struct TriangleSupport {
  const Vec3* v;
  Vec3 operator()(const Vec3& d) const {
    const double h0 = v[0].dot(d), h1 = v[1].dot(d), h2 = v[2].dot(d);
    if (h0 >= h1 && h0 >= h2) return v[0];
    return h1 >= h2 ? v[1] : v[2];
  }
};

// Whether the shape gives its core's nearest points (asked once per query:
// the answer is the function's).
bool givesNearestCorePoints(const SupportShape& shape) {
  Vec3 unused;
  return shape.nearestCorePoint(Vec3::Zero(), unused);
}

// The test nearestPairByProjection accepts its pair by: GJK's own
// (gjk_distance.h) with 10 times the relative gap its caller asks of GJK.
// On a curved core GJK stalls on rounding at about that gap (it ends by
// "no progress", not by its test; the rim of a cylinder against an edge:
// 1e-9 to 1e-8 after ~30 iterations), so the pairs accepted are no less
// exact than the ones GJK returns there. With GJK's gap itself, 4% of a
// resting cylinder's projected pairs failed the test on rounding alone and
// went on to GJK as well (~30 iterations each): 5.3 against 4.4 us per
// query (shapes_bench, the two run in turn).
constexpr double kProjectionGapFactor = 10.0;

// A pair of closest points found by projection (nearestPairByProjection).
struct ProjectedPair {
  Vec3 on_core, on_triangle;
  double distance = 0.0;
  bool beyond = false;
  // As gjkDistance would report it (separated; v = on_core - on_triangle).
  detail::GjkResult asGjkResult() const {
    detail::GjkResult r;
    r.status = detail::GjkStatus::kSeparated;
    r.distance = distance;
    r.point_a = on_core;
    r.point_b = on_triangle;
    r.v = on_core - on_triangle;
    r.beyond = beyond;
    return r;
  }
};

// The closest points of the core K and a triangle T by projections, in
// place of GJK, for a shape that gives its core's nearest points
// (SupportShape::nearestCorePoint).
//  1. Two rounds of alternating projections from `start` (a core point:
//     the support along -n) give a core point x and the triangle's point q
//     nearest it, with q's feature. The support of K - T along -(x - q)
//     bounds the distance from below: beyond max_distance, done (as GJK's
//     early exit; a third of the candidates that get this far under a
//     resting cylinder).
//  2. A vertex is its own answer. On an edge p0 + t e, half the squared
//     distance to K is convex in t and its slope, (s - nearest(s)) . e at
//     s = p0 + t e, continuous and nondecreasing: its root is bracketed
//     around q's parameter and found by Brent's method. A face: false (GJK
//     decides; the face whose interior holds the core's lowest point, in
//     front of its plane, never gets here).
//  3. The pair (nearest(s), s) passes GJK's test (kProjectionGapFactor):
//     with v = x - s and w the support of K - T along -v, |v|^2 - v . w
//     within that gap of |v|^2. This holds only within that gap of the
//     closest pair, whatever led to it: a wrong feature or a poor root
//     costs time (GJK then runs), never accuracy.
// False (GJK then decides): no projection, a face, a pair within
// `touching` (GJK tells touching from intersecting), anything not finite,
// or the test failed. On success `out` is the pair, its distance, and
// `beyond` by GJK's rule (the lower bound v . w / |v| beyond
// max_distance).
bool nearestPairByProjection(const PlacedCore& core, const Vec3 tri[3], const Vec3& start,
                             const detail::GjkSettings& settings, double touching, ProjectedPair& out) {
  const double touching2 = touching * touching;
  // v . w, w the support of K - T along -v: GJK's lower bound of the
  // distance is that over |v|; beyond max_distance by GJK's rule.
  const auto supportGap = [&](const Vec3& v) { return v.dot(Vec3(core(Vec3(-v)) - TriangleSupport{tri}(v))); };
  const auto beyondReach = [&](double vw, double v2) {
    return vw > 0.0 && vw * vw > settings.max_distance * settings.max_distance * v2;
  };
  Vec3 x = start;
  ClosestPoint q{};
  for (int round = 0; round < 2; ++round) {
    q = closestPointOnTriangle(x, tri[0], tri[1], tri[2]);
    if (!core.nearest(q.point, x)) return false;
  }
  q = closestPointOnTriangle(x, tri[0], tri[1], tri[2]);
  {  // 1: beyond reach?
    const Vec3 v = x - q.point;
    const double v2 = v.squaredNorm();
    if (v2 > touching2 && std::isfinite(v2)) {
      const double vw = supportGap(v);
      if (core.counters->support_not_finite) return false;
      if (beyondReach(vw, v2)) {
        out.on_core = x;
        out.on_triangle = q.point;
        out.distance = std::sqrt(v2);  // an upper bound, as GJK's
        out.beyond = true;
        return true;
      }
    }
  }
  // 2: the triangle's point.
  Vec3 on_triangle;
  if (q.feature.type == FeatureType::kVertex) {
    on_triangle = tri[q.feature.index];
  } else if (q.feature.type == FeatureType::kEdge) {
    const Vec3& p0 = tri[q.feature.index];
    const Vec3 e = tri[(q.feature.index + 1) % 3] - p0;
    // The slope of half the squared distance (the same root); NaN if the
    // shape declines this point (the test below then fails).
    Vec3 near;
    const auto slope = [&](double t) {
      const Vec3 s = p0 + t * e;
      if (!core.nearest(s, near)) return std::numeric_limits<double>::quiet_NaN();
      return (s - near).dot(e);
    };
    // The bracket: 1/64 of the edge around q (where the projections led),
    // doubled toward the root until it holds it or meets an end.
    const double guess = std::clamp((q.point - p0).dot(e) / e.squaredNorm(), 0.0, 1.0);
    double width = 0x1p-6;
    double lo = std::max(0.0, guess - width), hi = std::min(1.0, guess + width);
    double slope_lo = slope(lo), slope_hi = slope(hi);
    while (slope_lo > 0.0 && lo > 0.0) {  // the root is below lo
      hi = lo, slope_hi = slope_lo;
      width *= 2.0;
      lo = std::max(0.0, lo - width);
      slope_lo = slope(lo);
    }
    while (slope_hi < 0.0 && hi < 1.0) {  // above hi
      lo = hi, slope_lo = slope_hi;
      width *= 2.0;
      hi = std::min(1.0, hi + width);
      slope_hi = slope(hi);
    }
    double t;
    if (!(slope_lo < 0.0)) {
      t = lo;  // the first vertex, or a zero slope at lo (not finite: the test below fails)
    } else if (!(slope_hi > 0.0)) {
      t = hi;
    } else {
      // The slope's rounding: its factors are differences of points within
      // ~|p0| + |e| + |x| of the origin (the triangle's first vertex), each
      // within a few ulps. Below it the sign says nothing more.
      const double noise = 0x1p-44 * (p0.cwiseAbs().maxCoeff() + e.cwiseAbs().maxCoeff() + x.cwiseAbs().maxCoeff()) *
                           e.cwiseAbs().sum();
      // Brent's zero finder (Brent, "Algorithms for Minimization without
      // Derivatives", 1973, ch. 4): b the best point, [b, c] the bracket, a
      // the previous b; inverse quadratic or secant steps, bisection when
      // they would not shrink the bracket fast enough. The slope is only
      // piecewise smooth (the nearest core point passes from a flat cap to
      // the rim), and there regula falsi crawled: 21 steps on average on
      // resting cylinders, against Brent's 14 (3.4 on ode_adapter_bench's).
      double b = hi, fb = slope_hi, a = lo, fa = slope_lo, c = a, fc = fa;
      double step = b - a, prev_step = step;
      for (int it = 0; it < 64; ++it) {
        if ((fb > 0.0) == (fc > 0.0)) c = a, fc = fa, step = prev_step = b - a;
        if (std::abs(fc) < std::abs(fb)) a = b, b = c, c = a, fa = fb, fb = fc, fc = fa;
        const double tol = 0x1p-52 * std::abs(b) + 0x1p-41;
        const double half = 0.5 * (c - b);
        if (std::abs(half) <= tol || std::abs(fb) <= noise) break;
        if (std::abs(prev_step) >= tol && std::abs(fa) > std::abs(fb)) {
          double num, den;  // the step is num / den
          const double sb = fb / fa;
          if (a == c) {  // secant
            num = 2.0 * half * sb;
            den = 1.0 - sb;
          } else {  // inverse quadratic interpolation
            const double qa = fa / fc, rb = fb / fc;
            num = sb * (2.0 * half * qa * (qa - rb) - (b - a) * (rb - 1.0));
            den = (qa - 1.0) * (rb - 1.0) * (sb - 1.0);
          }
          if (num > 0.0) den = -den; else num = -num;
          if (2.0 * num < std::min(3.0 * half * den - std::abs(tol * den), std::abs(prev_step * den))) {
            prev_step = step;
            step = num / den;
          } else {
            step = prev_step = half;
          }
        } else {
          step = prev_step = half;
        }
        a = b, fa = fb;
        b += std::abs(step) > tol ? step : (half > 0.0 ? tol : -tol);
        fb = slope(b);
      }
      t = b;
    }
    on_triangle = p0 + t * e;
  } else {
    return false;  // a face
  }
  // 3: the test.
  Vec3 on_core;
  if (!core.nearest(on_triangle, on_core)) return false;
  const Vec3 v = on_core - on_triangle;
  const double v2 = v.squaredNorm();
  if (!(v2 > touching2) || !std::isfinite(v2)) return false;
  const double vw = supportGap(v);
  if (core.counters->support_not_finite) return false;  // GJK reports it
  if (!(v2 - vw <= kProjectionGapFactor * settings.relative_gap * v2)) return false;
  out.on_core = on_core;
  out.on_triangle = on_triangle;
  out.distance = std::sqrt(v2);
  out.beyond = beyondReach(vw, v2);
  return true;
}

// Collision checking's GJK monitor (see gjkDistance): stops once the
// closest vector's side of the triangle's plane (its sign along n) is
// certain, the lower bound of the distance clear of zero, with 1e-4 of slack
// on the direction (GJK itself ends within ~1e-6 rad of it).
struct SideMonitor {
  Vec3 n;
  double min_lower;
  bool enabled;
  int* side;
  bool operator()(const Vec3& v, double v2, double vw) const {
    if (!enabled || !(vw > 0.0) || !(vw * vw > min_lower * min_lower * v2)) return false;
    const double len = std::sqrt(v2);
    const double sin_max = std::sqrt(std::max(0.0, 1.0 - vw / v2));
    const double c = v.dot(n) / len;
    if (c > sin_max + 1e-4) *side = 1;
    else if (c < -(sin_max + 1e-4)) *side = -1;
    return *side != 0;
  }
};

// kChecking: collision checking's instance (ConvexContactProbe), with the
// predict_contact shortcut below; the contacts path's instance has none of
// its code.
template <bool kChecking>
struct ConvexNarrowphase {
  // A deep pass's edge and vertex patches carry face parts, written only
  // where they continue a face contact of their plane (withFacePart).
  static constexpr bool kFacePartsContinueFaces = true;
  const SupportShape* shape;
  Pose pose;
  double margin;
  // The settings' contact distance plus round-off (roundOffReach): every
  // reach test's; the query clamps the depths it gives back to the settings'.
  double contact_distance;
  double size;   // the shape's size (bounding-box diagonal), for tolerances
  Vec3 center;   // shape.center() in the query frame
  double scale;  // of the core about the center: 1, then smaller under deep penetration
  double radius; // of the core about the center (an upper bound)
  Counters* counters;
  // Edge patches' line contacts (addLineEnds): the cosine of the settings'
  // manifold angle.
  double cos_manifold = 1.0;
  // A core that clearly meets the triangle is taken as intersecting without
  // running GJK, and the first pass notes the deeper passes that are
  // certainly void (crossingBits): the queries' setting; off, GJK decides
  // and every pass runs (convex_passes.h). Collision checking
  // (ConvexContactProbe) with `predict_contact` too: a deeper pass whose
  // outcome is certainly a contact stops where GJK would start (see
  // touches()).
  bool predict_intersection = false;
  bool predict_contact = false;
  // The shape gives its core's nearest points (SupportShape::nearestCorePoint):
  // closest points by projection before GJK.
  bool projects = false;
  // The shape's supporting face along -n (clippedSupportFace), in the query
  // frame: the last normal's, kept. A floor's triangles share their normal,
  // and a deep pass asks for it on every triangle under the shape.
  struct SupportFaceCache {
    Vec3 normal = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
    int count = 0;
    Vec3 points[SupportShape::kMaxFacePoints];
  };
  mutable SupportFaceCache face_cache = {};
  // A triangle's clip of the supporting face (clippedSupportFace), kept from
  // the test that asked for it (underSupportingFace) for its face patch.
  struct ClippedFace {
    bool done = false;
    int count = 0;
    Vec3 points[detail::kMaxClipPoints];
    double depths[detail::kMaxClipPoints];
  };

  // How far the core scaled by s may be from a triangle that the full shape
  // still reaches (see operator(): "Beyond reach").
  double reachAt(double s) const { return margin + (1.0 - s) * radius + contact_distance; }

  detail::PatchOutcome operator()(const CandidateTriangle& t, detail::Patch& p) const {
    using detail::PatchOutcome;
    const Vec3* tri = t.vertices;
    const Vec3 &a = tri[0], &b = tri[1], &c = tri[2];
    const detail::ScaledEdges scaled = detail::scaledEdges(a, b, c);  // the build's test, at any scale
    if (scaled.degenerate) {
      p.distance = (center - a).norm();
      return PatchOutcome::kDegenerate;
    }
    const Vec3 n = scaled.unitNormal();
    if (counters->core_intersects || counters->support_not_finite) {
      // This pass is void (to be redone, or an error): skip the work.
      p.distance = 0.0;
      return PatchOutcome::kDegenerate;
    }
    const PlacedCore core{shape, &pose.rotation, pose.translation, center, scale, counters};
    // Beyond reach: the scaled core K farther than `reach` from the
    // triangle. The full shape lies within margin + (1 - scale) * radius of
    // K (radius: of the core about the center), so this never rejects a
    // triangle the shape reaches, and being a bound on K's distance (the
    // delayed pass's sort key) it keeps the voiding order intact.
    const double reach = reachAt(scale);
    // Cheap rejection, first (most candidates of a resting shape end here): the separating axis from the triangle's point
    // closest to the center (the triangle lies behind the plane through that
    // point normal to the axis), one support call.
    const Vec3 q = closestPointOnTriangle(center, a, b, c).point;
    const Vec3 w = normalizedOr(center - q, n);
    const Vec3 far_w = core(-w);
    const double separation = w.dot(far_w - q);
    if (separation > reach) {
      p.distance = separation - margin;
      return PatchOutcome::kBeyondContactDistance;
    }
    const Vec3 low = core(-n);  // the (scaled) core's lowest point along n
    const double gap = n.dot(low - a);
    // One-sided: culled when the whole (scaled) core is behind the plane.
    // (The highest point is kept for the clearlyIntersects shortcut.)
    Vec3 high = Vec3::Zero();
    double top = 0.0;
    if (gap < 0.0) {
      high = core(n);
      top = n.dot(high - a);
      if (top < 0.0) {
        p.distance = -top;
        return PatchOutcome::kBackFacing;
      }
    }
    // Even the plane is beyond reach of the full shape (fig. 1).
    const Vec3 low_full = scale == 1.0 ? low : core.full(-n);
    const double plane_gap = n.dot(low_full - a) - margin;
    if (counters->support_not_finite) return PatchOutcome::kDegenerate;
    if (plane_gap > contact_distance) {
      p.distance = plane_gap;
      return PatchOutcome::kBeyondContactDistance;
    }
    // The first pass notes the deeper passes this triangle certainly voids
    // (none when K is in front of the plane: so are its scaled copies).
    if (predict_intersection && scale == 1.0 && gap < 0.0)
      if (const int bits = crossingBits(tri, n, low, [&] { return high; }))
        counters->void_deeper |= withinReachBits(bits, q, w, far_w);

    // Deep pass: the face-ownership rule. The triangle under the full
    // shape's deepest point (its center in front of the plane) owns a face
    // patch with that point, whatever the scaled core's closest feature: on
    // flat ground the scaled core's face triangle need not be the one under
    // the deepest point, and its patch (clipped to its own prism) would
    // understate the depth. Another face patch only voids more, never adds a
    // ghost normal. Not when the shape leaves the triangle sooner within its
    // plane (ownsFace, leavesSoonerInPlane): a cliff's wall.
    if (scale < 1.0 && ownsFace(tri, n, low_full)) {
      p.distance = plane_gap;
      return facePatch(tri, n, low_full - margin * n, true, p);
    }
    if (scale == 0.0) {
      ClippedFace clipped;
      if (underSupportingFace(tri, n, low_full, clipped)) {
        p.distance = plane_gap;
        return facePatch(tri, n, low_full - margin * n, false, p, &clipped);
      }
      return withFacePart(tri, n, gap, centerPatch(tri, n, low_full, p, &clipped), p, &clipped);
    }

    // Exact face: K's lowest point over the triangle's interior.
    if (gap > 0.0 && closestPointOnTriangle(low, a, b, c).feature.type == FeatureType::kFace) {
      p.distance = gap - margin;
      if (scale < 1.0) return deepFacePatch(tri, n, n, gap, low_full, p);
      return facePatch(tri, n, low_full - margin * n, true, p);
    }

    if (predict_intersection && gap < 0.0 && clearlyIntersects(tri, n, low, gap, high, top)) {
      // What GJK would find (below): the core touches the triangle. The
      // scaled core lies in the full shape, which then meets the
      // triangle by at least the tolerance.
      counters->core_intersects = true;
      counters->intersecting = &t;
      if (kChecking && margin > 2e-6 * size) counters->full_meets = true;
      p.distance = 0.0;
      return PatchOutcome::kDegenerate;
    }
    if constexpr (kChecking) {
      if (predict_contact && scale < 1.0 && counters->full_meets && gap > 1e-6 * size) {
        // A deeper pass, the scaled core clear in front of the plane, the
        // full shape meeting the triangle: GJK (below) finds the core
        // separated (gap > 0), within reach (the full shape lies within
        // margin + (1 - scale) * radius of the scaled core), its closest
        // point in front (u . n >= gap / d > 0); then a face patch gets a
        // point (the witness, below the plane, if the clip is empty) and a
        // point patch a depth >= 0 (the shape and the triangle overlap on
        // every axis). A contact, whatever GJK's exact direction.
        counters->predicted_contact = true;
        p.distance = 0.0;
        return PatchOutcome::kDegenerate;
      }
    }
    detail::GjkSettings gjk;
    gjk.max_distance = reach;
    gjk.relative_gap = 1e-10;
    // GJK in a frame at the triangle's first vertex: the Minkowski
    // difference's points then have the size of the problem, not of the
    // query frame's coordinates (a mesh 1e5 from its origin would otherwise
    // cost GJK five digits).
    const Vec3 local_tri[3] = {Vec3::Zero(), b - a, c - a};
    const double longest = scaled.longestEdge();
    const PlacedCore local_core{shape, &pose.rotation, pose.translation - a, center - a, scale, counters};
    int side = 0;  // SideMonitor's verdict
    // (Initialized in place: a GjkResult holds its simplex, hundreds of bytes.)
    // One call site per instance, so that the compiler inlines GJK (and the
    // support calls in it) into each, as for a single caller. GJK starts
    // along w (from the triangle's point nearest the center toward the
    // center), not along n: beside the triangle under the shape the closest
    // direction leans toward w. On curved parts, where GJK converges only
    // linearly, that start cut a cylinder query's instructions by a quarter
    // (callgrind, random poses on a flat floor; a hull's by a tenth).
    // A shape that gives its core's nearest points (the cylinder) tries
    // projections first, from its lowest point along -n: on a curved core
    // they find what GJK would in a fraction of its time (resting
    // cylinders, shapes_bench: 8.3-8.6 -> 4.8 us per query).
    ProjectedPair pair;
    const double touching = gjk.touching * (size + longest);  // as gjkDistance scales it
    const bool projected =
        projects && nearestPairByProjection(local_core, local_tri, Vec3(low - a), gjk, touching, pair);
    detail::GjkResult g = [&] {
      if (projected) return pair.asGjkResult();
      if constexpr (kChecking) {
        const bool monitored = predict_contact && scale < 1.0 && counters->full_meets;
        return detail::gjkDistance(local_core, TriangleSupport{local_tri}, w, size + longest, gjk,
                                   SideMonitor{n, 1e-9 * size, monitored, &side});
      } else {
        return detail::gjkDistance(local_core, TriangleSupport{local_tri}, w, size + longest, gjk);
      }
    }();
    if (kChecking && g.stopped) {
      // A deeper pass, the full shape meeting the triangle (by more than
      // 1e-6 of the size: the margin), the scaled core separated: GJK's
      // closest point ends behind the plane (back-facing) or in front (a
      // contact, as in the gap > 0 case above): the side is known.
      p.distance = 0.0;
      if (side < 0) return PatchOutcome::kBackFacing;
      counters->predicted_contact = true;
      return PatchOutcome::kDegenerate;
    }
    g.point_a += a;
    g.point_b += a;
    if (g.status == detail::GjkStatus::kNotFinite || counters->support_not_finite) {
      counters->support_not_finite = true;
      return PatchOutcome::kDegenerate;
    }
    if (g.status == detail::GjkStatus::kIntersecting) {
      // Within 1e-10 of the size: the full shape meets the triangle by its
      // margin less that, when the margin is clearly larger.
      if (kChecking && scale == 1.0 && margin > 2e-6 * size) counters->full_meets = true;
      counters->core_intersects = true;
      counters->intersecting = &t;
      p.distance = 0.0;
      return PatchOutcome::kDegenerate;
    }
    const double d = g.distance;
    if (g.beyond) {
      p.distance = d - margin;
      return PatchOutcome::kBeyondContactDistance;
    }
    const Vec3 u = normalizedOr(g.v, n);
    p.distance = d - margin;  // the delayed pass's sort key: the same core for every triangle
    if (u.dot(n) < -1e-9) {
      // K's closest point is behind the plane: K reaches around the
      // triangle from its back, which a one-sided triangle does not have.
      // Edge-on (u in the plane to GJK's ~1e-9 rad: K beside the edge, as
      // on a cliff's brink over the wall's top edge) is not behind: the
      // patch goes through the filter and voids the triangle's other edges
      // in its turn. Culled on rounding's sign, it had left the wall
      // triangle below with an edge contact tilted 45 degrees sideways
      // (ConvexScenes.OverhangingACliffSunkPastTheMarginIsHeldByTheLedge).
      return PatchOutcome::kBackFacing;
    }
    // A deeper pass, the scaled core clear of the triangle (so this does not
    // change which pass is taken): the triangle under the shape's supporting
    // face owns a face patch too (underSupportingFace).
    ClippedFace clipped;
    if (scale < 1.0 && underSupportingFace(tri, n, low_full, clipped)) {
      p.distance = plane_gap;
      return facePatch(tri, n, low_full - margin * n, false, p, &clipped);
    }
    // Face when the distance is the plane's (only reached along n), or when
    // the triangle's support feature along u is its face.
    const bool plane_distance = gap > 0.0 && d <= gap + 1e-9 * size;
    bool face = plane_distance;
    if (!face) {
      // Tolerance 1e-4 (of the triangle's size, i.e. ~1e-4 rad): above
      // GJK's ~1e-6 rad on curved cores, so an edge is not taken for one of
      // its vertices (which a neighbour's contact would then void).
      p.feature = supportFeature(a, b, c, u, 1e-4);
      face = p.feature.type == FeatureType::kFace;
    }
    if (scale == 1.0) {
      if (d - margin > contact_distance) return PatchOutcome::kBeyondContactDistance;
      // The witness when the distance is the plane's: the closest vector is
      // then n (to that tolerance) and K's point nearest the triangle its
      // lowest point along -n, `low`, whose depth margin - gap is exact (as
      // in the exact face test above). GJK's point_a lies on K up to about
      // sqrt(2 R * 1e-9 size) from `low` (R: K's radius of curvature there):
      // when `low` is just beyond the triangle's edge (over the neighbour,
      // which reports it exactly), point_a is over the edge, on the curve
      // through `low`, higher by its sag. A cylinder's cap rim (R = 0.285)
      // 2.4e-5 along: 1.04e-9 shallower, within the manifold reduction's tie
      // band (1e-9 of the size, as here), which then kept that point for the
      // lowest one. Otherwise (a face by its support feature) GJK's point is
      // the one over the triangle: `low` may be anywhere under K.
      if (face) return facePatch(tri, n, Vec3((plane_distance ? low : g.point_a) - margin * n), true, p);
      p.normal = u;
      p.count = 1;
      // Over a vertex, the contact's place is the core's point over it.
      // GJK's witness on a core segment or face normal to the closest
      // direction may be any point of it (the direction and the distance
      // are unique, the witnesses not): a cylinder lying across a peak got
      // its contact at either end of its side line, which end depending on
      // the pose's rounding, and a torque about it (overVertex).
      const Vec3 on_core =
          p.feature.type == FeatureType::kVertex ? overVertex(tri[p.feature.index], u, g.point_a) : g.point_a;
      if (counters->support_not_finite) return PatchOutcome::kDegenerate;
      p.points[0] = on_core - margin * u;
      p.depths[0] = margin - d;
      if constexpr (kChecking) {
        return PatchOutcome::kContact;  // whether, not where: no line's ends, no face part
      } else {
        if (p.feature.type == FeatureType::kEdge) addLineEnds(tri, p.feature.index, u, g.point_a, p);
        return withFacePart(tri, n, gap, PatchOutcome::kContact, p);
      }
    }
    if (face) return deepFacePatch(tri, n, u, gap, low_full, p, &clipped);
    return withFacePart(tri, n, gap, pointPatch(tri, u, p), p, &clipped);
  }

  // An edge or vertex patch carries the triangle's face part, the full
  // shape's supporting face along -n clipped to the triangle's prism
  // (clippedSupportFace), when the (scaled) core is in front of the plane
  // (`gap`: its lowest point's height over it, as for the face-ownership
  // rule). In the first pass: a face tilted to the floor by more than the
  // face test's 1e-4 (supportFeature) has its closest point over one
  // triangle only, the one under its lowest corner, and every other
  // triangle under it met the core at an edge or vertex, voided: a box hull
  // tilted by up to 1e-3 rad on a floor of 0.5 cells, sunk 1e-5 to 1e-3 past
  // its corners, was held by points whose outline missed its center (by a
  // fifth of its half-width) at 1,321 of 2,000 placements
  // (ConvexScenes.AHullLyingOnAFaceKeepsItsFootprint). In the deeper
  // passes the scaled core is smaller than the shape: a cylinder lying on
  // its side, sunk past its margin, has a scaled side line half as long,
  // and each triangle under the rest of the line got the scaled core's
  // edge or vertex patch, voided by its neighbours' face contacts: a line
  // of 0.75 to 0.97 of its length kept, and a box-shaped hull's bottom with
  // up to a quarter of its area lost (ConvexScenes.ASupportingFaceSunkPast
  // TheMarginKeepsItsExtent: 229 of 300 cylinders and 89 of 300 hulls on a
  // floor of 0.5 cells). The part is written only where a face contact of its
  // plane ranked before it holds its feature or one of its edges
  // (voided_features.h, FacePartsContinueFaces): it extends a face contact
  // under the shape, never gives a new normal.
  detail::PatchOutcome withFacePart(const Vec3 tri[3], const Vec3& n, double gap, detail::PatchOutcome outcome,
                                    detail::Patch& p, const ClippedFace* clipped = nullptr) const {
    // (With the scaled core in front, so is its center.)
    if (outcome != detail::PatchOutcome::kContact || p.feature.type == FeatureType::kFace || !(gap > 0.0))
      return outcome;
    ClippedFace own;
    if (clipped == nullptr || !clipped->done) {
      own.count = clippedSupportFace(tri, n, own.points, own.depths);
      clipped = &own;
    }
    const int count = clipped->count;
    const Vec3* points = clipped->points;
    const double* depths = clipped->depths;
    if (count < 0) return detail::PatchOutcome::kDegenerate;
    if (count == 0) return outcome;
    int keep[4] = {0, 1, 2, 3};
    const int kept = count <= 4 ? count : detail::selectManifoldPoints(points, depths, count, n, size, keep);
    p.face_normal = n;
    p.face_count = kept;
    for (int i = 0; i < kept; ++i) {
      p.face_points[i] = points[keep[i]];
      p.face_depths[i] = depths[keep[i]];
    }
    return outcome;
  }

  // The deeper passes (scales 1/2: bit 0, 1/4: bit 1) in which this
  // triangle's narrowphase certainly finds the scaled core meeting it: its
  // own steps up to the clearlyIntersects shortcut, for both scales from
  // the full core's support points (the scaled core's are those scaled
  // about the center, as PlacedCore computes them). In two parts, cheapest
  // first: crossingBits from the supports along -n and n, then
  // withinReachBits, the first test of operator(), from q and w as there
  // and the support along -w. The caller has tested the plane's reach (the
  // same at every scale).
  // `high_full()`: the full core's support point along n, asked only when
  // a pass's verdict needs it: the segment from the lowest point to the
  // center crossing inside decides alone (the center is in the core, so
  // the highest point is at least as high, and in front).
  template <class HighFull>
  int crossingBits(const Vec3 tri[3], const Vec3& n, const Vec3& low_full, HighFull&& high_full) const {
    const Vec3& a = tri[0];
    const double center_height = n.dot(center - a);
    // The face-ownership rule returns before the shortcut in every deeper pass.
    if (ownsFace(tri, n, low_full)) return 0;
    int bits = 0;
    bool have_high = false;
    Vec3 high_point = Vec3::Zero();
    for (int k = 0; k < kSkippablePasses; ++k) {
      const double s = kPassScales[k + 1];
      const Vec3 low = scaledAbout(center, s, low_full);
      const double gap = n.dot(low - a);
      if (!(gap < 0.0)) continue;
      if (crossesInside(tri, n, low, gap, center, center_height)) {
        bits |= 1 << k;
        continue;
      }
      if (!have_high) {
        high_point = high_full();
        have_high = true;
      }
      const Vec3 high = scaledAbout(center, s, high_point);
      const double top = n.dot(high - a);
      if (top < 0.0) continue;
      if (crossesInside(tri, n, low, gap, high, top)) bits |= 1 << k;
    }
    return bits;
  }
  int withinReachBits(int bits, const Vec3& q, const Vec3& w, const Vec3& far_w) const {
    for (int k = 0; k < kSkippablePasses; ++k) {
      const double s = kPassScales[k + 1];
      if ((bits >> k & 1) && w.dot(Vec3(scaledAbout(center, s, far_w) - q)) > reachAt(s)) bits &= ~(1 << k);
    }
    return bits;
  }

  // Both parts for a candidate the first pass skipped (it was void before
  // its turn). A non-finite support point here is the query's error, as
  // anywhere else (convex.h).
  int deeperVoidBits(const CandidateTriangle& t) const {
    const Vec3* tri = t.vertices;
    const Vec3 &a = tri[0], &b = tri[1], &c = tri[2];
    const detail::ScaledEdges scaled = detail::scaledEdges(a, b, c);
    if (scaled.degenerate) return 0;
    const Vec3 n = scaled.unitNormal();
    const PlacedCore full{shape, &pose.rotation, pose.translation, center, 1.0, counters};
    const Vec3 low_full = full(-n);
    // In front of the plane, the core's scaled copies are too; the plane's reach.
    if (!(n.dot(low_full - a) < 0.0) || n.dot(low_full - a) - margin > contact_distance) return 0;
    const int bits = crossingBits(tri, n, low_full, [&] { return full(n); });
    if (bits == 0 || counters->support_not_finite) return 0;
    const Vec3 q = closestPointOnTriangle(center, a, b, c).point;
    const Vec3 w = normalizedOr(center - q, n);
    const Vec3 far_w = full(-w);
    if (counters->support_not_finite) return 0;
    return withinReachBits(bits, q, w, far_w);
  }

  // Whether the (scaled) core certainly meets the triangle: a segment of it
  // (its lowest point along n to its highest, or to its center) crosses
  // the triangle's plane inside the triangle, every margin at least 1e-6 of
  // the problem's size. GJK's distance on such a pair cannot stop
  // separated: each of its exits needs a lower bound > 0 or a point of the
  // Minkowski difference that this margin keeps away from the origin, and
  // its touching tolerance is 1e-10 of the size.
  bool clearlyIntersects(const Vec3 tri[3], const Vec3& n, const Vec3& low, double gap, const Vec3& high,
                         double top) const {
    return crossesInside(tri, n, low, gap, high, top) ||
           crossesInside(tri, n, low, gap, center, n.dot(center - tri[0]));
  }
  // The segment from `low` (gap below the plane) to `upper` (height above
  // it) crosses the plane inside the triangle, both by the tolerance.
  bool crossesInside(const Vec3 tri[3], const Vec3& n, const Vec3& low, double gap, const Vec3& upper,
                     double height) const {
    const double tol = 1e-6 * size;
    if (!(gap < -tol) || !(height > tol)) return false;
    const Vec3 x = low + (-gap / (height - gap)) * (upper - low);
    for (int k = 0; k < 3; ++k) {
      const Vec3 edge = tri[(k + 1) % 3] - tri[k];
      // n x edge points into the triangle (counter-clockwise about n).
      if (!(n.cross(edge).dot(x - tri[k]) > tol * edge.norm())) return false;
    }
    return true;
  }

  // Whether x projects along n into the closed triangle (edge planes
  // n x (v_k+1 - v_k), counter-clockwise about n).
  static bool overTriangle(const Vec3& x, const Vec3 tri[3], const Vec3& n) {
    for (int k = 0; k < 3; ++k)
      if (n.cross(tri[(k + 1) % 3] - tri[k]).dot(x - tri[k]) < 0.0) return false;
    return true;
  }

  // Deep pass: whether the full shape leaves the triangle sooner by moving
  // within the triangle's plane than along its normal n (by less than its
  // depth below the plane, from `low_full`, its core's lowest point along
  // -n). A box resting on a ledge and overhanging the cliff, sunk past its
  // margin, reaches 0.1-0.3 behind the wall's plane, but leaves the wall's
  // top triangles by rising its sink over their top edge: their face is not
  // where the box is held, the ledge's is. (Each triangle alone: the
  // filter's neighbours, not this, tell a cliff's brink from a floor's
  // internal edge.) The directions tried: each edge's outward normal in the
  // plane, and from each vertex the direction toward the shape's center in
  // the plane (a wall triangle whose top is a vertex). Any direction gives an
  // exit depth no less than the least one, so a miss keeps the face, the
  // rule as it was. `direction`, when given: the first one found.
  bool leavesSoonerInPlane(const Vec3 tri[3], const Vec3& n, const Vec3& low_full, Vec3* direction = nullptr) const {
    const PlacedCore full{shape, &pose.rotation, pose.translation, center, 1.0, counters};
    const double face_depth = n.dot(tri[0] - low_full);  // both depths less the margin
    const double tolerance = 1e-9 * size;
    const auto sooner = [&](const Vec3& m) {
      if (m == Vec3::Zero()) return false;
      const double reach = std::max({m.dot(tri[0]), m.dot(tri[1]), m.dot(tri[2])});
      // The center lies in the core, so the core reaches at least as far
      // back along -m: a lower bound of the exit depth, without the support.
      if (!(reach - m.dot(center) < face_depth - tolerance)) return false;
      if (!(reach - m.dot(full(-m)) < face_depth - tolerance)) return false;
      if (direction != nullptr) *direction = m;
      return true;
    };
    for (int k = 0; k < 3; ++k) {
      if (sooner(normalizedOr(Vec3((tri[(k + 1) % 3] - tri[k]).cross(n)), Vec3::Zero()))) return true;
      const Vec3 to_center = center - tri[k];
      if (sooner(normalizedOr(Vec3(to_center - n.dot(to_center) * n), Vec3::Zero()))) return true;
    }
    return false;
  }

  // The face-ownership rule (operator(), and crossingBits, which mirrors it).
  bool ownsFace(const Vec3 tri[3], const Vec3& n, const Vec3& low_full) const {
    return n.dot(center - tri[0]) > 0.0 && overTriangle(low_full, tri, n) && !leavesSoonerInPlane(tri, n, low_full);
  }

  // Deep pass: a triangle under any part of the shape's supporting face
  // along -n (clippedSupportFace), not only under the point the support's
  // tie-break picked (ownsFace), that the shape does not leave sooner within
  // its plane. A box overhanging a cliff whose tie-break point lies beyond
  // the brink: the ledge's triangles under the rest of its bottom. True as
  // well for a support point that is not finite (facePatch reports it).
  bool underSupportingFace(const Vec3 tri[3], const Vec3& n, const Vec3& low_full, ClippedFace& clipped) const {
    if (!(n.dot(center - tri[0]) > 0.0)) return false;
    clipped.count = clippedSupportFace(tri, n, clipped.points, clipped.depths);
    clipped.done = true;
    return clipped.count < 0 || (clipped.count > 0 && !leavesSoonerInPlane(tri, n, low_full));
  }

  // Deep pass, the scaled core's closest feature the triangle's face (u: the
  // closest direction): a face patch, unless the shape leaves the triangle
  // sooner within its plane. Then the patch names the triangle's feature on
  // that side (its support feature along that direction: the wall's top
  // edge), with the point along u, and carries the triangle's face part: the
  // ledge's face contact, or on a floor a neighbour's, voids it and holds
  // that feature, and the part continues a face of this plane if there is
  // one (withFacePart).
  detail::PatchOutcome deepFacePatch(const Vec3 tri[3], const Vec3& n, const Vec3& u, double gap, const Vec3& low_full,
                                     detail::Patch& p, const ClippedFace* clipped = nullptr) const {
    Vec3 direction;
    if (!leavesSoonerInPlane(tri, n, low_full, &direction))
      return facePatch(tri, n, low_full - margin * n, false, p, clipped);
    if (counters->support_not_finite) return detail::PatchOutcome::kDegenerate;
    p.feature = supportFeature(tri[0], tri[1], tri[2], direction, 1e-4);
    return withFacePart(tri, n, gap, pointPatch(tri, u, p), p, clipped);
  }

  // Deep penetration, the core shrunk to its center (a point in front of
  // the plane): the sphere's rule, exactly.
  detail::PatchOutcome centerPatch(const Vec3 tri[3], const Vec3& n, const Vec3& low_full, detail::Patch& p,
                                   const ClippedFace* clipped) const {
    const ClosestPoint q = closestPointOnTriangle(center, tri[0], tri[1], tri[2]);
    const Vec3 v = center - q.point;
    const double d = v.norm();
    p.distance = d - margin;
    if (d > margin + radius + contact_distance) return detail::PatchOutcome::kBeyondContactDistance;
    if (q.feature.type == FeatureType::kFace || !(d > 1e-12 * size))
      return deepFacePatch(tri, n, n, n.dot(center - tri[0]), low_full, p, clipped);
    p.feature = q.feature;
    // Not v / d: below ~1e-154 |v|^2 goes subnormal and d loses its digits.
    return pointPatch(tri, normalizedOr(v, n), p);
  }

  // The core's supporting face along `direction` (query frame; supportFace's
  // points, at most kMaxFacePoints) in the query frame. Returns how many; 0
  // for a point that is not finite, the shape's error (as in facePatch).
  int supportFacePoints(const Vec3& direction, Vec3* out) const {
    Vec3 local[SupportShape::kMaxFacePoints];
    const int count = std::min(shape->supportFace(pose.rotation.transpose() * direction, local),
                               SupportShape::kMaxFacePoints);
    for (int i = 0; i < count; ++i) {
      out[i] = pose.apply(local[i]);
      if (!out[i].allFinite()) {
        counters->support_not_finite = true;
        return 0;
      }
    }
    return count;
  }

  // A core lying along the edge (a cylinder on its side along a ridge or a
  // table's edge; a hull's edge, or a face across it) touches it along a
  // line, as a core lying on a face does (facePatch): the closest pair
  // alone gives one point of it (anywhere along the line when the two are
  // parallel), and a shape held at one point of its length pivots about it.
  // The capsule's rule (capsule.cpp), with the core's supporting face along
  // -u for the capsule's segment: the face's section by the plane through
  // the edge that holds u (a segment face is taken whole) is cut to the
  // part that projects onto the edge between its vertices, and each end of
  // that part is a point of the patch when within reach and in the same
  // contact plane, its direction from the edge within manifold_angle_deg of
  // u (a core crossing the edge has its part's ends far off that
  // direction). Its depth is the margin minus its own distance. `closest`:
  // the core's point of the closest pair, already the patch's first point.
  void addLineEnds(const Vec3 tri[3], int k, const Vec3& u, const Vec3& closest, detail::Patch& p) const {
    Vec3 face[SupportShape::kMaxFacePoints];
    const int count = supportFacePoints(-u, face);
    if (count < 2) return;
    const Vec3& a = tri[k];
    const Vec3 e = tri[(k + 1) % 3] - a;
    const double e2 = e.squaredNorm();
    // The section as an interval of x = (point - a) . e / |e|^2 along the
    // edge, with its two end points.
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    Vec3 at_lo = Vec3::Zero(), at_hi = Vec3::Zero();
    const auto extend = [&](const Vec3& q) {
      const double x = (q - a).dot(e) / e2;
      if (x < lo) lo = x, at_lo = q;
      if (x > hi) hi = x, at_hi = q;
    };
    if (count == 2) {
      extend(face[0]);
      extend(face[1]);
    } else {
      const Vec3 side = e.cross(u);  // normal of the plane through the edge holding u
      double h[SupportShape::kMaxFacePoints];
      for (int i = 0; i < count; ++i) h[i] = side.dot(face[i] - a);
      // The face is the points' convex polygon, given in any order: its
      // section is spanned by the points on the plane and the crossings of
      // every pair on opposite sides.
      for (int i = 0; i < count; ++i) {
        if (h[i] == 0.0) extend(face[i]);
        for (int j = i + 1; j < count; ++j)
          if ((h[i] < 0.0 && h[j] > 0.0) || (h[i] > 0.0 && h[j] < 0.0))
            extend(face[i] + (h[i] / (h[i] - h[j])) * (face[j] - face[i]));
      }
    }
    if (!(lo <= hi)) return;
    // The part over the edge: x in [0, 1].
    const double x0 = std::max(lo, 0.0), x1 = std::min(hi, 1.0);
    if (x0 > x1) return;
    const auto pointAt = [&](double x) {
      if (hi - lo <= 0.0) return at_lo;
      return Vec3(at_lo + ((x - lo) / (hi - lo)) * (at_hi - at_lo));
    };
    const double apart = 1e-9 * size;
    for (const double x : {x0, x1}) {
      if (x == x1 && !((x1 - x0) * std::sqrt(e2) > apart)) break;  // one point: taken once
      const Vec3 end = pointAt(x);
      if (!((end - closest).norm() > apart)) continue;  // the closest pair's point already
      const Vec3 w = end - (a + std::clamp((end - a).dot(e) / e2, 0.0, 1.0) * e);
      const double distance = w.norm();
      if (distance - margin <= contact_distance && w.dot(u) >= cos_manifold * distance && p.count < 4) {
        p.points[p.count] = end - margin * u;
        p.depths[p.count] = margin - distance;
        ++p.count;
      }
    }
  }

  // The core's supporting face along -u, its points level with `extreme`
  // along u to 1e-9 of the size (supportFace may give a face tilted within
  // its slack: then its lowest edge, or point, is the set). Returns how many.
  int levelSupportPoints(const Vec3& u, const Vec3& extreme, Vec3* points) const {
    const int given = supportFacePoints(-u, points);
    const double level = u.dot(extreme);
    int count = 0;
    for (int i = 0; i < given; ++i)
      if (std::abs(u.dot(points[i]) - level) <= 1e-9 * size) points[count++] = points[i];
    return count;
  }

  // The core's extreme point along -u that lies over the triangle's vertex
  // (on the line through it along u), when the core's supporting face
  // along -u is normal to u (its points level along u, to 1e-9 of the
  // size; of a face supportFace gives tilted within its slack, the points
  // level with `extreme`) and holds one; else `extreme` (the support point,
  // or GJK's witness). A core lying across a peak has a whole segment or face
  // extreme along -u, and the support point is any point of it (a cylinder
  // across a pyramid's apex, sunk 0.01: its contact at either end of its
  // side line, 0.24 from the apex); the depth along u is the same at each.
  // A face tilted within supportFace's slack has one lowest point, which
  // `extreme` is.
  Vec3 overVertex(const Vec3& vertex, const Vec3& u, const Vec3& extreme) const {
    Vec3 points[SupportShape::kMaxFacePoints];
    int count = levelSupportPoints(u, extreme, points);
    if (count < 2) return extreme;
    const ViewAlong view(u, vertex);
    detail::FacePoint face[SupportShape::kMaxFacePoints];
    for (int i = 0; i < count; ++i) face[i] = view(points[i]);
    if (count == 2) {  // a segment: its point nearest the line, in the plane normal to u
      const double dx = face[1].x - face[0].x, dy = face[1].y - face[0].y, len2 = dx * dx + dy * dy;
      const double t = len2 > 0.0 ? std::clamp(-(face[0].x * dx + face[0].y * dy) / len2, 0.0, 1.0) : 0.0;
      return face[0].p + t * (face[1].p - face[0].p);
    }
    count = detail::convexHull2d(face, count);  // counter-clockwise about u
    if (count < 3) return extreme;
    for (int i = 0; i < count; ++i) {  // the vertex's line (the origin here) inside the polygon?
      const detail::FacePoint &a = face[i], &b = face[(i + 1) % count];
      if ((b.x - a.x) * (0.0 - a.y) - (b.y - a.y) * (0.0 - a.x) < 0.0) return extreme;
    }
    return vertex + u.dot(extreme - vertex) * u;  // at the support point's height
  }

  // The edge's counterpart of overVertex: the core's extreme point along -u
  // nearest the triangle's edge e0-e1 as seen along u, when the core's
  // supporting face along -u is normal to u (its points level, to 1e-9 of
  // the size); else `extreme`. A deep pass takes u from the scaled core's
  // closest pair, and where that pair is edge against edge, u is normal to
  // the core's edge: the support point was either end of it, whichever
  // rounding gave (a box-shaped hull sunk at a step's brink: its contact
  // 0.59 along its long edge from one query frame to another). Seen along
  // u, the core's segment crosses the edge's line: the point of the
  // segment nearest it. A face normal to u: the middle of the edge's part
  // over the face (the edge is then level too), or `extreme` if none is.
  // Only the supporting face's points level with `extreme` count.
  Vec3 overEdge(const Vec3& e0, const Vec3& e1, const Vec3& u, const Vec3& extreme) const {
    Vec3 points[SupportShape::kMaxFacePoints];
    int count = levelSupportPoints(u, extreme, points);
    if (count < 2) return extreme;
    // Seen along u: everything moved to the support plane's level.
    const double level = u.dot(extreme);
    const auto flat = [&](const Vec3& x) { return Vec3(x + (level - u.dot(x)) * u); };
    const Vec3 a = flat(e0), b = flat(e1);
    if (count == 2) return detail::closestSegmentSegment(points[0], points[1], a, b).p;
    const ViewAlong view(u, a);
    detail::FacePoint face[SupportShape::kMaxFacePoints];
    for (int i = 0; i < count; ++i) face[i] = view(points[i]);
    count = detail::convexHull2d(face, count);  // counter-clockwise about u
    if (count < 3) return extreme;
    // The part of a-b inside the polygon (Cyrus-Beck), a at the origin.
    const detail::FacePoint end = view(b);
    const double dx = end.x, dy = end.y;
    double t0 = 0.0, t1 = 1.0;
    for (int i = 0; i < count && t0 <= t1; ++i) {
      const detail::FacePoint &p0 = face[i], &p1 = face[(i + 1) % count];
      // Inside: left of p0->p1, cross((p1 - p0), (x - p0)) >= 0 at x = t (dx, dy).
      const double ex = p1.x - p0.x, ey = p1.y - p0.y;
      const double at0 = ex * (0.0 - p0.y) - ey * (0.0 - p0.x);  // the cross at t = 0
      const double slope = ex * dy - ey * dx;                      // its change per unit t
      if (slope == 0.0) {
        if (at0 < 0.0) return extreme;
      } else if (slope > 0.0) {
        t0 = std::max(t0, -at0 / slope);
      } else {
        t1 = std::min(t1, -at0 / slope);
      }
    }
    if (!(t0 <= t1)) return extreme;
    return a + (0.5 * (t0 + t1)) * (b - a);
  }

  // One point along u for the full shape: its extreme point along -u and the
  // separation of the shape's and the triangle's projections on u.
  detail::PatchOutcome pointPatch(const Vec3 tri[3], const Vec3& u, detail::Patch& p) const {
    const PlacedCore core{shape, &pose.rotation, pose.translation, center, 1.0, counters};
    Vec3 extreme = core.full(-u);
    if (counters->support_not_finite) return detail::PatchOutcome::kDegenerate;
    if (p.feature.type == FeatureType::kVertex) extreme = overVertex(tri[p.feature.index], u, extreme);
    if (counters->support_not_finite) return detail::PatchOutcome::kDegenerate;
    Vec3 point = extreme - margin * u;
    const double depth = u.dot(TriangleSupport{tri}(u)) - u.dot(point);
    p.normal = u;
    p.count = 0;
    // Beyond reach along u: still a patch, with no point, so that the
    // triangle is voided in its turn. The reach test along u is not
    // monotone in the scaled core's distance (the sort key) as d - margin
    // is, and a triangle skipped out of order would break the chain of
    // voided neighbours the flat-ground argument relies on.
    if (-depth > contact_distance) return detail::PatchOutcome::kContact;
    // The projections' separation on u is not the distance: u comes from
    // the scaled core, and the shape may lie beside the triangle rather
    // than over it. Beyond reach of the full shape (its core farther than
    // margin + contact distance from the triangle), likewise no point. (A
    // box-shaped hull with its center under a sine terrain: a triangle
    // 0.096 from it, on the far side of a fold, got a contact 0.005 apart,
    // nearly horizontal; 7% of the hulls and 2% of the cylinders placed at
    // random over that terrain had such a contact, and whether the
    // midphase's box held that triangle turned on the query's frame.)
    if (unreached(tri, p)) return detail::PatchOutcome::kContact;
    // The point, once it is kept (its depth is the level's, whichever point
    // of the level).
    if (p.feature.type == FeatureType::kEdge) {
      point = overEdge(tri[p.feature.index], tri[(p.feature.index + 1) % 3], u, extreme) - margin * u;
      if (counters->support_not_finite) return detail::PatchOutcome::kDegenerate;
    }
    p.count = 1;
    p.points[0] = point;
    p.depths[0] = depth;
    return detail::PatchOutcome::kContact;
  }

  // Deep pass, a patch whose sort key (the scaled core's distance) is beyond
  // the contact distance: when the full shape does not reach its triangle
  // either (fullShapeReaches), it gets no point and still voids, ranked
  // after any patch at its distance: the two triangles of an edge, equally
  // near the scaled core, give it the same normal, and the one the shape
  // reaches must keep its point rather than be voided by this one. (Which
  // of the two came first was rounding's choice.)
  bool unreached(const Vec3 tri[3], detail::Patch& p) const {
    if (p.distance <= contact_distance || fullShapeReaches(tri)) return false;
    p.distance += 1e-9 * size;
    p.count = 0;
    return true;
  }

  // Deep pass: whether the full shape comes within the contact distance of
  // the triangle (the caller has tried the scaled core's distance, which
  // bounds the full core's from above, but not from below). Cheap tests
  // first, each exact: a chord of the full core (from the center, in front
  // of the plane, to the core's extreme point along -n or toward the
  // triangle's point q nearest the center) that meets the plane inside the
  // triangle; the separating axis from q toward the center; either extreme
  // point within reach of the triangle. Then GJK on the full core, stopped
  // as soon as a bound decides, at the problem's size (coordinates relative
  // to the triangle's first vertex, scaled by a power of two, which is
  // exact): GJK's squared cross products underflow for shapes below ~1e-80
  // of the unit. (On ode_adapter_bench's cylinders GJK still decides seven
  // calls in ten.) An iteration cap that leaves the distance unsettled
  // counts as reaching: a contact is kept, not lost.
  bool fullShapeReaches(const Vec3 tri[3]) const {
    const PlacedCore core{shape, &pose.rotation, pose.translation, center, 1.0, counters};
    const Vec3 normal = (tri[1] - tri[0]).cross(tri[2] - tri[0]);  // not degenerate (operator())
    const double h_center = normal.dot(center - tri[0]);
    const double reach = margin + contact_distance;
    // A chord from the center (in front) to a core point behind the plane
    // that meets the plane inside the triangle.
    const auto chordCrosses = [&](const Vec3& x_core) {
      const double h = normal.dot(x_core - tri[0]);
      if (!(h_center > 0.0 && h < 0.0)) return false;
      const Vec3 x = center + (h_center / (h_center - h)) * (x_core - center);
      return normal.dot((tri[1] - tri[0]).cross(x - tri[0])) >= 0.0 &&
             normal.dot((tri[2] - tri[1]).cross(x - tri[1])) >= 0.0 &&
             normal.dot((tri[0] - tri[2]).cross(x - tri[2])) >= 0.0;
    };
    const Vec3 low = core(-normal);
    if (chordCrosses(low)) return true;
    const Vec3 q = closestPointOnTriangle(center, tri[0], tri[1], tri[2]).point;
    const Vec3 w = center - q;
    const double w_length = w.norm();
    const Vec3 toward = core(-w);
    if (counters->support_not_finite) return false;
    if (w_length > 0.0 && w.dot(toward - q) / w_length - margin > contact_distance) return false;
    if (chordCrosses(toward)) return true;
    // A core point within reach of the triangle.
    for (const Vec3& x : {toward, low})
      if ((x - closestPointOnTriangle(x, tri[0], tri[1], tri[2]).point).squaredNorm() <= reach * reach) return true;
    const Vec3& origin = tri[0];
    const double unit = std::ldexp(1.0, -std::ilogb(size));  // 1 / size, to a power of two
    const Vec3 local[3] = {Vec3::Zero(), (tri[1] - origin) * unit, (tri[2] - origin) * unit};
    const auto scaled_core = [&](const Vec3& d) { return Vec3((core(d) - origin) * unit); };
    detail::GjkSettings gjk;
    gjk.max_distance = reach * unit;  // a lower bound beyond it: apart
    gjk.relative_gap = 1e-6;
    // An upper bound within it (the closest vector so far): within reach.
    const double within2 = gjk.max_distance * gjk.max_distance;
    const auto within = [within2](const Vec3&, double v2, double) { return v2 <= within2; };
    const double longest = std::max({local[1].norm(), local[2].norm(), (local[2] - local[1]).norm()});
    const detail::GjkResult g =
        detail::gjkDistance(scaled_core, TriangleSupport{local}, w, size * unit + longest, gjk, within);
    if (g.status == detail::GjkStatus::kNotFinite || counters->support_not_finite) {
      counters->support_not_finite = true;
      return false;
    }
    if (g.stopped || g.status == detail::GjkStatus::kIntersecting) return true;
    if (g.beyond) return false;
    return !g.converged || g.distance / unit - margin <= contact_distance;
  }

  // The shape's supporting face along -n (the core's supportFace, moved out
  // by the margin onto the shape's surface) clipped to the triangle's
  // prism: the points within reach of its plane, each with its depth along
  // n. Returns how many (at most kMaxClipPoints), or -1 when a point is not
  // finite (the shape's error, noted in the counters).
  int clippedSupportFace(const Vec3 tri[3], const Vec3& n, Vec3* points, double* depths) const {
    const Vec3& a = tri[0];
    SupportFaceCache& cache = face_cache;
    if (!(n == cache.normal)) {
      int k = supportFacePoints(-n, cache.points);
      if (counters->support_not_finite) return -1;
      if (k < 1) {  // against its contract (1..kMaxFacePoints): its support point, not an unwritten one
        cache.points[0] = pose.apply(shape->support(pose.rotation.transpose() * -n));
        if (!cache.points[0].allFinite()) {
          counters->support_not_finite = true;
          return -1;
        }
        k = 1;
      }
      for (int i = 0; i < k; ++i) cache.points[i] -= margin * n;
      cache.normal = n;
      cache.count = k;
    }
    int k = cache.count;
    const Vec3 e1 = (tri[1] - a).normalized();
    const Vec3 e2 = n.cross(e1);
    detail::FacePoint poly[SupportShape::kMaxFacePoints];
    for (int i = 0; i < k; ++i) {
      poly[i].p = cache.points[i];
      poly[i].x = e1.dot(cache.points[i] - a);
      poly[i].y = e2.dot(cache.points[i] - a);
    }
    double tri2d[3][2];
    double tri_magnitude = 0.0;
    for (int i = 0; i < 3; ++i) {
      tri2d[i][0] = e1.dot(tri[i] - a);
      tri2d[i][1] = e2.dot(tri[i] - a);
      tri_magnitude = std::max(tri_magnitude, tri[i].cwiseAbs().maxCoeff());
    }
    // Most triangles a deep pass asks about lie beside the face, not under
    // it: one of the triangle's edges has every point of the face outside
    // it, beyond the clip's rounding (clipToTriangle's noise, here with the
    // magnitude of all the face's points, at least the clip's), and the clip
    // is empty.
    double all_magnitude = tri_magnitude;
    for (int i = 0; i < k; ++i) all_magnitude = std::max(all_magnitude, poly[i].p.cwiseAbs().maxCoeff());
    for (int e = 0; e < 3; ++e) {
      const double px = tri2d[e][0], py = tri2d[e][1];
      const double ex = tri2d[(e + 1) % 3][0] - px, ey = tri2d[(e + 1) % 3][1] - py;
      bool outside = true;
      for (int i = 0; i < k && outside; ++i) {
        const double v = ex * (poly[i].y - py) - ey * (poly[i].x - px);
        const double noise = 0x1p-40 * (std::abs(ex) + std::abs(ey)) *
                             (std::abs(poly[i].x - px) + std::abs(poly[i].y - py) + all_magnitude);
        outside = v < -noise;
      }
      if (outside) return 0;
    }
    if (k >= 3) k = detail::convexHull2d(poly, k);
    double magnitude = tri_magnitude;
    for (int i = 0; i < k; ++i) magnitude = std::max(magnitude, poly[i].p.cwiseAbs().maxCoeff());
    detail::FacePoint clipped[detail::kMaxClipPoints];
    const int m = detail::clipToTriangle(poly, k, tri2d, magnitude, clipped);
    int count = 0;
    for (int i = 0; i < m; ++i) {
      const double d = n.dot(a - clipped[i].p);
      if (d < -contact_distance) continue;  // this part of the face is beyond reach
      points[count] = clipped[i].p;
      depths[count] = d;
      ++count;
    }
    return count;
  }

  // A face patch along the triangle's normal n: the shape's supporting face
  // along -n clipped to the triangle's prism (clippedSupportFace), each point
  // with its own depth. The witness (a deepest point of the shape, over the
  // triangle when `witness_over` holds) is added when the clip misses it or
  // is empty. `clipped`: that clip, when the caller has it already.
  detail::PatchOutcome facePatch(const Vec3 tri[3], const Vec3& n, const Vec3& witness, bool witness_over,
                                 detail::Patch& p, const ClippedFace* clipped = nullptr) const {
    p.feature = Feature::face();
    p.normal = n;
    Vec3 points[detail::kMaxClipPoints + 1];  // room for the witness
    double depths[detail::kMaxClipPoints + 1];
    const bool reuse = clipped != nullptr && clipped->done;
    int count = reuse ? clipped->count : clippedSupportFace(tri, n, points, depths);
    if (reuse)
      for (int i = 0; i < count; ++i) {
        points[i] = clipped->points[i];
        depths[i] = clipped->depths[i];
      }
    if (count < 0 || !witness.allFinite()) {
      counters->support_not_finite = true;
      return detail::PatchOutcome::kDegenerate;
    }
    double deepest = -std::numeric_limits<double>::infinity();
    for (int i = 0; i < count; ++i) deepest = std::max(deepest, depths[i]);
    const double witness_depth = n.dot(tri[0] - witness);
    // Deep pass, nothing of the shape over the triangle within reach, and
    // the witness (the shape's extreme along -n) beside it: its depth is the
    // projections' overlap on n, not a distance, as in pointPatch. Beyond
    // reach of the full shape, no point; the patch still voids. (A box sunk
    // 0.13 into the floor at a step's foot, 0.023 from the wall: its extreme
    // along the wall's normal, under the floor, beside the wall's triangle,
    // gave a wall contact 0.007 apart, which held the box off the wall.)
    if (count == 0 && !witness_over && unreached(tri, p)) return detail::PatchOutcome::kContact;
    if (count == 0 || (witness_over && witness_depth > deepest + 1e-9 * size)) {
      points[count] = witness;
      depths[count] = witness_depth;
      deepest = std::max(deepest, witness_depth);
      ++count;
    }
    if (deepest < -contact_distance) {
      if (!witness_over) {  // deep pass: void-only, as in pointPatch
        p.count = 0;
        return detail::PatchOutcome::kContact;
      }
      p.distance = -deepest;
      return detail::PatchOutcome::kBeyondContactDistance;
    }
    int keep[4] = {0, 1, 2, 3};
    const int kept = count <= 4 ? count : detail::selectManifoldPoints(points, depths, count, n, size, keep);
    p.count = kept;
    for (int i = 0; i < kept; ++i) {
      p.points[i] = points[keep[i]];
      p.depths[i] = depths[keep[i]];
    }
    return detail::PatchOutcome::kContact;
  }
};

Status checkCommon(const SupportShape& shape, const Pose& pose, const QuerySettings& settings) {
  Status s = shape.validate();
  if (!s) return s;
  const double m = shape.margin();
  if (!detail::inRange(m) || m < 0.0)
    return {ErrorCode::kInvalidShape,
            "the shape's margin must be finite, >= 0 and <= 1e50, got " + detail::describe(m)};
  s = detail::checkPose(pose, "shape");
  if (!s) return s;
  s = detail::checkQuerySettings(settings);
  if (!s) return s;
  return detail::checkManifoldSettings(settings);
}

// The rounded shape's query-frame bounding box from six support calls, its
// center in the query frame, and its core's radius about the center (an
// upper bound: coreRadius).
Status shapeBounds(const SupportShape& shape, const Pose& pose, Vec3& lo, Vec3& hi, Vec3& center, double& radius) {
  Counters counters;
  const PlacedCore core{&shape, &pose.rotation, pose.translation, Vec3::Zero(), 1.0, &counters};
  for (int k = 0; k < 3; ++k) {
    const Vec3 axis = Vec3::Unit(k);
    hi[k] = core(axis)[k];
    lo[k] = core(-axis)[k];
  }
  center = pose.apply(shape.center());
  if (counters.support_not_finite || !lo.allFinite() || !hi.allFinite() || !center.allFinite())
    return {ErrorCode::kInvalidShape, "the shape's support function (or center) returned a non-finite point"};
  if (!((hi - lo).minCoeff() >= 0.0))
    return {ErrorCode::kInvalidShape, "the shape's support function is inconsistent (bounds " +
                                          detail::describe(lo) + " - " + detail::describe(hi) + ")"};
  // center() must lie in the core (convex.h): the deep passes shrink the core
  // toward it. Outside the core's bounds it certainly does not (beyond
  // round-off), and a center far below a sunk shape cleared it of every
  // triangle at once: no contact, no error.
  const Vec3 slack = Vec3::Constant(1e-9 * ((hi - lo).norm() + center.cwiseAbs().maxCoeff()));
  if (((center - lo).array() < -slack.array()).any() || ((center - hi).array() > slack.array()).any())
    return {ErrorCode::kInvalidShape, "the shape's center() " + detail::describe(center) +
                                          " (query frame) lies outside its core's bounds " + detail::describe(lo) +
                                          " - " + detail::describe(hi)};
  // The core's radius about its center, in the shape's own frame: the
  // deep passes' reach (reachAt) and their candidates' box, the same in
  // whatever frame the query is posed. (The query frame's box gave a turned
  // cylinder up to 1.7 times its radius, and as many more candidates.)
  radius = shape.coreRadius();
  if (!(radius >= 0.0) || !std::isfinite(radius))
    return {ErrorCode::kInvalidShape, "the shape's coreRadius() is not finite and >= 0: " + detail::describe(radius)};
  // A rotation the pose check accepts (|R^T R - I| <= 1e-9, validate.cpp)
  // stretches a length by up to sqrt(1 + 3e-9): the radius in the query
  // frame, where the reach tests run, is up to that much longer.
  radius *= 1.0 + 2e-9;
  const Vec3 m = Vec3::Constant(shape.margin());
  lo -= m;
  hi += m;
  if (!((hi - lo).norm() > 0.0)) return {ErrorCode::kInvalidShape, "the shape has no extent (a single point)"};
  if (!detail::inRange(lo) || !detail::inRange(hi))
    return {ErrorCode::kInvalidShape, "the shape's bounds are beyond +-1e50"};
  return Status::ok();
}

Status runCandidates(const SupportShape& shape, const Pose& pose, const Vec3& lo, const Vec3& hi, const Vec3& center,
                     double radius, const CandidateTriangle* candidates, std::size_t count,
                     const QuerySettings& settings, detail::VertexIdentity identity, QueryScratch& scratch,
                     std::vector<Contact>& contacts, bool shortcuts, CandidateSource* deeper) {
  Counters counters;
  const double size = (hi - lo).norm();
  const double reach = settings.contact_distance + roundOffReach(size, center);
  ConvexNarrowphase<false> narrowphase{&shape, pose, shape.margin(), reach, size, center, 1.0, radius, &counters};
  narrowphase.predict_intersection = shortcuts;
  narrowphase.projects = givesNearestCorePoints(shape);
  narrowphase.cos_manifold = std::cos(settings.manifold_angle_deg * (M_PI / 180.0));
  QueryScratch::Impl& sc = scratch.impl();
  // The box the deep passes' candidates were last gathered on (`deeper`);
  // none yet: the caller's.
  Vec3 gathered_lo = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 gathered_hi = -gathered_lo;
  const Vec3 core_lo = lo + Vec3::Constant(shape.margin()), core_hi = hi - Vec3::Constant(shape.margin());
  // Deep penetration: the same query with the core shrunk toward its center
  // (convex.h); the last scale, the center itself, never intersects.
  for (const double scale : kPassScales) {
    // Passes certainly void (Counters::void_deeper) are skipped: each would
    // end as soon as it reached the triangle that voids it, at the price of
    // every triangle before it.
    if (counters.certainlyVoid(scale)) continue;
    if (deeper != nullptr && scale < 1.0) {
      // Every triangle within the pass's reach (reachAt) of the scaled core
      // overlaps the scaled core's box grown by that reach: (1 - scale) *
      // (radius - the core's half extent) beyond the shape's own box on
      // each side, more for each deeper pass (CandidateSource).
      const Vec3 grow = Vec3::Constant(narrowphase.reachAt(scale));
      const Vec3 need_lo = scaledAbout(center, scale, core_lo) - grow;
      const Vec3 need_hi = scaledAbout(center, scale, core_hi) + grow;
      if ((need_lo.array() < gathered_lo.array()).any() || (need_hi.array() > gathered_hi.array()).any()) {
        Status s = deeper->gather(need_lo, need_hi, sc.deep_candidates);
        if (s) s = detail::checkCandidates(sc.deep_candidates.data(), sc.deep_candidates.size());
        if (!s) {
          contacts.clear();
          return s;
        }
        candidates = sc.deep_candidates.data();
        count = sc.deep_candidates.size();
        gathered_lo = need_lo;
        gathered_hi = need_hi;
      }
    }
    narrowphase.scale = scale;
    counters.core_intersects = false;
    detail::generateContacts(candidates, count, narrowphase, settings, identity, sc.filter, contacts);
    if (counters.support_not_finite || !counters.core_intersects) break;
    // The candidates the first pass skipped: those after the one that voided
    // it (generateContacts hands the narrowphase the caller's candidates in
    // order, and each one after that returns at once).
    if (shortcuts && scale == 1.0 && counters.intersecting != nullptr)
      for (std::size_t i = static_cast<std::size_t>(counters.intersecting - candidates) + 1;
           i < count && counters.void_deeper != kAllSkippable && !counters.support_not_finite; ++i)
        counters.void_deeper |= narrowphase.deeperVoidBits(candidates[i]);
    if (counters.support_not_finite) break;
  }
  if (counters.support_not_finite) {
    contacts.clear();
    return {ErrorCode::kInvalidShape, "the shape's support function returned a non-finite point"};
  }
  // Within round-off beyond the contact distance: at it.
  for (Contact& c : contacts) c.depth = std::max(c.depth, -settings.contact_distance);
  detail::reduceManifolds(contacts, settings, size, sc.manifold);
  return Status::ok();
}

const char* const kNotFiniteSupport = "the shape's support function returned a non-finite point";

// A one-candidate query's contacts are the patch's points in order (the
// filter keeps the only patch; the reduction keeps each manifold's deepest
// point): its deepest contact is the patch's first deepest point.
bool patchContact(detail::PatchOutcome outcome, const detail::Patch& p, const CandidateTriangle& c,
                  double contact_distance, Contact* out) {
  if (outcome != detail::PatchOutcome::kContact || p.count <= 0) return false;
  if (out) {
    int best = 0;
    for (int k = 1; k < p.count; ++k)
      if (p.depths[k] > p.depths[best]) best = k;
    out->point = p.points[best];
    out->normal = p.normal;
    out->depth = std::max(p.depths[best], -contact_distance);  // runCandidates' clamp
    out->mesh = c.mesh;
    out->triangle = c.triangle;
    out->feature = p.feature;
  }
  return true;
}

}  // namespace

// ---------------------------------------------------------------------------
// Collision checking, one candidate at a time

Status ConvexContactProbe::prepare(const SupportShape& shape, const Pose& pose, const QuerySettings& settings) {
  shape_ = nullptr;
  Status s = checkCommon(shape, pose, settings);
  if (!s) return s;
  Vec3 lo, hi, center;
  double radius;
  s = shapeBounds(shape, pose, lo, hi, center, radius);
  if (!s) return s;
  // What runCandidates computes per query, once.
  shape_ = &shape;
  pose_ = pose;
  center_ = center;
  margin_ = shape.margin();
  contact_distance_ = settings.contact_distance;
  size_ = (hi - lo).norm();
  reach_ = contact_distance_ + roundOffReach(size_, center);
  radius_ = radius;
  projects_ = givesNearestCorePoints(shape);
  return Status::ok();
}

// Both answers replay runCandidates on the one triangle: its narrowphase,
// the same scales. With one candidate the filter keeps the patch whatever
// its feature (nothing is voided before the first patch), and the manifold
// reduction keeps at least one point of every manifold, so the query has a
// contact exactly when the last pass's patch is a contact with a point.
// predict_contact: touches() (a deeper pass whose outcome is certainly a
// contact ends the replay there, with no contact geometry).
Status ConvexContactProbe::replay(const CandidateTriangle& candidate, bool predict_contact, bool& contact,
                                  Contact* deepest) const {
  contact = false;
  if (shape_ == nullptr) return {ErrorCode::kInvalidShape, "ConvexContactProbe: prepare() has not succeeded"};
  const Status s = detail::checkCandidates(&candidate, 1);
  if (!s) return s;
  Counters counters;
  ConvexNarrowphase<true> narrowphase{shape_, pose_, margin_, reach_, size_, center_, 1.0, radius_, &counters};
  narrowphase.predict_intersection = true;
  narrowphase.predict_contact = predict_contact;
  narrowphase.projects = projects_;
  detail::Patch p;
  detail::PatchOutcome outcome = detail::PatchOutcome::kDegenerate;
  for (const double scale : kPassScales) {
    // As in runCandidates: the passes the first one proved void are skipped.
    if (counters.certainlyVoid(scale)) continue;
    narrowphase.scale = scale;
    counters.core_intersects = false;
    p.face_count = 0;
    outcome = narrowphase(candidate, p);
    if (counters.support_not_finite || counters.predicted_contact || !counters.core_intersects) break;
  }
  if (counters.support_not_finite) return {ErrorCode::kInvalidShape, kNotFiniteSupport};
  contact = counters.predicted_contact || patchContact(outcome, p, candidate, contact_distance_, deepest);
  return Status::ok();
}

Status ConvexContactProbe::touches(const CandidateTriangle& candidate, bool& contact) const {
  return replay(candidate, true, contact, nullptr);
}

Status ConvexContactProbe::check(const CandidateTriangle& candidate, bool& contact, Contact* deepest) const {
  return replay(candidate, false, contact, deepest);
}

Status collideConvexCandidates(const SupportShape& shape, const Pose& pose, const CandidateTriangle* candidates,
                               std::size_t count, const QuerySettings& settings, QueryScratch& scratch,
                               std::vector<Contact>& contacts) {
  return detail::collideConvexCandidates(shape, pose, candidates, count, settings, scratch, contacts, true, nullptr);
}

Status collideConvexCandidates(const SupportShape& shape, const Pose& pose, const CandidateTriangle* candidates,
                               std::size_t count, const QuerySettings& settings, QueryScratch& scratch,
                               std::vector<Contact>& contacts, CandidateSource* deeper) {
  return detail::collideConvexCandidates(shape, pose, candidates, count, settings, scratch, contacts, true, deeper);
}

Status detail::collideConvexCandidates(const SupportShape& shape, const Pose& pose, const CandidateTriangle* candidates,
                                       std::size_t count, const QuerySettings& settings, QueryScratch& scratch,
                                       std::vector<Contact>& contacts, bool shortcuts, CandidateSource* deeper) {
  contacts.clear();
  if (settings.trace) settings.trace->clear();
  Status s = checkCommon(shape, pose, settings);
  if (!s) return s;
  Vec3 lo, hi, center;
  double radius;
  s = shapeBounds(shape, pose, lo, hi, center, radius);
  if (!s) return s;
  s = checkCandidates(candidates, count);
  if (!s) return s;
  return runCandidates(shape, pose, lo, hi, center, radius, candidates, count, settings,
                       detail::candidateIdentity(settings), scratch, contacts, shortcuts, deeper);
}

Status collideConvex(const MeshInstance* instances, std::size_t count, const SupportShape& shape, const Pose& pose,
                     const QuerySettings& settings, QueryScratch& scratch, std::vector<Contact>& contacts) {
  contacts.clear();
  if (settings.trace) settings.trace->clear();
  Status s = checkCommon(shape, pose, settings);
  if (!s) return s;
  Vec3 lo, hi, center;
  double radius;
  s = shapeBounds(shape, pose, lo, hi, center, radius);
  if (!s) return s;
  const Vec3 reach = Vec3::Constant(settings.contact_distance + roundOffReach((hi - lo).norm(), center));
  QueryScratch::Impl& sc = scratch.impl();
  detail::VertexIdentity identity;
  s = detail::gatherForFilter(instances, count, lo - reach, hi + reach, settings.key_mode, scratch, sc.candidates,
                              identity);
  if (!s) return s;
  // The deep passes' triangles: the same midphase on their box. (The
  // vertex identity depends on the meshes alone, not on the box.)
  struct SameMidphase final : CandidateSource {
    const MeshInstance* instances;
    std::size_t count;
    KeyMode key_mode;
    QueryScratch* scratch;
    SameMidphase(const MeshInstance* i, std::size_t n, KeyMode k, QueryScratch* sc)
        : instances(i), count(n), key_mode(k), scratch(sc) {}
    Status gather(const Vec3& lo, const Vec3& hi, std::vector<CandidateTriangle>& out) override {
      detail::VertexIdentity same;
      return detail::gatherForFilter(instances, count, lo, hi, key_mode, *scratch, out, same);
    }
  } deeper(instances, count, settings.key_mode, &scratch);
  return runCandidates(shape, pose, lo, hi, center, radius, sc.candidates.data(), sc.candidates.size(), settings,
                       identity, scratch, contacts, true, &deeper);
}

Status collideConvex(const TriangleMesh& mesh, const SupportShape& shape, const Pose& pose,
                     const QuerySettings& settings, QueryScratch& scratch, std::vector<Contact>& contacts) {
  const MeshInstance instance{&mesh, Pose::identity()};
  return collideConvex(&instance, 1, shape, pose, settings, scratch, contacts);
}

Status collideCylinderCandidates(const Cylinder& cylinder, const Pose& pose, const CandidateTriangle* candidates,
                                 std::size_t count, const QuerySettings& settings, QueryScratch& scratch,
                                 std::vector<Contact>& contacts) {
  return collideConvexCandidates(CylinderShape(cylinder), pose, candidates, count, settings, scratch, contacts);
}

Status collideCylinder(const TriangleMesh& mesh, const Cylinder& cylinder, const Pose& pose,
                       const QuerySettings& settings, QueryScratch& scratch, std::vector<Contact>& contacts) {
  return collideConvex(mesh, CylinderShape(cylinder), pose, settings, scratch, contacts);
}

Status collideCylinder(const MeshInstance* instances, std::size_t count, const Cylinder& cylinder, const Pose& pose,
                       const QuerySettings& settings, QueryScratch& scratch, std::vector<Contact>& contacts) {
  return collideConvex(instances, count, CylinderShape(cylinder), pose, settings, scratch, contacts);
}

}  // namespace meshcontact
