// Refine stage (§3.3): each local operation on hand-made configurations, then whole meshes
// made by tetgen (poor input: no quality bound) checked with check_tet_mesh and meshcheck.

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <numeric>
#include <random>

#include <tbb/global_control.h>
#include <catch2/catch.hpp>

#include "io/mesh_io.h"
#include "pipeline/core/error.h"
#include "pipeline/core/quality.h"
#include "tests/fixtures/phantoms.h"
#include "tests/fixtures/referee.h"
#include "tests/fixtures/skip.h"
#include "tests/volume/refine_fixtures.h"
#include "volume/mesh_check.h"
#include "volume/refine.h"
#include "volume/refine_ops.h"
#include "volume/tet_topology.h"

using namespace frontmesh;
using volume::Objective;
using volume::RefineOps;
using volume::RefineParams;
using volume::Tet;
using volume::TetTopology;

namespace {

std::vector<Tet> canonical(const core::TetMesh& m) {
    // Each oriented tet as the smallest of its 12 even permutations, then sorted.
    static constexpr int kEven[12][4] = {{0, 1, 2, 3}, {0, 2, 3, 1}, {0, 3, 1, 2}, {1, 0, 3, 2},
                                         {1, 2, 0, 3}, {1, 3, 2, 0}, {2, 0, 1, 3}, {2, 1, 3, 0},
                                         {2, 3, 0, 1}, {3, 0, 2, 1}, {3, 1, 0, 2}, {3, 2, 1, 0}};
    std::vector<Tet> out;
    for (const Tet& t : m.tets) {
        Tet best = t;
        for (const auto& p : kEven) {
            const Tet q{t[static_cast<std::size_t>(p[0])], t[static_cast<std::size_t>(p[1])],
                        t[static_cast<std::size_t>(p[2])], t[static_cast<std::size_t>(p[3])]};
            best = std::min(best, q);
        }
        out.push_back(best);
    }
    std::sort(out.begin(), out.end());
    return out;
}

double max_skewness(const core::TetMesh& m) { return volume::tet_quality(m).max_skewness; }

bool same_surface(const core::TetMesh& a, const core::TetMesh& b) {
    if (a.surface_vertices != b.surface_vertices || a.faces != b.faces ||
        a.region_in != b.region_in || a.region_out != b.region_out)
        return false;
    return std::equal(a.xyz.begin(), a.xyz.begin() + 3 * a.surface_vertices, b.xyz.begin());
}

}  // namespace

TEST_CASE("A 2-3 flip then a 3-2 flip restore the bipyramid", "[refine]") {
    const core::TetMesh input = refine_fixtures::bipyramid();
    REQUIRE(volume::check_tet_mesh(input).valid());
    const double volume_before = volume::check_tet_mesh(input).volume;
    TetTopology topo(input);
    RefineParams params;
    RefineOps ops(topo, params);
    ops.set_unconditional(true);  // the round trip cannot improve quality both ways

    REQUIRE(ops.flip_2_3(0, 3, Objective::Skewness));  // face (0,1,2) opposite node 3
    CHECK(ops.counts.flips_2_3 == 1);
    CHECK(topo.alive_tets() == 3);
    REQUIRE(topo.check());
    const core::TetMesh three = topo.compact();
    const auto c3 = volume::check_tet_mesh(three);
    INFO(c3.summary());
    CHECK(c3.valid());
    CHECK(c3.volume == Approx(volume_before).epsilon(1e-12));
    for (const Tet& t : three.tets) {  // every new tet holds the new edge 3-4
        CHECK(volume::local_index(t, 3) >= 0);
        CHECK(volume::local_index(t, 4) >= 0);
    }

    std::int32_t holder = -1;
    for (std::int32_t t = 0; t < topo.tet_capacity(); ++t)
        if (topo.alive(t)) holder = t;
    REQUIRE(ops.remove_edge(3, 4, holder, Objective::Skewness));
    CHECK(ops.counts.flips_3_2 == 1);
    REQUIRE(topo.check());
    const core::TetMesh two = topo.compact();
    const auto c2 = volume::check_tet_mesh(two);
    CHECK(c2.valid());
    CHECK(c2.volume == Approx(volume_before).epsilon(1e-12));
    CHECK(canonical(two) == canonical(input));
}

