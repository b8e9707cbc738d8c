// The exact validity test of tetra's candidate tets (volume/tet_validity.h): the fast test
// (filters in SSE2 where available) and its portable filters against the plain reference, on
// hand-made cases with known answers, seeded random scenes and degenerate ones (points on the
// tet's planes, edges and nodes, shared vertices, nearly flat tets, huge and tiny coordinates).

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "pipeline/core/predicates.h"
#include "volume/tet_validity.h"

using namespace frontmesh;
using V3 = Eigen::Vector3d;

namespace {

/// Nodes and front faces for one or more validity tests; every face is "near".
struct Scene {
    std::vector<double> xyz;
    std::vector<volume::FrontFace> faces;

    std::int32_t add_point(const V3& p) {
        xyz.insert(xyz.end(), {p.x(), p.y(), p.z()});
        return static_cast<std::int32_t>(xyz.size() / 3 - 1);
    }
    std::int32_t add_face(std::int32_t a, std::int32_t b, std::int32_t c) {
        volume::FrontFace f{};
        f.v = {a, b, c};
        faces.push_back(f);
        return static_cast<std::int32_t>(faces.size() - 1);
    }
    V3 x(std::int32_t v) const { return V3(xyz[3 * v], xyz[3 * v + 1], xyz[3 * v + 2]); }
    std::vector<std::int32_t> all_faces() const {
        std::vector<std::int32_t> ids(faces.size());
        for (std::size_t i = 0; i < ids.size(); ++i) ids[i] = static_cast<std::int32_t>(i);
        return ids;
    }
    /// The view with a bound on the face edges as tetra keeps it (a little above the longest).
    volume::FrontView view() const {
        double longest = 0.0;
        for (const auto& f : faces)
            for (int k = 0; k < 3; ++k)
                longest = std::max(longest, (x(f.v[k]) - x(f.v[(k + 1) % 3])).norm());
        return {xyz.data(), faces.data(), longest * 1.0001};
    }
};

/// A tet (a, b, c, q) of scene nodes with all faces and edges new and no own faces.
volume::CandidateTet candidate(std::int32_t a, std::int32_t b, std::int32_t c, std::int32_t q) {
    return {{a, b, c, q}, {true, true, true}, {true, true, true}, {-1, -1, -1, -1}};
}

/// Swaps b and c when (a, b, c, q) is not VTK-positive, so most tets get past the first check.
void orient(const Scene& s, volume::CandidateTet& t) {
    const double* p = s.xyz.data();
    if (core::orient3d(p + 3 * t.v[0], p + 3 * t.v[1], p + 3 * t.v[2], p + 3 * t.v[3]) == 1)
        std::swap(t.v[1], t.v[2]);
}

/// The reference's answer; the fast and portable tests must agree with it.
struct Outcome {
    bool reference, fast, portable;
};
/// With `validity` kept across scenes, its per-node stamps must not carry over.
Outcome evaluate(const Scene& s, const volume::CandidateTet& tet, volume::TetValidity& validity) {
    const auto near = s.all_faces();
    const auto view = s.view();
    validity.resize(s.xyz.size() / 3);
    return {volume::is_valid_tet_reference(tet, view, near), validity.is_valid(tet, view, near),
            validity.is_valid_portable(tet, view, near)};
}
Outcome evaluate(const Scene& s, const volume::CandidateTet& tet) {
    volume::TetValidity validity;
    return evaluate(s, tet, validity);
}

/// Tallies of a batch of comparisons.
struct Tally {
    int valid = 0, invalid = 0, mismatches = 0;
    std::string first_mismatch;
    void add(const Outcome& o, const std::string& what) {
        (o.reference ? valid : invalid) += 1;
        if (o.fast != o.reference || o.portable != o.reference) {
            if (mismatches++ == 0) first_mismatch = what;
        }
    }
};

/// A random scene around the tet with nodes `tv`: `n_faces` front faces whose nodes are drawn
/// from the tet's nodes and `extra` points from `point`; some faces are the tet's own (the base,
/// faces it closes), and the flags say which of its faces and edges the front already has.
template <class PointGen>
volume::CandidateTet random_scene(Scene& s, std::mt19937_64& rng, PointGen point, int extra,
                                  int n_faces) {
    std::array<std::int32_t, 4> tv;
    for (auto& v : tv) v = s.add_point(point());
    volume::CandidateTet tet = candidate(tv[0], tv[1], tv[2], tv[3]);
    orient(s, tet);
    std::vector<std::int32_t> nodes(tv.begin(), tv.end());
    for (int i = 0; i < extra; ++i) nodes.push_back(s.add_point(point()));
    std::uniform_int_distribution<std::size_t> pick(0, nodes.size() - 1);
    std::bernoulli_distribution coin(0.5), often_tet_node(0.3);
    const auto& v = tet.v;
    tet.own[0] = s.add_face(v[0], v[1], v[2]);  // the base
    for (int i = 0; i < 3; ++i) {
        if (coin(rng)) {  // the front has the face (v_i, v_i+1, q), facing the tet
            tet.own[1 + i] = s.add_face(v[i], v[3], v[(i + 1) % 3]);
            tet.face_new[i] = false;
        }
    }
    for (int i = 0; i < 3; ++i) tet.edge_new[i] = tet.face_new[i] && tet.face_new[(i + 2) % 3];
    for (int i = 0; i < 3; ++i)
        if (tet.edge_new[i] && coin(rng)) {  // a front face on the edge (v_i, q)
            const std::int32_t w = nodes[pick(rng)];
            if (w == v[i] || w == v[3]) continue;
            s.add_face(v[i], v[3], w);
            tet.edge_new[i] = false;
        }
    for (int k = 0; k < n_faces; ++k) {
        std::int32_t f[3];
        for (auto& w : f) w = often_tet_node(rng) ? v[pick(rng) % 4] : nodes[pick(rng)];
        if (f[0] == f[1] || f[1] == f[2] || f[0] == f[2]) continue;
        s.add_face(f[0], f[1], f[2]);
    }
    return tet;
}

std::string describe(const Scene& s, const volume::CandidateTet& tet) {
    std::ostringstream o;
    o.precision(17);
    o << "tet";
    for (const auto v : tet.v) o << " (" << s.x(v).transpose() << ")";
    o << ", " << s.faces.size() << " faces";
    return o.str();
}

}  // namespace

