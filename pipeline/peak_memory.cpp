#include "pipeline/peak_memory.h"

#include <sys/resource.h>

#include <fstream>
#include <sstream>

namespace frontmesh::pipeline {

const char* peak_scope_name(PeakScope scope) {
    return scope == PeakScope::Stage ? "stage" : "process";
}

std::optional<double> vm_hwm_mb(const std::string& status_text) {
    std::istringstream in(status_text);
    std::string line;
    while (std::getline(in, line)) {
        if (line.rfind("VmHWM:", 0) != 0) continue;
        std::istringstream fields(line.substr(6));
        double kb = 0.0;
        std::string unit;
        if (!(fields >> kb >> unit) || unit != "kB" || kb < 0.0) return std::nullopt;
        return kb / 1024.0;
    }
    return std::nullopt;
}

namespace {

double process_peak_mb() {
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    return static_cast<double>(usage.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB on Linux
}

}  // namespace

void PeakMemory::start() {
    scope_ = PeakScope::Process;
#if defined(__linux__)
    std::ofstream clear("/proc/self/clear_refs");
    if (!clear) return;
    clear << "5";  // 5: reset the peak resident set size (VmHWM) to the current one
    clear.flush();
    if (!clear) return;
    // The reset only counts when VmHWM can be read back.
    std::ifstream status("/proc/self/status");
    std::ostringstream text;
    text << status.rdbuf();
    if (vm_hwm_mb(text.str())) scope_ = PeakScope::Stage;
#endif
}

double PeakMemory::peak_mb() const {
    if (scope_ == PeakScope::Stage) {
        std::ifstream status("/proc/self/status");
        std::ostringstream text;
        text << status.rdbuf();
        if (const auto mb = vm_hwm_mb(text.str())) return *mb;
    }
    return process_peak_mb();
}

}  // namespace frontmesh::pipeline
