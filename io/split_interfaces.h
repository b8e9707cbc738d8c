#pragma once
// Splitting interfaces for tie or contact (recipe key output.split_interfaces).

#include <string>
#include <utility>
#include <vector>

#include "pipeline/core/tet_mesh.h"

namespace frontmesh::io {

/// Which interfaces to split: every interface between two regions (`all`), or the listed
/// label pairs (either order). Nothing when neither.
struct SplitInterfaces {
    bool all = false;
    std::vector<std::pair<core::Label, core::Label>> pairs;
    bool is_none() const { return !all && pairs.empty(); }
};

/// `spec` as recipe text: "none", "all" or "[[1, 2], [2, 3]]" (pairs as given).
std::string split_interfaces_text(const SplitInterfaces& spec);

/// A copy of `mesh` whose regions no longer share nodes on the split interfaces.
///
/// Rule (README "Splitting interfaces"): around a node on a split interface face, the
/// regions of its tets are grouped, two regions joining a group when a face between them at
/// that node is not split (a region's own tets always form one group with it). The node
/// gets one copy per group: the group with the smallest label keeps the node, each other
/// group gets a new node at the same coordinates. So a node inside a split interface is
/// doubled; on a curve where three split interfaces meet it is tripled; where a split
/// interface meets an unsplit one (e.g. 1|2 split, 1|3 and 2|3 not) the node stays shared,
/// since regions 1 and 2 stay joined through region 3 there. Nodes on no split face are
/// not touched.
///
/// The result keeps the TetMesh layout: the input surface nodes first (unchanged ids), the
/// new copies after them (in order of the node copied, then of its groups), then the
/// interior nodes (ids shifted by the number of copies); surface_vertices counts the
/// copies. Each face of a split interface is stored twice, once per side with that side's
/// nodes, oriented out of its region_in (the copy directly after the face); mesh.twin and
/// mesh.face_twin say what is a copy of what. Coordinates, tets (order, regions) and
/// volumes are unchanged. `spec.is_none()` returns the mesh as it is.
/// Throws InputError naming `key` when a pair is not two different positive labels, a
/// label is no region of the mesh, or two labels do not touch. Cost: O(nodes + tets + faces).
core::TetMesh split_interfaces(const core::TetMesh& mesh, const SplitInterfaces& spec,
                               const std::string& key = "output.split_interfaces");

}  // namespace frontmesh::io
