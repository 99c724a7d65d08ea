#!/usr/bin/python3
"""Benchmark hyperqn on a fixed set of meshes at several rank counts.

Generates one deck per case, runs it under mpiexec, collects summary.json and
prints/writes a table (bench.csv, bench.json).  See bench/README.md.
Needs postprocess/ on PYTHONPATH (`make bench` sets it), PyYAML and numpy (the bandwidth loop).
"""
import argparse, csv, datetime, json, math, os, platform, subprocess, sys, time

import yaml

from hyperqn_tools import launch
from hyperqn_tools.cli import ArgumentParser, positive_float, positive_int, program, seconds_or_0, unwritable_dir
from hyperqn_tools.decks import write_deck as write_yaml
from hyperqn_tools.paths import REPO, SHARED_MESHES as MESHES

# name -> ("file", path), ("box", (nx, ny, nz)), ("hair", (n, segments)) or ("sheet", (nx, nz)).
# Boxes: 6 tets per cell.  Hair: an n x 2 x n box (1 x 2/n x 1) with a strand of `segments`
# segments and length 0.5 on every vertex of its top face, (n + 1)^2 strands in all.  Sheets: the
# cloth of Liu et al. 2013 (input/cloth/sheet_corners.yaml), 1 m x 1 m, pinned at two corners,
# at the paper's fixed budget of 10 iterations per frame (the fallback chain off).
CASES = {
    "bar990": ("file", "bar990.mesh"),
    "bar4099": ("file", "bar4099.mesh"),
    "bar16660": ("file", "bar16660.mesh"),
    "bar66792": ("file", "bar66792.mesh"),
    "bunny": ("file", "bunny.mesh"),
    "box10k": ("box", (40, 8, 6)),       # 11,520 tets
    "box50k": ("box", (70, 12, 10)),     # 50,400 tets
    "box130k": ("box", (100, 15, 15)),   # 135,000 tets
    "box480k": ("box", (200, 20, 20)),   # 480,000 tets
    "hair84k": ("hair", (40, 50)),       # 19,200 tets + 1,681 strands of 50 segments
    "sheet81": ("sheet", (80, 80)),      # 6,561 vertices, 12,800 triangles
    "sheet501": ("sheet", (500, 500)),   # 251,001 vertices, 500,000 triangles
}
QUICK = ["bar990", "bar4099", "box10k"]
MATERIALS = ["neohookean", "stvk", "corotated"]  # --material: the performance issue's three

COLUMNS = ["case", "vertices", "elements", "ranks", "frames", "factor_s", "ms/frame", "ms/iter",
           "grad%", "h0%", "other%", "bound ms/iter", "x bound", "peak MB/rank", "status"]

# The streaming bound of one iteration: the factor's values read twice (forward and backward
# solve) plus one pass over the element data (a record of ~96 B per element: rest data and
# vertex indices) and the vertex data (positions read, gradient written: 48 B per vertex), at the
# memory bandwidth measured below. It ignores the L-BFGS vector work and all arithmetic.
FACTOR_BYTES, ELEMENT_BYTES, VERTEX_BYTES = 2 * 8, 96, 48


def stream_bandwidth(n=1 << 25, repeat=5):
    """Memory bandwidth in bytes/s, STREAM's 'add' (a = b + c, 24 B per element, one core), best of repeat."""
    import numpy as np
    b, c = np.ones(n), np.full(n, 2.0)
    a = np.empty(n)
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        np.add(b, c, out=a)
        best = min(best, time.perf_counter() - t0)
    return 24.0 * n / best


def streaming_bound_ms(s, bandwidth):
    elements = s["tets"] + s["segments"] + s.get("triangles", 0)
    data = FACTOR_BYTES * s.get("h0_factor_nonzeros", 0) + ELEMENT_BYTES * elements + VERTEX_BYTES * s["vertices"]
    return 1e3 * data / bandwidth


def medit_bbox(path):
    """(min, max) corners of a Medit .mesh file's Vertices section."""
    with open(path) as f:                          # meshes here are a few MB at most
        toks = " ".join(l.split("#", 1)[0] for l in f).split()   # Medit allows # comments
    i = toks.index("Vertices")
    n = int(toks[i + 1])
    v = toks[i + 2:i + 2 + 4 * n]                  # x y z ref per vertex
    pts = [[float(v[4 * k + d]) for d in range(3)] for k in range(n)]
    lo = [min(p[d] for p in pts) for d in range(3)]
    hi = [max(p[d] for p in pts) for d in range(3)]
    return lo, hi


