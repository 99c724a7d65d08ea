"""Reaction forces (deck output.reactions, reactions.csv, summary.json's reactions; model/reactions.hpp), end to end.

- A clamped bar under gravity brought to rest by long implicit Euler steps: the clamp's force is
  the bar's weight, upwards, and its moment about the clamp's centre that of the weight.
- The body's momentum balance at every frame with a moving clamp and a moving attachment:
  sum of the supports' forces + M g = sum_i m_i (v_{n+1,i} - v_{n,i}) / h over all vertices, the
  masses lumped from the frames' tets (rho V / 4), the velocities from the frames.
- A traction on faces that touch the clamp: the balance holds with its whole force added.
- A release: the freed region's force is 0 from then on, the balance holds across it.
- A bar held by attachments alone, at rest: their forces are the weight.
- 1 and 2 ranks (and 4, oversubscribed) give the same reactions.
- A restart gives the same reactions.csv (bitwise, same rank count) and summary as the
  uninterrupted run; a deck that does not ask writes no reactions.csv and a rerun removes one.
"""
import copy
import csv
import json
import os

import numpy as np
import pytest

from conftest import run_deck, run_hyperqn, write_deck
from hyperqn_tools.energy import frame_lumped_masses
from hyperqn_tools.output import Frame, read_pvd, read_summary

RHO, G = 1000.0, np.array([0.0, -9.81, 0.0])
SIZE = [1.0, 0.2, 0.2]
CLAMP = {"min": [-0.01, -0.01, -0.01], "max": [0.01, 0.21, 0.21]}
TIP = {"min": [0.99, -0.01, -0.01], "max": [1.01, 0.21, 0.21]}
NEWTON = {"type": "newton", "iterations": 50, "grad_rtol": 1e-13, "grad_atol": 0}


def bar(**extra):
    deck = {
        "mesh": {"box": {"size": SIZE, "cells": [6, 2, 2]}},
        "material": {"model": "neohookean", "youngs_modulus": 1.0e6, "poisson_ratio": 0.3, "density": RHO},
        "fixed": [{"box": CLAMP}],
        "gravity": [float(g) for g in G],
        "time": {"dt": 0.02, "frames": 8},
        "solver": dict(NEWTON),
        "output": {"reactions": True},
    }
    deck.update(copy.deepcopy(extra))
    return deck


def run(tmp_path, name, deck, ranks=None, extra=()):
    out, s = run_deck(tmp_path, name, deck, ranks, extra)
    assert s["failed_frames"] == 0 and s["substepped_frames"] == 0
    return out


def reactions(out):
    """{frame: {region: (time, force, moment, point)}} from reactions.csv."""
    rows = {}
    with open(out / "reactions.csv") as f:
        for r in csv.DictReader(f):
            vec = lambda a: np.array([float(r[a + c]) for c in "xyz"])
            rows.setdefault(int(r["frame"]), {})[r["region"]] = (float(r["time"]), vec("f"), vec("m"), vec("p"))
    return rows


def frames(out):
    return [Frame(str(out / p)) for _, p in read_pvd(out / [n for n in os.listdir(out) if n.endswith(".pvd")][0])]


def lumped_masses(frame):
    """Per vertex: RHO times a quarter of the rest volume of its tets (as hyperqn lumps them)."""
    return frame_lumped_masses(frame, RHO)


def weight():
    return RHO * np.prod(SIZE) * G


def test_clamp_at_rest_carries_the_weight(tmp_path):
    # h = 1 s, long against the bar's slowest period: implicit Euler damps its motion about tenfold a
    # step (the clamp's force is 392.40000 N to 6e-9 at frame 8, 8e-12 at frame 16).
    out = run(tmp_path, "rest", bar(time={"dt": 1.0, "frames": 16}))
    rows = reactions(out)
    assert sorted(rows) == list(range(1, 17))
    _, F, M, c = rows[16]["fixed[0]"]
    W = weight()
    print(f"clamp force {F}, weight {W}: relative difference {np.linalg.norm(F + W) / np.linalg.norm(W):.2e}")
    assert np.linalg.norm(F + W) < 1e-10 * np.linalg.norm(W)
    np.testing.assert_allclose(c, [0, 0.1, 0.1], atol=1e-15)  # the clamp box's centre
    # Moment: the weight's about c, reversed (sum_i (x_i - c) x m_i g over the deformed bar).
    last = frames(out)[-1]
    m = lumped_masses(last)
    weight_moment = np.cross(last.points - c, np.outer(m, G)).sum(axis=0)
    relative = np.linalg.norm(M + weight_moment) / np.linalg.norm(weight_moment)
    print(f"clamp moment {M}, weight's {weight_moment}: relative difference {relative:.2e}")
    assert relative < 1e-10
    s = read_summary(out)["reactions"]
    assert [r["name"] for r in s] == ["fixed[0]"] and s[0]["line"] > 0
    np.testing.assert_array_equal(s[0]["force"], F)
    assert s[0]["max_force"] >= np.linalg.norm(F)


