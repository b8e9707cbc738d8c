#include "io/mesh_io.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <sstream>
#include <string_view>
#include <type_traits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <vtkAlgorithm.h>
#include <vtkCellArray.h>
#include <vtkCellArrayIterator.h>
#include <vtkCellData.h>
#include <vtkCellTypes.h>
#include <vtkCharArray.h>
#include <vtkCommand.h>
#include <vtkDataArray.h>
#include <vtkDataSet.h>
#include <vtkDoubleArray.h>
#include <vtkExecutive.h>
#include <vtkFieldData.h>
#include <vtkFloatArray.h>
#include <vtkIdTypeArray.h>
#include <vtkIntArray.h>
#include <vtkLongLongArray.h>
#include <vtkNew.h>
#include <vtkPLYReader.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkSTLReader.h>
#include <vtkSmartPointer.h>
#include <vtkStringArray.h>
#include <vtkUnsignedCharArray.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLPolyDataReader.h>
#include <vtkXMLPolyDataWriter.h>
#include <vtkXMLReader.h>
#include <vtkXMLUnstructuredGridReader.h>
#include <vtkXMLUnstructuredGridWriter.h>

#include "io/atomic_file.h"
#include "io/format_checks.h"
#include "pipeline/core/coordinate_range.h"
#include "pipeline/core/error.h"
#include "pipeline/core/quality.h"

namespace frontmesh::io {

namespace {

namespace fs = std::filesystem;

using core::Label;
using core::SurfaceNetwork;

std::string quoted(const std::string& path) { return "'" + path + "'"; }

// Collects VTK error and warning events of one object so that they neither reach the
// console (library code prints nothing) nor get lost: the first error becomes part of
// the exception message.
class VtkMessageCapture : public vtkCommand {
public:
    static VtkMessageCapture* New() { return new VtkMessageCapture; }

    void Execute(vtkObject*, unsigned long event, void* data) override {
        if (event != vtkCommand::ErrorEvent) return;
        has_error_ = true;
        if (message_.empty() && data != nullptr)
            message_ = plain_text(static_cast<const char*>(data));
    }

    /// Observes errors and warnings of `object`.
    void watch(vtkObject* object) {
        if (object == nullptr) return;
        object->AddObserver(vtkCommand::ErrorEvent, this);
        object->AddObserver(vtkCommand::WarningEvent, this);
    }

    bool has_error() const { return has_error_; }
    const std::string& message() const { return message_; }

private:
    // VTK formats "ERROR: In <file>, line <n>\n<Class> (<ptr>): <text>\n\n"; keep <text>.
    static std::string plain_text(std::string text) {
        const std::size_t header_end = text.find('\n');
        if (header_end != std::string::npos) {
            const std::size_t colon = text.find("): ", header_end);
            if (colon != std::string::npos) text = text.substr(colon + 3);
        }
        while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back())))
            text.pop_back();
        std::replace(text.begin(), text.end(), '\n', ' ');
        return text;
    }

    bool has_error_ = false;
    std::string message_;
};

}  // namespace

void silence_vtk_console() { vtkObject::GlobalWarningDisplayOff(); }

namespace {

// ---------------------------------------------------------------------------------------
// Writing

// A grid of double-precision points `xyz` (frontmesh never stores float geometry, STYLE
// §2) and cells of K nodes each, all of VTK type `type`, as offsets + connectivity.
template <std::size_t K>
vtkSmartPointer<vtkUnstructuredGrid> new_grid(const std::vector<double>& xyz,
                                              const std::vector<std::array<std::int32_t, K>>& cells,
                                              int type) {
    const std::size_t n_points = xyz.size() / 3;
    const std::size_t n_cells = cells.size();
    auto grid = vtkSmartPointer<vtkUnstructuredGrid>::New();
    vtkNew<vtkDoubleArray> coords;
    coords->SetNumberOfComponents(3);
    coords->SetNumberOfTuples(static_cast<vtkIdType>(n_points));
    std::copy(xyz.begin(), xyz.end(), coords->GetPointer(0));
    vtkNew<vtkPoints> points;
    points->SetData(coords);
    grid->SetPoints(points);

    vtkNew<vtkIdTypeArray> offsets;
    vtkNew<vtkIdTypeArray> connectivity;
    offsets->SetNumberOfTuples(static_cast<vtkIdType>(n_cells + 1));
    connectivity->SetNumberOfTuples(static_cast<vtkIdType>(K * n_cells));
    vtkIdType* off = offsets->GetPointer(0);
    vtkIdType* conn = connectivity->GetPointer(0);
    const auto limit = static_cast<std::int64_t>(n_points);
    for (std::size_t c = 0; c < n_cells; ++c) {
        for (std::size_t k = 0; k < K; ++k) {
            FM_CHECK(cells[c][k] >= 0 && cells[c][k] < limit);
            conn[K * c + k] = cells[c][k];
        }
        off[c] = static_cast<vtkIdType>(K * c);
    }
    off[n_cells] = static_cast<vtkIdType>(K * n_cells);
    vtkNew<vtkCellArray> cell_array;
    cell_array->SetData(offsets, connectivity);
    grid->SetCells(type, cell_array);
    return grid;
}

// Text entries of field data as char arrays (VTK type Int8), one per key, sorted by key so
// the output is stable. Not vtkStringArray: meshio (and other readers of VTU) reject the
// XML "String" type; copy_field_strings reads both back.
void add_field_strings(vtkFieldData* field_data, const FieldStrings& fields) {
    for (const auto& [key, value] : fields) {
        vtkNew<vtkCharArray> entry;
        entry->SetName(key.c_str());
        entry->SetNumberOfTuples(static_cast<vtkIdType>(value.size()));
        std::copy(value.begin(), value.end(), entry->GetPointer(0));
        field_data->AddArray(entry);
    }
}

// A VTK copy of `surface` with its cell and field arrays. Memory: about 57 B per face
// (64-bit ids, offsets, type, regions, quality) + 24 B per vertex, ~70 MB per million faces.
vtkSmartPointer<vtkUnstructuredGrid> surface_grid(const SurfaceNetwork& surface,
                                                  const FieldStrings& fields) {
    const std::size_t nv = surface.vertex_count();
    const std::size_t nf = surface.face_count();
    FM_CHECK(surface.xyz.size() == 3 * nv);
    FM_CHECK(surface.region_in.size() == nf && surface.region_out.size() == nf);

    const vtkSmartPointer<vtkUnstructuredGrid> grid =
        new_grid(surface.xyz, surface.faces, VTK_TRIANGLE);

    vtkNew<vtkIntArray> region_in;
    vtkNew<vtkIntArray> region_out;
    vtkNew<vtkDoubleArray> eta;
    vtkNew<vtkDoubleArray> min_angle;
    region_in->SetName("region_in");
    region_out->SetName("region_out");
    eta->SetName("eta");
    min_angle->SetName("min_angle");
    for (vtkDataArray* a :
         {static_cast<vtkDataArray*>(region_in.Get()), static_cast<vtkDataArray*>(region_out.Get()),
          static_cast<vtkDataArray*>(eta.Get()), static_cast<vtkDataArray*>(min_angle.Get())})
        a->SetNumberOfTuples(static_cast<vtkIdType>(nf));

    std::copy(surface.region_in.begin(), surface.region_in.end(), region_in->GetPointer(0));
    std::copy(surface.region_out.begin(), surface.region_out.end(), region_out->GetPointer(0));

    // Quality per face: independent values written by index, so the result does not
    // depend on the thread count. About a fifth of the write time when run serially.
    double* eta_values = eta->GetPointer(0);
    double* angle_values = min_angle->GetPointer(0);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nf, 4096),
                      [&](const tbb::blocked_range<std::size_t>& range) {
                          for (std::size_t f = range.begin(); f != range.end(); ++f) {
                              const auto& t = surface.faces[f];
                              const auto a = surface.point(t[0]);
                              const auto b = surface.point(t[1]);
                              const auto c = surface.point(t[2]);
                              eta_values[f] = core::triangle_skewness(a, b, c);
                              angle_values[f] = core::triangle_min_angle_deg(a, b, c);
                          }
                      });

    vtkCellData* cell_data = grid->GetCellData();
    cell_data->AddArray(region_in);
    cell_data->AddArray(region_out);
    cell_data->AddArray(eta);
    cell_data->AddArray(min_angle);

    add_field_strings(grid->GetFieldData(), fields);
    return grid;
}

