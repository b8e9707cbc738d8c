#include "pipeline/output_dir.h"

#include <pwd.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <climits>
#include <cstring>
#include <filesystem>
#include <string_view>
#include <vector>

#include "io/atomic_file.h"
#include "io/export.h"
#include "pipeline/core/error.h"
#include "pipeline/core/input_file.h"
#include "pipeline/version.h"

namespace frontmesh::pipeline {
namespace {

namespace fs = std::filesystem;

// "recipe.yaml:7: output.dir: '/etc' ", the start of every message about the folder.
struct Place {
    std::string origin, dir;
    [[noreturn]] void fail(const std::string& what) const {
        FM_THROW(InputError, origin + ": output.dir: '" + dir + "' " + what);
    }
};

// Before any stat: an over-long name makes every later call fail with ENAMETOOLONG.
void check_lengths(const fs::path& dir, const Place& place) {
    for (const auto& part : dir)
        if (part.native().size() > NAME_MAX)
            place.fail("has a name of " + std::to_string(part.native().size()) +
                       " characters; at most " + std::to_string(NAME_MAX) + " are allowed");
    if (dir.native().size() >= PATH_MAX)
        place.fail("is " + std::to_string(dir.native().size()) + " characters long; at most " +
                   std::to_string(PATH_MAX - 1) + " are allowed");
}

// "/a/b/" -> "/a/b"; the root stays "/".
fs::path without_slash(const fs::path& path) {
    return path.has_filename() || path == path.root_path() ? path : path.parent_path();
}

// True when `inner` is `outer` or lies below it (both canonical).
bool within(const fs::path& inner, const fs::path& outer) {
    auto i = inner.begin();
    for (auto o = outer.begin(); o != outer.end(); ++o, ++i)
        if (i == inner.end() || *i != *o) return false;
    return true;
}

std::string home_folder() {
    const passwd* user = getpwuid(getuid());
    return user != nullptr && user->pw_dir != nullptr ? user->pw_dir : "";
}

// The filesystem root, system folders and the home folder itself; /proc, /sys, /dev and
// /run with everything below them (pseudo filesystems).
void check_not_system(const fs::path& dir, const Place& place) {
    for (const char* pseudo : {"/proc", "/sys", "/dev", "/run"})
        if (within(dir, pseudo))
            place.fail("is on the pseudo filesystem " + std::string(pseudo) +
                       "; choose a folder on a disk");
    if (dir == dir.root_path()) place.fail("is the filesystem root; choose a new folder");
    static constexpr std::array<std::string_view, 10> system = {
        "/bin", "/boot", "/etc", "/home", "/opt", "/root", "/sbin", "/srv", "/usr", "/var"};
    const std::string text = dir.string();
    const bool lib = dir.parent_path() == dir.root_path() && text.rfind("/lib", 0) == 0;
    if (lib || std::find(system.begin(), system.end(), text) != system.end())
        place.fail("is a system folder; choose a new folder, e.g. below your home folder");
    if (const std::string home = home_folder(); !home.empty() && dir == fs::path(home))
        place.fail("is your home folder itself; choose a new folder below it");
}

// Every existing part of the path is a folder; returns the nearest existing one.
fs::path check_parts(const fs::path& dir, const Place& place) {
    fs::path prefix, existing = dir.root_path();
    for (const auto& part : dir) {
        prefix /= part;
        std::error_code ec;
        const fs::file_status status = fs::status(prefix, ec);
        // A link whose target is missing: create_directories would fail on it (exit 1, found
        // by the malformed-input campaign, issue 21), and making its target would write
        // wherever it points.
        if (!fs::exists(status) && fs::is_symlink(fs::symlink_status(prefix, ec)))
            place.fail("cannot be a folder: '" + prefix.string() + "' is a symbolic link to '" +
                       fs::read_symlink(prefix, ec).string() + "', which does not exist");
        if (!fs::exists(status)) break;
        if (!fs::is_directory(status)) {
            if (prefix == dir) place.fail("is " + core::file_kind(status) + ", not a folder");
            place.fail("cannot be a folder: '" + prefix.string() + "' is " +
                       core::file_kind(status));
        }
        existing = prefix;
    }
    return existing;
}

// The input file that `dir` holds (directly or below), or "".
std::string held_input(const Recipe& recipe, const fs::path& dir) {
    for (const std::string& input : {recipe.input.image, recipe.input.surface}) {
        if (input.empty()) continue;
        std::error_code ec;
        const fs::path file = fs::weakly_canonical(input, ec);
        if (ec) continue;
        if (within(fs::is_directory(file, ec) ? file : file.parent_path(), dir)) return input;
    }
    return {};
}

// The files a run writes at fixed names in the folder itself; a folder or a named pipe in
// their place would make the run fail after its work (a rename onto a folder) or hang (the
// log opened on a pipe).
std::vector<std::string> result_names(const Recipe& recipe) {
    std::vector<std::string> names = {kOutputMarker,      "frontmesh.log",   "summary.json",
                                      "run.pvd",          "run-surface.pvd", "run-volume.pvd",
                                      "surface.vtu",      "report.html",     "surface_skewness.svg",
                                      "tet_skewness.svg", "dihedral.svg",    "min_dihedral.svg"};
    for (const std::string& format : recipe.output.formats)
        names.push_back(io::export_file_name(io::format_from_name(format)));
    return names;
}

// In an existing folder: checkpoints and diagnostics are folders holding only files, the
// result names are not folders, nothing in it is a pipe, socket or device, and a folder
// with anything in it was made by frontmesh (it has the marker), unless it is the input's
// folder the recipe allows (output.allow_input_folder).
void check_contents(const Recipe& recipe, const fs::path& dir, bool foreign_ok,
                    const Place& place) {
    auto refuse = [&](const fs::path& path, const fs::file_status& status,
                      const std::string& wanted) {
        place.fail("cannot be used: '" + path.string() + "' is " + core::file_kind(status) +
                   ", not " + wanted);
    };
    // A symbolic link where frontmesh writes would take the writes out of the folder (the
    // log appended to the file it names, checkpoints written into the folder it names; found
    // by the malformed-input campaign, issue 21).
    auto refuse_link = [&](const fs::path& path) {
        std::error_code link_ec;
        if (fs::is_symlink(fs::symlink_status(path, link_ec)))
            place.fail("cannot be used: '" + path.string() + "' is a symbolic link (to '" +
                       fs::read_symlink(path, link_ec).string() +
                       "'); frontmesh writes there and would follow it out of the folder");
    };
    std::error_code ec;
    for (const std::string& name : result_names(recipe)) {
        refuse_link(dir / name);
        const fs::file_status status = fs::status(dir / name, ec);
        if (fs::exists(status) && !fs::is_regular_file(status))
            refuse(dir / name, status, "a file");
    }
    // Bounded by the folder's entries.
    for (const auto& entry : fs::directory_iterator(dir, ec)) {
        const fs::file_status status = entry.status(ec);
        if (fs::exists(status) && !fs::is_regular_file(status) && !fs::is_directory(status))
            refuse(entry.path(), status, "a file or a folder");
    }
    for (const char* sub : {"checkpoints", "diagnostics"}) {
        refuse_link(dir / sub);
        const fs::file_status status = fs::status(dir / sub, ec);
        if (!fs::exists(status)) continue;
        if (!fs::is_directory(status)) refuse(dir / sub, status, "a folder");
        // Only the run's own files live there: bounded by the folder's entries.
        for (const auto& entry : fs::directory_iterator(dir / sub, ec)) {
            refuse_link(entry.path());
            const fs::file_status inner = entry.status(ec);
            if (fs::exists(inner) && !fs::is_regular_file(inner))
                refuse(entry.path(), inner, "a file");
        }
    }
    const bool empty = fs::is_empty(dir, ec);
    if (ec) place.fail("cannot be read: " + ec.message());
    if (!empty && !foreign_ok && !fs::exists(dir / kOutputMarker, ec))
        place.fail("is not empty and is not a frontmesh output folder (it has no " +
                   std::string(kOutputMarker) + "); choose an empty or new folder");
}

}  // namespace

void check_output_dir(const Recipe& recipe, const std::string& origin) {
    const Place place{origin, recipe.output.dir};
    const fs::path lexical = without_slash(fs::absolute(recipe.output.dir).lexically_normal());
    check_lengths(lexical, place);
    check_not_system(lexical, place);  // as written: /lib may be a link to /usr/lib
    std::error_code ec;
    const fs::path dir = without_slash(fs::weakly_canonical(lexical, ec));
    if (ec) place.fail("cannot be resolved: " + ec.message());
    check_lengths(dir, place);
    check_not_system(dir, place);
    const fs::path existing = check_parts(dir, place);
    const std::string input = held_input(recipe, dir);
    if (!input.empty() && !recipe.output.allow_input_folder)
        place.fail("holds the input '" + input +
                   "'; a run there could overwrite your files: choose a new "
                   "folder, or set output.allow_input_folder: true");
    if (access(existing.c_str(), W_OK | X_OK) != 0) {
        const std::string why = std::strerror(errno);
        if (existing == dir) place.fail("is not writable (" + why + ")");
        place.fail("cannot be created: '" + existing.string() + "' is not writable (" + why + ")");
    }
    if (existing == dir) check_contents(recipe, dir, !input.empty(), place);
}

int remove_stale_temp_files(const std::string& dir) {
    if (!fs::exists(fs::path(dir) / kOutputMarker)) return 0;
    int removed = 0;
    for (const char* sub : {"", "checkpoints", "diagnostics"})
        removed += io::remove_stale_temp_files((fs::path(dir) / sub).string());
    return removed;
}

void claim_output_dir(const std::string& dir) {
    fs::create_directories(dir);
    const fs::path marker = fs::path(dir) / kOutputMarker;
    if (fs::exists(marker)) return;
    io::write_text_atomically(marker.string(), std::string("frontmesh ") + version() +
                                                   "\nThis folder holds the output of frontmesh "
                                                   "runs; a run may overwrite files in it.\n");
}

}  // namespace frontmesh::pipeline
