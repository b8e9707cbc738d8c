#pragma once
// Internals of the advancing-front surface triangulation shared by its source files.

#include <cstdint>

#include <Eigen/Core>

namespace frontmesh::surface {

/// Closest point of the closed triangle (a, b, c) to p (plain doubles; ranks, never decides).
Eigen::Vector3d closest_point_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                          const Eigen::Vector3d& b, const Eigen::Vector3d& c);

/// Exact test of two triangles of one mesh, `ids` their vertex ids (-1: a point of no id, never
/// shared), `x` their corners: true when they share a point other than their common vertices
/// (no common vertex: they intersect; one: the far edge of one meets the other; two: they fold
/// onto each other, coplanar on the same side of the common edge; three: the same triangle).
bool triangles_overlap(const std::int32_t ids_a[3], const double* const x_a[3],
                       const std::int32_t ids_b[3], const double* const x_b[3]);

}  // namespace frontmesh::surface
