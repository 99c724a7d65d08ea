"""Sweeps (python3 -m hyperqn_tools.sweep, docs/sweeps.md): a 2 x 2 grid runs with a table of its
cases, a rejected case is listed with hyperqn's message while the others run, --case runs one
(as a Slurm array task does), --table-only rebuilds the same table, a set of decks with relative
mesh and obstacle files runs from the case directories, and bad sweep files fail cleanly."""
import csv
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time

import pytest

from conftest import HYPERQN, MPIEXEC, write_deck
from hyperqn_tools.decks import load_deck
from hyperqn_tools.output import final_frame
from hyperqn_tools.paths import REPO

BASE = {
    "mesh": {"box": {"size": [1.0, 0.2, 0.2], "cells": [4, 1, 1]}},
    "material": {"model": "corotated", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 100},
    "fixed": [{"box": {"min": [-0.01, -1, -1], "max": [0.01, 1, 1]}}],
    "time": {"dt": 0.01, "frames": 3},
}
# As a user writes it: 1e5 is a number for hyperqn, a string for plain PyYAML.
GRID = """deck: decks/base.yaml
sweep:
  material.youngs_modulus: [1e5, 1.0e6]
  solver.type: [lbfgs, pd]
"""
GRID_NAMES = ["case-000_youngs_modulus-1e5_type-lbfgs", "case-001_youngs_modulus-1e5_type-pd",
              "case-002_youngs_modulus-1e6_type-lbfgs", "case-003_youngs_modulus-1e6_type-pd"]
DECK_NAME = re.compile(r"^[A-Za-z0-9_+][A-Za-z0-9_.+-]{0,99}$")  # docs/decks.md, input limits


def sweep(*args, check_rc=None):
    proc = subprocess.run([sys.executable, "-m", "hyperqn_tools.sweep", *map(str, args),
                           "--bin", HYPERQN, "--mpiexec", MPIEXEC, "--timeout", "120"],
                          capture_output=True, text=True, timeout=600)
    if check_rc is not None:
        assert proc.returncode == check_rc, f"exit {proc.returncode}\n{proc.stdout}\n{proc.stderr}"
    return proc


def make_sweep(tmp_path, text, base=BASE):
    (tmp_path / "decks").mkdir(exist_ok=True)
    write_deck(tmp_path / "decks" / "base.yaml", base)
    path = tmp_path / "sweep.yaml"
    path.write_text(text)
    return path


def read_table(out):
    with open(out / "sweep.csv") as f:
        return list(csv.DictReader(f))


def test_grid_runs_with_a_table_and_table_only_rebuilds_it(tmp_path):
    path = make_sweep(tmp_path, GRID)
    out = tmp_path / "out"
    sweep(path, "--out", out, check_rc=0)
    rows = read_table(out)
    assert [r["case"] for r in rows] == GRID_NAMES
    assert list(rows[0]) == ["case", "material.youngs_modulus", "solver.type", "status", "frames",
                             "mean_iterations", "ms_per_frame", "wall_s", "exit_code"]
    for row, (E, solver) in zip(rows, [(1e5, "lbfgs"), (1e5, "pd"), (1e6, "lbfgs"), (1e6, "pd")]):
        assert (row["status"], row["frames"], row["exit_code"]) == ("ok", "3", "0"), row
        assert float(row["material.youngs_modulus"]) == E and row["solver.type"] == solver
        cdir = out / row["case"]
        deck = load_deck(cdir / "deck.yaml")
        assert deck["material"]["youngs_modulus"] == E and isinstance(deck["material"]["youngs_modulus"], float)
        assert deck["solver"]["type"] == solver and deck["name"] == row["case"]
        summary = json.loads((cdir / "summary.json").read_text())
        assert summary["solver"] == solver
        assert float(row["mean_iterations"]) == summary["mean_iterations"] > 0
        assert (cdir / "run.log").exists() and (cdir / f"{row['case']}.pvd").exists()
    # The swept modulus reached the runs: the two moduli end at different positions.
    soft, stiff = (final_frame(str(out / GRID_NAMES[i])).displacement for i in (0, 2))
    assert abs(soft - stiff).max() > 1e-9
    md = (out / "sweep.md").read_text().splitlines()
    assert len(md) == 2 + 4 and all(name in "".join(md) for name in GRID_NAMES)

    csv_text, md_text = (out / "sweep.csv").read_text(), (out / "sweep.md").read_text()
    os.remove(out / "sweep.csv")
    os.remove(out / "sweep.md")
    sweep(path, "--out", out, "--table-only", check_rc=0)
    assert (out / "sweep.csv").read_text() == csv_text and (out / "sweep.md").read_text() == md_text


