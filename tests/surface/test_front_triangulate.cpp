// Tests of the advancing-front surface triangulation (surface/front_triangulate.h).

#include <catch2/catch.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <random>
#include <set>
#include <sstream>

#include "io/mesh_io.h"
#include "pipeline/core/error.h"
#include "pipeline/core/quality.h"
#include "pipeline/core/self_intersection.h"
#include "pipeline/core/surface_network.h"
#include "surface/extract.h"
#include "surface/front_internal.h"
#include "surface/front_triangulate.h"
#include "surface/size_field.h"
#include "tests/fixtures/phantoms.h"
#include "tests/fixtures/skip.h"

using namespace frontmesh;
using surface::BackgroundPatch;

namespace {

std::vector<std::int32_t> all_faces(const core::SurfaceNetwork& s) {
    std::vector<std::int32_t> f(s.face_count());
    for (std::size_t i = 0; i < f.size(); ++i) f[i] = static_cast<std::int32_t>(i);
    return f;
}

// Brute-force closest point over all faces.
double brute_distance(const core::SurfaceNetwork& s, const Eigen::Vector3d& p) {
    double best = 1e300;
    for (const auto& f : s.faces) {
        const Eigen::Vector3d q =
            surface::closest_point_on_triangle(p, s.point(f[0]), s.point(f[1]), s.point(f[2]));
        best = std::min(best, (q - p).norm());
    }
    return best;
}

}  // namespace

TEST_CASE("closest point on a triangle covers vertex, edge and face regions", "[front]") {
    const Eigen::Vector3d a(0, 0, 0), b(2, 0, 0), c(0, 2, 0);
    CHECK(
        (surface::closest_point_on_triangle({0.5, 0.5, 3}, a, b, c) - Eigen::Vector3d(0.5, 0.5, 0))
            .norm() < 1e-12);
    CHECK((surface::closest_point_on_triangle({-1, -1, 1}, a, b, c) - a).norm() < 1e-12);
    CHECK((surface::closest_point_on_triangle({3, -1, 0}, a, b, c) - b).norm() < 1e-12);
    CHECK((surface::closest_point_on_triangle({1, -1, 0}, a, b, c) - Eigen::Vector3d(1, 0, 0))
              .norm() < 1e-12);
    CHECK(
        (surface::closest_point_on_triangle({2, 2, 0}, a, b, c) - Eigen::Vector3d(1, 1, 0)).norm() <
        1e-12);
}

TEST_CASE("BackgroundPatch projection matches brute force", "[front]") {
    const core::SurfaceNetwork s = fixtures::uv_sphere(10.0, 24);
    const BackgroundPatch patch(s, all_faces(s), false);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-14.0, 14.0);
    for (int i = 0; i < 300; ++i) {
        const Eigen::Vector3d p(u(rng), u(rng), u(rng));
        const auto pr = patch.project(p);
        REQUIRE(pr.face >= 0);
        CHECK(pr.distance == Approx(brute_distance(s, p)).margin(1e-9));
        CHECK((pr.point - p).norm() == Approx(pr.distance).margin(1e-12));
        // The local descent from a random face reaches the global answer on a convex surface.
        const auto local = patch.project(p, static_cast<std::int32_t>(i % s.face_count()));
        CHECK(local.distance == Approx(pr.distance).margin(1e-9));
    }
    // Normals point outward (uv_sphere is outward), and inward when flipped.
    const BackgroundPatch flipped(s, all_faces(s), true);
    const auto pr = patch.project({0, 0, 20});
    CHECK(patch.normal(pr.face).z() > 0.9);
    CHECK(flipped.normal(pr.face).z() < -0.9);
    CHECK(patch.area() == Approx(4 * M_PI * 100).epsilon(0.02));
    // Oriented projection: from inside near the top, only faces facing down qualify on the
    // flipped patch; none facing +z within a small radius of the bottom.
    CHECK(patch.project_oriented({0, 0, -9.9}, {0, 0, 1}, 1.0, 0.5) == std::nullopt);
    CHECK(patch.project_oriented({0, 0, 9.9}, {0, 0, 1}, 1.0, 0.5).has_value());
}

