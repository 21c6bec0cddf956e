#pragma once
// Helpers shared by the FCL adapter's tests: the shape cases (an FCL
// geometry and the core query it must agree with) and conversions between
// FCL's conventions and the core's. FCL models of scene meshes and the
// prism come from the scene library (meshcontact_scenes/fcl_models.h).
#include "test_support.h"

#include <meshcontact/convex.h>
#include <meshcontact/fcl.h>
#include <meshcontact/shapes.h>
#include <meshcontact/triangle.h>
#include <meshcontact_scenes/fcl_models.h>
#include <meshcontact_scenes/scenes.h>

#include <fcl/fcl.h>

#include <cmath>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

namespace meshcontact::fcltest {

using scenes::fclModel;
using scenes::SceneMesh;
using testing::cutMesh;

/// Several pieces as one model (duplicated vertices at the seams).
inline SceneMesh merged(const std::vector<SceneMesh>& pieces) {
  SceneMesh all;
  for (const SceneMesh& p : pieces) all.append(p);
  return all;
}

inline ::fcl::Transform3d toTransform(const Pose& p) {
  ::fcl::Transform3d tf = ::fcl::Transform3d::Identity();
  tf.linear() = p.rotation;
  tf.translation() = p.translation;
  return tf;
}

inline Pose randomPose(scenes::Rng& rng, double extent) {
  Pose p;
  p.rotation = rng.rotation();
  p.translation = rng.uniformVector(Vec3::Constant(-extent), Vec3::Constant(extent));
  return p;
}

// --- Shapes -----------------------------------------------------------------

enum class Kind { kSphere, kCapsule, kBox, kCylinder, kCone, kEllipsoid, kConvex };

/// FCL's cone (base at -lz/2, apex at +lz/2) as a SupportShape, written
/// from the adapter's documented behaviour (meshcontact/fcl.h): the base is
/// a face (8 rim points) for directions within the 0.05 slope of its
/// normal, a side line (apex, rim point) for directions within that slope of
/// the side's normal, a single point otherwise.
class TestCone final : public SupportShape {
 public:
  TestCone(double r, double lz) : r_(r), h_(0.5 * lz) {}
  // Nearest core points as the adapter documents them (a solid of
  // revolution: the nearest point of its cross-section, in the half-plane
  // through the axis and x), so that the core's pipeline on this shape runs
  // what the drop-in runs.
  bool nearestCorePoint(const Vec3& x, Vec3& out) const override {
    const double rho = std::sqrt(x.x() * x.x() + x.y() * x.y());
    const ClosestPoint c =
        closestPointOnTriangle(Vec3(rho, x.z(), 0.0), Vec3(0.0, h_, 0.0), Vec3(0.0, -h_, 0.0), Vec3(r_, -h_, 0.0));
    const double k = rho > 0.0 ? c.point.x() / rho : 0.0;
    out = Vec3(k * x.x(), k * x.y(), c.point.y());
    return true;
  }
  Vec3 support(const Vec3& d) const override {
    // The apex or a rim point, whichever is higher along d.
    const double rho = std::hypot(d.x(), d.y());
    const Vec3 rim = rho > 0.0 ? Vec3(r_ * d.x() / rho, r_ * d.y() / rho, -h_) : Vec3(0.0, 0.0, -h_);
    const Vec3 apex(0.0, 0.0, h_);
    return apex.dot(d) > rim.dot(d) ? apex : rim;
  }
  int supportFace(const Vec3& d, Vec3* out) const override {
    const double flat = std::sqrt(1.0 - 0.05 * 0.05);
    const Vec3 u = d / d.norm();
    if (-u.z() >= flat) {
      for (int k = 0; k < 8; ++k) out[k] = Vec3(r_ * std::cos(k * (M_PI / 4.0)), r_ * std::sin(k * (M_PI / 4.0)), -h_);
      return 8;
    }
    const double rho = std::hypot(u.x(), u.y());
    if (rho > 0.0) {
      // The side's outward normal in d's azimuth: tilted up from horizontal
      // by the angle whose tangent is r / lz.
      const double slant = std::hypot(r_, 2.0 * h_);
      const Vec3 side(u.x() / rho * (2.0 * h_ / slant), u.y() / rho * (2.0 * h_ / slant), r_ / slant);
      if (u.dot(side) >= flat) {
        const double rho_d = std::hypot(d.x(), d.y());  // the rim point as support() computes it
        out[0] = Vec3(0.0, 0.0, h_);
        out[1] = Vec3(r_ * d.x() / rho_d, r_ * d.y() / rho_d, -h_);
        return 2;
      }
    }
    out[0] = support(d);
    return 1;
  }
  double coreRadius() const override {
    const Vec3 c = center();
    return std::max((Vec3(0.0, 0.0, h_) - c).norm(), std::hypot(std::hypot(c.x(), c.y()) + r_, c.z() + h_));
  }