// A VTK XML dataset (Writer: vtkXMLUnstructuredGridWriter or vtkXMLPolyDataWriter).
template <class Writer>
void write_xml(vtkDataSet* grid, const std::string& path, const std::string& temp) {
    vtkNew<Writer> writer;
    vtkNew<VtkMessageCapture> capture;
    capture->watch(writer);
    capture->watch(writer->GetExecutive());

    writer->SetInputData(grid);
    writer->SetFileName(temp.c_str());
    writer->SetDataModeToAppended();
    writer->EncodeAppendedDataOff();  // raw binary, no base64
    writer->SetCompressorTypeToZLib();
    // Level 1: checkpoints are written after every stage; the higher levels cost several
    // times the time for a few percent of size on float64 data.
    writer->SetCompressionLevel(1);
    writer->SetHeaderTypeToUInt64();
    const bool ids_fit_int32 = 3 * static_cast<std::int64_t>(grid->GetNumberOfCells()) <
                               static_cast<std::int64_t>(std::numeric_limits<std::int32_t>::max());
    if (ids_fit_int32)
        writer->SetIdTypeToInt32();
    else
        writer->SetIdTypeToInt64();

    const int ok = writer->Write();
    if (ok != 1 || capture->has_error() || writer->GetErrorCode() != 0) {
        std::string why = capture->message();
        if (why.empty()) why = "VTK writer failed";
        FM_THROW(IoError, quoted(path) + ": cannot write: " + why);
    }
}

void write_grid(vtkUnstructuredGrid* grid, const std::string& path, const std::string& temp) {
    write_xml<vtkXMLUnstructuredGridWriter>(grid, path, temp);
}

// ---------------------------------------------------------------------------------------
// Reading

bool is_integer_type(int vtk_type) {
    switch (vtk_type) {
        case VTK_CHAR:
        case VTK_SIGNED_CHAR:
        case VTK_UNSIGNED_CHAR:
        case VTK_SHORT:
        case VTK_UNSIGNED_SHORT:
        case VTK_INT:
        case VTK_UNSIGNED_INT:
        case VTK_LONG:
        case VTK_UNSIGNED_LONG:
        case VTK_LONG_LONG:
        case VTK_UNSIGNED_LONG_LONG:
        case VTK_ID_TYPE:
            return true;
        default:
            return false;
    }
}

// The region array `name` of `data` when present: one integer component per cell.
vtkDataArray* region_array(vtkDataSet* data, const char* name, const std::string& path) {
    vtkAbstractArray* array = data->GetCellData()->GetAbstractArray(name);
    if (array == nullptr) return nullptr;
    auto* numbers = vtkDataArray::SafeDownCast(array);
    if (numbers == nullptr || !is_integer_type(numbers->GetDataType()))
        FM_THROW(InputError, quoted(path) + ": cell array '" + name + "' is not an integer array");
    if (numbers->GetNumberOfComponents() != 1 ||
        numbers->GetNumberOfTuples() != data->GetNumberOfCells())
        FM_THROW(InputError,
                 quoted(path) + ": cell array '" + name + "' must have one value per cell");
    return numbers;
}

Label region_value(vtkDataArray* array, vtkIdType cell, Label fallback, const char* name,
                   const std::string& path) {
    if (array == nullptr) return fallback;
    const double v = array->GetTuple1(cell);
    if (!(v >= std::numeric_limits<Label>::min() && v <= std::numeric_limits<Label>::max()))
        FM_THROW(InputError, quoted(path) + ": cell " + std::to_string(cell) + ": " + name +
                                 " value out of range");
    return static_cast<Label>(v);
}

void copy_points(vtkPointSet* data, const std::string& path, std::vector<double>& xyz) {
    const vtkIdType n = data->GetNumberOfPoints();
    if (n > std::numeric_limits<std::int32_t>::max())
        FM_THROW(InputError, quoted(path) + ": too many points (" + std::to_string(n) + ")");
    xyz.resize(3 * static_cast<std::size_t>(n));
    if (n == 0) return;
    vtkDataArray* coords = data->GetPoints()->GetData();
    if (auto* doubles = vtkDoubleArray::SafeDownCast(coords);
        doubles != nullptr && doubles->GetNumberOfComponents() == 3) {
        const double* p = doubles->GetPointer(0);
        std::copy(p, p + 3 * n, xyz.begin());
    } else {
        for (vtkIdType i = 0; i < n; ++i) coords->GetTuple(i, &xyz[3 * i]);
    }
    for (vtkIdType i = 0; i < n; ++i)
        for (int k = 0; k < 3; ++k)
            if (!std::isfinite(xyz[3 * i + k]))
                FM_THROW(InputError, quoted(path) + ": point " + std::to_string(i) +
                                         " has a non-finite coordinate");
}

