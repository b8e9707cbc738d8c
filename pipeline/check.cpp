#include "pipeline/check.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <iomanip>
#include <numeric>
#include <sstream>
#include <unordered_map>
#include <vector>

#include <tbb/parallel_sort.h>

#include "io/mesh_io.h"
#include "pipeline/core/error.h"
#include "pipeline/core/input_file.h"
#include "pipeline/core/quality.h"

namespace frontmesh::pipeline {
namespace {

using Key = std::array<std::int32_t, 3>;

// Face k of a tet is opposite node k, oriented outward for a positive tet (as meshcheck.py).
constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};

struct FaceOcc {
    Key key;                                  // sorted nodes
    std::int32_t occ;                         // 4 * tet + k
    bool operator<(const FaceOcc& o) const {  // by hand: std::array's == is a memcmp call
        if (key[0] != o.key[0]) return key[0] < o.key[0];
        if (key[1] != o.key[1]) return key[1] < o.key[1];
        if (key[2] != o.key[2]) return key[2] < o.key[2];
        return occ < o.occ;
    }
    bool same_face(const FaceOcc& o) const {
        return key[0] == o.key[0] && key[1] == o.key[1] && key[2] == o.key[2];
    }
};

Key face_of(const core::TetMesh& mesh, std::int32_t occ) {
    const auto& t = mesh.tets[static_cast<std::size_t>(occ / 4)];
    const int k = occ % 4;
    return {t[kFace[k][0]], t[kFace[k][1]], t[kFace[k][2]]};
}

Key sorted(Key k) {
    std::sort(k.begin(), k.end());
    return k;
}

struct KeyHash {
    std::size_t operator()(const Key& k) const noexcept {
        std::uint64_t h = 1469598103934665603ull;
        for (std::int32_t v : k) h = (h ^ static_cast<std::uint32_t>(v)) * 1099511628211ull;
        return static_cast<std::size_t>(h);
    }
};

struct UnionFind {
    std::vector<std::int32_t> parent;
    explicit UnionFind(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
    std::int32_t find(std::int32_t a) {
        while (parent[static_cast<std::size_t>(a)] != a) {
            parent[static_cast<std::size_t>(a)] =
                parent[static_cast<std::size_t>(parent[static_cast<std::size_t>(a)])];
            a = parent[static_cast<std::size_t>(a)];
        }
        return a;
    }
    void unite(std::int32_t a, std::int32_t b) {
        a = find(a);
        b = find(b);
        if (a != b) parent[static_cast<std::size_t>(std::max(a, b))] = std::min(a, b);
    }
};

/// Topology of the boundary faces (faces of one tet), as meshcheck.py's surface_topology.
void boundary_topology(const std::vector<Key>& faces, RefereeFigures& r) {
    struct EdgeOcc {
        std::int32_t a, b;    // sorted
        std::int32_t corner;  // 3 f + j: directed edge from corner j to j + 1
        bool operator<(const EdgeOcc& o) const {
            return a != o.a ? a < o.a : b != o.b ? b < o.b : corner < o.corner;
        }
    };
    std::vector<EdgeOcc> edges;
    edges.reserve(3 * faces.size());
    for (std::size_t f = 0; f < faces.size(); ++f)
        for (int j = 0; j < 3; ++j) {
            const std::int32_t u = faces[f][static_cast<std::size_t>(j)],
                               v = faces[f][static_cast<std::size_t>((j + 1) % 3)];
            edges.push_back({std::min(u, v), std::max(u, v),
                             static_cast<std::int32_t>(3 * f + static_cast<std::size_t>(j))});
        }
    tbb::parallel_sort(edges.begin(), edges.end());
    UnionFind corners(3 * faces.size());  // corners joined across manifold edges
    UnionFind patches(faces.size());      // faces joined across any shared edge
    auto next = [](std::int32_t c) { return 3 * (c / 3) + (c % 3 + 1) % 3; };
    for (std::size_t i = 0; i < edges.size();) {
        std::size_t j = i + 1;
        while (j < edges.size() && edges[j].a == edges[i].a && edges[j].b == edges[i].b) ++j;
        const std::size_t n = j - i;
        if (n == 1) ++r.open_edges;
        if (n > 2) ++r.nonmanifold_edges;
        for (std::size_t k = i + 1; k < j; ++k)
            patches.unite(edges[i].corner / 3, edges[k].corner / 3);
        if (n == 2) {
            const std::int32_t e1 = edges[i].corner, e2 = edges[i + 1].corner;
            // Corner of e1's start vertex meets the corner of the same vertex in e2.
            const auto start = [&](std::int32_t c) {
                return faces[static_cast<std::size_t>(c / 3)][static_cast<std::size_t>(c % 3)];
            };
            const bool same_dir = start(e1) == start(e2);
            if (same_dir) ++r.misoriented_edges;
            corners.unite(e1, same_dir ? e2 : next(e2));
            corners.unite(next(e1), same_dir ? next(e2) : e2);
        }
        i = j;
    }
    // A vertex is manifold when its corners form one fan.
    std::vector<std::pair<std::int32_t, std::int32_t>> vertex_fan;  // (vertex, corner root)
    vertex_fan.reserve(3 * faces.size());
    for (std::size_t c = 0; c < 3 * faces.size(); ++c)
        vertex_fan.push_back({faces[c / 3][c % 3], corners.find(static_cast<std::int32_t>(c))});
    std::sort(vertex_fan.begin(), vertex_fan.end());
    vertex_fan.erase(std::unique(vertex_fan.begin(), vertex_fan.end()), vertex_fan.end());
    for (std::size_t i = 0; i < vertex_fan.size();) {
        std::size_t j = i + 1;
        while (j < vertex_fan.size() && vertex_fan[j].first == vertex_fan[i].first) ++j;
        if (j - i > 1) ++r.nonmanifold_vertices;
        i = j;
    }
    std::size_t components = 0;
    for (std::size_t f = 0; f < faces.size(); ++f)
        if (patches.find(static_cast<std::int32_t>(f)) == static_cast<std::int32_t>(f))
            ++components;
    r.boundary_components = components;
}

Eigen::Vector3d to_vec(const double* p) { return {p[0], p[1], p[2]}; }

PreservationFigures preservation(const core::TetMesh& mesh, const std::vector<Key>& all_faces,
                                 const std::vector<Key>& surface_faces,
                                 const core::SurfaceNetwork& ref) {
    PreservationFigures p;
    const std::size_t nr = ref.xyz.size() / 3;
    p.ref_vertices = nr;
    p.ref_triangles = ref.faces.size();
    p.mesh_surface_faces = surface_faces.size();
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = Eigen::Vector3d::Constant(-1e300);
    for (std::size_t v = 0; v < nr; ++v) {
        lo = lo.cwiseMin(to_vec(&ref.xyz[3 * v]));
        hi = hi.cwiseMax(to_vec(&ref.xyz[3 * v]));
    }
    double diag = nr ? (hi - lo).norm() : 1.0;
    if (diag == 0.0) diag = 1.0;
    const double h = 1e-9 * diag;
    // Mesh nodes in a hash grid of cell h; a reference vertex matches a node within h.
    using Cell = std::array<std::int64_t, 3>;
    struct CellHash {
        std::size_t operator()(const Cell& c) const noexcept {
            return static_cast<std::size_t>(c[0] * 73856093LL ^ c[1] * 19349663LL ^
                                            c[2] * 83492791LL);
        }
    };
    auto cell_of = [&](const Eigen::Vector3d& x) {
        return Cell{static_cast<std::int64_t>(std::floor((x.x() - lo.x()) / h)),
                    static_cast<std::int64_t>(std::floor((x.y() - lo.y()) / h)),
                    static_cast<std::int64_t>(std::floor((x.z() - lo.z()) / h))};
    };
    std::unordered_multimap<Cell, std::int32_t, CellHash> grid;
    grid.reserve(mesh.node_count());
    for (std::size_t v = 0; v < mesh.node_count(); ++v) {
        const Eigen::Vector3d x = mesh.point(static_cast<std::int32_t>(v));
        if ((x.array() < lo.array() - 2 * h).any() || (x.array() > hi.array() + 2 * h).any())
            continue;
        grid.emplace(cell_of(x), static_cast<std::int32_t>(v));
    }
    std::vector<std::int32_t> match(nr, -1);
    for (std::size_t v = 0; v < nr; ++v) {
        const Eigen::Vector3d x = to_vec(&ref.xyz[3 * v]);
        const Cell c = cell_of(x);
        double best = h;
        for (int dx = -1; dx <= 1; ++dx)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dz = -1; dz <= 1; ++dz) {
                    const auto range = grid.equal_range({c[0] + dx, c[1] + dy, c[2] + dz});
                    for (auto it = range.first; it != range.second; ++it) {
                        const double d = (mesh.point(it->second) - x).norm();
                        if (d <= best && (match[v] < 0 || it->second < match[v] || d < best)) {
                            best = d;
                            match[v] = it->second;
                        }
                    }
                }
        if (match[v] >= 0) ++p.ref_vertices_matched;
    }
    std::vector<Key> all = all_faces, surf;
    surf.reserve(surface_faces.size());
    for (const auto& f : surface_faces) surf.push_back(sorted(f));
    std::sort(all.begin(), all.end());
    std::sort(surf.begin(), surf.end());
    std::vector<Key> ref_keys;
    for (const auto& f : ref.faces) {
        const std::int32_t a = match[static_cast<std::size_t>(f[0])],
                           b = match[static_cast<std::size_t>(f[1])],
                           c = match[static_cast<std::size_t>(f[2])];
        if (a < 0 || b < 0 || c < 0) continue;
        const Key k = sorted({a, b, c});
        ref_keys.push_back(k);
        if (std::binary_search(all.begin(), all.end(), k)) ++p.ref_triangles_in_mesh;
        if (std::binary_search(surf.begin(), surf.end(), k)) ++p.ref_triangles_on_surface;
    }
    std::sort(ref_keys.begin(), ref_keys.end());
    for (const auto& k : surf)
        if (std::binary_search(ref_keys.begin(), ref_keys.end(), k)) ++p.mesh_surface_faces_in_ref;
    return p;
}

// ---------------------------------------------------------------------------- formatting
std::string num(double v, int precision = 6) {
    if (!std::isfinite(v)) return "null";
    std::ostringstream s;
    s << std::setprecision(precision) << v;
    return s.str();
}

std::string percent(std::size_t part, std::size_t whole) {
    std::ostringstream s;
    s << std::fixed << std::setprecision(3) << (whole ? 100.0 * double(part) / double(whole) : 0.0)
      << '%';
    return s.str();
}

std::string quoted(const std::string& s) {
    std::string out = "\"";
    for (char c : s) {
        if (c == '"' || c == '\\') out += '\\';
        if (static_cast<unsigned char>(c) < 0x20) {
            char buf[8];
            std::snprintf(buf, sizeof buf, "\\u%04x", c);
            out += buf;
            continue;
        }
        out += c;
    }
    return out + "\"";
}

template <std::size_t N>
std::string json_array(const std::array<std::size_t, N>& a) {
    std::string s = "[";
    for (std::size_t i = 0; i < N; ++i) s += (i ? ", " : "") + std::to_string(a[i]);
    return s + "]";
}

std::string quality_json(const volume::TetQuality& q) {
    std::ostringstream s;
    s << "{\"tets\": " << q.tets << ", \"skewness_mean\": " << num(q.mean_skewness)
      << ", \"skewness_max\": " << num(q.max_skewness)
      << ", \"skewness_over_0_8\": " << q.skewness_over_08 << ", \"skewness_frac_gt_0_8\": "
      << num(q.tets ? double(q.skewness_over_08) / double(q.tets) : 0.0)
      << ", \"min_dihedral_deg\": " << num(q.min_dihedral_deg)
      << ", \"max_dihedral_deg\": " << num(q.max_dihedral_deg)
      << ", \"skewness_histogram_0_to_1\": " << json_array(q.skewness_histogram)
      << ", \"min_dihedral_histogram_10deg\": " << json_array(q.dihedral_histogram) << "}";
    return s.str();
}

}  // namespace

