"""Contact with obstacles and friction (deck colliders:, contact:; terms/contact.hpp), end to end.

- A cube resting on the ground carries its weight: total contact force = m g within 1 %, and no
  vertex below the ground.
- Friction against the analytic answer: on a 30 degree incline a block with mu = 0.8 sticks
  (moves less than 1e-3 of its size in 1 s), with mu = 0.2 it slides with acceleration
  g (sin 30 - mu cos 30) within 3 %.
- A moving ball pressing into a clamped block: no vertex ends inside it; 1 and 2 ranks agree.
- The barrier's step bound does not depend on the ranks: Projective Dynamics, which backtracks
  from it at every step, takes the same iterations at 1 and 2 ranks.
- Every example deck of input/contact runs at 1 and 2 ranks with either model (reduced copies).
- A scene without colliders runs no contact code and writes no contact output.
- A start inside an obstacle: within the penalty's activation distance of its surface it runs,
  deeper it is an input error; a moving collider that pushes into the body faster than contact
  pushes back is flagged (console, summary.json's collider_intrusions); with the barrier the run
  stops, and its message names the collider and the vertex.
"""
import copy
import math
import os

import numpy as np
import pytest

from conftest import REPO, load_deck, run_deck, run_hyperqn, write_deck
from hyperqn_tools.output import final_frame, read_contact, read_frames, read_iterations, read_summary

G = 9.81
SIN30, COS30 = 0.5, math.sqrt(3) / 2
DOWN_SLOPE = np.array([-COS30, -SIN30, 0.0])


def run(tmp_path, name, deck, ranks=None):
    """Runs the deck and returns its output directory; the run must end ok."""
    out, s = run_deck(tmp_path, name, deck, ranks)
    assert s["failed_frames"] == 0
    return out


def cube_on_ground(frames=45):
    return {
        "mesh": {"box": {"size": [0.2, 0.2, 0.2], "cells": [4, 4, 4]}, "transform": {"translate": [-0.1, 0.002, -0.1]}},
        "material": {"model": "neohookean", "youngs_modulus": 1.0e6, "poisson_ratio": 0.3, "density": 1000},
        "colliders": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0], "friction": 0.5}],
        "gravity": [0, -G, 0],
        "time": {"dt": 1 / 30, "frames": frames},
        "solver": {"type": "lbfgs"},
        "output": {"every": frames},
    }


@pytest.mark.parametrize("model,ranks", [("penalty", None), ("penalty", 2), ("barrier", None), ("barrier", 2)])
def test_resting_cube_carries_its_weight(tmp_path, model, ranks):
    deck = cube_on_ground()
    deck["contact"] = {"model": model}
    out = run(tmp_path, "cube", deck, ranks=ranks)
    weight = 0.2 ** 3 * 1000 * G
    c = read_contact(out)
    s = read_summary(out)
    print(f"{model}, ranks {ranks}: last normal force / mg = {c['normal_force'][-1] / weight:.6f}, "
          f"friction {c['friction_force'][-1]:.3e} N, max penetration {s['max_penetration']:.3e} m, "
          f"{s['mean_iterations']:.2f} iterations/frame")
    assert abs(c["normal_force"][-1] / weight - 1) < 0.01
    assert c["friction_force"][-1] < 1e-3 * weight  # level ground: nothing to hold back
    assert s["max_penetration"] == 0  # resting contact stays within the activation layer
    assert np.all(c["max_penetration"] == 0)  # at the end of every frame
    frame = final_frame(out)
    assert frame.points[:, 1].min() > 0
    # The VTK field: the contact forces on the vertices add up to the total.
    assert abs(frame.contact_force[:, 1].sum() - c["normal_force"][-1]) < 1e-6 * weight
    assert np.abs(frame.velocity).max() < 1e-3  # at rest


# The cube's activation distance: 1e-2 of its rest diagonal (0.2 m sides).
CUBE_D = 1e-2 * 0.2 * math.sqrt(3)


@pytest.mark.parametrize("depth,runs", [(0.8 * CUBE_D, True), (1.2 * CUBE_D, False)])
def test_penalty_start_inside_the_layer_runs(tmp_path, depth, runs):
    """With the penalty a body may start inside an obstacle by up to the activation distance d
    (it is pushed out, with up to 4 times `stiffness` vertex weights); deeper is an input error."""
    deck = cube_on_ground(frames=5)
    deck["mesh"]["transform"]["translate"][1] = -depth
    out = tmp_path / "cube"
    proc = run_hyperqn([write_deck(tmp_path / "cube.yaml", deck), "-o", out], check=False)
    if runs:
        assert proc.returncode == 0, proc.stdout[-3000:]
        s = read_summary(out)
        assert s["status"] == "ok" and s["collider_intrusions"] == 0 and s["first_intrusion"] is None
        assert s["max_penetration"] < depth  # pushed back out
    else:
        assert proc.returncode == 1 and not out.exists()
        assert "'colliders[0]': the body starts inside this plane: 25 of its 125 free vertices" in proc.stdout


