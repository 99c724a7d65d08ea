"""Inflation of a hollow Neo-Hookean sphere by a follower pressure on its cavity, in static load
steps, against the exact pressure-stretch curve of the same energy (docs/loads.md#checks).

The sphere (scripts/shell_mesh.py) has radii A = 1 and B = 1.8: a load's region is a box, and the
box [-1.01, 1.01]^3 that holds the cavity's wall holds none of the outer surface's faces only when
B > 1.01 sqrt(3) A. A thin sphere (radii 1 and 1.1) needs a region that selects the cavity's wall
alone: shell_mesh.py --tags gives it tag 1, and its case selects it by face_tag.
The pressure (a closed surface: E = p V, a conservative follower load) ramps over 10 static load
steps to 93% of the curve's limit point; pressure control cannot pass that point (past it no
equilibrium at a higher pressure is near), so the steps stop short of it. One outer vertex is fixed
(a tiny box): the pressure on a closed cavity has no resultant, so the pin carries none (its
reaction is checked to be ~0), and the rotations about it stay free, which static's H0 = (M + s^2 L)^-1
keeps definite.

The reference is the spherically symmetric solution of hyperqn's energy (src/materials/neohookean.cpp)
psi = mu/2 (I1 - 3) - mu log J + lambda/2 log^2 J (J > J0 throughout), mu and lambda from E and nu
as hyperqn maps them: r(R) with principal stretches l_r = r', l_t = r/R, nominal stresses
P_i = dpsi/dl_i = mu l_i + (lambda log J - mu) / l_i, radial equilibrium d(R^2 P_r)/dR = 2 R P_t,
sigma_r(B) = 0 and sigma_r(A) = -p (P_r(A) = -p l_t(A)^2). Integrated by RK4 from the outer
surface inwards (r(B) = l_b B, P_r(B) = 0; l_r from P_r by Newton at each stage), each outer
stretch l_b gives the inner stretch and the pressure directly; the inner stretch's pressure takes a
secant solve for l_b. numpy only.

Each frame's measured stretch (the mean distance of the cavity's vertices from their centroid over
A; the outer surface's over B) against the reference: the applied pressure against the reference's
pressure at that stretch, within 1% at every step; at 1 and 2 ranks.
"""
import collections
import functools
import os
import subprocess
import sys

import numpy as np
import pytest

from conftest import run_hyperqn, write_deck
from hyperqn_tools.output import read_frames, read_reactions, read_summary
from hyperqn_tools.paths import REPO

A, B = 1.0, 1.8
E, NU = 1.0e6, 0.45
STEPS = 10          # static load steps (frames)
FRACTION = 0.93     # of the reference's limit pressure, reached at the last step
# (cells per cube face, layers through the wall), the layers graded: the outermost twice as thick as
# the innermost (scripts/shell_mesh.py --grading)
MESHES = ((4, 2), (8, 4), (12, 6))
FINER = (16, 8)
GRADING = 2.0


def lame_parameters(e, nu):
    """mu, lambda from E, nu (hyperqn's mapping: src/materials/material.hpp)."""
    return e / (2 * (1 + nu)), e * nu / ((1 + nu) * (1 - 2 * nu))


