#include "io/format_checks.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <string_view>
#include <vector>

#include <vtkCallbackCommand.h>
#include <vtkCommand.h>
#include <vtkLZ4DataCompressor.h>
#include <vtkLZMADataCompressor.h>
#include <vtkNew.h>
#include <vtkSmartPointer.h>
#include <vtkXMLDataElement.h>
#include <vtkXMLDataParser.h>
#include <vtkZLibDataCompressor.h>

#include "pipeline/core/error.h"

namespace frontmesh::io {

namespace {

std::string in_quotes(const std::string& path) { return "'" + path + "'"; }

std::string read_whole(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) FM_THROW(InputError, in_quotes(path) + ": cannot open");
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (in.bad()) FM_THROW(InputError, in_quotes(path) + ": read failed");
    return text;
}

template <class T>
bool parse_number(std::string_view token, T& value) {
    const char* end = token.data() + token.size();
    const auto [ptr, ec] = std::from_chars(token.data(), end, value);
    return ec == std::errc() && ptr == end;
}

// The unsigned integer of `size` (1..8) bytes at `data` in the given byte order.
std::uint64_t unsigned_from_bytes(const char* data, std::size_t size, bool big_endian) {
    std::uint64_t value = 0;
    for (std::size_t b = 0; b < size; ++b)
        value = (value << 8) | static_cast<unsigned char>(data[big_endian ? b : size - 1 - b]);
    return value;
}

// The two's-complement integer of `size` (1..8) bytes at `data`.
std::int64_t signed_from_bytes(const char* data, std::size_t size, bool big_endian) {
    std::uint64_t value = unsigned_from_bytes(data, size, big_endian);
    if (size < 8 && (value >> (8 * size - 1)) != 0) value |= ~std::uint64_t{0} << (8 * size);
    return static_cast<std::int64_t>(value);
}

// --- PLY ---------------------------------------------------------------------------------

// What VTK 9.1's PLY reader (vtkPLY, Greg Turk's ply.c) does with a file it should refuse,
// each found by fuzz_surface (issue 21):
// - takes the words of a line short of its properties from past the end of its word array
//   (one face line "3 0 1" crashed it in strtol);
// - goes on after "Cannot read geometry" with a closed file (no vertex x, y or z);
// - frees an uninitialised pointer for each face when the face element has no
//   vertex_indices list, and writes a list pointer into a scalar slot when a property it
//   knows as a scalar (red, nx, u ...) is a list;
// - builds cells from face indices without checking them against the vertex count
//   (an index of 0x02000002 crashed vtkCell::Initialize);
// - keeps list sizes in an unsigned char and copies them into a 256-entry array;
// - reads the elements in header order, so an element it skips (neither vertex nor face)
//   shifts every read after it, and crashes closing a file with one after them.
// So the header, and the element lines of a text PLY or the byte layout of a binary one,
// are checked here; VTK then reads only a file this check accepts.
class PlyCheck {
public:
    PlyCheck(const std::string& path, std::string text) : path_(path), text_(std::move(text)) {}

    void run() {
        if (next_line() != "ply") fail("the first line is not 'ply'");
        read_header();
        check_layout();
        if (format_ == "ascii")
            check_text_elements();
        else
            check_binary_elements(format_ == "binary_big_endian");
    }

private:
    struct Type {
        std::size_t bytes = 0;  // 0: unknown type name
        bool is_signed = false;
        bool is_float = false;
    };
    struct Property {
        std::string name;
        Type item;        // the scalar, or each list item
        Type count;       // the list size; count.bytes == 0 for a scalar
        bool is_indices;  // the face's vertex index list
        bool is_list() const { return count.bytes > 0; }
    };
    struct Element {
        std::string name;
        long long count = 0;
        std::size_t line = 0;  // of its "element" header line
        std::vector<Property> properties;
    };

    // VTK's limit on a list's length: it keeps it in an unsigned char (plyFace::nverts).
    static constexpr long long kMaxListSize = 255;

    [[noreturn]] void fail(const std::string& what) const { fail_at(line_, what); }
    [[noreturn]] void fail_at(std::size_t line, const std::string& what) const {
        FM_THROW(InputError, in_quotes(path_) + ": PLY line " + std::to_string(line) + ": " + what);
    }

    // The next line (without '\n'); VTK reads lines of at most 4094 characters and stops a
    // line at a NUL byte, so both are refused.
    std::string_view next_line() {
        if (pos_ >= text_.size()) fail("unexpected end of file");
        std::size_t end = text_.find('\n', pos_);
        if (end == std::string::npos) end = text_.size();
        const std::string_view line = std::string_view(text_).substr(pos_, end - pos_);
        pos_ = end + 1;
        ++line_;
        if (line.size() > 4094) fail("longer than 4094 characters");
        if (line.find('\0') != std::string_view::npos) fail("holds a NUL byte");
        // vtkPLY's get_words overwrites any line from its first "vertex_index" on with
        // "vertex_indices" (meant for the header's property name; a data line
        // "0 0vertex_index 1" lost its last word and crashed the reader): the line is read
        // as it does. Near the end of its 4096-byte buffer that write would overflow.
        if (const auto at = line.find("vertex_index"); at != std::string_view::npos) {
            if (at > 4000) fail("holds 'vertex_index' past column 4000");
            rewritten_ = std::string(line.substr(0, at)) + "vertex_indices";
            return rewritten_;
        }
        // A '\r' is a space to vtkPLY (see words()); a CRLF file's is dropped here.
        return line.ends_with('\r') ? line.substr(0, line.size() - 1) : line;
    }

    // Words as vtkPLY splits them: at spaces, tabs and carriage returns.
    static std::vector<std::string_view> words(std::string_view line) {
        std::vector<std::string_view> out;
        std::size_t i = 0;
        auto space = [&](std::size_t k) {
            return line[k] == ' ' || line[k] == '\t' || line[k] == '\r';
        };
        // Each pass of the outer loop consumes at least one character: bounded by the line.
        while (i < line.size()) {
            while (i < line.size() && space(i)) ++i;
            const std::size_t start = i;
            while (i < line.size() && !space(i)) ++i;
            if (i > start) out.push_back(line.substr(start, i - start));
        }
        return out;
    }

    static Type type_of(std::string_view name) {
        static const std::map<std::string_view, Type> types = {
            {"char", {1, true, false}},    {"int8", {1, true, false}},
            {"uchar", {1, false, false}},  {"uint8", {1, false, false}},
            {"short", {2, true, false}},   {"int16", {2, true, false}},
            {"ushort", {2, false, false}}, {"uint16", {2, false, false}},
            {"int", {4, true, false}},     {"int32", {4, true, false}},
            {"uint", {4, false, false}},   {"uint32", {4, false, false}},
            {"float", {4, true, true}},    {"float32", {4, true, true}},
            {"double", {8, true, true}},   {"float64", {8, true, true}}};
        const auto it = types.find(name);
        return it == types.end() ? Type{} : it->second;
    }

