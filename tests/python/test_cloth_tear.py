"""Tearing cloth by its strain (docs/snapping.md#tearing-cloth), end to end: a sheet clamped along
two opposite edges that move apart tears at the interior edge most stretched past the threshold,
one edge per step; mass is unchanged exactly; no tear adds energy (energy.csv's released); 1, 2 and 4 ranks tear the same edges in the same
frames (the tear crosses the 2-rank partition boundary); a run killed (kill -9) after tears and
restarted equals the uninterrupted run bit for bit, energy.csv too; with self-contact the torn edges open (no two
vertices at one rest position, no crossing; the mass from the rest shape before the opening
unchanged), at 1 and 2 ranks alike, restarted bitwise, the corrected H0 a fresh factor's; edge
springs that yield tear without adding energy (a torn edge's second half carries on the flow), at
1, 2 and 4 ranks alike, restarted bitwise; bad thresholds and a cloth too thick to open are
refused; a deck whose cloth does not tear runs no topology code."""
import copy
import csv

import numpy as np
import pytest

from conftest import event_count, run_deck, run_hyperqn, write_deck
from hyperqn_tools.intersections import check_run
from hyperqn_tools.output import Frame, final_frame, frame_list, read_checkpoint, read_summary, rest_diagonal
from test_bad_input import assert_deck_refused
from test_checkpoint_faults import (assert_restart_after_kill_is_bitwise, assert_restart_after_signal_in_a_changing_frame_is_bitwise,
                                    first_changing_frame)
from test_cut_contact import shared_rest_positions
from test_cuts import CHECK_LINE

# Newton at a fixed 20 iterations. On this sheet (its free sides squeezed, whose springs' negative
# curvature the PSD fix drops) Newton converges linearly, by about 0.77 an iteration, so no budget
# reaches round-off (50 iterations end 3 mm from 20's, at 2.5x the time); the rank and restart tests
# compare the same iterations, whose ranks agree to 2e-15 m (bound: 1e-8 of the diagonal).
TIGHT = {"type": "newton", "iterations": 20, "grad_rtol": 1e-12, "grad_atol": 0}
TEAR = 0.15
DENSITY = 0.2
SIZE = 0.5

# A 0.5 m sheet of 10 x 10 cells clamped along its bottom (z = 0) and top (z = 0.5) edges, the
# clamps moving apart (the top one a little sideways too: no mirror symmetry, so no two edges
# tie): input/topology/cloth_tear.yaml, smaller. At 2 ranks the sheet is cut at x = 0.25, across
# the tear's path.
CLOTH = {
    "mesh": {"sheet": {"size": [SIZE, SIZE], "cells": [10, 10]}},
    "cloth": {"model": "mass-spring", "stretch_stiffness": 1.0e3, "bending": {"model": "springs", "stiffness": 1.0},
              "areal_density": DENSITY, "tear": {"strain": TEAR}},
    "fixed": [{"box": {"min": [-0.001, -0.001, -0.001], "max": [0.501, 0.001, 0.001]},
               "motion": {"translate": {"velocity": [0, 0, -0.1]}}},
              {"box": {"min": [-0.001, -0.001, 0.499], "max": [0.501, 0.001, 0.501]},
               "motion": {"translate": {"velocity": [0.02, 0, 0.1]}}}],
    "gravity": [0, -9.81, 0],
    "time": {"dt": 1 / 60, "frames": 60},
    "solver": TIGHT,
}


def frames(out):
    return [Frame(path) for _, _, path in frame_list(out)]


def edge_strains(frame):
    """The interior edges (vertex index pairs, lo < hi: those two triangles share) and their
    strains across (hyperqn's strain_across_edge: the mean over the two triangles of the stretch
    |F n| perpendicular to the edge, less 1; rest positions: points - displacement)."""
    tri = frame.cells["triangle"]
    x, X = frame.points, frame.points - frame.displacement
    rows = []
    for j in range(3):
        a, b, c = tri[:, j], tri[:, (j + 1) % 3], tri[:, (j + 2) % 3]
        e, w, de, dw = X[b] - X[a], X[c] - X[a], x[b] - x[a], x[c] - x[a]
        s = np.sum(w * e, axis=1) / np.sum(e * e, axis=1)
        h = np.linalg.norm(w - s[:, None] * e, axis=1)
        stretch = np.linalg.norm(dw - s[:, None] * de, axis=1) / h
        rows.append((np.sort(np.stack([a, b], axis=1), axis=1), stretch))
    edges = np.concatenate([r[0] for r in rows])
    stretch = np.concatenate([r[1] for r in rows])
    unique, inverse, counts = np.unique(edges, axis=0, return_inverse=True, return_counts=True)
    total = np.zeros(len(unique))
    np.add.at(total, inverse.reshape(-1), stretch)
    interior = counts == 2
    return unique[interior], total[interior] / 2 - 1


