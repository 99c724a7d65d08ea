"""J2 plasticity in logarithmic strain (material.plastic over model hencky,
docs/inelastic.md#plasticity), end to end.

- A static uniaxial bar: a unit cube of 2 x 2 x 2 cells held by rollers (the bottom face in y, the
  top face in y moved by a table curve, one bottom corner in x and z, another in z), so that the
  discrete equilibrium is the homogeneous uniaxial stress state (linear tets pass the patch test).
  In the log strain E_yy = log(1 + u) and its conjugate stress T_yy = J sigma_yy (the Kirchhoff
  stress: everything is coaxial) the response is small-strain J2's: yield at sigma_y within 0.1%,
  the hardening slope E H / (E + H), H = H_iso + H_kin, within 1%, and the residual strain after
  elastic unloading against the closed form eps_max - sigma_max / E within 0.1%.
- Newton (the consistent tangent, projected) ends where lbfgs does.
- Elastic-perfectly plastic, a strain cycle eps_a -> -eps_a -> eps_a: the loop's area against
  4 sigma_y (eps_a - sigma_y / E) within 1%.
- The same at 2 ranks (to 1e-9 of the stress); a restart from the checkpoint of a frame in the middle
  of plastic flow ends bit for bit as the uninterrupted run at 1 rank, and within 1e-12 at 2.
- Two kinds in one scene (a plastic material and a viscoelastic region): a restart is bitwise.
- A study keeps each trajectory's plastic history (as test_viscoelastic.py's, at 1 and 2 ranks).
- Bad input: yield_stress <= 0, a negative hardening modulus, plastic with viscoelastic, plastic on
  a model other than hencky: the deck line named, exit 1, nothing written (the midpoint takes it:
  test_energy_balance.py).
"""
import copy
import math

import numpy as np
import pytest

from conftest import run_deck, run_hyperqn, twisted_bar_study, write_deck
from hyperqn_tools.output import final_frame, frame_list, frame_meshes, read_summary, tensors
from test_bad_input import assert_deck_refused

MU, LAMBDA = 8.0e4, 1.2e5
YOUNG = MU * (3 * LAMBDA + 2 * MU) / (LAMBDA + MU)  # 2.08e5
SIGMA_Y, H_ISO, H_KIN = 400.0, 1.0e4, 1.0e4
E = 0.01  # half the thickness of a roller's box
# Loading to u = 0.01 in 20 load steps (the first elastic, yield near the 4th), then unloading by 5.
LOADING = [0.0005 * n for n in range(21)]
UNLOADING = [0.01 - 0.0005 * n for n in range(1, 6)]


def bar_deck(path, plastic, frames=None, every=1):
    """The rollers' cube whose top face follows the displacements `path` (one per load step)."""
    points = [[float(t), u] for t, u in enumerate(path)]
    frames = frames or len(path) - 1
    top_motion = {"translate": {"velocity": [0, 1, 0]}, "curve": {"type": "table", "points": points}}
    return {
        "name": "bar",
        "mesh": {"box": {"size": [1, 1, 1], "cells": [2, 2, 2]}},
        "material": {"model": "hencky", "mu": MU, "lambda": LAMBDA, "density": 1000, "plastic": plastic},
        "fixed": [
            {"box": {"min": [-E, -E, -E], "max": [1 + E, E, 1 + E]}, "components": ["y"]},
            {"box": {"min": [-E, 1 - E, -E], "max": [1 + E, 1 + E, 1 + E]}, "components": ["y"], "motion": top_motion},
            {"box": {"min": [-E, -E, -E], "max": [E, E, E]}, "components": ["x", "z"]},
            {"box": {"min": [1 - E, -E, -E], "max": [1 + E, E, E]}, "components": ["z"]},
        ],
        "gravity": [0, 0, 0],
        "time": {"dt": 1.0, "frames": frames, "integrator": "static"},
        "solver": {"type": "lbfgs", "iterations": 1000, "grad_rtol": 1e-11},
        "output": {"every": every, "fields": ["cauchy_stress"]},
    }


HARDENING = {"yield_stress": SIGMA_Y, "isotropic_hardening": H_ISO, "kinematic_hardening": H_KIN}