    void read_header() {
        // Each pass reads one line: bounded by the file's lines.
        while (true) {
            const auto w = words(next_line());
            if (w.empty()) fail("an empty header line");
            if (w[0] == "end_header") break;
            if (w[0] == "comment" || w[0] == "obj_info") continue;
            if (w[0] == "format") {
                if (w.size() != 3 || (w[1] != "ascii" && w[1] != "binary_little_endian" &&
                                      w[1] != "binary_big_endian"))
                    fail("expected 'format ascii|binary_little_endian|binary_big_endian 1.0'");
                format_ = std::string(w[1]);
            } else if (w[0] == "element") {
                Element e;
                if (w.size() != 3 || !parse_number(w[2], e.count) || e.count < 0 ||
                    e.count > std::numeric_limits<std::int32_t>::max())
                    fail("expected 'element NAME COUNT'");
                e.name = std::string(w[1]);
                e.line = line_;
                for (const Element& other : elements_)
                    if (other.name == e.name) fail("a second element '" + e.name + "'");
                elements_.push_back(std::move(e));
            } else if (w[0] == "property") {
                if (elements_.empty()) fail("a property before any element");
                Property p;
                if (w.size() >= 2 && w[1] == "list") {
                    if (w.size() != 5 || (p.count = type_of(w[2])).bytes == 0 || p.count.is_float ||
                        (p.item = type_of(w[3])).bytes == 0)
                        fail(
                            "expected 'property list COUNT_TYPE ITEM_TYPE NAME' with an "
                            "integer COUNT_TYPE");
                    p.name = std::string(w[4]);
                } else {
                    if (w.size() != 3 || (p.item = type_of(w[1])).bytes == 0)
                        fail("expected 'property TYPE NAME'");
                    p.name = std::string(w[2]);
                }
                Element& e = elements_.back();
                for (const Property& other : e.properties)
                    if (other.name == p.name)
                        fail("a second property '" + p.name + "' of element '" + e.name + "'");
                p.is_indices =
                    e.name == "face" && (p.name == "vertex_indices" || p.name == "vertex_index");
                e.properties.push_back(std::move(p));
            } else {
                fail("unknown header keyword '" + std::string(w[0]) +
                     "' (expected format, element, property, comment, obj_info or end_header)");
            }
        }
        if (format_.empty()) fail("the header has no 'format' line");
    }

    // The elements VTK reads, and the kinds of their properties.
    void check_layout() {
        const Element* vertex = find("vertex");
        if (vertex == nullptr) fail("the header has no 'element vertex'");
        for (const char* axis : {"x", "y", "z"}) {
            const Property* p = find_property(*vertex, axis);
            if (p == nullptr)
                fail_at(vertex->line,
                        "the vertex element has no property '" + std::string(axis) + "'");
        }
        for (const Property& p : vertex->properties)
            if (p.is_list())
                fail_at(vertex->line, "vertex property '" + p.name +
                                          "' is a list; only scalar vertex properties are read");
        const Element* face = find("face");
        if (face != nullptr) {
            const Property* indices = nullptr;
            for (const Property& p : face->properties) {
                if (p.is_indices) {
                    if (indices != nullptr)
                        fail_at(face->line,
                                "the face element has both vertex_indices and "
                                "vertex_index");
                    indices = &p;
                    if (!p.is_list() || p.item.is_float)
                        fail_at(face->line,
                                "face property '" + p.name + "' must be a list of an integer type");
                } else if (p.is_list()) {
                    fail_at(face->line, "face property '" + p.name +
                                            "' is a list; only the vertex index list is read");
                }
            }
            if (indices == nullptr)
                fail_at(face->line, "the face element has no 'property list ... vertex_indices'");
        }
        // VTK reads the elements in order and skips no data, so an element before vertex or
        // face shifts every read after it; one after both crashed vtkPLY::ply_close (found
        // by the test below). Only vertex and face are read: others are refused.
        for (const Element& e : elements_)
            if (e.name != "vertex" && e.name != "face")
                fail_at(e.line, "element '" + e.name + "': only vertex and face elements are read");
        vertex_count_ = vertex->count;
    }

    const Element* find(const std::string& name) const {
        for (const Element& e : elements_)
            if (e.name == name) return &e;
        return nullptr;
    }
    static const Property* find_property(const Element& e, const std::string& name) {
        for (const Property& p : e.properties)
            if (p.name == name) return &p;
        return nullptr;
    }

    [[noreturn]] void fail_item(const Element& e, long long i, const std::string& what) const {
        fail(e.name + " " + std::to_string(i) + ": " + what);
    }

    void check_index(const Element& e, long long i, long long index) const {
        if (index < 0 || index >= vertex_count_)
            fail_item(e, i,
                      "vertex index " + std::to_string(index) + " is not below the vertex count " +
                          std::to_string(vertex_count_));
    }

    void check_text_elements() {
        for (const Element& e : elements_) {
            // One line per element: bounded by the file's lines (next_line fails at its end).
            for (long long i = 0; i < e.count; ++i) {
                const auto w = words(next_line());
                std::size_t at = 0;
                for (const Property& p : e.properties) {
                    long long n = 1;
                    if (p.is_list()) {
                        if (at >= w.size() || !parse_number(w[at], n) || n < 0)
                            fail_item(e, i, "expected a list size");
                        if (n > kMaxListSize)
                            fail_item(
                                e, i,
                                "a list of " + std::to_string(n) + " items (at most 255 are read)");
                        ++at;
                    }
                    if (static_cast<long long>(w.size() - at) < n)
                        fail_item(e, i,
                                  "has " + std::to_string(w.size()) +
                                      " values; its properties need more");
                    if (p.is_indices)
                        for (long long k = 0; k < n; ++k) {
                            long long index = 0;
                            if (!parse_number(w[at + static_cast<std::size_t>(k)], index))
                                fail_item(e, i, "a vertex index that is not an integer");
                            check_index(e, i, index);
                        }
                    at += static_cast<std::size_t>(n);
                }
            }
        }
    }

    // The integer of `type` at text_[at].
    long long integer_at(std::size_t at, const Type& type, bool big_endian) const {
        const char* data = text_.data() + at;
        return type.is_signed
                   ? signed_from_bytes(data, type.bytes, big_endian)
                   : static_cast<long long>(unsigned_from_bytes(data, type.bytes, big_endian));
    }

    void check_binary_elements(bool big_endian) {
        const std::size_t size = text_.size();
        std::size_t at = pos_;
        auto need = [&](std::size_t bytes, const Element& e, long long i) {
            if (bytes > size || at > size - bytes) fail_item(e, i, "the binary data ends early");
        };
        for (const Element& e : elements_) {
            if (e.properties.empty()) continue;
            // Each element takes at least one byte (need() fails past the end): bounded.
            for (long long i = 0; i < e.count; ++i)
                for (const Property& p : e.properties) {
                    if (!p.is_list()) {
                        need(p.item.bytes, e, i);
                        at += p.item.bytes;
                        continue;
                    }
                    need(p.count.bytes, e, i);
                    const long long n = integer_at(at, p.count, big_endian);
                    at += p.count.bytes;
                    if (n < 0) fail_item(e, i, "a negative list size");
                    if (n > kMaxListSize)
                        fail_item(
                            e, i,
                            "a list of " + std::to_string(n) + " items (at most 255 are read)");
                    need(static_cast<std::size_t>(n) * p.item.bytes, e, i);
                    if (p.is_indices)
                        for (long long k = 0; k < n; ++k)
                            check_index(e, i,
                                        integer_at(at + static_cast<std::size_t>(k) * p.item.bytes,
                                                   p.item, big_endian));
                    at += static_cast<std::size_t>(n) * p.item.bytes;
                }
        }
    }

