"""Sweeps: a deck's parameters over a grid of values, and/or a set of decks, run as one command;
each case in its own directory, then one table of all cases (docs/sweeps.md).

    python3 -m hyperqn_tools.sweep SWEEP.yaml [--out DIR] [--np N] [--case K] [--list] [--table-only]

A sweep file (paths relative to it):

    deck: ../bar.yaml                     # a base deck, and/or
    decks: [a.yaml, b.yaml]               # a set of base decks
    sweep:                                # every combination, the last key varying fastest
      material.youngs_modulus: [1.0e5, 1.0e6]
      solver.type: [lbfgs, newton]
    set: {time.frames: 10}                # one value for every case

Case k's deck is OUT/<case>/deck.yaml, hyperqn's results go next to it, with run.log (its
output) and run.json (exit code, seconds); OUT/sweep.csv and OUT/sweep.md are built from those
files only, so --table-only after a Slurm array gives the same table as a sweep run in one go.
A file of its own it cannot write stops the sweep (one line, exit 1); Ctrl-C or SIGTERM stops the
running case with a checkpoint, records it, writes the table and exits 130 or 143.
"""
import copy
import csv
import io
import itertools
import json
import math
import os
import re
import shutil
import signal
import sys
import threading
import time

from hyperqn_tools import launch
from hyperqn_tools.cli import ArgumentParser, positive_float, positive_int, unwritable_dir, writing
from hyperqn_tools.decks import absolute_path, load_deck, load_yaml, plain_copy, portable_copy, write_deck

TOP_KEYS = ("deck", "decks", "sweep", "set")
NAME_MAX = 100  # hyperqn's limit on a deck name (docs/decks.md), which each case's name becomes
SWEEP_EXIT_CASE_FAILED = 2


class SweepError(Exception):
    """A bad sweep file: said with the file and the key, before anything is written."""


class Case:
    def __init__(self, index, name, base, values, deck):
        self.index = index
        self.name = name
        self.base = base  # the base deck's path
        self.values = values  # {dotted key: value}, the swept ones
        self.deck = deck  # the deck to run, ready to write


