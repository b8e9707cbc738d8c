#include "volume/tetra_mesher.h"

#include <algorithm>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include "pipeline/core/error.h"
#include "pipeline/core/predicates.h"
#include "pipeline/core/quality.h"
#include "volume/cavity_kernel.h"

// A region's run beyond the paper's steps: the closing phase for the cavities the layered
// front leaves, what happens to a front left open (diagnostics, the error), the region's
// result and the merge of all regions.

namespace frontmesh::volume::detail {

core::AdtBox RegionMesher::domain_of(const core::SurfaceNetwork& s, Label r) {
    core::AdtBox box;
    for (std::size_t f = 0; f < s.face_count(); ++f) {
        if (s.region_in[f] != r && s.region_out[f] != r) continue;
        for (std::int32_t v : s.faces[f]) box.extend(s.point(v));
    }
    if (!box.is_valid()) box = core::AdtBox::of_point(V3::Zero());
    const double d = (box.hi - box.lo).norm();
    return box.enlarged(0.05 * d + 1e-9);
}

std::string RegionMesher::where(std::int32_t v) const {
    std::ostringstream s;
    s.precision(6);
    s << "(" << p(v)[0] << ", " << p(v)[1] << ", " << p(v)[2] << ") mm";
    return s.str();
}

// ---- closing phase (beyond the paper) ---------------------------------------------------------

/// Closing rounds `first` to `last` (rings removed = the round) until the front is empty;
/// their number (at most last - first + 1).
std::int64_t RegionMesher::close_cavities(std::int32_t first, std::int32_t last) {
    std::int64_t closing_rounds = 0;
    for (std::int32_t round = first; front_.size() > 0 && round <= last; ++round) {
        sink_.check_cancelled();
        ++closing_rounds;
        closing_round(round);
    }
    return closing_rounds;
}

/// Round `rings`: enlarges every cavity by `rings` rings of tets and refills it with the
/// layered front (good elements), then fills what is left with relaxed tests.
void RegionMesher::closing_round(std::int32_t rings) {
    if (rings > 0) {
        remove_rings(rings);
        ++front_no_;
        setup_level();
        run_stage(1, false);
        run_stage(2, false);
    }
    fill_relaxed();
}

/// Removes `rings` rings of tets around the nodes left on the front.
void RegionMesher::remove_rings(std::int32_t rings) {
    std::vector<std::int32_t> nodes;
    for (std::int32_t f = 0; f < front_.id_bound(); ++f)
        if (front_.is_alive(f))
            nodes.insert(nodes.end(), front_.face(f).v.begin(), front_.face(f).v.end());
    remove_rings_at(std::move(nodes), rings);
}

/// Removes `rings` rings of tets around `nodes`: the tets at them, then those at the nodes of
/// these, and so on.
void RegionMesher::remove_rings_at(std::vector<std::int32_t> nodes, std::int32_t rings) {
    std::vector<std::int32_t> tets;
    for (std::int32_t ring = 0; ring < rings; ++ring) {
        std::sort(nodes.begin(), nodes.end());
        nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
        tets.clear();
        for (std::int32_t v : nodes)
            for (std::int32_t k = tet_head_[v]; k >= 0; k = tnext_[k])
                if (talive_[k / 4]) tets.push_back(k / 4);
        std::sort(tets.begin(), tets.end());
        tets.erase(std::unique(tets.begin(), tets.end()), tets.end());
        for (std::int32_t t : tets) nodes.insert(nodes.end(), tv_[t].begin(), tv_[t].end());
    }
    for (std::int32_t t : tets) {
        new_faces_.clear();
        remove_tet(t);
    }
}

/// Relaxed filling: any valid tet, smallest faces first; at most 4 passes, each over the faces
/// at its start, ending early when a pass adds nothing.
void RegionMesher::fill_relaxed() {
    for (int pass = 0; pass < 4 && front_.size() > 0; ++pass) {
        bool progress = false;
        std::vector<std::pair<double, std::int32_t>> order;
        for (std::int32_t f = 0; f < front_.id_bound(); ++f)
            if (front_.is_alive(f)) order.push_back({front_.face(f).area, f});
        std::sort(order.begin(), order.end());
        std::vector<std::int32_t> stamps(front_.id_bound());
        for (auto [a, f] : order) stamps[f] = front_.face(f).stamp;
        for (auto [a, f] : order) {
            (void)a;
            if (f >= static_cast<std::int32_t>(stamps.size()) || !front_.is_alive(f) ||
                front_.face(f).stamp != stamps[f])
                continue;
            if (try_base(f, false, true)) progress = true;
        }
        if (!progress) break;
    }
}

// ---- completion path (beyond the paper) -------------------------------------------------------
//
// What the closing rounds leave is a set of cavities, each bounded by a group of front faces
// joined through edges (a 2-cycle: every edge is used as often in each direction). A cavity
// that is star-shaped from a point P (P strictly on the inner side of every face) is filled
// exactly by the cone of tets (face, P): the tets are all positive and, summed with signs,
// cover each point as often as the faces wind around it, once inside the cavity and never
// outside. A cavity that is not star-shaped from P is made so as Bowyer-Watson makes a
// Delaunay cavity: while a face does not see P, the tet behind it joins the cavity. Each step
// removes one tet of the region, so the growth ends; a cavity it reaches joins it. It fails
// only where a face that does not see P has no tet behind it (the input surface), or past a
// size limit, and then changes nothing. Candidate points: the Chebyshev centre of the kernel
// of the faces the growth cannot pass (volume/cavity_kernel.h), that of all the cavity's
// faces, the mean of the face centres, and a point over the largest face. Each cone tet still
// passes the exact validity test. Not every cavity is filled: one that wraps around an island
// (a shell around an inner boundary) is star-shaped from no point.

/// The search of a relaxed try (as try_base sets it up) for base bk.
RegionMesher::Search RegionMesher::relaxed_search(const Base& bk) const {
    Search s;
    s.relaxed = true;
    s.small_front = false;
    s.r1 = 1.1 * bk.h;
    s.min_vol = 1e-6 * bk.area * std::sqrt(bk.area);
    for (int i = 0; i < 3; ++i) s.base_box.extend(bk.A[i]);
    return s;
}

/// Completion rounds until the front is empty, at most `rounds` (<= kCompletionRounds); the
/// cavities filled. A failed cavity loses a ring of tets only when another round follows.
std::int64_t RegionMesher::complete_cavities(std::int32_t rounds) {
    std::int64_t cones = 0;
    for (std::int32_t round = 0; round < rounds && front_.size() > 0; ++round) {
        sink_.check_cancelled();
        std::vector<std::int32_t> stuck;
        for (const std::vector<std::int32_t>& cavity : front_cavities()) {
            if (fill_star(cavity)) {
                ++cones;
                continue;
            }
            for (std::int32_t f : cavity)
                stuck.insert(stuck.end(), front_.face(f).v.begin(), front_.face(f).v.end());
        }
        if (!stuck.empty() && round + 1 < rounds) remove_rings_at(std::move(stuck), 1);
    }
    return cones;
}

/// The front's faces in groups joined through shared edges, each group in increasing id
/// order and the groups by their first face: each group bounds one cavity.
std::vector<std::vector<std::int32_t>> RegionMesher::front_cavities() const {
    struct EdgeUse {
        std::int32_t lo, hi, f;
        bool operator<(const EdgeUse& o) const {
            return lo != o.lo ? lo < o.lo : hi != o.hi ? hi < o.hi : f < o.f;
        }
    };
    std::vector<EdgeUse> uses;
    std::vector<std::int32_t> parent(static_cast<std::size_t>(front_.id_bound()), -1);
    for (std::int32_t f = 0; f < front_.id_bound(); ++f) {
        if (!front_.is_alive(f)) continue;
        parent[f] = f;
        const Tri& t = front_.face(f).v;
        for (int k = 0; k < 3; ++k)
            uses.push_back({std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3]), f});
    }
    std::sort(uses.begin(), uses.end());
    auto root = [&](std::int32_t f) {
        while (parent[f] != f) f = parent[f] = parent[parent[f]];
        return f;
    };
    for (std::size_t i = 1; i < uses.size(); ++i) {
        if (uses[i].lo != uses[i - 1].lo || uses[i].hi != uses[i - 1].hi) continue;
        const std::int32_t a = root(uses[i].f), b = root(uses[i - 1].f);
        if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
    std::vector<std::vector<std::int32_t>> groups;
    std::vector<std::int32_t> group_of(parent.size(), -1);
    for (std::int32_t f = 0; f < front_.id_bound(); ++f) {
        if (parent[f] < 0) continue;
        const std::int32_t r = root(f);
        if (group_of[r] < 0) {
            group_of[r] = static_cast<std::int32_t>(groups.size());
            groups.emplace_back();
        }
        groups[group_of[r]].push_back(f);
    }
    return groups;
}

