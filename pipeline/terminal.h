#pragma once
// What the run shows on a terminal (issue 22, item 10): the progress line with elapsed
// time and an estimate of the time left, and long lines broken at word boundaries.

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

namespace frontmesh::pipeline {

/// Width used when the terminal does not report one.
inline constexpr std::size_t kDefaultColumns = 100;

/// Columns of the terminal on file descriptor `fd`; 0 when `fd` is not a terminal or
/// reports no width. One ioctl, no allocation.
std::size_t terminal_columns(int fd);

/// `text` broken at spaces into lines of at most `width` columns (bytes); every line but
/// the first starts with `indent` spaces. A word longer than a line is kept whole on its
/// own line. Line breaks already in `text` are kept. Cost O(size of text).
std::string wrap_words(const std::string& text, std::size_t width, std::size_t indent);

/// True when `line` holds numbers and every one of them is zero ("repair: filled 0 holes
/// with 0 faces"): such a line says nothing happened, and the terminal leaves it out (the
/// log file keeps it). Numbers are words made of digits, '.', and signs, with surrounding
/// punctuation ignored; "[1/5]" holds 1 and 5.
bool lists_only_zeros(const std::string& line);

/// A duration for people: "0.4 s", "12 s", "3:05", "1:02:03" (seconds >= 0).
std::string duration_text(double seconds);

/// The terminal progress line of a stage: "  tetra     42%  region 3  0:12, about 0:17
/// left". `fraction` in [0, 1] (clamped); the estimate of the time left appears once it is
/// meaningful (fraction >= 0.02 and 1 s elapsed: a linear extrapolation of the fraction
/// done). Cut to `width` columns so that it never wraps (a wrapped line cannot be redrawn).
std::string progress_line(const std::string& stage, double fraction, const std::string& what,
                          double elapsed_s, std::size_t width);

/// The fraction a progress line shows: the largest reported since reset() (NaN counts as 0,
/// the result is clamped to [0, 1]), so that the line never goes backwards when a stage
/// starts another round that counts from 0 again (remesh rounds, tetra's attempts).
class ShownFraction {
public:
    void reset() { shown_ = 0.0; }
    /// Takes a reported fraction; returns the one to show.
    double update(double reported);

private:
    double shown_ = 0.0;
};

/// Calls `tick` about every `period` from a thread of its own between start() and stop(),
/// so that a progress line is redrawn (its elapsed time moving) while a long phase reports
/// nothing. `tick` runs on that thread and takes its own locks; it must not call stop().
class ProgressTicker {
public:
    explicit ProgressTicker(std::function<void()> tick,
                            std::chrono::milliseconds period = std::chrono::seconds(1));
    ~ProgressTicker();  ///< stop()
    ProgressTicker(const ProgressTicker&) = delete;
    ProgressTicker& operator=(const ProgressTicker&) = delete;

    /// Starts the thread (nothing when it runs already).
    void start();
    /// Stops and joins the thread (nothing when it does not run): returns once a tick under
    /// way has finished; no tick starts after it.
    void stop();
    bool is_running() const { return thread_.joinable(); }

private:
    std::function<void()> tick_;
    std::chrono::milliseconds period_;
    std::mutex mutex_;
    std::condition_variable wake_;
    bool stopping_ = false;
    std::thread thread_;
};

/// What `frontmesh run` prints when it is done: the result, checkpoints, summary and log of
/// output folder `dir`, and how to step through the run in ParaView (run-surface.pvd,
/// run-volume.pvd). With `width` > 0 (stdout is a terminal of that many columns) each line
/// is wrapped at spaces, continuations indented, as the run's other summary lines; 0: as is.
std::string results_text(const std::string& result, const std::string& dir, std::size_t width);

}  // namespace frontmesh::pipeline