// Adds one triangle of input cell `cell` after checking its point ids.
struct TriangleSink {
    const std::string& path;
    SurfaceNetwork& surface;
    vtkDataArray* in_array;
    vtkDataArray* out_array;

    void add(vtkIdType cell, vtkIdType a, vtkIdType b, vtkIdType c) {
        const auto n = static_cast<vtkIdType>(surface.vertex_count());
        for (vtkIdType v : {a, b, c})
            if (v < 0 || v >= n)
                FM_THROW(InputError, quoted(path) + ": cell " + std::to_string(cell) +
                                         " refers to missing point " + std::to_string(v));
        surface.add_face(static_cast<std::int32_t>(a), static_cast<std::int32_t>(b),
                         static_cast<std::int32_t>(c),
                         region_value(in_array, cell, 1, "region_in", path),
                         region_value(out_array, cell, 0, "region_out", path));
    }
};

[[noreturn]] void throw_not_triangle(const std::string& path, vtkIdType cell,
                                     const std::string& what) {
    FM_THROW(InputError, quoted(path) + ": cell " + std::to_string(cell) + " is " + what +
                             "; only triangles are supported");
}

std::string cell_type_name(int type) {
    const char* name = vtkCellTypes::GetClassNameFromTypeId(type);
    return name != nullptr ? std::string("a ") + name : "of VTK cell type " + std::to_string(type);
}

void copy_field_strings(vtkDataObject* data, FieldStrings* fields) {
    if (fields == nullptr) return;
    vtkFieldData* fd = data->GetFieldData();
    if (fd == nullptr) return;
    for (int i = 0; i < fd->GetNumberOfArrays(); ++i) {
        vtkAbstractArray* array = fd->GetAbstractArray(i);
        if (array == nullptr || array->GetName() == nullptr) continue;
        if (auto* strings = vtkStringArray::SafeDownCast(array)) {
            if (strings->GetNumberOfValues() > 0)
                (*fields)[array->GetName()] = strings->GetValue(0);
        } else if ((array->GetDataType() == VTK_CHAR || array->GetDataType() == VTK_SIGNED_CHAR) &&
                   array->GetNumberOfComponents() == 1) {
            // Written as vtkCharArray, read back by VTK's XML reader as signed chars.
            const char* text = static_cast<const char*>(array->GetVoidPointer(0));
            (*fields)[array->GetName()] = std::string(text, text + array->GetNumberOfTuples());
        }
    }
}

// The cell types of `grid`, one per cell, checked to be there with its connectivity: a
// damaged compressed block can leave VTK's reader with no connectivity or a short types
// array and no error (found by fuzz_mesh, issue 21).
vtkUnsignedCharArray* cell_types(vtkUnstructuredGrid* grid, const std::string& path) {
    vtkUnsignedCharArray* types = grid->GetCellTypesArray();
    if (grid->GetCells() == nullptr || types == nullptr ||
        types->GetNumberOfTuples() < grid->GetNumberOfCells())
        FM_THROW(InputError, quoted(path) +
                                 ": its cells were not read (damaged connectivity, "
                                 "offsets or types)");
    return types;
}

SurfaceNetwork surface_from_grid(vtkUnstructuredGrid* grid, const std::string& path) {
    SurfaceNetwork surface;
    copy_points(grid, path, surface.xyz);
    const vtkIdType n_cells = grid->GetNumberOfCells();
    if (n_cells == 0) return surface;
    TriangleSink sink{path, surface, region_array(grid, "region_in", path),
                      region_array(grid, "region_out", path)};
    surface.faces.reserve(static_cast<std::size_t>(n_cells));
    surface.region_in.reserve(static_cast<std::size_t>(n_cells));
    surface.region_out.reserve(static_cast<std::size_t>(n_cells));

    vtkUnsignedCharArray* types = cell_types(grid, path);
    auto it = vtk::TakeSmartPointer(grid->GetCells()->NewIterator());
    for (it->GoToFirstCell(); !it->IsDoneWithTraversal(); it->GoToNextCell()) {
        const vtkIdType cell = it->GetCurrentCellId();
        vtkIdType npts = 0;
        const vtkIdType* pts = nullptr;
        it->GetCurrentCell(npts, pts);
        const int type = types->GetValue(cell);
        if (type != VTK_TRIANGLE || npts != 3) throw_not_triangle(path, cell, cell_type_name(type));
        sink.add(cell, pts[0], pts[1], pts[2]);
    }
    return surface;
}

SurfaceNetwork surface_from_polydata(vtkPolyData* poly, const std::string& path) {
    SurfaceNetwork surface;
    copy_points(poly, path, surface.xyz);
    // vtkPolyData numbers its cells verts, then lines, then polys, then strips.
    const vtkIdType n_verts = poly->GetNumberOfVerts();
    const vtkIdType n_lines = poly->GetNumberOfLines();
    const vtkIdType n_polys = poly->GetNumberOfPolys();
    if (n_verts > 0) throw_not_triangle(path, 0, "a vertex cell");
    if (n_lines > 0) throw_not_triangle(path, n_verts, "a line");
    if (poly->GetNumberOfCells() == 0) return surface;

    TriangleSink sink{path, surface, region_array(poly, "region_in", path),
                      region_array(poly, "region_out", path)};
    surface.faces.reserve(static_cast<std::size_t>(n_polys));
    surface.region_in.reserve(static_cast<std::size_t>(n_polys));
    surface.region_out.reserve(static_cast<std::size_t>(n_polys));

    vtkIdType cell = n_verts + n_lines;
    auto polys = vtk::TakeSmartPointer(poly->GetPolys()->NewIterator());
    for (polys->GoToFirstCell(); !polys->IsDoneWithTraversal(); polys->GoToNextCell(), ++cell) {
        vtkIdType npts = 0;
        const vtkIdType* pts = nullptr;
        polys->GetCurrentCell(npts, pts);
        if (npts != 3)
            throw_not_triangle(path, cell, "a polygon with " + std::to_string(npts) + " points");
        sink.add(cell, pts[0], pts[1], pts[2]);
    }

    // A strip p0 p1 p2 p3 ... holds (p0 p1 p2), (p2 p1 p3), ...: every second triangle is
    // flipped so that all share the orientation of the first. Repeated ids are the
    // zero-area connectors strips use to turn; they are no faces.
    auto strips = vtk::TakeSmartPointer(poly->GetStrips()->NewIterator());
    for (strips->GoToFirstCell(); !strips->IsDoneWithTraversal(); strips->GoToNextCell(), ++cell) {
        vtkIdType npts = 0;
        const vtkIdType* pts = nullptr;
        strips->GetCurrentCell(npts, pts);
        if (npts < 3)
            throw_not_triangle(path, cell, "a strip with " + std::to_string(npts) + " points");
        for (vtkIdType k = 0; k + 2 < npts; ++k) {
            vtkIdType a = pts[k], b = pts[k + 1];
            const vtkIdType c = pts[k + 2];
            if (a == b || b == c || a == c) continue;
            if (k % 2 == 1) std::swap(a, b);
            sink.add(cell, a, b, c);
        }
    }
    return surface;
}

