"""Time curves (deck `curve`, docs/deck-scene.md#curve; params/curve.hpp) in motions, end to end.

- A fixed region moved by a table read from a CSV file is, at every output frame, where the table
  says (to 1e-12 m: rest + velocity c(t)); its vertices are bitwise the same at 1 and 2 ranks and
  the rest of the bar agrees to 1e-8 of its motion.
- A collider moved by a sine (a ball pressing into a block and coming back): no vertex ends a frame
  inside the ball where the sine puts it, the block is pressed in at the bottom of the sine.
- An attachment's targets moved by a ramp are the targets of the same motion given by start and
  end with the velocity over the ramp's length: the two runs agree to round-off.
- A restart from a checkpoint in the middle of the curves (a fixed region turning with a sine and
  released at the checkpoint's time, an attachment on a table) equals the uninterrupted run bitwise;
  one after the table file changed is refused (its values are physics).
- Bad curves: exit 1, the deck line and key named, nothing written.
"""
import copy
import os

import numpy as np
import pytest

from conftest import run_deck, run_hyperqn, write_deck
from hyperqn_tools.compare import relative_difference
from hyperqn_tools.output import final_frame, read_frames
from test_checkpoint import assert_same_run, interrupted_then_restarted
from test_checkpoint import run as run_to

