#!/usr/bin/env python3
"""No result changes: runs a fixed set of decks with two hyperqn binaries and compares the results,
for a restructuring that must not change what hyperqn computes.

    export PYTHONPATH=$PWD/postprocess                 # from the repository root
    /usr/bin/python3 scripts/compare_revisions.py --base-bin OLD/hyperqn --new-bin build/hyperqn
    /usr/bin/python3 scripts/compare_revisions.py --base-rev HEAD [--new-bin build/hyperqn]

--base-rev REV builds that git revision instead (a `git worktree` in a temporary directory, cmake
Release, target hyperqn), uses its binary and removes the worktree at the end.

Per deck and rank count it compares
  - the final positions (the last VTK frame, vertices matched by vertex_id): max |x_new - x_base|
    over the rest bounding-box diagonal, and whether they are bitwise equal;
  - the iteration count of every frame (iterations.csv: the largest iteration index of the frame).
A case passes when the positions agree within --tol (1e-10) of the diagonal and every frame took
as many iterations. Prints a table, writes JSON to --out (decks and runs beside it) and exits 1 if
any case fails. Long decks run fewer frames (a copy of the deck with time.frames reduced); every
copy writes VTK. The 1-rank runs use the binary alone, the others mpiexec.

Runs at 1 rank are bitwise reproducible; runs at 2 ranks are not, run to run with one binary
(measured: up to 4e-14 of the diagonal, same iteration counts), which the tolerance allows.
"""
import argparse
import contextlib
import copy
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

from hyperqn_tools import launch
from hyperqn_tools.cli import ArgumentParser, fraction, positive_int, program, unwritable_file
from hyperqn_tools.compare import final_frames
from hyperqn_tools.decks import load_deck, portable_copy, write_deck
from hyperqn_tools.output import frames_of_iterations, read_iterations, rest_diagonal
from hyperqn_tools.paths import REPO

# Three materials in one body, which no deck of the repository has: a corotated bar with a
# mass-spring middle third and a principal-stretch end third with a fibre along the bar.
MIXED_MATERIALS = {
    "name": "mixed_materials",
    "mesh": {"box": {"size": [3.0, 0.5, 0.5], "cells": [12, 2, 2]}},
    "material": {"model": "corotated", "youngs_modulus": 1.0e6, "poisson_ratio": 0.3, "density": 1000},
    "regions": [
        {"box": {"min": [1.0, -1, -1], "max": [2.0, 1, 1]},
         "material": {"model": "mass-spring", "spring_stiffness": 2.0e4, "density": 1000}},
        {"box": {"min": [2.0, -1, -1], "max": [4.0, 1, 1]},
         "material": {"model": "principal-stretch", "f": {"polynomial": [0, 0, 3.8e5]},
                      "h": {"polynomial": [0, 0, 2.9e5]}, "fiber": {"direction": [1, 0, 0], "stiffness": 2.0e6},
                      "density": 1000}},
    ],
    "fixed": [{"box": {"min": [-0.01, -1, -1], "max": [0.01, 1, 1]}}],
    "gravity": [0, -9.81, 0],
    "time": {"dt": 0.04, "frames": 15},
    "solver": {"type": "lbfgs", "iterations": 20},
}

