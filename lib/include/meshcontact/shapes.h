#pragma once
// Convex shapes other than the sphere, each in its own local frame, placed in
// the query frame by a Pose (x_query = pose.apply(x_local)).
//
// Every collide*() runs the same pipeline as collideSphere (query.h): midphase
// on the shape's query-frame bounds inflated by the contact distance,
// per-triangle contact patch (one normal, 1..4 points) tagged with the
// triangle feature it comes from, then the voided-features filter.
// Contacts follow contact.h: normal from the mesh toward the shape, depth > 0
// when penetrating, points on the shape's surface, query frame.

#include "meshcontact/contact.h"
#include "meshcontact/geometry.h"
#include "meshcontact/query.h"
#include "meshcontact/status.h"

#include <vector>

namespace meshcontact {

/// Segment from (0, 0, -half_length) to (0, 0, +half_length) swept by a ball
/// of `radius` (ODE's dCapsule with length = 2 * half_length, FCL's Capsule
/// with lz = 2 * half_length).
struct Capsule {
  double radius = 0.0;
  double half_length = 0.0;
};

/// Axis-aligned in its frame: [-half_extents, +half_extents].
struct Box {
  Vec3 half_extents = Vec3::Zero();
};

/// Axis along local z, from -half_length to +half_length.
struct Cylinder {
  double radius = 0.0;
  double half_length = 0.0;
};

}  // namespace meshcontact
