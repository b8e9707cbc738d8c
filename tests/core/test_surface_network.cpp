#include <algorithm>
#include <cmath>
#include <vector>

#include <catch2/catch.hpp>

#include "pipeline/core/predicates.h"
#include "pipeline/core/self_intersection.h"
#include "pipeline/core/surface_network.h"
#include "tests/fixtures/phantoms.h"

using namespace frontmesh;
using core::Label;
using core::RegionBoundaryCheck;
using core::SurfaceNetwork;

namespace {

const RegionBoundaryCheck* find_check(const std::vector<RegionBoundaryCheck>& checks,
                                      Label region) {
    for (const auto& c : checks)
        if (c.region == region) return &c;
    return nullptr;
}

// Adds the four faces of tetrahedron `v` oriented outward from `in`, except those listed in
// `skip` (given as the opposite vertex's position in v).
void add_tet_boundary(SurfaceNetwork& s, const std::array<std::int32_t, 4>& v, Label in, Label out,
                      std::vector<int> skip = {}) {
    for (int l = 0; l < 4; ++l) {
        if (std::find(skip.begin(), skip.end(), l) != skip.end()) continue;
        std::int32_t f[3], n = 0;
        for (int k = 0; k < 4; ++k)
            if (k != l) f[n++] = v[static_cast<std::size_t>(k)];
        // Outward: the opposite vertex lies below the counter-clockwise face.
        if (core::orient3d(s.point(f[0]), s.point(f[1]), s.point(f[2]),
                           s.point(v[static_cast<std::size_t>(l)])) < 0)
            std::swap(f[1], f[2]);
        s.add_face(f[0], f[1], f[2], in, out);
    }
}

void translate(SurfaceNetwork& s, const Eigen::Vector3d& t) {
    for (std::size_t v = 0; v < s.vertex_count(); ++v) s.point(static_cast<std::int32_t>(v)) += t;
}

}  // namespace

TEST_CASE("the octahedron is closed, outward and of volume 4/3 r^3", "[core]") {
    SurfaceNetwork s = fixtures::octahedron(2.0);
    CHECK(core::region_labels(s) == std::vector<Label>{1});
    const auto checks = core::check_region_boundaries(s);
    REQUIRE(checks.size() == 1);
    const auto& c = checks[0];
    CHECK(c.region == 1);
    CHECK(c.faces == s.face_count());
    CHECK(c.open_edges == 0);
    CHECK(c.misoriented_edges == 0);
    CHECK(c.nonmanifold_edges == 0);
    CHECK(c.is_closed());
    CHECK(c.is_oriented());
    CHECK(c.volume == Approx(4.0 / 3.0 * 8.0).epsilon(1e-12));
    CHECK(core::enclosed_volume(s, 1) == Approx(c.volume).epsilon(1e-15));
    CHECK(core::enclosed_volume(s, 7) == 0.0);  // a label that is absent
    // A closed surface encloses the same volume wherever it is.
    translate(s, {100.0, -250.0, 31.5});
    CHECK(core::enclosed_volume(s, 1) == Approx(4.0 / 3.0 * 8.0).epsilon(1e-9));
}

TEST_CASE("uv spheres are closed manifolds whose volume converges to the ball's", "[core]") {
    const double radius = 2.0, ball = fixtures::ball_volume(radius);
    double previous_error = 1.0;
    for (int n : {12, 24, 48}) {
        const SurfaceNetwork s = fixtures::uv_sphere(radius, n);
        const auto checks = core::check_region_boundaries(s);
        REQUIRE(checks.size() == 1);
        CHECK(checks[0].is_closed());
        CHECK(checks[0].is_oriented());
        CHECK(checks[0].nonmanifold_edges == 0);
        // Euler characteristic of a sphere: V - E + F = 2 with E = 3F/2.
        CHECK(2 * static_cast<long>(s.vertex_count()) - static_cast<long>(s.face_count()) == 4);
        // An inscribed polyhedron: smaller than the ball, and closer as n grows (O(1/n^2)).
        const double error = (ball - checks[0].volume) / ball;
        CHECK(error > 0.0);
        CHECK(error < previous_error / 3.0);
        previous_error = error;
    }
    CHECK(previous_error < 0.01);
}

