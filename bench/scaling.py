#!/usr/bin/python3
"""Strong scaling of an L-BFGS iteration by phase, its messages, and a model that predicts it.

For each case (bench.py's, default box130k,box480k,sheet501) and each way of applying M + h^2 L
(--paths):
  default     solver.h0: auto, -hyperqn_h0_package auto (amg on meshes of 200,000 tetrahedra or
              more; else the factor: split on more than one rank)
  split       the factor split over the ranks (solver.h0: laplacian, -hyperqn_h0_package split)
  supernodal  the factor gathered to rank 0, b gathered and x scattered each solve
  amg         solver.h0: amg, one GAMG V-cycle
it runs the deck with -log_view at --time-ranks (1,2: times and counts) and at --count-ranks (4,8,
more ranks than cores: message counts only, their times are never reported), each with exactly
10 iterations per frame (the fallback chain off) for --frames frames. Per iteration it reports
the time of the gradient (event hqnObjective), of the H0 solves (hqnH0Solve) and the rest of the
time step (hqnStep minus both: the L-BFGS two-loop and vector operations, line search), slowest
rank each; and per rank and iteration the messages, bytes and reductions of each phase from the
event lines' Mess, AvgLen and Reduct (hyperqn_tools.log_view says what PETSc counts). PETSc counts
hyperqn's own MPI_Allreduce as a reduction but not its bytes: the split solve's Allreduce of 3 s
doubles (s = summary.json h0_interface) is added from that model (column ar_KB).

Before the runs it measures alpha, beta and Allreduce times with bench/pingpong.c (2 ranks;
built by CMake as `pingpong` next to the binary, else with mpicc), the memory bandwidth and the
dense Cholesky rate (numpy). Writes scaling.csv and scaling.json to --out and prints the table.

--predict: no runs; reads --out's scaling.json, fits the model of docs/performance.md#scaling-model
to a measured case (--reference) and prints T_iter at --predict-ranks for box2m and box10m (or
--targets) with the default path (amg at these sizes) and split, for a cluster's alpha and beta
(--alpha, --beta; assumptions), and writes predictions.csv.
Needs postprocess/ on PYTHONPATH and PyYAML; numpy for the machine's rates.
"""
import argparse, csv, json, math, os, shutil, subprocess, sys, time

import bench  # the cases, their decks, machine_info (this script's folder is on sys.path)
from hyperqn_tools import launch, log_view
from hyperqn_tools.decks import load_deck, write_deck

# The 2M- and 10M-tet boxes of amg_h0.py (320 x 32 x 32 and 560 x 56 x 56 cubic cells).
bench.CASES.setdefault("box2m", ("box", (320, 32, 32)))
bench.CASES.setdefault("box10m", ("box", (560, 56, 56)))

PATHS = {  # name: (solver keys, options)
    "default": ({}, []),
    "split": ({"h0": "laplacian"}, ["-hyperqn_h0_package", "split"]),
    "supernodal": ({"h0": "laplacian"}, ["-hyperqn_h0_package", "supernodal"]),
    "amg": ({"h0": "amg"}, []),
}
FIXED_BUDGET = {"iterations": 10, "budget": "fixed"}
COLUMNS = ["case", "path", "ranks", "timed", "vertices", "package", "s", "it",
           "ms/it", "grad ms", "h0 ms", "other ms", "setup s",
           "msg/it", "KB/it", "red/it", "grad msg", "grad KB", "h0 msg", "h0 KB", "h0 red", "uncounted KB",
           "run msg", "run MB", "run red", "peak MB", "status"]
# Per iteration and per rank: msg = messages sent, KB = their kilobytes, red = reductions
# (hqnStep: the whole iteration; grad and h0: their events). uncounted KB: the H0 bytes PETSc's
# counts miss, from the model: split's Allreduce of 3 s doubles per solve and rank; the gathered
# path's MPI_Gatherv of b and MPI_Scatterv of x, 2 x 24 B per vertex of the other ranks through
# rank 0 (PETSc counts a gather as a reduction; an event without messages shows no bytes). run:
# the whole run per rank (setup included), the largest rank. Times (ms per iteration, setup s) only where timed.

