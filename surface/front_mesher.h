#pragma once
// The advancing-front mesher of one patch (paper §2), shared by its source files:
//   front_triangulate.cpp  the driver: initial front or seed, the step loop, smoothing inside
//                          the patch, compaction, and triangulate_patch's attempts
//   front_step.cpp         one step: Eqs. 8, 10-12 analogues, candidates and validity tests
//                          (the 2-D analogue of §3.1.4 plus an exact 3-D crossing test)
//   front_stall.cpp        when a step fails: closing small loops, local remeshing (§3.2),
//                          and the stall handed to the diagnostics sink
//
// The front is a set of directed edges with the unmeshed part of the patch on their left
// (seen from the patch normal). Step: take the shortest front edge (a, b); place the ideal
// apex at the target size over it in the tangent plane (Eq. 10 analogue) and project it onto
// the background; rank existing front points near it by Eq. 12 (new point last); accept the
// first candidate passing the validity tests, done in the tangent plane at the edge midpoint
// with exact orient2d on the projected coordinates. An edge failing twice triggers local
// remeshing (§3.2): the triangles around its ends are removed and the front re-opened.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <queue>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <Eigen/Core>

#include "pipeline/core/adt.h"
#include "pipeline/core/predicates.h"
#include "pipeline/core/stage_context.h"
#include "surface/front_triangulate.h"

namespace frontmesh::surface::front_detail {

inline constexpr double pi = 3.14159265358979323846;
inline constexpr double two_pi = 2.0 * pi;

inline std::string where(const Eigen::Vector3d& p) {
    std::ostringstream s;
    s.precision(6);
    s << "(" << p.x() << ", " << p.y() << ", " << p.z() << ")";
    return s.str();
}

// A point of the tangent-plane frame, laid out for core::orient2d (coordinates 0 and 1).
struct P2 {
    double c[3] = {0.0, 0.0, 0.0};
    double x() const { return c[0]; }
    double y() const { return c[1]; }
};

inline int orient(const P2& a, const P2& b, const P2& c) {
    return core::orient2d(a.c, b.c, c.c, 0, 1);
}

inline double angle_of(const P2& from, const P2& to) {
    return std::atan2(to.y() - from.y(), to.x() - from.x());
}

// Counter-clockwise turn from direction angle `from` to `to`, in [0, 2 pi).
inline double ccw(double from, double to) {
    double d = to - from;
    while (d < 0.0) d += two_pi;
    while (d >= two_pi) d -= two_pi;
    return d;
}

// True when point r lies on the closed segment [p, q], given orient(p, q, r) == 0.
inline bool on_segment(const P2& p, const P2& q, const P2& r) {
    return std::min(p.x(), q.x()) <= r.x() && r.x() <= std::max(p.x(), q.x()) &&
           std::min(p.y(), q.y()) <= r.y() && r.y() <= std::max(p.y(), q.y());
}

// Squared distance from r to segment [p, q] in the plane.
inline double segment_distance2(const P2& p, const P2& q, const P2& r) {
    const double dx = q.x() - p.x(), dy = q.y() - p.y();
    const double l2 = dx * dx + dy * dy;
    double t = l2 > 0.0 ? ((r.x() - p.x()) * dx + (r.y() - p.y()) * dy) / l2 : 0.0;
    t = std::clamp(t, 0.0, 1.0);
    const double ex = p.x() + t * dx - r.x(), ey = p.y() + t * dy - r.y();
    return ex * ex + ey * ey;
}

struct FrontEdge {
    std::int32_t a = -1, b = -1;
    std::int32_t next_out = -1, next_in = -1;  // intrusive lists of a's out- and b's in-edges
    std::int32_t fails = 0;
    std::int32_t stalls = 0;  // times it was put back with nothing to remesh around it
    bool alive = false;
};

struct QueueEntry {
    std::int32_t fails;
    double length;
    std::int32_t edge;
};
struct Later {
    bool operator()(const QueueEntry& x, const QueueEntry& y) const {
        return std::tie(x.fails, x.length, x.edge) > std::tie(y.fails, y.length, y.edge);
    }
};

struct Candidate {
    double score;
    std::int32_t point;   // existing front point
    bool across = false;  // turned away from the edge (ridge or fold): tested in its own frame
};

class FrontMesher {
public:
    FrontMesher(const BackgroundPatch& patch, const SizeFunction& size, const FrontParams& params,
                core::StageContext& ctx, int attempt = 0)
        : patch_(patch),
          size_(size),
          params_(params),
          ctx_(ctx),
          attempt_(attempt),
          front_points_(domain_of(patch), core::AdtItems::points),
          triangle_boxes_(domain_of(patch), core::AdtItems::boxes),
          remesh_sites_(domain_of(patch), core::AdtItems::points) {}

