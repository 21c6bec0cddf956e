#pragma once
// Per-peer factories, each compiled in only when its dependency was found.
#include "meshcontact_peers/peers.h"

namespace meshcontact::peers {

Status makeCoreMethod(const std::string& name, const CompareScene& scene, std::unique_ptr<Method>& out);
Status makeOdeMethod(const CompareScene& scene, std::unique_ptr<Method>& out);
Status makeFclMethod(const CompareScene& scene, std::unique_ptr<Method>& out);
#ifdef MESHCONTACT_PEERS_BULLET
Status makeBulletMethod(bool internal_edge_utility, const CompareScene& scene, std::unique_ptr<Method>& out);
#endif

/// Keeps the penetrating contacts (depth > 0), counting the others.
inline void keepPenetrating(std::vector<Contact>& out, long& dropped) {
  std::size_t k = 0;
  for (const Contact& c : out)
    if (c.depth > 0.0) out[k++] = c;
  dropped += static_cast<long>(out.size() - k);
  out.resize(k);
}

}  // namespace meshcontact::peers
