#!/usr/bin/python3
"""Writes a coarse solid ball as a Medit .mesh file: a cube's grid mapped onto the ball.

The cube [-1, 1]^3 is cut into `--cells` hexahedra per side, each into 6 tetrahedra about its
diagonal from its corner of least indices (Kuhn's cut, conforming), and every point (x, y, z) is moved
to x sqrt(1 - y^2/2 - z^2/2 + y^2 z^2/3) and its permutations (the cube's surface onto the sphere),
then scaled by `--radius`. The surface vertices lie on the sphere (its faces are chords); the tets at
the cube's corners are the flattest. Every tet is positively oriented. Standard library and numpy.

    /usr/bin/python3 scripts/ball_mesh.py ball.mesh --radius 0.1 --cells 6
"""
import sys

import numpy as np

from tet_grid import kuhn_tets, orient_positive, signed_volumes, write_medit, positive_number, ArgumentParser, positive_int


def ball(radius, cells):
    """Vertices and positively oriented tets of the ball."""
    s = np.linspace(-1.0, 1.0, cells + 1)
    X = np.stack(np.meshgrid(s, s, s, indexing="ij"), axis=-1).reshape(-1, 3)
    x2 = X * X
    # x sqrt(1 - y^2/2 - z^2/2 + y^2 z^2/3) and its permutations: smoother at the corners than the
    # radial map (its flattest tet 7x fatter at 6 cells).
    X = X * np.sqrt(1 - (x2.sum(axis=1, keepdims=True) - x2) / 2 + x2[:, [1, 0, 0]] * x2[:, [2, 2, 1]] / 3) * radius

    def vid(i, j, k):
        return (i * (cells + 1) + j) * (cells + 1) + k

    T = orient_positive(X, kuhn_tets(vid, (cells, cells, cells)))
    if not signed_volumes(X, T).min() > 0:  # a radius whose cube underflows double precision
        raise ValueError("its tets' volumes are 0 in double precision")
    return X, T


def main(argv=None):
    p = ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("out", help="the .mesh file to write")
    p.add_argument("--radius", type=positive_number, default=1.0, help="the ball's radius (m)")
    p.add_argument("--cells", type=positive_int, default=6, help="cells along each side of the mapped cube")
    a = p.parse_args(argv)
    if a.radius <= 0 or a.cells < 1:
        p.error("need radius > 0 and cells >= 1")
    try:
        X, T = ball(a.radius, a.cells)
    except ValueError as e:
        p.error(f"--radius {a.radius:g}: {e}")
    write_medit(a.out, X, T)
    print("ball: %d vertices, %d tets" % (len(X), len(T)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
