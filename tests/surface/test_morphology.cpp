// Voxel closing and opening of the labelled object (extract.closing_voxels/opening_voxels).

#include <catch2/catch.hpp>

#include "surface/morphology.h"

using namespace frontmesh;

namespace {

// An n^3 image of zeros.
core::LabelImage empty_image(int n) {
    core::LabelImage image;
    image.dims = {n, n, n};
    image.labels.assign(image.voxel_count(), 0);
    return image;
}

void fill(core::LabelImage& image, int i0, int i1, int j0, int j1, int k0, int k1,
          core::Label label) {
    for (int k = k0; k < k1; ++k)
        for (int j = j0; j < j1; ++j)
            for (int i = i0; i < i1; ++i) image.labels[image.index(i, j, k)] = label;
}

}  // namespace

TEST_CASE("morphology: closing fills a narrow slit with the nearest label and keeps the object",
          "[extract]") {
    // Two blocks, labels 1 and 2, 8 voxels thick, facing each other across a slit of w voxels.
    for (const int w : {1, 2, 3, 4}) {
        INFO("slit " << w);
        auto image = empty_image(30);
        fill(image, 2, 10, 2, 28, 2, 28, 1);
        fill(image, 10 + w, 18 + w, 2, 28, 2, 28, 2);
        const auto before = image.labels;
        const std::size_t filled = surface::close_object(image, 1);
        // Object voxels never change.
        for (std::size_t v = 0; v < before.size(); ++v)
            if (before[v] != 0) CHECK(image.labels[v] == before[v]);
        // A slit of up to 2 voxels is filled (away from the blocks' rims), a wider one stays.
        const core::Label mid = image.at(10 + (w - 1) / 2, 15, 15);
        if (w <= 2) {
            CHECK(filled > 0);
            CHECK(mid != 0);
            CHECK(image.at(10, 15, 15) == 1);  // next to label 1: label 1
            CHECK(image.at(10 + w - 1, 15, 15) == (w == 1 ? 1 : 2));
        } else {
            CHECK(mid == 0);
            CHECK(filled == 0);
        }
    }
}

TEST_CASE("morphology: opening removes thin sheets and spikes, keeps thick parts", "[extract]") {
    auto image = empty_image(30);
    fill(image, 5, 15, 5, 15, 5, 15, 3);    // a thick block
    fill(image, 15, 25, 8, 10, 5, 15, 3);   // a two-voxel-thick sheet sticking out
    fill(image, 15, 25, 20, 23, 5, 15, 4);  // a three-voxel-thick plate of another label
    const auto before = image.labels;
    const std::size_t removed = surface::open_object(image, 1);
    CHECK(removed > 0);
    CHECK(image.at(20, 8, 10) == 0);  // the sheet is gone
    CHECK(image.at(20, 9, 10) == 0);
    CHECK(image.at(20, 21, 10) == 4);  // the plate keeps its middle layer and grows back
    CHECK(image.at(20, 20, 10) == 4);
    CHECK(image.at(10, 10, 10) == 3);  // the block stays
    // Nothing changes label other than to 0, and nothing outside the object is added.
    for (std::size_t v = 0; v < before.size(); ++v)
        CHECK((image.labels[v] == before[v] || image.labels[v] == 0));
    CHECK(surface::open_object(image, 0) == 0);
}
