#pragma once
// The deep-penetration passes of the support shapes' query (convex.cpp), for
// the tests: the query can run every pass the method defines, as the
// reference that its skipping of passes it has proved void must reproduce.

#include "meshcontact/convex.h"

namespace meshcontact::detail {

/// collideConvexCandidates (convex.h). With `skip_void_passes` (what the
/// library's queries do), a deeper pass that some triangle certainly voids
/// (the core scaled to 1/2 or 1/4 still clearly meets it) is not run; without
/// it, each pass runs until its own narrowphase finds it void.
Status collideConvexCandidates(const SupportShape& shape, const Pose& pose, const CandidateTriangle* candidates,
                               std::size_t count, const QuerySettings& settings, QueryScratch& scratch,
                               std::vector<Contact>& contacts, bool skip_void_passes);

}  // namespace meshcontact::detail