def inward(lb, mu, lam, a=A, b=B, steps=200):
    """(inner stretch, pressure) of the equilibrium with outer stretch lb (an array), by RK4 from
    R = b (r = lb b, P_r = 0) to R = a."""
    lb = np.asarray(lb, dtype=float)

    def radial_stretch(P, lt, guess):
        # P_r(l) = mu l + (lam log(l lt^2) - mu) / l = P, by Newton from the last stage's root
        # (the first from J = 1), halving a step that would leave l > 0.
        l = guess.copy()
        for _ in range(50):
            logJ = np.log(l * lt * lt)
            step = (mu * l + (lam * logJ - mu) / l - P) / (mu + (lam + mu - lam * logJ) / (l * l))
            l = np.where(step < l, l - step, l / 2)
            if np.all(np.abs(step) <= 1e-13 * l):  # quadratic convergence: the next step is ~1e-26
                break
        return l

    def rhs(R, r, P, guess):
        lt = r / R
        lr = radial_stretch(P, lt, guess)
        Pt = mu * lt + (lam * np.log(lr * lt * lt) - mu) / lt
        return lr, 2 * (Pt - P) / R

    h = (a - b) / steps
    R, r, P, lr = b, lb * b, np.zeros_like(lb), 1 / lb**2
    for _ in range(steps):
        k1r, k1P = rhs(R, r, P, lr)
        k2r, k2P = rhs(R + h / 2, r + h / 2 * k1r, P + h / 2 * k1P, k1r)
        k3r, k3P = rhs(R + h / 2, r + h / 2 * k2r, P + h / 2 * k2P, k2r)
        k4r, k4P = rhs(R + h, r + h * k3r, P + h * k3P, k3r)
        r = r + h / 6 * (k1r + 2 * k2r + 2 * k3r + k4r)
        P = P + h / 6 * (k1P + 2 * k2P + 2 * k3P + k4P)
        R, lr = R + h, k4r
    la = r / a
    return la, -P / la**2


def pressure_at_inner(la, mu, lam, a=A, b=B, steps=200):
    """(pressure, outer stretch) of the equilibrium with inner stretch la (an array): a secant
    solve on lb from the incompressible relation lb^3 - 1 = (la^3 - 1) a^3 / b^3."""
    la = np.asarray(la, dtype=float)
    x0 = np.cbrt(1 + (la**3 - 1) * a**3 / b**3)
    x1 = x0 + 1e-4 * (la - 1) + 1e-9
    f0, f1 = inward(x0, mu, lam, a, b, steps)[0] - la, inward(x1, mu, lam, a, b, steps)[0] - la
    for _ in range(50):
        x2 = np.where(f1 != f0, x1 - f1 * (x1 - x0) / np.where(f1 != f0, f1 - f0, 1), x1)
        x0, f0, x1 = x1, f1, x2
        f1 = inward(x1, mu, lam, a, b, steps)[0] - la
        if np.all(np.abs(f1) <= 1e-14 * la):
            break
    return inward(x1, mu, lam, a, b, steps)[1], x1


def incompressible_thick(la, mu, a=A, b=B):
    """The incompressible Neo-Hookean thick sphere: p = 2 mu [f(lb) - f(la)], f(l) = 1/l + 1/(4 l^4)."""
    lb = np.cbrt(1 + (la**3 - 1) * a**3 / b**3)
    return 2 * mu * ((1 / lb + 1 / (4 * lb**4)) - (1 / la + 1 / (4 * la**4)))


def incompressible_thin(l, mu, a=A, b=B):
    """The thin incompressible sphere (membrane): p = 2 mu (H/R) (1/l - 1/l^7), R the mid radius."""
    return 2 * mu * (b - a) / ((a + b) / 2) * (1 / l - 1 / l**7)


@functools.lru_cache()
def limit_point(mu, lam, a=A, b=B):
    """(pressure, inner stretch) at the reference's maximum pressure: a scan over lb, refined
    around its maximum four times (each 20 times finer)."""
    lo, hi = 1.001, 1.6
    for _ in range(5):
        lb = np.linspace(lo, hi, 41)
        la, p = inward(lb, mu, lam, a, b)
        k = int(np.argmax(p))
        lo, hi = lb[max(k - 1, 0)], lb[min(k + 1, len(lb) - 1)]
    return p[k], la[k]


MU, LAMBDA = lame_parameters(E, NU)

# A hollow sphere's mesh: radii, layers' grading, and whether its cavity's wall is selected by
# the face tag shell_mesh.py --tags gives it (else by the box [-1.01 a, 1.01 a]^3).
Shell = collections.namedtuple("Shell", "a b grading tagged")
THICK = Shell(A, B, GRADING, False)


