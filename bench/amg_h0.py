#!/usr/bin/python3
"""solver.h0: amg against the direct solve (h0: laplacian) on bench.py's meshes and a 2M-tet box.

For each case and H0: a plain run (bench.py's deck, --frames frames) gives iterations per frame,
ms per iteration, the setup time (factorization or AMG setup: summary.json factor_s) and the peak
memory; a study run (`hyperqn study`, lbfgs only, at frame --study-frame) gives the iterations
and the time to reach e <= 1e-3 from the converged reference's state. Prints a table and writes
amg_h0.csv and amg_h0.json in --out. With --study-decks: instead, `hyperqn study` on each given
study deck (input/study/*.yaml) with each H0, lbfgs only: iterations and ms to e <= 1e-3 at each
study frame and the trajectory's last relative RMS error (study_decks.csv). See bench/README.md.
Needs postprocess/ on PYTHONPATH and PyYAML.
"""
import argparse, csv, json, os, subprocess, sys, time

import bench  # the cases, their decks and run_case (this script's folder is on sys.path)
from hyperqn_tools import launch
from hyperqn_tools.decks import load_deck, write_deck

# ~2M tets: 320 x 32 x 32 cubic cells, 6 tets each (1,966,080 tets, 349,569 vertices); the shape
# of box480k (10 : 1 : 1).
bench.CASES["box2m"] = ("box", (320, 32, 32))
# ~10M tets, the same shape: 560 x 56 x 56 cells (10,536,960 tets, 1,822,689 vertices); with the
# factor it would not fit in 24 GB (the memory estimate refuses it), so amg only (--h0 amg).
bench.CASES["box10m"] = ("box", (560, 56, 56))
H0S = ["laplacian", "amg"]
COLUMNS = ["case", "h0", "ranks", "vertices", "it/frame", "ms/iter", "setup_s", "peak MB/rank", "h0_nonzeros",
           "study it to 1e-3", "study ms to 1e-3", "status"]


def time_to(study_dir, frame, target=1e-3):
    """(iterations, ms) at which lbfgs first reached e <= target at that frame, or None."""
    with open(os.path.join(study_dir, "study.csv")) as f:
        rows = [r for r in csv.DictReader(f) if r["solver"] == "lbfgs" and int(r["frame"]) == frame]
    for r in rows:
        if float(r["rel_error"]) <= target:
            return int(r["iteration"]), 1e3 * float(r["time_s"])
    return None


def run_study(args, deck, out, ranks, label):
    """`hyperqn study deck -o out` on ranks; its exit code, or "timeout"."""
    t0 = time.time()
    try:
        code = launch.run(["study", deck, "-o", out], ranks, args.hyperqn, args.mpiexec, timeout=args.timeout).returncode
    except subprocess.TimeoutExpired:
        code = "timeout"
    print(f"[{time.time() - t0:7.1f} s] study {label} np={ranks}: exit {code}", file=sys.stderr, flush=True)
    return code


def add_petsc(deck, h0, options):
    """--petsc's options into the deck's petsc: section, for amg runs only."""
    if h0 != "amg" or not options:
        return
    for item in options.split(","):
        name, _, value = item.partition("=")
        deck.setdefault("petsc", {})[name.strip()] = value.strip()