BAR = {
    "mesh": {"box": {"size": [2.0, 0.5, 0.5], "cells": [8, 2, 2]}},
    "material": {"model": "neohookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 1000},
    "gravity": [0, 0, 0],
    "time": {"dt": 0.05, "frames": 10},
    "solver": {"iterations": 50},
}
CLAMP = {"box": {"min": [-0.01, -1, -1], "max": [0.01, 1, 1]}}
END = {"min": [1.99, -1, -1], "max": [2.01, 1, 1]}
# Pulled out 0.1 m by t = 0.2, held, pushed back to 0.05 m at 0.4 (times of frames 4 and 8 and
# between them: the table's kinks at output frames and in between).
TABLE = "time, value\n0, 0\n0.2, 1\n0.3, 1\n0.4, 0.5\n"
VELOCITY = np.array([0.1, 0.0, 0.02])


def table_value(t):
    points = np.array([[0, 0], [0.2, 1], [0.3, 1], [0.4, 0.5]])
    return float(np.interp(t, points[:, 0], points[:, 1]))


def run(tmp_path, name, deck, ranks=None):
    out, s = run_deck(tmp_path, name, deck, ranks)
    assert s["failed_frames"] == 0
    return out


def pulled_bar(tmp_path):
    (tmp_path / "pull.csv").write_text(TABLE)
    deck = copy.deepcopy(BAR)
    deck["fixed"] = [CLAMP, {"box": END, "motion": {"translate": {"velocity": VELOCITY.tolist()},
                                                   "curve": {"type": "table", "file": "pull.csv"}}}]
    return deck


def test_fixed_region_follows_a_table_at_1_and_2_ranks(tmp_path):
    deck = pulled_bar(tmp_path)
    outs = {r: run(tmp_path, f"pulled_np{r}", deck, ranks=r) for r in (1, 2)}
    frames = {r: read_frames(out) for r, out in outs.items()}
    assert len(frames[1]) == 11
    worst = 0.0
    for (n, f1), (_, f2) in zip(frames[1], frames[2]):
        t = n * deck["time"]["dt"]
        rest = f1.points - f1.displacement
        end = rest[:, 0] > 2.0 - 1e-9
        assert end.sum() == 9
        expected = rest[end] + table_value(t) * VELOCITY
        worst = max(worst, np.abs(f1.points[end] - expected).max())
        assert np.array_equal(f1.points[end], f2.points[end]), f"frame {n}: the moved vertices differ between 1 and 2 ranks"
    print(f"moved end against the table: max |x - (X + v c(t))| = {worst:.2e} m")
    assert worst < 1e-12
    last = frames[1][-1][1]
    assert np.abs(last.displacement[:, 0]).max() > 0.04, "the bar should be stretched"
    rel, _, _ = relative_difference(outs[1], outs[2])
    assert rel <= 1e-8


def test_collider_moved_by_a_sine(tmp_path):
    """A ball (radius 0.15 m) 1 cm above a soft block goes down and back up with
    y = 0.46 - 0.05 (1 - cos 2 pi t): 9 cm into the block's top at t = 0.5, back at t = 1."""
    deck = {
        "mesh": {"box": {"size": [0.6, 0.3, 0.6], "cells": [6, 3, 6]}, "transform": {"translate": [-0.3, 0, -0.3]}},
        "material": {"model": "neohookean", "youngs_modulus": 5.0e4, "poisson_ratio": 0.4, "density": 1000},
        "fixed": [{"box": {"min": [-0.31, -0.01, -0.31], "max": [0.31, 0.001, 0.31]}}],
        "colliders": [{"type": "sphere", "center": [0, 0.46, 0], "radius": 0.15,
                       "motion": {"translate": {"velocity": [0, -0.05, 0]},
                                  "curve": {"type": "sine", "amplitude": 1, "frequency": 1, "phase": -90, "offset": 1}}}],
        "contact": {"model": "barrier"},
        "gravity": [0, -9.81, 0],
        "time": {"dt": 1 / 30, "frames": 30},
        "solver": {"type": "lbfgs"},
    }
    out = run(tmp_path, "sine_ball", deck)
    depth = {}
    for n, frame in read_frames(out):
        t = n / 30
        center = np.array([0, 0.46 - 0.05 * (1 - np.cos(2 * np.pi * t)), 0])
        phi = np.linalg.norm(frame.points - center, axis=1) - 0.15
        assert phi.min() >= 0, f"frame {n}: a vertex inside the ball ({phi.min():.3e} m)"
        depth[n] = -frame.displacement[:, 1].min()
    print(f"pressed depth at t = 0.5: {depth[15]:.4f} m, at t = 1: {depth[30]:.4f} m")
    assert depth[15] > 0.06, "the ball at the bottom of its sine should press the block 9 cm deep"
    assert depth[30] < 0.5 * depth[15], "the ball came back up"


def test_attachment_targets_follow_a_ramp(tmp_path):
    """Targets moved 0.1 m up by a ramp from t = 0.1 to 0.3 are those of a translation at 0.5 m/s
    between start 0.1 and end 0.3 (the same motion to round-off)."""
    box = {"min": [1.99, -1, -1], "max": [2.01, 1, 1]}
    ramp = dict(BAR, fixed=[CLAMP], attachments=[{
        "box": box, "stiffness": 1.0e4,
        "motion": {"translate": {"velocity": [0, 0.1, 0]}, "curve": {"type": "ramp", "start": 0.1, "end": 0.3}}}])
    plain = copy.deepcopy(ramp)
    plain["attachments"][0]["motion"] = {"translate": {"velocity": [0, 0.5, 0]}, "start": 0.1, "end": 0.3}
    a, b = run(tmp_path, "ramp", ramp), run(tmp_path, "plain", plain)
    fa, fb = final_frame(a), final_frame(b)
    lifted = fa.displacement[(fa.points - fa.displacement)[:, 0] > 2.0 - 1e-9][:, 1]
    diff = np.abs(fa.points - fb.points).max()
    print(f"attached end lifted {lifted.mean():.4f} m (targets 0.1 m); ramp vs start/end: {diff:.2e} m")
    assert 0.05 < lifted.mean() < 0.15
    assert diff < 1e-10


# A fixed end turning with a sine, released at t = 0.2 (the checkpoint's time: it lets go with the
# curve's velocity there), and an attachment on a table still moving at the checkpoint.
RESTART = dict(BAR, time={"dt": 0.05, "frames": 8}, fixed=[CLAMP, {
    "box": END, "release": 0.2,
    "motion": {"rotate": {"axis": [1, 0, 0], "center": [2.0, 0.25, 0.25], "rate": 30.0},
               "curve": {"type": "sine", "amplitude": 1, "frequency": 1.5}}}],
    attachments=[{"box": {"min": [0.99, -1, -1], "max": [1.01, 1, 1]}, "stiffness": 1.0e3,
                  "motion": {"translate": {"velocity": [0, 0, 0.1]},
                             "curve": {"type": "table", "points": [[0, 0], [0.15, 1], [0.35, -1], [0.4, 0]]}}}],
    name="run")


@pytest.mark.parametrize("ranks", [None, 2])
def test_restart_mid_curve_is_bitwise_exact(tmp_path, ranks):
    ref = tmp_path / "uninterrupted"
    run_to(tmp_path, "ref", RESTART, ref, ranks)
    out = interrupted_then_restarted(tmp_path, RESTART, ranks, ranks)
    assert_same_run(ref, out)
    released = final_frame(ref)
    rest = released.points - released.displacement
    assert np.abs(released.velocity[rest[:, 0] > 2.0 - 1e-9]).max() > 0.01, "the released end should move"


def test_restart_with_a_changed_table_file_is_refused(tmp_path):
    """The values of a table read from a file are physics (the deck's text does not change with them)."""
    deck = dict(pulled_bar(tmp_path), name="run")
    deck["time"] = {"dt": 0.05, "frames": 4}
    out = tmp_path / "out"
    run_to(tmp_path, "first", dict(deck, checkpoint={"every": 2}), out)
    (tmp_path / "pull.csv").write_text(TABLE.replace("0.4, 0.5", "0.4, 0.6"))
    done = run_to(tmp_path, "then", dict(deck, time={"dt": 0.05, "frames": 8}), out, extra=["--restart", "latest"],
                  check=False)
    assert done.returncode == 1 and "the deck's physics differ" in done.stdout and "section(s) curve_tables" in done.stdout
    (tmp_path / "pull.csv").write_text(TABLE)  # the same table again: accepted
    run_to(tmp_path, "same", dict(deck, time={"dt": 0.05, "frames": 8}), out, extra=["--restart", "latest"])


FIXED = "fixed[1].motion"


@pytest.mark.parametrize("name,curve,key,message", [
    ("one_point", {"type": "table", "points": [[0, 0]]}, "curve.points", "is a table of 1 point: a table needs at least 2"),
    ("not_increasing", {"type": "table", "points": [[0, 0], [1, 1], [0.5, 2]]}, "curve.points[2]",
     "has the time 0.5, not after the previous point's 1: a table's times increase strictly"),
    ("not_finite", {"type": "table", "points": [[0, 0], [1, float("inf")]]}, "curve.points[1][1]", "expected a number"),
    ("missing_file", {"type": "table", "file": "none.csv"}, "curve.file", "file not found"),
    ("file_not_increasing", {"type": "table", "file": "back.csv"}, "curve.file",
     "back.csv' line 4: the row has the time 1, not after the previous point's 1"),
    ("file_not_finite", {"type": "table", "file": "nan.csv"}, "curve.file", "nan.csv' line 3: the value must be finite"),
    ("file_one_point", {"type": "table", "file": "one.csv"}, "curve.file", "one.csv' is a table of 1 point"),
    # a row is quoted as the mesh readers quote a token: control bytes as '?', cut at 64 characters
    # (before: the escapes reached the terminal, a 200 kB row the whole message)
    ("file_escape", {"type": "table", "file": "escape.csv"}, "curve.file",
     "escape.csv' line 3: expected a row 't, v' of two numbers, got '?[31mRED?[0m,1'"),
    ("file_long_row", {"type": "table", "file": "long.csv"}, "curve.file", "got '1," + "1" * 62 + "...'"),
    ("ramp_backwards", {"type": "ramp", "start": 1, "end": 0.5}, "curve.end", "must be > start (1), got 0.5"),
    ("not_zero_at_0", {"type": "sine", "amplitude": 1, "frequency": 1, "phase": 90}, "curve",
     "is 1 at t = 0, and a motion's curve starts at 0"),
    ("end_beside_curve", {"type": "ramp", "end": 1}, "end", "give either start and end or curve"),
])
def test_bad_curve_is_a_deck_error(tmp_path, name, curve, key, message):
    (tmp_path / "back.csv").write_text("t,v\n0,0\n1,1\n1,2\n")
    (tmp_path / "nan.csv").write_text("t,v\n0,0\n1,nan\n")
    (tmp_path / "one.csv").write_text("t,v\n0,0\n")
    (tmp_path / "escape.csv").write_text("t,v\n0,0\n\x1b[31mRED\x1b[0m,1\n")
    (tmp_path / "long.csv").write_text("t,v\n0,0\n1," + "1" * 200000 + "x\n")
    deck = copy.deepcopy(BAR)
    motion = {"translate": {"velocity": [0.1, 0, 0]}, "curve": curve}
    if name == "end_beside_curve":
        motion["end"] = 2
    deck["fixed"] = [CLAMP, {"box": END, "motion": motion}]
    path = write_deck(tmp_path / f"{name}.yaml", deck)
    out = tmp_path / name
    proc = run_hyperqn([path, "-o", out], check=False)
    assert proc.returncode == 1, proc.stdout[-2000:]
    assert f"{path}:" in proc.stdout and f"'{FIXED}.{key}':" in proc.stdout and message in proc.stdout, proc.stdout[-2000:]
    assert not out.exists()


@pytest.mark.skipif(os.geteuid() == 0, reason="root reads any file")
def test_unreadable_table_file_is_named(tmp_path):
    csv = tmp_path / "locked.csv"
    csv.write_text("0,0\n1,1\n")
    csv.chmod(0)
    deck = copy.deepcopy(BAR)
    deck["fixed"] = [CLAMP, {"box": END, "motion": {"translate": {"velocity": [0.1, 0, 0]},
                                                   "curve": {"type": "table", "file": "locked.csv"}}}]
    proc = run_hyperqn([write_deck(tmp_path / "locked.yaml", deck), "-o", tmp_path / "out"], check=False)
    assert proc.returncode == 1 and "cannot read the curve's table file" in proc.stdout and "locked.csv" in proc.stdout
    assert not (tmp_path / "out").exists()