    std::string path_;
    std::string text_;
    std::size_t pos_ = 0;
    std::size_t line_ = 0;
    std::string rewritten_;  // a line as vtkPLY rewrites it (next_line)
    std::string format_;
    std::vector<Element> elements_;
    long long vertex_count_ = 0;
};

// --- VTK XML -----------------------------------------------------------------------------

// The bytes of one value of a VTK XML type name; 0 for String and unknown names. VTK 9.1's
// XML readers create arrays for these names only: for any other, vtkXMLReader::CreateArray
// gives null and ReadXMLInformation dereferences it (found by fuzz_mesh: type="Int10").
std::size_t xml_type_bytes(std::string_view type) {
    static const std::map<std::string_view, std::size_t> bytes = {
        {"Int8", 1},  {"UInt8", 1},  {"Int16", 2},   {"UInt16", 2},  {"Int32", 4}, {"UInt32", 4},
        {"Int64", 8}, {"UInt64", 8}, {"Float32", 4}, {"Float64", 8}, {"String", 0}};
    const auto it = bytes.find(type);
    return it == bytes.end() ? 0 : it->second;
}
bool is_known_xml_type(const char* type) {
    return type != nullptr &&
           (xml_type_bytes(type) > 0 || std::string_view(type) == std::string_view("String"));
}

std::string_view attribute(vtkXMLDataElement* e, const char* name) {
    const char* v = e->GetAttribute(name);
    return v == nullptr ? std::string_view() : std::string_view(v);
}

// The data of the arrays of a VTK XML file (ascii, base64 inline or raw appended) against
// the values their Piece needs. VTK 9.1 trusts what it finds there: it allocates a
// compressed block of the size its header gives (new[], found by fuzz_mesh with
// 0x61443c000000000c bytes), divides by the block size (SIGFPE on 0), and dereferences
// null when an array holds fewer values than its Piece counts or an ascii value does not
// parse (both found by fuzz_surface and fuzz_mesh).
class XmlData {
public:
    /// `appended`: where the AppendedData starts (0: none); `appended_base64`: it is not
    /// raw, which VTK reads as base64 whatever the encoding attribute says.
    XmlData(const std::string& path, vtkXMLDataParser* parser, std::int64_t appended,
            bool appended_base64)
        : path_(path),
          in_(path, std::ios::binary),
          parser_in_(path, std::ios::binary),
          parser_(parser),
          appended_(appended),
          appended_base64_(appended_base64) {
        // The parser reads array data from a stream of its own (its file's is closed).
        parser->SetStream(&parser_in_);
        vtkXMLDataElement* root = parser->GetRootElement();
        word_ = attribute(root, "header_type") == "UInt64" ? 8 : 4;
        big_endian_ = attribute(root, "byte_order") == "BigEndian";
        compressed_ = root->GetAttribute("compressor") != nullptr;
        // The compressors VTK's reader knows; for another name it reads no binary data.
        const std::string_view compressor = attribute(root, "compressor");
        if (compressor == "vtkZLibDataCompressor")
            parser->SetCompressor(vtkSmartPointer<vtkZLibDataCompressor>::New());
        else if (compressor == "vtkLZ4DataCompressor")
            parser->SetCompressor(vtkSmartPointer<vtkLZ4DataCompressor>::New());
        else if (compressor == "vtkLZMADataCompressor")
            parser->SetCompressor(vtkSmartPointer<vtkLZMADataCompressor>::New());
        in_.seekg(0, std::ios::end);
        size_ = static_cast<std::uint64_t>(in_.tellg());
        if (appended_ > 0 && appended_base64_) scan_appended_base64();
    }

    ~XmlData() { parser_->SetStream(nullptr); }
    XmlData(const XmlData&) = delete;
    XmlData& operator=(const XmlData&) = delete;

    /// Checks that the array `e` holds at least `values` values of its type, whatever its
    /// format (for a String array: at most `values` strings); the headers of its binary
    /// data are checked on the way.
    void check_array(vtkXMLDataElement* e, std::uint64_t values) {
        const std::string_view format = checked_format(e);
        if (attribute(e, "type") == "String") {
            check_headers(e);
            check_strings(e, values);
            return;
        }
        const std::size_t bytes = xml_type_bytes(attribute(e, "type"));
        if (format == "ascii") {
            check_ascii(e, values);
            return;
        }
        if (bytes == 0) return;  // String arrays: VTK reads them itself
        std::optional<std::uint64_t> held;
        if (format == "appended") {
            if (appended_ > 0) held = appended_bytes(e);
        } else if (format == "binary") {
            held = inline_bytes(e);
        }
        // Beyond the file the values cannot be; also keeps values * bytes from overflowing.
        if (values > size_) fail(e, "needs " + std::to_string(values) + " values");
        if (held && *held < values * bytes)
            fail(e, "holds " + std::to_string(*held) + " bytes; its piece needs " +
                        std::to_string(values) + " values of " + std::to_string(bytes) + " bytes");
    }

    /// Checks that the String array `e` holds at most `values` strings. VTK 9.1 reads the
    /// strings one after another, each ended by a NUL, into an array of `values` slots and
    /// writes past its end when there are more (heap-buffer-overflow in
    /// vtkXMLReader::ReadArrayValues, found by fuzz_surface: 3 NULs for 1 tuple). Ascii
    /// values are character codes. Bounded by the array's data, read in chunks.
    void check_strings(vtkXMLDataElement* e, std::uint64_t values) {
        const std::string_view format = checked_format(e);
        std::uint64_t strings = 0;
        auto count = [&](long long code) {
            if (code == 0) ++strings;
            if (strings > values)
                fail(e, "holds more than " + std::to_string(values) +
                            " strings (NUL-ended), its count");
        };
        if (format == "ascii") {
            std::uint64_t at = 0;
            if (!seek_inline_data(e, at)) return;
            std::uint64_t index = 0;
            std::string token;
            char c = 0;
            auto take = [&] {
                long long code = 0;
                if (!parse_number(std::string_view(token), code) || code < -128 || code > 255)
                    fail(e, "value " + std::to_string(index) + " '" + token +
                                "' is not a character code (-128 to 255)");
                count(code);
                ++index;
                token.clear();
            };
            // One character per pass, up to the element's end.
            while (in_.get(c) && c != '<') {
                if (!std::isspace(static_cast<unsigned char>(c))) {
                    token.push_back(c);
                    if (token.size() > 64) fail(e, "has a value longer than 64 characters");
                } else if (!token.empty()) {
                    take();
                }
            }
            if (!token.empty()) take();
            return;
        }
        std::uint64_t offset = 0;
        // Appended data raw or base64: the parser knows the encoding.
        if (format == "appended" && (parser_->GetAppendedDataPosition() <= 0 ||
                                     !parse_number(attribute(e, "offset"), offset)))
            return;  // the reader reports it
        if (compressed_ && parser_->GetCompressor() == nullptr) return;
        // VTK's own parser reads the bytes (inflating them if need be), a chunk per pass;
        // each pass reads a full chunk or ends the loop.
        constexpr std::size_t kChunk = std::size_t{1} << 16;
        std::vector<unsigned char> bytes(kChunk);
        for (std::uint64_t start = 0;; start += kChunk) {
            const std::size_t got =
                format == "binary"
                    ? parser_->ReadInlineData(e, 0, bytes.data(), start, kChunk, VTK_UNSIGNED_CHAR)
                    : parser_->ReadAppendedData(static_cast<vtkTypeInt64>(offset), bytes.data(),
                                                start, kChunk, VTK_UNSIGNED_CHAR);
            for (std::size_t i = 0; i < got && i < kChunk; ++i) count(bytes[i]);
            if (got < kChunk) break;
        }
    }

