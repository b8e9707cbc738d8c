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
    surface::ExtractParams ep;
    ep.method = surface::ExtractMethod::SurfaceNets;
    ep.smoothing_iterations = 0;  // a raw staircase: plenty to improve
    const auto background =
        surface::repair(surface::extract(fixtures::split_ball_image(36, 12.0), ep, ctx), {}, ctx);
    const auto features = surface::find_features(background, 0.0, ctx);
    REQUIRE(features.curves.size() == 1);

    std::vector<surface::BackgroundPatch> patches;
    std::vector<const surface::BackgroundPatch*> pointers;
    for (const auto& p : features.patches) patches.emplace_back(background, p.faces, false);
    for (const auto& p : patches) pointers.push_back(&p);

    auto s = background;
    surface::SurfaceConstraints c;
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
