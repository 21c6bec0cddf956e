// The collider override (trimesh vs sphere / capsule / box / cylinder /
// convex) and collideWithGroup: core contacts converted to dContactGeom.
#include "adapter.h"

#include <cstdarg>
#include <cstdio>

namespace meshcontact::ode {
namespace {

using detail::Registry;
using detail::ThreadContext;

dContactGeom* contactAt(dContactGeom* contacts, int i, int skip) {
  return reinterpret_cast<dContactGeom*>(reinterpret_cast<char*>(contacts) + static_cast<std::ptrdiff_t>(i) * skip);
}

void setVec(dVector3 out, const Vec3& v) {
  out[0] = static_cast<dReal>(v.x());
  out[1] = static_cast<dReal>(v.y());
  out[2] = static_cast<dReal>(v.z());
  out[3] = 0;
}

// Keeps the contacts of instance `own` in place (order kept).
void keepInstance(std::vector<Contact>& contacts, std::uint32_t own) {
  std::size_t w = 0;
  for (std::size_t i = 0; i < contacts.size(); ++i)
    if (contacts[i].mesh == own) contacts[w++] = contacts[i];
  contacts.resize(w);
}

// Writes the selected contacts (ctx.chosen) as dContactGeoms and returns how
// many. ODE's normal points into g1. `trimesh_first`: g1 = the trimesh (the
// override: the normal is the core's, negated, since the core's points from
// the mesh toward the shape) and side1 = the triangle; otherwise g1 = the
// shape (collideWithGroup: the core's direction) and side2 = the triangle.
int writeContacts(const ThreadContext& ctx, bool trimesh_first, dGeomID trimesh, dGeomID shape,
                  dContactGeom* contacts, int skip) {
  const Pose& frame = ctx.frame;
  int written = 0;
  for (std::uint32_t i : ctx.chosen) {
    const Contact& c = ctx.contacts[i];
    dContactGeom* out = contactAt(contacts, written++, skip);
    setVec(out->pos, frame.apply(c.point));
    // The core's normal is unit; the trimesh's rotation is only as
    // orthonormal as ODE keeps it (and the core accepts 1e-9 of error in
    // the shape's pose relative to it): renormalized unless it is the exact
    // identity (the usual static ground), which keeps the core's bits.
    const Vec3 normal = frame.isIdentity() ? c.normal : Vec3((frame.rotation * c.normal).normalized());
    setVec(out->normal, trimesh_first ? Vec3(-normal) : normal);
    out->depth = static_cast<dReal>(c.depth);
    // collideWithGroup: each contact names the piece it came from.
    const dGeomID mesh_geom = trimesh_first ? trimesh : ctx.instance_geoms[c.mesh];
    out->g1 = trimesh_first ? mesh_geom : shape;
    out->g2 = trimesh_first ? shape : mesh_geom;
    out->side1 = trimesh_first ? static_cast<int>(c.triangle) : -1;
    out->side2 = trimesh_first ? -1 : static_cast<int>(c.triangle);
  }
  return written;
}

// ODE calls it as (trimesh, shape) for both orders (dSetColliderOverride),
// and swaps the result itself for dCollide(shape, trimesh).
int trimeshCollider(dGeomID trimesh, dGeomID shape, int flags, dContactGeom* contacts, int skip) {
  const int budget = flags & 0xffff;
  if (budget <= 0) return 0;
  ThreadContext& ctx = detail::threadContext();
  ctx.counters.addPairQuery();
  const Settings& settings = detail::refreshView(ctx);
  std::uint32_t own = 0;
  Status s = detail::gatherInstances(trimesh, shape, settings.query, ctx, own);
  if (s) s = detail::shapeInFrame(shape, ctx);
  if (s) s = detail::runGroupQuery(settings.query, ctx);
  if (!s) {
    detail::report(s, trimesh, shape);
    return 0;
  }
  keepInstance(ctx.contacts, own);
  ctx.counters.addContactsFound(ctx.contacts.size());
  detail::selectContacts(ctx.contacts, budget, ctx.chosen, ctx.min_distance2);
  const int written = writeContacts(ctx, true, trimesh, shape, contacts, skip);
  ctx.counters.addContactsReturned(static_cast<std::uint64_t>(written));
  return written;
}

// ODE's internal assertions call its debug handler, then abort() when the
// handler returns. This one throws, so that an assertion in a call made
// while it is installed (OdeAssertionGuard) becomes an error.
struct OdeAssertion {
  std::string message;
};

void throwOdeAssertion(int, const char* format, va_list args) {
  char text[512];
  std::vsnprintf(text, sizeof text, format, args);
  throw OdeAssertion{text};
}

class OdeAssertionGuard {
 public:
  OdeAssertionGuard() : previous_(dGetDebugHandler()) { dSetDebugHandler(&throwOdeAssertion); }
  ~OdeAssertionGuard() { dSetDebugHandler(previous_); }
  OdeAssertionGuard(const OdeAssertionGuard&) = delete;
  OdeAssertionGuard& operator=(const OdeAssertionGuard&) = delete;

