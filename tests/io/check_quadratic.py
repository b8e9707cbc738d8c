#!/usr/bin/python3
"""Reads quadratic-tet exports (output.order 2) back and checks the elements.

For each file: .vtu, .msh (MSH 4.1 or 2.2) and .inp through meshio (its readers put every
format's tet10 in VTK's node order: Gmsh's swap of the last two mid nodes undone), .feb
parsed directly (meshio has no FEBio reader; tet10 in FEBio's order, which is VTK's). Then,
per quadratic tet, the 20 Bernstein coefficients of its Jacobian determinant (a cubic):
every one must be positive (det J >= the smallest coefficient everywhere, so no element is
inverted anywhere), and the element's volume (1/6 of their mean, the cubic Bernstein
polynomials having equal integrals) must be positive. The total volume per file is printed
so the caller can compare formats; every mid node must lie near its edge (within half the
edge length), which a wrong node order would break. With the gmsh binary on the PATH, each
.msh is also read by gmsh itself, whose Jacobian analysis (Plugin AnalyseMeshQuality) must
find every element's minJ/maxJ positive.

Prints "FILE tets N volume V min_scaled_jacobian J" per file and "OK"; exits 1 with the
first problem.

usage: check_quadratic.py FILE...
"""
import os
import re
import shutil
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET

import numpy as np

EDGES = ((0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3))  # VTK order of nodes 4..9


def fail(message):
    print("FAIL:", message)
    sys.exit(1)


def read(path):
    """Points (n x 3) and tet10 connectivity (m x 10, VTK order, 0-based)."""
    if path.endswith(".feb"):
        root = ET.parse(path).getroot()
        ids, xyz = [], []
        for nd in root.findall("Mesh/Nodes/node"):
            ids.append(int(nd.get("id")))
            xyz.append([float(v) for v in nd.text.split(",")])
        index = {v: i for i, v in enumerate(ids)}
        cells = []
        for part in root.findall("Mesh/Elements"):
            if part.get("type") != "tet10":
                fail(f"{path}: part {part.get('name')} is {part.get('type')}, not tet10")
            for e in part:
                cells.append([index[int(v)] for v in e.text.split(",")])
        return np.array(xyz), np.array(cells, dtype=np.int64)
    import meshio
    mesh = meshio.read(path)
    blocks = [c.data for c in mesh.cells if c.type == "tetra10"]
    if not blocks or any(c.type == "tetra" for c in mesh.cells):
        fail(f"{path}: no tetra10 cells, or linear tetra among them")
    return np.asarray(mesh.points, dtype=float), np.concatenate(blocks).astype(np.int64)


def bernstein(points, cells):
    """The 20 Bernstein coefficients of det J per element (m x 20) and det J straight (m)."""
    x = points[cells]  # m x 10 x 3
    P = np.empty((len(cells), 4, 4, 3))
    for i in range(4):
        P[:, i, i] = x[:, i]
    for k, (i, j) in enumerate(EDGES):
        P[:, i, j] = P[:, j, i] = 2.0 * x[:, 4 + k] - 0.5 * (x[:, i] + x[:, j])
    D = 2.0 * (P[:, 1:, :, :] - P[:, 0:1, :, :])  # D[:, k-1, j] = 2 (P_kj - P_0j)
    coeff = {}
    for a in range(4):
        for b in range(4):
            for c in range(4):
                det = np.einsum("ij,ij->i", D[:, 0, a], np.cross(D[:, 1, b], D[:, 2, c]))
                alpha = tuple(sorted((a, b, c)))
                coeff.setdefault(alpha, []).append(det)
    table = np.stack([np.mean(v, axis=0) for v in coeff.values()], axis=1)
    straight = np.einsum("ij,ij->i", x[:, 1] - x[:, 0],
                         np.cross(x[:, 2] - x[:, 0], x[:, 3] - x[:, 0]))
    return table, straight


def gmsh_worst_jacobian_ratio(path):
    """gmsh's own reading of a .msh: the worst minJ/maxJ of its 3-D elements (Plugin
    AnalyseMeshQuality, Jacobian determinant over each element, tet10 in Gmsh's order)."""
    with tempfile.TemporaryDirectory() as tmp:
        script = os.path.join(tmp, "quality.geo")
        with open(script, "w") as f:
            f.write(f'Merge "{os.path.abspath(path)}";\n'
                    "Plugin(AnalyseMeshQuality).JacobianDeterminant = 1;\n"
                    "Plugin(AnalyseMeshQuality).IGEMeasure = 0;\n"
                    "Plugin(AnalyseMeshQuality).ICNMeasure = 0;\n"
                    "Plugin(AnalyseMeshQuality).DimensionOfElements = 3;\n"
                    "Plugin(AnalyseMeshQuality).Run;\n")
        r = subprocess.run(["gmsh", script, "-0", "-nopopup"], capture_output=True, text=True,
                           timeout=600)
    text = r.stdout + r.stderr
    if r.returncode != 0 or "Error" in text:
        fail(f"{path}: gmsh: {text[-500:]}")
    m = re.search(r"minJ/maxJ\s*=\s*([-0-9.eE+]+),\s*[-0-9.eE+]+,\s*[-0-9.eE+]+\s*\(worst", text)
    if not m:
        fail(f"{path}: gmsh printed no Jacobian figures: {text[-500:]}")
    return float(m.group(1))


def main(files):
    for path in files:
        points, cells = read(path)
        if cells.shape[1] != 10:
            fail(f"{path}: {cells.shape[1]} nodes per element")
        x = points[cells]
        for k, (i, j) in enumerate(EDGES):
            length = np.linalg.norm(x[:, j] - x[:, i], axis=1)
            off = np.linalg.norm(x[:, 4 + k] - 0.5 * (x[:, i] + x[:, j]), axis=1)
            if np.any(off > 0.5 * length):
                t = int(np.argmax(off / length))
                fail(f"{path}: element {t}: node {5 + k} is not near edge {i + 1}-{j + 1} "
                     "(wrong node order?)")
        table, straight = bernstein(points, cells)
        if np.any(straight <= 0):
            fail(f"{path}: {int(np.sum(straight <= 0))} elements with non-positive corners")
        low = table.min(axis=1)
        if np.any(low <= 0):
            t = int(np.argmin(low))
            fail(f"{path}: element {t}: Jacobian not positive everywhere "
                 f"(Bernstein bound {low[t]:.3g})")
        volume = table.mean(axis=1) / 6.0
        if np.any(volume <= 0):
            fail(f"{path}: an element has non-positive volume")
        print(path, "tets", len(cells), "volume", f"{volume.sum():.9g}",
              "min_scaled_jacobian", f"{(low / straight).min():.4f}")
        if path.endswith(".msh") and shutil.which("gmsh"):
            worst = gmsh_worst_jacobian_ratio(path)
            if not worst > 0:
                fail(f"{path}: gmsh finds an element with minJ/maxJ {worst}")
            print(path, "gmsh minJ/maxJ", f"{worst:.4f}")
    print("OK")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        fail("usage: check_quadratic.py FILE...")
    main(sys.argv[1:])