MOVING = dict(
    fixed=[{"box": CLAMP, "motion": {"translate": {"velocity": [0, 0.5, 0.2]}}}],
    attachments=[{"box": TIP, "stiffness": 2.0e3, "motion": {"rotate": {"axis": [1, 0, 0], "rate": 30.0,
                                                                         "center": [1.0, 0.1, 0.1]}}}],
)


def balance_errors(out, extra_force=np.zeros(3)):
    """Per frame: |sum F + M g + extra_force - sum m dv/h| over the scale |sum m dv/h| + |M g|."""
    rows, series = reactions(out), frames(out)
    m = lumped_masses(series[0])
    h = 0.02
    errors = []
    for n in range(1, len(series)):
        inertia = (m[:, None] * (series[n].velocity - series[n - 1].velocity)).sum(axis=0) / h
        forces = sum(f for _, f, _, _ in rows[n].values())
        scale = np.linalg.norm(inertia) + np.linalg.norm(m.sum() * G)
        errors.append(np.linalg.norm(forces + m.sum() * G + extra_force - inertia) / scale)
    return errors


@pytest.fixture(scope="module")
def moving(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("reactions_moving")
    return {ranks: run(tmp, f"np{ranks}", bar(**MOVING), ranks=ranks) for ranks in (1, 2, 4)}


def test_momentum_balance_with_a_moving_clamp_and_attachment(moving):
    out = moving[1]
    rows = reactions(out)
    assert all(list(r) == ["fixed[0]", "attachments[0]"] for r in rows.values())
    assert all(np.linalg.norm(r["attachments[0]"][1]) > 0 for r in rows.values())
    errors = balance_errors(out)
    print("momentum balance, relative error per frame: " + ", ".join(f"{e:.1e}" for e in errors))
    assert len(errors) == 8 and max(errors) < 1e-11
    # The clamp moves with its box: the moment point does.
    for n, r in rows.items():
        np.testing.assert_allclose(r["fixed[0]"][3], [0, 0.1 + 0.5 * 0.02 * n, 0.1 + 0.2 * 0.02 * n], atol=1e-14)


def test_the_balance_test_can_fail(moving, tmp_path):
    """Reactions that left out the masses' inertia would not balance: a frame's clamp force changed by
    its inertia term m a fails the check above."""
    out = tmp_path / "tampered"
    os.makedirs(out)
    for name in os.listdir(moving[1]):
        if not os.path.isdir(moving[1] / name):
            (out / name).write_bytes((moving[1] / name).read_bytes())
    text = (out / "reactions.csv").read_text().splitlines()
    cells = text[1].split(",")
    cells[4] = repr(float(cells[4]) * (1 + 1e-6))  # fy of frame 1's clamp
    text[1] = ",".join(cells)
    (out / "reactions.csv").write_text("\n".join(text) + "\n")
    assert max(balance_errors(out)) > 1e-8


def test_rank_counts_agree(moving):
    one = reactions(moving[1])
    for ranks in (2, 4):
        other = reactions(moving[ranks])
        worst = 0
        for n, r in one.items():
            for name, (_, F, M, _) in r.items():
                _, F2, M2, _ = other[n][name]
                worst = max(worst, np.linalg.norm(F2 - F) / np.linalg.norm(F), np.linalg.norm(M2 - M) / np.linalg.norm(M))
        print(f"1 vs {ranks} ranks: largest relative difference of a force or moment {worst:.1e}")
        assert worst < 1e-11


def test_a_traction_on_clamped_faces_reaches_the_clamp(tmp_path):
    """A dead traction on the bar's top face, whose edge at x = 0 lies in the moving clamp: the share
    of its force on the clamped vertices is the clamp's to carry, and the balance holds with the
    traction's whole force t A added."""
    deck = bar(**MOVING)
    t = np.array([0.0, -500.0, 200.0])
    deck["loads"] = [{"type": "traction", "box": {"min": [-0.01, 0.19, -0.01], "max": [1.01, 0.21, 0.21]},
                      "normal": [0.0, 1.0, 0.0], "traction": [float(c) for c in t]}]
    out = run(tmp_path, "traction", deck)
    errors = balance_errors(out, extra_force=t * SIZE[0] * SIZE[2])
    print("momentum balance with a traction: " + ", ".join(f"{e:.1e}" for e in errors))
    assert max(errors) < 1e-11
    # Without the clamped vertices' share (the first column of cells' triangles, a third of each one's
    # force per vertex at x = 0: t / 60, 9 N) the balance would be off by 9 N of a scale of about 100 N.


@pytest.mark.parametrize("ranks", [1, 2])
def test_a_release_rebuilds_the_reactions(tmp_path, ranks):
    """The tip is fixed until t = 0.07 and then free, and the attachment on it (which leaves fixed
    vertices to their region) takes hold: the freed region's force is 0 from frame 5 on, the
    attachment's from then on not, and the balance holds at every frame, the release's included."""
    deck = bar(**MOVING)
    deck["fixed"].append({"box": TIP, "release": 0.07})
    out = run(tmp_path, f"released_np{ranks}", deck, ranks=ranks)
    rows = reactions(out)
    for n, r in rows.items():
        assert list(r) == ["fixed[0]", "fixed[1]", "attachments[0]"]
        held, pulled = np.linalg.norm(r["fixed[1]"][1]), np.linalg.norm(r["attachments[0]"][1])
        assert (held > 0 and pulled == 0) if n <= 4 else (held == 0 and pulled > 0), (n, held, pulled)
    errors = balance_errors(out)
    print(f"{ranks} rank(s), momentum balance with a release: " + ", ".join(f"{e:.1e}" for e in errors))
    assert max(errors) < 1e-11


@pytest.mark.parametrize("ranks", [1, 2])
@pytest.mark.parametrize("kind", ["traction", "force"])
def test_a_load_on_a_support_released_later_acts_from_the_release(tmp_path, kind, ranks):
    """A static bar clamped at both ends, a load on the tip's clamp released at t = 2: refused
    before ("selects only boundary faces whose vertices are all fixed", "selects no free vertex":
    the load would act on nothing), though from the release it acts. The clamps carry the weight
    and the load before, the left one alone after."""
    deck = bar(time={"dt": 1.0, "frames": 4, "integrator": "static"})
    deck["fixed"].append({"box": TIP, "release": 2})
    load = {"type": kind, "box": TIP}
    load.update({"traction": [0.0, -500.0, 0.0]} if kind == "traction" else {"force": [0.0, -5.0, 0.0]})
    deck["loads"] = [load]
    out = run(tmp_path, f"{kind}_np{ranks}", deck, ranks=ranks)
    rows = reactions(out)
    for n, r in rows.items():
        # a traction's share on held vertices is their support's; a force takes free vertices only
        applied = 500.0 * SIZE[1] * SIZE[2] if kind == "traction" else 5.0 * (n > 2)
        total = r["fixed[0]"][1] + r["fixed[1]"][1]
        assert abs(total[1] - (-weight()[1] + applied)) < 1e-8 * -weight()[1], (n, total)
        assert (np.linalg.norm(r["fixed[1]"][1]) > 0) == (n <= 2), (n, r["fixed[1]"])
    # a load on a support never released is still refused
    del deck["fixed"][1]["release"]
    proc = run_hyperqn([write_deck(tmp_path / "held.yaml", deck), "-o", tmp_path / "held"], ranks=None, check=False)
    assert proc.returncode == 1, proc.stdout[-2000:]
    assert ("the load would act on nothing" if kind == "traction" else "selects no free vertex") in proc.stdout


def test_attachment_at_rest_carries_the_weight(tmp_path):
    deck = bar(time={"dt": 1.0, "frames": 16})
    deck.pop("fixed")
    deck["attachments"] = [{"box": CLAMP, "stiffness": 1.0e5}, {"box": TIP, "stiffness": 1.0e5}]
    out = run(tmp_path, "attached", deck)
    last = reactions(out)[16]
    F = last["attachments[0]"][1] + last["attachments[1]"][1]
    W = weight()
    print(f"attachments' forces {last['attachments[0]'][1]} + {last['attachments[1]'][1]}, weight {W}")
    assert np.linalg.norm(F + W) < 1e-9 * np.linalg.norm(W)
    # Supports at both ends: each carries about half (the box's tets are not mirror-symmetric: 0.06 %).
    assert abs(last["attachments[0]"][1][1] + W[1] / 2) < 2e-3 * abs(W[1])


def test_restart_gives_the_same_reactions(tmp_path):
    deck = bar(**MOVING)
    whole = run(tmp_path, "whole", deck)
    out = tmp_path / "restarted"
    first = copy.deepcopy(deck)
    first["time"]["frames"] = 4
    first["checkpoint"] = {"every": 4}
    run_hyperqn([write_deck(tmp_path / "first.yaml", first), "-o", out])
    with open(out / "reactions.csv", "a") as f:  # rows of an abandoned frame, which the restart cuts
        f.write("5,0.1,fixed[0],1,2,3,4,5,6,7,8,9\n")
    run_hyperqn([write_deck(tmp_path / "then.yaml", deck), "-o", out, "--restart", "latest"])
    assert (out / "reactions.csv").read_text() == (whole / "reactions.csv").read_text()
    assert read_summary(out)["reactions"] == read_summary(whole)["reactions"]


def test_no_reactions_unless_asked(tmp_path):
    deck = bar()
    out = run(tmp_path, "asked", deck)
    assert (out / "reactions.csv").exists() and "reactions" in read_summary(out)
    deck["output"] = {}
    run_hyperqn([write_deck(tmp_path / "not.yaml", deck), "-o", out])  # the same directory
    assert not (out / "reactions.csv").exists()  # the earlier run's removed, none written
    assert "reactions" not in json.loads((out / "summary.json").read_text())


def test_reactions_of_a_scene_without_supports_are_warned_of(tmp_path):
    deck = bar()
    del deck["fixed"]
    deck["time"]["frames"] = 1
    done = run_hyperqn([write_deck(tmp_path / "free.yaml", deck), "-o", tmp_path / "free"])
    assert "warning: output.reactions: the scene has no fixed region or attachment" in done.stdout
    assert "warning" not in run_hyperqn([write_deck(tmp_path / "held.yaml", {**deck, "fixed": [{"box": CLAMP}]}),
                                         "-o", tmp_path / "held"]).stdout


def test_a_bad_value_is_an_input_error(tmp_path):
    deck = bar()
    deck["output"] = {"reactions": "sometimes"}
    out = tmp_path / "bad"
    proc = run_hyperqn([write_deck(tmp_path / "bad.yaml", deck), "-o", out], check=False)
    assert proc.returncode == 1 and "output.reactions" in proc.stdout, proc.stdout[-2000:]
    assert not out.exists()


def test_bodies_own_supports_are_named_as_the_deck_names_them(tmp_path):
    """A rope and a cloth hanging from their own fixed regions beside a block standing on its own:
    named bodies[k].fixed[0], each carrying its own body's weight once at rest."""
    rope = {"name": "rope", "mesh": {"strands": [{"from": [0.1, 0.5, 0.1], "to": [0.3, 0.5, 0.1], "segments": 4}]},
            "strand_material": {"axial_stiffness": 50.0, "linear_density": 0.1},
            "fixed": [{"box": {"min": [-1, -1, -1], "max": [0.1, 1, 1]}}]}
    block = {"name": "block", "mesh": {"box": {"size": [0.2] * 3, "cells": [2, 2, 2]}, "transform": {"translate": [0.5, 0.0, 0]}},
             "material": {"model": "neohookean", "youngs_modulus": 2.0e4, "poisson_ratio": 0.3, "density": 1000},
             "fixed": [{"box": {"min": [-1, -1, -1], "max": [1, 0.001, 1]}}]}
    cloth = {"name": "cloth", "mesh": {"sheet": {"size": [0.2, 0.2], "cells": [4, 4]}, "transform": {"translate": [-0.5, 0.3, 0]}},
             "cloth": {"model": "mass-spring", "stretch_stiffness": 1.0e3, "bending": {"model": "springs", "stiffness": 1.0},
                       "areal_density": 0.2},
             "fixed": [{"box": {"min": [-1, -1, 0.19], "max": [1, 1, 1]}}]}
    deck = {"bodies": [rope, block, cloth], "gravity": [0.0, -9.81, 0.0], "time": {"dt": 1.0, "frames": 16},
            "solver": dict(NEWTON), "output": {"reactions": True}}
    out = run(tmp_path, "bodies", deck)
    last = reactions(out)[16]
    assert list(last) == ["bodies[0].fixed[0]", "bodies[1].fixed[0]", "bodies[2].fixed[0]"]
    for name, mass in (("bodies[0].fixed[0]", 0.1 * 0.2), ("bodies[1].fixed[0]", 1000 * 0.2 ** 3),
                       ("bodies[2].fixed[0]", 0.2 * 0.2 ** 2)):
        F = last[name][1]
        print(f"{name}: {F}, weight {mass * 9.81}")
        assert np.linalg.norm(F - [0, mass * 9.81, 0]) < 1e-8 * mass * 9.81


@pytest.mark.parametrize("ranks", [None, 2])
def test_a_face_load_on_a_curve_reaches_the_support(tmp_path, ranks):
    """A traction on a ramp whose faces touch the clamp: its share at the clamped vertices reaches
    the clamp at the curve's value (before: the reactions' copy of the load stayed at c(0) = 0, so
    fixed[0] carried 750 N of the 1000 N, at every frame; without the curve 1000 N)."""
    deck = {"mesh": {"box": {"size": [1.0, 1.0, 1.0], "cells": [2, 2, 2]}},
            "material": {"model": "neohookean", "youngs_modulus": 1.0e6, "poisson_ratio": 0.3, "density": 1000},
            "fixed": [{"box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 1.01, 1.01]}}],
            "loads": [{"type": "traction", "box": {"min": [-0.01, 0.99, -0.01], "max": [1.01, 1.01, 1.01]},
                       "traction": [0, -1.0e3, 0], "curve": {"type": "ramp", "start": 0, "end": 2}}],
            "gravity": [0, 0, 0], "time": {"dt": 1, "frames": 2, "integrator": "static"},
            "solver": {"type": "lbfgs", "iterations": 400, "grad_rtol": 1.0e-10}, "output": {"reactions": True}}
    out = run(tmp_path, "ramp", deck, ranks)
    fy = [reactions(out)[frame]["fixed[0]"][1][1] for frame in (1, 2)]
    assert fy == pytest.approx([500.0, 1000.0], rel=1e-7), fy  # (the solve to grad_rtol 1e-10: 1.3e-8)


@pytest.mark.parametrize("load", ["force", "body_force"])
@pytest.mark.parametrize("ranks", [None, 2])
def test_a_vertex_load_on_rollers_reaches_them(tmp_path, load, ranks):
    # Found from outside: a cube on three roller planes, a force of 90 N on its x = 1 face (or a
    # body force of g): the floor's reaction was 60 N (the face's 3 vertices on the floor dropped
    # their 10 N each) and 7357.5 N of the weight's 9810 N; a traction, or gravity, gave the whole
    roller = lambda axis: {"box": {"min": [-0.01 if a != axis else -0.01 for a in range(3)],
                                   "max": [1.01 if a != axis else 0.01 for a in range(3)]}, "components": ["xyz"[axis]]}
    loaded = ({"type": "force", "box": {"min": [0.99, -0.01, -0.01], "max": [1.01, 1.01, 1.01]}, "force": [0, 0, -90.0]}
              if load == "force" else
              {"type": "body_force", "box": {"min": [-0.01] * 3, "max": [1.01] * 3}, "acceleration": [0, 0, -9.81]})
    deck = {"mesh": {"box": {"size": [1, 1, 1], "cells": [2, 2, 2]}},
            "material": {"model": "neohookean", "youngs_modulus": 1.0e6, "poisson_ratio": 0.3, "density": 1000},
            "fixed": [roller(0), roller(1), roller(2)], "loads": [loaded], "gravity": [0, 0, 0],
            "time": {"dt": 1, "frames": 1, "integrator": "static"},
            "solver": {"type": "newton", "iterations": 50, "grad_rtol": 1e-12}, "output": {"reactions": True}}
    out = run(tmp_path, "rollers", deck, ranks)
    total = sum(f for _, f, _, _ in reactions(out)[1].values())
    applied = 90.0 if load == "force" else 1000 * 9.81
    assert total == pytest.approx([0, 0, applied], abs=1e-6 * applied)