def test_reference_converges_and_reduces_to_the_closed_forms():
    """The reference itself: RK4 with 200 steps against 400 (1e-10 of p), small strain against Lame,
    the incompressible limit against the thick closed form (its gap falls like 1 - 2 nu)."""
    lb = np.linspace(1.01, 1.5, 50)
    la, p = inward(lb, MU, LAMBDA)
    la2, p2 = inward(lb, MU, LAMBDA, steps=400)
    print(f"RK4, 200 against 400 steps: {np.abs(p / p2 - 1).max():.1e} of p, {np.abs(la / la2 - 1).max():.1e} of la")
    assert np.abs(p / p2 - 1).max() <= 1e-10 and np.abs(la / la2 - 1).max() <= 1e-10
    # the secant solve for a given inner stretch returns it
    pa, lbs = pressure_at_inner(la, MU, LAMBDA)
    assert np.abs(pa / p - 1).max() <= 1e-10 and np.abs(lbs - lb).max() <= 1e-10
    # small strain: Lame's u(a) = p a^3 ((1 - 2 nu) a + (1 + nu) b^3 / (2 a^2)) / (E (b^3 - a^3))
    la0, p0 = inward([1 + 1e-7], MU, LAMBDA)
    u = p0[0] * A**3 * ((1 - 2 * NU) * A + (1 + NU) * B**3 / (2 * A**2)) / (E * (B**3 - A**3))
    print(f"small strain against Lame: {((la0[0] - 1) * A) / u - 1:.1e}")
    assert abs((la0[0] - 1) * A / u - 1) <= 1e-5
    gaps = []
    for nu in (0.499, 0.4999):
        mu, lam = lame_parameters(E, nu)
        la, p = inward(np.linspace(1.01, 1.6, 60), mu, lam)
        gaps.append(np.abs(p / incompressible_thick(la, mu) - 1).max())
        print(f"nu = {nu}: off the incompressible thick sphere by {gaps[-1]:.2e} (at most, for la in "
              f"[{la[0]:.3f}, {la[-1]:.3f}])")
    assert gaps[1] <= 5e-4 and 8 < gaps[0] / gaps[1] < 12


def mesh_file(tmp_path, cells, layers, shell=THICK):
    mesh = tmp_path / f"sphere{shell.b}_{cells}_{layers}.mesh"
    if not mesh.exists():
        subprocess.run([sys.executable, os.path.join(REPO, "scripts", "shell_mesh.py"), str(mesh), "--inner",
                        str(shell.a), "--outer", str(shell.b), "--cells", str(cells), "--layers", str(layers),
                        "--grading", str(shell.grading)] + ["--tags"] * shell.tagged,
                       check=True, stdout=subprocess.DEVNULL)
    return mesh


def inflation_deck(mesh, pressure, shell=THICK):
    a, b = shell.a, shell.b
    pin = 0.01 * (b - a)
    cavity = {"face_tag": 1} if shell.tagged else {"box": {"min": [-1.01 * a] * 3, "max": [1.01 * a] * 3}}
    return {
        "name": "inflation",
        "mesh": {"file": str(mesh)},
        "material": {"model": "neohookean", "youngs_modulus": E, "poisson_ratio": NU, "density": 1000},
        # the outer pole's vertex alone (cells even puts a vertex there)
        "fixed": [{"box": {"min": [-pin, -pin, b - pin], "max": [pin, pin, b + pin]}}],
        "loads": [{"type": "pressure", **cavity, "pressure": pressure, "curve": {"type": "ramp", "start": 0, "end": STEPS}}],
        "gravity": [0, 0, 0],
        "time": {"dt": 1, "frames": STEPS, "integrator": "static"},
        "solver": {"type": "lbfgs", "iterations": 2000, "grad_rtol": 1.0e-9},
        "output": {"every": 1, "reactions": True},
    }

def stretches(frame, a=A, b=B):
    """Inner and outer stretch: each surface's mean distance from its centroid over its rest radius."""
    rest = np.linalg.norm(frame.points - frame.displacement, axis=1)
    out = []
    for surface, radius in ((np.abs(rest - a) < 1e-9, a), (np.abs(rest - b) < 1e-9, b)):
        x = frame.points[surface]
        out.append(np.linalg.norm(x - x.mean(axis=0), axis=1).mean() / radius)
    return out


