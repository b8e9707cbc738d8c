#pragma once
// Internals of the repair stage shared by its source files (issue 19: one concern per file):
//   repair.cpp             the stage: preconditions (step 0), the driver, self-intersections
//                          (step 6) and the final verification (step 7)
//   repair_clean.cpp       step 1: merge points, drop degenerate, duplicate and zero-area faces
//   repair_components.cpp  orientation classes and pieces; step 2: small components
//   repair_orientation.cpp step 3: orient every face outward from its region_in
//   repair_holes.cpp       step 4: trace and fill holes region by region
//   repair_pinches.cpp     step 5: pinch vertices and non-manifold edges
//
// The network stays in flat arrays throughout: it is non-manifold at junctions, and even a
// single region's boundary may carry pinch vertices and non-manifold edges until step 5, which
// OpenMesh cannot represent. Every edit here is local (a flip, a fan of new faces, a vertex
// copy), so a per-face table of edge neighbours seen from each region (Topology) replaces a
// half-edge structure. Memory: about 80 MB per million faces on top of the network (table
// and orientation classes alive together).

#include <array>
#include <cstddef>
#include <cstdint>
#include <iomanip>
#include <numeric>
#include <optional>
#include <span>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "pipeline/core/predicates.h"
#include "pipeline/core/stage_context.h"
#include "pipeline/core/surface_network.h"
#include "surface/repair.h"

