#pragma once
// Arc-length evaluation of a background polyline (a feature curve), shared by the smoothing
// and the obtuse-face splits of remesh.

#include <algorithm>
#include <cstddef>
#include <vector>

#include <Eigen/Core>

namespace frontmesh::surface {

struct Polyline {
    std::vector<Eigen::Vector3d> points;
    std::vector<double> cumulative;  // arc length at each point

    static Polyline of(std::vector<Eigen::Vector3d> points) {
        Polyline pl;
        pl.points = std::move(points);
        pl.cumulative.assign(pl.points.size(), 0.0);
        for (std::size_t i = 1; i < pl.points.size(); ++i)
            pl.cumulative[i] = pl.cumulative[i - 1] + (pl.points[i] - pl.points[i - 1]).norm();
        return pl;
    }
    double length() const { return cumulative.empty() ? 0.0 : cumulative.back(); }
    /// The point at arc length s (clamped to the ends).
    Eigen::Vector3d at(double s) const {
        if (points.size() < 2) return points.empty() ? Eigen::Vector3d::Zero() : points[0];
        const auto it = std::upper_bound(cumulative.begin(), cumulative.end(), s);
        std::size_t i = it == cumulative.begin() ? 0 : std::size_t(it - cumulative.begin()) - 1;
        i = std::min(i, points.size() - 2);
        const double len = cumulative[i + 1] - cumulative[i];
        const double t = len > 0.0 ? std::clamp((s - cumulative[i]) / len, 0.0, 1.0) : 0.0;
        return (1.0 - t) * points[i] + t * points[i + 1];
    }
};

}  // namespace frontmesh::surface
