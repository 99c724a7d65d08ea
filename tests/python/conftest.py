"""Shared helpers for the end-to-end tests: where the binary is, and how to run it under MPI.
Running and deck writing are those of postprocess/hyperqn_tools (on PYTHONPATH; ctest sets it)."""
import json
import os
import re

import pytest

from hyperqn_tools import decks, launch
from hyperqn_tools.paths import REPO

HYPERQN = launch.default_binary()
MPIEXEC = launch.default_mpiexec()


def run_hyperqn(args, ranks=1, timeout=600, check=True):
    """Runs `mpiexec -n ranks hyperqn args...`, one rank as the binary alone (ranks 1 or None: a
    singleton MPI process, the same computation, started 0.1 s sooner than by mpiexec, which adds
    up over the suite's runs); returns the CompletedProcess (stdout+stderr text)."""
    proc = launch.run(args, None if ranks == 1 else ranks, HYPERQN, MPIEXEC, timeout=timeout)
    if check and proc.returncode != 0:
        raise AssertionError(f"{' '.join(proc.args)} failed ({proc.returncode}):\n{proc.stdout[-4000:]}")
    return proc


def run_at_1_and_2_ranks(deck_path, tmp):
    """Runs the deck at 1 and 2 ranks with -log_view; returns {ranks: (outdir, PETSc log text)}."""
    out = {}
    for ranks in (1, 2):
        outdir = tmp / f"np{ranks}"
        log = tmp / f"log_view_np{ranks}.txt"
        run_hyperqn([deck_path, "-o", outdir, "-log_view", f":{log}"], ranks=ranks)
        out[ranks] = (str(outdir), log.read_text())
    return out


def event_count(log_text, event):
    """Call count of a PETSc -log_view event (max over ranks)."""
    m = re.search(rf"^{event}\s+(\d+)", log_text, re.M)
    return int(m.group(1)) if m else 0


# solver keys that turn the fallback chain off (docs/guardrails.md#fallback): for the tests of
# what happens to a frame or a run that the chain would otherwise rescue.
NO_FALLBACK = {"max_iterations": 0, "max_halvings": 0, "newton_fallback": False}
# solver key that starts each step from y itself, not pulled back where y inverts or blows up
# elements (docs/guardrails.md#element-blow-up-and-inversion): for the tests of run-aways that
# the pulled-back guess would avoid.
FROM_Y = {"upright_guess": False}


def run_deck(tmp_path, name, deck, ranks=None, extra=()):
    """Writes deck to tmp_path/NAME.yaml, runs it into tmp_path/NAME (with the extra arguments) and
    returns that directory and its summary.json; the run must end with status ok."""
    out = tmp_path / name
    proc = run_hyperqn([write_deck(tmp_path / f"{name}.yaml", deck), "-o", out, *extra], ranks=ranks)
    with open(out / "summary.json") as f:
        summary = json.load(f)
    assert summary["status"] == "ok", proc.stdout[-3000:]
    return out, summary


def write_deck(path, deck):
    return decks.write_deck(path, deck)


def load_deck(name):
    """A deck of the repository by its path from the repository root."""
    return decks.load_deck(os.path.join(REPO, name))


@pytest.fixture
def repo():
    return REPO


def twisted_bar_study(tmp_path, material, ranks):
    """The study check of a material with history (test_viscoelastic, test_plasticity): a bar
    (2 x 0.5 x 0.5, 8 x 2 x 2 cells) of `material`, its end turned a quarter turn and released at
    t = 0.3, studied with lbfgs and Newton; then two plain runs of it (lbfgs, and the reference's
    Newton). Returns the worst relative difference, over frames 2, 5, 7 and 10, between the study's
    lbfgs trajectory's RMS distance to the reference and the two runs' (each frame's free vertices:
    the turned end's 9 are not free before the release)."""
    import csv

    import numpy as np
    from hyperqn_tools.output import Frame, frame_list, read_summary
    deck = {
        "mesh": {"box": {"size": [2.0, 0.5, 0.5], "cells": [8, 2, 2]}},
        "material": material,
        "fixed": [{"box": {"min": [-0.01, -1, -1], "max": [0.01, 1, 1]}},
                  {"box": {"min": [1.99, -1, -1], "max": [2.01, 1, 1]},
                   "motion": {"rotate": {"axis": [1, 0, 0], "center": [2.0, 0.25, 0.25], "rate": 360.0}, "end": 0.25},
                   "release": 0.3}],
        "gravity": [0, 0, 0],
        "time": {"dt": 0.05, "frames": 10},
        "solver": {"type": "lbfgs", "iterations": 10},
        "study": {"frames": [4, 8], "solvers": ["lbfgs", "newton"], "iterations": 100},
    }
    proc = run_hyperqn(["study", write_deck(tmp_path / "study.yaml", deck), "-o", tmp_path / "study"], ranks=ranks)
    assert "fixed region(s) released" in proc.stdout
    with open(tmp_path / "study" / "trajectory.csv") as f:
        rows = list(csv.DictReader(f))
    runs = {}
    for name, solver in {"lbfgs": {**deck["solver"], **NO_FALLBACK},
                         "reference": {"type": "newton", "newton_hessian": "exact", "iterations": 100,
                                       "grad_rtol": 1e-10, **NO_FALLBACK}}.items():
        d = dict(deck, solver=solver, output={"every": 1})
        del d["study"]
        runs[name] = tmp_path / name
        run_hyperqn([write_deck(tmp_path / f"{name}.yaml", d), "-o", runs[name]], ranks=ranks)
    free = read_summary(runs["lbfgs"])["dofs"] // 3  # after the release
    frames = {name: {n: path for n, _, path in frame_list(runs[name])} for name in runs}
    worst = 0.0
    for frame in (2, 5, 7, 10):
        a, b = Frame(frames["lbfgs"][frame]).points, Frame(frames["reference"][frame]).points
        rms = np.linalg.norm(a - b) / np.sqrt(free - (9 if frame * 0.05 <= 0.3 + 1e-9 else 0))
        assert rms > 1e-6, "the comparison needs a visible difference"
        row = next(r for r in rows if r["solver"] == "lbfgs" and int(r["frame"]) == frame)
        worst = max(worst, abs(float(row["rms_error"]) - rms) / rms)
    return worst


def env_without_matplotlib(tmp_path):
    """The environment of a tool run as if matplotlib were not installed: a `matplotlib` package
    first on PYTHONPATH whose import raises ImportError."""
    fake = tmp_path / "no_matplotlib" / "matplotlib"
    fake.mkdir(parents=True, exist_ok=True)
    (fake / "__init__.py").write_text('raise ImportError("No module named matplotlib (simulated)")\n')
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(fake.parent), os.path.join(REPO, "postprocess"),
                                                         os.environ.get("PYTHONPATH", "")])}