// Runs a VTK reader and returns its output, or throws InputError with VTK's reason.
template <class Reader>
vtkSmartPointer<Reader> run_reader(const std::string& path, const char* format) {
    auto reader = vtkSmartPointer<Reader>::New();
    vtkNew<VtkMessageCapture> capture;
    capture->watch(reader);
    capture->watch(reader->GetExecutive());
    if constexpr (std::is_base_of_v<vtkXMLReader, Reader>) {
        // The XML parser is created inside the reader; it reports through these.
        reader->SetReaderErrorObserver(capture);
        reader->SetParserErrorObserver(capture);
    }
    reader->SetFileName(path.c_str());
    try {
        reader->Update();
    } catch (const std::exception& e) {
        // VTK's XML readers size arrays by the file's compression header without checking
        // it: a damaged one throws std::length_error or std::bad_alloc out of Update()
        // (found by fuzz_mesh, issue 21). That is bad input, not a frontmesh failure.
        FM_THROW(InputError, quoted(path) + ": cannot read as " + format +
                                 ": the VTK reader failed (" + e.what() + ")");
    }
    if (capture->has_error() || reader->GetErrorCode() != 0) {
        std::string why = capture->message();
        if (why.empty()) why = "the VTK reader failed";
        FM_THROW(InputError, quoted(path) + ": cannot read as " + format + ": " + why);
    }
    return reader;
}

// --- OFF ---------------------------------------------------------------------------------

// Whitespace-separated tokens of one line, comments ('#' to the end) removed.
std::vector<std::string_view> line_tokens(std::string_view line) {
    const std::size_t hash = line.find('#');
    if (hash != std::string_view::npos) line = line.substr(0, hash);
    std::vector<std::string_view> tokens;
    std::size_t i = 0;
    while (i < line.size()) {
        while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
        const std::size_t start = i;
        while (i < line.size() && !std::isspace(static_cast<unsigned char>(line[i]))) ++i;
        if (i > start) tokens.push_back(line.substr(start, i - start));
    }
    return tokens;
}

// Reads a text file line by line, handing out the tokens of each non-empty line.
class TokenLines {
public:
    explicit TokenLines(std::string text) : text_(std::move(text)) {}

    /// Tokens of the next line that has any; empty at the end of the file.
    std::vector<std::string_view> next() {
        while (pos_ < text_.size()) {
            std::size_t end = text_.find('\n', pos_);
            if (end == std::string::npos) end = text_.size();
            auto tokens = line_tokens(std::string_view(text_).substr(pos_, end - pos_));
            pos_ = end + 1;
            ++line_;
            if (!tokens.empty()) return tokens;
        }
        return {};
    }
    std::size_t line() const { return line_; }

private:
    std::string text_;
    std::size_t pos_ = 0;
    std::size_t line_ = 0;
};

template <class T>
bool parse_number(std::string_view token, T& value) {
    const char* end = token.data() + token.size();
    const auto [ptr, ec] = std::from_chars(token.data(), end, value);
    return ec == std::errc() && ptr == end;
}

SurfaceNetwork read_off(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) FM_THROW(InputError, quoted(path) + ": cannot open");
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (in.bad()) FM_THROW(InputError, quoted(path) + ": read failed");
    const long long file_bytes = static_cast<long long>(text.size());
    TokenLines lines(std::move(text));

    auto fail = [&](const std::string& what) {
        FM_THROW(InputError, quoted(path) + ": line " + std::to_string(lines.line()) + ": " + what);
    };

    auto header = lines.next();
    if (header.empty() || header[0] != "OFF") fail("expected the 'OFF' header");
    // The counts may follow the keyword on the same line.
    std::vector<std::string_view> counts(header.begin() + 1, header.end());
    if (counts.empty()) counts = lines.next();
    long long n_vertices = -1;
    long long n_faces = -1;
    if (counts.size() < 2 || !parse_number(counts[0], n_vertices) ||
        !parse_number(counts[1], n_faces) || n_vertices < 0 || n_faces < 0 ||
        n_vertices > std::numeric_limits<std::int32_t>::max() ||
        n_faces > std::numeric_limits<std::int32_t>::max())
        fail("expected vertex and face counts");
    // A vertex line takes at least 6 bytes ("0 0 0\n") and a face line 8 ("3 0 1 2\n"), the
    // last line perhaps without its newline: counts beyond that cannot be in the file, and
    // reserving for them took 9 GB (398568147 vertices, found by fuzz_surface).
    if (6 * n_vertices + 8 * n_faces > file_bytes + 1)
        fail("announces " + std::to_string(n_vertices) + " vertices and " +
             std::to_string(n_faces) + " faces; the file's " + std::to_string(file_bytes) +
             " bytes cannot hold them");

    SurfaceNetwork surface;
    surface.xyz.reserve(3 * static_cast<std::size_t>(n_vertices));
    for (long long v = 0; v < n_vertices; ++v) {
        const auto tokens = lines.next();
        if (tokens.empty()) fail("unexpected end of file in vertex " + std::to_string(v));
        double p[3] = {0.0, 0.0, 0.0};
        if (tokens.size() < 3 || !parse_number(tokens[0], p[0]) || !parse_number(tokens[1], p[1]) ||
            !parse_number(tokens[2], p[2]))
            fail("vertex " + std::to_string(v) + ": expected three coordinates");
        if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
            fail("vertex " + std::to_string(v) + " has a non-finite coordinate");
        surface.xyz.insert(surface.xyz.end(), {p[0], p[1], p[2]});
    }

    surface.faces.reserve(static_cast<std::size_t>(n_faces));
    for (long long f = 0; f < n_faces; ++f) {
        const auto tokens = lines.next();
        if (tokens.empty()) fail("unexpected end of file in face " + std::to_string(f));
        long long size = 0;
        if (!parse_number(tokens[0], size) || size < 0)
            fail("face " + std::to_string(f) + ": expected its number of vertices");
        if (size != 3)
            FM_THROW(InputError, quoted(path) + ": face " + std::to_string(f) + " has " +
                                     std::to_string(size) +
                                     " vertices; only triangles are supported");
        // Tokens after the three ids (a colour) are allowed and ignored.
        long long ids[3] = {0, 0, 0};
        for (int k = 0; k < 3; ++k)
            if (tokens.size() < 4 || !parse_number(tokens[1 + k], ids[k]))
                fail("face " + std::to_string(f) + ": expected three vertex ids");
        for (long long id : ids)
            if (id < 0 || id >= n_vertices)
                fail("face " + std::to_string(f) + " refers to missing vertex " +
                     std::to_string(id));
        surface.add_face(static_cast<std::int32_t>(ids[0]), static_cast<std::int32_t>(ids[1]),
                         static_cast<std::int32_t>(ids[2]), 1, 0);
    }
    return surface;
}

