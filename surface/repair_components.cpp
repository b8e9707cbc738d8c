// Repair: orientation classes and pieces of the network (steps 2 and 3) and step 2, the
// removal of small components.

#include "surface/repair_internal.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace frontmesh::surface::repair_detail {

Shells analyse(const SurfaceNetwork& net, const Topology& topo) {
    const std::size_t nf = net.face_count();
    Shells sh;
    ParitySets parity(nf);
    DisjointSets sub(2 * nf);
    for (std::size_t f = 0; f < nf; ++f) {
        const Tri& t = net.faces[f];
        for (int i = 0; i < 3; ++i)
            for (int s = 0; s < 2; ++s) {
                const std::int32_t other = topo.at(f, i, s);
                const auto side = static_cast<std::int32_t>(2 * f) + s;
                if (other < side) continue;  // codes are negative; each pair once
                const std::int32_t g = other >> 1;
                const int s2 = other & 1;
                const std::int32_t a = t[static_cast<std::size_t>(i)];
                const std::int32_t b = t[static_cast<std::size_t>((i + 1) % 3)];
                // Directions of a -> b as each side sees it; agreeing sides run opposite.
                const int df = s == 0 ? 1 : -1;
                const int dg =
                    (has_directed_edge(net.faces[static_cast<std::size_t>(g)], a, b) ? 1 : -1) *
                    (s2 == 0 ? 1 : -1);
                if (!parity.unite(to_id(f), g, df == dg ? 1 : 0)) ++sh.conflicts;
                sub.unite(side, other);
            }
    }
    sh.cls.resize(nf);
    sh.flip.resize(nf);
    for (std::size_t f = 0; f < nf; ++f) {
        const auto [root, p] = parity.find(to_id(f));
        sh.cls[f] = root;
        sh.flip[f] = p;
    }
    // Dense piece ids in order of their smallest side.
    std::vector<std::int32_t> dense(2 * nf, -1);
    sh.piece.assign(2 * nf, -1);
    for (std::size_t side = 0; side < 2 * nf; ++side) {
        if (!has_side(net, side / 2, static_cast<int>(side % 2))) continue;
        const auto root = static_cast<std::size_t>(sub.find(to_id(side)));
        if (dense[root] < 0) {
            dense[root] = to_id(sh.pieces.size());
            sh.pieces.push_back({});
            sh.pieces.back().region = side_region(net, side / 2, static_cast<int>(side % 2));
        }
        sh.piece[side] = dense[root];
    }
    const std::size_t np = sh.pieces.size();
    sh.piece_start.assign(np + 1, 0);
    for (std::int32_t p : sh.piece)
        if (p >= 0) ++sh.piece_start[static_cast<std::size_t>(p) + 1];
    std::partial_sum(sh.piece_start.begin(), sh.piece_start.end(), sh.piece_start.begin());
    sh.piece_sides.resize(static_cast<std::size_t>(sh.piece_start.back()));
    std::vector<std::int32_t> cursor(sh.piece_start.begin(), sh.piece_start.end() - 1);
    for (std::size_t side = 0; side < 2 * nf; ++side)
        if (const std::int32_t p = sh.piece[side]; p >= 0)
            sh.piece_sides[static_cast<std::size_t>(cursor[static_cast<std::size_t>(p)]++)] =
                to_id(side);
    for (std::size_t p = 0; p < np; ++p) {
        Piece& piece = sh.pieces[p];
        const auto b = static_cast<std::size_t>(sh.piece_start[p]);
        const auto e = static_cast<std::size_t>(sh.piece_start[p + 1]);
        piece.sides = e - b;
        piece.lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
        piece.hi = -piece.lo;
        double largest = -1.0;
        for (std::size_t k = b; k < e; ++k) {
            const std::size_t f = static_cast<std::size_t>(sh.piece_sides[k]) / 2;
            const int s = sh.piece_sides[k] % 2;
            for (int i = 0; i < 3; ++i) piece.is_open = piece.is_open || topo.at(f, i, s) < 0;
            const Tri& t = net.faces[f];
            for (std::int32_t v : t) {
                piece.centroid += net.point(v) / 3.0;
                piece.lo = piece.lo.cwiseMin(net.point(v));
                piece.hi = piece.hi.cwiseMax(net.point(v));
            }
            const double area = triangle_area(net, t[0], t[1], t[2]);
            if (area > largest) {
                largest = area;
                piece.largest_face = to_id(f);
            }
        }
        piece.centroid /= static_cast<double>(piece.sides);
        // Relative to the centroid, so that open pieces get a meaningful volume too.
        double six_v = 0.0;
        for (std::size_t k = b; k < e; ++k) {
            const std::int32_t side = sh.piece_sides[k];
            const Tri& t = net.faces[static_cast<std::size_t>(side) / 2];
            const Eigen::Vector3d a = net.point(t[0]) - piece.centroid;
            six_v +=
                sh.sign(side) *
                a.dot((net.point(t[1]) - piece.centroid).cross(net.point(t[2]) - piece.centroid));
        }
        piece.volume = six_v / 6.0;
    }
    return sh;
}

// --- step 2: small components --------------------------------------------------------------

