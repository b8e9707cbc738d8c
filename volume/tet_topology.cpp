#include "volume/tet_topology.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "pipeline/core/error.h"
#include "pipeline/core/predicates.h"

namespace frontmesh::volume {

namespace {

using Key = std::array<std::int32_t, 3>;

Key sorted_key(std::int32_t x, std::int32_t y, std::int32_t z) {
    Key k{x, y, z};
    if (k[0] > k[1]) std::swap(k[0], k[1]);
    if (k[1] > k[2]) std::swap(k[1], k[2]);
    if (k[0] > k[1]) std::swap(k[0], k[1]);
    return k;
}

Key face_key(const Tet& t, int i) {
    const auto f = tet_face(t, i);
    return sorted_key(f[0], f[1], f[2]);
}

bool contains(const Tet& t, std::int32_t v) { return local_index(t, v) >= 0; }

bool same_key(const Key& x, const Key& y) { return x[0] == y[0] && x[1] == y[1] && x[2] == y[2]; }

/// Parity of the permutation mapping positions: 0 even, 1 odd.
int parity(std::array<int, 4> p) {
    int swaps = 0;
    for (int i = 0; i < 4; ++i) {
        while (p[static_cast<std::size_t>(i)] != i) {
            std::swap(p[static_cast<std::size_t>(i)],
                      p[static_cast<std::size_t>(p[static_cast<std::size_t>(i)])]);
            ++swaps;
        }
    }
    return swaps & 1;
}

}  // namespace

bool positive_tet(const double* a, const double* b, const double* c, const double* d) {
    // orient3d(a,b,c,d) = -1 when d lies on the right-hand normal side of abc (VTK-positive).
    return core::orient3d(a, b, c, d) < 0;
}

TetTopology::TetTopology(core::TetMesh mesh) : mesh_(std::move(mesh)) {
    const std::size_t n_nodes = mesh_.node_count();
    const std::size_t n_tets = mesh_.tets.size();
    if (mesh_.region.size() != n_tets)
        FM_THROW(InputError, "refine: tet mesh has " + std::to_string(n_tets) + " tets but " +
                                 std::to_string(mesh_.region.size()) + " region labels");
    if (mesh_.surface_vertices < 0 || static_cast<std::size_t>(mesh_.surface_vertices) > n_nodes)
        FM_THROW(InputError, "refine: surface_vertices out of range");

    // Node -> tets (CSR), in tet id order.
    std::vector<std::int32_t> offset(n_nodes + 1, 0);
    for (std::size_t t = 0; t < n_tets; ++t) {
        for (const std::int32_t v : mesh_.tets[t]) {
            if (v < 0 || static_cast<std::size_t>(v) >= n_nodes)
                FM_THROW(InputError, "refine: tet " + std::to_string(t) + " refers to node " +
                                         std::to_string(v) + " of " + std::to_string(n_nodes));
            ++offset[static_cast<std::size_t>(v) + 1];
        }
    }
    for (std::size_t v = 0; v < n_nodes; ++v) offset[v + 1] += offset[v];
    std::vector<std::int32_t> incident(static_cast<std::size_t>(offset[n_nodes]));
    {
        std::vector<std::int32_t> fill(offset.begin(), offset.end() - 1);
        for (std::size_t t = 0; t < n_tets; ++t)
            for (const std::int32_t v : mesh_.tets[t])
                incident[static_cast<std::size_t>(fill[static_cast<std::size_t>(v)]++)] =
                    static_cast<std::int32_t>(t);
    }
    // Tets holding face (x, y, z): scanned from the node with the fewest tets.
    auto for_face_tets = [&](std::int32_t x, std::int32_t y, std::int32_t z, auto&& fn) {
        std::int32_t s = x;
        auto degree = [&](std::int32_t v) {
            return offset[static_cast<std::size_t>(v) + 1] - offset[static_cast<std::size_t>(v)];
        };
        if (degree(y) < degree(s)) s = y;
        if (degree(z) < degree(s)) s = z;
        for (std::int32_t k = offset[static_cast<std::size_t>(s)];
             k < offset[static_cast<std::size_t>(s) + 1]; ++k) {
            const std::int32_t t = incident[static_cast<std::size_t>(k)];
            const Tet& tt = mesh_.tets[static_cast<std::size_t>(t)];
            if (contains(tt, x) && contains(tt, y) && contains(tt, z)) fn(t);
        }
    };

    nbr_.assign(n_tets, {-1, -1, -1, -1});
    // Faces matched at their smallest node: each face (t, i) is written by exactly one node, so
    // nodes run in parallel and the result does not depend on the thread count.
    std::atomic<std::int64_t> bad_face{-1};
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, n_nodes, 2048),
        [&](const tbb::blocked_range<std::size_t>& range) {
            struct FaceRef {
                Key key;
                std::int32_t tet;
                int local;
            };
            std::vector<FaceRef> refs;
            for (std::size_t v = range.begin(); v != range.end(); ++v) {
                refs.clear();
                for (std::int32_t k = offset[v]; k < offset[v + 1]; ++k) {
                    const std::int32_t t = incident[static_cast<std::size_t>(k)];
                    const Tet& tt = mesh_.tets[static_cast<std::size_t>(t)];
                    for (int i = 0; i < 4; ++i) {
                        if (tt[static_cast<std::size_t>(i)] == static_cast<std::int32_t>(v))
                            continue;
                        const Key key = face_key(tt, i);
                        if (key[0] == static_cast<std::int32_t>(v)) refs.push_back({key, t, i});
                    }
                }
                // Every key starts with v: order by (key[1], key[2]) packed in 64 bits, then tet.
                auto rest = [](const Key& k) {
                    return static_cast<std::uint64_t>(static_cast<std::uint32_t>(k[1])) << 32 |
                           static_cast<std::uint32_t>(k[2]);
                };
                std::sort(refs.begin(), refs.end(), [&](const FaceRef& x, const FaceRef& y) {
                    const std::uint64_t rx = rest(x.key), ry = rest(y.key);
                    return rx != ry ? rx < ry : x.tet < y.tet;
                });
                for (std::size_t k = 0; k < refs.size();) {
                    std::size_t e = k + 1;
                    while (e < refs.size() && same_key(refs[e].key, refs[k].key)) ++e;
                    if (e - k > 2) bad_face.store(refs[k].tet);
                    if (e - k == 2) {
                        const FaceRef& x = refs[k];
                        const FaceRef& y = refs[k + 1];
                        if (mesh_.region[static_cast<std::size_t>(x.tet)] ==
                            mesh_.region[static_cast<std::size_t>(y.tet)]) {
                            nbr_[static_cast<std::size_t>(x.tet)]
                                [static_cast<std::size_t>(x.local)] = y.tet;
                            nbr_[static_cast<std::size_t>(y.tet)]
                                [static_cast<std::size_t>(y.local)] = x.tet;
                        }
                    }
                    k = e;
                }
            }
        });
    if (bad_face.load() >= 0) {
        const Tet& tt = mesh_.tets[static_cast<std::size_t>(bad_face.load())];
        const Eigen::Vector3d p = mesh_.point(tt[0]);
        FM_THROW(InputError, "refine: a face of tet " + std::to_string(bad_face.load()) +
                                 " near (" + std::to_string(p.x()) + ", " + std::to_string(p.y()) +
                                 ", " + std::to_string(p.z()) +
                                 ") is shared by more than two tets (non-conforming mesh)");
    }
    // The input surface triangles are walls.
    for (const auto& f : mesh_.faces) {
        for_face_tets(f[0], f[1], f[2], [&](std::int32_t t) {
            const Tet& tt = mesh_.tets[static_cast<std::size_t>(t)];
            for (int i = 0; i < 4; ++i)
                if (tt[static_cast<std::size_t>(i)] != f[0] &&
                    tt[static_cast<std::size_t>(i)] != f[1] &&
                    tt[static_cast<std::size_t>(i)] != f[2])
                    nbr_[static_cast<std::size_t>(t)][static_cast<std::size_t>(i)] = -1;
        });
    }
    // Poor input triangles: skewness 1 - A / A_opt above the threshold, A_opt = 3 sqrt(3) / 4 r^2
    // with the circumradius r = |ab| |bc| |ca| / (4 A).
    for (const auto& f : mesh_.faces) {
        const Eigen::Vector3d a = mesh_.point(f[0]), b = mesh_.point(f[1]), c = mesh_.point(f[2]);
        const double area = 0.5 * (b - a).cross(c - a).norm();
        const double lengths = (b - a).norm() * (c - b).norm() * (a - c).norm();
        const double skewness =
            area > 0.0 ? 1.0 - area / (0.75 * std::sqrt(3.0) * std::pow(lengths / (4.0 * area), 2))
                       : 1.0;
        if (skewness > kPoorFaceSkewness) poor_faces_.push_back(sorted_key(f[0], f[1], f[2]));
    }
    std::sort(poor_faces_.begin(), poor_faces_.end());
    alive_.assign(n_tets, 1);
    alive_count_ = n_tets;
    node_tet_.assign(n_nodes, -1);
    for (std::size_t v = 0; v < n_nodes; ++v)
        if (offset[v + 1] > offset[v]) node_tet_[v] = incident[static_cast<std::size_t>(offset[v])];
}

