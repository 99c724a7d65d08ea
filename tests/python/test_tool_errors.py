"""The postprocess tools on a user's mistakes (docs/outputs.md): a directory that holds no run, runs
of other meshes, a run without reactions.csv, a damaged study, a meaningless tolerance: each a
message naming what is wrong and a non-zero exit, never a Python traceback. And `compare` on two
equal runs of a body at rest: 0 apart, not nan."""
import argparse
import copy
import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys

import pytest

from conftest import HYPERQN, MPIEXEC, REPO, env_without_matplotlib, run_deck, write_deck

BAR = {"mesh": {"box": {"size": [1.0, 0.2, 0.2], "cells": [4, 1, 1]}},
       "material": {"model": "corotated", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 100},
       "fixed": [{"box": {"min": [-0.01, -1, -1], "max": [0.01, 1, 1]}}],
       "gravity": [0, -9.81, 0],
       "time": {"dt": 0.01, "frames": 2}}


def tool(*args, env=None):
    return subprocess.run([sys.executable, "-m", *map(str, args)], capture_output=True, text=True, timeout=120,
                          env=env)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    base = tmp_path_factory.mktemp("runs")
    bar, _ = run_deck(base, "bar", BAR)
    other, _ = run_deck(base, "other", {**BAR, "mesh": {"box": {"size": [1.0, 0.2, 0.2], "cells": [5, 1, 1]}}})
    rest, _ = run_deck(base, "rest", {**BAR, "gravity": [0, 0, 0]})
    return base, bar, other, rest


def assert_said(proc, *fragments):
    assert proc.returncode == 1, (proc.returncode, proc.stdout, proc.stderr)
    assert "Traceback" not in proc.stderr, proc.stderr
    for f in fragments:
        assert f in proc.stdout + proc.stderr, proc.stdout + proc.stderr


def test_compare(runs):
    base, bar, other, rest = runs
    assert_said(tool("hyperqn_tools.compare", base / "nowhere", bar), "compare:", "nowhere")
    assert_said(tool("hyperqn_tools.compare", bar, other), "compare:", "different vertex sets", str(bar), str(other))
    same = tool("hyperqn_tools.compare", rest, rest)
    assert same.returncode == 0 and "relative 0.000e+00" in same.stdout and "Warning" not in same.stderr
    # the docs quote differences "of the diagonal": the tool says that figure too (it gave only the
    # one relative to the largest displacement, which the docs had called "over the rest diagonal")
    moved = tool("hyperqn_tools.compare", bar, rest)
    m = re.search(r"max \|x_a - x_b\| = (\S+), .*; (\S+) of the rest diagonal (\S+)$", moved.stdout.strip())
    assert m and float(m.group(2)) == pytest.approx(float(m.group(1)) / float(m.group(3)), rel=1e-3), moved.stdout


def test_force_displacement_without_reactions(runs):
    _, bar, _, _ = runs
    assert_said(tool("hyperqn_tools.force_displacement", bar, "--support", "fixed[0]"),
                "reactions.csv: no such file", "output.reactions: true")


def test_intersections_with_a_meaningless_tolerance(runs):
    _, bar, _, _ = runs
    for rtol in ("-1", "nan", "2"):
        assert_said(tool("hyperqn_tools.intersections", bar, "--rtol", rtol), "--rtol", "[0, 1)")


def test_study_report_of_a_damaged_study(runs, tmp_path):
    base, _, _, _ = runs
    study = tmp_path / "study"
    study.mkdir()
    (study / "study.csv").write_text("frame,solver,iteration,time_s,energy,grad_norm,rel_error\n1,lbfgs,0,0.0,1.0\n")
    assert_said(tool("hyperqn_tools.study_report", study, "--out", tmp_path / "r.md"), "study.csv:2", "not a row")
    (study / "study.csv").write_text("frame,solver,iteration,time_s,energy,grad_norm,rel_error\n")
    (study / "study.json").write_text("{bad")
    assert_said(tool("hyperqn_tools.study_report", study, "--out", tmp_path / "r.md"), "study.json", "not JSON")