def axial(outdir):
    """[(E_yy, T_yy of every tet)] per output frame: log strain and Kirchhoff stress."""
    out = []
    for _, _, path in frame_list(outdir):
        meshes = frame_meshes(path)
        sigma = np.concatenate([tensors(m.cell_data["cauchy_stress"][b])[:, 1, 1]
                                for m in meshes for b in range(len(m.cells))])
        J = np.concatenate([np.asarray(m.cell_data["J"][b]) for m in meshes for b in range(len(m.cells))])
        top = max(p[1] for m in meshes for p in m.points)
        out.append((math.log(top), J * sigma))
    return out


def test_uniaxial_yield_hardening_and_residual_strain(tmp_path):
    out, _ = run_deck(tmp_path, "bar", bar_deck(LOADING + UNLOADING, HARDENING))
    curve = axial(out)
    e = np.array([c[0] for c in curve])
    s = np.array([c[1].mean() for c in curve])
    spread = max((c[1].max() - c[1].min()) for c in curve[1:]) / SIGMA_Y
    n = len(LOADING) - 1
    E_fit = s[1] / e[1]
    H_fit = (s[n] - s[n - 1]) / (e[n] - e[n - 1])
    e_y = (s[n] - H_fit * e[n]) / (E_fit - H_fit)
    sigma_y = E_fit * e_y
    H = H_ISO + H_KIN
    slope = YOUNG * H / (YOUNG + H)
    # Unloading is elastic (the reverse yield stress beta - R is negative here): the residual log
    # strain where T_yy = 0 along the measured elastic line, against eps_max - sigma_max / E with
    # sigma_max = sigma_y + slope (eps_max - sigma_y / E).
    e_max = math.log(1 + LOADING[-1])
    s_max = SIGMA_Y + slope * (e_max - SIGMA_Y / YOUNG)
    residual = e[-1] - s[-1] / E_fit
    closed = e_max - s_max / YOUNG
    print(f"\nE {E_fit:.6g} (exact {YOUNG:.6g}); yield {sigma_y:.6g} (sigma_y {SIGMA_Y}, rel {sigma_y / SIGMA_Y - 1:.2e}); "
          f"slope {H_fit:.6g} (E H/(E+H) {slope:.6g}, rel {H_fit / slope - 1:.2e}); sigma_max {s[n]:.6g} "
          f"(closed {s_max:.6g}); residual strain {residual:.6e} (closed {closed:.6e}, rel {residual / closed - 1:.2e}); "
          f"spread over the tets {spread:.1e} of sigma_y")
    assert abs(E_fit / YOUNG - 1) <= 1e-6
    assert abs(sigma_y / SIGMA_Y - 1) <= 1e-3
    assert abs(H_fit / slope - 1) <= 1e-2
    assert abs(residual / closed - 1) <= 1e-3
    assert spread <= 1e-6


def test_newton_follows_lbfgs(tmp_path):
    path = LOADING[:9]
    lb, _ = run_deck(tmp_path, "lbfgs", bar_deck(path, HARDENING))
    deck = bar_deck(path, HARDENING)
    deck["solver"] = {"type": "newton", "iterations": 50, "grad_rtol": 1e-11}
    nt, summary = run_deck(tmp_path, "newton", deck)
    a, b = axial(lb), axial(nt)
    worst = max(abs(x[1].mean() - y[1].mean()) for x, y in zip(a, b)) / SIGMA_Y
    print(f"\nnewton vs lbfgs: worst stress difference {worst:.1e} of sigma_y; {summary['mean_iterations']} "
          "Newton iterations per load step")
    assert worst <= 1e-6
    assert summary["newton_frames"] == 0 or summary["mean_iterations"] < 50