def masses(frame):
    """hyperqn's lumped cloth masses: a third of each triangle's (at rest) at each vertex."""
    X = frame.points - frame.displacement
    tri = frame.cells["triangle"]
    third = DENSITY * 0.5 * np.linalg.norm(np.cross(X[tri[:, 1]] - X[tri[:, 0]], X[tri[:, 2]] - X[tri[:, 0]]), axis=1) / 3
    m = np.zeros(len(X))
    for j in range(3):
        np.add.at(m, tri[:, j], third)
    return m


# With energy.csv (output.energy): what each tear released (docs/inelastic.md#energy-balance).
WITH_ENERGY = {**CLOTH, "output": {"energy": True}}


@pytest.fixture(scope="module")
def cloth(tmp_path_factory):
    return run_deck(tmp_path_factory.mktemp("cloth"), "cloth", WITH_ENERGY)


def test_cloth_tears_where_its_strain_is_highest(cloth):
    out, s = cloth
    fs = frames(out)
    over = [k for k, f in enumerate(fs) if edge_strains(f)[1].max() > TEAR]
    assert over, "the cloth never stretched past the threshold"
    first = over[0]
    counts = [len(f.points) for f in fs]
    # frame `first` is written before the tear; the tear is made at the start of the next step,
    # at a clamp's corner (on the boundary): the end of the edge that was not on the boundary
    # already... its boundary end splits, so the frame after has one vertex more
    assert all(c == counts[0] for c in counts[: first + 1]) and counts[first + 1] == counts[0] + 1
    edges, strain = edge_strains(fs[first])
    worst = edges[np.argmax(strain)]
    after = fs[first + 1]
    new = np.flatnonzero(after.vertex_id >= counts[0])
    assert len(new) == 1
    rest = lambda f: f.points - f.displacement
    # the new vertex is a copy of an end of the edge most over the threshold (at its rest position)
    ends = rest(fs[first])[worst]
    assert np.min(np.linalg.norm(ends - rest(after)[new[0]], axis=1)) == 0
    b = s["breaks"]
    assert b["segments_snapped"] == 0 and b["edges_torn"] >= 10 and b["vertices_added"] == counts[-1] - counts[0]
    assert max(torn_per_frame(out).values()) == 1  # one edge per step
    assert b["refactorizations"] == b["h0_corrections"] == 0  # Newton factors no constant matrix
    # the sheet is in two at the end: its triangles fall into two pieces joined through shared vertices
    tri = fs[-1].cells["triangle"]
    parent = np.arange(len(fs[-1].points))

    def root(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for a, c in np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]]]):
        parent[root(a)] = root(c)
    assert len({root(v) for v in np.unique(tri)}) == 2


def test_total_mass_is_unchanged_exactly(cloth):
    out, _ = cloth
    fs = frames(out)
    m0, m1 = masses(fs[0]).sum(), masses(fs[-1]).sum()
    assert len(fs[-1].points) > len(fs[0].points)
    assert abs(m1 - m0) <= 1e-14 * m0 and abs(m0 - DENSITY * SIZE * SIZE) <= 1e-12 * m0
    # and momentum too: a copy starts with its original's velocity
    assert np.all(masses(fs[-1]) > 0)


def released_per_frame(out):
    """energy.csv's released column as each frame's increment, and the largest stored energy."""
    with open(out / "energy.csv") as f:
        rows = list(csv.DictReader(f))
    released = np.array([float(r["released"]) for r in rows])
    return np.diff(released, prepend=0.0), max(float(r["stored"]) for r in rows)