def test_study_report_of_an_empty_study_a_damaged_trajectory_and_a_directory_as_out(tmp_path):
    study = tmp_path / "study"
    study.mkdir()
    header = "frame,solver,iteration,time_s,energy,grad_norm,rel_error\n"
    for text in ("", header):  # a study killed before its first row
        (study / "study.csv").write_text(text)
        assert_said(tool("hyperqn_tools.study_report", study, "--out", tmp_path / "r.md"), "study.csv", "no rows")
    (study / "study.csv").write_text(header + "1,lbfgs,0,0.0,1.0,1.0,1.0\n1,lbfgs,1,0.1,0.5,0.5,0.1\n")
    (study / "trajectory.csv").write_text("solver,frame\nlbfgs,x\n")
    assert_said(tool("hyperqn_tools.study_report", study, "--out", tmp_path / "r.md"), "trajectory.csv:2",
                "not a row")
    (study / "trajectory.csv").unlink()
    (tmp_path / "d").mkdir()
    assert_said(tool("hyperqn_tools.study_report", study, "--out", tmp_path / "d"), "--out", "is a directory")
    assert sorted(p.name for p in study.iterdir()) == ["study.csv"]  # no figures left behind
    assert not (tmp_path / "r.md").exists()


DAMAGED = {"pvd": ("bar.pvd", "<VTKFile"), "pvtu": ("bar_00002.pvtu", "<VTKFile"),
           "xdmf": ("bar.xdmf", "<Xdmf"), "xdmf_without_grids": ("bar.xdmf", "<Xdmf/>")}


@pytest.mark.parametrize("damage", sorted(DAMAGED))
def test_compare_and_intersections_of_a_damaged_index_or_frame(runs, tmp_path, damage):
    """docs/outputs.md: a frame that cannot be read is `intersections: error:` naming the file."""
    _, bar, _, _ = runs
    name, text = DAMAGED[damage]
    run = tmp_path / "run"
    shutil.copytree(bar, run)
    if damage == "pvtu":  # the last frame a .pvtu (as at 2 ranks), cut short
        (run / "bar.pvd").write_text((run / "bar.pvd").read_text().replace("bar_00002.vtu", name))
    elif damage.startswith("xdmf"):  # an XDMF run's only index
        (run / "bar.pvd").unlink()
    (run / name).write_text(text)
    assert_said(tool("hyperqn_tools.compare", bar, run), "compare:", name)
    assert_said(tool("hyperqn_tools.intersections", run), "intersections: error:", name)


def test_intersections_with_a_directory_as_json(runs, tmp_path):
    _, bar, _, _ = runs
    proc = tool("hyperqn_tools.intersections", bar, "--json", tmp_path)
    assert_said(proc, "--json", "is a directory")
    assert "largest" not in proc.stdout  # refused before the frames were read


def test_intersections_refuses_a_json_in_a_missing_directory_first(runs, tmp_path):
    """It does not make --json's directory (as force_displacement's --csv): refused before the
    frames are read (before: every frame counted, then `No such file or directory`)."""
    _, bar, _, _ = runs
    proc = tool("hyperqn_tools.intersections", bar, "--json", tmp_path / "nodir" / "x.json")
    assert_said(proc, "--json", "no such directory")
    assert proc.stdout == "" and not (tmp_path / "nodir").exists()


@pytest.fixture(scope="module")
def reactions_run(tmp_path_factory):
    out, _ = run_deck(tmp_path_factory.mktemp("reactions"), "bar", {**BAR, "output": {"reactions": True}})
    return out


def test_force_displacement_of_damaged_files_and_unwritable_outputs(reactions_run, tmp_path):
    run = tmp_path / "run"
    shutil.copytree(reactions_run, run)
    support = ("--support", "fixed[0]")
    reactions = (run / "reactions.csv").read_text()
    (run / "reactions.csv").write_text(reactions[:reactions.index("\n", reactions.index("\n") + 1) + 20])
    assert_said(tool("hyperqn_tools.force_displacement", run, *support), "reactions.csv:3", "not a row")
    (run / "reactions.csv").write_text(reactions)
    # hyperqn wrote a curve's points as a block list that is not YAML (being fixed in C++): said
    (run / "config.yaml").write_text("fixed[0].box.min: [1\n")
    assert_said(tool("hyperqn_tools.force_displacement", run, *support), "config.yaml: not valid YAML", "line")
    (run / "config.yaml").unlink()
    assert_said(tool("hyperqn_tools.force_displacement", run, *support), "config.yaml: cannot be read")
    shutil.copy(reactions_run / "config.yaml", run)
    for option, path, said in [("--csv", tmp_path, "is a directory"),
                               ("--png", tmp_path / "nowhere" / "x.png", "no such directory")]:
        proc = tool("hyperqn_tools.force_displacement", run, *support, option, path)
        assert_said(proc, option, said)
        assert "travel_x" not in proc.stdout  # refused before the curve was printed
    assert tool("hyperqn_tools.force_displacement", run, *support, "--csv", tmp_path / "c.csv").returncode == 0