 private:
  double r_, h_;
};

class TestEllipsoid final : public SupportShape {
 public:
  explicit TestEllipsoid(const Vec3& r) : r_(r) {}
  Vec3 support(const Vec3& d) const override {
    const Vec3 s = r_.cwiseProduct(d);
    return r_.cwiseProduct(s) / s.norm();
  }
  double coreRadius() const override { return r_.maxCoeff(); }

 private:
  Vec3 r_;
};

/// FCL's Convex as the adapter documents it (meshcontact/fcl.h): its
/// vertices as they are, margin 0; the supporting face is the vertices
/// within 0.05 of the bounding-box diagonal of the extreme one, deepest
/// first; the center is the mean of the vertices.
class TestConvex final : public SupportShape {
 public:
  explicit TestConvex(const std::vector<Vec3>& v) : v_(v) {
    Vec3 lo = v[0], hi = v[0];
    for (const Vec3& p : v) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    diagonal_ = (hi - lo).norm();
  }
  Vec3 support(const Vec3& d) const override {
    std::size_t best = 0;
    for (std::size_t i = 1; i < v_.size(); ++i)
      if (v_[i].dot(d) > v_[best].dot(d)) best = i;
    return v_[best];
  }
  int supportFace(const Vec3& d, Vec3* out) const override {
    const Vec3 u = normalizedOr(d, Vec3::UnitZ());
    std::vector<std::pair<double, std::size_t>> by_height;  // (-height, index): deepest first, ties by index
    double top = -INFINITY;
    for (const Vec3& p : v_) top = std::max(top, p.dot(u));
    for (std::size_t i = 0; i < v_.size(); ++i)
      if (v_[i].dot(u) >= top - 0.05 * diagonal_) by_height.push_back({-v_[i].dot(u), i});
    std::stable_sort(by_height.begin(), by_height.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    const int n = static_cast<int>(std::min<std::size_t>(by_height.size(), kMaxFacePoints));
    for (int k = 0; k < n; ++k) out[k] = v_[by_height[k].second];
    return n;
  }
  Vec3 center() const override {
    Vec3 sum = Vec3::Zero();
    for (const Vec3& p : v_) sum += p;
    return sum / static_cast<double>(v_.size());
  }
  double coreRadius() const override {
    double radius = 0.0;
    for (const Vec3& p : v_) radius = std::max(radius, (p - center()).norm());
    return radius;
  }

 private:
  std::vector<Vec3> v_;
  double diagonal_ = 0.0;
};

struct ShapeCase {
  Kind kind;
  const char* name;
  Vec3 dims;  // sphere r; capsule (r, lz); box sides; cylinder/cone (r, lz); ellipsoid radii; convex (a, c)

  /// The FCL geometry, scaled by `scale` about its origin (every shape
  /// contains its origin, so scale > 1 contains the original).
  std::shared_ptr<::fcl::CollisionGeometryd> make(double scale = 1.0) const {
    const Vec3 d = scale * dims;
    switch (kind) {
      case Kind::kSphere: return std::make_shared<::fcl::Sphered>(d.x());
      case Kind::kCapsule: return std::make_shared<::fcl::Capsuled>(d.x(), d.y());
      case Kind::kBox: return std::make_shared<::fcl::Boxd>(d);
      case Kind::kCylinder: return std::make_shared<::fcl::Cylinderd>(d.x(), d.y());
      case Kind::kCone: return std::make_shared<::fcl::Coned>(d.x(), d.y());
      case Kind::kEllipsoid: return std::make_shared<::fcl::Ellipsoidd>(d);
      case Kind::kConvex: return scenes::fclHexPrism(d.x(), d.y());
    }
    return nullptr;
  }

