// What a run shows on a terminal (issue 22, item 10): progress with elapsed time and time
// left, long lines broken at word boundaries.

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>

#include <catch2/catch.hpp>

#include "pipeline/terminal.h"

using namespace frontmesh::pipeline;

namespace {
std::size_t longest_line(const std::string& text) {
    std::istringstream in(text);
    std::size_t n = 0;
    for (std::string line; std::getline(in, line);) n = std::max(n, line.size());
    return n;
}
}  // namespace

TEST_CASE("wrap_words breaks long lines at spaces only", "[pipeline][terminal]") {
    const std::string text =
        "tetra done in 2.31 s, peak memory 118 MB: 5123 nodes, 24020 tets, 3 regions, valid, "
        "volume 4188.79 mm^3 (relative error 1.2e-15), skewness mean 0.2315 max 0.8123, "
        "min dihedral 12.34 deg";
    const std::string wrapped = wrap_words(text, 60, 4);
    CHECK(longest_line(wrapped) <= 60);
    // Nothing lost, nothing cut inside a word.
    std::istringstream a(text), b(wrapped);
    std::string wa, wb;
    while (a >> wa) {
        REQUIRE(b >> wb);
        CHECK(wa == wb);
    }
    CHECK_FALSE(b >> wb);
    CHECK(wrapped.find("\n    ") != std::string::npos);  // continuation indented
    CHECK(wrap_words("short line", 60, 4) == "short line");
    // A word longer than the width stays whole.
    const std::string path(80, 'x');
    CHECK(wrap_words("wrote " + path, 40, 2) == "wrote\n  " + path);
}

TEST_CASE("progress line: elapsed time, time left, never wider than the terminal",
          "[pipeline][terminal]") {
    const std::string early = progress_line("tetra", 0.01, "region 3", 0.5, 100);
    CHECK_THAT(early, Catch::Contains("tetra") && Catch::Contains("1%") &&
                          Catch::Contains("0.5 s") && Catch::Contains("region 3"));
    CHECK_THAT(early, !Catch::Contains("left"));  // too early to estimate
    const std::string half = progress_line("tetra", 0.5, "region 3", 20.0, 100);
    CHECK_THAT(half, Catch::Contains("50%") && Catch::Contains("20 s") &&
                         Catch::Contains("about 20 s left"));
    CHECK(progress_line("refine", 0.25, std::string(300, 'w'), 75.0, 50).size() < 50);
    CHECK_THAT(progress_line("refine", 0.25, "", 75.0, 100),
               Catch::Contains("1:15") && Catch::Contains("about 3:45 left"));
    CHECK(duration_text(3723.0) == "1:02:03");
    CHECK(duration_text(4.25) == "4.2 s");
}

TEST_CASE("lines that only count zeros are recognised", "[pipeline][terminal]") {
    CHECK(lists_only_zeros("repair: filled 0 holes with 0 faces"));
    CHECK(lists_only_zeros(
        "repair: merged 0 points, dropped 0 collapsed, 0 zero-area (0 neighbours split), 0 "
        "duplicate and 0 cancelling faces, 0 unused points"));
    CHECK(lists_only_zeros("refine: 0.0 mm moved, 0 flips"));
    CHECK_FALSE(lists_only_zeros("repair: flipped 0 faces to face outward (3 pieces)"));
    CHECK_FALSE(lists_only_zeros("repair: no self-intersections"));  // no number: it says something
    CHECK_FALSE(lists_only_zeros("[1/5] extract"));
    CHECK_FALSE(lists_only_zeros("extract: 3D surface nets, 0.5 relaxation"));
    CHECK_FALSE(lists_only_zeros("remesh: 0 faces, 10 vertices"));
}

TEST_CASE("the closing ParaView hint is wrapped on a terminal, as is in a pipe",
          "[pipeline][terminal]") {
    const std::string dir = "/data/studies/cohort-2026/subject-0042/frontmesh-output";
    const std::string result = dir + "/mesh.vtu";
    // In a pipe (width 0): the lines as before.
    const std::string plain = results_text(result, dir, 0);
    CHECK_THAT(plain, Catch::Contains("\nResult:      " + result + "\n") &&
                          Catch::Contains("Step through the run in ParaView:  paraview " + dir +
                                          "/run-surface.pvd\n  (the surface stages;"));
    // On a terminal of 60 columns: no line longer, no word cut, both collections named.
    const std::string wrapped = results_text(result, dir, 60);
    std::istringstream in(wrapped);
    for (std::string line; std::getline(in, line);) {
        INFO(line);
        const bool one_long_word = line.find(' ', line.find_first_not_of(' ')) == std::string::npos;
        CHECK((line.size() <= 60 || one_long_word));
    }
    CHECK_THAT(wrapped, Catch::Contains(dir + "/run-surface.pvd") &&
                            Catch::Contains(dir + "/run-volume.pvd"));
    CHECK(wrapped.find("\n  ") != std::string::npos);  // continuations indented
    CHECK(longest_line(plain) > 60);                   // there was something to wrap
}

TEST_CASE("the shown fraction never goes back within a stage", "[pipeline][terminal]") {
    ShownFraction shown;
    CHECK(shown.update(0.4) == 0.4);
    CHECK(shown.update(0.1) == 0.4);  // a second remesh round counting from 0 again
    CHECK(shown.update(0.7) == 0.7);
    CHECK(shown.update(std::nan("")) == 0.7);
    CHECK(shown.update(3.0) == 1.0);
    shown.reset();  // the next stage
    CHECK(shown.update(0.1) == Approx(0.1));
}

TEST_CASE("the progress ticker redraws between events until it is stopped",
          "[pipeline][terminal]") {
    // No timing asserted: the test waits (up to a generous bound, against a hang) until the
    // ticker has ticked twice on its own, then checks that stop() ends the ticks.
    std::mutex mutex;
    std::condition_variable ticked;
    int ticks = 0;
    ProgressTicker ticker(
        [&] {
            const std::lock_guard lock(mutex);
            ++ticks;
            ticked.notify_all();
        },
        std::chrono::milliseconds(1));
    CHECK_FALSE(ticker.is_running());
    ticker.start();
    ticker.start();  // a second start changes nothing
    CHECK(ticker.is_running());
    {
        std::unique_lock lock(mutex);
        CHECK(ticked.wait_for(lock, std::chrono::seconds(60), [&] { return ticks >= 2; }));
    }
    ticker.stop();
    CHECK_FALSE(ticker.is_running());
    int after_stop = 0;
    {
        const std::lock_guard lock(mutex);
        after_stop = ticks;
    }
    std::this_thread::yield();
    {
        const std::lock_guard lock(mutex);
        CHECK(ticks == after_stop);  // joined: no tick after stop() returned
    }
    ticker.stop();  // harmless
    // It can run again (the next stage).
    ticker.start();
    {
        std::unique_lock lock(mutex);
        CHECK(ticked.wait_for(lock, std::chrono::seconds(60),
                              [&] { return ticks >= after_stop + 1; }));
    }
}
