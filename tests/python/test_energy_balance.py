"""The energy balance per frame (output.energy, energy.csv; docs/inelastic.md#energy-balance) and the
implicit midpoint with inelastic materials (docs/inelastic.md#the-midpoint).

- Undamped midpoint runs of a cantilever released under gravity, elastic, viscoelastic and plastic
  (yielding at its root), each step solved by Newton to round-off: kinetic + stored + dissipated
  stays within 1e-3 of the work of gravity (the residual over the run's largest energy or work).
- The elastic cantilever's kinetic, stored and gravity columns against the frames' positions and
  velocities (hyperqn_tools.energy, Neo-Hookean), and a bar whose clamp moves at a constant
  velocity under a traction on a ramp: the loads' and the support's work close the balance too; a
  body force, and a force whose box holds the clamp, alone (the balance's load terms as the solve's).
- A bar whose clamp (or roller end) moves on a sine, at two steps and 1 and 2 ranks: the residual stays
  within 1e-6 of the scale (the midpoint's z holds a moving support on its chord, not at p(t_n + h/2)).
- Dissipation is never negative: no tet's dissipated_energy falls from one frame (one step) to the
  next, and the plastic bar's root dissipates.
- 1 and 2 ranks write the same energy.csv to round-off; a restart of the plastic bar from a frame
  in the middle of its flow writes the same energy.csv and ends at the same positions, bit for bit.
- The midpoint's stabilized steps (completed by Euler) and the fallback chain's sub-steps with a
  viscoelastic material, from the stability suite's inverted start: dissipation never falls, a
  restart is bitwise.
- Bad input: output.energy not a boolean, and output.energy with a collider: the deck line named,
  exit 1, nothing written.
"""
import copy

import numpy as np
import pytest

from conftest import load_deck, run_deck, run_hyperqn, write_deck
from hyperqn_tools.energy import neohookean_energies
from hyperqn_tools.output import final_frame, frame_list, frame_meshes
from test_bad_input import assert_deck_refused

E, NU, RHO, G = 1.0e8, 0.3, 1000.0, 9.81
DT, FRAMES = 4.0e-3, 60  # about 50 steps per period of the first bending mode, 1.2 periods
COLUMNS = ["frame", "time", "kinetic", "stored", "dissipated", "released", "gravity_work", "load_work",
           "support_work", "residual"]
NEWTON = {"type": "newton", "iterations": 40, "budget": "fixed", "grad_rtol": 1e-11, "grad_atol": 0}
ELASTIC = {"model": "neohookean", "youngs_modulus": E, "poisson_ratio": NU, "density": RHO}
VISCOELASTIC = dict(ELASTIC, viscoelastic={"branches": [{"g": 0.3, "tau": 0.02}, {"g": 0.1, "tau": 0.2}]})
# Yields near the root in the first swing (dissipating about half of gravity's work).
PLASTIC = {"model": "hencky", "youngs_modulus": E, "poisson_ratio": NU, "density": RHO,
           "plastic": {"yield_stress": 5.0e4, "isotropic_hardening": 1.0e7, "kinematic_hardening": 5.0e6}}


def cantilever(material, frames=FRAMES, fields=()):
    return {
        "mesh": {"box": {"size": [1.0, 0.1, 0.1], "cells": [10, 1, 1]}},
        "material": material,
        "fixed": [{"box": {"min": [-0.001, -0.001, -0.001], "max": [0.001, 0.101, 0.101]}}],
        "gravity": [0, -G, 0],
        "time": {"dt": DT, "frames": frames, "integrator": "implicit-midpoint"},
        "solver": NEWTON,
        "output": dict({"every": 1, "energy": True}, **({"fields": list(fields)} if fields else {})),
    }


def read_energy(outdir):
    with open(outdir / "energy.csv") as f:
        header = f.readline().strip().split(",")
        rows = np.array([[float(c) for c in line.split(",")] for line in f if line.strip()])
    assert header == COLUMNS
    return {name: rows[:, k] for k, name in enumerate(header)}


