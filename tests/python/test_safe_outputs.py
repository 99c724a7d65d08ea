"""Safe outputs (issue "cluster runs"): every output file appears whole (written to a temporary
and renamed), iterations.csv holds complete rows after a kill, summary.json is always valid JSON,
a rerun into a directory replaces the earlier run's files (and only those), and a write failure
(unwritable directory, full disk) ends the run with exit 1 naming the path, at 1 and 2 ranks,
without a hang. docs/outputs.md, "Guarantees"."""
import contextlib
import copy
import csv
import json
import os
import random
import signal
import subprocess
import time
import xml.etree.ElementTree as ET

import pytest

from conftest import HYPERQN, MPIEXEC, run_hyperqn, write_deck
from hyperqn_tools.paths import REPO
from hyperqn_tools import launch, sessions
from hyperqn_tools.output import read_frames, read_pvd, read_summary
from test_bad_input import GOOD

ITERATION_COLUMNS = 7


def small_deck(name, frames):
    deck = copy.deepcopy(GOOD)
    deck["name"] = name
    deck["time"]["frames"] = frames
    deck["gravity"] = [0, -9.81, 0]
    return deck


def slow_deck(name):
    """Every frame written, some 40 ms per frame on one core (measured 2026-11-25: 41 ms, 2.6 s for
    60 frames, which a kill 0.1-2 s after a restart's first new checkpoint could outlast): 150
    frames, some 6 s, so a kill lands mid-run."""
    deck = small_deck(name, 150)
    deck["mesh"] = {"box": {"size": [4.0, 1.0, 1.0], "cells": [24, 6, 6]}}
    deck["fixed"] = [{"box": {"min": [-0.01, -1, -1], "max": [0.01, 2, 2]}}]
    deck["solver"] = {"iterations": 40, "grad_rtol": 1e-12, "grad_atol": 1e-14}
    return deck


def parses(path):
    ET.parse(path)  # raises on a truncated file
    return True


def check_complete(outdir):
    """Everything hyperqn left in outdir is whole: every .pvd/.pvtu/.vtu parses, the .pvd lists
    only existing files (no temporaries), iterations.csv has only complete rows, summary.json is
    absent or valid JSON."""
    names = os.listdir(outdir)
    for name in names:
        if name.endswith((".pvd", ".pvtu", ".vtu")) and not name.startswith("."):
            assert parses(os.path.join(outdir, name)), name
    pvds = [n for n in names if n.endswith(".pvd")]
    assert len(pvds) <= 1, pvds
    if pvds:
        for _, path in read_pvd(os.path.join(outdir, pvds[0])):
            assert not os.path.basename(path).startswith("."), path
            assert os.path.exists(path), path
        read_frames(outdir)  # meshio reads every listed frame and piece
    if "iterations.csv" in names:
        text = open(os.path.join(outdir, "iterations.csv")).read()
        assert text == "" or text.endswith("\n"), text[-200:]
        rows = list(csv.reader(text.splitlines()))
        assert all(len(r) == ITERATION_COLUMNS for r in rows), [r for r in rows if len(r) != ITERATION_COLUMNS]
        for r in rows[1:]:
            [float(x) for x in r]
    if "summary.json" in names:
        return json.load(open(os.path.join(outdir, "summary.json")))
    return None


