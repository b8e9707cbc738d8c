#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <set>
#include <tuple>

#include <tbb/global_control.h>
#include <catch2/catch.hpp>

#include "pipeline/core/error.h"
#include "pipeline/core/label_image.h"
#include "pipeline/core/quality.h"
#include "pipeline/core/self_intersection.h"
#include "surface/extract.h"
#include "surface/features.h"
#include "surface/front_triangulate.h"
#include "surface/remesh.h"
#include "surface/remesh_internal.h"
#include "surface/repair.h"
#include "surface/size_field.h"
#include "tests/fixtures/phantoms.h"

using namespace frontmesh;

namespace {

core::SurfaceNetwork background_of(const core::LabelImage& image, surface::ExtractMethod method,
                                   double blur = 0.0) {
    core::StageContext ctx;
    surface::ExtractParams params;
    params.method = method;
    params.blur_sigma_mm = blur;
    return surface::repair(surface::extract(image, params, ctx), {}, ctx);
}

// The acceptance checks of issue 3 that hold for any input.
void check_remeshed(const core::SurfaceNetwork& bg, const surface::RemeshResult& r,
                    double volume_tolerance) {
    const auto& s = r.surface;
    REQUIRE(s.face_count() > 0);
    CHECK(r.target_size.size() == s.vertex_count());
    CHECK(core::region_labels(s) == core::region_labels(bg));
    for (const auto& c : core::check_region_boundaries(s)) {
        INFO("region " << c.region);
        CHECK(c.is_closed());
        CHECK(c.is_oriented());
        CHECK(c.nonmanifold_edges == 0);
        CHECK(c.volume == Approx(core::enclosed_volume(bg, c.region)).epsilon(volume_tolerance));
    }
    CHECK(core::self_intersections(s, 1).empty());
    // Every vertex on the background.
    std::vector<std::int32_t> all(bg.face_count());
    for (std::size_t f = 0; f < all.size(); ++f) all[f] = std::int32_t(f);
    const surface::BackgroundPatch whole(bg, all, false);
    double worst = 0.0;
    for (std::size_t v = 0; v < s.vertex_count(); ++v)
        worst = std::max(worst, whole.project(s.point(std::int32_t(v))).distance);
    CHECK(worst < 1e-9);
}

}  // namespace

TEST_CASE("remesh a cube with sharp edges: corners and edges kept", "[remesh]") {
    const auto bg = fixtures::grid_box(10.0, 10.0, 10.0, 1.0);
    surface::RemeshParams params;
    params.edge_length = 1.5;
    params.feature_angle_deg = 30.0;
    core::StageContext ctx;
    const auto r = surface::remesh(bg, params, ctx);
    check_remeshed(bg, r, 1e-9);  // flat sides: the volume is exact
    CHECK(ctx.counters().at("remesh.corners") == 8);
    CHECK(ctx.counters().at("remesh.patches") == 6);
    // The eight corners are output vertices; every vertex lies on the cube's sides.
    int corners = 0;
    for (std::size_t v = 0; v < r.surface.vertex_count(); ++v) {
        const auto p = r.surface.point(std::int32_t(v));
        int on_planes = 0;
        for (int k = 0; k < 3; ++k)
            if (std::abs(p[k]) < 1e-12 || std::abs(p[k] - 10.0) < 1e-12) ++on_planes;
        CHECK(on_planes >= 1);
        if (on_planes == 3) ++corners;
    }
    CHECK(corners == 8);
    const auto q = surface::surface_quality(r.surface);
    INFO("min angle " << q.min_angle_deg << ", mean eta " << q.mean_eta);
    CHECK(q.min_angle_deg >= 20.0);
}

