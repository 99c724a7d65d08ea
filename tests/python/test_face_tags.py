"""Regions by the mesh file's face tags (face_tag in loads: and fixed:, docs/loads.md#regions), end to end.

The test writes a 2 x 1 x 1 bar of 4 x 2 x 2 cubes (6 tets each) as a Medit .mesh and as Gmsh
4.1 and 2.2 .msh files, with its boundary triangles tagged by side (x = 0: 5, x = 2: 3, the rest:
1) and one interior triangle tagged 3 and one tagged 7.

- A bar clamped by face_tag 5 under a traction on face_tag 3 ends bitwise where the same bar
  clamped and loaded by the equivalent boxes ends, from each file, at 1, 2 and 4 ranks; the run
  says how many of the tag's triangles it left out (the interior one).
- A force on the free vertices of a tag is the force on the equivalent box, bitwise.
- Bad input stops with exit 1 before anything is written, naming the deck line and key: a tag on
  no triangle, a tag on interior triangles only, a fixed tag on no triangle, a region with neither
  box nor face_tag, a face_tag on a generated box or sheet, on a mesh of strands alone.
- A real mesh of /work/shared/meshes (skipped where absent): bar990.mesh's triangles all carry
  reference 0; face_tag 0 selects its 700 boundary faces, as a box around the whole bar does.
"""
import copy
import itertools
import os

import numpy as np
import pytest

from conftest import run_hyperqn, write_deck
from hyperqn_tools.output import final_frame
from test_bad_input import assert_clean_failure

CELLS = (4, 2, 2)
SIZE = (2.0, 1.0, 1.0)
CLAMP, LOAD, SIDE, INNER = 5, 3, 1, 7
INTERIOR_LOAD = 1  # interior triangles tagged LOAD (left out of its region)


def bar_mesh():
    """Vertices (n x 3), tets (6 per cube, Kuhn), tagged triangles [(a, b, c, tag)] (0-based)."""
    nx, ny, nz = CELLS
    index = lambda i, j, k: (i * (ny + 1) + j) * (nz + 1) + k
    points = np.array([[SIZE[0] * i / nx, SIZE[1] * j / ny, SIZE[2] * k / nz]
                       for i in range(nx + 1) for j in range(ny + 1) for k in range(nz + 1)])
    tets = []
    for i, j, k in itertools.product(range(nx), range(ny), range(nz)):
        for order in itertools.permutations(range(3)):
            corner = [i, j, k]
            tet = [index(*corner)]
            for axis in order:
                corner[axis] += 1
                tet.append(index(*corner))
            tets.append(tet)
    faces = {}
    for tet in tets:
        for f in itertools.combinations(tet, 3):
            faces.setdefault(tuple(sorted(f)), []).append(tet)
    tagged = []
    for f, owners in sorted(faces.items()):
        if len(owners) > 1:
            continue
        x = points[list(f), 0]
        tag = CLAMP if np.all(x == 0) else LOAD if np.all(x == SIZE[0]) else SIDE
        tagged.append((*f, tag))
    interior = [f for f, owners in sorted(faces.items()) if len(owners) == 2]
    tagged.append((*interior[0], LOAD))
    tagged.append((*interior[1], INNER))
    return points, np.array(tets), tagged


def write_medit(path, points, tets, triangles, edges=()):
    with open(path, "w") as f:
        f.write("MeshVersionFormatted 1\nDimension 3\n")
        f.write(f"Vertices\n{len(points)}\n" + "".join(f"{x!r} {y!r} {z!r} 0\n" for x, y, z in points))
        if len(triangles):
            f.write(f"Triangles\n{len(triangles)}\n" + "".join(f"{a + 1} {b + 1} {c + 1} {t}\n" for a, b, c, t in triangles))
        if len(tets):
            f.write(f"Tetrahedra\n{len(tets)}\n" + "".join(" ".join(str(v + 1) for v in t) + " 1\n" for t in tets))
        if len(edges):
            f.write(f"Edges\n{len(edges)}\n" + "".join(f"{a + 1} {b + 1} 0\n" for a, b in edges))
        f.write("End\n")
    return path


