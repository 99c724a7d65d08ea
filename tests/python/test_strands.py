"""Strands: two-vertex segments carrying one axial spring each, alone or tied to a solid.

- A rope hanging from its top end settles to the static profile u(s) = rho g (L s - s^2 / 2) / EA
  (exact for the lumped-mass chain too), with lbfgs, newton and pd, at 1 and 2 ranks, and the
  same rope read from a Medit file's Edges gives the same answer.
- A cube hanging from a rope (tets and segments in one body): the tie point sinks by
  (W L + rho g L^2 / 2) / EA; 1 and 2 ranks agree; the VTK holds tets and lines.
- Springs are a Projective Dynamics energy: pd takes exact steps and matches lbfgs with history 0.
"""
import os

import numpy as np
import pytest

from conftest import REPO, load_deck, run_hyperqn, write_deck
from hyperqn_tools.compare import relative_difference
from hyperqn_tools.output import final_frame, read_summary

ROPE_DECK = os.path.join(REPO, "tests/decks/hanging_rope.yaml")
BOX_DECK = os.path.join(REPO, "tests/decks/box_on_rope.yaml")
RHO_L, G, L, EA = 0.1, 9.81, 1.0, 50.0  # hanging_rope.yaml
RANKS_TOLERANCE = 1e-8                    # 1 vs 2 ranks, relative to the largest displacement


def rope_profile_error(outdir):
    """Max |u - u_exact| over the rope's vertices, relative to the largest exact u."""
    frame = final_frame(outdir)
    s = -(frame.points - frame.displacement)[:, 1]  # arc length from the top
    exact = RHO_L * G * (L * s - s**2 / 2) / EA
    assert np.abs(frame.displacement[:, [0, 2]]).max() < 1e-12, "a vertical rope must not sway"
    return np.abs(-frame.displacement[:, 1] - exact).max() / exact.max()


@pytest.mark.parametrize("solver,ranks", [("lbfgs", 1), ("lbfgs", 2), ("newton", 1), ("pd", 1)])
def test_hanging_rope_profile(tmp_path, solver, ranks):
    deck = load_deck(ROPE_DECK)
    deck["solver"]["type"] = solver
    outdir = tmp_path / "out"
    run_hyperqn([write_deck(tmp_path / "rope.yaml", deck), "-o", outdir], ranks=ranks)
    summary = read_summary(outdir)
    assert summary["status"] == "ok" and summary["tets"] == 0 and summary["segments"] == 20
    assert rope_profile_error(outdir) < 1e-6


def test_strand_laplacian_weight_override(tmp_path):
    """L built with another stiffness than EA: pd is no longer exact and says so; lbfgs still
    converges to the same static profile."""
    deck = load_deck(ROPE_DECK)
    deck["strand_material"]["laplacian_weight"] = 2 * EA
    for solver in ("pd", "lbfgs"):
        deck["solver"]["type"] = solver
        outdir = tmp_path / solver
        proc = run_hyperqn([write_deck(tmp_path / f"{solver}.yaml", deck), "-o", outdir], ranks=1)
        if solver == "pd":
            assert "Projective Dynamics is not exact" in proc.stdout
        assert rope_profile_error(outdir) < 1e-6
    assert read_summary(tmp_path / "lbfgs")["mean_iterations"] > 1  # L is no longer the exact Hessian


def test_rope_from_medit_edges(tmp_path):
    """The rope of hanging_rope.yaml written as a Medit file (Vertices + Edges, no tets)."""
    n = 20
    lines = ["MeshVersionFormatted 2", "Dimension 3", "Vertices", str(n + 1)]
    lines += [f"0 {-i / n!r} 0 0" for i in range(n + 1)]
    lines += ["Edges", str(n)] + [f"{i + 1} {i + 2} 5" for i in range(n)] + ["End"]
    (tmp_path / "rope.mesh").write_text("\n".join(lines) + "\n")
    deck = load_deck(ROPE_DECK)
    deck["mesh"] = {"file": "rope.mesh", "edges": "strands"}
    outdir = tmp_path / "out"
    run_hyperqn([write_deck(tmp_path / "rope.yaml", deck), "-o", outdir], ranks=2)
    assert rope_profile_error(outdir) < 1e-6

    # The same file with a tet too: now the deck needs a material, and says so before any output.
    lines[3] = str(n + 3)
    lines[4 + n + 1:4 + n + 1] = ["1 0 0 0", "0 0 1 0"]
    lines[-1:-1] = ["Tetrahedra", "1", f"1 2 {n + 2} {n + 3} 0"]
    (tmp_path / "rope_tet.mesh").write_text("\n".join(lines) + "\n")
    deck["mesh"]["file"] = "rope_tet.mesh"
    bad_out = tmp_path / "bad"
    proc = run_hyperqn([write_deck(tmp_path / "rope_tet.yaml", deck), "-o", bad_out], ranks=1, check=False)
    assert proc.returncode != 0 and "'material': missing" in proc.stdout and "1 tetrahedra" in proc.stdout
    assert not bad_out.exists()


