"""time.integrator (docs/method.md#time-integrators): implicit Euler, BDF2 and implicit midpoint on
a stiff cantilever (small strain, so nearly a quadratic energy), each step solved by Newton to
round-off so that only the integrator differs.

- Energy: released at rest under gravity, the bar vibrates about its sagged shape; kinetic +
  elastic + gravitational energy stays 0 for the exact motion. Implicit midpoint keeps it within
  1% of the largest kinetic energy; implicit Euler loses most of it; BDF2 far less than Euler.
- Order: a small oscillator (a cube of 6 tets on its clamped base) at T against a fine-step
  reference; halving h divides the error by 2 (Euler) and by 4 (midpoint, BDF2).
- Each integrator with lbfgs and Newton at 1 and 2 ranks, through a restart (BDF2's history is in
  the checkpoint), the fallback chain's sub-steps and the study.
"""
import math
import os

import numpy as np
import pytest

from conftest import run_hyperqn, write_deck
from hyperqn_tools.energy import neohookean_energies
from hyperqn_tools.output import (final_frame, frame_list, frame_meshes, read_checkpoint, read_summary,
                                  rest_diagonal)

E, NU, RHO, G = 1.0e8, 0.3, 1000.0, 9.81  # sags 1.5% of its length


def cantilever(integrator, dt, frames, every):
    return {
        "mesh": {"box": {"size": [1.0, 0.1, 0.1], "cells": [10, 1, 1]}},
        "material": {"model": "neohookean", "youngs_modulus": E, "poisson_ratio": NU, "density": RHO},
        "fixed": [{"box": {"min": [-0.001, -0.001, -0.001], "max": [0.001, 0.101, 0.101]}}],
        "gravity": [0, -G, 0],
        "time": {"dt": dt, "frames": frames, "integrator": integrator},
        "solver": {"type": "newton", "iterations": 30, "budget": "fixed", "grad_rtol": 1e-10, "grad_atol": 0},
        "output": {"every": every},
    }


def run(tmp_path, name, deck):
    out = tmp_path / name
    run_hyperqn([write_deck(tmp_path / f"{name}.yaml", deck), "-o", out], ranks=1)
    assert read_summary(out)["status"] == "ok"
    return out


def energies(path):
    """(kinetic, elastic, gravitational) energy of a 1-rank frame of the cantilever."""
    return neohookean_energies(path, E, NU, RHO, G)


def test_energy_midpoint_keeps_bdf2_loses_little_euler_loses(tmp_path):
    totals, kinetic_peak = {}, {}
    for integrator in ("implicit-euler", "bdf2", "implicit-midpoint"):
        out = run(tmp_path, integrator, cantilever(integrator, 4.0e-3, 200, 1))
        e = np.array([energies(path) for _, _, path in frame_list(out)])
        totals[integrator] = e.sum(axis=1)
        kinetic_peak[integrator] = e[:, 0].max()
    for integrator, total in totals.items():
        print(f"{integrator}: largest kinetic energy {kinetic_peak[integrator]:.4e} J; total energy at the end "
              f"{total[-1]:+.4e} J, largest |total| {np.abs(total).max():.4e} J")
    peak = kinetic_peak["implicit-midpoint"]
    midpoint = totals["implicit-midpoint"]
    assert np.abs(midpoint).max() <= 0.01 * peak
    euler = totals["implicit-euler"]
    assert euler[-1] < -0.5 * peak  # lost to numerical damping
    assert np.all(np.diff(euler) <= 1e-9 * peak)  # and never gained
    bdf2 = totals["bdf2"]
    assert euler[-1] < 2 * bdf2[-1] < 0  # loses, but less than half of what Euler loses


def oscillator(integrator, T, steps):
    """A unit cube of 6 tets standing on its clamped base, released under gravity: 4 free
    vertices, no modes far stiffer than the slow ones (on the cantilever above, whose axial and
    shear modes are far stiffer than its bending, the midpoint's tip error fell with slopes 1.44
    and 0.29 over 8, 16, 32 steps: those modes were not resolved)."""
    return {
        "mesh": {"box": {"size": [1.0, 1.0, 1.0], "cells": [1, 1, 1]}},
        "material": {"model": "neohookean", "youngs_modulus": 1.0e5, "poisson_ratio": NU, "density": RHO},
        "fixed": [{"box": {"min": [-0.001, -0.001, -0.001], "max": [1.001, 0.001, 1.001]}}],
        "gravity": [0, -G, 0],
        "time": {"dt": T / steps, "frames": steps, "integrator": integrator},
        "solver": {"type": "newton", "iterations": 30, "budget": "fixed", "grad_rtol": 1e-10, "grad_atol": 0},
        "output": {"every": steps},
    }


