#!/usr/bin/python3
"""Region wedge angles of a surface network (not part of the test suite).

For every region r and every edge of r's closed boundary, the two faces of r at that edge
(oriented outward of r) make an interior dihedral angle measured inside r: the "wedge" of r
there. A tetrahedron of r holding that edge has a dihedral angle no larger than the wedge, so
the smallest wedge bounds the volume mesh quality from above.

    /usr/bin/python3 tests/bench/region_wedges.py SURFACE.vtu [--below 12] [--list 20]

Prints a histogram (wedges under 5, 10, 12, 15, 20, 30 degrees), the split by edge kind
(junction edge: >= 3 faces, i.e. on a curve where patches meet; or a 2-face edge) and the
smallest wedges with their place, region and the regions of their faces. Reads the VTU with
meshio (cell data region_in / region_out, as the remesh checkpoints write them). Faces are
oriented with their normal pointing out of region_in (checked: the enclosed volume of each
region comes out positive, else the sign is flipped).
"""
import argparse
import sys

import meshio
import numpy as np


def region_wedges(P, T, rin, rout):
    """Returns (angle_deg, region, v0, v1, faces_on_edge, f1, f2) arrays over region edges."""
    nf = len(T)
    # Region side records: the face as seen from the region (outward normal).
    recs_face = np.concatenate([np.arange(nf), np.arange(nf)])
    recs_reg = np.concatenate([rin, rout])
    recs_tri = np.concatenate([T, T[:, [0, 2, 1]]])
    keep = recs_reg != 0
    recs_face, recs_reg, recs_tri = recs_face[keep], recs_reg[keep], recs_tri[keep]
    # Orientation check: the enclosed volume of each region must be positive.
    a, b, c = P[recs_tri[:, 0]], P[recs_tri[:, 1]], P[recs_tri[:, 2]]
    vol6 = np.einsum('ij,ij->i', a, np.cross(b, c))
    regions = np.unique(recs_reg)
    vol = np.zeros(regions.max() + 1)
    np.add.at(vol, recs_reg, vol6)
    if np.sum(vol[regions] < 0) > len(regions) / 2:
        recs_tri = recs_tri[:, [0, 2, 1]]
    # Directed edges of each region's faces: (region, u, v) with the face's opposite vertex.
    n = len(recs_face)
    u = recs_tri[:, [0, 1, 2]].reshape(-1)
    v = recs_tri[:, [1, 2, 0]].reshape(-1)
    w = recs_tri[:, [2, 0, 1]].reshape(-1)
    rec = np.repeat(np.arange(n), 3)
    reg = recs_reg[rec]
    lo, hi = np.minimum(u, v), np.maximum(u, v)
    order = np.lexsort((u > v, hi, lo, reg))
    reg, lo, hi, u, v, w, rec = (x[order] for x in (reg, lo, hi, u, v, w, rec))
    same = (reg[:-1] == reg[1:]) & (lo[:-1] == lo[1:]) & (hi[:-1] == hi[1:])
    # Pairs: index i and i+1 with the same key; keys with exactly two uses.
    key_start = np.concatenate([[True], ~same])
    group = np.cumsum(key_start) - 1
    counts = np.bincount(group)
    i = np.where(key_start)[0]
    two = counts[group[i]] == 2
    i = i[two]
    j = i + 1
    # Face i holds u->v, face j the other direction (closed, oriented region).
    A, B = P[u[i]], P[v[i]]
    C1, C2 = P[w[i]], P[w[j]]
    e = B - A
    e /= np.linalg.norm(e, axis=1)[:, None]
    p1 = C1 - A
    p1 -= np.einsum('ij,ij->i', p1, e)[:, None] * e
    p2 = C2 - A
    p2 -= np.einsum('ij,ij->i', p2, e)[:, None] * e
    n1 = np.cross(B - A, C1 - A)  # outward normal of face 1
    cosang = np.einsum('ij,ij->i', p1, p2) / (np.linalg.norm(p1, axis=1) * np.linalg.norm(p2, axis=1))
    theta = np.degrees(np.arccos(np.clip(cosang, -1.0, 1.0)))
    convex = np.einsum('ij,ij->i', n1, C2 - A) < 0.0  # C2 behind face 1: the wedge is theta
    angle = np.where(convex, theta, 360.0 - theta)
    # Faces on the edge (all regions): a junction edge has >= 3.
    eu, ev = np.minimum(T, np.roll(T, -1, axis=1)).reshape(-1), np.maximum(T, np.roll(T, -1, axis=1)).reshape(-1)
    ekey = eu.astype(np.int64) * (P.shape[0] + 1) + ev
    uk, ucount = np.unique(ekey, return_counts=True)
    mykey = lo[i].astype(np.int64) * (P.shape[0] + 1) + hi[i]
    faces_on_edge = ucount[np.searchsorted(uk, mykey)]
    return angle, reg[i], lo[i], hi[i], faces_on_edge, recs_face[rec[i]], recs_face[rec[j]]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('surface')
    ap.add_argument('--below', type=float, default=12.0, help='list wedges under this (deg)')
    ap.add_argument('--list', type=int, default=15, help='how many of the smallest to list')
    args = ap.parse_args()
    m = meshio.read(args.surface)
    P = np.asarray(m.points, dtype=float)
    T = m.cells_dict['triangle'].astype(np.int64)
    k = [c.type for c in m.cells].index('triangle')
    rin = np.asarray(m.cell_data['region_in'][k]).astype(np.int64).reshape(-1)
    rout = np.asarray(m.cell_data['region_out'][k]).astype(np.int64).reshape(-1)
    angle, reg, a, b, nfe, f1, f2 = region_wedges(P, T, rin, rout)
    junction = nfe >= 3
    print(f'{args.surface}: {len(T)} faces, {len(np.unique(reg))} regions, {len(angle)} region edges '
          f'({int(junction.sum())} on junction edges)')
    print(f'smallest wedge {angle.min():.2f} deg; junction edges {angle[junction].min() if junction.any() else float("nan"):.2f}, '
          f'2-face edges {angle[~junction].min() if (~junction).any() else float("nan"):.2f}')
    print('  under (deg):   all  junction  2-face')
    for t in (5, 10, 12, 15, 20, 30):
        s = angle < t
        print(f'  {t:>5}      {int(s.sum()):>6} {int((s & junction).sum()):>8} {int((s & ~junction).sum()):>7}')
    order = np.argsort(angle, kind='stable')[:args.list]
    print(f'smallest {len(order)} (wedge, region, edge midpoint, faces on edge, regions of the two faces):')
    for q in order:
        mid = 0.5 * (P[a[q]] + P[b[q]])
        print(f'  {angle[q]:7.2f}  r{reg[q]:<4} ({mid[0]:.2f}, {mid[1]:.2f}, {mid[2]:.2f})  {nfe[q]} faces  '
              f'[{rin[f1[q]]}|{rout[f1[q]]}] [{rin[f2[q]]}|{rout[f2[q]]}]')
    return 0


if __name__ == '__main__':
    sys.exit(main())
