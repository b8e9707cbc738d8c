// Obtuse faces of a remeshed network split at their longest edge (split_obtuse_faces).

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <unordered_map>
#include <utility>

#include "pipeline/core/error.h"
#include "pipeline/core/quality.h"
#include "surface/features.h"
#include "surface/polyline.h"
#include "surface/surface_smoothing.h"

namespace frontmesh::surface {

namespace {

std::uint64_t edge_key(std::int32_t x, std::int32_t y) {
    if (x > y) std::swap(x, y);
    return (std::uint64_t(std::uint32_t(x)) << 32) | std::uint32_t(y);
}

// Where a curve edge lies: curve, and the index k of its first vertex (vertices k, k + 1).
struct CurveEdge {
    std::int32_t curve = -1;
    std::int32_t k = -1;
};

// A new curve vertex, inserted after position k of its curve once the pass is over.
struct CurveInsert {
    std::int32_t curve = -1;
    std::int32_t k = -1;
    double s = 0.0;
    std::int32_t vertex = -1;
};

class Splitter {
public:
    Splitter(core::SurfaceNetwork& s, const std::vector<const BackgroundPatch*>& patches,
             SurfaceConstraints& c, double max_angle_deg, double guard_deg)
        : s_(s), patches_(patches), c_(c), max_angle_(max_angle_deg), guard_(guard_deg) {
        for (const SurfaceCurve& curve : c.curves)
            polylines_.push_back(Polyline::of(curve.polyline));
    }

