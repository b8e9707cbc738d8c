#pragma once
// Internals of the remesh stage shared by its source files (issue 19: the paper's steps as
// named functions, one concern per file):
//   remesh.cpp           the stage: validate, the size-field parameters from the recipe, the
//                        driver over the steps below and one round of them
//   remesh_coarse.cpp    small closed shells meshed by collapsing their background (issue 20)
//   remesh_curves.cpp    curves discretised by the size field (§2 "node distribution on the
//                        features"), patch boundary loops, a patch copied from the background
//   remesh_retry.cpp     RetryPolicy: every size multiplier the rounds apply, in one place
//   remesh_checks.cpp    checks of a round's result (closed 2-manifold regions, volume change,
//                        self-intersections) and the figures of the final result
//   remesh_measures.cpp  hausdorff_distance, surface_quality, edge_length_fraction
// The size field itself (what h is before any retry) is surface/size_field.*; the front that
// triangulates one patch is surface/front_triangulate.* and the smoothing after it is
// surface/surface_smoothing.*.

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "pipeline/core/adt.h"
#include "pipeline/core/stage_context.h"
#include "pipeline/core/surface_network.h"
#include "surface/features.h"
#include "surface/front_triangulate.h"
#include "surface/remesh.h"
#include "surface/size_field.h"
#include "surface/surface_smoothing.h"

namespace frontmesh::surface::remesh_detail {

/// "(x, y, z) mm" for messages.
std::string point_text(const Eigen::Vector3d& p);

// --- retry policy (remesh_retry.cpp) -------------------------------------------------------

/// What the next round does differently, and why: every multiplier applied to the size field
/// across rounds, and the patches that fall back to their background triangles. The target
/// size that reaches the front's point placement (the Eq. 8 analogue in front_step.cpp) is
///
///     h(x, f) = field(x, f) * shrink(x) * volume_scale(f)        (size(); patches)
///     h(v)    = field(v)    * shrink(x_v) * volume_scale(v)      (vertex_size(); curves)
///
/// - shrink(x): over the rounds that added shrink sites, the product of each round's
///   smallest factor at x, never below 1/8; a site (c, r) gives 1/2 within r of c, rising
///   linearly to 1 at 2r. Sites are added where a patch's front stalled (r = 4 h), where a
///   region was not a closed 2-manifold (r = 2 h at the edge) and where faces crossed after
///   smoothing (r = 2 h at each face), h = field at the place. Sites of one round do not
///   compound: the several faces of one crossing, or crossings side by side, halve the size
///   once per round (torture seed 136: eight overlapping sites of one round cut a 5 mm
///   patch of a thin layer to 1/8 and its tiny faces then left tetra no closable front).
/// - volume_scale(f): per background face, multiplied by clamp(0.9 sqrt(limit / change),
///   0.5, 0.9) on the patches of a region whose enclosed volume changed by more than
///   remesh.max_volume_change_percent (chords lose volume as h^2), and by 1/2 on the
///   patches of a region that encloses no volume though every edge is in order (a region
///   thinner than h whose patches closed on the same curve points); volume_scale(v) is the
///   smallest scale of the faces at v, updated when a region is refined.
/// - within one round, triangulate_patch scales a patch by 0.85 per failed attempt
///   (FrontParams::attempts) on top.
/// A patch whose front stalls twice, or whose faces cross in three rounds, or that does
/// either in a late round (late()), keeps its background triangles from then on
/// (copy()): the last round then changes no size, so it meets no new stall.
/// Work of a stalling patch (issue 20): it is meshed by the front in at most 2 rounds where
/// it stalls (then copy()), each of FrontParams::attempts attempts bounded by O(n) steps,
/// n = expected triangles + loop points (front_triangulate.cpp), and is then coarsened
/// (coarsen_patch, O(faces log faces)); rounds in which its sizes do not change reuse its
/// mesh (the stage's patch cache). A closed shell smaller than h never enters the front.
class RetryPolicy {
public:
    /// Rounds at most: the last one reports what still fails instead of retrying.
    static constexpr int kRounds = 20;
    /// The rounds before the last in which a stall or crossing keeps the patch's background
    /// triangles at once (late()). A patch copied so changes the curves it shares (they take
    /// the background's points) and so its neighbours' loops: they are meshed again in the
    /// next round and may stall there in turn (natbrainlab: a neighbour stalled in the last
    /// round and the whole background was used). Each late round copies what stalls, crosses,
    /// turns inside out or opens in it and changes no size (a region's volume change is
    /// left to preserve_volumes: a late rescale of many patches started the stalls again,
    /// inia19 and jhu189), so the copied set grows until a round stands. AICHA, inia19 and
    /// jhu189 stood in rounds 16-17 (with five late rounds, each of them and JHU-2mm fell
    /// back to the whole background). The first kRounds - kLateRounds - 1 = 8 rounds refine.
    static constexpr int kLateRounds = 11;
    static constexpr bool late(int round) { return round + 1 + kLateRounds >= kRounds; }

