// BroadphaseCollector with FCL's DynamicAABBTreeCollisionManager: a floor
// made of 16 separate tile models and shapes over it. Per shape, the tiles it
// touches are filtered together: the contacts are the core's multi-mesh
// query (MeshInstance list), and no ghost normal appears at the seams, where
// querying each tile on its own (the drop-in per pair) does give ghosts.
#include "fcl_test_support.h"

#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/broadphase/default_broadphase_callbacks.h>

#include <functional>
#include <map>
#include <set>

namespace meshcontact::fcltest {
namespace {

constexpr double kDeg = M_PI / 180.0;

// The tiles of a floor, in the floor's frame (`floor_pose`). Each tile's
// model holds the floor's coordinates and has the floor's transform (equal
// transforms keep the seams bitwise equal), or, with `own_frames`, holds
// coordinates relative to its corner and has the floor's transform moved to
// that corner (instanced pieces: every mesh of a shape's group but the first
// is then in a frame of its own).
struct TiledWorld {
  std::vector<SceneMesh> scenes = scenes::tiledFloor(4, 4, 2, 0.5, 61);
  std::vector<TriangleMesh> core_meshes;  // in the floor's frame
  std::vector<std::shared_ptr<::fcl::BVHModel<::fcl::OBBRSSd>>> models;
  std::vector<std::unique_ptr<::fcl::CollisionObjectd>> tiles;
  Pose floor_pose;

