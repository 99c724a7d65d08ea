"""Rollers: fixed regions that hold only some components (fixed[k].components, docs/loads.md#rollers-components-of-fixed), end to end.

- Uniaxial stress on rollers: a Neo-Hookean box on a frictionless floor (z held at z = 0) with the
  symmetry planes x = 0 (x held) and y = 0 (y held), a dead traction on its top, static: the
  discrete answer is the homogeneous F = diag(m, m, l) of the closed form (test_static.py's), with
  lbfgs and newton; the floor's reaction is the applied force, the symmetry planes' are 0.
- Held components never move: a dynamic run under gravity ends with every held coordinate bitwise
  at its rest value, the free components moved; a roller with a translation moves its held
  coordinates with it (and not the others); the reactions keep the body's momentum balance.
- 1, 2 and 4 ranks agree; a restart is bitwise.
- Bad decks: an unknown, a repeated or no component, components on an attachment, solver.h0: amg.
"""
import copy

import numpy as np
import pytest

from conftest import run_deck, run_hyperqn, write_deck
from hyperqn_tools.compare import relative_difference
from hyperqn_tools.output import final_frame, read_frames
from test_bad_input import assert_clean_failure
from test_reactions import reactions
from test_static import NEO_LAMBDA, NEO_MU, deformation_gradient, uniaxial_closed_form

EPS = 0.01


def plane(axis, value, size=(1.0, 1.0, 1.0)):
    """The box selecting the plane {axis = value} of a box of this size."""
    lo = [-EPS, -EPS, -EPS]
    hi = [s + EPS for s in size]
    lo[axis], hi[axis] = value - EPS, value + EPS
    return {"min": lo, "max": hi}


def uniaxial_deck(traction, solver):
    return {
        "name": "rollers_uniaxial",
        "mesh": {"box": {"size": [1.0, 1.0, 1.0], "cells": [3, 3, 3]}},
        "material": {"model": "neohookean", "mu": NEO_MU, "lambda": NEO_LAMBDA, "density": 1000},
        "fixed": [
            {"box": plane(2, 0.0), "components": ["z"]},  # the frictionless floor
            {"box": plane(0, 0.0), "components": ["x"]},  # symmetry planes
            {"box": plane(1, 0.0), "components": ["y"]},
        ],
        "loads": [{"type": "traction", "box": plane(2, 1.0), "traction": [0, 0, traction]}],
        "gravity": [0, 0, 0],
        "time": {"dt": 1, "frames": 1, "integrator": "static"},
        "solver": {"type": solver, "iterations": 2000, "grad_rtol": 1e-12},
        "output": {"every": 1, "reactions": True},
    }


@pytest.mark.parametrize("solver", ["lbfgs", "newton"])
@pytest.mark.parametrize("stretch", [1.25, 1.5])
def test_uniaxial_stress_on_rollers(tmp_path, stretch, solver):
    traction, lateral = uniaxial_closed_form(stretch)
    out, _ = run_deck(tmp_path, "uniaxial", uniaxial_deck(traction, solver))
    frame = final_frame(out)
    F, off = deformation_gradient(frame)
    expected = np.diag([lateral, lateral, stretch])
    error = np.abs(F - expected).max() / stretch
    print(f"{solver}, stretch {stretch}: F diagonal {np.diag(F)} against ({lateral:.10f}, {lateral:.10f}, "
          f"{stretch}); max |F - F*| / stretch {error:.1e}, off the homogeneous state {off:.1e}")
    assert error <= 1e-6 and off <= 1e-6
    # The held components are exactly where the supports are.
    X = frame.points - frame.displacement
    for axis in range(3):
        on = np.abs(X[:, axis]) < 1e-9
        assert np.array_equal(frame.points[on, axis], X[on, axis])
    # The floor carries the applied force (traction x the top's rest area 1), the planes nothing.
    rows = reactions(out)[1]
    floor = rows["fixed[0]"][1]
    planes = max(np.abs(rows[f"fixed[{k}]"][1]).max() for k in (1, 2)) / traction
    print(f"floor reaction {floor}: off the applied force by {abs(floor[2] + traction) / traction:.1e}; symmetry "
          f"planes' largest {planes:.1e} of it")
    assert abs(floor[2] + traction) <= 1e-8 * traction
    assert np.abs(floor[:2]).max() <= 1e-8 * traction
    for k in (1, 2):
        assert np.abs(rows[f"fixed[{k}]"][1]).max() <= 1e-8 * traction


SIZE = (1.0, 0.2, 0.2)
RHO = 1000.0
G = np.array([0.0, -9.81, -3.0])


def hanging(motion=None, **extra):
    """A bar whose end x = 0 is held in x and y (z free), under gravity with a z part: it swings
    down in y and falls freely along z."""
    end = {"box": plane(0, 0.0, SIZE), "components": ["x", "y"]}
    if motion:
        end["motion"] = motion
    deck = {
        "mesh": {"box": {"size": list(SIZE), "cells": [6, 2, 2]}},
        "material": {"model": "neohookean", "youngs_modulus": 1.0e6, "poisson_ratio": 0.3, "density": RHO},
        "fixed": [end],
        "gravity": [float(g) for g in G],
        "time": {"dt": 0.02, "frames": 6},
        "solver": {"type": "newton", "iterations": 50, "grad_rtol": 1e-13, "grad_atol": 0},
        "output": {"every": 1, "reactions": True},
    }
    deck.update(copy.deepcopy(extra))
    return deck


def held_end(frame):
    X = frame.points - frame.displacement
    return X, np.abs(X[:, 0]) < 1e-9


