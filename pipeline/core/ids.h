#pragma once
// Strong 0-based integer ids (STYLE §2): an int32_t in a struct, -1 is invalid.

#include <compare>
#include <cstdint>
#include <functional>

namespace frontmesh::core {

template <class Tag>
struct Id {
    std::int32_t value = -1;

    constexpr Id() = default;
    constexpr explicit Id(std::int32_t v) : value(v) {}

    /// True when the id refers to an element (value >= 0).
    constexpr bool is_valid() const { return value >= 0; }
    constexpr auto operator<=>(const Id&) const = default;
};

using VertexId = Id<struct VertexTag>;
using FaceId = Id<struct FaceTag>;
using TetId = Id<struct TetTag>;

/// A label value of the segmented image; 0 is the outside.
using Label = std::int32_t;

}  // namespace frontmesh::core

template <class Tag>
struct std::hash<frontmesh::core::Id<Tag>> {
    std::size_t operator()(frontmesh::core::Id<Tag> id) const noexcept {
        return std::hash<std::int32_t>()(id.value);
    }
};