TEST_CASE("remesh a marching-cubes ball: uniform, quality, on the background", "[remesh]") {
    const auto bg = background_of(fixtures::sphere_image(48, 18.0, 1.0, 1),
                                  surface::ExtractMethod::FlyingEdges, 1.0);
    surface::RemeshParams params;
    params.edge_length = 2.0;
    params.preserve_volume = false;  // every vertex exactly on the background
    core::StageContext ctx;
    const auto r = surface::remesh(bg, params, ctx);
    check_remeshed(bg, r, 0.01);
    const auto q = surface::surface_quality(r.surface);
    const double in_band = surface::edge_length_fraction(r.surface, 0.7 * 2.0, 1.4 * 2.0);
    INFO("faces " << q.faces << ", min angle " << q.min_angle_deg
                  << ", >=30: " << q.fraction_at_least_30_deg << ", mean eta " << q.mean_eta
                  << ", band " << in_band);
    CHECK(q.min_angle_deg >= 20.0);
    CHECK(q.fraction_at_least_30_deg >= 0.99);
    CHECK(q.mean_eta <= 0.05);
    CHECK(in_band >= 0.95);
    for (const double h : r.target_size) CHECK(h == Approx(2.0));
    const auto hd = surface::hausdorff_distance(r.surface, bg);
    CHECK(hd.max() < 0.3);  // chords of a 2 mm mesh on an R = 18 mm ball
    CHECK(ctx.counters().count("remesh.faces") == 1);

    // remesh.preserve_volume (the default): the chords' loss is taken back within h / 10 of
    // the background, and the quality holds.
    params.preserve_volume = true;
    core::StageContext kept_ctx;
    const auto kept = surface::remesh(bg, params, kept_ctx);
    const double before = core::enclosed_volume(r.surface, 1),
                 after = core::enclosed_volume(kept.surface, 1);
    const double target = core::enclosed_volume(bg, 1);
    CHECK(std::abs(before / target - 1.0) > 0.003);
    CHECK(after == Approx(target).epsilon(0.001));
    CHECK(surface::hausdorff_distance(kept.surface, bg).a_to_b <= 0.1 * 2.0 + 1e-9);
    CHECK(surface::surface_quality(kept.surface).min_angle_deg >= 20.0);
    CHECK(kept_ctx.counters().at("remesh.volume_error_percent") < 0.1);
}

TEST_CASE("remesh the nested three-region phantom: shared interfaces", "[remesh]") {
    const auto bg = background_of(fixtures::nested_ellipsoids_image(1.0, 0.8),
                                  surface::ExtractMethod::SurfaceNets);
    surface::RemeshParams params;
    params.edge_length = 2.0;
    params.preserve_volume = false;  // every vertex exactly on the background
    core::StageContext ctx;
    const auto r = surface::remesh(bg, params, ctx);
    check_remeshed(bg, r, 0.01);
    const auto q = surface::surface_quality(r.surface);
    INFO("faces " << q.faces << ", min angle " << q.min_angle_deg
                  << ", >=30: " << q.fraction_at_least_30_deg << ", mean eta " << q.mean_eta);
    CHECK(q.min_angle_deg >= 20.0);
    CHECK(q.fraction_at_least_30_deg >= 0.99);
    CHECK(q.mean_eta <= 0.05);
    // Interfaces stored once: the output has the background's three region pairs, each once.
    std::set<std::pair<core::Label, core::Label>> pairs_bg, pairs_out;
    for (std::size_t f = 0; f < bg.face_count(); ++f)
        pairs_bg.insert({bg.region_in[f], bg.region_out[f]});
    for (std::size_t f = 0; f < r.surface.face_count(); ++f)
        pairs_out.insert({r.surface.region_in[f], r.surface.region_out[f]});
    CHECK(pairs_out == pairs_bg);
}

