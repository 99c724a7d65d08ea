"""Solver guardrails (README, "Guardrails"): non-finite energies are never accepted, failed line
searches are retried or flagged, and a run that cannot continue stops cleanly.

Non-finite energies are provoked with two test hooks, PETSc options read by src/time_step.cpp:
- -hyperqn_test_nan_energy_beyond d: g = NaN wherever ||x - y||_inf > d. With a d well above a
  frame's displacement only far trial points are hit; here they are made to happen with
  -tao_ls_stepinit 100 (TAO's first trial of every line search 100 times the L-BFGS step), or
  come naturally (lbfgs-identity's first gradient steps overshoot). With a smaller d the hook
  also constrains the solution (frames may then be flagged: g cannot be decreased further).
- -hyperqn_test_nan_energy_from_step n: g = NaN everywhere from the n-th time step on, so the
  run cannot continue.
"""
import math
import os
import re
from collections import defaultdict

import numpy as np
import pytest

from conftest import load_deck, run_hyperqn, write_deck
from compare_runs import relative_difference
from hyperqn_output import Frame, read_iterations, read_pvd, read_summary

DECK = "tests/decks/guardrails_bar.yaml"
FRAMES = 10
# TAO's More-Thuente accepts a step if g(x + a d) - (g(x) + ftol a g'.d) <= 1e-10 |g(x)| (TAO 3.18),
# so TAO's own steps may raise g by round-off near the minimizer (also without any guardrail
# involved); our own backtracking (pd, retries) only takes strict decreases.
MT_SLACK = 1e-10
NAN_BEYOND = "-hyperqn_test_nan_energy_beyond"
NAN_FROM_STEP = "-hyperqn_test_nan_energy_from_step"
OVERSHOOT = ["-tao_ls_stepinit", 100]

# name: (solver type, ranks, extra arguments)
RUNS = {
    "plain": ("lbfgs", None, []),
    "lbfgs": ("lbfgs", None, [NAN_BEYOND, 0.2] + OVERSHOOT),
    "lbfgs_np2": ("lbfgs", 2, [NAN_BEYOND, 0.2] + OVERSHOOT),
    "identity": ("lbfgs-identity", None, [NAN_BEYOND, 1.0]),
    "armijo": ("lbfgs", None, [NAN_BEYOND, 0.2, "-tao_ls_type", "armijo"] + OVERSHOOT),
    "unit": ("lbfgs", None, [NAN_BEYOND, 0.2, "-tao_ls_type", "unit"] + OVERSHOOT),
    "pd": ("pd", None, [NAN_BEYOND, 0.01]),
    "newton": ("newton", None, [NAN_BEYOND, 0.2] + OVERSHOOT),
}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """{name: (outdir, stdout)} for every run in RUNS; all must exit with 0."""
    tmp = tmp_path_factory.mktemp("guardrails")
    out = {}
    for name, (solver, ranks, args) in RUNS.items():
        deck = load_deck(DECK)
        deck["solver"]["type"] = solver
        outdir = tmp / name
        proc = run_hyperqn([write_deck(tmp / f"{name}.yaml", deck), "-o", outdir] + args, ranks=ranks)
        out[name] = (str(outdir), proc.stdout)
    return out


def by_frame(rows):
    frames = defaultdict(list)
    for r in rows:
        frames[r["frame"]].append(r)
    return frames


def check_iterations(outdir, monotone_slack):
    """iterations.csv: finite values only, iterations numbered 0, 1, ... in every frame, and (if
    monotone_slack is not None) g non-increasing within each frame up to monotone_slack |g|."""
    rows = read_iterations(outdir)
    assert rows
    with open(os.path.join(outdir, "iterations.csv")) as f:
        text = f.read().lower()
    assert "nan" not in text and "inf" not in text
    for r in rows:
        assert all(math.isfinite(v) for v in r.values()), r
        assert abs(r["energy"]) < 1e100, f"a rejected energy was logged: {r}"
    for frame, its in by_frame(rows).items():
        assert [r["iteration"] for r in its] == list(range(len(its))), f"frame {frame}"
        if monotone_slack is None:
            continue
        for prev, cur in zip(its, its[1:]):
            assert cur["energy"] <= prev["energy"] + monotone_slack * abs(prev["energy"]), \
                f"g increased in frame {frame}: {prev} -> {cur}"
    return rows


def check_vtk_finite(outdir):
    pvd = [f for f in os.listdir(outdir) if f.endswith(".pvd")]
    frames = read_pvd(os.path.join(outdir, pvd[0]))
    for _, path in frames:
        fr = Frame(path)
        for a in (fr.points, fr.displacement, fr.velocity, fr.J):
            assert np.all(np.isfinite(a)), path
    return frames


