"""Lamé's thick cylinder in plane strain, on rollers: a quarter of a slab (radii a = 1, b = 2,
thickness 0.25; scripts/cylinder_mesh.py) held by symmetry rollers on x = 0 (x held) and y = 0
(y held), both z faces held in z (plane strain: with one layer of cells every vertex is held in z),
under an internal pressure p on its inner surface (an open surface: normals at the step's start;
p/E = 1e-4), one static load step. Its mean radial displacement at the inner and outer surfaces
against Lamé's plane-strain solution

    u(r) = (1 + nu) p a^2 / (E (b^2 - a^2)) ((1 - 2 nu) r + b^2 / r),

and the mean hoop stress (output.fields cauchy_stress, e_theta . sigma e_theta) of the tets whose
centres lie in the mid-wall band 1.4 < r < 1.6 against p a^2 (1 + b^2 / r^2) / (b^2 - a^2), on
meshes of 4, 8 and 16 cells through the wall: within 1% on the finest, the displacement's error
falling at least like h^1.5, the stress's falling.
"""
import glob
import os
import subprocess
import sys

import meshio
import numpy as np

from conftest import run_deck
from hyperqn_tools.output import final_frame, tensors
from hyperqn_tools.paths import REPO

E, NU, P, A, B, T = 1.0e6, 0.3, 100.0, 1.0, 2.0, 0.25
MESHES = (4, 8, 16)
EPS = 0.01


def lame(r):
    return (1 + NU) * P * A**2 / (E * (B**2 - A**2)) * ((1 - 2 * NU) * r + B**2 / r)


def hoop(r):
    return P * A**2 / (B**2 - A**2) * (1 + B**2 / r**2)


def hoop_error(out):
    """The mid-wall band's mean hoop stress against Lamé's, relative, from the frame's pieces."""
    r, s = [], []
    for piece in sorted(glob.glob(str(out / "*_00001_*.vtu"))):
        m = meshio.read(piece)
        rest = m.points - m.point_data["displacement"]
        for block, sigma in zip(m.cells, m.cell_data["cauchy_stress"]):
            centre = rest[block.data].mean(axis=1)
            radius = np.hypot(centre[:, 0], centre[:, 1])
            e = np.c_[-centre[:, 1] / radius, centre[:, 0] / radius, np.zeros(len(radius))]
            S = tensors(sigma)
            r.append(radius)
            s.append(np.einsum("ei,eij,ej->e", e, S, e))
    r, s = np.concatenate(r), np.concatenate(s)
    band = (r > 1.4) & (r < 1.6)
    return abs(s[band].mean() / hoop(r[band]).mean() - 1)


def box(lo, hi):
    return {"min": lo, "max": hi}


def errors(tmp_path, cells):
    mesh = tmp_path / f"cylinder{cells}.mesh"
    subprocess.run([sys.executable, os.path.join(REPO, "scripts", "cylinder_mesh.py"), str(mesh), "--inner", str(A),
                    "--outer", str(B), "--thickness", str(T), "--cells", str(cells)], check=True)
    lo, hi = -EPS, B + EPS
    deck = {
        "name": f"lame_cylinder{cells}",
        "mesh": {"file": str(mesh)},
        "material": {"model": "neohookean", "youngs_modulus": E, "poisson_ratio": NU, "density": 1000},
        "fixed": [
            {"box": box([-EPS, lo, lo], [EPS, hi, hi]), "components": ["x"]},  # symmetry planes
            {"box": box([lo, -EPS, lo], [hi, EPS, hi]), "components": ["y"]},
            {"box": box([lo, lo, -EPS], [hi, hi, EPS]), "components": ["z"]},  # plane strain
            {"box": box([lo, lo, T - EPS], [hi, hi, T + EPS]), "components": ["z"]},
        ],
        # The inner surface: its faces' vertices have x, y <= a; the cone about (-1, -1, 0) leaves
        # out the z faces there.
        "loads": [{"type": "pressure", "box": box([-EPS, -EPS, -EPS], [A * 1.001, A * 1.001, T + EPS]),
                   "normal": [-1, -1, 0], "angle": 50, "pressure": P}],
        "gravity": [0, 0, 0],
        "time": {"dt": 1, "frames": 1, "integrator": "static"},
        "solver": {"type": "lbfgs", "h0": "rest-stiffness", "iterations": 200, "grad_rtol": 1.0e-10},
        "output": {"every": 1, "fields": ["cauchy_stress"]},
    }
    out, _ = run_deck(tmp_path, f"out{cells}", deck, ranks=2)
    f = final_frame(out)
    X = f.points - f.displacement
    r = np.hypot(X[:, 0], X[:, 1])
    ur = (f.displacement[:, 0] * X[:, 0] + f.displacement[:, 1] * X[:, 1]) / r
    assert np.array_equal(f.points[:, 2], X[:, 2])  # plane strain: every vertex held in z
    return [abs(ur[s].mean() / lame(r[s]).mean() - 1) for s in (r < A * 1.001, r > B * 0.999)] + [hoop_error(out)]


def test_lame_cylinder_in_plane_strain(tmp_path):
    found = {cells: errors(tmp_path, cells) for cells in MESHES}
    for cells, (inner, outer, stress) in found.items():
        print(f"{cells} cells: radial displacement off Lamé's by {inner:.3%} (inner), {outer:.3%} (outer); "
              f"mid-wall hoop stress by {stress:.3%}")
    inner, outer, stress = found[MESHES[-1]]
    assert inner < 0.01 and outer < 0.01 and stress < 0.01
    assert found[MESHES[0]][2] > stress
    for coarse, fine in zip(MESHES, MESHES[1:]):
        for k in (0, 1):
            rate = np.log(found[coarse][k] / found[fine][k]) / np.log(fine / coarse)
            print(f"rate {coarse} -> {fine} cells ({'inner' if k == 0 else 'outer'}): {rate:.2f}")
            assert rate > 1.5
