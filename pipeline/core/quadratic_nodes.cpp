#include "pipeline/core/quadratic_nodes.h"

#include <algorithm>
#include <unordered_map>

#include "pipeline/core/error.h"

namespace frontmesh::core {
namespace {

std::uint64_t edge_key(std::int32_t a, std::int32_t b) {
    const auto lo = static_cast<std::uint32_t>(std::min(a, b));
    const auto hi = static_cast<std::uint32_t>(std::max(a, b));
    return (std::uint64_t{lo} << 32) | hi;
}

}  // namespace

QuadraticNodes quadratic_nodes(const TetMesh& mesh) {
    QuadraticNodes q;
    // A tet mesh has about 1.2 edges per tet; the table only maps keys, the order of the
    // edges is the order of first use (never the table's).
    std::unordered_map<std::uint64_t, std::int32_t> index;
    index.reserve(mesh.tet_count() * 3 / 2 + 16);
    q.edges.reserve(mesh.tet_count() * 3 / 2 + 16);
    q.tet_edges.resize(mesh.tet_count());
    for (std::size_t t = 0; t < mesh.tet_count(); ++t)
        for (int k = 0; k < 6; ++k) {
            const std::int32_t a = mesh.tets[t][kTetEdge[k][0]], b = mesh.tets[t][kTetEdge[k][1]];
            const auto [it, added] =
                index.emplace(edge_key(a, b), static_cast<std::int32_t>(q.edges.size()));
            if (added) q.edges.push_back({std::min(a, b), std::max(a, b)});
            q.tet_edges[t][static_cast<std::size_t>(k)] = it->second;
        }
    q.face_edges.resize(mesh.face_count());
    for (std::size_t f = 0; f < mesh.face_count(); ++f)
        for (int k = 0; k < 3; ++k) {
            const std::int32_t a = mesh.faces[f][kTriEdge[k][0]], b = mesh.faces[f][kTriEdge[k][1]];
            const auto it = index.find(edge_key(a, b));
            if (it == index.end())
                FM_THROW(InternalError, "face " + std::to_string(f) + ": edge (" +
                                            std::to_string(a) + ", " + std::to_string(b) +
                                            ") is no edge of a tet");
            q.face_edges[f][static_cast<std::size_t>(k)] = it->second;
        }
    return q;
}

}  // namespace frontmesh::core
