"""Fracture (material.fracture, docs/topology.md#fracture), end to end, on thin plates written here
as Medit meshes (cubes of 6 tets; a notch is a row of cubes left out at an edge), pulled apart by a
clamp that moves at constant speed:
- the crack of an edge-notched plate starts at the notch tip;
- the crack of a double-notched plate, symmetric about its notches' plane, stays in that plane;
- a plain bar breaks first at the load the criterion predicts (threshold times the section);
- 1 vs 2 ranks (the crack crossing the partition boundary) and 4 ranks: the same faces in the same
  frames, positions within 1e-8 of the diagonal;
- a run killed after several breaks and restarted equals the uninterrupted one bit for bit;
- fracture leaves the total mass unchanged; a deck without fracture runs no topology code;
- fracture in a body of bodies: breaks (with cuts in one deck: test_topology_csv.py);
- with self-contact the cracks open and the fragments of a struck plate do not pass through each
  other (they do without it); 1 vs 2 ranks and a restart after a kill, with self-contact;
- bad fracture blocks are refused, naming the deck line, nothing written."""
import copy
import csv
import itertools

import numpy as np
import pytest

from conftest import load_deck, run_deck, run_hyperqn, write_deck
from hyperqn_tools.energy import frame_lumped_masses as lumped_masses
from hyperqn_tools.intersections import check_run
from hyperqn_tools.output import Frame, final_frame, frame_list, read_summary, rest_diagonal
from test_bad_input import assert_deck_refused
from test_checkpoint import assert_same_run
from test_checkpoint_faults import killed
from test_cuts import components

H = 0.1  # the cubes' edge: the element size
E, DENSITY = 1.0e6, 1000.0
THRESHOLD = 2.0e4  # Pa: a face breaks at 2 % strain of a plain bar (E = 1e6, nu = 0)


def plate_mesh(path, cells, notches=()):
    """A plate of cells[0] x cells[1] x cells[2] cubes of edge H (6 Kuhn tets each) without the
    cubes (i, j) of `notches` (every k), written as a Medit .mesh."""
    nx, ny, nz = cells
    index = lambda i, j, k: (i * (ny + 1) + j) * (nz + 1) + k
    points = [[H * i, H * j, H * k] for i in range(nx + 1) for j in range(ny + 1) for k in range(nz + 1)]
    tets = []
    for i, j, k in itertools.product(range(nx), range(ny), range(nz)):
        if (i, j) in notches:
            continue
        for order in itertools.permutations(range(3)):
            corner = [i, j, k]
            tet = [index(*corner)]
            for axis in order:
                corner[axis] += 1
                tet.append(index(*corner))
            tets.append(tet)
    with open(path, "w") as f:
        f.write("MeshVersionFormatted 1\nDimension 3\n")
        f.write(f"Vertices\n{len(points)}\n" + "".join(f"{x!r} {y!r} {z!r} 0\n" for x, y, z in points))
        f.write(f"Tetrahedra\n{len(tets)}\n" + "".join(" ".join(str(v + 1) for v in t) + " 1\n" for t in tets))
    return str(path)


def pulled_plate(mesh, height, speed=0.05, frames=60, poisson=0.0, fracture=None):
    """The plate of `mesh` clamped at y = 0 and pulled along y at y = height by a clamp at `speed`."""
    material = {"model": "corotated", "youngs_modulus": E, "poisson_ratio": poisson, "density": DENSITY,
                "fracture": fracture or {"criterion": "normal_stress", "threshold": THRESHOLD}}
    return {
        "mesh": {"file": mesh},
        "material": material,
        "fixed": [{"box": {"min": [-1, -0.01, -1], "max": [10, 0.01, 10]}},
                  {"box": {"min": [-1, height - 0.01, -1], "max": [10, height + 0.01, 10]},
                   "motion": {"translate": {"velocity": [0, speed, 0]}}}],
        "gravity": [0, 0, 0],
        "time": {"dt": 0.02, "frames": frames, "damping": 0.0},
        "solver": {"type": "lbfgs", "iterations": 400, "max_iterations": 400, "grad_rtol": 1e-10, "grad_atol": 0},
    }


def broken_faces(frame):
    """The faces of the rest mesh whose two tets no longer share their vertices in `frame`: {rest
    face (3 rest points, sorted): its centroid at rest}. Copies keep their original's rest position."""
    rest = np.round((frame.points - frame.displacement) / (H * 1e-3)).astype(np.int64)
    faces = {}
    for t in frame.cells["tetra"]:
        for f in itertools.combinations(t, 3):
            key = tuple(sorted(tuple(rest[v]) for v in f))
            faces.setdefault(key, set()).add(tuple(sorted(f)))
    out = {}
    for key, shared in faces.items():
        if len(shared) == 2:  # one rest face, two triangles: its tets no longer share it
            out[key] = np.mean(np.array(key, dtype=float), axis=0) * H * 1e-3
    return out


