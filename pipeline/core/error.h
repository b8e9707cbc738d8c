#pragma once
// Error types (STYLE §4). The message is the one line a user sees; the source location is
// attached separately and goes to the log only.

#include <stdexcept>
#include <string>

namespace frontmesh::core {

/// Base of every frontmesh error. `what()` is the user-facing line.
class Error : public std::runtime_error {
public:
    Error(const std::string& message, const char* file = "", int line = 0,
          const char* function = "")
        : std::runtime_error(message), file_(file), line_(line), function_(function) {}

    /// "file:line (function)" of the throw site, for the log.
    std::string where() const {
        return std::string(file_) + ":" + std::to_string(line_) + " (" + function_ + ")";
    }

private:
    const char* file_;
    int line_;
    const char* function_;
};

/// Bad recipe, image, labels or other user input: exit code 2.
class InputError : public Error {
public:
    using Error::Error;
};

/// Repair cannot close, orient or untangle a surface.
class GeometryError : public Error {
public:
    using Error::Error;
};

/// A meshing stage cannot finish (stalled front, failed region).
class MeshingError : public Error {
public:
    using Error::Error;
};

/// A file cannot be read or written for reasons other than its content.
class IoError : public Error {
public:
    using Error::Error;
};

/// Invariant violation inside frontmesh: a bug (exit code 1).
class InternalError : public Error {
public:
    using Error::Error;
};

}  // namespace frontmesh::core

#define FM_THROW(Type, message) \
    throw ::frontmesh::core::Type((message), __FILE__, __LINE__, __func__)

/// Always-on invariant check guarding against corrupt output.
#define FM_CHECK(cond)                                                         \
    do {                                                                       \
        if (!(cond)) FM_THROW(InternalError, "internal check failed: " #cond); \
    } while (false)

#ifndef NDEBUG
#define FM_ASSERT(cond) FM_CHECK(cond)
#else
#define FM_ASSERT(cond) \
    do {                \
    } while (false)
#endif