    /// Checks the data headers of an array whose count its Piece does not fix (a cell
    /// connectivity, a field array without NumberOfTuples).
    void check_headers(vtkXMLDataElement* e) {
        const std::string_view format = checked_format(e);
        if (format == "appended" && appended_ > 0) appended_bytes(e);
        if (format == "binary") inline_bytes(e);
    }

    /// The values of the integer array `e` (its first `limit`), when they can be read
    /// without inflating: ascii, or binary data that is not compressed. nullopt otherwise.
    /// Bounded by `limit` and the file.
    std::optional<std::vector<std::int64_t>> integers(vtkXMLDataElement* e, std::uint64_t limit) {
        const std::string_view format = checked_format(e);
        const std::string_view type = attribute(e, "type");
        const std::size_t bytes = xml_type_bytes(type);
        if (bytes == 0 || type.find("Int") == std::string_view::npos) return std::nullopt;
        std::vector<std::int64_t> values;
        if (format == "ascii") {
            std::uint64_t at = 0;
            if (!seek_inline_data(e, at)) return values;
            std::string token;
            char c = 0;
            // One character per pass, up to the element's end or `limit` values.
            while (values.size() < limit && in_.get(c) && c != '<') {
                if (!std::isspace(static_cast<unsigned char>(c)) && token.size() <= 64) {
                    token.push_back(c);
                    continue;
                }
                if (!token.empty()) values.push_back(ascii_integer(token));
                token.clear();
            }
            if (values.size() < limit && !token.empty()) values.push_back(ascii_integer(token));
            return values;
        }
        if (compressed_) return std::nullopt;
        std::string data;
        if (format == "appended" && !appended_base64_) {
            std::uint64_t offset = 0;
            if (appended_ <= 0 || !parse_number(attribute(e, "offset"), offset))
                return std::nullopt;
            std::uint64_t at = static_cast<std::uint64_t>(appended_) + offset;
            const std::uint64_t held = word(at, e);  // checked against the file before
            const std::uint64_t take = std::min({held, limit * bytes, size_ - at});
            data.resize(take);
            in_.clear();
            in_.seekg(static_cast<std::streamoff>(at));
            in_.read(data.data(), static_cast<std::streamsize>(take));
            if (!in_) return std::nullopt;
        } else {
            std::uint64_t at = 0;
            if (format == "appended") {  // base64 at the offset, checked by appended_bytes
                std::uint64_t offset = 0;
                if (appended_ <= 0 || !parse_number(attribute(e, "offset"), offset) ||
                    offset > appended_chars_)
                    return std::nullopt;
                in_.clear();
                in_.seekg(
                    static_cast<std::streamoff>(appended_ + static_cast<std::int64_t>(offset)));
            } else if (!seek_inline_data(e, at)) {
                return values;
            }
            // Uncompressed, the header word and the data are one base64 stream.
            std::string chars;
            char c = 0;
            const std::uint64_t want = 4 * ((word_ + limit * bytes + 2) / 3);
            while (chars.size() < want && in_.get(c) && c != '<')
                if (!std::isspace(static_cast<unsigned char>(c))) chars.push_back(c);
            chars.resize(chars.size() / 4 * 4);
            if (!decode_base64(chars, data)) return std::nullopt;
            if (data.size() < word_) return values;
            const std::uint64_t held = word_in(data, 0);
            data.erase(0, word_);
            if (data.size() > held) data.resize(held);
        }
        const std::size_t count = std::min<std::size_t>(data.size() / bytes, limit);
        const bool is_signed = type.front() == 'I';
        for (std::size_t i = 0; i < count; ++i) {
            const char* at = data.data() + i * bytes;
            values.push_back(
                is_signed ? signed_from_bytes(at, bytes, big_endian_)
                          : static_cast<std::int64_t>(unsigned_from_bytes(at, bytes, big_endian_)));
        }
        return values;
    }

    /// How many values the array `e` holds when that is known without inflating.
    std::optional<std::uint64_t> value_count(vtkXMLDataElement* e) {
        const std::string_view format = checked_format(e);
        const std::size_t bytes = xml_type_bytes(attribute(e, "type"));
        if (bytes == 0) return std::nullopt;
        if (format == "ascii") {
            std::uint64_t at = 0;
            if (!seek_inline_data(e, at)) return 0;
            std::uint64_t found = 0;
            bool in_token = false;
            char c = 0;
            while (in_.get(c) && c != '<') {  // one character per pass, bounded by the file
                const bool space = std::isspace(static_cast<unsigned char>(c)) != 0;
                if (!space && !in_token) ++found;
                in_token = !space;
            }
            return found;
        }
        std::optional<std::uint64_t> held;
        if (format == "appended" && appended_ > 0) held = appended_bytes(e);
        if (format == "binary") held = inline_bytes(e);
        if (!held) return std::nullopt;
        return *held / bytes;
    }

private:
    static std::int64_t ascii_integer(const std::string& token) {
        long long v = 0;
        std::string_view t(token);
        if (t.size() > 1 && t[0] == '+') t.remove_prefix(1);
        return parse_number(t, v) ? v : std::numeric_limits<std::int64_t>::max();
    }

    // The array's format; VTK dereferences null for an array without one (found by
    // fuzz_surface).
    std::string_view checked_format(vtkXMLDataElement* e) const {
        const std::string_view format = attribute(e, "format");
        if (format != "ascii" && format != "binary" && format != "appended")
            fail(e,
                 "has format \"" + std::string(format) + "\" (expected ascii, binary or appended)");
        return format;
    }

    [[noreturn]] void fail(vtkXMLDataElement* e, const std::string& what) const {
        const char* name = e->GetAttribute("Name");
        FM_THROW(InputError, in_quotes(path_) + ": " + e->GetName() + " '" +
                                 (name ? name : "(no name)") + "' " + what);
    }

    // The bytes of uncompressed data the raw appended header of `e` declares.
    std::optional<std::uint64_t> appended_bytes(vtkXMLDataElement* e) {
        std::uint64_t offset = 0;
        const std::string_view text = attribute(e, "offset");
        if (text.empty()) return {};  // the reader reports it
        // VTK reads the leading number of the text ("20=" as 20, found by fuzz_mesh: the
        // bytes there announced 77e12 compressed blocks); only a plain number is taken.
        if (!parse_number(text, offset))
            fail(e, "has offset \"" + std::string(text) + "\" (expected a whole number of bytes)");
        std::uint64_t at = static_cast<std::uint64_t>(appended_);
        if (appended_base64_) return appended_base64_bytes(e, offset);
        if (offset > size_ - std::min(size_, at)) fail(e, "starts past the end of the file");
        at += offset;
        if (!compressed_) {
            const std::uint64_t bytes = word(at, e);
            if (bytes > size_ - at)
                fail(e, "announces " + std::to_string(bytes) + " bytes, the file has " +
                            std::to_string(size_ - at) + " after it");
            return bytes;
        }
        const std::uint64_t blocks = word(at, e);
        const std::uint64_t block_size = word(at, e);
        const std::uint64_t last_size = word(at, e);
        if (blocks > (size_ - at) / word_)
            fail(e, "announces " + std::to_string(blocks) + " compressed blocks");
        check_block_sizes(e, blocks, block_size, last_size);
        std::uint64_t compressed = 0;
        // One header word per block: bounded by `blocks`, itself bounded by the file above.
        for (std::uint64_t b = 0; b < blocks; ++b) {
            compressed += word(at, e);
            if (compressed > size_) fail(e, "announces more compressed bytes than the file has");
        }
        if (compressed > size_ - at)
            fail(e, "announces " + std::to_string(compressed) + " compressed bytes, the file has " +
                        std::to_string(size_ - at) + " after its header");
        return uncompressed(blocks, block_size, last_size);
    }

