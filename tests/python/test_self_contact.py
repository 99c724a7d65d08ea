"""Self-contact (deck `contact: {self: true}`, docs/self-contact.md): two identical soft
blocks (two `bodies:`) fly at each other in empty space (no gravity, no damping, no colliders),
collide and bounce apart. With the barrier, hyperqn_tools.intersections finds no intersecting
surface triangles in any frame; the total momentum stays 0 to 1e-8 of one block's (every step
solved by Newton to round-off); the blocks exchange their momentum; 1, 2 and 4 ranks agree to
1e-8 of the diagonal. A cloth held along its middle folds onto itself without intersecting, its
halves a thickness farther apart with cloth.thickness. A block on a fixed block, gravity at 30
degrees to their contact's normal, slides with acceleration g (sin 30 - mu cos 30) within 2 % for
mu = 0.2 and sticks for mu = 0.8, at 1 and 2 ranks. A deck without self-contact runs none of its
code (its log event's count is 0); self-contact needs an integrator whose end of step is the
solve's, an activation distance and thickness below the surface's spacing at rest, and surfaces
that do not cross at frame 0 (the same pairs as hyperqn_tools.intersections counts). Newton's
restart after a kill is bitwise while the contacts change."""
import csv
import os
import re
import subprocess
import sys

import numpy as np
import pytest

from conftest import event_count, load_deck, run_hyperqn, write_deck
from hyperqn_tools.intersections import check_run
from hyperqn_tools.energy import frame_lumped_masses
from hyperqn_tools.output import read_frames, read_summary
from hyperqn_tools.paths import REPO
from test_checkpoint_faults import assert_restart_after_kill_is_bitwise

SIZE, GAP, SPEED, DENSITY = 0.2, 0.05, 1.0, 1000.0
DIAGONAL = np.linalg.norm([2 * SIZE + GAP, SIZE, SIZE])
MATERIAL = {"model": "neohookean", "youngs_modulus": 2.0e4, "poisson_ratio": 0.3, "density": DENSITY}


def block(name, x, velocity, y=0.0, z=0.0):
    return {"name": name, "mesh": {"box": {"size": [SIZE] * 3, "cells": [2, 2, 2]},
                                   "transform": {"translate": [x, y, z]}},
            "material": MATERIAL, "velocity": velocity}


def deck(model="barrier", frames=24, self_contact=True):
    # The second block a little off the first's axis: faces, edges and corners all meet.
    d = {"bodies": [block("left", 0.0, [SPEED, 0, 0]), block("right", SIZE + GAP, [-SPEED, 0, 0], 0.03, 0.02)],
         "gravity": [0, 0, 0],
         "time": {"dt": 0.01, "frames": frames},
         "solver": {"type": "newton", "iterations": 60, "budget": "fixed", "grad_rtol": 1e-12, "grad_atol": 0},
         "output": {"every": 1}}
    if self_contact:
        d["contact"] = {"self": True, "model": model, "distance": 5e-3}
    return d


def run(tmp_path, name, d, ranks=1):
    out = tmp_path / name
    log = tmp_path / f"{name}.log_view"
    run_hyperqn([write_deck(tmp_path / f"{name}.yaml", d), "-o", out, "-log_view", f":{log}"], ranks=ranks)
    assert read_summary(out)["status"] == "ok"
    return out, log.read_text()


def lumped_masses(frame):
    """Per vertex: DENSITY times a quarter of the rest volume of its tets (as hyperqn lumps them)."""
    return frame_lumped_masses(frame, DENSITY)


def momenta(frame):
    """Each block's momentum (vertex ids 0-26 the left block's, 27-53 the right's)."""
    m = lumped_masses(frame)[:, None] * frame.velocity
    return m[:27].sum(axis=0), m[27:].sum(axis=0)


@pytest.fixture(scope="module")
def barrier_runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("self_contact")
    return {ranks: run(tmp, f"np{ranks}", deck(), ranks) for ranks in (1, 2, 4)}


def test_blocks_bounce_apart_without_intersecting(barrier_runs):
    out, log = barrier_runs[1]
    frames = read_frames(out)
    one_block = 8.0 * SPEED  # 8 kg at 1 m/s
    worst = 0.0
    for n, frame in frames:
        left, right = momenta(frame)
        worst = max(worst, np.linalg.norm(left + right) / one_block)
    print(f"largest |total momentum| / one block's: {worst:.2e}")
    assert worst <= 1e-8
    left, right = momenta(frames[-1][1])
    print(f"after the collision: left block {left[0]:+.4f}, right block {right[0]:+.4f} kg m/s")
    assert left[0] < -0.3 * one_block and right[0] > 0.3 * one_block  # exchanged: they fly apart
    # Apart again, their centres farther apart than at the start (the collision also spins them).
    gaps = [f.points[27:, 0].mean() - f.points[:27, 0].mean() for _, f in frames]
    print("centres' distance in x per frame: " + " ".join(f"{g:.4f}" for g in gaps))
    assert min(gaps) < SIZE + GAP - 0.03 and gaps[-1] > SIZE + GAP and gaps[-1] > gaps[-2]
    rows = check_run(out)
    assert len(rows) == 25 and all(r["triangles"] == 96 for r in rows)
    assert [r["intersecting_pairs"] for r in rows] == [0] * 25
    assert event_count(log, "hqnSelfContact") > 0


