#pragma once
// The support shapes' query (convex.cpp) with its shortcuts off, for the
// tests: the reference that the shortcuts must reproduce bit for bit.

#include "meshcontact/convex.h"

namespace meshcontact::detail {

/// collideConvexCandidates (convex.h). With `shortcuts` (what the library's
/// queries do), a triangle that the core clearly crosses is taken as meeting
/// it without GJK, and a deeper pass that some triangle certainly voids (the
/// scaled core still clearly crosses it) is not run. Without, GJK decides on
/// every triangle a pass reaches and every pass runs until its own
/// narrowphase finds it void: the method as convex.h defines it.
Status collideConvexCandidates(const SupportShape& shape, const Pose& pose, const CandidateTriangle* candidates,
                               std::size_t count, const QuerySettings& settings, QueryScratch& scratch,
                               std::vector<Contact>& contacts, bool shortcuts, CandidateSource* deeper = nullptr);

}  // namespace meshcontact::detail
