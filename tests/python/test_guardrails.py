"""Solver guardrails (docs/guardrails.md): non-finite energies are never accepted, failed line
searches are retried or flagged (and summary.json's status says so), and a run that cannot
continue -- non-finite, or diverged -- stops cleanly.

Non-finite energies are provoked with two test hooks, PETSc options read by src/app/run_options.cpp, a term of src/terms/nan_injection.hpp:
- -hyperqn_test_nan_energy_beyond d: g = NaN wherever ||x - y||_inf > d. With a d well above a
  frame's displacement only far trial points are hit; here they are made to happen with
  -tao_ls_stepinit 100 (TAO's first trial of every line search 100 times the L-BFGS step), or
  come naturally (lbfgs-identity's first gradient steps overshoot). With a smaller d the hook
  also constrains the solution (frames may then be flagged: g cannot be decreased further).
- -hyperqn_test_nan_energy_from_step n: g = NaN everywhere from the n-th time step on, so the
  run cannot continue.
Divergence (a finite run-away) comes naturally from h = 1 s at 10 iterations per frame
(tests/decks/stability_dt_1.yaml).
"""
import itertools
import math
import os
import re
import subprocess
import sys
from collections import defaultdict

import meshio
import numpy as np
import pytest

from conftest import FROM_Y, NO_FALLBACK, REPO, load_deck, run_hyperqn, write_deck
from hyperqn_tools.compare import relative_difference
from hyperqn_tools.output import Frame, is_empty_piece, piece_files, read_iterations, read_pvd, read_summary

DECK = "tests/decks/guardrails_bar.yaml"
DIVERGING_DECK = "tests/decks/stability_dt_1.yaml"
FLING_DECK = "tests/decks/guardrails_fling.yaml"
FRAMES = 10
DIVERGENCE_LIMIT = 10  # rest bounding-box diagonals (src/app/run_options.hpp, divergence_limit)
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
    "newton_constrained": ("newton", None, [NAN_BEYOND, 0.01]),
}
# Runs whose flagged frames are the point: without the fallback chain, which would redo them.
NO_CHAIN = {"newton_constrained"}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """{name: (outdir, stdout)} for every run in RUNS; all must exit with 0."""
    tmp = tmp_path_factory.mktemp("guardrails")
    out = {}
    for name, (solver, ranks, args) in RUNS.items():
        deck = load_deck(DECK)
        deck["solver"]["type"] = solver
        if name in NO_CHAIN:
            deck["solver"].update(NO_FALLBACK)
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


def check_summary_finite(outdir):
    with open(os.path.join(outdir, "summary.json")) as f:
        assert "nan" not in f.read().lower()
    s = read_summary(outdir)
    assert all(s[k] is not None for k in ("final_energy", "final_grad_norm", "min_J")), s


def check_status(s):
    """A completed run's status: "ok" without flagged frames, else how many and the first."""
    flagged = s["flagged_frames"]
    if not flagged:
        assert s["status"] == "ok", s["status"]
    else:
        far = any(f["reason"].startswith("far from converged after the fallback chain") for f in flagged)
        assert s["status"] == (f"flagged: {len(flagged)} of {s['frames']} frames could not decrease g "
                               + ("or stayed far from converged " if far else "")
                               + f"(first: frame {flagged[0]['frame']})")


@pytest.mark.parametrize("ranks", [1, 2])
def test_frames_no_stage_makes_acceptable_are_flagged(tmp_path, ranks):
    # h = 1 s with no iteration past the budget: every stage of the chain (sub-steps, Newton) ends
    # far from converged from frame 2 on, and the better of them is kept. They were kept as "ok"
    # with no flag (summary.json's max_residual 6.0); a static step too (the same with the
    # tensile bar's first load step, Newton fallback off).
    deck = load_deck(DIVERGING_DECK)
    deck["solver"] = {"type": "lbfgs", "max_iterations": 0}
    deck["time"]["frames"] = 6
    out = tmp_path / "out"
    proc = run_hyperqn([write_deck(tmp_path / "far.yaml", deck), "-o", out], ranks=ranks)
    s = read_summary(out)
    flagged = s["flagged_frames"]
    assert [f["frame"] for f in flagged] == [2, 3, 4, 5, 6], flagged
    assert all(f["reason"].startswith("far from converged after the fallback chain (MAX_ITERATIONS, |grad g| ")
               for f in flagged)
    check_status(s)
    assert proc.stdout.count("FLAGGED: far from converged after the fallback chain") == 5
    static = load_deck("input/engineering/tensile_bar.yaml")
    static["time"]["frames"] = 1
    static["solver"] = {"type": "lbfgs", "iterations": 10, "max_iterations": 10, "grad_rtol": 1e-8, "newton_fallback": False}
    run_hyperqn([write_deck(tmp_path / "static.yaml", static), "-o", tmp_path / "static"], ranks=ranks)
    s = read_summary(tmp_path / "static")
    assert [f["frame"] for f in s["flagged_frames"]] == [1] and s["status"].startswith("flagged: 1 of 1 frames")
    # the default chain resolves it: nothing flagged
    del static["solver"]
    run_hyperqn([write_deck(tmp_path / "resolved.yaml", static), "-o", tmp_path / "resolved"], ranks=ranks)
    assert read_summary(tmp_path / "resolved")["status"] == "ok"


