#!/usr/bin/python3
"""Check every region of a frontmesh surface checkpoint with the outside referee.

Usage: meshcheck_regions.py CHECKPOINT.vtu OUTDIR [MESHCHECK]

A surface network is non-manifold where regions meet, so meshcheck.py cannot judge it
whole. This writes each region's boundary (faces with region_in == r as they are, faces
with region_out == r reversed) to OUTDIR/region<r>.vtp and runs meshcheck.py on it: each
must be a closed, oriented 2-manifold. Exit code 0 when every region is valid, 1 if not.
"""
import os
import subprocess
import sys

import numpy as np
import vtk
from vtk.util import numpy_support as ns


def main():
    if len(sys.argv) < 3:
        print(__doc__, file=sys.stderr)
        return 2
    checkpoint, outdir = sys.argv[1], sys.argv[2]
    here = os.path.dirname(os.path.abspath(__file__))
    meshcheck = sys.argv[3] if len(sys.argv) > 3 else os.path.join(here, "..", "..", "shared", "tools", "meshcheck.py")
    reader = vtk.vtkXMLUnstructuredGridReader()
    reader.SetFileName(checkpoint)
    reader.Update()
    grid = reader.GetOutput()
    points = ns.vtk_to_numpy(grid.GetPoints().GetData())
    faces = ns.vtk_to_numpy(grid.GetCells().GetConnectivityArray()).reshape(-1, 3)
    region_in = ns.vtk_to_numpy(grid.GetCellData().GetArray("region_in"))
    region_out = ns.vtk_to_numpy(grid.GetCellData().GetArray("region_out"))
    os.makedirs(outdir, exist_ok=True)
    regions = sorted(set(region_in.tolist()) | (set(region_out.tolist()) - {0}))
    invalid = []
    for region in regions:
        tris = np.vstack([faces[region_in == region], faces[region_out == region][:, ::-1]])
        used, local = np.unique(tris, return_inverse=True)
        poly = vtk.vtkPolyData()
        pts = vtk.vtkPoints()
        pts.SetData(ns.numpy_to_vtk(points[used].copy(), deep=True))
        poly.SetPoints(pts)
        cells = vtk.vtkCellArray()
        cells.SetData(3, ns.numpy_to_vtkIdTypeArray(local.reshape(-1).astype(np.int64), deep=True))
        poly.SetPolys(cells)
        path = os.path.join(outdir, "region%d.vtp" % region)
        writer = vtk.vtkXMLPolyDataWriter()
        writer.SetFileName(path)
        writer.SetInputData(poly)
        writer.Write()
        result = subprocess.run(["/usr/bin/python3", meshcheck, path], capture_output=True, text=True)
        if result.returncode != 0:
            invalid.append(region)
            print("region %d: INVALID\n%s" % (region, result.stdout.strip()))
    print("%d regions checked with meshcheck.py, %d invalid" % (len(regions), len(invalid)))
    return 1 if invalid else 0


if __name__ == "__main__":
    sys.exit(main())
