#!/usr/bin/python3
"""The torture corpus (issue 20): seeded label images and surfaces that frontmesh was not
tuned on. Every case is a pure function of its seed, so a failure is reproduced from the
seed alone.

  corpus.py SEED OUTDIR          write case SEED into OUTDIR (image or surface, recipe.yaml,
                                 case.json with the family, parameters and voxel counts)
  corpus.py --families           list the families and which seeds map to them
  corpus.py --cube-classes       count the 2x2x2 label configurations up to symmetry

Families (seed % 8):
  0 shells    head-like layers: lumpy brain, CSF 0..3 voxels (touching where the brain
              bulges), a skull shell 2..5 voxels, optionally a torus inside the brain;
              anisotropic voxels
  1 thin      tori, plates and tubes 1..4 voxels across, in one or several labels
  2 islands   islands of 1..8 voxels anywhere (also on the image border), one-voxel bridges
              and slits, random small cavities, inside a few blobs
  3 cube      one of the 2x2x2 configurations of up to four labels and the outside,
              up to the cube's 48 symmetries and renaming of labels (index seed // 8)
  4 block     a 3x3x3 block of random labels 0..4
  5 hull      poor surfaces for --from tetra: convex hulls of random points (needles and
              caps), size jumps (clustered points), several disjoint shells
  6 nested    nested hull shells with region_in/region_out arrays (--from tetra)
  7 mixed     a few random blobs of several labels touching each other, anisotropic voxels

Runs with Debian's /usr/bin/python3 (python3-numpy, python3-vtk9).
"""
import gzip
import itertools
import json
import os
import struct
import sys

import numpy as np

# vtk is imported here, once, not inside the functions: its lazy loading is not thread-safe,
# and run.py makes cases from several threads.
import vtk
from vtk.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray, vtk_to_numpy

FAMILIES = ["shells", "thin", "islands", "cube", "block", "hull", "nested", "mixed"]


# ------------------------------------------------------------------------------ writing
def write_nifti(path, labels, spacing):
    """Writes an int16 NIfTI-1 image (.nii or .nii.gz) with an sform of `spacing` (mm)."""
    labels = np.asarray(labels, dtype=np.int16)
    nx, ny, nz = labels.shape
    hdr = bytearray(352)
    struct.pack_into("<i", hdr, 0, 348)
    struct.pack_into("<8h", hdr, 40, 3, nx, ny, nz, 1, 1, 1, 1)
    struct.pack_into("<hh", hdr, 70, 4, 16)  # datatype int16, bitpix
    struct.pack_into("<8f", hdr, 76, 1.0, spacing[0], spacing[1], spacing[2], 1, 1, 1, 1)
    struct.pack_into("<f", hdr, 108, 352.0)  # vox_offset
    struct.pack_into("<f", hdr, 112, 1.0)  # scl_slope
    struct.pack_into("<B", hdr, 123, 10 | 8)  # xyzt_units: mm, s
    struct.pack_into("<hh", hdr, 252, 0, 1)  # qform_code 0, sform_code 1 (scanner)
    struct.pack_into("<4f", hdr, 280, spacing[0], 0, 0, 0)
    struct.pack_into("<4f", hdr, 296, 0, spacing[1], 0, 0)
    struct.pack_into("<4f", hdr, 312, 0, 0, spacing[2], 0)
    hdr[344:348] = b"n+1\0"
    data = bytes(hdr) + labels.transpose(2, 1, 0).tobytes()  # x fastest
    if path.endswith(".gz"):
        with gzip.GzipFile(path, "wb", mtime=0) as f:
            f.write(data)
    else:
        with open(path, "wb") as f:
            f.write(data)


def write_vtp(path, points, triangles, region_in, region_out):
    """Writes triangles with cell arrays region_in/region_out as VTK XML PolyData."""

    pts = vtk.vtkPoints()
    pts.SetData(numpy_to_vtk(np.ascontiguousarray(points, dtype=np.float64), deep=True))
    tri = np.asarray(triangles, dtype=np.int64)
    cells = np.hstack([np.full((len(tri), 1), 3, dtype=np.int64), tri]).ravel()
    ca = vtk.vtkCellArray()
    ca.SetCells(len(tri), numpy_to_vtkIdTypeArray(cells, deep=True))
    poly = vtk.vtkPolyData()
    poly.SetPoints(pts)
    poly.SetPolys(ca)
    for name, values in (("region_in", region_in), ("region_out", region_out)):
        arr = numpy_to_vtk(np.asarray(values, dtype=np.int32), deep=True)
        arr.SetName(name)
        poly.GetCellData().AddArray(arr)
    w = vtk.vtkXMLPolyDataWriter()
    w.SetFileName(path)
    w.SetInputData(poly)
    w.SetDataModeToAscii()
    if not w.Write():
        raise RuntimeError("cannot write " + path)


