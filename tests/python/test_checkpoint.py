"""Checkpoints and restart (deck checkpoint:, --restart; io/checkpoint.hpp), end to end.

- 1 and 2 ranks: N frames with a checkpoint, then --restart latest with the deck's 2N frames, equals
  the uninterrupted 2N-frame run bitwise (positions, velocities, iterations.csv without time_s,
  the .pvd listing, the summary's frame counts), for a bar with a rotating fixed end released at
  the checkpoint's time (implicit Euler and BDF2) and for a bar released before it falling onto a
  plane collider.
- 2 -> 1 and 1 -> 2 ranks with a tight solver tolerance: to 1e-10 of the rest diagonal (round-off
  differs between rank counts).
- A deck whose physics differ is refused (exit 1, the section named, nothing in OUTDIR changed).
- SIGTERM mid-run: exit 3, a checkpoint of the last frame done, summary status "interrupted" (after
  that frame, or during the next, given up); --restart latest finishes and equals the uninterrupted
  run.
- keep: only the newest checkpoints remain, no temporary files; what a checkpoint holds.
- kill -9 at random moments, each time continued with --restart latest: the finished run equals
  the uninterrupted one bitwise, and every file in the output directory is complete.
"""
import copy
import hashlib
import os
import random
import signal
import subprocess
import time

import numpy as np
import pytest

from test_safe_outputs import check_complete, run_and_kill, slow_deck
from conftest import HYPERQN, run_hyperqn, write_deck
from hyperqn_tools import launch
from hyperqn_tools.output import final_frame, frame_list, read_checkpoint, read_iterations, read_pvd, read_summary, read_xdmf, rest_diagonal

