#!/usr/bin/python3
"""Writes a dog-bone tensile specimen (grip - fillet - gauge - fillet - grip) as a Medit .mesh of
tets: input/engineering/dogbone.yaml's mesh (docs/loads.md#scenes).

The specimen lies along x from 0 to `length`, its thickness along z from 0 to `--thickness`, its
width along y centred on y = 0. The width w(x) is `--grip-width` over each grip, `--gauge-width`
over the gauge in the middle, and in each fillet between them a half cosine from one to the other
(w and dw/dx continuous). A box of nx x ny x nz hexahedra is mapped onto it (y = eta w(x), eta in
[-1/2, 1/2]); each hexahedron is cut into 6 tets about its main diagonal (the same diagonal in
every one, so the cut is conforming), every tet positively oriented. The grips, fillets and gauge
start and end at vertex planes: their lengths must be multiples of length / nx. Standard library
and numpy.

    /usr/bin/python3 scripts/dogbone_mesh.py dogbone.mesh --cells 40 4 2
"""
import sys

import numpy as np

from tet_grid import kuhn_tets, orient_positive, write_medit, positive_number, ArgumentParser, positive_int

# The specimen's shape (m): 100 mm long, 4 mm thick; 20 mm wide grips 20 mm long, 15 mm fillets,
# a 10 mm wide gauge 30 mm long.
DEFAULTS = {"grip_length": 0.02, "fillet_length": 0.015, "gauge_length": 0.03, "grip_width": 0.02,
            "gauge_width": 0.01, "thickness": 0.004}


class Profile:
    """The specimen's width along x: grip, fillet, gauge, fillet, grip."""

    def __init__(self, grip_length, fillet_length, gauge_length, grip_width, gauge_width, thickness):
        self.grip_length, self.fillet_length, self.gauge_length = grip_length, fillet_length, gauge_length
        self.grip_width, self.gauge_width, self.thickness = grip_width, gauge_width, thickness
        self.length = 2 * grip_length + 2 * fillet_length + gauge_length

    def width(self, x):
        x = np.asarray(x, dtype=float)
        d = np.minimum(x, self.length - x)  # distance from the nearer end: the profile is symmetric
        s = np.clip((d - self.grip_length) / self.fillet_length, 0.0, 1.0)  # 0: grip, 1: gauge
        return self.gauge_width + (self.grip_width - self.gauge_width) * (1 + np.cos(np.pi * s)) / 2


def dogbone(profile, cells):
    """Vertices and positively oriented tets of the mapped box of cells = (nx, ny, nz) hexahedra."""
    nx, ny, nz = cells
    x = np.linspace(0.0, profile.length, nx + 1)
    for edge in (profile.grip_length, profile.grip_length + profile.fillet_length):
        if abs(edge / (profile.length / nx) - round(edge / (profile.length / nx))) > 1e-9:
            raise ValueError(f"x = {edge:g} is not a vertex plane of {nx} cells along {profile.length:g}")
    eta = np.linspace(-0.5, 0.5, ny + 1)
    z = np.linspace(0.0, profile.thickness, nz + 1)
    w = profile.width(x)
    I, J, K = np.meshgrid(np.arange(nx + 1), np.arange(ny + 1), np.arange(nz + 1), indexing="ij")
    X = np.column_stack([x[I.ravel()], eta[J.ravel()] * w[I.ravel()], z[K.ravel()]])

    def vertex(i, j, k):
        return (i * (ny + 1) + j) * (nz + 1) + k

    return X, orient_positive(X, kuhn_tets(vertex, (nx, ny, nz)))


def main(argv=None):
    p = ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("out", help="the .mesh file to write")
    for key, value in DEFAULTS.items():
        p.add_argument("--" + key.replace("_", "-"), type=positive_number, default=value, help=f"(m, default {value:g})")
    p.add_argument("--cells", type=positive_int, nargs=3, default=[40, 4, 2], metavar=("NX", "NY", "NZ"))
    a = p.parse_args(argv)
    profile = Profile(**{key: getattr(a, key) for key in DEFAULTS})
    if min(getattr(a, k) for k in DEFAULTS) <= 0 or a.gauge_width > a.grip_width or min(a.cells) < 1:
        p.error("need positive lengths, widths and thickness, gauge width <= grip width, cells >= 1")
    try:
        X, T = dogbone(profile, a.cells)
    except ValueError as e:
        p.error(str(e))
    write_medit(a.out, X, T)
    print("dog-bone: %d vertices, %d tets, %g m long" % (len(X), len(T), profile.length))
    return 0


if __name__ == "__main__":
    sys.exit(main())