  /// Half the largest extent of the shape's box.
  double halfSize() const {
    switch (kind) {
      case Kind::kSphere: return dims.x();
      case Kind::kCapsule: return dims.x() + 0.5 * dims.y();
      case Kind::kBox: return 0.5 * dims.maxCoeff();
      case Kind::kCylinder:
      case Kind::kCone: return std::max(dims.x(), 0.5 * dims.y());
      case Kind::kEllipsoid: return dims.maxCoeff();
      case Kind::kConvex: return std::max(dims.x(), dims.y());
    }
    return 0.0;
  }

  /// max over the shape (local frame) of d.x: how far it reaches along d.
  double extentAlong(const Vec3& d) const {
    const double rho = std::hypot(d.x(), d.y());
    switch (kind) {
      case Kind::kSphere: return dims.x() * d.norm();
      case Kind::kCapsule: return dims.x() * d.norm() + 0.5 * dims.y() * std::abs(d.z());
      case Kind::kBox: return 0.5 * dims.cwiseAbs().dot(d.cwiseAbs());
      case Kind::kCylinder: return dims.x() * rho + 0.5 * dims.y() * std::abs(d.z());
      case Kind::kCone: return std::max(0.5 * dims.y() * d.z(), dims.x() * rho - 0.5 * dims.y() * d.z());
      case Kind::kEllipsoid: return dims.cwiseProduct(d).norm();
      case Kind::kConvex: {
        const auto convex = make();  // kept alive through the loop
        double best = -INFINITY;
        for (const auto& v : static_cast<const ::fcl::Convexd&>(*convex).getVertices()) best = std::max(best, v.dot(d));
        return best;
      }
    }
    return 0.0;
  }

  /// How deep the shape's lowest point may sink into a flat floor while the
  /// core still promises only the floor's normal (the domain of the core's
  /// own planar-oracle tests: shape_planar_oracle_test.cpp,
  /// convex_planar_oracle_test.cpp). The sphere's oracle is exact: any
  /// depth with the centre in front.
  double oracleDepth() const {
    switch (kind) {
      case Kind::kSphere: return dims.x();
      case Kind::kCapsule: return 0.3 * dims.x();
      case Kind::kBox: return 0.3 * 0.5 * dims.minCoeff();
      default: return 0.08 * 2.0 * halfDiagonal();
    }
  }

  /// Half the diagonal of the shape's local bounding box.
  double halfDiagonal() const {
    return Vec3(extentAlong(Vec3::UnitX()), extentAlong(Vec3::UnitY()), extentAlong(Vec3::UnitZ())).norm();
  }

