#pragma once
// The peers of the speed-vs-accuracy comparison (issue 6, DESIGN.md §5), each
// behind one interface, plus the scenes, the seeded placements and the local
// exact oracle they are all scored on.
//
// Contract of every method (the meshcontact convention, whatever the peer's
// own is): contacts in the scene's world frame, `normal` unit from the mesh
// toward the shape, `depth` > 0 penetrating, `point` as the peer gives it.
// The conversion from each peer's convention is fixed per peer (checked on a
// flat floor by tests/peers), never decided per contact. Contacts a peer
// reports with depth <= 0 (separated: Bullet's contact-breaking threshold)
// are dropped, since every query asks for penetration only (contact
// distance 0), and counted in `dropped_separated`.
//
// Not thread-safe: one Method per thread.

#include <meshcontact/contact.h>
#include <meshcontact/geometry.h>
#include <meshcontact/status.h>
#include <meshcontact_scenes/scenes.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace meshcontact::peers {

/// One comparison scene: pieces already in the world frame (tiles are
/// separate pieces whose seam vertices are bitwise equal).
struct CompareScene {
  std::string name;
  std::vector<scenes::SceneMesh> pieces;
  Vec3 lo, hi;             // box the sphere centres are drawn from
  double min_radius = 0.1;  // sphere radii drawn from [min_radius, max_radius)
  double max_radius = 0.5;
  bool planar = false;     // flat z = 0 floor: box placements / planar oracle apply
  std::size_t triangleCount() const;
};

/// The scenes, in report order: flat, tiles, cliff, vgroove, ridge, sine and,
/// when `with_terrain_1m`, terrain1m (a ~1M-triangle sine terrain).
std::vector<CompareScene> compareScenes(std::uint64_t seed, bool with_terrain_1m);

/// A scene by name ("" when absent): the same meshes as compareScenes.
CompareScene compareScene(const std::string& name, std::uint64_t seed);

struct SpherePlacement {
  Vec3 center;
  double radius;
};
struct BoxPlacement {
  Pose pose;         // box frame -> world
  Vec3 half_extents;
};

class LocalSphereOracle;

/// `count` seeded sphere placements that touch the scene (the oracle finds a
/// front-facing triangle closer than the radius: rejection sampling in the
/// scene's box). The same seed gives the same list on every machine.
std::vector<SpherePlacement> spherePlacements(const CompareScene& scene, const LocalSphereOracle& oracle, int count,
                                              std::uint64_t seed);
/// `count` seeded box poses over a planar scene: random rotation, half
/// extents in [0.1, 0.4) m, lowest corner between 5 cm below and 1 cm above
/// the floor (about 1/6 of the poses are separated).
std::vector<BoxPlacement> boxPlacements(const CompareScene& scene, int count, std::uint64_t seed);

/// The exact sphere oracle of DESIGN.md §5 (the algorithm of
/// meshcontact_scenes/oracle.h), with distances, restricted to the
/// triangles near the query through a uniform grid so that it scales to the
/// 1M-triangle terrain. Independent of the library's BVH and closest points.
class LocalSphereOracle {
 public:
  explicit LocalSphereOracle(const CompareScene& scene);
  ~LocalSphereOracle();
  LocalSphereOracle(const LocalSphereOracle&) = delete;
  LocalSphereOracle& operator=(const LocalSphereOracle&) = delete;

  struct Valid {
    Vec3 normal;      // normalize(c - q), or the face normal when c lies on q
    double distance;  // |c - q|
  };
  /// Valid contacts of a sphere at `center` with radius `reach`.
  void validContacts(const Vec3& center, double reach, std::vector<Valid>& out) const;
  /// Distance from `center` to the nearest front-facing triangle (infinity when none within `limit`).
  double nearestDistance(const Vec3& center, double limit) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

enum class ShapeKind { kSphere, kBox };

class Method {
 public:
  virtual ~Method() = default;
  virtual std::string name() const = 0;
  virtual bool supportsBox() const { return true; }
  /// Bytes the method's own per-mesh structures take (BVH, triangle info
  /// map, ...) beyond the caller's vertex and index arrays; 0 when unknown.
  virtual std::size_t structureBytes() const { return 0; }
  virtual Status collideSphere(const SpherePlacement& sphere, std::vector<Contact>& out) = 0;
  virtual Status collideBox(const BoxPlacement& box, std::vector<Contact>& out) = 0;
  /// Separated contacts dropped so far (see the file comment).
  long droppedSeparated() const { return dropped_separated_; }

 protected:
  long dropped_separated_ = 0;
};

/// Every method compiled in, in report order: meshcontact (KeyMode::kAuto),
/// meshcontact-position, naive-closest, naive-trinormal, ode, fcl, and (when
/// Bullet was found) bullet, bullet-iedge.
std::vector<std::string> methodNames();

/// Builds `name` over the scene's pieces (the scene must outlive the method).
/// Errors: kInvalidSettings for an unknown name; the method's own build errors.
Status makeMethod(const std::string& name, const CompareScene& scene, std::unique_ptr<Method>& out);

/// What the peers in this build are (for the report).
std::string peerVersions();

}  // namespace meshcontact::peers
