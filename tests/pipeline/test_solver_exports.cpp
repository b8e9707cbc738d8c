// Exports that real solvers run unchanged (issue 22): CalculiX (Debian's calculix-ccx) solves
// a static step on the .inp of generated single- and multi-region phantoms, and tag numbers
// do not change when a second run meshes a subset of the labels.

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "io/export.h"
#include "io/mesh_io.h"
#include "io/split_interfaces.h"
#include "pipeline/core/quality.h"
#include "tests/fixtures/phantoms.h"
#include "tests/fixtures/referee.h"
#include "tests/fixtures/skip.h"
#include "tests/pipeline/cli_helpers.h"

using namespace frontmesh;
using frontmesh::testing::run_frontmesh;
using frontmesh::testing::slurp;
using frontmesh::testing::write_file;
namespace fs = std::filesystem;

namespace {

struct Shell {
    int exit_code = -1;
    std::string out;
};

Shell shell(const std::string& command) {
    Shell r;
    std::FILE* p = popen((command + " 2>&1").c_str(), "r");
    if (!p) return r;
    char buf[4096];
    std::size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
    const int status = pclose(p);
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    return r;
}

/// Meshes `image` (in `dir`) with `labels` ("all" or "[2, 3]") into dir/NAME, exporting
/// vtu, msh and inp; names from names.txt in `dir` when it exists. Returns the output folder.
fs::path mesh_image(const std::string& dir, const std::string& image, const std::string& name,
                    const std::string& labels, const std::string& more_output = "") {
    std::string recipe = "input:\n  image: " + image + "\n  labels: " + labels + "\n";
    if (fs::exists(dir + "/names.txt")) recipe += "  label_names: names.txt\n";
    recipe += "output:\n  dir: " + name + "\n  formats: [vtu, msh, inp, feb]\n" + more_output;
    write_file(dir + "/" + name + ".yaml", recipe);
    const auto r = run_frontmesh("run " + name + ".yaml --quiet", dir);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    return fs::path(dir) / name;
}

/// The element sets of the regions: "** region <label> <set>" lines of a .inp we wrote.
std::map<int, std::string> region_sets(const fs::path& inp) {
    std::map<int, std::string> sets;
    std::istringstream in(slurp(inp));
    for (std::string line; std::getline(in, line);)
        if (line.rfind("** region ", 0) == 0) {
            std::istringstream s(line.substr(10));
            int label = 0;
            std::string set;
            s >> label >> set;
            sets[label] = set;
        }
    return sets;
}

/// The displacements CalculiX printed (*NODE PRINT U) in JOB.dat: node -> (ux, uy, uz).
std::map<int, std::array<double, 3>> displacements(const fs::path& dat) {
    std::map<int, std::array<double, 3>> u;
    std::istringstream in(slurp(dat));
    bool in_block = false;
    for (std::string line; std::getline(in, line);) {
        if (line.find("displacements (vx,vy,vz)") != std::string::npos) {
            in_block = true;
            continue;
        }
        std::istringstream s(line);
        int node = 0;
        std::array<double, 3> v{};
        std::string x[3];
        if (in_block && (s >> node >> x[0] >> x[1] >> x[2])) {
            for (int k = 0; k < 3; ++k)
                v[static_cast<std::size_t>(k)] = std::strtod(x[k].c_str(), nullptr);
            u[node] = v;
        } else if (in_block && !line.empty() && line.find_first_not_of(' ') != std::string::npos) {
            in_block = false;
        }
    }
    return u;
}

/// Writes DIR/job.inp around DIR/mesh.inp (included unchanged), runs ccx in DIR and checks
/// the job finished with a finite, non-zero displacement at every node. `deck` is the
/// model data between the *INCLUDE and the *STEP; `loads` the step's loads.
void solve_with_ccx(const fs::path& dir, const std::string& deck, const std::string& loads,
                    std::size_t nodes) {
    write_file((dir / "job.inp").string(),
               "*HEADING\nfrontmesh export solved by CalculiX\n*INCLUDE, INPUT=mesh.inp\n" + deck +
                   "*STEP\n*STATIC\n" + loads +
                   "*NODE FILE\nU\n*NODE PRINT, NSET=ALLNODES\nU\n*END STEP\n");
    const Shell r = shell("cd '" + dir.string() + "' && OMP_NUM_THREADS=1 ccx -i job");
    INFO(r.out);
    REQUIRE(r.exit_code == 0);
    CHECK_THAT(r.out, !Catch::Contains("*ERROR"));
    CHECK(fs::exists(dir / "job.frd"));
    const auto u = displacements(dir / "job.dat");
    CHECK(u.size() == nodes);
    double max_u = 0;
    std::size_t non_finite = 0;
    for (const auto& [node, v] : u)
        for (double x : v) {
            if (!std::isfinite(x)) ++non_finite;
            max_u = std::max(max_u, std::abs(x));
        }
    CHECK(non_finite == 0);
    CHECK(max_u > 0.0);
}

std::size_t node_count(const fs::path& inp) {
    std::istringstream in(slurp(inp));
    std::size_t n = 0;
    bool nodes = false;
    for (std::string line; std::getline(in, line);) {
        if (!line.empty() && line[0] == '*')
            nodes = line.rfind("*NODE,", 0) == 0;
        else if (nodes && !line.empty())
            ++n;
    }
    return n;
}

/// name -> "dim tag" of a .msh's $PhysicalNames.
std::map<std::string, std::string> physical_names(const fs::path& msh) {
    std::map<std::string, std::string> tags;
    std::istringstream in(slurp(msh));
    std::string line;
    while (std::getline(in, line) && line != "$PhysicalNames") {
    }
    std::getline(in, line);
    for (int n = std::stoi(line); n > 0 && std::getline(in, line); --n) {
        const auto q = line.find('"');
        tags[line.substr(q + 1, line.size() - q - 2)] = line.substr(0, q - 1);
    }
    return tags;
}

}  // namespace

