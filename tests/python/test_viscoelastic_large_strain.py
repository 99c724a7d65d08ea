"""Viscoelasticity at large strain (docs/materials.md#viscoelasticity): homogeneous uniaxial stretch to
lambda = 2 at a constant rate, then held, against independent integrations of the same constitutive
equations.

The body: a unit cube (2 x 2 x 2 cells, 48 tets) on rollers: x held on x = 0, y on y = 0, z on z = 0
(symmetry planes), and x on x = 1 moved by a table curve from 0 to 1 over [0, T] then held, so the
stretch lambda(t) = 1 + t / T to 2 and the cube is traction-free laterally (uniaxial stress). Static
load steps (time.dt the real time, over which the branches relax). Neo-Hookean equilibrium part
(mu, lambda) and two Maxwell branches with tau = T/2 and 2T (comparable to the loading time). Every
tet's `cauchy_stress` is the same (linear tets pass the patch test: the spread is checked), and its
sigma_xx (and the frame's stretches, the affine fit of its positions) is compared with:

- `backward_euler`: the same time discretization written again in numpy from the model's equations
  (maxwell_branches.hpp's header comment): per step the trial strain e = 1/2 log(F C_v,n^-1 F^T) by an
  eigendecomposition, Kirchhoff stress mu (b - I) + lambda log J I + sum 2 mu_i tau_i/(tau_i + dt) dev e,
  the lateral stretch from tau_yy = 0 by a secant iteration, then C_v^-1 = F^-1 exp(2 eps_e) F^-T with
  eps_e = tau_i/(tau_i + dt) dev e + tr e / 3 I. To 1e-6 relative at every frame (measured about 1e-10).
- `continuous`: the continuous equations, which in this coaxial, non-rotating motion are additive in
  the principal log strains: eps_e = eps - eps_v, d eps_v / dt = dev eps_e / tau_i, one unknown a_i =
  eps_v,xx per branch (eps_v,yy = eps_v,zz = -a_i / 2), the lateral stretch again from tau_yy = 0:
  classical RK4 with T/4000 steps (halving its step changes it by 3e-14). hyperqn's error against it at dt = T/20,
  T/40 and T/80 gives the observed order in dt (first: backward Euler).
"""
import math

import numpy as np

from conftest import run_deck
from hyperqn_tools.output import frame_list, frame_meshes, tensors

MU, LAMBDA = 1.0e4, 2.0e4
BRANCHES = [(0.3, 0.5), (0.2, 2.0)]  # (g, tau): Prony fractions of the instantaneous shear modulus
T, HOLD = 1.0, 1.0                    # the stretch to 2 over [0, T], then held for HOLD
MUS = [g * MU / (1 - sum(b[0] for b in BRANCHES)) for g, _ in BRANCHES]  # branch shear moduli
TAUS = [tau for _, tau in BRANCHES]
EPS = 0.01


def plane(axis, value):
    lo, hi = [-EPS] * 3, [1 + EPS] * 3
    lo[axis], hi[axis] = value - EPS, value + EPS
    return {"min": lo, "max": hi}


def deck(dt):
    frames = int(round((T + HOLD) / dt))
    return {
        "name": "uniaxial_visco",
        "mesh": {"box": {"size": [1, 1, 1], "cells": [2, 2, 2]}},
        "material": {"model": "neohookean", "mu": MU, "lambda": LAMBDA, "density": 1000,
                     "viscoelastic": {"branches": [{"g": g, "tau": tau} for g, tau in BRANCHES]}},
        "fixed": [
            {"box": plane(0, 0.0), "components": ["x"]},
            {"box": plane(1, 0.0), "components": ["y"]},
            {"box": plane(2, 0.0), "components": ["z"]},
            {"box": plane(0, 1.0), "components": ["x"],
             "motion": {"translate": {"velocity": [1, 0, 0]},
                        "curve": {"type": "table", "points": [[0, 0], [T, 1]]}}},
        ],
        "gravity": [0, 0, 0],
        "time": {"dt": dt, "frames": frames, "integrator": "static"},
        "solver": {"type": "lbfgs", "iterations": 2000, "grad_rtol": 1e-12},
        "output": {"every": 1, "fields": ["cauchy_stress"]},
    }


