#pragma once
// What the refine operations' files share (refine_ops.cpp: shapes, costs and node removal;
// refine_smooth.cpp; refine_flips.cpp; refine_slivers.cpp). Internal to the refine stage.

#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>

#include <Eigen/Core>

#include "volume/refine_ops.h"
#include "volume/tet_topology.h"

namespace frontmesh::volume::refine_detail {

using V3 = Eigen::Vector3d;
inline constexpr double kInf = std::numeric_limits<double>::infinity();
inline constexpr double kRegularDihedralDeg = 70.528779365509308;  // arccos(1/3)

/// Fixed pseudo-random offsets in [-1, 1), a deterministic function of `seed` (an element
/// id): the small random searches of smoothing and the sliver pass (splitmix64 finaliser).
class OffsetSequence {
public:
    explicit OffsetSequence(std::int32_t seed)
        : state_(0x9E3779B97F4A7C15ull ^ static_cast<std::uint64_t>(seed) * 0xBF58476D1CE4E5B9ull) {
    }
    double next() {
        state_ ^= state_ >> 33;
        state_ *= 0xff51afd7ed558ccdull;
        state_ ^= state_ >> 33;
        return static_cast<double>(state_ >> 11) / 9007199254740992.0 * 2.0 - 1.0;
    }

private:
    std::uint64_t state_;
};

/// Tets with skewness above 0.8 (the acceptance figure) among `tets` / the tets with ids `ids`.
inline std::size_t over_08(const TetTopology& topo, std::span<const Tet> tets) {
    std::size_t n = 0;
    for (const Tet& t : tets)
        if (tet_shape(topo.xyz(t[0]), topo.xyz(t[1]), topo.xyz(t[2]), topo.xyz(t[3]), false)
                .skewness > 0.8)
            ++n;
    return n;
}
inline std::size_t over_08(const TetTopology& topo, std::span<const std::int32_t> ids) {
    std::size_t n = 0;
    for (const std::int32_t id : ids) {
        const Tet& t = topo.tet(id);
        if (tet_shape(topo.xyz(t[0]), topo.xyz(t[1]), topo.xyz(t[2]), topo.xyz(t[3]), false)
                .skewness > 0.8)
            ++n;
    }
    return n;
}

inline bool tet_positive(const TetTopology& topo, const Tet& t) {
    return positive_tet(topo.xyz(t[0]), topo.xyz(t[1]), topo.xyz(t[2]), topo.xyz(t[3]));
}

}  // namespace frontmesh::volume::refine_detail