/// Removes pieces of a region's boundary (faces connected through any of its edges) whose
/// |volume| is below the minimum (surfaces read from a file only: for an image, extract
/// compared the voxel volumes) or which have too few faces; a piece goes only if each of
/// its interface faces also lies in a removable piece of the other region. When that would
/// remove every face, nothing goes: the whole input is not a speck. Each component removed
/// is a warning naming its region and place, and a ctx.drop() record. Returns whether
/// anything was removed.
bool remove_small_components(SurfaceNetwork& net, const Topology& topo, const Shells& sh,
                             const RepairParams& params, core::StageContext& ctx) {
    const bool by_volume = !params.is_from_image && params.min_component_volume_mm3 > 0.0;
    const std::size_t np = sh.pieces.size();
    auto nothing_removed = [&](const std::string& why) {
        ctx.count("repair.removed_components", 0);
        ctx.count("repair.removed_component_faces", 0);
        ctx.count("repair.removed_component_volume_mm3", 0);
        ctx.info(why);
        return false;
    };
    if (!by_volume && params.min_component_faces == 0)
        return nothing_removed(params.is_from_image
                                   ? "repair: small components were left out by extract, by "
                                     "their voxel volume"
                                   : "repair: no component limit");
    DisjointSets component(np);  // pieces joined through non-manifold edges
    for (std::size_t f = 0; f < net.face_count(); ++f)
        for (int i = 0; i < 3; ++i)
            for (int s = 0; s < 2; ++s)
                if (topo.at(f, i, s) == k_nonmanifold)
                    for (std::int32_t side : topo.edge_sides(net, f, i, side_region(net, f, s)))
                        component.unite(sh.piece[2 * f + static_cast<std::size_t>(s)],
                                        sh.piece[static_cast<std::size_t>(side)]);
    std::vector<double> volume(np, 0.0);
    std::vector<std::size_t> faces(np, 0);
    std::vector<Eigen::Vector3d> centre(np, Eigen::Vector3d::Zero());
    for (std::size_t p = 0; p < np; ++p) {
        const auto c = static_cast<std::size_t>(component.find(to_id(p)));
        volume[c] += std::abs(sh.pieces[p].volume);
        faces[c] += sh.pieces[p].sides;
        centre[c] += sh.pieces[p].centroid * static_cast<double>(sh.pieces[p].sides);
    }
    std::vector<char> removable(np, 0);
    for (std::size_t p = 0; p < np; ++p)
        if (component.find(to_id(p)) == to_id(p))
            removable[p] = (by_volume && volume[p] < params.min_component_volume_mm3) ||
                           faces[p] < params.min_component_faces;
    if (std::none_of(removable.begin(), removable.end(), [](char r) { return r != 0; }))
        return nothing_removed("repair: no small components");
    const auto small = static_cast<std::size_t>(std::count(removable.begin(), removable.end(), 1));
    auto comp_of_side = [&](std::size_t side) {
        return static_cast<std::size_t>(component.find(sh.piece[side]));
    };
    // Don't tear an interface: a component stays when one of its interface faces lies in a
    // component of the other region that stays. Repeat until nothing changes (each pass
    // that changes something keeps one more component, so at most np + 1 passes).
    for (bool changed = true; changed;) {
        changed = false;
        for (std::size_t f = 0; f < net.face_count(); ++f) {
            if (net.region_out[f] == 0) continue;
            const std::size_t a = comp_of_side(2 * f), b = comp_of_side(2 * f + 1);
            if (removable[a] != removable[b]) {
                removable[a] = removable[b] = 0;
                changed = true;
            }
        }
    }
    std::vector<char> keep(net.face_count(), 1);
    std::size_t removed_faces = 0;
    for (std::size_t f = 0; f < net.face_count(); ++f)
        if (removable[comp_of_side(2 * f)]) {
            keep[f] = 0;
            ++removed_faces;
        }
    const std::string limit =
        "repair.min_component_volume_mm3 = " + format_number(params.min_component_volume_mm3) +
        " mm^3 / min_component_faces = " + std::to_string(params.min_component_faces);
    if (removed_faces == net.face_count()) {
        ctx.warn("repair: every component is smaller than " + limit + "; all are kept");
        return nothing_removed("repair: no component removed");
    }
    std::size_t removed = 0;
    double removed_volume = 0.0;
    constexpr std::size_t kWarned = 20;  // warning lines; the rest are counted
    for (std::size_t p = 0; p < np; ++p) {
        if (!removable[p]) continue;
        ++removed;
        removed_volume += volume[p];
        const Eigen::Vector3d at = centre[p] / static_cast<double>(faces[p]);
        const std::string reason = "smaller than " + limit + " (" + std::to_string(faces[p]) +
                                   " faces enclosing " + format_number(volume[p]) + " mm^3)";
        ctx.drop({sh.pieces[p].region, 0, {at.x(), at.y(), at.z()}, reason});
        if (removed <= kWarned)
            ctx.warn("repair: label " + std::to_string(sh.pieces[p].region) + ": component near " +
                     format_point(at) + " mm not meshed: " + reason);
    }
    if (removed > kWarned)
        ctx.warn("repair: " + std::to_string(removed - kWarned) +
                 " more components not meshed (listed in summary.json, dropped_components)");
    ctx.count("repair.removed_components", static_cast<double>(removed));
    ctx.count("repair.removed_component_faces", static_cast<double>(removed_faces));
    ctx.count("repair.removed_component_volume_mm3", removed_volume);
    ctx.info("repair: removed " + std::to_string(removed) + " small components (" +
             std::to_string(removed_faces) + " faces, " + format_number(removed_volume) +
             " mm^3 summed over the regions' pieces); kept " + std::to_string(small - removed) +
             " small ones sharing an interface with a larger piece");
    if (removed_faces == 0) return false;
    keep_faces(net, keep);
    compact_vertices(net);
    return true;
}

}  // namespace frontmesh::surface::repair_detail