@pytest.mark.parametrize("ranks", [2, 4])
def test_ranks_agree(barrier_runs, ranks):
    one = read_frames(barrier_runs[1][0])[-1][1]
    more_out, _ = barrier_runs[ranks]
    more = read_frames(more_out)[-1][1]
    difference = np.max(np.linalg.norm(one.points - more.points, axis=1)) / DIAGONAL
    print(f"1 against {ranks} ranks: {difference:.2e} of the diagonal")
    assert difference <= 1e-8
    assert [r["intersecting_pairs"] for r in check_run(more_out)] == [0] * 25


def test_penalty_bounces_too(tmp_path):
    out, _ = run(tmp_path, "penalty", deck("penalty"))
    left, right = momenta(read_frames(out)[-1][1])
    assert left[0] < 0 < right[0]


def crossing_deck():
    """The blocks thrown at each other at 10 m/s with the penalty at stiffness 1 (one weight at the
    layer's bottom): they pass through each other."""
    d = deck("penalty", frames=8)
    for body in d["bodies"]:
        body["velocity"] = [10 * v for v in body["velocity"]]
    d["contact"]["stiffness"] = 1.0
    return d


def crossing_rows(out):
    """self-contact.csv's crossing_pairs per frame."""
    lines = (out / "self-contact.csv").read_text().splitlines()
    assert lines[0] == "frame,time,crossing_pairs"
    return {int(r.split(",")[0]): int(r.split(",")[2]) for r in lines[1:]}


@pytest.mark.parametrize("ranks", [1, 2])
def test_penalty_counts_and_flags_crossed_frames(tmp_path, ranks):
    """Penalty self-contact gives no guarantee: the frames that end with crossing surface triangles
    are counted (self-contact.csv's crossing_pairs, the same pairs hyperqn_tools.intersections
    finds in the written frame), flagged (summary.json's self_crossing_frames, max_self_crossings
    and first_self_crossing; a WARNING line each), at 1 and 2 ranks. Before: status ok and no word."""
    out = tmp_path / "through"
    done = run_hyperqn([write_deck(tmp_path / "through.yaml", crossing_deck()), "-o", out], ranks=ranks)
    rows = crossing_rows(out)
    checked = {r["frame"]: r["intersecting_pairs"] for r in check_run(out)}
    assert rows == {f: n for f, n in checked.items() if f > 0}
    crossed = [f for f, n in rows.items() if n > 0]
    assert crossed, rows  # the blocks pass through each other
    summary = read_summary(out)
    assert summary["status"] == "ok"
    assert summary["self_crossing_frames"] == len(crossed)
    assert summary["max_self_crossings"] == max(rows.values())
    first = summary["first_self_crossing"]
    assert first["frame"] == crossed[0]
    assert first["what"].startswith(f"self-contact (penalty): {rows[crossed[0]]} pair")
    warnings = re.findall(r"^frame +(\d+) +WARNING: self-contact \(penalty\): (\d+) pairs? of surface triangles",
                          done.stdout, re.M)
    assert [(int(f), int(n)) for f, n in warnings] == [(f, rows[f]) for f in crossed]


def test_penalty_without_crossings_and_the_barrier_report_none(tmp_path):
    """The blocks at 1 m/s with the penalty at stiffness 1e4 bounce without crossing: every row 0 and
    nothing flagged (at the default stiffness, 1e3, they cross: 28 pairs from frame 3 on, which
    test_penalty_bounces_too's momenta do not see); the barrier, which cannot cross, counts nothing
    and writes no self-contact.csv."""
    stiff = deck("penalty", frames=8)
    stiff["contact"]["stiffness"] = 1e4
    out, _ = run(tmp_path, "bounce", stiff)
    assert set(crossing_rows(out).values()) == {0}
    summary = read_summary(out)
    assert (summary["self_crossing_frames"], summary["max_self_crossings"], summary["first_self_crossing"]) == (0, 0, None)
    out, _ = run(tmp_path, "bounce", deck("barrier", frames=2))  # into the penalty run's directory
    assert not (out / "self-contact.csv").exists()  # the earlier run's removed, none written
    assert read_summary(out)["self_crossing_frames"] == 0


def halves_gap(f):
    """The distance between the closest vertices of the folded sheet's two halves in frame f."""
    rest = f.points - f.displacement
    left, right = f.points[rest[:, 0] < 0.19], f.points[rest[:, 0] > 0.21]
    return np.min(np.linalg.norm(left[:, None, :] - right[None, :, :], axis=2))