namespace {

// A parametric surface sampled on an nu x nv grid as a triangle background; `wrap_u`/`wrap_v`
// glue the parameter ends (torus). Orientation: right-hand normal along S_u x S_v.
template <class F>
core::SurfaceNetwork grid_surface(int nu, int nv, bool wrap_u, bool wrap_v, F map) {
    core::SurfaceNetwork s;
    const int cu = wrap_u ? nu : nu + 1, cv = wrap_v ? nv : nv + 1;
    for (int j = 0; j < cv; ++j)
        for (int i = 0; i < cu; ++i) s.add_vertex(map(double(i) / nu, double(j) / nv));
    auto id = [&](int i, int j) { return (j % cv) * cu + (i % cu); };
    for (int j = 0; j < nv; ++j)
        for (int i = 0; i < nu; ++i) {
            s.add_face(id(i, j), id(i + 1, j), id(i + 1, j + 1), 1, 0);
            s.add_face(id(i, j), id(i + 1, j + 1), id(i, j + 1), 1, 0);
        }
    return s;
}

struct MeshStats {
    double min_angle = 180.0;
    double fraction_30 = 0.0;  // triangles with min angle >= 30 degrees
    double mean_eta = 0.0;
    double fraction_size = 0.0;  // edges within [0.7 h, 1.4 h]
    double max_distance = 0.0;   // vertices to the background
    long euler = 0;
    bool closed = true;  // every directed edge has its reverse, once
    std::size_t boundary_edges = 0;
    std::size_t faces = 0;
};

MeshStats stats(const surface::PatchMesh& m, const BackgroundPatch& bg, double h) {
    MeshStats st;
    st.faces = m.faces.size();
    std::map<std::pair<int, int>, int> directed;
    std::size_t good = 0;
    for (const auto& f : m.faces) {
        const auto &a = m.points[f[0]], &b = m.points[f[1]], &c = m.points[f[2]];
        const double angle = core::triangle_min_angle_deg(a, b, c);
        st.min_angle = std::min(st.min_angle, angle);
        if (angle >= 30.0) ++good;
        st.mean_eta += core::triangle_skewness(a, b, c);
        for (int k = 0; k < 3; ++k) ++directed[{f[k], f[(k + 1) % 3]}];
    }
    st.fraction_30 = double(good) / double(std::max<std::size_t>(1, m.faces.size()));
    st.mean_eta /= double(std::max<std::size_t>(1, m.faces.size()));
    std::size_t edges = 0, in_range = 0;
    for (const auto& [e, n] : directed) {
        if (n != 1) st.closed = false;
        const auto rev = directed.find({e.second, e.first});
        if (rev == directed.end()) {
            st.closed = false;
            ++st.boundary_edges;
        }
        if (rev == directed.end() || e.first < e.second) {
            ++edges;
            const double len = (m.points[e.first] - m.points[e.second]).norm();
            if (len >= 0.7 * h && len <= 1.4 * h) ++in_range;
        }
    }
    st.fraction_size = double(in_range) / double(std::max<std::size_t>(1, edges));
    for (const auto& p : m.points)
        st.max_distance = std::max(st.max_distance, bg.project(p).distance);
    st.euler = long(m.points.size()) - long(edges) + long(m.faces.size());
    return st;
}

std::string describe(const MeshStats& s) {
    std::ostringstream o;
    o << s.faces << " faces, min angle " << s.min_angle << ", >=30deg " << 100 * s.fraction_30
      << "%, mean eta " << s.mean_eta << ", edges in [0.7h,1.4h] " << 100 * s.fraction_size
      << "%, euler " << s.euler << ", max dist " << s.max_distance;
    return o.str();
}

core::SurfaceNetwork to_network(const surface::PatchMesh& m) {
    core::SurfaceNetwork s;
    for (const auto& p : m.points) s.add_vertex(p);
    for (const auto& f : m.faces) s.add_face(f[0], f[1], f[2], 1, 0);
    return s;
}

long brain_euler(const core::SurfaceNetwork& s) {
    std::set<std::pair<int, int>> edges;
    for (const auto& f : s.faces)
        for (int k = 0; k < 3; ++k) edges.insert(std::minmax(f[k], f[(k + 1) % 3]));
    return long(s.vertex_count()) - long(edges.size()) + long(s.face_count());
}

bool has_directed_edge(const surface::PatchMesh& m, int a, int b) {
    for (const auto& f : m.faces)
        for (int k = 0; k < 3; ++k)
            if (f[k] == a && f[(k + 1) % 3] == b) return true;
    return false;
}

// Points along the closed polygon `corners` at spacing close to h (each side split evenly).
surface::PatchLoop polygon_loop(const std::vector<Eigen::Vector3d>& corners, double h) {
    surface::PatchLoop loop;
    for (std::size_t i = 0; i < corners.size(); ++i) {
        const Eigen::Vector3d &a = corners[i], &b = corners[(i + 1) % corners.size()];
        const int n = std::max(1, int(std::lround((b - a).norm() / h)));
        for (int k = 0; k < n; ++k) loop.points.push_back(a + (b - a) * (double(k) / n));
    }
    return loop;
}

surface::SizeFunction uniform(double h) {
    return [h](const Eigen::Vector3d&, std::int32_t) { return h; };
}

}  // namespace

