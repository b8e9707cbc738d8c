#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <utility>
#include <vector>

#include <tbb/parallel_for.h>
#include <Eigen/Core>
#include <catch2/catch.hpp>

#include "pipeline/core/adt.h"
#include "pipeline/core/error.h"

using namespace frontmesh::core;
using Eigen::Vector3d;

namespace {

const double inf = std::numeric_limits<double>::infinity();

// Brute-force reference: every id's box and whether it is alive. Its geometry is written
// out here independently of adt.h.
struct Reference {
    std::vector<AdtBox> boxes;
    std::vector<char> alive;
    std::int32_t live = 0;

    void insert(std::int32_t id, const AdtBox& b) {
        if (static_cast<std::size_t>(id) >= boxes.size()) {
            boxes.resize(static_cast<std::size_t>(id) + 1);
            alive.resize(static_cast<std::size_t>(id) + 1, 0);
        }
        boxes[static_cast<std::size_t>(id)] = b;
        alive[static_cast<std::size_t>(id)] = 1;
        ++live;
    }
    void remove(std::int32_t id) {
        alive[static_cast<std::size_t>(id)] = 0;
        --live;
    }
    bool has(std::int32_t id) const {
        return static_cast<std::size_t>(id) < alive.size() && alive[static_cast<std::size_t>(id)];
    }
};

bool overlap(const AdtBox& a, const AdtBox& b) {
    for (int k = 0; k < 3; ++k)
        if (a.lo[k] > b.hi[k] || a.hi[k] < b.lo[k]) return false;
    return true;
}

double dist2(const AdtBox& b, const Vector3d& p) {
    double s = 0.0;
    for (int k = 0; k < 3; ++k) {
        const double d = std::max({b.lo[k] - p[k], p[k] - b.hi[k], 0.0});
        s += d * d;
    }
    return s;
}

std::vector<std::int32_t> brute_box(const Reference& ref, const AdtBox& q) {
    std::vector<std::int32_t> ids;
    for (std::size_t i = 0; i < ref.boxes.size(); ++i)
        if (ref.alive[i] && overlap(ref.boxes[i], q)) ids.push_back(static_cast<std::int32_t>(i));
    return ids;
}

std::vector<std::int32_t> brute_sphere(const Reference& ref, const Vector3d& c, double r) {
    std::vector<std::int32_t> ids;
    for (std::size_t i = 0; i < ref.boxes.size(); ++i)
        if (ref.alive[i] && dist2(ref.boxes[i], c) <= r * r)
            ids.push_back(static_cast<std::int32_t>(i));
    return ids;
}

// The first `count` live items ordered by (squared distance, id).
std::vector<AdtNeighbor> brute_order(const Reference& ref, const Vector3d& p,
                                     std::size_t count = 20) {
    std::vector<AdtNeighbor> all;
    for (std::size_t i = 0; i < ref.boxes.size(); ++i)
        if (ref.alive[i]) all.push_back({static_cast<std::int32_t>(i), dist2(ref.boxes[i], p)});
    count = std::min(count, all.size());
    std::partial_sort(all.begin(), all.begin() + static_cast<std::ptrdiff_t>(count), all.end(),
                      [](const AdtNeighbor& a, const AdtNeighbor& b) {
                          return a.distance2 < b.distance2 ||
                                 (a.distance2 == b.distance2 && a.id < b.id);
                      });
    all.resize(count);
    return all;
}

Vector3d random_point(std::mt19937_64& rng, double lo, double hi) {
    std::uniform_real_distribution<double> u(lo, hi);
    const double x = u(rng), y = u(rng), z = u(rng);
    return {x, y, z};
}

// Boxes of mixed shapes: mostly small, some large, some flat (a triangle in a coordinate
// plane), some segments and points.
AdtBox random_box(std::mt19937_64& rng, double lo, double hi) {
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const Vector3d c = random_point(rng, lo, hi);
    const double span = hi - lo;
    const double kind = u(rng);
    Vector3d half;
    for (int k = 0; k < 3; ++k) half[k] = span * (kind < 0.9 ? 0.01 : 0.25) * u(rng);
    if (u(rng) < 0.1) half[static_cast<int>(u(rng) * 3) % 3] = 0.0;  // flat
    if (u(rng) < 0.05) half[0] = half[1] = 0.0;                      // segment
    if (u(rng) < 0.02) half.setZero();                               // point
    return {c - half, c + half};
}

struct QueryCounts {
    std::size_t queries = 0;
    std::size_t hits = 0;
};

// Random box and sphere queries (some of zero size at item locations) against brute force.
QueryCounts check_queries(const Adt& adt, const Reference& ref, std::mt19937_64& rng, int count,
                          double lo, double hi, double max_size) {
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::vector<std::int32_t> got;
    QueryCounts counts;
    std::vector<std::int32_t> live_ids;
    for (std::size_t i = 0; i < ref.alive.size(); ++i)
        if (ref.alive[i]) live_ids.push_back(static_cast<std::int32_t>(i));
    for (int q = 0; q < count; ++q) {
        Vector3d c = random_point(rng, lo, hi);
        double size = max_size * u(rng);
        if (q % 10 == 0 && !live_ids.empty()) {  // exactly at an item's corner, zero size
            const auto id = live_ids[static_cast<std::size_t>(u(rng) * live_ids.size())];
            c = ref.boxes[static_cast<std::size_t>(id)].lo;
            size = 0.0;
        }
        const AdtBox qb{c - Vector3d(size, 0.5 * size, 2.0 * size),
                        c + Vector3d(size, 1.5 * size, 0.5 * size)};
        adt.query_box(qb, got);
        const auto want_box = brute_box(ref, qb);
        REQUIRE(got == want_box);
        adt.query_sphere(c, size, got);
        const auto want_sphere = brute_sphere(ref, c, size);
        REQUIRE(got == want_sphere);
        counts.queries += 2;
        counts.hits += want_box.size() + want_sphere.size();
    }
    return counts;
}

// Nearest and nearest_k against brute force: same ids and distances, ties by smaller id.
void check_nearest(const Adt& adt, const Reference& ref, const std::vector<Vector3d>& points) {
    std::vector<AdtNeighbor> got;
    for (const Vector3d& p : points) {
        const auto order = brute_order(ref, p);
        const AdtNeighbor n = adt.nearest(p);
        if (order.empty()) {
            REQUIRE(n.id == -1);
            continue;
        }
        REQUIRE(n.id == order.front().id);
        REQUIRE(n.distance2 == order.front().distance2);
        for (const std::int32_t k : {3, 17}) {
            adt.nearest_k(p, k, got);
            REQUIRE(got.size() == std::min<std::size_t>(static_cast<std::size_t>(k),
                                                        static_cast<std::size_t>(adt.size())));
            for (std::size_t i = 0; i < got.size(); ++i) {
                REQUIRE(got[i].id == order[i].id);
                REQUIRE(got[i].distance2 == order[i].distance2);
            }
        }
    }
}

const AdtBox unit_box{Vector3d::Zero(), Vector3d::Ones()};

}  // namespace