def test_cloth_folds_onto_itself_without_intersecting(tmp_path):
    """A 0.4 m sheet held along its middle line: both halves fall into the same vertical plane
    below it. With the barrier they come to rest just inside d apart and never cross (without
    self-contact they pass through each other). With cloth.thickness t the contact acts on the
    distance less t (two layers: half of t each) with the same d: they meet at t + d instead of d.
    Nothing presses the halves together once they meet (gravity lies in their plane), so they stand
    at the edge of the layer where the swing leaves them: t + d to 0.1 d in every frame after they
    meet (measured: t + 0.988 d to t + 1.06 d, drifting slowly outward), never within t."""
    d = {"mesh": {"sheet": {"size": [0.4, 0.4], "cells": [8, 8]}},
         "cloth": {"model": "mass-spring", "stretch_stiffness": 1.0e3,
                   "bending": {"model": "springs", "stiffness": 1.0e-3}, "areal_density": 0.2},
         "fixed": [{"box": {"min": [0.19, -1, -1], "max": [0.21, 1, 1]}}],
         "gravity": [0, -9.81, 0], "time": {"dt": 1 / 60, "frames": 24}, "output": {"every": 1}}
    plain, _ = run(tmp_path, "fold_plain", d)
    assert max(r["intersecting_pairs"] for r in check_run(plain)) > 0
    d["contact"] = {"self": True, "model": "barrier", "distance": 5e-3}
    out, _ = run(tmp_path, "fold", d)
    assert [r["intersecting_pairs"] for r in check_run(out)] == [0] * 25
    closest = halves_gap(read_frames(out)[-1][1])
    print(f"the halves' closest vertices: {closest:.5f} m apart")
    assert 0 < closest < 5e-3  # they met: within the activation distance, not through
    thickness = 0.01
    d["cloth"]["thickness"] = thickness
    out, _ = run(tmp_path, "fold_thick", d)
    assert [r["intersecting_pairs"] for r in check_run(out)] == [0] * 25
    gaps = np.array([halves_gap(f) for _, f in read_frames(out)])
    print(f"with thickness {thickness}, the halves' closest vertices per frame (mm): " +
          " ".join(f"{1e3 * g:.2f}" for g in gaps))
    met = np.flatnonzero(gaps < thickness + 5e-3)[0]
    assert gaps.min() > thickness and np.all(np.abs(gaps[met:] - (thickness + 5e-3)) < 0.1 * 5e-3)


@pytest.mark.parametrize("ranks", [None, 2])
def test_distance_larger_than_the_mesh_spacing_is_an_input_error(tmp_path, ranks):
    """A flat 0.4 m sheet of 8 x 8 cells: its closest primitives that share no vertex (a vertex
    and the diagonal of the next cell) are 0.05/sqrt(2) = 0.0354 apart at rest. contact.distance
    0.04 would push the sheet apart from itself at rest: exit 1, nothing written, the deck line of
    contact.distance, the gap and a distance that fits; 0.03 runs."""
    d = {"mesh": {"sheet": {"size": [0.4, 0.4], "cells": [8, 8]}},
         "cloth": {"model": "mass-spring", "stretch_stiffness": 1.0e3, "areal_density": 0.2},
         "gravity": [0, -9.81, 0], "time": {"dt": 1 / 60, "frames": 2},
         "contact": {"self": True, "distance": 0.04}}
    path = write_deck(tmp_path / "coarse.yaml", d)
    line = next(n for n, text in enumerate(open(path).read().splitlines(), 1) if "distance:" in text)
    out = tmp_path / "coarse"
    proc = run_hyperqn([path, "-o", out], ranks=ranks, check=False)
    print(proc.stdout)
    assert proc.returncode == 1 and not out.exists()
    assert (f"coarse.yaml:{line}: 'contact.distance': 0.04 is too large for the surface: two of its primitives "
            "in one body that share no vertex") in proc.stdout
    assert "are 0.03536 apart at rest" in proc.stdout and "e.g. contact.distance: 0.017 (half of it), or " \
        "contact.self_distance for self-contact alone" in proc.stdout
    d["contact"]["distance"] = 0.03
    run(tmp_path, "fits", d, ranks or 1)


