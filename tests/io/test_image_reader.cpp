#include "io/image_reader.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <catch2/catch.hpp>
// System Eigen modules before ITK, whose bundled Eigen 3.3 clashes with Eigen 3.4 (see
// io/image_reader.cpp).
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <itkGDCMImageIO.h>
#include <itkImage.h>
#include <itkImageFileWriter.h>
#include <itkImageSeriesWriter.h>
#include <itkMetaDataObject.h>
#include <itkPNGImageIO.h>
#include <itkRGBPixel.h>
#include <itkTIFFImageIO.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>
#include <zlib.h>

#include "pipeline/core/error.h"
#include "tests/fixtures/phantoms.h"

namespace fs = std::filesystem;
using frontmesh::core::Frame;
using frontmesh::core::InputError;
using frontmesh::core::Label;
using frontmesh::core::LabelImage;
using frontmesh::io::check_label_image;
using frontmesh::io::ImageReadOptions;
using frontmesh::io::read_label_image;

namespace {

/// Geometry of a written test image.
struct Grid {
    std::array<int, 3> size{7, 6, 5};
    Eigen::Vector3d spacing{0.7, 1.3, 2.1};
    Eigen::Vector3d origin{-10.5, 20.25, 5.0};
    Eigen::Matrix3d direction = Eigen::Matrix3d::Identity();
};

/// A proper rotation (det +1) that mixes all three axes.
Eigen::Matrix3d oblique_rotation() {
    return Eigen::AngleAxisd(0.5, Eigen::Vector3d(1.0, 2.0, 3.0).normalized()).toRotationMatrix();
}

Grid rotated_grid() {
    Grid grid;
    grid.direction = oblique_rotation();
    return grid;
}

/// Labels of the test images: a box of 3, one marker voxel of 7 near a corner (so a flipped
/// or permuted axis shows), the rest 0.
Label test_label(int i, int j, int k) {
    if (i == 5 && j == 1 && k == 3) return 7;
    if (i >= 2 && i <= 4 && j >= 1 && j <= 3 && k >= 1 && k <= 2) return 3;
    return 0;
}

using LabelFunction = std::function<double(int, int, int)>;

template <class T>
typename itk::Image<T, 3>::Pointer make_image(const Grid& grid, const LabelFunction& value) {
    using ImageType = itk::Image<T, 3>;
    auto image = ImageType::New();
    typename ImageType::SizeType size;
    typename ImageType::SpacingType spacing;
    typename ImageType::PointType origin;
    typename ImageType::DirectionType direction;
    for (unsigned r = 0; r < 3; ++r) {
        size[r] = static_cast<itk::SizeValueType>(grid.size[r]);
        spacing[r] = grid.spacing[r];
        origin[r] = grid.origin[r];
        for (unsigned c = 0; c < 3; ++c) direction(r, c) = grid.direction(r, c);
    }
    image->SetRegions(typename ImageType::RegionType(size));
    image->SetSpacing(spacing);
    image->SetOrigin(origin);
    image->SetDirection(direction);
    image->Allocate();
    for (int k = 0; k < grid.size[2]; ++k)
        for (int j = 0; j < grid.size[1]; ++j)
            for (int i = 0; i < grid.size[0]; ++i)
                image->SetPixel({{i, j, k}}, static_cast<T>(value(i, j, k)));
    return image;
}

template <class ImageType>
void write_image(const ImageType* image, const std::string& path) {
    auto writer = itk::ImageFileWriter<ImageType>::New();
    writer->SetInput(image);
    writer->SetFileName(path);
    writer->Update();
}

/// Physical point (LPS) of voxel (i, j, k) as ITK computes it for the written image.
template <class ImageType>
Eigen::Vector3d itk_point(const ImageType* image, int i, int j, int k) {
    typename ImageType::PointType point;
    image->TransformIndexToPhysicalPoint({{i, j, k}}, point);
    return {point[0], point[1], point[2]};
}

/// Writes `image` as a DICOM series (one file per z slice, names prefix_NNN.dcm) with
/// per-slice position, orientation and instance number, like a CT scanner does.
template <class T>
void write_dicom_series(const itk::Image<T, 3>* image, const std::string& dir,
                        const std::string& prefix) {
    using Volume = itk::Image<T, 3>;
    using Slice = itk::Image<T, 2>;
    auto io = itk::GDCMImageIO::New();
    const auto& d = image->GetDirection();
    std::ostringstream orientation;
    orientation.precision(10);
    orientation << d(0, 0) << '\\' << d(1, 0) << '\\' << d(2, 0) << '\\' << d(0, 1) << '\\'
                << d(1, 1) << '\\' << d(2, 1);

    const auto size = image->GetLargestPossibleRegion().GetSize();
    std::vector<itk::MetaDataDictionary> dictionaries(size[2]);
    std::vector<itk::MetaDataDictionary*> dictionary_array;
    std::vector<std::string> names;
    for (unsigned k = 0; k < size[2]; ++k) {
        itk::MetaDataDictionary& dict = dictionaries[k];
        typename Volume::PointType position;
        image->TransformIndexToPhysicalPoint({{0, 0, static_cast<itk::IndexValueType>(k)}},
                                             position);
        std::ostringstream ipp;
        ipp.precision(10);
        ipp << position[0] << '\\' << position[1] << '\\' << position[2];
        itk::EncapsulateMetaData<std::string>(dict, "0008|0060", "CT");
        itk::EncapsulateMetaData<std::string>(dict, "0028|0004", "MONOCHROME2");
        itk::EncapsulateMetaData<std::string>(dict, "0008|0016", "1.2.840.10008.5.1.4.1.1.2");
        itk::EncapsulateMetaData<std::string>(dict, "0020|0032", ipp.str());
        itk::EncapsulateMetaData<std::string>(dict, "0020|0037", orientation.str());
        itk::EncapsulateMetaData<std::string>(dict, "0020|0013", std::to_string(k + 1));
        itk::EncapsulateMetaData<std::string>(dict, "0018|0050",
                                              std::to_string(image->GetSpacing()[2]));
        dictionary_array.push_back(&dict);
        char name[64];
        std::snprintf(name, sizeof name, "%s_%03u.dcm", prefix.c_str(), k);
        names.push_back((fs::path(dir) / name).string());
    }
    auto writer = itk::ImageSeriesWriter<Volume, Slice>::New();
    writer->SetInput(image);
    writer->SetImageIO(io);
    writer->SetFileNames(names);
    writer->SetMetaDataDictionaryArray(&dictionary_array);
    writer->Update();
}

/// Writes the z slices of `image` as 2-D files at `names` (one per slice), PNG by default.
void write_slices(const itk::Image<unsigned char, 3>* image, const std::vector<std::string>& names,
                  itk::ImageIOBase::Pointer io = itk::PNGImageIO::New()) {
    using Volume = itk::Image<unsigned char, 3>;
    using Slice = itk::Image<unsigned char, 2>;
    auto writer = itk::ImageSeriesWriter<Volume, Slice>::New();
    writer->SetInput(image);
    writer->SetImageIO(io);
    writer->SetFileNames(names);
    writer->Update();
}

/// Checks dims, geometry and every label of `read` against a grid written with labels
/// `expected`, padded by `pad`. `tolerance` (mm) covers formats storing geometry as float.
void check_image(const LabelImage& read, const Grid& grid, int pad,
                 const std::function<Label(int, int, int)>& expected, double tolerance) {
    for (int a = 0; a < 3; ++a) CHECK(read.dims[a] == grid.size[a] + 2 * pad);
    CHECK(read.spacing.isApprox(grid.spacing, 1e-6));
    CHECK((read.direction - grid.direction).cwiseAbs().maxCoeff() < 1e-5);
    const Eigen::Vector3d padded_origin =
        grid.origin - grid.direction * (grid.spacing * static_cast<double>(pad));
    CHECK((read.origin - padded_origin).norm() < tolerance);
    CHECK(read.labels.size() == read.voxel_count());

    long mismatches = 0;
    for (int k = 0; k < read.dims[2]; ++k)
        for (int j = 0; j < read.dims[1]; ++j)
            for (int i = 0; i < read.dims[0]; ++i) {
                const int fi = i - pad, fj = j - pad, fk = k - pad;
                const bool inside = fi >= 0 && fj >= 0 && fk >= 0 && fi < grid.size[0] &&
                                    fj < grid.size[1] && fk < grid.size[2];
                const Label want = inside ? expected(fi, fj, fk) : 0;
                if (read.at(i, j, k) != want) ++mismatches;
            }
    CHECK(mismatches == 0);
}

/// Physical position of the marker voxel (5, 1, 3) of the file in the padded read image.
Eigen::Vector3d marker_position(const LabelImage& read, int pad) {
    REQUIRE(read.at(5 + pad, 1 + pad, 3 + pad) == 7);
    return read.physical(Eigen::Vector3d(5 + pad, 1 + pad, 3 + pad));
}

/// The user-facing message of the InputError `read` throws ("" when it throws none).
std::string input_error_of(const std::function<void()>& read) {
    try {
        read();
    } catch (const InputError& e) {
        return e.what();
    }
    return "";
}

/// Checks that reading `path` throws an InputError whose one-line message names `file` and
/// each of `words` (the header field, data file or voxel).
void check_refused(const std::string& path, const ImageReadOptions& options,
                   const std::string& file, const std::vector<std::string>& words) {
    const std::string message = input_error_of([&] { read_label_image(path, options); });
    INFO(message);
    CHECK(message.find("'" + file + "'") != std::string::npos);
    for (const std::string& word : words) CHECK(message.find(word) != std::string::npos);
    CHECK(message.find('\n') == std::string::npos);
    // `frontmesh validate` reports the same line without reading voxels.
    CHECK(input_error_of([&] { check_label_image(path, options); }) == message);
}

std::string read_bytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream bytes;
    bytes << in.rdbuf();
    return bytes.str();
}

