"""Loads (deck loads:, docs/loads.md), end to end.

- Momentum: a free body (nothing fixed, no gravity) under a force and a traction gains, per
  implicit-Euler step, h times the loads' total: sum m v = t F to the solver's tolerance; under a
  ramp curve, h F sum_k c(t_k).
- A cut opens faces that take no traction: the momentum is the same through it.
- input/engineering/bar_tip_load.yaml (a traction and an open pressure) gives the same frames at 1
  and 2 ranks (1e-10 of the sag) and bends the bar down.
- A closed pressure's answer does not depend on how far its box reaches past the body.
- Bad loads stop the run before anything is written, naming the deck line and key.
"""
import copy
import os

import numpy as np
import pytest

from conftest import load_deck, run_hyperqn, write_deck
from hyperqn_tools.compare import relative_difference
from hyperqn_tools.energy import frame_lumped_masses
from hyperqn_tools.output import final_frame, read_summary
from hyperqn_tools.paths import REPO
from test_bad_input import assert_clean_failure

DENSITY = 100.0
FREE = {
    "mesh": {"box": {"size": [1.0, 0.5, 0.5], "cells": [4, 2, 2]}},
    "material": {"model": "neohookean", "youngs_modulus": 1.0e4, "poisson_ratio": 0.3, "density": DENSITY},
    "gravity": [0, 0, 0],
    "time": {"dt": 0.02, "frames": 10},
    "solver": {"type": "lbfgs", "iterations": 500, "grad_rtol": 1.0e-12},
    "output": {"every": 10},
}
EVERYWHERE = {"min": [-1, -1, -1], "max": [2, 2, 2]}
FORCE = np.array([0.3, -0.2, 0.1])          # N, over all vertices
TRACTION = np.array([0.0, 0.0, 4.0])        # Pa, on the end x = 1 (area 0.25)


def lumped_masses(frame):
    """Per vertex: DENSITY times a quarter of the rest volume of its tets (as hyperqn lumps them)."""
    return frame_lumped_masses(frame, DENSITY)


@pytest.mark.parametrize("ranks", [1, 2])
def test_momentum_of_a_free_body(tmp_path, ranks):
    deck = copy.deepcopy(FREE)
    deck["loads"] = [{"type": "force", "box": EVERYWHERE, "force": FORCE.tolist()},
                     {"type": "traction", "box": {"min": [1, -1, -1], "max": [1, 2, 2]}, "traction": TRACTION.tolist()}]
    out = tmp_path / "out"
    proc = run_hyperqn([write_deck(tmp_path / "free.yaml", deck), "-o", out], ranks=ranks)
    assert "loads[1] traction (deck line" in proc.stdout and "on 8 boundary faces" in proc.stdout, proc.stdout[-2000:]
    assert read_summary(out)["status"] == "ok"
    frame = final_frame(out)
    momentum = lumped_masses(frame) @ frame.velocity
    expected = 10 * 0.02 * (FORCE + 0.25 * TRACTION)
    print(f"{ranks} rank(s): momentum {momentum}, t F = {expected}")
    # The solves stop at grad_rtol 1e-12, each frame's error in the momentum is that of its residual.
    assert np.abs(momentum - expected).max() <= 1e-6 * np.abs(expected).max()


