#pragma once
// The precondition of the tetra stage on a surface a user hands in (input.surface with
// --from tetra): what the layered front (paper §3.1.2) needs, checked before any work.

#include <string>

#include "pipeline/core/surface_network.h"

namespace frontmesh::core {

/// Throws InputError with one line "SOURCE: <defect>, region R, near (x, y, z) mm" for the
/// first defect found, in this order: a vertex id out of range or a non-finite coordinate;
/// a face whose region_in is not positive or equals its region_out; a face repeating a
/// vertex or of zero area (exact predicate); a region boundary that is open (an edge with an
/// odd number of the region's faces) or misoriented (its faces do not alternate in
/// direction around an edge, or the region encloses a non-positive volume: faces must point
/// out of region_in); a part of a region's boundary turned inside out (core::inverted_parts);
/// two faces that intersect (core::self_intersections). Even numbers of
/// faces around an edge are accepted (2^q, §3: regions touching along an edge).
/// Cost: O(n log n), dominated by the self-intersection search (about 2 s per million faces).
void require_meshable_surface(const SurfaceNetwork& surface, const std::string& source);

}  // namespace frontmesh::core
