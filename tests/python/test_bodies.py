"""Scenes of several bodies (deck `bodies:`, docs/decks.md#bodies): a soft and a stiff block of
different materials fall side by side onto a ground plane, in one mesh with one factor and one
solve per iteration. Each lands as it does alone (to 1e-8 of its diagonal; every step solved by
Newton to round-off, so that only the coupling of the two solves could differ, and the contact's
distance-dependent defaults given explicitly: they follow the whole scene's diagonal); 1 and 2
ranks agree to 1e-8 (and 4, oversubscribed); a body's velocity and fixed regions are its own; the `body` cell field names
each tet's body; a one-body list is the plain deck."""
import copy

import numpy as np
import pytest

from conftest import run_hyperqn, write_deck
from hyperqn_tools.output import final_frame, read_summary

SIZE = 0.2
SOFT = {"name": "soft", "mesh": {"box": {"size": [SIZE] * 3, "cells": [2, 2, 2]}, "transform": {"translate": [0, 0.05, 0]}},
        "material": {"model": "neohookean", "youngs_modulus": 2.0e4, "poisson_ratio": 0.3, "density": 1000}}
STIFF = {"name": "stiff", "mesh": {"box": {"size": [SIZE] * 3, "cells": [2, 2, 2]}, "transform": {"translate": [0.5, 0.08, 0]}},
         "material": {"model": "corotated", "youngs_modulus": 1.0e6, "poisson_ratio": 0.4, "density": 500}}
DIAGONAL = SIZE * 3 ** 0.5
VERTICES = 27  # of each block: vertex ids 0-26 the first body's, 27-53 the second's


def scene(bodies, frames=30):
    return {
        "bodies": bodies,
        "colliders": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0]}],
        "contact": {"distance": 2e-3, "friction_velocity": 2e-3},
        "time": {"dt": 1.0 / 60, "frames": frames},
        "solver": {"type": "newton", "iterations": 50, "budget": "fixed", "grad_rtol": 1e-12, "grad_atol": 0},
        "output": {"every": frames},
    }


def run(tmp_path, name, deck, ranks=1):
    out = tmp_path / name
    run_hyperqn([write_deck(tmp_path / f"{name}.yaml", deck), "-o", out], ranks=ranks)
    assert read_summary(out)["status"] == "ok"
    return final_frame(out)


def by_id(m):
    """Final positions in vertex-id order (ids 0, 1, ... without gaps: boxes)."""
    assert np.array_equal(m.vertex_id, np.arange(len(m.vertex_id)))
    return m.points


def test_each_body_lands_as_it_does_alone(tmp_path):
    both = run(tmp_path, "both", scene([SOFT, STIFF]))
    x = by_id(both)
    for k, body in enumerate((SOFT, STIFF)):
        alone = by_id(run(tmp_path, body["name"], scene([body])))
        difference = np.max(np.linalg.norm(x[k * VERTICES:(k + 1) * VERTICES] - alone, axis=1)) / DIAGONAL
        print(f"{body['name']}: together against alone {difference:.2e} of its diagonal; lowest y {alone[:, 1].min():.4f}")
        assert difference <= 1e-8
        assert 0 < alone[:, 1].min() < 2e-3  # landed: resting within the contact distance of the ground
    assert np.bincount(both.body).tolist() == [48, 48]


def test_one_two_and_four_ranks_agree(tmp_path):
    a = by_id(run(tmp_path, "np1", scene([SOFT, STIFF])))
    for ranks in (2, 4):
        b = by_id(run(tmp_path, f"np{ranks}", scene([SOFT, STIFF]), ranks=ranks))
        difference = np.max(np.linalg.norm(a - b, axis=1)) / DIAGONAL
        print(f"1 against {ranks} ranks: {difference:.2e} of a block's diagonal")
        assert difference <= 1e-8


def test_velocity_and_fixed_regions_are_each_bodys_own(tmp_path):
    """The soft block flies off along z at 1 m/s without gravity; the stiff one is held by a box that
    also covers the soft block's vertices, but only the stiff body's fixed regions hold its own."""
    soft = dict(SOFT, velocity=[0, 0, 1.0])
    box = {"box": {"min": [-1, -1, -1], "max": [2, 2, 2]}}  # every vertex of both blocks
    stiff = dict(STIFF, fixed=[box])
    deck = scene([soft, stiff], frames=6)
    deck["gravity"] = [0, 0, 0]
    del deck["colliders"], deck["contact"]
    m = run(tmp_path, "fly", deck)
    by_id(m)
    u = m.displacement
    assert np.allclose(u[:VERTICES], [0, 0, 0.1], atol=1e-9)  # 6 frames of 1/60 s at 1 m/s, rigidly
    assert np.array_equal(u[VERTICES:], np.zeros((VERTICES, 3)))


def test_a_list_of_one_body_is_the_plain_deck(tmp_path):
    plain = copy.deepcopy(scene([]))
    del plain["bodies"]
    plain["mesh"], plain["material"] = SOFT["mesh"], SOFT["material"]
    a = by_id(run(tmp_path, "plain", plain))
    b = by_id(run(tmp_path, "list", scene([SOFT])))
    assert np.max(np.linalg.norm(a - b, axis=1)) / DIAGONAL <= 1e-10


@pytest.mark.parametrize("change, key, words", [
    (lambda d: d.update(mesh={"box": {"size": [1, 1, 1], "cells": [1, 1, 1]}}), "mesh", "each body has its own mesh"),
    (lambda d: d["bodies"][1].pop("material"), "bodies[1]", "material"),
    (lambda d: d["bodies"][1].update(name="soft"), "bodies[1].name", "another body is named soft"),
    (lambda d: d["bodies"][0].update(mesh={"sheet": {"size": [1, 1], "cells": [2, 2]}}), "bodies[0].mesh",
     "box or a tetrahedral mesh file"),
    (lambda d: d["bodies"][1].update(fixed=[{"box": {"min": [-1, -1, -1], "max": [0.3, 1, 1]}}]), "fixed[0].box",
     "selects no vertex of its body"),
])
def test_bad_bodies_are_input_errors(tmp_path, change, key, words):
    deck = scene(copy.deepcopy([SOFT, STIFF]))
    change(deck)
    out = tmp_path / "out"
    proc = run_hyperqn([write_deck(tmp_path / "bad.yaml", deck), "-o", out], ranks=1, check=False)
    assert proc.returncode == 1, proc.stdout
    assert key in proc.stdout and words in proc.stdout, proc.stdout
    assert not out.exists()
