#include "pipeline/recipe.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <string_view>
#include <type_traits>
#include <utility>
#include <variant>

#include <yaml-cpp/anchor.h>
#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/yaml.h>

#include "io/export.h"
#include "pipeline/core/error.h"
#include "pipeline/core/input_file.h"
#include "pipeline/output_dir.h"

namespace frontmesh::pipeline {
namespace {

namespace fs = std::filesystem;

// Where a value came from, for the one-line error: "recipe.yaml:12: input.image: ...".
struct Where {
    std::string origin;  // "path:line" or "--set"
    std::string key;
    [[noreturn]] void fail(const std::string& what) const {
        FM_THROW(InputError, origin + ": " + key + ": " + what);
    }
};

std::string describe(const YAML::Node& node) {
    if (node.IsNull()) return "nothing";
    if (node.IsSequence()) return "a list";
    if (node.IsMap()) return "a mapping";
    return "'" + node.Scalar() + "'";
}

// A number within `range`; the error names the value as it was written.
double as_number(const YAML::Node& node, const Where& where, const core::ParamRange& range) {
    double value = 0.0;
    if (!node.IsScalar() || !YAML::convert<double>::decode(node, value))
        where.fail("expected a number, got " + describe(node));
    if (!range.contains(value)) where.fail(range.violation(value, node.Scalar()));
    return value;
}

long long as_integer(const YAML::Node& node, const Where& where, const core::ParamRange& range) {
    long long value = 0;
    if (!node.IsScalar() || !YAML::convert<long long>::decode(node, value))
        where.fail("expected a whole number, got " + describe(node));
    if (!range.contains(static_cast<double>(value)))
        where.fail(range.violation(static_cast<double>(value), node.Scalar()));
    return value;
}

bool as_bool(const YAML::Node& node, const Where& where) {
    bool value = false;
    if (!node.IsScalar() || !YAML::convert<bool>::decode(node, value))
        where.fail("expected true or false, got " + describe(node));
    return value;
}

std::string as_string(const YAML::Node& node, const Where& where) {
    if (!node.IsScalar() || node.Scalar().empty())
        where.fail("expected a non-empty text, got " + describe(node));
    return node.Scalar();
}

std::string as_choice(const YAML::Node& node, const Where& where,
                      const std::vector<std::string>& choices) {
    const std::string value = node.IsScalar() ? node.Scalar() : std::string();
    if (std::find(choices.begin(), choices.end(), value) == choices.end()) {
        std::string list;
        for (const auto& c : choices) list += (list.empty() ? "" : ", ") + c;
        where.fail("expected one of " + list + ", got " + describe(node));
    }
    return value;
}

std::string resolve_input_path(const std::string& value, const std::string& recipe_path) {
    fs::path p(value);
    if (p.is_relative()) p = fs::path(recipe_path).parent_path() / p;
    // A printf pattern (slice stacks) names no existing file itself; keep it lexical.
    return p.lexically_normal().string();
}

std::size_t edit_distance(const std::string& a, const std::string& b) {
    std::vector<std::size_t> row(b.size() + 1);
    for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i) {
        std::size_t diagonal = row[0];
        row[0] = i;
        for (std::size_t j = 1; j <= b.size(); ++j) {
            const std::size_t up = row[j];
            row[j] =
                std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
            diagonal = up;
        }
    }
    return row[b.size()];
}

using Apply = std::function<void(const YAML::Node&, Recipe&, const Where&)>;

struct KeySpec {
    std::string path;
    std::string default_yaml;
    std::string range;  // "[0, 100]"; empty for texts, choices and switches
    std::string unit;
    std::string doc;
    Apply apply;
};

// The keys of one stage, from its declaration table (e.g. volume::tetra_keys()): a typed
// member is parsed and range-checked here; a key without one (a choice, a map) is applied
// by the function `by_hand` gives for it.
template <typename Params>
void add_stage_keys(std::vector<KeySpec>& specs, Params Recipe::*section,
                    const core::ParamTable<Params>& table,
                    const std::map<std::string_view, Apply>& by_hand = {}) {
    for (const auto& spec : table) {
        KeySpec key{std::string(spec.key),  std::string(spec.default_yaml), {},
                    std::string(spec.unit), std::string(spec.doc),          {}};
        std::visit(
            [&](auto member) {
                using Member = decltype(member);
                if constexpr (std::is_same_v<Member, std::monostate>) {
                    const auto it = by_hand.find(spec.key);
                    FM_CHECK(it != by_hand.end());
                    key.apply = it->second;
                    key.range =
                        spec.choices.empty() ? spec.range.text() : std::string(spec.choices);
                } else if constexpr (std::is_same_v<Member, bool Params::*>) {
                    key.apply = [=](const YAML::Node& n, Recipe& r, const Where& w) {
                        r.*section.*member = as_bool(n, w);
                    };
                } else if constexpr (std::is_same_v<Member, double Params::*>) {
                    key.range = spec.range.text();
                    key.apply = [=, range = spec.range](const YAML::Node& n, Recipe& r,
                                                        const Where& w) {
                        r.*section.*member = as_number(n, w, range);
                    };
                } else {
                    using Value =
                        std::remove_reference_t<decltype(std::declval<Params&>().*member)>;
                    key.range = spec.range.text();
                    key.apply = [=, range = spec.range](const YAML::Node& n, Recipe& r,
                                                        const Where& w) {
                        r.*section.*member = static_cast<Value>(as_integer(n, w, range));
                    };
                }
            },
            spec.field);
        specs.push_back(std::move(key));
    }
}

// input.* and output.*: read by the runner, not by a stage, so declared here.
void add_input_keys(std::vector<KeySpec>& specs) {
    const core::ParamRange threshold = core::closed(-1e300, 1e300);
    const core::ParamRange spacing = core::closed(1e-6, 1e6);
    specs.push_back({"input.image", "null", "", "",
                     "image file, DICOM folder or slice pattern; or input.surface",
                     [](const YAML::Node& n, Recipe& r, const Where& w) {
                         r.input.image = resolve_input_path(as_string(n, w), r.path);
                     }});
    specs.push_back({"input.surface", "null", "", "",
                     "triangle surface to start from (enters at repair)",
                     [](const YAML::Node& n, Recipe& r, const Where& w) {
                         r.input.surface = resolve_input_path(as_string(n, w), r.path);
                     }});
    specs.push_back(
        {"input.labels", "all", "", "", "labels to mesh: all, or a list such as [1, 4]",
         [](const YAML::Node& n, Recipe& r, const Where& w) {
             r.input.labels.clear();
             if (n.IsScalar() && n.Scalar() == "all") return;
             if (!n.IsSequence())
                 w.fail("expected 'all' or a list of labels such as [1, 2], got " + describe(n));
             if (n.size() == 0) w.fail("the list is empty; give at least one label, or 'all'");
             for (std::size_t i = 0; i < n.size(); ++i) {
                 const auto label =
                     static_cast<core::Label>(as_integer(n[i], w, core::closed(1, INT32_MAX)));
                 if (std::find(r.input.labels.begin(), r.input.labels.end(), label) !=
                     r.input.labels.end())
                     w.fail("label " + std::to_string(label) + " is listed twice");
                 r.input.labels.push_back(label);
             }
             std::sort(r.input.labels.begin(), r.input.labels.end());
         }});
    specs.push_back({"input.threshold", "null", "", "intensity",
                     "grayscale images: voxels above it become label 1",
                     [=](const YAML::Node& n, Recipe& r, const Where& w) {
                         r.input.threshold = as_number(n, w, threshold);
                     }});
    specs.push_back({"input.spacing", "null", spacing.text(), "mm",
                     "voxel spacing [x, y, z]; slice stacks need it",
                     [=](const YAML::Node& n, Recipe& r, const Where& w) {
                         if (!n.IsSequence() || n.size() != 3)
                             w.fail("expected three numbers [x, y, z] in mm, got " + describe(n));
                         Eigen::Vector3d s;
                         for (int i = 0; i < 3; ++i) s[i] = as_number(n[i], w, spacing);
                         r.input.spacing = s;
                     }});
    specs.push_back({"input.label_names", "null", "", "",
                     "label name table; null: the one beside the image",
                     [](const YAML::Node& n, Recipe& r, const Where& w) {
                         r.input.label_names = resolve_input_path(as_string(n, w), r.path);
                     }});
    const core::ParamRange gib = core::above_up_to(0.0, 65536.0);
    specs.push_back({"input.max_image_gib", "4", gib.text(), "GiB",
                     "memory an image may take while read: voxels x (file bytes + 4)",
                     [=](const YAML::Node& n, Recipe& r, const Where& w) {
                         r.input.max_image_gib = as_number(n, w, gib);
                     }});
}

void add_output_keys(std::vector<KeySpec>& specs) {
    specs.push_back({"output.dir", "frontmesh-out", "", "",
                     "folder of the checkpoints, summary, log and result",
                     [](const YAML::Node& n, Recipe& r, const Where& w) {
                         r.output.dir =
                             fs::absolute(fs::path(as_string(n, w))).lexically_normal().string();
                     }});
    specs.push_back({"output.frame", "lps", "", "", "world frame of every mesh: lps or ras",
                     [](const YAML::Node& n, Recipe& r, const Where& w) {
                         r.output.frame = as_choice(n, w, {"lps", "ras"}) == "ras"
                                              ? core::Frame::Ras
                                              : core::Frame::Lps;
                     }});
    specs.push_back({"output.formats", "[vtu]", "", "",
                     "files of the tet mesh: vtu, msh, msh22, mesh, inp, feb",
                     [](const YAML::Node& n, Recipe& r, const Where& w) {
                         if (!n.IsSequence() || n.size() == 0)
                             w.fail("expected a list of formats such as [vtu, msh, inp], got " +
                                    describe(n));
                         r.output.formats.clear();
                         for (std::size_t i = 0; i < n.size(); ++i) {
                             const std::string f = as_choice(n[i], w, io::format_names());
                             if (std::find(r.output.formats.begin(), r.output.formats.end(), f) !=
                                 r.output.formats.end())
                                 w.fail("format " + f + " is listed twice");
                             r.output.formats.push_back(f);
                         }
                     }});
    specs.push_back(
        {"output.binary", "false", "", "",
         "binary mesh.msh (MSH 4.1); VTU is always binary, other formats text",
         [](const YAML::Node& n, Recipe& r, const Where& w) { r.output.binary = as_bool(n, w); }});
    specs.push_back(
        {"output.split_interfaces", "none", "", "",
         "interfaces whose nodes are doubled for tie or contact: none, all, or [[1, 2], ...]",
         [](const YAML::Node& n, Recipe& r, const Where& w) {
             r.output.split_interfaces = {};
             if (n.IsNull()) return;
             if (n.IsScalar()) {
                 if (as_choice(n, w, {"none", "all"}) == "all")
                     r.output.split_interfaces.all = true;
                 return;
             }
             if (!n.IsSequence())
                 w.fail(
                     "expected none, all or a list of label pairs such as [[1, 2], [2, 3]], "
                     "got " +
                     describe(n));
             const core::ParamRange label = core::closed(1, INT32_MAX);
             for (std::size_t i = 0; i < n.size(); ++i) {
                 if (!n[i].IsSequence() || n[i].size() != 2)
                     w.fail("expected a pair of labels such as [1, 2], got " + describe(n[i]));
                 const auto a = static_cast<core::Label>(as_integer(n[i][0], w, label));
                 const auto b = static_cast<core::Label>(as_integer(n[i][1], w, label));
                 if (a == b)
                     w.fail("[" + std::to_string(a) + ", " + std::to_string(b) +
                            "] is not a pair of two different labels");
                 for (const auto& [x, y] : r.output.split_interfaces.pairs)
                     if (std::min(x, y) == std::min(a, b) && std::max(x, y) == std::max(a, b))
                         w.fail("the interface between " + std::to_string(a) + " and " +
                                std::to_string(b) + " is listed twice");
                 r.output.split_interfaces.pairs.emplace_back(a, b);
             }
         }});
    specs.push_back({"output.order", "1", "", "",
                     "element order of the exports: 1 (tet4) or 2 (tet10, curved on the surface)",
                     [](const YAML::Node& n, Recipe& r, const Where& w) {
                         r.output.order = as_choice(n, w, {"1", "2"}) == "2" ? 2 : 1;
                     }});
    specs.push_back({"output.quality_report", "true", "", "",
                     "report.html with quality histograms after refine",
                     [](const YAML::Node& n, Recipe& r, const Where& w) {
                         r.output.quality_report = as_bool(n, w);
                     }});
    specs.push_back({"output.allow_input_folder", "false", "", "",
                     "let output.dir be the folder holding the input (or contain it)",
                     [](const YAML::Node& n, Recipe& r, const Where& w) {
                         r.output.allow_input_folder = as_bool(n, w);
                     }});
}

void add_limits_keys(std::vector<KeySpec>& specs) {
    const core::ParamRange gib = core::above_up_to(0.0, 65536.0);
    specs.push_back({"limits.max_memory_gib", "16", gib.text(), "GiB",
                     "memory remesh or tetra may be expected to take (area/h^2, volume/h^3)",
                     [=](const YAML::Node& n, Recipe& r, const Where& w) {
                         r.limits.max_memory_gib = as_number(n, w, gib);
                     }});
}

// The stages' keys a table cannot set by itself.
Apply extract_method() {
    return [](const YAML::Node& n, Recipe& r, const Where& w) {
        const std::vector<std::string> choices =
            core::choice_list(core::find_spec(surface::extract_keys(), "extract.method")->choices);
        const std::string m = as_choice(n, w, choices);
        r.extract.method =
            static_cast<surface::ExtractMethod>(std::find(choices.begin(), choices.end(), m) -
                                                choices.begin());  // choices in enum order
    };
}

Apply remesh_label_edge_length() {
    return [](const YAML::Node& n, Recipe& r, const Where& w) {
        if (!n.IsMap())
            w.fail("expected a mapping of label: edge length in mm, such as {3: 0.8}, got " +
                   describe(n));
        const core::ParamRange& size =
            core::find_spec(surface::remesh_keys(), "remesh.label_edge_length")->range;
        r.remesh.label_edge_length.clear();
        for (const auto& entry : n) {
            const auto label =
                static_cast<core::Label>(as_integer(entry.first, w, core::closed(0, INT32_MAX)));
            // "3" and "03" are one label: the text scan for keys given twice cannot see it.
            if (r.remesh.label_edge_length.count(label) != 0)
                w.fail("label " + std::to_string(label) + " is given twice");
            r.remesh.label_edge_length[label] = as_number(entry.second, w, size);
        }
    };
}

// Every recipe key in documentation order: input, output, then the stages in pipeline order.
const std::vector<KeySpec>& key_specs() {
    static const std::vector<KeySpec> specs = [] {
        std::vector<KeySpec> s;
        add_input_keys(s);
        add_output_keys(s);
        add_limits_keys(s);
        add_stage_keys(s, &Recipe::extract, surface::extract_keys(),
                       {{"extract.method", extract_method()}});
        add_stage_keys(s, &Recipe::repair, surface::repair_keys());
        add_stage_keys(s, &Recipe::remesh, surface::remesh_keys(),
                       {{"remesh.label_edge_length", remesh_label_edge_length()}});
        add_stage_keys(s, &Recipe::tetra, volume::tetra_keys());
        add_stage_keys(s, &Recipe::refine, volume::refine_keys());
        return s;
    }();
    return specs;
}

[[noreturn]] void unknown_key(const std::string& key, const std::string& origin) {
    std::string best;
    std::size_t best_distance = key.size();
    for (const auto& spec : key_specs()) {
        for (const std::string& candidate : {spec.path, spec.path.substr(0, spec.path.find('.'))}) {
            const std::size_t d = edit_distance(key, candidate);
            if (d < best_distance) best_distance = d, best = candidate;
        }
    }
    std::string message = origin + ": " + key + ": unknown key";
    if (!best.empty() && best_distance <= std::max<std::size_t>(2, key.size() / 3))
        message += "; did you mean '" + best + "'?";
    else
        message += " (see configs/reference.yaml for every key)";
    FM_THROW(InputError, message);
}

// A YAML value as one line of flow text ("[1, 4]", "{3: 0.8}", "'a: b'").
std::string flow_text(const YAML::Node& value) {
    YAML::Emitter out;
    out.SetSeqFormat(YAML::Flow);
    out.SetMapFormat(YAML::Flow);
    out << value;
    return out.c_str();
}

// Recipe::values holds every key once, in key_specs() order (filled with the defaults
// first): the value of `key` is replaced in place.
void record_value(Recipe& recipe, const std::string& key, const YAML::Node& value) {
    for (auto& [name, text] : recipe.values)
        if (name == key) {
            text = value.IsNull() ? "null" : flow_text(value);
            return;
        }
    recipe.values.emplace_back(key, value.IsNull() ? "null" : flow_text(value));
}

void apply_key(const std::string& key, const YAML::Node& value, Recipe& recipe,
               const std::string& origin) {
    for (const auto& spec : key_specs())
        if (spec.path == key) {
            if (value.IsNull() && spec.default_yaml == "null") {  // explicit "not set"
                // It unsets what the file gave: `--set input.threshold=null` was recorded as
                // null while the file's threshold stayed in effect (`--set input.image=`
                // meshed the file's image; the malformed-input campaign, issue 21).
                if (key == "input.image") recipe.input.image.clear();
                if (key == "input.surface") recipe.input.surface.clear();
                if (key == "input.threshold") recipe.input.threshold.reset();
                if (key == "input.spacing") recipe.input.spacing.reset();
                if (key == "input.label_names") recipe.input.label_names.clear();
                record_value(recipe, key, value);
                return;
            }
            spec.apply(value, recipe, Where{origin, key});
            record_value(recipe, key, value);
            return;
        }
    unknown_key(key, origin);
}

std::string origin_of(const std::string& path, const YAML::Node& node) {
    const auto mark = node.Mark();
    return mark.line >= 0 ? path + ":" + std::to_string(mark.line + 1) : path;
}

// A recipe is a few dozen nodes. Before yaml-cpp builds the tree, its events are counted with
// every alias expanded (each anchor's size remembered, so the count is linear in the text): an
// alias inside the node it names (`&a [*a]`, a cycle: yaml-cpp's tree then loops and the walks
// below never end or overflow the stack), a tree expanded beyond kMaxYamlNodes (an "alias
// bomb", ten anchors of ten aliases each, 10^10 nodes from 600 bytes) or nested deeper than
// kMaxYamlDepth is refused before any walk (found by the malformed-input campaign, issue 21).
constexpr std::size_t kMaxYamlNodes = 100000;
constexpr std::size_t kMaxYamlDepth = 64;

class YamlSizeCheck : public YAML::EventHandler {
public:
    /// `with_lines` false for a --set value (one line: its line number says nothing).
    YamlSizeCheck(std::string origin, bool with_lines)
        : origin_(std::move(origin)), with_lines_(with_lines) {}
    void OnDocumentStart(const YAML::Mark&) override {}
    void OnDocumentEnd() override {}
    void OnNull(const YAML::Mark& mark, YAML::anchor_t anchor) override { leaf(mark, anchor); }
    void OnScalar(const YAML::Mark& mark, const std::string&, YAML::anchor_t anchor,
                  const std::string&) override {
        leaf(mark, anchor);
    }
    void OnAlias(const YAML::Mark& mark, YAML::anchor_t anchor) override {
        for (const Frame& f : open_)
            if (f.anchor == anchor && anchor != YAML::NullAnchor)
                fail(mark, "an alias inside the node its anchor names (a cycle)");
        const auto it = sizes_.find(anchor);
        add(mark, it == sizes_.end() ? 1 : it->second);
    }
    void OnSequenceStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t anchor,
                         YAML::EmitterStyle::value) override {
        open(mark, anchor);
    }
    void OnSequenceEnd() override { close(); }
    void OnMapStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t anchor,
                    YAML::EmitterStyle::value) override {
        open(mark, anchor);
    }
    void OnMapEnd() override { close(); }