def fixed_box(name, lo, hi):
    """Clamp region: bars and boxes at the -x end (1% of the length), bunny at its lowest 5% in y."""
    pad = [1e-3 * (h - l) + 1e-9 for l, h in zip(lo, hi)]
    bmin = [l - p for l, p in zip(lo, pad)]
    bmax = [h + p for h, p in zip(hi, pad)]
    if name.startswith("bunny"):
        bmax[1] = lo[1] + 0.05 * (hi[1] - lo[1])
    else:
        bmax[0] = lo[0] + 0.01 * (hi[0] - lo[0])
    return bmin, bmax


def vec(v):
    return [float(f"{x:.9g}") for x in v]


def write_deck(name, deckdir, frames, material="neohookean", solver=()):
    """Write DECKDIR/NAME.yaml; return its path, or None with a note if the mesh is missing.
    solver: (key, value) pairs set in the deck's solver: section."""
    kind, arg = CASES[name]
    deck = {"name": name}
    if kind == "file":
        path = os.path.join(MESHES, arg)
        if not os.path.exists(path):
            print(f"note: skipping {name}: {path} not found", file=sys.stderr)
            return None
        lo, hi = medit_bbox(path)
        deck["mesh"] = {"file": path}
    elif kind == "sheet":
        deck["mesh"] = {"sheet": {"size": [1.0, 1.0], "cells": list(arg)}}
        corner = 0.1 / arg[0]
        deck.update({
            "cloth": {"model": "mass-spring", "stretch_stiffness": 1.0e3, "bending": {"model": "springs", "stiffness": 1.0},
                      "areal_density": 0.2},
            "fixed": [{"box": {"min": vec([x - corner, -corner, 1 - corner]), "max": vec([x + corner, corner, 1 + corner])}}
                      for x in (0.0, 1.0)],
            "gravity": [0, -9.81, 0],
            "time": {"dt": 0.0333333333, "frames": frames},
            "solver": {"type": "lbfgs", "iterations": 10, "budget": "fixed"},
            "output": {"vtk": False},
        })
        deck["solver"].update(solver)
        return write_yaml(os.path.join(deckdir, name + ".yaml"), deck,
                          header="generated by bench/bench.py; output.vtk false keeps VTK writing out of the timings")
    elif kind == "hair":
        n, segments = arg
        size = [1.0, 2.0 / n, 1.0]
        lo, hi = [0.0] * 3, size
        strands = [{"from": vec([i / n, size[1], k / n]), "to": vec([i / n + 0.2, size[1] + 0.45, k / n]),
                    "segments": segments} for i in range(n + 1) for k in range(n + 1)]
        deck["mesh"] = {"box": {"size": vec(size), "cells": [n, 2, n]}, "strands": strands}
        deck["strand_material"] = {"axial_stiffness": 100, "linear_density": 0.01}
    else:
        # Cubic cells of edge 1/ny, so the box is [nx/ny, 1, nz/ny] long.
        size = [c / arg[1] for c in arg]
        lo, hi = [0.0] * 3, size
        deck["mesh"] = {"box": {"size": vec(size), "cells": list(arg)}}
    bmin, bmax = fixed_box(name, lo, hi)
    deck.update({
        "material": {"model": material, "youngs_modulus": 1.0e6, "poisson_ratio": 0.3, "density": 1000},
        "fixed": [{"box": {"min": vec(bmin), "max": vec(bmax)}}],
        "gravity": [0, -9.81, 0],
        "time": {"dt": 0.0333333333, "frames": frames},
        "solver": {"type": "lbfgs", **dict(solver)},
        "output": {"vtk": False},
    })
    return write_yaml(os.path.join(deckdir, name + ".yaml"), deck,
                      header="generated by bench/bench.py; output.vtk false keeps VTK writing out of the timings")


def run_case(args, name, deck, ranks, rundir):
    """Run one deck; return (summary dict or None, status string)."""
    os.makedirs(rundir, exist_ok=True)
    summ = os.path.join(rundir, "summary.json")
    if os.path.exists(summ):
        os.remove(summ)                            # never report a stale result
    with open(os.path.join(rundir, "stdout.log"), "w+") as out, \
         open(os.path.join(rundir, "stderr.log"), "w+") as err:
        try:
            rc = launch.run([deck, "-o", rundir], ranks, args.hyperqn, args.mpiexec, timeout=args.timeout,
                            stdout=out, stderr=err).returncode
        except subprocess.TimeoutExpired:          # the run is stopped, ranks and all
            return None, f"failed: timeout after {args.timeout:g} s"
        out.seek(0)
        err.seek(0)
        out_lines, err_lines = out.read().splitlines(), err.read().splitlines()
        # hyperqn prints its errors on stderr (builds before: stdout), and under mpiexec Open MPI's
        # banner follows on stderr ("Exit code: 1"): prefer hyperqn's message, skip the "-----" rules.
        errors = [l[len("hyperqn: error:"):].strip() for l in out_lines + err_lines if l.startswith("hyperqn: error:")]
        lines = errors or [l.strip() for l in err_lines if any(c.isalnum() for c in l)]
    s = None
    if os.path.exists(summ):
        with open(summ) as f:
            s = json.load(f)
    if rc != 0 or s is None:
        last = lines[-1] if lines else f"exit code {rc}, no message"
        return s, f"failed: {last}"
    return s, s.get("status", "?")