    PatchMesh run(const std::vector<PatchLoop>& loops);

private:
    static core::AdtBox domain_of(const BackgroundPatch& patch) {
        core::AdtBox box;
        const core::SurfaceNetwork& bg = patch.background();
        for (const std::int32_t f : patch.faces())
            for (const std::int32_t v : bg.faces[static_cast<std::size_t>(f)])
                box.extend(bg.point(v));
        return box.enlarged(1e-3 * std::max(1.0, (box.hi - box.lo).norm()));
    }

    // --- points ---------------------------------------------------------------------------
    std::int32_t add_point(const Eigen::Vector3d& p, std::int32_t face, bool fixed) {
        const auto id = static_cast<std::int32_t>(xyz_.size());
        xyz_.push_back(p);
        face_.push_back(face);
        normal_.push_back(patch_.smooth_normal(face));
        fixed_.push_back(fixed ? 1 : 0);
        alive_.push_back(1);
        head_out_.push_back(-1);
        head_in_.push_back(-1);
        tri_head_.push_back(-1);
        return id;
    }
    bool on_front(std::int32_t p) const {
        return head_out_[static_cast<std::size_t>(p)] >= 0 ||
               head_in_[static_cast<std::size_t>(p)] >= 0;
    }
    // Keeps the ADT of front points and the liveness of free points in step with the front.
    void sync_point(std::int32_t p) {
        const bool front = on_front(p);
        const bool in_tree = front_points_.contains(p);
        if (front && !in_tree) front_points_.insert(p, xyz_[static_cast<std::size_t>(p)]);
        if (!front && in_tree) front_points_.remove(p);
        if (!front && !fixed_[static_cast<std::size_t>(p)] &&
            tri_head_[static_cast<std::size_t>(p)] < 0)
            alive_[static_cast<std::size_t>(p)] = 0;
    }

    // --- front edges ----------------------------------------------------------------------
    std::int32_t find_edge(std::int32_t a, std::int32_t b) const {
        for (std::int32_t e = head_out_[static_cast<std::size_t>(a)]; e >= 0;
             e = edges_[static_cast<std::size_t>(e)].next_out)
            if (edges_[static_cast<std::size_t>(e)].b == b) return e;
        return -1;
    }
    void add_edge(std::int32_t a, std::int32_t b) {
        const auto e = static_cast<std::int32_t>(edges_.size());
        FrontEdge fe;
        fe.a = a;
        fe.b = b;
        fe.next_out = head_out_[static_cast<std::size_t>(a)];
        fe.next_in = head_in_[static_cast<std::size_t>(b)];
        fe.alive = true;
        edges_.push_back(fe);
        head_out_[static_cast<std::size_t>(a)] = e;
        head_in_[static_cast<std::size_t>(b)] = e;
        const double len =
            (xyz_[static_cast<std::size_t>(b)] - xyz_[static_cast<std::size_t>(a)]).norm();
        max_front_length_ = std::max(max_front_length_, len);
        queue_.push({0, len, e});
        ++front_size_;
    }
    void remove_edge(std::int32_t e) {
        FrontEdge& fe = edges_[static_cast<std::size_t>(e)];
        for (std::int32_t* link = &head_out_[static_cast<std::size_t>(fe.a)]; *link >= 0;
             link = &edges_[static_cast<std::size_t>(*link)].next_out)
            if (*link == e) {
                *link = fe.next_out;
                break;
            }
        for (std::int32_t* link = &head_in_[static_cast<std::size_t>(fe.b)]; *link >= 0;
             link = &edges_[static_cast<std::size_t>(*link)].next_in)
            if (*link == e) {
                *link = fe.next_in;
                break;
            }
        fe.alive = false;
        --front_size_;
    }