@pytest.mark.parametrize("args, said", [(["--ranks", "abc"], "--ranks"), (["--ranks", "0"], "--ranks"),
                                        (["--frames", "0"], "--frames"), (["--out", "FILE"], "not a directory")])
def test_bench_refuses_bad_arguments_before_measuring(tmp_path, args, said):
    (tmp_path / "file").write_text("")
    args = [str(tmp_path / "file") if a == "FILE" else a for a in args]
    proc = subprocess.run([sys.executable, os.path.join(REPO, "bench", "bench.py"), "--quick", *args],
                          capture_output=True, text=True, timeout=60)
    assert_said(proc, "bench/bench.py: error:", said)
    assert "memory bandwidth" not in proc.stderr  # refused before anything ran
    assert (tmp_path / "file").read_text() == ""


def test_bench_shows_hyperqn_s_error_not_mpiexec_s(tmp_path):
    """At 2 ranks mpiexec's banner ends stderr ('Exit code: 1'); the row shows hyperqn's line."""
    spec = importlib.util.spec_from_file_location("bench", os.path.join(REPO, "bench", "bench.py"))
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    deck = write_deck(tmp_path / "bad.yaml", {**BAR, "material": {**BAR["material"], "poisson_ratio": 0.6}})
    args = argparse.Namespace(hyperqn=HYPERQN, mpiexec=MPIEXEC, timeout=60)
    for ranks in (1, 2):
        _, status = bench.run_case(args, "bad", deck, ranks, str(tmp_path / f"np{ranks}"))
        assert status.startswith("failed: ") and "'material.poisson_ratio': must be in (-1, 0.5)" in status, status


def script(name, *args):
    return subprocess.run([sys.executable, os.path.join(REPO, "scripts", name), *map(str, args)],
                          capture_output=True, text=True, timeout=60)


def test_scripts_refuse_a_missing_page_or_binary_and_a_directory_as_out(tmp_path):
    assert_said(script("deck_tables.py", "--check", tmp_path / "nonexist.md"), "nonexist.md", "cannot be read")
    for args in (["--bin", "/nonexist"], ["--check", "--bin", "/nonexist"]):
        assert_said(script("deck_tables.py", *args), "--bin /nonexist", "not an executable")
    # before any run (they took minutes, then the result was lost to IsADirectoryError)
    proc = script("compare_revisions.py", "--base-bin", HYPERQN, "--new-bin", HYPERQN, "--out", tmp_path)
    assert_said(proc, "--out", "is a directory")
    assert not (tmp_path / "runs").exists() and not (tmp_path / "decks").exists()


@pytest.mark.parametrize("name, args, own, written", [
    ("fuzz.py", ["--cases", "0"], ["cases/00003/deck.yaml"], {"fuzz.json"}),
    ("faults.py", ["--trials", "0", "--classes", "kill", "--mpiexec", MPIEXEC],
     ["trials/0001-kill-np1/x", "references/r/deck.yaml", "failures/0002-kill-np2/trial.txt"],
     {"faults.json", "faults.csv", "failures"})])
