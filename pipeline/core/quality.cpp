#include "pipeline/core/quality.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>
#include <numbers>

#include <Eigen/Geometry>

namespace frontmesh::core {

double triangle_area(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
    return 0.5 * (b - a).cross(c - a).norm();
}

double triangle_skewness(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                         const Eigen::Vector3d& c) {
    const double area = triangle_area(a, b, c);
    if (area <= 0.0) return 1.0;
    // Circumradius R = |ab| |bc| |ca| / (4 area); equilateral area for R: 3 sqrt(3) / 4 R^2.
    const double R = (b - a).norm() * (c - b).norm() * (a - c).norm() / (4.0 * area);
    const double a_opt = 3.0 * std::sqrt(3.0) / 4.0 * R * R;  // Eq. 2
    return std::clamp((a_opt - area) / a_opt, 0.0, 1.0);
}

double triangle_min_angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                              const Eigen::Vector3d& c) {
    // The smallest angle lies opposite the shortest side (law of sines): one atan2, at the
    // vertex i opposite side (i + 1, i + 2).
    const std::array<Eigen::Vector3d, 3> p{a, b, c};
    const double side2[3] = {(c - b).squaredNorm(), (a - c).squaredNorm(), (b - a).squaredNorm()};
    int i = 0;
    if (side2[1] < side2[i]) i = 1;
    if (side2[2] < side2[i]) i = 2;
    const Eigen::Vector3d u = p[(i + 1) % 3] - p[i];
    const Eigen::Vector3d v = p[(i + 2) % 3] - p[i];
    return std::atan2(u.cross(v).norm(), u.dot(v)) * 180.0 / std::numbers::pi;
}

std::array<double, 3> triangle_angles_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                          const Eigen::Vector3d& c) {
    const auto angle = [](const Eigen::Vector3d& u, const Eigen::Vector3d& v) {
        return std::atan2(u.cross(v).norm(), u.dot(v)) * 180.0 / std::numbers::pi;
    };
    return {angle(b - a, c - a), angle(c - b, a - b), angle(a - c, b - c)};
}

double tet_signed_volume(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                         const Eigen::Vector3d& c, const Eigen::Vector3d& d) {
    return (b - a).cross(c - a).dot(d - a) / 6.0;
}

double tet_skewness(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                    const Eigen::Vector3d& d) {
    const Eigen::Vector3d u = b - a, v = c - a, w = d - a;
    const double det = u.dot(v.cross(w));
    if (det == 0.0) return 1.0;
    // Circumcentre offset from a: (|u|^2 v x w + |v|^2 w x u + |w|^2 u x v) / (2 det).
    const Eigen::Vector3d offset = (u.squaredNorm() * v.cross(w) + v.squaredNorm() * w.cross(u) +
                                    w.squaredNorm() * u.cross(v)) /
                                   (2.0 * det);
    const double R = offset.norm();
    const double volume = std::abs(det) / 6.0;
    const double v_opt = 8.0 * std::sqrt(3.0) / 27.0 * R * R * R;  // Eq. 1
    return std::clamp((v_opt - volume) / v_opt, 0.0, 1.0);
}

namespace {

// The six interior dihedral angles of a tetrahedron in degrees, one per pair of faces (0,1)
// (0,2) (0,3) (1,2) (1,3) (2,3), face i opposite vertex i; false (angles untouched) when a face
// has zero area. Face normals come from a consistently oriented boundary: all outward when
// the signed volume is positive, all inward when negative. Deciding each face's side from the
// opposite vertex instead fails for flat tetrahedra (that vertex lies in the face's plane)
// and could report 180 degrees where the true answer is 0.
bool dihedral_angles_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                         const Eigen::Vector3d& c, const Eigen::Vector3d& d, double (&angles)[6]) {
    const std::array<std::array<const Eigen::Vector3d*, 3>, 4> faces{
        {{&b, &c, &d}, {&a, &d, &c}, {&a, &b, &d}, {&a, &c, &b}}};
    std::array<Eigen::Vector3d, 4> n;
    for (int i = 0; i < 4; ++i) {
        const auto& f = faces[static_cast<std::size_t>(i)];
        const Eigen::Vector3d normal = (*f[1] - *f[0]).cross(*f[2] - *f[0]);
        const double length = normal.norm();
        if (length == 0.0) return false;
        n[static_cast<std::size_t>(i)] = normal / length;
    }
    int k = 0;
    for (int i = 0; i < 4; ++i)
        for (int j = i + 1; j < 4; ++j) {
            const double angle =
                std::numbers::pi - std::acos(std::clamp(n[i].dot(n[j]), -1.0, 1.0));
            angles[k++] = angle * 180.0 / std::numbers::pi;
        }
    return true;
}

}  // namespace

double tet_min_dihedral_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                            const Eigen::Vector3d& c, const Eigen::Vector3d& d) {
    double angles[6];
    if (!dihedral_angles_deg(a, b, c, d, angles)) return 0.0;
    return *std::min_element(std::begin(angles), std::end(angles));
}

double TetFigures::min_dihedral_deg() const {
    return *std::min_element(std::begin(dihedral_deg), std::end(dihedral_deg));
}

double TetFigures::max_dihedral_deg() const {
    return *std::max_element(std::begin(dihedral_deg), std::end(dihedral_deg));
}

TetFigures tet_figures(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                       const Eigen::Vector3d& d) {
    TetFigures f;
    double angles[6];
    if (!dihedral_angles_deg(a, b, c, d, angles)) return f;
    f.skewness = tet_skewness(a, b, c, d);
    for (int k = 0; k < 6; ++k) f.dihedral_deg[k] = static_cast<float>(angles[k]);
    return f;
}

}  // namespace frontmesh::core