def test_rejected_case_is_listed_and_the_others_run(tmp_path):
    path = make_sweep(tmp_path, "deck: decks/base.yaml\nsweep:\n  material.poisson_ratio: [0.3, 0.6, 0.4]\n")
    out = tmp_path / "out"
    proc = sweep(path, "--out", out, check_rc=2)  # 2: the sweep ran, a case did not exit 0
    rows = read_table(out)
    assert [r["status"] for r in rows][0::2] == ["ok", "ok"]
    bad = rows[1]
    assert bad["case"] == "case-001_poisson_ratio-0.6" and bad["exit_code"] == "1"
    assert bad["status"].startswith("failed: deck.yaml:") and "material.poisson_ratio" in bad["status"], bad
    assert bad["frames"] == "" and not (out / bad["case"] / "summary.json").exists()
    assert "material.poisson_ratio" in (out / "sweep.md").read_text()
    assert "case-002_poisson_ratio-0.4" in proc.stdout


def test_one_case_at_two_ranks_then_the_table(tmp_path):
    path = make_sweep(tmp_path, GRID)
    out = tmp_path / "out"
    sweep(path, "--out", out, "--case", 2, "--np", 2, check_rc=0)
    assert sorted(os.listdir(out)) == [GRID_NAMES[2]]  # one case, no table yet
    assert json.loads((out / GRID_NAMES[2] / "summary.json").read_text())["ranks"] == 2
    sweep(path, "--out", out, "--table-only", check_rc=0)
    assert [r["status"] for r in read_table(out)] == ["not run", "not run", "ok", "not run"]
    proc = sweep(path, "--out", out, "--case", 4, check_rc=1)
    assert "--case 4" in proc.stderr and "4 cases" in proc.stderr


def test_list_names_and_list_index(tmp_path):
    path = make_sweep(tmp_path, "deck: decks/base.yaml\nsweep:\n"
                                "  fixed.0.box.max: [[0.26, 1, 1]]\n"
                                "  gravity: [[0, -9.81, 0]]\n"
                                "  material.density: [100, 100.5, 101, 102, 103, 104, 105, 106, 107, 108, 109]\n"
                                "  solver.type: [lbfgs]\n"
                                "  solver.comment_that_is_long_enough_to_cut_the_name_to_one_hundred_chars: [x]\n")
    proc = sweep(path, "--list", check_rc=0)
    lines = proc.stdout.splitlines()
    assert lines[-1] == "11 cases" and len(lines) == 12
    names = [line.split(" ", 1)[1] for line in lines[:-1]]
    assert all(DECK_NAME.match(n) for n in names) and len(set(names)) == 11, names
    assert names[1].startswith("case-001_max-_0.26_1_1__gravity-_0_-9.81_0__density-100.5_type-lbfgs_")
    assert max(len(n) for n in names) == 100
    # Run one without the made-up key: hyperqn accepts the name, the list index set the box.
    path.write_text(path.read_text().replace("  solver.comment", "  # solver.comment"))
    out = tmp_path / "out"
    sweep(path, "--out", out, "--case", 1, check_rc=0)
    [case] = os.listdir(out)
    assert load_deck(out / case / "deck.yaml")["fixed"][0]["box"]["max"] == [0.26, 1, 1]
    assert json.loads((out / case / "summary.json").read_text())["status"] == "ok"


