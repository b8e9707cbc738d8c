// Editable tet topology of the refine stage: adjacency, stars, edge rings, walls, compaction.

#include <algorithm>

#include <catch2/catch.hpp>

#include "pipeline/core/quality.h"
#include "tests/fixtures/phantoms.h"
#include "volume/tet_topology.h"

using namespace frontmesh;
using volume::Tet;
using volume::TetTopology;

namespace {

int tets_holding(const core::TetMesh& m, std::int32_t a, std::int32_t b = -1) {
    int count = 0;
    for (const auto& t : m.tets)
        if (volume::local_index(t, a) >= 0 && (b < 0 || volume::local_index(t, b) >= 0)) ++count;
    return count;
}

}  // namespace

TEST_CASE("positive_tet follows the VTK orientation of TetMesh", "[refine]") {
    const Eigen::Vector3d a(0, 0, 0), b(1, 0, 0), c(0, 1, 0), d(0, 0, 1);
    REQUIRE(core::tet_signed_volume(a, b, c, d) > 0.0);
    CHECK(volume::positive_tet(a.data(), b.data(), c.data(), d.data()));
    CHECK_FALSE(volume::positive_tet(a.data(), c.data(), b.data(), d.data()));
    const Eigen::Vector3d flat(0.5, 0.5, 0.0);
    CHECK_FALSE(volume::positive_tet(a.data(), b.data(), c.data(), flat.data()));
}

TEST_CASE("Stars and edge rings of a Kuhn cube match brute force", "[refine]") {
    const core::TetMesh mesh = fixtures::cube_tet_mesh(3, 1.0);
    const TetTopology topo(mesh);
    REQUIRE(topo.check());
    std::vector<std::int32_t> star, ring_tets, ring;
    for (std::int32_t v = 0; v < static_cast<std::int32_t>(mesh.node_count()); ++v) {
        const bool closed = topo.star(v, star);
        CHECK(closed == (v >= mesh.surface_vertices));
        CHECK(static_cast<int>(star.size()) == tets_holding(mesh, v));
        for (const std::int32_t t : star) CHECK(volume::local_index(topo.tet(t), v) >= 0);
    }
    int closed_rings = 0, open_rings = 0;
    for (std::int32_t t = 0; t < topo.tet_capacity(); ++t) {
        const Tet& tt = topo.tet(t);
        for (int i = 0; i < 4; ++i)
            for (int j = i + 1; j < 4; ++j) {
                const std::int32_t a = tt[static_cast<std::size_t>(i)],
                                   b = tt[static_cast<std::size_t>(j)];
                const bool interior_edge = a >= mesh.surface_vertices || b >= mesh.surface_vertices;
                if (topo.edge_ring(a, b, t, ring_tets, ring)) {
                    ++closed_rings;
                    CHECK(static_cast<int>(ring.size()) == tets_holding(mesh, a, b));
                    for (std::size_t k = 0; k < ring.size(); ++k) {
                        const std::int32_t r0 = ring[k], r1 = ring[(k + 1) % ring.size()];
                        CHECK(volume::positive_tet(topo.xyz(a), topo.xyz(b), topo.xyz(r0),
                                                   topo.xyz(r1)));
                        const Tet& rt = topo.tet(ring_tets[k]);
                        CHECK(volume::local_index(rt, r0) >= 0);
                        CHECK(volume::local_index(rt, r1) >= 0);
                    }
                } else {
                    ++open_rings;
                    CHECK_FALSE(interior_edge);
                }
            }
    }
    CHECK(closed_rings > 0);
    CHECK(open_rings > 0);
    // Nothing edited: compaction gives the input back.
    const core::TetMesh out = topo.compact();
    CHECK(out.tets == mesh.tets);
    CHECK(out.xyz == mesh.xyz);
    CHECK(out.faces == mesh.faces);
}

TEST_CASE("Interface faces are walls between regions", "[refine]") {
    const core::TetMesh mesh = fixtures::cube_tet_mesh(4, 1.0, true);
    const TetTopology topo(mesh);
    REQUIRE(topo.check());
    std::size_t walls = 0, links = 0;
    for (std::int32_t t = 0; t < topo.tet_capacity(); ++t)
        for (int i = 0; i < 4; ++i) {
            const std::int32_t u = topo.neighbor(t, i);
            if (u < 0)
                ++walls;
            else {
                ++links;
                CHECK(topo.region(u) == topo.region(t));
            }
        }
    // Every boundary or interface triangle is a wall on each side where a tet has it.
    std::size_t interface_faces = 0;
    for (std::size_t f = 0; f < mesh.face_count(); ++f)
        if (mesh.region_out[f] != 0) ++interface_faces;
    CHECK(interface_faces > 0);
    CHECK(walls == mesh.face_count() + interface_faces);
    CHECK(links + walls == 4 * mesh.tet_count());
}

TEST_CASE("replace keeps adjacency valid and reuses ids", "[refine]") {
    core::TetMesh mesh = fixtures::cube_tet_mesh(2, 1.0);
    TetTopology topo(mesh);
    // The centre node of a 3x3x3 grid is interior; re-fan its star from one link node.
    const std::int32_t v = mesh.surface_vertices;
    std::vector<std::int32_t> star;
    REQUIRE(topo.star(v, star));
    REQUIRE(star.size() == 24);
    // Replace the star by itself (same tets): adjacency must be rebuilt identically.
    std::vector<Tet> same;
    for (const std::int32_t t : star) same.push_back(topo.tet(t));
    std::vector<std::int32_t> ids;
    topo.replace(star, same, 1, &ids);
    CHECK(ids == star);
    CHECK(topo.check());
    CHECK(topo.alive_tets() == mesh.tet_count());
}

#include <random>

#include "volume/refine_ops.h"

TEST_CASE("tet_shape agrees with core quality measures", "[refine]") {
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (int k = 0; k < 2000; ++k) {
        Eigen::Vector3d p[4];
        for (auto& x : p) x = Eigen::Vector3d(u(rng), u(rng), u(rng));
        if (k % 3 == 0)
            p[3] = 0.5 * (p[0] + p[1]) + 1e-3 * Eigen::Vector3d(u(rng), u(rng), u(rng));  // slivers
        const double volume = core::tet_signed_volume(p[0], p[1], p[2], p[3]);
        const double l = (p[1] - p[0]).norm() + (p[2] - p[0]).norm() + (p[3] - p[0]).norm();
        if (std::abs(volume) < 1e-5 * l * l * l) continue;  // the flat guard is tested below
        const volume::TetShape s =
            volume::tet_shape(p[0].data(), p[1].data(), p[2].data(), p[3].data(), true);
        CHECK(s.skewness == Approx(core::tet_skewness(p[0], p[1], p[2], p[3])).margin(1e-9));
        CHECK(s.min_dihedral_deg ==
              Approx(core::tet_min_dihedral_deg(p[0], p[1], p[2], p[3])).margin(1e-6));
    }
    // Four co-circular, coplanar-but-for-rounding nodes: degenerate, whatever Eq. 1 would say.
    const Eigen::Vector3d a(1, 0, 0), b(0, 1, 0), c(-1, 0, 0), d(0, -1, 1e-14);
    const volume::TetShape flat = volume::tet_shape(a.data(), b.data(), c.data(), d.data(), true);
    CHECK(flat.skewness == 1.0);
    CHECK(flat.min_dihedral_deg == 0.0);
}
