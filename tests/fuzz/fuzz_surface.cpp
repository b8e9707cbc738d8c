// libFuzzer target: a triangle surface through io::read_surface (.vtu .vtp .stl .ply .off:
// VTK's readers and our OFF reader, then our conversion to a SurfaceNetwork), as
// input.surface and `frontmesh check --surface` read it.
// Input: byte 0 picks the extension modulo 5, the rest is the file.

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

#include "io/mesh_io.h"
#include "tests/fuzz/fuzz_support.h"

namespace {

const std::array<const char*, 5> kExtensions = {".vtu", ".vtp", ".stl", ".ply", ".off"};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace frontmesh;
    if (size < 1) return 0;
    const std::string path = fuzz::write_input(
        std::string("surface") + kExtensions[data[0] % kExtensions.size()], data + 1, size - 1);
    io::FieldStrings fields;
    fuzz::expect_input_errors([&] { io::read_surface(path, &fields); });
    return 0;
}