TEST_CASE("remesh a split ball: the junction circle is kept and shared", "[remesh]") {
    const auto bg =
        background_of(fixtures::split_ball_image(44, 16.0), surface::ExtractMethod::SurfaceNets);
    surface::RemeshParams params;
    params.edge_length = 2.0;
    params.preserve_volume = false;  // every vertex exactly on the background
    core::StageContext ctx;
    const auto r = surface::remesh(bg, params, ctx);
    check_remeshed(bg, r, 0.01);
    const auto q = surface::surface_quality(r.surface);
    INFO("faces " << q.faces << ", min angle " << q.min_angle_deg << ", mean eta " << q.mean_eta);
    CHECK(q.min_angle_deg >= 20.0);
    // The output's junction: one closed curve, its vertices on the background's junction.
    const auto fb = surface::find_features(bg, 0.0, ctx);
    const auto fo = surface::find_features(r.surface, 0.0, ctx);
    REQUIRE(fo.curves.size() == 1);
    CHECK(fo.patches.size() == 3);
    std::vector<Eigen::Vector3d> junction;
    for (const auto v : fb.curves[0].vertices) junction.push_back(bg.point(v));
    for (const auto v : fo.curves[0].vertices) {
        double best = 1e300;
        const Eigen::Vector3d p = r.surface.point(v);
        for (std::size_t i = 0; i + 1 < junction.size(); ++i) {
            const Eigen::Vector3d d = junction[i + 1] - junction[i];
            const double t = std::clamp((p - junction[i]).dot(d) / d.squaredNorm(), 0.0, 1.0);
            best = std::min(best, (junction[i] + t * d - p).norm());
        }
        CHECK(best < 1e-9);
    }
}

TEST_CASE("remesh is deterministic and validates its parameters", "[remesh]") {
    const auto bg =
        background_of(fixtures::split_ball_image(30, 10.0), surface::ExtractMethod::SurfaceNets);
    surface::RemeshParams params;
    params.edge_length = 2.0;
    core::StageContext c1, c2;
    const auto a = surface::remesh(bg, params, c1);
    const auto b = [&] {
        const tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
        return surface::remesh(bg, params, c2);
    }();
    CHECK(a.surface.xyz == b.surface.xyz);
    CHECK(a.surface.faces == b.surface.faces);
    CHECK(a.target_size == b.target_size);
    params.gradation = 0.9;
    CHECK_THROWS_WITH(surface::remesh(bg, params, c1), Catch::Contains("remesh.gradation"));
    params.gradation = 1.3;
    params.feature_angle_deg = 200;
    CHECK_THROWS_AS(surface::remesh(bg, params, c1), core::InputError);
}