def test_fuzz_and_faults_keep_a_user_s_files_in_out(tmp_path, name, args, own, written):
    """A rerun removes what an earlier run wrote in --out, and nothing else (before: the whole
    directory, a user's files with it, was removed)."""
    out = tmp_path / "precious"
    (out / "notes").mkdir(parents=True)
    (out / "thesis.txt").write_text("t\n")
    (out / "notes" / "n.txt").write_text("n\n")
    for path in own:  # an earlier run's
        (out / path).parent.mkdir(parents=True, exist_ok=True)
        (out / path).write_text("old\n")
    proc = script(name, *args, "--out", out, "--bin", HYPERQN)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert (out / "thesis.txt").read_text() == "t\n" and (out / "notes" / "n.txt").read_text() == "n\n"
    assert {p.name for p in out.iterdir()} == {"thesis.txt", "notes"} | written
    assert not any((out / "failures").iterdir()) if (out / "failures").exists() else True
    results = json.loads((out / name.replace(".py", ".json")).read_text())
    assert results.get("cases", len(results.get("trials", []))) == 0


# A representative bad argument of every script, each refused in one line, exit 1, before anything
# is written (before: argparse's usage and exit 2, a traceback, or a run that failed later).
# OUT: a directory not yet made in the test's directory; FILE: a file there; BIN: the binary.
BAD_ARGUMENTS = [
    ("scripts/ball_mesh.py", ["OUT/y.mesh", "--radius", "1e-120"], "--radius 1e-120"),
    ("scripts/cylinder_mesh.py", ["OUT/x.mesh", "--cells", "0"], "--cells"),
    ("scripts/dogbone_mesh.py", ["OUT/d.mesh", "--cells", "4", "0", "2"], "--cells"),
    ("scripts/shell_mesh.py", ["OUT/s.mesh", "--layers", "-1"], "--layers"),
    ("scripts/slit_mesh.py", ["OUT/z.mesh", "--inner", "0.01", "--outer", "1", "--gap-fraction", "0.05"],
     "--gap-fraction"),
    ("scripts/sliver_mesh.py", ["OUT/v.mesh", "--element", "nan"], "--element"),
    ("scripts/compare_revisions.py", ["--base-bin", "BIN", "--new-bin", "BIN", "--tol", "nan", "--out", "OUT/r.json"],
     "--tol"),
    ("scripts/compare_revisions.py", ["--base-bin", "BIN", "--new-bin", "BIN", "--tol", "-1", "--out", "OUT/r.json"],
     "--tol"),
    ("scripts/fuzz.py", ["--cases", "-5", "--out", "OUT", "--bin", "BIN"], "--cases"),
    ("scripts/fuzz.py", ["--budget", "-1", "--out", "OUT", "--bin", "BIN"], "--budget"),
    ("scripts/fuzz.py", ["--timeout", "0", "--out", "OUT", "--bin", "BIN"], "--timeout"),
    ("scripts/fuzz.py", ["--cases", "1", "--out", "FILE", "--bin", "BIN"], "not a directory"),
    ("scripts/fuzz.py", ["--out", "OUT", "--bin", "/nonexist"], "/nonexist"),
    ("scripts/faults.py", ["--ranks", "0", "--out", "OUT", "--bin", "BIN"], "--ranks"),
    ("scripts/faults.py", ["--ranks", "a", "--out", "OUT", "--bin", "BIN"], "--ranks"),
    ("scripts/faults.py", ["--trials", "2", "--trial", "7", "--out", "OUT", "--bin", "BIN"], "--trial 7"),
    ("bench/bench.py", ["--min-solve-s", "nan", "--out", "OUT"], "--min-solve-s"),
    ("bench/bench.py", ["--min-solve-s", "-1", "--out", "OUT"], "--min-solve-s"),
    ("bench/bench.py", ["--mpiexec", "/nonexist/mpiexec", "--out", "OUT"], "--mpiexec"),
    ("bench/compare_builds.py", ["BIN", "BIN", "--cases", "nosuch", "--out", "OUT"], "nosuch"),
    ("bench/topology_cuts.py", ["--rounds", "0", "--out", "OUT", "--binary", "BIN"], "--rounds"),
    ("bench/topology_cuts.py", ["--out", "FILE", "--binary", "BIN"], "not a directory"),  # its --deck found
    ("bench/cloth_tear.py", ["--out", "FILE", "--binary", "BIN"], "not a directory"),  # from outside the repository
    ("bench/inelastic_cost.py", ["--cases", "nosuch", "--out", "OUT"], "nosuch"),
    ("bench/element_fields.py", ["--frames", "0", "--out", "OUT"], "--frames"),
    ("bench/h0_precision.py", ["--ranks", "1,x", "--out", "OUT"], "--ranks"),
    ("bench/checkpoint.py", ["new=/nonexist", "--out", "OUT"], "/nonexist"),
    ("bench/solver_defaults.py", ["--atol", "nan", "--out", "OUT"], "--atol"),
    ("bench/contact.py", ["--timeout", "-1", "--out", "OUT"], "--timeout"),
]