  explicit TiledWorld(const Pose& pose, bool own_frames = false) : floor_pose(pose) {
    for (const SceneMesh& s : scenes) {
      core_meshes.push_back(testing::buildMesh(s));
      Pose tile_pose = pose;
      SceneMesh local = s;
      if (own_frames) {
        Vec3 corner(s.vertex(0).x(), s.vertex(0).y(), 0.0);
        for (std::size_t i = 0; i < s.vertexCount(); ++i) corner = corner.cwiseMin(Vec3(s.vertex(i).x(), s.vertex(i).y(), 0.0));
        for (std::size_t i = 0; i < s.vertexCount(); ++i)
          for (int k = 0; k < 3; ++k) local.vertices[3 * i + k] -= corner[k];
        tile_pose.translation = pose.apply(corner);
      }
      models.push_back(fclModel<::fcl::OBBRSSd>(local));
      tiles.push_back(std::make_unique<::fcl::CollisionObjectd>(models.back(), toTransform(tile_pose)));
    }
  }
  int tileOf(const ::fcl::CollisionGeometryd* g) const {
    for (std::size_t i = 0; i < models.size(); ++i)
      if (models[i].get() == g) return static_cast<int>(i);
    return -1;
  }
};

// A shape of random attitude at (x, y) in the floor's frame (drawn by `xy`
// after the attitude), shallowly in contact with the floor or just above
// it: a sphere's centre from 0.01 to 1 radius up.
Pose shallowPlacement(const ShapeCase& shape, scenes::Rng& rng,
                      const std::function<Eigen::Vector2d(scenes::Rng&)>& xy) {
  Pose local;
  local.rotation = rng.rotation();
  const double low = shape.extentAlong(local.rotation.transpose() * -Vec3::UnitZ());
  const Eigen::Vector2d at = xy(rng);
  local.translation = Vec3{at.x(), at.y(), low + rng.uniform(-shape.oracleDepth(), 0.02)};
  if (shape.kind == Kind::kSphere) local.translation.z() = rng.uniform(0.01, 1.0) * shape.dims.x();
  return local;
}

TEST(Broadphase, TilesAreOneSurface) {
  scenes::Rng rng(62);
  const TiledWorld world(randomPose(rng, 2.0));
  std::vector<MeshInstance> instances;
  for (const TriangleMesh& m : world.core_meshes) instances.push_back({&m, Pose::identity()});
  const Vec3 up = world.floor_pose.rotation * Vec3::UnitZ();

  fcl::ModelCache cache;
  for (const auto& m : world.models) ASSERT_TRUE(cache.add(m.get()).isOk());
  fcl::Options cached;
  cached.cache = &cache;
  int rounds = 0, shapes_in_contact = 0, seam_groups = 0, per_pair_ghosts = 0;
  fcl::Scratch scratch;
  QueryScratch core_scratch;
  std::vector<Contact> core_contacts;
  const int round_count = testing::scaled(1200) / 12;  // 12 placements per round
  for (; rounds < round_count; ++rounds) {
    // 12 shapes over the floor, each shallowly in contact or just above it.
    std::vector<ShapeCase> cases;
    std::vector<Pose> locals;
    std::vector<std::unique_ptr<::fcl::CollisionObjectd>> shapes;
    for (int k = 0; k < 12; ++k) {
      const ShapeCase shape = allShapes()[k % 3];  // sphere, capsule, box
      const Pose local = shallowPlacement(shape, rng, [](scenes::Rng& r) {
        const double x = r.uniform(0.8, 3.2);
        return Eigen::Vector2d(x, r.uniform(0.8, 3.2));
      });
      cases.push_back(shape);
      locals.push_back(local);
      shapes.push_back(std::make_unique<::fcl::CollisionObjectd>(shape.make(), toTransform(world.floor_pose * local)));
    }
    ::fcl::DynamicAABBTreeCollisionManagerd manager;
    for (const auto& t : world.tiles) manager.registerObject(t.get());
    for (const auto& s : shapes) manager.registerObject(s.get());
    manager.setup();
    fcl::BroadphaseCollector collector(::fcl::CollisionRequestd(1000, true));
    manager.collide(&collector, fcl::BroadphaseCollector::callback);
    const Status s = collector.finish();
    ASSERT_TRUE(s.isOk()) << s.message();
    // The same through a ModelCache: the same contacts.
    fcl::BroadphaseCollector cached_collector(::fcl::CollisionRequestd(1000, true), cached);
    manager.collide(&cached_collector, fcl::BroadphaseCollector::callback);
    ASSERT_TRUE(cached_collector.finish().isOk());
    ASSERT_EQ(cached_collector.contacts().size(), collector.contacts().size());
    for (std::size_t i = 0; i < collector.contacts().size(); ++i) {
      EXPECT_EQ(cached_collector.contacts()[i].o1, collector.contacts()[i].o1);
      EXPECT_EQ(compareContacts({cached_collector.contacts()[i].contact}, {collector.contacts()[i].contact}, 0.0), "");
    }

    // Collision checking (FCL's default request) on the same shallow
    // placements, many across a seam: one contact exactly for the shapes the
    // grouped contacts query gives any (for a sphere, capsule or box, a
    // triangle alone has a contact iff the whole query has some).
    std::map<const ::fcl::CollisionObjectd*, int> checked;
    const fcl::Options plain;
    for (const fcl::Options* options : {&plain, static_cast<const fcl::Options*>(&cached)}) {
      fcl::BroadphaseCollector checker(::fcl::CollisionRequestd(), *options);
      manager.collide(&checker, fcl::BroadphaseCollector::callback);
      ASSERT_TRUE(checker.finish().isOk());
      std::map<const ::fcl::CollisionObjectd*, int> count;
      for (const fcl::ObjectContact& c : checker.contacts())
        if (world.tileOf(c.o1->collisionGeometry().get()) >= 0) ++count[c.o2];
      if (options == &plain) {
        checked = count;
      } else {
        EXPECT_EQ(count, checked) << "round " << rounds << ": checking with a cache";
      }
    }
    std::set<const ::fcl::CollisionObjectd*> touched_shapes;
    for (const fcl::ObjectContact& c : collector.contacts())
      if (world.tileOf(c.o1->collisionGeometry().get()) >= 0) touched_shapes.insert(c.o2);
    for (const auto& shape : shapes) {
      const auto it = checked.find(shape.get());
      EXPECT_EQ(it != checked.end(), touched_shapes.count(shape.get()) != 0) << "round " << rounds;
      if (it != checked.end()) {
        EXPECT_EQ(it->second, 1);
      }
    }

    // Contacts per shape (grouped) and the shape-vs-shape ones (forwarded).
    std::map<const ::fcl::CollisionObjectd*, std::vector<::fcl::Contactd>> per_shape;
    for (const fcl::ObjectContact& c : collector.contacts()) {
      if (world.tileOf(c.o1->collisionGeometry().get()) < 0) continue;  // a forwarded shape-shape pair
      EXPECT_EQ(c.contact.o1, c.o1->collisionGeometry().get());
      EXPECT_EQ(c.contact.o2, c.o2->collisionGeometry().get());
      per_shape[c.o2].push_back(c.contact);
    }
    for (std::size_t k = 0; k < shapes.size(); ++k) {
      const ShapeCase& shape = cases[k];
      const ::fcl::CollisionGeometryd* g = shapes[k]->collisionGeometry().get();
      const std::string config = std::string(shape.name) + ", round " + std::to_string(rounds) + ", shape " +
                                 std::to_string(k) + " at " + testing::str(locals[k].translation) +
                                 " in the floor's frame";
      // The core's query over all 16 tiles as one surface.
      ASSERT_TRUE(shape.core(instances.data(), instances.size(), *g, world.floor_pose.inverse() * (world.floor_pose * locals[k]),
                             QuerySettings(), core_scratch, core_contacts)
                      .isOk());
      std::vector<::fcl::Contactd> expected;
      std::set<std::uint32_t> meshes;
      for (const Contact& c : core_contacts) {
        expected.push_back(expectedContact(c, world.floor_pose, true, world.models[c.mesh].get(), g));
        meshes.insert(c.mesh);
      }
      const std::vector<::fcl::Contactd>& got = per_shape[shapes[k].get()];
      // Compared by geometry: where two triangles of different tiles give the
      // same point (a patch clipped at a seam), the manifold reduction keeps
      // the one of the lower mesh index, and the collector numbers the tiles
      // in the manager's order, not in this list's.
      auto unlabelled = [](std::vector<::fcl::Contactd> v) {
        for (auto& c : v) c.o1 = nullptr, c.b1 = 0;
        return v;
      };
      EXPECT_EQ(compareContacts(unlabelled(got), unlabelled(expected), 1e-12), "") << config;
      shapes_in_contact += !got.empty();
      for (const auto& c : got)
        EXPECT_LE(std::atan2(c.normal.cross(up).norm(), c.normal.dot(up)), 2.0 * kDeg)
            << "ghost at a seam: " << str(c) << "\n" << config;

      // Each tile on its own (what calling the drop-in per pair gives).
      std::set<int> touched;
      for (const auto& c : got) touched.insert(world.tileOf(c.o1));
      int near_tiles = 0;
      for (const auto& tile : world.tiles) {
        ::fcl::CollisionResultd r;
        ASSERT_TRUE(fcl::collide(tile.get(), shapes[k].get(), ::fcl::CollisionRequestd(1000, true), r,
                                 fcl::Options(), scratch)
                        .isOk());
        near_tiles += r.numContacts() > 0;
        for (const auto& c : contactsOf(r))
          per_pair_ghosts += std::atan2(c.normal.cross(up).norm(), c.normal.dot(up)) > 2.0 * kDeg;
      }
      seam_groups += near_tiles > 1;
    }
    if (::testing::Test::HasFailure()) return;
  }
  std::printf("%d rounds of 12 shapes: %d shapes in contact, %d across a seam (several tiles); per-pair queries "
              "would give %d ghost normals there, the collector 0\n",
              rounds, shapes_in_contact, seam_groups, per_pair_ghosts);
  EXPECT_GT(seam_groups, rounds);         // the seams are exercised
  EXPECT_GT(per_pair_ghosts, rounds / 10);  // and per-pair queries do show the ghosts
}

// Given the tiles' manager (setMeshManager; and setShapeManager, for shapes
// paired with no tile), each shape's contacts are the
// core's query over all the tiles, also where the query reaches tiles the
// manager did not pair with the shape: a contact distance of 3 cm, and the
// deep passes of the support shapes (some sunk 10 cm), on a sine terrain cut
// into 64 tiles of 0.5 m (each with its triangles' vertices only, so that
// FCL's bounds of each are tight), the shapes near a seam. Without the manager some shapes get other
// contacts (the control).
TEST(Broadphase, GivenTheMeshManagerContactsAreTheCoresOverEveryTile) {
  const SceneMesh terrain = scenes::sineTerrain(32, 32, 0.125, 0.3, 2.0, 71);
  std::vector<std::vector<std::uint32_t>> original;
  const std::vector<SceneMesh> pieces = cutMesh(
      terrain, 64,
      [&](std::size_t t) {
        Vec3 centroid = Vec3::Zero();
        for (int k = 0; k < 3; ++k) centroid += terrain.vertex(terrain.indices[3 * t + k]) / 3.0;
        return std::min(7, static_cast<int>(2 * centroid.x())) * 8 + std::min(7, static_cast<int>(2 * centroid.y()));
      },
      original);
  std::vector<TriangleMesh> core_meshes;
  std::vector<std::shared_ptr<::fcl::BVHModel<::fcl::OBBRSSd>>> models;
  std::vector<std::unique_ptr<::fcl::CollisionObjectd>> tiles;
  for (const SceneMesh& piece : pieces) {
    core_meshes.push_back(testing::buildMesh(piece));
    models.push_back(fclModel<::fcl::OBBRSSd>(piece));
    tiles.push_back(std::make_unique<::fcl::CollisionObjectd>(models.back()));
  }
  std::vector<MeshInstance> instances;
  for (const TriangleMesh& m : core_meshes) instances.push_back({&m, Pose::identity()});
  auto tileOf = [&](const ::fcl::CollisionObjectd* o) {
    for (std::size_t i = 0; i < tiles.size(); ++i)
      if (tiles[i].get() == o) return static_cast<int>(i);
    return -1;
  };
  // The terrain's height at (x, y): its nearest vertex's (the shapes are
  // placed about it, from 10 cm into the surface to 3 cm above it).
  auto heightAt = [&](double x, double y) {
    double best = std::numeric_limits<double>::infinity(), z = 0.0;
    for (std::size_t v = 0; v < terrain.vertexCount(); ++v) {
      const Vec3 p = terrain.vertex(v);
      const double d = std::hypot(p.x() - x, p.y() - y);
      if (d < best) best = d, z = p.z();
    }
    return z;
  };
  fcl::Options options;
  options.settings.contact_distance = 0.03;
  QuerySettings settings;
  settings.contact_distance = options.settings.contact_distance;
  QueryScratch core_scratch;
  std::vector<Contact> core;
  scenes::Rng rng(72);
  const std::vector<ShapeCase> kinds = allShapes();
  int shapes_in_contact = 0, reaching_unpaired = 0, control_differs = 0, never_paired = 0, beside_unpaired = 0;
  const int rounds = testing::scaled(600) / 12;
  for (int round = 0; round < rounds; ++round) {
    std::vector<std::unique_ptr<::fcl::CollisionObjectd>> shapes;
    std::vector<Pose> poses;
    for (int k = 0; k < 12; ++k) {
      const ShapeCase& shape = kinds[static_cast<std::size_t>(round * 12 + k) % kinds.size()];
      Pose pose;
      pose.rotation = rng.rotation();
      // Beside a seam (every 0.5 m, across x or y), FCL's bounds of the
      // shape ending 0 to 5 cm before it on either side: the tile beyond is
      // paired or not as the bounds reach across the seam in the other axis.
      auto object = std::make_unique<::fcl::CollisionObjectd>(shape.make(), toTransform(pose));
      const ::fcl::AABBd bounds = object->getAABB();  // about the origin
      const int axis = rng.uniform(0.0, 1.0) < 0.5 ? 0 : 1;
      const double seam = 0.5 * std::round(rng.uniform(2.0, 6.0)), gap = rng.uniform(0.0, 0.05);
      pose.translation[axis] =
          rng.uniform(0.0, 1.0) < 0.5 ? seam - gap - bounds.max_[axis] : seam + gap - bounds.min_[axis];
      pose.translation[1 - axis] = rng.uniform(0.4, 3.6);
      const double low = shape.extentAlong(pose.rotation.transpose() * -Vec3::UnitZ());
      pose.translation.z() = heightAt(pose.translation.x(), pose.translation.y()) + low + rng.uniform(-0.1, 0.03);
      poses.push_back(pose);
      object->setTransform(toTransform(pose));
      object->computeAABB();
      shapes.push_back(std::move(object));
    }
    ::fcl::DynamicAABBTreeCollisionManagerd manager;
    for (const auto& t : tiles) manager.registerObject(t.get());
    for (const auto& sh : shapes) manager.registerObject(sh.get());
    manager.setup();
    std::map<const ::fcl::CollisionObjectd*, std::vector<::fcl::Contactd>> per_shape[2];
    std::map<const ::fcl::CollisionObjectd*, std::set<int>> paired;  // the tiles the manager paired with a shape
    for (const bool with_manager : {true, false}) {
      fcl::BroadphaseCollector collector(::fcl::CollisionRequestd(1000, true), options);
      if (with_manager) {
        collector.setMeshManager(&manager);
        collector.setShapeManager(&manager);
      }
      manager.collide(&collector, fcl::BroadphaseCollector::callback);
      ASSERT_TRUE(collector.finish().isOk());
      for (const fcl::ObjectContact& c : collector.contacts()) {
        if (tileOf(c.o1) < 0 || tileOf(c.o2) >= 0) continue;  // forwarded: tile-tile, shape-shape
        // Compared by geometry (as in TilesAreOneSurface: where triangles
        // of two tiles give the same point, the reduction keeps the lower
        // mesh index, and the collector numbers the tiles in the manager's
        // order).
        ::fcl::Contactd g = c.contact;
        g.o1 = nullptr, g.b1 = 0;
        per_shape[with_manager ? 0 : 1][c.o2].push_back(g);
      }
    }
    std::set<const ::fcl::CollisionObjectd*> beside;  // shapes within the contact distance of an unpaired tile's bounds
    for (const auto& t : tiles)
      for (const auto& sh : shapes) {
        ::fcl::AABBd grown = sh->getAABB();
        grown.expand(Vec3::Constant(options.settings.contact_distance));
        if (t->getAABB().overlap(sh->getAABB()))
          paired[sh.get()].insert(tileOf(t.get()));
        else if (t->getAABB().overlap(grown))
          beside.insert(sh.get());
      }
    beside_unpaired += static_cast<int>(beside.size());
    for (std::size_t k = 0; k < shapes.size(); ++k) {
      const ShapeCase& shape = kinds[(static_cast<std::size_t>(round) * 12 + k) % kinds.size()];
      const ::fcl::CollisionObjectd* object = shapes[k].get();
      const ::fcl::CollisionGeometryd* g = object->collisionGeometry().get();
      // A shape the manager paired with no tile is queried through the
      // shapes' manager only (setShapeManager): none without it.
      if (paired[object].empty()) {
        EXPECT_TRUE(per_shape[1][object].empty());
        ++never_paired;
      }
      ASSERT_TRUE(shape.core(instances.data(), instances.size(), *g, poses[k], settings, core_scratch, core).isOk());
      std::vector<::fcl::Contactd> expected;
      bool unpaired = false;
      for (const Contact& c : core) {
        ::fcl::Contactd e = expectedContact(c, Pose::identity(), true, nullptr, g);
        e.b1 = 0;
        expected.push_back(e);
        unpaired = unpaired || paired[object].count(static_cast<int>(c.mesh)) == 0;
      }
      const std::string config = std::string(shape.name) + ", round " + std::to_string(round) + ", shape " +
                                 std::to_string(k) + " at " + testing::str(poses[k].translation);
      EXPECT_EQ(compareContacts(per_shape[0][object], expected, 1e-12), "") << config;
      shapes_in_contact += !expected.empty();
      reaching_unpaired += unpaired;
      control_differs += !compareContacts(per_shape[1][object], expected, 1e-12).empty();
    }
    if (::testing::Test::HasFailure()) return;
  }
  // On this gentle terrain a tile beyond the shape's bounds seldom changes
  // its contacts (the tile's own triangles at the seam are nearer and void
  // the shared edges): the controls that it can are the DropIn tests
  // *AsksTheMeshManager*. Here every group takes such tiles and must still
  // give the core's contacts.
  std::printf("%d of %d shapes with contacts (%d paired with no tile); %d within the contact distance of a tile "
              "the manager did not pair, %d with a contact on one; without the manager %d differ\n",
              shapes_in_contact, 12 * rounds, never_paired, beside_unpaired, reaching_unpaired, control_differs);
  EXPECT_GT(shapes_in_contact, 12 * rounds / 2);
  EXPECT_GT(beside_unpaired, 12 * rounds / 4);
}

// A pose of `shape` in the tiled floor's frame, well inside the floor and
// clear of touching it by at least 1 mm, so that the right answer is known
// without FCL's tolerances: across the floor's plane with probability
// `p_across` (touching; some with the centre below the plane), above it with
// `p_above`, else wholly below it (a floor of zero thickness: no overlap).
struct ClearPlacement {
  Pose local;
  bool across = false, above = false;
};
ClearPlacement clearPlacement(const ShapeCase& shape, double p_across, double p_above, scenes::Rng& rng) {
  ClearPlacement out;
  out.local.rotation = rng.rotation();
  const double low = shape.extentAlong(out.local.rotation.transpose() * -Vec3::UnitZ());
  const double high = shape.extentAlong(out.local.rotation.transpose() * Vec3::UnitZ());
  // Centre height z: lowest point z - low, highest z + high.
  const double pick = rng.uniform(0.0, 1.0);
  out.across = pick < p_across;
  out.above = !out.across && pick < p_across + p_above;
  double z;
  if (out.across) z = rng.uniform(-high + 1e-3, low - 1e-3);
  else if (out.above) z = low + rng.uniform(1e-3, 0.1);
  else z = -high - rng.uniform(1e-3, 0.1);
  out.local.translation = Vec3{rng.uniform(0.8, 3.2), rng.uniform(0.8, 3.2), z};
  return out;
}

// Collision checking through the collector (FCL's default request: no
// contact geometry, one contact): one contact for each shape that touches
// the floor, none for the others. Every shape kind, at clear placements
// (clearPlacement: a third across the floor's plane, a third above, a third
// below). The contacts request answers the same, with and without a
// ModelCache.
// Whether each shape touches the floor, from every path: checking and
// contacts, with and without a ModelCache, and with the tiles in the floor's
// frame or each in its own (the walk then tests each triangle's bounds in
// its model's frame, where the query's bounds are: tested after mapping the
// corners to the group's frame, a shape across two tiles could lose every
// contact).
void checkTouchingShapes(bool own_frames) {
  scenes::Rng rng(63);
  const TiledWorld world(randomPose(rng, 2.0), own_frames);
  fcl::ModelCache cache;
  for (const auto& m : world.models) ASSERT_TRUE(cache.add(m.get()).isOk());
  fcl::Options cached;
  cached.cache = &cache;
  const std::vector<ShapeCase> kinds = allShapes();
  int touching = 0, apart = 0, sunk = 0, checked = 0;
  for (int round = 0; round < testing::scaled(600) / 14; ++round) {
    std::vector<std::unique_ptr<::fcl::CollisionObjectd>> shapes;
    std::vector<bool> expected;
    for (int k = 0; k < 14; ++k) {
      const ShapeCase& shape = kinds[k % kinds.size()];
      const ClearPlacement place = clearPlacement(shape, 1.0 / 3.0, 1.0 / 3.0, rng);
      expected.push_back(place.across);
      touching += place.across;
      apart += place.above;
      sunk += place.across && place.local.translation.z() < 0.0;
      shapes.push_back(
          std::make_unique<::fcl::CollisionObjectd>(shape.make(), toTransform(world.floor_pose * place.local)));
    }
    ::fcl::DynamicAABBTreeCollisionManagerd manager;
    for (const auto& t : world.tiles) manager.registerObject(t.get());
    for (const auto& sh : shapes) manager.registerObject(sh.get());
    manager.setup();
    for (const bool contacts_on : {false, true}) {
      const fcl::Options plain;
      for (const fcl::Options* options : {&plain, static_cast<const fcl::Options*>(&cached)}) {
        const ::fcl::CollisionRequestd request = contacts_on ? ::fcl::CollisionRequestd(1000, true)
                                                             : ::fcl::CollisionRequestd();
        fcl::BroadphaseCollector collector(request, *options);
        manager.collide(&collector, fcl::BroadphaseCollector::callback);
        const Status st = collector.finish();
        ASSERT_TRUE(st.isOk()) << st.message();
        std::map<const ::fcl::CollisionObjectd*, int> count;
        for (const fcl::ObjectContact& c : collector.contacts()) {
          if (world.tileOf(c.o1->collisionGeometry().get()) < 0) continue;  // shape-vs-shape, forwarded
          EXPECT_EQ(c.contact.o1, c.o1->collisionGeometry().get());
          EXPECT_EQ(c.contact.o2, c.o2->collisionGeometry().get());
          ++count[c.o2];
        }
        for (std::size_t k = 0; k < shapes.size(); ++k) {
          const int n = count.count(shapes[k].get()) ? count[shapes[k].get()] : 0;
          EXPECT_EQ(n > 0, expected[k]) << kinds[k % kinds.size()].name << ", round " << round << ", shape " << k
                                        << (contacts_on ? ", contacts" : ", checking")
                                        << (options == &cached ? ", cached" : "");
          if (!contacts_on) {
            EXPECT_LE(n, 1);
          }
          ++checked;
        }
      }
    }
  }
  std::printf("%d checks: %d shapes across the floor (%d with the centre below it), %d above it, the rest below\n",
              checked, touching, sunk, apart);
  EXPECT_GT(sunk, touching / 10);
  EXPECT_GT(apart, checked / 4 / 5);
}

// Tiles each in a frame of its own (TiledWorld's own_frames: coordinates
// from the tile's corner, the floor's transform moved there): moved into
// the first tile's frame by relativePose, neighbours' shared corners land a
// few ulps apart under the floor's random rotation. The collector welds
// them (weldCorners, as the core's pipelines do): shapes near the seams get
// only the floor's normal. Without the weld, 548 of the 937 shapes in
// contact here got a tilted contact.
TEST(Broadphase, TilesInTheirOwnFramesAreOneSurface) {
  scenes::Rng rng(65);
  const TiledWorld world(randomPose(rng, 2.0), true);
  const Vec3 up = world.floor_pose.rotation * Vec3::UnitZ();
  int in_contact = 0, tilted = 0;
  const int rounds = testing::scaled(1200) / 12;
  for (int round = 0; round < rounds; ++round) {
    std::vector<std::unique_ptr<::fcl::CollisionObjectd>> shapes;
    for (int k = 0; k < 12; ++k) {
      const ShapeCase shape = allShapes()[k % 3];  // sphere, capsule, box
      // Near a seam (tiles are 1 m: seams at whole metres), across x or y.
      const Pose local = shallowPlacement(shape, rng, [](scenes::Rng& r) {
        const double across = std::round(r.uniform(1.0, 3.0)) + r.uniform(-0.2, 0.2);
        const double along = r.uniform(0.8, 3.2);
        return r.uniform(0.0, 1.0) < 0.5 ? Eigen::Vector2d(across, along) : Eigen::Vector2d(along, across);
      });
      shapes.push_back(std::make_unique<::fcl::CollisionObjectd>(shape.make(), toTransform(world.floor_pose * local)));
    }
    ::fcl::DynamicAABBTreeCollisionManagerd manager;
    for (const auto& t : world.tiles) manager.registerObject(t.get());
    for (const auto& sh : shapes) manager.registerObject(sh.get());
    manager.setup();
    fcl::BroadphaseCollector collector(::fcl::CollisionRequestd(1000, true));
    manager.collide(&collector, fcl::BroadphaseCollector::callback);
    ASSERT_TRUE(collector.finish().isOk());
    std::set<const ::fcl::CollisionObjectd*> touched;
    std::set<const ::fcl::CollisionObjectd*> shapes_tilted;
    for (const fcl::ObjectContact& c : collector.contacts()) {
      const int tile = world.tileOf(c.o1->collisionGeometry().get());
      // Forwarded pairs: shape-shape, and tile-tile (neighbours touch).
      if (tile < 0 || world.tileOf(c.o2->collisionGeometry().get()) >= 0) continue;
      touched.insert(c.o2);
      if (!((c.contact.normal - up).norm() <= 1e-9)) {
        if (shapes_tilted.insert(c.o2).second && shapes_tilted.size() <= 3)
          ADD_FAILURE() << "round " << round << ": tilted normal " << str(c.contact);
      }
    }
    in_contact += static_cast<int>(touched.size());
    tilted += static_cast<int>(shapes_tilted.size());
  }
  std::printf("%d of %d shapes near a seam in contact; %d with a tilted normal\n", in_contact, 12 * rounds, tilted);
  EXPECT_GT(in_contact, 12 * rounds / 2);
  EXPECT_EQ(tilted, 0);
}

TEST(Broadphase, CheckingFindsTheShapesThatTouch) { checkTouchingShapes(false); }

TEST(Broadphase, CheckingFindsTheShapesThatTouchInstancedTiles) { checkTouchingShapes(true); }

// defaultCollisionFunction against FCL's DefaultCollisionFunction on the
// same managers: rounds of 3 shapes at clear placements (clearPlacement: a
// fifth across the floor, two fifths above, two fifths below).
//  - Checking (FCL's default request): both answer whether anything touches
//    the floor, and stop there (one contact each).
//  - Contacts, room for all: every pair is queried; the result is the drop-in
//    collide() on each pair the manager reports, in its order.
//  - Contacts, num_max_contacts 3: the pass stops once 3 are found.
// An error ends the pass at once; lastStatus() says why.
TEST(Broadphase, DefaultCollisionFunctionIsFclsWithTheDropIn) {
  scenes::Rng rng(64);
  const TiledWorld world(randomPose(rng, 2.0));
  const std::vector<ShapeCase> kinds = allShapes();
  int in_collision = 0, rounds = 0, capped = 0;
  for (; rounds < testing::scaled(300) / 3; ++rounds) {
    std::vector<std::unique_ptr<::fcl::CollisionObjectd>> shapes;
    bool any = false;
    for (int k = 0; k < 3; ++k) {
      const ShapeCase& shape = kinds[static_cast<std::size_t>(rng.uniform(0.0, 6.999))];
      const ClearPlacement place = clearPlacement(shape, 0.2, 0.4, rng);
      any |= place.across;
      shapes.push_back(
          std::make_unique<::fcl::CollisionObjectd>(shape.make(), toTransform(world.floor_pose * place.local)));
    }
    // Shapes and tiles in separate managers: no tile-tile or shape-shape pair.
    ::fcl::DynamicAABBTreeCollisionManagerd floor, bodies;
    for (const auto& t : world.tiles) floor.registerObject(t.get());
    for (const auto& sh : shapes) bodies.registerObject(sh.get());
    floor.setup();
    bodies.setup();

    ::fcl::DefaultCollisionData<double> theirs, ours;
    bodies.collide(&floor, &theirs, ::fcl::DefaultCollisionFunction<double>);
    bodies.collide(&floor, &ours, fcl::defaultCollisionFunction);
    ASSERT_TRUE(fcl::lastStatus().isOk()) << fcl::lastStatus().message();
    EXPECT_EQ(ours.result.isCollision(), any) << "round " << rounds;
    EXPECT_EQ(theirs.result.isCollision(), any) << "round " << rounds;
    EXPECT_EQ(ours.done, any);
    EXPECT_EQ(theirs.done, any);
    EXPECT_EQ(ours.result.numContacts(), any ? 1u : 0u);
    EXPECT_EQ(theirs.result.numContacts(), any ? 1u : 0u);
    in_collision += any;

    // enable_cost: FCL's own pair functions (the drop-in forwards such a
    // request), and FCL's rule never ends the pass.
    ::fcl::DefaultCollisionData<double> cost_theirs, cost_ours;
    cost_theirs.request = cost_ours.request = ::fcl::CollisionRequestd(1, true, 10, true);
    bodies.collide(&floor, &cost_theirs, ::fcl::DefaultCollisionFunction<double>);
    bodies.collide(&floor, &cost_ours, fcl::defaultCollisionFunction);
    EXPECT_FALSE(cost_ours.done);
    EXPECT_EQ(compareContacts(contactsOf(cost_ours.result), contactsOf(cost_theirs.result), 0.0), "");

    // Every pair, in the manager's order, through the drop-in itself.
    struct Pairs {
      std::vector<std::pair<::fcl::CollisionObjectd*, ::fcl::CollisionObjectd*>> list;
      static bool record(::fcl::CollisionObjectd* a, ::fcl::CollisionObjectd* b, void* data) {
        static_cast<Pairs*>(data)->list.emplace_back(a, b);
        return false;
      }
    } pairs;
    bodies.collide(&floor, &pairs, Pairs::record);
    ::fcl::CollisionResultd expected;
    for (const auto& [a, b] : pairs.list) fcl::collide(a, b, ::fcl::CollisionRequestd(100000, true), expected);
    ::fcl::DefaultCollisionData<double> all;
    all.request = ::fcl::CollisionRequestd(100000, true);
    bodies.collide(&floor, &all, fcl::defaultCollisionFunction);
    EXPECT_FALSE(all.done);
    EXPECT_EQ(compareContacts(contactsOf(all.result), contactsOf(expected), 0.0), "") << "round " << rounds;

    ::fcl::DefaultCollisionData<double> three;
    three.request = ::fcl::CollisionRequestd(3, true);
    bodies.collide(&floor, &three, fcl::defaultCollisionFunction);
    EXPECT_EQ(three.result.numContacts(), std::min<std::size_t>(3, expected.numContacts())) << "round " << rounds;
    EXPECT_EQ(three.done, expected.numContacts() >= 3);
    capped += expected.numContacts() > 3;
  }
  std::printf("%d rounds of 3 shapes: %d with a shape on the floor, %d with more than 3 contacts\n", rounds,
              in_collision, capped);
  EXPECT_GT(in_collision, rounds / 4);
  EXPECT_LT(in_collision, rounds * 3 / 4);
  EXPECT_GT(capped, rounds / 20);

  // An error ends the pass at once, marks it done and leaves the result
  // without that pair: a box across a seam of the floor (several pairs) with
  // a rotation 1e-3 from orthonormal, which FCL accepts and the drop-in
  // refuses.
  Pose skewed;
  skewed.rotation = 1.001 * Eigen::Matrix3d(Eigen::AngleAxisd(0.3, Vec3::UnitZ()));
  skewed.translation = Vec3(2.0, 2.0, 0.0);  // at the corner of four tiles
  ::fcl::CollisionObjectd bad(std::make_shared<::fcl::Boxd>(0.4, 0.4, 0.4), toTransform(world.floor_pose * skewed));
  ::fcl::DynamicAABBTreeCollisionManagerd floor, body;
  for (const auto& t : world.tiles) floor.registerObject(t.get());
  body.registerObject(&bad);
  floor.setup();
  body.setup();
  struct Counted {
    ::fcl::DefaultCollisionData<double> data;
    int calls = 0, pairs = 0;
    static bool call(::fcl::CollisionObjectd* a, ::fcl::CollisionObjectd* b, void* self) {
      auto& c = *static_cast<Counted*>(self);
      ++c.calls;
      return fcl::defaultCollisionFunction(a, b, &c.data);
    }
    static bool count(::fcl::CollisionObjectd*, ::fcl::CollisionObjectd*, void* self) {
      ++static_cast<Counted*>(self)->pairs;
      return false;
    }
  } counted;
  body.collide(&floor, &counted, Counted::count);
  ASSERT_GE(counted.pairs, 2);
  body.collide(&floor, &counted, Counted::call);
  EXPECT_EQ(counted.calls, 1);
  EXPECT_EQ(fcl::lastStatus().code(), ErrorCode::kInvalidPose) << fcl::lastStatus().message();
  EXPECT_TRUE(counted.data.done);
  EXPECT_EQ(counted.data.result.numContacts(), 0u);
}

// A mesh the mesh manager gives (setMeshManager) is checked as a paired one:
// an unfinished model (endModel not called) 1 cm beside a box's bounds,
// within the contact distance, is the group's error (kMeshNotBuilt), not
// skipped; a non-mesh object beside it (a sphere) is left to its own pairs.
// Without the manager the unfinished model is never read.
TEST(Broadphase, TheMeshManagersMeshesAreChecked) {
  const SceneMesh floor = scenes::flatFloor(2, 4, 0.5, 3);  // x in [0, 1]
  auto floor_model = fclModel<::fcl::OBBRSSd>(floor);
  auto unfinished = std::make_shared<::fcl::BVHModel<::fcl::OBBRSSd>>();
  unfinished->beginModel();  // beyond the floor's bounds: no pair with it
  unfinished->addTriangle(Vec3(1.005, 0.0, -0.5), Vec3(1.005, 0.0, 1.0), Vec3(1.005, 2.0, 0.0));
  ::fcl::CollisionObjectd floor_object(floor_model), wall(unfinished);
  ::fcl::Transform3d tf = ::fcl::Transform3d::Identity();
  tf.translation() = Vec3(1.005 - 0.01 - 0.2, 1.0, 0.1 - 0.002);  // half extents 0.2, 0.15, 0.1
  ::fcl::CollisionObjectd box(std::make_shared<::fcl::Boxd>(0.4, 0.3, 0.2), tf);
  tf.translation() = Vec3(0.795, 1.0, 0.198 + 0.01 + 0.2);  // 1 cm over the box's bounds, clear of the floor
  ::fcl::CollisionObjectd ball(std::make_shared<::fcl::Sphered>(0.2), tf);
  ASSERT_FALSE(ball.getAABB().overlap(box.getAABB()));
  ASSERT_FALSE(wall.getAABB().overlap(box.getAABB()));
  ASSERT_FALSE(wall.getAABB().overlap(floor_object.getAABB()));
  ::fcl::DynamicAABBTreeCollisionManagerd manager;
  for (::fcl::CollisionObjectd* o : {&floor_object, &wall, &box, &ball}) manager.registerObject(o);
  manager.setup();
  fcl::Options options;
  options.settings.contact_distance = 0.02;
  for (const bool mesh_manager : {true, false}) {
    fcl::BroadphaseCollector collector(::fcl::CollisionRequestd(100, true), options);
    if (mesh_manager) collector.setMeshManager(&manager);
    manager.collide(&collector, fcl::BroadphaseCollector::callback);
    const Status s = collector.finish();
    if (mesh_manager) {
      EXPECT_EQ(s.code(), ErrorCode::kMeshNotBuilt) << s.message();
      EXPECT_NE(s.message().find("a mesh of the group: the BVHModel is not finished"), std::string::npos)
          << s.message();
    } else {
      EXPECT_TRUE(s.isOk()) << s.message();
      int on_floor = 0;
      for (const fcl::ObjectContact& c : collector.contacts()) on_floor += c.o1 == &floor_object && c.o2 == &box;
      EXPECT_GT(on_floor, 0);
    }
  }
}

// A shape queried through the shapes' manager (setShapeManager) only is
// checked as a paired one: a sphere with a NaN transform, in a manager of
// its own with a sphere 1 cm over a flat floor, makes finish() report
// kInvalidPose; the other sphere still gets its contact at a contact distance
// of 2 cm (finish() goes on after an error). Without the shapes' manager
// neither is queried (the manager pairs neither with the floor).
TEST(Broadphase, ShapesTheManagerPairedWithNoMeshAreChecked) {
  const SceneMesh floor = scenes::flatFloor(4, 4, 0.5, 3);
  ::fcl::CollisionObjectd floor_object(fclModel<::fcl::OBBRSSd>(floor));
  auto ball = std::make_shared<::fcl::Sphered>(0.2);
  ::fcl::Transform3d tf = ::fcl::Transform3d::Identity();
  tf.translation() = Vec3(0.6, 1.2, 0.2 + 0.01);
  ::fcl::CollisionObjectd hovering(ball, tf);
  tf.translation().x() = std::numeric_limits<double>::quiet_NaN();
  ::fcl::CollisionObjectd lost(ball, tf);
  ::fcl::DynamicAABBTreeCollisionManagerd meshes, shapes;
  meshes.registerObject(&floor_object);
  meshes.setup();
  shapes.registerObject(&hovering);
  shapes.registerObject(&lost);
  shapes.setup();
  fcl::Options options;
  options.settings.contact_distance = 0.02;
  for (const bool shape_manager : {true, false}) {
    fcl::BroadphaseCollector collector(::fcl::CollisionRequestd(100, true), options);
    collector.setMeshManager(&meshes);
    if (shape_manager) collector.setShapeManager(&shapes);
    shapes.collide(&meshes, &collector, fcl::BroadphaseCollector::callback);
    const Status s = collector.finish();
    if (!shape_manager) {
      EXPECT_TRUE(s.isOk()) << s.message();
      EXPECT_TRUE(collector.contacts().empty());
      continue;
    }
    EXPECT_EQ(s.code(), ErrorCode::kInvalidPose) << s.message();
    ASSERT_EQ(collector.contacts().size(), 1u);
    const fcl::ObjectContact& c = collector.contacts()[0];
    EXPECT_EQ(c.o1, &floor_object);
    EXPECT_EQ(c.o2, &hovering);
    EXPECT_NEAR(c.contact.penetration_depth, -0.01, 1e-12);
    EXPECT_NEAR(c.contact.normal.z(), 1.0, 1e-12);
  }
}

TEST(Broadphase, ForwardsShapePairsAndReportsErrors) {
  const TiledWorld world(Pose::identity());
  ::fcl::Transform3d tf = ::fcl::Transform3d::Identity();
  tf.translation() = Vec3(1.0, 1.0, 1.5);
  ::fcl::CollisionObjectd a(std::make_shared<::fcl::Sphered>(0.3), tf);
  tf.translation().x() += 0.4;
  ::fcl::CollisionObjectd b(std::make_shared<::fcl::Boxd>(0.4, 0.4, 0.4), tf);
  ::fcl::DynamicAABBTreeCollisionManagerd manager;
  for (const auto& t : world.tiles) manager.registerObject(t.get());
  manager.registerObject(&a);
  manager.registerObject(&b);
  manager.setup();
  fcl::BroadphaseCollector collector(::fcl::CollisionRequestd(10, true));
  manager.collide(&collector, fcl::BroadphaseCollector::callback);
  ::fcl::CollisionResultd result;
  ASSERT_TRUE(collector.finish(result).isOk());
  // The shapes are above the floor: only the sphere-box pair and the tiles'
  // seams (mesh-vs-mesh, forwarded as well) touch; FCL's own answer comes
  // back for the sphere and the box.
  std::vector<fcl::ObjectContact> shape_pairs;
  for (const fcl::ObjectContact& c : collector.contacts()) {
    if (c.o1 == &a || c.o1 == &b || c.o2 == &a || c.o2 == &b) shape_pairs.push_back(c);
    else EXPECT_TRUE(world.tileOf(c.contact.o1) >= 0 && world.tileOf(c.contact.o2) >= 0);
  }
  ASSERT_EQ(shape_pairs.size(), 1u);
  EXPECT_EQ(result.numContacts(), collector.contacts().size());
  const fcl::ObjectContact& c = shape_pairs[0];
  const bool sphere_first = c.o1 == &a;
  ::fcl::CollisionResultd fcl_result;
  ::fcl::collide(sphere_first ? &a : &b, sphere_first ? &b : &a, ::fcl::CollisionRequestd(10, true), fcl_result);
  EXPECT_EQ(compareContacts({c.contact}, contactsOf(fcl_result), 0.0), "");

  // clear() forgets the pairs; a bad shape is reported by finish().
  collector.clear();
  EXPECT_TRUE(collector.finish().isOk());
  EXPECT_TRUE(collector.contacts().empty());
  ::fcl::CollisionObjectd bad(std::make_shared<::fcl::Sphered>(-1.0));
  bad.setTranslation(Vec3(1.0, 1.0, 0.0));
  bad.computeAABB();
  ::fcl::CollisionObjectd good(std::make_shared<::fcl::Sphered>(0.3));
  good.setTranslation(Vec3(2.0, 2.0, 0.2));
  good.computeAABB();
  fcl::BroadphaseCollector::callback(world.tiles[0].get(), &bad, &collector);
  fcl::BroadphaseCollector::callback(world.tiles[10].get(), &good, &collector);
  const Status s = collector.finish();
  EXPECT_EQ(s.code(), ErrorCode::kInvalidShape) << s.message();
  EXPECT_FALSE(collector.contacts().empty()) << "the other shapes are still processed";

  // Collision checking stops at the shape's first mesh in collision, but a
  // bad mesh after it is still reported, and that shape gets no contact.
  fcl::BroadphaseCollector checking;  // FCL's default request: no contacts, one wanted
  ::fcl::CollisionObjectd nan_tile(world.models[3], ::fcl::Transform3d::Identity());
  nan_tile.setTranslation(Vec3(NAN, 0.0, 0.0));
  fcl::BroadphaseCollector::callback(world.tiles[10].get(), &good, &checking);
  ASSERT_TRUE(checking.finish().isOk());
  ASSERT_EQ(checking.contacts().size(), 1u);
  EXPECT_EQ(checking.contacts()[0].o1, world.tiles[10].get());
  EXPECT_EQ(checking.contacts()[0].o2, &good);
  fcl::BroadphaseCollector::callback(&nan_tile, &good, &checking);
  const Status bad_pose = checking.finish();
  EXPECT_EQ(bad_pose.code(), ErrorCode::kInvalidPose) << bad_pose.message();
  EXPECT_TRUE(checking.contacts().empty());
}

}  // namespace
}  // namespace meshcontact::fcltest
