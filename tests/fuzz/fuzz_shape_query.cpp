// Fuzz target (c): every shape the core knows (sphere, capsule, box, cylinder,
// convex hull) against fuzzed meshes (degenerate and duplicated triangles,
// one to three pieces), with arbitrary shape parameters, poses and contact
// distances: NaN/Inf, 1e9 and 1e-9 scales, invalid rotations. A query either
// returns a Status error (with a message and no contacts) or contacts that are
// finite, have unit normals and name an existing triangle (fuzz_common.h).
#include "fuzz_common.h"

namespace {

using namespace meshcontact;

/// A shape extent: mostly positive, sometimes zero, negative or non-finite.
double extent(FuzzedDataProvider& in, double scale) {
  if (in.ConsumeBool()) return std::abs(in.ConsumeFloatingPointInRange<double>(1e-3, 2.0)) * scale;
  return fuzz::value(in, scale);
}

/// Hull points: a few random ones, sometimes all coplanar, collinear or equal.
std::vector<Vec3> hullPoints(FuzzedDataProvider& in, double scale) {
  std::vector<Vec3> points;
  const int count = in.ConsumeIntegralInRange<int>(0, 20);
  const int degenerate = in.ConsumeIntegralInRange<int>(0, 3);
  for (int i = 0; i < count; ++i) {
    Vec3 p = fuzz::vec(in, scale);
    if (degenerate == 1) p.z() = 0.0;                 // coplanar
    if (degenerate == 2) p.y() = p.z() = 0.0;         // collinear
    if (degenerate == 3 && !points.empty() && in.ConsumeBool()) p = points.back();  // duplicated
    points.push_back(p);
  }
  return points;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider in(data, size);
  std::vector<TriangleMesh> meshes;
  std::vector<MeshInstance> instances = fuzz::buildPieces(in, meshes);
  if (instances.empty()) return 0;
  const double scale = std::ldexp(1.0, in.ConsumeIntegralInRange<int>(-30, 30));
  if (instances.size() > 1 || in.ConsumeBool())
    for (MeshInstance& instance : instances) instance.pose = fuzz::pose(in, scale);

  QueryScratch scratch;
  std::vector<Contact> contacts;
  for (int query = 0; query < 4 && in.remaining_bytes() > 0; ++query) {
    QuerySettings settings;
    settings.contact_distance = in.ConsumeBool() ? 0.0 : fuzz::value(in, scale);
    settings.key_mode = static_cast<KeyMode>(in.ConsumeIntegralInRange<int>(0, 2));
    settings.filter = in.ConsumeBool() ? FilterMode::kVoidedFeatures : FilterMode::kNone;
    const Pose pose = fuzz::pose(in, scale);
    // Contacts carried over from a previous query must never leak into an
    // error result: start some queries with a non-empty vector.
    if (in.ConsumeBool()) contacts.assign(2, Contact{});
    Status s;
    switch (in.ConsumeIntegralInRange<int>(0, 5)) {
      case 0: {
        const Sphere sphere{pose.translation, extent(in, scale)};
        s = collideSphere(instances.data(), instances.size(), sphere, settings, scratch, contacts);
        break;
      }
      case 1: {
        const Capsule capsule{extent(in, scale), extent(in, scale)};
        s = collideCapsule(instances.data(), instances.size(), capsule, pose, settings, scratch, contacts);
        break;
      }
      case 2: {
        const double x = extent(in, scale), y = extent(in, scale);
        const Box box{Vec3(x, y, extent(in, scale))};
        s = collideBox(instances.data(), instances.size(), box, pose, settings, scratch, contacts);
        break;
      }
      case 3: {
        const Cylinder cylinder{extent(in, scale), extent(in, scale)};
        s = collideCylinder(instances.data(), instances.size(), cylinder, pose, settings, scratch, contacts);
        break;
      }
      case 4: {  // the cylinder as a support shape, with a chosen margin
        const Cylinder cylinder{extent(in, scale), extent(in, scale)};
        const CylinderShape shape(cylinder, in.ConsumeBool() ? kAutoMargin : fuzz::value(in, scale));
        s = collideConvex(instances.data(), instances.size(), shape, pose, settings, scratch, contacts);
        break;
      }
      default: {
        ConvexHull hull;
        const std::vector<Vec3> points = hullPoints(in, scale);
        const Status built = hull.build(points, in.ConsumeBool() ? kAutoMargin : fuzz::value(in, scale));
        if (!built) {
          MC_FUZZ_CHECK(!built.message().empty());
          // An unbuilt hull is still a shape a caller may pass: an error.
          s = collideConvex(instances.data(), instances.size(), hull, pose, settings, scratch, contacts);
          MC_FUZZ_CHECK(!s);
        } else {
          s = collideConvex(instances.data(), instances.size(), hull, pose, settings, scratch, contacts);
        }
        break;
      }
    }
    if (!s) {
      fuzz::checkError(s, contacts);
      continue;
    }
    fuzz::checkContacts(contacts, instances.data(), instances.size());
  }
  return 0;
}