void TetTopology::set_point(std::int32_t v, const Eigen::Vector3d& p) {
    FM_ASSERT(!is_surface_node(v));
    mesh_.point(v) = p;
    ++stamp_;
}

bool TetTopology::is_poor_face(std::int32_t a, std::int32_t b, std::int32_t c) const {
    return !poor_faces_.empty() &&
           std::binary_search(poor_faces_.begin(), poor_faces_.end(), sorted_key(a, b, c));
}

bool TetTopology::has_poor_face(const Tet& t) const {
    if (poor_faces_.empty()) return false;
    int on_surface = 0;
    for (const std::int32_t v : t) on_surface += is_surface_node(v) ? 1 : 0;
    if (on_surface < 3) return false;
    for (int i = 0; i < 4; ++i) {
        const auto f = tet_face(t, i);
        if (is_surface_node(f[0]) && is_surface_node(f[1]) && is_surface_node(f[2]) &&
            is_poor_face(f[0], f[1], f[2]))
            return true;
    }
    return false;
}

std::int32_t TetTopology::add_node(const Eigen::Vector3d& p, std::int32_t level) {
    const std::int32_t v = mesh_.add_node(p);
    if (!mesh_.level.empty()) mesh_.level.push_back(level);
    node_tet_.push_back(-1);
    ++stamp_;
    FM_ASSERT(static_cast<std::size_t>(v) + 1 == node_tet_.size());
    return v;
}

