#!/usr/bin/python3
"""Writes a quarter of a thick-walled cylinder slab as a Medit .mesh file: Lamé's cylinder in plane
strain under internal pressure (docs/loads.md#rollers-components-of-fixed).

The slab lies between radii `--inner` and `--outer` about the z axis, at angles 0 to 90 degrees
(x >= 0, y >= 0), and 0 <= z <= `--thickness`: `--cells` hexahedra through the wall, twice as many
around the quarter, `--layers` through the thickness, every vertex on its circle (the curved
surfaces are faceted by chords). Each hexahedron is cut into 6 tetrahedra about its diagonal from
its corner of least indices (Kuhn's cut, conforming across the structured grid). Every tet is
positively oriented. Standard library and numpy.

    /usr/bin/python3 scripts/cylinder_mesh.py cylinder.mesh --inner 1 --outer 2 --cells 8
"""
import sys

import numpy as np

from tet_grid import kuhn_tets, orient_positive, write_medit, positive_number, ArgumentParser, positive_int


def quarter_cylinder(inner, outer, thickness, cells, layers):
    """Vertices and positively oriented tets of the slab."""
    nr, nt, nz = cells, 2 * cells, layers
    r = np.linspace(inner, outer, nr + 1)
    theta = np.linspace(0, np.pi / 2, nt + 1)
    z = np.linspace(0, thickness, nz + 1)
    R, TH, Z = np.meshgrid(r, theta, z, indexing="ij")
    X = np.c_[(R * np.cos(TH)).ravel(), (R * np.sin(TH)).ravel(), Z.ravel()]
    X[np.isclose(TH.ravel(), np.pi / 2), 0] = 0.0  # exactly on the plane x = 0

    def vid(i, j, k):
        return (i * (nt + 1) + j) * (nz + 1) + k

    return X, orient_positive(X, kuhn_tets(vid, (nr, nt, nz)))


def main(argv=None):
    p = ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("out", help="the .mesh file to write")
    p.add_argument("--inner", type=positive_number, default=1.0, help="inner radius (m)")
    p.add_argument("--outer", type=positive_number, default=2.0, help="outer radius (m)")
    p.add_argument("--thickness", type=positive_number, default=0.25, help="the slab's thickness along z (m)")
    p.add_argument("--cells", type=positive_int, default=4, help="cells through the wall (twice as many around)")
    p.add_argument("--layers", type=positive_int, default=1, help="cells through the thickness")
    a = p.parse_args(argv)
    if not (0 < a.inner < a.outer) or a.thickness <= 0 or a.cells < 1 or a.layers < 1:
        p.error("need 0 < inner < outer, thickness > 0, cells >= 1 and layers >= 1")
    X, T = quarter_cylinder(a.inner, a.outer, a.thickness, a.cells, a.layers)
    write_medit(a.out, X, T)
    print("quarter cylinder: %d vertices, %d tets" % (len(X), len(T)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
