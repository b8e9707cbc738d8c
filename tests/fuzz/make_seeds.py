#!/usr/bin/env python3
"""Writes the seed corpus of the libFuzzer targets (issue 21) into tests/fuzz/corpus/.

Every seed is small (< 4 KB) and valid, or nearly so, for the reader it feeds; libFuzzer
mutates from there. The first byte of an image, surface or mesh seed picks the file
extension the target writes (see fuzz_image.cpp, fuzz_surface.cpp, fuzz_mesh.cpp).
The tet mesh in .msh 4.1, .mesh, .inp and binary .vtu is our own writer's output, made with
    frontmesh convert corpus/mesh/<seed>.msh22 OUT
when --frontmesh is given; otherwise those seeds are left as they are.
Usage: /usr/bin/python3 tests/fuzz/make_seeds.py [--frontmesh build/pipeline/frontmesh]
"""
import argparse
import gzip
import os
import struct
import subprocess
import tempfile
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
CORPUS = os.path.join(HERE, "corpus")

IMAGE_EXT = [".nii", ".nii.gz", ".mha", ".mhd", ".nrrd", ".nhdr"]
SURFACE_EXT = [".vtu", ".vtp", ".stl", ".ply", ".off"]
MESH_EXT = [".vtu", ".msh", ".mesh", ".inp"]
CHECK = 4  # bit of the mesh selector byte: `frontmesh check` instead of convert's read


def put(target, name, data):
    os.makedirs(os.path.join(CORPUS, target), exist_ok=True)
    if isinstance(data, str):
        data = data.encode("latin-1")  # binary parts are carried as latin-1 text
    with open(os.path.join(CORPUS, target, name), "wb") as f:
        f.write(data)


# --- images: a 4x4x4 block, a 2x2x2 cube of label 1 (and 2) inside ----------------------

def voxels(n=4, dtype="B"):
    out = []
    for k in range(n):
        for j in range(n):
            for i in range(n):
                inside = 1 <= i <= 2 and 1 <= j <= 2 and 1 <= k <= 2
                out.append((2 if k == 2 else 1) if inside else 0)
    return struct.pack("<%d%s" % (len(out), dtype), *out)


def nifti(datatype=2, bitpix=8, dtype="B", pixdim=(1.0, 1.0, 1.0), sform=True, qform=True):
    h = bytearray(348)
    struct.pack_into("<i", h, 0, 348)
    struct.pack_into("<8h", h, 40, 3, 4, 4, 4, 1, 1, 1, 1)
    struct.pack_into("<hh", h, 70, datatype, bitpix)
    struct.pack_into("<8f", h, 76, 1.0, *pixdim, 0, 0, 0, 0)
    struct.pack_into("<f", h, 108, 352.0)          # vox_offset
    struct.pack_into("<f", h, 112, 1.0)            # scl_slope
    h[123] = 2                                     # xyzt_units: mm
    struct.pack_into("<hh", h, 252, 1 if qform else 0, 2 if sform else 0)
    struct.pack_into("<6f", h, 256, 0.0, 0.0, 0.0, -2.0, 3.0, 4.0)  # quaternion, offset
    struct.pack_into("<4f", h, 280, pixdim[0], 0, 0, -2.0)
    struct.pack_into("<4f", h, 296, 0, pixdim[1], 0, 3.0)
    struct.pack_into("<4f", h, 312, 0, 0, pixdim[2], 4.0)
    h[344:348] = b"n+1\0"
    return bytes(h) + b"\0\0\0\0" + voxels(dtype=dtype)


def text(data):
    """Bytes as latin-1 text, to concatenate with header text."""
    return data.decode("latin-1")