/// The front faces joined to front face g through shared edges (g's cavity), by a walk over
/// the node->face lists; each face once.
std::vector<std::int32_t> RegionMesher::front_cavity_of(std::int32_t g) const {
    std::vector<std::int32_t> group{g}, seen{g};
    for (std::size_t i = 0; i < group.size(); ++i) {
        const Tri t = front_.face(group[i]).v;
        for (int e = 0; e < 3; ++e) {
            const std::int32_t a = t[e], b = t[(e + 1) % 3];
            for (std::int32_t k = front_.first_corner(a); k >= 0; k = front_.next_corner(k)) {
                const std::int32_t h = k / 3;
                const Tri& th = front_.face(h).v;
                if (th[0] != b && th[1] != b && th[2] != b) continue;
                if (std::find(seen.begin(), seen.end(), h) != seen.end()) continue;
                seen.push_back(h);
                group.push_back(h);
            }
        }
    }
    return group;
}

/// The alive tet with the outward face (a, b, c) (in that cyclic order), -1 when none: the
/// tet behind the front face (a, b, c).
std::int32_t RegionMesher::tet_behind(std::int32_t a, std::int32_t b, std::int32_t c) const {
    for (std::int32_t k = tet_head_[a]; k >= 0; k = tnext_[k]) {
        const std::int32_t t = k / 4;
        if (!talive_[t]) continue;
        const Tet& v = tv_[t];
        for (const auto& lf : kTetFace)
            if (same_cycle({v[lf[0]], v[lf[1]], v[lf[2]]}, a, b, c)) return t;
    }
    return -1;
}