def test_set_of_decks_with_relative_files(tmp_path):
    """Relative mesh and obstacle files of base decks in another directory still load from OUT/<case>/."""
    (tmp_path / "meshes").mkdir()
    shutil.copy(os.path.join(REPO, "input", "meshes", "tet.mesh"), tmp_path / "meshes")
    (tmp_path / "decks").mkdir()
    (tmp_path / "decks" / "ground.obj").write_text("v -5 -0.5 -5\nv 5 -0.5 -5\nv 5 -0.5 5\nv -5 -0.5 5\nf 1 4 3 2\n")
    write_deck(tmp_path / "decks" / "tet.yaml", {
        "mesh": {"file": "../meshes/tet.mesh"},
        "material": {"youngs_modulus": 1.0e4, "poisson_ratio": 0.3, "density": 100},
        "time": {"dt": 0.01, "frames": 50}})
    write_deck(tmp_path / "decks" / "ground.yaml", {**BASE, "fixed": [],
                                                    "colliders": [{"type": "mesh", "file": "ground.obj"}]})
    path = tmp_path / "sweeps" / "set.yaml"
    path.parent.mkdir()
    path.write_text("decks: [../decks/tet.yaml, ../decks/ground.yaml]\nset: {time.frames: 2}\n")
    out = tmp_path / "elsewhere" / "out"
    sweep(path, "--out", out, check_rc=0)
    rows = read_table(out)
    assert [(r["case"], r["status"], r["frames"]) for r in rows] == [
        ("case-000_tet", "ok", "2"), ("case-001_ground", "ok", "2")]
    assert rows[0]["deck"].endswith("decks/tet.yaml")
    assert load_deck(out / "case-001_ground" / "deck.yaml")["colliders"][0]["file"] == str(tmp_path / "decks" / "ground.obj")


BAD_SWEEPS = {
    # name: (sweep file text, fragments of the message)
    "unknown_top_key": ("deck: decks/base.yaml\nsweeps: {solver.type: [lbfgs]}\n", ["'sweeps'", "unknown key"]),
    "empty_values": ("deck: decks/base.yaml\nsweep: {material.youngs_modulus: []}\n",
                     ["sweep.material.youngs_modulus", "non-empty list"]),
    "values_not_a_list": ("deck: decks/base.yaml\nsweep: {solver.type: lbfgs}\n", ["sweep.solver.type", "list"]),
    "missing_base_deck": ("deck: decks/absent.yaml\nsweep: {solver.type: [lbfgs]}\n", ["'deck'", "absent.yaml"]),
    "missing_deck_of_set": ("decks: [decks/base.yaml, nowhere.yaml]\n", ["'decks[1]'", "nowhere.yaml"]),
    "path_not_a_map": ("deck: decks/base.yaml\nsweep: {time.dt.x: [1]}\n", ["sweep.time.dt.x", "'time.dt'", "not a map"]),
    "index_out_of_range": ("deck: decks/base.yaml\nset: {fixed.3.box.min: [0, 0, 0]}\n", ["set.fixed.3.box.min", "'3'"]),
    "no_deck": ("sweep: {solver.type: [lbfgs]}\n", ["'deck' or 'decks'"]),
    "index_into_nothing": ("deck: decks/base.yaml\nsweep: {colliders.0.friction: [0.1]}\n",
                           ["sweep.colliders.0.friction", "'colliders' is not in the deck", "existing list"]),
    "not_yaml": ("deck: decks/base.yaml\nsweep: {solver.type: [lbfgs\n", ["not a valid YAML"]),
    # hyperqn refuses tags; a sweep must not turn !!float "1e5" into a plain number for it
    "tagged_value": ("deck: decks/base.yaml\nsweep: {material.youngs_modulus: [!!float '1e5']}\n",
                     ["YAML tags are not accepted, found !!float", "line 2"]),
    # PyYAML kept the last of the two (hyperqn refuses a key given twice)
    "key_twice": ("deck: decks/base.yaml\nsweep: {time.dt: [0.01]}\nsweep: {time.dt: [0.02]}\n",
                  ["key 'sweep' given twice in a map", "line 3"]),
}


