#include "surface/repair.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <iomanip>
#include <limits>
#include <numbers>
#include <numeric>
#include <optional>
#include <set>
#include <span>
#include <sstream>
#include <string>
#include <tuple>
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "pipeline/core/error.h"
#include "pipeline/core/predicates.h"
#include "pipeline/core/self_intersection.h"

// The network stays in flat arrays throughout: it is non-manifold at junctions, and even a
// single region's boundary may carry pinch vertices and non-manifold edges until step 5, which
// OpenMesh cannot represent. Every edit here is local (a flip, a fan of new faces, a vertex
// copy), so a per-face table of edge neighbours seen from each region (Topology) replaces a
// half-edge structure. Memory: about 80 MB per million faces on top of the network (table
// and orientation classes alive together).

namespace frontmesh::surface {
namespace {

using core::Label;
using core::SurfaceNetwork;
using Tri = std::array<std::int32_t, 3>;

// Codes of Topology::nbr besides a neighbour side id (>= 0).
constexpr std::int32_t k_open = -1;         // the only face of its region on the edge
constexpr std::int32_t k_nonmanifold = -2;  // three or more faces of the region on the edge
constexpr std::int32_t k_no_side = -3;      // the face has no such side (region_out == 0)

// --- small helpers -------------------------------------------------------------------------

std::string format_point(const Eigen::Vector3d& p) {
    std::ostringstream s;
    s << std::setprecision(6) << "(" << p.x() << ", " << p.y() << ", " << p.z() << ")";
    return s.str();
}

std::string format_number(double v) {
    std::ostringstream s;
    s << std::setprecision(6) << v;
    return s.str();
}

std::int32_t to_id(std::size_t i) { return static_cast<std::int32_t>(i); }

bool contains(const Tri& t, std::int32_t v) { return t[0] == v || t[1] == v || t[2] == v; }

bool has_directed_edge(const Tri& t, std::int32_t a, std::int32_t b) {
    return (t[0] == a && t[1] == b) || (t[1] == a && t[2] == b) || (t[2] == a && t[0] == b);
}

// A face has two sides: side 0 seen from region_in (stored order), side 1 seen from
// region_out (reversed order), the latter only when region_out > 0. Side id = 2 f + s.
Label side_region(const SurfaceNetwork& net, std::size_t f, int s) {
    return s == 0 ? net.region_in[f] : net.region_out[f];
}

bool has_side(const SurfaceNetwork& net, std::size_t f, int s) {
    return s == 0 || net.region_out[f] != 0;
}

// Vertex cycle of side s of face f, counter-clockwise seen from outside that side's region.
Tri side_view(const SurfaceNetwork& net, std::size_t f, int s) {
    const Tri& t = net.faces[f];
    return s == 0 ? t : Tri{t[0], t[2], t[1]};
}

// Stored edge index (edge i joins t[i] and t[i+1]) of edge k of side_view(f, s).
int stored_edge(int s, int k) { return s == 0 ? k : 2 - k; }

int index_of(const Tri& t, std::int32_t v) { return t[0] == v ? 0 : t[1] == v ? 1 : 2; }

bool is_collinear(const SurfaceNetwork& net, const Tri& t) {
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

double triangle_area(const SurfaceNetwork& net, std::int32_t a, std::int32_t b, std::int32_t c) {
    return 0.5 * (net.point(b) - net.point(a)).cross(net.point(c) - net.point(a)).norm();
}

void reverse_face(Tri& t) { std::swap(t[1], t[2]); }

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
void keep_faces(SurfaceNetwork& net, const std::vector<char>& keep) {
    std::size_t n = 0;
    for (std::size_t f = 0; f < net.face_count(); ++f) {
        if (!keep[f]) continue;
        net.faces[n] = net.faces[f];
        net.region_in[n] = net.region_in[f];
        net.region_out[n] = net.region_out[f];
        ++n;
    }
    net.faces.resize(n);
    net.region_in.resize(n);
    net.region_out.resize(n);
}

/// Drops vertices no face uses; the others keep their order. Returns how many were dropped.
std::size_t compact_vertices(SurfaceNetwork& net) {
    std::vector<std::int32_t> new_id(net.vertex_count(), -1);
    for (const Tri& t : net.faces)
        for (std::int32_t v : t) new_id[static_cast<std::size_t>(v)] = 0;
    std::size_t n = 0;
    for (std::size_t v = 0; v < new_id.size(); ++v) {
        if (new_id[v] < 0) continue;
        new_id[v] = to_id(n);
        for (std::size_t k = 0; k < 3; ++k) net.xyz[3 * n + k] = net.xyz[3 * v + k];
        ++n;
    }
    const std::size_t dropped = net.vertex_count() - n;
    net.xyz.resize(3 * n);
    for (Tri& t : net.faces)
        for (std::int32_t& v : t) v = new_id[static_cast<std::size_t>(v)];
    return dropped;
}

// --- step 0: preconditions -----------------------------------------------------------------

void check_input(const SurfaceNetwork& net) {
    if (net.xyz.size() % 3 != 0)
        FM_THROW(InputError, "repair: input network has " + std::to_string(net.xyz.size()) +
                                 " coordinates, not a multiple of 3");
    if (net.region_in.size() != net.face_count() || net.region_out.size() != net.face_count())
        FM_THROW(InputError, "repair: input network has " + std::to_string(net.face_count()) +
                                 " faces but " + std::to_string(net.region_in.size()) +
                                 " region_in and " + std::to_string(net.region_out.size()) +
                                 " region_out labels");
    if (net.face_count() == 0) FM_THROW(InputError, "repair: input network has no faces");
    if (net.face_count() >= static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max() / 6))
        FM_THROW(InputError, "repair: input network has too many faces (" +
                                 std::to_string(net.face_count()) + ")");
    for (std::size_t i = 0; i < net.xyz.size(); ++i)
        if (!std::isfinite(net.xyz[i]))
            FM_THROW(InputError,
                     "repair: vertex " + std::to_string(i / 3) + " has a non-finite coordinate");
    const auto nv = static_cast<std::int64_t>(net.vertex_count());
    for (std::size_t f = 0; f < net.face_count(); ++f) {
        for (std::int32_t v : net.faces[f])
            if (v < 0 || v >= nv)
                FM_THROW(InputError, "repair: face " + std::to_string(f) + " refers to vertex " +
                                         std::to_string(v) + " but the network has " +
                                         std::to_string(nv) + " vertices");
        const Label in = net.region_in[f], out = net.region_out[f];
        if (in <= 0 || out < 0 || in == out)
            FM_THROW(InputError, "repair: face " + std::to_string(f) + " has region_in " +
                                     std::to_string(in) + " and region_out " + std::to_string(out) +
                                     " (need region_in > 0, region_out >= 0, different)");
    }
}

// --- step 1: merge, degenerate and duplicate faces -----------------------------------------

/// For each vertex the lowest-id vertex within `tol` mm that it merges into (itself if none).
/// Points are taken in id order; each is compared with the earlier kept points in the grid
/// cells its tolerance box overlaps (cells of side 8 tol: usually one or two). The cells live
/// in an open-addressing table (16 B per point) holding the newest kept point of the cell
/// (keys are recomputed from that point), older ones chained through `next_in_cell`.
std::vector<std::int32_t> merge_targets(const SurfaceNetwork& net, double tol) {
    const std::size_t n = net.vertex_count();
    std::vector<std::int32_t> target(n);
    std::iota(target.begin(), target.end(), 0);
    if (n == 0) return target;
    Eigen::Vector3d lo = net.point(0), hi = net.point(0);
    for (std::size_t v = 1; v < n; ++v) {
        lo = lo.cwiseMin(net.point(to_id(v)));
        hi = hi.cwiseMax(net.point(to_id(v)));
    }
    const double h = 8.0 * tol;
    if (tol == 0.0 || (hi - lo).maxCoeff() / h > 0x1p50) {
        // Exact coincidence only (tolerance below the coordinates' resolution).
        std::vector<std::int32_t> order(n);
        std::iota(order.begin(), order.end(), 0);
        auto less = [&](std::int32_t a, std::int32_t b) {
            const auto pa = net.point(a), pb = net.point(b);
            for (int k = 0; k < 3; ++k)
                if (pa[k] != pb[k]) return pa[k] < pb[k];
            return a < b;
        };
        std::sort(order.begin(), order.end(), less);
        for (std::size_t i = 1; i < n; ++i)
            if (net.point(order[i]) == net.point(order[i - 1]))
                target[static_cast<std::size_t>(order[i])] =
                    target[static_cast<std::size_t>(order[i - 1])];
        return target;
    }
    using Cell = std::array<std::int64_t, 3>;
    auto cell_index = [&](double x, int k) {
        return static_cast<std::int64_t>(std::floor((x - lo[k]) / h));
    };
    auto cell_of = [&](std::int32_t v) {
        const auto p = net.point(v);
        return Cell{cell_index(p[0], 0), cell_index(p[1], 1), cell_index(p[2], 2)};
    };
    std::size_t capacity = 16;
    while (capacity < 2 * n) capacity *= 2;
    const std::size_t mask = capacity - 1;
    struct Slot {
        std::int32_t head = -1;  // newest kept point of the cell
        std::uint32_t tag = 0;   // high hash bits, so that most probes need not load a point
    };
    std::vector<Slot> table(capacity);
    auto slot_of = [&](const Cell& c) {
        std::uint64_t k = static_cast<std::uint64_t>(c[0]) * 0x9E3779B97F4A7C15ull;
        k ^= static_cast<std::uint64_t>(c[1]) * 0xC2B2AE3D27D4EB4Full;
        k ^= static_cast<std::uint64_t>(c[2]) * 0x165667B19E3779F9ull;
        k ^= k >> 31;
        const auto tag = static_cast<std::uint32_t>(k >> 32);
        std::size_t i = static_cast<std::size_t>(k) & mask;
        while (table[i].head >= 0 && (table[i].tag != tag || cell_of(table[i].head) != c))
            i = (i + 1) & mask;
        table[i].tag = tag;  // harmless on an empty slot that stays empty
        return i;
    };
    std::vector<std::int32_t> next_in_cell(n, -1);
    const double tol2 = tol * tol;
    for (std::size_t i = 0; i < n; ++i) {
        const Eigen::Vector3d p = net.point(to_id(i));
        Cell c0, c1;
        for (int k = 0; k < 3; ++k) {
            c0[static_cast<std::size_t>(k)] = cell_index(p[k] - tol, k);
            c1[static_cast<std::size_t>(k)] = cell_index(p[k] + tol, k);
        }
        std::int32_t best = -1;
        for (std::int64_t x = c0[0]; x <= c1[0]; ++x)
            for (std::int64_t y = c0[1]; y <= c1[1]; ++y)
                for (std::int64_t z = c0[2]; z <= c1[2]; ++z)
                    for (std::int32_t r = table[slot_of({x, y, z})].head; r >= 0;
                         r = next_in_cell[static_cast<std::size_t>(r)])
                        if ((best < 0 || r < best) && (net.point(r) - p).squaredNorm() <= tol2)
                            best = r;
        if (best >= 0) {
            target[i] = best;
            continue;
        }
        const std::size_t slot = slot_of(cell_of(to_id(i)));
        next_in_cell[i] = table[slot].head;
        table[slot].head = to_id(i);
    }
    return target;
}

struct DuplicateCounts {
    std::size_t duplicates = 0;   // same-orientation copies dropped
    std::size_t cancelled = 0;    // opposite copies dropped in pairs
    std::size_t conflicting = 0;  // vertex sets carried by faces of different region pairs
};

/// Marks duplicate faces (same vertex set and region pair) in `keep`. A face's sense is
/// taken relative to its smaller label; copies of opposite sense cancel in pairs, and of
/// what is left one face (the lowest id) stays.
DuplicateCounts mark_duplicates(const SurfaceNetwork& net, std::vector<char>& keep) {
    struct Key {
        Tri v;
        Label lo, hi;
        std::int8_t sense;
        std::int32_t face;
    };
    std::vector<Key> keys;
    keys.reserve(net.face_count());
    for (std::size_t f = 0; f < net.face_count(); ++f) {
        if (!keep[f]) continue;
        const Tri& t = net.faces[f];
        Tri v = t;
        std::sort(v.begin(), v.end());
        const int k = index_of(t, v[0]);
        std::int8_t sense = t[static_cast<std::size_t>((k + 1) % 3)] == v[1] ? 1 : -1;
        const Label in = net.region_in[f], out = net.region_out[f];
        if (in > out) sense = static_cast<std::int8_t>(-sense);
        keys.push_back({v, std::min(in, out), std::max(in, out), sense, to_id(f)});
    }
    auto same_set = [](const Key& a, const Key& b) {
        return a.v[0] == b.v[0] && a.v[1] == b.v[1] && a.v[2] == b.v[2];
    };
    auto same_group = [&](const Key& a, const Key& b) {
        return same_set(a, b) && a.lo == b.lo && a.hi == b.hi;
    };
    std::sort(keys.begin(), keys.end(), [](const Key& a, const Key& b) {
        return std::tie(a.v[0], a.v[1], a.v[2], a.lo, a.hi, a.face) <
               std::tie(b.v[0], b.v[1], b.v[2], b.lo, b.hi, b.face);
    });
    DuplicateCounts counts;
    std::size_t set_begin = 0, survivors_in_set = 0;
    for (std::size_t i = 0; i < keys.size();) {
        std::size_t j = i;
        std::size_t plus = 0, minus = 0;
        std::int32_t first_plus = -1, first_minus = -1;
        for (; j < keys.size() && same_group(keys[i], keys[j]); ++j) {
            if (keys[j].sense > 0) {
                if (plus++ == 0) first_plus = keys[j].face;
            } else if (minus++ == 0) {
                first_minus = keys[j].face;
            }
        }
        if (!same_set(keys[set_begin], keys[i])) {
            set_begin = i;
            survivors_in_set = 0;
        }
        if (j - i > 1) {
            for (std::size_t k = i; k < j; ++k) keep[static_cast<std::size_t>(keys[k].face)] = 0;
            const std::int32_t survivor = plus > minus   ? first_plus
                                          : minus > plus ? first_minus
                                                         : -1;
            if (survivor >= 0) keep[static_cast<std::size_t>(survivor)] = 1;
            counts.cancelled += 2 * std::min(plus, minus);
            if (plus != minus)
                counts.duplicates += std::max(plus, minus) - std::min(plus, minus) - 1;
        }
        if (plus != minus && ++survivors_in_set == 2) ++counts.conflicting;
        i = j;
    }
    return counts;
}

/// The vertices of a collinear face ordered (end, middle, end) along their line.
Tri order_along_line(const SurfaceNetwork& net, const Tri& t) {
    int axis = 0;
    double best = -1.0;
    for (int k = 0; k < 3; ++k) {
        double lo = net.point(t[0])[k], hi = lo;
        for (std::int32_t v : t) {
            lo = std::min(lo, net.point(v)[k]);
            hi = std::max(hi, net.point(v)[k]);
        }
        if (hi - lo > best) {
            best = hi - lo;
            axis = k;
        }
    }
    Tri s = t;
    std::sort(s.begin(), s.end(), [&](std::int32_t a, std::int32_t b) {
        return net.point(a)[axis] < net.point(b)[axis];
    });
    return s;
}

struct SliverCounts {
    std::size_t removed = 0;  // zero-area faces dropped
    std::size_t split = 0;    // faces split at the middle vertex of a dropped face
};

/// Drops faces of zero area (three distinct, exactly collinear points p, m, q with m between).
/// Such a face closes a T-junction: the faces on its long edge (p, q) are split at m, so the
/// surface stays closed. Marks dropped faces in `keep` and appends the split halves.
SliverCounts remove_slivers(SurfaceNetwork& net, std::vector<char>& keep) {
    SliverCounts counts;
    std::vector<char> sliver(net.face_count(), 0);
    std::vector<std::int32_t> slivers;
    for (std::size_t f = 0; f < net.face_count(); ++f)
        if (keep[f] && is_collinear(net, net.faces[f])) {
            sliver[f] = 1;
            slivers.push_back(to_id(f));
        }
    if (slivers.empty()) return counts;
    const VertexFaces vf(net);
    std::unordered_map<std::int32_t, std::vector<std::int32_t>> added;  // incidences of new faces
    auto faces_at = [&](std::int32_t v) {
        std::vector<std::int32_t> r(vf.of(v).begin(), vf.of(v).end());
        if (const auto it = added.find(v); it != added.end())
            r.insert(r.end(), it->second.begin(), it->second.end());
        std::sort(r.begin(), r.end());
        r.erase(std::unique(r.begin(), r.end()), r.end());
        return r;
    };
    for (std::int32_t z : slivers) {
        const auto zi = static_cast<std::size_t>(z);
        if (!keep[zi]) continue;
        const Tri line = order_along_line(net, net.faces[zi]);
        const std::int32_t p = line[0], m = line[1], q = line[2];
        keep[zi] = 0;
        ++counts.removed;
        for (std::int32_t g : faces_at(p)) {
            const auto gi = static_cast<std::size_t>(g);
            if (!keep[gi] || sliver[gi] || !contains(net.faces[gi], q) ||
                contains(net.faces[gi], m))
                continue;
            const Tri t = net.faces[gi];
            const int i = has_directed_edge(t, p, q) ? index_of(t, p) : index_of(t, q);
            const std::int32_t x = t[static_cast<std::size_t>(i)];
            const std::int32_t y = t[static_cast<std::size_t>((i + 1) % 3)];
            const std::int32_t r = t[static_cast<std::size_t>((i + 2) % 3)];
            net.faces[gi] = {x, m, r};
            net.add_face(m, y, r, net.region_in[gi], net.region_out[gi]);
            keep.push_back(1);
            sliver.push_back(0);
            const std::int32_t h = to_id(net.face_count() - 1);
            for (std::int32_t v : {m, y, r}) added[v].push_back(h);
            added[m].push_back(g);
            ++counts.split;
        }
    }
    return counts;
}

void clean_up(SurfaceNetwork& net, const RepairParams& params, core::StageContext& ctx) {
    const std::vector<std::int32_t> target = merge_targets(net, params.merge_tolerance_mm);
    std::size_t merged = 0;
    for (std::size_t v = 0; v < target.size(); ++v) merged += target[v] != to_id(v);
    std::vector<char> keep(net.face_count(), 1);
    std::size_t collapsed = 0;
    for (std::size_t f = 0; f < net.face_count(); ++f) {
        Tri& t = net.faces[f];
        for (std::int32_t& v : t) v = target[static_cast<std::size_t>(v)];
        if (t[0] == t[1] || t[1] == t[2] || t[2] == t[0]) {
            keep[f] = 0;
            ++collapsed;
        }
    }
    const DuplicateCounts dup = mark_duplicates(net, keep);
    const SliverCounts sliver = remove_slivers(net, keep);
    keep_faces(net, keep);
    const std::size_t unused = compact_vertices(net) - merged;
    ctx.count("repair.merged_points", static_cast<double>(merged));
    ctx.count("repair.unused_points", static_cast<double>(unused));
    ctx.count("repair.collapsed_faces", static_cast<double>(collapsed));
    ctx.count("repair.duplicate_faces", static_cast<double>(dup.duplicates));
    ctx.count("repair.cancelled_faces", static_cast<double>(dup.cancelled));
    ctx.count("repair.zero_area_faces", static_cast<double>(sliver.removed));
    ctx.count("repair.split_faces", static_cast<double>(sliver.split));
    ctx.info("repair: merged " + std::to_string(merged) + " points, dropped " +
             std::to_string(collapsed) + " collapsed, " + std::to_string(sliver.removed) +
             " zero-area (" + std::to_string(sliver.split) + " neighbours split), " +
             std::to_string(dup.duplicates) + " duplicate and " + std::to_string(dup.cancelled) +
             " cancelling faces, " + std::to_string(unused) + " unused points");
    if (dup.conflicting > 0)
        ctx.warn("repair: " + std::to_string(dup.conflicting) +
                 " triangles carry two different region pairs; kept");
    ctx.count("repair.conflicting_faces", static_cast<double>(dup.conflicting));
}

// --- orientation analysis (steps 2 and 3) --------------------------------------------------

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

Shells analyse(const SurfaceNetwork& net, const Topology& topo) {
    const std::size_t nf = net.face_count();
    Shells sh;
    ParitySets parity(nf);
    DisjointSets sub(2 * nf);
    for (std::size_t f = 0; f < nf; ++f) {
        const Tri& t = net.faces[f];
        for (int i = 0; i < 3; ++i)
            for (int s = 0; s < 2; ++s) {
                const std::int32_t other = topo.at(f, i, s);
                const auto side = static_cast<std::int32_t>(2 * f) + s;
                if (other < side) continue;  // codes are negative; each pair once
                const std::int32_t g = other >> 1;
                const int s2 = other & 1;
                const std::int32_t a = t[static_cast<std::size_t>(i)];
                const std::int32_t b = t[static_cast<std::size_t>((i + 1) % 3)];
                // Directions of a -> b as each side sees it; agreeing sides run opposite.
                const int df = s == 0 ? 1 : -1;
                const int dg =
                    (has_directed_edge(net.faces[static_cast<std::size_t>(g)], a, b) ? 1 : -1) *
                    (s2 == 0 ? 1 : -1);
                if (!parity.unite(to_id(f), g, df == dg ? 1 : 0)) ++sh.conflicts;
                sub.unite(side, other);
            }
    }
    sh.cls.resize(nf);
    sh.flip.resize(nf);
    for (std::size_t f = 0; f < nf; ++f) {
        const auto [root, p] = parity.find(to_id(f));
        sh.cls[f] = root;
        sh.flip[f] = p;
    }
    // Dense piece ids in order of their smallest side.
    std::vector<std::int32_t> dense(2 * nf, -1);
    sh.piece.assign(2 * nf, -1);
    for (std::size_t side = 0; side < 2 * nf; ++side) {
        if (!has_side(net, side / 2, static_cast<int>(side % 2))) continue;
        const auto root = static_cast<std::size_t>(sub.find(to_id(side)));
        if (dense[root] < 0) {
            dense[root] = to_id(sh.pieces.size());
            sh.pieces.push_back({});
            sh.pieces.back().region = side_region(net, side / 2, static_cast<int>(side % 2));
        }
        sh.piece[side] = dense[root];
    }
    const std::size_t np = sh.pieces.size();
    sh.piece_start.assign(np + 1, 0);
    for (std::int32_t p : sh.piece)
        if (p >= 0) ++sh.piece_start[static_cast<std::size_t>(p) + 1];
    std::partial_sum(sh.piece_start.begin(), sh.piece_start.end(), sh.piece_start.begin());
    sh.piece_sides.resize(static_cast<std::size_t>(sh.piece_start.back()));
    std::vector<std::int32_t> cursor(sh.piece_start.begin(), sh.piece_start.end() - 1);
    for (std::size_t side = 0; side < 2 * nf; ++side)
        if (const std::int32_t p = sh.piece[side]; p >= 0)
            sh.piece_sides[static_cast<std::size_t>(cursor[static_cast<std::size_t>(p)]++)] =
                to_id(side);
    for (std::size_t p = 0; p < np; ++p) {
        Piece& piece = sh.pieces[p];
        const auto b = static_cast<std::size_t>(sh.piece_start[p]);
        const auto e = static_cast<std::size_t>(sh.piece_start[p + 1]);
        piece.sides = e - b;
        piece.lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
        piece.hi = -piece.lo;
        double largest = -1.0;
        for (std::size_t k = b; k < e; ++k) {
            const std::size_t f = static_cast<std::size_t>(sh.piece_sides[k]) / 2;
            const int s = sh.piece_sides[k] % 2;
            for (int i = 0; i < 3; ++i) piece.is_open = piece.is_open || topo.at(f, i, s) < 0;
            const Tri& t = net.faces[f];
            for (std::int32_t v : t) {
                piece.centroid += net.point(v) / 3.0;
                piece.lo = piece.lo.cwiseMin(net.point(v));
                piece.hi = piece.hi.cwiseMax(net.point(v));
            }
            const double area = triangle_area(net, t[0], t[1], t[2]);
            if (area > largest) {
                largest = area;
                piece.largest_face = to_id(f);
            }
        }
        piece.centroid /= static_cast<double>(piece.sides);
        // Relative to the centroid, so that open pieces get a meaningful volume too.
        double six_v = 0.0;
        for (std::size_t k = b; k < e; ++k) {
            const std::int32_t side = sh.piece_sides[k];
            const Tri& t = net.faces[static_cast<std::size_t>(side) / 2];
            const Eigen::Vector3d a = net.point(t[0]) - piece.centroid;
            six_v +=
                sh.sign(side) *
                a.dot((net.point(t[1]) - piece.centroid).cross(net.point(t[2]) - piece.centroid));
        }
        piece.volume = six_v / 6.0;
    }
    return sh;
}

// --- step 2: small components --------------------------------------------------------------

/// Removes pieces of a region's boundary (faces connected through any of its edges) whose
/// |volume| is below the minimum or which have too few faces; a piece goes only if each of
/// its interface faces also lies in a removable piece of the other region. Returns whether
/// anything was removed.
bool remove_small_components(SurfaceNetwork& net, const Topology& topo, const Shells& sh,
                             const RepairParams& params, core::StageContext& ctx) {
    const std::size_t np = sh.pieces.size();
    DisjointSets component(np);  // pieces joined through non-manifold edges
    for (std::size_t f = 0; f < net.face_count(); ++f)
        for (int i = 0; i < 3; ++i)
            for (int s = 0; s < 2; ++s)
                if (topo.at(f, i, s) == k_nonmanifold)
                    for (std::int32_t side : topo.edge_sides(net, f, i, side_region(net, f, s)))
                        component.unite(sh.piece[2 * f + static_cast<std::size_t>(s)],
                                        sh.piece[static_cast<std::size_t>(side)]);
    std::vector<double> volume(np, 0.0);
    std::vector<std::size_t> faces(np, 0);
    for (std::size_t p = 0; p < np; ++p) {
        const auto c = static_cast<std::size_t>(component.find(to_id(p)));
        volume[c] += std::abs(sh.pieces[p].volume);
        faces[c] += sh.pieces[p].sides;
    }
    std::vector<char> removable(np, 0);
    for (std::size_t p = 0; p < np; ++p)
        if (component.find(to_id(p)) == to_id(p))
            removable[p] = volume[p] < params.min_component_volume_mm3 ||
                           faces[p] < params.min_component_faces;
    if (std::none_of(removable.begin(), removable.end(), [](char r) { return r != 0; })) {
        ctx.count("repair.removed_components", 0);
        ctx.count("repair.removed_component_faces", 0);
        ctx.count("repair.removed_component_volume_mm3", 0);
        ctx.info("repair: no small components");
        return false;
    }
    const auto small = static_cast<std::size_t>(std::count(removable.begin(), removable.end(), 1));
    auto comp_of_side = [&](std::size_t side) {
        return static_cast<std::size_t>(component.find(sh.piece[side]));
    };
    // Don't tear an interface: a component stays when one of its interface faces lies in a
    // component of the other region that stays. Repeat until nothing changes.
    for (bool changed = true; changed;) {
        changed = false;
        for (std::size_t f = 0; f < net.face_count(); ++f) {
            if (net.region_out[f] == 0) continue;
            const std::size_t a = comp_of_side(2 * f), b = comp_of_side(2 * f + 1);
            if (removable[a] != removable[b]) {
                removable[a] = removable[b] = 0;
                changed = true;
            }
        }
    }
    std::vector<char> keep(net.face_count(), 1);
    std::size_t removed_faces = 0;
    for (std::size_t f = 0; f < net.face_count(); ++f)
        if (removable[comp_of_side(2 * f)]) {
            keep[f] = 0;
            ++removed_faces;
        }
    std::size_t removed = 0;
    double removed_volume = 0.0;
    for (std::size_t p = 0; p < np; ++p)
        if (removable[p]) {
            ++removed;
            removed_volume += volume[p];
        }
    ctx.count("repair.removed_components", static_cast<double>(removed));
    ctx.count("repair.removed_component_faces", static_cast<double>(removed_faces));
    ctx.count("repair.removed_component_volume_mm3", removed_volume);
    ctx.info("repair: removed " + std::to_string(removed) + " small components (" +
             std::to_string(removed_faces) + " faces, " + format_number(removed_volume) +
             " mm^3 summed over the regions' pieces); kept " + std::to_string(small - removed) +
             " small ones sharing an interface with a larger piece");
    if (removed_faces == 0) return false;
    keep_faces(net, keep);
    compact_vertices(net);
    return true;
}

// --- step 3: orientation -------------------------------------------------------------------

/// Generalised winding number of a piece (oriented by the tentative flips) around x:
/// the sum of the signed solid angles of its triangles over 4 pi (Van Oosterom-Strackee).
double winding_number(const SurfaceNetwork& net, const Shells& sh, std::size_t piece,
                      const Eigen::Vector3d& x) {
    double omega = 0.0;
    for (auto k = static_cast<std::size_t>(sh.piece_start[piece]);
         k < static_cast<std::size_t>(sh.piece_start[piece + 1]); ++k) {
        const std::int32_t side = sh.piece_sides[k];
        const Tri& t = net.faces[static_cast<std::size_t>(side) / 2];
        const Eigen::Vector3d a = net.point(t[0]) - x;
        Eigen::Vector3d b = net.point(t[1]) - x, c = net.point(t[2]) - x;
        if (sh.sign(side) < 0) std::swap(b, c);
        const double la = a.norm(), lb = b.norm(), lc = c.norm();
        const double num = a.dot(b.cross(c));
        const double den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
        omega += 2.0 * std::atan2(num, den);
    }
    return omega / (4.0 * std::numbers::pi);
}

/// Whether the closed piece encloses x, by the parity of its faces crossed by a ray from x.
/// Exact (orient3d); a ray that touches an edge or a vertex is cast again in another
/// direction. Nullopt when every direction tried touches one. Cost: a few ns per face.
std::optional<bool> ray_parity_encloses(const SurfaceNetwork& net, const Shells& sh,
                                        std::size_t piece, const Eigen::Vector3d& x) {
    const Piece& q = sh.pieces[piece];
    static constexpr double k_slopes[][2] = {{0.0123456789, 0.0234567891},
                                             {-0.0345678912, 0.0156789123},
                                             {0.0267891234, -0.0378912345},
                                             {-0.0189123456, -0.0291234567}};
    for (const auto& slope : k_slopes) {
        const double length = (q.hi.x() - x.x()) + 1.0 + (q.hi - q.lo).norm();
        const Eigen::Vector3d far = x + length * Eigen::Vector3d(1.0, slope[0], slope[1]);
        const Eigen::Vector3d lo = x.cwiseMin(far), hi = x.cwiseMax(far);
        std::size_t crossings = 0;
        bool touched = false;
        for (auto k = static_cast<std::size_t>(sh.piece_start[piece]);
             k < static_cast<std::size_t>(sh.piece_start[piece + 1]) && !touched; ++k) {
            const Tri& t = net.faces[static_cast<std::size_t>(sh.piece_sides[k]) / 2];
            const auto a = net.point(t[0]), b = net.point(t[1]), c = net.point(t[2]);
            bool outside = false;
            for (int d = 0; d < 3 && !outside; ++d)
                outside =
                    std::max({a[d], b[d], c[d]}) < lo[d] || std::min({a[d], b[d], c[d]}) > hi[d];
            if (outside) continue;
            const int sx = core::orient3d(a.data(), b.data(), c.data(), x.data());
            const int sf = core::orient3d(a.data(), b.data(), c.data(), far.data());
            if (sx * sf > 0) continue;  // both ends on one side of the face's plane
            const int s1 = core::orient3d(x.data(), far.data(), a.data(), b.data());
            const int s2 = core::orient3d(x.data(), far.data(), b.data(), c.data());
            const int s3 = core::orient3d(x.data(), far.data(), c.data(), a.data());
            const bool all_pos = s1 >= 0 && s2 >= 0 && s3 >= 0;
            const bool all_neg = s1 <= 0 && s2 <= 0 && s3 <= 0;
            if (!all_pos && !all_neg) continue;  // the line misses the triangle
            if (sx == 0 || sf == 0 || s1 == 0 || s2 == 0 || s3 == 0)
                touched = true;
            else
                ++crossings;
        }
        if (!touched) return crossings % 2 == 1;
    }
    return std::nullopt;
}

/// Orients every face outward from its region_in. Rule: within an orientation class (faces
/// tied by edge agreement within any region; an interface face ties its two regions'
/// pieces together) one flip bit per face is fixed by the constraints; the class's overall
/// sense is chosen by its pieces. A piece of region R enclosed by an even number of R's
/// other pieces is an outer shell of R and must enclose positive volume seen from R; by an
/// odd number it bounds a cavity of R (an inner shell, e.g. a hollow region's inside wall
/// labelled R|0) and must enclose negative volume. Each piece votes with its |volume|.
/// Labels are never changed; faces are flipped (vertex order reversed).
void orient(SurfaceNetwork& net, Topology& topo, const Shells& sh, core::StageContext& ctx) {
    const std::size_t np = sh.pieces.size();
    std::vector<std::vector<std::size_t>> by_region;  // piece ids grouped by region, in order
    {
        std::vector<std::size_t> order(np);
        std::iota(order.begin(), order.end(), 0);
        std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
            return sh.pieces[a].region < sh.pieces[b].region;
        });
        for (std::size_t k = 0; k < np; ++k) {
            if (k == 0 || sh.pieces[order[k]].region != sh.pieces[order[k - 1]].region)
                by_region.emplace_back();
            by_region.back().push_back(order[k]);
        }
    }
    std::vector<int> wanted(np, 1);  // +1 outer shell, -1 inner shell
    for (const auto& group : by_region) {
        if (group.size() < 2) continue;
        for (std::size_t p : group) {
            const Piece& a = sh.pieces[p];
            const Tri& t = net.faces[static_cast<std::size_t>(a.largest_face)];
            const Eigen::Vector3d x = (net.point(t[0]) + net.point(t[1]) + net.point(t[2])) / 3.0;
            int enclosing = 0;
            for (std::size_t q : group) {
                const Piece& b = sh.pieces[q];
                if (q == p || (b.lo.array() > a.lo.array()).any() ||
                    (b.hi.array() < a.hi.array()).any())
                    continue;
                // Ray parity is exact for closed pieces; the winding number tolerates the
                // holes of open ones (filled later) and pieces ending at non-manifold edges.
                std::optional<bool> inside;
                if (!b.is_open) inside = ray_parity_encloses(net, sh, q, x);
                if (!inside) inside = std::abs(winding_number(net, sh, q, x)) > 0.5;
                if (*inside) ++enclosing;
            }
            wanted[p] = enclosing % 2 == 0 ? 1 : -1;
        }
    }
    std::vector<double> score(net.face_count(), 0.0);  // per class root
    for (std::size_t p = 0; p < np; ++p) {
        const std::int32_t side = sh.piece_sides[static_cast<std::size_t>(sh.piece_start[p])];
        score[static_cast<std::size_t>(sh.cls[static_cast<std::size_t>(side) / 2])] +=
            wanted[p] * sh.pieces[p].volume;
    }
    std::size_t flipped = 0;
    for (std::size_t f = 0; f < net.face_count(); ++f) {
        const bool class_flip = score[static_cast<std::size_t>(sh.cls[f])] < 0.0;
        if ((sh.flip[f] != 0) != class_flip) {
            reverse_face(net.faces[f]);
            topo.reverse(f);
            ++flipped;
        }
    }
    std::size_t disagreeing = 0;
    for (std::size_t p = 0; p < np; ++p) {
        const std::int32_t side = sh.piece_sides[static_cast<std::size_t>(sh.piece_start[p])];
        const bool class_flip =
            score[static_cast<std::size_t>(sh.cls[static_cast<std::size_t>(side) / 2])] < 0.0;
        if (wanted[p] * sh.pieces[p].volume * (class_flip ? -1.0 : 1.0) < 0.0) ++disagreeing;
    }
    ctx.count("repair.flipped_faces", static_cast<double>(flipped));
    ctx.count("repair.orientation_conflicts", static_cast<double>(sh.conflicts + disagreeing));
    ctx.info("repair: flipped " + std::to_string(flipped) + " faces to face outward (" +
             std::to_string(np) + " pieces)");
    if (sh.conflicts > 0)
        ctx.warn("repair: " + std::to_string(sh.conflicts) +
                 " edges where a region's faces cannot agree in orientation (non-orientable)");
    if (disagreeing > 0)
        ctx.warn("repair: " + std::to_string(disagreeing) +
                 " boundary pieces whose labels disagree with their nesting; oriented by the "
                 "majority of their orientation class");
}