/// The tets to remove so that the cavity bounded by the front faces `cavity` becomes
/// star-shaped from P, into `grown`, and the faces of the grown cavity; false when a face that does
/// not see P has no tet behind it, or the growth passes max_grown tets. Nothing changes: the growth
/// runs on a copy of the cavity's faces. Each face taken from the queue either sees P or adds the
/// one tet behind it to `grown` (never twice: a tet's faces toward the cavity leave the boundary
/// when it joins; a merged cavity's faces join once), so the loop ends after at most |front| + 4
/// max_grown faces.
bool RegionMesher::grow_star(const std::vector<std::int32_t>& cavity, const V3& P,
                             std::vector<std::int32_t>& grown, std::vector<Tri>& faces) const {
    struct Key {
        std::int32_t a, b, c;
        bool operator<(const Key& o) const {
            return a != o.a ? a < o.a : b != o.b ? b < o.b : c < o.c;
        }
    };
    auto key_of = [](Tri t) {
        std::sort(t.begin(), t.end());
        return Key{t[0], t[1], t[2]};
    };
    std::map<Key, Tri> boundary;  // the grown cavity's faces, normals into it
    std::vector<Tri> queue;
    for (std::int32_t f : cavity) {
        boundary.emplace(key_of(front_.face(f).v), front_.face(f).v);
        queue.push_back(front_.face(f).v);
    }
    std::set<std::int32_t> in_grown;
    // a local repair: a growth beyond this many tets is given up (the cone would be a fan
    // over much of the region)
    const std::size_t max_grown = 16 * cavity.size() + 256;
    grown.clear();
    while (!queue.empty()) {
        const Tri t = queue.back();
        queue.pop_back();
        const auto it = boundary.find(key_of(t));
        if (it == boundary.end() || it->second != t) continue;  // left the boundary meanwhile
        if (core::orient3d(p(t[0]), p(t[1]), p(t[2]), P.data()) == -1) continue;  // sees P
        const std::int32_t tet = tet_behind(t[0], t[1], t[2]);
        if (tet < 0 || !in_grown.insert(tet).second || in_grown.size() > max_grown) return false;
        grown.push_back(tet);
        const Tet& v = tv_[tet];
        for (const auto& lf : kTetFace) {
            const Tri inward{v[lf[0]], v[lf[2]], v[lf[1]]};  // into the removed tet
            const Key k = key_of(inward);
            const auto at = boundary.find(k);
            if (at != boundary.end()) {
                boundary.erase(at);  // the face between the cavity and the tet
                continue;
            }
            const std::int32_t g = front_.find_face(inward[0], inward[1], inward[2]);
            if (g >= 0) {
                // another cavity's face, between it and the tet: the cavities merge, its other
                // faces join the boundary (each cavity once: its faces are then on the boundary)
                for (std::int32_t h : front_cavity_of(g)) {
                    if (h == g) continue;
                    boundary.emplace(key_of(front_.face(h).v), front_.face(h).v);
                    queue.push_back(front_.face(h).v);
                }
                continue;
            }
            boundary.emplace(k, inward);
            queue.push_back(inward);
        }
    }
    faces.clear();
    for (const auto& [k, t] : boundary) faces.push_back(t);
    return true;
}

