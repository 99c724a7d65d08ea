"""Cloth (mesh.sheet, .obj / surface: cloth, the cloth: section; docs/cloth.md), end to end.

- The sheet of Liu et al. 2013 (pinned at two corners) runs at 1 and 2 ranks to the same positions;
  the output holds triangles with the stretch field; every example deck in input/cloth runs.
- A sheet hanging from one edge comes to rest in the static shape of a converged Newton run.
- A plate with quadratic bending under a small load matches the solution of the linear system
  of its discretization (the cotangent-weight bending matrix, built here independently).
- On mass-spring cloth with springs or quadratic bending, pd equals lbfgs with history 0.
- A cloth mesh that is not a manifold, or has a degenerate triangle, is refused by name; nothing is written.
"""
import os

import meshio
import numpy as np
import pytest

from conftest import REPO, load_deck, run_hyperqn, write_deck
from hyperqn_tools.compare import relative_difference
from hyperqn_tools.output import final_frame, read_iterations, read_pvd, read_summary, rest_diagonal

LIU_DECK = "input/cloth/sheet_corners.yaml"


def run(tmp_path, name, deck, ranks=None, check=True):
    out = tmp_path / name
    proc = run_hyperqn([write_deck(tmp_path / f"{name}.yaml", deck), "-o", out], ranks=ranks, check=check)
    return out, proc


def small_liu_sheet(frames=12):
    deck = load_deck(LIU_DECK)
    deck["mesh"]["sheet"]["cells"] = [24, 24]
    deck["time"]["frames"] = frames
    return deck


def test_liu_sheet_same_at_1_and_2_ranks(tmp_path):
    deck = small_liu_sheet()
    out1, _ = run(tmp_path, "np1", deck, ranks=1)
    out2, _ = run(tmp_path, "np2", deck, ranks=2)
    for out in (out1, out2):
        s = read_summary(out)
        assert s["status"] == "ok" and s["triangles"] == 2 * 24 * 24 and s["tets"] == 0, s
    a, b = final_frame(out1), final_frame(out2)
    diff = np.max(np.linalg.norm(a.points - b.points, axis=1)) / rest_diagonal(a)
    print(f"1 vs 2 ranks: max |x1 - x2| = {diff:.2e} rest diagonals")
    assert diff <= 1e-8
    assert np.min(a.points[:, 1]) < -0.3, "the sheet should swing down"
    # The .vtu holds the triangles, J (area ratio) and the stretch of each.
    m = meshio.read(read_pvd(os.path.join(out1, "np1.pvd"))[-1][1])
    assert [c.type for c in m.cells] == ["triangle"] and len(m.cells[0].data) == 2 * 24 * 24
    stretch = np.concatenate([np.ravel(x) for x in m.cell_data["stretch"]])
    J = np.concatenate([np.ravel(x) for x in m.cell_data["J"]])
    assert np.all(stretch >= np.sqrt(J) - 1e-12) and 1.0 < stretch.max() < 1.2, (stretch.min(), stretch.max())


@pytest.mark.parametrize("name", ["sheet_corners", "drape_sphere", "curtain"])
def test_example_decks_run(tmp_path, name):
    deck = load_deck(f"input/cloth/{name}.yaml")
    deck["time"]["frames"] = {"sheet_corners": 6, "drape_sphere": 14, "curtain": 8}[name]
    deck["output"] = {"vtk": name == "drape_sphere"}
    out, _ = run(tmp_path, name, deck)
    s = read_summary(out)
    assert s["status"] == "ok" and s["failed_frames"] == 0, s
    if name == "drape_sphere":  # the sheet has landed on the ball and none of it is inside
        f = final_frame(out)
        r = np.linalg.norm(f.points, axis=1)
        assert r.min() > 0.3 - 0.01 and f.points[:, 1].max() < 0.33, (r.min(), f.points[:, 1].max())


def hanging_sheet(solver, frames, dt, damping=0.0):
    """A 0.6 m x 0.4 m stvk membrane with quadratic bending, held along its edge z = 0.4."""
    return {
        "mesh": {"sheet": {"size": [0.6, 0.4], "cells": [12, 8]}},
        "cloth": {"model": "membrane", "material": "stvk", "youngs_modulus": 200.0, "poisson_ratio": 0.3,
                  "bending": {"model": "quadratic", "stiffness": 1.0e-3}, "areal_density": 0.2},
        "fixed": [{"box": {"min": [-0.01, -0.01, 0.399], "max": [0.61, 0.01, 0.401]}}],
        "gravity": [0, -9.81, 0],
        "time": {"dt": dt, "frames": frames, "damping": damping},
        "solver": solver,
        "output": {"every": frames},
    }


