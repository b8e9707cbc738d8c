// The volume stages and their StageContext: cancellation between levels / passes, and no
// diagnostics from a run that succeeds.

#include <atomic>
#include <vector>

#include <catch2/catch.hpp>

#include "pipeline/core/stage_context.h"
#include "tests/fixtures/phantoms.h"
#include "volume/refine.h"
#include "volume/tetra.h"

using namespace frontmesh;

namespace {

core::StageContext context(const std::atomic<bool>* cancel,
                           std::vector<core::Diagnostic>* diagnostics) {
    return core::StageContext(
        {}, {},
        [diagnostics](core::Diagnostic d) {
            if (diagnostics) diagnostics->push_back(std::move(d));
        },
        cancel);
}

}  // namespace

TEST_CASE("tetra and refine stop when the run is cancelled", "[volume]") {
    const std::atomic<bool> cancel{true};
    core::StageContext ctx = context(&cancel, nullptr);
    CHECK_THROWS_AS(volume::tetra(fixtures::uv_sphere(10.0, 16), volume::TetraParams{}, ctx),
                    core::CancelledError);
    CHECK_THROWS_AS(volume::refine(fixtures::cube_tet_mesh(3), volume::RefineParams{}, ctx),
                    core::CancelledError);
}

TEST_CASE("tetra hands over no diagnostics when every front closes", "[volume]") {
    const std::atomic<bool> cancel{false};
    std::vector<core::Diagnostic> diagnostics;
    core::StageContext ctx = context(&cancel, &diagnostics);
    REQUIRE(ctx.wants_diagnostics());
    const core::TetMesh mesh =
        volume::tetra(fixtures::uv_sphere(10.0, 16), volume::TetraParams{}, ctx);
    CHECK(mesh.tet_count() > 0);
    CHECK(diagnostics.empty());
}
