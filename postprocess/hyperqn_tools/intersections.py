"""Counts the intersecting triangle pairs of each frame of a run: a check, independent of the
simulator, that bodies and cloth did not pass through each other or through themselves.

A frame's surface is the boundary faces of its tets (faces of one tet only) and its cloth
triangles; strand segments are not surfaces and are left out. Two surface triangles intersect
when they cross: each has vertices strictly on both sides of the other's plane and the two
segments where they cut the line common to both planes overlap (Moeller's interval test), or,
when one lies in the other's plane, their interiors overlap. "Strictly" means by more than the
tolerance tol = rtol x the diagonal of the frame's bounding box (rtol 1e-8 unless told): a vertex
within tol of a plane counts as on it, so triangles that touch at a point or along an edge, or
cross by no more than tol, do not count. Pairs that share a vertex (neighbours in a mesh) are
never counted, and triangles whose height is at most tol (degenerate) take no part.

    /usr/bin/python3 -m hyperqn_tools.intersections OUTDIR [--frames N ...] [--json FILE] [--rtol R]

prints per frame the number of intersecting pairs and the largest of them; exit 0, or 1 with a
message for a directory that is missing or holds no readable frames. docs/outputs.md describes it.
"""
import argparse
import json
import os
import sys

import numpy as np

from hyperqn_tools.cli import ArgumentParser, fraction, unwritable_file, writing
from hyperqn_tools.output import frame_list, read_frame

RTOL = 1e-8
TET_FACES = ((1, 2, 3), (0, 3, 2), (0, 1, 3), (0, 2, 1))


def surface_triangles(cells):
    """(m, 3) vertex rows of a frame's surface: its tets' boundary faces, then its cloth
    triangles. cells: {meshio cell type: rows} (Frame.cells)."""
    tets = cells.get("tetra", np.zeros((0, 4), dtype=np.int64))
    faces = np.concatenate([tets[:, list(f)] for f in TET_FACES])
    _, first, count = np.unique(np.sort(faces, axis=1), axis=0, return_index=True, return_counts=True)
    boundary = faces[np.sort(first[count == 1])]
    return np.concatenate([boundary, cells.get("triangle", np.zeros((0, 3), dtype=np.int64))])


def frame_tolerance(points, rtol=RTOL):
    """rtol x the diagonal of the points' bounding box."""
    return rtol * float(np.linalg.norm(points.max(axis=0) - points.min(axis=0))) if len(points) else 0.0


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _snapped_distances(T, origin, normal, tol):
    """Signed distances of the vertices of T (m, 3, 3) from the planes (origin, unit normal), 0
    within tol."""
    d = np.einsum("mij,mj->mi", T - origin[:, None, :], normal)
    return np.where(np.abs(d) <= tol, 0.0, d)


def _cut_interval(T, d, direction):
    """Where triangles T, with snapped distances d (of opposite signs) from a plane, cut it: the
    interval (lo, hi) of the cut segment's projection onto the unit direction of the cut line."""
    t = np.einsum("mij,mj->mi", T, direction)
    lo = np.where(d == 0, t, np.inf).min(axis=1)
    hi = np.where(d == 0, t, -np.inf).max(axis=1)
    for i, j in ((0, 1), (1, 2), (2, 0)):
        crosses = d[:, i] * d[:, j] < 0
        x = t[:, i] + d[:, i] / np.where(crosses, d[:, i] - d[:, j], 1.0) * (t[:, j] - t[:, i])
        lo = np.where(crosses, np.minimum(lo, x), lo)
        hi = np.where(crosses, np.maximum(hi, x), hi)
    return lo, hi


def _coplanar_overlap(A, B, base, normal, tol):
    """Whether the interiors of triangles A and B, both within tol of the plane of triangle base
    (unit normal given), overlap by more than tol: no edge normal of either separates them (in 2D,
    in that plane)."""
    e1 = _unit(base[:, 1] - base[:, 0])
    e2 = np.cross(normal, e1)
    a = np.stack([np.einsum("mij,mj->mi", A, e) for e in (e1, e2)], axis=2)  # (m, 3, 2)
    b = np.stack([np.einsum("mij,mj->mi", B, e) for e in (e1, e2)], axis=2)
    overlap = np.ones(len(A), dtype=bool)
    for tri in (a, b):
        for i in range(3):
            edge = tri[:, (i + 1) % 3] - tri[:, i]
            axis = _unit(np.stack([-edge[:, 1], edge[:, 0]], axis=1))
            pa, pb = np.einsum("mij,mj->mi", a, axis), np.einsum("mij,mj->mi", b, axis)
            overlap &= np.minimum(pa.max(1), pb.max(1)) - np.maximum(pa.min(1), pb.min(1)) > tol
    return overlap


