"""Per-region materials and prescribed motion of fixed regions, end to end."""
import numpy as np
import pytest

from conftest import run_hyperqn, write_deck
from hyperqn_tools.compare import relative_difference
from hyperqn_tools.output import final_frame, read_iterations, read_summary

BAR = {
    "mesh": {"box": {"size": [2.0, 0.5, 0.5], "cells": [8, 2, 2]}},
    "material": {"model": "neohookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 1000},
    "fixed": [{"box": {"min": [-0.01, -1, -1], "max": [0.01, 1, 1]}}],
    "time": {"dt": 0.05, "frames": 10},
    "solver": {"iterations": 50},
}
FREE_HALF = {"box": {"min": [1.0, -1, -1], "max": [3, 1, 1]}}


def run(tmp_path, name, deck, ranks=None):
    out = tmp_path / name
    run_hyperqn([write_deck(tmp_path / f"{name}.yaml", deck), "-o", out], ranks=ranks)
    assert read_summary(out)["status"] == "ok"
    return out


def test_region_with_the_default_material_changes_nothing(tmp_path):
    same = dict(BAR, regions=[dict(FREE_HALF, material=BAR["material"])])
    a, b = run(tmp_path, "plain", BAR), run(tmp_path, "same", same)
    assert np.array_equal(final_frame(a).points, final_frame(b).points)


def test_stiff_region_barely_strains(tmp_path):
    stiff = dict(BAR["material"], youngs_modulus=1.0e9)
    out = run(tmp_path, "stiff", dict(BAR, regions=[dict(FREE_HALF, material=stiff)]))
    f = final_frame(out)
    # Half of the cells are 1e4 times stiffer: their volume change |J - 1| must be far below the
    # soft half's.
    strain = np.abs(f.J - 1.0)
    assert strain.max() > 1e-3, "the soft half should deform under gravity"
    assert np.sort(strain)[: len(strain) // 2].max() < 1e-2 * strain.max()


@pytest.mark.parametrize("ranks", [1, 2])
def test_rotating_end_reaches_its_prescribed_pose(tmp_path, ranks):
    deck = dict(BAR, gravity=[0, 0, 0])
    deck["fixed"] = BAR["fixed"] + [{
        "box": {"min": [1.99, -1, -1], "max": [2.01, 1, 1]},
        "motion": {"rotate": {"axis": [1, 0, 0], "center": [2.0, 0.25, 0.25], "rate": 180.0},
                   "translate": {"velocity": [0.2, 0, 0]}, "start": 0.0, "end": 0.25}}]
    out = run(tmp_path, f"twist{ranks}", deck, ranks=ranks)
    f = final_frame(out)
    rest = f.points - f.displacement
    end = rest[:, 0] > 2.0 - 1e-9
    # After end = 0.25: rotated by 45 degrees about the axis through (., 0.25, 0.25), moved by 0.05 in x.
    c, th = np.array([2.0, 0.25, 0.25]), np.radians(45.0)
    R = np.array([[1, 0, 0], [0, np.cos(th), -np.sin(th)], [0, np.sin(th), np.cos(th)]])
    expected = (rest[end] - c) @ R.T + c + np.array([0.05, 0, 0])
    assert np.abs(f.points[end] - expected).max() < 1e-12
    # The clamped end did not move; the bar in between is twisted and stretched.
    assert np.abs(f.displacement[rest[:, 0] < 1e-9]).max() == 0
    assert np.all(np.isfinite(f.points)) and f.J.min() > 0


def test_moving_boundary_same_at_1_and_2_ranks(tmp_path):
    deck = dict(BAR, gravity=[0, 0, 0])
    deck["fixed"] = BAR["fixed"] + [{"box": {"min": [1.99, -1, -1], "max": [2.01, 1, 1]},
                                     "motion": {"rotate": {"axis": [1, 0, 0], "center": [2.0, 0.25, 0.25],
                                                           "rate": 360.0}}}]
    a, b = run(tmp_path, "np1", deck, ranks=1), run(tmp_path, "np2", deck, ranks=2)
    rel, _, _ = relative_difference(a, b)
    assert rel <= 1e-8


GMSH_DECK = {
    "mesh": {"file": "two_tets.msh"},
    "material": {"model": "neohookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 1000},
    "fixed": [{"box": {"min": [-0.1, -0.1, -0.1], "max": [0.1, 1.1, 1.1]}}],
    "time": {"frames": 3},
}


@pytest.mark.parametrize("ranks", [None, 2])
def test_gmsh_mesh_with_physical_groups_as_region_tags(tmp_path, ranks):
    import os
    import shutil
    from conftest import REPO
    shutil.copy(os.path.join(REPO, "input/meshes/two_tets.msh"), tmp_path)
    deck = dict(GMSH_DECK, regions=[{"tags": [2], "material": dict(GMSH_DECK["material"], youngs_modulus=1.0e7)}])
    out = run(tmp_path, "gmsh", deck, ranks=ranks)
    f = final_frame(out)
    assert len(f.vertex_id) == 5 and f.num_cells == 2 and np.all(np.isfinite(f.points))
    # A tag no element carries is an input error naming the region.
    bad = dict(GMSH_DECK, regions=[{"tags": [3], "material": GMSH_DECK["material"]}])
    proc = run_hyperqn([write_deck(tmp_path / "bad.yaml", bad), "-o", tmp_path / "bad"], ranks=ranks, check=False)
    assert proc.returncode != 0 and "regions[0]" in proc.stdout and "selects no element" in proc.stdout
    assert not (tmp_path / "bad").exists()


@pytest.mark.parametrize("ranks", [1, 2])
def test_released_end_untwists(tmp_path, ranks):
    # One end turns half a turn in 0.5 s, is held, and is released at t = 0.6: from then on its
    # vertices are free (one more factorization of M + h^2 L) and the bar untwists.
    from hyperqn_tools.output import Frame, read_pvd
    deck = dict(BAR, gravity=[0, 0, 0], time={"dt": 0.05, "frames": 30}, solver={"iterations": 30})
    deck["fixed"] = BAR["fixed"] + [{"box": {"min": [1.99, -1, -1], "max": [2.01, 1, 1]},
                                     "motion": {"rotate": {"axis": [1, 0, 0], "center": [2.0, 0.25, 0.25],
                                                           "rate": 360.0}, "end": 0.5},
                                     "release": 0.6}]
    out = run(tmp_path, f"release{ranks}", deck, ranks=ranks)
    s = read_summary(out)
    assert s["factorizations"] == 2 and s["frames"] == 30
    frames = read_pvd(out / f"release{ranks}.pvd")
    held, last = Frame(frames[11][1]), Frame(frames[-1][1])  # t = 0.55 (still held), t = 1.5
    rest = held.points - held.displacement
    end = rest[:, 0] > 2.0 - 1e-9
    twist_held = np.abs(held.displacement[end]).max()
    assert twist_held > 0.2, "the end should be turned half a turn while held"
    assert np.abs(last.displacement[end]).max() < 0.5 * twist_held, "released, the bar untwists"
    assert np.all(np.isfinite(last.points))
    rows = read_iterations(out)
    for prev, cur in zip(rows, rows[1:]):
        if cur["frame"] == prev["frame"]:
            assert cur["energy"] <= prev["energy"] * (1 + 1e-12) + 1e-300
