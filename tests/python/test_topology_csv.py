"""topology.csv (docs/outputs.md#topologycsv), end to end: its rows sum to summary.json's totals for
cuts, fracture and snapping strands; a run killed after changes, or stopped by a signal in a frame
that began with a change, and restarted writes the same file as the uninterrupted run; cuts and
fracture in one deck, counted apart, restarted bitwise; a deck without a topology trigger, or
with output.topology_csv: false, writes none; turned on at a restart, it is refused."""
import copy
import csv

import pytest

from conftest import run_deck, run_hyperqn, write_deck
from hyperqn_tools.output import final_frame, read_summary
from test_checkpoint import assert_same_run, tree_digest
from test_checkpoint_faults import assert_restart_after_kill_is_bitwise, killed
from test_cuts import BAR
from test_fracture import NOTCHED, plate_mesh, pulled_plate
from test_cloth_tear import CLOTH
from test_tearing import ROPE

COLUMNS = ["frame", "time", "faces_separated", "faces_total", "vertices_added", "segments_snapped", "edges_torn",
           "h0_corrections", "refactorizations", "tets_removed"]


def rows(out):
    with open(out / "topology.csv") as f:
        reader = csv.DictReader(f)
        assert reader.fieldnames == COLUMNS
        return [{k: (float(v) if k == "time" else int(v)) for k, v in r.items()} for r in reader]


def sums(table):
    return {k: sum(r[k] for r in table) for k in COLUMNS[2:] if k != "faces_total"}


def assert_one_row_per_frame(table, frames, dt):
    assert [r["frame"] for r in table] == list(range(1, frames + 1))
    assert all(abs(r["time"] - r["frame"] * dt) <= 1e-12 for r in table)
    total = 0
    for r in table:
        total += r["faces_separated"]
        assert r["faces_total"] == total


def plate(tmp_path, frames=40):
    return pulled_plate(plate_mesh(tmp_path / "notched.mesh", **NOTCHED), 1.1, frames=frames)


def test_fracture_rows_sum_to_the_summary(tmp_path):
    out, s = run_deck(tmp_path, "plate", plate(tmp_path))
    table = rows(out)
    assert_one_row_per_frame(table, 40, 0.02)
    f, total = s["fracture"], sums(table)
    assert f["faces_broken"] > 0
    assert total == {"faces_separated": f["faces_broken"], "vertices_added": f["vertices_added"], "segments_snapped": 0,
                     "edges_torn": 0, "h0_corrections": f["h0_corrections"], "refactorizations": f["refactorizations"],
                     "tets_removed": 0}
    # faces open at the start of the frame after the one whose state broke them
    first = next(r["frame"] for r in table if r["faces_separated"])
    assert first == f["first_break_frame"] + 1


def test_cut_rows_sum_to_the_summary(tmp_path):
    out, s = run_deck(tmp_path, "bar", BAR)
    table = rows(out)
    assert_one_row_per_frame(table, BAR["time"]["frames"], BAR["time"]["dt"])
    c = s["cuts"]
    assert c["faces_separated"] > 0
    assert sums(table) == {"faces_separated": c["faces_separated"], "vertices_added": c["vertices_added"],
                           "segments_snapped": 0, "edges_torn": 0, "h0_corrections": c["h0_corrections"],
                           "refactorizations": c["refactorizations"], "tets_removed": 0}
    assert c["tets_removed"] == 0
    # every frame that separates faces is one step whose H0 followed or was factored again
    assert all((r["h0_corrections"] + r["refactorizations"] == 1) == (r["faces_separated"] > 0) for r in table)


def test_snap_rows_sum_to_the_summary(tmp_path):
    out, s = run_deck(tmp_path, "rope", ROPE)
    table = rows(out)
    assert_one_row_per_frame(table, ROPE["time"]["frames"], ROPE["time"]["dt"])
    b = s["breaks"]
    assert b["segments_snapped"] == 2
    assert sums(table) == {"faces_separated": 0, "vertices_added": b["vertices_added"],
                           "segments_snapped": b["segments_snapped"], "edges_torn": 0, "h0_corrections": b["h0_corrections"],
                           "refactorizations": b["refactorizations"], "tets_removed": 0}


