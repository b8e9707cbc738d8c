// Repair step 4: trace the holes of every region and fill them (minimum-area triangulation).

#include "surface/repair_internal.h"

#include <algorithm>
#include <limits>
#include <map>
#include <set>
#include <unordered_set>

#include "pipeline/core/error.h"
#include "pipeline/core/predicates.h"

namespace frontmesh::surface::repair_detail {
namespace {

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
    std::size_t holes = 0, faces = 0, open_edges = 0, unavoidable = 0, fans = 0;
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

/// The simple cycles of a closed loop that may pass a vertex more than once (two holes
/// touching at a vertex, e.g. where faces around it were lost): walking the loop, a vertex
/// met again closes the cycle since its last visit. Each cycle keeps the loop's direction, and
/// together they use each of the loop's edges once. O(n log n).
std::vector<std::vector<std::int32_t>> simple_cycles(const std::vector<std::int32_t>& loop) {
    std::vector<std::vector<std::int32_t>> cycles;
    std::vector<std::int32_t> path;
    std::map<std::int32_t, std::size_t> at;  // vertex -> its index in path
    for (std::size_t k = 0; k <= loop.size(); ++k) {
        const std::int32_t v = loop[k % loop.size()];
        if (const auto it = at.find(v); it != at.end()) {
            const std::size_t from = it->second;
            cycles.emplace_back(path.begin() + static_cast<std::ptrdiff_t>(from), path.end());
            for (std::size_t q = from + 1; q < path.size(); ++q) at.erase(path[q]);
            path.resize(from + 1);
            continue;
        }
        at.emplace(v, path.size());
        path.push_back(v);
    }
    return cycles;
}

/// No triangulation of a hole's border alone may avoid a flat triangle or an edge that exists
/// already (four faces of the region on it: a non-manifold boundary the referee refuses;
/// campaign seed 11, issue 21). A fan from a new vertex at the border's centroid makes only
/// new edges; it is taken (appended to `fill`, true) when none of its triangles is flat. Its
/// triangles may cross the surface, which the self-intersection step after this one mends
/// like any other crossing.
bool fan_fill(SurfaceNetwork& net, const std::vector<std::int32_t>& cycle, std::vector<Tri>& fill,
              HoleCounts& counts) {
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (const std::int32_t v : cycle) centre += net.point(v);
    centre /= static_cast<double>(cycle.size());
    const std::size_t n = cycle.size();
    for (std::size_t k = 0; k < n; ++k) {
        const Eigen::Vector3d a = net.point(cycle[k]), b = net.point(cycle[(k + 1) % n]);
        if (core::is_degenerate_triangle(a.data(), b.data(), centre.data())) return false;
    }
    const std::int32_t c = net.add_vertex(centre);
    for (std::size_t k = 0; k < n; ++k) fill.push_back({cycle[k], cycle[(k + 1) % n], c});
    ++counts.fans;
    return true;
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
    // The faces of the hole, as vertex triples in the loop's order.
    std::vector<Tri> fill;
    for (const std::vector<std::int32_t>& cycle : simple_cycles(loop.vertices)) {
        if (cycle.size() < 3)
            FM_THROW(GeometryError, "repair: region " + std::to_string(region) +
                                        ": cannot fill the hole of " +
                                        std::to_string(loop.vertices.size()) + " edges at " +
                                        describe_entry(net, loop.entries.front()) +
                                        " (its border runs along one edge forth and back)");
        const LoopTriangulation tri = triangulate_loop(net, cycle, edge_exists);
        if (tri.bad > 0 && fan_fill(net, cycle, fill, counts)) continue;
        if (tri.bad >= LoopTriangulation::k_forbidden)
            FM_THROW(GeometryError, "repair: region " + std::to_string(region) +
                                        ": cannot fill the hole of " +
                                        std::to_string(loop.vertices.size()) + " edges at " +
                                        describe_entry(net, loop.entries.front()) +
                                        " (its border touches itself)");
        counts.unavoidable += tri.bad;
        for (const auto& [i, m, j] : tri.triangles) fill.push_back({cycle[i], cycle[m], cycle[j]});
    }
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
    for (const auto& [a, b, c] : fill) {
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

}  // namespace

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
    ctx.count("repair.hole_fans", static_cast<double>(counts.fans));
    ctx.info("repair: filled " + std::to_string(counts.holes) + " holes with " +
             std::to_string(counts.faces) + " faces" +
             (counts.fans > 0
                  ? " (" + std::to_string(counts.fans) + " of them fanned from a new centre vertex)"
                  : std::string()) +
             (params.fill_holes ? std::string()
                                : " (repair.fill_holes is off: " +
                                      std::to_string(counts.open_edges) + " open edges left)"));
    if (counts.unavoidable > 0)
        ctx.warn("repair: " + std::to_string(counts.unavoidable) +
                 " hole-filling triangles are flat or reuse an existing edge (no better "
                 "triangulation of their hole)");
    return counts.faces > 0;
}

}  // namespace frontmesh::surface::repair_detail
