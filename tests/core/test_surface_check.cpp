// require_meshable_surface: the tetra stage's precondition on a user's surface (issue 20
// item 4). Each defect is one InputError naming the defect, the region and a position.

#include <limits>

#include <catch2/catch.hpp>

#include "pipeline/core/error.h"
#include "pipeline/core/surface_check.h"
#include "tests/fixtures/phantoms.h"

using Catch::Matchers::Contains;
using frontmesh::core::InputError;
using frontmesh::core::require_meshable_surface;
using frontmesh::core::SurfaceNetwork;

namespace {

// Two octahedra side by side: regions 1 and 2, both closed and outward.
SurfaceNetwork two_shells() {
    SurfaceNetwork a = frontmesh::fixtures::octahedron(1.0);
    const SurfaceNetwork b = frontmesh::fixtures::octahedron(1.0);
    const auto offset = static_cast<std::int32_t>(a.vertex_count());
    for (std::size_t v = 0; v < b.vertex_count(); ++v)
        a.add_vertex(b.point(std::int32_t(v)) + Eigen::Vector3d(5.0, 0.0, 0.0));
    for (std::size_t f = 0; f < b.face_count(); ++f)
        a.add_face(b.faces[f][0] + offset, b.faces[f][1] + offset, b.faces[f][2] + offset, 2, 0);
    return a;
}

// Octahedron `inner` (radius r at the origin) added to `s` with the given regions; reversed
// when `reversed` (its right-hand normals point into it).
void add_octahedron(SurfaceNetwork& s, double r, const Eigen::Vector3d& at,
                    frontmesh::core::Label in, frontmesh::core::Label out, bool reversed) {
    const SurfaceNetwork b = frontmesh::fixtures::octahedron(r);
    const auto offset = static_cast<std::int32_t>(s.vertex_count());
    for (std::size_t v = 0; v < b.vertex_count(); ++v) s.add_vertex(b.point(std::int32_t(v)) + at);
    for (const auto& t : b.faces) {
        if (reversed)
            s.add_face(t[0] + offset, t[2] + offset, t[1] + offset, in, out);
        else
            s.add_face(t[0] + offset, t[1] + offset, t[2] + offset, in, out);
    }
}

void require_defect(const SurfaceNetwork& s, const std::string& words) {
    CHECK_THROWS_AS(require_meshable_surface(s, "in.vtp"), InputError);
    CHECK_THROWS_WITH(require_meshable_surface(s, "in.vtp"),
                      Contains("in.vtp: ") && Contains(words) && !Contains("\n"));
}

}  // namespace

TEST_CASE("a closed, oriented, clean surface network is meshable", "[core][surface_check]") {
    CHECK_NOTHROW(require_meshable_surface(frontmesh::fixtures::octahedron(2.0), "in.vtp"));
    CHECK_NOTHROW(require_meshable_surface(two_shells(), "in.vtp"));
    CHECK_NOTHROW(require_meshable_surface(frontmesh::fixtures::uv_sphere(3.0, 12), "in.vtp"));
    // Holes: a part of region 1 with negative volume inside its outer part, filled by region
    // 2 or empty (its faces point into the hole, out of region 1).
    SurfaceNetwork filled = frontmesh::fixtures::octahedron(2.0);
    add_octahedron(filled, 0.5, Eigen::Vector3d::Zero(), 2, 1, false);
    CHECK_NOTHROW(require_meshable_surface(filled, "in.vtp"));
    SurfaceNetwork empty = frontmesh::fixtures::octahedron(2.0);
    add_octahedron(empty, 0.5, Eigen::Vector3d::Zero(), 1, 0, true);
    CHECK_NOTHROW(require_meshable_surface(empty, "in.vtp"));
}

TEST_CASE("a part of a region turned inside out is a defect though every edge is in order",
          "[core][surface_check]") {
    // Region 1: a large octahedron and, beside it, a small one whose faces point into it
    // (the two sides of a thin piece crossed through each other): the total volume is
    // positive and every edge alternates, but the region's winding number is 0 behind the
    // small part's faces.
    SurfaceNetwork s = frontmesh::fixtures::octahedron(2.0);
    add_octahedron(s, 0.5, Eigen::Vector3d(5.0, 0.0, 0.0), 1, 0, true);
    require_defect(s, "turned inside out");
    CHECK_THROWS_WITH(require_meshable_surface(s, "in.vtp"),
                      Contains("region 1") && Contains("mm"));
    const auto parts = frontmesh::core::inverted_parts(s);
    REQUIRE(parts.size() == 1);
    CHECK(parts[0].faces.size() == 8);
    CHECK(parts[0].faces.front() == 8);
    CHECK(std::abs(parts[0].winding) < 0.01);
    CHECK(parts[0].place.x() > 4.0);
}

