"""hyperqn_tools.intersections, the independent count of intersecting surface triangles
(docs/outputs.md#intersecting-triangles):
- hand-made pairs against the unit triangle A in z = 0, tolerance 1e-8: a crossing counts; touching
  at a point or along an edge, or reaching into A by less than the tolerance, does not; coplanar
  triangles count when their interiors overlap; near misses by 1e-9 and 1e-3 do not count, the same
  reach into A does by 1e-3 only; triangles that share a vertex are never a pair;
- the grid broad phase finds the same box pairs and the same count as all pairs on random soups;
- end to end: a hanging bar and the Liu cloth sheet have none in any frame; two blocks of `bodies`
  (which do not collide with each other) thrown through each other have none at the start and some
  once they overlap, the same at 1 and 2 ranks and in XDMF; the command's output, JSON and exit codes."""
import json
import subprocess
import sys

import numpy as np
import pytest

from conftest import load_deck, run_hyperqn, write_deck
from hyperqn_tools.intersections import (intersecting_pairs, overlapping_boxes, surface_triangles,
                                         triangles_intersect)

TOL = 1e-8
A = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]  # the unit right triangle in z = 0


def intersects(b, a=A, tol=TOL):
    return bool(triangles_intersect(np.array([a], float), np.array([b], float), tol)[0])


def test_crossing_triangles_intersect_either_way_round():
    b = [[0.2, 0.2, -0.5], [0.3, 0.2, 0.5], [0.2, 0.3, 0.5]]  # pierces A's interior
    assert intersects(b) and intersects(A, a=b)


@pytest.mark.parametrize("depth", [0.0, 0.5e-8])  # on A's plane, or below it within the tolerance
def test_touching_at_a_point_or_along_an_edge_does_not_count(depth):
    assert not intersects([[0.2, 0.2, -depth], [0.3, 0.2, 0.5], [0.2, 0.3, 0.5]])  # a vertex on A
    assert not intersects([[0.1, 0.2, -depth], [0.6, 0.2, -depth], [0.3, 0.2, 0.5]])  # an edge on A
    # crossing A's plane, with the cut ending on A's edge y = 0: the cuts touch at one point
    assert not intersects([[0.5, depth, -0.5], [0.5, depth, 0.5], [0.5, -1, 0]])


@pytest.mark.parametrize("reach, counts", [(-1e-3, False), (-1e-9, False), (1e-9, False), (1e-3, True)])
def test_near_misses_and_reaches_into_a(reach, counts):
    """B crosses A's plane in the plane y = 0.3 with its cut ending at x = reach: past A's edge x = 0
    (a miss) or into A by reach, which counts only beyond the tolerance."""
    assert intersects([[-1, 0.3, -0.5], [-1, 0.3, 0.5], [reach, 0.3, 0]]) == counts


@pytest.mark.parametrize("depth, counts", [(1e-9, False), (1e-3, True)])
def test_a_vertex_through_a(depth, counts):
    assert intersects([[0.2, 0.2, -depth], [0.3, 0.2, 0.5], [0.2, 0.3, 0.5]]) == counts


def test_coplanar_triangles_count_when_their_interiors_overlap():
    shifted = lambda dx, dy, dz=0.0: [[x + dx, y + dy, z + dz] for x, y, z in A]  # noqa: E731
    assert intersects(shifted(0.3, 0.3))
    assert intersects(shifted(0.3, 0.3, 1e-9))  # within the tolerance of A's plane: coplanar
    assert not intersects(shifted(0.3, 0.3, 1e-3))  # parallel, above A
    assert not intersects(shifted(2.0, 0.0))  # disjoint
    assert not intersects(shifted(1.0, 0.0))  # touching at the vertex (1, 0, 0)
    assert not intersects([[1, 0, 0], [0, 1, 0], [1, 1, 0]])  # touching along A's long edge
    assert intersects([[1, 0, 0], [0, 1, 0], [0.4, 0.4, 0]])  # its interior reaches into A's


def test_triangles_sharing_a_vertex_are_never_a_pair():
    """B crosses A along the diagonal from the vertex they share; as two triangles with a vertex
    each at the same place they intersect."""
    points = np.array(A + [[0.4, 0.4, 0.5], [0.4, 0.4, -0.5], [0, 0, 0]], float)
    assert len(intersecting_pairs(points, np.array([[0, 1, 2], [0, 3, 4]]), TOL)) == 0
    assert intersecting_pairs(points, np.array([[0, 1, 2], [5, 3, 4]]), TOL).tolist() == [[0, 1]]


def test_surface_of_tets_is_their_unshared_faces():
    assert len(surface_triangles({"tetra": np.array([[0, 1, 2, 3]])})) == 4
    two = surface_triangles({"tetra": np.array([[0, 1, 2, 3], [1, 2, 3, 4]]), "triangle": np.array([[5, 6, 7]])})
    assert len(two) == 7 and [1, 2, 3] not in np.sort(two, axis=1).tolist() and two[-1].tolist() == [5, 6, 7]


def triangle_soup(rng, n, size, points=None):
    """n random triangles of the given size in the unit cube; with points, their vertices are drawn
    from a pool of that many, so that some triangles share vertices."""
    if points is None:
        centre = rng.random((n, 1, 3))
        return (centre + size * (rng.random((n, 3, 3)) - 0.5)).reshape(-1, 3), np.arange(3 * n).reshape(-1, 3)
    pool = rng.random((points, 3))
    triangles = np.array([rng.choice(points, 3, replace=False) for _ in range(n)])
    return pool, triangles