 private:
  dMessageFunction* previous_;
};

}  // namespace

Status installColliders(const Settings& settings, unsigned* installed) {
  if (installed) *installed = 0;
  Status s = detail::checkSettings(settings);
  if (!s) return s;
  static const int kClasses[] = {dSphereClass, dCapsuleClass, dBoxClass, dCylinderClass, dConvexClass};
  unsigned done = 0;
  try {
    // Before dInitODE2 (or after dCloseODE) ODE's collider table is not
    // initialised, and dSetColliderOverride's first statement asserts that
    // it is, which aborts the process; ODE publishes no way to ask. The
    // assertion comes before any change, so nothing is installed then.
    const OdeAssertionGuard guard;
    for (int cls : kClasses) {
      const unsigned bit = detail::shapeBit(cls);
      if ((settings.shapes & bit) == 0) continue;
      dSetColliderOverride(dTriMeshClass, cls, &trimeshCollider);
      done |= bit;
    }
  } catch (const OdeAssertion& e) {
    return {ErrorCode::kInvalidSettings,
            "installColliders: ODE refused the override (call dInitODE2 first): " + e.message};
  }
  if (installed) *installed = done;
  return setSettings(settings);
}

int collideWithGroup(dGeomID shape, const dGeomID* trimeshes, int count, int flags, dContactGeom* contacts, int skip) {
  const int budget = flags & 0xffff;
  if (budget <= 0) return 0;
  ThreadContext& ctx = detail::threadContext();
  ctx.counters.addPairQuery();
  const Settings& settings = detail::refreshView(ctx);
  Status s;
  // ODE checks these for its own colliders (dCollide's assertions); a near
  // callback calls this function directly.
  if (contacts == nullptr || skip < static_cast<int>(sizeof(dContactGeom)))
    s = {ErrorCode::kInvalidSettings, "collideWithGroup: contacts is null or skip " + std::to_string(skip) +
                                          " is below sizeof(dContactGeom)"};
  if (s) s = detail::gatherInstanceList(trimeshes, count, shape, settings.query, ctx);
  if (s) s = detail::shapeInFrame(shape, ctx);
  if (s) s = detail::runShapeQuery(settings.query, ctx);
  if (!s) {
    detail::report(s, count > 0 && trimeshes ? trimeshes[0] : nullptr, shape);
    return 0;
  }
  ctx.counters.addContactsFound(ctx.contacts.size());
  detail::selectContacts(ctx.contacts, budget, ctx.chosen, ctx.min_distance2);
  const int written = writeContacts(ctx, false, nullptr, shape, contacts, skip);
  ctx.counters.addContactsReturned(static_cast<std::uint64_t>(written));
  return written;
}

}  // namespace meshcontact::ode