def test_hanging_sheet_comes_to_newtons_static_shape(tmp_path):
    # Newton with a step of 100 s: inertia is 1e-7 of gravity's work, so each frame is a static solve.
    newton, _ = run(tmp_path, "newton", hanging_sheet({"type": "newton", "iterations": 100, "grad_rtol": 1e-11}, 3, 100.0))
    lbfgs, _ = run(tmp_path, "lbfgs", hanging_sheet({"type": "lbfgs"}, 240, 1.0 / 30.0, damping=0.05))
    for out in (newton, lbfgs):
        assert read_summary(out)["status"] == "ok"
    a, b = final_frame(newton), final_frame(lbfgs)
    diff = np.max(np.linalg.norm(a.points - b.points, axis=1)) / rest_diagonal(a)
    print(f"hanging sheet: lbfgs at rest vs Newton's static shape: {diff:.2e} rest diagonals; "
          f"lowest point {a.points[:, 1].min():.4f} m")
    assert a.points[:, 1].min() < -0.35, "the sheet should hang down from its edge"
    assert diff <= 5e-4


def cotangent_bending_matrix(points, triangles):
    """K = sum over interior edges a-b of 3 / (A1 + A2) w w^T (Bergou et al. 2006) on (a, b, c, d),
    c and d opposite the edge, w from the cotangents of the triangles' angles at a and b."""
    n = len(points)
    K = np.zeros((n, n))
    edges = {}
    for t in triangles:
        for k in range(3):
            a, b, c = t[k], t[(k + 1) % 3], t[(k + 2) % 3]
            edges.setdefault((min(a, b), max(a, b)), []).append(c)

    def cot(at, p, q):  # cotangent of the angle at `at` between the directions to p and q
        u, v = points[p] - points[at], points[q] - points[at]
        return np.dot(u, v) / np.linalg.norm(np.cross(u, v))

    def area(p, q, r):
        return 0.5 * np.linalg.norm(np.cross(points[q] - points[p], points[r] - points[p]))

    for (a, b), opposite in edges.items():
        if len(opposite) != 2:
            continue
        c, d = opposite
        # w . x is the discrete mean-curvature normal at the edge: zero for every affine x.
        w = np.array([cot(b, a, c) + cot(b, a, d), cot(a, b, c) + cot(a, b, d),
                      -cot(a, b, c) - cot(b, a, c), -cot(a, b, d) - cot(b, a, d)])
        idx = [a, b, c, d]
        K[np.ix_(idx, idx)] += 3.0 / (area(a, b, c) + area(a, b, d)) * np.outer(w, w)
    return K


def test_quadratic_plate_matches_its_linear_solution(tmp_path):
    k, rho, g = 1.0e-2, 0.2, 1.0e-2  # a load small enough for the springs' O(w^2) stretch to vanish
    deck = {
        "mesh": {"sheet": {"size": [1.0, 1.0], "cells": [12, 12]}},
        "cloth": {"model": "mass-spring", "stretch_stiffness": 10.0,
                  "bending": {"model": "quadratic", "stiffness": k}, "areal_density": rho},
        "fixed": [{"box": {"min": [-0.01, -0.01, -0.01], "max": [1.01, 0.01, 0.001]}},
                  {"box": {"min": [-0.01, -0.01, 0.999], "max": [1.01, 0.01, 1.01]}},
                  {"box": {"min": [-0.01, -0.01, -0.01], "max": [0.001, 0.01, 1.01]}},
                  {"box": {"min": [0.999, -0.01, -0.01], "max": [1.01, 0.01, 1.01]}}],
        "gravity": [0, -g, 0],
        "time": {"dt": 100.0, "frames": 2},
        "solver": {"type": "newton", "iterations": 50, "grad_rtol": 1e-12},
        "output": {"every": 2},
    }
    out, _ = run(tmp_path, "plate", deck)
    f = final_frame(out)
    rest = f.points - f.displacement
    m = meshio.read(read_pvd(os.path.join(out, "plate.pvd"))[-1][1])
    order = np.argsort(np.asarray(m.point_data["vertex_id"]).ravel())  # Frame sorts by vertex id
    tri = np.argsort(order)[m.cells[0].data]
    K = k * cotangent_bending_matrix(rest, tri)
    # Affine fields are free of bending energy: a check of the weights themselves.
    for field in (np.ones(len(rest)), rest[:, 0], rest[:, 2]):
        assert np.max(np.abs(K @ field)) <= 1e-9 * np.max(np.abs(K))
    mass = np.zeros(len(rest))
    for t in tri:
        mass[t] += rho * 0.5 * np.linalg.norm(np.cross(rest[t[1]] - rest[t[0]], rest[t[2]] - rest[t[0]])) / 3
    boundary = (rest[:, 0] < 1e-9) | (rest[:, 0] > 1 - 1e-9) | (rest[:, 2] < 1e-9) | (rest[:, 2] > 1 - 1e-9)
    free = ~boundary
    w = np.zeros(len(rest))
    w[free] = np.linalg.solve(K[np.ix_(free, free)], -g * mass[free])
    got = f.displacement[:, 1]
    err = np.max(np.abs(got - w)) / np.max(np.abs(w))
    print(f"plate: max deflection {np.max(np.abs(w)):.3e} m, hyperqn vs linear solution: relative {err:.2e}")
    assert np.max(np.abs(w)) > 1e-4
    assert err <= 1e-3