/// Fills the cavity bounded by the front faces `cavity` with a cone of tets from one point,
/// after growing it to be star-shaped from that point; false (nothing changed but unused
/// nodes) when no candidate point works.
bool RegionMesher::fill_star(const std::vector<std::int32_t>& cavity) {
    // Four faces on four nodes bound one tet; a flat one has no kernel point, and a cone
    // could only be worse. (Where the input surface pinches a region to nothing, torture
    // seed 67, the tet is too flat even for the relaxed volume test: remesh must not make
    // such a surface, see kUnmeshableWedgeDeg.)
    if (cavity.size() == 4) {
        std::vector<std::int32_t> nodes;
        for (std::int32_t f : cavity)
            nodes.insert(nodes.end(), front_.face(f).v.begin(), front_.face(f).v.end());
        std::sort(nodes.begin(), nodes.end());
        nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
        const Tri& t = front_.face(cavity.front()).v;
        for (std::int32_t q : nodes) {
            if (nodes.size() != 4 || q == t[0] || q == t[1] || q == t[2]) continue;
            const Base bk = make_base(cavity.front(), false);
            Search s = relaxed_search(bk);
            return try_existing(bk, s, q);
        }
    }
    std::vector<CavityPlane> planes, fixed;
    planes.reserve(cavity.size());
    V3 centre = V3::Zero();
    std::int32_t largest = cavity.front();
    for (std::int32_t f : cavity) {
        const Tri& t = front_.face(f).v;
        const V3 n = front_.normal(f);
        planes.push_back({n, n.dot(x(t[0]))});
        // a face with no tet behind it is the input surface: the growth cannot pass it
        if (tet_behind(t[0], t[1], t[2]) < 0) fixed.push_back(planes.back());
        centre += (x(t[0]) + x(t[1]) + x(t[2])) / 3.0;
        if (front_.face(f).area > front_.face(largest).area) largest = f;
    }
    centre /= static_cast<double>(cavity.size());
    double radius = 0.0;
    for (std::int32_t f : cavity)
        for (std::int32_t v : front_.face(f).v) radius = std::max(radius, (x(v) - centre).norm());
    if (!(radius > 0.0)) return false;
    // candidates, best first: the kernel's centre of the faces the growth cannot pass, that of
    // all faces, the centre, a point over the largest face
    std::vector<V3> points;
    if (!fixed.empty() && fixed.size() < planes.size()) {
        const KernelCentre k = kernel_centre(fixed, centre, radius);
        if (k.solved && k.t > 0.0) points.push_back(k.p);
    }
    const KernelCentre k = kernel_centre(planes, centre, 2.0 * radius);
    if (k.solved) points.push_back(k.p);
    points.push_back(centre);
    {
        const Tri& t = front_.face(largest).v;
        points.push_back((x(t[0]) + x(t[1]) + x(t[2])) / 3.0 +
                         0.5 * std::sqrt(front_.face(largest).area) * front_.normal(largest));
    }
    std::vector<std::int32_t> grown;
    std::vector<Tri> faces;
    for (const V3& P : points) {
        if (!P.allFinite() || !grow_star(cavity, P, grown, faces)) continue;
        if (cone_from(P, grown, faces)) return true;
    }
    return false;
}