std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return s;
}

// Escapes the five XML special characters for use in an attribute value.
std::string xml_attribute(const std::string& s) {
    std::string out;
    out.reserve(s.size());
    for (char c : s) {
        switch (c) {
            case '&':
                out += "&amp;";
                break;
            case '<':
                out += "&lt;";
                break;
            case '>':
                out += "&gt;";
                break;
            case '"':
                out += "&quot;";
                break;
            case '\'':
                out += "&apos;";
                break;
            default:
                out += c;
        }
    }
    return out;
}

}  // namespace

void write_surface_vtu(const core::SurfaceNetwork& surface, const std::string& path,
                       const FieldStrings& fields, const PointArrays& point_arrays) {
    const vtkSmartPointer<vtkUnstructuredGrid> grid = surface_grid(surface, fields);
    for (const auto& [name, values] : point_arrays) {
        FM_CHECK(values.size() == surface.vertex_count());
        vtkNew<vtkDoubleArray> array;
        array->SetName(name.c_str());
        array->SetNumberOfTuples(static_cast<vtkIdType>(values.size()));
        std::copy(values.begin(), values.end(), array->GetPointer(0));
        grid->GetPointData()->AddArray(array);
    }
    write_atomically(path, [&](const std::string& temp) { write_grid(grid, path, temp); });
}

void write_diagnostic_vtu(const core::Diagnostic& diagnostic, const std::string& path,
                          const FieldStrings& fields) {
    FM_CHECK(diagnostic.xyz.size() % 3 == 0);
    FM_CHECK(diagnostic.kind.size() == diagnostic.cells.size());
    const auto n_points = static_cast<vtkIdType>(diagnostic.xyz.size() / 3);
    auto grid = vtkSmartPointer<vtkUnstructuredGrid>::New();
    vtkNew<vtkDoubleArray> coords;
    coords->SetNumberOfComponents(3);
    coords->SetNumberOfTuples(n_points);
    std::copy(diagnostic.xyz.begin(), diagnostic.xyz.end(), coords->GetPointer(0));
    vtkNew<vtkPoints> points;
    points->SetData(coords);
    grid->SetPoints(points);
    grid->AllocateExact(static_cast<vtkIdType>(diagnostic.cells.size()), 4);
    for (const auto& cell : diagnostic.cells) {
        FM_CHECK(cell.size() >= 2 && cell.size() <= 4);
        std::array<vtkIdType, 4> ids{};
        for (std::size_t k = 0; k < cell.size(); ++k) {
            FM_CHECK(cell[k] >= 0 && cell[k] < n_points);
            ids[k] = cell[k];
        }
        const int type = cell.size() == 2 ? VTK_LINE : cell.size() == 3 ? VTK_TRIANGLE : VTK_TETRA;
        grid->InsertNextCell(type, static_cast<vtkIdType>(cell.size()), ids.data());
    }
    vtkNew<vtkIntArray> kind;
    kind->SetName("kind");
    kind->SetNumberOfTuples(static_cast<vtkIdType>(diagnostic.kind.size()));
    std::copy(diagnostic.kind.begin(), diagnostic.kind.end(), kind->GetPointer(0));
    grid->GetCellData()->AddArray(kind);
    FieldStrings strings = fields;
    strings["what"] = diagnostic.what;
    add_field_strings(grid->GetFieldData(), strings);
    write_atomically(path, [&](const std::string& temp) { write_grid(grid, path, temp); });
}

core::SurfaceNetwork read_surface(const std::string& path, FieldStrings* fields) {
    std::error_code ec;
    if (!fs::exists(path, ec)) FM_THROW(InputError, quoted(path) + " does not exist");
    if (fs::is_directory(path, ec))
        FM_THROW(InputError, quoted(path) + " is a folder, not a surface file");
    if (!fs::is_regular_file(path, ec))  // a named pipe or device: reading it would block
        FM_THROW(InputError, quoted(path) + " is not a regular file");
    if (fields != nullptr) fields->clear();

    const std::string ext = lower(fs::path(path).extension().string());
    SurfaceNetwork surface;
    if (ext == ".vtu") {
        check_vtk_xml(path);
        auto reader = run_reader<vtkXMLUnstructuredGridReader>(path, "VTK XML unstructured grid");
        surface = surface_from_grid(reader->GetOutput(), path);
        copy_field_strings(reader->GetOutput(), fields);
    } else if (ext == ".vtp") {
        check_vtk_xml(path);
        auto reader = run_reader<vtkXMLPolyDataReader>(path, "VTK XML polydata");
        surface = surface_from_polydata(reader->GetOutput(), path);
        copy_field_strings(reader->GetOutput(), fields);
    } else if (ext == ".stl") {
        check_stl(path);
        auto reader = run_reader<vtkSTLReader>(path, "STL");
        surface = surface_from_polydata(reader->GetOutput(), path);
    } else if (ext == ".ply") {
        check_ply(path);
        auto reader = run_reader<vtkPLYReader>(path, "PLY");
        surface = surface_from_polydata(reader->GetOutput(), path);
    } else if (ext == ".off") {
        surface = read_off(path);
    } else {
        FM_THROW(InputError, quoted(path) + ": unknown surface format '" + ext +
                                 "' (supported: .vtu, .vtp, .stl, .ply, .off)");
    }
    if (surface.face_count() == 0) FM_THROW(InputError, quoted(path) + " contains no triangles");
    core::require_coordinates_in_range(surface.xyz, quoted(path));
    return surface;
}