def images():
    sel = {e: chr(i) for i, e in enumerate(IMAGE_EXT)}
    put("image", "nii-uint8", sel[".nii"] + text(nifti()))
    put("image", "nii-float32-qform", sel[".nii"] + text(nifti(16, 32, "f", (0.5, 1.0, 2.0), False)))
    put("image", "nii-int16-sform", sel[".nii"] + text(nifti(4, 16, "h", qform=False)))
    put("image", "niigz-uint8", sel[".nii.gz"] + text(gzip.compress(nifti(), mtime=0)))
    meta = ("ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
            "TransformMatrix = 1 0 0 0 1 0 0 0 1\nOffset = 1 2 3\nElementSpacing = 1 1 1.5\n"
            "DimSize = 4 4 4\nElementType = MET_UCHAR\n")
    put("image", "mha-uchar", sel[".mha"] + meta + "ElementDataFile = LOCAL\n" + text(voxels()))
    z = text(zlib.compress(voxels()))
    put("image", "mha-compressed", sel[".mha"] + meta + "CompressedData = True\n"
        "CompressedDataSize = %d\nElementDataFile = LOCAL\n" % len(z) + z)
    put("image", "mha-text", sel[".mha"] + meta.replace("BinaryData = True", "BinaryData = False")
        + "ElementDataFile = LOCAL\n" + " ".join(str(b) for b in voxels()) + "\n")
    put("image", "mhd-uchar", sel[".mhd"] + meta.replace("DimSize = 4 4 4", "DimSize = 8 8 8")
        + "ElementDataFile = data.raw\n")
    nrrd = ("NRRD0004\ntype: uint8\ndimension: 3\nspace: left-posterior-superior\n"
            "sizes: 4 4 4\nspace directions: (1,0,0) (0,1,0) (0,0,1.5)\n"
            "space origin: (1,2,3)\n")
    put("image", "nrrd-raw", sel[".nrrd"] + nrrd + "encoding: raw\n\n" + text(voxels()))
    put("image", "nrrd-gzip", sel[".nrrd"] + nrrd + "encoding: gzip\n\n"
        + text(gzip.compress(voxels(), mtime=0)))
    put("image", "nrrd-ascii", sel[".nrrd"] + nrrd + "encoding: ascii\n\n"
        + " ".join(str(b) for b in voxels()) + "\n")
    put("image", "nhdr-raw", sel[".nhdr"] + nrrd.replace("sizes: 4 4 4", "sizes: 8 8 8")
        + "encoding: raw\ndata file: data.raw\n\n")


# --- surfaces: a tetrahedron, regions 1 | 0 ----------------------------------------------

P = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
T = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]


def normal(t):
    a, b, c = (P[i] for i in t)
    u = [b[k] - a[k] for k in range(3)]
    v = [c[k] - a[k] for k in range(3)]
    return (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])


def ascii_list(values):
    return " ".join(str(v) for v in values)


