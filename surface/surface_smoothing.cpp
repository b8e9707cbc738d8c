#include "surface/surface_smoothing.h"

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <numbers>
#include <optional>
#include <string>
#include <unordered_map>
#include <unordered_set>

#include "pipeline/core/error.h"
#include "pipeline/core/quality.h"
#include "surface/features.h"
#include "surface/polyline.h"

namespace frontmesh::surface {

namespace {

enum class Kind : std::uint8_t { Free, Curve, Fixed };

struct CurveSlot {
    std::int32_t curve = -1;
    std::int32_t index = -1;  // position in SurfaceCurve::vertices
};

Eigen::Vector3d raw_normal(const core::SurfaceNetwork& s, const std::array<std::int32_t, 3>& t) {
    return (s.point(t[1]) - s.point(t[0])).cross(s.point(t[2]) - s.point(t[0]));
}

// Interior dihedral angle (degrees, in (0, 360)) of `region` at edge (a, b) between its faces
// f and g, each seen from the region (normal out of region_in: reversed when the region is
// f's region_out): the region's wedge there.
double region_wedge_deg(const core::SurfaceNetwork& s, core::Label region, std::int32_t a,
                        std::int32_t b, std::int32_t f, std::int32_t g) {
    const auto& tf = s.faces[std::size_t(f)];
    const auto& tg = s.faces[std::size_t(g)];
    bool a_to_b = false;  // f holds a -> b as stored
    for (int i = 0; i < 3; ++i)
        if (tf[std::size_t(i)] == a && tf[std::size_t((i + 1) % 3)] == b) a_to_b = true;
    if (s.region_in[std::size_t(f)] != region) a_to_b = !a_to_b;
    const std::int32_t from = a_to_b ? a : b, to = a_to_b ? b : a;
    const auto third = [a, b](const std::array<std::int32_t, 3>& t) {
        for (const auto x : t)
            if (x != a && x != b) return x;
        return t[0];
    };
    const Eigen::Vector3d A = s.point(from), B = s.point(to);
    const Eigen::Vector3d c1 = s.point(third(tf)) - A, c2 = s.point(third(tg)) - A;
    const Eigen::Vector3d e = (B - A).normalized();
    const Eigen::Vector3d p1 = c1 - c1.dot(e) * e, p2 = c2 - c2.dot(e) * e;
    const double theta = std::atan2(p1.cross(p2).norm(), p1.dot(p2)) * 180.0 / std::numbers::pi;
    const bool convex = (B - A).cross(c1).dot(c2) < 0.0;  // c2 behind f, seen from the region
    return convex ? theta : 360.0 - theta;
}

// Smallest wedge of any region with exactly two of `faces` (the faces on edge (a, b)); with
// `folds`, a wedge w counts as min(w, 360 - w) (thin_region_wedges: faces on each other).
// With `deficit`, also adds up target - w over the wedges w under `target`; with `outside`,
// also takes the outside's (label 0) smallest wedge there, kept apart (no tet lies in it).
template <class Faces>
double smallest_edge_wedge(const core::SurfaceNetwork& s, std::int32_t a, std::int32_t b,
                           const Faces& faces, bool folds = false, double* deficit = nullptr,
                           double target = 0.0, double* outside = nullptr) {
    double smallest = 360.0;
    const std::size_t n = faces.size();
    for (std::size_t i = 0; i < n; ++i)
        for (const core::Label r :
             {s.region_in[std::size_t(faces[i])], s.region_out[std::size_t(faces[i])]}) {
            if (r == 0 && !outside) continue;
            std::int32_t other = -1;
            int uses = 0;
            bool seen_before = false;
            for (std::size_t j = 0; j < n; ++j) {
                const auto fj = std::size_t(faces[j]);
                if (s.region_in[fj] != r && s.region_out[fj] != r) continue;
                ++uses;
                if (j < i) seen_before = true;
                if (j != i) other = faces[j];
            }
            if (uses != 2 || seen_before) continue;  // each region once
            // With `folds`: the other regions at the edge share 360 - w, so min(w, 360 - w)
            // leaves a consistent smallest wedge as it is; where two faces lie on each other
            // (a region closed on itself, torture seed 67) w comes out as 0 or 360 by
            // rounding, and this takes 0.
            const double w = region_wedge_deg(s, r, a, b, faces[i], other);
            if (r == 0) {
                *outside = std::min(*outside, w);
                continue;
            }
            smallest = std::min(smallest, folds ? std::min(w, 360.0 - w) : w);
            if (deficit && w < target) *deficit += target - w;
        }
    return smallest;
}

double global_min_angle(const core::SurfaceNetwork& s) {
    double smallest = 180.0;
    for (const auto& t : s.faces)
        smallest = std::min(
            smallest, core::triangle_min_angle_deg(s.point(t[0]), s.point(t[1]), s.point(t[2])));
    return smallest;
}

// A spike tip's fan (ForcedTet): the tet (T, x, y, z), T first, positive while the cone of
// `region` at T is convex.
struct FanTet {
    std::array<std::int32_t, 4> v{};
    core::Label region = 0;
};

// The fan of region r at t when it has exactly the three faces `fan` (increasing ids) closing
// a convex cone with a region wedge under `wedge_below_deg` at one of its edges.
std::optional<FanTet> fan_tet(const core::SurfaceNetwork& s, std::int32_t t, core::Label r,
                              const std::array<std::int32_t, 3>& fan, double wedge_below_deg) {
    // (t, x, y) with its normal out of r; z the third ring vertex.
    const auto& t0 = s.faces[std::size_t(fan[0])];
    int k = 0;
    while (t0[std::size_t(k)] != t) ++k;
    std::int32_t x = t0[std::size_t((k + 1) % 3)], y = t0[std::size_t((k + 2) % 3)];
    if (s.region_in[std::size_t(fan[0])] != r) std::swap(x, y);
    std::int32_t z = -1;
    for (const std::int32_t f : {fan[1], fan[2]}) {
        int ring = 0;  // the three faces close a cone around t: ring {x, y, z}
        for (const auto u : s.faces[std::size_t(f)]) {
            if (u == t) continue;
            if (u != x && u != y) {
                if (z >= 0 && z != u) return std::nullopt;
                z = u;
            }
            ++ring;
        }
        if (ring != 2) return std::nullopt;
    }
    // Convex: z behind (t, x, y) seen from r.
    if (z < 0 || !(core::tet_signed_volume(s.point(t), s.point(x), s.point(y), s.point(z)) < 0.0))
        return std::nullopt;
    double smallest = 360.0;
    for (const std::int32_t u : {x, y, z}) {
        std::array<std::int32_t, 2> pair{-1, -1};
        int n = 0;
        for (const std::int32_t f : fan)
            for (const auto w : s.faces[std::size_t(f)])
                if (w == u && n < 2) pair[std::size_t(n++)] = f;
        if (n == 2) smallest = std::min(smallest, region_wedge_deg(s, r, t, u, pair[0], pair[1]));
    }
    if (!(smallest < wedge_below_deg)) return std::nullopt;
    return FanTet{{t, y, x, z}, r};
}

// Every vertex with exactly three faces of a region (not the outside) whose cone there is
// convex and has a region wedge under `wedge_below_deg` at one of its three edges, in
// (vertex, region) order. `offsets`/`incident`: vertex_faces of s.
std::vector<FanTet> fan_tets(const core::SurfaceNetwork& s,
                             const std::vector<std::int32_t>& offsets,
                             const std::vector<std::int32_t>& incident, double wedge_below_deg) {
    std::vector<FanTet> fans;
    std::vector<core::Label> regions;
    for (std::size_t v = 0; v < s.vertex_count(); ++v) {
        const auto b = std::size_t(offsets[v]), e = std::size_t(offsets[v + 1]);
        regions.clear();
        for (auto k = b; k < e; ++k)
            for (const core::Label r :
                 {s.region_in[std::size_t(incident[k])], s.region_out[std::size_t(incident[k])]})
                if (r != 0) regions.push_back(r);
        std::sort(regions.begin(), regions.end());
        for (std::size_t i = 0; i < regions.size();) {
            std::size_t j = i;
            while (j < regions.size() && regions[j] == regions[i]) ++j;
            if (j - i == 3) {
                const core::Label r = regions[i];
                std::array<std::int32_t, 3> fan{};
                std::size_t n = 0;
                for (auto k = b; k < e; ++k) {
                    const auto f = std::size_t(incident[k]);
                    if (s.region_in[f] == r || s.region_out[f] == r) fan[n++] = incident[k];
                }
                if (auto tet = fan_tet(s, static_cast<std::int32_t>(v), r, fan, wedge_below_deg))
                    fans.push_back(*tet);
            }
            i = j;
        }
    }
    return fans;
}

// Smallest dihedral angle of a fan's tet; 0 once it inverts (the cone is no longer convex).
double fan_tet_angle(const core::SurfaceNetwork& s, const FanTet& fan) {
    const Eigen::Vector3d a = s.point(fan.v[0]), b = s.point(fan.v[1]), c = s.point(fan.v[2]),
                          d = s.point(fan.v[3]);
    return core::tet_signed_volume(a, b, c, d) > 0.0 ? core::tet_min_dihedral_deg(a, b, c, d) : 0.0;
}

class Smoother {
public:
    Smoother(core::SurfaceNetwork& s, const std::vector<const BackgroundPatch*>& patches,
             SurfaceConstraints& c, const SmoothingParams& p)
        : s_(s), patches_(patches), c_(c), p_(p) {
        const std::size_t n = s.vertex_count();
        FM_CHECK(c.face_patch.size() == s.face_count());
        FM_CHECK(c.vertex_face.size() == n);
        kind_.assign(n, Kind::Free);
        slot_.assign(n, {});
        polylines_.resize(c.curves.size());
        for (std::size_t ci = 0; ci < c.curves.size(); ++ci) {
            const SurfaceCurve& curve = c.curves[ci];
            FM_CHECK(curve.vertices.size() == curve.s.size() && curve.vertices.size() >= 2);
            polylines_[ci] = Polyline::of(curve.polyline);
            const std::size_t last = curve.vertices.size() - 1;
            for (std::size_t k = 0; k <= last; ++k) {
                const auto v = std::size_t(curve.vertices[k]);
                const bool end = k == 0 || k == last;
                if (end && !(curve.is_closed && k == 0)) {
                    if (!(curve.is_closed && k == last)) kind_[v] = Kind::Fixed;
                    continue;
                }
                if (kind_[v] != Kind::Free) {
                    kind_[v] = Kind::Fixed;  // on two curves: a corner in all but name
                    continue;
                }
                kind_[v] = Kind::Curve;
                slot_[v] = {static_cast<std::int32_t>(ci), static_cast<std::int32_t>(k)};
            }
        }
        cos_turn_ = std::cos(p.max_normal_turn_deg * std::numbers::pi / 180.0);
        cos_flat_ = std::cos(p.flip_max_dihedral_deg * std::numbers::pi / 180.0);
        build_incidence();
        guard_deg_ = std::min(p.wedge_target_deg, 20.0);
        jmask_.assign(s.face_count(), 0);
        if (guard_deg_ > 0.0) build_junctions();
        // A free vertex whose faces lie on several patches has no single surface to move on.
        for (std::size_t v = 0; v < n; ++v) {
            if (kind_[v] != Kind::Free) continue;
            const auto b = offsets_[v], e = offsets_[v + 1];
            if (b == e) {
                kind_[v] = Kind::Fixed;
                continue;
            }
            const auto patch = c.face_patch[std::size_t(incident_[std::size_t(b)])];
            for (auto k = b; k < e; ++k)
                if (c.face_patch[std::size_t(incident_[std::size_t(k)])] != patch)
                    kind_[v] = Kind::Fixed;
        }
    }

