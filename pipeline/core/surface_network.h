#pragma once
// The triangle surface network handed between extract, repair and remesh (STYLE §2).

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "pipeline/core/ids.h"

namespace frontmesh::core {

/// Triangles that bound labelled regions. A face separates `region_in` (behind it) from
/// `region_out` (in front of it); its vertex order is counter-clockwise seen from
/// `region_out`, so the right-hand normal points out of `region_in`. An interface between
/// two regions is stored once. Non-manifold where three or more regions meet.
/// Memory: 24 B per vertex + 20 B per face (about 64 MB per million faces with vertices).
struct SurfaceNetwork {
    std::vector<double> xyz;                         ///< 3 per vertex, mm
    std::vector<std::array<std::int32_t, 3>> faces;  ///< vertex ids
    std::vector<Label> region_in;                    ///< per face, > 0
    std::vector<Label> region_out;                   ///< per face, 0 = outside

    std::size_t vertex_count() const { return xyz.size() / 3; }
    std::size_t face_count() const { return faces.size(); }

    Eigen::Map<const Eigen::Vector3d> point(std::int32_t v) const {
        return Eigen::Map<const Eigen::Vector3d>(&xyz[3 * static_cast<std::size_t>(v)]);
    }
    Eigen::Map<Eigen::Vector3d> point(std::int32_t v) {
        return Eigen::Map<Eigen::Vector3d>(&xyz[3 * static_cast<std::size_t>(v)]);
    }
    std::int32_t add_vertex(const Eigen::Vector3d& p) {
        xyz.push_back(p.x());
        xyz.push_back(p.y());
        xyz.push_back(p.z());
        return static_cast<std::int32_t>(vertex_count() - 1);
    }
    void add_face(std::int32_t a, std::int32_t b, std::int32_t c, Label in, Label out) {
        faces.push_back({a, b, c});
        region_in.push_back(in);
        region_out.push_back(out);
    }
};

/// The faces around every vertex as CSR: the faces of vertex v are
/// faces[offsets[v] .. offsets[v + 1]), in increasing face id. Cost O(faces).
void vertex_faces(const SurfaceNetwork& surface, std::vector<std::int32_t>& offsets,
                  std::vector<std::int32_t>& faces);

/// Sorted list of the labels present (region_in and region_out), without 0.
std::vector<Label> region_labels(const SurfaceNetwork& surface);

/// Signed volume (mm^3) enclosed by the boundary of `region`, faces oriented outward.
double enclosed_volume(const SurfaceNetwork& surface, Label region);

/// Result of checking one region's boundary.
struct RegionBoundaryCheck {
    Label region = 0;
    std::size_t faces = 0;
    std::size_t open_edges = 0;         ///< edges with an odd number of this region's faces
    std::size_t misoriented_edges = 0;  ///< edges whose faces disagree in orientation
    std::size_t nonmanifold_edges = 0;  ///< edges with more than two of this region's faces
    double volume = 0.0;                ///< mm^3, positive when oriented outward
    bool is_closed() const { return open_edges == 0; }
    bool is_oriented() const { return misoriented_edges == 0 && volume > 0.0; }
};

/// Checks every region's boundary: closed, consistently oriented outward, manifold edges.
/// Faces of an interface count for both regions (reversed for region_out).
std::vector<RegionBoundaryCheck> check_region_boundaries(const SurfaceNetwork& surface);

/// A part of a region's boundary (its faces joined through edges) that is turned inside out.
struct InvertedPart {
    Label region = 0;
    std::vector<std::int32_t> faces;  ///< the part's faces, increasing
    Eigen::Vector3d place;            ///< just on the region's side of its largest face, mm
    double winding = 0.0;             ///< the region's winding number there (1 if it were right)
};

/// The parts of each region's boundary that are turned inside out: where a region has two or
/// more parts, each must have the region on its inner side, so the region's winding number
/// just behind the part's largest face (towards region_in) is 1. A part of a thin region
/// whose two sides crossed through each other (remesh of a sliver, or a user's surface)
/// encloses the region's own volume with the wrong sign while every edge is in order, which
/// check_region_boundaries does not see (a hole is a part with negative volume and passes).
/// Cost O(F + P^2) for P parts: each part's winding counts only its own faces and those of the
/// parts whose bounding box holds the point.
std::vector<InvertedPart> inverted_parts(const SurfaceNetwork& surface);

}  // namespace frontmesh::core