/// A cavity star-shaped from no point (one that wraps around an island of the input surface:
/// torus-like, torture seed 466's 592 faces of Euler characteristic 0) is closed piece by
/// piece. Grown from a seed face through shared edges, patches of 4, 8, 16 ... faces keep a
/// kernel until the patch turns around the island. Candidate points: the kernel centre of
/// each such patch, largest first, and the points 1/2 and 1/4 of the way to it from the
/// seed face's centre (still in the patch's kernel, which is convex and touches the seed
/// face, but nearer the seed: a large patch's centre can lie beyond the cavity). The seeds:
/// the largest face, then the faces a quarter, half and three quarters along the growth.
/// For the first candidate P that works, the cone from P takes every cavity face that sees
/// P and whose tet passes the exact validity test, nearest first. What is left of the
/// cavity, closed by P's new faces, is the next round's cavity: a shorter turn around the
/// island, star-shaped once the cones have cut the ring. True when a tet was added.
bool RegionMesher::fill_partial(const std::vector<std::int32_t>& cavity) {
    const std::size_t n = cavity.size();
    if (n < 4) return false;
    std::map<std::pair<std::int32_t, std::int32_t>, std::vector<std::size_t>> edge_faces;
    std::size_t largest = 0;
    for (std::size_t i = 0; i < n; ++i) {
        const Tri& t = front_.face(cavity[i]).v;
        for (int k = 0; k < 3; ++k)
            edge_faces[{std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3])}].push_back(
                i);
        if (front_.face(cavity[i]).area > front_.face(cavity[largest]).area) largest = i;
    }
    // The cavity's faces joined through shared edges in breadth-first order from `seed`
    // (ties by position): each face enters the order once.
    auto growth_from = [&](std::size_t seed) {
        std::vector<std::size_t> order{seed};
        std::vector<char> taken(n, 0);
        taken[seed] = 1;
        for (std::size_t q = 0; q < order.size(); ++q) {
            const Tri& t = front_.face(cavity[order[q]]).v;
            for (int k = 0; k < 3; ++k)
                for (std::size_t j :
                     edge_faces[{std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3])}])
                    if (!taken[j]) {
                        taken[j] = 1;
                        order.push_back(j);
                    }
        }
        return order;
    };
    auto centroid = [&](std::int32_t f) {
        const Tri& t = front_.face(f).v;
        return V3((x(t[0]) + x(t[1]) + x(t[2])) / 3.0);
    };
    // The candidates of one seed, best first.
    auto candidates_from = [&](const std::vector<std::size_t>& order) {
        std::vector<V3> centres;
        // Patch sizes double up to the cavity's size: at most log2(n) + 2 patches.
        for (std::size_t size = 4; size <= 2 * order.size(); size *= 2) {
            const std::size_t m = std::min(size, order.size());
            std::vector<CavityPlane> planes;
            V3 centre = V3::Zero();
            for (std::size_t q = 0; q < m; ++q) {
                const std::int32_t f = cavity[order[q]];
                const V3 nrm = front_.normal(f);
                planes.push_back({nrm, nrm.dot(x(front_.face(f).v[0]))});
                centre += centroid(f);
            }
            centre /= static_cast<double>(m);
            double radius = 0.0;
            for (std::size_t q = 0; q < m; ++q)
                for (std::int32_t v : front_.face(cavity[order[q]]).v)
                    radius = std::max(radius, (x(v) - centre).norm());
            if (!(radius > 0.0)) break;
            const KernelCentre k = kernel_centre(planes, centre, radius);
            if (!k.solved || !(k.t > 0.0) || !k.p.allFinite()) break;
            centres.push_back(k.p);
            if (m == order.size()) break;
        }
        const V3 c0 = centroid(cavity[order.front()]);
        std::vector<V3> points;
        for (auto it = centres.rbegin(); it != centres.rend(); ++it)
            for (const double s : {1.0, 0.5, 0.25}) points.push_back(c0 + s * (*it - c0));
        return points;
    };
    // The partial cone from P; the tets added.
    auto cone = [&](const V3& P) {
        std::vector<std::pair<double, std::size_t>> near;
        for (std::size_t i = 0; i < n; ++i) {
            const Tri& t = front_.face(cavity[i]).v;
            if (core::tet_signed_volume(x(t[0]), x(t[1]), x(t[2]), P) > 0.0)
                near.push_back({(centroid(cavity[i]) - P).squaredNorm(), i});
        }
        std::sort(near.begin(), near.end());
        std::vector<Tri> faces;
        for (const auto& [d, i] : near) faces.push_back(front_.face(cavity[i]).v);
        std::int32_t apex = -1;
        std::int64_t added = 0;
        // One try per face: bounded by the cavity's size.
        for (const Tri& t : faces) {
            const std::int32_t f = front_.find_face(t[0], t[1], t[2]);
            if (f < 0 || !same_cycle(front_.face(f).v, t[0], t[1], t[2])) continue;
            const Base bk = make_base(f, false);
            Search s = relaxed_search(bk);
            const bool ok = apex < 0 ? try_new(bk, s, P) : try_existing(bk, s, apex);
            if (ok && apex < 0) apex = node_count() - 1;
            added += ok ? 1 : 0;
        }
        return added;
    };
    const std::vector<std::size_t> first = growth_from(largest);
    // At most 4 seeds, each with at most 3 (log2(n) + 2) candidates.
    for (const std::size_t at : {std::size_t(0), n / 4, n / 2, 3 * n / 4}) {
        const std::vector<std::size_t> order =
            at == 0 ? first : growth_from(first[std::min(at, first.size() - 1)]);
        for (const V3& P : candidates_from(order))
            if (cone(P) > 0) return true;
    }
    return false;
}