// --- step 4: holes -------------------------------------------------------------------------

/// Minimum-area triangulation of a closed loop (dynamic programming over chords), avoiding
/// first triangles with a repeated vertex, then zero-area triangles and chords that are
/// already edges of the network. Triangles (i, m, j), i < m < j, follow the loop's order.
struct LoopTriangulation {
    std::vector<std::array<std::size_t, 3>> triangles;
    std::size_t bad = 0;  // penalty of the result: >= k_forbidden means unusable
    static constexpr std::size_t k_forbidden = 1000000;
};

template <class EdgeExists>
LoopTriangulation triangulate_loop(const SurfaceNetwork& net, const std::vector<std::int32_t>& loop,
                                   EdgeExists&& edge_exists) {
    const std::size_t n = loop.size();
    struct Cost {
        std::size_t bad = 0;
        double area = 0.0;
        bool operator<(const Cost& o) const { return bad != o.bad ? bad < o.bad : area < o.area; }
    };
    std::vector<Cost> cost(n * n);
    std::vector<std::size_t> split(n * n, 0);
    for (std::size_t len = 2; len < n; ++len)
        for (std::size_t i = 0; i + len < n; ++i) {
            const std::size_t j = i + len;
            std::size_t chord_bad = 0;
            if (!(i == 0 && j == n - 1)) {
                if (loop[i] == loop[j])
                    chord_bad = LoopTriangulation::k_forbidden;
                else if (edge_exists(loop[i], loop[j]))
                    chord_bad = 1;
            }
            Cost best{std::numeric_limits<std::size_t>::max(), 0.0};
            std::size_t best_m = i + 1;
            for (std::size_t m = i + 1; m < j; ++m) {
                const Tri t{loop[i], loop[m], loop[j]};
                Cost c{cost[i * n + m].bad + cost[m * n + j].bad + chord_bad,
                       cost[i * n + m].area + cost[m * n + j].area};
                if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) {
                    c.bad += LoopTriangulation::k_forbidden;
                } else {
                    if (is_collinear(net, t)) c.bad += 1;
                    c.area += triangle_area(net, t[0], t[1], t[2]);
                }
                if (c < best) {
                    best = c;
                    best_m = m;
                }
            }
            cost[i * n + j] = best;
            split[i * n + j] = best_m;
        }
    LoopTriangulation result;
    result.bad = cost[n - 1].bad;
    std::vector<std::pair<std::size_t, std::size_t>> stack{{0, n - 1}};
    while (!stack.empty()) {
        const auto [i, j] = stack.back();
        stack.pop_back();
        if (j - i < 2) continue;
        const std::size_t m = split[i * n + j];
        result.triangles.push_back({i, m, j});
        stack.push_back({i, m});
        stack.push_back({m, j});
    }
    return result;
}