def stretch(t):
    return 1 + min(t, T) / T


def dev(A):
    return A - np.trace(A) / 3 * np.eye(3)


def sym_fn(A, fn):
    w, V = np.linalg.eigh(A)
    return (V * fn(w)) @ V.T


def secant(f, x0, x1, tol=1e-15):
    f0, f1 = f(x0), f(x1)
    for _ in range(100):
        if f1 == f0 or abs(x1 - x0) <= tol * abs(x1):
            return x1
        x0, x1, f0 = x1, x1 - f1 * (x1 - x0) / (f1 - f0), f1
        f1 = f(x1)
    raise RuntimeError("the lateral stretch did not converge")


def backward_euler(dt, steps):
    """([sigma_xx], [lateral stretch]) at t = n dt, n = 1..steps: the discrete model, in tensors."""
    cv_inv = [np.eye(3) for _ in BRANCHES]
    m, out, lateral = 1.0, [], []

    def kirchhoff(lam, m, with_update=False):
        F = np.diag([lam, m, m])
        J = np.linalg.det(F)
        tau = MU * (F @ F.T - np.eye(3)) + LAMBDA * math.log(J) * np.eye(3)
        ends = []
        for mu_i, tau_i, c in zip(MUS, TAUS, cv_inv):
            e = 0.5 * sym_fn(F @ c @ F.T, np.log)
            tau = tau + 2 * mu_i * tau_i / (tau_i + dt) * dev(e)
            if with_update:
                eps_e = tau_i / (tau_i + dt) * dev(e) + np.trace(e) / 3 * np.eye(3)
                Fi = np.linalg.inv(F)
                ends.append(Fi @ sym_fn(2 * eps_e, np.exp) @ Fi.T)
        return tau, J, ends

    for n in range(1, steps + 1):
        lam = stretch(n * dt)
        m = secant(lambda mm: kirchhoff(lam, mm)[0][1, 1], m, m * (1 - 1e-3))
        tau, J, cv_inv = kirchhoff(lam, m, with_update=True)
        out.append(tau[0, 0] / J)
        lateral.append(m)
    return np.array(out), np.array(lateral)


def continuous(times, per_unit=4000):
    """sigma_xx at the given times (multiples of T / per_unit): RK4 of d a_i/dt = (2/3)(log(lam/m) -
    3/2 a_i) / tau_i with m from tau_yy = 0."""
    def lateral(lam, a, m0):
        def tyy(m):
            s = MU * (m * m - 1) + LAMBDA * math.log(lam * m * m)
            return s - sum(2 * mu / 3 * (math.log(lam / m) - 1.5 * ai) for mu, ai in zip(MUS, a))
        return secant(tyy, m0, m0 * (1 - 1e-3))

    def rate(t, a, m0):
        lam = stretch(t)
        m = lateral(lam, a, m0)
        return np.array([2 / 3 * (math.log(lam / m) - 1.5 * ai) / tau for ai, tau in zip(a, TAUS)]), m

    def sigma(t, a, m):
        lam = stretch(t)
        s = MU * (lam * lam - 1) + LAMBDA * math.log(lam * m * m)
        s += sum(4 * mu / 3 * (math.log(lam / m) - 1.5 * ai) for mu, ai in zip(MUS, a))
        return s / (lam * m * m)

    h = T / per_unit
    a, m, t, out = np.zeros(len(BRANCHES)), 1.0, 0.0, []
    for target in times:
        while t < target - 1e-12:
            k1, m = rate(t, a, m)
            k2, _ = rate(t + h / 2, a + h / 2 * k1, m)
            k3, _ = rate(t + h / 2, a + h / 2 * k2, m)
            k4, _ = rate(t + h, a + h * k3, m)
            a, t = a + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4), t + h
        m = lateral(stretch(t), a, m)
        out.append(sigma(t, a, m))
    return np.array(out)


