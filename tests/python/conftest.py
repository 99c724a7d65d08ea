"""Shared helpers for the end-to-end tests: where the binary is, and how to run it under MPI.
Running and deck writing are those of postprocess/hyperqn_tools (on PYTHONPATH; ctest sets it)."""
import json
import os
import re

import pytest

from hyperqn_tools import decks, launch
from hyperqn_tools.paths import REPO

HYPERQN = launch.default_binary()
MPIEXEC = launch.default_mpiexec()


def run_hyperqn(args, ranks=1, timeout=600, check=True):
    """Runs `mpiexec -n ranks hyperqn args...` (ranks=None: the binary alone, as a singleton MPI
    process, which starts faster); returns the CompletedProcess (stdout+stderr text)."""
    proc = launch.run(args, ranks, HYPERQN, MPIEXEC, timeout=timeout)
    if check and proc.returncode != 0:
        raise AssertionError(f"{' '.join(proc.args)} failed ({proc.returncode}):\n{proc.stdout[-4000:]}")
    return proc


def run_at_1_and_2_ranks(deck_path, tmp):
    """Runs the deck at 1 and 2 ranks with -log_view; returns {ranks: (outdir, PETSc log text)}."""
    out = {}
    for ranks in (1, 2):
        outdir = tmp / f"np{ranks}"
        log = tmp / f"log_view_np{ranks}.txt"
        run_hyperqn([deck_path, "-o", outdir, "-log_view", f":{log}"], ranks=ranks)
        out[ranks] = (str(outdir), log.read_text())
    return out


def event_count(log_text, event):
    """Call count of a PETSc -log_view event (max over ranks)."""
    m = re.search(rf"^{event}\s+(\d+)", log_text, re.M)
    return int(m.group(1)) if m else 0


# solver keys that turn the fallback chain off (docs/guardrails.md#fallback): for the tests of
# what happens to a frame or a run that the chain would otherwise rescue.
NO_FALLBACK = {"max_iterations": 0, "max_halvings": 0, "newton_fallback": False}
# solver key that starts each step from y itself, not pulled back where y inverts or blows up
# elements (docs/guardrails.md#element-blow-up-and-inversion): for the tests of run-aways that
# the pulled-back guess would avoid.
FROM_Y = {"upright_guess": False}


def run_deck(tmp_path, name, deck, ranks=None, extra=()):
    """Writes deck to tmp_path/NAME.yaml, runs it into tmp_path/NAME (with the extra arguments) and
    returns that directory and its summary.json; the run must end with status ok."""
    out = tmp_path / name
    proc = run_hyperqn([write_deck(tmp_path / f"{name}.yaml", deck), "-o", out, *extra], ranks=ranks)
    with open(out / "summary.json") as f:
        summary = json.load(f)
    assert summary["status"] == "ok", proc.stdout[-3000:]
    return out, summary


def write_deck(path, deck):
    return decks.write_deck(path, deck)


def load_deck(name):
    """A deck of the repository by its path from the repository root."""
    return decks.load_deck(os.path.join(REPO, name))


@pytest.fixture
def repo():
    return REPO