    // AppendedData that is not raw is read by VTK as one run of base64 from its '_' on, each
    // array's streams at its offset in characters, with no white space skipped (a missing
    // or misspelled encoding attribute counts: found by fuzz_mesh, "encodkng" made VTK read
    // a base64 header announcing 4e9 blocks and allocate 16 GB). Its characters are checked
    // once here: base64, '=' only as the padding that ends a group of four (a stream may
    // start again after it), white space only at the end. One character per pass.
    void scan_appended_base64() {
        in_.clear();
        in_.seekg(appended_);
        std::uint64_t position = 0;
        std::uint64_t padding = 0;
        bool ended = false;  // white space seen: only white space may follow
        char c = 0;
        // The message is made only on failure: this runs once per character of the data.
        auto fail_at = [&](const std::string& what) {
            FM_THROW(InputError, in_quotes(path_) + ": AppendedData: base64 character " +
                                     std::to_string(position) + " " + what);
        };
        while (in_.get(c) && c != '<') {
            if (std::isspace(static_cast<unsigned char>(c))) {
                ended = true;
                continue;
            }
            if (ended)
                fail_at(
                    "follows white space inside the data (VTK reads appended base64 "
                    "without skipping any)");
            if (c == '=') {
                if (position % 4 < 2 || (position % 4 == 2 && padding > 0))
                    fail_at("is '=', which is not padding at the end of a group of four");
                ++padding;
            } else if (!is_base64(c)) {
                const auto byte = static_cast<unsigned char>(c);
                char code[8];
                std::snprintf(code, sizeof code, "0x%02x", byte);
                fail_at("is " +
                        (std::isprint(byte) ? "'" + std::string(1, c) + "'"
                                            : std::string("byte ") + code) +
                        ", which is not base64 (the AppendedData element is not "
                        "encoding=\"raw\", so VTK reads it as base64)");
            } else if (padding > 0) {
                fail_at("follows '=' padding inside a group of four");
            }
            ++position;
            if (position % 4 == 0) padding = 0;
        }
        if (position % 4 != 0)
            FM_THROW(InputError, in_quotes(path_) +
                                     ": AppendedData: the base64 data ends inside a group of four");
        appended_chars_ = position;
    }

    // `count` characters of the appended base64 from character `from`, decoded; fails when
    // the data has fewer.
    std::string appended_base64(vtkXMLDataElement* e, std::uint64_t from, std::uint64_t count) {
        if (from > appended_chars_ || appended_chars_ - from < count)
            fail(e, "announces more base64 data than the AppendedData holds (" +
                        std::to_string(appended_chars_) + " characters)");
        std::string chars(count, '\0');
        in_.clear();
        in_.seekg(appended_ + static_cast<std::int64_t>(from));
        in_.read(chars.data(), static_cast<std::streamsize>(count));
        std::string bytes;
        if (!in_ || !decode_base64(chars, bytes))
            FM_THROW(InputError, in_quotes(path_) + ": read failed");
        return bytes;
    }

    // The bytes of uncompressed data the base64 header at `offset` characters into the
    // AppendedData declares, bounded by the characters there (4 per 3 bytes).
    std::uint64_t appended_base64_bytes(vtkXMLDataElement* e, std::uint64_t offset) {
        auto chars_for = [](std::uint64_t bytes) { return 4 * ((bytes + 2) / 3); };
        if (offset > appended_chars_) fail(e, "starts past the end of the AppendedData");
        const std::uint64_t left = appended_chars_ - offset;  // characters from the offset
        if (!compressed_) {  // one stream: the header word, then the data
            const std::uint64_t bytes = word_in(appended_base64(e, offset, chars_for(word_)), 0);
            if (bytes > left / 4 * 3 || chars_for(word_ + bytes) > left)
                fail(e, "announces " + std::to_string(bytes) + " bytes, the AppendedData has " +
                            std::to_string(left) + " base64 characters after its offset");
            return bytes;
        }
        // The header (three words and one per block) is a stream; the data follows.
        const std::string head = appended_base64(e, offset, chars_for(3 * word_));
        const std::uint64_t blocks = word_in(head, 0);
        if (blocks > left / 4 * 3 / word_)
            fail(e, "announces " + std::to_string(blocks) + " compressed blocks");
        check_block_sizes(e, blocks, word_in(head, 1), word_in(head, 2));
        const std::uint64_t header_chars = chars_for((3 + blocks) * word_);
        const std::string header = appended_base64(e, offset, header_chars);
        std::uint64_t compressed = 0;
        for (std::uint64_t b = 0; b < blocks; ++b) {  // bounded by `blocks`, itself by the data
            compressed += word_in(header, 3 + b);
            if (compressed > left) fail(e, "announces more compressed bytes than the file has");
        }
        if (chars_for(compressed) > left - header_chars)
            fail(e, "announces " + std::to_string(compressed) +
                        " compressed bytes, more than the base64 after its header holds");
        return uncompressed(blocks, word_in(head, 1), word_in(head, 2));
    }

    // The bytes of uncompressed data the base64 header inline in `e` declares.
    std::optional<std::uint64_t> inline_bytes(vtkXMLDataElement* e) {
        std::uint64_t at = 0;
        if (!seek_inline_data(e, at)) return {};
        // Leading white space, then the base64 of the header: one word, or three words
        // when compressed (4 characters per 3 bytes). Bounded by the file.
        std::string chars;
        char c = 0;
        while (in_.get(c) && std::isspace(static_cast<unsigned char>(c))) {
        }
        if (in_) chars.push_back(c);
        const std::size_t words = compressed_ ? 3 : 1;
        const std::size_t need = 4 * ((words * word_ + 2) / 3);
        while (chars.size() < need && in_.get(c)) chars.push_back(c);
        std::string bytes;
        if (chars.size() < need || !decode_base64(chars, bytes))
            fail(e, "has no base64 header of " + std::to_string(words * word_) + " bytes");
        // The rest up to the element's end is base64 too: VTK dereferences null when its
        // decoding fails (a ',' in it, found by fuzz_surface) and when a '=' ends the
        // stream before the data it announces (found by fuzz_surface: "EAAAAA=AAAAC...").
        // Padding is one or two '=' closing the last group of four. One character per pass.
        // Compressed, the header (three words and one per block) is a stream of its own
        // and may end in padding too; the data's stream follows.
        const std::uint64_t first = word_in(bytes, 0);
        if (compressed_ && first > size_ - std::min(size_, at))
            fail(e, "announces " + std::to_string(first) + " compressed blocks");
        const std::uint64_t header_end = compressed_ ? 4 * (((3 + first) * word_ + 2) / 3) : 0;
        std::uint64_t position = 0;  // of the character in the stream, white space skipped
        std::uint64_t padding = 0;
        auto take = [&](char ch) {
            if (position == header_end) padding = 0;
            if (ch == '=') {
                if (position % 4 < 2 || padding == 2)
                    fail(e, "has '=' at base64 character " + std::to_string(position) +
                                ", which is not padding at the end of its data");
                ++padding;
            } else if (!is_base64(ch)) {
                fail(e, "holds '" + std::string(1, ch) + "', which is not base64");
            } else if (padding > 0) {
                fail(e, "has base64 data after its '=' padding at character " +
                            std::to_string(position));
            }
            ++position;
        };
        for (const char ch : chars) take(ch);
        while (in_.get(c) && c != '<')
            if (!std::isspace(static_cast<unsigned char>(c))) take(c);
        if (padding > 0 && position % 4 != 0)
            fail(e, "has '=' padding that does not close a group of four base64 characters");
        if (!compressed_) return first;
        // Each block needs a header word and at least a byte of data (checked above).
        check_block_sizes(e, first, word_in(bytes, 1), word_in(bytes, 2));
        return uncompressed(first, word_in(bytes, 1), word_in(bytes, 2));
    }

