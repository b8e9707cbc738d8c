#include "io/atomic_file.h"

#include <atomic>
#include <cerrno>
#include <charconv>
#include <filesystem>
#include <fstream>
#include <system_error>
#include <vector>

#include <signal.h>
#include <unistd.h>

#include "pipeline/core/error.h"

namespace frontmesh::io {

namespace {

namespace fs = std::filesystem;

// Distinguishes temporary files of concurrent writes from the same process.
std::atomic<unsigned long> temp_counter{0};

// ".name.tmp-<pid>-<counter>" beside `target`: the same folder keeps the rename on one
// file system, so it replaces the target in one step.
fs::path temp_path_for(const fs::path& target) {
    const unsigned long n = temp_counter.fetch_add(1);
    std::string name(1, '.');
    name += target.filename().string();
    name += ".tmp-";
    name += std::to_string(static_cast<long>(::getpid()));
    name += '-';
    name += std::to_string(n);
    return target.parent_path() / name;
}

// The writer's process id when `name` is ".NAME.tmp-PID-N" (temp_path_for), else 0.
long temp_file_pid(const std::string& name) {
    const std::size_t tmp = name.rfind(".tmp-");
    if (name.size() < 2 || name[0] != '.' || tmp == std::string::npos || tmp < 2) return 0;
    const char* first = name.data() + tmp + 5;
    const char* last = name.data() + name.size();
    long pid = 0;
    unsigned long counter = 0;
    const auto [dash, pid_error] = std::from_chars(first, last, pid);
    if (pid_error != std::errc() || dash == last || *dash != '-' || pid <= 0) return 0;
    const auto [end, counter_error] = std::from_chars(dash + 1, last, counter);
    return counter_error == std::errc() && end == last ? pid : 0;
}

// kill(pid, 0) delivers nothing; ESRCH says no such process exists (EPERM: it does).
bool is_running(long pid) { return ::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH; }

void remove_quietly(const fs::path& p) {
    std::error_code ignored;
    fs::remove(p, ignored);
}

}  // namespace

void write_atomically(const std::string& path,
                      const std::function<void(const std::string& temp_path)>& write) {
    const fs::path target(path);
    if (target.filename().empty()) FM_THROW(IoError, "'" + path + "': not a file name");

    const fs::path parent = target.parent_path();
    if (!parent.empty()) {
        std::error_code ec;
        fs::create_directories(parent, ec);
        if (ec)
            FM_THROW(IoError, "'" + path + "': cannot create folder '" + parent.string() +
                                  "': " + ec.message());
    }

    const fs::path temp = temp_path_for(target);
    try {
        write(temp.string());
    } catch (...) {
        remove_quietly(temp);
        throw;
    }

    std::error_code ec;
    if (!fs::is_regular_file(temp, ec)) {
        remove_quietly(temp);
        FM_THROW(IoError, "'" + path + "': the writer produced no file");
    }
    fs::rename(temp, target, ec);
    if (ec) {
        remove_quietly(temp);
        FM_THROW(IoError, "'" + path + "': cannot replace the file: " + ec.message());
    }
}

void write_text_atomically(const std::string& path, const std::string& text) {
    write_atomically(path, [&](const std::string& temp) {
        std::ofstream out(temp, std::ios::binary | std::ios::trunc);
        if (!out) FM_THROW(IoError, "'" + path + "': cannot open '" + temp + "' for writing");
        out.write(text.data(), static_cast<std::streamsize>(text.size()));
        out.flush();
        if (!out) FM_THROW(IoError, "'" + path + "': write failed");
    });
}

int remove_stale_temp_files(const std::string& folder) {
    std::error_code ec;
    std::vector<fs::path> stale;
    // Bounded by the folder's entries; collected first, removed after the listing.
    for (const auto& entry : fs::directory_iterator(folder, ec)) {
        const long pid = temp_file_pid(entry.path().filename().string());
        if (pid != 0 && entry.is_regular_file(ec) && !is_running(pid)) stale.push_back(entry);
    }
    int removed = 0;
    for (const fs::path& file : stale) removed += fs::remove(file, ec) ? 1 : 0;
    return removed;
}

}  // namespace frontmesh::io
