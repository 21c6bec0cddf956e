// ODE's native sphere/box-vs-trimesh colliders (OPCODE), untouched: this
// library never links meshcontact::ode, so no collider override is installed.
#include "methods.h"

#include <ode/ode.h>

#include <mutex>

namespace meshcontact::peers {

namespace {

constexpr int kMaxContacts = 512;

void initOde() {
  static std::once_flag once;
  std::call_once(once, [] { dInitODE2(0); });
  // Per thread; repeated calls are cheap no-ops once allocated.
  dAllocateODEDataForThread(dAllocateMaskAll);
}

class OdeMethod : public Method {
 public:
  explicit OdeMethod(const CompareScene& scene) : scene_(scene) {}
  ~OdeMethod() override {
    for (dGeomID g : meshes_) dGeomDestroy(g);
    for (dTriMeshDataID d : data_) dGeomTriMeshDataDestroy(d);
    if (sphere_) dGeomDestroy(sphere_);
    if (box_) dGeomDestroy(box_);
  }

  Status build() {
    initOde();
    static_assert(sizeof(dTriIndex) == sizeof(std::uint32_t), "ODE built with 32-bit trimesh indices");
    for (const scenes::SceneMesh& piece : scene_.pieces) {
      dTriMeshDataID data = dGeomTriMeshDataCreate();
      dGeomTriMeshDataBuildDouble(data, piece.vertices.data(), 3 * sizeof(double),
                                  static_cast<int>(piece.vertexCount()),
                                  reinterpret_cast<const dTriIndex*>(piece.indices.data()),
                                  static_cast<int>(piece.indices.size()), 3 * sizeof(std::uint32_t));
      data_.push_back(data);
      meshes_.push_back(dCreateTriMesh(nullptr, data, nullptr, nullptr, nullptr));
    }
    sphere_ = dCreateSphere(nullptr, 1.0);
    box_ = dCreateBox(nullptr, 1.0, 1.0, 1.0);
    return Status::ok();
  }

  std::string name() const override { return "ode"; }

  Status collideSphere(const SpherePlacement& p, std::vector<Contact>& out) override {
    dGeomSphereSetRadius(sphere_, p.radius);
    dGeomSetPosition(sphere_, p.center.x(), p.center.y(), p.center.z());
    return collide(sphere_, out);
  }

  Status collideBox(const BoxPlacement& p, std::vector<Contact>& out) override {
    dGeomBoxSetLengths(box_, 2 * p.half_extents.x(), 2 * p.half_extents.y(), 2 * p.half_extents.z());
    dMatrix3 R;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) R[4 * i + j] = p.pose.rotation(i, j);
      R[4 * i + 3] = 0;
    }
    dGeomSetRotation(box_, R);
    const Vec3& t = p.pose.translation;
    dGeomSetPosition(box_, t.x(), t.y(), t.z());
    return collide(box_, out);
  }

 private:
  Status collide(dGeomID shape, std::vector<Contact>& out) {
    out.clear();
    for (std::size_t m = 0; m < meshes_.size(); ++m) {
      // dCollide(shape, mesh): ODE's normal points into the first geom, i.e.
      // from the mesh toward the shape (DESIGN.md §2), depth > 0.
      const int n = dCollide(shape, meshes_[m], kMaxContacts, buffer_, sizeof(dContactGeom)) & 0xffff;
      for (int i = 0; i < n; ++i) {
        const dContactGeom& g = buffer_[i];
        Contact c;
        c.point = Vec3(g.pos[0], g.pos[1], g.pos[2]);
        c.normal = Vec3(g.normal[0], g.normal[1], g.normal[2]);
        c.depth = g.depth;
        c.mesh = static_cast<std::uint32_t>(m);
        c.triangle = static_cast<std::uint32_t>(g.side2 >= 0 ? g.side2 : 0);
        out.push_back(c);
      }
    }
    keepPenetrating(out, dropped_separated_);
    return Status::ok();
  }

  const CompareScene& scene_;
  std::vector<dTriMeshDataID> data_;
  std::vector<dGeomID> meshes_;
  dGeomID sphere_ = nullptr;
  dGeomID box_ = nullptr;
  dContactGeom buffer_[kMaxContacts];
};

}  // namespace

Status makeOdeMethod(const CompareScene& scene, std::unique_ptr<Method>& out) {
  auto m = std::make_unique<OdeMethod>(scene);
  if (Status s = m->build(); !s) return s;
  out = std::move(m);
  return Status::ok();
}

}  // namespace meshcontact::peers
