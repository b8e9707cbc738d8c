#include "volume/cavity_kernel.h"

#include <array>
#include <cmath>
#include <cstddef>
#include <limits>

#include <Eigen/Dense>

namespace frontmesh::volume {

// The primal, in coordinates q = (p - centre) / radius:  max t  s.t.  n_i . q - t >= b'_i,
// b'_i = (b_i - n_i . centre) / radius. Its dual:  min sum_i (-b'_i) y_i  s.t.
// sum_i y_i (-n_i, 1) = (0, 0, 0, 1), y >= 0: four equality rows, so every basis is a 4 x 4
// matrix B and the simplex multipliers pi = B^-T c_B are the primal point (q, t) itself.
// Four planes of a regular tetrahedron around the unit ball, u_k . q >= -1 with sum u_k = 0,
// bound the primal and give the dual its first basis: y = 1/4 on each.
KernelCentre kernel_centre(const std::vector<CavityPlane>& planes, const Eigen::Vector3d& centre,
                           double radius) {
    using V4 = Eigen::Vector4d;
    const std::size_t m = planes.size(), n = m + 4;
    std::vector<V4> column(n);
    std::vector<double> cost(n);
    for (std::size_t j = 0; j < m; ++j) {
        const Eigen::Vector3d& nj = planes[j].n;
        column[j] = V4(-nj.x(), -nj.y(), -nj.z(), 1.0);
        cost[j] = -(planes[j].b - nj.dot(centre)) / radius;
    }
    const double s = 1.0 / std::sqrt(3.0);
    const double u[4][3] = {{s, s, s}, {s, -s, -s}, {-s, s, -s}, {-s, -s, s}};
    std::array<std::size_t, 4> basis{};
    for (std::size_t k = 0; k < 4; ++k) {
        column[m + k] = V4(-u[k][0], -u[k][1], -u[k][2], 1.0);
        cost[m + k] = 1.0;  // b' = -1
        basis[k] = m + k;
    }
    std::vector<char> in_basis(n, 0);
    for (std::size_t b : basis) in_basis[b] = 1;

    KernelCentre out;
    constexpr double kTol = 1e-12;
    // Bland's rule (the smallest improving index enters, ties of the ratio test leave by the
    // smallest index) never revisits a basis, so the method ends; the most improving column
    // enters instead after a pivot that moved the solution, which cannot start a cycle (every
    // pivot of a cycle is degenerate). The cap only guards rounding, which the exact tests of
    // the caller catch.
    const std::size_t max_pivots = 50 * n + 1000;
    bool degenerate = false;
    for (std::size_t pivot = 0; pivot <= max_pivots; ++pivot) {
        Eigen::Matrix4d B;
        V4 cb;
        for (int k = 0; k < 4; ++k) {
            B.col(k) = column[basis[k]];
            cb[k] = cost[basis[k]];
        }
        const Eigen::FullPivLU<Eigen::Matrix4d> lu(B);
        if (!lu.isInvertible()) return out;
        const Eigen::Matrix4d Binv = lu.inverse();
        const V4 xb = Binv.col(3);  // B^-1 (0, 0, 0, 1)
        const V4 pi = Binv.transpose() * cb;
        std::size_t enter = n;
        double best = -kTol;
        for (std::size_t j = 0; j < n; ++j) {
            if (in_basis[j]) continue;
            const double r = cost[j] - pi.dot(column[j]);
            if (r >= best) continue;
            enter = j;
            if (degenerate) break;  // Bland: the first improving index
            best = r;
        }
        if (enter == n) {  // optimal: pi is the primal point
            out.p = centre + radius * pi.head<3>();
            out.t = radius * pi[3];
            out.solved = true;
            return out;
        }
        const V4 d = Binv * column[enter];
        int leave = -1;
        double ratio = std::numeric_limits<double>::infinity();
        for (int k = 0; k < 4; ++k) {
            if (d[k] <= kTol) continue;
            const double r = std::max(xb[k], 0.0) / d[k];
            if (leave < 0 || r < ratio ||
                (r == ratio && basis[k] < basis[static_cast<std::size_t>(leave)])) {
                ratio = r;
                leave = k;
            }
        }
        if (leave < 0) return out;  // dual unbounded: impossible with the bounding planes
        degenerate = ratio <= kTol;
        in_basis[basis[static_cast<std::size_t>(leave)]] = 0;
        basis[static_cast<std::size_t>(leave)] = enter;
        in_basis[enter] = 1;
    }
    return out;
}

}  // namespace frontmesh::volume
