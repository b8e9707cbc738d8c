// libFuzzer target: an image file through io::read_label_image, i.e. the header checks of
// io/image_header.cpp (check_image_header) and then ITK's reader and our conversion.
// Input: byte 0 picks the format (file extension) modulo 6, the rest is the file. For the
// two-file formats (.mhd, .nhdr) the scratch folder holds data.raw (4 KiB) and data.raw.gz
// for the header to name. The memory limit is lowered to 64 MiB so that a header asking
// for more is refused by our check, not by libFuzzer's -rss_limit_mb.

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "io/image_reader.h"
#include "tests/fuzz/fuzz_support.h"

namespace {

const std::array<const char*, 6> kExtensions = {".nii", ".nii.gz", ".mha",
                                                ".mhd", ".nrrd",   ".nhdr"};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace frontmesh;
    static const bool data_made = [] {
        std::vector<std::uint8_t> bytes(4096);
        // Labels 0..3 in a pattern, any voxel type reads something.
        for (std::size_t i = 0; i < bytes.size(); ++i) bytes[i] = (i / 7) % 4 == 0 ? 1 : 0;
        fuzz::write_input("data.raw", bytes.data(), bytes.size());
        // Not a valid gzip stream on purpose: the header checks must refuse it.
        fuzz::write_input("data.raw.gz", bytes.data(), 64);
        return true;
    }();
    (void)data_made;
    if (size < 1) return 0;
    const std::string path = fuzz::write_input(
        std::string("image") + kExtensions[data[0] % kExtensions.size()], data + 1, size - 1);
    io::ImageReadOptions options;
    options.max_image_gib = 1.0 / 16.0;
    fuzz::expect_input_errors([&] { io::read_label_image(path, options); });
    return 0;
}