# (name, deck: a path from the repository root, a (path, {section: replacement}) pair or a dict,
# rank counts, frames or None: the deck's, and optionally extra command-line options)
CASES = [
    ("bar", "input/bar.yaml", (1, 2), 20),
    ("strands", "input/strands.yaml", (2,), 30),
    ("newton_box", "tests/decks/newton_box.yaml", (1, 2), None),
    ("pd_arap", "tests/decks/pd_arap.yaml", (1,), None),
    ("pd_neohookean", "tests/decks/pd_neohookean.yaml", (1,), None),
    ("twist", "tests/decks/stability_twist.yaml", (1,), None),
    ("fling_release", "tests/decks/guardrails_fling.yaml", (1,), 40),  # released at frame 30
    ("box_on_rope", "tests/decks/box_on_rope.yaml", (1, 2), None),
    ("mixed_materials", MIXED_MATERIALS, (1, 2), None),
    ("guardrails_bar", "tests/decks/guardrails_bar.yaml", (1,), None),
    # The guardrails at work: g is NaN at far trial points (the test hook's term), first trials of 100.
    ("guardrails_nan", "tests/decks/guardrails_bar.yaml", (1, 2), None,
     ["-hyperqn_test_nan_energy_beyond", "0.2", "-tao_ls_stepinit", "100"]),
    # Self-contact: two blocks that meet (Newton), a cloth that folds onto itself (L-BFGS, barrier).
    ("self_blocks", "tests/decks/self_contact_blocks.yaml", (1, 2), None),
    ("cloth_pile", "input/contact/cloth_pile.yaml", (1, 2), 8),
    # The blocks with the penalty, whose frames end with a count of the crossing triangles.
    ("self_penalty", ("tests/decks/self_contact_blocks.yaml",
                      {"contact": {"self": True, "model": "penalty", "distance": 5.0e-3}}), (1, 2), None),
    # Scripted cuts: H0 corrected across each cut at 1 rank (factored again at 2), and factored again.
    ("bar_sliced", "input/topology/bar_sliced.yaml", (1, 2), None),
    ("bar_sliced_refactor", "input/topology/bar_sliced.yaml", (1,), None, ["-hyperqn_topology_h0", "false"]),
]
TIMEOUT_S = 300


def prepared_deck(name, source, frames, deckdir):
    """Writes the deck to run (absolute mesh path, VTK on, fewer frames if asked); returns its path."""
    if isinstance(source, dict):
        deck = copy.deepcopy(source)
    else:
        source, changes = source if isinstance(source, tuple) else (source, {})
        path = os.path.join(REPO, source)
        deck = {**portable_copy(load_deck(path), path), **changes}
    if frames:
        deck["time"]["frames"] = frames
    deck["output"] = {**(deck.get("output") or {}), "vtk": True}
    return write_deck(os.path.join(deckdir, f"{name}.yaml"), deck)


def run(binary, deck_path, ranks, outdir, options=()):
    """Runs hyperqn into a fresh outdir; returns an error text, or None when it exited 0."""
    shutil.rmtree(outdir, ignore_errors=True)
    try:
        proc = launch.run([deck_path, "-o", outdir, *options], None if ranks == 1 else ranks, binary, timeout=TIMEOUT_S)
    except subprocess.TimeoutExpired:
        return f"timeout after {TIMEOUT_S} s"
    os.makedirs(outdir, exist_ok=True)
    with open(os.path.join(outdir, "run.log"), "w") as f:
        f.write(" ".join(proc.args) + "\n" + proc.stdout)
    return None if proc.returncode == 0 else f"exit {proc.returncode}: {proc.stdout.strip()[-300:]}"


def iterations_per_frame(outdir):
    """{frame: largest iteration index of the frame} from iterations.csv."""
    return {frame: max(r["iteration"] for r in rows)
            for frame, rows in frames_of_iterations(read_iterations(outdir)).items()}


def compare(base_dir, new_dir, tol):
    """The comparison of two runs of one deck, as a dict (see the module docstring)."""
    base, new = final_frames(base_dir, new_dir)
    its_base, its_new = iterations_per_frame(base_dir), iterations_per_frame(new_dir)
    rel = float(np.max(np.linalg.norm(new.points - base.points, axis=1))) / rest_diagonal(base)
    differing = [f for f in sorted(set(its_base) | set(its_new)) if its_base.get(f) != its_new.get(f)]
    return {"max_rel_diff": rel, "bitwise": bool(np.array_equal(new.points, base.points)),
            "iterations_equal": not differing, "frames_with_other_iterations": differing,
            "pass": rel <= tol and not differing}


@contextlib.contextmanager
def built_revision(rev, jobs):
    """Yields the hyperqn binary of git revision rev, built in a temporary worktree."""
    with tempfile.TemporaryDirectory(prefix="hyperqn-rev-") as tmp:
        src, build = os.path.join(tmp, "src"), os.path.join(tmp, "build")
        subprocess.run(["git", "-C", REPO, "worktree", "add", "--detach", src, rev], check=True)
        try:
            subprocess.run(["cmake", "-S", src, "-B", build, "-DCMAKE_BUILD_TYPE=Release"], check=True,
                           stdout=subprocess.DEVNULL)
            subprocess.run(["cmake", "--build", build, "-j", str(jobs), "--target", "hyperqn"], check=True,
                           stdout=subprocess.DEVNULL)
            yield os.path.join(build, "hyperqn")
        finally:
            subprocess.run(["git", "-C", REPO, "worktree", "remove", "--force", src], check=False)