def top(out):
    """Mean position of the cube's top vertices at the last frame."""
    (m,) = frame_meshes(frame_list(out)[-1][2])
    rest = m.points - m.point_data["displacement"]
    return m.points[rest[:, 1] > 1.0 - 1e-9].mean(axis=0)


def test_order(tmp_path):
    T = 0.1  # short enough for Euler's asymptotic regime (at T = 0.3: slopes 0.26-0.89 over 32-512 steps)
    reference = top(run(tmp_path, "reference", oscillator("implicit-midpoint", T, 1024)))
    for integrator, order in (("implicit-euler", 1), ("bdf2", 2), ("implicit-midpoint", 2)):
        errors = []
        for steps in (32, 64, 128):
            errors.append(np.linalg.norm(top(run(tmp_path, f"{integrator}-{steps}", oscillator(integrator, T, steps))) -
                                         reference))
        slopes = [math.log2(a / b) for a, b in zip(errors, errors[1:])]
        print(f"{integrator}: errors at T {['%.3e' % e for e in errors]}, slopes {['%.2f' % s for s in slopes]}")
        assert all(abs(s - order) <= 0.3 for s in slopes), slopes


@pytest.mark.parametrize("integrator", ["bdf2", "implicit-midpoint"])
@pytest.mark.parametrize("solver", ["lbfgs", "newton"])
def test_same_at_1_and_2_ranks(tmp_path, solver, integrator):
    """The default solver (its H0 factors M + h'^2 L) and Newton, at 1 and 2 ranks."""
    deck = oscillator(integrator, 0.1, 25)
    deck["solver"] = {"type": solver, "iterations": 500, "grad_rtol": 1e-10}
    finals = []
    for ranks in (1, 2):
        out = tmp_path / f"{solver}-np{ranks}"
        run_hyperqn([write_deck(tmp_path / f"{solver}-np{ranks}.yaml", deck), "-o", out], ranks=ranks)
        assert read_summary(out)["status"] == "ok"
        finals.append(final_frame(out))
    a, b = finals
    difference = np.max(np.linalg.norm(a.points - b.points, axis=1)) / rest_diagonal(a)
    print(f"{solver}: 1 against 2 ranks {difference:.2e} of the diagonal")
    assert difference <= 1e-8


@pytest.mark.parametrize("integrator", ["bdf2", "implicit-midpoint"])
def test_restart_substeps_and_study(tmp_path, integrator):
    """Through the rest of the stepping: a restart from a checkpoint equals the uninterrupted run
    bit for bit (BDF2: its history x_{n-1}, v_{n-1} is in the checkpoint); the fallback chain's
    sub-steps (steps of h/k of the same integrator, BDF2 with a history of their own) finish the
    run near the converged one; `hyperqn study` runs it."""
    deck = oscillator(integrator, 0.2, 20)
    deck["output"] = {"every": 5}
    full = run(tmp_path, "full", deck)
    restarted = tmp_path / "restarted"
    first = dict(deck, time=dict(deck["time"], frames=10), checkpoint={"every": 10})
    run_hyperqn([write_deck(tmp_path / "first.yaml", first), "-o", restarted], ranks=1)
    saved = read_checkpoint(restarted / "checkpoints" / "checkpoint_10.h5")
    assert saved["history"] == (integrator == "bdf2")
    assert ("previous_positions" in saved) == (integrator == "bdf2")
    done = run_hyperqn([write_deck(tmp_path / "then.yaml", deck), "-o", restarted, "--restart", "latest"], ranks=1)
    assert "restart from" in done.stdout
    a, b = final_frame(full), final_frame(restarted)
    assert np.array_equal(a.points, b.points) and np.array_equal(a.velocity, b.velocity)

    chained = dict(deck, solver={"type": "lbfgs", "iterations": 1, "max_iterations": 1, "max_halvings": 2,
                                 "newton_fallback": False})
    out = run(tmp_path, "substeps", chained)
    assert read_summary(out)["substepped_frames"] > 0
    difference = np.max(np.linalg.norm(final_frame(out).points - a.points, axis=1)) / rest_diagonal(a)
    print(f"sub-stepped {integrator} against the converged one: {difference:.2e} of the diagonal")
    assert difference <= 1e-3

    study = dict(deck, study={"frames": [5], "solvers": ["lbfgs", "newton"], "iterations": 50})
    proc = run_hyperqn(["study", write_deck(tmp_path / "study.yaml", study), "-o", tmp_path / "study"], ranks=1)
    assert "study written" in proc.stdout
