"""The Prony series of stress histories (material.viscoelastic_prony, docs/viscoelastic-prony.md), end to end.

- Relaxation in simple shear through the solver: test_viscoelastic.py's block, whose boundary vertices
  follow u = gamma0 y e_x (a ramp over the first static load step, then held), with one branch
  (g = 0.3, tau = 0.1) over Neo-Hookean. The whole stress relaxes: sigma_xy = mu gamma0 (1 + gt
  (tau/dt)(1 - e^{-dt/tau}) e^{-(t - dt)/tau}), gt = g / (1 - g), the closed form of that ramp (the
  update is exact for S0 linear in time): to the solver's tolerance. Against the jump at t = 0,
  mu gamma0 (1 + gt e^{-t/tau}): first order in dt. Newton gives the same.
- Through real solves, the clamped bar of test_viscoelastic.py: with tau = 1e5 dt the bar answers as
  Neo-Hookean with the instantaneous mu/(1 - g) and lambda/(1 - g) (both relax here); with tau = dt/100
  as the equilibrium material; lbfgs and Newton agree in between.
- 1 and 2 ranks agree; a restart from frame 40 of 60 is bit for bit at 1 rank, within 1e-12 at 2.
- The dissipated energy never falls in any tet, and the summary's total is the field's sum.
- The midpoint: the cantilever of test_energy_balance.py balances kinetic + stored + dissipated against gravity's
  work to first order in h (small strain); the inverted start with steps completed by Euler and frames in sub-steps, no tet's
  dissipation falling and a restart bitwise.
- A study keeps each trajectory's history (test_viscoelastic.py's twisted bar): the step values
  derived once per step from the history are not another trajectory's (ElementState::revision).
- Bad input: tau <= 0, g <= 0, sum g >= 1, 5 branches, none, a model without elastic constants, both
  viscoelastic blocks: the deck line named, exit 1, nothing written.
"""
import copy
import json
import math

import numpy as np
import pytest

from conftest import load_deck, run_deck, run_hyperqn, twisted_bar_study, write_deck
from hyperqn_tools.output import final_frame, frame_list, frame_meshes
import test_energy_balance as eb
from test_bad_input import assert_deck_refused
from test_viscoelastic import GAMMA, LAMBDA, MU, bar_deck, pull, shear_deck, shear_stresses

G, TAU = 0.3, 0.1
GT = G / (1 - G)
DT = TAU / 20
PRONY = {"branches": [{"g": G, "tau": TAU}]}


def prony_material(branches=None, **over):
    m = {"model": "neohookean", "mu": MU, "lambda": LAMBDA, "density": 1000,
         "viscoelastic_prony": {"branches": branches or PRONY["branches"]}}
    m.update(over)
    return m


def prony_shear_deck(frames=100, every=1, dt=DT):
    deck = shear_deck(frames=frames, every=every, dt=dt)
    deck["material"] = prony_material()
    return deck


def ramp_closed(t, dt):
    return GAMMA * MU * (1 + GT * (TAU / dt) * -math.expm1(-dt / TAU) * math.exp(-(t - dt) / TAU))


def relaxation_errors(tmp_path, name, dt, solver=None):
    frames = int(round(5 * TAU / dt))
    deck = prony_shear_deck(frames=frames, dt=dt)
    if solver:
        deck["solver"] = solver
    out, summary = run_deck(tmp_path, name, deck)
    stresses = shear_stresses(out)[1:]
    assert len(stresses) == frames
    ramp, jump, spread = 0.0, 0.0, 0.0
    for n, (t, s) in enumerate(stresses, start=1):
        assert abs(t - n * dt) < 1e-12
        closed = GAMMA * MU * (1 + GT * math.exp(-t / TAU))
        spread = max(spread, (s.max() - s.min()) / closed)
        ramp = max(ramp, abs(s.mean() / ramp_closed(t, dt) - 1))
        jump = max(jump, abs(s.mean() / closed - 1))
    return ramp, jump, spread, summary