    RetryPolicy(const core::SurfaceNetwork& background, const SizeField& field,
                std::size_t patches);

    /// Target size (mm) at `x` on background face `face` (< 0: no face), every multiplier
    /// applied: the h the front places points by.
    double size(const Eigen::Vector3d& x, std::int32_t face) const;
    /// Target size (mm) at background vertex v, every multiplier applied (curve points).
    double vertex_size(std::int32_t v) const;
    /// Product over rounds of the smallest factor of the round's shrink sites at x, in
    /// [1/8, 1].
    double shrink(const Eigen::Vector3d& x) const;
    /// size() as the front's SizeFunction (refers to this policy).
    SizeFunction size_function() const;

    /// Patch p keeps its background triangles instead of a front.
    bool copy(std::size_t p) const { return copy_patch_[p] != 0; }
    /// Whether the sizes over patch p (bounding box `box`) may differ from those it was last
    /// meshed with: its volume scale changed, or a shrink site added since reaches the box.
    bool has_new_sizes(std::size_t p, const core::AdtBox& box) const;
    /// The sizes of this round are in use: has_new_sizes() compares with them from now on.
    void mark_sizes_used();

    /// The front of patch p stalled in round `round` (0-based), its attempts at `places`
    /// (the last attempt's last): at its first stall, a shrink site at each place. At
    /// its second stall (or its first at kCutAtOnce places or more), a patch of at least
    /// kMinCutFaces faces is cut (cuts()): the
    /// background around every place becomes a patch of its own that keeps its background
    /// triangles, and the rest is meshed by the front again; a smaller patch, or any patch
    /// in a late round or once frugal, keeps its background triangles.
    static constexpr std::size_t kMinCutFaces = 64;
    /// A stall at this many places or more is cut at once, at the first stall.
    static constexpr std::size_t kCutAtOnce = 8;
    void on_stall(std::size_t p, std::size_t patch_faces,
                  const std::vector<Eigen::Vector3d>& places, int round);
    /// Patches to cut around the places where they stalled (issue 20: a local fallback
    /// instead of a whole patch of background triangles); cleared by the policy of the cut
    /// features (the constructor below).
    struct Cut {
        std::size_t patch;
        std::vector<Eigen::Vector3d> places;
    };
    const std::vector<Cut>& cuts() const { return cuts_; }
    /// The policy carried over to the features after cuts(): `old_of_new` is, per new patch,
    /// the old patch with the same faces or -1; `is_cut` marks the new patches cut out around
    /// a stall (they keep their background triangles). A patch that is neither is the rest
    /// of a cut patch: it counts one stall, so that it is cut again at its next one. Sizes,
    /// sites, work and the round's triggers carry over.
    RetryPolicy(RetryPolicy&& old, const std::vector<std::int32_t>& old_of_new,
                const std::vector<std::uint8_t>& is_cut);
    /// Edges of a region that is not a closed 2-manifold (two patches joined the same two
    /// curve points by an inner edge): a shrink site at each midpoint.
    void on_open_edges(const std::vector<Eigen::Vector3d>& midpoints);
    /// Faces of `out` that are wrong after smoothing (`face_patch` of the output): faces of
    /// intersecting pairs, or of a boundary part turned inside out. Patches found so in a
    /// third round keep their background triangles, the other faces get a shrink site at
    /// their centroid. In a late round (`round`, 0-based), every such patch
    /// keeps its background triangles (which are right: the background is checked).
    void on_bad_faces(const std::vector<std::int32_t>& faces, const core::SurfaceNetwork& out,
                      const std::vector<std::int32_t>& face_patch, int round);
    /// The region's enclosed volume changed by `change_percent` (> `limit_percent`): the
    /// volume scale of its patches' faces drops by clamp(0.9 sqrt(limit / |change|), 0.5,
    /// 0.9). The vertex scales follow at update_vertex_scales().
    void on_volume_change(const Features& features, core::Label region, double change_percent,
                          double limit_percent);
    /// The region has every edge in order but encloses no volume (its patches closed on the
    /// same few curve points): the volume scale of its patches' faces halves, and the vertex
    /// scales follow at once.
    void on_collapsed_region(const Features& features, core::Label region);
    /// volume_scale(v) = min over the faces at v (after on_volume_change).
    void update_vertex_scales();

