#!/usr/bin/env python3
"""Measures the L-BFGS defaults on a deck: warm start (inertial y vs previous x_n) and the TAO line
search (more-thuente, armijo, unit). Two views per combination:
  - budget: the deck's 10 iterations per frame -> mean final |grad g| and ms/frame;
  - converge: up to 500 iterations until |grad g| <= --atol -> mean iterations, evaluations and
    ms per frame, and how many frames reached the tolerance.
Prints a table and writes solver_defaults.csv in --out. Needs postprocess/ on PYTHONPATH
(see bench/README.md)."""
import argparse
import csv
import os
import subprocess

from hyperqn_tools import cli, launch
from hyperqn_tools.decks import load_deck, portable_copy, write_deck
from hyperqn_tools.output import read_iterations, read_summary
from hyperqn_tools.paths import REPO


def run(deck, outdir, ranks, hyperqn, mpiexec):
    os.makedirs(outdir, exist_ok=True)
    path = write_deck(os.path.join(outdir, "deck.yaml"), deck)
    launch.run([path, "-o", outdir], ranks, hyperqn, mpiexec, stdout=subprocess.DEVNULL, stderr=None, check=True)
    return read_summary(outdir), read_iterations(outdir)


def mean_final_grad(rows):
    last = {}
    for r in rows:
        last[r["frame"]] = r["grad_norm"]
    return sum(last.values()) / len(last)


def main():
    p = cli.ArgumentParser(description=__doc__)
    p.add_argument("--deck", type=cli.input_file, default=os.path.join(REPO, "input/bar.yaml"))
    p.add_argument("--frames", type=cli.positive_int, default=50)
    p.add_argument("--ranks", type=cli.positive_int, default=1)
    p.add_argument("--atol", type=cli.positive_float, default=1e-6)
    p.add_argument("--out", default=os.path.join(REPO, "output/solver_defaults"))
    p.add_argument("--hyperqn", type=cli.program, default=launch.default_binary(), help="default: $HYPERQN_BIN, else build/hyperqn")
    p.add_argument("--mpiexec", type=cli.program, default=launch.default_mpiexec(), help="default: $MPIEXEC, else mpiexec")
    args = p.parse_args()
    why = cli.unwritable_dir(args.out)
    if why:
        p.error(f"--out {why}")
    base = portable_copy(load_deck(args.deck), args.deck)
    base["time"]["frames"] = args.frames
    base["output"] = {"vtk": False}
    rows = []
    for warm in ("inertial", "previous"):
        for ls in ("more-thuente", "armijo", "unit"):
            row = {"warm_start": warm, "line_search": ls}
            for mode, its, atol in (("budget", 10, 0.0), ("converge", 500, args.atol)):
                deck = dict(base)
                deck["solver"] = {**base.get("solver", {}), "warm_start": warm, "line_search": ls,
                                  "iterations": its, "grad_atol": atol, "grad_rtol": 0.0}
                s, it = run(deck, os.path.join(args.out, f"{warm}_{ls}_{mode}"), args.ranks, args.hyperqn, args.mpiexec)
                if mode == "budget":
                    row.update(budget_final_grad=mean_final_grad(it), budget_ms_per_frame=s["ms_per_frame"],
                               budget_evals_per_frame=s["evaluations"] / s["frames"])
                else:
                    row.update(converge_iterations=s["mean_iterations"], converge_evals_per_frame=s["evaluations"] / s["frames"],
                               converge_ms_per_frame=s["ms_per_frame"], converged_frames=s["converged_frames"])
            rows.append(row)
            print(f"{warm:9s} {ls:13s} budget: |g| {row['budget_final_grad']:.2e} "
                  f"{row['budget_evals_per_frame']:5.1f} evals {row['budget_ms_per_frame']:7.2f} ms | "
                  f"converge: {row['converge_iterations']:6.1f} it {row['converge_evals_per_frame']:6.1f} evals "
                  f"{row['converge_ms_per_frame']:7.2f} ms ({row['converged_frames']}/{args.frames} frames)", flush=True)
    with open(os.path.join(args.out, "solver_defaults.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


if __name__ == "__main__":
    main()
