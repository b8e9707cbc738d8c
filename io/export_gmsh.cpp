// Gmsh MSH 4.1 (ASCII or binary) and 2.2 (ASCII): writers; reader of ASCII files.
// Format reference: the Gmsh manual, section "MSH file format" (versions 4.1 and 2.2).

#include <algorithm>
#include <limits>
#include <map>
#include <numeric>
#include <set>

#include "io/atomic_file.h"
#include "io/export_detail.h"
#include "pipeline/core/error.h"

namespace frontmesh::io::detail {
namespace {

constexpr int kGmshTriangle = 2;
constexpr int kGmshTet = 4;
constexpr int kGmshTriangle6 = 9;
constexpr int kGmshTet10 = 11;

/// Gmsh's node order of a tet10 from VTK's (export_detail tet_nodes): the mid nodes of
/// edges 03, 23, 13 come last in Gmsh (its manual, "Node ordering": node 8 on edge 2-3,
/// node 9 on edge 1-3), so VTK's nodes 8 and 9 swap. Triangles of 6 nodes agree.
constexpr int kGmshTet10Order[10] = {0, 1, 2, 3, 4, 5, 6, 7, 9, 8};

/// The element type and the nodes of tet t in Gmsh's order; returns the count.
int gmsh_tet(const core::TetMesh& mesh, std::size_t t, std::array<std::int32_t, 10>& v) {
    std::array<std::int32_t, 10> vtk{};
    const int n = tet_nodes(mesh, t, vtk);
    for (int k = 0; k < n; ++k)
        v[static_cast<std::size_t>(k)] =
            vtk[static_cast<std::size_t>(n == 10 ? kGmshTet10Order[k] : k)];
    return n;
}

/// Nodes per element of the Gmsh element types a reader may meet (0 = unknown).
int gmsh_nodes_per_element(long long type) {
    switch (type) {
        case 1:
            return 2;  // line
        case 2:
            return 3;  // triangle
        case 3:
            return 4;  // quadrangle
        case 4:
            return 4;  // tetrahedron
        case 5:
            return 8;  // hexahedron
        case 6:
            return 6;  // prism
        case 7:
            return 5;  // pyramid
        case 8:
            return 3;  // line3
        case 9:
            return 6;  // triangle6
        case 10:
            return 9;  // quadrangle9
        case 11:
            return 10;  // tetrahedron10
        case 15:
            return 1;  // point
        case 16:
            return 8;  // quadrangle8
        case 17:
            return 20;  // hexahedron20
        default:
            return 0;
    }
}

/// Physical names: every surface (2-D, its tag) and region (3-D, its label). No group
/// overlaps another: FEniCSx (gmshio.model_to_mesh) would duplicate cells and facets of an
/// element in two groups, and MSH 2.2 holds one group per element. The whole mesh is every
/// 3-D group; the whole outer boundary is every 2-D group of tag below kTagBase.
void write_physical_names(TextOut& out, const std::vector<RegionGroup>& regions,
                          const std::vector<SurfaceGroup>& surfaces) {
    out << "$PhysicalNames\n" << regions.size() + surfaces.size() << '\n';
    for (const auto& g : surfaces) out << "2 " << g.tag << " \"" << g.name << "\"\n";
    for (const auto& r : regions) out << "3 " << r.label << " \"" << r.name << "\"\n";
    out << "$EndPhysicalNames\n";
}

void write_node_xyz(TextOut& out, const core::TetMesh& mesh, std::size_t v) {
    out << mesh.xyz[3 * v] << ' ' << mesh.xyz[3 * v + 1] << ' ' << mesh.xyz[3 * v + 2];
}

/// MSH 4.1 sections in ASCII (numbers separated by spaces, a line per record) or binary
/// (native little-endian int32 for dims, tags and types, size_t = uint64 for counts and
/// node / element tags, float64 coordinates, no separators; Gmsh manual, "MSH file format
/// version 4.1", binary mode).
class MshOut {
public:
    MshOut(TextOut& out, bool binary) : out_(out), binary_(binary) {}
    MshOut& size(std::uint64_t v) {
        if (binary_) return bytes(&v, sizeof v);
        sep();
        out_ << static_cast<std::int64_t>(v);
        return *this;
    }
    MshOut& integer(std::int64_t v) {
        if (binary_) {
            FM_CHECK(v >= std::numeric_limits<std::int32_t>::min() &&
                     v <= std::numeric_limits<std::int32_t>::max());
            const auto i = static_cast<std::int32_t>(v);
            return bytes(&i, sizeof i);
        }
        sep();
        out_ << v;
        return *this;
    }
    MshOut& real(double v) {
        if (binary_) return bytes(&v, sizeof v);
        sep();
        out_ << v;
        return *this;
    }
    /// Ends an ASCII record (nothing in binary).
    void end_record() {
        if (!binary_) out_ << '\n';
        first_ = true;
    }
    /// Ends a section's data: binary data is followed by a line break before $End...
    void end_section(std::string_view end) {
        if (binary_) out_ << '\n';
        out_ << end << '\n';
        first_ = true;
    }

private:
    void sep() {
        if (!first_) out_ << ' ';
        first_ = false;
    }
    MshOut& bytes(const void* p, std::size_t n) {
        out_.bytes(p, n);
        return *this;
    }
    TextOut& out_;
    bool binary_;
    bool first_ = true;
};

/// Bounding box of the nodes of some elements (their mid nodes too), as six reals.
template <class Elements, class Mids>
void write_bbox(MshOut& out, const core::TetMesh& mesh, const Elements& elements, const Mids& mids,
                const std::vector<std::int32_t>& ids) {
    double lo[3], hi[3];
    for (int k = 0; k < 3; ++k) {
        lo[k] = std::numeric_limits<double>::max();
        hi[k] = std::numeric_limits<double>::lowest();
    }
    auto extend = [&](std::int32_t v) {
        for (int k = 0; k < 3; ++k) {
            lo[k] = std::min(lo[k], mesh.xyz[3 * static_cast<std::size_t>(v) + k]);
            hi[k] = std::max(hi[k], mesh.xyz[3 * static_cast<std::size_t>(v) + k]);
        }
    };
    for (std::int32_t e : ids) {
        for (std::int32_t v : elements[static_cast<std::size_t>(e)]) extend(v);
        if (!mids.empty())
            for (std::int32_t v : mids[static_cast<std::size_t>(e)]) extend(v);
    }
    for (double x : lo) out.real(x);
    for (double x : hi) out.real(x);
}

}  // namespace

/// After io::split_interfaces: the view "twin" ($NodeData, one value per node: the tag of
/// the node it is a copy of, its own for a node that is not a copy), which gmsh shows and
/// meshio reads as point data. Binary records are int32 tag + float64 (gmsh's and meshio's
/// reading). Nothing for a mesh without split interfaces.
void write_twin_node_data(TextOut& text, MshOut& out, const core::TetMesh& mesh) {
    if (mesh.twin.empty()) return;
    text << "$NodeData\n1\n\"twin\"\n1\n0\n3\n0\n1\n" << mesh.node_count() << '\n';
    for (std::size_t v = 0; v < mesh.node_count(); ++v)
        out.integer(static_cast<std::int64_t>(v) + 1)
            .real(static_cast<double>(mesh.twin[v]) + 1.0)
            .end_record();
    out.end_section("$EndNodeData");
}

void write_msh41(const core::TetMesh& mesh, const std::string& path, const LabelTable& names,
                 bool binary) {
    const auto regions = region_groups(mesh, names);
    const auto surfaces = surface_groups(mesh, names);
    check_numeric_tags(regions, surfaces, path);
    // Surface entities: one per surface and side (the label of region_in), so that each is
    // oriented one way; entity tags 1, 2, ... in surface order.
    struct SurfaceEntity {
        const SurfaceGroup* group;
        core::Label in;
        std::vector<std::int32_t> faces;
    };
    std::vector<SurfaceEntity> entities;
    for (const auto& g : surfaces)
        for (const core::Label in : {g.lo, g.hi}) {
            SurfaceEntity e{&g, in, {}};
            for (std::int32_t f : g.faces)
                if (mesh.region_in[static_cast<std::size_t>(f)] == in) e.faces.push_back(f);
            if (!e.faces.empty()) entities.push_back(std::move(e));
        }
    // Each node belongs to one entity, as Gmsh classifies it: the first surface entity with
    // a face on it (a node where surfaces meet sits on their shared curve, which this file
    // does not model: the first surface stands for it), else the volume of the first tet
    // on it (an interior node lies in one region). Index i < entities.size() is surface
    // entity i, entities.size() + j is region j. Each loop visits every face or tet once.
    const std::size_t n = mesh.node_count();
    constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();
    std::vector<std::size_t> node_entity(n, kNone);
    // Mid nodes of quadratic tets go with the face or tet they are on, as corners do.
    for (std::size_t i = 0; i < entities.size(); ++i)
        for (std::int32_t f : entities[i].faces) {
            std::array<std::int32_t, 6> nodes{};
            const int count = face_nodes_of(mesh, static_cast<std::size_t>(f), false, nodes);
            for (int k = 0; k < count; ++k)
                if (node_entity[static_cast<std::size_t>(nodes[static_cast<std::size_t>(k)])] ==
                    kNone)
                    node_entity[static_cast<std::size_t>(nodes[static_cast<std::size_t>(k)])] = i;
        }
    for (std::size_t j = 0; j < regions.size(); ++j)
        for (std::int32_t t : regions[j].tets) {
            std::array<std::int32_t, 10> nodes{};
            const int count = tet_nodes(mesh, static_cast<std::size_t>(t), nodes);
            for (int k = 0; k < count; ++k)
                if (node_entity[static_cast<std::size_t>(nodes[static_cast<std::size_t>(k)])] ==
                    kNone)
                    node_entity[static_cast<std::size_t>(nodes[static_cast<std::size_t>(k)])] =
                        entities.size() + j;
        }
    // The nodes of each entity, increasing (counting sort; a node in no element goes with
    // the first region).
    std::vector<std::vector<std::int32_t>> entity_nodes(entities.size() + regions.size());
    for (std::size_t v = 0; v < n; ++v)
        entity_nodes[node_entity[v] == kNone ? entities.size() : node_entity[v]].push_back(
            static_cast<std::int32_t>(v));
    const auto blocks = static_cast<std::size_t>(
        std::count_if(entity_nodes.begin(), entity_nodes.end(),
                      [](const std::vector<std::int32_t>& b) { return !b.empty(); }));

    write_atomically(path, [&](const std::string& temp) {
        TextOut text(temp);
        MshOut out(text, binary);
        text << "$MeshFormat\n4.1 " << (binary ? "1" : "0") << " 8\n";
        if (binary) {
            const std::int32_t one = 1;  // lets a reader detect the byte order
            text.bytes(&one, sizeof one);
            text << '\n';
        }
        text << "$EndMeshFormat\n";
        write_physical_names(text, regions, surfaces);
        // One volume entity per region (entity tag = label), bounded by the surface entities
        // of its surfaces (negative tag where the entity's normal points into the volume).
        // Each entity is in one physical group: its surface's tag or its region's label.
        text << "$Entities\n";
        out.size(0).size(0).size(entities.size()).size(regions.size()).end_record();
        for (std::size_t i = 0; i < entities.size(); ++i) {
            const auto& e = entities[i];
            out.integer(static_cast<std::int64_t>(i) + 1);
            write_bbox(out, mesh, mesh.faces, mesh.face_mid, e.faces);
            out.size(1).integer(e.group->tag).size(0).end_record();
        }
        for (const auto& r : regions) {
            out.integer(r.label);
            write_bbox(out, mesh, mesh.tets, mesh.tet_mid, r.tets);
            std::vector<std::int64_t> bounding;
            for (std::size_t i = 0; i < entities.size(); ++i) {
                const auto& e = entities[i];
                const auto tag = static_cast<std::int64_t>(i) + 1;
                if (e.in == r.label)
                    bounding.push_back(tag);
                else if (e.group->lo == r.label || e.group->hi == r.label)
                    bounding.push_back(-tag);
            }
            out.size(1).integer(r.label).size(bounding.size());
            for (std::int64_t b : bounding) out.integer(b);
            out.end_record();
        }
        out.end_section("$EndEntities");
        // Nodes: node tag = index + 1, one block per entity that has nodes.
        text << "$Nodes\n";
        out.size(blocks).size(n).size(1).size(n).end_record();
        for (std::size_t e = 0; e < entity_nodes.size(); ++e) {
            const auto& nodes = entity_nodes[e];
            if (nodes.empty()) continue;
            const bool surface = e < entities.size();
            out.integer(surface ? 2 : 3)
                .integer(surface ? static_cast<std::int64_t>(e) + 1
                                 : regions[e - entities.size()].label)
                .integer(0)
                .size(nodes.size())
                .end_record();
            for (std::int32_t v : nodes) out.size(static_cast<std::uint64_t>(v) + 1).end_record();
            for (std::int32_t v : nodes) {
                for (int k = 0; k < 3; ++k) out.real(mesh.xyz[3 * static_cast<std::size_t>(v) + k]);
                out.end_record();
            }
        }
        out.end_section("$EndNodes");
        // Elements: tet t has tag t + 1, face f has tag tets + f + 1.
        const std::size_t nt = mesh.tet_count(), nf = mesh.face_count();
        const int tet_type = mesh.is_quadratic() ? kGmshTet10 : kGmshTet;
        const int triangle_type = mesh.is_quadratic() ? kGmshTriangle6 : kGmshTriangle;
        text << "$Elements\n";
        out.size(entities.size() + regions.size()).size(nt + nf).size(1).size(nt + nf);
        out.end_record();
        for (std::size_t i = 0; i < entities.size(); ++i) {
            out.integer(2).integer(static_cast<std::int64_t>(i) + 1).integer(triangle_type);
            out.size(entities[i].faces.size()).end_record();
            for (std::int32_t f : entities[i].faces) {
                out.size(nt + static_cast<std::size_t>(f) + 1);
                std::array<std::int32_t, 6> nodes{};
                const int count = face_nodes_of(mesh, static_cast<std::size_t>(f), false, nodes);
                for (int k = 0; k < count; ++k)
                    out.size(static_cast<std::uint64_t>(nodes[static_cast<std::size_t>(k)]) + 1);
                out.end_record();
            }
        }
        for (const auto& r : regions) {
            out.integer(3).integer(r.label).integer(tet_type).size(r.tets.size()).end_record();
            for (std::int32_t t : r.tets) {
                out.size(static_cast<std::size_t>(t) + 1);
                std::array<std::int32_t, 10> nodes{};
                const int count = gmsh_tet(mesh, static_cast<std::size_t>(t), nodes);
                for (int k = 0; k < count; ++k)
                    out.size(static_cast<std::uint64_t>(nodes[static_cast<std::size_t>(k)]) + 1);
                out.end_record();
            }
        }
        out.end_section("$EndElements");
        write_twin_node_data(text, out, mesh);
        text.close();
    });
}

void write_msh22(const core::TetMesh& mesh, const std::string& path, const LabelTable& names) {
    const auto regions = region_groups(mesh, names);
    const auto surfaces = surface_groups(mesh, names);
    check_numeric_tags(regions, surfaces, path);
    std::vector<std::int64_t> face_tag(mesh.face_count(), 0);
    for (const auto& g : surfaces)
        for (std::int32_t f : g.faces) face_tag[static_cast<std::size_t>(f)] = g.tag;
    write_atomically(path, [&](const std::string& temp) {
        TextOut out(temp);
        out << "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n";
        write_physical_names(out, regions, surfaces);
        const std::size_t n = mesh.node_count();
        out << "$Nodes\n" << n << '\n';
        for (std::size_t v = 0; v < n; ++v) {
            out << v + 1 << ' ';
            write_node_xyz(out, mesh, v);
            out << '\n';
        }
        out << "$EndNodes\n";
        // elm-number elm-type 2 physical elementary nodes...; tets first (tag t + 1).
        const std::size_t nt = mesh.tet_count(), nf = mesh.face_count();
        out << "$Elements\n" << nt + nf << '\n';
        const int tet_type = mesh.is_quadratic() ? kGmshTet10 : kGmshTet;
        const int triangle_type = mesh.is_quadratic() ? kGmshTriangle6 : kGmshTriangle;
        for (std::size_t t = 0; t < nt; ++t) {
            const core::Label r = mesh.region[t];
            out << t + 1 << ' ' << tet_type << " 2 " << r << ' ' << r;
            std::array<std::int32_t, 10> nodes{};
            const int count = gmsh_tet(mesh, t, nodes);
            for (int k = 0; k < count; ++k) out << ' ' << nodes[static_cast<std::size_t>(k)] + 1;
            out << '\n';
        }
        for (std::size_t f = 0; f < nf; ++f) {
            out << nt + f + 1 << ' ' << triangle_type << " 2 " << face_tag[f] << ' ' << face_tag[f];
            std::array<std::int32_t, 6> nodes{};
            const int count = face_nodes_of(mesh, f, false, nodes);
            for (int k = 0; k < count; ++k) out << ' ' << nodes[static_cast<std::size_t>(k)] + 1;
            out << '\n';
        }
        out << "$EndElements\n";
        MshOut data(out, false);
        write_twin_node_data(out, data, mesh);
        out.close();
    });
}

RawMesh read_msh(const std::string& path) {
    Tokens in(path);
    RawMesh raw;
    if (in.word("$MeshFormat") != "$MeshFormat") in.fail("not a Gmsh .msh file (no $MeshFormat)");
    const std::string version(in.word("the format version"));
    const long long file_type = in.integer("the file type");
    const long long data_size = in.integer("the data size");
    const bool v4 = version == "4.1";
    const bool binary = file_type != 0;
    if (binary) {
        // Binary MSH 4.1: the int 1 in the writer's byte order, then the sections with
        // binary data between their text markers.
        if (!v4)
            in.fail("binary MSH " + version +
                    " files are not supported (binary 4.1 and ASCII are; gmsh FILE -0 -save -o "
                    "out.msh saves it as ASCII)");
        if (data_size != 8)
            in.fail("binary .msh with data size " + std::to_string(data_size) +
                    " is not supported (8 is)");
        in.skip_line();
        in.set_binary(true);
        const long long one = in.integer("the byte-order mark", 4);
        in.set_binary(false);
        if (one != 1) in.fail("binary .msh written with another byte order");
    }
    if (in.word("$EndMeshFormat") != "$EndMeshFormat") in.fail("expected $EndMeshFormat");
    if (!v4 && version.rfind("2.", 0) != 0)
        in.fail("MSH version " + version + " is not supported (4.1 and 2.x are)");
    raw.format = v4 ? "msh 4.1" : "msh " + version;

    std::map<std::pair<int, long long>, std::string> physical_names;  // (dim, tag) -> name
    std::map<std::pair<int, long long>, long long> entity_physical;   // (dim, entity) -> tag
    std::map<long long, std::int32_t> node_index;                     // node tag -> index
    struct Element {
        long long tag;
        std::array<long long, 4> nodes;
        long long region;
    };
    std::vector<Element> tets, tris;
    std::vector<std::pair<long long, std::array<double, 3>>> nodes;

    auto add_element = [&](int type, long long tag, long long region,
                           const std::vector<long long>& v) {
        if (type == 4 || type == 11)
            tets.push_back({tag, {v[0], v[1], v[2], v[3]}, region});
        else if (type == 2 || type == 9)
            tris.push_back({tag, {v[0], v[1], v[2], 0}, region});
    };

    // How many items of `tokens` tokens (at least a byte and a separator each) the rest of
    // the file can hold: a count beyond it is not reserved (a $Nodes count of 1e9 in a
    // 300-byte file threw bad_alloc, exit 1; found by the malformed-input campaign, issue 21).
    auto room = [&in](int tokens) {
        const std::size_t left = in.text().size() - std::min(in.text().size(), in.position());
        return static_cast<long long>(left / static_cast<std::size_t>(2 * tokens)) + 1;
    };
    // The data of a binary section starts after the line break that ends its $Name.
    auto start_data = [&] {
        if (!binary) return;
        in.skip_line();
        in.set_binary(true);
    };
    while (!in.at_end()) {
        const std::string section(in.word("a section"));
        if (section.empty() || section[0] != '$')
            in.fail("expected a $Section, found \"" + section + "\"");
        const std::string end = "$End" + section.substr(1);
        if (section == "$PhysicalNames") {
            const long long n = in.integer("the number of physical names");
            for (long long i = 0; i < n; ++i) {
                const int dim = static_cast<int>(in.integer("a physical dimension"));
                const long long tag = in.integer("a physical tag");
                std::string name(in.rest_of_line());
                if (name.size() >= 2 && name.front() == '"' && name.back() == '"')
                    name = name.substr(1, name.size() - 2);
                physical_names[{dim, tag}] = name;
            }
        } else if (section == "$Entities" && v4) {
            start_data();
            long long count[4];
            for (auto& c : count) c = in.integer("an entity count", 8);
            for (int dim = 0; dim < 4; ++dim)
                for (long long i = 0; i < count[dim]; ++i) {
                    const long long tag = in.integer("an entity tag", 4);
                    for (int k = 0; k < (dim == 0 ? 3 : 6); ++k)
                        in.real("a bounding box coordinate");
                    const long long np = in.integer("the number of physical tags", 8);
                    for (long long k = 0; k < np; ++k) {
                        const long long p = in.integer("a physical tag", 4);
                        if (k == 0) entity_physical[{dim, tag}] = p;
                    }
                    if (dim > 0) {
                        const long long nb = in.integer("the number of bounding entities", 8);
                        for (long long k = 0; k < nb; ++k) in.integer("a bounding entity", 4);
                    }
                }
            in.set_binary(false);
        } else if (section == "$Nodes") {
            if (v4) {
                start_data();
                const long long blocks = in.integer("the number of node blocks", 8);
                const long long total = in.integer("the number of nodes", 8);
                in.integer("the smallest node tag", 8);
                in.integer("the largest node tag", 8);
                nodes.reserve(static_cast<std::size_t>(std::max(0LL, std::min(total, room(4)))));
                for (long long b = 0; b < blocks; ++b) {
                    in.integer("an entity dimension", 4);
                    in.integer("an entity tag", 4);
                    const long long parametric = in.integer("the parametric flag", 4);
                    const long long n = in.integer("the number of nodes in the block", 8);
                    if (parametric) in.fail("parametric node coordinates are not supported");
                    const std::size_t first = nodes.size();
                    for (long long i = 0; i < n; ++i)
                        nodes.push_back({in.integer("a node tag", 8), {}});
                    for (long long i = 0; i < n; ++i) {
                        auto& p = nodes[first + static_cast<std::size_t>(i)].second;
                        for (double& c : p) c = in.real("a node coordinate");
                    }
                }
                in.set_binary(false);
            } else {
                const long long n = in.integer("the number of nodes");
                if (n < 0 || n > room(4))
                    in.fail("the number of nodes " + std::to_string(n) +
                            " is more than the rest of the file holds");
                nodes.reserve(static_cast<std::size_t>(n));
                for (long long i = 0; i < n; ++i) {
                    const long long tag = in.integer("a node number");
                    std::array<double, 3> p{};
                    for (double& c : p) c = in.real("a node coordinate");
                    nodes.push_back({tag, p});
                }
            }
        } else if (section == "$Elements") {
            std::vector<long long> v;
            if (v4) {
                start_data();
                const long long blocks = in.integer("the number of element blocks", 8);
                in.integer("the number of elements", 8);
                in.integer("the smallest element tag", 8);
                in.integer("the largest element tag", 8);
                for (long long b = 0; b < blocks; ++b) {
                    const int dim = static_cast<int>(in.integer("an entity dimension", 4));
                    const long long entity = in.integer("an entity tag", 4);
                    const long long type = in.integer("an element type", 4);
                    const long long n = in.integer("the number of elements in the block", 8);
                    const int nn = gmsh_nodes_per_element(type);
                    if (nn == 0) in.fail("unknown element type " + std::to_string(type));
                    const auto it = entity_physical.find({dim, entity});
                    const long long region = it != entity_physical.end() ? it->second : entity;
                    v.resize(static_cast<std::size_t>(nn));
                    for (long long i = 0; i < n; ++i) {
                        const long long tag = in.integer("an element tag", 8);
                        for (auto& x : v) x = in.integer("a node tag", 8);
                        add_element(static_cast<int>(type), tag, region, v);
                    }
                }
                in.set_binary(false);
            } else {
                const long long n = in.integer("the number of elements");
                for (long long i = 0; i < n; ++i) {
                    const long long tag = in.integer("an element number");
                    const long long type = in.integer("an element type");
                    const long long ntags = in.integer("the number of tags");
                    long long physical = 0, elementary = 0;
                    for (long long k = 0; k < ntags; ++k) {
                        const long long t = in.integer("an element tag");
                        if (k == 0) physical = t;
                        if (k == 1) elementary = t;
                    }
                    const int nn = gmsh_nodes_per_element(type);
                    if (nn == 0) in.fail("unknown element type " + std::to_string(type));
                    v.resize(static_cast<std::size_t>(nn));
                    for (auto& x : v) x = in.integer("a node number");
                    add_element(static_cast<int>(type), tag, physical != 0 ? physical : elementary,
                                v);
                }
            }
        } else {
            // Sections we do not need ($Entities of 2.x files, $NodeData, $Periodic, ...).
            for (;;) {
                if (in.at_end()) in.fail("file ends inside " + section);
                if (in.word("a section end") == end) break;
            }
            continue;
        }
        if (in.word(end.c_str()) != end) in.fail("expected " + end);
    }

    std::sort(nodes.begin(), nodes.end(),
              [](const auto& a, const auto& b) { return a.first < b.first; });
    raw.mesh.xyz.reserve(3 * nodes.size());
    for (std::size_t i = 0; i < nodes.size(); ++i) {
        if (!node_index.emplace(nodes[i].first, static_cast<std::int32_t>(i)).second)
            in.fail("node tag " + std::to_string(nodes[i].first) + " appears twice");
        raw.mesh.add_node({nodes[i].second[0], nodes[i].second[1], nodes[i].second[2]});
    }
    // Node tags are usually 1..n: a dense table then, else the map.
    const long long max_tag = nodes.empty() ? 0 : nodes.back().first;
    std::vector<std::int32_t> dense;
    if (!nodes.empty() && nodes.front().first >= 0 &&
        max_tag <= 4 * static_cast<long long>(nodes.size()) + 16) {
        dense.assign(static_cast<std::size_t>(max_tag) + 1, -1);
        for (const auto& [tag, index] : node_index) dense[static_cast<std::size_t>(tag)] = index;
    }
    auto index_of = [&](long long tag) {
        if (!dense.empty() && tag >= 0 && tag <= max_tag &&
            dense[static_cast<std::size_t>(tag)] >= 0)
            return dense[static_cast<std::size_t>(tag)];
        const auto it = node_index.find(tag);
        if (it == node_index.end())
            in.fail("an element refers to node " + std::to_string(tag) +
                    ", which is not in $Nodes");
        return it->second;
    };
    auto by_tag = [](const Element& a, const Element& b) { return a.tag < b.tag; };
    std::stable_sort(tets.begin(), tets.end(), by_tag);
    std::stable_sort(tris.begin(), tris.end(), by_tag);
    std::set<long long> labels;
    for (const auto& e : tets) {
        if (e.region <= 0 || e.region > std::numeric_limits<core::Label>::max())
            in.fail("tetrahedron " + std::to_string(e.tag) + " has region tag " +
                    std::to_string(e.region) + " (regions must be > 0)");
        raw.mesh.add_tet(index_of(e.nodes[0]), index_of(e.nodes[1]), index_of(e.nodes[2]),
                         index_of(e.nodes[3]), static_cast<core::Label>(e.region));
        labels.insert(e.region);
    }
    for (const auto& e : tris)
        raw.triangles.push_back({index_of(e.nodes[0]), index_of(e.nodes[1]), index_of(e.nodes[2])});
    for (const auto& [key, name] : physical_names)
        if (key.first == 3 && labels.count(key.second) &&
            name != "region_" + std::to_string(key.second))
            raw.names.set(static_cast<core::Label>(key.second), name);
    return raw;
}

}  // namespace frontmesh::io::detail