def write_gmsh41(path, points, tets, triangles):
    """MSH 4.1 with $Entities: one volume (physical 1), one surface per tag (its physical group)."""
    tags = sorted({t for *_, t in triangles})
    with open(path, "w") as f:
        f.write("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Entities\n")
        f.write(f"0 0 {len(tags)} 1\n")
        for s, tag in enumerate(tags):
            f.write(f"{s + 1} 0 0 0 2 1 1 1 {tag} 0\n")
        f.write("1 0 0 0 2 1 1 1 1 0\n$EndEntities\n$Nodes\n")
        n = len(points)
        f.write(f"1 {n} 1 {n}\n3 1 0 {n}\n" + "".join(f"{v + 1}\n" for v in range(n)))
        f.write("".join(f"{x!r} {y!r} {z!r}\n" for x, y, z in points) + "$EndNodes\n$Elements\n")
        total = len(tets) + len(triangles)
        f.write(f"{len(tags) + 1} {total} 1 {total}\n")
        e = 1
        for s, tag in enumerate(tags):
            mine = [t for t in triangles if t[3] == tag]
            f.write(f"2 {s + 1} 2 {len(mine)}\n")
            for a, b, c, _ in mine:
                f.write(f"{e} {a + 1} {b + 1} {c + 1}\n")
                e += 1
        f.write(f"3 1 4 {len(tets)}\n")
        for t in tets:
            f.write(f"{e} " + " ".join(str(v + 1) for v in t) + "\n")
            e += 1
        f.write("$EndElements\n")
    return path


def write_gmsh22(path, points, tets, triangles):
    """MSH 2.2: each element with its physical group and elementary tag."""
    with open(path, "w") as f:
        f.write("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n")
        f.write(f"{len(points)}\n" + "".join(f"{v + 1} {x!r} {y!r} {z!r}\n" for v, (x, y, z) in enumerate(points)))
        f.write(f"$EndNodes\n$Elements\n{len(tets) + len(triangles)}\n")
        e = 1
        for a, b, c, tag in triangles:
            f.write(f"{e} 2 2 {tag} {tag} {a + 1} {b + 1} {c + 1}\n")
            e += 1
        for t in tets:
            f.write(f"{e} 4 2 1 1 " + " ".join(str(v + 1) for v in t) + "\n")
            e += 1
        f.write("$EndElements\n")
    return path


WRITERS = {"bar.mesh": write_medit, "bar41.msh": write_gmsh41, "bar22.msh": write_gmsh22}
END_BOX = {"min": [2.0, -1, -1], "max": [2.0, 2, 2]}
CLAMP_BOX = {"min": [0.0, -1, -1], "max": [0.0, 2, 2]}
TRACTION = [0.0, -2.0e3, 1.0e3]


