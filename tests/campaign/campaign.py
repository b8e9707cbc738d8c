#!/usr/bin/python3
"""Malformed-input and fault campaign for the frontmesh command line.

  campaign.py [--seed N] [--scale F] [--classes a,b] [--only ID[,ID]] [-j 1|2]
              [--out /tmp/campaign] [--findings /tmp/campaign-findings] [--json FILE]
              [--frontmesh BIN] [--timeout 120] [--kills N] [--keep]

Every case is generated from (seed, class, number) alone, so `--seed S --only ID` makes
and runs the same case again. Each case gets its own folder below OUT/cases/ID, runs one
frontmesh command there (at most 2 at once), and is checked against what README.md promises:

  all cases  no signal (negative return code), no time-out, never exit 1 (internal error;
             `check` may exit 1 for a readable invalid mesh, `cohort` for a failed subject)
  invalid    exit 2; stderr's last non-empty line is one line starting 'frontmesh:' that
             names a file, key, voxel, line, option or position; no other error lines;
             the output folder not created, or unchanged (names, sizes, mtimes)
  valid      exit 0 and mesh.vtu accepted by ../shared/tools/meshcheck.py; an exit 2 with a
             clean one-line reason is a 'refused' note, not a failure
  any        (mutations whose verdict README does not fix) exit 0 with a valid mesh, or
             exit 2 under the 'invalid' rules
  after each completed run: nothing in the case folder outside the output folder changed
  (snapshot before/after) nor the campaign's shared inputs; no .NAME.tmp-* files in the
  output folder.
The 'kill' class runs a small recipe, SIGKILLs it at uniformly random moments of an
uninterrupted run's duration, re-runs to completion and compares mesh.vtu and the exports
byte for byte with the uninterrupted run, the summary's outputs with the files, and
looks for temporary files.

One line per failure: 'FAIL ID [class] violation | reproduce: cd DIR && COMMAND'; the
inputs of failing cases are copied to FINDINGS/ID/. Then counts per class and, with
--json, everything as JSON. Exit 0 when nothing failed.
"""
import argparse
import concurrent.futures
import errno
import gzip
import hashlib
import json
import math
import os
import random
import re
import shlex
import shutil
import signal
import stat
import struct
import subprocess
import sys
import threading
import time
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
DEFAULT_FM = os.path.join(REPO, "build", "pipeline", "frontmesh")
MESHCHECK = os.path.normpath(os.path.join(REPO, "..", "shared", "tools", "meshcheck.py"))
PY = "/usr/bin/python3"

# ------------------------------------------------------------------------------ label images


def ball_volume(n, centres, rng=None):
    """Label volume (x fastest) of size n=(nx,ny,nz): centres is [(cx,cy,cz,r,label)],
    later balls overwrite earlier ones."""
    nx, ny, nz = n
    vol = [0] * (nx * ny * nz)
    for (cx, cy, cz, r, lab) in centres:
        r2 = r * r
        for k in range(max(0, int(cz - r - 1)), min(nz, int(cz + r + 2))):
            for j in range(max(0, int(cy - r - 1)), min(ny, int(cy + r + 2))):
                base = (k * ny + j) * nx
                for i in range(max(0, int(cx - r - 1)), min(nx, int(cx + r + 2))):
                    if (i - cx) ** 2 + (j - cy) ** 2 + (k - cz) ** 2 <= r2:
                        vol[base + i] = lab
    return vol