def test_thickness_larger_than_the_mesh_spacing_is_an_input_error(tmp_path):
    """The same sheet with thickness 0.04: its closest primitives (0.0354 apart) are within the
    thickness, which no activation distance fixes: exit 1, nothing written, the line of
    cloth.thickness and a thickness that fits (the gap less d = 0.005)."""
    d = {"mesh": {"sheet": {"size": [0.4, 0.4], "cells": [8, 8]}},
         "cloth": {"model": "mass-spring", "stretch_stiffness": 1.0e3, "areal_density": 0.2, "thickness": 0.04},
         "time": {"dt": 1 / 60, "frames": 2}, "contact": {"self": True, "distance": 0.005}}
    path = write_deck(tmp_path / "thick.yaml", d)
    line = next(n for n, text in enumerate(open(path).read().splitlines(), 1) if "thickness:" in text)
    proc = run_hyperqn([path, "-o", tmp_path / "thick"], ranks=None, check=False)
    print(proc.stdout)
    assert proc.returncode == 1 and not (tmp_path / "thick").exists()
    assert f"thick.yaml:{line}: 'cloth.thickness': 0.04 is too large for the cloth's mesh" in proc.stdout
    assert "are 0.03536 apart at rest, within the thickness" in proc.stdout and "e.g. 0.03" in proc.stdout


def test_bodies_that_start_crossed_are_an_input_error(tmp_path):
    """The two blocks, the second 0.05 into the first at frame 0: self-contact cannot separate
    them (barrier or penalty), so exit 1, nothing written, a message naming bodies[0] and
    bodies[1], the number of crossing triangle pairs and the first, the same at 1, 2 and 4 ranks;
    that number is what hyperqn_tools.intersections counts in frame 0 of the same scene run without
    self-contact."""
    d = deck(frames=1)
    d["bodies"][1]["mesh"]["transform"]["translate"] = [SIZE - 0.05, 0.03, 0.02]
    path = write_deck(tmp_path / "crossed.yaml", d)
    line = next(n for n, text in enumerate(open(path).read().splitlines(), 1) if "- name: left" in text)
    messages = {}
    for model, ranks in (("barrier", None), ("barrier", 2), ("barrier", 4), ("penalty", None)):
        d["contact"]["model"] = model
        path = write_deck(tmp_path / "crossed.yaml", d)
        out = tmp_path / f"crossed_{model}_{ranks}"
        proc = run_hyperqn([path, "-o", out], ranks=ranks, check=False)
        print(proc.stdout)
        assert proc.returncode == 1 and not out.exists()
        messages[model, ranks] = next(l for l in proc.stdout.splitlines() if "hyperqn: error:" in l)
    message = messages["barrier", None]
    assert f"crossed.yaml:{line}: 'bodies[0]': its surface and that of bodies[1] (deck line" in message
    assert "cross at frame 0" in message and "move the bodies apart" in message
    assert messages["barrier", 2] == message and messages["barrier", 4] == message
    assert messages["penalty", None] == message  # the penalty cannot separate them either
    count = int(re.search(r"(\d+) pairs of surface triangles in the scene cross", message).group(1))
    del d["contact"]
    out, _ = run(tmp_path, "crossed_plain", d)
    checked = check_run(out, frames=[0])[0]["intersecting_pairs"]
    print(f"crossing pairs: hyperqn {count}, hyperqn_tools.intersections {checked}")
    assert count == checked > 0


# Friction between surfaces (contact.self_friction): a 0.2 m block resting on a fixed 1 m x 0.1 m x
# 0.4 m block, with gravity at THETA to the normal of their faces (+y) and down the slope along +x:
# the analytic answer of a block on an incline, as test_contact.py's obstacle inclines.
THETA, G = np.radians(30.0), 9.81
INCLINE_DISTANCE = 5e-3


def incline_deck(mu, frames, friction_velocity):
    stiff = {"model": "corotated", "youngs_modulus": 1.0e6, "poisson_ratio": 0.3, "density": 1000}
    return {"bodies": [
                {"name": "incline", "material": stiff,
                 "mesh": {"box": {"size": [1.0, 0.1, 0.4], "cells": [5, 1, 2]}, "transform": {"translate": [-0.5, -0.1, -0.2]}},
                 "fixed": [{"box": {"min": [-1, -1, -1], "max": [1, 0.01, 1]}}]},
                # 0.9 d above it: about where it rests in the barrier's layer
                {"name": "block", "material": stiff,
                 "mesh": {"box": {"size": [0.2, 0.2, 0.2], "cells": [2, 2, 2]},
                          "transform": {"translate": [-0.4, 0.9 * INCLINE_DISTANCE, -0.13]}}}],
            "gravity": [float(G * np.sin(THETA)), float(-G * np.cos(THETA)), 0],
            "contact": {"self": True, "model": "barrier", "distance": INCLINE_DISTANCE, "self_friction": mu,
                        "friction_velocity": friction_velocity},
            "time": {"dt": 0.01, "frames": frames},
            # Newton to round-off: the frames end where the solve converges, not where an iteration
            # budget stops them (so 1 and 2 ranks agree to round-off)
            "solver": {"type": "newton", "grad_rtol": 1e-10},
            "output": {"every": 1}}


