#!/usr/bin/env python3
"""Two hyperqn builds side by side on the benchmark (bench/bench.py), for "no slowdown" checks:

    PYTHONPATH=$PWD/postprocess /usr/bin/python3 bench/compare_builds.py OLD/hyperqn build/hyperqn --quick
    PYTHONPATH=$PWD/postprocess /usr/bin/python3 bench/compare_builds.py OLD/hyperqn build/hyperqn --cases bar66792,box130k

The builds take turns case by case, round after round (--rounds), so that the machine's noise,
which comes and goes over tens of seconds here, falls on both alike; each keeps its fastest run. Prints ms/iteration and ms/frame of both and the
ratio new/old, and writes compare.csv and compare.json to --out. Arguments after the two binaries
that bench.py knows (--quick, --cases, --ranks, --frames, --material, --solver) pass through to it.
--old-solver/--new-solver KEY=VALUE give one build's decks a solver key, so one binary can be
compared with itself under two settings:

    PYTHONPATH=$PWD/postprocess /usr/bin/python3 bench/compare_builds.py build/hyperqn build/hyperqn --new-solver two_loop=streamed
"""
import argparse
import csv
import json
import os
import subprocess
import sys

from hyperqn_tools import cli
from hyperqn_tools.paths import REPO

BENCH = os.path.join(REPO, "bench", "bench.py")


def main():
    ap = cli.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("old", type=cli.program)
    ap.add_argument("new", type=cli.program)
    ap.add_argument("--rounds", type=cli.positive_int, default=3)
    ap.add_argument("--out", default=os.path.join(REPO, "output", "bench-compare"))
    ap.add_argument("--old-solver", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--new-solver", action="append", default=[], metavar="KEY=VALUE")
    args, bench_args = ap.parse_known_args()
    solver = {"old": [a for kv in args.old_solver for a in ("--solver", kv)],
              "new": [a for kv in args.new_solver for a in ("--solver", kv)]}
    builds = {"old": os.path.abspath(args.old), "new": os.path.abspath(args.new)}
    why = cli.unwritable_dir(args.out)
    if why:
        ap.error(f"--out {why}")
    # bench.py's own arguments, checked by it before any run: its one-line error is ours
    listed = subprocess.run([sys.executable, BENCH, "--list", "--hyperqn", args.new] + bench_args, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    if listed.returncode != 0:
        ap.error((listed.stderr.strip().splitlines() or [f"bench.py --list: exit {listed.returncode}"])[-1])
    names = listed.stdout.strip().split(",")
    others = [a for i, a in enumerate(bench_args)  # --cases/--quick are replaced by one case per call
              if a not in ("--quick", "--cases") and not (i > 0 and bench_args[i - 1] == "--cases")]
    best = {}  # (case, ranks, build) -> row of the fastest run
    for k in range(args.rounds):
        for name in names:
            for label, binary in builds.items():
                out = os.path.join(args.out, f"{name}-{label}-{k}")
                subprocess.run([sys.executable, BENCH, "--hyperqn", binary, "--out", out, "--cases", name] + others + solver[label],
                               check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                with open(os.path.join(out, "bench.json")) as f:
                    for row in json.load(f)["rows"]:
                        key = (row["case"], row["ranks"], label)
                        if row["ms/iter"] != "" and (key not in best or row["ms/iter"] < best[key]["ms/iter"]):
                            best[key] = row
    table = []
    for case, ranks in sorted({(c, r) for c, r, _ in best}, key=lambda cr: (names.index(cr[0]), cr[1])):
        old, new = best.get((case, ranks, "old")), best.get((case, ranks, "new"))
        if not old or not new:
            continue
        table.append({"case": case, "ranks": ranks, "old ms/iter": old["ms/iter"], "new ms/iter": new["ms/iter"],
                      "new/old": round(new["ms/iter"] / old["ms/iter"], 3),
                      "old ms/frame": old["ms/frame"], "new ms/frame": new["ms/frame"]})
    cols = list(table[0]) if table else []
    print(" | ".join(cols))
    for row in table:
        print(" | ".join(str(row[c]) for c in cols))
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "compare.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=cols)
        w.writeheader()
        w.writerows(table)
    with open(os.path.join(args.out, "compare.json"), "w") as f:
        json.dump({"builds": builds, "solver": {"old": args.old_solver, "new": args.new_solver}, "rounds": args.rounds, "bench_args": bench_args, "rows": table}, f, indent=1)


if __name__ == "__main__":
    main()
