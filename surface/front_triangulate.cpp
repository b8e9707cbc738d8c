// Direct advancing-front triangulation of one patch over the discrete background surface
// (paper §2; Löhner-style front in 3-D with the 2-D analogue of the §3.1.4 tests).
//
// The front is a set of directed edges with the unmeshed part of the patch on their left
// (seen from the patch normal). Step: take the shortest front edge (a, b); place the ideal
// apex at the target size over it in the tangent plane (Eq. 10 analogue) and project it onto
// the background; rank existing front points near it by Eq. 12 (new point last); accept the
// first candidate passing the validity tests, done in the tangent plane at the edge midpoint
// with exact orient2d on the projected coordinates. An edge failing twice triggers local
// remeshing (§3.2): the triangles around its ends are removed and the front re-opened.

#include "surface/front_triangulate.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <queue>
#include <sstream>
#include <string>
#include <tuple>
#include <utility>

#include "pipeline/core/adt.h"
#include "pipeline/core/error.h"
#include "pipeline/core/predicates.h"
#include "pipeline/core/quality.h"

namespace frontmesh::surface {

namespace {

constexpr double pi = 3.14159265358979323846;
constexpr double two_pi = 2.0 * pi;

std::string where(const Eigen::Vector3d& p) {
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

int orient(const P2& a, const P2& b, const P2& c) { return core::orient2d(a.c, b.c, c.c, 0, 1); }

double angle_of(const P2& from, const P2& to) { return std::atan2(to.y() - from.y(), to.x() - from.x()); }

// Counter-clockwise turn from direction angle `from` to `to`, in [0, 2 pi).
double ccw(double from, double to) {
    double d = to - from;
    while (d < 0.0) d += two_pi;
    while (d >= two_pi) d -= two_pi;
    return d;
}

// True when point r lies on the closed segment [p, q], given orient(p, q, r) == 0.
bool on_segment(const P2& p, const P2& q, const P2& r) {
    return std::min(p.x(), q.x()) <= r.x() && r.x() <= std::max(p.x(), q.x()) &&
           std::min(p.y(), q.y()) <= r.y() && r.y() <= std::max(p.y(), q.y());
}

// Squared distance from r to segment [p, q] in the plane.
double segment_distance2(const P2& p, const P2& q, const P2& r) {
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
        : patch_(patch), size_(size), params_(params), ctx_(ctx), attempt_(attempt),
          front_points_(domain_of(patch), core::AdtItems::points),
          triangle_boxes_(domain_of(patch), core::AdtItems::boxes),
          remesh_sites_(domain_of(patch), core::AdtItems::points) {}

    PatchMesh run(const std::vector<PatchLoop>& loops);

private:
    static core::AdtBox domain_of(const BackgroundPatch& patch) {
        core::AdtBox box;
        const core::SurfaceNetwork& bg = patch.background();
        for (const std::int32_t f : patch.faces())
            for (const std::int32_t v : bg.faces[static_cast<std::size_t>(f)]) box.extend(bg.point(v));
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
        return head_out_[static_cast<std::size_t>(p)] >= 0 || head_in_[static_cast<std::size_t>(p)] >= 0;
    }
    // Keeps the ADT of front points and the liveness of free points in step with the front.
    void sync_point(std::int32_t p) {
        const bool front = on_front(p);
        const bool in_tree = front_points_.contains(p);
        if (front && !in_tree) front_points_.insert(p, xyz_[static_cast<std::size_t>(p)]);
        if (!front && in_tree) front_points_.remove(p);
        if (!front && !fixed_[static_cast<std::size_t>(p)] && tri_head_[static_cast<std::size_t>(p)] < 0)
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
        const double len = (xyz_[static_cast<std::size_t>(b)] - xyz_[static_cast<std::size_t>(a)]).norm();
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
            for (std::int32_t* link = &tri_head_[static_cast<std::size_t>(tri[static_cast<std::size_t>(k)])];
                 *link >= 0; link = &tri_next_[static_cast<std::size_t>(*link)])
                if (*link == slot) {
                    *link = tri_next_[static_cast<std::size_t>(slot)];
                    break;
                }
        }
        for (int k = 0; k < 3; ++k) {
            const std::int32_t x = tri[static_cast<std::size_t>(k)], y = tri[static_cast<std::size_t>((k + 1) % 3)];
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
    bool sector_ok_at_a(std::int32_t a, std::int32_t b, std::int32_t c, const P2& pc, const Frame& fr) const;
    bool sector_ok_at_b(std::int32_t a, std::int32_t b, std::int32_t c, const P2& pc, const Frame& fr) const;
    bool sector_ok_at_c(std::int32_t a, std::int32_t b, std::int32_t c, const Frame& fr) const;
    void gather(const Eigen::Vector3d& center, double radius, const Frame& fr);
    bool local_remesh(std::int32_t e);
    bool close_small_loop(std::int32_t e, double min_angle_deg = 1.0);
    // Local remeshings recorded within two edge lengths of edge e.
    int remeshings_near(std::int32_t e) {
        const std::int32_t a = edges_[static_cast<std::size_t>(e)].a, b = edges_[static_cast<std::size_t>(e)].b;
        const Eigen::Vector3d centre = 0.5 * (xyz_[static_cast<std::size_t>(a)] + xyz_[static_cast<std::size_t>(b)]);
        remesh_sites_.query_sphere(centre, 2.0 * (xyz_[static_cast<std::size_t>(b)] - xyz_[static_cast<std::size_t>(a)]).norm(),
                                   scratch_ids_);
        return static_cast<int>(scratch_ids_.size());
    }
    static constexpr int kLastResortAfter = 8;
    void dump_near(const Eigen::Vector3d& centre, double radius) const;
    void seed();
    void smooth();

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
    std::int64_t why_[11] = {};  // rejected candidates by test, for the counters
    // Smallest angle (radians) a new triangle may leave between itself and a front edge at
    // a shared point (the paper's 5-degree edge-face angle test, stricter on a first try).
    double min_gap_ = 0.0;

    // Scratch of one step: nearby front points (same sheet) and the front edges at them.
    std::vector<std::int32_t> near_points_, near_edges_, scratch_ids_;
    std::vector<std::int32_t> gathered_all_;  // every front point of the last gather()
    std::vector<std::int32_t> edge_stamp_;
    std::int32_t stamp_ = 0;
};

// Collects the front points within `radius` of `center` on the same sheet as the frame
// (normal within 90 degrees: the facing sheet of a thin gap is ignored) and their edges.
void FrontMesher::gather(const Eigen::Vector3d& center, double radius, const Frame& fr) {
    front_points_.query_sphere(center, radius, scratch_ids_);
    gathered_all_ = scratch_ids_;
    near_points_.clear();
    near_edges_.clear();
    if (edge_stamp_.size() < edges_.size()) edge_stamp_.resize(edges_.size() + edges_.size() / 2 + 16, 0);
    ++stamp_;
    for (const std::int32_t q : scratch_ids_) {
        if (normal_[static_cast<std::size_t>(q)].dot(fr.n) <= 0.0) continue;
        near_points_.push_back(q);
        for (std::int32_t e = head_out_[static_cast<std::size_t>(q)]; e >= 0;
             e = edges_[static_cast<std::size_t>(e)].next_out)
            if (edge_stamp_[static_cast<std::size_t>(e)] != stamp_) {
                edge_stamp_[static_cast<std::size_t>(e)] = stamp_;
                near_edges_.push_back(e);
            }
        for (std::int32_t e = head_in_[static_cast<std::size_t>(q)]; e >= 0;
             e = edges_[static_cast<std::size_t>(e)].next_in)
            if (edge_stamp_[static_cast<std::size_t>(e)] != stamp_) {
                edge_stamp_[static_cast<std::size_t>(e)] = stamp_;
                near_edges_.push_back(e);
            }
    }
}

// At a, the triangle spans from a->b counter-clockwise to a->c; that wedge must stay inside
// the unmeshed sector that starts at a->b and ends at the first incoming front edge p->a.
bool FrontMesher::sector_ok_at_a(std::int32_t a, std::int32_t b, std::int32_t c, const P2& pc,
                                 const Frame& fr) const {
    const P2 pa = fr.to2d(xyz_[static_cast<std::size_t>(a)]), pb = fr.to2d(xyz_[static_cast<std::size_t>(b)]);
    const double base = angle_of(pa, pb);
    const double wedge = ccw(base, angle_of(pa, pc));
    double limit = two_pi;
    std::int32_t limit_point = -1;
    for (std::int32_t e = head_in_[static_cast<std::size_t>(a)]; e >= 0; e = edges_[static_cast<std::size_t>(e)].next_in) {
        const std::int32_t p = edges_[static_cast<std::size_t>(e)].a;
        if (p == b) continue;
        const double t = ccw(base, angle_of(pa, fr.to2d(xyz_[static_cast<std::size_t>(p)])));
        if (t < limit) {
            limit = t;
            limit_point = p;
        }
    }
    if (c == limit_point) return wedge <= limit + 1e-9;
    return wedge > 0.0 && wedge < limit - min_gap_;
}

// At b, the triangle spans from b->c counter-clockwise to b->a; that wedge must stay inside
// the unmeshed sector that ends at b->a and starts at the first outgoing edge b->q found
// turning clockwise from b->a.
bool FrontMesher::sector_ok_at_b(std::int32_t a, std::int32_t b, std::int32_t c, const P2& pc,
                                 const Frame& fr) const {
    const P2 pa = fr.to2d(xyz_[static_cast<std::size_t>(a)]), pb = fr.to2d(xyz_[static_cast<std::size_t>(b)]);
    const double base = angle_of(pb, pa);
    const double wedge = ccw(angle_of(pb, pc), base);
    double limit = two_pi;
    std::int32_t limit_point = -1;
    for (std::int32_t e = head_out_[static_cast<std::size_t>(b)]; e >= 0; e = edges_[static_cast<std::size_t>(e)].next_out) {
        const std::int32_t q = edges_[static_cast<std::size_t>(e)].b;
        if (q == a) continue;
        const double t = ccw(angle_of(pb, fr.to2d(xyz_[static_cast<std::size_t>(q)])), base);
        if (t < limit) {
            limit = t;
            limit_point = q;
        }
    }
    if (c == limit_point) return wedge <= limit + 1e-9;
    return wedge > 0.0 && wedge < limit - min_gap_;
}

// At an existing point c, the triangle spans from c->a counter-clockwise to c->b; that wedge
// must lie inside one unmeshed sector of c (from an outgoing edge c->q counter-clockwise to
// the next incoming edge p->c).
bool FrontMesher::sector_ok_at_c(std::int32_t a, std::int32_t b, std::int32_t c, const Frame& fr) const {
    const P2 pc = fr.to2d(xyz_[static_cast<std::size_t>(c)]);
    const double dir_a = angle_of(pc, fr.to2d(xyz_[static_cast<std::size_t>(a)]));
    const double wedge = ccw(dir_a, angle_of(pc, fr.to2d(xyz_[static_cast<std::size_t>(b)])));
    // The sector start: the outgoing edge reached first turning clockwise from c->a.
    double back = two_pi;
    double start = 0.0;
    for (std::int32_t e = head_out_[static_cast<std::size_t>(c)]; e >= 0; e = edges_[static_cast<std::size_t>(e)].next_out) {
        const std::int32_t q = edges_[static_cast<std::size_t>(e)].b;
        const double dq = angle_of(pc, fr.to2d(xyz_[static_cast<std::size_t>(q)]));
        const double t = q == a ? 0.0 : ccw(dq, dir_a);
        if (t < back) {
            back = t;
            start = q == a ? dir_a : dq;
        }
    }
    if (back == two_pi || (back > 0.0 && back < min_gap_)) return false;
    double limit = two_pi;
    std::int32_t limit_point = -1;
    for (std::int32_t e = head_in_[static_cast<std::size_t>(c)]; e >= 0; e = edges_[static_cast<std::size_t>(e)].next_in) {
        const std::int32_t p = edges_[static_cast<std::size_t>(e)].a;
        const double t = ccw(start, angle_of(pc, fr.to2d(xyz_[static_cast<std::size_t>(p)])));
        if (t > 0.0 && t < limit) {
            limit = t;
            limit_point = p;
        }
    }
    const double end = back + wedge;
    if (b == limit_point) return end <= limit + 1e-9;
    return end < limit - min_gap_;
}

// Exact 3-D test of the new triangle (a, b, c) (c = -1: a new point at xc) against every live
// triangle whose box meets its box: true when they share a point other than their common
// vertices (with one common vertex: the far edge of one meets the other; with a common edge:
// the two fold onto each other). The tangent-plane tests see one sheet; this one sees all,
// so the front never crosses a thin gap or folds over a ridge.
bool FrontMesher::crosses_mesh(std::int32_t a, std::int32_t b, std::int32_t c,
                               const Eigen::Vector3d& xc) {
    const std::int32_t mine[3] = {a, b, c};
    const double* pm[3] = {xyz_[static_cast<std::size_t>(a)].data(), xyz_[static_cast<std::size_t>(b)].data(), xc.data()};
    core::AdtBox box = core::AdtBox::of_point(xyz_[static_cast<std::size_t>(a)]);
    box.extend(xyz_[static_cast<std::size_t>(b)]);
    box.extend(xc);
    triangle_boxes_.query_box(box, box_hits_);
    for (const std::int32_t t : box_hits_) {
        const auto& o = tris_[static_cast<std::size_t>(t)];
        const double* po[3] = {xyz_[static_cast<std::size_t>(o[0])].data(), xyz_[static_cast<std::size_t>(o[1])].data(),
                               xyz_[static_cast<std::size_t>(o[2])].data()};
        int im[3], io[3], n = 0;  // positions of shared vertices
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                if (mine[i] >= 0 && mine[i] == o[static_cast<std::size_t>(j)]) {
                    im[n] = i;
                    io[n] = j;
                    ++n;
                }
        if (n == 0) {
            if (core::triangles_intersect(pm[0], pm[1], pm[2], po[0], po[1], po[2])) return true;
        } else if (n == 1) {
            // Far edges against the other triangle, both ways.
            const double* m0 = pm[(im[0] + 1) % 3];
            const double* m1 = pm[(im[0] + 2) % 3];
            const double* o0 = po[(io[0] + 1) % 3];
            const double* o1 = po[(io[0] + 2) % 3];
            if (core::segment_intersects_triangle(m0, m1, po[0], po[1], po[2]) ||
                core::segment_intersects_triangle(o0, o1, pm[0], pm[1], pm[2]))
                return true;
        } else if (n == 2) {
            // Common edge: the free vertices must not fold onto each other.
            const int fm = 3 - im[0] - im[1], fo = 3 - io[0] - io[1];
            const double* e0 = pm[im[0]];
            const double* e1 = pm[im[1]];
            if (core::orient3d(e0, e1, pm[fm], po[fo]) == 0) {
                // Coplanar: overlap unless the free vertices lie on opposite sides of the edge.
                if (core::segment_intersects_triangle(pm[fm], pm[fm], po[0], po[1], po[2]) ||
                    core::segment_intersects_triangle(po[fo], po[fo], pm[0], pm[1], pm[2]))
                    return true;
            }
        } else {
            return true;  // the same triangle again
        }
    }
    return false;
}

// The 2-D analogue of the §3.1.4 tests for triangle (a, b, c), c at xc with background
// normal nc (c = -1 for a new point). Uses near_points_/near_edges_ from gather().
bool FrontMesher::is_valid(std::int32_t a, std::int32_t b, std::int32_t c,
                           const Eigen::Vector3d& xc, const Eigen::Vector3d& nc, const Frame& fr,
                           double min_cos, double corner_cos) {
    const Eigen::Vector3d& xa = xyz_[static_cast<std::size_t>(a)];
    const Eigen::Vector3d& xb = xyz_[static_cast<std::size_t>(b)];
    // Orientation consistent with the background at the three corners (3-D).
    const Eigen::Vector3d t = (xb - xa).cross(xc - xa);
    const double tl = t.norm();
    if (!(tl > 0.0)) return false;
    if (t.dot(fr.n) <= min_cos * tl || t.dot(normal_[static_cast<std::size_t>(a)]) <= corner_cos * tl ||
        t.dot(normal_[static_cast<std::size_t>(b)]) <= corner_cos * tl || t.dot(nc) <= corner_cos * tl)
        return ++why_[0], false;
    const P2 pa = fr.to2d(xa), pb = fr.to2d(xb), pc = fr.to2d(xc);
    if (orient(pa, pb, pc) <= 0) return ++why_[1], false;
    if (!sector_ok_at_a(a, b, c, pc, fr) || !sector_ok_at_b(a, b, c, pc, fr)) return ++why_[2], false;
    if (c >= 0) {
        // Each triangle edge is used once per direction: no overlap with the mesh.
        if (has_mesh_edge(b, c) || has_mesh_edge(c, a)) return ++why_[3], false;
        if (!sector_ok_at_c(a, b, c, fr)) return ++why_[4], false;
    }
    // Point in triangle: no nearby front point inside or on the closed triangle.
    for (const std::int32_t q : near_points_) {
        if (q == a || q == b || q == c) continue;
        const P2 pq = fr.to2d(xyz_[static_cast<std::size_t>(q)]);
        if (orient(pa, pb, pq) >= 0 && orient(pb, pc, pq) >= 0 && orient(pc, pa, pq) >= 0) return ++why_[5], false;
    }
    // Edge crossing: the new edges (b, c) and (c, a) against nearby front edges.
    const std::int32_t ends[2][2] = {{b, c}, {c, a}};
    const P2* pts[2][2] = {{&pb, &pc}, {&pc, &pa}};
    for (const std::int32_t e : near_edges_) {
        const FrontEdge& fe = edges_[static_cast<std::size_t>(e)];
        const P2 r = fr.to2d(xyz_[static_cast<std::size_t>(fe.a)]);
        const P2 s = fr.to2d(xyz_[static_cast<std::size_t>(fe.b)]);
        for (int k = 0; k < 2; ++k) {
            const std::int32_t x = ends[k][0], y = ends[k][1];
            const P2& px = *pts[k][0];
            const P2& py = *pts[k][1];
            const bool share_x = fe.a == x || fe.b == x, share_y = fe.a == y || fe.b == y;
            if (share_x && share_y) continue;  // the same edge: closing onto the front
            if (share_x || share_y) {
                // Segments sharing one end overlap only when collinear and pointing alike.
                const P2& shared = share_x ? px : py;
                const P2& mine = share_x ? py : px;
                const bool shared_is_a = share_x ? fe.a == x : fe.a == y;
                const P2& other = shared_is_a ? s : r;
                if (orient(shared, mine, other) == 0 &&
                    (mine.x() - shared.x()) * (other.x() - shared.x()) +
                            (mine.y() - shared.y()) * (other.y() - shared.y()) > 0.0)
                    return ++why_[6], false;
                continue;
            }
            const int o1 = orient(px, py, r), o2 = orient(px, py, s);
            const int o3 = orient(r, s, px), o4 = orient(r, s, py);
            if (o1 * o2 < 0 && o3 * o4 < 0) return ++why_[6], false;
            if ((o1 == 0 && on_segment(px, py, r)) || (o2 == 0 && on_segment(px, py, s)) ||
                (o3 == 0 && on_segment(r, s, px)) || (o4 == 0 && on_segment(r, s, py)))
                return ++why_[6], false;
        }
    }
    if (crosses_mesh(a, b, c, xc)) return ++why_[10], false;
    return true;
}

bool FrontMesher::advance(std::int32_t e, int fails) {
    const std::int32_t a = edges_[static_cast<std::size_t>(e)].a, b = edges_[static_cast<std::size_t>(e)].b;
    const Eigen::Vector3d& xa = xyz_[static_cast<std::size_t>(a)];
    const Eigen::Vector3d& xb = xyz_[static_cast<std::size_t>(b)];
    Frame fr;
    fr.origin = 0.5 * (xa + xb);
    fr.n = normal_[static_cast<std::size_t>(a)] + normal_[static_cast<std::size_t>(b)];
    if (fr.n.norm() < 1e-6) return false;
    fr.n.normalize();
    const Eigen::Vector3d ab = xb - xa;
    const double length = ab.norm();
    fr.u = ab - ab.dot(fr.n) * fr.n;
    if (fr.u.norm() < 1e-9 * std::max(length, 1e-300)) return false;
    fr.u.normalize();
    fr.v = fr.n.cross(fr.u);

    // Eq. 8 analogue: the target side s from the size field, kept within reach of the base
    // so that the triangle stays well shaped where the size changes.
    const double h = size_(fr.origin, face_[static_cast<std::size_t>(a)]);
    if (!(h > 0.0)) FM_THROW(MeshingError, "remesh: size field not positive at " + where(fr.origin));
    const double s = std::clamp(h, 0.7 * length, 1.5 * length);
    const double height = std::sqrt(std::max(s * s - 0.25 * length * length, 0.2 * length * length));

    // Eq. 10 analogue: ideal apex over the edge midpoint in the tangent plane, projected by a
    // local descent from the face of a (stays on a's sheet).
    const Eigen::Vector3d ideal = fr.origin + height * fr.v;
    const BackgroundPatch::Projection p_ideal = patch_.project(ideal, face_[static_cast<std::size_t>(a)]);
    const Eigen::Vector3d x_ck = 0.4 * fr.origin + 0.6 * p_ideal.point;  // Eq. 11

    const double search = 1.6 * std::max(length, s) + max_front_length_;
    gather(fr.origin, search, fr);

    // Candidates: front points near the ideal apex and the front neighbours of a and b.
    // fails 0: strict; 1: relaxed; 2: last resort where local remeshing keeps failing (any
    // shape that passes the validity tests; the smoothing after the front mends it).
    const double min_cos = fails == 0 ? 0.3 : fails == 1 ? 0.05 : 0.0;
    min_gap_ = (fails == 0 ? 12.0 : fails == 1 ? 4.0 : 0.5) * pi / 180.0;
    const double max_eta = fails == 0 ? 0.45 : fails == 1 ? 0.85 : 0.99;
    const double radius_c = (fails == 0 ? 0.75 : fails == 1 ? 1.2 : 2.0) * s;
    std::vector<Candidate> candidates;
    auto consider = [&](std::int32_t q) {
        if (q == a || q == b) return;
        for (const Candidate& c : candidates)
            if (c.point == q) return;
        const Eigen::Vector3d& xq = xyz_[static_cast<std::size_t>(q)];
        const double facing = normal_[static_cast<std::size_t>(q)].dot(fr.n);
        const bool across = facing <= 0.5;
        if (!across && (xq - fr.origin).dot(fr.v) <= 0.0) return;
        const double eta = core::triangle_skewness(xa, xb, xq);
        const bool closes = find_edge(b, q) >= 0 && find_edge(q, a) >= 0;
        if (eta > max_eta && !closes) return;
        // Thin gaps: a point turned away is a candidate only the short way round (over a
        // ridge or a fold), never across the gap (DESIGN-NOTES §2).
        if (across) {
            const double chord = (xq - fr.origin).norm();
            if (patch_.path_distance(fr.origin, face_[static_cast<std::size_t>(a)], xq,
                                     face_[static_cast<std::size_t>(q)], 1.5 * chord + 0.25 * s) ==
                std::numeric_limits<double>::infinity())
                return;
        }
        candidates.push_back({(eta + 0.1) * (x_ck - xq).norm(), q, across});  // Eq. 12
    };
    for (std::int32_t f = head_in_[static_cast<std::size_t>(a)]; f >= 0; f = edges_[static_cast<std::size_t>(f)].next_in)
        consider(edges_[static_cast<std::size_t>(f)].a);
    for (std::int32_t f = head_out_[static_cast<std::size_t>(b)]; f >= 0; f = edges_[static_cast<std::size_t>(f)].next_out)
        consider(edges_[static_cast<std::size_t>(f)].b);
    for (const std::int32_t q : near_points_)
        if ((xyz_[static_cast<std::size_t>(q)] - p_ideal.point).norm() <= radius_c) consider(q);
    std::sort(candidates.begin(), candidates.end(), [](const Candidate& x, const Candidate& y) {
        return std::tie(x.score, x.point) < std::tie(y.score, y.point);
    });
    for (const Candidate& c : candidates) {
        const std::size_t q = static_cast<std::size_t>(c.point);
        if (!c.across) {
            if (is_valid(a, b, c.point, xyz_[q], normal_[q], fr, min_cos, min_cos)) {
                add_triangle(a, b, c.point);
                return true;
            }
            continue;
        }
        // Across a ridge or fold: test in the plane of the triangle itself (the two sides
        // unfold onto its two halves), provided it faces the way of the corners' normals.
        Frame own = fr;
        own.n = ab.cross(xyz_[q] - xa);
        const Eigen::Vector3d corners =
            normal_[static_cast<std::size_t>(a)] + normal_[static_cast<std::size_t>(b)] + normal_[q];
        if (own.n.norm() < 1e-12 * length * length || own.n.dot(corners) <= 0.0) continue;
        own.n.normalize();
        own.u = ab - ab.dot(own.n) * own.n;
        if (own.u.norm() < 1e-9 * length) continue;
        own.u.normalize();
        own.v = own.n.cross(own.u);
        gather(fr.origin, search, own);
        const bool ok = is_valid(a, b, c.point, xyz_[q], normal_[q], own, min_cos, -0.1);
        gather(fr.origin, search, fr);
        if (ok) {
            add_triangle(a, b, c.point);
            return true;
        }
    }

    // The new point last, at heights g = 1, 0.7, 0.49 (paper §3.1.4 step 2).
    for (const double g : {1.0, 0.7, 0.49}) {
        const Eigen::Vector3d target = fr.origin + g * height * fr.v;
        const BackgroundPatch::Projection pr =
            g == 1.0 ? p_ideal : patch_.project(target, face_[static_cast<std::size_t>(a)]);
        const Eigen::Vector3d nc = patch_.smooth_normal(pr.face);
        const bool last = fails >= 2;
        if (nc.dot(fr.n) < (last ? 0.0 : 0.5) || pr.distance > (last ? 1.0 : 0.5) * g * height) {
            ++why_[7];
            continue;
        }
        // Not too close to the front: a point there should have been a candidate.
        const P2 pc = fr.to2d(pr.point);
        bool clear = true;
        const double point_gap2 = std::pow(0.55 * g * s, 2), edge_gap2 = std::pow(0.3 * g * s, 2);
        for (const std::int32_t q : near_points_) {
            if (q == a || q == b) continue;
            if ((xyz_[static_cast<std::size_t>(q)] - pr.point).squaredNorm() < point_gap2) {
                clear = false;
                break;
            }
        }
        // Nor onto a point of another sheet (over a sharp ridge both sides project to the
        // same places): that point is a candidate of its own, the short way round.
        for (const std::int32_t q : gathered_all_) {
            if (!clear) break;
            if (q == a || q == b) continue;
            if ((xyz_[static_cast<std::size_t>(q)] - pr.point).squaredNorm() < 0.25 * point_gap2) clear = false;
        }
        if (!clear) { ++why_[8]; continue; }
        for (const std::int32_t f : near_edges_) {
            const FrontEdge& fe = edges_[static_cast<std::size_t>(f)];
            if (fe.a == a || fe.b == a || fe.a == b || fe.b == b) continue;
            if (segment_distance2(fr.to2d(xyz_[static_cast<std::size_t>(fe.a)]),
                                  fr.to2d(xyz_[static_cast<std::size_t>(fe.b)]), pc) < edge_gap2) {
                clear = false;
                break;
            }
        }
        if (!clear) { ++why_[9]; continue; }
        if (!is_valid(a, b, -1, pr.point, nc, fr, min_cos, min_cos)) continue;
        const std::int32_t c = add_point(pr.point, pr.face, false);
        add_triangle(a, b, c);
        return true;
    }
    return false;
}

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
        edges_[static_cast<std::size_t>(head_in_[static_cast<std::size_t>(loop.front())])].next_in >= 0)
        return false;
    Eigen::Vector3d n_avg = Eigen::Vector3d::Zero();
    for (const std::int32_t v : loop) n_avg += normal_[static_cast<std::size_t>(v)];
    if (n_avg.norm() < 1e-9) return false;
    n_avg.normalize();
    auto X = [&](int i) -> const Eigen::Vector3d& { return xyz_[static_cast<std::size_t>(loop[std::size_t(i)])]; };
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
            if (t.dot(normal_[static_cast<std::size_t>(loop[std::size_t(c)])]) <= -0.2 * tl) return -1.0;
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
                const double q = std::min({quality(i, k, j), k > i + 1 ? best[std::size_t(i * m + k)] : 180.0,
                                           j > k + 1 ? best[std::size_t(k * m + j)] : 180.0});
                if (q > b) {
                    b = q;
                    split[std::size_t(i * m + j)] = k;
                }
            }
        }
    if (!(best[std::size_t(m - 1)] >= min_angle_deg) || best[std::size_t(m - 1)] <= 0.0) return false;
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
    for (const auto& t : made)
        if (crosses_mesh(t[0], t[1], t[2], xyz_[static_cast<std::size_t>(t[2])])) return false;
    for (const auto& t : made) add_triangle(t[0], t[1], t[2]);
    ++closed_loops_;
    return true;
}

