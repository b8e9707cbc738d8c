#include "pipeline/runner.h"

#include <sys/resource.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>
#include <variant>

#include "io/atomic_file.h"
#include "io/export.h"
#include "io/label_table.h"
#include "io/image_reader.h"
#include "io/mesh_io.h"
#include "pipeline/core/error.h"
#include "pipeline/version.h"
#include "pipeline/quality_report.h"
#include "pipeline/report.h"
#include "volume/mesh_check.h"
#include "volume/refine.h"
#include "surface/morphology.h"
#include "surface/remesh.h"
#include "volume/tetra.h"

namespace frontmesh::pipeline {
namespace {

namespace fs = std::filesystem;
using StageData = std::variant<std::monostate, core::LabelImage, core::SurfaceNetwork, core::TetMesh>;

// What a stage reads and writes; decides how checkpoints are read, written and reported.
enum class Kind { Image, Surface, Tets };

struct StageDef {
    std::string name;
    int number;  // NN of checkpoints/NN-name.vtu, fixed by the method's order
    Kind in, out;
};

const std::vector<StageDef>& stage_defs() {
    static const std::vector<StageDef> defs = {
        {"extract", 1, Kind::Image, Kind::Surface},
        {"repair", 2, Kind::Surface, Kind::Surface},
        {"remesh", 3, Kind::Surface, Kind::Surface},
        {"tetra", 4, Kind::Surface, Kind::Tets},
        {"refine", 5, Kind::Tets, Kind::Tets},
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
    const std::string source = recipe.input.image.empty() ? recipe.input.surface : recipe.input.image;
    std::vector<fs::path> files;
    if (fs::is_directory(source)) {
        for (const auto& entry : fs::directory_iterator(source))
            if (entry.is_regular_file()) files.push_back(entry.path());
    } else if (fs::exists(source)) {
        files.push_back(source);
    } else {  // printf pattern: hash the folder it names
        const fs::path folder = fs::path(source).parent_path();
        if (fs::is_directory(folder))
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

double peak_rss_mb() {
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    return static_cast<double>(usage.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB on Linux
}

std::string now_text() {
    const std::time_t t = std::time(nullptr);
    char buf[32];
    std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M:%S", std::localtime(&t));
    return buf;
}

std::string read_text(const fs::path& path) {
    std::ifstream in(path);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

// Log lines go to the terminal and to frontmesh.log; until the output folder exists they
// are kept in memory, so a run that fails on bad input leaves no folder behind.
class Log {
public:
    Log(bool quiet) : quiet_(quiet), tty_(isatty(STDERR_FILENO)) {}

    void open(const fs::path& file) {
        file_.open(file, std::ios::app);
        for (const auto& line : pending_) file_ << line << '\n';
        pending_.clear();
        file_.flush();
    }
    void line(core::LogLevel level, const std::string& message) {
        if (level == core::LogLevel::Debug) return write_file("DEBUG " + message);
        const bool warning = level == core::LogLevel::Warning;
        if (warning || !quiet_) {
            clear_progress();
            std::cerr << (warning ? "warning: " : "") << message << '\n';
        }
        write_file((level == core::LogLevel::Warning ? "WARN  " : "INFO  ") + message);
    }
    void progress(const std::string& stage, double fraction, const std::string& what) {
        if (quiet_) return;
        const int percent = static_cast<int>(fraction * 100.0 + 0.5);
        char buf[200];
        std::snprintf(buf, sizeof buf, "  %-8s %3d%%  %s", stage.c_str(), percent, what.c_str());
        if (tty_) {
            std::cerr << "\r\033[K" << buf << std::flush;
            progress_shown_ = true;
        } else if (what != last_what_) {
            std::cerr << buf << '\n';
        }
        last_what_ = what;
    }
    void clear_progress() {
        if (progress_shown_) std::cerr << "\r\033[K" << std::flush;
        progress_shown_ = false;
    }

private:
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
    bool quiet_, tty_;
    bool progress_shown_ = false;
    std::string last_what_;
    std::ofstream file_;
    std::vector<std::string> pending_;
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
};

StageData read_checkpoint(const fs::path& path, Kind kind) {
    if (kind == Kind::Tets) return io::read_tet_mesh(path.string());
    return io::read_surface(path.string());
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
    const auto& stages = stage_defs();
    const auto run_start = std::chrono::steady_clock::now();
    Log log(options.quiet);
    auto info = [&](const std::string& m) { log.line(core::LogLevel::Info, m); };
    auto index_of = [&](const std::string& name, const char* flag) {
        for (std::size_t i = 0; i < stages.size(); ++i)
            if (stages[i].name == name) return static_cast<int>(i);
        std::string list;
        for (const auto& s : stages) list += (list.empty() ? "" : ", ") + s.name;
        FM_THROW(InputError, std::string(flag) + " " + name + ": unknown stage; stages: " + list);
    };

    // A surface input enters at repair, or at the stage --from names (e.g. --from tetra meshes
    // the surface as it is); an image enters at extract. --from a stage that needs a tet mesh
    // (refine) enters the surface at the last stage before it that takes one (tetra) and reads
    // that stage's checkpoint, as a run from the image would.
    const bool surface_input = !recipe.input.surface.empty();
    const int last = options.until.empty() ? static_cast<int>(stages.size()) - 1 : index_of(options.until, "--until");
    int first = options.from.empty() ? -1 : index_of(options.from, "--from");
    int entry = !surface_input ? 0 : first >= 0 ? first : index_of("repair", "input.surface");
    if (surface_input && stages[entry].in == Kind::Tets)
        while (entry > 0 && stages[entry].in != Kind::Surface) --entry;
    if (surface_input && stages[entry].in != Kind::Surface)
        FM_THROW(InputError, "--from " + options.from + ": input.surface is a triangle surface; the " +
                                 stages[entry].name + " stage needs an image");
    if (first > last) FM_THROW(InputError, "--from " + options.from + " comes after --until " + options.until);

    // Region names for the exports: the recipe's table, else the one beside the image. Read
    // before any work so a bad table fails fast.
    io::LabelTable names;
    {
        std::string table = recipe.input.label_names;
        if (table.empty() && !recipe.input.image.empty()) table = io::label_table_beside(recipe.input.image);
        if (!table.empty()) names = io::read_label_table(table);
    }

    const Outputs out{recipe.output.dir};
    const std::string frame = core::frame_name(recipe.output.frame);

    // Stage hashes chain the input's bytes and every earlier stage's parameters.
    std::vector<std::string> hashes(stages.size());
    {
        std::string previous = input_hash(recipe);
        for (int i = entry; i < static_cast<int>(stages.size()); ++i) {
            Hash h;
            h.add(previous);
            h.add(stages[i].name);
            h.add(canonical_params(recipe, stages[i].name));
            hashes[i] = previous = h.hex();
        }
    }
    auto is_up_to_date = [&](int i) {
        return fs::exists(out.checkpoint(stages[i])) && fs::exists(out.with_ext(stages[i], ".hash")) &&
               read_text(out.with_ext(stages[i], ".hash")) == hashes[i] + "\n";
    };
    if (first < 0) {
        first = entry;
        while (!options.force && first <= last && is_up_to_date(first)) ++first;
    } else if (first > entry && !fs::exists(out.checkpoint(stages[first - 1]))) {
        FM_THROW(InputError, "--from " + options.from + ": checkpoint '" + out.checkpoint(stages[first - 1]).string() +
                                 "' does not exist; run the earlier stages first");
    }

    // Input of the first stage to run: the image, the surface, or the previous checkpoint.
    StageData data;
    if (first <= last) {
        if (first == entry && !surface_input) {
            io::ImageReadOptions read;
            read.threshold = recipe.input.threshold;
            read.spacing = recipe.input.spacing;
            read.frame = recipe.output.frame;
            info("reading image " + recipe.input.image);
            data = io::read_label_image(recipe.input.image, read);
            const auto& image = std::get<core::LabelImage>(data);
            char buf[200];
            std::snprintf(buf, sizeof buf, "image %d x %d x %d voxels (padded), spacing %.3g x %.3g x %.3g mm, frame %s",
                          image.dims[0], image.dims[1], image.dims[2], image.spacing.x(), image.spacing.y(),
                          image.spacing.z(), frame.c_str());
            info(buf);
        } else if (first == entry) {
            info("reading surface " + recipe.input.surface);
            data = io::read_surface(recipe.input.surface);
        } else {
            info("reading checkpoint " + out.checkpoint(stages[first - 1]).string());
            data = read_checkpoint(out.checkpoint(stages[first - 1]), stages[first - 1].out);
        }
    }

    bool folder_ready = false;
    auto prepare_folder = [&] {
        if (folder_ready) return;
        fs::create_directories(out.dir / "checkpoints");
        log.open(out.dir / "frontmesh.log");
        folder_ready = true;
    };
    auto write_summary = [&](const std::string& status, const std::string& error) {
        std::ostringstream s;
        s << "{\n  \"frontmesh_version\": " << json_quote(version()) << ",\n  \"recipe\": "
          << json_quote(recipe.path) << ",\n  \"input\": "
          << json_quote(surface_input ? recipe.input.surface : recipe.input.image) << ",\n  \"frame\": "
          << json_quote(frame) << ",\n  \"status\": " << json_quote(status) << ",\n  \"error\": "
          << (error.empty() ? "null" : json_quote(error)) << ",\n  \"stages\": [";
        bool any = false;
        for (int i = entry; i <= last; ++i) {
            const fs::path part = out.with_ext(stages[i], ".json");
            if (!fs::exists(part)) continue;
            s << (any ? ",\n    " : "\n    ") << read_text(part);
            any = true;
        }
        s << "\n  ],\n  \"total_wall_s\": "
          << json_number(std::chrono::duration<double>(std::chrono::steady_clock::now() - run_start).count())
          << "\n}\n";
        io::write_text_atomically((out.dir / "summary.json").string(), s.str());
    };
    auto write_pvd = [&] {
        std::vector<std::pair<std::string, std::string>> entries;
        for (int i = entry; i < static_cast<int>(stages.size()); ++i)
            if (fs::exists(out.checkpoint(stages[i])))
                entries.emplace_back(fs::relative(out.checkpoint(stages[i]), out.dir).string(), stages[i].name);
        io::write_pvd((out.dir / "run.pvd").string(), entries);
    };

    if (first > last) info("every stage up to " + stages[last].name + " is up to date; nothing to run");
    for (int i = entry; i < first && i <= last; ++i) {
        if (!fs::exists(out.with_ext(stages[i], ".json"))) continue;
        // Mark the reused stage as skipped in its summary entry.
        std::string part = read_text(out.with_ext(stages[i], ".json"));
        const std::string ran = "\"status\": \"ran\"";
        if (const auto at = part.find(ran); at != std::string::npos) part.replace(at, ran.size(), "\"status\": \"skipped\"");
        prepare_folder();
        io::write_text_atomically(out.with_ext(stages[i], ".json").string(), part);
    }

    std::optional<QualityHistograms> tetra_histograms;  // kept for the quality report
    std::vector<core::TetFigures> figures;              // of the last tet mesh a stage made
    for (int i = first; i <= last; ++i) {
        const StageDef& stage = stages[i];
        core::StageContext ctx(
            [&](double fraction, const std::string& what) { log.progress(stage.name, fraction, what); },
            [&](core::LogLevel level, const std::string& m) { log.line(level, m); });
        std::string heading(1, '[');
        heading.append(std::to_string(i + 1)).append("/").append(std::to_string(last + 1)).append("] ");
        info(heading + stage.name);
        std::vector<core::TetFigures>().swap(figures);  // the last stage's: not held while this runs
        const auto t0 = std::chrono::steady_clock::now();
        io::PointArrays point_arrays;  // extra per-point figures of the checkpoint
        try {
            if (stage.name == "extract") {
                auto& image = std::get<core::LabelImage>(data);
                if (recipe.morphology.closing_voxels > 0) {
                    const std::size_t n = surface::close_object(image, recipe.morphology.closing_voxels);
                    ctx.count("extract.closing_filled_voxels", double(n));
                    ctx.info("extract: closing of " + std::to_string(recipe.morphology.closing_voxels) +
                             " voxel(s) filled " + std::to_string(n) + " voxels");
                }
                if (recipe.morphology.opening_voxels > 0) {
                    const std::size_t n = surface::open_object(image, recipe.morphology.opening_voxels);
                    ctx.count("extract.opening_removed_voxels", double(n));
                    ctx.info("extract: opening of " + std::to_string(recipe.morphology.opening_voxels) +
                             " voxel(s) removed " + std::to_string(n) + " voxels");
                }
                data = surface::extract(image, recipe.extract, ctx);
            } else if (stage.name == "repair") {
                data = surface::repair(std::get<core::SurfaceNetwork>(data), recipe.repair, ctx);
            } else if (stage.name == "remesh") {
                surface::RemeshResult r = surface::remesh(std::get<core::SurfaceNetwork>(data), recipe.remesh, ctx);
                point_arrays["target_size"] = std::move(r.target_size);
                data = std::move(r.surface);
            } else if (stage.name == "tetra") {
                data = volume::tetra(std::get<core::SurfaceNetwork>(data), recipe.tetra, ctx);
            } else if (stage.name == "refine") {
                data = volume::refine(std::get<core::TetMesh>(data), recipe.refine, ctx);
            }
        } catch (const core::InputError&) {
            log.clear_progress();
            throw;
        } catch (const core::Error& e) {
            log.clear_progress();
            prepare_folder();
            log.line(core::LogLevel::Warning, stage.name + " failed: " + e.what() + " [" + e.where() + "]");
            fs::remove(out.with_ext(stage, ".json"));
            write_summary("failed", stage.name + ": " + e.what());
            throw;
        }
        log.clear_progress();
        const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

        prepare_folder();
        const io::FieldStrings fields = {{"frame", frame}, {"stage", stage.name}, {"frontmesh_version", version()}};
        std::string report_json, report_line;
        if (stage.out == Kind::Tets) {
            const auto& mesh = std::get<core::TetMesh>(data);
            // Skewness and dihedral angles of every tet, once: the checkpoint's cell arrays,
            // the report below and the histograms of report.html all read them.
            figures = volume::tet_figures(mesh);
            io::write_tet_mesh_vtu(mesh, out.checkpoint(stage).string(), fields, &figures);
            if (stage.name == "tetra" && stages[last].name == "refine" && recipe.output.quality_report)
                tetra_histograms = quality_histograms(mesh, &figures);  // "before refine" in report.html
            const TetReport report = tet_report(mesh, &figures);
            report_json = report.json;
            report_line = report.line;
            if (!report.valid) ctx.warn(stage.name + " produced an invalid mesh: " + report.line);
        } else {
            const auto& surface = std::get<core::SurfaceNetwork>(data);
            io::write_surface_vtu(surface, out.checkpoint(stage).string(), fields, point_arrays);
            const SurfaceReport report = surface_report(surface);
            report_json = report.json;
            report_line = report.line;
        }
        std::ostringstream part;
        part << "{\"name\": " << json_quote(stage.name) << ", \"status\": \"ran\", \"wall_s\": " << json_number(wall)
             << ", \"peak_rss_mb\": " << json_number(peak_rss_mb()) << ", \"checkpoint\": "
             << json_quote(fs::relative(out.checkpoint(stage), out.dir).string()) << ", \"hash\": "
             << json_quote(hashes[i]) << ",\n     \"counters\": {";
        bool any = false;
        for (const auto& [name, value] : ctx.counters()) {
            part << (any ? ", " : "") << json_quote(name) << ": " << json_number(value);
            any = true;
        }
        part << "},\n     \"warnings\": [";
        for (std::size_t w = 0; w < ctx.warnings().size(); ++w)
            part << (w ? ", " : "") << json_quote(ctx.warnings()[w]);
        part << "],\n     \"quality\": " << report_json << "}";
        io::write_text_atomically(out.with_ext(stage, ".json").string(), part.str());
        io::write_text_atomically(out.with_ext(stage, ".hash").string(), hashes[i] + "\n");
        char buf[120];
        std::snprintf(buf, sizeof buf, "%s done in %.2f s, peak memory %.0f MB: ", stage.name.c_str(), wall,
                      peak_rss_mb());
        info(buf + report_line);
    }

    // The final result: mesh.vtu for a tetrahedral mesh (a copy of the last checkpoint, or
    // written again with the region names) plus the other formats asked for, and the
    // quality report after refine; surface.vtu, a copy of the last checkpoint, for a surface.
    // When every stage was up to date, only missing result files are written.
    prepare_folder();
    const bool ran_any = first <= last;
    auto wanted = [&](const fs::path& file) { return ran_any || !fs::exists(file); };
    const fs::path last_checkpoint = out.checkpoint(stages[last]);
    const bool tet_result = stages[last].out == Kind::Tets;
    const fs::path result = out.dir / (tet_result ? "mesh.vtu" : "surface.vtu");
    if ((!tet_result || names.empty()) && wanted(result))
        io::write_atomically(result.string(), [&](const std::string& temp) {
            fs::copy_file(last_checkpoint, temp, fs::copy_options::overwrite_existing);
        });
    std::vector<std::pair<fs::path, io::MeshFormat>> exports;
    if (tet_result) {
        if (!names.empty() && wanted(result)) exports.emplace_back(result, io::MeshFormat::Vtu);
        for (const std::string& name : recipe.output.formats) {
            const io::MeshFormat format = io::format_from_name(name);
            const fs::path file = out.dir / io::export_file_name(format);
            if (format != io::MeshFormat::Vtu && wanted(file)) exports.emplace_back(file, format);
        }
    }
    const bool report = tet_result && recipe.output.quality_report && stages[last].name == "refine" &&
                        wanted(out.dir / "report.html");
    if (!exports.empty() || report) {
        const core::TetMesh mesh = std::holds_alternative<core::TetMesh>(data)
                                       ? std::get<core::TetMesh>(std::move(data))
                                       : io::read_tet_mesh(last_checkpoint.string());
        const io::FieldStrings fields = {{"frame", frame}, {"stage", stages[last].name}, {"frontmesh_version", version()}};
        for (const auto& [file, format] : exports) {
            io::write_mesh(mesh, file.string(), format, names, fields);
            info("wrote " + file.string());
        }
        if (report) {
            // The tetra histograms of this run, else those of its checkpoint (--from refine).
            const fs::path tetra_checkpoint = out.checkpoint(stages[static_cast<std::size_t>(last) - 1]);
            if (!tetra_histograms && fs::exists(tetra_checkpoint))
                tetra_histograms = quality_histograms(io::read_tet_mesh(tetra_checkpoint.string()));
            write_quality_report(out.dir.string(), mesh, tetra_histograms ? &*tetra_histograms : nullptr,
                                 recipe.path, figures.size() == mesh.tet_count() && ran_any ? &figures : nullptr);
            info("wrote " + (out.dir / "report.html").string());
        }
    }
    write_pvd();
    write_summary("ok", "");
    return result.string();
}

}  // namespace frontmesh::pipeline
