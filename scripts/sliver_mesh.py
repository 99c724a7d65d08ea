#!/usr/bin/python3
"""Writes a box tetrahedralization with slivers as a Medit .mesh file, for tests.

The box [0, size] is cut into cubes of edge about `--element`, six tetrahedra per cube (the Kuhn
subdivision, conforming). Then, in a random order, a tet is turned into a sliver by moving one of
its vertices towards the plane of the opposite face until the tet's quality

    q = 6 sqrt(2) V / (longest edge)^3      (1 for a regular tet)

is a target drawn log-uniformly in [worst, 100 worst] (the first sliver gets exactly `worst`).
A move is kept only if every tet around the vertex keeps a positive volume and a quality >= worst;
the four vertices of a sliver are not moved again, so the mesh stays valid and conforming with no
inverted tet. It stops when `--fraction` of the tets are slivers or no candidate is left.

Prints the quality histogram (decades) and the worst quality. Standard library and numpy.

    /usr/bin/python3 scripts/sliver_mesh.py out.mesh --size 1 0.2 0.2 --element 0.05 \
        --worst 1e-5 --fraction 0.01 --seed 1
"""
import argparse
import itertools
import math
import random
import sys

import numpy as np

from tet_grid import kuhn_tets, orient_positive, signed_volumes, write_medit, positive_number, fraction, ArgumentParser, positive_int


def box_mesh(size, element):
    """Vertices and positively oriented tets of the Kuhn subdivision of [0, size]."""
    cells = [max(1, int(round(s / element))) for s in size]
    axes = [np.linspace(0.0, s, n + 1) for s, n in zip(size, cells)]
    X = np.array([[x, y, z] for z in axes[2] for y in axes[1] for x in axes[0]])  # x fastest
    nx, ny = cells[0] + 1, cells[1] + 1

    def vid(i, j, k):
        return i + nx * (j + ny * k)

    return X, orient_positive(X, kuhn_tets(vid, cells, i_fastest=True)), cells


def qualities(X, T):
    """6 sqrt(2) V / longest edge^3 per tet (signed: negative for an inverted tet)."""
    longest = np.zeros(len(T))
    for p, q in itertools.combinations(range(4), 2):
        longest = np.maximum(longest, np.linalg.norm(X[T[:, p]] - X[T[:, q]], axis=1))
    return 6.0 * math.sqrt(2.0) * signed_volumes(X, T) / longest**3


def tet_quality(p):
    """Quality of one tet given as 4 points (tuples)."""
    a, b, c, d = p
    u = (b[0] - a[0], b[1] - a[1], b[2] - a[2])
    v = (c[0] - a[0], c[1] - a[1], c[2] - a[2])
    w = (d[0] - a[0], d[1] - a[1], d[2] - a[2])
    vol = (u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) +
           u[2] * (v[0] * w[1] - v[1] * w[0])) / 6.0
    longest = max(math.dist(p[i], p[j]) for i, j in itertools.combinations(range(4), 2))
    return 6.0 * math.sqrt(2.0) * vol / longest**3


def make_slivers(X, T, worst, fraction, rng):
    """Moves vertices so that about fraction * len(T) tets become slivers; returns their count."""
    X_list = [tuple(x) for x in X.tolist()]
    T_list = T.tolist()
    around = [[] for _ in X_list]
    for e, t in enumerate(T_list):
        for v in t:
            around[v].append(e)
    locked = [False] * len(X_list)
    wanted = int(round(fraction * len(T_list)))
    made = 0
    order = list(range(len(T_list)))
    rng.shuffle(order)
    for e in order:
        if made >= wanted:
            break
        target = worst if made == 0 else worst * 100.0 ** rng.random()
        t = T_list[e]
        for slot in rng.sample(range(4), 4):
            v = t[slot]
            if locked[v]:
                continue
            face = [X_list[t[k]] for k in range(4) if k != slot]
            a, b, c = (np.array(p) for p in face)
            n = np.cross(b - a, c - a)
            n /= np.linalg.norm(n)
            x0 = np.array(X_list[v])
            dist = float(np.dot(x0 - a, n))
            if dist <= 0:
                continue

            def quality_at(s):  # s in (0, 1]: distance to the face plane as a fraction of dist
                pts = [X_list[w] for w in t]
                pts[slot] = tuple(x0 - (1.0 - s) * dist * n)
                return tet_quality(pts)

            lo, hi = 0.0, 1.0  # quality_at grows with s (the volume does, the longest edge barely)
            if quality_at(hi) <= target:
                continue
            for _ in range(80):
                mid = 0.5 * (lo + hi)
                if quality_at(mid) < target:
                    lo = mid
                else:
                    hi = mid
            new = tuple(x0 - (1.0 - hi) * dist * n)
            old = X_list[v]
            X_list[v] = new
            ok = all(tet_quality([X_list[w] for w in T_list[f]]) >= worst for f in around[v])
            if not ok:
                X_list[v] = old
                continue
            for w in t:
                locked[w] = True
            made += 1
            break
    X[:] = np.array(X_list)
    return made


def histogram(q):
    edges = [0.0, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1, 1.0 + 1e-12]
    lines = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        count = int(np.count_nonzero((q >= lo) & (q < hi)))
        lines.append(f"  [{lo:.0e}, {min(hi, 1.0):.0e}): {count}")
    inverted = int(np.count_nonzero(q <= 0))
    return "\n".join(lines) + f"\n  inverted or flat: {inverted}"


def main(argv=None):
    ap = ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("output", help="the .mesh file to write")
    ap.add_argument("--size", type=positive_number, nargs="+", default=[1.0],
                    help="box size: one number (a cube) or three (x y z); default 1")
    ap.add_argument("--element", type=positive_number, default=0.05, help="cube edge (element size); default 0.05")
    ap.add_argument("--worst", type=positive_number, default=1e-5, help="worst tet quality; default 1e-5")
    ap.add_argument("--fraction", type=fraction, default=0.01, help="fraction of tets made slivers; default 0.01")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args(argv)
    size = args.size * 3 if len(args.size) == 1 else args.size
    if len(size) != 3 or min(size) <= 0 or args.element <= 0:
        ap.error("--size takes 1 or 3 positive numbers, --element a positive number")
    if not 0 < args.worst < 1 or not 0 <= args.fraction <= 1:
        ap.error("--worst must be in (0, 1) and --fraction in [0, 1]")
    X, T, cells = box_mesh(size, args.element)
    made = make_slivers(X, T, args.worst, args.fraction, random.Random(args.seed))
    q = qualities(X, T)
    if q.min() <= 0:
        sys.exit("sliver_mesh: produced an inverted tet (bug)")
    write_medit(args.output, X, T)
    print(f"{args.output}: {len(X)} vertices, {len(T)} tets ({cells[0]}x{cells[1]}x{cells[2]} cubes), "
          f"{made} slivers, worst quality {q.min():.3e}")
    print("quality histogram:\n" + histogram(q))
    return 0


if __name__ == "__main__":
    sys.exit(main())
