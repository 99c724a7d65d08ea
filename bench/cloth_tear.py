#!/usr/bin/python3
"""The cost of tearing cloth or snapping strands (docs/snapping.md): the breaking scene against the
same scene without breaks.

Runs --deck (default input/topology/cloth_tear.yaml; or a deck whose strands snap, e.g.
input/topology/rope_snap.yaml) in three ways, interleaved round by round (plain, tear, refactor,
plain, ...; --rounds rounds), 1 rank, OMP_NUM_THREADS=1:
  plain     the deck without its cloth.tear / strand_material.snap key (nothing breaks),
  tear      the deck as it is (on one rank each break's H0 follows by a TopologyH0 correction),
  refactor  the deck with -hyperqn_topology_h0 false (M + h^2 L factored again at every break).
--budget fixed runs every mode at solver.budget: fixed (the animation setting: at most solver.iterations
a frame, no fallback chain) instead of the deck's own budget.
--before BIN adds a fourth, `before`: the deck as it is run by BIN (a build before a change), right
after `tear` in each round.
Per run it reads summary.json: wall ms/frame (wall_s / frames: setup, every break's rebuild and
refactorization or correction and the VTK frames included), cpu ms/frame (the process's user +
system CPU time from getrusage, setup included, / frames: what other jobs on a shared machine do
not inflate), solve ms/frame (solve_s / frames), iterations per frame and the breaks' counts.
Prints a table of medians (with the range) and issue 44's bar: wall ms/frame of tear over plain
(at most 1.5), and the same in CPU time. Writes cloth_tear.csv (every run) and .json (medians) to
--out. Needs postprocess/ on PYTHONPATH.
"""
import argparse, csv, json, os, resource, statistics, subprocess, sys

from hyperqn_tools import cli, launch
from hyperqn_tools.decks import load_deck, write_deck
from hyperqn_tools.output import read_summary
from hyperqn_tools.paths import REPO

METRICS = ["wall_ms_per_frame", "cpu_ms_per_frame", "solve_ms_per_frame", "iterations_per_frame", "topology_s"]
FLAGS = {"plain": [], "tear": [], "refactor": ["-hyperqn_topology_h0", "false"], "before": []}


def one_run(binary, mode, deck_path, outdir):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    start = resource.getrusage(resource.RUSAGE_CHILDREN)
    proc = subprocess.run([binary, deck_path, "-o", outdir, *FLAGS[mode]], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          text=True, env=env, timeout=3600)
    end = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu_s = (end.ru_utime - start.ru_utime) + (end.ru_stime - start.ru_stime)
    if proc.returncode != 0:
        sys.exit(f"{mode}: exit {proc.returncode}\n{proc.stdout[-2000:]}")
    s = read_summary(outdir)
    breaks = s.get("breaks", {})
    return {
        "mode": mode,
        "wall_ms_per_frame": 1e3 * s["wall_s"] / s["frames"],
        "cpu_ms_per_frame": 1e3 * cpu_s / s["frames"],
        "solve_ms_per_frame": 1e3 * s["solve_s"] / s["frames"],
        "iterations_per_frame": s["iterations"] / s["frames"],
        "topology_s": breaks.get("topology_s", 0.0),
        "edges_torn": breaks.get("edges_torn", 0),
        "segments_snapped": breaks.get("segments_snapped", 0),
        "vertices_added": breaks.get("vertices_added", 0),
        "h0_corrections": breaks.get("h0_corrections", 0),
        "refactorizations": breaks.get("refactorizations", 0),
    }


def main():
    ap = cli.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--binary", type=cli.program, default=launch.default_binary())
    ap.add_argument("--deck", type=cli.input_file, default=os.path.join(REPO, "input", "topology", "cloth_tear.yaml"))
    ap.add_argument("--rounds", type=cli.positive_int, default=5)
    ap.add_argument("--out", default="bench_out/cloth_tear")
    ap.add_argument("--before", type=cli.program, help="a second binary (a build before a change): mode `before`, the deck as it is")
    ap.add_argument("--budget", choices=("adaptive", "fixed"), help="solver.budget of every mode (default: the deck's)")
    args = ap.parse_args()
    why = cli.unwritable_dir(args.out)
    if why:
        ap.error(f"--out {why}")
    deck = load_deck(args.deck)
    if args.budget:
        deck.setdefault("solver", {})["budget"] = args.budget
    plain = json.loads(json.dumps(deck))
    if "tear" in (deck.get("cloth") or {}):
        del plain["cloth"]["tear"]
    elif "snap" in (deck.get("strand_material") or {}):
        del plain["strand_material"]["snap"]
    else:
        ap.error(f"--deck {args.deck}: neither its cloth tears nor its strands snap")
    os.makedirs(args.out, exist_ok=True)
    paths = {"tear": write_deck(os.path.join(args.out, "tear.yaml"), deck),
             "plain": write_deck(os.path.join(args.out, "plain.yaml"), plain)}
    paths["refactor"] = paths["before"] = paths["tear"]
    modes = ("plain", "tear", "refactor") + (("before",) if args.before else ())
    rows = []
    for r in range(args.rounds):
        for mode in modes:
            binary = args.before if mode == "before" else args.binary
            row = one_run(binary, mode, paths[mode], os.path.join(args.out, f"{mode}_{r}"))
            row["round"] = r
            rows.append(row)
            print(f"round {r} {mode:8s} wall {row['wall_ms_per_frame']:8.2f} ms/frame  cpu {row['cpu_ms_per_frame']:8.2f}"
                  f"  solve {row['solve_ms_per_frame']:8.2f}  iterations {row['iterations_per_frame']:6.2f}"
                  f"  breaks {row['edges_torn'] + row['segments_snapped']} (corrected {row['h0_corrections']},"
                  f" factored {row['refactorizations']})", flush=True)
    with open(os.path.join(args.out, "cloth_tear.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    medians = {}
    print(f"\n{'mode':8s} " + " ".join(f"{m:>28s}" for m in METRICS))
    for mode in modes:
        values = {m: [row[m] for row in rows if row["mode"] == mode] for m in METRICS}
        medians[mode] = {m: statistics.median(v) for m, v in values.items()}
        print(f"{mode:8s} " + " ".join(f"{statistics.median(v):10.3f} ({min(v):.3f}-{max(v):.3f})".rjust(28)
                                       for v in values.values()))
    ratios = {}
    for mode in modes[1:]:
        ratios[mode] = {m: medians[mode][m] / medians["plain"][m] for m in ("wall_ms_per_frame", "cpu_ms_per_frame", "solve_ms_per_frame")}
        print(f"{mode} / plain: wall ms/frame {ratios[mode]['wall_ms_per_frame']:.2f} (bar: at most 1.5), "
              f"cpu ms/frame {ratios[mode]['cpu_ms_per_frame']:.2f}, solve ms/frame {ratios[mode]['solve_ms_per_frame']:.2f}")
    with open(os.path.join(args.out, "cloth_tear.json"), "w") as f:
        json.dump({"deck": args.deck, "budget": args.budget, "rounds": args.rounds, "medians": medians, "ratios": ratios,
                   "wall_ratio": ratios["tear"]["wall_ms_per_frame"], "solve_ratio": ratios["tear"]["solve_ms_per_frame"],
                   "load": os.getloadavg()}, f, indent=1)


if __name__ == "__main__":
    main()
