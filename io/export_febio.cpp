// FEBio .feb, format spec 4.0 (FEBio 4): a complete model skeleton that FEBio reads as it
// is and that a user completes with boundary conditions and loads. Sections in FEBio's order:
// Module (solid, units mm-N-s), Control (one STATIC step: time_steps, step_size,
// time_stepper, a solid solver with BFGS updates), Material (one placeholder per region,
// units in a comment), Mesh (Nodes; one Elements part per region; the ElementSet
// all_elements and the PartList all_parts (every part: FEBio 4.3 and later read PartList,
// FEBio 4.0-4.2 refuse the tag); a Surface per boundary and per side of an interface, a
// NodeSet per surface;
// the whole outer boundary as Surface "boundary" and NodeSet "boundary_NODES"; a
// SurfacePair per interface), MeshDomains (a SolidDomain per part with its material) and
// Output (a plot file with displacement and stress). Write only.
// Format reference: the FEBio 4 User's Manual, chapter "Free format input" (the sections
// above; set members as comma-separated lists and "first:last" ranges).

#include <algorithm>

#include "io/atomic_file.h"
#include "io/export_detail.h"
#include "pipeline/core/error.h"

namespace frontmesh::io::detail {
namespace {

// Placeholder material (units mm-N-s): a soft tissue of water's density; E and v are to be
// replaced by the user (the file says so).
constexpr double kPlaceholderE = 0.001;       // MPa (1 kPa)
constexpr double kPlaceholderV = 0.45;        // Poisson's ratio
constexpr double kPlaceholderDensity = 1e-9;  // t/mm^3 (1000 kg/m^3)
constexpr int kTimeSteps = 10;                // steps of the one static step, to time 1

}  // namespace

void write_febio(const core::TetMesh& mesh, const std::string& path, const LabelTable& names) {
    const auto regions = region_groups(mesh, names);
    const auto surfaces = surface_groups(mesh, names);
    // Quadratic tets: tet10 (corners, then the mid nodes of edges 1-2, 2-3, 3-1, 1-4, 2-4,
    // 3-4: VTK's order, tet_nodes) and tri6 facets (corners, then edges 1-2, 2-3, 3-1), as
    // FEBio's shape functions number them (FECore FETet10 and FETri6: H[4] = 4 r u, ...).
    const char* element = mesh.is_quadratic() ? "tet10" : "tet4";
    const char* facet = mesh.is_quadratic() ? "tri6" : "tri3";
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
            std::array<std::int32_t, 6> nodes{};
            const int count = face_nodes_of(
                mesh, static_cast<std::size_t>(f),
                from != 0 && mesh.region_in[static_cast<std::size_t>(f)] != from, nodes);
            out << "\t\t\t<" << facet << " id=\"" << ++k << "\">";
            for (int i = 0; i < count; ++i)
                out << (i ? "," : "") << nodes[static_cast<std::size_t>(i)] + 1;
            out << "</" << facet << ">\n";
        }
        out << "\t\t</Surface>\n";
    };
    write_atomically(path, [&](const std::string& temp) {
        TextOut out(temp);
        out << "<?xml version=\"1.0\" encoding=\"ISO-8859-1\"?>\n<febio_spec version=\"4.0\">\n";
        out << "\t<!-- frontmesh: " << mesh.node_count() << " nodes, " << mesh.tet_count() << ' '
            << element << " elements in " << regions.size() << " parts (one per region), "
            << surfaces.size()
            << " surfaces (boundary_R; interface_X_Y = faces of X bordering Y, normals out\n"
               "\t     of X, for both sides, paired in a SurfacePair for tie or contact;\n"
               "\t     boundary = the whole outer boundary).\n"
               "\t     Units mm-N-s: lengths in mm, forces in N, stresses in MPa, mass in t,\n"
               "\t     density in t/mm^3. The materials are PLACEHOLDERS (neo-Hookean, E = "
            << kPlaceholderE << " MPa,\n\t     v = " << kPlaceholderV << ", density "
            << kPlaceholderDensity
            << " t/mm^3 = 1000 kg/m^3): set real ones, and add\n"
               "\t     Boundary and Loads sections (e.g. on boundary_NODES) before running. -->\n";
        out << "\t<Module type=\"solid\">\n\t\t<units>mm-N-s</units>\n\t</Module>\n";
        // One static step of kTimeSteps steps; FEBio's usual Newton settings (BFGS updates,
        // displacement / energy / residual tolerances) so that the file runs once loaded.
        out << "\t<Control>\n\t\t<analysis>STATIC</analysis>\n\t\t<time_steps>" << kTimeSteps
            << "</time_steps>\n\t\t<step_size>" << 1.0 / kTimeSteps
            << "</step_size>\n"
               "\t\t<plot_level>PLOT_MAJOR_ITRS</plot_level>\n"
               "\t\t<output_level>OUTPUT_MAJOR_ITRS</output_level>\n"
               "\t\t<time_stepper type=\"default\">\n"
               "\t\t\t<max_retries>5</max_retries>\n\t\t\t<opt_iter>11</opt_iter>\n"
               "\t\t\t<dtmin>0</dtmin>\n\t\t\t<dtmax>"
            << 1.0 / kTimeSteps
            << "</dtmax>\n\t\t</time_stepper>\n"
               "\t\t<solver type=\"solid\">\n"
               "\t\t\t<max_refs>15</max_refs>\n\t\t\t<diverge_reform>1</diverge_reform>\n"
               "\t\t\t<reform_each_time_step>1</reform_each_time_step>\n"
               "\t\t\t<dtol>0.001</dtol>\n\t\t\t<etol>0.01</etol>\n\t\t\t<rtol>0</rtol>\n"
               "\t\t\t<lstol>0.9</lstol>\n\t\t\t<min_residual>1e-20</min_residual>\n"
               "\t\t\t<qn_method type=\"BFGS\">\n\t\t\t\t<max_ups>10</max_ups>\n"
               "\t\t\t</qn_method>\n\t\t</solver>\n\t</Control>\n";
        out << "\t<Material>\n";
        int id = 0;
        for (const auto& r : regions) {
            out << "\t\t<!-- region " << r.label << ": PLACEHOLDER material, units MPa and "
                << "t/mm^3 -->\n\t\t<material id=\"" << ++id << "\" name=\"" << r.name
                << "\" type=\"neo-Hookean\">\n\t\t\t<density>" << kPlaceholderDensity
                << "</density>\n\t\t\t<E>" << kPlaceholderE << "</E>\n\t\t\t<v>" << kPlaceholderV
                << "</v>\n\t\t</material>\n";
        }
        out << "\t</Material>\n\t<Mesh>\n\t\t<Nodes name=\"nodes\">\n";
        for (std::size_t v = 0; v < mesh.node_count(); ++v)
            out << "\t\t\t<node id=\"" << v + 1 << "\">" << mesh.xyz[3 * v] << ','
                << mesh.xyz[3 * v + 1] << ',' << mesh.xyz[3 * v + 2] << "</node>\n";
        out << "\t\t</Nodes>\n";
        for (const auto& r : regions) {
            out << "\t\t<Elements type=\"" << element << "\" name=\"" << r.name << "\">\n";
            for (std::int32_t t : r.tets) {
                std::array<std::int32_t, 10> nodes{};
                const int count = tet_nodes(mesh, static_cast<std::size_t>(t), nodes);
                out << "\t\t\t<elem id=\"" << static_cast<std::int64_t>(t) + 1 << "\">";
                for (int i = 0; i < count; ++i)
                    out << (i ? "," : "") << nodes[static_cast<std::size_t>(i)] + 1;
                out << "</elem>\n";
            }
            out << "\t\t</Elements>\n";
        }
        out << "\t\t<ElementSet name=\"all_elements\">1:" << mesh.tet_count() << "</ElementSet>\n";
        // Every part by name, for what FEBio takes as a list of parts (a surface extracted
        // from them, a domain list). FEBio splits the list at commas without trimming: no
        // spaces.
        out << "\t\t<PartList name=\"all_parts\">";
        for (std::size_t r = 0; r < regions.size(); ++r) out << (r ? "," : "") << regions[r].name;
        out << "</PartList>\n";
        // Tags (README "Tag numbers"): a surface's is in a comment before it.
        std::vector<std::int32_t> outer;
        for (const auto& g : surfaces) {
            out << "\t\t<!-- surface " << g.tag << ": labels " << g.lo << " and " << g.hi
                << " -->\n";
            if (g.is_boundary()) {
                write_surface(out, g.name, g.faces, 0);
                outer.insert(outer.end(), g.faces.begin(), g.faces.end());
            } else {
                // A split interface: each side its own faces on its own nodes.
                write_surface(out, side_name(g, g.lo, names), side_faces(mesh, g, g.lo), g.lo);
                write_surface(out, side_name(g, g.hi, names), side_faces(mesh, g, g.hi), g.hi);
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
        // The two sides of each interface (the smaller label's side primary), for a tied or
        // contact interface in a Contact section: <contact type="tied-elastic"
        // surface_pair="interface_X_Y_PAIR">. On an interface split by
        // output.split_interfaces the sides share no node (but where the interface meets
        // an unsplit one), so the pair is what holds them together, or lets them slide.
        for (const auto& g : surfaces) {
            if (g.is_boundary()) continue;
            out << "\t\t<SurfacePair name=\"" << g.name << "_PAIR\">\n\t\t\t<primary>"
                << side_name(g, g.lo, names) << "</primary>\n\t\t\t<secondary>"
                << side_name(g, g.hi, names) << "</secondary>\n\t\t</SurfacePair>\n";
        }
        out << "\t</Mesh>\n\t<MeshDomains>\n";
        for (const auto& r : regions)
            out << "\t\t<SolidDomain name=\"" << r.name << "\" mat=\"" << r.name << "\"/>\n";
        out << "\t</MeshDomains>\n\t<Output>\n\t\t<plotfile type=\"febio\">\n"
               "\t\t\t<var type=\"displacement\"/>\n\t\t\t<var type=\"stress\"/>\n"
               "\t\t</plotfile>\n\t</Output>\n</febio_spec>\n";
        out.close();
    });
}

}  // namespace frontmesh::io::detail
