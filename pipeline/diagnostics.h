#pragma once
// The runner's diagnostics sink (STYLE §3): geometry a stage hands over with
// StageContext::diagnose becomes OUTPUT/diagnostics/STAGE-NAME.vtu.

#include <filesystem>
#include <mutex>
#include <string>
#include <vector>

#include "io/mesh_io.h"
#include "pipeline/core/stage_context.h"

namespace frontmesh::pipeline {

/// Writes each core::Diagnostic of the running stage as `folder/STAGE-NAME.vtu`
/// (io::write_diagnostic_vtu, atomic) and logs one line naming the file. Thread-safe: stages
/// call it from TBB threads. NAME is the diagnostic's name with characters other than
/// letters, digits, '-', '_' and '.' replaced by '_'; a name given twice in one stage gets
/// "-2", "-3", ... A file that cannot be written is a logged warning, not an error of the
/// stage. At most max_files_per_run files are written per run (issue 21: remesh retries on a
/// 16^3 block of random labels wrote 642 files, 38 MB): the first ones to arrive; the rest
/// are counted (not_written()) and named in one log line per stage.
class DiagnosticsWriter {
public:
    static constexpr int max_files_per_run = 20;

    /// `fields` go into every file's field data (with "stage").
    DiagnosticsWriter(std::filesystem::path folder, core::StageContext::LogSink log,
                      io::FieldStrings fields);

    /// Starts `stage`: its files of an earlier run are removed.
    void start(const std::string& stage);
    /// Ends the stage started last: logs how many of its diagnostics were not written.
    void finish();
    /// Diagnostics of the stage started last that were not written (over the cap).
    int not_written() const;
    /// Writes `diagnostic` for the stage started last.
    void write(core::Diagnostic diagnostic);
    /// A sink for a StageContext that calls write(); valid while this object lives.
    core::StageContext::DiagnosticSink sink() {
        return [this](core::Diagnostic d) { write(std::move(d)); };
    }

    /// The diagnostics of `stage` in `folder`, sorted by name.
    static std::vector<std::filesystem::path> files_of(const std::filesystem::path& folder,
                                                       const std::string& stage);

private:
    mutable std::mutex mutex_;
    std::filesystem::path folder_;
    core::StageContext::LogSink log_;
    io::FieldStrings fields_;
    std::string stage_;
    std::vector<std::string> written_;  // names of this stage's files
    int written_in_run_ = 0;            // files of every stage of this run
    int not_written_ = 0;               // this stage's diagnostics over the cap
};

}  // namespace frontmesh::pipeline