def deck_for(mesh_file, fixed, load):
    return {
        "mesh": {"file": str(mesh_file)},
        "material": {"model": "neohookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 100.0},
        "fixed": [fixed],
        "loads": [dict(load, type="traction", traction=TRACTION)],
        "gravity": [0, 0, 0],
        "time": {"dt": 0.02, "frames": 3},
        "solver": {"type": "lbfgs", "iterations": 200, "grad_rtol": 1.0e-10},
        "output": {"every": 3},
    }


@pytest.fixture(scope="module")
def meshes(tmp_path_factory):
    d = tmp_path_factory.mktemp("face_tag_meshes")
    points, tets, triangles = bar_mesh()
    return {name: write(d / name, points, tets, triangles) for name, write in WRITERS.items()}


def run(tmp_path, name, deck, ranks):
    out = tmp_path / name
    proc = run_hyperqn([write_deck(tmp_path / f"{name}.yaml", deck), "-o", out], ranks=ranks)
    return proc, final_frame(out)


@pytest.mark.parametrize("ranks", [1, 2, 4])
@pytest.mark.parametrize("mesh", sorted(WRITERS))
def test_tag_gives_the_box_results(tmp_path, meshes, mesh, ranks):
    by_box = deck_for(meshes[mesh], {"box": CLAMP_BOX}, {"box": END_BOX})
    by_tag = deck_for(meshes[mesh], {"face_tag": CLAMP}, {"face_tag": LOAD})
    _, box_frame = run(tmp_path, "box", by_box, ranks)
    proc, tag_frame = run(tmp_path, "tag", by_tag, ranks)
    assert "on 8 boundary faces of face_tag 3 (1 of the tag's triangles are not boundary faces" in proc.stdout, \
        proc.stdout[-2000:]
    moved = np.abs(tag_frame.displacement).max()
    print(f"{mesh}, {ranks} rank(s): largest displacement {moved:.3e}, "
          f"tag - box {np.abs(tag_frame.points - box_frame.points).max():.1e}")
    assert moved > 1e-4, "the traction moves the bar"
    assert np.array_equal(tag_frame.points, box_frame.points), "bitwise the box's frame"
    # A tag and a box together: their intersection (the end's faces with y <= 0.5).
    half = deck_for(meshes[mesh], {"face_tag": CLAMP}, {"face_tag": LOAD, "box": {"min": [-1, -1, -1], "max": [3, 0.5, 2]}})
    proc, _ = run(tmp_path, "half", half, ranks)
    assert "on 4 boundary faces of face_tag 3" in proc.stdout, proc.stdout[-2000:]


def test_force_on_a_tag(tmp_path, meshes):
    """A force on the free vertices of face_tag 5 (the end x = 0, the bar clamped at x = 2) is the
    force on the box around that end, bitwise (2 ranks)."""
    results = {}
    for name, region in (("box", {"box": CLAMP_BOX}), ("tag", {"face_tag": CLAMP})):
        deck = deck_for(meshes["bar.mesh"], {"box": END_BOX}, {})
        deck["loads"] = [dict(region, type="force", force=[0.0, -50.0, 0.0])]
        results[name] = run(tmp_path, name, deck, 2)
    assert "on 9 free vertices of face_tag 5" in results["tag"][0].stdout, results["tag"][0].stdout[-2000:]
    assert np.abs(results["tag"][1].displacement).max() > 1e-4
    assert np.array_equal(results["tag"][1].points, results["box"][1].points)


def bad(tmp_path, case, deck, fragments):
    path = write_deck(tmp_path / f"{case}.yaml", deck)
    outdir = tmp_path / "out"
    proc = run_hyperqn([path, "-o", outdir], ranks=None, check=False, timeout=60)
    assert proc.returncode == 1, proc.stdout[-2000:]
    assert_clean_failure(proc, outdir, [f"{case}.yaml"] + fragments)


# write_deck keeps the keys' order: fixed[0] is deck line 4, loads[0]'s face_tag line 6.
@pytest.mark.parametrize("case", ["tag_on_no_triangle", "tag_on_interior_faces", "fixed_tag_on_no_triangle",
                                  "neither_box_nor_tag", "fixed_neither"])
def test_bad_tags(tmp_path, meshes, case):
    mesh = meshes["bar.mesh"]
    decks = {
        "tag_on_no_triangle": (deck_for(mesh, {"face_tag": CLAMP}, {"face_tag": 9}),
                               [".yaml:6:", "'loads[0].face_tag'", "no triangle of the mesh file", "carries tag 9",
                                "1, 3, 5, 7"]),
        "tag_on_interior_faces": (deck_for(mesh, {"face_tag": CLAMP}, {"face_tag": INNER}),
                                  [".yaml:6:", "'loads[0].face_tag'", "selects no boundary face", "interior faces"]),
        "fixed_tag_on_no_triangle": (deck_for(mesh, {"face_tag": 4}, {"face_tag": LOAD}),
                                     [".yaml:4:", "'fixed[0].face_tag'", "carries tag 4"]),
        "neither_box_nor_tag": (deck_for(mesh, {"face_tag": CLAMP}, {"normal": [1, 0, 0]}),
                                ["'loads[0]'", "give box or face_tag"]),
        "fixed_neither": (deck_for(mesh, {"release": 1.0}, {"face_tag": LOAD}), ["'fixed[0]'", "give box or face_tag"]),
    }
    deck, fragments = decks[case]
    bad(tmp_path, case, deck, fragments)


def test_tag_on_meshes_without_faces(tmp_path, meshes):
    box = deck_for("x", {"face_tag": CLAMP}, {"face_tag": LOAD})
    box["mesh"] = {"box": {"size": [2, 1, 1], "cells": [4, 2, 2]}}
    bad(tmp_path, "box_mesh", box, ["'fixed[0].face_tag'", "generated (mesh.box)", "select by box"])
    sheet = copy.deepcopy(box)
    sheet["mesh"] = {"sheet": {"size": [1, 1], "cells": [2, 2]}}
    del sheet["material"]
    sheet["cloth"] = {"model": "mass-spring", "stretch_stiffness": 100.0, "areal_density": 0.2}
    bad(tmp_path, "sheet_mesh", sheet, ["'fixed[0].face_tag'", "generated (mesh.sheet)"])
    # A file of strands alone (Medit Edges): no tets, whose faces a tag would select.
    points = np.array([[0.1 * k, 0, 0] for k in range(5)])
    strands = write_medit(tmp_path / "strands.mesh", points, [], [(0, 1, 2, LOAD)], edges=[(k, k + 1) for k in range(4)])
    rope = deck_for(strands, {"face_tag": LOAD}, {"face_tag": LOAD})
    rope["mesh"]["edges"] = "strands"
    del rope["material"]
    rope["strand_material"] = {"axial_stiffness": 100.0, "linear_density": 0.05}
    bad(tmp_path, "strand_mesh", rope, ["face_tag'", "no tetrahedra"])
    # A body's own fixed region is named as the body's (it was 'fixed[1].face_tag')
    body = {k: v for k, v in deck_for(meshes["bar.mesh"], {"face_tag": CLAMP}, {}).items() if k in ("mesh", "material", "fixed")}
    body["fixed"] = [{"box": CLAMP_BOX}, {"box": CLAMP_BOX, "face_tag": CLAMP}]  # (written out twice: line 11)
    bad(tmp_path, "bodies", {"bodies": [body], "time": {"dt": 0.01, "frames": 1}},
        [":11: 'bodies[0].fixed[1].face_tag'", "a scene of bodies has several"])


SHARED_BAR = "/work/shared/meshes/bar990.mesh"


@pytest.mark.skipif(not os.path.exists(SHARED_BAR), reason=f"{SHARED_BAR} is absent")
def test_shared_mesh_references(tmp_path):
    """bar990.mesh lists its 700 boundary triangles with reference 0: face_tag 0 is its whole surface."""
    lo = [-1e3] * 3
    hi = [1e3] * 3
    everywhere = {"min": lo, "max": hi}
    base = deck_for(SHARED_BAR, {"box": everywhere}, {})
    del base["fixed"]  # a free bar
    base["time"]["frames"] = 2
    by_tag, by_box = copy.deepcopy(base), copy.deepcopy(base)
    by_tag["loads"][0]["face_tag"] = 0
    by_box["loads"][0]["box"] = everywhere
    del base
    procs, frames = {}, {}
    for name, deck in (("tag", by_tag), ("box", by_box)):
        procs[name], frames[name] = run(tmp_path, name, deck, 2)
    assert "on 700 boundary faces of face_tag 0" in procs["tag"].stdout, procs["tag"].stdout[-2000:]
    assert "not boundary faces" not in procs["tag"].stdout
    assert np.array_equal(frames["tag"].points, frames["box"].points)


def test_force_displacement_of_a_support_of_a_tag_alone(tmp_path, meshes):
    """A clamp given by face_tag alone pulled 0.05 per frame: its moment point is the origin moved by
    its motion (outputs.md#reactionscsv), and hyperqn_tools.force_displacement reads its travel from it
    (before: 'config.yaml has no fixed[1].box.min and .max', exit 1)."""
    from hyperqn_tools.force_displacement import curve
    deck = deck_for(meshes["bar.mesh"], {"face_tag": CLAMP}, {"face_tag": LOAD})
    del deck["loads"]
    deck["fixed"].append({"face_tag": LOAD, "motion": {"translate": {"velocity": [0.1, 0, 0]}, "curve": {"type": "ramp", "end": 2}}})
    deck["time"] = {"dt": 1, "frames": 2, "integrator": "static"}
    deck["output"] = {"reactions": True}
    out = tmp_path / "pull"
    run_hyperqn([write_deck(tmp_path / "pull.yaml", deck), "-o", out], ranks=None)
    travel, force = curve(out, "fixed[1]", "x")
    assert np.allclose(travel, [0.05, 0.1]) and np.all(force > 0), (travel, force)
