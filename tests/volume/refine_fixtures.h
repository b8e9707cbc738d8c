#pragma once
// Test inputs for the refine stage: small hand-made configurations and tetgen meshes of a
// SurfaceNetwork (tetgen -pY keeps the surface triangles; nodes [0, n) are mapped back to the
// surface vertices and given their exact input coordinates).

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "pipeline/core/quality.h"
#include "pipeline/core/surface_network.h"
#include "pipeline/core/tet_mesh.h"

namespace frontmesh::refine_fixtures {

/// Seed points (one per region) for tetgen's region attributes.
struct RegionSeed {
    double x, y, z;
    core::Label label;
};

/// Writes `surface` as a tetgen .smesh (with region seeds), runs `tetgen <flags>` on it in `dir`
/// and reads the result. With one region and no seeds, every tet gets region 1. Throws when
/// tetgen fails or the surface vertices cannot be matched. With `reuse`, an existing tetgen
/// result in `dir` is read instead of running tetgen again.
inline core::TetMesh tetgen_mesh(const core::SurfaceNetwork& surface, const std::string& dir,
                                 const std::string& flags,
                                 const std::vector<RegionSeed>& seeds = {}, bool reuse = false) {
    const std::string base = dir + "/input";
    const std::size_t n = surface.xyz.size() / 3;
    {
        std::ofstream out(base + ".smesh");
        out.precision(17);
        out << n << " 3 0 0\n";
        for (std::size_t v = 0; v < n; ++v)
            out << v << ' ' << surface.xyz[3 * v] << ' ' << surface.xyz[3 * v + 1] << ' '
                << surface.xyz[3 * v + 2] << '\n';
        out << surface.faces.size() << " 0\n";
        for (const auto& f : surface.faces)
            out << "3 " << f[0] << ' ' << f[1] << ' ' << f[2] << '\n';
        out << "0\n" << seeds.size() << '\n';
        for (std::size_t k = 0; k < seeds.size(); ++k)
            out << k << ' ' << seeds[k].x << ' ' << seeds[k].y << ' ' << seeds[k].z << ' '
                << seeds[k].label << '\n';
    }
    const bool have = reuse && std::ifstream(base + ".1.ele").good();
    const std::string command = "cd '" + dir + "' && tetgen -" + flags +
                                (seeds.empty() ? "" : "A") + " input.smesh > tetgen.log 2>&1";
    if (!have && std::system(command.c_str()) != 0)
        throw std::runtime_error("tetgen failed: " + command);

    core::TetMesh mesh;
    // Whole files tokenised with strtod (comments '#' to end of line skipped).
    auto slurp = [](const std::string& path) {
        std::ifstream in(path, std::ios::binary);
        if (!in) throw std::runtime_error("tetgen output missing: " + path);
        std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        for (std::size_t k = text.find('#'); k != std::string::npos; k = text.find('#', k))
            for (; k < text.size() && text[k] != '\n'; ++k) text[k] = ' ';
        return text;
    };
    const std::string node_text = slurp(base + ".1.node"), ele_text = slurp(base + ".1.ele");
    const char* c = node_text.c_str();
    char* end = nullptr;
    auto number = [&]() {
        const double x = std::strtod(c, &end);
        if (end == c) throw std::runtime_error("bad tetgen output in " + dir);
        c = end;
        return x;
    };
    const auto nodes = static_cast<std::size_t>(number());
    const int dim = static_cast<int>(number()), attrs = static_cast<int>(number()),
              marks = static_cast<int>(number());
    (void)dim;
    std::vector<double> xyz(3 * nodes);
    int first = 0;
    for (std::size_t k = 0; k < nodes; ++k) {
        const int id = static_cast<int>(number());
        if (k == 0) first = id;
        for (int d = 0; d < 3; ++d) xyz[3 * k + static_cast<std::size_t>(d)] = number();
        for (int a = 0; a < attrs + marks; ++a) number();
    }
    if (nodes < n) throw std::runtime_error("tetgen lost surface vertices");
    for (std::size_t v = 0; v < n; ++v) {
        for (std::size_t d = 0; d < 3; ++d) {
            const double a = xyz[3 * v + d], b = surface.xyz[3 * v + d];
            if (std::abs(a - b) > 1e-9 * (1.0 + std::abs(b)))
                throw std::runtime_error("tetgen node " + std::to_string(v) +
                                         " is not surface vertex");
            xyz[3 * v + d] = b;  // exact input coordinates
        }
    }
    mesh.xyz = std::move(xyz);
    mesh.surface_vertices = static_cast<std::int32_t>(n);
    c = ele_text.c_str();
    const auto tets = static_cast<std::size_t>(number());
    const int per = static_cast<int>(number()), tet_attrs = static_cast<int>(number());
    mesh.tets.reserve(tets);
    mesh.region.reserve(tets);
    for (std::size_t k = 0; k < tets; ++k) {
        number();
        std::array<std::int32_t, 4> t{};
        for (auto& v : t) v = static_cast<std::int32_t>(number()) - first;
        for (int e = 4; e < per; ++e) number();
        double attr = 1.0;
        for (int a = 0; a < tet_attrs; ++a) {
            const double x = number();
            if (a == 0) attr = x;
        }
        if (core::tet_signed_volume(mesh.point(t[0]), mesh.point(t[1]), mesh.point(t[2]),
                                    mesh.point(t[3])) < 0.0)
            std::swap(t[2], t[3]);
        mesh.add_tet(t[0], t[1], t[2], t[3], static_cast<core::Label>(std::lround(attr)));
    }
    mesh.faces = surface.faces;
    mesh.region_in = surface.region_in;
    mesh.region_out = surface.region_out;
    return mesh;
}

/// Two concentric UV spheres (radii r1 < r2): region 1 inside the inner one, region 2 between;
/// the inner sphere is the interface (region_in 1, region_out 2).
inline core::SurfaceNetwork nested_spheres(const core::SurfaceNetwork& inner,
                                           const core::SurfaceNetwork& outer) {
    core::SurfaceNetwork s = inner;
    const auto offset = static_cast<std::int32_t>(inner.xyz.size() / 3);
    for (auto& r : s.region_out) r = 2;
    s.xyz.insert(s.xyz.end(), outer.xyz.begin(), outer.xyz.end());
    for (std::size_t f = 0; f < outer.faces.size(); ++f) {
        s.faces.push_back(
            {outer.faces[f][0] + offset, outer.faces[f][1] + offset, outer.faces[f][2] + offset});
        s.region_in.push_back(2);
        s.region_out.push_back(0);
    }
    return s;
}

/// Two tets sharing face (0, 1, 2): apex 3 above, apex 4 below (a triangular bipyramid whose
/// axis 3-4 crosses the shared face), all nodes on the surface, region 1.
inline core::TetMesh bipyramid() {
    core::TetMesh m;
    m.add_node({0.0, 0.0, 0.0});
    m.add_node({1.0, 0.0, 0.0});
    m.add_node({0.0, 1.0, 0.0});
    m.add_node({0.3, 0.3, 0.8});
    m.add_node({0.35, 0.25, -0.9});
    m.add_tet(0, 1, 2, 3, 1);
    m.add_tet(0, 2, 1, 4, 1);
    m.faces = {{0, 1, 3}, {1, 2, 3}, {2, 0, 3}, {0, 4, 1}, {1, 4, 2}, {2, 4, 0}};
    m.region_in.assign(6, 1);
    m.region_out.assign(6, 0);
    m.surface_vertices = 5;
    return m;
}

/// The hull of `m`'s tets as faces (region_in 1, outside 0) and its nodes as surface nodes:
/// hand-made configurations whose interior node is `interior` (the last node).
inline void cone_from(core::TetMesh& m, const std::vector<std::array<std::int32_t, 3>>& hull,
                      const Eigen::Vector3d& interior) {
    const std::int32_t c = m.add_node(interior);
    for (const auto& f : hull) {
        // Hull faces are outward: the interior node is on the side opposite the normal.
        m.add_tet(f[0], f[2], f[1], c, 1);
        m.faces.push_back(f);
        m.region_in.push_back(1);
        m.region_out.push_back(0);
    }
    m.surface_vertices = c;
}

}  // namespace frontmesh::refine_fixtures
