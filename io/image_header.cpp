#include "io/image_header.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <string_view>
#include <utility>

#include <zlib.h>

#include "pipeline/core/error.h"

namespace frontmesh::io {
namespace {

namespace fs = std::filesystem;

/// Smallest |det| of a direction matrix with unit columns (the volume of its parallelepiped)
/// below which it counts as singular; the same bound as for the direction ITK reports.
constexpr double min_direction_determinant = 1e-6;
/// A text header (MetaImage, NRRD) longer than this is taken as damaged.
constexpr std::size_t max_text_header_bytes = std::size_t{1} << 20;

std::string lowercase(std::string text) {
    std::transform(text.begin(), text.end(), text.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return text;
}

bool ends_with_nocase(const std::string& text, std::string_view suffix) {
    return lowercase(text).ends_with(suffix);
}

std::string trimmed(const std::string& text) {
    const auto first = text.find_first_not_of(" \t\r\n");
    if (first == std::string::npos) return "";
    const auto last = text.find_last_not_of(" \t\r\n");
    return text.substr(first, last - first + 1);
}

/// A number as a user wrote it: "nan", "inf", "1e+30", "0.5".
std::string number_text(double value) {
    std::ostringstream text;
    text << value;
    return text.str();
}

std::string join(const std::vector<std::uint64_t>& values, const char* separator) {
    std::string text;
    for (std::uint64_t v : values) text += (text.empty() ? "" : separator) + std::to_string(v);
    return text;
}

/// What a file that is not a regular file is, for the message.
std::string kind_of(const fs::file_status& status) {
    if (fs::is_fifo(status)) return "a named pipe (FIFO)";
    if (fs::is_character_file(status)) return "a character device";
    if (fs::is_block_file(status)) return "a block device";
    if (fs::is_socket(status)) return "a socket";
    if (fs::is_directory(status)) return "a folder";
    return "not a regular file";
}

std::uint64_t file_size_of(const std::string& file) {
    std::error_code ec;
    const auto size = fs::file_size(file, ec);
    return ec ? 0 : static_cast<std::uint64_t>(size);
}

/// Determinant of the 3x3 matrix with columns `c`, each scaled to unit length (0 when a
/// column is zero): 1 for a rotation, near 0 for a singular matrix.
double unit_column_determinant(std::array<std::array<double, 3>, 3> c) {
    for (auto& column : c) {
        const double norm =
            std::sqrt(column[0] * column[0] + column[1] * column[1] + column[2] * column[2]);
        if (!(norm > 0.0)) return 0.0;
        for (double& x : column) x /= norm;
    }
    return c[0][0] * (c[1][1] * c[2][2] - c[2][1] * c[1][2]) -
           c[1][0] * (c[0][1] * c[2][2] - c[2][1] * c[0][2]) +
           c[2][0] * (c[0][1] * c[1][2] - c[1][1] * c[0][2]);
}

/// Throws InputError when a data stream holds `present` bytes, fewer than the `needed` ones;
/// `what` names the data file when it is not the image itself, `because` the header fields.
void check_data_size(const std::string& path, const std::string& what, std::uint64_t present,
                     std::uint64_t needed, const std::string& because) {
    if (present < needed)
        FM_THROW(InputError, image_prefix(path) + what + "is truncated: it holds " +
                                 std::to_string(present) + " of the " + std::to_string(needed) +
                                 " bytes " + because);
}

/// Bytes of `extents` voxels of `bytes` each; called after check_image_memory, which bounds
/// the product (input.max_image_gib is at most 2^16 GiB), so no overflow.
std::uint64_t data_bytes(const std::vector<std::uint64_t>& extents, std::uint64_t bytes) {
    std::uint64_t total = bytes;
    for (std::uint64_t e : extents) total *= e;
    return total;
}

// ---------------------------------------------------------------------------------------
// NIfTI-1 (and Analyze 7.5, its ancestor) and NIfTI-2: binary headers, fields at fixed
// offsets (nifti1.h, nifti2.h), in the byte order sizeof_hdr reveals.

/// A field of a binary header at byte `offset`, swapped when the file's byte order differs.
template <class T>
T field(const unsigned char* header, std::size_t offset, bool swap) {
    unsigned char bytes[sizeof(T)];
    std::memcpy(bytes, header + offset, sizeof(T));
    if (swap) std::reverse(bytes, bytes + sizeof(T));
    T value;
    std::memcpy(&value, bytes, sizeof(T));
    return value;
}

/// Bytes per voxel of a NIfTI datatype code; 0 for a code NIfTI does not define (or DT_BINARY,
/// which niftilib does not read).
std::uint64_t nifti_datatype_bytes(int datatype) {
    switch (datatype) {
        case 2:
        case 256:
            return 1;  // uint8, int8
        case 4:
        case 512:
            return 2;  // int16, uint16
        case 8:
        case 768:
        case 16:
        case 2304:
            return 4;  // int32, uint32, float32, rgba32
        case 128:
            return 3;  // rgb24
        case 32:
        case 64:
        case 1024:
        case 1280:
            return 8;  // complex64, float64, int64, uint64
        case 1536:
        case 1792:
            return 16;  // float128, complex128
        case 2048:
            return 32;  // complex256
        default:
            return 0;
    }
}

/// The header fields of a NIfTI-1/-2 or Analyze header that are checked, widened to one type.
struct NiftiHeader {
    int version = 1;          // 1 (or Analyze when !is_nifti), 2
    bool is_nifti = true;     // magic "n+1"/"ni1"/"n+2"/"ni2"; Analyze 7.5 has none
    bool single_file = true;  // magic "n+1"/"n+2": data in the same file after the header
    bool swap = false;        // byte order opposite to this machine's
    std::int64_t rank = 0;
    std::array<std::int64_t, 8> dim{};
    int datatype = 0;
    std::array<double, 8> pixdim{};
    double vox_offset = 0.0;
    double scl_slope = 0.0;
    double scl_inter = 0.0;
    int qform_code = 0;
    int sform_code = 0;
    std::array<double, 6> quatern{};  // quatern_b, _c, _d, qoffset_x, _y, _z
    std::array<double, 12> srow{};    // srow_x, srow_y, srow_z, 4 values each
    int xyz_units = 0;
    std::size_t size = 348;
};

/// Header file and data file of a NIfTI or Analyze image given by either name.
struct NiftiFiles {
    std::string header;
    std::string data;
};

std::optional<NiftiFiles> nifti_files(const std::string& file) {
    const std::string name = lowercase(file);
    if (name.ends_with(".nii") || name.ends_with(".nii.gz")) return NiftiFiles{file, file};
    auto stem_of = [&](std::size_t suffix) { return file.substr(0, file.size() - suffix); };
    std::string stem;
    if (name.ends_with(".hdr"))
        stem = stem_of(4);
    else if (name.ends_with(".img"))
        stem = stem_of(4);
    else if (name.ends_with(".img.gz"))
        stem = stem_of(7);
    else
        return std::nullopt;
    const bool upper = file.size() >= 3 && std::isupper(static_cast<unsigned char>(file.back()));
    NiftiFiles files;
    files.header = name.ends_with(".hdr") ? file : stem + (upper ? ".HDR" : ".hdr");
    if (!name.ends_with(".hdr")) {
        files.data = file;
    } else {
        files.data = stem + (upper ? ".IMG" : ".img");
        std::error_code ec;  // NAME.img.gz may be too long a name where NAME.hdr is not
        if (!fs::exists(files.data, ec) && fs::exists(files.data + ".gz", ec)) files.data += ".gz";
    }
    return files;
}

/// Reads the header of a NIfTI-1/-2 or Analyze file through zlib (plain files pass through).
NiftiHeader read_nifti_header(const std::string& path, const std::string& file) {
    errno = 0;
    const std::unique_ptr<gzFile_s, int (*)(gzFile)> stream(gzopen(file.c_str(), "rb"), gzclose);
    if (!stream)
        FM_THROW(InputError, image_prefix(path) + "NIfTI header '" + file +
                                 "' cannot be opened: " + std::strerror(errno));
    std::array<unsigned char, 540> h{};
    const int got = gzread(stream.get(), h.data(), static_cast<unsigned>(h.size()));
    const std::string where = image_prefix(path) + "NIfTI header" +
                              (file == path ? std::string() : " '" + file + "'") + ": ";
    if (got < 4)
        FM_THROW(InputError, where + "the file holds " + std::to_string(std::max(got, 0)) +
                                 " bytes, fewer than a header");

    NiftiHeader n;
    // sizeof_hdr (348 for NIfTI-1 and Analyze, 540 for NIfTI-2) tells version and byte order.
    const auto size_host = field<std::int32_t>(h.data(), 0, false);
    const auto size_swapped = field<std::int32_t>(h.data(), 0, true);
    if (size_host != 348 && size_host != 540 && size_swapped != 348 && size_swapped != 540)
        FM_THROW(InputError, where + "sizeof_hdr is " + std::to_string(size_host) +
                                 "; expected 348 (NIfTI-1) or 540 (NIfTI-2)");
    const bool swap = size_host != 348 && size_host != 540;
    n.swap = swap;
    n.version = (swap ? size_swapped : size_host) == 540 ? 2 : 1;
    n.size = n.version == 2 ? 540 : 348;
    if (got < static_cast<int>(n.size))
        FM_THROW(InputError, where + "the header is truncated: the file holds " +
                                 std::to_string(got) + " of its " + std::to_string(n.size) +
                                 " bytes");

    const unsigned char* p = h.data();
    if (n.version == 2) {
        const std::string_view magic(reinterpret_cast<const char*>(p) + 4, 3);
        n.is_nifti = magic == "n+2" || magic == "ni2";
        n.single_file = magic == "n+2";
        n.datatype = field<std::int16_t>(p, 12, swap);
        for (int d = 0; d < 8; ++d) n.dim[d] = field<std::int64_t>(p, 16 + 8 * d, swap);
        for (int d = 0; d < 8; ++d) n.pixdim[d] = field<double>(p, 104 + 8 * d, swap);
        n.vox_offset = static_cast<double>(field<std::int64_t>(p, 168, swap));
        n.scl_slope = field<double>(p, 176, swap);
        n.scl_inter = field<double>(p, 184, swap);
        n.qform_code = field<std::int32_t>(p, 344, swap);
        n.sform_code = field<std::int32_t>(p, 348, swap);
        for (int i = 0; i < 6; ++i) n.quatern[i] = field<double>(p, 352 + 8 * i, swap);
        for (int i = 0; i < 12; ++i) n.srow[i] = field<double>(p, 400 + 8 * i, swap);
        n.xyz_units = field<std::int32_t>(p, 500, swap) & 0x07;
    } else {
        // As niftilib's NIFTI_VERSION and NIFTI_ONEFILE decide it (nifti1.h): "n+" or "ni", a
        // digit 1..9 and a NUL is NIfTI whatever the digit ("n+2" in a 348-byte header is read
        // as NIfTI-1 with its qform and sform), anything else is Analyze 7.5.
        const char* magic = reinterpret_cast<const char*>(p) + 344;
        n.is_nifti = magic[0] == 'n' && (magic[1] == '+' || magic[1] == 'i') && magic[2] >= '1' &&
                     magic[2] <= '9' && magic[3] == '\0';
        n.single_file = n.is_nifti && magic[1] == '+';
        for (int d = 0; d < 8; ++d) n.dim[d] = field<std::int16_t>(p, 40 + 2 * d, swap);
        n.datatype = field<std::int16_t>(p, 70, swap);
        for (int d = 0; d < 8; ++d) n.pixdim[d] = field<float>(p, 76 + 4 * d, swap);
        n.vox_offset = field<float>(p, 108, swap);
        n.scl_slope = field<float>(p, 112, swap);
        n.scl_inter = field<float>(p, 116, swap);
        n.xyz_units = p[123] & 0x07;
        n.qform_code = field<std::int16_t>(p, 252, swap);
        n.sform_code = field<std::int16_t>(p, 254, swap);
        for (int i = 0; i < 6; ++i) n.quatern[i] = field<float>(p, 256 + 4 * i, swap);
        for (int i = 0; i < 12; ++i) n.srow[i] = field<float>(p, 280 + 4 * i, swap);
    }
    n.rank = n.dim[0];
    return n;
}

/// Millimetres per unit of the header's xyzt_units, as ITK's NiftiImageIO scales spacing.
double nifti_unit_mm(int xyz_units) {
    switch (xyz_units) {
        case 1:
            return 1e3;  // NIFTI_UNITS_METER
        case 3:
            return 1e-3;  // NIFTI_UNITS_MICRON
        default:
            return 1.0;  // NIFTI_UNITS_MM, or unknown: ITK takes mm
    }
}

/// Receives the bytes of a data stream from a given offset on, in order, in chunks.
using ByteVisitor = std::function<void(const unsigned char*, std::size_t)>;

/// Bytes of the data stream of `file` (decompressing it when gzip), counting at most `limit`;
/// when `visit` is set, the bytes from offset `from` up to `limit` are handed to it in order.
std::uint64_t stream_bytes(const std::string& file, std::uint64_t limit, std::uint64_t from = 0,
                           const ByteVisitor& visit = {}) {
    const bool gzip = ends_with_nocase(file, ".gz");
    if (!gzip && !visit) return file_size_of(file);
    std::vector<unsigned char> chunk(std::size_t{1} << 20);
    std::uint64_t present = 0;
    // Hands [present, present + got) to `visit`, the part at or after `from`.
    auto deliver = [&](std::uint64_t got) {
        if (visit && present + got > from) {
            const std::uint64_t skip = from > present ? from - present : 0;
            visit(chunk.data() + skip, static_cast<std::size_t>(got - skip));
        }
        present += got;
    };
    if (!gzip) {
        std::ifstream in(file, std::ios::binary);
        if (!in) return 0;
        in.seekg(static_cast<std::streamoff>(std::min(from, limit)));
        present = std::min(from, limit);
        // Bound: each pass reads at least one byte of a finite file, or stops.
        while (present < limit) {
            const auto want = std::min<std::uint64_t>(chunk.size(), limit - present);
            in.read(reinterpret_cast<char*>(chunk.data()), static_cast<std::streamsize>(want));
            const auto got = in.gcount();
            if (got <= 0) break;
            deliver(static_cast<std::uint64_t>(got));
        }
        return std::min(present, file_size_of(file));
    }
    const std::unique_ptr<gzFile_s, int (*)(gzFile)> stream(gzopen(file.c_str(), "rb"), gzclose);
    if (!stream) return 0;
    gzbuffer(stream.get(), 1u << 17);
    // Bound: each pass inflates at least one byte, at most `limit` in all, or stops.
    while (present < limit) {
        const auto want =
            static_cast<unsigned>(std::min<std::uint64_t>(chunk.size(), limit - present));
        const int got = gzread(stream.get(), chunk.data(), want);
        if (got <= 0) break;
        deliver(static_cast<std::uint64_t>(got));
    }
    return present;
}

/// Bytes a zlib or gzip stream (detected from its first bytes) that starts at byte `offset`
/// of `file` inflates to, counting at most `limit`; a damaged stream counts up to the damage.
/// MetaImage CompressedData is zlib, NRRD "encoding: gzip" is gzip; both may follow a header.
/// With `in_limit`, only that many compressed bytes are read (MetaIO reads CompressedDataSize).
std::uint64_t inflated_bytes(const std::string& file, std::uint64_t offset, std::uint64_t limit,
                             std::uint64_t in_limit = std::numeric_limits<std::uint64_t>::max()) {
    std::ifstream in(file, std::ios::binary);
    if (!in) return 0;
    in.seekg(static_cast<std::streamoff>(offset));
    z_stream z{};
    if (inflateInit2(&z, 15 + 32) != Z_OK) return 0;  // 15 + 32: zlib or gzip header
    std::vector<unsigned char> input(std::size_t{1} << 16);
    std::vector<unsigned char> output(std::size_t{1} << 20);
    std::uint64_t produced = 0;
    int status = Z_OK;
    // Bound: with input and output space inflate consumes or produces at least one byte, or
    // returns an error; input is a finite file and output stops at `limit`.
    while (produced < limit && status == Z_OK) {
        if (z.avail_in == 0) {
            const auto want = std::min<std::uint64_t>(input.size(), in_limit);
            if (want == 0) break;
            in.read(reinterpret_cast<char*>(input.data()), static_cast<std::streamsize>(want));
            const auto got = in.gcount();
            if (got <= 0) break;
            in_limit -= static_cast<std::uint64_t>(got);
            z.next_in = input.data();
            z.avail_in = static_cast<uInt>(got);
        }
        z.next_out = output.data();
        z.avail_out = static_cast<uInt>(output.size());
        status = inflate(&z, Z_NO_FLUSH);
        produced += output.size() - z.avail_out;
    }
    inflateEnd(&z);
    return produced;
}

/// Counts the NaN and inf values among float32 or float64 voxels handed over in chunks of any
/// size (a value split between two chunks is carried over), and keeps the first one.
class NonFiniteScan {
public:
    NonFiniteScan(std::uint64_t value_bytes, bool swap) : value_bytes_(value_bytes), swap_(swap) {}

    void add(const unsigned char* data, std::size_t size) {
        // Bound: each pass takes at least one byte of `size`.
        while (size > 0) {
            const std::size_t take = std::min<std::size_t>(size, value_bytes_ - carried_);
            std::memcpy(carry_.data() + carried_, data, take);
            carried_ += take;
            data += take;
            size -= take;
            if (carried_ < value_bytes_) break;
            carried_ = 0;
            const double v = value_bytes_ == 4 ? field<float>(carry_.data(), 0, swap_)
                                               : field<double>(carry_.data(), 0, swap_);
            if (!std::isfinite(v)) {
                if (count_ == 0) {
                    first_index_ = index_;
                    first_value_ = v;
                }
                ++count_;
            }
            ++index_;
        }
    }
    std::uint64_t count() const { return count_; }
    std::uint64_t first_index() const { return first_index_; }
    double first_value() const { return first_value_; }

private:
    std::uint64_t value_bytes_;
    bool swap_;
    std::array<unsigned char, 8> carry_{};
    std::size_t carried_ = 0;
    std::uint64_t index_ = 0;
    std::uint64_t count_ = 0;
    std::uint64_t first_index_ = 0;
    double first_value_ = 0.0;
};

/// "nan", "inf" or "-inf", whatever the sign bit of a NaN.
std::string non_finite_text(double value) {
    return std::isnan(value) ? "nan" : value > 0 ? "inf" : "-inf";
}

void check_nifti(const std::string& path, const std::string& file, const HeaderLimits& limits) {
    const auto files = nifti_files(file);
    if (!files) return;
    if (files->header != file) require_regular_file(path, files->header, "NIfTI header file");
    const NiftiHeader n = read_nifti_header(path, files->header);
    const std::string where = image_prefix(path) + "NIfTI header" +
                              (files->header == path ? std::string() : " '" + files->header + "'") +
                              ": ";
    auto fail = [&](const std::string& what) { FM_THROW(InputError, where + what); };
    auto finite = [&](const std::string& name, double value) {
        if (!std::isfinite(value)) fail(name + " is " + number_text(value) + "; it must be finite");
    };

    if (n.rank < 1 || n.rank > 7)
        fail("dim[0] (the number of dimensions) is " + std::to_string(n.rank) +
             "; expected 1 to 7");
    std::vector<std::uint64_t> extents;
    for (int d = 1; d <= n.rank; ++d) {
        if (n.dim[d] < 1)
            fail("dim[" + std::to_string(d) + "] is " + std::to_string(n.dim[d]) +
                 "; every extent must be at least 1");
        extents.push_back(static_cast<std::uint64_t>(n.dim[d]));
    }
    const std::uint64_t voxel_bytes = nifti_datatype_bytes(n.datatype);
    if (voxel_bytes == 0)
        fail("datatype " + std::to_string(n.datatype) +
             " is not a NIfTI voxel type frontmesh reads");
    check_image_memory(path, "NIfTI header: dim[1.." + std::to_string(n.rank) + "]", extents,
                       voxel_bytes, limits.max_image_gib);

    if (limits.check_spacing) {
        // In the header's unit, as ITK scales it. NIfTI requires pixdim[1..3] > 0; niftilib
        // replaces a negative one by 1 in the qform and ITK takes its magnitude elsewhere, so
        // a negative one is refused like a zero one rather than guessed at.
        const double unit = nifti_unit_mm(n.xyz_units);
        for (int d = 1; d <= std::min<std::int64_t>(n.rank, 3); ++d)
            check_spacing(path, "NIfTI header: pixdim[" + std::to_string(d) + "]",
                          n.pixdim[d] * unit);
    }
    // 2^53: beyond it the float field holds no exact byte offset, and no file is that long.
    if (!(n.vox_offset >= 0.0 && n.vox_offset <= 9007199254740992.0))
        fail("vox_offset is " + number_text(n.vox_offset) + "; it must be a byte offset >= 0");

    if (n.is_nifti) {
        finite("scl_slope", n.scl_slope);
        finite("scl_inter", n.scl_inter);
        if (n.qform_code > 0) {
            static const char* const names[] = {"quatern_b", "quatern_c", "quatern_d",
                                                "qoffset_x", "qoffset_y", "qoffset_z"};
            for (int i = 0; i < 6; ++i) finite(names[i], n.quatern[i]);
            // The qform scales by pixdim[1..3] even when the spacing is given by the user: a
            // NaN there makes ITK's orientation SVD (netlib ssvdc) loop without end.
            for (int d = 1; d <= 3; ++d)
                finite("pixdim[" + std::to_string(d) + "] (used by the qform)", n.pixdim[d]);
            for (int i = 3; i < 6; ++i)
                check_origin(path, std::string("NIfTI header: ") + names[i], n.quatern[i]);
        }
        if (n.sform_code > 0) {
            static const char* const rows[] = {"srow_x", "srow_y", "srow_z"};
            for (int i = 0; i < 12; ++i)
                finite(std::string(rows[i / 4]) + "[" + std::to_string(i % 4) + "]", n.srow[i]);
            for (int r = 0; r < 3; ++r)
                check_origin(path, std::string("NIfTI header: ") + rows[r] + "[3]",
                             n.srow[4 * r + 3]);
            std::array<std::array<double, 3>, 3> columns{};
            for (int r = 0; r < 3; ++r)
                for (int c = 0; c < 3; ++c) columns[c][r] = n.srow[4 * r + c];
            if (std::abs(unit_column_determinant(columns)) < min_direction_determinant)
                fail("the sform (srow_x, srow_y, srow_z with sform_code " +
                     std::to_string(n.sform_code) + ") is singular");
        }
    }

    // niftilib fills the voxels missing from a truncated file with 0 and reports success,
    // and reads what the header announces before that: compare the bytes present first.
    require_regular_file(path, files->data, "NIfTI data file");
    const bool same_file = files->data == files->header;
    // A .nii without the single-file magic "n+1"/"n+2" keeps its voxels elsewhere (niftilib
    // then looks for a .img); ITK reports that case.
    if (same_file && !n.single_file) return;
    std::uint64_t start = static_cast<std::uint64_t>(n.vox_offset);
    if (same_file) start = std::max<std::uint64_t>(start, n.version == 2 ? 544 : 352);
    const std::uint64_t needed = start + data_bytes(extents, voxel_bytes);
    // niftilib sets every NaN and inf float voxel to 0 before ITK sees it, so they are
    // counted here, in the pass that counts the bytes (datatypes 16 and 64, one volume).
    const bool is_float = n.datatype == 16 || n.datatype == 64;
    const bool one_volume = std::all_of(extents.begin() + std::min<std::ptrdiff_t>(3, n.rank),
                                        extents.end(), [](std::uint64_t e) { return e == 1; });
    NonFiniteScan scan(voxel_bytes, n.swap);
    const std::uint64_t present =
        is_float && one_volume ? stream_bytes(files->data, needed, start,
                                              [&scan](const unsigned char* data, std::size_t size) {
                                                  scan.add(data, size);
                                              })
                               : stream_bytes(files->data, needed);
    check_data_size(path, same_file ? "" : "NIfTI data file '" + files->data + "' ", present,
                    needed, "its NIfTI header announces (dim, datatype, vox_offset)");
    if (scan.count() > 0) {
        const std::uint64_t nx = extents[0];
        const std::uint64_t ny = extents.size() > 1 ? extents[1] : 1;
        const std::uint64_t first = scan.first_index();
        FM_THROW(InputError,
                 non_finite_voxels_message(path, non_finite_text(scan.first_value()), first % nx,
                                           first / nx % ny, first / (nx * ny), scan.count()));
    }
    // Checked whole like a NIfTI-1 header, but Debian's ITK 5.2 has no NIfTI-2 reader: its
    // own message ("not an image ITK can read, damaged header") blamed a sound file (the
    // malformed-input campaign, issue 21).
    if (n.version == 2)
        fail(
            "NIfTI-2 (sizeof_hdr 540), which ITK 5.2 cannot read; save the image as NIfTI-1, "
            "e.g. with nibabel: nib.save(nib.Nifti1Image(img.dataobj, img.affine), "
            "'image.nii.gz')");
}

// ---------------------------------------------------------------------------------------
// MetaImage (.mha, .mhd): "Key = Value" lines ending with ElementDataFile (MetaIO's keys are
// case-sensitive), then the data or the name of the file holding it.

/// Bytes per voxel of a MetaIO ElementType (metaTypes.h MET_ValueTypeSize); 0 when unknown.
std::uint64_t meta_type_bytes(const std::string& type) {
    static const std::map<std::string, std::uint64_t> sizes = {{"MET_ASCII_CHAR", 1},
                                                               {"MET_CHAR", 1},
                                                               {"MET_UCHAR", 1},
                                                               {"MET_SHORT", 2},
                                                               {"MET_USHORT", 2},
                                                               {"MET_INT", 4},
                                                               {"MET_UINT", 4},
                                                               {"MET_LONG", 4},
                                                               {"MET_ULONG", 4},
                                                               {"MET_LONG_LONG", 8},
                                                               {"MET_ULONG_LONG", 8},
                                                               {"MET_FLOAT", 4},
                                                               {"MET_DOUBLE", 8},
                                                               {"MET_CHAR_ARRAY", 1},
                                                               {"MET_UCHAR_ARRAY", 1},
                                                               {"MET_SHORT_ARRAY", 2},
                                                               {"MET_USHORT_ARRAY", 2},
                                                               {"MET_INT_ARRAY", 4},
                                                               {"MET_UINT_ARRAY", 4},
                                                               {"MET_LONG_ARRAY", 4},
                                                               {"MET_ULONG_ARRAY", 4},
                                                               {"MET_LONG_LONG_ARRAY", 8},
                                                               {"MET_ULONG_LONG_ARRAY", 8},
                                                               {"MET_FLOAT_ARRAY", 4},
                                                               {"MET_DOUBLE_ARRAY", 8},
                                                               {"MET_FLOAT_MATRIX", 4}};
    const auto it = sizes.find(type);
    return it == sizes.end() ? 0 : it->second;
}

/// Whether `token` is a number as C++'s `operator>>(double&)` reads it whole: sign, digits,
/// point, exponent, nothing else (no "inf", "nan" or hex, which strtod would take).
bool plain_decimal(const std::string& token) {
    std::size_t i = 0;
    const std::size_t n = token.size();
    auto digits = [&] {
        const std::size_t from = i;
        while (i < n && token[i] >= '0' && token[i] <= '9') ++i;
        return i - from;
    };
    if (i < n && (token[i] == '+' || token[i] == '-')) ++i;
    std::size_t mantissa = digits();
    if (i < n && token[i] == '.') {
        ++i;
        mantissa += digits();
    }
    if (mantissa == 0) return false;
    if (i < n && (token[i] == 'e' || token[i] == 'E')) {
        ++i;
        if (i < n && (token[i] == '+' || token[i] == '-')) ++i;
        if (digits() == 0) return false;
    }
    return i == n;
}

/// The range of a MetaIO integer ElementType's values; nullopt for the float types.
std::optional<std::pair<double, double>> meta_integer_range(const std::string& type) {
    const std::string base = type.substr(
        0, type.rfind("_ARRAY") == std::string::npos ? type.size() : type.rfind("_ARRAY"));
    static const std::map<std::string, std::pair<double, double>> ranges = {
        {"MET_ASCII_CHAR", {-128, 127}},
        {"MET_CHAR", {-128, 127}},
        {"MET_UCHAR", {0, 255}},
        {"MET_SHORT", {-32768, 32767}},
        {"MET_USHORT", {0, 65535}},
        {"MET_INT", {-2147483648.0, 2147483647.0}},
        {"MET_UINT", {0, 4294967295.0}},
        {"MET_LONG", {-2147483648.0, 2147483647.0}},
        {"MET_ULONG", {0, 4294967295.0}},
        {"MET_LONG_LONG", {-9.2233720368547758e18, 9.2233720368547758e18}},
        {"MET_ULONG_LONG", {0, 1.8446744073709552e19}}};
    const auto it = ranges.find(base);
    if (it == ranges.end()) return std::nullopt;
    return it->second;
}

/// MetaImage text voxels (BinaryData = False), as MetaIO reads them (`>>` into a double, then
/// a cast to the voxel type): each of the first voxels a plain decimal number within the
/// type's range. MetaIO stops at the first token it cannot read and leaves the rest of the
/// image as it was allocated: garbage labels (found by the malformed-input campaign, issue
/// 21). Bounded by the data's size (text images are small: two bytes a voxel at least).
void check_meta_text_values(const std::string& path, const std::string& what,
                            const std::string& data_file, std::uint64_t start,
                            const std::vector<std::uint64_t>& counted, const std::string& type) {
    const std::uint64_t voxels = data_bytes(counted, 1);
    const auto range = meta_integer_range(type);
    std::ifstream in(data_file, std::ios::binary);
    in.seekg(static_cast<std::streamoff>(start));
    std::uint64_t index = 0;
    auto where = [&] {
        std::string text = "text voxel " + std::to_string(index);
        if (counted.size() >= 3) {
            const std::uint64_t i = index % counted[0], j = index / counted[0] % counted[1],
                                k = index / counted[0] / counted[1];
            text += " (" + std::to_string(i) + ", " + std::to_string(j) + ", " + std::to_string(k) +
                    ")";
        }
        return text;
    };
    for (std::string token; index < voxels && in >> token; ++index) {
        if (!plain_decimal(token))
            FM_THROW(InputError, image_prefix(path) + what + where() + " is '" +
                                     token.substr(0, 40) + "', not a number");
        const double value = std::strtod(token.c_str(), nullptr);
        if (!std::isfinite(value) || (range && (value < range->first || value > range->second)))
            FM_THROW(InputError, image_prefix(path) + what + where() + " is " +
                                     token.substr(0, 40) + ", outside the range of " + type);
    }
    if (index < voxels)
        FM_THROW(InputError, image_prefix(path) + what + "is truncated: it holds " +
                                 std::to_string(index) + " of the " + std::to_string(voxels) +
                                 " text voxels its MetaImage header announces");
}

/// Whitespace-separated numbers of a header value; nullopt when one token is not a number
/// (with `decimal_only`, when one is not a plain decimal number).
std::optional<std::vector<double>> parse_numbers(const std::string& value,
                                                 bool decimal_only = false) {
    std::vector<double> numbers;
    std::istringstream tokens(value);
    for (std::string token; tokens >> token;) {
        if (decimal_only && !plain_decimal(token)) return std::nullopt;
        char* end = nullptr;
        const double number = std::strtod(token.c_str(), &end);
        if (end == token.c_str() || *end != '\0') return std::nullopt;
        numbers.push_back(number);
    }
    return numbers;
}

/// One checked header of text key/value lines, with the messages' common start.
class TextHeader {
public:
    /// `decimal_only`: numbers are read as C++ streams read them (MetaIO), not as strtod.
    TextHeader(const std::string& path, const std::string& file, const std::string& format,
               bool decimal_only = false)
        : where_(image_prefix(path) + format + " header" +
                 (file == path ? std::string() : " '" + file + "'") + ": "),
          decimal_only_(decimal_only) {}

    [[noreturn]] void fail(const std::string& what) const { FM_THROW(InputError, where_ + what); }

    /// `count` numbers (at least) of `value`, the value of `key`.
    std::vector<double> numbers(const std::string& key, const std::string& value,
                                std::size_t count) const {
        auto values = parse_numbers(value, decimal_only_);
        if (!values) {
            // Name the first token that is no number.
            std::istringstream tokens(value);
            std::size_t index = 1;
            for (std::string token; tokens >> token; ++index)
                if (!parse_numbers(token, decimal_only_))
                    fail(key + " value " + std::to_string(index) + " '" + token.substr(0, 40) +
                         "' is not a " + (decimal_only_ ? "decimal number" : "number"));
            fail(key + " '" + value + "' is not a list of numbers");
        }
        // Exactly: extra values (an Offset of four numbers in a 3-D header) mean a header
        // written for another dimension; the readers take the first ones silently (the
        // malformed-input campaign, issue 21).
        if (values->size() != count)
            fail(key + " '" + value + "' has " + std::to_string(values->size()) +
                 " values; expected " + std::to_string(count));
        values->resize(count);
        return *values;
    }

    /// One whole number of `value` within [lo, hi].
    std::int64_t integer(const std::string& key, const std::string& value, std::int64_t lo,
                         std::int64_t hi) const {
        const auto n = numbers(key, value, 1).front();
        if (!(n >= static_cast<double>(lo) && n <= static_cast<double>(hi)) || n != std::trunc(n))
            fail(key + " is " + trimmed(value) + "; expected a whole number from " +
                 std::to_string(lo) + " to " + std::to_string(hi));
        return static_cast<std::int64_t>(n);
    }

    /// Extents of `value`, each a whole number >= 1.
    std::vector<std::uint64_t> extents(const std::string& key, const std::string& value,
                                       std::size_t count) const {
        std::vector<std::uint64_t> extents;
        for (double n : numbers(key, value, count)) {
            if (!(n >= 1.0) || n != std::trunc(n) || n > 9e15)
                fail(key + " '" + trimmed(value) + "' holds " + number_text(n) +
                     "; every extent must be a whole number, at least 1");
            extents.push_back(static_cast<std::uint64_t>(n));
        }
        return extents;
    }

    void require_finite(const std::string& key, const std::vector<double>& values) const {
        for (std::size_t i = 0; i < values.size(); ++i)
            if (!std::isfinite(values[i]))
                fail(key + " value " + std::to_string(i + 1) + " is " + number_text(values[i]) +
                     "; it must be finite");
    }

    /// A 3x3 matrix with columns `columns` must be non-singular.
    void require_nonsingular(const std::string& key,
                             const std::array<std::array<double, 3>, 3>& columns) const {
        if (std::abs(unit_column_determinant(columns)) < min_direction_determinant)
            fail(key + " is singular");
    }

private:
    std::string where_;
    bool decimal_only_ = false;
};

/// Lines of a text header from `in` until `is_last(line)` or `stop_at_blank` meets an empty
/// line; sets `end` to the offset of the byte after the header.
std::vector<std::string> header_lines(std::istream& in, bool stop_at_blank,
                                      const std::function<bool(const std::string&)>& is_last,
                                      std::uint64_t& end, const TextHeader& header) {
    std::vector<std::string> lines;
    std::uint64_t read = 0;
    for (std::string line; std::getline(in, line);) {
        read += line.size() + (in.eof() ? 0 : 1);
        if (read > max_text_header_bytes)
            header.fail("the header is longer than " + std::to_string(max_text_header_bytes) +
                        " bytes");
        if (!line.empty() && line.back() == '\r') line.pop_back();
        if (stop_at_blank && line.empty()) break;
        lines.push_back(line);
        if (is_last(line)) break;
    }
    end = read;
    return lines;
}

/// The folder relative names in a header are resolved against.
std::string beside(const std::string& header_file, const std::string& name) {
    const fs::path p(name);
    if (p.is_absolute()) return name;
    return (fs::path(header_file).parent_path() / p).string();
}

/// A MetaImage printf pattern "ElementDataFile = slice%03d.raw MIN MAX STEP [SUBDIM]": MetaIO
/// formats the pattern with an int (anything but one %d conversion reads garbage from its
/// stack) and divides by STEP (0 stopped a fuzzed run with SIGFPE). The files it names, one
/// per slice of SUBDIM (default NDims - 1) dimensions, must be as many as those slices.
void check_meta_pattern(const TextHeader& header, const std::vector<std::string>& tokens,
                        const std::vector<std::uint64_t>& extents) {
    const std::string key = "ElementDataFile";
    if (tokens.size() < 4 || tokens.size() > 5)
        header.fail(key + " names a file pattern ('%' in '" + tokens.front().substr(0, 80) +
                    "'); expected 'pattern MIN MAX STEP [SUBDIM]'");
    const std::string& pattern = tokens.front();
    std::size_t conversions = 0;
    for (std::size_t i = pattern.find('%'); i != std::string::npos; i = pattern.find('%', i)) {
        std::size_t j = i + 1;
        while (j < pattern.size() && pattern[j] >= '0' && pattern[j] <= '9') ++j;
        if (j >= pattern.size() || pattern[j] != 'd' || j - i > 4)
            header.fail(key + " pattern '" + pattern.substr(0, 80) +
                        "' may only hold one %d conversion (as %d or %03d)");
        ++conversions;
        i = j + 1;
    }
    if (conversions != 1)
        header.fail(key + " pattern '" + pattern.substr(0, 80) + "' holds " +
                    std::to_string(conversions) + " conversions; expected one %d");
    const std::int64_t lo = 0, hi = std::int64_t{1} << 30;
    const std::int64_t first = header.integer(key + " MIN", tokens[1], lo, hi);
    const std::int64_t last = header.integer(key + " MAX", tokens[2], first, hi);
    const std::int64_t step = header.integer(key + " STEP", tokens[3], 1, hi);
    const auto ndims = static_cast<std::int64_t>(extents.size());
    const std::int64_t subdim =
        tokens.size() == 5 ? header.integer(key + " SUBDIM", tokens[4], 1, ndims) : ndims - 1;
    std::uint64_t slices = 1;
    for (auto d = static_cast<std::size_t>(subdim); d < extents.size(); ++d) slices *= extents[d];
    const auto files = static_cast<std::uint64_t>((last - first) / step + 1);
    if (files != slices)
        header.fail(key + " pattern names " + std::to_string(files) + " files (" + tokens[1] +
                    " to " + tokens[2] + " by " + tokens[3] + "); DimSize needs " +
                    std::to_string(slices));
}

/// The files of a pattern (checked by check_meta_pattern): each a regular file holding, when
/// raw (`raw_bytes`), a slice's bytes. MetaIO read a pattern of twelve missing files as an
/// image without complaint, and a mesh was made of it (the malformed-input campaign, issue
/// 21). Bounded by the slice count, which the image's memory limit bounds.
void check_meta_pattern_files(const std::string& path, const std::string& header_file,
                              const std::vector<std::string>& tokens,
                              const std::vector<std::uint64_t>& counted, std::uint64_t voxel_bytes,
                              bool raw_bytes) {
    const std::int64_t first = std::stoll(tokens[1]), last = std::stoll(tokens[2]),
                       step = std::stoll(tokens[3]);
    // A file holds the first SUBDIM extents (all but the last by default); counted may end
    // with the channels, which every file holds too.
    const std::size_t dims = counted.size();
    const std::size_t subdim = tokens.size() == 5 ? std::stoul(tokens[4]) : dims - 1;
    std::uint64_t slice_bytes = voxel_bytes;
    for (std::size_t d = 0; d < std::min(subdim, dims); ++d) slice_bytes *= counted[d];
    std::vector<char> name(tokens[0].size() + 32);
    for (std::int64_t i = first; i <= last; i += step) {
        std::snprintf(name.data(), name.size(), tokens[0].c_str(), static_cast<int>(i));
        const std::string slice = beside(header_file, name.data());
        require_regular_file(path, slice, "data file (ElementDataFile pattern)");
        if (raw_bytes)
            check_data_size(path, "data file '" + slice + "' (ElementDataFile pattern) ",
                            file_size_of(slice), slice_bytes, "of the slice its header announces");
    }
}

/// "ElementDataFile = LIST [SUBDIM]": the lines after the header name one file each, one
/// per slice of SUBDIM dimensions (MetaIO takes a missing, zero or too large SUBDIM as
/// NDims - 1). MetaIO skips a name it cannot open and reads up to 1,023 characters per line,
/// stopping silently at the end of the file: any of these left the image's slices unread,
/// and a header followed by binary data made a mesh of garbage (campaign seed 10, issue 21).
/// So the names must be as many as the slices, text, and each a regular file holding, when
/// raw (`raw_bytes`), a slice's bytes. Bounded by the slice count (the image's memory limit
/// bounds it) and the 1,023 characters per line.
void check_meta_list(const std::string& path, const std::string& header_file, std::istream& in,
                     const TextHeader& header, const std::vector<std::string>& tokens,
                     const std::vector<std::uint64_t>& counted, std::size_t ndims,
                     std::uint64_t voxel_bytes, bool raw_bytes) {
    std::size_t subdim = ndims - 1;
    if (tokens.front() != "LIST" || tokens.size() > 2)
        header.fail(
            "ElementDataFile starts with LIST, which MetaIO reads as a list of files; "
            "expected 'LIST' or 'LIST SUBDIM', not " +
            std::to_string(tokens.size()) + " word(s) starting '" + tokens.front().substr(0, 40) +
            "'");
    if (tokens.size() == 2) {
        std::string dim = tokens[1];
        if (!dim.empty() && (dim.back() == 'D' || dim.back() == 'd')) dim.pop_back();
        subdim = static_cast<std::size_t>(header.integer("ElementDataFile LIST SUBDIM", dim, 0,
                                                         static_cast<std::int64_t>(ndims)));
        if (subdim == 0) subdim = ndims - 1;
    }
    std::uint64_t files = 1, slice_bytes = voxel_bytes;
    for (std::size_t d = 0; d < ndims; ++d) (d < subdim ? slice_bytes : files) *= counted[d];
    for (std::size_t d = ndims; d < counted.size(); ++d) slice_bytes *= counted[d];  // channels
    for (std::uint64_t i = 0; i < files; ++i) {
        const std::string which =
            "ElementDataFile LIST name " + std::to_string(i + 1) + " of " + std::to_string(files);
        std::string name;
        if (!std::getline(in, name)) header.fail(which + " is missing: the file ends before it");
        if (name.size() > 1000)
            header.fail(which + " is " + std::to_string(name.size()) +
                        " characters long; at most 1000");
        while (!name.empty() && (std::isspace(static_cast<unsigned char>(name.back())) != 0 ||
                                 std::isprint(static_cast<unsigned char>(name.back())) == 0))
            name.pop_back();
        if (name.empty()) header.fail(which + " is an empty line");
        for (const char ch : name)
            if (std::isprint(static_cast<unsigned char>(ch)) == 0)
                header.fail(which +
                            " holds a byte that is no printable character; the names "
                            "after LIST are text, one per line");
        const std::string slice = beside(header_file, name);
        require_regular_file(path, slice, "data file (ElementDataFile LIST)");
        if (raw_bytes)
            check_data_size(path, "data file '" + slice + "' (ElementDataFile LIST) ",
                            file_size_of(slice), slice_bytes, "of the slice its header announces");
    }
}

void check_metaimage(const std::string& path, const std::string& file, const HeaderLimits& limits) {
    const TextHeader header(path, file, "MetaImage", true);
    std::ifstream in(file, std::ios::binary);
    if (!in) header.fail("the file cannot be opened");
    std::uint64_t header_end = 0;
    const auto lines = header_lines(
        in, false,
        [](const std::string& line) { return trimmed(line).rfind("ElementDataFile", 0) == 0; },
        header_end, header);

    // Keys and values as MetaIO's MET_Read takes them, or refused where it would take them
    // otherwise than we do (a fuzzed header overflowed its 255-byte key buffer, another one
    // had a value it read differently): a key ends at the first '=' or ':', a line with
    // neither would make MetaIO read on into the next line, a control character means the
    // header is damaged, and a key given twice is ambiguous.
    std::map<std::string, std::string> keys;
    std::map<std::string, std::size_t> key_line;
    for (std::size_t i = 0; i < lines.size(); ++i) {
        const std::string& line = lines[i];
        const std::string line_name = "line " + std::to_string(i + 1);
        for (const char ch : line) {
            const auto c = static_cast<unsigned char>(ch);
            if ((c < 0x20 && c != '\t') || c == 0x7f) {
                char code[8];
                std::snprintf(code, sizeof code, "0x%02x", c);
                header.fail(line_name + " holds the control character " + code +
                            "; a MetaImage header is text");
            }
        }
        // MetaIO reads a line into 500 bytes (getline); a longer one fails its stream, and
        // what it reads after that (even a size taken from tellg() = -1) is garbage.
        if (line.size() > 400)
            header.fail(line_name + " is " + std::to_string(line.size()) +
                        " characters long; at most 400");
        if (trimmed(line).empty()) continue;
        const auto separator = line.find_first_of("=:");
        if (separator == std::string::npos)
            header.fail(line_name + " '" + trimmed(line).substr(0, 80) +
                        "' is not a 'Key = value' line");
        const std::string key = trimmed(line.substr(0, separator));
        if (key.size() > 200)
            header.fail(line_name + ": the key '" + key.substr(0, 40) + "...' is " +
                        std::to_string(key.size()) + " characters long; at most 200");
        if (const auto [it, added] = key_line.emplace(key, i + 1); !added)
            header.fail(key + " is given twice (lines " + std::to_string(it->second) + " and " +
                        std::to_string(i + 1) + ")");
        // MET_SkipToVal skips white space after the separator, line ends included: an empty
        // value makes MetaIO take the next line as the value (an empty ElementDataFile
        // followed by compressed bytes made it allocate 2^64 - 1 bytes).
        std::string value = trimmed(line.substr(separator + 1));
        if (value.empty())
            header.fail(line_name + ": " + key + " has no value (MetaIO would read line " +
                        std::to_string(i + 2) + " as its value)");
        keys[key] = std::move(value);
    }
    auto value_of = [&](std::initializer_list<const char*> names)
        -> std::optional<std::pair<std::string, std::string>> {
        for (const char* name : names)
            if (const auto it = keys.find(name); it != keys.end()) return *it;
        return std::nullopt;
    };
    auto required = [&](const char* name) {
        const auto it = keys.find(name);
        if (it == keys.end()) header.fail(std::string(name) + " is missing");
        return it->second;
    };

    const auto ndims = static_cast<std::size_t>(header.integer("NDims", required("NDims"), 1, 10));
    const std::vector<std::uint64_t> extents =
        header.extents("DimSize", required("DimSize"), ndims);
    std::vector<std::uint64_t> counted = extents;
    if (const auto channels = value_of({"ElementNumberOfChannels"}))
        counted.push_back(static_cast<std::uint64_t>(
            header.integer(channels->first, channels->second, 1, 1 << 16)));
    const std::string type = required("ElementType");
    const std::uint64_t voxel_bytes = meta_type_bytes(type);
    if (voxel_bytes == 0) header.fail("ElementType '" + type + "' is not a MetaImage voxel type");
    check_image_memory(path, "MetaImage header: DimSize", counted, voxel_bytes,
                       limits.max_image_gib);

    if (const auto spacing = value_of({"ElementSpacing", "ElementSize"})) {
        const auto values = header.numbers(spacing->first, spacing->second, ndims);
        if (limits.check_spacing)
            for (std::size_t d = 0; d < std::min<std::size_t>(ndims, 3); ++d)
                check_spacing(
                    path, "MetaImage header: " + spacing->first + " value " + std::to_string(d + 1),
                    values[d]);
    }
    // The other number lists MetaIO parses: a value it cannot read (ElementSize = nan 1 1)
    // made it print four lines of its own and lose the rest of the header (the malformed-
    // input campaign, issue 21). ElementSize is the spacing when ElementSpacing is absent.
    for (const char* name : {"ElementSize", "CenterOfRotation"})
        if (const auto it = keys.find(name); it != keys.end())
            header.require_finite(name, header.numbers(name, it->second, ndims));
    for (const char* name : {"ElementMin", "ElementMax"})
        if (const auto it = keys.find(name); it != keys.end())
            header.require_finite(name, header.numbers(name, it->second, 1));
    // MetaIO reads these names as one field; given twice it misreads the header (a NaN in
    // the second went unchecked, and MetaIO printed four lines of its own).
    auto one_of = [&](std::initializer_list<const char*> names) {
        const char* first = nullptr;
        for (const char* name : names)
            if (keys.count(name)) {
                if (first != nullptr)
                    header.fail(std::string(first) + " and " + name +
                                " are two names of one field; keep one");
                first = name;
            }
    };
    one_of({"Offset", "Position", "Origin"});
    one_of({"TransformMatrix", "Rotation", "Orientation"});
    if (const auto origin = value_of({"Offset", "Position", "Origin"})) {
        const auto values = header.numbers(origin->first, origin->second, ndims);
        header.require_finite(origin->first, values);
        for (std::size_t d = 0; d < values.size(); ++d)
            check_origin(path,
                         "MetaImage header: " + origin->first + " value " + std::to_string(d + 1),
                         values[d]);
    }
    if (const auto matrix = value_of({"TransformMatrix", "Rotation", "Orientation"})) {
        const auto values = header.numbers(matrix->first, matrix->second, ndims * ndims);
        header.require_finite(matrix->first, values);
        if (ndims == 3) {
            // MetaIO stores the matrix row by row with rows as the axis directions.
            std::array<std::array<double, 3>, 3> columns{};
            for (int a = 0; a < 3; ++a)
                for (int r = 0; r < 3; ++r) columns[a][r] = values[3 * a + r];
            header.require_nonsingular(matrix->first, columns);
        }
    }

    std::int64_t header_size = 0;
    if (const auto skip = value_of({"HeaderSize"}))
        header_size = header.integer(skip->first, skip->second, -1, std::int64_t{1} << 50);
    auto is_true = [&](const char* name, bool fallback) {
        const auto v = value_of({name});
        if (!v) return fallback;
        const char c = v->second.front();
        return c == 'T' || c == 't' || c == '1';
    };
    const bool compressed = is_true("CompressedData", false);
    const bool binary = is_true("BinaryData", true);

    const std::string data_name = required("ElementDataFile");
    std::istringstream data_tokens(data_name);
    std::vector<std::string> tokens;
    for (std::string token; data_tokens >> token;) tokens.push_back(token);
    // LIST and printf patterns ("slice%03d.raw 1 40 1") name one file per slice.
    if (tokens.front().rfind("LIST", 0) == 0) {  // values are never empty (checked above)
        check_meta_list(path, file, in, header, tokens, counted, ndims, voxel_bytes,
                        binary && !compressed);
        return;
    }
    if (data_name.find('%') != std::string::npos) {
        check_meta_pattern(header, tokens, extents);
        check_meta_pattern_files(path, file, tokens, extents, voxel_bytes, binary && !compressed);
        return;
    }
    const bool local = data_name == "LOCAL" || data_name == "Local" || data_name == "local";
    const std::string data_file = local ? file : beside(file, data_name);
    if (!local) require_regular_file(path, data_file, "data file (ElementDataFile)");

    if (local && header_size > 0 && static_cast<std::uint64_t>(header_size) < header_end)
        header.fail("HeaderSize " + std::to_string(header_size) +
                    " points inside the header (it ends at byte " + std::to_string(header_end) +
                    "); MetaIO would read header text as voxels");
    const std::uint64_t bytes = data_bytes(counted, voxel_bytes);
    const std::uint64_t start =
        local && header_size <= 0
            ? header_end
            // MetaIO seeks to a positive HeaderSize in attached data too (HeaderSize = 100000
            // in a 14 KB .mha read nothing, and validate said valid; campaign seed 4).
            : static_cast<std::uint64_t>(std::max<std::int64_t>(header_size, 0));
    const std::string what = local ? "" : "data file '" + data_file + "' (ElementDataFile) ";
    const std::string announced = "(DimSize " + join(extents, " ") + " of " + type + ")";
    if (!binary) {
        // Text voxels: at least one digit and one separator each, but for the last.
        const std::uint64_t present =
            file_size_of(data_file) - std::min(start, file_size_of(data_file));
        check_data_size(path, what, present, 2 * data_bytes(counted, 1) - 1,
                        "of text that its MetaImage header announces at least " + announced);
        check_meta_text_values(path, what, data_file, start, counted, type);
        return;
    }
    if (compressed) {
        // MetaIO reads compressed data after the header as garbage, silently, when it is not
        // told its size (a 16^3 cube became 88 labels); its own writer always writes it.
        if (local && !value_of({"CompressedDataSize"}))
            header.fail(
                "CompressedDataSize is missing; compressed data in the file itself needs "
                "it (MetaIO reads it as garbage without)");
        std::uint64_t compressed_size = std::numeric_limits<std::uint64_t>::max();
        if (const auto size = value_of({"CompressedDataSize"}))
            compressed_size = static_cast<std::uint64_t>(
                header.integer(size->first, size->second, 1, std::int64_t{1} << 50));
        if (compressed_size != std::numeric_limits<std::uint64_t>::max())
            check_data_size(path, what,
                            file_size_of(data_file) - std::min(start, file_size_of(data_file)),
                            compressed_size, "of compressed data its CompressedDataSize announces");
        // MetaIO allocates the whole image before it inflates: inflate once here to count,
        // from the CompressedDataSize bytes MetaIO reads (fewer than the stream's: the voxels
        // past them were garbage labels; found by the malformed-input campaign, issue 21).
        check_data_size(
            path, what, inflated_bytes(data_file, start, bytes, compressed_size), bytes,
            "that its MetaImage header announces once decompressed " + announced +
                (compressed_size != std::numeric_limits<std::uint64_t>::max()
                     ? " from its CompressedDataSize " + std::to_string(compressed_size) + " bytes"
                     : std::string()));
        return;
    }
    check_data_size(
        path, what, file_size_of(data_file), start + bytes,
        "its MetaImage header announces (DimSize " + join(extents, " ") + " of " + type +
            (start > 0 ? " after " + std::to_string(start) + " header bytes" : "") + ")");
}

// ---------------------------------------------------------------------------------------
// NRRD (.nrrd, .nhdr): "NRRD000N", then "field: value" lines (field names case-insensitive,
// spaces optional), "key:=value" pairs and "#" comments, up to an empty line and the data.

/// Bytes per voxel of a NRRD type name (lower case, single spaces); 0 when unknown.
std::uint64_t nrrd_type_bytes(const std::string& type) {
    static const std::map<std::string, std::uint64_t> sizes = {{"signed char", 1},
                                                               {"int8", 1},
                                                               {"int8_t", 1},
                                                               {"uchar", 1},
                                                               {"unsigned char", 1},
                                                               {"uint8", 1},
                                                               {"uint8_t", 1},
                                                               {"short", 2},
                                                               {"short int", 2},
                                                               {"signed short", 2},
                                                               {"signed short int", 2},
                                                               {"int16", 2},
                                                               {"int16_t", 2},
                                                               {"ushort", 2},
                                                               {"unsigned short", 2},
                                                               {"unsigned short int", 2},
                                                               {"uint16", 2},
                                                               {"uint16_t", 2},
                                                               {"int", 4},
                                                               {"signed int", 4},
                                                               {"int32", 4},
                                                               {"int32_t", 4},
                                                               {"uint", 4},
                                                               {"unsigned int", 4},
                                                               {"uint32", 4},
                                                               {"uint32_t", 4},
                                                               {"longlong", 8},
                                                               {"long long", 8},
                                                               {"long long int", 8},
                                                               {"signed long long", 8},
                                                               {"signed long long int", 8},
                                                               {"int64", 8},
                                                               {"int64_t", 8},
                                                               {"ulonglong", 8},
                                                               {"unsigned long long", 8},
                                                               {"unsigned long long int", 8},
                                                               {"uint64", 8},
                                                               {"uint64_t", 8},
                                                               {"float", 4},
                                                               {"double", 8}};
    const auto it = sizes.find(type);
    return it == sizes.end() ? 0 : it->second;
}

/// The vectors of a "space directions" value: "(1,0,0) (0,1,0) none"; nullopt for "none".
std::vector<std::optional<std::vector<double>>> nrrd_vectors(const std::string& key,
                                                             const std::string& value,
                                                             const TextHeader& header) {
    std::vector<std::optional<std::vector<double>>> vectors;
    std::size_t i = 0;
    while (true) {
        i = value.find_first_not_of(" \t", i);
        if (i == std::string::npos) break;
        if (value.compare(i, 4, "none") == 0) {
            vectors.emplace_back(std::nullopt);
            i += 4;
            continue;
        }
        const auto close = value.find(')', i);
        if (value[i] != '(' || close == std::string::npos)
            header.fail(key + " '" + value + "' is not a list of (x,y,z) vectors");
        std::string inner = value.substr(i + 1, close - i - 1);
        std::replace(inner.begin(), inner.end(), ',', ' ');
        const auto numbers = parse_numbers(inner);
        if (!numbers || numbers->empty())
            header.fail(key + " '" + value + "' is not a list of (x,y,z) vectors");
        vectors.emplace_back(*numbers);
        i = close + 1;
    }
    return vectors;
}

void check_nrrd(const std::string& path, const std::string& file, const HeaderLimits& limits) {
    const TextHeader header(path, file, "NRRD");
    std::ifstream in(file, std::ios::binary);
    if (!in) header.fail("the file cannot be opened");
    std::string magic;
    std::getline(in, magic);
    if (magic.rfind("NRRD000", 0) != 0) header.fail("the first line is not 'NRRD000N'");
    std::uint64_t header_end = 0;
    const auto lines = header_lines(
        in, true, [](const std::string&) { return false; }, header_end, header);
    header_end += magic.size() + 1;

    std::map<std::string, std::pair<std::string, std::string>>
        fields;  // normalized -> (name, value)
    for (const std::string& line : lines) {
        if (line.empty() || line.front() == '#') continue;
        const auto colon = line.find(": ");
        if (colon == std::string::npos || line.find(":=") < colon) continue;
        std::string name = lowercase(line.substr(0, colon));
        std::string normal;
        for (char c : name)
            if (c != ' ') normal.push_back(c);
        fields[normal] = {name, trimmed(line.substr(colon + 2))};
    }
    auto value_of = [&](const char* normal) -> const std::pair<std::string, std::string>* {
        const auto it = fields.find(normal);
        return it == fields.end() ? nullptr : &it->second;
    };
    auto required = [&](const char* normal) {
        const auto* f = value_of(normal);
        if (!f) header.fail(std::string("'") + normal + "' is missing");
        return *f;
    };

    const auto [dimension_name, dimension_value] = required("dimension");
    const auto dimension =
        static_cast<std::size_t>(header.integer(dimension_name, dimension_value, 1, 16));
    const auto [sizes_name, sizes_value] = required("sizes");
    const std::vector<std::uint64_t> extents = header.extents(sizes_name, sizes_value, dimension);
    const auto [type_name, type_value] = required("type");
    std::string type;
    {
        std::istringstream words(lowercase(type_value));
        for (std::string word; words >> word;) type += (type.empty() ? "" : " ") + word;
    }
    const std::uint64_t voxel_bytes = nrrd_type_bytes(type);
    if (voxel_bytes == 0)
        header.fail("type '" + type_value + "' is not a NRRD voxel type frontmesh reads");
    check_image_memory(path, "NRRD header: sizes", extents, voxel_bytes, limits.max_image_gib);

    // A NaN spacing means "unknown" in NRRD, which ITK turns into 1 mm: refused like any other
    // spacing outside the range, for the three axes of a scalar volume.
    if (const auto* spacings = value_of("spacings")) {
        const auto values = header.numbers(spacings->first, spacings->second, dimension);
        if (limits.check_spacing && dimension == 3)
            for (std::size_t d = 0; d < 3; ++d)
                check_spacing(path, "NRRD header: spacings value " + std::to_string(d + 1),
                              values[d]);
    }
    if (const auto* directions = value_of("spacedirections")) {
        const auto vectors = nrrd_vectors(directions->first, directions->second, header);
        if (vectors.size() != dimension)
            header.fail(directions->first + " has " + std::to_string(vectors.size()) +
                        " entries; expected " + std::to_string(dimension));
        std::vector<std::array<double, 3>> spatial;
        for (const auto& v : vectors) {
            if (!v) continue;
            header.require_finite(directions->first, *v);
            if (v->size() == 3) spatial.push_back({(*v)[0], (*v)[1], (*v)[2]});
        }
        if (spatial.size() == 3) {
            for (std::size_t d = 0; d < 3 && limits.check_spacing; ++d)
                check_spacing(
                    path,
                    "NRRD header: " + directions->first + " vector " + std::to_string(d + 1) +
                        " (its length)",
                    std::sqrt(spatial[d][0] * spatial[d][0] + spatial[d][1] * spatial[d][1] +
                              spatial[d][2] * spatial[d][2]));
            header.require_nonsingular(directions->first, {spatial[0], spatial[1], spatial[2]});
        }
    }
    if (const auto* origin = value_of("spaceorigin")) {
        const auto vectors = nrrd_vectors(origin->first, origin->second, header);
        if (vectors.size() != 1 || !vectors.front())
            header.fail(origin->first + " '" + origin->second + "' is not one (x,y,z) vector");
        header.require_finite(origin->first, *vectors.front());
        for (std::size_t d = 0; d < vectors.front()->size(); ++d)
            check_origin(path, "NRRD header: " + origin->first + " value " + std::to_string(d + 1),
                         (*vectors.front())[d]);
    }

    std::int64_t byte_skip = 0;
    if (const auto* skip = value_of("byteskip"))
        byte_skip = header.integer(skip->first, skip->second, -1, std::int64_t{1} << 50);
    std::string encoding = "raw";
    if (const auto* e = value_of("encoding")) encoding = lowercase(e->second);

    std::string data_file = file;
    if (const auto* data = value_of("datafile")) {
        std::istringstream words(data->second);
        std::vector<std::string> tokens;
        for (std::string token; words >> token;) tokens.push_back(token);
        // LIST and printf patterns ("slice%03d.raw 1 40 1") name one file per slice.
        if (tokens.empty() || tokens.front() == "LIST" || tokens.size() >= 4) return;
        data_file = beside(file, data->second);
        require_regular_file(path, data_file, "data file");
    }
    const bool attached = data_file == file;
    const std::string what = attached ? "" : "data file '" + data_file + "' ";
    const std::string announced = "(sizes " + join(extents, " ") + " of " + type + ")";
    const std::uint64_t skip = static_cast<std::uint64_t>(std::max<std::int64_t>(byte_skip, 0));
    const std::uint64_t bytes = data_bytes(extents, voxel_bytes);
    const std::uint64_t header_bytes = attached ? std::min(header_end, file_size_of(file)) : 0;
    if (encoding == "raw") {
        check_data_size(path, what, file_size_of(data_file), header_bytes + skip + bytes,
                        "its NRRD header announces " + announced);
    } else if (encoding == "gzip" || encoding == "gz") {
        // teem allocates the whole image before it inflates: inflate once here to count
        // (a byte skip applies to the decompressed data).
        check_data_size(path, what, inflated_bytes(data_file, header_bytes, skip + bytes),
                        skip + bytes,
                        "that its NRRD header announces once decompressed " + announced);
    } else if (encoding == "ascii" || encoding == "text" || encoding == "txt") {
        // At least one digit and one separator per voxel, but for the last.
        check_data_size(path, what, file_size_of(data_file) - header_bytes,
                        2 * data_bytes(extents, 1) - 1,
                        "of text that its NRRD header announces at least " + announced);
    } else if (encoding == "hex") {
        check_data_size(path, what, file_size_of(data_file) - header_bytes, 2 * bytes,
                        "of hex digits that its NRRD header announces at least " + announced);
    }
}

}  // namespace

std::string image_prefix(const std::string& path) { return "input.image: '" + path + "' "; }

void require_regular_file(const std::string& path, const std::string& file,
                          const std::string& role) {
    std::error_code ec;
    const fs::file_status status = fs::status(file, ec);
    const std::string which = file == path ? std::string() : role + " '" + file + "' ";
    if (!fs::exists(status)) FM_THROW(InputError, image_prefix(path) + which + "does not exist");
    if (!fs::is_regular_file(status))
        FM_THROW(InputError,
                 image_prefix(path) + which + "is " + kind_of(status) + ", not a regular file");
}

void check_image_memory(const std::string& path, const std::string& field,
                        const std::vector<std::uint64_t>& extents, std::uint64_t voxel_bytes,
                        double max_image_gib) {
    double voxels = 1.0;
    for (std::uint64_t e : extents) voxels *= static_cast<double>(e);
    const double per_voxel = static_cast<double>(voxel_bytes + label_bytes);
    const double gib = voxels * per_voxel / static_cast<double>(std::uint64_t{1} << 30);
    if (!(gib <= max_image_gib)) {
        std::ostringstream size;
        size.precision(3);
        size << gib;
        FM_THROW(InputError,
                 image_prefix(path) + field + " " + join(extents, " x ") + " is " +
                     number_text(voxels) + " voxels, about " + size.str() + " GiB to read (" +
                     std::to_string(voxel_bytes) + (voxel_bytes == 1 ? " byte" : " bytes") +
                     " per voxel in the file and " + std::to_string(label_bytes) +
                     " per label), more than input.max_image_gib = " + number_text(max_image_gib) +
                     " (raise it to read this image)");
    }
}

void check_origin(const std::string& path, const std::string& field, double origin_mm) {
    if (!(std::abs(origin_mm) <= max_origin_mm))
        FM_THROW(InputError, image_prefix(path) + field + " is " + number_text(origin_mm) +
                                 (std::isfinite(origin_mm) ? " mm" : "") +
                                 "; an origin coordinate must be finite and within +-" +
                                 number_text(max_origin_mm) + " mm");
}

std::string non_finite_voxels_message(const std::string& path, const std::string& value,
                                      std::uint64_t i, std::uint64_t j, std::uint64_t k,
                                      std::uint64_t count) {
    return image_prefix(path) + "voxel (" + std::to_string(i) + ", " + std::to_string(j) + ", " +
           std::to_string(k) + ") is " + value + " (" + std::to_string(count) +
           " NaN or inf voxel" + (count > 1 ? "s" : "") + " in all)" +
           "; every voxel of a float image must be a finite number, with or without "
           "input.threshold";
}

void check_spacing(const std::string& path, const std::string& field, double spacing_mm) {
    if (!(spacing_mm >= min_spacing_mm && spacing_mm <= max_spacing_mm))
        FM_THROW(InputError, image_prefix(path) + field + " is " + number_text(spacing_mm) +
                                 (std::isfinite(spacing_mm) ? " mm" : "") +
                                 "; a voxel spacing must be finite and within [" +
                                 number_text(min_spacing_mm) + ", " + number_text(max_spacing_mm) +
                                 "] mm (input.spacing replaces a wrong one)");
}

void check_image_header(const std::string& path, const std::string& file,
                        const HeaderLimits& limits) {
    const std::string name = lowercase(file);
    if (nifti_files(file)) {
        check_nifti(path, file, limits);
    } else if (name.ends_with(".mha") || name.ends_with(".mhd")) {
        check_metaimage(path, file, limits);
    } else if (name.ends_with(".nrrd") || name.ends_with(".nhdr")) {
        check_nrrd(path, file, limits);
    }
}

}  // namespace frontmesh::io