TEST_CASE("ADT box helpers", "[core]") {
    const AdtBox b{Vector3d(0, 0, 0), Vector3d(1, 2, 3)};
    CHECK(squared_distance(b, Vector3d(0.5, 1, 1)) == 0.0);
    CHECK(squared_distance(b, Vector3d(-1, 1, 1)) == 1.0);
    CHECK(squared_distance(b, Vector3d(2, 4, 5)) == 1.0 + 4.0 + 4.0);
    CHECK(boxes_intersect(b, AdtBox{Vector3d(1, 2, 3), Vector3d(5, 5, 5)}));  // touching corner
    CHECK_FALSE(boxes_intersect(b, AdtBox{Vector3d(1, 2, 3.5), Vector3d(5, 5, 5)}));
    AdtBox grown;
    CHECK_FALSE(grown.is_valid());
    grown.extend(Vector3d(1, -1, 0));
    grown.extend(Vector3d(-1, 1, 0));
    CHECK(grown.is_valid());
    CHECK(grown.lo == Vector3d(-1, -1, 0));
    CHECK(grown.enlarged(0.5).hi == Vector3d(1.5, 1.5, 0.5));
}

TEST_CASE("ADT queries on random points match brute force", "[core]") {
    for (const AdtItems kind : {AdtItems::points, AdtItems::boxes}) {
        std::mt19937_64 rng(20240611);
        const std::int32_t n = 50000;
        Adt adt(unit_box, kind);
        Reference ref;
        // Ids inserted in shuffled order.
        std::vector<std::int32_t> ids(n);
        for (std::int32_t i = 0; i < n; ++i) ids[static_cast<std::size_t>(i)] = i;
        std::shuffle(ids.begin(), ids.end(), rng);
        for (const std::int32_t id : ids) {
            const Vector3d p = random_point(rng, 0.0, 1.0);
            adt.insert(id, p);
            ref.insert(id, AdtBox::of_point(p));
        }
        REQUIRE(adt.size() == n);
        CHECK(adt.max_depth() < 200);  // log-depth for spread points: no chains
        const QueryCounts counts = check_queries(adt, ref, rng, 400, -0.05, 1.05, 0.06);
        CHECK(counts.hits > counts.queries);  // the queries are not vacuous

        std::vector<Vector3d> probes;
        for (int i = 0; i < 200; ++i) probes.push_back(random_point(rng, -0.2, 1.2));
        check_nearest(adt, ref, probes);
        // At an item: distance 0, that item.
        const AdtBox b3 = adt.box(ids[3]);
        const AdtNeighbor at = adt.nearest(b3.lo);
        CHECK(at.id == ids[3]);
        CHECK(at.distance2 == 0.0);
    }
}