    std::size_t smooth_pass() {
        std::size_t moves = 0;
        for (std::size_t v = 0; v < s_.vertex_count(); ++v) {
            const auto vi = static_cast<std::int32_t>(v);
            if (kind_[v] == Kind::Free) {
                if (move_free(vi)) ++moves;
            } else if (kind_[v] == Kind::Curve) {
                if (move_on_curve(vi)) ++moves;
            }
        }
        return moves;
    }

    // The last pass for the worst faces (smallest angle under `below_deg`): each free vertex
    // of such a face tries steps of 5 to 35% of its mean ring edge towards and away from
    // every ring vertex, projected onto its patch, and takes the position with the best
    // star (Zhou & Shimada's bisector move settles on a compromise its ring allows; a
    // direct search lifts a cap whose vertex sits next to a curve edge). Returns the moves.
    std::size_t worst_pass(double below_deg) {
        const std::vector<std::int32_t> candidates = vertices_of_poor_faces(below_deg, Kind::Free);
        std::size_t moves = 0;
        for (const std::int32_t v : candidates) {
            star_normals(v, normals_);
            double best = star_quality(v, nullptr);
            const double wedge_before = star_wedge(v);
            const auto better = [&] {
                const double q = star_quality(v, &normals_);
                if (!(q > best + 1e-9 && wedge_kept(wedge_before, star_wedge(v)))) return false;
                best = q;
                return true;
            };
            if (patch_search(v, {0.05, 0.12, 0.2, 0.35}, better)) ++moves;
        }
        return moves;
    }

    // The last pass, after the wedge and tip passes: each curve vertex of a face under
    // `below_deg` slides along its curve (2.5 to 35% of the gap between its curve
    // neighbours) to the position with the best star. In a patch narrower than its curve
    // spacing every vertex lies on a curve, and only the stagger of the two sides sets the
    // angles (AAL's patch 24/0 near (14, 50, 21) mm, 0.13 mm wide, had 18.4 deg faces). A
    // move keeps the region wedges and the listed spike-tip tets it touches from dropping
    // (below their value before, capped at `guard_deg`), which the earlier passes raised.
    // Returns the moves.
    std::size_t curve_pass(double below_deg, double guard_deg) {
        const std::vector<std::int32_t> candidates = vertices_of_poor_faces(below_deg, Kind::Curve);
        std::size_t moves = 0;
        for (const std::int32_t v : candidates) {
            star_normals(v, normals_);
            double best = star_quality(v, nullptr);
            const double wedge_floor = std::min(star_wedge(v), guard_deg) - 1e-9;
            const double tip_floor = std::min(tip_angle(v), guard_deg) - 1e-9;
            const auto better = [&] {
                const double q = star_quality(v, &normals_);
                if (!(q > best + 1e-9) || star_wedge(v) < wedge_floor || tip_angle(v) < tip_floor)
                    return false;
                best = q;
                return true;
            };
            if (curve_search(v, {0.025, 0.06, 0.1, 0.15, 0.25, 0.35}, better)) ++moves;
        }
        return moves;
    }

    // The vertices of kind `kind` of the faces whose smallest angle is under `below_deg`, in
    // id order, each once (the candidates of the worst and curve passes).
    std::vector<std::int32_t> vertices_of_poor_faces(double below_deg, Kind kind) const {
        std::vector<std::int32_t> vertices;
        for (const auto& t : s_.faces)
            if (min_angle(t) < below_deg)
                for (const auto v : t)
                    if (kind_[std::size_t(v)] == kind) vertices.push_back(v);
        std::sort(vertices.begin(), vertices.end());
        vertices.erase(std::unique(vertices.begin(), vertices.end()), vertices.end());
        return vertices;
    }

