// Bullet 3 (double precision): btBvhTriangleMeshShape over a
// btTriangleIndexVertexArray that borrows the scene's arrays, queried with
// btCollisionWorld::contactPairTest (every contact of the pair reaches the
// callback; a simulation's persistent manifold would keep at most 4).
//
// With the internal-edge utility: btGenerateInternalEdgeInfo fills a
// btTriangleInfoMap per mesh, the mesh object carries
// CF_CUSTOM_MATERIAL_CALLBACK, and every contact goes through
// btAdjustInternalEdgeContacts, as Bullet's gContactAddedCallback recipe
// does. contactPairTest's result (btBridgedManifoldResult) does not invoke
// gContactAddedCallback itself, so the result callback makes exactly the
// call that callback would make, with the same arguments.
//
// Margins: the sphere's margin is its radius (Bullet's implicit choice, so
// the sphere is exact); the mesh's margin is 0; the box keeps Bullet's
// default 0.04 m margin (the box's outer extents stay the requested ones,
// its edges and corners are rounded by 4 cm). Contacts reported separated
// (within Bullet's contact-breaking threshold) are dropped.
#include "methods.h"

#include <BulletCollision/BroadphaseCollision/btDbvtBroadphase.h>
#include <BulletCollision/CollisionDispatch/btCollisionDispatcher.h>
#include <BulletCollision/CollisionDispatch/btCollisionWorld.h>
#include <BulletCollision/CollisionDispatch/btDefaultCollisionConfiguration.h>
#include <BulletCollision/CollisionDispatch/btInternalEdgeUtility.h>
#include <BulletCollision/CollisionShapes/btBoxShape.h>
#include <BulletCollision/CollisionShapes/btBvhTriangleMeshShape.h>
#include <BulletCollision/CollisionShapes/btOptimizedBvh.h>
#include <BulletCollision/CollisionShapes/btSphereShape.h>
#include <BulletCollision/CollisionShapes/btTriangleIndexVertexArray.h>
#include <BulletCollision/CollisionShapes/btTriangleInfoMap.h>
#include <BulletCollision/CollisionShapes/btTriangleShape.h>

static_assert(sizeof(btScalar) == sizeof(double), "pkg-config bullet-float64 defines BT_USE_DOUBLE_PRECISION");

namespace meshcontact::peers {

namespace {

// Exposes the hash map's array sizes for the memory report.
struct SizedTriangleInfoMap : btTriangleInfoMap {
  std::size_t bytes() const {
    return static_cast<std::size_t>(m_hashTable.capacity()) * sizeof(int) +
           static_cast<std::size_t>(m_next.capacity()) * sizeof(int) +
           static_cast<std::size_t>(m_valueArray.capacity()) * sizeof(btTriangleInfo) +
           static_cast<std::size_t>(m_keyArray.capacity()) * sizeof(btHashInt);
  }
};

struct Callback : btCollisionWorld::ContactResultCallback {
  std::vector<Contact>* out = nullptr;
  bool adjust = false;
  std::uint32_t mesh = 0;

  btScalar addSingleResult(btManifoldPoint& cp, const btCollisionObjectWrapper* w0, int part0, int index0,
                           const btCollisionObjectWrapper* w1, int part1, int index1) override {
    // contactPairTest(shape, mesh): body A is the shape, body B the mesh's
    // triangle; m_normalWorldOnB points from B toward A, i.e. from the mesh
    // toward the shape, and getDistance() < 0 when penetrating.
    if (adjust) {
      // What a gContactAddedCallback does (Bullet's InternalEdgeDemo): the
      // triangle's wrapper first.
      if (w1->getCollisionShape()->getShapeType() == TRIANGLE_SHAPE_PROXYTYPE)
        btAdjustInternalEdgeContacts(cp, w1, w0, part1, index1);
      else if (w0->getCollisionShape()->getShapeType() == TRIANGLE_SHAPE_PROXYTYPE)
        btAdjustInternalEdgeContacts(cp, w0, w1, part0, index0);
    }
    Contact c;
    const btVector3& n = cp.m_normalWorldOnB;
    const btVector3& a = cp.getPositionWorldOnA();
    c.normal = Vec3(n.x(), n.y(), n.z());
    c.point = Vec3(a.x(), a.y(), a.z());
    c.depth = -cp.getDistance();
    c.mesh = mesh;
    c.triangle = static_cast<std::uint32_t>(w1->getCollisionShape()->getShapeType() == TRIANGLE_SHAPE_PROXYTYPE
                                                ? (index1 >= 0 ? index1 : 0)
                                                : (index0 >= 0 ? index0 : 0));
    out->push_back(c);
    return 0;
  }
};

class BulletMethod : public Method {
 public:
  BulletMethod(bool adjust, const CompareScene& scene) : adjust_(adjust), scene_(scene) {}
  ~BulletMethod() override {
    for (auto& o : objects_) world_->removeCollisionObject(o.get());
  }