def ball_driven_in(speed, model, stiffness=None):
    """sphere_press with the ball driven down into the block at `speed` (m/s), just above it at t = 0."""
    deck = sphere_press(10)
    deck["mesh"]["box"]["cells"] = [6, 3, 6]
    ball = deck["colliders"][0]
    ball["center"] = [0, 0.46, 0]
    ball["motion"] = {"translate": {"velocity": [0, -speed, 0]}, "start": 0, "end": 10}
    deck["contact"] = {"model": model}
    if stiffness:
        deck["contact"]["stiffness"] = stiffness
    return deck


def test_penalty_flags_a_collider_driven_into_the_body(tmp_path):
    """A ball driven into the block faster than a soft penalty pushes back: the run completes,
    each frame that ends with a vertex deeper than d in the ball is flagged on the console, and
    summary.json counts them with the first one's frame and collider."""
    deck = ball_driven_in(0.6, "penalty", stiffness=1)
    out = tmp_path / "press"
    path = write_deck(tmp_path / "press.yaml", deck)
    proc = run_hyperqn([path, "-o", out])
    s = read_summary(out)
    warnings = [l for l in proc.stdout.splitlines() if "WARNING: colliders[0] (sphere, deck line" in l]
    print(f"{s['collider_intrusions']} frames flagged, first {s['first_intrusion']}; max penetration {s['max_penetration']:.3e} m")
    assert s["collider_intrusions"] == len(warnings) > 0
    first = s["first_intrusion"]
    assert f"frame {first['frame']:5d}  WARNING: {first['what']}" in proc.stdout
    assert "deeper than the activation distance" in first["what"] and "moved into the body" in first["what"]
    assert s["max_penetration"] > deck["contact"].get("distance", 1e-2 * math.sqrt(0.6 ** 2 * 2 + 0.3 ** 2))

    # A restart goes on from a state the run reached, a vertex deep in the ball included, and
    # keeps the count: interrupted after the first flagged frame, continued, the same summary.
    after = first["frame"]
    stopped = tmp_path / "stopped"
    proc = run_hyperqn([path, "-o", stopped, "-hyperqn_test_signal_after_frame", str(after)], check=False)
    assert proc.returncode == 3, proc.stdout[-2000:]
    run_hyperqn([path, "-o", stopped, "--restart", "latest"])
    again = read_summary(stopped)
    assert again["status"] == s["status"]
    assert again["collider_intrusions"] == s["collider_intrusions"] and again["first_intrusion"] == first


def test_barrier_stop_names_the_collider(tmp_path):
    """With the barrier a ball that reaches a vertex's x_n within one step leaves no admissible
    start: the run stops, and the message says which collider holds which vertex."""
    deck = ball_driven_in(3.0, "barrier")
    deck["solver"] = dict(deck.get("solver", {}), max_halvings=0, newton_fallback=False)
    out = tmp_path / "press"
    proc = run_hyperqn([write_deck(tmp_path / "press.yaml", deck), "-o", out], check=False)
    assert proc.returncode == 1
    s = read_summary(out)
    assert s["status"].startswith("error: frame ")
    assert "non-finite energy or gradient at every point tried" in s["status"]
    assert "colliders[0] (sphere, deck line" in s["status"] and "at or inside its surface" in s["status"]
    assert "the deepest: vertex" in s["status"]


def slope_track(out, dt):
    """Time and the block's mean displacement down the slope, per written frame."""
    frames = read_frames(out)
    t = np.array([f * dt for f, _ in frames])
    s = np.array([frame.displacement.mean(axis=0) @ DOWN_SLOPE for _, frame in frames])
    return t, s


def test_incline_sticks_with_mu_08(tmp_path):
    deck = load_deck("input/contact/incline_stick.yaml")
    deck["output"] = {"every": 5}
    out = run(tmp_path, "stick", deck)
    t, s = slope_track(out, deck["time"]["dt"])
    settled = t >= 0.2 - 1e-9  # the block settles into the contact layer first (the deck says how)
    moved = np.abs(s[settled] - s[settled][0]).max()
    print(f"mu = 0.8: largest displacement down the slope from t = 0.2 s to {t[-1]:.2f} s: {moved:.3e} m "
          f"(limit 2e-4 m; {s[settled][0]:.3e} m while settling)")
    assert t[-1] - 0.2 >= 1.0 - 1e-9
    assert moved < 1e-3 * 0.2


