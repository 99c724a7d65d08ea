"""Bodies that break by their strain (docs/snapping.md), end to end: ropes
holding a swinging cube snap in the frame after their strain first exceeds the deck's threshold;
mass is unchanged exactly; 1, 2 and 4 ranks snap the same segments in the same frames; a run
killed (kill -9) after snaps and restarted equals the uninterrupted run bit for bit; with
self-contact, a cube whose rope snaps lands on a slab below it (without, it falls through), at 1
and 2 ranks alike and bitwise across a restart; bad thresholds are refused; a deck whose strands
do not snap runs no topology code."""
import copy
import csv

import numpy as np
import pytest

from conftest import event_count, run_deck, run_hyperqn, write_deck
from hyperqn_tools.energy import lumped_masses
from hyperqn_tools.intersections import check_run
from hyperqn_tools.output import Frame, final_frame, frame_list, read_checkpoint, read_iterations, read_summary, rest_diagonal
from test_bad_input import assert_deck_refused
from test_checkpoint_faults import assert_restart_after_signal_in_a_changing_frame_is_bitwise, first_changing_frame, killed

# Newton, converged to round-off: the rank test compares positions to 1e-8 of the diagonal.
TIGHT = {"type": "newton", "iterations": 50, "grad_rtol": 1e-12, "grad_atol": 0}
SNAP = 0.1
DENSITY, LINEAR_DENSITY = 1100, 0.05