def format_value(v):
    """A value as the table and the case names show it, at 12 digits and short: 1e5, 0.3, 1500, 2.5e-6."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        plain = f"{v:.12g}"
        if not math.isfinite(v):
            return plain
        plain = re.sub(r"e\+?(-?)0*(\d)", r"e\1\2", plain)
        mantissa, exponent = f"{v:.11e}".split("e")
        sci = mantissa.rstrip("0").rstrip(".") + "e" + str(int(exponent))
        return plain if len(plain) <= len(sci) else sci
    if isinstance(v, list):
        return "[" + ",".join(format_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ",".join(f"{k}:{format_value(x)}" for k, x in v.items()) + "}"
    return str(v)


def sanitize(text):
    """text with every character a deck name may not hold replaced by '_'."""
    return re.sub(r"[^A-Za-z0-9_.+-]", "_", text)


def short_labels(keys):
    """{dotted key: label in case names}: its last part, or the whole key when two keys share it."""
    last = [k.split(".")[-1] for k in keys]
    return {k: (l if last.count(l) == 1 else k) for k, l in zip(keys, last)}


def case_name(index, base_label, values, labels):
    """case-007[_base][_label-value...], sanitized and cut to hyperqn's name rules; the index alone
    keeps names unique."""
    parts = [f"case-{index:03d}"] + ([base_label] if base_label else [])
    parts += [f"{labels[k]}-{format_value(v)}" for k, v in values.items()]  # '=' is not allowed
    return sanitize("_".join(parts))[:NAME_MAX]


def set_dotted(deck, dotted, value, where):
    """deck[a][b][c] = value for dotted 'a.b.c' (an integer part indexes a list); missing maps are
    made. `where` names the sweep file and key in errors."""
    parts = dotted.split(".")
    if not all(parts):
        raise SweepError(f"{where}: empty part in the key path '{dotted}'")
    node = deck
    for i, part in enumerate(parts):
        last = i == len(parts) - 1
        here = ".".join(parts[:i]) or "the deck"
        if isinstance(node, list):
            if not re.fullmatch(r"\d+", part) or int(part) >= len(node):
                raise SweepError(f"{where}: '{here}' is a list of {len(node)} items; '{part}' is not an index in it")
            key = int(part)
        elif isinstance(node, dict):
            key = part
            if not last and node.get(key) is None:
                if re.fullmatch(r"\d+", parts[i + 1]):  # 'colliders.0.friction' on a deck without colliders
                    raise SweepError(f"{where}: '{'.'.join(parts[:i + 1])}' is not in the deck: an index "
                                     f"('{parts[i + 1]}') needs an existing list")
                node[key] = {}
        else:
            raise SweepError(f"{where}: '{here}' is {format_value(node)!r}, not a map")
        if last:
            node[key] = value
        else:
            node = node[key]


def resolve_file_value(dotted, value, sweep_dir):
    """A relative file given in the sweep file (a key ending in 'file') is relative to the sweep file."""
    if dotted.split(".")[-1] == "file" and isinstance(value, str):
        return absolute_path(value, sweep_dir)
    return value


def load_sweep(path):
    """The cases of a sweep file, in their stable order; SweepError on a bad file."""
    if not os.path.isfile(path):
        raise SweepError(f"{path}: no such sweep file")
    try:
        spec = load_yaml(path)
    except Exception as e:  # yaml's own message has the line and column
        raise SweepError(f"{path}: not a valid YAML file: {e}") from None
    if not isinstance(spec, dict):
        raise SweepError(f"{path}: expected a map with keys {', '.join(TOP_KEYS)}")
    unknown = [k for k in spec if k not in TOP_KEYS]
    if unknown:
        raise SweepError(f"{path}: unknown key '{unknown[0]}' (known: {', '.join(TOP_KEYS)})")
    sweep_dir = os.path.dirname(os.path.abspath(path))

    bases = []
    if "deck" in spec:
        if not isinstance(spec["deck"], str) or not spec["deck"]:
            raise SweepError(f"{path}: key 'deck': expected the path of a deck")
        bases.append(("deck", spec["deck"]))
    if "decks" in spec:
        if not isinstance(spec["decks"], list) or not spec["decks"]:
            raise SweepError(f"{path}: key 'decks': expected a non-empty list of deck paths")
        for i, d in enumerate(spec["decks"]):
            if not isinstance(d, str) or not d:
                raise SweepError(f"{path}: key 'decks[{i}]': expected the path of a deck")
            bases.append((f"decks[{i}]", d))
    if not bases:
        raise SweepError(f"{path}: no 'deck' or 'decks': nothing to run")

    def dotted_map(key):
        m = spec.get(key) or {}
        if not isinstance(m, dict):
            raise SweepError(f"{path}: key '{key}': expected a map of dotted deck keys")
        for k in m:
            if not isinstance(k, str) or not k:
                raise SweepError(f"{path}: key '{key}': {k!r} is not a dotted deck key")
        return m

    grid = dotted_map("sweep")
    fixed = dotted_map("set")
    for k, values in grid.items():
        if not isinstance(values, list) or not values:
            raise SweepError(f"{path}: key 'sweep.{k}': expected a non-empty list of values")

    loaded = []
    for where, rel in bases:
        deck_path = absolute_path(rel, sweep_dir)
        if not os.path.isfile(deck_path):
            raise SweepError(f"{path}: key '{where}': no such deck {deck_path}")
        try:
            deck = load_deck(deck_path)
        except Exception as e:
            raise SweepError(f"{path}: key '{where}': cannot read {deck_path}: {e}") from None
        if not isinstance(deck, dict):
            raise SweepError(f"{path}: key '{where}': {deck_path} is not a map of deck sections")
        try:
            deck = portable_copy(deck, deck_path)  # mesh and obstacle files stay found from OUT/<case>/
        except ValueError as e:  # an alias bomb or cycle, which hyperqn refuses too
            raise SweepError(f"{path}: key '{where}': {deck_path}: {e}") from None
        loaded.append((deck_path, deck))

    # A base's label in case names only when there are several bases.
    stems = [os.path.splitext(os.path.basename(p))[0] for p, _ in loaded]
    labels = short_labels(list(grid))
    cases = []
    for (deck_path, deck), stem in zip(loaded, stems):
        for combo in itertools.product(*grid.values()):
            values = dict(zip(grid, combo))
            d = plain_copy(deck)  # every case its own; no entry shared by a YAML alias, so a key sets one
            for k, v in fixed.items():
                set_dotted(d, k, resolve_file_value(k, copy.deepcopy(v), sweep_dir), f"{path}: key 'set.{k}'")
            for k, v in values.items():
                set_dotted(d, k, resolve_file_value(k, copy.deepcopy(v), sweep_dir), f"{path}: key 'sweep.{k}'")
            name = case_name(len(cases), stem if len(loaded) > 1 else "", values, labels)
            d["name"] = name  # the output files carry the case's name, and "deck" would be the default
            cases.append(Case(len(cases), name, deck_path, values, d))
    return cases


class WriteError(Exception):
    """A file of the sweep's own (a case's deck.yaml, run.log, run.json; the table) could not be
    written: the sweep stops, said in one line naming the file (docs/sweeps.md)."""


class CaseInterrupted(Exception):
    """The sweep was interrupted (Ctrl-C, SIGTERM) during a case; the case is stopped and recorded."""

    def __init__(self, case, signal_name):
        super().__init__(signal_name)
        self.case, self.signal_name = case, signal_name


def write_file(path, text):
    """text into path; WriteError naming path (the file removed, not left cut short) on an OSError."""
    try:
        with writing(path), open(path, "w", newline="") as f:
            f.write(text)
    except OSError as e:
        raise WriteError(f"{path}: cannot write it: {e.strerror}") from None


def run_case(case, out, np_ranks, binary, mpiexec, timeout):
    """Runs one case in OUT/<case>/ (emptied first: results of an earlier run would mislead the
    table); writes deck.yaml, run.log and run.json; returns hyperqn's exit code (None: it did not
    finish). WriteError when those files cannot be written; CaseInterrupted, after they are, when
    the sweep was interrupted during the run (the run stopped with a checkpoint)."""
    cdir = os.path.join(out, case.name)
    try:
        os.makedirs(cdir, exist_ok=True)
        for old in os.listdir(cdir):
            p = os.path.join(cdir, old)
            if os.path.isfile(p):
                os.remove(p)
    except OSError as e:
        raise WriteError(f"{e.filename or cdir}: cannot make or empty it: {e.strerror or e}") from None
    deck_file = os.path.join(cdir, "deck.yaml")
    try:
        deck_path = write_deck(deck_file, case.deck,
                               header=f"sweep case {case.index}: {case.name}\nbase deck: {case.base}")
    except OSError as e:  # write_deck removed it: no deck cut short is left to be run by hand
        raise WriteError(f"{deck_file}: cannot write it: {e.strerror or e}") from None
    args = [deck_path, "-o", cdir]
    ranks = None if np_ranks == 1 else np_ranks  # alone: a singleton MPI process starts faster
    cmd = launch.command(args, ranks, binary, mpiexec)
    t0 = time.time()
    interrupted = late_signal = None
    try:
        proc = launch.run(args, ranks, binary, mpiexec, timeout=timeout)
        code, output = proc.returncode, proc.stdout
    except launch.Timeout as e:
        if e.completed():  # the signal came once the last frame's solve had ended: the run is whole
            code = e.returncode
            late_signal = (f"SIGUSR1 after the timeout of {timeout} s came once the last frame's solve had "
                           f"ended: the run completed")
            output = (e.stdout or "") + f"\nsweep: {late_signal} (exit {code})\n"
        else:
            code, output = None, (e.stdout or "") + f"\nsweep: stopped after the timeout of {timeout} s\n"
    except OSError as e:  # the binary could not be started: this case fails, the sweep goes on
        code, output = None, f"sweep: cannot start {cmd[0]}: {e}\n"
    except launch.Interrupted as e:  # stopped with a checkpoint (SIGUSR1), as on a timeout
        interrupted = e.signal_name
        code, output = e.returncode, (e.output or "") + f"\nsweep: interrupted by {interrupted}: the case was stopped\n"
    seconds = time.time() - t0
    record = {"case": case.name, "index": case.index, "exit_code": code, "seconds": seconds, "command": cmd}
    if interrupted:
        record["interrupted"] = interrupted
    if late_signal:
        record["timeout"] = late_signal
    write_file(os.path.join(cdir, "run.log"), " ".join(cmd) + "\n" + output)
    write_file(os.path.join(cdir, "run.json"), json.dumps(record, indent=1))
    if interrupted:
        raise CaseInterrupted(case, interrupted)
    return code


def last_error(log_text):
    """The last `hyperqn: error:` message of a run's output, without the prefix."""
    errors = re.findall(r"hyperqn: error: (.*)", log_text)
    return errors[-1].strip() if errors else None


