"""Structured tetrahedral meshes for the mesh scripts (cylinder, dog-bone, shell, slit, sliver): the
Kuhn subdivision of a grid of hexahedra, positive orientation, and the Medit writer."""

import itertools
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, "postprocess"))
# The mesh scripts' command lines follow the tools' rule (a bad argument: one line, exit 1).
from hyperqn_tools.cli import ArgumentParser, positive_int  # noqa: E402,F401
from hyperqn_tools.cli import positive_float as positive_number  # noqa: E402,F401  sizes and ratios: finite, > 0


def kuhn_tets(vid, cells, i_fastest=False):
    """Six tets per cell of a grid of cells = (ni, nj, nk) hexahedra, each a path from the cell's
    corner (i, j, k) to the opposite one, one axis a step (conforming across cells); vid(i, j, k)
    numbers the vertices. Cells in the order (i, j, k) with i slowest, or with i fastest."""
    ni, nj, nk = cells
    if i_fastest:
        order = ((i, j, k) for k, j, i in itertools.product(range(nk), range(nj), range(ni)))
    else:
        order = itertools.product(range(ni), range(nj), range(nk))
    tets = []
    for i, j, k in order:
        for axes in itertools.permutations(range(3)):
            c = [i, j, k]
            path = [vid(*c)]
            for axis in axes:
                c[axis] += 1
                path.append(vid(*c))
            tets.append(path)
    return np.array(tets, dtype=np.int64)


def signed_volumes(X, T):
    a, b, c, d = (X[T[:, k]] for k in range(4))
    return np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a) / 6.0


def orient_positive(X, T):
    """T with the last two vertices of each negatively oriented tet swapped (in place)."""
    negative = signed_volumes(X, T) < 0
    T[negative, 2], T[negative, 3] = T[negative, 3].copy(), T[negative, 2].copy()
    return T


def fraction(text):
    """argparse type of a share: a number in [0, 1]."""
    import argparse

    try:
        x = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not 0 <= x <= 1:  # nan too
        raise argparse.ArgumentTypeError(f"{text!r}: must be a number in [0, 1]")
    return x


def write_medit(path, X, T, triangles=None, references=None):
    """X, T (0-based) as a Medit .mesh; with triangles (0-based rows) and their references, a
    Triangles section after the tets (boundary faces tagged for a region). A path that cannot be
    written ends the script with a message naming it."""
    try:
        f = open(path, "w")
    except OSError as e:
        raise SystemExit(f"{path}: cannot write it ({e.strerror})") from None
    with f:
        f.write("MeshVersionFormatted 1\nDimension 3\nVertices\n%d\n" % len(X))
        for p in X:
            f.write("%.17g %.17g %.17g 0\n" % tuple(p))
        f.write("Tetrahedra\n%d\n" % len(T))
        for t in T:
            f.write("%d %d %d %d 0\n" % tuple(int(v) + 1 for v in t))
        if triangles is not None:
            f.write("Triangles\n%d\n" % len(triangles))
            for t, ref in zip(triangles, references):
                f.write("%d %d %d %d\n" % (int(t[0]) + 1, int(t[1]) + 1, int(t[2]) + 1, int(ref)))
        f.write("End\n")