TEST_CASE("ADT queries on random boxes match brute force", "[core]") {
    std::mt19937_64 rng(77);
    Adt adt(unit_box.enlarged(0.01), AdtItems::boxes);
    Reference ref;
    for (std::int32_t id = 0; id < 30000; ++id) {
        const AdtBox b = random_box(rng, 0.0, 1.0);
        adt.insert(id, b);
        ref.insert(id, b);
    }
    const QueryCounts counts = check_queries(adt, ref, rng, 300, -0.1, 1.1, 0.05);
    CHECK(counts.hits > counts.queries);
    std::vector<Vector3d> probes;
    for (int i = 0; i < 100; ++i) probes.push_back(random_point(rng, -0.3, 1.3));
    check_nearest(adt, ref, probes);
    // A point query inside a box finds it at distance zero.
    const AdtBox b = adt.box(123);
    std::vector<std::int32_t> got;
    adt.query_sphere(0.5 * (b.lo + b.hi), 0.0, got);
    CHECK(std::binary_search(got.begin(), got.end(), 123));
}

TEST_CASE("ADT nearest breaks exact ties by the smaller id", "[core]") {
    for (const AdtItems kind : {AdtItems::points, AdtItems::boxes}) {
        std::mt19937_64 rng(5);
        std::uniform_int_distribution<int> grid(0, 6);
        Adt adt(AdtBox{Vector3d::Zero(), Vector3d::Constant(6.0)}, kind);
        Reference ref;
        // Integer grid points with about 15 items on each: every query has many exact ties.
        for (std::int32_t id = 0; id < 5000; ++id) {
            const Vector3d p(grid(rng), grid(rng), grid(rng));
            adt.insert(id, p);
            ref.insert(id, AdtBox::of_point(p));
        }
        std::vector<Vector3d> probes;
        for (int i = 0; i < 150; ++i)
            probes.push_back(Vector3d(grid(rng), grid(rng), grid(rng)) * 0.5 +
                             Vector3d(i % 3 == 0 ? -1.0 : 0.5, 0.0, i % 5 == 0 ? 8.0 : 0.0));
        check_nearest(adt, ref, probes);

        // Removing the winner hands the answer to the next smaller id at the same distance.
        const Vector3d p = adt.box(0).lo;
        const auto order = brute_order(ref, p);
        REQUIRE(order.size() > 2);
        REQUIRE(order[1].distance2 == 0.0);
        CHECK(adt.nearest(p).id == order[0].id);
        REQUIRE(adt.remove(order[0].id));
        CHECK(adt.nearest(p).id == order[1].id);
    }
}

