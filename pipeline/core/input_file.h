#pragma once
// A file a user names (image, surface, recipe, manifest, label table, mesh): checked by
// stat before anything opens it, so a named pipe or a device cannot block a run.

#include <filesystem>
#include <string>

namespace frontmesh::core {

/// "a file", "a folder", "a named pipe", "a socket", "a device" or "not a file": what
/// `status` describes, for one-line messages.
std::string file_kind(const std::filesystem::file_status& status);

/// Throws InputError, one line "PREFIX'PATH' <what is wrong>", unless `path` is an existing
/// regular file the process may read, or, when `folder_ok`, a readable folder. A named
/// pipe, socket or device is refused without opening it (an open would block or consume
/// it). `prefix` names the place, e.g. "recipe.yaml:3: input.surface: " or "manifest ".
/// Reads the filesystem only (stat, access).
void require_input_file(const std::string& path, const std::string& prefix, bool folder_ok = false);

}  // namespace frontmesh::core