// §3.2: remove the triangles around the ends of a stuck edge, the region growing with the
// number of earlier remeshings there, and re-open the front.
bool FrontMesher::local_remesh(std::int32_t e) {
    const std::int32_t a = edges_[static_cast<std::size_t>(e)].a, b = edges_[static_cast<std::size_t>(e)].b;
    // The level counts earlier remeshings near here (new points do not remember them).
    const Eigen::Vector3d centre = 0.5 * (xyz_[static_cast<std::size_t>(a)] + xyz_[static_cast<std::size_t>(b)]);
    const int near = remeshings_near(e);
    const int level = std::min(1 + near / 2, 8);
    if (near >= params_.max_local_remesh) {
        dump_near(centre, std::max(20.0 * (xyz_[static_cast<std::size_t>(b)] - xyz_[static_cast<std::size_t>(a)]).norm(), 8.0));
        throw FrontStall("remesh: the front cannot be closed near " + where(centre) + " after " +
                             std::to_string(near) + " local remeshings there",
                         centre, __FILE__, __LINE__, __func__);
    }
    remesh_sites_.insert(static_cast<std::int32_t>(remeshings_), centre);
    std::vector<std::int32_t> ring = {a, b}, triangles;
    for (int k = 0; k < level; ++k) {
        triangles.clear();
        for (const std::int32_t p : ring)
            for (std::int32_t s = tri_head_[static_cast<std::size_t>(p)]; s >= 0; s = tri_next_[static_cast<std::size_t>(s)])
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
        queue_.push({0, (xyz_[static_cast<std::size_t>(b)] - xyz_[static_cast<std::size_t>(a)]).norm(), e});
    }
    ++remeshings_;
    return true;
}