bool TetTopology::star(std::int32_t v, std::vector<std::int32_t>& tets) const {
    return star(v, tets, std::numeric_limits<std::size_t>::max());
}

bool TetTopology::star(std::int32_t v, std::vector<std::int32_t>& tets, std::size_t limit) const {
    tets.clear();
    const std::int32_t start = node_tet(v);
    if (start < 0) return false;
    if (mark_.size() < alive_.size()) mark_.resize(alive_.size(), 0);
    if (++epoch_ == 0) {  // wrapped: clear the marks once
        std::fill(mark_.begin(), mark_.end(), 0);
        epoch_ = 1;
    }
    tets.push_back(start);
    mark_[static_cast<std::size_t>(start)] = epoch_;
    bool closed = true;
    for (std::size_t k = 0; k < tets.size(); ++k) {
        const std::int32_t t = tets[k];
        const Tet& tt = tet(t);
        for (int i = 0; i < 4; ++i) {
            if (tt[static_cast<std::size_t>(i)] == v) continue;  // face opposite v: not around v
            const std::int32_t u = neighbor(t, i);
            if (u < 0) {
                closed = false;
                continue;
            }
            if (mark_[static_cast<std::size_t>(u)] != epoch_) {
                mark_[static_cast<std::size_t>(u)] = epoch_;
                tets.push_back(u);
                if (tets.size() > limit) return false;
            }
        }
    }
    return closed;
}