void write_bytes(const std::string& path, const std::string& bytes) {
    std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

/// The decompressed bytes of a gzip file (or of a plain one, which zlib passes through).
std::string read_gz(const std::string& path) {
    gzFile in = gzopen(path.c_str(), "rb");
    REQUIRE(in != nullptr);
    std::string bytes;
    char chunk[1 << 14];
    for (int got; (got = gzread(in, chunk, sizeof chunk)) > 0;) bytes.append(chunk, got);
    gzclose(in);
    return bytes;
}

void write_gz(const std::string& path, const std::string& bytes) {
    gzFile out = gzopen(path.c_str(), "wb");
    REQUIRE(out != nullptr);
    REQUIRE(gzwrite(out, bytes.data(), static_cast<unsigned>(bytes.size())) ==
            static_cast<int>(bytes.size()));
    gzclose(out);
}

/// `value` written at byte `offset` of `bytes` (host byte order, as ITK writes on x86).
template <class T>
std::string poked(std::string bytes, std::size_t offset, T value) {
    REQUIRE(offset + sizeof(T) <= bytes.size());
    std::memcpy(bytes.data() + offset, &value, sizeof(T));
    return bytes;
}

template <class T>
T peeked(const std::string& bytes, std::size_t offset) {
    T value;
    std::memcpy(&value, bytes.data() + offset, sizeof(T));
    return value;
}

/// `header` with the line that starts with `key` replaced by `line`.
std::string with_line(const std::string& header, const std::string& key, const std::string& line) {
    const auto at = header.find("\n" + key);
    REQUIRE(at != std::string::npos);
    const auto end = header.find('\n', at + 1);
    return header.substr(0, at + 1) + line + header.substr(end);
}

const LabelFunction as_value = [](int i, int j, int k) { return double(test_label(i, j, k)); };

}  // namespace

TEST_CASE("NIfTI .nii.gz keeps spacing, origin, rotation and labels", "[io]") {
    const std::string dir = frontmesh::fixtures::temp_dir("io_nifti");
    const std::string path = dir + "/labels.nii.gz";
    const Grid grid = rotated_grid();
    const auto image = make_image<short>(grid, as_value);
    write_image(image.GetPointer(), path);

    const LabelImage read = read_label_image(path, ImageReadOptions{});
    CHECK(read.source == path);
    CHECK(read.frame == Frame::Lps);
    check_image(read, grid, 1, test_label, 1e-4);
    CHECK((marker_position(read, 1) - itk_point(image.GetPointer(), 5, 1, 3)).norm() < 1e-4);
}

TEST_CASE("MetaImage .mha keeps geometry and labels, padding is configurable", "[io]") {
    const std::string dir = frontmesh::fixtures::temp_dir("io_mha");
    const std::string path = dir + "/labels.mha";
    const Grid grid = rotated_grid();
    const auto image = make_image<unsigned char>(grid, as_value);
    write_image(image.GetPointer(), path);

    for (int pad : {0, 1, 3}) {
        ImageReadOptions options;
        options.pad = pad;
        const LabelImage read = read_label_image(path, options);
        check_image(read, grid, pad, test_label, 1e-6);
        CHECK((marker_position(read, pad) - itk_point(image.GetPointer(), 5, 1, 3)).norm() < 1e-6);
    }

    // options.spacing overrides the file's spacing; the padding shift follows it.
    ImageReadOptions override;
    override.spacing = Eigen::Vector3d(0.25, 0.5, 4.0);
    Grid respaced = grid;
    respaced.spacing = *override.spacing;
    check_image(read_label_image(path, override), respaced, 1, test_label, 1e-6);

    ImageReadOptions negative;
    negative.pad = -1;
    CHECK_THROWS_AS(read_label_image(path, negative), InputError);
}

TEST_CASE("NRRD keeps geometry and int32 labels", "[io]") {
    const std::string dir = frontmesh::fixtures::temp_dir("io_nrrd");
    const std::string path = dir + "/labels.nrrd";
    const Grid grid = rotated_grid();
    // Large and negative labels survive as they are.
    const auto big = [](int i, int j, int k) -> Label {
        const Label base = test_label(i, j, k);
        if (base == 3) return 2000000000;
        if (base == 7) return -5;
        return base;
    };
    const auto image = make_image<int>(grid, [&](int i, int j, int k) { return big(i, j, k); });
    write_image(image.GetPointer(), path);

    const LabelImage read = read_label_image(path, ImageReadOptions{});
    check_image(read, grid, 1, big, 1e-6);
    CHECK(read.at(1 + 5, 1 + 1, 1 + 3) == -5);
}

TEST_CASE("DICOM series folder keeps geometry and takes the largest series", "[io]") {
    const std::string dir = frontmesh::fixtures::temp_dir("io_dicom");
    const Grid grid = rotated_grid();
    const auto image = make_image<short>(grid, as_value);
    write_dicom_series(image.GetPointer(), dir, "main");

    // A second, smaller series in the same folder (other uids, other labels) must be ignored.
    Grid small = grid;
    small.size = {7, 6, 2};
    const auto other = make_image<short>(small, [](int, int, int) { return 9.0; });
    write_dicom_series(other.GetPointer(), dir, "other");

    const LabelImage read = read_label_image(dir, ImageReadOptions{});
    CHECK(read.source == dir);
    check_image(read, grid, 1, test_label, 1e-4);
    CHECK((marker_position(read, 1) - itk_point(image.GetPointer(), 5, 1, 3)).norm() < 1e-4);
}

TEST_CASE("PNG slice stack folder is stacked along z in name order", "[io]") {
    const std::string dir = frontmesh::fixtures::temp_dir("io_png_folder");
    Grid grid;  // PNG carries neither origin nor direction: identity at 0.
    grid.origin.setZero();
    const auto image = make_image<unsigned char>(grid, as_value);
    std::vector<std::string> names;
    for (int k = 0; k < grid.size[2]; ++k)
        names.push_back(dir + "/slice_" + std::to_string(100 + k) + ".png");
    write_slices(image.GetPointer(), names);

    CHECK_THROWS_AS(read_label_image(dir, ImageReadOptions{}), InputError);
    CHECK(input_error_of([&] {
              read_label_image(dir, ImageReadOptions{});
          }).find("input.spacing") != std::string::npos);

    ImageReadOptions options;
    options.spacing = grid.spacing;
    const LabelImage read = read_label_image(dir, options);
    CHECK(read.source == dir);
    check_image(read, grid, 1, test_label, 1e-9);
    CHECK((marker_position(read, 1) - itk_point(image.GetPointer(), 5, 1, 3)).norm() < 1e-9);
}

