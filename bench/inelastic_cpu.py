#!/usr/bin/env python3
"""CPU time of an L-BFGS iteration, an inelastic variant against its elastic deck, where the machine
is too loaded for bench/inelastic_cost.py's wall-clock times (docs/viscoelastic-prony.md#cost):

    PYTHONPATH=$PWD/postprocess /usr/bin/python3 bench/inelastic_cpu.py --binary build/hyperqn \\
        --decks output/bench-inelastic/decks --variant "4 prony branches" --repeat 3

Takes the decks bench/inelastic_cost.py wrote (its --out/decks: 10 iterations a frame, budget fixed)
and runs each case's variant and its elastic deck with N1 and N2 frames under `perf stat -e
task-clock`, the four runs taking turns, --repeat rounds: CPU ms per iteration is
(cpu(N2) - cpu(N1)) / ((N2 - N1) * 10), which cancels the setup (mesh, factorization). Prints the
medians and their ratio. Needs perf; one rank.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys

import yaml

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from inelastic_cost import VARIANTS  # noqa: E402


def cpu_ms(binary, deck, frames, out):
    with open(deck) as f:
        d = yaml.safe_load(f)
    d["time"]["frames"] = frames
    path = out + ".yaml"
    with open(path, "w") as f:
        yaml.safe_dump(d, f)
    proc = subprocess.run(["perf", "stat", "-x,", "-e", "task-clock", binary, path, "-o", out],
                          capture_output=True, text=True)
    lines = [line for line in proc.stderr.splitlines() if "task-clock" in line]
    if proc.returncode != 0 or not lines:
        raise SystemExit(f"{binary} {path} failed:\n{proc.stdout[-2000:]}{proc.stderr[-2000:]}")
    with open(os.path.join(out, "summary.json")) as f:
        iterations = json.load(f)["iterations"]
    if iterations != 10 * frames:
        raise SystemExit(f"{path}: {iterations} iterations, expected {10 * frames} (10 a frame, budget fixed)")
    return float(lines[0].split(",")[0])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--binary", required=True)
    ap.add_argument("--decks", required=True, help="bench/inelastic_cost.py's --out/decks")
    ap.add_argument("--variant", default="4 prony branches")
    ap.add_argument("--cases", default="bar66792,bunny")
    ap.add_argument("--frames", default="5,25", help="N1,N2")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", default="/tmp/inelastic-cpu")
    args = ap.parse_args()
    n1, n2 = (int(x) for x in args.frames.split(","))
    names = list(VARIANTS)
    pair = {"elastic": names.index(VARIANTS[args.variant][0]), "variant": names.index(args.variant)}
    os.makedirs(args.out, exist_ok=True)
    got = {}
    for r in range(args.repeat):
        for case in args.cases.split(","):
            for label, k in pair.items():
                deck = os.path.join(args.decks, f"{case}_{k}.yaml")
                if not os.path.exists(deck):
                    raise SystemExit(f"{deck} missing: run bench/inelastic_cost.py with this variant first")
                run = os.path.join(args.out, f"{case}-{label}")
                a, b = cpu_ms(args.binary, deck, n1, run + "-a"), cpu_ms(args.binary, deck, n2, run + "-b")
                got.setdefault((case, label), []).append((b - a) / ((n2 - n1) * 10))
                print(f"round {r}: {case}, {label}: {got[(case, label)][-1]:.3f} cpu ms/iteration "
                      f"(load {os.getloadavg()[0]:.1f})", file=sys.stderr, flush=True)
    for case in args.cases.split(","):
        e, v = (statistics.median(got[(case, label)]) for label in ("elastic", "variant"))
        print(f"{case}: elastic {e:.2f}, {args.variant} {v:.2f} cpu ms/iteration (medians of {args.repeat}), "
              f"{v / e:.2f}x elastic")


if __name__ == "__main__":
    main()
