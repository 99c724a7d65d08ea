#!/usr/bin/env python3
"""Stability suite: runs every deck in input/stability/ with every solver and judges each run.

    /usr/bin/python3 postprocess/stability.py [DECK.yaml ...] [--out output/stability] [--solvers ...]

(`make stability` runs it on input/stability/*.yaml.) For each case (deck) and solver, the deck is
copied with `solver.type` replaced (nothing else changes: every solver gets the deck's budget,
the project default of 10 iterations and grad_rtol 1e-6 unless the deck says otherwise) and run
under output/stability/runs/<case>/<solver>/. Every case also gets a converged reference run
(Newton with the exact Hessian, up to 100 iterations per frame, grad_rtol 1e-10) in
runs/<case>/reference/: cases without a simple exact end state are judged against it.

Measured per case and solver (see `analyse_run`): frames completed, any NaN/Inf (iterations.csv,
summary.json, every VTK frame), min J (summary.json), whether g decreased monotonically within
every frame (iterations.csv), line-search failures (summary.json `ls_failures`, else
`failed_frames`), the largest final |grad g| of a frame, the distance of the last frame from the
rest shape, and for cases with a reference the distance from the reference's last frame.
Verdicts: ok / degraded / failed / not run (see `verdict`).

Writes stability.csv, stability.md, verdicts.png and one grad_<case>.png per case into --out,
and the copy of the binary every run used (--out/hyperqn, taken at the start).
"""
import argparse
import concurrent.futures
import copy
import csv
import glob
import math
import os
import re
import shutil
import subprocess
import sys
import time

import meshio
import numpy as np
import yaml

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from hyperqn_output import Frame, piece_files, read_iterations, read_pvd, read_summary  # noqa: E402

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
SOLVERS = ["lbfgs", "lbfgs-identity", "pd", "newton"]
REFERENCE_SOLVER = {"type": "newton", "newton_hessian": "exact", "iterations": 100, "grad_rtol": 1.0e-10,
                    "grad_atol": 0.0}
MPI_ENV = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1"}

# Judgement thresholds, as fractions of the rest bounding-box diagonal.
REST_TOL = 1.0e-2   # a case that must settle at its rest shape: RMS distance from it at the last frame
REF_TOL = 5.0e-2    # a case with a converged reference: RMS distance from the reference's last frame
BLOWUP_TOL = 10.0   # any case: farther than this from rest at the last frame = diverged (nothing in
                    # these decks can physically move more than about one diagonal from rest); a
                    # backstop: hyperqn stops a diverging run itself (README, "Guardrails")
# g may rise by round-off between iterates. g = 1/2 |x - y|_M^2 + h^2 E sums per-element energies of
# size (mu + lambda) V_e h^2 with cancellation (tr F^T F - 3, log J), so its round-off is about
# eps h^2 (mu + lambda) V even where g itself is much smaller. An increase counts when it exceeds
#   MONOTONE_RTOL |g| + MONOTONE_FLOOR * eps * h^2 * max(mu + lambda) * (rest bounding-box volume).
MONOTONE_RTOL = 1.0e-12
MONOTONE_FLOOR = 100.0

# A deck may state its expectation in a comment line "# stability: expect rest" (or "reference"),
# overriding the automatic rule (rest when there is no gravity and no moving support): e.g.
# spin_one_turn, whose support turns a full turn and stops where it started.
EXPECT_MARK = re.compile(r"^#\s*stability:\s*expect\s+(rest|reference)\b")

# What the decks input/stability/initial_*.yaml assume of the top-level `initial:` key (written
# before it existed; src/initial_state.cpp now implements it so). A hyperqn that rejects the key
# gets those decks reported as "not run".
INITIAL_SEMANTICS = """\
`initial:` (top level, optional; default: start at the rest shape) sets the positions of frame 0
while the rest shape stays the mesh (after `mesh.transform`). Exactly one of:

- `squash: {axis: A, factor: s}` (A in {0, 1, 2}, s >= 0): x = c + S (X - c) with S the identity
  except S[A][A] = s, i.e. every vertex's coordinate A is scaled by s about the centre c
  (s = 0: the body is flattened onto the plane through c normal to axis A; every J = 0).
- `collapse: true`: every vertex at c (F = 0 and J = 0 in every element). `collapse: false` is
  the same as no `initial`.
- `random: {seed: N}` (integer, default 1): every vertex at an independent uniformly random point
  of the rest bounding box, drawn from a generator seeded with N and the vertex's input-mesh index
  (so it does not depend on the number of ranks).
- `invert: {axis: A}`: every vertex mirrored through the plane through c normal to axis A,
  x_A = 2 c_A - X_A (every element inverted, J = -1).

c is the centre of the rest bounding box (for a generated box also the vertex mean and the
centroid). The initial velocity is zero. Fixed vertices, if any, are not moved by `initial`: they
stay at their rest (or prescribed) positions, which are imposed as usual. Frame 0 of the output is
this initial state (so its `displacement` is x - X and its `J` the initial one, which summary.json's
min_J includes). Errors: an unknown form, more than one form, an axis outside {0, 1, 2},
factor < 0, a non-integer seed name the deck line, like every other key."""


# ----------------------------------------------------------------------------- decks and runs

