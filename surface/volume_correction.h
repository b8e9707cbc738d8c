#pragma once
// Region volumes of an extracted surface brought back to their voxel volumes (issue 20,
// item 5): surface nets cuts every voxel corner and its smoothing rounds the rest, so a
// small or thin region encloses several per cent less than its voxels (a 1,000-voxel blob
// about 7%, a tube four voxels across about 8%).

#include <map>

#include "pipeline/core/ids.h"
#include "pipeline/core/surface_network.h"

namespace frontmesh::surface {

struct VolumeCorrection {
    int passes = 0;                     ///< least-squares passes run
    double worst_before = 0.0;          ///< largest |V / V_voxels - 1| before (fraction)
    double worst_after = 0.0;           ///< and after
    core::Label worst_region = 0;       ///< the region of worst_after
    std::size_t vertices_put_back = 0;  ///< moved vertices restored where faces crossed
};

/// Moves the faces of `surface` along their normals so that every region of `target_mm3`
/// (label -> voxel volume) encloses that volume. Each region r gets one offset o_r (mm,
/// outward; the outside 0): a face between a and b moves by o_a - o_b, which changes the
/// volume of a by area * (o_a - o_b) and that of b by the opposite. The offsets solve the
/// weighted graph Laplacian system  sum_b A_ab (o_a - o_b) = T_a - V_a  (A_ab: area shared,
/// b = 0 included with o_0 = 0; symmetric positive definite since every region reaches the
/// outside through its neighbours), clamped to |o| <= `max_offset_mm`; a vertex moves by
/// the area-weighted mean of its faces' displacements. Junctions and corners average, so
/// the system is solved again on the moved surface, at most `max_passes` times (stopping
/// once every region is within 0.1%). Faces that then intersect, close a region's wedge
/// below 1 degree or turn a part inside out get their vertices' former positions back until
/// none does (each round restores at least one moved vertex or stops, so it ends).
VolumeCorrection correct_region_volumes(core::SurfaceNetwork& surface,
                                        const std::map<core::Label, double>& target_mm3,
                                        double max_offset_mm, int max_passes);

}  // namespace frontmesh::surface
