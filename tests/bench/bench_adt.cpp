// Microbenchmark of the ADT (pipeline/core/adt.h) against brute force and a static k-d tree.
//   cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DFRONTMESH_BUILD_BENCHMARKS=ON
//   cmake --build build --target bench_adt && build/tests/bench/bench_adt
// Query benchmarks run a batch of 100k queries per iteration; the ns_per_query counter is the
// time per query (shown in seconds with an SI prefix) and hits_per_query the mean result size.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

#include <benchmark/benchmark.h>
#include <Eigen/Core>

#include "pipeline/core/adt.h"

using Eigen::Vector3d;
using frontmesh::core::Adt;
using frontmesh::core::AdtBox;
using frontmesh::core::AdtItems;
using frontmesh::core::squared_distance;

namespace {

constexpr std::int32_t point_count = 1000000;
constexpr std::int32_t triangle_count = 200000;
constexpr std::int32_t brute_count = 20000;  // brute force costs O(n) per query
constexpr std::int32_t query_count = 100000;
// About 10 of 1M uniform points in the unit cube lie in a ball of this radius.
const double point_radius = std::cbrt(10.0 / (4.0 / 3.0 * std::numbers::pi * point_count));
// Triangles: vertices within 0.02 of a centre; spheres of about three times their size.
constexpr double triangle_size = 0.02;
constexpr double triangle_radius = 0.03;

const AdtBox unit_box{Vector3d::Zero(), Vector3d::Ones()};

std::vector<Vector3d> random_points(std::int32_t n, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::vector<Vector3d> points(static_cast<std::size_t>(n));
    for (auto& p : points) {
        const double x = u(rng), y = u(rng), z = u(rng);
        p = Vector3d(x, y, z);
    }
    return points;
}

std::vector<AdtBox> random_triangle_boxes(std::int32_t n, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0), e(-triangle_size, triangle_size);
    std::vector<AdtBox> boxes(static_cast<std::size_t>(n));
    for (auto& b : boxes) {
        const double x = u(rng), y = u(rng), z = u(rng);
        b = AdtBox::of_point(Vector3d(x, y, z));
        for (int v = 0; v < 2; ++v) {
            const double dx = e(rng), dy = e(rng), dz = e(rng);
            b.extend(Vector3d(x + dx, y + dy, z + dz));
        }
    }
    return boxes;
}

const std::vector<Vector3d>& points() {
    static const std::vector<Vector3d> data = random_points(point_count, 1);
    return data;
}
const std::vector<AdtBox>& triangles() {
    static const std::vector<AdtBox> data = random_triangle_boxes(triangle_count, 2);
    return data;
}
const std::vector<Vector3d>& query_centers() {
    static const std::vector<Vector3d> data = random_points(query_count, 3);
    return data;
}

Adt build_point_adt(AdtItems kind, std::int32_t n, bool compact) {
    Adt adt(unit_box, kind);
    adt.reserve(n);
    for (std::int32_t i = 0; i < n; ++i) adt.insert(i, points()[static_cast<std::size_t>(i)]);
    if (compact) adt.compact();
    return adt;
}

Adt build_triangle_adt(std::int32_t n, bool compact) {
    Adt adt(unit_box.enlarged(triangle_size), AdtItems::boxes);
    adt.reserve(n);
    for (std::int32_t i = 0; i < n; ++i) adt.insert(i, triangles()[static_cast<std::size_t>(i)]);
    if (compact) adt.compact();
    return adt;
}

// One tree per (kind, compact) built on first use and kept for the query benchmarks.
const Adt& point_adt(AdtItems kind, bool compact) {
    static const Adt trees[2][2] = {{build_point_adt(AdtItems::points, point_count, false),
                                     build_point_adt(AdtItems::points, point_count, true)},
                                    {build_point_adt(AdtItems::boxes, point_count, false),
                                     build_point_adt(AdtItems::boxes, point_count, true)}};
    return trees[kind == AdtItems::points ? 0 : 1][compact ? 1 : 0];
}
const Adt& triangle_adt(bool compact) {
    static const Adt trees[2] = {build_triangle_adt(triangle_count, false),
                                 build_triangle_adt(triangle_count, true)};
    return trees[compact ? 1 : 0];
}

