"""The static integrator (time.integrator: static, docs/method.md#time-integrators), end to end.

- Against dynamics: a damped implicit-Euler run of a cantilever under gravity settles where the
  static load step puts it (gravity acts in static as the inertia term's linear part).
- Uniaxial tension of a compressible Neo-Hookean bar under equal and opposite dead tractions, held
  only by a soft attachment at its centre vertex: the discrete equilibrium is the homogeneous state
  F = diag(lambda, mu, mu) (linear tets pass the patch test, and the attached vertex does not move
  in it, so its spring carries nothing); stretch and lateral contraction against the closed form of
  the model's own psi (src/materials/neohookean.cpp) for stretches up to 2.
- A cantilever under a tip traction against Timoshenko beam theory on a refined mesh.
- input/engineering/static_cantilever.yaml at 1 and 2 ranks; lbfgs against Newton.
- A restart equals the uninterrupted run bit for bit; a load step too large for the solver's budget
  is split by the fallback chain; `hyperqn study` runs a static deck.
- Bad input: a static deck with nothing that holds the body, damping, pseudo_step without static.
"""
import copy
import csv
import math
import os

import numpy as np
import pytest

from conftest import load_deck, run_deck, run_hyperqn, write_deck
from hyperqn_tools.compare import relative_difference
from hyperqn_tools.output import final_frame, read_contact, read_frames, read_reactions, read_summary
from hyperqn_tools.paths import REPO
from test_bad_input import assert_clean_failure

CANTILEVER = load_deck("input/engineering/static_cantilever.yaml")
END = {"min": [3.99, -0.01, -0.01], "max": [4.01, 1.01, 1.01]}


def run(tmp_path, name, deck, ranks=1):
    return run_deck(tmp_path, name, deck, ranks)[0]


def test_damped_dynamics_settles_at_the_static_answer(tmp_path):
    """Gravity on a cantilever: the damped dynamic run's last frame (at rest: M (x - y) + h^2 grad E
    = h^2 (grad E - M g) = 0) against one static load step, both solved to grad_rtol 1e-10."""
    deck = copy.deepcopy(CANTILEVER)
    deck["mesh"]["box"]["cells"] = [8, 2, 2]
    del deck["loads"]
    deck["gravity"] = [0, -9.81, 0]
    deck["solver"] = {"type": "lbfgs", "iterations": 1000, "grad_rtol": 1e-10}
    deck["time"] = {"dt": 1, "frames": 1, "integrator": "static"}
    static = run(tmp_path, "static", deck)
    deck["time"] = {"dt": 0.1, "frames": 300, "damping": 0.2}
    deck["output"] = {"every": 300}
    dynamic = run(tmp_path, "dynamic", deck)
    rel, diff, sag = relative_difference(static, dynamic, same_end=False)
    print(f"static against damped dynamics: {diff:.3e} of a displacement of {sag:.3e} ({rel:.2e})")
    assert sag > 0.05  # the bar sags
    assert rel <= 1e-6


NEO_MU, NEO_LAMBDA = 1.0e4, 2.0e4


def uniaxial_closed_form(stretch):
    """(traction, lateral stretch) of F = diag(l, m, m) with P22 = 0, for the model's psi =
    mu/2 (I1 - 3) - mu log J + lambda/2 log^2 J: P = mu F + (lambda log J - mu) F^-T, so
    P11 = mu l + (lambda log J - mu) / l and P22 = mu m + (lambda log J - mu) / m, J = l m^2."""
    def p22(m):
        return NEO_MU * m + (NEO_LAMBDA * math.log(stretch * m * m) - NEO_MU) / m
    lo, hi = 0.1, 1.0 + 1e-12  # p22 increases with m, negative at 0.1, >= 0 at 1 for l >= 1
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if p22(mid) > 0 else (mid, hi)
    m = 0.5 * (lo + hi)
    return NEO_MU * stretch + (NEO_LAMBDA * math.log(stretch * m * m) - NEO_MU) / stretch, m


