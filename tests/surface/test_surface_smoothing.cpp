#include <algorithm>
#include <cmath>

#include <catch2/catch.hpp>

#include "pipeline/core/label_image.h"
#include "pipeline/core/quality.h"
#include "surface/extract.h"
#include "surface/features.h"
#include "surface/repair.h"
#include "surface/surface_smoothing.h"
#include "tests/fixtures/phantoms.h"

using namespace frontmesh;

namespace {

double min_angle(const core::SurfaceNetwork& s) {
    double m = 180.0;
    for (const auto& t : s.faces)
        m = std::min(m, core::triangle_min_angle_deg(s.point(t[0]), s.point(t[1]), s.point(t[2])));
    return m;
}

double mean_skewness(const core::SurfaceNetwork& s) {
    double sum = 0.0;
    for (const auto& t : s.faces)
        sum += core::triangle_skewness(s.point(t[0]), s.point(t[1]), s.point(t[2]));
    return sum / double(s.face_count());
}

// Distance of the polyline (a_0 ... a_n) to p.
double polyline_distance(const std::vector<Eigen::Vector3d>& pl, const Eigen::Vector3d& p) {
    double best = 1e300;
    for (std::size_t i = 0; i + 1 < pl.size(); ++i) {
        const Eigen::Vector3d d = pl[i + 1] - pl[i];
        const double t =
            d.squaredNorm() > 0 ? std::clamp((p - pl[i]).dot(d) / d.squaredNorm(), 0.0, 1.0) : 0.0;
        best = std::min(best, (pl[i] + t * d - p).norm());
    }
    return best;
}

// A raw surface-nets split ball (two half balls and the outside: one junction curve) with
// its patches and the constraints the smoothing takes: every vertex on its background.
struct SplitBall {
    core::SurfaceNetwork background;
    surface::Features features;
    std::vector<surface::BackgroundPatch> patches;
    std::vector<const surface::BackgroundPatch*> pointers;
    core::SurfaceNetwork s;
    surface::SurfaceConstraints c;

    SplitBall(core::StageContext& ctx, int smoothing_iterations) {
        surface::ExtractParams ep;
        ep.method = surface::ExtractMethod::SurfaceNets;
        ep.smoothing_iterations = smoothing_iterations;
        background = surface::repair(
            surface::extract(fixtures::split_ball_image(36, 12.0), ep, ctx), {}, ctx);
        features = surface::find_features(background, 0.0, ctx);
        for (const auto& p : features.patches) patches.emplace_back(background, p.faces, false);
        for (const auto& p : patches) pointers.push_back(&p);
        s = background;
        c.face_patch = features.face_patch;
        c.vertex_face.assign(s.vertex_count(), -1);
        for (std::size_t f = 0; f < s.face_count(); ++f)
            for (const auto v : s.faces[f]) c.vertex_face[std::size_t(v)] = std::int32_t(f);
        for (const auto& fc : features.curves) {
            surface::SurfaceCurve curve;
            curve.is_closed = fc.is_closed;
            curve.vertices = fc.vertices;
            double arc = 0.0;
            for (std::size_t i = 0; i < fc.vertices.size(); ++i) {
                curve.polyline.push_back(background.point(fc.vertices[i]));
                if (i > 0) arc += (curve.polyline[i] - curve.polyline[i - 1]).norm();
                curve.s.push_back(arc);
            }
            c.curves.push_back(curve);
        }
    }
    SplitBall(const SplitBall&) = delete;
};

}  // namespace

