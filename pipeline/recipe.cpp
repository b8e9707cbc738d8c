#include "pipeline/recipe.h"

#include <algorithm>
#include <filesystem>
#include <functional>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "io/export.h"
#include "pipeline/core/error.h"

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

double as_number(const YAML::Node& node, const Where& where, double lo, double hi) {
    double value = 0.0;
    if (!node.IsScalar() || !YAML::convert<double>::decode(node, value))
        where.fail("expected a number, got " + describe(node));
    if (!(value >= lo && value <= hi)) {
        std::ostringstream s;
        s << "must be in [" << lo << ", " << hi << "], got " << node.Scalar();
        where.fail(s.str());
    }
    return value;
}

long long as_integer(const YAML::Node& node, const Where& where, long long lo, long long hi) {
    long long value = 0;
    if (!node.IsScalar() || !YAML::convert<long long>::decode(node, value))
        where.fail("expected a whole number, got " + describe(node));
    if (value < lo || value > hi)
        where.fail("must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " + node.Scalar());
    return value;
}

bool as_bool(const YAML::Node& node, const Where& where) {
    bool value = false;
    if (!node.IsScalar() || !YAML::convert<bool>::decode(node, value))
        where.fail("expected true or false, got " + describe(node));
    return value;
}

std::string as_string(const YAML::Node& node, const Where& where) {
    if (!node.IsScalar() || node.Scalar().empty()) where.fail("expected a non-empty text, got " + describe(node));
    return node.Scalar();
}

std::string as_choice(const YAML::Node& node, const Where& where, const std::vector<std::string>& choices) {
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
            row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
            diagonal = up;
        }
    }
    return row[b.size()];
}

struct KeySpec {
    std::string path;
    std::string default_yaml;
    std::function<void(const YAML::Node&, Recipe&, const Where&)> apply;
};

// Keys that set one field of a stage's parameters, with their range.
template <typename Section>
KeySpec number_key(std::string path, std::string default_yaml, Section Recipe::*section, double Section::*field,
                   double lo, double hi, bool open_below = false) {
    return {std::move(path), std::move(default_yaml),
            [=](const YAML::Node& n, Recipe& r, const Where& w) {
                const double v = as_number(n, w, lo, hi);
                if (open_below && v == lo) {
                    std::ostringstream s;
                    s << "must be greater than " << lo << ", got " << n.Scalar();
                    w.fail(s.str());
                }
                r.*section.*field = v;
            }};
}

template <typename Section>
KeySpec integer_key(std::string path, std::string default_yaml, Section Recipe::*section, int Section::*field,
                    int lo, int hi) {
    return {std::move(path), std::move(default_yaml), [=](const YAML::Node& n, Recipe& r, const Where& w) {
                r.*section.*field = static_cast<int>(as_integer(n, w, lo, hi));
            }};
}

template <typename Section>
KeySpec bool_key(std::string path, std::string default_yaml, Section Recipe::*section, bool Section::*field) {
    return {std::move(path), std::move(default_yaml),
            [=](const YAML::Node& n, Recipe& r, const Where& w) { r.*section.*field = as_bool(n, w); }};
}

