#include "methods.h"

#include <fcl/config.h>
#include <ode/ode.h>
#ifdef MESHCONTACT_PEERS_BULLET
#include <LinearMath/btScalar.h>
#endif

namespace meshcontact::peers {

std::vector<std::string> methodNames() {
  std::vector<std::string> names = {"meshcontact", "meshcontact-position", "naive-closest", "naive-trinormal",
                                    "ode", "fcl"};
#ifdef MESHCONTACT_PEERS_BULLET
  names.push_back("bullet");
  names.push_back("bullet-iedge");
#endif
  return names;
}

Status makeMethod(const std::string& name, const CompareScene& scene, std::unique_ptr<Method>& out) {
  if (name == "ode") return makeOdeMethod(scene, out);
  if (name == "fcl") return makeFclMethod(scene, out);
#ifdef MESHCONTACT_PEERS_BULLET
  if (name == "bullet") return makeBulletMethod(false, scene, out);
  if (name == "bullet-iedge") return makeBulletMethod(true, scene, out);
#endif
  return makeCoreMethod(name, scene, out);
}

std::string peerVersions() {
  std::string s = "ODE (";
  s += dCheckConfiguration("ODE_double_precision") ? "double" : "single";
  s += ", OPCODE trimesh); FCL " FCL_VERSION " (OBBRSS, GST_LIBCCD)";
#ifdef MESHCONTACT_PEERS_BULLET
  s += "; Bullet " + std::to_string(BT_BULLET_VERSION) + " (double)";
#else
  s += "; Bullet not found (skipped)";
#endif
  return s;
}

}  // namespace meshcontact::peers
