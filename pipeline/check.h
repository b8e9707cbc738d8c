#pragma once
// `frontmesh check`: validity and quality report of a tetrahedral mesh file of any supported
// format, with the same criteria as the outside referee (meshcheck.py) plus our own
// surface-preservation checks (volume/mesh_check.h).

#include <cstddef>
#include <optional>
#include <string>

#include "io/export.h"
#include "io/label_table.h"
#include "pipeline/core/surface_network.h"
#include "pipeline/core/tet_mesh.h"
#include "volume/mesh_check.h"

namespace frontmesh::pipeline {

/// The figures meshcheck.py decides validity on, computed the same way (plain doubles:
/// these mirror the referee, orientation by exact predicates is in TetMeshCheck).
struct RefereeFigures {
    std::size_t inverted_tets = 0;        ///< V < 0 and not degenerate
    std::size_t degenerate_tets = 0;      ///< |V| < 1e-12 mean |V|
    std::size_t nonconforming_faces = 0;  ///< faces of more than two tets
    std::size_t duplicate_tets = 0;
    std::size_t same_side_faces = 0;       ///< interior faces whose two tets lie on one side
    std::size_t duplicate_nodes = 0;       ///< used nodes at identical coordinates
    std::size_t boundary_faces = 0;        ///< faces of one tet
    std::size_t interface_faces = 0;       ///< faces between tets of two regions
    std::size_t open_edges = 0;            ///< boundary edges of one boundary face
    std::size_t nonmanifold_edges = 0;     ///< boundary edges of more than two
    std::size_t nonmanifold_vertices = 0;  ///< boundary vertices with more than one fan
    std::size_t misoriented_edges = 0;
    std::size_t boundary_components = 0;
    double volume = 0.0;           ///< sum of signed tet volumes, mm^3
    double enclosed_volume = 0.0;  ///< by the boundary faces (divergence theorem)
    double volume_rel_diff = 0.0;
    bool closed_manifold() const {
        return boundary_faces > 0 && open_edges == 0 && nonmanifold_edges == 0 &&
               nonmanifold_vertices == 0;
    }
    /// meshcheck.py's "valid".
    bool valid() const {
        return inverted_tets == 0 && degenerate_tets == 0 && nonconforming_faces == 0 &&
               duplicate_tets == 0 && same_side_faces == 0 && volume_rel_diff < 1e-6 &&
               closed_manifold();
    }
};

/// Triangle quality (Eq. 2) of the boundary and interface faces.
struct TriangleFigures {
    std::size_t triangles = 0;
    double mean_eta = 0.0, max_eta = 0.0;
    std::size_t eta_over_08 = 0;
    double min_angle_deg = 180.0, max_angle_deg = 0.0;
};

/// Preservation of a reference surface (meshcheck.py --surface): vertices matched up to
/// 1e-9 of the reference's bounding-box diagonal.
struct PreservationFigures {
    std::size_t ref_vertices = 0, ref_vertices_matched = 0;
    std::size_t ref_triangles = 0;
    std::size_t ref_triangles_in_mesh = 0;     ///< a face of some tet
    std::size_t ref_triangles_on_surface = 0;  ///< a boundary or interface face
    std::size_t mesh_surface_faces = 0;        ///< boundary + interface faces of the tets
    std::size_t mesh_surface_faces_in_ref = 0;
    bool preserved() const {
        return ref_triangles_in_mesh == ref_triangles &&
               mesh_surface_faces_in_ref == mesh_surface_faces;
    }
};

struct MeshReport {
    std::string file;
    std::string format;
    io::MeshReadInfo read;  ///< triangles found / ignored / added by the reader
    io::LabelTable names;
    volume::TetMeshCheck check;  ///< ours: exact orientation, faces kept, quality
    RefereeFigures referee;
    TriangleFigures surface_quality;
    std::optional<PreservationFigures> preservation;
    std::string reference;  ///< the reference surface file, if any

    /// Valid by the referee's criteria, by ours (the mesh's recorded faces are faces of its
    /// tets, on the right side), and the reference surface (if given) preserved exactly.
    bool valid() const {
        return referee.valid() && check.valid() && (!preservation || preservation->preserved());
    }
    /// Human-readable report (several lines, ending with "RESULT VALID|INVALID").
    std::string text() const;
    /// All figures as one JSON object.
    std::string json() const;
};

/// Checks a mesh in memory; `reference` is an optional surface that must be preserved.
MeshReport check_mesh(const core::TetMesh& mesh, const core::SurfaceNetwork* reference = nullptr);

/// Reads `path` (io::read_mesh: .vtu .msh .mesh .inp; tets kept in the file's node order,
/// inverted ones too) and checks it; `reference_surface`
/// (optional, io::read_surface formats) must then be preserved. Throws InputError for
/// unreadable input.
MeshReport check_mesh_file(const std::string& path, const std::string& reference_surface = "");

}  // namespace frontmesh::pipeline