private:
    struct Frame {
        YAML::anchor_t anchor;
        std::size_t nodes;  // the expanded nodes of this container so far, itself included
    };
    [[noreturn]] void fail(const YAML::Mark& mark, const std::string& what) const {
        FM_THROW(InputError,
                 (with_lines_ && mark.line >= 0 ? origin_ + ":" + std::to_string(mark.line + 1)
                                                : origin_) +
                     ": " + what);
    }
    // Every node is added to total_ once, when it starts (an alias: its anchor's whole size),
    // and to the count of the container holding it; so total_ bounds every count, and no sum
    // exceeds 2 kMaxYamlNodes before it is refused.
    void add(const YAML::Mark& mark, std::size_t nodes) {
        total_ += nodes;
        if (total_ > kMaxYamlNodes)
            fail(mark, "more than " + std::to_string(kMaxYamlNodes) +
                           " values with its aliases expanded; a recipe needs far fewer");
        if (!open_.empty()) open_.back().nodes += nodes;
    }
    void leaf(const YAML::Mark& mark, YAML::anchor_t anchor) {
        if (anchor != YAML::NullAnchor) sizes_[anchor] = 1;
        add(mark, 1);
    }
    void open(const YAML::Mark& mark, YAML::anchor_t anchor) {
        if (open_.size() >= kMaxYamlDepth)
            fail(mark, "nested more than " + std::to_string(kMaxYamlDepth) +
                           " levels deep; a recipe needs three");
        add(mark, 1);
        open_.push_back({anchor, 1});
    }
    void close() {
        const Frame f = open_.back();
        open_.pop_back();
        if (f.anchor != YAML::NullAnchor) sizes_[f.anchor] = f.nodes;
        if (!open_.empty()) open_.back().nodes += f.nodes - 1;  // its own 1 went in at open
    }
    std::string origin_;
    bool with_lines_;
    std::vector<Frame> open_;
    std::map<YAML::anchor_t, std::size_t> sizes_;
    std::size_t total_ = 0;
};