TEST_CASE("ADT stays exact and bounded under insert/remove churn", "[core]") {
    for (const AdtItems kind : {AdtItems::points, AdtItems::boxes}) {
        std::mt19937_64 rng(kind == AdtItems::points ? 11 : 12);
        std::uniform_real_distribution<double> u(0.0, 1.0);
        const std::int32_t id_range = 20000;
        std::uniform_int_distribution<std::int32_t> pick(0, id_range - 1);
        Adt adt(unit_box, kind);
        Reference ref;
        std::int32_t max_live = 0;
        const int operations = 200000;
        for (int op = 0; op < operations; ++op) {
            // Phases that grow and shrink the tree.
            const double insert_bias = (op / 25000) % 2 == 0 ? 0.75 : 0.25;
            const std::int32_t id = pick(rng);
            if (u(rng) < insert_bias) {
                if (adt.contains(id)) continue;
                const AdtBox b = kind == AdtItems::points
                                     ? AdtBox::of_point(random_point(rng, -0.1, 1.1))
                                     : random_box(rng, -0.1, 1.1);
                adt.insert(id, b);
                ref.insert(id, b);
            } else {
                const bool present = ref.has(id);
                REQUIRE(adt.remove(id) == present);
                if (present) ref.remove(id);
                REQUIRE_FALSE(adt.contains(id));
            }
            REQUIRE(adt.size() == ref.live);
            max_live = std::max(max_live, ref.live);
            if (op % 4000 == 0) {
                check_queries(adt, ref, rng, 10, -0.1, 1.1, 0.1);
                std::vector<Vector3d> probes;
                for (int i = 0; i < 5; ++i) probes.push_back(random_point(rng, -0.2, 1.2));
                check_nearest(adt, ref, probes);
            }
        }
        CHECK(max_live > id_range / 2);
        // Freed nodes are reused: the pool never outgrows the peak number of live items.
        CHECK(adt.pool_size() <= max_live);
        // Compaction merges sparse leaves and changes no result; churn goes on after it.
        adt.compact();
        INFO("nodes " << adt.pool_size() << ", buckets " << adt.bucket_count() << ", items "
                      << adt.size());
        CHECK(adt.pool_size() <= adt.size() / 4);
        CHECK(adt.bucket_count() <= adt.size() / 4);
        check_queries(adt, ref, rng, 50, -0.1, 1.1, 0.1);
        for (int op = 0; op < 20000; ++op) {
            const std::int32_t id = pick(rng);
            if (ref.has(id)) {
                REQUIRE(adt.remove(id));
                ref.remove(id);
            } else {
                const Vector3d p = random_point(rng, -0.1, 1.1);
                adt.insert(id, p);
                ref.insert(id, AdtBox::of_point(p));
            }
        }
        check_queries(adt, ref, rng, 50, -0.1, 1.1, 0.1);
        check_nearest(adt, ref, {Vector3d(0.5, 0.5, 0.5), Vector3d(-1, 2, 0.3)});
        // Removing everything leaves an empty, reusable tree.
        for (std::int32_t id = 0; id < id_range; ++id) REQUIRE(adt.remove(id) == ref.has(id));
        CHECK(adt.is_empty());
        CHECK(adt.nearest(Vector3d(0.5, 0.5, 0.5)).id == -1);
        adt.insert(7, Vector3d(0.3, 0.3, 0.3));
        CHECK(adt.nearest(Vector3d(0.5, 0.5, 0.5)).id == 7);
        CHECK(adt.pool_size() <= max_live);
    }
}

namespace {

// Box and sphere queries exactly on the boxes of `ids` (live or removed): zero-size boxes at
// their corners, the boxes themselves and spheres through them, against brute force. Queries
// that graze an item catch subtree bounds that are too tight by a rounding step.
void check_queries_at(const Adt& adt, const Reference& ref, const std::vector<std::int32_t>& ids) {
    std::vector<std::int32_t> got;
    for (const std::int32_t id : ids) {
        const AdtBox& b = ref.boxes[static_cast<std::size_t>(id)];
        for (const AdtBox& q : {AdtBox{b.lo, b.lo}, AdtBox{b.hi, b.hi}, b}) {
            adt.query_box(q, got);
            REQUIRE(got == brute_box(ref, q));
            // in walk order: the same ids, each once
            adt.query_box(q, got, AdtOrder::walk);
            std::sort(got.begin(), got.end());
            REQUIRE(got == brute_box(ref, q));
        }
        const double r = 0.5 * (b.hi - b.lo).norm();
        adt.query_sphere(b.hi, 0.0, got);
        REQUIRE(got == brute_sphere(ref, b.hi, 0.0));
        adt.query_sphere(0.5 * (b.lo + b.hi), r, got);
        REQUIRE(got == brute_sphere(ref, 0.5 * (b.lo + b.hi), r));
        adt.query_sphere(0.5 * (b.lo + b.hi), r, got, AdtOrder::walk);
        std::sort(got.begin(), got.end());
        REQUIRE(got == brute_sphere(ref, 0.5 * (b.lo + b.hi), r));
    }
}

}  // namespace

