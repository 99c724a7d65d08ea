"""Reads PETSc's -log_view text (3.18's layout, and the older "MPI Messages" names): the run's
message summary and the event lines. Standard library only.

What PETSc counts (petsclog.h's macros around the MPI calls of any code that includes PETSc's
headers, hyperqn's too): a message per point-to-point send (Msg Count halves sends + receives);
its length; a "reduction" per MPI_Allreduce, MPI_Bcast or gather/scatter on a communicator of
more than one rank, with no length. An event line's Mess is the sum over the ranks, its AvgLen
the bytes per message, its Reduct the count per rank.
"""
import re

# Fixed two-digit exponents: PETSc prints "%2.1e%3d", which glues 4.4e+01 to a following 100.
_NUMBER = re.compile(r"[-+]?\d+\.\d+e[-+]\d\d|[-+]?\d+\.\d+|[-+]?\d+")
_SUMMARY = {  # key: the line's names (3.18 first)
    "messages": ("MPI Msg Count:", "MPI Messages:"),
    "message_bytes": ("MPI Msg Len (bytes):", "MPI Message Lengths:"),
    "reductions": ("MPI Reductions:",),
    "time": ("Time (sec):",),
}
# An event line: name, count, its ratio, max time, ratio, max flop, ratio, Mess, AvgLen, Reduct,
# %T %F %M %L %R (global), the same for the stage, total Mflop/s.
_EVENT_NUMBERS = 20


def summary(text):
    """{key: {"max", "ratio", "avg", "total"}} of the run's summary lines that are there (reductions
    have max and ratio only): whole run, setup included."""
    found = {}
    for line in text.splitlines():
        for key, names in _SUMMARY.items():
            for name in names:
                if line.startswith(name):
                    values = [float(v) for v in _NUMBER.findall(line[len(name):])]
                    found[key] = dict(zip(("max", "ratio", "avg", "total"), values))
    return found


def events(text, names=None):
    """{event: {"count", "time_max", "messages", "avg_bytes", "reductions", "bytes"}} of the event
    lines (names: only those); messages and bytes summed over the ranks, reductions per rank. A
    line whose numbers do not parse as an event line is skipped."""
    found = {}
    for line in text.splitlines():
        parts = line.split(None, 1)
        if len(parts) != 2 or (names is not None and parts[0] not in names):
            continue
        values = _NUMBER.findall(parts[1])
        if len(values) != _EVENT_NUMBERS or not re.match(r"^\d+$", values[0]):
            continue
        messages, avg_bytes, reductions = (float(v) for v in values[6:9])
        found[parts[0]] = {"count": int(values[0]), "time_max": float(values[2]), "messages": messages,
                           "avg_bytes": avg_bytes, "reductions": reductions, "bytes": messages * avg_bytes}
    return found
