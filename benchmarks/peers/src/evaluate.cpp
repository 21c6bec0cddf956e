#include "meshcontact_peers/evaluate.h"

#include <cmath>
#include <sstream>

namespace meshcontact::peers {

namespace {

std::string describe(const SpherePlacement& p) {
  std::ostringstream s;
  s.precision(17);
  s << "SpherePlacement{Vec3(" << p.center.x() << ", " << p.center.y() << ", " << p.center.z() << "), " << p.radius
    << "}";
  return s.str();
}

}  // namespace

SphereStats evaluateSpheres(Method& method, const LocalSphereOracle& oracle,
                            const std::vector<SpherePlacement>& placements, double tolerance_deg) {
  const double cos_tol = std::cos(tolerance_deg * M_PI / 180.0);
  SphereStats st;
  const long dropped_before = method.droppedSeparated();
  std::vector<Contact> contacts;
  std::vector<LocalSphereOracle::Valid> valid;
  std::vector<double> deepest;
  for (const SpherePlacement& p : placements) {
    ++st.queries;
    const Status s = method.collideSphere(p, contacts);
    if (!s) {
      ++st.failed;
      if (st.first_failure.empty()) st.first_failure = "error '" + s.message() + "' at " + describe(p);
      continue;
    }
    oracle.validContacts(p.center, p.radius, valid);
    st.contacts += static_cast<long>(contacts.size());
    st.valid += static_cast<long>(valid.size());
    int ghosts = 0, misses = 0;
    for (const Contact& c : contacts) {
      bool near = false;
      for (const auto& v : valid) near = near || c.normal.dot(v.normal) >= cos_tol;
      if (!near) ++ghosts;
    }
    // Depth error: each contact is assigned to the valid normal nearest to
    // its own (within the tolerance); a valid contact's depth is the deepest
    // assigned to it (a solver pushes by the deepest; shallower duplicates
    // show in contacts per query), compared with the oracle's r - |c - q|.
    deepest.assign(valid.size(), -INFINITY);
    for (const Contact& c : contacts) {
      double best = cos_tol;
      std::size_t nearest = valid.size();
      for (std::size_t k = 0; k < valid.size(); ++k) {
        const double d = c.normal.dot(valid[k].normal);
        if (d >= best) {
          best = d;
          nearest = k;
        }
      }
      if (nearest < valid.size()) deepest[nearest] = std::max(deepest[nearest], c.depth);
    }
    for (std::size_t k = 0; k < valid.size(); ++k) {
      const auto& v = valid[k];
      bool near = false;
      for (const Contact& c : contacts) near = near || c.normal.dot(v.normal) >= cos_tol;
      if (!near) {
        ++misses;
        continue;
      }
      if (deepest[k] == -INFINITY) continue;  // its contacts are nearer another valid normal
      const double err = std::abs(deepest[k] - (p.radius - v.distance));
      ++st.matched;
      st.depth_error_sum += err;
      st.depth_error_max = std::max(st.depth_error_max, err);
    }
    st.ghosts += ghosts;
    st.misses += misses;
    if ((ghosts || misses) && st.first_failure.empty())
      st.first_failure = std::to_string(ghosts) + " ghosts, " + std::to_string(misses) + " misses at " + describe(p);
  }
  st.dropped_separated = method.droppedSeparated() - dropped_before;
  return st;
}

BoxStats evaluateBoxes(Method& method, const std::vector<BoxPlacement>& placements, double tolerance_deg) {
  const double cos_tol = std::cos(tolerance_deg * M_PI / 180.0);
  BoxStats st;
  const long dropped_before = method.droppedSeparated();
  std::vector<Contact> contacts;
  for (const BoxPlacement& p : placements) {
    ++st.queries;
    const Status s = method.collideBox(p, contacts);
    if (!s) {
      ++st.failed;
      if (st.first_failure.empty()) st.first_failure = s.message();
      continue;
    }
    double lowest = INFINITY;
    for (int k = 0; k < 8; ++k) {
      const Vec3 corner((k & 1 ? 1 : -1) * p.half_extents.x(), (k & 2 ? 1 : -1) * p.half_extents.y(),
                        (k & 4 ? 1 : -1) * p.half_extents.z());
      lowest = std::min(lowest, p.pose.apply(corner).z());
    }
    st.contacts += static_cast<long>(contacts.size());
    for (const Contact& c : contacts)
      if (c.normal.z() < cos_tol) ++st.tilted;
    if (lowest < 0.0) {
      ++st.penetrating;
      if (contacts.empty()) ++st.missed;
    }
  }
  st.dropped_separated = method.droppedSeparated() - dropped_before;
  return st;
}

}  // namespace meshcontact::peers