// YAML text is Unicode, and yaml-cpp takes any bytes: a recipe whose output.dir held
// random bytes ran and wrote a folder of that name (campaign seed 5, issue 21). Refused
// naming the line and the first byte that is not UTF-8 (overlong forms, surrogates and
// code points beyond U+10FFFF included).
void require_utf8(const std::string& text, const std::string& origin, bool with_lines) {
    std::size_t line = 1, i = 0;
    const std::size_t n = text.size();
    while (i < n) {
        const auto c = static_cast<unsigned char>(text[i]);
        std::size_t extra = 0;
        std::uint32_t cp = 0;
        if (c < 0x80) {
            if (c == '\n') ++line;
            ++i;
            continue;
        }
        if (c >= 0xc2 && c <= 0xdf) {
            extra = 1;
            cp = c & 0x1fu;
        } else if (c >= 0xe0 && c <= 0xef) {
            extra = 2;
            cp = c & 0x0fu;
        } else if (c >= 0xf0 && c <= 0xf4) {
            extra = 3;
            cp = c & 0x07u;
        }
        bool ok = extra > 0 && i + extra < n;
        for (std::size_t k = 1; ok && k <= extra; ++k) {
            const auto t = static_cast<unsigned char>(text[i + k]);
            ok = (t & 0xc0u) == 0x80u;
            cp = (cp << 6) | (t & 0x3fu);
        }
        ok = ok && !(extra == 2 && (cp < 0x800 || (cp >= 0xd800 && cp <= 0xdfff))) &&
             !(extra == 3 && (cp < 0x10000 || cp > 0x10ffff));
        if (!ok) {
            char byte[8];
            std::snprintf(byte, sizeof byte, "0x%02x", c);
            FM_THROW(InputError, (with_lines ? origin + ":" + std::to_string(line) : origin) +
                                     ": not UTF-8 text (byte " + byte +
                                     "); a YAML recipe is UTF-8");
        }
        i += extra + 1;
    }
}