def test_no_tear_adds_energy(cloth):
    """A tear keeps x and v; its edge's spring is shared by the two sides (k/2 each) and its hinge
    goes, so the stored energy after it is at most that before: each frame's increment of energy.csv's
    `released` (the energy before the change less after it) is >= 0 and > 0 in the frames that tear
    (the hinges' bending springs). Measured: 35 tears releasing 1.2e-4 to 8.7e-4 J each (the stored
    energy is 3-8 J); with each side a whole spring (before) the tears added up to 1.0e-2 J each."""
    out, s = cloth
    steps, stored = released_per_frame(out)
    with open(out / "topology.csv") as f:
        torn = {int(r["frame"]) for r in csv.DictReader(f) if int(r["edges_torn"]) > 0}
    assert s["breaks"]["edges_torn"] >= 20 and len(torn) == s["breaks"]["edges_torn"]
    print(f"released per tear: {steps[sorted(torn)].min():.3e} to {steps.max():.3e} J (stored up to {stored:.3g} J)")
    assert steps.min() >= -1e-12 * stored
    assert all(steps[f] > 1e-9 * stored for f in torn)
    assert all(steps[f] == 0 for f in range(len(steps)) if f not in torn)


# Edge springs that yield (docs/yielding-springs.md) on the tearing sheet: a torn edge's second
# half carries on the edge spring's flow, so each half stores half of what the whole did. With
# hardening: without it (perfect plasticity) Newton stalls at the yield kink in some frames
# (|grad g| 1e-8, a line-search failure), and 1 and 2 ranks part there by 3e-6 of the diagonal.
YIELDING = {**WITH_ENERGY, "cloth": {**CLOTH["cloth"], "yield_strain": 0.02, "hardening": 1.0}}


@pytest.fixture(scope="module")
def yielding(tmp_path_factory):
    return run_deck(tmp_path_factory.mktemp("yielding"), "yielding", YIELDING)


def test_a_yielding_cloth_tears_without_adding_energy(yielding):
    """The flowed rest length goes with both halves of a torn edge: no tear adds energy. Measured:
    35 tears; with the second half starting unflowed instead (a trial build) 18 frames added
    energy, up to 2.2e-4 J of 4.4 J stored."""
    out, s = yielding
    steps, stored = released_per_frame(out)
    assert s["breaks"]["edges_torn"] >= 20 and s["dissipated_energy"] > 0
    print(f"{s['breaks']['edges_torn']} tears; released per frame {steps.min():.3e} to {steps.max():.3e} J (stored up to {stored:.3g} J)")
    assert steps.min() >= -1e-12 * stored


@pytest.mark.parametrize("ranks", [2])  # 4 ranks: the elastic sheet's test below (the suite's time)
def test_ranks_agree_on_a_yielding_cloth_that_tears(yielding, tmp_path, ranks):
    ref, s1 = yielding
    out, s2 = run_deck(tmp_path, "yielding", YIELDING, ranks=ranks)
    assert s1["breaks"] == {**s2["breaks"], "topology_s": s1["breaks"]["topology_s"]}
    assert abs(s1["dissipated_energy"] - s2["dissipated_energy"]) <= 1e-8 * s1["dissipated_energy"]
    for a, b in zip(frames(ref), frames(out)):
        assert np.array_equal(a.vertex_id, b.vertex_id)
        assert np.abs(a.points - b.points).max() <= 1e-8 * rest_diagonal(a)


@pytest.mark.parametrize("ranks", [None, 2])
def test_restart_after_kill_after_tears_of_yielding_springs_is_bitwise(tmp_path, ranks):
    ref, out = assert_restart_after_kill_is_bitwise(tmp_path, YIELDING, ranks, frames=36, every=30, kill_after=33)
    assert (ref / "energy.csv").read_bytes() == (out / "energy.csv").read_bytes()
    flowed = read_checkpoint(out / "checkpoints" / "checkpoint_30.h5")["elements_edge_yield"]
    assert np.count_nonzero(flowed[:, 0]) > 0  # the checkpoint holds flowed springs