// Static k-d tree over points: median split on the widest axis, buckets of up to 8 points
// at the leaves, the tree implicit in a permutation of the points (node = index range).
class KdTree {
public:
    explicit KdTree(const std::vector<Vector3d>& pts)
        : points_(pts.size()), ids_(pts.size()), axis_(pts.size(), 0) {
        std::vector<std::int32_t> order(pts.size());
        for (std::size_t i = 0; i < pts.size(); ++i) order[i] = static_cast<std::int32_t>(i);
        build(pts, order, 0, static_cast<std::int32_t>(pts.size()));
        for (std::size_t i = 0; i < pts.size(); ++i) {
            ids_[i] = order[i];
            points_[i] = pts[static_cast<std::size_t>(order[i])];
        }
    }

    void query_sphere(const Vector3d& c, double r, std::vector<std::int32_t>& out) const {
        out.clear();
        const double r2 = r * r;
        struct Range {
            std::int32_t begin, end;
        };
        Range stack[64];
        int top = 0;
        stack[top++] = {0, static_cast<std::int32_t>(points_.size())};
        while (top > 0) {
            const Range range = stack[--top];
            if (range.end - range.begin <= leaf_size) {
                for (std::int32_t i = range.begin; i < range.end; ++i)
                    if ((points_[static_cast<std::size_t>(i)] - c).squaredNorm() <= r2)
                        out.push_back(ids_[static_cast<std::size_t>(i)]);
                continue;
            }
            const std::int32_t mid = range.begin + (range.end - range.begin) / 2;
            const Vector3d& p = points_[static_cast<std::size_t>(mid)];
            if ((p - c).squaredNorm() <= r2) out.push_back(ids_[static_cast<std::size_t>(mid)]);
            const int a = axis_[static_cast<std::size_t>(mid)];
            if (c[a] - r <= p[a]) stack[top++] = {range.begin, mid};
            if (c[a] + r >= p[a]) stack[top++] = {mid + 1, range.end};
        }
        std::sort(out.begin(), out.end());
    }

    std::int32_t nearest(const Vector3d& c) const {
        std::int32_t best = -1;
        double best2 = std::numeric_limits<double>::infinity();
        auto consider = [&](std::int32_t i) {
            const double d2 = (points_[static_cast<std::size_t>(i)] - c).squaredNorm();
            const std::int32_t id = ids_[static_cast<std::size_t>(i)];
            if (d2 < best2 || (d2 == best2 && id < best)) {
                best2 = d2;
                best = id;
            }
        };
        struct Range {
            std::int32_t begin, end;
            double gap2;
        };
        Range stack[64];
        int top = 0;
        stack[top++] = {0, static_cast<std::int32_t>(points_.size()), 0.0};
        while (top > 0) {
            const Range range = stack[--top];
            if (range.gap2 > best2) continue;
            if (range.end - range.begin <= leaf_size) {
                for (std::int32_t i = range.begin; i < range.end; ++i) consider(i);
                continue;
            }
            const std::int32_t mid = range.begin + (range.end - range.begin) / 2;
            consider(mid);
            const int a = axis_[static_cast<std::size_t>(mid)];
            const double diff = c[a] - points_[static_cast<std::size_t>(mid)][a];
            const Range low{range.begin, mid,
                            diff > 0 ? std::max(range.gap2, diff * diff) : range.gap2};
            const Range high{mid + 1, range.end,
                             diff < 0 ? std::max(range.gap2, diff * diff) : range.gap2};
            if (diff < 0) {
                stack[top++] = high;
                stack[top++] = low;
            } else {
                stack[top++] = low;
                stack[top++] = high;
            }
        }
        return best;
    }

private:
    static constexpr std::int32_t leaf_size = 8;

