#include "pipeline/terminal.h"

#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <utility>

namespace frontmesh::pipeline {

std::size_t terminal_columns(int fd) {
    if (!isatty(fd)) return 0;
    winsize size{};
    if (ioctl(fd, TIOCGWINSZ, &size) != 0) return 0;
    return size.ws_col;
}

std::string wrap_words(const std::string& text, std::size_t width, std::size_t indent) {
    width = std::max<std::size_t>(width, indent + 8);  // room for a word on every line
    std::string out;
    std::size_t column = 0;  // of the line being filled
    std::size_t i = 0;
    // Each pass takes one word (or one line break) and advances i past it: at most
    // text.size() passes.
    while (i < text.size()) {
        if (text[i] == '\n') {
            out += '\n';
            column = 0;
            ++i;
            continue;
        }
        if (text[i] == ' ') {  // counted back from the next word
            ++i;
            continue;
        }
        const std::size_t end = std::min(text.find_first_of(" \n", i), text.size());
        const std::size_t length = end - i;
        // The spaces before the word, as written (an aligned column keeps its alignment).
        std::size_t spaces = 0;
        while (spaces < i && text[i - spaces - 1] == ' ') ++spaces;
        if (column == 0 && out.empty()) {
            out.append(spaces, ' ');
            column = spaces;
        } else if (column == 0) {
            out.append(indent, ' ');
            column = indent;
        } else if (column + 1 + length > width) {
            out += '\n';
            out.append(indent, ' ');
            column = indent;
        } else {
            out.append(std::max<std::size_t>(spaces, 1), ' ');
            column += std::max<std::size_t>(spaces, 1);
        }
        out.append(text, i, length);
        column += length;
        i = end;
    }
    return out;
}

bool lists_only_zeros(const std::string& line) {
    bool any = false;
    std::size_t i = 0;
    // Each pass consumes one run of digit characters (or one other character): at most
    // line.size() passes.
    while (i < line.size()) {
        if (!std::isdigit(static_cast<unsigned char>(line[i]))) {
            ++i;
            continue;
        }
        const bool in_word = i > 0 && std::isalpha(static_cast<unsigned char>(line[i - 1]));
        std::size_t end = i;
        bool zero = true;
        while (end < line.size() && (std::isdigit(static_cast<unsigned char>(line[end])) ||
                                     (line[end] == '.' && end + 1 < line.size() &&
                                      std::isdigit(static_cast<unsigned char>(line[end + 1]))))) {
            zero &= line[end] == '0' || line[end] == '.';
            ++end;
        }
        const bool word_goes_on = end < line.size() &&
                                  std::isalpha(static_cast<unsigned char>(line[end])) &&
                                  line[end] != 's';  // "0s"
        if (!in_word && !word_goes_on) {             // "v2", "3D" are names, not counts
            any = true;
            if (!zero) return false;
        }
        i = end;
    }
    return any;
}

std::string duration_text(double seconds) {
    seconds = std::max(seconds, 0.0);
    char buf[32];
    if (seconds < 10.0) {
        std::snprintf(buf, sizeof buf, "%.1f s", seconds);
        return buf;
    }
    if (seconds < 60.0) {
        std::snprintf(buf, sizeof buf, "%.0f s", std::floor(seconds));
        return buf;
    }
    const long total = std::lround(std::floor(seconds));
    if (total < 3600)
        std::snprintf(buf, sizeof buf, "%ld:%02ld", total / 60, total % 60);
    else
        std::snprintf(buf, sizeof buf, "%ld:%02ld:%02ld", total / 3600, total / 60 % 60,
                      total % 60);
    return buf;
}

std::string progress_line(const std::string& stage, double fraction, const std::string& what,
                          double elapsed_s, std::size_t width) {
    fraction = std::clamp(std::isfinite(fraction) ? fraction : 0.0, 0.0, 1.0);
    char head[64];
    std::snprintf(head, sizeof head, "  %-8s %3d%%", stage.c_str(),
                  static_cast<int>(fraction * 100.0 + 0.5));
    std::string time = duration_text(elapsed_s);
    if (fraction >= 0.02 && fraction < 1.0 && elapsed_s >= 1.0)
        time += ", about " + duration_text(elapsed_s * (1.0 - fraction) / fraction) + " left";
    std::string line = std::string(head) + "  " + time;
    if (!what.empty()) line += "  " + what;
    if (width > 0 && line.size() >= width) line.resize(width - 1);  // the cursor's column
    return line;
}

double ShownFraction::update(double reported) {
    if (!std::isfinite(reported)) reported = 0.0;
    shown_ = std::max(shown_, std::clamp(reported, 0.0, 1.0));
    return shown_;
}

ProgressTicker::ProgressTicker(std::function<void()> tick, std::chrono::milliseconds period)
    : tick_(std::move(tick)), period_(period) {}

ProgressTicker::~ProgressTicker() { stop(); }

void ProgressTicker::start() {
    if (thread_.joinable()) return;
    stopping_ = false;
    thread_ = std::thread([this] {
        std::unique_lock lock(mutex_);
        // Ends when stop() sets stopping_ (it then joins): one tick per period until then.
        while (!stopping_) {
            if (wake_.wait_for(lock, period_, [this] { return stopping_; })) break;
            lock.unlock();
            tick_();
            lock.lock();
        }
    });
}

void ProgressTicker::stop() {
    if (!thread_.joinable()) return;
    {
        const std::lock_guard lock(mutex_);
        stopping_ = true;
    }
    wake_.notify_all();
    thread_.join();
}

std::string results_text(const std::string& result, const std::string& dir, std::size_t width) {
    const std::filesystem::path d(dir);
    std::string out = "\nResult:      " + result +
                      "\nCheckpoints: " + (d / "checkpoints").string() +
                      "\nSummary:     " + (d / "summary.json").string() +
                      "\nLog:         " + (d / "frontmesh.log").string() + "\n";
    const std::string surfaces = (d / "run-surface.pvd").string();
    const std::string volumes = (d / "run-volume.pvd").string();
    if (width == 0)  // not a terminal: the lines as they always were
        return out + "Step through the run in ParaView:  paraview " + surfaces +
               "\n  (the surface stages; colour by region_in, eta or min_angle), and " + volumes +
               "\n  (the tet stages, when the run made tets; colour by region or skewness)\n";
    // One paragraph wrapped at spaces (each of the lines above may be wrapped too).
    std::string wrapped;
    std::size_t start = 1;  // after the leading blank line
    while (start < out.size()) {
        const std::size_t end = out.find('\n', start);
        wrapped += wrap_words(out.substr(start, end - start), width, 2) + '\n';
        start = end + 1;
    }
    return "\n" + wrapped +
           wrap_words("Step through the run in ParaView: paraview " + surfaces +
                          " (the surface stages; colour by region_in, eta or min_angle), and "
                          "paraview " +
                          volumes +
                          " (the tet stages, when the run made tets; colour by region or "
                          "skewness)",
                      width, 2) +
           '\n';
}

}  // namespace frontmesh::pipeline