def block_track(out):
    """Times and the upper block's mean displacement along the slope (+x)."""
    frames = read_frames(out)
    t = np.array([n * 0.01 for n, _ in frames])
    x = np.array([f.displacement[-27:, 0].mean() for _, f in frames])  # the block's 27 vertices follow the incline's
    return t, x


@pytest.fixture(scope="module")
def incline_runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("self_incline")
    return {(name, ranks): run(tmp, f"{name}_np{ranks}", incline_deck(mu, frames, eps), ranks)[0]
            for name, mu, frames, eps in (("slide", 0.2, 25, 1e-2), ("stick", 0.8, 25, 1e-4)) for ranks in (1, 2)}


@pytest.mark.parametrize("ranks", [1, 2])
def test_block_slides_on_a_block_as_on_an_incline(incline_runs, ranks):
    t, x = block_track(incline_runs["slide", ranks])
    late = t >= 0.1  # after the block has settled into the barrier's layer
    A = np.c_[np.ones(late.sum()), t[late], 0.5 * t[late] ** 2]
    acceleration = np.linalg.lstsq(A, x[late], rcond=None)[0][2]
    expected = G * (np.sin(THETA) - 0.2 * np.cos(THETA))
    print(f"mu = 0.2, {ranks} rank(s): acceleration {acceleration:.4f} m/s^2, analytic {expected:.4f} "
          f"({100 * (acceleration / expected - 1):+.2f} %)")
    assert abs(acceleration / expected - 1) < 0.02
    assert [r["intersecting_pairs"] for r in check_run(incline_runs["slide", ranks])] == [0] * len(t)


@pytest.mark.parametrize("ranks", [1, 2])
def test_block_sticks_on_a_block_as_on_an_incline(incline_runs, ranks):
    t, x = block_track(incline_runs["stick", ranks])
    settled = t >= 0.1
    moved = np.abs(x[settled] - x[settled][0]).max()
    slide = 0.5 * G * (np.sin(THETA) - 0.2 * np.cos(THETA)) * (t[-1] - 0.1) ** 2  # with mu = 0.2
    print(f"mu = 0.8, {ranks} rank(s): displacement down the slope from t = 0.1 s to {t[-1]:.2f} s: {moved:.3e} m "
          f"({x[settled][0]:.3e} m while settling; with mu = 0.2 it slides {slide:.3f} m)")
    assert moved < 1e-3 * 0.2


def test_friction_ranks_agree(incline_runs):
    for name in ("slide", "stick"):
        one, two = (read_frames(incline_runs[name, r])[-1][1] for r in (1, 2))
        difference = np.max(np.linalg.norm(one.points - two.points, axis=1))
        print(f"{name}: 1 against 2 ranks {difference:.2e} m")
        assert difference <= 1e-6


# bodies_stack at 2 ranks only: 10 frames take 24 s at 1 rank (the whole scenes at 1 and 2 ranks
# are in docs/self-contact.md#tests-and-scenes; the blocks above compare 1, 2 and 4 ranks). blocks_stack3 at 1 rank
# until all three blocks have landed; cloth_ball on a coarser sheet; twist 3 times as fast, until
# the rod has buckled into a loop.
@pytest.mark.parametrize("name, frames, ranks", [("bodies_stack", 10, 2), ("cloth_pile", 6, 1), ("cloth_pile", 6, 2),
                                                 ("blocks_stack3", 10, 1), ("cloth_ball", 6, 1), ("twist", 12, 2)])
def test_example_deck_runs_without_intersecting(tmp_path, name, frames, ranks):
    """The self-contact scenes of input/contact/ (shortened: the slab lands on the cube, the cloth
    buckles, the cloth lands on the ball, the twisted rod buckles): every frame written, 0
    intersecting pairs in each."""
    d = load_deck(f"input/contact/{name}.yaml")
    d["time"]["frames"] = frames
    d["output"] = {"every": 1}
    if name == "cloth_ball":
        d["mesh"]["sheet"]["cells"] = [10, 10]
        d["time"]["dt"] = 0.05
    if name == "twist":  # the ends 3 times as fast
        for region in d["fixed"]:
            region["motion"]["rotate"]["rate"] *= 3
            region["motion"]["translate"]["velocity"][0] *= 3
    out, _ = run(tmp_path, name, d, ranks)
    assert [r["intersecting_pairs"] for r in check_run(out)] == [0] * (frames + 1)


def pusher_deck(wall=False):
    """A block fixed as a whole, its region moving at 0.5 m/s, 2 cm from a free block (or, with
    wall, from a block fixed as a whole that does not move; a free block far away). A step of 0.05 s
    carries the pusher's surface 2.5 cm: into the other block if the step's start were not checked
    (the base build, d9ab4de, runs it with 36 intersecting pairs at 0.4 s)."""
    everything = {"box": {"min": [-1, -1, -1], "max": [3, 1, 1]}}
    pusher = block("pusher", 0.0, [0, 0, 0])
    pusher["fixed"] = [dict(everything, motion={"translate": {"velocity": [0.5, 0, 0]}})]
    other = block("wall" if wall else "free", SIZE + 0.02, [0, 0, 0], 0.03, 0.02)
    bodies = [pusher, other]
    if wall:
        other["fixed"] = [everything]
        bodies.append(block("free", 2.0, [0, 0, 0]))
    return {"bodies": bodies, "gravity": [0, 0, 0], "time": {"dt": 0.05, "frames": 8},
            "contact": {"self": True, "model": "barrier", "distance": 5e-3}, "output": {"every": 1}}