bool TetTopology::edge_ring(std::int32_t a, std::int32_t b, std::int32_t t,
                            std::vector<std::int32_t>& tets,
                            std::vector<std::int32_t>& ring) const {
    tets.clear();
    ring.clear();
    const Tet& tt = tet(t);
    const int la = local_index(tt, a), lb = local_index(tt, b);
    FM_ASSERT(la >= 0 && lb >= 0 && la != lb);
    int lc = -1, ld = -1;
    for (int i = 0; i < 4; ++i) {
        if (i == la || i == lb) continue;
        (lc < 0 ? lc : ld) = i;
    }
    // (a, b, c, d) positive when the permutation (la, lb, lc, ld) of tt is even.
    if (parity({la, lb, lc, ld}) != 0) std::swap(lc, ld);
    ring.push_back(tt[static_cast<std::size_t>(lc)]);
    ring.push_back(tt[static_cast<std::size_t>(ld)]);
    tets.push_back(t);
    std::int32_t cur = t, prev = ring[0], next = ring[1];
    for (int guard = 0; guard < 256; ++guard) {
        const std::int32_t u = neighbor(cur, local_index(tet(cur), prev));
        if (u < 0) return false;
        if (u == t) {
            ring.pop_back();  // the walk came back: the last node pushed is ring[0]
            return ring.size() == tets.size() && ring.size() >= 3;
        }
        const Tet& ut = tet(u);
        std::int32_t z = -1;
        for (const std::int32_t w : ut)
            if (w != a && w != b && w != next) z = w;
        tets.push_back(u);
        ring.push_back(z);
        prev = next;
        next = z;
        cur = u;
    }
    return false;
}

std::int32_t TetTopology::allocate() {
    if (!free_.empty()) {
        const std::int32_t t = free_.back();
        free_.pop_back();
        return t;
    }
    mesh_.tets.push_back({-1, -1, -1, -1});
    mesh_.region.push_back(0);
    nbr_.push_back({-1, -1, -1, -1});
    alive_.push_back(0);
    return static_cast<std::int32_t>(mesh_.tets.size() - 1);
}

void TetTopology::replace(std::span<const std::int32_t> old_tets, std::span<const Tet> new_tets,
                          core::Label region, std::vector<std::int32_t>* new_ids) {
    struct Outer {
        Key key;
        std::int32_t tet;    // outside neighbour, -1 at a wall
        std::int32_t local;  // its face index
        bool used;
    };
    std::vector<Outer> outer;
    outer.reserve(old_tets.size() * 2 + 4);
    auto is_old = [&](std::int32_t u) {
        return std::find(old_tets.begin(), old_tets.end(), u) != old_tets.end();
    };
    for (const std::int32_t t : old_tets) {
        FM_ASSERT(alive(t));
        for (int i = 0; i < 4; ++i) {
            const std::int32_t u = neighbor(t, i);
            if (u >= 0 && is_old(u)) continue;
            int lu = -1;
            if (u >= 0)
                for (int j = 0; j < 4; ++j)
                    if (neighbor(u, j) == t) lu = j;
            outer.push_back({face_key(tet(t), i), u, lu, false});
        }
    }
    // Kill the old tets.
    std::vector<std::int32_t> old_nodes;
    for (const std::int32_t t : old_tets) {
        alive_[static_cast<std::size_t>(t)] = 0;
        for (const std::int32_t v : tet(t)) old_nodes.push_back(v);
    }
    alive_count_ -= old_tets.size();
    // Ids: the old ones first (in order), then the free list, then new slots.
    std::vector<std::int32_t> ids(new_tets.size());
    for (std::size_t j = 0; j < new_tets.size(); ++j)
        ids[j] = j < old_tets.size() ? old_tets[j] : allocate();
    for (std::size_t j = new_tets.size(); j < old_tets.size(); ++j) free_.push_back(old_tets[j]);
    ++stamp_;
    for (std::size_t j = 0; j < new_tets.size(); ++j) {
        const auto t = static_cast<std::size_t>(ids[j]);
        mesh_.tets[t] = new_tets[j];
        mesh_.region[t] = region;
        nbr_[t] = {-1, -1, -1, -1};
        alive_[t] = 1;
    }
    alive_count_ += new_tets.size();
    // Connect faces: to the cavity's outside, or between new tets.
    for (std::size_t j = 0; j < new_tets.size(); ++j) {
        for (int i = 0; i < 4; ++i) {
            const Key k = face_key(new_tets[j], i);
            bool done = false;
            for (Outer& o : outer) {
                if (o.used || !same_key(o.key, k)) continue;
                o.used = true;
                done = true;
                nbr_[static_cast<std::size_t>(ids[j])][static_cast<std::size_t>(i)] = o.tet;
                if (o.tet >= 0)
                    nbr_[static_cast<std::size_t>(o.tet)][static_cast<std::size_t>(o.local)] =
                        ids[j];
                break;
            }
            if (done) continue;
            for (std::size_t j2 = 0; j2 < new_tets.size() && !done; ++j2) {
                if (j2 == j) continue;
                for (int i2 = 0; i2 < 4; ++i2) {
                    if (!same_key(face_key(new_tets[j2], i2), k)) continue;
                    nbr_[static_cast<std::size_t>(ids[j])][static_cast<std::size_t>(i)] = ids[j2];
                    done = true;
                    break;
                }
            }
            FM_CHECK(done);
        }
    }
    for (const Outer& o : outer) FM_CHECK(o.used);
    for (const std::int32_t v : old_nodes) node_tet_[static_cast<std::size_t>(v)] = -1;
    for (std::size_t j = 0; j < new_tets.size(); ++j)
        for (const std::int32_t v : new_tets[j]) node_tet_[static_cast<std::size_t>(v)] = ids[j];
    for (const std::int32_t v : old_nodes) FM_CHECK(node_tet(v) >= 0 || !is_surface_node(v));
    if (new_ids) *new_ids = std::move(ids);
}

