#include "pipeline/runner.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <mutex>
#include <optional>
#include <regex>
#include <sstream>
#include <string_view>
#include <variant>

#include "io/atomic_file.h"
#include "io/export.h"
#include "io/image_reader.h"
#include "io/label_table.h"
#include "io/mesh_io.h"
#include "io/split_interfaces.h"
#include "pipeline/core/error.h"
#include "pipeline/core/quality.h"
#include "pipeline/core/surface_check.h"
#include "pipeline/diagnostics.h"
#include "pipeline/output_dir.h"
#include "pipeline/peak_memory.h"
#include "pipeline/quality_report.h"
#include "pipeline/report.h"
#include "pipeline/resource_estimate.h"
#include "pipeline/terminal.h"
#include "pipeline/version.h"
#include "surface/extract.h"
#include "surface/remesh.h"
#include "surface/repair.h"
#include "volume/mesh_check.h"
#include "volume/quadratic.h"
#include "volume/refine.h"
#include "volume/tetra.h"

namespace frontmesh::pipeline {
namespace {

namespace fs = std::filesystem;
using StageData =
    std::variant<std::monostate, core::LabelImage, core::SurfaceNetwork, core::TetMesh>;

// What a stage reads and writes; decides how checkpoints are read, written and reported.
enum class Kind { Image, Surface, Tets };

/// The ParaView collection of the checkpoints of one kind (README "Outputs").
std::string pvd_file_name(Kind kind) {
    return kind == Kind::Tets ? "run-volume.pvd" : "run-surface.pvd";
}

// What a stage function hands back: its result, and the extra per-point figures its
// checkpoint carries.
struct StageOutput {
    StageData data;
    io::PointArrays point_arrays;
};

StageOutput stage_output(core::SurfaceNetwork surface) { return {std::move(surface), {}}; }
StageOutput stage_output(core::TetMesh mesh) { return {std::move(mesh), {}}; }
StageOutput stage_output(surface::RemeshResult result) {
    StageOutput out{std::move(result.surface), {}};
    out.point_arrays["target_size"] = std::move(result.target_size);
    return out;
}

// A stage function `Out stage(const In&, const Params&, StageContext&)` (STYLE §3) applied
// to the input held in `data`.
template <typename Out, typename In, typename Params>
StageOutput call(Out (*stage)(const In&, const Params&, core::StageContext&), const StageData& data,
                 const Params& params, core::StageContext& ctx) {
    return stage_output(stage(std::get<In>(data), params, ctx));
}

// Runs `stage` with the parameters of the recipe section `section`.
template <auto section, auto stage>
StageOutput run_stage(const StageData& data, const Recipe& recipe, core::StageContext& ctx) {
    return call(stage, data, recipe.*section, ctx);
}

// One stage of the method. `name` is also its recipe section, whose canonical text
// (canonical_params) enters the stage hash.
struct StageDef {
    std::string name;
    int number;  // NN of checkpoints/NN-name.vtu, fixed by the method's order
    Kind in, out;
    StageOutput (*run)(const StageData&, const Recipe&, core::StageContext&);
};

const std::vector<StageDef>& stage_defs() {
    static const std::vector<StageDef> defs = {
        // name    NN  reads          checkpoint     parameters, stage function
        {"extract", 1, Kind::Image, Kind::Surface, &run_stage<&Recipe::extract, &surface::extract>},
        {"repair", 2, Kind::Surface, Kind::Surface, &run_stage<&Recipe::repair, &surface::repair>},
        {"remesh", 3, Kind::Surface, Kind::Surface, &run_stage<&Recipe::remesh, &surface::remesh>},
        {"tetra", 4, Kind::Surface, Kind::Tets, &run_stage<&Recipe::tetra, &volume::tetra>},
        {"refine", 5, Kind::Tets, Kind::Tets, &run_stage<&Recipe::refine, &volume::refine>},
    };
    return defs;
}

// FNV-1a, 64 bit: stage hashes decide whether a checkpoint is up to date.
struct Hash {
    std::uint64_t value = 1469598103934665603ull;
    void add(const void* data, std::size_t size) {
        const auto* bytes = static_cast<const unsigned char*>(data);
        for (std::size_t i = 0; i < size; ++i) value = (value ^ bytes[i]) * 1099511628211ull;
    }
    void add(const std::string& text) { add(text.data(), text.size() + 1); }
    void add_file(const fs::path& path) {
        std::ifstream in(path, std::ios::binary);
        std::vector<char> buffer(1 << 20);
        while (in) {
            in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
            add(buffer.data(), static_cast<std::size_t>(in.gcount()));
        }
    }
    std::string hex() const {
        char buf[17];
        std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(value));
        return buf;
    }
};

// The bytes of the input: a file, every file of a folder, or the files a pattern names.
std::string input_hash(const Recipe& recipe) {
    Hash h;
    h.add(std::string("frontmesh ") + version());
    h.add(canonical_params(recipe, "input"));
    const std::string source =
        recipe.input.image.empty() ? recipe.input.surface : recipe.input.image;
    std::vector<fs::path> files;
    std::error_code ec;  // the reader has checked the input; a name it expands is not thrown
    if (fs::is_directory(source, ec)) {
        for (const auto& entry : fs::directory_iterator(source))
            if (entry.is_regular_file()) files.push_back(entry.path());
    } else if (fs::exists(source, ec)) {
        files.push_back(source);
    } else {  // printf pattern: hash the folder it names
        const fs::path folder = fs::path(source).parent_path();
        if (fs::is_directory(folder, ec))
            for (const auto& entry : fs::directory_iterator(folder))
                if (entry.is_regular_file()) files.push_back(entry.path());
    }
    std::sort(files.begin(), files.end());
    for (const auto& f : files) {
        h.add(f.filename().string());
        h.add_file(f);
    }
    return h.hex();
}

// `text` with `marker` replaced by the size in bytes of the result: the fixed point of
// size = bytes(text without the marker) + digits(size). Each pass can only grow the digit
// count, which a size of bounded length bounds: at most 20 passes (a size_t has 20 digits).
std::string with_own_size(const std::string& text, const std::string& marker) {
    const std::size_t at = text.find(marker);
    if (at == std::string::npos) return text;
    const std::size_t base = text.size() - marker.size();
    std::size_t size = base + 1;
    for (int pass = 0; pass < 20; ++pass) {
        const std::size_t next = base + std::to_string(size).size();
        if (next == size) break;
        size = next;
    }
    std::string out = text;
    out.replace(at, marker.size(), std::to_string(size));
    return out;
}

std::string now_text() {
    const std::time_t t = std::time(nullptr);
    char buf[32];
    std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M:%S", std::localtime(&t));
    return buf;
}

// A moment as ISO 8601 / RFC 3339 local time with its offset: "2026-12-03T18:41:56+01:00".
std::string iso_time(std::chrono::system_clock::time_point when) {
    const std::time_t t = std::chrono::system_clock::to_time_t(when);
    std::tm local{};
    localtime_r(&t, &local);
    char buf[40];
    std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S%z", &local);
    const std::string text = buf;  // "+0100": RFC 3339 wants "+01:00"
    if (text.size() < 5) return text;
    std::ostringstream out;
    out << std::string_view(text).substr(0, text.size() - 2) << ':'
        << std::string_view(text).substr(text.size() - 2);
    return out.str();
}

// The labels listed as "labels": [1, 2] in a stage's part of summary.json (written by
// write_stage_summary); empty when there is none.
std::vector<core::Label> labels_in_part(const std::string& part) {
    std::vector<core::Label> labels;
    const std::string key = "\"labels\": [";
    const auto at = part.find(key);
    if (at == std::string::npos) return labels;
    std::istringstream list(part.substr(at + key.size(), part.find(']', at) - at - key.size()));
    for (std::string item; std::getline(list, item, ',');)  // one pass per label
        labels.push_back(static_cast<core::Label>(std::stol(item)));
    return labels;
}

std::string read_text(const fs::path& path) {
    std::ifstream in(path);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

// Log lines go to the terminal and to frontmesh.log; until the output folder exists they
// are kept in memory, so a run that fails on bad input leaves no folder behind. Stages log
// from TBB threads (child contexts), hence the mutex.
class Log {
public:
    Log(bool quiet) : quiet_(quiet), tty_(isatty(STDERR_FILENO)) {}

    void open(const fs::path& file) {
        const std::lock_guard lock(mutex_);
        file_.open(file, std::ios::app);
        for (const auto& line : pending_) file_ << line << '\n';
        pending_.clear();
        file_.flush();
    }
    void line(core::LogLevel level, const std::string& message) {
        const std::lock_guard lock(mutex_);
        if (level == core::LogLevel::Debug) return write_file("DEBUG " + message);
        const bool warning = level == core::LogLevel::Warning;
        // A terminal leaves out lines that only count zeros (the log file keeps them).
        if (warning || (!quiet_ && !(tty_ && lists_only_zeros(message)))) {
            clear_progress_locked();
            // A terminal gets long lines broken at word boundaries; a pipe or file gets one
            // line per message, as the log file does.
            const std::string text = (warning ? "warning: " : "") + message;
            std::cerr << (tty_ ? wrap_words(text, columns(), 4) : text) << '\n';
        }
        write_file((level == core::LogLevel::Warning ? "WARN  " : "INFO  ") + message);
    }
    /// A line for frontmesh.log only (the terminal gets its own line from the CLI).
    void note(const std::string& message) {
        const std::lock_guard lock(mutex_);
        write_file("INFO  " + message);
    }
    /// The stage whose progress follows starts now (its elapsed time counts from here). On a
    /// terminal the progress line is then also redrawn once a second (ticker_) until
    /// clear_progress(), so that its elapsed time moves while a long phase reports nothing.
    void begin_stage() {
        {
            const std::lock_guard lock(mutex_);
            stage_start_ = std::chrono::steady_clock::now();
            last_what_.clear();
            shown_.reset();
            has_progress_ = false;
        }
        if (tty_ && !quiet_) ticker_.start();
    }
    void progress(const std::string& stage, double fraction, const std::string& what) {
        if (quiet_) return;
        const std::lock_guard lock(mutex_);
        if (tty_) {
            // One line redrawn in place: stage, percent, elapsed time and time left; the
            // percent never goes back within a stage (a new remesh round counts from 0).
            stage_ = stage;
            what_ = what;
            fraction_ = shown_.update(fraction);
            has_progress_ = true;
            draw_progress_locked();
        } else if (what != last_what_) {
            const int percent = static_cast<int>(fraction * 100.0 + 0.5);
            char buf[200];
            std::snprintf(buf, sizeof buf, "  %-8s %3d%%  %s", stage.c_str(), percent,
                          what.c_str());
            std::cerr << buf << '\n';
        }
        last_what_ = what;
    }
    /// Ends the stage's progress line: stops the redraws (joins ticker_) and erases it.
    void clear_progress() {
        ticker_.stop();  // not under mutex_: a tick under way takes it
        const std::lock_guard lock(mutex_);
        has_progress_ = false;
        clear_progress_locked();
    }

private:
    // ticker_'s thread: the last progress line again, with the elapsed time now.
    void redraw() {
        const std::lock_guard lock(mutex_);
        if (has_progress_) draw_progress_locked();
    }
    void draw_progress_locked() {
        const double elapsed =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - stage_start_).count();
        std::cerr << "\r\033[K" << progress_line(stage_, fraction_, what_, elapsed, columns())
                  << std::flush;
        progress_shown_ = true;
    }
    static std::size_t columns() {
        const std::size_t n = terminal_columns(STDERR_FILENO);
        return n > 0 ? n : kDefaultColumns;
    }
    void clear_progress_locked() {
        if (progress_shown_) std::cerr << "\r\033[K" << std::flush;
        progress_shown_ = false;
    }
    void write_file(const std::string& text) {
        std::string stamped(1, '[');
        stamped.append(now_text()).append("] ").append(text);
        if (file_.is_open()) {
            file_ << stamped << '\n';
            file_.flush();
        } else {
            pending_.push_back(stamped);
        }
    }
    std::mutex mutex_;
    bool quiet_, tty_;
    bool progress_shown_ = false;
    std::string last_what_;
    std::chrono::steady_clock::time_point stage_start_ = std::chrono::steady_clock::now();
    std::ofstream file_;
    std::vector<std::string> pending_;
    // The last progress event on a terminal, for the redraws.
    std::string stage_, what_;
    double fraction_ = 0.0;
    bool has_progress_ = false;
    ShownFraction shown_;
    // Last: destroyed (stopped and joined) before the members its ticks use.
    ProgressTicker ticker_{[this] { redraw(); }};
};

struct Outputs {
    fs::path dir;
    fs::path checkpoint(const StageDef& s) const {
        char buf[64];
        std::snprintf(buf, sizeof buf, "%02d-%s.vtu", s.number, s.name.c_str());
        return dir / "checkpoints" / buf;
    }
    fs::path with_ext(const StageDef& s, const std::string& ext) const {
        return checkpoint(s).replace_extension(ext);
    }
    fs::path diagnostics() const { return dir / "diagnostics"; }
};

StageData read_checkpoint(const fs::path& path, Kind kind) {
    if (kind == Kind::Tets) return io::read_tet_mesh(path.string());
    return io::read_surface(path.string());
}

// Set by SIGINT/SIGTERM while a run has its handlers installed; read by the stages through
// their StageContext. Lock-free, so the handler may store to it.
std::atomic<bool> stop_requested{false};
static_assert(std::atomic<bool>::is_always_lock_free);

extern "C" void request_stop(int) { stop_requested.store(true); }

// SIGINT and SIGTERM ask the run to stop for as long as this lives; the previous handlers
// come back after it. SA_RESTART: a blocking read goes on after the signal. SA_RESETHAND: a
// second Ctrl-C ends the process at once.
class StopSignals {
public:
    StopSignals() {
        stop_requested.store(false);
        struct sigaction action = {};
        action.sa_handler = request_stop;
        sigemptyset(&action.sa_mask);
        action.sa_flags = SA_RESTART | SA_RESETHAND;
        sigaction(SIGINT, &action, &previous_int_);
        sigaction(SIGTERM, &action, &previous_term_);
    }
    ~StopSignals() {
        sigaction(SIGINT, &previous_int_, nullptr);
        sigaction(SIGTERM, &previous_term_, nullptr);
    }
    StopSignals(const StopSignals&) = delete;
    StopSignals& operator=(const StopSignals&) = delete;

private:
    struct sigaction previous_int_ = {}, previous_term_ = {};
};

// Quality figures of a checkpoint: JSON for summary.json, one line for the log.
struct Quality {
    std::string json, line;
};

// One run of a recipe, step by step: plan which stages run, read their input, run each,
// write the result files and the summary.
class Run {
public:
    Run(const Recipe& recipe, const RunOptions& options, const std::atomic<bool>* cancel)
        : recipe_(recipe),
          options_(options),
          cancel_(cancel),
          stages_(stage_defs()),
          log_(options.quiet),
          out_{recipe.output.dir},
          frame_(core::frame_name(recipe.output.frame)),
          diagnostics_(out_.diagnostics(),
                       [this](core::LogLevel level, const std::string& m) { log_.line(level, m); },
                       {{"frame", frame_}, {"frontmesh_version", version()}}) {}