// Debugging aid: with FRONTMESH_FRONT_DUMP=path set, the triangles, front edges and
// background faces within `radius` of `centre` go to a legacy VTK file (cell data `kind`:
// 0 triangle, 1 front edge, 2 background face) when the front cannot be closed.
void FrontMesher::dump_near(const Eigen::Vector3d& centre, double radius) const {
    const char* path = std::getenv("FRONTMESH_FRONT_DUMP");
    if (path == nullptr) return;
    std::vector<Eigen::Vector3d> pts;
    std::vector<std::vector<std::int32_t>> cells;
    std::vector<int> kind;
    auto near = [&](const Eigen::Vector3d& p) { return (p - centre).norm() <= radius; };
    for (std::size_t t = 0; t < tris_.size(); ++t) {
        if (!tri_alive_[t]) continue;
        const auto& v = tris_[t];
        if (!near(xyz_[std::size_t(v[0])])) continue;
        std::vector<std::int32_t> c;
        for (const auto i : v) { c.push_back(std::int32_t(pts.size())); pts.push_back(xyz_[std::size_t(i)]); }
        cells.push_back(c);
        kind.push_back(0);
    }
    for (const FrontEdge& fe : edges_) {
        if (!fe.alive || !near(xyz_[std::size_t(fe.a)])) continue;
        cells.push_back({std::int32_t(pts.size()), std::int32_t(pts.size() + 1)});
        pts.push_back(xyz_[std::size_t(fe.a)]);
        pts.push_back(xyz_[std::size_t(fe.b)]);
        kind.push_back(1);
    }
    const core::SurfaceNetwork& bg = patch_.background();
    for (const std::int32_t f : patch_.faces()) {
        const auto& v = bg.faces[std::size_t(f)];
        if (!near(bg.point(v[0]))) continue;
        std::vector<std::int32_t> c;
        for (const auto i : v) { c.push_back(std::int32_t(pts.size())); pts.push_back(bg.point(i)); }
        cells.push_back(c);
        kind.push_back(2);
    }
    std::ostringstream name;
    name << path << "-" << std::lround(centre.x()) << "_" << std::lround(centre.y()) << "_"
         << std::lround(centre.z()) << ".vtk";
    std::ofstream out(name.str());
    out.precision(17);
    out << "# vtk DataFile Version 3.0\nfront dump\nASCII\nDATASET POLYDATA\nPOINTS " << pts.size() << " double\n";
    for (const auto& p : pts) out << p.x() << " " << p.y() << " " << p.z() << "\n";
    std::size_t lines = 0, polys = 0;
    for (const auto& c : cells) (c.size() == 2 ? lines : polys) += c.size() + 1;
    std::size_t nl = 0, np = 0;
    for (const auto& c : cells) (c.size() == 2 ? nl : np) += 1;
    out << "LINES " << nl << " " << lines << "\n";
    for (const auto& c : cells) if (c.size() == 2) out << "2 " << c[0] << " " << c[1] << "\n";
    out << "POLYGONS " << np << " " << polys << "\n";
    for (const auto& c : cells) if (c.size() == 3) out << "3 " << c[0] << " " << c[1] << " " << c[2] << "\n";
    out << "CELL_DATA " << cells.size() << "\nSCALARS kind int 1\nLOOKUP_TABLE default\n";
    for (std::size_t i = 0; i < cells.size(); ++i) if (cells[i].size() == 2) out << kind[i] << "\n";
    for (std::size_t i = 0; i < cells.size(); ++i) if (cells[i].size() == 3) out << kind[i] << "\n";
}