TEST_CASE("the retry policy owns every size multiplier of the rounds", "[remesh]") {
    // Two triangles of one region's (open) sheet are enough for the policy's arithmetic.
    core::SurfaceNetwork bg;
    for (const Eigen::Vector3d& p : {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(40, 0, 0),
                                     Eigen::Vector3d(40, 40, 0), Eigen::Vector3d(0, 40, 0)})
        bg.add_vertex(p);
    bg.add_face(0, 1, 2, 1, 0);
    bg.add_face(0, 2, 3, 1, 0);
    const surface::SizeField field(bg, std::vector<double>(4, 2.0));
    surface::Features features;
    surface::Patch patch;
    patch.region_in = 1;
    patch.faces = {0, 1};
    features.patches.push_back(patch);
    surface::remesh_detail::RetryPolicy retry(bg, field, 1);
    core::AdtBox whole = core::AdtBox::of_point(Eigen::Vector3d(0, 0, 0));
    whole.extend(Eigen::Vector3d(40, 40, 0));

    const Eigen::Vector3d far(30, 30, 0);
    CHECK(retry.size(far, 0) == Approx(2.0));
    CHECK(retry.vertex_size(2) == 2.0);
    CHECK(!retry.has_new_sizes(0, whole));

    // A first stall: a shrink site of radius 4 h = 8 mm: 1/2 within it, 1 beyond 16 mm.
    const Eigen::Vector3d place(10, 10, 0);
    retry.on_stall(0, 2, {place}, 0);
    CHECK(!retry.copy(0));
    CHECK(retry.shrink(place) == 0.5);
    CHECK(retry.shrink(place + Eigen::Vector3d(12, 0, 0)) == Approx(0.75));
    CHECK(retry.shrink(place + Eigen::Vector3d(20, 0, 0)) == 1.0);
    CHECK(retry.size(place, 0) == 1.0);
    CHECK(retry.has_new_sizes(0, whole));
    retry.mark_sizes_used();
    CHECK(!retry.has_new_sizes(0, whole));
    // Sites of one round do not compound (torture seed 136); rounds multiply, never below
    // 1/8.
    retry.on_open_edges({place, place, place, place});
    CHECK(retry.shrink(place) == 0.25);
    for (int round = 0; round < 3; ++round) {
        retry.mark_sizes_used();
        retry.on_open_edges({place, place});
    }
    CHECK(retry.shrink(place) == 0.125);
    // A second stall of the same (small) patch: it keeps its background triangles, no new
    // site.
    retry.mark_sizes_used();
    retry.on_stall(0, 2, {far}, 1);
    CHECK(retry.copy(0));
    CHECK(!retry.has_new_sizes(0, whole));
    CHECK(retry.cuts().empty());
    // A patch of kMinCutFaces faces or more is cut around the places instead.
    using surface::remesh_detail::RetryPolicy;
    RetryPolicy big(bg, field, 1);
    big.on_stall(0, RetryPolicy::kMinCutFaces, {place}, 0);
    big.on_stall(0, RetryPolicy::kMinCutFaces, {place, far}, 1);
    CHECK(!big.copy(0));
    REQUIRE(big.cuts().size() == 1);
    CHECK(big.cuts()[0].places.size() == 2);
    // The policy of the cut features: the cut part keeps its background triangles, the rest
    // counts one stall (its next one is a second), sizes carry over.
    RetryPolicy after(std::move(big), {-1, -1}, {1, 0});
    CHECK(after.cuts().empty());
    CHECK(after.copy(0));
    CHECK(!after.copy(1));
    CHECK(after.shrink(place) == 0.5);
    after.on_stall(1, RetryPolicy::kMinCutFaces, {far}, 2);
    CHECK(after.cuts().size() == 1);
    // In a late round a first stall copies the patch at once, large or not: the last round
    // must not stall there. The rounds before are not late.
    CHECK(!RetryPolicy::late(RetryPolicy::kRounds - RetryPolicy::kLateRounds - 2));
    CHECK(RetryPolicy::late(RetryPolicy::kRounds - RetryPolicy::kLateRounds - 1));
    RetryPolicy late(bg, field, 1);
    late.on_stall(0, RetryPolicy::kMinCutFaces, {place}, RetryPolicy::kRounds - 2);
    CHECK(late.copy(0));
    CHECK(late.cuts().empty());
    RetryPolicy crossed(bg, field, 1);
    crossed.on_bad_faces({0, 1}, bg, {0, 0}, RetryPolicy::kRounds - 2);
    CHECK(crossed.copy(0));

    // A region that lost 20% of its volume against a 10% limit: x 0.9 sqrt(1/2); a change
    // of 80% would ask for less than the floor of 0.5.
    const double factor = 0.9 * std::sqrt(0.5);
    retry.on_volume_change(features, 1, -20.0, 10.0);
    CHECK(retry.has_new_sizes(0, whole));
    CHECK(retry.size(far, 1) == Approx(2.0 * factor));
    CHECK(retry.vertex_size(2) == 2.0);  // vertices follow at update_vertex_scales()
    retry.update_vertex_scales();
    CHECK(retry.vertex_size(2) == Approx(2.0 * factor));
    retry.on_volume_change(features, 1, 80.0, 10.0);
    CHECK(retry.size(far, 1) == Approx(2.0 * factor * 0.5));
    CHECK(retry.size(far, -1) == 2.0);  // no face: no volume scale
    CHECK(retry.round_summary(1).find("round 2") != std::string::npos);
}

