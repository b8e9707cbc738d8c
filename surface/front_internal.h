#pragma once
// Internals of the advancing-front surface triangulation shared by its source files.

#include <Eigen/Core>

namespace frontmesh::surface {

/// Closest point of the closed triangle (a, b, c) to p (plain doubles; ranks, never decides).
Eigen::Vector3d closest_point_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                          const Eigen::Vector3d& b, const Eigen::Vector3d& c);

}  // namespace frontmesh::surface