TEST_CASE("CalculiX solves the .inp of a single-region phantom unchanged",
          "[pipeline][export][ccx]") {
    if (shell("command -v ccx").exit_code != 0) {
        FM_SKIP("ccx not installed (scripts/install-deps.sh installs calculix-ccx)");
    }
    const std::string dir = fixtures::temp_dir("solver_ccx_single");
    fixtures::write_metaimage(fixtures::sphere_image(20, 7.0), dir + "/ball.mha");
    const fs::path out = mesh_image(dir, "ball.mha", "out", "all");
    const auto sets = region_sets(out / "mesh.inp");
    REQUIRE(sets.size() == 1);
    // Fixed outer boundary, gravity: the inside sags.
    solve_with_ccx(out,
                   "*MATERIAL, NAME=TISSUE\n*ELASTIC\n1000., 0.45\n*DENSITY\n1.E-9\n"
                   "*SOLID SECTION, ELSET=" +
                       sets.begin()->second +
                       ", MATERIAL=TISSUE\n*BOUNDARY\nboundary_NODES, 1, 3\n",
                   "*DLOAD\nALLELEMENTS, GRAV, 9810., 0., 0., -1.\n", node_count(out / "mesh.inp"));
    // The re-read .inp (numbers of at most 20 characters) still holds the remeshed surface.
    const auto check =
        run_frontmesh("check out/mesh.inp --surface out/checkpoints/03-remesh.vtu", dir);
    INFO(check.out << check.err);
    CHECK(check.exit_code == 0);
    CHECK_THAT(check.out, Catch::Contains("preserved yes"));
}

TEST_CASE("tag numbers do not change when a run meshes a subset of the labels",
          "[pipeline][export]") {
    const std::string dir = fixtures::temp_dir("solver_tags_subset");
    fixtures::write_metaimage(fixtures::nested_ellipsoids_image(1.0, 0.6), dir + "/phantom.mha");
    write_file(dir + "/names.txt", "1 Brain\n2 CSF\n3 Skull\n");
    const fs::path all = mesh_image(dir, "phantom.mha", "all", "all");
    const fs::path subset = mesh_image(dir, "phantom.mha", "subset", "[2, 3]");

    // Tags (README "Tag numbers") do not depend on which other labels were meshed.
    const auto tags_all = physical_names(all / "mesh.msh");
    const auto tags_subset = physical_names(subset / "mesh.msh");
    const std::map<std::string, std::string> want = {{"CSF", "3 2"},
                                                     {"Skull", "3 3"},
                                                     {"boundary_Skull", "2 3"},
                                                     {"interface_CSF_Skull", "2 200003"}};
    for (const auto& [name, tag] : want) {
        INFO(name);
        REQUIRE(tags_all.count(name));
        REQUIRE(tags_subset.count(name));
        CHECK(tags_all.at(name) == tag);
        CHECK(tags_subset.at(name) == tag);
    }
    CHECK(tags_all.at("interface_Brain_CSF") == "2 100002");
    for (const auto* out : {&all, &subset}) {
        const std::string inp = slurp(*out / "mesh.inp");
        CHECK_THAT(inp, Catch::Contains("** surface 200003 interface_CSF_Skull labels 2 3\n"));
        const std::string feb = slurp(*out / "mesh.feb");
        CHECK_THAT(feb, Catch::Contains("<!-- surface 200003: labels 2 and 3 -->"));
    }
}