TEST_CASE("Flips are refused when invalid or not better", "[refine]") {
    // Apex 4 far to the side: segment 3-4 misses face (0,1,2), a 2-3 flip would invert a tet.
    core::TetMesh input = refine_fixtures::bipyramid();
    input.point(4) = Eigen::Vector3d(2.5, 2.0, -0.3);
    REQUIRE(volume::check_tet_mesh(input).valid());
    {
        TetTopology topo(input);
        RefineOps ops(topo, RefineParams{});
        ops.set_unconditional(true);
        CHECK_FALSE(ops.flip_2_3(0, 3, Objective::Skewness));
        CHECK(topo.compact().tets == input.tets);
    }
    // With the quality criterion, the round trip can go one way at most.
    const core::TetMesh good = refine_fixtures::bipyramid();
    TetTopology topo(good);
    RefineOps ops(topo, RefineParams{});
    const bool forward = ops.flip_2_3(0, 3, Objective::Skewness);
    if (forward) {
        CHECK(max_skewness(topo.compact()) < max_skewness(good));
        for (std::int32_t t = 0; t < topo.tet_capacity(); ++t)
            if (topo.alive(t)) CHECK_FALSE(ops.remove_edge(3, 4, t, Objective::Skewness));
    } else {
        CHECK(topo.compact().tets == good.tets);
    }
}

TEST_CASE("Node removal: a node inside a tetrahedron and inside a bipyramid", "[refine]") {
    SECTION("four tets around the node") {
        core::TetMesh m;
        m.add_node({0, 0, 0});
        m.add_node({1, 0, 0});
        m.add_node({0, 1, 0});
        m.add_node({0, 0, 1});
        refine_fixtures::cone_from(m, {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}},
                                   {0.2, 0.3, 0.25});
        REQUIRE(m.tet_count() == 4);
        REQUIRE(volume::check_tet_mesh(m).valid());
        TetTopology topo(m);
        RefineOps ops(topo, RefineParams{});
        ops.remove_nodes();
        CHECK(ops.counts.nodes_removed == 1);
        const core::TetMesh out = topo.compact();
        const auto c = volume::check_tet_mesh(out);
        INFO(c.summary());
        CHECK(c.valid());
        CHECK(out.tet_count() == 1);
        CHECK(out.node_count() == 4);
        CHECK(c.volume == Approx(1.0 / 6.0).epsilon(1e-12));
    }
    SECTION("six tets around the node") {
        const core::TetMesh bp = refine_fixtures::bipyramid();
        core::TetMesh m;
        m.xyz = bp.xyz;
        refine_fixtures::cone_from(m, bp.faces, {0.3, 0.3, 0.05});
        REQUIRE(m.tet_count() == 6);
        const auto before = volume::check_tet_mesh(m);
        REQUIRE(before.valid());
        TetTopology topo(m);
        RefineOps ops(topo, RefineParams{});
        ops.remove_nodes();
        CHECK(ops.counts.nodes_removed == 1);
        const core::TetMesh out = topo.compact();
        const auto c = volume::check_tet_mesh(out);
        CHECK(c.valid());
        CHECK((out.tet_count() == 2 || out.tet_count() == 3));
        CHECK(c.volume == Approx(before.volume).epsilon(1e-12));
        CHECK(same_surface(out, m));
    }
    SECTION("a star too large is kept") {
        core::TetMesh m = fixtures::cube_tet_mesh(2, 1.0);  // centre node: 24 tets
        TetTopology topo(m);
        RefineOps ops(topo, RefineParams{});
        ops.remove_nodes();
        CHECK(ops.counts.nodes_removed == 0);
    }
}

TEST_CASE("Smoothing moves a displaced node back and never inverts", "[refine]") {
    core::TetMesh m = fixtures::cube_tet_mesh(2, 1.0);
    const std::int32_t v = m.surface_vertices;  // the centre (1,1,1)
    REQUIRE(m.point(v).isApprox(Eigen::Vector3d(1, 1, 1)));
    m.point(v) = Eigen::Vector3d(1.35, 0.8, 1.3);
    const auto before = volume::check_tet_mesh(m);
    REQUIRE(before.valid());
    TetTopology topo(m);
    RefineOps ops(topo, RefineParams{});
    ops.smooth();
    CHECK(ops.counts.smoothing_moves == 1);
    const core::TetMesh out = topo.compact();
    const auto after = volume::check_tet_mesh(out);
    CHECK(after.valid());
    CHECK(after.quality.max_skewness <= before.quality.max_skewness);
    CHECK(after.quality.mean_skewness < before.quality.mean_skewness);
    CHECK((out.point(v) - Eigen::Vector3d(1, 1, 1)).norm() <
          (m.point(v) - Eigen::Vector3d(1, 1, 1)).norm());
    CHECK(same_surface(out, m));
}

