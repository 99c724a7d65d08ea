"""Viscoelastic materials (material.viscoelastic, docs/materials.md#viscoelasticity), end to end.

- Standard linear solid, relaxation, in simple shear: a 1 x 1 x 1 block whose boundary vertices all
  follow u = gamma0 y e_x (the bottom face fixed, the top face and each layer's ring of boundary
  vertices clamps that a ramp moves in the first load step and then holds), static load steps of
  dt = tau/20. With every boundary vertex on the affine field the discrete equilibrium is
  homogeneous (linear tets pass the patch test), so every tet's Cauchy shear stress is the
  material's. Neo-Hookean's sigma_xy = mu gamma exactly in simple shear (J = 1) and one branch of
  shear modulus mu_1 = g mu / (1 - g) gives sigma_xy(t) = gamma0 (E_inf + E_1 e^{-t/tau}) with
  E_inf = mu (the deck's, the equilibrium part's) and E_1 = mu_1: within 0.5% over t in (0, 5 tau],
  first order in dt (tau/20 against tau/40), and equal (to the solver's tolerance) to the
  backward-Euler recurrence gamma0 (mu + mu_1 (1 + dt/tau)^-n).
  (The positions stay affine: after the first step the solve has nothing to move.)
- Newton (exact tangent, projected) follows the same recurrence.
- Through real solves, a bar clamped at both ends, its clamp's reaction: a step of 1e-5 tau gives
  the instantaneous moduli's answer, steps of 100 tau the equilibrium material's; lbfgs and Newton
  agree in between.
- The fallback chain's sub-steps move the history per sub-step: a load step solved in 4 sub-steps
  ends bit for bit where load steps of a quarter end.
- The same at 2 ranks (agrees to 1e-9 of the stress); a restart from the checkpoint of frame 40
  (mid-relaxation) ends bit for bit as the uninterrupted run at 1 rank, and within 1e-12 at 2.
- Bad input: tau <= 0, g <= 0, sum g >= 1, 5 branches, no branches, a model without elastic
  constants: the deck line named, exit 1, nothing written (the midpoint takes it:
  test_energy_balance.py).
- A study keeps each trajectory's history apart: its lbfgs trajectory's distance to the converged
  reference equals the distance between two plain runs, through a release's rebuild too.
"""
import copy
import json
import math

import numpy as np
import pytest

from conftest import run_deck, run_hyperqn, twisted_bar_study, write_deck
from hyperqn_tools.output import final_frame, frame_list, frame_meshes, read_reactions, tensors
from test_bad_input import assert_deck_refused

MU, LAMBDA, G, TAU, GAMMA = 1.0e4, 2.0e4, 0.3, 0.1, 1.0e-3
MU1 = G * MU / (1 - G)
DT = TAU / 20
CELLS = [2, 4, 2]
E = 0.01  # half the thickness of a clamp's box


def clamp(lo, hi, y, dt=DT):
    """A fixed region over [lo, hi] (x, z) at height y that a ramp moves by gamma0 y along x in the first step."""
    box = {"min": [lo[0], y - E, lo[1]], "max": [hi[0], y + E, hi[1]]}
    if y == 0:
        return {"box": box}
    return {"box": box, "motion": {"translate": {"velocity": [GAMMA * y, 0, 0]},
                                   "curve": {"type": "ramp", "start": 0, "end": dt}}}


def shear_deck(frames=100, every=1, dt=DT):
    fixed = [clamp((-E, -E), (1 + E, 1 + E), 0.0, dt), clamp((-E, -E), (1 + E, 1 + E), 1.0, dt)]
    for j in range(1, CELLS[1]):  # each inner layer's ring: x = 0 and x = 1 whole, z = 0 and z = 1 between
        y = j / CELLS[1]
        fixed += [clamp((-E, -E), (E, 1 + E), y, dt), clamp((1 - E, -E), (1 + E, 1 + E), y, dt),
                  clamp((2 * E, -E), (1 - 2 * E, E), y, dt), clamp((2 * E, 1 - E), (1 - 2 * E, 1 + E), y, dt)]
    return {
        "name": "relaxation",
        "mesh": {"box": {"size": [1, 1, 1], "cells": CELLS}},
        "material": {"model": "neohookean", "mu": MU, "lambda": LAMBDA, "density": 1000,
                     "viscoelastic": {"branches": [{"g": G, "tau": TAU}]}},
        "fixed": fixed,
        "gravity": [0, 0, 0],
        "time": {"dt": dt, "frames": frames, "integrator": "static"},
        "solver": {"type": "lbfgs", "iterations": 500, "grad_rtol": 1e-11},
        "output": {"every": every, "fields": ["cauchy_stress"]},
    }