def triangles_intersect(A, B, tol):
    """Whether triangle A[k] (vertices (m, 3, 3)) intersects B[k], for each k, as the module's
    docstring defines it. The triangles must not be degenerate."""
    nA = _unit(np.cross(A[:, 1] - A[:, 0], A[:, 2] - A[:, 0]))
    nB = _unit(np.cross(B[:, 1] - B[:, 0], B[:, 2] - B[:, 0]))
    dB = _snapped_distances(B, A[:, 0], nA, tol)  # B's vertices from A's plane
    dA = _snapped_distances(A, B[:, 0], nB, tol)
    in_A_plane, in_B_plane = np.all(dB == 0, axis=1), np.all(dA == 0, axis=1)
    coplanar = in_A_plane | in_B_plane

    def straddles(d):
        return (d.max(axis=1) > 0) & (d.min(axis=1) < 0)

    result = np.zeros(len(A), dtype=bool)
    k = np.flatnonzero(~coplanar & straddles(dA) & straddles(dB))
    if len(k):
        direction = _unit(np.cross(nA[k], nB[k]))
        loA, hiA = _cut_interval(A[k], dA[k], direction)
        loB, hiB = _cut_interval(B[k], dB[k], direction)
        result[k] = np.minimum(hiA, hiB) - np.maximum(loA, loB) > tol
    k = np.flatnonzero(coplanar)
    if len(k):
        base = np.where(in_A_plane[k, None, None], A[k], B[k])
        normal = np.where(in_A_plane[k, None], nA[k], nB[k])
        result[k] = _coplanar_overlap(A[k], B[k], base, normal, tol)
    return result


def overlapping_boxes(lo, hi):
    """(p, 2) index pairs i < j of the boxes [lo, hi] (n, 3) that overlap (closed), found through a
    uniform grid whose cell is about a box's size."""
    n = len(lo)
    if n < 2:
        return np.zeros((0, 2), dtype=np.int64)
    size = (hi - lo).max(axis=1)
    # Not much smaller than the largest box (which would fill too many cells), and at most 2^20
    # cells along an axis (so that a cell's key fits in 64 bits).
    cell = max(size.mean(), size.max() / 8, (hi.max(0) - lo.min(0)).max() / 2**20)
    if cell == 0:  # all boxes are one point
        cell = 1.0
    first = np.floor((lo - lo.min(0)) / cell).astype(np.int64)
    span = np.floor((hi - lo.min(0)) / cell).astype(np.int64) - first + 1
    grid = (first + span).max(axis=0)
    # One entry per box and grid cell it touches, sorted by cell.
    count = span.prod(axis=1)
    box = np.repeat(np.arange(n), count)
    k = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    sx, sy = span[box, 0], span[box, 1]
    cx, cy, cz = first[box, 0] + k % sx, first[box, 1] + (k // sx) % sy, first[box, 2] + k // (sx * sy)
    key = cx + grid[0] * (cy + grid[1] * cz)
    order = np.argsort(key, kind="stable")
    key, box = key[order], box[order]
    # Every entry paired with the entries after it in its cell.
    partners = np.searchsorted(key, key, side="right") - np.arange(len(key)) - 1
    a = np.repeat(np.arange(len(key)), partners)
    b = a + 1 + np.arange(len(a)) - np.repeat(np.cumsum(partners) - partners, partners)
    i, j = np.minimum(box[a], box[b]), np.maximum(box[a], box[b])
    pair = np.unique(i * n + j)  # a pair may share several cells
    i, j = pair // n, pair % n
    keep = np.all(lo[i] <= hi[j], axis=1) & np.all(lo[j] <= hi[i], axis=1)
    return np.stack([i[keep], j[keep]], axis=1)


def degenerate(points, triangles, tol):
    """Whether each triangle's height over its longest edge is at most tol."""
    T = points[triangles]
    twice_area = np.linalg.norm(np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0]), axis=1)
    longest = np.linalg.norm(T - np.roll(T, 1, axis=1), axis=2).max(axis=1)
    return twice_area <= tol * longest


