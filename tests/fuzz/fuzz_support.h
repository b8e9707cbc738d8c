#pragma once
// Shared pieces of the libFuzzer targets (issue 21): the readers under test take a file
// path, so each input is written to a file in a per-process scratch folder first, and the
// errors a user may legitimately get from bad input are told apart from findings.

#include <unistd.h>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>
#include <typeinfo>

#include "pipeline/core/error.h"

namespace frontmesh::fuzz {

/// The scratch folder of this process: /dev/shm/frontmesh-fuzz-PID (the system temp folder
/// when /dev/shm is missing), created on first use and removed at normal exit. A crashed
/// run leaves it behind; its name says which process made it.
inline const std::filesystem::path& scratch_dir() {
    static const std::filesystem::path dir = [] {
        namespace fs = std::filesystem;
        std::error_code ec;
        const fs::path base =
            fs::is_directory("/dev/shm", ec) ? fs::path("/dev/shm") : fs::temp_directory_path();
        fs::path d = base / ("frontmesh-fuzz-" + std::to_string(::getpid()));
        fs::create_directories(d);
        std::atexit([] {
            std::error_code ignored;
            std::filesystem::remove_all(scratch_dir(), ignored);
        });
        return d;
    }();
    return dir;
}

/// Writes `size` bytes at `data` to scratch_dir()/name (replacing it) and returns its path.
inline std::string write_input(const std::string& name, const std::uint8_t* data,
                               std::size_t size) {
    const std::filesystem::path path = scratch_dir() / name;
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
    out.close();
    if (!out) {
        std::fprintf(stderr, "fuzz: cannot write %s\n", path.c_str());
        std::abort();
    }
    return path.string();
}

/// Runs `read`. InputError, GeometryError, MeshingError and IoError are what bad input may
/// give (exit 2 and friends in the CLI) and are ignored; an InternalError or any other
/// exception is what the CLI reports as "internal error", exit 1: a finding, so it aborts
/// with the message and libFuzzer keeps the input.
template <class Read>
void expect_input_errors(Read&& read) {
    try {
        read();
    } catch (const core::InternalError& e) {
        std::fprintf(stderr, "fuzz: InternalError on bad input: %s at %s\n", e.what(),
                     e.where().c_str());
        std::abort();
    } catch (const core::Error&) {
        // InputError, GeometryError, MeshingError, IoError: a clear error for bad input.
    } catch (const std::exception& e) {
        std::fprintf(stderr, "fuzz: unexpected %s: %s\n", typeid(e).name(), e.what());
        std::abort();
    }
}

}  // namespace frontmesh::fuzz
