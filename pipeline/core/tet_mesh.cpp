#include "pipeline/core/tet_mesh.h"

#include <algorithm>

namespace frontmesh::core {

SurfaceNetwork boundary_surface(const TetMesh& mesh) {
    SurfaceNetwork s;
    s.xyz.assign(mesh.xyz.begin(), mesh.xyz.begin() + 3 * std::size_t(mesh.surface_vertices));
    s.faces = mesh.faces;
    s.region_in = mesh.region_in;
    s.region_out = mesh.region_out;
    return s;
}

void derive_boundary_faces(TetMesh& mesh) {
    // Each tet face keyed by its sorted nodes; faces seen once are boundary, faces seen
    // twice with two regions are interfaces. Sorting keeps the result deterministic.
    struct FaceRef {
        std::array<std::int32_t, 3> key;
        std::array<std::int32_t, 3> nodes;  // oriented out of the tet
        Label region;
    };
    static constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
    std::vector<FaceRef> refs;
    refs.reserve(4 * mesh.tet_count());
    for (std::size_t t = 0; t < mesh.tet_count(); ++t)
        for (const auto& f : kFace) {
            FaceRef r;
            r.nodes = {mesh.tets[t][f[0]], mesh.tets[t][f[1]], mesh.tets[t][f[2]]};
            r.key = r.nodes;
            std::sort(r.key.begin(), r.key.end());
            r.region = mesh.region[t];
            refs.push_back(r);
        }
    std::sort(refs.begin(), refs.end(), [](const FaceRef& a, const FaceRef& b) {
        return a.key != b.key ? a.key < b.key : a.region < b.region;
    });
    mesh.faces.clear();
    mesh.region_in.clear();
    mesh.region_out.clear();
    for (std::size_t i = 0; i < refs.size();) {
        std::size_t j = i + 1;
        while (j < refs.size() && refs[j].key == refs[i].key) ++j;
        if (j - i == 1) {
            mesh.faces.push_back(refs[i].nodes);
            mesh.region_in.push_back(refs[i].region);
            mesh.region_out.push_back(0);
        } else if (j - i == 2 && refs[i].region != refs[i + 1].region) {
            mesh.faces.push_back(refs[i].nodes);  // the smaller label's side
            mesh.region_in.push_back(refs[i].region);
            mesh.region_out.push_back(refs[i + 1].region);
        }
        i = j;
    }
}

}  // namespace frontmesh::core
