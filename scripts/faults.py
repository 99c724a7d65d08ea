#!/usr/bin/env python3
"""Fault injection for checkpoints, restarts and outputs: small runs killed, starved of disk,
pointed at unwritable places, restarted from damaged checkpoints, mixed with other runs' files and
requeued, at 1 and 2 ranks (docs/testing.md, "Fault injection"). Each trial ends either equal to the
uninterrupted run of its deck bitwise (final positions and velocities, iterations.csv without
time_s, the .pvd listing, summary.json's counts and status "ok") or with a named error (exit 1 and a
`hyperqn: error: ...` line naming the path), never a hang, never a wrong answer.

    PYTHONPATH=$PWD/postprocess /usr/bin/python3 scripts/faults.py              # make faults: 240 trials
    PYTHONPATH=$PWD/postprocess /usr/bin/python3 scripts/faults.py --budget 35 --seed 7  # ctest faults_quick
    PYTHONPATH=$PWD/postprocess /usr/bin/python3 scripts/faults.py --seed 7 --trial 13   # one trial again

Trial k has class CLASSES[k % n] (of --classes), --ranks[(k // n) % len(ranks)] and its own random
numbers from (--seed, k), so a campaign and any one trial can be rerun; the moments at which kills
land still depend on the machine's speed. Prints a table of outcomes per class and writes
faults.json and faults.csv to --out; a failed trial's decks, commands, outputs and directories stay
in --out/failures/. A rerun removes what an earlier one wrote in --out (failures/, trials/,
references/, faults.json, faults.csv) and nothing else there. Exits 1 on any hang, wrong resume,
undetected corruption or other failure.
Full-disk trials mount a tmpfs (root) and count as skipped where that is not permitted.
"""
import argparse
import csv
import hashlib
import json
import math
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import time
import traceback
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hyperqn_tools import cli, decks, launch, sessions
from hyperqn_tools.output import final_frame, read_pvd, read_summary
from hyperqn_tools.paths import REPO