@pytest.mark.parametrize("first_ranks,second_ranks,same_name", [(2, None, False), (None, 2, True)])
def test_rerun_replaces_the_earlier_run(tmp_path, first_ranks, second_ranks, same_name):
    out = tmp_path / "out"
    first = write_deck(tmp_path / "first.yaml", small_deck("first", 6))
    second_name = "first" if same_name else "second"
    second = write_deck(tmp_path / "second.yaml", small_deck(second_name, 3))
    run_hyperqn([first, "-o", out], ranks=first_ranks, timeout=120)
    # A user's files, and what an interrupted write of the first run would have left.
    (out / "notes.txt").write_text("mine\n")
    (out / "scan.vtu").write_text("not hyperqn's\n")
    (out / "other.pvd").write_text('<VTKFile type="Collection"><Collection>'
                                   '<DataSet file="scan.vtu"/></Collection></VTKFile>\n')
    (out / ".first_00004.vtu.tmp-12345").write_text("<VTKFile")
    proc = run_hyperqn([second, "-o", out], ranks=second_ranks, timeout=120)
    assert "earlier run's output" in proc.stdout, proc.stdout[-2000:]

    names = set(os.listdir(out))
    assert (out / "notes.txt").read_text() == "mine\n"
    assert (out / "scan.vtu").read_text() == "not hyperqn's\n"
    assert "other.pvd" in names  # it lists no frames of its own name: not hyperqn's
    assert ".first_00004.vtu.tmp-12345" not in names
    ours = sorted(n for n in names if n.endswith(".pvd") and n != "other.pvd")
    assert ours == [f"{second_name}.pvd"]
    # Only the second run's frames, on disk and in the .pvd.
    listed = [os.path.basename(p) for _, p in read_pvd(out / ours[0])]
    ext = ".pvtu" if second_ranks == 2 else ".vtu"
    assert listed == [f"{second_name}_{k:05d}{ext}" for k in range(4)]
    frames_on_disk = sorted(n for n in names if n.endswith((".vtu", ".pvtu")) and n != "scan.vtu")
    pieces = [f"{second_name}_{k:05d}_{r}.vtu" for k in range(4) for r in range(2)] if second_ranks == 2 else []
    assert frames_on_disk == sorted(listed + pieces)
    (out / "other.pvd").unlink()  # read_frames wants the one .pvd of the run
    assert [k for k, _ in read_frames(out)] == [0, 1, 2, 3]
    summary = read_summary(out)
    assert summary["frames"] == 3 and summary["status"] == "ok"
    rows = list(csv.DictReader(open(out / "iterations.csv")))
    assert {int(r["frame"]) for r in rows} == {1, 2, 3}


@pytest.mark.parametrize("fmt,ranks", [("xdmf", None), ("xdmf", 2), ("vtu", None), ("vtu", 2)])
def test_a_users_file_under_the_series_name_is_refused(tmp_path, fmt, ranks):
    """A user's file under the name the run's series takes, which is not a run's output (docs/outputs.md):
    a tb.h5 with no tb.xdmf beside it, a tb.pvd that lists other/run_00000.vtu. The run refuses before
    it writes anything, naming it (before: exit 0, the file replaced, the user's dataset gone); once it
    is moved, the run and a rerun (which clears the first run's tb.h5 or tb.pvd) go on."""
    import h5py
    out = tmp_path / "D"
    out.mkdir()
    (out / "notes.txt").write_text("mine\n")
    if fmt == "xdmf":
        mine = "tb.h5"
        with h5py.File(out / mine, "w") as f:
            f["my_results"] = [1.5, 2.5, 3.5]
    else:
        mine = "tb.pvd"
        (out / mine).write_text('<VTKFile type="Collection"><Collection>'
                                '<DataSet file="other/run_00000.vtu"/></Collection></VTKFile>\n')
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    deck = small_deck("tb", 2)
    deck["output"] = {"format": fmt}
    path = write_deck(tmp_path / "tb.yaml", deck)
    proc = run_hyperqn([path, "-o", out], ranks=ranks, check=False, timeout=120)
    assert proc.returncode == 1, proc.stdout[-2000:]
    assert f"hyperqn: error: {out}/{mine} is not a run's output" in proc.stdout, proc.stdout[-2000:]
    assert "choose another -o or another name, or move or remove the file" in proc.stdout
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before  # nothing written, nothing removed
    if fmt == "xdmf":
        with h5py.File(out / mine, "r") as f:
            assert list(f) == ["my_results"] and list(f["my_results"][()]) == [1.5, 2.5, 3.5]
    (out / mine).rename(tmp_path / mine)
    for _ in range(2):
        proc = run_hyperqn([path, "-o", out], ranks=ranks, timeout=120)
    assert "held an earlier run's output" in proc.stdout, proc.stdout[-2000:]
    assert read_summary(out)["status"] == "ok" and (out / "notes.txt").read_text() == "mine\n"
    if fmt == "xdmf":
        with h5py.File(out / "tb.h5", "r") as f:
            assert sorted(f) == ["frames", "mesh"] and sorted(f["frames"]) == ["00000", "00001", "00002"]
    else:
        assert len(read_pvd(out / "tb.pvd")) == 3
    if fmt == "xdmf":  # a run's tb.h5 without its tb.xdmf (a run killed in its first frame leaves one)
        (out / "tb.xdmf").unlink()
        proc = run_hyperqn([path, "-o", out], ranks=ranks, timeout=120)
        assert read_summary(out)["status"] == "ok" and (out / "tb.xdmf").exists()


