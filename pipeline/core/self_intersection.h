#pragma once
// Self-intersection detection on a triangle surface network.

#include <cstdint>
#include <utility>
#include <vector>

#include "pipeline/core/surface_network.h"

namespace frontmesh::core {

/// Pairs (f, g), f < g, of faces that intersect other than in what they share by topology:
/// faces sharing an edge intersect when they overlap beyond that edge (a fold onto each
/// other); faces sharing one vertex when they meet anywhere else; other faces when they
/// meet at all. Decisions are exact (core predicates). Sorted; the first `max_pairs` of them
/// returned (0 = all), the same for any thread count. Degenerate (zero-area) faces count as the
/// segment or point they span. Throws InputError for a vertex id out of range or a non-finite
/// coordinate. Cost: O(n log n) typical (bounding volume hierarchy broad phase, TBB-parallel),
/// about 2 s of one core per million faces; the limit bounds the output, not the work.
std::vector<std::pair<std::int32_t, std::int32_t>> self_intersections(const SurfaceNetwork& surface,
                                                                      std::size_t max_pairs = 0);

}  // namespace frontmesh::core
