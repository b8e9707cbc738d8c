#pragma once
// Morton (Z-order) codes: grid cells in 3-D mapped to integers whose order keeps most
// neighbouring cells close together. Used to sort faces spatially (self_intersection's BVH)
// and to visit tetra's bases in a cache-friendly order.

#include <cstdint>

namespace frontmesh::core {

/// Spreads the low 21 bits of v to every third bit (bit i to bit 3 i); the code of cell
/// (x, y, z) is spread(x) | spread(y) << 1 | spread(z) << 2.
inline std::uint64_t morton_spread21(std::uint64_t v) {
    v &= 0x1fffffULL;
    v = (v | v << 32) & 0x1f00000000ffffULL;
    v = (v | v << 16) & 0x1f0000ff0000ffULL;
    v = (v | v << 8) & 0x100f00f00f00f00fULL;
    v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
    v = (v | v << 2) & 0x1249249249249249ULL;
    return v;
}

}  // namespace frontmesh::core