TEST_CASE("ADT queries stay exact under interleaved inserts and removals", "[core]") {
    for (const AdtItems kind : {AdtItems::points, AdtItems::boxes}) {
        std::mt19937_64 rng(kind == AdtItems::points ? 31 : 32);
        std::uniform_real_distribution<double> u(0.0, 1.0);
        Adt adt(unit_box, kind);
        Reference ref;
        std::vector<std::int32_t> live, removed;
        std::int32_t next_id = 0;
        auto make = [&](double lo, double hi) {
            return kind == AdtItems::points ? AdtBox::of_point(random_point(rng, lo, hi))
                                            : random_box(rng, lo, hi);
        };
        auto insert = [&](const AdtBox& b) {
            adt.insert(next_id, b);
            ref.insert(next_id, b);
            live.push_back(next_id++);
        };
        auto remove_random = [&] {
            const auto at = static_cast<std::size_t>(u(rng) * static_cast<double>(live.size()));
            const std::int32_t id = live[at];
            live[at] = live.back();
            live.pop_back();
            REQUIRE(adt.remove(id));
            ref.remove(id);
            removed.push_back(id);
        };
        auto check = [&](int queries) {
            REQUIRE(adt.size() == static_cast<std::int32_t>(live.size()));
            check_queries(adt, ref, rng, queries, -0.2, 1.2, 0.15);
            std::vector<std::int32_t> sample;
            for (int i = 0; i < 20 && !live.empty(); ++i)
                sample.push_back(live[static_cast<std::size_t>(u(rng) * live.size())]);
            for (int i = 0; i < 20 && !removed.empty(); ++i)
                sample.push_back(removed[static_cast<std::size_t>(u(rng) * removed.size())]);
            check_queries_at(adt, ref, sample);
            std::vector<Vector3d> probes;
            for (int i = 0; i < 5; ++i) probes.push_back(random_point(rng, -0.3, 1.3));
            check_nearest(adt, ref, probes);
        };

        // Items far outside the domain, beyond the float range included: their bounds round
        // outward to the largest float or to infinity.
        for (const double far : {1e300, -1e300, 3.5e38, -3.5e38, 1e-40}) {
            insert(AdtBox::of_point(Vector3d(far, 0.5, -far)));
            if (kind == AdtItems::boxes)
                insert(AdtBox{Vector3d(-std::abs(far), 0.1, 0.2),
                              Vector3d(0.3, std::max(std::abs(far), 1.0), 0.4)});
        }
        // Growth: 3 inserts for each removal.
        for (int op = 0; op < 8000; ++op) {
            if (u(rng) < 0.75 || live.empty())
                insert(make(-0.1, 1.1));
            else
                remove_random();
            if (op % 1000 == 999) check(10);
        }
        // Shrink to a few percent, a few inserts in between; a cluster is inserted and then
        // emptied again, leaving loose bounds behind.
        for (int i = 0; i < 300; ++i) insert(make(0.80, 0.85));
        for (int op = 0; live.size() > 150; ++op) {
            if (u(rng) < 0.1)
                insert(make(-0.1, 1.1));
            else
                remove_random();
            if (op % 1000 == 999) check(10);
        }
        check(100);
        // Down to a single item, then empty.
        while (live.size() > 1) remove_random();
        check(20);
        remove_random();
        check(5);
        CHECK(adt.is_empty());
        // Regrowth reuses the freed nodes, whose old bounds must not leak.
        for (int i = 0; i < 2000; ++i) insert(make(0.2, 0.4));
        check(50);
    }
}

TEST_CASE("ADT compact keeps every query result and exact bounds", "[core]") {
    for (const AdtItems kind : {AdtItems::points, AdtItems::boxes}) {
        std::mt19937_64 rng(kind == AdtItems::points ? 41 : 42);
        std::uniform_real_distribution<double> u(0.0, 1.0);
        Adt adt(unit_box, kind);
        Reference ref;
        const std::int32_t n = 20000;
        for (std::int32_t id = 0; id < n; ++id) {
            const AdtBox b = kind == AdtItems::points
                                 ? AdtBox::of_point(random_point(rng, -0.1, 1.1))
                                 : random_box(rng, -0.1, 1.1);
            adt.insert(id, b);
            ref.insert(id, b);
        }
        // Remove 90%, leaving loose bounds, then compare results before and after compact.
        for (std::int32_t id = 0; id < n; ++id)
            if (u(rng) < 0.9) {
                REQUIRE(adt.remove(id));
                ref.remove(id);
            }
        std::vector<AdtBox> boxes;
        std::vector<Vector3d> centres;
        std::vector<double> radii;
        for (int q = 0; q < 300; ++q) {
            const Vector3d c = random_point(rng, -0.2, 1.2);
            const double r = 0.1 * u(rng);
            boxes.push_back({c.array() - r, c.array() + 0.5 * r});
            centres.push_back(c);
            radii.push_back(r);
        }
        auto run = [&] {
            std::vector<std::vector<std::int32_t>> ids;
            std::vector<std::vector<AdtNeighbor>> near;
            std::vector<std::int32_t> got;
            std::vector<AdtNeighbor> got_k;
            for (std::size_t q = 0; q < boxes.size(); ++q) {
                adt.query_box(boxes[q], got);
                ids.push_back(got);
                adt.query_sphere(centres[q], radii[q], got);
                ids.push_back(got);
                adt.nearest_k(centres[q], 9, got_k);
                near.push_back(got_k);
            }
            return std::make_pair(ids, near);
        };
        const auto before = run();
        const std::int32_t depth = adt.max_depth();
        adt.compact();
        INFO("nodes " << adt.pool_size() << ", buckets " << adt.bucket_count() << ", items "
                      << adt.size());
        CHECK(adt.pool_size() <= adt.size() / 4);
        CHECK(adt.bucket_count() <= adt.size() / 4);
        CHECK(adt.max_depth() <= depth);  // sparse subtrees became leaves
        const auto after = run();
        REQUIRE(after.first == before.first);
        REQUIRE(after.second.size() == before.second.size());
        for (std::size_t q = 0; q < after.second.size(); ++q) {
            REQUIRE(after.second[q].size() == before.second[q].size());
            for (std::size_t i = 0; i < after.second[q].size(); ++i) {
                REQUIRE(after.second[q][i].id == before.second[q][i].id);
                REQUIRE(after.second[q][i].distance2 == before.second[q][i].distance2);
            }
        }
        for (std::size_t q = 0; q < boxes.size(); ++q) {
            REQUIRE(before.first[2 * q] == brute_box(ref, boxes[q]));
            REQUIRE(before.first[2 * q + 1] == brute_sphere(ref, centres[q], radii[q]));
        }
        std::vector<std::int32_t> sample;
        for (std::int32_t id = 0; id < n; id += 37) sample.push_back(id);  // live and removed
        check_queries_at(adt, ref, sample);
        check_nearest(adt, ref, centres);
        // Churn after compaction stays exact.
        for (int op = 0; op < 5000; ++op) {
            const auto id = static_cast<std::int32_t>(u(rng) * n);
            if (ref.has(id)) {
                REQUIRE(adt.remove(id));
                ref.remove(id);
            } else {
                const AdtBox b = kind == AdtItems::points
                                     ? AdtBox::of_point(random_point(rng, -0.1, 1.1))
                                     : random_box(rng, -0.1, 1.1);
                adt.insert(id, b);
                ref.insert(id, b);
            }
        }
        check_queries(adt, ref, rng, 100, -0.2, 1.2, 0.1);
        check_queries_at(adt, ref, sample);
        check_nearest(adt, ref, centres);
    }
}

