"""Scenes of several bodies (deck `bodies:`, docs/deck-scene.md#bodies-instead-of-mesh-and-material):
a soft and a stiff block of different materials fall side by side onto a ground plane, in one mesh
with one factor and one solve per iteration. Each lands as it does alone (to 1e-8 of its diagonal;
every step solved by Newton to round-off, so that only the coupling of the two solves could differ,
and the contact's distance-dependent defaults given explicitly: they follow the whole scene's
diagonal); 1 and 2 ranks agree to 1e-8 (and 4, oversubscribed); a body's velocity, fixed regions
and attachments are its own; the `body` cell field names each element's body, in the VTK and the
XDMF frames; a one-body list is the plain deck. A cloth body (a sheet with its cloth block) and a
rope (strands with their strand_material) hang from their own fixed regions beside a falling block,
each as it does alone, at 1 and 2 ranks; a cloth, a rope and a block dropped onto the ground plane
come to rest on it, none below it, at 1 and 2 ranks alike; bad body keys are input errors."""
import copy
import json

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
# A cloth sheet in the x-z plane at y = 0.3, pinned along its edge z = 0.2 by a box that also holds
# the z = 0.2 face of a block beside it, but selects the cloth's vertices only.
CLOTH = {"name": "cloth", "mesh": {"sheet": {"size": [SIZE, SIZE], "cells": [4, 4]}, "transform": {"translate": [-0.5, 0.3, 0]}},
         "cloth": {"model": "mass-spring", "stretch_stiffness": 1.0e3, "bending": {"model": "springs", "stiffness": 1.0},
                   "areal_density": 0.2},
         "fixed": [{"box": {"min": [-1, -1, 0.19], "max": [1, 1, 1]}}]}
CLOTH_DIAGONAL = SIZE * 2 ** 0.5
CLOTH_VERTICES = 25
# A rope of 4 segments hanging from y = 0.5 beside the block, its top held by a box that also
# covers the block's vertices, but selects the rope's only.
ROPE = {"name": "rope", "mesh": {"strands": [{"from": [0.1, 0.5, 0.1], "to": [0.3, 0.5, 0.1], "segments": 4}]},
        "strand_material": {"axial_stiffness": 50.0, "linear_density": 0.1},
        "fixed": [{"box": {"min": [-1, -1, -1], "max": [0.1, 1, 1]}}]}
ROPE_LENGTH = 0.2
ROPE_VERTICES = 5


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


@pytest.fixture(scope="module")
def run_once(tmp_path_factory):
    """run() for the whole module, each deck at each rank count once: several tests compare with
    the same runs (both blocks, a block alone, a hanging scene at 1 rank)."""
    tmp, frames = tmp_path_factory.mktemp("bodies"), {}

    def run_or_reuse(name, deck, ranks=1):
        key = (json.dumps(deck, sort_keys=True), ranks)
        if key not in frames:
            frames[key] = run(tmp, f"{name}_{len(frames)}", deck, ranks)
        return frames[key]
    return run_or_reuse


def by_id(m):
    """Final positions in vertex-id order (ids 0, 1, ... without gaps: boxes)."""
    assert np.array_equal(m.vertex_id, np.arange(len(m.vertex_id)))
    return m.points


def test_each_body_lands_as_it_does_alone(run_once):
    both = run_once("both", scene([SOFT, STIFF]))
    x = by_id(both)
    for k, body in enumerate((SOFT, STIFF)):
        alone = by_id(run_once(body["name"], scene([body])))
        difference = np.max(np.linalg.norm(x[k * VERTICES:(k + 1) * VERTICES] - alone, axis=1)) / DIAGONAL
        print(f"{body['name']}: together against alone {difference:.2e} of its diagonal; lowest y {alone[:, 1].min():.4f}")
        assert difference <= 1e-8
        assert 0 < alone[:, 1].min() < 2e-3  # landed: resting within the contact distance of the ground
    assert np.bincount(both.body).tolist() == [48, 48]