TEST_CASE("Smoothing a jittered tetgen mesh keeps it valid and the worst tet no worse",
          "[refine]") {
    const std::string dir = fixtures::temp_dir("refine_smooth");
    core::TetMesh m = refine_fixtures::tetgen_mesh(fixtures::uv_sphere(10.0, 12), dir, "pYq1.3Q");
    REQUIRE(static_cast<std::int32_t>(m.node_count()) > m.surface_vertices + 20);
    // Jitter interior nodes (keeping every tet positive) to make a poor mesh.
    {
        TetTopology topo(m);
        std::mt19937 rng(7);
        std::uniform_real_distribution<double> u(-0.8, 0.8);
        std::vector<std::int32_t> star;
        for (std::int32_t v = m.surface_vertices; v < topo.node_capacity(); ++v) {
            if (!topo.star(v, star)) continue;
            const Eigen::Vector3d p0 = topo.point(v);
            topo.set_point(v, p0 + Eigen::Vector3d(u(rng), u(rng), u(rng)));
            for (const std::int32_t t : star) {
                const Tet& tt = topo.tet(t);
                if (!volume::positive_tet(topo.xyz(tt[0]), topo.xyz(tt[1]), topo.xyz(tt[2]),
                                          topo.xyz(tt[3]))) {
                    topo.set_point(v, p0);
                    break;
                }
            }
        }
        m = topo.compact();
    }
    const auto before = volume::check_tet_mesh(m);
    REQUIRE(before.valid());
    TetTopology topo(m);
    RefineOps ops(topo, RefineParams{});
    for (int k = 0; k < 3; ++k) ops.smooth();
    CHECK(ops.counts.smoothing_moves > 0);
    const core::TetMesh out = topo.compact();
    const auto after = volume::check_tet_mesh(out);
    INFO(before.summary() << "\n" << after.summary());
    CHECK(after.valid());
    CHECK(after.quality.max_skewness <= before.quality.max_skewness);
    CHECK(after.quality.mean_skewness < before.quality.mean_skewness);
    CHECK(same_surface(out, m));
}

TEST_CASE("Refine of a two-region tetgen mesh keeps surfaces and regions", "[refine]") {
    const std::string dir = fixtures::temp_dir("refine_two_regions");
    const core::SurfaceNetwork s = refine_fixtures::nested_spheres(fixtures::uv_sphere(6.0, 10),
                                                                   fixtures::uv_sphere(10.0, 14));
    const core::TetMesh input =
        refine_fixtures::tetgen_mesh(s, dir, "pYQ", {{0.0, 0.0, 0.0, 1}, {8.0, 0.0, 0.0, 2}});
    const auto before = volume::check_tet_mesh(input);
    INFO(before.summary());
    REQUIRE(before.valid());
    REQUIRE(before.region_volume.size() == 2);

    core::StageContext ctx;
    const core::TetMesh out = volume::refine(input, RefineParams{}, ctx);
    const auto after = volume::check_tet_mesh(out);
    INFO(after.summary());
    CHECK(after.valid());
    CHECK(same_surface(out, input));
    for (const auto& [label, volume] : before.region_volume)
        CHECK(after.region_volume.at(label) == Approx(volume).epsilon(1e-9));
    CHECK(after.quality.max_skewness < before.quality.max_skewness);
    CHECK(after.quality.mean_skewness < before.quality.mean_skewness);
    for (const auto& [label, q] : before.region_quality)
        CHECK(after.region_quality.at(label).mean_skewness < q.mean_skewness);
    const auto& counters = ctx.counters();
    CHECK(counters.at("refine.flips_2_3") + counters.at("refine.flips_3_2") +
              counters.at("refine.flips_n_m") >
          0);
    CHECK(counters.at("refine.pass0.max_skewness") == Approx(before.quality.max_skewness));
    CHECK(counters.at("refine.pass3.max_skewness") <= counters.at("refine.pass1.max_skewness"));
    CHECK(counters.count("refine.final.min_dihedral") == 1);
}

TEST_CASE("Refine is deterministic for any thread count", "[refine]") {
    const std::string dir = fixtures::temp_dir("refine_determinism");
    const core::TetMesh input =
        refine_fixtures::tetgen_mesh(fixtures::uv_sphere(10.0, 12), dir, "pYq1.3Q");
    core::TetMesh one, many;
    {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
        core::StageContext ctx;
        one = volume::refine(input, RefineParams{}, ctx);
    }
    {
        core::StageContext ctx;
        many = volume::refine(input, RefineParams{}, ctx);
    }
    CHECK(one.tets == many.tets);
    CHECK(one.xyz == many.xyz);
    CHECK(one.region == many.region);
}

TEST_CASE("Refined tetgen sphere passes meshcheck with the surface preserved", "[refine]") {
    const std::string dir = fixtures::temp_dir("refine_meshcheck");
    const core::SurfaceNetwork surface = fixtures::uv_sphere(10.0, 16);
    const core::TetMesh input = refine_fixtures::tetgen_mesh(surface, dir, "pYQ");
    core::StageContext ctx;
    const core::TetMesh out = volume::refine(input, RefineParams{}, ctx);
    REQUIRE(volume::check_tet_mesh(out).valid());
    io::write_surface_vtu(surface, dir + "/surface.vtu", {});
    io::write_tet_mesh_vtu(out, dir + "/refined.vtu", {});
    if (fixtures::meshcheck_path().empty()) {
        FM_SKIP("meshcheck.py not found (../shared/tools or FRONTMESH_MESHCHECK)");
    }
    const std::string command = "/usr/bin/python3 '" + fixtures::meshcheck_path() + "' '" + dir +
                                "/refined.vtu' --surface '" + dir +
                                "/surface.vtu' --strict-surface > '" + dir + "/meshcheck.log' 2>&1";
    CHECK(std::system(command.c_str()) == 0);
}

