"""Springs that yield (strand_material.yield_strain, cloth.yield_strain, cloth.bending.yield_strain;
docs/yielding-springs.md), end to end.

- A strand of 4 segments, fixed at one end, pulled at the other by a force ramped to F and
  released (static load steps): each step's length against the closed form of 1-D plasticity with
  linear hardening, eps = F/EA + (F/EA - eps_y)/h beyond yield, and after the release the residual
  length L (1 + (F/EA - eps_y)/h) to 1e-9; summary.json's dissipated energy EA L eps_y eps_p. At 1
  and 2 ranks alike (to 1e-12); the same deck without the yield comes back to L.
- A cloth strip whose far half is folded 90 degrees about a line across it (a fixed region
  rotated, then released), bending springs that yield: the fold stays (the flap within 10 degrees
  of 90 at every frame after the release), while the elastic strip springs back (below 45 degrees).
  Newton steps; 1 and 2 ranks agree to 1e-12; a restart from a checkpoint in the middle of the fold (plastic flow) ends
  bit for bit as the uninterrupted run, at 1 and at 2 ranks.
"""
import copy
import math

import numpy as np
import pytest

from conftest import run_hyperqn, write_deck
from hyperqn_tools.output import Frame, final_frame, frame_list, read_summary

EA, EPS_Y, H, F = 100.0, 0.01, 0.5, 3.0
LOAD = [0, 0.2, 0.4, 0.6, 0.8, 1.0, 0.0, 0.0]  # the force's fraction at each load step's end (t = 0..7)

