#include "surface/size_field.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <queue>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "pipeline/core/error.h"
#include "surface/features.h"

namespace frontmesh::surface {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

core::AdtBox bounding_box(const core::SurfaceNetwork& s) {
    core::AdtBox box;
    for (std::size_t v = 0; v < s.vertex_count(); ++v)
        box.extend(s.point(static_cast<std::int32_t>(v)));
    if (!box.is_valid()) box = core::AdtBox::of_point(Eigen::Vector3d::Zero());
    return box.enlarged(1e-6 + 1e-9 * (box.hi - box.lo).norm());
}

// Ray parameter t of the hit of ray (o, d) with triangle (a, b, c), or infinity
// (Moeller-Trumbore; a measurement, not a topological decision).
double ray_triangle(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Eigen::Vector3d& a,
                    const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
    const Eigen::Vector3d e1 = b - a, e2 = c - a;
    const Eigen::Vector3d pv = d.cross(e2);
    const double det = e1.dot(pv);
    if (std::abs(det) < 1e-300) return kInf;
    const double inv = 1.0 / det;
    const Eigen::Vector3d tv = o - a;
    const double u = tv.dot(pv) * inv;
    if (u < -1e-12 || u > 1.0 + 1e-12) return kInf;
    const Eigen::Vector3d qv = tv.cross(e1);
    const double v = d.dot(qv) * inv;
    if (v < -1e-12 || u + v > 1.0 + 1e-12) return kInf;
    const double t = e2.dot(qv) * inv;
    return t > 0.0 ? t : kInf;
}

}  // namespace

SizeField::SizeField(const core::SurfaceNetwork& background, std::vector<double> vertex_size)
    : background_(&background),
      size_(std::move(vertex_size)),
      vertices_(bounding_box(background), core::AdtItems::points) {
    FM_CHECK(size_.size() == background.vertex_count());
    vertices_.reserve(static_cast<std::int32_t>(background.vertex_count()));
    for (std::size_t v = 0; v < background.vertex_count(); ++v)
        vertices_.insert(static_cast<std::int32_t>(v),
                         Eigen::Vector3d(background.point(static_cast<std::int32_t>(v))));
    vertices_.compact();
}

double SizeField::at(const Eigen::Vector3d& p, std::int32_t face) const {
    if (face < 0 || face >= static_cast<std::int32_t>(background_->face_count())) {
        const auto nearest = vertices_.nearest(p);
        FM_CHECK(nearest.id >= 0);
        return size_[std::size_t(nearest.id)];
    }
    const auto& t = background_->faces[std::size_t(face)];
    const Eigen::Vector3d a = background_->point(t[0]), b = background_->point(t[1]),
                          c = background_->point(t[2]);
    // Barycentric coordinates of p's projection on the face plane, clamped to the face.
    const Eigen::Vector3d n = (b - a).cross(c - a);
    const double area2 = n.squaredNorm();
    if (area2 <= 0.0)
        return (size_[std::size_t(t[0])] + size_[std::size_t(t[1])] + size_[std::size_t(t[2])]) /
               3.0;
    double wa = (c - b).cross(p - b).dot(n) / area2;
    double wb = (a - c).cross(p - c).dot(n) / area2;
    double wc = 1.0 - wa - wb;
    wa = std::max(wa, 0.0);
    wb = std::max(wb, 0.0);
    wc = std::max(wc, 0.0);
    const double sum = wa + wb + wc;
    return (wa * size_[std::size_t(t[0])] + wb * size_[std::size_t(t[1])] +
            wc * size_[std::size_t(t[2])]) /
           sum;
}

double mean_edge_length(const core::SurfaceNetwork& s) {
    const EdgeTable et = edge_table(s);
    if (et.edge_count() == 0) return 0.0;
    double sum = 0.0;
    for (const auto& e : et.vertices) sum += (s.point(e[0]) - s.point(e[1])).norm();
    return sum / double(et.edge_count());
}