    // One pass: the longest edge of each face with an angle over max_angle_, most obtuse
    // first, each face split at most once. Returns the splits.
    std::size_t pass() {
        const EdgeTable et = edge_table(s_);
        std::unordered_map<std::uint64_t, CurveEdge> curve_edges;
        for (std::size_t ci = 0; ci < c_.curves.size(); ++ci) {
            const auto& vs = c_.curves[ci].vertices;
            for (std::size_t k = 0; k + 1 < vs.size(); ++k)
                curve_edges[edge_key(vs[k], vs[k + 1])] = {std::int32_t(ci), std::int32_t(k)};
        }
        std::vector<std::pair<double, std::int32_t>> candidates;  // (max angle, edge)
        for (std::size_t f = 0; f < s_.face_count(); ++f) {
            const auto& t = s_.faces[f];
            const auto a =
                core::triangle_angles_deg(s_.point(t[0]), s_.point(t[1]), s_.point(t[2]));
            const int i = int(std::max_element(a.begin(), a.end()) - a.begin());
            if (a[std::size_t(i)] > max_angle_)
                candidates.emplace_back(a[std::size_t(i)],
                                        et.edge_of(std::int32_t(f), (i + 1) % 3));
        }
        std::sort(candidates.begin(), candidates.end(), [](const auto& x, const auto& y) {
            return x.first > y.first || (x.first == y.first && x.second < y.second);
        });
        std::vector<std::uint8_t> touched(s_.face_count(), 0);
        std::vector<CurveInsert> inserts;
        std::size_t splits = 0;
        for (const auto& [angle, e] : candidates) {
            const auto b = std::size_t(et.face_offsets[std::size_t(e)]);
            const auto n = std::size_t(et.face_count(e));
            faces_.assign(et.edge_faces.begin() + std::ptrdiff_t(b),
                          et.edge_faces.begin() + std::ptrdiff_t(b + n));
            if (std::any_of(faces_.begin(), faces_.end(),
                            [&](std::int32_t f) { return touched[std::size_t(f)] != 0; }))
                continue;
            const auto it = curve_edges.find(
                edge_key(et.vertices[std::size_t(e)][0], et.vertices[std::size_t(e)][1]));
            const CurveEdge ce = it == curve_edges.end() ? CurveEdge{} : it->second;
            if (split(e, et, ce, inserts)) {
                ++splits;
                for (const auto f : faces_) touched[std::size_t(f)] = 1;
                touched.resize(s_.face_count(), 1);
            }
        }
        // Curve vertices go in last first, so that the indices of a curve's earlier edges hold.
        std::sort(inserts.begin(), inserts.end(), [](const CurveInsert& x, const CurveInsert& y) {
            return x.curve < y.curve || (x.curve == y.curve && x.k > y.k);
        });
        for (const CurveInsert& ins : inserts) {
            SurfaceCurve& curve = c_.curves[std::size_t(ins.curve)];
            curve.vertices.insert(curve.vertices.begin() + ins.k + 1, ins.vertex);
            curve.s.insert(curve.s.begin() + ins.k + 1, ins.s);
        }
        return splits;
    }

private:
    // Splits edge e (its faces in faces_) at the best of a few points when every face it makes
    // keeps its side and the worst angles improve (see split_obtuse_faces). Returns whether.
    bool split(std::int32_t e, const EdgeTable& et, const CurveEdge& ce,
               std::vector<CurveInsert>& inserts) {
        const std::int32_t x = et.vertices[std::size_t(e)][0], y = et.vertices[std::size_t(e)][1];
        const Eigen::Vector3d X = s_.point(x), Y = s_.point(y);
        if (ce.curve < 0) {
            // An inner edge: two faces of one patch.
            if (faces_.size() != 2 ||
                c_.face_patch[std::size_t(faces_[0])] != c_.face_patch[std::size_t(faces_[1])])
                return false;
        }
        double old_max = 0.0, old_min = 180.0;
        for (const auto f : faces_) {
            const auto& t = s_.faces[std::size_t(f)];
            const auto a =
                core::triangle_angles_deg(s_.point(t[0]), s_.point(t[1]), s_.point(t[2]));
            old_max = std::max(old_max, *std::max_element(a.begin(), a.end()));
            old_min = std::min(old_min, *std::min_element(a.begin(), a.end()));
        }
        // Candidate places along the edge: the feet of the opposite vertices, and the middle,
        // kept a quarter of the edge from its ends.
        std::vector<double> ts{0.5};
        const Eigen::Vector3d d = Y - X;
        const double len2 = d.squaredNorm();
        if (!(len2 > 0.0)) return false;
        for (const auto f : faces_)
            for (const auto w : s_.faces[std::size_t(f)])
                if (w != x && w != y)
                    ts.push_back(std::clamp((s_.point(w) - X).dot(d) / len2, 0.25, 0.75));
        double best_min = -1.0;
        Eigen::Vector3d best_point = X;
        double best_s = 0.0;
        std::int32_t best_face = -1;
        for (const double t : ts) {
            Eigen::Vector3d m;
            double s_m = 0.0;
            std::int32_t face_hint = -1;
            if (ce.curve >= 0) {
                const SurfaceCurve& curve = c_.curves[std::size_t(ce.curve)];
                const std::size_t k = std::size_t(ce.k);
                // t runs from x to y; the curve runs from vertices[k] to vertices[k + 1].
                const double tc = curve.vertices[k] == x ? t : 1.0 - t;
                s_m = curve.s[k] + tc * (curve.s[k + 1] - curve.s[k]);
                const Polyline& pl = polylines_[std::size_t(ce.curve)];
                if (pl.points.size() < 2 || !(curve.s[k + 1] > curve.s[k])) return false;
                const double length = pl.length();
                const double w = length > 0.0 ? s_m - length * std::floor(s_m / length) : 0.0;
                m = pl.at(w);
                face_hint =
                    patches_[std::size_t(c_.face_patch[std::size_t(faces_[0])])]->project(m).face;
            } else {
                const BackgroundPatch& patch =
                    *patches_[std::size_t(c_.face_patch[std::size_t(faces_[0])])];
                const std::int32_t hint = c_.vertex_face[std::size_t(x)];
                const auto proj = hint >= 0 && patch.contains(hint) ? patch.project(X + t * d, hint)
                                                                    : patch.project(X + t * d);
                m = proj.point;
                face_hint = proj.face;
            }
            double new_max = 0.0, new_min = 180.0;
            bool ok = true;
            for (const auto f : faces_) {
                const auto& tf = s_.faces[std::size_t(f)];
                const Eigen::Vector3d n_old =
                    (s_.point(tf[1]) - s_.point(tf[0])).cross(s_.point(tf[2]) - s_.point(tf[0]));
                for (const auto& half : halves(tf, x, y)) {
                    const Eigen::Vector3d p0 = half[0] < 0 ? m : s_.point(half[0]);
                    const Eigen::Vector3d p1 = half[1] < 0 ? m : s_.point(half[1]);
                    const Eigen::Vector3d p2 = half[2] < 0 ? m : s_.point(half[2]);
                    const Eigen::Vector3d n_new = (p1 - p0).cross(p2 - p0);
                    // No fold: a new face turns by less than 30 degrees from the face it halves.
                    if (!(n_new.dot(n_old) >
                          std::cos(std::numbers::pi / 6.0) * n_new.norm() * n_old.norm())) {
                        ok = false;
                        break;
                    }
                    const auto a = core::triangle_angles_deg(p0, p1, p2);
                    new_max = std::max(new_max, *std::max_element(a.begin(), a.end()));
                    new_min = std::min(new_min, *std::min_element(a.begin(), a.end()));
                }
                if (!ok) break;
            }
            if (!ok || !(new_max < old_max - 5.0) || new_min < std::min(old_min, guard_) - 1e-9)
                continue;
            if (new_min > best_min) {
                best_min = new_min, best_point = m, best_s = s_m;
                best_face = face_hint;
            }
        }
        if (best_min < 0.0) return false;
        const std::int32_t m = s_.add_vertex(best_point);
        c_.vertex_face.push_back(best_face);
        for (const auto f : faces_) {
            const auto tf = s_.faces[std::size_t(f)];
            const auto h = halves(tf, x, y);
            const auto put = [m](std::array<std::int32_t, 3> t) {
                for (auto& v : t)
                    if (v < 0) v = m;
                return t;
            };
            s_.faces[std::size_t(f)] = put(h[0]);
            const auto t1 = put(h[1]);
            s_.add_face(t1[0], t1[1], t1[2], s_.region_in[std::size_t(f)],
                        s_.region_out[std::size_t(f)]);
            c_.face_patch.push_back(c_.face_patch[std::size_t(f)]);
        }
        if (ce.curve >= 0) inserts.push_back({ce.curve, ce.k, best_s, m});
        return true;
    }

