"""Stability suite: runs every deck in input/stability/ with every solver and judges each run.

    PYTHONPATH=postprocess /usr/bin/python3 -m hyperqn_tools.stability [DECK.yaml ...]
        [--out output/stability] [--solvers ...] [--integrator NAME] [--bin build/hyperqn] [--np 1] ...

(`make stability` runs it on input/stability/*.yaml.) For each case (deck) and solver, the deck is
copied with `solver.type` replaced (and `time.integrator`, with --integrator; `output.vtk` and
`output.iterations_csv` set true, run.JUDGED_OUTPUT, as the judgement reads them; nothing else changes: every solver gets the deck's budget,
the project default of 10 iterations and grad_rtol 1e-6 unless the deck says otherwise) and run
under output/stability/runs/<case>/<solver>/. Every case also gets a converged reference run
(Newton with the exact Hessian, up to 100 iterations per frame, grad_rtol 1e-10) in
runs/<case>/reference/: cases without a simple exact end state are judged against it.

Measured per case and solver (judge.analyse_run): frames completed, any NaN/Inf (iterations.csv,
summary.json, every VTK frame), min J (summary.json), whether g decreased monotonically within
every frame (iterations.csv), line-search failures (summary.json `ls_failures`, else
`failed_frames`), the largest final |grad g| of a frame, the distance of the last frame from the
rest shape, and for cases with a reference the distance from the reference's last frame.
Verdicts: ok / degraded / failed / not run (judge.verdict).

Writes stability.csv, stability.md, verdicts.png and one grad_<case>.png per case into --out,
and the copy of the binary every run used (--out/hyperqn, taken at the start). Without matplotlib
the figures are skipped, which stability.md and one line at the end say (exit 0).
"""
import concurrent.futures
import glob
import os
import shutil
import sys
import time

import yaml

from hyperqn_tools.cli import ArgumentParser, WriteFailed, positive_float, positive_int, unwritable_dir
from hyperqn_tools.decks import load_deck
from hyperqn_tools.launch import deck_choices, default_binary, default_mpiexec, registry
from hyperqn_tools.paths import REPO
from hyperqn_tools.stability.judge import analyse_run, reference_ok, rest_distance
from hyperqn_tools.stability.report import case_figure, fmt, make_row, verdict_figure, write_csv, write_markdown
from hyperqn_tools.stability.run import (REFERENCE_SOLVER, case_name, case_order, description,
                                         expectation, rejection, run_deck)
from hyperqn_tools.style import NO_MATPLOTLIB, pyplot


def load_decks(p, paths):
    """{case name: (path, deck)} of the decks; p.error (one line, exit 1, nothing written yet) on a
    deck that is missing, unreadable or not a map of sections, and on two decks of one case name
    (a deck given twice, or two files of one name: they would run into one runs/<case>/ and give
    one case's rows, the other's lost)."""
    loaded = {}
    for path in paths:
        if not os.path.isfile(path):
            p.error(f"{path}: {'a directory, not a deck' if os.path.isdir(path) else 'no such deck'}")
        try:
            deck = load_deck(path)
        except (OSError, ValueError, yaml.YAMLError) as e:
            p.error(f"{path}: not a valid deck: {' '.join(str(e).split())}")  # yaml's message spans lines
        if not isinstance(deck, dict):
            p.error(f"{path}: not a map of deck sections")
        c = case_name(path)
        if c in loaded:
            other = loaded[c][0]
            p.error(f"{path}: given twice" if os.path.realpath(other) == os.path.realpath(path) else
                    f"{other} and {path}: two decks named {c} (a case is named by its file name: rename one)")
        loaded[c] = (path, deck)
    return loaded


def main(argv=None):
    try:
        return run_suite(argv)
    except WriteFailed as e:  # a full disk, which the check of --out cannot see: one line, not a traceback
        print(f"python3 -m hyperqn_tools.stability: error: cannot write {e.filename}: {e.strerror}", file=sys.stderr)
        return 1


