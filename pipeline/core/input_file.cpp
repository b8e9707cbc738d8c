#include "pipeline/core/input_file.h"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <system_error>

#include "pipeline/core/error.h"

namespace frontmesh::core {

namespace fs = std::filesystem;

std::string file_kind(const fs::file_status& status) {
    switch (status.type()) {
        case fs::file_type::regular:
            return "a file";
        case fs::file_type::directory:
            return "a folder";
        case fs::file_type::fifo:
            return "a named pipe";
        case fs::file_type::socket:
            return "a socket";
        case fs::file_type::block:
        case fs::file_type::character:
            return "a device";
        default:
            return "not a file";
    }
}

void require_input_file(const std::string& path, const std::string& prefix, bool folder_ok) {
    const std::string named = prefix + "'" + path + "' ";
    std::error_code ec;
    const fs::file_status status = fs::status(path, ec);  // follows links: the target counts
    if (!fs::exists(status)) {
        if (ec && ec != std::errc::no_such_file_or_directory)
            FM_THROW(InputError, named + "cannot be examined: " + ec.message());
        FM_THROW(InputError, named + "does not exist");
    }
    const bool folder = fs::is_directory(status);
    if (folder && !folder_ok) FM_THROW(InputError, named + "is a folder; give a file");
    if (!folder && !fs::is_regular_file(status))
        FM_THROW(InputError, named + "is " + file_kind(status) + ", not a regular file");
    if (access(path.c_str(), folder ? R_OK | X_OK : R_OK) != 0)
        FM_THROW(InputError, named + "cannot be read: " + std::strerror(errno));
}

}  // namespace frontmesh::core