def share_a_vertex(triangles, pairs):
    a, b = triangles[pairs[:, 0]], triangles[pairs[:, 1]]
    return np.any(a[:, :, None] == b[:, None, :], axis=(1, 2))


def intersecting_pairs(points, triangles, tol):
    """(p, 2) index pairs i < j of the triangles (rows of vertex indices into points) that
    intersect, as the module's docstring defines it: pairs sharing a vertex and degenerate
    triangles excluded."""
    usable = np.flatnonzero(~degenerate(points, triangles, tol))
    T = points[triangles[usable]]
    pairs = usable[overlapping_boxes(T.min(axis=1), T.max(axis=1))]
    pairs = pairs[~share_a_vertex(triangles, pairs)]
    hit = triangles_intersect(points[triangles[pairs[:, 0]]], points[triangles[pairs[:, 1]]], tol)
    return pairs[hit]


def check_frame(frame, rtol=RTOL):
    """{triangles, degenerate_triangles, tolerance, intersecting_pairs} of a Frame."""
    triangles = surface_triangles(frame.cells)
    tol = frame_tolerance(frame.points, rtol)
    return {"triangles": len(triangles),
            "degenerate_triangles": int(np.count_nonzero(degenerate(frame.points, triangles, tol))),
            "tolerance": tol,
            "intersecting_pairs": len(intersecting_pairs(frame.points, triangles, tol))}


def check_run(outdir, frames=None, rtol=RTOL):
    """[{frame, time, ...check_frame}] of the run's frames (all, or those numbered in frames).
    Raises ValueError for a directory without frames or frames it does not hold."""
    if not os.path.isdir(outdir):
        raise ValueError(f"{outdir}: no such directory")
    listed = frame_list(outdir)
    if not listed:
        raise ValueError(f"{outdir}: no .pvd or .xdmf listing frames (not a run's output directory?)")
    if frames is not None:
        wanted = set(frames)
        missing = sorted(wanted - {n for n, _, _ in listed})
        if missing:
            raise ValueError(f"{outdir}: no frame {', '.join(map(str, missing))} "
                             f"(it holds {len(listed)} frames, {listed[0][0]} to {listed[-1][0]})")
        listed = [entry for entry in listed if entry[0] in wanted]
    rows = []
    for number, time, path in listed:
        rows.append({"frame": number, "time": time, **check_frame(read_frame(path, number), rtol)})
    return rows


def main(argv=None):
    p = ArgumentParser(prog="python3 -m hyperqn_tools.intersections", description=__doc__,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("outdir", help="a run's output directory")
    p.add_argument("--frames", type=int, nargs="+", help="frame numbers to check (default: all)")
    p.add_argument("--json", help="also write the counts to this JSON file")
    p.add_argument("--rtol", type=fraction, default=RTOL,
                   help="tolerance relative to the frame's bounding-box diagonal, in [0, 1)")
    a = p.parse_args(argv)
    why = a.json and unwritable_file(a.json, parents=False)  # its directory is not made, as force_displacement's files
    if why:  # found before the frames are read and the counts printed
        p.error(f"--json {why}")
    try:
        rows = check_run(a.outdir, a.frames, a.rtol)
    except ValueError as e:
        print(f"intersections: error: {e}", file=sys.stderr)
        return 1
    for r in rows:
        extra = f", {r['degenerate_triangles']} degenerate left out" if r["degenerate_triangles"] else ""
        print(f"frame {r['frame']:5d}  t = {r['time']:.6g}  {r['triangles']} surface triangles{extra}: "
              f"{r['intersecting_pairs']} intersecting pairs")
    worst = max(rows, key=lambda r: r["intersecting_pairs"])
    print(f"largest: {worst['intersecting_pairs']} intersecting pairs (frame {worst['frame']}); "
          f"tolerance {a.rtol:g} x the bounding-box diagonal")
    if a.json:
        try:  # writing: a full disk leaves no partial file
            with writing(a.json), open(a.json, "w") as f:
                json.dump({"outdir": a.outdir, "rtol": a.rtol, "frames": rows,
                           "largest": {"frame": worst["frame"], "intersecting_pairs": worst["intersecting_pairs"]}}, f, indent=1)
        except OSError as e:  # what unwritable_file cannot see (root on a read-only file system, a full disk)
            p.error(f"--json {a.json}: {e.strerror}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