TEST_CASE("front triangulation of a flat square keeps its loop", "[front]") {
    const auto plane = grid_surface(20, 20, false, false, [](double u, double v) {
        return Eigen::Vector3d(10 * u, 10 * v, 0);
    });
    const BackgroundPatch patch(plane, all_faces(plane), false);
    const double h = 1.0;
    const auto loop = polygon_loop({{0, 0, 0}, {10, 0, 0}, {10, 10, 0}, {0, 10, 0}}, h);
    core::StageContext ctx;
    const auto m = surface::triangulate_patch(patch, {loop}, uniform(h), {}, ctx);
    const MeshStats st = stats(m, patch, h);
    INFO(describe(st));
    WARN(describe(st));
    const int n = int(loop.points.size());
    for (int i = 0; i < n; ++i) {
        CHECK(m.points[i] == loop.points[i]);
        CHECK(has_directed_edge(m, i, (i + 1) % n));
    }
    double area = 0.0;
    for (const auto& f : m.faces) {
        const Eigen::Vector3d nrm =
            (m.points[f[1]] - m.points[f[0]]).cross(m.points[f[2]] - m.points[f[0]]);
        CHECK(nrm.z() > 0.0);
        area += 0.5 * nrm.norm();
    }
    CHECK(area == Approx(100.0).epsilon(1e-9));
    CHECK(st.boundary_edges == std::size_t(n));
    CHECK(st.euler == 1);
    CHECK(st.min_angle > 20.0);
    CHECK(st.fraction_30 > 0.9);
    CHECK(st.mean_eta < 0.1);
    CHECK(st.fraction_size > 0.9);
    CHECK(m.faces.size() > 180);
    CHECK(m.faces.size() < 300);
}

TEST_CASE("front triangulation of a square with a hole (two loops)", "[front]") {
    const auto plane = grid_surface(20, 20, false, false, [](double u, double v) {
        return Eigen::Vector3d(10 * u, 10 * v, 0);
    });
    const BackgroundPatch patch(plane, all_faces(plane), false);
    const double h = 0.8;
    const auto outer = polygon_loop({{0, 0, 0}, {10, 0, 0}, {10, 10, 0}, {0, 10, 0}}, h);
    // The hole runs clockwise (the patch is to the left of its edges).
    const auto inner = polygon_loop({{3, 3, 0}, {3, 6, 0}, {7, 6, 0}, {7, 3, 0}}, h);
    core::StageContext ctx;
    const auto m = surface::triangulate_patch(patch, {outer, inner}, uniform(h), {}, ctx);
    const MeshStats st = stats(m, patch, h);
    INFO(describe(st));
    WARN(describe(st));
    double area = 0.0;
    for (const auto& f : m.faces)
        area += core::triangle_area(m.points[f[0]], m.points[f[1]], m.points[f[2]]);
    CHECK(area == Approx(100.0 - 12.0).epsilon(1e-9));
    CHECK(st.euler == 0);
    CHECK(st.boundary_edges == outer.points.size() + inner.points.size());
    CHECK(st.min_angle > 20.0);
    CHECK(st.mean_eta < 0.1);
}

TEST_CASE("front triangulation closes a sphere without loops", "[front]") {
    const core::SurfaceNetwork sphere = fixtures::uv_sphere(10.0, 64);
    const BackgroundPatch patch(sphere, all_faces(sphere), false);
    const double h = 1.5;
    core::StageContext ctx;
    const auto m = surface::triangulate_patch(patch, {}, uniform(h), {}, ctx);
    const MeshStats st = stats(m, patch, h);
    INFO(describe(st));
    WARN(describe(st));
    CHECK(st.closed);
    CHECK(st.euler == 2);
    CHECK(st.max_distance < 1e-9);
    const auto net = to_network(m);
    CHECK(core::enclosed_volume(net, 1) == Approx(4.0 / 3.0 * M_PI * 1000).epsilon(0.03));
    CHECK(core::self_intersections(net, 1).empty());
    CHECK(st.min_angle > 15.0);
    CHECK(st.fraction_30 > 0.9);
    CHECK(st.mean_eta < 0.1);
    CHECK(st.fraction_size > 0.9);
}