MeshReport check_mesh(const core::TetMesh& mesh, const core::SurfaceNetwork* reference) {
    if (mesh.tet_count() == 0) FM_THROW(InputError, "the mesh has no tetrahedra");
    MeshReport report;
    report.check = volume::check_tet_mesh(mesh);
    RefereeFigures& r = report.referee;
    const std::size_t nt = mesh.tet_count();

    // Volumes: inverted / degenerate exactly as the referee decides them.
    std::vector<double> vol(nt);
    double abs_sum = 0.0;
    for (std::size_t t = 0; t < nt; ++t) {
        const auto& q = mesh.tets[t];
        vol[t] = core::tet_signed_volume(mesh.point(q[0]), mesh.point(q[1]), mesh.point(q[2]),
                                         mesh.point(q[3]));
        abs_sum += std::abs(vol[t]);
        r.volume += vol[t];
    }
    const double mean_abs = abs_sum / double(nt);
    for (std::size_t t = 0; t < nt; ++t) {
        const bool degenerate = std::abs(vol[t]) < 1e-12 * mean_abs;
        if (degenerate)
            ++r.degenerate_tets;
        else if (vol[t] < 0)
            ++r.inverted_tets;
    }

    // Duplicate nodes among the used ones (identical coordinates).
    {
        std::vector<char> used(mesh.node_count(), 0);
        for (const auto& q : mesh.tets)
            for (std::int32_t v : q) used[static_cast<std::size_t>(v)] = 1;
        std::vector<std::array<double, 3>> pts;
        for (std::size_t v = 0; v < mesh.node_count(); ++v)
            if (used[v]) pts.push_back({mesh.xyz[3 * v], mesh.xyz[3 * v + 1], mesh.xyz[3 * v + 2]});
        tbb::parallel_sort(pts.begin(), pts.end());
        for (std::size_t i = 1; i < pts.size(); ++i)
            if (pts[i] == pts[i - 1]) ++r.duplicate_nodes;
    }

    // Faces: group the 4 nt occurrences by their node set.
    std::vector<FaceOcc> occ(4 * nt);
    for (std::size_t t = 0; t < nt; ++t)
        for (int k = 0; k < 4; ++k) {
            const auto o = static_cast<std::int32_t>(4 * t + static_cast<std::size_t>(k));
            occ[4 * t + static_cast<std::size_t>(k)] = {sorted(face_of(mesh, o)), o};
        }
    tbb::parallel_sort(occ.begin(), occ.end());
    std::vector<Key> boundary, all_faces, surface_faces;
    auto opposite = [&](std::int32_t o) {
        return mesh.tets[static_cast<std::size_t>(o / 4)][static_cast<std::size_t>(o % 4)];
    };
    for (std::size_t i = 0; i < occ.size();) {
        std::size_t j = i + 1;
        while (j < occ.size() && occ[j].same_face(occ[i])) ++j;
        all_faces.push_back(occ[i].key);
        const std::size_t n = j - i;
        if (n == 1) {
            boundary.push_back(face_of(mesh, occ[i].occ));
            surface_faces.push_back(occ[i].key);
        } else if (n == 2) {
            const std::int32_t a = occ[i].occ, b = occ[i + 1].occ;
            const std::int32_t va = opposite(a), vb = opposite(b);
            if (va == vb) {
                ++r.duplicate_tets;  // counted 4 times per duplicate pair, rounded below
            } else {
                // Both opposite nodes against the plane of the face as seen from tet a.
                const Key f = face_of(mesh, a);
                const Eigen::Vector3d p0 = mesh.point(f[0]);
                const Eigen::Vector3d nrm = (mesh.point(f[1]) - p0).cross(mesh.point(f[2]) - p0);
                const double sa = (mesh.point(va) - p0).dot(nrm),
                             sb = (mesh.point(vb) - p0).dot(nrm);
                if ((sa > 0 && sb > 0) || (sa < 0 && sb < 0)) ++r.same_side_faces;
            }
            if (mesh.region[static_cast<std::size_t>(a / 4)] !=
                mesh.region[static_cast<std::size_t>(b / 4)]) {
                ++r.interface_faces;
                surface_faces.push_back(occ[i].key);
            }
        } else {
            ++r.nonconforming_faces;
            std::vector<std::int32_t> opp;
            for (std::size_t k = i; k < j; ++k) opp.push_back(opposite(occ[k].occ));
            std::sort(opp.begin(), opp.end());
            r.duplicate_tets += opp.size() - static_cast<std::size_t>(
                                                 std::unique(opp.begin(), opp.end()) - opp.begin());
        }
        i = j;
    }
    r.duplicate_tets = (r.duplicate_tets + 2) / 4;
    r.boundary_faces = boundary.size();
    boundary_topology(boundary, r);
    {
        // Enclosed volume about the centroid of the used nodes (as the referee).
        Eigen::Vector3d c = Eigen::Vector3d::Zero();
        std::vector<char> used(mesh.node_count(), 0);
        std::size_t n_used = 0;
        for (const auto& q : mesh.tets)
            for (std::int32_t v : q)
                if (!used[static_cast<std::size_t>(v)]) {
                    used[static_cast<std::size_t>(v)] = 1;
                    c += mesh.point(v);
                    ++n_used;
                }
        c /= double(std::max<std::size_t>(n_used, 1));
        for (const auto& f : boundary) {
            const Eigen::Vector3d q0 = mesh.point(f[0]) - c, q1 = mesh.point(f[1]) - c,
                                  q2 = mesh.point(f[2]) - c;
            r.enclosed_volume += q0.dot(q1.cross(q2)) / 6.0;
        }
        r.volume_rel_diff =
            std::abs(r.volume - r.enclosed_volume) / std::max(std::abs(r.enclosed_volume), 1e-300);
    }

    // Triangle quality (Eq. 2) of the recorded boundary and interface faces.
    TriangleFigures& s = report.surface_quality;
    for (const auto& f : mesh.faces) {
        const Eigen::Vector3d a = mesh.point(f[0]), b = mesh.point(f[1]), c = mesh.point(f[2]);
        const double eta = core::triangle_skewness(a, b, c);  // Eq. 2
        const double min_angle = core::triangle_min_angle_deg(a, b, c);
        ++s.triangles;
        s.mean_eta += eta;
        s.max_eta = std::max(s.max_eta, eta);
        if (eta > 0.8) ++s.eta_over_08;
        s.min_angle_deg = std::min(s.min_angle_deg, min_angle);
        // Largest angle from the law of cosines at each corner.
        const double la = (b - c).norm(), lb = (c - a).norm(), lc = (a - b).norm();
        const std::array<std::array<double, 3>, 3> sides{
            {{la, lb, lc}, {lb, lc, la}, {lc, la, lb}}};
        for (const auto& [x, y, z] : sides) {
            const double cosv = std::clamp((y * y + z * z - x * x) / (2 * y * z), -1.0, 1.0);
            s.max_angle_deg = std::max(s.max_angle_deg, std::acos(cosv) * 180.0 / M_PI);
        }
    }
    if (s.triangles) s.mean_eta /= double(s.triangles);

    if (reference) report.preservation = preservation(mesh, all_faces, surface_faces, *reference);
    return report;
}

