#pragma once
// The exact validity test of a candidate tet of the advancing front (§3.1.4 step 4): it
// decides, with exact predicates, the paper's point-in-tetrahedron, over-the-manifold and
// edge-face intersection tests (1) and (2). Two implementations with one contract:
// is_valid_tet_reference, plain and obviously correct, and TetValidity, the one tetra runs,
// which first drops the front faces that cannot touch the tet by box and plane filters in
// doubles (SSE2 where the compiler targets it, the same arithmetic in plain code elsewhere),
// without a branch on their outcome. tests/volume/test_tet_validity.cpp compares them.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "pipeline/core/huge_pages.h"
#include "volume/tetra_front.h"

namespace frontmesh::volume {

/// A candidate tet (a, b, c, q) on the front face (a, b, c), and which of its faces and edges
/// the front has already.
struct CandidateTet {
    std::array<std::int32_t, 4> v;    ///< a, b, c, q (node ids)
    std::array<bool, 3> face_new;     ///< outward face (v_i, v_i+1, q) is not on the front
    std::array<bool, 3> edge_new;     ///< edge (v_i, q) is not on the front
    std::array<std::int32_t, 4> own;  ///< front faces whose nodes are nodes of the tet (the
                                      ///< base, the faces the tet closes), -1 for none
};

/// The front as the validity test reads it: node coordinates and the front face records.
struct FrontView {
    const double* xyz;       ///< 3 per node, mm
    const FrontFace* faces;  ///< by face id; only the nodes `v` are read
    double max_edge;         ///< upper bound (mm) of every edge of the faces given as `near`

    const Tri& face(std::int32_t f) const { return faces[f].v; }
    const double* p(std::int32_t v) const { return xyz + 3 * static_cast<std::size_t>(v); }
};

/// True when the closed segment (s0, s1) meets the closed triangle (t0, t1, t2) anywhere but
/// at their shared vertices (node ids into `xyz`, 3 doubles per node). Exact.
bool improper_intersection(const double* xyz, std::int32_t s0, std::int32_t s1, std::int32_t t0,
                           std::int32_t t1, std::int32_t t2);

/// The validity test, plainly: the tet is strictly positive (VTK order, exact), no node of a
/// face in `near` other than the tet's own lies in the closed tet, no edge of a face in `near`
/// meets a new face of the tet improperly, and no new edge of the tet meets a face in `near`
/// improperly (improper_intersection). `near` must hold every front face that can touch the
/// tet (e.g. those whose boxes meet its box); more faces change nothing. `front.max_edge` is
/// not read. Cost O(|near|) exact predicates.
bool is_valid_tet_reference(const CandidateTet& tet, const FrontView& front,
                            std::span<const std::int32_t> near);

/// The same test, fast: the result of is_valid_tet_reference for the same input when
/// `front.max_edge` bounds the edges of the faces in `near` that meet the tet's box, and
/// every face in `tet.own` has only nodes of the tet. Faces whose nodes all lie beyond one
/// side of the tet's box, or all on or beyond one of its face planes (by far more than the
/// rounding error), are dropped before any exact predicate; each node is classified once per
/// call. Scratch per node id: 12 B.
class TetValidity {
public:
    /// Node ids [0, n) may appear in the calls (new scratch entries start empty).
    void resize(std::size_t n) {
        code_.resize(n);
        tested_.resize(n);
    }

    /// The test with the filters in SSE2 when the target has it, else in plain code.
    bool is_valid(const CandidateTet& tet, const FrontView& front,
                  std::span<const std::int32_t> near);
    /// The test with the filters in plain code, on every target (tests compare it).
    bool is_valid_portable(const CandidateTet& tet, const FrontView& front,
                           std::span<const std::int32_t> near);

private:
    template <class Coder>
    bool check(const CandidateTet& tet, const FrontView& front, std::span<const std::int32_t> near);
    std::int32_t next_code_stamp();
    std::int32_t next_tested_stamp();

    /// A node's filter code (bits 0-5 outcode against the tet's box, 6-9 beyond the tet's
    /// planes, 10-13 on them), valid when `stamp` is the call's.
    struct NodeCode {
        std::int32_t stamp = 0;
        std::uint16_t code = 0;
    };
    core::HugeVector<NodeCode> code_;
    std::int32_t code_stamp_ = 0;
    core::HugeVector<std::int32_t> tested_;  // the call's stamp: node tested against the tet
    std::int32_t tested_stamp_ = 0;
    /// A face past the filters, with its nodes' codes.
    struct Suspect {
        std::int32_t f;
        std::uint16_t code[3];
    };
    std::vector<Suspect> suspects_;
};

}  // namespace frontmesh::volume
