// Repair step 3: orient every face outward from its region_in.

#include "surface/repair_internal.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace frontmesh::surface::repair_detail {
namespace {

/// Generalised winding number of a piece (oriented by the tentative flips) around x:
/// the sum of the signed solid angles of its triangles over 4 pi (Van Oosterom-Strackee).
double winding_number(const SurfaceNetwork& net, const Shells& sh, std::size_t piece,
                      const Eigen::Vector3d& x) {
    double omega = 0.0;
    for (auto k = static_cast<std::size_t>(sh.piece_start[piece]);
         k < static_cast<std::size_t>(sh.piece_start[piece + 1]); ++k) {
        const std::int32_t side = sh.piece_sides[k];
        const Tri& t = net.faces[static_cast<std::size_t>(side) / 2];
        const Eigen::Vector3d a = net.point(t[0]) - x;
        Eigen::Vector3d b = net.point(t[1]) - x, c = net.point(t[2]) - x;
        if (sh.sign(side) < 0) std::swap(b, c);
        const double la = a.norm(), lb = b.norm(), lc = c.norm();
        const double num = a.dot(b.cross(c));
        const double den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
        omega += 2.0 * std::atan2(num, den);
    }
    return omega / (4.0 * std::numbers::pi);
}

/// Whether the closed piece encloses x, by the parity of its faces crossed by a ray from x.
/// Exact (orient3d); a ray that touches an edge or a vertex is cast again in another
/// direction. Nullopt when every direction tried touches one. Cost: a few ns per face.
std::optional<bool> ray_parity_encloses(const SurfaceNetwork& net, const Shells& sh,
                                        std::size_t piece, const Eigen::Vector3d& x) {
    const Piece& q = sh.pieces[piece];
    static constexpr double k_slopes[][2] = {{0.0123456789, 0.0234567891},
                                             {-0.0345678912, 0.0156789123},
                                             {0.0267891234, -0.0378912345},
                                             {-0.0189123456, -0.0291234567}};
    for (const auto& slope : k_slopes) {
        const double length = (q.hi.x() - x.x()) + 1.0 + (q.hi - q.lo).norm();
        const Eigen::Vector3d far = x + length * Eigen::Vector3d(1.0, slope[0], slope[1]);
        const Eigen::Vector3d lo = x.cwiseMin(far), hi = x.cwiseMax(far);
        std::size_t crossings = 0;
        bool touched = false;
        for (auto k = static_cast<std::size_t>(sh.piece_start[piece]);
             k < static_cast<std::size_t>(sh.piece_start[piece + 1]) && !touched; ++k) {
            const Tri& t = net.faces[static_cast<std::size_t>(sh.piece_sides[k]) / 2];
            const auto a = net.point(t[0]), b = net.point(t[1]), c = net.point(t[2]);
            bool outside = false;
            for (int d = 0; d < 3 && !outside; ++d)
                outside =
                    std::max({a[d], b[d], c[d]}) < lo[d] || std::min({a[d], b[d], c[d]}) > hi[d];
            if (outside) continue;
            const int sx = core::orient3d(a.data(), b.data(), c.data(), x.data());
            const int sf = core::orient3d(a.data(), b.data(), c.data(), far.data());
            if (sx * sf > 0) continue;  // both ends on one side of the face's plane
            const int s1 = core::orient3d(x.data(), far.data(), a.data(), b.data());
            const int s2 = core::orient3d(x.data(), far.data(), b.data(), c.data());
            const int s3 = core::orient3d(x.data(), far.data(), c.data(), a.data());
            const bool all_pos = s1 >= 0 && s2 >= 0 && s3 >= 0;
            const bool all_neg = s1 <= 0 && s2 <= 0 && s3 <= 0;
            if (!all_pos && !all_neg) continue;  // the line misses the triangle
            if (sx == 0 || sf == 0 || s1 == 0 || s2 == 0 || s3 == 0)
                touched = true;
            else
                ++crossings;
        }
        if (!touched) return crossings % 2 == 1;
    }
    return std::nullopt;
}

/// Orients every face outward from its region_in. Rule: within an orientation class (faces

}  // namespace