    std::size_t flip_pass() {
        const EdgeTable et = edge_table(s_);
        std::unordered_set<std::int64_t> edges;
        edges.reserve(et.edge_count() * 2);
        const std::int64_t n = static_cast<std::int64_t>(s_.vertex_count());
        auto key = [n](std::int32_t a, std::int32_t b) {
            return std::int64_t(std::min(a, b)) * n + std::max(a, b);
        };
        std::vector<std::int32_t> valence(s_.vertex_count(), 0);
        for (const auto& e : et.vertices) {
            edges.insert(key(e[0], e[1]));
            ++valence[std::size_t(e[0])];
            ++valence[std::size_t(e[1])];
        }
        std::vector<std::uint8_t> dirty(s_.face_count(), 0);
        std::size_t flips = 0;
        for (std::size_t e = 0; e < et.edge_count(); ++e) {
            if (et.face_count(static_cast<std::int32_t>(e)) != 2) continue;
            const std::int32_t f = et.edge_faces[std::size_t(et.face_offsets[e])];
            const std::int32_t g = et.edge_faces[std::size_t(et.face_offsets[e]) + 1];
            if (dirty[std::size_t(f)] || dirty[std::size_t(g)]) continue;
            if (c_.face_patch[std::size_t(f)] != c_.face_patch[std::size_t(g)]) continue;
            auto [a, b] = et.vertices[e];
            const auto& tf = s_.faces[std::size_t(f)];
            const auto& tg = s_.faces[std::size_t(g)];
            // Orient: f holds a -> b.
            int i = 0;
            while (i < 3 && !(tf[std::size_t(i)] == a && tf[std::size_t((i + 1) % 3)] == b)) ++i;
            if (i == 3) {
                std::swap(a, b);
                i = 0;
                while (i < 3 && !(tf[std::size_t(i)] == a && tf[std::size_t((i + 1) % 3)] == b))
                    ++i;
                if (i == 3) continue;
            }
            const std::int32_t c = tf[std::size_t((i + 2) % 3)];
            std::int32_t d = -1;
            for (int j = 0; j < 3; ++j)
                if (tg[std::size_t(j)] == b && tg[std::size_t((j + 1) % 3)] == a)
                    d = tg[std::size_t((j + 2) % 3)];
            if (d < 0 || c == d || edges.count(key(c, d))) continue;
            if (valence[std::size_t(a)] <= 3 || valence[std::size_t(b)] <= 3) continue;
            const std::array<std::int32_t, 3> nf{c, a, d}, ng{d, b, c};
            const Eigen::Vector3d of = raw_normal(s_, tf).normalized();
            const Eigen::Vector3d og = raw_normal(s_, tg).normalized();
            const double before = std::min(min_angle(tf), min_angle(tg));
            // A pair holding a poor face (smallest angle under 20 degrees) may flip over a
            // bend of up to 30 degrees: better a slightly coarser bend than the poor face.
            const double cos_flat = before < 20.0 ? std::min(cos_flat_, kCosBadFlat) : cos_flat_;
            if (of.dot(og) < cos_flat) continue;
            const Eigen::Vector3d n1 = raw_normal(s_, nf), n2 = raw_normal(s_, ng);
            if (n1.norm() <= 0.0 || n2.norm() <= 0.0) continue;
            const Eigen::Vector3d u1 = n1.normalized(), u2 = n2.normalized();
            const Eigen::Vector3d mean = of + og;
            if (u1.dot(u2) < cos_flat || u1.dot(mean) <= 0.0 || u2.dot(mean) <= 0.0) continue;
            const double after = std::min(min_angle(nf), min_angle(ng));
            if (!(after > before + 1e-6)) continue;
            if (!flip_faces(f, g, nf, ng, true)) continue;
            edges.erase(key(a, b));
            edges.insert(key(c, d));
            --valence[std::size_t(a)];
            --valence[std::size_t(b)];
            ++valence[std::size_t(c)];
            ++valence[std::size_t(d)];
            dirty[std::size_t(f)] = dirty[std::size_t(g)] = 1;
            ++flips;
        }
        if (flips > 0) build_incidence();
        return flips;
    }

    // Raises the region wedges under `target_deg` at junction edges (edges of three or more
    // faces, where patches meet): the interior dihedral angle of a region between its two
    // faces there, which bounds every dihedral angle of a tetrahedron of that region on the
    // edge. The chords of a coarse patch next to a corner of the curve network can close a
    // wedge of 30 degrees on the background to under 10. Per thin edge, in edge order: each
    // free vertex of its faces tries steps along its patch (as in worst_pass), each curve
    // vertex steps along its curve, then the inner edges of its faces are flipped (within a
    // bend of 30 degrees); a change is kept when it raises the smallest wedge of the faces it
    // changes (capped at the target, then the thin edge's own) and no face folds or drops
    // under min(its angle before, kWedgeMinAngleDeg). Returns moves + flips.
    std::size_t wedge_pass(double target_deg) {
        std::size_t changes = 0;
        std::vector<std::int32_t> verts;
        for (const std::int64_t k : junction_keys_) {
            if (edge_wedge(k) >= target_deg) continue;
            junction_vertices(k, verts);
            for (const std::int32_t v : verts) {
                if (edge_wedge(k) >= target_deg) break;
                if (kind_[std::size_t(v)] != Kind::Fixed) changes += raise_wedge(v, k, target_deg);
            }
            if (edge_wedge(k) < target_deg) changes += raise_wedge_flip(k, target_deg);
        }
        return changes;
    }

    // Raises the tets of spike tips (ForcedTet): lists the convex three-face fans with a
    // region wedge under `list_below_deg` (their tet is the only one reaching half that wedge
    // there), kept for the tip passes (which move vertices, no flips).
    void build_tips(double list_below_deg) {
        fans_ = fan_tets(s_, offsets_, incident_, list_below_deg);
        const std::size_t n = s_.vertex_count();
        fan_offsets_.assign(n + 1, 0);
        for (const FanTet& fan : fans_)
            for (const auto v : fan.v) ++fan_offsets_[std::size_t(v) + 1];
        for (std::size_t v = 0; v < n; ++v) fan_offsets_[v + 1] += fan_offsets_[v];
        fan_list_.assign(std::size_t(fan_offsets_[n]), 0);
        std::vector<std::int32_t> fill(fan_offsets_.begin(), fan_offsets_.end() - 1);
        for (std::size_t i = 0; i < fans_.size(); ++i)
            for (const auto v : fans_[i].v)
                fan_list_[std::size_t(fill[std::size_t(v)]++)] = static_cast<std::int32_t>(i);
    }

    // Per listed fan under `target_deg`, in list order: each free or curve vertex of its tet
    // (in id order) tries steps along its patch or curve (as the wedge pass) and keeps the one
    // that raises the smallest tet angle of the fans it touches (capped at the target), then
    // this fan's, with no face folding or dropping under min(its angle, kWedgeMinAngleDeg)
    // and no region wedge dropping under min(its value, the guard, the raised tet angle). In
    // a thin fin the tet (T, a, b, c) is a sliver whose small angles at a-c and b-c shrink as
    // the far vertex c leaves the line ab: the moves bring c in (or a and b out). Returns the
    // moves.
    std::size_t tip_pass(double target_deg) {
        std::size_t changes = 0;
        for (std::size_t i = 0; i < fans_.size(); ++i) {
            if (fan_tet_angle(s_, fans_[i]) >= target_deg) continue;
            std::array<std::int32_t, 4> verts = fans_[i].v;
            std::sort(verts.begin(), verts.end());
            for (const std::int32_t v : verts) {
                if (fan_tet_angle(s_, fans_[i]) >= target_deg) break;
                if (kind_[std::size_t(v)] != Kind::Fixed) changes += raise_tip(v, i, target_deg);
            }
        }
        return changes;
    }