namespace frontmesh::surface::repair_detail {

using core::Label;
using core::SurfaceNetwork;
using Tri = std::array<std::int32_t, 3>;

// Codes of Topology::nbr besides a neighbour side id (>= 0).
constexpr std::int32_t k_open = -1;         // the only face of its region on the edge
constexpr std::int32_t k_nonmanifold = -2;  // three or more faces of the region on the edge
constexpr std::int32_t k_no_side = -3;      // the face has no such side (region_out == 0)

// --- small helpers -------------------------------------------------------------------------

inline std::string format_point(const Eigen::Vector3d& p) {
    std::ostringstream s;
    s << std::setprecision(6) << "(" << p.x() << ", " << p.y() << ", " << p.z() << ")";
    return s.str();
}

inline std::string format_number(double v) {
    std::ostringstream s;
    s << std::setprecision(6) << v;
    return s.str();
}

inline std::int32_t to_id(std::size_t i) { return static_cast<std::int32_t>(i); }

inline bool contains(const Tri& t, std::int32_t v) { return t[0] == v || t[1] == v || t[2] == v; }

inline bool has_directed_edge(const Tri& t, std::int32_t a, std::int32_t b) {
    return (t[0] == a && t[1] == b) || (t[1] == a && t[2] == b) || (t[2] == a && t[0] == b);
}

// A face has two sides: side 0 seen from region_in (stored order), side 1 seen from
// region_out (reversed order), the latter only when region_out > 0. Side id = 2 f + s.
inline Label side_region(const SurfaceNetwork& net, std::size_t f, int s) {
    return s == 0 ? net.region_in[f] : net.region_out[f];
}

inline bool has_side(const SurfaceNetwork& net, std::size_t f, int s) {
    return s == 0 || net.region_out[f] != 0;
}

// Vertex cycle of side s of face f, counter-clockwise seen from outside that side's region.
inline Tri side_view(const SurfaceNetwork& net, std::size_t f, int s) {
    const Tri& t = net.faces[f];
    return s == 0 ? t : Tri{t[0], t[2], t[1]};
}

// Stored edge index (edge i joins t[i] and t[i+1]) of edge k of side_view(f, s).
inline int stored_edge(int s, int k) { return s == 0 ? k : 2 - k; }

inline int index_of(const Tri& t, std::int32_t v) { return t[0] == v ? 0 : t[1] == v ? 1 : 2; }

inline bool is_collinear(const SurfaceNetwork& net, const Tri& t) {
    const double* a = &net.xyz[3 * static_cast<std::size_t>(t[0])];
    const double* b = &net.xyz[3 * static_cast<std::size_t>(t[1])];
    const double* c = &net.xyz[3 * static_cast<std::size_t>(t[2])];
    // Three points are collinear exactly when all three coordinate projections are. The
    // projection along the largest normal component goes first: for a face that is not
    // degenerate, the predicate's fast filter settles it there.
    const Eigen::Vector3d normal =
        (Eigen::Map<const Eigen::Vector3d>(b) - Eigen::Map<const Eigen::Vector3d>(a))
            .cross(Eigen::Map<const Eigen::Vector3d>(c) - Eigen::Map<const Eigen::Vector3d>(a));
    int k = 0;
    normal.cwiseAbs().maxCoeff(&k);
    for (int d = 0; d < 3; ++d) {
        const int axis = (k + d) % 3;  // the projection drops `axis`
        if (core::orient2d(a, b, c, (axis + 1) % 3, (axis + 2) % 3) != 0) return false;
    }
    return true;
}

inline double triangle_area(const SurfaceNetwork& net, std::int32_t a, std::int32_t b,
                            std::int32_t c) {
    return 0.5 * (net.point(b) - net.point(a)).cross(net.point(c) - net.point(a)).norm();
}

inline void reverse_face(Tri& t) { std::swap(t[1], t[2]); }

class DisjointSets {
public:
    explicit DisjointSets(std::size_t n) : parent_(n) {
        std::iota(parent_.begin(), parent_.end(), 0);
    }
    std::int32_t find(std::int32_t x) {
        while (parent_[static_cast<std::size_t>(x)] != x) {
            auto& p = parent_[static_cast<std::size_t>(x)];
            p = parent_[static_cast<std::size_t>(p)];
            x = p;
        }
        return x;
    }
    /// The smaller root becomes the root, so roots are the smallest member (deterministic).
    void unite(std::int32_t a, std::int32_t b) {
        a = find(a);
        b = find(b);
        if (a == b) return;
        if (a > b) std::swap(a, b);
        parent_[static_cast<std::size_t>(b)] = a;
    }

private:
    std::vector<std::int32_t> parent_;
};

/// Union-find where each member carries a bit relative to its root (here: "flip this face").
class ParitySets {
public:
    explicit ParitySets(std::size_t n) : parent_(n), parity_(n, 0) {
        std::iota(parent_.begin(), parent_.end(), 0);
    }
    /// Root of x and the parity of x relative to it.
    std::pair<std::int32_t, std::uint8_t> find(std::int32_t x) {
        std::int32_t root = x;
        std::uint8_t p = 0;
        while (parent_[static_cast<std::size_t>(root)] != root) {
            p ^= parity_[static_cast<std::size_t>(root)];
            root = parent_[static_cast<std::size_t>(root)];
        }
        std::uint8_t px = p;
        while (x != root) {  // path compression, keeping each member's parity to the root
            const auto i = static_cast<std::size_t>(x);
            const std::int32_t next = parent_[i];
            const std::uint8_t pnext = px ^ parity_[i];
            parent_[i] = root;
            parity_[i] = px;
            x = next;
            px = pnext;
        }
        return {root, p};
    }
    /// Requires parity(a) xor parity(b) == rel; false when that contradicts earlier unions.
    bool unite(std::int32_t a, std::int32_t b, std::uint8_t rel) {
        auto [ra, pa] = find(a);
        auto [rb, pb] = find(b);
        if (ra == rb) return (pa ^ pb) == rel;
        if (ra > rb) std::swap(ra, rb);
        parent_[static_cast<std::size_t>(rb)] = ra;
        parity_[static_cast<std::size_t>(rb)] = pa ^ pb ^ rel;
        return true;
    }

private:
    std::vector<std::int32_t> parent_;
    std::vector<std::uint8_t> parity_;
};

// --- adjacency -----------------------------------------------------------------------------

/// Faces around each vertex (CSR), in ascending face id.
struct VertexFaces {
    std::vector<std::int32_t> start;
    std::vector<std::int32_t> face;