TEST_CASE("FEniCSx reads the .msh with the same tags in two subjects and solves Poisson on it",
          "[pipeline][asan-slow][export][fenicsx]") {
    if (shell("/usr/bin/python3 -c 'import dolfinx.io.gmshio'").exit_code != 0) {
        FM_SKIP("dolfinx not installed (scripts/install-deps.sh installs python3-dolfinx)");
    }
    const std::string dir = fixtures::temp_dir("solver_fenicsx");
    fixtures::write_metaimage(fixtures::nested_ellipsoids_image(1.0, 0.6), dir + "/phantom.mha");
    // Every label, and a second subject without label 1: region 2's inner surface is then
    // its boundary (tag 2) while the 2|3 interface keeps tag 200003 (README, tag numbers).
    const fs::path all = mesh_image(dir, "phantom.mha", "all", "all");
    const fs::path subset = mesh_image(dir, "phantom.mha", "subset", "[2, 3]");
    const std::string script = FRONTMESH_SOURCE_DIR "/tests/io/check_fenicsx.py";
    const Shell a = shell("/usr/bin/python3 '" + script + "' '" + (all / "mesh.msh").string() +
                          "' 1,2,3 3,100002,200003");
    INFO(a.out);
    CHECK(a.exit_code == 0);
    const Shell b = shell("/usr/bin/python3 '" + script + "' '" + (subset / "mesh.msh").string() +
                          "' 2,3 2,3,200003");
    INFO(b.out);
    CHECK(b.exit_code == 0);
}

TEST_CASE("CalculiX solves the .inp of a three-region phantom unchanged",
          "[pipeline][export][ccx]") {
    if (shell("command -v ccx").exit_code != 0) {
        FM_SKIP("ccx not installed (scripts/install-deps.sh installs calculix-ccx)");
    }
    const std::string dir = fixtures::temp_dir("solver_ccx_multi");
    fixtures::write_metaimage(fixtures::nested_ellipsoids_image(1.0, 0.6), dir + "/phantom.mha");
    write_file(dir + "/names.txt", "1 Brain\n2 CSF\n3 Skull\n");
    const fs::path all = mesh_image(dir, "phantom.mha", "all", "all");
    const fs::path subset = mesh_image(dir, "phantom.mha", "subset", "[2, 3]");
    for (const auto* out : {&all, &subset}) {
        INFO(out->string());
        const auto sets = region_sets(*out / "mesh.inp");
        // A material and a section per region; the inner surface of the skull is held (its
        // nodes), the outer boundary is pressed and every element has weight.
        std::string deck;
        for (const auto& [label, set] : sets)
            deck += "*MATERIAL, NAME=M" + std::to_string(label) + "\n*ELASTIC\n" +
                    std::to_string(1000 * label) + "., 0.45\n*DENSITY\n1.E-9\n" +
                    "*SOLID SECTION, ELSET=" + set + ", MATERIAL=M" + std::to_string(label) + "\n";
        deck += "*BOUNDARY\ninterface_CSF_Skull_NODES, 1, 3\n";
        solve_with_ccx(
            *out, deck,
            "*DSLOAD\nboundary, P, 0.01\n*DLOAD\nALLELEMENTS, GRAV, 9810., 0., 0., -1.\n",
            node_count(*out / "mesh.inp"));
        // The surfaces from either side of an interface are there for contact or tie.
        const std::string inp = slurp(*out / "mesh.inp");
        CHECK_THAT(inp, Catch::Contains("NAME=interface_CSF_Skull\n"));
        CHECK_THAT(inp, Catch::Contains("NAME=interface_Skull_CSF\n"));
    }
}