def shape_volume(kind, n, rng):
    nx, ny, nz = n
    c = ((nx - 1) / 2.0, (ny - 1) / 2.0, (nz - 1) / 2.0)
    rmax = min(n) / 2.0 - 1.5
    if kind == "ball":
        return ball_volume(n, [(c[0], c[1], c[2], max(1.5, rmax), 1)])
    if kind == "two":  # a ball split in two labels
        v = ball_volume(n, [(c[0], c[1], c[2], max(2.0, rmax), 1)])
        for idx in range(len(v)):
            if v[idx] and idx % nx > c[0]:
                v[idx] = 2
        return v
    if kind == "nested":
        return ball_volume(n, [(c[0], c[1], c[2], max(2.5, rmax), 1),
                               (c[0], c[1], c[2], max(1.2, rmax / 2.0), 2)])
    if kind == "border":  # a box touching three faces of the image
        v = [0] * (nx * ny * nz)
        for k in range(nz * 2 // 3):
            for j in range(ny * 2 // 3):
                for i in range(nx * 2 // 3):
                    v[(k * ny + j) * nx + i] = 1
        return v
    if kind == "full":  # every voxel labelled
        return [1] * (nx * ny * nz)
    if kind == "blobs":
        balls = []
        for lab in range(1, rng.randint(2, 3) + 1):
            r = rng.uniform(2.0, max(2.2, rmax * 0.8))
            balls.append((rng.uniform(r, nx - 1 - r), rng.uniform(r, ny - 1 - r),
                          rng.uniform(r, nz - 1 - r), r, lab))
        return ball_volume(n, balls)
    raise ValueError(kind)


# NIfTI datatype: (code, struct letter, bytes)
NIFTI_TYPES = {
    "u1": (2, "B", 1), "i2": (4, "h", 2), "i4": (8, "i", 4), "f4": (16, "f", 4),
    "f8": (64, "d", 8), "i1": (256, "b", 1), "u2": (512, "H", 2), "u4": (768, "I", 4),
    "i8": (1024, "q", 8), "u8": (1280, "Q", 8),
}


def pack_voxels(vals, dtype, big=False):
    letter = NIFTI_TYPES[dtype][1]
    return struct.pack(("<" if not big else ">") + str(len(vals)) + letter, *vals)


NIFTI1_FIELDS = [  # name, offset, struct letter, count
    ("sizeof_hdr", 0, "i", 1), ("dim_info", 39, "B", 1), ("dim", 40, "h", 8),
    ("intent_p1", 56, "f", 1), ("intent_code", 68, "h", 1), ("datatype", 70, "h", 1),
    ("bitpix", 72, "h", 1), ("slice_start", 74, "h", 1), ("pixdim", 76, "f", 8),
    ("vox_offset", 108, "f", 1), ("scl_slope", 112, "f", 1), ("scl_inter", 116, "f", 1),
    ("slice_end", 120, "h", 1), ("xyzt_units", 123, "B", 1), ("cal_max", 124, "f", 1),
    ("cal_min", 128, "f", 1), ("qform_code", 252, "h", 1), ("sform_code", 254, "h", 1),
    ("quatern", 256, "f", 6), ("srow", 280, "f", 12), ("magic", 344, "4s", 1),
    ("extension", 348, "4B", 1),
]
NIFTI2_FIELDS = [
    ("sizeof_hdr", 0, "i", 1), ("magic", 4, "8s", 1), ("datatype", 12, "h", 1),
    ("bitpix", 14, "h", 1), ("dim", 16, "q", 8), ("intent_p1", 80, "d", 1),
    ("pixdim", 104, "d", 8), ("vox_offset", 168, "q", 1), ("scl_slope", 176, "d", 1),
    ("scl_inter", 184, "d", 1), ("cal_max", 192, "d", 1), ("cal_min", 200, "d", 1),
    ("qform_code", 344, "i", 1), ("sform_code", 348, "i", 1), ("quatern", 352, "d", 6),
    ("srow", 400, "d", 12), ("xyzt_units", 500, "i", 1), ("intent_code", 504, "i", 1),
    ("dim_info", 524, "B", 1), ("extension", 540, "4B", 1),
]


def nifti_header(version, n, dtype, spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0)):
    code, _, nbytes = NIFTI_TYPES[dtype]
    h = {
        "sizeof_hdr": 348 if version == 1 else 540,
        "dim": [3, n[0], n[1], n[2], 1, 1, 1, 1],
        "datatype": code, "bitpix": 8 * nbytes,
        "pixdim": [1.0, spacing[0], spacing[1], spacing[2], 1.0, 1.0, 1.0, 1.0],
        "vox_offset": 352 if version == 1 else 544,
        "scl_slope": 1.0, "scl_inter": 0.0, "xyzt_units": 2,
        "qform_code": 1, "sform_code": 1,
        "quatern": [0.0, 0.0, 0.0, origin[0], origin[1], origin[2]],
        "srow": [spacing[0], 0, 0, origin[0], 0, spacing[1], 0, origin[1], 0, 0, spacing[2],
                 origin[2]],
        "magic": b"n+1\0" if version == 1 else b"n+2\0\r\n\x1a\n",
        "extension": [0, 0, 0, 0],
    }
    return h


def nifti_bytes(h, version, big=False):
    size = 348 if version == 1 else 540
    buf = bytearray(size + 4)
    e = ">" if big else "<"
    for name, off, letter, count in (NIFTI1_FIELDS if version == 1 else NIFTI2_FIELDS):
        if name not in h:
            continue
        v = h[name]
        if letter.endswith("s"):
            struct.pack_into(letter, buf, off, v)
        elif letter == "4B":
            struct.pack_into("4B", buf, off, *v)
        elif count == 1:
            struct.pack_into(e + letter, buf, off, v)
        else:
            struct.pack_into(e + str(count) + letter, buf, off, *v)
    return bytes(buf)


def write_nifti(path, vol, n, dtype="u1", version=1, spacing=(1, 1, 1), origin=(0, 0, 0),
                mutate=None, big=False, scale=None):
    """Writes .nii / .nii.gz / .hdr+.img; `mutate(h)` edits the header dict first."""
    h = nifti_header(version, n, dtype, spacing, origin)
    if mutate:
        mutate(h)
    vals = vol if scale is None else [scale(v) for v in vol]
    data = pack_voxels(vals, dtype, big)
    hdr = nifti_bytes(h, version, big)
    if path.endswith(".hdr"):
        h2 = dict(h)
        h2["magic"] = b"ni1\0" if version == 1 else b"ni2\0\r\n\x1a\n"
        h2["vox_offset"] = 0
        if mutate:
            mutate(h2)
        with open(path, "wb") as f:
            f.write(nifti_bytes(h2, version, big))
        with open(path[:-4] + ".img", "wb") as f:
            f.write(data)
        return
    pad = int(h["vox_offset"]) - len(hdr) if isinstance(h["vox_offset"], (int, float)) and \
        math.isfinite(h["vox_offset"]) and 0 <= h["vox_offset"] < 1e6 else 0
    blob = hdr + b"\0" * max(0, pad) + data
    if path.endswith(".gz"):
        with open(path, "wb") as f:
            f.write(gzip.compress(blob, mtime=0))
    else:
        with open(path, "wb") as f:
            f.write(blob)


MET_TYPES = {"u1": "MET_UCHAR", "i2": "MET_SHORT", "u2": "MET_USHORT", "i4": "MET_INT",
             "u4": "MET_UINT", "f4": "MET_FLOAT", "f8": "MET_DOUBLE", "i1": "MET_CHAR",
             "i8": "MET_LONG_LONG", "u8": "MET_ULONG_LONG"}


def meta_lines(n, dtype="u1", spacing=(1, 1, 1), origin=(0, 0, 0), local=True, compressed=False):
    lines = [["ObjectType", "Image"], ["NDims", "3"], ["BinaryData", "True"],
             ["BinaryDataByteOrderMSB", "False"], ["CompressedData",
                                                   "True" if compressed else "False"],
             ["TransformMatrix", "1 0 0 0 1 0 0 0 1"],
             ["Offset", " ".join(repr(float(o)) for o in origin)],
             ["CenterOfRotation", "0 0 0"], ["AnatomicalOrientation", "RAI"],
             ["ElementSpacing", " ".join(repr(float(s)) for s in spacing)],
             ["DimSize", " ".join(str(x) for x in n)], ["ElementType", MET_TYPES[dtype]],
             ["ElementDataFile", "LOCAL" if local else "data.raw"]]
    return lines


def write_meta(path, lines, data, sep=" = ", eol="\n", raw_name=None):
    text = "".join(k + sep + v + eol if v is not None else k + eol for k, v in lines)
    if raw_name is None:
        with open(path, "wb") as f:
            f.write(text.encode("latin-1", "replace") + data)
    else:
        with open(path, "wb") as f:
            f.write(text.encode("latin-1", "replace"))
        with open(os.path.join(os.path.dirname(path), raw_name), "wb") as f:
            f.write(data)


NRRD_TYPES = {"u1": "uchar", "i2": "short", "u2": "ushort", "i4": "int", "u4": "uint",
              "f4": "float", "f8": "double", "i1": "signed char", "i8": "longlong",
              "u8": "ulonglong"}


def nrrd_fields(n, dtype="u1", spacing=(1, 1, 1), origin=(0, 0, 0), encoding="raw"):
    s = spacing
    return [["type", NRRD_TYPES[dtype]], ["dimension", "3"],
            ["space", "left-posterior-superior"], ["sizes", " ".join(str(x) for x in n)],
            ["space directions", "(%r,0,0) (0,%r,0) (0,0,%r)" % (float(s[0]), float(s[1]),
                                                                  float(s[2]))],
            ["kinds", "domain domain domain"], ["endian", "little"], ["encoding", encoding],
            ["space origin", "(%r,%r,%r)" % tuple(float(o) for o in origin)]]


def write_nrrd(path, fields, data, magic="NRRD0004", detached=None, sep=": "):
    text = magic + "\n" + "".join(k + sep + v + "\n" if v is not None else k + "\n"
                                  for k, v in fields)
    if detached:
        with open(path, "wb") as f:
            f.write(text.encode("latin-1", "replace"))
        with open(os.path.join(os.path.dirname(path), detached), "wb") as f:
            f.write(data)
    else:
        with open(path, "wb") as f:
            f.write(text.encode("latin-1", "replace") + b"\n" + data)


# ------------------------------------------------------------------------------ surfaces


def icosphere(level=1, r=5.0, c=(0.0, 0.0, 0.0)):
    t = (1.0 + 5 ** 0.5) / 2.0
    pts = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t),
           (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
             (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
             (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    pts = [tuple(x / math.sqrt(sum(y * y for y in p)) for x in p) for p in pts]
    for _ in range(level):
        cache = {}
        nf = []

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in cache:
                p = [(pts[a][i] + pts[b][i]) / 2 for i in range(3)]
                L = math.sqrt(sum(x * x for x in p))
                pts.append(tuple(x / L for x in p))
                cache[key] = len(pts) - 1
            return cache[key]
        for a, b, cc in faces:
            ab, bc, ca = mid(a, b), mid(b, cc), mid(cc, a)
            nf += [(a, ab, ca), (b, bc, ab), (cc, ca, bc), (ab, bc, ca)]
        faces = nf
    pts = [(c[0] + r * p[0], c[1] + r * p[1], c[2] + r * p[2]) for p in pts]
    return [list(p) for p in pts], [list(f) for f in faces]


def fmt(x):
    if isinstance(x, float):
        if math.isnan(x):
            return "nan"
        if math.isinf(x):
            return "inf" if x > 0 else "-inf"
        return repr(x)
    return str(x)


def stl_ascii(pts, faces):
    out = ["solid campaign"]
    for f in faces:
        out.append(" facet normal 0 0 0\n  outer loop")
        for v in f:
            p = pts[v] if 0 <= v < len(pts) else (0.0, 0.0, 0.0)
            out.append("   vertex %s %s %s" % tuple(fmt(float(x)) for x in p))
        out.append("  endloop\n endfacet")
    out.append("endsolid campaign\n")
    return "\n".join(out).encode()


def stl_binary(pts, faces, count=None, header=b"campaign"):
    b = bytearray(header.ljust(80, b"\0")[:80])
    b += struct.pack("<I", len(faces) if count is None else count)
    for f in faces:
        b += struct.pack("<3f", 0, 0, 0)
        for v in f:
            p = pts[v] if 0 <= v < len(pts) else (0.0, 0.0, 0.0)
            b += struct.pack("<3f", *p)
        b += b"\0\0"
    return bytes(b)


def off_text(pts, faces, nv=None, nf=None):
    out = ["OFF", "%d %d 0" % (len(pts) if nv is None else nv, len(faces) if nf is None else nf)]
    out += ["%s %s %s" % tuple(fmt(x) for x in p) for p in pts]
    out += [" ".join([str(len(f))] + [str(v) for v in f]) for f in faces]
    return ("\n".join(out) + "\n").encode()


def ply_text(pts, faces, binary=False, nv=None, nf=None, index_type="int"):
    head = ["ply", "format %s 1.0" % ("binary_little_endian" if binary else "ascii"),
            "element vertex %d" % (len(pts) if nv is None else nv),
            "property float x", "property float y", "property float z",
            "element face %d" % (len(faces) if nf is None else nf),
            "property list uchar %s vertex_indices" % index_type, "end_header"]
    h = ("\n".join(head) + "\n").encode()
    if not binary:
        body = ["%s %s %s" % tuple(fmt(float(x)) for x in p) for p in pts]
        body += [" ".join([str(len(f))] + [str(v) for v in f]) for f in faces]
        return h + ("\n".join(body) + "\n").encode()
    b = bytearray(h)
    for p in pts:
        b += struct.pack("<3f", *p)
    letter = {"int": "i", "uint": "I", "short": "h", "uchar": "B", "int32": "i"}[index_type]
    bits = {"I": 32, "B": 8}.get(letter)
    for f in faces:
        # an unsigned index type writes a negative index as its two's complement (huge)
        f = [v % (1 << bits) for v in f] if bits else f
        b += struct.pack("<B", len(f)) + struct.pack("<%d%s" % (len(f), letter), *f)
    return bytes(b)


def vtk_xml(kind, pts, faces, cell_arrays=None, point_arrays=None, npts=None, ncells=None,
            conn_type="Int64", cell_type=5):
    """Hand-written ascii VTK XML PolyData (.vtp) or UnstructuredGrid (.vtu) of triangles or
    tets (cell_type 10)."""
    npts = len(pts) if npts is None else npts
    ncells = len(faces) if ncells is None else ncells
    conn = " ".join(str(v) for f in faces for v in f)
    offs, o = [], 0
    for f in faces:
        o += len(f)
        offs.append(str(o))
    ptxt = " ".join(fmt(float(x)) for p in pts for x in p)
    cd = ""
    if cell_arrays:
        cd = "<CellData>" + "".join(
            '<DataArray type="%s" Name="%s" format="ascii">%s</DataArray>' %
            (t, name, " ".join(str(v) for v in vals)) for name, t, vals in cell_arrays) + \
            "</CellData>"
    pd = ""
    if point_arrays:
        pd = "<PointData>" + "".join(
            '<DataArray type="%s" Name="%s" format="ascii">%s</DataArray>' %
            (t, name, " ".join(str(v) for v in vals)) for name, t, vals in point_arrays) + \
            "</PointData>"
    if kind == "vtp":
        return ('<?xml version="1.0"?>\n<VTKFile type="PolyData" version="0.1" '
                'byte_order="LittleEndian">\n<PolyData>\n<Piece NumberOfPoints="%d" '
                'NumberOfVerts="0" NumberOfLines="0" NumberOfStrips="0" NumberOfPolys="%d">\n'
                '%s%s<Points><DataArray type="Float64" NumberOfComponents="3" format="ascii">'
                '%s</DataArray></Points>\n<Polys><DataArray type="%s" Name="connectivity" '
                'format="ascii">%s</DataArray><DataArray type="%s" Name="offsets" '
                'format="ascii">%s</DataArray></Polys>\n</Piece>\n</PolyData>\n</VTKFile>\n'
                % (npts, ncells, pd, cd, ptxt, conn_type, conn, conn_type, " ".join(offs))
                ).encode()
    types = " ".join(str(cell_type) for _ in faces)
    return ('<?xml version="1.0"?>\n<VTKFile type="UnstructuredGrid" version="0.1" '
            'byte_order="LittleEndian">\n<UnstructuredGrid>\n<Piece NumberOfPoints="%d" '
            'NumberOfCells="%d">\n%s%s<Points><DataArray type="Float64" '
            'NumberOfComponents="3" format="ascii">%s</DataArray></Points>\n<Cells>'
            '<DataArray type="%s" Name="connectivity" format="ascii">%s</DataArray>'
            '<DataArray type="%s" Name="offsets" format="ascii">%s</DataArray>'
            '<DataArray type="UInt8" Name="types" format="ascii">%s</DataArray></Cells>\n'
            '</Piece>\n</UnstructuredGrid>\n</VTKFile>\n'
            % (npts, ncells, pd, cd, ptxt, conn_type, conn, conn_type, " ".join(offs), types)
            ).encode()


def write_surface(path, pts, faces, regions=None):
    ext = path.rsplit(".", 1)[-1]
    if ext == "stl":
        data = stl_ascii(pts, faces)
    elif ext == "off":
        data = off_text(pts, faces)
    elif ext == "ply":
        data = ply_text(pts, faces)
    else:
        arrays = None
        if regions:
            arrays = [("region_in", "Int32", regions[0]), ("region_out", "Int32", regions[1])]
        data = vtk_xml(ext, pts, faces, arrays)
    with open(path, "wb") as f:
        f.write(data)


# ------------------------------------------------------------------------------ tet meshes


def cube_tets(m=2, h=1.0):
    """A cube of m^3 cells, each split into 6 tets (Kuhn), conforming, positive in VTK order."""
    idx = lambda i, j, k: (k * (m + 1) + j) * (m + 1) + i  # noqa: E731
    pts = [[i * h, j * h, k * h] for k in range(m + 1) for j in range(m + 1) for i in range(m + 1)]
    tets = []
    perms = [(0, 1, 2), (0, 2, 1), (1, 0, 2), (1, 2, 0), (2, 0, 1), (2, 1, 0)]
    for k in range(m):
        for j in range(m):
            for i in range(m):
                for p in perms:
                    c = [i, j, k]
                    path = [tuple(c)]
                    for ax in p:
                        c[ax] += 1
                        path.append(tuple(c))
                    t = [idx(*q) for q in path]
                    a, b, cc, d = (pts[v] for v in t)
                    det = _det3([b[x] - a[x] for x in range(3)], [cc[x] - a[x] for x in range(3)],
                                [d[x] - a[x] for x in range(3)])
                    if det < 0:
                        t[2], t[3] = t[3], t[2]
                    tets.append(t)
    regions = [1 if (sum(pts[v][0] for v in t) / 4.0) < m * h / 2.0 else 2 for t in tets]
    return pts, tets, regions


def _det3(a, b, c):
    return (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
            a[2] * (b[0] * c[1] - b[1] * c[0]))


def msh22(pts, tets, regions, nn=None, ne=None):
    out = ["$MeshFormat", "2.2 0 8", "$EndMeshFormat", "$Nodes", str(len(pts) if nn is None
                                                                      else nn)]
    out += ["%d %s %s %s" % ((i + 1,) + tuple(fmt(x) for x in p)) for i, p in enumerate(pts)]
    out += ["$EndNodes", "$Elements", str(len(tets) if ne is None else ne)]
    out += ["%d 4 2 %d %d %s" % (i + 1, r, r, " ".join(str(v + 1) for v in t))
            for i, (t, r) in enumerate(zip(tets, regions))]
    out += ["$EndElements"]
    return ("\n".join(out) + "\n").encode()


def msh41(pts, tets, regions):
    labs = sorted(set(regions)) or [1]  # no tets: one empty entity
    out = ["$MeshFormat", "4.1 0 8", "$EndMeshFormat", "$Entities", "0 0 0 %d" % len(labs)]
    out += ["%d 0 0 0 1 1 1 1 %d 0" % (r, r) for r in labs]
    out += ["$EndEntities", "$Nodes", "1 %d 1 %d" % (len(pts), len(pts)),
            "3 %d 0 %d" % (labs[0], len(pts))]
    out += [str(i + 1) for i in range(len(pts))]
    out += ["%s %s %s" % tuple(fmt(x) for x in p) for p in pts]
    out += ["$EndNodes", "$Elements", "%d %d 1 %d" % (len(labs), len(tets), len(tets))]
    e = 1
    for r in labs:
        mine = [t for t, rr in zip(tets, regions) if rr == r]
        out.append("3 %d 4 %d" % (r, len(mine)))
        for t in mine:
            out.append("%d %s" % (e, " ".join(str(v + 1) for v in t)))
            e += 1
    out += ["$EndElements"]
    return ("\n".join(out) + "\n").encode()


def medit(pts, tets, regions, nv=None, nt=None):
    out = ["MeshVersionFormatted 2", "Dimension 3", "Vertices", str(len(pts) if nv is None
                                                                     else nv)]
    out += ["%s %s %s 0" % tuple(fmt(x) for x in p) for p in pts]
    out += ["Tetrahedra", str(len(tets) if nt is None else nt)]
    out += ["%s %d" % (" ".join(str(v + 1) for v in t), r) for t, r in zip(tets, regions)]
    out += ["End"]
    return ("\n".join(out) + "\n").encode()


def abaqus(pts, tets, regions):
    out = ["*NODE"]
    out += ["%d, %s, %s, %s" % ((i + 1,) + tuple(fmt(x) for x in p)) for i, p in enumerate(pts)]
    for r in sorted(set(regions)):
        out.append("*ELEMENT, TYPE=C3D4, ELSET=region_%d" % r)
        for i, (t, rr) in enumerate(zip(tets, regions)):
            if rr == r:
                out.append("%d, %s" % (i + 1, ", ".join(str(v + 1) for v in t)))
    return ("\n".join(out) + "\n").encode()


# ------------------------------------------------------------------------------ the runner


class Spec:
    """What one case runs and expects.
    expect: 'invalid' | 'valid' | 'any' | 'check' | 'convert' | 'cohort' | 'info'
    out: the output folder the command may write (absolute), or None (writes nothing)."""

    def __init__(self, argv, expect, out=None, desc="", inputs=None, cwd=None, mesh=True,
                 extra=None, allow_refusal=True, watch=None):
        self.argv = argv
        self.expect = expect
        self.out = out
        self.desc = desc
        self.inputs = inputs or []     # files / folders to keep as the finding's input
        self.cwd = cwd
        self.mesh = mesh               # a valid run writes mesh.vtu (False: --until a surface)
        self.extra = extra             # callable(result) -> list of violations
        self.allow_refusal = allow_refusal
        self.watch = watch or []       # further folders that must not change


def snapshot(root, exclude=()):
    """{relative path: (kind, size, mtime_ns)} below root (symlinks not followed)."""
    snap = {}
    if not os.path.lexists(root):
        return None
    ex = [os.path.abspath(e) for e in exclude if e]
    st = os.lstat(root)
    if not stat.S_ISDIR(st.st_mode):
        return {".": ("f", st.st_size, st.st_mtime_ns)}
    for dirpath, dirnames, filenames in os.walk(root):
        keep = []
        for d in dirnames:
            full = os.path.join(dirpath, d)
            if any(full == e or full.startswith(e + "/") for e in ex):
                continue
            keep.append(d)
        dirnames[:] = keep
        for name in dirnames + filenames:
            full = os.path.join(dirpath, name)
            if any(full == e or full.startswith(e + "/") for e in ex):
                continue
            try:
                s = os.lstat(full)
            except OSError:
                continue
            kind = "d" if stat.S_ISDIR(s.st_mode) else "l" if stat.S_ISLNK(s.st_mode) else "f"
            snap[os.path.relpath(full, root)] = (kind, 0 if kind == "d" else s.st_size,
                                                 0 if kind == "d" else s.st_mtime_ns)
    return snap


def snap_diff(a, b):
    if a == b:
        return ""
    if a is None:
        return "created (%d entries)" % len(b or {})
    if b is None:
        return "removed"
    added = sorted(set(b) - set(a))
    gone = sorted(set(a) - set(b))
    changed = sorted(k for k in set(a) & set(b) if a[k] != b[k])
    parts = []
    if added:
        parts.append("new: " + ", ".join(added[:4]) + (" ..." if len(added) > 4 else ""))
    if gone:
        parts.append("gone: " + ", ".join(gone[:4]) + (" ..." if len(gone) > 4 else ""))
    if changed:
        parts.append("changed: " + ", ".join(changed[:4]) + (" ..." if len(changed) > 4 else ""))
    return "; ".join(parts)


TMP_RE = re.compile(r"^\..+\.tmp-")
NAMES_RE = re.compile(
    r"(/|\.(yaml|yml|nii|gz|mha|mhd|nrrd|nhdr|raw|img|hdr|stl|off|ply|vtp|vtu|msh|mesh|inp|feb|"
    r"csv|txt|lut|json)\b|\b[a-z_]+\.[a-z_0-9]+\b|--?[a-z]|\bvoxel|\bline \d|:\d+:|\bposition|"
    r"\(\s*-?[0-9.]+,|\bkey\b|\blabel \d|\bstage\b|\bcolumn\b|\bsubject\b|\boption\b|"
    r"\bcommand\b|\bfield\b|\bheader\b)", re.I)


def temp_files(out):
    found = []
    if out and os.path.isdir(out):
        for dirpath, _, filenames in os.walk(out):
            for f in filenames:
                if TMP_RE.match(f):
                    found.append(os.path.relpath(os.path.join(dirpath, f), out))
    return found


def error_line_violations(stderr):
    """The rules for a refusal's stderr; returns violations."""
    lines = [l for l in stderr.split("\n") if l.strip()]  # '\r' or '\f' in a quoted token
    if not lines:                                           # does not start a line
        return ["exit 2 with nothing on stderr"]
    v = []
    last = lines[-1]
    if not last.startswith("frontmesh:"):
        v.append("last stderr line does not start with 'frontmesh:': %r" % last[:160])
    elif not NAMES_RE.search(last):
        v.append("error line names no file/key/voxel/position: %r" % last[:200])
    if "internal" in last.lower():
        v.append("refusal worded as internal error: %r" % last[:160])
    others = [l for l in lines[:-1] if not re.search(r"\bwarning\b", l, re.I) and
              not l.startswith("recipe: ")]
    if others:
        v.append("%d more stderr lines besides the error: %r" % (len(others), others[0][:160]))
    return v


class Runner:
    def __init__(self, args):
        self.args = args
        self.fm = args.frontmesh
        self.root = args.out
        self.shared = os.path.join(self.root, "shared")
        self.lock = threading.Lock()
        self.results = []
        self._shared_snap = None

    def shared_snapshot(self):
        return snapshot(self.shared)

    def run_cmd(self, argv, cwd, timeout=None):
        timeout = timeout or self.args.timeout
        t0 = time.time()
        p = subprocess.Popen(argv, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             stdin=subprocess.DEVNULL, start_new_session=True)
        try:
            out, err = p.communicate(timeout=timeout)
            rc = p.returncode
        except subprocess.TimeoutExpired:
            try:
                os.killpg(p.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            out, err = p.communicate()
            rc = None
        return rc, out.decode("utf-8", "replace"), err.decode("utf-8", "replace"), \
            time.time() - t0

    def meshcheck(self, path):
        p = subprocess.run([PY, MESHCHECK, os.path.basename(path)], cwd=os.path.dirname(path),
                           capture_output=True, text=True, timeout=300)
        return p.returncode, (p.stdout + p.stderr)

    def repro(self, cid, spec):
        cmd = " ".join(shlex.quote(a) for a in spec.argv)
        return "cd %s && %s   # regenerate: %s --seed %d --only %s" % (
            shlex.quote(spec.cwd), cmd, os.path.relpath(__file__, REPO), self.args.seed, cid)

    def execute(self, cid, cls, spec):
        """Runs one case and checks it; returns a result dict."""
        exclude = [spec.out] if spec.out else []
        case_dir = spec.cwd
        before_case = snapshot(case_dir, exclude)
        before_out = snapshot(spec.out) if spec.out else None
        before_watch = [snapshot(w) for w in spec.watch]
        before_shared = self.shared_snapshot()
        try:
            rc, out, err, wall = self.run_cmd(spec.argv, spec.cwd)
        except OSError as e:
            if e.errno != errno.E2BIG:
                raise
            # The kernel refuses the command line itself (a generated --set value beyond
            # ARG_MAX): frontmesh never runs, so there is nothing to judge.
            return {"id": cid, "class": cls, "desc": spec.desc, "expect": spec.expect,
                    "outcome": "not run (argument list too long for the OS)", "wall_s": 0.0,
                    "violations": [], "notes": [], "stderr_last": "",
                    "repro": self.repro(cid, spec), "cwd": spec.cwd, "inputs": spec.inputs}
        v = []      # violations
        notes = []
        outcome = "timeout" if rc is None else "signal %d" % -rc if rc < 0 else "exit %d" % rc
        if rc is None:
            v.append("timeout: no result after %d s (hang)" % self.args.timeout)
        elif rc < 0:
            v.append("crash: killed by signal %d (%s)" % (-rc, signal.Signals(-rc).name
                                                          if -rc in signal.Signals._value2member_map_
                                                          else "?"))
        else:
            v += self.judge(spec, rc, out, err, before_out, notes)
        # nothing written outside the output folder
        after_case = snapshot(case_dir, exclude)
        d = snap_diff(before_case, after_case)
        if d:
            v.append("wrote outside the output folder (case folder): " + d)
        for w, b in zip(spec.watch, before_watch):
            d = snap_diff(b, snapshot(w))
            if d:
                v.append("wrote outside the output folder (%s): %s" % (w, d))
        d = snap_diff(before_shared, self.shared_snapshot())
        if d:
            v.append("changed the campaign's shared inputs: " + d)
        if rc is not None and rc >= 0:
            tmp = temp_files(spec.out)
            if tmp:
                v.append("temporary files left in the output folder: " + ", ".join(tmp[:3]))
        last = ([l for l in err.split("\n") if l.strip()] or [""])[-1]
        res = {"id": cid, "class": cls, "desc": spec.desc, "expect": spec.expect,
               "outcome": outcome, "wall_s": round(wall, 2), "violations": v, "notes": notes,
               "stderr_last": last[:400], "repro": self.repro(cid, spec), "cwd": spec.cwd,
               "inputs": spec.inputs}
        return res

    def judge(self, spec, rc, out, err, before_out, notes):
        v = []
        e = spec.expect
        after_out = snapshot(spec.out) if spec.out else None
        out_changed = snap_diff(before_out, after_out) if spec.out else ""
        internal = [l for l in err.splitlines() if "internal error" in l or "internal check" in l]

        def refusal_rules():
            r = error_line_violations(err)
            if out_changed:
                r.append("refused but the output folder changed: " + out_changed)
            return r

        if e == "usage":  # no arguments at all: the usage text on stderr, exit 2
            if rc != 2 or "Usage:" not in err:
                v.append("no arguments: expected the usage and exit 2, got exit %d" % rc)
            return v
        if e == "info":
            if rc != 0:
                v.append("expected exit 0, got %d: %s" % (rc, err.strip()[-200:]))
            return v
        if e == "check":
            if rc == 2:
                v += error_line_violations(err)
            elif rc == 1:
                said_invalid = "invalid" in out.lower()
                try:
                    said_invalid |= json.loads(out).get("valid") is False
                except (ValueError, AttributeError):
                    pass
                if internal or "error" in err.lower():
                    v.append("exit 1 with an error (internal?): %r" % err.strip()[-200:])
                elif not said_invalid:
                    v.append("exit 1 without a report saying invalid")
                else:
                    notes.append("readable, invalid")
            elif rc != 0:
                v.append("unexpected exit %d" % rc)
            if spec.extra:
                v += spec.extra(rc, out, err)
            return v
        if e == "convert":
            if rc == 2:
                v += refusal_rules()
            elif rc == 0:
                if spec.extra:
                    v += spec.extra(rc, out, err)
            else:
                v.append("exit %d (internal failure): %r" % (rc, err.strip()[-200:]))
            return v
        if e == "cohort":
            if rc == 2:
                v += refusal_rules()
            elif rc == 1:
                summ = os.path.join(spec.out, "cohort-summary.json")
                if internal:
                    v.append("cohort exit 1 with an internal error: %r" % internal[0][:200])
                elif not os.path.exists(summ):
                    v.append("cohort exit 1 without cohort-summary.json")
                else:
                    notes.append("a subject failed (recorded)")
                    if spec.extra:
                        v += spec.extra(rc, out, err)
            elif rc == 0:
                if spec.extra:
                    v += spec.extra(rc, out, err)
            else:
                v.append("unexpected exit %d" % rc)
            return v
        # run / validate / mesh
        if rc == 1:
            v.append("exit 1 (internal failure) on %s input: %r" %
                     ("valid" if e == "valid" else "bad" if e == "invalid" else "mutated",
                      ([l for l in err.splitlines() if l.strip()] or [""])[-1][:240]))
            return v
        if rc == 130:
            v.append("exit 130 (interrupted) without an interrupt")
            return v
        if rc not in (0, 2):
            v.append("unexpected exit %d" % rc)
            return v
        if e == "invalid":
            if rc == 0:
                v.append("exit 0 on invalid input")
            else:
                v += refusal_rules()
        elif e in ("valid", "any"):
            if rc == 2:
                r = refusal_rules()
                if e == "valid" and not r:
                    notes.append("refused: " + ([l for l in err.splitlines() if l.strip()]
                                                or [""])[-1][:200])
                    if not spec.allow_refusal:
                        v.append("valid input refused: " + notes[-1])
                v += r
            else:
                if spec.mesh and spec.out and spec.argv[1] in ("run", "mesh"):
                    mv = os.path.join(spec.out, "mesh.vtu")
                    if not os.path.exists(mv):
                        v.append("exit 0 but no mesh.vtu")
                    else:
                        mrc, mtext = self.meshcheck(mv)
                        if mrc != 0:
                            tail = [l for l in mtext.splitlines() if l.strip()][-3:]
                            v.append("exit 0 but meshcheck says %d: %s" % (mrc, " / ".join(tail)))
                        else:
                            notes.append("mesh valid")
        if spec.extra:
            v += spec.extra(rc, out, err)
        return v


# ------------------------------------------------------------------------------ case context


class Ctx:
    """Helpers for one case: its folder, its random numbers, its base inputs."""

    def __init__(self, runner, cid, rng):
        self.r = runner
        self.cid = cid
        self.rng = rng
        self.dir = os.path.join(runner.root, "cases", cid)
        shutil.rmtree(self.dir, ignore_errors=True)
        os.makedirs(self.dir)
        self.fm = runner.fm

    def p(self, *names):
        return os.path.join(self.dir, *names)

    def write(self, name, data):
        path = self.p(name)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "wb") as f:
            f.write(data if isinstance(data, bytes) else data.encode("utf-8", "surrogatepass"))
        return path

    def image(self, name="img.nii.gz", kind="ball", n=(14, 14, 14), dtype="u1", **kw):
        vol = shape_volume(kind, n, self.rng)
        path = self.p(name)
        if name.endswith((".nii", ".nii.gz", ".hdr")):
            write_nifti(path, vol, n, dtype, **kw)
        elif name.endswith((".mha", ".mhd")):
            lines = meta_lines(n, dtype, kw.get("spacing", (1, 1, 1)), kw.get("origin", (0, 0, 0)),
                               local=name.endswith(".mha"))
            write_meta(path, lines, pack_voxels(vol, dtype),
                       raw_name=None if name.endswith(".mha") else "data.raw")
        elif name.endswith((".nrrd", ".nhdr")):
            f = nrrd_fields(n, dtype, kw.get("spacing", (1, 1, 1)), kw.get("origin", (0, 0, 0)))
            if name.endswith(".nhdr"):
                f.append(["data file", "data.raw"])
            write_nrrd(path, f, pack_voxels(vol, dtype),
                       detached="data.raw" if name.endswith(".nhdr") else None)
        return path

    def recipe(self, body, name="recipe.yaml"):
        return self.write(name, body)

    def argv(self, cmd="run", recipe="recipe.yaml", extra=()):
        a = [self.fm, cmd, recipe]
        if cmd in ("run", "mesh"):
            a += ["--quiet", "--threads", "1"]
        return a + list(extra)

    def spec(self, argv, expect, out="out", desc="", inputs=None, **kw):
        outp = None if out is None else (out if os.path.isabs(out) else self.p(out))
        return Spec(argv, expect, outp, desc, inputs or [self.dir], cwd=self.dir, **kw)


BASE_RECIPE = "input:\n  image: img.nii.gz\noutput:\n  dir: out\n"


def base_recipe_text(rng):
    """A valid recipe with a few more keys than the minimum, for mutations."""
    lines = ["# campaign base recipe", "input:", "  image: img.nii.gz", "  labels: all",
             "output:", "  dir: out", "  formats: [vtu]", "extract:",
             "  smoothing_iterations: 8", "remesh:", "  gradation: 1.3",
             "  label_edge_length: {}", "tetra:", "  stretching: 1.15", "refine:",
             "  passes: 3"]
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------------------ recipe class

KEYS = []  # (key, default, range text) from `frontmesh keys`


def load_keys(fm, probe_dir=None):
    """(key, default, range) of every key; a key with a range is probed (when probe_dir holds
    a valid recipe.yaml) for whether it takes whole numbers only: its range text alone does
    not tell (tetra.max_edge_length: default 0, range [0, 1e6], a real number)."""
    p = subprocess.run([fm, "keys"], capture_output=True, text=True, timeout=60)
    keys = []
    for line in p.stdout.splitlines():
        m = re.match(r"^(\S+): (.*?)\s+# (.*)$", line)
        if not m:
            continue
        key, default, doc = m.group(1), m.group(2).strip(), m.group(3)
        num = r"-?[0-9.]+(?:e[+-]?[0-9]+)?"
        rng = re.search(r"([\[(]\s*%s\s*,\s*%s\s*[\])])\)?$" % (num, num), doc)
        keys.append((key, default, rng.group(1) if rng else ""))
    if probe_dir:
        for i, (key, default, rtext) in enumerate(keys):
            if not rtext or not re.fullmatch(r"-?[0-9]+", default):
                continue
            lo, hi = [float(x) for x in re.findall(r"-?[0-9.]+(?:e[+-]?[0-9]+)?", rtext)[:2]]
            v = lo + 0.5 if lo + 0.5 < hi else (lo + hi) / 2.0
            q = subprocess.run([fm, "validate", "recipe.yaml", "--set", "%s=%r" % (key, v)],
                               cwd=probe_dir, capture_output=True, text=True, timeout=60)
            WHOLE_KEYS[key] = q.returncode == 2 and "whole number" in q.stderr
    return keys


WHOLE_KEYS = {}  # key -> takes whole numbers only (probed)


def key_kind(key, default, rtext):
    if default in ("true", "false"):
        return "bool"
    if key in ("input.image", "input.surface", "input.label_names", "output.dir"):
        return "path"
    if key in ("input.labels", "input.spacing", "output.formats", "output.split_interfaces",
               "remesh.label_edge_length", "extract.method", "output.frame", "output.order"):
        return key
    if key == "input.threshold":
        return "number"
    if rtext:
        lo, hi = [float(x) for x in re.findall(r"-?[0-9.]+(?:e[+-]?[0-9]+)?", rtext)[:2]]
        whole = WHOLE_KEYS.get(key, re.fullmatch(r"-?[0-9]+", default) is not None and
                               "." not in rtext)
        return ("int" if whole else "number", rtext[0] == "[", lo, hi, rtext[-1] == "]")
    return "other"


def set_in_recipe(text, key, value):
    """Puts `key: value` in the recipe text (section created when missing)."""
    sec, name = key.split(".", 1)
    lines = text.splitlines()
    out, done, in_sec = [], False, False
    for i, l in enumerate(lines):
        if re.match(r"^%s:\s*$" % re.escape(sec), l):
            in_sec = True
            out.append(l)
            out.append("  %s: %s" % (name, value))
            done = True
            continue
        if in_sec and re.match(r"^  %s:" % re.escape(name), l):
            continue
        if not l.startswith(" "):
            in_sec = False if not re.match(r"^%s:" % re.escape(sec), l) else in_sec
        out.append(l)
    if not done:
        out += ["%s:" % sec, "  %s: %s" % (name, value)]
    return "\n".join(out) + "\n"


def wrong_values(kind):
    common = ["[1, 2]", "{a: 1}", "'[x'", "{}", "[]"]
    if kind == "bool":
        return common + ["maybe", "2", "'tru'", "1.0", "[true]", "truee"]
    if kind == "path":
        return ["[a, b]", "{x: 1}", "''", "[]", "{}"]
    if kind == "input.labels":
        return ["[1, 1]", "[0]", "[-1]", "[1.5]", "[2147483648]", "[]", "{1: 2}", "none", "'1'",
                "[[1]]", "[1, '']", "[1, null]", "[0x]", "1"]
    if kind == "input.spacing":
        return ["[1, 1]", "[1, 1, 1, 1]", "[0, 1, 1]", "[-1, 1, 1]", "[.nan, 1, 1]",
                "[.inf, 1, 1]", "[1e-7, 1, 1]", "[2e6, 1, 1]", "1", "{x: 1}", "[a, b, c]", "[]"]
    if kind == "output.formats":
        return ["[]", "[vtu, vtu]", "[stl]", "vtu", "[VTU]", "[[vtu]]", "{vtu: 1}", "[msh, '']"]
    if kind == "output.split_interfaces":
        return ["[[1, 1]]", "[[1]]", "[1, 2]", "[[1, 2], [2, 1]]", "[[0, 1]]", "some",
                "{1: 2}", "[[1, 2, 3]]", "[[-1, 2]]", "[[a, b]]"]
    if kind == "remesh.label_edge_length":
        return ["[1, 2]", "{1: 0}", "{1: -1}", "{a: 1}", "{1: .nan}", "{1: 1e5}", "{-1: 1}",
                "{1: [1]}", "3", "{1.5: 1}", "{1: .inf}", "{2147483648: 1}"]
    if kind in ("extract.method", "output.frame", "output.order"):
        return ["[auto]", "AUTO", "nope", "''", "3", "{a: b}", "1.0", "01"]
    if kind == "number" or (isinstance(kind, tuple) and kind[0] == "number"):
        return common + ["abc", "1,5", "1 mm", "0x1G", "true", "''", "'1e'", "..5", "--1", "1e",
                         "+-2", "1.2.3"]
    if isinstance(kind, tuple) and kind[0] == "int":
        return common + ["abc", "2.5", "1,5", "true", "''", "0.5", "1e", "3.0000001", "- 1"]
    return common


def range_values(kind, rng):
    _, lo_closed, lo, hi, hi_closed = kind
    vals = [".nan", ".NaN", ".inf", "-.inf", "1e309", "-1e309",
            "99999999999999999999999999999999", "-99999999999999999999999999999999"]
    span = max(abs(hi - lo), 1.0)
    for _ in range(3):
        vals.append(repr(lo - rng.choice([1e-9, 1e-3, 0.5, 1.0, 10.0]) * span))
        vals.append(repr(hi + rng.choice([1e-9, 1e-3, 0.5, 1.0, 10.0]) * span))
    if not lo_closed:
        vals.append(repr(lo))
    if not hi_closed:
        vals.append(repr(hi))
    if kind[0] == "int":
        vals += [str(int(hi) + 1), str(int(lo) - 1), str(2 ** 63), str(-2 ** 63 - 1),
                 str(2 ** 64), str(2 ** 31)]
    return [v for v in vals if v not in ("inf",)]


def gen_recipe(ctx):
    rng = ctx.rng
    ctx.image("img.nii.gz", rng.choice(["ball", "two"]), n=(12, 12, 12))
    base = base_recipe_text(rng)
    keys = KEYS
    sub = rng.choice(["syntax", "type", "range", "unknown", "duplicate", "alias", "huge",
                      "unicode", "empty", "garbage", "deep", "set", "tags", "multidoc",
                      "type", "range", "syntax", "unknown"])
    cmd = rng.choice(["run", "run", "validate"])
    expect = "invalid"
    extra = []
    text = base
    desc = sub
    outname = "out"
    if sub == "syntax":
        text = base
        nmut = rng.randint(1, 3)
        ops = []
        for _ in range(nmut):
            op = rng.choice(["ins", "del", "dupline", "tab", "indent", "truncate", "swapline",
                             "colon"])
            pos = rng.randrange(max(1, len(text)))  # truncate may leave nothing
            if op == "ins":
                ch = rng.choice(list(":{}[]'\"&*!|>%@`#\t-,?\\") + ["\n", " - ", ": :"])
                text = text[:pos] + ch + text[pos:]
            elif op == "del":
                text = text[:pos] + text[pos + 1:]
            elif op == "truncate":
                text = text[:pos]
            elif op in ("dupline", "swapline", "tab", "indent", "colon"):
                lines = text.split("\n")
                i = rng.randrange(len(lines))
                if op == "dupline":
                    lines.insert(i, lines[i])
                elif op == "swapline" and len(lines) > 1:
                    j = rng.randrange(len(lines))
                    lines[i], lines[j] = lines[j], lines[i]
                elif op == "tab":
                    lines[i] = "\t" + lines[i]
                elif op == "indent":
                    lines[i] = " " * rng.choice([1, 3, 4, 6]) + lines[i].lstrip()
                else:
                    lines[i] = lines[i].replace(":", rng.choice(["", "::", " :", ":  :"]), 1)
                text = "\n".join(lines)
            ops.append(op)
        desc = "syntax: " + ",".join(ops)
        expect = "any"
        extra = ["--set", "output.dir=out"]  # a mutated dir line must not send it elsewhere
    elif sub in ("type", "range"):
        cands = [k for k in keys if key_kind(*k) != "other"]
        if sub == "range":
            cands = [k for k in keys if isinstance(key_kind(*k), tuple)] + \
                [("input.threshold", "null", "")] * 2
        key, default, rtext = rng.choice(cands)
        kind = key_kind(key, default, rtext)
        if sub == "type":
            val = rng.choice(wrong_values(kind))
        elif key == "input.threshold":
            val = rng.choice([".nan", ".NaN", "-.nan", ".inf", "1e301", "-1e301", "1e309"])
        else:
            val = rng.choice(range_values(kind, rng))
        # special: the value may be valid after all for a few combinations
        if key == "input.labels" and val == "'1'":
            expect = "any"
        if key == "output.order" and val in ("01", "1.0"):
            expect = "any"
        if key.startswith("input.") and key in ("input.image", "input.surface") and val == "''":
            expect = "invalid"
        desc = "%s: %s = %s" % (sub, key, val)
        if rng.random() < 0.4:
            extra = ["--set", "%s=%s" % (key, val)]
        else:
            text = set_in_recipe(base, key, val)
        if key == "input.label_names" and val not in ("''",):
            pass
        if key in ("output.dir",) and val in ("[a, b]", "{x: 1}", "''", "[]", "{}"):
            expect = "invalid"
    elif sub == "unknown":
        key, default, _ = rng.choice(keys)
        sec, name = key.split(".", 1)
        how = rng.choice(["typo", "typo", "section", "wrongsec", "toplevel", "unicode",
                          "trailing", "case"])
        if how == "typo":
            i = rng.randrange(len(name))
            op = rng.choice(["del", "dup", "swap", "sub"])
            if op == "del" and len(name) > 1:
                name2 = name[:i] + name[i + 1:]
            elif op == "dup":
                name2 = name[:i] + name[i] + name[i:]
            elif op == "swap" and i + 1 < len(name) and name[i] != name[i + 1]:
                name2 = name[:i] + name[i + 1] + name[i] + name[i + 2:]
            else:
                name2 = name[:i] + rng.choice("xqz_") + name[i + 1:]
            if name2 == name:
                name2 = name + "x"
            k2 = sec + "." + name2
        elif how == "section":
            k2 = sec[:-1] + "s." + name if len(sec) > 2 else "x" + sec + "." + name
        elif how == "wrongsec":
            other = rng.choice([s for s in ("input", "output", "extract", "repair", "remesh",
                                            "tetra", "refine", "limits") if s != sec])
            k2 = other + "." + name
        elif how == "toplevel":
            text = base + "%s: %s\n" % (name, default)
            k2 = None
        elif how == "unicode":
            k2 = sec + "." + name[:2] + rng.choice(["\u200b", "\u00e9", "\u0430", "\u2060"]) + \
                name[2:]
        elif how == "trailing":
            k2 = None
            text = set_in_recipe(base, sec + ".x", "1").replace("  x: 1", "  '%s ': %s" %
                                                                   (name, default))
        else:
            k2 = sec + "." + name.upper()
        if k2 and k2 in set(k for k, _, _ in keys):
            k2 = sec + ".x" + name
        if k2:
            if rng.random() < 0.3:
                extra = ["--set", "%s=%s" % (k2, default)]
            else:
                text = set_in_recipe(base, k2, default)
        desc = "unknown key (%s): %s" % (how, k2 or name)
    elif sub == "duplicate":
        how = rng.choice(["key", "section", "flow", "label03", "labelquoted", "set", "twoset",
                          "nested", "quotedkey"])
        if how == "key":
            key, default, _ = rng.choice(keys)
            sec, name = key.split(".", 1)
            t = set_in_recipe(base, key, default)
            text = t.replace("%s:\n" % sec, "%s:\n  %s: %s\n" % (sec, name, default), 1)
        elif how == "section":
            text = base + "remesh:\n  gradation: 1.5\n"
        elif how == "flow":
            text = base.replace("output:\n  dir: out\n", "output: {dir: out, dir: out2}\n")
        elif how == "label03":
            text = base.replace("  label_edge_length: {}", "  label_edge_length: {1: 2, 01: 3}")
        elif how == "labelquoted":
            text = base.replace("  label_edge_length: {}",
                                "  label_edge_length: {1: 2, '1': 3}")
        elif how == "set":
            extra = ["--set", "remesh.label_edge_length={1: 2, 1: 3}"]
        elif how == "twoset":
            extra = ["--set", "remesh.gradation=1.4", "--set", "remesh.gradation=1.5"]
            expect = "valid"
        elif how == "nested":
            extra = ["--set", "output.split_interfaces=[[1, 2], [1, 2]]"]
        else:
            text = base.replace("  image: img.nii.gz", "  image: img.nii.gz\n  \"image\": x.nii")
        desc = "duplicate (%s)" % how
    elif sub == "alias":
        how = rng.choice(["undefined", "recursive_seq", "recursive_map", "laughs", "laughs_set",
                          "merge", "section_alias", "alias_key", "reuse_valid",
                          "recursive_labels", "laughs_known"])
        if how == "undefined":
            text = base.replace("  labels: all", "  labels: *nope")
        elif how == "recursive_seq":
            text = base + "extra: &a [*a]\n"
        elif how == "recursive_map":
            text = base.replace("  label_edge_length: {}", "  label_edge_length: &m {1: *m}")
        elif how == "recursive_labels":
            text = base.replace("  labels: all", "  labels: &a [1, *a]")
        elif how in ("laughs", "laughs_known"):
            depth = rng.randint(6, 9)
            lines = ["  l0: &l0 [x, x, x, x, x, x, x, x, x, x]"]
            for d in range(1, depth + 1):
                lines.append("  l%d: &l%d [%s]" % (d, d, ", ".join(["*l%d" % (d - 1)] * 10)))
            if how == "laughs":
                text = base + "bomb:\n" + "\n".join(lines) + "\n"
            else:
                text = base.replace("  labels: all", "  labels: *l%d" % depth)
                text = "defs:\n" + "\n".join(lines) + "\n" + text
        elif how == "laughs_set":
            depth = rng.randint(6, 9)
            parts = ["&a0 [x,x,x,x,x,x,x,x,x,x]"]
            val = "[" + ",".join(["&a0 [x,x,x,x,x,x,x,x,x,x]"] + ["*a0"] * 9) + "]"
            for d in range(1, depth):
                val = "[&a%d %s%s]" % (d, val, ",*a%d" % d * 9)
            extra = ["--set", "input.labels=" + val]
        elif how == "merge":
            text = base.replace("tetra:\n", "tetra:\n  <<: {stretching: 1.2}\n")
        elif how == "section_alias":
            text = base.replace("input:\n", "input: &in\n") + "copy: *in\n"
        elif how == "alias_key":
            text = base.replace("  gradation: 1.3", "  &g gradation: 1.3\n  *g : 1.4")
        else:
            text = base.replace("  gradation: 1.3", "  gradation: &g 1.3").replace(
                "  stretching: 1.15", "  stretching: 1.15\n  min_angle_deg: &m 5\n"
                "  max_remesh_per_node: *m")
            expect = "valid"
        desc = "alias (%s)" % how
    elif sub == "huge":
        how = rng.choice(["bigint", "longdir", "longkey", "manylabels", "longvalue", "bigfloat",
                          "bigint_set", "longline"])
        if how == "bigint":
            text = set_in_recipe(base, "refine.passes", "9" * rng.choice([20, 400, 5000]))
        elif how == "bigint_set":
            extra = ["--set", "tetra.max_closing_rounds=" + "1" * rng.choice([19, 20, 300])]
        elif how == "bigfloat":
            text = set_in_recipe(base, "remesh.gradation", "1" + "0" * rng.choice([310, 4000]))
        elif how == "longdir":
            text = set_in_recipe(base, "output.dir", "o" * rng.choice([256, 5000, 70000]))
        elif how == "longkey":
            text = set_in_recipe(base, "remesh." + "k" * rng.choice([300, 70000]), "1")
        elif how == "manylabels":
            nl = rng.choice([1000, 100000])
            text = set_in_recipe(base, "input.labels", "[" + ", ".join(
                str(i) for i in range(1, nl + 1)) + "]")
        elif how == "longline":
            text = base + "# " + "x" * rng.choice([100000, 3000000]) + "\n"
            expect = "valid"
        else:
            text = set_in_recipe(base, "input.image", "'" + "a/" * 3000 + "x.nii'")
        desc = "huge (%s)" % how
    elif sub == "unicode":
        how = rng.choice(["bom", "utf16", "zwsp_key", "unicode_dir", "unicode_image", "nul",
                          "badutf8", "surrogate", "rtl", "emoji_key", "crlf", "cr_only",
                          "nbsp_indent"])
        if how == "bom":
            text = "\ufeff" + base
            expect = "valid"
        elif how == "utf16":
            ctx.write("recipe.yaml", ("\ufeff" + base).encode("utf-16-le"))
            text = None
            expect = "any"
        elif how == "zwsp_key":
            text = base.replace("  gradation", "  grad\u200bation")
        elif how == "unicode_dir":
            outname = "out-\u03a9\u03bc\u00e9\u65e5\u672c"
            text = base.replace("  dir: out", "  dir: " + outname)
            expect = "valid"
        elif how == "unicode_image":
            shutil.move(ctx.p("img.nii.gz"), ctx.p("\u00efmage-\u65e5\u672c \u2603.nii.gz"))
            text = base.replace("  image: img.nii.gz",
                                "  image: \"\u00efmage-\u65e5\u672c \u2603.nii.gz\"")
            expect = "valid"
        elif how == "nul":
            pos = rng.randrange(len(base))
            if "dir: out" in base[max(0, pos - 9):pos + 1]:
                cmd = "validate"  # a NUL inside the folder's name: where would it write?
            ctx.write("recipe.yaml", base[:pos].encode() + b"\0" + base[pos:].encode())
            text = None
            expect = "any"
        elif how == "badutf8":
            ctx.write("recipe.yaml", base.replace("  dir: out", "  dir: out-").encode()
                      .replace(b"out-", b"out-\xff\xfe\xc3", 1))
            outname = os.fsdecode(b"out-\xff\xfe\xc3")
            text = None
            expect = "any"
        elif how == "surrogate":
            text = base.replace("  dir: out", "  dir: \"out-\\ud800\"")
            expect = "any"
            cmd = "validate"  # where it would write is not known
        elif how == "rtl":
            outname = "out\u202egnp"
            text = base.replace("  dir: out", "  dir: " + outname)
            expect = "valid"
        elif how == "emoji_key":
            text = base + "\U0001F600:\n  a: 1\n"
        elif how == "crlf":
            text = base.replace("\n", "\r\n")
            expect = "valid"
        elif how == "cr_only":
            text = base.replace("\n", "\r")
            expect = "any"
        else:
            text = base.replace("  gradation", "\u00a0 gradation")
            expect = "any"
        desc = "unicode (%s)" % how
    elif sub == "empty":
        text = rng.choice(["", " ", "\n\n\n", "# only a comment\n", "---\n", "...\n", "~\n",
                           "null\n", "[]\n", "{}\n", "hello\n", "---\n---\n", "- a\n- b\n",
                           "input:\n", "input: {}\n", "input: ~\noutput: ~\n", "input:\noutput:\n"])
        desc = "empty: %r" % text
    elif sub == "garbage":
        nbytes = rng.choice([1, 7, 100, 1000, 4096, 65536])
        data = bytes(rng.randrange(256) for _ in range(nbytes))
        if rng.random() < 0.3:
            data = base.encode()[:rng.randrange(len(base))] + data
        ctx.write("recipe.yaml", data)
        text = None
        desc = "garbage (%d bytes)" % nbytes
    elif sub == "deep":
        depth = rng.choice([100, 1000, 1500, 3000, 10000, 100000])
        how = rng.choice(["flowseq", "flowmap", "block", "set", "labels"])
        if how == "flowseq":
            text = base + "deep: " + "[" * depth + "]" * depth + "\n"
        elif how == "flowmap":
            text = base + "deep: " + "{a: " * depth + "1" + "}" * depth + "\n"
        elif how == "labels":
            text = base.replace("  labels: all", "  labels: " + "[" * depth + "1" + "]" * depth)
        elif how == "block":
            depth = min(depth, 3000)
            text = base + "deep:\n" + "".join(" " * (i + 1) + "a%d:\n" % i for i in range(depth)) \
                + " " * (depth + 1) + "x\n"
        else:
            extra = ["--set", "input.labels=" + "[" * depth + "1" + "]" * depth]
        desc = "deep (%s, depth %d)" % (how, depth)
    elif sub == "set":
        bad = rng.choice(["input.image", "=1", "input.=x", ".image=x", "input.image.x=y",
                          "input=3", "remesh.gradation=[1,", "remesh.gradation=*x",
                          "remesh.gradation=a\n---\nb", "a.b.c=1", "=", "input..image=x",
                          "remesh.gradation=1=2", " remesh.gradation=1.4",
                          "remesh.gradation =1.4", "REMESH.gradation=1.4", "remesh=1",
                          "input.labels=[1", "input.labels={", "remesh.gradation=\t",
                          "output.dir=", "input.image=", "tetra.stretching=1.2 # c",
                          "remesh.gradation=!!binary aGVsbG8="])
        if bad in ("tetra.stretching=1.2 # c",):
            expect = "any"
        if bad == "--last":
            pass
        extra = ["--set", bad] if rng.random() < 0.8 else ["--set=" + bad]
        if rng.random() < 0.1:
            extra = ["--set"]
        desc = "--set %r" % extra[-1]
    elif sub == "tags":
        how = rng.choice(["binary", "str_number", "custom", "python", "int_text", "float_tag",
                          "null_tag", "seq_tag"])
        val = {"binary": "!!binary aGVsbG8=", "str_number": "!!str 1.4", "custom": "!foo 1.4",
               "python": "!!python/object/apply:os.system ['true']", "int_text": "!!int abc",
               "float_tag": "!!float 1.4", "null_tag": "!!null ''", "seq_tag": "!!seq [1]"}[how]
        text = base.replace("  gradation: 1.3", "  gradation: " + val)
        expect = "any" if how in ("str_number", "custom", "float_tag") else "invalid"
        desc = "tag (%s)" % how
    elif sub == "multidoc":
        how = rng.choice(["second_bad", "second_good", "first_empty", "directive", "end_marker"])
        if how == "second_bad":
            text = base + "---\n: : :\n[\n"
        elif how == "second_good":
            text = base + "---\n" + base
        elif how == "first_empty":
            text = "---\n---\n" + base
        elif how == "directive":
            text = "%YAML 1.2\n---\n" + base
        else:
            text = base + "...\ngarbage: [\n"
        expect = "any"
        desc = "multidoc (%s)" % how
    if text is not None:
        ctx.recipe(text)
    argv = ctx.argv(cmd, "recipe.yaml", extra)
    if cmd == "validate":
        argv = [ctx.fm, "validate", "recipe.yaml"] + list(extra)
    return ctx.spec(argv, expect, outname, desc)


# ------------------------------------------------------------------------------ image classes


def _nifti_case(ctx, name, mutate=None, dtype="u1", version=1, kind="ball", n=(12, 12, 12),
                post=None, big=False, scale=None, vol=None, spacing=(1, 1, 1)):
    vol = vol if vol is not None else shape_volume(kind, n, ctx.rng)
    path = ctx.p(name)
    write_nifti(path, vol, n, dtype, version, spacing=spacing, mutate=mutate, big=big,
                scale=scale)
    if post:
        post(path)
    return path


def truncate_file(path, keep):
    with open(path, "rb") as f:
        data = f.read()
    keep = max(0, min(len(data), keep if keep >= 0 else len(data) + keep))
    with open(path, "wb") as f:
        f.write(data[:keep])


def flip_bytes(path, rng, count, start=0, end=None):
    with open(path, "rb") as f:
        data = bytearray(f.read())
    end = len(data) if end is None else min(end, len(data))
    for _ in range(count):
        if end > start:
            i = rng.randrange(start, end)
            data[i] = rng.randrange(256)
    with open(path, "wb") as f:
        f.write(bytes(data))


def set_field(name, value, index=None):
    def m(h):
        if index is None:
            h[name] = value
        else:
            h[name] = list(h[name])
            h[name][index] = value
    return m


def chain(*ms):
    def m(h):
        for f in ms:
            f(h)
    return m


def gen_nifti(ctx):
    rng = ctx.rng
    version = rng.choice([1, 1, 1, 1, 2])  # ITK 5.2 reads no NIfTI-2 (its niftilib is nifti1_io)
    ext = rng.choice([".nii", ".nii.gz", ".nii", ".nii.gz", ".hdr"])
    name = "img" + ext
    nan, inf = float("nan"), float("inf")
    extra = []
    big = rng.random() < 0.15
    muts = [
        # (label, expect, mutate, kwargs)
        ("dim0=%s", "invalid", lambda v: set_field("dim", v, 0), [0, -1, 8, 100, -32768]),
        ("dim1=%s", "invalid", lambda v: set_field("dim", v, 1), [0, -1, -12]),
        ("dim3=%s", "invalid", lambda v: set_field("dim", v, 3), [0, -5]),
        ("dim huge %s", "invalid", lambda v: chain(set_field("dim", v, 1), set_field("dim", v, 2),
                                                   set_field("dim", v, 3)),
         [32767] if version == 1 else [2 ** 20, 2 ** 40, 2 ** 62]),
        ("dim2 larger %s", "invalid", lambda v: set_field("dim", v, 2), [13, 20, 1000]),
        ("datatype=%s", "invalid", lambda v: set_field("datatype", v), [0, 3, 6, 2048, -1, 777,
                                                                        4096, 1537]),
        ("datatype odd size %s", "any", lambda v: set_field("datatype", v), [128, 2304, 32,
                                                                             1536, 1792, 1]),
        ("bitpix=%s", "any", lambda v: set_field("bitpix", v), [0, 7, 64, -8]),
        ("pixdim%s", "invalid", lambda v: set_field("pixdim", v[1], v[0]),
         [(1, 0.0), (2, -1.0), (3, nan), (1, inf), (2, 1e-5), (3, 2e4), (1, -inf), (2, 1e-45),
          (3, -0.0)]),
        ("pixdim0(qfac)=%s", "any", lambda v: set_field("pixdim", v, 0), [0.0, -1.0, 2.0, nan]),
        ("vox_offset=%s", "invalid", lambda v: set_field("vox_offset", v),
         [-1.0, nan, inf, 1e20, 9e15] if version == 1 else [-1, 2 ** 62, 10 ** 12]),
        ("vox_offset odd %s", "any", lambda v: set_field("vox_offset", v), [0, 100, 351, 353,
                                                                            360]),
        ("scl_slope=%s", "invalid", lambda v: set_field("scl_slope", v), [nan, inf, -inf]),
        ("scl_inter=%s", "invalid", lambda v: set_field("scl_inter", v), [nan, inf]),
        ("scl_slope odd %s", "any", lambda v: set_field("scl_slope", v), [0.0, 2.0, -1.0, 0.5,
                                                                          1e-30, 1e30]),
        ("scl_inter odd %s", "any", lambda v: set_field("scl_inter", v), [0.5, 3.0, -1.0]),
        ("quatern[%d]=%s", "invalid", lambda v: set_field("quatern", v[1], v[0]),
         [(0, nan), (1, inf), (2, -inf), (3, nan), (4, inf)]),
        ("qoffset far %s", "invalid", lambda v: set_field("quatern", v, 3), [1.5e6, -2e6, 1e30]),
        ("qoffset near limit %s", "any", lambda v: set_field("quatern", v, 5), [999000.0,
                                                                                -999000.0]),
        ("quatern not unit %s", "any", lambda v: chain(set_field("quatern", v, 0),
                                                       set_field("quatern", v, 1),
                                                       set_field("quatern", v, 2)),
         [0.9, 1.0, 2.0, 1e10]),
        ("srow[%d]=%s", "invalid", lambda v: set_field("srow", v[1], v[0]),
         [(0, nan), (5, inf), (10, -inf), (3, nan), (7, inf)]),
        ("srow origin far %s", "invalid", lambda v: set_field("srow", v, 11), [3e6, -1e7]),
        ("sform singular %s", "invalid", lambda v: (lambda h: h.__setitem__("srow", v)),
         [[0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0], [1, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0],
          [1, 1, 0, 0, 1, 1, 0, 0, 0, 0, 1, 0]]),
        ("sform oblique %s", "any", lambda v: (lambda h: h.__setitem__("srow", v)),
         [[0.7071, -0.7071, 0, 5, 0.7071, 0.7071, 0, 0, 0, 0, 1, 0],
          [-1, 0, 0, 0, 0, -1, 0, 0, 0, 0, 1, 0], [0, 1, 0, 0, 1, 0, 0, 0, 0, 0, 1, 0],
          [1e6, 0, 0, 0, 0, 1e-6, 0, 0, 0, 0, 1, 0], [1e-20, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0]]),
        ("sform_code=%s", "any", lambda v: set_field("sform_code", v), [-1, 0, 5, 1000, 32767]),
        ("qform_code=%s", "any", lambda v: set_field("qform_code", v), [-1, 0, 5, 1000]),
        ("no forms, pixdim %s", "any", lambda v: chain(set_field("sform_code", 0),
                                                       set_field("qform_code", 0),
                                                       set_field("pixdim", v, 1)),
         [0.5, 3.0]),
        ("xyzt_units=%s", "any", lambda v: set_field("xyzt_units", v), [0, 1, 3, 7, 0xff, 24]),
        ("magic=%s", "any", lambda v: set_field("magic", v),
         [b"ni1\0", b"n+9\0", b"xyz\0", b"n+1x", b"\0\0\0\0"] if version == 1 else
         [b"n+2\0\0\0\0\0", b"ni2\0\r\n\x1a\n", b"n+3\0\r\n\x1a\n", b"garbage!"]),
        ("sizeof_hdr=%s", "invalid", lambda v: set_field("sizeof_hdr", v),
         [0, 347, 349, -348, 1 << 30, 1000]),
        ("sizeof_hdr of the other version %s", "any", lambda v: set_field("sizeof_hdr", v),
         [540 if version == 1 else 348]),
        ("extension %s", "any", lambda v: set_field("extension", v), [[1, 0, 0, 0],
                                                                      [255, 255, 255, 255]]),
        ("intent_code=%s", "any", lambda v: set_field("intent_code", v), [1002, 2001, -1, 32767]),
        ("dim0=%s extra dims", "any", lambda v: chain(set_field("dim", v[0], 0),
                                                      set_field("dim", v[1], 4)),
         [(4, 2), (4, 1), (5, 1), (2, 1), (1, 1), (7, 1)]),
        ("dim5..7 garbage %s", "valid", lambda v: chain(set_field("dim", v, 5),
                                                        set_field("dim", v, 6),
                                                        set_field("dim", v, 7)), [-7, 0, 999]),
    ]
    special = ["trunc_data", "trunc_header", "gz_trunc", "gz_trailer", "gz_flip", "gz_append",
               "gz_multimember", "nan_voxel", "float_labels", "labels_signed", "labels_huge",
               "all_zero", "ext_esize", "hdr_no_img", "img_short", "flip_header_bytes",
               "bigendian_valid", "absent_label", "threshold_nan_scl", "spacing_override"]
    pick = rng.random()
    dtype = rng.choice(["u1", "u1", "i2", "u2", "i4", "f4", "f8", "i1", "u4", "i8"])
    if dtype in ("f4", "f8"):
        extra = ["--set", "input.threshold=0.5"]
    if pick < 0.62:
        label, expect, mk, vals = rng.choice(muts)
        v = rng.choice(vals)
        mut = mk(v)
        shown = label.replace("%d", "%s").replace("%s", "{}", 1).replace("%s", "")
        desc = "nifti%d%s %s %s" % (version, ext, dtype, shown.format(v))
        if label.startswith("dim huge") and version == 2 and v == 2 ** 62:
            pass
        if label.startswith("magic") and ext == ".hdr":
            expect = "any"
        if label.startswith("vox_offset") and ext == ".hdr" and expect == "invalid" and \
                v in (1e20, 9e15, 10 ** 12):
            expect = "invalid"
        if label.startswith("scl_") and label.endswith("%s") and expect == "invalid" and \
                version == 1 and ext == ".hdr":
            expect = "any"  # Analyze? no: .hdr keeps ni1 magic; still NIfTI
        if label.startswith("pixdim") and "qfac" not in label and rng.random() < 0.25:
            # README: a wrong spacing can be replaced with input.spacing (without a qform)
            mut = chain(mut, set_field("qform_code", 0), set_field("sform_code", 0))
            extra += ["--set", "input.spacing=[1, 1, 1]"]
            expect = "valid"
            desc += " +input.spacing, no forms"
        _nifti_case(ctx, name, mut, dtype, version, big=big,
                    scale=(lambda x: float(x)) if dtype in ("f4", "f8") else None)
        if ext == ".hdr" and label.startswith("vox_offset") and expect == "invalid" and \
                isinstance(v, (int, float)) and math.isfinite(v) and v >= 0 and v < 1e6:
            expect = "any"
    else:
        sp = rng.choice(special)
        desc = "nifti%d%s %s %s" % (version, ext, dtype, sp)
        expect = "invalid"
        scale = (lambda x: float(x)) if dtype in ("f4", "f8") else None
        if sp == "trunc_data":
            if ext == ".hdr":
                _nifti_case(ctx, name, None, dtype, version, scale=scale,
                            post=lambda p: truncate_file(p[:-4] + ".img", -rng.randint(1, 50)))
            else:
                gz = ext.endswith(".gz")
                raw = ctx.p("tmp.nii")
                _nifti_case(ctx, "tmp.nii", None, dtype, version, scale=scale)
                truncate_file(raw, -rng.randint(1, 200))
                data = open(raw, "rb").read()
                os.remove(raw)
                ctx.write(name, gzip.compress(data, mtime=0) if gz else data)
        elif sp == "trunc_header":
            _nifti_case(ctx, name.replace(".gz", ""), None, dtype, version, scale=scale,
                        post=lambda p: truncate_file(p, rng.randint(0, 347 if version == 1
                                                                    else 539)))
            if ext == ".nii.gz":
                raw = ctx.p("img.nii")
                ctx.write(name, gzip.compress(open(raw, "rb").read(), mtime=0))
                os.remove(raw)
        elif sp in ("gz_trunc", "gz_trailer", "gz_flip", "gz_append", "gz_multimember"):
            name = "img.nii.gz"
            desc = "nifti%d.nii.gz %s %s" % (version, dtype, sp)
            path = _nifti_case(ctx, name, None, dtype, version, scale=scale)
            data = open(path, "rb").read()
            if sp == "gz_trunc":
                data = data[:rng.randint(10, len(data) - 9)]
            elif sp == "gz_trailer":
                data = data[:-rng.randint(1, 8)]
                expect = "any"
            elif sp == "gz_flip":
                i = rng.randrange(10, len(data) - 8)
                data = data[:i] + bytes([data[i] ^ (1 << rng.randrange(8))]) + data[i + 1:]
                expect = "any"
            elif sp == "gz_append":
                data = data + bytes(rng.randrange(256) for _ in range(rng.randint(1, 300)))
                expect = "any"
            else:
                raw = gzip.decompress(data)
                cut = rng.randint(1, len(raw) - 1)
                data = gzip.compress(raw[:cut], mtime=0) + gzip.compress(raw[cut:], mtime=0)
                expect = "valid"
            ctx.write(name, data)
        elif sp == "nan_voxel":
            dtype = rng.choice(["f4", "f8"])
            vol = shape_volume("ball", (12, 12, 12), rng)
            bad = rng.choice([float("nan"), float("inf"), float("-inf")])
            idx = rng.choice([0, len(vol) - 1, rng.randrange(len(vol))])
            vol = [float(x) for x in vol]
            vol[idx] = bad
            extra = ["--set", "input.threshold=0.5"] if rng.random() < 0.5 else []
            _nifti_case(ctx, name, None, dtype, version, vol=vol, big=big)
            desc = "nifti%d%s %s one %s voxel at %d%s" % (version, ext, dtype, bad, idx,
                                                          " +threshold" if extra else "")
        elif sp == "float_labels":
            dtype = rng.choice(["f4", "f8"])
            vol = [x * rng.choice([1.5, 0.3, 1.0000001]) for x in
                   shape_volume("two", (12, 12, 12), rng)]
            _nifti_case(ctx, name, None, dtype, version, vol=vol)
            extra = []
            desc = "nifti%d%s %s non-integer labels, no threshold" % (version, ext, dtype)
        elif sp == "labels_signed":
            dtype = rng.choice(["i1", "i2", "i4"])
            vol = [-x * rng.choice([1, 3]) for x in shape_volume("two", (12, 12, 12), rng)]
            _nifti_case(ctx, name, None, dtype, version, vol=vol)
            extra = []
            expect = "any"
            desc = "nifti%d%s %s negative labels" % (version, ext, dtype)
        elif sp == "labels_huge":
            dtype, v = rng.choice([("u4", 3000000000), ("i8", 2 ** 40), ("u8", 2 ** 63 + 5),
                                   ("i4", 2147483647), ("i4", 100000), ("u2", 65535),
                                   ("i8", -2 ** 40)])
            vol = [v if x else 0 for x in shape_volume("ball", (12, 12, 12), rng)]
            _nifti_case(ctx, name, None, dtype, version, vol=vol)
            extra = []
            expect = "any"
            desc = "nifti%d%s %s label %d" % (version, ext, dtype, v)
        elif sp == "all_zero":
            vol = [0] * (12 * 12 * 12)
            _nifti_case(ctx, name, None, dtype, version, vol=vol, scale=scale)
            desc = "nifti%d%s %s every voxel 0" % (version, ext, dtype)
        elif sp == "ext_esize":
            es = rng.choice([0, 7, -16, 2 ** 31 - 1, 16, 1 << 20])
            ecode = rng.choice([0, 4, 6, 999])

            def post(p, es=es, ecode=ecode):
                raw = open(p, "rb").read() if not p.endswith(".gz") else gzip.decompress(
                    open(p, "rb").read())
                hs = 348 if version == 1 else 540
                body = bytearray(raw)
                body[hs:hs + 4] = bytes([1, 0, 0, 0])
                body[hs + 4:hs + 12] = struct.pack("<ii", es, ecode)
                out = bytes(body)
                with open(p, "wb") as f:
                    f.write(gzip.compress(out, mtime=0) if p.endswith(".gz") else out)
            nm = name if ext != ".hdr" else "img.nii"
            if nm == "img.nii" and ext == ".hdr":
                desc = desc.replace(".hdr", ".nii")
            voff = (352 if version == 1 else 544) + 32
            _nifti_case(ctx, nm, set_field("vox_offset", voff), dtype, version, scale=scale,
                        post=post)
            expect = "any"
            desc += " esize=%d ecode=%d" % (es, ecode)
        elif sp == "hdr_no_img":
            _nifti_case(ctx, "img.hdr", None, dtype, version, scale=scale,
                        post=lambda p: os.remove(p[:-4] + ".img"))
            name = "img.hdr"
            desc = "nifti%d.hdr without .img" % version
        elif sp == "img_short":
            _nifti_case(ctx, "img.hdr", None, dtype, version, scale=scale,
                        post=lambda p: truncate_file(p[:-4] + ".img", 0))
            name = "img.hdr"
            desc = "nifti%d.hdr with an empty .img" % version
        elif sp == "flip_header_bytes":
            k = rng.randint(1, 6)
            hs = 348 if version == 1 else 540
            raw_name = name if not name.endswith(".gz") else "img.nii"
            path = _nifti_case(ctx, raw_name if ext != ".hdr" else name, None, dtype, version,
                               scale=scale)
            flip_bytes(path, rng, k, 4, hs)
            if ext == ".nii.gz":
                ctx.write(name, gzip.compress(open(path, "rb").read(), mtime=0))
                os.remove(path)
            expect = "any"
            desc += " %d random header bytes" % k
        elif sp == "bigendian_valid":
            _nifti_case(ctx, name, None, dtype, version, big=True, scale=scale)
            expect = "valid"
            desc += " big-endian"
        elif sp == "absent_label":
            _nifti_case(ctx, name, None, dtype, version, scale=scale)
            extra = ["--set", "input.labels=[%d]" % rng.choice([3, 7, 200])]
            if dtype in ("f4", "f8"):
                extra = ["--set", "input.labels=[2]", "--set", "input.threshold=0.5"]
            desc += " input.labels absent from the image"
        elif sp == "threshold_nan_scl":
            _nifti_case(ctx, name, set_field("scl_slope", float("nan")), "f4", version,
                        scale=lambda x: float(x))
            extra = ["--set", "input.threshold=0.5"]
            desc = "nifti%d%s f4 scl_slope nan with threshold" % (version, ext)
        elif sp == "spacing_override":
            _nifti_case(ctx, name, chain(set_field("pixdim", float("nan"), 1),
                                         set_field("qform_code", 1)), dtype, version, scale=scale)
            extra += ["--set", "input.spacing=[1, 1, 1]"]
            desc += " pixdim nan with a qform, input.spacing given"
    ctx.recipe(BASE_RECIPE.replace("img.nii.gz", name))
    cmd = "run" if rng.random() < 0.8 else "validate"
    if cmd == "validate":
        argv = [ctx.fm, "validate", "recipe.yaml"] + extra
    else:
        argv = ctx.argv("run", "recipe.yaml", extra)
    return ctx.spec(argv, expect, "out", desc)


def _set_line(lines, key, value, insert_at=None):
    for l in lines:
        if l[0] == key:
            l[1] = value
            return lines
    lines.insert(len(lines) - 1 if insert_at is None else insert_at, [key, value])
    return lines


def _drop_line(lines, key):
    return [l for l in lines if l[0] != key]


def gen_meta(ctx):
    rng = ctx.rng
    ext = rng.choice([".mha", ".mha", ".mhd"])
    name = "img" + ext
    n = (12, 12, 12)
    dtype = rng.choice(["u1", "u1", "i2", "u2", "i4", "f4", "f8", "i1"])
    vol = shape_volume(rng.choice(["ball", "two", "border"]), n, rng)
    data = pack_voxels([float(x) for x in vol] if dtype in ("f4", "f8") else vol, dtype)
    extra = ["--set", "input.threshold=0.5"] if dtype in ("f4", "f8") else []
    lines = meta_lines(n, dtype, local=ext == ".mha")
    raw_name = None if ext == ".mha" else "data.raw"
    sep, eol = " = ", "\n"
    table = [
        ("NDims", ["0", "-1", "2", "abc", "3.5", "", "8", "99999999999"], "invalid"),
        ("NDims", ["4"], "any"),
        ("DimSize", ["12 12", "0 12 12", "-12 12 12", "12 12 99999", "a b c", "12 12 12 12",
                     "12 12 13", "12 12 4294967308", "1e400 12 12", "12 12 12 x"], "invalid"),
        ("DimSize", ["1e1 12 12", "12 12 12.0", "012 12 12", "+12 12 12", "12  12\t12"], "any"),
        ("ElementSpacing", ["0 1 1", "-1 1 1", "nan 1 1", "inf 1 1", "1e-5 1 1", "2e4 1 1",
                            "1 1", "1 1 1 1", "1 1 x", "1e999 1 1", "0x1p-2 1 1"], "invalid"),
        ("ElementSpacing", ["1e-4 1 1", "0.3 1 4", "1e4 1 1", ".5 .5 .5", "5. 1 1"], "any"),
        ("ElementSize", ["1 1 1", "0 0 0", "nan 1 1"], "any"),
        ("ElementType", ["MET_FOO", "met_uchar", "", "MET_STRING", "MET_OTHER", "MET_NONE",
                         "MET_UCHAR MET_UCHAR"], "invalid"),
        ("ElementType", ["MET_UCHAR_ARRAY", "MET_FLOAT_MATRIX", "MET_ASCII_CHAR"], "any"),
        ("TransformMatrix", ["0 0 0 0 1 0 0 0 1", "nan 0 0 0 1 0 0 0 1", "1 0 0 0 1 0",
                             "1 0 0 0 1 0 0 0 1 0", "1 1 0 1 1 0 0 0 1", "inf 0 0 0 1 0 0 0 1",
                             ], "invalid"),
        ("TransformMatrix", ["-1 0 0 0 -1 0 0 0 1", "0.7071 0.7071 0 -0.7071 0.7071 0 0 0 1",
                             "2 0 0 0 2 0 0 0 2", "0 1 0 1 0 0 0 0 1",
                             "1 0 0 0 1 0 0 0 1e-300"], "any"),
        ("Offset", ["1e7 0 0", "nan 0 0", "1 2", "0 0 -inf", "0 0 0 0", "x y z"], "invalid"),
        ("Offset", ["999999 0 0", "-12.5 3 1e3"], "any"),
        ("Position", ["1e7 0 0", "nan 0 0"], "any"),
        ("ElementDataFile", ["nonexistent.raw", "/dev/zero", ".", "LIST", "img%03d.raw 1 12 1",
                             "/proc/self/mem", "sub", "", "data.raw.gz"], "invalid"),
        ("HeaderSize", ["100000", "abc", "1e9", "-5"], "invalid"),
        ("HeaderSize", ["-1", "0", "1"], "any"),
        ("CompressedData", ["True"], "any"),
        ("BinaryDataByteOrderMSB", ["True", "maybe"], "any"),
        ("ElementNumberOfChannels", ["3", "0", "-1", "2"], "any"),
        ("ObjectType", ["Mesh", "", "Image Image"], "any"),
        ("AnatomicalOrientation", ["XYZ", "", "RAIRAI"], "any"),
        ("Comment", ["\x01\x02 control", "x" * 70000], "any"),
    ]
    specials = ["short", "extra", "dupkey", "noequals", "crlf", "longline", "compressed",
                "compressed_nosize", "compressed_bigsize", "compressed_smallsize",
                "compressed_trunc", "text", "text_short", "text_garbage", "keys_after_data",
                "no_datafile", "unknown_key", "space_in_key", "colon_sep", "empty_value",
                "datafile_dir", "datafile_symlink_outside", "cr_in_type", "nul_in_header"]
    expect = "invalid"
    if rng.random() < 0.6:
        key, vals, expect = rng.choice(table)
        val = rng.choice(vals)
        if key == "ElementDataFile":
            if val == "sub":
                os.makedirs(ctx.p("sub"), exist_ok=True)
            if ext == ".mha" and val not in ("LIST",):
                pass
            raw_name = None
            if val in ("data.raw.gz",):
                ctx.write("data.raw.gz", gzip.compress(data)[:-20])
        if key == "NDims" and val == "4":
            _set_line(lines, "DimSize", "12 12 12 1")
            _set_line(lines, "ElementSpacing", "1 1 1 1")
            lines = _drop_line(lines, "TransformMatrix")
            lines = _drop_line(lines, "Offset")
            lines = _drop_line(lines, "CenterOfRotation")
        if key == "CompressedData":
            pass
        _set_line(lines, key, val, insert_at=1 if key in ("HeaderSize",) else None)
        if key == "DimSize" and val in ("12 12 12.0", "012 12 12", "+12 12 12", "12  12\t12",
                                        "1e1 12 12"):
            expect = "any"
        desc = "meta%s %s %s = %r" % (ext, dtype, key, val[:40])
        if key == "ElementDataFile" and val not in ("LOCAL",) and ext == ".mha":
            # the data stays after the header; the named file is what is read
            pass
        write_meta(ctx.p(name), lines, data, raw_name=raw_name if key != "ElementDataFile"
                   else None)
    else:
        sp = rng.choice(specials)
        desc = "meta%s %s %s" % (ext, dtype, sp)
        if sp == "short":
            data = data[:-rng.randint(1, len(data) // 2)]
        elif sp == "extra":
            data = data + b"\0" * rng.randint(1, 100)
            expect = "valid"
        elif sp == "dupkey":
            k = rng.choice(["DimSize", "ElementSpacing", "ElementType", "NDims"])
            v = [l[1] for l in lines if l[0] == k][0]
            lines.insert(2, [k, v])
        elif sp == "noequals":
            lines.insert(rng.randint(1, len(lines) - 1), ["JustAWord", None])
            expect = "any"
        elif sp == "crlf":
            eol = "\r\n"
            expect = "any"
        elif sp == "longline":
            lines.insert(1, ["Comment", "y" * rng.choice([5000, 200000])])
            expect = "any"
        elif sp.startswith("compressed"):
            comp = zlib.compress(data)
            _set_line(lines, "CompressedData", "True")
            size = len(comp)
            expect = "valid"
            if sp == "compressed_nosize":
                expect = "any"
            else:
                if sp == "compressed_bigsize":
                    size += rng.randint(1, 1000)
                    expect = "any"
                elif sp == "compressed_smallsize":
                    size -= rng.randint(1, size - 1)
                    expect = "any"
                elif sp == "compressed_trunc":
                    comp = comp[:rng.randint(2, len(comp) - 1)]
                    expect = "invalid"
                lines.insert(len(lines) - 1, ["CompressedDataSize", str(size)])
            data = comp
        elif sp.startswith("text"):
            _set_line(lines, "BinaryData", "False")
            vals = [float(x) for x in vol] if dtype in ("f4", "f8") else vol
            txt = " ".join(str(v) for v in vals)
            expect = "valid"
            if sp == "text_short":
                txt = " ".join(str(v) for v in vals[:rng.randint(0, len(vals) - 1)])
                expect = "invalid"
            elif sp == "text_garbage":
                toks = txt.split(" ")
                for _ in range(rng.randint(1, 5)):
                    toks[rng.randrange(len(toks))] = rng.choice(["x", "1e999", "nan", "--",
                                                                 "0x10", "1,5"])
                txt = " ".join(toks)
                expect = "any"
            data = txt.encode()
        elif sp == "keys_after_data":
            lines.append(["DimSize", "13 13 13"])
            expect = "any"
        elif sp == "no_datafile":
            lines = _drop_line(lines, "ElementDataFile")
        elif sp == "unknown_key":
            lines.insert(2, ["FrontmeshCampaign", "1 2 3"])
            expect = "any"
        elif sp == "space_in_key":
            lines = [[("Dim Size" if l[0] == "DimSize" else l[0]), l[1]] for l in lines]
        elif sp == "colon_sep":
            sep = ": "
            expect = "any"
        elif sp == "empty_value":
            k = rng.choice(["ElementSpacing", "DimSize", "ElementType", "Offset"])
            _set_line(lines, k, "")
        elif sp == "datafile_dir":
            os.makedirs(ctx.p("adir"))
            _set_line(lines, "ElementDataFile", "adir")
            raw_name = None
        elif sp == "datafile_symlink_outside":
            # a data file that is a symlink to a raw file elsewhere: valid data, read only
            shared = os.path.join(ctx.r.shared, "ball12.raw")
            os.symlink(shared, ctx.p("link.raw"))
            _set_line(lines, "ElementDataFile", "link.raw")
            _set_line(lines, "ElementType", "MET_UCHAR")
            _set_line(lines, "DimSize", "12 12 12")
            raw_name = None
            data = b""
            extra = []
            expect = "valid"
        elif sp == "cr_in_type":
            _set_line(lines, "ElementType", lines[-2][1] + "\r")
            expect = "any"
        elif sp == "nul_in_header":
            lines.insert(2, ["Comment", "a\0b"])
            expect = "any"
        write_meta(ctx.p(name), lines, data, sep=sep, eol=eol, raw_name=raw_name)
    ctx.recipe(BASE_RECIPE.replace("img.nii.gz", name))
    argv = ctx.argv("run", "recipe.yaml", extra) if rng.random() < 0.8 else \
        [ctx.fm, "validate", "recipe.yaml"] + extra
    return ctx.spec(argv, expect, "out", desc)


def gen_nrrd(ctx):
    rng = ctx.rng
    ext = rng.choice([".nrrd", ".nrrd", ".nhdr"])
    name = "img" + ext
    n = (12, 12, 12)
    dtype = rng.choice(["u1", "u1", "i2", "u2", "i4", "f4", "f8"])
    vol = shape_volume(rng.choice(["ball", "two", "border"]), n, rng)
    data = pack_voxels([float(x) for x in vol] if dtype in ("f4", "f8") else vol, dtype)
    extra = ["--set", "input.threshold=0.5"] if dtype in ("f4", "f8") else []
    fields = nrrd_fields(n, dtype)
    magic = "NRRD0004"
    detached = "data.raw" if ext == ".nhdr" else None
    if detached:
        fields.append(["data file", "data.raw"])
    table = [
        ("dimension", ["2", "0", "x", "-3", "17"], "invalid"),
        ("dimension", ["4"], "any"),
        ("sizes", ["12 12", "0 12 12", "-12 12 12", "12 12 13", "12 12 99999", "a b c",
                   "12 12 12 12", "12 12 18446744073709551617"], "invalid"),
        ("space directions", ["(0,0,0) (0,1,0) (0,0,1)", "(nan,0,0) (0,1,0) (0,0,1)",
                              "(1,0) (0,1,0) (0,0,1)", "(1,0,0) (0,1,0)",
                              "(1,0,0) (0,1,0) (0,0,1) (1,1,1)", "(1,0,0) (1,0,0) (0,0,1)",
                              "(inf,0,0) (0,1,0) (0,0,1)", "(1e-7,0,0) (0,1,0) (0,0,1)",
                              "garbage", "(1,0,0 (0,1,0) (0,0,1)"], "invalid"),
        ("space directions", ["none (0,1,0) (0,0,1)", "(-1,0,0) (0,-1,0) (0,0,1)",
                              "(0.7,0.7,0) (-0.7,0.7,0) (0,0,2)", "( 1 , 0 , 0 ) (0,1,0) (0,0,1)"],
         "any"),
        ("space origin", ["(1e7,0,0)", "(nan,0,0)", "(1,2)", "(0,0,-inf)", "nope", "(1,2,3,4)"],
         "invalid"),
        ("space origin", ["(999999,0,0)", "( -5 , 3 , 1e2 )"], "any"),
        ("type", ["block", "foo", "", "complex"], "invalid"),
        ("type", ["unsigned char", "uint8", "uint8_t", "int8"], "any"),
        ("encoding", ["foo", "", "zip"], "invalid"),
        ("encoding", ["bzip2", "bz2", "txt", "text", "hex", "gz"], "any"),
        ("endian", ["middle", "", "big"], "any"),
        ("byte skip", ["1000000", "abc", "-2", "1e3"], "invalid"),
        ("byte skip", ["-1", "0"], "any"),
        ("line skip", ["5", "-1", "x", "100000"], "any"),
        ("kinds", ["domain domain", "space space space space", "foo bar baz"], "any"),
        ("space", ["right-anterior-superior", "3D-right-handed", "foo", "scanner-xyz"], "any"),
        ("data file", ["nonexistent.raw", "/dev/zero", ".", "LIST", "slice%02d.raw 0 11 1",
                       "/proc/self/mem", "LIST 3"], "invalid"),
        ("spacings", ["1 1 1", "0 1 1", "nan 1 1", "-1 1 1", "1 1"], "any"),
    ]
    specials = ["short", "extra", "dupfield", "noblank", "crlf", "gzip", "gzip_trunc", "ascii",
                "ascii_short", "hex", "hex_short", "magic", "comment", "no_type", "no_sizes",
                "spacings_only", "no_encoding", "bzip2", "big_endian", "longline"]
    expect = "invalid"
    if rng.random() < 0.6:
        key, vals, expect = rng.choice(table)
        val = rng.choice(vals)
        if key == "dimension" and val == "4":
            _set_line(fields, "sizes", "12 12 12 1")
            _set_line(fields, "kinds", "domain domain domain list")
            _set_line(fields, "space directions", "(1,0,0) (0,1,0) (0,0,1) none")
        if key == "data file":
            detached = None
        if key == "spacings":
            fields = _drop_line(fields, "space directions")
            fields = _drop_line(fields, "space")
            fields = _drop_line(fields, "space origin")
            if val == "1 1 1":
                expect = "valid"
            elif val in ("0 1 1", "nan 1 1", "-1 1 1", "1 1"):
                expect = "invalid"
        if key == "encoding" and val in ("bzip2", "bz2"):
            import bz2
            data = bz2.compress(data)
        elif key == "encoding" and val in ("txt", "text"):
            data = " ".join(str(v) for v in ([float(x) for x in vol] if dtype in ("f4", "f8")
                                             else vol)).encode()
        elif key == "encoding" and val == "hex":
            data = data.hex().encode()
        elif key == "encoding" and val == "gz":
            data = gzip.compress(data)
        if key == "byte skip" and val == "-1":
            data = b"junk" * 10 + data
        if key == "line skip" and val == "5":
            data = b"a\nb\nc\nd\ne\n" + data
        _set_line(fields, key, val, insert_at=len(fields))
        desc = "nrrd%s %s %s: %r" % (ext, dtype, key, val[:40])
    else:
        sp = rng.choice(specials)
        desc = "nrrd%s %s %s" % (ext, dtype, sp)
        if sp == "short":
            data = data[:-rng.randint(1, len(data) // 2)]
        elif sp == "extra":
            data += b"\0" * rng.randint(1, 50)
            expect = "any"
        elif sp == "dupfield":
            k = rng.choice(["sizes", "type", "dimension", "encoding"])
            fields.insert(1, [k, [f[1] for f in fields if f[0] == k][0]])
            expect = "any"
        elif sp == "noblank":
            expect = "any"
        elif sp == "crlf":
            expect = "any"
        elif sp.startswith("gzip"):
            _set_line(fields, "encoding", "gzip")
            data = gzip.compress(data)
            expect = "valid"
            if sp == "gzip_trunc":
                data = data[:rng.randint(10, len(data) - 9)]
                expect = "invalid"
        elif sp.startswith("ascii"):
            _set_line(fields, "encoding", "ascii")
            vals = [float(x) for x in vol] if dtype in ("f4", "f8") else vol
            if sp == "ascii_short":
                vals = vals[:rng.randint(0, len(vals) - 1)]
            else:
                expect = "valid"
            data = " ".join(str(v) for v in vals).encode()
        elif sp.startswith("hex"):
            _set_line(fields, "encoding", "hex")
            data = data.hex().encode()
            if sp == "hex_short":
                data = data[:rng.randint(0, len(data) - 2)]
            else:
                expect = "valid"
        elif sp == "magic":
            magic = rng.choice(["NRRD0001", "NRRD0005", "NRRD0009", "NRRD", "nrrd0004",
                                "NRRD00041", "NRRD000"])
            expect = "any"
            desc += " " + magic
        elif sp == "comment":
            fields.insert(2, ["# a comment", None])
            expect = "valid"
        elif sp == "no_type":
            fields = _drop_line(fields, "type")
        elif sp == "no_sizes":
            fields = _drop_line(fields, "sizes")
        elif sp == "spacings_only":
            fields = _drop_line(fields, "space directions")
            fields = _drop_line(fields, "space")
            fields = _drop_line(fields, "space origin")
            fields.insert(3, ["spacings", "0.5 1 2"])
            expect = "valid"
        elif sp == "no_encoding":
            fields = _drop_line(fields, "encoding")
        elif sp == "bzip2":
            import bz2
            _set_line(fields, "encoding", "bzip2")
            data = bz2.compress(data)
            expect = "any"
        elif sp == "big_endian":
            _set_line(fields, "endian", "big")
            data = pack_voxels([float(x) for x in vol] if dtype in ("f4", "f8") else vol, dtype,
                               big=True)
            expect = "valid"
        elif sp == "longline":
            fields.insert(2, ["# " + "z" * rng.choice([5000, 300000]), None])
            expect = "any"
        if sp in ("noblank", "crlf"):
            text = magic + "\n" + "".join(k + ": " + v + "\n" for k, v in fields)
            if sp == "crlf":
                text = text.replace("\n", "\r\n") + "\r\n"
            path = ctx.p(name)
            if detached:
                open(path, "wb").write(text.encode())
                open(ctx.p(detached), "wb").write(data)
            else:
                open(path, "wb").write(text.encode() + data)
            ctx.recipe(BASE_RECIPE.replace("img.nii.gz", name))
            return ctx.spec(ctx.argv("run", "recipe.yaml", extra), expect, "out", desc)
    write_nrrd(ctx.p(name), fields, data, magic=magic, detached=detached)
    ctx.recipe(BASE_RECIPE.replace("img.nii.gz", name))
    argv = ctx.argv("run", "recipe.yaml", extra) if rng.random() < 0.8 else \
        [ctx.fm, "validate", "recipe.yaml"] + extra
    return ctx.spec(argv, expect, "out", desc)


def write_any_image(ctx, name, vol, n, dtype, spacing=(1, 1, 1), origin=(0, 0, 0),
                    direction=None, version=1):
    path = ctx.p(name)
    vals = [float(x) for x in vol] if dtype in ("f4", "f8") else vol
    data = pack_voxels(vals, dtype)
    if name.endswith((".nii", ".nii.gz", ".hdr")):
        def mut(h):
            if direction:
                d = direction
                h["srow"] = [d[0] * spacing[0], d[1] * spacing[1], d[2] * spacing[2], origin[0],
                             d[3] * spacing[0], d[4] * spacing[1], d[5] * spacing[2], origin[1],
                             d[6] * spacing[0], d[7] * spacing[1], d[8] * spacing[2], origin[2]]
                h["qform_code"] = 0
        write_nifti(path, vol if dtype not in ("f4", "f8") else vals, n, dtype, version,
                    spacing=spacing, origin=origin, mutate=mut)
    elif name.endswith((".mha", ".mhd")):
        lines = meta_lines(n, dtype, spacing, origin, local=name.endswith(".mha"))
        if direction:
            _set_line(lines, "TransformMatrix", " ".join(repr(float(x)) for x in direction))
        write_meta(path, lines, data, raw_name=None if name.endswith(".mha") else "data.raw")
    else:
        f = nrrd_fields(n, dtype, spacing, origin)
        if direction:
            d = direction
            _set_line(f, "space directions", " ".join(
                "(%r,%r,%r)" % (d[c] * spacing[c], d[3 + c] * spacing[c], d[6 + c] * spacing[c])
                for c in range(3)))
        if name.endswith(".nhdr"):
            f.append(["data file", "data.raw"])
        write_nrrd(path, f, data, detached="data.raw" if name.endswith(".nhdr") else None)
    return path


def rotation(rng):
    a, b = rng.uniform(0, math.pi), rng.uniform(0, math.pi)
    ca, sa, cb, sb = math.cos(a), math.sin(a), math.cos(b), math.sin(b)
    rz = [ca, -sa, 0, sa, ca, 0, 0, 0, 1]
    rx = [1, 0, 0, 0, cb, -sb, 0, sb, cb]
    return [sum(rz[3 * i + k] * rx[3 * k + j] for k in range(3)) for i in range(3)
            for j in range(3)]


def summary_checks(out, formats=(), want_warning_label=None):
    """Extra checks of a completed run's folder."""
    def check(rc, stdout, stderr):
        v = []
        if rc != 0:
            return v
        sj = os.path.join(out, "summary.json")
        try:
            s = json.load(open(sj))
        except Exception as e:  # noqa: BLE001
            return ["exit 0 but summary.json unreadable: %s" % e]
        if s.get("status") != "ok":
            v.append("exit 0 but summary.json status %r" % s.get("status"))
        outs = s.get("outputs") or []
        for o in outs if isinstance(outs, list) else []:
            name = o.get("file") or o.get("path") or o.get("name")
            if not name:
                continue
            full = name if os.path.isabs(name) else os.path.join(out, name)
            if not os.path.exists(full):
                v.append("summary.json lists %s, which is not there" % name)
            elif o.get("bytes", o.get("size")) not in (None, os.path.getsize(full)) and \
                    not full.endswith("frontmesh.log"):
                v.append("summary.json gives %s %s bytes, the file has %d" %
                         (name, o.get("bytes", o.get("size")), os.path.getsize(full)))
        for f in formats:
            fn = {"msh": "mesh.msh", "msh22": "mesh.v22.msh", "mesh": "mesh.mesh",
                  "inp": "mesh.inp", "feb": "mesh.feb", "vtu": "mesh.vtu"}[f]
            if not os.path.exists(os.path.join(out, fn)):
                v.append("format %s asked for, %s not written" % (f, fn))
        if want_warning_label is not None:
            text = stderr + json.dumps(s)
            if not re.search(r"label %d\b" % want_warning_label, text):
                v.append("label %d (one voxel) neither warned about nor in dropped_components"
                         % want_warning_label)
        return v
    return check


def gen_valid(ctx):
    rng = ctx.rng
    fmt_name = rng.choice(["img.nii", "img.nii.gz", "img.hdr", "img.mha", "img.mhd", "img.nrrd",
                           "img.nhdr"] * 4 + ["img2.nii.gz"])
    version = 2 if fmt_name.startswith("img2") else 1
    name = fmt_name.replace("img2", "img")
    kind = rng.choice(["tiny", "aniso", "onevoxel", "border", "int16", "float", "blobs",
                       "oblique", "farorigin", "ras", "noncubic", "biglabel", "exports",
                       "single", "thin", "labels_subset", "twolabel_touching_border"])
    n = (rng.randint(12, 18), rng.randint(12, 18), rng.randint(12, 18))
    spacing = (1.0, 1.0, 1.0)
    origin = (rng.uniform(-50, 50), rng.uniform(-50, 50), rng.uniform(-50, 50))
    direction = None
    dtype = rng.choice(["u1", "i2", "u2", "i4"])
    extra = []
    recipe_extra = ""
    formats = []
    warn_label = None
    allow_refusal = True
    vol = None
    if kind == "tiny":
        n = tuple(rng.randint(1, 5) for _ in range(3))
        vol = [1] * (n[0] * n[1] * n[2])
        spacing = tuple(rng.choice([1.0, 2.0, 5.0]) for _ in range(3))
    elif kind == "aniso":
        spacing = tuple(round(rng.choice([0.2, 0.5, 1.0, 2.0, 3.5]) * rng.uniform(0.8, 1.2), 3)
                        for _ in range(3))
        # a ball in mm: radius ~ 5 mm
        nx, ny, nz = n = tuple(max(6, min(24, int(12 / s) + 2)) for s in spacing)
        cmm = [(n[i] - 1) * spacing[i] / 2 for i in range(3)]
        r = min(cmm) * 0.8
        vol = [1 if sum(((idx[i]) * spacing[i] - cmm[i]) ** 2 for i in range(3)) <= r * r else 0
               for idx in ((i, j, k) for k in range(nz) for j in range(ny) for i in range(nx))]
    elif kind == "onevoxel":
        vol = shape_volume("ball", n, rng)
        # one voxel of label 2 well away from the ball (a corner region)
        i, j, k = 1, 1, 1
        vol[(k * n[1] + j) * n[0] + i] = 2
        spacing = (0.8, 0.8, 0.8)  # 0.512 mm^3, under repair.min_component_volume_mm3 = 1
        warn_label = 2
    elif kind == "border":
        vol = shape_volume("border", n, rng)
    elif kind == "int16":
        dtype = rng.choice(["i2", "u2"])
        a, b = rng.choice([(1000, 2000), (300, 30000), (7, 65535 if dtype == "u2" else 32767)])
        vol = [a if x == 1 else b if x == 2 else 0 for x in shape_volume("two", n, rng)]
    elif kind == "float":
        dtype = rng.choice(["f4", "f8"])
        c = [(n[i] - 1) / 2 for i in range(3)]
        vol = [100.0 - 10 * math.sqrt(sum((idx[i] - c[i]) ** 2 for i in range(3)))
               for idx in ((i, j, k) for k in range(n[2]) for j in range(n[1])
                           for i in range(n[0]))]
        thr = rng.choice([50.0, 55.5, 60.0])
        extra = ["--set", "input.threshold=%r" % thr]
    elif kind == "blobs":
        vol = shape_volume("blobs", n, rng)
    elif kind == "oblique":
        direction = rotation(rng)
        vol = shape_volume(rng.choice(["ball", "two"]), n, rng)
    elif kind == "farorigin":
        origin = tuple(rng.choice([-1, 1]) * rng.uniform(1e5, 9.9e5) for _ in range(3))
        vol = shape_volume("ball", n, rng)
    elif kind == "ras":
        recipe_extra = "  frame: ras\n"
        vol = shape_volume("nested", n, rng)
    elif kind == "noncubic":
        n = (rng.randint(6, 10), rng.randint(18, 24), rng.randint(10, 14))
        vol = shape_volume("blobs", n, rng)
    elif kind == "biglabel":
        dtype = "i4"
        lab = rng.choice([99999, 21473, 100001, 2 ** 31 - 1, 65536])
        vol = [lab if x else 0 for x in shape_volume("ball", n, rng)]
    elif kind == "exports":
        vol = shape_volume("two", n, rng)
        formats = rng.sample(["msh", "msh22", "inp", "feb", "mesh"], rng.randint(1, 4))
        order = rng.choice([1, 1, 2])
        if order == 2 and "mesh" in formats:
            formats.remove("mesh")
        if not formats:
            formats = ["msh"]
        recipe_extra = "  formats: [vtu, %s]\n  order: %d\n  binary: %s\n  split_interfaces: %s\n" \
            % (", ".join(formats), order, rng.choice(["true", "false"]),
               rng.choice(["none", "all", "[[1, 2]]"]))
    elif kind == "single":
        vol = [0] * (n[0] * n[1] * n[2])
        vol[(n[2] // 2 * n[1] + n[1] // 2) * n[0] + n[0] // 2] = 1
    elif kind == "thin":
        vol = [0] * (n[0] * n[1] * n[2])
        k = n[2] // 2
        for j in range(2, n[1] - 2):
            for i in range(2, n[0] - 2):
                vol[(k * n[1] + j) * n[0] + i] = 1
    elif kind == "labels_subset":
        vol = shape_volume("nested", n, rng)
        extra = ["--set", "input.labels=[%d]" % rng.choice([1, 2])]
    elif kind == "twolabel_touching_border":
        vol = [0] * (n[0] * n[1] * n[2])
        for k in range(n[2]):
            for j in range(n[1]):
                for i in range(n[0]):
                    if i < n[0] // 2 and j < n[1] - 3:
                        vol[(k * n[1] + j) * n[0] + i] = 1
                    elif j < n[1] - 3:
                        vol[(k * n[1] + j) * n[0] + i] = 2
    if dtype in ("f4", "f8") and not extra:
        extra = ["--set", "input.threshold=0.5"]
    write_any_image(ctx, name, vol, n, dtype, spacing, origin, direction, version)
    ctx.recipe("input:\n  image: %s\noutput:\n  dir: out\n%s" % (name, recipe_extra))
    argv = ctx.argv("run", "recipe.yaml", extra)
    desc = "valid %s %s %s n=%s spacing=%s" % (kind, fmt_name, dtype, n, spacing)
    return ctx.spec(argv, "valid", "out", desc, extra=summary_checks(ctx.p("out"), formats,
                                                                      warn_label),
                    allow_refusal=allow_refusal)


# ------------------------------------------------------------------------------ surfaces


def gen_surface(ctx):
    rng = ctx.rng
    ext = rng.choice(["stl", "stlb", "off", "ply", "plyb", "vtp", "vtu"])
    level = rng.choice([1, 2, 2])
    pts, faces = icosphere(level, r=rng.choice([4.0, 5.0, 6.0]),
                           c=(rng.uniform(-20, 20), rng.uniform(-20, 20), rng.uniform(-20, 20)))
    regions = None
    muts = ["none", "none", "truncate", "nan", "inf", "far", "tiny", "index_big", "index_neg",
            "degenerate", "open", "open_big", "flip_some", "flip_all", "self_intersect",
            "duplicate", "fin", "empty", "single", "count_big", "count_small", "quads",
            "random_bytes", "two_shells", "nested_regions", "bad_regions", "scale_big",
            "coincident_points", "zero_area_sliver", "header_garbage", "touch_vertex",
            "touch_edge"]
    m = rng.choice(muts)
    expect = "any"
    body = None
    fname = "surf." + ext.rstrip("b")
    if m == "none":
        expect = "valid"
    elif m == "nan":
        pts[rng.randrange(len(pts))][rng.randrange(3)] = float("nan")
        expect = "invalid"
    elif m == "inf":
        pts[rng.randrange(len(pts))][rng.randrange(3)] = rng.choice([float("inf"),
                                                                     float("-inf")])
        expect = "invalid"
    elif m == "far":
        pts[rng.randrange(len(pts))][rng.randrange(3)] = rng.choice([2e7, -1e30, 1e15])
        expect = "invalid"
    elif m == "tiny":
        pts = [[x * 1e-6 for x in p] for p in pts]
        expect = "invalid"
    elif m == "scale_big":
        pts = [[x * 1e7 for x in p] for p in pts]  # beyond 10 km
        expect = "invalid"
    elif m == "index_big":
        faces[rng.randrange(len(faces))][rng.randrange(3)] = rng.choice([len(pts), len(pts) + 7,
                                                                        2 ** 31 - 1])
        expect = "invalid" if ext not in ("stl", "stlb") else "any"
    elif m == "index_neg":
        faces[rng.randrange(len(faces))][rng.randrange(3)] = rng.choice([-1, -2 ** 31])
        expect = "invalid" if ext not in ("stl", "stlb") else "any"
    elif m == "degenerate":
        for _ in range(rng.randint(1, 3)):
            f = faces[rng.randrange(len(faces))]
            f[1] = f[0]
    elif m == "open":
        for _ in range(rng.randint(1, 3)):
            faces.pop(rng.randrange(len(faces)))
    elif m == "open_big":
        faces = [f for f in faces if sum(pts[v][2] for v in f) / 3 < pts[0][2] +
                 rng.uniform(-2, 2)]
    elif m == "flip_some":
        for _ in range(rng.randint(1, len(faces) // 3)):
            f = faces[rng.randrange(len(faces))]
            f[1], f[2] = f[2], f[1]
    elif m == "flip_all":
        faces = [[f[0], f[2], f[1]] for f in faces]
    elif m == "self_intersect":
        p2, f2 = icosphere(level, r=5.0, c=(pts[0][0] + 3, pts[0][1], pts[0][2]))
        c0 = [sum(p[i] for p in pts) / len(pts) for i in range(3)]
        p2, f2 = icosphere(level, r=5.0, c=(c0[0] + 4, c0[1], c0[2]))
        off = len(pts)
        pts += p2
        faces += [[v + off for v in f] for f in f2]
        expect = "invalid"
    elif m == "two_shells":
        c0 = [sum(p[i] for p in pts) / len(pts) for i in range(3)]
        p2, f2 = icosphere(level, r=3.0, c=(c0[0] + 15, c0[1], c0[2]))
        off = len(pts)
        pts += p2
        faces += [[v + off for v in f] for f in f2]
        expect = "valid"
    elif m in ("touch_vertex", "touch_edge"):
        # A copy of the (convex) sphere reflected through one of its vertices, or through the
        # midpoint of one of its edges: the two bodies touch there only, and the domain's
        # outer boundary is not a manifold (refused, or split at a point by repair).
        a, b, _ = faces[rng.randrange(len(faces))]
        if m == "touch_vertex":
            centre, weld = pts[a], {a: a}
        else:
            centre, weld = [(pts[a][i] + pts[b][i]) / 2 for i in range(3)], {a: b, b: a}
        copy = {}
        for v, p in enumerate(list(pts)):
            if v in weld:
                copy[v] = weld[v]
            else:
                copy[v] = len(pts)
                pts.append([2 * centre[i] - p[i] for i in range(3)])
        faces += [[copy[f[0]], copy[f[2]], copy[f[1]]] for f in faces[:]]  # reflected: reversed
    elif m == "duplicate":
        for _ in range(rng.randint(1, 5)):
            faces.append(list(faces[rng.randrange(len(faces))]))
    elif m == "fin":
        a, b, _ = faces[0]
        pts.append([pts[a][i] * 1.0 + rng.uniform(2, 3) for i in range(3)])
        faces.append([a, b, len(pts) - 1])
        expect = "invalid"
    elif m == "empty":
        pts, faces = [], []
        expect = "invalid"
    elif m == "single":
        pts, faces = [[0, 0, 0], [5, 0, 0], [0, 5, 0]], [[0, 1, 2]]
    elif m == "quads":
        if ext in ("off", "ply", "vtp", "vtu"):
            pts2 = [[0, 0, 0], [6, 0, 0], [6, 6, 0], [0, 6, 0], [0, 0, 6], [6, 0, 6], [6, 6, 6],
                    [0, 6, 6]]
            faces = [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6],
                     [3, 0, 4, 7]]
            pts = pts2
    elif m == "nested_regions" and ext in ("vtp", "vtu"):
        c0 = [sum(p[i] for p in pts) / len(pts) for i in range(3)]
        R = math.sqrt(sum((pts[0][i] - c0[i]) ** 2 for i in range(3)))
        p2, f2 = icosphere(level, r=R / 2.0, c=tuple(c0))
        nf = len(faces)
        off = len(pts)
        pts += p2
        faces += [[v + off for v in f] for f in f2]
        regions = ([1] * nf + [2] * len(f2), [0] * nf + [1] * len(f2))
        expect = "valid"
    elif m == "bad_regions" and ext in ("vtp", "vtu"):
        how = rng.choice(["in_zero", "out_neg", "equal", "short", "in_neg"])
        rin, rout = [1] * len(faces), [0] * len(faces)
        k = rng.randrange(len(faces))
        if how == "in_zero":
            rin[k] = 0
        elif how == "out_neg":
            rout[k] = -3
        elif how == "equal":
            rout[k] = 1
        elif how == "in_neg":
            rin[k] = -1
        else:
            rin = rin[:-5]
        regions = (rin, rout)
        expect = "invalid"
    elif m == "coincident_points":
        # every vertex written twice, faces using the copies at random: merged by repair
        n0 = len(pts)
        pts = pts + [list(p) for p in pts]
        faces = [[v + n0 * rng.randint(0, 1) for v in f] for f in faces]
        expect = "any"
    elif m == "zero_area_sliver":
        a, b, c = faces[0]
        mid = [(pts[a][i] + pts[b][i]) / 2 for i in range(3)]
        pts.append(mid)
        faces[0] = [a, len(pts) - 1, c]
        faces.append([len(pts) - 1, b, c])
        faces.append([a, b, len(pts) - 1])  # zero area, on the edge
    # serialise
    if ext == "stl":
        body = stl_ascii(pts, faces)
    elif ext == "stlb":
        body = stl_binary(pts, faces, header=b"solid pretending to be ascii"
                          if rng.random() < 0.3 else b"campaign")
    elif ext == "off":
        body = off_text(pts, faces)
    elif ext == "ply":
        body = ply_text(pts, faces)
    elif ext == "plyb":
        body = ply_text(pts, faces, binary=True,
                        index_type=rng.choice(["int", "uint", "int32"]))
    else:
        arrays = None
        if regions:
            arrays = [("region_in", "Int32", regions[0]), ("region_out", "Int32", regions[1])]
        body = vtk_xml(ext, pts, faces, arrays)
    if m == "truncate":
        cut = rng.randint(1, len(body) - 1)
        whole = body[cut:].strip() == b""
        body = body[:cut]
        expect = "invalid" if ext in ("stlb", "off", "vtp", "vtu", "plyb") and not whole \
            else "any"
    elif m == "count_big":
        if ext == "stlb":
            body = stl_binary(pts, faces, count=len(faces) + rng.choice([1, 1000, 2 ** 31]))
        elif ext == "off":
            body = off_text(pts, faces, nf=len(faces) + rng.choice([1, 10 ** 9]))
        elif ext in ("ply", "plyb"):
            body = ply_text(pts, faces, binary=ext == "plyb",
                            nv=len(pts) + rng.choice([1, 2 ** 31 - 1]))
        elif ext in ("vtp", "vtu"):
            body = vtk_xml(ext, pts, faces, npts=len(pts) + rng.choice([1, 10 ** 6]))
        expect = "invalid" if ext != "stl" else "any"
    elif m == "count_small":
        if ext == "stlb":
            body = stl_binary(pts, faces, count=max(0, len(faces) - rng.randint(1, 10)))
        elif ext == "off":
            body = off_text(pts, faces, nf=max(0, len(faces) - rng.randint(1, 10)))
        elif ext in ("ply", "plyb"):
            body = ply_text(pts, faces, binary=ext == "plyb", nf=max(0, len(faces) - 3))
        elif ext in ("vtp", "vtu"):
            body = vtk_xml(ext, pts, faces, ncells=max(0, len(faces) - 3))
    elif m == "random_bytes":
        b = bytearray(body)
        for _ in range(rng.randint(1, 20)):
            b[rng.randrange(len(b))] = rng.randrange(256)
        body = bytes(b)
    elif m == "header_garbage":
        body = bytes(rng.randrange(256) for _ in range(rng.randint(0, 100))) + body
    ctx.write(fname, body)
    mode = rng.choice(["run", "run", "from_tetra", "from_remesh", "until_repair", "validate",
                       "validate_tetra"])
    argv = ctx.argv("run", "recipe.yaml")
    mesh = True
    if mode == "from_tetra":
        argv += ["--from", "tetra"]
    elif mode == "from_remesh":
        argv += ["--from", "remesh"]
    elif mode == "until_repair":
        argv += ["--until", "repair"]
        mesh = False
    elif mode.startswith("validate"):
        argv = [ctx.fm, "validate", "recipe.yaml"] + (["--from", "tetra"] if mode.endswith(
            "tetra") else [])
    ctx.recipe("input:\n  surface: %s\noutput:\n  dir: out\n" % fname)
    desc = "surface .%s level %d: %s (%s)" % (ext, level, m, mode)
    if mode in ("from_tetra", "validate_tetra") and m in ("open", "open_big", "flip_some",
                                                          "flip_all", "degenerate",
                                                          "duplicate", "single", "quads",
                                                          "coincident_points",
                                                          "zero_area_sliver"):
        expect = "any"  # meshed as it is: must be closed and oriented
    if mode == "validate" and m in ("self_intersect", "fin"):
        expect = "any"  # README: plain validate checks coordinates and labels only
    return ctx.spec(argv, expect, "out", desc, mesh=mesh)


# ------------------------------------------------------------------------------ meshes


def mesh_bytes(fmtname, pts, tets, regions):
    if fmtname == "vtu":
        return vtk_xml("vtu", pts, tets, [("region", "Int32", regions)], cell_type=10)
    if fmtname == "msh22":
        return msh22(pts, tets, regions)
    if fmtname == "msh41":
        return msh41(pts, tets, regions)
    if fmtname == "mesh":
        return medit(pts, tets, regions)
    return abaqus(pts, tets, regions)


MESH_EXT = {"vtu": "vtu", "msh22": "msh", "msh41": "msh", "mesh": "mesh", "inp": "inp"}


def gen_mesh(ctx):
    rng = ctx.rng
    src = rng.choice(["hand", "hand", "ref"])
    want = None  # exit codes allowed for check
    m = rng.choice(["none", "none", "inverted", "duplicate", "nan", "far", "index_big",
                    "index_zero", "truncate", "count_big", "flip_bytes", "flat", "unused",
                    "empty", "overlap", "nonconforming", "negative_region", "huge_region",
                    "tiny_scale"])
    if src == "ref":
        refdir = os.path.join(ctx.r.shared, "ref", "out")
        choices = [f for f in ("mesh.vtu", "mesh.msh", "mesh.v22.msh", "mesh.inp", "mesh.mesh")
                   if os.path.exists(os.path.join(refdir, f))]
        f = rng.choice(choices)
        data = open(os.path.join(refdir, f), "rb").read()
        ext = f.split(".")[-1]
        fname = "in." + ext
        if m in ("none",):
            want = {0}
        elif m == "truncate":
            cut = rng.randint(0, len(data) - 1)
            whole = data[cut:].strip() == b""
            data = data[:cut]
            want = {2} if ext == "vtu" and not whole else {0, 1, 2}
        else:
            b = bytearray(data)
            for _ in range(rng.randint(1, 30)):
                b[rng.randrange(len(b))] = rng.randrange(256)
            data = bytes(b)
            m = "flip_bytes"
            want = {0, 1, 2}
        ctx.write(fname, data)
        desc = "mesh ref %s %s" % (f, m)
    else:
        fmtname = rng.choice(["vtu", "msh22", "msh41", "mesh", "inp"])
        pts, tets, regions = cube_tets(rng.choice([1, 2, 3]), rng.choice([1.0, 0.5, 3.0]))
        want = {0}
        if m == "inverted":
            t = tets[rng.randrange(len(tets))]
            t[0], t[1] = t[1], t[0]
            want = {1}
        elif m == "duplicate":
            k = rng.randrange(len(tets))
            tets.append(list(tets[k]))
            regions.append(regions[k])
            want = {1}
        elif m == "nan":
            pts[rng.randrange(len(pts))][rng.randrange(3)] = float("nan")
            want = {2}
        elif m == "far":
            pts[rng.randrange(len(pts))][rng.randrange(3)] = rng.choice([1e8, -1e12])
            want = {2}
        elif m == "tiny_scale":
            pts = [[x * 1e-9 for x in p] for p in pts]
            want = {2}
        elif m == "index_big":
            tets[rng.randrange(len(tets))][rng.randrange(4)] = len(pts) + rng.choice([0, 5, 10 ** 9])
            want = {2}
        elif m == "index_zero":
            tets[rng.randrange(len(tets))][rng.randrange(4)] = -1  # written as 0 in 1-based
            want = {2} if fmtname != "vtu" else {2}
        elif m == "flat":
            t = tets[rng.randrange(len(tets))]
            t[3] = t[2]
            want = {1, 2}
        elif m == "unused":
            pts.append([100.0, 100.0, 100.0])
            want = {0, 1}
        elif m == "empty":
            tets, regions = [], []
            want = {1, 2}
        elif m == "overlap":
            k = rng.randrange(len(tets))
            t = list(tets[k])
            # a tet sharing 3 nodes with k and lying on the same side (its 4th point nearby)
            c = [sum(pts[v][i] for v in t) / 4.0 for i in range(3)]
            pts.append([c[i] + 0.01 * (pts[t[3]][i] - c[i]) for i in range(3)])
            t2 = [t[0], t[1], t[2], len(pts) - 1]
            tets.append(t2)
            regions.append(regions[k])
            want = {1}
        elif m == "nonconforming":
            # move one interior node far off so that tets overlap / invert
            inner = [i for i, p in enumerate(pts) if all(0 < x < max(max(q) for q in pts)
                                                           for x in p)]
            if inner:
                pts[inner[0]][0] += 5.0
                want = {1}
        elif m == "negative_region":
            regions = [-r for r in regions]
            want = {0, 1, 2}
        elif m == "huge_region":
            regions = [r + 2 ** 31 - 3 for r in regions]
            want = {0, 1, 2}
        data = mesh_bytes(fmtname, pts, tets, regions)
        if m == "truncate":
            cut = rng.randint(0, len(data) - 1)
            whole = data[cut:].strip() == b""
            data = data[:cut]
            want = {2} if fmtname == "vtu" and not whole else {0, 1, 2}
        elif m == "count_big":
            if fmtname == "msh22":
                data = msh22(pts, tets, regions, nn=len(pts) + rng.choice([1, 10 ** 9]))
            elif fmtname == "mesh":
                data = medit(pts, tets, regions, nt=len(tets) + rng.choice([1, 10 ** 9]))
            elif fmtname == "vtu":
                data = vtk_xml("vtu", pts, tets, [("region", "Int32", regions)], cell_type=10,
                               npts=len(pts) + rng.choice([1, 10 ** 7]))
            want = {2} if fmtname in ("msh22", "mesh", "vtu") else {0, 1, 2}
        elif m == "flip_bytes":
            b = bytearray(data)
            for _ in range(rng.randint(1, 10)):
                b[rng.randrange(len(b))] = rng.randrange(256)
            data = bytes(b)
            want = {0, 1, 2}
        fname = "in." + MESH_EXT[fmtname]
        ctx.write(fname, data)
        desc = "mesh %s cube %s" % (fmtname, m)
    cmd = rng.choice(["check", "check", "check_json", "check_surface", "convert"])
    if cmd == "convert":
        os.makedirs(ctx.p("conv"))
        outfmt = rng.choice(["vtu", "msh", "mesh", "inp", "feb", "msh22"])
        outname = "conv/out." + {"msh22": "msh"}.get(outfmt, outfmt)
        argv = [ctx.fm, "convert", fname, outname]
        if outfmt == "msh22" or rng.random() < 0.2:
            argv += ["--format", outfmt]
        convert_want = {0} if want == {0} else {0, 2} if want != {2} else {2}
        if want == {1}:
            convert_want = {0, 2}

        def extra(rc, out, err, cw=convert_want, outpath=ctx.p(outname)):
            v = []
            if rc not in cw:
                v.append("convert exit %d, expected %s" % (rc, sorted(cw)))
            if rc == 0 and not os.path.exists(outpath):
                v.append("convert exit 0 but %s not written" % outpath)
            return v
        spec = ctx.spec(argv, "convert", "conv", desc + " -> convert " + outfmt, extra=extra)
        return spec
    argv = [ctx.fm, "check", fname]
    if cmd == "check_json":
        argv.append("--json")
    if cmd == "check_surface":
        sname = rng.choice(["ref.stl", "ref.off", "ref.vtp", "ref.ply"])
        p, f = icosphere(1, 3.0)
        write_surface(ctx.p(sname), p, f)
        if rng.random() < 0.5:
            b = bytes(open(ctx.p(sname), "rb").read())
            cut = rng.randint(1, len(b) - 1)
            whole = b[cut:].strip() == b""
            open(ctx.p(sname), "wb").write(b[:cut])
            desc += " with a truncated --surface"
            want = {2} | want
            if sname.endswith(("stl", "ply")) or whole:
                want = {0, 1, 2}
        else:
            want = {1, 2} if want == {0} else want | {1}
            desc += " with a foreign --surface"
        argv += ["--surface", sname]

    def extra(rc, out, err, w=want):
        if rc not in w:
            return ["check exit %d, expected %s" % (rc, sorted(w))]
        if cmd == "check_json" and rc in (0, 1):
            try:
                json.loads(out)
            except ValueError as e:
                return ["check --json printed invalid JSON: %s" % e]
        return []
    return ctx.spec(argv, "check", None, desc + " (" + cmd + ")", extra=extra)


# ------------------------------------------------------------------------------ command lines


def gen_cli(ctx):
    rng = ctx.rng
    ctx.image("img.nii.gz", "ball", n=(12, 12, 12))
    ctx.recipe(BASE_RECIPE)
    fm = ctx.fm
    stages = ["extract", "repair", "remesh", "tetra", "refine"]
    t = rng.choice(["badflag", "fromuntil", "threads", "missing", "extra_pos", "meshcmd",
                    "help", "recipe_path", "repeat", "unknown_cmd", "wrongcmd_flag",
                    "threads", "fromuntil", "meshcmd", "recipe_path", "odd_set", "empty_args"])
    expect = "invalid"
    out = "out"
    mesh = True
    if t == "badflag":
        flag = rng.choice(["--frm", "--threads=2", "-x", "---set", "--SET", "--until=tetra",
                           "--quiet=yes", "--force=1", "-", "--", "--from=repair", "-J", "-jx",
                           "--jobs=2", "-o=x", "--help-me", "-vv", "--outdir", "-q"])
        argv = ctx.argv("run") + [flag]
        if flag in ("-", "--"):
            expect = "invalid"
        desc = "run with %s" % flag
    elif t == "fromuntil":
        a, b = rng.choice(stages), rng.choice(stages + ["nothing", "", "EXTRACT", "all",
                                                        "03-remesh", "tetra "])
        how = rng.choice(["both", "from", "until"])
        if how == "both":
            argv = ctx.argv("run") + ["--from", a, "--until", b]
            if b == "":
                expect = "any"  # an empty --until: README does not say
            elif b in stages and stages.index(b) >= stages.index(a):
                expect = "any"  # fresh folder: --from needs the checkpoint before it
                if a == "extract":
                    expect = "valid"
                    mesh = b == "refine" or b == "tetra"
            desc = "--from %s --until %r" % (a, b)
        elif how == "from":
            argv = ctx.argv("run") + ["--from", b]
            expect = "valid" if b == "extract" else "any" if b == "" else "invalid"
            desc = "--from %r on a fresh folder" % b
        else:
            argv = ctx.argv("run") + ["--until", b]
            expect = "valid" if b in stages else "any" if b == "" else "invalid"
            mesh = b in ("tetra", "refine") or b == ""
            desc = "--until %r" % b
    elif t == "threads":
        v = rng.choice(["0", "-1", "abc", "", "1.5", "2x", "99999999999", "1e3", " 2", "0x2",
                        "-0", "+1", "1", "64", "2"])
        argv = ctx.argv("run", extra=[])
        argv = [fm, "run", "recipe.yaml", "--quiet", "--threads", v]
        expect = "valid" if v in ("1", "64", "2", "+1", " 2") else "invalid"
        if v in ("+1", " 2", "1e3", "1.5", "2x", "0x2"):
            expect = "any"  # stoi reads a prefix; README says nothing
        desc = "--threads %r" % v
    elif t == "missing":
        argv = rng.choice([[fm, "run"], [fm, "validate"], [fm, "check"], [fm, "convert", "a.vtu"],
                           [fm, "mesh"], [fm, "cohort", "m.csv"], [fm, "run", "recipe.yaml",
                                                                    "--set"],
                           [fm, "run", "recipe.yaml", "--from"], [fm, "cohort"],
                           [fm, "convert"], [fm, "run", "recipe.yaml", "--threads"],
                           [fm, "mesh", "img.nii.gz", "-o"], [fm, "check", "--json"]])
        desc = "missing argument: %s" % " ".join(argv[1:])
    elif t == "extra_pos":
        argv = rng.choice([[fm, "run", "recipe.yaml", "more"], [fm, "validate", "recipe.yaml",
                                                                 "b", "c"],
                           [fm, "check", "a.vtu", "b.vtu"], [fm, "keys", "extra"],
                           [fm, "convert", "a", "b", "c"]])
        expect = "any" if argv[1] == "keys" else "invalid"
        if argv[1] == "keys":
            out = None
        desc = "extra positional: %s" % " ".join(argv[1:])
    elif t == "meshcmd":
        opt = rng.choice([["--labels", "1,x"], ["--labels", ""], ["--labels", "nosuch.txt"],
                          ["--size", "-1"], ["--size", ".nan"], ["--size", "abc"],
                          ["--size", "1e-9"], ["--format", "stl"], ["--format", "msh,,inp"],
                          ["--format", ""], ["-o", "."], ["-o", "afile"], ["--size", "0"],
                          ["--labels", "1"], ["--labels", "all"], ["--labels", "0"],
                          ["--labels", "1, 1"], ["--from", "tetra"], ["--json"],
                          ["--size", "1e400"], ["--size", "[1]"], ["--size", "1\nremesh:"],
                          ["--format", "vtu,vtu"], ["--labels", "-1"],
                          ["--size", "2", "--set", "remesh.edge_length=3"]])
        ctx.write("afile", b"x")
        argv = [fm, "mesh", "img.nii.gz", "--quiet", "--threads", "1"] + \
            (["-o", "out"] if "-o" not in opt else []) + opt
        good = {("--size", "0"), ("--labels", "1"), ("--labels", "all"), ("--format", "msh,,inp"),
                ("--size", "2", "--set", "remesh.edge_length=3")}
        expect = "valid" if tuple(opt) in good else "invalid"
        if tuple(opt) in {("--labels", ""), ("--format", ""), ("--labels", "1, 1")}:
            expect = "any"
        if "-o" in opt and opt[-1] == ".":
            out = ctx.dir
        desc = "mesh %s" % " ".join(opt)
    elif t == "help":
        argv = rng.choice([[fm, "--help"], [fm, "run", "--help"], [fm, "help"], [fm, "-h"],
                           [fm, "--version"], [fm, "keys"], [fm, "bogus", "--help"],
                           [fm, "run", "nosuch.yaml", "--version"]])
        expect = "info"
        out = None
        desc = "info: %s" % " ".join(argv[1:])
    elif t == "recipe_path":
        how = rng.choice(["folder", "devnull", "fifo", "missing", "empty_name", "loop",
                          "long", "dangling", "proc", "socketish", "stdin"])
        if how == "folder":
            os.makedirs(ctx.p("afolder.yaml"))
            rp = "afolder.yaml"
        elif how == "devnull":
            rp = "/dev/null"
        elif how == "fifo":
            os.mkfifo(ctx.p("fifo.yaml"))
            rp = "fifo.yaml"
        elif how == "missing":
            rp = "nosuch.yaml"
        elif how == "empty_name":
            rp = ""
        elif how == "loop":
            os.symlink("loop.yaml", ctx.p("loop.yaml"))
            rp = "loop.yaml"
        elif how == "long":
            rp = "r" * rng.choice([300, 5000]) + ".yaml"
        elif how == "dangling":
            os.symlink("gone.yaml", ctx.p("dangling.yaml"))
            rp = "dangling.yaml"
        elif how == "proc":
            rp = "/proc/self/status"
        elif how == "socketish":
            rp = "/dev/zero"
        else:
            rp = "/dev/stdin"
        argv = [fm, rng.choice(["run", "validate"]), rp, "--quiet"]
        desc = "recipe path %s (%s)" % (how, rp[:40])
    elif t == "repeat":
        argv = rng.choice([ctx.argv("run") + ["--threads", "2"],
                           ctx.argv("run") + ["--force", "--force", "--quiet"],
                           ctx.argv("run") + ["--until", "repair", "--until", "extract"]])
        expect = "valid"
        mesh = "--until" not in argv
        desc = "repeated flags: %s" % " ".join(argv[2:])
    elif t == "unknown_cmd":
        c = rng.choice(["frobnicate", "Run", "runn", "RUN", "valid", "chek", "mesh2", "x",
                        "\u00fcnicode", "run\n", "0"])
        argv = [fm, c, "recipe.yaml"]
        desc = "unknown command %r" % c
    elif t == "wrongcmd_flag":
        argv = rng.choice([ctx.argv("run") + ["-j", "2"], ctx.argv("run") + ["--recipe", "r"],
                           ctx.argv("run") + ["--json"], ctx.argv("run") + ["--surface", "s"],
                           ctx.argv("run") + ["--format", "msh"], ctx.argv("run") + ["-o", "x"],
                           ctx.argv("run") + ["--size", "2"],
                           [fm, "check", "x.vtu", "--set", "a.b=1"],
                           [fm, "check", "x.vtu", "--force"], [fm, "convert", "a", "b", "--from",
                                                               "tetra"],
                           [fm, "validate", "recipe.yaml", "-j", "2"],
                           [fm, "cohort", "m.csv", "--recipe", "recipe.yaml", "--from", "tetra"],
                           [fm, "mesh", "img.nii.gz", "--recipe", "r.yaml"]])
        desc = "flag of another command: %s" % " ".join(argv[1:])
    elif t == "odd_set":
        how = rng.choice(["newline_dir", "dash_dir", "space_dir", "tab_value"])
        if how == "newline_dir":
            out = "o\nut"  # given as a YAML double-quoted "o\nut" below
        elif how == "dash_dir":
            out = "-out"
        elif how == "space_dir":
            out = " out "
        else:
            out = "out"
        val = '"o\\nut"' if how == "newline_dir" else out
        argv = ctx.argv("run", extra=["--set", "output.dir=" + val if how != "tab_value" else
                                      "remesh.gradation=\t1.4"])
        expect = "valid" if how != "tab_value" else "any"
        desc = "--set %s" % how
        if how == "space_dir":
            expect = "any"
            out = "out"  # YAML trims: ' out ' -> 'out'
    else:
        argv = [fm]
        out = None
        expect = "usage"
        desc = "no arguments at all"
    return ctx.spec(argv, expect, out, desc, mesh=mesh)


# ------------------------------------------------------------------------------ cohorts


def csv_cell(text):
    if any(c in text for c in ",\"\n\r") or text != text.strip():
        return '"' + text.replace('"', '""') + '"'
    return text


def gen_cohort(ctx):
    rng = ctx.rng
    ctx.image("sub-01.nii.gz", "ball", n=(12, 12, 12))
    ctx.image("sub-02.mha", "two", n=(12, 12, 12))
    until = rng.choice(["repair", "repair", "extract", None])
    ctx.recipe("output:\n  dir: cohort-out\n")
    header = ["id", "image"]
    rows = [["sub-01", "sub-01.nii.gz"], ["sub-02", "sub-02.mha"]]
    expect_codes = {0}
    how = rng.choice(["valid", "bom", "crlf", "quoted", "blank_lines", "no_header", "no_image_col",
                      "dup_id", "slash_id", "dotdot_id", "empty_id", "long_id", "nul_id",
                      "unknown_col", "bad_value", "outdir_col", "missing_image", "garbage_image",
                      "unclosed_quote", "more_fields", "fewer_fields", "empty", "folder",
                      "binary", "j0", "jabc", "j2", "from", "until_bad", "override_ok",
                      "dup_col", "unicode_id", "summary_id", "space_id", "huge_rows",
                      "id_case_clash", "manifest_fifo", "image_is_dir", "recipe_col"])
    text = None
    extra = []
    mpath = "m.csv"
    expect_codes = {0}
    if how == "valid":
        pass
    elif how == "bom":
        text = "\ufeff"
    elif how == "crlf":
        pass
    elif how == "quoted":
        rows[0][1] = "sub-01.nii.gz"
        header.append("input.labels")
        rows[0].append("[1]")
        rows[1].append("all")
    elif how == "blank_lines":
        pass
    elif how == "no_header":
        header = None
        expect_codes = {2}
    elif how == "no_image_col":
        header = ["id", "file"]
        expect_codes = {2}
    elif how == "dup_id":
        rows[1][0] = "sub-01"
        expect_codes = {2}
    elif how == "slash_id":
        rows[1][0] = rng.choice(["a/b", "/abs", "..\\x", "sub/../x"])
        expect_codes = {2} if "/" in rows[1][0] else {0, 1, 2}
    elif how == "dotdot_id":
        rows[1][0] = rng.choice(["..", ".", ".hidden"])
        expect_codes = {2}
    elif how == "empty_id":
        rows[1][0] = ""
        expect_codes = {2}
    elif how == "long_id":
        rows[1][0] = "s" * rng.choice([255, 256, 5000])
        expect_codes = {0} if len(rows[1][0]) <= 255 else {1, 2}
        if len(rows[1][0]) == 255:
            expect_codes = {0, 1, 2}
    elif how == "nul_id":
        rows[1][0] = "sub\x0002"
        expect_codes = {1, 2}
    elif how == "unknown_col":
        header.append("remesh.gradaton")
        for r in rows:
            r.append("1.3")
        expect_codes = {2}
    elif how == "bad_value":
        header.append(rng.choice(["remesh.gradation", "input.labels", "tetra.stretching"]))
        for r in rows:
            r.append(rng.choice(["abc", "[", "-5", ".nan", "{a: 1}"]))
        expect_codes = {2}
    elif how == "outdir_col":
        header.append("output.dir")
        for r in rows:
            r.append("elsewhere")
        expect_codes = {2}
    elif how == "recipe_col":
        header.append("input.image")
        for r in rows:
            r.append("x.nii")
        expect_codes = {2, 0, 1}
    elif how == "missing_image":
        rows[1][1] = "nosuch.nii.gz"
        expect_codes = {1}
    elif how == "garbage_image":
        ctx.write("junk.nii", bytes(rng.randrange(256) for _ in range(500)))
        rows[1][1] = "junk.nii"
        expect_codes = {1}
    elif how == "image_is_dir":
        os.makedirs(ctx.p("adir.nii"))
        rows[1][1] = "adir.nii"
        expect_codes = {1, 2}
    elif how == "unclosed_quote":
        text = "id,image\nsub-01,\"sub-01.nii.gz\n"
        expect_codes = {2}
    elif how == "more_fields":
        rows[1].append("extra")
        expect_codes = {2}
    elif how == "fewer_fields":
        header.append("remesh.gradation")
        rows[0].append("1.3")
        expect_codes = {0, 2}
    elif how == "empty":
        text = ""
        expect_codes = {2}
    elif how == "folder":
        os.makedirs(ctx.p("mdir.csv"))
        mpath = "mdir.csv"
        expect_codes = {2}
    elif how == "manifest_fifo":
        os.mkfifo(ctx.p("fifo.csv"))
        mpath = "fifo.csv"
        expect_codes = {2}
    elif how == "binary":
        text = bytes(rng.randrange(256) for _ in range(rng.choice([10, 1000]))).decode("latin-1")
        expect_codes = {2}
    elif how == "j0":
        extra = ["-j", rng.choice(["0", "-1"])]
        expect_codes = {2}
    elif how == "jabc":
        extra = ["-j", rng.choice(["abc", "", "1.5x"])]
        expect_codes = {2} if extra[1] != "1.5x" else {0, 2}
    elif how == "j2":
        extra = ["-j", "2"]
    elif how == "from":
        extra = ["--from", "repair"]
        expect_codes = {2}
    elif how == "until_bad":
        extra = ["--until", rng.choice(["nothing", "REPAIR", ""])]
        expect_codes = {2}
    elif how == "override_ok":
        header.append("extract.smoothing_iterations")
        rows[0].append("4")
        rows[1].append("")
    elif how == "dup_col":
        header.append("image")
        for r in rows:
            r.append(r[1])
        expect_codes = {2}
    elif how == "unicode_id":
        rows[1][0] = "sujet-\u00e9\u65e5"
    elif how == "summary_id":
        rows[1][0] = rng.choice(["cohort-summary.csv", "cohort-summary.json"])
        expect_codes = {2}
    elif how == "space_id":
        rows[1][0] = " sub 02 "
        expect_codes = {0, 2}
    elif how == "huge_rows":
        for i in range(3, 3000):
            rows.append(["x%d" % i, "nosuch-%d.nii" % i])
        rows = rows[:rng.choice([60, 300])]
        expect_codes = {1, 2}
        until = "extract"
    elif how == "id_case_clash":
        rows[1][0] = "SUB-01"
        expect_codes = {0, 2}
    if text is None or how == "bom":
        eol = "\r\n" if how == "crlf" else "\n"
        lines = []
        if header:
            lines.append(",".join(csv_cell(h) for h in header))
        for r in rows:
            lines.append(",".join(csv_cell(c) for c in r))
            if how == "blank_lines":
                lines.append("")
        text = (text or "") + eol.join(lines) + eol
    if how not in ("folder", "manifest_fifo"):
        ctx.write(mpath, text.encode("utf-8", "surrogateescape") if how != "binary"
                  else text.encode("latin-1"))
    argv = [ctx.fm, "cohort", mpath, "--recipe", "recipe.yaml", "--quiet", "--threads", "1"] + \
        extra
    if until and "--until" not in extra:
        argv += ["--until", until]
    out = ctx.p("cohort-out")

    def check(rc, stdout, stderr, codes=expect_codes):
        v = []
        if rc not in codes:
            v.append("cohort exit %d, expected %s" % (rc, sorted(codes)))
        if rc in (0, 1):
            try:
                s = json.load(open(os.path.join(out, "cohort-summary.json")))
            except Exception as e:  # noqa: BLE001
                return v + ["cohort-summary.json unreadable: %s" % e]
            txt = json.dumps(s)
            if rc == 1 and "fail" not in txt.lower():
                v.append("cohort exit 1 but no failed subject in cohort-summary.json")
        return v
    return Spec(argv, "cohort", out, "cohort %s" % how, [ctx.dir], cwd=ctx.dir, extra=check)


# ------------------------------------------------------------------------------ output folders


def gen_outdir(ctx):
    rng = ctx.rng
    ctx.image("img.nii.gz", "ball", n=(12, 12, 12))
    ctx.recipe(BASE_RECIPE)
    how = rng.choice(["file", "under_file", "proc", "sys", "devshm", "run", "system", "system_odd",
                      "dot", "dotdot", "abs_case", "symlink_case", "allow_input", "foreign",
                      "foreign_hidden", "pipe_inside", "checkpoints_file", "summary_dir",
                      "log_symlink_out", "ckpt_symlink_out", "mesh_symlink_out",
                      "marker_symlink_out", "link_to_other", "link_to_proc", "link_to_etc",
                      "dangling_link", "name255", "name256", "pathmax", "trailing_slash",
                      "dotted", "image_inside_out", "input_via_link_marked", "etc_sub",
                      "reuse_marked", "home", "tilde", "log_is_dir", "diagnostics_file",
                      "socket_inside", "export_dir"])
    out = "out"
    expect = "invalid"
    watch = []
    extra_argv = []
    mesh = True
    cmd = rng.choice(["run", "run", "validate"])
    outside = ctx.p("outside")
    os.makedirs(outside)
    with open(os.path.join(outside, "precious.txt"), "w") as f:
        f.write("do not touch\n")
    marked = lambda d: (os.makedirs(ctx.p(d), exist_ok=True),  # noqa: E731
                        open(ctx.p(d, ".frontmesh-output"), "w").write("frontmesh 0\n"))
    dirval = "out"
    if how == "file":
        ctx.write("afile", b"x")
        dirval = "afile"
    elif how == "under_file":
        ctx.write("afile", b"x")
        dirval = "afile/out"
    elif how == "proc":
        dirval = rng.choice(["/proc/campaign-out", "/proc/self/fd/campaign", "/proc"])
    elif how == "sys":
        dirval = rng.choice(["/sys/campaign-out", "/sys/kernel/campaign"])
    elif how == "devshm":
        dirval = rng.choice(["/dev/shm/campaign-out-%s" % ctx.cid, "/dev/campaign-out"])
    elif how == "run":
        dirval = "/run/campaign-out-%s" % ctx.cid
    elif how == "system":
        dirval = rng.choice(["/", "/etc", "/usr", "/var", "/bin", "/lib", "/lib64", "/opt", "/srv",
                             "/boot", "/home", "/root", "/sbin"])
    elif how == "system_odd":
        dirval = rng.choice(["/etc/", "//etc", "/etc/.", "/usr/../etc", "/tmp/../etc",
                             "/./usr", "/usr//", "///"])
    elif how == "dot":
        dirval = "."
    elif how == "dotdot":
        dirval = rng.choice(["..", "../..", ctx.dir + "/sub/.."])
    elif how == "abs_case":
        dirval = ctx.dir
    elif how == "symlink_case":
        os.symlink(".", ctx.p("here"))
        dirval = "here"
    elif how == "allow_input":
        dirval = "."
        extra_argv = ["--set", "output.allow_input_folder=true"]
        expect = "valid"
        out = ctx.dir
    elif how == "foreign":
        ctx.write("foreign/thesis.tex", b"mine")
        dirval = "foreign"
    elif how == "foreign_hidden":
        ctx.write("foreign/.keep", b"")
        dirval = "foreign"
    elif how == "pipe_inside":
        marked("out")
        os.mkfifo(ctx.p("out", rng.choice(["frontmesh.log", "other.fifo", "summary.json"])))
    elif how == "socket_inside":
        import socket
        marked("out")
        s = socket.socket(socket.AF_UNIX)
        s.bind(ctx.p("out", "sock"))
        s.close()
    elif how == "checkpoints_file":
        marked("out")
        ctx.write("out/checkpoints", b"x")
    elif how == "diagnostics_file":
        marked("out")
        ctx.write("out/diagnostics", b"x")
    elif how == "summary_dir":
        marked("out")
        os.makedirs(ctx.p("out", "summary.json"))
    elif how == "log_is_dir":
        marked("out")
        os.makedirs(ctx.p("out", "frontmesh.log"))
    elif how == "export_dir":
        marked("out")
        os.makedirs(ctx.p("out", "mesh.inp"))
        extra_argv = ["--set", "output.formats=[vtu, inp]"]
    elif how in ("log_symlink_out", "mesh_symlink_out", "marker_symlink_out"):
        marked("out")
        target = os.path.join(outside, "precious.txt")
        name = {"log_symlink_out": "frontmesh.log", "mesh_symlink_out": "mesh.vtu",
                "marker_symlink_out": ".frontmesh-output"}[how]
        os.remove(ctx.p("out", ".frontmesh-output")) if name == ".frontmesh-output" else None
        os.symlink(target, ctx.p("out", name))
        expect = "any"
        watch = [outside]
    elif how == "ckpt_symlink_out":
        marked("out")
        os.symlink(outside, ctx.p("out", "checkpoints"))
        expect = "any"
        watch = [outside]
    elif how == "link_to_other":
        os.makedirs(ctx.p("elsewhere"))
        os.symlink("elsewhere", ctx.p("out"))
        expect = "valid"
        out = ctx.p("elsewhere")
    elif how == "link_to_proc":
        os.symlink("/proc/self", ctx.p("out"))
    elif how == "link_to_etc":
        os.symlink("/etc", ctx.p("out"))
    elif how == "dangling_link":
        os.symlink("gone/deeper", ctx.p("out"))
        expect = "any"
        out = ctx.p("gone")
        watch = []
    elif how == "name255":
        dirval = "n" * 255
        out = dirval
        expect = "valid"
    elif how == "name256":
        dirval = "n" * 256
    elif how == "pathmax":
        dirval = "/".join(["d" * 200] * 21)
    elif how == "trailing_slash":
        dirval = rng.choice(["out/", "out//", "./out/../out", "out/."])
        expect = "valid"
    elif how == "dotted":
        dirval = rng.choice(["...", "out.", ".out", "-out", "out~", "o u t"])
        out = dirval
        expect = "valid"
    elif how == "image_inside_out":
        marked("out")
        shutil.move(ctx.p("img.nii.gz"), ctx.p("out", "img.nii.gz"))
        ctx.recipe(BASE_RECIPE.replace("img.nii.gz", "out/img.nii.gz"))
    elif how == "input_via_link_marked":
        marked("realdir")
        shutil.move(ctx.p("img.nii.gz"), ctx.p("realdir", "img.nii.gz"))
        os.symlink("realdir/img.nii.gz", ctx.p("img.nii.gz"))
        dirval = "realdir"
        out = "realdir"
    elif how == "etc_sub":
        dirval = "/etc/frontmesh-campaign-%s" % ctx.cid
        cmd = "validate"
        expect = "any"
        out = dirval
    elif how == "reuse_marked":
        marked("out")
        ctx.write("out/old-notes.txt", b"kept")
        expect = "valid"
    elif how == "home":
        dirval = os.path.expanduser("~")
    elif how == "tilde":
        dirval = "~"  # quoted in the recipe: a folder named '~', not the home folder
        out = "~"
        expect = "valid"
    if how in ("log_symlink_out", "mesh_symlink_out", "marker_symlink_out", "ckpt_symlink_out",
               "dangling_link", "link_to_other"):
        cmd = "run"  # what a run writes through the link is the point
    if dirval != "out":
        ctx.recipe(open(ctx.p("recipe.yaml")).read().replace("  dir: out", "  dir: '%s'" %
                                                               dirval.replace("'", "''")))
    argv = ctx.argv(cmd, extra=extra_argv) if cmd == "run" else \
        [ctx.fm, "validate", "recipe.yaml"] + extra_argv
    if out is not None and not os.path.isabs(out):
        out = ctx.p(out)
    if how in ("devshm", "run"):
        out = dirval
    elif dirval.startswith("/") and how != "etc_sub" or how in ("dot", "dotdot", "symlink_case",
                                                               "home"):
        out = None  # a system folder, or one holding the case: not snapshotted as a whole
    spec = ctx.spec(argv, expect, out, "outdir %s (%s) %s" % (how, dirval[:60], cmd),
                    mesh=mesh, watch=watch)
    if how == "etc_sub":
        def gone(rc, o, e, d=dirval):
            return ["validate created %s" % d] if os.path.exists(d) else []
        spec.extra = gone
    return spec


# ------------------------------------------------------------------------------ kill -9


KILL_FORMATS = ["vtu", "msh", "inp", "feb", "msh22"]
KILL_FILES = ["mesh.vtu", "mesh.msh", "mesh.inp", "mesh.feb", "mesh.v22.msh", "mesh_surface.vtp"]


def kill_setup(runner, d, rng):
    os.makedirs(d, exist_ok=True)
    n = (30, 30, 30)
    vol = ball_volume(n, [(14.5, 14.5, 14.5, 13.0, 1), (12.0, 14.5, 14.5, 7.0, 2),
                          (19.0, 15.0, 14.0, 5.0, 3)])
    write_nifti(os.path.join(d, "img.nii.gz"), vol, n, "u1")
    with open(os.path.join(d, "recipe.yaml"), "w") as f:
        f.write("input:\n  image: img.nii.gz\noutput:\n  dir: out\n  formats: [%s]\n"
                "remesh:\n  edge_length: 1.0\n" % ", ".join(KILL_FORMATS))


def result_bytes(out):
    got = {}
    for f in KILL_FILES:
        p = os.path.join(out, f)
        got[f] = hashlib.sha256(open(p, "rb").read()).hexdigest() if os.path.exists(p) else None
    return got


def outputs_violations(out):
    v = []
    try:
        s = json.load(open(os.path.join(out, "summary.json")))
    except Exception as e:  # noqa: BLE001
        return ["summary.json unreadable: %s" % e], set()
    if s.get("status") != "ok":
        v.append("summary.json status %r after the completed re-run" % s.get("status"))
    names = set()
    for o in s.get("outputs") or []:
        name = o.get("file") or o.get("path") or o.get("name")
        if not name:
            continue
        names.add(name)
        full = name if os.path.isabs(name) else os.path.join(out, name)
        if not os.path.exists(full):
            v.append("summary.json lists %s, which is not there" % name)
        elif o.get("bytes", o.get("size")) not in (None, os.path.getsize(full)) and \
                not name.endswith("frontmesh.log"):
            v.append("summary.json gives %s %s bytes, the file has %d" %
                     (name, o.get("bytes", o.get("size")), os.path.getsize(full)))
    return v, names


def kill_campaign(runner, trials, seed, results_cb):
    rng = random.Random("%d/kill" % seed)
    base = os.path.join(runner.root, "kill")
    shutil.rmtree(base, ignore_errors=True)
    src = os.path.join(base, "src")
    kill_setup(runner, src, rng)
    fm = runner.fm

    def fresh(name):
        d = os.path.join(base, name)
        shutil.rmtree(d, ignore_errors=True)
        os.makedirs(d)
        for f in ("img.nii.gz", "recipe.yaml"):
            shutil.copy(os.path.join(src, f), d)
        return d
    argv1 = [fm, "run", "recipe.yaml", "--quiet", "--threads", "1"]
    ref = fresh("ref")
    rc, o, e, dur = runner.run_cmd(argv1, ref)
    if rc != 0:
        results_cb({"id": "kill-ref", "class": "kill", "desc": "uninterrupted reference run",
                    "expect": "valid", "outcome": "exit %s" % rc, "wall_s": dur,
                    "violations": ["reference run failed: %s" % e.strip()[-300:]], "notes": [],
                    "stderr_last": e.strip()[-300:], "repro": "cd %s && %s" % (
                        ref, " ".join(argv1)), "cwd": ref, "inputs": [src]})
        return 0
    ref_bytes = result_bytes(os.path.join(ref, "out"))
    _, ref_names = outputs_violations(os.path.join(ref, "out"))
    # determinism across thread counts, so that a difference after a kill means the kill
    ref2 = fresh("ref2")
    rc2, _, e2, _ = runner.run_cmd([fm, "run", "recipe.yaml", "--quiet", "--threads", "2"], ref2)
    v0 = []
    if rc2 != 0:
        v0.append("second reference (--threads 2) exit %s: %s" % (rc2, e2.strip()[-200:]))
    else:
        b2 = result_bytes(os.path.join(ref2, "out"))
        diff = [f for f in KILL_FILES if b2[f] != ref_bytes[f]]
        if diff:
            v0.append("--threads 2 gives other bytes than --threads 1: " + ", ".join(diff))
    results_cb({"id": "kill-ref", "class": "kill", "desc": "reference runs (threads 1 and 2), "
                "%.1f s" % dur, "expect": "valid", "outcome": "exit 0", "wall_s": dur,
                "violations": v0, "notes": [], "stderr_last": "", "repro": "cd %s && %s" % (
                    ref2, " ".join(argv1[:-1] + ["2"])), "cwd": ref2, "inputs": [src]})
    total_kills = 0
    for t in range(trials):
        d = fresh("t%02d" % t)
        out = os.path.join(d, "out")
        mode = rng.choice(["fresh", "fresh", "fresh", "force", "changed"])
        k = rng.choice([1, 1, 2, 3])
        log = []
        v = []
        if mode in ("force", "changed"):
            rc, _, e, _ = runner.run_cmd(argv1, d)
            if rc != 0:
                v.append("preparatory run exit %s" % rc)
        before_case = snapshot(d, [out])
        for j in range(k):
            argv = [fm, "run", "recipe.yaml", "--quiet", "--threads", rng.choice(["1", "2"])]
            if mode == "force":
                argv.append("--force")
            if mode == "changed" and j == 0:
                argv += ["--set", "refine.passes=2"]
            when = rng.uniform(0, dur)
            p = subprocess.Popen(argv, cwd=d, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                 stdin=subprocess.DEVNULL, start_new_session=True)
            time.sleep(when)
            if p.poll() is None:
                p.send_signal(signal.SIGKILL)
                p.wait()
                total_kills += 1
                log.append("killed at %.2f s (%s)" % (when, " ".join(argv[3:])))
            else:
                log.append("finished (exit %d) before %.2f s" % (p.returncode, when))
                if p.returncode not in (0,):
                    v.append("an unkilled run exit %d: %s" % (
                        p.returncode, p.stderr.read().decode(errors="replace").strip()[-200:]))
            p.stderr.close()
        final = argv1 + ([] if mode != "changed" else [])
        rc, o, e, w = runner.run_cmd(final, d)
        if rc != 0:
            v.append("re-run after the kills exit %s: %s" % (rc, e.strip()[-240:]))
        else:
            got = result_bytes(out)
            diff = [f for f in KILL_FILES if got[f] != ref_bytes[f]]
            if diff:
                v.append("after the kills, bytes differ from the uninterrupted run: " +
                         ", ".join(diff))
            ov, names = outputs_violations(out)
            v += ov
            if names != ref_names:
                v.append("summary.json outputs differ from the uninterrupted run's: +%s -%s" % (
                    sorted(names - ref_names)[:3], sorted(ref_names - names)[:3]))
            if not os.path.exists(os.path.join(out, "report.html")):
                v.append("no report.html after the completed re-run")
        tmp = temp_files(out)
        if tmp:
            v.append("temporary files left after the completed re-run: " + ", ".join(tmp[:3]))
        dd = snap_diff(before_case, snapshot(d, [out]))
        if dd:
            v.append("wrote outside the output folder: " + dd)
        results_cb({"id": "kill-%02d" % t, "class": "kill", "desc": "%s, %d kill(s): %s" % (
            mode, k, "; ".join(log)), "expect": "valid", "outcome": "exit %s" % rc,
            "wall_s": round(w, 2), "violations": v, "notes": [],
            "stderr_last": e.strip()[-300:], "repro": "cd %s && %s  # after: %s" % (
                d, " ".join(final), "; ".join(log)), "cwd": d, "inputs": [d]})
    return total_kills


# ------------------------------------------------------------------------------ main


CLASSES = [  # name, generator, cases at --scale 1
    ("recipe", gen_recipe, 200), ("cli", gen_cli, 70), ("nifti", gen_nifti, 150),
    ("meta", gen_meta, 80), ("nrrd", gen_nrrd, 80), ("valid", gen_valid, 60),
    ("surface", gen_surface, 110), ("mesh", gen_mesh, 80), ("cohort", gen_cohort, 40),
    ("outdir", gen_outdir, 60),
]


def shared_setup(runner):
    os.makedirs(runner.shared, exist_ok=True)
    rng = random.Random("%d/shared" % runner.args.seed)
    vol = shape_volume("ball", (12, 12, 12), rng)
    with open(os.path.join(runner.shared, "ball12.raw"), "wb") as f:
        f.write(pack_voxels(vol, "u1"))
    ref = os.path.join(runner.shared, "ref")
    if not os.path.exists(os.path.join(ref, "out", "mesh.vtu")):
        shutil.rmtree(ref, ignore_errors=True)
        os.makedirs(ref)
        write_nifti(os.path.join(ref, "img.nii.gz"), shape_volume("two", (12, 12, 12), rng),
                    (12, 12, 12), "u1")
        with open(os.path.join(ref, "recipe.yaml"), "w") as f:
            f.write("input:\n  image: img.nii.gz\noutput:\n  dir: out\n"
                    "  formats: [vtu, msh, msh22, inp, mesh]\n")
        rc, _, err, _ = runner.run_cmd([runner.fm, "run", "recipe.yaml", "--quiet"], ref)
        if rc != 0:
            print("campaign: the shared reference run failed (exit %s): %s" % (rc, err[-300:]),
                  file=sys.stderr)


def keep_finding(args, res):
    dst = os.path.join(args.findings, res["id"])
    shutil.rmtree(dst, ignore_errors=True)
    os.makedirs(dst, exist_ok=True)
    for src in res.get("inputs") or []:
        if not os.path.exists(src):
            continue
        if os.path.isdir(src):
            for name in os.listdir(src):
                s = os.path.join(src, name)
                if name in ("out", "cohort-out", "conv") and os.path.isdir(s):
                    continue  # results, not inputs
                try:
                    if os.path.islink(s):
                        os.symlink(os.readlink(s), os.path.join(dst, name))
                    elif os.path.isdir(s):
                        shutil.copytree(s, os.path.join(dst, name), symlinks=True)
                    elif stat.S_ISFIFO(os.lstat(s).st_mode):
                        os.mkfifo(os.path.join(dst, name))
                    elif os.path.getsize(s) < 50 << 20:
                        shutil.copy2(s, os.path.join(dst, name))
                except OSError:
                    pass
        else:
            shutil.copy2(src, dst)
    # errors="backslashreplace": a file name of undecodable bytes (surrogate escapes) in a
    # violation ended the campaign with UnicodeEncodeError.
    with open(os.path.join(dst, "FINDING.txt"), "w", errors="backslashreplace") as f:
        f.write("case: %s [%s]\n%s\nexpect: %s, outcome: %s\n" % (
            res["id"], res["class"], res["desc"], res["expect"], res["outcome"]))
        for v in res["violations"]:
            f.write("violation: %s\n" % v)
        f.write("stderr (last line): %s\nreproduce: %s\n" % (res["stderr_last"], res["repro"]))
        f.write("(inputs copied from %s; re-run the command in this folder or there)\n" %
                res["cwd"])


def main():
    sys.stdout.reconfigure(errors="backslashreplace")  # undecodable file names in FAIL lines
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--scale", type=float, default=1.0, help="cases per class times this")
    ap.add_argument("--classes", default="", help="comma-separated subset (and 'kill')")
    ap.add_argument("--only", default="", help="case ids to run, e.g. nifti-0012,recipe-0003")
    ap.add_argument("-j", "--jobs", type=int, default=2, choices=[1, 2])
    ap.add_argument("--out", default="/tmp/campaign")
    ap.add_argument("--findings", default="/tmp/campaign-findings")
    ap.add_argument("--json", default="")
    ap.add_argument("--frontmesh", default=DEFAULT_FM)
    ap.add_argument("--timeout", type=float, default=120)
    ap.add_argument("--kills", type=int, default=24, help="kill trials (1 to 3 kills each)")
    ap.add_argument("--keep", action="store_true", help="keep the folders of passing cases")
    args = ap.parse_args()
    args.frontmesh = os.path.abspath(args.frontmesh)
    if not os.access(args.frontmesh, os.X_OK):
        sys.exit("campaign: no frontmesh at %s" % args.frontmesh)
    if not os.path.exists(MESHCHECK):
        sys.exit("campaign: no meshcheck at %s" % MESHCHECK)
    os.makedirs(args.out, exist_ok=True)
    os.makedirs(os.path.join(args.out, "cases"), exist_ok=True)
    runner = Runner(args)
    shared_setup(runner)
    KEYS[:] = load_keys(args.frontmesh, os.path.join(runner.shared, "ref"))
    if not KEYS:
        sys.exit("campaign: `frontmesh keys` listed no keys")
    only = set(x for x in args.only.split(",") if x)
    wanted = set(x for x in args.classes.split(",") if x)
    tasks = []
    for name, gen, count in CLASSES:
        if wanted and name not in wanted:
            continue
        for i in range(max(1, int(round(count * args.scale)))):
            cid = "%s-%04d" % (name, i)
            if only and cid not in only:
                continue
            tasks.append((cid, name, gen))
    results = []
    lock = threading.Lock()
    t_start = time.time()

    def record(res):
        with lock:
            results.append(res)
            if res["violations"]:
                for v in res["violations"]:
                    print("FAIL %s [%s] %s | %s | reproduce: %s" % (
                        res["id"], res["class"], v, res["desc"][:120], res["repro"]),
                        flush=True)
                keep_finding(args, res)
            n = len(results)
            if n % 50 == 0:
                print("... %d cases, %d failed, %.0f s" % (
                    n, sum(1 for r in results if r["violations"]), time.time() - t_start),
                    flush=True)

    def task(item):
        cid, cls, gen = item
        rng = random.Random("%d/%s/%s" % (args.seed, cls, cid))
        try:
            ctx = Ctx(runner, cid, rng)
            spec = gen(ctx)
        except Exception as e:  # noqa: BLE001  a campaign bug, not a finding
            import traceback
            res = {"id": cid, "class": cls, "desc": "generator error", "expect": "-",
                   "outcome": "campaign-error", "wall_s": 0, "violations": [],
                   "notes": ["campaign error: %s" % traceback.format_exc(limit=3)[-400:]],
                   "stderr_last": "", "repro": "", "cwd": "", "inputs": []}
            print("CAMPAIGN-ERROR %s: %r" % (cid, e), file=sys.stderr, flush=True)
            record(res)
            return
        res = runner.execute(cid, cls, spec)
        record(res)
        if not res["violations"] and not args.keep:
            shutil.rmtree(ctx.dir, ignore_errors=True)

    with concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs) as pool:
        list(pool.map(task, tasks))
    kills = 0
    if (not wanted or "kill" in wanted) and not only:
        kills = kill_campaign(runner, args.kills, args.seed, record)
    elif only and any(o.startswith("kill") for o in only):
        kills = kill_campaign(runner, args.kills, args.seed, record)
    wall = time.time() - t_start
    # counts per class
    classes = {}
    for r in results:
        c = classes.setdefault(r["class"], {"cases": 0, "failed": 0, "refused_valid": 0,
                                            "outcomes": {}, "campaign_errors": 0})
        c["cases"] += 1
        c["failed"] += 1 if r["violations"] else 0
        c["refused_valid"] += 1 if any(n.startswith("refused:") for n in r["notes"]) else 0
        c["campaign_errors"] += 1 if r["outcome"] == "campaign-error" else 0
        c["outcomes"][r["outcome"]] = c["outcomes"].get(r["outcome"], 0) + 1
    refused = [r for r in results if any(n.startswith("refused:") for n in r["notes"])]
    if refused:
        print("\nValid inputs refused with a clean one-line reason (notes, not failures):")
        for r in refused:
            print("  NOTE %s [%s] %s: %s" % (r["id"], r["class"], r["desc"][:100],
                                             [n for n in r["notes"] if n.startswith("refused:")]
                                             [0][9:200]))
    print("\n%-8s %6s %6s %8s  outcomes" % ("class", "cases", "failed", "refused"))
    for name in sorted(classes):
        c = classes[name]
        print("%-8s %6d %6d %8d  %s" % (name, c["cases"], c["failed"], c["refused_valid"],
                                        ", ".join("%s: %d" % kv for kv in
                                                  sorted(c["outcomes"].items()))))
    nfail = sum(1 for r in results if r["violations"])
    print("\nseed %d, %d cases, %d kills delivered, wall %.0f s" % (args.seed, len(results), kills,
                                                                   wall))
    print("%d passed, %d failed" % (len(results) - nfail, nfail))
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"seed": args.seed, "cases": len(results), "failed": nfail,
                       "kills": kills, "wall_s": round(wall, 1), "classes": classes,
                       "results": sorted(results, key=lambda r: r["id"])}, f, indent=1)
    return 1 if nfail else 0


if __name__ == "__main__":
    sys.exit(main())
