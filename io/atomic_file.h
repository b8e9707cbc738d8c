#pragma once
// Atomic output: write to a temporary file beside the target, then rename over it.

#include <functional>
#include <string>

namespace frontmesh::io {

/// Calls `write(temp_path)` and renames the temporary file to `path` when it returns.
/// On an exception the temporary file is removed and `path` is untouched. Creates the
/// parent folder if needed. Throws IoError naming `path` when the rename fails.
void write_atomically(const std::string& path,
                      const std::function<void(const std::string& temp_path)>& write);

/// Writes `text` to `path` atomically.
void write_text_atomically(const std::string& path, const std::string& text);

/// Removes from `folder` (not below it) the temporary files write_atomically leaves when
/// its process is killed between writing and renaming: ".NAME.tmp-PID-N" whose process
/// PID no longer exists. Files of a live process (a concurrent writer) are kept, and so
/// is every other name. Returns how many files were removed; a missing folder has none.
/// Call only on a folder frontmesh owns (pipeline/output_dir.h: the marker file).
int remove_stale_temp_files(const std::string& folder);

}  // namespace frontmesh::io