def relative_residual(e):
    """The largest |residual| over the run's largest energy or work."""
    scale = max(np.abs(e[k]).max() for k in COLUMNS[2:9])
    return np.abs(e["residual"]).max() / scale


def dissipation_per_frame(outdir):
    """Each frame's dissipated_energy per tet (1 rank: one piece)."""
    out = []
    for _, _, path in frame_list(outdir):
        (m,) = frame_meshes(path)
        out.append(np.concatenate([np.asarray(m.cell_data["dissipated_energy"][b]) for b in range(len(m.cells))]))
    return np.array(out)


@pytest.mark.parametrize("name,material", [("elastic", ELASTIC), ("viscoelastic", VISCOELASTIC), ("plastic", PLASTIC)])
def test_midpoint_balance_closes(tmp_path, name, material):
    fields = () if name == "elastic" else ("dissipated_energy",)
    out, summary = run_deck(tmp_path, name, cantilever(material, fields=fields))
    assert summary["substepped_frames"] == 0 and summary["euler_completed_steps"] == 0
    e = read_energy(out)
    assert list(e["frame"]) == list(range(FRAMES + 1))
    assert e["residual"][0] == 0 and e["gravity_work"][0] == 0
    assert e["load_work"].max() == 0 and np.abs(e["support_work"]).max() == 0  # a clamp at rest does no work
    assert not e["released"].any()  # nothing changes the topology
    measured = relative_residual(e)
    print(f"{name}: |K + S + D - W| / scale at most {measured:.3e}; gravity's work at the end {e['gravity_work'][-1]:.4e} J, "
          f"dissipated {e['dissipated'][-1]:.4e} J")
    assert measured <= 1e-3
    if name == "elastic":
        assert e["dissipated"].max() == 0
        for frame, _, path in frame_list(out):  # the columns against the frames' own fields
            kinetic, stored, gravity = neohookean_energies(path, E, NU, RHO, G)
            assert abs(e["kinetic"][frame] - kinetic) <= 1e-9 * e["gravity_work"].max()
            assert abs(e["stored"][frame] - stored) <= 1e-9 * e["gravity_work"].max()
            assert abs(e["gravity_work"][frame] + gravity) <= 1e-9 * e["gravity_work"].max()
    else:
        D = dissipation_per_frame(out)
        assert np.all(np.diff(D, axis=0) >= 0), "a tet's dissipated energy fell in a step"
        assert e["dissipated"][-1] > 1e-3 * e["gravity_work"].max()  # it does dissipate
        # The summary's total is the last row's.
        assert summary["dissipated_energy"] == e["dissipated"][-1]


def test_loads_and_moving_support_close_the_balance(tmp_path):
    """No gravity; the clamp moves at a constant velocity, a traction on the free end ramps up, an open
    pressure on the top face (normals of each step's start) and a force on the free vertices follow
    sines."""
    deck = cantilever(ELASTIC)
    deck["gravity"] = [0, 0, 0]
    deck["fixed"][0]["motion"] = {"translate": {"velocity": [0, 0.05, 0.02]}}
    deck["loads"] = [{"type": "traction", "box": {"min": [0.999, -1, -1], "max": [1.001, 1, 1]},
                      "traction": [0, -2.0e4, 1.0e4], "curve": {"type": "ramp", "end": 0.1}},
                     {"type": "pressure", "box": {"min": [0.4, 0.099, -1], "max": [1.001, 0.101, 1]}, "normal": [0, 1, 0],
                      "pressure": 2.0e3, "curve": {"type": "sine", "amplitude": 1, "frequency": 14}},
                     {"type": "force", "box": {"min": [0.5, -1, -1], "max": [0.9, 1, 1]}, "force": [30, 0, -20],
                      "curve": {"type": "sine", "amplitude": 1, "frequency": 20}}]
    out, _ = run_deck(tmp_path, "loads", deck)
    e = read_energy(out)
    assert e["gravity_work"].max() == 0
    assert np.abs(e["load_work"]).max() > 0 and np.abs(e["support_work"]).max() > 0
    measured = relative_residual(e)
    print(f"loads and a moving clamp: |K + S - W| / scale at most {measured:.3e}; load work {e['load_work'][-1]:.4e} J, "
          f"support work {e['support_work'][-1]:.4e} J")
    assert measured <= 1e-3