    // At least `values` numbers of the array's type in its ascii text.
    void check_ascii(vtkXMLDataElement* e, std::uint64_t values) {
        const std::string_view type = attribute(e, "type");
        if (type == "String") return;
        std::uint64_t at = 0;
        if (values == 0) return;
        if (!seek_inline_data(e, at))
            fail(e, "has no values; its piece needs " + std::to_string(values));
        std::uint64_t found = 0;
        std::string token;
        char c = 0;
        // One character per pass, up to the element's end ('<') or the values needed.
        while (found < values && in_.get(c) && c != '<') {
            if (!std::isspace(static_cast<unsigned char>(c))) {
                token.push_back(c);
                if (token.size() <= 64) continue;
                fail(e, "has a value longer than 64 characters");
            }
            if (token.empty()) continue;
            check_number(e, token, type, found);
            ++found;
            token.clear();
        }
        if (found < values && !token.empty()) {
            check_number(e, token, type, found);
            ++found;
        }
        if (found < values)
            fail(e, "holds " + std::to_string(found) + " values; its piece needs " +
                        std::to_string(values));
    }

    // One ascii value of an array of `type`. VTK 9.1 reads the values with `stream >> v`
    // into the array's C type (a short for Int8 and UInt8) and stops at the first that does
    // not fit; when that leaves the array short it dereferences null (a last CellData
    // array of type Int32 holding 12475941756269202993, found by fuzz_surface). A value is
    // taken here only inside its type's range: stricter than VTK, which also takes 300 as
    // an Int8 (44) and -1 as a UInt32 (4294967295).
    void check_number(vtkXMLDataElement* e, const std::string& token, std::string_view type,
                      std::uint64_t index) const {
        std::string_view t(token);
        if (t.size() > 1 && t[0] == '+') t.remove_prefix(1);
        const bool integer = type.find("Int") != std::string_view::npos;
        if (integer) {
            const std::size_t bits = 8 * xml_type_bytes(type);
            const bool is_unsigned = type.front() == 'U';
            long long v = 0;
            unsigned long long u = 0;
            bool fits = false;
            if (parse_number(t, v)) {
                const long long high_bits = bits >= 64 ? 0 : v >> (bits - (is_unsigned ? 0 : 1));
                fits = is_unsigned ? v >= 0 && high_bits == 0 : high_bits == 0 || high_bits == -1;
            } else if (parse_number(t, u)) {
                fits = is_unsigned && bits == 64;  // beyond the largest long long
            } else {
                fail(e, "value " + std::to_string(index) + " '" + token + "' is not an integer");
            }
            if (!fits)
                fail(e, "value " + std::to_string(index) + " '" + token +
                            "' is outside the range of " + std::string(type));
            return;
        }
        double v = 0;
        // Digits, sign, point and exponent only: no "nan" or "inf", which VTK's stream
        // extraction does not read; a Float32 beyond the largest float fails there too.
        if (!parse_number(t, v) || t.find_first_not_of("0123456789+-.eE") != t.npos)
            fail(e, "value " + std::to_string(index) + " '" + token + "' is not a number");
        if (type == "Float32" &&
            std::abs(v) > static_cast<double>(std::numeric_limits<float>::max()))
            fail(e, "value " + std::to_string(index) + " '" + token +
                        "' is outside the range of Float32");
    }

    // Positions the stream after the start tag of `e` (its XML byte index); false when the
    // element has no inline data ("<DataArray .../>").
    bool seek_inline_data(vtkXMLDataElement* e, std::uint64_t& at) {
        if (e->GetXMLByteIndex() < 0) return false;
        at = static_cast<std::uint64_t>(e->GetXMLByteIndex());
        in_.clear();
        in_.seekg(static_cast<std::streamoff>(at));
        // The end of the start tag: the first '>' outside quotes. Bounded by the file.
        char c = 0;
        char quote = 0;
        char last = 0;
        while (in_.get(c)) {
            ++at;
            if (quote != 0) {
                if (c == quote) quote = 0;
            } else if (c == '"' || c == '\'') {
                quote = c;
            } else if (c == '>') {
                break;
            }
            last = c;
        }
        return in_ && last != '/';
    }

    static std::uint64_t uncompressed(std::uint64_t blocks, std::uint64_t block_size,
                                      std::uint64_t last_size) {
        if (blocks == 0) return 0;
        return (blocks - 1) * block_size + (last_size == 0 ? block_size : last_size);
    }

    void check_block_sizes(vtkXMLDataElement* e, std::uint64_t blocks, std::uint64_t block_size,
                           std::uint64_t last_size) const {
        // VTK divides by the block size (a zero one crashed it with SIGFPE, found by
        // fuzz_mesh) and inflates each block into a buffer of its stated size: VTK writes
        // 32 KiB blocks, 2 GiB is far beyond any writer's.
        constexpr std::uint64_t kMaxBlock = std::uint64_t{1} << 31;
        if (blocks > 0 && block_size == 0) fail(e, "announces blocks of 0 bytes");
        // VTK's total is blocks * size, less size and plus the last block's size when that
        // is not 0, modulo 2^64: with no block and a last size that is neither 0 nor the
        // block size it wraps to a huge size and VTK reads block 0 of none (null
        // dereference, found by fuzz_mesh: 0 blocks of 32768 bytes, the last 4); a last
        // block larger than the others makes it read blocks past the header's list.
        if (last_size > block_size)
            fail(e, "announces a last block of " + std::to_string(last_size) +
                        " bytes, larger than its blocks of " + std::to_string(block_size));
        if (blocks == 0 && last_size != 0 && last_size != block_size)
            fail(e,
                 "announces no block but a last block of " + std::to_string(last_size) + " bytes");
        if (block_size > kMaxBlock || last_size > kMaxBlock)
            fail(e, "announces blocks of " + std::to_string(std::max(block_size, last_size)) +
                        " bytes (at most 2 GiB)");
    }

    std::uint64_t word_in(std::string_view bytes, std::size_t index) const {
        return unsigned_from_bytes(bytes.data() + index * word_, word_, big_endian_);
    }

