#pragma once
// A segmented 3-D image in physical coordinates (STYLE §2: io -> LabelImage).

#include <array>
#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/LU>

#include "pipeline/core/ids.h"

namespace frontmesh::core {

/// The world frame coordinates are expressed in.
enum class Frame { Lps, Ras };

/// "lps" or "ras".
std::string frame_name(Frame frame);

/// Labels on a regular grid. Voxel (i, j, k) sits at
/// origin + direction * diag(spacing) * (i, j, k), in millimetres, in `frame`.
/// Label 0 is the outside. The reader pads the image by one voxel of 0 on every side.
struct LabelImage {
    std::array<int, 3> dims{0, 0, 0};
    Eigen::Vector3d spacing{1.0, 1.0, 1.0};                   ///< mm, all > 0
    Eigen::Vector3d origin{0.0, 0.0, 0.0};                    ///< mm, position of voxel (0, 0, 0)
    Eigen::Matrix3d direction = Eigen::Matrix3d::Identity();  ///< columns: axis directions
    Frame frame = Frame::Lps;
    std::vector<Label> labels;  ///< size dims[0]*dims[1]*dims[2], x fastest
    std::string source;         ///< file or folder read, for messages

    std::size_t voxel_count() const {
        return static_cast<std::size_t>(dims[0]) * dims[1] * dims[2];
    }
    std::size_t index(int i, int j, int k) const {
        return (static_cast<std::size_t>(k) * dims[1] + j) * dims[0] + i;
    }
    Label at(int i, int j, int k) const { return labels[index(i, j, k)]; }

    /// Physical position (mm) of a continuous voxel index.
    Eigen::Vector3d physical(const Eigen::Vector3d& continuous_index) const {
        return origin + direction * spacing.cwiseProduct(continuous_index);
    }
    /// Volume of one voxel in mm^3.
    double voxel_volume() const { return spacing.prod() * std::abs(direction.determinant()); }
};

}  // namespace frontmesh::core