TEST_CASE("TIFF: one multi-page file, or a folder of slices", "[io]") {
    const std::string dir = frontmesh::fixtures::temp_dir("io_tiff");
    Grid grid;
    grid.origin.setZero();
    const auto image = make_image<unsigned char>(grid, as_value);
    ImageReadOptions options;
    options.spacing = grid.spacing;

    const std::string volume = dir + "/volume.tif";
    write_image(image.GetPointer(), volume);
    check_image(read_label_image(volume, options), grid, 1, test_label, 1e-9);

    const std::string slices = dir + "/slices";
    fs::create_directory(slices);
    std::vector<std::string> names;
    for (int k = 0; k < grid.size[2]; ++k)
        names.push_back(slices + "/s" + std::to_string(k) + ".tiff");
    write_slices(image.GetPointer(), names, itk::TIFFImageIO::New());
    check_image(read_label_image(slices, options), grid, 1, test_label, 1e-9);
}

TEST_CASE("printf pattern reads slices from the lowest number upward", "[io]") {
    const std::string dir = frontmesh::fixtures::temp_dir("io_png_pattern");
    Grid grid;
    grid.origin.setZero();
    const auto image = make_image<unsigned char>(grid, as_value);
    std::vector<std::string> names;
    // Numbers 8..12 with %03d: name order and number order agree only by zero padding.
    for (int k = 0; k < grid.size[2]; ++k) {
        char name[32];
        std::snprintf(name, sizeof name, "img_%03d.png", 8 + k);
        names.push_back(dir + "/" + name);
    }
    write_slices(image.GetPointer(), names);
    std::ofstream(dir + "/notes.txt") << "not a slice\n";

    ImageReadOptions options;
    options.spacing = grid.spacing;
    const std::string pattern = dir + "/img_%03d.png";
    const LabelImage read = read_label_image(pattern, options);
    CHECK(read.source == pattern);
    check_image(read, grid, 1, test_label, 1e-9);

    // A gap in the numbering is an error naming the missing slice.
    fs::remove(dir + "/img_010.png");
    const std::string message = input_error_of([&] { read_label_image(pattern, options); });
    CHECK(message.find("img_010.png") != std::string::npos);

    CHECK_THROWS_AS(read_label_image(dir + "/none_%03d.png", options), InputError);
}

TEST_CASE("RAS frame negates x and y of every physical point", "[io]") {
    const std::string dir = frontmesh::fixtures::temp_dir("io_ras");
    const std::string path = dir + "/labels.mha";
    const auto image = make_image<unsigned char>(rotated_grid(), as_value);
    write_image(image.GetPointer(), path);

    const LabelImage lps = read_label_image(path, ImageReadOptions{});
    ImageReadOptions ras_options;
    ras_options.frame = Frame::Ras;
    const LabelImage ras = read_label_image(path, ras_options);
    CHECK(ras.frame == Frame::Ras);
    CHECK(ras.labels == lps.labels);
    const Eigen::Vector3d flip(-1.0, -1.0, 1.0);
    for (const Eigen::Vector3d& index :
         {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(6, 1, 4), Eigen::Vector3d(2.5, 7.0, 3.25)}) {
        const Eigen::Vector3d expected = lps.physical(index).cwiseProduct(flip);
        CHECK((ras.physical(index) - expected).norm() < 1e-9);
    }
    CHECK((marker_position(ras, 1) - itk_point(image.GetPointer(), 5, 1, 3).cwiseProduct(flip))
              .norm() < 1e-6);
}

TEST_CASE("float images: integral values are labels, threshold segments grayscale", "[io]") {
    const std::string dir = frontmesh::fixtures::temp_dir("io_float");
    const Grid grid = rotated_grid();
    const auto gray = [](int i, int j, int k) { return 10.25 * i + 3.5 * j - 2.0 * k; };
    const std::string gray_path = dir + "/gray.nrrd";
    const auto gray_image = make_image<float>(grid, gray);
    write_image(gray_image.GetPointer(), gray_path);

    ImageReadOptions options;
    options.threshold = 30.0;
    const LabelImage read = read_label_image(gray_path, options);
    check_image(
        read, grid, 1, [&](int i, int j, int k) { return gray(i, j, k) > 30.0 ? 1 : 0; }, 1e-6);

    const std::string message =
        input_error_of([&] { read_label_image(gray_path, ImageReadOptions{}); });
    CHECK(message.find(gray_path) != std::string::npos);
    CHECK(message.find("input.threshold") != std::string::npos);

    const std::string integral_path = dir + "/integral.mha";
    const auto integral = make_image<double>(grid, [](int i, int j, int k) {
        return test_label(i, j, k) == 7 ? -4.0 : double(test_label(i, j, k));
    });
    write_image(integral.GetPointer(), integral_path);
    const LabelImage labels = read_label_image(integral_path, ImageReadOptions{});
    check_image(
        labels, grid, 1,
        [](int i, int j, int k) { return test_label(i, j, k) == 7 ? -4 : test_label(i, j, k); },
        1e-6);
}

TEST_CASE("64-bit labels outside int32 name the file and the voxel", "[io]") {
    const std::string dir = frontmesh::fixtures::temp_dir("io_int64");
    const Grid grid;
    const std::string ok_path = dir + "/ok.mha";
    const auto ok = make_image<long long>(grid, as_value);
    write_image(ok.GetPointer(), ok_path);
    check_image(read_label_image(ok_path, ImageReadOptions{}), grid, 1, test_label, 1e-9);

    const std::string bad_path = dir + "/bad.mha";
    const auto bad = make_image<long long>(grid, [](int i, int j, int k) {
        return (i == 2 && j == 4 && k == 1) ? 5e9 : double(test_label(i, j, k));
    });
    write_image(bad.GetPointer(), bad_path);
    const std::string message =
        input_error_of([&] { read_label_image(bad_path, ImageReadOptions{}); });
    CHECK(message.find(bad_path) != std::string::npos);
    CHECK(message.find("(2, 4, 1)") != std::string::npos);
}

TEST_CASE("voxels over 100 times longer one way than another are refused", "[io]") {
    // The malformed-input campaign (issue 21): 0.0001 x 1 x 1 mm made remesh fail with exit 1
    // (a sheet thinner than any surface size); 100:1 meshes.
    const std::string dir = frontmesh::fixtures::temp_dir("io_aspect");
    Grid grid;
    grid.spacing = {0.001, 1.0, 1.0};
    const std::string path = dir + "/sheet.mha";
    write_image(make_image<unsigned char>(grid, as_value).GetPointer(), path);
    check_refused(path, ImageReadOptions{}, path,
                  {"0.001 x 1 x 1 mm", "1000 times", "at most 100"});
    ImageReadOptions fixed;
    fixed.spacing = Eigen::Vector3d(0.01, 1.0, 1.0);  // 100:1 is read
    CHECK(read_label_image(path, fixed).spacing.x() == 0.01);
    fixed.spacing = Eigen::Vector3d(1.0, 1.0, 101.0);
    check_refused(path, fixed, path, {"(input.spacing)", "101 times"});
}