def shear_stresses(outdir):
    """[(time, sigma_xy of every tet)] per output frame."""
    out = []
    for _, time, path in frame_list(outdir):
        values = [tensors(m.cell_data["cauchy_stress"][b])[:, 0, 1]
                  for m in frame_meshes(path) for b in range(len(m.cells))]
        out.append((time, np.concatenate(values)))
    return out


def relaxation_errors(tmp_path, name, dt):
    """(worst relative error against the closed form, against the recurrence, spread over the tets)
    over t in (0, 5 tau] in load steps of dt; the first frame's mean stress."""
    frames = int(round(5 * TAU / dt))
    out, _ = run_deck(tmp_path, name, shear_deck(frames=frames, dt=dt))
    stresses = shear_stresses(out)[1:]
    assert len(stresses) == frames
    worst_closed, worst_recurrence, spread = 0.0, 0.0, 0.0
    for n, (t, s) in enumerate(stresses, start=1):
        assert abs(t - n * dt) < 1e-12
        closed = GAMMA * (MU + MU1 * math.exp(-t / TAU))
        recurrence = GAMMA * (MU + MU1 * (1 + dt / TAU) ** -n)
        spread = max(spread, (s.max() - s.min()) / closed)
        worst_closed = max(worst_closed, abs(s.mean() - closed) / closed)
        worst_recurrence = max(worst_recurrence, abs(s.mean() - recurrence) / recurrence)
    return worst_closed, worst_recurrence, spread, stresses[0][1].mean()


def test_relaxation_in_simple_shear(tmp_path):
    closed, recurrence, spread, first = relaxation_errors(tmp_path, "tau20", DT)
    closed40, recurrence40, _, _ = relaxation_errors(tmp_path, "tau40", DT / 2)
    order = math.log2(closed / closed40)
    print(f"relaxation in shear: against the closed form {closed:.3e} (dt = tau/20), {closed40:.3e} (tau/40), "
          f"order {order:.2f}; against backward Euler's recurrence {max(recurrence, recurrence40):.2e}; spread over "
          f"the tets {spread:.1e}")
    assert spread < 1e-6  # homogeneous
    assert closed <= 5e-3
    assert abs(order - 1) < 0.1
    assert max(recurrence, recurrence40) <= 1e-6
    # The first frame holds the instantaneous modulus mu / (1 - g) (relaxed by one step).
    assert first > GAMMA * MU * 1.2


def test_newton(tmp_path):
    """Newton (the exact tangent of the condensed energy, projected to PSD) reaches the same
    recurrence in its few iterations per step."""
    deck = shear_deck(frames=20)
    deck["solver"] = {"type": "newton", "iterations": 50, "grad_rtol": 1e-11}
    out, summary = run_deck(tmp_path, "newton", deck)
    worst = 0.0
    for n, (t, s) in enumerate(shear_stresses(out)[1:], start=1):
        recurrence = GAMMA * (MU + MU1 * (1 + DT / TAU) ** -n)
        worst = max(worst, abs(s.mean() - recurrence) / recurrence)
    print(f"newton: against the recurrence {worst:.2e}, {summary['iterations']} iterations in 20 steps")
    assert worst <= 1e-6
    assert summary["iterations"] <= 20 * 5


def bar_deck(material, frames, solver="lbfgs"):
    """A bar 0.1 x 0.01 x 0.01 clamped at both ends, the far clamp moved by 1e-4 (strain 1e-3) in
    the first load step (dt = 1) and held; the moving clamp's reaction per frame."""
    return {
        "name": "bar",
        "mesh": {"box": {"size": [0.1, 0.01, 0.01], "cells": [10, 2, 2]}},
        "material": dict(material, density=1000),
        "fixed": [{"box": {"min": [-0.001, -0.001, -0.001], "max": [0.001, 0.011, 0.011]}},
                  {"box": {"min": [0.099, -0.001, -0.001], "max": [0.101, 0.011, 0.011]},
                   "motion": {"translate": {"velocity": [1e-4, 0, 0]}, "curve": {"type": "ramp", "start": 0, "end": 1}}}],
        "gravity": [0, 0, 0],
        "time": {"dt": 1, "frames": frames, "integrator": "static"},
        "solver": {"type": solver, "iterations": 2000, "grad_rtol": 1e-10},
        "output": {"every": frames, "reactions": True},
    }