def load_yaml(path):
    with open(path) as f:
        return yaml.safe_load(f) or {}


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


def has_motion(deck):
    return any(isinstance(f, dict) and f.get("motion") for f in deck.get("fixed") or [])


def expectation(deck_path, deck):
    """'rest' when the body must settle at its rest shape, else 'reference' (judged against a
    converged run): the deck's "# stability: expect ..." comment, else rest when there is no
    gravity and no moving support."""
    with open(deck_path) as f:
        for line in f:
            m = EXPECT_MARK.match(line.strip())
            if m:
                return m.group(1)
    gravity = deck.get("gravity", [0, -9.81, 0])
    return "rest" if all(g == 0 for g in gravity) and not has_motion(deck) else "reference"


def run_deck(deck, deck_path, solver_section, outdir, binary, np_ranks, mpiexec, timeout):
    """Writes a copy of the deck with `solver_section` merged into `solver`, runs hyperqn on it
    into outdir; returns {'returncode', 'output', 'timed_out', 'seconds'}."""
    os.makedirs(outdir, exist_ok=True)
    d = copy.deepcopy(deck)
    d.setdefault("name", case_name(deck_path))
    d["solver"] = {**(d.get("solver") or {}), **solver_section}
    d.setdefault("output", {})
    d["output"].pop("directory", None)
    mesh = d.get("mesh") or {}
    if isinstance(mesh.get("file"), str) and not os.path.isabs(mesh["file"]):
        mesh["file"] = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(deck_path)), mesh["file"]))
    copy_path = os.path.join(outdir, "deck.yaml")
    with open(copy_path, "w") as f:
        yaml.safe_dump(d, f, sort_keys=False)
    for old in glob.glob(os.path.join(outdir, "*")):  # results of an earlier run would mislead
        if os.path.basename(old) not in ("deck.yaml",) and os.path.isfile(old):
            os.remove(old)
    launcher = [] if np_ranks == 1 else [mpiexec or "mpiexec", "-n", str(np_ranks)]
    cmd = launcher + [binary, copy_path, "-o", outdir]
    t0 = time.time()
    try:
        proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=timeout,
                              env={**os.environ, **MPI_ENV})
        result = {"returncode": proc.returncode, "output": proc.stdout, "timed_out": False}
    except subprocess.TimeoutExpired as e:
        out = e.stdout.decode(errors="replace") if isinstance(e.stdout, bytes) else (e.stdout or "")
        result = {"returncode": None, "output": out, "timed_out": True}
    except OSError as e:  # the binary could not be started: a crash of this run, not of the suite
        result = {"returncode": None, "output": f"cannot start {cmd[0]}: {e}", "timed_out": False}
    result["seconds"] = time.time() - t0
    with open(os.path.join(outdir, "run.log"), "w") as f:
        f.write(" ".join(cmd) + "\n" + result["output"])
    return result


def rejection(output):
    """hyperqn's message when it rejected the deck before running (an input error naming the
    deck file and line), without the file and line (those of the run's copy), else None."""
    m = re.search(r"hyperqn: error: \S+?\.yaml:\d+: (.*)", output)
    return m.group(1).strip() if m else None


# ----------------------------------------------------------------------------- VTK reading

VTK_TYPES = {"Float64": "<f8", "Float32": "<f4", "Int64": "<i8", "Int32": "<i4", "UInt8": "u1", "UInt64": "<u8"}




# ----------------------------------------------------------------------------- measurements

def finite(x):
    return x is not None and isinstance(x, (int, float)) and math.isfinite(x)


def frames_of_iterations(rows):
    """{frame: [rows]} in order."""
    frames = {}
    for r in rows:
        frames.setdefault(r["frame"], []).append(r)
    return frames


def lame(material):
    """(mu, lambda) of a deck material section."""
    if "mu" in material:
        return float(material["mu"]), float(material["lambda"])
    E, nu = float(material["youngs_modulus"]), float(material["poisson_ratio"])
    return E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))


def energy_roundoff(deck, rest_points):
    """Round-off scale of g for this deck: eps h^2 max(mu + lambda) V_bbox (see MONOTONE_FLOOR)."""
    materials = [deck["material"]] + [r["material"] for r in deck.get("regions") or []]
    stiffness = max(sum(lame(m)) for m in materials)
    h = float((deck.get("time") or {}).get("dt", 1.0 / 30.0))
    volume = float(np.prod(rest_points.max(axis=0) - rest_points.min(axis=0)))
    return np.finfo(float).eps * h * h * stiffness * volume


def monotone_violations(rows, floor=0.0, rtol=MONOTONE_RTOL):
    """(frames in which g rose between consecutive iterates by more than rtol |g| + floor,
    number of frames with smaller rises, i.e. round-off)."""
    bad, roundoff = set(), set()
    for frame, its in frames_of_iterations(rows).items():
        for prev, cur in zip(its, its[1:]):
            if not (cur["energy"] <= prev["energy"] + rtol * abs(prev["energy"]) + floor):
                bad.add(frame)
            elif cur["energy"] > prev["energy"]:
                roundoff.add(frame)
    return sorted(bad), len(roundoff - bad)