    // The header word at `at`, advancing `at`.
    std::uint64_t word(std::uint64_t& at, vtkXMLDataElement* e) {
        if (at > size_ || size_ - at < word_) fail(e, "has a header cut by the end of the file");
        char bytes[8] = {};
        in_.clear();
        in_.seekg(static_cast<std::streamoff>(at));
        in_.read(bytes, static_cast<std::streamsize>(word_));
        if (!in_) FM_THROW(InputError, in_quotes(path_) + ": read failed");
        at += word_;
        return unsigned_from_bytes(bytes, word_, big_endian_);
    }

    static bool is_base64(char c) {
        return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
               c == '+' || c == '/';
    }

    // Standard base64 of `chars` (a multiple of 4; '=' padding read as zero bits).
    static bool decode_base64(const std::string& chars, std::string& bytes) {
        auto value = [](char c) -> int {
            if (c >= 'A' && c <= 'Z') return c - 'A';
            if (c >= 'a' && c <= 'z') return c - 'a' + 26;
            if (c >= '0' && c <= '9') return c - '0' + 52;
            if (c == '+') return 62;
            if (c == '/') return 63;
            if (c == '=') return 0;
            return -1;
        };
        for (std::size_t i = 0; i + 4 <= chars.size(); i += 4) {
            int v[4];
            for (int k = 0; k < 4; ++k)
                if ((v[k] = value(chars[i + static_cast<std::size_t>(k)])) < 0) return false;
            const std::uint32_t triple =
                static_cast<std::uint32_t>(v[0]) << 18 | static_cast<std::uint32_t>(v[1]) << 12 |
                static_cast<std::uint32_t>(v[2]) << 6 | static_cast<std::uint32_t>(v[3]);
            bytes.push_back(static_cast<char>(triple >> 16));
            bytes.push_back(static_cast<char>((triple >> 8) & 0xff));
            bytes.push_back(static_cast<char>(triple & 0xff));
        }
        return true;
    }

    std::string path_;
    std::ifstream in_;
    std::ifstream parser_in_;
    vtkXMLDataParser* parser_;
    std::int64_t appended_;
    bool appended_base64_;
    std::uint64_t appended_chars_ = 0;  // base64 characters of a non-raw AppendedData
    std::uint64_t size_ = 0;
    std::size_t word_ = 4;
    bool big_endian_ = false;
    bool compressed_ = false;
};

// A count attribute of a Piece ("NumberOfPoints" ...): 0 when absent, as VTK takes it.
std::uint64_t piece_count(const std::string& path, vtkXMLDataElement* piece, const char* name) {
    const std::string_view text = attribute(piece, name);
    std::uint64_t n = 0;
    if (text.empty()) return 0;
    if (!parse_number(text, n))
        FM_THROW(InputError, in_quotes(path) + ": Piece " + name + "=\"" + std::string(text) +
                                 "\" is not a count");
    return n;
}

// The components of an array: NumberOfComponents, 1 when absent.
std::uint64_t components(const std::string& path, vtkXMLDataElement* e) {
    const std::string_view text = attribute(e, "NumberOfComponents");
    std::uint64_t n = 1;
    if (!text.empty() && (!parse_number(text, n) || n == 0 || n > 1000000)) {
        const char* name = e->GetAttribute("Name");
        FM_THROW(InputError, in_quotes(path) + ": " + e->GetName() + " '" +
                                 (name ? name : "(no name)") + "' has NumberOfComponents \"" +
                                 std::string(text) + "\"");
    }
    return n;
}

// a * b, or the largest value when that overflows.
std::uint64_t saturated_product(std::uint64_t a, std::uint64_t b) {
    return b != 0 && a > std::numeric_limits<std::uint64_t>::max() / b
               ? std::numeric_limits<std::uint64_t>::max()
               : a * b;
}

// A cell section (Cells, Verts, Lines, Strips, Polys): VTK allocates and reads as many
// connectivity values as the last offset says (an ascii offset of 999999999 made it allocate
// 8 GB and spend 13 s under ASan), so every offset must lie within the connectivity held.
// Checked where both arrays can be read without inflating (ascii, uncompressed binary).
void check_cell_arrays(const std::string& path, vtkXMLDataElement* section, XmlData& data) {
    vtkXMLDataElement* offsets = nullptr;
    vtkXMLDataElement* connectivity = nullptr;
    for (int j = 0; j < section->GetNumberOfNestedElements(); ++j) {
        vtkXMLDataElement* e = section->GetNestedElement(j);
        if (e->GetName() == nullptr || std::string_view(e->GetName()) != "DataArray") continue;
        if (attribute(e, "Name") == "offsets") offsets = e;
        if (attribute(e, "Name") == "connectivity") connectivity = e;
    }
    if (offsets == nullptr || connectivity == nullptr) return;
    const auto held = data.value_count(connectivity);
    if (!held) return;
    // At most one offset per connectivity value and one more (a leading 0): more is not read.
    const auto values = data.integers(offsets, *held + 2);
    if (!values) return;
    for (std::size_t i = 0; i < values->size(); ++i) {
        const std::int64_t v = (*values)[i];
        if (v < 0 || static_cast<std::uint64_t>(v) > *held)
            FM_THROW(InputError,
                     in_quotes(path) + ": " + section->GetName() + " offsets value " +
                         std::to_string(i) + " is " +
                         (v == std::numeric_limits<std::int64_t>::max() ? std::string("not a count")
                                                                        : std::to_string(v)) +
                         "; the connectivity holds " + std::to_string(*held) + " values");
    }
}

// The arrays of one Piece against its counts.
void check_piece(const std::string& path, vtkXMLDataElement* piece, bool poly, XmlData& data) {
    const std::uint64_t points = piece_count(path, piece, "NumberOfPoints");
    std::uint64_t cells = 0;
    static const char* const kPolySections[] = {"Verts", "Lines", "Strips", "Polys"};
    if (poly) {
        for (const char* section : kPolySections)
            cells += piece_count(path, piece, (std::string("NumberOf") + section).c_str());
    } else {
        cells = piece_count(path, piece, "NumberOfCells");
    }
    for (int i = 0; i < piece->GetNumberOfNestedElements(); ++i) {
        vtkXMLDataElement* section = piece->GetNestedElement(i);
        const std::string_view name = section->GetName() ? section->GetName() : "";
        // The values each array of this section needs per component; none when its count
        // is not fixed here.
        std::optional<std::uint64_t> tuples;
        if (name == "Points" || name == "PointData") tuples = points;
        if (name == "CellData") tuples = cells;
        for (int j = 0; j < section->GetNumberOfNestedElements(); ++j) {
            vtkXMLDataElement* e = section->GetNestedElement(j);
            if (e->GetName() == nullptr || std::string_view(e->GetName()) != "DataArray") continue;
            const std::string_view array = attribute(e, "Name");
            std::optional<std::uint64_t> values;
            if (tuples) {
                values = saturated_product(*tuples, components(path, e));
            } else if (name == "Cells" && (array == "offsets" || array == "types")) {
                values = cells;
            } else if (array == "offsets") {
                for (const char* s : kPolySections)
                    if (name == s)
                        values = piece_count(path, piece, (std::string("NumberOf") + s).c_str());
            }
            if (values)
                data.check_array(e, *values);
            else
                data.check_headers(e);
        }
        check_cell_arrays(path, section, data);
    }
}

}  // namespace

void check_ply(const std::string& path) { PlyCheck(path, read_whole(path)).run(); }