def test_relaxation_in_simple_shear(tmp_path):
    ramp, jump, spread, _ = relaxation_errors(tmp_path, "tau20", DT)
    ramp40, jump40, _, _ = relaxation_errors(tmp_path, "tau40", DT / 2)
    order = math.log2(jump / jump40)
    print(f"prony relaxation in shear: against the ramp's closed form {max(ramp, ramp40):.2e}; against the jump "
          f"{jump:.3e} (tau/20), {jump40:.3e} (tau/40), order {order:.2f}; spread over the tets {spread:.1e}")
    assert spread < 1e-6
    assert max(ramp, ramp40) <= 1e-6
    assert jump40 <= 5e-3
    assert abs(order - 1) < 0.1


def test_newton(tmp_path):
    ramp, _, _, summary = relaxation_errors(tmp_path, "newton", DT,
                                           solver={"type": "newton", "iterations": 50, "grad_rtol": 1e-11})
    print(f"prony, newton: against the ramp's closed form {ramp:.2e}, {summary['iterations']} iterations in 100 steps")
    assert ramp <= 1e-6
    assert summary["iterations"] <= 100 * 5


def test_instantaneous_and_relaxed_limits_through_the_solver(tmp_path):
    elastic = {"model": "neohookean", "mu": MU, "lambda": LAMBDA}
    instantaneous = {"model": "neohookean", "mu": MU / (1 - G), "lambda": LAMBDA / (1 - G)}

    def visco(tau):
        return dict(elastic, viscoelastic_prony={"branches": [{"g": G, "tau": tau}]})

    r_inf = pull(tmp_path, "relaxed_elastic", elastic, 4)[-1]
    r_0 = pull(tmp_path, "instant_elastic", instantaneous, 1)[-1]
    v_0 = pull(tmp_path, "instant_visco", visco(1e5), 1)[-1]
    v_inf = pull(tmp_path, "relaxed_visco", visco(0.01), 4)[-1]
    print(f"prony bar: instantaneous {v_0:.6e} against {r_0:.6e} ({abs(v_0 / r_0 - 1):.2e}); relaxed {v_inf:.6e} "
          f"against {r_inf:.6e} ({abs(v_inf / r_inf - 1):.2e})")
    # Neo-Hookean's stress is linear in its moduli: (1 + gt) psi is Neo-Hookean with both scaled,
    # up to the step's (1 - e^{-x})/x = 1 - 5e-6 and the log's extension.
    assert abs(v_0 / r_0 - 1) <= 1e-4
    assert abs(v_inf / r_inf - 1) <= 1e-6
    lb = pull(tmp_path, "lbfgs", visco(20), 10)
    nt = pull(tmp_path, "newton", visco(20), 10, solver="newton")
    print(f"prony bar, lbfgs against newton over 10 steps: {np.max(np.abs(lb / nt - 1)):.2e}")
    assert np.all(np.diff(lb[1:]) < 0)  # relaxes
    assert np.max(np.abs(lb / nt - 1)) <= 1e-6