def kabsch_rms(X, x):
    """RMS distance between x and the best proper rigid motion of X (rotation + translation)."""
    cX, cx = X.mean(axis=0), x.mean(axis=0)
    H = (X - cX).T @ (x - cx)
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0
    R = Vt.T @ np.diag([1.0, 1.0, d]) @ U.T
    return float(np.sqrt(np.mean(np.sum(((X - cX) @ R.T + cx - x) ** 2, axis=1))))


def rest_distance(frame, align):
    """RMS over vertices of the distance from the rest shape (after the best rigid motion when
    align), divided by the rest bounding-box diagonal."""
    rest = frame.points - frame.displacement
    diag = float(np.linalg.norm(rest.max(axis=0) - rest.min(axis=0)))
    if align:
        return kabsch_rms(rest, frame.points) / diag
    return float(np.sqrt(np.mean(np.sum(frame.displacement ** 2, axis=1)))) / diag


def read_frames(outdir):
    """[(frame number, Frame)] of every VTK frame written, or [] if there is none. Raises on
    unreadable files (a crash in the middle of writing)."""
    pvd = glob.glob(os.path.join(outdir, "*.pvd"))
    if len(pvd) != 1:
        return []
    frames = []
    for _, path in read_pvd(pvd[0]):
        m = re.search(r"_(\d+)\.p?vtu$", path)
        frames.append((int(m.group(1)) if m else len(frames), Frame(path)))
    return frames


FRAME_LINE = re.compile(r"^frame\s+(\d+)\s+it\s+\d+\s.*?ms\s+(\S+)(.*)$")


def frame_reasons(log_text):
    """{frame: (solver's stop reason, line-search failures in the frame)} from hyperqn's
    per-frame lines (`frame N it K g ... ms REASON [k line-search failure(s), retried] ...`)."""
    out = {}
    for line in log_text.splitlines():
        m = FRAME_LINE.match(line.strip())
        if not m:
            continue
        reason, note = m.group(2), m.group(3)
        k = re.search(r"\[(\d+) line-search failure", note)
        count = int(k.group(1)) if k else (1 if stopped_by_line_search(reason) else 0)
        out[int(m.group(1))] = (reason, count)
    return out


def stopped_by_line_search(reason):
    return "LS_FAILURE" in reason or "LINE_SEARCH_FAILURE" in reason


def min_vertex_mass_bound(frame_path, deck):
    """A lower bound of the lumped vertex masses: smallest density times smallest tet volume / 4."""
    volumes = []
    for piece in piece_files(frame_path):
        m = meshio.read(piece)
        rest = m.points - m.point_data["displacement"]
        for block in m.cells:
            if block.type != "tetra":
                continue
            p = rest[block.data]
            volumes.append(np.abs(np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]),
                                            p[:, 3] - p[:, 0])) / 6.0)
    if not volumes:
        return None
    materials = [deck["material"]] + [r["material"] for r in deck.get("regions") or []]
    rest_all = None
    densities = []
    for mat in materials:
        if "density" in mat:
            densities.append(float(mat["density"]))
        else:  # total_mass over the body's volume
            rest_all = np.concatenate(volumes).sum() if rest_all is None else rest_all
            densities.append(float(mat["total_mass"]) / rest_all)
    return min(densities) * float(np.concatenate(volumes).min()) / 4.0


