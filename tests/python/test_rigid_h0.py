"""solver.h0_rigid: the stiff clusters' rotations left out of L-BFGS's H0 by a Woodbury correction
of the factored M + h^2 L (solvers/rigid_mode_h0.hpp, docs/method.md#the-initial-hessian-h0), on
the stability suite's 1e4 stiffness contrast (input/stability/contrast_1e4.yaml, 81 vertices).
The corrected operator equals A'^{-1} of a dense A' to 1e-10 relative at 1 and 2 ranks (and A^{-1}
alone does not: the check can fail); the run ends nearer the converged reference with it than
without; 1, 2 and 4 ranks agree; a killed run restarts bit for bit at 1 and 2 ranks; a bad value is
refused; a deck without a contrast runs as before, bit for bit."""
import os
import re
from pathlib import Path

import numpy as np
import pytest

from conftest import MPIEXEC, load_deck, run_hyperqn, write_deck
from hyperqn_tools import launch
from hyperqn_tools.output import Frame, final_frame, frame_list, read_iterations, read_summary, rest_diagonal
from hyperqn_tools.stability.judge import frame_distance
from hyperqn_tools.stability.run import REFERENCE_SOLVER
from test_bad_input import assert_deck_refused
from test_checkpoint_faults import assert_restart_after_kill_is_bitwise

CONTRAST = load_deck("input/stability/contrast_1e4.yaml")
CHECK = ["-hyperqn_test_rigid_h0_check"]


def deck_with(solver, frames=None):
    deck = {**CONTRAST, "solver": solver}
    if frames:
        deck["time"] = {**CONTRAST["time"], "frames": frames}
    return deck


def run(tmp_path, name, deck, ranks=None, extra=()):
    out = tmp_path / name
    proc = run_hyperqn([write_deck(tmp_path / f"{name}.yaml", deck), "-o", out, *extra], ranks=ranks)
    assert read_summary(out)["status"] == "ok", proc.stdout[-3000:]
    return out, proc.stdout


@pytest.mark.parametrize("ranks", [None, 2])
def test_corrected_operator_equals_a_dense_inverse(tmp_path, ranks):
    _, stdout = run(tmp_path, "check", deck_with({"type": "lbfgs", "h0_rigid": True}, frames=2), ranks, CHECK)
    found = re.findall(r"rigid-mode H0 check: (\d+) clusters, (\d+) dofs, corrected (\S+), uncorrected (\S+)", stdout)
    assert found, stdout[-2000:]
    for clusters, dofs, corrected, uncorrected in found:
        assert int(clusters) == 1 and int(dofs) == 216  # the stiff half, the same at every rank count
        assert float(corrected) < 1e-10
        assert float(uncorrected) > 1e-2  # A^{-1} alone is far from A'^{-1} (measured 0.05): the check sees it


@pytest.fixture(scope="module")
def contrast_runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("contrast")
    runs = {}
    for name, solver in [("reference", REFERENCE_SOLVER), ("on", {"type": "lbfgs", "h0_rigid": True}),
                         ("off", {"type": "lbfgs", "h0_rigid": False}), ("auto", {"type": "lbfgs"})]:
        runs[name], _ = run(tmp, name, deck_with(solver))
    return runs


def test_ends_nearer_the_reference_with_it(contrast_runs):
    ref = final_frame(contrast_runs["reference"])
    on = frame_distance(final_frame(contrast_runs["on"]), ref)
    off = frame_distance(final_frame(contrast_runs["off"]), ref)
    # measured 0.0096 against 0.379 (docs/records/2026-12-04-rigid-h0.md)
    assert on < 0.05 < 0.2 < off, (on, off)


def test_auto_turns_it_on_where_there_is_a_contrast(contrast_runs):
    on, auto = contrast_runs["on"], contrast_runs["auto"]
    assert (auto / "contrast_1e4_00040.vtu").read_bytes() == (on / "contrast_1e4_00040.vtu").read_bytes()


def positions(out):
    return [Frame(path) for _, _, path in frame_list(out)]


def test_ranks_agree(tmp_path):
    # round-off between rank counts grows about 4x a frame on this swing (1e-13 at frame 3, 3e-9 at
    # frame 8, 1e-8 at frame 10; without the correction 2.6e-10 at frame 10)
    deck = deck_with({"type": "lbfgs", "h0_rigid": True}, frames=8)
    serial, _ = run(tmp_path, "one", deck)
    frames = positions(serial)
    for ranks in (2, 4):
        other, _ = run(tmp_path, f"ranks{ranks}", deck, ranks)
        for a, b in zip(frames, positions(other)):
            assert np.array_equal(a.vertex_id, b.vertex_id)
            assert np.abs(a.points - b.points).max() / rest_diagonal(a) < 1e-8, ranks


@pytest.mark.parametrize("ranks", [None, 2])
def test_restart_after_kill_is_bitwise(tmp_path, ranks):
    assert_restart_after_kill_is_bitwise(tmp_path, deck_with({"type": "lbfgs", "h0_rigid": True}), ranks=ranks,
                                         frames=12, every=4, kill_after=10)


BAD = {
    "word": ({"type": "lbfgs", "h0_rigid": "sometimes"}, ["solver.h0_rigid", "auto", "true", "false"]),
    "matrix": ({"type": "lbfgs", "h0": "rest-stiffness", "h0_rigid": True},
               ["solver.h0_rigid", "h0: rest-stiffness", "h0: laplacian or auto"]),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_value_is_refused(tmp_path, case):
    solver, fragments = BAD[case]
    assert_deck_refused(tmp_path, case, deck_with(solver, frames=2), fragments)


def outputs(out):
    """Every output file's bytes but the run's own records (times, ids, the deck's path)."""
    skip = {"summary.json", "run.log", "config.yaml", "deck.yaml", "iterations.csv"}
    return {p.name: p.read_bytes() for p in sorted(Path(out).iterdir()) if p.is_file() and p.name not in skip}


def iterations(out):
    return [{k: v for k, v in r.items() if k != "time_s"} for r in read_iterations(out)]


def test_no_contrast_runs_none_of_it(tmp_path):
    # the contrast at 10x (below the 100x of a stiff cluster): h0_rigid true is the same run as false
    deck = deck_with({"type": "lbfgs", "h0_rigid": True}, frames=8)
    deck["regions"] = [{**CONTRAST["regions"][0], "material": {**CONTRAST["regions"][0]["material"], "youngs_modulus": 1.0e6}}]
    on, _ = run(tmp_path, "on", deck)
    off, _ = run(tmp_path, "off", {**deck, "solver": {"type": "lbfgs", "h0_rigid": False}})
    assert outputs(on) == outputs(off) and iterations(on) == iterations(off)


BASE = os.environ.get("HYPERQN_BASE_BIN", "/tmp/hyperqn-98bff2e")


@pytest.mark.skipif(not os.path.exists(BASE), reason="the binary of main before solver.h0_rigid")
def test_deck_without_contrast_is_bitwise_as_before(tmp_path):
    deck = load_deck("input/bar.yaml")
    deck["time"] = {**deck["time"], "frames": 10}
    path = write_deck(tmp_path / "bar.yaml", deck)
    new, base = tmp_path / "new", tmp_path / "base"
    run_hyperqn([path, "-o", new])
    assert launch.run([path, "-o", base], None, BASE, MPIEXEC, timeout=120).returncode == 0
    assert outputs(new) == outputs(base) and iterations(new) == iterations(base)
    assert read_summary(new)["iterations"] == read_summary(base)["iterations"]
