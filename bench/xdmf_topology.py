#!/usr/bin/python3
"""XDMF output with topology changes (docs/outputs.md#changing-topology-in-xdmf): what it changed
and what it writes.

1. --before BIN (a build before mesh blocks): decks without topology changes (test_xdmf_output.py's
   bar, rope with strands, cloth with a collider, and the bar with a release) with output.format
   xdmf and a checkpoint every 2 frames, at 1 and 2 ranks, run by BIN twice and by --binary once.
   HDF5 stores each object's modification time (seconds since 1970, 4 bytes), so two runs of one
   build differ in a few bytes: the .h5 must have the same size and differ from BIN's only inside
   4-byte words that read, in both files, as a time of the last day; the .xdmf must be equal byte
   for byte, and each checkpoint's writer_xdmf text too.
2. The scenes of test_xdmf_topology.py with xdmf (1, 2 ranks; 4 for the cut and the sawn bar) and
   vtu (1 rank):
   mesh blocks, frames with new vertices, the largest |x_xdmf - x_vtu| and |x_1 - x_N| per vertex id
   over all frames (over the rest diagonal), and the .h5's size.
Needs postprocess/ and tests/python on PYTHONPATH.
"""
import argparse, copy, filecmp, os, subprocess, sys, time
import numpy as np
import h5py

from hyperqn_tools.decks import write_deck
from hyperqn_tools.output import read_checkpoint, read_frames, rest_diagonal


def run(binary, deck_path, out, ranks):
    cmd = (["mpiexec", "-n", str(ranks)] if ranks > 1 else []) + [binary, str(deck_path), "-o", str(out)]
    subprocess.run(cmd, check=True, capture_output=True)
    return out


def differing(a, b):
    """(bytes that differ, of them those outside any timestamp), None if the sizes differ."""
    x, y = np.fromfile(a, np.uint8), np.fromfile(b, np.uint8)
    if len(x) != len(y):
        return None
    now = time.time()
    stamp = lambda z, j: now - 86400 <= int.from_bytes(z[j:j + 4].tobytes(), "little") <= now + 60
    diff = np.nonzero(x != y)[0].tolist()
    other = [i for i in diff if not any(j >= 0 and stamp(x, j) and stamp(y, j) for j in range(i - 3, i + 1))]
    return diff, other


def same_bytes(args, work):
    import test_xdmf_output as X
    decks = {"bar": X.scene("bar"), "rope": X.scene("rope"), "cloth": X.scene("cloth"), "release": X.BAR}
    ok = True
    for name, d in decks.items():
        d = copy.deepcopy(d)
        d["name"] = "run"
        d["output"] = dict(d.get("output") or {}, format="xdmf", every=1)
        d["checkpoint"] = {"every": 2}
        path = write_deck(work / f"{name}.yaml", d)
        for ranks in (1, 2):
            old = run(args.before, path, work / f"{name}_old_{ranks}", ranks)
            new = run(args.binary, path, work / f"{name}_new_{ranks}", ranks)
            diff = differing(old / "run.h5", new / "run.h5")
            index = filecmp.cmp(old / "run.xdmf", new / "run.xdmf", shallow=False)
            cks = sorted(os.listdir(new / "checkpoints"))
            states = all(read_checkpoint(old / "checkpoints" / c)["writer_xdmf"] ==
                         read_checkpoint(new / "checkpoints" / c)["writer_xdmf"] for c in cks)
            same = diff is not None and not diff[1] and index and states
            ok = ok and same
            print(f"{name:8s} {ranks} ranks: .h5 {os.path.getsize(new / 'run.h5')} bytes, "
                  + (f"{len(diff[0])} differ from before's, {len(diff[1])} outside timestamps" if diff else "sizes differ")
                  + f"; .xdmf equal {index}; writer_xdmf of {len(cks)} checkpoints equal {states}: "
                  + ("SAME" if same else "DIFFERENT"))
    return ok


def scenes(args, work):
    import test_xdmf_topology as T
    for name in ("cut", "rope", "cloth", "fracture", "sawn"):
        d = T.scene(name, work)
        d["output"] = {"format": "xdmf", "every": 1}
        path = write_deck(work / f"{name}.yaml", d)
        ranks = (1, 2, 4) if name in ("cut", "sawn") else (1, 2)
        outs = {r: run(args.binary, path, work / f"{name}_xdmf_{r}", r) for r in ranks}
        d["output"]["format"] = "vtu"
        vtu = read_frames(run(args.binary, write_deck(work / f"{name}_vtu.yaml", d), work / f"{name}_vtu", 1))
        frames = {r: read_frames(o) for r, o in outs.items()}
        diagonal = rest_diagonal(vtu[0][1])
        worst = lambda a, b: max(np.abs(x.points - y.points).max() for (_, x), (_, y) in zip(a, b)) / diagonal
        with h5py.File(outs[1] / "run.h5", "r") as f:
            blocks = 1 + sum(1 for k in f["mesh"] if k.isdigit())
        changes = len(T.topology_rows(outs[1]))
        print(f"{name:8s}: {len(vtu)} frames, {blocks} mesh blocks, {changes} frames with new vertices or removed tets, "
              f"{len(frames[1][0][1].vertex_id)} -> {len(frames[1][-1][1].vertex_id)} points, "
              f"{frames[1][0][1].num_cells} -> {frames[1][-1][1].num_cells} cells; "
              f"max |x_xdmf - x_vtu| / diagonal {worst(frames[1], vtu):.3g}; "
              + "; ".join(f"1 vs {r} ranks {worst(frames[1], frames[r]):.3g}" for r in ranks[1:])
              + f"; run.h5 {os.path.getsize(outs[1] / 'run.h5')} bytes")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--binary", default="build/hyperqn")
    p.add_argument("--before", help="a build before mesh blocks: compare bytes on decks without changes")
    p.add_argument("--out", default="/tmp/xdmf_topology")
    args = p.parse_args()
    args.binary = os.path.abspath(args.binary)
    work = __import__("pathlib").Path(args.out)
    work.mkdir(parents=True, exist_ok=True)
    ok = same_bytes(args, work) if args.before else True
    scenes(args, work)
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