# ------------------------------------------------------------------------------ images
def grid(shape, spacing):
    """Physical coordinates (mm) of the voxel centres, centred on the image."""
    axes = [(np.arange(n) - (n - 1) / 2.0) * s for n, s in zip(shape, spacing)]
    return np.meshgrid(*axes, indexing="ij")


def lumpy_radius(rng, x, y, z, base, amplitude, lumps):
    """base * (1 + sum of random smooth bumps) along the direction of (x, y, z)."""
    r = np.sqrt(x * x + y * y + z * z) + 1e-12
    u = np.stack([x / r, y / r, z / r])
    f = np.ones_like(r)
    for _ in range(lumps):
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        width = rng.uniform(0.2, 0.6)
        dot = np.tensordot(d, u, axes=1)
        f += amplitude * rng.uniform(-1, 1) * np.exp(-(1 - dot) / width**2 * 2)
    return r, base * f


def anisotropic_spacing(rng):
    return [float(round(rng.uniform(0.7, 1.3), 3)) for _ in range(3)]


def family_shells(rng):
    spacing = anisotropic_spacing(rng)
    n = int(rng.integers(40, 60))
    shape = (n, int(n * rng.uniform(0.85, 1.15)), int(n * rng.uniform(0.8, 1.1)))
    x, y, z = grid(shape, spacing)
    half = min(s * spacing[i] for i, s in enumerate(shape)) / 2.0
    vox = min(spacing)
    skull_out = half - 2 * vox
    skull = rng.uniform(2, 5) * vox
    csf = rng.uniform(0, 3) * vox
    r, brain_r = lumpy_radius(rng, x, y, z, skull_out - skull - csf, rng.uniform(0.02, 0.12),
                              int(rng.integers(3, 9)))
    brain_r = np.minimum(brain_r, skull_out - skull)  # bulges touch the skull: CSF 0
    lab = np.zeros(shape, np.int16)
    lab[r < skull_out] = 3
    lab[r < skull_out - skull] = 2
    lab[r < brain_r] = 1
    params = {"skull_voxels": skull / vox, "csf_voxels": csf / vox}
    if rng.random() < 0.6:  # a torus (e.g. a ventricle ring) inside the brain
        R = (skull_out - skull - csf) * rng.uniform(0.3, 0.5)
        tube = rng.uniform(1.5, 4.0) * vox
        q = np.sqrt((np.sqrt(x * x + y * y) - R) ** 2 + z * z)
        lab[(q < tube) & (lab == 1)] = 4
        params["torus_tube_voxels"] = tube / vox
    return lab, spacing, params