// A closed patch without loops starts from an equilateral triangle of the target size on the
// patch's first face.
void FrontMesher::seed() {
    const core::SurfaceNetwork& bg = patch_.background();
    const auto& faces = patch_.faces();
    const std::int32_t f0 = faces[(static_cast<std::size_t>(attempt_) * 7919u) % faces.size()];
    const auto& fv = bg.faces[static_cast<std::size_t>(f0)];
    const Eigen::Vector3d centre = (bg.point(fv[0]) + bg.point(fv[1]) + bg.point(fv[2])) / 3.0;
    const Eigen::Vector3d n = patch_.smooth_normal(f0);
    Eigen::Vector3d u = n.unitOrthogonal();
    const Eigen::Vector3d v = n.cross(u);
    const double h = size_(centre, f0);
    if (!(h > 0.0)) FM_THROW(MeshingError, "remesh: size field not positive at " + where(centre));
    std::int32_t ids[3];
    for (int k = 0; k < 3; ++k) {
        const double angle = pi / 2.0 + k * two_pi / 3.0;
        const Eigen::Vector3d p = centre + h / std::sqrt(3.0) * (std::cos(angle) * u + std::sin(angle) * v);
        const BackgroundPatch::Projection pr = patch_.project(p, f0);
        ids[k] = add_point(pr.point, pr.face, false);
    }
    add_triangle(ids[0], ids[1], ids[2]);
}