@pytest.mark.parametrize("n, size, pool", [(400, 0.8, None), (1000, 0.1, None), (1000, 0.05, None),
                                           (600, 1.0, 60), (500, 1.0, 400)])
def test_broad_phase_matches_all_pairs(n, size, pool):
    rng = np.random.default_rng(n)
    points, triangles = triangle_soup(rng, n, size, pool)
    T = points[triangles]
    lo, hi = T.min(axis=1), T.max(axis=1)
    i, j = np.triu_indices(n, 1)
    overlapping = np.all(lo[i] <= hi[j], axis=1) & np.all(lo[j] <= hi[i], axis=1)
    found = overlapping_boxes(lo, hi)
    assert sorted(map(tuple, found.tolist())) == list(zip(i[overlapping].tolist(), j[overlapping].tolist()))
    apart = ~np.any(triangles[i][:, :, None] == triangles[j][:, None, :], axis=(1, 2))
    brute = np.count_nonzero(triangles_intersect(T[i[apart]], T[j[apart]], TOL))
    counted = len(intersecting_pairs(points, triangles, TOL))
    print(f"{n} triangles of size {size}: {len(found)} box pairs, {counted} intersecting")
    assert counted == brute and counted > 0


def check(outdir, *args):
    """The command on outdir: (exit code, stdout, stderr)."""
    p = subprocess.run([sys.executable, "-m", "hyperqn_tools.intersections", str(outdir), *map(str, args)],
                       capture_output=True, text=True, timeout=600)
    return p.returncode, p.stdout, p.stderr


def counts_of(outdir, *args):
    code, out, err = check(outdir, "--json", outdir / "intersections.json", *args)
    assert code == 0, err
    report = json.loads((outdir / "intersections.json").read_text())
    return [r["intersecting_pairs"] for r in report["frames"]], report


@pytest.mark.parametrize("deck_name, frames", [("tests/decks/hanging_bar.yaml", None), ("input/cloth/sheet_corners.yaml", 30)])
def test_runs_without_contact_between_parts_have_none(tmp_path, deck_name, frames):
    deck = load_deck(deck_name)
    if frames:  # the Liu sheet (81 x 81 vertices) swinging down, every frame written
        deck["time"]["frames"] = frames
    deck["output"] = dict(deck.get("output", {}), every=1)
    out = tmp_path / "out"
    run_hyperqn([write_deck(tmp_path / "deck.yaml", deck), "-o", out], ranks=None)
    counts, report = counts_of(out)
    assert len(counts) == deck["time"]["frames"] + 1 and counts == [0] * len(counts)
    assert report["frames"][0]["triangles"] == (2 * 80 * 80 if frames else 4 * (2 * 2 + 2 * 12 + 2 * 12))


BLOCK = {"mesh": {"box": {"size": [0.2, 0.2, 0.2], "cells": [2, 2, 2]}},
         "material": {"model": "neohookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 1000}}


def through_each_other(output_format="vtu"):
    """Two blocks 0.1 apart along x (and offset in y and z, so that no faces are coplanar), the
    first thrown at the second at 3 m/s: bodies do not collide with each other, so from t = 0.1/3 s
    it passes into it."""
    first = dict(BLOCK, name="thrown", velocity=[3.0, 0, 0])
    second = dict(BLOCK, name="still", mesh=dict(BLOCK["mesh"], transform={"translate": [0.3, 0.05, 0.07]}))
    return {"bodies": [first, second], "gravity": [0, 0, 0], "time": {"dt": 0.01, "frames": 8},
            "solver": {"type": "newton", "iterations": 20}, "output": {"every": 1, "format": output_format}}


def test_bodies_passing_through_each_other_are_found(tmp_path):
    runs = {}
    for name, ranks, output_format in (("np1", None, "vtu"), ("np2", 2, "vtu"), ("xdmf", 1, "xdmf")):
        out = tmp_path / name
        run_hyperqn([write_deck(tmp_path / f"{name}.yaml", through_each_other(output_format)), "-o", out], ranks=ranks)
        runs[name], report = counts_of(out)
        print(f"{name}: intersecting pairs per frame {runs[name]}")
        assert all(r["triangles"] == 2 * 48 for r in report["frames"])  # 2 x 6 faces x 8 triangles
    assert runs["np1"][:4] == [0, 0, 0, 0] and min(runs["np1"][4:]) > 0  # they meet at t = 0.033 s
    assert runs["np2"] == runs["np1"] and runs["xdmf"] == runs["np1"]

    code, out, _ = check(tmp_path / "np1", "--frames", 0, 8)
    assert code == 0 and len(out.splitlines()) == 3
    assert f"largest: {runs['np1'][8]} intersecting pairs (frame 8)" in out


def test_bad_directories_are_refused(tmp_path):
    code, _, err = check(tmp_path / "missing")
    assert code == 1 and "missing: no such directory" in err and "Traceback" not in err
    code, _, err = check(tmp_path)
    assert code == 1 and "no .pvd or .xdmf" in err
    out = tmp_path / "run"
    run_hyperqn([write_deck(tmp_path / "deck.yaml", through_each_other() | {"time": {"dt": 0.01, "frames": 1}}), "-o", out],
                ranks=None)
    code, _, err = check(out, "--frames", 5)
    assert code == 1 and "no frame 5" in err
    (piece,) = out.glob("*_00001.vtu")
    piece.write_text("<VTKFile>cut off")
    code, _, err = check(out)
    assert code == 1 and f"{piece.name}: cannot read frame 1" in err