@pytest.mark.parametrize("case", sorted(BAD_SWEEPS))
def test_bad_sweep_file(tmp_path, case):
    text, fragments = BAD_SWEEPS[case]
    path = make_sweep(tmp_path, text)
    out = tmp_path / "out"
    proc = sweep(path, "--out", out, check_rc=1)
    for fragment in [str(path), "sweep: error:"] + fragments:
        assert fragment in proc.stderr, f"{fragment!r} not in {proc.stderr!r}"
    assert not out.exists()


def test_tagged_base_deck(tmp_path):
    path = make_sweep(tmp_path, "deck: decks/tagged.yaml\nsweep: {solver.type: [lbfgs]}\n")
    (tmp_path / "decks" / "tagged.yaml").write_text((tmp_path / "decks" / "base.yaml").read_text()
                                                     .replace("dt: 0.01", "dt: !!float '0.01'"))
    proc = sweep(path, "--out", tmp_path / "out", check_rc=1)
    assert "tagged.yaml" in proc.stderr and "YAML tags are not accepted, found !!float" in proc.stderr, proc.stderr
    assert not (tmp_path / "out").exists()


def test_a_base_deck_is_read_as_hyperqn_reads_it(tmp_path):
    """YAML 1.2's scalars, as hyperqn's: frames: 010 is 10 (PyYAML's YAML 1.1: octal 8, and the
    case ran 8 frames), yes is a word that hyperqn refuses (PyYAML's true), and a key twice in
    the base deck is refused (PyYAML kept the last)."""
    path = make_sweep(tmp_path, "deck: decks/odd.yaml\nsweep: {time.dt: [0.01]}\n")
    odd = (tmp_path / "decks" / "base.yaml").read_text().replace("frames: 3", "frames: 010")
    (tmp_path / "decks" / "odd.yaml").write_text(odd)
    sweep(path, "--out", tmp_path / "out", check_rc=0)
    case = next(p for p in (tmp_path / "out").iterdir() if p.is_dir())
    assert load_deck(case / "deck.yaml")["time"]["frames"] == 10
    assert json.load(open(case / "summary.json"))["frames"] == 10
    (tmp_path / "decks" / "odd.yaml").write_text(odd + "output: {reactions: yes}\n")
    proc = sweep(path, "--out", tmp_path / "out2", check_rc=2)
    assert "'output.reactions': expected true or false" in proc.stdout, proc.stdout
    (tmp_path / "decks" / "odd.yaml").write_text(odd + "time: {dt: 0.02, frames: 3}\n")
    proc = sweep(path, "--out", tmp_path / "out3", check_rc=1)
    assert "odd.yaml" in proc.stderr and "key 'time' given twice in a map" in proc.stderr, proc.stderr


def test_missing_sweep_file(tmp_path):
    proc = sweep(tmp_path / "absent.yaml", "--out", tmp_path / "out", check_rc=1)
    assert "absent.yaml" in proc.stderr and not (tmp_path / "out").exists()


def test_a_case_stopped_by_its_timeout_at_two_ranks_stops_with_a_checkpoint(tmp_path):
    # --timeout sends SIGUSR1, which mpiexec forwards: the ranks write a checkpoint and summary.json
    # (a SIGTERM mpiexec would follow by SIGKILL before they had, docs/cluster.md)
    path = make_sweep(tmp_path, "deck: decks/base.yaml\nsweep:\n  solver.type: [lbfgs]\n",
                      {**BASE, "time": {"dt": 0.01, "frames": 10000000}, "output": {"vtk": False}})
    out = tmp_path / "out"
    proc = subprocess.run([sys.executable, "-m", "hyperqn_tools.sweep", path, "--out", out, "--np", "2",
                           "--bin", HYPERQN, "--mpiexec", MPIEXEC, "--timeout", "4"],
                          capture_output=True, text=True, timeout=120)
    [row] = read_table(out)
    assert row["status"].startswith("interrupted: SIGUSR1"), (row, proc.stdout, proc.stderr)
    assert int(row["frames"]) > 0 and row["exit_code"] == "none" and proc.returncode == 2
    run = json.loads((out / row["case"] / "run.json").read_text())
    assert run["exit_code"] is None and "timeout" not in run, run
    assert any(p.name.startswith("checkpoint_") for p in (out / row["case"] / "checkpoints").iterdir())