PatchMesh FrontMesher::run(const std::vector<PatchLoop>& loops) {
    // Loop points first, in loop order; loop edges are the initial front.
    for (std::size_t l = 0; l < loops.size(); ++l) {
        const auto& pts = loops[l].points;
        if (pts.size() < 3)
            FM_THROW(InputError, "remesh: patch loop " + std::to_string(l) + " has fewer than 3 points");
        const auto first = static_cast<std::int32_t>(xyz_.size());
        for (const Eigen::Vector3d& p : pts) {
            const BackgroundPatch::Projection pr = patch_.project(p);
            add_point(p, pr.face, true);
        }
        const auto n = static_cast<std::int32_t>(pts.size());
        for (std::int32_t i = 0; i < n; ++i) {
            const std::int32_t a = first + i, b = first + (i + 1) % n;
            add_edge(a, b);
            sync_point(a);
        }
    }
    if (loops.empty()) seed();

    // Every step either adds a triangle or counts a failure; both are bounded.
    double h_min = std::numeric_limits<double>::infinity();
    {
        const core::SurfaceNetwork& bg = patch_.background();
        const auto& faces = patch_.faces();
        const std::size_t stride = std::max<std::size_t>(1, faces.size() / 4096);
        for (std::size_t i = 0; i < faces.size(); i += stride) {
            const auto& fv = bg.faces[static_cast<std::size_t>(faces[i])];
            h_min = std::min(h_min, size_((bg.point(fv[0]) + bg.point(fv[1]) + bg.point(fv[2])) / 3.0, faces[i]));
        }
        for (const Eigen::Vector3d& p : xyz_) h_min = std::min(h_min, size_(p, face_[0]));
    }
    const double expected = patch_.area() / (0.43 * h_min * h_min);
    const std::int64_t max_steps = static_cast<std::int64_t>(std::min(20.0 * expected, 4.0e9)) + 100000;
    const std::int64_t max_remeshings = static_cast<std::int64_t>(std::min(expected / 20.0, 1.0e8)) + 1000;
    std::int64_t steps = 0;
    while (!queue_.empty()) {
        const QueueEntry top = queue_.top();
        queue_.pop();
        FrontEdge& fe = edges_[static_cast<std::size_t>(top.edge)];
        if (!fe.alive || fe.fails != top.fails) continue;
        if (++steps > max_steps)
            throw FrontStall("remesh: the front does not close (step limit) near " +
                                 where(xyz_[static_cast<std::size_t>(fe.a)]) + " (" +
                                 std::to_string(live_triangles_) + " triangles, front of " +
                                 std::to_string(front_size_) + " edges, " +
                                 std::to_string(remeshings_) + " local remeshings)",
                             xyz_[static_cast<std::size_t>(fe.a)], __FILE__, __LINE__, __func__);
        if ((steps & 0x3fff) == 0)
            ctx_.progress(std::min(1.0, static_cast<double>(live_triangles_) / expected),
                          "front: " + std::to_string(live_triangles_) + " triangles, " +
                              std::to_string(front_size_) + " front edges, " +
                              std::to_string(remeshings_) + " local remeshings");
        if (advance(top.edge, top.fails)) continue;
        FrontEdge& again = edges_[static_cast<std::size_t>(top.edge)];
        ++again.fails;
        if (again.fails < 2)
            queue_.push({again.fails, top.length, top.edge});
        else if (close_small_loop(top.edge))
            continue;
        else if (remeshings_near(top.edge) >= kLastResortAfter && advance(top.edge, 2)) {
            ++last_resort_;
            continue;
        }
        else if (remeshings_ >= max_remeshings)
            throw FrontStall("remesh: the front stalls near " +
                                 where(xyz_[static_cast<std::size_t>(fe.a)]) + " (" +
                                 std::to_string(live_triangles_) + " triangles, front of " +
                                 std::to_string(front_size_) + " edges, " +
                                 std::to_string(remeshings_) + " local remeshings)",
                             xyz_[static_cast<std::size_t>(fe.a)], __FILE__, __LINE__, __func__);
        else
            if (!local_remesh(top.edge)) {
                // Nothing to remove around the edge (e.g. a loop edge at a sharp corner
                // before any triangle): the last resort, then any valid closing of its loop.
                if (advance(top.edge, 2) || close_small_loop(top.edge, 0.0)) {
                    ++last_resort_;
                    continue;
                }
                // Put back behind every fresh edge a few times: the front around may open
                // the way.
                FrontEdge& stuck = edges_[static_cast<std::size_t>(top.edge)];
                if (stuck.stalls < 3) {
                    ++stuck.stalls;
                    stuck.fails = 1;
                    queue_.push({1, top.length, top.edge});
                    continue;
                }
                const Eigen::Vector3d& xa = xyz_[static_cast<std::size_t>(fe.a)];
                dump_near(xa, 8.0);
                throw FrontStall("remesh: the front cannot advance from edge at " + where(xa) +
                                     " and there is nothing to remesh around it",
                                 xa, __FILE__, __LINE__, __func__);
            }
    }
    FM_CHECK(front_size_ == 0);
    static const char* const reasons[11] = {"normal", "side", "sector", "mesh_edge", "sector_apex",
                                            "point_inside", "crossing", "projection",
                                            "near_point", "near_edge", "crossing_3d"};
    for (int i = 0; i < 11; ++i)
        ctx_.add(std::string("remesh.front_rejected_") + reasons[i], static_cast<double>(why_[i]));
    ctx_.add("remesh.front_local_remeshings", static_cast<double>(remeshings_));
    ctx_.add("remesh.front_closed_loops", static_cast<double>(closed_loops_));
    ctx_.add("remesh.front_last_resort_triangles", static_cast<double>(last_resort_));
    ctx_.add("remesh.front_steps", static_cast<double>(steps));

    if (params_.smoothing_iterations > 0) smooth();

    // Compact: loop points keep their ids (they come first and are never removed).
    PatchMesh out;
    std::vector<std::int32_t> new_id(xyz_.size(), -1);
    for (std::size_t p = 0; p < xyz_.size(); ++p) {
        if (!alive_[p]) continue;
        new_id[p] = static_cast<std::int32_t>(out.points.size());
        out.points.push_back(xyz_[p]);
        out.point_face.push_back(face_[p]);
    }
    for (std::size_t t = 0; t < tris_.size(); ++t) {
        if (!tri_alive_[t]) continue;
        const auto& tri = tris_[t];
        out.faces.push_back({new_id[static_cast<std::size_t>(tri[0])], new_id[static_cast<std::size_t>(tri[1])],
                             new_id[static_cast<std::size_t>(tri[2])]});
        FM_CHECK(out.faces.back()[0] >= 0 && out.faces.back()[1] >= 0 && out.faces.back()[2] >= 0);
    }
    return out;
}

