// meshcontact itself (index keys, position keys) and the two naive
// baselines of reference §2, behind the peers interface.
#include "methods.h"

#include <meshcontact/meshcontact.h>
#include <meshcontact/shapes.h>

namespace meshcontact::peers {

namespace {

class CoreMethod : public Method {
 public:
  enum class Kind { kAutoKeys, kPositionKeys, kNaiveClosest, kNaiveTriangleNormal };

  CoreMethod(Kind kind, const CompareScene& scene) : kind_(kind), scene_(scene) {}

  Status build() {
    meshes_.resize(scene_.pieces.size());
    for (std::size_t i = 0; i < meshes_.size(); ++i) {
      // Borrowed arrays: memoryBytes() is then the BVH alone.
      if (Status s = meshes_[i].build(scene_.pieces[i].view(), Storage::kBorrow); !s) return s;
      instances_.push_back({&meshes_[i], Pose::identity()});
    }
    switch (kind_) {
      case Kind::kAutoKeys:
        // What a user gets by default: index keys on one welded mesh,
        // position keys on several meshes or duplicated vertices.
        settings_.key_mode = KeyMode::kAuto;
        break;
      case Kind::kPositionKeys:
        settings_.key_mode = KeyMode::kVertexPosition;
        break;
      case Kind::kNaiveClosest:
      case Kind::kNaiveTriangleNormal:
        settings_.key_mode = KeyMode::kVertexPosition;
        settings_.filter = FilterMode::kNone;
        settings_.reduce_manifold = false;  // every per-triangle contact, as the naive method makes
        break;
    }
    return Status::ok();
  }

  std::string name() const override {
    switch (kind_) {
      case Kind::kAutoKeys: return "meshcontact";
      case Kind::kPositionKeys: return "meshcontact-position";
      case Kind::kNaiveClosest: return "naive-closest";
      case Kind::kNaiveTriangleNormal: return "naive-trinormal";
    }
    return "";
  }

  bool supportsBox() const override { return kind_ != Kind::kNaiveTriangleNormal; }

  std::size_t structureBytes() const override {
    std::size_t n = 0;
    for (const TriangleMesh& m : meshes_) n += m.memoryBytes();
    return n;
  }

  Status collideSphere(const SpherePlacement& p, std::vector<Contact>& out) override {
    const Sphere sphere{p.center, p.radius};
    Status s = meshcontact::collideSphere(instances_.data(), instances_.size(), sphere, settings_, scratch_, out);
    if (!s) return s;
    if (kind_ == Kind::kNaiveTriangleNormal) {
      // The triangle-normal method (ODE's, reference §2 "cliff problem"): every
      // touched triangle pushes along its face normal, by the sphere's depth
      // below the triangle's plane.
      for (Contact& c : out) {
        const std::uint32_t* id = scene_.pieces[c.mesh].indices.data() + 3 * static_cast<std::size_t>(c.triangle);
        const scenes::SceneMesh& piece = scene_.pieces[c.mesh];
        const Vec3 a = piece.vertex(id[0]), b = piece.vertex(id[1]), d = piece.vertex(id[2]);
        const Vec3 n = normalizedOr((b - a).cross(d - a), c.normal);
        c.normal = n;
        c.depth = p.radius - n.dot(p.center - a);
        c.point = p.center - p.radius * n;
      }
    }
    dropSeparated(out);
    return Status::ok();
  }

  Status collideBox(const BoxPlacement& p, std::vector<Contact>& out) override {
    if (!supportsBox()) return Status(ErrorCode::kInvalidSettings, name() + ": no box query");
    Status s = meshcontact::collideBox(instances_.data(), instances_.size(), Box{p.half_extents}, p.pose, settings_,
                                       scratch_, out);
    if (!s) return s;
    dropSeparated(out);
    return Status::ok();
  }

 private:
  void dropSeparated(std::vector<Contact>& out) {
    std::size_t k = 0;
    for (const Contact& c : out)
      if (c.depth > 0.0) out[k++] = c;
    dropped_separated_ += static_cast<long>(out.size() - k);
    out.resize(k);
  }

  Kind kind_;
  const CompareScene& scene_;
  std::vector<TriangleMesh> meshes_;
  std::vector<MeshInstance> instances_;
  QuerySettings settings_;
  QueryScratch scratch_;
};

}  // namespace

Status makeCoreMethod(const std::string& name, const CompareScene& scene, std::unique_ptr<Method>& out) {
  CoreMethod::Kind kind;
  if (name == "meshcontact") kind = CoreMethod::Kind::kAutoKeys;
  else if (name == "meshcontact-position") kind = CoreMethod::Kind::kPositionKeys;
  else if (name == "naive-closest") kind = CoreMethod::Kind::kNaiveClosest;
  else if (name == "naive-trinormal") kind = CoreMethod::Kind::kNaiveTriangleNormal;
  else return Status(ErrorCode::kInvalidSettings, "unknown core method '" + name + "'");
  auto m = std::make_unique<CoreMethod>(kind, scene);
  if (Status s = m->build(); !s) return s;
  out = std::move(m);
  return Status::ok();
}

}  // namespace meshcontact::peers
