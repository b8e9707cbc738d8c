#pragma once
// Running the frontmesh executable from tests.

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace frontmesh::testing {

struct CommandResult {
    int exit_code = -1;
    std::string out, err;
};

inline std::string slurp(const std::filesystem::path& path) {
    std::ifstream in(path);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

/// Runs `frontmesh ARGS` in `dir`, returning exit code, stdout and stderr.
inline CommandResult run_frontmesh(const std::string& args, const std::string& dir) {
    const std::string out = dir + "/.stdout", err = dir + "/.stderr";
    const std::string command = "cd '" + dir + "' && '" + FRONTMESH_BINARY + "' " + args + " > '" +
                                out + "' 2> '" + err + "'";
    const int status = std::system(command.c_str());
    CommandResult r;
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.out = slurp(out);
    r.err = slurp(err);
    std::filesystem::remove(out);
    std::filesystem::remove(err);
    return r;
}

inline void write_file(const std::string& path, const std::string& text) {
    std::ofstream(path) << text;
}

}  // namespace frontmesh::testing