@pytest.mark.parametrize("name, args, said", BAD_ARGUMENTS, ids=[f"{n}-{a[-3] if len(a) > 2 else a[0]}-{k}"
                                                                  for k, (n, a, _) in enumerate(BAD_ARGUMENTS)])
def test_scripts_refuse_a_bad_argument_in_one_line(tmp_path, name, args, said):
    (tmp_path / "FILE").write_text("mine\n")
    subst = {"OUT": str(tmp_path / "out"), "FILE": str(tmp_path / "FILE"), "BIN": HYPERQN}
    args = [subst.get(a, a.replace("OUT/", subst["OUT"] + "/")) for a in args]
    env = {**os.environ, "PYTHONPATH": os.path.join(REPO, "postprocess")}
    proc = subprocess.run([sys.executable, os.path.join(REPO, name), *args], capture_output=True, text=True,
                          timeout=60, cwd=tmp_path, env=env)
    assert proc.returncode == 1, (proc.returncode, proc.stdout, proc.stderr)
    assert "Traceback" not in proc.stderr and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "error:" in proc.stderr and said in proc.stderr, proc.stderr
    assert proc.stdout == "" and sorted(p.name for p in tmp_path.iterdir()) == ["FILE"]
    assert (tmp_path / "FILE").read_text() == "mine\n"


STUDY_HEADER = "frame,solver,iteration,time_s,energy,grad_norm,rel_error\n"


def test_tools_without_matplotlib(reactions_run, tmp_path):
    """Without matplotlib (docs/study.md, docs/outputs.md#reactionscsv): study_report ended in an
    ImportError traceback; now it writes its report's tables and says in one line that the figures
    were skipped (exit 0). force_displacement --png, a figure asked for, is refused in one line
    before anything is printed or written (exit 1); without --png it prints and writes the curve."""
    env = env_without_matplotlib(tmp_path)
    study = tmp_path / "study"
    study.mkdir()
    (study / "study.csv").write_text(STUDY_HEADER + "1,lbfgs,0,0.0,1.0,1.0,1.0\n1,lbfgs,1,0.1,0.5,0.5,0.1\n"
                                     "1,newton,0,0.0,1.0,1.0,1.0\n1,newton,1,0.2,0.5,0.5,0.01\n")
    proc = tool("hyperqn_tools.study_report", study, "--out", tmp_path / "r.md", env=env)
    assert proc.returncode == 0 and "Traceback" not in proc.stderr, proc.stderr
    assert proc.stderr.strip() == ("study_report: figures skipped: matplotlib is not installed "
                                   "(Debian: apt-get install python3-matplotlib)"), proc.stderr
    report = (tmp_path / "r.md").read_text()
    assert "| lbfgs |" in report and "Figures skipped" in report and ".png" not in report
    assert not list(tmp_path.rglob("*.png"))
    support = ("--support", "fixed[0]")
    proc = tool("hyperqn_tools.force_displacement", reactions_run, *support, "--png", tmp_path / "c.png",
                "--csv", tmp_path / "c.csv", env=env)
    assert_said(proc, "--png", "matplotlib is not installed", "python3-matplotlib")
    assert len(proc.stderr.strip().splitlines()) == 1 and "travel_x" not in proc.stdout
    assert not (tmp_path / "c.csv").exists() and not (tmp_path / "c.png").exists()
    proc = tool("hyperqn_tools.force_displacement", reactions_run, *support, "--csv", tmp_path / "c.csv", env=env)
    assert proc.returncode == 0 and "travel_x" in proc.stdout and (tmp_path / "c.csv").exists(), proc.stderr