TEST_CASE("ADT handles items outside the root domain", "[core]") {
    for (const AdtItems kind : {AdtItems::points, AdtItems::boxes}) {
        std::mt19937_64 rng(99);
        // Domain [0, 1]^3, items spread over [-3, 4]^3: most lie outside.
        Adt adt(unit_box, kind);
        Reference ref;
        for (std::int32_t id = 0; id < 15000; ++id) {
            const AdtBox b = kind == AdtItems::points
                                 ? AdtBox::of_point(random_point(rng, -3.0, 4.0))
                                 : random_box(rng, -3.0, 4.0);
            adt.insert(id, b);
            ref.insert(id, b);
        }
        // A box much larger than the domain.
        if (kind == AdtItems::boxes) {
            const AdtBox big{Vector3d::Constant(-10.0), Vector3d::Constant(10.0)};
            adt.insert(15000, big);
            ref.insert(15000, big);
        }
        const QueryCounts counts = check_queries(adt, ref, rng, 300, -4.0, 5.0, 0.4);
        CHECK(counts.hits > counts.queries);
        std::vector<Vector3d> probes;
        for (int i = 0; i < 100; ++i) probes.push_back(random_point(rng, -5.0, 6.0));
        check_nearest(adt, ref, probes);
        // Removing items outside the domain keeps the tree exact.
        for (std::int32_t id = 0; id < 15000; id += 3) {
            REQUIRE(adt.remove(id));
            ref.remove(id);
        }
        check_queries(adt, ref, rng, 100, -4.0, 5.0, 0.4);
    }
}

TEST_CASE("ADT handles many identical points", "[core]") {
    for (const AdtItems kind : {AdtItems::points, AdtItems::boxes}) {
        std::mt19937_64 rng(3);
        Adt adt(unit_box, kind);
        Reference ref;
        const Vector3d a(0.5, 0.5, 0.5), b(0.25, 0.75, 0.0);
        std::int32_t id = 0;
        // Interleave two clusters of duplicates with random points.
        for (int i = 0; i < 2000; ++i) {
            for (const Vector3d& p : {a, b, random_point(rng, 0.0, 1.0)}) {
                adt.insert(id, p);
                ref.insert(id, AdtBox::of_point(p));
                ++id;
            }
        }
        check_queries(adt, ref, rng, 100, 0.0, 1.0, 0.1);
        std::vector<std::int32_t> got;
        adt.query_sphere(a, 0.0, got);
        CHECK(got == brute_sphere(ref, a, 0.0));
        CHECK(got.size() >= 2000);
        check_nearest(adt, ref, {a, b, Vector3d(0.5, 0.5, 0.6), Vector3d(0.2, 0.8, -0.1)});
        CHECK(adt.nearest(a).id == 0);
        // Remove half of each cluster, smallest ids first.
        for (std::int32_t i = 0; i < 3000; i += 1) {
            REQUIRE(adt.remove(i));
            ref.remove(i);
        }
        CHECK(adt.nearest(a).id == 3000);
        check_queries(adt, ref, rng, 50, 0.0, 1.0, 0.1);
        check_nearest(adt, ref, {a, b});
    }
}

