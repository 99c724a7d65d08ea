#!/usr/bin/python3
"""Writes a split ring, a body with a narrow slit, as a Medit .mesh file, for tests and benchmarks.

The ring lies in the xy-plane around the z-axis, between radii `--inner` and `--outer`, `--depth`
deep in z, and is cut open at the top by a slit `--gap` wide: its two end faces are the planes
x = -gap/2 and x = +gap/2 (for y > 0), parallel, so the two faces are `gap` apart over their whole
area while no surface triangle of one end shares a vertex with the other's. This is the narrow gap
between two parts of one body that real meshes have (a slit, two limbs almost touching): a
self-contact distance must stay below it.

The ring is a grid of `--cells` (around, radial, depth) hexahedra in (angle, radius, z), each cut
into six tetrahedra (the Kuhn subdivision, conforming), every tet positively oriented. The
angle phi, measured from +y, runs over [phi0(r), 2 pi - phi0(r)] with r sin(phi0(r)) = gap/2,
so the ends are exactly the two planes.

Prints the counts, the bounding-box diagonal and the gap relative to it. Standard library and
numpy.

    /usr/bin/python3 scripts/slit_mesh.py ring.mesh --outer 0.5 --inner 0.3 --depth 0.2 \
        --gap-fraction 5e-5 --cells 48 4 4
"""
import math
import sys

import numpy as np

from tet_grid import kuhn_tets, orient_positive, write_medit, positive_number, ArgumentParser, positive_int


def split_ring(outer, inner, depth, gap, cells):
    """Vertices and positively oriented tets of the split ring."""
    na, nr, nz = cells
    X = []
    for k in range(nz + 1):
        z = depth * k / nz - depth / 2
        for j in range(nr + 1):
            r = inner + (outer - inner) * j / nr
            phi0 = math.asin(gap / (2 * r))
            for i in range(na + 1):
                phi = phi0 + (2 * math.pi - 2 * phi0) * i / na
                X.append((r * math.sin(phi), r * math.cos(phi), z))
    X = np.array(X)

    def vid(i, j, k):
        return i + (na + 1) * (j + (nr + 1) * k)

    return X, orient_positive(X, kuhn_tets(vid, (na, nr, nz), i_fastest=True))


def main(argv=None):
    p = ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("out", help="the .mesh file to write")
    p.add_argument("--outer", type=positive_number, default=0.5, help="outer radius (m)")
    p.add_argument("--inner", type=positive_number, default=0.3, help="inner radius (m)")
    p.add_argument("--depth", type=positive_number, default=0.2, help="extent in z (m)")
    p.add_argument("--gap-fraction", type=positive_number, default=5e-5,
                   help="the slit's width as a fraction of the bounding-box diagonal")
    p.add_argument("--cells", type=positive_int, nargs=3, default=[48, 4, 4], metavar=("AROUND", "RADIAL", "DEPTH"))
    a = p.parse_args(argv)
    if not (0 < a.inner < a.outer) or a.depth <= 0 or min(a.cells) < 1 or not (0 < a.gap_fraction < 0.1):
        p.error("need 0 < inner < outer, depth > 0, cells >= 1 and 0 < gap-fraction < 0.1")
    diagonal = math.sqrt(4 * a.outer ** 2 + 4 * a.outer ** 2 + a.depth ** 2)  # the ring's box, gap aside
    gap = a.gap_fraction * diagonal
    if gap >= 2 * a.inner:  # the slit would cut the ring in two
        p.error(f"--gap-fraction {a.gap_fraction:g}: the slit, {gap:g} m wide, must be narrower than 2 x --inner")
    X, T = split_ring(a.outer, a.inner, a.depth, gap, a.cells)
    write_medit(a.out, X, T)
    extent = X.max(axis=0) - X.min(axis=0)
    print("split ring: %d vertices, %d tets, diagonal %.6g m, slit %.6g m (%.3g of the diagonal)"
          % (len(X), len(T), np.linalg.norm(extent), gap, gap / np.linalg.norm(extent)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