TEST_CASE("each defect of a user's surface is named with its region and place",
          "[core][surface_check]") {
    SurfaceNetwork s = two_shells();
    SECTION("open") {
        s.faces.pop_back();
        s.region_in.pop_back();
        s.region_out.pop_back();
        require_defect(s, "open boundary of region 2");
        CHECK_THROWS_WITH(require_meshable_surface(s, "in.vtp"), Contains("mm"));
    }
    SECTION("one face flipped") {
        std::swap(s.faces[3][0], s.faces[3][1]);
        require_defect(s, "misoriented boundary of region 1");
    }
    SECTION("every face of a region flipped") {
        for (std::size_t f = 8; f < 16; ++f) std::swap(s.faces[f][0], s.faces[f][1]);
        require_defect(s, "region 2 encloses -");
    }
    SECTION("a face with the same region on both sides") {
        s.region_out[0] = 1;
        require_defect(s, "region_out is 1");
    }
    SECTION("a face without a region behind it") {
        s.region_in[0] = 0;
        require_defect(s, "region_in is 0");
    }
    SECTION("a zero-area face") {
        s.point(s.faces[0][2]) = 0.5 * (s.point(s.faces[0][0]) + s.point(s.faces[0][1]));
        require_defect(s, "zero area");
    }
    SECTION("a vertex id out of range") {
        s.faces[2][1] = 1000;
        require_defect(s, "names vertex 1000");
    }
    SECTION("a non-finite coordinate") {
        s.point(0).x() = std::numeric_limits<double>::quiet_NaN();
        require_defect(s, "non-finite");
    }
    SECTION("two shells crossing each other") {
        for (std::size_t v = 6; v < 12; ++v) s.point(std::int32_t(v)).x() -= 4.5;
        require_defect(s, "intersect");
    }
}

// tetra keeps every given triangle: a face on which every tet would be degenerate to the
// referee is refused before tetra (campaign seed 8: a nearly collinear face, area 1e-15 mm^2,
// gave exit 0 and a mesh meshcheck called INVALID). A point put into one face of an
// octahedron at distance d from a corner makes two faces of height about d.
TEST_CASE("a face too flat or too small for any tet is refused for tetra",
          "[core][surface_check]") {
    auto with_point_near_corner = [](double d) {
        SurfaceNetwork s = frontmesh::fixtures::octahedron(2.0);
        const auto [a, b, c] = s.faces[0];
        const Eigen::Vector3d p =
            s.point(a) + d * ((s.point(b) + s.point(c)) / 2.0 - s.point(a)).normalized();
        const auto q = static_cast<std::int32_t>(s.vertex_count());
        s.add_vertex(p);
        s.faces[0] = {a, b, q};
        s.add_face(b, c, q, s.region_in[0], s.region_out[0]);
        s.add_face(c, a, q, s.region_in[0], s.region_out[0]);
        return s;
    };
    using frontmesh::core::require_tetra_ready_faces;
    const SurfaceNetwork fine = with_point_near_corner(1e-3);
    CHECK_NOTHROW(require_meshable_surface(fine, "in.vtp"));
    CHECK_NOTHROW(require_tetra_ready_faces(fine, "in.vtp"));
    const SurfaceNetwork flat = with_point_near_corner(1e-12);
    CHECK_NOTHROW(require_meshable_surface(flat, "in.vtp"));  // exact: not collinear
    CHECK_THROWS_AS(require_tetra_ready_faces(flat, "in.vtp"), InputError);
    CHECK_THROWS_WITH(require_tetra_ready_faces(flat, "in.vtp"),
                      Contains("in.vtp: face") && Contains("too small or too flat") &&
                          Contains("region 1") && !Contains("\n"));
}

// The referee calls a mesh invalid when the domain's outer boundary is no 2-manifold, so
// bodies touching along an edge or at a point are refused before tetra (they gave exit 0
// and an INVALID mesh); inside another region the same contact is fine.
TEST_CASE("bodies touching on the outer boundary are refused, inside a region they are not",
          "[core][surface_check]") {
    auto touching = [](const Eigen::Vector3d& shift, frontmesh::core::Label in,
                       frontmesh::core::Label out) {
        SurfaceNetwork s;
        for (const Eigen::Vector3d& at : {Eigen::Vector3d::Zero().eval(), shift})
            add_octahedron(s, 1.0, at, in, out, false);
        // weld the coincident vertices
        std::vector<std::int32_t> id(s.vertex_count());
        for (std::size_t v = 0; v < s.vertex_count(); ++v) {
            id[v] = static_cast<std::int32_t>(v);
            for (std::size_t w = 0; w < v; ++w)
                if ((s.point(std::int32_t(v)) - s.point(std::int32_t(w))).norm() < 1e-12)
                    id[v] = id[w];
        }
        for (auto& t : s.faces)
            for (auto& v : t) v = id[static_cast<std::size_t>(v)];
        return s;
    };
    using frontmesh::core::outer_boundary_defect;
    const SurfaceNetwork edge = touching({1.0, 1.0, 0.0}, 1, 0);
    REQUIRE(outer_boundary_defect(edge));
    CHECK_THAT(*outer_boundary_defect(edge), Contains("at edge") && Contains("4 faces"));
    require_defect(edge, "outer boundary is not a manifold at edge");
    const SurfaceNetwork point = touching({2.0, 0.0, 0.0}, 1, 0);
    REQUIRE(outer_boundary_defect(point));
    CHECK_THAT(*outer_boundary_defect(point), Contains("at vertex") && Contains("(1, 0, 0)"));
    require_defect(point, "outer boundary is not a manifold at vertex");
    SurfaceNetwork inside = touching({2.0, 0.0, 0.0}, 1, 2);
    add_octahedron(inside, 10.0, Eigen::Vector3d::Zero(), 2, 0, false);
    CHECK_FALSE(outer_boundary_defect(inside));
    CHECK_NOTHROW(require_meshable_surface(inside, "in.vtp"));
}