# A 0.2 m cube (8.8 kg) on two ropes of 10 segments (from (0, 0, 0) and (0, 0, 0.3) to the centre
# of its face x = 1), released with the ropes horizontal: swinging down, the tension grows towards
# 3 mg; one rope snaps, then the other, which then holds it all (input/topology/rope_snap.yaml, smaller).
ROPE = {
    "mesh": {"box": {"size": [0.2, 0.2, 0.2], "cells": [2, 2, 2]},
             "transform": {"translate": [1.0, -0.1, -0.1]},
             "strands": [{"from": [0, 0, 0], "to": [1, 0, 0], "segments": 10},
                         {"from": [0, 0, 0.3], "to": [1, 0, 0], "segments": 10}]},
    "material": {"model": "neohookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.4, "density": DENSITY},
    "strand_material": {"axial_stiffness": 1.0e3, "linear_density": LINEAR_DENSITY, "snap": {"strain": SNAP}},
    "fixed": [{"box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 0.01, 0.01]}},
              {"box": {"min": [-0.01, -0.01, 0.29], "max": [0.01, 0.01, 0.31]}}],
    "gravity": [0, -9.81, 0],
    "time": {"dt": 1 / 60, "frames": 40},
    "solver": TIGHT,
}


def frames(out):
    return [Frame(path) for _, _, path in frame_list(out)]


def strains(frame):
    """Each strand segment's strain l/L - 1 (L from the rest positions, points - displacement)."""
    seg = frame.cells["line"]
    x, X = frame.points, frame.points - frame.displacement
    return np.linalg.norm(x[seg[:, 1]] - x[seg[:, 0]], axis=1) / np.linalg.norm(X[seg[:, 1]] - X[seg[:, 0]], axis=1) - 1


def masses(frame):
    """hyperqn's lumped masses: the tets' quarters and half of each segment's mass to each end."""
    X = frame.points - frame.displacement
    m = lumped_masses(X, frame.cells["tetra"], DENSITY)
    seg = frame.cells["line"]
    half = 0.5 * LINEAR_DENSITY * np.linalg.norm(X[seg[:, 1]] - X[seg[:, 0]], axis=1)
    np.add.at(m, seg[:, 0], half)
    np.add.at(m, seg[:, 1], half)
    return m


@pytest.fixture(scope="module")
def rope(tmp_path_factory):
    return run_deck(tmp_path_factory.mktemp("rope"), "rope", ROPE)


def test_rope_snaps_in_the_frame_after_its_strain_exceeds_the_threshold(rope):
    out, s = rope
    fs = frames(out)
    over = [k for k, f in enumerate(fs) if strains(f).max() > SNAP]
    assert over, "the rope never stretched past the threshold"
    first = over[0]
    counts = [len(f.points) for f in fs]
    # frame `first` is written before the break; the break is made at the start of the next step
    assert all(c == counts[0] for c in counts[: first + 1]) and counts[first + 1] > counts[0]
    assert s["breaks"]["segments_snapped"] >= 1 and s["breaks"]["vertices_added"] == counts[-1] - counts[0]
    # Newton factors no constant matrix: no step with snaps counts a correction or a refactorization
    assert s["breaks"]["refactorizations"] == s["breaks"]["h0_corrections"] == 0 and s["factorizations"] == 0
    # the segment most over the threshold in that frame is the one that came apart: it has a
    # vertex of its own (an id after the input's) at its end that had a neighbour
    worst = int(np.argmax(strains(fs[first])))
    seg = fs[-1].cells["line"]
    assert (fs[-1].vertex_id[seg[worst]] >= counts[0]).any()
    assert counts[first + 1] == counts[0] + 1  # one segment per step
    assert s["breaks"]["segments_snapped"] == 2  # then the other rope, in a later frame
    assert len(set(counts)) == 3
    # the cube flies off: at the end it is far from where the rope would hold it
    assert np.linalg.norm(fs[-1].points[fs[-1].cells["tetra"]].mean(axis=(0, 1))) > 1.1


def test_total_mass_is_unchanged_exactly(rope):
    out, _ = rope
    fs = frames(out)
    m0, m1 = masses(fs[0]).sum(), masses(fs[-1]).sum()
    assert len(fs[-1].points) > len(fs[0].points)
    assert abs(m1 - m0) <= 1e-14 * m0 and abs(m0 - (DENSITY * 0.008 + LINEAR_DENSITY * (1 + np.hypot(1, 0.3)))) <= 1e-12 * m0


def test_the_midpoint_ends_by_euler_where_a_recoiling_rope_would_reverse_a_segment(tmp_path):
    """With the implicit midpoint, a rope recoiling after a snap: where the end map would turn a
    segment through 90 degrees or more from the midpoint z (it passed through zero length, the kink
    of l = |x_b - x_a|), the step ends by implicit Euler from z, as for a tet it would invert
    (docs/method.md). The same rope that does not snap swings calmly: no step is completed so, and
    its energy balance closes (energy.csv's residual: measured 0.0996 J, 0.6 % of the largest
    stored energy). A snap adds no energy: the snapped segment lets go at both ends and keeps its
    spring, so it releases nothing at once (energy.csv's `released` 0 to round-off: measured at most
    2.8e-14 J, 3e-15 of the largest stored energy, 9.6 J: 1,601 J before the springs' energy test ended the recoil's
    energy-making steps by Euler as well); the recoil after it is the rope's motion."""
    deck = copy.deepcopy(ROPE)
    deck["time"]["integrator"] = "implicit-midpoint"
    deck["output"] = {"energy": True}
    out, s = run_deck(tmp_path, "snap", deck)
    assert s["breaks"]["segments_snapped"] > 0 and s["euler_completed_steps"] > 0
    with open(out / "energy.csv") as f:
        rows = list(csv.DictReader(f))
    steps = np.diff([float(r["released"]) for r in rows], prepend=0.0)
    with open(out / "topology.csv") as f:
        snaps = {int(r["frame"]) for r in csv.DictReader(f) if int(r["segments_snapped"]) > 0}
    stored = max(float(r["stored"]) for r in rows)
    print("released per snap (J):", [f"{steps[f]:.3e}" for f in sorted(snaps)], f"stored up to {stored:.4g} J")
    assert len(snaps) == s["breaks"]["segments_snapped"]
    assert np.abs(steps).max() <= 1e-12 * stored
    assert all(steps[f] == 0 for f in range(len(steps)) if f not in snaps)
    calm = copy.deepcopy(deck)
    calm["strand_material"]["snap"]["strain"] = 10.0
    out, s = run_deck(tmp_path, "calm", calm)
    assert s["breaks"]["segments_snapped"] == 0 and s["euler_completed_steps"] == 0
    with open(out / "energy.csv") as f:
        rows = list(csv.DictReader(f))
    assert max(abs(float(r["residual"])) for r in rows) <= 1e-2 * max(float(r["stored"]) for r in rows)


def test_snapping_with_the_midpoint_is_warned_of(tmp_path):
    deck = copy.deepcopy(ROPE)
    deck["time"] = {**deck["time"], "frames": 1}
    quiet = run_hyperqn([write_deck(tmp_path / "euler.yaml", deck), "-o", tmp_path / "euler"], ranks=None)
    deck["time"]["integrator"] = "implicit-midpoint"
    warned = run_hyperqn([write_deck(tmp_path / "midpoint.yaml", deck), "-o", tmp_path / "midpoint"], ranks=None)
    assert "warning" not in quiet.stdout
    assert "midpoint.yaml: time.integrator: implicit-midpoint does not damp" in warned.stdout


def test_a_deck_whose_strands_do_not_snap_runs_no_topology_code(tmp_path):
    plain = copy.deepcopy(ROPE)
    del plain["strand_material"]["snap"]
    plain["time"]["frames"] = 3
    log = tmp_path / "plain.log"
    run_hyperqn([write_deck(tmp_path / "plain.yaml", plain), "-o", tmp_path / "plain", "-log_view", f":{log}"], ranks=None)
    text = log.read_text()
    # PETSc lists an event only once it has run: absent is a count of 0 (the objective's is there)
    assert event_count(text, "hqnObjective") > 0 and event_count(text, "hqnTopology") == 0
    assert "breaks" not in read_summary(tmp_path / "plain")


@pytest.mark.parametrize("ranks", [2, 4])
def test_ranks_snap_the_same_segments_in_the_same_frames(rope, tmp_path, ranks):
    ref, s1 = rope
    out, s2 = run_deck(tmp_path, "rope", ROPE, ranks=ranks)
    assert s1["breaks"] == {**s2["breaks"], "topology_s": s1["breaks"]["topology_s"]}
    for a, b in zip(frames(ref), frames(out)):
        assert np.array_equal(a.vertex_id, b.vertex_id)
        assert np.abs(a.points - b.points).max() <= 1e-8 * rest_diagonal(a)


@pytest.mark.parametrize("ranks", [None, 2])
def test_restart_after_kill_after_snaps_is_bitwise(tmp_path, ranks):
    deck = copy.deepcopy(ROPE)
    deck["time"]["frames"] = 60
    deck["checkpoint"] = {"every": 36}
    ref, s = run_deck(tmp_path, "ref", deck, ranks=ranks)
    out = tmp_path / "killed"
    args = [write_deck(tmp_path / "killed.yaml", deck), "-o", out]
    killed(args[0], out, 45, ranks)  # SIGKILL, every rank, after frame 45: 36 is the last checkpoint
    saved = read_checkpoint(out / "checkpoints" / "checkpoint_36.h5")
    assert len(str(saved["breaks"]).split()) == 6  # the checkpoint was written after both snaps
    done = run_hyperqn(args + ["--restart", "latest"], ranks=ranks)
    assert "restart from" in done.stdout
    a, b = final_frame(ref), final_frame(out)
    assert np.array_equal(a.vertex_id, b.vertex_id)
    assert np.array_equal(a.points, b.points) and np.array_equal(a.velocity, b.velocity)
    strip = lambda rows: [{k: v for k, v in r.items() if k != "time_s"} for r in rows]
    assert strip(read_iterations(ref)) == strip(read_iterations(out))
    sb = read_summary(out)
    assert {k: v for k, v in s["breaks"].items() if k != "topology_s"} == {k: v for k, v in sb["breaks"].items() if k != "topology_s"}


@pytest.mark.parametrize("ranks", [None, 2])
def test_restart_after_a_signal_in_a_frame_that_began_with_a_snap_is_bitwise(rope, tmp_path, ranks):
    """Before, the restart snapped the segment again from the same state: the next one (2 snapped, 2
    vertices added in that frame against 1)."""
    frame = first_changing_frame(rope[0], "segments_snapped")
    assert_restart_after_signal_in_a_changing_frame_is_bitwise(tmp_path, ROPE, frame, ranks)


# A cube (8.8 kg) hanging from a rope of 5 segments, released at the rope's rest length above a
# fixed slab: its first stretch overshoots the static strain (0.086) towards twice it, so the rope
# snaps past 0.12 and the cube falls 0.3 m onto the slab. Strands have no self-contact surface
# (docs/self-contact.md); the cube and the slab do.
HANG = {
    "bodies": [
        {"name": "hanging",
         "mesh": {"box": {"size": [0.2, 0.2, 0.2], "cells": [2, 2, 2]}, "transform": {"translate": [-0.1, -0.7, -0.1]},
                  "strands": [{"from": [0, 0, 0], "to": [0, -0.5, 0], "segments": 5}]},
         "material": ROPE["material"],
         "strand_material": {"axial_stiffness": 1.0e3, "linear_density": LINEAR_DENSITY, "snap": {"strain": 0.12}},
         "fixed": [{"box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 0.01, 0.01]}}]},
        {"name": "slab",
         "mesh": {"box": {"size": [0.6, 0.1, 0.6], "cells": [3, 1, 3]}, "transform": {"translate": [-0.3, -1.1, -0.3]}},
         "material": {"model": "neohookean", "youngs_modulus": 1.0e6, "poisson_ratio": 0.3, "density": 1000},
         "fixed": [{"box": {"min": [-0.31, -1.11, -0.31], "max": [0.31, -1.09, 0.31]}}]},
    ],
    "contact": {"model": "barrier", "self": True},
    "gravity": [0, -9.81, 0],
    "time": {"dt": 1 / 60, "frames": 40},
    "solver": TIGHT,
}
SLAB_TOP = -1.0


def lowest_cube_point(frame):
    """The lowest y of the hanging body's tets (its vertices come first: ids below the slab's)."""
    tets = frame.cells["tetra"]
    cube = tets[(frame.vertex_id[tets] < 27).all(axis=1)]  # the 3 x 3 x 3 vertices of its box
    return frame.points[cube.ravel(), 1].min()


def test_a_cube_whose_rope_snaps_lands_on_a_slab_with_self_contact(tmp_path):
    lowest, crossings = {}, {}
    for self_contact in (True, False):
        deck = copy.deepcopy(HANG)
        deck["solver"] = {"type": "lbfgs"}
        if not self_contact:
            del deck["contact"]
        out, s = run_deck(tmp_path, f"self_{self_contact}", deck)
        assert s["breaks"]["segments_snapped"] == 1
        crossings[self_contact] = [row["intersecting_pairs"] for row in check_run(out)]
        lowest[self_contact] = lowest_cube_point(frames(out)[-1])
    print("intersecting pairs per frame, with and without self-contact:", crossings, "lowest cube point:", lowest)
    assert max(crossings[True]) == 0 and SLAB_TOP < lowest[True] < SLAB_TOP + 0.02  # resting on the slab
    assert max(crossings[False]) > 0 and lowest[False] < SLAB_TOP - 0.5  # fell through it


def test_ranks_agree_when_a_rope_snaps_with_self_contact(tmp_path):
    one, s1 = run_deck(tmp_path, "one", HANG)
    two, s2 = run_deck(tmp_path, "two", HANG, ranks=2)
    assert s1["breaks"]["segments_snapped"] == 1
    assert s1["breaks"] == {**s2["breaks"], "topology_s": s1["breaks"]["topology_s"]}
    for a, b in zip(frames(one), frames(two)):
        assert np.array_equal(a.vertex_id, b.vertex_id)
        assert np.abs(a.points - b.points).max() <= 1e-8 * rest_diagonal(a)  # measured 2.8e-11


def test_restart_after_kill_after_a_snap_is_bitwise_with_self_contact(tmp_path):
    deck = copy.deepcopy(HANG)
    deck["checkpoint"] = {"every": 20}
    ref, _ = run_deck(tmp_path, "ref", deck, ranks=2)
    out = tmp_path / "killed"
    args = [write_deck(tmp_path / "killed.yaml", deck), "-o", out]
    killed(args[0], out, 30, 2)  # SIGKILL, every rank, after frame 30: 20 is the last checkpoint
    saved = read_checkpoint(out / "checkpoints" / "checkpoint_20.h5")
    assert len(str(saved["breaks"]).split()) == 3  # written after the snap
    run_hyperqn(args + ["--restart", "latest"], ranks=2)
    a, b = final_frame(ref), final_frame(out)
    assert np.array_equal(a.vertex_id, b.vertex_id)
    assert np.array_equal(a.points, b.points) and np.array_equal(a.velocity, b.velocity)


def bad(**changes):
    deck = copy.deepcopy(ROPE)
    deck["time"]["frames"] = 2
    for key, value in changes.items():
        deck[key] = value
    return deck


def snap(strain):
    return bad(strand_material={**ROPE["strand_material"], "snap": {"strain": strain}})


BAD_DECKS = {
    "negative_strain": (snap(-0.2), ["strand_material.snap.strain"]),
    "zero_strain": (snap(0.0), ["strand_material.snap.strain"]),
    "nan_strain": (snap(float("nan")), ["strand_material.snap.strain"]),
    "inf_strain": (snap(float("inf")), ["strand_material.snap.strain"]),
    "missing_strain": (bad(strand_material={**ROPE["strand_material"], "snap": {}}), ["strain"]),
    "negative_resolve": (bad(strand_material={**ROPE["strand_material"], "snap": {"strain": SNAP, "resolve": -1}}),
                         ["strand_material.snap.resolve"]),
    "fractional_resolve": (bad(strand_material={**ROPE["strand_material"], "snap": {"strain": SNAP, "resolve": 0.5}}),
                           ["strand_material.snap.resolve"]),
}


@pytest.mark.parametrize("case", sorted(BAD_DECKS))
def test_bad_snap_deck_is_refused(tmp_path, case):
    deck, fragments = BAD_DECKS[case]
    assert_deck_refused(tmp_path, case, deck, fragments)


# strand_material.snap.resolve: a step whose converged state has a segment over the threshold is
# solved again from its start with that segment snapped, up to N times. A cube (8.8 kg) hanging from
# two vertical ropes, released at their rest length: the first stretch overshoots the static strain
# (0.043 each) towards twice it; the ropes are symmetric, so both pass 0.06 in one step, and once one
# has snapped the other holds the whole weight (0.086 statically): over again.
PAIR = {**ROPE,
        "mesh": {"box": {"size": [0.2, 0.2, 0.2], "cells": [2, 2, 2]}, "transform": {"translate": [-0.1, -1.2, -0.1]},
                 "strands": [{"from": [-0.1, 0, 0], "to": [-0.1, -1, 0], "segments": 10},
                             {"from": [0.1, 0, 0], "to": [0.1, -1, 0], "segments": 10}]},
        "fixed": [{"box": {"min": [-0.11, -0.01, -0.01], "max": [-0.09, 0.01, 0.01]}},
                  {"box": {"min": [0.09, -0.01, -0.01], "max": [0.11, 0.01, 0.01]}}],
        "time": {"dt": 1 / 60, "frames": 14}}
PAIR_SNAP = 0.06


def pair(resolve):
    return {**PAIR, "strand_material": {**ROPE["strand_material"], "snap": {"strain": PAIR_SNAP, "resolve": resolve}}}


def added_per_frame(out):
    counts = [len(f.points) for f in frames(out)]
    return [c - counts[0] for c in counts]


@pytest.fixture(scope="module")
def resolving_pair(tmp_path_factory):
    return run_deck(tmp_path_factory.mktemp("pair"), "pair", pair(2))


def test_a_resolved_step_snaps_until_no_segment_is_over(resolving_pair, tmp_path):
    out, s = resolving_pair
    plain, _ = run_deck(tmp_path, "plain", pair(0))
    once, _ = run_deck(tmp_path, "once", pair(1))
    over = [strains(f).max() > PAIR_SNAP for f in frames(plain)]
    first = over.index(True)  # the plain run's first frame with a segment over: it snaps at the next step's start
    print("vertices added per frame, resolve 0/1/2:", added_per_frame(plain), added_per_frame(once), added_per_frame(out))
    assert added_per_frame(plain)[first] == 0 and added_per_frame(plain)[first + 1] == 1
    assert added_per_frame(plain)[first + 2] == 2  # the other rope, one step later
    # resolve 2: both ropes snap in the step that first went over, one segment per re-solve
    assert added_per_frame(out)[first - 1] == 0 and added_per_frame(out)[first] == 2
    assert s["breaks"]["segments_snapped"] == 2
    # after a step with fewer re-solves than allowed no segment is over; resolve 1 leaves the second
    # rope over at the end of that step (written), and it snaps at the next step's start
    assert all(strains(f).max() <= PAIR_SNAP for f in frames(out))
    assert added_per_frame(once)[first] == 1 and added_per_frame(once)[first + 1] == 2
    assert strains(frames(once)[first]).max() > PAIR_SNAP
    # the frame's solve counts every solve's iterations
    rows = [r for r in read_iterations(out) if int(r["frame"]) == first]
    assert len({int(r["iteration"]) for r in rows}) < len(rows)  # the step solved three times over


@pytest.mark.parametrize("ranks", [2, 4])
def test_ranks_agree_on_a_resolved_snap(resolving_pair, tmp_path, ranks):
    ref, s1 = resolving_pair
    out, s2 = run_deck(tmp_path, "pair", pair(2), ranks=ranks)
    assert added_per_frame(ref) == added_per_frame(out)
    for a, b in zip(frames(ref), frames(out)):
        assert np.array_equal(a.vertex_id, b.vertex_id)
        assert np.abs(a.points - b.points).max() <= 1e-8 * rest_diagonal(a)


@pytest.mark.parametrize("ranks", [None, 2])
def test_restart_after_kill_after_resolved_snaps_is_bitwise(tmp_path, ranks):
    from test_checkpoint_faults import assert_restart_after_kill_is_bitwise

    # frame 9's step snaps both ropes (two batches); the checkpoint of 10 holds them, the kill comes after 12
    assert_restart_after_kill_is_bitwise(tmp_path, pair(2), ranks, frames=14, every=10, kill_after=12)
