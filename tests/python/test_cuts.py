"""Scripted cuts (deck cuts:, docs/topology.md), end to end: the bar sliced by a blade; mass,
momentum and energy across cuts; 1, 2 and 4 ranks with the cut crossing the partition boundary;
H0 follows the cuts by TopologyH0's corrections on one rank (checked against fresh factorizations
in the run); a restart after cuts, and after a kill, equals the uninterrupted run bit for bit; a
deck without cuts runs no topology code; bad cut decks are refused."""
import copy
import csv
import os
import re

import numpy as np
import pytest

from conftest import event_count, run_deck, run_hyperqn, write_deck
from hyperqn_tools.energy import frame_lumped_masses as lumped_masses, neohookean_energies
from hyperqn_tools.output import Frame, final_frame, frame_list, read_iterations, read_summary, rest_diagonal
from test_bad_input import assert_deck_refused
from test_checkpoint import assert_same_run
from test_checkpoint_faults import assert_restart_after_kill_is_bitwise, killed

TIGHT = {"type": "lbfgs", "iterations": 300, "max_iterations": 300, "grad_rtol": 1e-12, "grad_atol": 0}
MATERIAL = {"model": "neohookean", "youngs_modulus": 5.0e5, "poisson_ratio": 0.3, "density": 1000}