TEST_CASE("Validity reference: hand-made cases", "[volume]") {
    Scene s;
    const auto a = s.add_point({0, 0, 0}), b = s.add_point({0, 1, 0}), c = s.add_point({1, 0, 0}),
               q = s.add_point({0, 0, 1});
    volume::CandidateTet tet = candidate(a, b, c, q);
    orient(s, tet);
    REQUIRE(core::orient3d(s.xyz.data() + 3 * tet.v[0], s.xyz.data() + 3 * tet.v[1],
                           s.xyz.data() + 3 * tet.v[2], s.xyz.data() + 3 * tet.v[3]) == -1);

    SECTION("an empty front: valid; the reversed tet: invalid") {
        CHECK(evaluate(s, tet).reference);
        volume::CandidateTet flipped = tet;
        std::swap(flipped.v[1], flipped.v[2]);
        const Outcome o = evaluate(s, flipped);
        CHECK_FALSE(o.reference);
        CHECK_FALSE(o.fast);
        CHECK_FALSE(o.portable);
    }
    SECTION("a front node inside the tet, on an edge, on a face: invalid") {
        for (const V3& p : {V3(0.1, 0.1, 0.1), V3(0.5, 0.0, 0.0), V3(0.2, 0.2, 0.0)}) {
            Scene t = s;
            const auto w = t.add_point(p), u = t.add_point({-1, -1, -1}),
                       z = t.add_point({-1, -2, -1});
            t.add_face(w, u, z);
            const Outcome o = evaluate(t, tet);
            CHECK_FALSE(o.reference);
            CHECK_FALSE(o.fast);
            CHECK_FALSE(o.portable);
        }
    }
    SECTION("a front triangle through a new face: invalid") {
        Scene t = s;
        // pierces the face (a, b, q) (the plane x = 0) near (0, 0.2, 0.2), nodes outside
        const auto u = t.add_point({-1, 0.2, 0.2}), w = t.add_point({0.05, 0.2, 0.25}),
                   z = t.add_point({0.05, 0.25, 0.15});
        t.add_face(u, w, z);
        CHECK_FALSE(evaluate(t, tet).reference);
    }
    SECTION("a new edge through a front triangle: invalid") {
        Scene t = s;
        // a big triangle in the plane z = 0.5 minus a corner far away: the edges a-q, b-q
        // and c-q all cross it
        const auto u = t.add_point({-5, -5, 0.5}), w = t.add_point({5, -5, 0.5}),
                   z = t.add_point({-5, 5, 0.5});
        t.add_face(u, w, z);
        CHECK_FALSE(evaluate(t, tet).reference);
    }
    SECTION("front triangles sharing the base's nodes, outside the tet: valid") {
        Scene t = s;
        const auto u = t.add_point({0.5, 0.5, -1}), w = t.add_point({-1, -1, 0.5});
        t.add_face(a, c, u);
        t.add_face(b, a, w);
        t.add_face(a, w, u);
        const Outcome o = evaluate(t, tet);
        CHECK(o.reference);
        CHECK(o.fast);
        CHECK(o.portable);
    }
}

