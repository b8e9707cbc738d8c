#pragma once
// Peak resident memory of one stage (issue 22). getrusage's ru_maxrss is the peak of the whole
// process so far, so a stage after a larger one reported the larger one's peak. On Linux the
// kernel's high-water mark (VmHWM in /proc/self/status) can be reset to the current resident
// size by writing "5" to /proc/self/clear_refs (Linux 4.0+): reset before a stage, read after
// it, it is the stage's own peak (what it held at its start included). Where that file cannot
// be written (another system, a restricted container), the process peak is reported and
// marked as such.

#include <optional>
#include <string>

namespace frontmesh::pipeline {

/// Where a peak comes from.
enum class PeakScope {
    Stage,    ///< VmHWM after a reset at the stage's start: the stage's own peak
    Process,  ///< ru_maxrss: the peak of the process since it started
};

/// "stage" or "process", as summary.json's `peak_rss_scope` spells it.
const char* peak_scope_name(PeakScope scope);

/// VmHWM of a /proc/PID/status text, MB (1 MB = 1024 kB, as ru_maxrss / 1024); nullopt when
/// the line is absent or unreadable.
std::optional<double> vm_hwm_mb(const std::string& status_text);

/// The peak resident memory of a stretch of the run. Not thread-safe; one per runner.
class PeakMemory {
public:
    /// Starts a stretch: resets the kernel's high-water mark when /proc/self/clear_refs can be
    /// written (scope() then Stage), else leaves it (scope() Process).
    void start();
    /// Peak resident memory since start(), MB (scope() says of what). Reads /proc/self/status
    /// once, or calls getrusage.
    double peak_mb() const;
    PeakScope scope() const { return scope_; }

private:
    PeakScope scope_ = PeakScope::Process;
};

}  // namespace frontmesh::pipeline