struct HoleCounts {
    std::size_t holes = 0, faces = 0, open_edges = 0, unavoidable = 0;
};

/// One hole of one region: its vertices in the order the new faces follow (seen from the
/// region), the open edge entries (6 f + 2 i + s) along it, or why it cannot be filled.
struct HoleLoop {
    Label region = 0;
    std::vector<std::int32_t> vertices, entries;
    std::string problem;
};

std::uint64_t edge_key(std::int32_t a, std::int32_t b) {
    return (static_cast<std::uint64_t>(std::min(a, b)) << 32) |
           static_cast<std::uint32_t>(std::max(a, b));
}

std::string describe_entry(const SurfaceNetwork& net, std::int32_t entry) {
    const Tri& t = net.faces[static_cast<std::size_t>(entry / 6)];
    const int i = (entry % 6) / 2;
    const std::int32_t a = t[static_cast<std::size_t>(i)];
    const std::int32_t b = t[static_cast<std::size_t>((i + 1) % 3)];
    return "edge (" + std::to_string(a) + ", " + std::to_string(b) + ") at " +
           format_point(net.point(a)) + " - " + format_point(net.point(b)) + " mm";
}

/// Traces the holes of the regions above `after`, regions ascending, each from its first
/// open edge in id order. The loop runs against the open edges' direction; the next open
/// edge is found by turning around the current vertex through the region's manifold edges.
std::vector<HoleLoop> trace_holes(const SurfaceNetwork& net, const Topology& topo, Label after) {
    std::vector<std::pair<Label, std::int32_t>> open;  // (region, entry)
    for (std::size_t f = 0; f < topo.nbr.size() / 6; ++f)
        for (int i = 0; i < 3; ++i)
            for (int s = 0; s < 2; ++s)
                if (topo.at(f, i, s) == k_open && side_region(net, f, s) > after)
                    open.emplace_back(
                        side_region(net, f, s),
                        static_cast<std::int32_t>(6 * f + 2 * static_cast<std::size_t>(i)) + s);
    std::stable_sort(open.begin(), open.end(),
                     [](const auto& x, const auto& y) { return x.first < y.first; });
    std::vector<HoleLoop> loops;
    std::unordered_set<std::int32_t> visited;
    for (const auto& [region, start] : open) {
        if (visited.count(start)) continue;
        HoleLoop loop;
        loop.region = region;
        std::int32_t entry = start;
        bool closed = false;
        while (loop.entries.size() <= open.size()) {
            visited.insert(entry);
            loop.entries.push_back(entry);
            auto f = static_cast<std::size_t>(entry / 6);
            int s = entry % 2;
            const int i = (entry % 6) / 2;
            const std::int32_t a =
                side_view(net, f, s)[static_cast<std::size_t>(s == 0 ? i : 2 - i)];
            loop.vertices.push_back(a);  // the open view edge is (a -> b)
            std::int32_t next = -1;
            const std::size_t max_turns = topo.vf.of(a).size() + 1;
            for (std::size_t turn = 0; turn < max_turns; ++turn) {
                const int in = (index_of(side_view(net, f, s), a) + 2) % 3;  // view edge (x -> a)
                const int j = stored_edge(s, in);
                const std::int32_t code = topo.at(f, j, s);
                if (code == k_open) {
                    next = static_cast<std::int32_t>(6 * f + 2 * static_cast<std::size_t>(j)) + s;
                    break;
                }
                if (code < 0) break;  // non-manifold edge: the turn is ambiguous
                f = static_cast<std::size_t>(code >> 1);
                s = code & 1;
            }
            if (next < 0 || (next != start && visited.count(next))) break;
            if (next == start) {
                closed = true;
                break;
            }
            entry = next;
        }
        if (!closed || loop.vertices.size() < 3)
            loop.problem = "repair: region " + std::to_string(region) +
                           ": cannot trace the border of the hole at " +
                           describe_entry(net, start) +
                           " (a non-manifold edge or vertex lies on it)";
        loops.push_back(std::move(loop));
    }
    return loops;
}

