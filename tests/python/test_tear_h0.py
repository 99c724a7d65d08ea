"""The H0 that follows snaps and tears by a TopologyH0 correction (docs/topology.md#h0-across-a-cut,
docs/snapping.md), with L-BFGS (whose H0 is the factored M + h^2 L): on one rank every break is
followed by a correction, not a factorization, and the corrected H0 equals a fresh factorization
of the changed matrix to 1e-10 relative (the check fails with an edit left out); the run equals
one with -hyperqn_topology_h0 false (factored again at every break) to 1e-8 of the diagonal with
iterations within 5 %; 2 ranks factor again and agree with 1 rank; a run killed (kill -9) after
corrected breaks and restarted with --restart latest equals the uninterrupted run bit for bit (also
across refactorizations by the size trigger, and across a release between tears), at 1 and 2 ranks. Scenes: input/topology/
rope_snap.yaml shortened to 45 frames (its snap at frame 31) and the 10 x 10 tearing cloth of
test_cloth_tear with L-BFGS."""
import copy
import re

import numpy as np
import pytest

from conftest import event_count, load_deck, run_hyperqn, write_deck
from hyperqn_tools.output import Frame, frame_list, read_checkpoint, read_iterations, read_summary, rest_diagonal
from test_checkpoint_faults import assert_same_run, killed
from test_cloth_tear import CLOTH

ROPE = load_deck("input/topology/rope_snap.yaml")
ROPE["time"]["frames"] = 45
TEARING = {**copy.deepcopy(CLOTH), "solver": {"type": "lbfgs"}}
DECKS = {"rope": ROPE, "cloth": TEARING}
CHECK = ["-hyperqn_test_topology_h0_check"]


def frames(out):
    return [Frame(path) for _, _, path in frame_list(out)]


def deviation(ref, out):
    """The largest distance between the two runs' positions over all frames, over the rest
    diagonal; every frame has the same vertex ids in both."""
    worst = 0.0
    fa, fb = frames(ref), frames(out)
    assert len(fa) == len(fb)
    for a, b in zip(fa, fb):
        assert np.array_equal(a.vertex_id, b.vertex_id)
        worst = max(worst, np.abs(a.points - b.points).max() / rest_diagonal(a))
    return worst


def checked(stdout):
    """The check's relative differences, one per correction (FactoredSystem::check_correction)."""
    return [float(x) for x in re.findall(r"topology H0 check: .* relative difference (\S+) from a fresh", stdout)]


def run(tmp_path, name, deck, ranks=None, extra=()):
    out = tmp_path / name
    proc = run_hyperqn([write_deck(tmp_path / f"{name}.yaml", deck), "-o", out, *extra], ranks=ranks)
    s = read_summary(out)
    assert s["status"] == "ok", proc.stdout[-3000:]
    return out, s, proc.stdout


@pytest.fixture(scope="module", params=sorted(DECKS))
def checked_run(request, tmp_path_factory):
    name = request.param
    return (name,) + run(tmp_path_factory.mktemp(name), name, DECKS[name], extra=CHECK)


def test_every_break_is_followed_by_a_correction_equal_to_a_fresh_factor(checked_run):
    name, out, s, stdout = checked_run
    b = s["breaks"]
    batches = b["segments_snapped"] + b["edges_torn"]  # one segment or edge per step
    assert batches >= (1 if name == "rope" else 10)
    assert b["h0_corrections"] == batches and b["refactorizations"] == 0
    diffs = checked(stdout)
    assert len(diffs) == batches
    print(f"{name}: {len(diffs)} corrections, worst relative difference {max(diffs):.3e}")
    assert max(diffs) <= 1e-10
    assert stdout.count("constant matrix corrected (TopologyH0)") == batches