OUTCOMES = ["passed", "hang", "wrong resume", "undetected corruption", "failure", "skipped"]
# A bar of 4 x 1 x 1 cells, every frame written; the tight tolerance makes each frame take its 40
# iterations, so a run of 100 frames lasts some 0.5-2 s (1-2 ranks, a checkpoint every frame).
BAR = {
    "name": "bar",
    "mesh": {"box": {"size": [1.0, 0.25, 0.25], "cells": [4, 1, 1]}},
    "material": {"model": "neohookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 1000},
    "fixed": [{"box": {"min": [-0.01, -1, -1], "max": [0.01, 1, 1]}}],
    "gravity": [0, -9.81, 0],
    "time": {"dt": 0.02, "frames": 100},
    "solver": {"iterations": 40, "grad_rtol": 1.0e-12, "grad_atol": 1.0e-14},
    "output": {"every": 1},
}
# summary.json entries that an interrupted and continued run must share with the uninterrupted one
# (test_checkpoint.py's assert_same_run).
SUMMARY_KEYS = ["status", "frames", "converged_frames", "failed_frames", "extended_frames", "substepped_frames",
                "newton_frames", "iterations", "evaluations", "min_J", "final_energy", "max_active_contacts"]
KILL_GRACE_S = 5  # after a SIGKILL, how long mpiexec gets to end the other ranks (it takes some 2 s) before we do


def bar(frames, checkpoint=None, vtk=True, youngs_modulus=1.0e5):
    """BAR with `frames` frames, a checkpoint section, VTK on or off and another stiffness."""
    deck = json.loads(json.dumps(BAR))
    deck["time"]["frames"] = frames
    deck["material"]["youngs_modulus"] = youngs_modulus
    if checkpoint:
        deck["checkpoint"] = checkpoint
    if not vtk:
        deck["output"]["vtk"] = False
    return deck


class Verdict(Exception):
    """Ends a trial with an outcome other than "passed"."""

    def __init__(self, outcome, why):
        super().__init__(why)
        self.outcome = outcome
        self.why = why


def fail(why):
    raise Verdict("failure", why)


# ---------------------------------------------------------------------------------------------
# Running hyperqn, and stopping it on purpose


@dataclass
class Stop:
    """When and how to stop a run: when(seconds since start, start time) -> bool; how is "kill"
    (SIGKILL to every process of the run), "kill-one" (SIGKILL to one rank) or "usr1" (SIGUSR1
    to mpiexec, or to hyperqn alone at 1 rank)."""
    when: object
    how: str
    what: str
    kind: str = "at a moment"  # for the tally: "at a moment", "after a frame", "in a checkpoint write"


@dataclass
class Part:
    """One hyperqn process (or mpiexec and its ranks) of a trial."""
    command: str
    code: int
    output: str
    seconds: float
    stopped: str = ""  # how and when it was stopped on purpose, "" if it ran to its end


@dataclass
class Settings:
    binary: str
    mpiexec: str
    timeout: float
    work: Path  # where trials and references go


def run_part(settings, args, ranks, log_path, stop=None):
    """Runs hyperqn args at `ranks` (1: the binary alone), stopped as `stop` says; the whole
    session is ended afterwards. Raises Verdict "hang" if the run outlives settings.timeout."""
    began = time.time()
    proc = sessions.start(args, None if ranks == 1 else ranks, settings.binary, settings.mpiexec, log_path)
    stopped, code = "", None
    try:
        while stop and proc.poll() is None and time.time() - began < settings.timeout:
            if stop.when(time.time() - began, began):
                stopped = f"{stop.how} at {time.time() - began:.2f} s ({stop.what})"
                send_stop(proc, stop.how)
                break
            time.sleep(0.002)
        grace = KILL_GRACE_S if stopped.startswith("kill") else settings.timeout - (time.time() - began)
        code = sessions.wait(proc, grace)
    finally:
        emptied = sessions.end(proc)
    command = " ".join(launch.command(args, None if ranks == 1 else ranks, settings.binary, settings.mpiexec))
    output = Path(log_path).read_text(errors="replace")
    if code is None and not stopped.startswith("kill"):
        raise Verdict("hang", f"`{command}` did not end within {settings.timeout:.0f} s{', ' + stopped if stopped else ''}"
                      f"; output ends:\n{tail(output)}")
    if not emptied:
        raise Verdict("hang", f"a process of `{command}` survived SIGKILL")
    return Part(command, proc.returncode if code is None else code, output, time.time() - began, stopped)


def send_stop(proc, how):
    if how == "usr1":
        sessions.send([proc.pid], signal.SIGUSR1)
        return
    ranks = sessions.members(proc.pid, "hyperqn")
    if how == "kill-one" and len(ranks) > 1:
        sessions.send([random.Random(proc.pid).choice(ranks)], signal.SIGKILL)
    else:
        sessions.send(sessions.members(proc.pid), signal.SIGKILL)


def tail(text, lines=12):
    return "\n".join("    " + line for line in text.splitlines()[-lines:])


@dataclass
class Reference:
    out: Path
    seconds: float


class References:
    """Uninterrupted runs of decks in fresh directories, one per deck text and rank count."""

    def __init__(self, settings):
        self.settings = settings
        self.done = {}

    def get(self, deck, ranks):
        text = json.dumps(deck, sort_keys=True)
        key = hashlib.sha256(f"{text} {ranks}".encode()).hexdigest()[:12]
        if key not in self.done:
            where = self.settings.work / "references" / f"{key}-np{ranks}"
            shutil.rmtree(where, ignore_errors=True)
            where.mkdir(parents=True)
            path = decks.write_deck(where / "deck.yaml", deck)
            part = run_part(self.settings, [path, "-o", where / "out"], ranks, where / "output.txt")
            if part.code != 0:
                fail(f"the reference run `{part.command}` ended with exit {part.code}:\n{tail(part.output)}")
            self.done[key] = Reference(where / "out", part.seconds)
        return self.done[key]


class Trial:
    """One trial's random numbers, directory, runs and references."""

    def __init__(self, number, kind, ranks, rng, directory, settings, references):
        self.number, self.kind, self.ranks, self.rng = number, kind, ranks, rng
        self.dir = directory
        self.settings = settings
        self.references = references
        self.parts = []
        self.tags = []  # what happened, counted per class over the campaign (a kill's landing, the writer that failed, ...)

    def deck(self, name, deck):
        """Writes the deck into the trial's directory; its path."""
        return decks.write_deck(self.dir / f"{name}.yaml", deck)

    def run(self, args, stop=None):
        log = self.dir / f"part{len(self.parts) + 1}.txt"
        part = run_part(self.settings, args, self.ranks, log, stop)
        self.parts.append(part)
        return part

    def reference(self, deck):
        return self.references.get(deck, self.ranks)

    def report(self):
        """The commands of the trial with their exits and output ends, for failures/."""
        return "\n".join(f"$ {p.command}\n  exit {p.code}, {p.seconds:.2f} s{', stopped: ' + p.stopped if p.stopped else ''}\n"
                         f"{tail(p.output, 30)}" for p in self.parts)


# ---------------------------------------------------------------------------------------------
# What a run left


def frame_file(out, n):
    """The path of frame n (VTK: .vtu at 1 rank, .pvtu at more), whichever exists, else None."""
    for ext in (".vtu", ".pvtu"):
        p = Path(out) / f"bar_{n:05d}{ext}"
        if p.exists():
            return p
    return None


def newer_than(path, began):
    try:
        return path is not None and os.stat(path).st_mtime >= began
    except OSError:
        return False


def checkpoints(out):
    """{frame: path} of the files named as complete checkpoints in OUT/checkpoints."""
    found = {}
    where = Path(out) / "checkpoints"
    for p in where.glob("checkpoint_*.h5") if where.is_dir() else []:
        digits = p.name[len("checkpoint_"):-len(".h5")]
        if digits.isdigit():
            found[int(digits)] = p
    return found


def writing_checkpoint(out):
    """True while a checkpoint's temporary exists (a write in progress)."""
    where = Path(out) / "checkpoints"
    try:
        return any(".tmp" in n for n in os.listdir(where))
    except OSError:
        return False


def problems(out):
    """What is not whole in an output directory: a .pvd listing a missing or hidden file, a listed
    file that does not parse, iterations.csv with a partial row, summary.json not valid JSON."""
    out = Path(out)
    if not out.is_dir():
        return []
    found = []
    pvds = [p for p in out.glob("*.pvd")]
    if len(pvds) > 1:
        found.append(f"several .pvd files: {[p.name for p in pvds]}")
    for pvd in pvds:
        try:
            listed = [Path(f) for _, f in read_pvd(pvd)]
            for f in listed:
                pieces = [f] if f.suffix == ".vtu" else [f] + [f.parent / p.get("Source") for p in ET.parse(f).getroot().iter("Piece")]
                for piece in pieces:
                    if piece.name.startswith("."):
                        found.append(f"{pvd.name} lists a temporary {piece.name}")
                    ET.parse(piece)
        except (OSError, ValueError, ET.ParseError) as e:  # ValueError: read_pvd's for a partial .pvd
            found.append(f"{pvd.name} lists a missing or partial file: {e}")
    csv_path = out / "iterations.csv"
    if csv_path.is_file():
        text = csv_path.read_text(errors="replace")
        rows = list(csv.reader(text.splitlines()))
        if text and not text.endswith("\n"):
            found.append(f"iterations.csv ends inside a row: {text[-80:]!r}")
        elif rows and any(len(r) != len(rows[0]) for r in rows):
            found.append("iterations.csv has rows of another length than its header")
    if (out / "summary.json").is_file():
        try:
            read_summary(out)
        except ValueError as e:
            found.append(f"summary.json is not valid JSON: {e}")
    return found


def status(out):
    """summary.json's status, or None without a (valid) summary.json."""
    try:
        return read_summary(out).get("status")
    except (OSError, ValueError):
        return None


def iteration_rows(out):
    with open(Path(out) / "iterations.csv") as f:
        return [{k: v for k, v in r.items() if k != "time_s"} for r in csv.DictReader(f)]


def differences(ref, out):
    """What differs between the run in out and the uninterrupted run in ref ([]: bitwise the same):
    summary.json's counts and status, iterations.csv without time_s, the .pvd listing, and the
    final frame's positions and velocities."""
    found = []
    try:
        a, b = read_summary(ref), read_summary(out)
        found += [f"summary {k}: {b.get(k)!r}, uninterrupted {a.get(k)!r}" for k in SUMMARY_KEYS if a.get(k) != b.get(k)]
        if iteration_rows(ref) != iteration_rows(out):
            found.append("iterations.csv differs (time_s aside)")
        if list(Path(ref).glob("*.pvd")):
            listing = [[(t, Path(f).name) for t, f in read_pvd(next(Path(d).glob("*.pvd")))] for d in (ref, out)]
            if listing[0] != listing[1]:
                found.append(f"the .pvd lists {len(listing[1])} frames, uninterrupted {len(listing[0])}, or other ones")
            fa, fb = final_frame(ref), final_frame(out)
            for what in ("vertex_id", "points", "velocity"):
                if not np.array_equal(getattr(fa, what), getattr(fb, what)):
                    found.append(f"final frame {what} differs")
    except (OSError, ValueError, StopIteration, KeyError, ET.ParseError) as e:
        found.append(f"cannot read the run: {type(e).__name__}: {e}")
    return found


def lines_with(text, prefix):
    return [line for line in text.splitlines() if line.startswith(prefix)]


def errors(part):
    return lines_with(part.output, "hyperqn: error:")


def warnings(part):
    return lines_with(part.output, "hyperqn: warning:")


def restarted_from(part):
    """The checkpoint a run says it restarted from, else None."""
    m = re.search(r"^hyperqn: restart from (.+?\.h5)\b", part.output, re.M)
    return Path(m.group(1)) if m else None


def expect_whole(out):
    found = problems(out)
    if found:
        fail("left incomplete files: " + "; ".join(found))


def expect_same(ref, out, part):
    """The run ended with exit 0, and equals the uninterrupted one (else a failure)."""
    if part.code != 0:
        fail(f"`{part.command}` ended with exit {part.code}:\n{tail(part.output)}")
    expect_whole(out)
    found = differences(ref, out)
    if found:
        fail("differs from the uninterrupted run: " + "; ".join(found))


def expect_named_error(part, fragment, out=None):
    """Exit 1 with a `hyperqn: error:` line naming fragment; summary.json, if any, not "ok"."""
    named = [line for line in errors(part) if fragment in line]
    if part.code != 1 or not named:
        fail(f"expected exit 1 and `hyperqn: error: ...{fragment}...`, got exit {part.code}:\n{tail(part.output)}")
    if "PETSC ERROR" in part.output:
        fail(f"a raw PETSc trace besides the error:\n{tail(part.output)}")
    if out is not None:
        expect_whole(out)
        if status(out) == "ok":
            fail("summary.json says ok after an error")
    return named[0]


def random_kill(rng, out, first, frames, seconds, ranks):
    """A kill -9 at a random moment of a run lasting some `seconds` (from its start, so possibly
    before its first frame), right after a random frame in (first, frames), or during a checkpoint
    write after it."""
    how = "kill-one" if ranks > 1 and rng.random() < 0.3 else "kill"
    kind = rng.choice(["moment", "frame", "checkpoint write"])
    n = rng.randint(min(first + 1, frames - 1), frames - 1)
    if kind == "moment":
        t = rng.uniform(0, seconds)
        return Stop(lambda elapsed, began: elapsed >= t, how, "at a random moment")
    if kind == "frame":
        return Stop(lambda elapsed, began: newer_than(frame_file(out, n), began), how, f"after frame {n}", "after a frame")
    return Stop(lambda elapsed, began: newer_than(frame_file(out, n), began) and writing_checkpoint(out), how,
                f"in a checkpoint write after frame {n}", "in a checkpoint write")


# ---------------------------------------------------------------------------------------------
# The trial classes: each returns a note on what happened (passed) or raises Verdict.


def kill_trial(t):
    """kill -9 at random moments, each time continued with --restart latest (afresh while there is
    no checkpoint), until the run ends: equal to the uninterrupted run."""
    frames = t.rng.choice([100, 150])
    deck = bar(frames, {"every": t.rng.choice([1, 1, 2, 5]), "keep": t.rng.choice([1, 2, 3])})
    ref, path, out = t.reference(deck), t.deck("run", deck), t.dir / "out"
    kills = t.rng.randint(1, 3)
    notes = []
    for k in range(kills + 1):
        first = max(checkpoints(out), default=0)  # where this part starts
        resume = ["--restart", "latest"] if checkpoints(out) else []
        stop = random_kill(t.rng, out, first, frames, ref.seconds, t.ranks) if k < kills else None
        part = t.run([path, "-o", out, *resume], stop)
        expect_whole(out)
        if not part.stopped:
            notes += [f"no kill {stop.what}: the run ended before"] if stop else []
            t.tags += ["kill missed"] if stop else []
            break
        notes.append(part.stopped)
        t.tags.append(f"{stop.how} {stop.kind}")
    expect_same(ref.out, out, part)
    return "; ".join(notes)


def mount_tmpfs(where, kilobytes):
    """Mounts a tmpfs of that size at where; raises Verdict "skipped" where that is not permitted."""
    where.mkdir()
    try:
        done = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={kilobytes}k", "tmpfs", str(where)],
                              capture_output=True, text=True, timeout=20)
    except (OSError, subprocess.TimeoutExpired) as e:
        raise Verdict("skipped", f"cannot mount a tmpfs: {e}")
    if done.returncode != 0:
        raise Verdict("skipped", f"cannot mount a tmpfs: {done.stderr.strip()}")


