"""solver.h0_precision: single end to end on tests/decks/h0_box.yaml (solver.h0: laplacian): lbfgs
with the factor's values in floats reaches the double factor's converged answer at 1 and 2 ranks
(supernodal at 1, split and the gathered supernodal at 2), the same at both to round-off, in about
as many iterations; it repeats bit for bit at 2 ranks, a run killed and restarted equals the
uninterrupted one bit for bit at 1 and 2 ranks, rest-stiffness (the full matrix, one column) works
too, and the combinations it cannot serve are deck errors."""
import copy

import numpy as np
import pytest

from conftest import load_deck, run_hyperqn, write_deck
from hyperqn_tools.compare import relative_difference
from hyperqn_tools.output import final_frame, read_summary
from test_bad_input import assert_clean_failure, assert_deck_refused
from test_checkpoint import assert_same_run
from test_checkpoint_faults import assert_restart_after_kill_is_bitwise
from test_h0 import iterations

DECK = "tests/decks/h0_box.yaml"
# Both precisions converge to grad_rtol 1e-10 along paths that part at the first iteration (H0
# differs by about 1e-7): the answers agree to the solve's tolerance, relative to the largest
# displacement, as amg's do (test_h0.py's AMG_TOLERANCE).
TOLERANCE = 1e-9


def deck_of(precision, h0="laplacian"):
    deck = load_deck(DECK)
    deck["solver"]["h0"] = h0
    deck["solver"]["h0_precision"] = precision
    return deck


def run(tmp_path, name, deck, ranks=1, extra=()):
    out = tmp_path / name
    run_hyperqn([write_deck(tmp_path / f"{name}.yaml", deck), "-o", out, *extra], ranks=ranks)
    s = read_summary(out)
    assert s["status"] == "ok" and s["converged_frames"] == s["frames"] == 3, s
    return out, s


@pytest.mark.parametrize("h0", ["laplacian", "rest-stiffness"])
def test_single_reaches_the_double_answer(tmp_path, h0):
    double, sd = run(tmp_path, "double", deck_of("double", h0))
    single1, s1 = run(tmp_path, "single_np1", deck_of("single", h0))
    single2, s2 = run(tmp_path, "single_np2", deck_of("single", h0), ranks=2)
    gathered, sg = run(tmp_path, "single_gathered", deck_of("single", h0), ranks=2,
                       extra=["-hyperqn_h0_package", "supernodal"])
    assert (s1["h0_package"], s2["h0_package"], sg["h0_package"]) == ("supernodal", "split", "supernodal")
    to_double, _, _ = relative_difference(double, single1)
    ranks, _, _ = relative_difference(single1, single2)
    ranks_gathered, _, _ = relative_difference(single1, gathered)
    print(f"{h0}: single vs double {to_double:.2e}, 1 vs 2 ranks {ranks:.2e} (gathered {ranks_gathered:.2e}); "
          f"iterations double {iterations(double)}, single {iterations(single1)}, {iterations(single2)} at 2 ranks")
    assert to_double <= TOLERANCE and ranks <= TOLERANCE and ranks_gathered <= TOLERANCE
    # The floats are used: the paths part (the same answer, not the same bits).
    assert not np.array_equal(final_frame(double).points, final_frame(single1).points)
    assert abs(iterations(single1) - iterations(double)) <= 0.1 * iterations(double)


def test_single_repeats_bitwise_at_2_ranks(tmp_path):
    a, _ = run(tmp_path, "a", deck_of("single"), ranks=2)
    b, _ = run(tmp_path, "b", deck_of("single"), ranks=2)
    assert_same_run(a, b)


@pytest.mark.parametrize("ranks", [1, 2])
def test_single_restart_after_a_kill_is_bitwise(tmp_path, ranks):
    # The floats are rounded from the factor of the rest shape's matrix, so a restart rebuilds them
    # bit for bit: a run killed (SIGKILL, every rank) after frame 4's checkpoint and restarted
    # equals the uninterrupted one in positions, velocities, iterations and the .pvd.
    assert_restart_after_kill_is_bitwise(tmp_path, deck_of("single"), ranks)


BAD = {
    # pd's steps are exact solves with M + h^2 L
    "pd_single": ({"type": "pd", "h0_precision": "single"}, ["solver.h0_precision", "single is for lbfgs", "pd"]),
    # a V-cycle has no factor to round
    "amg_single": ({"type": "lbfgs", "h0": "amg", "h0_precision": "single"},
                   ["solver.h0_precision", "h0: amg factors nothing"]),
    "half": ({"type": "lbfgs", "h0_precision": "half"}, ["solver.h0_precision", "double, single"]),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_precision(tmp_path, case):
    solver, fragments = BAD[case]
    deck = load_deck(DECK)
    deck["solver"] = solver
    assert_deck_refused(tmp_path, case, deck, fragments)


@pytest.mark.parametrize("package", ["mumps", "cholmod"])
def test_single_needs_hyperqns_own_solve(tmp_path, package):
    path = write_deck(tmp_path / "single.yaml", deck_of("single"))
    out = tmp_path / "out"
    proc = run_hyperqn([path, "-o", out, "-hyperqn_h0_package", package], check=False, timeout=60)
    assert_clean_failure(proc, out, ["-hyperqn_h0_package", "solver.h0_precision: single", "auto, supernodal or split"])
    assert proc.returncode == 1
