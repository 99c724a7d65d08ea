"""Projective Dynamics (solver pd) and the scaled-identity L-BFGS ablation (lbfgs-identity).

- ARAP (corotated, lambda = 0): pd is PD's exact local-global iteration: every step is alpha = 1,
  g never increases within a frame, 1 and 2 ranks agree, and it is the same iteration as TAO's
  L-BFGS with history 0 and H0 = A^{-1} (both give d = -A^{-1} grad g and take the unit step).
- Neo-Hookean: pd is not exact, says so, and backtracks; g still never increases.
- lbfgs-identity converges, but needs more iterations than lbfgs to the same gradient tolerance.
"""
import os
from collections import defaultdict

import pytest

from conftest import REPO, load_deck, run_hyperqn, write_deck
from hyperqn_tools.compare import relative_difference
from hyperqn_tools.output import read_iterations, read_summary

ARAP_DECK = os.path.join(REPO, "tests/decks/pd_arap.yaml")
NEOHOOKEAN_DECK = os.path.join(REPO, "tests/decks/pd_neohookean.yaml")
EXACT_LINE = "exact local-global steps"
NOT_EXACT_LINE = "Projective Dynamics is not exact for this material"


def by_frame(rows):
    frames = defaultdict(list)
    for r in rows:
        frames[r["frame"]].append(r)
    return frames


def assert_energy_never_increases(rows):
    for frame, its in by_frame(rows).items():
        assert [r["iteration"] for r in its] == list(range(len(its)))
        for prev, cur in zip(its, its[1:]):
            assert cur["energy"] <= prev["energy"], f"g increased in frame {frame}: {prev} -> {cur}"


def with_solver(tmp_path, deck_path, name, **solver):
    deck = load_deck(deck_path)
    deck["solver"] = {**deck["solver"], **solver}
    return write_deck(tmp_path / f"{name}.yaml", deck)


@pytest.fixture(scope="module")
def arap(tmp_path_factory):
    """{run name: (outdir, stdout)}: pd at 1 and 2 ranks, lbfgs with history 0 at 1 rank."""
    tmp = tmp_path_factory.mktemp("arap")
    deck = load_deck(ARAP_DECK)
    runs = {"pd_np1": (deck, 1), "pd_np2": (deck, 2)}
    for ls in ("unit", "more-thuente"):
        d = load_deck(ARAP_DECK)
        d["solver"] = {**d["solver"], "type": "lbfgs", "history": 0, "line_search": ls}
        runs[f"lbfgs0_{ls}"] = (d, 1)
    out = {}
    for name, (d, ranks) in runs.items():
        outdir = tmp / name
        proc = run_hyperqn([write_deck(tmp / f"{name}.yaml", d), "-o", outdir], ranks=ranks)
        out[name] = (str(outdir), proc.stdout)
    return out


@pytest.mark.parametrize("ranks", [1, 2])
def test_arap_pd_is_monotone_with_unit_steps(arap, ranks):
    outdir, log = arap[f"pd_np{ranks}"]
    assert log.count(EXACT_LINE) == 1 and NOT_EXACT_LINE not in log
    s = read_summary(outdir)
    assert s["status"] == "ok" and s["solver"] == "pd" and s["failed_frames"] == 0
    assert s["factorizations"] == 1
    rows = read_iterations(outdir)
    assert {r["frame"] for r in rows} == set(range(1, s["frames"] + 1))
    assert all(r["step"] == 1.0 for r in rows if r["iteration"] >= 1)
    # One g/grad g evaluation and one A^{-1} solve per iteration (the gradient at the accepted
    # point is reused for the next direction).
    assert all(r["evaluations"] == r["iteration"] + 1 for r in rows)
    assert s["h0_solves"] == s["iterations"] > 0
    assert_energy_never_increases(rows)


def test_arap_pd_parallel_matches_serial(arap):
    rel, _, scale = relative_difference(arap["pd_np1"][0], arap["pd_np2"][0])
    assert scale > 1e-3, "the bar should sag"
    assert rel <= 1e-8, f"pd at 1 vs 2 ranks differs by {rel:.3e} of the largest displacement"


@pytest.mark.parametrize("line_search", ["unit", "more-thuente"])
def test_arap_pd_is_lbfgs_with_history_0(arap, line_search):
    # TAOLMVM with hist_size 0 keeps no pairs, and with a user H0 its J0 scaling is off, so its
    # direction is exactly -A^{-1} grad g; More-Thuente accepts the unit step on the first try.
    pd_rows = read_iterations(arap["pd_np1"][0])
    lb_rows = read_iterations(arap[f"lbfgs0_{line_search}"][0])
    assert [(r["frame"], r["iteration"]) for r in pd_rows] == [(r["frame"], r["iteration"]) for r in lb_rows]
    for p, q in zip(pd_rows, lb_rows):
        assert q["step"] == p["step"]
        assert q["evaluations"] == p["evaluations"]
        assert abs(p["energy"] - q["energy"]) <= 1e-10 * abs(p["energy"]), (p, q)
        assert abs(p["grad_norm"] - q["grad_norm"]) <= 1e-8 * p["grad_norm"], (p, q)
    rel, _, _ = relative_difference(arap["pd_np1"][0], arap[f"lbfgs0_{line_search}"][0])
    assert rel <= 1e-9, f"pd and lbfgs (history 0) positions differ by {rel:.3e}"