def pages(directory):
    """The 4 KiB pages the files under directory take on a tmpfs."""
    return sum(math.ceil(p.stat().st_size / 4096) for p in Path(directory).rglob("*") if p.is_file())


def writer_of(lines):
    """Which writer the paths of error lines belong to (summary.json only if no other: a run that
    fails to write a frame also fails to write its final summary.json on a full disk)."""
    for key, writer in (("checkpoint", "checkpoint HDF5"), (".vtu", "VTK"), (".pvtu", "VTK"), (".pvd", "VTK"),
                        ("iterations.csv", "CSV"), ("summary.json", "summary.json")):
        if key in lines:
            return writer
    return "other"


def full_disk_trial(t):
    """A run with checkpoints (every frame, or every 5th: then a VTK or CSV write may be the one that
    fails) into a tmpfs too small for it (a random size up to a bit more than the run needs): exit 1
    naming the path and "No space left on device", whole files, or, if it fitted, equal to the
    uninterrupted run."""
    checkpoint = t.rng.choice([{"every": 1, "keep": 2}, {"every": 1, "keep": 2}, {"every": 5, "keep": 1}])
    deck = bar(20, checkpoint, vtk=t.rng.random() < 0.5)
    ref, path = t.reference(deck), t.deck("run", deck)
    kilobytes = 4 * t.rng.randint(1, int(pages(ref.out) * 1.15) + 1)
    disk = t.dir / "disk"
    mount_tmpfs(disk, kilobytes)
    what = (f"a {kilobytes} kB disk ({'VTK' if deck['output'].get('vtk', True) else 'no VTK'}, "
            f"checkpoint every {checkpoint['every']})")
    try:
        out = disk / "out"
        part = t.run([path, "-o", out])
        try:
            if part.code == 0:
                expect_same(ref.out, out, part)
                t.tags.append("the run fitted")
                return f"{what}: the run fitted"
            expect_named_error(part, str(disk), out)
            named = "\n".join(line for line in errors(part) if str(disk) in line)
            if "No space left on device" not in named:
                fail(f"the error does not say \"No space left on device\": {named}")
            t.tags.append(f"{writer_of(named)} full")
            return f"{what}: {writer_of(named)}: {named}"
        except Verdict as v:
            shutil.copytree(disk, t.dir / "disk_contents", symlinks=True)
            raise Verdict(v.outcome, f"{what}: {v.why}")
    finally:
        subprocess.run(["umount", str(disk)], capture_output=True, timeout=30)
        if os.path.ismount(disk):
            subprocess.run(["umount", "-l", str(disk)], capture_output=True, timeout=30)