TEST_CASE("late rounds change no size: volume changes are left, bad patches copied", "[remesh]") {
    using surface::remesh_detail::RetryPolicy;
    const core::SurfaceNetwork bg = fixtures::octahedron(10.0);
    core::SurfaceNetwork shrunk = bg;  // every vertex at 0.8: the volume -48.8%
    for (double& c : shrunk.xyz) c *= 0.8;
    const surface::SizeField field(bg, std::vector<double>(bg.vertex_count(), 2.0));
    surface::Features features;
    surface::Patch patch;
    patch.region_in = 1;
    for (std::int32_t f = 0; f < std::int32_t(bg.face_count()); ++f) patch.faces.push_back(f);
    features.patches.push_back(patch);
    const std::vector<std::int32_t> face_patch(bg.face_count(), 0);
    surface::RemeshParams params;
    params.max_volume_change_percent = 1.0;
    core::AdtBox whole = core::AdtBox::of_point(Eigen::Vector3d(-10, -10, -10));
    whole.extend(Eigen::Vector3d(10, 10, 10));
    const int first_late = RetryPolicy::kRounds - RetryPolicy::kLateRounds - 1;

    // Before the late rounds the region's patches get finer sizes.
    RetryPolicy early(bg, field, 1);
    core::StageContext c0;
    const auto r0 = surface::remesh_detail::check_regions(bg, shrunk, face_patch, features, params,
                                                          first_late - 1, early, c0);
    CHECK(!r0.again);
    CHECK(r0.rescaled.find(" 1 (") != std::string::npos);
    CHECK(early.has_new_sizes(0, whole));

    // In a late round the change is only a warning: no new size could start a new stall.
    RetryPolicy late(bg, field, 1);
    core::StageContext c1;
    const auto r1 = surface::remesh_detail::check_regions(bg, shrunk, face_patch, features, params,
                                                          first_late, late, c1);
    CHECK(!r1.again);
    CHECK(r1.rescaled.empty());
    CHECK(!late.has_new_sizes(0, whole));
    CHECK(!late.copy(0));
    REQUIRE(r1.volume_warnings.size() == 1);
    CHECK_THAT(r1.volume_warnings.front(), Catch::Contains("changed its volume"));
    CHECK(c1.warnings().empty());  // logged only by the round that stands

    // An open region in a late round: the patch at its open edges keeps its background
    // triangles (no shrink site), and the round is meshed again.
    core::SurfaceNetwork open = bg;
    open.faces.pop_back();
    open.region_in.pop_back();
    open.region_out.pop_back();
    const std::vector<std::int32_t> open_patch(open.face_count(), 0);
    RetryPolicy opened(bg, field, 1);
    core::StageContext c2;
    const auto r2 = surface::remesh_detail::check_regions(bg, open, open_patch, features, params,
                                                          first_late, opened, c2);
    CHECK(r2.again);
    CHECK(opened.copy(0));
    CHECK(opened.shrink(Eigen::Vector3d(0, 0, 10)) == 1.0);
    REQUIRE(!c2.warnings().empty());
    CHECK_THAT(c2.warnings().front(), Catch::Contains("keep their background triangles"));
    // The same before the late rounds: finer there, not copied.
    RetryPolicy early_open(bg, field, 1);
    core::StageContext c3;
    CHECK(surface::remesh_detail::check_regions(bg, open, open_patch, features, params,
                                                first_late - 1, early_open, c3)
              .again);
    CHECK(!early_open.copy(0));
    CHECK(early_open.has_new_sizes(0, whole));
}

TEST_CASE("a patch is cut around the places where its front stalled", "[remesh]") {
    // A flat 30 x 30 mm sheet of 1 mm squares, one patch of one region.
    core::SurfaceNetwork bg;
    constexpr int n = 30;
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) bg.add_vertex(Eigen::Vector3d(i, j, 0));
    auto id = [](int i, int j) { return j * (n + 1) + i; };
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            bg.add_face(id(i, j), id(i + 1, j), id(i + 1, j + 1), 1, 0);
            bg.add_face(id(i, j), id(i + 1, j + 1), id(i, j + 1), 1, 0);
        }
    core::StageContext ctx;
    const surface::Features features = surface::find_features(bg, 0.0, ctx);
    REQUIRE(features.patches.size() == 1);
    const surface::SizeField field(bg, std::vector<double>(bg.vertex_count(), 1.0));
    std::vector<std::int32_t> face_part;
    const Eigen::Vector3d place(15, 15, 0);
    const std::int32_t first =
        surface::remesh_detail::cut_patches(bg, features, field, {{0, {place}}}, face_part);
    CHECK(first == 1);
    // The faces within 4 h = 4 mm of the place, and no face beyond 4 mm plus a notch.
    std::size_t in_part = 0;
    for (std::size_t f = 0; f < bg.face_count(); ++f) {
        const auto& t = bg.faces[f];
        const Eigen::Vector3d c = (bg.point(t[0]) + bg.point(t[1]) + bg.point(t[2])) / 3.0;
        if ((c - place).norm() <= 4.0) CHECK(face_part[f] == 1);
        if ((c - place).norm() > 6.0) CHECK(face_part[f] == 0);
        in_part += face_part[f] == 1;
    }
    CHECK(in_part > 80);
    // The features of the parts: the disk, and the rest with the disk's boundary as a loop.
    const surface::Features cut = surface::find_features(bg, 0.0, ctx, face_part);
    REQUIRE(cut.patches.size() == 2);
    std::size_t loops = 0;
    for (const auto& p : cut.patches) loops += p.loops.size();
    CHECK(loops == 3);  // the disk's boundary twice, the sheet's outer boundary once
    // A place whose disk would take half of the patch takes all of it.
    const surface::SizeField coarse(bg, std::vector<double>(bg.vertex_count(), 3.5));
    std::vector<std::int32_t> all;
    surface::remesh_detail::cut_patches(bg, features, coarse, {{0, {place}}}, all);
    CHECK(std::count(all.begin(), all.end(), 1) == std::int64_t(bg.face_count()));
}

