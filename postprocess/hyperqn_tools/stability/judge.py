"""Stability suite, the judgement: what is measured on one run directory (`analyse_run`) and the
verdict drawn from it (`verdict`): ok / degraded / failed / not run."""
import math
import os
import re

import numpy as np

from hyperqn_tools.output import (frame_meshes, frames_of_iterations, read_frames, read_iterations, read_summary,
                                  rest_diagonal)

# Judgement thresholds, as fractions of the rest bounding-box diagonal.
REST_TOL = 1.0e-2   # a case that must settle at its rest shape: RMS distance from it at the last frame
REF_TOL = 5.0e-2    # a case with a converged reference: RMS distance from the reference's last frame
BLOWUP_TOL = 10.0   # any case: farther than this from rest at the last frame = diverged (nothing in
                    # these decks can physically move more than about one diagonal from rest); a
                    # backstop: hyperqn stops a diverging run itself (docs/guardrails.md)
# g may rise by round-off between iterates. g = 1/2 |x - y|_M^2 + h^2 E sums per-element energies of
# size (mu + lambda) V_e h^2 with cancellation (tr F^T F - 3, log J), so its round-off is about
# eps h^2 (mu + lambda) V even where g itself is much smaller. An increase counts when it exceeds
#   MONOTONE_RTOL |g| + MONOTONE_FLOOR * eps * h^2 * S,
# S the largest stiffness times the measure it acts on (energy_scale): of tets max(mu + lambda) times
# the rest bounding-box volume; of a cloth its stiffness (N/m) times the box's largest face; of
# strands axial_stiffness (N) times the box's diagonal.
MONOTONE_RTOL = 1.0e-12
MONOTONE_FLOOR = 100.0


def lame(material):
    """(mu, lambda) of a deck material section."""
    if "mu" in material:
        return float(material["mu"]), float(material["lambda"])
    E, nu = float(material["youngs_modulus"]), float(material["poisson_ratio"])
    return E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))


def bodies_of(deck):
    """The deck's bodies as sections holding their parts (`material` with `regions`, `cloth`,
    `strand_material`): its `bodies`, or the deck itself (one body of `mesh`)."""
    return [b for b in deck.get("bodies") or [] if isinstance(b, dict)] or [deck]


def tet_materials(deck):
    """The material sections of the deck's tets: each body's material and its regions' materials."""
    return [m for body in bodies_of(deck)
            for m in [body.get("material")] + [r.get("material") for r in body.get("regions") or []]
            if isinstance(m, dict)]


def energy_scale(deck, rest_points):
    """S of MONOTONE_FLOOR: the largest stiffness of the deck's parts times the measure it acts on
    (J): tets' mu + lambda times the rest bounding-box volume, a cloth's stiffness (N/m; a membrane's
    plane-stress mu + lambda) times the box's largest face, strands' axial_stiffness times its diagonal."""
    extent = np.sort(rest_points.max(axis=0) - rest_points.min(axis=0))
    volume, face, diagonal = float(np.prod(extent)), float(extent[1] * extent[2]), float(np.linalg.norm(extent))
    scales = [sum(lame(m)) * volume for m in tet_materials(deck)]
    for body in bodies_of(deck):
        cloth, strands = body.get("cloth"), body.get("strand_material")
        if isinstance(cloth, dict):
            if "stretch_stiffness" in cloth:
                k = float(cloth["stretch_stiffness"])
            else:  # a membrane: plane stress's mu + lambda of its stretching modulus E (N/m)
                E, nu = float(cloth["youngs_modulus"]), float(cloth["poisson_ratio"])
                k = E / (2 * (1 + nu)) + E * nu / (1 - nu * nu)
            scales.append(k * face)
        if isinstance(strands, dict):
            scales.append(float(strands["axial_stiffness"]) * diagonal)
    return max(scales, default=0.0)


