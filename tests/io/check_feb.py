#!/usr/bin/python3
"""Structural check of a FEBio 4 model (.feb) as write_mesh writes it.

No FEBio binary is packaged for Debian, so this checks what FEBio 4's reader requires of
the sections frontmesh writes (FEBio 4 User's Manual, "Free format input"):
  - root febio_spec version 4.0; sections Module, Control, Material, Mesh, MeshDomains in
    that order (Output may follow);
  - Module type solid with units; Control: analysis STATIC, time_steps > 0, step_size > 0,
    a solver; every material has an id, a name, a type and numeric parameters;
  - Mesh: node ids 1..n; every Elements part named, tet4 (or, for output.order 2, tet10:
    corners, then the mid nodes of edges 1-2, 2-3, 3-1, 1-4, 2-4, 3-4), its element ids
    unique and its nodes existing; every Surface face (tri3, or tri6 of tet10 parts:
    corners, then edges 1-2, 2-3, 3-1) references existing nodes and is a face of an
    element, oriented out of it, with that element's mid nodes on its edges; NodeSet / ElementSet members exist (lists and a:b ranges);
    every PartList (FEBio 4.3+) is named, unique among part lists and lists existing
    Elements parts, comma-separated without spaces (FEBio does not trim them);
    names of parts, surfaces, sets unique; every SurfacePair names two existing surfaces
    of the same triangles: on the same nodes, or, for an interface split by
    output.split_interfaces (sides on their own nodes), at the same coordinates;
  - MeshDomains: every part has exactly one SolidDomain whose material exists, and every
    domain names an existing part.
Prints one "count NAME N" line per kind (for the caller to compare with the mesh) and
exits 1 with the first problem found.

usage: check_feb.py MESH.feb
"""
import sys
import xml.etree.ElementTree as ET


def fail(message):
    print("FAIL:", message)
    sys.exit(1)


def ids(text, what):
    """Members of a FEBio list: "1,2,5:9" (first:last[:step])."""
    out = []
    for item in (text or "").split(","):
        item = item.strip()
        if not item:
            continue
        parts = [int(p) for p in item.split(":")]
        if len(parts) == 1:
            out.append(parts[0])
        elif len(parts) in (2, 3):
            step = parts[2] if len(parts) == 3 else 1
            if step <= 0 or parts[1] < parts[0]:
                fail(f"{what}: bad range {item}")
            out.extend(range(parts[0], parts[1] + 1, step))
        else:
            fail(f"{what}: bad list item {item}")
    return out


def numbers(text, count, what):
    values = [float(v) for v in (text or "").split(",")]
    if len(values) != count:
        fail(f"{what}: {len(values)} values, expected {count}")
    return values