TEST_CASE("a copied patch loses its needles and keeps its boundary (coarsen_patch, light)",
          "[remesh]") {
    // A flat 10 x 10 mm sheet of 1 mm squares whose vertex (5, 5) sits 0.05 mm from (6, 5):
    // two needles, as marching cubes leaves them at a voxel corner.
    core::SurfaceNetwork bg;
    constexpr int n = 10;
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i)
            bg.add_vertex(i == 5 && j == 5 ? Eigen::Vector3d(5.95, 5, 0)
                                           : Eigen::Vector3d(i, j, 0));
    auto id = [](int i, int j) { return j * (n + 1) + i; };
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            bg.add_face(id(i, j), id(i + 1, j), id(i + 1, j + 1), 1, 0);
            bg.add_face(id(i, j), id(i + 1, j + 1), id(i, j + 1), 1, 0);
        }
    std::vector<std::int32_t> all(bg.face_count());
    for (std::size_t f = 0; f < all.size(); ++f) all[f] = std::int32_t(f);
    const surface::BackgroundPatch patch(bg, all, false);
    // The patch mesh: boundary points first (fixed), then the inner ones.
    surface::PatchMesh mesh;
    std::vector<std::int32_t> at(bg.vertex_count(), -1);
    for (const bool boundary : {true, false})
        for (int j = 0; j <= n; ++j)
            for (int i = 0; i <= n; ++i)
                if ((i == 0 || j == 0 || i == n || j == n) == boundary) {
                    at[std::size_t(id(i, j))] = std::int32_t(mesh.points.size());
                    mesh.points.push_back(bg.point(id(i, j)));
                    mesh.point_face.push_back(0);
                }
    for (const auto& t : bg.faces)
        mesh.faces.push_back({at[std::size_t(t[0])], at[std::size_t(t[1])], at[std::size_t(t[2])]});
    const std::size_t fixed = 4 * n;
    auto worst_angle = [](const surface::PatchMesh& m) {
        double worst = 180.0;
        for (const auto& t : m.faces)
            worst = std::min(worst, core::triangle_min_angle_deg(m.points[std::size_t(t[0])],
                                                                 m.points[std::size_t(t[1])],
                                                                 m.points[std::size_t(t[2])]));
        return worst;
    };
    REQUIRE(worst_angle(mesh) < 3.0);
    // A size far below the squares: the light mode's scale is the mesh's own edges.
    const surface::SizeFunction size = [](const Eigen::Vector3d&, std::int32_t) { return 0.2; };
    const surface::PatchMesh out =
        surface::remesh_detail::coarsen_patch(patch, mesh, fixed, size, 0.3);
    CHECK(out.faces.size() == mesh.faces.size() - 2);  // one collapse: the needles' edge
    CHECK(worst_angle(out) > 15.0);                    // the squares around the gap, stretched
    for (std::size_t k = 0; k < fixed; ++k) CHECK(out.points[k] == mesh.points[k]);
    for (const auto& p : out.points)  // every point a background vertex
        CHECK(std::find(mesh.points.begin(), mesh.points.end(), p) != mesh.points.end());
}

