#!/usr/bin/python3
"""What a triangle-mesh blade's size costs (deck cuts[k].surface, docs/topology.md#scripted-cuts).

Runs --deck (default input/topology/bar_sliced.yaml) with its rectangle blade given instead as a
surface of n x n cells of 2 triangles each, for each n of --cells (default 1,15,150: 2, 450 and
45,000 triangles), 1 rank, OMP_NUM_THREADS=1; with --before BIN, that binary's run follows each run
of --binary, interleaved round by round (--rounds). Per run it reads summary.json's cuts.topology_s
(the time of the cut searches and the mesh operations) and faces_separated (which must not depend on
the triangles' count or the binary). Prints the medians of topology_s (with the range) and writes
blade_triangles.csv (every run) and .json (medians) to --out. Needs postprocess/ on PYTHONPATH.
"""
import argparse, csv, json, os, statistics, subprocess, sys

from hyperqn_tools import launch
from hyperqn_tools.decks import load_deck, write_deck
from hyperqn_tools.output import read_summary


def write_blade(path, cut, n):
    """The deck's rectangle blade (centre, normal, axis, size) as n x n cells of 2 triangles,
    wound so that their normal is the rectangle's."""
    import numpy as np
    c, nrm, ax = (np.array(cut[k], dtype=float) for k in ("center", "normal", "axis"))
    nrm /= np.linalg.norm(nrm)
    u = ax - ax.dot(nrm) * nrm
    u /= np.linalg.norm(u)
    w = np.cross(nrm, u)
    s = np.linspace(-0.5, 0.5, n + 1)
    with open(path, "w") as f:
        for b in s:
            for a in s:
                x = c + a * cut["size"][0] * u + b * cut["size"][1] * w
                f.write("v %r %r %r\n" % tuple(float(v) for v in x))
        at = lambda i, j: j * (n + 1) + i + 1
        for j in range(n):
            for i in range(n):
                f.write(f"f {at(i, j)} {at(i + 1, j)} {at(i + 1, j + 1)}\nf {at(i, j)} {at(i + 1, j + 1)} {at(i, j + 1)}\n")


def one_run(binary, deck_path, outdir):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    proc = subprocess.run([binary, deck_path, "-o", outdir], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          text=True, env=env, timeout=3600)
    if proc.returncode != 0:
        sys.exit(f"{binary} {deck_path}: exit {proc.returncode}\n{proc.stdout[-2000:]}")
    cuts = read_summary(outdir)["cuts"]
    return cuts["topology_s"], cuts["faces_separated"]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--deck", default=os.path.join("input", "topology", "bar_sliced.yaml"))
    ap.add_argument("--binary", default=launch.default_binary())
    ap.add_argument("--before", help="a second binary (a build before a change), run interleaved")
    ap.add_argument("--cells", default="1,15,150", help="n of the n x n cells of the blade, comma-separated")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--out", default=os.path.join("output", "blade_triangles"))
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    deck = load_deck(args.deck)
    cut = deck["cuts"][0]
    binaries = {"new": args.binary, **({"before": args.before} if args.before else {})}
    decks = {}
    for n in (int(c) for c in args.cells.split(",")):
        write_blade(os.path.join(args.out, f"blade_{n}.obj"), cut, n)
        d = dict(deck, cuts=[{"surface": os.path.abspath(os.path.join(args.out, f"blade_{n}.obj")),
                              "motion": cut["motion"]}])
        decks[n] = os.path.join(args.out, f"deck_{n}.yaml")
        write_deck(decks[n], d)
    rows = []
    for r in range(args.rounds):
        for n, path in decks.items():
            for name, binary in binaries.items():
                t, faces = one_run(binary, path, os.path.join(args.out, f"run_{name}_{n}"))
                rows.append({"round": r, "binary": name, "triangles": 2 * n * n, "topology_s": t, "faces_separated": faces})
    with open(os.path.join(args.out, "blade_triangles.csv"), "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(rows[0]))
        wr.writeheader()
        wr.writerows(rows)
    medians = []
    print(f"{'triangles':>10} {'binary':>7} {'topology_s median (range)':>28} {'faces':>6}")
    for n in decks:
        for name in binaries:
            ts = [x["topology_s"] for x in rows if x["triangles"] == 2 * n * n and x["binary"] == name]
            faces = sorted({x["faces_separated"] for x in rows if x["triangles"] == 2 * n * n and x["binary"] == name})
            medians.append({"triangles": 2 * n * n, "binary": name, "topology_s": statistics.median(ts),
                            "min": min(ts), "max": max(ts), "faces_separated": faces})
            print(f"{2 * n * n:>10} {name:>7} {statistics.median(ts):>12.3f} ({min(ts):.3f}-{max(ts):.3f}) {str(faces):>6}")
    with open(os.path.join(args.out, "blade_triangles.json"), "w") as f:
        json.dump({"deck": args.deck, "binaries": binaries, "rounds": args.rounds, "medians": medians}, f, indent=1)


if __name__ == "__main__":
    main()