namespace {

// A pyramid over a slightly folded diamond (a, c, b, d): the input triangles (a, b, c) and
// (a, b, d) meet at 178 deg along a-b; apex e. Three tets, all nodes on the surface: the flat
// sliver (a, b, c, d) lying on the two triangles, and the two tets above it around edge c-d.
core::TetMesh folded_pyramid() {
    core::TetMesh m;
    const std::int32_t a = m.add_node({-0.5, 0.0, 0.0}), b = m.add_node({0.5, 0.0, 0.0});
    const std::int32_t c = m.add_node({0.0, -1.0, 0.0}), d = m.add_node({0.0, 1.0, 0.03});
    const std::int32_t e = m.add_node({0.2, -0.15, 1.3});
    m.surface_vertices = 5;
    auto positive = [&](const Tet& t) {
        const double* x = m.xyz.data();
        return volume::positive_tet(x + 3 * t[0], x + 3 * t[1], x + 3 * t[2], x + 3 * t[3]);
    };
    for (Tet t : {Tet{a, b, c, d}, Tet{a, c, d, e}, Tet{b, c, d, e}}) {
        if (!positive(t)) std::swap(t[1], t[2]);
        m.add_tet(t[0], t[1], t[2], t[3], 1);
    }
    const Eigen::Vector3d inside =
        (m.point(a) + m.point(b) + m.point(c) + m.point(d) + m.point(e)) / 5.0;
    using Face = std::array<std::int32_t, 3>;
    for (Face f : {Face{a, b, c}, Face{a, b, d}, Face{a, c, e}, Face{c, b, e}, Face{b, d, e},
                   Face{d, a, e}}) {
        const Eigen::Vector3d n =
            (m.point(f[1]) - m.point(f[0])).cross(m.point(f[2]) - m.point(f[0]));
        if (n.dot(m.point(f[0]) - inside) < 0.0) std::swap(f[1], f[2]);  // outward
        m.faces.push_back(f);
    }
    m.region_in.assign(6, 1);
    m.region_out.assign(6, 0);
    return m;
}

}  // namespace

TEST_CASE("A Steiner node mends a sliver whose four nodes are on the surface", "[refine]") {
    const core::TetMesh input = folded_pyramid();
    const auto before = volume::check_tet_mesh(input);
    INFO(before.summary());
    REQUIRE(before.valid());
    const auto q_before = volume::tet_quality(input);
    REQUIRE(q_before.min_dihedral_deg < 10.0);  // the sliver
    TetTopology topo(input);
    RefineOps ops(topo, RefineParams{});
    // No interior node to move or remove: only a new node (or a flip) can help.
    REQUIRE(ops.insert_node(0, Objective::Combined));
    REQUIRE(topo.check());
    const core::TetMesh out = topo.compact();
    const auto after = volume::check_tet_mesh(out);
    INFO(after.summary());
    CHECK(after.valid());
    CHECK(after.volume == Approx(before.volume).epsilon(1e-12));
    CHECK(same_surface(out, input));  // input triangles and surface nodes untouched
    CHECK(out.node_count() == input.node_count() + 1);
    CHECK(out.tet_count() > input.tet_count());
    const auto q_after = volume::tet_quality(out);
    CHECK(q_after.min_dihedral_deg > q_before.min_dihedral_deg + 10.0);
    CHECK(q_after.skewness_over_08 <= q_before.skewness_over_08);

    // A regular tet gains nothing from a node inside it: refused, nothing changed.
    core::TetMesh regular;
    regular.add_node({1, 1, 1});
    regular.add_node({1, -1, -1});
    regular.add_node({-1, 1, -1});
    regular.add_node({-1, -1, 1});
    regular.add_tet(0, 1, 2, 3, 1);
    if (!volume::positive_tet(regular.xyz.data(), regular.xyz.data() + 3, regular.xyz.data() + 6,
                              regular.xyz.data() + 9))
        std::swap(regular.tets[0][1], regular.tets[0][2]);
    TetTopology single(regular);
    RefineOps ops_single(single, RefineParams{});
    CHECK_FALSE(ops_single.insert_node(0, Objective::Combined));
    CHECK(single.compact().tets == regular.tets);
    CHECK(single.compact().node_count() == 4);
}