STRAND = {
    "mesh": {"strands": [{"from": [0, 0, 0], "to": [1, 0, 0], "segments": 4}]},
    "strand_material": {"axial_stiffness": EA, "linear_density": 0.1, "yield_strain": EPS_Y, "hardening": H},
    "fixed": [{"box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 0.01, 0.01]}}],
    "loads": [{"type": "force", "box": {"min": [0.99, -0.01, -0.01], "max": [1.01, 0.01, 0.01]}, "force": [F, 0, 0],
               "curve": {"type": "table", "points": [[float(t), c] for t, c in enumerate(LOAD)]}}],
    "gravity": [0, 0, 0],
    "time": {"dt": 1.0, "frames": len(LOAD) - 1, "integrator": "static"},
    "solver": {"type": "lbfgs", "iterations": 1000, "grad_rtol": 1e-11},
    "output": {"every": 1},
}


def closed_form_lengths():
    """The strand's length at each load step: elastic strain F/EA, plus the plastic strain the largest
    force so far left ((F/EA - eps_y)/h where positive; the loading is monotone until the release)."""
    lengths, eps_p = [], 0.0
    for c in LOAD:
        e = c * F / EA
        eps_p = max(eps_p, (e - EPS_Y) / H)
        lengths.append(1 + e + eps_p)
    return lengths


def lengths(outdir):
    return [Frame(path).points[:, 0].max() for _, _, path in frame_list(outdir)]


@pytest.mark.parametrize("ranks", [1, 2])
def test_strand_pull_and_release(tmp_path, ranks):
    out = tmp_path / "out"
    run_hyperqn([write_deck(tmp_path / "strand.yaml", STRAND), "-o", out], ranks=ranks)
    got, want = lengths(out), closed_form_lengths()
    assert len(got) == len(want)
    assert np.abs(np.array(got) - want).max() < 1e-9, list(zip(got, want))
    eps_p = (F / EA - EPS_Y) / H
    assert abs(got[-1] - (1 + eps_p)) < 1e-9  # the residual length L (1 + eps_p), L = 1
    assert read_summary(out)["dissipated_energy"] == pytest.approx(EA * 1.0 * EPS_Y * eps_p, rel=1e-9)
    # Points sorted by vertex id: every vertex where the uniform stretch puts it.
    final = final_frame(out)
    rest = final.points - final.displacement
    assert np.abs(final.points[:, 0] - rest[:, 0] * (1 + eps_p)).max() < 1e-9


def test_elastic_strand_comes_back(tmp_path):
    deck = copy.deepcopy(STRAND)
    del deck["strand_material"]["yield_strain"], deck["strand_material"]["hardening"]
    out = tmp_path / "out"
    run_hyperqn([write_deck(tmp_path / "strand.yaml", deck), "-o", out], ranks=1)
    got = lengths(out)
    assert abs(got[5] - (1 + F / EA)) < 1e-9 and abs(got[-1] - 1) < 1e-9
    assert "dissipated_energy" not in read_summary(out)  # no history: the elastic run as before


# A strip 1 x 0.2 of 10 x 2 cells in the x-z plane: x <= 0.4 clamped, x >= 0.6 turned 90 degrees
# about the z line through (0.5, 0, 0) in the first second, held, released at t = 1.5.
CREASE = {
    "mesh": {"sheet": {"size": [1.0, 0.2], "cells": [10, 2]}},
    "cloth": {"model": "mass-spring", "stretch_stiffness": 1.0e3, "areal_density": 0.2,
              "bending": {"model": "springs", "stiffness": 10.0, "yield_strain": 0.02, "hardening": 0.1}},
    "fixed": [{"box": {"min": [-0.01, -0.01, -0.01], "max": [0.41, 0.01, 0.21]}},
              {"box": {"min": [0.59, -0.01, -0.01], "max": [1.01, 0.01, 0.21]},
               "motion": {"rotate": {"axis": [0, 0, 1], "center": [0.5, 0, 0], "rate": 90}, "end": 1.0},
               "release": 1.5}],
    "gravity": [0, 0, 0],
    "time": {"dt": 0.05, "frames": 70},
    # Newton (the return map's tangent) converges every step, so 1 and 2 ranks agree to round-off;
    # lbfgs stops at its iteration cap after the release here, and the ranks' paths part by 1e-3.
    "solver": {"type": "newton", "iterations": 50, "grad_rtol": 1e-9},
    "output": {"every": 5},
}


def flap_angles(outdir):
    """[(time, the flap's angle in degrees)]: the far edge's (rest x = 1) mean direction from the crease."""
    out = []
    for _, t, path in frame_list(outdir):
        frame = Frame(path)
        rest = frame.points - frame.displacement
        tip = frame.points[np.abs(rest[:, 0] - 1.0) < 1e-9]
        out.append((t, math.degrees(math.atan2(tip[:, 1].mean(), tip[:, 0].mean() - 0.5))))
    return out


def test_crease_keeps_its_fold_and_elastic_springs_back(tmp_path):
    yielding = tmp_path / "yielding"
    run_hyperqn([write_deck(tmp_path / "crease.yaml", CREASE), "-o", yielding], ranks=1)
    elastic_deck = copy.deepcopy(CREASE)
    del elastic_deck["cloth"]["bending"]["yield_strain"], elastic_deck["cloth"]["bending"]["hardening"]
    elastic = tmp_path / "elastic"
    run_hyperqn([write_deck(tmp_path / "elastic.yaml", elastic_deck), "-o", elastic], ranks=1)
    after = [a for t, a in flap_angles(yielding) if t > 1.5 + 1e-9]
    assert len(after) >= 8 and max(abs(a - 90) for a in after) < 10, after
    assert min(a for t, a in flap_angles(elastic) if t > 1.5 + 1e-9) < 45
    assert read_summary(yielding)["dissipated_energy"] > 0 and "dissipated_energy" not in read_summary(elastic)
    # 1 and 2 ranks agree.
    two = tmp_path / "two"
    run_hyperqn([write_deck(tmp_path / "crease2.yaml", CREASE), "-o", two], ranks=2)
    a, b = final_frame(yielding), final_frame(two)
    assert np.abs(a.points - b.points).max() < 1e-12
    # The same strip as a body of a bodies deck (its mesh cut by METIS, hinges with the triangle
    # carrying their edge): at 2 ranks it stopped, "a yielding bending spring's hinge has no
    # triangle carrying its edge on its rank"
    body = {k: CREASE[k] for k in ("mesh", "cloth", "fixed")}
    bodies = dict({k: v for k, v in CREASE.items() if k not in body}, bodies=[body])
    as_body = tmp_path / "as_body"
    run_hyperqn([write_deck(tmp_path / "bodies.yaml", bodies), "-o", as_body], ranks=2)
    assert np.abs(final_frame(as_body).points - a.points).max() < 1e-12


@pytest.mark.parametrize("ranks", [1, 2])
def test_crease_restart_is_bitwise(tmp_path, ranks):
    """A checkpoint at frame 10 (t = 0.5: the fold half made, the crease's springs flowing)."""
    deck = dict(CREASE, time=dict(CREASE["time"], frames=30))
    one = tmp_path / "one"
    run_hyperqn([write_deck(tmp_path / "one.yaml", deck), "-o", one], ranks=ranks)
    restarted = tmp_path / "restarted"
    first = dict(deck, time=dict(deck["time"], frames=10), checkpoint={"every": 10})
    run_hyperqn([write_deck(tmp_path / "first.yaml", first), "-o", restarted], ranks=ranks)
    done = run_hyperqn([write_deck(tmp_path / "then.yaml", deck), "-o", restarted, "--restart", "latest"], ranks=ranks)
    assert "restart from" in done.stdout
    assert np.array_equal(final_frame(one).points, final_frame(restarted).points)
    assert read_summary(one)["dissipated_energy"] == read_summary(restarted)["dissipated_energy"]