/// Fills one traced hole; new faces are appended, their edges recorded in `new_edges` and,
/// per region they bound, in `new_region_edges`.
void fill_hole(SurfaceNetwork& net, const Topology& topo, const HoleLoop& loop,
               const RepairParams& params, std::unordered_set<std::uint64_t>& new_edges,
               std::set<std::pair<Label, std::uint64_t>>& new_region_edges, HoleCounts& counts) {
    const Label region = loop.region;
    if (!loop.problem.empty()) FM_THROW(GeometryError, loop.problem);
    if (loop.vertices.size() > params.max_hole_edges)
        FM_THROW(
            GeometryError,
            "repair: region " + std::to_string(region) + ": hole of " +
                std::to_string(loop.vertices.size()) +
                " edges exceeds repair.max_hole_edges = " + std::to_string(params.max_hole_edges) +
                "; one of its edges: " + describe_entry(net, loop.entries.front()));
    auto edge_exists = [&](std::int32_t a, std::int32_t b) {
        if (static_cast<std::size_t>(a) < topo.vf.start.size() - 1)
            for (std::int32_t g : topo.vf.of(a))
                if (contains(net.faces[static_cast<std::size_t>(g)], b)) return true;
        return new_edges.count(edge_key(a, b)) > 0;
    };
    const LoopTriangulation tri = triangulate_loop(net, loop.vertices, edge_exists);
    if (tri.bad >= LoopTriangulation::k_forbidden)
        FM_THROW(GeometryError,
                 "repair: region " + std::to_string(region) + ": cannot fill the hole of " +
                     std::to_string(loop.vertices.size()) + " edges at " +
                     describe_entry(net, loop.entries.front()) + " (its border touches itself)");
    counts.unavoidable += tri.bad;
    // The new faces separate the region from the label most of the hole's border has on its
    // other side (ties: the smaller label).
    std::vector<Label> others;
    for (std::int32_t e : loop.entries)
        others.push_back(side_region(net, static_cast<std::size_t>(e / 6), 1 - e % 2));
    std::sort(others.begin(), others.end());
    Label other = others.front();
    std::size_t best_run = 0;
    for (std::size_t b = 0; b < others.size();) {
        std::size_t e = b;
        while (e < others.size() && others[e] == others[b]) ++e;
        if (e - b > best_run) {
            best_run = e - b;
            other = others[b];
        }
        b = e;
    }
    // Extract's convention for interfaces: region_in is the larger label.
    const bool region_is_in = other == 0 || region > other;
    for (const auto& [i, m, j] : tri.triangles) {
        const std::int32_t a = loop.vertices[i], b = loop.vertices[m], c = loop.vertices[j];
        if (region_is_in)
            net.add_face(a, b, c, region, other);
        else
            net.add_face(a, c, b, other, region);
        for (auto [p, q] : {std::pair{a, b}, std::pair{b, c}, std::pair{c, a}}) {
            new_edges.insert(edge_key(p, q));
            new_region_edges.emplace(region, edge_key(p, q));
            if (other != 0) new_region_edges.emplace(other, edge_key(p, q));
        }
        ++counts.faces;
    }
    ++counts.holes;
}