def test_substep_matrices_of_a_torn_scene_take_their_pattern_from_the_cells(tmp_path):
    # input/topology/cloth_tear.yaml factors its sub-steps' M + (h/k)^2 L again after tears (34
    # times in its 90 frames): a rebuilt scene's sub-step integrators take A1's pattern from the
    # mesh's cells, as its own H0 does, so DMPlex preallocates only the first scene's H0 and
    # sub-step matrices (at most 1 + max_halvings) and each chain's Newton Hessian (at most one per
    # Newton frame); before, one preallocation per sub-step factorization (37 in the run)
    log = tmp_path / "log_view.txt"
    out, s, _ = run(tmp_path, "tear", load_deck("input/topology/cloth_tear.yaml"), extra=["-log_view", f":{log}"])
    prealloc = event_count(log.read_text(), "DMPlexPrealloc")
    print(f"cloth_tear: {s['factorizations']} factorizations, {s['newton_frames']} Newton frames, {prealloc} DMPlex preallocations")
    assert s["factorizations"] >= 10 and s["breaks"]["h0_corrections"] >= 10
    assert prealloc <= 1 + 3 + s["newton_frames"]


@pytest.mark.parametrize("name", sorted(DECKS))
def test_the_check_fails_with_an_edit_left_out(tmp_path, name):
    _, s, stdout = run(tmp_path, name, DECKS[name], extra=CHECK + ["-hyperqn_test_topology_h0_drop_edit"])
    diffs = checked(stdout)
    assert diffs and s["breaks"]["h0_corrections"] == len(diffs)
    print(f"{name}: an edit dropped, relative differences {min(diffs):.3e} to {max(diffs):.3e}")
    assert min(diffs) > 1e-6


def test_corrected_equals_factored_again(checked_run, tmp_path):
    name, ref, s1, _ = checked_run
    out, s2, stdout = run(tmp_path, "off", DECKS[name], extra=["-hyperqn_topology_h0", "false"])
    b1, b2 = s1["breaks"], s2["breaks"]
    assert b2["h0_corrections"] == 0 and b2["refactorizations"] == b1["h0_corrections"]
    assert "constant matrix corrected" not in stdout
    # the breaks' factorizations are gone (the cloth's sub-steps factor M + (h/2)^2 L in both)
    assert s1["factorizations"] == s2["factorizations"] - b2["refactorizations"]
    assert {k: b1[k] for k in ("segments_snapped", "edges_torn", "vertices_added")} == \
           {k: b2[k] for k in ("segments_snapped", "edges_torn", "vertices_added")}
    worst = deviation(ref, out)
    print(f"{name}: corrected against factored again: {worst:.3e} of the diagonal, iterations {s1['iterations']} and {s2['iterations']}")
    # The two operators differ by round-off (the direct check above: 1e-13), the same iterations in
    # every frame; 60 frames of the torn sheet's flapping pieces at lbfgs's budget amplify it: 2.3e-13
    # of the diagonal on one trajectory, 2.4e-8 on the one FrameBudget::creeping's extensions take
    # (from frame 49 on, where some frames stop at |grad g| ~ 5e-7).
    assert worst <= 1e-7
    assert abs(s1["iterations"] - s2["iterations"]) <= 0.05 * s2["iterations"]


def test_two_ranks_factor_again_and_agree_with_one(checked_run, tmp_path):
    name, ref, s1, _ = checked_run
    out, s2, _ = run(tmp_path, "np2", DECKS[name], ranks=2)
    b1, b2 = s1["breaks"], s2["breaks"]
    assert b2["h0_corrections"] == 0 and b2["refactorizations"] == b1["h0_corrections"]
    worst = deviation(ref, out)
    print(f"{name}: 1 against 2 ranks: {worst:.3e} of the diagonal")
    assert worst <= 1e-8


# (frames, checkpoint every, killed after): the checkpoint falls after breaks (the rope's snap is
# at frame 31, the cloth tears from frame 19 on).
RESTART = {"rope": (45, 36, 40), "cloth": (40, 30, 35)}


