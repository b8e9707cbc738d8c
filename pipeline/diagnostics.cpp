#include "pipeline/diagnostics.h"

#include <algorithm>
#include <cctype>
#include <system_error>
#include <utility>

#include "pipeline/core/error.h"

namespace frontmesh::pipeline {
namespace {

namespace fs = std::filesystem;

std::string safe_name(std::string name) {
    for (char& c : name)
        if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_' && c != '.')
            c = '_';
    return name.empty() ? std::string("diagnostic") : name;
}

}  // namespace

DiagnosticsWriter::DiagnosticsWriter(fs::path folder, core::StageContext::LogSink log,
                                     io::FieldStrings fields)
    : folder_(std::move(folder)), log_(std::move(log)), fields_(std::move(fields)) {}

void DiagnosticsWriter::start(const std::string& stage) {
    const std::lock_guard lock(mutex_);
    stage_ = stage;
    written_.clear();
    not_written_ = 0;
    for (const fs::path& file : files_of(folder_, stage)) fs::remove(file);
}

void DiagnosticsWriter::finish() {
    const std::lock_guard lock(mutex_);
    if (not_written_ > 0 && log_)
        log_(core::LogLevel::Info, "diagnostics: " + std::to_string(not_written_) + " more of " +
                                       stage_ + " not written (at most " +
                                       std::to_string(max_files_per_run) + " files per run)");
}

int DiagnosticsWriter::not_written() const {
    const std::lock_guard lock(mutex_);
    return not_written_;
}

void DiagnosticsWriter::write(core::Diagnostic diagnostic) {
    const std::lock_guard lock(mutex_);
    if (written_in_run_ >= max_files_per_run) {
        ++not_written_;
        return;
    }
    const std::string base = stage_ + "-" + safe_name(diagnostic.name);
    std::string name = base;
    for (int n = 2; std::find(written_.begin(), written_.end(), name) != written_.end(); ++n)
        name = base + "-" + std::to_string(n);
    const fs::path file = folder_ / (name + ".vtu");
    io::FieldStrings fields = fields_;
    fields["stage"] = stage_;
    try {
        io::write_diagnostic_vtu(diagnostic, file.string(), fields);
    } catch (const core::Error& e) {
        if (log_) log_(core::LogLevel::Warning, "diagnostic " + name + " not written: " + e.what());
        return;
    }
    written_.push_back(name);
    ++written_in_run_;
    if (log_)
        log_(core::LogLevel::Info,
             "diagnostic: wrote " + file.string() + " (" + diagnostic.what + ")");
}

std::vector<fs::path> DiagnosticsWriter::files_of(const fs::path& folder,
                                                  const std::string& stage) {
    std::vector<fs::path> files;
    std::error_code ec;
    for (const auto& entry : fs::directory_iterator(folder, ec)) {
        const std::string file = entry.path().filename().string();
        if (file.rfind(stage + "-", 0) == 0 && entry.path().extension() == ".vtu")
            files.push_back(entry.path());
    }
    std::sort(files.begin(), files.end());
    return files;
}

}  // namespace frontmesh::pipeline