    // The last resort for region wedges still under `target_deg` after the wedge pass (and
    // the curve pass): there the background itself is that thin (a region tapering to a
    // knife edge between two others, AICHA's 1.6 degrees), and no position on it opens the
    // wedge. Each vertex of the edge's faces but corners tries offsets off the background
    // (opening_search); a wedge w at an edge whose far vertex sits d from it
    // opens by about offset / d radians per side, so offsets of at most kOpenStep of the
    // local edge raise a 2 degree wedge past 10. Kept when no face folds or drops under
    // min(its angle, kWedgeMinAngleDeg), no listed tip drops under min(its angle, the target),
    // no wedge of the outside drops under min(its value, the target), the smallest touched
    // wedge (capped at the target) does not drop and it or the sum of the touched wedges'
    // shortfalls under the target improves. Returns the moves.
    std::size_t open_wedge_pass(double target_deg) {
        std::size_t changes = 0;
        std::vector<std::int32_t> verts;
        for (const std::int64_t k : junction_keys_) {
            if (edge_wedge(k) >= target_deg) continue;
            junction_vertices(k, verts);
            for (const std::int32_t v : verts) {
                if (edge_wedge(k) >= target_deg) break;
                if (kind_[std::size_t(v)] == Kind::Fixed) continue;
                star_normals(v, normals_);
                const double floor = std::min(star_quality(v, nullptr), kWedgeMinAngleDeg);
                // Better: the smallest touched wedge (capped at the target) not lower, and
                // it or the deficit under the target smaller.
                double best_touched = std::min(star_wedge(v), target_deg), outside_before = 0.0;
                double best_deficit = star_wedge_deficit(v, target_deg, outside_before);
                const double outside_floor = std::min(outside_before, target_deg);
                const double tip_before = tip_angle(v);
                const auto better = [&] {
                    const double q = star_quality(v, &normals_);
                    if (q <= 0.0 || q < floor) return false;
                    if (tip_angle(v) < std::min(tip_before, target_deg) - 1e-9) return false;
                    const double touched = std::min(star_wedge(v), target_deg);
                    if (touched < best_touched - 1e-9) return false;
                    double outside = 0.0;
                    const double deficit = star_wedge_deficit(v, target_deg, outside);
                    if (outside < outside_floor - 1e-9) return false;
                    if (!(touched > best_touched + 1e-6 || deficit < best_deficit - 1e-6))
                        return false;
                    best_touched = touched, best_deficit = deficit;
                    return true;
                };
                changes += opening_search(v, better) ? 1 : 0;
            }
        }
        return changes;
    }

    // As open_wedge_pass for the listed fans (spike tips) whose tet stays under `target_deg`
    // after the tip pass: their vertices but corners try offsets off the background, under the tip
    // pass's rules. Returns the moves.
    std::size_t open_tip_pass(double target_deg) {
        std::size_t changes = 0;
        for (std::size_t i = 0; i < fans_.size(); ++i) {
            if (fan_tet_angle(s_, fans_[i]) >= target_deg) continue;
            std::array<std::int32_t, 4> verts = fans_[i].v;
            std::sort(verts.begin(), verts.end());
            for (const std::int32_t v : verts) {
                if (fan_tet_angle(s_, fans_[i]) >= target_deg) break;
                if (kind_[std::size_t(v)] == Kind::Fixed) continue;
                star_normals(v, normals_);
                const double floor = std::min(star_quality(v, nullptr), kWedgeMinAngleDeg);
                const double wedge_before = star_wedge(v);
                double outside_before = 0.0;
                star_wedge_deficit(v, target_deg, outside_before);
                const double outside_floor = std::min(outside_before, target_deg);
                double best_touched = vertex_fan_angle(v), best_own = fan_tet_angle(s_, fans_[i]);
                const auto better = [&] {
                    const double q = star_quality(v, &normals_);
                    if (q <= 0.0 || q < floor) return false;
                    double outside = 0.0;
                    star_wedge_deficit(v, target_deg, outside);
                    if (outside < outside_floor - 1e-9) return false;
                    const double touched = vertex_fan_angle(v), own = fan_tet_angle(s_, fans_[i]);
                    if (!wedge_better(touched, own, best_touched, best_own, target_deg))
                        return false;
                    if (star_wedge(v) < std::min({wedge_before, guard_deg_, touched}) - 1e-9)
                        return false;
                    best_touched = touched, best_own = own;
                    return true;
                };
                changes += opening_search(v, better) ? 1 : 0;
            }
        }
        return changes;
    }

    /// The smallest tet angle of the listed fans (degrees; 180 when there is none).
    double min_forced_tet() const {
        double smallest = 180.0;
        for (const FanTet& fan : fans_) smallest = std::min(smallest, fan_tet_angle(s_, fan));
        return smallest;
    }

    /// The smallest region wedge over all junction edges (degrees; 360 when there is none).
    double min_wedge() const {
        double smallest = 360.0;
        for (const std::int64_t k : junction_keys_) smallest = std::min(smallest, edge_wedge(k));
        return smallest;
    }

private:
    // --- Region wedges at junction edges -------------------------------------------------

    std::int64_t edge_key(std::int32_t a, std::int32_t b) const {
        return std::int64_t(std::min(a, b)) * std::int64_t(s_.vertex_count()) + std::max(a, b);
    }

    void build_junctions() {
        const EdgeTable et = edge_table(s_);
        junction_.clear();
        junction_keys_.clear();
        for (std::size_t e = 0; e < et.edge_count(); ++e) {
            if (et.face_count(static_cast<std::int32_t>(e)) < 3) continue;
            const std::int64_t k = edge_key(et.vertices[e][0], et.vertices[e][1]);
            junction_keys_.push_back(k);
            junction_[k];  // faces linked below
        }
        std::sort(junction_keys_.begin(), junction_keys_.end());
        jmask_.assign(s_.face_count(), 0);
        for (std::size_t f = 0; f < s_.face_count(); ++f) link(static_cast<std::int32_t>(f));
    }

    // Records face f on its junction edges (after its vertices changed) / removes it.
    void link(std::int32_t f) {
        const auto& t = s_.faces[std::size_t(f)];
        for (int i = 0; i < 3; ++i) {
            const auto it =
                junction_.find(edge_key(t[std::size_t(i)], t[std::size_t((i + 1) % 3)]));
            if (it == junction_.end()) continue;
            it->second.push_back(f);
            jmask_[std::size_t(f)] |= std::uint8_t(1u << i);
        }
    }
    void unlink(std::int32_t f) {
        const auto& t = s_.faces[std::size_t(f)];
        for (int i = 0; i < 3; ++i) {
            if (!(jmask_[std::size_t(f)] & (1u << i))) continue;
            auto& list = junction_.at(edge_key(t[std::size_t(i)], t[std::size_t((i + 1) % 3)]));
            list.erase(std::find(list.begin(), list.end(), f));
        }
        jmask_[std::size_t(f)] = 0;
    }

    // The vertices of the faces at junction edge k, increasing.
    void junction_vertices(std::int64_t k, std::vector<std::int32_t>& verts) const {
        verts.clear();
        for (const std::int32_t f : junction_.at(k))
            for (const auto x : s_.faces[std::size_t(f)]) verts.push_back(x);
        std::sort(verts.begin(), verts.end());
        verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
    }

