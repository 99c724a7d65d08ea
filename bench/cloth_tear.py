#!/usr/bin/python3
"""The cost of tearing cloth (docs/snapping.md#tearing-cloth): the tearing cloth against the same
scene without tearing.

Runs --deck (default input/topology/cloth_tear.yaml) in two ways, interleaved round by round
(plain, tear, plain, tear, ...; --rounds rounds), 1 rank, OMP_NUM_THREADS=1:
  plain  the deck without its cloth.tear key (the cloth stretches and never tears),
  tear   the deck as it is.
Per run it reads summary.json: wall ms/frame (wall_s / frames: setup, every tear's rebuild and
refactorization and the VTK frames included), solve ms/frame (solve_s / frames), iterations per
frame and the breaks' counts. Prints a table of medians (with the range) and issue 44's bar: wall
ms/frame of tear over plain (at most 1.5). Writes cloth_tear.csv (every run) and .json (medians)
to --out. Needs postprocess/ on PYTHONPATH.
"""
import argparse, csv, json, os, statistics, subprocess, sys

from hyperqn_tools.decks import load_deck, write_deck
from hyperqn_tools.output import read_summary

METRICS = ["wall_ms_per_frame", "solve_ms_per_frame", "iterations_per_frame", "topology_s"]


def one_run(binary, mode, deck_path, outdir):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    proc = subprocess.run([binary, deck_path, "-o", outdir], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          text=True, env=env, timeout=3600)
    if proc.returncode != 0:
        sys.exit(f"{mode}: exit {proc.returncode}\n{proc.stdout[-2000:]}")
    s = read_summary(outdir)
    breaks = s.get("breaks", {})
    return {
        "mode": mode,
        "wall_ms_per_frame": 1e3 * s["wall_s"] / s["frames"],
        "solve_ms_per_frame": 1e3 * s["solve_s"] / s["frames"],
        "iterations_per_frame": s["iterations"] / s["frames"],
        "topology_s": breaks.get("topology_s", 0.0),
        "edges_torn": breaks.get("edges_torn", 0),
        "vertices_added": breaks.get("vertices_added", 0),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--binary", default="build/hyperqn")
    ap.add_argument("--deck", default="input/topology/cloth_tear.yaml")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--out", default="bench_out/cloth_tear")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    deck = load_deck(args.deck)
    if "tear" not in deck.get("cloth", {}):
        sys.exit(f"{args.deck}: its cloth has no tear key")
    plain = json.loads(json.dumps(deck))
    del plain["cloth"]["tear"]
    paths = {"tear": write_deck(os.path.join(args.out, "tear.yaml"), deck),
             "plain": write_deck(os.path.join(args.out, "plain.yaml"), plain)}
    rows = []
    for r in range(args.rounds):
        for mode in ("plain", "tear"):
            row = one_run(args.binary, mode, paths[mode], os.path.join(args.out, f"{mode}_{r}"))
            row["round"] = r
            rows.append(row)
            print(f"round {r} {mode:5s} wall {row['wall_ms_per_frame']:8.2f} ms/frame  solve {row['solve_ms_per_frame']:8.2f}"
                  f"  iterations {row['iterations_per_frame']:6.2f}  edges torn {row['edges_torn']}", flush=True)
    with open(os.path.join(args.out, "cloth_tear.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    medians = {}
    print(f"\n{'mode':6s} " + " ".join(f"{m:>28s}" for m in METRICS))
    for mode in ("plain", "tear"):
        values = {m: [row[m] for row in rows if row["mode"] == mode] for m in METRICS}
        medians[mode] = {m: statistics.median(v) for m, v in values.items()}
        print(f"{mode:6s} " + " ".join(f"{statistics.median(v):10.3f} ({min(v):.3f}-{max(v):.3f})".rjust(28)
                                       for v in values.values()))
    ratio = medians["tear"]["wall_ms_per_frame"] / medians["plain"]["wall_ms_per_frame"]
    solve_ratio = medians["tear"]["solve_ms_per_frame"] / medians["plain"]["solve_ms_per_frame"]
    print(f"\ntear / plain: wall ms/frame {ratio:.2f} (bar: at most 1.5), solve ms/frame {solve_ratio:.2f}")
    with open(os.path.join(args.out, "cloth_tear.json"), "w") as f:
        json.dump({"deck": args.deck, "rounds": args.rounds, "medians": medians, "wall_ratio": ratio,
                   "solve_ratio": solve_ratio, "load": os.getloadavg()}, f, indent=1)


if __name__ == "__main__":
    main()