/// Closing by partial cones (fill_partial) where the completion rounds leave a cavity: each
/// round fills every cavity that is star-shaped from a point and cuts a cone out of every
/// other one, at most `rounds` rounds; a round that adds no tet ends them. The cones made.
std::int64_t RegionMesher::split_cavities(std::int32_t rounds) {
    std::int64_t cones = 0;
    for (std::int32_t round = 0; round < rounds && front_.size() > 0; ++round) {
        sink_.check_cancelled();
        bool progress = false;
        for (const std::vector<std::int32_t>& cavity : front_cavities()) {
            // The cavities of one round are disjoint: filling one leaves the others' faces.
            if (fill_star(cavity) || fill_partial(cavity)) {
                ++cones;
                progress = true;
            }
        }
        if (!progress) break;
    }
    return cones;
}

/// Removes the tets `grown` and fills the cavity bounded by `faces` (which all see P) with
/// the cone from P; on a failed cone tet everything is put back and false returned.
bool RegionMesher::cone_from(const V3& P, const std::vector<std::int32_t>& grown,
                             const std::vector<Tri>& faces) {
    std::vector<Tet> removed;
    for (std::int32_t t : grown) {
        removed.push_back(tv_[t]);
        new_faces_.clear();
        remove_tet(t);
    }
    const std::size_t first_tet = tv_.size();
    std::int32_t apex = -1;
    bool ok = true;
    for (const Tri& t : faces) {
        const std::int32_t f = front_.find_face(t[0], t[1], t[2]);
        ok = f >= 0 && same_cycle(front_.face(f).v, t[0], t[1], t[2]);
        if (!ok) break;
        const Base bk = make_base(f, false);
        Search s = relaxed_search(bk);
        s.min_vol = 0.0;  // the face sees P: the exact test decides
        ok = apex < 0 ? try_new(bk, s, P) : try_existing(bk, s, apex);
        if (!ok) break;
        if (apex < 0) apex = node_count() - 1;
    }
    if (ok) return true;
    for (std::size_t t = first_tet; t < tv_.size(); ++t) {
        if (!talive_[t]) continue;
        new_faces_.clear();
        remove_tet(static_cast<std::int32_t>(t));
    }
    for (const Tet& v : removed) add_tet(v[0], v[1], v[2], v[3]);
    return false;
}