def analyse_run(outdir, deck, log_text=None):
    """Everything measured on one run directory of `deck` (no judgement). Missing files give None.
    log_text: hyperqn's output (default: outdir/run.log, written by run_deck)."""
    expected_frames = int((deck.get("time") or {}).get("frames", 100))
    a = {"summary": None, "rows": [], "frames": [], "vtk_error": None}
    if os.path.exists(os.path.join(outdir, "summary.json")):
        a["summary"] = read_summary(outdir)
    if os.path.exists(os.path.join(outdir, "iterations.csv")):
        a["rows"] = read_iterations(outdir)
    try:
        a["frames"] = read_frames(outdir)
    except Exception as e:  # noqa: BLE001 - a truncated VTK file is a finding, not a crash of the suite
        a["vtk_error"] = f"{type(e).__name__}: {e}"
    s, rows, frames = a["summary"], a["rows"], a["frames"]

    nan = []
    if any(not (math.isfinite(r["energy"]) and math.isfinite(r["grad_norm"]) and math.isfinite(r["step"]))
           for r in rows):
        nan.append("iterations.csv")
    if s is not None and s.get("frames", 0) > 0 and any(
            s.get(k, 0) is None for k in ("final_energy", "final_grad_norm", "min_J")):
        nan.append("summary.json")
    if any(not (np.isfinite(f.points).all() and np.isfinite(f.displacement).all()
                and np.isfinite(f.velocity).all() and np.isfinite(f.J).all()) for _, f in frames):
        nan.append("VTK")
    a["nan"] = nan

    by_frame = frames_of_iterations(rows)
    a["final_grad"] = {fr: its[-1]["grad_norm"] for fr, its in by_frame.items()}
    a["final_grad_rel"] = {fr: its[-1]["grad_norm"] / its[0]["grad_norm"] if its[0]["grad_norm"] > 0 else 0.0
                           for fr, its in by_frame.items()}
    floor = 0.0
    if frames:
        f0 = frames[0][1]
        floor = MONOTONE_FLOOR * energy_roundoff(deck, f0.points - f0.displacement)
    a["monotone_floor"] = floor
    a["monotone_bad"], a["roundoff_increase_frames"] = monotone_violations(rows, floor)
    if s is not None:
        a["frames_completed"] = s.get("frames", 0)
    else:  # crashed: the last frame logged may not have finished
        a["frames_completed"] = max(by_frame.keys(), default=1) - 1
    a["expected_frames"] = expected_frames
    a["min_J_frames"] = {fr: float(np.min(f.J)) for fr, f in frames if len(f.J)}
    if s is not None and "ls_failures" in s:
        a["ls_failures"], a["ls_source"] = s["ls_failures"], "ls_failures"
    elif s is not None:
        a["ls_failures"], a["ls_source"] = s.get("failed_frames", 0), "failed_frames"
    else:
        a["ls_failures"], a["ls_source"] = None, ""

    # Line-search failures at round-off: frames with failed line searches that ended where no
    # decrease of g above g's round-off was left, whether the solver stopped on the failure or
    # converged after a retry (which near round-off only finds decreases of g's noise). With
    # H = M + h^2 K >= m_min I (K >= 0 near a stable state), g - g* <= |grad g|^2 / (2 m_min).
    if log_text is None and os.path.exists(os.path.join(outdir, "run.log")):
        with open(os.path.join(outdir, "run.log")) as f:
            log_text = f.read()
    reasons = frame_reasons(log_text or "")
    m_min = min_vertex_mass_bound(read_pvd(glob.glob(os.path.join(outdir, "*.pvd"))[0])[0][1], deck) \
        if frames else None
    stalls = []
    for fr, (_, count) in reasons.items():
        if count and fr in by_frame and m_min:
            g, grad = by_frame[fr][-1]["energy"], by_frame[fr][-1]["grad_norm"]
            if 0.5 * grad * grad / m_min <= MONOTONE_RTOL * abs(g) + floor:
                stalls.append(fr)
    a["ls_roundoff_frames"] = sorted(stalls)
    logged = sum(count for _, count in reasons.values())
    a["ls_judged"] = a["ls_failures"]
    if a["ls_failures"] and logged:
        # failures the log places in round-off stall frames do not count
        a["ls_judged"] = max(0, a["ls_failures"] - sum(reasons[fr][1] for fr in stalls))
    return a


def last_frame(a):
    return a["frames"][-1] if a["frames"] else (None, None)


def reference_distance(a, ref):
    """RMS distance between the last frames of a run and of its reference (same frame number,
    vertices matched by vertex_id) over the rest diagonal, or None."""
    fa, A = last_frame(a)
    fr, R = last_frame(ref)
    if A is None or R is None or fa != fr or not np.array_equal(A.vertex_id, R.vertex_id):
        return None
    rest = R.points - R.displacement
    diag = float(np.linalg.norm(rest.max(axis=0) - rest.min(axis=0)))
    return float(np.sqrt(np.mean(np.sum((A.points - R.points) ** 2, axis=1)))) / diag


def completed(status):
    """Whether summary.json's status is that of a run that went through every frame: "ok", or
    "flagged: ..." (some frames could not decrease g; they count as line-search failures)."""
    return status == "ok" or status.startswith("flagged")


def reference_ok(ref):
    s = ref["summary"]
    return (s is not None and completed(s.get("status", "")) and not ref["nan"]
            and ref["frames_completed"] == ref["expected_frames"] and bool(ref["frames"]))


def verdict(run, a, expect, ref, align):
    """(verdict, reason, rest_error, ref_error)."""
    rest_error = ref_error = None
    fnum, last = last_frame(a)
    if last is not None and fnum == a["frames_completed"]:
        rest_error = rest_distance(last, align)
    if ref is not None and reference_ok(ref):
        ref_error = reference_distance(a, ref)

    if run.get("rejected"):
        return "not run", run["rejected"], rest_error, ref_error
    s = a["summary"]
    if run["timed_out"]:
        return "failed", f"timeout after {run['seconds']:.0f} s", rest_error, ref_error
    if s is None:
        tail = [l for l in run["output"].strip().splitlines() if l.strip()][-1:] or ["no output"]
        return "failed", f"crash (exit code {run['returncode']}): {tail[0][:200]}", rest_error, ref_error
    if not completed(s.get("status", "")):
        return "failed", s.get("status", "no status"), rest_error, ref_error
    if a["nan"]:
        return "failed", "NaN/Inf in " + ", ".join(a["nan"]), rest_error, ref_error
    if a["frames_completed"] < a["expected_frames"]:
        return "failed", f"completed {a['frames_completed']}/{a['expected_frames']} frames", rest_error, ref_error
    if run["returncode"] != 0:
        return "failed", f"exit code {run['returncode']} with status {s['status']}", rest_error, ref_error
    if a["vtk_error"]:
        return "failed", "unreadable VTK: " + a["vtk_error"], rest_error, ref_error
    if rest_error is not None and rest_error > BLOWUP_TOL:
        why = f"diverged: last frame {rest_error:.3g} diagonals from rest (> {BLOWUP_TOL:g})"
        if a["ls_failures"]:
            why += f"; {a['ls_failures']} line-search failure(s) ({a['ls_source']})"
        return "failed", why, rest_error, ref_error

    reasons = []
    if a["ls_judged"]:
        stalls = len(a["ls_roundoff_frames"])
        reasons.append(f"{a['ls_judged']} line-search failure(s) ({a['ls_source']}"
                       + (f"; not counting {stalls} frame(s) ended at round-off" if stalls else "") + ")")
    if a["monotone_bad"]:
        bad = a["monotone_bad"]
        reasons.append(f"g increased within {len(bad)} frame(s) (first: {bad[0]})")
    if last is not None and len(last.J) and float(np.min(last.J)) <= 0:
        reasons.append(f"inverted or flat elements in the last frame (min J {float(np.min(last.J)):.3g})")
    if expect == "rest" and rest_error is not None and rest_error > REST_TOL:
        reasons.append(f"not back at rest: RMS distance {rest_error:.2e} of the diagonal > {REST_TOL:g}")
    if expect == "reference" and ref_error is not None and ref_error > REF_TOL:
        reasons.append(f"last frame {ref_error:.2e} of the diagonal from the converged reference > {REF_TOL:g}")
    if reasons:
        return "degraded", "; ".join(reasons), rest_error, ref_error
    return "ok", "", rest_error, ref_error


