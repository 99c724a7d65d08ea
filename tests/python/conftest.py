"""Shared helpers for the end-to-end tests: where the binary is, and how to run it under MPI."""
import os
import re
import subprocess
import sys

import pytest
import yaml

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
sys.path.insert(0, os.path.join(REPO, "postprocess"))

HYPERQN = os.environ.get("HYPERQN_BIN", os.path.join(REPO, "build", "hyperqn"))
MPIEXEC = os.environ.get("MPIEXEC", "mpiexec")
SHARED_MESHES = os.path.abspath(os.path.join(REPO, "..", "shared", "meshes"))
MPI_ENV = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1"}


def run_hyperqn(args, ranks=1, timeout=600, check=True):
    """Runs `mpiexec -n ranks hyperqn args...` (ranks=None: the binary alone, as a singleton MPI
    process, which starts faster); returns the CompletedProcess (stdout+stderr text)."""
    launcher = [] if ranks is None else [MPIEXEC, "-n", str(ranks)]
    cmd = launcher + [HYPERQN] + [str(a) for a in args]
    proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                          timeout=timeout, env={**os.environ, **MPI_ENV})
    if check and proc.returncode != 0:
        raise AssertionError(f"{' '.join(cmd)} failed ({proc.returncode}):\n{proc.stdout[-4000:]}")
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


def write_deck(path, deck):
    with open(path, "w") as f:
        yaml.safe_dump(deck, f, sort_keys=False)
    return str(path)


def load_deck(name):
    with open(os.path.join(REPO, name)) as f:
        return yaml.safe_load(f)


@pytest.fixture
def repo():
    return REPO