  /// The core's whole pipeline for this shape (query frame = the instances').
  Status core(const MeshInstance* instances, std::size_t count, const ::fcl::CollisionGeometryd& geometry,
              const Pose& pose, const QuerySettings& settings, QueryScratch& scratch,
              std::vector<Contact>& contacts) const {
    switch (kind) {
      case Kind::kSphere:
        return collideSphere(instances, count, Sphere{pose.translation, dims.x()}, settings, scratch, contacts);
      case Kind::kCapsule:
        return collideCapsule(instances, count, Capsule{dims.x(), 0.5 * dims.y()}, pose, settings, scratch, contacts);
      case Kind::kBox: return collideBox(instances, count, Box{0.5 * dims}, pose, settings, scratch, contacts);
      case Kind::kCylinder:
        return collideCylinder(instances, count, Cylinder{dims.x(), 0.5 * dims.y()}, pose, settings, scratch,
                               contacts);
      case Kind::kCone:
        return collideConvex(instances, count, TestCone(dims.x(), dims.y()), pose, settings, scratch, contacts);
      case Kind::kEllipsoid:
        return collideConvex(instances, count, TestEllipsoid(dims), pose, settings, scratch, contacts);
      case Kind::kConvex:
        return collideConvex(instances, count, TestConvex(static_cast<const ::fcl::Convexd&>(geometry).getVertices()),
                             pose, settings, scratch, contacts);
    }
    return Status::ok();
  }
};

inline std::vector<ShapeCase> allShapes() {
  return {
      {Kind::kSphere, "sphere", Vec3(0.3, 0, 0)},
      {Kind::kCapsule, "capsule", Vec3(0.15, 0.5, 0)},
      {Kind::kBox, "box", Vec3(0.6, 0.4, 0.25)},
      {Kind::kCylinder, "cylinder", Vec3(0.25, 0.4, 0)},
      {Kind::kCone, "cone", Vec3(0.3, 0.5, 0)},
      {Kind::kEllipsoid, "ellipsoid", Vec3(0.35, 0.25, 0.15)},
      {Kind::kConvex, "convex", Vec3(0.3, 0.2, 0)},
  };
}

// --- Conversions -------------------------------------------------------------

/// A core contact (query frame = the mesh's frame) in the adapter's FCL
/// conventions, for a mesh at `mesh_pose`.
inline ::fcl::Contactd expectedContact(const Contact& c, const Pose& mesh_pose, bool mesh_first,
                                       const ::fcl::CollisionGeometryd* mesh, const ::fcl::CollisionGeometryd* shape) {
  const Vec3 n = mesh_pose.rotation * c.normal;
  const Vec3 p = mesh_pose.apply(c.point);
  const int t = static_cast<int>(c.triangle);
  if (mesh_first) return ::fcl::Contactd(mesh, shape, t, ::fcl::Contactd::NONE, p, n, c.depth);
  return ::fcl::Contactd(shape, mesh, ::fcl::Contactd::NONE, t, p, Vec3(-n), c.depth);
}

inline std::string str(const ::fcl::Contactd& c) {
  std::ostringstream s;
  s.precision(17);
  s << "{b1 " << c.b1 << ", b2 " << c.b2 << ", pos " << testing::str(c.pos) << ", normal " << testing::str(c.normal)
    << ", depth " << c.penetration_depth << "}";
  return s.str();
}

inline std::vector<::fcl::Contactd> contactsOf(const ::fcl::CollisionResultd& r) {
  std::vector<::fcl::Contactd> v;
  for (std::size_t i = 0; i < r.numContacts(); ++i) v.push_back(r.getContact(i));
  return v;
}

/// Compares two contact lists as multisets (order by b1, b2, pos). Returns
/// an empty string when they agree within `tol` (positions and depths,
/// absolute) and `tol` on normals; otherwise a description.
// compare_geometry false: o1/o2 are not compared. fcl::collide on an AABB,
// KDOP or kIOS model against a shape collides a temporary copy of the model
// (BVHShapeCollider copies it to move its vertices into the world frame) and
// deletes it on return, so each contact's o1/o2 points at freed memory: an
// address that two calls share only when the allocator happens to reuse it
// (glibc does; ASan's quarantine does not).
inline std::string compareContacts(std::vector<::fcl::Contactd> a, std::vector<::fcl::Contactd> b, double tol,
                                   bool compare_geometry = true) {
  auto less = [](const ::fcl::Contactd& x, const ::fcl::Contactd& y) {
    if (x.b1 != y.b1) return x.b1 < y.b1;
    if (x.b2 != y.b2) return x.b2 < y.b2;
    for (int k = 0; k < 3; ++k)
      if (x.pos[k] != y.pos[k]) return x.pos[k] < y.pos[k];
    return x.penetration_depth < y.penetration_depth;
  };
  std::sort(a.begin(), a.end(), less);
  std::sort(b.begin(), b.end(), less);
  std::ostringstream s;
  if (a.size() != b.size()) {
    s << "count " << a.size() << " vs " << b.size() << ":";
    for (const auto& c : a) s << "\n  got " << str(c);
    for (const auto& c : b) s << "\n  expected " << str(c);
    return s.str();
  }
  for (std::size_t i = 0; i < a.size(); ++i) {
    const auto& x = a[i];
    const auto& y = b[i];
    if ((compare_geometry && (x.o1 != y.o1 || x.o2 != y.o2)) || x.b1 != y.b1 || x.b2 != y.b2 || (x.pos - y.pos).norm() > tol ||
        (x.normal - y.normal).norm() > tol || std::abs(x.penetration_depth - y.penetration_depth) > tol)
      s << "contact " << i << ": got " << str(x) << " expected " << str(y) << "\n";
  }
  return s.str();
}

}  // namespace meshcontact::fcltest