def tet_key(rest, tet):
    """A tet by its rest centroid, in units of a thousandth of H: the same at any rank count."""
    return tuple(np.round(rest[tet].mean(axis=0) / (H * 1e-3)).astype(np.int64))


def broken_face_tets(frame):
    """{broken rest face: its two tets (tet_key)} of `frame` (as broken_faces)."""
    rest = frame.points - frame.displacement
    key_of = np.round(rest / (H * 1e-3)).astype(np.int64)
    faces = {}
    for t in frame.cells["tetra"]:
        for f in itertools.combinations(t, 3):
            key = tuple(sorted(tuple(key_of[v]) for v in f))
            faces.setdefault(key, []).append((tuple(sorted(f)), tet_key(rest, t)))
    return {k: (v[0][1], v[1][1]) for k, v in faces.items() if len(v) == 2 and v[0][0] != v[1][0]}


def crack_history(out):
    """{frame number: the set of rest faces broken by then} for every written frame."""
    return {n: set(broken_faces(Frame(f))) for n, t, f in frame_list(out)}


def first_break(out):
    """(frame number, rest centroids of the faces broken in it) of the first frame with broken faces."""
    for n, t, f in frame_list(out):
        faces = broken_faces(Frame(f))
        if faces:
            return n, np.array(list(faces.values()))
    return None, None


# An edge-notched plate, 1.0 x 1.1 x 0.1 (10 x 11 x 1 cubes), the notch the cubes i < 3 of row
# j = 5 (x < 0.3, 0.5 < y < 0.6): its tip is the edge x = 0.3, y in [0.5, 0.6].
NOTCHED = dict(cells=(10, 11, 1), notches={(i, 5) for i in range(3)})
# The same with a notch at each side (x < 0.3 and x > 0.8, 11 cubes wide): symmetric about x = 0.55
# and, but for the clamps' being fixed and moving, about y = 0.55.
DOUBLE = dict(cells=(11, 11, 1), notches={(i, 5) for i in list(range(3)) + list(range(8, 11))})


def test_the_crack_of_a_notched_plate_starts_at_the_notch_tip(tmp_path):
    mesh = plate_mesh(tmp_path / "notched.mesh", **NOTCHED)
    out, s = run_deck(tmp_path, "notched", pulled_plate(mesh, 1.1))
    assert s["fracture"]["faces_broken"] > 0
    frame, centroids = first_break(out)
    tip = np.array([0.3, 0.55])
    d = np.linalg.norm(centroids[:, :2] - tip, axis=1)
    print(f"first break in frame {frame} (summary: {s['fracture']['first_break_frame']}), "
          f"{len(centroids)} faces, at {d.max():.3f} at most from the notch tip")
    assert d.max() <= 2 * H
    # the crack then runs across: the plate ends in two pieces (or more: a free tet or two)
    assert components(final_frame(out)) >= 2


def test_a_symmetric_specimen_cracks_in_its_plane_of_symmetry(tmp_path):
    mesh = plate_mesh(tmp_path / "double.mesh", **DOUBLE)
    out, s = run_deck(tmp_path, "double", pulled_plate(mesh, 1.1))
    assert s["fracture"]["faces_broken"] > 0
    centroids = np.array(list(broken_faces(final_frame(out)).values()))
    print(f"{len(centroids)} faces broken, |y - 0.55| at most {np.abs(centroids[:, 1] - 0.55).max():.3f}")
    assert np.abs(centroids[:, 1] - 0.55).max() <= H
    assert components(final_frame(out)) >= 2


