#pragma once
// gap_distance_warm for a pair the caller has already proved disjoint (e.g. by a separating
// plane): the same warm-started solve without the libccd overlap test, the most expensive part
// of a warm call. Calling it on an overlapping pair is a caller error (Λ would still be ≥ 0).
#include "distlab/gap/distance.hpp"

namespace distlab {

GapResult gap_distance_warm_disjoint(const GapBody& a, const GapBody& b, const GapParams& params,
                                     const Vec3& start_a, const Vec3& start_b);

}  // namespace distlab
