"""Lamé's thick sphere: a hollow sphere (radii a = 1, b = 2; scripts/shell_mesh.py) under an
internal pressure p (a closed cavity: E = p V, docs/loads.md), small strain (p/E = 1e-3). Its
radial displacement at the inner and outer surfaces against Lamé's solution,

    u(r) = p a^3 / (E (b^3 - a^3)) ((1 - 2 nu) r + (1 + nu) b^3 / (2 r^2)),

on three meshes (4, 8, 12 cells per cube face; 2, 4, 6 through the wall): within 1% on the
finest, and the error falls at least like h^1.5 (it falls like h^2: the faceted cavity and the
linear tets). The hoop stress (output.fields cauchy_stress: the mean of its two tangential normal
stresses) of the tets whose centres lie in the mid-wall band 1.4 < r < 1.6, averaged, against
Lamé's p a^3 (1 + b^3/(2 r^3)) / (b^3 - a^3): within 1% on the finest mesh, and falling. The equilibrium is reached by steps of dt = 100 s (some 10^4 periods of the shell's
breathing) with the velocity damped away, each a minimization dominated by E; the last step takes
no iteration. At 2 ranks.
"""
import glob
import os
import subprocess
import sys

import meshio
import numpy as np

from conftest import run_hyperqn, write_deck
from hyperqn_tools.output import final_frame, tensors
from hyperqn_tools.paths import REPO

E, NU, P, A, B = 1.0e6, 0.3, 1.0e3, 1.0, 2.0
MESHES = (4, 8, 12)


def lame(r):
    return P * A ** 3 / (E * (B ** 3 - A ** 3)) * ((1 - 2 * NU) * r + (1 + NU) * B ** 3 / (2 * r ** 2))


def hoop(r):
    return P * A ** 3 / (B ** 3 - A ** 3) * (1 + B ** 3 / (2 * r ** 3))


def hoop_error(out):
    """The mid-wall band's mean hoop stress against Lamé's, relative, from the last frame's pieces."""
    r, t = [], []
    for piece in sorted(glob.glob(str(out / "*_00003_*.vtu"))):
        m = meshio.read(piece)
        rest = m.points - m.point_data["displacement"]
        for block, sigma in zip(m.cells, m.cell_data["cauchy_stress"]):
            centre = rest[block.data].mean(axis=1)
            radius = np.linalg.norm(centre, axis=1)
            n = centre / radius[:, None]
            S = tensors(sigma)
            radial = np.einsum("ei,eij,ej->e", n, S, n)
            r.append(radius)
            t.append((np.trace(S, axis1=1, axis2=2) - radial) / 2)
    r, t = np.concatenate(r), np.concatenate(t)
    band = (r > 1.4) & (r < 1.6)
    return abs(t[band].mean() / hoop(r[band]).mean() - 1)


def radial_errors(tmp_path, cells):
    mesh = tmp_path / f"shell{cells}.mesh"
    subprocess.run([sys.executable, os.path.join(REPO, "scripts", "shell_mesh.py"), str(mesh), "--inner", str(A),
                    "--outer", str(B), "--cells", str(cells), "--layers", str(cells // 2)], check=True)
    deck = {
        "name": f"lame{cells}",
        "mesh": {"file": str(mesh)},
        "material": {"model": "neohookean", "youngs_modulus": E, "poisson_ratio": NU, "density": 1000},
        "loads": [{"type": "pressure", "box": {"min": [-1.01 * A] * 3, "max": [1.01 * A] * 3}, "pressure": P}],
        "gravity": [0, 0, 0],
        "time": {"dt": 100, "frames": 3, "damping": 0.999},
        "solver": {"type": "lbfgs", "iterations": 500, "grad_rtol": 1.0e-10},
        "output": {"every": 3, "fields": ["cauchy_stress"]},
    }
    out = tmp_path / f"out{cells}"
    proc = run_hyperqn([write_deck(tmp_path / f"lame{cells}.yaml", deck), "-o", out], ranks=2)
    assert "closed: E = p V" in proc.stdout
    f = final_frame(out)
    X = f.points - f.displacement
    r = np.linalg.norm(X, axis=1)
    ur = np.einsum("ij,ij->i", f.displacement, X / r[:, None])
    return [abs(ur[s].mean() / lame(r[s]).mean() - 1) for s in (r < A * 1.001, r > B * 0.999)] + [hoop_error(out)]


def test_lame_sphere(tmp_path):
    errors = {cells: radial_errors(tmp_path, cells) for cells in MESHES}
    for cells, (inner, outer, stress) in errors.items():
        print(f"{cells} cells: radial displacement off Lamé's by {inner:.3%} (inner), {outer:.3%} (outer); "
              f"mid-wall hoop stress by {stress:.3%}")
    inner, outer, stress = errors[MESHES[-1]]
    assert inner < 0.01 and outer < 0.01 and stress < 0.01
    assert errors[MESHES[0]][2] > errors[MESHES[1]][2] > stress
    for coarse, fine in zip(MESHES, MESHES[1:]):
        for k in (0, 1):
            rate = np.log(errors[coarse][k] / errors[fine][k]) / np.log(fine / coarse)
            print(f"rate {coarse} -> {fine} cells ({'inner' if k == 0 else 'outer'}): {rate:.2f}")
            assert rate > 1.5