def family_thin(rng):
    spacing = anisotropic_spacing(rng)
    shape = tuple(int(rng.integers(28, 44)) for _ in range(3))
    x, y, z = grid(shape, spacing)
    vox = min(spacing)
    lab = np.zeros(shape, np.int16)
    params = {"objects": []}
    for k in range(int(rng.integers(1, 4))):
        label = int(rng.integers(1, 4))
        c = rng.uniform(-0.25, 0.25, size=3) * np.array(shape) * spacing
        kind = rng.choice(["torus", "plate", "tube"])
        thick = rng.uniform(1.0, 4.0) * vox
        rot = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        px, py, pz = (np.tensordot(rot, np.stack([x - c[0], y - c[1], z - c[2]]), axes=1))
        size = 0.3 * min(np.array(shape) * spacing)
        if kind == "torus":
            m = np.sqrt((np.sqrt(px**2 + py**2) - size * 0.6) ** 2 + pz**2) < thick / 2
        elif kind == "plate":
            m = (np.abs(pz) < thick / 2) & (np.sqrt(px**2 + py**2) < size)
        else:
            m = (np.sqrt(px**2 + py**2) < thick / 2) & (np.abs(pz) < size)
        lab[m] = label
        params["objects"].append({"kind": str(kind), "label": label, "voxels": thick / vox})
    if not lab.any():
        lab[shape[0] // 2, shape[1] // 2, shape[2] // 2] = 1
    return lab, spacing, params


def family_islands(rng):
    spacing = anisotropic_spacing(rng) if rng.random() < 0.5 else [1.0, 1.0, 1.0]
    shape = tuple(int(rng.integers(20, 32)) for _ in range(3))
    x, y, z = grid(shape, spacing)
    lab = np.zeros(shape, np.int16)
    params = {"islands": 0, "bridges": 0, "slits": 0, "cavities": 0}
    for _ in range(int(rng.integers(1, 3))):  # blobs
        c = rng.uniform(-0.2, 0.2, size=3) * np.array(shape) * spacing
        rad = rng.uniform(0.15, 0.3) * min(np.array(shape) * spacing)
        lab[(x - c[0]) ** 2 + (y - c[1]) ** 2 + (z - c[2]) ** 2 < rad**2] = int(rng.integers(1, 4))
    for _ in range(int(rng.integers(0, 3))):  # one-voxel bridge along an axis
        a = int(rng.integers(0, 3))
        i0 = [int(rng.integers(2, s - 2)) for s in shape]
        sl = [slice(i, i + 1) for i in i0]
        sl[a] = slice(1, shape[a] - 1)
        lab[tuple(sl)] = int(rng.integers(1, 4))
        params["bridges"] += 1
    for _ in range(int(rng.integers(0, 3))):  # one-voxel slit through whatever is there
        a = int(rng.integers(0, 3))
        i = int(rng.integers(2, shape[a] - 2))
        sl = [slice(None)] * 3
        sl[a] = slice(i, i + 1)
        other = [b for b in range(3) if b != a]
        for b in other:
            lo = int(rng.integers(0, shape[b] // 2))
            sl[b] = slice(lo, lo + shape[b] // 2)
        lab[tuple(sl)] = 0
        params["slits"] += 1
    for _ in range(int(rng.integers(0, 4))):  # cavities of 1..8 voxels inside labels
        i = [int(rng.integers(1, s - 3)) for s in shape]
        d = [int(v) for v in rng.integers(1, 3, size=3)]
        lab[i[0]:i[0] + d[0], i[1]:i[1] + d[1], i[2]:i[2] + d[2]] = int(rng.integers(0, 4))
        params["cavities"] += 1
    for _ in range(int(rng.integers(1, 6))):  # islands, also on the border
        d = [int(v) for v in rng.integers(1, 3, size=3)]
        i = [int(rng.choice([0, s - d[k], int(rng.integers(0, s - d[k]))]))
             for k, s in enumerate(shape)]
        lab[i[0]:i[0] + d[0], i[1]:i[1] + d[1], i[2]:i[2] + d[2]] = int(rng.integers(1, 5))
        params["islands"] += 1
    return lab, spacing, params


# The 48 symmetries of the cube as permutations of the 8 voxels of a 2x2x2 block.
def cube_symmetries():
    corners = [(i, j, k) for i in range(2) for j in range(2) for k in range(2)]
    index = {c: n for n, c in enumerate(corners)}
    perms = []
    for axes in itertools.permutations(range(3)):
        for flips in itertools.product((0, 1), repeat=3):
            p = []
            for c in corners:
                d = [c[axes[a]] ^ flips[a] for a in range(3)]
                p.append(index[tuple(d)])
            perms.append(p)
    return np.array(perms)


def cube_classes():
    """Canonical 2x2x2 configurations of labels 0..4 (0 = outside), one per class under the
    cube's symmetries and renaming of labels 1..4; the all-outside block is left out.
    Canonical form: the smallest code over the 48 symmetries after renaming labels in the
    order of first appearance. Cost: 5^8 x 48, a second or two."""
    codes = np.arange(5**8)
    digits = np.stack([(codes // 5**i) % 5 for i in range(8)], axis=1)  # voxel i = digit i
    best = np.full(len(codes), np.iinfo(np.int64).max, dtype=np.int64)
    for p in cube_symmetries():
        d = digits[:, p]
        out = np.zeros_like(d)
        mapping = np.zeros((len(d), 5), dtype=np.int64)  # label -> new label (0: not yet)
        next_label = np.ones(len(d), dtype=np.int64)
        rows = np.arange(len(d))
        for i in range(8):
            v = d[:, i]
            new = (v > 0) & (mapping[rows, v] == 0)
            mapping[rows[new], v[new]] = next_label[new]
            next_label += new
            out[:, i] = np.where(v > 0, mapping[rows, v], 0)
        code = (out * (5 ** np.arange(7, -1, -1))).sum(axis=1)
        np.minimum(best, code, out=best)
    classes = np.unique(best)
    return classes[classes > 0]


cube_classes_cached = None


def family_cube(rng, seed):
    global cube_classes_cached
    if cube_classes_cached is None:
        cube_classes_cached = cube_classes()
    classes = cube_classes_cached
    code = int(classes[(seed // 8) % len(classes)])
    digits = [(code // 5 ** (7 - i)) % 5 for i in range(8)]
    lab = np.array(digits, dtype=np.int16).reshape(2, 2, 2)
    s = float(rng.choice([1.0, 10.0, 100.0]))
    return lab, [s, s, s], {"class_index": (seed // 8) % len(classes), "classes": len(classes)}


def family_block(rng):
    lab = rng.integers(0, 5, size=(3, 3, 3)).astype(np.int16)
    if not lab.any():
        lab[1, 1, 1] = 1
    s = float(rng.choice([1.0, 2.0, 10.0]))
    return lab, [s, s, s], {}


def family_mixed(rng):
    spacing = anisotropic_spacing(rng)
    shape = tuple(int(rng.integers(24, 40)) for _ in range(3))
    x, y, z = grid(shape, spacing)
    lab = np.zeros(shape, np.int16)
    n = int(rng.integers(2, 6))
    for k in range(n):
        c = rng.uniform(-0.2, 0.2, size=3) * np.array(shape) * spacing
        r, rad = lumpy_radius(rng, x - c[0], y - c[1], z - c[2],
                              rng.uniform(0.15, 0.3) * min(np.array(shape) * spacing),
                              0.15, 4)
        lab[r < rad] = k + 1
    return lab, spacing, {"blobs": n}


# ------------------------------------------------------------------------------ surfaces
def hull(points):
    """Outward-oriented convex hull triangles of `points` (vtkDelaunay3D + surface)."""

    pts = vtk.vtkPoints()
    pts.SetData(numpy_to_vtk(np.ascontiguousarray(points, dtype=np.float64), deep=True))
    poly = vtk.vtkPolyData()
    poly.SetPoints(pts)
    d = vtk.vtkDelaunay3D()
    d.SetInputData(poly)
    d.Update()
    surf = vtk.vtkDataSetSurfaceFilter()
    surf.SetInputConnection(d.GetOutputPort())
    surf.Update()
    out = surf.GetOutput()
    xyz = vtk_to_numpy(out.GetPoints().GetData()).astype(np.float64)
    tri = vtk_to_numpy(out.GetPolys().GetConnectivityArray()).reshape(-1, 3).astype(np.int64)
    centre = xyz.mean(axis=0)
    a, b, c = xyz[tri[:, 0]], xyz[tri[:, 1]], xyz[tri[:, 2]]
    n = np.cross(b - a, c - a)
    flip = ((a - centre) * n).sum(axis=1) < 0
    tri[flip] = tri[flip][:, [0, 2, 1]]
    used = np.unique(tri)  # points inside the hull are not surface vertices
    remap = np.full(len(xyz), -1)
    remap[used] = np.arange(len(used))
    return xyz[used], remap[tri]


def random_shell(rng, centre, radius, n):
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    axes = rng.uniform(0.5, 1.0, size=3) * radius
    p = d * axes
    if rng.random() < 0.5:  # size jump: a dense cluster on one side
        k = int(n * rng.uniform(0.3, 0.7))
        dirn = rng.normal(size=3)
        dirn /= np.linalg.norm(dirn)
        q = dirn + rng.normal(scale=0.15, size=(k, 3))
        q /= np.linalg.norm(q, axis=1)[:, None]
        p = np.vstack([p, q * axes])
    return p + centre


def family_hull(rng):
    shells = int(rng.integers(1, 4))
    pts_all, tri_all, rin, rout = [], [], [], []
    offset = 0
    for k in range(shells):
        centre = np.array([k * 40.0, rng.uniform(-3, 3), 0.0])
        p, t = hull(random_shell(rng, centre, rng.uniform(8, 16), int(rng.integers(30, 300))))
        pts_all.append(p)
        tri_all.append(t + offset)
        offset += len(p)
        rin += [k + 1] * len(t)
        rout += [0] * len(t)
    return np.vstack(pts_all), np.vstack(tri_all), rin, rout, {"shells": shells}


def family_nested(rng):
    levels = int(rng.integers(2, 4))
    pts_all, tri_all, rin, rout = [], [], [], []
    offset = 0
    radius = 20.0
    for k in range(levels):
        p, t = hull(random_shell(rng, np.zeros(3), radius, int(rng.integers(40, 250))))
        # the next shell lies strictly inside this one: scale below its inscribed sphere
        pts_all.append(p)
        tri_all.append(t + offset)
        offset += len(p)
        rin += [k + 1] * len(t)
        rout += [k] * len(t)
        inner = np.min(np.abs(((p[t[:, 0]]) * np.cross(p[t[:, 1]] - p[t[:, 0]],
                                                       p[t[:, 2]] - p[t[:, 0]])).sum(axis=1)
                              / np.linalg.norm(np.cross(p[t[:, 1]] - p[t[:, 0]],
                                                        p[t[:, 2]] - p[t[:, 0]]), axis=1)))
        radius = inner * rng.uniform(0.35, 0.8)
    return np.vstack(pts_all), np.vstack(tri_all), rin, rout, {"levels": levels}


# ------------------------------------------------------------------------------ driver
def make_case(seed, outdir):
    """Writes case `seed` into outdir; returns the case description (also case.json)."""
    rng = np.random.default_rng(seed)
    family = FAMILIES[seed % len(FAMILIES)]
    os.makedirs(outdir, exist_ok=True)
    case = {"seed": seed, "family": family}
    recipe = ["# torture corpus case %d (%s): tests/torture/corpus.py %d DIR" % (seed, family, seed)]
    if family in ("hull", "nested"):
        fn = family_hull if family == "hull" else family_nested
        p, t, rin, rout, params = fn(rng)
        write_vtp(os.path.join(outdir, "surface.vtp"), p, t, rin, rout)
        case.update(kind="surface", params=params, triangles=int(len(t)))
        alpha = round(float(rng.uniform(1.05, 1.3)), 3)
        recipe += ["input:", "  surface: surface.vtp", "output:", "  dir: out",
                   "tetra:", "  stretching: %g" % alpha]
        case["from"] = "tetra"
    else:
        if family == "cube":
            lab, spacing, params = family_cube(rng, seed)
        else:
            lab, spacing, params = {
                "shells": family_shells, "thin": family_thin, "islands": family_islands,
                "block": family_block, "mixed": family_mixed}[family](rng)
        write_nifti(os.path.join(outdir, "labels.nii.gz"), lab, spacing)
        values, counts = np.unique(lab[lab > 0], return_counts=True)
        vox = float(np.prod(spacing))
        case.update(kind="image", params=params, shape=list(lab.shape), spacing=spacing,
                    labels={str(int(v)): {"voxels": int(c), "volume_mm3": c * vox}
                            for v, c in zip(values, counts)})
        h = round(float(min(spacing) * rng.uniform(0.8, 2.5)), 3)
        recipe += ["input:", "  image: labels.nii.gz", "  labels: all", "output:", "  dir: out",
                   "remesh:", "  edge_length: %g" % h]
        case["edge_length"] = h
    with open(os.path.join(outdir, "recipe.yaml"), "w") as f:
        f.write("\n".join(recipe) + "\n")
    with open(os.path.join(outdir, "case.json"), "w") as f:
        json.dump(case, f, indent=1, default=float)
    return case


def main(argv):
    if len(argv) >= 1 and argv[0] == "--families":
        for i, f in enumerate(FAMILIES):
            print("%d %s: seeds %d, %d, %d, ..." % (i, f, i, i + 8, i + 16))
        return 0
    if len(argv) >= 1 and argv[0] == "--cube-classes":
        print(len(cube_classes()))
        return 0
    if len(argv) != 2:
        print(__doc__)
        return 2
    case = make_case(int(argv[0]), argv[1])
    print(json.dumps({k: case[k] for k in ("seed", "family", "kind")}))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