SheetDistances sheet_distances(const core::SurfaceNetwork& s,
                               const std::vector<double>& max_distance) {
    const std::size_t n = s.vertex_count();
    FM_CHECK(max_distance.size() == n);
    SheetDistances out;
    out.inside.assign(n, kInf);
    out.outside.assign(n, kInf);
    if (n == 0) return out;

    // Face boxes in an ADT: each vertex queries the box of its ray segments only (two sides
    // of each normal), far fewer faces than a ball of the ray's length around it.
    core::Adt tree(bounding_box(s), core::AdtItems::boxes);
    tree.reserve(static_cast<std::int32_t>(s.face_count()));
    std::vector<Eigen::Vector3d> normals(s.face_count());
    for (std::size_t f = 0; f < s.face_count(); ++f) {
        const auto& t = s.faces[f];
        core::AdtBox box = core::AdtBox::of_point(s.point(t[0]));
        box.extend(s.point(t[1]));
        box.extend(s.point(t[2]));
        tree.insert(static_cast<std::int32_t>(f), box);
        normals[f] = (s.point(t[1]) - s.point(t[0])).cross(s.point(t[2]) - s.point(t[0]));
    }
    tree.compact();
    std::vector<std::int32_t> offsets, incident;
    core::vertex_faces(s, offsets, incident);

    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1024), [&](const auto& range) {
        std::vector<std::int32_t> found;
        std::vector<std::pair<std::int64_t, Eigen::Vector3d>> groups;  // (pair key, normal sum)
        for (std::size_t v = range.begin(); v != range.end(); ++v) {
            const double limit = max_distance[v];
            if (!(limit > 0.0)) continue;
            const auto* fs = &incident[std::size_t(offsets[v])];
            const auto count = offsets[v + 1] - offsets[v];
            groups.clear();
            for (int k = 0; k < count; ++k) {
                const std::size_t f = std::size_t(fs[k]);
                const std::int64_t key =
                    (std::int64_t(s.region_in[f]) << 32) | std::uint32_t(s.region_out[f]);
                auto it = std::find_if(groups.begin(), groups.end(),
                                       [&](const auto& g) { return g.first == key; });
                if (it == groups.end())
                    groups.emplace_back(key, normals[f]);
                else
                    it->second += normals[f];
            }
            const Eigen::Vector3d o = s.point(static_cast<std::int32_t>(v));
            // One query for every ray of this vertex: faces whose box meets the rays' box.
            core::AdtBox rays = core::AdtBox::of_point(o);
            for (const auto& group : groups) {
                if (group.second.norm() <= 0.0) continue;
                const Eigen::Vector3d d = limit * group.second.normalized();
                rays.extend(o + d);
                rays.extend(o - d);
            }
            tree.query_box(rays, found);
            for (const auto& [key, sum] : groups) {
                if (sum.norm() <= 0.0) continue;
                const Eigen::Vector3d nrm = sum.normalized();
                const auto region_out = static_cast<core::Label>(key & 0xffffffff);
                for (const double side : {-1.0, 1.0}) {  // -1: into region_in, +1: region_out
                    const Eigen::Vector3d d = side * nrm;
                    double best = kInf;
                    for (const std::int32_t g : found) {
                        const auto& t = s.faces[std::size_t(g)];
                        if (t[0] == std::int32_t(v) || t[1] == std::int32_t(v) ||
                            t[2] == std::int32_t(v))
                            continue;
                        const Eigen::Vector3d& gn = normals[std::size_t(g)];
                        const double gl = gn.norm();
                        if (gl <= 0.0 || std::abs(gn.dot(d)) < 0.5 * gl) continue;  // not facing
                        const double hit =
                            ray_triangle(o, d, s.point(t[0]), s.point(t[1]), s.point(t[2]));
                        if (hit < best) best = hit;
                    }
                    if (best > limit) continue;
                    if (side < 0.0 || region_out > 0) {
                        out.inside[v] = std::min(out.inside[v], best);
                    } else {
                        out.outside[v] = std::min(out.outside[v], best);
                    }
                }
            }
        }
    });
    return out;
}