# Cluster values for the predictions, assumptions (docs/performance.md#scaling-model): latency of
# an MPI message between nodes and seconds per byte of InfiniBand HDR (12.5 GB/s).
CLUSTER_ALPHA, CLUSTER_BETA = 1.5e-6, 1 / 12.5e9


# ---------------------------------------------------------------- the machine's rates

def pingpong_binary(args):
    """The pingpong executable: next to the hyperqn binary (CMake's target), else built with mpicc."""
    beside = os.path.join(os.path.dirname(args.hyperqn), "pingpong")
    if os.path.exists(beside):
        return beside
    built = os.path.join(args.out, "pingpong")
    subprocess.run(["mpicc", "-O2", "-o", built, os.path.join(bench.REPO, "bench", "pingpong.c")], check=True)
    return built


def message_costs(args):
    """pingpong's JSON at 2 ranks: alpha_s, beta_s_per_byte, one_way_s, allreduce_s."""
    cmd = [args.mpiexec, "-n", "2", pingpong_binary(args)]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=600, check=True,
                          env={**os.environ, **launch.MPI_ENV})
    return json.loads(done.stdout)


def dense_cholesky_gflops(n=2000, repeat=3):
    """Dense Cholesky rate of this machine's BLAS through numpy (n^3/3 flops), best of repeat."""
    import numpy as np
    a = np.random.default_rng(0).random((n, n))
    a = a @ a.T + n * np.eye(n)
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        np.linalg.cholesky(a)
        best = min(best, time.perf_counter() - t0)
    return n ** 3 / 3 / best / 1e9


# ---------------------------------------------------------------- runs

def run_one(args, deck, ranks, options, rundir):
    """One run with -log_view; (summary or None, log text, status)."""
    os.makedirs(rundir, exist_ok=True)
    summ = os.path.join(rundir, "summary.json")
    if os.path.exists(summ):
        os.remove(summ)  # never report a stale result
    try:
        proc = launch.run([deck, "-o", rundir, "-log_view", *options], ranks, args.hyperqn, args.mpiexec,
                          timeout=args.timeout)
    except subprocess.TimeoutExpired:
        return None, "", f"failed: timeout after {args.timeout:g} s"
    with open(os.path.join(rundir, "stdout.log"), "w") as f:
        f.write(proc.stdout)
    s = None
    if os.path.exists(summ):
        with open(summ) as f:
            s = json.load(f)
    if proc.returncode != 0 or s is None:
        errors = [l for l in proc.stdout.splitlines() if l.startswith("hyperqn: error:")]
        return s, proc.stdout, "failed: " + (errors[-1] if errors else f"exit code {proc.returncode}")
    return s, proc.stdout, s.get("status", "?")


def uncounted_bytes(s, ranks):
    """Bytes of one H0 solve that PETSc does not count (see COLUMNS): per rank for split, rank 0's
    for the gathered factor."""
    if ranks <= 1:
        return 0.0
    if s.get("h0_package") == "split":
        return 3 * 8 * s.get("h0_interface", 0)
    if s.get("h0_package") in ("supernodal", "mumps", "cholmod"):
        return 2 * 3 * 8 * s["vertices"] * (ranks - 1) / ranks
    return 0.0


