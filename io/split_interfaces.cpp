#include "io/split_interfaces.h"

#include <algorithm>
#include <map>
#include <numeric>
#include <set>

#include "pipeline/core/error.h"

namespace frontmesh::io {
namespace {

using Pair = std::pair<core::Label, core::Label>;

Pair ordered(core::Label a, core::Label b) { return {std::min(a, b), std::max(a, b)}; }

/// Items -> CSR lists of what touches each node (tets or faces), in increasing item order.
template <class Items>
void node_incidence(const Items& items, std::size_t nodes, std::vector<std::int32_t>& start,
                    std::vector<std::int32_t>& list) {
    start.assign(nodes + 1, 0);
    for (const auto& item : items)
        for (std::int32_t v : item) ++start[static_cast<std::size_t>(v) + 1];
    std::partial_sum(start.begin(), start.end(), start.begin());
    list.assign(static_cast<std::size_t>(start.back()), 0);
    std::vector<std::int32_t> next(start.begin(), start.end() - 1);
    for (std::size_t i = 0; i < items.size(); ++i)
        for (std::int32_t v : items[i])
            list[static_cast<std::size_t>(next[static_cast<std::size_t>(v)]++)] =
                static_cast<std::int32_t>(i);
}

}  // namespace

std::string split_interfaces_text(const SplitInterfaces& spec) {
    if (spec.all) return "all";
    if (spec.pairs.empty()) return "none";
    std::string s = "[";
    for (std::size_t i = 0; i < spec.pairs.size(); ++i)
        s += (i ? ", [" : "[") + std::to_string(spec.pairs[i].first) + ", " +
             std::to_string(spec.pairs[i].second) + "]";
    return s + "]";
}

core::TetMesh split_interfaces(const core::TetMesh& mesh, const SplitInterfaces& spec,
                               const std::string& key) {
    if (spec.is_none()) return mesh;
    FM_CHECK(mesh.region.size() == mesh.tet_count());
    FM_CHECK(mesh.region_in.size() == mesh.face_count() &&
             mesh.region_out.size() == mesh.face_count());
    FM_CHECK(mesh.twin.empty());  // a mesh is split once

    // The interfaces to split: every pair of region labels with faces between them, or the
    // listed ones, each of which must exist.
    std::set<Pair> touching;
    for (std::size_t f = 0; f < mesh.face_count(); ++f)
        if (mesh.region_out[f] != 0)
            touching.insert(ordered(mesh.region_in[f], mesh.region_out[f]));
    std::set<Pair> split;
    if (spec.all) {
        split = touching;
    } else {
        const std::set<core::Label> labels(mesh.region.begin(), mesh.region.end());
        for (const auto& [a, b] : spec.pairs) {
            const std::string pair = "[" + std::to_string(a) + ", " + std::to_string(b) + "]";
            if (a <= 0 || b <= 0 || a == b)
                FM_THROW(InputError, key + ": " + pair + " is not a pair of two different " +
                                         "region labels (positive numbers)");
            for (const core::Label l : {a, b})
                if (labels.count(l) == 0)
                    FM_THROW(InputError, key + ": " + pair + ": label " + std::to_string(l) +
                                             " is not a region of the mesh");
            if (touching.count(ordered(a, b)) == 0)
                FM_THROW(InputError, key + ": " + pair + ": regions " + std::to_string(a) +
                                         " and " + std::to_string(b) +
                                         " do not touch (no interface between them)");
            split.insert(ordered(a, b));
        }
    }
    const std::size_t n = mesh.node_count();
    std::vector<char> is_split_face(mesh.face_count(), 0), on_split(n, 0);
    for (std::size_t f = 0; f < mesh.face_count(); ++f)
        if (mesh.region_out[f] != 0 &&
            split.count(ordered(mesh.region_in[f], mesh.region_out[f])) != 0) {
            is_split_face[f] = 1;
            for (std::int32_t v : mesh.faces[f]) on_split[static_cast<std::size_t>(v)] = 1;
        }

    std::vector<std::int32_t> tet_start, tet_list, face_start, face_list;
    node_incidence(mesh.tets, n, tet_start, tet_list);
    node_incidence(mesh.faces, n, face_start, face_list);

    // Per node on a split face: its regions grouped across unsplit faces (union-find over
    // the few regions around it); (node, label) -> the node's copy for that label's group.
    // One pass over the nodes, each looking at its incident tets and faces: O(tets + faces).
    std::map<std::pair<std::int32_t, core::Label>, std::int32_t> copy_of;
    std::vector<std::int32_t> copied;  // per copy, the node it copies
    const std::int32_t sv = mesh.surface_vertices;
    for (std::size_t v = 0; v < n; ++v) {
        if (!on_split[v]) continue;
        std::vector<core::Label> regions;
        for (std::int32_t i = tet_start[v]; i < tet_start[v + 1]; ++i)
            regions.push_back(mesh.region[static_cast<std::size_t>(tet_list[i])]);
        std::sort(regions.begin(), regions.end());
        regions.erase(std::unique(regions.begin(), regions.end()), regions.end());
        std::vector<std::size_t> parent(regions.size());
        std::iota(parent.begin(), parent.end(), 0);
        auto root = [&](std::size_t i) {
            while (parent[i] != i) i = parent[i] = parent[parent[i]];  // halves the path
            return i;
        };
        auto index = [&](core::Label l) {
            const auto it = std::lower_bound(regions.begin(), regions.end(), l);
            return it != regions.end() && *it == l ? static_cast<std::size_t>(it - regions.begin())
                                                   : regions.size();
        };
        for (std::int32_t i = face_start[v]; i < face_start[v + 1]; ++i) {
            const auto f = static_cast<std::size_t>(face_list[i]);
            if (mesh.region_out[f] == 0 || is_split_face[f]) continue;
            const std::size_t a = index(mesh.region_in[f]), b = index(mesh.region_out[f]);
            if (a < regions.size() && b < regions.size()) {
                // The smaller root wins, so a group's root is its smallest label.
                const std::size_t ra = root(a), rb = root(b);
                parent[std::max(ra, rb)] = std::min(ra, rb);
            }
        }
        // Regions are in increasing label order: the group of regions[0] keeps the node.
        std::map<std::size_t, std::int32_t> group_node;
        for (std::size_t i = 0; i < regions.size(); ++i) {
            const std::size_t r = root(i);
            auto it = group_node.find(r);
            if (it == group_node.end()) {
                std::int32_t id = -1;  // the kept node
                if (!group_node.empty()) {
                    id = static_cast<std::int32_t>(copied.size());
                    copied.push_back(static_cast<std::int32_t>(v));
                }
                it = group_node.emplace(r, id).first;
            }
            if (it->second >= 0) copy_of[{static_cast<std::int32_t>(v), regions[i]}] = it->second;
        }
    }

    // New ids: [0, sv) unchanged, the copies at [sv, sv + d), the rest shifted by d.
    const auto d = static_cast<std::int32_t>(copied.size());
    auto moved = [&](std::int32_t v) { return v < sv ? v : v + d; };
    auto node_for = [&](std::int32_t v, core::Label region) {
        if (on_split[static_cast<std::size_t>(v)])
            if (const auto it = copy_of.find({v, region}); it != copy_of.end())
                return sv + it->second;
        return moved(v);
    };
    core::TetMesh out;
    out.xyz.resize(3 * (n + static_cast<std::size_t>(d)));
    out.twin.resize(n + static_cast<std::size_t>(d));
    if (!mesh.level.empty()) out.level.resize(n + static_cast<std::size_t>(d));
    for (std::size_t v = 0; v < n; ++v) {
        const auto w = static_cast<std::size_t>(moved(static_cast<std::int32_t>(v)));
        std::copy_n(&mesh.xyz[3 * v], 3, &out.xyz[3 * w]);
        out.twin[w] = static_cast<std::int32_t>(w);
        if (!mesh.level.empty()) out.level[w] = mesh.level[v];
    }
    for (std::int32_t c = 0; c < d; ++c) {
        const auto w = static_cast<std::size_t>(sv + c);
        const std::int32_t v = copied[static_cast<std::size_t>(c)];
        std::copy_n(&mesh.xyz[3 * static_cast<std::size_t>(v)], 3, &out.xyz[3 * w]);
        out.twin[w] = moved(v);
        if (!mesh.level.empty()) out.level[w] = mesh.level[static_cast<std::size_t>(v)];
    }
    out.tets.resize(mesh.tet_count());
    out.region = mesh.region;
    for (std::size_t t = 0; t < mesh.tet_count(); ++t)
        for (int k = 0; k < 4; ++k) out.tets[t][k] = node_for(mesh.tets[t][k], mesh.region[t]);
    for (std::size_t f = 0; f < mesh.face_count(); ++f) {
        const auto& tri = mesh.faces[f];
        const core::Label in = mesh.region_in[f], other = mesh.region_out[f];
        out.faces.push_back({node_for(tri[0], in), node_for(tri[1], in), node_for(tri[2], in)});
        out.region_in.push_back(in);
        out.region_out.push_back(other);
        if (!is_split_face[f]) {
            out.face_twin.push_back(-1);
            continue;
        }
        // The other side: its nodes, reversed so that the normal points out of `other`.
        const auto here = static_cast<std::int32_t>(out.faces.size()) - 1;
        out.faces.push_back(
            {node_for(tri[0], other), node_for(tri[2], other), node_for(tri[1], other)});
        out.region_in.push_back(other);
        out.region_out.push_back(in);
        out.face_twin.push_back(here + 1);
        out.face_twin.push_back(here);
    }
    out.surface_vertices = sv + d;
    return out;
}

}  // namespace frontmesh::io