def test_total_mass_is_spread_over_its_own_body(tmp_path, run_once):
    """A material given by total_mass spreads it over its own body's volume, not the scene's: the
    soft block given as 8 kg (its density times its volume) settles under its weight as with its
    density, beside the stiff block."""
    by_mass = copy.deepcopy(SOFT)
    del by_mass["material"]["density"]
    by_mass["material"]["total_mass"] = 1000 * SIZE ** 3
    x = by_id(run(tmp_path, "by_mass", scene([by_mass, STIFF])))[:VERTICES]
    alone = by_id(run_once("soft", scene([SOFT])))
    difference = np.max(np.linalg.norm(x - alone, axis=1)) / DIAGONAL
    print(f"total_mass against density: {difference:.2e} of the diagonal")
    assert difference <= 1e-8


def test_one_two_and_four_ranks_agree(run_once):
    a = by_id(run_once("both", scene([SOFT, STIFF])))
    for ranks in (2, 4):
        b = by_id(run_once("both", scene([SOFT, STIFF]), ranks=ranks))
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


def test_attachments_are_each_bodys_own(tmp_path):
    """Under gravity the stiff block hangs from an attachment whose box covers both blocks; the
    soft block falls freely (only the stiff body's attachments hold its own vertices). Each moves
    as it does alone."""
    box = {"min": [-1, -1, -1], "max": [2, 2, 2]}  # every vertex of both blocks
    stiff = dict(STIFF, attachments=[{"box": box, "stiffness": 50.0}])
    frames = 10
    deck = scene([SOFT, stiff], frames=frames)
    del deck["colliders"], deck["contact"]
    m = run(tmp_path, "both", deck)
    x = by_id(m)
    for k, body in enumerate((SOFT, stiff)):
        alone = scene([body], frames=frames)
        del alone["colliders"], alone["contact"]
        a = by_id(run(tmp_path, body["name"], alone))
        assert np.max(np.linalg.norm(x[k * VERTICES:(k + 1) * VERTICES] - a, axis=1)) / DIAGONAL <= 1e-8
    h = 1.0 / 60
    free_fall = -9.81 * h * h * frames * (frames + 1) / 2  # implicit Euler's, from rest
    assert np.allclose(m.displacement[:VERTICES], [0, free_fall, 0], atol=1e-9)
    assert np.max(np.abs(m.displacement[VERTICES:, 1])) < 0.5 * abs(free_fall)  # held near its rest (sag ~0.03 m)


def test_xdmf_frames_have_the_body_field(tmp_path):
    deck = scene([SOFT, STIFF], frames=2)
    deck["output"] = {"every": 2, "format": "xdmf"}
    m = run(tmp_path, "xdmf", deck)
    assert m.body is not None and np.bincount(m.body).tolist() == [48, 48]


def hanging_scene(bodies, frames=20):
    deck = scene(bodies, frames=frames)
    del deck["colliders"], deck["contact"]
    return deck


# A cloth or a rope first, the soft block second: (body, its vertices, its size, its elements,
# the vertices its fixed box holds, its rest height).
HANGING = {"cloth": (CLOTH, CLOTH_VERTICES, CLOTH_DIAGONAL, 32, 5, 0.3),
           "rope": (ROPE, ROPE_VERTICES, ROPE_LENGTH, 4, 1, 0.5)}


