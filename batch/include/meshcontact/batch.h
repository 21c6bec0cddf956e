#pragma once
// Batch queries on all cores (meshcontact::batch, oneTBB): many shape queries
// against one mesh set, answered in parallel, with results identical to the
// sequential calls whatever the number of threads.
//
// Conventions
// - Each BatchQuery is one call of the core: collideSphere, collideCapsule,
//   collideBox, collideCylinder or collideConvex (query.h, shapes.h,
//   convex.h) against the same instances with the same QuerySettings. Its
//   contacts follow contact.h: query frame, normal from the mesh toward the
//   shape, depth > 0 when penetrating.
// - Output (caller-owned BatchOutput, reused between calls): query i's
//   contacts are contacts[offsets[i] .. offsets[i + 1]), in the order the
//   sequential call returns them; status[i] is that call's Status. A query
//   that fails (NaN pose, negative radius, ...) gets its error and no
//   contacts; the others are unaffected. Nothing is truncated: there is no
//   per-query capacity.
// - Determinism: every query is answered by the same core function as the
//   sequential call, with a per-thread QueryScratch that holds nothing that
//   changes a result (query.h), and the output order is fixed by the query
//   index alone. So the output is bitwise identical for any thread count and
//   equal to calling the core function query by query.
// - Memory: BatchScratch keeps one QueryScratch per worker thread
//   (tbb::enumerable_thread_specific) and the per-block contact buffers,
//   never shrunk. Once they have grown, a batch allocates nothing per query
//   (oneTBB's own task bookkeeping aside). Blocks go to whichever thread is
//   free, so a worker's scratch can still grow the first time it meets a
//   larger query than before: with several threads this settles over the
//   first few batches (benchmarks/batch_bench.cpp counts it).
// - Threads: BatchSettings::max_threads caps the worker count through a
//   tbb::task_arena owned by the scratch (0 = oneTBB's default, all
//   hardware threads). The call blocks until the batch is done.
//
// Thread safety: one call per BatchScratch at a time. The instances, their
// meshes and any SupportShape must stay unchanged during the call (built
// meshes are immutable; SupportShape::support() must be safe to call from
// several threads at once, as every const member of the built-in shapes is).

#include "meshcontact/contact.h"
#include "meshcontact/convex.h"
#include "meshcontact/geometry.h"
#include "meshcontact/query.h"
#include "meshcontact/shapes.h"
#include "meshcontact/status.h"

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

namespace meshcontact {

enum class BatchShape : std::uint8_t { kSphere, kCapsule, kBox, kCylinder, kConvex };

/// One query of a batch. Only the member named by `shape` is read.
struct BatchQuery {
  BatchShape shape = BatchShape::kSphere;
  /// kSphere: centre in the query frame (`pose` is not used).
  Sphere sphere;
  Capsule capsule;                        // kCapsule, placed by `pose`
  Box box;                                // kBox, placed by `pose`
  Cylinder cylinder;                      // kCylinder (automatic margin), placed by `pose`
  const SupportShape* convex = nullptr;   // kConvex: not owned, placed by `pose`
  /// x_query = pose.apply(x_local) for every shape but the sphere.
  Pose pose;

  static BatchQuery ofSphere(const Sphere& s) {
    BatchQuery q;
    q.shape = BatchShape::kSphere;
    q.sphere = s;
    return q;
  }
  static BatchQuery ofCapsule(const Capsule& c, const Pose& p) {
    BatchQuery q;
    q.shape = BatchShape::kCapsule;
    q.capsule = c;
    q.pose = p;
    return q;
  }
  static BatchQuery ofBox(const Box& b, const Pose& p) {
    BatchQuery q;
    q.shape = BatchShape::kBox;
    q.box = b;
    q.pose = p;
    return q;
  }
  static BatchQuery ofCylinder(const Cylinder& c, const Pose& p) {
    BatchQuery q;
    q.shape = BatchShape::kCylinder;
    q.cylinder = c;
    q.pose = p;
    return q;
  }
  static BatchQuery ofConvex(const SupportShape& s, const Pose& p) {
    BatchQuery q;
    q.shape = BatchShape::kConvex;
    q.convex = &s;
    q.pose = p;
    return q;
  }
};

struct BatchSettings {
  /// Applied to every query. `trace` must be null (kInvalidSettings
  /// otherwise: one trace cannot be filled by many threads).
  QuerySettings query;
  /// Worker threads at most; 0 = all hardware threads (oneTBB's default).
  /// Larger values are capped at the parallelism oneTBB allows the process
  /// (the hardware's threads, unless a tbb::global_control changes it).
  int max_threads = 0;
  /// Queries per parallel block (>= 1). Blocks are fixed by the query index,
  /// not by the threads, so this changes speed only, never results.
  std::size_t block_size = 64;
};

/// Caller-owned results (see the conventions above). Vectors are resized,
/// never shrunk, so a reused BatchOutput stops allocating.
struct BatchOutput {
  std::vector<Contact> contacts;
  std::vector<std::size_t> offsets;  // size queries + 1
  std::vector<Status> status;        // size queries
  std::size_t failed = 0;            // queries whose status is not ok

  std::size_t contactCount(std::size_t query) const { return offsets[query + 1] - offsets[query]; }
  const Contact* contactsOf(std::size_t query) const { return contacts.data() + offsets[query]; }
};

/// Per-thread query scratch, per-block buffers and the task arena, reused
/// between batches. Movable, not copyable.
class BatchScratch {
 public:
  BatchScratch();
  ~BatchScratch();
  BatchScratch(BatchScratch&&) noexcept;
  BatchScratch& operator=(BatchScratch&&) noexcept;

  struct Impl;
  Impl& impl() { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

/// Answers queries[0 .. count) against the instances (one surface, as in
/// collideSphere(instances, ...)). Per-query errors (the core's, and
/// kInvalidShape for a kConvex query without a shape) go to out.status and
/// never stop the other queries. The returned Status is an error only for
/// the batch as a whole, checked before any query runs: kInvalidSettings
/// (trace set, block_size 0, max_threads < 0), kMeshNotBuilt (`instances`
/// null with instance_count > 0, a null mesh, or a mesh whose build() did
/// not succeed); then `out` holds count queries with no contacts, each with
/// that same error. kInvalidShape: `queries` null with count > 0; then `out`
/// holds no query (offsets = {0}, failed = 0). An empty batch succeeds with
/// offsets = {0}.
/// An exception thrown inside a query (by a user's SupportShape, convex.h,
/// or std::bad_alloc) stops the batch (oneTBB cancels the blocks not yet
/// started) and is rethrown to the caller once the running ones ended; `out`
/// then holds count queries with no contacts, each with kInvalidShape saying
/// that the batch was stopped (none half-written), and the scratch stays
/// usable.
Status collideBatch(const MeshInstance* instances, std::size_t instance_count, const BatchQuery* queries,
                    std::size_t count, const BatchSettings& settings, BatchScratch& scratch, BatchOutput& out);

/// The same query answered sequentially by the core (what collideBatch does
/// for each query, exposed for comparisons and fallbacks).
Status collideOne(const MeshInstance* instances, std::size_t instance_count, const BatchQuery& query,
                  const QuerySettings& settings, QueryScratch& scratch, std::vector<Contact>& contacts);

}  // namespace meshcontact