def pull(tmp_path, name, material, frames, solver="lbfgs"):
    out, _ = run_deck(tmp_path, name, bar_deck(material, frames, solver))
    return read_reactions(out)["fixed[1]"]["fx"]


def test_instantaneous_and_relaxed_limits_through_the_solver(tmp_path):
    """A clamped bar (not homogeneous: the clamps hold its ends' contraction), so every step is a
    real solve, and its reaction (output.reactions: the viscoelastic term's stored stress at the
    step's end). Load steps of dt = 1: with tau = 1e5 the bar answers with the instantaneous moduli,
    Neo-Hookean with mu_0 = mu / (1 - g) and the same bulk modulus (lambda_0 = lambda - 2/3 (mu_0 -
    mu)), to the strain's order (the log strain against Neo-Hookean's, 1e-3) and dt/tau; with tau =
    0.01 the branch relaxes to (1 + 100)^-4 of itself in 4 steps, leaving the equilibrium material's
    own answer. lbfgs and Newton agree on the relaxation between (tau = 20: dt = tau/20)."""
    elastic = {"model": "neohookean", "mu": MU, "lambda": LAMBDA}
    mu0 = MU / (1 - G)
    instantaneous = {"model": "neohookean", "mu": mu0, "lambda": LAMBDA - 2 / 3 * (mu0 - MU)}

    def visco(tau):
        return dict(elastic, viscoelastic={"branches": [{"g": G, "tau": tau}]})

    r_inf = pull(tmp_path, "relaxed_elastic", elastic, 4)[-1]
    r_0 = pull(tmp_path, "instant_elastic", instantaneous, 1)[-1]
    v_0 = pull(tmp_path, "instant_visco", visco(1e5), 1)[-1]
    v_inf = pull(tmp_path, "relaxed_visco", visco(0.01), 4)[-1]
    print(f"bar: instantaneous {v_0:.6e} against {r_0:.6e} ({abs(v_0 / r_0 - 1):.2e}); relaxed {v_inf:.6e} "
          f"against {r_inf:.6e} ({abs(v_inf / r_inf - 1):.2e})")
    assert abs(v_0 / r_0 - 1) <= 3e-3
    assert abs(v_inf / r_inf - 1) <= 1e-6
    assert v_0 / r_inf > 1.2  # the two limits are far apart
    lb = pull(tmp_path, "lbfgs", visco(20), 10)
    nt = pull(tmp_path, "newton", visco(20), 10, solver="newton")
    print(f"bar, lbfgs against newton over 10 steps: {np.max(np.abs(lb / nt - 1)):.2e}")
    assert np.all(np.diff(lb[1:]) < 0)  # relaxes
    assert np.max(np.abs(lb / nt - 1)) <= 1e-6


def test_substeps_move_the_history_per_substep(tmp_path):
    """The fallback chain's sub-steps each move the viscous history with their own length: a bar
    stretched by half in one static load step of dt = tau/2, with a budget (10 iterations) that
    the whole step misses, is solved in 4 sub-steps (frame 2 starts at that size), and ends where
    the run of load steps of dt/4 ends, bit for bit (the same solves; a history moved once per
    frame would leave the branch (8/9)^4 / (2/3) - 1 = 6% off)."""
    material = {"model": "neohookean", "mu": MU, "lambda": LAMBDA,
                "viscoelastic": {"branches": [{"g": G, "tau": 2.0}]}}
    deck = bar_deck(material, 2)
    deck["fixed"][1]["motion"]["translate"]["velocity"] = [0.05, 0, 0]
    deck["solver"] = {"type": "lbfgs", "iterations": 10, "max_iterations": 10, "max_halvings": 2,
                      "newton_fallback": False, "grad_rtol": 1e-8}
    deck["output"] = {"every": 1}
    coarse, summary = run_deck(tmp_path, "substeps", deck)
    assert summary["substepped_frames"] == 2
    fine = copy.deepcopy(deck)
    fine["time"] = dict(deck["time"], dt=0.25, frames=8)
    fine_out, fine_summary = run_deck(tmp_path, "fine", fine)
    assert fine_summary["substepped_frames"] == 0
    a, b = final_frame(coarse), final_frame(fine_out)
    assert np.array_equal(a.points, b.points)