def surfaces():
    sel = {e: chr(i) for i, e in enumerate(SURFACE_EXT)}
    pts = ascii_list(c for p in P for c in p)
    conn = ascii_list(i for t in T for i in t)
    offsets = ascii_list(3 * (i + 1) for i in range(len(T)))
    regions = ('<CellData><DataArray type="Int32" Name="region_in" format="ascii">1 1 1 1'
               '</DataArray><DataArray type="Int32" Name="region_out" format="ascii">0 0 0 0'
               '</DataArray></CellData>')
    fields = ('<FieldData><Array type="String" Name="stage" NumberOfTuples="1" format="ascii">'
              '114 101 112 97 105 114 0</Array></FieldData>')
    put("surface", "vtu-ascii", sel[".vtu"] +
        '<?xml version="1.0"?>\n<VTKFile type="UnstructuredGrid" version="1.0" '
        'byte_order="LittleEndian" header_type="UInt64"><UnstructuredGrid>' + fields +
        '<Piece NumberOfPoints="4" NumberOfCells="4"><Points>'
        '<DataArray type="Float64" NumberOfComponents="3" format="ascii">' + pts +
        '</DataArray></Points><Cells>'
        '<DataArray type="Int64" Name="connectivity" format="ascii">' + conn + '</DataArray>'
        '<DataArray type="Int64" Name="offsets" format="ascii">' + offsets + '</DataArray>'
        '<DataArray type="UInt8" Name="types" format="ascii">5 5 5 5</DataArray></Cells>'
        + regions + '</Piece></UnstructuredGrid></VTKFile>\n')
    put("surface", "vtp-ascii", sel[".vtp"] +
        '<?xml version="1.0"?>\n<VTKFile type="PolyData" version="1.0" '
        'byte_order="LittleEndian" header_type="UInt64"><PolyData>'
        '<Piece NumberOfPoints="4" NumberOfPolys="4"><Points>'
        '<DataArray type="Float32" NumberOfComponents="3" format="ascii">' + pts +
        '</DataArray></Points><Polys>'
        '<DataArray type="Int64" Name="connectivity" format="ascii">' + conn + '</DataArray>'
        '<DataArray type="Int64" Name="offsets" format="ascii">' + offsets + '</DataArray>'
        '</Polys>' + regions + '</Piece></PolyData></VTKFile>\n')
    # The same surface with its arrays as base64 binary (VTK's default encoding).
    import base64
    def b64(fmt, values):
        raw = struct.pack("<" + fmt * len(values), *values)
        return base64.b64encode(struct.pack("<Q", len(raw)) + raw).decode()
    put("surface", "vtp-binary", sel[".vtp"] +
        '<?xml version="1.0"?>\n<VTKFile type="PolyData" version="1.0" '
        'byte_order="LittleEndian" header_type="UInt64"><PolyData>'
        '<Piece NumberOfPoints="4" NumberOfPolys="4"><Points>'
        '<DataArray type="Float64" NumberOfComponents="3" format="binary">'
        + b64("d", [c for p in P for c in p]) + '</DataArray></Points><Polys>'
        '<DataArray type="Int64" Name="connectivity" format="binary">'
        + b64("q", [i for t in T for i in t]) + '</DataArray>'
        '<DataArray type="Int64" Name="offsets" format="binary">'
        + b64("q", [3 * (i + 1) for i in range(len(T))]) + '</DataArray></Polys>'
        '<CellData><DataArray type="Int32" Name="region_in" format="binary">'
        + b64("i", [2, 2, 2, 2]) + '</DataArray></CellData></Piece></PolyData></VTKFile>\n')
    stl = "solid tet\n"
    for t in T:
        stl += " facet normal %g %g %g\n  outer loop\n" % normal(t)
        for i in t:
            stl += "   vertex %g %g %g\n" % P[i]
        stl += "  endloop\n endfacet\n"
    put("surface", "stl-ascii", sel[".stl"] + stl + "endsolid tet\n")
    binstl = b"binary stl".ljust(80, b" ") + struct.pack("<I", len(T))
    for t in T:
        binstl += struct.pack("<3f", *normal(t))
        for i in t:
            binstl += struct.pack("<3f", *P[i])
        binstl += b"\0\0"
    put("surface", "stl-binary", sel[".stl"] + text(binstl))
    ply = ("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
           "property float z\nelement face 4\nproperty list uchar int vertex_indices\n"
           "end_header\n")
    ply += "".join("%g %g %g\n" % p for p in P) + "".join("3 %d %d %d\n" % t for t in T)
    put("surface", "ply-ascii", sel[".ply"] + ply)
    plyb = ("ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\n"
            "property float y\nproperty float z\nelement face 4\n"
            "property list uchar int vertex_indices\nend_header\n").encode()
    plyb += b"".join(struct.pack("<3f", *p) for p in P)
    plyb += b"".join(struct.pack("<B3i", 3, *t) for t in T)
    put("surface", "ply-binary", sel[".ply"] + text(plyb))
    off = "OFF\n# a tetrahedron\n4 4 6\n" + "".join("%g %g %g\n" % p for p in P)
    off += "".join("3 %d %d %d\n" % t for t in T)
    put("surface", "off", sel[".off"] + off)
    put("surface", "off-quad", sel[".off"] + "OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n")


# --- tet meshes: a unit cube cut into 5 tets, regions 1 and 2 ----------------------------

CUBE = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
TETS = [(0, 1, 3, 4), (1, 2, 3, 6), (1, 4, 5, 6), (3, 4, 6, 7), (1, 3, 4, 6)]


def msh22():
    s = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n"
    s += '$PhysicalNames\n2\n3 1 "outer"\n3 2 "core"\n$EndPhysicalNames\n'
    s += "$Nodes\n%d\n" % len(CUBE)
    s += "".join("%d %g %g %g\n" % (i + 1, *p) for i, p in enumerate(CUBE)) + "$EndNodes\n"
    s += "$Elements\n%d\n" % (len(TETS) + 1)
    s += "1 2 2 7 1 1 2 4\n"  # one boundary triangle, physical 7
    for i, t in enumerate(TETS):
        r = 2 if i == 4 else 1
        s += "%d 4 2 %d %d %s\n" % (i + 2, r, r, " ".join(str(v + 1) for v in t))
    return s + "$EndElements\n"


