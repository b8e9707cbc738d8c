// Label tables: mricron atlas .txt, FreeSurfer LUT, ITK-SNAP descriptions, CSV; errors.

#include <filesystem>
#include <fstream>
#include <string>

#include <catch2/catch.hpp>

#include "io/label_table.h"
#include "pipeline/core/error.h"
#include "tests/fixtures/phantoms.h"
#include "tests/fixtures/skip.h"

using namespace frontmesh;

namespace {
std::string write(const std::string& dir, const std::string& name, const std::string& text) {
    const std::string path = dir + "/" + name;
    std::ofstream(path, std::ios::binary) << text;
    return path;
}
}  // namespace

TEST_CASE("label table styles", "[io][labels]") {
    const std::string dir = fixtures::temp_dir("label_tables");
    SECTION("mricron atlas txt with CRLF and a third column") {
        const auto t = io::read_label_table(
            write(dir, "aal.nii.txt", "1 Precentral_L 2001\r\n2 Precentral_R 2002\r\n"));
        CHECK(t.size() == 2);
        CHECK(t.name(1) == "Precentral_L");
        CHECK(t.name(2) == "Precentral_R");
        CHECK(t.name(3) == "region_3");
        // One number after the name is the atlas' code, not a colour.
        CHECK(t.colour(1) == io::default_colour(1));
        CHECK(t.colour(2) != t.colour(1));
    }
    SECTION("tab separated with background 0") {
        const auto t = io::read_label_table(
            write(dir, "jhu.txt", "0\tUnclassified\n2\tPontine_crossing_tract_(a_part_of_MCP)\n"));
        CHECK(t.name(0) == "Unclassified");
        CHECK(t.safe_name(2) == "Pontine_crossing_tract_a_part_of_MCP");
    }
    SECTION("FreeSurfer LUT with comments and colours") {
        const auto t = io::read_label_table(
            write(dir, "FreeSurferColorLUT.txt",
                  "#$Id: FreeSurferColorLUT.txt $\n\n"
                  "#No. Label Name:                            R   G   B   A\n"
                  "0   Unknown                                 0   0   0   0\n"
                  "2   Left-Cerebral-White-Matter              245 245 245 0\n"
                  "17  Left-Hippocampus                        220 216 20  0\n"));
        CHECK(t.name(17) == "Left-Hippocampus");
        CHECK(t.safe_name(2) == "Left_Cerebral_White_Matter");
        CHECK(t.colour(17) == io::Rgb{220, 216, 20});
        CHECK(t.colour(2) == io::Rgb{245, 245, 245});
        CHECK(t.colour(5) == io::default_colour(5));
    }
    SECTION("ITK-SNAP label description with quoted names") {
        const auto t = io::read_label_table(
            write(dir, "snap.txt",
                  "################################################\n"
                  "# ITK-SnAP Label Description File\n"
                  "    0     0    0    0        0  0  0    \"Clear Label\"\n"
                  "    1   255    0    0        1  1  1    \"Left hippocampus\"\n"
                  "   12     0  255    0        1  1  1    \"3rd ventricle\"\n"));
        CHECK(t.name(1) == "Left hippocampus");
        CHECK(t.safe_name(1) == "Left_hippocampus");
        CHECK(t.safe_name(12) == "R_3rd_ventricle");
        CHECK(t.colour(1) == io::Rgb{255, 0, 0});
        CHECK(t.colour(12) == io::Rgb{0, 255, 0});
    }
    SECTION("CSV with a header") {
        const auto t = io::read_label_table(write(dir, "labels.csv", "id,name\n1,brain\n2,csf\n"));
        CHECK(t.name(2) == "csf");
    }
    SECTION("names of several words") {
        const auto t = io::read_label_table(
            write(dir, "words.txt", "1 Grey matter\n2 White matter 200 10 10\n"));
        CHECK(t.name(1) == "Grey matter");
        CHECK(t.name(2) == "White matter");
        CHECK(t.colour(2) == io::Rgb{200, 10, 10});
        // The default palette: the same colour for a label in every run, distinct neighbours.
        CHECK(t.colour(1) == io::default_colour(1));
        CHECK(io::default_colour(1) != io::default_colour(2));
        CHECK(io::default_colour(13) == io::default_colour(1));
    }
}

TEST_CASE("label table errors name file and line", "[io][labels]") {
    const std::string dir = fixtures::temp_dir("label_tables_bad");
    CHECK_THROWS_WITH(io::read_label_table(write(dir, "a.txt", "1 a\n2 b\nthree c\n")),
                      Catch::Contains("a.txt:3") && Catch::Contains("three"));
    CHECK_THROWS_WITH(io::read_label_table(write(dir, "b.txt", "1 a\n1 b\n")),
                      Catch::Contains("b.txt:2") && Catch::Contains("twice"));
    CHECK_THROWS_WITH(io::read_label_table(write(dir, "c.txt", "1 a\n5\n")),
                      Catch::Contains("c.txt:2"));
    CHECK_THROWS_WITH(io::read_label_table(write(dir, "d.txt", "-4 a\n")),
                      Catch::Contains("d.txt:1"));
    CHECK_THROWS_WITH(
        io::read_label_table(write(dir, "e.lut", std::string("\xff\xcc\x00\x01\x02", 5))),
        Catch::Contains("not a text file"));
    CHECK_THROWS_WITH(io::read_label_table(dir + "/missing.txt"), Catch::Contains("no such file"));
    CHECK_THROWS_AS(io::read_label_table(write(dir, "f.txt", "# only comments\n")),
                    core::InputError);
}

TEST_CASE("sanitized names are identifiers and unique", "[io][labels]") {
    CHECK(io::sanitized_name("Left-Cerebral-White-Matter") == "Left_Cerebral_White_Matter");
    CHECK(io::sanitized_name("  (a) b  ") == "a_b");
    CHECK(io::sanitized_name("4th ventricle") == "R_4th_ventricle");
    CHECK(io::sanitized_name("???") == "region");
    CHECK(io::sanitized_name(std::string(200, 'x')).size() <= 64);
    io::LabelTable t;
    t.set(3, "a-b");
    t.set(4, "a b");
    CHECK(t.safe_name(3) == "a_b");
    CHECK(t.safe_name(4) == "a_b_4");
    CHECK(t.safe_name(9) == "region_9");
}

TEST_CASE("the mricron atlas tables", "[io][labels][e2e]") {
    const std::string aal = "/usr/share/mricron/templates/aal.nii.gz";
    if (!std::filesystem::exists(aal)) {
        FM_SKIP("mricron-data not installed");
    }
    const std::string txt = io::label_table_beside(aal);
    CHECK(txt == "/usr/share/mricron/templates/aal.nii.txt");
    const auto t = io::read_label_table(txt);
    CHECK(t.size() == 116);
    CHECK(t.name(1) == "Precentral_L");
    // The binary .lut beside it is a colour map without names.
    CHECK_THROWS_WITH(io::read_label_table("/usr/share/mricron/templates/aal.nii.lut"),
                      Catch::Contains("not a text file"));
    for (const char* atlas : {"AICHAmc.nii.gz", "JHU-WhiteMatter-labels-1mm.nii.gz"}) {
        const std::string beside =
            io::label_table_beside(std::string("/usr/share/mricron/templates/") + atlas);
        INFO(atlas);
        REQUIRE(!beside.empty());
        CHECK(io::read_label_table(beside).size() > 40);
    }
}