    /// The stage's work budget (issue 21: a 16^3 block of random labels kept remeshing, its
    /// shrink sites making more patches stall each round). A round's work is the triangles
    /// it expects to make: over the patches it meshes by the front, area / (sqrt(3)/4 h^2)
    /// at the sizes in force (the O(n) of front_triangulate.cpp). Once the rounds together
    /// have spent kWorkBudget times the first round's, the policy turns frugal: every later
    /// stall or crossing keeps that patch's background triangles at once, as from the
    /// late rounds, and a volume change is reported, not meshed again. The stage's
    /// work is then at most (kWorkBudget + 64) times the first round's, 64 = 1 / (1/8)^2
    /// for the round that crosses the budget. Returns true when this call turned it frugal.
    static constexpr double kWorkBudget = 8.0;
    bool spend(double expected_triangles);
    bool frugal() const { return frugal_; }
    /// Work spent so far over the first round's.
    double work_ratio() const { return first_work_ > 0.0 ? work_ / first_work_ : 0.0; }

    /// Records what makes the next round necessary (several triggers of a round are joined).
    void note(const std::string& trigger);
    /// One log line for round `round` (0-based): why it runs (the triggers noted since the
    /// last summary) and the multipliers in force.
    std::string round_summary(int round);

private:
    void add_shrink_site(const Eigen::Vector3d& centre, double radius_in_h);