@pytest.fixture(scope="module")
def pusher_runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("pusher")
    return {ranks: run(tmp, f"np{ranks}", pusher_deck(), ranks)[0] for ranks in (1, 2)}


@pytest.mark.parametrize("ranks", [1, 2])
def test_a_moving_fixed_region_pushes_a_surface_without_passing_through(pusher_runs, ranks):
    """The fixed vertices' jump at a step's start is checked (SelfContactTerm::begin_step): a step
    that would carry the pusher into the free block is refused and redone in sub-steps, between
    which the barrier pushes the free block ahead. 0 intersecting pairs in every frame, the free
    block ahead of the pusher at the end (at 2 ranks one rank holds only the pusher's fixed
    vertices); 1 and 2 ranks agree to 1e-10 of the diagonal."""
    out = pusher_runs[ranks]
    assert [r["intersecting_pairs"] for r in check_run(out)] == [0] * 9
    summary = read_summary(out)
    assert summary["substepped_frames"] > 0 and summary["rejected_evaluations"] > 0
    frames = read_frames(out)
    last = frames[-1][1].points
    assert last[:27, 0].max() == pytest.approx(0.4) and last[27:, 0].min() > 0.4  # moved 0.2 m: pushed ahead
    one = read_frames(pusher_runs[1])
    difference = max(np.max(np.abs(f.points - g.points)) for (_, f), (_, g) in zip(one, frames)) / DIAGONAL
    print(f"1 against {ranks} ranks: {difference:.2e} of the diagonal")
    assert difference <= 1e-10


def test_a_fixed_region_driven_into_a_fixed_surface_stops_naming_it(tmp_path):
    """Two fixed blocks, one moving into the other: no sub-step can keep their surfaces apart, so
    the run stops at the first frame (exit 1) with the moving region's deck line."""
    path = write_deck(tmp_path / "wall.yaml", pusher_deck(wall=True))
    lines = open(path).read().splitlines()
    line = next(n for n, text in enumerate(lines, 1) if text.strip() == "fixed:") + 1  # the pusher's region
    proc = run_hyperqn([path, "-o", tmp_path / "wall"], ranks=None, check=False)
    print(proc.stdout[-1500:])
    assert proc.returncode == 1
    assert (f"frame 1: non-finite energy or gradient at every point tried (REJECTED_INITIAL_GUESS): self-contact: "
            f"the fixed region of deck line {line} moves its surface into another surface within one step") in proc.stdout
    assert read_summary(tmp_path / "wall")["status"] != "ok"


def test_without_self_contact_none_of_its_code_runs(tmp_path):
    out, log = run(tmp_path, "plain", deck(self_contact=False, frames=4))
    assert event_count(log, "hqnSelfContact") == 0 and event_count(log, "hqnSelfGather") == 0


def test_needs_an_integrator_that_ends_at_the_solve(tmp_path):
    d = deck(frames=2)
    d["time"]["integrator"] = "implicit-midpoint"
    proc = run_hyperqn([write_deck(tmp_path / "mid.yaml", d), "-o", tmp_path / "mid"], ranks=None, check=False)
    assert proc.returncode == 1 and "implicit-midpoint does not take colliders or self-contact" in proc.stdout
    d = deck(frames=2)
    d["contact"] = {"model": "barrier"}
    proc = run_hyperqn([write_deck(tmp_path / "noself.yaml", d), "-o", tmp_path / "noself"], ranks=None, check=False)
    assert proc.returncode == 1 and "there are none (or self-contact: self: true)" in proc.stdout


def test_self_friction_needs_self_contact(tmp_path):
    d = incline_deck(0.5, 2, 1e-2)
    d["contact"]["self"] = False
    d["colliders"] = [{"type": "plane", "point": [0, -1, 0], "normal": [0, 1, 0]}]
    path = write_deck(tmp_path / "noself.yaml", d)
    line = next(n for n, text in enumerate(open(path).read().splitlines(), 1) if "self_friction" in text)
    proc = run_hyperqn([path, "-o", tmp_path / "noself"], ranks=None, check=False)
    print(proc.stdout)
    assert proc.returncode == 1 and not (tmp_path / "noself").exists()
    assert f"noself.yaml:{line}: 'contact.self_friction': self_friction is the friction between surfaces" in proc.stdout


