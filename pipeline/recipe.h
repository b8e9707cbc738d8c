#pragma once
// The YAML recipe: parsed, fully validated and typed before any work starts.

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "io/split_interfaces.h"
#include "pipeline/core/label_image.h"
#include "pipeline/resource_estimate.h"
#include "surface/extract.h"
#include "surface/remesh.h"
#include "surface/repair.h"
#include "volume/refine.h"
#include "volume/tetra.h"

namespace frontmesh::pipeline {

struct InputSection {
    std::string image;                       ///< image file or folder (absolute), or empty
    std::string surface;                     ///< triangle surface file (absolute), or empty
    std::vector<core::Label> labels;         ///< empty = all
    std::optional<double> threshold;         ///< grayscale: value > threshold is label 1
    std::optional<Eigen::Vector3d> spacing;  ///< mm, slice stacks
    std::string label_names;                 ///< label table file (absolute), or empty: the table
                                             ///< beside the image when there is one
    double max_image_gib = 4.0;              ///< GiB an image may take while read (io limit)
};

struct OutputSection {
    std::string dir;  ///< absolute
    core::Frame frame = core::Frame::Lps;
    std::vector<std::string> formats{"vtu"};  ///< exports of a tet mesh: mesh.EXT
    bool binary = false;                      ///< binary mesh.msh (VTU is always binary)
    int order = 1;  ///< 1: linear tets; 2: quadratic (volume::elevate_to_quadratic)
    io::SplitInterfaces split_interfaces;  ///< interfaces whose nodes are doubled
    bool quality_report = true;            ///< report.html + SVG histograms after refine
    bool allow_input_folder = false;       ///< dir may be (or contain) the input's folder
};

/// Limits on the work a run may take on (issue 21): estimated before the stages that could
/// run away, refused beyond them (pipeline/resource_estimate.h).
struct LimitsSection {
    double max_memory_gib =
        default_max_memory_gib;  ///< GiB remesh or tetra may be expected to take
};

struct Recipe {
    std::string path;  ///< the recipe file, absolute
    /// Every key with the value in effect (default, then the file, then --set) as YAML flow
    /// text, in documentation order; paths absolute. summary.json and `frontmesh mesh`
    /// write it.
    std::vector<std::pair<std::string, std::string>> values;
    InputSection input;
    OutputSection output;
    LimitsSection limits;
    surface::ExtractParams extract;
    surface::RepairParams repair;
    surface::RemeshParams remesh;
    volume::TetraParams tetra;
    volume::RefineParams refine;
};

/// Reads and validates `path`, then applies `overrides` ("key.path=value", YAML values).
/// Relative input paths resolve against the recipe's folder, a relative output.dir against
/// the current folder. Throws InputError with one line naming the file, line and key:
/// unknown keys (with a did-you-mean), keys given twice, wrong types, out-of-range values,
/// missing files, a recipe that is not a readable file, an output.dir that may not be used
/// (check_output_dir, pipeline/output_dir.h).
Recipe load_recipe(const std::string& path, const std::vector<std::string>& overrides = {});

/// As load_recipe, from recipe text that is to live at `path` (not read; it need not exist
/// yet): relative input paths resolve against its folder and errors name it.
Recipe parse_recipe(const std::string& text, const std::string& path,
                    const std::vector<std::string>& overrides = {});

/// The recipe as a complete recipe file: every key with its value in effect (Recipe::values),
/// section by section. Loading it gives the same recipe, whatever folder it is read from.
std::string effective_recipe_yaml(const Recipe& recipe);

/// The values in effect as one JSON object {"key": value, ...} (YAML numbers, booleans,
/// null, lists and mappings as their JSON kinds, other scalars as strings), of the keys of
/// `section` ("tetra") or, when empty, of every key.
std::string effective_recipe_json(const Recipe& recipe, const std::string& section = {});

/// One recipe key as declared: by its stage (e.g. volume::tetra_keys()) or, for input.* and
/// output.*, by the recipe reader.
struct RecipeKey {
    std::string key;           ///< "tetra.stretching"
    std::string default_yaml;  ///< "1.15"
    std::string range;         ///< "(1, 2]"; empty for texts, choices and switches
    std::string unit;          ///< "mm", "deg", ...; empty: dimensionless or a count
    std::string doc;           ///< one line
};

/// Every recipe key in documentation order (input, output, then the stages in pipeline
/// order); `frontmesh keys` prints it and the tests check configs/reference.yaml against it.
std::vector<RecipeKey> recipe_keys();

/// Canonical text of a stage's parameters (the recipe section it reads), for stage hashes.
std::string canonical_params(const Recipe& recipe, const std::string& section);

}  // namespace frontmesh::pipeline
