// When a front step fails: closing of small front loops, local remeshing (paper §3.2), and
// the geometry of a stall handed to the diagnostics sink.

#include "surface/front_mesher.h"

#include <initializer_list>
#include <utility>

#include "pipeline/core/error.h"
#include "pipeline/core/quality.h"

namespace frontmesh::surface::front_detail {

// Closing of small fronts: when edge e lies on a simple closed front loop of at most
// kMaxClosingLoop edges, the loop is triangulated at once by the triangulation of the polygon
// that maximises the smallest angle (dynamic programming over its diagonals). Each triangle
// must agree with the background normals at its corners and a diagonal must not be a mesh
// edge already. The smoothing after the front mends the angles.
bool FrontMesher::close_small_loop(std::int32_t e, double min_angle_deg) {
    constexpr int kMaxClosingLoop = 24;
    std::vector<std::int32_t> loop = {edges_[static_cast<std::size_t>(e)].a};
    std::int32_t cur = e;
    while (true) {
        const std::int32_t b = edges_[static_cast<std::size_t>(cur)].b;
        if (b == loop.front()) break;
        if (static_cast<int>(loop.size()) >= kMaxClosingLoop) return false;
        // b must have exactly one outgoing front edge and not repeat.
        const std::int32_t out = head_out_[static_cast<std::size_t>(b)];
        if (out < 0 || edges_[static_cast<std::size_t>(out)].next_out >= 0) return false;
        if (std::find(loop.begin(), loop.end(), b) != loop.end()) return false;
        loop.push_back(b);
        cur = out;
    }
    const int m = static_cast<int>(loop.size());
    if (m < 3) return false;
    if (head_in_[static_cast<std::size_t>(loop.front())] < 0 ||
        edges_[static_cast<std::size_t>(head_in_[static_cast<std::size_t>(loop.front())])]
                .next_in >= 0)
        return false;
    Eigen::Vector3d n_avg = Eigen::Vector3d::Zero();
    for (const std::int32_t v : loop) n_avg += normal_[static_cast<std::size_t>(v)];
    if (n_avg.norm() < 1e-9) return false;
    n_avg.normalize();
    auto X = [&](int i) -> const Eigen::Vector3d& {
        return xyz_[static_cast<std::size_t>(loop[std::size_t(i)])];
    };
    auto diagonal_ok = [&](int i, int j) {
        if (j == i + 1 || (i == 0 && j == m - 1)) return true;  // a loop edge
        const std::int32_t x = loop[std::size_t(i)], y = loop[std::size_t(j)];
        return !has_mesh_edge(x, y) && !has_mesh_edge(y, x);
    };
    auto quality = [&](int i, int j, int k) {
        const Eigen::Vector3d t = (X(j) - X(i)).cross(X(k) - X(i));
        const double tl = t.norm();
        if (!(tl > 0.0) || t.dot(n_avg) <= 0.1 * tl) return -1.0;
        for (const int c : {i, j, k})
            if (t.dot(normal_[static_cast<std::size_t>(loop[std::size_t(c)])]) <= -0.2 * tl)
                return -1.0;
        return core::triangle_min_angle_deg(X(i), X(j), X(k));
    };
    // best[i][j]: the largest smallest angle of a triangulation of the chain i..j (j > i + 1).
    std::vector<double> best(std::size_t(m * m), 180.0);
    std::vector<int> split(std::size_t(m * m), -1);
    for (int len = 2; len < m; ++len)
        for (int i = 0; i + len < m; ++i) {
            const int j = i + len;
            double& b = best[std::size_t(i * m + j)];
            b = -1.0;
            if (!diagonal_ok(i, j)) continue;
            for (int k = i + 1; k < j; ++k) {
                const double q =
                    std::min({quality(i, k, j), k > i + 1 ? best[std::size_t(i * m + k)] : 180.0,
                              j > k + 1 ? best[std::size_t(k * m + j)] : 180.0});
                if (q > b) {
                    b = q;
                    split[std::size_t(i * m + j)] = k;
                }
            }
        }
    if (!(best[std::size_t(m - 1)] >= min_angle_deg) || best[std::size_t(m - 1)] <= 0.0)
        return false;
    std::vector<std::pair<int, int>> todo = {{0, m - 1}};
    std::vector<std::array<std::int32_t, 3>> made;
    while (!todo.empty()) {
        const auto [i, j] = todo.back();
        todo.pop_back();
        if (j < i + 2) continue;
        const int k = split[std::size_t(i * m + j)];
        made.push_back({loop[std::size_t(i)], loop[std::size_t(k)], loop[std::size_t(j)]});
        todo.push_back({i, k});
        todo.push_back({k, j});
    }
    for (const auto& t : made) {
        const Eigen::Vector3d& x0 = xyz_[static_cast<std::size_t>(t[0])];
        const Eigen::Vector3d& x1 = xyz_[static_cast<std::size_t>(t[1])];
        const Eigen::Vector3d& x2 = xyz_[static_cast<std::size_t>(t[2])];
        if (!covers_background(x0, x1, x2, face_[static_cast<std::size_t>(t[0])]) ||
            crosses_mesh(t[0], t[1], t[2], x2))
            return false;
    }
    for (const auto& t : made) add_triangle(t[0], t[1], t[2]);
    ++closed_loops_;
    return true;
}

// §3.2: remove the triangles around the ends of a stuck edge, the region growing with the
// number of earlier remeshings there, and re-open the front.
bool FrontMesher::local_remesh(std::int32_t e) {
    const std::int32_t a = edges_[static_cast<std::size_t>(e)].a,
                       b = edges_[static_cast<std::size_t>(e)].b;
    // The level counts earlier remeshings near here (new points do not remember them).
    const Eigen::Vector3d centre =
        0.5 * (xyz_[static_cast<std::size_t>(a)] + xyz_[static_cast<std::size_t>(b)]);
    const int near = remeshings_near(e);
    const int level = std::min(1 + near / 2, 8);
    if (near >= params_.max_local_remesh) {
        const std::string why = "remesh: the front cannot be closed near " + where(centre) +
                                " after " + std::to_string(near) + " local remeshings there";
        const double length =
            (xyz_[static_cast<std::size_t>(b)] - xyz_[static_cast<std::size_t>(a)]).norm();
        abandon(centre, std::max(20.0 * length, 8.0), why);
        return true;  // the edge is not queued again
    }
    remesh_sites_.insert(static_cast<std::int32_t>(remeshings_), centre);
    std::vector<std::int32_t> ring = {a, b}, triangles;
    for (int k = 0; k < level; ++k) {
        triangles.clear();
        for (const std::int32_t p : ring)
            for (std::int32_t s = tri_head_[static_cast<std::size_t>(p)]; s >= 0;
                 s = tri_next_[static_cast<std::size_t>(s)])
                triangles.push_back(s / 3);
        std::sort(triangles.begin(), triangles.end());
        triangles.erase(std::unique(triangles.begin(), triangles.end()), triangles.end());
        for (const std::int32_t t : triangles)
            for (const std::int32_t p : tris_[static_cast<std::size_t>(t)]) ring.push_back(p);
        std::sort(ring.begin(), ring.end());
        ring.erase(std::unique(ring.begin(), ring.end()), ring.end());
    }
    if (triangles.empty() || static_cast<std::int64_t>(triangles.size()) >= live_triangles_) {
        remesh_sites_.remove(static_cast<std::int32_t>(remeshings_));
        return false;  // nothing to remove around the edge
    }
    for (const std::int32_t t : triangles) remove_triangle(t);
    // A stuck loop edge survives the removal: give it a fresh start.
    if (edges_[static_cast<std::size_t>(e)].alive) {
        edges_[static_cast<std::size_t>(e)].fails = 0;
        queue_.push(
            {0, (xyz_[static_cast<std::size_t>(b)] - xyz_[static_cast<std::size_t>(a)]).norm(), e});
    }
    ++remeshings_;
    return true;
}

void FrontMesher::abandon(const Eigen::Vector3d& place, double radius, const std::string& why) {
    if (abandoned_.empty()) first_abandoned_why_ = why;
    constexpr std::size_t kDiagnosedPlaces = 4;
    if (abandoned_.size() < kDiagnosedPlaces) hand_over_stall(place, radius, why);
    abandoned_.push_back(place);
    abandoned_radius_.push_back(2.0 * size_(place, patch_.project(place).face));
    // Each place costs up to max_local_remesh remeshings around it; past kMaxAbandoned the
    // attempt ends at once with the places found (the stage cuts them out and the next round
    // finds the others).
    constexpr std::size_t kMaxAbandoned = 64;
    if (abandoned_.size() >= kMaxAbandoned) {
        std::vector<Eigen::Vector3d> earlier(abandoned_.begin(), abandoned_.end() - 1);
        FrontStall stall(first_abandoned_why_ + " (and " + std::to_string(earlier.size()) +
                             " more place(s) in this patch, the most one attempt gives up)",
                         place, __FILE__, __LINE__, __func__);
        stall.add_earlier_places(earlier);
        throw stall;
    }
}

// Hands the geometry around a stall to the diagnostics sink (STYLE §4: the stage hands the
// offending front over before the failure becomes an exception): live triangles, front edges
// and background faces with a vertex within `radius` of `centre`; cell data `kind`: 0
// triangle, 1 front edge, 2 background face. Built only when someone receives it.
void FrontMesher::hand_over_stall(const Eigen::Vector3d& centre, double radius,
                                  const std::string& why) const {
    if (!ctx_.wants_diagnostics()) return;
    core::Diagnostic d;
    std::ostringstream name;
    name << "remesh-front-stall-attempt" << attempt_ << "-at_" << std::lround(centre.x()) << "_"
         << std::lround(centre.y()) << "_" << std::lround(centre.z());
    d.name = name.str();
    d.what = why + "; kind: 0 triangle made, 1 front edge, 2 background face (within " +
             std::to_string(radius) + " mm)";
    auto near = [&](const Eigen::Vector3d& p) { return (p - centre).norm() <= radius; };
    auto add_cell = [&d](std::initializer_list<Eigen::Vector3d> points, std::int32_t kind) {
        std::vector<std::int32_t> ids;
        for (const Eigen::Vector3d& p : points) ids.push_back(d.add_point(p.x(), p.y(), p.z()));
        d.add_cell(std::move(ids), kind);
    };
    for (std::size_t t = 0; t < tris_.size(); ++t) {
        if (!tri_alive_[t]) continue;
        const auto& v = tris_[t];
        if (!near(xyz_[std::size_t(v[0])])) continue;
        add_cell({xyz_[std::size_t(v[0])], xyz_[std::size_t(v[1])], xyz_[std::size_t(v[2])]}, 0);
    }
    for (const FrontEdge& fe : edges_) {
        if (!fe.alive || !near(xyz_[std::size_t(fe.a)])) continue;
        add_cell({xyz_[std::size_t(fe.a)], xyz_[std::size_t(fe.b)]}, 1);
    }
    const core::SurfaceNetwork& bg = patch_.background();
    for (const std::int32_t f : patch_.faces()) {
        const auto& v = bg.faces[std::size_t(f)];
        if (!near(bg.point(v[0]))) continue;
        add_cell({bg.point(v[0]), bg.point(v[1]), bg.point(v[2])}, 2);
    }
    ctx_.diagnose(std::move(d));
}

}  // namespace frontmesh::surface::front_detail