/// tied by edge agreement within any region; an interface face ties its two regions'
/// pieces together) one flip bit per face is fixed by the constraints; the class's overall
/// sense is chosen by its pieces. A piece of region R enclosed by an even number of R's
/// other pieces is an outer shell of R and must enclose positive volume seen from R; by an
/// odd number it bounds a cavity of R (an inner shell, e.g. a hollow region's inside wall
/// labelled R|0) and must enclose negative volume. Each piece votes with its |volume|.
/// Labels are never changed; faces are flipped (vertex order reversed).
void orient(SurfaceNetwork& net, Topology& topo, const Shells& sh, core::StageContext& ctx) {
    const std::size_t np = sh.pieces.size();
    std::vector<std::vector<std::size_t>> by_region;  // piece ids grouped by region, in order
    {
        std::vector<std::size_t> order(np);
        std::iota(order.begin(), order.end(), 0);
        std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
            return sh.pieces[a].region < sh.pieces[b].region;
        });
        for (std::size_t k = 0; k < np; ++k) {
            if (k == 0 || sh.pieces[order[k]].region != sh.pieces[order[k - 1]].region)
                by_region.emplace_back();
            by_region.back().push_back(order[k]);
        }
    }
    std::vector<int> wanted(np, 1);  // +1 outer shell, -1 inner shell
    for (const auto& group : by_region) {
        if (group.size() < 2) continue;
        for (std::size_t p : group) {
            const Piece& a = sh.pieces[p];
            const Tri& t = net.faces[static_cast<std::size_t>(a.largest_face)];
            const Eigen::Vector3d x = (net.point(t[0]) + net.point(t[1]) + net.point(t[2])) / 3.0;
            int enclosing = 0;
            for (std::size_t q : group) {
                const Piece& b = sh.pieces[q];
                if (q == p || (b.lo.array() > a.lo.array()).any() ||
                    (b.hi.array() < a.hi.array()).any())
                    continue;
                // Ray parity is exact for closed pieces; the winding number tolerates the
                // holes of open ones (filled later) and pieces ending at non-manifold edges.
                std::optional<bool> inside;
                if (!b.is_open) inside = ray_parity_encloses(net, sh, q, x);
                if (!inside) inside = std::abs(winding_number(net, sh, q, x)) > 0.5;
                if (*inside) ++enclosing;
            }
            wanted[p] = enclosing % 2 == 0 ? 1 : -1;
        }
    }
    std::vector<double> score(net.face_count(), 0.0);  // per class root
    for (std::size_t p = 0; p < np; ++p) {
        const std::int32_t side = sh.piece_sides[static_cast<std::size_t>(sh.piece_start[p])];
        score[static_cast<std::size_t>(sh.cls[static_cast<std::size_t>(side) / 2])] +=
            wanted[p] * sh.pieces[p].volume;
    }
    std::size_t flipped = 0;
    for (std::size_t f = 0; f < net.face_count(); ++f) {
        const bool class_flip = score[static_cast<std::size_t>(sh.cls[f])] < 0.0;
        if ((sh.flip[f] != 0) != class_flip) {
            reverse_face(net.faces[f]);
            topo.reverse(f);
            ++flipped;
        }
    }
    std::size_t disagreeing = 0;
    for (std::size_t p = 0; p < np; ++p) {
        const std::int32_t side = sh.piece_sides[static_cast<std::size_t>(sh.piece_start[p])];
        const bool class_flip =
            score[static_cast<std::size_t>(sh.cls[static_cast<std::size_t>(side) / 2])] < 0.0;
        if (wanted[p] * sh.pieces[p].volume * (class_flip ? -1.0 : 1.0) < 0.0) ++disagreeing;
    }
    ctx.count("repair.flipped_faces", static_cast<double>(flipped));
    ctx.count("repair.orientation_conflicts", static_cast<double>(sh.conflicts + disagreeing));
    ctx.info("repair: flipped " + std::to_string(flipped) + " faces to face outward (" +
             std::to_string(np) + " pieces)");
    if (sh.conflicts > 0)
        ctx.warn("repair: " + std::to_string(sh.conflicts) +
                 " edges where a region's faces cannot agree in orientation (non-orientable)");
    if (disagreeing > 0)
        ctx.warn("repair: " + std::to_string(disagreeing) +
                 " boundary pieces whose labels disagree with their nesting; oriented by the "
                 "majority of their orientation class");
}

}  // namespace frontmesh::surface::repair_detail