namespace {

// Walls of region 1 against the outside on every tet face (outward) that appears once.
void add_hull_faces(core::TetMesh& m) {
    static constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
    std::vector<std::array<std::int32_t, 3>> all;
    for (const Tet& t : m.tets)
        for (const auto& f : kFace) all.push_back({t[f[0]], t[f[1]], t[f[2]]});
    for (const auto& f : all) {
        auto key = f;
        std::sort(key.begin(), key.end());
        const auto same = std::count_if(all.begin(), all.end(), [&](std::array<std::int32_t, 3> g) {
            std::sort(g.begin(), g.end());
            return g == key;
        });
        if (same == 1) m.faces.push_back(f);
    }
    m.region_in.assign(m.faces.size(), 1);
    m.region_out.assign(m.faces.size(), 0);
}

// The four tets around an inner edge on a convex stretch of AAL region 62 (frontmesh's AAL
// run, refine stage), the first of them a 7.2 degree sliver on two boundary triangles that no
// flip, move or removal mended: every node placed in the ring to split it left more tets
// above skewness 0.8 than before, which insert_node refused until its rescue of slivers.
// Here all faces of the ring's hull are walls.
core::TetMesh aal_ring() {
    core::TetMesh m;
    const std::int32_t n7 =
        m.add_node({42.634114328011378, -43.453635940825151, 37.33580305029605});
    const std::int32_t n8 =
        m.add_node({43.438918479227183, -44.040870297462632, 37.370046175104555});
    const std::int32_t n213 =
        m.add_node({43.208340770790166, -42.602898258382574, 38.023860972865279});
    const std::int32_t n274 =
        m.add_node({43.775815590809522, -43.41069397537553, 37.984882628206464});
    const std::int32_t n315 =
        m.add_node({43.264470652596493, -44.219414951438154, 38.416623794422804});
    const std::int32_t n346 =
        m.add_node({42.099290221363347, -43.487969915474778, 38.265956381451481});
    m.surface_vertices = 6;
    for (Tet t : {Tet{n8, n7, n274, n213}, Tet{n346, n213, n274, n7}, Tet{n315, n7, n346, n274},
                  Tet{n315, n8, n7, n274}}) {
        const double* x = m.xyz.data();
        if (!volume::positive_tet(x + 3 * t[0], x + 3 * t[1], x + 3 * t[2], x + 3 * t[3]))
            std::swap(t[1], t[2]);
        m.add_tet(t[0], t[1], t[2], t[3], 1);
    }
    add_hull_faces(m);
    return m;
}

// The star of interior node 946340 of frontmesh's jhu189 run (refine stage, region 113): its
// tet 6 is a 1.47 degree sliver, node 8 nearly on the surface edge 0-1 (the triangle 8-0-1 has
// a 169.8 degree angle at node 8). No flip, move, removal or new node in a ring or layer
// around the sliver mended it: moving node 8 alone trades the sliver for more tets above
// skewness 0.8 than a move may make. Here all faces of the star's hull are walls.
core::TetMesh jhu189_star() {
    core::TetMesh m;
    for (const std::array<double, 3> x :
         {std::array<double, 3>{-78.58168602037672, -81.5918511010493, 27.546554944763894},
          std::array<double, 3>{-78.4937614258327, -83.15301484903839, 27.15409792099988},
          std::array<double, 3>{-78.44391870329531, -82.58589697503729, 28.425581403116702},
          std::array<double, 3>{-78.92480530217586, -82.95494050963478, 27.634658871219806},
          std::array<double, 3>{-78.80913939694337, -82.45709960118008, 27.690926365351018},
          std::array<double, 3>{-78.87044934274071, -82.69841685349044, 27.364002235330183},
          std::array<double, 3>{-79.0658924202864, -82.43093796968652, 27.509723666914766},
          std::array<double, 3>{-78.88571636049569, -82.53281091201903, 27.196019769651347},
          std::array<double, 3>{-78.54441484810911, -82.48559881850215, 27.39360884595815}})
        m.add_node({x[0], x[1], x[2]});
    m.surface_vertices = 8;
    for (Tet t : {Tet{7, 0, 6, 8}, Tet{5, 8, 1, 7}, Tet{8, 0, 1, 7}, Tet{3, 4, 2, 8},
                  Tet{1, 5, 3, 8}, Tet{2, 1, 3, 8}, Tet{0, 2, 8, 1}, Tet{7, 8, 6, 5},
                  Tet{6, 8, 0, 4}, Tet{4, 5, 8, 3}, Tet{4, 8, 0, 2}, Tet{4, 5, 6, 8}}) {
        const double* x = m.xyz.data();
        if (!volume::positive_tet(x + 3 * t[0], x + 3 * t[1], x + 3 * t[2], x + 3 * t[3]))
            std::swap(t[1], t[2]);
        m.add_tet(t[0], t[1], t[2], t[3], 1);
    }
    add_hull_faces(m);
    return m;
}

}  // namespace