// YAML::Load after the size check above. `origin` the recipe's path (errors name its line)
// or "--set KEY".
YAML::Node load_yaml(const std::string& text, const std::string& origin, bool with_lines) {
    require_utf8(text, origin, with_lines);
    try {
        std::istringstream in(text);
        YAML::Parser parser(in);
        YamlSizeCheck check(origin, with_lines);
        while (parser.HandleNextDocument(check)) {
        }
        return YAML::Load(text);
    } catch (const YAML::Exception& e) {
        if (!with_lines) FM_THROW(InputError, origin + ": cannot read the value: " + e.msg);
        FM_THROW(InputError,
                 origin + ":" + std::to_string(e.mark.line + 1) + ": YAML syntax error: " + e.msg);
    }
}

// yaml-cpp keeps every pair of a mapping, so a key given twice would silently take the
// last value: refuse it, naming both lines. `path` "--set": a value given on the command line.
void reject_duplicate_keys(const YAML::Node& node, const std::string& path,
                           const std::string& prefix) {
    if (node.IsSequence())
        for (const auto& item : node) reject_duplicate_keys(item, path, prefix);
    if (!node.IsMap()) return;
    std::map<std::string, int> lines;
    for (const auto& entry : node) {
        const std::string key = prefix + (entry.first.IsScalar() ? entry.first.Scalar() : "?");
        const int line = entry.first.Mark().line + 1;
        if (const auto [it, fresh] = lines.emplace(key, line); !fresh) {
            if (path == "--set")  // a one-line value: its lines say nothing
                FM_THROW(InputError, path + " " + key + ": given twice; keep one");
            FM_THROW(InputError, origin_of(path, entry.first) + ": " + key +
                                     ": given twice (first on line " + std::to_string(it->second) +
                                     "); keep one");
        }
        reject_duplicate_keys(entry.second, path, key + ".");
    }
}