def test_a_users_file_under_a_restarts_new_series_name_is_refused(tmp_path):
    """A restart that switches output.format from vtu to xdmf starts an XDMF series: a user's tb.h5
    there is refused as for a new run, nothing changed (before: overwritten); moved, the restart goes on."""
    import h5py
    out = tmp_path / "D"
    deck = small_deck("tb", 3)
    deck["checkpoint"] = {"every": 2}
    run_hyperqn([write_deck(tmp_path / "tb.yaml", deck), "-o", out], timeout=120)
    with h5py.File(out / "tb.h5", "w") as f:
        f["my_results"] = [1.5]
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    deck["output"] = {"format": "xdmf"}
    path = write_deck(tmp_path / "tbx.yaml", deck)
    proc = run_hyperqn([path, "-o", out, "--restart", "latest"], check=False, timeout=120)
    assert proc.returncode == 1 and f"{out}/tb.h5 is not a run's output" in proc.stdout, proc.stdout[-2000:]
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()} == before
    (out / "tb.h5").rename(tmp_path / "tb.h5")
    proc = run_hyperqn([path, "-o", out, "--restart", "latest"], timeout=120)
    assert "output.format is now xdmf" in proc.stdout, proc.stdout[-2000:]
    with h5py.File(out / "tb.h5", "r") as f:
        assert sorted(f["frames"]) == ["00003"]
    assert len(read_pvd(out / "tb.pvd")) == 3  # frames 0-2, as at the checkpoint


def hyperqn_pids(session):
    """The hyperqn processes of a session (mpiexec started with start_new_session)."""
    return sessions.members(session, "hyperqn")


def run_and_kill(args, ranks, ready, rng):
    """Starts hyperqn with args, waits until ready() (at most 60 s), then kill -9s every rank at a
    random moment of the next 0.1-2 s, and makes sure none is left running."""
    cmd = launch.command(args, ranks, HYPERQN, MPIEXEC)
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            env={**os.environ, **launch.MPI_ENV}, start_new_session=True)
    try:
        start = time.time()
        while not ready() and time.time() - start < 60 and proc.poll() is None:
            time.sleep(0.05)
        time.sleep(rng.uniform(0.1, 2.0))
        assert proc.poll() is None, "the run ended before the kill: make the deck slower"
        pids = [proc.pid] if ranks is None else hyperqn_pids(proc.pid)
        assert pids, "no hyperqn process found"
        sessions.send(pids, signal.SIGKILL)
    finally:
        # Open MPI may leave mpiexec or another rank running: end them by their ids.
        deadline = time.time() + 10
        while time.time() < deadline and (hyperqn_pids(proc.pid) or proc.poll() is None):
            sessions.send(hyperqn_pids(proc.pid), signal.SIGKILL)  # one may end meanwhile
            if proc.poll() is None and ranks is not None and not hyperqn_pids(proc.pid):
                proc.kill()
            time.sleep(0.1)
        proc.wait(timeout=10)
    assert not hyperqn_pids(proc.pid), "a rank is still running"


def pvd_written_since(out, started):
    """Whether a .pvd in out was written at or after time `started` (an earlier run's stays until
    the next run clears the directory, which under load may come after the first look)."""
    for path in out.glob("*.pvd"):
        try:
            if path.stat().st_mtime >= started:
                return True
        except FileNotFoundError:  # removed meanwhile
            pass
    return False


@pytest.mark.parametrize("ranks", [None, 2])
def test_kill_leaves_complete_files(tmp_path, ranks):
    deck = write_deck(tmp_path / "slow.yaml", slow_deck("slow"))
    rng = random.Random(20240611 + (ranks or 1))
    out = tmp_path / "out"
    for trial in range(3):
        started = time.time()
        run_and_kill([deck, "-o", out], ranks, lambda: pvd_written_since(out, started), rng)  # after its first frame
        summary = check_complete(out)
        if summary is not None:
            assert summary["status"].startswith("incomplete"), summary["status"]
        assert list(out.glob("*.pvd")), "the killed run wrote no frame"
    # The next run starts from that directory and leaves only its own, complete files.
    run_hyperqn([write_deck(tmp_path / "quick.yaml", small_deck("quick", 2)), "-o", out], ranks=ranks, timeout=120)
    assert not [n for n in os.listdir(out) if n.startswith(".") or n.startswith("slow")]
    assert check_complete(out)["status"] == "ok"


def assert_write_failure(proc, fragment, outdir):
    assert proc.returncode == 1, proc.stdout[-3000:]
    assert "hyperqn: error: cannot " in proc.stdout and fragment in proc.stdout, proc.stdout[-3000:]
    summary = outdir / "summary.json"
    if summary.exists():
        status = json.loads(summary.read_text())["status"]
        assert status.startswith(("error", "incomplete")), status