@pytest.mark.parametrize("material, exact", [
    ({"model": "corotated", "youngs_modulus": 1.0e6, "poisson_ratio": 0.0, "density": 1000}, True),
    ({"model": "corotated", "youngs_modulus": 1.0e6, "poisson_ratio": 0.3, "density": 1000}, False),
    # ARAP, but A built with another weight than 2 mu: no longer the local-global step.
    ({"model": "corotated", "mu": 5.0e5, "lambda": 0, "density": 1000, "laplacian_weight": 2.0e6}, False),
    # Springs: exact with their own stiffness in L, not with another one.
    ({"model": "mass-spring", "spring_stiffness": 2.0e4, "density": 1000}, True),
    ({"model": "mass-spring", "spring_stiffness": 2.0e4, "density": 1000, "laplacian_weight": 4.0e4}, False),
])
def test_pd_says_which_mode_runs(tmp_path, material, exact):
    deck = load_deck(ARAP_DECK)
    deck["material"] = material
    deck["time"]["frames"] = 1
    deck["output"] = {"vtk": False}
    proc = run_hyperqn([write_deck(tmp_path / "d.yaml", deck), "-o", tmp_path / "out"], ranks=None)
    assert (EXACT_LINE in proc.stdout) == exact and (NOT_EXACT_LINE in proc.stdout) == (not exact), proc.stdout
    assert_energy_never_increases(read_iterations(tmp_path / "out"))


def test_pd_names_the_terms_that_are_not_exact(tmp_path):
    # a cloth whose edge springs yield: the message listed every term ("cloth mass, cloth springs,
    # bending springs") and the rule "ARAP or springs", never the yield
    deck = {"mesh": {"sheet": {"size": [0.2, 0.2], "cells": [4, 4]}},
            "cloth": {"model": "mass-spring", "stretch_stiffness": 10.0, "areal_density": 0.2, "yield_strain": 0.01,
                      "bending": {"model": "springs", "stiffness": 1.0}},
            "fixed": [{"box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 0.01, 0.21]}}],
            "time": {"dt": 0.01, "frames": 1}, "solver": {"type": "pd"}, "output": {"vtk": False}}
    proc = run_hyperqn([write_deck(tmp_path / "d.yaml", deck), "-o", tmp_path / "out"], ranks=None)
    assert NOT_EXACT_LINE + " (not: cloth springs; exact needs ARAP or springs without yield_strain" in proc.stdout, \
        proc.stdout


@pytest.mark.parametrize("ranks", [1, 2])
def test_neohookean_pd_uses_the_line_search(tmp_path, ranks):
    proc = run_hyperqn([NEOHOOKEAN_DECK, "-o", tmp_path / "out"], ranks=ranks)
    assert proc.stdout.count(NOT_EXACT_LINE) == 1 and EXACT_LINE not in proc.stdout
    s = read_summary(tmp_path / "out")
    assert s["status"] == "ok" and s["failed_frames"] == 0
    rows = read_iterations(tmp_path / "out")
    steps = [r["step"] for r in rows if r["iteration"] >= 1]
    # Backtracking by halving from 1: every step is 2^-j, and this scene needs some j > 0.
    assert all(st in [0.5**j for j in range(31)] for st in steps)
    assert any(st < 1 for st in steps), "expected the line search to backtrack at least once"
    assert_energy_never_increases(rows)


def test_lbfgs_identity_needs_more_iterations_than_lbfgs(tmp_path):
    base = load_deck("input/bar.yaml")
    base["mesh"]["box"]["cells"] = [12, 3, 3]
    base["time"]["frames"] = 3
    base["output"] = {"vtk": False}
    mean = {}
    for solver in ("lbfgs", "lbfgs-identity"):
        deck = dict(base, solver={"type": solver, "iterations": 3000, "grad_rtol": 1.0e-6})
        outdir = tmp_path / solver
        run_hyperqn([write_deck(tmp_path / f"{solver}.yaml", deck), "-o", outdir], ranks=None)
        s = read_summary(outdir)
        assert s["status"] == "ok" and s["solver"] == solver
        assert s["converged_frames"] == 3 and s["failed_frames"] == 0
        mean[solver] = s["mean_iterations"]
    print(f"mean iterations per frame to |grad g| < 1e-6 |grad g0|: {mean}")
    assert read_summary(tmp_path / "lbfgs-identity")["factorizations"] == 0
    assert mean["lbfgs-identity"] > 2 * mean["lbfgs"], mean