// A mapping key as text. YAML allows any node as a key ("? {a: 1}: x"); a recipe's keys are
// names (found by fuzz_recipe, issue 21: a mapping key escaped as yaml-cpp's bad conversion).
std::string key_name(const YAML::Node& key, const std::string& origin) {
    if (!key.IsScalar())
        FM_THROW(InputError, origin + ": a key must be a plain name, got " + describe(key));
    return key.Scalar();
}

// The recipe file's sections, key by key.
void apply_sections(const YAML::Node& root, const std::string& path, Recipe& recipe) {
    if (!root.IsMap()) return;
    for (const auto& section : root) {
        const std::string origin = origin_of(path, section.first);
        const std::string name = key_name(section.first, origin);
        bool known = false;
        for (const auto& spec : key_specs()) known |= spec.path.rfind(name + ".", 0) == 0;
        // A section holding keys names its first key (with a suggestion for the pair);
        // an empty one itself: `label_edge_length: {}` at the top was accepted (campaign
        // seed 5, issue 21).
        if (!known && (!section.second.IsMap() || section.second.size() == 0))
            unknown_key(name, origin);
        if (!section.second.IsMap()) {
            FM_THROW(InputError, origin + ": " + name + ": expected a section of keys, got " +
                                     describe(section.second));
        }
        for (const auto& entry : section.second)
            apply_key(name + "." + key_name(entry.first, origin_of(path, entry.first)),
                      entry.second, recipe, origin_of(path, entry.first));
    }
}