def test_compare_and_intersections_pass_over_a_user_s_other_pvd(runs, tmp_path):
    """docs/outputs.md: a run leaves a user's other files alone, a .pvd of other files too; compare
    and intersections refused such a directory ("expected one .pvd or one .xdmf"). In a run's
    directory (summary.json) they read the series the run wrote (a NAME.pvd listing NAME_... files,
    hyperqn's own rule); without summary.json two .pvd are refused naming both."""
    _, bar, _, _ = runs
    run = tmp_path / "run"
    shutil.copytree(bar, run)
    (run / "notes.pvd").write_text('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1"><Collection>'
                                   '<DataSet timestep="0" part="0" file="bar_00000.vtu"/></Collection></VTKFile>\n')
    proc = tool("hyperqn_tools.compare", run, bar)
    assert proc.returncode == 0 and "relative 0.000e+00" in proc.stdout, proc.stdout + proc.stderr
    proc = tool("hyperqn_tools.intersections", run)
    assert proc.returncode == 0 and "frame     2" in proc.stdout, proc.stdout + proc.stderr
    (run / "summary.json").unlink()
    assert_said(tool("hyperqn_tools.intersections", run), "intersections: error:", "bar.pvd, notes.pvd",
                "no summary.json")
    assert_said(tool("hyperqn_tools.compare", run, bar), "compare:", "bar.pvd, notes.pvd")


@pytest.fixture(scope="module")
def xdmf_run(tmp_path_factory):
    out, _ = run_deck(tmp_path_factory.mktemp("xdmf"), "bar", {**BAR, "output": {"format": "xdmf"}})
    return out