def unwritable_trial(t):
    """An output place that cannot be written (root ignores permission bits, so a regular file or
    a directory stands where a directory or a file must go): exit 1 naming it."""
    place = t.rng.choice(["output directory is a file", "output directory below a file", "checkpoints is a file",
                          "iterations.csv is a directory", "summary.json is a directory"])
    deck = bar(10, {"every": t.rng.choice([1, 3]), "keep": 2})
    path, out = t.deck("run", deck), t.dir / "out"
    if place.startswith("output directory"):
        blocker = t.dir / "blocker"
        blocker.write_text("a regular file\n")
        out = blocker if place.endswith("is a file") else blocker / "out"
    else:
        out.mkdir()
        blocker = out / place.split()[0]
        if place.endswith("a file"):
            blocker.write_text("a regular file\n")
        else:
            (blocker / "keep").mkdir(parents=True)  # not empty: nothing may remove it
    part = t.run([path, "-o", out])
    line = expect_named_error(part, str(blocker), out if out.is_dir() else None)
    t.tags.append(place)
    return f"{place}: {line}"


def damage(path, rng):
    """Flips 1-8 random bytes of the file, or (one time in five) cuts it short; says what it did."""
    data = bytearray(path.read_bytes())
    if rng.random() < 0.2:
        keep = rng.randrange(len(data))
        path.write_bytes(data[:keep])
        return f"cut {path.name} to {keep} of {len(data)} bytes"
    offsets = sorted(rng.randrange(len(data)) for _ in range(rng.randint(1, 8)))
    for o in offsets:
        data[o] ^= rng.randint(1, 255)
    path.write_bytes(data)
    return f"flipped bytes of {path.name} at {offsets}"