    // The two faces that replace t when its edge {x, y} is split, in t's orientation; -1
    // stands for the new vertex.
    static std::array<std::array<std::int32_t, 3>, 2> halves(const std::array<std::int32_t, 3>& t,
                                                             std::int32_t x, std::int32_t y) {
        for (int i = 0; i < 3; ++i) {
            const auto u = t[std::size_t(i)], v = t[std::size_t((i + 1) % 3)];
            if ((u == x && v == y) || (u == y && v == x)) {
                const auto w = t[std::size_t((i + 2) % 3)];
                return {{{u, -1, w}, {-1, v, w}}};
            }
        }
        FM_THROW(InternalError, "split_obtuse_faces: a face of an edge does not hold it");
    }

    core::SurfaceNetwork& s_;
    const std::vector<const BackgroundPatch*>& patches_;
    SurfaceConstraints& c_;
    double max_angle_;
    double guard_;
    std::vector<Polyline> polylines_;
    std::vector<std::int32_t> faces_;
};

}  // namespace

std::size_t split_obtuse_faces(core::SurfaceNetwork& surface,
                               const std::vector<const BackgroundPatch*>& patches,
                               SurfaceConstraints& constraints, double max_angle_deg,
                               double guard_deg) {
    FM_CHECK(constraints.face_patch.size() == surface.face_count());
    FM_CHECK(constraints.vertex_face.size() == surface.vertex_count());
    Splitter splitter(surface, patches, constraints, max_angle_deg, guard_deg);
    std::size_t splits = 0;
    // Each pass splits only faces with an angle over max_angle_deg into faces whose largest
    // angle is at least 5 degrees smaller: three passes bound the work.
    for (int pass = 0; pass < 3; ++pass) {
        const std::size_t made = splitter.pass();
        splits += made;
        if (made == 0) break;
    }
    return splits;
}

}  // namespace frontmesh::surface