# A bar clamped at x = 0 under gravity; a blade comes down through it at x = 1.02, next to the
# plane x = 1 where the box is cut between 2 ranks (and 4), so the faces it separates lie on the
# partition boundary.
BAR = {
    "mesh": {"box": {"size": [2.0, 0.5, 0.5], "cells": [8, 2, 2]}},
    "material": MATERIAL,
    "fixed": [{"box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 0.51, 0.51]}}],
    "gravity": [0, -9.81, 0],
    "cuts": [{"center": [1.02, 1.0, 0.25], "normal": [1, 0, 0], "axis": [0, 1, 0], "size": [0.6, 1.0],
              "motion": {"translate": {"velocity": [0, -8, 0]}, "start": 0.02, "end": 0.3}}],
    "time": {"dt": 0.02, "frames": 16},
    "solver": TIGHT,
}

# A free body spinning about z and translating along x (a fixed region that moves so and is
# released at t = 0.1, all but its last layer of vertices), no gravity, implicit midpoint; a
# blade in the plane y = 0.2 (through the spin axis) sweeps down through it along z.
SPINNING = {
    "mesh": {"box": {"size": [1.0, 0.4, 0.4], "cells": [5, 4, 4]}},
    "material": MATERIAL,
    "fixed": [{"box": {"min": [-0.01, -0.01, -0.01], "max": [0.81, 0.41, 0.41]}, "release": 0.1,
               "motion": {"rotate": {"axis": [0, 0, 1], "center": [0.5, 0.2, 0.2], "rate": 40},
                          "translate": {"velocity": [0.5, 0, 0]}}}],
    "gravity": [0, 0, 0],
    "cuts": [{"center": [0.5, 0.2, 0.9], "normal": [0, 1, 0], "axis": [1, 0, 0], "size": [3.0, 0.4],
              "motion": {"translate": {"velocity": [0, 0, -4]}, "start": 0.1, "end": 0.5}}],
    "time": {"dt": 0.02, "frames": 24, "integrator": "implicit-midpoint"},
    "solver": TIGHT,
}


def piece_labels(frame):
    """The piece of each tet of the frame's mesh (tets joined through shared vertices)."""
    tets = frame.cells["tetra"]
    parent = np.arange(len(frame.points))

    def root(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i
    for t in tets:
        r = [root(v) for v in t]
        for x in r[1:]:
            parent[root(x)] = root(r[0])
    return np.array([root(t[0]) for t in tets])


def components(frame):
    """The number of pieces of the frame's mesh."""
    return len(set(piece_labels(frame)))


def test_bar_is_sliced_apart(tmp_path):
    out, s = run_deck(tmp_path, "bar", BAR)
    assert s["cuts"]["faces_separated"] >= 8 and s["cuts"]["vertices_added"] > 0
    # One rank, supernodal: every step with separations corrects H0 (no refactorization).
    assert s["cuts"]["h0_corrections"] >= 2 and s["cuts"]["refactorizations"] == 0 and s["factorizations"] == 1
    first, last = Frame(frame_list(out)[0][2]), final_frame(out)
    assert len(last.points) == len(first.points) + s["cuts"]["vertices_added"] == s["vertices"]
    assert components(first) == 1 and components(last) == 2
    # Mass: the same tets, so the same total (each copy has exactly its own tets' quarters).
    m0, m1 = lumped_masses(first, 1000).sum(), lumped_masses(last, 1000).sum()
    assert abs(m1 - m0) <= 1e-14 * m0 and abs(m0 - 1000 * 2.0 * 0.5 * 0.5) <= 1e-12 * m0
    # The fragment beyond the cut falls: it is apart from the clamped part at the cut.
    x = last.points
    near_cut = np.abs((x - last.displacement)[:, 0] - 1.0) < 1e-9
    assert near_cut.sum() > 9  # both sides' vertices at the cut (9 of the box, plus copies)
    assert np.ptp(x[near_cut, 1]) > 0.05


# A cleaver: a thin blade in the plane x = 1.02 from the bar's axis (y = z = 0.25) to y = 0.55,
# turning 60 degrees about the axis (the blade's normal) while the bar hangs, in the rest frame; its
# arc and its last position run through the cells of the bar's section (4 x 4 cells here).
PIVOT, REACH, TURN = np.array([0.25, 0.25]), 0.3, 60  # (y, z), m, degrees
CLEAVER = {"center": [1.02, 0.25 + REACH / 2, 0.25], "normal": [1, 0, 0], "axis": [0, 1, 0], "size": [REACH, 0.02],
           "frame": "rest", "motion": {"rotate": {"axis": [1, 0, 0], "center": [1.02, 0.25, 0.25], "rate": TURN / 0.28},
                                       "start": 0.02, "end": 0.3}}


def swept_by_cleaver(q, turn_deg):
    """Whether the point q = (y, z) of the blade's plane lies under the cleaver as it turns by
    0..turn_deg about the pivot: the point turned back by some angle in that range (sampled every
    0.01 degree, not the simulator's 1-degree chords) lies in the blade's rectangle."""
    rel = q - PIVOT
    for theta in np.radians(np.arange(0, turn_deg + 1e-9, 0.01)):
        c, s = np.cos(theta), np.sin(theta)
        y, z = c * rel[0] + s * rel[1], -s * rel[0] + c * rel[1]
        if 0 <= y <= REACH and abs(z) <= 0.01:
            return True
    return False


def test_a_turning_blade_cuts_the_faces_it_swept(tmp_path):
    """A blade turns in its plane (rotate about its normal): the faces whose dual edge crosses the
    plane in the sector it swept separate, counted independently here from the rest mesh; the
    copies of the cut vertices lie on that side of the pivot (a turn about +x takes +y towards +z);
    turning through 360 degrees a blade reaching past the section's corners cuts the bar in two."""
    deck = copy.deepcopy(BAR)
    deck["mesh"]["box"]["cells"] = [8, 4, 4]
    deck["cuts"] = [CLEAVER]
    out, s = run_deck(tmp_path, "cleaver", deck)
    first, last = Frame(frame_list(out)[0][2]), final_frame(out)
    rest, tets = first.points - first.displacement, first.cells["tetra"]
    centroid = rest[tets].mean(axis=1)
    side = centroid[:, 0] > 1.02
    faces = {}
    for t, tet in enumerate(tets):
        for skip in range(4):
            faces.setdefault(tuple(sorted(np.delete(tet, skip))), []).append(t)
    expected = 0
    for pair in faces.values():
        if len(pair) == 2 and side[pair[0]] != side[pair[1]]:
            a, b = centroid[pair[0]], centroid[pair[1]]
            q = a + (1.02 - a[0]) / (b[0] - a[0]) * (b - a)
            expected += swept_by_cleaver(q[1:], TURN)
    print(f"turning blade: {s['cuts']['faces_separated']} faces separated, {expected} predicted")
    assert 0 < expected < 32 and s["cuts"]["faces_separated"] == expected
    copies = (last.points - last.displacement)[last.vertex_id >= len(first.points)]
    assert len(copies) == s["cuts"]["vertices_added"] > 0
    assert np.all(copies[:, 1] >= 0.25 - 1e-12) and np.all(copies[:, 2] >= 0.25 - 1e-12), copies
    assert components(last) == 1
    # the rest frame decides: the same faces at 2 ranks
    _, s2 = run_deck(tmp_path, "cleaver2", deck, ranks=2)
    assert {k: s2["cuts"][k] for k in ("faces_separated", "vertices_added")} == \
        {k: s["cuts"][k] for k in ("faces_separated", "vertices_added")}
    whole = copy.deepcopy(deck)
    whole["cuts"][0].update(center=[1.02, 0.45, 0.25], size=[0.4, 0.02])  # past the corners, 0.354 away
    whole["cuts"][0]["motion"]["rotate"]["rate"] = 360 / 0.28
    out, s = run_deck(tmp_path, "turned", whole)
    assert s["cuts"]["faces_separated"] == 32 and components(final_frame(out)) == 2


def test_a_deck_without_cuts_runs_no_topology_code(tmp_path):
    plain = {k: v for k, v in BAR.items() if k != "cuts"}
    plain["time"] = dict(BAR["time"], frames=3)
    logs = {}
    for name, deck in [("plain", plain), ("cut", BAR)]:
        log = tmp_path / f"{name}.log"
        run_hyperqn([write_deck(tmp_path / f"{name}.yaml", deck), "-o", tmp_path / name, "-log_view", f":{log}"], ranks=None)
        logs[name] = log.read_text()
    # PETSc lists an event only once it has run: absent is a count of 0 (the objective's is there)
    assert event_count(logs["plain"], "hqnObjective") > 0 and event_count(logs["plain"], "hqnTopology") == 0
    assert event_count(logs["cut"], "hqnTopology") == BAR["time"]["frames"] - 1
    assert "cuts" not in read_summary(tmp_path / "plain")


def momenta(frame, density):
    m = lumped_masses(frame, density)
    P = (m[:, None] * frame.velocity).sum(axis=0)
    L = (m[:, None] * np.cross(frame.points, frame.velocity)).sum(axis=0)
    return P, L


@pytest.mark.parametrize("frame", ["world", "rest"])
def test_spinning_body_keeps_momentum_and_energy_across_cuts(tmp_path, frame):
    deck = copy.deepcopy(SPINNING)
    deck["cuts"][0]["frame"] = frame
    deck["output"] = {"energy": True}
    out, s = run_deck(tmp_path, "spin", deck)
    assert s["cuts"]["faces_separated"] > 0 and s["cuts"]["vertices_added"] > 0
    frames = frame_list(out)
    released = [f for n, t, f in frames if t > 0.1 + 1e-9]
    P0, L0 = momenta(Frame(released[0]), 1000)
    last = final_frame(out)
    # In the rest frame the crack is the plane y = 0.2: two halves. In the world the body turns
    # under the blade and the crack is jagged (measured: 77 faces), but the crumbs it would cut
    # loose stay attached (docs/topology.md#scripted-cuts): two pieces too (31 before).
    assert components(last) == 2
    if frame == "rest":
        assert s["cuts"]["faces_separated"] == 2 * 5 * 4
    else:
        assert s["cuts"]["faces_separated"] > 2 * 5 * 4
    P1, L1 = momenta(last, 1000)
    assert np.linalg.norm(P1 - P0) <= 1e-10 * np.linalg.norm(P0)
    assert np.linalg.norm(L1 - L0) <= 1e-10 * np.linalg.norm(L0)
    # Energy: a cut keeps x and v, so it adds nothing; the midpoint then keeps kinetic + elastic
    # within 1% and it never rises above the energy before the first cut by more than that.
    E = []
    for f in released:
        k, e, _ = neohookean_energies(f, MATERIAL["youngs_modulus"], MATERIAL["poisson_ratio"], 1000, 0.0)
        E.append(k + e)
    assert max(E) <= E[0] * (1 + 1e-2) and min(E) >= E[0] * (1 - 1e-2)
    check_energy_csv_across_cuts(out, released)


def check_energy_csv_across_cuts(out, released):
    """energy.csv (output.energy) through the cuts: its kinetic and stored columns are the frames'
    own energies (the copies' split masses and the new connectivity), a cut releases nothing (its
    `released` column stays 0 to round-off), and its balance holds. With no
    loads, gravity or supports after the release, the residual stays where the release left it (a
    released region brings its kinetic energy in, docs/inelastic.md#energy-balance) up to the
    midpoint's error per step: measured 4.2e-4 of the total over the run, cut frames as others
    (2.2e-4 per frame at most, either way)."""
    with open(out / "energy.csv") as f:
        rows = {int(r["frame"]): r for r in csv.DictReader(f)}
    with open(out / "topology.csv") as f:
        cut_frames = {int(r["frame"]) for r in csv.DictReader(f) if int(r["faces_separated"]) > 0}
    numbers = [n for n, t, _ in frame_list(out) if t > 0.1 + 1e-9]
    assert cut_frames and cut_frames <= set(numbers), (cut_frames, numbers)
    residual0 = float(rows[numbers[0]]["residual"])
    for n, path in zip(numbers, released):
        k, e, _ = neohookean_energies(path, MATERIAL["youngs_modulus"], MATERIAL["poisson_ratio"], 1000, 0.0)
        r = rows[n]
        assert float(r["kinetic"]) == pytest.approx(k, rel=1e-9) and float(r["stored"]) == pytest.approx(e, rel=1e-9)
        assert float(r["gravity_work"]) == float(r["load_work"]) == 0
        assert abs(float(r["released"])) <= 1e-12 * (k + e)  # a cut keeps x, v, the tets and their masses' sum
        assert abs(float(r["residual"]) - residual0) <= 1e-3 * (k + e), (n, r)


@pytest.mark.parametrize("ranks", [2, 4])
def test_ranks_agree_with_the_cut_on_the_partition_boundary(tmp_path, ranks):
    one, s1 = run_deck(tmp_path, "one", BAR)
    many, sn = run_deck(tmp_path, f"np{ranks}", BAR, ranks=ranks)
    assert sn["ranks"] == ranks
    same = ["faces_separated", "vertices_added"]
    assert {k: s1["cuts"][k] for k in same} == {k: sn["cuts"][k] for k in same}
    # more ranks (the split factor) factor again at every step with separations, one rank corrects
    steps = s1["cuts"]["h0_corrections"] + s1["cuts"]["refactorizations"]
    assert sn["cuts"]["refactorizations"] == steps and sn["cuts"]["h0_corrections"] == 0
    assert sn["factorizations"] == 1 + steps and s1["factorizations"] == 1
    a, b = final_frame(one), final_frame(many)
    assert np.array_equal(a.vertex_id, b.vertex_id)
    assert np.abs(a.points - b.points).max() <= 1e-8 * rest_diagonal(a)
    # the cut's faces were on the boundary between ranks: tets of different ranks meet at x = 1
    rank_of = b.ranks
    x = (b.points - b.displacement)[b.cells["tetra"]].mean(axis=1)[:, 0]
    assert set(rank_of[x < 1]) != set(rank_of[x > 1])


@pytest.mark.parametrize("ranks", [None, 2])
def test_restart_after_cuts_is_bitwise(tmp_path, ranks):
    ref, _ = run_deck(tmp_path, "ref", BAR, ranks=ranks)
    out = tmp_path / "restarted"
    half = copy.deepcopy(BAR)
    half["time"]["frames"] = 10
    half["checkpoint"] = {"every": 10}
    run_hyperqn([write_deck(tmp_path / "half.yaml", half), "-o", out], ranks=ranks)
    from hyperqn_tools.output import read_checkpoint
    saved = read_checkpoint(out / "checkpoints" / "checkpoint_10.h5")
    assert "cuts" in saved  # the checkpoint was written after cuts
    # one rank: the restart replays the corrected batches from the uncut scene's factor
    assert saved["cuts_factored"] == (0 if ranks is None else len({f for f in saved["cuts"].split()[::3]}))
    done = run_hyperqn([write_deck(tmp_path / "ref.yaml", BAR), "-o", out, "--restart", "latest"], ranks=ranks)
    assert "restart from" in done.stdout
    a, b = final_frame(ref), final_frame(out)
    assert np.array_equal(a.vertex_id, b.vertex_id)
    assert np.array_equal(a.points, b.points) and np.array_equal(a.velocity, b.velocity)
    strip = lambda rows: [{k: v for k, v in r.items() if k != "time_s"} for r in rows]
    assert strip(read_iterations(ref)) == strip(read_iterations(out))
    sa, sb = read_summary(ref), read_summary(out)
    assert {k: v for k, v in sa["cuts"].items() if k != "topology_s"} == {k: v for k, v in sb["cuts"].items() if k != "topology_s"}


@pytest.mark.parametrize("ranks", [None, 2])
def test_restart_after_a_kill_after_cuts_is_bitwise(tmp_path, ranks):
    # Checkpoints every 3 frames, killed (SIGKILL) after frame 10: the last checkpoint (9) comes
    # after several steps with separations, all corrected on one rank.
    ref, out = assert_restart_after_kill_is_bitwise(tmp_path, BAR, ranks, frames=BAR["time"]["frames"], every=3,
                                                    kill_after=10)
    sa, sb = read_summary(ref), read_summary(out)
    assert {k: v for k, v in sa["cuts"].items() if k != "topology_s"} == {k: v for k, v in sb["cuts"].items() if k != "topology_s"}
    assert sa["cuts"]["h0_corrections"] >= (2 if ranks is None else 0)


def test_size_trigger_factors_again_and_a_restart_replays_from_there(tmp_path):
    # A size trigger of 8 rows: the bar's 4 steps with separations touch 5, 12, 6 and 11 rows since
    # the last factorization, so they go corrected, factored, corrected, factored. The checkpoint at
    # frame 6 holds 3 batches, the scene of the first 2 factored: the restart factors that scene and
    # replays the third batch as a correction, and then equals the uninterrupted run bit for bit.
    trigger = ["-hyperqn_test_topology_h0_max_touched", "8"]
    deck = copy.deepcopy(BAR)
    deck["checkpoint"] = {"every": 3}
    path = write_deck(tmp_path / "bar.yaml", deck)
    ref = tmp_path / "ref"
    proc = run_hyperqn([path, "-o", ref, *trigger], ranks=None)
    s = read_summary(ref)
    assert (s["cuts"]["h0_corrections"], s["cuts"]["refactorizations"], s["factorizations"]) == (2, 2, 3)
    # The console's line for each step with separations names the change it reports, not the one before.
    lines = re.findall(r"t = \S+: (\S+): .*constant matrix (corrected|factored)", proc.stdout)
    assert lines == [("cut", "corrected"), ("cut", "factored"), ("cut", "corrected"), ("cut", "factored")]
    out = tmp_path / "out"
    killed(path, out, 7, None, trigger)
    from hyperqn_tools.output import read_checkpoint
    saved = read_checkpoint(out / "checkpoints" / "checkpoint_6.h5")
    assert len(set(saved["cuts"].split()[::3])) == 3 and saved["cuts_factored"] == 2
    run_hyperqn([path, "-o", out, "--restart", "latest", *trigger], ranks=None)
    assert_same_run(ref, out)
    assert {k: v for k, v in s["cuts"].items() if k != "topology_s"} == \
        {k: v for k, v in read_summary(out)["cuts"].items() if k != "topology_s"}


CHECK_LINE = re.compile(r"topology H0 check: (\d+) rows touched since the factorization, relative difference (\S+) from")


def checked_differences(tmp_path, name, extra):
    out = tmp_path / name
    proc = run_hyperqn([write_deck(tmp_path / f"{name}.yaml", BAR), "-o", out, "-hyperqn_test_topology_h0_check", *extra],
                       ranks=None)
    found = [(int(t), float(d)) for t, d in CHECK_LINE.findall(proc.stdout)]
    return found, read_summary(out)


def test_corrected_h0_equals_a_fresh_factorization_after_every_cut(tmp_path):
    # After each step with separations, the run applies the corrected H0 and a fresh factorization
    # of the changed M + h^2 L to random vectors (FactoredSystem::check_correction).
    found, s = checked_differences(tmp_path, "check", [])
    assert len(found) == s["cuts"]["h0_corrections"] >= 2
    assert max(d for _, d in found) <= 1e-10
    assert all(0 < t <= 200 for t, _ in found) and [t for t, _ in found] == sorted(t for t, _ in found)
    # The check can fail: with the largest off-diagonal entry of each change left out, it sees it.
    dropped, _ = checked_differences(tmp_path, "dropped", ["-hyperqn_test_topology_h0_drop_edit"])
    assert len(dropped) == len(found) and min(d for _, d in dropped) > 1e-6


def test_corrections_and_refactorizations_give_the_same_run(tmp_path):
    # -hyperqn_topology_h0 false factors again at every step with separations: the same operator
    # to round-off, so the same cut and the same iterations to within a few.
    new, sn = run_deck(tmp_path, "new", BAR)
    old, so = run_deck(tmp_path, "old", BAR, extra=["-hyperqn_topology_h0", "false"])
    assert so["cuts"]["h0_corrections"] == 0 and so["cuts"]["refactorizations"] == sn["cuts"]["h0_corrections"]
    assert so["factorizations"] == 1 + so["cuts"]["refactorizations"]
    a, b = final_frame(new), final_frame(old)
    assert np.array_equal(a.vertex_id, b.vertex_id)
    assert np.abs(a.points - b.points).max() <= 1e-8 * rest_diagonal(a)
    assert abs(sn["iterations"] - so["iterations"]) <= 0.05 * so["iterations"]


GATHERED = ["-hyperqn_h0_package", "supernodal"]


def test_the_factor_gathered_to_rank_0_is_corrected_at_2_ranks(tmp_path):
    # -hyperqn_h0_package supernodal on 2 ranks: the factor is gathered to rank 0 and follows the
    # cuts there as on one rank (auto keeps split, which factors again: test above).
    one, s1 = run_deck(tmp_path, "one", BAR)
    out = tmp_path / "np2"
    proc = run_hyperqn([write_deck(tmp_path / "np2.yaml", BAR), "-o", out, *GATHERED, "-hyperqn_test_topology_h0_check"],
                       ranks=2)
    s2 = read_summary(out)
    assert s2["ranks"] == 2 and s2["factorizations"] == 1
    assert s2["cuts"]["h0_corrections"] == s1["cuts"]["h0_corrections"] >= 2
    assert s2["cuts"]["refactorizations"] == s1["cuts"]["refactorizations"] == 0
    found = [float(d) for _, d in CHECK_LINE.findall(proc.stdout)]
    assert len(found) == s2["cuts"]["h0_corrections"] and max(found) <= 1e-10
    a, b = final_frame(one), final_frame(out)
    assert np.array_equal(a.vertex_id, b.vertex_id)
    assert np.abs(a.points - b.points).max() <= 1e-8 * rest_diagonal(a)
    # a kill after corrected cuts and a restart: bitwise at 2 ranks (the replay corrects as the run did)
    (tmp_path / "kill").mkdir()
    ref, again = assert_restart_after_kill_is_bitwise(tmp_path / "kill", BAR, 2, frames=BAR["time"]["frames"], every=3,
                                                      kill_after=10, extra=GATHERED)
    sa, sb = read_summary(ref), read_summary(again)
    assert sa["cuts"]["h0_corrections"] >= 2
    assert {k: v for k, v in sa["cuts"].items() if k != "topology_s"} == {k: v for k, v in sb["cuts"].items() if k != "topology_s"}


def test_a_single_precision_factor_is_factored_again_at_every_cut(tmp_path):
    # TopologyH0 corrects a factor kept in double: with solver.h0_precision single every step with
    # separations factors again (in single), and the run reaches the double run's answer.
    single = copy.deepcopy(BAR)
    single["solver"]["h0_precision"] = "single"
    new, sn = run_deck(tmp_path, "single", single)
    old, so = run_deck(tmp_path, "double", BAR)
    assert sn["cuts"]["h0_corrections"] == 0 and sn["cuts"]["refactorizations"] == so["cuts"]["h0_corrections"] > 0
    assert sn["factorizations"] == 1 + sn["cuts"]["refactorizations"]
    a, b = final_frame(new), final_frame(old)
    assert np.array_equal(a.vertex_id, b.vertex_id)
    assert np.abs(a.points - b.points).max() <= 1e-8 * rest_diagonal(a)


@pytest.mark.parametrize("ranks", [None, 2])
def test_copies_take_ids_past_the_vertices_cleaning_dropped(tmp_path, ranks):
    # A Medit bar of 4 x 1 x 1 cubes (20 vertices) with a vertex of no element first and last (22 in
    # the file, ids 0 to 21: outputs.md's vertex_id is the index in the input mesh), cut across
    # x = 0.5: the copies' ids were 21.. (21 the dropped last vertex's), now 22..
    coords = [(x * 0.25, y * 0.25, z * 0.25) for x in range(5) for y in range(2) for z in range(2)]
    points = [(9.0, 9.0, 9.0)] + coords + [(-9.0, -9.0, -9.0)]
    index = {c: k + 2 for k, c in enumerate(coords)}  # 1-based Medit numbers of the cube corners
    tets = []
    for x in range(4):
        c = [index[((x + i) * 0.25, j * 0.25, k * 0.25)] for i in (0, 1) for j in (0, 1) for k in (0, 1)]
        for t in ((0, 1, 3, 7), (0, 3, 2, 7), (0, 2, 6, 7), (0, 6, 4, 7), (0, 4, 5, 7), (0, 5, 1, 7)):
            tets.append([c[v] for v in t])
    mesh = tmp_path / "gap.mesh"
    mesh.write_text("MeshVersionFormatted 1\nDimension 3\nVertices\n%d\n%s\nTetrahedra\n%d\n%s\nEnd\n" % (
        len(points), "\n".join("%g %g %g 0" % p for p in points), len(tets), "\n".join("%d %d %d %d 1" % tuple(t) for t in tets)))
    deck = {"mesh": {"file": str(mesh)}, "material": MATERIAL,
            "fixed": [{"box": {"min": [-0.01, -1, -1], "max": [0.01, 1, 1]}}], "gravity": [0, -9.81, 0],
            "cuts": [{"center": [0.5, 0.125, 0.125], "normal": [1, 0, 0], "axis": [0, 1, 0], "size": [1, 1], "frame": "rest"}],
            "time": {"dt": 0.02, "frames": 2}, "solver": {"type": "lbfgs"}}
    out, s = run_deck(tmp_path, "gap", deck, ranks=ranks)
    assert s["dropped_vertices"] == 2 and s["cuts"]["vertices_added"] > 0
    ids = np.sort(final_frame(out).vertex_id)
    assert list(ids[:20]) == list(range(1, 21)), ids  # the input's, by their index in the file
    assert list(ids[20:]) == list(range(22, 22 + s["cuts"]["vertices_added"])), ids


@pytest.mark.parametrize("frame", ["rest", "world"])
def test_a_blade_that_never_meets_the_body_is_a_warning(tmp_path, frame):
    # A rest-frame blade far from the rest shape cuts nothing; a world-frame one only if the body moves there.
    deck = copy.deepcopy(BAR)
    deck["time"]["frames"] = 2
    deck["cuts"][0]["center"] = [1.02, 50.0, 0.25]
    deck["cuts"][0]["frame"] = frame
    out, s = run_deck(tmp_path, "far", deck)
    proc = run_hyperqn([write_deck(tmp_path / "far.yaml", deck), "-o", out], ranks=None)
    said = "it cuts nothing (frame: rest)" if frame == "rest" else "it cuts only if the body moves there (frame: world)"
    assert "warning: " in proc.stdout and "far.yaml:" in proc.stdout and "cuts[0]: the blade never comes near" in proc.stdout
    assert said in proc.stdout
    assert s["cuts"]["faces_separated"] == 0


def test_a_world_blade_far_from_the_rest_position_cuts_a_body_that_falls_onto_it(tmp_path):
    # A free bar falls under gravity onto a still world-frame blade 2.8 m below it: the warning says it
    # cuts only if the body moves there, and it does (at t = 0.7 s).
    deck = {"mesh": BAR["mesh"], "material": {**MATERIAL, "youngs_modulus": 5.0e6}, "gravity": [0, -9.81, 0],
            "cuts": [{"center": [1.0, -2.8, 0.25], "normal": [1, 0, 0], "axis": [0, 1, 0], "size": [1.0, 2.0]}],
            "time": {"dt": 1 / 30, "frames": 30}, "solver": {"type": "lbfgs"}}
    out = tmp_path / "fall"
    proc = run_hyperqn([write_deck(tmp_path / "fall.yaml", deck), "-o", out], ranks=None)
    assert "it cuts only if the body moves there" in proc.stdout and "it cuts nothing" not in proc.stdout
    assert read_summary(out)["cuts"]["faces_separated"] == 8


def bad(**cut):
    deck = copy.deepcopy(BAR)
    deck["time"]["frames"] = 2
    deck["cuts"][0].update(cut)
    return deck


BAD_CUTS = {
    "negative_size": (bad(size=[-0.6, 1.0]), ["cuts[0].size"]),
    "zero_normal": (bad(normal=[0, 0, 0]), ["cuts[0].normal"]),
    "nan_center": (bad(center=[float("nan"), 1.0, 0.25]), ["cuts[0].center", "expected a number"]),
    "inf_size": (bad(size=[float("inf"), 1.0]), ["cuts[0].size"]),
    "axis_along_normal": (bad(axis=[2, 0, 0]), ["cuts[0].axis", "along normal"]),
    "turning_out_of_its_plane": (bad(motion={"rotate": {"axis": [0, 0, 1], "rate": 10}}),
                                 ["cuts[0].motion", "rotate.axis is not along the blade's normal"]),
    "leaving_its_plane": (bad(motion={"translate": {"velocity": [1, -1, 0]}}), ["cuts[0].motion", "leaves the blade's plane"]),
    # 1e9 degrees/s: 3.3e7 degrees a step, each sampled (it took 1.9 GB and 9 s for 3 frames before)
    "turning_too_fast": (bad(motion={"rotate": {"axis": [1, 0, 0], "center": [1.0, 0.5, 0.25], "rate": 1e9}}),
                         ["cuts[0].motion.rotate.rate", "degrees in one step", "at most 360"]),
    "missing_size": ({**bad(), "cuts": [{k: v for k, v in BAR["cuts"][0].items() if k != "size"}]}, ["size"]),
    # a blade cuts strands (test_strand_cut.py) but removes only tets
    "removing_strands": ({**{k: v for k, v in bad(remove=True).items() if k not in ("mesh", "material", "fixed")},
                          "mesh": {"strands": [{"from": [0, 0, 0], "to": [1, 0, 0], "segments": 4}]},
                          "strand_material": {"axial_stiffness": 100.0, "linear_density": 0.1}},
                         ["cuts[0].remove", "strands, whose segments", "does not remove"]),
}


@pytest.mark.parametrize("case", sorted(BAD_CUTS))
def test_bad_cut_deck_is_refused(tmp_path, case):
    deck, fragments = BAD_CUTS[case]
    assert_deck_refused(tmp_path, case, deck, fragments)
