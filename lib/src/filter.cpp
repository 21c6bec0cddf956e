// The filter stage on external input (filter.h): position keys for triangles
// from another midphase, and the voided-features filter on patches computed
// by another narrowphase. Both reuse the query pipeline's own code paths
// (the StampedMap of the midphase, detail::generateContacts, the manifold
// reduction), so an adapter gets exactly the filter the queries run.
#include "meshcontact/filter.h"

#include "manifold_reduction.h"
#include "scratch.h"
#include "validate.h"
#include "voided_features.h"

#include <cmath>
#include <cstring>
#include <string>

namespace meshcontact {

namespace {

Status checkPatch(const TrianglePatch& p, std::size_t i, const CandidateTriangle& c) {
  const std::string where = "patch " + std::to_string(i) + " (mesh " + std::to_string(c.mesh) + ", triangle " +
                            std::to_string(c.triangle) + ")";
  // The filter reads the keys of edge or vertex `index` (voided_features.h):
  // an index beyond 2 would read past them.
  const bool face = p.feature.type == FeatureType::kFace && p.feature.index == 0;
  const bool edge_or_vertex =
      (p.feature.type == FeatureType::kEdge || p.feature.type == FeatureType::kVertex) && p.feature.index < 3;
  if (!face && !edge_or_vertex)
    return {ErrorCode::kInvalidSettings, where + ": feature (type " + std::to_string(static_cast<int>(p.feature.type)) +
                                             ", index " + std::to_string(p.feature.index) +
                                             ") is not the face (index 0), an edge 0..2 or a vertex 0..2"};
  if (p.count < 1 || p.count > 4)
    return {ErrorCode::kInvalidSettings, where + ": point count must be 1..4, got " + std::to_string(p.count)};
  if (!p.normal.allFinite() || !(std::abs(p.normal.norm() - 1.0) <= 1e-6))
    return {ErrorCode::kInvalidSettings, where + ": normal " + detail::describe(p.normal) + " is not a unit vector"};
  if (!std::isfinite(p.distance))
    return {ErrorCode::kInvalidSettings, where + ": distance is not finite"};
  for (int k = 0; k < p.count; ++k)
    if (!p.points[k].allFinite() || !std::isfinite(p.depths[k]))
      return {ErrorCode::kInvalidSettings, where + ": point " + std::to_string(k) + " or its depth is not finite"};
  return Status::ok();
}

Status checkArray(const void* array, std::size_t count, const char* what) {
  if (array == nullptr && count > 0)
    return {ErrorCode::kInvalidSettings, std::string(what) + " is null with count " + std::to_string(count)};
  return Status::ok();
}

}  // namespace

Status assignPositionKeys(CandidateTriangle* candidates, std::size_t count, QueryScratch& scratch) {
  if (Status s = checkArray(candidates, count, "candidates"); !s) return s;
  QueryScratch::Impl& sc = scratch.impl();
  sc.positions.reset(3 * count);
  for (std::size_t i = 0; i < count; ++i) {
    CandidateTriangle& c = candidates[i];
    for (int k = 0; k < 3; ++k) {
      if (!c.vertices[k].allFinite()) return detail::candidateCornerError(c, i, k, "is not finite");
      c.keys[k] = sc.positionKeyOf(c.vertices[k]);
    }
  }
  return Status::ok();
}

Status assignPositionKeysFromIndices(CandidateTriangle* candidates, std::size_t count, QueryScratch& scratch) {
  if (Status s = checkArray(candidates, count, "candidates"); !s) return s;
  QueryScratch::Impl& sc = scratch.impl();
  sc.positions.reset(3 * count);
  // A run of candidates of one mesh shares a generation of the index cache
  // (scratch.h): a new mesh, or the return of an earlier one, starts a new
  // run, so a cached key is only ever reused for the same (mesh, index).
  std::uint64_t generation = 0;
  for (std::size_t i = 0; i < count; ++i) {
    CandidateTriangle& c = candidates[i];
    if (i == 0 || c.mesh != candidates[i - 1].mesh) generation = sc.nextVertexKeyGeneration();
    for (int k = 0; k < 3; ++k) {
      // Every corner is checked, also those whose key the cache gives: a
      // caller whose equal indices are not equal positions still gets the
      // error for a non-finite corner.
      if (!c.vertices[k].allFinite()) return detail::candidateCornerError(c, i, k, "is not finite");
      const std::uint64_t index = c.keys[k];
      if (index <= 0xffffffffu) {
        sc.vertexPositionKey(generation, static_cast<std::uint32_t>(index), c.vertices[k], c.keys[k]);
      } else {  // beyond the cache's 32-bit tags: hashed every time (same key)
        c.keys[k] = sc.positionKeyOf(c.vertices[k]);
      }
    }
  }
  return Status::ok();
}

Status filterPatches(const CandidateTriangle* candidates, const TrianglePatch* patches, std::size_t count,
                     double length_scale, const QuerySettings& settings, QueryScratch& scratch,
                     std::vector<Contact>& contacts) {
  contacts.clear();
  if (settings.trace) settings.trace->clear();
  if (!std::isfinite(length_scale) || !(length_scale > 0.0))
    return {ErrorCode::kInvalidSettings, "length_scale must be finite and > 0, got " + detail::describe(length_scale)};
  Status s = detail::checkManifoldSettings(settings);
  if (!s) return s;
  if (s = detail::checkFilterMode(settings.filter); !s) return s;
  // Not read here (the keys are compared as given), but a value none of the
  // enum's is an error wherever the settings are taken (contact.h).
  if (!detail::isKeyMode(settings.key_mode)) return detail::keyModeError(settings.key_mode);
  if (s = checkArray(candidates, count, "candidates"); !s) return s;
  if (s = checkArray(patches, count, "patches"); !s) return s;
  for (std::size_t i = 0; i < count; ++i) {
    s = checkPatch(patches[i], i, candidates[i]);
    if (!s) return s;
  }
  // The "narrowphase" hands back the caller's patch for its candidate.
  auto narrowphase = [candidates, patches](const CandidateTriangle& c, detail::Patch& p) {
    const TrianglePatch& in = patches[&c - candidates];
    p.feature = in.feature;
    p.distance = in.distance;
    p.normal = in.normal.normalized();  // accepted within 1e-6 of unit; Contact::normal is unit
    p.count = in.count;
    for (int k = 0; k < in.count; ++k) {
      p.points[k] = in.points[k];
      p.depths[k] = in.depths[k];
    }
    return detail::PatchOutcome::kContact;
  };
  QueryScratch::Impl& sc = scratch.impl();
  // The keys as the caller set them (assignPositionKeys...).
  detail::generateContacts(candidates, count, narrowphase, settings, detail::VertexIdentity::kKeys, sc.filter,
                           contacts);
  detail::reduceManifolds(contacts, settings, length_scale, sc.manifold);
  return Status::ok();
}

}  // namespace meshcontact