TEST_CASE("smoothing a marching-cubes ball raises its quality and stays on it", "[remesh]") {
    core::StageContext ctx;
    surface::ExtractParams ep;
    ep.method = surface::ExtractMethod::FlyingEdges;
    const auto background = surface::repair(
        surface::extract(fixtures::sphere_image(40, 14.0, 1.0, 1), ep, ctx), {}, ctx);
    std::vector<std::int32_t> all(background.face_count());
    for (std::size_t f = 0; f < all.size(); ++f) all[f] = std::int32_t(f);
    const surface::BackgroundPatch patch(background, all, false);
    auto s = background;
    surface::SurfaceConstraints c;
    c.face_patch.assign(s.face_count(), 0);
    c.vertex_face.assign(s.vertex_count(), -1);
    surface::SmoothingParams params;
    params.iterations = 10;
    const double before = min_angle(s);
    const double eta_before = mean_skewness(s);
    const auto report = surface::smooth_surface(s, {&patch}, c, params, ctx);
    CHECK(report.moves > 0);
    CHECK(report.min_angle_before_deg == Approx(before));
    CHECK(report.min_angle_after_deg == Approx(min_angle(s)));
    INFO("min angle " << before << " -> " << min_angle(s) << ", eta " << eta_before << " -> "
                      << mean_skewness(s) << ", moves " << report.moves << ", flips "
                      << report.flips);
    CHECK(min_angle(s) >= before);
    CHECK(mean_skewness(s) < 0.8 * eta_before);
    for (std::size_t v = 0; v < s.vertex_count(); ++v)
        CHECK(patch.project(s.point(std::int32_t(v))).distance < 1e-9);
    const auto checks = core::check_region_boundaries(s);
    REQUIRE(checks.size() == 1);
    CHECK(checks[0].is_closed());
    CHECK(checks[0].is_oriented());
    CHECK(checks[0].nonmanifold_edges == 0);
}

TEST_CASE("smoothing a surface-nets network: curves slide on themselves, patches kept",
          "[remesh]") {
    core::StageContext ctx;
    SplitBall ball(ctx, 0);  // a raw staircase: plenty to improve
    REQUIRE(ball.features.curves.size() == 1);
    const auto& background = ball.background;
    const auto& pointers = ball.pointers;
    auto& s = ball.s;
    auto& c = ball.c;
    const double before = min_angle(s);
    const double eta_before = mean_skewness(s);
    surface::SmoothingParams params;
    params.iterations = 8;
    const auto report = surface::smooth_surface(s, pointers, c, params, ctx);
    INFO("min angle " << before << " -> " << min_angle(s) << ", eta " << eta_before << " -> "
                      << mean_skewness(s) << ", moves " << report.moves << ", flips "
                      << report.flips);
    CHECK(min_angle(s) >= before);
    CHECK(mean_skewness(s) < eta_before);
    CHECK(report.flips > 0);
    // Curve vertices stay on the junction polyline; the others on their own patch.
    std::vector<char> on_curve(s.vertex_count(), 0);
    for (const auto& curve : c.curves)
        for (const auto v : curve.vertices) {
            on_curve[std::size_t(v)] = 1;
            CHECK(polyline_distance(curve.polyline, s.point(v)) < 1e-9);
        }
    for (std::size_t f = 0; f < s.face_count(); ++f)
        for (const auto v : s.faces[f])
            if (!on_curve[std::size_t(v)])
                CHECK(pointers[std::size_t(c.face_patch[f])]->project(s.point(v)).distance < 1e-9);
    // Regions still closed and oriented, interfaces still shared (3 regions -> 2 labels).
    for (const auto& check : core::check_region_boundaries(s)) {
        INFO("region " << check.region);
        CHECK(check.is_closed());
        CHECK(check.is_oriented());
        CHECK(check.volume ==
              Approx(core::enclosed_volume(background, check.region)).epsilon(0.01));
    }
    CHECK(core::region_labels(s) == core::region_labels(background));
}

