// Tests of the tetra stage (issue 4): layered advancing front, §3.1-3.2.
#include <iostream>

#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <map>
#include <numbers>
#include <string>

#include <tbb/global_control.h>

#include "io/mesh_io.h"
#include "pipeline/core/error.h"
#include "pipeline/core/predicates.h"
#include "pipeline/core/quality.h"
#include "tests/fixtures/phantoms.h"
#include "tests/fixtures/referee.h"
#include "volume/tetra.h"

using namespace frontmesh;
using Eigen::Vector3d;

namespace {

/// Closed box [0,L]^3-like surface with an (nx, ny, nz) grid per axis; `coord(axis, i)` gives
/// the coordinate of grid line i (graded grids make poor, size-jumping triangles).
core::SurfaceNetwork box_surface(std::array<int, 3> n,
                                 const std::function<double(int, int)>& coord) {
    core::SurfaceNetwork s;
    std::map<std::array<int, 3>, std::int32_t> id;
    auto vertex = [&](std::array<int, 3> g) {
        auto it = id.find(g);
        if (it != id.end()) return it->second;
        const std::int32_t v = s.add_vertex({coord(0, g[0]), coord(1, g[1]), coord(2, g[2])});
        id[g] = v;
        return v;
    };
    const Vector3d centre(0.5 * (coord(0, 0) + coord(0, n[0])),
                          0.5 * (coord(1, 0) + coord(1, n[1])),
                          0.5 * (coord(2, 0) + coord(2, n[2])));
    for (int axis = 0; axis < 3; ++axis) {
        const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
        for (int side = 0; side < 2; ++side)
            for (int i = 0; i < n[a1]; ++i)
                for (int j = 0; j < n[a2]; ++j) {
                    std::array<std::array<int, 3>, 4> q;
                    for (int c = 0; c < 4; ++c) {
                        q[c][axis] = side * n[axis];
                        q[c][a1] = i + (c == 1 || c == 2);
                        q[c][a2] = j + (c >= 2);
                    }
                    const std::int32_t v[4] = {vertex(q[0]), vertex(q[1]), vertex(q[2]),
                                               vertex(q[3])};
                    for (auto t : {std::array<int, 3>{0, 1, 2}, std::array<int, 3>{0, 2, 3}}) {
                        std::int32_t a = v[t[0]], b = v[t[1]], c = v[t[2]];
                        const Vector3d nn =
                            (s.point(b) - s.point(a)).cross(s.point(c) - s.point(a));
                        if (nn.dot(s.point(a) - centre) < 0) std::swap(b, c);
                        s.add_face(a, b, c, 1, 0);
                    }
                }
    }
    return s;
}

core::SurfaceNetwork uniform_box(double lx, double ly, double lz, std::array<int, 3> n) {
    const double len[3] = {lx, ly, lz};
    return box_surface(n, [&](int axis, int i) { return len[axis] * i / n[axis]; });
}

core::SurfaceNetwork torus(double R, double r, int nu, int nv) {
    core::SurfaceNetwork s;
    for (int i = 0; i < nu; ++i)
        for (int j = 0; j < nv; ++j) {
            const double u = 2 * std::numbers::pi * i / nu, v = 2 * std::numbers::pi * j / nv;
            s.add_vertex({(R + r * std::cos(v)) * std::cos(u), (R + r * std::cos(v)) * std::sin(u),
                          r * std::sin(v)});
        }
    auto id = [&](int i, int j) { return (i % nu) * nv + (j % nv); };
    for (int i = 0; i < nu; ++i)
        for (int j = 0; j < nv; ++j) {
            const std::int32_t q[4] = {id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)};
            for (auto t : {std::array<int, 3>{0, 1, 2}, std::array<int, 3>{0, 2, 3}}) {
                std::int32_t a = q[t[0]], b = q[t[1]], c = q[t[2]];
                const Vector3d pa = s.point(a);
                const Vector3d axis_pt = R * Vector3d(pa.x(), pa.y(), 0).normalized();
                const Vector3d nn = (s.point(b) - pa).cross(s.point(c) - pa);
                if (nn.dot(pa - axis_pt) < 0) std::swap(b, c);
                s.add_face(a, b, c, 1, 0);
            }
        }
    return s;
}

/// Two nested uv spheres: region 1 inside r_in, region 2 between r_in and r_out.
core::SurfaceNetwork nested_spheres(double r_in, int n_in, double r_out, int n_out) {
    core::SurfaceNetwork s = fixtures::uv_sphere(r_in, n_in);
    for (auto& l : s.region_out) l = 2;
    const core::SurfaceNetwork o = fixtures::uv_sphere(r_out, n_out);
    const std::int32_t off = static_cast<std::int32_t>(s.vertex_count());
    for (std::size_t v = 0; v < o.vertex_count(); ++v)
        s.add_vertex(o.point(static_cast<std::int32_t>(v)));
    for (const auto& f : o.faces) s.add_face(f[0] + off, f[1] + off, f[2] + off, 2, 0);
    return s;
}

