// A robot-like chain (a box base, two capsule links, a box gripper) checked
// against an environment made of several FCL meshes: a table whose top is
// two boards meeting at a seam, four legs, and a shelf of separate boards.
// For a few configurations, each link's contacts are printed twice:
//   FCL:         fcl::collide through FCL's broadphase and its default
//                callback (one contact per touched triangle);
//   meshcontact: the same broadphase with meshcontact::fcl::BroadphaseCollector
//                (each link against all the meshes it touches, as one surface).
// Before them, the yes/no answer of collision checking: FCL's default
// callback against meshcontact::fcl::defaultCollisionFunction; and each
// link's clearance within a 5 cm margin (meshcontact only: FCL 0.7's
// collision request has no contact distance).
// Every environment surface here is flat, so every valid normal is a face
// normal (vertical on the table top and the boards); the count of "tilted"
// normals (more than 2 degrees off every face normal of the touched
// triangles' planes, i.e. internal-edge ghosts) is printed for both.
#include <meshcontact/fcl.h>

#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/broadphase/default_broadphase_callbacks.h>
#include <fcl/fcl.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace {

using Vec3 = Eigen::Vector3d;
using Model = fcl::BVHModel<fcl::OBBRSSd>;

// A box [lo, hi] as a triangle mesh, each face cut into cells of about
// `cell` (two triangles per cell, alternating diagonals), outward front
// faces. Shared vertices along the box's edges are reused. `open_x`: leave
// out the -x (-1) or +x (+1) face, for a box that continues in another mesh
// (the two boards of the table top form one closed surface, with no face
// inside it).
std::shared_ptr<Model> tessellatedBox(const Vec3& lo, const Vec3& hi, double cell, int open_x = 0) {
  std::vector<fcl::Vector3d> vertices;
  std::vector<fcl::Triangle> triangles;
  std::map<std::array<double, 3>, int> index;  // weld equal positions
  auto vertex = [&](const Vec3& p) {
    const std::array<double, 3> key{p.x(), p.y(), p.z()};
    auto it = index.find(key);
    if (it != index.end()) return it->second;
    vertices.push_back(p);
    return index[key] = static_cast<int>(vertices.size() - 1);
  };
  // A face: origin + s u + t v, front along u x v.
  auto face = [&](const Vec3& origin, const Vec3& u, const Vec3& v) {
    const int nu = std::max(1, static_cast<int>(std::round(u.norm() / cell)));
    const int nv = std::max(1, static_cast<int>(std::round(v.norm() / cell)));
    for (int j = 0; j < nv; ++j)
      for (int i = 0; i < nu; ++i) {
        auto at = [&](int a, int b) { return vertex(origin + u * (double(a) / nu) + v * (double(b) / nv)); };
        const int a = at(i, j), b = at(i + 1, j), c = at(i + 1, j + 1), d = at(i, j + 1);
        if ((i + j) % 2) {
          triangles.emplace_back(a, b, c);
          triangles.emplace_back(a, c, d);
        } else {
          triangles.emplace_back(a, b, d);
          triangles.emplace_back(b, c, d);
        }
      }
  };
  const Vec3 d = hi - lo;
  face(Vec3(lo.x(), lo.y(), hi.z()), Vec3(d.x(), 0, 0), Vec3(0, d.y(), 0));  // top (+z)
  face(Vec3(lo.x(), hi.y(), lo.z()), Vec3(d.x(), 0, 0), Vec3(0, -d.y(), 0)); // bottom (-z)
  face(Vec3(lo.x(), lo.y(), lo.z()), Vec3(d.x(), 0, 0), Vec3(0, 0, d.z()));  // -y
  face(Vec3(hi.x(), hi.y(), lo.z()), Vec3(-d.x(), 0, 0), Vec3(0, 0, d.z())); // +y
  if (open_x != -1) face(Vec3(lo.x(), hi.y(), lo.z()), Vec3(0, -d.y(), 0), Vec3(0, 0, d.z()));  // -x
  if (open_x != 1) face(Vec3(hi.x(), lo.y(), lo.z()), Vec3(0, d.y(), 0), Vec3(0, 0, d.z()));   // +x
  auto model = std::make_shared<Model>();
  model->beginModel();
  model->addSubModel(vertices, triangles);
  model->endModel();
  return model;
}

struct Part {
  std::string name;
  std::unique_ptr<fcl::CollisionObjectd> object;
};

fcl::Transform3d pose(const Eigen::Matrix3d& r, const Vec3& t) {
  fcl::Transform3d tf = fcl::Transform3d::Identity();
  tf.linear() = r;
  tf.translation() = t;
  return tf;
}