    // Smallest region wedge at junction edge k: every region with exactly two faces there,
    // folded (min(w, 360 - w)). Unfolded, a face turned past its neighbour at the edge reads
    // as a wide wedge of about 360 degrees while the region lies on itself (the regions
    // around the edge then add up to more than 360): natbrainlab's region 102 kept a fold of
    // 0.44 degrees between its faces with region 108 and the outside, which the guards took
    // for 359.56, and tetra could only fill it with tets of 1 degree.
    double edge_wedge(std::int64_t k) const {
        const std::int64_t n = std::int64_t(s_.vertex_count());
        return smallest_edge_wedge(s_, static_cast<std::int32_t>(k / n),
                                   static_cast<std::int32_t>(k % n), junction_.at(k), true);
    }

    double face_wedge(std::int32_t f, double smallest) const {
        const auto m = jmask_[std::size_t(f)];
        if (!m) return smallest;
        const auto& t = s_.faces[std::size_t(f)];
        for (int i = 0; i < 3; ++i)
            if (m & (1u << i))
                smallest = std::min(
                    smallest, edge_wedge(edge_key(t[std::size_t(i)], t[std::size_t((i + 1) % 3)])));
        return smallest;
    }

    // Smallest region wedge at the junction edges of the faces around v (360: none).
    double star_wedge(std::int32_t v) const {
        double smallest = 360.0;
        for (auto k = offsets_[std::size_t(v)]; k < offsets_[std::size_t(v) + 1]; ++k)
            smallest = face_wedge(incident_[std::size_t(k)], smallest);
        return smallest;
    }

    // The wedges under `target` at the junction edges of the faces around v, summed as
    // target - w: the opening passes' second measure, which sees a rise of one of two equal
    // smallest wedges (the two regions of a symmetric knife edge) that their minimum hides.
    // `outside`: the outside's smallest wedge there (360: none), which an opening move
    // squeezes: two regions opened towards each other across a slit of the outside close it.
    double star_wedge_deficit(std::int32_t v, double target, double& outside) {
        keys_.clear();
        for (auto k = offsets_[std::size_t(v)]; k < offsets_[std::size_t(v) + 1]; ++k) {
            const std::int32_t f = incident_[std::size_t(k)];
            const auto m = jmask_[std::size_t(f)];
            const auto& t = s_.faces[std::size_t(f)];
            for (int i = 0; i < 3; ++i)
                if (m & (1u << i))
                    keys_.push_back(edge_key(t[std::size_t(i)], t[std::size_t((i + 1) % 3)]));
        }
        std::sort(keys_.begin(), keys_.end());
        keys_.erase(std::unique(keys_.begin(), keys_.end()), keys_.end());
        const std::int64_t n = std::int64_t(s_.vertex_count());
        double deficit = 0.0;
        outside = 360.0;
        for (const std::int64_t key : keys_)
            smallest_edge_wedge(s_, static_cast<std::int32_t>(key / n),
                                static_cast<std::int32_t>(key % n), junction_.at(key), false,
                                &deficit, target, &outside);
        return deficit;
    }

    // A change may lower the smallest wedge it touches only while that stays >= the guard.
    bool wedge_kept(double before, double after) const {
        return after >= std::min(before, guard_deg_) - 1e-9;
    }

    // Lexicographic score of a wedge change: the touched minimum capped at the target, then
    // the thin edge's own wedge.
    static bool wedge_better(double touched, double own, double best_touched, double best_own,
                             double target) {
        touched = std::min(touched, target);
        best_touched = std::min(best_touched, target);
        if (touched > best_touched + 1e-6) return true;
        return touched > best_touched - 1e-9 && own > best_own + 1e-6;
    }

    // One wedge-pass move of free or curve vertex v for junction edge k.
    std::size_t raise_wedge(std::int32_t v, std::int64_t k, double target) {
        star_normals(v, normals_);
        const double floor = std::min(star_quality(v, nullptr), kWedgeMinAngleDeg);
        double best_touched = star_wedge(v), best_own = edge_wedge(k);
        const auto better = [&] {
            const double q = star_quality(v, &normals_);
            if (q <= 0.0 || q < floor) return false;
            const double touched = star_wedge(v), own = edge_wedge(k);
            if (!wedge_better(touched, own, best_touched, best_own, target)) return false;
            best_touched = touched, best_own = own;
            return true;
        };
        return search(v, better) ? 1 : 0;
    }

    // One tip-pass move of free or curve vertex v for listed fan `fan`.
    std::size_t raise_tip(std::int32_t v, std::size_t fan, double target) {
        star_normals(v, normals_);
        const double floor = std::min(star_quality(v, nullptr), kWedgeMinAngleDeg);
        const double wedge_before = star_wedge(v);
        double best_touched = vertex_fan_angle(v), best_own = fan_tet_angle(s_, fans_[fan]);
        const auto better = [&] {
            const double q = star_quality(v, &normals_);
            if (q <= 0.0 || q < floor) return false;
            const double touched = vertex_fan_angle(v), own = fan_tet_angle(s_, fans_[fan]);
            if (!wedge_better(touched, own, best_touched, best_own, target)) return false;
            // The fan's wedges at its own edges are dihedral angles of its tet: a wedge may
            // drop to the raised tet angle (no new bottleneck), not below it.
            if (star_wedge(v) < std::min({wedge_before, guard_deg_, touched}) - 1e-9) return false;
            best_touched = touched, best_own = own;
            return true;
        };
        return search(v, better) ? 1 : 0;
    }

    // vertex_fan_angle when the tip passes listed fans, else 180.
    double tip_angle(std::int32_t v) const {
        return fan_offsets_.size() == s_.vertex_count() + 1 ? vertex_fan_angle(v) : 180.0;
    }

    // Smallest tet angle of the listed fans with v in their tet (180: none).
    double vertex_fan_angle(std::int32_t v) const {
        double smallest = 180.0;
        for (auto k = fan_offsets_[std::size_t(v)]; k < fan_offsets_[std::size_t(v) + 1]; ++k)
            smallest = std::min(smallest,
                                fan_tet_angle(s_, fans_[std::size_t(fan_list_[std::size_t(k)])]));
        return smallest;
    }

    // The direct search of the wedge and tip passes: along the patch for a free vertex, along
    // the curve for a curve vertex.
    template <class Better>
    bool search(std::int32_t v, Better&& better) {
        if (kind_[std::size_t(v)] == Kind::Free)
            return patch_search(v, {0.05, 0.12, 0.2, 0.35, 0.5}, better);
        return curve_search(v, {0.025, 0.06, 0.1, 0.15, 0.25}, better);
    }

    // Direct search for free vertex v (worst_pass, wedge pass): steps of `steps` times the
    // mean ring edge towards and away from each ring vertex, projected onto v's patch. At
    // each trial point (v placed there) `better()` says whether it beats the best so far.
    // v ends at the best point and its face is recorded; false when none was better (v stays).
    template <class Better>
    bool patch_search(std::int32_t v, std::initializer_list<double> steps, Better&& better) {
        const auto b = offsets_[std::size_t(v)], e = offsets_[std::size_t(v) + 1];
        if (b == e) return false;
        ring_.clear();
        for (auto k = b; k < e; ++k)
            for (const auto x : s_.faces[std::size_t(incident_[std::size_t(k)])])
                if (x != v) ring_.push_back(x);
        std::sort(ring_.begin(), ring_.end());
        ring_.erase(std::unique(ring_.begin(), ring_.end()), ring_.end());
        const Eigen::Vector3d P = s_.point(v);
        double mean_edge = 0.0;
        for (const auto x : ring_) mean_edge += (s_.point(x) - P).norm();
        mean_edge /= double(ring_.size());
        Eigen::Vector3d best_point = P;
        std::int32_t best_face = -1;
        const BackgroundPatch& patch =
            *patches_[std::size_t(c_.face_patch[std::size_t(incident_[std::size_t(b)])])];
        const auto hint = c_.vertex_face[std::size_t(v)];
        for (const auto x : ring_) {
            const Eigen::Vector3d dir = (s_.point(x) - P).normalized();
            for (const double sign : {1.0, -1.0})
                for (const double step : steps) {
                    const Eigen::Vector3d goal = P + sign * step * mean_edge * dir;
                    const auto proj = hint >= 0 ? patch.project(goal, hint) : patch.project(goal);
                    s_.point(v) = proj.point;
                    if (better()) best_point = proj.point, best_face = proj.face;
                }
        }
        s_.point(v) = best_point;
        if (best_face < 0) return false;
        c_.vertex_face[std::size_t(v)] = best_face;
        return true;
    }