    void build(const std::vector<Vector3d>& pts, std::vector<std::int32_t>& order,
               std::int32_t begin, std::int32_t end) {
        if (end - begin <= leaf_size) return;
        Vector3d lo = Vector3d::Constant(std::numeric_limits<double>::infinity());
        Vector3d hi = -lo;
        for (std::int32_t i = begin; i < end; ++i) {
            lo = lo.cwiseMin(pts[static_cast<std::size_t>(order[static_cast<std::size_t>(i)])]);
            hi = hi.cwiseMax(pts[static_cast<std::size_t>(order[static_cast<std::size_t>(i)])]);
        }
        int a = 0;
        (hi - lo).maxCoeff(&a);
        const std::int32_t mid = begin + (end - begin) / 2;
        std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end,
                         [&](std::int32_t i, std::int32_t j) {
                             return pts[static_cast<std::size_t>(i)][a] <
                                    pts[static_cast<std::size_t>(j)][a];
                         });
        axis_[static_cast<std::size_t>(mid)] = static_cast<std::int8_t>(a);
        build(pts, order, begin, mid);
        build(pts, order, mid + 1, end);
    }

    std::vector<Vector3d> points_;
    std::vector<std::int32_t> ids_;
    std::vector<std::int8_t> axis_;
};

void set_query_counters(benchmark::State& state, std::int64_t queries, std::int64_t hits) {
    state.counters["ns_per_query"] = benchmark::Counter(
        static_cast<double>(queries),
        benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
    state.counters["hits_per_query"] =
        static_cast<double>(hits) / static_cast<double>(queries * state.iterations());
}

// ---- builds -------------------------------------------------------------------------------

// Argument: 1 = compact() after the insertions (included in the time).
void BM_AdtBuildPoints3D(benchmark::State& state) {
    points();
    for (auto _ : state)
        benchmark::DoNotOptimize(build_point_adt(AdtItems::points, point_count, state.range(0)));
}
BENCHMARK(BM_AdtBuildPoints3D)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

void BM_AdtBuildPoints6D(benchmark::State& state) {
    points();
    for (auto _ : state)
        benchmark::DoNotOptimize(build_point_adt(AdtItems::boxes, point_count, state.range(0)));
}
BENCHMARK(BM_AdtBuildPoints6D)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

void BM_KdBuildPoints(benchmark::State& state) {
    points();
    for (auto _ : state) benchmark::DoNotOptimize(KdTree(points()));
}
BENCHMARK(BM_KdBuildPoints)->Unit(benchmark::kMillisecond);

void BM_AdtBuildTriangles(benchmark::State& state) {
    triangles();
    for (auto _ : state)
        benchmark::DoNotOptimize(build_triangle_adt(triangle_count, state.range(0)));
}
BENCHMARK(BM_AdtBuildTriangles)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// ---- sphere queries on 1M points ----------------------------------------------------------

// Argument: 1 = queries on the compacted tree.
template <AdtItems kind>
void BM_AdtSpherePoints(benchmark::State& state) {
    const Adt& adt = point_adt(kind, state.range(0));
    std::vector<std::int32_t> out;
    std::int64_t hits = 0;
    for (auto _ : state)
        for (const Vector3d& c : query_centers()) {
            adt.query_sphere(c, point_radius, out);
            hits += static_cast<std::int64_t>(out.size());
        }
    state.counters["max_depth"] = adt.max_depth();
    set_query_counters(state, query_count, hits);
}
BENCHMARK_TEMPLATE(BM_AdtSpherePoints, AdtItems::points)
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_TEMPLATE(BM_AdtSpherePoints, AdtItems::boxes)
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond);

void BM_KdSpherePoints(benchmark::State& state) {
    static const KdTree tree(points());
    std::vector<std::int32_t> out;
    std::int64_t hits = 0;
    for (auto _ : state)
        for (const Vector3d& c : query_centers()) {
            tree.query_sphere(c, point_radius, out);
            hits += static_cast<std::int64_t>(out.size());
        }
    set_query_counters(state, query_count, hits);
}
BENCHMARK(BM_KdSpherePoints)->Unit(benchmark::kMillisecond);

// Brute force over the first 20k points with the same radius scaled to keep ~10 hits.
void BM_BruteSpherePoints20k(benchmark::State& state) {
    const double r = point_radius * std::cbrt(static_cast<double>(point_count) / brute_count);
    const std::int64_t queries = 2000;
    std::vector<std::int32_t> out;
    std::int64_t hits = 0;
    for (auto _ : state)
        for (std::int64_t q = 0; q < queries; ++q) {
            const Vector3d& c = query_centers()[static_cast<std::size_t>(q)];
            out.clear();
            for (std::int32_t i = 0; i < brute_count; ++i)
                if ((points()[static_cast<std::size_t>(i)] - c).squaredNorm() <= r * r)
                    out.push_back(i);
            hits += static_cast<std::int64_t>(out.size());
        }
    set_query_counters(state, queries, hits);
}
BENCHMARK(BM_BruteSpherePoints20k)->Unit(benchmark::kMillisecond);