@pytest.mark.parametrize("bending", ["springs", "quadratic"])
def test_pd_is_lbfgs_with_history_0_on_mass_spring_cloth(tmp_path, bending):
    deck = small_liu_sheet(frames=6)
    deck["cloth"]["bending"] = {"model": bending, "stiffness": 1.0 if bending == "springs" else 1.0e-3}
    deck["output"] = {"every": 6}
    outs = {}
    for name, solver in {"pd": {"type": "pd", "iterations": 10},
                         "lbfgs0": {"type": "lbfgs", "iterations": 10, "history": 0, "line_search": "unit"}}.items():
        d = dict(deck, solver={**solver, "max_iterations": 0, "max_halvings": 0, "newton_fallback": False})
        outs[name], proc = run(tmp_path, name, d)
        if name == "pd":
            assert "exact local-global steps" in proc.stdout, proc.stdout[-2000:]
    a, b = read_iterations(outs["pd"]), read_iterations(outs["lbfgs0"])
    assert [(r["frame"], r["iteration"], r["energy"]) for r in a] == [(r["frame"], r["iteration"], r["energy"]) for r in b]
    fa, fb = final_frame(outs["pd"]), final_frame(outs["lbfgs0"])
    assert np.array_equal(fa.points, fb.points), np.max(np.abs(fa.points - fb.points))


def test_fixed_budget_takes_exactly_the_iterations(tmp_path):
    """solver.budget: fixed (docs/deck-run.md#solver): every frame takes `iterations` iterations, no more,
    no sub-steps, no Newton, where the adaptive default goes on with frames left far from converged."""
    deck = small_liu_sheet(frames=8)
    deck["output"] = {"vtk": False}
    counts = {}
    for budget in ("adaptive", "fixed"):
        d = dict(deck, solver={"type": "lbfgs", "iterations": 3, "budget": budget})
        out, _ = run(tmp_path, budget, d)
        per_frame = {}
        for r in read_iterations(out):
            per_frame[r["frame"]] = max(per_frame.get(r["frame"], 0), r["iteration"])
        counts[budget] = (per_frame, read_summary(out))
    fixed, summary = counts["fixed"]
    assert sorted(fixed) == list(range(1, 9)) and set(fixed.values()) == {3}, fixed
    assert summary["substepped_frames"] == 0 and summary["newton_frames"] == 0, summary
    adaptive, summary = counts["adaptive"]
    print(f"iterations per frame, adaptive: {adaptive}; fixed: {fixed}")
    assert max(adaptive.values()) > 3 or summary["substepped_frames"] > 0 or summary["newton_frames"] > 0, adaptive


def test_bad_cloth_meshes_are_refused(tmp_path):
    springs = {"model": "mass-spring", "stretch_stiffness": 10.0, "areal_density": 0.1}
    cases = {
        "fan.obj": ("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 1 1 1\nf 1 2 3\nf 1 2 4\nf 2 1 5\n", "shared by 3 triangles"),
        "flat.obj": ("v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 4\nf 1 2 3\n", "triangle 2"),
        # before: "'Tetrahedra': the mesh has no tetrahedra"
        "none.obj": ("v 0 0 0\nv 1 0 0\n", "none.obj: 'f': the file has no faces"),
        "slash.obj": ("v 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nf 1/x 2 3\nf 1 3 4\n", "slash.obj:5: 'f': expected a vertex as"),
    }
    for file, (text, message) in cases.items():
        (tmp_path / file).write_text(text)
        out, proc = run(tmp_path, file[:-4], {"mesh": {"file": str(tmp_path / file)}, "cloth": springs}, check=False)
        assert proc.returncode == 1 and file in proc.stdout and message in proc.stdout, proc.stdout[-1000:]
        assert not os.path.exists(out) or not os.listdir(out), os.listdir(out)