@pytest.mark.parametrize("ranks", [None, 2])
def test_unwritable_output_directory(tmp_path, ranks):
    # Root ignores permissions: a path below a regular file cannot be created by anyone.
    (tmp_path / "afile").write_text("")
    deck = write_deck(tmp_path / "deck.yaml", small_deck("deck", 2))
    out = tmp_path / "afile" / "out"
    proc = run_hyperqn([deck, "-o", out], ranks=ranks, check=False, timeout=60)
    assert_write_failure(proc, str(out), out)


@contextlib.contextmanager
def held_by_another(directory):
    """directory's lock held, as another run (of other.yaml) would hold it, while in the context."""
    import fcntl
    with open(directory / ".hyperqn.lock", "w") as held:
        fcntl.flock(held, fcntl.LOCK_EX)
        held.write("pid 4242 on host elsewhere, started now, deck other.yaml\n")
        held.flush()
        yield


def started(args, ranks, until):
    """hyperqn args launched in a session of its own, once until() holds (it must still run then)."""
    proc = subprocess.Popen(launch.command(args, ranks, HYPERQN, MPIEXEC), stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, env={**os.environ, **launch.MPI_ENV},
                            start_new_session=True)
    deadline = time.time() + 60
    while not until() and time.time() < deadline and proc.poll() is None:
        time.sleep(0.02)
    return proc


@contextlib.contextmanager
def small_disk(mnt, size):
    """A tmpfs of `size` (e.g. "200k") mounted at mnt while in the context; skips the test if this
    machine does not let us mount one."""
    mnt.mkdir()
    try:
        done = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(mnt)],
                              capture_output=True, text=True, timeout=20)
    except (OSError, subprocess.TimeoutExpired) as e:
        pytest.skip(f"cannot mount a tmpfs: {e}")
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs: {done.stderr.strip()}")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], timeout=20)


@pytest.fixture
def full_disk(tmp_path):
    """A 200 kB tmpfs."""
    with small_disk(tmp_path / "full", "200k") as mnt:
        yield mnt


@pytest.mark.parametrize("ranks", [None, 2])
def test_full_disk(full_disk, tmp_path, ranks):
    deck = slow_deck("full")
    deck["time"]["frames"] = 20
    deck_path = write_deck(tmp_path / "full.yaml", deck)
    out = full_disk / "out"
    start = time.time()
    proc = run_hyperqn([deck_path, "-o", out], ranks=ranks, check=False, timeout=60)
    assert time.time() - start < 30
    assert_write_failure(proc, str(out) + "/full_0000", out)
    assert "No space left on device" in proc.stdout
    check_complete(out)


@pytest.mark.parametrize("ranks", [None, 2])
def test_full_disk_during_a_study(tmp_path, ranks):
    """The study's files are rank 0's: its failure ends every rank, naming the path."""
    with small_disk(tmp_path / "disk", "40k") as mnt:
        out = mnt / "study"
        proc = run_hyperqn(["study", os.path.join(REPO, "tests", "decks", "study_small.yaml"), "-o", out],
                           ranks=ranks, check=False, timeout=120)
        assert proc.returncode == 1, proc.stdout[-3000:]
        assert f"hyperqn: error: cannot write {out}/" in proc.stdout and "No space left on device" in proc.stdout



@pytest.mark.parametrize("ranks", [None, 2])
def test_a_second_run_into_a_directory_in_use_is_refused(tmp_path, ranks):
    # Two runs into one directory at once: the second removed the first's files and both exited 0,
    # the .pvd listing missing frames, summary.json of one run beside iterations.csv of the other.
    # Now the second is refused (exit 1, naming the directory and the first's pid and host) while
    # the first holds the directory's lock; the first ends whole; a kill -9 leaves nothing stale.
    out = tmp_path / "out"
    deck = slow_deck("first")
    deck["time"]["frames"] = 15  # some 0.6 s at 1 rank; stopped (SIGSTOP) while the second tries
    first = write_deck(tmp_path / "first.yaml", deck)
    second = write_deck(tmp_path / "second.yaml", small_deck("second", 2))
    proc = started([first, "-o", out], ranks, lambda: (out / "first.pvd").exists())
    try:
        assert proc.poll() is None, "the first run ended before the second started: make it slower"
        pids = [proc.pid] if ranks is None else hyperqn_pids(proc.pid)
        sessions.send(pids, signal.SIGSTOP)  # it holds the directory, whatever the machine's speed
        try:
            refused = run_hyperqn([second, "-o", out], ranks=ranks, check=False, timeout=60)
        finally:
            sessions.send(pids, signal.SIGCONT)
        assert refused.returncode == 1, refused.stdout[-2000:]
        said = f"hyperqn: error: the output directory {out} is in use by another run (pid "
        assert said in refused.stdout, refused.stdout[-2000:]
        assert any(f"(pid {pid} on host " in refused.stdout for pid in pids), (pids, refused.stdout[-2000:])
        assert "first.yaml" in refused.stdout and refused.stdout.count("hyperqn: error") == 1
        assert not list(out.glob("second*"))
        stdout, _ = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            sessions.send([proc.pid] + hyperqn_pids(proc.pid), signal.SIGKILL)
            proc.wait(timeout=10)
    assert proc.returncode == 0, stdout[-2000:]
    summary = check_complete(out)
    assert summary["status"] == "ok" and summary["frames"] == 15
    assert len(read_pvd(out / "first.pvd")) == 16
    assert {int(r["frame"]) for r in csv.DictReader(open(out / "iterations.csv"))} == set(range(1, 16))
    assert not (out / ".hyperqn.lock").exists()  # released and removed at the end
    # A run killed -9 holds nothing: the next run into the directory goes ahead.
    first = write_deck(tmp_path / "first.yaml", slow_deck("first"))
    run_and_kill([first, "-o", out], ranks, lambda: (out / ".hyperqn.lock").exists(), random.Random(1))
    assert (out / ".hyperqn.lock").exists()  # left by the kill, unlocked
    run_hyperqn([second, "-o", out], ranks=ranks, timeout=120)
    assert check_complete(out)["status"] == "ok" and not (out / ".hyperqn.lock").exists()


