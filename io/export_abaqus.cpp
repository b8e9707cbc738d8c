// Abaqus .inp (C3D4, or C3D10 for quadratic tets): writer and a reader for flat (part-less)
// input files.
// Regions are element sets (*ELEMENT, ELSET=name), boundary and interface surfaces are a
// node set plus an element-based surface (faces S1..S4 of the tets of region_in).

#include <algorithm>
#include <cctype>
#include <map>
#include <set>

#include "io/atomic_file.h"
#include "io/export_detail.h"
#include "pipeline/core/error.h"

namespace frontmesh::io::detail {
namespace {

constexpr std::size_t kMaxAbaqusName = 80;
// Abaqus data lines hold at most 16 entries, CalculiX reads lines of at most 132 characters:
// 10 ids of up to 10 digits with their ", " take 118; a C3D10 line (element id and 10
// nodes) 130.
constexpr int kIdsPerLine = 10;
// Abaqus and CalculiX read at most 20 characters per number field.
constexpr int kMaxNumberChars = 20;

/// Abaqus face number (1..4) of our local face k (the face opposite node k):
/// S1 = nodes 1-2-3 (opposite 4), S2 = 1-4-2 (opposite 3), S3 = 2-4-3 (opposite 1),
/// S4 = 3-4-1 (opposite 2). The same face numbers for C3D10 (faces by their corners).
constexpr int kAbaqusFace[4] = {3, 4, 2, 1};

/// `name + suffix` when it fits Abaqus's 80 characters, else the same with the labels as
/// numbers ("boundary_<r>", "interface_<x>_<y>").
std::string abaqus_name(const std::string& name, const SurfaceGroup& g, core::Label from,
                        const std::string& suffix) {
    if (name.size() + suffix.size() <= kMaxAbaqusName) return name + suffix;
    if (g.is_boundary()) return "boundary_" + std::to_string(g.hi) + suffix;
    const core::Label other = from == g.lo ? g.hi : g.lo;
    return "interface_" + std::to_string(from) + "_" + std::to_string(other) + suffix;
}

template <class Ids>
void write_id_lines(TextOut& out, const Ids& ids) {
    int k = 0;
    for (const auto id : ids) {
        if (k) out << ", ";
        out << static_cast<std::int64_t>(id) + 1;
        if (++k == kIdsPerLine) {
            out << '\n';
            k = 0;
        }
    }
    if (k) out << '\n';
}

std::string upper(std::string s) {
    for (char& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    return s;
}

std::string trim(const std::string& s) {
    std::size_t a = 0, b = s.size();
    while (a < b && std::isspace(static_cast<unsigned char>(s[a]))) ++a;
    while (b > a && std::isspace(static_cast<unsigned char>(s[b - 1]))) --b;
    return s.substr(a, b - a);
}

std::vector<std::string> split_commas(const std::string& line) {
    std::vector<std::string> out;
    std::size_t start = 0;
    for (;;) {
        const std::size_t c = line.find(',', start);
        out.push_back(
            trim(line.substr(start, c == std::string::npos ? std::string::npos : c - start)));
        if (c == std::string::npos) break;
        start = c + 1;
    }
    if (!out.empty() && out.back().empty()) out.pop_back();  // trailing comma
    return out;
}

/// For each interface split by output.split_interfaces (its sides are surfaces on their
/// own nodes): the node set "<slave>_SLAVE_NODES" and node-based surface "<slave>_SLAVE"
/// of the slave side's nodes that are not nodes of the master side, then a *TIE and a
/// *CONTACT PAIR skeleton, commented out ("***TIE" is the comment "**" before "*TIE"): the
/// mesh file stays a mesh that users *INCLUDE, and they choose. Slave = the larger label's
/// side, master = the smaller's. The tie's slave is node-based because the nodes the two
/// sides still share (where the interface meets an unsplit one) cannot be tied to
/// themselves (CalculiX: "zero coefficient on the dependent side"). Both skeletons are
/// accepted by CalculiX 2.20 once uncommented (the tie in
/// tests/pipeline/test_solver_exports.cpp).
void write_split_pairs(TextOut& out, const core::TetMesh& mesh,
                       const std::vector<SurfaceGroup>& surfaces, const LabelTable& names) {
    bool any = false;
    for (const auto& g : surfaces) {
        if (!g.split) continue;
        if (!any)
            out << "** Split interfaces (output.split_interfaces): the two sides are surfaces on "
                   "their own\n"
                   "** nodes (twins at equal coordinates). Uncomment (remove \"**\" before "
                   "\"*\") one of the\n"
                   "** pairs below, or both sides move apart freely. *CONTACT PAIR needs your "
                   "own\n"
                   "** *SURFACE INTERACTION; a node in two ties (a curve where split "
                   "interfaces meet)\n"
                   "** must be slave in only one of them.\n";
        any = true;
        const std::string master = abaqus_name(side_name(g, g.lo, names), g, g.lo, "");
        const std::string slave = abaqus_name(side_name(g, g.hi, names), g, g.hi, "");
        const std::string tied = abaqus_name(side_name(g, g.hi, names), g, g.hi, "_SLAVE");
        const auto master_nodes = face_nodes(mesh, side_faces(mesh, g, g.lo));
        std::vector<std::int32_t> slave_nodes;
        for (std::int32_t v : face_nodes(mesh, side_faces(mesh, g, g.hi)))
            if (!std::binary_search(master_nodes.begin(), master_nodes.end(), v))
                slave_nodes.push_back(v);
        out << "** split " << g.tag << " labels " << g.lo << ' ' << g.hi << '\n';
        if (!slave_nodes.empty()) {
            out << "*NSET, NSET=" << abaqus_name(side_name(g, g.hi, names), g, g.hi, "_SLAVE_NODES")
                << '\n';
            write_id_lines(out, slave_nodes);
            out << "*SURFACE, TYPE=NODE, NAME=" << tied << '\n'
                << abaqus_name(side_name(g, g.hi, names), g, g.hi, "_SLAVE_NODES") << '\n';
            out << "***TIE, NAME=T" << g.tag << ", ADJUST=NO\n**" << tied << ", " << master << '\n';
        }
        out << "***CONTACT PAIR, INTERACTION=<your interaction>, TYPE=SURFACE TO SURFACE\n**"
            << slave << ", " << master << '\n';
    }
}

}  // namespace

void write_abaqus(const core::TetMesh& mesh, const std::string& path, const LabelTable& names) {
    const auto regions = region_groups(mesh, names);
    const auto surfaces = surface_groups(mesh, names);
    const auto sides = face_tets(mesh);
    // C3D10: corners, then the mid nodes of edges 1-2, 2-3, 3-1, 1-4, 2-4, 3-4 (the Abaqus
    // manual's node ordering of the 10-node tetrahedron), which is VTK's (tet_nodes).
    const char* type = mesh.is_quadratic() ? "C3D10" : "C3D4";
    write_atomically(path, [&](const std::string& temp) {
        TextOut out(temp);
        // No *HEADING: a deck may hold only one, and users *INCLUDE this file in their own.
        out << "** frontmesh tetrahedral mesh: " << mesh.node_count() << " nodes, "
            << mesh.tet_count() << ' ' << type << " elements, " << regions.size() << " regions, "
            << surfaces.size() << " surfaces\n";
        out << "** Tag numbers, the same in every format and for every subject: region = its\n"
               "** label; surface between labels a < b (0 = outside) = a * "
            << kTagBase << " + b; " << kAllTag
            << " = the whole.\n"
               "** Element sets: one per region, ALLELEMENTS. Node sets: ALLNODES, "
               "<surface>_NODES.\n"
               "** Surfaces (element faces): boundary_<r>; interface_<x>_<y> = the faces of x's\n"
               "** tets that border y, for both sides; boundary = every face whose outside is 0.\n"
               "** No materials, sections or steps are defined.\n";
        for (const auto& r : regions) out << "** region " << r.label << ' ' << r.name << '\n';
        out << "*NODE, NSET=ALLNODES\n";
        for (std::size_t v = 0; v < mesh.node_count(); ++v) {
            out << v + 1 << ", ";
            out.real_within(mesh.xyz[3 * v], kMaxNumberChars) << ", ";
            out.real_within(mesh.xyz[3 * v + 1], kMaxNumberChars) << ", ";
            out.real_within(mesh.xyz[3 * v + 2], kMaxNumberChars) << '\n';
        }
        for (const auto& r : regions) {
            out << "*ELEMENT, TYPE=" << type << ", ELSET=" << r.name << '\n';
            for (std::int32_t t : r.tets) {
                std::array<std::int32_t, 10> nodes{};
                const int count = tet_nodes(mesh, static_cast<std::size_t>(t), nodes);
                out << static_cast<std::int64_t>(t) + 1;
                for (int k = 0; k < count; ++k)
                    out << ", " << nodes[static_cast<std::size_t>(k)] + 1;
                out << '\n';
            }
        }
        out << "*ELSET, ELSET=ALLELEMENTS, GENERATE\n1, " << mesh.tet_count() << ", 1\n";
        // The outer boundary's surface names the element sets of the regions' boundaries.
        std::vector<std::string> outer_sets;
        for (const auto& g : surfaces) {
            out << "** surface " << g.tag << ' ' << abaqus_name(g.name, g, g.lo, "") << " labels "
                << g.lo << ' ' << g.hi << '\n';
            out << "*NSET, NSET=" << abaqus_name(g.name, g, g.lo, "_NODES") << '\n';
            write_id_lines(out, face_nodes(mesh, g.faces));
            // Each side: one element set per Abaqus face number, then the surface made of them.
            for (const core::Label from : {g.lo, g.hi}) {
                if (from == 0) continue;  // the outside has no elements
                std::vector<std::int32_t> by_face[4];
                for (std::int32_t f : g.faces) {
                    const auto& s = sides[static_cast<std::size_t>(f)];
                    const auto [tet, k] =
                        mesh.region_in[static_cast<std::size_t>(f)] == from ? s.in : s.out;
                    if (tet >= 0) by_face[kAbaqusFace[k] - 1].push_back(tet);
                }
                const std::string name = side_name(g, from, names);
                for (int k = 0; k < 4; ++k) {
                    if (by_face[k].empty()) continue;
                    std::sort(by_face[k].begin(), by_face[k].end());
                    const std::string set =
                        abaqus_name(name, g, from, "_S" + std::to_string(k + 1));
                    out << "*ELSET, ELSET=" << set << '\n';
                    write_id_lines(out, by_face[k]);
                    if (g.is_boundary()) outer_sets.push_back(set + ", S" + std::to_string(k + 1));
                }
                out << "*SURFACE, TYPE=ELEMENT, NAME=" << abaqus_name(name, g, from, "") << '\n';
                for (int k = 0; k < 4; ++k)
                    if (!by_face[k].empty())
                        out << abaqus_name(name, g, from, "_S" + std::to_string(k + 1)) << ", S"
                            << k + 1 << '\n';
            }
        }
        if (!outer_sets.empty()) {
            std::vector<std::int32_t> outer_faces;
            for (const auto& g : surfaces)
                if (g.is_boundary())
                    outer_faces.insert(outer_faces.end(), g.faces.begin(), g.faces.end());
            out << "** surface " << kAllTag << " boundary: every face whose outside is 0\n";
            out << "*NSET, NSET=boundary_NODES\n";
            write_id_lines(out, face_nodes(mesh, outer_faces));
            out << "*SURFACE, TYPE=ELEMENT, NAME=boundary\n";
            for (const auto& line : outer_sets) out << line << '\n';
        }
        write_split_pairs(out, mesh, surfaces, names);
        out.close();
    });
}

RawMesh read_abaqus(const std::string& path) {
    Tokens in(path);  // for the text and "file:line" errors
    const std::string& text = in.text();
    RawMesh raw;
    raw.format = "inp";
    std::map<long long, std::array<double, 3>> nodes;
    struct Element {
        long long id;
        std::array<long long, 4> nodes;
        std::string set;
    };
    std::vector<Element> elements;
    std::map<std::string, std::pair<long long, std::string>> set_region;  // "** region <id> <set>"
    std::vector<std::string> set_order;

    std::size_t pos = 0, line_no = 0;
    enum class Block { None, Node, Element, Skip } block = Block::None;
    std::string element_set;
    int nodes_per_element = 4;
    auto fail = [&](const std::string& msg) {
        FM_THROW(InputError, path + ":" + std::to_string(line_no) + ": " + msg);
    };
    auto number = [&](const std::string& s, const char* what) -> long long {
        try {
            std::size_t used = 0;
            const long long v = std::stoll(s, &used);
            if (used == s.size()) return v;
        } catch (const std::exception&) {
        }
        fail(std::string("expected ") + what + ", found \"" + s.substr(0, 40) + "\"");
        return 0LL;
    };
    std::vector<long long> pending;  // element data continued over lines
    while (pos < text.size()) {
        std::size_t end = text.find('\n', pos);
        if (end == std::string::npos) end = text.size();
        const std::string line = trim(text.substr(pos, end - pos));
        pos = end + 1;
        ++line_no;
        if (line.empty()) continue;
        if (line.rfind("**", 0) == 0) {
            // "** region <id> <set>" (written by write_abaqus) names the region of an element set.
            const std::string c = trim(line.substr(2));
            if (c.rfind("region ", 0) == 0) {
                const std::size_t sp = c.find(' ', 7);
                if (sp != std::string::npos) {
                    try {
                        const std::string set = trim(c.substr(sp + 1));
                        set_region[upper(set)] = {std::stoll(c.substr(7, sp - 7)), set};
                    } catch (const std::exception&) {
                    }
                }
            }
            continue;
        }
        if (line[0] == '*') {
            if (!pending.empty()) fail("incomplete element data before " + line.substr(0, 40));
            const auto parts = split_commas(line);
            const std::string keyword = upper(parts[0]);
            std::map<std::string, std::string> params;
            for (std::size_t i = 1; i < parts.size(); ++i) {
                const std::size_t eq = parts[i].find('=');
                params[upper(trim(parts[i].substr(0, eq)))] =
                    eq == std::string::npos ? "" : trim(parts[i].substr(eq + 1));
            }
            if (keyword == "*NODE") {
                block = Block::Node;
            } else if (keyword == "*ELEMENT") {
                const std::string type = upper(params["TYPE"]);
                if (type.rfind("C3D4", 0) == 0)
                    nodes_per_element = 4;
                else if (type.rfind("C3D10", 0) == 0)
                    nodes_per_element = 10;
                else {
                    block = Block::Skip;  // other element types are not part of the tet mesh
                    continue;
                }
                block = Block::Element;
                element_set = upper(params["ELSET"]);
                if (std::find(set_order.begin(), set_order.end(), element_set) == set_order.end())
                    set_order.push_back(element_set);
            } else if (keyword == "*PART" || keyword == "*INSTANCE") {
                fail("Abaqus parts and instances are not supported; export a flat input file");
            } else {
                block = Block::Skip;
            }
            continue;
        }
        if (block == Block::Node) {
            const auto f = split_commas(line);
            if (f.size() < 4) fail("a node line needs an id and three coordinates");
            std::array<double, 3> p{};
            for (int k = 0; k < 3; ++k) {
                try {
                    p[static_cast<std::size_t>(k)] = std::stod(f[static_cast<std::size_t>(k) + 1]);
                } catch (const std::exception&) {
                    fail("bad coordinate \"" + f[static_cast<std::size_t>(k) + 1] + "\"");
                }
            }
            const long long id = number(f[0], "a node id");
            if (!nodes.emplace(id, p).second) fail("node " + f[0] + " defined twice");
        } else if (block == Block::Element) {
            for (const auto& s : split_commas(line)) pending.push_back(number(s, "a node id"));
            if (pending.size() >= static_cast<std::size_t>(nodes_per_element + 1)) {
                if (pending.size() > static_cast<std::size_t>(nodes_per_element + 1))
                    fail("too many nodes for the element type");
                elements.push_back(
                    {pending[0], {pending[1], pending[2], pending[3], pending[4]}, element_set});
                pending.clear();
            }
        }
    }
    if (!pending.empty()) fail("file ends inside element data");

    std::map<long long, std::int32_t> index;
    for (const auto& [id, p] : nodes) {
        index[id] = static_cast<std::int32_t>(raw.mesh.node_count());
        raw.mesh.add_node({p[0], p[1], p[2]});
    }
    // Region of an element set: the "** region" comment, else a "REGION_<id>" name, else its
    // position among the element sets (1, 2, ...).
    std::map<std::string, core::Label> region_of;
    std::map<core::Label, std::string> name_of;
    for (std::size_t i = 0; i < set_order.size(); ++i) {
        const std::string& s = set_order[i];
        long long r = static_cast<long long>(i) + 1;
        std::string name = s;
        if (const auto it = set_region.find(s); it != set_region.end()) {
            r = it->second.first;
            name = it->second.second;
        } else if (s.rfind("REGION_", 0) == 0) {
            try {
                r = std::stoll(s.substr(7));
            } catch (const std::exception&) {
            }
        }
        if (r <= 0 || r > 2147483647LL) r = static_cast<long long>(i) + 1;
        region_of[s] = static_cast<core::Label>(r);
        if (!s.empty() && s != "REGION_" + std::to_string(r))
            name_of[static_cast<core::Label>(r)] = name;
    }
    std::stable_sort(elements.begin(), elements.end(),
                     [](const Element& a, const Element& b) { return a.id < b.id; });
    for (const auto& e : elements) {
        std::int32_t v[4];
        for (int k = 0; k < 4; ++k) {
            const auto it = index.find(e.nodes[static_cast<std::size_t>(k)]);
            if (it == index.end())
                FM_THROW(InputError, path + ": element " + std::to_string(e.id) +
                                         " refers to node " +
                                         std::to_string(e.nodes[static_cast<std::size_t>(k)]) +
                                         ", which is not defined");
            v[k] = it->second;
        }
        raw.mesh.add_tet(v[0], v[1], v[2], v[3], region_of[e.set]);
    }
    // Names: the set names (their case from the "** region" comments when present).
    for (const auto& [label, name] : name_of)
        if (name != "region_" + std::to_string(label)) raw.names.set(label, name);
    return raw;
}

}  // namespace frontmesh::io::detail