def test_a_deck_whose_cloth_does_not_tear_runs_no_topology_code(tmp_path):
    plain = copy.deepcopy(CLOTH)
    del plain["cloth"]["tear"]
    plain["time"]["frames"] = 3
    log = tmp_path / "plain.log"
    run_hyperqn([write_deck(tmp_path / "plain.yaml", plain), "-o", tmp_path / "plain", "-log_view", f":{log}"], ranks=None)
    text = log.read_text()
    assert event_count(text, "hqnObjective") > 0 and event_count(text, "hqnTopology") == 0
    assert "breaks" not in read_summary(tmp_path / "plain")


@pytest.mark.parametrize("ranks", [2, 4])
def test_ranks_tear_the_same_edges_in_the_same_frames(cloth, tmp_path, ranks):
    ref, s1 = cloth
    out, s2 = run_deck(tmp_path, "cloth", CLOTH, ranks=ranks)
    assert s1["breaks"] == {**s2["breaks"], "topology_s": s1["breaks"]["topology_s"]}
    fs = frames(out)
    for a, b in zip(frames(ref), fs):
        assert np.array_equal(a.vertex_id, b.vertex_id)
        assert np.abs(a.points - b.points).max() <= 1e-8 * rest_diagonal(a)
    if ranks == 2:  # the tear crossed the partition boundary (x = 0.25): copies on both sides
        last = fs[-1]
        x = (last.points - last.displacement)[last.vertex_id >= len(fs[0].points), 0]
        assert x.min() < 0.2 and x.max() > 0.3


@pytest.mark.parametrize("ranks", [None, 2])
def test_restart_after_kill_after_tears_is_bitwise(tmp_path, ranks):
    ref, out = assert_restart_after_kill_is_bitwise(tmp_path, WITH_ENERGY, ranks, frames=36, every=30, kill_after=33)
    assert (ref / "energy.csv").read_bytes() == (out / "energy.csv").read_bytes()
    saved = read_checkpoint(out / "checkpoints" / "checkpoint_30.h5")
    kinds = [int(k) for k in str(saved["breaks"]).split()[1::3]]
    assert kinds and set(kinds) == {1}  # the checkpoint was written after tears
    a, b = read_summary(ref)["breaks"], read_summary(out)["breaks"]
    assert {k: v for k, v in a.items() if k != "topology_s"} == {k: v for k, v in b.items() if k != "topology_s"}


# The other terms on a tearing sheet: an attachment in its middle and a sphere just below it, 2 mm
# under the sheet (within the contact distance), that it leans on while it tears (contact forces in
# the last frame, on the torn mesh).
TERMS = {**CLOTH,
         "attachments": [{"box": {"min": [0.2, -0.01, 0.2], "max": [0.3, 0.01, 0.3]}, "stiffness": 5.0}],
         "colliders": [{"type": "sphere", "center": [0.25, -0.052, 0.25], "radius": 0.05}],
         "time": {"dt": 1 / 60, "frames": 40}}
# And the membrane with dihedral bending (its moved hinges' rest angles): Newton stalls at its
# round-off floor on it (|grad| ~1e-8 in some frames), so 1 and 2 ranks are not compared there.
MEMBRANE = {**TERMS,
            "cloth": {"model": "membrane", "youngs_modulus": 1000.0, "poisson_ratio": 0.3,
                      "bending": {"model": "dihedral", "stiffness": 1e-4}, "areal_density": DENSITY,
                      "tear": {"strain": TEAR}}}


def test_attachment_and_contact_follow_the_tears_at_1_and_2_ranks(tmp_path):
    ref, s1 = run_deck(tmp_path, "one", TERMS)
    out, s2 = run_deck(tmp_path, "two", TERMS, ranks=2)
    assert s1["breaks"]["edges_torn"] >= 10 and s1["breaks"]["vertices_added"] > 0
    assert s1["breaks"] == {**s2["breaks"], "topology_s": s1["breaks"]["topology_s"]}
    fa, fb = frames(ref), frames(out)
    for a, b in zip(fa, fb):
        assert np.array_equal(a.vertex_id, b.vertex_id)
        assert np.abs(a.points - b.points).max() <= 1e-8 * rest_diagonal(a)
    assert np.abs(fa[-1].contact_force).max() > 0  # the torn sheet leans on the sphere
    m0, m1 = masses(fa[0]).sum(), masses(fa[-1]).sum()
    assert abs(m1 - m0) <= 1e-14 * m0