# ----------------------------------------------------------------------------- report

COLUMNS = ["case", "solver", "expect", "frames_expected", "frames_completed", "nan", "min_J", "final_min_J",
           "monotone", "g_increase_frames", "roundoff_increase_frames", "ls_failures", "ls_failures_source",
           "ls_roundoff_frames", "converged_frames",
           "max_final_grad_norm", "max_final_grad_rel", "rest_error", "ref_error", "mean_iterations", "wall_s",
           "verdict", "reason"]


def make_row(case, solver, expect, run, a, ref, align):
    v, reason, rest_error, ref_error = verdict(run, a, expect, ref, align)
    s = a["summary"] or {}
    _, last = last_frame(a)
    return {
        "case": case, "solver": solver, "expect": expect,
        "frames_expected": a["expected_frames"], "frames_completed": a["frames_completed"],
        "nan": "yes" if a["nan"] else "no",
        "min_J": None if s.get("min_J") is None else float(s["min_J"]),
        "final_min_J": float(np.min(last.J)) if last is not None and len(last.J) else None,
        "monotone": "no" if a["monotone_bad"] else ("yes" if a["rows"] else ""),
        "g_increase_frames": len(a["monotone_bad"]),
        "roundoff_increase_frames": a["roundoff_increase_frames"] if a["rows"] else None,
        "ls_failures": a["ls_failures"], "ls_failures_source": a["ls_source"],
        "ls_roundoff_frames": len(a["ls_roundoff_frames"]) if a["summary"] is not None else None,
        "converged_frames": s.get("converged_frames"),
        "max_final_grad_norm": max(a["final_grad"].values(), default=None),
        "max_final_grad_rel": max(a["final_grad_rel"].values(), default=None),
        "rest_error": rest_error, "ref_error": ref_error,
        "mean_iterations": s.get("mean_iterations"), "wall_s": s.get("wall_s"),
        "verdict": v, "reason": reason,
    }


def fmt(x, digits=3):
    if x is None or x == "":
        return "–"
    if isinstance(x, float):
        if not math.isfinite(x):
            return str(x)
        return f"{x:.{digits}g}" if 1e-3 <= abs(x) < 1e4 or x == 0 else f"{x:.{digits - 1}e}"
    return str(x)


def write_csv(rows, path):
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        w.writeheader()
        for r in rows:
            w.writerow({k: ("" if r[k] is None else (f"{r[k]:.6g}" if isinstance(r[k], float) else r[k]))
                        for k in COLUMNS})


STYLE = {"lbfgs": ("C0", "-"), "newton": ("C3", "-"), "pd": ("C2", "--"), "lbfgs-identity": ("C1", ":"),
         "reference": ("0.5", "-")}
VERDICT_COLOUR = {"ok": "#4caf50", "degraded": "#ffb300", "failed": "#e53935", "not run": "#9e9e9e"}