TEST_CASE("unreadable inputs throw InputError naming the path", "[io]") {
    const std::string dir = frontmesh::fixtures::temp_dir("io_errors");

    const std::string missing = dir + "/missing.nii.gz";
    const std::string message =
        input_error_of([&] { read_label_image(missing, ImageReadOptions{}); });
    CHECK(message.find("'" + missing + "'") != std::string::npos);
    CHECK(message.find("does not exist") != std::string::npos);
    CHECK(message.find('\n') == std::string::npos);

    SECTION("a 2-D image") {
        using Image2 = itk::Image<unsigned char, 2>;
        auto image = Image2::New();
        image->SetRegions(Image2::RegionType(Image2::SizeType{{8, 8}}));
        image->Allocate();
        image->FillBuffer(1);
        for (const std::string name : {"/flat.png", "/flat.nrrd"}) {
            write_image(image.GetPointer(), dir + name);
            const std::string flat =
                input_error_of([&] { read_label_image(dir + name, ImageReadOptions{}); });
            CHECK(flat.find(dir + name) != std::string::npos);
            CHECK(flat.find("2-D") != std::string::npos);
        }
        // Declared 3-D with one slice: a volume one voxel thick, read (it was refused as
        // 2-D while 1 x 1 x 4 was read; the malformed-input campaign, issue 21).
        Grid one_slice;
        one_slice.size = {4, 3, 1};
        for (const std::string name : {"/slab.nii", "/slab.mha"}) {
            write_image(make_image<unsigned char>(one_slice, as_value).GetPointer(), dir + name);
            const LabelImage slab = read_label_image(dir + name, ImageReadOptions{});
            CHECK(slab.dims == std::array<int, 3>{6, 5, 3});
        }
    }
    SECTION("a multi-component image") {
        using Rgb = itk::Image<itk::RGBPixel<unsigned char>, 3>;
        auto image = Rgb::New();
        image->SetRegions(Rgb::RegionType(Rgb::SizeType{{4, 4, 4}}));
        image->Allocate();
        write_image(image.GetPointer(), dir + "/rgb.mha");
        CHECK(input_error_of([&] {
                  read_label_image(dir + "/rgb.mha", ImageReadOptions{});
              }).find("components") != std::string::npos);
    }
    SECTION("a corrupt or truncated file") {
        const std::string garbage = dir + "/garbage.nii.gz";
        std::ofstream(garbage, std::ios::binary) << "this is not an image at all";
        const std::string garbage_message =
            input_error_of([&] { read_label_image(garbage, ImageReadOptions{}); });
        CHECK(garbage_message.find(garbage) != std::string::npos);
        CHECK(garbage_message.find('\n') == std::string::npos);

        // niftilib zero-fills missing voxels silently; the reader must notice.
        Grid big;
        big.size = {40, 40, 40};
        const auto image = make_image<short>(
            big, [](int i, int j, int k) { return double((i * 7 + j * 13 + k * 31) % 251); });
        for (const std::string name : {"/truncated.nii", "/truncated.nii.gz"}) {
            const std::string truncated = dir + name;
            write_image(image.GetPointer(), truncated);
            REQUIRE_NOTHROW(read_label_image(truncated, ImageReadOptions{}));
            fs::resize_file(truncated, fs::file_size(truncated) * 2 / 3);
            const std::string truncated_message =
                input_error_of([&] { read_label_image(truncated, ImageReadOptions{}); });
            CHECK(truncated_message.find(truncated) != std::string::npos);
            CHECK(truncated_message.find("truncated") != std::string::npos);
        }

        // NRRD reports the short read itself; its reason comes on one line.
        const std::string nrrd = dir + "/truncated.nrrd";
        write_image(image.GetPointer(), nrrd);
        fs::resize_file(nrrd, fs::file_size(nrrd) * 2 / 3);
        const std::string nrrd_message =
            input_error_of([&] { read_label_image(nrrd, ImageReadOptions{}); });
        CHECK(nrrd_message.find(nrrd) != std::string::npos);
        CHECK(nrrd_message.find('\n') == std::string::npos);
    }
    SECTION("a folder with no image") {
        std::ofstream(dir + "/readme.txt") << "nothing here\n";
        CHECK_THROWS_AS(read_label_image(dir, ImageReadOptions{}), InputError);
    }
}

TEST_CASE("NIfTI header values are checked before ITK reads them", "[io]") {
    // Each case: a valid image written by ITK, then one header field corrupted, in .nii and
    // in .nii.gz (the header read through zlib). ITK would turn a NaN, 0 or inf pixdim into
    // 1 mm, and abort() (VNL) on a non-finite sform or qform.
    const std::string dir = frontmesh::fixtures::temp_dir("io_nifti_header");
    const auto image = make_image<unsigned char>(rotated_grid(), as_value);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    struct Corruption {
        std::string name;
        std::function<std::string(const std::string&)> apply;
        std::vector<std::string> words;
    };
    const std::vector<Corruption> corruptions = {
        {"pixdim_nan",
         [&](const std::string& b) { return poked<float>(b, 80, nan); },
         {"pixdim[1]", "nan"}},
        {"pixdim_zero",
         [&](const std::string& b) { return poked<float>(b, 84, 0.0f); },
         {"pixdim[2]", "0 mm"}},
        {"pixdim_inf",
         [&](const std::string& b) { return poked<float>(b, 88, inf); },
         {"pixdim[3]", "inf"}},
        {"pixdim_huge",
         [&](const std::string& b) { return poked<float>(b, 80, 1e30f); },
         {"pixdim[1]", "1e+30 mm"}},
        {"pixdim_tiny",
         [&](const std::string& b) { return poked<float>(b, 80, 1e-30f); },
         {"pixdim[1]", "1e-30 mm"}},
        {"pixdim_negative",
         [&](const std::string& b) { return poked<float>(b, 84, -1.3f); },
         {"pixdim[2]", "-1.3 mm"}},
        {"vox_offset_huge",
         [&](const std::string& b) { return poked<float>(b, 108, 1e30f); },
         {"vox_offset", "1e+30"}},
        {"sform_offset_huge",
         [&](const std::string& b) { return poked<float>(b, 292, 1e9f); },
         {"srow_x[3]", "1e+09 mm", "1e+06 mm"}},
        {"qoffset_huge",
         [&](const std::string& b) { return poked<float>(b, 272, -1e9f); },
         {"qoffset_y", "-1e+09 mm"}},
        {"sform_nan",
         [&](const std::string& b) { return poked<float>(b, 280, nan); },
         {"srow_x[0]", "nan"}},
        {"sform_inf",
         [&](const std::string& b) { return poked<float>(b, 324, inf); },
         {"srow_z[3]", "inf"}},
        {"sform_singular",
         [&](const std::string& b) {
             std::string c = b;
             for (std::size_t at : {280u, 284u, 288u}) c = poked<float>(c, at, 0.0f);
             return c;
         },
         {"sform", "singular"}},
        {"qform_nan",
         [&](const std::string& b) { return poked<float>(b, 256, nan); },
         {"quatern_b", "nan"}},
        // niftilib reads any digit after "n+" as NIfTI (NIFTI_VERSION), so a "n+2" magic in a
        // 348-byte header still has its sform used; a NaN in it made ITK's SVD loop forever.
        {"magic_n+2_sform_nan",
         [&](const std::string& b) {
             std::string c = b;
             c[346] = '2';
             return poked<float>(c, 324, nan);
         },
         {"srow_z[3]", "nan"}},
        {"dim_zero",
         [&](const std::string& b) { return poked<std::int16_t>(b, 44, 0); },
         {"dim[2]", "at least 1"}},
        {"dim_negative",
         [&](const std::string& b) { return poked<std::int16_t>(b, 46, -4); },
         {"dim[3] is -4", "at least 1"}},
        {"dim_huge",
         [&](const std::string& b) {
             std::string c = b;
             for (std::size_t at : {42u, 44u, 46u}) c = poked<std::int16_t>(c, at, 1500);
             return c;
         },
         {"dim[1..3]", "1500 x 1500 x 1500", "15.7 GiB", "input.max_image_gib = 4"}},
        {"datatype",
         [&](const std::string& b) { return poked<std::int16_t>(b, 70, 3); },
         {"datatype 3"}},
    };
    for (const std::string extension : {".nii", ".nii.gz"}) {
        const std::string valid = dir + "/valid" + extension;
        write_image(image.GetPointer(), valid);
        const std::string bytes = read_gz(valid);
        REQUIRE(peeked<std::int32_t>(bytes, 0) == 348);
        REQUIRE(peeked<std::int16_t>(bytes, 252) > 0);  // ITK writes a qform and an sform
        REQUIRE(peeked<std::int16_t>(bytes, 254) > 0);
        REQUIRE_NOTHROW(read_label_image(valid, ImageReadOptions{}));
        for (const Corruption& corruption : corruptions) {
            DYNAMIC_SECTION(corruption.name << extension) {
                const std::string path = dir + "/" + corruption.name + extension;
                const std::string corrupt = corruption.apply(bytes);
                extension == ".nii" ? write_bytes(path, corrupt) : write_gz(path, corrupt);
                check_refused(path, ImageReadOptions{}, path, corruption.words);
            }
        }
    }

    SECTION("input.spacing replaces a broken pixdim; the sform is checked regardless") {
        const std::string valid = dir + "/valid.nii";
        write_image(image.GetPointer(), valid);
        const std::string path = dir + "/pixdim_zero_replaced.nii";
        write_bytes(path, poked<float>(read_bytes(valid), 80, 0.0f));
        ImageReadOptions options;
        options.spacing = Eigen::Vector3d(0.5, 0.5, 0.5);
        Grid respaced = rotated_grid();
        respaced.spacing = *options.spacing;
        check_image(read_label_image(path, options), respaced, 1, test_label, 1e-4);
        write_bytes(path, poked<float>(read_bytes(path), 300, nan));
        check_refused(path, options, path, {"srow_y[1]"});
        // The qform scales by pixdim[1..3] even then: a NaN there is refused.
        write_bytes(path, poked<float>(read_bytes(valid), 80, nan));
        check_refused(path, options, path, {"pixdim[1] (used by the qform)", "nan"});
    }

    SECTION("a .hdr/.img pair: the header in one file, the voxels in the other") {
        const std::string hdr = dir + "/pair.hdr";
        write_image(image.GetPointer(), hdr);
        const std::string img = dir + "/pair.img";
        REQUIRE(fs::exists(img));
        check_image(read_label_image(hdr, ImageReadOptions{}), rotated_grid(), 1, test_label, 1e-4);
        const std::string header = read_bytes(hdr);
        write_bytes(hdr, poked<float>(header, 84, nan));
        check_refused(hdr, ImageReadOptions{}, hdr, {"pixdim[2]", "nan"});
        write_bytes(hdr, header);
        fs::resize_file(img, fs::file_size(img) - 1);
        check_refused(hdr, ImageReadOptions{}, img, {"NIfTI data file", "truncated"});
    }
    SECTION("a NIfTI-2 header") {
        // ITK 5.2 reads no NIfTI-2, but its header is checked first all the same.
        std::string header(544, '\0');
        header = poked<std::int32_t>(header, 0, 540);
        header.replace(4, 8, std::string("n+2\0\r\n\x1a\n", 8));
        header = poked<std::int16_t>(header, 12, 2);
        header = poked<std::int16_t>(header, 14, 8);
        const std::int64_t dims[8] = {3, 4, 4, 4, 1, 1, 1, 1};
        for (int d = 0; d < 8; ++d) header = poked<std::int64_t>(header, 16 + 8 * d, dims[d]);
        for (int d = 0; d < 8; ++d) header = poked<double>(header, 104 + 8 * d, 1.0);
        header = poked<std::int64_t>(header, 168, 544);
        header = poked<double>(header, 120, std::numeric_limits<double>::quiet_NaN());
        const std::string path = dir + "/nifti2.nii.gz";
        write_gz(path, header + std::string(64, '\1'));
        check_refused(path, ImageReadOptions{}, path, {"pixdim[2]", "nan"});
        // A sound one: refused as what it is, not as a damaged file ITK cannot read.
        write_gz(path, poked<double>(header, 120, 1.0) + std::string(64, '\1'));
        check_refused(path, ImageReadOptions{}, path, {"NIfTI-2", "save the image as NIfTI-1"});
    }
}