def test_two_ranks_and_restart(tmp_path):
    deck = shear_deck(frames=60, every=20)
    one, _ = run_deck(tmp_path, "np1", deck)
    two, _ = run_deck(tmp_path, "np2", deck, ranks=2)
    a, b = shear_stresses(one), shear_stresses(two)
    for (_, sa), (_, sb) in zip(a, b):
        assert abs(sa.mean() - sb.mean()) <= 1e-9 * abs(sa.mean())
    restarted = tmp_path / "restarted"
    first = dict(deck, time=dict(deck["time"], frames=40), checkpoint={"every": 40})
    run_hyperqn([write_deck(tmp_path / "first.yaml", first), "-o", restarted], ranks=1)
    done = run_hyperqn([write_deck(tmp_path / "then.yaml", deck), "-o", restarted, "--restart", "latest"], ranks=1)
    assert "restart from" in done.stdout
    fa, fb = final_frame(one), final_frame(restarted)
    assert np.array_equal(fa.points, fb.points)
    sa, sb = shear_stresses(one)[-1][1], shear_stresses(restarted)[-1][1]
    assert np.array_equal(np.sort(sa), np.sort(sb)), "the restarted stresses bit for bit"
    # At 2 ranks (whose runs agree to round-off run to run, scripts/compare_revisions.py), to 1e-12.
    restarted2 = tmp_path / "restarted2"
    run_hyperqn([write_deck(tmp_path / "first2.yaml", first), "-o", restarted2], ranks=2)
    run_hyperqn([write_deck(tmp_path / "then2.yaml", deck), "-o", restarted2, "--restart", "latest"], ranks=2)
    s2, r2 = shear_stresses(two)[-1][1], shear_stresses(restarted2)[-1][1]
    assert np.max(np.abs(np.sort(s2) - np.sort(r2))) <= 1e-12 * np.max(np.abs(s2))


def bad(material=None, **top):
    deck = copy.deepcopy(shear_deck(frames=2))
    if material is not None:
        deck["material"] = material
    deck.update(top)
    return deck