namespace {

// insert_node's rescue of tet `sliver` of `input`, whose smallest angle is under `below_deg`:
// the mesh stays valid with the same volume and surface, its smallest angle reaches 10 deg,
// and at most 8 more tets are above skewness 0.8 (the rescue's bound). Returns the result.
core::TetMesh check_rescue(const core::TetMesh& input, std::int32_t sliver, double below_deg) {
    const auto before = volume::check_tet_mesh(input);
    INFO(before.summary());
    REQUIRE(before.valid());
    const auto q_before = volume::tet_quality(input);
    REQUIRE(q_before.min_dihedral_deg < below_deg);
    TetTopology topo(input);
    RefineOps ops(topo, RefineParams{});
    REQUIRE(ops.insert_node(sliver, Objective::Combined));
    REQUIRE(topo.check());
    core::TetMesh out = topo.compact();
    const auto after = volume::check_tet_mesh(out);
    INFO(after.summary());
    CHECK(after.valid());
    CHECK(after.volume == Approx(before.volume).epsilon(1e-12));
    CHECK(same_surface(out, input));
    const auto q_after = volume::tet_quality(out);
    CHECK(q_after.min_dihedral_deg >= 10.0);
    CHECK(q_after.skewness_over_08 <= q_before.skewness_over_08 + 8);
    return out;
}

}  // namespace

TEST_CASE("A sliver on a convex stretch of boundary is split even at the cost of caps",
          "[refine]") {
    const core::TetMesh input = aal_ring();
    REQUIRE(input.faces.size() == 8);
    const core::TetMesh out = check_rescue(input, 0, 7.5);  // the sliver, tet 0
    CHECK(out.node_count() == input.node_count() + 1);
}

TEST_CASE("A sliver at an interior node near a surface edge: the node is placed anew", "[refine]") {
    const core::TetMesh input = jhu189_star();
    const core::TetMesh out = check_rescue(input, 6, 1.5);  // the sliver, tet 6
    CHECK(out.node_count() == input.node_count());          // node 8 replaced, not joined
    CHECK(out.tet_count() == input.tet_count());
}

TEST_CASE("Tets whose shape the surface fixes are counted and named", "[refine]") {
    // One flat tet whose four faces are input triangles: nothing can change it.
    core::TetMesh m;
    m.add_node({0.0, 0.0, 0.0});
    m.add_node({1.0, 0.0, 0.0});
    m.add_node({0.5, 0.9, 0.0});
    m.add_node({0.5, 0.3, 0.05});
    m.surface_vertices = 4;
    Tet t{0, 1, 2, 3};
    if (!volume::positive_tet(m.xyz.data(), m.xyz.data() + 3, m.xyz.data() + 6, m.xyz.data() + 9))
        std::swap(t[1], t[2]);
    m.add_tet(t[0], t[1], t[2], t[3], 1);
    static constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
    for (const auto& f : kFace) m.faces.push_back({t[f[0]], t[f[1]], t[f[2]]});
    m.region_in.assign(4, 1);
    m.region_out.assign(4, 0);
    REQUIRE(volume::check_tet_mesh(m).valid());
    REQUIRE(volume::tet_quality(m).min_dihedral_deg < 10.0);
    core::StageContext ctx;
    const core::TetMesh out = volume::refine(m, RefineParams{}, ctx);
    CHECK(out.tets.size() == 1);
    CHECK(ctx.counters().at("refine.surface_fixed_under_10deg") == 1.0);
    REQUIRE(ctx.warnings().size() == 1);
    CHECK_THAT(ctx.warnings()[0], Catch::Contains("fixes their shape"));

    // The AAL ring's sliver has two walls only: the rescue mends it, nothing is reported.
    core::StageContext ring_ctx;
    const core::TetMesh ring = volume::refine(aal_ring(), RefineParams{}, ring_ctx);
    CHECK(volume::tet_quality(ring).min_dihedral_deg >= 10.0);
    CHECK(ring_ctx.counters().at("refine.surface_fixed_under_10deg") == 0.0);
    CHECK(ring_ctx.warnings().empty());
}

