"""The Newton baseline end to end on tests/decks/newton_box.yaml: quadratic convergence with the
exact Hessian; the default (PSD-projected Hessian, MUMPS Cholesky) giving the same positions at
1 and 2 ranks with one symbolic factorization per run; cg-amg and ntr converging to the same
answer."""
import os
from collections import defaultdict

import numpy as np
import pytest

from conftest import event_count, run_at_1_and_2_ranks, REPO, load_deck, run_hyperqn, write_deck
from hyperqn_tools.compare import relative_difference
from hyperqn_tools.output import read_iterations, read_summary

DECK = "tests/decks/newton_box.yaml"


def grad_norms_by_frame(outdir):
    """{frame: array of |grad g| at iterations 0, 1, ...}"""
    frames = defaultdict(list)
    for row in read_iterations(outdir):
        frames[row["frame"]].append(row["grad_norm"])
    return {f: np.array(g) for f, g in frames.items()}



def test_quadratic_convergence_with_exact_hessian(tmp_path):
    # Without the PSD fix the Hessian is exact, so Newton must converge quadratically. (With the
    # fix it converges linearly wherever the projection is active near the solution; see docs/method.md, "Newton".)
    outdir = tmp_path / "exact"
    deck = load_deck(DECK)
    deck["solver"]["newton_hessian"] = "exact"
    run_hyperqn([write_deck(tmp_path / "exact.yaml", deck), "-o", outdir], ranks=1)
    s = read_summary(outdir)
    assert s["status"] == "ok" and s["frames"] == 2 and s["converged_frames"] == 2
    C = 1e3  # stated constant: r_{k+1} <= C r_k^2 for r = |grad g| / |grad g(x0)|
    for frame, g in grad_norms_by_frame(outdir).items():
        r = g / g[0]
        print(f"frame {frame}: |grad g| = " + ", ".join(f"{x:.3e}" for x in g))
        assert r[-1] <= 1e-12, f"frame {frame} did not converge: {r}"
        # The final phase: from r <= 1e-3 on, down to the round-off floor (r ~ 1e-15).
        pairs = [(a, b) for a, b in zip(r, r[1:]) if a <= 1e-3 and b >= 1e-14]
        assert len(pairs) >= 2, f"frame {frame}: final phase too short: {r}"
        # Deep enough that a linear rate would have to contract by C * 1e-4 = 0.1 or better to pass.
        assert min(a for a, _ in pairs) <= 1e-4
        for a, b in pairs:
            assert b <= C * a * a, f"frame {frame}: {a:.3e} -> {b:.3e} is not quadratic (C = {b / a**2:.3g})"


def test_projected_newton_converges(tmp_path):
    outdir = tmp_path / "projected"
    run_hyperqn([os.path.join(REPO, DECK), "-o", outdir], ranks=1)
    assert read_summary(outdir)["status"] == "ok"
    rows = read_iterations(outdir)
    for prev, cur in zip(rows, rows[1:]):
        if cur["frame"] == prev["frame"]:
            # Near convergence g changes by round-off only (an ulp of g is ~1e-16 |g|).
            assert cur["energy"] <= prev["energy"] * (1 + 1e-13), f"g increased: {prev} -> {cur}"
    for frame, g in grad_norms_by_frame(outdir).items():
        print(f"frame {frame}: |grad g| = " + ", ".join(f"{x:.3e}" for x in g))
        assert g.min() <= 1e-8 * g[0]


def moderate_deck(tmp_path, linear_solver="mumps", method="nls"):
    """The box with dt = 0.1 s over 5 frames, solved to 1e-8 relative."""
    deck = load_deck(DECK)
    deck["time"] = {"dt": 0.1, "frames": 5}
    deck["solver"].update({"grad_rtol": 1.0e-8, "newton_method": method, "linear_solver": linear_solver})
    return write_deck(tmp_path / f"box_{method}_{linear_solver}.yaml", deck)


@pytest.fixture(scope="module")
def mumps_runs(tmp_path_factory):
    """{ranks: (outdir, PETSc log text)} for the default Newton (NLS + MUMPS) at 1 and 2 ranks."""
    tmp = tmp_path_factory.mktemp("newton")
    deck = moderate_deck(tmp)
    return run_at_1_and_2_ranks(deck, tmp)


def test_mumps_parallel_matches_serial(mumps_runs):
    rel, _, scale = relative_difference(mumps_runs[1][0], mumps_runs[2][0])
    assert scale > 0.1, "the box should sag visibly"
    assert rel <= 1e-8, f"1 vs 2 ranks differ by {rel:.3e} of the largest displacement"


@pytest.mark.parametrize("ranks", [1, 2])
def test_one_symbolic_factorization_per_run(mumps_runs, ranks):
    outdir, log_text = mumps_runs[ranks]
    s = read_summary(outdir)
    assert s["status"] == "ok" and s["converged_frames"] == s["frames"] == 5
    # One symbolic analysis for the whole run (the pattern never changes), one numeric
    # factorization per Newton iteration (NLS assembles the Hessian once per iteration).
    assert event_count(log_text, "MatCholFctrSym") == 1
    assert event_count(log_text, "MatCholFctrNum") == s["iterations"] > s["frames"]


@pytest.mark.parametrize("method,linear_solver", [("nls", "cg-amg"), ("ntr", "mumps"), ("ntr", "cg-amg")])
def test_variants_converge_to_the_same_answer(tmp_path, mumps_runs, method, linear_solver):
    outdir = tmp_path / "out"
    run_hyperqn([moderate_deck(tmp_path, linear_solver, method), "-o", outdir], ranks=2)
    s = read_summary(outdir)
    assert s["status"] == "ok" and s["converged_frames"] == s["frames"] == 5 and s["failed_frames"] == 0
    for frame, g in grad_norms_by_frame(outdir).items():
        assert g[-1] <= 1e-8 * g[0], f"frame {frame}: final |grad g| {g[-1]:.3e} from {g[0]:.3e}"
    rel, _, _ = relative_difference(mumps_runs[1][0], str(outdir))
    assert rel <= 1e-6, f"{method}/{linear_solver} differs from nls/mumps by {rel:.3e}"