def test_held_components_never_move(tmp_path):
    out, summary = run_deck(tmp_path, "hanging", hanging(solver={"type": "lbfgs", "iterations": 200}))
    assert summary["failed_frames"] == 0
    for n, frame in read_frames(out):
        X, end = held_end(frame)
        assert np.array_equal(frame.points[end, :2], X[end, :2]), n  # bitwise
    frame = final_frame(out)
    X, end = held_end(frame)
    fall = 0.5 * G[2] * 0.12**2
    print(f"held end: z moved by {frame.displacement[end, 2].mean():.4e} (free fall {fall:.4e}); tip y "
          f"{frame.displacement[~end, 1].min():.3e}")
    assert frame.displacement[end, 2].max() < 0.5 * fall  # the free component moved
    assert frame.displacement[~end, 1].min() < -1e-3  # the bar swings down


def test_a_moving_roller_moves_its_held_components(tmp_path):
    velocity = np.array([0.5, 0.25, 7.0])  # z is not held: its part of the motion does nothing
    out, _ = run_deck(tmp_path, "moving", hanging({"translate": {"velocity": [float(v) for v in velocity]}}))
    for n, frame in read_frames(out):
        X, end = held_end(frame)
        t = 0.02 * n
        np.testing.assert_allclose(frame.points[end, :2], X[end, :2] + t * velocity[:2], rtol=0, atol=1e-14)
        assert np.abs(frame.displacement[end, 2] - t * velocity[2]).min() > 0.1 * t * velocity[2] or n == 0


def test_momentum_balance_with_rollers(tmp_path):
    """sum of the supports' forces + M g = sum_i m_i (v_{n+1} - v_n) / h, as for clamps (test_reactions.py)."""
    from test_reactions import lumped_masses
    out, _ = run_deck(tmp_path, "moving", hanging({"translate": {"velocity": [0.5, 0.25, 0.0]}}))
    rows, series = reactions(out), [f for _, f in read_frames(out)]
    m = lumped_masses(series[0])
    errors = []
    for n in range(1, len(series)):
        inertia = (m[:, None] * (series[n].velocity - series[n - 1].velocity)).sum(axis=0) / 0.02
        force = rows[n]["fixed[0]"][1]
        assert force[2] == 0  # z is free: no reaction along it
        scale = np.linalg.norm(inertia) + np.linalg.norm(m.sum() * G)
        errors.append(np.linalg.norm(force + m.sum() * G - inertia) / scale)
    print("momentum balance with a roller, relative error per frame: " + ", ".join(f"{e:.1e}" for e in errors))
    assert max(errors) < 1e-10


def test_rank_counts_agree_and_a_restart_is_bitwise(tmp_path):
    deck = hanging({"translate": {"velocity": [0.5, 0.25, 0.0]}})
    outs = {ranks: run_deck(tmp_path, f"np{ranks}", deck, ranks=ranks)[0] for ranks in (1, 2, 4)}
    for ranks in (2, 4):
        rel, diff, scale = relative_difference(outs[1], outs[ranks])
        print(f"1 vs {ranks} ranks: {diff:.3e} of a displacement of {scale:.3e} ({rel:.1e})")
        assert rel <= 1e-10
    # lbfgs: H0 the factor of M + h^2 L with identity rows (split at 2 ranks, supernodal at 1).
    lbfgs = dict(deck, solver={"type": "lbfgs", "iterations": 500, "grad_rtol": 1e-10})
    one, two = (run_deck(tmp_path, f"lbfgs{ranks}", lbfgs, ranks=ranks)[0] for ranks in (1, 2))
    rel, diff, scale = relative_difference(one, two)
    print(f"lbfgs, 1 vs 2 ranks: {diff:.3e} of a displacement of {scale:.3e} ({rel:.1e})")
    assert rel <= 1e-8
    restarted = tmp_path / "restarted"
    first = dict(deck, time=dict(deck["time"], frames=3), checkpoint={"every": 3})
    run_hyperqn([write_deck(tmp_path / "first.yaml", first), "-o", restarted], ranks=2)
    done = run_hyperqn([write_deck(tmp_path / "then.yaml", deck), "-o", restarted, "--restart", "latest"], ranks=2)
    assert "restart from" in done.stdout
    a, b = final_frame(outs[2]), final_frame(restarted)
    assert np.array_equal(a.points, b.points) and np.array_equal(a.velocity, b.velocity)


def with_fixed(change):
    deck = hanging()
    change(deck)
    return deck


BAD = {
    "unknown_component": (lambda d: d["fixed"][0].update(components=["x", "w"]), ["'fixed[0].components[1]'", "unknown value 'w'"]),
    "repeated_component": (lambda d: d["fixed"][0].update(components=["y", "x", "y"]),
                           ["'fixed[0].components'", "names y twice"]),
    "no_component": (lambda d: d["fixed"][0].update(components=[]), ["'fixed[0].components'", "non-empty"]),
    "attachment_components": (lambda d: d.update(attachments=[{"box": plane(0, 1.0, SIZE), "stiffness": 10.0,
                                                                "components": ["x"]}]),
                              ["attachments[0]", "components"]),
    "amg_h0": (lambda d: d.update(solver={"type": "lbfgs", "h0": "amg"}),
               ["'solver.h0'", "fixed region with components at line"]),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_roller_deck(tmp_path, case):
    change, fragments = BAD[case]
    path = write_deck(tmp_path / f"{case}.yaml", with_fixed(change))
    outdir = tmp_path / "out"
    proc = run_hyperqn([path, "-o", outdir], ranks=None, check=False, timeout=60)
    print(proc.stdout[-600:])
    assert proc.returncode == 1
    assert_clean_failure(proc, outdir, [f"{case}.yaml"] + fragments)