def json_map(path):
    """(the JSON object in path, None if there is no such file; why it cannot be read, else None)."""
    if not os.path.isfile(path):
        return None, None
    try:
        with open(path) as f:
            data = json.load(f)
    except (OSError, ValueError) as e:  # ValueError: JSON's errors and undecodable bytes
        return None, f"{os.path.basename(path)} damaged ({e})"
    if not isinstance(data, dict):
        return None, f"{os.path.basename(path)} damaged (not a JSON object)"
    return data, None


def case_row(case, out):
    """One table row from the files of OUT/<case>/."""
    cdir = os.path.join(out, case.name)
    row = {"case": case.name, "status": "not run", "frames": "", "mean_iterations": "", "ms_per_frame": "",
           "wall_s": "", "exit_code": ""}
    run, run_damaged = json_map(os.path.join(cdir, "run.json"))
    if run is not None:
        row["exit_code"] = "none" if run.get("exit_code") is None else run["exit_code"]
    s, summary_damaged = json_map(os.path.join(cdir, "summary.json"))
    if s is not None:
        row.update(status=s.get("status", ""), frames=s.get("frames", ""),
                   mean_iterations=s.get("mean_iterations", ""), ms_per_frame=s.get("ms_per_frame", ""),
                   wall_s=s.get("wall_s", ""))
    if summary_damaged or run_damaged:
        # A Slurm array task killed while writing: its row says so and the other cases' rows stand.
        row["status"] = "failed: " + (summary_damaged or run_damaged)
    elif s is None and run is not None:
        log = ""
        if os.path.isfile(os.path.join(cdir, "run.log")):
            with open(os.path.join(cdir, "run.log")) as f:
                log = f.read()
        msg = last_error(log) or (re.search(r"sweep: (cannot start .*)", log) or [None, None])[1]
        if msg is None:
            msg = "timeout" if "stopped after the timeout" in log else "no summary.json and no hyperqn error message"
        # The message names OUT/<case>/deck.yaml (whose lines are not the base deck's): shortened
        # to deck.yaml, the row says which case, and the table does not depend on OUT's spelling.
        row["status"] = "failed: " + re.sub(r"^\S*deck\.yaml:", "deck.yaml:", msg)
    return row