def uniaxial_deck(traction, solver="lbfgs"):
    return {
        "name": "uniaxial",
        "mesh": {"box": {"size": [2.0, 1.0, 1.0], "cells": [4, 2, 2]}},
        "material": {"model": "neohookean", "mu": NEO_MU, "lambda": NEO_LAMBDA, "density": 1000},
        # the centre vertex (1, 0.5, 0.5) alone, on a soft spring
        "attachments": [{"box": {"min": [0.99, 0.49, 0.49], "max": [1.01, 0.51, 0.51]}, "stiffness": 100.0}],
        "loads": [
            {"type": "traction", "box": {"min": [1.99, -0.01, -0.01], "max": [2.01, 1.01, 1.01]},
             "traction": [traction, 0, 0]},
            {"type": "traction", "box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 1.01, 1.01]},
             "traction": [-traction, 0, 0]},
        ],
        "gravity": [0, 0, 0],
        "time": {"dt": 1, "frames": 1, "integrator": "static"},
        "solver": {"type": solver, "iterations": 2000, "grad_rtol": 1e-12},
        "output": {"every": 1},
    }


def deformation_gradient(frame):
    """The affine map X -> x that fits the frame best, and the largest distance of a vertex from it."""
    rest = frame.points - frame.displacement
    X = np.c_[rest, np.ones(len(rest))]
    fit = np.linalg.lstsq(X, frame.points, rcond=None)[0]
    return fit[:3].T, np.abs(X @ fit - frame.points).max()


@pytest.mark.parametrize("solver", ["lbfgs", "newton"])
@pytest.mark.parametrize("stretch", [1.25, 1.5, 2.0])
def test_uniaxial_tension_against_the_closed_form(tmp_path, stretch, solver):
    traction, lateral = uniaxial_closed_form(stretch)
    out = run(tmp_path, "uniaxial", uniaxial_deck(traction, solver))
    F, off = deformation_gradient(final_frame(out))
    # A rotation about the load's axis changes no energy (the dead tractions are along it): compare
    # the stretch U of F = R U (Newton's iterates turn by 4e-5 rad about x, lbfgs's not at all).
    w, V = np.linalg.eigh(F.T @ F)
    U = V @ np.diag(np.sqrt(w)) @ V.T
    errors = (abs(U[0, 0] / stretch - 1), abs(U[1, 1] / lateral - 1), abs(U[2, 2] / lateral - 1))
    print(f"{solver}, stretch {stretch}: traction {traction:.6g} Pa gives stretch {U[0, 0]:.10f}, lateral "
          f"{U[1, 1]:.10f} {U[2, 2]:.10f} (closed form {lateral:.10f}); relative errors {max(errors):.1e}, "
          f"off the homogeneous state {off:.1e}")
    assert max(errors) <= 1e-6
    assert off <= 1e-6 * stretch
    assert np.abs(U - np.diag(np.diag(U))).max() <= 1e-6  # no shear
    assert abs(F[0, 0] - U[0, 0]) <= 1e-9 * stretch  # the bar's axis stays along x