def run_suite(argv=None):
    p = ArgumentParser(prog="python3 -m hyperqn_tools.stability", description=__doc__.split("\n")[0])
    p.add_argument("decks", nargs="*", help="decks (default: input/stability/*.yaml)")
    p.add_argument("--out", default=os.path.join(REPO, "output", "stability"))
    p.add_argument("--solvers", nargs="+", help="default: every solver the binary registers (hyperqn registry)")
    p.add_argument("--integrator", help="time.integrator of every run, the references' too (default: each deck's)")
    p.add_argument("--bin", default=default_binary(), help="hyperqn (default: $HYPERQN_BIN, else build/hyperqn)")
    p.add_argument("--np", type=positive_int, default=1, help="MPI ranks per run (1: the binary alone, without mpiexec)")
    p.add_argument("--mpiexec", default=default_mpiexec(),
                   help="MPI launcher, used when --np > 1 (default: $MPIEXEC, else mpiexec)")
    p.add_argument("--jobs", type=positive_int, default=os.cpu_count() or 1, help="runs at once")
    p.add_argument("--timeout", type=positive_float, default=600, help="seconds per run")
    p.add_argument("--no-reference", action="store_true", help="skip the converged reference runs")
    args = p.parse_args(argv)

    decks = sorted(args.decks or glob.glob(os.path.join(REPO, "input", "stability", "*.yaml")), key=case_order)
    if not decks:
        p.error("no decks")
    loaded = load_decks(p, decks)
    if not os.access(args.bin, os.X_OK):
        p.error(f"{args.bin}: not an executable (build first: make build)")
    reg = registry(args.bin)
    known = [s["name"] for s in reg["solvers"]]
    args.solvers = args.solvers or known
    unknown = [s for s in args.solvers if s not in known]
    if unknown:
        p.error(f"--solvers: unknown {', '.join(unknown)}; the binary has {', '.join(known)}")
    twice = sorted({s for s in args.solvers if args.solvers.count(s) > 1})
    if twice:  # its runs would share runs/<case>/<solver>/
        p.error(f"--solvers: {', '.join(twice)} given twice")
    integrators = deck_choices("time", "integrator", reg)
    if args.integrator is not None and args.integrator not in integrators:
        p.error(f"--integrator: unknown {args.integrator!r}; the binary has {', '.join(integrators)}")
    why = unwritable_dir(args.out)
    if why:
        p.error(f"--out {why}")
    # Every run uses a copy of the binary taken now, so a rebuild during the suite changes nothing.
    binary = os.path.join(args.out, "hyperqn")
    try:
        os.makedirs(args.out, exist_ok=True)
        shutil.copy2(args.bin, binary)
    except OSError as e:  # what unwritable_dir cannot see (root on a read-only file system)
        p.error(f"--out {args.out}: cannot write {binary}: {e.strerror}")
    t_start = time.time()
    cases = [case_name(d) for d in decks]
    if args.integrator:
        for _, deck in loaded.values():
            deck["time"] = {**(deck.get("time") or {}), "integrator": args.integrator}
    expect = {c: expectation(*loaded[c]) for c in cases}
    runs_dir = os.path.join(args.out, "runs")

    jobs = []
    for c in cases:
        for s in args.solvers:
            jobs.append((c, s, {"type": s}))
        if not args.no_reference:  # judged against for 'reference' cases, only reported for 'rest' ones
            jobs.append((c, "reference", REFERENCE_SOLVER))
    results = {}
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        futures = {pool.submit(run_deck, loaded[c][1], loaded[c][0], section, os.path.join(runs_dir, c, s),
                               binary, args.np, args.mpiexec, args.timeout): (c, s) for c, s, section in jobs}
        for fut in concurrent.futures.as_completed(futures):
            c, s = futures[fut]
            try:
                r = fut.result()
            except WriteFailed:  # the runs not started yet would fail alike
                pool.shutdown(wait=False, cancel_futures=True)
                raise
            r["rejected"] = rejection(r["output"]) if r["returncode"] == 1 and not os.path.exists(
                os.path.join(runs_dir, c, s, "summary.json")) else None
            results[(c, s)] = r
            state = ("rejected" if r["rejected"] else "timeout" if r["timed_out"]
                     else f"exit {r['returncode']}")
            print(f"  {c:>18s} {s:<15s} {r['seconds']:6.1f} s  {state}", flush=True)

    rows, meta_refs = [], {}
    figures = pyplot() is not None  # optional: without matplotlib the tables alone
    for c in cases:
        deck_path, deck = loaded[c]
        expected = int((deck.get("time") or {}).get("frames", 100))
        align = not deck.get("fixed")
        ref = None
        if (c, "reference") in results:
            ref = analyse_run(os.path.join(runs_dir, c, "reference"), deck)
            ok = reference_ok(ref) and not results[(c, "reference")]["rejected"]
            s = ref["summary"] or {}
            rest_note = ""
            if expect[c] == "rest" and ref["frames"] and ref["frames"][-1][0] == ref["frames_completed"]:
                rest_note = f", rest err. {fmt(rest_distance(ref['frames'][-1][1], align))}"
            meta_refs[c] = (f"completed, {s.get('converged_frames')}/{expected} frames converged{rest_note}" if ok else
                            "not run" if results[(c, "reference")]["rejected"] else
                            f"failed ({s.get('status', 'no summary')})")
        analyses = {}
        for s in args.solvers:
            a = analyse_run(os.path.join(runs_dir, c, s), deck)
            analyses[s] = a
            rows.append(make_row(c, s, expect[c], results[(c, s)], a, ref, align))
        if ref is not None:
            analyses["reference"] = ref
        verdicts = {r["solver"]: r["verdict"] for r in rows if r["case"] == c}
        if figures:
            case_figure(c, analyses, verdicts, align, os.path.join(args.out, f"grad_{c}.png"))

    os.makedirs(args.out, exist_ok=True)
    write_csv(rows, os.path.join(args.out, "stability.csv"))
    meta = {"figures": figures, "ranks": args.np, "date": time.strftime("%Y-%m-%d %H:%M"), "seconds": time.time() - t_start,
            "expect": expect, "descriptions": {c: description(loaded[c][0]) for c in cases}, "references": meta_refs}
    write_markdown(rows, cases, args.solvers, meta, os.path.join(args.out, "stability.md"))
    if figures:
        verdict_figure(rows, cases, args.solvers, os.path.join(args.out, "verdicts.png"))

    width = max(len(c) for c in cases)
    print(f"\n{'case':<{width}s} " + " ".join(f"{s:>15s}" for s in args.solvers))
    by = {(r["case"], r["solver"]): r["verdict"] for r in rows}
    for c in cases:
        print(f"{c:<{width}s} " + " ".join(f"{by[(c, s)]:>15s}" for s in args.solvers))
    print(f"\nwrote {os.path.join(args.out, 'stability.md')}, stability.csv"
          + (", verdicts.png, grad_<case>.png" if figures else "") + f" ({time.time() - t_start:.0f} s)")
    if not figures:
        print(f"stability: figures skipped: {NO_MATPLOTLIB}", file=sys.stderr)
    return 0