void check_stl(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) FM_THROW(InputError, in_quotes(path) + ": cannot open");
    in.seekg(0, std::ios::end);
    const auto size = static_cast<std::uint64_t>(in.tellg());
    in.seekg(0);
    // VTK 9.1 reads the file as binary as vtksys::SystemTools::DetectFileType says: when 5%
    // or more of its first 256 bytes are not text (0x20..0x7f, tab, CR, LF), or it is empty.
    // (A vertical tab or form feed is white space to isspace() but binary here: a fuzzed
    // "solid" file with form feeds was read as binary and allocated its header's count.)
    std::string head(static_cast<std::size_t>(std::min<std::uint64_t>(size, 256)), '\0');
    in.read(head.data(), static_cast<std::streamsize>(head.size()));
    const auto text_bytes = std::count_if(head.begin(), head.end(), [](char c) {
        const auto u = static_cast<unsigned char>(c);
        return (u >= 0x20 && u <= 0x7f) || u == '\n' || u == '\r' || u == '\t';
    });
    const bool text =
        !head.empty() && static_cast<double>(head.size() - static_cast<std::size_t>(text_bytes)) /
                                 static_cast<double>(head.size()) <
                             0.05;
    if (text) return;
    if (size < 84)
        FM_THROW(InputError, in_quotes(path) +
                                 ": a binary STL needs at least 84 bytes, the file has " +
                                 std::to_string(size));
    const auto count = std::uint64_t(static_cast<unsigned char>(head[80])) |
                       std::uint64_t(static_cast<unsigned char>(head[81])) << 8 |
                       std::uint64_t(static_cast<unsigned char>(head[82])) << 16 |
                       std::uint64_t(static_cast<unsigned char>(head[83])) << 24;
    if (84 + 50 * count > size)
        FM_THROW(InputError, in_quotes(path) + ": the binary STL header counts " +
                                 std::to_string(count) + " triangles (" +
                                 std::to_string(84 + 50 * count) + " bytes), the file has " +
                                 std::to_string(size) + " bytes");
}

void check_vtk_xml(const std::string& path) {
    vtkNew<vtkXMLDataParser> parser;
    // The parser's own complaints are the reader's to report: swallowed here.
    vtkNew<vtkCallbackCommand> quiet;
    parser->AddObserver(vtkCommand::ErrorEvent, quiet);
    parser->AddObserver(vtkCommand::WarningEvent, quiet);
    parser->SetFileName(path.c_str());
    if (parser->Parse() == 0 || parser->GetRootElement() == nullptr) return;
    vtkXMLDataElement* root = parser->GetRootElement();
    // Every array's type name, wherever it is. An explicit stack, not recursion: a file may
    // nest deeply. Each element is pushed once.
    std::vector<vtkXMLDataElement*> stack = {root};
    while (!stack.empty()) {
        vtkXMLDataElement* element = stack.back();
        stack.pop_back();
        const std::string_view name = element->GetName() ? element->GetName() : "";
        auto check_type = [&](vtkXMLDataElement* e) {
            const char* type = e->GetAttribute("type");
            if (is_known_xml_type(type)) return;
            const char* array = e->GetAttribute("Name");
            FM_THROW(InputError, in_quotes(path) + ": the " +
                                     std::string(e->GetName() ? e->GetName() : "") + " '" +
                                     (array ? array : "(no name)") + "' has type '" +
                                     (type ? type : "") +
                                     "'; VTK knows Int8..UInt64, Float32, Float64 and String");
        };
        if (name == "DataArray" || name == "Array") check_type(element);
        // VTK reads every element inside these as an array, whatever its name: one without
        // a type dereferenced null in ReadXMLInformation (found by fuzz_mesh: "<DatAar
        // aytrype=...>" in FieldData).
        static const std::set<std::string_view> containers = {"FieldData", "PointData", "CellData",
                                                              "Points",    "Cells",     "Verts",
                                                              "Lines",     "Strips",    "Polys"};
        const bool container = containers.count(name) > 0;
        // Two arrays of one name in a PointData or CellData: VTK keeps one of them in its
        // output, then reads the other's element into the array index past the end (null
        // dereference in ReadArrayForCells, found by fuzz_surface).
        const bool attributes = name == "PointData" || name == "CellData";
        std::set<std::string_view> names;
        for (int i = 0; i < element->GetNumberOfNestedElements(); ++i) {
            vtkXMLDataElement* nested = element->GetNestedElement(i);
            if (container) check_type(nested);
            const std::string_view array = attribute(nested, "Name");
            if (attributes && !array.empty() && !names.insert(array).second)
                FM_THROW(InputError, in_quotes(path) + ": the " + std::string(name) +
                                         " holds two arrays named '" + std::string(array) + "'");
            stack.push_back(nested);
        }
    }
    // The headers of every array's binary data, wherever it is; then the data of each
    // Piece's arrays, and of the field arrays, against their counts. The dataset is read
    // by its element's name whatever the root's type says (VTK's reader does so: a root
    // type "UnstructuredGrof" passed its data to a SIGFPE, found by fuzz_mesh).
    std::int64_t appended = 0;
    bool appended_base64 = false;
    for (int i = 0; i < root->GetNumberOfNestedElements(); ++i) {
        vtkXMLDataElement* e = root->GetNestedElement(i);
        if (e->GetName() != nullptr && std::string_view(e->GetName()) == "AppendedData") {
            appended = parser->GetAppendedDataPosition();
            appended_base64 = attribute(e, "encoding") != "raw";  // as VTK's parser decides
        }
    }
    XmlData data(path, parser, appended, appended_base64);
    stack = {root};
    while (!stack.empty()) {
        vtkXMLDataElement* element = stack.back();
        stack.pop_back();
        if (element->GetName() != nullptr && std::string_view(element->GetName()) == "DataArray")
            data.check_headers(element);
        for (int i = 0; i < element->GetNumberOfNestedElements(); ++i)
            stack.push_back(element->GetNestedElement(i));
    }
    for (int i = 0; i < root->GetNumberOfNestedElements(); ++i) {
        vtkXMLDataElement* dataset = root->GetNestedElement(i);
        const std::string_view type = dataset->GetName() ? dataset->GetName() : "";
        if (type != "UnstructuredGrid" && type != "PolyData") continue;
        for (int j = 0; j < dataset->GetNumberOfNestedElements(); ++j) {
            vtkXMLDataElement* e = dataset->GetNestedElement(j);
            const std::string_view name = e->GetName() ? e->GetName() : "";
            if (name == "Piece") check_piece(path, e, type == "PolyData", data);
            if (name != "FieldData") continue;
            for (int k = 0; k < e->GetNumberOfNestedElements(); ++k) {
                vtkXMLDataElement* array = e->GetNestedElement(k);
                // VTK reads the leading number of NumberOfTuples ("16=" as 16): only a
                // plain count is taken, so that the array is checked against what VTK reads.
                std::uint64_t tuples = 0;
                const char* text = array->GetAttribute("NumberOfTuples");
                if (text != nullptr && !parse_number(std::string_view(text), tuples))
                    FM_THROW(InputError, in_quotes(path) + ": field array '" +
                                             std::string(attribute(array, "Name")) +
                                             "' has NumberOfTuples \"" + text +
                                             "\" (expected a count)");
                if (text != nullptr)
                    data.check_array(array, saturated_product(tuples, components(path, array)));
                else
                    data.check_headers(array);
            }
        }
    }
}

}  // namespace frontmesh::io
