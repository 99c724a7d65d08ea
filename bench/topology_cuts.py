#!/usr/bin/python3
"""The cost of a run with scripted cuts (docs/topology.md): H0 corrected (TopologyH0) against H0
factored again at every step with separations, and the same deck without its cuts.

Runs --deck (default input/topology/bar_sliced.yaml) in three ways, interleaved round by round
(uncut, refactor, correct, uncut, ...; --rounds rounds), 1 rank, OMP_NUM_THREADS=1:
  uncut     the deck without its cuts: section,
  refactor  -hyperqn_topology_h0 false (M + h^2 L factored again after each step with separations),
  correct   the default (TopologyH0's correction where the package allows; one rank here).
Per run it reads summary.json (wall_s / frames, solve_s / frames, iterations, the cuts' counts)
and iterations.csv (L-BFGS iterations of the frames after a step with separations, and of all
frames). Prints a table of medians (with the range) and the ratios of issue 44's two bars:
wall ms/frame of correct over uncut (at most 1.5), and iterations per frame after cuts of
correct over refactor (at most 1.15). Writes topology_cuts.csv (every run) and .json (medians)
to --out. Needs postprocess/ on PYTHONPATH.

On a shared machine wall time counts the time other jobs held the cores. Each run also records the
process's CPU time (user + system, from getrusage), and each round runs the uncut deck for one
frame (`startup`: initialization, setup, one frame); cpu ms/frame is a run's CPU time less the
round's startup run's, over frames - 1, and its ratio correct over uncut is printed beside the wall
ratio.

--before BIN adds a second binary (a build before a change): each round runs the three modes with
it too, right after --binary's, and its table and ratios follow (keys "before_..." in the JSON).
"""
import argparse, csv, json, os, resource, statistics, subprocess, sys

from hyperqn_tools import cli, launch
from hyperqn_tools.decks import load_deck, write_deck
from hyperqn_tools.output import read_iterations, read_summary
from hyperqn_tools.paths import REPO

MODES = {"uncut": [], "refactor": ["-hyperqn_topology_h0", "false"], "correct": []}


def frame_iterations(outdir):
    """Per frame, the iterations of its solve (the last stage's count of iterations.csv)."""
    per = {}
    for row in read_iterations(outdir):
        per[int(row["frame"])] = per.get(int(row["frame"]), 0) + 1
    return per


def cut_frames(outdir):
    """The frames whose step began with separations (the console's cut lines, by time)."""
    with open(os.path.join(outdir, "console.txt")) as f:
        return [float(line.split()[2].rstrip(":")) for line in f if ": cut: " in line]


def one_run(args, mode, deck_path, outdir, binary):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    cmd = [binary, deck_path, "-o", outdir, *MODES[mode]]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env, timeout=3600)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu_s = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if proc.returncode != 0:
        sys.exit(f"{mode}: exit {proc.returncode}\n{proc.stdout[-2000:]}")
    with open(os.path.join(outdir, "console.txt"), "w") as f:
        f.write(proc.stdout)
    s = read_summary(outdir)
    its = frame_iterations(outdir)
    dt = s.get("dt") or args.dt
    after = sorted({int(round(t / dt)) + 1 for t in cut_frames(outdir)})  # the frame a cut's step solves
    after_its = [its[f] for f in after if f in its]
    cuts = s.get("cuts", {})
    return {
        "mode": mode,
        "cpu_s": cpu_s,
        "wall_ms_per_frame": 1e3 * s["wall_s"] / s["frames"],
        "solve_ms_per_frame": 1e3 * s["solve_s"] / s["frames"],
        "iterations_per_frame": s["iterations"] / s["frames"],
        "iterations_after_cuts": statistics.mean(after_its) if after_its else float("nan"),
        "cut_steps": len(after),
        "h0_corrections": cuts.get("h0_corrections", 0),
        "refactorizations": cuts.get("refactorizations", 0),
        "factor_s": s["factor_s"],
        "topology_s": cuts.get("topology_s", 0.0),
    }


