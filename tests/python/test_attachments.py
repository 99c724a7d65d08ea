"""Soft attachments (deck attachments:, terms/attachments.hpp), end to end.

- A cantilever held by attachments alone at x = 0 approaches the clamped one as k grows.
- Projective Dynamics stays exact with attachments (their springs are in A = M + h^2 L): on ARAP,
  pd equals lbfgs with history 0 and agrees at 1 and 2 ranks.
- input/contact/bar_attached.yaml (one attachment moving, one released) runs at 1 and 2 ranks;
  the release refactors A and the lifted end then falls.
"""
import copy
import os

import numpy as np
import pytest

from conftest import REPO, load_deck, run_hyperqn, write_deck
from hyperqn_tools.compare import relative_difference
from hyperqn_tools.output import Frame, read_iterations, read_pvd, read_summary
from test_pd import assert_energy_never_increases

CLAMP_BOX = {"min": [-0.01, -0.01, -0.01], "max": [0.01, 1.01, 1.01]}
EXACT_LINE = "exact local-global steps"


def run(tmp_path, name, deck, ranks=None):
    out = tmp_path / name
    proc = run_hyperqn([write_deck(tmp_path / f"{name}.yaml", deck), "-o", out], ranks=ranks)
    s = read_summary(out)
    assert s["status"] == "ok" and s["failed_frames"] == 0, proc.stdout[-2000:]
    return out, proc.stdout


def held_by_attachments(deck, stiffness):
    """The deck with its fixed region replaced by attachments of the same box."""
    soft = copy.deepcopy(deck)
    soft["attachments"] = [{"box": f["box"], "stiffness": stiffness} for f in soft.pop("fixed")]
    return soft


STIFFNESSES = (1.0e3, 1.0e4, 1.0e5, 1.0e6)  # N/m per vertex


def test_soft_clamp_approaches_the_fixed_bar(tmp_path):
    bar = load_deck("input/bar.yaml")
    bar["mesh"]["box"]["cells"] = [12, 3, 3]
    bar["time"]["frames"] = 10
    bar["solver"] = {"type": "lbfgs", "iterations": 200, "grad_rtol": 1.0e-8}
    clamped, _ = run(tmp_path, "clamped", bar)
    differences = {}
    for k in STIFFNESSES:
        soft, _ = run(tmp_path, f"soft_{k:g}", held_by_attachments(bar, k))
        differences[k] = relative_difference(clamped, soft)
    print("end frame, soft vs clamped (relative to the clamped sag): " +
          ", ".join(f"k = {k:g}: {rel:.3e} ({diff:.3e} m of {scale:.3e} m)" for k, (rel, diff, scale) in differences.items()))
    rel = [differences[k][0] for k in STIFFNESSES]
    assert differences[1.0e3][2] > 0.1, "the clamped bar should sag"
    assert all(a > b for a, b in zip(rel, rel[1:])), rel
    # Once the springs are much stiffer than the bar at the clamp, the difference goes like 1/k.
    assert rel[-1] < 0.2 * rel[-2] and rel[-1] < 0.05, rel


@pytest.fixture(scope="module")
def arap_attached(tmp_path_factory):
    """pd at 1 and 2 ranks and lbfgs with history 0 (unit steps) at 1 rank on the PD test's ARAP bar
    held by attachments: a stiff one at x = 0 and a moving one at x = 4."""
    tmp = tmp_path_factory.mktemp("arap_attached")
    deck = held_by_attachments(load_deck("tests/decks/pd_arap.yaml"), 1.0e7)  # h^2 k dominates A there
    deck["attachments"].append({"box": {"min": [3.99, -0.01, -0.01], "max": [4.01, 1.01, 1.01]}, "stiffness": 2.0e3,
                                "motion": {"translate": {"velocity": [0, 0.5, 0]}}})
    lbfgs = copy.deepcopy(deck)
    lbfgs["solver"] = {**deck["solver"], "type": "lbfgs", "history": 0, "line_search": "unit"}
    return {"pd_np1": run(tmp, "pd_np1", deck, ranks=1), "pd_np2": run(tmp, "pd_np2", deck, ranks=2),
            "lbfgs0": run(tmp, "lbfgs0", lbfgs, ranks=1)}


def test_pd_stays_exact_with_attachments(arap_attached):
    outdir, log = arap_attached["pd_np1"]
    assert EXACT_LINE in log
    # Unit local-global steps never increase g (they would with a matrix too soft for the springs).
    assert_energy_never_increases(read_iterations(outdir))
    rel, diff, scale = relative_difference(outdir, arap_attached["lbfgs0"][0])
    print(f"pd vs lbfgs (history 0): {rel:.3e} of the largest displacement {scale:.3e}")
    assert scale > 1e-2, "the bar should move"
    assert rel <= 1e-9, f"pd and lbfgs (history 0) positions differ by {rel:.3e}"


def test_pd_with_attachments_parallel_matches_serial(arap_attached):
    rel, _, _ = relative_difference(arap_attached["pd_np1"][0], arap_attached["pd_np2"][0])
    assert rel <= 1e-8, f"pd at 1 vs 2 ranks differs by {rel:.3e}"


def mean_end_height(frame):
    rest = frame.points - frame.displacement
    end = rest[:, 0] > rest[:, 0].max() - 1e-9
    return frame.displacement[end, 1].mean()


@pytest.mark.parametrize("ranks", [1, 2])
def test_example_deck_lifts_then_releases(tmp_path, ranks):
    # input/contact/bar_attached.yaml on a coarser mesh, to just past the release at t = 1.5.
    deck = load_deck("input/contact/bar_attached.yaml")
    deck["mesh"]["box"]["cells"] = [12, 3, 3]
    deck["time"]["frames"] = 54
    out, log = run(tmp_path, "attached", deck, ranks=ranks)
    s = read_summary(out)
    assert s["frames"] == 54 and s["fixed_vertices"] == 0
    assert s["factorizations"] == 2, "the release refactors M + h^2 L"
    assert log.count("attachment(s) gone") == 1
    frames = read_pvd(out / "attached.pvd")
    times = [t for t, _ in frames]
    held = Frame(frames[times.index(min(times, key=lambda t: abs(t - 1.5)))][1])
    last = Frame(frames[-1][1])
    lifted, fallen = mean_end_height(held), mean_end_height(last)
    print(f"{ranks} rank(s): free end {lifted:+.3f} m while lifted, {fallen:+.3f} m 0.3 s after the release")
    assert lifted > 0.05, "the moving attachment lifts the free end"
    assert fallen < lifted - 0.1, "released, the free end falls"


@pytest.mark.parametrize("ranks", [1, 2])
def test_example_deck_runs(tmp_path, ranks):
    out, _ = run(tmp_path, "full", load_deck("input/contact/bar_attached.yaml"), ranks=ranks)
    s = read_summary(out)
    assert s["frames"] == 60 and s["factorizations"] == 2


def test_attachment_on_vertices_freed_later_is_accepted(tmp_path):
    # Attached vertices that are also fixed are refused only when they stay fixed (test_bad_input):
    # here the clamp lets go at t = 0.05 and the attachment holds the end from then on.
    bar = load_deck("input/bar.yaml")
    bar["mesh"]["box"]["cells"] = [8, 2, 2]
    bar["time"]["frames"] = 4
    bar["fixed"] = [{"box": CLAMP_BOX, "release": 0.05}]
    bar["attachments"] = [{"box": CLAMP_BOX, "stiffness": 1.0e5}]
    out, _ = run(tmp_path, "freed", bar)
    assert read_summary(out)["factorizations"] == 2, "the release refactors M + h^2 L"