def table_rows(cases, out):
    return [case_row(c, out) for c in cases]


def columns(cases):
    keys = list(dict.fromkeys(k for c in cases for k in c.values))
    several = len({c.base for c in cases}) > 1
    return (["case"] + (["deck"] if several else []) + keys
            + ["status", "frames", "mean_iterations", "ms_per_frame", "wall_s", "exit_code"]), keys, several


def write_tables(cases, out):
    """OUT/sweep.csv (summary numbers at full precision) and OUT/sweep.md; returns the rows.
    WriteError when they cannot be written."""
    cols, keys, several = columns(cases)
    rows = table_rows(cases, out)
    full = []
    for c, r in zip(cases, rows):
        r = dict(r)
        if several:
            r["deck"] = os.path.relpath(c.base, out)
        for k in keys:
            r[k] = format_value(c.values[k]) if k in c.values else ""
        full.append(r)
    text = io.StringIO()
    w = csv.DictWriter(text, fieldnames=cols)
    w.writeheader()
    w.writerows(full)
    write_file(os.path.join(out, "sweep.csv"), text.getvalue())

    def cell(col, v):
        if isinstance(v, float):
            v = f"{v:.3g}" if col == "wall_s" else f"{v:.2f}" if col == "mean_iterations" else f"{v:.1f}"
        return str(v).replace("|", "\\|")

    write_file(os.path.join(out, "sweep.md"), "| " + " | ".join(cols) + " |\n|" + "---|" * len(cols) + "\n"
               + "".join("| " + " | ".join(cell(c, r[c]) for c in cols) + " |\n" for r in full))
    return full