namespace {

// Two tets on the edge T-U: region 1 (T, U, P1, P2) with a wedge of 30 degrees there, region
// 2 (T, U, P2, P3) beside it with a wedge of `wedge2_deg`; faces oriented out of region_in.
core::SurfaceNetwork two_wedges(double wedge2_deg) {
    core::SurfaceNetwork s;
    const auto ray = [](double deg) {
        const double a = deg * std::numbers::pi / 180.0;
        return Eigen::Vector3d(std::cos(a), std::sin(a), 0.5);
    };
    const std::int32_t t = s.add_vertex({0.0, 0.0, 0.0}), u = s.add_vertex({0.0, 0.0, 1.0}),
                       p1 = s.add_vertex(ray(0.0)), p2 = s.add_vertex(ray(30.0)),
                       p3 = s.add_vertex(ray(30.0 + wedge2_deg));
    const auto add = [&s](std::int32_t a, std::int32_t b, std::int32_t c, core::Label in,
                          core::Label out, const Eigen::Vector3d& inside) {
        const Eigen::Vector3d n = (s.point(b) - s.point(a)).cross(s.point(c) - s.point(a));
        const Eigen::Vector3d m = (s.point(a) + s.point(b) + s.point(c)) / 3.0;
        if (n.dot(m - inside) >= 0.0)
            s.add_face(a, b, c, in, out);
        else
            s.add_face(a, c, b, in, out);
    };
    const Eigen::Vector3d in1 = (s.point(t) + s.point(u) + s.point(p1) + s.point(p2)) / 4.0;
    const Eigen::Vector3d in2 = (s.point(t) + s.point(u) + s.point(p2) + s.point(p3)) / 4.0;
    add(t, u, p1, 1, 0, in1);
    add(t, p1, p2, 1, 0, in1);
    add(u, p1, p2, 1, 0, in1);
    add(t, u, p2, 1, 2, in1);
    add(t, u, p3, 2, 0, in2);
    add(t, p2, p3, 2, 0, in2);
    add(u, p2, p3, 2, 0, in2);
    return s;
}

}  // namespace

TEST_CASE("a region wedge the mend of crossings closed is meshed again finer", "[remesh]") {
    // HarvardOxford-cort: the smoothing opened region 17's wedges, the mend of a crossing put
    // their vertices back where the front made them, at 1.55 degrees. A wedge under 12
    // degrees after the mend and not before it asks for another round; one the smoothing
    // left thin is not the mend's doing.
    using surface::remesh_detail::RetryPolicy;
    const core::SurfaceNetwork opened = two_wedges(30.0), closed = two_wedges(5.0);
    const surface::SizeField field(opened, std::vector<double>(opened.vertex_count(), 1.0));
    const std::vector<std::int32_t> face_patch(opened.face_count(), 0);
    {
        RetryPolicy retry(opened, field, 1);
        core::StageContext ctx;
        CHECK(surface::remesh_detail::mend_closed_wedges(opened.xyz, closed, face_patch, 0, retry,
                                                         ctx));
        CHECK(ctx.counters().at("remesh.wedges_closed_by_mend") == 1.0);
        REQUIRE(ctx.warnings().size() == 1);
        CHECK(ctx.warnings()[0].find("meshing again finer") != std::string::npos);
    }
    {
        RetryPolicy retry(opened, field, 1);
        core::StageContext ctx;
        CHECK_FALSE(surface::remesh_detail::mend_closed_wedges(closed.xyz, closed, face_patch, 0,
                                                               retry, ctx));
        CHECK_FALSE(surface::remesh_detail::mend_closed_wedges(opened.xyz, opened, face_patch, 0,
                                                               retry, ctx));
        // The last round keeps what it has.
        CHECK_FALSE(surface::remesh_detail::mend_closed_wedges(
            opened.xyz, closed, face_patch, RetryPolicy::kRounds - 1, retry, ctx));
    }
}