def hyperqn_stresses(tmp_path, name, dt):
    """(times, mean sigma_xx, the deformation gradient's diagonal, worst spread over the tets /
    |sigma_xx|, worst |sigma_yy|, |sigma_zz| / |sigma_xx|) over frames 1..N."""
    out, _ = run_deck(tmp_path, name, deck(dt))
    times, sxx, stretches, spread, lateral = [], [], [], 0.0, 0.0
    for _, time, path in frame_list(out)[1:]:
        meshes = frame_meshes(path)
        x = np.concatenate([m.points for m in meshes])
        X = x - np.concatenate([m.point_data["displacement"] for m in meshes])
        F = np.linalg.lstsq(np.c_[X, np.ones(len(X))], x, rcond=None)[0][:3].T  # x = F X + c
        stretches.append(np.diag(F))
        s = np.concatenate([tensors(m.cell_data["cauchy_stress"][b]) for m in meshes for b in range(len(m.cells))])
        xx = s[:, 0, 0]
        times.append(time)
        sxx.append(xx.mean())
        spread = max(spread, (xx.max() - xx.min()) / abs(xx.mean()))
        lateral = max(lateral, np.abs(s[:, 1, 1]).max() / abs(xx.mean()), np.abs(s[:, 2, 2]).max() / abs(xx.mean()))
    return np.array(times), np.array(sxx), np.array(stretches), spread, lateral


def test_uniaxial_stretch_to_two_against_the_constitutive_equations(tmp_path):
    errors = {}
    for k in (20, 40, 80):
        dt = T / k
        steps = int(round((T + HOLD) / dt))
        times, sxx, stretches, spread, lateral = hyperqn_stresses(tmp_path, f"dt{k}", dt)
        assert len(times) == steps and np.allclose(times, dt * np.arange(1, steps + 1), rtol=0, atol=1e-12)
        be, be_lateral = backward_euler(dt, steps)
        exact = continuous(times)
        against_be = np.max(np.abs(sxx / be - 1))
        kinematics = max(np.max(np.abs(stretches[:, 0] / [stretch(t) for t in times] - 1)),
                         np.max(np.abs(stretches[:, 1:] / be_lateral[:, None] - 1)))
        errors[k] = np.max(np.abs(sxx - exact)) / np.max(np.abs(exact))
        peak = int(round(T / dt)) - 1
        print(f"dt = T/{k}: against backward Euler in numpy {against_be:.2e} (worst frame; stretches {kinematics:.1e}); "
              f"lateral stretch at lambda = 2 {be_lateral[int(round(T / dt)) - 1]:.6f}; against RK4 "
              f"{errors[k]:.3e} of the peak stress; sigma_xx at lambda = 2 {sxx[peak]:.6e} (RK4 {exact[peak]:.6e}), "
              f"at the end {sxx[-1]:.6e} (RK4 {exact[-1]:.6e}); spread over the tets {spread:.1e}, lateral "
              f"stress {lateral:.1e} of the axial")
        assert spread <= 1e-8 and lateral <= 1e-8  # homogeneous, uniaxial
        assert against_be <= 1e-6 and kinematics <= 1e-6
        # It relaxes while held (the branches' stress decays) but not to zero (the equilibrium part).
        assert np.all(np.diff(sxx[peak:]) < 0) and sxx[-1] > 0.5 * sxx[peak]
    orders = [math.log2(errors[k] / errors[2 * k]) for k in (20, 40)]
    # RK4's own error: halving its step changes it by far less than the errors measured.
    self_error = np.max(np.abs(continuous(times, 2000) - exact)) / np.max(np.abs(exact))
    print(f"observed order in dt against RK4: {orders[0]:.3f} (T/20 to T/40), {orders[1]:.3f} (T/40 to T/80); "
          f"RK4 T/2000 against T/4000: {self_error:.1e}")
    assert self_error <= 1e-3 * errors[80]
    assert all(abs(order - 1) <= 0.1 for order in orders)