    // --- triangles ------------------------------------------------------------------------
    bool has_mesh_edge(std::int32_t x, std::int32_t y) const {  // directed x -> y in a triangle
        for (std::int32_t s = tri_head_[static_cast<std::size_t>(x)]; s >= 0;
             s = tri_next_[static_cast<std::size_t>(s)]) {
            const auto& t = tris_[static_cast<std::size_t>(s / 3)];
            if (t[static_cast<std::size_t>((s % 3 + 1) % 3)] == y) return true;
        }
        return false;
    }
    // Adds triangle (a, b, c) and updates the front: a triangle edge x -> y closes the front
    // edge (x, y) when present (the unmeshed side was where the triangle goes), else opens
    // the front edge (y, x).
    void add_triangle(std::int32_t a, std::int32_t b, std::int32_t c) {
        const auto t = static_cast<std::int32_t>(tris_.size());
        tris_.push_back({a, b, c});
        tri_alive_.push_back(1);
        const std::int32_t v[3] = {a, b, c};
        for (int k = 0; k < 3; ++k) {
            tri_next_.push_back(tri_head_[static_cast<std::size_t>(v[k])]);
            tri_head_[static_cast<std::size_t>(v[k])] = 3 * t + k;
        }
        for (int k = 0; k < 3; ++k) {
            const std::int32_t x = v[k], y = v[(k + 1) % 3];
            const std::int32_t e = find_edge(x, y);
            if (e >= 0)
                remove_edge(e);
            else
                add_edge(y, x);
        }
        ++live_triangles_;
        for (int k = 0; k < 3; ++k) sync_point(v[k]);
        core::AdtBox box = core::AdtBox::of_point(xyz_[static_cast<std::size_t>(a)]);
        box.extend(xyz_[static_cast<std::size_t>(b)]);
        box.extend(xyz_[static_cast<std::size_t>(c)]);
        triangle_boxes_.insert(t, box);
    }
    // Removes triangle t; the reverse of add_triangle.
    void remove_triangle(std::int32_t t) {
        const auto tri = tris_[static_cast<std::size_t>(t)];
        tri_alive_[static_cast<std::size_t>(t)] = 0;
        for (int k = 0; k < 3; ++k) {
            const std::int32_t slot = 3 * t + k;
            for (std::int32_t* link =
                     &tri_head_[static_cast<std::size_t>(tri[static_cast<std::size_t>(k)])];
                 *link >= 0; link = &tri_next_[static_cast<std::size_t>(*link)])
                if (*link == slot) {
                    *link = tri_next_[static_cast<std::size_t>(slot)];
                    break;
                }
        }
        for (int k = 0; k < 3; ++k) {
            const std::int32_t x = tri[static_cast<std::size_t>(k)],
                               y = tri[static_cast<std::size_t>((k + 1) % 3)];
            const std::int32_t e = find_edge(y, x);
            if (e >= 0)
                remove_edge(e);
            else
                add_edge(x, y);
        }
        --live_triangles_;
        for (int k = 0; k < 3; ++k) sync_point(tri[static_cast<std::size_t>(k)]);
        triangle_boxes_.remove(t);
    }