// ---- nearest on 1M points -----------------------------------------------------------------

void BM_AdtNearestPoints(benchmark::State& state) {
    const Adt& adt = point_adt(AdtItems::points, state.range(0));
    std::int64_t sum = 0;
    for (auto _ : state)
        for (const Vector3d& c : query_centers()) sum += adt.nearest(c).id;
    benchmark::DoNotOptimize(sum);
    set_query_counters(state, query_count, query_count * state.iterations());
}
BENCHMARK(BM_AdtNearestPoints)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

void BM_KdNearestPoints(benchmark::State& state) {
    static const KdTree tree(points());
    std::int64_t sum = 0;
    for (auto _ : state)
        for (const Vector3d& c : query_centers()) sum += tree.nearest(c);
    benchmark::DoNotOptimize(sum);
    set_query_counters(state, query_count, query_count * state.iterations());
}
BENCHMARK(BM_KdNearestPoints)->Unit(benchmark::kMillisecond);

// ---- 200k triangle boxes ------------------------------------------------------------------

void BM_AdtSphereTriangles(benchmark::State& state) {
    const Adt& adt = triangle_adt(state.range(0));
    std::vector<std::int32_t> out;
    std::int64_t hits = 0;
    for (auto _ : state)
        for (const Vector3d& c : query_centers()) {
            adt.query_sphere(c, triangle_radius, out);
            hits += static_cast<std::int64_t>(out.size());
        }
    state.counters["max_depth"] = adt.max_depth();
    set_query_counters(state, query_count, hits);
}
BENCHMARK(BM_AdtSphereTriangles)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// Each triangle's own box as the query: the candidate search of a self-intersection check.
void BM_AdtBoxTriangles(benchmark::State& state) {
    const Adt& adt = triangle_adt(state.range(0));
    std::vector<std::int32_t> out;
    std::int64_t hits = 0;
    for (auto _ : state)
        for (std::int32_t q = 0; q < query_count; ++q) {
            adt.query_box(triangles()[static_cast<std::size_t>(q)], out);
            hits += static_cast<std::int64_t>(out.size());
        }
    set_query_counters(state, query_count, hits);
}
BENCHMARK(BM_AdtBoxTriangles)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// Brute force over the first 20k triangles; radius scaled to keep the hit count comparable.
void BM_BruteSphereTriangles20k(benchmark::State& state) {
    const double r = triangle_radius * std::cbrt(static_cast<double>(triangle_count) / brute_count);
    const std::int64_t queries = 2000;
    std::vector<std::int32_t> out;
    std::int64_t hits = 0;
    for (auto _ : state)
        for (std::int64_t q = 0; q < queries; ++q) {
            const Vector3d& c = query_centers()[static_cast<std::size_t>(q)];
            out.clear();
            for (std::int32_t i = 0; i < brute_count; ++i)
                if (squared_distance(triangles()[static_cast<std::size_t>(i)], c) <= r * r)
                    out.push_back(i);
            hits += static_cast<std::int64_t>(out.size());
        }
    set_query_counters(state, queries, hits);
}
BENCHMARK(BM_BruteSphereTriangles20k)->Unit(benchmark::kMillisecond);

// ---- churn: remove one point and insert it elsewhere, on a 1M-point tree ------------------

void BM_AdtChurnPoints(benchmark::State& state) {
    static Adt adt = build_point_adt(AdtItems::points, point_count, true);
    std::mt19937_64 rng(4);
    std::uniform_int_distribution<std::int32_t> pick(0, point_count - 1);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (auto _ : state) {
        const std::int32_t id = pick(rng);
        adt.remove(id);
        const double x = u(rng), y = u(rng), z = u(rng);
        adt.insert(id, Vector3d(x, y, z));
    }
    state.counters["pool_size"] = adt.pool_size();
}
BENCHMARK(BM_AdtChurnPoints)->Unit(benchmark::kNanosecond);

}  // namespace

BENCHMARK_MAIN();
