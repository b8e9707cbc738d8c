// BackgroundPatch: closest-point projection onto one patch of the background surface
// (paper §2: "an alternating digital tree (ADT) is prepared in order to efficiently find
// neighboring nodes"; here the ADT holds the boxes of the background triangles).

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>
#include <string>
#include <utility>

#include "pipeline/core/adt.h"
#include "pipeline/core/error.h"
#include "surface/front_internal.h"
#include "surface/front_triangulate.h"

namespace frontmesh::surface {

namespace {

constexpr double infinity = std::numeric_limits<double>::infinity();

}  // namespace

// Closest point of triangle (a, b, c) to p by Voronoi regions of vertices, edges and face
// (Ericson, Real-Time Collision Detection, §5.1.5). Plain doubles: it ranks, never decides.
Eigen::Vector3d closest_point_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                          const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
    const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
    const double d1 = ab.dot(ap), d2 = ac.dot(ap);
    if (d1 <= 0.0 && d2 <= 0.0) return a;
    const Eigen::Vector3d bp = p - b;
    const double d3 = ab.dot(bp), d4 = ac.dot(bp);
    if (d3 >= 0.0 && d4 <= d3) return b;
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return a + (d1 / (d1 - d3)) * ab;
    const Eigen::Vector3d cp = p - c;
    const double d5 = ab.dot(cp), d6 = ac.dot(cp);
    if (d6 >= 0.0 && d5 <= d6) return c;
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return a + (d2 / (d2 - d6)) * ac;
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0)
        return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
    const double denom = 1.0 / (va + vb + vc);
    return a + ab * (vb * denom) + ac * (vc * denom);
}

// Memory: 96 B of corner coordinates and normal per face, an ADT node (64 B) per face, and a
// vertex->face CSR (about 28 B per face): about 200 MB per million patch faces.
struct BackgroundPatch::Impl {
    const core::SurfaceNetwork* background = nullptr;
    std::vector<std::int32_t> faces;                               // local -> global face id
    std::vector<std::pair<std::int32_t, std::int32_t>> by_global;  // (global, local), sorted
    std::vector<double> corners;                                   // 9 per local face (oriented)
    std::vector<double> normals;                                   // 3 per local face
    std::vector<double> smooth;                                    // 3 per local face
    std::vector<std::array<std::int32_t, 3>> local_vertices;       // local vertex ids per face
    std::vector<std::int32_t> star_offsets, star_faces;            // local vertex -> local faces
    std::vector<Eigen::Vector3d> vertex_xyz;                       // per local vertex
    core::Adt tree{core::AdtBox{Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones()},
                   core::AdtItems::boxes};
    double area = 0.0;

    Eigen::Map<const Eigen::Vector3d> corner(std::int32_t f, int k) const {
        return Eigen::Map<const Eigen::Vector3d>(&corners[9 * static_cast<std::size_t>(f) + 3 * k]);
    }
    double distance2(std::int32_t f, const Eigen::Vector3d& p, Eigen::Vector3d& q) const {
        q = closest_point_on_triangle(p, corner(f, 0), corner(f, 1), corner(f, 2));
        return (q - p).squaredNorm();
    }
    std::int32_t local_of(std::int32_t global) const {
        auto it = std::lower_bound(by_global.begin(), by_global.end(),
                                   std::pair<std::int32_t, std::int32_t>{global, -1});
        return it != by_global.end() && it->first == global ? it->second : -1;
    }
    Projection make(std::int32_t f, const Eigen::Vector3d& q, double d2) const {
        return {q, faces[static_cast<std::size_t>(f)], std::sqrt(d2)};
    }
};

