"""Checkpoints a cluster job can trust (docs/outputs.md#checkpoints, docs/cluster.md): each fault
found in the field is reproduced here and must end as documented.

- A restart continues only the run that last wrote the directory: a rerun into a used directory
  removes the earlier run's checkpoints, and --restart latest never resumes them (before: the
  earlier run's checkpoint_100 was resumed, leaving a .pvd of missing frames with status ok).
- A full disk during a checkpoint ends every rank with exit 1 naming the path and the reason, at 1
  and 2 ranks (before: 2 ranks hung in HDF5; 1 rank blamed an option).
- No length limit: a .pvd listing past 64 KiB in the checkpoint (before: exit 1 there, near frame
  2,000 of a run named "run": the listing was a 64 KiB HDF5 attribute); here 600 frames of a run
  with a 100-character name, every one written, checkpoint every 100, past 64 KiB near frame 500;
  a SIGTERM after that point exits 3.
- Damage is detected: a flipped byte in positions or velocities, a truncated or garbage file; latest
  falls back to the newest whole checkpoint; a stray checkpoint_999.h5 or a name that does not parse
  does not block it; a FIFO or a directory named as the newest checkpoint is passed over (before:
  a FIFO blocked --restart latest and auto forever); --restart PATH of another run says whose it is.
- Smaller faults: a killed part's temporaries go; a restart with another name or vtk: false leaves
  no .pvd listing abandoned frames; a signal during setup stops before the first frame with a
  checkpoint; a signal after the last frame leaves a complete run that says so.
- docker/hyperqn.slurm, with stand-ins for srun and scontrol: first allocation fresh, requeue
  continues this job's run.

Kills are made deterministic by the test hook -hyperqn_test_kill_after_frame N (the ranks SIGKILL
themselves once frame N and its checkpoint are done) and signals by -hyperqn_test_signal_after_frame N
(SIGTERM to each rank after frame N; 0: during setup).
"""
import os
import shutil
import signal
import subprocess
import time

import h5py
import numpy as np
import pytest

from conftest import HYPERQN, run_hyperqn, write_deck
from test_checkpoint import assert_same_run, iteration_rows, pvd_listing, tree_digest
from test_safe_outputs import check_complete, small_disk
from hyperqn_tools.output import read_checkpoint, read_pvd, read_summary
from hyperqn_tools.paths import REPO

