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


# A spinning body let go (docs/deck-scene.md#fixed, `release`): the 2 m x 0.5 m x 0.5 m bar of 8 x 2 x 2
# cells is held by two fixed regions, its halves but the middle layer of vertices (x = 1), both
# turning at 360 degrees/s about the bar's long axis, and released at t = dt. From the step that
# starts at t = dt on it is free, and the released vertices keep the prescribed velocity at that
# moment, w x r: without gravity the bar goes on spinning. (Before the fix the release took effect
# at the step that ends at t = dt, i.e. at t = 0, with the vertices' velocity there, 0: the bar never
# moved.) The free middle layer lags behind at t = dt (about 1.8 rad/s), so the bar shares out the
# angular momentum L0 it has at the release: L0 = sum of m r x v over the vertices at t = dt, w x r
# for the released ones (lumped masses, axis through SPIN_CENTER). After the release L stays L0 as
# far as the integrator keeps angular momentum; the mean spin L0 / I is 0.91 of 2 pi.
SPIN_DT = 0.005
SPIN_CENTER = np.array([1.0, 0.25, 0.25])
SPIN = {"rotate": {"axis": [1, 0, 0], "center": SPIN_CENTER.tolist(), "rate": 360.0}}
# Measured |L / L0 - 1| over 40 frames (see the commit): implicit Euler 3.0e-2, BDF2 1.4e-3, the
# midpoint 5e-11 (it keeps angular momentum exactly; a release velocity off by the mean over a step
# instead of w x r would show as 4e-5).
SPIN_L_TOLERANCE = {"implicit-euler": 5e-2, "bdf2": 5e-3, "implicit-midpoint": 1e-8}


def spin_deck(release, integrator, frames):
    return {
        "mesh": {"box": {"size": [2.0, 0.5, 0.5], "cells": [8, 2, 2]}},
        "material": {"model": "neohookean", "youngs_modulus": 1.0e6, "poisson_ratio": 0.3, "density": 1000},
        "fixed": [{"box": {"min": [-0.01, -1, -1], "max": [0.76, 1, 1]}, "motion": SPIN, "release": release},
                  {"box": {"min": [1.24, -1, -1], "max": [2.01, 1, 1]}, "motion": SPIN, "release": release}],
        "gravity": [0, 0, 0],
        "time": {"dt": SPIN_DT, "frames": frames, "integrator": integrator},
        "solver": {"iterations": 100, "grad_rtol": 1e-9},
    }


def angular_momentum(frame, masses, velocity=None):
    """About the bar's axis (x through SPIN_CENTER)."""
    v = frame.velocity if velocity is None else velocity
    return np.sum(masses * np.cross(frame.points - SPIN_CENTER, v)[:, 0])


@pytest.mark.parametrize("integrator,ranks", [("bdf2", 1), ("bdf2", 2), ("implicit-euler", 1), ("implicit-midpoint", 1)])
def test_released_spinning_body_keeps_spinning(tmp_path, integrator, ranks):
    from hyperqn_tools.output import read_frames
    from test_self_contact import lumped_masses  # density 1000, as here
    out = tmp_path / f"spin_{integrator}_{ranks}"
    proc = run_hyperqn([write_deck(tmp_path / f"spin_{integrator}.yaml", spin_deck(SPIN_DT, integrator, 40)), "-o", out],
                       ranks=ranks)
    assert "t = 0.005: fixed region(s) released" in proc.stdout, proc.stdout[-2000:]
    assert read_summary(out)["status"] == "ok"
    frames = read_frames(out)
    held = frames[1][1]  # t = dt: the released vertices at their prescribed positions
    m = lumped_masses(held)
    middle = np.abs((held.points - held.displacement)[:, 0] - 1.0) < 1e-9
    w = np.array([2 * np.pi, 0, 0])
    v0 = np.where(middle[:, None], held.velocity, np.cross(w, held.points - SPIN_CENTER))
    L0 = angular_momentum(held, m, v0)
    r = held.points - SPIN_CENTER
    spin = L0 / np.sum(m * (r[:, 1] ** 2 + r[:, 2] ** 2))
    L = np.array([angular_momentum(f, m) for _, f in frames[2:]])  # from t = 2 dt: stepped free
    print(f"{integrator}, {ranks} rank(s): L0 = {L0:.6g} (mean spin {spin:.4f} rad/s), "
          f"|L / L0 - 1| <= {np.abs(L / L0 - 1).max():.2g}")
    assert abs(spin / (2 * np.pi) - 0.91) < 0.02, "the middle layer at t = dt should be all that lags"
    assert np.all(np.abs(L / L0 - 1) < SPIN_L_TOLERANCE[integrator]), L / L0


@pytest.mark.parametrize("ranks", [1, 2])
def test_release_is_logged_at_its_time(tmp_path, ranks):
    """A fixed region released at t = 10 dt and an attachment released at 6 dt: each takes effect
    at the step that starts at that time, and the log says so at that time."""
    deck = spin_deck(10 * SPIN_DT, "implicit-euler", 12)
    deck["fixed"] = deck["fixed"][:1]
    deck["attachments"] = [{"box": {"min": [1.99, -1, -1], "max": [2.01, 1, 1]}, "stiffness": 1.0e3,
                            "release": 6 * SPIN_DT}]
    out = tmp_path / f"logged{ranks}"
    proc = run_hyperqn([write_deck(tmp_path / "logged.yaml", deck), "-o", out], ranks=ranks)
    lines = [l for l in proc.stdout.splitlines() if "released or attachment(s) gone" in l]
    assert [l.split(":")[0] for l in lines] == ["t = 0.03", "t = 0.05"], proc.stdout[-3000:]
    assert read_summary(out)["factorizations"] == 3