FRAMES = 8
BAR = {
    "mesh": {"box": {"size": [2.0, 0.5, 0.5], "cells": [8, 2, 2]}},
    "material": {"model": "neohookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 1000},
    "gravity": [0, -9.81, 0],
    "time": {"dt": 0.05, "frames": FRAMES},
    "solver": {"iterations": 50},
}
CLAMP = {"box": {"min": [-0.01, -1, -1], "max": [0.01, 1, 1]}}
# A rotating end, released at t = 0.2, the time of the checkpoint at frame 4: the checkpoint holds the
# state before the release, and the restart releases the end at the step that starts there (the
# step to frame 5), as the uninterrupted run does; its vertices go on with the prescribed velocity
# at t = 0.2 (w x r). (Released at 0.25 before the release took effect at the step that starts at
# its time: then also the step to frame 5.) With BDF2 too: the release drops its history.
MOTION = dict(BAR, fixed=[CLAMP, {
    "box": {"min": [1.99, -1, -1], "max": [2.01, 1, 1]},
    "motion": {"rotate": {"axis": [1, 0, 0], "center": [2.0, 0.25, 0.25], "rate": 90.0}},
    "release": 0.2}])
MOTION_BDF2 = dict(MOTION, time=dict(MOTION["time"], integrator="bdf2"))
# Released at t = 0.1 (before the checkpoint: the restart rebuilds the released scene), falling
# onto a plane.
COLLIDER = dict(BAR, fixed=[dict(CLAMP, release=0.1)],
                colliders=[{"type": "plane", "point": [0, -0.05, 0], "normal": [0, 1, 0], "friction": 0.3}])
# A cloth pinned at one corner and held at another by an attachment released at t = 0.25.
CLOTH = {
    "mesh": {"sheet": {"size": [1.0, 0.5], "cells": [8, 4]}},
    "cloth": {"model": "mass-spring", "stretch_stiffness": 50.0, "bending": {"model": "dihedral", "stiffness": 1e-3},
              "areal_density": 0.2},
    "fixed": [{"box": {"min": [-0.01, -0.01, 0.49], "max": [0.01, 0.01, 0.51]}}],
    "attachments": [{"box": {"min": [0.99, -0.01, 0.49], "max": [1.01, 0.01, 0.51]}, "stiffness": 10.0, "release": 0.25}],
    "gravity": [0, -9.81, 0],
    "time": {"dt": 0.05, "frames": FRAMES},
    "solver": {"iterations": 50},
}
SCENES = {"motion": MOTION, "motion_bdf2": MOTION_BDF2, "collider": COLLIDER, "cloth": CLOTH}
TIGHT = {"iterations": 300, "max_iterations": 300, "grad_rtol": 1e-12, "grad_atol": 0}


def deck_with(base, frames, checkpoint=None, solver=None):
    d = copy.deepcopy(base)
    d["time"]["frames"] = frames
    if checkpoint:
        d["checkpoint"] = checkpoint
    if solver:
        d["solver"] = dict(d["solver"], **solver)
    return d


def run(tmp_path, name, deck, out, ranks=None, extra=(), check=True):
    path = write_deck(tmp_path / f"{name}.yaml", deck)
    return run_hyperqn([path, "-o", out, *extra], ranks=ranks, check=check)


def interrupted_then_restarted(tmp_path, base, ranks_first, ranks_then, solver=None):
    """N frames with a checkpoint at N, then --restart latest with 2N frames; the output dir."""
    out = tmp_path / f"restarted_{ranks_first}_{ranks_then}"
    run(tmp_path, "first", deck_with(base, FRAMES // 2, {"every": FRAMES // 2}, solver), out, ranks_first)
    assert os.listdir(out / "checkpoints") == [f"checkpoint_{FRAMES // 2}.h5"]
    done = run(tmp_path, "then", deck_with(base, FRAMES, solver=solver), out, ranks_then,
               ["--restart", "latest"])
    assert f"restart from {out}/checkpoints/checkpoint_{FRAMES // 2}.h5" in done.stdout
    return out


def iteration_rows(out):
    return [{k: v for k, v in r.items() if k != "time_s"} for r in read_iterations(out)]


def pvd_listing(out):
    (pvd,) = out.glob("*.pvd")  # the run's one .pvd, whatever its name
    return [(t, os.path.basename(f)) for t, f in read_pvd(pvd)]


def assert_same_run(a, b, exact=True, tol=0.0, status="ok"):
    fa, fb = final_frame(a), final_frame(b)
    assert np.array_equal(fa.vertex_id, fb.vertex_id)
    if exact:
        assert np.array_equal(fa.points, fb.points)
        assert np.array_equal(fa.velocity, fb.velocity)
        assert iteration_rows(a) == iteration_rows(b)
        assert pvd_listing(a) == pvd_listing(b)
    else:
        d = rest_diagonal(fa)
        assert np.abs(fa.points - fb.points).max() <= tol * d
    sa, sb = read_summary(a), read_summary(b)
    assert sa["status"] == sb["status"] and sa["status"].startswith(status), (sa["status"], sb["status"])
    assert sa["flagged_frames"] == sb["flagged_frames"]
    keys = ["frames", "converged_frames", "failed_frames", "extended_frames", "substepped_frames", "newton_frames"]
    if exact:
        # and the scene at the end: its mesh and the constant matrix's factor in use (a restart
        # after a release or a cut reported the factor it set up, the run the one it started with)
        keys += ["iterations", "evaluations", "min_J", "final_energy", "max_active_contacts",
                 "vertices", "tets", "dofs", "h0_factor_nonzeros", "h0_interface"]
    assert {k: sa[k] for k in keys} == {k: sb[k] for k in keys}


# Bitwise at the same rank count: runs are reproducible (docs/performance.md, "Reproducibility").
@pytest.mark.parametrize("ranks", [None, 2])
@pytest.mark.parametrize("scene", sorted(SCENES))
def test_restart_at_the_same_rank_count_is_bitwise_exact(tmp_path, scene, ranks):
    base = dict(SCENES[scene], name="run")
    ref = tmp_path / "uninterrupted"
    run(tmp_path, "ref", base, ref, ranks)
    out = interrupted_then_restarted(tmp_path, base, ranks, ranks)
    assert_same_run(ref, out)
    assert read_iterations(out)[-1]["frame"] == FRAMES


@pytest.mark.parametrize("first,then", [(2, None), (None, 2)])
def test_restart_at_another_rank_count(tmp_path, first, then):
    base = dict(MOTION, name="run")
    ref = tmp_path / "ref"
    run(tmp_path, "ref", deck_with(base, FRAMES, solver=TIGHT), ref)
    out = interrupted_then_restarted(tmp_path, base, first, then, solver=TIGHT)
    assert_same_run(ref, out, exact=False, tol=1e-10)
    assert read_checkpoint(out / "checkpoints" / "checkpoint_4.h5")["ranks"] == (2 if first == 2 else 1)


def tree_digest(root):
    """{relative path: sha256} of every file under root."""
    digest = {}
    for d, _, files in os.walk(root):
        for name in files:
            p = os.path.join(d, name)
            with open(p, "rb") as f:
                digest[os.path.relpath(p, root)] = hashlib.sha256(f.read()).hexdigest()
    return digest


def test_restart_with_other_physics_is_refused(tmp_path):
    base = dict(MOTION, name="run")
    out = tmp_path / "out"
    run(tmp_path, "first", deck_with(base, 4, {"every": 2}), out)
    before = tree_digest(out)
    other = deck_with(base, FRAMES)
    other["material"]["youngs_modulus"] = 2.0e5
    done = run(tmp_path, "other", other, out, extra=["--restart", "latest"], check=False)
    assert done.returncode == 1
    assert "the deck's physics differ" in done.stdout and "section(s) material" in done.stdout
    assert tree_digest(out) == before
    # time.frames, output and the solver are not physics: that restart is accepted.
    run(tmp_path, "same", deck_with(base, 6, solver={"iterations": 40}), out, extra=["--restart", "latest"])


@pytest.mark.parametrize("log", ["energy", "reactions"])
def test_restart_asking_for_a_log_the_run_did_not_write_is_refused_and_writes_nothing(tmp_path, log):
    # output.energy and output.reactions go on from the checkpoint's frame: a checkpointed run without
    # them has no rows to go on from. Refused before summary.json and config.yaml are written.
    base = dict(MOTION, name="run")
    out = tmp_path / "out"
    run(tmp_path, "first", deck_with(base, 4, {"every": 2}), out)
    before = tree_digest(out)
    more = dict(deck_with(base, 6), output={log: True})
    done = run(tmp_path, "more", more, out, extra=["--restart", "latest"], check=False)
    assert done.returncode == 1
    assert f"{log}.csv" in done.stdout and f"output.{log}: the checkpointed run must have written it" in done.stdout
    assert tree_digest(out) == before


# SIGINT: Ctrl-C at a terminal to a run without mpiexec (which turns it into SIGTERM to the ranks);
# it ended the process with no checkpoint and summary.json "incomplete".
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_sigterm_writes_a_checkpoint_and_the_restart_finishes_the_run(tmp_path, sig):
    frames = 300  # a few seconds: the signal comes long before the end
    base = dict(MOTION, name="run", time={"dt": 0.05, "frames": frames}, output={"every": 10})
    base["fixed"] = [CLAMP, dict(MOTION["fixed"][1], release=4.0)]
    ref = tmp_path / "ref"
    run(tmp_path, "ref", base, ref)
    out = tmp_path / "out"
    path = write_deck(tmp_path / "sig.yaml", base)
    proc = subprocess.Popen(launch.command([path, "-o", out], None, HYPERQN), stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, env={**os.environ, **launch.MPI_ENV})
    deadline = time.time() + 60
    while not (out / "run_00010.vtu").exists() and proc.poll() is None and time.time() < deadline:
        time.sleep(0.01)
    proc.send_signal(sig)
    text, _ = proc.communicate(timeout=120)
    assert proc.returncode == 3, text[-2000:]
    summary = read_summary(out)
    stopped = summary["frames"]
    # Between two frames, or during one (given up: the checkpoint is of the frame before).
    name = signal.Signals(sig).name
    assert summary["status"].startswith((f"interrupted: {name} after frame {stopped} of",
                                         f"interrupted: {name} during frame {stopped + 1} of")), summary["status"]
    assert summary["signal"] == name and 10 <= stopped < frames
    assert os.listdir(out / "checkpoints") == [f"checkpoint_{stopped}.h5"]
    run_hyperqn([path, "-o", out, "--restart", "latest"])
    assert_same_run(ref, out)


def test_keep_and_contents(tmp_path):
    out = tmp_path / "out"
    run(tmp_path, "keep", deck_with(dict(COLLIDER, name="run"), 6, {"every": 1, "keep": 3}), out, ranks=2)
    assert sorted(os.listdir(out / "checkpoints")) == ["checkpoint_4.h5", "checkpoint_5.h5", "checkpoint_6.h5"]
    final = final_frame(out)
    c = read_checkpoint(out / "checkpoints" / "checkpoint_6.h5")
    assert c["frame"] == 6 and c["ranks"] == 2 and c["format_version"] == 3
    assert abs(c["time"] - 0.3) < 1e-15
    assert c["vertices"] == len(final.vertex_id) == 81
    assert c["positions"].shape == (81, 3)
    assert c["run_id"] == read_summary(out)["run_id"] and len(c["run_id"]) == 32
    # Stored by vertex id whatever the partition: the last frame's positions and velocities.
    assert np.array_equal(c["positions"][final.vertex_id], final.points)
    assert np.array_equal(c["velocities"][final.vertex_id], final.velocity)
    # By wall time: every frame with a tiny interval; keep defaults to 2.
    out2 = tmp_path / "seconds"
    run(tmp_path, "seconds", deck_with(dict(MOTION, name="run"), 5, {"seconds": 1e-6}), out2)
    assert sorted(os.listdir(out2 / "checkpoints")) == ["checkpoint_4.h5", "checkpoint_5.h5"]


def checkpoint_frames(out):
    """Frames of the complete checkpoints in out/checkpoints."""
    where = out / "checkpoints"
    names = os.listdir(where) if where.exists() else []
    return [int(n[len("checkpoint_"):-len(".h5")]) for n in names if n.startswith("checkpoint_") and n.endswith(".h5")]


@pytest.mark.parametrize("ranks", [None, 2])
def test_killed_and_restarted_run_equals_the_uninterrupted_one(tmp_path, ranks):
    deck = slow_deck("run")  # 150 frames of some 40 ms: the kills land mid-run
    deck["checkpoint"] = {"every": 3}
    path = write_deck(tmp_path / "run.yaml", deck)
    ref = tmp_path / "ref"
    run_hyperqn([path, "-o", ref], ranks=ranks)
    out = tmp_path / "out"
    rng = random.Random(7 + (ranks or 1))
    args = [path, "-o", out]
    for trial in range(2):  # killed twice, each time after a checkpoint newer than the last
        newest = max(checkpoint_frames(out), default=0)
        run_and_kill(args, ranks, lambda: max(checkpoint_frames(out), default=0) > newest, rng)
        check_complete(out)
        args = [path, "-o", out, "--restart", "latest"]
    run_hyperqn(args, ranks=ranks)
    check_complete(out)
    assert_same_run(ref, out)


def frames_listed(out, index):
    if index.endswith(".pvd"):
        return [int(os.path.basename(f).split("_")[-1].split(".")[0]) for _, f in read_pvd(out / index)]
    return [number for _, number, _ in read_xdmf(out / index)]


@pytest.mark.parametrize("fmt", ["vtu", "xdmf"])
def test_output_left_off_for_a_part_keeps_the_earlier_parts_output(tmp_path, fmt):
    # Found from outside: a part of the run with frames off (or the other format) did not carry the
    # series into its checkpoints, so the next part that wrote it again started it afresh (the .pvd
    # listed only its own frames; XDMF's .h5 was made anew, frames 0-2 deleted). A log left off kept
    # the rows of the abandoned trajectory past the checkpoint, and a later part went on from them.
    base = dict(MOTION, name="run", output={"format": fmt, "energy": True})
    out = tmp_path / "out"
    run(tmp_path, "first", deck_with(base, 3, {"every": 2}), out)  # frames 0-3, a checkpoint at 2
    index = "run.pvd" if fmt == "vtu" else "run.xdmf"
    assert frames_listed(out, index) == [0, 1, 2, 3]
    off = dict(deck_with(base, 5, {"every": 2}), output={"format": fmt, "vtk": False})
    run(tmp_path, "off", off, out, extra=["--restart", "latest"])  # from 2 to 5, a checkpoint at 4
    assert frames_listed(out, index) == [0, 1, 2]
    assert sorted({int(r.split(",")[0]) for r in (out / "energy.csv").read_text().splitlines()[1:]}) == [0, 1, 2]
    # energy.csv has no row of the checkpoint's frame 4: refused, nothing changed
    before = tree_digest(out)
    refused = run(tmp_path, "on", deck_with(base, 6), out, extra=["--restart", "latest"], check=False)
    assert refused.returncode == 1 and "energy.csv has no row of frame 4" in refused.stdout, refused.stdout
    assert tree_digest(out) == before
    on = dict(deck_with(base, 6), output={"format": fmt})
    run(tmp_path, "on", on, out, extra=["--restart", "latest"])
    assert frames_listed(out, index) == [0, 1, 2, 5, 6]
    if fmt == "xdmf":
        import h5py
        with h5py.File(out / "run.h5") as h5:
            assert sorted(h5["frames"].keys()) == ["00000", "00001", "00002", "00005", "00006"]


def test_a_damaged_energy_row_is_refused_at_a_restart(tmp_path):
    # a cell that is not a number was read as 0, and the restart went on from it (exit 0)
    base = dict(MOTION, name="run", output={"energy": True})
    out = tmp_path / "out"
    run(tmp_path, "first", deck_with(base, 2, {"every": 2}), out)
    lines = (out / "energy.csv").read_text().splitlines()
    number = next(k for k, line in enumerate(lines) if line.startswith("2,"))
    cells = lines[number].split(",")
    cells[6] = "x"
    lines[number] = ",".join(cells)
    (out / "energy.csv").write_text("\n".join(lines) + "\n")
    done = run(tmp_path, "then", deck_with(base, 4), out, extra=["--restart", "latest"], check=False)
    assert done.returncode == 1 and f"energy.csv:{number + 1}: 'x' is not a finite number" in done.stdout, done.stdout


@pytest.mark.parametrize("changed", ["collider_mesh", "cut_curve_table"])
def test_restart_with_a_changed_physics_file_is_refused(tmp_path, changed):
    # Found from outside: a collider's mesh file, a blade's curve table (and a blade's surface, the
    # mesh's tagged faces) were not part of the checkpoint's physics: the restart went on with them
    # changed (the blade then no longer cut), exit 0
    (tmp_path / "c.csv").write_text("t, v\n0, 0\n1, 1\n")
    (tmp_path / "ob.obj").write_text("v -1 -0.6 -1\nv 1 -0.6 -1\nv 0 -0.6 1\nf 1 3 2\n")
    base = dict(BAR, name="run", fixed=[CLAMP])
    if changed == "collider_mesh":
        base["colliders"] = [{"type": "mesh", "file": "ob.obj"}]
    else:
        base["cuts"] = [{"center": [1.0, 0.9, 0.25], "normal": [1, 0, 0], "axis": [0, 1, 0], "size": [0.2, 1.0],
                         "motion": {"translate": {"velocity": [0, -1, 0]}, "curve": {"type": "table", "file": "c.csv"}}}]
    out = tmp_path / "out"
    run(tmp_path, "first", deck_with(base, 2, {"every": 2}), out)
    # unchanged files, the deck named by a relative path from another directory: accepted (the
    # files' resolved paths were hashed with their contents, and such a restart was refused)
    same = write_deck(tmp_path / "same.yaml", deck_with(base, 3))
    (tmp_path / "elsewhere").mkdir()
    proc = subprocess.run([HYPERQN, os.path.relpath(same, tmp_path / "elsewhere"), "-o", str(out), "--restart", "latest"],
                          cwd=tmp_path / "elsewhere", capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    if changed == "collider_mesh":
        (tmp_path / "ob.obj").write_text("v -1 -0.7 -1\nv 1 -0.7 -1\nv 0 -0.7 1\nf 1 3 2\n")
    else:
        (tmp_path / "c.csv").write_text("t, v\n0, 0\n1, 0\n")
    before = tree_digest(out)
    done = run(tmp_path, "then", deck_with(base, 4), out, extra=["--restart", "latest"], check=False)
    section = "files" if changed == "collider_mesh" else "curve_tables"
    assert done.returncode == 1 and f"section(s) {section}" in done.stdout, done.stdout
    assert tree_digest(out) == before


@pytest.mark.parametrize("damage", ["row_removed", "not_a_number"])
def test_a_damaged_reactions_log_is_refused_at_a_restart(tmp_path, damage):
    # a deleted row of the checkpoint's frame was taken, leaving a gap in the log (exit 0)
    base = dict(MOTION, name="run", output={"reactions": True})
    out = tmp_path / "out"
    run(tmp_path, "first", deck_with(base, 2, {"every": 2}), out)
    lines = (out / "reactions.csv").read_text().splitlines()
    number = next(k for k, line in enumerate(lines) if line.startswith("2,") and ",fixed[1]," in line)
    if damage == "row_removed":
        del lines[number]
        said = "reactions.csv has no row of fixed[1] at frame 2"
    else:
        cells = lines[number].split(",")
        cells[4] = "nan"
        lines[number] = ",".join(cells)
        said = f"reactions.csv:{number + 1}: 'nan' is not a finite number"
    (out / "reactions.csv").write_text("\n".join(lines) + "\n")
    done = run(tmp_path, "then", dict(deck_with(base, 4), output={"reactions": True}), out,
               extra=["--restart", "latest"], check=False)
    assert done.returncode == 1 and said in done.stdout, done.stdout


def test_a_series_begun_after_the_checkpoint_goes_at_a_restart(tmp_path):
    # Found from outside: frames in vtu to 3, then XDMF from 3 to 6, then a restart from checkpoint 3
    # in vtu: the XDMF series of the abandoned frames 4-6 stayed, and frame_list took its frames
    base = dict(MOTION, name="run")
    out = tmp_path / "out"
    run(tmp_path, "first", deck_with(base, 3, {"every": 1, "keep": 10}), out)
    run(tmp_path, "xdmf", dict(deck_with(base, 6, {"every": 1, "keep": 10}), output={"format": "xdmf"}), out,
        extra=["--restart", "latest"])
    assert (out / "run.xdmf").exists()
    done = run(tmp_path, "again", deck_with(base, 6), out, extra=["--restart", str(out / "checkpoints" / "checkpoint_3.h5")])
    assert "file(s) of a xdmf series begun after the checkpoint removed" in done.stdout
    assert not (out / "run.xdmf").exists() and not (out / "run.h5").exists()
    assert [n for n, _, _ in frame_list(out)] == list(range(7))
    assert all(path.endswith(".vtu") for _, _, path in frame_list(out))


@pytest.mark.parametrize("ranks", [None, 2])
@pytest.mark.parametrize("fmt", ["vtu", "xdmf"])
def test_a_restart_at_its_last_frame_writes_that_frame(tmp_path, fmt, ranks):
    """Found from outside: a run of 7 frames (output every 3, a checkpoint every 4) restarted from
    its checkpoint at frame 4 as a run of 4 frames steps none, and never wrote its last frame,
    which the uninterrupted 4-frame run writes (the .pvd or .xdmf ended at frame 3). A restart of
    a finished run at its last frame, which wrote it, lists it once."""
    base = dict(BAR, name="run", output={"format": fmt, "every": 3})
    index = "run.pvd" if fmt == "vtu" else "run.xdmf"
    whole, out = tmp_path / "whole", tmp_path / "out"
    run(tmp_path, "whole", deck_with(base, 4), whole, ranks)
    run(tmp_path, "first", deck_with(base, 7, {"every": 4}), out, ranks)
    run(tmp_path, "then", deck_with(base, 4), out, ranks, ["--restart", str(out / "checkpoints" / "checkpoint_4.h5")])
    assert frames_listed(out, index) == frames_listed(whole, index) == [0, 3, 4]
    assert np.array_equal(final_frame(whole).points, final_frame(out).points)
    run(tmp_path, "again", deck_with(base, 4, {"every": 4}), whole, ranks)
    run(tmp_path, "again", deck_with(base, 4, {"every": 4}), whole, ranks, ["--restart", "latest"])
    assert frames_listed(whole, index) == [0, 3, 4]
