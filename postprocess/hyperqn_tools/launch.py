"""Runs hyperqn, alone or under mpiexec. Standard library only (bench/bench.py needs no numpy).

The binary is $HYPERQN_BIN, else build/hyperqn in the repository; the launcher is $MPIEXEC, else
`mpiexec`. Open MPI refuses to run as root and to put more ranks than cores on a machine unless
the variables of MPI_ENV are set; every run gets them. MPI_ENV also sets the wait between SIGTERM
and SIGKILL when mpiexec ends the ranks of a run that one rank left with a non-zero exit code to 0
(Open MPI's default makes every such run take 2 s longer; hyperqn's ranks leave an input error
together, after MPI_Finalize, so there is nothing left to wait for).
"""
import json
import os
import signal
import subprocess
import time

from hyperqn_tools.paths import REPO

MPI_ENV = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1", "OMPI_MCA_odls_base_sigkill_timeout": "0"}
WAIT_S = 1.0  # run's longest wait for the run in one call, so that a signal to the caller is taken
STOP_GRACE_S = 10  # after SIGUSR1 on a timeout, how long the ranks get to write a checkpoint and stop
EXIT_INTERRUPTED = 3  # hyperqn's exit code when a signal stopped it with a checkpoint (kExitInterrupted)


class Interrupted(KeyboardInterrupt):
    """The caller was interrupted while a run went on (Ctrl-C: KeyboardInterrupt; a caller's own
    handler may raise one with a `signal_name`, e.g. for SIGTERM). The run, in a session of its own,
    does not see the terminal's SIGINT: `run` stops it as on a timeout (SIGUSR1: a checkpoint; a
    second Ctrl-C meanwhile: SIGKILL) and raises this, with the run's exit code and output so far."""

    def __init__(self, cmd, returncode, output, signal_name="SIGINT"):
        super().__init__(f"{signal_name} while running {' '.join(cmd)}")
        self.cmd, self.returncode, self.output, self.signal_name = cmd, returncode, output, signal_name


class Timeout(subprocess.TimeoutExpired):
    """The run outlived its `timeout` and was stopped (`stop`: SIGUSR1, SIGKILL after STOP_GRACE_S),
    with its exit code then: EXIT_INTERRUPTED when it stopped with a checkpoint, negative when
    SIGKILL ended it, or the code of a run that the signal reached once its last frame's solve had
    ended, which completes (docs/outputs.md#checkpoints)."""

    def __init__(self, cmd, timeout, returncode, output=None, stderr=None):
        super().__init__(cmd, timeout, output=output, stderr=stderr)
        self.returncode = returncode

    def completed(self):
        """Whether the run ended by itself, not stopped by the signal (hyperqn's exit 3) or killed."""
        return self.returncode is not None and self.returncode >= 0 and self.returncode != EXIT_INTERRUPTED


def default_binary():
    return os.environ.get("HYPERQN_BIN", os.path.join(REPO, "build", "hyperqn"))


def default_mpiexec():
    return os.environ.get("MPIEXEC", "mpiexec")


def command(args, ranks=1, binary=None, mpiexec=None):
    """`mpiexec -n ranks hyperqn args...`; ranks=None: the binary alone (a singleton MPI process,
    which starts faster)."""
    launcher = [] if ranks is None else [mpiexec or default_mpiexec(), "-n", str(ranks)]
    return launcher + [binary or default_binary()] + [str(a) for a in args]


def run(args, ranks=1, binary=None, mpiexec=None, timeout=None, stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT, check=False):
    """Runs hyperqn (see `command`) and returns the CompletedProcess; by default its stdout and
    stderr are one text in .stdout. stdout/stderr may also be open files or DEVNULL.

    After `timeout` seconds the run is stopped, mpiexec and its ranks with it, and Timeout (a
    subprocess.TimeoutExpired) is raised with the output and the exit code. check=True raises
    CalledProcessError on a non-zero exit code. OSError when the binary cannot be started.
    Interrupted (a KeyboardInterrupt) when the caller is interrupted meanwhile: the run is stopped
    first, not left running."""
    cmd = command(args, ranks, binary, mpiexec)
    # Own session, so a hung run can be killed as one process group.
    proc = subprocess.Popen(cmd, stdout=stdout, stderr=stderr, text=True,
                            env={**os.environ, **MPI_ENV}, start_new_session=True)
    deadline = None if timeout is None else time.monotonic() + timeout
    try:
        while True:
            # Waits of a second at most: without a timeout, communicate() reads the output in one
            # blocking read, where a signal that comes just before it (Ctrl-C) is not seen until
            # the run ends; between short waits Python takes it.
            wait = WAIT_S if deadline is None else max(0.0, min(WAIT_S, deadline - time.monotonic()))
            try:
                out, err = proc.communicate(timeout=wait)
                break
            except subprocess.TimeoutExpired:
                if deadline is not None and time.monotonic() >= deadline:
                    out, err = stop(proc)
                    raise Timeout(cmd, timeout, proc.returncode, output=out, stderr=err) from None
    except KeyboardInterrupt as e:  # not passed on to the run by the terminal (its own session)
        try:
            out, err = stop(proc)
        except KeyboardInterrupt:  # a second one while it stops: no grace
            kill(proc)
            out, err = proc.communicate()
        raise Interrupted(cmd, proc.returncode, out if isinstance(out, str) else None,
                          getattr(e, "signal_name", "SIGINT")) from None
    done = subprocess.CompletedProcess(cmd, proc.returncode, out, err)
    if check:
        done.check_returncode()
    return done


def registry(binary=None):
    """The material models and solvers the binary registers (`hyperqn registry`): a dict with
    lists "materials" ({name, summary, parameters}), "solvers" ({name, summary,
    uses_constant_matrix}) and "deck_keys" ({section, name, type, default, unit, choices, doc}: the
    declared deck keys, params/deck_keys.hpp), in the binary's order."""
    done = run(["registry"], ranks=None, binary=binary, stderr=subprocess.DEVNULL, check=True, timeout=60)
    return json.loads(done.stdout)


def solver_names(binary=None):
    """The names of every registered solver, as decks write them in solver.type."""
    return [s["name"] for s in registry(binary)["solvers"]]


def deck_choices(section, name, reg):
    """The names a deck may give `section.name` (a key of type choice, e.g. time integrator), from
    the deck_keys of `reg`, a `registry()`; [] when the binary declares no such key."""
    return next((k["choices"] for k in reg["deck_keys"] if (k["section"], k["name"]) == (section, name)), [])


def stop(proc):
    """SIGUSR1, then SIGKILL to whatever is left of the process group, so that no rank keeps running
    or holds the output pipe open; returns the rest of the run's output, as communicate() does.
    mpiexec forwards SIGUSR1 to its ranks, which stop with a checkpoint (docs/cluster.md); a SIGTERM
    it would follow with SIGKILL (MPI_ENV's wait of 0) before they had written anything. The output
    is read while the run stops: a run writing fast blocks on a full pipe and would never stop."""
    proc.send_signal(signal.SIGUSR1)
    try:
        return proc.communicate(timeout=STOP_GRACE_S)
    except subprocess.TimeoutExpired:
        pass
    kill(proc)
    return proc.communicate()


def kill(proc):
    """SIGKILL to the run's process group (mpiexec and its ranks, or the binary alone); waits for it."""
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:  # the group is gone already
        pass
    proc.wait()