def inflate(tmp_path, cells, layers, ranks, shell=THICK):
    p_limit, _ = limit_point(MU, LAMBDA, shell.a, shell.b)
    pressure = float(FRACTION * p_limit)
    name = f"b{shell.b}c{cells}np{ranks}"
    out = tmp_path / name
    mesh = mesh_file(tmp_path, cells, layers, shell)
    deck = inflation_deck(mesh, pressure, shell)
    proc = run_hyperqn([write_deck(tmp_path / f"{name}.yaml", deck), "-o", out], ranks=ranks)
    assert "closed: E = p V" in proc.stdout
    frames = [(n, f) for n, f in read_frames(out) if n > 0]
    assert len(frames) == STEPS
    applied = pressure * np.array([n for n, _ in frames]) / STEPS
    la, lb = np.array([stretches(f, shell.a, shell.b) for _, f in frames]).T
    reaction = read_reactions(out)["fixed[0]"]
    force = np.sqrt(reaction["fx"] ** 2 + reaction["fy"] ** 2 + reaction["fz"] ** 2)
    return applied, la, lb, force, p_limit


def compare(applied, la, lb, p_limit, shell=THICK):
    """Relative errors of the applied pressure against the reference's at the inner and the outer
    stretch, per step, printed as a table."""
    a, b = shell.a, shell.b
    p_inner, _ = pressure_at_inner(la, MU, LAMBDA, a, b)
    _, p_outer = inward(lb, MU, LAMBDA, a, b)
    e_inner, e_outer = applied / p_inner - 1, applied / p_outer - 1
    print(f"radii {a}, {b}: limit point p = {p_limit:.6g} Pa (p/mu = {p_limit / MU:.5f}) at "
          f"la = {limit_point(MU, LAMBDA, a, b)[1]:.4f}")
    print(" step  p/p_limit    la         lb        p_ref(la)  err(la)   p_ref(lb)  err(lb)  "
          "thick incompr.  thin incompr.")
    for k in range(len(applied)):
        print(f"{k + 1:5d}  {applied[k] / p_limit:.4f}  {la[k]:.6f}  {lb[k]:.6f}  {p_inner[k]:10.6g} {e_inner[k]:+.3%}  "
              f"{p_outer[k]:10.6g} {e_outer[k]:+.3%}  {incompressible_thick(la[k], MU, a, b):10.6g}  "
              f"{incompressible_thin(la[k], MU, a, b):10.6g}")
    return np.abs(e_inner).max(), np.abs(e_outer).max()


def test_inflation_against_the_exact_curve(tmp_path):
    """The finest default mesh (2 ranks) within 1% at every step, the coarser two further off, the
    error falling like h^2; the middle one at 1 and 2 ranks alike (the finest at 1 rank too takes
    another 10 s: the same 2e-15 when measured)."""
    errors = {}
    for mesh in MESHES:
        applied, la, lb, force, p_limit = inflate(tmp_path, *mesh, 2)
        print(f"{mesh[0]} cells, {mesh[1]} layers, 2 ranks:")
        errors[mesh] = compare(applied, la, lb, p_limit)
        print(f"max |error| {errors[mesh][0]:.3%} (inner stretch), {errors[mesh][1]:.3%} (outer); the pin's "
              f"reaction at most {force.max():.2e} N against p pi A^2 = {applied[-1] * np.pi * A**2:.3e} N")
        assert la[-1] > 1.4  # well into the large stretches
        assert force.max() <= 1e-8 * applied[-1] * np.pi * A**2
        if mesh == MESHES[1]:
            _, la1, lb1, _, _ = inflate(tmp_path, *mesh, 1)
            diff = max(np.abs(la1 - la).max() / (la[-1] - 1), np.abs(lb1 - lb).max() / (lb[-1] - 1))
            print(f"1 against 2 ranks: the stretches differ by {diff:.1e} of the last step's stretch - 1")
            assert diff <= 1e-6
    assert max(errors[MESHES[-1]]) <= 0.01
    for coarse, finer in zip(MESHES, MESHES[1:]):
        for k, surface in enumerate(("inner", "outer")):
            rate = np.log(errors[coarse][k] / errors[finer][k]) / np.log(finer[0] / coarse[0])
            print(f"{surface}: max |error| {errors[coarse][k]:.3%} ({coarse[0]} cells) -> "
                  f"{errors[finer][k]:.3%} ({finer[0]} cells): rate {rate:.2f}")
            assert rate > 1.5


