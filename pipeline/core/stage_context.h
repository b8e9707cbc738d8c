#pragma once
// What a stage may use besides its input and parameters (STYLE §3): progress, logging,
// named counters, warnings and a cancellation check. The runner owns the sinks.

#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace frontmesh::core {

enum class LogLevel { Debug, Info, Warning };

class StageContext {
public:
    using ProgressSink = std::function<void(double fraction, const std::string& what)>;
    using LogSink = std::function<void(LogLevel, const std::string&)>;

    StageContext() = default;
    StageContext(ProgressSink progress, LogSink log)
        : progress_(std::move(progress)), log_(std::move(log)) {}

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
    /// Sets a named figure reported in summary.json (counts, volumes, times of sub-steps).
    void count(const std::string& name, double value) { counters_[name] = value; }
    void add(const std::string& name, double value) { counters_[name] += value; }

    const std::map<std::string, double>& counters() const { return counters_; }
    const std::vector<std::string>& warnings() const { return warnings_; }
    void clear() {
        counters_.clear();
        warnings_.clear();
    }

private:
    void emit(LogLevel level, const std::string& message) const {
        if (log_) log_(level, message);
    }

    ProgressSink progress_;
    LogSink log_;
    std::map<std::string, double> counters_;
    std::vector<std::string> warnings_;
};

}  // namespace frontmesh::core