def test_cantilever_against_timoshenko(tmp_path):
    """A 10 x 1 x 1 cantilever (nu = 0, so no anticlastic coupling) clamped at x = 0 under a small
    uniform traction P on its end: the tip's mean deflection against Timoshenko's
    P L^3 / (3 E I) + P L / (k G A), k = 5/6, by Newton. Linear tets are stiff in bending, so the mesh
    is fine: 40 x 4 x 4 cubes gave -17.6 %, 80 x 8 x 8 -5.1 %, 200 x 10 x 10 -2.3 %, 240 x 12 x 12
    -1.6 % (11 s, 0.8 GB), 160 x 16 x 16 -1.3 % (27 s, 1.1 GB)."""
    E, L, P = 1.0e6, 10.0, 1.0
    deck = {
        "name": "timoshenko",
        "mesh": {"box": {"size": [L, 1.0, 1.0], "cells": [240, 12, 12]}},
        "material": {"model": "neohookean", "youngs_modulus": E, "poisson_ratio": 0.0, "density": 1000},
        "fixed": [{"box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 1.01, 1.01]}}],
        "loads": [{"type": "traction", "box": {"min": [L - 0.01, -0.01, -0.01], "max": [L + 0.01, 1.01, 1.01]},
                   "traction": [0, -P, 0]}],
        "gravity": [0, 0, 0],
        "time": {"dt": 1, "frames": 1, "integrator": "static"},
        "solver": {"type": "newton", "iterations": 20, "grad_rtol": 1e-8},
        "output": {"every": 1},
    }
    frame = final_frame(run(tmp_path, "timoshenko", deck))
    tip = (frame.points - frame.displacement)[:, 0] > L - 0.01
    deflection = -frame.displacement[tip, 1].mean()
    theory = P * L**3 / (3 * E / 12) + P * L / (5 / 6 * E / 2)
    print(f"tip deflection {deflection:.6e}, Timoshenko {theory:.6e}: {deflection / theory - 1:+.2%}")
    assert abs(deflection / theory - 1) <= 0.02


def test_same_at_1_and_2_ranks_and_newton(tmp_path):
    path = os.path.join(REPO, "input/engineering/static_cantilever.yaml")
    outs = {}
    for ranks in (1, 2):
        outs[ranks] = tmp_path / f"np{ranks}"
        proc = run_hyperqn([path, "-o", outs[ranks]], ranks=ranks)
        assert "static: load steps of" in proc.stdout and "pseudo step s =" in proc.stdout
    rel, diff, sag = relative_difference(outs[1], outs[2])
    print(f"1 vs 2 ranks: {diff:.3e} of a displacement of {sag:.3e}")
    assert rel <= 1e-10
    summary = read_summary(outs[1])
    assert summary["converged_frames"] == 3
    newton = copy.deepcopy(CANTILEVER)
    newton["solver"] = {"type": "newton", "iterations": 50}
    rel, diff, sag = relative_difference(outs[1], run(tmp_path, "newton", newton))
    print(f"lbfgs vs newton: {diff:.3e} of {sag:.3e}")
    assert sag > 0.3 and rel <= 1e-4


def twisted(frames, solver):
    """A bar clamped at both ends, the end x = 4 turned by 90 degrees per unit time."""
    deck = copy.deepcopy(CANTILEVER)
    deck["mesh"]["box"]["cells"] = [8, 2, 2]
    del deck["loads"]
    deck["fixed"].append({"box": END, "motion": {"rotate": {"axis": [1, 0, 0], "center": [4, 0.5, 0.5], "rate": 90}}})
    deck["time"] = {"dt": 1, "frames": frames, "integrator": "static"}
    deck["solver"] = solver
    return deck


def test_restart_is_bitwise(tmp_path):
    solver = {"type": "lbfgs", "iterations": 100}
    deck = twisted(4, solver)
    full = run(tmp_path, "full", deck)
    restarted = tmp_path / "restarted"
    first = dict(deck, time=dict(deck["time"], frames=2), checkpoint={"every": 2})
    run_hyperqn([write_deck(tmp_path / "first.yaml", first), "-o", restarted], ranks=1)
    done = run_hyperqn([write_deck(tmp_path / "then.yaml", deck), "-o", restarted, "--restart", "latest"], ranks=1)
    assert "restart from" in done.stdout
    a, b = final_frame(full), final_frame(restarted)
    assert np.array_equal(a.points, b.points) and np.array_equal(a.velocity, b.velocity)
    rest_x = (a.points - a.displacement)[:, 0]
    assert not a.velocity[(rest_x > 0.01) & (rest_x < 3.99)].any()  # free vertices end at rest


def test_a_load_step_the_budget_cannot_reach_is_split(tmp_path):
    """90 degrees of twist in one load step: 20 iterations do not reach the answer from the start
    (the end turned, the rest at rest), so the chain splits the step into increments of h/2^k (the
    fixed end at t_n + h/2^k) and ends near the converged answer; with no splitting, Newton's
    fallback takes the step."""
    converged = run(tmp_path, "converged", twisted(1, {"type": "lbfgs", "iterations": 1000, "grad_rtol": 1e-9}))
    split = run(tmp_path, "split", twisted(1, {"type": "lbfgs", "iterations": 20, "max_iterations": 20,
                                               "max_halvings": 4, "newton_fallback": False}))
    summary = read_summary(split)
    assert summary["substepped_frames"] == 1, summary
    rel, diff, scale = relative_difference(converged, split)
    print(f"split load step against the converged one: {diff:.3e} of {scale:.3e}")
    assert rel <= 1e-2
    newton = run(tmp_path, "newton", twisted(1, {"type": "lbfgs", "iterations": 20, "max_iterations": 20,
                                                 "max_halvings": 0, "newton_fallback": True}))
    assert read_summary(newton)["newton_frames"] == 1
    rel, diff, scale = relative_difference(converged, newton)
    print(f"Newton's fallback against the converged one: {diff:.3e} of {scale:.3e}")
    assert rel <= 1e-3


def test_a_static_frame_ends_in_equilibrium(tmp_path):
    """A rope's support moved 20 % inwards in 10 load steps: L-BFGS creeps (the slack rope is nearly a
    mechanism), its last iterations change little, and the frame was accepted at a residual force
    of 5.2 S (S the forces acting). A static frame is far from converged while its residual is
    above FrameBudget::kFarResidual S (0.5 %): the chain goes on, and every frame ends below it."""
    deck = {
        "mesh": {"strands": [{"from": [0, 0, 0], "to": [1, 0, 0], "segments": 20}]},
        "strand_material": {"axial_stiffness": 1.0e5, "linear_density": 0.1},
        "fixed": [{"box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 0.01, 0.01]}},
                  {"box": {"min": [0.99, -0.01, -0.01], "max": [1.01, 0.01, 0.01]},
                   "motion": {"translate": {"velocity": [-0.2, 0, 0]}, "start": 0, "end": 1.0}}],
        "gravity": [0, -9.81, 0],
        "time": {"dt": 0.1, "frames": 20, "integrator": "static"},
        "solver": {"type": "lbfgs"},
    }
    summary = read_summary(run(tmp_path, "rope", deck))
    print(f"slackened rope: largest residual {summary['max_residual']:.2e} S, {summary['mean_iterations']} iterations "
          f"per frame, {summary['extended_frames']} extended, {summary['newton_frames']} by Newton")
    assert summary["status"] == "ok" and summary["max_residual"] <= 5e-3


def test_study_of_a_static_deck(tmp_path):
    deck = twisted(2, {"type": "lbfgs", "iterations": 20})
    deck["study"] = {"frames": [1, 2], "solvers": ["lbfgs", "newton"], "iterations": 50}
    proc = run_hyperqn(["study", write_deck(tmp_path / "study.yaml", deck), "-o", tmp_path / "study"], ranks=1)
    assert "study written" in proc.stdout


BAD = {
    "no_support": (lambda d: d.pop("fixed"), ["'time.integrator'", "nothing holds the body", "fixed:",
                                               "attachments:", "colliders:"]),
    "damping": (lambda d: d["time"].update(damping=0.1), ["'time.damping'", "static has no velocities"]),
    "pseudo_step_of_dynamics": (lambda d: d["time"].update(integrator="implicit-euler", pseudo_step=1.0),
                                ["'time.pseudo_step'", "integrator: static"]),
    "zero_pseudo_step": (lambda d: d["time"].update(pseudo_step=0.0), ["'time.pseudo_step'"]),
    # g = s^2 (E - W) underflowed: 0 iterations, "ok", nothing moved under gravity; or overflowed
    # ("Inf or NaN" in TAO's line search, not naming the key)
    "tiny_pseudo_step": (lambda d: d["time"].update(pseudo_step=1e-90),
                         ["'time.pseudo_step': 1e-90 is", "times the automatic pseudo step of this mesh",
                          "within [0.0001, 10000] times it"]),
    "huge_pseudo_step": (lambda d: d["time"].update(pseudo_step=1e100), ["'time.pseudo_step': 1e+100 is"]),
}


def static_bodies(second):
    block = {"mesh": {"box": {"size": [1.0, 0.2, 0.2], "cells": [2, 1, 1]}},
             "material": {"model": "corotated", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 100}}
    held = dict(block, name="a", fixed=[{"box": {"min": [-0.01, -1, -1], "max": [0.01, 1, 1]}}])
    other = dict(copy.deepcopy(block), name="b", **second)
    other["mesh"]["transform"] = {"translate": [0, 3, 0]}
    return {"bodies": [held, other], "time": {"dt": 1, "frames": 2, "integrator": "static"}}


@pytest.mark.parametrize("case,second,fragments", [
    # before: the velocity was ignored, and the unheld body diverged at frame 1 (exit 1, output left)
    ("body_velocity", {"velocity": [1, 0, 0], "fixed": [{"box": {"min": [-0.01, 2, -1], "max": [0.01, 4, 1]}}]},
     [".yaml:", "'bodies[1].velocity': integrator: static has no velocities"]),
    ("body_unheld", {}, [".yaml:", "'bodies[1]': static finds an equilibrium, and nothing holds body b",
                         # (before: it offered penalty self-contact, which holds no static body)
                         "contact: {self: true, model: barrier} to rest on (penalty self-contact, the default "
                         "model, cannot hold a body in a static step)"]),
])
def test_bad_static_bodies(tmp_path, case, second, fragments):
    path = write_deck(tmp_path / f"{case}.yaml", static_bodies(second))
    outdir = tmp_path / "out"
    proc = run_hyperqn([path, "-o", outdir], ranks=None, check=False, timeout=60)
    assert proc.returncode == 1
    assert_clean_failure(proc, outdir, [f"{case}.yaml"] + fragments)


def test_a_static_body_may_rest_on_another(tmp_path):
    """With self-contact (or a collider) a body without a region of its own may be held by contact:
    not refused at input."""
    deck = static_bodies({})
    deck["contact"] = {"self": True}
    proc = run_hyperqn(["config", write_deck(tmp_path / "rest.yaml", deck)], ranks=None, timeout=60)
    assert proc.returncode == 0


def test_static_reactions_do_not_depend_on_the_time_scale(tmp_path):
    """A static step has no inertia, so its reactions are the same whatever time the load path takes:
    tensile_bar.yaml's ramp over 10 s and over 10 ms give the same clamp forces (before: the clamp's
    start from rest added m dv/h, 6.41 N against 5.04 N at the first step over 10 ms)."""
    slow = load_deck("input/engineering/tensile_bar.yaml")
    fast = copy.deepcopy(slow)
    fast["fixed"][1]["motion"]["curve"]["end"] = 0.01
    fast["time"]["dt"] = 0.001
    forces = [read_reactions(run(tmp_path, name, deck))["fixed[1]"]["fx"] for name, deck in (("slow", slow), ("fast", fast))]
    assert len(forces[0]) == 10 and forces[0][0] > 4.5
    assert np.max(np.abs(forces[1] - forces[0])) <= 1e-8 * np.max(np.abs(forces[0]))


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_static_deck(tmp_path, case):
    deck = copy.deepcopy(CANTILEVER)
    change, fragments = BAD[case]
    change(deck)
    path = write_deck(tmp_path / f"{case}.yaml", deck)
    outdir = tmp_path / "out"
    proc = run_hyperqn([path, "-o", outdir], ranks=None, check=False, timeout=60)
    assert proc.returncode == 1
    assert_clean_failure(proc, outdir, [f"{case}.yaml"] + fragments)


def test_a_piece_a_cut_sets_free_stops_a_static_run_saying_why(tmp_path):
    # A bar held at one end, cut through by a blade: the piece beyond the cut has no equilibrium
    # under gravity, the static step diverges, and the message says what a static analysis needs.
    deck = {"mesh": {"box": {"size": [2.0, 0.5, 0.5], "cells": [8, 2, 2]}},
            "material": {"model": "neohookean", "youngs_modulus": 5.0e6, "poisson_ratio": 0.3, "density": 1000},
            "fixed": [{"box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 0.51, 0.51]}}],
            "gravity": [0, -9.81, 0],
            "cuts": [{"center": [1.27, 1.0, 0.25], "normal": [1, 0, 0], "axis": [0, 1, 0], "size": [0.6, 1.0],
                      "frame": "rest", "motion": {"translate": {"velocity": [0, -3, 0]}, "start": 0.1, "end": 0.6}}],
            "time": {"dt": 1 / 30, "frames": 16, "integrator": "static"},
            "solver": {"type": "lbfgs"}}
    out = tmp_path / "out"
    proc = run_hyperqn([write_deck(tmp_path / "freed.yaml", deck), "-o", out], ranks=None, check=False, timeout=300)
    assert proc.returncode == 1
    assert "diverged" in proc.stdout and "or a piece that nothing holds" in proc.stdout
    assert "use a dynamic time.integrator" in proc.stdout
    assert read_summary(out)["cuts"]["faces_separated"] > 0


def test_a_held_body_s_divergence_names_the_load_step_first(tmp_path):
    # The clamped cantilever under a traction it cannot carry in one step: the message blamed only
    # "a piece that nothing holds", which sent the user to the supports
    deck = copy.deepcopy(CANTILEVER)
    deck["mesh"]["box"]["cells"] = [4, 1, 1]
    deck["loads"][0]["traction"] = [0, -2.0e9, 0]
    deck["time"]["frames"] = 1
    out = tmp_path / "out"
    proc = run_hyperqn([write_deck(tmp_path / "over.yaml", deck), "-o", out], ranks=None, check=False, timeout=120)
    assert proc.returncode == 1 and "diverged" in proc.stdout, proc.stdout
    assert "static: either the load step is more than the body carries from the last equilibrium (more, smaller " \
           "load steps: more frames)" in proc.stdout
    assert "here only colliders hold the body" not in proc.stdout  # it is clamped


BLOCK_ON_BALL = {
    "name": "block_on_ball",
    "mesh": {"box": {"size": [0.2, 0.2, 0.2], "cells": [3, 3, 3]}, "transform": {"translate": [0, 0.002, 0]}},
    "material": {"model": "neohookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 1000},
    "colliders": [{"type": "sphere", "center": [0.1, -0.3, 0.1], "radius": 0.3, "friction": 0.5}],
    "gravity": [0, -9.81, 0],
    "time": {"dt": 1, "frames": 1, "integrator": "static"},
    "solver": {"type": "lbfgs", "iterations": 500, "grad_rtol": 1.0e-10},
}


@pytest.mark.parametrize("ranks", [None, 2])
def test_a_static_block_on_a_ball_stops_saying_why(tmp_path, ranks):
    """A known limitation (docs/method.md#time-integrators): a block held only by a ball (2 mm above
    it, r = 0.3 m) has no static answer here: g has no inertia, the first steps carry it through or
    off the ball, and the run diverges. The message says that only colliders hold it and what to do
    instead (before: only the load step's and a free piece's advice, neither of which applies)."""
    out = tmp_path / "out"
    proc = run_hyperqn([write_deck(tmp_path / "ball.yaml", BLOCK_ON_BALL), "-o", out], ranks=ranks, check=False,
                       timeout=120)
    assert proc.returncode == 1 and "diverged" in proc.stdout, proc.stdout[-3000:]
    assert "here only colliders hold the body (no vertex fixed or attached)" in proc.stdout
    assert "let it settle with a dynamic time.integrator and damping, or fix or attach a vertex" in proc.stdout


def test_the_block_on_a_ball_settles_dynamically(tmp_path):
    """The advice of the message above works: the same block, damped implicit Euler (h = 0.02 s,
    damping 0.2, 1.2 s), rests on the ball with the ball's normal force its weight within 1 % (it
    still rocks slightly: 78.35 N of 78.48 N at the last frame, measured)."""
    deck = copy.deepcopy(BLOCK_ON_BALL)
    deck["time"] = {"dt": 0.02, "frames": 60, "damping": 0.2}
    deck["solver"]["iterations"] = 200
    out = run(tmp_path, "dynamic", deck)
    weight = 0.2 ** 3 * 1000 * 9.81
    normal = read_contact(out)["normal_force"][-1]
    print(f"normal force {normal:.4f} N, weight {weight:.4f} N")
    assert abs(normal / weight - 1) < 0.01


RELEASED = {
    "mesh": {"box": {"size": [2.0, 1.0, 1.0], "cells": [4, 2, 2]}},
    "material": {"model": "neohookean", "youngs_modulus": 1.0e6, "poisson_ratio": 0.3, "density": 1000},
    "fixed": [{"box": {"min": [-0.01, -1, -1], "max": [0.01, 2, 2]}, "release": 2}],
    "loads": [{"type": "traction", "box": {"min": [1.99, -1, -1], "max": [2.01, 2, 2]}, "traction": [0, -1.0e3, 0]}],
    "gravity": [0, 0, 0],
    "time": {"dt": 1, "frames": 4, "integrator": "static"},
    "solver": {"type": "lbfgs", "iterations": 200},
    "output": {"every": 1, "reactions": True},
}
STATIC_HINT = ("static: either the load step is more than the body carries from the last equilibrium (more, smaller "
               "load steps: more frames), or a piece that nothing holds")


@pytest.mark.parametrize("load,ranks", [("traction", None), ("traction", 2), ("gravity", 2)])
def test_a_support_released_in_a_static_run_stops_it_alike_at_any_rank_count(tmp_path, load, ranks):
    """The bar's only clamp released at t = 2: the load step after it has no equilibrium. Before, the
    run ended three ways: 1 rank exit 1 "elements exploded" without the static hint; 2 ranks wrote
    frames 3 and 4 with the bar flown off rigidly by 1.7e7 m (no edge longer, no element past the
    limit: status inverted, exit 2); 4 ranks the diverged message (gravity instead of the traction:
    2 ranks without the hint). Now every rank count stops at frame 3 on the static step's travel
    beyond its supports (an allreduce), naming the release."""
    deck = copy.deepcopy(RELEASED)
    if load == "gravity":
        del deck["loads"]
        deck["gravity"] = [0, -9.81, 0]
    out = tmp_path / "out"
    proc = run_hyperqn([write_deck(tmp_path / "released.yaml", deck), "-o", out], ranks=ranks, check=False,
                       timeout=120)
    assert proc.returncode == 1, proc.stdout[-3000:]
    assert "error: frame 3: diverged: the load step moved a vertex" in proc.stdout
    assert "rest bounding-box diagonals farther than any held vertex moved (limit 10)" in proc.stdout
    assert STATIC_HINT in proc.stdout
    assert "released before this step: fixed[0]" in proc.stdout
    assert [n for n, _ in read_frames(out)] == [0, 1, 2]
    assert read_summary(out)["status"].startswith("error: frame 3: diverged")


def stacked_blocks(model):
    """Block a clamped at its base, block b 0.03 above it on rollers (x at its x = 0 face, z at its
    z = 0 face), self-contact, 20 Pa down on b's top in one static load step."""
    block = {"mesh": {"box": {"size": [1.0, 0.5, 1.0], "cells": [2, 1, 2]}},
             "material": {"model": "neohookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 100}}
    a = dict(copy.deepcopy(block), name="a", fixed=[{"box": {"min": [-1, -0.01, -1], "max": [2, 0.01, 2]}}])
    b = dict(copy.deepcopy(block), name="b",
             fixed=[{"box": {"min": [-0.01, 0.52, -1], "max": [0.01, 1.04, 2]}, "components": ["x"]},
                    {"box": {"min": [-1, 0.52, -0.01], "max": [2, 1.04, 0.01]}, "components": ["z"]}])
    b["mesh"]["transform"] = {"translate": [0, 0.53, 0]}
    return {"bodies": [a, b], "contact": {"self": True, "model": model},
            "loads": [{"type": "traction", "box": {"min": [-1, 1.02, -1], "max": [2, 1.04, 2]},
                       "traction": [0, -20, 0]}],
            "gravity": [0, 0, 0],
            "time": {"dt": 1, "frames": 1, "integrator": "static"},
            "solver": {"type": "lbfgs", "iterations": 100, "budget": "fixed"},
            "output": {"every": 1, "reactions": True}}


@pytest.mark.parametrize("ranks", [None, 2])
def test_penalty_self_contact_holds_no_static_body(tmp_path, ranks):
    """Block b pressed onto block a through penalty self-contact (the default model): the load step
    carries b through the contact layer and on without bound. Before, 2 ranks wrote frame 1 with b
    some 1e8 m down and 0 N at a's clamp (exit 2: inverted) and 1 rank stopped on an edge without
    saying that the penalty cannot hold it. Now both stop at frame 1 on its travel, saying what holds."""
    out = tmp_path / "out"
    proc = run_hyperqn([write_deck(tmp_path / "penalty.yaml", stacked_blocks("penalty")), "-o", out], ranks=ranks,
                       check=False, timeout=120)
    assert proc.returncode == 1, proc.stdout[-3000:]
    assert "error: frame 1: diverged" in proc.stdout and STATIC_HINT in proc.stdout
    assert "penalty self-contact (contact.model: penalty, the default) cannot hold a body in a static step" in proc.stdout
    assert "contact: {self: true, model: barrier}" in proc.stdout
    assert [n for n, _ in read_frames(out)] == [0]


def test_barrier_self_contact_holds_a_static_body(tmp_path):
    """The same blocks with the barrier: b rests on a, and a's clamp carries the 20 N on b's top."""
    out = run(tmp_path, "barrier", stacked_blocks("barrier"))
    clamp = read_reactions(out)["bodies[0].fixed[0]"]
    assert read_summary(out)["status"] == "ok"
    assert abs(clamp["fy"][-1] - 20.0) < 1e-3 * 20


@pytest.mark.parametrize("model", ["penalty", "barrier"])
def test_a_static_body_started_inside_the_contact_layer_ends_at_equilibrium(tmp_path, model):
    """Block b 0.01 above a, inside the contact layer (d = 0.0174): the contact pushes b out at the
    start with forces no load balances. The force scale S of the stopping tests counted them (4e4
    times the 20 N load), so after 10 iterations the penalty's frame was converged, status ok, with
    a's clamp carrying 722 N of 20 N (the barrier's: 186 N of 29.4 N in the probe's scene). S now
    leaves contact out: the frame goes on (here to the Newton fallback) to equilibrium."""
    deck = stacked_blocks(model)
    deck["bodies"][1]["mesh"]["transform"] = {"translate": [0, 0.51, 0]}
    deck["loads"][0]["box"] = {"min": [-1, 1.0, -1], "max": [2, 1.02, 2]}
    deck["contact"]["distance"] = 0.0174
    deck["solver"] = {"type": "lbfgs"}
    out = run(tmp_path, model, deck)
    assert read_summary(out)["status"] == "ok"
    assert abs(read_reactions(out)["bodies[0].fixed[0]"]["fy"][-1] - 20.0) < 1e-3 * 20


def test_a_static_body_started_inside_a_colliders_layer_ends_at_equilibrium(tmp_path):
    """A cube 0.5 mm above a barrier plane (d = 1.7 mm, the default): the plane carries its weight
    to the static step's tolerance (measured 1.5e-3 in frame 1; before: 0.88 N of 2.94 N, status ok)."""
    deck = {"mesh": {"box": {"size": [0.1, 0.1, 0.1], "cells": [2, 2, 2]}, "transform": {"translate": [0.1, 0.5005, 0.1]}},
            "material": {"model": "neohookean", "youngs_modulus": 1.0e4, "poisson_ratio": 0.3, "density": 300},
            "gravity": [0, -9.81, 0],
            "colliders": [{"type": "plane", "point": [0, 0.5, 0], "normal": [0, 1, 0]}],
            "contact": {"model": "barrier"},
            "time": {"dt": 0.02, "frames": 2, "integrator": "static"}}
    out = run(tmp_path, "cube", deck)
    rows = list(csv.DictReader(open(out / "contact.csv")))
    weight = 300 * 1e-3 * 9.81
    assert read_summary(out)["status"] == "ok"
    assert all(abs(float(r["normal_force"]) - weight) < 1e-2 * weight for r in rows), rows


CUBE_ON_BLOCK = {
    "bodies": [
        {"name": "base", "mesh": {"box": {"size": [0.3, 0.1, 0.3], "cells": [3, 1, 3]}, "transform": {"translate": [0, 0.4, 0]}},
         "material": {"model": "neohookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 300},
         "fixed": [{"box": {"min": [-0.01, 0.39, -0.01], "max": [0.31, 0.41, 0.31]}}]},
        {"name": "cube", "mesh": {"box": {"size": [0.1, 0.1, 0.1], "cells": [2, 2, 2]}, "transform": {"translate": [0.1, 0.52, 0.1]}},
         "material": {"model": "neohookean", "youngs_modulus": 1.0e4, "poisson_ratio": 0.3, "density": 300}}],
    "gravity": [0, -9.81, 0],
    "contact": {"self": True, "model": "barrier"},
    "time": {"dt": 0.02, "frames": 2, "integrator": "static"},
    "output": {"reactions": True},
}


@pytest.mark.parametrize("ranks", [None, 2])
def test_a_cube_dropped_on_a_block_in_a_static_step_rests_on_it(tmp_path, ranks):
    """A cube 2 cm above a clamped block, barrier self-contact, static steps: nothing but contact
    holds the cube, so H0 = (M + s^2 L)^-1 moved it s^2 g = 1.6e5 m per resumed L-BFGS step; each
    step bound swept every pair (0.75 s per iteration on 59 vertices) and frame 1 had not ended
    after 100 s. Now the clamp carries both weights (29.43 N) in well under a second."""
    out = tmp_path / "out"
    run_hyperqn([write_deck(tmp_path / "cube.yaml", CUBE_ON_BLOCK), "-o", out], ranks=ranks, timeout=30)
    assert read_summary(out)["status"] == "ok"
    weight = (0.1 ** 3 + 0.3 * 0.1 * 0.3) * 300 * 9.81
    clamp = read_reactions(out)["bodies[0].fixed[0]"]
    assert all(abs(fy - weight) < 1e-3 * weight for fy in clamp["fy"]), clamp["fy"]