  Status build() {
    config_ = std::make_unique<btDefaultCollisionConfiguration>();
    dispatcher_ = std::make_unique<btCollisionDispatcher>(config_.get());
    broadphase_ = std::make_unique<btDbvtBroadphase>();
    world_ = std::make_unique<btCollisionWorld>(dispatcher_.get(), broadphase_.get(), config_.get());
    for (const scenes::SceneMesh& piece : scene_.pieces) {
      auto array = std::make_unique<btTriangleIndexVertexArray>(
          static_cast<int>(piece.triangleCount()),
          reinterpret_cast<int*>(const_cast<std::uint32_t*>(piece.indices.data())), 3 * static_cast<int>(sizeof(int)),
          static_cast<int>(piece.vertexCount()), const_cast<btScalar*>(piece.vertices.data()),
          3 * static_cast<int>(sizeof(btScalar)));
      auto shape = std::make_unique<btBvhTriangleMeshShape>(array.get(), true, true);
      shape->setMargin(0);
      auto object = std::make_unique<btCollisionObject>();
      object->setCollisionShape(shape.get());
      if (adjust_) {
        auto map = std::make_unique<SizedTriangleInfoMap>();
        btGenerateInternalEdgeInfo(shape.get(), map.get());
        object->setCollisionFlags(object->getCollisionFlags() | btCollisionObject::CF_CUSTOM_MATERIAL_CALLBACK);
        maps_.push_back(std::move(map));
      }
      world_->addCollisionObject(object.get());
      arrays_.push_back(std::move(array));
      shapes_.push_back(std::move(shape));
      objects_.push_back(std::move(object));
    }
    sphere_shape_ = std::make_unique<btSphereShape>(1.0);
    box_shape_ = std::make_unique<btBoxShape>(btVector3(1, 1, 1));
    sphere_ = std::make_unique<btCollisionObject>();
    sphere_->setCollisionShape(sphere_shape_.get());
    box_ = std::make_unique<btCollisionObject>();
    return Status::ok();
  }

  std::string name() const override { return adjust_ ? "bullet-iedge" : "bullet"; }

  std::size_t structureBytes() const override {
    std::size_t n = 0;
    for (const auto& s : shapes_) {
      const btOptimizedBvh* bvh = s->getOptimizedBvh();
      if (bvh) n += bvh->calculateSerializeBufferSize();
    }
    for (const auto& m : maps_) n += m->bytes();
    return n;
  }

  Status collideSphere(const SpherePlacement& p, std::vector<Contact>& out) override {
    // btSphereShape's radius is its margin (implicit): set both at once.
    sphere_shape_->setUnscaledRadius(p.radius);
    btTransform t;
    t.setIdentity();
    t.setOrigin(btVector3(p.center.x(), p.center.y(), p.center.z()));
    sphere_->setWorldTransform(t);
    return collide(sphere_.get(), out);
  }

  Status collideBox(const BoxPlacement& p, std::vector<Contact>& out) override {
    // A new btBoxShape per query: btBoxShape has no extent setter (setting the
    // local scaling of a unit box would also scale its margin).
    box_shape_ = std::make_unique<btBoxShape>(btVector3(p.half_extents.x(), p.half_extents.y(), p.half_extents.z()));
    box_->setCollisionShape(box_shape_.get());
    const Mat3& R = p.pose.rotation;
    btTransform t(btMatrix3x3(R(0, 0), R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2), R(2, 0), R(2, 1), R(2, 2)),
                  btVector3(p.pose.translation.x(), p.pose.translation.y(), p.pose.translation.z()));
    box_->setWorldTransform(t);
    return collide(box_.get(), out);
  }

 private:
  Status collide(btCollisionObject* shape, std::vector<Contact>& out) {
    out.clear();
    callback_.out = &out;
    callback_.adjust = adjust_;
    for (std::size_t m = 0; m < objects_.size(); ++m) {
      callback_.mesh = static_cast<std::uint32_t>(m);
      world_->contactPairTest(shape, objects_[m].get(), callback_);
    }
    keepPenetrating(out, dropped_separated_);
    return Status::ok();
  }

  bool adjust_;
  const CompareScene& scene_;
  std::unique_ptr<btDefaultCollisionConfiguration> config_;
  std::unique_ptr<btCollisionDispatcher> dispatcher_;
  std::unique_ptr<btDbvtBroadphase> broadphase_;
  std::unique_ptr<btCollisionWorld> world_;
  std::vector<std::unique_ptr<btTriangleIndexVertexArray>> arrays_;
  std::vector<std::unique_ptr<btBvhTriangleMeshShape>> shapes_;
  std::vector<std::unique_ptr<SizedTriangleInfoMap>> maps_;
  std::vector<std::unique_ptr<btCollisionObject>> objects_;
  std::unique_ptr<btSphereShape> sphere_shape_;
  std::unique_ptr<btBoxShape> box_shape_;
  std::unique_ptr<btCollisionObject> sphere_, box_;
  Callback callback_;
};

}  // namespace

Status makeBulletMethod(bool internal_edge_utility, const CompareScene& scene, std::unique_ptr<Method>& out) {
  auto m = std::make_unique<BulletMethod>(internal_edge_utility, scene);
  if (Status s = m->build(); !s) return s;
  out = std::move(m);
  return Status::ok();
}

}  // namespace meshcontact::peers