def sweep_main(argv=None):
    ap = ArgumentParser(prog="python3 -m hyperqn_tools.sweep", description=__doc__.split("\n\n")[0])
    ap.add_argument("sweep", help="the sweep file (YAML)")
    ap.add_argument("--out", help="output directory (default output/sweep/<sweep file name>)")
    ap.add_argument("--np", type=positive_int, default=1, help="MPI ranks per case (1: the binary alone)")
    ap.add_argument("--case", type=int, help="run only case K (0-based), e.g. $SLURM_ARRAY_TASK_ID; no table")
    ap.add_argument("--list", action="store_true", help="print the cases and their count, run nothing")
    ap.add_argument("--table-only", action="store_true", help="build the table from the case directories")
    ap.add_argument("--bin", default=None, help="the hyperqn binary (default $HYPERQN_BIN or build/hyperqn)")
    ap.add_argument("--mpiexec", default=None, help="the MPI launcher (default $MPIEXEC or mpiexec)")
    ap.add_argument("--timeout", type=positive_float, default=None, help="seconds per case before it is stopped")
    a = ap.parse_args(argv)
    try:
        cases = load_sweep(a.sweep)
    except SweepError as e:
        print(f"sweep: error: {e}", file=sys.stderr)
        return 1
    if a.case is not None and not 0 <= a.case < len(cases):
        print(f"sweep: error: {a.sweep}: --case {a.case}: there are {len(cases)} cases (0 to {len(cases) - 1})",
              file=sys.stderr)
        return 1
    if a.list:
        for c in cases:
            print(f"{c.index} {c.name}")
        print(f"{len(cases)} cases")
        return 0
    out = a.out or os.path.join("output", "sweep", os.path.splitext(os.path.basename(a.sweep))[0])

    if a.table_only:
        if not os.path.isdir(out):
            print(f"sweep: error: {out}: no such directory (run the sweep first)", file=sys.stderr)
            return 1
    else:
        # the binary and the launcher before any case (each case failed "cannot start" and left its directory)
        if not shutil.which(a.bin or launch.default_binary()):
            ap.error(f"--bin {a.bin or launch.default_binary()}: not an executable file (build it, or give --bin)")
        if a.np > 1 and not shutil.which(a.mpiexec or launch.default_mpiexec()):
            ap.error(f"--mpiexec {a.mpiexec or launch.default_mpiexec()}: not an executable file")
        why = unwritable_dir(out)
        if why:
            ap.error(f"--out {why}")
        try:
            os.makedirs(out, exist_ok=True)
        except OSError as e:  # what unwritable_dir cannot see (root on a read-only file system)
            ap.error(f"--out {out}: cannot create it: {e.strerror}")
        todo = cases if a.case is None else [cases[a.case]]
        codes = []
        try:
            for c in todo:
                print(f"== {c.index + 1}/{len(cases)} {c.name}", flush=True)
                code = run_case(c, out, a.np, a.bin, a.mpiexec, a.timeout)
                row = case_row(c, out)
                print(f"   exit {code}: {row['status']}", flush=True)
                codes.append(code)
        except WriteError as e:  # a full disk: the next cases would fail alike, the table too
            print(f"sweep: error: {e}; the sweep stopped at case {c.index} ({c.name})", file=sys.stderr)
            return 1
        except CaseInterrupted as e:
            row = case_row(e.case, out)
            table = ""
            if a.case is None:
                try:
                    write_tables(cases, out)
                    table = f"; {os.path.join(out, 'sweep.csv')} lists the cases run, the rest 'not run'"
                except WriteError as w:
                    table = f"; no table ({w})"
            print(f"sweep: interrupted by {e.signal_name} during case {e.case.index} ({e.case.name}): "
                  f"stopped ({row['status']}), recorded in {os.path.join(out, e.case.name, 'run.json')}{table}",
                  file=sys.stderr)
            return interrupted_exit(e.signal_name)
        if a.case is not None:  # an array task: the table is built by --table-only at the end
            return 0 if codes[0] == 0 else SWEEP_EXIT_CASE_FAILED
    try:
        rows = write_tables(cases, out)
    except WriteError as e:
        print(f"sweep: error: {e}", file=sys.stderr)
        return 1
    print(f"{os.path.join(out, 'sweep.csv')}, {os.path.join(out, 'sweep.md')}: {len(rows)} cases, "
          f"{sum(r['exit_code'] == 0 for r in rows)} exited 0")
    if a.table_only:
        return 0
    return 0 if all(code == 0 for code in codes) else SWEEP_EXIT_CASE_FAILED


def interrupted_exit(signal_name):
    """The exit code of a sweep ended by a signal: 128 + its number (130 for Ctrl-C, 143 for
    SIGTERM), as a shell gives a command the signal ended."""
    return 128 + int(getattr(signal, signal_name))


def on_sigterm(signum, frame):
    """SIGTERM (a scheduler's, `kill`) ends the sweep as Ctrl-C does: the running case is stopped
    with a checkpoint and recorded."""
    e = KeyboardInterrupt()
    e.signal_name = "SIGTERM"
    raise e


def main(argv=None):
    here = threading.current_thread() is threading.main_thread()  # only there may Python set a handler
    previous = signal.signal(signal.SIGTERM, on_sigterm) if here else None
    try:
        return sweep_main(argv)
    except KeyboardInterrupt as e:  # outside a case's run (reading the sweep, between cases, --table-only)
        name = getattr(e, "signal_name", "SIGINT")
        print(f"sweep: interrupted by {name}", file=sys.stderr)
        return interrupted_exit(name)
    finally:
        if here:
            signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":
    sys.exit(main())