    std::string execute() {
        remove_stale_temp_files();
        plan_stages();
        read_label_names();
        chain_hashes();
        skip_up_to_date_stages();
        check_cancelled("before reading the input");
        read_input();
        check_input_resources();
        if (first_ > last_)
            info("every stage up to " + stages_[last_].name + " is up to date; nothing to run");
        mark_reused_stages();
        for (int i = first_; i <= last_; ++i) run_one(i);
        return write_results();
    }

private:
    void info(const std::string& m) { log_.line(core::LogLevel::Info, m); }
    void warn_obtuse_triangles(const core::SurfaceNetwork& surface);
    /// How messages name input.surface.
    std::string user_surface() const { return "input.surface '" + recipe_.input.surface + "'"; }
    int index_of(const std::string& name, const char* flag) const;
    void plan_stages();
    void read_label_names();
    void chain_hashes();
    void skip_up_to_date_stages();
    void check_cancelled(const std::string& when);
    [[noreturn]] void stop(const std::string& when);
    void read_input();
    std::string image_json(const core::LabelImage& image, int pad) const;
    void prepare_folder();
    void remove_stale_temp_files();
    void committed(const fs::path& file);
    void mark_reused_stages();
    void run_one(int i);
    StageOutput call_stage(int i, core::StageContext& ctx);
    bool runs(const std::string& stage) const;
    void check_resources(int i);
    void check_input_resources();
    Quality write_checkpoint(int i, const StageOutput& output);
    void write_stage_summary(int i, const core::StageContext& ctx, double wall,
                             const Quality& quality, std::chrono::system_clock::time_point started);
    std::string write_results();
    std::string results_key() const;
    core::TetMesh elevate(const core::TetMesh& mesh);
    void write_exports(const fs::path& result, const fs::path& last_checkpoint,
                       const std::vector<fs::path>& stale, bool ran_any);
    ReportContext report_context() const;
    void write_pvd();
    void write_summary(const std::string& status, const std::string& error);