def steady_frames(args, name, deck, ranks):
    """(frames, first run): --frames and the first timed run at `ranks`, or more frames and no run if
    that run solves in under --min-solve-s (a run of a few milliseconds is mostly its first frames:
    caches, page faults, the ranks' first messages)."""
    if args.min_solve_s <= 0:
        return args.frames, None
    t0 = time.time()
    s, status = run_case(args, name, deck, ranks, os.path.join(args.out, "runs", f"{name}-np{ranks}-0"))
    if s is None or status.startswith("failed") or not s.get("solve_s") or s["solve_s"] >= args.min_solve_s:
        print(f"[{time.time() - t0:7.1f} s] {name} np={ranks} #0: {status}", file=sys.stderr, flush=True)
        return args.frames, (s, status)
    frames = min(100 * args.frames, math.ceil(args.frames * args.min_solve_s / s["solve_s"]))
    print(f"note: {name}: {1e3 * s['solve_s']:.1f} ms for {args.frames} frames; timed with {frames}", file=sys.stderr)
    return frames, None


def make_row(name, ranks, frames, s, status, bandwidth):
    row = dict.fromkeys(COLUMNS, "")
    row.update(case=name, ranks=ranks, frames=frames, status=status)
    if s:
        solve = s.get("solve_s") or 0.0
        pct = lambda x: round(100.0 * x / solve, 1) if solve > 0 else ""
        grad, h0 = pct(s["objective_s"]), pct(s["h0_solve_s"])
        row.update({"vertices": s["vertices"],
                    "elements": s["tets"] + s["segments"] + s.get("triangles", 0),
                    "factor_s": round(s["factor_s"], 3),
                    "ms/frame": round(s["ms_per_frame"], 2),
                    "ms/iter": round(s["ms_per_iteration"], 3),
                    "grad%": grad, "h0%": h0,
                    "other%": round(100.0 - grad - h0, 1) if solve > 0 else "",
                    "peak MB/rank": round(s["peak_rss_mb"])})
        bound = streaming_bound_ms(s, bandwidth)
        row.update({"bound ms/iter": round(bound, 3), "x bound": round(s["ms_per_iteration"] / bound, 1)})
    return row


def machine_info():
    info = {"date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
            "nproc": len(os.sched_getaffinity(0)), "cpu_count": os.cpu_count(),
            "platform": platform.platform(), "cpu": "", "blas": "unknown",
            # Other jobs on the machine distort timings; a high load average says so.
            "loadavg": [round(x, 2) for x in os.getloadavg()]}
    try:
        with open("/proc/cpuinfo") as f:
            info["cpu"] = next((l.split(":", 1)[1].strip() for l in f if l.startswith("model name")), "")
    except OSError:
        pass
    try:  # Debian's alternatives system tells which libblas.so.3 is active
        q = subprocess.run(["update-alternatives", "--query", "libblas.so.3-x86_64-linux-gnu"],
                           capture_output=True, text=True, timeout=10).stdout
        info["blas"] = next((l.split(":", 1)[1].strip() for l in q.splitlines()
                             if l.startswith("Value:")), "unknown")
    except (OSError, subprocess.SubprocessError):
        pass
    return info


FMT = {"factor_s": "{:.3f}", "ms/frame": "{:.2f}", "ms/iter": "{:.2f}", "bound ms/iter": "{:.3f}", "x bound": "{:.1f}",
       "grad%": "{:.1f}", "h0%": "{:.1f}", "other%": "{:.1f}"}


def print_table(rows):
    cell = lambda r, c: FMT[c].format(r[c]) if c in FMT and r[c] != "" else str(r[c])
    w = {c: max(len(c), *(len(cell(r, c)) for r in rows)) for c in COLUMNS}
    left = ("case", "status")
    line = lambda get: "  ".join(get(c).ljust(w[c]) if c in left else get(c).rjust(w[c]) for c in COLUMNS)
    print(line(lambda c: c))
    for r in rows:
        print(line(lambda c: cell(r, c)))


def case_list(text):
    """argparse type of --cases: a comma list of CASES' names."""
    names = [c.strip() for c in text.split(",") if c.strip()]
    bad = [c for c in names if c not in CASES]
    if bad or not names:
        raise argparse.ArgumentTypeError(f"unknown case(s) {bad or repr(text)}; known: {','.join(CASES)}")
    return names