# Newton (no constant matrix: a tear counts neither a correction nor a refactorization) and L-BFGS
# (on one rank every tear's H0 follows by a TopologyH0 correction, docs/topology.md#h0-across-a-cut).
@pytest.mark.parametrize("solver", ["newton", "lbfgs"])
def test_tear_rows_sum_to_the_summary(tmp_path, solver):
    deck = CLOTH if solver == "newton" else {**CLOTH, "solver": {"type": "lbfgs"}}
    out, s = run_deck(tmp_path, "cloth", deck)
    table = rows(out)
    assert_one_row_per_frame(table, CLOTH["time"]["frames"], CLOTH["time"]["dt"])
    b = s["breaks"]
    assert b["edges_torn"] > 0
    assert (b["h0_corrections"] == b["edges_torn"]) == (solver == "lbfgs")
    assert sums(table) == {"faces_separated": 0, "vertices_added": b["vertices_added"], "segments_snapped": 0,
                           "edges_torn": b["edges_torn"], "h0_corrections": b["h0_corrections"],
                           "refactorizations": b["refactorizations"], "tets_removed": 0}
    assert max(r["edges_torn"] for r in table) == 1  # one edge per step
    steps = lambda r: r["edges_torn"] if solver == "lbfgs" else 0
    assert all(r["h0_corrections"] + r["refactorizations"] == steps(r) for r in table)


def test_a_run_that_stops_in_a_frame_that_began_with_a_cut(tmp_path):
    # Static, the blade (rest frame) frees the bar's end at the start of frame 10, which then has no
    # equilibrium and diverges: summary.json counts what topology.csv and the frames hold (frame 9's
    # scene), not the cut of the frame that did not stand.
    deck = copy.deepcopy(BAR)
    deck["material"]["youngs_modulus"] = 5.0e6
    deck["solver"] = {"type": "lbfgs"}
    deck["time"] = {"dt": 1 / 30, "frames": 10, "integrator": "static"}
    deck["cuts"][0].update({"center": [1.27, 1.0, 0.25], "frame": "rest",
                            "motion": {"translate": {"velocity": [0, -3, 0]}, "start": 0.1, "end": 0.6}})
    out = tmp_path / "static"
    done = run_hyperqn([write_deck(tmp_path / "static.yaml", deck), "-o", out], check=False)
    s = read_summary(out)
    assert done.returncode == 1 and s["status"].startswith("error: frame 10: diverged")
    table, c = rows(out), s["cuts"]
    assert table[-1]["frame"] == 9 and c["faces_separated"] > 0
    assert sums(table) == {"faces_separated": c["faces_separated"], "vertices_added": c["vertices_added"],
                           "segments_snapped": 0, "edges_torn": 0, "h0_corrections": c["h0_corrections"],
                           "refactorizations": c["refactorizations"], "tets_removed": 0}
    last = final_frame(out)
    assert s["vertices"] == len(last.points) and s["tets"] == len(last.cells["tetra"])


@pytest.mark.parametrize("ranks", [None, 2])
def test_restart_after_a_kill_writes_the_same_file(tmp_path, ranks):
    deck = plate(tmp_path)
    deck["checkpoint"] = {"every": 2}
    path = write_deck(tmp_path / "plate.yaml", deck)
    ref = tmp_path / "ref"
    run_hyperqn([path, "-o", ref], ranks=ranks)
    first = read_summary(ref)["fracture"]["first_break_frame"]
    out = tmp_path / "out"
    killed(path, out, first + 5, ranks)  # after several breaks, between checkpoints
    assert rows(out)[-1]["frame"] == first + 5
    run_hyperqn([path, "-o", out, "--restart", "latest"], ranks=ranks)
    assert (out / "topology.csv").read_bytes() == (ref / "topology.csv").read_bytes()