TEST_CASE("Poor input triangles: the Combined cost of a tet on one is its dihedral term",
          "[refine]") {
    // Node 3 nearly on segment 0-1: triangle (0, 3, 1) has a 170 deg angle, so every tet on it
    // has skewness above 0.8 (the least is the triangle's own 1 - A / A_opt, here ~0.9).
    core::TetMesh m;
    m.add_node({0.0, 0.0, 0.0});
    m.add_node({1.0, 0.0, 0.0});
    m.add_node({0.5, 0.9, 0.0});
    m.add_node({0.5, -0.044, 0.0});
    m.add_node({0.5, 0.3, 0.7});
    m.add_node({0.5, -0.3, -0.6});
    m.add_tet(0, 1, 2, 4, 1);
    m.add_tet(0, 3, 1, 5, 1);
    m.add_tet(0, 1, 3, 4, 1);
    m.add_tet(0, 2, 1, 5, 1);
    for (auto& t : m.tets)
        if (!volume::positive_tet(m.xyz.data() + 3 * t[0], m.xyz.data() + 3 * t[1],
                                  m.xyz.data() + 3 * t[2], m.xyz.data() + 3 * t[3]))
            std::swap(t[1], t[2]);
    m.faces = {{0, 3, 1},
               {0, 1, 2}};  // only the triangles under test; the rest is of no matter here
    m.region_in.assign(2, 1);
    m.region_out.assign(2, 0);
    m.surface_vertices = 6;
    TetTopology topo(m);
    CHECK(topo.is_poor_face(0, 3, 1));
    CHECK(topo.is_poor_face(1, 0, 3));  // any order
    CHECK_FALSE(topo.is_poor_face(0, 1, 2));
    CHECK(topo.has_poor_face(topo.tet(1)));
    CHECK_FALSE(topo.has_poor_face(topo.tet(0)));
    const Tet& t = topo.tet(1);
    const auto shape =
        volume::tet_shape(topo.xyz(t[0]), topo.xyz(t[1]), topo.xyz(t[2]), topo.xyz(t[3]), true);
    CHECK(shape.skewness > 0.8);
    // Its dihedral term; 1 more, as it is under the sliver floor (10 deg).
    REQUIRE(shape.min_dihedral_deg < volume::kSliverFloorDeg);
    CHECK(volume::tet_cost(topo, t, Objective::Combined) ==
          Approx(2.0 - shape.min_dihedral_deg / 70.528779365509308));
    CHECK(volume::tet_cost(topo, t, Objective::Skewness) == Approx(shape.skewness));
}

TEST_CASE("The Combined cost ranks a sliver under 10 deg behind every cap", "[refine]") {
    // A cap: node 3 just above the middle of triangle (0, 1, 2): skewness near 1, smallest
    // dihedral angle well above 10 deg. A sliver: four nearly coplanar nodes in a square.
    const double cap[4][3] = {{0, 0, 0}, {1, 0, 0}, {0.5, 0.866, 0}, {0.5, 0.289, 0.055}};
    const double sliver[4][3] = {{0, 0, 0}, {1, 0, 0.02}, {1, 1, 0}, {0, 1, 0.02}};
    const auto shape_of = [](const double(&x)[4][3]) {
        volume::TetShape s = volume::tet_shape(x[0], x[1], x[2], x[3], true);
        if (!volume::positive_tet(x[0], x[1], x[2], x[3]))
            s = volume::tet_shape(x[0], x[2], x[1], x[3], true);
        return s;
    };
    const volume::TetShape c = shape_of(cap), s = shape_of(sliver);
    INFO("cap: skewness " << c.skewness << ", " << c.min_dihedral_deg << " deg; sliver: "
                          << s.skewness << ", " << s.min_dihedral_deg << " deg");
    REQUIRE(c.skewness > s.skewness);
    REQUIRE(c.min_dihedral_deg > volume::kSliverFloorDeg);
    REQUIRE(s.min_dihedral_deg < volume::kSliverFloorDeg);
    CHECK(volume::combined_cost(c, false) <= 1.0);
    CHECK(volume::combined_cost(s, false) > volume::combined_cost(c, false));
    CHECK(volume::combined_cost(s, false) > 1.0);
    // Without the floor the cap would cost more: its skewness is larger.
    CHECK(c.skewness > 1.0 - s.min_dihedral_deg / 70.528779365509308);
}

TEST_CASE("Refine parameters are validated by key", "[refine]") {
    RefineParams p;
    p.flip_skewness = 1.5;
    try {
        volume::validate(p);
        FAIL("no error");
    } catch (const core::InputError& e) {
        CHECK(std::string(e.what()).find("refine.flip_skewness") != std::string::npos);
    }
    CHECK_NOTHROW(volume::validate(RefineParams{}));
}

