#include "io/label_table.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <filesystem>
#include <fstream>
#include <set>
#include <vector>

#include "pipeline/core/error.h"

namespace frontmesh::io {
namespace {

constexpr std::size_t kMaxNameLength = 64;

std::string trimmed(const std::string& s) {
    std::size_t a = 0, b = s.size();
    while (a < b && std::isspace(static_cast<unsigned char>(s[a]))) ++a;
    while (b > a && std::isspace(static_cast<unsigned char>(s[b - 1]))) --b;
    return s.substr(a, b - a);
}

/// Splits at runs of whitespace and at commas (a quoted field stays whole, without quotes).
std::vector<std::string> fields_of(const std::string& line) {
    std::vector<std::string> out;
    std::string cur;
    bool in_field = false;
    for (std::size_t i = 0; i < line.size(); ++i) {
        const char c = line[i];
        if (c == '"') {
            const std::size_t end = line.find('"', i + 1);
            const std::size_t stop = end == std::string::npos ? line.size() : end;
            cur += line.substr(i + 1, stop - i - 1);
            in_field = true;
            i = stop;
        } else if (std::isspace(static_cast<unsigned char>(c)) || c == ',') {
            if (in_field) out.push_back(cur);
            cur.clear();
            in_field = false;
        } else {
            cur += c;
            in_field = true;
        }
    }
    if (in_field) out.push_back(cur);
    return out;
}

bool whole_number(const std::string& s, long long& value) {
    if (s.empty()) return false;
    const char* first = s.data() + (s[0] == '+' ? 1 : 0);
    const auto [ptr, ec] = std::from_chars(first, s.data() + s.size(), value);
    return ec == std::errc() && ptr == s.data() + s.size();
}

bool is_text_file(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return false;
    char buf[512];
    in.read(buf, sizeof buf);
    const std::streamsize n = in.gcount();
    for (std::streamsize i = 0; i < n; ++i) {
        const auto c = static_cast<unsigned char>(buf[i]);
        if (c == 0 || (c < 32 && c != '\n' && c != '\r' && c != '\t')) return false;
    }
    return n > 0;
}

}  // namespace

void LabelTable::set(core::Label label, const std::string& name) {
    names_[label] = name;
    safe_ready_ = false;
}

std::string LabelTable::name(core::Label label) const {
    const auto it = names_.find(label);
    return it != names_.end() ? it->second : "region_" + std::to_string(label);
}

Rgb LabelTable::colour(core::Label label) const {
    const auto it = colours_.find(label);
    return it != colours_.end() ? it->second : default_colour(label);
}

Rgb default_colour(core::Label label) {
    // Twelve well-separated colours (ColorBrewer "Paired", reordered so that neighbouring
    // labels differ in hue), grey for the background.
    static constexpr Rgb kPalette[12] = {{{31, 120, 180}},  {{227, 26, 28}},   {{51, 160, 44}},
                                         {{255, 127, 0}},   {{106, 61, 154}},  {{177, 89, 40}},
                                         {{166, 206, 227}}, {{251, 154, 153}}, {{178, 223, 138}},
                                         {{253, 191, 111}}, {{202, 178, 214}}, {{255, 255, 153}}};
    if (label <= 0) return {{128, 128, 128}};
    return kPalette[static_cast<std::size_t>(label - 1) % 12];
}

std::string LabelTable::safe_name(core::Label label) const {
    if (!safe_ready_) rebuild_safe_names();
    const auto it = safe_.find(label);
    return it != safe_.end() ? it->second : "region_" + std::to_string(label);
}

void LabelTable::rebuild_safe_names() const {
    // Deterministic: labels in increasing order; a clash keeps the first and suffixes the id.
    safe_.clear();
    std::set<std::string> used;
    for (const auto& [label, name] : names_) {
        std::string s = sanitized_name(name);
        if (used.count(s)) s = s.substr(0, kMaxNameLength - 12) + "_" + std::to_string(label);
        used.insert(s);
        safe_[label] = s;
    }
    safe_ready_ = true;
}

std::string sanitized_name(const std::string& name) {
    std::string s;
    for (const char c : name) {
        const bool ok =
            std::isalnum(static_cast<unsigned char>(c)) && static_cast<unsigned char>(c) < 128;
        if (ok)
            s += c;
        else if (!s.empty() && s.back() != '_')
            s += '_';
    }
    while (!s.empty() && s.back() == '_') s.pop_back();
    if (s.empty()) return "region";
    if (std::isdigit(static_cast<unsigned char>(s[0]))) s = "R_" + s;
    if (s.size() > kMaxNameLength) s.resize(kMaxNameLength);
    while (s.back() == '_') s.pop_back();
    return s;
}

LabelTable read_label_table(const std::string& path) {
    if (!std::filesystem::is_regular_file(path))
        FM_THROW(InputError, "label table " + path + ": no such file");
    if (!is_text_file(path))
        FM_THROW(InputError, "label table " + path +
                                 ": not a text file (binary colour maps such as mricron's .lut "
                                 "hold no names; use the .txt beside it)");
    std::ifstream in(path);
    if (!in) FM_THROW(InputError, "label table " + path + ": cannot be read");
    LabelTable table;
    std::string raw;
    int line_no = 0;
    bool seen_data = false;
    while (std::getline(in, raw)) {
        ++line_no;
        const std::string line = trimmed(raw);
        if (line.empty() || line[0] == '#' || line.rfind("//", 0) == 0) continue;
        const std::string where = path + ":" + std::to_string(line_no) + ": ";
        const std::vector<std::string> f = fields_of(line);
        long long id = 0;
        if (f.empty() || !whole_number(f[0], id)) {
            if (!seen_data && table.empty()) {  // a header line ("id,name", "No. Label Name")
                seen_data = true;
                continue;
            }
            FM_THROW(InputError, where + "expected a label id (whole number) first, got \"" +
                                     (f.empty() ? line : f[0]) + "\"");
        }
        seen_data = true;
        if (id < 0 || id > 2147483647LL)
            FM_THROW(InputError, where + "label id " + f[0] + " out of range (0 .. 2^31-1)");
        // ITK-SNAP: the name is the quoted field; otherwise the second field.
        std::string name;
        std::size_t rgb_at = 0;  // index in f of R G B, 0: none
        if (const std::size_t q = line.find('"'); q != std::string::npos) {
            const std::size_t e = line.find('"', q + 1);
            if (e == std::string::npos) FM_THROW(InputError, where + "unterminated quoted name");
            name = trimmed(line.substr(q + 1, e - q - 1));
            rgb_at = 1;
        } else if (f.size() >= 2) {
            // The words after the id up to the first number (R G B, an atlas' own code).
            name = f[1];
            long long ignored = 0;
            std::size_t i = 2;
            for (; i < f.size() && !whole_number(f[i], ignored); ++i) name += " " + f[i];
            rgb_at = i;
        }
        // Three whole numbers 0..255 there are a colour (an atlas' single code is not).
        Rgb rgb{};
        bool has_rgb = rgb_at > 0 && rgb_at + 3 <= f.size();
        for (std::size_t k = 0; has_rgb && k < 3; ++k) {
            long long c = 0;
            has_rgb = whole_number(f[rgb_at + k], c) && c >= 0 && c <= 255;
            rgb[k] = static_cast<std::uint8_t>(c);
        }
        if (name.empty()) FM_THROW(InputError, where + "label " + f[0] + " has no name");
        const auto label = static_cast<core::Label>(id);
        if (table.has(label))
            FM_THROW(InputError, where + "label " + f[0] + " listed twice (first as \"" +
                                     table.name(label) + "\")");
        table.set(label, name);
        if (has_rgb) table.set_colour(label, rgb);
    }
    if (table.empty()) FM_THROW(InputError, "label table " + path + ": no labels found");
    return table;
}

std::string label_table_beside(const std::string& image_path) {
    namespace fs = std::filesystem;
    fs::path p(image_path);
    if (p.extension() == ".gz") p.replace_extension();  // aal.nii.gz -> aal.nii
    fs::path stem = p;
    stem.replace_extension();  // aal.nii -> aal
    std::vector<fs::path> candidates;
    for (const char* ext : {".txt", ".lut"}) {
        candidates.push_back(fs::path(p.string() + ext));
        candidates.push_back(fs::path(stem.string() + ext));
    }
    std::stable_sort(candidates.begin(), candidates.end(),
                     [](const fs::path& a, const fs::path& b) {
                         return a.extension() == ".txt" && b.extension() != ".txt";
                     });
    std::error_code ec;  // NAME.nii.txt may be too long a name where NAME.nii is not
    for (const auto& c : candidates)
        if (fs::is_regular_file(c, ec) && is_text_file(c.string())) return c.string();
    return {};
}

}  // namespace frontmesh::io