# Stands for hyperqn in a sweep whose timeout comes once the run's last frame's solve has ended,
# on any machine: it runs hyperqn to its end, passing its output on, and exits with its code only
# when SIGUSR1 has come (the sweep's, or mpiexec's forwarded to each rank). That a run the signal
# reaches then completes with exit 0 is hyperqn's (test_checkpoint_faults.py); this is the sweep's side.
HOLD_EXIT = """
import signal, subprocess, sys
got = []
signal.signal(signal.SIGUSR1, lambda *_: got.append(1))
code = subprocess.Popen(sys.argv[1:], start_new_session=True).wait()  # the signal is this script's alone
while not got:
    signal.pause()
print("(the timeout's SIGUSR1 came)", flush=True)
sys.exit(code)
"""


@pytest.mark.parametrize("ranks", [1, 2])
def test_a_timeout_after_the_last_frames_solve_leaves_the_run_complete(tmp_path, ranks):
    """The timeout's SIGUSR1 reaching a run once its last frame's solve had ended: the run completed
    (summary.json ok, exit 0), but run.json said exit_code null, the row `none`,
    the sweep '0 exited 0' and exit 2. Now run.json has the exit code 0 and says why in `timeout`."""
    path = make_sweep(tmp_path, "deck: decks/base.yaml\nsweep:\n  solver.type: [lbfgs]\n",
                      {**BASE, "output": {"vtk": False}})
    wrapper = tmp_path / "hold_exit"
    wrapper.write_text(f"#!/bin/sh\nexec {sys.executable} {tmp_path / 'hold.py'} {HYPERQN} \"$@\"\n")
    wrapper.chmod(0o755)
    (tmp_path / "hold.py").write_text(HOLD_EXIT)
    out = tmp_path / "out"
    proc = subprocess.run([sys.executable, "-m", "hyperqn_tools.sweep", path, "--out", out, "--np", str(ranks),
                           "--bin", wrapper, "--mpiexec", MPIEXEC, "--timeout", "1"],
                          capture_output=True, text=True, timeout=120)
    [row] = read_table(out)
    cdir = out / row["case"]
    summary = json.loads((cdir / "summary.json").read_text())
    assert (summary["status"], summary["frames"], summary["ranks"]) == ("ok", 3, ranks)
    run = json.loads((cdir / "run.json").read_text())
    assert run["exit_code"] == 0 and "interrupted" not in run, run
    assert run["timeout"] == ("SIGUSR1 after the timeout of 1.0 s came once the last frame's solve had ended: "
                              "the run completed"), run
    assert (row["status"], row["frames"], row["exit_code"]) == ("ok", "3", "0"), row
    log = (cdir / "run.log").read_text()
    assert "(the timeout's SIGUSR1 came)" in log, log
    assert "stopped after the timeout" not in log and "sweep: SIGUSR1 after the timeout" in log, log
    assert proc.returncode == 0 and "1 cases, 1 exited 0" in proc.stdout, (proc.returncode, proc.stdout, proc.stderr)