const std::vector<KeySpec>& key_specs() {
    static const std::vector<KeySpec> specs = {
        {"input.image", "null",
         [](const YAML::Node& n, Recipe& r, const Where& w) { r.input.image = resolve_input_path(as_string(n, w), r.path); }},
        {"input.surface", "null",
         [](const YAML::Node& n, Recipe& r, const Where& w) { r.input.surface = resolve_input_path(as_string(n, w), r.path); }},
        {"input.labels", "all",
         [](const YAML::Node& n, Recipe& r, const Where& w) {
             r.input.labels.clear();
             if (n.IsScalar() && n.Scalar() == "all") return;
             if (!n.IsSequence()) w.fail("expected 'all' or a list of labels such as [1, 2], got " + describe(n));
             if (n.size() == 0) w.fail("the list is empty; give at least one label, or 'all'");
             for (std::size_t i = 0; i < n.size(); ++i) {
                 const auto label = static_cast<core::Label>(as_integer(n[i], w, 1, INT32_MAX));
                 if (std::find(r.input.labels.begin(), r.input.labels.end(), label) != r.input.labels.end())
                     w.fail("label " + std::to_string(label) + " is listed twice");
                 r.input.labels.push_back(label);
             }
             std::sort(r.input.labels.begin(), r.input.labels.end());
         }},
        {"input.threshold", "null",
         [](const YAML::Node& n, Recipe& r, const Where& w) { r.input.threshold = as_number(n, w, -1e300, 1e300); }},
        {"input.spacing", "null",
         [](const YAML::Node& n, Recipe& r, const Where& w) {
             if (!n.IsSequence() || n.size() != 3) w.fail("expected three numbers [x, y, z] in mm, got " + describe(n));
             Eigen::Vector3d s;
             for (int i = 0; i < 3; ++i) s[i] = as_number(n[i], w, 1e-6, 1e6);
             r.input.spacing = s;
         }},
        {"input.label_names", "null",
         [](const YAML::Node& n, Recipe& r, const Where& w) {
             r.input.label_names = resolve_input_path(as_string(n, w), r.path);
         }},
        {"output.dir", "frontmesh-out",
         [](const YAML::Node& n, Recipe& r, const Where& w) {
             r.output.dir = fs::absolute(fs::path(as_string(n, w))).lexically_normal().string();
         }},
        {"output.frame", "lps",
         [](const YAML::Node& n, Recipe& r, const Where& w) {
             r.output.frame = as_choice(n, w, {"lps", "ras"}) == "ras" ? core::Frame::Ras : core::Frame::Lps;
         }},
        {"output.formats", "[vtu]",
         [](const YAML::Node& n, Recipe& r, const Where& w) {
             if (!n.IsSequence() || n.size() == 0)
                 w.fail("expected a list of formats such as [vtu, msh, inp], got " + describe(n));
             r.output.formats.clear();
             for (std::size_t i = 0; i < n.size(); ++i) {
                 const std::string f = as_choice(n[i], w, io::format_names());
                 if (std::find(r.output.formats.begin(), r.output.formats.end(), f) != r.output.formats.end())
                     w.fail("format " + f + " is listed twice");
                 r.output.formats.push_back(f);
             }
         }},
        {"output.quality_report", "true",
         [](const YAML::Node& n, Recipe& r, const Where& w) { r.output.quality_report = as_bool(n, w); }},
        {"extract.method", "auto",
         [](const YAML::Node& n, Recipe& r, const Where& w) {
             const std::string m = as_choice(n, w, {"auto", "flying_edges", "surface_nets"});
             r.extract.method = m == "auto"           ? surface::ExtractMethod::Auto
                                : m == "flying_edges" ? surface::ExtractMethod::FlyingEdges
                                                      : surface::ExtractMethod::SurfaceNets;
         }},
        {"extract.blur_sigma_mm", "0.0",
         [](const YAML::Node& n, Recipe& r, const Where& w) { r.extract.blur_sigma_mm = as_number(n, w, 0.0, 100.0); }},
        {"extract.smoothing_iterations", "8",
         [](const YAML::Node& n, Recipe& r, const Where& w) {
             r.extract.smoothing_iterations = static_cast<int>(as_integer(n, w, 0, 1000));
         }},
        {"extract.smoothing_relaxation", "0.5",
         [](const YAML::Node& n, Recipe& r, const Where& w) {
             r.extract.smoothing_relaxation = as_number(n, w, 1e-6, 1.0);
         }},
        {"extract.manifold_cleanup", "true",
         [](const YAML::Node& n, Recipe& r, const Where& w) { r.extract.manifold_cleanup = as_bool(n, w); }},
        integer_key("extract.closing_voxels", "0", &Recipe::morphology, &surface::MorphologyParams::closing_voxels, 0,
                    10),
        integer_key("extract.opening_voxels", "0", &Recipe::morphology, &surface::MorphologyParams::opening_voxels, 0,
                    10),
        {"repair.merge_tolerance_mm", "1.0e-6",
         [](const YAML::Node& n, Recipe& r, const Where& w) { r.repair.merge_tolerance_mm = as_number(n, w, 0.0, 1.0); }},
        {"repair.min_component_volume_mm3", "1.0",
         [](const YAML::Node& n, Recipe& r, const Where& w) {
             r.repair.min_component_volume_mm3 = as_number(n, w, 0.0, 1e12);
         }},
        {"repair.min_component_faces", "0",
         [](const YAML::Node& n, Recipe& r, const Where& w) {
             r.repair.min_component_faces = static_cast<std::size_t>(as_integer(n, w, 0, 1'000'000'000));
         }},
        {"repair.max_hole_edges", "200",
         [](const YAML::Node& n, Recipe& r, const Where& w) {
             r.repair.max_hole_edges = static_cast<std::size_t>(as_integer(n, w, 3, 1'000'000));
         }},
        {"repair.fill_holes", "true",
         [](const YAML::Node& n, Recipe& r, const Where& w) { r.repair.fill_holes = as_bool(n, w); }},
        {"repair.check_self_intersections", "true",
         [](const YAML::Node& n, Recipe& r, const Where& w) { r.repair.check_self_intersections = as_bool(n, w); }},
        {"repair.fail_on_self_intersections", "true",
         [](const YAML::Node& n, Recipe& r, const Where& w) { r.repair.fail_on_self_intersections = as_bool(n, w); }},
        number_key("remesh.edge_length", "0.0", &Recipe::remesh, &surface::RemeshParams::edge_length, 0.0, 1e4),
        number_key("remesh.gradation", "1.3", &Recipe::remesh, &surface::RemeshParams::gradation, 1.0, 10.0),
        number_key("remesh.min_edge_length", "0.0", &Recipe::remesh, &surface::RemeshParams::min_edge_length, 0.0, 1e4),
        number_key("remesh.max_edge_length", "0.0", &Recipe::remesh, &surface::RemeshParams::max_edge_length, 0.0, 1e4),
        number_key("remesh.curvature_angle_deg", "0.0", &Recipe::remesh, &surface::RemeshParams::curvature_angle_deg,
                   0.0, 89.0),
        integer_key("remesh.thickness_layers", "0", &Recipe::remesh, &surface::RemeshParams::thickness_layers, 0, 20),
        number_key("remesh.feature_angle_deg", "0.0", &Recipe::remesh, &surface::RemeshParams::feature_angle_deg, 0.0,
                   179.0),
        {"remesh.label_edge_length", "{}",
         [](const YAML::Node& n, Recipe& r, const Where& w) {
             if (!n.IsMap()) w.fail("expected a mapping of label: edge length in mm, such as {3: 0.8}, got " + describe(n));
             r.remesh.label_edge_length.clear();
             for (const auto& entry : n) {
                 const auto label = static_cast<core::Label>(as_integer(entry.first, w, 0, 2147483647));
                 r.remesh.label_edge_length[label] = as_number(entry.second, w, 1e-6, 1e4);
             }
         }},
        integer_key("remesh.smoothing_iterations", "5", &Recipe::remesh, &surface::RemeshParams::smoothing_iterations,
                    0, 100),
        number_key("remesh.flip_max_dihedral_deg", "10.0", &Recipe::remesh,
                   &surface::RemeshParams::flip_max_dihedral_deg, 0.0, 90.0),
        number_key("remesh.max_volume_change_percent", "0.0", &Recipe::remesh,
                   &surface::RemeshParams::max_volume_change_percent, 0.0, 100.0),
        bool_key("remesh.check_self_intersections", "true", &Recipe::remesh,
                 &surface::RemeshParams::check_self_intersections),
        number_key("tetra.stretching", "1.15", &Recipe::tetra, &volume::TetraParams::stretching, 1.0, 2.0, true),
        integer_key("tetra.height_smoothing_iterations", "3", &Recipe::tetra,
                    &volume::TetraParams::height_smoothing_iterations, 0, 100),
        integer_key("tetra.max_remesh_per_node", "3", &Recipe::tetra, &volume::TetraParams::max_remesh_per_node, 0, 50),
        number_key("tetra.min_angle_deg", "5.0", &Recipe::tetra, &volume::TetraParams::min_angle_deg, 0.0, 30.0),
        integer_key("tetra.max_closing_rounds", "8", &Recipe::tetra, &volume::TetraParams::max_closing_rounds, 0, 100),
        bool_key("refine.node_removal", "true", &Recipe::refine, &volume::RefineParams::node_removal),
        integer_key("refine.node_removal_max_tets", "6", &Recipe::refine, &volume::RefineParams::node_removal_max_tets,
                    4, 12),
        integer_key("refine.passes", "3", &Recipe::refine, &volume::RefineParams::passes, 0, 20),
        bool_key("refine.smoothing", "true", &Recipe::refine, &volume::RefineParams::smoothing),
        integer_key("refine.smoothing_sweeps", "1", &Recipe::refine, &volume::RefineParams::smoothing_sweeps, 1, 10),
        number_key("refine.smoothing_skewness", "0.0", &Recipe::refine, &volume::RefineParams::smoothing_skewness, 0.0,
                   0.999),
        number_key("refine.flip_skewness", "0.3", &Recipe::refine, &volume::RefineParams::flip_skewness, 0.0, 0.999),
        integer_key("refine.flip_max_ring", "7", &Recipe::refine, &volume::RefineParams::flip_max_ring, 3, 10),
        bool_key("refine.flip_delaunay_test", "true", &Recipe::refine, &volume::RefineParams::flip_delaunay_test),
        integer_key("refine.flip_sweeps", "4", &Recipe::refine, &volume::RefineParams::flip_sweeps, 1, 20),
        bool_key("refine.sliver_pass", "true", &Recipe::refine, &volume::RefineParams::sliver_pass),
        number_key("refine.sliver_dihedral_deg", "20.0", &Recipe::refine, &volume::RefineParams::sliver_dihedral_deg,
                   0.0, 70.5, true),
        integer_key("refine.sliver_sweeps", "3", &Recipe::refine, &volume::RefineParams::sliver_sweeps, 1, 20),
    };
    return specs;
}

// Stages named by the method whose sections a recipe may not use yet.
const std::vector<std::pair<std::string, std::string>> kPlannedSections = {};

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

void apply_key(const std::string& key, const YAML::Node& value, Recipe& recipe, const std::string& origin) {
    for (const auto& spec : key_specs())
        if (spec.path == key) {
            if (value.IsNull() && spec.default_yaml == "null") return;  // explicit "not set"
            spec.apply(value, recipe, Where{origin, key});
            return;
        }
    const std::string section = key.substr(0, key.find('.'));
    for (const auto& [name, issue] : kPlannedSections)
        if (section == name)
            FM_THROW(InputError, origin + ": " + key + ": the " + name +
                                     " stage is not available in this version of frontmesh yet (issue " + issue + ")");
    unknown_key(key, origin);
}

std::string origin_of(const std::string& path, const YAML::Node& node) {
    const auto mark = node.Mark();
    return mark.line >= 0 ? path + ":" + std::to_string(mark.line + 1) : path;
}

}  // namespace

Recipe load_recipe(const std::string& path, const std::vector<std::string>& overrides) {
    Recipe recipe;
    if (!fs::exists(path)) FM_THROW(InputError, "recipe '" + path + "' does not exist");
    recipe.path = fs::absolute(path).lexically_normal().string();
    for (const auto& spec : key_specs())
        if (spec.default_yaml != "null") spec.apply(YAML::Load(spec.default_yaml), recipe, Where{"defaults", spec.path});

    YAML::Node root;
    try {
        root = YAML::LoadFile(path);
    } catch (const YAML::Exception& e) {
        FM_THROW(InputError, path + ":" + std::to_string(e.mark.line + 1) + ": YAML syntax error: " + e.msg);
    }
    if (!root.IsNull() && !root.IsMap()) FM_THROW(InputError, path + ": the recipe must be a mapping of sections");
    std::vector<std::string> seen;
    if (root.IsMap()) {
        for (const auto& section : root) {
            const std::string name = section.first.as<std::string>();
            const std::string origin = origin_of(path, section.first);
            if (!section.second.IsMap()) {
                bool known = false;
                for (const auto& spec : key_specs()) known |= spec.path.rfind(name + ".", 0) == 0;
                if (!known) unknown_key(name, origin);
                FM_THROW(InputError, origin + ": " + name + ": expected a section of keys, got " + describe(section.second));
            }
            for (const auto& entry : section.second) {
                const std::string key = name + "." + entry.first.as<std::string>();
                apply_key(key, entry.second, recipe, origin_of(path, entry.first));
                seen.push_back(key);
            }
        }
    }
    for (const std::string& item : overrides) {
        const auto eq = item.find('=');
        if (eq == std::string::npos || eq == 0)
            FM_THROW(InputError, "--set " + item + ": expected key.path=value");
        const std::string key = item.substr(0, eq);
        YAML::Node value;
        try {
            value = YAML::Load(item.substr(eq + 1));
        } catch (const YAML::Exception& e) {
            FM_THROW(InputError, "--set " + key + ": cannot read the value: " + e.msg);
        }
        // Relative paths given on the command line are relative to the current folder.
        if ((key == "input.image" || key == "input.surface" || key == "input.label_names") && value.IsScalar())
            value = YAML::Node(fs::absolute(value.Scalar()).lexically_normal().string());
        apply_key(key, value, recipe, "--set");
        seen.push_back(key);
    }

    auto origin_for = [&](const std::string& key) {
        if (root.IsMap()) {
            const auto dot = key.find('.');
            const YAML::Node section = root[key.substr(0, dot)];
            if (section.IsMap())
                for (const auto& entry : section)
                    if (entry.first.as<std::string>() == key.substr(dot + 1)) return origin_of(path, entry.first);
        }
        return std::find(seen.begin(), seen.end(), key) != seen.end() ? std::string("--set") : path;
    };
    const InputSection& in = recipe.input;
    if (in.image.empty() == in.surface.empty())
        FM_THROW(InputError, path + ": input: give exactly one of input.image or input.surface");
    if (!in.image.empty() && !fs::exists(in.image) && in.image.find('%') == std::string::npos)
        FM_THROW(InputError, origin_for("input.image") + ": input.image: '" + in.image + "' does not exist");
    if (!in.surface.empty() && !fs::exists(in.surface))
        FM_THROW(InputError, origin_for("input.surface") + ": input.surface: '" + in.surface + "' does not exist");
    if (!in.label_names.empty() && !fs::exists(in.label_names))
        FM_THROW(InputError, origin_for("input.label_names") + ": input.label_names: '" + in.label_names +
                                 "' does not exist");
    if (in.threshold && !(in.labels.empty() || in.labels == std::vector<core::Label>{1}))
        FM_THROW(InputError, origin_for("input.labels") +
                                 ": input.labels: with input.threshold the mask has the single label 1; use [1] or all");
    recipe.extract.labels = in.labels;
    surface::validate(recipe.extract);
    surface::validate(recipe.repair);
    surface::validate(recipe.remesh);
    volume::validate(recipe.tetra);
    volume::validate(recipe.refine);
    return recipe;
}

std::vector<std::pair<std::string, std::string>> recipe_keys() {
    std::vector<std::pair<std::string, std::string>> keys;
    for (const auto& spec : key_specs()) keys.emplace_back(spec.path, spec.default_yaml);
    return keys;
}

std::string canonical_params(const Recipe& recipe, const std::string& section) {
    std::ostringstream s;
    s.precision(17);
    if (section == "input") {
        s << "image=" << recipe.input.image << ";surface=" << recipe.input.surface << ";labels=";
        for (auto l : recipe.input.labels) s << l << ',';
        s << ";threshold=" << (recipe.input.threshold ? std::to_string(*recipe.input.threshold) : "none");
        if (recipe.input.spacing) s << ";spacing=" << recipe.input.spacing->transpose();
        s << ";frame=" << core::frame_name(recipe.output.frame);
    } else if (section == "extract") {
        const auto& e = recipe.extract;
        s << "method=" << static_cast<int>(e.method) << ";blur=" << e.blur_sigma_mm
          << ";iterations=" << e.smoothing_iterations << ";relaxation=" << e.smoothing_relaxation
          << ";cleanup=" << e.manifold_cleanup << ";closing=" << recipe.morphology.closing_voxels
          << ";opening=" << recipe.morphology.opening_voxels;
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
          << ";check_si=" << m.check_self_intersections << ";max_volume=" << m.max_volume_change_percent;
        for (const auto& [label, size] : m.label_edge_length) s << ";label" << label << "=" << size;
    } else if (section == "tetra") {
        const auto& t = recipe.tetra;
        s << "stretching=" << t.stretching << ";height_smoothing=" << t.height_smoothing_iterations
          << ";max_remesh=" << t.max_remesh_per_node << ";min_angle=" << t.min_angle_deg
          << ";closing=" << t.max_closing_rounds;
    } else if (section == "refine") {
        const auto& f = recipe.refine;
        s << "node_removal=" << f.node_removal << ";max_tets=" << f.node_removal_max_tets << ";passes=" << f.passes
          << ";smoothing=" << f.smoothing << ";sweeps=" << f.smoothing_sweeps
          << ";smoothing_skewness=" << f.smoothing_skewness << ";flip_skewness=" << f.flip_skewness
          << ";ring=" << f.flip_max_ring << ";delaunay=" << f.flip_delaunay_test << ";flip_sweeps=" << f.flip_sweeps
          << ";sliver=" << f.sliver_pass << ";sliver_deg=" << f.sliver_dihedral_deg
          << ";sliver_sweeps=" << f.sliver_sweeps;
    } else {
        FM_CHECK(false && "unknown recipe section");
    }
    return s.str();
}

}  // namespace frontmesh::pipeline