    explicit VertexFaces(const SurfaceNetwork& net) : start(net.vertex_count() + 1, 0) {
        for (const Tri& t : net.faces)
            for (std::int32_t v : t) ++start[static_cast<std::size_t>(v) + 1];
        std::partial_sum(start.begin(), start.end(), start.begin());
        face.resize(static_cast<std::size_t>(start.back()));
        std::vector<std::int32_t> cursor(start.begin(), start.end() - 1);
        for (std::size_t f = 0; f < net.face_count(); ++f)
            for (std::int32_t v : net.faces[f])
                face[static_cast<std::size_t>(cursor[static_cast<std::size_t>(v)]++)] = to_id(f);
    }
    std::span<const std::int32_t> of(std::int32_t v) const {
        const auto b = static_cast<std::size_t>(start[static_cast<std::size_t>(v)]);
        const auto e = static_cast<std::size_t>(start[static_cast<std::size_t>(v) + 1]);
        return {face.data() + b, e - b};
    }
};

/// Edge neighbours of every face side within its region. Memory: 24 B per face + CSR.
struct Topology {
    VertexFaces vf;
    /// [6 f + 2 i + s]: for stored edge i of face f (t[i] -> t[i+1]) seen from side s, the
    /// other side (2 g + s') of the same region on that edge, or k_open / k_nonmanifold /
    /// k_no_side.
    std::vector<std::int32_t> nbr;

    explicit Topology(const SurfaceNetwork& net) : vf(net), nbr(6 * net.face_count(), k_no_side) {
        std::vector<std::int32_t> others;
        for (std::size_t f = 0; f < net.face_count(); ++f) {
            const Tri& t = net.faces[f];
            for (int i = 0; i < 3; ++i) {
                const std::int32_t a = t[static_cast<std::size_t>(i)];
                const std::int32_t b = t[static_cast<std::size_t>((i + 1) % 3)];
                others.clear();
                for (std::int32_t g : vf.of(a))
                    if (static_cast<std::size_t>(g) != f &&
                        contains(net.faces[static_cast<std::size_t>(g)], b))
                        others.push_back(g);
                for (int s = 0; s < 2; ++s) {
                    if (!has_side(net, f, s)) continue;
                    const Label region = side_region(net, f, s);
                    int count = 1;
                    std::int32_t last = -1;
                    for (std::int32_t g : others)
                        for (int s2 = 0; s2 < 2; ++s2)
                            if (side_region(net, static_cast<std::size_t>(g), s2) == region) {
                                ++count;
                                last = 2 * g + s2;
                            }
                    nbr[6 * f + 2 * static_cast<std::size_t>(i) + static_cast<std::size_t>(s)] =
                        count == 1   ? k_open
                        : count == 2 ? last
                                     : k_nonmanifold;
                }
            }
        }
    }