@pytest.mark.parametrize("name", ["lbfgs", "lbfgs_np2", "armijo"])
def test_rejected_trials_are_backtracked_to_the_same_answer(runs, name):
    """Far trial points have NaN energies; the frames still converge, to the same positions."""
    outdir, log = runs[name]
    s = read_summary(outdir)
    assert s["status"] == "ok" and s["frames"] == FRAMES
    assert s["rejected_evaluations"] > 0, "the test hook should have rejected some trial points"
    assert s["converged_frames"] == FRAMES and s["failed_frames"] == 0 and s["flagged_frames"] == []
    check_iterations(outdir, MT_SLACK)
    check_vtk_finite(outdir)
    rel, _, scale = relative_difference(runs["plain"][0], outdir)
    assert scale > 0.1
    assert rel < 1e-5, f"{name} differs from the run without rejections by {rel:.2e}"  # tolerance 1e-6


def test_plain_run_has_no_guardrail_events(runs):
    s = read_summary(runs["plain"][0])
    assert s["status"] == "ok" and s["rejected_evaluations"] == 0 and s["ls_failures"] == 0
    assert s["flagged_frames"] == []


def test_lbfgs_identity_overshoot(runs):
    """TAO's default H0 makes the first steps overshoot by far: rejected, backtracked, run completes."""
    outdir, _ = runs["identity"]
    s = read_summary(outdir)
    assert s["status"] == "ok" and s["frames"] == FRAMES and s["solver"] == "lbfgs-identity"
    assert s["rejected_evaluations"] > 0
    check_iterations(outdir, MT_SLACK)
    check_vtk_finite(outdir)


def test_unit_step_never_accepts_a_rejected_point(runs):
    """The unit line search has no sufficient-decrease test (finite increases are its choice), but a
    rejected point is undone and backtracked from."""
    outdir, _ = runs["unit"]
    s = read_summary(outdir)
    assert s["status"] == "ok" and s["frames"] == FRAMES and s["rejected_evaluations"] > 0
    check_iterations(outdir, None)
    check_vtk_finite(outdir)


def test_pd_backtracks_and_retries(runs):
    """pd with the solution itself constrained by the hook: rejected points are backtracked from,
    failed line searches retried along -grad g, g strictly decreasing, never NaN."""
    outdir, log = runs["pd"]
    s = read_summary(outdir)
    assert s["status"] == "ok" and s["frames"] == FRAMES
    assert s["rejected_evaluations"] > 0 and s["ls_failures"] > 0
    assert len(s["flagged_frames"]) == s["failed_frames"]
    check_iterations(outdir, 0.0)
    check_vtk_finite(outdir)


def test_newton_failures_are_flagged(runs):
    """TAONLS's More-Thuente stops at a rejected trial and its fallbacks cannot get past it
    either: the frame is flagged in the progress line and in summary.json, and the run goes on."""
    outdir, log = runs["newton"]
    s = read_summary(outdir)
    assert s["status"] == "ok" and s["frames"] == FRAMES and s["rejected_evaluations"] > 0
    assert s["failed_frames"] > 0 and s["ls_failures"] >= s["failed_frames"]
    flagged = s["flagged_frames"]
    assert len(flagged) == s["failed_frames"]
    assert all(f["reason"] == "LINE_SEARCH_FAILURE" for f in flagged)
    for f in flagged:
        line = re.search(rf"^frame +{f['frame']} .*$", log, re.M).group(0)
        assert "LINE_SEARCH_FAILURE" in line and "FLAGGED" in line
    check_iterations(outdir, MT_SLACK)
    check_vtk_finite(outdir)


@pytest.mark.parametrize("solver,ranks", [("lbfgs", None), ("lbfgs", 2), ("pd", None)])
def test_run_that_cannot_continue_stops_cleanly(tmp_path, solver, ranks):
    """From step 8 on g is NaN everywhere: exit code 1, status "error: frame 8: ...", frame 7 (not
    an output frame) written as the last, finite, VTK frame; no NaN in any output."""
    deck = load_deck(DECK)
    deck["solver"]["type"] = solver
    outdir = tmp_path / "out"
    proc = run_hyperqn([write_deck(tmp_path / "deck.yaml", deck), "-o", outdir, NAN_FROM_STEP, 8],
                       ranks=ranks, check=False)
    assert proc.returncode != 0
    assert re.search(r"hyperqn: error: frame 8: ", proc.stdout), proc.stdout[-2000:]
    s = read_summary(outdir)
    assert s["status"].startswith("error") and "frame 8" in s["status"]
    assert s["frames"] == 7
    assert {"frame": 8, "reason": "REJECTED_INITIAL_GUESS"} in s["flagged_frames"]
    with open(os.path.join(outdir, "summary.json")) as f:
        assert "nan" not in f.read().lower()
    rows = check_iterations(outdir, MT_SLACK if solver == "lbfgs" else 0.0)
    assert max(r["frame"] for r in rows) == 7
    frames = check_vtk_finite(outdir)
    dt = deck["time"]["dt"]
    assert [round(t / dt) for t, _ in frames] == [0, 5, 7]