def meshes(frontmesh):
    sel = {e: i for i, e in enumerate(MESH_EXT)}
    base = msh22()
    put("mesh", "msh22", bytes([sel[".msh"]]) + base.encode())
    put("mesh", "msh22-check", bytes([sel[".msh"] | CHECK]) + base.encode())
    tets = ascii_list(v for t in TETS for v in t)
    put("mesh", "vtu-ascii-check", bytes([sel[".vtu"] | CHECK]) + (
        '<?xml version="1.0"?>\n<VTKFile type="UnstructuredGrid" version="1.0" '
        'byte_order="LittleEndian" header_type="UInt64"><UnstructuredGrid>'
        '<Piece NumberOfPoints="8" NumberOfCells="5"><Points>'
        '<DataArray type="Float64" NumberOfComponents="3" format="ascii">'
        + ascii_list(c for p in CUBE for c in p) + '</DataArray></Points><Cells>'
        '<DataArray type="Int64" Name="connectivity" format="ascii">' + tets + '</DataArray>'
        '<DataArray type="Int64" Name="offsets" format="ascii">'
        + ascii_list(4 * (i + 1) for i in range(len(TETS))) + '</DataArray>'
        '<DataArray type="UInt8" Name="types" format="ascii">10 10 10 10 10</DataArray></Cells>'
        '<CellData><DataArray type="Int32" Name="region" format="ascii">1 1 1 1 2</DataArray>'
        '</CellData></Piece></UnstructuredGrid></VTKFile>\n').encode())
    if not frontmesh:
        return
    with tempfile.TemporaryDirectory() as tmp:
        src = os.path.join(tmp, "cube.msh")
        with open(src, "w") as f:
            f.write(base)
        for ext, name in ((".msh", "msh41"), (".mesh", "medit"), (".inp", "abaqus"),
                          (".vtu", "vtu-ours")):
            out = os.path.join(tmp, "out" + ext)
            subprocess.run([frontmesh, "convert", src, out], check=True,
                           stdout=subprocess.DEVNULL)
            with open(out, "rb") as f:
                data = f.read()
            put("mesh", name, bytes([sel[ext]]) + data)
            put("mesh", name + "-check", bytes([sel[ext] | CHECK]) + data)


# --- recipes -----------------------------------------------------------------------------

def recipes():
    put("recipe", "minimal", "input:\n  image: image.nii\noutput:\n  dir: fuzz-out/a\n")
    put("recipe", "surface-input",
        "input:\n  surface: surface.stl\noutput:\n  dir: fuzz-out/b\n  formats: [vtu, msh, inp]\n"
        "remesh:\n  edge_length: 2.0\ntetra:\n  stretching: 1.2\n")
    with open(os.path.join(HERE, "..", "..", "configs", "reference.yaml")) as f:
        lines = [l for l in f.read().splitlines() if not l.lstrip().startswith("#")]
    text = "\n".join(l.split(" #")[0].rstrip() for l in lines if l.strip()) + "\n"
    text = text.replace("/usr/share/mricron/templates/aal.nii.gz", "image.nii")
    text = text.replace("dir: frontmesh-out", "dir: fuzz-out/c")
    put("recipe", "reference", text)
    put("recipe", "labels-overrides",
        "input:\n  image: image.nii\n  labels: [1, 2, 17]\n  label_names: labels.txt\n"
        "  spacing: [1, 1, 2]\noutput:\n  dir: fuzz-out/d\n  frame: ras\n"
        "\0remesh.edge_length=1.5\0tetra.stretching=1.1\0output.formats=[msh22, feb]")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frontmesh", help="frontmesh executable, for the converted mesh seeds")
    args = ap.parse_args()
    images()
    surfaces()
    meshes(args.frontmesh)
    recipes()


if __name__ == "__main__":
    main()