namespace {

std::map<core::Label, double> region_volumes(const core::TetMesh& mesh) {
    std::map<core::Label, double> v;
    for (std::size_t t = 0; t < mesh.tet_count(); ++t) {
        const auto& q = mesh.tets[t];
        v[mesh.region[t]] += core::tet_signed_volume(mesh.point(q[0]), mesh.point(q[1]),
                                                     mesh.point(q[2]), mesh.point(q[3]));
    }
    return v;
}

std::set<std::int32_t> region_nodes(const core::TetMesh& mesh, core::Label r) {
    std::set<std::int32_t> nodes;
    for (std::size_t t = 0; t < mesh.tet_count(); ++t)
        if (mesh.region[t] == r) nodes.insert(mesh.tets[t].begin(), mesh.tets[t].end());
    return nodes;
}

/// The lines of the commented *TIE skeleton of a split interface in a .inp we wrote,
/// uncommented ("***TIE" -> "*TIE").
std::string tie_lines(const fs::path& inp, long long tag) {
    std::istringstream in(slurp(inp));
    std::string line, tie;
    while (std::getline(in, line))
        if (line.rfind("***TIE, NAME=T" + std::to_string(tag) + ",", 0) == 0) {
            tie = line.substr(2) + "\n";
            if (std::getline(in, line) && line.rfind("**", 0) == 0) tie += line.substr(2) + "\n";
            break;
        }
    return tie;
}

}  // namespace