def corrupt_trial(t):
    """A damaged newest checkpoint, then --restart latest with more frames: with keep >= 2 the
    damage is reported and the run continues from the older checkpoint (or the damage hit nothing
    read), equal to the uninterrupted run; with keep 1, exit 1 naming the file, or equal. Exit 0
    with another answer is an undetected corruption."""
    keep = t.rng.choice([1, 2, 2, 3])
    checkpoint = {"every": t.rng.choice([1, 2]), "keep": keep}
    first, frames = t.rng.choice([10, 16]), t.rng.choice([24, 30])
    ref, out = t.reference(bar(frames, checkpoint)), t.dir / "out"
    part = t.run([t.deck("first", bar(first, checkpoint)), "-o", out])
    if part.code != 0:
        fail(f"the first part ended with exit {part.code}:\n{tail(part.output)}")
    newest = checkpoints(out)[max(checkpoints(out))]
    did = damage(newest, t.rng)
    part = t.run([t.deck("then", bar(frames, checkpoint)), "-o", out, "--restart", "latest"])
    told = [line for line in warnings(part) + errors(part) if newest.name in line]
    if part.code == 0:
        found = differences(ref.out, out)
        if found:
            raise Verdict("undetected corruption", f"{did}; exit 0 from {restarted_from(part)} but " + "; ".join(found))
        expect_whole(out)
        t.tags.append("reported, fell back" if told else "nothing read was damaged")
        return f"{did}: " + (f"reported, continued from {restarted_from(part)}" if told else "nothing read was damaged")
    if keep == 1 and part.code == 1 and told and errors(part):
        t.tags.append("keep 1: refused")
        return f"{did}: refused: {errors(part)[0]}"
    fail(f"{did}; keep {keep}: exit {part.code}" + ("" if told else f", {newest.name} not named") + f":\n{tail(part.output)}")