TEST_CASE("ADT handles flat boxes and a flat domain", "[core]") {
    std::mt19937_64 rng(8);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    // Triangles in the plane z = 0: the domain has zero extent in z.
    Adt flat(AdtBox{Vector3d(0, 0, 0), Vector3d(1, 1, 0)}, AdtItems::boxes);
    // Triangles in axis planes x = 0.5 and y = const inside a unit domain.
    Adt planes(unit_box, AdtItems::boxes);
    Reference flat_ref, planes_ref;
    std::vector<std::int32_t> got;
    for (std::int32_t id = 0; id < 20000; ++id) {
        const Vector3d p = random_point(rng, 0.0, 1.0);
        const Vector3d e1 = 0.02 * random_point(rng, -1.0, 1.0);
        const Vector3d e2 = 0.02 * random_point(rng, -1.0, 1.0);
        AdtBox t;
        t.extend(Vector3d(p.x(), p.y(), 0.0));
        t.extend(Vector3d(p.x() + e1.x(), p.y() + e1.y(), 0.0));
        t.extend(Vector3d(p.x() + e2.x(), p.y() + e2.y(), 0.0));
        if (id % 50 == 0) {  // a few off the plane, outside the flat domain
            t.lo.z() = -0.01 * u(rng);
            t.hi.z() = t.lo.z() + (id % 100 == 0 ? 0.0 : 0.005);
        }
        flat.insert(id, t);
        flat_ref.insert(id, t);
        AdtBox s;
        const double x = id % 2 == 0 ? 0.5 : p.x();
        const double y = id % 2 == 0 ? p.y() : std::floor(p.y() * 10.0) / 10.0;
        s.extend(Vector3d(x, y, p.z()));
        s.extend(Vector3d(x, y + (id % 2 == 0) * e1.y(), p.z() + e1.z()));
        s.extend(Vector3d(x + (id % 2) * e2.x(), y, p.z() + e2.z()));
        planes.insert(id, s);
        planes_ref.insert(id, s);
    }
    const QueryCounts c1 = check_queries(flat, flat_ref, rng, 200, -0.1, 1.1, 0.05);
    // Queries below the plane find exactly the off-plane items.
    for (int i = 0; i < 50; ++i) {
        const Vector3d c(u(rng), u(rng), -0.01 * u(rng));
        flat.query_sphere(c, 0.05, got);
        REQUIRE(got == brute_sphere(flat_ref, c, 0.05));
        const AdtBox q{c - Vector3d(0.05, 0.05, 0.0), c + Vector3d(0.05, 0.05, 0.0)};
        flat.query_box(q, got);
        REQUIRE(got == brute_box(flat_ref, q));
    }
    const QueryCounts c2 = check_queries(planes, planes_ref, rng, 200, -0.1, 1.1, 0.05);
    CHECK(c1.hits > c1.queries);
    CHECK(c2.hits > c2.queries);
    // Flat query boxes lying in the planes.
    for (int i = 0; i < 50; ++i) {
        const Vector3d c = random_point(rng, 0.0, 1.0);
        const AdtBox qz{Vector3d(c.x() - 0.05, c.y() - 0.05, 0.0),
                        Vector3d(c.x() + 0.05, c.y() + 0.05, 0.0)};
        flat.query_box(qz, got);
        REQUIRE(got == brute_box(flat_ref, qz));
        const AdtBox qx{Vector3d(0.5, c.y() - 0.05, c.z() - 0.05),
                        Vector3d(0.5, c.y() + 0.05, c.z() + 0.05)};
        planes.query_box(qx, got);
        REQUIRE(got == brute_box(planes_ref, qx));
    }
    std::vector<Vector3d> probes;
    for (int i = 0; i < 60; ++i) probes.push_back(random_point(rng, -0.2, 1.2));
    check_nearest(flat, flat_ref, probes);
    check_nearest(planes, planes_ref, probes);
}