def test_portable_copies_name_every_file_absolutely(tmp_path):
    from hyperqn_tools.decks import portable_copy

    deck = {"bodies": [{"mesh": {"file": "m/a.mesh"}, "fixed": [{"box": {}, "motion": {"curve": {"file": "c.csv"}}}]}],
            "partition": "p.h5", "cuts": [{"surface": "blade.obj"}], "colliders": [{"file": "../o.obj"}],
            "loads": [{"curve": {"type": "table", "file": "l.csv"}}], "output": {"directory": "x"}}
    d = portable_copy(deck, tmp_path / "decks" / "deck.yaml")
    base = tmp_path / "decks"
    assert d["bodies"][0]["mesh"]["file"] == str(base / "m/a.mesh")
    assert d["bodies"][0]["fixed"][0]["motion"]["curve"]["file"] == str(base / "c.csv")
    assert d["partition"] == str(base / "p.h5") and d["cuts"][0]["surface"] == str(base / "blade.obj")
    assert d["colliders"][0]["file"] == str(tmp_path / "o.obj") and d["loads"][0]["curve"]["file"] == str(base / "l.csv")
    assert "directory" not in d["output"] and deck["partition"] == "p.h5"  # a copy


def test_a_deck_with_a_curve_table_file_sweeps(tmp_path):
    # input/bar_curves.yaml reads its clamp's motion from bar_curves_pull.csv beside it
    path = tmp_path / "sweep.yaml"
    path.write_text(f"deck: {REPO}/input/bar_curves.yaml\nsweep:\n  material.youngs_modulus: [1e6, 2e6]\n"
                    "set:\n  time.frames: 2\n  output.vtk: false\n")
    out = tmp_path / "out"
    sweep(path, "--out", out, check_rc=0)
    assert [r["status"] for r in read_table(out)] == ["ok", "ok"]


@pytest.mark.parametrize("where", ["a_file", "under_a_file", "not_creatable"])
def test_an_output_directory_that_cannot_be_made_is_refused_before_running(tmp_path, where):
    path = make_sweep(tmp_path, GRID)
    (tmp_path / "a_file").write_text("")
    out = {"a_file": tmp_path / "a_file", "under_a_file": tmp_path / "a_file" / "out",
           "not_creatable": "/sys/hyperqn-sweep-test/out"}[where]  # /sys: not even root makes one
    for extra in ([], ["--case", 0]):
        proc = sweep(path, "--out", out, *extra, check_rc=1)
        assert "error: --out" in proc.stderr and str(out) in proc.stderr and "Traceback" not in proc.stderr, proc.stderr
        assert "==" not in proc.stdout  # no case ran
    assert (tmp_path / "a_file").read_text() == ""