VISCO = {"model": "neohookean", "mu": MU, "lambda": LAMBDA, "density": 1000}
BAD = {
    "tau_zero": (bad(dict(VISCO, viscoelastic={"branches": [{"g": 0.3, "tau": 0}]})),
                 ["viscoelastic.branches[0].tau", "must be > 0"]),
    "g_negative": (bad(dict(VISCO, viscoelastic={"branches": [{"g": -0.1, "tau": 1}]})),
                   ["viscoelastic.branches[0].g", "must be > 0"]),
    "sum_g_one": (bad(dict(VISCO, viscoelastic={"branches": [{"g": 0.5, "tau": 1}, {"g": 0.5, "tau": 2}]})),
                  ["viscoelastic.branches", "sum to 1"]),
    "five_branches": (bad(dict(VISCO, viscoelastic={"branches": [{"g": 0.1, "tau": k + 1} for k in range(5)]})),
                      ["viscoelastic.branches", "1 to 4 branches, got 5"]),
    "no_branches": (bad(dict(VISCO, viscoelastic={})), ["branches"]),
    "principal_stretch": (bad({"model": "principal-stretch", "f": {"polynomial": [0, 0, 1]}, "density": 1000,
                               "viscoelastic": {"branches": [{"g": 0.3, "tau": 1}]}}),
                          ["viscoelastic"]),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_input(tmp_path, case):
    deck, fragments = BAD[case]
    assert_deck_refused(tmp_path, case, deck, fragments)


@pytest.mark.parametrize("ranks", [1, 2])
def test_study_keeps_each_trajectory_history(tmp_path, ranks):
    """A viscoelastic bar twisted and released at t = 0.3 (tau of the order of the step): in a
    study the reference and each trajectory carry their own viscous history (app/time_loop.cpp),
    and the per-frame solves start from the reference's. The lbfgs trajectory's RMS distance to the
    converged reference equals the distance between two plain runs (lbfgs, and the reference's
    Newton), to the reference's tolerance; sharing one history among them moves it by far more."""
    worst = twisted_bar_study(tmp_path, {"model": "neohookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3,
                                         "density": 1000,
                                         "viscoelastic": {"branches": [{"g": 0.5, "tau": 0.05}, {"g": 0.2, "tau": 0.5}]}},
                              ranks)
    print(f"study of a viscoelastic deck at {ranks} rank(s): lbfgs trajectory against two plain runs, worst "
          f"relative difference of the RMS distance {worst:.1e}")
    assert worst <= 1e-6


def uniaxial_cycle_deck(omega_tau, cycles, steps_per_cycle, strain=1e-3):
    """A unit cube under uniaxial stress on rollers (x = 0 held in x, y = 0 in y, z = 0 in z; the face
    x = 1 moved along x by strain sin(2 pi t)), one Maxwell branch with omega tau given, static load
    steps of dt = 1 / steps_per_cycle: a homogeneous state that linear tets hold exactly."""
    tau = omega_tau / (2 * math.pi)
    lo, hi = -E, 1 + E
    return {
        "name": "cycle",
        "mesh": {"box": {"size": [1, 1, 1], "cells": [1, 1, 1]}},
        "material": {"model": "neohookean", "mu": MU, "lambda": LAMBDA, "density": 1000,
                     "viscoelastic": {"branches": [{"g": G, "tau": tau}]}},
        "fixed": [{"box": {"min": [-E, lo, lo], "max": [E, hi, hi]}, "components": ["x"]},
                  {"box": {"min": [1 - E, lo, lo], "max": [1 + E, hi, hi]}, "components": ["x"],
                   "motion": {"translate": {"velocity": [strain, 0, 0]},
                              "curve": {"type": "sine", "amplitude": 1, "frequency": 1}}},
                  {"box": {"min": [lo, -E, lo], "max": [hi, E, hi]}, "components": ["y"]},
                  {"box": {"min": [lo, lo, -E], "max": [hi, hi, E]}, "components": ["z"]}],
        "gravity": [0, 0, 0],
        "time": {"dt": 1.0 / steps_per_cycle, "frames": cycles * steps_per_cycle, "integrator": "static"},
        "solver": {"type": "lbfgs", "iterations": 500, "grad_rtol": 1e-11},
        "output": {"every": steps_per_cycle, "reactions": True, "fields": ["dissipated_energy", "viscous_strain"]},
    }


@pytest.mark.parametrize("omega_tau", [0.1, 1.0, 10.0])
def test_uniaxial_loss_per_cycle(tmp_path, omega_tau):
    """Tension-compression cycles of the cube on rollers, through real solves: the moving face's
    reaction against its travel draws the hysteresis loop, whose area in the last cycle (the
    transient gone) is the work lost per cycle, pi eps0^2 Im E*(omega) per unit volume, with the
    uniaxial complex modulus E* = 9 K G* / (3 K + G*) of a shear modulus G* = mu + mu_1 i omega tau
    / (1 + i omega tau) that relaxes and a bulk modulus K = lambda + 2 mu / 3 that does not
    (small strain: eps0 = 1e-3). Within 1%, at 400 steps over the shorter of tau and the period.
    The material's own account agrees: the dissipated_energy field (per rest volume, the unit
    cube's) grows by the same amount over the last cycle (within 1e-3 of the loop), never falls in
    any tet, and its sum at the end is summary.json's dissipated_energy."""
    tau = omega_tau / (2 * math.pi)
    steps = int(round(400 / min(1.0, tau)))
    cycles = 1 + math.ceil(8 * tau)  # e^{-8} of the transient left at the last cycle's start
    out, _ = run_deck(tmp_path, "cycle", uniaxial_cycle_deck(omega_tau, cycles, steps))
    r = read_reactions(out)["fixed[1]"]
    assert len(r["time"]) == cycles * steps  # frames 1 ..
    last = slice((cycles - 1) * steps - 1, None)  # t from cycles - 1 to cycles
    travel = 1e-3 * np.sin(2 * math.pi * r["time"][last])
    force = r["fx"][last]
    lost = float(np.sum(0.5 * (force[1:] + force[:-1]) * np.diff(travel)))  # the clamp's work on the body
    K = LAMBDA + 2 * MU / 3
    G_star = MU + MU1 * 1j * omega_tau / (1 + 1j * omega_tau)
    E_star = 9 * K * G_star / (3 * K + G_star)
    expected = math.pi * 1e-3**2 * E_star.imag
    dissipated = [(t, m.cell_data["dissipated_energy"]) for _, t, path in frame_list(out)
                  for m in frame_meshes(path)]
    volumes = [1.0 / 6] * 6  # the cube's 6 Kuhn tets
    totals = [float(np.dot(volumes, np.concatenate([np.ravel(a) for a in d]))) for _, d in dissipated]
    per_cycle = totals[-1] - totals[-2]
    assert all(np.all(np.concatenate([np.ravel(a) for a in b]) >= np.concatenate([np.ravel(a) for a in a_]))
               for (_, a_), (_, b) in zip(dissipated, dissipated[1:])), "dissipation never falls"
    with open(out / "summary.json") as f:
        summary = json.load(f)
    print(f"uniaxial loss per cycle at omega tau = {omega_tau}: {lost:.6e} J against {expected:.6e} "
          f"({lost / expected - 1:+.2e}), {cycles} cycles of {steps} steps; dissipated by the material "
          f"{per_cycle:.6e} ({per_cycle / lost - 1:+.2e} of the loop)")
    assert lost == pytest.approx(expected, rel=1e-2)
    assert per_cycle == pytest.approx(lost, rel=1e-3)
    assert summary["dissipated_energy"] == pytest.approx(totals[-1], rel=1e-12)


def test_viscous_strain_and_dissipation_in_relaxation(tmp_path):
    """The history's own fields in the shear relaxation: the branch's flowed log strain |eps_v|
    (viscous_strain) follows backward Euler's recurrence gamma0/sqrt(2) (1 - (1 + dt/tau)^-n) (the
    deviatoric log strain of simple shear has norm gamma/sqrt(2) up to O(gamma^2)); the energy
    dissipated in n steps (dissipated_energy, summary.json), step k's 2 mu_1 tau dt/(tau + dt)^2
    |dev e_k|^2 with |dev e_k| = gamma0/sqrt(2) q^(k-1), q = tau/(tau + dt), summed:
    mu_1 gamma0^2 tau dt/(tau + dt)^2 (1 - q^2n)/(1 - q^2), which tends to mu_1 gamma0^2/2 * 2 tau/(2 tau
    + dt), the branch's energy less what its first step dissipated."""
    frames = 100  # 5 tau
    deck = shear_deck(frames=frames)
    deck["output"]["fields"] = ["viscous_strain", "dissipated_energy"]
    out, summary = run_deck(tmp_path, "fields", deck)
    worst = 0.0
    for n, time, path in frame_list(out):
        if n == 0:
            continue
        (m,) = frame_meshes(path)
        eps_v = np.ravel(m.cell_data["viscous_strain"][0])
        expected = GAMMA / math.sqrt(2) * (1 - (1 + DT / TAU) ** -n)
        assert np.ptp(eps_v) <= 1e-9 * expected  # homogeneous
        worst = max(worst, abs(eps_v.mean() / expected - 1))
    (m,) = frame_meshes(frame_list(out)[-1][2])
    d = np.ravel(m.cell_data["dissipated_energy"][0])
    q = TAU / (TAU + DT)
    expected = MU1 * GAMMA**2 * TAU * DT / (TAU + DT) ** 2 * (1 - q ** (2 * frames)) / (1 - q**2)  # the unit block
    print(f"viscous strain against the recurrence: {worst:.1e}; dissipated after 5 tau {summary['dissipated_energy']:.6e} J "
          f"against the recurrence's {expected:.6e} ({summary['dissipated_energy'] / expected - 1:+.1e})")
    assert worst <= 1e-5
    assert np.ptp(d) <= 1e-6 * d.mean()
    assert summary["dissipated_energy"] == pytest.approx(d.mean(), rel=1e-9)
    assert summary["dissipated_energy"] == pytest.approx(expected, rel=1e-5)