// One --set key.path=value; it replaces what the file gave.
void apply_override(const std::string& item, Recipe& recipe) {
    const auto eq = item.find('=');
    if (eq == std::string::npos || eq == 0)
        FM_THROW(InputError, "--set " + item + ": expected key.path=value");
    const std::string key = item.substr(0, eq);
    YAML::Node value = load_yaml(item.substr(eq + 1), "--set " + key, false);
    reject_duplicate_keys(value, "--set", key + ".");
    // Relative paths given on the command line are relative to the current folder.
    // An empty value is left for the key's own check ("expected a non-empty text"):
    // fs::absolute("") throws (campaign seed 19: exit 1).
    if ((key == "input.image" || key == "input.surface" || key == "input.label_names") &&
        value.IsScalar() && !value.Scalar().empty())
        value = YAML::Node(fs::absolute(value.Scalar()).lexically_normal().string());
    apply_key(key, value, recipe, "--set");
}

}  // namespace

Recipe load_recipe(const std::string& path, const std::vector<std::string>& overrides) {
    // A folder or a named pipe is refused by stat, without opening it.
    core::require_input_file(path, "recipe ");
    std::ifstream in(path, std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    if (!in && !in.eof()) FM_THROW(InputError, path + ": cannot read the recipe");
    return parse_recipe(text.str(), path, overrides);
}

Recipe parse_recipe(const std::string& text, const std::string& path,
                    const std::vector<std::string>& overrides) {
    Recipe recipe;
    recipe.path = fs::absolute(path).lexically_normal().string();
    for (const auto& spec : key_specs()) {
        const YAML::Node value = YAML::Load(spec.default_yaml);
        if (spec.default_yaml != "null") spec.apply(value, recipe, Where{"defaults", spec.path});
        record_value(recipe, spec.path, value);
    }

    YAML::Node root = load_yaml(text, path, true);  // not const: root[k] of a missing k is null
    if (!root.IsNull() && !root.IsMap())
        FM_THROW(InputError, path + ": the recipe must be a mapping of sections");
    reject_duplicate_keys(root, path, "");
    apply_sections(root, path, recipe);
    for (const std::string& item : overrides) apply_override(item, recipe);

    auto origin_for = [&](const std::string& key) {
        for (const std::string& item : overrides)  // the value --set gave replaced the file's
            if (item.rfind(key + "=", 0) == 0) return std::string("--set");
        if (root.IsMap()) {
            const auto dot = key.find('.');
            const YAML::Node section = root[key.substr(0, dot)];
            if (section.IsMap())
                for (const auto& entry : section)
                    if (entry.first.IsScalar() && entry.first.Scalar() == key.substr(dot + 1))
                        return origin_of(path, entry.first);
        }
        return path;
    };
    const InputSection& in = recipe.input;
    if (in.image.empty() == in.surface.empty())
        FM_THROW(InputError, path + ": input: give exactly one of input.image or input.surface");
    // Every input is stat-ed before anything reads it: a named pipe, socket or device
    // would block the reader (issue 21). A slice pattern ("slice%03d.png") names no file
    // itself; the image reader checks the files it expands to.
    // (error_code forms: a name too long for the file system is bad input, not a throw.)
    std::error_code ec;
    if (!in.image.empty() && (fs::exists(in.image, ec) || in.image.find('%') == std::string::npos))
        core::require_input_file(in.image, origin_for("input.image") + ": input.image: ", true);
    if (!in.surface.empty())
        core::require_input_file(in.surface, origin_for("input.surface") + ": input.surface: ");
    if (!in.label_names.empty())
        core::require_input_file(in.label_names,
                                 origin_for("input.label_names") + ": input.label_names: ");
    if (in.threshold && !(in.labels.empty() || in.labels == std::vector<core::Label>{1}))
        FM_THROW(InputError, origin_for("input.labels") +
                                 ": input.labels: with input.threshold the mask has the single "
                                 "label 1; use [1] or all");
    // A label of output.split_interfaces must be meshed; whether two labels touch only the
    // mesh can tell (io::split_interfaces checks it before the exports).
    if (!in.labels.empty())
        for (const auto& [a, b] : recipe.output.split_interfaces.pairs)
            for (const core::Label l : {a, b})
                if (std::find(in.labels.begin(), in.labels.end(), l) == in.labels.end())
                    FM_THROW(InputError, origin_for("output.split_interfaces") +
                                             ": output.split_interfaces: label " +
                                             std::to_string(l) + " is not in input.labels");
    // MEDIT's .mesh holds linear tets only (io::write_mesh refuses quadratic ones too).
    if (recipe.output.order == 2 &&
        std::find(recipe.output.formats.begin(), recipe.output.formats.end(), "mesh") !=
            recipe.output.formats.end())
        FM_THROW(InputError, origin_for("output.order") +
                                 ": output.order: 2 (quadratic tets) cannot be written as MEDIT "
                                 ".mesh, which holds linear tets only; drop mesh from "
                                 "output.formats or use order 1");
    check_output_dir(recipe, origin_for("output.dir"));
    recipe.extract.labels = in.labels;
    // The volume size cap of tetra is honoured by refine too (its edge splits).
    recipe.refine.max_edge_length = recipe.tetra.max_edge_length;
    // ... and bounds remesh's automatic size, so that the surface is no coarser than the cap.
    recipe.remesh.volume_edge_cap = recipe.tetra.max_edge_length;
    // An image's components are measured in voxels, by extract (issue 20).
    recipe.extract.min_component_volume_mm3 = recipe.repair.min_component_volume_mm3;
    recipe.repair.is_from_image = !in.image.empty();
    // Paths as resolved, so that the values read the same from any folder.
    for (const auto& [key, value] :
         {std::pair<const char*, const std::string*>{"input.image", &in.image},
          {"input.surface", &in.surface},
          {"input.label_names", &in.label_names},
          {"output.dir", &recipe.output.dir}})
        if (!value->empty()) record_value(recipe, key, YAML::Node(*value));
    surface::validate(recipe.extract);
    surface::validate(recipe.repair);
    surface::validate(recipe.remesh);
    volume::validate(recipe.tetra);
    volume::validate(recipe.refine);
    return recipe;
}

std::vector<RecipeKey> recipe_keys() {
    std::vector<RecipeKey> keys;
    for (const auto& spec : key_specs())
        keys.push_back({spec.path, spec.default_yaml, spec.range, spec.unit, spec.doc});
    return keys;
}

std::string canonical_params(const Recipe& recipe, const std::string& section) {
    std::ostringstream s;
    s.precision(17);
    if (section == "input") {
        s << "image=" << recipe.input.image << ";surface=" << recipe.input.surface << ";labels=";
        for (auto l : recipe.input.labels) s << l << ',';
        s << ";threshold="
          << (recipe.input.threshold ? std::to_string(*recipe.input.threshold) : "none");
        if (recipe.input.spacing) s << ";spacing=" << recipe.input.spacing->transpose();
        s << ";frame=" << core::frame_name(recipe.output.frame);
    } else if (section == "extract") {
        const auto& e = recipe.extract;
        s << "method=" << static_cast<int>(e.method) << ";blur=" << e.blur_sigma_mm
          << ";iterations=" << e.smoothing_iterations << ";relaxation=" << e.smoothing_relaxation
          << ";cleanup=" << e.manifold_cleanup << ";closing=" << e.closing_voxels
          << ";opening=" << e.opening_voxels << ";min_volume=" << e.min_component_volume_mm3
          << ";volume=" << e.preserve_volume;
        for (auto l : e.labels) s << ";label=" << l;
    } else if (section == "repair") {
        const auto& p = recipe.repair;
        s << "merge=" << p.merge_tolerance_mm << ";min_volume=" << p.min_component_volume_mm3
          << ";min_faces=" << p.min_component_faces << ";max_hole=" << p.max_hole_edges
          << ";fill=" << p.fill_holes << ";check_si=" << p.check_self_intersections
          << ";fail_si=" << p.fail_on_self_intersections;
    } else if (section == "remesh") {
        const auto& m = recipe.remesh;
        s << "h=" << m.edge_length << ";gradation=" << m.gradation << ";min=" << m.min_edge_length
          << ";max=" << m.max_edge_length << ";curvature=" << m.curvature_angle_deg
          << ";layers=" << m.thickness_layers << ";feature=" << m.feature_angle_deg
          << ";smoothing=" << m.smoothing_iterations << ";flip=" << m.flip_max_dihedral_deg
          << ";check_si=" << m.check_self_intersections
          << ";max_volume=" << m.max_volume_change_percent << ";volume=" << m.preserve_volume;
        for (const auto& [label, size] : m.label_edge_length) s << ";label" << label << "=" << size;
        if (m.volume_edge_cap > 0 && m.edge_length == 0)  // default: as before
            s << ";volume_cap=" << m.volume_edge_cap;
    } else if (section == "tetra") {
        const auto& t = recipe.tetra;
        s << "stretching=" << t.stretching << ";height_smoothing=" << t.height_smoothing_iterations
          << ";max_remesh=" << t.max_remesh_per_node << ";min_angle=" << t.min_angle_deg
          << ";closing=" << t.max_closing_rounds;
        if (t.max_edge_length > 0) s << ";max_edge=" << t.max_edge_length;  // default: as before
    } else if (section == "refine") {
        const auto& f = recipe.refine;
        s << "node_removal=" << f.node_removal << ";max_tets=" << f.node_removal_max_tets
          << ";passes=" << f.passes << ";smoothing=" << f.smoothing
          << ";sweeps=" << f.smoothing_sweeps << ";smoothing_skewness=" << f.smoothing_skewness
          << ";flip_skewness=" << f.flip_skewness << ";ring=" << f.flip_max_ring
          << ";delaunay=" << f.flip_delaunay_test << ";flip_sweeps=" << f.flip_sweeps
          << ";sliver=" << f.sliver_pass << ";sliver_deg=" << f.sliver_dihedral_deg
          << ";sliver_sweeps=" << f.sliver_sweeps;
        if (f.max_edge_length > 0) s << ";max_edge=" << f.max_edge_length;  // default: as before
    } else {
        FM_CHECK(false && "unknown recipe section");
    }
    return s.str();
}

}  // namespace frontmesh::pipeline

