#!/usr/bin/env python3
"""Fuzzes hyperqn's inputs: decks, meshes and command-line options, mutated from a small valid
scene. Every run must end cleanly:

  - no crash: the exit code is 0, 1, or 2 with status "inverted" (a signal, an abort or an MPI abort is a crash);
  - no hang: each run finishes within --timeout seconds;
  - rejected input writes nothing: a run that exits 1 before its first frame leaves no output
    directory (a run that started and then stopped, e.g. diverged, has its summary.json);
  - every failure says "hyperqn: error" and no raw PETSc trace.

    PYTHONPATH=$PWD/postprocess /usr/bin/python3 scripts/fuzz.py --cases 1000     # make fuzz
    PYTHONPATH=$PWD/postprocess /usr/bin/python3 scripts/fuzz.py --cases 60 --budget 50

Cases are drawn from --seed, so a run is reproducible; a failing case's deck, mesh and command
are kept in --out/failures/ and listed. Prints counts per outcome and writes fuzz.json; exits 1
if any case failed.
"""
import argparse
import copy
import json
import os
import random
import shutil
import subprocess
import sys
import time

import yaml

from hyperqn_tools import launch
from hyperqn_tools.paths import REPO

BASE = {
    "name": "fuzz",
    "mesh": {"box": {"size": [1.0, 0.25, 0.25], "cells": [4, 1, 1]}},
    "material": {"model": "neohookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 1000},
    "fixed": [{"box": {"min": [-0.01, -1, -1], "max": [0.01, 1, 1]}}],
    "gravity": [0, -9.81, 0],
    "time": {"dt": 0.0333333333, "frames": 3},
    "solver": {"type": "lbfgs", "iterations": 10},
    "output": {"every": 1},
}
MESH = ("MeshVersionFormatted 1\nDimension 3\nVertices\n5\n0 0 0 1\n1 0 0 1\n0 1 0 1\n0 0 1 1\n1 1 1 1\n"
        "Tetrahedra\n2\n1 2 3 4 1\n2 3 4 5 2\nEdges\n1\n1 2 0\nEnd\n")
GMSH = ("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Entities\n0 0 1 1\n1 0 0 0 1 1 1 0 0\n1 0 0 0 1 1 1 1 2 1 1\n"
        "$EndEntities\n$Nodes\n1 5 1 5\n3 1 0 5\n1\n2\n3\n4\n5\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 1 1\n$EndNodes\n"
        "$Elements\n2 3 1 3\n2 1 2 1\n1 1 2 3\n3 1 4 2\n2 1 2 3 4\n3 2 3 4 5\n$EndElements\n")

# Values a fuzzer tries anywhere: wrong types, edges of ranges, overflow, text, structure.
ODD_VALUES = [0, -1, 1, 2147483647, -2147483648, 1e308, -1e308, 1e-320, float("nan"), float("inf"), 0.5, 1e100,
              "", "x", "0x10", "1e5", "..", "a/b", "a\nb", None, True, [], [1], [1, 2, 3, 4], {}, {"a": 1},
              [[1, 2, 3]], "\0", "é" * 300]
KEYS = ["name", "mesh", "material", "fixed", "gravity", "time", "solver", "output", "regions", "initial",
        "strand_material", "study", "petsc", "colliders", "contact", "attachments", "cloth", "bogus"]
CLOTH = {"mesh": {"sheet": {"size": [1.0, 0.5], "cells": [4, 2]}},
         "cloth": {"model": "mass-spring", "stretch_stiffness": 100.0, "bending": {"model": "quadratic", "stiffness": 1e-3},
                   "areal_density": 0.2},
         "fixed": [{"box": {"min": [-0.01, -0.01, 0.49], "max": [0.01, 0.01, 0.51]}}]}
CLOTH_OBJ = "v 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nv 0.5 0.2 0.5\nf 1 2 5\nf 2 3 5\nf 3 4 5\nf 4 1 5\n"
OBJ = "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nf 1 4 3\nf 1 3 2\n"
COLLIDERS = [{"type": "plane", "point": [0, -0.1, 0], "normal": [0, 1, 0], "friction": 0.3},
             {"type": "sphere", "center": [0.5, 0.5, 0.5], "radius": 0.2},
             {"type": "box", "min": [-1, -1, -1], "max": [2, -0.05, 2]},
             {"type": "capsule", "a": [0, 0.5, -1], "b": [0, 0.5, 2], "radius": 0.1},
             {"type": "mesh", "file": "fuzz.obj", "friction": 0.2}]
COLLIDER_KEYS = ["type", "point", "normal", "center", "radius", "min", "max", "a", "b", "file", "friction", "motion"]
SUBKEYS = {"mesh": ["box", "file", "transform", "edges", "strands"],
           "material": ["model", "youngs_modulus", "poisson_ratio", "mu", "lambda", "density", "total_mass", "J0",
                        "kappa", "laplacian_weight", "fiber", "spring_stiffness", "f"],
           "time": ["dt", "frames", "damping"],
           "solver": ["type", "iterations", "grad_atol", "grad_rtol", "history", "line_search", "warm_start",
                      "newton_method", "linear_solver", "newton_hessian", "h0"],
           "output": ["every", "vtk", "iterations_csv", "contact_csv", "directory"],
           "contact": ["model", "distance", "stiffness", "friction_velocity"],
           "cloth": ["model", "stretch_stiffness", "material", "youngs_modulus", "poisson_ratio", "bending",
                     "areal_density"]}
OPTIONS = ["-tao_type", "-tao_ls_type", "-tao_max_it", "-tao_gatol", "-tao_lmvm_mat_lmvm_hist_size",
           "-h0_mat_mumps_icntl_7", "-h0_mat_mumps_icntl_14", "-hyperqn_divergence_limit", "-tao_ls_stepinit",
           "-tao_bogus_option", "-hyperqn_h0_package", "-h0_mat_cholmod_factor"]
OPTION_VALUES = ["0", "-1", "1", "nan", "inf", "abc", "1e308", "lmvm", "nls", "armijo", "unit", "", "99999999999",
                 "mumps", "cholmod", "supernodal"]


def mutate_deck(rng, deck):
    """One to three mutations: a value replaced, a key removed, or an unknown key added."""
    d = copy.deepcopy(deck)
    for _ in range(rng.randint(1, 3)):
        kind = rng.random()
        section = rng.choice(KEYS)
        if kind < 0.15:
            d.pop(section, None)
        elif kind < 0.35 or section not in SUBKEYS:
            d[section] = rng.choice(ODD_VALUES)
        else:
            node = d.setdefault(section, {})
            if not isinstance(node, dict):
                node = d[section] = {}
            key = rng.choice(SUBKEYS[section] + ["bogus"])
            node[key] = rng.choice(ODD_VALUES + [rng.uniform(-10, 10), rng.randint(-5, 50)])
    return d


def mutate_mesh(rng, text):
    """A mesh text with a line changed, removed, duplicated or cut, or bytes flipped."""
    lines = text.splitlines(keepends=True)
    kind = rng.random()
    i = rng.randrange(len(lines))
    if kind < 0.25:
        del lines[i]
    elif kind < 0.45:
        lines.insert(i, lines[i])
    elif kind < 0.7:
        lines[i] = " ".join(str(rng.choice([0, -1, 7, 1e308, "nan", "x", 99999999999])) for _ in range(rng.randint(1, 6))) + "\n"
    elif kind < 0.85:
        return "".join(lines)[: rng.randrange(len(text))]
    else:
        text = bytearray("".join(lines), "utf-8")
        for _ in range(rng.randint(1, 5)):
            text[rng.randrange(len(text))] = rng.randrange(256)
        return text.decode("utf-8", errors="replace")
    return "".join(lines)


def make_case(rng, k, casedir):
    """Writes case k's files into casedir; returns (command arguments, ranks, what was fuzzed)."""
    os.makedirs(casedir, exist_ok=True)
    deck, args, what = copy.deepcopy(BASE), [], rng.choice(["deck", "deck", "mesh", "gmsh", "options", "contact", "cloth"])
    if what == "cloth":
        # A sheet or an OBJ surface (maybe mutated) with the cloth section and mesh keys mutated.
        deck.pop("material")
        deck.update(copy.deepcopy(CLOTH))
        if rng.random() < 0.4:
            with open(os.path.join(casedir, "fuzz.obj"), "w") as f:
                f.write(mutate_mesh(rng, CLOTH_OBJ) if rng.random() < 0.6 else CLOTH_OBJ)
            deck["mesh"] = {"file": "fuzz.obj"}
            deck["fixed"] = [{"box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 0.01, 0.01]}}]
        if rng.random() < 0.3:
            deck["cloth"] = {"model": "membrane", "material": rng.choice(["stvk", "corotated", "neohookean"]),
                             "youngs_modulus": 100.0, "poisson_ratio": 0.3, "areal_density": 0.2,
                             "bending": {"model": rng.choice(["dihedral", "springs", "none"]), "stiffness": 1e-3}}
            if deck["cloth"]["bending"]["model"] == "none":
                deck["cloth"]["bending"].pop("stiffness")
        if rng.random() < 0.8:
            deck = mutate_deck(rng, deck) if rng.random() < 0.4 else deck
            section = rng.choice(["cloth", "mesh"])
            keys = SUBKEYS["cloth"] if section == "cloth" else ["sheet", "surface", "file", "transform", "strands"]
            node = deck.setdefault(section, {})
            if isinstance(node, dict):
                node[rng.choice(keys + ["bogus"])] = rng.choice(ODD_VALUES + [rng.uniform(-10, 10), rng.randint(-5, 50)])
    elif what == "deck":
        deck = mutate_deck(rng, deck)
    elif what == "contact":
        # Colliders of every type, one item or the obstacle file mutated, maybe a contact section.
        with open(os.path.join(casedir, "fuzz.obj"), "w") as f:
            f.write(mutate_mesh(rng, OBJ) if rng.random() < 0.3 else OBJ)
        deck["colliders"] = copy.deepcopy(rng.sample(COLLIDERS, rng.randint(1, len(COLLIDERS))))
        item = rng.choice(deck["colliders"])
        for _ in range(rng.randint(0, 2)):
            item[rng.choice(COLLIDER_KEYS + ["bogus"])] = rng.choice(ODD_VALUES + [rng.uniform(-10, 10)])
        if rng.random() < 0.5:
            deck = mutate_deck(rng, deck) if rng.random() < 0.3 else deck
            deck["contact"] = {rng.choice(SUBKEYS["contact"] + ["bogus"]): rng.choice(ODD_VALUES + [rng.uniform(0, 1)])}
    elif what == "mesh":
        with open(os.path.join(casedir, "fuzz.mesh"), "w") as f:
            f.write(mutate_mesh(rng, MESH))
        deck["mesh"] = {"file": "fuzz.mesh", "edges": rng.choice(["ignore", "strands"])}
        deck["fixed"] = []
        deck["strand_material"] = {"axial_stiffness": 10, "linear_density": 0.1}
        if deck["mesh"]["edges"] == "ignore":
            deck.pop("strand_material")
    elif what == "gmsh":
        with open(os.path.join(casedir, "fuzz.msh"), "w") as f:
            f.write(mutate_mesh(rng, GMSH))
        deck["mesh"] = {"file": "fuzz.msh"}
        deck["fixed"] = []
    else:
        for _ in range(rng.randint(1, 3)):
            args += [rng.choice(OPTIONS), rng.choice(OPTION_VALUES)]
    deck_path = os.path.join(casedir, "deck.yaml")
    with open(deck_path, "w") as f:
        yaml.safe_dump(deck, f, sort_keys=False, allow_unicode=True)
    ranks = 2 if rng.random() < 0.2 else None
    return [deck_path, "-o", os.path.join(casedir, "out")] + args, ranks, what


def judge(proc, outdir, timed_out):
    """The outcome of one run: 'ok', 'rejected', 'stopped' (ran, then could not continue),
    'inverted' (ran to the end with inverted elements, exit 2), or a failure class."""
    if timed_out:
        return "hang"
    out = proc.stdout or ""
    if proc.returncode not in (0, 1, 2):
        return f"crash (exit {proc.returncode})"
    if "PETSC ERROR" in out:
        return "petsc trace"
    if proc.returncode == 2:
        summary = os.path.join(outdir, "summary.json")
        if not os.path.exists(summary):
            return "exit 2 without summary"
        with open(summary) as f:
            status = json.load(f).get("status", "")
        return "inverted" if status.startswith("inverted") else "exit 2 with status " + status[:30]
    if proc.returncode == 0:
        return "ok" if os.path.exists(os.path.join(outdir, "summary.json")) else "ok without summary"
    if "hyperqn: error" not in out:
        return "error without message"
    if not os.path.exists(outdir):
        return "rejected"
    summary = os.path.join(outdir, "summary.json")
    if os.path.exists(summary):
        with open(summary) as f:
            status = json.load(f).get("status", "")
        return "stopped" if status.startswith("error") else "exit 1 with status " + status[:30]
    return "rejected input wrote output"


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--cases", type=int, default=1000)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--timeout", type=float, default=30, help="seconds per run")
    p.add_argument("--budget", type=float, default=0, help="stop after this many seconds (0: no limit)")
    p.add_argument("--out", default=os.path.join(REPO, "output", "fuzz"))
    p.add_argument("--bin", default=launch.default_binary())
    args = p.parse_args()
    shutil.rmtree(args.out, ignore_errors=True)
    rng = random.Random(args.seed)
    counts, failures, start = {}, [], time.time()
    run_cases = 0
    for k in range(args.cases):
        if args.budget and time.time() - start > args.budget:
            break
        casedir = os.path.join(args.out, "cases", f"{k:05d}")
        cmd, ranks, what = make_case(rng, k, casedir)
        timed_out = False
        try:
            proc = launch.run(cmd, ranks=ranks, binary=args.bin, timeout=args.timeout)
        except subprocess.TimeoutExpired as e:
            proc, timed_out = subprocess.CompletedProcess(cmd, -1, e.output or ""), True
        outcome = judge(proc, os.path.join(casedir, "out"), timed_out)
        counts[outcome] = counts.get(outcome, 0) + 1
        run_cases += 1
        if outcome in ("ok", "rejected", "stopped", "inverted"):
            shutil.rmtree(casedir)
        else:
            failures.append({"case": k, "fuzzed": what, "ranks": ranks or 1, "outcome": outcome,
                             "command": " ".join(proc.args), "output": (proc.stdout or "")[-1500:]})
    seconds = time.time() - start
    print(f"{run_cases} cases in {seconds:.0f} s (seed {args.seed}):")
    for outcome, n in sorted(counts.items(), key=lambda kv: -kv[1]):
        print(f"  {n:6d}  {outcome}")
    for f in failures:
        print(f"FAILED case {f['case']} ({f['fuzzed']}, {f['ranks']} rank(s)): {f['outcome']}\n  {f['command']}\n"
              + "\n".join("    " + line for line in f["output"].splitlines()[-6:]))
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "fuzz.json"), "w") as f:
        json.dump({"cases": run_cases, "seed": args.seed, "seconds": seconds, "counts": counts, "failures": failures},
                  f, indent=1)
    print(f"{len(failures)} failed, {run_cases - len(failures)} passed")
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