def measures(s, text, ranks, timed):
    """The row's numbers of one run (summary s, -log_view text)."""
    ev = log_view.events(text, {"hqnStep", "hqnObjective", "hqnH0Solve", "hqnScene"})
    total = log_view.summary(text)
    it = max(s["iterations"], 1)
    zero = {"count": 0, "time_max": 0.0, "messages": 0.0, "bytes": 0.0, "reductions": 0.0}
    step, grad, h0 = (ev.get(k, zero) for k in ("hqnStep", "hqnObjective", "hqnH0Solve"))
    s_rows = s.get("h0_interface", 0) if s.get("h0_package") == "split" else 0
    per = lambda e, key: e[key] / it / (ranks if key in ("messages", "bytes") else 1)  # Mess, bytes: over ranks
    m = {"vertices": s["vertices"], "package": s.get("h0_package", ""), "s": s_rows, "it": s["iterations"],
         "msg/it": per(step, "messages"), "KB/it": per(step, "bytes") / 1e3, "red/it": per(step, "reductions"),
         "grad msg": per(grad, "messages"), "grad KB": per(grad, "bytes") / 1e3,
         "h0 msg": per(h0, "messages"), "h0 KB": per(h0, "bytes") / 1e3, "h0 red": per(h0, "reductions"),
         "uncounted KB": uncounted_bytes(s, ranks) * h0["count"] / it / 1e3,
         "run msg": total.get("messages", {}).get("max", ""),
         "run MB": total.get("message_bytes", {}).get("max", 0.0) / 1e6,
         "run red": total.get("reductions", {}).get("max", ""),
         "peak MB": max(s.get("peak_rss_mb_by_rank") or [s["peak_rss_mb"]]),
         "evaluations/it": grad["count"] / it, "solves/it": h0["count"] / it}
    if timed:
        ms = lambda e: 1e3 * e["time_max"] / it
        m.update({"ms/it": ms(step), "grad ms": ms(grad), "h0 ms": ms(h0),
                  "other ms": ms(step) - ms(grad) - ms(h0), "setup s": s["setup_s"],
                  "scene s": ev.get("hqnScene", zero)["time_max"], "h0 setup s": s["factor_s"]})
    return m


def measure(args, costs):
    deckdir = os.path.join(args.out, "decks")
    os.makedirs(deckdir, exist_ok=True)
    rows = []
    time_ranks = [int(r) for r in args.time_ranks.split(",") if r]
    count_ranks = [int(r) for r in args.count_ranks.split(",") if r]
    for name in args.cases.split(","):
        base = bench.write_deck(name, deckdir, args.frames)
        if base is None:
            continue
        for path in args.paths.split(","):
            keys, options = PATHS[path]
            deck = load_deck(base)
            deck["solver"].update(FIXED_BUDGET, **keys)
            plain = write_deck(os.path.join(deckdir, f"{name}-{path}.yaml"), deck,
                               header="generated by bench/scaling.py: 10 iterations per frame, no fallback chain")
            for ranks in time_ranks + count_ranks:
                timed = ranks in time_ranks
                row = dict.fromkeys(COLUMNS, "")
                row.update(case=name, path=path, ranks=ranks, timed="yes" if timed else "counts only")
                best = None
                for k in range(args.repeat if timed else 1):  # the fastest: other jobs only ever add time
                    t0 = time.time()
                    s, text, status = run_one(args, plain, ranks, options,
                                              os.path.join(args.out, "runs", f"{name}-{path}-np{ranks}-{k}"))
                    print(f"[{time.time() - t0:7.1f} s] {name} {path} np={ranks} #{k}: {status}", file=sys.stderr,
                          flush=True)
                    if status == "ok" and (best is None or s["solve_s"] < best[0]["solve_s"]):
                        best = (s, text)
                    elif best is None and k == (args.repeat if timed else 1) - 1:
                        row["status"] = status
                if best:
                    row.update(measures(best[0], best[1], ranks, timed), status="ok")
                rows.append(row)
    return rows


FMT = {"ms/it": "{:.2f}", "grad ms": "{:.2f}", "h0 ms": "{:.2f}", "other ms": "{:.2f}", "setup s": "{:.2f}",
       "msg/it": "{:.1f}", "KB/it": "{:.1f}", "red/it": "{:.1f}", "grad msg": "{:.1f}", "grad KB": "{:.1f}",
       "h0 msg": "{:.1f}", "h0 KB": "{:.1f}", "h0 red": "{:.1f}", "uncounted KB": "{:.1f}", "run msg": "{:.0f}",
       "run MB": "{:.1f}", "run red": "{:.0f}", "peak MB": "{:.0f}"}


def print_rows(rows, cols, fmt=FMT):
    cell = lambda r, c: fmt[c].format(r[c]) if c in fmt and isinstance(r.get(c), (int, float)) else str(r.get(c, ""))
    w = {c: max(len(c), *(len(cell(r, c)) for r in rows)) for c in cols}
    print("  ".join(c.ljust(w[c]) for c in cols))
    for r in rows:
        print("  ".join(cell(r, c).ljust(w[c]) for c in cols))