namespace frontmesh::pipeline {
namespace {

std::string json_string(const std::string& text) {
    std::string out = "\"";
    for (const unsigned char c : text) {
        if (c == '"' || c == '\\') {
            out += '\\';
            out += static_cast<char>(c);
        } else if (c < 0x20) {
            char buf[8];
            std::snprintf(buf, sizeof buf, "\\u%04x", c);
            out += buf;
        } else {
            out += static_cast<char>(c);
        }
    }
    return out + "\"";
}

// A YAML value as JSON; `depth` bounds the recursion (recipe values nest at most twice).
std::string yaml_as_json(const YAML::Node& node, int depth) {
    if (depth > 16 || !node.IsDefined() || node.IsNull()) return "null";
    if (node.IsSequence()) {
        std::string out = "[";
        for (std::size_t i = 0; i < node.size(); ++i)
            out += (i ? ", " : "") + yaml_as_json(node[i], depth + 1);
        return out + "]";
    }
    if (node.IsMap()) {
        std::string out = "{";
        bool first = true;
        for (const auto& entry : node) {
            out += (first ? "" : ", ") + json_string(entry.first.Scalar()) + ": " +
                   yaml_as_json(entry.second, depth + 1);
            first = false;
        }
        return out + "}";
    }
    const std::string& text = node.Scalar();
    if (node.Tag() != "!") {  // plain scalars only: a quoted '1' stays a string
        if (text == "true" || text == "false") return text;
        double number = 0.0;
        if (YAML::convert<double>::decode(node, number) && std::isfinite(number) &&
            text.find_first_not_of("0123456789+-.eE") == std::string::npos)
            return text;
    }
    return json_string(text);
}

}  // namespace

std::string effective_recipe_json(const Recipe& recipe, const std::string& section) {
    std::string out = "{";
    bool first = true;
    for (const auto& [key, value] : recipe.values) {
        if (!section.empty() && key.rfind(section + ".", 0) != 0) continue;
        out += (first ? "" : ", ") + json_string(key) + ": " + yaml_as_json(YAML::Load(value), 0);
        first = false;
    }
    return out + "}";
}

std::string effective_recipe_yaml(const Recipe& recipe) {
    std::string out, section;
    for (const auto& [key, value] : recipe.values) {
        const auto dot = key.find('.');
        if (key.substr(0, dot) != section) {
            section = key.substr(0, dot);
            out += (out.empty() ? "" : "\n") + section + ":\n";
        }
        out += "  " + key.substr(dot + 1) + ": " + value + "\n";
    }
    return out;
}

}  // namespace frontmesh::pipeline