    const Recipe& recipe_;
    const RunOptions& options_;
    const std::atomic<bool>* cancel_;
    const std::vector<StageDef>& stages_;
    const std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
    PeakMemory stage_memory_;  ///< reset at each stage's start (run_one)
    Log log_;
    const Outputs out_;
    const std::string frame_;
    DiagnosticsWriter diagnostics_;
    io::LabelTable names_;
    bool surface_input_ = false;
    int entry_ = 0, first_ = 0, last_ = 0;
    std::vector<std::string> hashes_;
    StageData data_;  // the input of the next stage to run, then the last stage's result
    bool folder_ready_ = false;
    const std::chrono::system_clock::time_point started_ = std::chrono::system_clock::now();
    std::string input_json_;  // the image's metadata, until the folder exists to hold it
    std::optional<QualityHistograms> tetra_histograms_;  // kept for the quality report
    std::vector<core::TetFigures> figures_;              // of the last tet mesh a stage made
    std::vector<fs::path> results_;  // the result files this run wrote or found up to date
};

int Run::index_of(const std::string& name, const char* flag) const {
    for (std::size_t i = 0; i < stages_.size(); ++i)
        if (stages_[i].name == name) return static_cast<int>(i);
    std::string list;
    for (const auto& s : stages_) list += (list.empty() ? "" : ", ") + s.name;
    FM_THROW(InputError, std::string(flag) + " " + name + ": unknown stage; stages: " + list);
}

// A surface input enters at repair, or at the stage --from names (e.g. --from tetra meshes
// the surface as it is); an image enters at extract. --from a stage that needs a tet mesh
// (refine) enters the surface at the last stage before it that takes one (tetra) and reads
// that stage's checkpoint, as a run from the image would.
void Run::plan_stages() {
    surface_input_ = !recipe_.input.surface.empty();
    last_ = options_.until.empty() ? static_cast<int>(stages_.size()) - 1
                                   : index_of(options_.until, "--until");
    first_ = options_.from.empty() ? -1 : index_of(options_.from, "--from");
    entry_ = !surface_input_ ? 0 : first_ >= 0 ? first_ : index_of("repair", "input.surface");
    if (surface_input_ && stages_[entry_].in == Kind::Tets)
        while (entry_ > 0 && stages_[entry_].in != Kind::Surface) --entry_;
    if (surface_input_ && stages_[entry_].in != Kind::Surface)
        FM_THROW(InputError, "--from " + options_.from +
                                 ": input.surface is a triangle surface; the " +
                                 stages_[entry_].name + " stage needs an image");
    if (first_ > last_)
        FM_THROW(InputError, "--from " + options_.from + " comes after --until " + options_.until);
}

// Region names for the exports: the recipe's table, else the one beside the image. Read
// before any work so a bad table fails fast.
void Run::read_label_names() {
    std::string table = recipe_.input.label_names;
    if (table.empty() && !recipe_.input.image.empty())
        table = io::label_table_beside(recipe_.input.image);
    if (!table.empty()) names_ = io::read_label_table(table);
}

// Stage hashes chain the input's bytes and every earlier stage's parameters.
void Run::chain_hashes() {
    hashes_.assign(stages_.size(), {});
    std::string previous = input_hash(recipe_);
    for (int i = entry_; i < static_cast<int>(stages_.size()); ++i) {
        Hash h;
        h.add(previous);
        h.add(stages_[i].name);
        h.add(canonical_params(recipe_, stages_[i].name));
        hashes_[i] = previous = h.hex();
    }
}

// Without --from the run starts at the first stage whose checkpoint is missing or stale;
// with --from the previous stage's checkpoint must exist.
void Run::skip_up_to_date_stages() {
    auto is_up_to_date = [&](int i) {
        return fs::exists(out_.checkpoint(stages_[i])) &&
               fs::exists(out_.with_ext(stages_[i], ".hash")) &&
               read_text(out_.with_ext(stages_[i], ".hash")) == hashes_[i] + "\n";
    };
    if (first_ < 0) {
        first_ = entry_;
        while (!options_.force && first_ <= last_ && is_up_to_date(first_)) ++first_;
    } else if (first_ > entry_ && !fs::exists(out_.checkpoint(stages_[first_ - 1]))) {
        FM_THROW(InputError, "--from " + options_.from + ": checkpoint '" +
                                 out_.checkpoint(stages_[first_ - 1]).string() +
                                 "' does not exist; run the earlier stages first");
    }
}

// Between steps: a stop asked for (Ctrl-C, SIGTERM) ends the run here, with the summary
// saying so. Nothing is half-written: every file is written atomically.
void Run::check_cancelled(const std::string& when) {
    if (cancel_->load()) stop(when);
}

void Run::stop(const std::string& when) {
    log_.clear_progress();
    prepare_folder();
    log_.note("interrupted " + when);
    write_summary("interrupted", "interrupted " + when);
    FM_THROW(CancelledError,
             "interrupted " + when +
                 "; the checkpoints of finished stages are kept, a new run goes on from them");
}

// Input of the first stage to run: the image, the surface, or the previous checkpoint.
void Run::read_input() {
    if (first_ > last_) return;
    if (first_ == entry_ && !surface_input_) {
        io::ImageReadOptions read;
        read.threshold = recipe_.input.threshold;
        read.spacing = recipe_.input.spacing;
        read.max_image_gib = recipe_.input.max_image_gib;
        read.frame = recipe_.output.frame;
        info("reading image " + recipe_.input.image);
        data_ = io::read_label_image(recipe_.input.image, read);
        const auto& image = std::get<core::LabelImage>(data_);
        input_json_ = image_json(image, read.pad);
        char buf[200];
        std::snprintf(buf, sizeof buf,
                      "image %d x %d x %d voxels (padded), spacing %.3g x %.3g x %.3g mm, frame %s",
                      image.dims[0], image.dims[1], image.dims[2], image.spacing.x(),
                      image.spacing.y(), image.spacing.z(), frame_.c_str());
        info(buf);
    } else if (first_ == entry_) {
        info("reading surface " + recipe_.input.surface);
        data_ = io::read_surface(recipe_.input.surface);  // coordinates in range, or refused
        const auto& surface = std::get<core::SurfaceNetwork>(data_);
        // Whatever stage it enters, every face must separate two regions (issue 21: a
        // surface with region_in == region_out everywhere made an empty mesh and exit 0).
        core::require_valid_regions(surface, user_surface());
        // Straight into tetra, the surface is kept exactly as it is: it must be closed,
        // oriented and clean (repair does that otherwise). A defect is bad input, exit 2.
        // Remesh takes it as its background and needs the same (an inside-out sphere given
        // with --from remesh ran 20 rounds to over 1 GB, then tetra failed with exit 1; found
        // by the malformed-input campaign, issue 21).
        const bool to_tets =
            stages_[entry_].in == Kind::Surface && stages_[entry_].out == Kind::Tets;
        if (to_tets || stages_[entry_].name == "remesh")
            core::require_meshable_surface(surface, user_surface());
        if (to_tets) {
            core::require_tetra_ready_faces(surface, user_surface());
            warn_obtuse_triangles(surface);
        }
    } else {
        info("reading checkpoint " + out_.checkpoint(stages_[first_ - 1]).string());
        data_ = read_checkpoint(out_.checkpoint(stages_[first_ - 1]), stages_[first_ - 1].out);
    }
}

// A triangle with an angle over about 130 degrees gives every tet on it a skewness over 0.8,
// whatever its fourth point; tetra keeps the given triangles, so the user hears it first.
void Run::warn_obtuse_triangles(const core::SurfaceNetwork& surface) {
    constexpr double kForcedDeg = 130.0;
    std::size_t count = 0;
    double worst = 0.0;
    Eigen::Vector3d where = Eigen::Vector3d::Zero();
    for (const auto& t : surface.faces) {
        const Eigen::Vector3d a = surface.point(t[0]), b = surface.point(t[1]),
                              c = surface.point(t[2]);
        const auto angles = core::triangle_angles_deg(a, b, c);
        const double largest = *std::max_element(angles.begin(), angles.end());
        if (!(largest > kForcedDeg)) continue;
        ++count;
        if (largest > worst) worst = largest, where = (a + b + c) / 3.0;
    }
    if (count == 0) return;
    std::ostringstream m;
    m << user_surface() << ": " << count << " of " << surface.face_count()
      << " triangles have an angle over 130 degrees (the largest " << std::fixed
      << std::setprecision(1) << worst << std::defaultfloat << std::setprecision(6) << " at ("
      << where.x() << ", " << where.y() << ", " << where.z()
      << ") mm); tetra keeps every given triangle, and each tet on such a triangle has skewness "
         "over 0.8 whatever its fourth point (--from remesh remeshes the surface first)";
    log_.line(core::LogLevel::Warning, m.str());
}

// checkpoints/input.json: what summary.json and report.html say about the image (the
// file's dims, spacing, origin of its first voxel and axes in the output frame; voxels per
// label), kept beside the checkpoints so that a re-run that reuses them still has it.
std::string Run::image_json(const core::LabelImage& image, int pad) const {
    std::map<core::Label, std::size_t> voxels;
    for (const core::Label l : image.labels)  // one pass over the voxels
        if (l != 0) ++voxels[l];
    const Eigen::Vector3d first = image.physical(Eigen::Vector3d::Constant(pad));
    auto triple = [](const Eigen::Vector3d& v) {
        std::ostringstream out;
        out << '[' << json_number(v.x()) << ", " << json_number(v.y()) << ", " << json_number(v.z())
            << ']';
        return out.str();
    };
    std::ostringstream s;
    s << "{\"path\": " << json_quote(recipe_.input.image) << ", \"dims\": ["
      << image.dims[0] - 2 * pad << ", " << image.dims[1] - 2 * pad << ", "
      << image.dims[2] - 2 * pad << "], \"spacing_mm\": " << triple(image.spacing)
      << ", \"origin_mm\": " << triple(first) << ", \"direction\": ["
      << triple(image.direction.col(0)) << ", " << triple(image.direction.col(1)) << ", "
      << triple(image.direction.col(2)) << "], \"frame\": " << json_quote(frame_)
      << ", \"voxel_volume_mm3\": " << json_number(image.voxel_volume()) << ", \"label_voxels\": {";
    bool first_label = true;
    for (const auto& [label, n] : voxels) {
        s << (first_label ? "" : ", ") << '"' << label << "\": " << n;
        first_label = false;
    }
    s << "}}";
    return s.str();
}

// Temporary files a killed run left (".NAME.tmp-PID-N", io/atomic_file.h), removed before
// anything is written; only in a folder frontmesh marked as its own, so nothing of the
// user's is touched.
void Run::remove_stale_temp_files() {
    const int removed = pipeline::remove_stale_temp_files(out_.dir.string());
    if (removed > 0)
        log_.note("removed " + std::to_string(removed) + " temporary file(s) of an earlier run");
}

// Called after each file the run commits (renames into place or removes), in commit order.
void Run::committed(const fs::path& file) {
    if (options_.on_commit) options_.on_commit(file.string());
}

void Run::prepare_folder() {
    if (folder_ready_) return;
    claim_output_dir(out_.dir.string());
    for (const auto& [name, text] : options_.files_on_claim)
        io::write_text_atomically((out_.dir / name).string(), text);
    fs::create_directories(out_.dir / "checkpoints");
    log_.open(out_.dir / "frontmesh.log");
    folder_ready_ = true;
}

// Reused stages keep their summary entry, marked skipped.
void Run::mark_reused_stages() {
    for (int i = entry_; i < first_ && i <= last_; ++i) {
        if (!fs::exists(out_.with_ext(stages_[i], ".json"))) continue;
        std::string part = read_text(out_.with_ext(stages_[i], ".json"));
        // Its timings, timestamps and figures stay those of the run that made it.
        const std::string ran = "\"status\": \"ran\"", fresh = "\"reused\": false";
        if (const auto at = part.find(ran); at != std::string::npos)
            part.replace(at, ran.size(), "\"status\": \"skipped\"");
        if (const auto at = part.find(fresh); at != std::string::npos)
            part.replace(at, fresh.size(), "\"reused\": true");
        prepare_folder();
        io::write_text_atomically(out_.with_ext(stages_[i], ".json").string(), part);
    }
}

void Run::run_one(int i) {
    const StageDef& stage = stages_[i];
    check_cancelled("before " + stage.name);
    core::StageContext ctx(
        [&](double fraction, const std::string& what) {
            log_.progress(stage.name, fraction, what);
        },
        [&](core::LogLevel level, const std::string& m) { log_.line(level, m); },
        diagnostics_.sink(), cancel_);
    std::string heading(1, '[');
    heading.append(std::to_string(i + 1))
        .append("/")
        .append(std::to_string(last_ + 1))
        .append("] ");
    info(heading + stage.name);
    log_.begin_stage();
    diagnostics_.start(stage.name);
    std::vector<core::TetFigures>().swap(figures_);  // the last stage's: not held while this runs
    stage_memory_.start();  // the stage's own peak from here to its summary (with its checkpoint)
    const auto t0 = std::chrono::steady_clock::now();
    const auto started = std::chrono::system_clock::now();
    // A surface stage that loses a whole region says so (issue 20: nothing disappears
    // silently); extract names what it leaves out itself.
    std::vector<core::Label> regions_before;
    if (stage.in == Kind::Surface && stage.out == Kind::Surface)
        regions_before = core::region_labels(std::get<core::SurfaceNetwork>(data_));
    StageOutput output = call_stage(i, ctx);
    log_.clear_progress();
    diagnostics_.finish();
    if (const int n = diagnostics_.not_written(); n > 0)
        ctx.count("diagnostics_not_written", static_cast<double>(n));
    if (!regions_before.empty()) {
        const auto after = core::region_labels(std::get<core::SurfaceNetwork>(output.data));
        for (const core::Label l : regions_before)
            if (!std::binary_search(after.begin(), after.end(), l))
                ctx.warn(stage.name + ": label " + std::to_string(l) +
                         " is not meshed at all: its region has no face left");
    }
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    data_ = std::move(output.data);
    prepare_folder();
    if (!input_json_.empty()) {
        io::write_text_atomically((out_.dir / "checkpoints" / "input.json").string(),
                                  input_json_ + "\n");
        input_json_.clear();
    }
    const Quality quality = write_checkpoint(i, output);
    write_stage_summary(i, ctx, wall, quality, started);
}

// True when this run computes `stage`.
bool Run::runs(const std::string& stage) const {
    for (int i = first_; i <= last_; ++i)
        if (stages_[i].name == stage) return true;
    return false;
}

// Runaway work is refused before it starts (issue 21): remesh and tetra are estimated from
// the surface they are about to take, and refused (InputError, exit 2) beyond
// limits.max_memory_gib.
void Run::check_resources(int i) {
    const std::string& name = stages_[i].name;
    if (name != "remesh" && name != "tetra") return;
    const auto& surface = std::get<core::SurfaceNetwork>(data_);
    const ResourceEstimate estimate = name == "remesh" ? remesh_estimate(surface, recipe_.remesh)
                                                       : tetra_estimate(surface, recipe_.tetra);
    log_.note(name + ": expected about " + json_number(std::round(estimate.count)) + " " +
              estimate.elements + " (" + estimate.basis + "), about " +
              json_number(estimate.memory_gib) + " GiB");
    require_within_memory_limit(estimate, recipe_.limits.max_memory_gib);
}

// The same estimates from the input, before any stage: a remesh.edge_length far too small
// is refused at once, with nothing written, rather than after extract and repair. The
// surface remesh takes is about the input's: an image's voxel boundaries, or the surface.
void Run::check_input_resources() {
    if (!runs("remesh")) return;
    if (const auto* image = std::get_if<core::LabelImage>(&data_))
        require_input_within_memory_limit(
            remesh_estimate(*image, recipe_.extract.labels, recipe_.remesh),
            labelled_volume(*image, recipe_.extract.labels), runs("tetra"), recipe_.tetra,
            recipe_.limits.max_memory_gib);
    else if (const auto* surface = std::get_if<core::SurfaceNetwork>(&data_);
             surface != nullptr && first_ == entry_)
        require_input_within_memory_limit(remesh_estimate(*surface, recipe_.remesh),
                                          enclosed_volume(*surface), runs("tetra"), recipe_.tetra,
                                          recipe_.limits.max_memory_gib);
}

// Runs stage i on data_. A failure is logged and recorded in summary.json before it goes
// on to the caller; bad input is not (nothing is written for it).
StageOutput Run::call_stage(int i, core::StageContext& ctx) {
    const StageDef& stage = stages_[i];
    try {
        ctx.check_cancelled();
        check_resources(i);
        return stage.run(data_, recipe_, ctx);
    } catch (const core::InputError&) {
        log_.clear_progress();
        throw;
    } catch (const core::CancelledError&) {
        fs::remove(out_.with_ext(stage, ".json"));
        diagnostics_.finish();
        stop("during " + stage.name);
    } catch (const core::Error& e) {
        log_.clear_progress();
        // The stage that takes the user's own surface (repair, or the stage --from names)
        // finds a defect repair cannot mend: the file is bad, not frontmesh (issue 21).
        if (surface_input_ && i == entry_ && dynamic_cast<const core::GeometryError*>(&e))
            FM_THROW(InputError, user_surface() + ": " + e.what());
        prepare_folder();
        diagnostics_.finish();
        log_.line(core::LogLevel::Warning,
                  stage.name + " failed: " + e.what() + " [" + e.where() + "]");
        fs::remove(out_.with_ext(stage, ".json"));
        write_summary("failed", stage.name + ": " + e.what());
        throw;
    } catch (...) {  // our bug (exit 1): no more redraws of the progress line
        log_.clear_progress();
        throw;
    }
}

// Writes stage i's checkpoint from data_; returns its quality figures.
//
// Commit order (issue 21), so that no interruption can pair a .hash with a checkpoint or
// a .json of other parameters: (1) remove NN-STAGE.hash, (2) rename the checkpoint into
// place, (3) the .json, (4) the .hash, written last. The .hash is the stage's one commit
// record: it exists only when the checkpoint and .json beside it were written by the run
// that wrote it. A kill after (1) and before (4) leaves no .hash, so the next run computes
// the stage again; a kill before (1) leaves the previous consistent triple. Checking the
// hash inside the checkpoint instead would mean reading the whole VTU on every re-run.
// Each step is one unlink or rename, which a kill -9 cannot split (a power cut could
// reorder them: no fsync is made).
Quality Run::write_checkpoint(int i, const StageOutput& output) {
    const StageDef& stage = stages_[i];
    fs::remove(out_.with_ext(stage, ".hash"));
    committed(out_.with_ext(stage, ".hash"));
    const io::FieldStrings fields = {
        {"frame", frame_}, {"stage", stage.name}, {"frontmesh_version", version()}};
    if (stage.out == Kind::Tets) {
        const auto& mesh = std::get<core::TetMesh>(data_);
        // Skewness and dihedral angles of every tet, once: the checkpoint's cell arrays,
        // the report below and the histograms of report.html all read them.
        figures_ = volume::tet_figures(mesh);
        io::write_tet_mesh_vtu(mesh, out_.checkpoint(stage).string(), fields, &figures_);
        committed(out_.checkpoint(stage));
        if (stage.name == "tetra" && stages_[last_].name == "refine" &&
            recipe_.output.quality_report)
            tetra_histograms_ =
                quality_histograms(mesh, &figures_);  // "before refine" in report.html
        const TetReport report = tet_report(mesh, &figures_);
        // A mesh the checks call invalid is never handed on or exported as a result: the
        // checkpoint stays for inspection (without its hash, so a re-run meshes again) and the
        // run fails as our own bug (exit 1).
        if (!report.valid) {
            const std::string why = stage.name + " produced an invalid mesh (" +
                                    out_.checkpoint(stage).string() + "): " + report.line;
            log_.clear_progress();
            log_.line(core::LogLevel::Warning, stage.name + " failed: " + why);
            write_summary("failed", why);
            FM_THROW(MeshingError, why);
        }
        return {report.json, report.line};
    }
    const auto& surface = std::get<core::SurfaceNetwork>(data_);
    io::write_surface_vtu(surface, out_.checkpoint(stage).string(), fields, output.point_arrays);
    committed(out_.checkpoint(stage));
    const SurfaceReport report = surface_report(surface);
    return {report.json, report.line};
}

// checkpoints/NN-STAGE.json (the stage's entry of summary.json) and .hash, and the log line.
void Run::write_stage_summary(int i, const core::StageContext& ctx, double wall,
                              const Quality& quality,
                              std::chrono::system_clock::time_point started) {
    const StageDef& stage = stages_[i];
    // The regions of the stage's result, for the names in summary.json.
    std::vector<core::Label> labels;
    if (const auto* mesh = std::get_if<core::TetMesh>(&data_)) {
        labels = mesh->region;
        std::sort(labels.begin(), labels.end());
        labels.erase(std::unique(labels.begin(), labels.end()), labels.end());
    } else if (const auto* surface = std::get_if<core::SurfaceNetwork>(&data_)) {
        labels = core::region_labels(*surface);
    }
    const double peak_mb = stage_memory_.peak_mb();
    std::ostringstream part;
    part << "{\"name\": " << json_quote(stage.name)
         << ", \"status\": \"ran\", \"reused\": false, \"started\": "
         << json_quote(iso_time(started))
         << ", \"finished\": " << json_quote(iso_time(std::chrono::system_clock::now()))
         << ", \"wall_s\": " << json_number(wall) << ", \"peak_rss_mb\": " << json_number(peak_mb)
         << ", \"peak_rss_scope\": " << json_quote(peak_scope_name(stage_memory_.scope()))
         << ", \"checkpoint\": "
         << json_quote(fs::relative(out_.checkpoint(stage), out_.dir).string())
         << ", \"hash\": " << json_quote(hashes_[i]) << ",\n     \"counters\": {";
    bool any = false;
    for (const auto& [name, value] : ctx.counters()) {
        part << (any ? ", " : "") << json_quote(name) << ": " << json_number(value);
        any = true;
    }
    part << "},\n     \"warnings\": [";
    for (std::size_t w = 0; w < ctx.warnings().size(); ++w)
        part << (w ? ", " : "") << json_quote(ctx.warnings()[w]);
    part << "],\n     \"dropped_components\": [";
    for (std::size_t c = 0; c < ctx.dropped_components().size(); ++c) {
        const core::DroppedComponent& d = ctx.dropped_components()[c];
        part << (c ? ",\n       " : "") << "{\"label\": " << d.label << ", \"voxels\": " << d.voxels
             << ", \"position_mm\": [" << json_number(d.position_mm[0]) << ", "
             << json_number(d.position_mm[1]) << ", " << json_number(d.position_mm[2])
             << "], \"reason\": " << json_quote(d.reason) << "}";
    }
    part << "],\n     \"labels\": [";
    for (std::size_t l = 0; l < labels.size(); ++l) part << (l ? ", " : "") << labels[l];
    part << "],\n     \"parameters\": " << effective_recipe_json(recipe_, stage.name)
         << ",\n     \"quality\": " << quality.json << "}";
    io::write_text_atomically(out_.with_ext(stage, ".json").string(), part.str());
    committed(out_.with_ext(stage, ".json"));
    io::write_text_atomically(out_.with_ext(stage, ".hash").string(), hashes_[i] + "\n");  // last
    committed(out_.with_ext(stage, ".hash"));
    char buf[120];
    std::snprintf(buf, sizeof buf, "%s done in %.2f s, peak memory %.0f MB%s: ", stage.name.c_str(),
                  wall, peak_mb, stage_memory_.scope() == PeakScope::Stage ? "" : " (process)");
    info(buf + quality.line);
}

// The final result: mesh.vtu for a tetrahedral mesh (the last checkpoint's mesh with region
// colours and names), mesh_surface.vtp (its boundary and interface triangles with their
// tags), the other formats asked for, and the quality report after refine; surface.vtu, a
// copy of the last checkpoint, for a surface.
//
// Each result file is tied to what it was made from (issue 21): checkpoints/results.hash
// lists "NAME KEY" per file, KEY being results_key(). A file is written again when a stage
// ran, when it is missing, or when its KEY differs (e.g. after a run killed right after
// mesh.vtu was renamed, mesh.inp and report.html of the previous parameters are not
// kept). Commit order as for a stage's .hash: the record is removed before the first
// result file is replaced and written after the last, so an interruption in between
// leaves no record and the next run writes every result again.
std::string Run::write_results() {
    check_cancelled("before writing the result");
    prepare_folder();
    const bool ran_any = first_ <= last_;
    const fs::path last_checkpoint = out_.checkpoint(stages_[last_]);
    const bool tet_result = stages_[last_].out == Kind::Tets;
    const fs::path result = out_.dir / (tet_result ? "mesh.vtu" : "surface.vtu");
    std::vector<fs::path> files = {result};
    if (tet_result) {
        files.push_back(out_.dir / io::surface_file_name());
        for (const std::string& name : recipe_.output.formats)
            if (const io::MeshFormat format = io::format_from_name(name);
                format != io::MeshFormat::Vtu)
                files.push_back(out_.dir / io::export_file_name(format));
        if (recipe_.output.quality_report && stages_[last_].name == "refine")
            files.push_back(out_.dir / "report.html");
    }
    const fs::path record_path = out_.dir / "checkpoints" / "results.hash";
    std::map<std::string, std::string> record;
    std::istringstream lines(fs::exists(record_path) ? read_text(record_path) : "");
    for (std::string name, key; lines >> name >> key;) record[name] = key;
    const std::string key = results_key();
    std::vector<fs::path> stale;
    for (const fs::path& file : files) {
        const auto entry = record.find(file.filename().string());
        if (ran_any || !fs::exists(file) || entry == record.end() || entry->second != key)
            stale.push_back(file);
    }
    if (!stale.empty()) {
        fs::remove(record_path);
        committed(record_path);
    }
    if (!tet_result && std::find(stale.begin(), stale.end(), result) != stale.end()) {
        io::write_atomically(result.string(), [&](const std::string& temp) {
            fs::copy_file(last_checkpoint, temp, fs::copy_options::overwrite_existing);
        });
        committed(result);
    }
    if (tet_result) write_exports(result, last_checkpoint, stale, ran_any);
    results_ = files;
    if (std::find(files.begin(), files.end(), out_.dir / "report.html") != files.end())
        for (const char* svg : {"surface_skewness.svg", "tet_skewness.svg", "dihedral.svg",
                                "min_dihedral.svg", "cross_section.svg"})
            results_.push_back(out_.dir / svg);
    if (!stale.empty()) {
        for (const fs::path& file : files) record[file.filename().string()] = key;
        std::string text;
        for (const auto& [name, file_key] : record) text += name + " " + file_key + "\n";
        io::write_text_atomically(record_path.string(), text);  // last
        committed(record_path);
    }
    write_pvd();
    write_summary("ok", "");
    return result.string();
}

// What the result files are made from: the last stage's hash (which chains the input and
// every stage's parameters) and the label names the exports carry.
std::string Run::results_key() const {
    Hash h;
    h.add(hashes_[last_]);
    h.add(recipe_.output.binary ? "binary" : "text");
    h.add(io::split_interfaces_text(recipe_.output.split_interfaces));
    if (recipe_.output.order != 1) h.add("order " + std::to_string(recipe_.output.order));
    for (const auto& [label, name] : names_.names()) {
        h.add(std::to_string(label));
        h.add(name);
    }
    return h.hex();
}

void Run::write_exports(const fs::path& result, const fs::path& last_checkpoint,
                        const std::vector<fs::path>& stale, bool ran_any) {
    auto wanted = [&](const fs::path& file) {
        return std::find(stale.begin(), stale.end(), file) != stale.end();
    };
    std::vector<std::pair<fs::path, io::MeshFormat>> exports;
    if (wanted(result)) exports.emplace_back(result, io::MeshFormat::Vtu);  // with colours
    for (const std::string& name : recipe_.output.formats) {
        const io::MeshFormat format = io::format_from_name(name);
        const fs::path file = out_.dir / io::export_file_name(format);
        if (format != io::MeshFormat::Vtu && wanted(file)) exports.emplace_back(file, format);
    }
    const bool report = wanted(out_.dir / "report.html");
    const fs::path surface = out_.dir / io::surface_file_name();
    if (exports.empty() && !report && !wanted(surface)) return;
    const core::TetMesh mesh = std::holds_alternative<core::TetMesh>(data_)
                                   ? std::get<core::TetMesh>(std::move(data_))
                                   : io::read_tet_mesh(last_checkpoint.string());
    io::FieldStrings fields = {
        {"frame", frame_}, {"stage", stages_[last_].name}, {"frontmesh_version", version()}};
    // Split interfaces (output.split_interfaces) in every export and mesh_surface.vtp, whose
    // point array `node` indexes mesh.vtu; the report looks at the mesh as meshed.
    const io::SplitInterfaces& split = recipe_.output.split_interfaces;
    std::optional<core::TetMesh> split_copy;
    if (!split.is_none() && (!exports.empty() || wanted(surface))) {
        split_copy = io::split_interfaces(mesh, split);
        fields["split_interfaces"] = io::split_interfaces_text(split);
        info("split interfaces " + io::split_interfaces_text(split) + ": " +
             std::to_string(split_copy->node_count() - mesh.node_count()) + " node copies");
    }
    const core::TetMesh& split_mesh = split_copy ? *split_copy : mesh;
    // Quadratic tets (output.order 2) in the exports, after the split so that the copies of
    // a split interface get their own mid nodes; mesh_surface.vtp stays linear.
    std::optional<core::TetMesh> quadratic;
    if (recipe_.output.order == 2 && !exports.empty()) quadratic = elevate(split_mesh);
    for (const auto& [file, format] : exports) {
        io::write_mesh(quadratic ? *quadratic : split_mesh, file.string(), format, names_, fields,
                       {recipe_.output.binary});
        committed(file);
        info("wrote " + file.string());
    }
    if (wanted(surface)) {
        io::write_mesh_surface(split_mesh, surface.string(), names_, fields);
        committed(surface);
    }
    if (report) {
        // The tetra histograms of this run, else those of its checkpoint (--from refine).
        const fs::path tetra_checkpoint =
            out_.checkpoint(stages_[static_cast<std::size_t>(last_) - 1]);
        if (!tetra_histograms_ && fs::exists(tetra_checkpoint))
            tetra_histograms_ = quality_histograms(io::read_tet_mesh(tetra_checkpoint.string()));
        write_quality_report(out_.dir.string(), mesh,
                             tetra_histograms_ ? &*tetra_histograms_ : nullptr, report_context(),
                             figures_.size() == mesh.tet_count() && ran_any ? &figures_ : nullptr);
        committed(out_.dir / "report.html");
        info("wrote " + (out_.dir / "report.html").string());
    }
}

// The quadratic tets of `mesh` (volume::elevate_to_quadratic), mid nodes of surface edges on
// the background remesh projected onto: the repair checkpoint of this chain of stages. When
// remesh is not part of it (a surface meshed as it is), the mid nodes stay straight.
core::TetMesh Run::elevate(const core::TetMesh& mesh) {
    std::optional<core::SurfaceNetwork> background;
    for (int i = entry_; i <= last_; ++i)
        if (stages_[i].name == "remesh" && i > 0 && fs::exists(out_.checkpoint(stages_[i - 1])))
            background = io::read_surface(out_.checkpoint(stages_[i - 1]).string());
    volume::QuadraticStats stats;
    core::TetMesh out =
        volume::elevate_to_quadratic(mesh, background ? &*background : nullptr, &stats);
    char buf[300];
    std::snprintf(buf, sizeof buf,
                  "quadratic tets: %zu mid nodes, %zu on the surface of which %zu curved onto "
                  "the %s (%zu taken back to keep elements valid), smallest scaled Jacobian "
                  "bound %.3f",
                  stats.edges, stats.surface_edges, stats.curved,
                  background ? "repaired surface" : "(no background: straight)", stats.straightened,
                  stats.min_scaled_jacobian);
    info(buf);
    return out;
}

// What report.html tells besides the mesh: names, the voxels' volume per label (from
// checkpoints/input.json), and every stage's timing (from its part of summary.json) and
// parameters.
ReportContext Run::report_context() const {
    ReportContext context;
    context.title = recipe_.path;
    context.frame = frame_;
    context.region_names = names_.names();
    // The table's colours as the VTU writes them (io::LabelTable::colour); other labels get
    // io::default_colour in the report too.
    for (const auto& [label, name] : names_.names()) {
        (void)name;
        context.region_colours[label] = names_.colour(label);
    }
    const fs::path input_json = out_.dir / "checkpoints" / "input.json";
    if (!surface_input_ && fs::exists(input_json)) {
        const std::string text = read_text(input_json);
        std::smatch m;
        double voxel = 0.0;
        if (std::regex_search(text, m, std::regex("\"voxel_volume_mm3\": ([0-9.eE+-]+)")))
            voxel = std::stod(m[1].str());
        if (std::regex_search(text, m, std::regex("\"label_voxels\": \\{([^}]*)\\}"))) {
            const std::string list = m[1].str();
            const std::regex entry("\"([0-9]+)\": ([0-9]+)");
            for (auto it = std::sregex_iterator(list.begin(), list.end(), entry);
                 it != std::sregex_iterator(); ++it)  // one entry per label
                context.voxel_volume_mm3[static_cast<core::Label>(std::stol((*it)[1].str()))] =
                    voxel * std::stod((*it)[2].str());
        }
    }
    for (int i = entry_; i <= last_; ++i) {
        const fs::path part_path = out_.with_ext(stages_[i], ".json");
        if (!fs::exists(part_path)) continue;
        const std::string part = read_text(part_path);
        ReportContext::Stage stage;
        stage.name = stages_[i].name;
        stage.reused = part.find("\"reused\": true") != std::string::npos;
        std::smatch m;
        if (std::regex_search(part, m, std::regex("\"wall_s\": ([0-9.eE+-]+)")))
            stage.wall_s = std::stod(m[1].str());
        if (std::regex_search(part, m, std::regex("\"peak_rss_mb\": ([0-9.eE+-]+)")))
            stage.peak_rss_mb = std::stod(m[1].str());
        stage.peak_is_process = part.find("\"peak_rss_scope\": \"stage\"") == std::string::npos;
        for (const auto& [key, value] : recipe_.values)
            if (key.rfind(stage.name + ".", 0) == 0) stage.parameters.emplace_back(key, value);
        context.stages.push_back(std::move(stage));
    }
    return context;
}

// One ParaView collection per kind (issue 22): run-surface.pvd steps through the surface
// checkpoints of this run (extract, repair, remesh), run-volume.pvd through its tet
// checkpoints (tetra, refine), so that stepping never jumps from triangles to tets. Only
// stages up to the last one of this run: later checkpoints of an earlier, longer run are
// not this run's. A collection with nothing to show is removed, as is the mixed run.pvd
// of earlier versions.
void Run::write_pvd() {
    for (const Kind kind : {Kind::Surface, Kind::Tets}) {
        std::vector<std::pair<std::string, std::string>> entries;
        for (int i = entry_; i <= last_; ++i)
            if (stages_[i].out == kind && fs::exists(out_.checkpoint(stages_[i])))
                entries.emplace_back(fs::relative(out_.checkpoint(stages_[i]), out_.dir).string(),
                                     stages_[i].name);
        const fs::path pvd = out_.dir / pvd_file_name(kind);
        if (!entries.empty()) {
            io::write_pvd(pvd.string(), entries);
        } else if (fs::exists(pvd)) {
            fs::remove(pvd);
            committed(pvd);
        }
    }
    if (fs::exists(out_.dir / "run.pvd")) {
        fs::remove(out_.dir / "run.pvd");
        committed(out_.dir / "run.pvd");
    }
}

void Run::write_summary(const std::string& status, const std::string& error) {
    std::ostringstream s;
    s << "{\n  \"frontmesh_version\": " << json_quote(version())
      << ",\n  \"recipe\": " << json_quote(recipe_.path) << ",\n  \"input\": "
      << json_quote(surface_input_ ? recipe_.input.surface : recipe_.input.image)
      << ",\n  \"frame\": " << json_quote(frame_) << ",\n  \"status\": " << json_quote(status)
      << ",\n  \"error\": " << (error.empty() ? "null" : json_quote(error)) << ",\n  \"stages\": [";
    bool any = false;
    for (int i = entry_; i <= last_; ++i) {
        const fs::path part = out_.with_ext(stages_[i], ".json");
        if (!fs::exists(part)) continue;
        s << (any ? ",\n    " : "\n    ") << read_text(part);
        any = true;
    }
    s << "\n  ],\n  \"diagnostics\": [";
    any = false;
    for (int i = entry_; i <= last_; ++i)
        for (const fs::path& file :
             DiagnosticsWriter::files_of(out_.diagnostics(), stages_[i].name)) {
            s << (any ? ", " : "") << json_quote(fs::relative(file, out_.dir).string());
            any = true;
        }
    s << "],\n  \"started\": " << json_quote(iso_time(started_))
      << ",\n  \"finished\": " << json_quote(iso_time(std::chrono::system_clock::now()))
      << ",\n  \"total_wall_s\": "
      << json_number(
             std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count());
    // The input image as read (by this run or the one whose checkpoints it reuses).
    const fs::path input_json = out_.dir / "checkpoints" / "input.json";
    std::string image = "null";
    if (!surface_input_ && fs::exists(input_json)) {
        image = read_text(input_json);
        while (!image.empty() && image.back() == '\n') image.pop_back();
    }
    s << ",\n  \"input_image\": " << image;
    // The regions of the last stage's result, with their names from the label table.
    std::vector<core::Label> labels;
    for (int i = last_; i >= entry_ && labels.empty(); --i)
        if (fs::exists(out_.with_ext(stages_[i], ".json")))
            labels = labels_in_part(read_text(out_.with_ext(stages_[i], ".json")));
    s << ",\n  \"regions\": [";
    for (std::size_t r = 0; r < labels.size(); ++r)
        s << (r ? ", " : "") << "{\"label\": " << labels[r]
          << ", \"name\": " << (names_.has(labels[r]) ? json_quote(names_.name(labels[r])) : "null")
          << "}";
    // What this run wrote or found up to date (issue 22): its result files, collections and
    // log, the checkpoints of its stages, the recipe when it lies in the folder (`frontmesh
    // mesh` writes recipe.yaml there) and this summary.json; not files of earlier runs that
    // the folder still holds (an export of a format no longer asked for, a checkpoint of a
    // later stage).
    s << "],\n  \"outputs\": [";
    std::vector<fs::path> files;
    auto add = [&](const fs::path& file) {
        if (fs::is_regular_file(file) && std::find(files.begin(), files.end(), file) == files.end())
            files.push_back(file);
    };
    for (const fs::path& file : results_) add(file);
    for (const Kind kind : {Kind::Surface, Kind::Tets}) add(out_.dir / pvd_file_name(kind));
    add(out_.dir / "frontmesh.log");
    for (int i = entry_; i <= last_; ++i) add(out_.checkpoint(stages_[i]));
    if (!recipe_.path.empty()) {
        const fs::path recipe = fs::absolute(recipe_.path).lexically_normal();
        const fs::path inside =
            recipe.lexically_relative(fs::absolute(out_.dir).lexically_normal());
        if (!inside.empty() && *inside.begin() != "..") add(recipe);
    }
    const fs::path summary = out_.dir / "summary.json";
    files.erase(std::remove(files.begin(), files.end(), summary), files.end());
    files.push_back(summary);  // its size is known only once the text is: a marker for now
    std::sort(files.begin(), files.end());
    constexpr const char* kOwnSize = "@SUMMARY-BYTES@";
    for (std::size_t f = 0; f < files.size(); ++f)
        s << (f ? ",\n    " : "\n    ")
          << "{\"file\": " << json_quote(fs::relative(files[f], out_.dir).string())
          << ", \"bytes\": "
          << (files[f] == summary ? std::string(kOwnSize) : std::to_string(fs::file_size(files[f])))
          << "}";
    s << "],\n  \"effective_recipe\": " << effective_recipe_json(recipe_) << "\n}\n";
    io::write_text_atomically(summary.string(), with_own_size(s.str(), kOwnSize));
}

}  // namespace

const std::vector<std::string>& stage_names() {
    static const std::vector<std::string> names = [] {
        std::vector<std::string> n;
        for (const auto& s : stage_defs()) n.push_back(s.name);
        return n;
    }();
    return names;
}

std::string run_recipe(const Recipe& recipe, const RunOptions& options) {
    std::optional<StopSignals> signals;
    check_output_dir(recipe, recipe.path);  // load_recipe did, unless the caller built it
    if (options.cancel == nullptr) signals.emplace();
    return Run(recipe, options, options.cancel ? options.cancel : &stop_requested).execute();
}

}  // namespace frontmesh::pipeline