std::size_t limit_gradation(const core::SurfaceNetwork& s, double gradation,
                            std::vector<double>& size) {
    const std::size_t n = s.vertex_count();
    FM_CHECK(size.size() == n);
    const EdgeTable et = edge_table(s);
    std::vector<std::int32_t> offsets(n + 1, 0);
    for (const auto& e : et.vertices) {
        ++offsets[std::size_t(e[0]) + 1];
        ++offsets[std::size_t(e[1]) + 1];
    }
    for (std::size_t v = 0; v < n; ++v) offsets[v + 1] += offsets[v];
    std::vector<std::int32_t> adjacent(static_cast<std::size_t>(offsets[n]));
    {
        std::vector<std::int32_t> fill(offsets.begin(), offsets.end() - 1);
        for (const auto& e : et.vertices) {
            adjacent[std::size_t(fill[std::size_t(e[0])]++)] = e[1];
            adjacent[std::size_t(fill[std::size_t(e[1])]++)] = e[0];
        }
    }
    const double slope = gradation - 1.0;
    std::vector<std::uint8_t> lowered(n, 0), done(n, 0);
    using Item = std::pair<double, std::int32_t>;
    std::priority_queue<Item, std::vector<Item>, std::greater<Item>> queue;
    for (std::size_t v = 0; v < n; ++v) queue.emplace(size[v], static_cast<std::int32_t>(v));
    while (!queue.empty()) {
        const auto [h, u] = queue.top();
        queue.pop();
        if (done[std::size_t(u)] || h > size[std::size_t(u)]) continue;
        done[std::size_t(u)] = 1;
        const Eigen::Vector3d pu = s.point(u);
        for (auto k = offsets[std::size_t(u)]; k < offsets[std::size_t(u) + 1]; ++k) {
            const std::int32_t w = adjacent[std::size_t(k)];
            if (done[std::size_t(w)]) continue;
            const double limit = h + slope * (s.point(w) - pu).norm();
            if (limit < size[std::size_t(w)]) {
                size[std::size_t(w)] = limit;
                lowered[std::size_t(w)] = 1;
                queue.emplace(limit, w);
            }
        }
    }
    return std::size_t(std::count(lowered.begin(), lowered.end(), 1));
}