def test_two_ranks_and_restart(tmp_path):
    deck = prony_shear_deck(frames=60, every=20)
    one, _ = run_deck(tmp_path, "np1", deck)
    two, _ = run_deck(tmp_path, "np2", deck, ranks=2)
    a, b = shear_stresses(one), shear_stresses(two)
    worst = max(abs(sa.mean() - sb.mean()) / abs(sa.mean()) for (_, sa), (_, sb) in zip(a[1:], b[1:]))
    print(f"prony, 1 against 2 ranks: {worst:.1e}")
    assert worst <= 1e-9
    restarted = tmp_path / "restarted"
    first = dict(deck, time=dict(deck["time"], frames=40), checkpoint={"every": 40})
    run_hyperqn([write_deck(tmp_path / "first.yaml", first), "-o", restarted], ranks=1)
    done = run_hyperqn([write_deck(tmp_path / "then.yaml", deck), "-o", restarted, "--restart", "latest"], ranks=1)
    assert "restart from" in done.stdout
    assert np.array_equal(final_frame(one).points, final_frame(restarted).points)
    sa, sb = shear_stresses(one)[-1][1], shear_stresses(restarted)[-1][1]
    assert np.array_equal(np.sort(sa), np.sort(sb)), "the restarted stresses bit for bit"
    restarted2 = tmp_path / "restarted2"
    run_hyperqn([write_deck(tmp_path / "first2.yaml", first), "-o", restarted2], ranks=2)
    run_hyperqn([write_deck(tmp_path / "then2.yaml", deck), "-o", restarted2, "--restart", "latest"], ranks=2)
    s2, r2 = shear_stresses(two)[-1][1], shear_stresses(restarted2)[-1][1]
    assert np.max(np.abs(np.sort(s2) - np.sort(r2))) <= 1e-12 * np.max(np.abs(s2))


def test_dissipation_never_falls(tmp_path):
    """A bar pulled and pushed over one cycle of a sine (20 static steps of tau/2): every tet's dissipated energy grows or
    stays, and summary.json's total is the field's sum (times the tets' volumes)."""
    deck = bar_deck(prony_material(), 20)
    deck["fixed"][1]["motion"] = {"translate": {"velocity": [1e-3, 0, 0]},
                                  "curve": {"type": "sine", "amplitude": 1.0, "frequency": 10.0}}
    deck["time"]["dt"] = 0.5 * TAU
    deck["output"] = {"every": 1, "fields": ["dissipated_energy"]}
    out, summary = run_deck(tmp_path, "dissipation", deck)
    previous = None
    for _, _, path in frame_list(out):
        d = np.concatenate([m.cell_data["dissipated_energy"][b] for m in frame_meshes(path) for b in range(len(m.cells))])
        assert np.all(d >= 0)
        if previous is not None:
            assert np.all(d >= previous)
        previous = d
    assert previous.max() > 0
    assert summary["dissipated_energy"] > 0


VISCO = {"model": "neohookean", "mu": MU, "lambda": LAMBDA, "density": 1000}


def bad(material):
    deck = copy.deepcopy(prony_shear_deck(frames=2))
    deck["material"] = material
    return deck


