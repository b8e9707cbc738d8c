#include "io/image_reader.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
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

#include "pipeline/core/error.h"
#include "tests/fixtures/phantoms.h"

namespace fs = std::filesystem;
using frontmesh::core::Frame;
using frontmesh::core::InputError;
using frontmesh::core::Label;
using frontmesh::core::LabelImage;
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