TEST_CASE("a split interface shares no node and keeps volumes and CalculiX solves it tied",
          "[pipeline][export][ccx][split]") {
    const std::string dir = fixtures::temp_dir("solver_ccx_split");
    fixtures::write_metaimage(fixtures::nested_ellipsoids_image(1.0, 0.6), dir + "/phantom.mha");
    write_file(dir + "/names.txt", "1 Brain\n2 CSF\n3 Skull\n");
    const fs::path out =
        mesh_image(dir, "phantom.mha", "out", "all", "  split_interfaces: [[2, 1]]\n");

    // The brain and the CSF share no node; twins sit at the same place; volumes as meshed.
    const core::TetMesh split = io::read_tet_mesh((out / "mesh.vtu").string());
    const core::TetMesh meshed = io::read_tet_mesh((out / "checkpoints/05-refine.vtu").string());
    REQUIRE(split.twin.size() == split.node_count());
    CHECK(split.node_count() > meshed.node_count());
    const auto brain = region_nodes(split, 1), csf = region_nodes(split, 2);
    std::vector<std::int32_t> common;
    std::set_intersection(brain.begin(), brain.end(), csf.begin(), csf.end(),
                          std::back_inserter(common));
    CHECK(common.empty());
    std::size_t copies = 0;
    for (std::size_t v = 0; v < split.node_count(); ++v) {
        const std::int32_t w = split.twin[v];
        if (w == static_cast<std::int32_t>(v)) continue;
        ++copies;
        CHECK((split.point(static_cast<std::int32_t>(v)) - split.point(w)).norm() == 0.0);
    }
    CHECK(copies == split.node_count() - meshed.node_count());
    const auto before = region_volumes(meshed), after = region_volumes(split);
    for (const auto& [r, v] : before) CHECK(after.at(r) == Approx(v).epsilon(1e-12));

    // The referee: the split sides are boundary faces of their regions (two closed sheets
    // at the same place, opposite normals), the twins duplicate nodes; still valid.
    if (const std::string meshcheck = fixtures::meshcheck_path(); !meshcheck.empty()) {
        const Shell r =
            shell("/usr/bin/python3 '" + meshcheck + "' '" + (out / "mesh.vtu").string() + "'");
        INFO(r.out);
        CHECK(r.exit_code == 0);
    }
    // Brain and skull do not touch: exit 2, one line naming the key (the stages are reused).
    const auto apart =
        run_frontmesh("run out.yaml --quiet --set 'output.split_interfaces=[[1, 3]]'", dir);
    CHECK(apart.exit_code == 2);
    CHECK_THAT(apart.err, Catch::Contains("output.split_interfaces: [1, 3]: regions 1 and 3 "
                                          "do not touch (no interface between them)"));
    CHECK(std::count(apart.err.begin(), apart.err.end(), '\n') <= 1);
    const auto again =
        run_frontmesh("run out.yaml --quiet --set 'output.split_interfaces=[[2, 1]]'", dir);
    REQUIRE(again.exit_code == 0);

    // FEBio: the pair of the split interface holds the same triangles on other nodes.
    const Shell feb = shell("/usr/bin/python3 '" FRONTMESH_SOURCE_DIR "/tests/io/check_feb.py' '" +
                            (out / "mesh.feb").string() + "'");
    INFO(feb.out);
    CHECK(feb.exit_code == 0);
    CHECK_THAT(feb.out, Catch::Contains("split pairs 1\n"));

    if (shell("command -v ccx").exit_code != 0) {
        FM_SKIP("ccx not installed (scripts/install-deps.sh installs calculix-ccx)");
    }
    // Held at the skull's inner surface, under gravity: the brain hangs on the tie alone.
    const std::string tie = tie_lines(out / "mesh.inp", 100002);
    REQUIRE(tie ==
            "*TIE, NAME=T100002, ADJUST=NO\ninterface_CSF_Brain_SLAVE, interface_Brain_CSF\n");
    std::string deck;
    for (const auto& [label, set] : region_sets(out / "mesh.inp"))
        deck += "*MATERIAL, NAME=M" + std::to_string(label) + "\n*ELASTIC\n" +
                std::to_string(1000 * label) + "., 0.45\n*DENSITY\n1.E-9\n" +
                "*SOLID SECTION, ELSET=" + set + ", MATERIAL=M" + std::to_string(label) + "\n";
    deck += tie + "*BOUNDARY\ninterface_CSF_Skull_NODES, 1, 3\n";
    solve_with_ccx(out, deck, "*DLOAD\nALLELEMENTS, GRAV, 9810., 0., 0., -1.\n",
                   node_count(out / "mesh.inp"));
    // Continuous across the tie: each copy moves with the node it copies.
    const auto u = displacements(out / "job.dat");
    double max_u = 0, max_jump = 0;
    for (const auto& [node, v] : u)
        for (double x : v) max_u = std::max(max_u, std::abs(x));
    for (std::size_t v = 0; v < split.node_count(); ++v) {
        const std::int32_t w = split.twin[v];
        if (w == static_cast<std::int32_t>(v)) continue;
        const auto a = u.find(static_cast<int>(v) + 1), b = u.find(w + 1);
        REQUIRE(a != u.end());
        REQUIRE(b != u.end());
        for (int k = 0; k < 3; ++k)
            max_jump = std::max(max_jump, std::abs(a->second[static_cast<std::size_t>(k)] -
                                                   b->second[static_cast<std::size_t>(k)]));
    }
    INFO("max |u| " << max_u << ", largest jump across the tie " << max_jump);
    CHECK(max_u > 0.0);
    CHECK(max_jump <= 1e-3 * max_u);
}