BackgroundPatch::BackgroundPatch(const core::SurfaceNetwork& background,
                                 std::vector<std::int32_t> faces, bool flip)
    : impl_(std::make_unique<Impl>()) {
    Impl& m = *impl_;
    m.background = &background;
    m.faces = std::move(faces);
    if (m.faces.empty()) FM_THROW(InputError, "remesh: a background patch has no faces");
    const auto n = static_cast<std::int32_t>(m.faces.size());
    m.by_global.resize(m.faces.size());
    m.corners.resize(9 * m.faces.size());
    m.normals.resize(3 * m.faces.size());
    m.local_vertices.resize(m.faces.size());
    core::AdtBox domain;
    std::vector<std::pair<std::int32_t, std::int32_t>> vertex_uses;  // (global vertex, slot)
    vertex_uses.reserve(3 * m.faces.size());
    for (std::int32_t f = 0; f < n; ++f) {
        const std::int32_t g = m.faces[static_cast<std::size_t>(f)];
        if (g < 0 || static_cast<std::size_t>(g) >= background.face_count())
            FM_THROW(InputError, "remesh: patch face id " + std::to_string(g) + " out of range");
        m.by_global[static_cast<std::size_t>(f)] = {g, f};
        auto v = background.faces[static_cast<std::size_t>(g)];
        if (flip) std::swap(v[1], v[2]);
        for (int k = 0; k < 3; ++k) {
            const Eigen::Vector3d p = background.point(v[static_cast<std::size_t>(k)]);
            for (int c = 0; c < 3; ++c)
                m.corners[9 * static_cast<std::size_t>(f) + 3 * k + c] = p[c];
            domain.extend(p);
            vertex_uses.push_back({v[static_cast<std::size_t>(k)], 3 * f + k});
        }
        const Eigen::Vector3d a = m.corner(f, 0), b = m.corner(f, 1), c = m.corner(f, 2);
        const Eigen::Vector3d nrm = (b - a).cross(c - a);
        const double len = nrm.norm();
        m.area += 0.5 * len;
        const Eigen::Vector3d unit =
            len > 0.0 ? Eigen::Vector3d(nrm / len) : Eigen::Vector3d::Zero();
        for (int c2 = 0; c2 < 3; ++c2) m.normals[3 * static_cast<std::size_t>(f) + c2] = unit[c2];
    }
    std::sort(m.by_global.begin(), m.by_global.end());
    for (std::size_t i = 1; i < m.by_global.size(); ++i)
        if (m.by_global[i].first == m.by_global[i - 1].first)
            FM_THROW(InputError, "remesh: patch face " + std::to_string(m.by_global[i].first) +
                                     " listed twice");

    // Local vertex ids and the vertex -> faces star (CSR), for the local descent.
    std::sort(vertex_uses.begin(), vertex_uses.end());
    std::int32_t local_vertex = -1;
    std::vector<std::int32_t> slot_vertex(vertex_uses.size());
    for (std::size_t i = 0; i < vertex_uses.size(); ++i) {
        if (i == 0 || vertex_uses[i].first != vertex_uses[i - 1].first) ++local_vertex;
        const std::int32_t slot = vertex_uses[i].second;
        m.local_vertices[static_cast<std::size_t>(slot / 3)][static_cast<std::size_t>(slot % 3)] =
            local_vertex;
        slot_vertex[i] = local_vertex;
    }
    m.vertex_xyz.resize(static_cast<std::size_t>(local_vertex) + 1);
    for (std::int32_t f = 0; f < n; ++f)
        for (int k = 0; k < 3; ++k)
            m.vertex_xyz[static_cast<std::size_t>(
                m.local_vertices[static_cast<std::size_t>(f)][static_cast<std::size_t>(k)])] =
                m.corner(f, k);
    m.star_offsets.assign(static_cast<std::size_t>(local_vertex) + 2, 0);
    for (std::size_t i = 0; i < vertex_uses.size(); ++i)
        ++m.star_offsets[static_cast<std::size_t>(slot_vertex[i]) + 1];
    for (std::size_t v = 1; v < m.star_offsets.size(); ++v)
        m.star_offsets[v] += m.star_offsets[v - 1];
    m.star_faces.resize(vertex_uses.size());
    {
        std::vector<std::int32_t> fill(m.star_offsets.begin(), m.star_offsets.end() - 1);
        for (std::size_t i = 0; i < vertex_uses.size(); ++i)
            m.star_faces[static_cast<std::size_t>(
                fill[static_cast<std::size_t>(slot_vertex[i])]++)] = vertex_uses[i].second / 3;
    }

    // Smoothed normals: area-weighted over the faces around the three corners.
    m.smooth.assign(3 * m.faces.size(), 0.0);
    for (std::int32_t f = 0; f < n; ++f) {
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        for (int k = 0; k < 3; ++k) {
            const std::int32_t v =
                m.local_vertices[static_cast<std::size_t>(f)][static_cast<std::size_t>(k)];
            for (std::int32_t i = m.star_offsets[static_cast<std::size_t>(v)];
                 i < m.star_offsets[static_cast<std::size_t>(v) + 1]; ++i) {
                const std::int32_t g = m.star_faces[static_cast<std::size_t>(i)];
                const Eigen::Vector3d a = m.corner(g, 0), b = m.corner(g, 1), c = m.corner(g, 2);
                sum += (b - a).cross(c - a);  // twice the area times the unit normal
            }
        }
        const double len = sum.norm();
        const Eigen::Vector3d unit = len > 0.0 ? Eigen::Vector3d(sum / len)
                                               : Eigen::Vector3d(Eigen::Map<const Eigen::Vector3d>(
                                                     &m.normals[3 * static_cast<std::size_t>(f)]));
        for (int c = 0; c < 3; ++c) m.smooth[3 * static_cast<std::size_t>(f) + c] = unit[c];
    }

    const double margin = 1e-6 * std::max(1.0, (domain.hi - domain.lo).norm());
    m.tree = core::Adt(domain.enlarged(margin), core::AdtItems::boxes);
    m.tree.reserve(n);
    for (std::int32_t f = 0; f < n; ++f) {
        core::AdtBox box;
        for (int k = 0; k < 3; ++k) box.extend(m.corner(f, k));
        m.tree.insert(f, box);
    }
    m.tree.compact();
}