/// A flat box [0, L]^2 x [0, H], region 1: a fine floor (n x n squares), a lid of two
/// triangles spanning the whole box and fan-triangulated walls. Tets grown from the floor
/// reach the lid far from its nodes, so the validity tests must find front faces whose nodes
/// all lie far outside the tet.
core::SurfaceNetwork coarse_lid_box(double L, double H, int n) {
    core::SurfaceNetwork s;
    auto floor_id = [&](int i, int j) { return static_cast<std::int32_t>(i * (n + 1) + j); };
    for (int i = 0; i <= n; ++i)
        for (int j = 0; j <= n; ++j) s.add_vertex({L * i / n, L * j / n, 0.0});
    const std::int32_t top[4] = {s.add_vertex({0, 0, H}), s.add_vertex({L, 0, H}),
                                 s.add_vertex({L, L, H}), s.add_vertex({0, L, H})};
    const Vector3d centre(0.5 * L, 0.5 * L, 0.5 * H);
    auto add = [&](std::int32_t a, std::int32_t b, std::int32_t c) {
        const Vector3d nn = (s.point(b) - s.point(a)).cross(s.point(c) - s.point(a));
        const Vector3d mid = (s.point(a) + s.point(b) + s.point(c)) / 3.0;
        if (nn.dot(mid - centre) < 0) std::swap(b, c);
        s.add_face(a, b, c, 1, 0);
    };
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            add(floor_id(i, j), floor_id(i + 1, j), floor_id(i + 1, j + 1));
            add(floor_id(i, j), floor_id(i + 1, j + 1), floor_id(i, j + 1));
        }
    add(top[0], top[1], top[2]);
    add(top[0], top[2], top[3]);
    // walls, counter-clockwise around the floor: corner k to corner k + 1
    const int corner[5][2] = {{0, 0}, {n, 0}, {n, n}, {0, n}, {0, 0}};
    for (int k = 0; k < 4; ++k) {
        std::vector<std::int32_t> b;
        for (int m = 0; m <= n; ++m) {
            const int i = corner[k][0] + (corner[k + 1][0] - corner[k][0]) * m / n;
            const int j = corner[k][1] + (corner[k + 1][1] - corner[k][1]) * m / n;
            b.push_back(floor_id(i, j));
        }
        const std::int32_t t0 = top[k], t1 = top[(k + 1) % 4];
        for (int m = 0; m < n; ++m) add(b[m], b[m + 1], m < n / 2 ? t0 : t1);
        add(b[n / 2], t1, t0);
    }
    return s;
}

using Key = std::array<std::int32_t, 3>;
Key sorted_key(std::int32_t a, std::int32_t b, std::int32_t c) {
    Key k{a, b, c};
    std::sort(k.begin(), k.end());
    return k;
}

