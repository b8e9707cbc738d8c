// FEBio .feb, format spec 4.0 (FEBio 4): Mesh (Nodes, one Elements part per region,
// one Surface per boundary / interface pair), MeshDomains (a SolidDomain per part) and one
// placeholder material per region, named after the region. Write only.

#include "io/atomic_file.h"
#include "io/export_detail.h"
#include "pipeline/core/error.h"

namespace frontmesh::io::detail {

void write_febio(const core::TetMesh& mesh, const std::string& path, const LabelTable& names) {
    const auto regions = region_groups(mesh, names);
    const auto surfaces = surface_groups(mesh, names);
    write_atomically(path, [&](const std::string& temp) {
        TextOut out(temp);
        out << "<?xml version=\"1.0\" encoding=\"ISO-8859-1\"?>\n<febio_spec version=\"4.0\">\n";
        out << "\t<!-- frontmesh: " << mesh.node_count() << " nodes, " << mesh.tet_count()
            << " tet4 elements in " << regions.size() << " parts (one per region), "
            << surfaces.size()
            << " surfaces (boundary and interface faces, normals out of region_in).\n"
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
        for (const auto& g : surfaces) {
            out << "\t\t<Surface name=\"" << g.name << "\">\n";
            std::size_t k = 0;
            for (std::int32_t f : g.faces) {
                const auto& tri = mesh.faces[static_cast<std::size_t>(f)];
                out << "\t\t\t<tri3 id=\"" << ++k << "\">" << tri[0] + 1 << ',' << tri[1] + 1 << ','
                    << tri[2] + 1 << "</tri3>\n";
            }
            out << "\t\t</Surface>\n";
        }
        out << "\t</Mesh>\n\t<MeshDomains>\n";
        for (const auto& r : regions)
            out << "\t\t<SolidDomain name=\"" << r.name << "\" mat=\"" << r.name << "\"/>\n";
        out << "\t</MeshDomains>\n</febio_spec>\n";
        out.close();
    });
}

}  // namespace frontmesh::io::detail