TEST_CASE("ADT edge cases and precondition errors", "[core]") {
    CHECK_THROWS_AS(Adt(AdtBox{Vector3d(0, 0, 0), Vector3d(1, -1, 1)}, AdtItems::boxes),
                    InternalError);
    CHECK_THROWS_AS(Adt(AdtBox{}, AdtItems::points), InternalError);

    Adt adt(unit_box, AdtItems::points);
    std::vector<std::int32_t> got{42};
    adt.query_box(unit_box, got);
    CHECK(got.empty());
    CHECK(adt.nearest(Vector3d(0, 0, 0)).id == -1);
    CHECK(adt.max_depth() == 0);
    CHECK_FALSE(adt.remove(0));

    adt.insert(4, Vector3d(0.1, 0.2, 0.3));
    adt.insert(9, Vector3d(0.9, 0.2, 0.3));
    CHECK_THROWS_AS(adt.insert(4, Vector3d(0.5, 0.5, 0.5)), InternalError);
    CHECK_THROWS_AS(adt.insert(-1, Vector3d(0.5, 0.5, 0.5)), InternalError);
    CHECK_THROWS_AS(adt.insert(5, Vector3d(std::nan(""), 0.5, 0.5)), InternalError);
    CHECK_THROWS_AS(adt.insert(5, Vector3d(inf, 0.5, 0.5)), InternalError);
    CHECK_THROWS_AS(adt.insert(5, AdtBox{Vector3d::Zero(), Vector3d::Ones()}), InternalError);
    CHECK_THROWS_AS(adt.box(5), InternalError);
    CHECK(adt.size() == 2);
    CHECK_FALSE(adt.contains(5));
    CHECK(adt.box(9).lo == Vector3d(0.9, 0.2, 0.3));

    // Empty query box, negative and infinite radius, NaN input.
    adt.query_box(AdtBox{Vector3d(0.5, 0, 0), Vector3d(0.4, 1, 1)}, got);
    CHECK(got.empty());
    adt.query_sphere(Vector3d(0.1, 0.2, 0.3), -1.0, got);
    CHECK(got.empty());
    adt.query_sphere(Vector3d(0.1, 0.2, 0.3), inf, got);
    CHECK(got == std::vector<std::int32_t>{4, 9});
    adt.query_box(AdtBox{Vector3d::Constant(-inf), Vector3d::Constant(inf)}, got);
    CHECK(got == std::vector<std::int32_t>{4, 9});
    CHECK_THROWS_AS(adt.query_sphere(Vector3d(0, 0, 0), std::nan(""), got), InternalError);
    CHECK_THROWS_AS(adt.nearest(Vector3d(inf, 0, 0)), InternalError);

    std::vector<AdtNeighbor> near;
    adt.nearest_k(Vector3d(0.8, 0.2, 0.3), 10, near);
    REQUIRE(near.size() == 2);
    CHECK(near[0].id == 9);
    CHECK(near[1].id == 4);
    adt.nearest_k(Vector3d(0.8, 0.2, 0.3), 0, near);
    CHECK(near.empty());

    // A box tree accepts points; a large id grows the id table.
    Adt boxes(unit_box, AdtItems::boxes);
    boxes.insert(1000000, Vector3d(0.5, 0.5, 0.5));
    CHECK(boxes.contains(1000000));
    CHECK(boxes.nearest(Vector3d(0, 0, 0)).id == 1000000);
    boxes.clear();
    CHECK(boxes.is_empty());
    CHECK_FALSE(boxes.contains(1000000));
    CHECK(boxes.pool_size() == 0);
}

TEST_CASE("ADT const queries are safe to run concurrently", "[core]") {
    std::mt19937_64 rng(21);
    Adt adt(unit_box, AdtItems::boxes);
    for (std::int32_t id = 0; id < 20000; ++id) adt.insert(id, random_box(rng, 0.0, 1.0));
    const int count = 4000;
    std::vector<Vector3d> centers;
    for (int i = 0; i < count; ++i) centers.push_back(random_point(rng, 0.0, 1.0));

    auto run = [&](int i, std::vector<std::int32_t>& ids) {
        std::vector<std::int32_t> scratch;
        adt.query_sphere(centers[static_cast<std::size_t>(i)], 0.03, ids);
        adt.query_box(AdtBox::of_point(centers[static_cast<std::size_t>(i)]).enlarged(0.02),
                      scratch);
        ids.insert(ids.end(), scratch.begin(), scratch.end());
        ids.push_back(adt.nearest(centers[static_cast<std::size_t>(i)]).id);
    };
    std::vector<std::vector<std::int32_t>> serial(count), parallel(count);
    for (int i = 0; i < count; ++i) run(i, serial[static_cast<std::size_t>(i)]);
    tbb::parallel_for(0, count, [&](int i) { run(i, parallel[static_cast<std::size_t>(i)]); });
    CHECK(serial == parallel);
}