TEST_CASE("front triangulation closes a torus (genus 1)", "[front]") {
    const double R = 10.0, r = 4.0;
    const auto torus = grid_surface(160, 64, true, true, [&](double u, double v) {
        const double a = 2 * M_PI * u, b = 2 * M_PI * v;
        return Eigen::Vector3d((R + r * std::cos(b)) * std::cos(a),
                               (R + r * std::cos(b)) * std::sin(a), r * std::sin(b));
    });
    const BackgroundPatch probe(torus, all_faces(torus), false);
    // Orient outward whatever the parametrisation gives.
    const auto top = probe.project({R, 0, r + 1});
    const bool flip = probe.normal(top.face).z() < 0;
    const BackgroundPatch patch(torus, all_faces(torus), flip);
    const double h = 1.2;
    core::StageContext ctx;
    const auto m = surface::triangulate_patch(patch, {}, uniform(h), {}, ctx);
    const MeshStats st = stats(m, patch, h);
    INFO(describe(st));
    WARN(describe(st));
    CHECK(st.closed);
    CHECK(st.euler == 0);
    CHECK(st.max_distance < 1e-9);
    const auto net = to_network(m);
    CHECK(core::enclosed_volume(net, 1) == Approx(2 * M_PI * M_PI * R * r * r).epsilon(0.03));
    CHECK(core::self_intersections(net, 1).empty());
    CHECK(st.min_angle > 15.0);
    CHECK(st.mean_eta < 0.1);
}

// The Colin27 background (02-repair checkpoint of examples/colin27-brain.yaml) as one closed
// patch. Path from FRONTMESH_COLIN_SURFACE; target size from FRONTMESH_FRONT_H (mm).
TEST_CASE("front triangulation of the Colin27 brain", "[front][e2e][.]") {
    const char* path = std::getenv("FRONTMESH_COLIN_SURFACE");
    if (path == nullptr) {
        FM_SKIP("FRONTMESH_COLIN_SURFACE not set");
    }
    const char* hs = std::getenv("FRONTMESH_FRONT_H");
    const double h = hs ? std::atof(hs) : 2.2;
    const core::SurfaceNetwork brain = io::read_surface(path);
    auto t0 = std::chrono::steady_clock::now();
    const BackgroundPatch patch(brain, all_faces(brain), false);
    auto t1 = std::chrono::steady_clock::now();
    core::StageContext ctx(
        [](double f, const std::string& what) {
            if (std::getenv("FRONTMESH_FRONT_VERBOSE"))
                std::fprintf(stderr, "%.3f %s\n", f, what.c_str());
        },
        {});
    // The remesh frame's size field (gap-limited, curvature-limited, graded).
    surface::SizeFieldParams sp;
    sp.edge_length = h;
    const char* ca = std::getenv("FRONTMESH_FRONT_CURVATURE_DEG");
    sp.curvature_angle_deg = ca ? std::atof(ca) : 0.0;
    const char* tl = std::getenv("FRONTMESH_FRONT_THICKNESS_LAYERS");
    sp.thickness_layers = tl ? std::atoi(tl) : 0;
    const char* hmin = std::getenv("FRONTMESH_FRONT_MIN_H");
    sp.min_edge_length = hmin ? std::atof(hmin) : 0.0;
    const surface::SizeField field = surface::build_size_field(brain, sp, ctx);
    const surface::SizeFunction size = [&](const Eigen::Vector3d& p, std::int32_t f) {
        return field.at(p, f);
    };
    auto t15 = std::chrono::steady_clock::now();
    const auto m = surface::triangulate_patch(patch, {}, size, {}, ctx);
    auto t2 = std::chrono::steady_clock::now();
    const MeshStats st = stats(m, patch, h);
    WARN("h " << h << ": " << describe(st) << "; background ADT "
              << std::chrono::duration<double>(t1 - t0).count() << " s, front "
              << std::chrono::duration<double>(t15 - t1).count() << " s, size field "
              << std::chrono::duration<double>(t2 - t15).count() << " s, local remeshings "
              << ctx.counters().at("remesh.front_local_remeshings"));
    const auto net = to_network(m);
    const auto si = core::self_intersections(net, 100);
    WARN("self-intersecting pairs: " << si.size() << "; volume " << core::enclosed_volume(net, 1)
                                     << " vs background " << core::enclosed_volume(brain, 1));
    if (const char* out = std::getenv("FRONTMESH_FRONT_OUT")) {  // OFF, for a look
        std::ofstream f(out);
        f << "OFF\n" << m.points.size() << " " << m.faces.size() << " 0\n";
        f.precision(17);
        for (const auto& p : m.points) f << p.x() << " " << p.y() << " " << p.z() << "\n";
        for (const auto& t : m.faces) f << "3 " << t[0] << " " << t[1] << " " << t[2] << "\n";
    }
    CHECK(st.closed);
    CHECK(st.euler == brain_euler(brain));
    CHECK(st.max_distance < 1e-9);
    CHECK(si.empty());
}