BAR = {
    "name": "run",
    "mesh": {"box": {"size": [4.0, 1.0, 1.0], "cells": [8, 2, 2]}},
    "material": {"model": "neohookean", "youngs_modulus": 1.0e6, "poisson_ratio": 0.3, "density": 1000},
    "fixed": [{"box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 1.01, 1.01]}}],
    "gravity": [0, -9.81, 0],
    "time": {"dt": 1 / 30, "frames": 20},
    "checkpoint": {"every": 5},
}


def deck(tmp_path, file="run", **changes):
    d = dict(BAR, **changes)
    return write_deck(tmp_path / f"{file}.yaml", d)


def killed(path, out, frame, ranks=None, extra=()):
    """The run of `path` into out, killed (SIGKILL, every rank) after `frame`."""
    proc = run_hyperqn([path, "-o", out, "-hyperqn_test_kill_after_frame", str(frame), *extra], ranks=ranks,
                       check=False, timeout=120)
    assert proc.returncode != 0, proc.stdout[-2000:]
    assert read_summary(out)["status"].startswith("incomplete")
    return proc


def assert_restart_after_kill_is_bitwise(tmp_path, deck, ranks=None, frames=6, every=2, kill_after=4, extra=(),
                                         before_restart=None):
    """deck (a dict) run for `frames` with a checkpoint every `every` frames: a run killed
    (SIGKILL, every rank) after frame `kill_after` and restarted from its latest checkpoint equals
    the uninterrupted one in positions, velocities, iterations and the .pvd. extra: more arguments
    of every run; before_restart(out): called on the killed run's output before the restart.
    Returns both outputs."""
    deck = {**deck, "time": {**deck["time"], "frames": frames}, "checkpoint": {"every": every}}
    path = write_deck(tmp_path / "killed.yaml", deck)
    ref = tmp_path / "ref"
    run_hyperqn([path, "-o", ref, *extra], ranks=ranks)
    out = tmp_path / "out"
    killed(path, out, kill_after, ranks, extra)
    if before_restart:
        before_restart(out)
    run_hyperqn([path, "-o", out, "--restart", "latest", *extra], ranks=ranks)
    assert_same_run(ref, out)
    return ref, out


def first_changing_frame(out, column):
    """The first frame whose row in out's topology.csv has `column` > 0."""
    import csv
    with open(out / "topology.csv") as f:
        return min(int(r["frame"]) for r in csv.DictReader(f) if int(r[column]) > 0)


def assert_restart_after_signal_in_a_changing_frame_is_bitwise(tmp_path, deck, frame, ranks=None):
    """deck (a dict) whose frame `frame` begins with a snap or a tear (first_changing_frame), run to
    frame + 2: a signal (SIGUSR1, the test hook) at that frame's first iteration; the checkpoint of
    the frame before holds the change, and the restart must not decide it again (it took the next
    segment or edge: LiveScene::changes_decided_after). The restart equals the uninterrupted run in
    positions, velocities, iterations, the .pvd and topology.csv."""
    deck = {**deck, "time": {**deck["time"], "frames": frame + 2}}
    path = write_deck(tmp_path / "deck.yaml", deck)
    ref = tmp_path / "ref"
    run_hyperqn([path, "-o", ref], ranks=ranks)
    out = tmp_path / "out"
    done = run_hyperqn([path, "-o", out, "-hyperqn_test_signal_in_frame", frame, "-hyperqn_test_signal_at_iteration", 1],
                       ranks=ranks, check=False)
    assert done.returncode == 3, done.stdout[-2000:]
    assert read_checkpoint(out / "checkpoints" / f"checkpoint_{frame - 1}.h5").get("changes_decided") == 1
    run_hyperqn([path, "-o", out, "--restart", "latest"], ranks=ranks)
    assert_same_run(ref, out)
    assert (out / "topology.csv").read_bytes() == (ref / "topology.csv").read_bytes()


def checkpoints(out):
    return sorted(os.listdir(out / "checkpoints"))


@pytest.mark.parametrize("ranks", [None, 2])
def test_restart_never_resumes_an_earlier_run(tmp_path, ranks):
    path = deck(tmp_path)
    ref = tmp_path / "ref"
    run_hyperqn([path, "-o", ref], ranks=ranks)
    out = tmp_path / "out"
    run_hyperqn([path, "-o", out], ranks=ranks)  # the earlier run: checkpoints 15 and 20 remain
    earlier = read_summary(out)["run_id"]
    assert checkpoints(out) == ["checkpoint_15.h5", "checkpoint_20.h5"]
    done = killed(path, out, 8, ranks)  # the rerun: its own checkpoint is 5
    assert f"held an earlier run's output (run {earlier})" in done.stdout and "2 checkpoint(s) removed" in done.stdout
    assert checkpoints(out) == ["checkpoint_5.h5"]
    assert read_summary(out)["run_id"] != earlier
    # A checkpoint of another run copied in: passed over, saying whose it is.
    shutil.copy(ref / "checkpoints" / "checkpoint_20.h5", out / "checkpoints" / "checkpoint_20.h5")
    done = run_hyperqn([path, "-o", out, "--restart", "latest"], ranks=ranks)
    assert "checkpoint_20.h5 is a checkpoint of run" in done.stdout and "passed over" in done.stdout
    assert f"restart from {out}/checkpoints/checkpoint_5.h5" in done.stdout
    check_complete(out)
    assert_same_run(ref, out)
    assert iteration_rows(out)[-1]["frame"] == 20


def test_a_run_killed_before_its_first_checkpoint(tmp_path):
    path = deck(tmp_path)
    out = tmp_path / "out"
    run_hyperqn([path, "-o", out])
    killed(path, out, 3)  # before its checkpoint at 5: nothing of its own to continue
    assert not checkpoints(out)
    done = run_hyperqn([path, "-o", out, "--restart", "latest"], check=False)
    assert done.returncode == 1
    assert f"--restart latest: no whole checkpoint of run {read_summary(out)['run_id']}" in done.stdout
    done = run_hyperqn([path, "-o", out, "--restart", "auto"])
    assert "the deck starts afresh" in done.stdout
    ref = tmp_path / "ref"
    run_hyperqn([path, "-o", ref])
    assert_same_run(ref, out)


def test_restart_from_a_checkpoint_of_another_run_says_whose(tmp_path):
    path = deck(tmp_path)
    a, b = tmp_path / "a", tmp_path / "b"
    run_hyperqn([path, "-o", a])
    run_hyperqn([path, "-o", b])
    before = tree_digest(b)
    foreign = a / "checkpoints" / "checkpoint_15.h5"
    done = run_hyperqn([path, "-o", b, "--restart", foreign], check=False)
    assert done.returncode == 1
    run_a = read_summary(a)["run_id"]
    assert f"cannot restart from {foreign} into {b}: it is a checkpoint of run {run_a} (deck {path}" in done.stdout
    assert "at frame 15" in done.stdout and f"holds the output of run {read_summary(b)['run_id']}" in done.stdout
    assert tree_digest(b) == before


@pytest.fixture
def disk_150k(tmp_path):
    with small_disk(tmp_path / "disk", "150k") as mnt:
        yield mnt


@pytest.mark.parametrize("ranks", [None, 2])
def test_full_disk_during_a_checkpoint(disk_150k, tmp_path, ranks):
    # The reproducer: input/bar.yaml without VTK, a checkpoint every frame, a 150 KiB disk.
    path = write_deck(tmp_path / "bar.yaml", dict(load_bar(), output={"vtk": False}, checkpoint={"every": 1}))
    out = disk_150k / "out"
    start = time.time()
    done = run_hyperqn([path, "-o", out], ranks=ranks, check=False, timeout=60)
    assert time.time() - start < 30
    assert done.returncode == 1, done.stdout[-3000:]
    assert f"hyperqn: error: cannot write {out}/checkpoints/checkpoint_" in done.stdout, done.stdout[-3000:]
    assert "No space left on device" in done.stdout
    assert "HDF5-DIAG" not in done.stdout and "tao_lmvm" not in done.stdout  # HDF5's stack is the reason, not noise
    assert not [n for n in os.listdir(out / "checkpoints") if n.startswith(".")]  # the temporary is gone
    check_complete(out)  # iterations.csv: whole rows only
    # What is left restarts (once there is room again).
    newest = checkpoints(out)[-1]
    assert read_checkpoint(out / "checkpoints" / newest)["frame"] >= 1


def test_full_disk_at_every_point_of_a_checkpoint(tmp_path):
    """Disks from nearly empty to just large enough, so that the space runs out at every stage of
    a checkpoint write; before, HDF5 crashed at exit (SIGSEGV) when the file could not be closed."""
    path = deck(tmp_path, output={"vtk": False}, checkpoint={"every": 1, "keep": 2})
    outcomes = set()
    for k, size in enumerate(range(16, 102, 6)):  # to 100k: the run's lock file (.hyperqn.lock) takes a 4k page too
        with small_disk(tmp_path / f"disk{k}", f"{size}k") as mnt:
            done = run_hyperqn([path, "-o", mnt / "out"], ranks=None, check=False, timeout=60)
            assert done.returncode in (0, 1), (size, done.returncode, done.stdout[-2000:])
            if done.returncode == 1:
                assert f"hyperqn: error: cannot write {mnt}/out/" in done.stdout, done.stdout[-2000:]
                assert "No space left on device" in done.stdout
            outcomes.add(done.returncode)
    assert outcomes == {0, 1}  # the sizes span both


def test_full_disk_leaves_whole_rows_in_iterations_csv(tmp_path):
    """Only iterations.csv grows (no VTK, no checkpoints): the write that fills the disk is cut back
    to the last whole row (before, the file ended mid-row)."""
    path = deck(tmp_path, time={"dt": 1 / 30, "frames": 2000}, output={"vtk": False}, checkpoint={"every": 0})
    with small_disk(tmp_path / "disk", "24k") as mnt:
        out = mnt / "out"
        done = run_hyperqn([path, "-o", out], ranks=None, check=False, timeout=60)
        assert done.returncode == 1, done.stdout[-2000:]
        assert f"hyperqn: error: cannot write {out}/iterations.csv: No space left on device" in done.stdout
        text = (out / "iterations.csv").read_text()
        assert text.endswith("\n") and len(text) > 10000
        assert all(len(row.split(",")) == 7 for row in text.splitlines())


def load_bar():
    import yaml
    with open(os.path.join(REPO, "input", "bar.yaml")) as f:
        return dict(yaml.safe_load(f), name="bar")


# The .pvd listing's lines ("time file") hold the name: with the longest name a deck may have
# (100 characters) it passes 64 KiB near frame 500 instead of 2,000 (a cost that grows with the
# frames squared: the .pvd is rewritten whole at every frame).
LONG_NAME = "long_" + "n" * 95
LONG = {
    "name": LONG_NAME,
    "mesh": {"box": {"size": [1.0, 0.25, 0.25], "cells": [4, 1, 1]}},
    "material": {"model": "neohookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 1000},
    "fixed": [{"box": {"min": [-0.01, -1, -1], "max": [0.01, 1, 1]}}],
    "gravity": [0, -9.81, 0],
    "time": {"dt": 1 / 30, "frames": 600},
    "checkpoint": {"every": 100},
}


@pytest.mark.parametrize("ranks", [None, 2])
def test_no_length_limit(tmp_path, ranks):
    path = write_deck(tmp_path / "long.yaml", LONG)
    out = tmp_path / "out"
    run_hyperqn([path, "-o", out], ranks=ranks)
    assert checkpoints(out) == ["checkpoint_500.h5", "checkpoint_600.h5"]
    listing = read_checkpoint(out / "checkpoints" / "checkpoint_600.h5")["writer_vtk_pvd"].splitlines()
    assert len(listing) == 601 and len("\n".join(listing)) > 65536
    assert len(read_pvd(out / f"{LONG_NAME}.pvd")) == 601
    if ranks is None:  # a signal past 64 KiB of listing: a checkpoint, exit 3, and the restart finishes
        stopped = tmp_path / "stopped"
        done = run_hyperqn([path, "-o", stopped, "-hyperqn_test_signal_after_frame", "550"], check=False)
        assert done.returncode == 3, done.stdout[-2000:]
        assert checkpoints(stopped)[-1] == "checkpoint_550.h5"
        listing = read_checkpoint(stopped / "checkpoints" / "checkpoint_550.h5")["writer_vtk_pvd"]
        assert len(listing) > 65536
        run_hyperqn([path, "-o", stopped, "--restart", "latest"])
        assert_same_run(out, stopped)


def damaged_copy(src, dst, dataset, flip=True):
    """dst: src with one bit flipped in the first chunk of `dataset` (or the file cut in half)."""
    data = bytearray(open(src, "rb").read())
    if flip:
        with h5py.File(src, "r") as f:
            offset = f[dataset].id.get_chunk_info(0).byte_offset
        data[offset + 40] ^= 0x04
    else:
        data = data[: len(data) // 2]
    open(dst, "wb").write(bytes(data))


@pytest.mark.parametrize("dataset", ["positions", "velocities", None])
def test_damaged_newest_checkpoint_falls_back(tmp_path, dataset):
    first = deck(tmp_path, "first", time={"dt": 1 / 30, "frames": 15})
    path = deck(tmp_path)
    ref = tmp_path / "ref"
    run_hyperqn([path, "-o", ref])
    out = tmp_path / "out"
    run_hyperqn([first, "-o", out])  # checkpoints 10 and 15
    newest = out / "checkpoints" / "checkpoint_15.h5"
    damaged_copy(newest, tmp_path / "bad.h5", dataset, flip=dataset is not None)
    shutil.copy(tmp_path / "bad.h5", newest)
    (out / "checkpoints" / "checkpoint_999.h5").write_bytes(b"not a checkpoint\n")  # a stray file
    (out / "checkpoints" / "checkpoint_x.h5").write_bytes(b"")  # a name that does not parse
    done = run_hyperqn([path, "-o", out, "--restart", "latest"])
    assert "checkpoint_999.h5 is damaged or not a checkpoint" in done.stdout
    assert "checkpoint_x.h5 is not named as a checkpoint" in done.stdout
    what = "data error detected by Fletcher32 checksum" if dataset else ""
    assert f"checkpoint_15.h5 is damaged or not a checkpoint ({dataset + ': ' + what if dataset else ''}" in done.stdout
    assert f"falling back to {out}/checkpoints/checkpoint_10.h5" in done.stdout
    assert_same_run(ref, out)
    check_complete(out)


@pytest.mark.parametrize("item", ["velocities", "physics"])
def test_values_changed_behind_hdf5s_checksums(tmp_path, item):
    """What HDF5 reads without an error can still be wrong (a damaged chunk index in its earliest
    format has no checksum: zeros came back, found by the fault campaign): the stored checksums of
    the values and of the texts catch it. Here the file is rewritten with valid HDF5 checksums."""
    first = deck(tmp_path, "first", time={"dt": 1 / 30, "frames": 15})
    path = deck(tmp_path)
    ref = tmp_path / "ref"
    run_hyperqn([path, "-o", ref])
    out = tmp_path / "out"
    run_hyperqn([first, "-o", out])
    with h5py.File(out / "checkpoints" / "checkpoint_15.h5", "r+") as f:
        if item == "velocities":
            f["velocities"][0, 0] = 0.0 if f["velocities"][0, 0] != 0 else 1.0
            f["velocities"][40, 1] = 0.0
        else:
            text = f["physics"][()]
            text[0] = ord("x") if text[0] != ord("x") else ord("y")
            f["physics"][...] = text
    done = run_hyperqn([path, "-o", out, "--restart", "latest"])
    reason = "velocities: checksum" if item == "velocities" else "its texts: checksum"
    assert f"checkpoint_15.h5 is damaged or not a checkpoint ({reason}" in done.stdout, done.stdout[-2000:]
    assert f"falling back to {out}/checkpoints/checkpoint_10.h5" in done.stdout
    assert_same_run(ref, out)


@pytest.mark.parametrize("mode", ["latest", "auto"])
def test_a_fifo_or_directory_named_as_a_checkpoint_is_passed_over(tmp_path, mode):
    """A FIFO named as the newest checkpoint (before: --restart latest and auto blocked forever in
    H5Fopen, waiting for a writer) and a directory named as one: each passed over with a warning,
    the restart continues checkpoint 15 and equals the uninterrupted run; --restart naming the FIFO
    is an error. Every run has a timeout, so that a hang fails the test."""
    first = deck(tmp_path, "first", time={"dt": 1 / 30, "frames": 15})
    path = deck(tmp_path)
    ref = tmp_path / "ref"
    run_hyperqn([path, "-o", ref], timeout=60)
    out = tmp_path / "out"
    run_hyperqn([first, "-o", out], timeout=60)  # checkpoints 10 and 15
    fifo = out / "checkpoints" / "checkpoint_45.h5"
    os.mkfifo(fifo)
    (out / "checkpoints" / "checkpoint_30.h5").mkdir()
    done = run_hyperqn([path, "-o", out, "--restart", fifo], check=False, timeout=60)
    assert done.returncode == 1 and f"cannot restart from {fifo}: not a regular file" in done.stdout, done.stdout[-2000:]
    done = run_hyperqn([path, "-o", out, "--restart", mode], timeout=60)
    assert f"{fifo} is not a regular file: passed over" in done.stdout, done.stdout[-2000:]
    assert f"{out}/checkpoints/checkpoint_30.h5 is not a regular file: passed over" in done.stdout
    assert f"restart from {out}/checkpoints/checkpoint_15.h5" in done.stdout
    assert_same_run(ref, out)


def test_checkpoint_past_the_decks_frames_is_refused(tmp_path):
    out = tmp_path / "out"
    run_hyperqn([deck(tmp_path), "-o", out])  # checkpoints 15 and 20
    shorter = deck(tmp_path, "shorter", time={"dt": 1 / 30, "frames": 12})
    for mode in ("latest", "auto"):
        done = run_hyperqn([shorter, "-o", out, "--restart", mode], check=False)
        assert done.returncode == 1
        assert "checkpoint_20.h5: its frame 20 is past the deck's time.frames 12" in done.stdout


def test_damaged_only_checkpoint_is_an_error(tmp_path):
    path = deck(tmp_path, checkpoint={"every": 5, "keep": 1})
    out = tmp_path / "out"
    killed(path, out, 7)
    damaged_copy(out / "checkpoints" / "checkpoint_5.h5", tmp_path / "bad.h5", "positions")
    shutil.copy(tmp_path / "bad.h5", out / "checkpoints" / "checkpoint_5.h5")
    done = run_hyperqn([path, "-o", out, "--restart", "latest"], check=False)
    assert done.returncode == 1 and "--restart latest: no whole checkpoint of run" in done.stdout
    done = run_hyperqn([path, "-o", out, "--restart", out / "checkpoints" / "checkpoint_5.h5"], check=False)
    assert done.returncode == 1
    assert "cannot restart from" in done.stdout and "positions: data error detected by Fletcher32 checksum" in done.stdout


def test_restart_removes_a_killed_parts_temporaries(tmp_path):
    path = deck(tmp_path)
    out = tmp_path / "out"
    killed(path, out, 7)
    (out / ".run_00008.vtu.tmp-12345").write_text("<VTKFile")  # what a kill inside a write leaves
    (out / "checkpoints" / ".checkpoint_10.h5.tmp-12345").write_bytes(b"\x89HDF")
    run_hyperqn([path, "-o", out, "--restart", "latest"])
    assert not [n for n in os.listdir(out) if n.startswith(".")]
    assert not [n for n in os.listdir(out / "checkpoints") if n.startswith(".")]


@pytest.mark.parametrize("change", ["name", "vtk"])
def test_restart_with_another_name_or_without_vtk(tmp_path, change):
    path = deck(tmp_path)
    out = tmp_path / "out"
    killed(path, out, 8)  # frames 0..8 written, checkpoint at 5
    other = deck(tmp_path, "other", **({"name": "renamed"} if change == "name" else {"output": {"vtk": False}}))
    done = run_hyperqn([other, "-o", out, "--restart", "latest"])
    assert [n for n in os.listdir(out) if n.endswith(".pvd")] == ["run.pvd"]
    listed = [os.path.basename(f) for _, f in read_pvd(out / "run.pvd")]
    if change == "name":
        assert "goes on as run.pvd, the name it started with (the deck now says renamed)" in done.stdout
        assert listed == [f"run_{k:05d}.vtu" for k in range(21)]
    else:
        assert "output.vtk is false" in done.stdout
        assert listed == [f"run_{k:05d}.vtu" for k in range(6)]  # cut back to the checkpoint's frame
    assert not [n for n in os.listdir(out) if n.startswith("renamed")]
    check_complete(out)


def test_restart_with_another_name_and_format_names_the_index_it_writes(tmp_path):
    # vtu as run, then xdmf as run, then vtu as renamed: the vtu series goes on as run.pvd, but
    # the console said "later frames go to out/renamed.pvd"
    out = tmp_path / "out"
    killed(deck(tmp_path), out, 8)  # checkpoint 5: the vtu series
    killed(deck(tmp_path, "xdmf", output={"format": "xdmf"}), out, 13, extra=["--restart", "latest"])  # checkpoint 10: both
    done = run_hyperqn([deck(tmp_path, "renamed", name="renamed"), "-o", out, "--restart", "latest"])
    assert f"output.format is now vtu: {out}/run.xdmf stays as it was at frame 10; later frames go to {out}/run.pvd" \
        in done.stdout, done.stdout
    frames = [*range(6), *range(11, 21)]  # frames 6-10 are in run.xdmf
    assert [os.path.basename(f) for _, f in read_pvd(out / "run.pvd")] == [f"run_{k:05d}.vtu" for k in frames]
    assert not [n for n in os.listdir(out) if n.startswith("renamed")]


def test_signal_during_setup_stops_before_the_first_frame(tmp_path):
    path = deck(tmp_path)
    out = tmp_path / "out"
    done = run_hyperqn([path, "-o", out, "-hyperqn_test_signal_after_frame", "0"], check=False)
    assert done.returncode == 3, done.stdout[-2000:]
    assert read_summary(out)["status"].startswith("interrupted: SIGTERM after frame 0 of 20")
    assert checkpoints(out) == ["checkpoint_0.h5"]
    run_hyperqn([path, "-o", out, "--restart", "latest"])
    ref = tmp_path / "ref"
    run_hyperqn([path, "-o", ref])
    assert_same_run(ref, out)


@pytest.mark.parametrize("ranks", [None, 2])
def test_signal_after_the_last_frame(tmp_path, ranks):
    path = deck(tmp_path)
    out = tmp_path / "out"
    done = run_hyperqn([path, "-o", out, "-hyperqn_test_signal_after_frame", "20"], ranks=ranks)
    summary = read_summary(out)
    assert summary["status"] == "ok" and summary["signal"] == "SIGTERM" and summary["frames"] == 20
    assert "SIGTERM arrived after the last frame had begun: the run is complete" in done.stdout


def test_slurm_script_is_safe_by_construction(tmp_path):
    """docker/hyperqn.slurm with stand-ins: srun runs the binary, scontrol records the requeue."""
    bindir = tmp_path / "bin"
    bindir.mkdir()
    (bindir / "srun").write_text('#!/bin/bash\nshift  # --mpi=pmix\nexec "$@"\n')
    (bindir / "scontrol").write_text(f'#!/bin/bash\necho "$@" >> {tmp_path}/requeued\n')
    for f in ("srun", "scontrol"):
        os.chmod(bindir / f, 0o755)
    work = tmp_path / "work"
    (work / "build").mkdir(parents=True)
    os.symlink(HYPERQN, work / "build" / "hyperqn")
    # Long enough (some 2 s) for the signal to land mid-run.
    path = deck(tmp_path, time={"dt": 1 / 30, "frames": 3000}, output={"every": 50}, checkpoint={"every": 100})
    out = tmp_path / "out"
    ref = tmp_path / "ref"
    run_hyperqn([path, "-o", ref])
    # An earlier run of the same physics left in OUT, with checkpoints up to frame 3100.
    run_hyperqn([deck(tmp_path, "earlier", time={"dt": 1 / 30, "frames": 3100}, output={"every": 50},
                      checkpoint={"every": 100}), "-o", out])
    env = {**os.environ, "PATH": f"{bindir}:{os.environ['PATH']}", "SLURM_JOB_ID": "77"}
    env.pop("SLURM_RESTART_COUNT", None)
    script = os.path.join(REPO, "docker", "hyperqn.slurm")

    def allocation(restart_count, args=()):
        e = dict(env, **({"SLURM_RESTART_COUNT": str(restart_count)} if restart_count else {}))
        return subprocess.run(["bash", script, path, str(out), *args], cwd=work, env=e, capture_output=True,
                              text=True, timeout=120)

    # First allocation: fresh, even though OUT holds a run of the same physics with checkpoints
    # up to frame 30; stopped by SIGUSR1 (as Slurm's --signal=B:USR1 would) -> exit 3 -> requeue.
    proc = subprocess.Popen(["bash", script, path, str(out)], cwd=work, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    deadline = time.time() + 60
    while "checkpoint_100.h5" not in os.listdir(out / "checkpoints") and time.time() < deadline:
        time.sleep(0.01)
    proc.send_signal(signal.SIGUSR1)
    text, _ = proc.communicate(timeout=120)
    assert proc.returncode == 0, text[-2000:]
    assert "earlier run's output" in text
    assert (tmp_path / "requeued").read_text().split() == ["requeue", "77"]
    assert read_summary(out)["status"].startswith("interrupted: SIGUSR1")
    # The requeued allocation continues this job's run to its end.
    second = allocation(1)
    assert second.returncode == 0, second.stdout[-2000:]
    assert "restart from" in second.stdout
    assert_same_run(ref, out)