MeshReport check_mesh_file(const std::string& path, const std::string& reference_surface) {
    io::LabelTable names;
    io::MeshReadInfo info;
    // stat first: a named pipe or device would block the readers.
    core::require_input_file(path, "check: ");
    if (!reference_surface.empty()) core::require_input_file(reference_surface, "--surface ");
    const core::TetMesh mesh = io::read_mesh(path, &names, &info, /*keep_orientation=*/true);
    std::optional<core::SurfaceNetwork> ref;
    if (!reference_surface.empty()) {
        ref = io::read_surface(reference_surface);
        if (ref->faces.empty()) FM_THROW(InputError, reference_surface + ": no triangles found");
    }
    MeshReport report = check_mesh(mesh, ref ? &*ref : nullptr);
    report.file = path;
    report.format = info.format;
    report.read = std::move(info);
    report.names = std::move(names);
    report.reference = reference_surface;
    return report;
}

std::string MeshReport::text() const {
    std::ostringstream o;
    const auto& c = check;
    const auto& r = referee;
    const auto& q = c.quality;
    o << "mesh      " << file << " (" << format << "): " << c.nodes << " nodes, " << c.tets
      << " tets, " << c.region_volume.size() << " region"
      << (c.region_volume.size() == 1 ? "" : "s") << ", " << r.boundary_faces << " boundary + "
      << r.interface_faces << " interface faces\n";
    if (read.file_triangles || read.derived_faces)
        o << "          file triangles " << read.file_triangles << " (" << read.ignored_triangles
          << " not boundary/interface faces of the tets), faces derived from the tets "
          << read.derived_faces << '\n';
    o << "validity  inverted " << r.inverted_tets << " (exact: " << c.inverted_tets
      << "), degenerate " << r.degenerate_tets << ", non-conforming faces " << r.nonconforming_faces
      << ", duplicate tets " << r.duplicate_tets << ", same-side interior faces "
      << r.same_side_faces << ", unused nodes " << c.unused_nodes << ", duplicate nodes "
      << r.duplicate_nodes << '\n';
    o << "boundary  closed 2-manifold " << (r.closed_manifold() ? "yes" : "NO") << " (open edges "
      << r.open_edges << ", non-manifold edges " << r.nonmanifold_edges << ", vertices "
      << r.nonmanifold_vertices << ", misoriented edges " << r.misoriented_edges << "), "
      << r.boundary_components << " component" << (r.boundary_components == 1 ? "" : "s") << '\n';
    o << "faces     recorded boundary/interface faces kept: "
      << (c.missing_faces == 0 && c.wrong_side_faces == 0 ? "yes" : "NO") << " (missing "
      << c.missing_faces << ", wrong side " << c.wrong_side_faces << ", inner faces on surface "
      << c.inner_faces_on_surface << ", open faces not recorded " << c.open_faces << ")\n";
    o << "volume    " << num(r.volume, 9) << " mm^3, enclosed by the boundary "
      << num(r.enclosed_volume, 9) << ", rel diff " << num(r.volume_rel_diff, 3) << '\n';
    if (c.region_volume.size() > 1 || !names.empty())
        for (const auto& [label, v] : c.region_volume) {
            const auto it = c.region_quality.find(label);
            o << "  region " << label;
            if (names.has(label)) o << ' ' << names.name(label);
            o << ": " << (it != c.region_quality.end() ? it->second.tets : 0) << " tets, volume "
              << num(v) << " mm^3, skewness > 0.8: "
              << (it != c.region_quality.end()
                      ? percent(it->second.skewness_over_08, it->second.tets)
                      : "-")
              << '\n';
        }
    o << "skewness  (Eq. 1) mean " << num(q.mean_skewness, 4) << ", max " << num(q.max_skewness, 4)
      << ", > 0.8: " << q.skewness_over_08 << " tets (" << percent(q.skewness_over_08, q.tets)
      << "), histogram " << json_array(q.skewness_histogram) << '\n';
    o << "dihedral  min " << num(q.min_dihedral_deg, 4) << " deg, max "
      << num(q.max_dihedral_deg, 4) << " deg\n";
    o << "surface   " << surface_quality.triangles << " triangles, eta (Eq. 2) mean "
      << num(surface_quality.mean_eta, 4) << ", max " << num(surface_quality.max_eta, 4)
      << ", > 0.8: " << surface_quality.eta_over_08 << ", angles "
      << num(surface_quality.min_angle_deg, 4) << " .. " << num(surface_quality.max_angle_deg, 4)
      << " deg\n";
    if (preservation) {
        const auto& p = *preservation;
        o << "reference " << reference << ": " << p.ref_triangles_in_mesh << " of "
          << p.ref_triangles << " triangles are mesh faces (" << p.ref_triangles_on_surface
          << " on the boundary/interfaces), " << p.mesh_surface_faces_in_ref << " of "
          << p.mesh_surface_faces
          << " mesh boundary/interface faces are reference triangles: preserved "
          << (p.preserved() ? "yes" : "NO") << '\n';
    }
    o << "RESULT    " << (valid() ? "VALID" : "INVALID") << '\n';
    return o.str();
}