@pytest.mark.parametrize("kind", HANGING)
def test_a_cloth_or_rope_hangs_beside_a_falling_block_as_each_does_alone(run_once, kind):
    """The cloth or rope swings down from its own fixed region; the block falls freely (that
    region's box covers some of its vertices but holds none of them); each moves as it does alone."""
    body, n, size, elements, held, height = HANGING[kind]
    frames = 20
    both = run_once(f"{kind}_and_block", hanging_scene([body, SOFT], frames))
    x = by_id(both)
    for name, together, alone, scale in ((kind, x[:n], by_id(run_once(kind, hanging_scene([body], frames))), size),
                                         ("block", x[n:], by_id(run_once("block", hanging_scene([SOFT], frames))), DIAGONAL)):
        difference = np.max(np.linalg.norm(together - alone, axis=1)) / scale
        print(f"{name}: together against alone {difference:.2e} of its size")
        assert difference <= 1e-8
    h = 1.0 / 60
    assert np.allclose(both.displacement[n:], [0, -9.81 * h * h * frames * (frames + 1) / 2, 0], atol=1e-9)
    box = body["fixed"][0]["box"]
    rest = both.points - both.displacement
    in_box = np.all((rest >= box["min"]) & (rest <= box["max"]), axis=1)
    assert in_box[n:].any()  # the box covers block vertices too
    assert in_box[:n].sum() == held and np.array_equal(both.displacement[:n][in_box[:n]], np.zeros((held, 3)))
    assert np.min(x[:n, 1]) < height - 0.05  # the free end swung down
    assert np.bincount(both.body).tolist() == [elements, 48]  # its triangles or segments, then the block's tets


@pytest.mark.parametrize("kind", HANGING)
def test_a_cloth_or_rope_and_a_block_at_one_and_two_ranks(run_once, kind):
    body, _, size, _, _, _ = HANGING[kind]
    a = by_id(run_once(f"{kind}_and_block", hanging_scene([body, SOFT])))
    b = by_id(run_once(f"{kind}_and_block", hanging_scene([body, SOFT]), ranks=2))
    difference = np.max(np.linalg.norm(a - b, axis=1)) / size
    print(f"1 against 2 ranks: {difference:.2e} of the {kind}'s size")
    assert difference <= 1e-8


def test_a_list_of_one_body_is_the_plain_deck(tmp_path, run_once):
    plain = copy.deepcopy(scene([]))
    del plain["bodies"]
    plain["mesh"], plain["material"] = SOFT["mesh"], SOFT["material"]
    a = by_id(run(tmp_path, "plain", plain))
    b = by_id(run_once("soft", scene([SOFT])))
    assert np.max(np.linalg.norm(a - b, axis=1)) / DIAGONAL <= 1e-10


@pytest.mark.parametrize("change, key, words", [
    (lambda d: d.update(mesh={"box": {"size": [1, 1, 1], "cells": [1, 1, 1]}}), "mesh", "each body has its own mesh"),
    (lambda d: d["bodies"][1].pop("material"), "bodies[1]", "material"),
    (lambda d: d["bodies"][1].update(name="soft"), "bodies[1].name", "another body is named soft"),
    # an unnamed body's default, bodyK, taken by another's name (accepted: two bodies named body1)
    (lambda d: (d["bodies"][0].update(name="body1"), d["bodies"][1].pop("name", None)), "bodies[1]",
     "this body's default name body1 is another body's"),
    (lambda d: d["bodies"].__setitem__(0, {"mesh": CLOTH["mesh"]}), "bodies[0].cloth", "missing"),
    (lambda d: d["bodies"][0].update(mesh=CLOTH["mesh"], cloth=CLOTH["cloth"]), "bodies[0].material",
     "material describes tetrahedra"),
    (lambda d: d["bodies"][1].update(cloth=CLOTH["cloth"]), "bodies[1].cloth", "cloth describes a cloth"),
    (lambda d: d["bodies"][1].update(strand_material=ROPE["strand_material"]), "bodies[1].strand_material",
     "strand_material describes strands"),
    (lambda d: d["bodies"][1].update(mesh=ROPE["mesh"]), "bodies[1].material", "material describes tetrahedra"),
    (lambda d: d["bodies"].__setitem__(1, {"mesh": ROPE["mesh"]}), "bodies[1].strand_material", "missing"),
    (lambda d: d["bodies"][1].update(fixed=[{"box": {"min": [-1, -1, -1], "max": [0.3, 1, 1]}}]), "bodies[1].fixed[0].box",
     "selects no vertex of its body"),
    (lambda d: d["bodies"][1].update(attachments=[{"box": {"min": [-1, -1, -1], "max": [0.3, 1, 1]}, "stiffness": 1}]),
     "bodies[1].attachments[0].box", "selects no vertex of its body"),
    (lambda d: d["bodies"][1].update(attachments=[{"box": {"min": [0, 0, 0], "max": [1, 1, 1]}, "stiffen": 1}]),
     "bodies[1].attachments[0]", "stiffen"),
    # The keys of a body (body_keys(), src/model/scene_spec.hpp).
    (lambda d: d["bodies"][1].update(speed=[0, 0, 1]), "bodies[1].speed",
     "allowed: name, mesh, material, cloth, strand_material, velocity, fixed, attachments"),
    (lambda d: d["bodies"][1].pop("mesh"), "bodies[1].mesh", "missing required key 'mesh' in bodies[1]"),
    (lambda d: d["bodies"][1].update(velocity=[0, 1]), "bodies[1].velocity", "expected a list of 3 numbers"),
])
def test_bad_bodies_are_input_errors(tmp_path, change, key, words):
    deck = scene(copy.deepcopy([SOFT, STIFF]))
    change(deck)
    out = tmp_path / "out"
    proc = run_hyperqn([write_deck(tmp_path / "bad.yaml", deck), "-o", out], ranks=None, check=False)
    assert proc.returncode == 1, proc.stdout
    assert key in proc.stdout and words in proc.stdout, proc.stdout
    assert not out.exists()