def test_a_membrane_with_dihedral_bending_tears(tmp_path):
    out, s = run_deck(tmp_path, "membrane", MEMBRANE)
    assert s["breaks"]["edges_torn"] >= 10 and s["breaks"]["vertices_added"] > 0
    fs = frames(out)
    m0, m1 = masses(fs[0]).sum(), masses(fs[-1]).sum()
    assert len(fs[-1].points) > len(fs[0].points) and abs(m1 - m0) <= 1e-14 * m0


# With self-contact (docs/snapping.md#tearing-cloth): each side of a torn vertex opens into its
# own triangles, so the torn edges take part in self-contact from their first step.
SELF = {**CLOTH, "contact": {"model": "barrier", "self": True}}
CELL = SIZE / 10


def unopened_masses(frame):
    """The lumped masses from the rest shape before any opening: the sheet's grid, to which every
    opened rest position rounds (each opening moves a side by at most a tenth of a triangle's
    height, 0.07 of a cell; a vertex that splits again moves again: 0.14 of a cell measured)."""
    rounded = copy.copy(frame)
    rest = frame.points - frame.displacement
    grid = np.round(rest / CELL) * CELL
    assert np.abs(rest - grid).max() < 0.3 * CELL
    rounded.displacement = frame.points - grid
    return masses(rounded)


@pytest.fixture(scope="module")
def torn_with_self_contact(tmp_path_factory):
    return run_deck(tmp_path_factory.mktemp("self"), "self", SELF)


def test_with_self_contact_torn_edges_open_and_the_pieces_do_not_cross(cloth, torn_with_self_contact):
    crossings, twins = {}, {}
    for name, (out, s) in (("with", torn_with_self_contact), ("without", cloth)):
        assert s["breaks"]["edges_torn"] >= 10
        crossings[name] = [r["intersecting_pairs"] for r in check_run(out)]
        twins[name] = [shared_rest_positions(f) for f in frames(out)]
    print("intersecting pairs:", crossings, "vertices sharing a rest position:", twins)
    assert max(crossings["without"]) > 0 and max(twins["without"]) > 0  # the checks see them
    assert max(crossings["with"]) == 0 and max(twins["with"]) == 0
    # the opening moved rest positions, not the mass: from the rest shape before it, unchanged
    fs = frames(torn_with_self_contact[0])
    m0, m1, opened = unopened_masses(fs[0]).sum(), unopened_masses(fs[-1]).sum(), masses(fs[-1]).sum()
    print(f"total mass {m0!r} -> {m1!r}; from the opened rest shape {opened!r}")
    assert abs(m1 - m0) <= 1e-14 * m0 and abs(m0 - DENSITY * SIZE * SIZE) <= 1e-12 * m0
    assert abs(opened - m0) > 1e-6 * m0


def test_ranks_agree_on_tears_with_self_contact(torn_with_self_contact, tmp_path):
    ref, s1 = torn_with_self_contact
    out, s2 = run_deck(tmp_path, "two", SELF, ranks=2)
    assert s1["breaks"] == {**s2["breaks"], "topology_s": s1["breaks"]["topology_s"]}
    for a, b in zip(frames(ref), frames(out)):
        assert np.array_equal(a.vertex_id, b.vertex_id)
        assert np.abs(a.points - b.points).max() <= 1e-8 * rest_diagonal(a)


def test_restart_after_kill_after_tears_is_bitwise_with_self_contact(tmp_path):
    assert_restart_after_kill_is_bitwise(tmp_path, SELF, 2, frames=36, every=30, kill_after=33)


def corrected_vs_fresh(tmp_path, deck):
    """The deck run at 1 rank with -hyperqn_test_topology_h0_check: the relative difference of the
    corrected H0 from a fresh factor after each change, and summary.json's breaks."""
    out = tmp_path / "checked"
    proc = run_hyperqn([write_deck(tmp_path / "checked.yaml", deck), "-o", out, "-hyperqn_test_topology_h0_check"],
                       ranks=None)
    found = [float(d) for _, d in CHECK_LINE.findall(proc.stdout)]
    print("corrected vs fresh:", found)
    return found, read_summary(out)["breaks"]