@pytest.mark.parametrize("load", [
    # a body force acts through the masses (EnergyTerm::set_masses), which the balance's own terms must take too
    {"type": "body_force", "box": {"min": [-1, -1, -1], "max": [2, 2, 2]}, "acceleration": [0, -4.0, 2.0]},
    # a force's box that holds the clamp: the clamped vertices take no share of it in the balance either
    {"type": "force", "box": {"min": [-1, -1, -1], "max": [2, 2, 2]}, "force": [0, -60, 20]}])
def test_vertex_loads_over_the_clamp_close_the_balance(tmp_path, load):
    deck = cantilever(ELASTIC)
    deck["gravity"] = [0, 0, 0]
    deck["loads"] = [load]
    out, _ = run_deck(tmp_path, load["type"], deck)
    e = read_energy(out)
    assert e["load_work"].max() > 0
    measured = relative_residual(e)
    print(f"{load['type']} over the whole cantilever: |K + S - W| / scale at most {measured:.3e}; "
          f"load work {e['load_work'][-1]:.4e} J")
    assert measured <= 1e-3


def sine_driven_bar(dt, support):
    """A 2 x 0.5 x 0.5 corotated bar (E = 1e6), no gravity, one end held, the other's support moving
    along x on a sine (0.5 mm/s peak, 10 Hz): a clamp, or rollers on three faces and a roller end."""
    moving = {"box": {"min": [1.99, -1, -1], "max": [2.01, 2, 2]},
              "motion": {"translate": {"velocity": [0.0005, 0, 0]}, "curve": {"type": "sine", "amplitude": 1, "frequency": 10}}}
    if support == "clamp":
        fixed = [{"box": {"min": [-0.01, -1, -1], "max": [0.01, 2, 2]}}, moving]
    else:
        fixed = [{"box": {"min": [-0.01, -1, -1], "max": [0.01, 2, 2]}, "components": ["x"]},
                 {"box": {"min": [-1, -0.01, -1], "max": [3, 0.01, 2]}, "components": ["y"]},
                 {"box": {"min": [-1, -1, -0.01], "max": [3, 2, 0.01]}, "components": ["z"]},
                 dict(moving, components=["x"])]
    return {
        "mesh": {"box": {"size": [2.0, 0.5, 0.5], "cells": [4, 2, 2]}},
        "material": {"model": "corotated", "youngs_modulus": 1.0e6, "poisson_ratio": 0.3, "density": 1000},
        "fixed": fixed,
        "gravity": [0, 0, 0],
        "time": {"dt": dt, "frames": round(0.1 / dt), "integrator": "implicit-midpoint"},
        "solver": {"type": "newton", "iterations": 100, "grad_rtol": 1e-12},
        "output": {"every": 10, "energy": True, "vtk": False},
    }


@pytest.mark.parametrize("support,dt,ranks", [("clamp", 0.002, 1), ("clamp", 0.001, 1), ("clamp", 0.002, 2),
                                              ("roller", 0.002, 2)])
def test_support_on_a_sine_closes_the_balance(tmp_path, support, dt, ranks):
    """The midpoint's z holds every vertex at (x_n + x_{n+1}) / 2, a moving support's too (on its chord,
    not at p(t_n + h/2), which is off it by h^2 p''/8): at strains of 1e-4 (a quadratic energy) the
    balance closes to the solves' tolerance, as with a support at a constant velocity."""
    out, _ = run_deck(tmp_path, f"{support}_{dt}", sine_driven_bar(dt, support), ranks=ranks)
    e = read_energy(out)
    assert np.abs(e["support_work"]).max() > 0.1  # the support does the work: 0.32 J at the sine's crest
    measured = relative_residual(e)
    print(f"{support}, h = {dt}, {ranks} rank(s): |K + S - W| / scale at most {measured:.3e}; "
          f"support work at most {np.abs(e['support_work']).max():.4e} J")
    assert measured <= 1e-6