# ---------------------------------------------------------------- the model

def grid_parts(cells, p):
    """(px, py[, pz]) with product p that cuts the grid of cells into the most nearly cubic parts
    (least cut area): what a good partitioner does to a box."""
    best = None
    dims = len(cells)
    for px in range(1, p + 1):
        if p % px:
            continue
        rest = p // px
        for py in range(1, rest + 1):
            if rest % py or (dims == 2 and py != rest):
                continue
            parts = (px, py) if dims == 2 else (px, py, rest // py)
            if any(k > c for k, c in zip(parts, cells)):
                continue
            area = interface_of(cells, parts)
            if best is None or area < best[0]:
                best = (area, parts)
    return best[1]


def interface_of(cells, parts):
    """Vertices on the cut planes of a vertex grid of cells (+1 per axis) cut into parts per axis:
    the separator s of the split factor, one layer of vertices per cut."""
    n = [c + 1 for c in cells]
    total = 0
    for axis, k in enumerate(parts):
        plane = 1
        for other, m in enumerate(n):
            if other != axis:
                plane *= m
        total += (k - 1) * plane
    return total


def separator(cells, p):
    return interface_of(cells, grid_parts(cells, p)) if p > 1 else 0


def cube_interface(vertices, p):
    """src/model/memory_estimate.cpp interface_vertices: a cube of V vertices in p near-cubic parts."""
    return 0 if p <= 1 else max(1.0, 3 * (p ** (1 / 3) - 1)) * vertices ** (2 / 3)


def ghosts_per_rank(cells, p):
    """Interface vertices of an average part (a part touches about 2 of the cut planes' share)."""
    return 2 * separator(cells, p) / p if p > 1 else 0


def neighbours(cells, p):
    """Average number of other parts a part touches through a face, an edge or a corner (the
    tets' diagonals couple across all three) in the grid partition."""
    if p <= 1:
        return 0
    parts = grid_parts(cells, p)
    parts = list(parts) + [1] * (3 - len(parts))
    count = 0
    for i in range(parts[0]):
        for j in range(parts[1]):
            for k in range(parts[2]):
                for di in (-1, 0, 1):
                    for dj in (-1, 0, 1):
                        for dk in (-1, 0, 1):
                            a, b, c = i + di, j + dj, k + dk
                            if (di, dj, dk) != (0, 0, 0) and 0 <= a < parts[0] and 0 <= b < parts[1] and 0 <= c < parts[2]:
                                count += 1
    return count / p


def allreduce_s(n_doubles, p, alpha, beta):
    """An Allreduce of n doubles on p ranks: log2 p latencies, and for long vectors a
    reduce-scatter and an allgather (2 (p - 1)/p of the data through each rank's link)."""
    if p <= 1:
        return 0.0
    return math.ceil(math.log2(p)) * alpha + 2 * (p - 1) / p * 8 * n_doubles * beta


def split_work(t1, t2, comm2_ms, notes, phase):
    """(work, serial) in ms per iteration from T1 = serial + work and T2 = serial + work/2 + comm2.
    Where the 2-rank time is not below the 1-rank one (load, or two ranks sharing the memory bus),
    no split can be fitted: work = T1, serial 0, and a note says so."""
    work = 2 * (t1 - t2 + comm2_ms)
    if t2 >= t1 or work <= 0:
        notes.append(f"{phase}: T2 {t2:.3g} >= T1 {t1:.3g} ms: not fitted, all of T1 taken as work/p")
        return t1, 0.0
    work = min(work, t1)
    return work, t1 - work


def fit(rows, case, costs, machine):
    """The model's constants from one case's rows (1 and 2 ranks timed, the counts at every rank
    count): per phase work (s per iteration on one rank), serial (s per iteration, every rank) and
    the counts that scale the communication, per path."""
    cells = bench.CASES[case][1]
    alpha, beta = costs["alpha_s"], costs["beta_s_per_byte"]
    out = {}
    for path in PATHS:
        r = {x["ranks"]: x for x in rows if x["case"] == case and x["path"] == path and x["status"] == "ok"}
        if 1 not in r or 2 not in r or r[2]["timed"] != "yes":
            continue
        one, two = r[1], r[2]
        g2 = ghosts_per_rank(cells, 2)
        f = {"path": path, "case": case, "vertices": one["vertices"], "cells": list(cells),
             "package_2": two["package"], "s_2": two["s"], "s_2_grid": separator(cells, 2)}
        # Gradient: work/p + alpha m + beta b; m = exchanges x neighbours, b ~ the part's ghosts.
        exchanges = two["grad msg"] / max(neighbours(cells, 2), 1)
        bytes_per_ghost = 1e3 * two["grad KB"] / g2 if g2 else 0.0
        comm2 = alpha * two["grad msg"] + beta * 1e3 * two["grad KB"]
        notes = f["notes"] = []
        work, serial = split_work(one["grad ms"], two["grad ms"], 1e3 * comm2, notes, "grad")
        f["grad"] = {"work_ms": work, "serial_ms": serial, "exchanges": exchanges,
                     "bytes_per_ghost": bytes_per_ghost}
        # Other: work/p + serial + reductions x Allreduce(1 double).
        red = two["red/it"] - two["h0 red"]
        comm2 = red * allreduce_s(1, 2, alpha, beta)
        work, serial = split_work(one["other ms"], two["other ms"], 1e3 * comm2, notes, "other")
        f["other"] = {"work_ms": work, "serial_ms": serial, "reductions": red}
        # H0.
        solves = two.get("solves/it", 1.0) or 1.0
        if two["package"] == "split":
            # Interior solves: one rank's work, per rank (V/p)^(4/3) (nested dissection's fill);
            # the dense solve with L_S: 8 s^2 bytes read at the memory bandwidth; the Allreduce.
            work = one["h0 ms"]
            dense = 1e3 * solves * 8 * two["s"] ** 2 / machine["bandwidth_Bps"]
            ar = 1e3 * solves * allreduce_s(3 * two["s"], 2, alpha, beta)
            f["h0"] = {"kind": "split", "work_ms": work, "solves": solves, "dense_ms_2": dense, "allreduce_ms_2": ar,
                       "residual_ms_2": two["h0 ms"] - work * 2 ** (-4 / 3) - dense - ar}
        elif two["package"] == "amg":
            msgs = {x: r[x]["h0 msg"] for x in r}
            comm2 = alpha * two["h0 msg"] + beta * 1e3 * two["h0 KB"]
            work, serial = split_work(one["h0 ms"], two["h0 ms"], 1e3 * comm2, notes, "h0")
            f["h0"] = {"kind": "amg", "work_ms": work, "serial_ms": serial,
                       "solves": solves, "messages_by_ranks": msgs,
                       "messages_per_neighbour": max(m / max(neighbours(cells, x), 1) for x, m in msgs.items()),
                       "bytes_per_ghost": 1e3 * two["h0 KB"] / g2 if g2 else 0.0, "reductions": two["h0 red"]}
        else:  # gathered: the whole solve on rank 0, b and x through it
            f["h0"] = {"kind": "gathered", "serial_ms": two["h0 ms"], "solves": solves}
        f["setup"] = {"scene_s": one.get("scene s", 0.0), "h0_setup_s": one.get("h0 setup s", 0.0)}
        # Message counts at every rank count, measured, beside the model's (checks the model).
        f["check"] = [{"ranks": x, "grad msg": r[x]["grad msg"],
                       "grad msg model": exchanges * neighbours(cells, x),
                       "grad KB": r[x]["grad KB"], "grad KB model": bytes_per_ghost * ghosts_per_rank(cells, x) / 1e3,
                       "s": r[x]["s"], "s grid": separator(cells, x),
                       "s cube": round(cube_interface(one["vertices"], x))} for x in sorted(r)]
        out[path] = f
    return out


def predict(f, cells, vertices, p, alpha, beta, machine):
    """T_iter (ms) at p ranks of the mesh (cells, vertices) from the fit f of one path; its parts."""
    scale = vertices / f["vertices"]
    g, o, h = f["grad"], f["other"], f["h0"]
    nb, gh = neighbours(cells, p), ghosts_per_rank(cells, p)
    part = {}
    part["grad"] = g["work_ms"] * scale / p + g["serial_ms"] + 1e3 * (
        alpha * g["exchanges"] * nb + beta * g["bytes_per_ghost"] * gh)
    part["other"] = o["work_ms"] * scale / p + o["serial_ms"] + 1e3 * o["reductions"] * allreduce_s(1, p, alpha, beta)
    s = separator(cells, p)
    part["s"] = s
    if h["kind"] == "split":
        part["h0 work"] = h["work_ms"] * scale ** (4 / 3) * p ** (-4 / 3)
        part["h0 serial"] = 1e3 * h["solves"] * 8 * s ** 2 / machine["bandwidth_Bps"]
        part["h0 comm"] = 1e3 * h["solves"] * allreduce_s(3 * s, p, alpha, beta)
        part["dense GB/rank"] = 8 * s ** 2 / 1e9
        part["dense factor s"] = s ** 3 / 3 / (machine["dense_gflops"] * 1e9)
    elif h["kind"] == "amg":
        # Levels grow with log V; messages per level saturate with the neighbours.
        levels = math.log(vertices) / math.log(f["vertices"])
        part["h0 work"] = h["work_ms"] * scale / p
        part["h0 serial"] = h["serial_ms"] * levels
        part["h0 comm"] = 1e3 * (alpha * h["messages_per_neighbour"] * nb * levels + beta * h["bytes_per_ghost"] * gh
                                 + h["reductions"] * allreduce_s(1, p, alpha, 0.0))
    else:
        part["h0 work"] = 0.0
        part["h0 serial"] = h["serial_ms"] * scale ** (4 / 3)
        part["h0 comm"] = 1e3 * h["solves"] * (2 * alpha * math.log2(p) + 2 * 8 * 3 * vertices * beta)
    part["h0"] = part["h0 work"] + part["h0 serial"] + part["h0 comm"]
    part["ms/it"] = part["grad"] + part["other"] + part["h0"]
    serial = {"grad serial": g["serial_ms"], "other serial": o["serial_ms"], "h0 serial": part["h0 serial"]}
    comm = {"grad comm": part["grad"] - g["work_ms"] * scale / p - g["serial_ms"], "h0 comm": part["h0 comm"],
            "other comm": part["other"] - o["work_ms"] * scale / p - o["serial_ms"]}
    parts = {**serial, **comm, "work/p": part["ms/it"] - sum(serial.values()) - sum(comm.values())}
    part["largest"] = max(parts, key=parts.get)
    # Setup: the scene less the H0 setup (rank 0 reads or generates the mesh and distributes it) grows with V.
    part["mesh setup s"] = max(f["setup"]["scene_s"] - f["setup"]["h0_setup_s"], 0.0) * scale
    return part


def predictions(args):
    with open(os.path.join(args.out, "scaling.json")) as fh:
        data = json.load(fh)
    costs = data["machine"]["message_costs"]
    machine = {"bandwidth_Bps": data["machine"]["bandwidth_GBps"] * 1e9, "dense_gflops": data["machine"]["dense_gflops"]}
    rows = data["rows"]
    measured = [c for c in dict.fromkeys(r["case"] for r in rows) if bench.CASES[c][0] == "box"]
    case = args.reference or (max(measured, key=lambda c: next(r["vertices"] for r in rows if r["case"] == c and r["vertices"] != ""))
                              if measured else None)
    if not case:
        sys.exit("no measured box case in scaling.json to fit")
    fits = fit(rows, case, costs, machine)
    print(f"fitted on {case} (alpha {costs['alpha_s']:.3g} s, beta {costs['beta_s_per_byte']:.3g} s/B measured; "
          f"predicted with alpha {args.alpha:.3g} s, beta {args.beta:.3g} s/B)")
    print(json.dumps(fits, indent=1))
    out = []
    for target in args.targets.split(","):
        cells = bench.CASES[target][1]
        vertices = math.prod(c + 1 for c in cells)
        for path in ("amg", "split"):
            if path not in fits:
                continue
            for p in [int(x) for x in args.predict_ranks.split(",")]:
                part = predict(fits[path], cells, vertices, p, args.alpha, args.beta, machine)
                out.append({"case": target, "vertices": vertices, "path": path if path == "split" else "amg (default)",
                            "ranks": p, **{k: part[k] for k in ("s", "ms/it", "grad", "h0 work", "h0 serial",
                                                                 "h0 comm", "other", "largest", "mesh setup s")},
                            "dense GB/rank": part.get("dense GB/rank", ""), "dense factor s": part.get("dense factor s", "")})
    cols = list(out[0])
    fmt = {c: "{:.3g}" for c in cols if c not in ("case", "vertices", "path", "ranks", "s", "largest")}
    print_rows(out, cols, fmt)
    with open(os.path.join(args.out, "predictions.csv"), "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=cols)
        w.writeheader()
        w.writerows(out)
    with open(os.path.join(args.out, "predictions.json"), "w") as fh:
        json.dump({"reference": case, "fits": fits, "alpha": args.alpha, "beta": args.beta, "rows": out}, fh, indent=1)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=os.path.join(bench.REPO, "output", "scaling"))
    ap.add_argument("--cases", default="box130k,box480k,sheet501", help="comma list of bench.py's cases")
    ap.add_argument("--paths", default="default,split,supernodal,amg", help="comma list of " + ",".join(PATHS))
    ap.add_argument("--time-ranks", default="1,2", help="rank counts whose times are reported (at most the cores)")
    ap.add_argument("--count-ranks", default="4,8", help="rank counts run for the message counts only")
    ap.add_argument("--frames", type=int, default=2, help="frames per run, 10 iterations each")
    ap.add_argument("--repeat", type=int, default=1, help="timed runs per configuration; the fastest is kept")
    ap.add_argument("--timeout", type=float, default=1800, help="seconds per run")
    ap.add_argument("--hyperqn", default=launch.default_binary())
    ap.add_argument("--mpiexec", default=launch.default_mpiexec())
    ap.add_argument("--predict", action="store_true", help="no runs: the model's predictions from --out's scaling.json")
    ap.add_argument("--reference", help="--predict: the measured case to fit (default: the largest box measured)")
    ap.add_argument("--targets", default="box2m,box10m", help="--predict: the boxes to predict")
    ap.add_argument("--predict-ranks", default="16,64,256,1024")
    ap.add_argument("--alpha", type=float, default=CLUSTER_ALPHA, help="--predict: s per message (assumed)")
    ap.add_argument("--beta", type=float, default=CLUSTER_BETA, help="--predict: s per byte (assumed)")
    args = ap.parse_args()
    args.hyperqn = os.path.abspath(args.hyperqn)
    os.makedirs(args.out, exist_ok=True)
    if args.predict:
        predictions(args)
        return
    bad = [c for c in args.cases.split(",") if c not in bench.CASES] + [p for p in args.paths.split(",") if p not in PATHS]
    if bad:
        ap.error(f"unknown case(s) or path(s) {bad}; cases: {','.join(bench.CASES)}; paths: {','.join(PATHS)}")
    machine = bench.machine_info()  # before the runs: the load average at the start
    machine["bandwidth_GBps"] = round(bench.stream_bandwidth() / 1e9, 2)
    machine["dense_gflops"] = round(dense_cholesky_gflops(), 1)
    machine["message_costs"] = costs = message_costs(args)
    print(f"alpha {costs['alpha_s']:.3g} s, beta {costs['beta_s_per_byte']:.3g} s/B "
          f"({1e-9 / costs['beta_s_per_byte']:.1f} GB/s), Allreduce {costs['allreduce_s']} (2 ranks); "
          f"memory {machine['bandwidth_GBps']} GB/s, dense Cholesky {machine['dense_gflops']} GFlop/s", file=sys.stderr)
    rows = measure(args, costs)
    if not rows:
        sys.exit("no case was run")
    print_rows(rows, COLUMNS)
    with open(os.path.join(args.out, "scaling.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    with open(os.path.join(args.out, "scaling.json"), "w") as f:
        json.dump({"machine": machine, "args": vars(args), "rows": rows}, f, indent=1)
    sys.exit(1 if all(r["status"] != "ok" for r in rows) else 0)


if __name__ == "__main__":
    main()