def test_incline_slides_with_mu_02(tmp_path):
    deck = load_deck("input/contact/incline_slide.yaml")
    deck["output"] = {"every": 5}
    out = run(tmp_path, "slide", deck)
    t, s = slope_track(out, deck["time"]["dt"])
    late = t >= 0.5  # after the block has settled onto the plane
    A = np.c_[np.ones(late.sum()), t[late], 0.5 * t[late] ** 2]
    acceleration = np.linalg.lstsq(A, s[late], rcond=None)[0][2]
    expected = G * (SIN30 - 0.2 * COS30)
    print(f"mu = 0.2: acceleration {acceleration:.4f} m/s^2, analytic {expected:.4f} "
          f"({100 * (acceleration / expected - 1):+.2f} %)")
    assert abs(acceleration / expected - 1) < 0.03


def sphere_press(frames):
    deck = load_deck("input/contact/sphere_press.yaml")
    deck["mesh"]["box"]["cells"] = [8, 4, 8]
    deck["time"]["frames"] = frames
    deck["output"] = {"every": frames}
    return deck


@pytest.mark.parametrize("model", ["penalty", "barrier"])
def test_moving_ball_presses_block_same_at_1_and_2_ranks(tmp_path, model):
    deck = sphere_press(30)  # the ball moves down 5 cm/s for 1 s
    deck["contact"] = {"model": model}
    # Solved to round-off: with the 10-iteration budget the frames end where the iterations stop,
    # and that depends on the order of the sums over ranks (1.4e-4 m apart here; docs/records/2026-11-23-contact-defaults.md).
    deck["solver"] = {"type": "lbfgs", "iterations": 300, "grad_rtol": 1.0e-11}
    outs = {r: run(tmp_path, f"press_np{r}", deck, ranks=r) for r in (1, 2)}
    frames = {r: final_frame(o) for r, o in outs.items()}
    ball = deck["colliders"][0]
    t = deck["time"]["frames"] * deck["time"]["dt"]
    center = np.array(ball["center"]) + np.array(ball["motion"]["translate"]["velocity"]) * min(t, ball["motion"]["end"])
    for r, frame in frames.items():
        phi = np.linalg.norm(frame.points - center, axis=1) - ball["radius"]
        print(f"{model}, {r} rank(s): min distance to the ball {phi.min():.3e} m; pressed depth "
              f"{-frame.displacement[:, 1].min():.4f} m")
        assert phi.min() >= 0, "a vertex ended inside the moving ball"
        assert -frame.displacement[:, 1].min() > 0.02, "the ball should press the block in"
    a, b = frames[1], frames[2]
    assert np.array_equal(a.vertex_id, b.vertex_id)
    diff = np.abs(a.points - b.points).max()
    print(f"1 vs 2 ranks: max |x1 - x2| = {diff:.3e} m")
    # The barrier's frames stall at the round-off of g (its log) before grad_rtol, where the line
    # search can no longer decrease g, at a residual below 1e-3 of the force scale: measured 6e-11
    # to 6e-7 m apart, depending on history and grad_rtol (docs/records/2026-11-23-contact-defaults.md).
    assert diff < (1e-8 if model == "penalty" else 1e-6)


def test_barrier_step_bound_same_at_1_and_2_ranks(tmp_path):
    """The barrier's step bound is 0.8 of the earliest impact over every vertex, whichever rank
    holds it: Projective Dynamics, whose every step backtracks from that bound, takes the same
    iterations in every frame at 1 and 2 ranks, and ends at the same positions. (When the bound
    was 0.8 of the impact of the first vertex a rank looked at, these frames took 289 and 261
    iterations at 1 and 2 ranks, 3.6e-3 m apart.)"""
    deck = shorten(load_deck("input/contact/bar_on_sphere.yaml"), frames=5)  # the bar lands at frame 3
    deck["contact"] = {"model": "barrier"}
    deck["solver"] = {"type": "pd"}
    outs = {r: run(tmp_path, f"bar_np{r}", deck, ranks=r) for r in (1, 2)}
    its = {r: [row["iteration"] for row in read_iterations(o)] for r, o in outs.items()}
    assert its[1] == its[2], "the frames took other iterations at 2 ranks"
    evaluations = {r: read_summary(o)["evaluations"] for r, o in outs.items()}
    assert evaluations[1] == evaluations[2]
    a, b = final_frame(outs[1]), final_frame(outs[2])
    assert np.array_equal(a.vertex_id, b.vertex_id)
    diff = np.abs(a.points - b.points).max()
    print(f"1 vs 2 ranks: {len(its[1])} iterations each, {evaluations[1]} evaluations, max |x1 - x2| = {diff:.3e} m")
    assert diff < 1e-10


# Example decks, reduced: (deck, changes to make it short).
def shorten(deck, frames, cells=None):
    deck = copy.deepcopy(deck)
    deck["time"]["frames"] = frames
    deck["output"] = {"every": frames}
    if cells:
        deck["mesh"]["box"]["cells"] = cells
    return deck