def test_two_ranks_and_restart(tmp_path):
    deck = cantilever(PLASTIC, frames=30)
    one, _ = run_deck(tmp_path, "np1", deck)
    two, _ = run_deck(tmp_path, "np2", deck, ranks=2)
    a, b = read_energy(one), read_energy(two)
    scale = max(np.abs(a[k]).max() for k in COLUMNS[2:9])
    diff = max(np.abs(a[k] - b[k]).max() for k in COLUMNS[2:])
    print(f"1 vs 2 ranks: energy.csv differs by {diff / scale:.2e} of its scale")
    assert diff <= 1e-9 * scale
    assert a["dissipated"][15] > 0 and a["dissipated"][-1] > a["dissipated"][15]  # frame 15 is mid-flow
    restarted = tmp_path / "restarted"
    first = dict(deck, time=dict(deck["time"], frames=15), checkpoint={"every": 15})
    run_hyperqn([write_deck(tmp_path / "first.yaml", first), "-o", restarted], ranks=1)
    done = run_hyperqn([write_deck(tmp_path / "then.yaml", deck), "-o", restarted, "--restart", "latest"], ranks=1)
    assert "restart from" in done.stdout
    assert np.array_equal(final_frame(one).points, final_frame(restarted).points)
    assert (one / "energy.csv").read_bytes() == (restarted / "energy.csv").read_bytes()


def test_euler_completed_and_substepped_steps(tmp_path):
    """The stability suite's inverted start with a Maxwell branch, midpoint, 20 frames of lbfgs: some
    steps end by the stabilization's second Euler half step (their history from z on) and some frames
    in sub-steps; no tet's dissipation falls, and a restart from frame 10 is bitwise."""
    deck = load_deck("input/stability/initial_invert.yaml")
    deck["material"]["viscoelastic"] = {"branches": [{"g": 0.3, "tau": 0.05}]}
    deck["time"] = dict(deck["time"], integrator="implicit-midpoint", frames=20)
    deck["time"].pop("damping", None)
    deck["output"] = {"every": 1, "fields": ["dissipated_energy"]}
    out, summary = run_deck(tmp_path, "invert", deck)
    print(f"euler_completed_steps {summary['euler_completed_steps']}, substepped_frames {summary['substepped_frames']}")
    assert summary["euler_completed_steps"] > 0 and summary["substepped_frames"] > 0
    assert np.all(np.diff(dissipation_per_frame(out), axis=0) >= 0)
    restarted = tmp_path / "restarted"
    first = dict(deck, time=dict(deck["time"], frames=10), checkpoint={"every": 10})
    run_hyperqn([write_deck(tmp_path / "first.yaml", first), "-o", restarted], ranks=None)
    run_hyperqn([write_deck(tmp_path / "then.yaml", deck), "-o", restarted, "--restart", "latest"], ranks=None)
    assert np.array_equal(final_frame(out).points, final_frame(restarted).points)


def bad(**changes):
    deck = cantilever(ELASTIC, frames=2)
    deck.update(copy.deepcopy(changes))
    return deck


BAD = {
    "not_boolean": (bad(output={"energy": "sometimes"}), ["output.energy"]),
    "with_collider": (bad(time={"dt": DT, "frames": 2},
                          colliders=[{"type": "plane", "point": [0, -0.5, 0], "normal": [0, 1, 0]}]),
                      ["output.energy", "colliders"]),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_input(tmp_path, case):
    deck, fragments = BAD[case]
    assert_deck_refused(tmp_path, case, deck, fragments)


def test_the_frames_energies_at_two_ranks_are_the_energy_csv_s(tmp_path):
    # hyperqn_tools.energy reads a frame of several pieces (a .pvtu of 2 ranks) merged
    out, _ = run_deck(tmp_path, "two", cantilever(ELASTIC, frames=3), ranks=2)
    e = read_energy(out)
    for frame, _, path in frame_list(out):
        kinetic, stored, gravity = neohookean_energies(path, E, NU, RHO, G)
        assert abs(e["stored"][frame] - stored) <= 1e-9 * e["gravity_work"].max()
        assert abs(e["kinetic"][frame] - kinetic) <= 1e-9 * e["gravity_work"].max()