def test_corrected_h0_follows_tears_that_open(tmp_path):
    # L-BFGS (its H0 the factored M + h^2 L): the opening moves rest positions, and the corrected
    # H0 is still a fresh factorization's after every tear.
    found, s = corrected_vs_fresh(tmp_path, {**SELF, "solver": {"type": "lbfgs"}, "time": {"dt": 1 / 60, "frames": 40}})
    assert s["edges_torn"] >= 5 and len(found) == s["h0_corrections"] == s["edges_torn"]
    assert max(found) <= 1e-13


# With cloth.tear.resolve: a step whose converged state has an edge over the threshold is solved
# again from its start with that edge torn, up to RESOLVE times, so a rip runs several edges a step.
# 34 frames: the rip's re-solves come in frames 20-32 (10, 8, 7, 2, 2, 2 and 9 edges); later the two
# pieces flap, Newton stops at its iteration cap near 1e-8 (linear convergence, the projected
# Hessian), and ranks part by up to 1.1e-8 of the diagonal (7.6e-9 m at frame 51 of 60).
RESOLVE = 10
RESOLVING = {**WITH_ENERGY, "cloth": {**CLOTH["cloth"], "tear": {"strain": TEAR, "resolve": RESOLVE}},
             "time": {"dt": 1 / 60, "frames": 34}}


def torn_per_frame(out):
    with open(out / "topology.csv") as f:
        return {int(r["frame"]): int(r["edges_torn"]) for r in csv.DictReader(f)}


@pytest.fixture(scope="module")
def resolving(tmp_path_factory):
    return run_deck(tmp_path_factory.mktemp("resolving"), "resolving", RESOLVING)


def test_a_resolved_step_tears_until_no_edge_is_over(cloth, resolving):
    out, s = resolving
    fs, torn = frames(out), torn_per_frame(out)
    print("edges torn per frame:", {f: n for f, n in torn.items() if n})
    # the first tear comes in the step whose converged state first has an edge over the threshold,
    # one frame before the plain sheet's (which tears it at the next step's start)
    first = min(f for f, n in torn.items() if n)
    assert first == min(f for f, n in torn_per_frame(cloth[0]).items() if n) - 1
    assert max(torn.values()) == RESOLVE  # a rip ran RESOLVE edges in one step
    assert s["breaks"]["edges_torn"] == sum(torn.values()) > cloth[1]["breaks"]["edges_torn"]
    # a step solved again fewer than RESOLVE times ends with no edge over the threshold
    # (frame k's row counts the tear at its step's start and the re-solves' edges)
    for k, f in enumerate(fs):
        if k > 0 and torn.get(k, 0) < RESOLVE:
            assert edge_strains(f)[1].max() <= TEAR * (1 + 1e-12), k
    assert masses(fs[-1]).sum() == pytest.approx(masses(fs[0]).sum(), rel=1e-14)
    steps, stored = released_per_frame(out)
    assert steps.min() >= -1e-12 * stored  # no tear adds energy


def test_ranks_agree_on_a_resolved_tear(resolving, tmp_path):
    ref, s1 = resolving
    out, s2 = run_deck(tmp_path, "resolving", RESOLVING, ranks=2)
    assert torn_per_frame(ref) == torn_per_frame(out)
    worst = 0.0
    for a, b in zip(frames(ref), frames(out)):
        assert np.array_equal(a.vertex_id, b.vertex_id)
        worst = max(worst, np.abs(a.points - b.points).max() / rest_diagonal(a))
    print(f"1 and 2 ranks apart by at most {worst:.2e} of the diagonal")
    assert worst <= 1e-8


@pytest.mark.parametrize("ranks", [None, 2])
def test_restart_after_kill_after_resolved_tears_is_bitwise(tmp_path, ranks):
    # frames 19-24 tear 10, 8, 0, 7, 2 and 2 edges: the checkpoint at 22 holds steps of several batches
    assert_restart_after_kill_is_bitwise(tmp_path, RESOLVING, ranks, frames=26, every=22, kill_after=24)


