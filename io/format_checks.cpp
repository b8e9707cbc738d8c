#include "io/format_checks.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <string_view>
#include <vector>

#include <vtkCallbackCommand.h>
#include <vtkCommand.h>
#include <vtkNew.h>
#include <vtkXMLDataElement.h>
#include <vtkXMLDataParser.h>

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
        // A '\r' of a CRLF file stays in vtkPLY's last word, where atoi and atof ignore it.
        return line.ends_with('\r') ? line.substr(0, line.size() - 1) : line;
    }

    // Words as vtkPLY splits them: at spaces and tabs.
    static std::vector<std::string_view> words(std::string_view line) {
        std::vector<std::string_view> out;
        std::size_t i = 0;
        // Each pass of the outer loop consumes at least one character: bounded by the line.
        while (i < line.size()) {
            while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
            const std::size_t start = i;
            while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
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
        std::uint64_t raw = 0;
        for (std::size_t b = 0; b < type.bytes; ++b) {
            const auto byte =
                static_cast<unsigned char>(text_[at + (big_endian ? b : type.bytes - 1 - b)]);
            raw = (raw << 8) | byte;
        }
        const std::uint64_t sign_bit = std::uint64_t{1} << (8 * type.bytes - 1);
        if (type.is_signed && (raw & sign_bit) != 0)
            return static_cast<long long>(raw) - static_cast<long long>(sign_bit << 1);
        return static_cast<long long>(raw);
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
    std::string format_;
    std::vector<Element> elements_;
    long long vertex_count_ = 0;
};

// --- VTK XML -----------------------------------------------------------------------------

// The type names VTK 9.1's XML readers create arrays for. For any other name
// vtkXMLReader::CreateArray gives null and ReadXMLInformation dereferences it (found by
// fuzz_mesh: type="Int10" in a FieldData DataArray).
bool is_known_xml_type(const char* type) {
    static const std::vector<std::string_view> known = {"Int8",    "UInt8",   "Int16", "UInt16",
                                                        "Int32",   "UInt32",  "Int64", "UInt64",
                                                        "Float32", "Float64", "String"};
    return type != nullptr && std::find(known.begin(), known.end(), type) != known.end();
}

// The binary data of a VTK XML file (raw appended, or base64 inline): where the appended
// part starts, how its header words read. VTK 9.1 trusts the sizes in these headers: it
// allocates a compressed block of the size its header gives (new[], found by fuzz_mesh
// with 0x61443c000000000c bytes), divides by the block size, and allocates the byte count
// an uncompressed header gives.
class BinaryData {
public:
    BinaryData(const std::string& path, vtkXMLDataElement* root, std::int64_t start)
        : path_(path), in_(path, std::ios::binary), start_(start) {
        const char* header_type = root->GetAttribute("header_type");
        word_ = header_type != nullptr && std::string_view(header_type) == "UInt64" ? 8 : 4;
        const char* order = root->GetAttribute("byte_order");
        big_endian_ = order != nullptr && std::string_view(order) == "BigEndian";
        compressed_ = root->GetAttribute("compressor") != nullptr;
        in_.seekg(0, std::ios::end);
        size_ = static_cast<std::uint64_t>(in_.tellg());
    }

    /// Checks the header of the array at `offset` (its attribute) against the file's size.
    void check(const std::string& array, const char* offset_text) {
        std::uint64_t offset = 0;
        if (offset_text == nullptr || !parse_number(std::string_view(offset_text), offset))
            return;  // the reader reports a missing or unreadable offset
        std::uint64_t at = static_cast<std::uint64_t>(start_);
        if (offset > size_ - std::min(size_, at)) fail(array, "starts past the end of the file");
        at += offset;
        if (!compressed_) {
            const std::uint64_t bytes = word(at, array);
            if (bytes > size_ - at)
                fail(array, "announces " + std::to_string(bytes) + " bytes, the file has " +
                                std::to_string(size_ - at) + " after it");
            return;
        }
        const std::uint64_t blocks = word(at, array);
        const std::uint64_t block_size = word(at, array);
        const std::uint64_t last_size = word(at, array);
        if (blocks > (size_ - at) / word_)
            fail(array, "announces " + std::to_string(blocks) + " compressed blocks");
        check_block_sizes(array, blocks, block_size, last_size);
        std::uint64_t compressed = 0;
        // One header word per block: bounded by `blocks`, itself bounded by the file above.
        for (std::uint64_t b = 0; b < blocks; ++b) {
            compressed += word(at, array);
            if (compressed > size_)
                fail(array, "announces more compressed bytes than the file has");
        }
        if (compressed > size_ - at)
            fail(array, "announces " + std::to_string(compressed) +
                            " compressed bytes, the file has " + std::to_string(size_ - at) +
                            " after its header");
    }

    /// Checks the header of a compressed array inline in base64 in the element whose start
    /// tag begins at `tag` (its XML byte index): what VTK decodes first, the block count
    /// and sizes.
    void check_inline(const std::string& array, std::int64_t tag) {
        if (!compressed_ || tag < 0) return;
        std::uint64_t at = static_cast<std::uint64_t>(tag);
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
        if (!in_ || last == '/') return;  // no inline data
        // Leading white space, then the base64 of three header words: 4 characters per 3
        // bytes, 3 * word_ bytes. Bounded by the file.
        std::string chars;
        while (in_.get(c) && std::isspace(static_cast<unsigned char>(c))) {
        }
        if (in_) chars.push_back(c);
        const std::size_t need = 4 * word_;
        while (chars.size() < need && in_.get(c)) chars.push_back(c);
        if (chars.size() < need) return;  // the reader reports a cut header
        std::string bytes;
        if (!decode_base64(chars, bytes)) return;  // the reader reports bad base64
        const std::string_view header(bytes);
        const std::uint64_t blocks = word_in(header, 0);
        // Each block needs a header word and at least a byte of data: 4/3 characters each.
        if (blocks > size_ - std::min(size_, at))
            fail(array, "announces " + std::to_string(blocks) + " compressed blocks");
        check_block_sizes(array, blocks, word_in(header, 1), word_in(header, 2));
    }

private:
    [[noreturn]] void fail(const std::string& array, const std::string& what) const {
        FM_THROW(InputError,
                 in_quotes(path_) + ": the binary data of array '" + array + "' " + what);
    }

    void check_block_sizes(const std::string& array, std::uint64_t blocks, std::uint64_t block_size,
                           std::uint64_t last_size) const {
        // VTK divides by the block size (a zero one crashed it with SIGFPE, found by
        // fuzz_mesh) and inflates each block into a buffer of its stated size: VTK writes
        // 32 KiB blocks, 2 GiB is far beyond any writer's.
        constexpr std::uint64_t kMaxBlock = std::uint64_t{1} << 31;
        if (blocks > 0 && block_size == 0) fail(array, "announces blocks of 0 bytes");
        if (block_size > kMaxBlock || last_size > kMaxBlock)
            fail(array, "announces blocks of " + std::to_string(std::max(block_size, last_size)) +
                            " bytes (at most 2 GiB)");
    }

    std::uint64_t word_in(std::string_view bytes, std::size_t index) const {
        std::uint64_t value = 0;
        for (std::size_t b = 0; b < word_; ++b) {
            const auto byte = static_cast<unsigned char>(
                bytes[index * word_ + (big_endian_ ? b : word_ - 1 - b)]);
            value = (value << 8) | byte;
        }
        return value;
    }

    // Standard base64 of `chars` (a multiple of 4, no padding inside) into `bytes`.
    static bool decode_base64(const std::string& chars, std::string& bytes) {
        auto value = [](char c) -> int {
            if (c >= 'A' && c <= 'Z') return c - 'A';
            if (c >= 'a' && c <= 'z') return c - 'a' + 26;
            if (c >= '0' && c <= '9') return c - '0' + 52;
            if (c == '+') return 62;
            if (c == '/') return 63;
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

    // The header word at `at`, advancing `at`.
    std::uint64_t word(std::uint64_t& at, const std::string& array) {
        if (at > size_ || size_ - at < word_)
            fail(array, "has a header cut by the end of the file");
        unsigned char bytes[8] = {};
        in_.clear();
        in_.seekg(static_cast<std::streamoff>(at));
        in_.read(reinterpret_cast<char*>(bytes), static_cast<std::streamsize>(word_));
        if (!in_) FM_THROW(InputError, in_quotes(path_) + ": read failed");
        at += word_;
        std::uint64_t value = 0;
        for (std::size_t b = 0; b < word_; ++b)
            value = (value << 8) | bytes[big_endian_ ? b : word_ - 1 - b];
        return value;
    }

    std::string path_;
    std::ifstream in_;
    std::int64_t start_;
    std::uint64_t size_ = 0;
    std::size_t word_ = 4;
    bool big_endian_ = false;
    bool compressed_ = false;
};

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
    bool raw_appended = false;
    for (int i = 0; i < root->GetNumberOfNestedElements(); ++i) {
        vtkXMLDataElement* e = root->GetNestedElement(i);
        const char* encoding = e->GetAttribute("encoding");
        raw_appended |= e->GetName() != nullptr &&
                        std::string_view(e->GetName()) == "AppendedData" && encoding != nullptr &&
                        std::string_view(encoding) == "raw" &&
                        parser->GetAppendedDataPosition() > 0;
    }
    BinaryData binary(path, root, raw_appended ? parser->GetAppendedDataPosition() : 0);
    // An explicit stack, not recursion: a file may nest deeply. Each element is pushed once.
    std::vector<vtkXMLDataElement*> stack = {root};
    while (!stack.empty()) {
        vtkXMLDataElement* element = stack.back();
        stack.pop_back();
        const char* name = element->GetName();
        if (name != nullptr &&
            (std::string_view(name) == "DataArray" || std::string_view(name) == "Array")) {
            const char* type = element->GetAttribute("type");
            if (!is_known_xml_type(type)) {
                const char* array = element->GetAttribute("Name");
                FM_THROW(InputError, in_quotes(path) + ": the " + name + " '" +
                                         (array ? array : "(no name)") + "' has type '" +
                                         (type ? type : "") +
                                         "'; VTK knows Int8..UInt64, Float32, Float64 and String");
            }
            const char* format = element->GetAttribute("format");
            const char* array = element->GetAttribute("Name");
            const std::string array_name = array ? array : "(no name)";
            if (raw_appended && format != nullptr && std::string_view(format) == "appended")
                binary.check(array_name, element->GetAttribute("offset"));
            if (format != nullptr && std::string_view(format) == "binary")
                binary.check_inline(array_name, element->GetXMLByteIndex());
        }
        for (int i = 0; i < element->GetNumberOfNestedElements(); ++i)
            stack.push_back(element->GetNestedElement(i));
    }
}

}  // namespace frontmesh::io
