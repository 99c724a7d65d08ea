"""The postprocess tools on a user's mistakes (docs/outputs.md): a directory that holds no run, runs
of other meshes, a run without reactions.csv, a damaged study, a meaningless tolerance: each a
message naming what is wrong and a non-zero exit, never a Python traceback. And `compare` on two
equal runs of a body at rest: 0 apart, not nan."""
import copy
import shutil
import subprocess
import sys

import pytest

from conftest import run_deck

BAR = {"mesh": {"box": {"size": [1.0, 0.2, 0.2], "cells": [4, 1, 1]}},
       "material": {"model": "corotated", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 100},
       "fixed": [{"box": {"min": [-0.01, -1, -1], "max": [0.01, 1, 1]}}],
       "gravity": [0, -9.81, 0],
       "time": {"dt": 0.01, "frames": 2}}


def tool(*args):
    return subprocess.run([sys.executable, "-m", *map(str, args)], capture_output=True, text=True, timeout=120)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    base = tmp_path_factory.mktemp("runs")
    bar, _ = run_deck(base, "bar", BAR)
    other, _ = run_deck(base, "other", {**BAR, "mesh": {"box": {"size": [1.0, 0.2, 0.2], "cells": [5, 1, 1]}}})
    rest, _ = run_deck(base, "rest", {**BAR, "gravity": [0, 0, 0]})
    return base, bar, other, rest


def assert_said(proc, *fragments):
    assert proc.returncode != 0, proc.stdout
    assert "Traceback" not in proc.stderr, proc.stderr
    for f in fragments:
        assert f in proc.stdout + proc.stderr, proc.stdout + proc.stderr


def test_compare(runs):
    base, bar, other, rest = runs
    assert_said(tool("hyperqn_tools.compare", base / "nowhere", bar), "compare:", "nowhere")
    assert_said(tool("hyperqn_tools.compare", bar, other), "compare:", "different vertex sets")
    same = tool("hyperqn_tools.compare", rest, rest)
    assert same.returncode == 0 and "relative 0.000e+00" in same.stdout and "Warning" not in same.stderr


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
