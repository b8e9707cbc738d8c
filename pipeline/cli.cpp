#include "pipeline/cli.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <tbb/global_control.h>

#include "io/atomic_file.h"
#include "io/export.h"
#include "io/image_reader.h"
#include "io/label_table.h"
#include "io/mesh_io.h"
#include "pipeline/check.h"
#include "pipeline/cohort.h"
#include "pipeline/core/error.h"
#include "pipeline/core/input_file.h"
#include "pipeline/core/surface_check.h"
#include "pipeline/output_dir.h"
#include "pipeline/recipe.h"
#include "pipeline/resource_estimate.h"
#include "pipeline/runner.h"
#include "pipeline/terminal.h"
#include "pipeline/version.h"
#include "surface/extract.h"

namespace frontmesh::pipeline {
namespace {

constexpr const char* kUsage = R"(frontmesh - isotropic tetrahedral meshes from segmented 3-D images

Usage:
  frontmesh mesh IMAGE [-o DIR] [--labels LIST|TABLE] [--size MM] [--format LIST]
                            [--set key.path=value ...] [--force] [--threads N] [--quiet]
  frontmesh run RECIPE.yaml [--set key.path=value ...] [--from STAGE] [--until STAGE]
                            [--force] [--threads N] [--quiet]
  frontmesh validate RECIPE.yaml [--set key.path=value ...]
  frontmesh cohort MANIFEST.csv --recipe RECIPE.yaml [-j N] [--set key.path=value ...]
                            [--until STAGE] [--force] [--threads N] [--quiet]
  frontmesh check MESH [--json] [--surface REF]
  frontmesh convert IN OUT [--format NAME] [--labels TABLE]
  frontmesh keys                 list every recipe key: default, doc, unit, range
  frontmesh --help | --version

Commands:
  mesh      the common case without writing a recipe: mesh IMAGE with the defaults and
            the options given, into DIR (default: IMAGE's name without extension +
            "-mesh", in the current folder); writes the recipe it used, every key with
            its value, as DIR/recipe.yaml (`frontmesh run DIR/recipe.yaml` runs it
            again), then runs it exactly as `run` does
  run       validate the recipe, then run its stages; each stage writes
            OUTPUT/checkpoints/NN-STAGE.vtu; OUTPUT/run-surface.pvd and run-volume.pvd
            step through its surface and tet stages in ParaView; OUTPUT/summary.json has
            times, memory and quality figures
  validate  check the recipe and its input files without running anything
  cohort    run the recipe for every subject of MANIFEST.csv (columns id, image, then
            recipe keys as per-subject overrides) into OUTPUT/ID/, N subjects at a time
            (-j N), each in its own process; writes OUTPUT/cohort-summary.csv and .json;
            finished subjects are skipped on a re-run; exit 1 if any subject failed
  check     validity and quality report of a tetrahedral mesh (.vtu .msh .mesh .inp):
            inverted/degenerate/duplicate tets, conformity, closed boundary, volume vs
            enclosed volume (the criteria of meshcheck.py), boundary faces kept with their
            regions, skewness (Eq. 1), dihedral angles, surface triangle skewness (Eq. 2);
            exit 0 valid, 1 invalid, 2 unreadable input
  convert   read IN (.vtu .msh .mesh .inp) and write OUT in the format of its extension
            (.vtu .msh .mesh .inp .feb) or of --format (vtu msh msh22 mesh inp feb)

Options:
  --set key.path=value  override a recipe key (YAML value), e.g. --set input.threshold=30
  --from STAGE          start at STAGE, reading the previous stage's checkpoint
  --until STAGE         stop after STAGE
  --force               run every stage even if its checkpoint is up to date
  --threads N           worker threads (default: all cores); results do not depend on it
  --quiet               only warnings and errors on the terminal (the log has all)
  -o, --output DIR      mesh: the output folder (output.dir)
  --labels LIST|TABLE   mesh: labels to mesh (input.labels), "1,4,7" or "all"; or a label
                        table file (input.label_names) for region names
  --size MM             mesh: target edge length in mm (remesh.edge_length); default: about
                        1.3 voxels
  --format LIST         mesh: files of the mesh besides mesh.vtu, e.g. "msh,inp"
                        (output.formats: vtu msh msh22 mesh inp feb)
  --recipe FILE         cohort: the recipe every subject runs
  -j, --jobs N          cohort: subjects running at the same time (default 1)
  --json                check: print the report as JSON instead of text
  --surface REF         check: a triangle surface (.vtu .vtp .stl .off .ply) that must be
                        preserved exactly (every triangle a mesh face, and back)
  --format NAME         convert: output format (vtu msh msh22 mesh inp feb)
  --labels TABLE        convert: label names (atlas .txt, FreeSurfer/ITK-SNAP table) for
                        region, group and set names

Stages, in order: extract, repair, remesh, tetra, refine.
A stage whose input and parameters are unchanged since the last run is skipped.
Every recipe key, its default and unit: configs/reference.yaml.

Exit codes: 0 success, 2 bad input or recipe, 1 internal failure, 130 interrupted
(Ctrl-C or SIGTERM: the running stage stops, finished checkpoints are kept and
summary.json says "interrupted"; cohort: 2 bad manifest or recipe, 1 when any
subject failed).
)";

struct Arguments {
    std::string command, recipe, from, until, cohort_recipe;
    std::string output, surface, format, labels;  // check / convert / mesh
    std::string output_dir, size;                 // mesh
    bool json = false;
    std::vector<std::string> overrides;
    bool force = false, quiet = false;
    int threads = 0, jobs = 0;
};

int whole_number(const std::string& flag, const std::string& v) {
    int n = -1;
    try {
        n = std::stoi(v);
    } catch (...) {
    }
    if (n < 1) FM_THROW(InputError, flag + " " + v + ": expected a whole number >= 1");
    return n;
}

Arguments parse(int argc, char** argv) {
    Arguments a;
    std::vector<std::string> args(argv + 1, argv + argc);
    auto value = [&](std::size_t& i) -> std::string {
        if (i + 1 >= args.size())
            FM_THROW(InputError, args[i] + ": needs a value (see frontmesh --help)");
        // `--until ''` ran every stage as if no --until were given.
        if (args[i + 1].empty())
            FM_THROW(InputError, args[i] + ": an empty value (see frontmesh --help)");
        return args[++i];
    };
    for (std::size_t i = 0; i < args.size(); ++i) {
        const std::string& arg = args[i];
        if (arg == "--set")
            a.overrides.push_back(value(i));
        else if (arg.rfind("--set=", 0) == 0)
            a.overrides.push_back(arg.substr(6));
        else if (arg == "--from")
            a.from = value(i);
        else if (arg == "--until")
            a.until = value(i);
        else if (arg == "--force")
            a.force = true;
        else if (arg == "--quiet")
            a.quiet = true;
        else if (arg == "--threads")
            a.threads = whole_number(arg, value(i));
        else if (arg == "--recipe")
            a.cohort_recipe = value(i);
        else if (arg == "-j" || arg == "--jobs")
            a.jobs = whole_number(arg, value(i));
        else if (arg == "--json")
            a.json = true;
        else if (arg == "--surface")
            a.surface = value(i);
        else if (arg == "--format")
            a.format = value(i);
        else if (arg == "--labels")
            a.labels = value(i);
        else if (arg == "-o" || arg == "--output")
            a.output_dir = value(i);
        else if (arg == "--size")
            a.size = value(i);
        else if (arg.size() > 2 && arg.rfind("-j", 0) == 0)
            a.jobs = whole_number("-j", arg.substr(2));
        else if (!arg.empty() && arg[0] == '-') {
            FM_THROW(InputError, arg + ": unknown option (see frontmesh --help)");
        } else if (a.command.empty()) {
            a.command = arg;
        } else if (a.recipe.empty()) {
            a.recipe = arg;
        } else if (a.command == "convert" && a.output.empty()) {
            a.output = arg;
        } else {
            FM_THROW(InputError, arg + ": unexpected argument (see frontmesh --help)");
        }
    }
    return a;
}

// Runs the recipe and prints where its results are.
int run_and_report(const Recipe& recipe, const RunOptions& options) {
    const std::string result = run_recipe(recipe, options);
    // Wrapped at the terminal's width like the run's other summary lines; as is in a pipe.
    std::cout << results_text(result, recipe.output.dir, terminal_columns(STDOUT_FILENO));
    return 0;
}

// The labels of `frontmesh mesh --labels`: "all", or whole numbers separated by commas or
// spaces, as a YAML list; empty when `text` is none of these (then it names a table).
std::string label_list_yaml(const std::string& text) {
    if (text == "all") return "all";
    std::string list;
    std::istringstream items(text);
    for (std::string item; std::getline(items, item, ',');) {
        std::istringstream words(item);
        for (std::string word; words >> word;) {
            if (word.find_first_not_of("0123456789") != std::string::npos) return {};
            list += (list.empty() ? "" : ", ") + word;
        }
    }
    return list.empty() ? std::string() : "[" + list + "]";
}

// The recipe of `frontmesh mesh`: the defaults and the options given, as recipe text.
std::string mesh_recipe_text(const Arguments& args, const std::filesystem::path& dir) {
    namespace fs = std::filesystem;
    auto quoted = [](const std::string& text) {  // a YAML single-quoted scalar
        std::string out = "'";
        for (char c : text) out += c == '\'' ? std::string("''") : std::string(1, c);
        return out + "'";
    };
    std::string text =
        "input:\n  image: " + quoted(fs::absolute(args.recipe).lexically_normal().string()) + "\n";
    if (!args.labels.empty()) {
        const std::string list = label_list_yaml(args.labels);
        if (!list.empty())
            text += "  labels: " + list + "\n";
        else if (std::error_code ec; std::filesystem::is_regular_file(args.labels, ec))
            text +=
                "  label_names: " + quoted(fs::absolute(args.labels).lexically_normal().string()) +
                "\n";
        else
            FM_THROW(InputError, "--labels " + args.labels +
                                     ": expected labels such as 1,4,7 (or all), or a label "
                                     "table file");
    }
    text += "output:\n  dir: " + quoted(dir.string()) + "\n";
    if (!args.format.empty()) {
        std::string list;
        std::istringstream items(args.format);
        for (std::string item; std::getline(items, item, ',');)
            if (!item.empty()) list += (list.empty() ? "" : ", ") + item;
        text += "  formats: [" + list + "]\n";
    }
    if (!args.size.empty()) text += "remesh:\n  edge_length: " + args.size + "\n";
    return text;
}

// frontmesh mesh IMAGE: builds the recipe, writes it (every key) into the output folder,
// and runs that file as `frontmesh run` would, so the run and the file cannot differ.
int run_mesh_command(const Arguments& args, RunOptions options) {
    namespace fs = std::filesystem;
    if (args.recipe.empty())
        FM_THROW(InputError,
                 "mesh: usage: frontmesh mesh IMAGE [-o DIR] [--labels LIST] [--size MM] "
                 "[--format LIST]");
    if (args.recipe.find('%') == std::string::npos)  // a slice pattern: the reader checks
        core::require_input_file(args.recipe, "mesh: image ", true);
    fs::path dir = args.output_dir;
    if (dir.empty()) {
        fs::path stem = fs::path(args.recipe).filename();
        while (!stem.extension().empty()) stem = stem.stem();  // a.nii.gz: at most 2 passes
        dir = stem.string() + "-mesh";
    }
    dir = fs::absolute(dir).lexically_normal();
    const fs::path recipe_file = dir / "recipe.yaml";
    // Checked whole (image, keys, output folder) before anything is written.
    const Recipe built = parse_recipe(mesh_recipe_text(args, dir), recipe_file, args.overrides);
    io::check_label_image(built.input.image, {.threshold = built.input.threshold,
                                              .spacing = built.input.spacing,
                                              .max_image_gib = built.input.max_image_gib});
    const std::string text = "# Written by frontmesh " + std::string(version()) +
                             " mesh: every key with the value the run used.\n# Run it again "
                             "with: frontmesh run " +
                             recipe_file.string() + "\n" + effective_recipe_yaml(built);
    // The run is the file's text read back, so the two cannot differ; the file is written
    // when the run first writes into the folder, after the checks that need the image (a
    // size whose work is beyond limits.max_memory_gib left recipe.yaml and the marker
    // behind; found by the malformed-input campaign, issue 21).
    const Recipe recipe = parse_recipe(text, recipe_file.string());
    options.files_on_claim.emplace_back("recipe.yaml", text);
    if (!options.quiet) std::cerr << "recipe: " << recipe_file.string() << '\n';
    return run_and_report(recipe, options);
}

RunOptions run_options(const Arguments& args) {
    RunOptions options;
    options.from = args.from;
    options.until = args.until;
    options.force = args.force;
    options.quiet = args.quiet;
    return options;
}

int run_cohort_command(const Arguments& args) {
    if (args.recipe.empty() || args.cohort_recipe.empty())
        FM_THROW(InputError,
                 "cohort: usage: frontmesh cohort MANIFEST.csv --recipe RECIPE.yaml [-j N]");
    if (!args.from.empty()) FM_THROW(InputError, "cohort: --from is for run");
    if (!args.until.empty()) {
        const auto& names = stage_names();
        if (std::find(names.begin(), names.end(), args.until) == names.end())
            FM_THROW(InputError, "--until " + args.until + ": unknown stage");
    }
    CohortOptions options;
    options.recipe = args.cohort_recipe;
    options.overrides = args.overrides;
    options.jobs = std::max(args.jobs, 1);
    options.force = args.force;
    options.until = args.until;
    options.threads = args.threads;
    if (!args.quiet)
        options.on_progress = [](const std::string& line) { std::cerr << line << '\n'; };
    const CohortResult result = run_cohort(args.recipe, options);
    const auto root = std::filesystem::path(result.root);
    std::cout << "\nSubjects: " << result.count(SubjectStatus::Ok) << " ok, "
              << result.count(SubjectStatus::Skipped) << " skipped (up to date), "
              << result.count(SubjectStatus::Failed) << " failed"
              << "\nSummary:  " << (root / "cohort-summary.csv").string() << "\n          "
              << (root / "cohort-summary.json").string() << "\nResults:  " << (root / "ID").string()
              << "/ (each with its summary.json, frontmesh.log and cohort-run.log)\n";
    return result.count(SubjectStatus::Failed) ? 1 : 0;
}

// validate with input.surface: the surface is read and checked as a run with the same
// --from and --until checks it (coordinates and labels; with --from tetra or remesh,
// meshable as it is), and the work of remesh and tetra on it estimated against
// limits.max_memory_gib (issue 21); repair changes the surface's extent little.
void validate_surface_input(const Recipe& recipe, const std::string& from,
                            const std::string& until) {
    const std::string source = "input.surface '" + recipe.input.surface + "'";
    const core::SurfaceNetwork surface = io::read_surface(recipe.input.surface);
    core::require_valid_regions(surface, source);
    if (from == "refine") return;  // the run reads its 04-tetra checkpoint instead
    if (from == "tetra") {
        core::require_meshable_surface(surface, source);
        core::require_tetra_ready_faces(surface, source);
        require_within_memory_limit(tetra_estimate(surface, recipe.tetra),
                                    recipe.limits.max_memory_gib);
        return;
    }
    if (from == "remesh") core::require_meshable_surface(surface, source);  // its background
    const bool tetra = until.empty() || until == "tetra" || until == "refine";
    if (!until.empty() && until != "remesh" && !tetra) return;
    require_input_within_memory_limit(remesh_estimate(surface, recipe.remesh),
                                      enclosed_volume(surface), tetra, recipe.tetra,
                                      recipe.limits.max_memory_gib);
}

// validate with input.image, when the run reads it: the image is read and its labels
// checked as extract checks them (absent or negative labels; validate said "valid" to a
// label the run then refused, found by the malformed-input campaign, issue 21), and the
// work of remesh and tetra estimated from it as the run does before any stage.
void validate_image_input(const Recipe& recipe, const std::string& until) {
    io::ImageReadOptions read;
    read.threshold = recipe.input.threshold;
    read.spacing = recipe.input.spacing;
    read.max_image_gib = recipe.input.max_image_gib;
    read.frame = recipe.output.frame;
    const core::LabelImage image = io::read_label_image(recipe.input.image, read);
    surface::check_labels(image, recipe.extract.labels);
    const bool tetra = until.empty() || until == "tetra" || until == "refine";
    if (!until.empty() && until != "remesh" && !tetra) return;
    require_input_within_memory_limit(remesh_estimate(image, recipe.extract.labels, recipe.remesh),
                                      labelled_volume(image, recipe.extract.labels), tetra,
                                      recipe.tetra, recipe.limits.max_memory_gib);
}

// "key: default" then, from column 48, "# doc (unit, range)".
void print_keys() {
    for (const RecipeKey& k : recipe_keys()) {
        std::string line = k.key + ": " + k.default_yaml;
        line.resize(std::max<std::size_t>(line.size() + 1, 47), ' ');
        std::string detail = k.unit;
        if (!k.range.empty()) detail += (detail.empty() ? "" : ", ") + k.range;
        std::cout << line << "# " << k.doc << (detail.empty() ? "" : " (" + detail + ")") << '\n';
    }
}

int run_check_command(const Arguments& args) {
    if (args.recipe.empty())
        FM_THROW(InputError, "check: usage: frontmesh check MESH [--json] [--surface REF]");
    const MeshReport report = check_mesh_file(args.recipe, args.surface);
    std::cout << (args.json ? report.json() : report.text());
    return report.valid() ? 0 : 1;
}

int run_convert_command(const Arguments& args) {
    if (args.recipe.empty() || args.output.empty())
        FM_THROW(InputError,
                 "convert: usage: frontmesh convert IN OUT [--format NAME] [--labels TABLE]");
    const io::MeshFormat format =
        args.format.empty() ? io::format_from_path(args.output) : io::format_from_name(args.format);
    io::LabelTable names;
    io::MeshReadInfo info;
    core::require_input_file(args.recipe, "convert: ");  // stat first: a pipe would block
    const core::TetMesh mesh = io::read_mesh(args.recipe, &names, &info);
    // The exports number regions from 1 (Gmsh physical groups, Abaqus and FEBio sets): a
    // region of -3 ended in an internal check of the FEBio writer (exit 1; campaign seed 7,
    // issue 21). `check` reports such a mesh as invalid; convert refuses it.
    for (std::size_t t = 0; t < mesh.tet_count(); ++t)
        if (mesh.region[t] <= 0)
            FM_THROW(InputError, "'" + args.recipe + "': tet " + std::to_string(t) +
                                     " has region " + std::to_string(mesh.region[t]) +
                                     "; a region is a positive label");
    if (!args.labels.empty()) {
        const io::LabelTable table = io::read_label_table(args.labels);
        for (const auto& [label, name] : table.names()) names.set(label, name);
    }
    io::write_mesh(mesh, args.output, format, names, info.fields);
    std::cout << args.output << ": " << mesh.node_count() << " nodes, " << mesh.tet_count()
              << " tets, " << mesh.face_count() << " boundary/interface faces ("
              << io::format_name(format) << ")\n";
    return 0;
}

}  // namespace