def case_figure(case, analyses, verdicts, align, path):
    """Three panels per case: final |grad g| per frame, min J per frame, RMS distance from the rest
    shape per frame; one curve per solver (legend: its verdict) and the reference."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (ax, bx, cx) = plt.subplots(1, 3, figsize=(16, 4.2))
    drawn = False
    lowest_J = 0.0
    for solver, a in analyses.items():
        colour, ls = STYLE.get(solver, ("k", "-"))
        lw = 1.0 if solver == "reference" else 1.6
        label = solver + (f" ({verdicts[solver]})" if solver in verdicts else "")
        fg = sorted(a["final_grad"].items())
        if fg:
            ax.semilogy([f for f, _ in fg], [max(g, 1e-300) for _, g in fg], ls, color=colour, lw=lw, label=label,
                        marker="." if len(fg) < 3 else None)
            drawn = True
        mj = sorted(a["min_J_frames"].items())
        if mj:
            bx.plot([f for f, _ in mj], [j for _, j in mj], ls, color=colour, lw=lw, label=label)
            lowest_J = min(lowest_J, min(j for _, j in mj))
        rd = [(n, d) for n, d in ((n, rest_distance(f, align)) for n, f in a["frames"]) if d > 0]
        if rd:
            cx.semilogy([n for n, _ in rd], [d for _, d in rd], ls, color=colour, lw=lw, label=label)
    ax.set_xlabel("frame")
    ax.set_ylabel("final |grad g| of the frame")
    ax.set_title(f"{case}: final gradient norm per frame", fontsize=10)
    bx.set_xlabel("frame")
    bx.set_ylabel("min J over elements")
    if lowest_J < -2:
        bx.set_yscale("symlog", linthresh=1.0)
        decades = int(math.ceil(math.log10(-lowest_J)))
        step = max(1, int(math.ceil(decades / 6)))
        bx.set_yticks([1, 0] + [-(10.0 ** k) for k in range(0, decades + 1, step)])
    bx.axhline(0, color="k", lw=0.5)
    bx.set_title(f"{case}: smallest det F per frame", fontsize=10)
    cx.set_xlabel("frame")
    cx.set_ylabel("RMS distance from rest / diagonal" + (" (rigidly aligned)" if align else ""))
    cx.axhline(BLOWUP_TOL, color="r", lw=0.6, ls=":")
    cx.set_title(f"{case}: distance from the rest shape", fontsize=10)
    if drawn:
        ax.legend(fontsize=8)
        bx.legend(fontsize=8)
    else:
        for x in (ax, bx, cx):
            x.text(0.5, 0.5, "not run", ha="center", va="center", transform=x.transAxes)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def short_reason(reason):
    """A few words for a figure cell."""
    tags = []
    for key, tag in (("timeout", "timeout"), ("crash", "crash"), ("NaN", "NaN"), ("diverged", "diverged"),
                     ("completed", "incomplete"), ("error", "error"), ("line-search", "LS fail."),
                     ("g increased", "g rose"), ("inverted or flat", "J ≤ 0"), ("not back at rest", "not at rest"),
                     ("converged reference", "off ref.")):
        if key in reason and tag not in tags:
            tags.append(tag)
    return ", ".join(tags[:3])


def verdict_figure(rows, cases, solvers, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch
    by = {(r["case"], r["solver"]): r for r in rows}
    fig, ax = plt.subplots(figsize=(2.3 * len(solvers) + 2.5, 0.5 * len(cases) + 1.4))
    for i, case in enumerate(cases):
        for j, solver in enumerate(solvers):
            r = by.get((case, solver))
            v = r["verdict"] if r else "not run"
            ax.add_patch(plt.Rectangle((j, i), 1, 1, color=VERDICT_COLOUR[v], ec="white", lw=1.5))
            label = v
            if r and v in ("ok", "degraded"):
                err = r["rest_error"] if r["expect"] == "rest" else r["ref_error"]
                label += f"\n{'rest' if r['expect'] == 'rest' else 'ref'} {fmt(err, 2)}"
            if r and v in ("degraded", "failed"):
                label += "\n" + short_reason(r["reason"])
            ax.text(j + 0.5, i + 0.5, label, ha="center", va="center", fontsize=6.5)
    ax.set_xlim(0, len(solvers))
    ax.set_ylim(len(cases), 0)
    ax.set_xticks([j + 0.5 for j in range(len(solvers))])
    ax.set_xticklabels(solvers)
    ax.xaxis.tick_top()
    ax.set_yticks([i + 0.5 for i in range(len(cases))])
    ax.set_yticklabels(cases, fontsize=8)
    ax.tick_params(length=0)
    for side in ax.spines.values():
        side.set_visible(False)
    ax.legend(handles=[Patch(color=c, label=v) for v, c in VERDICT_COLOUR.items()], loc="upper center",
              bbox_to_anchor=(0.5, -0.01), ncol=4, fontsize=8, frameon=False)
    ax.set_title("stability verdicts (cell: verdict, distance from rest or from the converged reference)",
                 fontsize=9, pad=22)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_markdown(rows, cases, solvers, meta, path):
    by = {(r["case"], r["solver"]): r for r in rows}
    L = ["# Stability suite", "",
         f"{len(cases)} cases x {len(solvers)} solvers, run by `make stability` "
         f"(`postprocess/stability.py`) on {meta['ranks']} rank(s), {meta['date']}; total {meta['seconds']:.0f} s.",
         "Each case is a deck in `input/stability/`; every solver runs a copy with only `solver.type` replaced, "
         "so all get the deck's iteration budget (the project defaults: 10 iterations per frame, grad_rtol 1e-6; "
         "Newton too, with its default projected Hessian). Runs: `output/stability/runs/<case>/<solver>/`.",
         "", "![verdicts](verdicts.png)", "", "## Verdicts", "",
         "| case | " + " | ".join(solvers) + " |", "|---|" + "---|" * len(solvers)]
    for case in cases:
        cells = []
        for solver in solvers:
            r = by.get((case, solver))
            cells.append(r["verdict"] if r else "–")
        L.append(f"| {case} | " + " | ".join(cells) + " |")
    L += ["", "## Measurements", "",
          "| case | solver | frames | NaN | min J | final min J | monotone | LS fail. | conv. frames | "
          "max final ‖∇g‖ | max final/initial | rest err. | ref. err. | it./frame | verdict |",
          "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        L.append("| " + " | ".join([
            r["case"], r["solver"], f"{r['frames_completed']}/{r['frames_expected']}", r["nan"], fmt(r["min_J"]),
            fmt(r["final_min_J"]), r["monotone"] or "–",
            fmt(r["ls_failures"]) + (" ᶠ" if r["ls_failures_source"] == "failed_frames" else "")
            + (f" ({r['ls_roundoff_frames']})" if r["ls_roundoff_frames"] else ""),
            fmt(r["converged_frames"]), fmt(r["max_final_grad_norm"]), fmt(r["max_final_grad_rel"]),
            fmt(r["rest_error"]) + (" ◆" if r["expect"] == "rest" else ""),
            fmt(r["ref_error"]) + (" ◆" if r["expect"] == "reference" else ""),
            fmt(r["mean_iterations"]), f"**{r['verdict']}**"]) + " |")
    L += ["", "◆ marks the distance a case is judged by. ᶠ: summary.json has no `ls_failures`; "
          "the number is `failed_frames` (frames whose solver stopped on a failure: line search, NaN, ...).", ""]
    bad = [r for r in rows if r["verdict"] != "ok"]
    L += ["## Cells that are not ok", ""]
    if not bad:
        L.append("None.")
    for case in cases:  # one line when every solver of a case has the same verdict and reason
        mine = [r for r in bad if r["case"] == case]
        if len(mine) == len(solvers) > 1 and len({(r["verdict"], r["reason"]) for r in mine}) == 1:
            L.append(f"- **{case} / every solver: {mine[0]['verdict']}** — {mine[0]['reason']}")
            continue
        for r in mine:
            L.append(f"- **{r['case']} / {r['solver']}: {r['verdict']}** — {r['reason']}")
    refs = meta.get("references", {})
    L += ["", "## Cases", "", "| case | expectation | converged reference run (frames converged: ‖∇g‖ ≤ 1e-10 ‖∇g₀‖) | description |", "|---|---|---|---|"]
    for case in cases:
        L.append(f"| {case} | {meta['expect'][case]} | {refs.get(case, '–')} | {meta['descriptions'][case]} |")
    L += ["", "## What is measured", "",
          "- **frames**: `frames` of summary.json (frames finished) against `time.frames`; without a summary.json "
          "(crash), the last frame in iterations.csv minus one.",
          "- **NaN**: any non-finite energy, gradient norm or step in iterations.csv, a null (non-finite) "
          "final_energy, final_grad_norm or min_J in summary.json, or a non-finite position, displacement, "
          "velocity or J in any VTK frame.",
          "- **min J**: summary.json's `min_J` (over every written frame, frame 0 included); **final min J**: "
          "smallest J of the last frame.",
          f"- **monotone**: in every frame, g (iterations.csv `energy`) never rises from one iterate to the next by "
          f"more than its round-off, {MONOTONE_RTOL:g}·|g| + {MONOTONE_FLOOR:g}·ε·h²·max(μ + λ)·V (V: volume of the "
          "rest bounding box; g sums element energies of size (μ + λ)V_e h² with cancellation, so its round-off "
          "is of that size even when g itself is much smaller). Rises below that are counted in the CSV "
          "(`roundoff_increase_frames`), not judged.",
          "- **LS fail.**: summary.json `ls_failures` when present, else `failed_frames`. In parentheses: frames "
          "with failed line searches that ended *at round-off* (their failures are not judged), whether the "
          "solver stopped on the failure or converged after a retry: no decrease of g above its round-off (as "
          "for monotone) was left at the frame's last iterate, by the bound g − g* ≤ ‖∇g‖²/(2 m_min) that "
          "holds where H = M + h²K ⪰ m_min·I (m_min: smallest density × smallest tet volume / 4). Newton near "
          "rest stops like this.",
          "- **max final ‖∇g‖**: the largest over frames of the last logged ‖∇g‖ of the frame (in g's units, "
          "g = ½‖x − y‖²_M + h²E; not comparable between cases), and **max final/initial** the same relative to "
          "the frame's initial ‖∇g‖ (1e-6 = converged at the default tolerance).",
          "- **rest err.**: RMS over vertices of the distance between the last frame and the rest shape, divided "
          "by the rest bounding-box diagonal. With fixed vertices it is the RMS displacement; a body without "
          "fixed vertices is first aligned by the best rotation and translation (Kabsch), since it may drift "
          "or turn as a whole.",
          "- **ref. err.**: RMS over vertices of the distance between the last frame and the last frame of the "
          "case's converged reference (Newton, exact Hessian, ≤ 100 iterations per frame, grad_rtol 1e-10, same "
          "deck otherwise), divided by the diagonal; – when the case has no reference or the reference did not "
          "complete cleanly.",
          "", "## Judgement", "",
          "- **failed**: the run did not finish: hyperqn crashed or timed out, summary.json's `status` is an "
          "error (its text is the reason; hyperqn stops a run that diverged, an element edge longer than 10 rest "
          "bounding-box diagonals, with `error: frame N: diverged: ...`), a NaN/Inf appears anywhere, or fewer "
          f"frames than asked were completed; or its last frame is more than {BLOWUP_TOL:g} diagonals "
          f"(rest err. > {BLOWUP_TOL:g}) from the rest shape, where no case can physically be. A status "
          "`flagged: ...` (frames that could not decrease g) is a completed run; those frames are line-search "
          "failures.",
          "- **degraded**: it finished, but with line-search failures, g increasing within a frame, "
          "inverted or flat elements (J ≤ 0) in the last frame, or a wrong end state: "
          f"for cases that must return to rest, rest err. > {REST_TOL:g}; for the others, ref. err. > {REF_TOL:g}.",
          "- **ok**: none of these. Not converging within the iteration budget is not a stability problem by "
          "itself (see conv. frames and max final/initial).",
          "- **not run**: hyperqn rejected the deck (its message is the reason).",
          "",
          "**Expectation.** A case must return to its rest shape (`rest`) when nothing pulls it elsewhere: no "
          "gravity and no moving support (the `initial_*` extreme starts), or a support that moves and comes "
          "back to where it started while the rest of the body is free to unwind (`spin_one_turn`: one full "
          "turn of one end, the other end free; its deck says so in a comment line "
          "`# stability: expect rest`). Everything else (gravity, or the held two-turn twist) has "
          "no simple exact end state, so its last frame is compared with the same deck solved to convergence "
          "(`reference`); its rest err. is reported but not judged. The `rest` cases get the converged run "
          "too, not to judge them but to tell a solver's failure to recover from the problem's own (the "
          "Cases table gives the converged run's rest err.). The tolerances are deliberately loose: "
          f"{REST_TOL:g} and {REF_TOL:g} of the diagonal separate \"qualitatively right\" from \"wrong shape\", "
          "not accuracy levels; an under-converged but stable solver can still be ok.",
          "", "Release of a twisted bar is not supported: a fixed region stays fixed; its `motion` holds "
          "its last pose after `end`.",
          "", "## Assumed semantics of `initial:` (decks `initial_*.yaml`)", "", INITIAL_SEMANTICS, "",
          "## Figures", ""]
    for case in cases:
        L.append(f"- [{case}](grad_{case}.png): final ‖∇g‖, min J and distance from rest per frame, every solver"
                 + (" and the reference" if case in refs and refs[case] != "–" else ""))
    with open(path, "w") as f:
        f.write("\n".join(L) + "\n")


# ----------------------------------------------------------------------------- main

def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("decks", nargs="*", help="decks (default: input/stability/*.yaml)")
    p.add_argument("--out", default=os.path.join(REPO, "output", "stability"))
    p.add_argument("--solvers", nargs="+", default=SOLVERS, choices=SOLVERS)
    p.add_argument("--bin", default=os.environ.get("HYPERQN_BIN", os.path.join(REPO, "build", "hyperqn")))
    p.add_argument("--np", type=int, default=1, help="MPI ranks per run (1: the binary alone, without mpiexec)")
    p.add_argument("--mpiexec", default="mpiexec", help="MPI launcher, used when --np > 1")
    p.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="runs at once")
    p.add_argument("--timeout", type=float, default=600, help="seconds per run")
    p.add_argument("--no-reference", action="store_true", help="skip the converged reference runs")
    args = p.parse_args(argv)

    decks = sorted(args.decks or glob.glob(os.path.join(REPO, "input", "stability", "*.yaml")), key=case_order)
    if not decks:
        sys.exit("no decks")
    if not os.access(args.bin, os.X_OK):
        sys.exit(f"{args.bin}: not an executable (build first: make build)")
    # Every run uses a copy of the binary taken now, so a rebuild during the suite changes nothing.
    os.makedirs(args.out, exist_ok=True)
    binary = os.path.join(args.out, "hyperqn")
    shutil.copy2(args.bin, binary)
    t_start = time.time()
    cases = [case_name(d) for d in decks]
    loaded = {case_name(d): (d, load_yaml(d)) for d in decks}
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
            r = fut.result()
            r["rejected"] = rejection(r["output"]) if r["returncode"] == 1 and not os.path.exists(
                os.path.join(runs_dir, c, s, "summary.json")) else None
            results[(c, s)] = r
            state = ("rejected" if r["rejected"] else "timeout" if r["timed_out"]
                     else f"exit {r['returncode']}")
            print(f"  {c:>18s} {s:<15s} {r['seconds']:6.1f} s  {state}", flush=True)

    rows, meta_refs = [], {}
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
        case_figure(c, analyses, verdicts, align, os.path.join(args.out, f"grad_{c}.png"))

    os.makedirs(args.out, exist_ok=True)
    write_csv(rows, os.path.join(args.out, "stability.csv"))
    verdict_figure(rows, cases, args.solvers, os.path.join(args.out, "verdicts.png"))
    meta = {"ranks": args.np, "date": time.strftime("%Y-%m-%d %H:%M"), "seconds": time.time() - t_start,
            "expect": expect, "descriptions": {c: description(loaded[c][0]) for c in cases}, "references": meta_refs}
    write_markdown(rows, cases, args.solvers, meta, os.path.join(args.out, "stability.md"))

    width = max(len(c) for c in cases)
    print(f"\n{'case':<{width}s} " + " ".join(f"{s:>15s}" for s in args.solvers))
    by = {(r["case"], r["solver"]): r["verdict"] for r in rows}
    for c in cases:
        print(f"{c:<{width}s} " + " ".join(f"{by[(c, s)]:>15s}" for s in args.solvers))
    print(f"\nwrote {os.path.join(args.out, 'stability.md')}, stability.csv, verdicts.png, grad_<case>.png "
          f"({time.time() - t_start:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
