// libFuzzer target: a tetrahedral mesh as `frontmesh check` and `frontmesh convert` read it:
// io::read_mesh (.vtu .msh .mesh .inp) and, for check, pipeline::check_mesh_file (the same
// reader keeping the file's orientation, then the validity and quality figures).
// Input: byte 0 picks the extension modulo 4 and, with bit 2, check instead of convert's
// read; the rest is the file.

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

#include "io/export.h"
#include "pipeline/check.h"
#include "tests/fuzz/fuzz_support.h"

namespace {

const std::array<const char*, 4> kExtensions = {".vtu", ".msh", ".mesh", ".inp"};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace frontmesh;
    if (size < 1) return 0;
    const std::string path = fuzz::write_input(
        std::string("mesh") + kExtensions[data[0] % kExtensions.size()], data + 1, size - 1);
    if (data[0] & 4) {
        fuzz::expect_input_errors([&] { pipeline::check_mesh_file(path); });
    } else {
        fuzz::expect_input_errors([&] {
            io::LabelTable names;
            io::MeshReadInfo info;
            io::read_mesh(path, &names, &info);
        });
    }
    return 0;
}