@pytest.mark.parametrize("criterion", ["normal_stress", "energy_density"])
def test_a_plain_bar_breaks_at_the_load_the_criterion_predicts(tmp_path, criterion):
    # A bar 0.3 x 1.0 x 0.1 pulled along y, static steps: with nu = 0 the corotated model under a
    # uniaxial stretch 1 + e has sigma = E e and psi = mu e^2 = E e^2 / 2 exactly, the same in every
    # tet. The faces normal to y carry n.sigma.n = sigma (the slanted faces of the cubes less);
    # every face has the mean psi. The clamp moves speed dt per step; the threshold is the value at
    # strain 0.0205, between two steps' strains (not on one: a tie is decided by round-off). The
    # first break must come after the first state over the threshold: the load at first fracture
    # is within one step's load above the criterion's prediction, threshold strain x E x section.
    # A fracture separates faces at x, keeping the tets: it releases nothing at once (energy.csv's
    # `released` stays 0 to round-off); the pieces then relax in the step after it.
    mesh = plate_mesh(tmp_path / "bar.mesh", (3, 10, 1))
    speed, dt, strain = 0.05, 0.02, 0.0205
    threshold = E * strain if criterion == "normal_stress" else E * strain ** 2 / 2
    deck = pulled_plate(mesh, 1.0, speed=speed, frames=23, fracture={"criterion": criterion, "threshold": threshold})
    deck["time"]["integrator"] = "static"
    del deck["time"]["damping"]
    deck["output"] = {"energy": True}
    out, s = run_deck(tmp_path, "bar", deck)
    first = s["fracture"]["first_break_frame"]
    with open(out / "energy.csv") as f:
        rows = list(csv.DictReader(f))
    stored = max(float(r["stored"]) for r in rows)
    assert stored > 0 and max(abs(float(r["released"])) for r in rows) <= 1e-12 * stored
    section, step = 0.3 * 0.1, dt * speed  # the clamp's displacement per step over the length 1.0
    load, predicted = E * first * step * section, E * strain * section
    print(f"{criterion}: first break after frame {first}: load {load:.1f} N, predicted {predicted:.1f} N "
          f"(one step: {E * step * section:.1f} N)")
    assert E * (first - 1) * step * section < predicted < load
    if criterion == "normal_stress":  # the faces that broke are those normal to y (on the planes y = j H)
        y = np.array([c[1] for c in broken_faces(final_frame(out)).values()])
        assert len(y) > 0 and np.allclose(y / H, np.round(y / H), atol=1e-9)


def test_ranks_agree_with_the_crack_across_the_partition(tmp_path):
    mesh = plate_mesh(tmp_path / "notched.mesh", **NOTCHED)
    deck = pulled_plate(mesh, 1.1, frames=40)
    one, s1 = run_deck(tmp_path, "one", deck)
    two, s2 = run_deck(tmp_path, "two", deck, ranks=2)
    assert s2["ranks"] == 2 and s1["fracture"]["faces_broken"] > 0
    # the H0 follows a break by a correction on one rank and is factored again on two
    # (docs/topology.md#h0-across-a-cut): the same number of steps with breaks either way
    h0 = ("topology_s", "h0_corrections", "refactorizations")
    skip = lambda f: {k: v for k, v in f.items() if k not in h0}
    assert skip(s1["fracture"]) == skip(s2["fracture"])
    steps = lambda f: f["h0_corrections"] + f["refactorizations"]
    assert steps(s1["fracture"]) == steps(s2["fracture"]) > 0
    assert s2["fracture"]["h0_corrections"] == 0
    assert crack_history(one) == crack_history(two)
    a, b = final_frame(one), final_frame(two)
    assert np.array_equal(a.vertex_id, b.vertex_id)
    assert np.abs(a.points - b.points).max() <= 1e-8 * rest_diagonal(a)
    # the crack crosses the partition boundary: faces broken between tets of the two ranks' pieces
    first = Frame(frame_list(two)[0][2])
    rest = first.points - first.displacement
    rank_of = {tet_key(rest, t): r for t, r in zip(first.cells["tetra"], first.ranks)}
    last = b
    across = [f for f, tets in broken_face_tets(last).items() if rank_of[tets[0]] != rank_of[tets[1]]]
    print(f"{len(broken_faces(last))} faces broken, {len(across)} of them between the ranks' pieces")
    assert len(across) > 0


def test_four_ranks_agree(tmp_path):
    mesh = plate_mesh(tmp_path / "notched.mesh", **NOTCHED)
    deck = pulled_plate(mesh, 1.1, frames=40)
    one, s1 = run_deck(tmp_path, "one", deck)
    four, s4 = run_deck(tmp_path, "four", deck, ranks=4)
    assert crack_history(one) == crack_history(four)
    a, b = final_frame(one), final_frame(four)
    assert np.abs(a.points - b.points).max() <= 1e-8 * rest_diagonal(a)