@pytest.mark.parametrize("value", ["0", "-1", "nan", "x"])
def test_a_timeout_that_is_not_positive_is_refused(tmp_path, value):
    path = make_sweep(tmp_path, GRID)
    proc = subprocess.run([sys.executable, "-m", "hyperqn_tools.sweep", path, "--out", tmp_path / "out",
                           "--bin", HYPERQN, "--timeout", value], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 1 and "--timeout" in proc.stderr and "Traceback" not in proc.stderr, proc.stderr
    assert not (tmp_path / "out").exists()


def test_table_only_shows_a_case_with_a_damaged_json_file_as_failed(tmp_path):
    """A Slurm array task killed while writing leaves run.json or summary.json cut short: its row
    says which file is damaged, the other cases' rows stand."""
    path = make_sweep(tmp_path, "deck: decks/base.yaml\nsweep:\n  solver.type: [lbfgs, pd]\n")
    out = tmp_path / "out"
    sweep(path, "--out", out, check_rc=0)
    damaged = out / "case-000_type-lbfgs"
    good = {name: (damaged / name).read_text() for name in ("run.json", "summary.json")}
    for name, text in [("summary.json", '{"status": '), ("summary.json", "[1,2]"), ("run.json", "{"),
                       ("run.json", "[]")]:
        (damaged / name).write_text(text)
        proc = sweep(path, "--out", out, "--table-only", check_rc=0)
        assert "Traceback" not in proc.stderr, proc.stderr
        rows = read_table(out)
        assert rows[0]["status"].startswith(f"failed: {name} damaged ("), rows[0]
        assert rows[1]["status"] == "ok" and rows[1]["exit_code"] == "0", rows[1]
        (damaged / name).write_text(good[name])


def test_a_write_that_fails_is_one_line_naming_the_file(tmp_path):
    """A full disk (simulated by /dev/full in the file's place: root writes anywhere else) while
    the sweep writes its own files: a case's deck.yaml (it left a 0-byte deck and an OSError
    traceback), its run.json, or --table-only's table. One line naming the file, exit 1, no deck cut
    short left, and the cases after it not run."""
    path = make_sweep(tmp_path, "deck: decks/base.yaml\nsweep:\n  solver.type: [lbfgs, pd]\n"
                                "set:\n  time.frames: 2\n  output.vtk: false\n")
    out = tmp_path / "out"
    first = out / "case-000_type-lbfgs"
    first.mkdir(parents=True)
    for name in ("deck.yaml", "run.json"):
        (first / name).symlink_to("/dev/full")
        proc = sweep(path, "--out", out, check_rc=1)
        assert "Traceback" not in proc.stderr and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
        assert proc.stderr.startswith(f"sweep: error: {first / name}: cannot write it: No space left on device"), \
            proc.stderr
        assert "2/2" not in proc.stdout and not (out / "case-001_type-pd").exists() and not (out / "sweep.csv").exists()
        assert not os.path.lexists(first / name) or (first / name).is_symlink()  # nothing cut short left
        if (first / name).is_symlink():
            (first / name).unlink()
    sweep(path, "--out", out, check_rc=0)
    for name in ("sweep.csv", "sweep.md"):
        os.remove(out / name)
        (out / name).symlink_to("/dev/full")
        proc = sweep(path, "--out", out, "--table-only", check_rc=1)
        assert proc.stderr.strip() == f"sweep: error: {out / name}: cannot write it: No space left on device", \
            proc.stderr
        (out / name).unlink()


ALIASED = """name: aliased
bodies:
  - name: a
    mesh: {box: {size: [1.0, 1.0, 1.0], cells: [1, 1, 1]}}
    material: &mat {model: neohookean, youngs_modulus: 1.0e6, poisson_ratio: 0.3, density: 1000}
    fixed: &fix [{box: {min: [-0.01, -0.01, -0.01], max: [0.01, 1.01, 1.01]}}]
  - name: b
    mesh: {box: {size: [1.0, 1.0, 1.0], cells: [1, 1, 1]}, transform: {translate: [3, 0, 0]}}
    material: *mat
    fixed: [{box: {min: [2.99, -0.01, -0.01], max: [3.01, 1.01, 1.01]}}]
time: {dt: 0.01, frames: 1}
"""


def test_a_key_sets_one_entry_of_a_deck_that_shares_it_by_an_alias(tmp_path):
    """Two bodies sharing `material: &mat` / `*mat`: a swept or set key naming one body's changed
    both (and the case deck was written with &id001 / *id001 anchors); now only the named one."""
    (tmp_path / "decks").mkdir()
    (tmp_path / "decks" / "base.yaml").write_text(ALIASED)
    path = tmp_path / "sweep.yaml"
    path.write_text("deck: decks/base.yaml\nsweep:\n  bodies.0.material.youngs_modulus: [1e3]\n"
                    "set:\n  bodies.1.material.density: 5000\n  output.vtk: false\n")
    out = tmp_path / "out"
    sweep(path, "--out", out, check_rc=0)
    text = (out / "case-000_youngs_modulus-1e3" / "deck.yaml").read_text()
    assert "&" not in text and "*" not in text, text
    a, b = load_deck(out / "case-000_youngs_modulus-1e3" / "deck.yaml")["bodies"]
    assert (a["material"]["youngs_modulus"], a["material"]["density"]) == (1e3, 1000)
    assert (b["material"]["youngs_modulus"], b["material"]["density"]) == (1e6, 5000)
    assert a["material"]["model"] == b["material"]["model"] == "neohookean"
    # an alias inside the node it names: refused as hyperqn refuses it, not a RecursionError
    (tmp_path / "decks" / "base.yaml").write_text(ALIASED + "gravity: &g [0, *g, 0]\n")
    proc = sweep(path, "--out", tmp_path / "out2", check_rc=1)
    assert "a YAML alias refers to the node it is in" in proc.stderr and "Traceback" not in proc.stderr, proc.stderr
    assert not (tmp_path / "out2").exists()


def sweep_process_running(out):
    """The sweep's runs still alive: processes whose command line names OUT."""
    alive = []
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                cmdline = f.read().decode(errors="replace")
        except OSError:
            continue
        if str(out) in cmdline and "hyperqn_tools.sweep" not in cmdline:
            alive.append(cmdline.replace("\0", " "))
    return alive


@pytest.mark.parametrize("ranks, signame", [(1, "SIGINT"), (2, "SIGINT"), (1, "SIGTERM")])
def test_ctrl_c_stops_the_running_case_and_records_it(tmp_path, ranks, signame):
    """Ctrl-C (SIGINT to the sweep, not to the run in its own session) ended in a KeyboardInterrupt
    traceback, the case without run.json or run.log and its run left going. Now the run stops with a
    checkpoint, run.json says interrupted, the table lists the cases not run, one line, exit 128 +
    the signal's number (130; SIGTERM, a scheduler's, 143)."""
    path = make_sweep(tmp_path, "deck: decks/base.yaml\nsweep:\n  solver.type: [lbfgs, pd]\n"
                                "set:\n  time.frames: 1000000\n  output.vtk: false\n")
    out = tmp_path / "out"
    first = out / "case-000_type-lbfgs"
    # A shell's background job ignores SIGINT, and Python then takes none: the default back, as a terminal's.
    proc = subprocess.Popen([sys.executable, "-m", "hyperqn_tools.sweep", path, "--out", out, "--np", str(ranks),
                             "--bin", HYPERQN, "--mpiexec", MPIEXEC], text=True, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        deadline = time.time() + 60
        while not (first / "iterations.csv").exists() or len((first / "iterations.csv").read_text()) < 2000:
            assert time.time() < deadline and proc.poll() is None, "the first case did not start"
            time.sleep(0.1)
        proc.send_signal(getattr(signal, signame))
        stdout, stderr = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 128 + getattr(signal, signame), (proc.returncode, stdout, stderr)
    assert "Traceback" not in stderr and len(stderr.strip().splitlines()) == 1, stderr
    assert stderr.startswith(f"sweep: interrupted by {signame} during case 0 (case-000_type-lbfgs): stopped"), stderr
    run = json.loads((first / "run.json").read_text())
    assert run["interrupted"] == signame and run["exit_code"] == 3, run
    assert f"sweep: interrupted by {signame}" in (first / "run.log").read_text()
    summary = json.loads((first / "summary.json").read_text())
    assert summary["status"].startswith("interrupted: SIGUSR1 "), summary["status"]
    rows = read_table(out)
    assert rows[0]["status"] == summary["status"] and rows[0]["exit_code"] == "3"
    assert rows[1]["status"] == "not run" and not (out / "case-001_type-pd").exists()
    assert not sweep_process_running(out)


@pytest.mark.parametrize("flag", ["--bin", "--mpiexec"])
def test_a_missing_binary_or_launcher_is_refused_before_any_case(tmp_path, flag):
    """--bin /nonexist ran every case, each failing "cannot start" with its directory written, and
    the sweep exited 2; now one line, exit 1, nothing written (the launcher only where --np > 1)."""
    path = make_sweep(tmp_path, GRID)
    out = tmp_path / "out"
    args = {"--bin": HYPERQN, "--mpiexec": MPIEXEC}
    args[flag] = str(tmp_path / "nonexist")
    proc = subprocess.run([sys.executable, "-m", "hyperqn_tools.sweep", str(path), "--out", str(out), "--np", "2",
                           *[x for kv in args.items() for x in kv]], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 1, (proc.stdout, proc.stderr)
    assert proc.stderr.count("\n") == 1 and f"{flag} {tmp_path / 'nonexist'}: not an executable file" in proc.stderr
    assert proc.stdout == "" and not out.exists()
