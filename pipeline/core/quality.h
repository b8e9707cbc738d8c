#pragma once
// Element quality measures of the paper (Eqs. 1 and 2) and angles. Plain doubles: these
// rank and report, they never decide topology.

#include <array>

#include <Eigen/Core>

namespace frontmesh::core {

/// Triangle skewness eta (Eq. 2): (a_opt - a) / a_opt, a_opt the area of the equilateral
/// triangle with the same circumcircle. 0 equilateral, 1 degenerate.
double triangle_skewness(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                         const Eigen::Vector3d& c);

/// Smallest interior angle of a triangle, degrees.
double triangle_min_angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                              const Eigen::Vector3d& c);

/// The three interior angles of a triangle, degrees, at a, b and c.
std::array<double, 3> triangle_angles_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                          const Eigen::Vector3d& c);

/// Area of a triangle, mm^2.
double triangle_area(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c);

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

/// The figures every report shows of one tetrahedron: skewness (Eq. 1) and its six interior
/// dihedral angles in degrees, one per pair of faces (0,1) (0,2) (0,3) (1,2) (1,3) (2,3),
/// face i opposite vertex i, kept as floats (they are looked at, not decided on; 32 bytes a
/// tet). A tet with a zero-area face has skewness 1 and angles of 0 and 180 degrees.
struct TetFigures {
    double skewness = 1.0;
    float dihedral_deg[6] = {0, 0, 0, 180, 180, 180};
    double min_dihedral_deg() const;
    double max_dihedral_deg() const;
};

/// TetFigures of tetrahedron (a, b, c, d), for either orientation: skewness as tet_skewness,
/// min_dihedral_deg() as tet_min_dihedral_deg rounded to float.
TetFigures tet_figures(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                       const Eigen::Vector3d& d);

}  // namespace frontmesh::core