// Smoothing inside the patch: each free point moves toward the centroid of its neighbours,
// projected back onto the background from its face; the move is kept only when the smallest
// angle of its triangles grows and their orientation stays consistent with the background.
void FrontMesher::smooth() {
    std::vector<std::int32_t> ring;
    for (int it = 0; it < params_.smoothing_iterations; ++it) {
        for (std::size_t p = 0; p < xyz_.size(); ++p) {
            if (!alive_[p] || fixed_[p]) continue;
            Eigen::Vector3d sum = Eigen::Vector3d::Zero();
            int count = 0;
            double before = 180.0;
            for (std::int32_t s = tri_head_[p]; s >= 0; s = tri_next_[static_cast<std::size_t>(s)]) {
                const auto& t = tris_[static_cast<std::size_t>(s / 3)];
                sum += xyz_[static_cast<std::size_t>(t[static_cast<std::size_t>((s % 3 + 1) % 3)])];
                ++count;
                before = std::min(before, core::triangle_min_angle_deg(xyz_[static_cast<std::size_t>(t[0])],
                                                                       xyz_[static_cast<std::size_t>(t[1])],
                                                                       xyz_[static_cast<std::size_t>(t[2])]));
            }
            if (count < 3) continue;
            const BackgroundPatch::Projection pr = patch_.project(sum / count, face_[p]);
            const Eigen::Vector3d old = xyz_[p];
            xyz_[p] = pr.point;
            double after = 180.0;
            bool ok = true;
            const Eigen::Vector3d np = patch_.smooth_normal(pr.face);
            for (std::int32_t s = tri_head_[p]; s >= 0 && ok; s = tri_next_[static_cast<std::size_t>(s)]) {
                const auto& t = tris_[static_cast<std::size_t>(s / 3)];
                const Eigen::Vector3d& x0 = xyz_[static_cast<std::size_t>(t[0])];
                const Eigen::Vector3d& x1 = xyz_[static_cast<std::size_t>(t[1])];
                const Eigen::Vector3d& x2 = xyz_[static_cast<std::size_t>(t[2])];
                const Eigen::Vector3d tn = (x1 - x0).cross(x2 - x0);
                if (tn.dot(np) <= 0.3 * tn.norm()) ok = false;
                after = std::min(after, core::triangle_min_angle_deg(x0, x1, x2));
            }
            if (ok && after > before) {
                face_[p] = pr.face;
                normal_[p] = np;
            } else {
                xyz_[p] = old;
            }
        }
    }
}

}  // namespace