TEST_CASE("MetaImage and NRRD headers and data sizes are checked before allocation", "[io]") {
    // A short data file was read as garbage, a huge DimSize allocated gigabytes before
    // failing: both are refused from the header and the file sizes alone.
    const std::string dir = frontmesh::fixtures::temp_dir("io_data_size");
    Grid grid = rotated_grid();
    grid.size = {12, 10, 8};
    const auto image = make_image<short>(grid, as_value);

    SECTION("MetaImage with a separate data file (.mhd + .raw)") {
        const std::string path = dir + "/labels.mhd";
        write_image(image.GetPointer(), path);
        const std::string raw = dir + "/labels.raw";
        REQUIRE(fs::exists(raw));
        REQUIRE_NOTHROW(read_label_image(path, ImageReadOptions{}));
        const std::string header = read_bytes(path);

        fs::resize_file(raw, fs::file_size(raw) / 3);
        check_refused(path, ImageReadOptions{}, raw, {"ElementDataFile", "truncated", "1920"});
        fs::resize_file(raw, 0);
        check_refused(path, ImageReadOptions{}, raw, {"ElementDataFile", "truncated"});

        write_bytes(path, with_line(header, "DimSize", "DimSize = 1500 1500 1500"));
        check_refused(path, ImageReadOptions{}, path,
                      {"DimSize", "1500 x 1500 x 1500", "input.max_image_gib"});
        write_bytes(path, with_line(header, "Offset", "Offset = 0 2e6 0"));
        check_refused(path, ImageReadOptions{}, path, {"Offset value 2", "2e+06 mm"});
        write_bytes(path, with_line(header, "DimSize", "DimSize = 12 0 8"));
        check_refused(path, ImageReadOptions{}, path, {"DimSize", "at least 1"});
        write_bytes(path, with_line(header, "ElementSpacing", "ElementSpacing = 0.7 nan 2.1"));
        check_refused(path, ImageReadOptions{}, path, {"ElementSpacing value 2", "nan"});
        write_bytes(path, with_line(header, "ElementSpacing", "ElementSpacing = 0.7 1e30 2.1"));
        check_refused(path, ImageReadOptions{}, path, {"ElementSpacing value 2", "1e+30"});
        write_bytes(path,
                    with_line(header, "TransformMatrix", "TransformMatrix = 1 0 0 1 0 0 0 0 1"));
        check_refused(path, ImageReadOptions{}, path, {"TransformMatrix", "singular"});
        write_bytes(path, with_line(header, "Offset", "Offset = 0 inf 0"));
        check_refused(path, ImageReadOptions{}, path, {"Offset", "inf"});
        write_bytes(path, with_line(header, "ElementType", "ElementType = MET_NOTHING"));
        check_refused(path, ImageReadOptions{}, path, {"ElementType", "MET_NOTHING"});
        // What MetaIO would read otherwise than this check does is refused (fuzz findings:
        // an overflow of MetaIO's key buffer, a 2^64-byte allocation, an unknown type).
        write_bytes(path, with_line(header, "ElementType", "ElementType = \rMET_UCHAR"));
        check_refused(path, ImageReadOptions{}, path, {"control character 0x0d"});
        write_bytes(path, with_line(header, "Offset", "Offset = 0 0 0\n" + std::string(300, 'K')));
        check_refused(path, ImageReadOptions{}, path, {"line", "is not a 'Key = value' line"});
        write_bytes(path, with_line(header, "Offset", std::string(300, 'K') + " = 1"));
        check_refused(path, ImageReadOptions{}, path, {"300 characters long", "at most 200"});
        write_bytes(path, with_line(header, "Offset", "Offset = " + std::string(500, '0')));
        check_refused(path, ImageReadOptions{}, path, {"509 characters long", "at most 400"});
        write_bytes(path, with_line(header, "DimSize", "DimSize : 1500 1500 1500"));
        check_refused(path, ImageReadOptions{}, path, {"DimSize", "1500 x 1500 x 1500"});
        write_bytes(path, with_line(header, "DimSize", "DimSize = 12 10 8\nDimSize = 12 10 9"));
        check_refused(path, ImageReadOptions{}, path, {"DimSize is given twice"});
        write_bytes(path, with_line(header, "DimSize", "DimSize = 12 0x10 8"));
        check_refused(path, ImageReadOptions{}, path, {"DimSize value 2 '0x10'", "decimal"});
    }
    SECTION("MetaImage with one data file per slice (printf pattern)") {
        const std::string path = dir + "/labels.mhd";
        write_image(image.GetPointer(), path);
        const std::string raw = read_bytes(dir + "/labels.raw");
        const std::size_t slice = raw.size() / 8;
        for (int k = 0; k < 8; ++k) {
            char name[32];
            std::snprintf(name, sizeof name, "/slice%03d.raw", 2 * k + 1);
            write_bytes(dir + name, raw.substr(k * slice, slice));
        }
        const std::string header = read_bytes(path);
        write_bytes(path,
                    with_line(header, "ElementDataFile", "ElementDataFile = slice%03d.raw 1 15 2"));
        check_image(read_label_image(path, ImageReadOptions{}), grid, 1, test_label, 1e-6);
        // MetaIO divides by STEP (SIGFPE at 0) and formats the pattern with an int.
        write_bytes(path,
                    with_line(header, "ElementDataFile", "ElementDataFile = slice%03d.raw 1 15 0"));
        check_refused(path, ImageReadOptions{}, path, {"ElementDataFile STEP is 0"});
        write_bytes(path,
                    with_line(header, "ElementDataFile", "ElementDataFile = slice%s.raw 1 15 2"));
        check_refused(path, ImageReadOptions{}, path, {"one %d conversion"});
        write_bytes(path,
                    with_line(header, "ElementDataFile", "ElementDataFile = slice%03d.raw 1 13 2"));
        check_refused(path, ImageReadOptions{}, path, {"names 7 files", "DimSize needs 8"});
        // Each file present and holding its slice: twelve missing files were read as an
        // image and meshed (the malformed-input campaign, issue 21).
        write_bytes(path,
                    with_line(header, "ElementDataFile", "ElementDataFile = slice%03d.raw 2 16 2"));
        check_refused(path, ImageReadOptions{}, path,
                      {"slice002.raw' does not exist", "ElementDataFile pattern"});
        write_bytes(dir + "/slice009.raw", raw.substr(0, slice - 1));
        write_bytes(path,
                    with_line(header, "ElementDataFile", "ElementDataFile = slice%03d.raw 1 15 2"));
        check_refused(path, ImageReadOptions{}, dir + "/slice009.raw",
                      {"truncated", "of the slice its header announces"});
    }
    SECTION("MetaImage with a LIST of slice files") {
        const std::string path = dir + "/labels.mhd";
        write_image(image.GetPointer(), path);
        const std::string raw = read_bytes(dir + "/labels.raw");
        const std::size_t slice = raw.size() / 8;
        std::string names;
        for (int k = 0; k < 8; ++k) {
            const std::string name = "part" + std::to_string(k) + ".raw";
            write_bytes(dir + "/" + name, raw.substr(k * slice, slice));
            names += name + "\n";
        }
        const std::string header = read_bytes(path);
        write_bytes(path, with_line(header, "ElementDataFile", "ElementDataFile = LIST\n" + names));
        check_image(read_label_image(path, ImageReadOptions{}), grid, 1, test_label, 1e-6);
        write_bytes(path,
                    with_line(header, "ElementDataFile", "ElementDataFile = LIST 2D\n" + names));
        check_image(read_label_image(path, ImageReadOptions{}), grid, 1, test_label, 1e-6);
        // MetaIO skips names it cannot open and stops at the end of the file, leaving slices
        // unread: a header followed by binary data was meshed (campaign seed 10, issue 21).
        write_bytes(path, with_line(header, "ElementDataFile",
                                    "ElementDataFile = LIST\n" + std::string(8, '\0') + raw));
        check_refused(path, ImageReadOptions{}, path, {"ElementDataFile LIST name 1 of 8"});
        write_bytes(path, with_line(header, "ElementDataFile",
                                    "ElementDataFile = LIST\n" + names.substr(0, 60)));
        check_refused(path, ImageReadOptions{}, path, {"LIST name", "of 8"});
        write_bytes(path, with_line(header, "ElementDataFile",
                                    "ElementDataFile = LIST\nnothing.raw\n" + names));
        check_refused(path, ImageReadOptions{}, path, {"nothing.raw' does not exist"});
        write_bytes(dir + "/part3.raw", raw.substr(0, slice - 1));
        write_bytes(path, with_line(header, "ElementDataFile", "ElementDataFile = LIST\n" + names));
        check_refused(path, ImageReadOptions{}, dir + "/part3.raw", {"truncated"});
        write_bytes(path,
                    with_line(header, "ElementDataFile", "ElementDataFile = LISTS\n" + names));
        check_refused(path, ImageReadOptions{}, path, {"expected 'LIST' or 'LIST SUBDIM'"});
    }
    SECTION("MetaImage with attached data (.mha)") {
        const std::string path = dir + "/labels.mha";
        write_image(image.GetPointer(), path);
        fs::resize_file(path, fs::file_size(path) - 100);
        check_refused(path, ImageReadOptions{}, path, {"truncated", "DimSize 12 10 8"});
    }
    SECTION("NRRD, attached (.nrrd) and detached (.nhdr)") {
        const std::string path = dir + "/labels.nrrd";
        write_image(image.GetPointer(), path);
        const std::string bytes = read_bytes(path);
        REQUIRE(bytes.find("encoding: raw") != std::string::npos);
        REQUIRE_NOTHROW(read_label_image(path, ImageReadOptions{}));
        const auto data_at = bytes.find("\n\n") + 2;
        const std::string header = bytes.substr(0, data_at);
        const std::string data = bytes.substr(data_at);

        write_bytes(path, bytes.substr(0, bytes.size() - 1));
        check_refused(path, ImageReadOptions{}, path, {"truncated", "sizes 12 10 8"});
        write_bytes(path, with_line(header, "sizes", "sizes: 1500 1500 1500") + data);
        check_refused(path, ImageReadOptions{}, path,
                      {"sizes", "1500 x 1500 x 1500", "input.max_image_gib"});
        write_bytes(path, with_line(header, "space origin", "space origin: (0,0,-1e7)") + data);
        check_refused(path, ImageReadOptions{}, path, {"space origin value 3", "-1e+07 mm"});
        write_bytes(path, with_line(header, "space directions",
                                    "space directions: (nan,0,0) (0,1,0) (0,0,1)") +
                              data);
        check_refused(path, ImageReadOptions{}, path, {"space directions", "nan"});
        write_bytes(path, with_line(header, "space directions",
                                    "space directions: (1e-9,0,0) (0,1,0) (0,0,1)") +
                              data);
        check_refused(path, ImageReadOptions{}, path, {"space directions", "1e-09 mm"});
        write_bytes(path, with_line(header, "space directions",
                                    "space directions: (1,0,0) (2,0,0) (0,0,1)") +
                              data);
        check_refused(path, ImageReadOptions{}, path, {"space directions", "singular"});
        write_bytes(path, with_line(header, "space directions", "spacings: 1 inf 1") + data);
        check_refused(path, ImageReadOptions{}, path, {"spacings value 2", "inf"});

        const std::string nhdr = dir + "/labels.nhdr";
        const std::string raw = dir + "/labels_data.raw";
        write_bytes(nhdr, header.substr(0, header.size() - 1) + "data file: labels_data.raw\n");
        write_bytes(raw, data);
        check_image(read_label_image(nhdr, ImageReadOptions{}), grid, 1, test_label, 1e-6);
        write_bytes(raw, data.substr(0, data.size() / 2));
        check_refused(nhdr, ImageReadOptions{}, raw, {"truncated", "sizes 12 10 8"});
    }
}