BAD = {
    "tau_zero": (bad(dict(VISCO, viscoelastic_prony={"branches": [{"g": 0.3, "tau": 0}]})),
                 ["viscoelastic_prony.branches[0].tau", "must be > 0"]),
    "g_negative": (bad(dict(VISCO, viscoelastic_prony={"branches": [{"g": -0.1, "tau": 1}]})),
                   ["viscoelastic_prony.branches[0].g", "must be > 0"]),
    "sum_g_one": (bad(dict(VISCO, viscoelastic_prony={"branches": [{"g": 0.5, "tau": 1}, {"g": 0.5, "tau": 2}]})),
                  ["viscoelastic_prony.branches", "sum to 1"]),
    "five_branches": (bad(dict(VISCO, viscoelastic_prony={"branches": [{"g": 0.1, "tau": k + 1} for k in range(5)]})),
                      ["viscoelastic_prony.branches", "1 to 4 branches, got 5"]),
    "no_branches": (bad(dict(VISCO, viscoelastic_prony={})), ["branches"]),
    "principal_stretch": (bad({"model": "principal-stretch", "f": {"polynomial": [0, 0, 1]}, "density": 1000,
                               "viscoelastic_prony": PRONY}), ["viscoelastic_prony"]),
    "both_blocks": (bad(dict(VISCO, viscoelastic=PRONY, viscoelastic_prony=PRONY)), ["one inelastic block"]),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_input(tmp_path, case):
    deck, fragments = BAD[case]
    assert_deck_refused(tmp_path, case, deck, fragments)


def test_midpoint_energy_balance(tmp_path):
    """test_energy_balance.py's undamped midpoint cantilever under gravity (small strain) with the same two
    branches as Prony's (h/tau_min = 0.2): kinetic + stored + dissipated against gravity's work. The residual
    over the run's scale is first order in h for this model (the Maxwell branches' is 7.8e-7 here): within
    1e-2 at h and at least 1.5 times smaller at h/2. No tet's dissipation falls; the summary's total is
    energy.csv's."""
    material = dict(eb.ELASTIC, viscoelastic_prony=eb.VISCOELASTIC["viscoelastic"])
    measured = []
    for k in (1, 2):
        deck = eb.cantilever(material, frames=eb.FRAMES * k, fields=("dissipated_energy",))
        deck["time"]["dt"] = eb.DT / k
        out, summary = run_deck(tmp_path, f"balance{k}", deck)
        assert summary["substepped_frames"] == 0 and summary["euler_completed_steps"] == 0
        e = eb.read_energy(out)
        measured.append(eb.relative_residual(e))
        assert np.all(np.diff(eb.dissipation_per_frame(out), axis=0) >= 0)
        assert e["dissipated"][-1] > 1e-3 * e["gravity_work"].max()
        assert summary["dissipated_energy"] == e["dissipated"][-1]
    print(f"prony, midpoint cantilever: |K + S + D - W| / scale at most {measured[0]:.3e} (h), {measured[1]:.3e} (h/2); "
          f"dissipated {e['dissipated'][-1] / e['gravity_work'][-1]:.3f} of gravity's work")
    assert measured[0] <= 1e-2
    assert measured[1] <= measured[0] / 1.5


def test_euler_completed_and_substepped_steps(tmp_path):
    """test_energy_balance.py's inverted start (the stability suite's) with a Prony branch, midpoint, 20 frames
    of lbfgs: steps completed by Euler's second half step (the history from z on: advance) and frames in
    sub-steps (begin_substep), each moving the step values' key; no tet's dissipation falls, and a restart
    from frame 10 is bitwise."""
    deck = load_deck("input/stability/initial_invert.yaml")
    deck["material"]["viscoelastic_prony"] = {"branches": [{"g": 0.3, "tau": 0.05}]}
    deck["time"] = dict(deck["time"], integrator="implicit-midpoint", frames=20)
    deck["time"].pop("damping", None)
    deck["output"] = {"every": 1, "fields": ["dissipated_energy"]}
    out, summary = run_deck(tmp_path, "invert", deck)
    print(f"prony: euler_completed_steps {summary['euler_completed_steps']}, substepped_frames "
          f"{summary['substepped_frames']}")
    assert summary["euler_completed_steps"] > 0 and summary["substepped_frames"] > 0
    assert np.all(np.diff(eb.dissipation_per_frame(out), axis=0) >= 0)
    restarted = tmp_path / "restarted"
    first = dict(deck, time=dict(deck["time"], frames=10), checkpoint={"every": 10})
    run_hyperqn([write_deck(tmp_path / "first.yaml", first), "-o", restarted], ranks=None)
    run_hyperqn([write_deck(tmp_path / "then.yaml", deck), "-o", restarted, "--restart", "latest"], ranks=None)
    assert np.array_equal(final_frame(out).points, final_frame(restarted).points)


def test_study_keeps_each_trajectory_history(tmp_path):
    """The lbfgs trajectory's RMS distance to the converged reference equals the distance between two
    plain runs: the trajectories' step values (the Prony stress histories' per-step part) are each
    their own. They were shared by revision number: 14-78 % off from frame 2 on."""
    worst = twisted_bar_study(tmp_path, {"model": "neohookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3,
                                         "density": 1000,
                                         "viscoelastic_prony": {"branches": [{"g": 0.5, "tau": 0.05}, {"g": 0.2, "tau": 0.5}]}},
                              1)
    print(f"study of a prony deck: lbfgs trajectory against two plain runs, worst relative difference {worst:.1e}")
    assert worst <= 1e-6


def rollers_cube(amplitude):
    """/tmp/probe-3/prony_mid.yaml: the 2 x 2 x 2 cube on rollers, its top face moved in y by a table curve
    (u = a (0.2, -0.15, 0.25, -0.1, 0, 0.3, 0) at 0.2 s intervals), one branch g 0.3, tau 0.02, midpoint h = 0.05."""
    points = [[0.2 * k, amplitude * u] for k, u in enumerate([0, 0.2, -0.15, 0.25, -0.1, 0, 0.3, 0])]
    return {
        "mesh": {"box": {"size": [1, 1, 1], "cells": [2, 2, 2]}},
        "material": {"model": "neohookean", "mu": 1.0e4, "lambda": 2.0e4, "density": 1000,
                     "viscoelastic_prony": {"branches": [{"g": 0.3, "tau": 0.02}]}},
        "fixed": [{"box": {"min": [-0.01, -0.01, -0.01], "max": [1.01, 0.01, 1.01]}, "components": ["y"]},
                  {"box": {"min": [-0.01, 0.99, -0.01], "max": [1.01, 1.01, 1.01]}, "components": ["x", "y"],
                   "motion": {"translate": {"velocity": [0, 1, 0]}, "curve": {"type": "table", "points": points}}},
                  {"box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 0.01, 0.01]}, "components": ["x", "z"]},
                  {"box": {"min": [0.99, -0.01, -0.01], "max": [1.01, 0.01, 0.01]}, "components": ["z"]}],
        "gravity": [0, 0, 0],
        "time": {"dt": 0.05, "frames": 28, "integrator": "implicit-midpoint"},
        "solver": {"type": "newton", "iterations": 100, "grad_rtol": 1.0e-10},
        "output": {"every": 28, "energy": True},
    }


def test_finite_strain_dissipation_is_flagged(tmp_path):
    """The branches' stored energy and dissipation are small-strain measures (docs/viscoelastic-prony.md#dissipation-and-
    energy): past a strain of a few percent the dissipation reported is not the energy lost. On the rollers cube's
    cycle (min J 0.6 at full amplitude) dissipated + kinetic + stored reached twice the supports' work, and the run
    said ok (the Maxwell twin closes it). summary.json's prony_largest_strain gives the largest |E| the updates saw
    (measured 0.88), and the run warns once where it passes 0.05; at 3 % of the amplitude (0.024) it does not warn."""
    proc = run_hyperqn([write_deck(tmp_path / "large.yaml", rollers_cube(1.0)), "-o", tmp_path / "large"])
    summary = json.loads((tmp_path / "large" / "summary.json").read_text())
    e = eb.read_energy(tmp_path / "large")
    print(f"full amplitude: prony_largest_strain {summary['prony_largest_strain']:.3f}, dissipated {e['dissipated'][-1]:.4g} J "
          f"against the supports' {e['support_work'][-1]:.4g} J")
    assert summary["prony_largest_strain"] > 0.2
    assert proc.stdout.count("WARNING: viscoelastic_prony tets reached a strain") == 1
    small = rollers_cube(0.03)
    proc = run_hyperqn([write_deck(tmp_path / "small.yaml", small), "-o", tmp_path / "small"])
    summary = json.loads((tmp_path / "small" / "summary.json").read_text())
    e = eb.read_energy(tmp_path / "small")
    print(f"amplitude 0.03: prony_largest_strain {summary['prony_largest_strain']:.4f}, residual "
          f"{e['residual'][-1]:.3g} J of the supports' {e['support_work'][-1]:.4g} J")
    assert 0 < summary["prony_largest_strain"] < 0.05
    assert "WARNING: viscoelastic_prony" not in proc.stdout