/// Our own validity check: exact positive orientation, conforming (each face in one or two
/// tets of opposite sides), boundary = the input faces with the right regions on the right
/// sides, volumes per region = enclosed volumes. Returns "" when valid.
std::string validity_problem(const core::TetMesh& m, const core::SurfaceNetwork& s) {
    if (m.surface_vertices != static_cast<std::int32_t>(s.vertex_count()))
        return "surface_vertices";
    for (std::size_t i = 0; i < s.xyz.size(); ++i)
        if (m.xyz[i] != s.xyz[i]) return "surface vertex moved";
    struct Side {
        int count = 0;
        std::int32_t tet[2] = {-1, -1};
        bool outward_matches[2] = {false, false};  // tet's outward cycle equals the key cycle
    };
    std::map<Key, Side> faces;
    std::map<core::Label, double> volume;
    static constexpr int kF[4][3] = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {2, 0, 3}};
    for (std::size_t t = 0; t < m.tet_count(); ++t) {
        const auto& v = m.tets[t];
        if (core::orient3d(m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3])) != -1)
            return "tet " + std::to_string(t) + " not positive";
        volume[m.region[t]] +=
            core::tet_signed_volume(m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3]));
        for (const auto& lf : kF) {
            const std::int32_t a = v[lf[0]], b = v[lf[1]], c = v[lf[2]];
            const Key k = sorted_key(a, b, c);
            Side& sd = faces[k];
            if (sd.count == 2) return "face in three tets";
            // cycle (a, b, c) equal to the cycle of (k0, k1, k2)?
            const bool even =
                (a == k[0] && b == k[1]) || (b == k[0] && c == k[1]) || (c == k[0] && a == k[1]);
            sd.tet[sd.count] = static_cast<std::int32_t>(t);
            sd.outward_matches[sd.count] = even;
            ++sd.count;
        }
    }
    std::map<Key, std::size_t> input;
    for (std::size_t f = 0; f < s.face_count(); ++f) {
        const auto& t = s.faces[f];
        input[sorted_key(t[0], t[1], t[2])] = f;
    }
    for (const auto& [k, sd] : faces) {
        auto it = input.find(k);
        if (sd.count == 2 && sd.outward_matches[0] == sd.outward_matches[1])
            return "overlapping tets";
        if (it == input.end()) {
            if (sd.count != 2) return "open face not in the input";
            if (m.region[sd.tet[0]] != m.region[sd.tet[1]]) return "region change off the surface";
            continue;
        }
        const auto& t = s.faces[it->second];
        const bool even = (t[0] == k[0] && t[1] == k[1]) || (t[1] == k[0] && t[2] == k[1]) ||
                          (t[2] == k[0] && t[0] == k[1]);
        const core::Label rin = s.region_in[it->second], rout = s.region_out[it->second];
        const int want = rout == 0 ? 1 : 2;
        if (sd.count != want) return "input face with wrong tet count";
        for (int i = 0; i < sd.count; ++i) {
            // the tet whose outward face has the input face's orientation is region_in's
            const core::Label expect = (sd.outward_matches[i] == even) ? rin : rout;
            if (m.region[sd.tet[i]] != expect) return "input face with wrong region on a side";
        }
    }
    for (const auto& [k, f] : input)
        if (!faces.count(k)) return "input face missing";
    for (core::Label r : core::region_labels(s)) {
        const double want = core::enclosed_volume(s, r);
        if (std::abs(volume[r] - want) > 1e-9 * std::abs(want))
            return "volume of region " + std::to_string(r);
    }
    return "";
}

struct Run {
    core::TetMesh mesh;
    double min_dihedral = 180.0, max_skew = 0.0;
    std::size_t skew08 = 0;
};

Run mesh_it(const core::SurfaceNetwork& s, double alpha = 1.15) {
    volume::TetraParams p;
    p.stretching = alpha;
    core::StageContext ctx;
    Run r;
    r.mesh = volume::tetra(s, p, ctx);
    for (const auto& t : r.mesh.tets) {
        const auto a = r.mesh.point(t[0]), b = r.mesh.point(t[1]), c = r.mesh.point(t[2]),
                   d = r.mesh.point(t[3]);
        r.min_dihedral = std::min(r.min_dihedral, core::tet_min_dihedral_deg(a, b, c, d));
        const double e = core::tet_skewness(a, b, c, d);
        r.max_skew = std::max(r.max_skew, e);
        r.skew08 += e > 0.8;
    }
    return r;
}

/// Runs meshcheck.py (strict surface preservation) on the result; true when it passes.
bool meshcheck_passes(const core::TetMesh& m, const core::SurfaceNetwork& s,
                      const std::string& name) {
    const std::string dir = fixtures::temp_dir("tetra_" + name);
    io::write_tet_mesh_vtu(m, dir + "/mesh.vtu", {});
    io::write_surface_vtu(s, dir + "/surf.vtu", {});
    if (fixtures::meshcheck_path().empty()) {
        std::cout << "FRONTMESH-TEST-SKIPPED: meshcheck.py not found (../shared/tools or "
                     "FRONTMESH_MESHCHECK)"
                  << std::endl;
        return true;
    }
    const std::string cmd = "/usr/bin/python3 '" + fixtures::meshcheck_path() + "' " + dir +
                            "/mesh.vtu --surface " + dir + "/surf.vtu --strict-surface > " + dir +
                            "/meshcheck.txt 2>&1";
    return std::system(cmd.c_str()) == 0;
}

}  // namespace

TEST_CASE("orient3d sign convention matches VTK-positive tets", "[tetra]") {
    const Vector3d a(0, 0, 0), b(1, 0, 0), c(0, 1, 0), d(0, 0, 1);
    CHECK(core::tet_signed_volume(a, b, c, d) > 0);
    CHECK(core::orient3d(a, b, c, d) == -1);
}

TEST_CASE("tetra rejects bad parameters", "[tetra]") {
    volume::TetraParams p;
    p.stretching = 1.0;
    CHECK_THROWS_AS(volume::validate(p), core::InputError);
    p.stretching = 2.5;
    CHECK_THROWS_AS(volume::validate(p), core::InputError);
    p = {};
    p.max_remesh_per_node = -1;
    CHECK_THROWS_AS(volume::validate(p), core::InputError);
}

