#pragma once
// What a stage may use besides its input and parameters (STYLE §3): progress, logging,
// named counters, warnings, a diagnostics sink and a cancellation check. The runner owns
// the sinks; a default-constructed context drops progress, log lines and diagnostics and
// is never cancelled.

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "pipeline/core/error.h"
#include "pipeline/core/ids.h"

namespace frontmesh::core {

enum class LogLevel { Debug, Info, Warning };

/// Geometry a stage hands over for a person to inspect, e.g. the front around a stall or a
/// cavity that could not be closed. The runner writes it as `diagnostics/STAGE-NAME.vtu`
/// beside the checkpoints (cells of 2, 3 or 4 points: lines, triangles, tets; the cell
/// array `kind` carries `kind`'s meaning, the field data `what`) and lists it in
/// summary.json. The sink may be called from any thread.
struct Diagnostic {
    std::string name;         ///< short, file-name safe: letters, digits, '-', '_', '.'
    std::string what;         ///< one line: why it was handed over, and what `kind` means
    std::vector<double> xyz;  ///< 3 per point, mm
    std::vector<std::vector<std::int32_t>> cells;  ///< point ids, 2 to 4 per cell
    std::vector<std::int32_t> kind;                ///< per cell

    std::int32_t add_point(double x, double y, double z) {
        xyz.push_back(x);
        xyz.push_back(y);
        xyz.push_back(z);
        return static_cast<std::int32_t>(xyz.size() / 3 - 1);
    }
    void add_cell(std::vector<std::int32_t> ids, std::int32_t cell_kind) {
        cells.push_back(std::move(ids));
        kind.push_back(cell_kind);
    }
};

/// A connected component of a chosen label that a stage did not mesh (too small, or lost to
/// a clean-up): what summary.json lists under the stage's `dropped_components`, beside the
/// warning that names it (issue 20: nothing labelled disappears silently).
struct DroppedComponent {
    Label label = 0;
    std::size_t voxels = 0;               ///< voxel count; 0 when not known (a surface)
    std::array<double, 3> position_mm{};  ///< centre of its voxels (or faces), mm
    std::string reason;                   ///< one line, e.g. "smaller than KEY = 1 mm^3"
};

/// Thrown by StageContext::check_cancelled when the run was asked to stop (Ctrl-C,
/// SIGTERM): not a failure of the input or of frontmesh.
class CancelledError : public Error {
public:
    using Error::Error;
};

class StageContext {
public:
    using ProgressSink = std::function<void(double fraction, const std::string& what)>;
    using LogSink = std::function<void(LogLevel, const std::string&)>;
    using DiagnosticSink = std::function<void(Diagnostic)>;

    StageContext() = default;
    StageContext(ProgressSink progress, LogSink log, DiagnosticSink diagnostics = {},
                 const std::atomic<bool>* cancel = nullptr)
        : progress_(std::move(progress)),
          log_(std::move(log)),
          diagnostics_(std::move(diagnostics)),
          cancel_(cancel) {}

    /// Reports progress in [0, 1] of the running stage.
    void progress(double fraction, const std::string& what = {}) const {
        if (progress_) progress_(fraction, what);
    }
    void info(const std::string& message) const { emit(LogLevel::Info, message); }
    void debug(const std::string& message) const { emit(LogLevel::Debug, message); }
    /// A warning is logged and recorded in the run summary.
    void warn(const std::string& message) {
        warnings_.push_back(message);
        emit(LogLevel::Warning, message);
    }
    /// Records a component the stage did not mesh (warn about it too, naming the label).
    void drop(DroppedComponent component) { dropped_.push_back(std::move(component)); }

    /// Sets a named figure reported in summary.json (counts, volumes, times of sub-steps).
    void count(const std::string& name, double value) { counters_[name] = value; }
    void add(const std::string& name, double value) { counters_[name] += value; }

    /// True when someone receives diagnostics: build a Diagnostic only then.
    bool wants_diagnostics() const { return static_cast<bool>(diagnostics_); }
    /// Hands geometry to the runner for inspection; dropped when nobody receives it.
    void diagnose(Diagnostic diagnostic) const {
        if (diagnostics_) diagnostics_(std::move(diagnostic));
    }

    /// True once the run was asked to stop. Cheap (one relaxed atomic load).
    bool is_cancelled() const {
        return cancel_ != nullptr && cancel_->load(std::memory_order_relaxed);
    }
    /// Long loops call this between units of work; throws CancelledError when the run was
    /// asked to stop, so the stage ends without writing anything.
    void check_cancelled() const {
        if (is_cancelled()) FM_THROW(CancelledError, "the run was interrupted");
    }

    /// A context for parallel work inside a stage: the same log, diagnostics and
    /// cancellation, no progress, its own counters and warnings (merge them in a fixed
    /// order with merge_from so the summary does not depend on the threads).
    StageContext child() const { return StageContext({}, log_, diagnostics_, cancel_); }
    /// Adds another context's counters (summed) and warnings (appended, not logged again).
    void merge_from(const StageContext& other) {
        for (const auto& [name, value] : other.counters_) counters_[name] += value;
        warnings_.insert(warnings_.end(), other.warnings_.begin(), other.warnings_.end());
        dropped_.insert(dropped_.end(), other.dropped_.begin(), other.dropped_.end());
    }

    const std::map<std::string, double>& counters() const { return counters_; }
    const std::vector<std::string>& warnings() const { return warnings_; }
    const std::vector<DroppedComponent>& dropped_components() const { return dropped_; }
    void clear() {
        counters_.clear();
        warnings_.clear();
        dropped_.clear();
    }

private:
    void emit(LogLevel level, const std::string& message) const {
        if (log_) log_(level, message);
    }

    ProgressSink progress_;
    LogSink log_;
    DiagnosticSink diagnostics_;
    const std::atomic<bool>* cancel_ = nullptr;
    std::map<std::string, double> counters_;
    std::vector<std::string> warnings_;
    std::vector<DroppedComponent> dropped_;
};

}  // namespace frontmesh::core
