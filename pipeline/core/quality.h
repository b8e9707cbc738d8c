#pragma once
// Element quality measures of the paper (Eqs. 1 and 2) and angles. Plain doubles: these
// rank and report, they never decide topology.

#include <Eigen/Core>

namespace frontmesh::core {

/// Triangle skewness eta (Eq. 2): (a_opt - a) / a_opt, a_opt the area of the equilateral
/// triangle with the same circumcircle. 0 equilateral, 1 degenerate.
double triangle_skewness(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                         const Eigen::Vector3d& c);

/// Smallest interior angle of a triangle, degrees.
double triangle_min_angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                              const Eigen::Vector3d& c);

/// Area of a triangle, mm^2.
double triangle_area(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                     const Eigen::Vector3d& c);

/// Signed volume of tetrahedron (a, b, c, d): positive when d lies on the side of the
/// right-hand normal of (a, b, c).
double tet_signed_volume(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                         const Eigen::Vector3d& c, const Eigen::Vector3d& d);

/// Tetrahedron skewness epsilon (Eq. 1): (V_opt - V) / V_opt, V_opt the volume of the
/// equilateral tetrahedron with the same circumradius. 0 equilateral, 1 degenerate;
/// computed from |V|.
double tet_skewness(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                    const Eigen::Vector3d& d);

/// Smallest of the six dihedral angles of a tetrahedron, degrees.
double tet_min_dihedral_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                            const Eigen::Vector3d& c, const Eigen::Vector3d& d);

}  // namespace frontmesh::core
