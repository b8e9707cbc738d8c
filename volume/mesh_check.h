#pragma once
// Our own validity and quality checks of a tetrahedral mesh (besides meshcheck.py, the
// outside referee). Used by the tests, the run summary and `frontmesh check`.

#include <array>
#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "pipeline/core/quality.h"
#include "pipeline/core/tet_mesh.h"

namespace frontmesh::volume {

using core::Label;

/// Quality figures of a set of tets (skewness Eq. 1, dihedral angles in degrees).
struct TetQuality {
    std::size_t tets = 0;
    double mean_skewness = 0.0;
    double max_skewness = 0.0;
    std::size_t skewness_over_08 = 0;  ///< tets with skewness > 0.8
    double min_dihedral_deg = 180.0;
    double max_dihedral_deg = 0.0;
    std::array<std::size_t, 10> skewness_histogram{};  ///< bins of 0.1 over [0, 1]
    std::array<std::size_t, 18> dihedral_histogram{};  ///< min dihedral, bins of 10 degrees
};

/// Result of check_tet_mesh. valid() when the mesh is a conforming tetrahedralisation of
/// exactly its boundary faces.
struct TetMeshCheck {
    std::size_t nodes = 0;
    std::size_t tets = 0;
    std::size_t inverted_tets = 0;           ///< signed volume <= 0 (exact orientation)
    std::size_t nonconforming_faces = 0;     ///< a face shared by more than two tets
    std::size_t open_faces = 0;              ///< faces of one tet that are not boundary faces
    std::size_t missing_faces = 0;           ///< boundary faces that no tet has
    std::size_t wrong_side_faces = 0;        ///< boundary faces met by a tet of the wrong region
                                             ///< or orientation
    std::size_t inner_faces_on_surface = 0;  ///< faces between two tets of one region that are
                                             ///< boundary faces
    std::size_t unused_nodes = 0;            ///< nodes in no tet (not an error, reported)
    double volume = 0.0;                     ///< sum of tet volumes, mm^3
    double enclosed_volume = 0.0;            ///< volume enclosed by the boundary faces, mm^3
    std::map<Label, double> region_volume;   ///< tets
    std::map<Label, double> region_enclosed_volume;  ///< boundary faces
    TetQuality quality;
    std::map<Label, TetQuality> region_quality;

    bool valid() const {
        return inverted_tets == 0 && nonconforming_faces == 0 && open_faces == 0 &&
               missing_faces == 0 && wrong_side_faces == 0 && inner_faces_on_surface == 0;
    }
    /// One line: counts, validity, volume error, quality.
    std::string summary() const;
};

/// core::tet_figures of every tet of `mesh`, in tet order (TBB, identical for any thread
/// count). The runner computes them once per mesh for the checks, the checkpoint's cell
/// arrays and the quality report. 32 MB per million tets.
std::vector<core::TetFigures> tet_figures(const core::TetMesh& mesh);

/// Quality of all tets of `mesh` (TBB, identical for any thread count). `figures`, when
/// given, are tet_figures(mesh) (else computed here).
TetQuality tet_quality(const core::TetMesh& mesh,
                       const std::vector<core::TetFigures>* figures = nullptr);

/// Checks validity (conformity, orientation by exact predicates, boundary faces preserved
/// with their regions) and quality, overall and per region. `figures` as for tet_quality.
TetMeshCheck check_tet_mesh(const core::TetMesh& mesh,
                            const std::vector<core::TetFigures>* figures = nullptr);

}  // namespace frontmesh::volume