def test_box_on_rope_static(tmp_path):
    outdir = tmp_path / "out"
    run_hyperqn([BOX_DECK, "-o", outdir], ranks=1)
    assert read_summary(outdir)["status"] == "ok"
    frame = final_frame(outdir)
    rest = frame.points - frame.displacement
    tie = np.flatnonzero(np.all(np.abs(rest - [0.1, 0.2, 0.1]) < 1e-9, axis=1))
    assert len(tie) == 1, "the rope's end must be the cube's vertex, not a copy"
    weight = 1000 * 0.2**3 * 9.81
    drop = (weight * 1.0 + 0.1 * 9.81 * 1.0**2 / 2) / 1.0e4
    assert -frame.displacement[tie[0], 1] == pytest.approx(drop, rel=1e-4)


def test_box_on_rope_ranks_agree(tmp_path):
    """Fixed iteration counts (no tolerance test) so both runs do the same arithmetic; the cube
    starts tilted so that it swings."""
    deck = load_deck(BOX_DECK)
    deck["time"] = {"dt": 1 / 30, "frames": 15}
    deck["solver"] = {"type": "lbfgs", "iterations": 10, "grad_rtol": 0}
    deck["gravity"] = [2.0, -9.81, 0]
    deck["output"] = {"every": 5}
    path = write_deck(tmp_path / "box.yaml", deck)
    runs = {}
    for ranks in (1, 2):
        runs[ranks] = tmp_path / f"np{ranks}"
        run_hyperqn([path, "-o", runs[ranks]], ranks=ranks)
    assert relative_difference(str(runs[1]), str(runs[2]))[0] < RANKS_TOLERANCE
    frame = final_frame(runs[2])
    assert frame.num_cells == 48 + 10 and frame.num_pieces == 2
    assert np.all(np.isfinite(frame.J)) and frame.J.max() > 1.0  # the segments' stretch l / L


def test_pd_is_exact_on_strands(tmp_path):
    """A rope released horizontally: pd (exact for springs) and lbfgs with history 0 and a unit
    step compute the same iterates."""
    deck = load_deck(ROPE_DECK)
    deck["mesh"]["strands"][0]["to"] = [1, 0, 0]
    deck["time"] = {"dt": 1 / 30, "frames": 10}
    deck["output"] = {"every": 10}
    outdirs = {}
    for name, solver in {"pd": {"type": "pd"}, "lbfgs0": {"type": "lbfgs", "history": 0, "line_search": "unit"}}.items():
        deck["solver"] = {**solver, "iterations": 5, "grad_rtol": 0}
        outdirs[name] = tmp_path / name
        proc = run_hyperqn([write_deck(tmp_path / f"{name}.yaml", deck), "-o", outdirs[name]], ranks=1)
        if name == "pd":
            assert "exact local-global steps" in proc.stdout
    assert relative_difference(str(outdirs["pd"]), str(outdirs["lbfgs0"]))[0] < 1e-10


def test_midpoint_makes_no_energy_in_a_stiff_strand(tmp_path):
    """/tmp/probe-3/strand_mid.yaml: a 10-segment strand between two supports, one moved in and up by a table curve
    then held, implicit midpoint at h = 0.05 s (h sqrt(k/m) ~ 10): 29 J of kinetic and stored energy from 0.86 J
    of the supports' work, with 1 step completed by Euler (a reversed segment). The springs' energy test
    (docs/method.md#time-integrators) ends every step that would make energy by Euler: energy.csv's residual stays
    below a tenth of the work."""
    deck = {
        "mesh": {"strands": [{"from": [0, 0, 0], "to": [1, 0, 0], "segments": 10}]},
        "strand_material": {"axial_stiffness": 100.0, "linear_density": 0.1},
        "fixed": [{"box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 0.01, 0.01]}},
                  {"box": {"min": [0.99, -0.01, -0.01], "max": [1.01, 0.01, 0.01]},
                   "motion": {"translate": {"velocity": [-0.2, 0.3, 0.05]},
                              "curve": {"type": "table", "points": [[0, 0], [0.5, 1], [1.0, 0.2]]}}}],
        "gravity": [0, -9.81, 0],
        "time": {"dt": 0.05, "frames": 30, "integrator": "implicit-midpoint"},
        "solver": {"type": "newton", "iterations": 100, "grad_rtol": 1.0e-10},
        "output": {"every": 30, "energy": True},
    }
    outdir = tmp_path / "out"
    run_hyperqn([write_deck(tmp_path / "strand.yaml", deck), "-o", outdir])
    s = read_summary(outdir)
    with open(outdir / "energy.csv") as f:
        header = f.readline().strip().split(",")
        rows = np.array([[float(c) for c in line.split(",")] for line in f if line.strip()])
    e = {name: rows[:, k] for k, name in enumerate(header)}
    work = np.abs(e["support_work"]).max() + np.abs(e["gravity_work"]).max()
    print(f"strand: euler_completed_steps {s['euler_completed_steps']}, largest residual {e['residual'].max():.3e} J, "
          f"work {work:.3e} J")
    assert s["status"] == "ok" and s["euler_completed_steps"] > 1
    assert e["residual"].max() <= 0.1 * work
