// FCL's native mesh-vs-shape collide: BVHModel<OBBRSS>, libccd GJK/EPA
// (GST_LIBCCD), every contact requested.
#include "methods.h"

#include <fcl/geometry/bvh/BVH_model.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/collision_object.h>

namespace meshcontact::peers {

namespace {

using Model = fcl::BVHModel<fcl::OBBRSSd>;

class FclMethod : public Method {
 public:
  explicit FclMethod(const CompareScene& scene) : scene_(scene) {}

  Status build() {
    for (const scenes::SceneMesh& piece : scene_.pieces) {
      auto model = std::make_shared<Model>();
      std::vector<fcl::Vector3d> points;
      std::vector<fcl::Triangle> triangles;
      for (std::size_t i = 0; i < piece.vertexCount(); ++i) points.emplace_back(piece.vertex(i));
      for (std::size_t t = 0; t < piece.triangleCount(); ++t)
        triangles.emplace_back(piece.indices[3 * t], piece.indices[3 * t + 1], piece.indices[3 * t + 2]);
      if (model->beginModel() != fcl::BVH_OK || model->addSubModel(points, triangles) != fcl::BVH_OK ||
          model->endModel() != fcl::BVH_OK)
        return Status(ErrorCode::kInvalidSettings, "fcl: BVHModel<OBBRSS> build failed");
      objects_.push_back(std::make_unique<fcl::CollisionObjectd>(model));
      models_.push_back(model);
    }
    sphere_ = std::make_shared<fcl::Sphered>(1.0);
    box_ = std::make_shared<fcl::Boxd>(1.0, 1.0, 1.0);
    sphere_object_ = std::make_unique<fcl::CollisionObjectd>(sphere_);
    box_object_ = std::make_unique<fcl::CollisionObjectd>(box_);
    request_.num_max_contacts = 100000;
    request_.enable_contact = true;
    request_.gjk_solver_type = fcl::GST_LIBCCD;
    return Status::ok();
  }

  std::string name() const override { return "fcl"; }

  std::size_t structureBytes() const override {
    // FCL cannot borrow arrays: its BV nodes, primitive index and its own
    // copies of the vertices and triangles (BVHModel::memUsage only prints these).
    std::size_t n = 0;
    for (const auto& m : models_)
      n += static_cast<std::size_t>(m->getNumBVs()) * sizeof(fcl::BVNode<fcl::OBBRSSd>) +
           static_cast<std::size_t>(m->num_tris) * (sizeof(fcl::Triangle) + sizeof(unsigned int)) +
           static_cast<std::size_t>(m->num_vertices) * sizeof(fcl::Vector3d);
    return n;
  }

  Status collideSphere(const SpherePlacement& p, std::vector<Contact>& out) override {
    sphere_->radius = p.radius;
    sphere_->computeLocalAABB();
    sphere_object_->setTransform(fcl::Matrix3d::Identity(), p.center);
    sphere_object_->computeAABB();
    return collide(*sphere_object_, out);
  }

  Status collideBox(const BoxPlacement& p, std::vector<Contact>& out) override {
    box_->side = 2.0 * p.half_extents;
    box_->computeLocalAABB();
    box_object_->setTransform(p.pose.rotation, p.pose.translation);
    box_object_->computeAABB();
    return collide(*box_object_, out);
  }

 private:
  Status collide(const fcl::CollisionObjectd& shape, std::vector<Contact>& out) {
    out.clear();
    for (std::size_t m = 0; m < objects_.size(); ++m) {
      result_.clear();
      fcl::collide(objects_[m].get(), &shape, request_, result_);
      for (std::size_t i = 0; i < result_.numContacts(); ++i) {
        const fcl::Contactd& fc = result_.getContact(i);
        Contact c;
        c.point = fc.pos;
        // FCL's normal points from o1 (the mesh) to o2 (the shape): already
        // "from the mesh toward the shape". Its sphere-triangle depth comes
        // back negative (DESIGN.md §4): the magnitude is the overlap.
        c.normal = fc.normal;
        c.depth = std::abs(fc.penetration_depth);
        c.mesh = static_cast<std::uint32_t>(m);
        c.triangle = static_cast<std::uint32_t>(fc.b1 >= 0 ? fc.b1 : 0);
        out.push_back(c);
      }
    }
    keepPenetrating(out, dropped_separated_);
    return Status::ok();
  }

  const CompareScene& scene_;
  std::vector<std::shared_ptr<Model>> models_;
  std::vector<std::unique_ptr<fcl::CollisionObjectd>> objects_;
  std::shared_ptr<fcl::Sphered> sphere_;
  std::shared_ptr<fcl::Boxd> box_;
  std::unique_ptr<fcl::CollisionObjectd> sphere_object_, box_object_;
  fcl::CollisionRequestd request_;
  fcl::CollisionResultd result_;
};

}  // namespace

Status makeFclMethod(const CompareScene& scene, std::unique_ptr<Method>& out) {
  auto m = std::make_unique<FclMethod>(scene);
  if (Status s = m->build(); !s) return s;
  out = std::move(m);
  return Status::ok();
}

}  // namespace meshcontact::peers