TEST_CASE("NaN and inf voxels of a float image are refused with or without threshold", "[io]") {
    // A NaN voxel compared false with the threshold and silently became background.
    const std::string dir = frontmesh::fixtures::temp_dir("io_float_nan");
    const Grid grid = rotated_grid();
    ImageReadOptions threshold;
    threshold.threshold = 1.5;
    for (const double bad :
         {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
          -std::numeric_limits<double>::infinity()}) {
        const auto image = make_image<float>(grid, [&](int i, int j, int k) {
            if (i == 4 && j == 2 && k == 1) return bad;
            if (i == 5 && j == 5 && k == 4) return bad;  // a later one: not the one named
            return double(test_label(i, j, k));
        });
        const std::string path = dir + "/bad.nrrd";
        write_image(image.GetPointer(), path);
        const std::string value = std::isnan(bad) ? "nan" : bad > 0 ? "inf" : "-inf";
        for (const ImageReadOptions& options : {ImageReadOptions{}, threshold}) {
            const std::string message = input_error_of([&] { read_label_image(path, options); });
            INFO(message);
            CHECK(message.find("'" + path + "'") != std::string::npos);
            CHECK(message.find("voxel (4, 2, 1) is " + value + " (2 NaN or inf voxels in all);") !=
                  std::string::npos);
        }
    }
    // Finite grayscale values still segment as before.
    const auto gray = make_image<double>(grid, [](int i, int, int) { return 0.5 * i; });
    write_image(gray.GetPointer(), dir + "/gray.mha");
    check_image(
        read_label_image(dir + "/gray.mha", threshold), grid, 1,
        [](int i, int, int) { return 0.5 * i > 1.5 ? 1 : 0; }, 1e-6);
}