TEST_CASE("CalculiX ties a split interface that ends on an unsplit junction",
          "[pipeline][export][ccx][split]") {
    if (shell("command -v ccx").exit_code != 0) {
        FM_SKIP("ccx not installed (scripts/install-deps.sh installs calculix-ccx)");
    }
    // A cube of 4^3 Kuhn cells: 1 below, 2 above, 3 on the side (x > 1); 1|2 is split and
    // ends on the line where 1|3 and 2|3 (not split) meet, whose nodes stay shared. A tie
    // whose slave side held those nodes would tie them to themselves (CalculiX stops:
    // "zero coefficient on the dependent side").
    core::TetMesh mesh = fixtures::cube_tet_mesh(4, 0.5, true);
    for (std::size_t t = 0; t < mesh.tet_count(); ++t) {
        double x = 0;
        for (int k = 0; k < 4; ++k) x += mesh.point(mesh.tets[t][k]).x() / 4;
        if (x > 1.0) mesh.region[t] = 3;
    }
    core::derive_boundary_faces(mesh);
    mesh.surface_vertices = static_cast<std::int32_t>(mesh.node_count());
    const core::TetMesh split = io::split_interfaces(mesh, {false, {{1, 2}}});
    const fs::path dir = fixtures::temp_dir("solver_ccx_split_junction");
    io::write_mesh(split, (dir / "mesh.inp").string(), io::MeshFormat::Abaqus);
    const std::string tie = tie_lines(dir / "mesh.inp", 100002);
    REQUIRE(tie ==
            "*TIE, NAME=T100002, ADJUST=NO\ninterface_region_2_region_1_SLAVE, "
            "interface_region_1_region_2\n");
    std::string deck;
    for (int r = 1; r <= 3; ++r)
        deck += "*MATERIAL, NAME=M" + std::to_string(r) + "\n*ELASTIC\n" + std::to_string(10 * r) +
                "., 0.45\n*DENSITY\n1.E-9\n*SOLID SECTION, ELSET=region_" + std::to_string(r) +
                ", MATERIAL=M" + std::to_string(r) + "\n";
    deck += tie + "*BOUNDARY\nboundary_region_3_NODES, 1, 3\n";
    solve_with_ccx(dir, deck, "*DLOAD\nALLELEMENTS, GRAV, 9810., 0., 0., -1.\n",
                   split.node_count());
    const auto u = displacements(dir / "job.dat");
    double max_u = 0, max_jump = 0;
    for (const auto& [node, v] : u)
        for (double x : v) max_u = std::max(max_u, std::abs(x));
    for (std::size_t v = 0; v < split.node_count(); ++v) {
        const std::int32_t w = split.twin[v];
        if (w == static_cast<std::int32_t>(v)) continue;
        const auto a = u.find(static_cast<int>(v) + 1), b = u.find(w + 1);
        REQUIRE(a != u.end());
        REQUIRE(b != u.end());
        for (int k = 0; k < 3; ++k)
            max_jump = std::max(max_jump, std::abs(a->second[static_cast<std::size_t>(k)] -
                                                   b->second[static_cast<std::size_t>(k)]));
    }
    INFO("max |u| " << max_u << ", largest jump across the tie " << max_jump);
    CHECK(max_u > 0.0);
    CHECK(max_jump <= 1e-3 * max_u);
}

namespace {

/// "FILE tets N volume V ..." lines of check_quadratic.py: file name -> volume.
std::map<std::string, double> quadratic_volumes(const std::string& out) {
    std::map<std::string, double> volumes;
    std::istringstream in(out);
    for (std::string line; std::getline(in, line);) {
        std::istringstream s(line);
        std::string file, tets_word, volume_word;
        std::size_t tets = 0;
        double volume = 0;
        if (s >> file >> tets_word >> tets >> volume_word >> volume && tets_word == "tets" &&
            volume_word == "volume")
            volumes[fs::path(file).filename().string()] = volume;
    }
    return volumes;
}

}  // namespace