# A cloth, a rope and a (stiff: it stops wobbling sooner) block side by side, lying flat 5 cm above
# the ground plane (y = 0).
LYING = [
    {"name": "cloth", "mesh": {"sheet": {"size": [SIZE, SIZE], "cells": [4, 4]}, "transform": {"translate": [-0.5, 0.05, 0]}},
     "cloth": CLOTH["cloth"]},
    {"name": "rope", "mesh": {"strands": [{"from": [-0.1, 0.05, 0.1], "to": [0.1, 0.05, 0.1], "segments": 4}]},
     "strand_material": ROPE["strand_material"]},
    {"name": "block", "mesh": {"box": {"size": [SIZE] * 3, "cells": [2, 2, 2]}, "transform": {"translate": [0.3, 0.05, 0]}},
     "material": STIFF["material"]},
]
LYING_VERTICES = (CLOTH_VERTICES, ROPE_VERTICES, VERTICES)
LYING_DIAGONAL = np.linalg.norm([0.5 + 0.3 + SIZE, 0.05 + SIZE, SIZE])  # of the whole scene at rest


def test_a_cloth_a_rope_and_a_block_come_to_rest_on_the_ground(tmp_path):
    """Dropped from 5 cm, each body lands on the ground plane and comes to rest there. No vertex is
    below the plane after 0.5 s, nor in any frame before: the penalty lets a vertex into the
    activation layer (d = 2 mm) only as deep as its load asks, d·sqrt(f / stiffness), and these
    bodies are far too light to reach the plane, so the tolerance is 0. Each body's lowest vertex
    is within d of the plane and its largest speed below 1 mm/s; 1 and 2 ranks agree to 1e-8 of
    the scene's diagonal."""
    deck = scene(LYING, frames=30)
    a = run(tmp_path, "np1", deck)
    b = run(tmp_path, "np2", deck, ranks=2)
    x = by_id(a)
    difference = np.max(np.linalg.norm(x - by_id(b), axis=1)) / LYING_DIAGONAL
    print(f"1 against 2 ranks: {difference:.2e} of the scene's diagonal")
    assert difference <= 1e-8
    assert read_summary(tmp_path / "np1")["max_penetration"] == 0  # in no frame below the plane
    distance = deck["contact"]["distance"]
    first = 0
    for body, n in zip(LYING, LYING_VERTICES):
        y, speed = x[first:first + n, 1], np.linalg.norm(a.velocity[first:first + n], axis=1)
        print(f"{body['name']}: lowest y {y.min():.2e} m, largest speed {speed.max():.1e} m/s")
        assert 0 <= y.min() <= distance, body["name"]
        assert speed.max() < 1e-3, body["name"]
        first += n
    assert first == len(x)