@pytest.mark.parametrize("ranks", [None, 2])
def test_restart_after_a_kill_is_bitwise(tmp_path, ranks):
    mesh = plate_mesh(tmp_path / "notched.mesh", **NOTCHED)
    deck = pulled_plate(mesh, 1.1, frames=40)
    deck["checkpoint"] = {"every": 2}
    path = write_deck(tmp_path / "plate.yaml", deck)
    ref = tmp_path / "ref"
    run_hyperqn([path, "-o", ref], ranks=ranks)
    s = read_summary(ref)
    first = s["fracture"]["first_break_frame"]
    assert first is not None and first + 6 < deck["time"]["frames"]
    out = tmp_path / "out"
    killed(path, out, first + 6, ranks)  # after several breaks
    from hyperqn_tools.output import read_checkpoint
    import glob
    latest = max(glob.glob(str(out / "checkpoints" / "checkpoint_*.h5")), key=lambda p: int(p.split("_")[-1][:-3]))
    assert len(read_checkpoint(latest)["cuts"]) > 0
    run_hyperqn([path, "-o", out, "--restart", "latest"], ranks=ranks)
    assert_same_run(ref, out)
    skip = lambda f: {k: v for k, v in f.items() if k != "topology_s"}
    assert skip(read_summary(ref)["fracture"]) == skip(read_summary(out)["fracture"])


def test_fracture_keeps_the_mass(tmp_path):
    mesh = plate_mesh(tmp_path / "notched.mesh", **NOTCHED)
    out, s = run_deck(tmp_path, "notched", pulled_plate(mesh, 1.1, frames=40))
    first, last = Frame(frame_list(out)[0][2]), final_frame(out)
    assert s["fracture"]["vertices_added"] > 0
    assert len(last.points) == len(first.points) + s["fracture"]["vertices_added"]
    m0, m1 = lumped_masses(first, DENSITY).sum(), lumped_masses(last, DENSITY).sum()
    assert abs(m1 - m0) <= 1e-14 * m0


def struck_plate(self_contact):
    """input/topology/plate_crack.yaml at 10 x 1 x 10 cells for 40 frames: the ball punches through
    and the fragments fly; with or without self-contact (the barrier, the default distance)."""
    deck = load_deck("input/topology/plate_crack.yaml")
    deck["mesh"]["box"]["cells"] = [10, 1, 10]
    deck["time"]["frames"] = 40
    deck["output"] = {"every": 4}
    if self_contact:
        deck["contact"] = {"model": "barrier", "self": True}
    return deck


def test_fragments_do_not_pass_through_each_other_with_self_contact(tmp_path):
    crossings = {}
    for self_contact in (False, True):
        out, s = run_deck(tmp_path, f"self_{self_contact}", struck_plate(self_contact))
        assert s["fracture"]["faces_broken"] > 50
        crossings[self_contact] = [row["intersecting_pairs"] for row in check_run(out)]
    print("intersecting pairs per written frame, without and with self-contact:", crossings)
    assert max(crossings[False]) > 0  # the check sees fragments pass through each other
    assert max(crossings[True]) == 0


def notched_with_self_contact(tmp_path):
    # 28 frames: it breaks in frames 14 to 25 (37 faces), then rings
    deck = pulled_plate(plate_mesh(tmp_path / "notched.mesh", **NOTCHED), 1.1, frames=28)
    deck["contact"] = {"model": "barrier", "self": True}
    # Newton to round-off (as test_cut_contact.py): lbfgs's 400 iterations leave the barrier's
    # frames 3e-7 of the diagonal apart at 1 and 2 ranks, the solver's tolerance, not the ranks'
    deck["solver"] = {"type": "newton", "iterations": 60, "budget": "fixed", "grad_rtol": 1e-12, "grad_atol": 0}
    return deck


def test_ranks_agree_with_self_contact(tmp_path):
    deck = notched_with_self_contact(tmp_path)
    one, s1 = run_deck(tmp_path, "one", deck)
    two, _ = run_deck(tmp_path, "two", deck, ranks=2)
    print("1 vs 2 ranks:", np.abs(final_frame(one).points - final_frame(two).points).max() / rest_diagonal(final_frame(one)))
    assert s1["fracture"]["faces_broken"] > 0
    assert crack_history(one) == crack_history(two)
    a, b = final_frame(one), final_frame(two)
    assert np.array_equal(a.vertex_id, b.vertex_id)
    assert np.abs(a.points - b.points).max() <= 1e-8 * rest_diagonal(a)