def test_restart_after_a_signal_in_a_frame_that_began_with_breaks(tmp_path):
    # The frame given up began with breaks, which its checkpoint (of the frame before) holds: the
    # restart's row of that frame still counts them.
    deck = plate(tmp_path, frames=20)
    path = write_deck(tmp_path / "plate.yaml", deck)
    ref = tmp_path / "ref"
    run_hyperqn([path, "-o", ref])
    table = rows(ref)
    frame = next(r["frame"] for r in table if r["faces_separated"])
    out = tmp_path / "out"
    done = run_hyperqn([path, "-o", out, "-hyperqn_test_signal_in_frame", frame, "-hyperqn_test_signal_at_iteration", 2],
                       check=False)
    assert done.returncode == 3
    assert rows(out)[-1]["frame"] == frame - 1
    run_hyperqn([path, "-o", out, "--restart", "latest"])
    assert (out / "topology.csv").read_bytes() == (ref / "topology.csv").read_bytes()


# test_cuts' bar sliced by its blade, its material also breaking where its tension exceeds 3e4 Pa
# (near the clamp, away from the blade): cuts and fracture in one deck.
BOTH = copy.deepcopy(BAR)
BOTH["material"]["fracture"] = {"criterion": "normal_stress", "threshold": 3.0e4}


def test_cuts_and_fracture_in_one_deck(tmp_path):
    out, s = run_deck(tmp_path, "both", BOTH)
    cut, broken, total = s["cuts"]["faces_separated"], s["fracture"]["faces_broken"], sums(rows(out))
    print(f"{cut} faces cut by the blade, {broken} broken by the criterion")
    assert cut > 0 and broken > 0
    assert total["faces_separated"] == cut + broken
    assert total["vertices_added"] == s["cuts"]["vertices_added"] == s["fracture"]["vertices_added"]
    _, alone = run_deck(tmp_path, "alone", BAR)  # the blade alone cuts as many faces or more
    assert alone["cuts"]["faces_separated"] >= cut


@pytest.mark.parametrize("ranks", [None, 2])
def test_cuts_and_fracture_restart_after_a_kill(tmp_path, ranks):
    # killed after cuts and the first breaks (frames 4 to 7 and 13)
    ref, out = assert_restart_after_kill_is_bitwise(tmp_path, BOTH, ranks, frames=BOTH["time"]["frames"], every=2,
                                                    kill_after=14)
    assert (out / "topology.csv").read_bytes() == (ref / "topology.csv").read_bytes()
    skip = lambda f: {k: v for k, v in f.items() if k != "topology_s"}
    a, b = read_summary(ref), read_summary(out)
    assert skip(a["cuts"]) == skip(b["cuts"]) and skip(a["fracture"]) == skip(b["fracture"])


def test_no_file_without_a_trigger_or_when_turned_off(tmp_path):
    deck = plate(tmp_path, frames=2)
    plain = copy.deepcopy(deck)
    del plain["material"]["fracture"]
    out, s = run_deck(tmp_path, "plain", plain)
    assert "fracture" not in s and not (out / "topology.csv").exists()
    deck["output"] = {"topology_csv": False}
    out, s = run_deck(tmp_path, "off", deck)
    assert "fracture" in s and not (out / "topology.csv").exists()


def test_turned_on_at_a_restart_is_refused_and_writes_nothing(tmp_path):
    # Like energy.csv and reactions.csv (test_checkpoint.py), topology.csv goes on from the
    # checkpoint's row: a checkpointed run with output.topology_csv: false has none to go on from.
    # iterations.csv, which sums nothing, may be turned on.
    off = dict(copy.deepcopy(BAR), time={**BAR["time"], "frames": 8}, checkpoint={"every": 8},
               output={"topology_csv": False, "iterations_csv": False})
    out, _ = run_deck(tmp_path, "off", off)
    before = tree_digest(out)
    on = dict(off, time={**BAR["time"], "frames": 10}, output={"topology_csv": True, "iterations_csv": False})
    done = run_hyperqn([write_deck(tmp_path / "on.yaml", on), "-o", out, "--restart", "latest"], check=False)
    assert done.returncode == 1
    assert ("topology.csv has no row of frame 8 to go on from (output.topology_csv: the checkpointed run must "
            "have written it)") in done.stdout, done.stdout[-2000:]
    assert tree_digest(out) == before
    iterations = dict(off, time={**BAR["time"], "frames": 10}, output={"topology_csv": False})
    run_hyperqn([write_deck(tmp_path / "iterations.yaml", iterations), "-o", out, "--restart", "latest"])
    with open(out / "iterations.csv") as f:
        assert int(next(csv.DictReader(f))["frame"]) == 9