// A message printed as one line whatever it quotes: control characters (a newline inside
// a command name or a file name) are shown escaped (an unknown command "run\n" printed two
// lines; the malformed-input campaign, issue 21).
std::string one_line(const std::string& text) {
    std::string out;
    for (const char c : text) {
        const auto u = static_cast<unsigned char>(c);
        if (c == '\n') {
            out += "\\n";
        } else if (c == '\r') {
            out += "\\r";
        } else if (c == '\t') {
            out += "\\t";
        } else if (u < 0x20 || u == 0x7f) {
            char hex[8];
            std::snprintf(hex, sizeof hex, "\\x%02x", u);
            out += hex;
        } else {
            out += c;
        }
    }
    return out;
}

int run_cli(int argc, char** argv) {
    for (int i = 1; i < argc; ++i) {
        if (!std::strcmp(argv[i], "--help") || !std::strcmp(argv[i], "-h") ||
            !std::strcmp(argv[i], "help")) {
            std::cout << kUsage;
            return 0;
        }
        if (!std::strcmp(argv[i], "--version")) {
            std::cout << "frontmesh " << version() << '\n';
            return 0;
        }
    }
    io::silence_vtk_console();  // each failure is one line of ours
    try {
        const Arguments args = parse(argc, argv);
        if (args.command.empty()) {
            std::cerr << kUsage;
            return 2;
        }
        if (args.command == "keys") {
            print_keys();
            return 0;
        }
        const bool mesh_command = args.command == "check" || args.command == "convert";
        const bool mesh_image = args.command == "mesh";
        if (!mesh_command && !mesh_image &&
            (args.json || !args.surface.empty() || !args.format.empty() || !args.labels.empty()))
            FM_THROW(InputError,
                     "--json, --surface, --format and --labels are for frontmesh "
                     "check / convert / mesh");
        if (!mesh_image && (!args.output_dir.empty() || !args.size.empty()))
            FM_THROW(InputError, "-o and --size are for frontmesh mesh");
        if (mesh_image && (args.json || !args.surface.empty() || !args.from.empty() || args.jobs ||
                           !args.cohort_recipe.empty()))
            FM_THROW(InputError,
                     "mesh: takes -o, --labels, --size, --format, --set, --until, "
                     "--force, --threads and --quiet (see frontmesh --help)");
        if (mesh_command && (!args.overrides.empty() || !args.from.empty() || !args.until.empty() ||
                             args.force || args.jobs || !args.cohort_recipe.empty()))
            FM_THROW(InputError, args.command + ": takes no recipe options (see frontmesh --help)");
        if (args.command == "check") return run_check_command(args);
        if (args.command == "convert") return run_convert_command(args);
        if (args.command == "cohort") return run_cohort_command(args);
        std::unique_ptr<tbb::global_control> threads;
        if (args.threads > 0)
            threads =
                std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                      static_cast<std::size_t>(args.threads));
        if (mesh_image) return run_mesh_command(args, run_options(args));
        if (args.command != "run" && args.command != "validate")
            FM_THROW(InputError, args.command +
                                     ": unknown command; use mesh, run, validate, cohort, check, "
                                     "convert or keys (see frontmesh --help)");
        if (!args.cohort_recipe.empty() || args.jobs)
            FM_THROW(InputError,
                     std::string(args.jobs ? "-j" : "--recipe") + ": only for frontmesh cohort");
        if (args.recipe.empty())
            FM_THROW(InputError, args.command + ": needs a recipe file (frontmesh " + args.command +
                                     " RECIPE.yaml)");
        const Recipe recipe = load_recipe(args.recipe, args.overrides);
        if (!recipe.input.image.empty())
            io::check_label_image(recipe.input.image,
                                  {.threshold = recipe.input.threshold,
                                   .spacing = recipe.input.spacing,
                                   .max_image_gib = recipe.input.max_image_gib});
        if (args.command == "validate") {
            if (!recipe.input.surface.empty())
                validate_surface_input(recipe, args.from, args.until);
            else if (args.from.empty() || args.from == "extract")
                validate_image_input(recipe, args.until);
            std::cout << args.recipe << ": valid; output in " << recipe.output.dir << '\n';
            return 0;
        }
        return run_and_report(recipe, run_options(args));
    } catch (const core::InputError& e) {
        std::cerr << "frontmesh: error: " << one_line(e.what()) << '\n';
        return 2;
    } catch (const core::CancelledError& e) {
        std::cerr << "frontmesh: " << one_line(e.what()) << '\n';
        return 130;  // as a shell reports a process ended by SIGINT
    } catch (const core::Error& e) {
        std::cerr << "frontmesh: error: " << one_line(e.what()) << '\n';
        return 1;
    } catch (const std::exception& e) {
        std::cerr << "frontmesh: internal error: " << one_line(e.what()) << '\n';
        return 1;
    }
}

}  // namespace frontmesh::pipeline
