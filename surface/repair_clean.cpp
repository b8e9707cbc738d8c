// Repair step 1: merge coincident points, drop collapsed, duplicate and zero-area faces
// (and the network edits the steps share).

#include "surface/repair_internal.h"

#include <algorithm>
#include <cmath>
#include <tuple>
#include <unordered_map>

namespace frontmesh::surface::repair_detail {
namespace {

/// For each vertex the lowest-id vertex within `tol` mm that it merges into (itself if none).
/// Points are taken in id order; each is compared with the earlier kept points in the grid
/// cells its tolerance box overlaps (cells of side 8 tol: usually one or two). The cells live
/// in an open-addressing table (16 B per point) holding the newest kept point of the cell
/// (keys are recomputed from that point), older ones chained through `next_in_cell`.
std::vector<std::int32_t> merge_targets(const SurfaceNetwork& net, double tol) {
    const std::size_t n = net.vertex_count();
    std::vector<std::int32_t> target(n);
    std::iota(target.begin(), target.end(), 0);
    if (n == 0) return target;
    Eigen::Vector3d lo = net.point(0), hi = net.point(0);
    for (std::size_t v = 1; v < n; ++v) {
        lo = lo.cwiseMin(net.point(to_id(v)));
        hi = hi.cwiseMax(net.point(to_id(v)));
    }
    const double h = 8.0 * tol;
    if (tol == 0.0 || (hi - lo).maxCoeff() / h > 0x1p50) {
        // Exact coincidence only (tolerance below the coordinates' resolution).
        std::vector<std::int32_t> order(n);
        std::iota(order.begin(), order.end(), 0);
        auto less = [&](std::int32_t a, std::int32_t b) {
            const auto pa = net.point(a), pb = net.point(b);
            for (int k = 0; k < 3; ++k)
                if (pa[k] != pb[k]) return pa[k] < pb[k];
            return a < b;
        };
        std::sort(order.begin(), order.end(), less);
        for (std::size_t i = 1; i < n; ++i)
            if (net.point(order[i]) == net.point(order[i - 1]))
                target[static_cast<std::size_t>(order[i])] =
                    target[static_cast<std::size_t>(order[i - 1])];
        return target;
    }
    using Cell = std::array<std::int64_t, 3>;
    auto cell_index = [&](double x, int k) {
        return static_cast<std::int64_t>(std::floor((x - lo[k]) / h));
    };
    auto cell_of = [&](std::int32_t v) {
        const auto p = net.point(v);
        return Cell{cell_index(p[0], 0), cell_index(p[1], 1), cell_index(p[2], 2)};
    };
    std::size_t capacity = 16;
    while (capacity < 2 * n) capacity *= 2;
    const std::size_t mask = capacity - 1;
    struct Slot {
        std::int32_t head = -1;  // newest kept point of the cell
        std::uint32_t tag = 0;   // high hash bits, so that most probes need not load a point
    };
    std::vector<Slot> table(capacity);
    auto slot_of = [&](const Cell& c) {
        std::uint64_t k = static_cast<std::uint64_t>(c[0]) * 0x9E3779B97F4A7C15ull;
        k ^= static_cast<std::uint64_t>(c[1]) * 0xC2B2AE3D27D4EB4Full;
        k ^= static_cast<std::uint64_t>(c[2]) * 0x165667B19E3779F9ull;
        k ^= k >> 31;
        const auto tag = static_cast<std::uint32_t>(k >> 32);
        std::size_t i = static_cast<std::size_t>(k) & mask;
        while (table[i].head >= 0 && (table[i].tag != tag || cell_of(table[i].head) != c))
            i = (i + 1) & mask;
        table[i].tag = tag;  // harmless on an empty slot that stays empty
        return i;
    };
    std::vector<std::int32_t> next_in_cell(n, -1);
    const double tol2 = tol * tol;
    for (std::size_t i = 0; i < n; ++i) {
        const Eigen::Vector3d p = net.point(to_id(i));
        Cell c0, c1;
        for (int k = 0; k < 3; ++k) {
            c0[static_cast<std::size_t>(k)] = cell_index(p[k] - tol, k);
            c1[static_cast<std::size_t>(k)] = cell_index(p[k] + tol, k);
        }
        std::int32_t best = -1;
        for (std::int64_t x = c0[0]; x <= c1[0]; ++x)
            for (std::int64_t y = c0[1]; y <= c1[1]; ++y)
                for (std::int64_t z = c0[2]; z <= c1[2]; ++z)
                    for (std::int32_t r = table[slot_of({x, y, z})].head; r >= 0;
                         r = next_in_cell[static_cast<std::size_t>(r)])
                        if ((best < 0 || r < best) && (net.point(r) - p).squaredNorm() <= tol2)
                            best = r;
        if (best >= 0) {
            target[i] = best;
            continue;
        }
        const std::size_t slot = slot_of(cell_of(to_id(i)));
        next_in_cell[i] = table[slot].head;
        table[slot].head = to_id(i);
    }
    return target;
}

struct DuplicateCounts {
    std::size_t duplicates = 0;   // same-orientation copies dropped
    std::size_t cancelled = 0;    // opposite copies dropped in pairs
    std::size_t conflicting = 0;  // vertex sets carried by faces of different region pairs
};

/// Marks duplicate faces (same vertex set and region pair) in `keep`. A face's sense is
/// taken relative to its smaller label; copies of opposite sense cancel in pairs, and of
/// what is left one face (the lowest id) stays.
DuplicateCounts mark_duplicates(const SurfaceNetwork& net, std::vector<char>& keep) {
    struct Key {
        Tri v;
        Label lo, hi;
        std::int8_t sense;
        std::int32_t face;
    };
    std::vector<Key> keys;
    keys.reserve(net.face_count());
    for (std::size_t f = 0; f < net.face_count(); ++f) {
        if (!keep[f]) continue;
        const Tri& t = net.faces[f];
        Tri v = t;
        std::sort(v.begin(), v.end());
        const int k = index_of(t, v[0]);
        std::int8_t sense = t[static_cast<std::size_t>((k + 1) % 3)] == v[1] ? 1 : -1;
        const Label in = net.region_in[f], out = net.region_out[f];
        if (in > out) sense = static_cast<std::int8_t>(-sense);
        keys.push_back({v, std::min(in, out), std::max(in, out), sense, to_id(f)});
    }
    auto same_set = [](const Key& a, const Key& b) {
        return a.v[0] == b.v[0] && a.v[1] == b.v[1] && a.v[2] == b.v[2];
    };
    auto same_group = [&](const Key& a, const Key& b) {
        return same_set(a, b) && a.lo == b.lo && a.hi == b.hi;
    };
    std::sort(keys.begin(), keys.end(), [](const Key& a, const Key& b) {
        return std::tie(a.v[0], a.v[1], a.v[2], a.lo, a.hi, a.face) <
               std::tie(b.v[0], b.v[1], b.v[2], b.lo, b.hi, b.face);
    });
    DuplicateCounts counts;
    std::size_t set_begin = 0, survivors_in_set = 0;
    for (std::size_t i = 0; i < keys.size();) {
        std::size_t j = i;
        std::size_t plus = 0, minus = 0;
        std::int32_t first_plus = -1, first_minus = -1;
        for (; j < keys.size() && same_group(keys[i], keys[j]); ++j) {
            if (keys[j].sense > 0) {
                if (plus++ == 0) first_plus = keys[j].face;
            } else if (minus++ == 0) {
                first_minus = keys[j].face;
            }
        }
        if (!same_set(keys[set_begin], keys[i])) {
            set_begin = i;
            survivors_in_set = 0;
        }
        if (j - i > 1) {
            for (std::size_t k = i; k < j; ++k) keep[static_cast<std::size_t>(keys[k].face)] = 0;
            const std::int32_t survivor = plus > minus   ? first_plus
                                          : minus > plus ? first_minus
                                                         : -1;
            if (survivor >= 0) keep[static_cast<std::size_t>(survivor)] = 1;
            counts.cancelled += 2 * std::min(plus, minus);
            if (plus != minus)
                counts.duplicates += std::max(plus, minus) - std::min(plus, minus) - 1;
        }
        if (plus != minus && ++survivors_in_set == 2) ++counts.conflicting;
        i = j;
    }
    return counts;
}

/// The vertices of a collinear face ordered (end, middle, end) along their line.
Tri order_along_line(const SurfaceNetwork& net, const Tri& t) {
    int axis = 0;
    double best = -1.0;
    for (int k = 0; k < 3; ++k) {
        double lo = net.point(t[0])[k], hi = lo;
        for (std::int32_t v : t) {
            lo = std::min(lo, net.point(v)[k]);
            hi = std::max(hi, net.point(v)[k]);
        }
        if (hi - lo > best) {
            best = hi - lo;
            axis = k;
        }
    }
    Tri s = t;
    std::sort(s.begin(), s.end(), [&](std::int32_t a, std::int32_t b) {
        return net.point(a)[axis] < net.point(b)[axis];
    });
    return s;
}

struct SliverCounts {
    std::size_t removed = 0;  // zero-area faces dropped
    std::size_t split = 0;    // faces split at the middle vertex of a dropped face
};

/// Drops faces of zero area (three distinct, exactly collinear points p, m, q with m between).
/// Such a face closes a T-junction: the faces on its long edge (p, q) are split at m, so the
/// surface stays closed. Marks dropped faces in `keep` and appends the split halves.
SliverCounts remove_slivers(SurfaceNetwork& net, std::vector<char>& keep) {
    SliverCounts counts;
    std::vector<char> sliver(net.face_count(), 0);
    std::vector<std::int32_t> slivers;
    for (std::size_t f = 0; f < net.face_count(); ++f)
        if (keep[f] && is_collinear(net, net.faces[f])) {
            sliver[f] = 1;
            slivers.push_back(to_id(f));
        }
    if (slivers.empty()) return counts;
    const VertexFaces vf(net);
    std::unordered_map<std::int32_t, std::vector<std::int32_t>> added;  // incidences of new faces
    auto faces_at = [&](std::int32_t v) {
        std::vector<std::int32_t> r(vf.of(v).begin(), vf.of(v).end());
        if (const auto it = added.find(v); it != added.end())
            r.insert(r.end(), it->second.begin(), it->second.end());
        std::sort(r.begin(), r.end());
        r.erase(std::unique(r.begin(), r.end()), r.end());
        return r;
    };
    for (std::int32_t z : slivers) {
        const auto zi = static_cast<std::size_t>(z);
        if (!keep[zi]) continue;
        const Tri line = order_along_line(net, net.faces[zi]);
        const std::int32_t p = line[0], m = line[1], q = line[2];
        keep[zi] = 0;
        ++counts.removed;
        for (std::int32_t g : faces_at(p)) {
            const auto gi = static_cast<std::size_t>(g);
            if (!keep[gi] || sliver[gi] || !contains(net.faces[gi], q) ||
                contains(net.faces[gi], m))
                continue;
            const Tri t = net.faces[gi];
            const int i = has_directed_edge(t, p, q) ? index_of(t, p) : index_of(t, q);
            const std::int32_t x = t[static_cast<std::size_t>(i)];
            const std::int32_t y = t[static_cast<std::size_t>((i + 1) % 3)];
            const std::int32_t r = t[static_cast<std::size_t>((i + 2) % 3)];
            net.faces[gi] = {x, m, r};
            net.add_face(m, y, r, net.region_in[gi], net.region_out[gi]);
            keep.push_back(1);
            sliver.push_back(0);
            const std::int32_t h = to_id(net.face_count() - 1);
            for (std::int32_t v : {m, y, r}) added[v].push_back(h);
            added[m].push_back(g);
            ++counts.split;
        }
    }
    return counts;
}

}  // namespace

/// Keeps the faces with keep[f] != 0, in order.
void keep_faces(SurfaceNetwork& net, const std::vector<char>& keep) {
    std::size_t n = 0;
    for (std::size_t f = 0; f < net.face_count(); ++f) {
        if (!keep[f]) continue;
        net.faces[n] = net.faces[f];
        net.region_in[n] = net.region_in[f];
        net.region_out[n] = net.region_out[f];
        ++n;
    }
    net.faces.resize(n);
    net.region_in.resize(n);
    net.region_out.resize(n);
}

/// Drops vertices no face uses; the others keep their order. Returns how many were dropped.
std::size_t compact_vertices(SurfaceNetwork& net) {
    std::vector<std::int32_t> new_id(net.vertex_count(), -1);
    for (const Tri& t : net.faces)
        for (std::int32_t v : t) new_id[static_cast<std::size_t>(v)] = 0;
    std::size_t n = 0;
    for (std::size_t v = 0; v < new_id.size(); ++v) {
        if (new_id[v] < 0) continue;
        new_id[v] = to_id(n);
        for (std::size_t k = 0; k < 3; ++k) net.xyz[3 * n + k] = net.xyz[3 * v + k];
        ++n;
    }
    const std::size_t dropped = net.vertex_count() - n;
    net.xyz.resize(3 * n);
    for (Tri& t : net.faces)
        for (std::int32_t& v : t) v = new_id[static_cast<std::size_t>(v)];
    return dropped;
}

void clean_up(SurfaceNetwork& net, const RepairParams& params, core::StageContext& ctx) {
    const std::vector<std::int32_t> target = merge_targets(net, params.merge_tolerance_mm);
    std::size_t merged = 0;
    for (std::size_t v = 0; v < target.size(); ++v) merged += target[v] != to_id(v);
    std::vector<char> keep(net.face_count(), 1);
    std::size_t collapsed = 0;
    for (std::size_t f = 0; f < net.face_count(); ++f) {
        Tri& t = net.faces[f];
        for (std::int32_t& v : t) v = target[static_cast<std::size_t>(v)];
        if (t[0] == t[1] || t[1] == t[2] || t[2] == t[0]) {
            keep[f] = 0;
            ++collapsed;
        }
    }
    const DuplicateCounts dup = mark_duplicates(net, keep);
    const SliverCounts sliver = remove_slivers(net, keep);
    keep_faces(net, keep);
    const std::size_t unused = compact_vertices(net) - merged;
    ctx.count("repair.merged_points", static_cast<double>(merged));
    ctx.count("repair.unused_points", static_cast<double>(unused));
    ctx.count("repair.collapsed_faces", static_cast<double>(collapsed));
    ctx.count("repair.duplicate_faces", static_cast<double>(dup.duplicates));
    ctx.count("repair.cancelled_faces", static_cast<double>(dup.cancelled));
    ctx.count("repair.zero_area_faces", static_cast<double>(sliver.removed));
    ctx.count("repair.split_faces", static_cast<double>(sliver.split));
    ctx.info("repair: merged " + std::to_string(merged) + " points, dropped " +
             std::to_string(collapsed) + " collapsed, " + std::to_string(sliver.removed) +
             " zero-area (" + std::to_string(sliver.split) + " neighbours split), " +
             std::to_string(dup.duplicates) + " duplicate and " + std::to_string(dup.cancelled) +
             " cancelling faces, " + std::to_string(unused) + " unused points");
    if (dup.conflicting > 0)
        ctx.warn("repair: " + std::to_string(dup.conflicting) +
                 " triangles carry two different region pairs; kept");
    ctx.count("repair.conflicting_faces", static_cast<double>(dup.conflicting));
}

}  // namespace frontmesh::surface::repair_detail
