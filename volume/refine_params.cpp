// The refine stage's recipe keys and their check (STYLE §3: one declaration per key).

#include "volume/refine.h"

namespace frontmesh::volume {

const core::ParamTable<RefineParams>& refine_keys() {
    using P = RefineParams;
    static const core::ParamTable<RefineParams> table = {
        {"refine.node_removal",
         &P::node_removal,
         "true",
         {},
         "",
         "remove interior nodes with few tets around them (§3.3.1)"},
        {"refine.node_removal_max_tets", &P::node_removal_max_tets, "6", core::closed(4, 12),
         "tets", "largest star node removal takes (the paper: 4 and 6)"},
        {"refine.passes", &P::passes, "3", core::closed(0, 20), "",
         "rounds of smoothing + flips (the paper: three)"},
        {"refine.smoothing",
         &P::smoothing,
         "true",
         {},
         "",
         "angle-based smoothing of interior nodes in each round (§3.3.2)"},
        {"refine.smoothing_sweeps", &P::smoothing_sweeps, "1", core::closed(1, 10), "",
         "smoothing sweeps over all interior nodes per round"},
        {"refine.smoothing_skewness", &P::smoothing_skewness, "0.0", core::from_below(0.0, 1.0), "",
         "nodes whose tets all have skewness (Eq. 1) at most this are not smoothed"},
        {"refine.flip_skewness", &P::flip_skewness, "0.3", core::from_below(0.0, 1.0), "",
         "tets with skewness (Eq. 1) above this are flip candidates (§3.3.3)"},
        {"refine.flip_max_ring", &P::flip_max_ring, "7", core::closed(3, 10), "tets",
         "largest ring of tets around an edge that edge suppression removes"},
        {"refine.flip_delaunay_test",
         &P::flip_delaunay_test,
         "true",
         {},
         "",
         "require the paper's in-sphere condition before trying a flip"},
        {"refine.flip_sweeps", &P::flip_sweeps, "4", core::closed(1, 20), "",
         "sweeps over the flip candidates per round"},
        {"refine.sliver_pass",
         &P::sliver_pass,
         "true",
         {},
         "",
         "beyond the paper: flips, node moves and Steiner nodes aimed at slivers"},
        {"refine.sliver_dihedral_deg", &P::sliver_dihedral_deg, "25.0",
         core::above_up_to(0.0, 70.5), "deg",
         "tets with a smaller dihedral angle are targeted by the sliver pass"},
        {"refine.sliver_sweeps", &P::sliver_sweeps, "5", core::closed(1, 20), "",
         "full sweeps of the sliver pass at most (it stops after a sweep that changes nothing); up "
         "to 7 more visit the tets under 10 degrees alone"},
    };
    return table;
}

void validate(const RefineParams& params) { core::check_ranges(params, refine_keys()); }

}  // namespace frontmesh::volume