def main():
    ap = ArgumentParser(prog="bench/bench.py", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=os.path.join(REPO, "output", "bench"))
    ap.add_argument("--cases", type=case_list, help="comma list of case names (default: all)")
    ap.add_argument("--ranks", default="1,2", type=lambda text: [positive_int(r) for r in text.split(",")],
                    help="comma list of rank counts")
    ap.add_argument("--frames", type=positive_int, default=10)
    ap.add_argument("--min-solve-s", type=seconds_or_0, default=0.5,
                    help="a case whose first run at the first rank count solves in less time runs with more "
                         "frames (at most 100 x --frames), so that its first frames do not decide its ms/frame; "
                         "0: always --frames")
    ap.add_argument("--quick", action="store_true", help="only " + ",".join(QUICK))
    ap.add_argument("--repeat", type=positive_int, default=1, help="runs per case; the fastest is reported")
    ap.add_argument("--timeout", type=positive_float, default=1800, help="seconds per run")
    ap.add_argument("--hyperqn", type=program, default=launch.default_binary(), help="default: $HYPERQN_BIN, else build/hyperqn")
    ap.add_argument("--mpiexec", type=program, default=launch.default_mpiexec(), help="default: $MPIEXEC, else mpiexec")
    ap.add_argument("--material", default="neohookean", choices=MATERIALS,
                    help="the solids' material model (cloth sheets keep their springs)")
    ap.add_argument("--solver", action="append", default=[], metavar="KEY=VALUE",
                    help="set a key of every deck's solver: section, e.g. two_loop=streamed (repeatable)")
    ap.add_argument("--list", action="store_true", help="print the selected case names and stop")
    args = ap.parse_args()
    bad = [kv for kv in args.solver if "=" not in kv]
    if bad:
        ap.error(f"--solver takes KEY=VALUE, not {bad}")
    args.solver = [(k, yaml.safe_load(v)) for k, v in (kv.split("=", 1) for kv in args.solver)]  # 20 is a number
    args.hyperqn = os.path.abspath(args.hyperqn)
    names = QUICK if args.quick else list(CASES)
    if args.cases:
        names = [n for n in names if n in args.cases]
    ranks = args.ranks
    if args.list:
        print(",".join(names))
        return
    why = unwritable_dir(args.out)
    if why:
        ap.error(f"--out {why}")

    machine = machine_info()                       # before the runs, so loadavg is the idle load
    machine["bandwidth_GBps"] = round(stream_bandwidth() / 1e9, 2)
    print(f"memory bandwidth (STREAM add, one core): {machine['bandwidth_GBps']} GB/s", file=sys.stderr)
    built = (datetime.datetime.fromtimestamp(os.path.getmtime(args.hyperqn)).isoformat(timespec="seconds")
             if os.path.exists(args.hyperqn) else None)  # which build was measured
    deckdir = os.path.join(args.out, "decks")
    os.makedirs(deckdir, exist_ok=True)
    rows, raw = [], []                             # raw: full summary.json of each run
    for name in names:
        deck = write_deck(name, deckdir, args.frames, args.material, args.solver)
        if deck is None:
            continue
        frames, first = steady_frames(args, name, deck, ranks[0])
        if frames != args.frames:
            deck = write_deck(name, deckdir, frames, args.material, args.solver)
        for r in ranks:
            best = None
            for k in range(args.repeat):
                if first and r == ranks[0] and k == 0:  # the frames' probe was this run
                    s, status = first
                else:
                    t0 = time.time()
                    s, status = run_case(args, name, deck, r, os.path.join(args.out, "runs", f"{name}-np{r}-{k}"))
                    print(f"[{time.time() - t0:7.1f} s] {name} np={r} #{k}: {status}", file=sys.stderr, flush=True)
                # Keep the fastest good run: on a shared machine other jobs only ever add time.
                good = s is not None and not status.startswith("failed")
                if best is None or (good and (not best[2] or s["wall_s"] < best[0]["wall_s"])):
                    best = (s, status, good)
            rows.append(make_row(name, r, frames, best[0], best[1], machine["bandwidth_GBps"] * 1e9))
            raw.append(best[0])

    if not rows:
        sys.exit("no case was run")
    print_table(rows)
    with open(os.path.join(args.out, "bench.csv"), "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=COLUMNS)
        wr.writeheader()
        wr.writerows(rows)
    with open(os.path.join(args.out, "bench.json"), "w") as f:
        json.dump({"machine": machine, "frames": args.frames, "repeat": args.repeat, "material": args.material, "solver": dict(args.solver),
                   "hyperqn": args.hyperqn, "hyperqn_built": built, "rows": rows, "summaries": raw},
                  f, indent=1)
    # Non-zero only when nothing worked, so one bad case does not hide the others.
    sys.exit(1 if all(r["status"].startswith("failed") for r in rows) else 0)


if __name__ == "__main__":
    main()
