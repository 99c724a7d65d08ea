#!/usr/bin/python3
"""Writes a thick spherical shell (a hollow sphere) as a Medit .mesh file: Lamé's sphere under
internal pressure (docs/loads.md).

The shell lies between radii `--inner` and `--outer` around the origin. Its surface is a cube
sphere: each of the cube's 6 faces is an n x n grid, projected radially; `--layers` hexahedra
through the thickness, their radii spaced evenly or, with `--grading g`, their thicknesses
growing geometrically outwards, the outermost g times the innermost (finer where the stress
varies most, at the cavity). With `--tags` the boundary triangles follow the tets, with
reference 1 on the cavity's wall and 2 on the outer surface, for a region that selects a surface
by its tag. Each hexahedron is cut into 24 tetrahedra around
its centre and its faces' centres (every face into 4 triangles about its centre), so the cut is
conforming across the cube's faces, where the grids meet with different orientations. Every tet is
positively oriented. Standard library and numpy.

    /usr/bin/python3 scripts/shell_mesh.py shell.mesh --inner 1 --outer 2 --cells 8 --layers 4
"""
import sys

import numpy as np

from tet_grid import write_medit, positive_number, ArgumentParser, positive_int

# The cube's faces: (axis, sign); a face's grid runs over the two other axes.
FACES = [(axis, sign) for axis in range(3) for sign in (-1, 1)]


def layer_radii(inner, outer, layers, grading=1.0):
    """The radii of the layers' surfaces, inner to outer: the layers' thicknesses in geometric
    progression, the outermost `grading` times the innermost (1: even)."""
    if grading == 1.0:
        return [inner + (outer - inner) * k / layers for k in range(layers + 1)]
    q = grading ** (1.0 / (layers - 1)) if layers > 1 else 1.0
    widths = q ** np.arange(layers)
    return inner + (outer - inner) * np.concatenate([[0.0], np.cumsum(widths) / widths.sum()])


def shell(inner, outer, cells, layers, grading=1.0):
    """Vertices and positively oriented tets of the shell."""
    radii = layer_radii(inner, outer, layers, grading)
    index = {}  # a point's key -> its vertex
    X = []

    def vertex(p):
        key = tuple(np.round(p, 12))
        if key not in index:
            index[key] = len(X)
            X.append(p)
        return index[key]

    def on_shell(cube_point, r):
        return r * cube_point / np.linalg.norm(cube_point)

    tets = []
    for axis, sign in FACES:
        u_axis, v_axis = [a for a in range(3) if a != axis]
        for i in range(cells):
            for j in range(cells):
                for k in range(layers):
                    # The hex's 8 corners at parameters (i + di, j + dj) and layer k + dk.
                    def corner(di, dj, dk):
                        c = np.zeros(3)
                        c[axis] = sign
                        c[u_axis] = -1 + 2 * (i + di) / cells
                        c[v_axis] = -1 + 2 * (j + dj) / cells
                        return c, radii[k + dk]

                    corners = {(di, dj, dk): corner(di, dj, dk) for di in (0, 1) for dj in (0, 1) for dk in (0, 1)}
                    ids = {key: vertex(on_shell(*corners[key])) for key in corners}
                    pts = {key: X[ids[key]] for key in corners}
                    centre = vertex(np.mean([pts[key] for key in corners], axis=0))
                    # Each of the hex's 6 faces: its 4 corners in cyclic order.
                    faces = []
                    for fixed_dim in range(3):
                        for value in (0, 1):
                            cyc = [(0, 0), (1, 0), (1, 1), (0, 1)]
                            quad = []
                            for a, b in cyc:
                                key = [0, 0, 0]
                                free = [d for d in range(3) if d != fixed_dim]
                                key[fixed_dim], key[free[0]], key[free[1]] = value, a, b
                                quad.append(tuple(key))
                            faces.append(quad)
                    for quad in faces:
                        # The face's centre: the mean of its corners, so neighbours agree on it.
                        fc = vertex(np.mean([pts[q] for q in quad], axis=0))
                        for m in range(4):
                            tets.append([ids[quad[m]], ids[quad[(m + 1) % 4]], fc, centre])
    X = np.array(X)
    T = np.array(tets, dtype=np.int64)
    a, b, c, d = (X[T[:, m]] for m in range(4))
    vol = np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a)
    T[vol < 0, 2], T[vol < 0, 3] = T[vol < 0, 3].copy(), T[vol < 0, 2].copy()
    return X, T


def boundary_triangles(X, T, inner, outer):
    """The shell's boundary faces, each once and oriented outwards of the body, and their
    references: 1 on the cavity's wall, 2 on the outer surface."""
    faces = np.concatenate([T[:, [1, 2, 3]], T[:, [0, 3, 2]], T[:, [0, 1, 3]], T[:, [0, 2, 1]]])
    _, first, count = np.unique(np.sort(faces, axis=1), axis=0, return_index=True, return_counts=True)
    tri = faces[first[count == 1]]  # outward: each tet's faces above are ordered so (positive tets)
    radius = np.linalg.norm(X[tri].mean(axis=1), axis=1)
    return tri, np.where(radius < (inner + outer) / 2, 1, 2)


def main(argv=None):
    p = ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("out", help="the .mesh file to write")
    p.add_argument("--inner", type=positive_number, default=1.0, help="inner radius (m)")
    p.add_argument("--outer", type=positive_number, default=2.0, help="outer radius (m)")
    p.add_argument("--cells", type=positive_int, default=4, help="cells along each edge of a cube face")
    p.add_argument("--layers", type=positive_int, default=2, help="cells through the thickness")
    p.add_argument("--grading", type=positive_number, default=1.0,
                   help="the outermost layer's thickness over the innermost's (1: even)")
    p.add_argument("--tags", action="store_true",
                   help="also write the boundary triangles: reference 1 the cavity's wall, 2 the outer surface")
    a = p.parse_args(argv)
    if not (0 < a.inner < a.outer) or a.cells < 1 or a.layers < 1 or not a.grading > 0:
        p.error("need 0 < inner < outer, cells >= 1, layers >= 1 and grading > 0")
    X, T = shell(a.inner, a.outer, a.cells, a.layers, a.grading)
    if a.tags:
        write_medit(a.out, X, T, *boundary_triangles(X, T, a.inner, a.outer))
    else:
        write_medit(a.out, X, T)
    print("shell: %d vertices, %d tets" % (len(X), len(T)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
