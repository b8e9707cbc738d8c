#include "volume/tetra_mesher.h"

#include <algorithm>
#include <sstream>

#include "pipeline/core/error.h"

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

/// Closing rounds until the front is empty, at most max_closing_rounds + 1; their number.
std::int64_t RegionMesher::close_cavities() {
    std::int64_t closing_rounds = 0;
    for (std::int32_t round = 0; front_.size() > 0 && round <= params_.max_closing_rounds;
         ++round) {
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
    std::int64_t remeshes = 0, closing_rounds = 0, closing_tets = 0, levels = 0;
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
    ctx.count("tetra.max_levels", static_cast<double>(levels));
    ctx.info("tetra: " + std::to_string(mesh.tet_count()) + " tets, " +
             std::to_string(mesh.node_count()) + " nodes, " + std::to_string(results.size()) +
             " regions, " + std::to_string(remeshes) + " local remeshings");
    return mesh;
}

}  // namespace frontmesh::volume::detail