    // Direct search off the background for vertex v (the opening passes; curve vertices too,
    // off their curves: a region one triangle wide between two curves has only curve vertices
    // on its faces at the thin edge): offsets of kOpenSteps times the mean ring edge along the
    // star's summed normal and towards and away from each ring vertex. v ends at the best
    // point or stays (false); its face hint and arc length stay (nothing projects it after).
    template <class Better>
    bool opening_search(std::int32_t v, Better&& better) {
        const auto b = offsets_[std::size_t(v)], e = offsets_[std::size_t(v) + 1];
        if (b == e) return false;
        Eigen::Vector3d normal = Eigen::Vector3d::Zero();
        ring_.clear();
        for (auto k = b; k < e; ++k) {
            const auto& t = s_.faces[std::size_t(incident_[std::size_t(k)])];
            normal += raw_normal(s_, t);
            for (const auto x : t)
                if (x != v) ring_.push_back(x);
        }
        std::sort(ring_.begin(), ring_.end());
        ring_.erase(std::unique(ring_.begin(), ring_.end()), ring_.end());
        const Eigen::Vector3d P = s_.point(v);
        double mean_edge = 0.0;
        for (const auto x : ring_) mean_edge += (s_.point(x) - P).norm();
        mean_edge /= double(ring_.size());
        directions_.clear();
        if (normal.norm() > 0.0) directions_.push_back(normal.normalized());
        for (const auto x : ring_) directions_.push_back((s_.point(x) - P).normalized());
        Eigen::Vector3d best_point = P;
        bool moved = false;
        for (const Eigen::Vector3d& d : directions_)
            for (const double sign : {1.0, -1.0})
                for (const double step : kOpenSteps) {
                    s_.point(v) = P + sign * step * mean_edge * d;
                    if (better()) best_point = s_.point(v), moved = true;
                }
        s_.point(v) = best_point;
        return moved;
    }

    // Direct search for curve vertex v: steps of `steps` times the gap between its curve
    // neighbours, both ways along its curve, staying 15% of the gap from each; as
    // patch_search, v ends at the best point (its arc length recorded) or stays (false).
    template <class Better>
    bool curve_search(std::int32_t v, std::initializer_list<double> steps, Better&& better) {
        const CurveSlot slot = slot_[std::size_t(v)];
        SurfaceCurve& curve = c_.curves[std::size_t(slot.curve)];
        const Polyline& pl = polylines_[std::size_t(slot.curve)];
        const std::size_t i = std::size_t(slot.index);
        const std::size_t last = curve.vertices.size() - 1;
        const double length = pl.length();
        const double s_prev = i == 0 ? curve.s[last - 1] - length : curve.s[i - 1];
        const double s_next = i == 0 ? curve.s[1] : curve.s[i + 1];
        const double gap = s_next - s_prev;
        if (!(gap > 0.0)) return false;
        const Eigen::Vector3d P = s_.point(v);
        double best_s = curve.s[i];
        Eigen::Vector3d best_point = P;
        for (const double sign : {1.0, -1.0})
            for (const double step : steps) {
                const double s_new = curve.s[i] + sign * step * gap;
                if (s_new <= s_prev + 0.15 * gap || s_new >= s_next - 0.15 * gap) continue;
                const double w = length > 0.0 ? s_new - length * std::floor(s_new / length) : 0.0;
                s_.point(v) = pl.at(w);
                if (better()) best_s = s_new, best_point = s_.point(v);
            }
        s_.point(v) = best_point;
        if (best_s == curve.s[i]) return false;
        curve.s[i] = best_s;
        if (i == 0) curve.s[last] = best_s + length;
        return true;
    }

    // Flips an inner edge (two faces of one patch) of a face on junction edge k when that
    // raises the wedges of the pair. Returns the flips (incidence rebuilt after each).
    std::size_t raise_wedge_flip(std::int64_t k, double target) {
        std::size_t flips = 0;
        const std::vector<std::int32_t> faces = junction_.at(k);
        for (const std::int32_t f : faces) {
            for (int i = 0; i < 3; ++i) {
                if (edge_wedge(k) >= target) return flips;
                const auto tf = s_.faces[std::size_t(f)];
                if (jmask_[std::size_t(f)] & (1u << i)) continue;
                const std::int32_t a = tf[std::size_t(i)], b = tf[std::size_t((i + 1) % 3)],
                                   c = tf[std::size_t((i + 2) % 3)];
                std::int32_t g = -1, d = -1;
                for (auto j = offsets_[std::size_t(a)]; j < offsets_[std::size_t(a) + 1]; ++j) {
                    const std::int32_t h = incident_[std::size_t(j)];
                    const auto& th = s_.faces[std::size_t(h)];
                    for (int m = 0; m < 3; ++m)
                        if (th[std::size_t(m)] == b && th[std::size_t((m + 1) % 3)] == a)
                            g = h, d = th[std::size_t((m + 2) % 3)];
                }
                if (g < 0 || d == c ||
                    c_.face_patch[std::size_t(f)] != c_.face_patch[std::size_t(g)])
                    continue;
                if (offsets_[std::size_t(a) + 1] - offsets_[std::size_t(a)] <= 3 ||
                    offsets_[std::size_t(b) + 1] - offsets_[std::size_t(b)] <= 3)
                    continue;
                bool exists = false;  // edge c-d already there
                for (auto j = offsets_[std::size_t(c)]; j < offsets_[std::size_t(c) + 1] && !exists;
                     ++j)
                    for (const auto x : s_.faces[std::size_t(incident_[std::size_t(j)])])
                        exists |= x == d;
                if (exists) continue;
                const auto tg = s_.faces[std::size_t(g)];
                const std::array<std::int32_t, 3> nf{c, a, d}, ng{d, b, c};
                const Eigen::Vector3d of = raw_normal(s_, tf).normalized(),
                                      og = raw_normal(s_, tg).normalized();
                const Eigen::Vector3d n1 = raw_normal(s_, nf), n2 = raw_normal(s_, ng);
                if (n1.norm() <= 0.0 || n2.norm() <= 0.0) continue;
                const Eigen::Vector3d u1 = n1.normalized(), u2 = n2.normalized(), mean = of + og;
                if (of.dot(og) < kCosBadFlat || u1.dot(u2) < kCosBadFlat || u1.dot(mean) <= 0.0 ||
                    u2.dot(mean) <= 0.0)
                    continue;
                const double before_angle = std::min(min_angle(tf), min_angle(tg));
                if (std::min(min_angle(nf), min_angle(ng)) <
                    std::min(before_angle, kWedgeMinAngleDeg))
                    continue;
                const double touched = face_wedge(g, face_wedge(f, 360.0)), own = edge_wedge(k);
                flip_faces(f, g, nf, ng, false);
                const double touched_after = face_wedge(g, face_wedge(f, 360.0)),
                             own_after = edge_wedge(k);
                if (wedge_better(touched_after, own_after, touched, own, target)) {
                    build_incidence();
                    ++flips;
                } else {
                    flip_faces(f, g, tf, tg, false);
                }
            }
        }
        return flips;
    }

