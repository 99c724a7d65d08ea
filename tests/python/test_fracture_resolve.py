"""Fracture's re-solves (material.fracture.resolve, docs/topology.md#fracture), end to end, on the
edge-notched plate of test_fracture.py: with re-solves the crack runs further within one step
(several batches of faces in one frame); 1 and 2 ranks break the same faces in the same frames; a
run killed after a frame of several batches, or stopped by a signal during a re-solve, and
restarted equals the uninterrupted run bit for bit; a bad `resolve` is refused."""
import copy

import numpy as np
import pytest

from conftest import run_deck, run_hyperqn, write_deck
from hyperqn_tools.output import final_frame, read_iterations, read_summary, rest_diagonal
from test_bad_input import assert_deck_refused
from test_checkpoint import assert_same_run
from test_checkpoint_faults import killed
from test_fracture import NOTCHED, crack_history, plate_mesh, pulled_plate
from test_topology_csv import rows


# test_fracture's notched plate with its notch at the other side (x > 0.7): the crack runs towards
# lower vertex numbers, so that each batch's copies are numbered differently from one batch of all
# the frame's faces (a restart must replay the batches as they were made).
NOTCHED_RIGHT = dict(cells=NOTCHED["cells"], notches={(i, 5) for i in range(7, 10)})


def plate(tmp_path, resolve, frames=24):
    deck = pulled_plate(plate_mesh(tmp_path / "notched.mesh", **NOTCHED_RIGHT), 1.1, frames=frames)
    deck["material"]["fracture"]["resolve"] = resolve
    return deck


def several_batches(table):
    """The frames whose start broke faces more than once (a step solved again after breaks)."""
    return [r["frame"] for r in table if r["h0_corrections"] + r["refactorizations"] > 1]


def test_the_crack_runs_further_within_a_step(tmp_path):
    once, s0 = run_deck(tmp_path, "once", plate(tmp_path, 0))
    again, s1 = run_deck(tmp_path, "again", plate(tmp_path, 10))
    a, b = rows(once), rows(again)
    most = lambda table: max(r["faces_separated"] for r in table)
    print(f"faces broken in one frame, at most: {most(a)} without re-solves, {most(b)} with; "
          f"frames with several batches: {several_batches(b)}")
    assert not several_batches(a) and several_batches(b)
    assert most(b) > most(a)
    # every re-solve is a solve of the whole step: the frame's iterations count them all
    assert s1["iterations"] > s0["iterations"] and s1["fracture"]["faces_broken"] > 0


def test_ranks_agree(tmp_path):
    deck = plate(tmp_path, 10)
    one, s1 = run_deck(tmp_path, "one", deck)
    two, s2 = run_deck(tmp_path, "two", deck, ranks=2)
    assert s2["ranks"] == 2 and several_batches(rows(one))
    counts = lambda table: [(r["frame"], r["faces_separated"], r["vertices_added"],
                             r["h0_corrections"] + r["refactorizations"]) for r in table]
    assert counts(rows(one)) == counts(rows(two))
    assert crack_history(one) == crack_history(two)
    a, b = final_frame(one), final_frame(two)
    assert np.array_equal(a.vertex_id, b.vertex_id)
    assert np.abs(a.points - b.points).max() <= 1e-8 * rest_diagonal(a)


@pytest.mark.parametrize("ranks", [None, 2])
def test_restart_after_a_kill_is_bitwise(tmp_path, ranks):
    deck = plate(tmp_path, 10)
    deck["checkpoint"] = {"every": 1}
    path = write_deck(tmp_path / "plate.yaml", deck)
    ref = tmp_path / "ref"
    run_hyperqn([path, "-o", ref], ranks=ranks)
    frame = several_batches(rows(ref))[0]
    out = tmp_path / "out"
    killed(path, out, frame + 1, ranks)  # its checkpoint holds a frame of several batches
    run_hyperqn([path, "-o", out, "--restart", "latest"], ranks=ranks)
    assert_same_run(ref, out)
    assert (out / "topology.csv").read_bytes() == (ref / "topology.csv").read_bytes()
    skip = lambda f: {k: v for k, v in f.items() if k != "topology_s"}
    assert skip(read_summary(ref)["fracture"]) == skip(read_summary(out)["fracture"])


def solve_lengths(out, frame):
    """The iterations of each solve of `frame` (iterations.csv: each solve counts from 0)."""
    its = [r["iteration"] for r in read_iterations(out) if r["frame"] == frame]
    starts = [k for k, i in enumerate(its) if i == 0] + [len(its)]
    return [starts[k + 1] - starts[k] - 1 for k in range(len(starts) - 1)]


def test_restart_after_a_signal_during_a_re_solve(tmp_path):
    # The signal stops a step's last re-solve: the checkpoint (of the frame before) holds the
    # breaks so far and how many re-solves were made, and the restart redoes that solve. The same
    # positions, velocities and topology.csv; iterations.csv lacks the frame's earlier solves.
    resolve = 1
    deck = plate(tmp_path, resolve)
    path = write_deck(tmp_path / "plate.yaml", deck)
    ref = tmp_path / "ref"
    run_hyperqn([path, "-o", ref])
    table = {r["frame"]: r for r in rows(ref)}
    batches = lambda f: table[f]["h0_corrections"] + table[f]["refactorizations"] if f in table else 0
    # A frame that reached its limit of re-solves with faces still overloaded (the next frame's
    # start broke them): a restart that counted its re-solves anew would solve it once more.
    # Its last re-solve is longer than its solves before: a signal after one more iteration than
    # those comes in it (the hook counts each solve's iterations anew).
    target = None
    for frame in sorted(table):
        lengths, after = solve_lengths(ref, frame), solve_lengths(ref, frame + 1)
        if (len(lengths) == resolve + 1 and lengths[-1] > max(lengths[:-1]) and after
                and batches(frame + 1) > len(after) - 1):
            target = frame, max(lengths[:-1]) + 1
            break
    assert target, "no re-solve to stop"
    out = tmp_path / "out"
    done = run_hyperqn([path, "-o", out, "-hyperqn_test_signal_in_frame", target[0],
                        "-hyperqn_test_signal_at_iteration", target[1]], check=False)
    assert done.returncode == 3, done.stdout[-2000:]
    run_hyperqn([path, "-o", out, "--restart", "latest"])
    a, b = final_frame(ref), final_frame(out)
    assert np.array_equal(a.vertex_id, b.vertex_id)
    assert np.array_equal(a.points, b.points) and np.array_equal(a.velocity, b.velocity)
    assert (out / "topology.csv").read_bytes() == (ref / "topology.csv").read_bytes()


BAD = {
    "negative_resolve": ({"resolve": -1}, ["material.fracture.resolve", ">= 0"]),
    "fractional_resolve": ({"resolve": 1.5}, ["material.fracture.resolve"]),
    "word_resolve": ({"resolve": "yes"}, ["material.fracture.resolve"]),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_resolve_is_refused(tmp_path, case):
    fracture, fragments = BAD[case]
    deck = plate(tmp_path, 0, frames=2)
    deck["material"]["fracture"].update(fracture)
    assert_deck_refused(tmp_path, case, deck, fragments)