/// Step 4. All holes are traced once, then filled region by region (ascending). A hole of an
/// interface appears once per region; when an earlier fill covers every edge of a loop, that
/// loop is closed already. A loop only partly covered (holes meeting at a junction) makes the
/// table be rebuilt and the remaining regions' holes be traced again. Returns whether faces
/// were added.
bool fill_holes(SurfaceNetwork& net, std::optional<Topology>& topo, const RepairParams& params,
                core::StageContext& ctx) {
    HoleCounts counts;
    std::unordered_set<std::uint64_t> new_edges;
    Label after = 0;
    for (bool retrace = true; retrace;) {
        retrace = false;
        std::set<std::pair<Label, std::uint64_t>> new_region_edges;
        const std::vector<HoleLoop> loops = trace_holes(net, *topo, after);
        for (const HoleLoop& loop : loops) {
            if (!params.fill_holes) {
                counts.open_edges += loop.entries.size();
                continue;
            }
            std::size_t covered = 0;
            for (std::size_t k = 0; k < loop.vertices.size(); ++k) {
                const std::int32_t a = loop.vertices[k];
                const std::int32_t b = loop.vertices[(k + 1) % loop.vertices.size()];
                covered += new_region_edges.count({loop.region, edge_key(a, b)});
            }
            if (covered == loop.vertices.size()) continue;
            if (covered > 0) {
                topo.emplace(net);
                after = loop.region - 1;
                retrace = true;
                break;
            }
            fill_hole(net, *topo, loop, params, new_edges, new_region_edges, counts);
        }
    }
    ctx.count("repair.filled_holes", static_cast<double>(counts.holes));
    ctx.count("repair.hole_faces", static_cast<double>(counts.faces));
    ctx.info("repair: filled " + std::to_string(counts.holes) + " holes with " +
             std::to_string(counts.faces) + " faces" +
             (params.fill_holes ? std::string()
                                : " (repair.fill_holes is off: " +
                                      std::to_string(counts.open_edges) + " open edges left)"));
    if (counts.unavoidable > 0)
        ctx.warn("repair: " + std::to_string(counts.unavoidable) +
                 " hole-filling triangles are flat or reuse an existing edge (no better "
                 "triangulation of their hole)");
    return counts.faces > 0;
}