TEST_CASE("Validity: fast and portable equal the reference on random scenes", "[volume]") {
    Tally tally;
    volume::TetValidity validity;
    for (std::uint64_t seed = 1; seed <= 4000; ++seed) {
        std::mt19937_64 rng(seed);
        std::uniform_real_distribution<double> u(-1.0, 1.0);
        Scene s;
        auto point = [&] { return V3(u(rng), u(rng), u(rng)); };
        const auto tet = random_scene(s, rng, point, 12, 24);
        tally.add(evaluate(s, tet, validity),
                  "seed " + std::to_string(seed) + ": " + describe(s, tet));
    }
    INFO(tally.first_mismatch);
    CHECK(tally.mismatches == 0);
    CHECK(tally.valid > 100);  // both answers occur often
    CHECK(tally.invalid > 100);
}

TEST_CASE("Validity: fast and portable equal the reference on degenerate scenes", "[volume]") {
    // Points on a small integer grid: many lie exactly on the tet's planes, edges and nodes,
    // and many triangles are coplanar with its faces or share its nodes. The grid is then
    // scaled and moved (huge and tiny coordinates; exact for the power-of-two scales).
    struct Frame {
        double scale;
        V3 offset;
    };
    const Frame frames[] = {{1.0, V3::Zero()},
                            {0.5, V3(0.25, -0.75, 0.5)},
                            {1024.0, V3(1e8, -3e8, 2e8)},
                            {1.0 / 1024.0, V3(1e-3, 2e-3, -1e-3)},
                            {1e-7, V3::Zero()},
                            {3e6, V3(-1e9, 1e9, 5e8)}};
    for (const Frame& frame : frames) {
        Tally tally;
        volume::TetValidity validity;
        for (std::uint64_t seed = 1; seed <= 1500; ++seed) {
            std::mt19937_64 rng(seed);
            std::uniform_int_distribution<int> g(0, 4);
            Scene s;
            auto point = [&] {
                return V3(frame.offset + frame.scale * V3(g(rng), g(rng), g(rng)));
            };
            const auto tet = random_scene(s, rng, point, 10, 30);
            tally.add(evaluate(s, tet, validity),
                      "seed " + std::to_string(seed) + ": " + describe(s, tet));
        }
        INFO("scale " << frame.scale << ", offset " << frame.offset.transpose());
        INFO(tally.first_mismatch);
        CHECK(tally.mismatches == 0);
        CHECK(tally.valid > 20);
        CHECK(tally.invalid > 20);
    }
}

TEST_CASE("Validity: fast and portable equal the reference on nearly flat tets", "[volume]") {
    // Slivers and caps: the apex q a hair above the base plane, over the base, its edges or
    // beyond them; front nodes near the base plane on both sides.
    Tally tally;
    for (std::uint64_t seed = 1; seed <= 3000; ++seed) {
        std::mt19937_64 rng(seed);
        std::uniform_real_distribution<double> u(-1.0, 1.0);
        const double eps = std::pow(10.0, -2.0 - static_cast<double>(seed % 12));
        Scene s;
        const auto a = s.add_point({0, 0, 0}), b = s.add_point({1, 0, 0}),
                   c = s.add_point({u(rng), 1 + u(rng), 0});
        const auto q = s.add_point({u(rng), u(rng), eps * (seed % 2 ? 1.0 : -1.0)});
        volume::CandidateTet tet = candidate(a, b, c, q);
        orient(s, tet);
        std::vector<std::int32_t> nodes{a, b, c, q};
        for (int i = 0; i < 10; ++i) {
            const double z = (i % 3 == 0) ? 0.0 : eps * u(rng) * 2.0;
            nodes.push_back(s.add_point({2.0 * u(rng), 2.0 * u(rng), z}));
        }
        std::uniform_int_distribution<std::size_t> pick(0, nodes.size() - 1);
        for (int k = 0; k < 6; ++k) {
            const auto f0 = nodes[pick(rng)], f1 = nodes[pick(rng)], f2 = nodes[pick(rng)];
            if (f0 != f1 && f1 != f2 && f0 != f2) s.add_face(f0, f1, f2);
        }
        tally.add(evaluate(s, tet), "seed " + std::to_string(seed) + ": " + describe(s, tet));
    }
    INFO(tally.first_mismatch);
    CHECK(tally.mismatches == 0);
    CHECK(tally.valid > 50);
    CHECK(tally.invalid > 50);
}