# A body with a narrow gap: scripts/slit_mesh.py's split ring (0.5 m outer and 0.3 m inner
# radius, 0.2 m deep, 32 x 3 x 3 cells), its slit 5e-5 of the diagonal wide, dropped 10 cm onto
# the ground with the activation distance half the slit (what the message of a larger distance
# suggests).
def slit_ring_deck(tmp_path, frames, self_contact=True):
    mesh = tmp_path / "ring.mesh"
    if not mesh.exists():
        printed = subprocess.run([sys.executable, os.path.join(REPO, "scripts", "slit_mesh.py"), str(mesh),
                                  "--cells", "32", "3", "3"], capture_output=True, text=True, check=True).stdout
        print(printed)
    gap = 5e-5 * float(np.sqrt(0.5 ** 2 * 8 + 0.2 ** 2))
    return {"mesh": {"file": str(mesh), "transform": {"translate": [0, 0.6, 0]}},
            "material": {"model": "neohookean", "youngs_modulus": 2.0e5, "poisson_ratio": 0.4, "density": 1000},
            "colliders": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0], "friction": 0.5}],
            "contact": {"model": "barrier", "distance": gap / 2, "self": self_contact},
            "gravity": [0, -9.81, 0], "time": {"dt": 1 / 30, "frames": frames}, "output": {"every": 1}}


@pytest.mark.parametrize("ranks", [1, 2])
def test_a_body_with_a_narrow_slit_lands_without_crossing(tmp_path, ranks):
    """The split ring lands on the ground (frame 4) and squashes (frames 5, 6) with self-contact at
    a distance 2.5e-5 of its diagonal: every frame written, status ok, 0 intersecting pairs."""
    out, _ = run(tmp_path, f"ring{ranks}", slit_ring_deck(tmp_path, 6), ranks)
    assert [r["intersecting_pairs"] for r in check_run(out)] == [0] * 7


def lowest_heights(out):
    """The lowest vertex's height in each written frame."""
    return [float(frame.points[:, 1].min()) for _, frame in read_frames(out)]


@pytest.mark.parametrize("ranks", [1, 2])
def test_the_ground_keeps_its_own_distance_beside_a_slit(tmp_path, ranks):
    """contact.self_distance: the split ring with the colliders' distance 5e-3 m (140 times the
    slit's half) and self-contact's the slit's half (a single distance that large is refused,
    below). 0 intersecting pairs in every frame; from the landing on, the ring rests in the
    colliders' layer (its lowest vertex between 2.5e-3 and 5e-3 above the ground; measured
    4.1e-3 to 4.4e-3), where with one distance for both it comes within the slit's half
    (3.6e-5). The thin layer costs iterations where it is not needed: the 6 frames take fewer
    iterations with the ground's own distance (measured at 1 rank: 229 against 605)."""
    d = slit_ring_deck(tmp_path, 6)
    thin = d["contact"]["distance"]
    d["contact"].update({"distance": 5e-3, "self_distance": thin})
    out, _ = run(tmp_path, f"two{ranks}", d, ranks)
    assert [r["intersecting_pairs"] for r in check_run(out)] == [0] * 7
    assert all(2.5e-3 < h < 5e-3 for h in lowest_heights(out)[4:])
    if ranks == 1:
        one, _ = run(tmp_path, "one", slit_ring_deck(tmp_path, 6))
        assert 0 < min(lowest_heights(one)[4:]) < thin
        two_iterations, one_iterations = read_summary(out)["iterations"], read_summary(one)["iterations"]
        print("iterations: two distances", two_iterations, "one", one_iterations)
        assert two_iterations < one_iterations / 2


@pytest.mark.parametrize("case", ["without_self", "wider_than_the_slit", "larger_than_the_body"])
def test_a_bad_self_distance_is_an_input_error(tmp_path, case):
    """contact.self_distance without self-contact; wider than the ring's slit (the message names
    self_distance and its line, the gap and a distance that fits); larger than the body's rest
    diagonal. Each: exit 1, nothing written, the deck line of self_distance."""
    d = slit_ring_deck(tmp_path, 2)
    d["contact"].update({"distance": 5e-3, "self_distance": {"without_self": 1e-5, "wider_than_the_slit": 1e-4,
                                                              "larger_than_the_body": 2.0}[case]})
    if case == "without_self":
        d["contact"]["self"] = False
    path = write_deck(tmp_path / f"{case}.yaml", d)
    line = next(n for n, text in enumerate(open(path).read().splitlines(), 1) if "self_distance:" in text)
    out = tmp_path / case
    proc = run_hyperqn([path, "-o", out], ranks=None, check=False)
    print(proc.stdout)
    assert proc.returncode == 1 and not out.exists()
    prefix = f"{case}.yaml:{line}: 'contact.self_distance': "
    assert prefix + {"without_self": "self_distance is the activation distance between surfaces in self-contact, "
                                     "which is off",
                     "wider_than_the_slit": "0.0001 is too large for the surface: two of its primitives in one body",
                     "larger_than_the_body": "2 is larger than the body"}[case] in proc.stdout
    if case == "wider_than_the_slit":
        assert "are 7.141e-05 apart at rest" in proc.stdout and "e.g. contact.self_distance: 3.5e-05 (half of it)" in proc.stdout