TEST_CASE("front triangulation over marching-cubes backgrounds of a sphere and a torus",
          "[front]") {
    core::StageContext ctx;
    surface::ExtractParams ep;
    ep.blur_sigma_mm = 1.0;
    struct Case {
        core::LabelImage image;
        double h;
        long euler;
        double volume;
    };
    std::vector<Case> cases;
    cases.push_back({fixtures::sphere_image(48, 18.0), 2.0, 2, fixtures::ball_volume(18.0)});
    cases.push_back({fixtures::torus_image(16.0, 6.0), 2.0, 0, fixtures::torus_volume(16.0, 6.0)});
    for (const Case& c : cases) {
        const core::SurfaceNetwork bg = surface::extract(c.image, ep, ctx);
        const BackgroundPatch patch(bg, all_faces(bg), false);
        surface::FrontParams fp;
        fp.smoothing_iterations = 3;
        const auto m = surface::triangulate_patch(patch, {}, uniform(c.h), fp, ctx);
        const MeshStats st = stats(m, patch, c.h);
        INFO(describe(st));
        WARN(describe(st));
        CHECK(st.closed);
        CHECK(st.euler == c.euler);
        CHECK(st.max_distance < 1e-9);
        const auto net = to_network(m);
        CHECK(core::enclosed_volume(net, 1) == Approx(c.volume).epsilon(0.05));
        CHECK(core::self_intersections(net, 1).empty());
        CHECK(st.min_angle > 15.0);
        CHECK(st.mean_eta < 0.1);
    }
}

// A strip folded into a hairpin: two parallel sheets `gap` apart (the inside faces of the
// fold face each other, like the walls of a sulcus), joined by a half cylinder at x = 10.
TEST_CASE("a stalled front is handed to the diagnostics sink", "[front]") {
    const auto plane = grid_surface(20, 20, false, false, [](double u, double v) {
        return Eigen::Vector3d(10 * u, 10 * v, 0);
    });
    const BackgroundPatch patch(plane, all_faces(plane), false);
    const double h = 1.0;
    // Clockwise: the patch lies to the right of every loop edge, so no triangle fits.
    const auto loop = polygon_loop({{0, 0, 0}, {0, 10, 0}, {10, 10, 0}, {10, 0, 0}}, h);
    surface::FrontParams params;
    params.attempts = 1;
    std::vector<core::Diagnostic> received;
    core::StageContext ctx({}, {}, [&](core::Diagnostic d) { received.push_back(std::move(d)); });
    CHECK_THROWS_AS(surface::triangulate_patch(patch, {loop}, uniform(h), params, ctx),
                    surface::FrontStall);
    // Every edge is stuck: the front gives up at several places, the first four diagnosed.
    REQUIRE(!received.empty());
    CHECK(received.size() <= 4);
    const core::Diagnostic& d = received.front();
    CHECK(!d.name.empty());
    CHECK(d.name.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                   "0123456789-_.") == std::string::npos);
    CHECK(d.what.find("kind") != std::string::npos);
    REQUIRE(d.cells.size() == d.kind.size());
    std::size_t front_edges = 0, background_faces = 0;
    for (std::size_t c = 0; c < d.cells.size(); ++c) {
        CHECK(d.cells[c].size() == (d.kind[c] == 1 ? 2u : 3u));
        for (const std::int32_t id : d.cells[c]) CHECK(std::size_t(id) < d.xyz.size() / 3);
        front_edges += d.kind[c] == 1;
        background_faces += d.kind[c] == 2;
    }
    CHECK(front_edges > 0);
    CHECK(background_faces > 0);

    // Nobody receives diagnostics: the same stall, nothing built.
    core::StageContext quiet;
    CHECK_THROWS_AS(surface::triangulate_patch(patch, {loop}, uniform(h), params, quiet),
                    surface::FrontStall);
}

