"""Every material model runs a sagging bar with lbfgs and newton: no NaN, g never increases
within a frame, same positions at 1 and 2 ranks."""
import numpy as np
import pytest

from conftest import run_hyperqn, write_deck
from hyperqn_tools.compare import relative_difference
from hyperqn_tools.output import final_frame, read_iterations, read_summary

E, NU = 1.0e5, 0.3
MU, LAMBDA = E / (2 * (1 + NU)), E * NU / ((1 + NU) * (1 - 2 * NU))
MATERIALS = {
    "corotated": {"model": "corotated", "youngs_modulus": E, "poisson_ratio": NU},
    "neohookean": {"model": "neohookean", "youngs_modulus": E, "poisson_ratio": NU},
    "stvk": {"model": "stvk", "youngs_modulus": E, "poisson_ratio": NU, "kappa": 10 * E},
    # f(s) = mu (s - 1)^2, h(J) = lambda/2 (J - 1)^2: a corotated-like principal-stretch energy.
    "principal_polynomial": {"model": "principal-stretch", "f": {"polynomial": [0, 0, MU]},
                             "h": {"polynomial": [0, 0, LAMBDA / 2]}},
    # The same stress curves as splines through control points of f' and h'.
    "principal_spline": {"model": "principal-stretch",
                         "f": {"spline": {"x": [0.0, 1.0, 2.0], "y": [-2 * MU, 0.0, 2 * MU]}},
                         "h": {"spline": {"x": [0.0, 1.0, 2.0], "y": [-LAMBDA, 0.0, LAMBDA]}}},
    # k per tet edge chosen so the bar sags about as much as the continuum ones.
    "mass_spring": {"model": "mass-spring", "spring_stiffness": 2.0e3},
    "hencky": {"model": "hencky", "youngs_modulus": E, "poisson_ratio": NU},
    # J2 plasticity over it, yielding at the root as it sags (docs/inelastic.md#plasticity).
    "hencky_plastic": {"model": "hencky", "youngs_modulus": E, "poisson_ratio": NU,
                       "plastic": {"yield_stress": 2.0e3, "isotropic_hardening": 1.0e4, "kinematic_hardening": 1.0e4}},
    "neohookean_fiber": {"model": "neohookean", "youngs_modulus": E, "poisson_ratio": NU,
                         "fiber": {"direction": [1, 0, 0], "stiffness": 5 * E}},
}


def deck(material, solver):
    return {
        "mesh": {"box": {"size": [2.0, 0.4, 0.4], "cells": [10, 2, 2]}},
        "material": dict(material, density=1000),
        "fixed": [{"box": {"min": [-0.01, -1, -1], "max": [0.01, 1, 1]}}],
        "time": {"dt": 0.04, "frames": 8},
        "solver": {"type": solver, "iterations": 20},
    }


@pytest.mark.parametrize("solver", ["lbfgs", "newton"])
@pytest.mark.parametrize("name", sorted(MATERIALS))
def test_material_runs(tmp_path, name, solver):
    out = tmp_path / "out"
    run_hyperqn([write_deck(tmp_path / "d.yaml", deck(MATERIALS[name], solver)), "-o", out], ranks=None)
    s = read_summary(out)
    assert s["status"] == "ok" and s["frames"] == 8
    rows = read_iterations(out)
    assert all(np.isfinite([r["energy"], r["grad_norm"]]).all() for r in rows)
    for prev, cur in zip(rows, rows[1:]):
        if cur["frame"] == prev["frame"]:
            assert cur["energy"] <= prev["energy"] * (1 + 1e-13) + 1e-300, (prev, cur)
    f = final_frame(out)
    assert np.all(np.isfinite(f.points)) and f.displacement[:, 1].min() < -1e-3  # it sags


def test_principal_stretch_reproduces_arap_at_one_and_two_ranks(tmp_path):
    # With lambda = 0, corotated is psi = mu sum (s_i - 1)^2: exactly f(s) = mu (s - 1)^2, as a
    # polynomial or as the spline of f'(s) = 2 mu (s - 1) (linear, so the spline is exact).
    materials = {
        "arap": {"model": "corotated", "mu": MU, "lambda": 0},
        "polynomial": {"model": "principal-stretch", "f": {"polynomial": [0, 0, MU]}},
        "spline": {"model": "principal-stretch", "f": {"spline": {"x": [0.0, 1.0, 2.0], "y": [-2 * MU, 0.0, 2 * MU]}}},
    }
    outs = {}
    for (name, material), ranks in zip(materials.items(), (1, 2, 1)):
        d = deck(material, "newton")
        d["solver"].update(iterations=50, grad_rtol=1e-12)
        outs[name] = tmp_path / name
        run_hyperqn([write_deck(tmp_path / f"{name}.yaml", d), "-o", outs[name]], ranks=ranks)
    for name in ("polynomial", "spline"):
        rel, _, _ = relative_difference(outs["arap"], outs[name])
        assert rel <= 1e-8, f"{name}: {rel:.2e}"


def test_mass_spring_pd_is_exact_and_matches_lbfgs_history_0(tmp_path):
    # Springs are a Projective Dynamics energy: pd takes alpha = 1 without a line search, never
    # increases g, and equals lbfgs with no history (H = A^{-1}) step for step.
    outs = {}
    for name, solver in (("pd", {"type": "pd"}), ("lbfgs0", {"type": "lbfgs", "history": 0, "line_search": "unit"})):
        d = deck(MATERIALS["mass_spring"], "pd")
        d["solver"] = dict(solver, iterations=15)
        outs[name] = tmp_path / name
        proc = run_hyperqn([write_deck(tmp_path / f"{name}.yaml", d), "-o", outs[name]], ranks=None)
        if name == "pd":
            assert "exact local-global steps" in proc.stdout
    rows = {n: read_iterations(o) for n, o in outs.items()}
    assert all(r["step"] == 1 for r in rows["pd"] if r["iteration"] >= 1)
    for prev, cur in zip(rows["pd"], rows["pd"][1:]):
        if cur["frame"] == prev["frame"]:
            assert cur["energy"] <= prev["energy"]
    assert len(rows["pd"]) == len(rows["lbfgs0"])
    for p, q in zip(rows["pd"], rows["lbfgs0"]):
        assert abs(p["energy"] - q["energy"]) <= 1e-10 * abs(p["energy"])
