#pragma once
// Scoring of a method on a list of placements (DESIGN.md §5), shared by the
// accuracy harness and the CI test.
#include "meshcontact_peers/peers.h"

namespace meshcontact::peers {

/// Sphere oracle figures of one method on one scene.
struct SphereStats {
  long queries = 0;
  long failed = 0;    // queries that returned an error status
  long contacts = 0;
  long ghosts = 0;    // contacts more than 2 degrees from every valid normal
  long valid = 0;     // valid normals (oracle, reach = radius)
  long misses = 0;    // valid normals no contact reproduces within 2 degrees
  long matched = 0;   // valid normals with a contact assigned (nearest normal): the depth error is over these
  double depth_error_sum = 0.0;
  double depth_error_max = 0.0;
  long dropped_separated = 0;
  std::string first_failure;  // the first ghost / miss / error, ready to paste

  double ghostRate() const { return contacts ? double(ghosts) / double(contacts) : 0.0; }
  double missRate() const { return valid ? double(misses) / double(valid) : 0.0; }
  double contactsPerQuery() const { return queries ? double(contacts) / double(queries) : 0.0; }
  double meanDepthError() const { return matched ? depth_error_sum / double(matched) : 0.0; }
};

/// Planar oracle figures (boxes on a z = 0 floor: every valid normal is +z).
struct BoxStats {
  long queries = 0;
  long failed = 0;
  long contacts = 0;
  long tilted = 0;        // normals more than 2 degrees from +z
  long penetrating = 0;   // poses whose lowest corner is below the floor
  long missed = 0;        // penetrating poses with no contact
  long dropped_separated = 0;
  std::string first_failure;

  double tiltedRate() const { return contacts ? double(tilted) / double(contacts) : 0.0; }
  double missRate() const { return penetrating ? double(missed) / double(penetrating) : 0.0; }
  double contactsPerQuery() const { return queries ? double(contacts) / double(queries) : 0.0; }
};

SphereStats evaluateSpheres(Method& method, const LocalSphereOracle& oracle,
                            const std::vector<SpherePlacement>& placements, double tolerance_deg = 2.0);
BoxStats evaluateBoxes(Method& method, const std::vector<BoxPlacement>& placements, double tolerance_deg = 2.0);

}  // namespace meshcontact::peers
