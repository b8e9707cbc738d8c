#pragma once
// Identifiers shared by every stage.
//
// Element ids (vertices, faces, tets) are plain `std::int32_t` indices into the flat arrays
// of SurfaceNetwork and TetMesh, -1 where none. A strong-id wrapper (`VertexId` ...) was
// declared here once but never adopted: every public signature, the SIMD kernels and the
// VTK/ITK converters index the flat arrays directly, and a wrapper at the boundary only
// would add conversions without catching anything. It was removed (issue 19).

#include <cstdint>

namespace frontmesh::core {

/// A label value of the segmented image; 0 is the outside.
using Label = std::int32_t;

}  // namespace frontmesh::core