// ---- the end --------------------------------------------------------------------------------

/// Hands the front left open to the diagnostics sink as "tetra-region<label>-front": its
/// triangles (kind 0) and the tets with a node on it (kind 1).
void RegionMesher::diagnose_open_front() const {
    if (!sink_.wants_diagnostics()) return;
    core::Diagnostic d;
    d.name = "tetra-region" + std::to_string(region_) + "-front";
    d.what = "tetra: region " + std::to_string(region_) +
             ": the front cannot be closed; kind 0: front triangle left open (normal into the "
             "unmeshed part), kind 1: tet with a node on that front";
    std::vector<std::int32_t> point(static_cast<std::size_t>(node_count()), -1);
    auto id = [&](std::int32_t v) {
        if (point[v] < 0) point[v] = d.add_point(p(v)[0], p(v)[1], p(v)[2]);
        return point[v];
    };
    for (std::int32_t f = 0; f < front_.id_bound(); ++f) {
        if (!front_.is_alive(f)) continue;
        const Tri& t = front_.face(f).v;
        d.add_cell({id(t[0]), id(t[1]), id(t[2])}, 0);
    }
    for (std::size_t t = 0; t < tv_.size(); ++t) {
        if (!talive_[t]) continue;
        const Tet& v = tv_[t];
        bool at_front = false;
        for (const std::int32_t w : v) at_front = at_front || front_.first_corner(w) >= 0;
        if (at_front) d.add_cell({id(v[0]), id(v[1]), id(v[2]), id(v[3])}, 1);
    }
    sink_.diagnose(std::move(d));
}

RegionResult RegionMesher::result() const {
    RegionResult res;
    res.region = region_;
    res.boundary_nodes = boundary_nodes_;
    res.global_of_local = global_of_local_;
    res.xyz.assign(xyz_.begin(), xyz_.end());
    res.level.assign(level_.begin(), level_.end());
    res.tets.reserve(static_cast<std::size_t>(alive_tets_));
    for (std::size_t t = 0; t < tv_.size(); ++t)
        if (talive_[t]) res.tets.push_back(tv_[t]);
    res.remeshes = remeshes_;
    for (int i = 0; i < kStatCount; ++i) res.stat[i] = stat_[i];
    return res;
}