BackgroundPatch::~BackgroundPatch() = default;
BackgroundPatch::BackgroundPatch(BackgroundPatch&&) noexcept = default;
BackgroundPatch& BackgroundPatch::operator=(BackgroundPatch&&) noexcept = default;

BackgroundPatch::Projection BackgroundPatch::project(const Eigen::Vector3d& p) const {
    const Impl& m = *impl_;
    if (!p.allFinite()) FM_THROW(InternalError, "remesh: projection of a non-finite point");
    // The nearest box bounds the answer from above (its triangle's distance); every triangle
    // closer than that has its box within the same radius.
    const core::AdtNeighbor first = m.tree.nearest(p);
    Eigen::Vector3d best_q;
    double best = m.distance2(first.id, p, best_q);
    std::int32_t best_f = first.id;
    thread_local std::vector<std::int32_t> ids;
    m.tree.query_sphere(p, std::sqrt(best) * (1.0 + 1e-12) + 1e-300, ids);
    for (const std::int32_t f : ids) {
        if (f == first.id) continue;
        Eigen::Vector3d q;
        const double d2 = m.distance2(f, p, q);
        if (d2 < best || (d2 == best && m.faces[static_cast<std::size_t>(f)] <
                                            m.faces[static_cast<std::size_t>(best_f)])) {
            best = d2;
            best_q = q;
            best_f = f;
        }
    }
    return m.make(best_f, best_q, best);
}

BackgroundPatch::Projection BackgroundPatch::project(const Eigen::Vector3d& p,
                                                     std::int32_t hint) const {
    const Impl& m = *impl_;
    std::int32_t cur = m.local_of(hint);
    if (cur < 0) return project(p);
    if (!p.allFinite()) FM_THROW(InternalError, "remesh: projection of a non-finite point");
    Eigen::Vector3d cur_q;
    double cur_d = m.distance2(cur, p, cur_q);
    for (int step = 0; step < 64; ++step) {
        std::int32_t best_f = cur;
        double best = cur_d;
        Eigen::Vector3d best_q = cur_q;
        for (int k = 0; k < 3; ++k) {
            const std::int32_t v =
                m.local_vertices[static_cast<std::size_t>(cur)][static_cast<std::size_t>(k)];
            for (std::int32_t i = m.star_offsets[static_cast<std::size_t>(v)];
                 i < m.star_offsets[static_cast<std::size_t>(v) + 1]; ++i) {
                const std::int32_t f = m.star_faces[static_cast<std::size_t>(i)];
                if (f == cur) continue;
                Eigen::Vector3d q;
                const double d2 = m.distance2(f, p, q);
                if (d2 < best || (d2 == best && f < best_f && best_f != cur)) {
                    best = d2;
                    best_q = q;
                    best_f = f;
                }
            }
        }
        // Strict decrease (relative) guarantees termination; ties on a shared edge or vertex
        // give the same point and are not worth a step.
        if (best_f == cur || !(best < cur_d * (1.0 - 1e-12))) return m.make(cur, cur_q, cur_d);
        cur = best_f;
        cur_d = best;
        cur_q = best_q;
    }
    return project(p);
}