TEST_CASE("a flipped face is reported as misoriented", "[core]") {
    SurfaceNetwork s = fixtures::octahedron(1.0);
    std::swap(s.faces[2][1], s.faces[2][2]);
    const auto checks = core::check_region_boundaries(s);
    REQUIRE(checks.size() == 1);
    CHECK(checks[0].is_closed());
    CHECK(checks[0].misoriented_edges == 3);
    CHECK_FALSE(checks[0].is_oriented());
    CHECK(checks[0].volume < 4.0 / 3.0);

    // Every face flipped: consistent, but inward, so the volume is negative.
    SurfaceNetwork inward = fixtures::octahedron(1.0);
    for (auto& f : inward.faces) std::swap(f[1], f[2]);
    const auto inward_checks = core::check_region_boundaries(inward);
    CHECK(inward_checks[0].misoriented_edges == 0);
    CHECK(inward_checks[0].volume == Approx(-4.0 / 3.0).epsilon(1e-12));
    CHECK_FALSE(inward_checks[0].is_oriented());
}

TEST_CASE("a missing face leaves a hole of three open edges", "[core]") {
    SurfaceNetwork s = fixtures::uv_sphere(1.0, 10);
    const std::size_t removed = s.face_count() / 2;
    s.faces.erase(s.faces.begin() + static_cast<std::ptrdiff_t>(removed));
    s.region_in.erase(s.region_in.begin() + static_cast<std::ptrdiff_t>(removed));
    s.region_out.erase(s.region_out.begin() + static_cast<std::ptrdiff_t>(removed));
    const auto checks = core::check_region_boundaries(s);
    REQUIRE(checks.size() == 1);
    CHECK(checks[0].open_edges == 3);
    CHECK_FALSE(checks[0].is_closed());
    CHECK(checks[0].misoriented_edges == 0);
}

TEST_CASE("two regions sharing an interface stored once", "[core]") {
    // Region 1 above z = 0, region 2 below; the triangle in z = 0 separates them.
    SurfaceNetwork s;
    for (const Eigen::Vector3d& p :
         {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 1, 0),
          Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0, 0, -1)})
        s.add_vertex(p);
    add_tet_boundary(s, {0, 1, 2, 3}, 1, 0, {3});  // all but the interface
    add_tet_boundary(s, {0, 1, 2, 4}, 2, 0, {3});
    add_tet_boundary(s, {0, 1, 2, 3}, 1, 2, {0, 1, 2});  // the interface, outward from 1
    REQUIRE(s.face_count() == 7);
    CHECK(core::region_labels(s) == std::vector<Label>{1, 2});

    auto checks = core::check_region_boundaries(s);
    REQUIRE(checks.size() == 2);
    for (Label region : {1, 2}) {
        const auto* c = find_check(checks, region);
        REQUIRE(c != nullptr);
        CHECK(c->faces == 4);  // the interface counts for both
        CHECK(c->is_closed());
        CHECK(c->is_oriented());
        CHECK(c->nonmanifold_edges == 0);
        CHECK(c->volume == Approx(1.0 / 6.0).epsilon(1e-12));
        CHECK(core::enclosed_volume(s, region) == Approx(1.0 / 6.0).epsilon(1e-12));
    }
    CHECK(core::self_intersections(s).empty());

    // The interface with region_in and region_out swapped is wrong for both.
    std::swap(s.region_in[6], s.region_out[6]);
    checks = core::check_region_boundaries(s);
    for (Label region : {1, 2}) {
        const auto* c = find_check(checks, region);
        REQUIRE(c != nullptr);
        CHECK(c->is_closed());
        CHECK(c->misoriented_edges == 3);
        CHECK_FALSE(c->is_oriented());
    }
}

TEST_CASE("two tetrahedra of one region sharing only an edge are non-manifold", "[core]") {
    SurfaceNetwork s;
    for (const Eigen::Vector3d& p :
         {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(1, 0, 0),
          Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(-1, 0, 0), Eigen::Vector3d(0, -1, 0)})
        s.add_vertex(p);
    add_tet_boundary(s, {0, 1, 2, 3}, 1, 0);
    add_tet_boundary(s, {0, 1, 4, 5}, 1, 0);
    const auto checks = core::check_region_boundaries(s);
    REQUIRE(checks.size() == 1);
    CHECK(checks[0].nonmanifold_edges == 1);
    CHECK(checks[0].is_closed());
    CHECK(checks[0].is_oriented());
    CHECK(checks[0].volume == Approx(2.0 / 6.0).epsilon(1e-12));
}