SizeField build_size_field(const core::SurfaceNetwork& s, const SizeFieldParams& params,
                           core::StageContext& ctx, SizeFieldStats* stats_out) {
    const double h = params.edge_length;
    if (!(h > 0.0) || !std::isfinite(h))
        FM_THROW(InputError, "remesh.edge_length: must be > 0 mm, got " + std::to_string(h));
    if (!(params.gradation >= 1.0))
        FM_THROW(InputError,
                 "remesh.gradation: must be >= 1, got " + std::to_string(params.gradation));
    const double h_min = params.min_edge_length > 0.0 ? params.min_edge_length : h / 4.0;
    const double h_max = params.max_edge_length > 0.0 ? params.max_edge_length : 4.0 * h;
    if (h_min > h_max)
        FM_THROW(InputError, "remesh.min_edge_length: larger than remesh.max_edge_length");
    SizeFieldStats stats;
    const std::size_t n = s.vertex_count();
    std::vector<double> size(n, h);

    // Per-label sizes: the smallest size of the labels a vertex touches.
    if (!params.label_edge_length.empty()) {
        for (std::size_t f = 0; f < s.face_count(); ++f) {
            for (const core::Label label : {s.region_in[f], s.region_out[f]}) {
                const auto it = params.label_edge_length.find(label);
                if (it == params.label_edge_length.end()) continue;
                if (!(it->second > 0.0))
                    FM_THROW(InputError, "remesh.label_edge_length: label " +
                                             std::to_string(label) + " needs a size > 0 mm");
                for (const auto v : s.faces[f])
                    size[std::size_t(v)] = std::min(size[std::size_t(v)], it->second);
            }
        }
    }

    // Curvature: along an edge uv of a smooth sheet the vertex normals turn by |uv| / R, so
    // angle(n_u, n_v) / |uv| estimates 1/R; h <= angle * R bounds the turning angle per edge.
    // Vertices where several (region_in, region_out) pairs meet have no single normal and
    // take the estimate of their neighbours.
    if (params.curvature_angle_deg > 0.0) {
        const double theta = params.curvature_angle_deg * std::numbers::pi / 180.0;
        const EdgeTable et = edge_table(s);
        std::vector<Eigen::Vector3d> vertex_normal(n, Eigen::Vector3d::Zero());
        std::vector<std::int64_t> pair_of(n, -1);
        std::vector<std::uint8_t> mixed(n, 0);
        for (std::size_t f = 0; f < s.face_count(); ++f) {
            const auto& t = s.faces[f];
            const Eigen::Vector3d nf =
                (s.point(t[1]) - s.point(t[0])).cross(s.point(t[2]) - s.point(t[0]));
            const std::int64_t key =
                (std::int64_t(s.region_in[f]) << 32) | std::uint32_t(s.region_out[f]);
            for (const auto v : t) {
                vertex_normal[std::size_t(v)] += nf;
                if (pair_of[std::size_t(v)] >= 0 && pair_of[std::size_t(v)] != key)
                    mixed[std::size_t(v)] = 1;
                pair_of[std::size_t(v)] = key;
            }
        }
        for (auto& x : vertex_normal)
            if (x.norm() > 0.0) x.normalize();
        std::vector<double> kappa_sum(n, 0.0), weight(n, 0.0);
        for (std::size_t e = 0; e < et.edge_count(); ++e) {
            const auto [u, v] = et.vertices[e];
            if (mixed[std::size_t(u)] || mixed[std::size_t(v)]) continue;
            const Eigen::Vector3d& nu = vertex_normal[std::size_t(u)];
            const Eigen::Vector3d& nv = vertex_normal[std::size_t(v)];
            const double len = (s.point(u) - s.point(v)).norm();
            if (len <= 0.0) continue;
            const double angle = std::atan2(nu.cross(nv).norm(), nu.dot(nv));
            for (const auto w : {u, v}) {
                kappa_sum[std::size_t(w)] += angle;  // sum of angle / len, weighted by len
                weight[std::size_t(w)] += len;
            }
        }
        std::vector<double> kappa(n, 0.0);
        for (std::size_t v = 0; v < n; ++v)
            if (weight[v] > 0.0) kappa[v] = kappa_sum[v] / weight[v];
        // One averaging pass over the edges: the staircase of a marching-cubes surface makes
        // single-edge estimates noisy.
        std::vector<double> smooth_sum(kappa), smooth_count(n, 1.0);
        for (const auto& e : et.vertices) {
            smooth_sum[std::size_t(e[0])] += kappa[std::size_t(e[1])];
            smooth_sum[std::size_t(e[1])] += kappa[std::size_t(e[0])];
            smooth_count[std::size_t(e[0])] += 1.0;
            smooth_count[std::size_t(e[1])] += 1.0;
        }
        for (std::size_t v = 0; v < n; ++v) {
            const double k = smooth_sum[v] / smooth_count[v];
            if (k > 0.0 && theta / k < size[v]) {
                size[v] = theta / k;
                ++stats.curvature_limited;
            }
        }
    }

    // Sheets: a gap d gets h <= d; a region of thickness t gets h <= t / max(N, 1).
    {
        const double layers = std::max(1, params.thickness_layers);
        std::vector<double> reach(n);
        for (std::size_t v = 0; v < n; ++v) reach[v] = std::min(size[v], h_max) * layers;
        const SheetDistances d = sheet_distances(s, reach);
        for (std::size_t v = 0; v < n; ++v) {
            const double limit = std::min(d.inside[v] / layers, d.outside[v]);
            if (limit < size[v]) {
                size[v] = limit;
                ++stats.gap_limited;
                if (limit < h_min) ++stats.gap_below_min;
            }
        }
    }

    for (double& x : size) x = std::clamp(x, h_min, h_max);
    stats.graded = limit_gradation(s, params.gradation, size);

    ctx.count("remesh.size_curvature_limited", double(stats.curvature_limited));
    ctx.count("remesh.size_gap_limited", double(stats.gap_limited));
    ctx.count("remesh.size_gap_below_min", double(stats.gap_below_min));
    ctx.count("remesh.size_graded", double(stats.graded));
    if (stats.gap_below_min > 0)
        ctx.warn("remesh: " + std::to_string(stats.gap_below_min) +
                 " background vertices face a sheet closer than remesh.min_edge_length (" +
                 std::to_string(h_min) + " mm); the clamp wins there");
    if (stats_out) *stats_out = stats;
    return SizeField(s, std::move(size));
}

}  // namespace frontmesh::surface
