// libFuzzer target: the YAML recipe, parsed and validated by pipeline::load_recipe.
// Input: the recipe text up to the first NUL byte; each further NUL-separated piece is a
// command-line override ("key.path=value", as --set). The scratch folder holds the files
// the seed recipes name (image.nii, surface.stl, labels.txt), so that validation goes past
// the "file does not exist" checks; output.dir is relative to the fuzzer's folder and
// load_recipe creates nothing there.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "pipeline/recipe.h"
#include "tests/fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace frontmesh;
    static const bool inputs_made = [] {
        const std::uint8_t empty[1] = {0};
        fuzz::write_input("image.nii", empty, 0);
        fuzz::write_input("surface.stl", empty, 0);
        const std::string labels = "1 Left\n2 Right\n";
        fuzz::write_input("labels.txt", reinterpret_cast<const std::uint8_t*>(labels.data()),
                          labels.size());
        return true;
    }();
    (void)inputs_made;

    const std::string text(reinterpret_cast<const char*>(data), size);
    std::vector<std::string> pieces;
    // One pass over the input: each NUL ends a piece.
    for (std::size_t begin = 0;;) {
        const std::size_t end = text.find('\0', begin);
        pieces.push_back(text.substr(begin, end == std::string::npos ? end : end - begin));
        if (end == std::string::npos) break;
        begin = end + 1;
    }
    const std::string path = fuzz::write_input(
        "recipe.yaml", reinterpret_cast<const std::uint8_t*>(pieces[0].data()), pieces[0].size());
    const std::vector<std::string> overrides(pieces.begin() + 1, pieces.end());
    fuzz::expect_input_errors([&] { pipeline::load_recipe(path, overrides); });
    return 0;
}