def energy_roundoff(deck, rest_points):
    """Round-off scale of g for this deck: eps h^2 S (see MONOTONE_FLOOR)."""
    h = float((deck.get("time") or {}).get("dt", 1.0 / 30.0))
    return np.finfo(float).eps * h * h * energy_scale(deck, rest_points)


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
    diag = rest_diagonal(frame)
    if align:
        return kabsch_rms(frame.points - frame.displacement, frame.points) / diag
    return float(np.sqrt(np.mean(np.sum(frame.displacement ** 2, axis=1)))) / diag


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
    for m in frame_meshes(frame_path):
        rest = m.points - m.point_data["displacement"]
        for block in m.cells:
            if block.type != "tetra":
                continue
            p = rest[block.data]
            volumes.append(np.abs(np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]),
                                            p[:, 3] - p[:, 0])) / 6.0)
    if not volumes:
        return None
    materials = tet_materials(deck)
    rest_all = None
    densities = []
    for mat in materials:
        if "density" in mat:
            densities.append(float(mat["density"]))
        else:  # total_mass over the body's volume
            rest_all = np.concatenate(volumes).sum() if rest_all is None else rest_all
            densities.append(float(mat["total_mass"]) / rest_all)  # over every body's tets: a lower bound
    return min(densities) * float(np.concatenate(volumes).min()) / 4.0 if densities else None


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
    # min_J is over tets and cloth triangles: a scene of strands alone has none (+inf, written null)
    measured = ("final_energy", "final_grad_norm") + (("min_J",) if s and (s.get("tets") or s.get("triangles")) else ())
    if s is not None and s.get("frames", 0) > 0 and any(s.get(k, 0) is None for k in measured):
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
    m_min = min_vertex_mass_bound(frames[0][1].path, deck) if frames else None
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
    return frame_distance(A, R) if fa == fr else None


def frame_distance(A, R):
    """RMS distance between two frames of the same mesh (vertices matched by vertex_id) over R's
    rest diagonal, or None if either is missing or their vertices differ."""
    if A is None or R is None or not np.array_equal(A.vertex_id, R.vertex_id):
        return None
    return float(np.sqrt(np.mean(np.sum((A.points - R.points) ** 2, axis=1)))) / rest_diagonal(R)


def largest_reference_distance(a, ref):
    """The largest RMS distance over the rest diagonal between a run and its reference at the frames
    both wrote (vertices matched by vertex_id), or None. The verdict uses the last frame's
    (reference_distance); this one shows a run that is far off in between and back near the
    reference at the end by the phase of a swing."""
    frames = dict(ref["frames"]) if ref else {}
    found = [d for d in (frame_distance(A, frames.get(n)) for n, A in a["frames"]) if d is not None]
    return max(found, default=None)


# hyperqn's exit code for a run that went through every frame with inverted elements
# (src/app/simulation.hpp, kExitInverted).
EXIT_INVERTED = 2


def completed(status):
    """Whether summary.json's status is that of a run that went through every frame: "ok",
    "flagged: ..." (some frames could not decrease g; they count as line-search failures) or
    "inverted: ..." (elements with det F <= 0; judged below)."""
    return status == "ok" or status.startswith(("flagged", "inverted"))


def expected_returncode(status):
    return EXIT_INVERTED if status.startswith("inverted") else 0


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
    if s is None or s.get("status", "").startswith("incomplete"):  # the summary of a run that never ended
        tail = [l for l in run["output"].strip().splitlines() if l.strip()][-1:] or ["no output"]
        return "failed", f"crash (exit code {run['returncode']}): {tail[0][:200]}", rest_error, ref_error
    if not completed(s.get("status", "")):
        return "failed", s.get("status", "no status"), rest_error, ref_error
    if a["nan"]:
        return "failed", "NaN/Inf in " + ", ".join(a["nan"]), rest_error, ref_error
    if a["frames_completed"] < a["expected_frames"]:
        return "failed", f"completed {a['frames_completed']}/{a['expected_frames']} frames", rest_error, ref_error
    if run["returncode"] != expected_returncode(s["status"]):
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
    if s["status"].startswith("inverted"):
        reasons.append(s["status"].split("; flagged")[0])
    elif last is not None and len(last.J) and float(np.min(last.J)) <= 0:
        reasons.append(f"inverted or flat elements in the last frame (min J {float(np.min(last.J)):.3g})")
    if expect == "rest" and rest_error is not None and rest_error > REST_TOL:
        why = f"not back at rest: RMS distance {rest_error:.2e} of the diagonal > {REST_TOL:g}"
        ref_last = last_frame(ref)[1] if ref is not None and reference_ok(ref) else None
        ref_rest = rest_distance(ref_last, align) if ref_last is not None else None
        if ref_rest is not None and ref_rest > REST_TOL:  # the case's expectation, not the solver
            why += f" (so is the converged reference: {ref_rest:.2e})"
        reasons.append(why)
    if expect == "reference" and ref_error is not None and ref_error > REF_TOL:
        reasons.append(f"last frame {ref_error:.2e} of the diagonal from the converged reference > {REF_TOL:g}")
    if reasons:
        return "degraded", "; ".join(reasons), rest_error, ref_error
    return "ok", "", rest_error, ref_error