    // --- the step ---------------------------------------------------------------------------
    struct Frame {
        Eigen::Vector3d origin, u, v, n;
        P2 to2d(const Eigen::Vector3d& p) const {
            const Eigen::Vector3d d = p - origin;
            P2 r;
            r.c[0] = d.dot(u);
            r.c[1] = d.dot(v);
            return r;
        }
    };
    bool advance(std::int32_t e, int fails);
    bool is_valid(std::int32_t a, std::int32_t b, std::int32_t c, const Eigen::Vector3d& xc,
                  const Eigen::Vector3d& nc, const Frame& fr, double min_cos, double corner_cos);
    bool crosses_mesh(std::int32_t a, std::int32_t b, std::int32_t c, const Eigen::Vector3d& xc);
    // Whether the triangle (xa, xb, xc) lies over its own patch: the background under its
    // centroid (projected from `hint`) faces the triangle's way.
    bool covers_background(const Eigen::Vector3d& xa, const Eigen::Vector3d& xb,
                           const Eigen::Vector3d& xc, std::int32_t hint) const;
    bool sector_ok_at_a(std::int32_t a, std::int32_t b, std::int32_t c, const P2& pc,
                        const Frame& fr) const;
    bool sector_ok_at_b(std::int32_t a, std::int32_t b, std::int32_t c, const P2& pc,
                        const Frame& fr) const;
    bool sector_ok_at_c(std::int32_t a, std::int32_t b, std::int32_t c, const Frame& fr) const;
    void gather(const Eigen::Vector3d& center, double radius, const Frame& fr);
    bool local_remesh(std::int32_t e);
    bool close_small_loop(std::int32_t e, double min_angle_deg = 1.0);
    // Local remeshings recorded within two edge lengths of edge e.
    int remeshings_near(std::int32_t e) {
        const std::int32_t a = edges_[static_cast<std::size_t>(e)].a,
                           b = edges_[static_cast<std::size_t>(e)].b;
        const Eigen::Vector3d centre =
            0.5 * (xyz_[static_cast<std::size_t>(a)] + xyz_[static_cast<std::size_t>(b)]);
        remesh_sites_.query_sphere(
            centre,
            2.0 * (xyz_[static_cast<std::size_t>(b)] - xyz_[static_cast<std::size_t>(a)]).norm(),
            scratch_ids_);
        return static_cast<int>(scratch_ids_.size());
    }
    // Counts of the front for messages: triangles, front edges, local remeshings.
    std::string front_state() const {
        return std::to_string(live_triangles_) + " triangles, front of " +
               std::to_string(front_size_) + " edges, " + std::to_string(remeshings_) +
               " local remeshings";
    }
    static constexpr int kLastResortAfter = 8;
    // Hands the triangles, front edges and background faces within `radius` of `centre` to
    // the diagnostics sink (front_stall.cpp) before a FrontStall is thrown.
    void hand_over_stall(const Eigen::Vector3d& centre, double radius,
                         const std::string& why) const;
    void seed();
    void smooth();
    // The front cannot be closed at `place` (`why`): the place is recorded and the edge at
    // it left in the front, not queued again, so that the front goes on everywhere else and
    // one attempt finds the patch's such places, up to 64 (the remesh stage cuts them out of
    // the patch, surface/remesh_cuts.cpp). The diagnostics get the first four.
    void abandon(const Eigen::Vector3d& place, double radius, const std::string& why);
    // Every place abandoned, and the first reason: thrown as one FrontStall when the queue
    // runs dry with a front left.
    std::vector<Eigen::Vector3d> abandoned_;
    std::vector<double> abandoned_radius_;  // 2 h there: the zone whose edges wait
    std::string first_abandoned_why_;
    // Whether edge e has an end within the zone of an abandoned place: such an edge is not
    // advanced (it stays in the front), so that the front does not keep remeshing its way
    // around a place it has given up (each remeshing there would abandon a place 2 h further
    // on). Cost O(abandoned places).
    bool waits(std::int32_t e) const {
        const Eigen::Vector3d& a = xyz_[static_cast<std::size_t>(edges_[std::size_t(e)].a)];
        const Eigen::Vector3d& b = xyz_[static_cast<std::size_t>(edges_[std::size_t(e)].b)];
        for (std::size_t i = 0; i < abandoned_.size(); ++i)
            if ((a - abandoned_[i]).norm() <= abandoned_radius_[i] ||
                (b - abandoned_[i]).norm() <= abandoned_radius_[i])
                return true;
        return false;
    }

    const BackgroundPatch& patch_;
    const SizeFunction& size_;
    const FrontParams& params_;
    core::StageContext& ctx_;
    const int attempt_;  // 0 first; later attempts seed elsewhere

    std::vector<Eigen::Vector3d> xyz_, normal_;
    std::vector<std::int32_t> face_, head_out_, head_in_, tri_head_;
    std::vector<std::uint8_t> fixed_, alive_;
    std::vector<FrontEdge> edges_;
    std::vector<std::array<std::int32_t, 3>> tris_;
    std::vector<std::uint8_t> tri_alive_;
    std::vector<std::int32_t> tri_next_;
    std::priority_queue<QueueEntry, std::vector<QueueEntry>, Later> queue_;
    core::Adt front_points_;
    core::Adt triangle_boxes_;  // every live triangle, for the exact 3-D crossing test
    std::vector<std::int32_t> box_hits_;
    core::Adt remesh_sites_;  // where local remeshing happened: the region grows there
    double max_front_length_ = 0.0;
    std::int64_t front_size_ = 0, live_triangles_ = 0;
    std::int64_t remeshings_ = 0;
    std::int64_t closed_loops_ = 0;
    std::int64_t last_resort_ = 0;  // triangles made by the last-resort rules
    std::int64_t why_[11] = {};     // rejected candidates by test, for the counters
    // Smallest angle (radians) a new triangle may leave between itself and a front edge at
    // a shared point (the paper's 5-degree edge-face angle test, stricter on a first try).
    double min_gap_ = 0.0;

    // Scratch of one step: nearby front points (same sheet) and the front edges at them.
    std::vector<std::int32_t> near_points_, near_edges_, scratch_ids_;
    std::vector<std::int32_t> gathered_all_;  // every front point of the last gather()
    std::vector<std::int32_t> edge_stamp_;
    std::int32_t stamp_ = 0;
};

}  // namespace frontmesh::surface::front_detail