def strays(t, out, frames, checkpoint):
    """Puts 1-3 files into OUT/checkpoints that are not checkpoints of the run there: garbage or a
    copy of another run's checkpoint (other physics, or another run of the same deck) under a
    newer frame's name, and names that do not parse. Returns their names."""
    where = out / "checkpoints"
    newer = [f"checkpoint_{frames + 1}.h5", "checkpoint_999.h5"]
    unparsable = ["checkpoint_x.h5", "checkpoint_.h5", "checkpoint_12a.h5", "checkpoint_99999999999.h5"]
    names = []
    for kind in t.rng.sample(["garbage", "other physics", "same deck", "unparsable"], t.rng.randint(1, 3)):
        name = t.rng.choice(unparsable if kind == "unparsable" else newer)
        if name in names:
            continue
        if kind in ("garbage", "unparsable"):
            (where / name).write_bytes(t.rng.randbytes(t.rng.randint(0, 20000)))
        else:
            other = t.references.get(bar(8, checkpoint, youngs_modulus=2.0e5 if kind == "other physics" else 1.0e5), t.ranks)
            shutil.copyfile(checkpoints(other.out)[8], where / name)
        names.append(name)
    return names


def reuse_trial(t):
    """A directory that held another run. "new deck": run A to its end, then deck B (other frames or
    other physics) into the same directory, killed at a random moment, then --restart latest: B
    continued (equal to B's uninterrupted run) or exit 1 (B had no checkpoint); resuming A's
    checkpoint is a wrong resume. "stray files": other runs' checkpoints, garbage and unparsable
    names in OUT/checkpoints are passed over with a warning each."""
    checkpoint = {"every": t.rng.choice([1, 2]), "keep": 2}
    out = t.dir / "out"
    if t.rng.random() < 0.4:
        ref = t.reference(bar(30, checkpoint))
        part = t.run([t.deck("first", bar(20, checkpoint)), "-o", out])
        if part.code != 0:
            fail(f"the first part ended with exit {part.code}:\n{tail(part.output)}")
        names = strays(t, out, 20, checkpoint)
        part = t.run([t.deck("then", bar(30, checkpoint)), "-o", out, "--restart", "latest"])
        if restarted_from(part) and restarted_from(part).name in names:
            raise Verdict("wrong resume", f"stray files {names}: resumed {restarted_from(part)}")
        expect_same(ref.out, out, part)
        silent = [n for n in names if not any(n in line for line in warnings(part))]
        if silent:
            fail(f"stray files {names}: no warning names {silent}:\n{tail(part.output)}")
        t.tags.append("stray files passed over")
        return f"stray files {names} passed over"
    other = t.rng.choice(["fewer frames", "more frames", "other physics"])
    deck_b = bar({"fewer frames": 60, "more frames": 150, "other physics": 100}[other], checkpoint,
                 youngs_modulus=2.0e5 if other == "other physics" else 1.0e5)
    ref = t.reference(deck_b)
    part = t.run([t.deck("a", bar(100, checkpoint)), "-o", out])
    if part.code != 0:
        fail(f"run A ended with exit {part.code}:\n{tail(part.output)}")
    began = time.time()
    path = t.deck("b", deck_b)
    moment = t.rng.uniform(0, 0.9 * ref.seconds)  # a run into a used directory is no slower
    part = t.run([path, "-o", out], Stop(lambda elapsed, _: elapsed >= moment, "kill", "at a random moment"))
    if not part.stopped:
        expect_same(ref.out, out, part)
        t.tags.append("B ended before the kill")
        return f"B ({other}) ended before the kill"
    expect_whole(out)
    a_files = {p.name for p in checkpoints(out).values() if p.stat().st_mtime < began}
    b_files = {p.name for p in checkpoints(out).values()} - a_files
    b_wrote = (out / "summary.json").exists() and (out / "summary.json").stat().st_mtime >= began
    part = t.run([path, "-o", out, "--restart", "latest"])
    source = restarted_from(part)
    if not b_wrote:  # B died before it wrote anything: for hyperqn the directory holds A's run
        t.tags.append("B killed before it wrote anything")
        if part.code == 1 and errors(part):
            return f"B ({other}) killed before it wrote anything; A's run not continued: {errors(part)[0]}"
        if part.code == 0 and differences(ref.out, out):
            raise Verdict("wrong resume", f"B ({other}), killed before it wrote anything, continued A's run from {source} "
                          f"with exit 0 but a result other than B's uninterrupted run: " + "; ".join(differences(ref.out, out)))
        expect_same(ref.out, out, part)
        return f"B ({other}) killed before it wrote anything; A's run continued with B's deck from {source}"
    if source and source.name in a_files:
        raise Verdict("wrong resume", f"B ({other}) resumed A's {source} (B's own: {sorted(b_files)})")
    if part.code == 1 and not b_files and any("checkpoint" in line for line in errors(part)):
        t.tags.append("B had no checkpoint: refused")
        return f"B ({other}) killed before its first checkpoint; refused: {errors(part)[0]}"
    if part.code == 0 and differences(ref.out, out):
        raise Verdict("wrong resume", f"B ({other}) continued from {source} but differs from B's uninterrupted run: "
                      + "; ".join(differences(ref.out, out)))
    expect_same(ref.out, out, part)
    t.tags.append("B continued")
    return f"B ({other}) continued from {source}"