    const core::SurfaceNetwork& background_;
    const SizeField& field_;
    struct ShrinkSite {
        Eigen::Vector3d centre;
        double radius;   // mm
        int generation;  // mark_sizes_used() calls before it was added: its round
    };
    std::vector<ShrinkSite> shrink_sites_;  // in increasing generation
    // Each site's reach (centre +- 2 r) by site index: shrink() visits only the sites that
    // reach x (a stall may add a hundred sites, and the front asks for sizes at every step).
    std::unique_ptr<core::Adt> site_reach_;
    std::size_t sites_used_ = 0;  // sites in force when the patches were last meshed
    int generation_ = 0;          // mark_sizes_used() calls so far
    std::vector<double> face_scale_, vertex_scale_;  // volume scales
    std::vector<std::uint8_t> rescaled_;             // per patch, since mark_sizes_used()
    std::vector<int> patch_stalls_, patch_crossings_;
    std::vector<std::uint8_t> copy_patch_;
    std::vector<Cut> cuts_;
    double first_work_ = 0.0, work_ = 0.0;  // expected triangles: the first round's, all
    bool frugal_ = false;
    std::string triggers_;  // noted since the last round_summary()
};

// --- cuts around stalls (remesh_cuts.cpp) -------------------------------------------------

/// Cuts the stalled patches of `cuts` (RetryPolicy::cuts()) into parts (issue 20 item 2: a
/// local fallback). Around each place, the faces of the patch whose centroids lie within
/// 4 h of it (h: the size field there), grown across the patch's edges from the face nearest
/// the place, join that cut's new part; notches (a face with two of its neighbours in the
/// part) and pieces of the rest smaller than the part are added to it, and a part that
/// would take half of its patch takes all of it. `face_part` (per background face, created
/// with 0 when empty) gets the new part ids, each larger than every id before. Returns the
/// first new id. Cost O(patch faces x places) per cut.
std::int32_t cut_patches(const core::SurfaceNetwork& bg, const Features& features,
                         const SizeField& field, const std::vector<RetryPolicy::Cut>& cuts,
                         std::vector<std::int32_t>& face_part);

// --- curves and loops (remesh_curves.cpp) --------------------------------------------------

/// One feature curve cut into segments whose lengths follow the size field (§2: "specifying
/// node distribution on the features"): arc length integrated with density 1/h.
struct DiscreteCurve {
    std::vector<std::int32_t> ids;        ///< output vertex ids along the curve
    std::vector<Eigen::Vector3d> points;  ///< their positions
    std::vector<double> s;                ///< arc length on the background polyline, mm
    std::vector<std::int32_t> faces;      ///< a background face at each point
    std::vector<std::int32_t> bg_vertex;  ///< the background vertex at each point, or -1
    /// A curve at full resolution: background vertices left out of it (a curve edge far
    /// shorter than h), each with the kept vertex it is merged into in the copied patches.
    std::vector<std::array<std::int32_t, 2>> merged;
};

/// Output vertices of the curves, shared by every patch they bound: the corners first, then
/// each curve's other points (a curve of a copied patch at full background resolution).
/// Appends them to `out` and their background face hints (-1 at corners) to `vertex_face`.
std::vector<DiscreteCurve> place_curve_points(const core::SurfaceNetwork& bg,
                                              const Features& features, const RetryPolicy& retry,
                                              core::SurfaceNetwork& out,
                                              std::vector<std::int32_t>& vertex_face);

/// Boundary loops of every patch from the shared curve points.
struct PatchLoops {
    std::vector<std::vector<std::int32_t>> ids;  ///< per patch: output ids, loops in order
    std::vector<std::vector<std::int32_t>> bg;   ///< per patch: background vertex or -1
    std::vector<std::vector<PatchLoop>> loops;   ///< per patch: the loops' points
    /// per patch: the curves' merged background vertices (DiscreteCurve::merged)
    std::vector<std::vector<std::array<std::int32_t, 2>>> merged;
};
PatchLoops patch_loops(const Features& features, const std::vector<DiscreteCurve>& curves,
                       const core::SurfaceNetwork& out);

/// Patches whose loops pass a point twice (a patch touching itself at a corner): legal, but
/// the hardest case for the front.
std::size_t patches_with_repeated_loop_points(const PatchLoops& loops);

/// The last resort for a patch whose front stalls again and again: its own background
/// triangles, its boundary at full resolution (`loop_bg`: the background vertex of each loop
/// point, in loop order). A closed patch (no loops) is then brought towards h by
/// coarsen_patch; a small closed shell gets the same without any front. `merged` (from
/// PatchLoops::merged): background vertices left out of the curves, each replaced by the kept
/// vertex it merges into; faces that lose a corner that way are dropped.
PatchMesh copy_background_patch(const core::SurfaceNetwork& bg, const Patch& patch,
                                const std::vector<std::int32_t>& loop_bg,
                                const std::vector<std::array<std::int32_t, 2>>& merged = {});

// --- coarse patches (remesh_coarse.cpp) ----------------------------------------------------

/// Whether a closed patch (one without loops) is a shell smaller than the target edge length:
/// its bounding box diagonal is below 2 h, h the larger of `nominal_h` (the recipe's size for
/// its regions, before the size field's sheet and curvature limits) and the largest size at
/// its face centroids. Such a shell (a label island of a few voxels) leaves the front no room
/// to turn; it is meshed by coarsen_patch() instead. Cost O(patch faces).
bool is_small_closed_patch(const BackgroundPatch& patch, const SizeFunction& size,
                           double nominal_h);

/// The coarsest valid triangulation of a patch that keeps its shape: `mesh` (its background
/// triangles, copy_background_patch()) with inner edges longer than 4/3 h split at the
/// background point nearest their midpoint (at most 4 x faces splits), then edges collapsed
/// shortest first while the result stays a 2-manifold with the same boundary (the first
/// `fixed_points` points, the loop points, never go), no face turns against the background
/// or overlaps another (exact test), no angle drops below min(its old value, 25 degrees), no
/// edge exceeds 4/3 h, every removed point stays within 0.1 h of the faces that replace it
/// and a closed patch keeps its enclosed volume within 2%. Every point lies on the
/// background. Ends after at most points - 4 collapses; cost O(faces log faces) for bounded
/// valence. With `collapse_below` under 4/3 (a copied patch beside others, whose shape must
/// not change), no edge is split and only edges shorter than collapse_below h collapse: the
/// needles of the background go, nothing else changes.
PatchMesh coarsen_patch(const BackgroundPatch& patch, PatchMesh mesh, std::size_t fixed_points,
                        const SizeFunction& size,
                        double collapse_below = std::numeric_limits<double>::infinity());

// --- checks (remesh_checks.cpp) ------------------------------------------------------------

/// Outcome of the region checks of a round.
/// A region wedge (the angle inside a region between its two faces at a junction edge) under
/// this is a defect of a remesh result: no tet of the region on that edge can be better, and at
/// zero none is valid (degrees).
constexpr double kUnmeshableWedgeDeg = 1.0;

/// Region wedges of `out` under kUnmeshableWedgeDeg (after the crossings are mended): shrink
/// sites or background triangles at their faces (RetryPolicy::on_bad_faces) and true (mesh
/// again), or in the last round GeometryError naming the place; false when there are none.
bool check_unmeshable_wedges(const core::SurfaceNetwork& out,
                             const std::vector<std::int32_t>& face_patch, int round,
                             RetryPolicy& retry, core::StageContext& ctx);

struct RegionChecks {
    bool again = false;    ///< a region is not a closed 2-manifold, or a part of it turned
                           ///< inside out: mesh again finer there
    std::string rescaled;  ///< regions refined for their volume change: " R (x %)" each
    /// Volume changes beyond the limit left as they are (late rounds, frugal work): warnings
    /// for the round that stands, not for every late round that checks them.
    std::vector<std::string> volume_warnings;
};

/// Every region of `out` must be a closed, oriented 2-manifold with no part turned inside out
/// (else shrink sites or background triangles and again, or
/// in the last round GeometryError naming the place) and keep its enclosed volume within
/// remesh.max_volume_change_percent (else its patches are refined, or in the last round a
/// warning). Counters `remesh.volume_change_percent.region_*` go to ctx.
RegionChecks check_regions(const core::SurfaceNetwork& bg, const core::SurfaceNetwork& out,
                           const std::vector<std::int32_t>& face_patch, const Features& features,
                           const RemeshParams& params, int round, RetryPolicy& retry,
                           core::StageContext& ctx);

/// Region wedges under 12 degrees in `out` (after the mend of self-intersections) that were
/// not there with the positions before it (`smoothed_xyz`): unless in the last round, shrink
/// sites at their faces, a warning, and true (mesh again); else false. Counter
/// `remesh.wedges_closed_by_mend`.
bool mend_closed_wedges(const std::vector<double>& smoothed_xyz, const core::SurfaceNetwork& out,
                        const std::vector<std::int32_t>& face_patch, int round, RetryPolicy& retry,
                        core::StageContext& ctx);

/// Self-intersections after smoothing: vertices of crossing faces go back to where the front
/// put them (`front_xyz`) for up to three passes; faces still crossing make shrink sites and
/// return true (mesh again), or in the last round throw GeometryError naming the faces.
bool mend_self_intersections(core::SurfaceNetwork& out, const std::vector<double>& front_xyz,
                             const std::vector<std::int32_t>& face_patch, int round,
                             RetryPolicy& retry, core::StageContext& ctx);

/// Parts of region boundaries turned inside out after the crossings are mended (the mend puts
/// vertices back where the front put them, after check_regions looked): shrink sites or
/// background triangles there and true (mesh again), or in the last round GeometryError
/// naming the place; false when there are none.
bool check_inverted_after_mend(const core::SurfaceNetwork& out,
                               const std::vector<std::int32_t>& face_patch, int round,
                               RetryPolicy& retry, core::StageContext& ctx);

/// The result: the surface, the size field's target size per vertex (curve points by their
/// nearest background vertex), and the counters of its quality, wedges and forced tets.
RemeshResult finished_result(const SizeField& size, core::SurfaceNetwork out,
                             const std::vector<std::int32_t>& vertex_face, std::size_t curve_points,
                             core::StageContext& ctx);

}  // namespace frontmesh::surface::remesh_detail