def main(path):
    root = ET.parse(path).getroot()
    if root.tag != "febio_spec" or root.get("version") != "4.0":
        fail("root is not <febio_spec version=\"4.0\">")
    order = [child.tag for child in root]
    required = ["Module", "Control", "Material", "Mesh", "MeshDomains"]
    if [t for t in order if t in required] != required:
        fail(f"sections {order}, expected {required} in this order")

    module = root.find("Module")
    if module.get("type") != "solid" or not (module.findtext("units") or "").strip():
        fail("Module is not type solid with units")
    control = root.find("Control")
    if (control.findtext("analysis") or "").strip() != "STATIC":
        fail("Control/analysis is not STATIC")
    if int(control.findtext("time_steps") or 0) <= 0:
        fail("Control/time_steps missing or not positive")
    if float(control.findtext("step_size") or 0) <= 0:
        fail("Control/step_size missing or not positive")
    if control.find("solver") is None:
        fail("Control has no solver")

    materials = {}
    for m in root.findall("Material/material"):
        name, mid, mtype = m.get("name"), m.get("id"), m.get("type")
        if not name or not mid or not mtype:
            fail(f"material {name} lacks a name, id or type")
        if name in materials:
            fail(f"material {name} defined twice")
        for p in m:
            float(p.text)
        materials[name] = mid
    if len(set(materials.values())) != len(materials):
        fail("material ids repeat")

    mesh = root.find("Mesh")
    nodes = set()
    xyz = {}
    for nd in mesh.findall("Nodes/node"):
        xyz[int(nd.get("id"))] = tuple(numbers(nd.text, 3, f"node {nd.get('id')}"))
        nodes.add(int(nd.get("id")))
    if nodes != set(range(1, len(nodes) + 1)):
        fail("node ids are not 1..n")
    parts, elements, outward = {}, set(), {}
    cycles = ((1, 2, 3), (0, 3, 2), (0, 1, 3), (0, 2, 1))  # tet4 faces, normals outwards
    # tet10: the mid node of edge (i, j) of the corners (FEBio's and VTK's order).
    tet10_edges = ((0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3))
    mid_of = {}  # sorted corner pair -> mid node (tet10)
    types = set()
    for part in mesh.findall("Elements"):
        name = part.get("name")
        if not name or part.get("type") not in ("tet4", "tet10"):
            fail(f"Elements {name}: needs a name and type tet4 or tet10")
        types.add(part.get("type"))
        per_element = 10 if part.get("type") == "tet10" else 4
        if name in parts:
            fail(f"part {name} defined twice")
        parts[name] = len(part)
        for e in part:
            eid = int(e.get("id"))
            if eid in elements:
                fail(f"element id {eid} repeats")
            elements.add(eid)
            q = [int(v) for v in numbers(e.text, per_element, f"element {eid}")]
            if not set(q) <= nodes:
                fail(f"element {eid} references a missing node")
            if per_element == 10:
                for k, (i, j) in enumerate(tet10_edges):
                    key = (min(q[i], q[j]), max(q[i], q[j]))
                    if mid_of.setdefault(key, q[4 + k]) != q[4 + k]:
                        fail(f"element {eid}: edge {key} has two mid nodes")
            for c in cycles:
                a, b, d = (q[k] for k in c)
                for rot in ((a, b, d), (b, d, a), (d, a, b)):
                    outward[rot] = eid
    names = set(parts)
    surfaces, faces = {}, {}
    for s in mesh.findall("Surface"):
        name = s.get("name")
        if not name or name in names:
            fail(f"surface {name}: no name, or the name is taken")
        names.add(name)
        facet = "tri6" if types == {"tet10"} else "tri3"
        for f in s:
            if f.tag != facet:
                fail(f"surface {name}: face type {f.tag}, expected {facet}")
            six = tuple(int(v) for v in numbers(f.text, 6 if facet == "tri6" else 3,
                                                f"surface {name}"))
            tri = six[:3]
            if not set(six) <= nodes:
                fail(f"surface {name}: face {f.get('id')} references a missing node")
            if tri not in outward:
                fail(f"surface {name}: face {tri} is not an outward element face")
            for k in range(len(six) - 3):
                a, b = tri[k], tri[(k + 1) % 3]
                if mid_of.get((min(a, b), max(a, b))) != six[3 + k]:
                    fail(f"surface {name}: face {six}: node {six[3 + k]} is not the mid node "
                         f"of edge ({a}, {b})")
        surfaces[name] = len(s)
        faces[name] = [tuple(int(v) for v in f.text.split(","))[:3] for f in s]
        if not len(s):
            fail(f"surface {name} is empty")
    for tag, members, what in (("NodeSet", nodes, "node"), ("ElementSet", elements, "element")):
        for s in mesh.findall(tag):
            name = s.get("name")
            if not name or name in names:
                fail(f"{tag} {name}: no name, or the name is taken")
            names.add(name)
            listed = ids(s.text, f"{tag} {name}")
            if not listed or not set(listed) <= members:
                fail(f"{tag} {name}: empty or lists a missing {what}")
            print("count", tag, name, len(listed))
    part_lists = set()
    for pl in mesh.findall("PartList"):
        name = pl.get("name")
        if not name or name in part_lists:
            fail(f"PartList {name}: no name, or the name is taken")
        part_lists.add(name)
        listed = (pl.text or "").split(",")
        if not pl.text or any(p not in parts for p in listed):
            fail(f"PartList {name}: empty or names a missing part ({pl.text!r})")
        print("count PartList", name, len(listed))
    pairs = split = 0
    for p in mesh.findall("SurfacePair"):
        primary, secondary = p.findtext("primary"), p.findtext("secondary")
        if primary not in surfaces or secondary not in surfaces or primary == secondary:
            fail(f"SurfacePair {p.get('name')}: {primary} / {secondary} are not two surfaces")
        pairs += 1
        on_nodes = [sorted(frozenset(f) for f in faces[s]) for s in (primary, secondary)]
        if on_nodes[0] == on_nodes[1]:
            continue
        # A split interface: the same triangles at the same coordinates, on other nodes.
        at = [sorted(tuple(sorted(xyz[v] for v in f)) for f in faces[s])
              for s in (primary, secondary)]
        if at[0] != at[1]:
            fail(f"SurfacePair {p.get('name')}: {primary} and {secondary} are not the same "
                 "triangles")
        split += 1

    domains = {}
    for d in root.findall("MeshDomains/*"):
        if d.tag != "SolidDomain":
            fail(f"domain {d.get('name')}: {d.tag}, expected SolidDomain")
        name, mat = d.get("name"), d.get("mat")
        if name not in parts:
            fail(f"SolidDomain {name} names no part")
        if name in domains:
            fail(f"part {name} has two domains")
        if mat not in materials:
            fail(f"SolidDomain {name}: material {mat} does not exist")
        domains[name] = mat
    for name in parts:
        if name not in domains:
            fail(f"part {name} has no SolidDomain")

    print("count nodes", len(nodes))
    print("count elements", len(elements))
    for name, n in sorted(parts.items()):
        print("count part", name, n)
    for name, n in sorted(surfaces.items()):
        print("count surface", name, n)
    print("count pairs", pairs)
    print("split pairs", split)
    print("OK")


if __name__ == "__main__":
    main(sys.argv[1])