def requeue_trial(t):
    """A batch job requeued again and again: 3-5 parts started with --restart auto, each killed
    (or sent SIGUSR1) at a random moment, some before the part's first checkpoint; a last part
    runs to the end: equal to the uninterrupted run."""
    frames = t.rng.choice([100, 150])
    deck = bar(frames, {"every": t.rng.choice([1, 2, 5]), "keep": 2})
    ref, path, out = t.reference(deck), t.deck("run", deck), t.dir / "out"
    notes = []
    for k in range(t.rng.randint(3, 5)):
        moment = t.rng.uniform(0, ref.seconds)
        how = "usr1" if t.rng.random() < 0.3 else "kill"
        part = t.run([path, "-o", out, "--restart", "auto"],
                     Stop(lambda elapsed, _: elapsed >= moment, how, "at a random moment"))
        expect_whole(out)
        if not part.stopped:
            expect_same(ref.out, out, part)
            return f"ended in part {k + 1}: " + "; ".join(notes)
        if part.code == 3 and not (str(status(out)).startswith("interrupted") and checkpoints(out)):
            fail(f"exit 3 without a checkpoint and status interrupted (status {status(out)!r})")
        notes.append(f"{part.stopped} -> exit {part.code}")
        t.tags.append(f"{part.stopped.split()[0]} -> exit {part.code}")
    part = t.run([path, "-o", out, "--restart", "auto"])
    expect_same(ref.out, out, part)
    return "; ".join(notes)


CLASSES = {"kill": kill_trial, "full-disk": full_disk_trial, "unwritable": unwritable_trial,
           "corrupt": corrupt_trial, "reuse": reuse_trial, "requeue": requeue_trial}


# ---------------------------------------------------------------------------------------------
# The campaign


def run_trial(trial):
    """(outcome, note or reason) of one trial; a harness error is a failure with its traceback."""
    try:
        return "passed", CLASSES[trial.kind](trial)
    except Verdict as v:
        return v.outcome, v.why
    except Exception:  # noqa: BLE001 - a bug of the harness is reported, not hidden
        return "failure", "harness error:\n" + traceback.format_exc()


def keep_failure(trial, outcome, why, failures_dir):
    """Moves the trial's directory to failures/ with trial.txt (reason, commands, outputs)."""
    target = failures_dir / trial.dir.name
    shutil.rmtree(target, ignore_errors=True)
    shutil.move(str(trial.dir), target)
    (target / "trial.txt").write_text(f"trial {trial.number} ({trial.kind}, {trial.ranks} rank(s)): {outcome}\n{why}\n\n"
                                      f"{trial.report()}\n")
    return target