TEST_CASE("front triangulation does not connect the two sheets of a thin gap", "[front]") {
    const double gap = 0.8, rr = gap / 2, width = 6.0, flat = 10.0;
    const double total = 2 * flat + M_PI * rr;
    auto profile = [&](double t) {  // arc length along the fold -> (x, z)
        if (t <= flat) return Eigen::Vector2d(t, 0.0);
        if (t <= flat + M_PI * rr) {
            const double a = -M_PI / 2 + (t - flat) / rr;
            return Eigen::Vector2d(flat + rr * std::cos(a), rr + rr * std::sin(a));
        }
        return Eigen::Vector2d(flat - (t - flat - M_PI * rr), gap);
    };
    const auto strip = grid_surface(240, 30, false, false, [&](double u, double v) {
        const Eigen::Vector2d xz = profile(u * total);
        return Eigen::Vector3d(xz.x(), v * width, xz.y());
    });
    const BackgroundPatch patch(strip, all_faces(strip), false);
    const double h = 1.0;
    // Size: h on the flat parts, finer over the fold (what the gap-limited size field gives).
    const surface::SizeFunction size = [&](const Eigen::Vector3d& p, std::int32_t) {
        return std::clamp(0.25 + 0.3 * std::max(0.0, flat - 0.5 - p.x()), 0.25, h);
    };
    // The boundary loop: counter-clockwise in the (arc length, y) parameters.
    surface::PatchLoop loop;
    auto on = [&](double t, double y) {
        const Eigen::Vector2d xz = profile(t);
        return Eigen::Vector3d(xz.x(), y, xz.y());
    };
    std::vector<double> ts = {0.0};
    while (ts.back() < total - 1e-9) {
        const double step = size(on(ts.back(), 0), -1);
        ts.push_back(std::min(total, ts.back() + step));
    }
    if (total - ts[ts.size() - 2] < 0.3 * size(on(total, 0), -1)) ts.erase(ts.end() - 2);
    for (std::size_t i = 0; i + 1 < ts.size(); ++i) loop.points.push_back(on(ts[i], 0));
    for (int k = 0; k < 6; ++k) loop.points.push_back(on(total, width * k / 6.0));
    for (std::size_t i = ts.size() - 1; i > 0; --i) loop.points.push_back(on(ts[i], width));
    for (int k = 6; k > 0; --k) loop.points.push_back(on(0, width * k / 6.0));
    core::StageContext ctx;
    const auto m = surface::triangulate_patch(patch, {loop}, size, {}, ctx);
    const MeshStats st = stats(m, patch, h);
    INFO(describe(st));
    WARN(describe(st));
    CHECK(st.euler == 1);
    // The loop follows the analytic fold, a hair off the polygonal background.
    for (std::size_t i = loop.points.size(); i < m.points.size(); ++i)
        CHECK(patch.project(m.points[i]).distance < 1e-9);
    for (const auto& f : m.faces)
        if (core::triangle_min_angle_deg(m.points[f[0]], m.points[f[1]], m.points[f[2]]) < 10)
            WARN("sliver at " << m.points[f[0]].transpose() << " / " << m.points[f[1]].transpose()
                              << " / " << m.points[f[2]].transpose());
    CHECK(core::self_intersections(to_network(m), 1).empty());
    // No edge crosses the gap away from the fold.
    std::size_t crossing = 0;
    for (const auto& f : m.faces)
        for (int k = 0; k < 3; ++k) {
            const auto &p = m.points[f[k]], &q = m.points[f[(k + 1) % 3]];
            if (p.x() < flat - 0.5 && q.x() < flat - 0.5 && std::abs(p.z() - q.z()) > gap / 2)
                ++crossing;
        }
    CHECK(crossing == 0);
    CHECK(st.min_angle > 10.0);
}

// Speed of the triangulator on a large sphere (about 70,000 triangles at h = 1 mm).
TEST_CASE("front triangulation speed on a sphere", "[front][bench][.]") {
    const core::SurfaceNetwork sphere = fixtures::uv_sphere(50.0, 400);
    const BackgroundPatch patch(sphere, all_faces(sphere), false);
    core::StageContext ctx;
    const auto t0 = std::chrono::steady_clock::now();
    const auto m = surface::triangulate_patch(patch, {}, uniform(1.0), {}, ctx);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const MeshStats st = stats(m, patch, 1.0);
    WARN(describe(st) << "; " << s << " s, " << double(m.faces.size()) / s << " triangles/s");
    CHECK(st.closed);
    CHECK(st.euler == 2);
}