def test_perfectly_plastic_loop_area(tmp_path):
    eps_a, steps = 0.005, 20  # 2.6 yield strains; 20 load steps per quarter
    quarter = [eps_a * k / steps for k in range(steps + 1)]
    down = [eps_a - 2 * eps_a * k / (2 * steps) for k in range(1, 2 * steps + 1)]
    up = [-eps_a + 2 * eps_a * k / (2 * steps) for k in range(1, 2 * steps + 1)]
    # The log strain cycles between +-eps_a: u = exp(e) - 1.
    path = [math.expm1(x) for x in quarter + down + up]
    deck = bar_deck(path, {"yield_stress": SIGMA_Y})
    deck["output"]["fields"] += ["dissipated_energy", "equivalent_plastic_strain"]
    out, summary = run_deck(tmp_path, "loop", deck)
    curve = axial(out)[steps:]  # from eps_a round to eps_a
    e = np.array([c[0] for c in curve])
    s = np.array([c[1].mean() for c in curve])
    area = abs(np.sum(0.5 * (s[1:] + s[:-1]) * np.diff(e)))
    exact = 4 * SIGMA_Y * (eps_a - SIGMA_Y / YOUNG)
    print(f"\nloop area {area:.6g}, 4 sigma_y (eps_a - sigma_y/E) {exact:.6g}, rel {area / exact - 1:.2e}")
    assert abs(area / exact - 1) <= 1e-2
    # The material's account (the unit cube's 48 tets, each of volume 1/48): the energy it
    # dissipated over the loop is sigma_y times the plastic strain it crossed, 4 (eps_a - sigma_y/E),
    # and alpha ends at 5 (eps_a - sigma_y/E) (the first loading's, then the loop's).
    frames = [(n, frame_meshes(p)) for n, _, p in frame_list(out)]
    def field(meshes, name):
        return np.concatenate([np.ravel(m.cell_data[name][b]) for m in meshes for b in range(len(m.cells))])
    start, end = frames[steps][1], frames[-1][1]
    lost = (field(end, "dissipated_energy") - field(start, "dissipated_energy")).mean()
    alpha = field(end, "equivalent_plastic_strain")
    flow = eps_a - SIGMA_Y / YOUNG
    print(f"dissipated over the loop {lost:.6g} ({lost / exact - 1:+.2e} of the closed form, {lost / area - 1:+.2e} "
          f"of the loop); alpha {alpha.mean():.6g} against {5 * flow:.6g}")
    assert abs(lost / exact - 1) <= 1e-2 and abs(lost / area - 1) <= 1e-3
    assert np.ptp(alpha) <= 1e-9 and abs(alpha.mean() / (5 * flow) - 1) <= 1e-2
    assert summary["dissipated_energy"] == pytest.approx(field(end, "dissipated_energy").mean(), rel=1e-9)
    for (_, a), (_, b) in zip(frames, frames[1:]):
        assert np.all(field(b, "dissipated_energy") >= field(a, "dissipated_energy")), "dissipation never falls"


def test_two_ranks_and_restart(tmp_path):
    deck = bar_deck(LOADING, HARDENING, every=5)
    one, _ = run_deck(tmp_path, "np1", deck)
    two, _ = run_deck(tmp_path, "np2", deck, ranks=2)
    for (_, sa), (_, sb) in zip(axial(one), axial(two)):
        assert abs(sa.mean() - sb.mean()) <= 1e-9 * max(abs(sa.mean()), SIGMA_Y)
    # Frame 10 is in the middle of plastic flow (yield near frame 4).
    restarted = tmp_path / "restarted"
    first = dict(deck, time=dict(deck["time"], frames=10), checkpoint={"every": 10})
    run_hyperqn([write_deck(tmp_path / "first.yaml", first), "-o", restarted], ranks=1)
    done = run_hyperqn([write_deck(tmp_path / "then.yaml", deck), "-o", restarted, "--restart", "latest"], ranks=1)
    assert "restart from" in done.stdout
    assert np.array_equal(final_frame(one).points, final_frame(restarted).points)
    sa, sb = axial(one)[-1][1], axial(restarted)[-1][1]
    assert np.array_equal(np.sort(sa), np.sort(sb)), "the restarted stresses bit for bit"
    assert read_summary(restarted)["dissipated_energy"] == read_summary(one)["dissipated_energy"]
    # A restart from the checkpoint of the last frame computes no frame: its summary still says
    # what was dissipated (it left the key out)
    last = dict(deck, checkpoint={"every": deck["time"]["frames"]})
    ended = tmp_path / "ended"
    run_hyperqn([write_deck(tmp_path / "last.yaml", last), "-o", ended], ranks=1)
    run_hyperqn([write_deck(tmp_path / "last.yaml", last), "-o", ended, "--restart", "latest"], ranks=1)
    assert read_summary(ended)["dissipated_energy"] == read_summary(one)["dissipated_energy"] > 0
    restarted2 = tmp_path / "restarted2"
    run_hyperqn([write_deck(tmp_path / "first2.yaml", first), "-o", restarted2], ranks=2)
    run_hyperqn([write_deck(tmp_path / "then2.yaml", deck), "-o", restarted2, "--restart", "latest"], ranks=2)
    s2, r2 = axial(two)[-1][1], axial(restarted2)[-1][1]
    assert np.max(np.abs(np.sort(s2) - np.sort(r2))) <= 1e-12 * np.max(np.abs(s2))