// --- step 5: non-manifold vertices and edges -----------------------------------------------

/// A vertex whose faces of one region form several fans (connected through edges at the
/// vertex). Fans after the first get their own copy of the vertex.
struct PinchSplit {
    std::int32_t vertex;
    std::vector<std::vector<std::int32_t>> fans;  // faces; fans[0] keeps the vertex
};

/// Fast path of find_pinches: true when turning around v through manifold edges from the
/// first side visits every one of `sides` (the region's sides at v) and comes back.
bool is_single_closed_fan(const SurfaceNetwork& net, const Topology& topo, std::int32_t v,
                          const std::vector<std::int32_t>& sides) {
    std::int32_t side = sides.front();
    for (std::size_t visited = 1; visited <= sides.size(); ++visited) {
        const auto f = static_cast<std::size_t>(side / 2);
        const int s = side % 2;
        const Tri u = side_view(net, f, s);
        const int in = (index_of(u, v) + 2) % 3;  // view edge (x -> v)
        side = topo.at(f, stored_edge(s, in), s);
        if (side < 0) return false;
        if (side == sides.front()) return visited == sides.size();
    }
    return false;
}

/// Finds pinch vertices. Rule: a pinch on the outer boundary (all faces at the vertex
/// separate one region from the outside, e.g. two bodies touching at a point) is split, so
/// that the boundary of the final mesh is a 2-manifold (meshcheck requires it); a pinch inside
/// the meshed domain (the other side is another region) or at a junction of three or more
/// labels is kept: both sides get tetrahedra, and a conforming tet mesh needs one node there
/// (two coincident nodes could only be joined by flat tets).
std::vector<PinchSplit> find_pinches(const SurfaceNetwork& net, const Topology& topo,
                                     std::size_t& kept) {
    std::vector<PinchSplit> splits;
    std::vector<Label> labels;
    std::vector<std::int32_t> sides, parent;
    for (std::size_t vi = 0; vi < net.vertex_count(); ++vi) {
        const auto v = to_id(vi);
        const auto faces = topo.vf.of(v);
        if (faces.size() < 2) continue;
        labels.clear();
        for (std::int32_t f : faces) {
            labels.push_back(net.region_in[static_cast<std::size_t>(f)]);
            labels.push_back(net.region_out[static_cast<std::size_t>(f)]);
        }
        std::sort(labels.begin(), labels.end());
        labels.erase(std::unique(labels.begin(), labels.end()), labels.end());
        for (Label region : labels) {
            if (region == 0) continue;
            sides.clear();
            for (std::int32_t f : faces)
                for (int s = 0; s < 2; ++s)
                    if (side_region(net, static_cast<std::size_t>(f), s) == region)
                        sides.push_back(2 * f + s);
            if (sides.size() < 2 || is_single_closed_fan(net, topo, v, sides)) continue;
            parent.resize(sides.size());
            std::iota(parent.begin(), parent.end(), 0);
            auto find = [&](std::int32_t x) {
                while (parent[static_cast<std::size_t>(x)] != x)
                    x = parent[static_cast<std::size_t>(x)];
                return x;
            };
            auto unite = [&](std::size_t a, std::size_t b) {
                std::int32_t ra = find(to_id(a)), rb = find(to_id(b));
                if (ra > rb) std::swap(ra, rb);
                parent[static_cast<std::size_t>(rb)] = ra;
            };
            for (std::size_t k = 0; k < sides.size(); ++k) {
                const auto f = static_cast<std::size_t>(sides[k] / 2);
                const int s = sides[k] % 2;
                const Tri& t = net.faces[f];
                for (int i = 0; i < 3; ++i) {
                    const std::int32_t a = t[static_cast<std::size_t>(i)];
                    const std::int32_t b = t[static_cast<std::size_t>((i + 1) % 3)];
                    if (a != v && b != v) continue;
                    const std::int32_t w = a == v ? b : a;
                    const std::int32_t code = topo.at(f, i, s);
                    for (std::size_t k2 = 0; k2 < sides.size(); ++k2) {
                        const bool linked =
                            code >= 0
                                ? sides[k2] == code
                                : code == k_nonmanifold &&
                                      contains(net.faces[static_cast<std::size_t>(sides[k2] / 2)],
                                               w);
                        if (linked) unite(k, k2);
                    }
                }
            }
            std::size_t roots = 0;
            for (std::size_t k = 0; k < sides.size(); ++k) roots += find(to_id(k)) == to_id(k);
            if (roots < 2) continue;
            std::vector<std::vector<std::int32_t>> fans;
            std::vector<std::int32_t> fan_of(sides.size(), -1);
            for (std::size_t k = 0; k < sides.size(); ++k) {
                const auto root = static_cast<std::size_t>(find(to_id(k)));
                if (fan_of[root] < 0) {
                    fan_of[root] = to_id(fans.size());
                    fans.emplace_back();
                }
                fans[static_cast<std::size_t>(fan_of[root])].push_back(sides[k] / 2);
            }
            if (labels.size() == 2 && labels[0] == 0)
                splits.push_back({v, std::move(fans)});
            else
                ++kept;
            break;  // with two labels the other region sees the same fans
        }
    }
    return splits;
}