bool TetTopology::check() const {
    for (std::int32_t t = 0; t < tet_capacity(); ++t) {
        if (!alive(t)) continue;
        for (int i = 0; i < 4; ++i) {
            const std::int32_t u = neighbor(t, i);
            if (u < 0) continue;
            if (!alive(u) || region(u) != region(t)) return false;
            const Key k = face_key(tet(t), i);
            bool back = false;
            for (int j = 0; j < 4; ++j)
                if (neighbor(u, j) == t && face_key(tet(u), j) == k) back = true;
            if (!back) return false;
        }
        for (const std::int32_t v : tet(t))
            if (node_tet(v) < 0) return false;
    }
    for (std::int32_t v = 0; v < node_capacity(); ++v) {
        const std::int32_t t = node_tet(v);
        if (t >= 0 && (!alive(t) || !contains(tet(t), v))) return false;
    }
    return true;
}

core::TetMesh TetTopology::compact() const {
    core::TetMesh out;
    const std::int32_t n = node_capacity();
    std::vector<std::int32_t> map(static_cast<std::size_t>(n), -1);
    std::int32_t next = 0;
    for (std::int32_t v = 0; v < n; ++v) {
        if (v < mesh_.surface_vertices || node_tet(v) >= 0) {
            map[static_cast<std::size_t>(v)] = next++;
            out.add_node(mesh_.point(v));
            if (!mesh_.level.empty()) out.level.push_back(mesh_.level[static_cast<std::size_t>(v)]);
        }
    }
    out.tets.reserve(alive_count_);
    out.region.reserve(alive_count_);
    for (std::int32_t t = 0; t < tet_capacity(); ++t) {
        if (!alive(t)) continue;
        const Tet& tt = tet(t);
        out.add_tet(map[static_cast<std::size_t>(tt[0])], map[static_cast<std::size_t>(tt[1])],
                    map[static_cast<std::size_t>(tt[2])], map[static_cast<std::size_t>(tt[3])],
                    region(t));
    }
    out.faces = mesh_.faces;
    out.region_in = mesh_.region_in;
    out.region_out = mesh_.region_out;
    out.surface_vertices = mesh_.surface_vertices;
    return out;
}

}  // namespace frontmesh::volume