TEST_CASE("obtuse faces are split at their longest edge, on curves and inside patches",
          "[remesh]") {
    core::StageContext ctx;
    SplitBall ball(ctx, surface::ExtractParams{}.smoothing_iterations);
    REQUIRE(ball.features.curves.size() == 1);
    const auto& pointers = ball.pointers;
    auto& s = ball.s;
    auto& c = ball.c;
    std::vector<char> on_curve(s.vertex_count(), 0);
    for (const auto& curve : c.curves)
        for (const auto v : curve.vertices) on_curve[std::size_t(v)] = 1;
    // Obtuse faces: every tenth face with exactly one vertex off the curves has that vertex
    // moved 75% of the way to the middle of its opposite edge (on its patch), once per vertex;
    // with two curve vertices the long edge is a curve edge.
    std::vector<char> moved(s.vertex_count(), 0);
    std::size_t on_curve_edges = 0;
    for (std::size_t f = 0; f < s.face_count(); f += 10) {
        const auto t = s.faces[f];
        for (int i = 0; i < 3; ++i) {
            const auto v = t[std::size_t(i)], a = t[std::size_t((i + 1) % 3)],
                       b = t[std::size_t((i + 2) % 3)];
            if (on_curve[std::size_t(v)] || moved[std::size_t(v)] || moved[std::size_t(a)] ||
                moved[std::size_t(b)])
                continue;
            const Eigen::Vector3d goal =
                s.point(v) + 0.75 * (0.5 * (s.point(a) + s.point(b)) - s.point(v));
            s.point(v) = pointers[std::size_t(c.face_patch[f])]->project(goal).point;
            moved[std::size_t(v)] = 1;
            on_curve_edges += on_curve[std::size_t(a)] && on_curve[std::size_t(b)];
            break;
        }
    }
    const auto count_over = [](const core::SurfaceNetwork& net, double deg) {
        std::size_t n = 0;
        for (const auto& t : net.faces) {
            const Eigen::Vector3d p = net.point(t[0]), q = net.point(t[1]), r = net.point(t[2]);
            const double a = std::atan2((q - p).cross(r - p).norm(), (q - p).dot(r - p));
            const double b = std::atan2((r - q).cross(p - q).norm(), (r - q).dot(p - q));
            n += std::max({a, b, M_PI - a - b}) * 180.0 / M_PI > deg;
        }
        return n;
    };
    const std::size_t over_before = count_over(s, 130.0);
    const double min_before = min_angle(s);
    REQUIRE(over_before > 20);
    REQUIRE(on_curve_edges > 3);
    const std::size_t faces_before = s.face_count();

    const std::size_t splits = surface::split_obtuse_faces(s, pointers, c, 120.0, 15.0);
    const std::size_t over_after = count_over(s, 130.0);
    INFO("faces over 130 deg " << over_before << " -> " << over_after << ", splits " << splits
                               << ", min angle " << min_before << " -> " << min_angle(s));
    CHECK(splits > 0);
    CHECK(over_after * 2 < over_before);
    CHECK(s.face_count() > faces_before);
    CHECK(min_angle(s) >= std::min(min_before, 20.0) - 1e-9);
    // Constraints grew with the surface; curve vertices in arc-length order on the polyline,
    // the others on the patch of their faces.
    REQUIRE(c.face_patch.size() == s.face_count());
    REQUIRE(c.vertex_face.size() == s.vertex_count());
    std::vector<char> curve_vertex(s.vertex_count(), 0);
    std::size_t curve_vertices_added = 0;
    for (const auto& curve : c.curves) {
        REQUIRE(curve.vertices.size() == curve.s.size());
        for (std::size_t i = 0; i < curve.vertices.size(); ++i) {
            const auto v = curve.vertices[i];
            curve_vertex[std::size_t(v)] = 1;
            curve_vertices_added += std::size_t(v) >= on_curve.size();
            CHECK(polyline_distance(curve.polyline, s.point(v)) < 1e-9);
            if (i > 0) CHECK(curve.s[i] > curve.s[i - 1]);
        }
    }
    CHECK(curve_vertices_added > 0);
    for (std::size_t f = 0; f < s.face_count(); ++f)
        for (const auto v : s.faces[f])
            if (!curve_vertex[std::size_t(v)])
                CHECK(pointers[std::size_t(c.face_patch[f])]->project(s.point(v)).distance < 1e-9);
    for (const auto& check : core::check_region_boundaries(s)) {
        INFO("region " << check.region);
        CHECK(check.is_closed());
        CHECK(check.is_oriented());
        CHECK(check.nonmanifold_edges == 0);
    }
    // The smoothing runs on the grown constraints and keeps its promise there.
    const double min_after_split = min_angle(s);
    surface::SmoothingParams params;
    params.iterations = 2;
    surface::smooth_surface(s, pointers, c, params, ctx);
    CHECK(min_angle(s) >= min_after_split - 1e-9);
}