/// Counts edges with more than two faces of one region, once per region and edge.
std::size_t count_nonmanifold_edges(const SurfaceNetwork& net, const Topology& topo) {
    std::size_t n = 0;
    for (std::size_t f = 0; f < net.face_count(); ++f)
        for (int i = 0; i < 3; ++i)
            for (int s = 0; s < 2; ++s)
                if (topo.at(f, i, s) == k_nonmanifold &&
                    topo.edge_sides(net, f, i, side_region(net, f, s)).front() ==
                        static_cast<std::int32_t>(2 * f) + s)
                    ++n;
    return n;
}

// --- step 6: self-intersections ------------------------------------------------------------

void check_self_intersections(const SurfaceNetwork& net, const RepairParams& params,
                              core::StageContext& ctx) {
    if (!params.check_self_intersections) {
        ctx.info("repair: self-intersection check off");
        return;
    }
    const auto pairs = core::self_intersections(net, 100);
    ctx.count("repair.self_intersecting_pairs", static_cast<double>(pairs.size()));
    if (pairs.empty()) {
        ctx.info("repair: no self-intersections");
        return;
    }
    const auto [f, g] = pairs.front();
    Eigen::Vector3d near = Eigen::Vector3d::Zero();
    for (std::int32_t face : {f, g})
        for (std::int32_t v : net.faces[static_cast<std::size_t>(face)]) near += net.point(v) / 6.0;
    const std::string message = "repair: " + std::to_string(pairs.size()) +
                                (pairs.size() >= 100 ? " or more" : "") +
                                " self-intersecting face pairs, first faces " + std::to_string(f) +
                                " and " + std::to_string(g) + " near " + format_point(near) + " mm";
    if (params.fail_on_self_intersections) FM_THROW(GeometryError, message);
    ctx.warn(message);
}

