#pragma once
// Cohorts: one recipe run over many subjects listed in a CSV manifest, each subject in its
// own child process (`frontmesh run`), N at a time, with one summary for the whole cohort.

#include <array>
#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace frontmesh::pipeline {

/// One row of a manifest.
struct CohortSubject {
    std::string id;     ///< folder name of the subject's results below the cohort root
    std::string image;  ///< absolute path (relative cells resolve against the manifest's folder)
    std::vector<std::pair<std::string, std::string>>
        overrides;  ///< recipe key -> YAML value, non-empty cells only
    int line = 0;   ///< line of the manifest where the row starts (1 = header)
};

/// A parsed manifest: the header and one entry per subject, in file order.
struct Manifest {
    std::string path;                  ///< absolute
    std::vector<std::string> columns;  ///< header names, in file order
    int header_line = 1;               ///< line of the header (blank lines before it are skipped)
    std::vector<CohortSubject> subjects;
};

/// Splits CSV text into records of fields (RFC 4180: comma separators, double-quoted
/// fields that may hold commas, line breaks and doubled quotes, LF or CRLF line ends).
/// Unquoted fields are trimmed of spaces and tabs; blank lines are skipped; a UTF-8 BOM is
/// ignored. Each record comes with the line it starts on. `origin` names the text in errors.
/// Throws InputError "origin:line: ..." for an unclosed quote or text after a closing quote.
std::vector<std::pair<int, std::vector<std::string>>> parse_csv(const std::string& text,
                                                                const std::string& origin);

/// Reads and checks the structure of the manifest at `path`: a header with the columns
/// `id` and `image` (any order) plus recipe keys, one row per subject with as many fields
/// as the header, ids unique and safe as folder names (letters, digits, '.', '_', '-',
/// starting with a letter or digit), non-empty images. Recipe keys are not checked here
/// (run_cohort checks them against the recipe). Throws InputError "path:line: ...".
Manifest read_manifest(const std::string& path);

struct CohortOptions {
    std::string recipe;  ///< recipe file; its output.dir is the cohort root
    std::vector<std::string>
        overrides;       ///< "key.path=value" for every subject (before the manifest's cells)
    int jobs = 1;        ///< subjects running at the same time, >= 1
    bool force = false;  ///< pass --force to every subject's run
    std::string until;   ///< pass --until STAGE to every subject's run; empty = do not
    int threads = 0;     ///< pass --threads N to every subject's run; 0 = do not
    /// The frontmesh executable run for each subject. The default names the running
    /// program itself, so the command line needs no path.
    std::string executable = "/proc/self/exe";
    /// Called once per finished subject with a line such as "[2/3] sub-02 ok in 4.1 s".
    std::function<void(const std::string&)> on_progress;
};

enum class SubjectStatus { Ok, Skipped, Failed };

/// "ok", "skipped" or "failed".
const char* subject_status_name(SubjectStatus status);

/// What one subject's run gave.
struct SubjectResult {
    std::string id;
    std::string dir;  ///< ROOT/ID, absolute
    SubjectStatus status = SubjectStatus::Failed;
    int exit_code = -1;   ///< of the child; 128 + signal number when it was killed
    double wall_s = 0.0;  ///< measured by the cohort, from start to exit of the child
    std::optional<double> total_wall_s;                ///< from the subject's summary.json
    std::optional<long long> faces;                    ///< of the last stage's result
    std::optional<long long> regions, regions_closed;  ///< of the last stage's result
    std::optional<long long> nodes, tets;              ///< a tetrahedral result
    std::optional<double> skewness_over_08;            ///< fraction of tets with skewness > 0.8
    std::optional<double> min_dihedral_deg;            ///< smallest dihedral angle of the tets
    std::vector<std::string> region_names;  ///< "LABEL:NAME" (or "LABEL") per region of the result
    std::vector<std::string> outputs;       ///< result files in ROOT/ID (not the checkpoints)
    std::string image;                      ///< the manifest's image, absolute
    /// From the subject's summary.json when this run wrote it (empty / nullopt otherwise):
    /// its path, the recipe file it ran, when it started and finished (ISO 8601), and the
    /// input image's dims (voxels) and spacing (mm) as read (none for a surface input).
    std::string summary, recipe, started, finished;
    std::optional<std::array<long long, 3>> image_dims;
    std::optional<std::array<double, 3>> image_spacing_mm;
    std::string error;  ///< failed: the child's last "frontmesh: error:" line, without that prefix
};

struct CohortResult {
    std::string root;                     ///< absolute cohort folder
    std::vector<SubjectResult> subjects;  ///< in manifest order
    std::size_t count(SubjectStatus status) const;
};

/// Runs `options.recipe` for every subject of the manifest at `manifest_path`.
/// Before anything runs, the manifest and, for each subject, the recipe with the subject's
/// overrides are validated (load_recipe); any problem throws InputError with one line and
/// nothing is written. A subject whose image does not exist is not a manifest error: its
/// run fails and is recorded, and the others go on. Each subject runs as
/// `EXECUTABLE run RECIPE --set ... --set input.image=IMAGE --set output.dir=ROOT/ID
/// --set KEY=CELL ... --quiet` with stdout and stderr in ROOT/ID/cohort-run.log, at most
/// `options.jobs` at a time. A subject that exits 0 is `skipped` when its summary.json
/// lists no stage that ran (every checkpoint was up to date), else `ok`. Writes
/// ROOT/cohort-summary.csv and ROOT/cohort-summary.json atomically, rows in manifest order.
/// Throws IoError when a summary cannot be written.
CohortResult run_cohort(const std::string& manifest_path, const CohortOptions& options);

}  // namespace frontmesh::pipeline