std::optional<BackgroundPatch::Projection> BackgroundPatch::project_oriented(
    const Eigen::Vector3d& p, const Eigen::Vector3d& normal, double radius, double min_cos) const {
    const Impl& m = *impl_;
    thread_local std::vector<std::int32_t> ids;
    m.tree.query_sphere(p, radius, ids);
    double best = infinity;
    std::int32_t best_f = -1;
    Eigen::Vector3d best_q;
    for (const std::int32_t f : ids) {
        const Eigen::Map<const Eigen::Vector3d> n(&m.normals[3 * static_cast<std::size_t>(f)]);
        if (n.dot(normal) < min_cos) continue;
        Eigen::Vector3d q;
        const double d2 = m.distance2(f, p, q);
        if (d2 < best) {
            best = d2;
            best_q = q;
            best_f = f;
        }
    }
    if (best_f < 0 || best > radius * radius) return std::nullopt;
    return m.make(best_f, best_q, best);
}

double BackgroundPatch::path_distance(const Eigen::Vector3d& p, std::int32_t face_p,
                                      const Eigen::Vector3d& q, std::int32_t face_q,
                                      double limit) const {
    const Impl& m = *impl_;
    const std::int32_t fp = m.local_of(face_p), fq = m.local_of(face_q);
    if (fp < 0 || fq < 0) return infinity;
    if (fp == fq) return (p - q).norm() <= limit ? (p - q).norm() : infinity;
    // Per-thread scratch stamped per query: no clearing, safe across patches.
    thread_local std::vector<double> dist;
    thread_local std::vector<std::uint32_t> seen;
    thread_local std::uint32_t stamp = 0;
    if (dist.size() < m.vertex_xyz.size()) {
        dist.resize(m.vertex_xyz.size());
        seen.resize(m.vertex_xyz.size(), 0);
    }
    if (++stamp == 0) {
        std::fill(seen.begin(), seen.end(), 0);
        stamp = 1;
    }
    using Item = std::pair<double, std::int32_t>;
    std::priority_queue<Item, std::vector<Item>, std::greater<Item>> heap;
    auto relax = [&](std::int32_t v, double d) {
        if (d > limit) return;
        const auto i = static_cast<std::size_t>(v);
        if (seen[i] != stamp || d < dist[i]) {
            seen[i] = stamp;
            dist[i] = d;
            heap.push({d, v});
        }
    };
    for (int k = 0; k < 3; ++k) {
        const std::int32_t v =
            m.local_vertices[static_cast<std::size_t>(fp)][static_cast<std::size_t>(k)];
        relax(v, (m.vertex_xyz[static_cast<std::size_t>(v)] - p).norm());
    }
    const auto& targets = m.local_vertices[static_cast<std::size_t>(fq)];
    double best = infinity;
    while (!heap.empty()) {
        const auto [d, v] = heap.top();
        heap.pop();
        if (d > dist[static_cast<std::size_t>(v)] || d >= best) continue;
        const Eigen::Vector3d& xv = m.vertex_xyz[static_cast<std::size_t>(v)];
        if (v == targets[0] || v == targets[1] || v == targets[2])
            best = std::min(best, d + (xv - q).norm());
        for (std::int32_t i = m.star_offsets[static_cast<std::size_t>(v)];
             i < m.star_offsets[static_cast<std::size_t>(v) + 1]; ++i) {
            const auto& tri = m.local_vertices[static_cast<std::size_t>(
                m.star_faces[static_cast<std::size_t>(i)])];
            for (const std::int32_t w : tri)
                if (w != v) relax(w, d + (m.vertex_xyz[static_cast<std::size_t>(w)] - xv).norm());
        }
    }
    return best <= limit ? best : infinity;
}

Eigen::Vector3d BackgroundPatch::normal(std::int32_t face) const {
    const Impl& m = *impl_;
    const std::int32_t f = m.local_of(face);
    if (f >= 0)
        return Eigen::Map<const Eigen::Vector3d>(&m.normals[3 * static_cast<std::size_t>(f)]);
    FM_THROW(InternalError,
             "remesh: normal of face " + std::to_string(face) + " outside the patch");
}

Eigen::Vector3d BackgroundPatch::smooth_normal(std::int32_t face) const {
    const Impl& m = *impl_;
    const std::int32_t f = m.local_of(face);
    if (f >= 0)
        return Eigen::Map<const Eigen::Vector3d>(&m.smooth[3 * static_cast<std::size_t>(f)]);
    FM_THROW(InternalError,
             "remesh: normal of face " + std::to_string(face) + " outside the patch");
}

const std::vector<std::int32_t>& BackgroundPatch::faces() const { return impl_->faces; }
const core::SurfaceNetwork& BackgroundPatch::background() const { return *impl_->background; }
bool BackgroundPatch::contains(std::int32_t face) const { return impl_->local_of(face) >= 0; }
double BackgroundPatch::area() const { return impl_->area; }

}  // namespace frontmesh::surface