@pytest.mark.parametrize("ranks", [1, 2])
def test_a_failed_newton_factorization_is_a_failed_stage(tmp_path, ranks):
    # A force of 1e90 N on the free end of a clamped bar: the chain's Newton steps ~1e86 m, where the
    # Hessian's entries reach ~1e177 beside the mass matrix's ~10 and MUMPS finds it numerically
    # singular (INFOG(1) = -10). PETSc 3.18 then skipped every later numeric factorization of that
    # factor, and at 1 rank the run stopped in frame 2 with "Error reported by MUMPS in solve phase:
    # INFOG(1)=-3", frames written, exit 1 (2 ranks: flagged, exit 0). Now the factor is made afresh
    # and, at 1 and 2 ranks alike, every frame is flagged: g could not be decreased.
    deck = {
        "mesh": {"box": {"size": [1.0, 0.2, 0.2], "cells": [4, 2, 2]}},
        "material": {"model": "neohookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 1000},
        "fixed": [{"box": {"min": [-0.01, -1, -1], "max": [0.01, 1, 1]}}],
        "loads": [{"type": "force", "box": {"min": [0.7, -1, -1], "max": [1.1, 1, 1]}, "force": [0, 1e90, 0]}],
        "time": {"dt": 0.03, "frames": 2},
        "solver": {"type": "lbfgs", "iterations": 10, "history": 5},
    }
    out = tmp_path / "out"
    proc = run_hyperqn([write_deck(tmp_path / "huge_load.yaml", deck), "-o", out], ranks=ranks, check=False)
    assert proc.returncode == 0, proc.stdout[-2000:]
    assert "MUMPS" not in proc.stdout and "PETSc" not in proc.stdout, proc.stdout[-2000:]
    s = read_summary(out)
    assert s["status"].startswith("flagged: 2 of 2 frames could not decrease g"), s["status"]
    assert s["frames"] == 2


def longest_edge(path):
    """Longest tet edge of a VTK frame (.vtu or .pvtu) over its rest bounding-box diagonal."""
    edge, rest = 0.0, []
    for piece in piece_files(path):
        if is_empty_piece(piece):
            continue
        m = meshio.read(piece)
        rest.append(m.points - m.point_data["displacement"])
        tets = np.concatenate([c.data for c in m.cells if c.type == "tetra"])
        for a, b in itertools.combinations(range(4), 2):
            edge = max(edge, np.linalg.norm(m.points[tets[:, a]] - m.points[tets[:, b]], axis=1).max())
    rest = np.concatenate(rest)
    return edge / np.linalg.norm(rest.max(axis=0) - rest.min(axis=0))


@pytest.mark.parametrize("name", ["lbfgs", "lbfgs_np2", "armijo", "newton"])
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
    assert s["frames"] == FRAMES and s["rejected_evaluations"] > 0
    check_status(s)
    check_iterations(outdir, None)
    check_vtk_finite(outdir)


@pytest.mark.parametrize("name", list(RUNS))
def test_status_says_whether_frames_were_flagged(runs, name):
    """Every run completes with exit 0; its status is plain "ok" only without flagged frames."""
    outdir, log = runs[name]
    s = read_summary(outdir)
    check_status(s)
    assert re.search(rf"hyperqn: .*; {re.escape(s['status'])}$", log, re.M), log[-500:]


def test_pd_backtracks_from_rejected_points(runs):
    """pd with the solution itself constrained by the hook: rejected points are backtracked from
    (the fallback chain sub-steps the frames that need it), g strictly decreasing, never NaN, and
    the status says whatever frames were flagged. Measured 2026-11-25: 1796 rejected evaluations,
    6 sub-stepped frames, no line-search failure, status ok. Before the multiply-adds of the
    AVX2 kernels, frame 1 ended in one line-search failure (flagged) at every radius of the hook,
    even at 0.02, where it rejects nothing: a stall at round-off, not the hook. Retries along
    -grad g after failed line searches: test_newton_recovers_then_flags."""
    outdir, log = runs["pd"]
    s = read_summary(outdir)
    assert s["frames"] == FRAMES and s["rejected_evaluations"] > 0
    assert len(s["flagged_frames"]) == s["failed_frames"] <= s["ls_failures"]
    assert s["status"] == "ok" if not s["failed_frames"] else s["status"].startswith(f"flagged: {s['failed_frames']} of")
    check_iterations(outdir, 0.0)
    check_vtk_finite(outdir)


def test_newton_recovers_then_flags(runs):
    """newton with the solution itself constrained by the hook: TAONLS's line search stops at
    rejected trials; backtracking from them and retries along the Newton direction and -grad g
    keep g decreasing (measured: 15-20 iterations in frames 5-10, where TAONLS alone made none),
    and a frame is flagged only when they fail too, in the progress line, flagged_frames and the
    status."""
    outdir, log = runs["newton_constrained"]
    s = read_summary(outdir)
    assert s["frames"] == FRAMES and s["rejected_evaluations"] > 0
    assert s["failed_frames"] > 0 and s["ls_failures"] >= s["failed_frames"]
    assert s["status"].startswith(f"flagged: {s['failed_frames']} of {FRAMES} frames")
    flagged = s["flagged_frames"]
    assert len(flagged) == s["failed_frames"]
    assert all(f["reason"] == "LINE_SEARCH_FAILURE" for f in flagged)
    frames = by_frame(check_iterations(outdir, MT_SLACK))
    for f in flagged:
        line = re.search(rf"^frame +{f['frame']} .*$", log, re.M).group(0)
        assert "LINE_SEARCH_FAILURE" in line and "FLAGGED" in line
        its = frames[f["frame"]]
        assert len(its) > 5 and its[-1]["energy"] < its[0]["energy"], f"no progress in frame {f['frame']}"
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


@pytest.mark.parametrize("solver,ranks", [("lbfgs", None), ("lbfgs", 2), ("pd", None)])
def test_diverging_run_stops_cleanly(tmp_path, solver, ranks):
    """h = 1 s at 10 iterations per frame, no fallback chain and each step from y itself: the solvers
    fall behind and the bar runs away, finite. The first frame with an element edge longer than 10 rest diagonals stops the
    run: exit code 1, "error: frame N: diverged: ..." naming the edge length, frame N - 1 written as
    the last frame although only every 5th frame is an output frame, and it is within the limit;
    no NaN anywhere."""
    deck = load_deck(DIVERGING_DECK)
    deck["solver"].update(type=solver, **NO_FALLBACK, **FROM_Y)
    deck["output"]["every"] = 5
    outdir = tmp_path / "out"
    # The element check (|det F| > 100) would stop it first: this test is about the divergence check.
    proc = run_hyperqn([write_deck(tmp_path / "deck.yaml", deck), "-o", outdir, "-hyperqn_element_limit", 0],
                       ranks=ranks, check=False)
    assert proc.returncode == 1
    m = re.search(r"^hyperqn: error: frame (\d+): diverged: an element edge is (\S+) rest bounding-box "
                  rf"diagonals long \(limit {DIVERGENCE_LIMIT}\)", proc.stdout, re.M)
    assert m, proc.stdout[-2000:]
    n, edge = int(m.group(1)), float(m.group(2))
    assert 1 < n < deck["time"]["frames"] and edge > DIVERGENCE_LIMIT
    s = read_summary(outdir)
    assert s["status"].startswith(f"error: frame {n}: diverged: ") and s["frames"] == n - 1
    assert n in [f["frame"] for f in s["flagged_frames"]]
    check_summary_finite(outdir)
    rows = check_iterations(outdir, MT_SLACK)
    assert max(r["frame"] for r in rows) == n  # the diverged frame's iterates are finite too
    frames = check_vtk_finite(outdir)
    dt = deck["time"]["dt"]
    assert [round(t / dt) for t, _ in frames] == sorted({0, *range(5, n, 5), n - 1})
    assert longest_edge(frames[-1][1]) <= DIVERGENCE_LIMIT


@pytest.mark.parametrize("given", ["command line", "deck"])
def test_divergence_check_can_be_turned_off(tmp_path, given):
    """-hyperqn_divergence_limit 0 and -hyperqn_element_limit 0 (also in a deck's petsc: section), or
    the deck's guardrails: {divergence_limit: 0, element_limit: 0}: the run-away goes on to the last
    frame; its inverted elements and line-search failures are in the status, and the exit code is 2,
    never 0; still nothing NaN."""
    outdir = tmp_path / "out"
    deck = load_deck(DIVERGING_DECK)
    deck["solver"].update(NO_FALLBACK, **FROM_Y)
    options = ["-hyperqn_divergence_limit", 0, "-hyperqn_element_limit", 0]
    if given == "deck":
        deck["guardrails"] = {"divergence_limit": 0, "element_limit": 0}
        options = []
    proc = run_hyperqn([write_deck(tmp_path / "deck.yaml", deck), "-o", outdir] + options, check=False)
    assert proc.returncode == 2, proc.stdout[-2000:]
    s = read_summary(outdir)
    assert s["frames"] == 20 and s["failed_frames"] > 0 and s["inverted_frames"] > 0
    flagged = s["flagged_frames"]
    assert s["status"].startswith("inverted: elements with det F <= 0 in ")
    assert s["status"].endswith(f"; flagged: {len(flagged)} of 20 frames could not decrease g "
                                f"(first: frame {flagged[0]['frame']})")
    check_summary_finite(outdir)
    frames = check_vtk_finite(outdir)
    assert longest_edge(frames[-1][1]) > 10 * DIVERGENCE_LIMIT


@pytest.mark.parametrize("solver", ["lbfgs", "newton"])
def test_large_rigid_motion_is_not_divergence(tmp_path, solver):
    """A bar carried 10 m while turning half a turn, released and falling: it ends ~18 rest
    diagonals from its start, but no element is stretched, so the run is ok."""
    deck = load_deck(FLING_DECK)
    deck["solver"]["type"] = solver
    outdir = tmp_path / "out"
    run_hyperqn([write_deck(tmp_path / "deck.yaml", deck), "-o", outdir])
    s = read_summary(outdir)
    assert s["status"] == "ok" and s["frames"] == 60 and s["factorizations"] == (2 if solver == "lbfgs" else 0)
    frames = check_vtk_finite(outdir)
    last = Frame(frames[-1][1])
    rest = last.points - last.displacement
    moved = np.linalg.norm(last.displacement.mean(axis=0)) / np.linalg.norm(rest.max(axis=0) - rest.min(axis=0))
    assert moved > 1.5 * DIVERGENCE_LIMIT
    assert max(longest_edge(path) for _, path in frames) < 0.5


# A 1 m cube whose top face is pushed 1.5 m down, through its clamped bottom face: elements must
# invert (measured: det F < 0 from frame 7 on, min -0.50).
CRUSH = {
    "name": "crush",
    "mesh": {"box": {"size": [1.0, 1.0, 1.0], "cells": [2, 2, 2]}},
    "material": {"model": "neohookean", "youngs_modulus": 1.0e4, "poisson_ratio": 0.3, "density": 1000},
    "fixed": [{"box": {"min": [-1, -0.01, -1], "max": [2, 0.01, 2]}},
              {"box": {"min": [-1, 0.99, -1], "max": [2, 1.01, 2]},
               "motion": {"translate": {"velocity": [0, -3.0, 0]}, "end": 0.5}}],
    "gravity": [0, 0, 0],
    "time": {"dt": 0.05, "frames": 12},
    "output": {"vtk": False},
}


@pytest.mark.parametrize("ranks", [None, 2])
def test_inverted_elements_are_said_in_status_and_exit_code(tmp_path, ranks):
    """A run that goes through every frame with inverted elements is not ok: status "inverted:
    elements with det F <= 0 in N of M frames (first: frame K, ...; min det F X)" and exit code 2."""
    outdir = tmp_path / "out"
    proc = run_hyperqn([write_deck(tmp_path / "crush.yaml", CRUSH), "-o", outdir], ranks=ranks, check=False)
    assert proc.returncode == 2, proc.stdout[-2000:]
    s = read_summary(outdir)
    assert s["frames"] == 12 and s["min_J"] < 0, s
    n = s["inverted_frames"]
    assert 0 < n <= 12
    assert s["status"].startswith(f"inverted: elements with det F <= 0 in {n} of 12 frames (first: frame "), s["status"]
    assert "and the last" in s["status"]


@pytest.mark.parametrize("ranks", [None, 2])
def test_a_body_that_stays_flat_is_not_ok(tmp_path, ranks):
    """A body collapsed to a point (initial: collapse; det F = 0 everywhere) stays there (F = 0 is a
    local minimum of Neo-Hookean, docs/stability.md): flat elements count as inverted, so the run
    ends "inverted: ..." with exit code 2, at 1 and 2 ranks. It used to end "ok" with exit 0."""
    deck = load_deck("tests/decks/stability_initial_collapse.yaml")
    deck["output"] = {"vtk": False}
    outdir = tmp_path / "out"
    proc = run_hyperqn([write_deck(tmp_path / "deck.yaml", deck), "-o", outdir], ranks=ranks, check=False)
    assert proc.returncode == 2, proc.stdout[-2000:]
    s = read_summary(outdir)
    assert s["min_J"] == 0 and s["inverted_frames"] == s["frames"], s
    assert s["status"] == (f"inverted: elements with det F <= 0 in {s['frames']} of {s['frames']} frames "
                           "(first: frame 1, and the last; min det F 0)"), s["status"]


def test_a_start_the_deck_inverts_is_judged_by_its_last_frame(tmp_path):
    """initial: invert makes every element inverted at frame 0; the run recovers, so it is not
    "inverted" (exit 0; frames stalled at the round-off of g near rest may be flagged)."""
    deck = load_deck("tests/decks/stability_initial_invert.yaml")
    outdir = tmp_path / "out"
    run_hyperqn([write_deck(tmp_path / "deck.yaml", deck), "-o", outdir], ranks=None)
    s = read_summary(outdir)
    assert not s["status"].startswith("inverted") and s["min_J"] < 0, s


def test_exploding_elements_stop_the_run(tmp_path):
    """A sliver-laden mesh (scripts/sliver_mesh.py) whose slivers next to the clamped top blow up
    when the fallback chain does not redo the frame and the step starts from y: an element's |det F|
    past 100 stops the run
    (exit 1, "elements exploded", the last good frame written), long before any edge reaches the
    divergence limit (without this check the run went on to frame 10 with min det F -9e4)."""
    mesh = tmp_path / "slivers.mesh"
    subprocess.run([sys.executable, os.path.join(REPO, "scripts", "sliver_mesh.py"), str(mesh), "--size", "0.1", "0.5",
                    "0.1", "--element", "0.05", "--worst", "1e-5", "--fraction", "0.1", "--seed", "3"],
                   check=True, capture_output=True)
    deck = {"name": "slivers", "mesh": {"file": str(mesh)},
            "material": {"model": "neohookean", "youngs_modulus": 1.0e6, "poisson_ratio": 0.4, "density": 1000},
            "fixed": [{"box": {"min": [-1, 0.475, -1], "max": [1, 1, 1]}}],
            "time": {"dt": 1 / 30, "frames": 20}, "output": {"every": 5},
            # the chain would redo the frame, and the pulled-back guess avoids it (test_sliver_mesh.py)
            "solver": dict(NO_FALLBACK, **FROM_Y)}
    outdir = tmp_path / "out"
    proc = run_hyperqn([write_deck(tmp_path / "slivers.yaml", deck), "-o", outdir], ranks=None, check=False)
    assert proc.returncode == 1
    m = re.search(r"^hyperqn: error: frame (\d+): elements exploded: \|det F\| reaches (\S+) \(limit 100\)",
                  proc.stdout, re.M)
    assert m, proc.stdout[-2000:]
    n = int(m.group(1))
    assert float(m.group(2)) > 100
    s = read_summary(outdir)
    assert s["status"].startswith(f"error: frame {n}: elements exploded") and s["frames"] == n - 1
    frames = check_vtk_finite(outdir)
    assert frames[-1][0] == pytest.approx((n - 1) / 30)
    assert np.abs(Frame(frames[-1][1]).J).max() <= 100
