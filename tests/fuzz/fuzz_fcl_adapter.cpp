// Fuzz target (d): the FCL adapter (meshcontact::fcl), the code that takes
// input from FCL users: a BVHModel of any of the five BV types the drop-in
// walks in place (finished or not, sometimes with a vertex edited to NaN, Inf
// or a huge value after endModel(), sometimes through a ModelCache) against
// each shape the drop-in answers (sphere, capsule, box, cylinder, cone,
// ellipsoid, a tetrahedron as fcl::Convex), with fuzzed sizes (zero,
// negative, non-finite), transforms (NaN, invalid rotations, 1e9 scales),
// requests (num_max_contacts, enable_contact, solver) and options (contact
// distance, key mode); then postFilter on a result whose contacts are fuzzed
// (triangle ids out of range, foreign geometries, NaN normals and depths).
// Every call returns: either a Status error with a message (collide then
// appends nothing), or contacts that are finite, have unit normals, name a
// triangle of the model on the model's side and -1 (FCL's NONE) on the
// shape's, and number at most the request's num_max_contacts.
//
// The model is built by FCL from finite vertices and in-range indices: FCL's
// own construction is not what this target tests. Only pairs the adapter
// answers itself are fuzzed: a forwarded pair is fcl::collide's input.
#include "fuzz_common.h"

#include <meshcontact/fcl.h>

#include <fcl/fcl.h>

#include <memory>