Eigen::Matrix3d rotY(double a) { return Eigen::AngleAxisd(a, Vec3::UnitY()).toRotationMatrix(); }
Eigen::Matrix3d rotZ(double a) { return Eigen::AngleAxisd(a, Vec3::UnitZ()).toRotationMatrix(); }

// The chain: a base box on a mobile platform at `base`, yawed by `yaw`; a
// shoulder at its top pitching link 1 (capsule) by `q1`; an elbow pitching
// link 2 (capsule) by `q2`; a gripper box at the end pitched by `q3`.
// Capsules and boxes are centred on their frames (FCL's convention), the
// capsule's axis along its local z.
struct Robot {
  std::vector<Part> links;
  Robot() {
    links.push_back({"base", std::make_unique<fcl::CollisionObjectd>(std::make_shared<fcl::Boxd>(0.3, 0.3, 0.6))});
    links.push_back({"link1", std::make_unique<fcl::CollisionObjectd>(std::make_shared<fcl::Capsuled>(0.05, 0.45))});
    links.push_back({"link2", std::make_unique<fcl::CollisionObjectd>(std::make_shared<fcl::Capsuled>(0.04, 0.40))});
    links.push_back({"gripper", std::make_unique<fcl::CollisionObjectd>(std::make_shared<fcl::Boxd>(0.16, 0.10, 0.06))});
  }
  // Forward kinematics; links point along +x of their parent when q = 0.
  void place(const Vec3& base, double yaw, double q1, double q2, double q3) {
    const Eigen::Matrix3d r0 = rotZ(yaw);
    links[0].object->setTransform(pose(r0, base + Vec3(0, 0, 0.3)));
    const Vec3 shoulder = base + Vec3(0, 0, 0.65);
    // A capsule along local z: rotate z onto the link's direction.
    const Eigen::Matrix3d z_to_x = rotY(M_PI / 2);
    const Eigen::Matrix3d r1 = r0 * rotY(q1);
    const Vec3 elbow = shoulder + r1 * Vec3(0.5, 0, 0);
    links[1].object->setTransform(pose(r1 * z_to_x, 0.5 * (shoulder + elbow)));
    const Eigen::Matrix3d r2 = r1 * rotY(q2);
    const Vec3 wrist = elbow + r2 * Vec3(0.45, 0, 0);
    links[2].object->setTransform(pose(r2 * z_to_x, 0.5 * (elbow + wrist)));
    const Eigen::Matrix3d r3 = r2 * rotY(q3);
    links[3].object->setTransform(pose(r3, wrist + r3 * Vec3(0.08, 0, 0)));
    for (Part& p : links) p.object->computeAABB();
  }
};

// The lowest point of a box or capsule link (FCL's own object AABB is loose
// for rotated shapes).
double lowestZ(const fcl::CollisionObjectd& o) {
  const Eigen::Matrix3d& r = o.getRotation();
  const double z = o.getTranslation().z();
  if (o.getNodeType() == fcl::GEOM_BOX) {
    const Vec3 h = 0.5 * static_cast<const fcl::Boxd&>(*o.collisionGeometry()).side;
    return z - r.row(2).cwiseAbs().dot(h);
  }
  const auto& c = static_cast<const fcl::Capsuled&>(*o.collisionGeometry());
  return z - c.radius - 0.5 * c.lz * std::abs(r(2, 2));
}

// Tilted = more than 2 degrees off the touched triangle's face normal (every
// surface here is flat, so the face normal is the only valid one), after
// orienting the normal from the environment toward the robot.
bool tilted(const fcl::Contactd& c, bool env_is_o1) {
  const auto* model = static_cast<const Model*>(env_is_o1 ? c.o1 : c.o2);
  const int t = static_cast<int>(env_is_o1 ? c.b1 : c.b2);
  const fcl::Triangle& tri = model->tri_indices[t];
  const Vec3 n = (model->vertices[tri[1]] - model->vertices[tri[0]])
                     .cross(model->vertices[tri[2]] - model->vertices[tri[0]])
                     .normalized();
  const Vec3 from_env = env_is_o1 ? c.normal : Vec3(-c.normal);
  return std::atan2(from_env.cross(n).norm(), from_env.dot(n)) > 2.0 * M_PI / 180.0;
}

}  // namespace