TEST_CASE("NaN and inf voxels of a NIfTI float image are counted before niftilib zeroes them",
          "[io]") {
    // niftilib sets every non-finite float voxel to 0 while it reads: a NaN became background
    // even with the checks after ITK. The header check scans the raw (or gzip) voxels first.
    const std::string dir = frontmesh::fixtures::temp_dir("io_nifti_nan");
    const Grid grid = rotated_grid();
    const auto image = make_image<float>(grid, as_value);
    ImageReadOptions threshold;
    threshold.threshold = 1.5;
    for (const std::string extension : {".nii", ".nii.gz"}) {
        const std::string valid = dir + "/valid" + extension;
        write_image(image.GetPointer(), valid);
        const std::string bytes = read_gz(valid);
        REQUIRE(peeked<std::int16_t>(bytes, 70) == 16);  // DT_FLOAT32
        const auto data_at = static_cast<std::size_t>(peeked<float>(bytes, 108));
        check_image(read_label_image(valid, ImageReadOptions{}), grid, 1, test_label, 1e-4);
        // Voxel (i, j, k) of the 7 x 6 x 5 grid is value i + 7 j + 42 k of the data.
        auto at = [&](int i, int j, int k) { return data_at + 4 * (i + 7 * j + 42 * k); };
        for (const float bad :
             {std::numeric_limits<float>::quiet_NaN(), -std::numeric_limits<float>::infinity()}) {
            const std::string value = std::isnan(bad) ? "nan" : "-inf";
            DYNAMIC_SECTION(value << extension) {
                std::string corrupt = poked<float>(bytes, at(6, 5, 4), bad);
                corrupt = poked<float>(corrupt, at(4, 2, 1), bad);
                corrupt =
                    poked<float>(corrupt, at(3, 2, 1), std::numeric_limits<float>::infinity());
                const std::string path = dir + "/bad_" + value + extension;
                extension == ".nii" ? write_bytes(path, corrupt) : write_gz(path, corrupt);
                for (const ImageReadOptions& options : {ImageReadOptions{}, threshold})
                    check_refused(
                        path, options, path,
                        {"voxel (3, 2, 1) is inf (3 NaN or inf voxels in all)", "input.threshold"});
            }
        }
    }
}

TEST_CASE("the memory an image takes is estimated from its header and limited", "[io]") {
    // A header announcing 1024^3 voxels is refused from the header alone, naming the key that
    // raises the limit; raised, the next check (the data size) refuses it, still unallocated.
    const std::string dir = frontmesh::fixtures::temp_dir("io_memory_limit");
    Grid grid;
    const auto image = make_image<unsigned char>(grid, as_value);
    const std::string path = dir + "/big.mhd";
    write_image(image.GetPointer(), path);
    REQUIRE_NOTHROW(read_label_image(path, ImageReadOptions{}));
    write_bytes(path, with_line(read_bytes(path), "DimSize", "DimSize = 1024 1024 1024"));
    // 2^30 voxels x (1 byte + 4 bytes of label) = 5 GiB.
    check_refused(path, ImageReadOptions{}, path,
                  {"DimSize 1024 x 1024 x 1024", "about 5 GiB", "(1 byte per voxel",
                   "input.max_image_gib = 4"});
    ImageReadOptions raised;
    raised.max_image_gib = 6.0;
    check_refused(path, raised, dir + "/big.raw", {"truncated", "1073741824"});

    SECTION("formats without a header of ours: the size ITK reports") {
        const std::string png = dir + "/slices";
        fs::create_directories(png);
        // 7 x 6 x 5 voxels of 1 + 4 bytes take 1050 bytes.
        write_slices(image.GetPointer(), {png + "/s0.png", png + "/s1.png", png + "/s2.png",
                                          png + "/s3.png", png + "/s4.png"});
        ImageReadOptions tiny;
        tiny.spacing = Eigen::Vector3d(1.0, 1.0, 1.0);
        REQUIRE_NOTHROW(read_label_image(png, tiny));
        tiny.max_image_gib = 5e-7;  // 537 bytes
        check_refused(png, tiny, png, {"image size 7 x 6 x 5", "input.max_image_gib"});
    }
}

TEST_CASE("compressed and text data are counted against the header before allocation", "[io]") {
    // MetaIO and teem allocate what the header announces, then inflate: a 200^3 header over
    // a few hundred compressed bytes allocated 8 MB (1500^3: 3.4 GB) before failing.
    const std::string dir = frontmesh::fixtures::temp_dir("io_compressed_size");
    Grid grid = rotated_grid();
    grid.size = {12, 10, 8};
    const auto image = make_image<short>(grid, as_value);
    auto write_compressed = [&](const std::string& path) {
        auto writer = itk::ImageFileWriter<itk::Image<short, 3>>::New();
        writer->SetInput(image);
        writer->SetFileName(path);
        writer->UseCompressionOn();
        writer->Update();
    };

    SECTION("MetaImage CompressedData (zlib), attached and in a .zraw") {
        for (const std::string name : {"labels.mha", "labels.mhd"}) {
            const std::string path = dir + "/" + name;
            write_compressed(path);
            const std::string bytes = read_bytes(path);
            REQUIRE(bytes.find("CompressedData = True") != std::string::npos);
            check_image(read_label_image(path, ImageReadOptions{}), grid, 1, test_label, 1e-4);
            write_bytes(path, with_line(bytes, "DimSize", "DimSize = 200 200 200"));
            check_refused(path, ImageReadOptions{},
                          name == "labels.mha" ? path : dir + "/labels.zraw",
                          {"truncated", "16000000 bytes", "once decompressed", "DimSize 200"});
        }
        const std::string path = dir + "/labels.mha";
        write_compressed(path);
        const std::string bytes = read_bytes(path);
        write_bytes(path, bytes.substr(0, bytes.size() - 20));  // a damaged stream
        check_refused(path, ImageReadOptions{}, path,
                      {"truncated", "of compressed data its CompressedDataSize announces"});
        // Without its size MetaIO read the data after the header as garbage (88 labels).
        const auto size_at = bytes.find("\nCompressedDataSize");
        REQUIRE(size_at != std::string::npos);
        write_bytes(path, bytes.substr(0, size_at) + bytes.substr(bytes.find('\n', size_at + 1)));
        check_refused(path, ImageReadOptions{}, path, {"CompressedDataSize is missing"});
        // An empty value: MetaIO reads the next line as the value (fuzz_image: an empty
        // ElementDataFile before the compressed bytes made it allocate 2^64 - 1 bytes).
        write_bytes(path, with_line(bytes, "ElementDataFile", "ElementDataFile =\nLOCAL"));
        check_refused(path, ImageReadOptions{}, path,
                      {"ElementDataFile has no value", "would read line"});
        write_bytes(path, with_line(bytes, "ElementSpacing", "ElementSpacing = "));
        check_refused(path, ImageReadOptions{}, path, {"ElementSpacing has no value"});
        // A CompressedDataSize shorter than the stream: MetaIO inflates only those bytes and
        // the voxels past them were garbage labels (the malformed-input campaign, issue 21).
        write_bytes(path, with_line(bytes, "CompressedDataSize", "CompressedDataSize = 40"));
        check_refused(path, ImageReadOptions{}, path,
                      {"truncated", "once decompressed", "from its CompressedDataSize 40 bytes"});
        // Fewer compressed bytes than CompressedDataSize (the stream's checksum cut off).
        const auto size_line = bytes.find("CompressedDataSize = ");
        REQUIRE(size_line != std::string::npos);
        const long announced = std::stol(bytes.substr(size_line + 21));
        write_bytes(path, with_line(bytes, "CompressedDataSize",
                                    "CompressedDataSize = " + std::to_string(announced + 4)));
        check_refused(path, ImageReadOptions{}, path,
                      {"truncated", "of compressed data its CompressedDataSize announces"});
        // Values for another dimension: the readers took the first ones silently.
        write_bytes(path, with_line(bytes, "ElementSpacing", "ElementSpacing = 1 1 1 1"));
        check_refused(path, ImageReadOptions{}, path,
                      {"ElementSpacing '1 1 1 1' has 4 values; expected 3"});
        // A HeaderSize beyond attached data: MetaIO read nothing (campaign seed 4); one
        // inside the header would read header text as voxels.
        write_bytes(path, with_line(bytes, "ElementSpacing",
                                    "ElementSpacing = 1 1 1\nHeaderSize = 100000"));
        check_refused(path, ImageReadOptions{}, path, {"truncated"});
        write_bytes(path,
                    with_line(bytes, "ElementSpacing", "ElementSpacing = 1 1 1\nHeaderSize = 20"));
        check_refused(path, ImageReadOptions{}, path, {"HeaderSize 20 points inside the header"});
        // A number MetaIO cannot read in another list: it printed four lines and lost the
        // rest of the header.
        write_bytes(path, with_line(bytes, "ElementSpacing",
                                    "ElementSpacing = 1 1 1\nElementSize = nan 1 1"));
        check_refused(path, ImageReadOptions{}, path, {"ElementSize value 1 'nan'"});
        // Two names of one field: MetaIO misread the header, the second went unchecked.
        write_bytes(
            path, with_line(bytes, "ElementSpacing", "ElementSpacing = 1 1 1\nPosition = nan 0 0"));
        check_refused(path, ImageReadOptions{}, path,
                      {"Offset and Position are two names of one field"});
    }
    SECTION("MetaImage text voxels are numbers within the voxel type") {
        const std::string path = dir + "/text.mha";
        std::string values;
        for (int v = 0; v < 12 * 10 * 8; ++v) values += std::to_string(v % 2) + " ";
        const std::string header =
            "ObjectType = Image\nNDims = 3\nBinaryData = False\nDimSize = 12 10 8\n"
            "ElementType = MET_UCHAR\nElementDataFile = LOCAL\n";
        write_bytes(path, header + values);
        REQUIRE(read_label_image(path, ImageReadOptions{}).dims[0] == 14);
        // MetaIO stopped at a token it could not read and left the rest as allocated.
        const std::size_t at = 2 * (12 * 10 * 3 + 12 * 2 + 5);  // voxel (5, 2, 3)
        write_bytes(path, header + values.substr(0, at) + "x" + values.substr(at + 1));
        check_refused(path, ImageReadOptions{}, path, {"text voxel 389 (5, 2, 3) is 'x'"});
        write_bytes(path, header + values.substr(0, at) + "300" + values.substr(at + 1));
        check_refused(path, ImageReadOptions{}, path, {"is 300, outside the range of MET_UCHAR"});
        write_bytes(path, header + values.substr(0, at) + "1e999" + values.substr(at + 1));
        check_refused(path, ImageReadOptions{}, path, {"is 1e999, outside the range"});
        write_bytes(path, header + values.substr(0, 2 * 500) + std::string(2000, ' '));
        check_refused(path, ImageReadOptions{}, path, {"holds 500 of the 960 text voxels"});
    }
    SECTION("NRRD gzip, and ascii text") {
        const std::string path = dir + "/labels.nrrd";
        write_compressed(path);
        const std::string bytes = read_bytes(path);
        REQUIRE(bytes.find("encoding: gzip") != std::string::npos);
        check_image(read_label_image(path, ImageReadOptions{}), grid, 1, test_label, 1e-4);
        write_bytes(path, with_line(bytes, "sizes", "sizes: 200 200 200"));
        check_refused(path, ImageReadOptions{}, path,
                      {"truncated", "16000000 bytes", "once decompressed", "sizes 200 200 200"});

        const std::string text = dir + "/text.nrrd";
        std::string values;
        for (int v = 0; v < 12 * 10 * 8; ++v) values += std::to_string(v % 2) + " ";
        const std::string header =
            "NRRD0004\ntype: short\ndimension: 3\nsizes: 12 10 8\n"
            "spacings: 1 1 1\nencoding: ascii\n\n";
        write_bytes(text, header + values);
        REQUIRE(read_label_image(text, ImageReadOptions{}).dims[0] == 14);
        write_bytes(text, with_line(header, "sizes", "sizes: 200 200 200") + values);
        check_refused(text, ImageReadOptions{}, text, {"truncated", "of text", "15999999"});
    }
}