def test_pressure_control_stops_at_the_limit_point(tmp_path):
    """Past the limit pressure there is no equilibrium (the energy falls without bound as the
    sphere grows): on the coarse mesh, 5 steps to 1.5 times the limit pressure take 0.3, 0.6 and
    0.9 of it and the fourth (1.2) ends the run with an error, exit 1, the three frames written."""
    p_limit, _ = limit_point(MU, LAMBDA)
    deck = inflation_deck(mesh_file(tmp_path, *MESHES[0]), float(1.5 * p_limit))
    deck["time"]["frames"] = 5
    deck["loads"][0]["curve"]["end"] = 5
    out = tmp_path / "past"
    proc = run_hyperqn([write_deck(tmp_path / "past.yaml", deck), "-o", out], ranks=1, check=False)
    print(proc.stdout[-600:])
    assert proc.returncode == 1
    assert [n for n, _ in read_frames(out)] == [0, 1, 2, 3]
    assert read_summary(out)["status"].startswith("error")


def test_pd_stops_at_the_limit_point_as_lbfgs_does(tmp_path):
    """The same steps with pd (100 iterations): its fourth step (1.2 times the limit) ended far from
    converged after every stage of the fallback chain (Newton's run away), and the run went on:
    frames 4 and 5 written flagged, exit 0. A static step is an equilibrium: now the run stops there
    as lbfgs's does, exit 1, the three frames of equilibria written."""
    p_limit, _ = limit_point(MU, LAMBDA)
    deck = inflation_deck(mesh_file(tmp_path, *MESHES[0]), float(1.5 * p_limit))
    deck["time"]["frames"] = 5
    deck["loads"][0]["curve"]["end"] = 5
    deck["solver"] = {"type": "pd", "iterations": 100}
    out = tmp_path / "past"
    proc = run_hyperqn([write_deck(tmp_path / "past.yaml", deck), "-o", out], ranks=1, check=False)
    print(proc.stdout[-600:])
    assert proc.returncode == 1
    assert "error: frame 4: no equilibrium found" in proc.stdout
    assert [n for n, _ in read_frames(out)] == [0, 1, 2, 3]
    assert read_summary(out)["status"].startswith("error: frame 4")


THIN = Shell(A, 1.1, 1.0, True)  # H/a = 0.1
THIN_MESH = (16, 2)  # measured: 8, 12, 16 cells (2 layers) 1.94%, 0.99%, 0.61% (inner stretch)


def test_thin_sphere_against_the_exact_curve(tmp_path):
    """A thin sphere (radii 1 and 1.1), its cavity's wall selected by its face tag, to 93% of its
    limit pressure at 2 ranks: within 1% of the exact curve at every step."""
    applied, la, lb, force, p_limit = inflate(tmp_path, *THIN_MESH, 2, THIN)
    inner, outer = compare(applied, la, lb, p_limit, THIN)
    print(f"thin sphere, {THIN_MESH[0]} cells, {THIN_MESH[1]} layers: max |error| {inner:.3%} (inner stretch), "
          f"{outer:.3%} (outer); the pin's reaction at most {force.max():.2e} N")
    assert inner <= 0.01 and outer <= 0.01
    assert force.max() <= 1e-8 * applied[-1] * np.pi * THIN.a**2


@pytest.mark.skipif(not os.environ.get("HYPERQN_FINE"), reason="the finer mesh: HYPERQN_FINE=1")
def test_inflation_on_the_finer_mesh(tmp_path):
    applied, la, lb, _, p_limit = inflate(tmp_path, *FINER, 2)
    inner, outer = compare(applied, la, lb, p_limit)
    print(f"{FINER[0]} cells, {FINER[1]} layers: max |error| {inner:.3%} (inner stretch), {outer:.3%} (outer)")
    assert inner <= 0.01 and outer <= 0.01
