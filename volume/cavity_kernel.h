#pragma once
// The kernel of a cavity (beyond the paper): the points that see every face of a closed
// triangulated cavity from its inner side. A cavity with a non-empty kernel is filled exactly
// by the cone of tets from one such point over its faces; the tetra stage's completion path
// (volume/tetra_region.cpp) uses it for what the layered front and the closing rounds leave.

#include <vector>

#include <Eigen/Core>

namespace frontmesh::volume {

/// One face plane of a cavity: n . x >= b on the cavity's side, n a unit normal into it.
struct CavityPlane {
    Eigen::Vector3d n;
    double b = 0.0;
};

/// The Chebyshev centre of the kernel: the point p maximising t = min_i (n_i . p - b_i).
struct KernelCentre {
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    double t = 0.0;       // the margin; > 0 when p is inside the kernel (in doubles)
    bool solved = false;  // false when the solver ran out of iterations
};

/// The Chebyshev centre of the kernel of the half-spaces `planes`, limited to the ball of
/// radius `radius` around `centre` (a bounding tetrahedron of it, so the optimum exists).
/// A linear programme in (p, t), solved by the simplex method on its dual (four equality
/// rows), with Bland's rule so that it ends. Doubles only: callers decide exactly.
KernelCentre kernel_centre(const std::vector<CavityPlane>& planes, const Eigen::Vector3d& centre,
                           double radius);

}  // namespace frontmesh::volume