TEST_CASE("named pipes and devices and sockets are refused unopened", "[io]") {
    // Opening a FIFO for reading blocks until a writer comes: a run hung. Every path the
    // reader would open is tested by type first; none of these calls may block.
    const std::string dir = frontmesh::fixtures::temp_dir("io_special_files");
    const std::string fifo = dir + "/pipe.nii";
    REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
    check_refused(fifo, ImageReadOptions{}, fifo, {"named pipe (FIFO)"});
    check_refused("/dev/zero", ImageReadOptions{}, "/dev/zero", {"character device"});

    const std::string socket_path = dir + "/socket.mha";
    const int socket_fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
    REQUIRE(socket_fd >= 0);
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    REQUIRE(socket_path.size() < sizeof address.sun_path);
    std::strcpy(address.sun_path, socket_path.c_str());
    REQUIRE(::bind(socket_fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0);
    check_refused(socket_path, ImageReadOptions{}, socket_path, {"socket"});
    ::close(socket_fd);

    SECTION("a data file named by the header") {
        Grid grid;
        const auto image = make_image<unsigned char>(grid, as_value);
        const std::string mhd = dir + "/labels.mhd";
        write_image(image.GetPointer(), mhd);
        fs::remove(dir + "/labels.raw");
        REQUIRE(::mkfifo((dir + "/labels.raw").c_str(), 0600) == 0);
        check_refused(mhd, ImageReadOptions{}, dir + "/labels.raw",
                      {"ElementDataFile", "named pipe"});

        const std::string nhdr = dir + "/labels.nhdr";
        write_bytes(nhdr,
                    "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 7 6 5\nencoding: raw\n"
                    "data file: labels.raw\n");
        check_refused(nhdr, ImageReadOptions{}, dir + "/labels.raw", {"data file", "named pipe"});
    }
    SECTION("an entry of a slice folder or a slice a pattern names") {
        Grid grid;
        grid.origin.setZero();
        const auto image = make_image<unsigned char>(grid, as_value);
        const std::string stack = dir + "/stack";
        fs::create_directory(stack);
        std::vector<std::string> names;
        for (int k = 0; k < grid.size[2]; ++k)
            names.push_back(stack + "/slice_" + std::to_string(k) + ".png");
        write_slices(image.GetPointer(), names);
        ImageReadOptions options;
        options.spacing = grid.spacing;
        REQUIRE_NOTHROW(read_label_image(stack + "/slice_%d.png", options));
        const std::string slice = stack + "/slice_2.png";
        fs::remove(slice);
        REQUIRE(::mkfifo(slice.c_str(), 0600) == 0);
        check_refused(stack + "/slice_%d.png", options, slice, {"slice", "named pipe"});
        check_refused(stack, options, slice, {"folder entry", "named pipe"});
    }
}

TEST_CASE("real atlases: AAL labels and thresholded Colin27", "[io][e2e]") {
    const std::string aal = "/usr/share/mricron/templates/aal.nii.gz";
    const std::string colin = "/usr/share/mricron/templates/ch2bet.nii.gz";
    REQUIRE(fs::exists(aal));
    REQUIRE(fs::exists(colin));

    const LabelImage atlas = read_label_image(aal, ImageReadOptions{});
    CHECK(atlas.spacing.isApprox(Eigen::Vector3d::Ones(), 1e-6));
    std::set<Label> labels(atlas.labels.begin(), atlas.labels.end());
    labels.erase(0);
    CHECK(labels.size() == 116);
    // The atlas ships with a table of its labels, one "number name code" line each.
    std::set<Label> listed;
    std::ifstream table("/usr/share/mricron/templates/aal.nii.txt");
    for (Label number; table >> number; table.ignore(1 << 16, '\n')) listed.insert(number);
    CHECK(labels == listed);
    // The padding is label 0.
    CHECK(atlas.at(0, atlas.dims[1] / 2, atlas.dims[2] / 2) == 0);
    CHECK(atlas.at(atlas.dims[0] - 1, atlas.dims[1] / 2, atlas.dims[2] / 2) == 0);

    ImageReadOptions options;
    options.threshold = 30.0;
    const LabelImage brain = read_label_image(colin, options);
    const auto inside = std::count(brain.labels.begin(), brain.labels.end(), Label{1});
    CHECK(std::count(brain.labels.begin(), brain.labels.end(), Label{0}) + inside ==
          static_cast<std::ptrdiff_t>(brain.voxel_count()));
    CHECK(inside > 0);
    CHECK(static_cast<std::size_t>(inside) < brain.voxel_count());
    // A brain is about 1.1-1.6 litres.
    const double volume_ml = inside * brain.voxel_volume() / 1000.0;
    CHECK(volume_ml > 800.0);
    CHECK(volume_ml < 2000.0);
}