namespace {

using namespace meshcontact;

double finiteOr(double x, double fallback) { return std::isfinite(x) ? x : fallback; }

/// A shape size: mostly positive, sometimes zero, negative or non-finite.
double size(FuzzedDataProvider& in, double scale) {
  if (in.ConsumeBool()) return in.ConsumeFloatingPointInRange<double>(1e-3, 2.0) * scale;
  return fuzz::value(in, scale);
}

template <class BV>
std::shared_ptr<::fcl::CollisionGeometryd> model(const std::vector<::fcl::Vector3d>& vertices,
                                                 const std::vector<::fcl::Triangle>& triangles, bool finish) {
  auto m = std::make_shared<::fcl::BVHModel<BV>>();
  m->beginModel();
  m->addSubModel(vertices, triangles);
  if (finish) m->endModel();
  return m;
}

/// The model's vertex array (public in FCL), of any of the five BV types.
::fcl::Vector3d* vertexArray(::fcl::CollisionGeometryd& g) {
  switch (g.getNodeType()) {
    case ::fcl::BV_AABB: return static_cast<::fcl::BVHModel<::fcl::AABBd>&>(g).vertices;
    case ::fcl::BV_OBB: return static_cast<::fcl::BVHModel<::fcl::OBBd>&>(g).vertices;
    case ::fcl::BV_RSS: return static_cast<::fcl::BVHModel<::fcl::RSSd>&>(g).vertices;
    case ::fcl::BV_kIOS: return static_cast<::fcl::BVHModel<::fcl::kIOSd>&>(g).vertices;
    default: return static_cast<::fcl::BVHModel<::fcl::OBBRSSd>&>(g).vertices;
  }
}

std::shared_ptr<::fcl::CollisionGeometryd> shape(FuzzedDataProvider& in, double scale) {
  switch (in.ConsumeIntegralInRange<int>(0, 6)) {
    case 0: return std::make_shared<::fcl::Sphered>(size(in, scale));
    case 1: {
      const double r = size(in, scale);
      return std::make_shared<::fcl::Capsuled>(r, size(in, scale));
    }
    case 2: {
      const double x = size(in, scale), y = size(in, scale);
      return std::make_shared<::fcl::Boxd>(x, y, size(in, scale));
    }
    case 3: {
      const double r = size(in, scale);
      return std::make_shared<::fcl::Cylinderd>(r, size(in, scale));
    }
    case 4: {
      const double r = size(in, scale);
      return std::make_shared<::fcl::Coned>(r, size(in, scale));
    }
    case 5: {
      const double a = size(in, scale), b = size(in, scale);
      return std::make_shared<::fcl::Ellipsoidd>(a, b, size(in, scale));
    }
    default: {  // a tetrahedron: four fuzzed corners (sometimes coplanar or equal), four faces
      auto v = std::make_shared<std::vector<::fcl::Vector3d>>();
      for (int k = 0; k < 4; ++k) v->push_back(fuzz::vec(in, scale));
      auto f = std::make_shared<std::vector<int>>(std::vector<int>{3, 0, 2, 1, 3, 0, 1, 3, 3, 1, 2, 3, 3, 2, 0, 3});
      return std::make_shared<::fcl::Convexd>(v, 4, f);
    }
  }
}

::fcl::Transform3d transform(FuzzedDataProvider& in, double scale) {
  const Pose p = fuzz::pose(in, scale);
  ::fcl::Transform3d t = ::fcl::Transform3d::Identity();
  t.linear() = p.rotation;
  t.translation() = p.translation;
  return t;
}

/// The invariants of a result the adapter filled (contacts from `first` on).
void checkResult(const ::fcl::CollisionResultd& result, std::size_t first, std::size_t max_contacts,
                 const ::fcl::CollisionGeometryd* mesh, int triangles) {
  MC_FUZZ_CHECK(result.numContacts() - first <= max_contacts);
  for (std::size_t i = first; i < result.numContacts(); ++i) {
    const ::fcl::Contactd& c = result.getContact(i);
    MC_FUZZ_CHECK(c.pos.allFinite());
    MC_FUZZ_CHECK(c.normal.allFinite());
    MC_FUZZ_CHECK(std::isfinite(c.penetration_depth));
    MC_FUZZ_CHECK(std::abs(c.normal.norm() - 1.0) < 1e-9);
    MC_FUZZ_CHECK(c.o1 == mesh || c.o2 == mesh);
    const int triangle = c.o1 == mesh ? c.b1 : c.b2;
    const int other = c.o1 == mesh ? c.b2 : c.b1;
    MC_FUZZ_CHECK(triangle >= 0 && triangle < triangles);
    MC_FUZZ_CHECK(other == ::fcl::Contactd::NONE);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider in(data, size);
  const double scale = std::ldexp(1.0, in.ConsumeIntegralInRange<int>(-30, 30));

  // The model: finite vertices (extreme ones included), in-range indices.
  std::vector<::fcl::Vector3d> vertices;
  const int vertex_count = in.ConsumeIntegralInRange<int>(3, 16);
  for (int i = 0; i < vertex_count; ++i) {
    const Vec3 v = fuzz::vec(in, scale);
    vertices.emplace_back(finiteOr(v.x(), 0.0), finiteOr(v.y(), scale), finiteOr(v.z(), 0.0));
  }
  std::vector<::fcl::Triangle> triangles;
  const int triangle_count = in.ConsumeIntegralInRange<int>(1, 24);
  for (int t = 0; t < triangle_count; ++t) {
    const auto a = in.ConsumeIntegralInRange<std::size_t>(0, vertices.size() - 1);
    const auto b = in.ConsumeIntegralInRange<std::size_t>(0, vertices.size() - 1);
    triangles.emplace_back(a, b, in.ConsumeIntegralInRange<std::size_t>(0, vertices.size() - 1));
  }
  const bool finished = in.ConsumeIntegralInRange<int>(0, 7) != 0;
  std::shared_ptr<::fcl::CollisionGeometryd> mesh;
  switch (in.ConsumeIntegralInRange<int>(0, 4)) {
    case 0: mesh = model<::fcl::AABBd>(vertices, triangles, finished); break;
    case 1: mesh = model<::fcl::OBBd>(vertices, triangles, finished); break;
    case 2: mesh = model<::fcl::RSSd>(vertices, triangles, finished); break;
    case 3: mesh = model<::fcl::kIOSd>(vertices, triangles, finished); break;
    default: mesh = model<::fcl::OBBRSSd>(vertices, triangles, finished); break;
  }
  // A ModelCache of the model as it was built, before any edit below (a
  // stale cache is the caller's contract, fcl.h): only its own queries.
  meshcontact::fcl::ModelCache cache;
  const bool cached = finished && in.ConsumeBool() && cache.add(mesh.get());
  if (finished && !cached && in.ConsumeIntegralInRange<int>(0, 7) == 0) {
    // A vertex edited in place after endModel(): the hierarchy no longer
    // bounds it, and the value may be anything.
    vertexArray(*mesh)[in.ConsumeIntegralInRange<int>(0, vertex_count - 1)] = fuzz::vec(in, scale);
  }

  meshcontact::fcl::Scratch scratch;
  for (int query = 0; query < 3 && in.remaining_bytes() > 0; ++query) {
    const ::fcl::CollisionObjectd mesh_object(mesh, transform(in, scale));
    const ::fcl::CollisionObjectd shape_object(shape(in, scale), transform(in, scale));
    const bool mesh_first = in.ConsumeBool();
    const ::fcl::CollisionObjectd* o1 = mesh_first ? &mesh_object : &shape_object;
    const ::fcl::CollisionObjectd* o2 = mesh_first ? &shape_object : &mesh_object;

    ::fcl::CollisionRequestd request(in.ConsumeIntegralInRange<std::size_t>(0, 40), in.ConsumeBool());
    request.gjk_solver_type = in.ConsumeBool() ? ::fcl::GST_LIBCCD : ::fcl::GST_INDEP;
    meshcontact::fcl::Options options;
    if (in.ConsumeBool()) options.settings.contact_distance = fuzz::value(in, scale);
    options.settings.key_mode = static_cast<KeyMode>(in.ConsumeIntegralInRange<int>(0, 2));
    if (cached) options.cache = &cache;

    // The drop-in, appending to a result that may already hold contacts.
    ::fcl::CollisionResultd result;
    if (in.ConsumeBool()) result.addContact(::fcl::Contactd(o1->collisionGeometry().get(), nullptr, 0, 0));
    const std::size_t before = result.numContacts();
    const Status s = meshcontact::fcl::collide(o1, o2, request, result, options, scratch);
    if (!s) {
      MC_FUZZ_CHECK(!s.message().empty());
      MC_FUZZ_CHECK(result.numContacts() == before);
      continue;
    }
    checkResult(result, before, request.num_max_contacts, mesh.get(), triangle_count);

    // postFilter on a raw result: the drop-in's own contacts (valid ones) and
    // fuzzed ones.
    ::fcl::CollisionResultd raw;
    if (request.enable_contact)
      for (std::size_t i = before; i < result.numContacts(); ++i) raw.addContact(result.getContact(i));
    const int fuzzed = in.ConsumeIntegralInRange<int>(0, 3);
    for (int k = 0; k < fuzzed; ++k) {
      const ::fcl::CollisionGeometryd* g1 = o1->collisionGeometry().get();
      const ::fcl::CollisionGeometryd* g2 = in.ConsumeIntegralInRange<int>(0, 7) == 0 ? g1 : o2->collisionGeometry().get();
      const int b = in.ConsumeIntegralInRange<int>(-2, triangle_count + 1);
      const Vec3 normal = fuzz::vec(in, 1.0);
      const Vec3 pos = fuzz::vec(in, scale);
      raw.addContact(::fcl::Contactd(g1, g2, mesh_first ? b : ::fcl::Contactd::NONE,
                                     mesh_first ? ::fcl::Contactd::NONE : b, pos, normal, fuzz::value(in, scale)));
    }
    ::fcl::CollisionResultd cleaned;
    if (in.ConsumeBool()) cleaned.addContact(::fcl::Contactd(nullptr, nullptr, 0, 0));  // replaced, not appended to
    options.post_filter = in.ConsumeBool() ? meshcontact::fcl::PostFilterMode::kRecompute : meshcontact::fcl::PostFilterMode::kClassifyFcl;
    const Status f = meshcontact::fcl::postFilter(o1, o2, request, raw, cleaned, options, scratch);
    if (!f) {
      MC_FUZZ_CHECK(!f.message().empty());
      continue;
    }
    checkResult(cleaned, 0, request.num_max_contacts, mesh.get(), triangle_count);
  }
  return 0;
}