EXAMPLES = {
    "bar_on_sphere": dict(frames=20),
    "incline_stick": dict(frames=10),
    "incline_slide": dict(frames=10),
    "sphere_press": dict(frames=10, cells=[6, 3, 6]),
    "mesh_drop": dict(frames=15, cells=[6, 2, 6]),
    "bunny_drop": dict(frames=4),
}


@pytest.mark.parametrize("model", ["penalty", "barrier"])
@pytest.mark.parametrize("ranks", [1, 2])
@pytest.mark.parametrize("name", sorted(EXAMPLES))
def test_example_deck_runs(tmp_path, name, ranks, model):
    deck_dir = os.path.join(REPO, "input", "contact")
    short = shorten(load_deck(os.path.join(deck_dir, f"{name}.yaml")), **EXAMPLES[name])
    short["contact"] = dict(short.get("contact", {}), model=model)
    # The copy lives elsewhere: its relative mesh and obstacle paths become absolute.
    for item in [short["mesh"]] + short["colliders"]:
        if "file" in item:
            item["file"] = os.path.normpath(os.path.join(deck_dir, item["file"]))
            if not os.path.exists(item["file"]):
                pytest.skip(f"{item['file']} is absent (the shared meshes beside the checkout)")
    out = tmp_path / "out"
    proc = run_hyperqn([write_deck(tmp_path / f"{name}.yaml", short), "-o", out], ranks=ranks)
    s = read_summary(out)
    assert s["status"] == "ok" and s["failed_frames"] == 0, proc.stdout[-3000:]
    # Contact does not enter M + h^2 L: one factorization, unless the fallback chain used sub-steps
    # or L-BFGS's H0 took the contacts' stiffness (solver.h0_contact: refactor, the default).
    refactors = short.get("solver", {}).get("type", "lbfgs") == "lbfgs"
    assert s["contact_evaluations"] > 0 and (s["factorizations"] == 1 or s["substepped_frames"] > 0 or refactors)
    c = read_contact(out)
    assert len(c["frame"]) == short["time"]["frames"] * len(short["colliders"])
    if model == "barrier":
        assert np.all(c["max_penetration"] == 0)
    print(f"{name} ({model}) at {ranks} rank(s): {s['mean_iterations']:.2f} iterations/frame, {s['ms_per_frame']:.2f} ms/frame, "
          f"max penetration {s['max_penetration']:.2e} m, at most {s['max_active_contacts']} vertices in contact")


def test_history_reset_on_contact_change_runs(tmp_path):
    """solver.history_reset: contact-change (measured in docs/contact.md) runs and resets: the
    frames take other iterations than with the history kept."""
    deck = shorten(load_deck("input/contact/bar_on_sphere.yaml"), frames=20)
    keep = run(tmp_path, "keep", deck)
    deck["solver"]["history_reset"] = "contact-change"
    reset = run(tmp_path, "reset", deck)
    assert read_summary(keep)["iterations"] != read_summary(reset)["iterations"]


@pytest.mark.parametrize("ranks", [1, 2])
def test_h0_contact_same_answer(tmp_path, ranks):
    """solver.h0_contact changes L-BFGS's H0, not the answer: the cube landing on the slope ends where
    it does with (M + h^2 L)^{-1} alone, to the solver's tolerance, in fewer iterations."""
    deck = shorten(load_deck("input/contact/incline_stick.yaml"), frames=3)
    deck["solver"].update(iterations=1000, grad_rtol=1e-7)  # converged, so that the answers can agree
    ends, iterations = {}, {}
    for mode in ("off", "refactor", "woodbury"):
        deck["solver"]["h0_contact"] = mode
        out = run(tmp_path, mode, deck, ranks=ranks)
        ends[mode] = final_frame(out).points
        iterations[mode] = read_summary(out)["iterations"]
    size = 0.2
    for mode in ("refactor", "woodbury"):
        diff = np.abs(ends[mode] - ends["off"]).max()
        print(f"{mode} at {ranks} rank(s): {iterations[mode]} iterations (off: {iterations['off']}), "
              f"max |x - x_off| = {diff:.2e} m")
        assert diff < 1e-8 * size
        assert iterations[mode] < iterations["off"]


def test_no_colliders_no_contact_code(tmp_path):
    bar = load_deck("input/bar.yaml")
    bar["mesh"]["box"]["cells"] = [8, 2, 2]
    bar["time"]["frames"] = 3
    out = run(tmp_path, "bar", bar)
    s = read_summary(out)
    assert s["contact_evaluations"] == 0 and s["contact_s"] == 0 and s["max_active_contacts"] == 0
    assert not (out / "contact.csv").exists()
    assert final_frame(out).contact_force is None
