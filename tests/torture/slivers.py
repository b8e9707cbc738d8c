#!/usr/bin/python3
"""Where do a mesh's smallest dihedral angles come from? (issue 20, item 6)

  slivers.py mesh.vtu [--bound DEG] [--worst N]

Classifies every tet whose smallest dihedral angle is under --bound (default 10 deg) by what
fixes its shape. A wall is a face on its region's boundary (no tet behind it, or one of
another region); a surface node is a node of some wall.
  surface wedge         the two faces at the small angle's edge are both walls: the angle is
                        the surface's own (no volume operation can change it)
  four surface nodes    every node is on the surface (with the number of walls): with three
                        walls the tet is a region's tip of three faces, fixed by the surface
  interior node         the tet has a node inside its region, which refine may still move
Prints the counts per class and the N worst tets with their region and centre (mm). Needs
Debian's /usr/bin/python3 with python3-vtk9 and numpy.
"""
import argparse
import sys

import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy

FACES = np.array([[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]])  # face k is opposite node k
EDGES = [(a, b) for a in range(4) for b in range(a + 1, 4)]


def read(path):
    r = vtk.vtkXMLUnstructuredGridReader()
    r.SetFileName(path)
    r.Update()
    g = r.GetOutput()
    if g.GetNumberOfCells() == 0:
        sys.exit("slivers.py: %s: no cells" % path)
    pts = vtk_to_numpy(g.GetPoints().GetData()).astype(float)
    conn = vtk_to_numpy(g.GetCells().GetConnectivityArray())
    offsets = vtk_to_numpy(g.GetCells().GetOffsetsArray())
    types = vtk_to_numpy(g.GetCellTypesArray())
    if not np.all(types == vtk.VTK_TETRA):
        sys.exit("slivers.py: %s: only linear tets are read" % path)
    tets = conn.reshape(-1, 4) if np.all(np.diff(offsets) == 4) else None
    if tets is None:
        sys.exit("slivers.py: %s: unexpected cell offsets" % path)
    region = g.GetCellData().GetArray("region")
    region = vtk_to_numpy(region) if region is not None else np.zeros(len(tets), int)
    return pts, tets, region


def neighbours(tets):
    """nb[t, k]: the tet behind face k of tet t, or -1."""
    n = len(tets)
    keys = np.sort(tets[:, FACES].reshape(-1, 3), axis=1)  # row 4 t + k
    order = np.lexsort(keys.T[::-1])
    sk = keys[order]
    same = np.all(sk[1:] == sk[:-1], axis=1)
    nb = np.full(4 * n, -1)
    i = np.nonzero(same)[0]
    nb[order[i]] = order[i + 1] // 4
    nb[order[i + 1]] = order[i] // 4
    return nb.reshape(n, 4)


def dihedrals(x):
    """Dihedral angles (deg) at the six edges of tets x (n, 4, 3), in EDGES order."""
    out = []
    for a, b in EDGES:
        c, d = [i for i in range(4) if i not in (a, b)]
        e = x[:, b] - x[:, a]
        e /= np.linalg.norm(e, axis=1)[:, None]
        u = x[:, c] - x[:, a]
        w = x[:, d] - x[:, a]
        u -= (u * e).sum(1)[:, None] * e
        w -= (w * e).sum(1)[:, None] * e
        cos = (u * w).sum(1) / (np.linalg.norm(u, axis=1) * np.linalg.norm(w, axis=1))
        out.append(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))
    return np.stack(out, axis=1)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("mesh")
    ap.add_argument("--bound", type=float, default=10.0)
    ap.add_argument("--worst", type=int, default=15)
    args = ap.parse_args()
    pts, tets, region = read(args.mesh)
    nb = neighbours(tets)
    wall = (nb < 0) | (region[np.maximum(nb, 0)] != region[:, None])
    surface_node = np.zeros(len(pts), bool)
    for k in range(4):
        surface_node[tets[wall[:, k]][:, FACES[k]].ravel()] = True
    angles = dihedrals(pts[tets])
    small = np.nonzero(angles.min(1) < args.bound)[0]
    counts, rows = {}, []
    for t in small:
        e = int(np.argmin(angles[t]))
        a, b = EDGES[e]
        c, d = [i for i in range(4) if i not in (a, b)]
        walls = int(wall[t].sum())
        nodes = int(surface_node[tets[t]].sum())
        if wall[t, c] and wall[t, d]:
            kind = "surface wedge"
        elif nodes == 4:
            kind = "four surface nodes, %d wall(s)" % walls
        else:
            kind = "interior node (%d surface nodes, %d wall(s))" % (nodes, walls)
        counts[kind] = counts.get(kind, 0) + 1
        rows.append((angles[t, e], kind, pts[tets[t]].mean(0), region[t]))
    print("%s: %d tets, %d under %g deg" % (args.mesh, len(tets), len(small), args.bound))
    for kind, n in sorted(counts.items(), key=lambda kv: -kv[1]):
        print("%8d  %s" % (n, kind))
    for angle, kind, c, r in sorted(rows, key=lambda row: row[0])[:args.worst]:
        print("%7.2f deg  region %d at (%.1f, %.1f, %.1f) mm  %s" % (angle, r, *c, kind))


if __name__ == "__main__":
    main()