def restarted(tmp_path, deck, ranks, frames, every, kill_after, extra=()):
    deck = {**deck, "time": {**deck["time"], "frames": frames}, "checkpoint": {"every": every},
            "output": {**deck.get("output", {}), "topology_csv": True}}
    path = write_deck(tmp_path / "deck.yaml", deck)
    ref, out = tmp_path / "ref", tmp_path / "out"
    run_hyperqn([path, "-o", ref, *extra], ranks=ranks)
    killed(path, out, kill_after, ranks, extra)
    run_hyperqn([path, "-o", out, "--restart", "latest", *extra], ranks=ranks)
    assert_same_run(ref, out)
    strip = lambda rows: [{k: v for k, v in r.items() if k != "time_s"} for r in rows]
    assert strip(read_iterations(ref)) == strip(read_iterations(out))
    assert (out / "topology.csv").read_bytes() == (ref / "topology.csv").read_bytes()
    a, b = read_summary(ref)["breaks"], read_summary(out)["breaks"]
    assert {k: v for k, v in a.items() if k != "topology_s"} == {k: v for k, v in b.items() if k != "topology_s"}
    return ref, out, read_checkpoint(out / "checkpoints" / f"checkpoint_{every}.h5")


@pytest.mark.parametrize("ranks", [None, 2])
@pytest.mark.parametrize("name", sorted(DECKS))
def test_restart_after_kill_after_corrected_breaks_is_bitwise(tmp_path, name, ranks):
    ref, out, saved = restarted(tmp_path, DECKS[name], ranks, *RESTART[name])
    batches = len(set(str(saved["breaks"]).split()[0::3]))
    assert batches >= 1
    # one rank: every break was corrected, the restart replays them all from the first factor;
    # two ranks: every break factored again
    assert int(saved["breaks_factored"]) == (0 if ranks is None else batches)
    b = read_summary(ref)["breaks"]
    assert (b["h0_corrections"] > 0) == (ranks is None)


def test_restart_across_a_refactorization_by_the_size_trigger_is_bitwise(tmp_path):
    # max_touched 12: the crack's corrections refactor now and then, so the checkpoint's scene was
    # factored after some breaks and corrected after others
    ref, out, saved = restarted(tmp_path, TEARING, None, *RESTART["cloth"], extra=["-hyperqn_test_topology_h0_max_touched", "12"])
    batches = len(set(str(saved["breaks"]).split()[0::3]))
    assert 0 < int(saved["breaks_factored"]) < batches
    b = read_summary(ref)["breaks"]
    assert b["h0_corrections"] > 0 and b["refactorizations"] > 0


def test_restart_across_a_release_between_corrected_tears_is_bitwise(tmp_path):
    # an attachment in the sheet's middle let go at t = 0.45 (frame 27), between tears: the release
    # factors again, the tears after it are corrected, and the restart replays them from that scene
    deck = {**TEARING, "attachments": [{"box": {"min": [0.2, -0.01, 0.2], "max": [0.3, 0.01, 0.3]}, "stiffness": 5.0,
                                        "release": 0.45}]}
    ref, out, saved = restarted(tmp_path, deck, None, *RESTART["cloth"])
    first = [int(f) for f in str(saved["breaks"]).split()[0::3]]
    batches = len(set(first))
    assert min(first) < 27 < max(first)  # tears before and after the release
    assert 0 < int(saved["breaks_factored"]) < batches
    b = read_summary(ref)["breaks"]
    assert b["h0_corrections"] == b["edges_torn"] and b["refactorizations"] == 0  # the release factors, not a tear
    # and says so, after corrected tears (it said "corrected", the last tear's word, before)
    done = run_hyperqn([write_deck(tmp_path / "to_release.yaml", {**deck, "time": {**deck["time"], "frames": 28}}),
                        "-o", tmp_path / "to_release"], ranks=None)
    [line] = [l for l in done.stdout.splitlines() if "released or attachment(s) gone" in l]
    assert line.endswith("constant matrix factored again"), line

