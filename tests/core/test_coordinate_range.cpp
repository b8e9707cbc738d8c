// require_coordinates_in_range (issue 21, item 7): points astray, non-finite or a geometry
// scaled to nothing are bad input named by the point and its position.

#include <limits>
#include <vector>

#include <catch2/catch.hpp>

#include "pipeline/core/coordinate_range.h"
#include "pipeline/core/error.h"
#include "tests/fixtures/phantoms.h"

using Catch::Matchers::Contains;
using frontmesh::core::InputError;
using frontmesh::core::require_coordinates_in_range;

TEST_CASE("coordinates within range and a geometry of some size pass", "[core][coordinates]") {
    const auto sphere = frontmesh::fixtures::uv_sphere(10.0, 12);
    CHECK_NOTHROW(require_coordinates_in_range(sphere.xyz, "in.vtp"));
    CHECK_NOTHROW(require_coordinates_in_range({}, "in.vtp"));
    // At the limits: 1e7 mm from the origin, 1e-4 mm across.
    CHECK_NOTHROW(require_coordinates_in_range({1e7, -1e7, 0.0, 1e7, -1e7, 1.0}, "in.vtp"));
    CHECK_NOTHROW(require_coordinates_in_range({0.0, 0.0, 0.0, 1e-4, 0.0, 0.0}, "in.vtp"));
}

TEST_CASE("a point astray or non-finite and a geometry too small are refused by name",
          "[core][coordinates]") {
    std::vector<double> xyz = frontmesh::fixtures::uv_sphere(10.0, 12).xyz;
    SECTION("one vertex at 1e30 mm") {
        xyz[3 * 7 + 1] = 1e30;
        CHECK_THROWS_AS(require_coordinates_in_range(xyz, "in.vtp"), InputError);
        CHECK_THROWS_WITH(require_coordinates_in_range(xyz, "in.vtp"),
                          Contains("in.vtp: point 7 at (") && Contains("1e+30") &&
                              Contains("out of range") && Contains("1e+07 mm") && !Contains("\n"));
    }
    SECTION("moved to 1e12 mm") {
        for (std::size_t i = 0; i < xyz.size(); i += 3) xyz[i] += 1e12;
        CHECK_THROWS_WITH(require_coordinates_in_range(xyz, "in.vtp"),
                          Contains("point 0 at") && Contains("out of range"));
    }
    SECTION("just beyond the limit") {
        xyz[2] = -1.0000001e7;
        CHECK_THROWS_AS(require_coordinates_in_range(xyz, "in.vtp"), InputError);
    }
    SECTION("a non-finite coordinate") {
        xyz[3 * 4] = std::numeric_limits<double>::quiet_NaN();
        CHECK_THROWS_WITH(require_coordinates_in_range(xyz, "in.vtp"),
                          Contains("point 4 has a non-finite coordinate"));
        xyz[3 * 4] = std::numeric_limits<double>::infinity();
        CHECK_THROWS_WITH(require_coordinates_in_range(xyz, "in.vtp"),
                          Contains("point 4 has a non-finite coordinate"));
    }
    SECTION("scaled by 1e-30") {
        for (double& c : xyz) c *= 1e-30;
        CHECK_THROWS_AS(require_coordinates_in_range(xyz, "in.vtp"), InputError);
        CHECK_THROWS_WITH(require_coordinates_in_range(xyz, "in.vtp"),
                          Contains("in.vtp: the geometry is 2e-29 mm across") &&
                              Contains("too small to mesh") && Contains("0.0001"));
    }
    SECTION("every point in one place, far from the origin") {
        for (std::size_t i = 0; i < xyz.size(); i += 3) {
            xyz[i] = 5.0;
            xyz[i + 1] = 6.0;
            xyz[i + 2] = 7.0;
        }
        CHECK_THROWS_WITH(require_coordinates_in_range(xyz, "in.vtp"),
                          Contains("0 mm across") && Contains("(5, 6, 7) mm"));
    }
}