def print_table(results):
    head = f"{'deck':<16} {'ranks':>5} {'max rel diff':>12} {'bitwise':>7} {'iterations equal':>16}  verdict"
    print(head + "\n" + "-" * len(head))
    for r in results:
        if "error" in r:
            print(f"{r['deck']:<16} {r['ranks']:>5} {'-':>12} {'-':>7} {'-':>16}  FAIL ({r['error']})")
            continue
        print(f"{r['deck']:<16} {r['ranks']:>5} {r['max_rel_diff']:>12.3e} {'yes' if r['bitwise'] else 'no':>7} "
              f"{'yes' if r['iterations_equal'] else 'no':>16}  {'pass' if r['pass'] else 'FAIL'}")


def compare_binaries(base_bin, new_bin, names, tol, workdir):
    deckdir = os.path.join(workdir, "decks")
    os.makedirs(deckdir, exist_ok=True)
    results = []
    for name, source, ranks_list, frames, *options in CASES:
        options = options[0] if options else ()
        if names and name not in names:
            continue
        deck = prepared_deck(name, source, frames, deckdir)
        for ranks in ranks_list:
            t0 = time.time()
            dirs = {side: os.path.join(workdir, "runs", side, f"{name}-np{ranks}") for side in ("base", "new")}
            errors = {side: run(binary, deck, ranks, dirs[side], options)
                      for side, binary in (("base", base_bin), ("new", new_bin))}
            result = {"deck": name, "ranks": ranks, "deck_file": deck}
            failed = [f"{side} run: {e}" for side, e in errors.items() if e]
            if failed:
                result.update({"error": "; ".join(failed), "pass": False})
            else:
                result.update(compare(dirs["base"], dirs["new"], tol))
            result["seconds"] = round(time.time() - t0, 1)
            print(f"[{result['seconds']:6.1f} s] {name} np{ranks}: {'pass' if result['pass'] else 'FAIL'}",
                  file=sys.stderr, flush=True)
            results.append(result)
    return results


def main():
    p = ArgumentParser(prog="scripts/compare_revisions.py", description=__doc__,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    base = p.add_mutually_exclusive_group(required=True)
    base.add_argument("--base-bin", type=program, help="hyperqn binary of the base")
    base.add_argument("--base-rev", help="git revision to build and use as the base")
    p.add_argument("--new-bin", type=program, default=launch.default_binary(), help="default: $HYPERQN_BIN, else build/hyperqn")
    p.add_argument("--out", default=os.path.join(REPO, "output", "compare_revisions", "result.json"),
                   help="JSON result; the decks and runs go into its directory")
    p.add_argument("--cases", help="comma list of deck names (default: all): " + ",".join(c[0] for c in CASES))
    p.add_argument("--tol", type=fraction, default=1e-10, help="max |x_new - x_base| / rest diagonal")
    p.add_argument("--jobs", type=positive_int, default=os.cpu_count() or 1, help="build jobs for --base-rev")
    args = p.parse_args()
    names = [n.strip() for n in args.cases.split(",")] if args.cases else []
    unknown = set(names) - {c[0] for c in CASES}
    if unknown:
        p.error(f"unknown case(s) {sorted(unknown)}")
    why = unwritable_file(args.out)
    if why:  # said now, not after every run has finished
        p.error(f"--out {why}")
    workdir = os.path.dirname(os.path.abspath(args.out))

    with contextlib.ExitStack() as stack:
        base_bin = args.base_bin or stack.enter_context(built_revision(args.base_rev, args.jobs))
        base_bin, new_bin = os.path.abspath(base_bin), os.path.abspath(args.new_bin)
        for b in (base_bin, new_bin):
            if not os.access(b, os.X_OK):
                sys.exit(f"{b}: not an executable")
        results = compare_binaries(base_bin, new_bin, names, args.tol, workdir)

    print_table(results)
    ok = all(r["pass"] for r in results)
    with open(args.out, "w") as f:
        json.dump({"base": args.base_rev or base_bin, "new": new_bin, "tol": args.tol, "pass": ok,
                   "results": results}, f, indent=1)
    print(f"\n{'all pass' if ok else 'FAILED'}; wrote {args.out}")
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