TEST_CASE("quadratic tets (output.order 2) read back in every format and CalculiX solves them",
          "[pipeline][asan-slow][export][quadratic][ccx]") {
    const std::string dir = fixtures::temp_dir("solver_quadratic");
    fixtures::write_metaimage(fixtures::nested_ellipsoids_image(1.0, 0.6), dir + "/phantom.mha");
    write_file(dir + "/names.txt", "1 Brain\n2 CSF\n3 Skull\n");
    write_file(dir + "/q.yaml",
               "input:\n  image: phantom.mha\n  label_names: names.txt\noutput:\n  dir: out\n"
               "  formats: [vtu, msh, msh22, inp, feb]\n  order: 2\n");
    const auto run = run_frontmesh("run q.yaml --quiet", dir);
    INFO(run.err);
    REQUIRE(run.exit_code == 0);
    const fs::path out = fs::path(dir) / "out";
    const std::string log = slurp(out / "frontmesh.log");
    CHECK_THAT(log, Catch::Contains("quadratic tets: "));

    // Every format read back (meshio; gmsh itself for .msh where installed): positive
    // Jacobians everywhere, mid nodes on their edges, the same volume in every format.
    std::string files;
    for (const char* f : {"mesh.vtu", "mesh.msh", "mesh.v22.msh", "mesh.inp", "mesh.feb"})
        files += " '" + (out / f).string() + "'";
    const Shell check =
        shell("/usr/bin/python3 '" FRONTMESH_SOURCE_DIR "/tests/io/check_quadratic.py'" + files);
    INFO(check.out);
    REQUIRE(check.exit_code == 0);
    const auto volumes = quadratic_volumes(check.out);
    REQUIRE(volumes.size() == 5);
    for (const auto& [file, v] : volumes) {
        INFO(file);
        CHECK(v == Approx(volumes.at("mesh.vtu")).epsilon(1e-9));
    }
    // Curved boundaries add volume where the straight tets cut the surface's curvature off.
    const core::TetMesh linear = io::read_tet_mesh((out / "checkpoints/05-refine.vtu").string());
    double linear_volume = 0;
    for (const auto& [r, v] : region_volumes(linear)) linear_volume += v;
    CHECK(volumes.at("mesh.vtu") == Approx(linear_volume).epsilon(0.02));
    CHECK(volumes.at("mesh.vtu") != linear_volume);

    // FEBio: tet10 parts, tri6 facets whose mid nodes are their elements'.
    const Shell feb = shell("/usr/bin/python3 '" FRONTMESH_SOURCE_DIR "/tests/io/check_feb.py' '" +
                            (out / "mesh.feb").string() + "'");
    INFO(feb.out);
    CHECK(feb.exit_code == 0);
    const std::string inp = slurp(out / "mesh.inp");
    CHECK_THAT(inp, Catch::Contains("*ELEMENT, TYPE=C3D10, ELSET="));
    // frontmesh check reads quadratic files as their corner tets (mid nodes unused).
    for (const char* f : {"out/mesh.vtu", "out/mesh.msh", "out/mesh.inp"}) {
        const auto checked = run_frontmesh(std::string("check ") + f, dir);
        INFO(f << ": " << checked.out << checked.err);
        CHECK(checked.exit_code == 0);
    }
    CHECK_THAT(inp, !Catch::Contains("C3D4"));

    // MEDIT .mesh has no quadratic tets: refused before any work, naming the key.
    const auto medit = run_frontmesh("run q.yaml --quiet --set 'output.formats=[vtu, mesh]'", dir);
    CHECK(medit.exit_code == 2);
    CHECK_THAT(medit.err, Catch::Contains("output.order"));

    // Split interfaces and quadratic tets: each side its own mid nodes, the FEBio pair
    // still the same triangles at the same places.
    const auto split = run_frontmesh(
        "run q.yaml --quiet --set 'output.split_interfaces=[[2, 1]]' --set 'output.formats=[feb]'",
        dir);
    INFO(split.err);
    REQUIRE(split.exit_code == 0);
    const Shell split_feb =
        shell("/usr/bin/python3 '" FRONTMESH_SOURCE_DIR "/tests/io/check_feb.py' '" +
              (out / "mesh.feb").string() + "'");
    INFO(split_feb.out);
    CHECK(split_feb.exit_code == 0);
    CHECK_THAT(split_feb.out, Catch::Contains("split pairs 1\n"));

    if (shell("command -v ccx").exit_code != 0) {
        FM_SKIP("ccx not installed (scripts/install-deps.sh installs calculix-ccx)");
    }
    // C3D10: a material and a section per region, the skull's inner surface held (corner
    // and mid nodes), pressure on the outer boundary and gravity.
    const auto again = run_frontmesh("run q.yaml --quiet", dir);
    REQUIRE(again.exit_code == 0);
    std::string deck;
    for (const auto& [label, set] : region_sets(out / "mesh.inp"))
        deck += "*MATERIAL, NAME=M" + std::to_string(label) + "\n*ELASTIC\n" +
                std::to_string(1000 * label) + "., 0.45\n*DENSITY\n1.E-9\n" +
                "*SOLID SECTION, ELSET=" + set + ", MATERIAL=M" + std::to_string(label) + "\n";
    deck += "*BOUNDARY\ninterface_CSF_Skull_NODES, 1, 3\n";
    solve_with_ccx(out, deck,
                   "*DSLOAD\nboundary, P, 0.01\n*DLOAD\nALLELEMENTS, GRAV, 9810., 0., 0., -1.\n",
                   node_count(out / "mesh.inp"));
}
