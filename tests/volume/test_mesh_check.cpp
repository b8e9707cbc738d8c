// Our own tet-mesh checks: they must accept a valid conforming mesh and catch each kind of
// defect (the tetra and refine tests rely on them besides meshcheck.py).

#include <catch2/catch.hpp>

#include "pipeline/core/quality.h"
#include "tests/fixtures/phantoms.h"
#include "volume/mesh_check.h"

using namespace frontmesh;

TEST_CASE("A Kuhn-split cube is a valid mesh of its boundary", "[mesh_check]") {
    const core::TetMesh mesh = fixtures::cube_tet_mesh(3, 2.0);
    const volume::TetMeshCheck c = volume::check_tet_mesh(mesh);
    INFO(c.summary());
    CHECK(c.valid());
    CHECK(c.tets == 6 * 27);
    CHECK(mesh.face_count() == 6 * 9 * 2);
    CHECK(mesh.surface_vertices == 6 * 16 - 12 * 4 + 8);  // faces - edges + corners of a 4^3 grid
    CHECK(c.volume == Approx(216.0).epsilon(1e-12));
    CHECK(c.enclosed_volume == Approx(216.0).epsilon(1e-12));
    CHECK(c.unused_nodes == 0);
    // Kuhn tets: skewness well below 0.8, min dihedral 45 degrees (the path tets).
    CHECK(c.quality.skewness_over_08 == 0);
    CHECK(c.quality.min_dihedral_deg == Approx(45.0).margin(1e-9));
    CHECK(c.quality.max_dihedral_deg == Approx(90.0).margin(1e-9));
}

TEST_CASE("Two regions share their interface faces", "[mesh_check]") {
    const core::TetMesh mesh = fixtures::cube_tet_mesh(4, 1.0, true);
    const volume::TetMeshCheck c = volume::check_tet_mesh(mesh);
    INFO(c.summary());
    CHECK(c.valid());
    REQUIRE(c.region_volume.size() == 2);
    CHECK(c.region_volume.at(1) == Approx(32.0));
    CHECK(c.region_volume.at(2) == Approx(32.0));
    CHECK(c.region_enclosed_volume.at(1) == Approx(32.0));
    CHECK(c.region_enclosed_volume.at(2) == Approx(32.0));
    std::size_t interface = 0;
    for (std::size_t f = 0; f < mesh.face_count(); ++f)
        if (mesh.region_out[f] != 0) ++interface;
    CHECK(interface == 4 * 4 * 2);
    CHECK(c.region_quality.at(1).tets == 6 * 32);
}

TEST_CASE("Defects are caught one by one", "[mesh_check]") {
    const core::TetMesh good = fixtures::cube_tet_mesh(2, 1.0, true);
    REQUIRE(volume::check_tet_mesh(good).valid());

    SECTION("an inverted tet") {
        core::TetMesh m = good;
        std::swap(m.tets[5][0], m.tets[5][1]);
        const auto c = volume::check_tet_mesh(m);
        CHECK(c.inverted_tets == 1);
        CHECK(c.nonconforming_faces > 0);  // it now overlaps its neighbours
        CHECK_FALSE(c.valid());
    }
    SECTION("a missing tet") {
        core::TetMesh m = good;
        m.tets.erase(m.tets.begin() + 7);
        m.region.erase(m.region.begin() + 7);
        const auto c = volume::check_tet_mesh(m);
        CHECK(c.open_faces + c.missing_faces + c.wrong_side_faces > 0);
        CHECK(c.volume < volume::check_tet_mesh(good).volume);
        CHECK_FALSE(c.valid());
    }
    SECTION("a tet in the wrong region") {
        core::TetMesh m = good;
        m.region[0] = 2;  // a bottom tet: its boundary faces now meet region 2
        const auto c = volume::check_tet_mesh(m);
        CHECK(c.wrong_side_faces + c.open_faces > 0);
        CHECK_FALSE(c.valid());
    }
    SECTION("a boundary face listed with the wrong orientation") {
        core::TetMesh m = good;
        std::swap(m.faces[0][1], m.faces[0][2]);
        const auto c = volume::check_tet_mesh(m);
        CHECK(c.wrong_side_faces == 1);
        CHECK_FALSE(c.valid());
    }
    SECTION("a duplicated tet") {
        core::TetMesh m = good;
        m.add_tet(m.tets[3][0], m.tets[3][1], m.tets[3][2], m.tets[3][3], m.region[3]);
        const auto c = volume::check_tet_mesh(m);
        CHECK(c.nonconforming_faces == 4);
        CHECK_FALSE(c.valid());
    }
    SECTION("a flat tet") {
        core::TetMesh m = good;
        const auto t = m.tets[0];
        // Move an interior-free configuration: put node 3 of tet 0 in the plane of the others
        // on a fresh copy of the nodes, so only this tet sees the change.
        const std::int32_t a = m.add_node(m.point(t[0]));
        const std::int32_t b = m.add_node(m.point(t[1]));
        const std::int32_t c2 = m.add_node(m.point(t[2]));
        const std::int32_t d = m.add_node(0.5 * (m.point(t[0]) + m.point(t[1])));
        m.add_tet(a, b, c2, d, 1);
        const auto c = volume::check_tet_mesh(m);
        CHECK(c.inverted_tets == 1);
        CHECK(c.quality.skewness_over_08 >= 1);
        CHECK(c.quality.min_dihedral_deg == Approx(0.0).margin(1e-9));
    }
}