@pytest.mark.parametrize("ranks", [None, 2])
def test_a_study_takes_the_directory_lock(tmp_path, ranks):
    # A study took no lock: a second study (or a run) into its directory meanwhile removed its files
    # and wrote beside them. Now a study holds OUTDIR's lock as a run does, refuses a directory held,
    # and releases it (removing the file) at its end.
    import fcntl
    study = os.path.join(REPO, "tests", "decks", "study_small.yaml")
    out = tmp_path / "study"
    out.mkdir()
    with held_by_another(out):
        refused = run_hyperqn(["study", study, "-o", out], ranks=ranks, check=False, timeout=120)
        assert refused.returncode == 1, refused.stdout[-2000:]
        assert f"hyperqn: error: the output directory {out} is in use by another run" in refused.stdout
        assert "other.yaml" in refused.stdout and refused.stdout.count("hyperqn: error") == 1
        assert sorted(p.name for p in out.iterdir()) == [".hyperqn.lock"]
    (out / ".hyperqn.lock").unlink()
    # While the study runs, the directory is locked; the study ends whole and leaves no lock file.
    proc = started(["study", study, "-o", out], ranks, lambda: (out / "study.json").exists())
    try:
        assert proc.poll() is None, "the study ended before its lock was tried: make it slower"
        with open(out / ".hyperqn.lock") as probe:
            with pytest.raises(BlockingIOError):
                fcntl.flock(probe, fcntl.LOCK_EX | fcntl.LOCK_NB)
        stdout, _ = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            sessions.send([proc.pid] + hyperqn_pids(proc.pid), signal.SIGKILL)
            proc.wait(timeout=10)
    assert proc.returncode == 0, stdout[-2000:]
    assert (out / "study.csv").exists() and not (out / ".hyperqn.lock").exists()


def test_a_study_holds_each_integrator_s_directory_it_runs_in(tmp_path):
    # A study of several integrators held only OUTDIR: a second study into OUTDIR/bdf2 meanwhile
    # removed the first's partial files there and both exited 0, bdf2/ then holding one's CSVs and
    # the other's study.h5. Now each integrator's directory is locked while the study runs in it.
    deck = open(os.path.join(REPO, "tests", "decks", "study_small.yaml")).read()
    deck = deck.replace("time: {dt: 0.0333333333, frames: 20}", "time: {dt: 0.0333333333, frames: 6}")
    deck = deck.replace("  frames: [5, 15]", "  frames: [2]\n  integrators: [implicit-euler, bdf2]")
    path = tmp_path / "axis.yaml"
    path.write_text(deck)
    out = tmp_path / "axis"
    (out / "bdf2").mkdir(parents=True)
    with held_by_another(out / "bdf2"):
        proc = run_hyperqn(["study", path, "-o", out], check=False, timeout=300)
    assert proc.returncode == 1, proc.stdout[-2000:]
    assert f"the output directory {out}/bdf2 is in use by another run" in proc.stdout, proc.stdout[-2000:]
    assert (out / "implicit-euler" / "study.h5").exists()  # the first integrator's study is whole
    assert not (out / "bdf2" / "study.csv").exists() and not (out / ".hyperqn.lock").exists()