def campaign(args, kinds, rank_counts, out):
    """Runs the trials (all of --trials, or --trial alone) within --budget; their results."""
    settings = Settings(os.path.abspath(args.bin), args.mpiexec, args.timeout, out)
    references = References(settings)
    results, longest, start = [], {}, time.time()
    for number in [args.trial] if args.trial is not None else range(args.trials):
        kind, ranks = kinds[number % len(kinds)], rank_counts[(number // len(kinds)) % len(rank_counts)]
        if args.budget and time.time() - start + longest.get((kind, ranks), 10) > args.budget:
            break
        directory = out / "trials" / f"{number:04d}-{kind}-np{ranks}"
        directory.mkdir(parents=True)
        trial = Trial(number, kind, ranks, random.Random(f"{args.seed}:{number}"), directory, settings, references)
        began = time.time()
        outcome, note = run_trial(trial)
        seconds = time.time() - began
        longest[(kind, ranks)] = max(longest.get((kind, ranks), 0), seconds)
        result = {"trial": number, "class": kind, "ranks": ranks, "outcome": outcome, "seconds": round(seconds, 2),
                  "note": note, "tags": trial.tags}
        if outcome in ("passed", "skipped"):
            shutil.rmtree(directory)
        else:
            result["kept"] = str(keep_failure(trial, outcome, note, out / "failures"))
            lines = note.splitlines()
            print(f"FAILED trial {number} ({kind}, {ranks} rank(s)): {outcome}: {lines[0]}\n" + tail("\n".join(lines[1:]), 3)
                  + f"\n    kept in {result['kept']}", flush=True)
        results.append(result)
    shutil.rmtree(out / "trials", ignore_errors=True)
    return results


def tally(results, kinds):
    """{class: {"trials": n, outcome: n, ...}} and {class: {tag: n}}."""
    counts = {k: {c: 0 for c in ["trials"] + OUTCOMES} for k in kinds}
    tags = {k: {} for k in kinds}
    for r in results:
        counts[r["class"]]["trials"] += 1
        counts[r["class"]][r["outcome"]] += 1
        for tag in r["tags"]:
            tags[r["class"]][tag] = tags[r["class"]].get(tag, 0) + 1
    return counts, tags


def print_table(counts, tags):
    columns = ["trials"] + OUTCOMES
    print(f"{'class':12s}" + "".join(f"{c:>{len(c) + 2}s}" for c in columns))
    for kind, row in counts.items():
        print(f"{kind:12s}" + "".join(f"{row[c]:{len(c) + 2}d}" for c in columns))
    for kind, seen in tags.items():
        if seen:
            print(f"  {kind}: " + ", ".join(f"{tag} {n}" for tag, n in sorted(seen.items(), key=lambda kv: -kv[1])))


def write_results(out, counts, tags, results, summary):
    with open(out / "faults.json", "w") as f:
        json.dump({**summary, "counts": counts, "tags": tags, "trials": results}, f, indent=1)
    with open(out / "faults.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["class", "trials"] + OUTCOMES)
        for kind, row in counts.items():
            w.writerow([kind, row["trials"]] + [row[c] for c in OUTCOMES])


OWN = ["failures", "trials", "references", "faults.json", "faults.csv"]  # what a run writes in --out: a rerun removes these only


def main():
    p = cli.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--trials", type=cli.count, default=240)
    p.add_argument("--budget", type=cli.seconds_or_0, default=0,
                   help="seconds: start no trial that would end later than this, by the longest of its kind so far (0: no limit)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--ranks", default="1,2", type=lambda text: [cli.positive_int(r) for r in text.split(",")],
                   help="rank counts, comma-separated")
    p.add_argument("--classes", default=",".join(CLASSES), help="comma-separated, of: " + ", ".join(CLASSES))
    p.add_argument("--trial", type=cli.count,
                   help="run only this trial number (as numbered in a campaign with the same options), below --trials")
    p.add_argument("--timeout", type=cli.positive_float, default=60, help="seconds a run may take before it counts as a hang")
    p.add_argument("--out", default=os.path.join(REPO, "output", "faults"))
    p.add_argument("--bin", type=cli.program, default=launch.default_binary())
    p.add_argument("--mpiexec", type=cli.program, default=launch.default_mpiexec())
    args = p.parse_args()
    kinds = args.classes.split(",")
    if any(k not in CLASSES for k in kinds):
        p.error(f"unknown class in {kinds}; known: {', '.join(CLASSES)}")
    if args.trial is not None and args.trial >= args.trials:
        p.error(f"--trial {args.trial}: a campaign of --trials {args.trials} numbers them 0 to {args.trials - 1}")
    rank_counts = args.ranks
    why = cli.unwritable_dir(args.out)
    if why:
        p.error(f"--out {why}")
    out = Path(args.out).absolute()
    cli.remove_own(out, OWN)
    (out / "failures").mkdir(parents=True)
    start = time.time()
    results = campaign(args, kinds, rank_counts, out)
    seconds = time.time() - start
    counts, tags = tally(results, kinds)
    print(f"{len(results)} trials in {seconds:.0f} s (seed {args.seed}, {args.bin}):")
    print_table(counts, tags)
    write_results(out, counts, tags, results, {"seed": args.seed, "binary": os.path.abspath(args.bin),
                                               "seconds": round(seconds, 1), "ranks": rank_counts, "classes": kinds})
    bad = sum(counts[k][c] for k in kinds for c in OUTCOMES if c not in ("passed", "skipped"))
    print(f"{bad} failed, {sum(counts[k]['passed'] for k in kinds)} passed, "
          f"{sum(counts[k]['skipped'] for k in kinds)} skipped; results in {out}")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
