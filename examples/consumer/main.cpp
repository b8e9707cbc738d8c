// Using frontmesh from C++: one stage on an image made in memory, then (optionally) a
// whole recipe through the runner.
//
//   frontmesh_consumer                         extract the surface of a labelled ball
//   frontmesh_consumer RECIPE.yaml OUTPUT_DIR [UNTIL_STAGE]
//                                              also run the recipe into OUTPUT_DIR

#include <cmath>
#include <iostream>
#include <string>

#include "pipeline/core/error.h"
#include "pipeline/core/label_image.h"
#include "pipeline/core/stage_context.h"
#include "pipeline/recipe.h"
#include "pipeline/runner.h"
#include "surface/extract.h"

namespace fm = frontmesh;

int main(int argc, char** argv) {
    try {
        // A single stage: extract the surface of a ball of radius 6 mm (1 mm voxels).
        fm::core::LabelImage image;
        image.dims = {20, 20, 20};
        image.labels.assign(image.voxel_count(), 0);
        for (int k = 0; k < 20; ++k)
            for (int j = 0; j < 20; ++j)
                for (int i = 0; i < 20; ++i)
                    if (std::hypot(i - 9.5, j - 9.5, k - 9.5) < 6.0)
                        image.labels[image.index(i, j, k)] = 1;
        fm::surface::ExtractParams params;
        fm::surface::validate(params);
        fm::core::StageContext ctx;
        const fm::core::SurfaceNetwork surface = fm::surface::extract(image, params, ctx);
        std::cout << "extract: " << surface.faces.size() << " triangles, enclosed volume "
                  << fm::core::enclosed_volume(surface, 1)
                  << " mm^3 (ball: " << 4.0 / 3.0 * M_PI * 216.0 << ")\n";

        if (argc >= 3) {
            // A whole recipe, its output folder overridden as on the command line (--set).
            const fm::pipeline::Recipe recipe =
                fm::pipeline::load_recipe(argv[1], {std::string("output.dir=") + argv[2]});
            fm::pipeline::RunOptions options;
            options.quiet = true;
            if (argc >= 4) options.until = argv[3];
            const std::string result = fm::pipeline::run_recipe(recipe, options);
            std::cout << "run: " << result << '\n';
        }
        return 0;
    } catch (const fm::core::Error& e) {
        std::cerr << "frontmesh_consumer: " << e.what() << '\n';
        return dynamic_cast<const fm::core::InputError*>(&e) ? 2 : 1;
    }
}