void RegionMesher::fail(const std::string& why) const {
    std::int32_t f = 0;
    while (f < front_.id_bound() && !front_.is_alive(f)) ++f;
    std::string place = f < front_.id_bound() ? where(front_.face(f).v[0]) : "?";
    FM_THROW(MeshingError, "tetra: region " + std::to_string(region_) + ": " + why + " near " +
                               place + ", " + std::to_string(front_.size()) +
                               " front triangles left");
}

/// Deterministic merge: surface nodes first, then each region's new nodes in label order.
core::TetMesh merge_regions(const core::SurfaceNetwork& surface,
                            const std::vector<RegionResult>& results, core::StageContext& ctx) {
    const std::size_t nv = surface.vertex_count();
    core::TetMesh mesh;
    mesh.xyz = surface.xyz;
    mesh.level.assign(nv, 0);
    mesh.faces = surface.faces;
    mesh.region_in = surface.region_in;
    mesh.region_out = surface.region_out;
    mesh.surface_vertices = static_cast<std::int32_t>(nv);
    std::int64_t remeshes = 0, closing_rounds = 0, closing_tets = 0, cones = 0, levels = 0;
    std::int64_t second_attempts = 0, later_attempts = 0;
    std::int64_t stat[kStatCount] = {};
    for (const RegionResult& res : results) {
        const std::int32_t nl = static_cast<std::int32_t>(res.level.size());
        std::vector<std::int32_t> global(nl, -1);
        for (std::int32_t v = 0; v < res.boundary_nodes; ++v) global[v] = res.global_of_local[v];
        for (const Tet& t : res.tets) {
            Tet g;
            for (int k = 0; k < 4; ++k) {
                const std::int32_t v = t[k];
                if (global[v] < 0) {
                    global[v] = mesh.add_node(
                        Eigen::Vector3d(res.xyz[3 * v], res.xyz[3 * v + 1], res.xyz[3 * v + 2]));
                    mesh.level.push_back(res.level[v]);
                }
                g[k] = global[v];
            }
            mesh.add_tet(g[0], g[1], g[2], g[3], res.region);
        }
        remeshes += res.remeshes;
        closing_rounds += res.closing_rounds;
        closing_tets += res.closing_tets;
        cones += res.cones;
        second_attempts += res.attempt > 0 ? 1 : 0;
        later_attempts += res.attempt > 1 ? 1 : 0;
        levels = std::max<std::int64_t>(levels, res.levels);
        for (int i = 0; i < kStatCount; ++i) stat[i] += res.stat[i];
    }
    for (int i = 0; i < kStatCount; ++i)
        ctx.count(std::string("tetra.") + kStatNames[i], static_cast<double>(stat[i]));
    ctx.count("tetra.tets", static_cast<double>(mesh.tet_count()));
    ctx.count("tetra.nodes", static_cast<double>(mesh.node_count()));
    ctx.count("tetra.regions", static_cast<double>(results.size()));
    ctx.count("tetra.remeshings", static_cast<double>(remeshes));
    ctx.count("tetra.closing_rounds", static_cast<double>(closing_rounds));
    ctx.count("tetra.closing_tets", static_cast<double>(closing_tets));
    ctx.count("tetra.completion_cones", static_cast<double>(cones));
    ctx.count("tetra.regions_meshed_twice", static_cast<double>(second_attempts));
    ctx.count("tetra.regions_meshed_with_other_spacing", static_cast<double>(later_attempts));
    ctx.count("tetra.max_levels", static_cast<double>(levels));
    ctx.info("tetra: " + std::to_string(mesh.tet_count()) + " tets, " +
             std::to_string(mesh.node_count()) + " nodes, " + std::to_string(results.size()) +
             " regions, " + std::to_string(remeshes) + " local remeshings");
    return mesh;
}

}  // namespace frontmesh::volume::detail