std::string MeshReport::json() const {
    std::ostringstream o;
    const auto& c = check;
    const auto& r = referee;
    o << "{\n \"file\": " << quoted(file) << ",\n \"format\": " << quoted(format)
      << ",\n \"valid\": " << (valid() ? "true" : "false")
      << ",\n \"valid_by_referee_criteria\": " << (r.valid() ? "true" : "false")
      << ",\n \"faces_kept\": " << (c.valid() ? "true" : "false") << ",\n \"n_nodes\": " << c.nodes
      << ",\n \"n_tets\": " << c.tets << ",\n \"n_regions\": " << c.region_volume.size()
      << ",\n \"boundary_faces\": " << r.boundary_faces
      << ",\n \"interface_faces\": " << r.interface_faces
      << ",\n \"file_triangles\": " << read.file_triangles
      << ",\n \"ignored_triangles\": " << read.ignored_triangles
      << ",\n \"derived_faces\": " << read.derived_faces
      << ",\n \"inverted_tets\": " << r.inverted_tets
      << ",\n \"inverted_tets_exact\": " << c.inverted_tets
      << ",\n \"degenerate_tets\": " << r.degenerate_tets
      << ",\n \"nonconforming_faces\": " << r.nonconforming_faces
      << ",\n \"duplicate_tets\": " << r.duplicate_tets
      << ",\n \"same_side_interior_faces\": " << r.same_side_faces
      << ",\n \"unused_nodes\": " << c.unused_nodes
      << ",\n \"duplicate_nodes\": " << r.duplicate_nodes << ",\n \"open_faces\": " << c.open_faces
      << ",\n \"missing_faces\": " << c.missing_faces
      << ",\n \"wrong_side_faces\": " << c.wrong_side_faces
      << ",\n \"inner_faces_on_surface\": " << c.inner_faces_on_surface
      << ",\n \"boundary\": {\"closed_manifold\": " << (r.closed_manifold() ? "true" : "false")
      << ", \"open_edges\": " << r.open_edges << ", \"nonmanifold_edges\": " << r.nonmanifold_edges
      << ", \"nonmanifold_vertices\": " << r.nonmanifold_vertices
      << ", \"misoriented_edges\": " << r.misoriented_edges
      << ", \"n_components\": " << r.boundary_components << "},\n \"volume\": " << num(r.volume, 12)
      << ",\n \"enclosed_volume\": " << num(r.enclosed_volume, 12)
      << ",\n \"volume_rel_diff\": " << num(r.volume_rel_diff, 4)
      << ",\n \"quality\": " << quality_json(c.quality) << ",\n \"regions\": {";
    bool first = true;
    for (const auto& [label, v] : c.region_volume) {
        o << (first ? "\n  " : ",\n  ") << quoted(std::to_string(label))
          << ": {\"name\": " << quoted(names.name(label)) << ", \"volume\": " << num(v, 12);
        if (const auto it = c.region_enclosed_volume.find(label);
            it != c.region_enclosed_volume.end())
            o << ", \"enclosed_volume\": " << num(it->second, 12);
        if (const auto it = c.region_quality.find(label); it != c.region_quality.end())
            o << ", \"quality\": " << quality_json(it->second);
        o << "}";
        first = false;
    }
    const auto& s = surface_quality;
    o << "\n },\n \"surface_triangles\": {\"n\": " << s.triangles
      << ", \"eta_mean\": " << num(s.mean_eta) << ", \"eta_max\": " << num(s.max_eta)
      << ", \"eta_over_0_8\": " << s.eta_over_08 << ", \"min_angle_deg\": " << num(s.min_angle_deg)
      << ", \"max_angle_deg\": " << num(s.max_angle_deg) << "}";
    if (preservation) {
        const auto& p = *preservation;
        o << ",\n \"reference\": " << quoted(reference)
          << ",\n \"preservation\": {\"ref_vertices\": " << p.ref_vertices
          << ", \"ref_vertices_matched\": " << p.ref_vertices_matched
          << ", \"ref_triangles\": " << p.ref_triangles
          << ", \"ref_triangles_in_mesh\": " << p.ref_triangles_in_mesh
          << ", \"ref_triangles_on_surface\": " << p.ref_triangles_on_surface
          << ", \"mesh_surface_faces\": " << p.mesh_surface_faces
          << ", \"mesh_surface_faces_in_ref\": " << p.mesh_surface_faces_in_ref
          << ", \"preserved\": " << (p.preserved() ? "true" : "false") << "}";
    }
    o << "\n}\n";
    return o.str();
}

}  // namespace frontmesh::pipeline