int main() {
  // --- The environment: several separate meshes, 5 cm cells. ---
  std::vector<Part> env;
  auto add = [&](const std::string& name, const Vec3& lo, const Vec3& hi, int open_x = 0) {
    env.push_back({name, std::make_unique<fcl::CollisionObjectd>(tessellatedBox(lo, hi, 0.05, open_x))});
  };
  // The table top: one slab made of two meshes that meet at x = 0.6 (their
  // seam vertices are bitwise equal, so the seam is an internal edge).
  add("table top (left half)", Vec3(0.0, -0.4, 0.72), Vec3(0.6, 0.4, 0.76), +1);
  add("table top (right half)", Vec3(0.6, -0.4, 0.72), Vec3(1.2, 0.4, 0.76), -1);
  for (int i = 0; i < 4; ++i) {
    const double x = i % 2 ? 1.1 : 0.05, y = i / 2 ? 0.3 : -0.35;
    add("table leg " + std::to_string(i), Vec3(x, y, 0.0), Vec3(x + 0.05, y + 0.05, 0.72));
  }
  add("shelf side (near)", Vec3(1.4, -0.52, 0.0), Vec3(1.75, -0.5, 1.4));
  add("shelf side (far)", Vec3(1.4, 0.5, 0.0), Vec3(1.75, 0.52, 1.4));
  for (int k = 0; k < 3; ++k) {
    const double z = 0.35 + 0.4 * k;
    add("shelf board " + std::to_string(k), Vec3(1.4, -0.5, z - 0.02), Vec3(1.75, 0.5, z));
  }
  fcl::DynamicAABBTreeCollisionManagerd environment;
  for (Part& p : env) environment.registerObject(p.object.get());
  environment.setup();
  std::map<const fcl::CollisionGeometryd*, std::string> env_name;
  for (Part& p : env) env_name[p.object->collisionGeometry().get()] = p.name;

  // --- The robot, in three configurations. ---
  Robot robot;
  // Each configuration names a link and where it should touch: the whole
  // robot (a mobile base) is moved so that this link's centre is over
  // (x, y) and its lowest point is 3 mm below `surface` (a planner's
  // "slightly in collision" pose), so the example needs no hand-tuned base.
  struct Config {
    const char* what;
    double yaw, q1, q2, q3;
    int link;          // -1: no anchoring, the base stays at `base`
    double x, y, surface;
    Vec3 base;
  };
  // Joint angles pitch each link down (positive) or up (negative); q1 + q2 +
  // q3 = 0 keeps the gripper level, q1 + q2 = 0 keeps link 2 level.
  const Config configs[] = {
      {"gripper pressed flat on the table top, across the seam between its two boards", 0.0, -0.25, 0.80, -0.55, 3,
       0.6, 0.05, 0.76, Vec3::Zero()},
      {"link 2 lying on the middle shelf board, reaching in from the open side", M_PI, -0.05, 0.05, 0.0, 2, 1.6, 0.1,
       0.75, Vec3::Zero()},
      {"reaching over the table, clear of everything", 0.3, -0.6, 0.6, 0.0, -1, 0, 0, 0, Vec3(-0.5, 0.0, 0.2)},
  };

  for (const Config& cfg : configs) {
    Vec3 base = cfg.base;
    robot.place(base, cfg.yaw, cfg.q1, cfg.q2, cfg.q3);
    if (cfg.link >= 0) {
      const fcl::CollisionObjectd& o = *robot.links[cfg.link].object;
      const Vec3 centre = o.getTranslation();
      base += Vec3(cfg.x - centre.x(), cfg.y - centre.y(), cfg.surface - 0.003 - lowestZ(o));
      robot.place(base, cfg.yaw, cfg.q1, cfg.q2, cfg.q3);
    }
    std::printf("\n=== %s ===\n", cfg.what);
    fcl::DynamicAABBTreeCollisionManagerd arm;
    for (Part& p : robot.links) arm.registerObject(p.object.get());
    arm.setup();

    // FCL: its broadphase and default callback, all contacts.
    fcl::DefaultCollisionData<double> fcl_data;
    fcl_data.request = fcl::CollisionRequestd(10000, true);
    environment.collide(&arm, &fcl_data, fcl::DefaultCollisionFunction<double>);
    // meshcontact: the same broadphase, the collector's callback.
    meshcontact::fcl::BroadphaseCollector collector(fcl::CollisionRequestd(10000, true));
    // The environment's meshes that a query reaches beyond the bounds the
    // manager pairs (a contact distance; a convex link's deep passes).
    collector.setMeshManager(&environment);
    environment.collide(&arm, &collector, meshcontact::fcl::BroadphaseCollector::callback);
    if (meshcontact::Status s = collector.finish(); !s) {
      std::fprintf(stderr, "meshcontact: %s\n", s.message().c_str());
      return 1;
    }

    // Collision checking, as a planner asks it (is this configuration in
    // collision?): FCL's default request, the pass ending at the first pair
    // in collision, with meshcontact::fcl::defaultCollisionFunction in place
    // of FCL's callback.
    fcl::DefaultCollisionData<double> fcl_check, mc_check;
    environment.collide(&arm, &fcl_check, fcl::DefaultCollisionFunction<double>);
    environment.collide(&arm, &mc_check, meshcontact::fcl::defaultCollisionFunction);
    if (mc_check.done && !meshcontact::fcl::lastStatus()) {  // the pass ended at an error
      std::fprintf(stderr, "meshcontact: %s\n", meshcontact::fcl::lastStatus().message().c_str());
      return 1;
    }
    std::printf("  in collision: FCL %s | meshcontact %s\n", fcl_check.result.isCollision() ? "yes" : "no",
                mc_check.result.isCollision() ? "yes" : "no");

    // Clearance, as a planner with a safety margin asks it: each link within
    // 5 cm of the environment and its signed distance (minus the deepest
    // contact's depth: negative when in contact). A manager pairs a link only
    // with meshes whose bounds overlap its own; given the arm's manager too
    // (setShapeManager), the collector also queries the links it paired with
    // no mesh, on the meshes within the margin.
    meshcontact::fcl::Options margin;
    margin.settings.contact_distance = 0.05;
    meshcontact::fcl::BroadphaseCollector clearance(fcl::CollisionRequestd(10000, true), margin);
    clearance.setMeshManager(&environment);
    clearance.setShapeManager(&arm);
    environment.collide(&arm, &clearance, meshcontact::fcl::BroadphaseCollector::callback);
    if (meshcontact::Status s = clearance.finish(); !s) {
      std::fprintf(stderr, "meshcontact: %s\n", s.message().c_str());
      return 1;
    }
    std::printf("  within %.0f cm:", 100 * margin.settings.contact_distance);
    int near_links = 0;
    for (Part& link : robot.links) {
      double distance = INFINITY;
      for (const meshcontact::fcl::ObjectContact& oc : clearance.contacts())
        if (oc.o2 == link.object.get()) distance = std::min(distance, -oc.contact.penetration_depth);
      if (std::isinf(distance)) continue;
      std::printf(" %s %.1f mm", link.name.c_str(), 1000 * distance);
      ++near_links;
    }
    std::printf("%s\n", near_links == 0 ? " none" : "");

    for (Part& link : robot.links) {
      const fcl::CollisionGeometryd* g = link.object->collisionGeometry().get();
      int fcl_count = 0, fcl_tilted = 0, mc_count = 0, mc_tilted = 0;
      std::map<std::string, int> touched;
      for (std::size_t i = 0; i < fcl_data.result.numContacts(); ++i) {
        const fcl::Contactd& c = fcl_data.result.getContact(i);
        // FCL's mesh-vs-shape contacts always say o1 = the mesh.
        if (c.o2 != g && c.o1 != g) continue;
        const bool env_is_o1 = c.o2 == g;
        ++fcl_count;
        fcl_tilted += tilted(c, env_is_o1);
      }
      for (const meshcontact::fcl::ObjectContact& oc : collector.contacts()) {
        if (oc.o2 != link.object.get()) continue;
        ++mc_count;
        mc_tilted += tilted(oc.contact, true);
        ++touched[env_name[oc.contact.o1]];
      }
      std::printf("  %-8s FCL: %3d contacts, %3d tilted | meshcontact: %2d contacts, %d tilted", link.name.c_str(),
                  fcl_count, fcl_tilted, mc_count, mc_tilted);
      for (const auto& [name, n] : touched) std::printf("  [%s: %d]", name.c_str(), n);
      std::printf("\n");
      for (const meshcontact::fcl::ObjectContact& oc : collector.contacts()) {
        if (oc.o2 != link.object.get()) continue;
        const fcl::Contactd& c = oc.contact;
        std::printf("           point (%.3f, %.3f, %.3f)  normal (%+.3f, %+.3f, %+.3f)  depth %.4f  triangle %ld\n",
                    c.pos.x(), c.pos.y(), c.pos.z(), c.normal.x(), c.normal.y(), c.normal.z(), c.penetration_depth,
                    static_cast<long>(c.b1));
      }
    }
  }
  return 0;
}