TEST_CASE("tetra meshes an octahedron", "[tetra]") {
    const auto s = fixtures::octahedron(1.0);
    const Run r = mesh_it(s);
    CHECK(validity_problem(r.mesh, s) == "");
    CHECK(r.mesh.tet_count() >= 4);
}

TEST_CASE("tetra meshes a cube", "[tetra]") {
    const auto s = uniform_box(10, 10, 10, {6, 6, 6});
    const Run r = mesh_it(s);
    INFO("tets " << r.mesh.tet_count() << " min dihedral " << r.min_dihedral);
    CHECK(validity_problem(r.mesh, s) == "");
    CHECK(r.mesh.level.size() == r.mesh.node_count());
    CHECK(meshcheck_passes(r.mesh, s, "cube"));
}

TEST_CASE("tetra meshes a sphere at alpha 1.15 and 1.05", "[tetra]") {
    const auto s = fixtures::uv_sphere(10.0, 16);
    const Run r115 = mesh_it(s, 1.15);
    const Run r105 = mesh_it(s, 1.05);
    INFO("tets 1.15: " << r115.mesh.tet_count() << ", 1.05: " << r105.mesh.tet_count());
    CHECK(validity_problem(r115.mesh, s) == "");
    CHECK(validity_problem(r105.mesh, s) == "");
    CHECK(r105.mesh.tet_count() > r115.mesh.tet_count());
    CHECK(meshcheck_passes(r115.mesh, s, "sphere"));
}

TEST_CASE("tetra meshes two nested spheres with a shared interface", "[tetra]") {
    const auto s = nested_spheres(5.0, 10, 10.0, 14);
    const Run r = mesh_it(s);
    CHECK(validity_problem(r.mesh, s) == "");
    std::size_t n1 = std::count(r.mesh.region.begin(), r.mesh.region.end(), 1);
    std::size_t n2 = std::count(r.mesh.region.begin(), r.mesh.region.end(), 2);
    CHECK(n1 > 0);
    CHECK(n2 > 0);
    CHECK(meshcheck_passes(r.mesh, s, "nested"));
}

TEST_CASE("tetra meshes a torus", "[tetra]") {
    const auto s = torus(10.0, 3.0, 36, 12);
    const Run r = mesh_it(s);
    CHECK(validity_problem(r.mesh, s) == "");
    CHECK(meshcheck_passes(r.mesh, s, "torus"));
}

TEST_CASE("tetra meshes a thin slab", "[tetra]") {
    const auto s = uniform_box(20, 20, 1, {20, 20, 1});
    const Run r = mesh_it(s);
    CHECK(validity_problem(r.mesh, s) == "");
}

TEST_CASE("tetra meshes a surface with poor triangles and size jumps (Fig. 4)", "[tetra]") {
    // geometric grading 1.6 along x, a coarse z, uniform y: slivers and jumps
    const auto s = box_surface({8, 5, 3}, [](int axis, int i) {
        if (axis == 0) return (std::pow(1.6, i) - 1.0) / (std::pow(1.6, 8) - 1.0) * 20.0;
        if (axis == 1) return 2.0 * i;
        return 10.0 * i / 3.0;
    });
    const Run r = mesh_it(s);
    CHECK(validity_problem(r.mesh, s) == "");
    CHECK(meshcheck_passes(r.mesh, s, "poor"));
    // a uv sphere has thin triangles at its poles
    const auto sp = fixtures::uv_sphere(5.0, 30);
    const Run rs = mesh_it(sp);
    CHECK(validity_problem(rs.mesh, sp) == "");
}

TEST_CASE("tetra output is identical for any thread count", "[tetra]") {
    const auto s = nested_spheres(5.0, 8, 10.0, 12);
    core::TetMesh one, two;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        one = mesh_it(s).mesh;
    }
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        two = mesh_it(s).mesh;
    }
    CHECK(one.xyz == two.xyz);
    CHECK(one.tets == two.tets);
    CHECK(one.region == two.region);
    CHECK(one.level == two.level);
}

TEST_CASE("tetra finds front faces far larger than the tets they stop (coarse lid)", "[tetra]") {
    // The front faces are found by their boxes, not through nodes near the tet: a tet grown
    // from the fine floor must not poke through the two-triangle lid.
    const auto s = coarse_lid_box(10.0, 1.5, 10);
    const Run r = mesh_it(s);
    INFO("tets " << r.mesh.tet_count());
    CHECK(validity_problem(r.mesh, s) == "");
    CHECK(meshcheck_passes(r.mesh, s, "coarse_lid"));
}
