// FEBio .feb, format spec 4.0 (FEBio 4): Mesh (Nodes, one Elements part per region, the
// ElementSet all_elements, a Surface per boundary and per side of an interface, a NodeSet
// per surface, the whole outer boundary as Surface "boundary" and NodeSet
// "boundary_NODES"), MeshDomains (a SolidDomain per part) and one placeholder material per
// region, named after the region. Write only.

#include <algorithm>

#include "io/atomic_file.h"
#include "io/export_detail.h"
#include "pipeline/core/error.h"

namespace frontmesh::io::detail {

void write_febio(const core::TetMesh& mesh, const std::string& path, const LabelTable& names) {
    const auto regions = region_groups(mesh, names);
    const auto surfaces = surface_groups(mesh, names);
    // "1,2,3" (1-based) on one line: FEBio 4 reads set members as a comma-separated list.
    auto write_ids = [](TextOut& out, const std::vector<std::int32_t>& ids) {
        for (std::size_t i = 0; i < ids.size(); ++i) out << (i ? "," : "") << ids[i] + 1;
    };
    // One Surface: the faces of `faces` oriented out of region `from` (0: as stored).
    auto write_surface = [&](TextOut& out, const std::string& name,
                             const std::vector<std::int32_t>& faces, core::Label from) {
        out << "\t\t<Surface name=\"" << name << "\">\n";
        std::size_t k = 0;
        for (std::int32_t f : faces) {
            auto tri = mesh.faces[static_cast<std::size_t>(f)];
            if (from != 0 && mesh.region_in[static_cast<std::size_t>(f)] != from)
                std::swap(tri[1], tri[2]);
            out << "\t\t\t<tri3 id=\"" << ++k << "\">" << tri[0] + 1 << ',' << tri[1] + 1 << ','
                << tri[2] + 1 << "</tri3>\n";
        }
        out << "\t\t</Surface>\n";
    };
    write_atomically(path, [&](const std::string& temp) {
        TextOut out(temp);
        out << "<?xml version=\"1.0\" encoding=\"ISO-8859-1\"?>\n<febio_spec version=\"4.0\">\n";
        out << "\t<!-- frontmesh: " << mesh.node_count() << " nodes, " << mesh.tet_count()
            << " tet4 elements in " << regions.size() << " parts (one per region), "
            << surfaces.size()
            << " surfaces (boundary_R; interface_X_Y = faces of X bordering Y, normals out\n"
               "\t     of X, for both sides; boundary = the whole outer boundary).\n"
               "\t     The materials are PLACEHOLDERS (neo-Hookean, E = 1, v = 0.3): set real "
               "ones. -->\n";
        out << "\t<Module type=\"solid\"/>\n\t<Material>\n";
        int id = 0;
        for (const auto& r : regions) {
            out << "\t\t<material id=\"" << ++id << "\" name=\"" << r.name
                << "\" type=\"neo-Hookean\">\n"
                << "\t\t\t<density>1</density>\n\t\t\t<E>1</E>\n\t\t\t<v>0.3</v>\n\t\t</"
                   "material>\n";
        }
        out << "\t</Material>\n\t<Mesh>\n\t\t<Nodes name=\"nodes\">\n";
        for (std::size_t v = 0; v < mesh.node_count(); ++v)
            out << "\t\t\t<node id=\"" << v + 1 << "\">" << mesh.xyz[3 * v] << ','
                << mesh.xyz[3 * v + 1] << ',' << mesh.xyz[3 * v + 2] << "</node>\n";
        out << "\t\t</Nodes>\n";
        for (const auto& r : regions) {
            out << "\t\t<Elements type=\"tet4\" name=\"" << r.name << "\">\n";
            for (std::int32_t t : r.tets) {
                const auto& q = mesh.tets[static_cast<std::size_t>(t)];
                out << "\t\t\t<elem id=\"" << static_cast<std::int64_t>(t) + 1 << "\">" << q[0] + 1
                    << ',' << q[1] + 1 << ',' << q[2] + 1 << ',' << q[3] + 1 << "</elem>\n";
            }
            out << "\t\t</Elements>\n";
        }
        out << "\t\t<ElementSet name=\"all_elements\">1:" << mesh.tet_count() << "</ElementSet>\n";
        // Tags (README "Tag numbers"): a surface's is in a comment before it.
        std::vector<std::int32_t> outer;
        for (const auto& g : surfaces) {
            out << "\t\t<!-- surface " << g.tag << ": labels " << g.lo << " and " << g.hi
                << " -->\n";
            if (g.is_boundary()) {
                write_surface(out, g.name, g.faces, 0);
                outer.insert(outer.end(), g.faces.begin(), g.faces.end());
            } else {
                write_surface(out, side_name(g, g.lo, names), g.faces, g.lo);
                write_surface(out, side_name(g, g.hi, names), g.faces, g.hi);
            }
            out << "\t\t<NodeSet name=\"" << g.name << "_NODES\">";
            write_ids(out, face_nodes(mesh, g.faces));
            out << "</NodeSet>\n";
        }
        if (!outer.empty()) {
            std::sort(outer.begin(), outer.end());
            out << "\t\t<!-- surface " << kAllTag << ": every face whose outside is 0 -->\n";
            write_surface(out, "boundary", outer, 0);
            out << "\t\t<NodeSet name=\"boundary_NODES\">";
            write_ids(out, face_nodes(mesh, outer));
            out << "</NodeSet>\n";
        }
        out << "\t</Mesh>\n\t<MeshDomains>\n";
        for (const auto& r : regions)
            out << "\t\t<SolidDomain name=\"" << r.name << "\" mat=\"" << r.name << "\"/>\n";
        out << "\t</MeshDomains>\n</febio_spec>\n";
        out.close();
    });
}

}  // namespace frontmesh::io::detail
