#!/usr/bin/env python3
"""Total energy against time per time integrator (docs/method.md#time-integrators): a cantilever
1 x 0.1 x 0.1 m (10 x 1 x 1 cubes, 60 tets, neo-Hookean, nu = 0.3, density 1000) clamped at x = 0,
released at rest under gravity, no damping. Kinetic + elastic + gravitational energy is 0 for the
exact motion, so its drift is the integrator's.

    export PYTHONPATH=$PWD/postprocess
    /usr/bin/python3 bench/integrator_energy.py [--out output/integrator_energy] [--cases small,large30,large120]

Cases: `small`: E = 1e8 (sags 1.5%: nearly a quadratic energy), h = 4 ms, 1,000 frames, Newton to
||grad g|| <= 1e-10 of its scale (only the integrator differs); `large30` and `large120`: E = 1e6
(swings through large deformation), 6 s at h = 1/30 and 1/120 s, lbfgs to 1e-8, up to 100
iterations per frame; `free_stretched`: the same bar free, without gravity, released from a 5 %
stretch along its length, E = 1e6, h = 5 ms, 2,000 steps, Newton to 1e-10 (the share of its
initial energy lost by step 10 and by the end is printed too). Prints a table (largest kinetic energy, total at the end, largest |total|
over the largest kinetic energy, wall seconds), writes energy.csv (per frame), energy.json and
energy.png (total energy against time, one panel per case) into --out.
"""
import argparse
import csv
import json
import os
import sys
import time

from hyperqn_tools import launch
from hyperqn_tools.decks import write_deck
from hyperqn_tools.energy import neohookean_energies
from hyperqn_tools.output import frame_list, read_summary
from hyperqn_tools.paths import REPO

INTEGRATORS = ("implicit-euler", "bdf2", "implicit-midpoint")
NU, RHO, G = 0.3, 1000.0, 9.81
CASES = {  # name: (E, h, frames, solver)
    "small": (1.0e8, 4.0e-3, 1000, {"type": "newton", "iterations": 30, "budget": "fixed", "grad_rtol": 1e-10,
                                     "grad_atol": 0}),
    "large30": (1.0e6, 1.0 / 30, 180, {"type": "lbfgs", "iterations": 100, "grad_rtol": 1e-8}),
    "large120": (1.0e6, 1.0 / 120, 720, {"type": "lbfgs", "iterations": 100, "grad_rtol": 1e-8}),
    # A free bar, no gravity, released from a 5 % stretch along its length: it vibrates about its rest
    # length (the first axial mode's period 2 L / sqrt(E / rho) = 63 ms, 12.6 steps).
    "free_stretched": (1.0e6, 5.0e-3, 2000, {"type": "newton", "iterations": 30, "budget": "fixed", "grad_rtol": 1e-10,
                                              "grad_atol": 0}),
}
FREE = {"free_stretched"}  # no clamp, no gravity, the initial stretch


def deck(name, integrator):
    E, h, frames, solver = CASES[name]
    d = {
        "name": f"{name}-{integrator}",
        "mesh": {"box": {"size": [1.0, 0.1, 0.1], "cells": [10, 1, 1]}},
        "material": {"model": "neohookean", "youngs_modulus": E, "poisson_ratio": NU, "density": RHO},
        "fixed": [{"box": {"min": [-0.001, -0.001, -0.001], "max": [0.001, 0.101, 0.101]}}],
        "gravity": [0, -G, 0],
        "time": {"dt": h, "frames": frames, "integrator": integrator},
        "solver": solver,
        "output": {"every": 1},
    }
    if name in FREE:
        del d["fixed"]
        d["gravity"] = [0, 0, 0]
        d["initial"] = {"squash": {"axis": 0, "factor": 1.05}}
    return d


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=os.path.join(REPO, "output", "integrator_energy"))
    ap.add_argument("--cases", default=",".join(CASES), help="comma list of " + ", ".join(CASES))
    ap.add_argument("--hyperqn", default=launch.default_binary())
    args = ap.parse_args()
    cases = args.cases.split(",")
    unknown = [c for c in cases if c not in CASES]
    if unknown:
        sys.exit(f"--cases: unknown {', '.join(unknown)}; known: {', '.join(CASES)}")
    os.makedirs(args.out, exist_ok=True)
    rows, series = [], {}
    print(f"{'case':<9s} {'integrator':<18s} {'largest KE (J)':>14s} {'total at end (J)':>16s} "
          f"{'max|total|/KE':>13s} {'wall s':>7s}")
    for name in cases:
        E, h = CASES[name][0], CASES[name][1]
        for integrator in INTEGRATORS:
            out = os.path.join(args.out, "runs", f"{name}-{integrator}")
            os.makedirs(os.path.join(args.out, "decks"), exist_ok=True)
            path = write_deck(os.path.join(args.out, "decks", f"{name}-{integrator}.yaml"), deck(name, integrator))
            start = time.time()
            proc = launch.run([path, "-o", out], 1, args.hyperqn)
            wall = time.time() - start
            status = read_summary(out)["status"] if proc.returncode == 0 else f"exit {proc.returncode}"
            e = [neohookean_energies(p, E, NU, RHO, 0.0 if name in FREE else G) for _, _, p in frame_list(out)]
            total = [sum(x) for x in e]
            peak = max(x[0] for x in e)
            # A case that starts with energy (the free bar's stretch): the share of it lost.
            lost = {k: 1 - total[k] / total[0] for k in (10, len(total) - 1)} if total[0] > 0 else {}
            series[(name, integrator)] = [(k * h, t) for k, t in enumerate(total)]
            row = {"case": name, "integrator": integrator, "status": status, "largest_kinetic_J": peak,
                   "total_at_end_J": total[-1], "largest_abs_total_over_kinetic": max(abs(t) for t in total) / peak,
                   "wall_s": wall, "euler_completed_steps": read_summary(out).get("euler_completed_steps"),
                   "lost_by_step": lost}
            rows.append(row)
            losses = "  ".join(f"lost by step {k}: {100 * x:.1f}%" for k, x in lost.items())
            print(f"{name:<9s} {integrator:<18s} {peak:14.4g} {total[-1]:+16.4g} "
                  f"{row['largest_abs_total_over_kinetic']:13.3g} {wall:7.1f}  {status}  {losses}", flush=True)
    with open(os.path.join(args.out, "energy.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["case", "integrator", "time_s", "total_energy_J"])
        for (name, integrator), points in series.items():
            w.writerows([name, integrator, t, e] for t, e in points)
    with open(os.path.join(args.out, "energy.json"), "w") as f:
        json.dump(rows, f, indent=1)
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, len(cases), figsize=(5 * len(cases), 3.6), squeeze=False)
    for ax, name in zip(axes[0], cases):
        for integrator in INTEGRATORS:
            t, e = zip(*series[(name, integrator)])
            ax.plot(t, e, label=integrator)
        E, h, frames, _ = CASES[name]
        ax.set_title(f"{name}: E = {E:g} Pa, h = {h:.3g} s")
        ax.set_xlabel("time (s)")
        ax.set_ylabel("total energy (J)")
        ax.grid(alpha=0.3)
        ax.legend()
    fig.tight_layout()
    fig.savefig(os.path.join(args.out, "energy.png"), dpi=110)
    print(f"wrote {args.out}/energy.csv, energy.json, energy.png")


if __name__ == "__main__":
    main()