PatchMesh triangulate_patch(const BackgroundPatch& patch, const std::vector<PatchLoop>& loops,
                            const SizeFunction& size, const FrontParams& params,
                            core::StageContext& ctx) {
    if (params.max_local_remesh < 1)
        FM_THROW(InputError, "remesh: max_local_remesh must be at least 1");
    if (params.smoothing_iterations < 0)
        FM_THROW(InputError, "remesh: smoothing_iterations must not be negative");
    if (params.attempts < 1) FM_THROW(InputError, "remesh: attempts must be at least 1");
    for (int attempt = 0;; ++attempt) {
        const double scale = std::pow(0.85, attempt);
        const SizeFunction scaled = [&size, scale](const Eigen::Vector3d& p, std::int32_t face) {
            return scale * size(p, face);
        };
        try {
            core::StageContext sub;
            FrontMesher mesher(patch, attempt == 0 ? size : scaled, params, sub, attempt);
            PatchMesh mesh = mesher.run(loops);
            for (const auto& [name, value] : sub.counters()) ctx.add(name, value);
            for (const auto& w : sub.warnings()) ctx.warn(w);
            ctx.add("remesh.patch_retries", attempt);
            return mesh;
        } catch (const FrontStall& e) {
            if (attempt + 1 >= params.attempts) throw;
            ctx.warn(std::string(e.what()) + "; the patch starts again with sizes x " +
                     std::to_string(std::pow(0.85, attempt + 1)));
        }
    }
}

}  // namespace frontmesh::surface