def main():
    ap = cli.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--deck", type=cli.input_file, default=os.path.join(REPO, "input", "topology", "bar_sliced.yaml"))
    ap.add_argument("--rounds", type=cli.positive_int, default=7)
    ap.add_argument("--out", default="topology_cuts_out")
    ap.add_argument("--binary", type=cli.program, default=launch.default_binary())
    ap.add_argument("--before", type=cli.program, help="a second binary, run interleaved with --binary")
    args = ap.parse_args()
    why = cli.unwritable_dir(args.out)
    if why:
        ap.error(f"--out {why}")
    deck = load_deck(args.deck)
    try:
        args.dt, args.frames = deck["time"]["dt"], deck["time"]["frames"]
    except (KeyError, TypeError):
        ap.error(f"--deck {args.deck}: gives no time.dt and time.frames")
    if not (isinstance(args.frames, int) and args.frames >= 2):  # cpu ms/frame is over frames - 1
        ap.error(f"--deck {args.deck}: time.frames must be at least 2")
    os.makedirs(args.out, exist_ok=True)
    uncut = {k: v for k, v in deck.items() if k != "cuts"}
    one_frame = {**uncut, "time": {**deck["time"], "frames": 1}}
    paths = {"uncut": write_deck(os.path.join(args.out, "uncut.yaml"), uncut, header="generated by bench/topology_cuts.py"),
             "refactor": args.deck, "correct": args.deck,
             "startup": write_deck(os.path.join(args.out, "startup.yaml"), one_frame, header="generated by bench/topology_cuts.py")}
    binaries = {"": args.binary, **({"before_": args.before} if args.before else {})}
    rows = {tag: [] for tag in binaries}
    for r in range(args.rounds):
        for tag, binary in binaries.items():
            startup = one_run(args, "uncut", paths["startup"], os.path.join(args.out, f"{tag}startup_{r}"), binary)["cpu_s"]
            for mode in MODES:
                row = one_run(args, mode, paths[mode], os.path.join(args.out, f"{tag}{mode}_{r}"), binary)
                row["round"] = r
                row["startup_cpu_s"] = startup
                row["cpu_ms_per_frame"] = 1e3 * (row["cpu_s"] - startup) / (args.frames - 1)
                rows[tag].append(row)
                print(f"round {r} {tag}{mode:8s} wall {row['wall_ms_per_frame']:.2f} ms/frame, cpu {row['cpu_ms_per_frame']:.2f} "
                      f"ms/frame, it/frame after cuts "
                      f"{row['iterations_after_cuts']:.2f}", flush=True)
    with open(os.path.join(args.out, "topology_cuts.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["binary", *rows[""][0]])
        w.writeheader()
        for tag, binary in binaries.items():
            w.writerows({"binary": binary, **row} for row in rows[tag])
    result = {"deck": args.deck, "rounds": args.rounds, "load": os.getloadavg()}
    for tag, binary in binaries.items():
        result.update({tag + k: v for k, v in summarize(args, binary, rows[tag]).items()})
    with open(os.path.join(args.out, "topology_cuts.json"), "w") as f:
        json.dump(result, f, indent=1)


def summarize(args, binary, rows):
    """Prints one binary's table of medians (range) and issue 44's ratios; returns them."""
    keys = ["wall_ms_per_frame", "cpu_ms_per_frame", "solve_ms_per_frame", "iterations_per_frame", "iterations_after_cuts", "factor_s", "topology_s"]
    medians = {m: {k: statistics.median(r[k] for r in rows if r["mode"] == m) for k in keys} for m in MODES}
    ranges = {m: {k: (min(r[k] for r in rows if r["mode"] == m), max(r[k] for r in rows if r["mode"] == m)) for k in keys}
              for m in MODES}
    counts = {m: {k: rows[[r["mode"] for r in rows].index(m)][k] for k in ("cut_steps", "h0_corrections", "refactorizations")}
              for m in MODES}
    print(f"\n{binary}: {args.deck}, {args.rounds} rounds, medians (range)")
    print("| mode | wall ms/frame | cpu ms/frame | solve ms/frame | it/frame | it/frame after cuts | factor_s | topology_s | corrections / refactorizations |")
    print("|---|---|---|---|---|---|---|---|---|")
    for m in MODES:
        cells = [f"{medians[m][k]:.3g} ({ranges[m][k][0]:.3g}–{ranges[m][k][1]:.3g})" for k in keys]
        print(f"| {m} | " + " | ".join(cells) + f" | {counts[m]['h0_corrections']} / {counts[m]['refactorizations']} |")
    bars = {
        "wall_correct_over_uncut": medians["correct"]["wall_ms_per_frame"] / medians["uncut"]["wall_ms_per_frame"],
        "cpu_correct_over_uncut": medians["correct"]["cpu_ms_per_frame"] / medians["uncut"]["cpu_ms_per_frame"],
        "wall_refactor_over_uncut": medians["refactor"]["wall_ms_per_frame"] / medians["uncut"]["wall_ms_per_frame"],
        "iterations_after_cuts_correct_over_refactor":
            medians["correct"]["iterations_after_cuts"] / medians["refactor"]["iterations_after_cuts"],
    }
    for k, v in bars.items():
        print(f"{k}: {v:.3f}")
    return {"binary": binary, "medians": medians, "ranges": ranges, "counts": counts, "bars": bars}


if __name__ == "__main__":
    main()