// --- step 7: verification ------------------------------------------------------------------

void verify(const SurfaceNetwork& net, const RepairParams& params, core::StageContext& ctx) {
    std::size_t nonmanifold = 0;
    for (const core::RegionBoundaryCheck& c : core::check_region_boundaries(net)) {
        if (!c.is_closed())
            FM_THROW(GeometryError, "repair: region " + std::to_string(c.region) +
                                        " is not closed: " + std::to_string(c.open_edges) +
                                        " open edges remain" +
                                        (params.fill_holes ? "" : " (repair.fill_holes is off)"));
        if (!c.is_oriented())
            FM_THROW(GeometryError,
                     "repair: region " + std::to_string(c.region) +
                         " is not consistently oriented: " + std::to_string(c.misoriented_edges) +
                         " misoriented edges, enclosed volume " + format_number(c.volume) +
                         " mm^3");
        nonmanifold += c.nonmanifold_edges;
    }
    ctx.info("repair: every region closed and oriented (" + std::to_string(net.vertex_count()) +
             " points, " + std::to_string(net.face_count()) + " faces, " +
             std::to_string(nonmanifold) + " non-manifold edges)");
}

}  // namespace

core::SurfaceNetwork repair(const core::SurfaceNetwork& input, const RepairParams& params,
                            core::StageContext& ctx) {
    validate(params);
    check_input(input);
    SurfaceNetwork net = input;

    ctx.progress(0.0, "repair: merge and clean up");
    clean_up(net, params, ctx);
    if (net.face_count() == 0)
        FM_THROW(GeometryError,
                 "repair: no face left after dropping degenerate and duplicate faces");

    ctx.progress(0.15, "repair: small components");
    std::optional<Topology> topo(std::in_place, net);
    std::optional<Shells> shells(analyse(net, *topo));
    if (remove_small_components(net, *topo, *shells, params, ctx)) {
        if (net.face_count() == 0)
            FM_THROW(GeometryError,
                     "repair: every component is smaller than "
                     "repair.min_component_volume_mm3 / min_component_faces");
        topo.emplace(net);
        shells.emplace(analyse(net, *topo));
    }

    ctx.progress(0.3, "repair: orientation");
    orient(net, *topo, *shells, ctx);
    shells.reset();

    ctx.progress(0.45, "repair: holes");
    if (fill_holes(net, topo, params, ctx)) topo.emplace(net);

    // Step 5 is planned here but applied after the self-intersection check: the copies of a
    // split vertex coincide, and faces meeting at coincident but distinct vertices count as
    // intersecting. The geometry checked is the same.
    ctx.progress(0.6, "repair: non-manifold vertices");
    std::size_t kept_pinches = 0;
    const std::vector<PinchSplit> splits = find_pinches(net, *topo, kept_pinches);
    const std::size_t nonmanifold_edges = count_nonmanifold_edges(net, *topo);
    topo.reset();

    ctx.progress(0.7, "repair: self-intersections");
    check_self_intersections(net, params, ctx);

    std::size_t copies = 0;
    for (const PinchSplit& split : splits)
        for (std::size_t k = 1; k < split.fans.size(); ++k) {
            const Eigen::Vector3d p = net.point(split.vertex);
            const std::int32_t copy = net.add_vertex(p);
            for (std::int32_t f : split.fans[k])
                for (std::int32_t& v : net.faces[static_cast<std::size_t>(f)])
                    if (v == split.vertex) v = copy;
            ++copies;
        }
    ctx.count("repair.split_vertices", static_cast<double>(splits.size()));
    ctx.count("repair.kept_pinch_vertices", static_cast<double>(kept_pinches));
    ctx.count("repair.nonmanifold_edges", static_cast<double>(nonmanifold_edges));
    ctx.info("repair: split " + std::to_string(splits.size()) + " pinch vertices into " +
             std::to_string(copies) + " extra copies; kept " + std::to_string(kept_pinches) +
             " pinch vertices inside the domain or at junctions");
    if (nonmanifold_edges > 0)
        ctx.warn("repair: " + std::to_string(nonmanifold_edges) +
                 " non-manifold edges (more than two faces of one region on an edge), kept");

    ctx.progress(0.9, "repair: verify");
    verify(net, params, ctx);
    ctx.progress(1.0, "repair: done");
    return net;
}

}  // namespace frontmesh::surface
