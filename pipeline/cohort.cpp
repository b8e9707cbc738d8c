#include "pipeline/cohort.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <thread>
#include <type_traits>

#include "io/atomic_file.h"
#include "pipeline/core/error.h"
#include "pipeline/core/input_file.h"
#include "pipeline/output_dir.h"
#include "pipeline/recipe.h"
#include "pipeline/report.h"
#include "pipeline/version.h"

namespace frontmesh::pipeline {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr const char* kSummaryCsv = "cohort-summary.csv";
constexpr const char* kSummaryJson = "cohort-summary.json";
constexpr const char* kRunLog = "cohort-run.log";

std::string trim(const std::string& text) {
    const auto first = text.find_first_not_of(" \t");
    if (first == std::string::npos) return {};
    return text.substr(first, text.find_last_not_of(" \t") - first + 1);
}

std::string read_text(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

// A YAML single-quoted scalar: paths reach the recipe through --set, whose values are YAML,
// and a path may hold ": ", "#", "[" or a leading "-".
std::string yaml_quote(const std::string& text) {
    std::string out = "'";
    for (char c : text) out += c == '\'' ? std::string("''") : std::string(1, c);
    return out + "'";
}

// A recipe error caused by an override names its origin as "--set: "; in a cohort the
// override is a manifest cell (or the cohort's own --set), named by the caller instead.
std::string without_set_origin(const std::string& message) {
    const std::string origin = "--set: ";
    return message.rfind(origin, 0) == 0 ? message.substr(origin.size()) : message;
}

bool is_safe_id(const std::string& id) {
    if (id.empty() || id.size() > 128 || !std::isalnum(static_cast<unsigned char>(id[0])))
        return false;
    return std::all_of(id.begin(), id.end(), [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-';
    });
}

// ---- a small JSON reader, for the subjects' summary.json ------------------------------

struct JsonMember;

struct JsonValue {
    enum class Kind { Null, Boolean, Number, String, Array, Object };
    Kind kind = Kind::Null;
    bool boolean = false;
    double number = 0.0;
    std::string text;
    std::vector<JsonValue> items;
    std::vector<JsonMember> members;

    const JsonValue* member(const std::string& key) const;
};

// A named struct, not std::pair<std::string, JsonValue>, defined after JsonValue: clang 14
// (the sanitizer build) refuses that pair inside JsonValue's own definition.
struct JsonMember {
    std::string name;
    JsonValue value;
};

const JsonValue* JsonValue::member(const std::string& key) const {
    for (const auto& [name, value] : members)
        if (name == key) return &value;
    return nullptr;
}

class JsonReader {
public:
    JsonReader(const std::string& text, const std::string& origin) : s_(text), origin_(origin) {}

    JsonValue document() {
        JsonValue v = value(0);
        skip_space();
        if (at_ != s_.size()) fail("text after the JSON value");
        return v;
    }

private:
    [[noreturn]] void fail(const std::string& what) const {
        FM_THROW(IoError,
                 origin_ + ": not valid JSON at byte " + std::to_string(at_) + ": " + what);
    }
    void skip_space() {
        while (at_ < s_.size() && std::strchr(" \t\r\n", s_[at_])) ++at_;
    }
    void expect(char c) {
        skip_space();
        if (at_ >= s_.size() || s_[at_] != c) fail(std::string("expected '") + c + "'");
        ++at_;
    }
    bool take(char c) {
        skip_space();
        if (at_ < s_.size() && s_[at_] == c) return ++at_, true;
        return false;
    }
    bool take_word(const char* word) {
        const std::size_t n = std::strlen(word);
        if (s_.compare(at_, n, word) != 0) return false;
        at_ += n;
        return true;
    }
    JsonValue value(int depth) {
        if (depth > 64) fail("nested too deeply");
        skip_space();
        if (at_ >= s_.size()) fail("unexpected end");
        JsonValue v;
        const char c = s_[at_];
        if (c == '{') {
            ++at_;
            v.kind = JsonValue::Kind::Object;
            if (take('}')) return v;
            do {
                skip_space();
                std::string key = string();
                expect(':');
                v.members.push_back(JsonMember{std::move(key), value(depth + 1)});
            } while (take(','));
            expect('}');
        } else if (c == '[') {
            ++at_;
            v.kind = JsonValue::Kind::Array;
            if (take(']')) return v;
            do v.items.push_back(value(depth + 1));
            while (take(','));
            expect(']');
        } else if (c == '"') {
            v.kind = JsonValue::Kind::String;
            v.text = string();
        } else if (take_word("true") || take_word("false")) {
            v.kind = JsonValue::Kind::Boolean;
            v.boolean = c == 't';
        } else if (take_word("null")) {
            v.kind = JsonValue::Kind::Null;
        } else {
            v.kind = JsonValue::Kind::Number;
            const char* begin = s_.data() + at_;
            const auto [end, error] = std::from_chars(begin, s_.data() + s_.size(), v.number);
            if (error != std::errc() || end == begin) fail("expected a value");
            at_ += static_cast<std::size_t>(end - begin);
        }
        return v;
    }
    unsigned hex4() {
        if (at_ + 4 > s_.size()) fail("short \\u escape");
        unsigned code = 0;
        const auto [end, error] = std::from_chars(s_.data() + at_, s_.data() + at_ + 4, code, 16);
        if (error != std::errc() || end != s_.data() + at_ + 4) fail("bad \\u escape");
        at_ += 4;
        return code;
    }
    static void append_utf8(std::string& out, unsigned code) {
        if (code < 0x80) {
            out += static_cast<char>(code);
        } else if (code < 0x800) {
            out += static_cast<char>(0xC0 | (code >> 6));
            out += static_cast<char>(0x80 | (code & 0x3F));
        } else if (code < 0x10000) {
            out += static_cast<char>(0xE0 | (code >> 12));
            out += static_cast<char>(0x80 | ((code >> 6) & 0x3F));
            out += static_cast<char>(0x80 | (code & 0x3F));
        } else {
            out += static_cast<char>(0xF0 | (code >> 18));
            out += static_cast<char>(0x80 | ((code >> 12) & 0x3F));
            out += static_cast<char>(0x80 | ((code >> 6) & 0x3F));
            out += static_cast<char>(0x80 | (code & 0x3F));
        }
    }
    std::string string() {
        if (at_ >= s_.size() || s_[at_] != '"') fail("expected a string");
        ++at_;
        std::string out;
        while (true) {
            if (at_ >= s_.size()) fail("unclosed string");
            const char c = s_[at_++];
            if (c == '"') return out;
            if (c != '\\') {
                out += c;
                continue;
            }
            if (at_ >= s_.size()) fail("unclosed string");
            const char e = s_[at_++];
            switch (e) {
                case '"':
                case '\\':
                case '/':
                    out += e;
                    break;
                case 'b':
                    out += '\b';
                    break;
                case 'f':
                    out += '\f';
                    break;
                case 'n':
                    out += '\n';
                    break;
                case 'r':
                    out += '\r';
                    break;
                case 't':
                    out += '\t';
                    break;
                case 'u': {
                    unsigned code = hex4();
                    if (code >= 0xD800 && code < 0xDC00 && s_.compare(at_, 2, "\\u") == 0) {
                        at_ += 2;
                        const unsigned low = hex4();
                        code = 0x10000 + ((code - 0xD800) << 10) + (low - 0xDC00);
                    }
                    append_utf8(out, code);
                    break;
                }
                default:
                    fail("bad escape");
            }
        }
    }

    const std::string& s_;
    std::string origin_;
    std::size_t at_ = 0;
};

// ---- running subjects -----------------------------------------------------------------

struct Job {
    std::size_t index = 0;  // in manifest order
    pid_t pid = -1;
    Clock::time_point start;
    fs::file_time_type written_since;  // a summary.json written after this is the run's
};

// The last "frontmesh: error:" line of a child's output, without that prefix.
std::string last_error_line(const fs::path& log) {
    std::ifstream in(log);
    std::string line, found;
    while (std::getline(in, line)) {
        if (!line.empty() && line.back() == '\r') line.pop_back();
        const std::string error = "frontmesh: error: ", internal = "frontmesh: internal error: ";
        if (line.rfind(error, 0) == 0)
            found = without_set_origin(line.substr(error.size()));
        else if (line.rfind(internal, 0) == 0)
            found = line.substr(std::strlen("frontmesh: "));
    }
    return found;
}

// The record of the subject's run in its summary.json (issue 22): the summary's path, the
// recipe file, the run's start and end, and the input image's dims and spacing. Only a
// summary.json written since `since` (by this run: a failed run may have left an older one
// in place) is read; a file that cannot be read leaves the fields empty.
void read_subject_record(SubjectResult& r, fs::file_time_type since) {
    const fs::path path = fs::path(r.dir) / "summary.json";
    std::error_code ec;
    const auto written = fs::last_write_time(path, ec);
    if (ec || written < since) return;
    JsonValue summary;
    try {
        summary = JsonReader(read_text(path), path.string()).document();
    } catch (const core::Error&) {
        return;  // read_subject_summary reports an unreadable summary of a run that exited 0
    }
    r.summary = path.string();
    auto text = [&](const JsonValue* object, const char* key) {
        const JsonValue* v = object ? object->member(key) : nullptr;
        return v && v->kind == JsonValue::Kind::String ? v->text : std::string();
    };
    r.recipe = text(&summary, "recipe");
    r.started = text(&summary, "started");
    r.finished = text(&summary, "finished");
    const JsonValue* image = summary.member("input_image");
    auto triple = [&](const char* key) -> std::optional<std::array<double, 3>> {
        const JsonValue* v = image ? image->member(key) : nullptr;
        if (!v || v->kind != JsonValue::Kind::Array || v->items.size() != 3) return std::nullopt;
        std::array<double, 3> out{};
        for (std::size_t k = 0; k < 3; ++k) {
            if (v->items[k].kind != JsonValue::Kind::Number) return std::nullopt;
            out[k] = v->items[k].number;
        }
        return out;
    };
    if (const auto dims = triple("dims"))
        r.image_dims = std::array<long long, 3>{static_cast<long long>((*dims)[0]),
                                                static_cast<long long>((*dims)[1]),
                                                static_cast<long long>((*dims)[2])};
    r.image_spacing_mm = triple("spacing_mm");
}

// Fills status and figures of a subject whose run exited 0 from its summary.json.
void read_subject_summary(SubjectResult& r) {
    const fs::path path = fs::path(r.dir) / "summary.json";
    if (!fs::exists(path)) {
        r.status = SubjectStatus::Failed;
        r.error = "the run exited 0 but wrote no " + path.string();
        return;
    }
    JsonValue summary;
    try {
        summary = JsonReader(read_text(path), path.string()).document();
    } catch (const core::Error& e) {
        r.status = SubjectStatus::Failed;
        r.error = e.what();
        return;
    }
    const JsonValue* status = summary.member("status");
    if (!status || status->text != "ok") {
        r.status = SubjectStatus::Failed;
        const JsonValue* error = summary.member("error");
        r.error = error && error->kind == JsonValue::Kind::String
                      ? error->text
                      : path.string() + ": status is not ok";
        return;
    }
    if (const JsonValue* total = summary.member("total_wall_s");
        total && total->kind == JsonValue::Kind::Number)
        r.total_wall_s = total->number;
    // Skipped: the run had stages to report and every one of them was up to date.
    bool any_ran = false, any_stage = false;
    const JsonValue* last = nullptr;
    if (const JsonValue* stages = summary.member("stages");
        stages && stages->kind == JsonValue::Kind::Array)
        for (const JsonValue& stage : stages->items) {
            any_stage = true;
            const JsonValue* s = stage.member("status");
            any_ran |= !s || s->text != "skipped";
            last = &stage;
        }
    r.status = any_stage && !any_ran ? SubjectStatus::Skipped : SubjectStatus::Ok;
    if (const JsonValue* regions = summary.member("regions");
        regions && regions->kind == JsonValue::Kind::Array)
        for (const JsonValue& region : regions->items) {
            const JsonValue* label = region.member("label");
            const JsonValue* name = region.member("name");
            if (!label || label->kind != JsonValue::Kind::Number) continue;
            std::string text = std::to_string(static_cast<long long>(label->number));
            if (name && name->kind == JsonValue::Kind::String) text += ":" + name->text;
            r.region_names.push_back(text);
        }
    if (const JsonValue* outputs = summary.member("outputs");
        outputs && outputs->kind == JsonValue::Kind::Array)
        for (const JsonValue& output : outputs->items)
            if (const JsonValue* file = output.member("file");
                file && file->kind == JsonValue::Kind::String &&
                file->text.find('/') == std::string::npos)
                r.outputs.push_back(file->text);
    if (const JsonValue* quality = last ? last->member("quality") : nullptr) {
        auto number = [](const JsonValue* object, const char* key) -> std::optional<double> {
            const JsonValue* v = object ? object->member(key) : nullptr;
            if (!v || v->kind != JsonValue::Kind::Number) return std::nullopt;
            return v->number;
        };
        auto count = [&](const JsonValue* object, const char* key) -> std::optional<long long> {
            const auto v = number(object, key);
            return v ? std::optional<long long>(static_cast<long long>(*v)) : std::nullopt;
        };
        r.faces = count(quality, "faces");
        r.regions = count(quality, "regions");
        r.regions_closed = count(quality, "regions_closed");
        // A tetrahedral result (tet_report): boundary faces, regions as a list, tet quality.
        if (const auto tets = count(quality, "tets")) {
            r.tets = tets;
            r.nodes = count(quality, "nodes");
            r.faces = count(quality, "boundary_faces");
            if (const JsonValue* regions = quality->member("regions");
                regions && regions->kind == JsonValue::Kind::Array)
                r.regions = static_cast<long long>(regions->items.size());
            const JsonValue* tet_quality = quality->member("quality");
            r.skewness_over_08 = number(tet_quality, "fraction_skewness_over_0.8");
            r.min_dihedral_deg = number(tet_quality, "min_dihedral_deg");
        }
    }
}

pid_t spawn_subject(const std::string& executable, const std::vector<std::string>& args,
                    const fs::path& log, std::string& error) {
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(),
                                     O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
    pid_t pid = -1;
    const int rc = posix_spawn(&pid, executable.c_str(), &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    if (rc != 0) {
        error = "cannot start '" + executable + "': " + std::strerror(rc);
        return -1;
    }
    return pid;
}

std::string format_seconds(double seconds) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.1f", seconds);
    return buf;
}

std::string csv_field(const std::string& text) {
    if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
    std::string out = "\"";
    for (char c : text) out += c == '"' ? std::string("\"\"") : std::string(1, c);
    return out + "\"";
}

template <typename T>
std::string optional_text(const std::optional<T>& value) {
    if (!value) return {};
    if constexpr (std::is_floating_point_v<T>) {
        char buf[32];
        std::snprintf(buf, sizeof buf, "%.3f", *value);
        return buf;
    } else {
        return std::to_string(*value);
    }
}

template <typename T>
std::string optional_json(const std::optional<T>& value) {
    if (!value) return "null";
    if constexpr (std::is_floating_point_v<T>)
        return json_number(*value);
    else
        return std::to_string(*value);
}

std::string json_list(const std::vector<std::string>& items) {
    std::string text = "[";
    for (std::size_t i = 0; i < items.size(); ++i) text += (i ? ", " : "") + json_quote(items[i]);
    return text + "]";
}

template <typename T>
std::string json_triple(const std::optional<std::array<T, 3>>& triple) {
    if (!triple) return "null";
    std::string text = "[";
    for (std::size_t k = 0; k < 3; ++k) {
        if constexpr (std::is_floating_point_v<T>)
            text += (k ? ", " : "") + json_number((*triple)[k]);
        else
            text += (k ? ", " : "") + std::to_string((*triple)[k]);
    }
    return text + "]";
}

std::string json_text_or_null(const std::string& text) {
    return text.empty() ? std::string("null") : json_quote(text);
}

void write_summaries(const CohortResult& result, const Manifest& manifest,
                     const std::string& recipe, int jobs) {
    std::ostringstream csv;
    auto joined = [](const std::vector<std::string>& items) {
        std::string text;
        for (const auto& item : items) text += (text.empty() ? "" : ";") + item;
        return text;
    };
    auto triple_text = [](const auto& triple) {
        if (!triple) return std::string();
        std::ostringstream out;
        out << (*triple)[0] << ';' << (*triple)[1] << ';' << (*triple)[2];
        return out.str();
    };
    csv << "id,status,exit_code,wall_s,total_wall_s,faces,regions,regions_closed,nodes,tets,"
           "fraction_skewness_over_0.8,min_dihedral_deg,region_names,outputs,image,started,"
           "finished,image_dims,image_spacing_mm,summary,recipe,error\n";
    for (const auto& r : result.subjects)
        csv << csv_field(r.id) << ',' << subject_status_name(r.status) << ',' << r.exit_code << ','
            << optional_text(std::optional<double>(r.wall_s)) << ','
            << optional_text(r.total_wall_s) << ',' << optional_text(r.faces) << ','
            << optional_text(r.regions) << ',' << optional_text(r.regions_closed) << ','
            << optional_text(r.nodes) << ',' << optional_text(r.tets) << ','
            << optional_text(r.skewness_over_08) << ',' << optional_text(r.min_dihedral_deg) << ','
            << csv_field(joined(r.region_names)) << ',' << csv_field(joined(r.outputs)) << ','
            << csv_field(r.image) << ',' << csv_field(r.started) << ',' << csv_field(r.finished)
            << ',' << triple_text(r.image_dims) << ',' << triple_text(r.image_spacing_mm) << ','
            << csv_field(r.summary) << ',' << csv_field(r.recipe) << ',' << csv_field(r.error)
            << '\n';
    io::write_text_atomically((fs::path(result.root) / kSummaryCsv).string(), csv.str());

    std::ostringstream json;
    json << "{\n  \"frontmesh_version\": " << json_quote(version())
         << ",\n  \"manifest\": " << json_quote(manifest.path)
         << ",\n  \"recipe\": " << json_quote(recipe)
         << ",\n  \"root\": " << json_quote(result.root) << ",\n  \"jobs\": " << jobs
         << ",\n  \"counts\": {\"ok\": " << result.count(SubjectStatus::Ok)
         << ", \"skipped\": " << result.count(SubjectStatus::Skipped)
         << ", \"failed\": " << result.count(SubjectStatus::Failed) << "},\n  \"subjects\": [";
    for (std::size_t i = 0; i < result.subjects.size(); ++i) {
        const auto& r = result.subjects[i];
        json << (i ? ",\n    " : "\n    ") << "{\"id\": " << json_quote(r.id)
             << ", \"status\": " << json_quote(subject_status_name(r.status))
             << ", \"exit_code\": " << r.exit_code << ", \"wall_s\": " << json_number(r.wall_s)
             << ", \"total_wall_s\": " << optional_json(r.total_wall_s)
             << ", \"faces\": " << optional_json(r.faces)
             << ", \"regions\": " << optional_json(r.regions)
             << ", \"regions_closed\": " << optional_json(r.regions_closed)
             << ", \"nodes\": " << optional_json(r.nodes) << ", \"tets\": " << optional_json(r.tets)
             << ", \"fraction_skewness_over_0.8\": " << optional_json(r.skewness_over_08)
             << ", \"min_dihedral_deg\": " << optional_json(r.min_dihedral_deg)
             << ",\n     \"region_names\": " << json_list(r.region_names)
             << ", \"outputs\": " << json_list(r.outputs)
             << ",\n     \"image\": " << json_quote(manifest.subjects[i].image)
             << ", \"image_dims\": " << json_triple(r.image_dims)
             << ", \"image_spacing_mm\": " << json_triple(r.image_spacing_mm)
             << ",\n     \"started\": " << json_text_or_null(r.started)
             << ", \"finished\": " << json_text_or_null(r.finished)
             << ", \"summary\": " << json_text_or_null(r.summary)
             << ", \"recipe\": " << json_text_or_null(r.recipe)
             << ", \"dir\": " << json_quote(r.dir)
             << ", \"log\": " << json_quote((fs::path(r.dir) / kRunLog).string())
             << ", \"error\": " << (r.error.empty() ? std::string("null") : json_quote(r.error))
             << "}";
    }
    json << "\n  ]\n}\n";
    io::write_text_atomically((fs::path(result.root) / kSummaryJson).string(), json.str());
}

// Overrides of one subject's run, in order: the cohort's --set, the subject's image and
// folder, then the manifest's cells (the most specific wins).
std::vector<std::string> subject_overrides(const CohortOptions& options,
                                           const CohortSubject& subject, const std::string& image,
                                           const std::string& dir) {
    std::vector<std::string> all = options.overrides;
    all.push_back("input.image=" + yaml_quote(image));
    all.push_back("output.dir=" + yaml_quote(dir));
    for (const auto& [key, value] : subject.overrides) all.push_back(key + "=" + value);
    return all;
}

bool is_existing_image(const std::string& image) {
    std::error_code ec;  // a name too long to stat is reported as missing, not thrown
    return fs::exists(image, ec) ||
           image.find('%') != std::string::npos;  // a slice pattern is checked by the run
}

}  // namespace

std::vector<std::pair<int, std::vector<std::string>>> parse_csv(const std::string& input,
                                                                const std::string& origin) {
    std::size_t i = input.compare(0, 3, "\xEF\xBB\xBF") == 0 ? 3 : 0;
    const std::size_t n = input.size();
    std::vector<std::pair<int, std::vector<std::string>>> records;
    std::vector<std::string> fields;
    std::string field;
    bool quoted = false, record_has_quote = false;
    int line = 1, record_line = 1;
    auto end_field = [&] {
        fields.push_back(quoted ? field : trim(field));
        field.clear();
        quoted = false;
    };
    auto end_record = [&] {
        end_field();
        const bool blank = fields.size() == 1 && fields[0].empty() && !record_has_quote;
        if (!blank) records.emplace_back(record_line, std::move(fields));
        fields.clear();
        record_has_quote = false;
    };
    while (i < n) {
        const char c = input[i];
        if (c == '"' && !quoted && trim(field).empty()) {
            // A quoted field: commas and line breaks inside are text, "" is one quote.
            const int quote_line = line;
            field.clear();
            quoted = record_has_quote = true;
            ++i;
            while (true) {
                if (i >= n)
                    FM_THROW(InputError, origin + ":" + std::to_string(quote_line) +
                                             ": a quoted field is not closed");
                if (input[i] == '"') {
                    if (i + 1 < n && input[i + 1] == '"') {
                        field += '"';
                        i += 2;
                        continue;
                    }
                    ++i;
                    break;
                }
                if (input[i] == '\n') ++line;
                field += input[i++];
            }
            while (i < n && (input[i] == ' ' || input[i] == '\t')) ++i;
            if (i < n && input[i] != ',' && input[i] != '\n' && input[i] != '\r')
                FM_THROW(InputError,
                         origin + ":" + std::to_string(line) +
                             ": text after the closing quote of a field; write a quote inside a "
                             "quoted field as \"\"");
            continue;
        }
        if (c == ',') {
            end_field();
            ++i;
        } else if (c == '\n' || c == '\r') {
            i += c == '\r' && i + 1 < n && input[i + 1] == '\n' ? 2 : 1;
            end_record();
            record_line = ++line;
        } else {
            if (quoted)
                FM_THROW(InputError, origin + ":" + std::to_string(line) +
                                         ": text after the closing quote of a field");
            field += c;
            ++i;
        }
    }
    if (!fields.empty() || !field.empty() || quoted) end_record();
    return records;
}

Manifest read_manifest(const std::string& path) {
    core::require_input_file(path, "manifest ");  // a named pipe would block the read
    Manifest m;
    m.path = fs::absolute(path).lexically_normal().string();
    const auto records = parse_csv(read_text(path), path);
    if (records.empty())
        FM_THROW(InputError,
                 path + ": the manifest is empty; its first line names the columns, e.g. id,image");
    m.header_line = records.front().first;
    const std::string at_header = path + ":" + std::to_string(m.header_line) + ": ";
    m.columns = records.front().second;
    int id_column = -1, image_column = -1;
    for (std::size_t c = 0; c < m.columns.size(); ++c) {
        const std::string& name = m.columns[c];
        if (name.empty())
            FM_THROW(InputError, at_header + "column " + std::to_string(c + 1) + " has no name");
        if (std::find(m.columns.begin(), m.columns.begin() + static_cast<long>(c), name) !=
            m.columns.begin() + static_cast<long>(c))
            FM_THROW(InputError, at_header + "column '" + name + "' appears twice");
        if (name == "id")
            id_column = static_cast<int>(c);
        else if (name == "image")
            image_column = static_cast<int>(c);
        else if (name == "input.image")
            FM_THROW(InputError,
                     at_header +
                         "column 'input.image': give each subject's image in the 'image' column");
        else if (name == "output.dir")
            FM_THROW(InputError,
                     at_header +
                         "column 'output.dir': each subject's results go to OUTPUT/ID below the "
                         "recipe's output.dir; set that in the recipe or with --set");
    }
    if (id_column < 0 || image_column < 0) {
        std::string found;
        for (const auto& name : m.columns) found += (found.empty() ? "" : ", ") + name;
        FM_THROW(InputError, at_header + "no '" + (id_column < 0 ? "id" : "image") +
                                 "' column; the header needs id and image (found: " + found + ")");
    }

    std::map<std::string, int> id_lines;
    const fs::path folder = fs::path(m.path).parent_path();
    for (std::size_t r = 1; r < records.size(); ++r) {
        const auto& [line, fields] = records[r];
        const std::string at = path + ":" + std::to_string(line) + ": ";
        if (fields.size() != m.columns.size())
            FM_THROW(InputError,
                     at + std::to_string(fields.size()) + " fields, but the header has " +
                         std::to_string(m.columns.size()) + " (quote a field that holds a comma)");
        CohortSubject s;
        s.line = line;
        s.id = fields[static_cast<std::size_t>(id_column)];
        if (s.id.empty()) FM_THROW(InputError, at + "the id is empty");
        if (!is_safe_id(s.id))
            FM_THROW(InputError, at + "id '" + s.id +
                                     "' cannot be a folder name; use letters, digits, '.', '_' and "
                                     "'-', starting with a letter or digit");
        if (s.id == kSummaryCsv || s.id == kSummaryJson)
            FM_THROW(InputError, at + "id '" + s.id + "' is the name of the cohort's summary file");
        if (const auto [it, fresh] = id_lines.emplace(s.id, line); !fresh)
            FM_THROW(InputError,
                     at + "id '" + s.id + "' is also on line " + std::to_string(it->second));
        const std::string& image = fields[static_cast<std::size_t>(image_column)];
        if (image.empty()) FM_THROW(InputError, at + "subject '" + s.id + "' has an empty image");
        fs::path p(image);
        if (p.is_relative()) p = folder / p;
        s.image = p.lexically_normal().string();
        for (std::size_t c = 0; c < fields.size(); ++c)
            if (static_cast<int>(c) != id_column && static_cast<int>(c) != image_column &&
                !fields[c].empty())
                s.overrides.emplace_back(m.columns[c], fields[c]);
        m.subjects.push_back(std::move(s));
    }
    if (m.subjects.empty())
        FM_THROW(InputError, path + ": no subjects; the manifest has only its header line");
    return m;
}

const char* subject_status_name(SubjectStatus status) {
    switch (status) {
        case SubjectStatus::Ok:
            return "ok";
        case SubjectStatus::Skipped:
            return "skipped";
        case SubjectStatus::Failed:
            return "failed";
    }
    return "failed";
}

std::size_t CohortResult::count(SubjectStatus status) const {
    return static_cast<std::size_t>(
        std::count_if(subjects.begin(), subjects.end(),
                      [&](const SubjectResult& r) { return r.status == status; }));
}

CohortResult run_cohort(const std::string& manifest_path, const CohortOptions& options) {
    if (options.jobs < 1)
        FM_THROW(InputError,
                 "-j " + std::to_string(options.jobs) + ": expected a whole number >= 1");
    if (options.recipe.empty()) FM_THROW(InputError, "cohort: needs a recipe (--recipe R.yaml)");
    const Manifest manifest = read_manifest(manifest_path);
    std::error_code ec;
    const std::string recipe_path = fs::exists(options.recipe, ec)
                                        ? fs::absolute(options.recipe).lexically_normal().string()
                                        : options.recipe;

    // 1. The recipe with the cohort's --set. Its input.image is replaced per subject, so an
    //    existing stand-in (the manifest) lets it validate; its output.dir is the root.
    std::vector<std::string> base = options.overrides;
    base.push_back("input.image=" + yaml_quote(manifest.path));
    CohortResult result;
    result.root = load_recipe(recipe_path, base).output.dir;

    // 2. Every key column, with the recipe's did-you-mean, even when all its cells are empty.
    const auto keys = recipe_keys();
    const std::string at_header = manifest_path + ":" + std::to_string(manifest.header_line) + ": ";
    for (const auto& column : manifest.columns) {
        if (column == "id" || column == "image") continue;
        if (std::any_of(keys.begin(), keys.end(), [&](const auto& k) { return k.key == column; }))
            continue;
        std::vector<std::string> probe = base;
        probe.push_back(column + "=null");
        try {
            load_recipe(recipe_path, probe);
        } catch (const core::InputError& e) {
            FM_THROW(InputError, at_header + "column " + without_set_origin(e.what()));
        }
        FM_THROW(InputError, at_header + "column '" + column + "' is not a recipe key");
    }

    // 3. Every subject's recipe, before anything runs. A missing image is the subject's own
    //    failure (recorded when it runs), so it validates with the stand-in.
    for (const auto& subject : manifest.subjects) {
        const std::string dir = (fs::path(result.root) / subject.id).string();
        const std::string image = is_existing_image(subject.image) ? subject.image : manifest.path;
        try {
            load_recipe(recipe_path, subject_overrides(options, subject, image, dir));
        } catch (const core::InputError& e) {
            FM_THROW(InputError, manifest_path + ":" + std::to_string(subject.line) +
                                     ": subject '" + subject.id +
                                     "': " + without_set_origin(e.what()));
        }
    }

    // 4. Run, `jobs` subjects at a time; rows stay in manifest order.
    const std::size_t total = manifest.subjects.size();
    result.subjects.resize(total);
    remove_stale_temp_files(result.root);  // of a killed cohort: its summaries' temp files
    claim_output_dir(result.root);
    std::size_t next = 0, finished = 0;
    std::vector<Job> running;
    auto report = [&](const SubjectResult& r) {
        ++finished;
        if (!options.on_progress) return;
        std::string line =
            "[" + std::to_string(finished) + "/" + std::to_string(total) + "] " + r.id + " ";
        if (r.status == SubjectStatus::Failed)
            line += "failed (exit " + std::to_string(r.exit_code) + ") in " +
                    format_seconds(r.wall_s) + " s: " + r.error +
                    " (log: " + (fs::path(r.dir) / kRunLog).string() + ")";
        else
            line += std::string(subject_status_name(r.status)) + " in " + format_seconds(r.wall_s) +
                    " s";
        options.on_progress(line);
    };
    auto start = [&](std::size_t index) {
        const CohortSubject& subject = manifest.subjects[index];
        SubjectResult& r = result.subjects[index];
        r.id = subject.id;
        r.dir = (fs::path(result.root) / subject.id).string();
        r.image = subject.image;
        std::vector<std::string> args = {"frontmesh", "run", recipe_path};
        for (const auto& o : subject_overrides(options, subject, subject.image, r.dir)) {
            args.push_back("--set");
            args.push_back(o);
        }
        args.push_back("--quiet");
        if (options.force) args.push_back("--force");
        if (!options.until.empty()) {
            args.push_back("--until");
            args.push_back(options.until);
        }
        if (options.threads > 0) {
            args.push_back("--threads");
            args.push_back(std::to_string(options.threads));
        }
        const auto t0 = Clock::now();
        // Less a second: file times come from a coarser kernel clock than now() (a few ms
        // behind it); an earlier run's summary is older than that by far.
        const auto written_since = fs::file_time_type::clock::now() - std::chrono::seconds(1);
        std::string error;
        pid_t pid = -1;
        try {
            claim_output_dir(r.dir);  // before cohort-run.log: the run finds a frontmesh folder
        } catch (const std::exception& e) {
            error = "cannot create '" + r.dir + "': " + e.what();
        }
        if (error.empty())
            pid = spawn_subject(options.executable, args, fs::path(r.dir) / kRunLog, error);
        if (pid < 0) {
            r.status = SubjectStatus::Failed;
            r.error = error;
            r.wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
            report(r);
            return;
        }
        running.push_back(Job{index, pid, t0, written_since});
    };
    // A run refused as bad input (exit 2) for a value of the manifest's row, its image or
    // one of its cells (the error starts with that key), is the row's error: it names the
    // manifest's file and line, as the checks before any run do (issue 22).
    auto blame_row = [&](SubjectResult& r, const CohortSubject& subject) {
        if (r.exit_code != 2) return;
        const std::string key = r.error.substr(0, r.error.find(": "));
        bool from_row = key == "input.image";
        for (const auto& [column, value] : subject.overrides) from_row |= column == key;
        if (from_row)
            r.error = manifest_path + ":" + std::to_string(subject.line) + ": subject '" +
                      subject.id + "': " + r.error;
    };
    auto finish = [&](const Job& job, int status) {
        SubjectResult& r = result.subjects[job.index];
        r.wall_s = std::chrono::duration<double>(Clock::now() - job.start).count();
        if (WIFEXITED(status)) {
            r.exit_code = WEXITSTATUS(status);
        } else {
            const int sig = WIFSIGNALED(status) ? WTERMSIG(status) : 0;
            r.exit_code = 128 + sig;
            r.error = "killed by signal " + std::to_string(sig) + " (" + strsignal(sig) + ")";
        }
        read_subject_record(r, job.written_since);
        if (r.exit_code == 0) {
            read_subject_summary(r);
        } else {
            r.status = SubjectStatus::Failed;
            if (r.error.empty()) r.error = last_error_line(fs::path(r.dir) / kRunLog);
            if (r.error.empty()) r.error = "exit code " + std::to_string(r.exit_code);
            blame_row(r, manifest.subjects[job.index]);
        }
        report(r);
    };
    const std::size_t jobs = static_cast<std::size_t>(options.jobs);
    while (next < total || !running.empty()) {
        while (running.size() < jobs && next < total) start(next++);
        bool reaped = false;
        for (auto it = running.begin(); it != running.end();) {
            int status = 0;
            const pid_t done = waitpid(it->pid, &status, WNOHANG);
            if (done == 0 || (done < 0 && errno == EINTR)) {
                ++it;
                continue;
            }
            if (done < 0) status = 127 << 8;  // lost child (cannot happen unless reaped elsewhere)
            const Job job = *it;
            it = running.erase(it);
            finish(job, status);
            reaped = true;
        }
        // Children are waited on by pid (never waitpid(-1), which could reap a child of
        // the embedding program); a short poll costs nothing next to a subject's run.
        if (!reaped && !running.empty()) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }

    write_summaries(result, manifest, recipe_path, options.jobs);
    return result;
}

}  // namespace frontmesh::pipeline
