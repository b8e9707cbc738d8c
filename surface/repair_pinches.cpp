// Repair step 5: pinch vertices (split on the outer boundary, kept inside the domain) and
// non-manifold edges (counted).

#include "surface/repair_internal.h"

#include <algorithm>

namespace frontmesh::surface::repair_detail {
namespace {

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

}  // namespace

}  // namespace

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

}  // namespace frontmesh::surface::repair_detail
