"""Runs started in a session of their own (mpiexec and its ranks, or hyperqn alone), found and ended
by their process ids: for harnesses that kill runs on purpose (scripts/faults.py).

Open MPI may leave a rank running when another one is killed; every process of the session
(`ps -s SID`) is found through /proc and ended by its pid, never by name. Standard library only.
"""
import os
import signal
import subprocess
import time

from hyperqn_tools import launch


def start(args, ranks, binary, mpiexec, log_path):
    """Starts hyperqn (launch.command: `mpiexec -n ranks hyperqn args...`, ranks=None: alone) in a
    new session, its stdout and stderr going to the file log_path; returns the Popen. The session's
    id is the Popen's pid."""
    cmd = launch.command(args, ranks, binary, mpiexec)
    with open(log_path, "w") as log:
        return subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                env={**os.environ, **launch.MPI_ENV}, start_new_session=True)


def members(session, name=None):
    """Pids of the live processes of a session (zombies left out), only those whose command is
    `name` if given."""
    pids = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as f:
                stat = f.read()
        except OSError:  # gone meanwhile
            continue
        comm = stat[stat.index("(") + 1:stat.rindex(")")]
        fields = stat[stat.rindex(")") + 2:].split()  # state, ppid, pgrp, session, ...
        if int(fields[3]) == session and fields[0] != "Z" and (name is None or comm == name):
            pids.append(int(entry))
    return pids


def send(pids, sig):
    """Sends sig to each pid; a process already gone is not an error."""
    for pid in pids:
        try:
            os.kill(pid, sig)
        except ProcessLookupError:
            pass


def wait(proc, timeout):
    """proc's exit code, or None if it is still running after timeout seconds."""
    try:
        return proc.wait(timeout=max(timeout, 0.001))
    except subprocess.TimeoutExpired:
        return None


def end(proc, deadline_s=20):
    """SIGKILLs every process of proc's session until none is left, and reaps proc. Returns True
    when the session is empty (False: a process survived deadline_s seconds of SIGKILLs)."""
    deadline = time.time() + deadline_s
    while True:
        left = members(proc.pid)
        send(left, signal.SIGKILL)
        if proc.poll() is None:
            send([proc.pid], signal.SIGKILL)
            wait(proc, 1)
        if not left and proc.poll() is not None:
            return True
        if time.time() > deadline:
            return False
        time.sleep(0.05)