    std::int32_t at(std::size_t f, int i, int s) const {
        return nbr[6 * f + 2 * static_cast<std::size_t>(i) + static_cast<std::size_t>(s)];
    }
    /// Keeps the table valid after reverse_face(f): stored edges 0 and 2 trade places.
    void reverse(std::size_t f) {
        std::swap(nbr[6 * f + 0], nbr[6 * f + 4]);
        std::swap(nbr[6 * f + 1], nbr[6 * f + 5]);
    }
    /// All sides of `region` on stored edge i of face f, f's own included, ascending.
    std::vector<std::int32_t> edge_sides(const SurfaceNetwork& net, std::size_t f, int i,
                                         Label region) const {
        const Tri& t = net.faces[f];
        const std::int32_t a = t[static_cast<std::size_t>(i)];
        const std::int32_t b = t[static_cast<std::size_t>((i + 1) % 3)];
        std::vector<std::int32_t> sides;
        for (std::int32_t g : vf.of(a)) {
            if (!contains(net.faces[static_cast<std::size_t>(g)], b)) continue;
            for (int s = 0; s < 2; ++s)
                if (side_region(net, static_cast<std::size_t>(g), s) == region)
                    sides.push_back(2 * g + s);
        }
        return sides;
    }
};

// --- network edits -------------------------------------------------------------------------

/// Keeps the faces with keep[f] != 0, in order.
void keep_faces(SurfaceNetwork& net, const std::vector<char>& keep);

/// Drops vertices no face uses; the others keep their order. Returns how many were dropped.
std::size_t compact_vertices(SurfaceNetwork& net);

// --- step 1: merge, degenerate and duplicate faces (repair_clean.cpp) ----------------------

/// Merges points within repair.merge_tolerance_mm, drops collapsed, duplicate and zero-area
/// faces and unused points; counters `repair.*` go to ctx.
void clean_up(SurfaceNetwork& net, const RepairParams& params, core::StageContext& ctx);

// --- orientation analysis (steps 2 and 3; repair_components.cpp) --------------------------

/// A piece: the sides of one region connected through manifold edges of that region.
struct Piece {
    Label region = 0;
    std::size_t sides = 0;
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    Eigen::Vector3d lo = Eigen::Vector3d::Zero(), hi = Eigen::Vector3d::Zero();  // bounding box
    double volume = 0.0;  // seen from the region, with the tentative orientation
    std::int32_t largest_face = -1;
    bool is_open = false;  // has an edge with one, or more than two, faces of the region
};

/// Orientation classes (faces linked by agreement constraints of any region) and pieces.
struct Shells {
    std::vector<std::int32_t> cls;    // per face: root face of its orientation class
    std::vector<std::uint8_t> flip;   // per face: tentative flip relative to the root
    std::vector<std::int32_t> piece;  // per side: piece id, -1 when no side
    std::vector<std::int32_t> piece_start, piece_sides;  // CSR: sides of each piece
    std::vector<Piece> pieces;
    std::size_t conflicts = 0;  // agreement constraints that contradict each other

    /// Orientation sign of a side seen from its region under the tentative flips.
    double sign(std::int32_t side) const {
        const bool reversed = (side & 1) != (flip[static_cast<std::size_t>(side >> 1)] != 0);
        return reversed ? -1.0 : 1.0;
    }
};

/// Orientation classes and pieces of the network under the current table.
Shells analyse(const SurfaceNetwork& net, const Topology& topo);

// --- step 2: small components (repair_components.cpp) -------------------------------------

/// Removes small pieces that tear no interface; returns whether anything was removed.
bool remove_small_components(SurfaceNetwork& net, const Topology& topo, const Shells& sh,
                             const RepairParams& params, core::StageContext& ctx);

// --- step 3: orientation (repair_orientation.cpp) -----------------------------------------

/// Orients every face outward from its region_in (flips faces, keeps `topo` in step).
void orient(SurfaceNetwork& net, Topology& topo, const Shells& sh, core::StageContext& ctx);

// --- step 4: holes (repair_holes.cpp) ------------------------------------------------------

/// Traces and fills the holes of every region; returns whether faces were added.
bool fill_holes(SurfaceNetwork& net, std::optional<Topology>& topo, const RepairParams& params,
                core::StageContext& ctx);

// --- step 5: non-manifold vertices and edges (repair_pinches.cpp) --------------------------

/// A vertex whose faces of one region form several fans (connected through edges at the
/// vertex). Fans after the first get their own copy of the vertex.
struct PinchSplit {
    std::int32_t vertex;
    std::vector<std::vector<std::int32_t>> fans;  // faces; fans[0] keeps the vertex
};

/// Pinch vertices to split (outer boundary); `kept` counts those kept inside the domain.
std::vector<PinchSplit> find_pinches(const SurfaceNetwork& net, const Topology& topo,
                                     std::size_t& kept);

/// Counts edges with more than two faces of one region, once per region and edge.
std::size_t count_nonmanifold_edges(const SurfaceNetwork& net, const Topology& topo);

}  // namespace frontmesh::surface::repair_detail
