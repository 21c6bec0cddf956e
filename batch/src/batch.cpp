#include "meshcontact/batch.h"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <string>

namespace meshcontact {

struct BatchScratch::Impl {
  // One query scratch and one contact buffer per worker thread: a thread
  // answers one query at a time, so these are never shared.
  tbb::enumerable_thread_specific<QueryScratch> query_scratch;
  tbb::enumerable_thread_specific<std::vector<Contact>> query_contacts;
  // Contacts of each block of queries, in query order; concatenated into the
  // caller's output once every block's size is known. Kept (never shrunk)
  // so that later batches reuse their capacity.
  std::vector<std::vector<Contact>> blocks;
  std::unique_ptr<tbb::task_arena> arena;
  int arena_threads = -1;

  tbb::task_arena& arenaFor(int max_threads) {
    if (!arena || arena_threads != max_threads) {
      // task_arena::automatic is a static const without a definition in
      // oneTBB 2021: read its value, never bind a reference to it.
      // Capped at the parallelism oneTBB allows the process (the hardware's
      // threads unless a tbb::global_control says otherwise): more slots
      // add nothing, and oneTBB 2021 crashed when an arena of 70,000 slots
      // was destroyed (65,536 worked).
      const auto allowed = tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism);
      const int slots = max_threads == 0 ? static_cast<int>(tbb::task_arena::automatic) + 0
                                         : static_cast<int>(std::min<std::size_t>(max_threads, allowed));
      arena = std::make_unique<tbb::task_arena>(slots);
      arena_threads = max_threads;
    }
    return *arena;
  }
};

BatchScratch::BatchScratch() : impl_(std::make_unique<Impl>()) {}
BatchScratch::~BatchScratch() = default;
BatchScratch::BatchScratch(BatchScratch&&) noexcept = default;
BatchScratch& BatchScratch::operator=(BatchScratch&&) noexcept = default;

Status collideOne(const MeshInstance* instances, std::size_t instance_count, const BatchQuery& query,
                  const QuerySettings& settings, QueryScratch& scratch, std::vector<Contact>& contacts) {
  switch (query.shape) {
    case BatchShape::kSphere:
      return collideSphere(instances, instance_count, query.sphere, settings, scratch, contacts);
    case BatchShape::kCapsule:
      return collideCapsule(instances, instance_count, query.capsule, query.pose, settings, scratch, contacts);
    case BatchShape::kBox:
      return collideBox(instances, instance_count, query.box, query.pose, settings, scratch, contacts);
    case BatchShape::kCylinder:
      return collideCylinder(instances, instance_count, query.cylinder, query.pose, settings, scratch, contacts);
    case BatchShape::kConvex:
      if (!query.convex) {
        contacts.clear();
        return Status(ErrorCode::kInvalidShape, "BatchQuery: a kConvex query without a shape (convex is null)");
      }
      return collideConvex(instances, instance_count, *query.convex, query.pose, settings, scratch, contacts);
  }
  contacts.clear();
  return Status(ErrorCode::kInvalidShape,
                "BatchQuery: unknown shape " + std::to_string(static_cast<int>(query.shape)));
}