    // Replaces faces f and g by nf and ng (a flip inside a patch: the pair's outer edges, so
    // its junction edges, stay; incidence is the caller's). With `guard`, undone (false) when
    // the smallest wedge at those edges drops and ends under the guard.
    bool flip_faces(std::int32_t f, std::int32_t g, const std::array<std::int32_t, 3>& nf,
                    const std::array<std::int32_t, 3>& ng, bool guard) {
        const auto of = s_.faces[std::size_t(f)], og = s_.faces[std::size_t(g)];
        const bool junction = (jmask_[std::size_t(f)] | jmask_[std::size_t(g)]) != 0;
        const double before = junction ? face_wedge(g, face_wedge(f, 360.0)) : 360.0;
        const auto put = [&](const std::array<std::int32_t, 3>& a,
                             const std::array<std::int32_t, 3>& b) {
            unlink(f);
            unlink(g);
            s_.faces[std::size_t(f)] = a;
            s_.faces[std::size_t(g)] = b;
            link(f);
            link(g);
        };
        if (!junction) {
            s_.faces[std::size_t(f)] = nf;
            s_.faces[std::size_t(g)] = ng;
            return true;
        }
        put(nf, ng);
        if (!guard || wedge_kept(before, face_wedge(g, face_wedge(f, 360.0)))) return true;
        put(of, og);
        return false;
    }

    // -------------------------------------------------------------------------------------

    void build_incidence() { core::vertex_faces(s_, offsets_, incident_); }

    double min_angle(const std::array<std::int32_t, 3>& t) const {
        return core::triangle_min_angle_deg(s_.point(t[0]), s_.point(t[1]), s_.point(t[2]));
    }

    // Smallest angle of the faces around v, or -1 when one of them folds (turns by more
    // than the limit from `old_normals`) at the current position of v.
    double star_quality(std::int32_t v, const std::vector<Eigen::Vector3d>* old_normals) const {
        double smallest = 180.0;
        const auto b = offsets_[std::size_t(v)], e = offsets_[std::size_t(v) + 1];
        for (auto k = b; k < e; ++k) {
            const auto& t = s_.faces[std::size_t(incident_[std::size_t(k)])];
            if (old_normals) {
                const Eigen::Vector3d nn = raw_normal(s_, t);
                const double len = nn.norm();
                if (len <= 0.0 || nn.dot((*old_normals)[std::size_t(k - b)]) < cos_turn_ * len)
                    return -1.0;
            }
            smallest = std::min(smallest, min_angle(t));
        }
        return smallest;
    }

    void star_normals(std::int32_t v, std::vector<Eigen::Vector3d>& normals) const {
        normals.clear();
        for (auto k = offsets_[std::size_t(v)]; k < offsets_[std::size_t(v) + 1]; ++k) {
            const Eigen::Vector3d nn =
                raw_normal(s_, s_.faces[std::size_t(incident_[std::size_t(k)])]);
            const double len = nn.norm();
            normals.push_back(len > 0.0 ? Eigen::Vector3d(nn / len) : Eigen::Vector3d::Zero());
        }
    }

    // Tries position q for v (already on the surface); keeps it when the star does not get
    // worse. Restores the old position otherwise.
    bool try_position(std::int32_t v, const Eigen::Vector3d& q) {
        const Eigen::Vector3d old = s_.point(v);
        if ((q - old).squaredNorm() <= 0.0) return false;
        star_normals(v, normals_);
        const double before = star_quality(v, nullptr);
        const double wedge_before = star_wedge(v);
        s_.point(v) = q;
        const double after = star_quality(v, &normals_);
        if (after >= before && after > 0.0 && wedge_kept(wedge_before, star_wedge(v))) return true;
        s_.point(v) = old;
        return false;
    }

    bool move_free(std::int32_t v) {
        const auto b = offsets_[std::size_t(v)], e = offsets_[std::size_t(v) + 1];
        if (e - b < 3) return false;
        // Ring: directed edges x -> y of the faces (v, x, y).
        ring_next_.clear();
        for (auto k = b; k < e; ++k) {
            const auto& t = s_.faces[std::size_t(incident_[std::size_t(k)])];
            int i = 0;
            while (t[std::size_t(i)] != v) ++i;
            ring_next_.emplace_back(t[std::size_t((i + 1) % 3)], t[std::size_t((i + 2) % 3)]);
        }
        const Eigen::Vector3d P = s_.point(v);
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        int count = 0;
        for (const auto& [x, next] : ring_next_) {
            std::int32_t prev = -1;
            for (const auto& [y, z] : ring_next_)
                if (z == x) prev = y;
            if (prev < 0) return false;  // open ring: not a free interior vertex
            // Zhou & Shimada: rotate V_j -> P onto the bisector of the ring angle at V_j.
            const Eigen::Vector3d vj = s_.point(x);
            const Eigen::Vector3d a = (s_.point(prev) - vj).normalized();
            const Eigen::Vector3d c = (s_.point(next) - vj).normalized();
            const Eigen::Vector3d to_p = P - vj;
            Eigen::Vector3d bis = a + c;
            if (bis.norm() < 1e-6) bis = to_p;
            bis.normalize();
            if (bis.dot(to_p) < 0.0) bis = -bis;  // reflex ring angle
            sum += vj + to_p.norm() * bis;
            ++count;
        }
        const Eigen::Vector3d target = sum / count;
        const auto patch_index = c_.face_patch[std::size_t(incident_[std::size_t(b)])];
        const BackgroundPatch& patch = *patches_[std::size_t(patch_index)];
        for (const double step : {1.0, 0.5}) {
            const Eigen::Vector3d goal = P + step * (target - P);
            const auto hint = c_.vertex_face[std::size_t(v)];
            const auto proj = hint >= 0 ? patch.project(goal, hint) : patch.project(goal);
            if (try_position(v, proj.point)) {
                c_.vertex_face[std::size_t(v)] = proj.face;
                return true;
            }
        }
        return false;
    }

    bool move_on_curve(std::int32_t v) {
        const CurveSlot slot = slot_[std::size_t(v)];
        SurfaceCurve& curve = c_.curves[std::size_t(slot.curve)];
        const Polyline& pl = polylines_[std::size_t(slot.curve)];
        const std::size_t k = std::size_t(slot.index);
        const std::size_t last = curve.vertices.size() - 1;
        const double length = pl.length();
        double s_prev, s_next;
        if (k == 0) {  // first vertex of a closed curve
            s_prev = curve.s[last - 1] - length;
            s_next = curve.s[1];
        } else {
            s_prev = curve.s[k - 1];
            s_next = curve.s[k + 1];
        }
        const double target = 0.5 * (s_prev + s_next);
        for (const double step : {1.0, 0.5}) {
            const double s_new = curve.s[k] + step * (target - curve.s[k]);
            const double w = length > 0.0 ? s_new - length * std::floor(s_new / length) : 0.0;
            if (try_position(v, pl.at(w))) {
                curve.s[k] = s_new;
                if (k == 0) curve.s[last] = s_new + length;
                return true;
            }
        }
        return false;
    }