def test_a_falling_body_keeps_its_candidate_list(tmp_path):
    """In free fall (frames 1 to 3) the surface only translates, which moves no pair: the candidate
    list is built once per step (hqnSelfPairs), not at every evaluation (7 builds in 3 steps when
    the translation counted as moves)."""
    out, log = run(tmp_path, "fall", slit_ring_deck(tmp_path, 3))
    assert read_summary(out)["iterations"] == 0  # every step solved at its start: a free fall
    assert event_count(log, "hqnSelfPairs") == 3


@pytest.mark.parametrize("ranks", [None, 2])
def test_newton_restart_after_a_kill_is_bitwise_while_contacts_change(tmp_path, ranks):
    """A block dropped onto a fixed slab (0.3 m below: it lands at frame 15 and bounces), Newton to
    round-off, killed after frame 30 and restarted from its checkpoint at 20: the same bits. Newton's
    Hessian holds the candidate list's couplings as explicit zeros; while it kept those of older,
    larger lists (made again only when a list held couplings it lacked), the restart, whose Hessian
    is new, factored another pattern: 7.9e-16 m apart at 1 rank, 2.3e-15 at 2 (before 2026-12-05)."""
    block = {"name": "block", "mesh": {"box": {"size": [0.2] * 3, "cells": [2, 2, 2]},
                                       "transform": {"translate": [-0.1, -0.7, -0.1]}},
             "material": {"model": "neohookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.4, "density": 1100}}
    slab = {"name": "slab", "mesh": {"box": {"size": [0.6, 0.1, 0.6], "cells": [3, 1, 3]},
                                     "transform": {"translate": [-0.3, -1.1, -0.3]}},
            "material": {"model": "neohookean", "youngs_modulus": 1.0e6, "poisson_ratio": 0.3, "density": 1000},
            "fixed": [{"box": {"min": [-0.31, -1.11, -0.31], "max": [0.31, -1.09, 0.31]}}]}
    d = {"bodies": [block, slab], "contact": {"model": "barrier", "self": True}, "gravity": [0, -9.81, 0],
         "time": {"dt": 1 / 60, "frames": 40},
         "solver": {"type": "newton", "iterations": 50, "grad_rtol": 1e-12, "grad_atol": 0}}
    assert_restart_after_kill_is_bitwise(tmp_path, d, ranks=ranks, frames=40, every=20, kill_after=30)


def test_a_collider_and_self_contact_bound_steps_alike_at_any_rank_count(tmp_path):
    """A cube on a barrier plane and a tilted slab falling onto it (Newton from the inertial guess,
    which the step bound pulls back): the collider cut the step's alpha on the ranks near the plane
    only, and self-contact then tested each rank's path at its own alpha. The pulled-back guess, and
    so the frame's first g, depended on the rank count (frame 4: 0.1255 at 1 rank, 0.0615 at 2).
    Now every term bounds the step the ranks agree on: the first g of every frame agrees."""
    d = {"bodies": [
            {"name": "cube", "mesh": {"box": {"size": [0.3, 0.3, 0.3], "cells": [3, 3, 3]},
                                       "transform": {"translate": [-0.15, 0.02, -0.15]}},
             "material": {"model": "neohookean", "youngs_modulus": 5.0e4, "poisson_ratio": 0.3, "density": 500}},
            {"name": "slab", "mesh": {"box": {"size": [0.4, 0.15, 0.25], "cells": [4, 2, 3]},
                                       "transform": {"rotate": [0, 0, 20], "translate": [-0.1, 0.4, -0.125]}},
             "material": {"model": "neohookean", "youngs_modulus": 5.0e4, "poisson_ratio": 0.3, "density": 500}}],
         "colliders": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0]}],
         "contact": {"self": True, "model": "barrier", "distance": 0.005},
         "gravity": [0, -9.81, 0],
         "time": {"dt": 0.0333333333, "frames": 6},
         "solver": {"type": "newton", "iterations": 100, "grad_rtol": 1.0e-10, "warm_start": "inertial"}}
    first = {}
    for ranks in (1, 2):
        out, _ = run(tmp_path, f"slab{ranks}", d, ranks)
        rows = list(csv.DictReader(open(out / "iterations.csv")))
        first[ranks] = np.array([float(r["energy"]) for r in rows if r["iteration"] == "0"])
    assert len(first[1]) == 6
    assert np.allclose(first[1], first[2], rtol=1e-9, atol=0), (first[1], first[2])
