"""Stability suite, the runs: which cases there are, what each is expected to do, and running one
case with one solver (a copy of its deck with `solver` changed)."""
import glob
import os
import re
import subprocess
import time

from hyperqn_tools import launch
from hyperqn_tools.cli import writing
from hyperqn_tools.decks import portable_copy, write_deck

# The converged reference: full steps only (sub-steps of the fallback chain would change the time
# discretization it is the reference of).
REFERENCE_SOLVER = {"type": "newton", "newton_hessian": "exact", "iterations": 100, "grad_rtol": 1.0e-10,
                    "grad_atol": 0.0, "max_halvings": 0, "newton_fallback": False}

# The output keys every run of the suite is given (run_deck): what judge.analyse_run reads.
JUDGED_OUTPUT = {"vtk": True, "iterations_csv": True}

# A deck may state its expectation in a comment line "# stability: expect rest" (or "reference"),
# overriding the automatic rule (rest when there is no gravity and nothing else drives the body or
# changes its rest shape: DRIVERS): e.g. spin_one_turn, whose support turns a full turn and stops
# where it started.
EXPECT_MARK = re.compile(r"^#\s*stability:\s*expect\s+(rest|reference)\b")


def case_name(deck_path):
    return os.path.splitext(os.path.basename(deck_path))[0]


# Report order: the sweeps in sweep order, then the single cases; decks not listed go last.
ORDER = ["stiff_x1", "stiff_x1e2", "stiff_x1e4", "stiff_x1e6", "nu_0p3", "nu_0p45", "nu_0p49", "nu_0p499",
         "nu_0p4999", "dt_1_240", "dt_1_30", "dt_1_5", "dt_1", "initial_squash", "initial_collapse",
         "initial_random", "initial_invert", "twist_two_turns", "spin_one_turn", "contrast_1e4", "thin_1to100"]


def case_order(deck_path):
    name = case_name(deck_path)
    return (ORDER.index(name), "") if name in ORDER else (len(ORDER), name)


def description(deck_path):
    """The deck's leading comment block, without the "Stability suite: " prefix."""
    lines = []
    with open(deck_path) as f:
        for line in f:
            if not line.startswith("#"):
                break
            lines.append(line[1:].strip())
    text = " ".join(lines)
    text = re.sub(r"^Stability suite:\s*", "", text)
    text = re.sub(r"\s*stability: expect \w+\s*", " ", text).strip()
    return re.sub(r"\s*(Needs|Uses) the top-level deck key 'initial'.*$", "", text)


# Keys that, set anywhere in a deck (its bodies and regions included), keep a body from settling at
# its rest shape: loads, moving supports, attachments and colliders, plastic flow (a permanent set),
# cuts and the other topology changes.
DRIVERS = ("loads", "motion", "plastic", "yield_strain", "cuts", "fracture", "tear", "snap")


def is_driven(node):
    if isinstance(node, dict):
        return any(k in DRIVERS and v not in (None, False, [], {}) for k, v in node.items()) or \
            any(is_driven(v) for v in node.values())
    if isinstance(node, list):
        return any(is_driven(v) for v in node)
    return False


def expectation(deck_path, deck):
    """'rest' when the body must settle at its rest shape, else 'reference' (judged against a
    converged run): the deck's "# stability: expect ..." comment, else rest when there is no
    gravity and nothing drives the body (is_driven)."""
    with open(deck_path) as f:
        for line in f:
            m = EXPECT_MARK.match(line.strip())
            if m:
                return m.group(1)
    gravity = deck.get("gravity", [0, -9.81, 0])
    return "rest" if all(g == 0 for g in gravity) and not is_driven(deck) else "reference"


def run_deck(deck, deck_path, solver_section, outdir, binary, np_ranks, mpiexec, timeout):
    """Writes a copy of the deck with `solver_section` merged into `solver` (and JUDGED_OUTPUT into
    `output`), runs hyperqn on it
    into outdir (np_ranks = 1: the binary alone, without mpiexec); returns {'returncode',
    'output', 'timed_out', 'seconds'}."""
    with writing(outdir):
        os.makedirs(outdir, exist_ok=True)
    d = portable_copy(deck, deck_path)
    d.setdefault("name", case_name(deck_path))
    d["solver"] = {**(d.get("solver") or {}), **solver_section}
    # What the judgement reads, whatever the deck says: the frames (output.vtk: false left a run
    # with nothing to judge its end state by, judged ok) and iterations.csv (g monotone).
    if isinstance(d.get("output"), dict) or d.get("output") is None:  # anything else: hyperqn says so
        d["output"] = {**(d.get("output") or {}), **JUDGED_OUTPUT}
    copy_path = write_deck(os.path.join(outdir, "deck.yaml"), d)  # a cli.WriteFailed on a full disk
    for old in glob.glob(os.path.join(outdir, "*")):  # results of an earlier run would mislead
        if os.path.basename(old) not in ("deck.yaml",) and os.path.isfile(old):
            os.remove(old)
    args = [copy_path, "-o", outdir]
    ranks = None if np_ranks == 1 else np_ranks
    cmd = launch.command(args, ranks, binary, mpiexec)
    t0 = time.time()
    try:
        proc = launch.run(args, ranks, binary, mpiexec, timeout=timeout)
        result = {"returncode": proc.returncode, "output": proc.stdout, "timed_out": False}
    except subprocess.TimeoutExpired as e:
        result = {"returncode": None, "output": e.stdout or "", "timed_out": True}
    except OSError as e:  # the binary could not be started: a crash of this run, not of the suite
        result = {"returncode": None, "output": f"cannot start {cmd[0]}: {e}", "timed_out": False}
    result["seconds"] = time.time() - t0
    with writing(os.path.join(outdir, "run.log")), open(os.path.join(outdir, "run.log"), "w") as f:
        f.write(" ".join(cmd) + "\n" + result["output"])
    return result


def rejection(output):
    """hyperqn's message when it rejected the deck before running (an input error naming the
    deck file and line), without the file and line (those of the run's copy), else None."""
    m = re.search(r"hyperqn: error: \S+?\.yaml:\d+: (.*)", output)
    return m.group(1).strip() if m else None