def study_decks(args):
    """hyperqn study on copies of the decks with solver.h0 set and lbfgs alone; prints and writes study_decks.csv."""
    cols = ["deck", "h0", "ranks", "frame", "it to 1e-3", "ms to 1e-3", "trajectory rel_rms", "trajectory s", "status"]
    rows = []
    os.makedirs(os.path.join(args.out, "decks"), exist_ok=True)
    for path in args.study_decks:
        stem = os.path.splitext(os.path.basename(path))[0]
        for h0 in args.h0.split(","):
            deck = load_deck(path)
            if "file" in deck["mesh"]:  # relative to the deck's folder: made absolute for the copy
                deck["mesh"]["file"] = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(path)),
                                                                     deck["mesh"]["file"]))
            deck.setdefault("solver", {})["h0"] = h0
            add_petsc(deck, h0, args.petsc)
            deck["study"]["solvers"] = ["lbfgs"]
            copy = write_deck(os.path.join(args.out, "decks", f"{stem}-{h0}.yaml"), deck)
            for r in [int(x) for x in args.ranks.split(",")]:
                out = os.path.join(args.out, "studies", f"{stem}-{h0}-np{r}")
                code = run_study(args, copy, out, r, f"{stem} {h0}")
                last = {}
                if code == 0:
                    with open(os.path.join(out, "trajectory.csv")) as f:
                        traj = [t for t in csv.DictReader(f) if t["solver"] == "lbfgs"]
                    last = traj[-1] if traj else {}
                for frame in deck["study"].get("frames", []):
                    reached = time_to(out, frame) if code == 0 else None
                    rows.append({"deck": stem, "h0": h0, "ranks": r, "frame": frame,
                                 "it to 1e-3": reached[0] if reached else ("not reached" if code == 0 else f"failed ({code})"),
                                 "ms to 1e-3": round(reached[1], 1) if reached else "",
                                 "trajectory rel_rms": f"{float(last['rel_rms_error']):.2e}" if last else "",
                                 "trajectory s": round(float(last["time_s"]), 2) if last else "",
                                 "status": "ok" if code == 0 else f"failed ({code})"})
    print_rows(rows, cols)
    with open(os.path.join(args.out, "study_decks.csv"), "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=cols)
        wr.writeheader()
        wr.writerows(rows)


def print_rows(rows, cols):
    w = {c: max(len(c), *(len(str(r[c])) for r in rows)) for c in cols}
    print("  ".join(c.ljust(w[c]) for c in cols))
    for r in rows:
        print("  ".join(str(r[c]).ljust(w[c]) for c in cols))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=os.path.join(bench.REPO, "output", "amg_h0"))
    ap.add_argument("--cases", default="bar66792,box480k,box2m")
    ap.add_argument("--h0", default=",".join(H0S), help="comma list of solver.h0 values")
    ap.add_argument("--ranks", default="1", help="comma list of rank counts")
    ap.add_argument("--frames", type=int, default=3, help="frames of the plain runs")
    ap.add_argument("--repeat", type=int, default=1, help="plain runs per case and H0; the fastest is reported")
    ap.add_argument("--study-frame", type=int, default=2, help="the study's frame (0: no study)")
    ap.add_argument("--reference-linear-solver", default="mumps", choices=["mumps", "cg-amg"],
                    help="the study reference's (Newton's) linear solver: cg-amg where MUMPS is too big")
    ap.add_argument("--timeout", type=float, default=3600, help="seconds per run")
    ap.add_argument("--hyperqn", default=launch.default_binary())
    ap.add_argument("--mpiexec", default=launch.default_mpiexec())
    ap.add_argument("--fixed-budget", action="store_true",
                    help="plain runs at exactly 10 iterations per frame: the fallback chain off (no more "
                         "iterations, sub-steps or Newton, whose factor the memory estimate would count)")
    ap.add_argument("--study-decks", nargs="+", help="study decks to run instead of the cases")
    ap.add_argument("--petsc", default="", help="PETSc options for the amg runs' decks (petsc: section), "
                    "comma list of name=value without '-', e.g. h0_pc_gamg_threshold=0.05")
    args = ap.parse_args()
    args.hyperqn = os.path.abspath(args.hyperqn)
    if args.study_decks:
        study_decks(args)
        return
    deckdir = os.path.join(args.out, "decks")
    os.makedirs(deckdir, exist_ok=True)
    rows = []
    for name in args.cases.split(","):
        base = bench.write_deck(name, deckdir, args.frames)
        if base is None:
            continue
        for h0 in args.h0.split(","):
            deck = load_deck(base)
            deck["solver"]["h0"] = h0
            if args.fixed_budget:
                deck["solver"].update({"iterations": 10, "budget": "fixed"})
            add_petsc(deck, h0, args.petsc)
            plain = write_deck(os.path.join(deckdir, f"{name}-{h0}.yaml"), deck)
            study = None
            if args.study_frame > 0:
                deck["time"]["frames"] = args.study_frame
                deck["solver"]["linear_solver"] = args.reference_linear_solver  # Newton's: the reference
                deck["study"] = {"frames": [args.study_frame], "solvers": ["lbfgs"], "iterations": 500,
                                 "time_limit": 600, "trajectory": False}
                study = write_deck(os.path.join(deckdir, f"{name}-{h0}-study.yaml"), deck)
            for r in [int(x) for x in args.ranks.split(",")]:
                row = dict.fromkeys(COLUMNS, "")
                row.update(case=name, h0=h0, ranks=r)
                s, status = None, "not run"
                for k in range(args.repeat):  # the fastest good run: other jobs only ever add time
                    t0 = time.time()
                    sk, st = bench.run_case(args, name, plain, r, os.path.join(args.out, "runs", f"{name}-{h0}-np{r}-{k}"))
                    print(f"[{time.time() - t0:7.1f} s] {name} {h0} np={r} #{k}: {st}", file=sys.stderr, flush=True)
                    if s is None or (sk is not None and st == "ok" and sk["wall_s"] < s["wall_s"]):
                        s, status = sk, st
                row["status"] = status
                if s:
                    row.update({"vertices": s["vertices"], "it/frame": round(s["iterations"] / max(s["frames"], 1), 1),
                                "ms/iter": round(s["ms_per_iteration"], 2), "setup_s": round(s["factor_s"], 3),
                                "peak MB/rank": round(s["peak_rss_mb"]), "h0_nonzeros": int(s["h0_factor_nonzeros"])})
                if study:
                    out = os.path.join(args.out, "studies", f"{name}-{h0}-np{r}")
                    code = run_study(args, study, out, r, f"{name} {h0}")
                    reached = time_to(out, args.study_frame) if code == 0 else None
                    if reached:
                        row["study it to 1e-3"], row["study ms to 1e-3"] = reached[0], round(reached[1], 1)
                    else:
                        row["study it to 1e-3"] = "not reached" if code == 0 else f"study failed ({code})"
                rows.append(row)
    if not rows:
        sys.exit("no case was run")
    print_rows(rows, COLUMNS)
    with open(os.path.join(args.out, "amg_h0.csv"), "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=COLUMNS)
        wr.writeheader()
        wr.writerows(rows)
    with open(os.path.join(args.out, "amg_h0.json"), "w") as f:
        json.dump({"machine": bench.machine_info(), "args": vars(args), "rows": rows}, f, indent=1)


if __name__ == "__main__":
    main()