    core::SurfaceNetwork& s_;
    const std::vector<const BackgroundPatch*>& patches_;
    SurfaceConstraints& c_;
    const SmoothingParams& p_;
    std::vector<Kind> kind_;
    std::vector<CurveSlot> slot_;
    std::vector<Polyline> polylines_;
    std::vector<std::int32_t> offsets_, incident_;
    std::vector<Eigen::Vector3d> normals_;
    std::vector<std::int32_t> ring_;  // scratch of patch_search
    std::vector<std::pair<std::int32_t, std::int32_t>> ring_next_;
    std::unordered_map<std::int64_t, std::vector<std::int32_t>> junction_;  // edge -> its faces
    std::vector<std::int64_t> junction_keys_;  // sorted: the order of wedge_pass
    std::vector<std::uint8_t> jmask_;  // per face: bit i = edge (t[i], t[i+1]) is a junction edge
    std::vector<FanTet> fans_;         // spike tips of the tip passes
    std::vector<std::int32_t> fan_offsets_, fan_list_;  // CSR: vertex -> fans with it in their tet
    double cos_turn_ = 0.0, cos_flat_ = 1.0;
    static constexpr double kCosBadFlat = 0.8660254037844387;  // cos 30 degrees
    // Region wedges: no change may lower one under the guard (or lower one already under
    // it); wedge_pass keeps faces at >= min(their angle, kWedgeMinAngleDeg).
    std::vector<std::int64_t> keys_;           // star_wedge_deficit's scratch
    std::vector<Eigen::Vector3d> directions_;  // opening_search's scratch
    static constexpr double kWedgeMinAngleDeg = 22.0;
    // The opening passes' offsets off the background, in mean ring edges (at most kOpenStep).
    static constexpr double kOpenStep = 0.15;
    static constexpr std::array<double, 5> kOpenSteps{0.02, 0.04, 0.07, 0.1, kOpenStep};
    double guard_deg_ = 0.0;  // min(wedge_target_deg, 20); 0 = no guard
};

}  // namespace

std::vector<ThinWedge> thin_region_wedges(const core::SurfaceNetwork& surface, double below_deg) {
    const EdgeTable et = edge_table(surface);
    std::vector<ThinWedge> thin;
    for (std::size_t e = 0; e < et.edge_count(); ++e) {
        const auto b = std::size_t(et.face_offsets[e]), n = std::size_t(et.face_offsets[e + 1]) - b;
        if (n < 3) continue;
        const std::vector<std::int32_t> faces(et.edge_faces.begin() + std::ptrdiff_t(b),
                                              et.edge_faces.begin() + std::ptrdiff_t(b + n));
        const auto [v0, v1] = et.vertices[e];
        const double w = smallest_edge_wedge(surface, v0, v1, faces, true);
        if (w < below_deg) {
            std::vector<std::int32_t> sorted = faces;
            std::sort(sorted.begin(), sorted.end());
            thin.push_back({0.5 * (surface.point(v0) + surface.point(v1)), w, std::move(sorted)});
        }
    }
    return thin;
}

std::vector<ForcedTet> forced_tets(const core::SurfaceNetwork& surface,
                                   double fan_wedge_below_deg) {
    std::vector<ForcedTet> tips;
    std::vector<std::int32_t> offsets, incident;
    core::vertex_faces(surface, offsets, incident);
    for (const FanTet& fan : fan_tets(surface, offsets, incident, fan_wedge_below_deg))
        tips.push_back({surface.point(fan.v[0]), fan.region, fan_tet_angle(surface, fan)});
    return tips;
}

// The opening passes (open_thin_wedges) of a smoother whose tips are listed: moves off the
// background for the wedges, then the tips, still under their targets. Two passes each.
std::size_t open_passes(Smoother& smoother, const SmoothingParams& params) {
    if (!params.open_thin_wedges) return 0;
    std::size_t openings = 0;
    if (params.wedge_target_deg > 0.0)
        for (int pass = 0; pass < 2; ++pass) {
            const std::size_t changes = smoother.open_wedge_pass(params.wedge_target_deg);
            openings += changes;
            if (changes == 0) break;
        }
    if (params.tip_target_deg > 0.0)
        for (int pass = 0; pass < 2; ++pass) {
            const std::size_t changes = smoother.open_tip_pass(params.tip_target_deg);
            openings += changes;
            if (changes == 0) break;
        }
    return openings;
}

// Faces with a smallest angle under this get the direct search of worst_pass.
constexpr double kWorstAngleDeg = 25.0;
// Faces under this get the curve pass, the last one. As for the worst pass, the faces
// around a poor one take part and make room (at 20 degrees, AAL kept a face of 19.93).
constexpr double kWorstCurveAngleDeg = 25.0;

SmoothingReport smooth_surface(core::SurfaceNetwork& surface,
                               const std::vector<const BackgroundPatch*>& patches,
                               SurfaceConstraints& constraints, const SmoothingParams& params,
                               core::StageContext& ctx) {
    if (params.iterations < 0) FM_THROW(InputError, "remesh.smoothing_iterations: must be >= 0");
    for (const auto p : constraints.face_patch)
        FM_CHECK(p >= 0 && std::size_t(p) < patches.size() && patches[std::size_t(p)] != nullptr);
    SmoothingReport report;
    report.min_angle_before_deg = global_min_angle(surface);
    Smoother smoother(surface, patches, constraints, params);
    for (int it = 0; it < params.iterations; ++it) {
        const std::size_t moves = smoother.smooth_pass();
        const std::size_t flips = params.flip_edges ? smoother.flip_pass() : 0;
        report.moves += moves;
        report.flips += flips;
        ctx.progress(double(it + 1) / params.iterations, "smoothing");
        if (moves == 0 && flips == 0) break;
    }
    if (params.iterations > 0)
        for (int pass = 0; pass < 3; ++pass) {
            const std::size_t moves = smoother.worst_pass(kWorstAngleDeg);
            const std::size_t flips = params.flip_edges ? smoother.flip_pass() : 0;
            report.moves += moves;
            report.flips += flips;
            if (moves == 0 && flips == 0) break;
        }
    if (params.iterations > 0 && params.wedge_target_deg > 0.0) {
        report.min_wedge_before_deg = smoother.min_wedge();
        for (int pass = 0; pass < 4; ++pass) {
            const std::size_t changes = smoother.wedge_pass(params.wedge_target_deg);
            report.wedge_changes += changes;
            if (changes == 0) break;
        }
        report.min_wedge_after_deg = smoother.min_wedge();
        ctx.add("remesh.wedge_changes", double(report.wedge_changes));
    }
    if (params.iterations > 0 && params.tip_target_deg > 0.0) {
        smoother.build_tips(2.0 * params.tip_target_deg);
        report.min_forced_tet_before_deg = smoother.min_forced_tet();
        for (int pass = 0; pass < 4; ++pass) {
            const std::size_t changes = smoother.tip_pass(params.tip_target_deg);
            report.tip_changes += changes;
            if (changes == 0) break;
        }
        report.min_forced_tet_after_deg = smoother.min_forced_tet();
        ctx.add("remesh.tip_changes", double(report.tip_changes));
        ctx.count("remesh.min_forced_tet_deg", report.min_forced_tet_after_deg);
    }
    if (params.iterations > 0)
        for (int pass = 0; pass < 3; ++pass) {
            const std::size_t moves = smoother.curve_pass(
                kWorstCurveAngleDeg, std::max(params.wedge_target_deg, params.tip_target_deg));
            report.moves += moves;
            if (moves == 0) break;
        }
    // Last, as nothing after them projects vertices back: the wedges and tips the background
    // itself makes thin are opened off it.
    if (params.iterations > 0) {
        report.openings = open_passes(smoother, params);
        ctx.add("remesh.wedge_openings", double(report.openings));
        if (params.tip_target_deg > 0.0)
            ctx.count("remesh.min_forced_tet_deg", smoother.min_forced_tet());
    }
    // After the tip passes, which may lower a fan's wedge to its raised tet angle.
    if (params.iterations > 0 && params.wedge_target_deg > 0.0)
        ctx.count("remesh.min_region_wedge_deg", smoother.min_wedge());
    report.min_angle_after_deg = global_min_angle(surface);
    ctx.add("remesh.smoothing_moves", double(report.moves));
    ctx.add("remesh.edge_flips", double(report.flips));
    return report;
}

}  // namespace frontmesh::surface