@pytest.mark.parametrize("ranks", [None, 2])
def test_restart_after_a_signal_in_a_frame_that_began_with_a_tear_is_bitwise(cloth, tmp_path, ranks):
    """Before, the restart tore again from the same state: the next edge."""
    frame = first_changing_frame(cloth[0], "edges_torn")
    assert_restart_after_signal_in_a_changing_frame_is_bitwise(tmp_path, CLOTH, frame, ranks)


def test_restart_after_a_signal_during_a_tear_re_solve(tmp_path):
    # As fracture's (test_fracture_resolve.py): a signal in the last re-solve of a step that used up
    # its re-solves; the checkpoint of the frame before holds the tears so far and the re-solves made
    # (cuts_resolved), and the restart redoes that solve: the same positions, velocities and topology.csv.
    from test_fracture_resolve import solve_lengths  # here: test_topology_csv, which it imports, imports this module

    # L-BFGS: its solves end at their own counts (Newton's here all run to the 50-iteration cap), so
    # the last one can be told from the others by its length
    path = write_deck(tmp_path / "resolving.yaml", {**RESOLVING, "solver": {"type": "lbfgs"}})
    ref = tmp_path / "ref"
    run_hyperqn([path, "-o", ref], ranks=None)
    torn = torn_per_frame(ref)
    frame = min(f for f, n in torn.items() if n == RESOLVE)  # RESOLVE re-solves: RESOLVE + 1 solves
    lengths = solve_lengths(ref, frame)
    # the signal fires in the first solve that reaches its iteration: the latest re-solve longer than
    # every solve before it (a restart that counted the re-solves anew would make more than RESOLVE)
    k = max(j for j in range(1, len(lengths)) if lengths[j] > max(lengths[:j]))
    print("solves of frame", frame, lengths, "signal in solve", k)
    assert len(lengths) == RESOLVE + 1 and k >= 2, lengths
    out = tmp_path / "out"
    done = run_hyperqn([path, "-o", out, "-hyperqn_test_signal_in_frame", frame,
                        "-hyperqn_test_signal_at_iteration", max(lengths[:k]) + 1], ranks=None, check=False)
    assert done.returncode == 3, done.stdout[-2000:]
    run_hyperqn([path, "-o", out, "--restart", "latest"], ranks=None)
    a, b = final_frame(ref), final_frame(out)
    assert np.array_equal(a.vertex_id, b.vertex_id)
    assert np.array_equal(a.points, b.points) and np.array_equal(a.velocity, b.velocity)
    assert (out / "topology.csv").read_bytes() == (ref / "topology.csv").read_bytes()


def bad(**changes):
    deck = copy.deepcopy(CLOTH)
    deck["time"]["frames"] = 2
    for key, value in changes.items():
        deck[key] = value
    return deck


def tear(strain):
    return bad(cloth={**CLOTH["cloth"], "tear": {"strain": strain}})


BAD_DECKS = {
    "negative_strain": (tear(-0.2), ["cloth.tear.strain"]),
    "zero_strain": (tear(0.0), ["cloth.tear.strain"]),
    "nan_strain": (tear(float("nan")), ["cloth.tear.strain"]),
    "inf_strain": (tear(float("inf")), ["cloth.tear.strain"]),
    "missing_strain": (bad(cloth={**CLOTH["cloth"], "tear": {}}), ["strain"]),
    "negative_resolve": (bad(cloth={**CLOTH["cloth"], "tear": {"strain": TEAR, "resolve": -1}}), ["cloth.tear.resolve"]),
    "fractional_resolve": (bad(cloth={**CLOTH["cloth"], "tear": {"strain": TEAR, "resolve": 1.5}}), ["cloth.tear.resolve"]),
    # a torn edge opens by at most a tenth of the least triangle height (0.0354 m) per side
    "too_thick_with_self_contact": (bad(cloth={**CLOTH["cloth"], "thickness": 0.004}, contact={"self": True}),
                                    ["cloth.thickness", "too thick for tearing (or cutting) with self-contact", "0.0035"]),
}


@pytest.mark.parametrize("case", sorted(BAD_DECKS))
def test_bad_tear_deck_is_refused(tmp_path, case):
    deck, fragments = BAD_DECKS[case]
    assert_deck_refused(tmp_path, case, deck, fragments)