void write_pvd(const std::string& path,
               const std::vector<std::pair<std::string, std::string>>& entries) {
    std::ostringstream xml;
    xml << "<?xml version=\"1.0\"?>\n"
        << "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
        << "  <Collection>\n";
    // One dataset per timestep (the index), all in part 0: ParaView then shows one stage
    // at a time and the time control steps through the run; `name` labels the block.
    for (std::size_t i = 0; i < entries.size(); ++i)
        xml << "    <DataSet timestep=\"" << i << "\" group=\"\" part=\"0\" file=\""
            << xml_attribute(entries[i].first) << "\" name=\"" << xml_attribute(entries[i].second)
            << "\"/>\n";
    xml << "  </Collection>\n</VTKFile>\n";
    write_text_atomically(path, xml.str());
}

// ---------------------------------------------------------------------------------------
// Tetrahedral meshes

namespace {

template <typename ArrayT, typename T>
void add_field_values(vtkFieldData* fd, const char* name, int components, const T* values,
                      std::size_t tuples) {
    vtkNew<ArrayT> a;
    a->SetName(name);
    a->SetNumberOfComponents(components);
    a->SetNumberOfTuples(static_cast<vtkIdType>(tuples));
    std::copy(values, values + components * tuples, a->GetPointer(0));
    fd->AddArray(a);
}

// The cell array `colour` (uint8 x3, the colour of each cell's label) and the field arrays
// `label_ids` / `label_colours` (the table). ParaView shows `colour` as is ("Map Scalars" off).
void add_label_colours(vtkDataSet* data, const std::vector<core::Label>& cell_labels,
                       const LabelColours& colours) {
    vtkNew<vtkUnsignedCharArray> colour;
    colour->SetName("colour");
    colour->SetNumberOfComponents(3);
    colour->SetNumberOfTuples(static_cast<vtkIdType>(cell_labels.size()));
    for (std::size_t c = 0; c < cell_labels.size(); ++c) {
        const auto it = colours.find(cell_labels[c]);
        FM_CHECK(it != colours.end());
        for (int k = 0; k < 3; ++k)
            colour->SetTypedComponent(static_cast<vtkIdType>(c), k, it->second[k]);
    }
    data->GetCellData()->AddArray(colour);
    std::vector<core::Label> ids;
    std::vector<std::uint8_t> rgb;
    for (const auto& [label, c] : colours) {
        ids.push_back(label);
        rgb.insert(rgb.end(), c.begin(), c.end());
    }
    add_field_values<vtkIntArray>(data->GetFieldData(), "label_ids", 1, ids.data(), ids.size());
    add_field_values<vtkUnsignedCharArray>(data->GetFieldData(), "label_colours", 3, rgb.data(),
                                           ids.size());
}

vtkSmartPointer<vtkUnstructuredGrid> tet_grid(const core::TetMesh& mesh, const FieldStrings& fields,
                                              const std::vector<core::TetFigures>* figures,
                                              const LabelColours* colours) {
    const std::size_t nn = mesh.node_count();
    const std::size_t nt = mesh.tet_count();
    const std::size_t nf = mesh.face_count();
    FM_CHECK(mesh.region.size() == nt);
    FM_CHECK(mesh.region_in.size() == nf && mesh.region_out.size() == nf);
    FM_CHECK(mesh.level.empty() || mesh.level.size() == nn);
    FM_CHECK(figures == nullptr || figures->size() == nt);

    // Quadratic tets (output.order 2): VTK_QUADRATIC_TETRA, corners then the mid nodes of
    // edges 01, 12, 20, 03, 13, 23 (TetMesh::tet_mid's order).
    vtkSmartPointer<vtkUnstructuredGrid> grid;
    if (mesh.is_quadratic()) {
        FM_CHECK(mesh.tet_mid.size() == nt);
        std::vector<std::array<std::int32_t, 10>> cells(nt);
        for (std::size_t t = 0; t < nt; ++t) {
            std::copy(mesh.tets[t].begin(), mesh.tets[t].end(), cells[t].begin());
            std::copy(mesh.tet_mid[t].begin(), mesh.tet_mid[t].end(), cells[t].begin() + 4);
        }
        grid = new_grid(mesh.xyz, cells, VTK_QUADRATIC_TETRA);
    } else {
        grid = new_grid(mesh.xyz, mesh.tets, VTK_TETRA);
    }

    vtkNew<vtkIntArray> region;
    region->SetName("region");
    region->SetNumberOfTuples(static_cast<vtkIdType>(nt));
    std::copy(mesh.region.begin(), mesh.region.end(), region->GetPointer(0));
    // Float32: figures to look at (colour maps, thresholds in ParaView), decided by nothing;
    // a third less to compress and store than float64.
    vtkNew<vtkFloatArray> skewness;
    vtkNew<vtkFloatArray> min_dihedral;
    skewness->SetName("skewness");
    min_dihedral->SetName("min_dihedral");
    skewness->SetNumberOfTuples(static_cast<vtkIdType>(nt));
    min_dihedral->SetNumberOfTuples(static_cast<vtkIdType>(nt));
    float* skew_values = skewness->GetPointer(0);
    float* dihedral_values = min_dihedral->GetPointer(0);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nt, 4096),
                      [&](const tbb::blocked_range<std::size_t>& range) {
                          for (std::size_t t = range.begin(); t != range.end(); ++t) {
                              const auto& c = mesh.tets[t];
                              const core::TetFigures f =
                                  figures != nullptr
                                      ? (*figures)[t]
                                      : core::tet_figures(mesh.point(c[0]), mesh.point(c[1]),
                                                          mesh.point(c[2]), mesh.point(c[3]));
                              skew_values[t] = static_cast<float>(f.skewness);
                              dihedral_values[t] = static_cast<float>(f.min_dihedral_deg());
                          }
                      });
    vtkCellData* cell_data = grid->GetCellData();
    cell_data->AddArray(region);
    cell_data->AddArray(skewness);
    cell_data->AddArray(min_dihedral);

    if (!mesh.level.empty()) {
        vtkNew<vtkIntArray> level;
        level->SetName("level");
        level->SetNumberOfTuples(static_cast<vtkIdType>(nn));
        std::copy(mesh.level.begin(), mesh.level.end(), level->GetPointer(0));
        grid->GetPointData()->AddArray(level);
    }

    // Split interfaces (io::split_interfaces): `twin` says which node each one is a copy of;
    // the faces' pairing travels with them.
    if (!mesh.twin.empty()) {
        FM_CHECK(mesh.twin.size() == nn && mesh.face_twin.size() == nf);
        vtkNew<vtkIntArray> twin;
        twin->SetName("twin");
        twin->SetNumberOfTuples(static_cast<vtkIdType>(nn));
        std::copy(mesh.twin.begin(), mesh.twin.end(), twin->GetPointer(0));
        grid->GetPointData()->AddArray(twin);
    }
    vtkFieldData* fd = grid->GetFieldData();
    if (!mesh.face_twin.empty())
        add_field_values<vtkIntArray>(fd, "boundary_face_twin", 1, mesh.face_twin.data(), nf);
    add_field_values<vtkIntArray>(fd, "boundary_faces", 3, mesh.faces.data()->data(), nf);
    add_field_values<vtkIntArray>(fd, "boundary_region_in", 1, mesh.region_in.data(), nf);
    add_field_values<vtkIntArray>(fd, "boundary_region_out", 1, mesh.region_out.data(), nf);
    add_field_values<vtkIntArray>(fd, "surface_vertices", 1, &mesh.surface_vertices, 1);
    add_field_strings(fd, fields);
    if (colours != nullptr) add_label_colours(grid, mesh.region, *colours);
    return grid;
}

