"""hyperqn_tools.log_view reads -log_view as bench/scaling.py needs it (docs/performance.md#scaling-model):
- glued columns ("%5.4e%4.1f", "%2.1e%3d") and both generations of the summary's names parse;
- a 2-rank run of the split factor: its one MPI_Allreduce per solve counts as one reduction per
  rank and solve with no message, and a gradient evaluation sends one message per rank (the ghost
  exchange between the two parts);
- `hyperqn -help` lists every -hyperqn_ option of the source."""
import os
import re

from conftest import REPO, run_hyperqn, write_deck
from hyperqn_tools import log_view
from hyperqn_tools.output import read_summary

SAMPLE = """
MPI Msg Count:        6.150e+01     1.000   6.150e+01  1.230e+02
MPI Msg Len (bytes):  6.184e+05     1.111   9.552e+03  1.175e+06
MPI Reductions:       4.790e+02     1.000
BuildTwoSidedF         2 1.0 7.5530e-03252.8 0.00e+00 0.0 0.0e+00 0.0e+00 2.0e+00  2  0  0  0  0   2  0  0  0  0     0
hqnObjective          22 1.0 8.4962e-03 1.0 5.33e+05 1.1 4.4e+01 1.6e+03 4.4e+01100 12 36  6  9   4 12 36  6 10   118
 0:      Main Stage: 1.9068e-01 100.0%  8.3632e+06 100.0%  1.230e+02 100.0%  9.552e+03      100.0%  4.610e+02  96.2%
"""


def test_parses_glued_columns():
    ev = log_view.events(SAMPLE)
    assert set(ev) == {"BuildTwoSidedF", "hqnObjective"}
    assert ev["BuildTwoSidedF"]["time_max"] == 7.553e-3 and ev["BuildTwoSidedF"]["reductions"] == 2
    o = ev["hqnObjective"]
    assert (o["count"], o["messages"], o["avg_bytes"], o["reductions"]) == (22, 44, 1600, 44)
    s = log_view.summary(SAMPLE)
    assert s["messages"]["total"] == 123 and s["message_bytes"]["max"] == 6.184e5 and s["reductions"]["max"] == 479
    old = log_view.summary("MPI Messages:         6.150e+01     1.000   6.150e+01  1.230e+02\n")
    assert old["messages"]["avg"] == 61.5


def test_counts_of_a_split_run(tmp_path):
    deck = {"name": "log_view_box", "mesh": {"box": {"size": [4.0, 1.0, 1.0], "cells": [16, 4, 4]}},
            "material": {"model": "neohookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 1000},
            "fixed": [{"box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 1.01, 1.01]}}],
            "gravity": [0, -9.81, 0], "time": {"dt": 0.0333333333, "frames": 1},
            "solver": {"type": "lbfgs", "iterations": 5, "max_iterations": 0, "max_halvings": 0,
                       "newton_fallback": False},
            "output": {"vtk": False}}
    out = tmp_path / "out"
    text = run_hyperqn([write_deck(tmp_path / "box.yaml", deck), "-o", out, "-log_view",
                        "-hyperqn_h0_package", "split"], ranks=2).stdout
    s = read_summary(out)
    assert s["h0_package"] == "split" and s["h0_interface"] > 0
    ev = log_view.events(text, {"hqnH0Solve", "hqnObjective"})
    solve, grad = ev["hqnH0Solve"], ev["hqnObjective"]
    assert solve["count"] == s["h0_solves"] and solve["messages"] == 0 and solve["reductions"] == solve["count"]
    assert grad["messages"] == 2 * grad["count"] and grad["avg_bytes"] > 0
    assert log_view.summary(text)["messages"]["total"] > 0


def test_help_lists_every_hyperqn_option_of_the_source():
    """Every -hyperqn_ option that the source reads (src/, solvers/) is in `hyperqn -help`, with the
    options read where they act (before: -hyperqn_topology_h0, -hyperqn_memory_report and
    -hyperqn_h0_matrix_view, documented, were missing)."""
    import glob
    names = set()
    for path in glob.glob(os.path.join(REPO, "src", "**", "*.cpp"), recursive=True) + \
            glob.glob(os.path.join(REPO, "solvers", "*.cpp")):
        names |= set(re.findall(r'"(-hyperqn_[a-z0-9_]+)"', open(path).read()))
    assert "-hyperqn_topology_h0" in names and len(names) >= 15
    listed = set(re.findall(r"^  (-hyperqn_[a-z0-9_]+)", run_hyperqn(["-help"], ranks=None).stdout, re.M))
    assert names <= listed, sorted(names - listed)
