// One step of the advancing front (paper §2 with the 2-D analogue of the §3.1.4 tests):
// candidates for the apex over the shortest front edge, ranked by Eq. 12, and the validity
// tests they must pass.

#include "surface/front_mesher.h"

#include "surface/front_internal.h"

#include <limits>

#include "pipeline/core/error.h"
#include "pipeline/core/quality.h"

namespace frontmesh::surface::front_detail {

// Collects the front points within `radius` of `center` on the same sheet as the frame
// (normal within 90 degrees: the facing sheet of a thin gap is ignored) and their edges.
void FrontMesher::gather(const Eigen::Vector3d& center, double radius, const Frame& fr) {
    front_points_.query_sphere(center, radius, scratch_ids_);
    gathered_all_ = scratch_ids_;
    near_points_.clear();
    near_edges_.clear();
    if (edge_stamp_.size() < edges_.size())
        edge_stamp_.resize(edges_.size() + edges_.size() / 2 + 16, 0);
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
    const P2 pa = fr.to2d(xyz_[static_cast<std::size_t>(a)]),
             pb = fr.to2d(xyz_[static_cast<std::size_t>(b)]);
    const double base = angle_of(pa, pb);
    const double wedge = ccw(base, angle_of(pa, pc));
    double limit = two_pi;
    std::int32_t limit_point = -1;
    for (std::int32_t e = head_in_[static_cast<std::size_t>(a)]; e >= 0;
         e = edges_[static_cast<std::size_t>(e)].next_in) {
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
    const P2 pa = fr.to2d(xyz_[static_cast<std::size_t>(a)]),
             pb = fr.to2d(xyz_[static_cast<std::size_t>(b)]);
    const double base = angle_of(pb, pa);
    const double wedge = ccw(angle_of(pb, pc), base);
    double limit = two_pi;
    std::int32_t limit_point = -1;
    for (std::int32_t e = head_out_[static_cast<std::size_t>(b)]; e >= 0;
         e = edges_[static_cast<std::size_t>(e)].next_out) {
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
bool FrontMesher::sector_ok_at_c(std::int32_t a, std::int32_t b, std::int32_t c,
                                 const Frame& fr) const {
    const P2 pc = fr.to2d(xyz_[static_cast<std::size_t>(c)]);
    const double dir_a = angle_of(pc, fr.to2d(xyz_[static_cast<std::size_t>(a)]));
    const double wedge = ccw(dir_a, angle_of(pc, fr.to2d(xyz_[static_cast<std::size_t>(b)])));
    // The sector start: the outgoing edge reached first turning clockwise from c->a.
    double back = two_pi;
    double start = 0.0;
    for (std::int32_t e = head_out_[static_cast<std::size_t>(c)]; e >= 0;
         e = edges_[static_cast<std::size_t>(e)].next_out) {
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
    for (std::int32_t e = head_in_[static_cast<std::size_t>(c)]; e >= 0;
         e = edges_[static_cast<std::size_t>(e)].next_in) {
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

}  // namespace frontmesh::surface::front_detail

namespace frontmesh::surface {

bool triangles_overlap(const std::int32_t ids_a[3], const double* const x_a[3],
                       const std::int32_t ids_b[3], const double* const x_b[3]) {
    int im[3], io[3], n = 0;  // positions of shared vertices
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            if (ids_a[i] >= 0 && ids_a[i] == ids_b[j]) {
                im[n] = i;
                io[n] = j;
                ++n;
            }
    if (n == 0) return core::triangles_intersect(x_a[0], x_a[1], x_a[2], x_b[0], x_b[1], x_b[2]);
    if (n == 1) {
        // Far edges against the other triangle, both ways.
        return core::segment_intersects_triangle(x_a[(im[0] + 1) % 3], x_a[(im[0] + 2) % 3], x_b[0],
                                                 x_b[1], x_b[2]) ||
               core::segment_intersects_triangle(x_b[(io[0] + 1) % 3], x_b[(io[0] + 2) % 3], x_a[0],
                                                 x_a[1], x_a[2]);
    }
    if (n == 2) {
        // Common edge: the free vertices must not fold onto each other.
        const int fm = 3 - im[0] - im[1], fo = 3 - io[0] - io[1];
        if (core::orient3d(x_a[im[0]], x_a[im[1]], x_a[fm], x_b[fo]) != 0) return false;
        // Coplanar: overlap unless the free vertices lie on opposite sides of the edge.
        return core::segment_intersects_triangle(x_a[fm], x_a[fm], x_b[0], x_b[1], x_b[2]) ||
               core::segment_intersects_triangle(x_b[fo], x_b[fo], x_a[0], x_a[1], x_a[2]);
    }
    return true;  // the same triangle again
}

}  // namespace frontmesh::surface

namespace frontmesh::surface::front_detail {

// Exact 3-D test of the new triangle (a, b, c) (c = -1: a new point at xc) against every live
// triangle whose box meets its box: true when they share a point other than their common
// vertices (with one common vertex: the far edge of one meets the other; with a common edge:
// the two fold onto each other). The tangent-plane tests see one sheet; this one sees all,
// so the front never crosses a thin gap or folds over a ridge.
bool FrontMesher::crosses_mesh(std::int32_t a, std::int32_t b, std::int32_t c,
                               const Eigen::Vector3d& xc) {
    const std::int32_t mine[3] = {a, b, c};
    const double* pm[3] = {xyz_[static_cast<std::size_t>(a)].data(),
                           xyz_[static_cast<std::size_t>(b)].data(), xc.data()};
    core::AdtBox box = core::AdtBox::of_point(xyz_[static_cast<std::size_t>(a)]);
    box.extend(xyz_[static_cast<std::size_t>(b)]);
    box.extend(xc);
    triangle_boxes_.query_box(box, box_hits_);
    for (const std::int32_t t : box_hits_) {
        const auto& o = tris_[static_cast<std::size_t>(t)];
        const double* po[3] = {xyz_[static_cast<std::size_t>(o[0])].data(),
                               xyz_[static_cast<std::size_t>(o[1])].data(),
                               xyz_[static_cast<std::size_t>(o[2])].data()};
        if (triangles_overlap(mine, pm, o.data(), po)) return true;
    }
    return false;
}

// A triangle whose corners lie on the patch may still span a hole of it: over the open end
// of a region thinner than the triangle (a box whose end is another patch), corners on two
// opposite sides close onto each other across the end, and the corner normals, tilted by the
// faces around a sharp end, do not tell. The background under the centroid does: there the
// patch runs across the triangle (normal about 90 degrees away), while over a ridge or fold
// that the front may cross it turns by at most 75 degrees for a ridge of 150 degrees.
bool FrontMesher::covers_background(const Eigen::Vector3d& xa, const Eigen::Vector3d& xb,
                                    const Eigen::Vector3d& xc, std::int32_t hint) const {
    const Eigen::Vector3d t = (xb - xa).cross(xc - xa);
    const double tl = t.norm();
    if (!(tl > 0.0)) return false;
    const BackgroundPatch::Projection pr = patch_.project((xa + xb + xc) / 3.0, hint);
    return t.dot(patch_.smooth_normal(pr.face)) > 0.2 * tl;
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
    if (t.dot(fr.n) <= min_cos * tl ||
        t.dot(normal_[static_cast<std::size_t>(a)]) <= corner_cos * tl ||
        t.dot(normal_[static_cast<std::size_t>(b)]) <= corner_cos * tl ||
        t.dot(nc) <= corner_cos * tl)
        return ++why_[0], false;
    const P2 pa = fr.to2d(xa), pb = fr.to2d(xb), pc = fr.to2d(xc);
    if (orient(pa, pb, pc) <= 0) return ++why_[1], false;
    if (!sector_ok_at_a(a, b, c, pc, fr) || !sector_ok_at_b(a, b, c, pc, fr))
        return ++why_[2], false;
    if (c >= 0) {
        // Each triangle edge is used once per direction: no overlap with the mesh.
        if (has_mesh_edge(b, c) || has_mesh_edge(c, a)) return ++why_[3], false;
        if (!sector_ok_at_c(a, b, c, fr)) return ++why_[4], false;
    }
    // Point in triangle: no nearby front point inside or on the closed triangle.
    for (const std::int32_t q : near_points_) {
        if (q == a || q == b || q == c) continue;
        const P2 pq = fr.to2d(xyz_[static_cast<std::size_t>(q)]);
        if (orient(pa, pb, pq) >= 0 && orient(pb, pc, pq) >= 0 && orient(pc, pa, pq) >= 0)
            return ++why_[5], false;
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
                            (mine.y() - shared.y()) * (other.y() - shared.y()) >
                        0.0)
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
    const std::int32_t a = edges_[static_cast<std::size_t>(e)].a,
                       b = edges_[static_cast<std::size_t>(e)].b;
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
    if (!(h > 0.0))
        FM_THROW(MeshingError, "remesh: size field not positive at " + where(fr.origin));
    const double s = std::clamp(h, 0.7 * length, 1.5 * length);
    const double height =
        std::sqrt(std::max(s * s - 0.25 * length * length, 0.2 * length * length));

    // Eq. 10 analogue: ideal apex over the edge midpoint in the tangent plane, projected by a
    // local descent from the face of a (stays on a's sheet).
    const Eigen::Vector3d ideal = fr.origin + height * fr.v;
    const BackgroundPatch::Projection p_ideal =
        patch_.project(ideal, face_[static_cast<std::size_t>(a)]);
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
    for (std::int32_t f = head_in_[static_cast<std::size_t>(a)]; f >= 0;
         f = edges_[static_cast<std::size_t>(f)].next_in)
        consider(edges_[static_cast<std::size_t>(f)].a);
    for (std::int32_t f = head_out_[static_cast<std::size_t>(b)]; f >= 0;
         f = edges_[static_cast<std::size_t>(f)].next_out)
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
        const Eigen::Vector3d corners = normal_[static_cast<std::size_t>(a)] +
                                        normal_[static_cast<std::size_t>(b)] + normal_[q];
        if (own.n.norm() < 1e-12 * length * length || own.n.dot(corners) <= 0.0) continue;
        own.n.normalize();
        own.u = ab - ab.dot(own.n) * own.n;
        if (own.u.norm() < 1e-9 * length) continue;
        own.u.normalize();
        own.v = own.n.cross(own.u);
        gather(fr.origin, search, own);
        const bool ok = is_valid(a, b, c.point, xyz_[q], normal_[q], own, min_cos, -0.1) &&
                        covers_background(xa, xb, xyz_[q], face_[static_cast<std::size_t>(a)]);
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
            if ((xyz_[static_cast<std::size_t>(q)] - pr.point).squaredNorm() < 0.25 * point_gap2)
                clear = false;
        }
        if (!clear) {
            ++why_[8];
            continue;
        }
        for (const std::int32_t f : near_edges_) {
            const FrontEdge& fe = edges_[static_cast<std::size_t>(f)];
            if (fe.a == a || fe.b == a || fe.a == b || fe.b == b) continue;
            if (segment_distance2(fr.to2d(xyz_[static_cast<std::size_t>(fe.a)]),
                                  fr.to2d(xyz_[static_cast<std::size_t>(fe.b)]), pc) < edge_gap2) {
                clear = false;
                break;
            }
        }
        if (!clear) {
            ++why_[9];
            continue;
        }
        if (!is_valid(a, b, -1, pr.point, nc, fr, min_cos, min_cos)) continue;
        const std::int32_t c = add_point(pr.point, pr.face, false);
        add_triangle(a, b, c);
        return true;
    }
    return false;
}

}  // namespace frontmesh::surface::front_detail