# A cube under a pressure on its whole surface (closed: E = p V), static, held at one corner: its
# answer must not depend on how far the load's box reaches past it. With the volume summed about
# the box's centre, a box reaching 1e3 m left a residual of 3.2e-4 S and one reaching 1e5 m was
# flagged (0.37 S): the digits went into the box's size.
HYDROSTATIC = {
    "mesh": {"box": {"size": [1.0, 1.0, 1.0], "cells": [2, 2, 2]}},
    "material": {"model": "neohookean", "youngs_modulus": 1.0e6, "poisson_ratio": 0.3, "density": 1000},
    "fixed": [{"box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 0.01, 0.01]}}],
    "gravity": [0, 0, 0],
    "time": {"dt": 1, "frames": 2, "integrator": "static"},
    "solver": {"type": "lbfgs", "iterations": 400, "grad_rtol": 1.0e-10},
}


@pytest.mark.parametrize("ranks", [1, 2])
def test_a_closed_pressure_does_not_depend_on_its_box(tmp_path, ranks):
    frames = []
    for reach in (1.01, 1.0e3, 1.0e5):
        deck = copy.deepcopy(HYDROSTATIC)
        deck["loads"] = [{"type": "pressure", "box": {"min": [-0.01] * 3, "max": [reach] * 3}, "pressure": 1.0e5}]
        out = tmp_path / f"reach{reach:g}"
        run_hyperqn([write_deck(tmp_path / f"reach{reach:g}.yaml", deck), "-o", out], ranks=ranks)
        s = read_summary(out)
        assert s["status"] == "ok" and s["max_residual"] <= 1e-8, (reach, s["status"], s["max_residual"])
        frames.append(final_frame(out))
    for f in frames[1:]:
        assert np.abs(f.points - frames[0].points).max() <= 1e-12
    # uniform compression: every tet's volume ratio the same
    assert frames[0].J.max() - frames[0].J.min() <= 1e-9 and frames[0].J.max() < 0.95


@pytest.mark.parametrize("ranks", [1, 2])  # at 2 ranks the crack is on the partition boundary
def test_a_cut_adds_no_traction(tmp_path, ranks):
    """Found from outside: a traction whose box holds the whole body took the faces a cut opens too
    (both crack sides pushed the same way: a net force the cut created). A box keeps to the input's
    boundary faces: a free bar's momentum grows by h t A_surface per step, A_surface = 2.5 m², through
    a cut (a rest-frame blade at x = 0.5 from the second frame) that splits it in 2."""
    deck = copy.deepcopy(FREE)
    deck["loads"] = [{"type": "traction", "box": EVERYWHERE, "traction": TRACTION.tolist()}]
    deck["cuts"] = [{"center": [0.5, 0.25, 0.25], "normal": [1, 0, 0], "axis": [0, 1, 0], "size": [2, 2], "frame": "rest"}]
    out = tmp_path / "out"
    run_hyperqn([write_deck(tmp_path / "cut.yaml", deck), "-o", out], ranks=ranks)
    assert read_summary(out)["cuts"]["faces_separated"] == 8
    frame = final_frame(out)
    momentum = lumped_masses(frame) @ frame.velocity
    expected = 10 * 0.02 * 2.5 * TRACTION
    print(f"momentum {momentum}, 10 h A t = {expected}")
    assert np.abs(momentum - expected).max() <= 1e-6 * np.abs(expected).max()


def test_momentum_under_a_ramp(tmp_path):
    """A force whose curve ramps from 0 at t = 0 to 1 at t = 0.5: step k (k = 1..10, h = 0.02)
    pushes with F c(k h), the load at the time the step solves for."""
    deck = copy.deepcopy(FREE)
    deck["loads"] = [{"type": "force", "box": EVERYWHERE, "force": FORCE.tolist(),
                      "curve": {"type": "ramp", "start": 0, "end": 0.5}}]
    out = tmp_path / "out"
    run_hyperqn([write_deck(tmp_path / "ramp.yaml", deck), "-o", out], ranks=1)
    frame = final_frame(out)
    momentum = lumped_masses(frame) @ frame.velocity
    expected = 0.02 * FORCE * sum(k * 0.02 / 0.5 for k in range(1, 11))
    print(f"momentum {momentum}, h F sum c(t_k) = {expected}")
    assert np.abs(momentum - expected).max() <= 1e-6 * np.abs(expected).max()


def test_tip_load_deck_at_1_and_2_ranks(tmp_path):
    path = os.path.join(REPO, "input/engineering/bar_tip_load.yaml")
    outs = {}
    for ranks in (1, 2):
        outs[ranks] = tmp_path / f"np{ranks}"
        proc = run_hyperqn([path, "-o", outs[ranks]], ranks=ranks)
        assert "open: normals of each step's start" in proc.stdout
    rel, diff, scale = relative_difference(outs[1], outs[2])
    print(f"1 vs 2 ranks: {diff:.3e} of a sag of {scale:.3e}")
    assert rel <= 1e-10
    frame = final_frame(outs[1])
    tip = frame.points[:, 0] > 3.99
    assert frame.displacement[tip, 1].mean() < -0.01, "the end goes down"


GOOD = load_deck("input/engineering/bar_tip_load.yaml")
END = {"min": [3.99, -0.01, -0.01], "max": [4.01, 1.01, 1.01]}


def with_loads(*loads):
    deck = copy.deepcopy(GOOD)
    deck["loads"] = list(loads)
    return deck


# deck line 13 is the loads: key, 14 its first item (write_deck writes keys in this order)
BAD_LOADS = {
    "unknown_type": (with_loads({"type": "gravity", "box": END}), ["'loads[0].type'", "traction", "pressure", "force"]),
    "no_traction": (with_loads({"type": "traction", "box": END}), ["'loads[0].traction'", "required"]),
    "negative_pressure": (with_loads({"type": "pressure", "box": END, "pressure": -1.0}), ["'loads[0].pressure'", "> 0"]),
    "zero_pressure": (with_loads({"type": "pressure", "box": END, "pressure": 0.0}), ["'loads[0].pressure'", "> 0"]),
    "infinite_pressure": (with_loads({"type": "pressure", "box": END, "pressure": float("inf")}), ["'loads[0].pressure'"]),
    "zero_force": (with_loads({"type": "force", "box": END, "force": [0, 0, 0]}), ["'loads[0].force'", "nonzero"]),
    "key_of_another_type": (with_loads({"type": "force", "box": END, "force": [0, 1, 0], "pressure": 3.0}),
                            ["'loads[0].pressure'", "pressure"]),
    "normal_of_a_force": (with_loads({"type": "force", "box": END, "force": [0, 1, 0], "normal": [1, 0, 0]}),
                          ["'loads[0].normal'", "acts on vertices"]),
    "angle_without_normal": (with_loads({"type": "traction", "box": END, "traction": [0, 1, 0], "angle": 5}),
                             ["'loads[0].angle'", "`normal`"]),
    "box_inside_out": (with_loads({"type": "traction", "box": {"min": [4.01, 0, 0], "max": [3.99, 1, 1]},
                                   "traction": [0, 1, 0]}), ["'loads[0].box'", "min > max along x"]),
    "no_face_in_box": (with_loads({"type": "traction", "box": {"min": [2, 0.2, 0.2], "max": [2.1, 0.8, 0.8]},
                                   "traction": [0, 1, 0]}), ["'loads[0].box'", "selects no boundary face"]),
    "no_face_with_normal": (with_loads({"type": "pressure", "box": END, "pressure": 1.0, "normal": [0, 1, 0],
                                        "angle": 10}), ["'loads[0].box'", "selects no boundary face"]),
    "curve_of_one_point": (with_loads({"type": "force", "box": END, "force": [0, 1, 0],
                                       "curve": {"type": "table", "points": [[0, 1]]}}), ["'loads[0].curve", "point"]),
    "no_free_vertex": (with_loads({"type": "force", "box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 1.01, 1.01]},
                                   "force": [0, 1, 0]}), ["'loads[0].box'", "selects no free vertex"]),
    # the clamped end's faces: a traction there acted on nothing (the run said "on 2 boundary faces", ok)
    "traction_on_fixed_faces": (with_loads({"type": "traction", "box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 1.01, 1.01]},
                                            "traction": [1, 0, 0]}),
                                ["'loads[0].box'", "selects only boundary faces whose vertices are all fixed", "act on nothing"]),
    "pressure_on_fixed_faces": (with_loads({"type": "pressure", "box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 1.01, 1.01]},
                                            "pressure": 1.0}), ["'loads[0].box'", "vertices are all fixed"]),
    # a cloth has no tets' faces: widening the box (the message before) could not help
    "traction_on_a_cloth": ({"mesh": {"sheet": {"size": [1.0, 0.5], "cells": [4, 2]}},
                             "cloth": {"model": "mass-spring", "stretch_stiffness": 100.0, "areal_density": 0.2},
                             "fixed": [{"box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 0.01, 0.51]}}],
                             "time": {"dt": 0.01, "frames": 2},
                             "loads": [{"type": "traction", "box": {"min": [-1, -1, -1], "max": [2, 2, 2]}, "traction": [0, 1, 0]}]},
                            ["'loads[0].type'", "traction acts on the boundary faces of tets, and the scene has none"]),
}


@pytest.mark.parametrize("case", sorted(BAD_LOADS))
def test_bad_loads(tmp_path, case):
    deck, fragments = BAD_LOADS[case]
    path = write_deck(tmp_path / f"{case}.yaml", deck)
    outdir = tmp_path / "out"
    proc = run_hyperqn([path, "-o", outdir], ranks=None, check=False, timeout=60)
    assert_clean_failure(proc, outdir, [f"{case}.yaml"] + fragments)
