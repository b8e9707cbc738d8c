// Quality and distance measures of remeshed surfaces (public helpers of surface/remesh.h).

#include <algorithm>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "pipeline/core/error.h"
#include "pipeline/core/quality.h"
#include "surface/features.h"
#include "surface/front_triangulate.h"
#include "surface/remesh.h"

namespace frontmesh::surface {

HausdorffDistance hausdorff_distance(const core::SurfaceNetwork& a, const core::SurfaceNetwork& b) {
    auto one_way = [](const core::SurfaceNetwork& from, const core::SurfaceNetwork& to,
                      double& max_out, double& mean_out) {
        std::vector<std::int32_t> all(to.face_count());
        for (std::size_t f = 0; f < all.size(); ++f) all[f] = static_cast<std::int32_t>(f);
        const BackgroundPatch target(to, std::move(all), false);
        // Samples: vertices, then per face the centroid and the three edge midpoints.
        const std::size_t nv = from.vertex_count(), nf = from.face_count();
        std::vector<double> dist(nv + 4 * nf, 0.0);
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv + nf, 512), [&](const auto& r) {
            for (std::size_t i = r.begin(); i != r.end(); ++i) {
                if (i < nv) {
                    dist[i] = target.project(from.point(static_cast<std::int32_t>(i))).distance;
                    continue;
                }
                const auto& t = from.faces[i - nv];
                const Eigen::Vector3d p0 = from.point(t[0]), p1 = from.point(t[1]),
                                      p2 = from.point(t[2]);
                const Eigen::Vector3d samples[4] = {(p0 + p1 + p2) / 3.0, 0.5 * (p0 + p1),
                                                    0.5 * (p1 + p2), 0.5 * (p2 + p0)};
                for (int k = 0; k < 4; ++k)
                    dist[nv + 4 * (i - nv) + std::size_t(k)] = target.project(samples[k]).distance;
            }
        });
        max_out = 0.0;
        double sum = 0.0;
        for (const double d : dist) {
            max_out = std::max(max_out, d);
            sum += d;
        }
        mean_out = dist.empty() ? 0.0 : sum / double(dist.size());
    };
    HausdorffDistance h;
    if (a.face_count() == 0 || b.face_count() == 0)
        FM_THROW(InputError, "hausdorff_distance: empty surface");
    one_way(a, b, h.a_to_b, h.mean_a_to_b);
    one_way(b, a, h.b_to_a, h.mean_b_to_a);
    return h;
}

SurfaceQuality surface_quality(const core::SurfaceNetwork& s) {
    SurfaceQuality q;
    q.faces = s.face_count();
    if (q.faces == 0) return q;
    std::size_t below_20 = 0, at_least_30 = 0;
    double eta_sum = 0.0;
    for (const auto& t : s.faces) {
        const Eigen::Vector3d a = s.point(t[0]), b = s.point(t[1]), c = s.point(t[2]);
        const double angle = core::triangle_min_angle_deg(a, b, c);
        const double eta = core::triangle_skewness(a, b, c);  // Eq. 2
        q.min_angle_deg = std::min(q.min_angle_deg, angle);
        q.max_eta = std::max(q.max_eta, eta);
        eta_sum += eta;
        if (angle < 20.0) ++below_20;
        if (angle >= 30.0) ++at_least_30;
        const auto bin = std::min<std::size_t>(9, std::size_t(std::max(0.0, eta) * 10.0));
        ++q.eta_histogram[bin];
    }
    q.mean_eta = eta_sum / double(q.faces);
    q.fraction_below_20_deg = double(below_20) / double(q.faces);
    q.fraction_at_least_30_deg = double(at_least_30) / double(q.faces);
    return q;
}

double edge_length_fraction(const core::SurfaceNetwork& s, double lo, double hi) {
    const EdgeTable et = edge_table(s);
    if (et.edge_count() == 0) return 0.0;
    std::size_t inside = 0;
    for (const auto& e : et.vertices) {
        const double len = (s.point(e[0]) - s.point(e[1])).norm();
        if (len >= lo && len <= hi) ++inside;
    }
    return double(inside) / double(et.edge_count());
}

}  // namespace frontmesh::surface