def test_restart_after_a_kill_is_bitwise_with_self_contact(tmp_path):
    deck = notched_with_self_contact(tmp_path)
    deck["checkpoint"] = {"every": 2}
    path = write_deck(tmp_path / "plate.yaml", deck)
    ref = tmp_path / "ref"
    run_hyperqn([path, "-o", ref])
    first = read_summary(ref)["fracture"]["first_break_frame"]
    assert first is not None and first + 6 < deck["time"]["frames"]
    out = tmp_path / "out"
    killed(path, out, first + 6, None)
    run_hyperqn([path, "-o", out, "--restart", "latest"])
    assert_same_run(ref, out)


def test_a_deck_without_fracture_runs_no_topology_code(tmp_path):
    mesh = plate_mesh(tmp_path / "notched.mesh", **NOTCHED)
    deck = pulled_plate(mesh, 1.1, frames=3)
    del deck["material"]["fracture"]
    log = tmp_path / "log.txt"
    run_hyperqn([write_deck(tmp_path / "plain.yaml", deck), "-o", tmp_path / "plain", "-log_view", f":{log}"])
    from conftest import event_count
    assert event_count(log.read_text(), "hqnTopology") == 0
    assert "fracture" not in read_summary(tmp_path / "plain")


def bad(tmp_path, **fracture):
    mesh = plate_mesh(tmp_path / "notched.mesh", **NOTCHED)
    deck = pulled_plate(mesh, 1.1, frames=2)
    deck["material"]["fracture"].update(fracture)
    return deck


BAD = {
    "negative_threshold": ({"threshold": -1.0}, ["material.fracture.threshold", "> 0"]),
    "inf_threshold": ({"threshold": float("inf")}, ["material.fracture.threshold"]),
    "nan_threshold": ({"threshold": float("nan")}, ["material.fracture.threshold"]),
    "spread_one": ({"spread": 1.0}, ["material.fracture.spread", "[0, 1)"]),
    "negative_spread": ({"spread": -0.1}, ["material.fracture.spread"]),
    "unknown_criterion": ({"criterion": "von_mises"}, ["material.fracture.criterion", "normal_stress"]),
    "unknown_key": ({"toughness": 3.0}, ["material.fracture", "toughness"]),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_fracture_is_refused(tmp_path, case):
    fracture, fragments = BAD[case]
    assert_deck_refused(tmp_path, case, bad(tmp_path, **fracture), fragments)


def test_fracture_of_mass_spring_tets_is_refused(tmp_path):
    deck = bad(tmp_path)
    deck["material"] = {"model": "mass-spring", "spring_stiffness": 1.0e4, "density": DENSITY,
                        "fracture": deck["material"]["fracture"]}
    assert_deck_refused(tmp_path, "springs", deck, ["material.fracture", "mass-spring", "no stress"])


def bodies_deck(threshold):
    """A cantilever of one body (deck bodies:) under gravity, its material with fracture."""
    return {
        "bodies": [{"mesh": {"box": {"size": [1.0, 0.2, 0.2], "cells": [5, 1, 1]}},
                    "material": {"model": "corotated", "youngs_modulus": 1.0e6, "poisson_ratio": 0.3, "density": 1000,
                                 "fracture": {"criterion": "normal_stress", "threshold": threshold}}}],
        "fixed": [{"box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 0.21, 0.21]}}],
        "gravity": [0, -9.81, 0],
        "time": {"dt": 0.02, "frames": 3},
    }


def test_fracture_in_bodies(tmp_path):
    # the clamped root's tension in beam theory, 6 M / (b h^2) with M = rho g A L^2 / 2 = 196 N m,
    # is about 1.5e5 Pa: faces break at a threshold of 2e3 Pa, none at 1e8 Pa
    _, weak = run_deck(tmp_path, "weak", bodies_deck(2.0e3))
    _, strong = run_deck(tmp_path, "strong", bodies_deck(1.0e8))
    assert weak["fracture"]["faces_broken"] > 0 and strong["fracture"]["faces_broken"] == 0
    assert strong["fracture"]["first_break_frame"] is None


def test_bad_fracture_in_bodies_is_refused(tmp_path):
    assert_deck_refused(tmp_path, "bodies", bodies_deck(-2.0), ["bodies[0].material.fracture.threshold", "> 0"])


def test_fracture_in_a_deck_of_bodies_with_strands_is_refused_naming_its_body(tmp_path):
    deck = bodies_deck(2.0e3)
    deck["bodies"].insert(0, {"name": "rope", "mesh": {"strands": [{"from": [2, 0, 0], "to": [3, 0, 0], "segments": 4}]},
                              "strand_material": {"axial_stiffness": 1.0e3, "linear_density": 0.05}})
    assert_deck_refused(tmp_path, "with_strands", deck, ["bodies[1].material.fracture", "strands or a cloth"])