namespace {

Status checkBatch(const MeshInstance* instances, std::size_t instance_count, const BatchQuery* queries,
                  std::size_t count, const BatchSettings& settings) {
  if (settings.query.trace)
    return Status(ErrorCode::kInvalidSettings, "collideBatch: QuerySettings::trace must be null in a batch");
  if (settings.block_size == 0) return Status(ErrorCode::kInvalidSettings, "collideBatch: block_size is 0");
  if (settings.max_threads < 0)
    return Status(ErrorCode::kInvalidSettings,
                  "collideBatch: max_threads is " + std::to_string(settings.max_threads) + " (must be >= 0)");
  if (!queries && count > 0)
    return Status(ErrorCode::kInvalidShape, "collideBatch: queries is null with count " + std::to_string(count));
  if (!instances && instance_count > 0)
    return Status(ErrorCode::kMeshNotBuilt,
                  "collideBatch: instances is null with instance_count " + std::to_string(instance_count));
  for (std::size_t i = 0; i < instance_count; ++i)
    if (!instances[i].mesh || !instances[i].mesh->isBuilt())
      return Status(ErrorCode::kMeshNotBuilt,
                    "collideBatch: instance " + std::to_string(i) + " has no built mesh");
  return Status::ok();
}

// Pass 1 of collideBatch: answer the queries, block by block. A block's
// queries run in index order on one thread; offsets[i + 1] holds query i's
// count.
void runQueries(const MeshInstance* instances, std::size_t instance_count, const BatchQuery* queries,
                std::size_t count, const BatchSettings& settings, BatchScratch::Impl& impl, std::size_t blocks,
                BatchOutput& out) {
  const std::size_t block = settings.block_size;
  const QuerySettings& query_settings = settings.query;
  impl.arenaFor(settings.max_threads).execute([&] {
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, blocks, 1),
        [&](const tbb::blocked_range<std::size_t>& range) {
          QueryScratch& query_scratch = impl.query_scratch.local();
          std::vector<Contact>& contacts = impl.query_contacts.local();
          for (std::size_t b = range.begin(); b != range.end(); ++b) {
            std::vector<Contact>& block_contacts = impl.blocks[b];
            block_contacts.clear();
            const std::size_t end = b * block + std::min(block, count - b * block);  // (b + 1) * block may wrap
            for (std::size_t i = b * block; i < end; ++i) {
              Status s = collideOne(instances, instance_count, queries[i], query_settings, query_scratch, contacts);
              if (s) {
                block_contacts.insert(block_contacts.end(), contacts.begin(), contacts.end());
                out.offsets[i + 1] = contacts.size();
              }
              out.status[i] = std::move(s);
            }
          }
        },
        tbb::simple_partitioner());
  });
}

}  // namespace

Status collideBatch(const MeshInstance* instances, std::size_t instance_count, const BatchQuery* queries,
                    std::size_t count, const BatchSettings& settings, BatchScratch& scratch, BatchOutput& out) {
  if (!queries && count > 0) {
    // No queries to answer: `out` gets none (count says nothing about an
    // array that is not there, and one status each for SIZE_MAX / 2 of them
    // threw std::length_error).
    out.offsets.assign(1, 0);
    out.status.clear();
    out.contacts.clear();
    out.failed = 0;
    return Status(ErrorCode::kInvalidShape, "collideBatch: queries is null with count " + std::to_string(count));
  }
  out.offsets.assign(count + 1, 0);
  out.status.resize(count);
  out.failed = 0;
  if (Status bad = checkBatch(instances, instance_count, queries, count, settings); !bad) {
    out.contacts.clear();
    std::fill(out.status.begin(), out.status.end(), bad);
    out.failed = count;
    return bad;
  }
  if (count == 0) {
    out.contacts.clear();
    return Status::ok();
  }

  BatchScratch::Impl& impl = scratch.impl();
  const std::size_t block = settings.block_size;
  // Rounded up without count + block - 1, which wraps for a block_size near
  // SIZE_MAX (then no block ran and every query came back empty, as ok).
  const std::size_t blocks = count / block + (count % block != 0);
  if (impl.blocks.size() < blocks) impl.blocks.resize(blocks);

  // An exception from a query (a user's SupportShape, std::bad_alloc)
  // cancels the parallel loop and leaves it; `out` is then made whole (no
  // contacts, every query failed) before it is rethrown, rather than left
  // with the offsets of the blocks that happened to finish.
  try {
    runQueries(instances, instance_count, queries, count, settings, impl, blocks, out);
  } catch (...) {
    out.contacts.clear();
    std::fill(out.offsets.begin(), out.offsets.end(), 0);
    std::fill(out.status.begin(), out.status.end(),
              Status(ErrorCode::kInvalidShape,
                     "collideBatch: not answered; a query threw an exception (rethrown to the caller)"));
    out.failed = count;
    throw;
  }

  // Offsets: a running sum over the query index (sequential, O(count)).
  for (std::size_t i = 0; i < count; ++i) {
    out.offsets[i + 1] += out.offsets[i];
    out.failed += !out.status[i].isOk();
  }
  out.contacts.resize(out.offsets[count]);

  // Pass 2: each block's contacts to their final place.
  impl.arenaFor(settings.max_threads).execute([&] {
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, blocks, 1),
        [&](const tbb::blocked_range<std::size_t>& range) {
          for (std::size_t b = range.begin(); b != range.end(); ++b)
            std::copy(impl.blocks[b].begin(), impl.blocks[b].end(), out.contacts.begin() + out.offsets[b * block]);
        },
        tbb::simple_partitioner());
  });
  return Status::ok();
}

}  // namespace meshcontact
