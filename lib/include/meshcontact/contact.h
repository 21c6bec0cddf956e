#pragma once
// What a query returns, and the options it takes.

#include "meshcontact/geometry.h"

#include <cstdint>
#include <vector>

namespace meshcontact {

/// One rigid-body contact between a shape and a mesh triangle.
/// Frame: the query frame (the mesh's local frame for a single mesh, the
/// frame the MeshInstance poses map into for a mesh set).
struct Contact {
  /// On the shape's surface: the shape's deepest point along -normal
  /// (reference §4a: where the line from the sphere's centre to the
  /// triangle's closest point crosses the sphere).
  Vec3 point = Vec3::Zero();
  /// Unit vector from the mesh toward the shape: moving the shape along it
  /// separates the two.
  Vec3 normal = Vec3::UnitZ();
  /// Positive when the shape penetrates the triangle, negative when they are
  /// apart but within the contact distance. Along `normal`.
  double depth = 0.0;
  /// Index of the mesh in the MeshInstance list (0 for a single mesh).
  std::uint32_t mesh = 0;
  /// Index of the triangle in that mesh.
  std::uint32_t triangle = 0;
  /// The triangle feature the contact lies on.
  Feature feature;
};

/// Which vertex identity the voided-features filter compares (reference §6).
enum class KeyMode : std::uint8_t {
  /// Vertex indices for a single welded mesh (cheapest); positions otherwise.
  kAuto,
  /// Vertex indices (per mesh). Edges shared only through duplicated
  /// vertices, or between separate meshes, count as boundaries.
  kVertexIndex,
  /// Exact (bitwise) vertex positions in the query frame: works across
  /// duplicated vertices and across separate meshes whose vertices meet at
  /// bitwise-equal positions (e.g. pieces authored in one frame; -0 == +0).
  /// Meshes of different poses (pieces each in a frame of its own) meet a
  /// few ulps apart once moved into the query frame: the pipelines first
  /// weld their corners within round-off (weldCorners, filter.h).
  kVertexPosition,
};

enum class FilterMode : std::uint8_t {
  /// The voided-features filter of reference §5: no internal-edge contacts.
  kVoidedFeatures,
  /// Every potential contact (the naive closest-point method of reference
  /// §2): a baseline for comparisons, with the ghosts it implies.
  kNone,
};

/// What happened to one candidate triangle (the per-contact "why" trace).
enum class Verdict : std::uint8_t {
  kFaceContact,            // closest point inside the face: kept, triangle voided
  kEdgeContact,            // delayed edge contact, not voided: kept
  kVertexContact,          // delayed vertex contact, not voided: kept
  kVoided,                 // delayed contact on a voided edge/vertex (a box's: or pushing along its plane): dropped
  kBackFacing,             // shape behind the triangle's plane (§4a): culled
  kBeyondContactDistance,  // farther than radius + contact distance (fig. 1)
  kDegenerate,             // no usable normal
};
const char* toString(Verdict verdict);

struct TraceEntry {
  std::uint32_t mesh = 0;
  std::uint32_t triangle = 0;
  Feature feature;          // meaningful for contacts and kVoided
  double distance = 0.0;    // shape-to-triangle distance (query frame units)
  Verdict verdict = Verdict::kDegenerate;
};

struct QuerySettings {
  /// Extra distance (query-frame units, >= 0) within which separated pairs
  /// still produce contacts (with negative depth). Reference §4a: the
  /// inflated radius is radius + contact_distance.
  double contact_distance = 0.0;
  /// A value none of the enum's (a cast integer) is kInvalidSettings.
  /// The whole pipelines (collideSphere(mesh, ...) and the others) resolve
  /// it over their meshes (resolveKeyMode). The candidates' stages
  /// (collide*Candidates) compare the keys the candidates carry, and with
  /// kVertexPosition also count corners at bitwise-equal positions as one
  /// vertex: vertex indices then serve as keys, with no assignPositionKeys()
  /// pass (filter.h), as long as equal keys are equal positions across all
  /// the candidates: with several meshes, mesh << 32 | index, not the bare
  /// index (two meshes' vertex 5 would count as one vertex).
  KeyMode key_mode = KeyMode::kAuto;
  FilterMode filter = FilterMode::kVoidedFeatures;
  /// When non-null, cleared and filled with one entry per candidate triangle
  /// (not free: for tests and debugging).
  std::vector<TraceEntry>* trace = nullptr;
  /// Manifold reduction (shapes other than the sphere; runs after the
  /// filter): contacts whose normals agree within `manifold_angle_deg` form
  /// one manifold, reduced to at most 4 contacts (the deepest, then the ones
  /// spanning the largest area). A box resting on a tessellated floor then
  /// gets 4 contacts, not a patch per triangle. Contacts are selected, never
  /// averaged: each kept contact is one the filter produced. The trace still
  /// reports the filter's verdict for triangles whose contacts were dropped
  /// here.
  bool reduce_manifold = true;
  /// Angle (degrees, in [0, 90)) within which two contact normals count as
  /// one manifold. The default tolerates tessellation noise on a flat or
  /// gently curved surface, and keeps the two slopes of a groove apart.
  double manifold_angle_deg = 3.0;
};

}  // namespace meshcontact