// An int32 field-data array of `components` per tuple, or nullptr when absent.
vtkIntArray* int_field(vtkFieldData* fd, const char* name, int components,
                       const std::string& path) {
    if (fd == nullptr) return nullptr;
    vtkAbstractArray* a = fd->GetAbstractArray(name);
    if (a == nullptr) return nullptr;
    auto* ints = vtkIntArray::SafeDownCast(a);
    if (ints == nullptr || ints->GetNumberOfComponents() != components)
        FM_THROW(InputError, quoted(path) + ": field array '" + name + "' is not int32 x" +
                                 std::to_string(components));
    return ints;
}

/// The `twin` point array and `boundary_face_twin` field array of a mesh with split
/// interfaces, into mesh.twin / mesh.face_twin when both are there and in range.
void read_split_arrays(vtkUnstructuredGrid* grid, const std::string& path, core::TetMesh& mesh) {
    auto* twin = vtkIntArray::SafeDownCast(grid->GetPointData()->GetAbstractArray("twin"));
    vtkIntArray* face_twin = int_field(grid->GetFieldData(), "boundary_face_twin", 1, path);
    const auto nn = static_cast<vtkIdType>(mesh.node_count());
    const auto nf = static_cast<vtkIdType>(mesh.face_count());
    if (twin == nullptr || face_twin == nullptr || twin->GetNumberOfComponents() != 1 ||
        twin->GetNumberOfTuples() != nn || face_twin->GetNumberOfTuples() != nf)
        return;
    for (vtkIdType v = 0; v < nn; ++v)
        if (twin->GetValue(v) < 0 || twin->GetValue(v) >= nn)
            FM_THROW(InputError,
                     quoted(path) + ": twin of node " + std::to_string(v) + " out of range");
    for (vtkIdType f = 0; f < nf; ++f)
        if (face_twin->GetValue(f) < -1 || face_twin->GetValue(f) >= nf)
            FM_THROW(InputError, quoted(path) + ": boundary_face_twin of face " +
                                     std::to_string(f) + " out of range");
    mesh.twin.assign(twin->GetPointer(0), twin->GetPointer(0) + nn);
    mesh.face_twin.assign(face_twin->GetPointer(0), face_twin->GetPointer(0) + nf);
}

}  // namespace

void write_tet_mesh_vtu(const core::TetMesh& mesh, const std::string& path,
                        const FieldStrings& fields, const std::vector<core::TetFigures>* figures,
                        const LabelColours* colours) {
    const vtkSmartPointer<vtkUnstructuredGrid> grid = tet_grid(mesh, fields, figures, colours);
    write_atomically(path, [&](const std::string& temp) { write_grid(grid, path, temp); });
}