TEST_CASE("The shape cache follows every edit, its own and others'", "[refine]") {
    const std::string dir = fixtures::temp_dir("refine_cache");
    const core::TetMesh input =
        refine_fixtures::tetgen_mesh(fixtures::uv_sphere(10.0, 12), dir, "pYQ");
    TetTopology topo(input);
    RefineOps ops(topo, RefineParams{});
    auto fresh = [&](std::int32_t t) {
        const Tet& q = topo.tet(t);
        return volume::tet_shape(topo.xyz(q[0]), topo.xyz(q[1]), topo.xyz(q[2]), topo.xyz(q[3]),
                                 true);
    };
    auto all_cached_exact = [&]() {
        std::size_t wrong = 0;
        for (std::int32_t t = 0; t < topo.tet_capacity(); ++t) {
            if (!topo.alive(t)) continue;
            // Skewness alone first: asking for the dihedral angle may measure the tet again.
            const volume::TetShape f = fresh(t);
            if (ops.shape(t, false).skewness != f.skewness) ++wrong;
            const volume::TetShape s = ops.shape(t, true);
            if (s.skewness != f.skewness || s.min_dihedral_deg != f.min_dihedral_deg) ++wrong;
        }
        return wrong;
    };
    REQUIRE(!ops.bad_tets(Objective::Combined, 0.0).empty());  // fills the cache
    ops.remove_nodes();
    ops.smooth();
    ops.flips();
    const std::size_t moves = ops.counts.smoothing_moves;
    ops.smooth();  // moves after the last candidate list: the next one must see them
    CHECK(moves > 0);
    CHECK(ops.counts.smoothing_moves > moves);
    CHECK(ops.counts.flips_2_3 + ops.counts.flips_3_2 + ops.counts.flips_4_4 +
              ops.counts.flips_n_m >
          0);
    CHECK(all_cached_exact() == 0);
    // The flip candidates (kept up to date between calls) equal a full scan, worst first.
    {
        std::vector<std::pair<double, std::int32_t>> scan;
        for (std::int32_t t = 0; t < topo.tet_capacity(); ++t)
            if (topo.alive(t) && fresh(t).skewness > 0.3) scan.emplace_back(fresh(t).skewness, t);
        std::sort(scan.begin(), scan.end(), [](const auto& x, const auto& y) {
            return x.first != y.first ? x.first > y.first : x.second < y.second;
        });
        std::vector<std::int32_t> expected;
        for (const auto& [c, t] : scan) expected.push_back(t);
        CHECK(ops.bad_tets(Objective::Skewness, 0.3) == expected);
    }
    ops.slivers();
    CHECK(all_cached_exact() == 0);
    CHECK(topo.check());
    // A node moved behind the cache's back: its star's shapes are measured again.
    std::vector<std::int32_t> star;
    std::int32_t v = topo.mesh().surface_vertices;
    while (v < topo.node_capacity() && !topo.star(v, star)) ++v;
    REQUIRE(v < topo.node_capacity());
    const std::vector<std::int32_t> moved_star = star;
    for (const std::int32_t t : moved_star) (void)ops.shape(t, true);
    topo.set_point(v, topo.point(v) + Eigen::Vector3d(0.05, -0.03, 0.02));
    for (const std::int32_t t : moved_star)
        CHECK(ops.shape(t, false).skewness == fresh(t).skewness);
    CHECK(all_cached_exact() == 0);
}

TEST_CASE("A star walk with a limit stops early and agrees otherwise", "[refine]") {
    const std::string dir = fixtures::temp_dir("refine_star_limit");
    const core::TetMesh input =
        refine_fixtures::tetgen_mesh(fixtures::uv_sphere(10.0, 12), dir, "pYq1.3Q");
    TetTopology topo(input);
    std::vector<std::int32_t> full, limited;
    std::size_t compared = 0, stopped = 0;
    for (std::int32_t v = 0; v < topo.node_capacity(); ++v) {
        const bool closed = topo.star(v, full);
        for (const std::size_t limit : {std::size_t{4}, std::size_t{12}, full.size()}) {
            const bool ok = topo.star(v, limited, limit);
            if (full.size() > limit) {
                CHECK_FALSE(ok);
                ++stopped;
            } else {
                CHECK(ok == closed);
                CHECK(limited == full);
                ++compared;
            }
        }
    }
    CHECK(compared > 0);
    CHECK(stopped > 0);
}

TEST_CASE("Refine output does not depend on the input's tet order", "[refine]") {
    // refine() reorders the tets by their smallest node first: any input order gives the same mesh.
    const std::string dir = fixtures::temp_dir("refine_tet_order");
    const core::TetMesh input =
        refine_fixtures::tetgen_mesh(fixtures::uv_sphere(10.0, 12), dir, "pYq1.3Q");
    // The counting sort is stable within one smallest node: permute whole groups (descending
    // smallest node), keeping the input order inside a group.
    std::vector<std::size_t> order(input.tets.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
    auto smallest = [&](std::size_t t) {
        return *std::min_element(input.tets[t].begin(), input.tets[t].end());
    };
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return smallest(a) > smallest(b); });
    core::TetMesh shuffled = input;
    for (std::size_t k = 0; k < order.size(); ++k) {
        shuffled.tets[k] = input.tets[order[k]];
        shuffled.region[k] = input.region[order[k]];
    }
    core::StageContext ctx1, ctx2;
    const core::TetMesh a = volume::refine(input, RefineParams{}, ctx1);
    const core::TetMesh b = volume::refine(shuffled, RefineParams{}, ctx2);
    CHECK(a.tets == b.tets);
    CHECK(a.xyz == b.xyz);
    CHECK(volume::check_tet_mesh(a).valid());
}