def test_gmsh_and_medit_cloth_files(tmp_path):
    # One square of two triangles, as Gmsh 2.2 and as Medit (with a tet beside it, skipped), pinned at one corner.
    nodes = [(0, 0, 0), (0.5, 0, 0), (0.5, 0, 0.5), (0, 0, 0.5)]
    gmsh = ("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n" +
            "".join(f"{i + 1} {x} {y} {z}\n" for i, (x, y, z) in enumerate(nodes)) +
            "$EndNodes\n$Elements\n3\n1 15 2 0 1 1\n2 2 2 0 1 1 2 3\n3 2 2 0 1 1 3 4\n$EndElements\n")
    medit = ("MeshVersionFormatted 2\nDimension 3\nVertices\n5\n" + "".join(f"{x} {y} {z} 0\n" for x, y, z in nodes) +
             "0 1 0 0\nTriangles\n2\n1 2 3 0\n1 3 4 0\nTetrahedra\n1\n1 2 3 5 0\nEnd\n")
    (tmp_path / "square.msh").write_text(gmsh)
    (tmp_path / "square.mesh").write_text(medit)
    for file in ("square.msh", "square.mesh"):
        deck = {"mesh": {"file": str(tmp_path / file), "surface": "cloth"},
                "cloth": {"model": "membrane", "material": "neohookean", "youngs_modulus": 100.0, "poisson_ratio": 0.3,
                          "bending": {"model": "dihedral", "stiffness": 1e-3}, "areal_density": 0.1},
                "fixed": [{"box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 0.01, 0.01]}}],
                "time": {"dt": 0.02, "frames": 5}, "solver": {"type": "lbfgs"}}
        out, proc = run(tmp_path, file.replace(".", "_"), deck)
        s = read_summary(out)
        assert s["status"] == "ok" and s["triangles"] == 2 and s["tets"] == 0 and s["vertices"] == 4, s


def spring_strip(integrator="implicit-midpoint", gravity=True, membrane=False, frames=30):
    """/tmp/probe-3/cloth_mid_el.yaml: an elastic 10 x 2 mass-spring strip between two supports, one moved in and up
    by a table curve and then held; h = 0.05 s resolves none of its springs (h sqrt(k/m) ~ 45), Newton to 1e-10.
    membrane: a StVK membrane (E = 1e4 N/m) with dihedral bending instead."""
    cloth = {"model": "mass-spring", "stretch_stiffness": 1000.0, "areal_density": 0.2,
             "bending": {"model": "springs", "stiffness": 10.0}}
    if membrane:
        cloth = {"model": "membrane", "material": "stvk", "youngs_modulus": 1.0e4, "poisson_ratio": 0.3,
                 "areal_density": 0.2, "bending": {"model": "dihedral", "stiffness": 0.01}}
    return {
        "mesh": {"sheet": {"size": [1.0, 0.2], "cells": [10, 2]}},
        "cloth": cloth,
        "fixed": [{"box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 0.01, 0.21]}},
                  {"box": {"min": [0.99, -0.01, -0.01], "max": [1.01, 0.01, 0.21]},
                   "motion": {"translate": {"velocity": [-0.2, 0.3, 0]},
                              "curve": {"type": "table", "points": [[0, 0], [0.5, 1], [1.0, 0.2]]}}}],
        "gravity": [0, -9.81 if gravity else 0.0, 0],
        "time": {"dt": 0.05, "frames": frames, "integrator": integrator},
        "solver": {"type": "newton", "iterations": 100, "grad_rtol": 1.0e-10},
        "output": {"every": frames, "energy": True},
    }


def energy_rows(out):
    with open(out / "energy.csv") as f:
        header = f.readline().strip().split(",")
        rows = np.array([[float(c) for c in line.split(",")] for line in f if line.strip()])
    return {name: rows[:, k] for k, name in enumerate(header)}


@pytest.mark.parametrize("gravity,membrane", [(True, False), (False, False), (True, True)])
def test_midpoint_makes_no_energy_in_a_stiff_cloth_strip(tmp_path, gravity, membrane):
    """The implicit midpoint on cloth it does not resolve (docs/method.md#time-integrators): the end map 2z - x_n
    doubles the sag or the buckle z took over half a step, and a spring's energy is not quadratic where it turns,
    so the step made energy out of nothing, status ok: by frame 30, 424 J of kinetic + stored energy from 0.13 J
    of the supports' work (1194 J from 0.64 J without gravity; the membrane 1090 J from 0.55 J). The
    stabilization's energy test on the cloth's terms ends such steps by Euler: energy.csv's residual (the energy
    made) stays below a tenth of the work (measured: never above 0 after frame 0)."""
    out, proc = run(tmp_path, "strip", spring_strip(gravity=gravity, membrane=membrane))
    s = read_summary(out)
    e = energy_rows(out)
    work = np.abs(e["support_work"]).max() + np.abs(e["gravity_work"]).max()
    print(f"gravity {gravity}, membrane {membrane}: euler_completed_steps {s['euler_completed_steps']}, largest residual "
          f"{e['residual'].max():.3e} J, stored {e['stored'][-1]:.3e} J, kinetic {e['kinetic'][-1]:.3e} J, "
          f"work {work:.3e} J")
    assert s["status"] == "ok" and s["euler_completed_steps"] > 0
    assert e["residual"].max() <= 0.1 * work