core::TetMesh read_tet_mesh(const std::string& path, FieldStrings* fields) {
    std::error_code ec;
    if (!fs::exists(path, ec)) FM_THROW(InputError, quoted(path) + " does not exist");
    if (!fs::is_regular_file(path, ec))  // a folder, a named pipe or a device
        FM_THROW(InputError, quoted(path) + " is not a regular file");
    if (fields != nullptr) fields->clear();
    const std::string ext = lower(fs::path(path).extension().string());
    if (ext != ".vtu")
        FM_THROW(InputError, quoted(path) + ": unknown tetrahedral mesh format '" + ext +
                                 "' (supported: .vtu)");
    check_vtk_xml(path);
    auto reader = run_reader<vtkXMLUnstructuredGridReader>(path, "VTK XML unstructured grid");
    vtkUnstructuredGrid* grid = reader->GetOutput();
    copy_field_strings(grid, fields);

    core::TetMesh mesh;
    copy_points(grid, path, mesh.xyz);
    core::require_coordinates_in_range(mesh.xyz, quoted(path));
    vtkDataArray* region = region_array(grid, "region", path);
    vtkUnsignedCharArray* types = cell_types(grid, path);
    const auto n_nodes = static_cast<vtkIdType>(mesh.node_count());
    auto it = vtk::TakeSmartPointer(grid->GetCells()->NewIterator());
    for (it->GoToFirstCell(); !it->IsDoneWithTraversal(); it->GoToNextCell()) {
        const vtkIdType cell = it->GetCurrentCellId();
        vtkIdType npts = 0;
        const vtkIdType* pts = nullptr;
        it->GetCurrentCell(npts, pts);
        const int type = types->GetValue(cell);
        // Quadratic tets (output.order 2) are read as their corner tets, as the Gmsh and
        // Abaqus readers read tet10 / C3D10: their mid nodes are left unused.
        if (!(type == VTK_TETRA && npts == 4) && !(type == VTK_QUADRATIC_TETRA && npts == 10))
            FM_THROW(InputError, quoted(path) + ": cell " + std::to_string(cell) + " is " +
                                     cell_type_name(type) + "; only tetrahedra are supported");
        std::array<std::int32_t, 4> t{};
        for (int k = 0; k < 4; ++k) {
            if (pts[k] < 0 || pts[k] >= n_nodes)
                FM_THROW(InputError, quoted(path) + ": cell " + std::to_string(cell) +
                                         " refers to missing point " + std::to_string(pts[k]));
            t[k] = static_cast<std::int32_t>(pts[k]);
        }
        if (core::tet_signed_volume(mesh.point(t[0]), mesh.point(t[1]), mesh.point(t[2]),
                                    mesh.point(t[3])) < 0.0)
            std::swap(t[0], t[1]);
        mesh.add_tet(t[0], t[1], t[2], t[3], region_value(region, cell, 1, "region", path));
    }
    if (mesh.tet_count() == 0) FM_THROW(InputError, quoted(path) + " contains no tetrahedra");

    if (auto* level = vtkIntArray::SafeDownCast(grid->GetPointData()->GetAbstractArray("level"));
        level != nullptr && level->GetNumberOfTuples() == n_nodes &&
        level->GetNumberOfComponents() == 1)
        mesh.level.assign(level->GetPointer(0), level->GetPointer(0) + n_nodes);

    vtkFieldData* fd = grid->GetFieldData();
    vtkIntArray* faces = int_field(fd, "boundary_faces", 3, path);
    vtkIntArray* in = int_field(fd, "boundary_region_in", 1, path);
    vtkIntArray* out = int_field(fd, "boundary_region_out", 1, path);
    vtkIntArray* sv = int_field(fd, "surface_vertices", 1, path);
    if (faces != nullptr && in != nullptr && out != nullptr && sv != nullptr) {
        const vtkIdType nf = faces->GetNumberOfTuples();
        if (in->GetNumberOfTuples() != nf || out->GetNumberOfTuples() != nf ||
            sv->GetNumberOfTuples() != 1)
            FM_THROW(InputError, quoted(path) + ": boundary field arrays differ in length");
        mesh.surface_vertices = sv->GetValue(0);
        if (mesh.surface_vertices < 0 || mesh.surface_vertices > n_nodes)
            FM_THROW(InputError, quoted(path) + ": surface_vertices out of range");
        mesh.faces.resize(static_cast<std::size_t>(nf));
        for (vtkIdType f = 0; f < nf; ++f)
            for (int k = 0; k < 3; ++k) {
                const int v = faces->GetValue(3 * f + k);
                if (v < 0 || v >= mesh.surface_vertices)
                    FM_THROW(InputError, quoted(path) + ": boundary face " + std::to_string(f) +
                                             " refers to node " + std::to_string(v) +
                                             " outside the surface nodes");
                mesh.faces[static_cast<std::size_t>(f)][k] = v;
            }
        mesh.region_in.assign(in->GetPointer(0), in->GetPointer(0) + nf);
        mesh.region_out.assign(out->GetPointer(0), out->GetPointer(0) + nf);
        read_split_arrays(grid, path, mesh);
    } else {
        core::derive_boundary_faces(mesh);
        mesh.surface_vertices = static_cast<std::int32_t>(mesh.node_count());
    }
    return mesh;
}

void write_surface_vtp(const core::TetMesh& mesh, const std::vector<std::int64_t>& face_tags,
                       const std::string& path, const FieldStrings& fields,
                       const LabelColours* colours) {
    const std::size_t nf = mesh.face_count();
    FM_CHECK(face_tags.size() == nf);
    FM_CHECK(mesh.region_in.size() == nf && mesh.region_out.size() == nf);
    // The nodes of the faces, in TetMesh order (each face visited once).
    std::vector<std::int32_t> local(mesh.node_count(), -1);
    for (const auto& f : mesh.faces)
        for (std::int32_t v : f) local[static_cast<std::size_t>(v)] = 0;
    vtkNew<vtkPoints> points;
    points->SetDataTypeToDouble();
    vtkNew<vtkIntArray> node;
    node->SetName("node");
    std::int32_t next = 0;
    for (std::size_t v = 0; v < mesh.node_count(); ++v) {
        if (local[v] < 0) continue;
        local[v] = next++;
        points->InsertNextPoint(mesh.xyz[3 * v], mesh.xyz[3 * v + 1], mesh.xyz[3 * v + 2]);
        node->InsertNextValue(static_cast<int>(v));
    }
    vtkNew<vtkCellArray> triangles;
    for (const auto& f : mesh.faces) {
        const vtkIdType ids[3] = {local[static_cast<std::size_t>(f[0])],
                                  local[static_cast<std::size_t>(f[1])],
                                  local[static_cast<std::size_t>(f[2])]};
        triangles->InsertNextCell(3, ids);
    }
    vtkNew<vtkPolyData> poly;
    poly->SetPoints(points);
    poly->SetPolys(triangles);
    poly->GetPointData()->AddArray(node);
    vtkNew<vtkLongLongArray> tag;
    tag->SetName("tag");
    tag->SetNumberOfTuples(static_cast<vtkIdType>(nf));
    std::copy(face_tags.begin(), face_tags.end(), tag->GetPointer(0));
    poly->GetCellData()->AddArray(tag);
    for (const auto& [name, labels] :
         {std::pair{"region_in", &mesh.region_in}, std::pair{"region_out", &mesh.region_out}}) {
        vtkNew<vtkIntArray> a;
        a->SetName(name);
        a->SetNumberOfTuples(static_cast<vtkIdType>(nf));
        std::copy(labels->begin(), labels->end(), a->GetPointer(0));
        poly->GetCellData()->AddArray(a);
    }
    if (colours != nullptr) add_label_colours(poly, mesh.region_in, *colours);
    // Text as vtkStringArray, a value per line, so ParaView shows it as text.
    for (const auto& [key, value] : fields) {
        vtkNew<vtkStringArray> text;
        text->SetName(key.c_str());
        std::size_t pos = 0;
        while (pos < value.size()) {  // one line per round: pos grows by at least 1
            std::size_t end = value.find('\n', pos);
            if (end == std::string::npos) end = value.size();
            text->InsertNextValue(value.substr(pos, end - pos));
            pos = end + 1;
        }
        if (value.empty()) text->InsertNextValue("");
        poly->GetFieldData()->AddArray(text);
    }
    write_atomically(
        path, [&](const std::string& temp) { write_xml<vtkXMLPolyDataWriter>(poly, path, temp); });
}

}  // namespace frontmesh::io