@pytest.mark.parametrize("damage", ["vtu", "h5"])
def test_compare_of_a_frame_cut_short_names_the_file(runs, xdmf_run, tmp_path, damage):
    """A frame's data cut short (a .vtu piece, an XDMF run's .h5): compare printed meshio's
    "Error: Couldn't read file ..." without its prefix, or h5py's "Unable to open file (truncated
    file ...)" naming no file. Now compare and intersections say it alike (output.read_frame), one
    line `compare: ...` naming the file."""
    _, bar, _, _ = runs
    source, name = (bar, "bar_00002.vtu") if damage == "vtu" else (xdmf_run, "bar.h5")
    run = tmp_path / "run"
    shutil.copytree(source, run)
    data = (run / name).read_bytes()
    (run / name).write_bytes(data[:len(data) // 2])
    for proc, prefix in ((tool("hyperqn_tools.compare", run, source), "compare: "),
                         (tool("hyperqn_tools.intersections", run), "intersections: error: ")):
        assert_said(proc, name, "cannot read frame")
        lines = (proc.stdout + proc.stderr).strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(prefix), lines


def test_compare_refuses_a_meaningless_tolerance_and_runs_ending_at_other_frames(runs, tmp_path):
    """compare took --rtol nan (two equal runs then 'differed', exit 1) or a negative one; it now
    refuses them as intersections does (cli.fraction, [0, 1)). And a run stopped after frame 1 was
    compared with a complete one's frame 2 without a word; now: exit 1 naming both last frames."""
    _, bar, _, _ = runs
    for rtol in ("nan", "-1", "2"):
        assert_said(tool("hyperqn_tools.compare", bar, bar, "--rtol", rtol), "--rtol", "[0, 1)")
    stopped = tmp_path / "stopped"
    shutil.copytree(bar, stopped)
    pvd = (stopped / "bar.pvd").read_text()
    (stopped / "bar.pvd").write_text(re.sub(r'<DataSet [^>]*file="bar_00002.vtu"/>\s*', "", pvd))
    (stopped / "bar_00002.vtu").unlink()  # what a kill after frame 1 leaves
    for a, b in ((stopped, bar), (bar, stopped)):
        assert_said(tool("hyperqn_tools.compare", a, b), "compare: the runs end at different frames",
                    f"{stopped} at frame 1", f"{bar} at frame 2")
    # --any-end compares the last frames wherever the runs end (a static answer against a settled run)
    proc = tool("hyperqn_tools.compare", stopped, bar, "--any-end")
    assert proc.returncode == 1 and re.search(r"relative 2\.\d+e\+00", proc.stdout), proc.stdout + proc.stderr


def test_force_displacement_refuses_a_figure_not_named_png_and_names_a_file_it_cannot_write(reactions_run, tmp_path):
    """--png z.txt ended in matplotlib's "Format 'txt' is not supported" traceback after the table
    was printed and the CSV written, and --png curve wrote curve.png: a name not ending in .png is
    refused before anything is printed or written. A write that fails (a full disk, /dev/full in the
    file's place) is one line naming the file."""
    support = ("--support", "fixed[0]")
    for name in ("z.txt", "curve", "z.pdf"):
        proc = tool("hyperqn_tools.force_displacement", reactions_run, *support, "--png", tmp_path / name,
                    "--csv", tmp_path / "z.csv")
        assert_said(proc, f"--png {tmp_path / name}: the figure's name must end in .png")
        assert len(proc.stderr.strip().splitlines()) == 1 and "travel_x" not in proc.stdout
        assert not os.listdir(tmp_path), os.listdir(tmp_path)
    (tmp_path / "full.png").symlink_to("/dev/full")
    for option in ("--csv", "--png"):
        proc = tool("hyperqn_tools.force_displacement", reactions_run, *support, option, tmp_path / "full.png")
        assert_said(proc, f"cannot write {tmp_path / 'full.png'}: No space left on device")
        assert len(proc.stderr.strip().splitlines()) == 1
    proc = tool("hyperqn_tools.force_displacement", reactions_run, *support, "--png", tmp_path / "c.PNG")
    assert proc.returncode == 0 and (tmp_path / "c.PNG").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", proc.stderr


def test_study_report_names_a_file_it_cannot_write(tmp_path):
    """study_report on a full disk (/dev/full in the report's place) said 'cannot write None'; each
    file it writes, the study's figure, the overview and the report, is named."""
    study = tmp_path / "study"
    study.mkdir()
    (study / "study.csv").write_text(STUDY_HEADER + "1,lbfgs,0,0.0,1.0,1.0,1.0\n1,lbfgs,1,0.1,0.5,0.5,0.1\n"
                                     "1,newton,0,0.0,1.0,1.0,1.0\n1,newton,1,0.2,0.5,0.5,0.01\n")
    for full in (study / "error_vs_time.png", tmp_path / "r_overview.png", tmp_path / "r.md"):
        full.symlink_to("/dev/full")
        proc = tool("hyperqn_tools.study_report", study, "--out", tmp_path / "r.md")
        assert_said(proc, f"study_report: error: cannot write {full}: No space left on device")
        full.unlink()


def test_stability_suite_names_a_file_it_cannot_write(tmp_path):
    """The stability suite on a full disk (/dev/full in a run's deck.yaml) ended in an OSError
    traceback from its worker thread; now one line naming the file, exit 1, before any table."""
    deck = write_deck(tmp_path / "bar.yaml", BAR)
    run = tmp_path / "out" / "runs" / "bar" / "lbfgs"
    run.mkdir(parents=True)
    (run / "deck.yaml").symlink_to("/dev/full")
    proc = subprocess.run([sys.executable, "-m", "hyperqn_tools.stability", deck, "--out", tmp_path / "out",
                           "--solvers", "lbfgs", "--no-reference", "--bin", HYPERQN, "--jobs", "1"],
                          capture_output=True, text=True, timeout=120)
    assert_said(proc, f"error: cannot write {run / 'deck.yaml'}: No space left on device")
    assert not (tmp_path / "out" / "stability.csv").exists()


def test_intersections_json_on_a_full_disk(runs, tmp_path):
    """A full disk while --json is written: the error names the file and no partial JSON is left
    (before: `--json F: No space left on device` beside F cut short)."""
    from test_safe_outputs import small_disk
    _, bar, _, _ = runs
    with small_disk(tmp_path / "disk", "40k") as mnt:
        filler = mnt / "filler"
        with open(filler, "wb", buffering=0) as f:  # fill it: the JSON gets no block
            try:
                while True:
                    f.write(b"x" * 512)
            except OSError:
                pass
        target = mnt / "counts.json"
        proc = tool("hyperqn_tools.intersections", bar, "--json", target)
        assert_said(proc, "--json", str(target))
        assert "No space left on device" in proc.stderr
        assert not target.exists()