def test_plastic_and_viscoelastic_regions_restart(tmp_path):
    """Two inelastic kinds in one scene (a term each, a history each: elements_plastic and
    elements_viscous in the checkpoint): a restart from frame 5, both flowing, is bitwise."""
    deck = bar_deck(LOADING[:11], HARDENING, every=5)
    deck["regions"] = [{"box": {"min": [-1, -1, -1], "max": [2, 0.5, 2]},
                        "material": {"model": "neohookean", "mu": MU, "lambda": LAMBDA, "density": 1000,
                                     "viscoelastic": {"branches": [{"g": 0.3, "tau": 2.0}]}}}]
    whole, _ = run_deck(tmp_path, "whole", deck)
    restarted = tmp_path / "restarted"
    first = dict(deck, time=dict(deck["time"], frames=5), checkpoint={"every": 5})
    run_hyperqn([write_deck(tmp_path / "first.yaml", first), "-o", restarted], ranks=1)
    done = run_hyperqn([write_deck(tmp_path / "then.yaml", deck), "-o", restarted, "--restart", "latest"], ranks=1)
    assert "restart from" in done.stdout
    assert np.array_equal(final_frame(whole).points, final_frame(restarted).points)
    # Without the histories the restart would differ: the same deck elastic ends elsewhere.
    elastic = copy.deepcopy(deck)
    del elastic["material"]["plastic"]
    del elastic["regions"][0]["material"]["viscoelastic"]
    other, _ = run_deck(tmp_path, "elastic", elastic)
    assert not np.allclose(final_frame(whole).points, final_frame(other).points, rtol=0, atol=1e-9)


@pytest.mark.parametrize("ranks", [1, 2])
def test_study_keeps_each_trajectory_history(tmp_path, ranks):
    """As test_viscoelastic.py's: a plastic bar twisted past yield and released; in a study the
    reference and each trajectory carry their own plastic history, so the lbfgs trajectory's RMS
    distance to the converged reference equals the distance between two plain runs (lbfgs, and the
    reference's Newton) to the reference's tolerance."""
    worst = twisted_bar_study(tmp_path, {"model": "hencky", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 1000,
                                         "plastic": {"yield_stress": 2.0e3, "isotropic_hardening": 1.0e4,
                                                     "kinematic_hardening": 5.0e3}}, ranks)
    print(f"\nstudy of a plastic deck at {ranks} rank(s): lbfgs trajectory against two plain runs, worst "
          f"relative difference of the RMS distance {worst:.1e}")
    assert worst <= 1e-6


def bad(material=None, **top):
    deck = copy.deepcopy(bar_deck(LOADING[:3], HARDENING))
    if material is not None:
        deck["material"] = material
    deck.update(top)
    return deck


PLASTIC = {"model": "hencky", "mu": MU, "lambda": LAMBDA, "density": 1000}
BAD = {
    "yield_negative": (bad(dict(PLASTIC, plastic={"yield_stress": -1})), ["plastic.yield_stress", "must be > 0"]),
    "yield_zero": (bad(dict(PLASTIC, plastic={"yield_stress": 0})), ["plastic.yield_stress", "must be > 0"]),
    "yield_missing": (bad(dict(PLASTIC, plastic={"isotropic_hardening": 1})), ["yield_stress"]),
    "isotropic_negative": (bad(dict(PLASTIC, plastic={"yield_stress": 1, "isotropic_hardening": -1})),
                           ["plastic.isotropic_hardening", "must be >= 0"]),
    "kinematic_negative": (bad(dict(PLASTIC, plastic={"yield_stress": 1, "kinematic_hardening": -2})),
                           ["plastic.kinematic_hardening", "must be >= 0"]),
    "with_viscoelastic": (bad(dict(PLASTIC, plastic={"yield_stress": 1},
                                   viscoelastic={"branches": [{"g": 0.3, "tau": 1}]})),
                          ["one inelastic block"]),
    "on_neohookean": (bad(dict(PLASTIC, model="neohookean", plastic={"yield_stress": 1})),
                      ["plastic", "hencky"]),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_input(tmp_path, case):
    deck, fragments = BAD[case]
    assert_deck_refused(tmp_path, case, deck, fragments)
