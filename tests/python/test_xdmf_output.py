"""output.format xdmf (io/xdmf_writer.hpp): one HDF5 file per run and an XDMF index, read here with
meshio's TimeSeriesReader and h5py.

- Its frames hold the positions, velocities and J of the VTK frames of the same deck (to 1e-8 of
  the rest diagonal), at 1 and 2 ranks, for tets, tets with strands (Mixed topology) and cloth
  with a collider (contact forces, stretch).
- The same deck at 1 and 2 ranks writes the same topology and vertex ids, and the same positions.
- A restart from a checkpoint cuts the series back to the checkpoint's frame (the later frames
  leave the index and the file) and goes on; with a release after the checkpoint (the mesh
  handed to the writer again) it equals an uninterrupted run.
- A later run into the same directory removes the earlier run's .xdmf and .h5.
"""
import copy
import os

import h5py
import meshio
import numpy as np
import pytest

from conftest import load_deck, run_hyperqn, write_deck
from hyperqn_tools.output import final_frame, read_frames, read_xdmf, rest_diagonal

TOL = 1e-8  # of the rest diagonal
CLOTH = {"mesh": {"sheet": {"size": [1.0, 0.5], "cells": [4, 2]}},
         "cloth": {"model": "mass-spring", "stretch_stiffness": 100.0, "areal_density": 0.2},
         "fixed": [{"box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 0.01, 0.51]}}],
         "colliders": [{"type": "plane", "point": [0, -0.3, 0], "normal": [0, 1, 0]}],
         "gravity": [0, -9.81, 0],
         "time": {"dt": 0.05, "frames": 3}}


def scene(name):
    if name == "bar":
        return load_deck("tests/decks/hanging_bar.yaml")
    if name == "rope":
        d = load_deck("tests/decks/box_on_rope.yaml")
        d["time"]["frames"] = 3
        return d
    return copy.deepcopy(CLOTH)


def run_format(tmp_path, deck, fmt, ranks, tag=""):
    d = copy.deepcopy(deck)
    d["name"] = "run"
    d["output"] = dict(d.get("output") or {}, every=1, format=fmt)
    out = tmp_path / f"{fmt}_np{ranks}{tag}"
    run_hyperqn([write_deck(tmp_path / f"{fmt}{tag}.yaml", d), "-o", out], ranks=ranks)
    return out


def assert_frames_close(a, b, diagonal, same_order):
    assert [n for n, _ in a] == [n for n, _ in b]
    for (_, fa), (_, fb) in zip(a, b):
        assert np.array_equal(fa.vertex_id, fb.vertex_id)
        assert np.abs(fa.points - fb.points).max() <= TOL * diagonal
        assert np.abs(fa.velocity - fb.velocity).max() <= TOL * max(1.0, np.abs(fb.velocity).max())
        assert fa.num_cells == fb.num_cells
        if fb.contact_force is None:
            assert fa.contact_force is None
        else:
            assert np.abs(fa.contact_force - fb.contact_force).max() <= TOL * max(1.0, np.abs(fb.contact_force).max())
        Ja, Jb = (fa.J, fb.J) if same_order else (np.sort(fa.J), np.sort(fb.J))  # VTK: per rank's piece
        assert np.abs(Ja - Jb).max() <= TOL


@pytest.mark.parametrize("name,ranks", [("bar", 1), ("bar", 2), ("rope", 2), ("cloth", 1), ("cloth", 2)])
def test_xdmf_holds_the_vtk_frames(tmp_path, name, ranks):
    deck = scene(name)
    vtu = read_frames(run_format(tmp_path, deck, "vtu", ranks))
    out = run_format(tmp_path, deck, "xdmf", ranks)
    assert set(os.listdir(out)) - {"iterations.csv", "contact.csv", "summary.json", "config.yaml"} == {"run.h5", "run.xdmf"}
    xdmf = read_frames(out)
    assert_frames_close(xdmf, vtu, rest_diagonal(vtu[0][1]), same_order=False)
    # meshio alone: the topology, each frame's time and fields.
    with meshio.xdmf.TimeSeriesReader(str(out / "run.xdmf")) as reader:
        points, cells = reader.read_points_cells()
        kinds = {"bar": {"tetra": 288}, "rope": {"tetra": 48, "line": 10}, "cloth": {"triangle": 16}}[name]
        assert {c.type: len(c.data) for c in cells} == kinds
        assert reader.num_steps == len(vtu)
        for k in range(reader.num_steps):
            t, point_data, cell_data = reader.read_data(k)
            assert t == pytest.approx(k * deck["time"]["dt"])
            assert point_data["displacement"].shape == (len(points), 3)
            assert ("contact_force" in point_data) == (name == "cloth")
            assert ("stretch" in cell_data) == (name == "cloth")


def test_one_and_two_ranks_write_the_same_arrays(tmp_path):
    deck = scene("rope")
    files = [h5py.File(run_format(tmp_path, deck, "xdmf", ranks) / "run.h5", "r") for ranks in (1, 2)]
    one, two = files
    for name in ("mesh/topology", "mesh/vertex_id", "mesh/rest"):
        assert np.array_equal(one[name][()], two[name][()]), name
    assert list(one["frames"]) == list(two["frames"]) == ["00000", "00001", "00002", "00003"]
    diagonal = float(np.linalg.norm(np.ptp(one["mesh/rest"][()], axis=0)))
    for frame in one["frames"]:
        for field in ("positions", "J"):
            a, b = one["frames"][frame][field][()], two["frames"][frame][field][()]
            assert np.abs(a - b).max() <= TOL * (diagonal if field == "positions" else 1.0), (frame, field)
    for f in files:
        f.close()


# The rotating end of test_checkpoint.py's MOTION, released at t = 0.25: the step to frame 6 (it
# starts at 0.25), after the checkpoint at 4, so both the restarted and the uninterrupted run hand
# the writer a new mesh.
BAR = {
    "mesh": {"box": {"size": [2.0, 0.5, 0.5], "cells": [8, 2, 2]}},
    "material": {"model": "neohookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 1000},
    "gravity": [0, -9.81, 0],
    "fixed": [{"box": {"min": [-0.01, -1, -1], "max": [0.01, 1, 1]}},
              {"box": {"min": [1.99, -1, -1], "max": [2.01, 1, 1]},
               "motion": {"rotate": {"axis": [1, 0, 0], "center": [2.0, 0.25, 0.25], "rate": 90.0}},
               "release": 0.25}],
    "time": {"dt": 0.05, "frames": 8},
    "solver": {"iterations": 50},
    "output": {"format": "xdmf"},
}


def test_restart_cuts_the_series_back_and_goes_on(tmp_path):
    whole = tmp_path / "whole"
    run_hyperqn([write_deck(tmp_path / "whole.yaml", dict(BAR, name="run")), "-o", whole], ranks=2)
    # 6 frames with a checkpoint at 4, then a restart from it with 8 frames: frames 5 and 6 of the
    # first part are abandoned.
    out = tmp_path / "restarted"
    first = dict(BAR, name="run", time={"dt": 0.05, "frames": 6}, checkpoint={"every": 4})
    run_hyperqn([write_deck(tmp_path / "first.yaml", first), "-o", out], ranks=2)
    assert [n for _, n, _ in read_xdmf(str(out / "run.xdmf"))] == list(range(7))
    done = run_hyperqn([write_deck(tmp_path / "then.yaml", dict(BAR, name="run")), "-o", out,
                        "--restart", str(out / "checkpoints" / "checkpoint_4.h5")], ranks=2)
    assert "released" in done.stdout
    listing = [(t, n) for t, n, _ in read_xdmf(str(out / "run.xdmf"))]
    assert listing == [(t, n) for t, n, _ in read_xdmf(str(whole / "run.xdmf"))]
    assert [n for _, n in listing] == list(range(9))
    with h5py.File(out / "run.h5", "r") as a, h5py.File(whole / "run.h5", "r") as b:
        assert list(a["frames"]) == list(b["frames"])
        for frame in a["frames"]:  # bitwise: the same rank count (docs/performance.md, "Reproducibility")
            for field in a["frames"][frame]:
                assert np.array_equal(a["frames"][frame][field][()], b["frames"][frame][field][()]), (frame, field)
    fa, fb = final_frame(out), final_frame(whole)
    assert np.array_equal(fa.points, fb.points)


def test_a_later_run_removes_the_xdmf_series(tmp_path):
    deck = scene("bar")
    out = run_format(tmp_path, deck, "xdmf", 1)
    d = dict(deck, name="run")
    run_hyperqn([write_deck(tmp_path / "vtu.yaml", d), "-o", out], ranks=None)
    names = os.listdir(out)
    assert "run.xdmf" not in names and "run.h5" not in names and "run.pvd" in names
